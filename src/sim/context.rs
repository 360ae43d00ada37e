//! What a system sees besides the world: `StepContext` with its settings, the body snapshot,
//! the posed-mesh cache, the pair list and the step's statistics. Buffers are cleared, never
//! freed, so once grown a step allocates nothing.

use crate::collision::contact::{Feature, Pair};
use crate::collision::posed::Posed;
use crate::math::{Scalar, Vector};
use crate::model::components::Pose;
use crate::model::mesh::MeshTable;
use crate::sim::bodies::Bodies;
pub use crate::sim::params::Params;
use hecs::World;
use rayon::prelude::*;
use std::any::{Any, TypeId};

/// Counts of one step, filled by the systems.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct StepStats {
    /// Candidate pairs from the broad phase.
    pub candidates: usize,
    /// Contacts found, by feature (face, vertex, edge).
    pub found: [u64; 3],
    /// Impulses applied, by feature of the contact.
    pub impulses: [u64; 3],
    /// Impulse sweeps used by `resolve`.
    pub sweeps: u32,
    /// Pairs the contact solver (`solve`) held this step.
    pub held: usize,
    /// The contact solver split its constraints in two sides of the scene, solved at once.
    pub split: bool,
}

impl StepStats {
    /// Adds one impulse for a contact found by `feature`.
    pub fn count_impulse(&mut self, feature: Feature) {
        self.impulses[feature as usize] += 1;
    }
}

/// World vertices and planes per body, filled once per step and only for the bodies a system
/// asks for: the tests' candidate pairs, the pairs `solve` finds afresh, and in `prune` the
/// small meshes (a many-faced body there is walked unposed, `hull::Placed`).
#[derive(Clone, Debug, Default)]
pub struct PosedCache {
    entries: Vec<Posed>,
    /// Entry i matches body i's current pose.
    fresh: Vec<bool>,
    /// Scratch: body i is in a candidate pair.
    wanted: Vec<bool>,
    /// Counts the moves marked (`mark_moved`) and the reloads: a system that kept something
    /// worked out from the poses may read it again only while this is unchanged.
    moves: u64,
}

impl PosedCache {
    /// The posed mesh of body `i`; valid once `StepContext::pose_candidates` ran this step.
    #[must_use]
    pub fn get(&self, i: u32) -> &Posed {
        debug_assert!(self.fresh[i as usize], "body {i} was not posed this step");
        &self.entries[i as usize]
    }

    /// Marks body `i` as moved, so it is posed again when next wanted.
    pub fn mark_moved(&mut self, i: usize) {
        self.fresh[i] = false;
        self.moves += 1;
    }

    /// How many moves and reloads there have been (`moves`).
    #[must_use]
    pub fn moves(&self) -> u64 {
        self.moves
    }

    fn reset(&mut self, meshes: &MeshTable, bodies: &Bodies) {
        self.entries.clear();
        self.entries.extend((0..bodies.len()).map(|i| {
            let pose = Pose { position: bodies.position[i], orientation: bodies.orientation[i] };
            Posed::new(meshes.get_arc(bodies.mesh[i]), &pose)
        }));
        self.fresh.clear();
        self.fresh.resize(bodies.len(), false);
        self.wanted.clear();
        self.wanted.resize(bodies.len(), false);
    }
}

/// Which bodies sleep, and for how long each awake one has been still: the `sleep` system's
/// state, kept from step to step (and in snapshots, as the warm-start cache is).
#[derive(Clone, Debug, Default)]
pub struct SleepState {
    /// Seconds body i has been still.
    pub still: Vec<Scalar>,
    /// Body i sleeps: the snapshot treats it as fixed (zero inverse mass and inertia).
    pub asleep: Vec<bool>,
    /// Scratch: each free body's speed this step [m/s].
    pub speed: Vec<Scalar>,
    /// Scratch: body i may fall asleep this step.
    pub ready: Vec<bool>,
    /// Where each body will end this step, as `sleep` last saw it (its position plus v·dt):
    /// the distance to the next step's gives how far it really moved, which a contact that
    /// stopped it within the step hides from its final velocity.
    pub reached: Vec<Vector>,
}

impl SleepState {
    /// Sizes the state for `n` bodies (new ones awake).
    pub fn resize(&mut self, n: usize) {
        self.still.resize(n, 0.0);
        self.asleep.resize(n, false);
    }

    /// Makes the sleeping bodies fixed in the snapshot for this step, so gravity, the contact
    /// stages and `integrate` leave them alone and pairs of two of them are never tested.
    fn apply(&self, bodies: &mut Bodies) {
        for (i, _) in self.asleep.iter().enumerate().filter(|(_, a)| **a) {
            bodies.inv_mass[i] = 0.0;
            bodies.inv_inertia_body[i] = crate::math::Mat3::ZERO;
            bodies.inv_inertia_world[i] = crate::math::Mat3::ZERO;
        }
    }
}

/// Reused allocations of the systems, at most one value of each type: a system keeps its own
/// scratch type beside it (`ctx.scratch.get_mut::<CullScratch>()`), a custom system too, and
/// the step context need not know any of them. Values live from step to step.
#[derive(Default)]
pub struct Scratch {
    slots: Vec<(TypeId, Box<dyn Any + Send + Sync>)>,
}

impl Scratch {
    /// The scratch of type `T`, made with `T::default()` on first use.
    pub fn get_mut<T: Any + Default + Send + Sync>(&mut self) -> &mut T {
        let id = TypeId::of::<T>();
        let k = match self.slots.iter().position(|(t, _)| *t == id) {
            Some(k) => k,
            None => {
                self.slots.push((id, Box::new(T::default())));
                self.slots.len() - 1
            }
        };
        self.slots[k].1.downcast_mut().expect("each slot holds the type it is keyed by")
    }

