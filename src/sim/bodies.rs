//! `Bodies`: the per-step snapshot of every actor's components as plain arrays (row = the
//! actor's `ActorIndex`). Pair loops read these, never the world, so they hold no hecs borrows
//! and are plain data that threads can share (ARCHITECTURE.md).

use crate::math::{Mat3, Quat, Scalar, Vector, world_inverse_inertia};
use crate::model::components::{ActorIndex, BoundingSphere, MassProps, Material, Mesh, Pose, Velocity};
use crate::model::mesh::{MeshId, MeshTable};
use hecs::{Entity, World};

/// Structure of arrays, one row per actor.
#[derive(Clone, Debug, Default)]
pub struct Bodies {
    /// The actor's entity in the world.
    pub entity: Vec<Entity>,
    /// Centre of mass [m].
    pub position: Vec<Vector>,
    /// Body → world rotation.
    pub orientation: Vec<Quat>,
    /// The same rotation as a matrix for the pair loops, kept with `orientation`: a system
    /// that turns a body sets both, and `inv_inertia_world` (as `integrate` and `ccd` do).
    pub rotation: Vec<Mat3>,
    /// Linear velocity [m/s].
    pub velocity: Vec<Vector>,
    /// Angular velocity, world frame [rad/s].
    pub angular_velocity: Vec<Vector>,
    /// 1/m, 0 for fixed actors [1/kg].
    pub inv_mass: Vec<Scalar>,
    /// Principal moments [kg·m²].
    pub principal_moments: Vec<Vector>,
    /// Principal frame → body frame.
    pub principal_axes: Vec<Quat>,
    /// Body-frame inverse inertia, zero for fixed actors.
    pub inv_inertia_body: Vec<Mat3>,
    /// World-frame inverse inertia R I⁻¹ Rᵀ at the snapshot's orientation (docs/physics.md E9).
    pub inv_inertia_world: Vec<Mat3>,
    /// Bounding-sphere radius [m].
    pub radius: Vec<Scalar>,
    /// Mesh of each actor.
    pub mesh: Vec<MeshId>,
    /// Restitution.
    pub restitution: Vec<Scalar>,
    /// Friction coefficient.
    pub friction: Vec<Scalar>,
}

