//! What a system sees besides the world: `StepContext` with its settings, the body snapshot,
//! the posed-mesh cache, the pair list and the step's statistics. Buffers are cleared, never
//! freed, so once grown a step allocates nothing.

use crate::bodies::Bodies;
use crate::components::Pose;
use crate::contact::{Feature, Pair};
use crate::geometry::Posed;
use crate::math::{Quat, Scalar, Vector};
use crate::mesh::MeshTable;
use hecs::World;
use rayon::prelude::*;

/// Settings of the pipeline that a scene or the CLI may change.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Gravity [m/s²].
    pub gravity: Vector,
    /// Most impulse sweeps over the contacts per step (PHYSICS.md §2.5). Sweeps stop earlier
    /// when one applies no impulse; the cap matters for e = 1 bodies squeezed between walls.
    pub max_sweeps: u32,
    /// Fraction β of the penetration removed per step by `correct` (PHYSICS.md §2.6).
    pub correction: Scalar,
    /// Penetration left alone, as a fraction of the thinner body's thickness (the slop).
    pub slop: Scalar,
    /// Largest correction per step, as a fraction of the thinner body's thickness: a wrong
    /// normal must not throw a body across the scene (§2.6).
    pub max_correction: Scalar,
    /// Approach speed [m/s] above which a contact bounces (in `solve`, or `resolve` where
    /// `solve` is idle); below it the contact rests. `None`: 2|g|·dt, the speed gravity alone
    /// gives in two steps, so resting bodies never hop, and zero without gravity.
    pub restitution_threshold: Option<Scalar>,
    /// Substeps of the contact solver (`solve`): each adds its share of gravity, solves and
    /// relaxes, so a tall stack's weight is carried in small pieces; the contacts' stiffness is
    /// a quarter of the substep rate. Scenes choose it by `Params::substeps_for` unless they
    /// set it.
    pub substeps: u32,
    /// Solve sweeps in each of the first half of the substeps of `solve` (rounded up); the
    /// later ones take one (`sweeps`). One relax sweep follows them.
    pub iterations: u32,
    /// Bodies that have been still for a while sleep (the `sleep` system): they are treated
    /// as fixed until something touching them moves. Off by default.
    pub sleep: bool,
    /// Distance within which two bodies count as in resting contact though apart, as a fraction
    /// of the thinner one's thickness: `prune` keeps such pairs and `solve` holds them
    /// (speculatively), so a stack does not lose a contact to a micro-bounce.
    pub contact_margin: Scalar,
}

/// Substep rate [Hz] the contact solver keeps at least, unless a scene sets its substeps: 4
/// substeps of a 1/60 s step. A soft contact sinks under a load by load / (m ω²), ω being a
/// quarter of the substep rate, so with a longer step and the same substeps a tower of ten
/// unit boxes sinks by the square of the ratio (3 cm at 1/30 s instead of 7 mm).
pub const MIN_SUBSTEP_RATE: Scalar = 240.0;

impl Params {
    /// The substeps a scene with time step `dt` [s] gets by default: 4, or as many more as keep
    /// each substep within 1/`MIN_SUBSTEP_RATE` s (8 for 1/30 s), at most 64. The same
    /// stiffness, sinking and stability at any step, for the same cost per simulated second.
    #[must_use]
    pub fn substeps_for(dt: Scalar) -> u32 {
        // The small allowance keeps 1/60 s at 4 substeps despite its rounding.
        let needed = (dt * MIN_SUBSTEP_RATE - 1e-9).ceil();
        if needed.is_finite() { needed.clamp(4.0, 64.0) as u32 } else { 4 }
    }

    /// True when `solve` holds contacts of a pair with this friction: under gravity all of
    /// them, otherwise only those with friction.
    #[must_use]
    pub fn resting_contacts(&self, dt: Scalar, friction: Scalar) -> bool {
        self.restitution_threshold(dt) > 0.0 || friction > 0.0
    }

