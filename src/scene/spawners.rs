//! Spawners: a few lines of scene that expand into many actors (docs/scenes.md), seeded
//! through `rng.rs`, never from system entropy. The box-gas scene of docs/benchmarks.md exists once,
//! here, and serves the `BoxGas` spawner, `rigid bench`, the benches and the tests.

use crate::math::{Quat, Scalar, Vector, from_euler_degrees};
use crate::model::components::{Material, Pose, Velocity};
use crate::rng::SplitMix64;
use crate::scene::{ActorDef, MassSpec, ShapeDef, V3, vector};
use serde::Deserialize;

/// Most actors a scene may hold after expansion: a clear limit instead of running out of
/// memory on a typo (64 000 is the largest benchmark).
pub const MAX_ACTORS: u64 = 1_000_000;

/// A generator of actors.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum SpawnerDef {
    /// `counts.x × counts.y × counts.z` copies of `actor`, x fastest; copy (i, j, k) stands at
    /// `actor.position + (i·spacing.x, j·spacing.y, k·spacing.z)`.
    Grid {
        /// The template (its name, if any, prefixes the copies' names).
        actor: ActorDef,
        /// Copies along x, y, z.
        counts: (u32, u32, u32),
        /// Distance between neighbours [m].
        spacing: V3,
    },
    /// `count` copies of `actor` on a jittered cubic lattice centred on `actor.position`,
    /// with random orientation (uniform on SO(3)), velocity in [−speed, speed)³ and angular
    /// velocity in [−spin, spin)³: the box-gas layout with free parameters.
    Random {
        /// The template.
        actor: ActorDef,
        /// How many.
        count: u32,
        /// SplitMix64 seed (default 1).
        #[serde(default = "one")]
        seed: u64,
        /// Lattice spacing [m].
        spacing: Scalar,
        /// Position jitter, each axis in [−jitter, jitter) [m] (default 0).
        #[serde(default)]
        jitter: Scalar,
        /// Speed bound per axis [m/s] (default 0).
        #[serde(default)]
        speed: Scalar,
        /// Spin bound per axis [rad/s] (default 0).
        #[serde(default)]
        spin: Scalar,
    },
    /// The pyramid benchmark scene of docs/benchmarks.md: `base` rows of unit cubes on a ground.
    Pyramid {
        /// Cubes in the bottom row.
        base: u32,
    },
    /// The rain benchmark scene of docs/benchmarks.md: `actors` bodies dropped into an open box,
    /// unit cubes of mass 1 unless `shape` says otherwise.
    Rain {
        /// Number of bodies.
        actors: u32,
        /// SplitMix64 seed (default 1).
        #[serde(default = "one")]
        seed: u64,
        /// Shape of the bodies (default the unit cube, mass 1 kg); any other shape has density
        /// 1 kg/m³. Same lattice, jitter, orientations and container whatever the shape.
        #[serde(default = "unit_cube")]
        shape: ShapeDef,
    },
    /// The box-gas benchmark scene of docs/benchmarks.md: `actors` unit cubes in a closed box.
    BoxGas {
        /// Number of cubes.
        actors: u32,
        /// SplitMix64 seed (default 1).
        #[serde(default = "one")]
        seed: u64,
    },
}

fn one() -> u64 {
    1
}

fn unit_cube() -> ShapeDef {
    crate::scene::benchmarks::UNIT_CUBE
}

/// One actor ready to build: a shape, mass, pose, velocities and material.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Unique name.
    pub name: String,
    /// Shape.
    pub shape: ShapeDef,
    /// Mass or density.
    pub mass: MassSpec,
    /// Initial pose.
    pub pose: Pose,
    /// Initial velocities.
    pub velocity: Velocity,
    /// Restitution and friction.
    pub material: Material,
    /// Never moves.
    pub fixed: bool,
}

impl Instance {
    /// The instance an actor definition describes, named `name`.
    #[must_use]
    pub fn from_def(def: &ActorDef, name: String) -> Self {
        Self {
            name,
            shape: def.shape.clone(),
            mass: def.mass,
            pose: Pose { position: def.position, orientation: from_euler_degrees(def.rotation) },
            velocity: Velocity { linear: def.velocity, angular: def.angular_velocity },
            material: Material { restitution: def.restitution, friction: def.friction },
            fixed: def.fixed,
        }
    }
}

