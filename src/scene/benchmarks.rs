//! The resting-contact benchmark scenes of docs/benchmarks.md, built exactly as the peer harness
//! builds them so both engines start from the same state: the `pyramid` of unit cubes on a
//! ground slab, and the `rain` of cubes dropped into an open box (hull-rain: of icospheres).

use crate::math::{Scalar, Vector};
use crate::model::components::{Material, Pose, Velocity};
use crate::rng::SplitMix64;
use crate::scene::instantiate::spawn_all;
use crate::scene::spawners::{Instance, box_gas, uniform_rotation};
use crate::scene::{MassSpec, ShapeDef};
use crate::sim::Sim;
use crate::sim::context::Params;
use std::path::Path;

/// A fixed box of the given full size at `position`.
fn slab(name: String, size: Vector, position: Vector, material: Material) -> Instance {
    Instance {
        name,
        shape: ShapeDef::Box { size: (size.x, size.y, size.z) },
        mass: MassSpec::Density(1.0),
        pose: Pose::from_position(position),
        velocity: Velocity::default(),
        material,
        fixed: true,
    }
}

/// A free unit cube of mass 1.
fn cube(name: String, pose: Pose, material: Material) -> Instance {
    Instance {
        name,
        shape: ShapeDef::Box { size: (1.0, 1.0, 1.0) },
        mass: MassSpec::Mass(1.0),
        pose,
        velocity: Velocity::default(),
        material,
        fixed: false,
    }
}

/// The pyramid: `base` rows, row r holding base − r unit cubes at x = j − (base − r − 1)/2,
/// y = 0.5 + r, touching exactly, on a ground slab of half-extents (base/2 + 10, 0.5, 10)
/// centred at (0, −0.5, 0); friction 0.5, restitution 0. The ground comes first, then the
/// cubes row by row (`cube-<i>`).
#[must_use]
pub fn pyramid(base: u32) -> Vec<Instance> {
    let material = Material { restitution: 0.0, friction: 0.5 };
    let half_x = f64::from(base) * 0.5 + 10.0;
    let mut out =
        vec![slab("ground".into(), Vector::new(2.0 * half_x, 1.0, 20.0), Vector::new(0.0, -0.5, 0.0), material)];
    for r in 0..base {
        let count = base - r;
        for j in 0..count {
            let x = f64::from(j) - (f64::from(count) - 1.0) * 0.5;
            let pose = Pose::from_position(Vector::new(x, 0.5 + f64::from(r), 0.0));
            out.push(cube(format!("cube-{}", out.len() - 1), pose, material));
        }
    }
    out
}

/// Height of the rain container's walls [m].
pub const RAIN_WALL_HEIGHT: Scalar = 8.0;

/// Columns per side g of a rain layer for `n` cubes: the smallest g with g² ≥ ⌈n/10⌉.
#[must_use]
pub fn rain_columns(n: u32) -> u32 {
    let per_layer = n.div_ceil(10);
    (0..).find(|g: &u32| u64::from(*g) * u64::from(*g) >= u64::from(per_layer)).unwrap_or(1)
}

/// Inner half-width of the rain container [m]: (g − 1) + 1.5.
#[must_use]
pub fn rain_half_width(n: u32) -> Scalar {
    f64::from(rain_columns(n)) - 1.0 + 1.5
}

/// The shape of the rain's (and the other benchmark scenes') cubes: 1 m on a side.
pub const UNIT_CUBE: ShapeDef = ShapeDef::Box { size: (1.0, 1.0, 1.0) };

/// Radius of hull-rain's icospheres [m].
pub const HULL_RAIN_RADIUS: Scalar = 0.5;

/// Subdivisions of hull-rain's icospheres when `rigid bench hull-rain` is given none.
pub const DEFAULT_HULL_RAIN_SUBDIVISIONS: u32 = 2;

/// The rain: `n` unit cubes in layers of g × g (2 m apart, jittered ±0.1 m, turned uniformly at
/// random; 6 SplitMix64 draws each), the lowest layer at y = 10, over an open box of 8 m walls,
/// 1 m thick, on a floor slab reaching 50 m past the walls; friction 0.5, restitution 0.2.
/// Floor and walls come first, then the cubes (`cube-<i>`).
#[must_use]
pub fn rain(n: u32, seed: u64) -> Vec<Instance> {
    rain_of(n, seed, &UNIT_CUBE)
}