    /// How far body `i` may travel towards another within one step [m], when `solve` may hold
    /// its contacts (else 0): its speed, gravity's gain over the step and its bounding sphere's
    /// spin, times `dt`. The broad phase widens the body's sphere by it, and `prune` and
    /// `solve` widen the pair's contact margin by the sum of the two, so a contact is held
    /// speculatively the step *before* the bodies meet; a box falling 10 cm a step then lands
    /// on the floor instead of in it, and a fast cube does not end up half inside another.
    #[must_use]
    pub fn speculative_distance(&self, dt: Scalar, b: &crate::bodies::Bodies, i: usize) -> Scalar {
        if !self.resting_contacts(dt, b.friction[i]) || b.inv_mass[i] == 0.0 {
            return 0.0;
        }
        let speed = b.velocity[i].length() + self.gravity.length() * dt + b.angular_velocity[i].length() * b.radius[i];
        speed * dt
    }

    /// `speculative_distance` of every body, into `out` (by actor index): the systems that
    /// need it for every pair compute it once per body, not twice per pair.
    pub fn speculative_distances(&self, dt: Scalar, b: &crate::bodies::Bodies, out: &mut Vec<Scalar>) {
        out.clear();
        out.extend((0..b.len()).map(|i| self.speculative_distance(dt, b, i)));
    }

    /// The length of a substep of `solve` [s] for a step of `dt`.
    #[must_use]
    pub fn substep(&self, dt: Scalar) -> Scalar {
        dt / Scalar::from(self.substeps.max(1))
    }

    /// Solve sweeps in substep `k` (0-based): `iterations` in the first half, one after. The
    /// later substeps start from the earlier ones' impulses, near the solution, and one sweep
    /// holds them: on a 40-row pyramid 2, 2, 1, 1 stands as well as 2, 2, 2, 2 (4.6 cm against
    /// 4.4 cm) for 7 % less work, and the 1 000-cube rain of seeds 1–5 is at rest by step 600
    /// (with 2 in every substep seeds 2, 3 and 5 still stirred at 2e-3 to 1e-2 J); one sweep
    /// in every substep leaves the pyramid bouncing.
    #[must_use]
    pub fn sweeps(&self, k: u32) -> u32 {
        if k < self.substeps.div_ceil(2) { self.iterations } else { 1 }
    }

    /// The restitution threshold in force for time step `dt` [m/s].
    #[must_use]
    pub fn restitution_threshold(&self, dt: Scalar) -> Scalar {
        self.restitution_threshold.unwrap_or(2.0 * self.gravity.length() * dt)
    }
}

impl Default for Params {
    fn default() -> Self {
        Self {
            gravity: Vector::new(0.0, -9.81, 0.0),
            max_sweeps: 20,
            correction: 0.4,
            slop: 0.0005,
            max_correction: 0.2,
            restitution_threshold: None,
            substeps: 4,
            iterations: 2,
            sleep: false,
            contact_margin: 0.02,
        }
    }
}

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
}

impl StepStats {
    /// Adds one impulse for a contact found by `feature`.
    pub fn count_impulse(&mut self, feature: Feature) {
        self.impulses[feature as usize] += 1;
    }
}

/// World vertices and planes per body, filled once per step and only for bodies that are in
/// candidate pairs (DESIGN.md §3).
#[derive(Clone, Debug, Default)]
pub struct PosedCache {
    entries: Vec<Posed>,
    /// Entry i matches body i's current pose.
    fresh: Vec<bool>,
    /// Scratch: body i is in a candidate pair.
    wanted: Vec<bool>,
}