impl SpawnerDef {
    /// How many actors it makes (u64: no overflow on absurd counts).
    #[must_use]
    pub fn count(&self) -> u64 {
        match self {
            Self::Grid { counts: (x, y, z), .. } => u64::from(*x) * u64::from(*y) * u64::from(*z),
            Self::Random { count, .. } => u64::from(*count),
            Self::BoxGas { actors, .. } => u64::from(*actors) + 6,
            Self::Pyramid { base } => u64::from(*base) * (u64::from(*base) + 1) / 2 + 1,
            Self::Rain { actors, .. } => u64::from(*actors) + 5,
        }
    }

    /// Checks the parameters; `Err((field, reason))`.
    pub fn check(&self) -> Result<(), (String, String)> {
        let finite_nonneg = |field: &str, v: Scalar| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err((field.to_string(), format!("must be a finite number >= 0, got {v}")))
            }
        };
        match self {
            Self::Grid { spacing, .. } => {
                let s = vector(*spacing);
                if crate::math::is_finite_vector(s) { Ok(()) } else { Err(("spacing".into(), "must be finite".into())) }
            }
            Self::Random { spacing, jitter, speed, spin, .. } => {
                if !(spacing.is_finite() && *spacing > 0.0) {
                    return Err(("spacing".into(), format!("must be a finite number > 0 m, got {spacing}")));
                }
                finite_nonneg("jitter", *jitter)?;
                finite_nonneg("speed", *speed)?;
                finite_nonneg("spin", *spin)
            }
            Self::Rain { shape, .. } => shape.check(),
            Self::BoxGas { .. } | Self::Pyramid { .. } => Ok(()),
        }
    }

    /// The actors, in spawn order. `prefix` names them when the template has no name.
    #[must_use]
    pub fn expand(&self, prefix: &str) -> Vec<Instance> {
        match self {
            Self::Grid { actor, counts: (nx, ny, nz), spacing } => {
                let name = actor.name.as_deref().unwrap_or(prefix);
                let mut out = Vec::with_capacity(self.count() as usize);
                for k in 0..*nz {
                    for j in 0..*ny {
                        for i in 0..*nx {
                            let offset = Vector::new(f64::from(i), f64::from(j), f64::from(k)) * vector(*spacing);
                            let mut inst = Instance::from_def(actor, format!("{name}-{}", out.len()));
                            inst.pose.position += offset;
                            out.push(inst);
                        }
                    }
                }
                out
            }
            Self::Random { actor, count, seed, spacing, jitter, speed, spin } => {
                let name = actor.name.as_deref().unwrap_or(prefix);
                let lattice = Lattice {
                    count: *count,
                    seed: *seed,
                    spacing: *spacing,
                    jitter: *jitter,
                    speed: *speed,
                    spin: *spin,
                };
                lattice
                    .place(actor.position)
                    .into_iter()
                    .enumerate()
                    .map(|(i, (pose, velocity))| Instance {
                        pose,
                        velocity,
                        ..Instance::from_def(actor, format!("{name}-{i}"))
                    })
                    .collect()
            }
            Self::BoxGas { actors, seed } => box_gas(*actors, *seed),
            Self::Pyramid { base } => crate::scene::benchmarks::pyramid(*base),
            Self::Rain { actors, seed, shape } => crate::scene::benchmarks::rain_of(*actors, *seed, shape),
        }
    }
}

/// The random lattice of `Random` and box-gas (docs/benchmarks.md): cube i in cell
/// (i mod k, (i div k) mod k, i div k²), k = ⌈∛count⌉, twelve draws per cube in the order
/// jitter (3), orientation (3), velocity (3), angular velocity (3).
struct Lattice {
    count: u32,
    seed: u64,
    spacing: Scalar,
    jitter: Scalar,
    speed: Scalar,
    spin: Scalar,
}

