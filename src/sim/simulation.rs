//! `Sim`: the world, its step context, the schedule and the clock. Structural changes
//! (spawning) happen here, between steps; systems never spawn or despawn.

use crate::collision::contact::Feature;
use crate::error::StepError;
use crate::math::{Mat3, Scalar, Vector};
use crate::model::components::{ActorIndex, BoundingSphere, MassProps, Material, Mesh, Name, Pose, Velocity};
use crate::model::mesh::ConvexMesh;
use crate::sim::context::{Params, StepContext};
use crate::sim::schedule::{Schedule, StepProfile};
use hecs::{Entity, World};

/// A body to add: a validated mesh (about its centre of mass) and its initial state.
#[derive(Clone, Debug)]
pub struct BodyDef {
    /// Unique name.
    pub name: String,
    /// Index of the mesh in the sim's `MeshTable` (from `Sim::add_mesh`).
    pub mesh: crate::model::mesh::MeshId,
    /// Mass [kg] (nominal for fixed bodies).
    pub mass: Scalar,
    /// Pose of the centre of mass.
    pub pose: Pose,
    /// Initial velocities.
    pub velocity: Velocity,
    /// Restitution and friction.
    pub material: Material,
    /// Fixed bodies never move.
    pub fixed: bool,
}

/// Totals over the non-fixed actors (docs/cli.md).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Totals {
    /// Σ m v [kg·m/s].
    pub linear_momentum: Vector,
    /// Σ (x × m v + I_w ω) about the world origin [kg·m²/s].
    pub angular_momentum: Vector,
    /// Σ ½ m v² + ½ ω·I_w ω [J].
    pub kinetic_energy: Scalar,
}

/// A simulation: world, context, schedule and clock.
pub struct Sim {
    /// The ECS world: one entity per actor.
    pub world: World,
    /// Per-step state shared by the systems.
    pub ctx: StepContext,
    /// The systems run each step, in order.
    pub schedule: Schedule,
    /// Simulated time [s].
    pub time: Scalar,
    /// Steps taken.
    pub steps: u64,
    /// Impulses applied over the run, by the feature of the contact (face, vertex, edge):
    /// each of `resolve`'s, and one for each pair and step the contact solver held a contact
    /// that a test found.
    pub impulses: [u64; 3],
    /// Contacts the detection tests found over the run, by test (face, vertex, edge).
    pub found: [u64; 3],
    /// Pairs held by the contact solver (`solve`), summed over the steps.
    pub held: u64,
    /// Timing of the last step.
    pub profile: StepProfile,
    pub(crate) names: Vec<String>,
}

impl Sim {
    /// An empty simulation with time step `dt` [s], settings and schedule.
    #[must_use]
    pub fn new(dt: Scalar, params: Params, schedule: Schedule) -> Self {
        let ctx = StepContext { dt, params, ..StepContext::default() };
        Self {
            world: World::new(),
            ctx,
            schedule,
            time: 0.0,
            steps: 0,
            impulses: [0; 3],
            found: [0; 3],
            held: 0,
            profile: StepProfile::default(),
            names: Vec::new(),
        }
    }

    /// Adds a mesh to the table (an identical one is shared) and returns its id.
    pub fn add_mesh(&mut self, mesh: ConvexMesh) -> crate::model::mesh::MeshId {
        self.ctx.meshes.insert(mesh)
    }

    /// Spawns an actor; its `ActorIndex` is the number of actors before it.
    pub fn spawn(&mut self, def: &BodyDef) -> Entity {
        let mesh = self.ctx.meshes.get(def.mesh);
        let inertia: Mat3 = mesh.unit_inertia * (def.mass / mesh.volume);
        let mass = if def.fixed { MassProps::fixed(def.mass, inertia) } else { MassProps::dynamic(def.mass, inertia) };
        let index = ActorIndex(self.names.len() as u32);
        self.names.push(def.name.clone());
        let velocity = if def.fixed { Velocity::default() } else { def.velocity };
        self.world.spawn((
            index,
            Name(def.name.clone()),
            def.pose,
            velocity,
            mass,
            def.material,
            BoundingSphere { radius: mesh.radius },
            Mesh { id: def.mesh, shape: self.ctx.meshes.get_arc(def.mesh) },
        ))
    }