impl PosedCache {
    /// The posed mesh of body `i`; valid once `StepContext::pose_candidates` ran this step.
    #[must_use]
    pub fn get(&self, i: u32) -> &Posed {
        debug_assert!(self.fresh[i as usize], "body {i} was not posed this step");
        &self.entries[i as usize]
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

/// One body in the grid's cell-sorted list.
#[derive(Clone, Copy, Debug, Default)]
pub struct CellEntry {
    /// Centre [m].
    pub position: Vector,
    /// Bounding radius [m].
    pub radius: Scalar,
    /// Actor index.
    pub index: u32,
    /// Fixed actor.
    pub fixed: bool,
}

/// Reused buffers of the grid broad phase (`cull`).
#[derive(Clone, Debug, Default)]
pub struct CullScratch {
    /// Each body's bounding radius widened by its speculative distance [m]
    /// (`Params::speculative_distance`).
    pub reach: Vec<Scalar>,
    /// Copy of the radii for the median.
    pub radii: Vec<Scalar>,
    /// Bodies too large for the grid.
    pub large: Vec<u32>,
    /// Cell of each body (`u32::MAX` for large ones).
    pub cell_of: Vec<u32>,
    /// Prefix sums: bodies of cell c are `order[cell_start[c]..cell_start[c + 1]]`.
    pub cell_start: Vec<u32>,
    /// Fill cursors while binning.
    pub fill: Vec<u32>,
    /// Bodies sorted by cell, with what the sphere test reads, so a neighbour scan reads one
    /// contiguous run instead of three scattered arrays.
    pub order: Vec<CellEntry>,
    /// Pairs (a, b) found per chunk of bodies, concatenated in order; 8 bytes each, not a
    /// whole `Pair`, because at 64 000 cubes they are 270 000 and memory traffic dominates.
    pub chunks: Vec<Vec<(u32, u32)>>,
}

/// Constraints solved together (see `SolveScratch::groups`), with their own solver-body
/// numbering: a group's slots count from `offset`, and its static slot is the last of its
/// range.
#[derive(Clone, Debug, Default)]
pub struct ConstraintGroup {
    /// First solver body of the group's range.
    pub offset: u32,
    /// The group's static slot, in its own numbering.
    pub fixed: u32,
    /// Solver-body slots of each constraint, in the group's numbering (for `solver::place`).
    pub slots: Vec<[u32; 2]>,
    /// (batch, lane) of each constraint.
    pub placed: Vec<(u32, u8)>,
    /// Constraints per batch.
    pub fill: Vec<u8>,
    /// Scratch of `solver::place`.
    pub last: Vec<u32>,
    /// The batches of independent constraints, in solving order.
    pub batches: Vec<crate::solver::Batch>,
    /// Their points, lane by lane.
    pub points: Vec<crate::solver::PointRows>,
}

/// A pair `solve` holds this step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldPair {
    /// Index into `SolveScratch::pairs`.
    pub pair: u32,
    /// Its group (`SolveScratch::groups`).
    pub group: u8,
    /// Its batch in the group.
    pub batch: u32,
    /// Lane within the batch.
    pub lane: u8,
    /// Points (1 to 4).
    pub len: u8,
}

/// A pair's contact points fixed to the two bodies, so a pair that has hardly moved relative to
/// each other since they were found keeps them (rapier's contact recycling): the manifold,
/// and so the warm start, stays the same from step to step instead of being rebuilt from
/// round-off, and the separating-axis test and clipping are skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Geometry {
    /// B's centre in A's body frame when the points were found [m].
    pub offset: Vector,
    /// B's orientation relative to A's then.
    pub turn: crate::math::Quat,
    /// The normal (from B to A) in A's body frame.
    pub normal: Vector,
    /// Each point on A's surface, A's body frame [m].
    pub on_a: [Vector; crate::manifold::MAX_POINTS],
    /// Each point on B's surface, B's body frame [m].
    pub on_b: [Vector; crate::manifold::MAX_POINTS],
    /// How many points.
    pub len: usize,
}

/// A pair's cached state: its contact geometry and its impulses (points' and friction
/// patch's), without a heap allocation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CachedManifold {
    /// Where the points are.
    pub geometry: Geometry,
    /// Each point's normal impulse [N·s].
    pub normal: [Scalar; crate::manifold::MAX_POINTS],
    /// Friction impulse at the patch's centre, world frame [N·s].
    pub tangent: Vector,
    /// Twist impulse about the normal, world frame [N·m·s].
    pub twist: Vector,
}