/// The rain of `n` bodies of `shape`: the unit cube gives `rain` exactly (mass 1, `cube-<i>`);
/// any other shape has density 1 kg/m³ and is named after its kind (`icosphere-<i>`, ...).
/// The lattice, jitter, orientations, draws and container are those of `rain` whatever the
/// shape, so shapes wider than about 1.8 m start overlapping their neighbours.
#[must_use]
pub fn rain_of(n: u32, seed: u64, shape: &ShapeDef) -> Vec<Instance> {
    let material = Material { restitution: 0.2, friction: 0.5 };
    let g = rain_columns(n);
    let half_span = f64::from(g) - 1.0;
    let a = rain_half_width(n);
    let (t, hh) = (0.5, RAIN_WALL_HEIGHT * 0.5);
    let floor_half = a + 2.0 * t + 50.0;
    let mut out = vec![slab(
        "floor".into(),
        Vector::new(2.0 * floor_half, 1.0, 2.0 * floor_half),
        Vector::new(0.0, -t, 0.0),
        material,
    )];
    for (s, side) in [(-1.0, '-'), (1.0, '+')] {
        let long = 2.0 * (a + 2.0 * t);
        out.push(slab(
            format!("wall{side}x"),
            Vector::new(1.0, 2.0 * hh, long),
            Vector::new(s * (a + t), hh, 0.0),
            material,
        ));
        out.push(slab(
            format!("wall{side}z"),
            Vector::new(long, 2.0 * hh, 1.0),
            Vector::new(0.0, hh, s * (a + t)),
            material,
        ));
    }
    let mut rng = SplitMix64::new(seed);
    let y0 = RAIN_WALL_HEIGHT + 2.0;
    for i in 0..n {
        let (ix, iz, iy) = (f64::from(i % g), f64::from((i / g) % g), f64::from(i / (g * g)));
        let j = Vector::new(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1));
        let u = Vector::new(rng.unit(), rng.unit(), rng.unit());
        let position = Vector::new(ix * 2.0 - half_span + j.x, y0 + iy * 2.0 + j.y, iz * 2.0 - half_span + j.z);
        let pose = Pose { position, orientation: uniform_rotation(u) };
        out.push(if *shape == UNIT_CUBE {
            cube(format!("cube-{i}"), pose, material)
        } else {
            Instance {
                name: format!("{}-{i}", kind(shape)),
                shape: shape.clone(),
                mass: MassSpec::Density(1.0),
                pose,
                velocity: Velocity::default(),
                material,
                fixed: false,
            }
        });
    }
    out
}

/// A shape's kind in lower case, as it names actors.
fn kind(shape: &ShapeDef) -> &'static str {
    match shape {
        ShapeDef::Box { .. } => "box",
        ShapeDef::Tetrahedron { .. } => "tetrahedron",
        ShapeDef::Octahedron { .. } => "octahedron",
        ShapeDef::Icosphere { .. } => "icosphere",
        ShapeDef::Cylinder { .. } => "cylinder",
        ShapeDef::Obj { .. } => "obj",
    }
}

/// The benchmark scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchScene {
    /// Unit cubes in a closed box, no gravity, e = 1 (size = cubes).
    BoxGas,
    /// A pyramid of cubes on the ground (size = cubes in the base row).
    Pyramid,
    /// Cubes dropped into an open box (size = cubes).
    Rain,
    /// The rain with icospheres of radius 0.5 m and density 1 kg/m³ instead of cubes
    /// (size = bodies).
    HullRain {
        /// Subdivisions of the icosahedron, 0..=5 (S = 1 has 42 vertices, S = 2 has 162).
        subdivisions: u32,
    },
    /// Boxes of 0.2 × 0.6 × 0.2 m on a 2 m lattice, each hung from the world by a ball joint at
    /// its top end and let go 30° from hanging (`jointed`), or the same boxes falling free:
    /// what joints cost against the same bodies without them (size = boxes).
    Pendulums {
        /// Joints on (`pendulums`) or off (`free-boxes`).
        jointed: bool,
    },
}

/// The pendulums scene (see `BenchScene::Pendulums`) as scene text: `n` boxes on a square
/// lattice 2 m apart, each turned 30° about z, hung at the end that was on top.
#[must_use]
pub fn pendulums_text(n: u32, jointed: bool) -> String {
    let side = (1..).find(|k: &u32| k * k >= n).unwrap_or(1);
    let (half, angle) = (0.3, 30f64.to_radians());
    let (mut actors, mut joints) = (String::new(), String::new());
    for i in 0..n {
        let (x, z) = (f64::from(i % side) * 2.0, f64::from(i / side) * 2.0);
        // The pivot at (x, 2, z); the box's centre half its length below it, swung 30°.
        let (cx, cy) = (x + half * angle.sin(), 2.0 - half * angle.cos());
        actors += &format!(
            "Actor(name: \"bob-{i}\", shape: Box(size: (0.2, 0.6, 0.2)), mass: 1.0, position: ({cx}, {cy}, {z}), rotation: (0.0, 0.0, 30.0)),\n"
        );
        if jointed {
            joints += &format!("Ball(a: \"bob-{i}\", anchor: ({x}, 2.0, {z})),\n");
        }
    }
    format!("Scene(dt: 0.016666666666666666, actors: [\n{actors}], joints: [\n{joints}])")
}