    /// The scratch of type `T`, if a system made one.
    #[must_use]
    pub fn get<T: Any + Send + Sync>(&self) -> Option<&T> {
        let id = TypeId::of::<T>();
        self.slots.iter().find(|(t, _)| *t == id).and_then(|(_, v)| v.downcast_ref())
    }
}

impl std::fmt::Debug for Scratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Scratch({} values)", self.slots.len())
    }
}

/// `StepContext::speculative_distances` as last worked out, and whether the bodies are still
/// those it was worked out from.
#[derive(Debug, Default)]
struct Speculative {
    fresh: bool,
    values: Vec<Scalar>,
}

/// Everything a system may read or write besides the world (ARCHITECTURE.md).
#[derive(Debug, Default)]
pub struct StepContext {
    /// Time step [s].
    pub dt: Scalar,
    /// Pipeline settings.
    pub params: Params,
    /// Each mesh once.
    pub meshes: MeshTable,
    /// Snapshot of the actors; `begin_step` loads it, resolve/correct/integrate update rows.
    pub bodies: Bodies,
    /// Posed meshes, filled on first use in a step.
    pub posed: PosedCache,
    /// Pairs: cull → face/vertex/edge → resolve → correct. Sorted by (a, b).
    pub pairs: Vec<Pair>,
    /// This step's counts.
    pub stats: StepStats,
    /// Reused allocations.
    pub scratch: Scratch,
    /// Number of the step being computed (1 for the first).
    pub step: u64,
    /// Sleeping bodies (empty while `params.sleep` is off).
    pub sleep: SleepState,
}

impl StepContext {
    /// Starts a step: clears the buffers and snapshots the world.
    pub fn begin_step(&mut self, world: &World) {
        self.step += 1;
        self.pairs.clear();
        self.stats = StepStats::default();
        self.reload(world);
    }

    /// Ends a step: writes every body's pose and velocities back to the world, the one store
    /// of the step. Systems change `bodies`, never the world, so nothing is lost between.
    pub fn end_step(&self, world: &mut World) {
        self.bodies.store(world);
    }

    /// Writes the bodies to the world now, for a custom system that reads poses or velocities
    /// from the world in the middle of a step (systems before it changed only `bodies`).
    pub fn sync_world(&self, world: &mut World) {
        self.bodies.store(world);
    }

    /// Each body's speculative distance (`Params::speculative_distances`) into `out`, worked
    /// out once for the systems between two that may move the bodies: `cull` and `prune` read
    /// the same. The schedule marks it stale after every other system (`bodies_changed`).
    pub fn speculative_distances(&mut self, out: &mut Vec<Scalar>) {
        let kept = self.scratch.get_mut::<Speculative>();
        if !kept.fresh {
            self.params.speculative_distances(self.dt, &self.bodies, &mut kept.values);
            kept.fresh = true;
        }
        out.clone_from(&kept.values);
    }

    /// Forgets what was worked out from the bodies (`speculative_distances`): after `reload`,
    /// and after each system that may have written them.
    pub fn bodies_changed(&mut self) {
        self.scratch.get_mut::<Speculative>().fresh = false;
    }

    /// Re-reads the world after a custom system edited it directly: `bodies` is what every
    /// later system reads and what the step stores at its end, so an edit of the world
    /// without it is overwritten.
    pub fn reload(&mut self, world: &World) {
        self.bodies_changed();
        let before = self.bodies.len();
        self.bodies.load(world);
        self.sleep.apply(&mut self.bodies);
        if self.posed.entries.len() != self.bodies.len() || before != self.bodies.len() {
            self.posed.reset(&self.meshes, &self.bodies);
        }
        // A body posed last step at the very pose it has now (a fixed one, or one at rest to
        // the bit) keeps its posed mesh: posing is a function of the pose alone.
        let (posed, bodies) = (&mut self.posed, &self.bodies);
        posed.moves += 1;
        for (i, (entry, fresh)) in posed.entries.iter().zip(posed.fresh.iter_mut()).enumerate() {
            *fresh = *fresh && entry.position == bodies.position[i] && entry.orientation == bodies.orientation[i];
        }
    }

    /// Marks body `i` as moved, so the next `pose_candidates` poses it again.
    pub fn mark_moved(&mut self, i: usize) {
        self.posed.mark_moved(i);
    }

    /// Poses every body that appears in a `Candidate` pair and was not posed since it last
    /// moved. Detectors call it first; the second call in a step finds nothing to do.
    pub fn pose_candidates(&mut self) {
        self.pose_pairs(Pair::is_candidate);
    }

    /// Poses every body of the pairs `want` picks that was not posed since it last moved (for
    /// systems after the detectors, e.g. pairs with a contact).
    pub fn pose_pairs(&mut self, want: impl Fn(&Pair) -> bool) {
        let bodies = self.pairs.iter().filter(|p| want(p)).flat_map(|p| [p.a, p.b]);
        self.posed.pose(&self.bodies, bodies);
    }
}

impl PosedCache {
    /// Poses each of `which` (body indices, repeats allowed) that was not posed since it last
    /// moved.
    pub fn pose(&mut self, bodies: &Bodies, which: impl Iterator<Item = u32>) {
        self.wanted.iter_mut().for_each(|w| *w = false);
        for i in which {
            self.wanted[i as usize] = true;
        }
        let rows = self.entries.par_iter_mut().zip(self.fresh.par_iter_mut());
        rows.zip(self.wanted.par_iter()).enumerate().for_each(|(i, ((posed, fresh), &wanted))| {
            if wanted && !*fresh {
                posed.update(&Pose { position: bodies.position[i], orientation: bodies.orientation[i] });
                *fresh = true;
            }
        });
    }
}
