//! The contact solver's state: the constraints of a step in their groups and batches, and the
//! warm-start cache (each pair's recycled points and impulses), the one part of it that lives
//! from one step to the next (snapshots carry it).

use crate::collision::contact::{Contact, Feature, Pair};
use crate::collision::manifold::{MAX_POINTS, Manifold, Reference};
use crate::math::{Mat3, Quat, Scalar, Vector, total_order_key};
use crate::solver::{Batch, PointRows, SolverBody};

/// Constraints solved together (see `SolveScratch::groups`), with their own solver-body
/// numbering: a group's slots count from `offset`, and its static slot is the last of its
/// range.
#[derive(Clone, Debug, Default)]
pub struct ConstraintGroup {
    /// First solver body of the group's range.
    pub offset: u32,
    /// The group's static slot, in its own numbering.
    pub static_slot: u32,
    /// Solver-body slots of each constraint, in the group's numbering (for `solver::place`).
    pub slots: Vec<[u32; 2]>,
    /// Scratch of `place_group`: each constraint's point count, which `solver::place`
    /// batches like with like and which sets each batch's length.
    pub kinds: Vec<u8>,
    /// (batch, lane) of each constraint.
    pub placed: Vec<(u32, u8)>,
    /// Constraints per batch.
    pub fill: Vec<u8>,
    /// Scratch of `solver::place`: each slot's last batch.
    pub last: Vec<u32>,
    /// Scratch of `solver::place`: each batch's kind while it has room.
    pub kind_of: Vec<u8>,
    /// Scratch of `fill`: each batch's lanes as (pair, index in `slots`).
    pub lanes: Vec<[(u32, u32); crate::solver::LANES]>,
    /// The batches of independent constraints, in solving order.
    pub batches: Vec<Batch>,
    /// Their points, lane by lane.
    pub points: Vec<PointRows>,
    /// The batches with a point that may bounce (`kernel::may_bounce`), in order: what the
    /// restitution pass visits. A resting pile has none, and the pass then reads nothing.
    pub bouncing: Vec<u32>,
    /// Scratch of `solve::remember`: each lane's impulses after the substeps, lane l of batch
    /// b at b · `LANES` + l.
    pub impulses: Vec<LaneImpulses>,
}

/// A lane's impulses after the substeps, as the warm-start cache keeps them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LaneImpulses {
    /// The normal impulse of each of its batch's points [N·s], the first `Batch::len` (past
    /// the lane's own points, an idle row's).
    pub normal: [Scalar; MAX_POINTS],
    /// Friction impulse at the patch's centre, world frame [N·s].
    pub tangent: Vector,
    /// Twist impulse about the normal, world frame [N·m·s].
    pub twist: Vector,
}

/// A pair `solve` holds this step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldPair {
    /// Index into `SolveScratch::pairs`.
    pub pair: u32,
    /// Its group (`SolveScratch::groups`).
    pub group: u8,
    /// Its place among the group's constraints: its (batch, lane) is the group's `placed[at]`.
    pub at: u32,
    /// Points (1 to 4).
    pub len: u8,
    /// It carries no impulse from last step (`PairEnds::quiet`).
    pub quiet: bool,
}

/// A pair's contact points fixed to the two bodies, so a pair that has hardly moved relative to
/// each other since they were found keeps them (rapier's contact recycling): the manifold,
/// and so the warm start, stays the same from step to step instead of being rebuilt from
/// round-off, and the separating-axis test and clipping are skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactAnchors {
    /// B's centre in A's body frame when the points were found [m].
    pub offset: Vector,
    /// B's orientation relative to A's then.
    pub turn: Quat,
    /// The normal (from B to A) in A's body frame.
    pub normal: Vector,
    /// Each point on A's surface, A's body frame [m].
    pub on_a: [Vector; MAX_POINTS],
    /// Each point on B's surface, B's body frame [m].
    pub on_b: [Vector; MAX_POINTS],
    /// How many points.
    pub len: usize,
    /// The axis the points were found along (its face, or an edge pair): next time the pair
    /// is searched afresh, the search starts there (`manifold::contact_axis_from`).
    pub axis: Option<Reference>,
}