/// The components one row is read from.
type Row<'a> =
    (Entity, &'a ActorIndex, &'a Pose, &'a Velocity, &'a MassProps, &'a Material, &'a BoundingSphere, &'a Mesh);

impl Bodies {
    /// Number of rows.
    #[must_use]
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// True when there are no actors.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// True for a fixed actor's row.
    #[must_use]
    pub fn is_fixed(&self, i: usize) -> bool {
        self.inv_mass[i] == 0.0
    }

    /// A pair's friction coefficient: the mean of its two actors' (docs/scenes.md).
    #[must_use]
    pub fn pair_friction(&self, a: usize, b: usize) -> Scalar {
        0.5 * (self.friction[a] + self.friction[b])
    }

    /// The thickness of the thinner of two bodies [m]: slops, margins and caps of the contact
    /// stages scale with it.
    #[must_use]
    pub fn thinner(&self, meshes: &MeshTable, a: usize, b: usize) -> Scalar {
        meshes.get(self.mesh[a]).thickness.min(meshes.get(self.mesh[b]).thickness)
    }

    /// Copies every actor's components into the arrays, reusing their allocations. Actor
    /// indices must be `0..n` (the `Sim` guarantees it).
    pub fn load(&mut self, world: &World) {
        let n = world.query::<&ActorIndex>().iter().count();
        // With other threads, most values are last step's to the bit and are left unwritten:
        // a line those threads read (or wrote) last step is then not taken back from them.
        let compare = rayon::current_num_threads() > 1;
        // And each part of the rows is read on a thread of its own, by the entities they held
        // last step, as `integrate` split them: a row is mostly read where it was last written.
        if compare && n == self.len() && n >= 2 * LOAD_CHUNK && load_part(world, self.rows(), 0) {
            return;
        }
        self.resize(n);
        let mut rows = self.rows();
        for (entity, index, pose, vel, mass, material, sphere, mesh) in world.query::<Row>().iter() {
            let i = index.0 as usize;
            put(&mut rows.entity[i], entity, compare);
            rows.put(i, (pose, vel, mass, material, sphere, mesh), compare);
        }
    }

    /// Every array, as one set of slices (`RowsMut`).
    fn rows(&mut self) -> RowsMut<'_> {
        RowsMut {
            entity: &mut self.entity,
            position: &mut self.position,
            orientation: &mut self.orientation,
            rotation: &mut self.rotation,
            velocity: &mut self.velocity,
            angular_velocity: &mut self.angular_velocity,
            inv_mass: &mut self.inv_mass,
            principal_moments: &mut self.principal_moments,
            principal_axes: &mut self.principal_axes,
            inv_inertia_body: &mut self.inv_inertia_body,
            inv_inertia_world: &mut self.inv_inertia_world,
            radius: &mut self.radius,
            mesh: &mut self.mesh,
            restitution: &mut self.restitution,
            friction: &mut self.friction,
        }
    }

    /// Writes poses and velocities back to the world, so world and arrays agree again.
    pub fn store(&self, world: &mut World) {
        for (index, pose, vel) in world.query_mut::<(&ActorIndex, &mut Pose, &mut Velocity)>() {
            let i = index.0 as usize;
            pose.position = self.position[i];
            pose.orientation = self.orientation[i];
            vel.linear = self.velocity[i];
            vel.angular = self.angular_velocity[i];
        }
    }

    /// The first row and field holding a NaN or infinity, if any (the NaN guard).
    #[must_use]
    pub fn first_non_finite(&self) -> Option<(usize, &'static str)> {
        // Velocities first: a blow-up starts there and reaches positions in the same step.
        let vectors =
            [("velocity", &self.velocity), ("angular_velocity", &self.angular_velocity), ("position", &self.position)];
        // Cheap pass first (`all_finite`); the search below runs only on failure.
        let finite = all_finite(&self.velocity, |v| v.to_array())
            && all_finite(&self.angular_velocity, |w| w.to_array())
            && all_finite(&self.position, |x| x.to_array())
            && all_finite(&self.orientation, |q| q.to_array());
        if finite {
            return None;
        }
        (0..self.len()).find_map(|i| {
            vectors
                .iter()
                .find(|(_, v)| !crate::math::is_finite_vector(v[i]))
                .map(|(name, _)| (i, *name))
                .or_else(|| (!self.orientation[i].is_finite()).then_some((i, "orientation")))
        })
    }

    fn resize(&mut self, n: usize) {
        self.entity.resize(n, Entity::DANGLING);
        self.position.resize(n, Vector::ZERO);
        self.orientation.resize(n, Quat::IDENTITY);
        self.rotation.resize(n, Mat3::IDENTITY);
        self.velocity.resize(n, Vector::ZERO);
        self.angular_velocity.resize(n, Vector::ZERO);
        self.inv_mass.resize(n, 0.0);
        self.inv_inertia_body.resize(n, Mat3::ZERO);
        self.principal_moments.resize(n, Vector::ZERO);
        self.principal_axes.resize(n, Quat::IDENTITY);
        self.inv_inertia_world.resize(n, Mat3::ZERO);
        self.radius.resize(n, 0.0);
        self.mesh.resize(n, MeshId(0));
        self.restitution.resize(n, 0.0);
        self.friction.resize(n, 0.0);
    }
}

/// Fewest rows a thread loads on its own (`load_part`).
const LOAD_CHUNK: usize = 256;

/// Loads `rows` (row `first` onwards) from the world, by the entity each row held: in halves
/// on two threads down to `LOAD_CHUNK` rows. False if some row's entity is gone or is no longer
/// that row's actor (then `load` reads the world afresh; the rows written so far hold their
/// actors' values, as a full load would leave them).
fn load_part(world: &World, mut rows: RowsMut, first: usize) -> bool {
    let len = rows.entity.len();
    if len >= 2 * LOAD_CHUNK {
        let mid = len / 2;
        let (low, high) = rows.split_at(mid);
        let (a, b) = rayon::join(|| load_part(world, low, first), || load_part(world, high, first + mid));
        return a && b;
    }
    let view = world.view::<Row>();
    for k in 0..len {
        match view.get(rows.entity[k]) {
            Some((_, index, pose, vel, mass, material, sphere, mesh)) if index.0 as usize == first + k => {
                rows.put(k, (pose, vel, mass, material, sphere, mesh), true);
            }
            _ => return false,
        }
    }
    true
}