/// Reused buffers of the contact solver (`solve`), and its warm-start cache, the one piece of
/// its state that lives from one step to the next (recycled points and impulses; snapshots
/// carry it, `snapshot::ContactSnapshot`).
#[derive(Clone, Debug, Default)]
pub struct SolveScratch {
    /// The pairs solved this step, in pair order.
    pub pairs: Vec<Pair>,
    /// Their manifolds.
    pub manifolds: Vec<crate::manifold::Manifold>,
    /// Whether each pair is near but untouched (no test found it).
    pub near: Vec<bool>,
    /// The order in which pairs are solved: (height of the contact against gravity as a
    /// `math::total_order_key`, index).
    pub order: Vec<(u64, u32)>,
    /// One entry per held pair, in solving order.
    pub held: Vec<HeldPair>,
    /// The constraints in three groups: those among the bodies of one side of the scene, of
    /// the other, and across (see `solver::build_constraints`). The first two are solved at
    /// once on two threads, the third after them.
    pub groups: [ConstraintGroup; 3],
    /// Each pair's contact geometry (in `pairs` order), found or recycled this step.
    pub geometry: Vec<Geometry>,
    /// Whether each pair's geometry was recycled from the previous step.
    pub recycled: Vec<bool>,
    /// Each pair's index in `cache` (`u32::MAX` for none).
    pub cached: Vec<u32>,
    /// Scratch of `solve::remember`: the held pairs' indices into `held`, in pair order.
    pub by_pair: Vec<u32>,
    /// Last step's geometry and impulses by pair, in pair order (found through `cached`).
    pub cache: Vec<((u32, u32), CachedManifold)>,
    /// The step these constraints belong to (`correct` uses them only if `solve` ran this step).
    pub step: u64,
    /// The free bodies of the constraints, each once, in solver-body order (the static slots
    /// between the sides and at the end skipped).
    pub moving: Vec<u32>,
    /// Free bodies on the first side; solver body `left` is that side's static slot.
    pub left: usize,
    /// Scratch: each moving body's velocity, angular velocity, position and orientation after
    /// the substeps, found in parallel and then written to the bodies.
    pub after: Vec<(Vector, Vector, Vector, Quat)>,
    /// Scratch: each free body's coordinate along the split, with its actor index.
    pub keys: Vec<(u64, u32)>,
    /// Each actor's solver-body slot (`u32::MAX` when not in a held pair this step; fixed
    /// bodies map to the last static slot).
    pub slot: Vec<u32>,
    /// The solver bodies: the first side's free bodies, its static slot, the second side's,
    /// the last static slot (`solver::build_constraints`).
    pub bodies: Vec<crate::solver::SolverBody>,
    /// S = (I⁻¹)^½ in world axes of each solver body (zero for the static slots).
    pub scale: Vec<crate::math::Mat3>,
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

/// Reused allocations of the shipped systems.
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    /// For `cull`.
    pub cull: CullScratch,
    /// Each body's speculative distance (`Params::speculative_distances`), refreshed by each
    /// system that reads it (velocities change between systems).
    pub speculative: Vec<Scalar>,
    /// For `solve`.
    pub solve: SolveScratch,
}

/// Everything a system may read or write besides the world (DESIGN.md §4).
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

    /// Re-reads the world after a custom system edited it directly (DESIGN.md §3).
    pub fn reload(&mut self, world: &World) {
        let before = self.bodies.len();
        self.bodies.load(world);
        self.sleep.apply(&mut self.bodies);
        if self.posed.entries.len() != self.bodies.len() || before != self.bodies.len() {
            self.posed.reset(&self.meshes, &self.bodies);
        }
        self.posed.fresh.iter_mut().for_each(|f| *f = false);
    }

    /// Marks body `i` as moved, so the next `pose_candidates` poses it again.
    pub fn mark_moved(&mut self, i: usize) {
        self.posed.fresh[i] = false;
    }

    /// Poses every body that appears in a `Candidate` pair and was not posed since it last
    /// moved. Detectors call it first; the second call in a step finds nothing to do.
    pub fn pose_candidates(&mut self) {
        self.pose_pairs(Pair::is_candidate);
    }

    /// Poses every body of the pairs `want` picks that was not posed since it last moved (for
    /// systems after the detectors, e.g. pairs with a contact).
    pub fn pose_pairs(&mut self, want: impl Fn(&Pair) -> bool) {
        let cache = &mut self.posed;
        cache.wanted.iter_mut().for_each(|w| *w = false);
        for p in self.pairs.iter().filter(|p| want(p)) {
            cache.wanted[p.a as usize] = true;
            cache.wanted[p.b as usize] = true;
        }
        let bodies = &self.bodies;
        let rows = cache.entries.par_iter_mut().zip(cache.fresh.par_iter_mut());
        rows.zip(cache.wanted.par_iter()).enumerate().for_each(|(i, ((posed, fresh), &wanted))| {
            if wanted && !*fresh {
                posed.update(&Pose { position: bodies.position[i], orientation: bodies.orientation[i] });
                *fresh = true;
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substeps_keep_each_at_most_a_240th_of_a_second() {
        let cases = [(1.0 / 60.0, 4), (0.01, 4), (1e-4, 4), (1.0 / 30.0, 8), (0.05, 12), (0.1, 24), (1.0, 64)];
        for (dt, substeps) in cases {
            assert_eq!(Params::substeps_for(dt), substeps, "dt = {dt}");
        }
    }
}