/// A pair's cached state: its contact anchors and its impulses (points' and friction
/// patch's), without a heap allocation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CachedManifold {
    /// Where the points are.
    pub anchors: ContactAnchors,
    /// Each point's normal impulse [N·s].
    pub normal: [Scalar; MAX_POINTS],
    /// Friction impulse at the patch's centre, world frame [N·s].
    pub tangent: Vector,
    /// Twist impulse about the normal, world frame [N·m·s].
    pub twist: Vector,
    /// The test that found the pair the last time the tests ran on it (`None`: none did, it
    /// was held as near). A pair that keeps its points skips the tests and keeps this verdict
    /// (`prune`, docs/physics.md §6.3), so the counts by test still count it.
    pub found: Option<Feature>,
}

/// A held pair's impulses taken from last step's (`solve::find_manifolds`), what building its
/// constraint reads of the warm-start cache.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WarmStart {
    /// Each point's normal impulse from last step's point it matches [N·s] (0 for none).
    pub normal: [Scalar; MAX_POINTS],
    /// Whether each point matched one of last step's (it then does not bounce).
    pub kept: [bool; MAX_POINTS],
    /// Last step's friction impulse at the patch centre [N·s].
    pub tangent: Vector,
    /// Last step's twist impulse about the normal [N·m·s].
    pub twist: Vector,
}

impl WarmStart {
    /// True when it starts the first `len` points and the friction patch at no impulse.
    #[must_use]
    pub fn is_zero(&self, len: usize) -> bool {
        self.normal[..len].iter().all(|&j| j == 0.0) && self.tangent == Vector::ZERO && self.twist == Vector::ZERO
    }
}

/// Whether a pair with an entry in the warm-start cache keeps its points this step, worked out
/// once: by `prune`, which takes such pairs out of the detection tests, and read by `solve`
/// instead of being worked out again, if no body moved in between.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Recycling {
    /// The step it was worked out in (`None`, or an earlier step: not worked out).
    pub step: Option<u64>,
    /// The kept points placed at the bodies' poses then; `None` when the bodies moved too much.
    pub manifold: Option<Manifold>,
    /// The contact the pair is held at then (`solve::recycled_contact`; its feature is not
    /// meant, the pair's own is).
    pub contact: Option<Contact>,
}

/// Each pair's index in `cache` (`u32::MAX` for none), into `out`: both lists are in pair
/// order, so one merge. Any per-pair list kept so serves (the warm-start cache, `prune`'s GJK
/// starts).
pub fn cache_entries<T>(cache: &[((u32, u32), T)], pairs: &[Pair], out: &mut Vec<u32>) {
    merge_entries(cache.len(), |e| cache[e].0, pairs, out);
}

/// `cache_entries` of the pairs in a list of `len` entries whose keys `key` gives.
fn merge_entries(len: usize, key: impl Fn(usize) -> (u32, u32), pairs: &[Pair], out: &mut Vec<u32>) {
    // Keys packed into one number each, ordered as the pairs: one comparison a step of the
    // walk, where a pair of numbers took two hard-to-predict branches. Past the last entry the
    // walk sees a key above every pair's (a < b, so no pair packs to it).
    let pack = |(a, b): (u32, u32)| (u64::from(a) << 32) | u64::from(b);
    let key_at = |at: usize| if at < len { pack(key(at)) } else { u64::MAX };
    let (mut at, mut next) = (0, key_at(0));
    out.clear();
    out.extend(pairs.iter().map(|pair| {
        let wanted = pack((pair.a, pair.b));
        while next < wanted {
            at += 1;
            next = key_at(at);
        }
        if next == wanted { at as u32 } else { u32::MAX }
    }));
}

/// A pair's two bodies, the number of points it is held at (0: not held) and its place in
/// the solving order (`PairEnds::of`).
#[derive(Clone, Copy, Debug, Default)]
pub struct PairEnds {
    /// Actor index of A.
    pub a: u32,
    /// Actor index of B.
    pub b: u32,
    /// Points held.
    pub len: u32,
    /// The height of its points' centre along `up` as a sort key (`total_order_key`; lowest
    /// first), if held.
    pub key: u64,
    /// It starts the step with no impulse, normal or friction (a contact at the side of a
    /// stack, or one held speculatively): placed with others like it (`Batch::quiet`).
    pub quiet: bool,
}