    /// Number of actors.
    #[must_use]
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// True when there are no actors.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// Actor names in index (scene) order.
    #[must_use]
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Advances one step through the schedule; counts impulses into `impulses`.
    pub fn step(&mut self) -> Result<(), StepError> {
        self.schedule.run(&mut self.world, &mut self.ctx, &mut self.profile)?;
        self.steps += 1;
        self.time = self.steps as Scalar * self.ctx.dt;
        for f in Feature::ALL {
            self.impulses[f as usize] += self.ctx.stats.impulses[f as usize];
            self.found[f as usize] += self.ctx.stats.found[f as usize];
        }
        self.held += self.ctx.stats.held as u64;
        Ok(())
    }

    /// Runs `n` steps.
    pub fn run(&mut self, n: u64) -> Result<(), StepError> {
        (0..n).try_for_each(|_| self.step())
    }

    /// Current state of every actor, in index order.
    #[must_use]
    pub fn actors(&self) -> Vec<ActorState> {
        let mut out: Vec<Option<ActorState>> = vec![None; self.len()];
        for (index, pose, vel, mass) in self.world.query::<(&ActorIndex, &Pose, &Velocity, &MassProps)>().iter() {
            out[index.0 as usize] = Some(ActorState {
                name: self.names[index.0 as usize].clone(),
                pose: *pose,
                velocity: *vel,
                mass: *mass,
            });
        }
        out.into_iter().flatten().collect()
    }

    /// Momentum, angular momentum about the origin, and kinetic energy of the free actors.
    #[must_use]
    pub fn totals(&self) -> Totals {
        // Straight from the world, without copying names: `rigid bench` calls this at 64 000
        // actors. hecs yields one archetype's entities in spawn (index) order.
        let mut query = self.world.query::<(&Pose, &Velocity, &MassProps)>();
        accumulate(query.iter())
    }
}

/// One actor's state, for output and tests.
#[derive(Clone, Debug, PartialEq)]
pub struct ActorState {
    /// Name.
    pub name: String,
    /// Pose.
    pub pose: Pose,
    /// Velocities.
    pub velocity: Velocity,
    /// Mass properties (body frame).
    pub mass: MassProps,
}

impl ActorState {
    /// Inertia in world axes, R I Rᵀ [kg·m²].
    #[must_use]
    pub fn world_inertia(&self) -> Mat3 {
        crate::sim::bodies::rotate_tensor(self.pose.orientation, self.mass.inertia)
    }
}

/// Totals over the non-fixed actors of `actors`.
#[must_use]
pub fn totals(actors: &[ActorState]) -> Totals {
    accumulate(actors.iter().map(|a| (&a.pose, &a.velocity, &a.mass)))
}

fn accumulate<'a>(actors: impl Iterator<Item = (&'a Pose, &'a Velocity, &'a MassProps)>) -> Totals {
    let mut t = Totals { linear_momentum: Vector::ZERO, angular_momentum: Vector::ZERO, kinetic_energy: 0.0 };
    for (pose, vel, mass) in actors.filter(|(_, _, m)| !m.is_fixed()) {
        let (m, v, w) = (mass.mass, vel.linear, vel.angular);
        let iw = crate::sim::bodies::rotate_tensor(pose.orientation, mass.inertia) * w;
        t.linear_momentum += m * v;
        t.angular_momentum += pose.position.cross(m * v) + iw;
        t.kinetic_energy += 0.5 * m * v.length_squared() + 0.5 * w.dot(iw);
    }
    t
}