impl Lattice {
    fn place(&self, centre: Vector) -> Vec<(Pose, Velocity)> {
        let k = cube_side(self.count);
        let half = (Scalar::from(k) - 1.0) / 2.0;
        let mut rng = SplitMix64::new(self.seed);
        (0..self.count)
            .map(|i| {
                let cell = Vector::new(f64::from(i % k), f64::from((i / k) % k), f64::from(i / (k * k)));
                let mut draw3 = |lo: Scalar, hi: Scalar| {
                    let x = rng.uniform(lo, hi);
                    let y = rng.uniform(lo, hi);
                    Vector::new(x, y, rng.uniform(lo, hi))
                };
                let jitter = draw3(-self.jitter, self.jitter);
                let u = draw3(0.0, 1.0);
                let velocity = draw3(-self.speed, self.speed);
                let angular = draw3(-self.spin, self.spin);
                let position = centre + (self.spacing * (cell - Vector::splat(half)) + jitter);
                let pose = Pose { position, orientation: uniform_rotation(u) };
                (pose, Velocity { linear: velocity, angular })
            })
            .collect()
    }
}

/// Smallest k with k³ ≥ n.
#[must_use]
pub fn cube_side(n: u32) -> u32 {
    let mut k = (f64::from(n)).cbrt().round() as u32;
    while u64::from(k).pow(3) < u64::from(n) {
        k += 1;
    }
    while k > 0 && u64::from(k - 1).pow(3) >= u64::from(n) {
        k -= 1;
    }
    k
}

/// Uniform rotation from three uniforms (docs/benchmarks.md): q = (x, y, z, w) =
/// (√(1−u1) sin 2πu2, √(1−u1) cos 2πu2, √u1 sin 2πu3, √u1 cos 2πu3).
#[must_use]
pub fn uniform_rotation(u: Vector) -> Quat {
    let tau = std::f64::consts::TAU;
    let (a, b) = ((1.0 - u.x).sqrt(), u.x.sqrt());
    Quat::from_xyzw(a * (tau * u.y).sin(), a * (tau * u.y).cos(), b * (tau * u.z).sin(), b * (tau * u.z).cos())
}

/// Inner half-extent of box-gas's closed box for `n` cubes: k + 0.5.
#[must_use]
pub fn box_gas_half_extent(n: u32) -> Scalar {
    f64::from(cube_side(n)) + 0.5
}