/// The arrays of a run of rows, to load them (`Bodies::load`).
struct RowsMut<'a> {
    entity: &'a mut [Entity],
    position: &'a mut [Vector],
    orientation: &'a mut [Quat],
    rotation: &'a mut [Mat3],
    velocity: &'a mut [Vector],
    angular_velocity: &'a mut [Vector],
    inv_mass: &'a mut [Scalar],
    principal_moments: &'a mut [Vector],
    principal_axes: &'a mut [Quat],
    inv_inertia_body: &'a mut [Mat3],
    inv_inertia_world: &'a mut [Mat3],
    radius: &'a mut [Scalar],
    mesh: &'a mut [MeshId],
    restitution: &'a mut [Scalar],
    friction: &'a mut [Scalar],
}

/// A row's components, but its entity and actor index.
type RowValues<'a> = (&'a Pose, &'a Velocity, &'a MassProps, &'a Material, &'a BoundingSphere, &'a Mesh);

impl RowsMut<'_> {
    /// Rows `..mid` and `mid..`.
    fn split_at(self, mid: usize) -> (Self, Self) {
        // Every field split alike; the struct literals name each, so none can be left out.
        macro_rules! split {
            ($($field:ident),*) => {{
                let RowsMut { $($field),* } = self;
                $(let $field = $field.split_at_mut(mid);)*
                (RowsMut { $($field: $field.0),* }, RowsMut { $($field: $field.1),* })
            }};
        }
        split!(
            entity,
            position,
            orientation,
            rotation,
            velocity,
            angular_velocity,
            inv_mass,
            principal_moments,
            principal_axes,
            inv_inertia_body,
            inv_inertia_world,
            radius,
            mesh,
            restitution,
            friction
        )
    }

    /// Row `i` from its actor's components (`put` with `compare`).
    fn put(&mut self, i: usize, (pose, vel, mass, material, sphere, mesh): RowValues, compare: bool) {
        // `integrate` left the rotation and world inverse inertia of the pose it stored:
        // worked out again only where the world's orientation or inertia is not that one.
        let same = self.orientation[i] == pose.orientation && self.inv_inertia_body[i] == mass.inv_inertia;
        put(&mut self.position[i], pose.position, compare);
        put(&mut self.orientation[i], pose.orientation, compare);
        put(&mut self.velocity[i], vel.linear, compare);
        put(&mut self.angular_velocity[i], vel.angular, compare);
        put(&mut self.inv_mass[i], mass.inv_mass, compare);
        put(&mut self.inv_inertia_body[i], mass.inv_inertia, compare);
        put(&mut self.principal_moments[i], mass.principal_moments, compare);
        put(&mut self.principal_axes[i], mass.principal_axes, compare);
        if !same {
            self.rotation[i] = Mat3::from_quat(pose.orientation);
            self.inv_inertia_world[i] = rotate_tensor(pose.orientation, mass.inv_inertia);
        }
        put(&mut self.radius[i], sphere.radius, compare);
        put(&mut self.mesh[i], mesh.id, compare);
        put(&mut self.restitution[i], material.restitution, compare);
        put(&mut self.friction[i], material.friction, compare);
    }
}

/// A body-frame tensor in world axes, R M Rᵀ (inertia or inverse inertia, docs/physics.md E9),
/// skipping the two products when M is a multiple of the identity (cubes, regular
/// tetrahedra, spheres), where rotation cannot change it: the exact value, without the
/// products' rounding noise, and cheaper for box-gas's 64 000 cubes.
#[must_use]
pub fn rotate_tensor(orientation: Quat, m: Mat3) -> Mat3 {
    let isotropic = m.x_axis.x == m.y_axis.y
        && m.y_axis.y == m.z_axis.z
        && [m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.z, m.z_axis.x, m.z_axis.y].iter().all(|&x| x == 0.0);
    if isotropic { m } else { world_inverse_inertia(orientation, m) }
}