impl PairEnds {
    /// The ends of `pair` held (or not) at the manifold `m` this step, `up` against gravity:
    /// worked out where the manifold is, so that building the constraints need not read the
    /// manifolds again.
    #[must_use]
    pub fn of(pair: &Pair, m: &Manifold, up: Vector) -> Self {
        let held = m.len > 0 && pair.contact().is_some();
        let height = || m.points().iter().map(|p| p.dot(up)).sum::<Scalar>() / m.len as Scalar;
        let (len, key) = if held { (m.len as u32, total_order_key(height())) } else { (0, 0) };
        Self { a: pair.a, b: pair.b, len, key, quiet: false }
    }
}

/// Reused buffers of the contact solver (`solve`), and its warm-start cache, the one piece of
/// its state that lives from one step to the next (recycled points and impulses; snapshots
/// carry it, `snapshot::ContactSnapshot`).
#[derive(Clone, Debug, Default)]
pub struct SolveScratch {
    /// The pairs solved this step, in pair order.
    pub pairs: Vec<Pair>,
    /// Their manifolds.
    pub manifolds: Vec<Manifold>,
    /// Whether each pair is near but untouched (no test found it).
    pub near: Vec<bool>,
    /// The held pairs lowest first, the order in which each group solves them (its quiet ones
    /// after the others): (height of the contact against gravity as a
    /// `math::total_order_key`, index).
    pub order: Vec<(u64, u32)>,
    /// One entry per held pair, in `order`.
    pub held: Vec<HeldPair>,
    /// The quiet ones among them (`PairEnds::quiet`), by index into `held`, with their slots
    /// in their group's numbering: each group takes them after its other constraints.
    pub quiet: Vec<(u32, [u32; 2])>,
    /// The constraints in three groups: those among the bodies of one side of the scene, of
    /// the other, and across (see `solver::build_constraints`). The first two are solved at
    /// once on two threads, the third after them.
    pub groups: [ConstraintGroup; 3],
    /// Each pair's contact anchors (in `pairs` order) when found this step; a recycled pair's
    /// are its entry's in `cache`, not copied here.
    pub anchors: Vec<ContactAnchors>,
    /// Whether each pair's anchors was recycled from the previous step.
    pub recycled: Vec<bool>,
    /// Each pair's impulses from last step's matching points (in `pairs` order), matched when
    /// its manifold is found: building the constraints reads them here, in solving order,
    /// instead of from the cache entries and anchors, which that order visits at random.
    pub warm: Vec<WarmStart>,
    /// Each pair's index in `cache` (`u32::MAX` for none).
    pub cached: Vec<u32>,
    /// The held pairs' indices into `held` (their places in `order`), in pair order, so by
    /// cache entry: `solve::remember` fills it, and the next step's order starts from it.
    pub by_pair: Vec<u32>,
    /// Last step's anchors and impulses by pair, in pair order (found through `cached`).
    /// Whatever writes it writes `cache_keys` too (`set_cache`).
    pub cache: Vec<((u32, u32), CachedManifold)>,
    /// The keys of `cache`'s entries, in its order: what `entries_of` merges the pairs with,
    /// 8 bytes an entry where a whole entry is about 300.
    pub cache_keys: Vec<(u32, u32)>,
    /// Scratch of `solve::remember`: the next cache, written while the recycled pairs' anchors
    /// are still read from `cache`, then swapped with it.
    pub next_cache: Vec<((u32, u32), CachedManifold)>,
    /// `prune`'s recycling verdicts by entry of `cache` (`Recycling`), for `solve` in the
    /// same step; entries of earlier steps are stale, not cleared.
    pub recycling: Vec<Recycling>,
    /// `PosedCache::moves` when `prune` worked the verdicts out: `solve` takes them only if no
    /// body moved since.
    pub recycling_moves: u64,
    /// The step these constraints belong to (`correct` uses them only if `solve` ran this step).
    pub step: u64,
    /// The free bodies of the constraints, each once, in solver-body order (the static slots
    /// between the sides and at the end skipped).
    pub moving: Vec<u32>,
    /// The fixed bodies of the constraints, each once (all in the last static slot).
    pub fixed: Vec<u32>,
    /// Free bodies on the first side; solver body `left` is that side's static slot.
    pub left: usize,
    /// The second side holds constraints: the scene is cut in two (`constraints::gather_bodies`).
    pub split: bool,
    /// Both sides' constraints are in the first group, numbered across both sides (one thread
    /// solves them; `build_constraints`).
    pub merged: bool,
    /// Scratch: each free body's coordinate along the split, with its actor index.
    pub keys: Vec<(u64, u32)>,
    /// Scratch: the same along the vertical, while the two cuts are compared.
    pub upright: Vec<(u64, u32)>,
    /// Scratch of the solving order's sort: the held pairs by their place in last step's order.
    pub ranked: Vec<(u64, u32)>,
    /// Scratch of the solving order's sort: the held pairs that were not held last step.
    pub unranked: Vec<(u64, u32)>,
    /// Each pair's bodies and points held (`PairEnds`), in pair order: what building the
    /// constraints reads of the pairs and manifolds, compact.
    pub ends: Vec<PairEnds>,
    /// Each actor's solver-body slot (`u32::MAX` when not in a held pair this step; fixed
    /// bodies map to the last static slot).
    pub slot: Vec<u32>,
    /// The solver bodies: the first side's free bodies, its static slot, the second side's,
    /// the last static slot (`solver::build_constraints`).
    pub bodies: Vec<SolverBody>,
    /// Each actor's speculative distance this step (`StepContext::speculative_distances`).
    pub speculative: Vec<Scalar>,
    /// S = (I⁻¹)^½ in world axes of each solver body (zero for the static slots).
    pub scale: Vec<Mat3>,
    /// Scratch of the substeps: each solver body's velocities (v, ŵ) when last kept
    /// (`drive::Step::Keep`).
    pub kept: Vec<[Vector; 2]>,
    /// The actors the joints hold, each once, in order of first mention (empty without
    /// joints): they get solver bodies whether or not they touch anything.
    pub jointed: Vec<u32>,
}