impl BenchScene {
    /// The scene `rigid bench` calls `name` (hull-rain's icospheres of `subdivisions`), or
    /// `None` for a name it does not know.
    #[must_use]
    pub fn named(name: &str, subdivisions: u32) -> Option<Self> {
        Some(match name {
            "box-gas" => Self::BoxGas,
            "pyramid" => Self::Pyramid,
            "rain" => Self::Rain,
            "hull-rain" => Self::HullRain { subdivisions },
            "pendulums" => Self::Pendulums { jointed: true },
            "free-boxes" => Self::Pendulums { jointed: false },
            _ => return None,
        })
    }

    /// The scene's name in output.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::BoxGas => "box-gas",
            Self::Pyramid => "pyramid",
            Self::Rain => "rain",
            Self::HullRain { .. } => "hull-rain",
            Self::Pendulums { jointed: true } => "pendulums",
            Self::Pendulums { jointed: false } => "free-boxes",
        }
    }

    /// The actors of the scene of this size.
    pub fn instances(self, size: u32, seed: u64) -> Vec<Instance> {
        match self {
            Self::BoxGas => box_gas(size, seed),
            Self::Pyramid => pyramid(size),
            Self::Rain => rain(size, seed),
            Self::HullRain { subdivisions } => {
                rain_of(size, seed, &ShapeDef::Icosphere { radius: HULL_RAIN_RADIUS, subdivisions })
            }
            // Built from scene text (`scene_sim`): joints come with the scene, not as instances.
            Self::Pendulums { .. } => Vec::new(),
        }
    }

    /// Which actor indices are the cubes (hull-rain: the icospheres): box-gas puts its 6 walls
    /// after them, the others their ground (1) or floor and walls (5) before, as the peer
    /// harness does.
    pub fn cubes(self, actors: usize) -> std::ops::Range<usize> {
        match self {
            Self::BoxGas => 0..actors - 6,
            Self::Pyramid => 1..actors,
            Self::Rain | Self::HullRain { .. } => 5..actors,
            Self::Pendulums { .. } => 0..actors,
        }
    }
}

/// The box-gas simulation of docs/benchmarks.md with `n` cubes (walls after the cubes), no gravity,
/// dt = 1/60, the default schedule.
#[must_use]
pub fn box_gas_sim(n: u32, seed: u64) -> Sim {
    scene_sim(BenchScene::BoxGas, n, seed)
}

/// A benchmark scene as a simulation: dt = 1/60, gravity −9.81 but none for box-gas.
#[must_use]
pub fn scene_sim(scene: BenchScene, size: u32, seed: u64) -> Sim {
    if let BenchScene::Pendulums { jointed } = scene {
        let (text, path) = (pendulums_text(size, jointed), Path::new(scene.name()));
        let def = crate::scene::parse(&text, path).expect("the pendulums scene is valid");
        return crate::scene::build(&def, path).expect("the pendulums scene builds");
    }
    let gravity = if scene == BenchScene::BoxGas { Vector::ZERO } else { Vector::new(0.0, -9.81, 0.0) };
    let mut sim = Sim::new(1.0 / 60.0, Params { gravity, ..Params::default() }, crate::systems::default_schedule());
    spawn_all(&mut sim, &scene.instances(size, seed), Path::new(scene.name())).expect("benchmark scenes are valid");
    sim
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_scene_is_found_by_its_name() {
        let all = [
            BenchScene::BoxGas,
            BenchScene::Pyramid,
            BenchScene::Rain,
            BenchScene::HullRain { subdivisions: 3 },
            BenchScene::Pendulums { jointed: true },
            BenchScene::Pendulums { jointed: false },
        ];
        for scene in all {
            assert_eq!(BenchScene::named(scene.name(), 3), Some(scene));
        }
        assert_eq!(BenchScene::named("box_gas", 3), None);
    }

    #[test]
    fn pyramid_rows_touch_and_are_centred() {
        let p = pyramid(3);
        assert_eq!(p.len(), 1 + 3 + 2 + 1);
        let xs: Vec<f64> = p[1..4].iter().map(|c| c.pose.position.x).collect();
        assert_eq!(xs, [-1.0, 0.0, 1.0]);
        assert_eq!(p[4].pose.position, Vector::new(-0.5, 1.5, 0.0));
        assert_eq!(p[6].pose.position, Vector::new(0.0, 2.5, 0.0));
    }

    #[test]
    fn rain_layers_match_the_peer_harness() {
        // n = 1000: 100 per layer, g = 10 columns, inner half-width 10.5 m, 10 layers.
        assert_eq!((rain_columns(1000), rain_half_width(1000)), (10, 10.5));
        let r = rain(1000, 1);
        assert_eq!(r.len(), 5 + 1000);
        let top = r.iter().map(|c| c.pose.position.y).fold(f64::MIN, f64::max);
        assert!((28.0 - 0.1..28.1).contains(&top), "top layer at 10 + 9·2 m, got {top}");
    }
}