/// True when every component `parts` gives of every item is finite. Each component times
/// zero is zero when finite and NaN otherwise, and a sum of zeros cannot overflow, so the sums
/// are zero exactly when all are finite. The guard runs after most systems: the sums go in
/// four chains per component, independent lanes the compiler keeps in vector registers.
fn all_finite<T, const K: usize>(items: &[T], parts: impl Fn(&T) -> [Scalar; K]) -> bool {
    let mut chains = [[0.0; K]; 4];
    let quads = items.chunks_exact(4);
    for item in quads.remainder() {
        chains[0].iter_mut().zip(parts(item)).for_each(|(c, x)| *c += x * 0.0);
    }
    for quad in quads {
        for (chain, item) in chains.iter_mut().zip(quad) {
            chain.iter_mut().zip(parts(item)).for_each(|(c, x)| *c += x * 0.0);
        }
    }
    chains.iter().flatten().all(|&c| c == 0.0)
}

/// Writes `value` into `slot`; with `compare`, only if `slot` does not hold those very bits.
#[inline(always)]
fn put<T: Bits>(slot: &mut T, value: T, compare: bool) {
    if !compare || !slot.same_bits(&value) {
        *slot = value;
    }
}

/// Equality to the bit: unlike `==`, −0.0 is not 0.0 and a NaN is itself.
trait Bits: Copy {
    fn same_bits(&self, other: &Self) -> bool;
}

impl Bits for Scalar {
    fn same_bits(&self, other: &Self) -> bool {
        self.to_bits() == other.to_bits()
    }
}

impl Bits for Vector {
    fn same_bits(&self, other: &Self) -> bool {
        self.to_array().map(Scalar::to_bits) == other.to_array().map(Scalar::to_bits)
    }
}

impl Bits for Quat {
    fn same_bits(&self, other: &Self) -> bool {
        self.to_array().map(Scalar::to_bits) == other.to_array().map(Scalar::to_bits)
    }
}

impl Bits for Mat3 {
    fn same_bits(&self, other: &Self) -> bool {
        self.to_cols_array().map(Scalar::to_bits) == other.to_cols_array().map(Scalar::to_bits)
    }
}

impl Bits for MeshId {
    fn same_bits(&self, other: &Self) -> bool {
        self == other
    }
}