impl SolveScratch {
    /// Replaces the warm-start cache (entries sorted by key, no repeats) and its keys.
    pub fn set_cache(&mut self, cache: Vec<((u32, u32), CachedManifold)>) {
        self.cache_keys.clear();
        self.cache_keys.extend(cache.iter().map(|e| e.0));
        self.cache = cache;
    }

    /// Each pair's index in `cache` (`u32::MAX` for none), into `out`: `cache_entries` on the
    /// compact keys.
    pub fn entries_of(&self, pairs: &[Pair], out: &mut Vec<u32>) {
        debug_assert_eq!(self.cache_keys.len(), self.cache.len(), "the keys are the cache's");
        merge_entries(self.cache_keys.len(), |e| self.cache_keys[e], pairs, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The merge finds each pair's entry as a search of the whole list would, with entries
    /// past the last pair, pairs past the last entry, and both lists empty.
    #[test]
    fn each_pair_finds_its_entry_or_none() {
        let mut rng = crate::rng::SplitMix64::new(5);
        let mut out = Vec::new();
        for round in 0..200 {
            let mut keys: Vec<(u32, u32)> = (0..rng.next_u64() % 40)
                .map(|_| {
                    let a = (rng.next_u64() % 12) as u32;
                    (a, a + 1 + (rng.next_u64() % 12) as u32)
                })
                .collect();
            // The largest actor indices too, where packing the two into one number matters.
            if round % 7 == 0 {
                keys.push((u32::MAX - 1, u32::MAX));
            }
            keys.sort_unstable();
            keys.dedup();
            if round == 0 {
                keys.clear();
            }
            let cache: Vec<((u32, u32), ())> = keys.iter().map(|&k| (k, ())).collect();
            let mut pairs: Vec<Pair> = (0..rng.next_u64() % 40)
                .map(|_| {
                    let a = (rng.next_u64() % 14) as u32;
                    Pair::candidate(a, a + 1 + (rng.next_u64() % 14) as u32)
                })
                .collect();
            if round % 5 == 0 {
                pairs.push(Pair::candidate(u32::MAX - 1, u32::MAX));
            }
            pairs.sort_unstable_by_key(|p| (p.a, p.b));
            pairs.dedup_by_key(|p| (p.a, p.b));
            if round == 0 {
                pairs.clear();
            }
            cache_entries(&cache, &pairs, &mut out);
            let want: Vec<u32> = pairs
                .iter()
                .map(|p| keys.iter().position(|&k| k == (p.a, p.b)).map_or(u32::MAX, |e| e as u32))
                .collect();
            assert_eq!(out, want, "keys {keys:?}");
        }
    }
}