/// The box-gas scene of docs/benchmarks.md: `n` unit cubes (mass 1, restitution 1, no friction)
/// on the seeded lattice, then six fixed walls 1 m thick closing the box.
#[must_use]
pub fn box_gas(n: u32, seed: u64) -> Vec<Instance> {
    let cube = Instance {
        name: String::new(),
        shape: ShapeDef::Box { size: (1.0, 1.0, 1.0) },
        mass: MassSpec::Mass(1.0),
        pose: Pose::IDENTITY,
        velocity: Velocity::default(),
        material: Material { restitution: 1.0, friction: 0.0 },
        fixed: false,
    };
    let lattice = Lattice { count: n, seed, spacing: 2.0, jitter: 0.1, speed: 2.0, spin: 1.0 };
    let mut out: Vec<Instance> = lattice
        .place(Vector::ZERO)
        .into_iter()
        .enumerate()
        .map(|(i, (pose, velocity))| Instance { name: format!("cube-{i}"), pose, velocity, ..cube.clone() })
        .collect();
    let a = box_gas_half_extent(n);
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut size = Vector::splat(2.0 * (a + 1.0));
            size[axis] = 1.0;
            let mut position = Vector::ZERO;
            position[axis] = sign * (a + 0.5);
            let name = format!("wall{}{}", if sign < 0.0 { '-' } else { '+' }, ['x', 'y', 'z'][axis]);
            let shape = ShapeDef::Box { size: (size.x, size.y, size.z) };
            out.push(Instance { name, shape, pose: Pose::from_position(position), fixed: true, ..cube.clone() });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_gas_matches_the_check_values_of_benchmarks_md() {
        let cubes = box_gas(1000, 1);
        assert_eq!(cube_side(1000), 10);
        assert_eq!([cube_side(4000), cube_side(16000), cube_side(64000)], [16, 26, 40]);
        let c0 = &cubes[0];
        // The check values were printed from rapier's f32 state: ~1e-6 absolute at |x| ≈ 9.
        let close = |a: Vector, b: [f64; 3]| (a - Vector::from_array(b)).abs().max_element() < 1e-6;
        assert!(close(c0.pose.position, [-8.986688, -8.950844, -8.905800]), "{}", c0.pose.position);
        let q = c0.pose.orientation;
        assert!(
            (Vector::new(q.x, q.y, q.z) - Vector::new(0.2557372, -0.7001709, -0.6644162)).abs().max_element() < 5e-8
        );
        assert!((q.w - 0.0539477).abs() < 5e-8);
        assert!(close(c0.velocity.linear, [1.5093948, 0.0922687, -0.8579653]));
        assert!(close(c0.velocity.angular, [0.5879932, -0.1917157, 0.2108407]));
        assert!(close(cubes[1].pose.position, [-7.009012, -8.993984, -9.012807]));
        assert_eq!(cubes.len(), 1006);
        assert!(cubes[1000..].iter().all(|w| w.fixed));
    }

    #[test]
    fn shape_checks_agree_with_the_actor_checks() {
        // A spawner's shape is judged as an actor's (the same check): same verdict, field, reason.
        let shapes = [
            "Box(size: (1.0, 2.0, 3.0))",
            "Box(size: (1.0, 0.0, 3.0))",
            "Box(size: (1.0, 2.0, inf))",
            "Box(size: (-1.0, 2.0, 3.0))",
            "Tetrahedron(edge: 1.0)",
            "Tetrahedron(edge: NaN)",
            "Octahedron(radius: 0.5)",
            "Octahedron(radius: 0.0)",
            "Icosphere(radius: 0.5, subdivisions: 5)",
            "Icosphere(radius: -1.0, subdivisions: 1)",
            "Icosphere(radius: 0.5, subdivisions: 6)",
            "Cylinder(radius: 0.5, height: 1.0, segments: 3)",
            "Cylinder(radius: 0.5, height: 1.0, segments: 2)",
            "Cylinder(radius: 0.5, height: 1.0, segments: 257)",
            "Cylinder(radius: 0.5, height: -1.0, segments: 8)",
            "Cylinder(radius: 0.0, height: 1.0, segments: 8)",
            "Obj(path: \"a.obj\")",
            "Obj(path: \"\")",
            "Obj(path: \"a.obj\", scale: 0.0)",
        ];
        let options = crate::scene::ron_options();
        for shape in shapes {
            let actor = options.from_str::<ActorDef>(&format!("Actor(shape: {shape})")).map_err(|e| e.code.to_string());
            let rain: SpawnerDef = options.from_str(&format!("Rain(actors: 1, shape: {shape})")).expect("parses");
            let spawner = rain.check().map_err(|(field, reason)| format!("actor: {field}: {reason}"));
            assert_eq!(actor.map(|_| ()), spawner, "{shape}");
        }
    }

    #[test]
    fn rain_takes_any_shape_at_density_1_and_defaults_to_the_unit_cube() {
        let options = crate::scene::ron_options();
        let parse = |text: &str| options.from_str::<SpawnerDef>(text).expect("parses");
        let cubes = parse("Rain(actors: 12, seed: 5)");
        assert_eq!(cubes, parse("Rain(actors: 12, seed: 5, shape: Box(size: (1.0, 1.0, 1.0)))"));
        assert_eq!(cubes.expand("x"), crate::scene::benchmarks::rain(12, 5));
        let balls = parse("Rain(actors: 12, seed: 5, shape: Icosphere(radius: 0.5, subdivisions: 1))").expand("x");
        let cubes = cubes.expand("x");
        assert_eq!(balls.len(), cubes.len());
        assert_eq!(balls[..5], cubes[..5], "the same container");
        for (b, c) in balls[5..].iter().zip(&cubes[5..]) {
            assert_eq!((b.pose, b.velocity, b.material, b.fixed), (c.pose, c.velocity, c.material, c.fixed));
            assert_eq!(
                (&b.shape, b.mass),
                (&ShapeDef::Icosphere { radius: 0.5, subdivisions: 1 }, MassSpec::Density(1.0))
            );
        }
        assert_eq!((cubes[5].name.as_str(), balls[5].name.as_str()), ("cube-0", "icosphere-0"));
    }
}