impl Bits for Entity {
    fn same_bits(&self, other: &Self) -> bool {
        self == other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nan_guard_names_the_first_bad_row_and_field_and_passes_huge_finite_values() {
        let mut b = Bodies::default();
        b.resize(5);
        // Sums of these overflow to infinity, yet every value is finite.
        for i in 0..5 {
            b.position[i] = Vector::splat(f64::MAX);
            b.velocity[i] = Vector::splat(-f64::MAX);
        }
        assert_eq!(b.first_non_finite(), None);
        for (field, bad) in [(0, f64::NAN), (1, f64::INFINITY), (2, f64::NEG_INFINITY), (3, f64::NAN)] {
            let mut c = b.clone();
            match field {
                0 => c.velocity[3].y = bad,
                1 => c.angular_velocity[3].z = bad,
                2 => c.position[3].x = bad,
                _ => c.orientation[3].w = bad,
            }
            c.position[4].x = f64::NAN; // a later row: the first is named
            let name = ["velocity", "angular_velocity", "position", "orientation"][field];
            assert_eq!(c.first_non_finite(), Some((3, name)));
        }
        // A row past the last whole four (the quick pass takes those apart).
        let mut c = b.clone();
        c.orientation[4].x = f64::INFINITY;
        assert_eq!(c.first_non_finite(), Some((4, "orientation")));
    }

    #[test]
    fn loading_works_the_rotation_and_world_inertia_out_again_only_for_a_new_pose_or_inertia() {
        use crate::model::components::{ActorIndex, BoundingSphere, MassProps, Material, Mesh, Pose, Velocity};
        use crate::model::mesh::ConvexMesh;
        let inertia = Mat3::from_diagonal(Vector::new(1.0, 2.0, 3.0));
        let mut world = World::new();
        let actor = world.spawn((
            ActorIndex(0),
            Pose { position: Vector::ZERO, orientation: Quat::from_rotation_x(0.3) },
            Velocity::default(),
            MassProps::dynamic(1.0, inertia),
            Material { restitution: 0.0, friction: 0.5 },
            BoundingSphere { radius: 1.0 },
            Mesh { id: MeshId(0), shape: std::sync::Arc::new(ConvexMesh::cuboid(Vector::ONE)) },
        ));
        let mut b = Bodies::default();
        let fresh =
            |b: &Bodies| (Mat3::from_quat(b.orientation[0]), rotate_tensor(b.orientation[0], b.inv_inertia_body[0]));
        b.load(&world);
        assert_eq!((b.rotation[0], b.inv_inertia_world[0]), fresh(&b));
        // The same pose and inertia: what the arrays hold is kept (a stale value survives).
        b.rotation[0] = Mat3::ZERO;
        b.load(&world);
        assert_eq!(b.rotation[0], Mat3::ZERO);
        // A turn of the world's pose, then a new inertia: both worked out again.
        world.get::<&mut Pose>(actor).unwrap().orientation = Quat::from_rotation_y(0.7);
        b.load(&world);
        assert_eq!((b.rotation[0], b.inv_inertia_world[0]), fresh(&b));
        b.inv_inertia_world[0] = Mat3::ZERO;
        *world.get::<&mut MassProps>(actor).unwrap() = MassProps::dynamic(2.0, inertia * 2.0);
        b.load(&world);
        assert_eq!((b.rotation[0], b.inv_inertia_world[0]), fresh(&b));
        assert_ne!(b.inv_inertia_world[0], Mat3::ZERO);
    }

    /// Actor `i`'s components, its values made from `i` (row 0: position (0, 0, -0), so a
    /// position of -0.0 along x is an edit `==` cannot see).
    fn actor(i: u32, shape: &std::sync::Arc<crate::model::mesh::ConvexMesh>) -> impl hecs::DynamicBundle {
        use crate::model::components::{ActorIndex, BoundingSphere, MassProps, Material, Mesh, Pose, Velocity};
        let x = f64::from(i);
        (
            ActorIndex(i),
            Pose { position: Vector::new(x, 0.5 * x, -x), orientation: Quat::from_rotation_y(0.01 * x) },
            Velocity { linear: Vector::new(0.0, -x, 1.0), angular: Vector::new(0.1 * x, 0.0, 0.0) },
            MassProps::dynamic(1.0 + x, Mat3::from_diagonal(Vector::new(1.0, 2.0, 3.0 + x))),
            Material { restitution: 0.1, friction: 0.5 },
            BoundingSphere { radius: 1.0 },
            Mesh { id: MeshId(i % 3), shape: shape.clone() },
        )
    }

    /// Every value of every row, as bits (entities as their ids).
    fn all_bits(b: &Bodies) -> Vec<u64> {
        let mut out = Vec::new();
        for i in 0..b.len() {
            out.push(b.entity[i].to_bits().get());
            for v in [b.position[i], b.velocity[i], b.angular_velocity[i], b.principal_moments[i]] {
                out.extend(v.to_array().map(f64::to_bits));
            }
            for q in [b.orientation[i], b.principal_axes[i]] {
                out.extend(q.to_array().map(f64::to_bits));
            }
            for m in [b.rotation[i], b.inv_inertia_body[i], b.inv_inertia_world[i]] {
                out.extend(m.to_cols_array().map(f64::to_bits));
            }
            out.extend([b.inv_mass[i], b.radius[i], b.restitution[i], b.friction[i]].map(f64::to_bits));
            out.push(u64::from(b.mesh[i].0));
        }
        out
    }

    /// 700 actors loaded by rows on two threads (`load_part`) and by a plain one-thread load
    /// agree to the bit through edits in both halves of the rows, an actor respawned under its
    /// index (a new entity: the rows are read afresh) and one despawned (fewer actors).
    #[test]
    fn many_rows_loaded_in_a_pool_of_two_match_a_plain_load() {
        use crate::model::components::{MassProps, Material, Pose, Velocity};
        let shape = std::sync::Arc::new(crate::model::mesh::ConvexMesh::cuboid(Vector::ONE));
        let mut world = World::new();
        let entities: Vec<Entity> = (0..700).map(|i| world.spawn(actor(i, &shape))).collect();
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let (mut plain, mut pooled) = (Bodies::default(), Bodies::default());
        let mut check = |world: &World, what: &str| {
            one.install(|| plain.load(world));
            two.install(|| pooled.load(world));
            assert_eq!(all_bits(&pooled), all_bits(&plain), "{what}");
        };
        // Whether the rows alone (the parallel form) load the world as it stands.
        let by_rows = |world: &World| {
            let mut b = Bodies::default();
            one.install(|| b.load(world));
            two.install(|| load_part(world, b.rows(), 0))
        };
        check(&world, "first load");
        check(&world, "unchanged");
        assert!(by_rows(&world));
        for &row in &[3, 340, 351, 699] {
            let e = entities[row];
            world.get::<&mut Pose>(e).unwrap().position.y = -0.0;
            world.get::<&mut Pose>(e).unwrap().orientation = Quat::from_rotation_x(0.3);
            world.get::<&mut Velocity>(e).unwrap().angular.z = f64::NAN;
            *world.get::<&mut MassProps>(e).unwrap() = MassProps::dynamic(9.0, Mat3::IDENTITY * 2.0);
            world.get::<&mut Material>(e).unwrap().friction = 0.25;
        }
        check(&world, "edits in both halves");
        let mut stale = Bodies::default();
        one.install(|| stale.load(&world));
        world.despawn(entities[500]).unwrap();
        let respawned = world.spawn(actor(500, &shape));
        world.get::<&mut Pose>(respawned).unwrap().position = Vector::splat(7.0);
        check(&world, "a respawned actor");
        // Row 500's entity is gone: the rows alone cannot load this world.
        assert!(!two.install(|| load_part(&world, stale.rows(), 0)));
        assert!(by_rows(&world));
        world.despawn(entities[699]).unwrap();
        check(&world, "one actor fewer");
        assert_eq!((plain.len(), plain.position[500]), (699, Vector::splat(7.0)));
    }

    #[test]
    fn loading_in_a_pool_of_two_writes_every_value_that_differs_to_the_bit() {
        use crate::model::components::{MassProps, Material, Pose, Velocity};
        let mut world = World::new();
        let actor = world.spawn(actor(0, &std::sync::Arc::new(crate::model::mesh::ConvexMesh::cuboid(Vector::ONE))));
        let bits = |v: Vector| v.to_array().map(f64::to_bits);
        // The plain load on a pool of one: outside a pool the global pool may have more threads.
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let (mut plain, mut pooled) = (Bodies::default(), Bodies::default());
        // Edits a one-thread load writes and a comparing load must not skip: 0.0 -> -0.0 (equal
        // by `==`), a NaN, and a change of mass and friction.
        let edits: [fn(&mut World, Entity); 3] = [
            |w, a| w.get::<&mut Pose>(a).unwrap().position.x = -0.0,
            |w, a| w.get::<&mut Velocity>(a).unwrap().angular.z = f64::NAN,
            |w, a| {
                *w.get::<&mut MassProps>(a).unwrap() = MassProps::dynamic(4.0, Mat3::IDENTITY * 2.0);
                w.get::<&mut Material>(a).unwrap().friction = -0.0;
            },
        ];
        one.install(|| plain.load(&world));
        pool.install(|| pooled.load(&world));
        for edit in edits {
            edit(&mut world, actor);
            one.install(|| plain.load(&world));
            pool.install(|| pooled.load(&world));
            assert_eq!(bits(pooled.position[0]), bits(plain.position[0]));
            assert_eq!(bits(pooled.angular_velocity[0]), bits(plain.angular_velocity[0]));
            assert_eq!(pooled.inv_mass[0].to_bits(), plain.inv_mass[0].to_bits());
            assert_eq!(pooled.friction[0].to_bits(), plain.friction[0].to_bits());
            assert_eq!(pooled.inv_inertia_body[0], plain.inv_inertia_body[0]);
        }
        assert_eq!(pooled.position[0].x.to_bits(), (-0.0_f64).to_bits());
        assert!(pooled.angular_velocity[0].z.is_nan());
        assert_eq!(pooled.inv_mass[0], 0.25);
    }
}
