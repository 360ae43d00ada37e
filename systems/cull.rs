//! `cull`: the broad phase. Bounding spheres about the centre of mass overlap
//! (docs/physics.md §1.2, erratum E1), and so do the bodies' world boxes widened by the
//! margins `prune` holds pairs within (`Bounds`). Two systems share the predicate and emit the
//! same sorted pair list: `cull_all_pairs`, the paper's O(N²) loop kept as the reference, and
//! `cull`, a uniform grid, near-linear in N.

use crate::collision::contact::Pair;
use crate::math::{Scalar, Vector};
use crate::model::mesh::MeshTable;
use crate::sim::bodies::Bodies;
use crate::sim::context::StepContext;
use crate::solver::Joints;
use crate::systems::prune::PRUNE_MARGIN;
use cells::AnchorCells;
use hecs::World;
use rayon::prelude::*;

mod cells;

/// The candidate test: `|x_a − x_b| ≤ r_a + r_b`. The paper compares half a centre-to-corner
/// distance against each radius separately, which misses touching cubes (E1).
#[must_use]
pub fn spheres_overlap(xa: Vector, ra: Scalar, xb: Vector, rb: Scalar) -> bool {
    let r = ra + rb;
    (xa - xb).length_squared() <= r * r
}

/// The paper's all-pairs broad phase: every pair (a < b) whose spheres overlap, skipping
/// pairs of two fixed actors (they never move, so never need an impulse) and pairs whose
/// widened world boxes are apart (`Bounds`).
///
/// - Reads: `ctx.bodies`, the joints (`Joints`: joined pairs are skipped). Writes: `ctx.pairs` (appends
///   `Candidate`s, sorted), `ctx.stats`.
/// - Paper: bounding box check; docs/physics.md §1.2, E1. Cost: O(N²).
pub fn cull_all_pairs(_world: &mut World, ctx: &mut StepContext) {
    reach(ctx);
    let rows = &ctx.scratch.get_mut::<CullScratch>().bounds.rows;
    for i in 0..rows.len() {
        for j in i + 1..rows.len() {
            if rows[i].candidates(&rows[j]) {
                ctx.pairs.push(Pair::candidate(i as u32, j as u32));
            }
        }
    }
    drop_jointed(ctx);
    ctx.stats.candidates = ctx.pairs.len();
}

/// Drops the pairs a joint joins without `collide` (docs/joints.md): a hinge's two halves
/// overlap at the hinge by design.
fn drop_jointed(ctx: &mut StepContext) {
    if let Some(joints) = ctx.scratch.get::<Joints>().filter(|j| !j.no_collide.is_empty()) {
        ctx.pairs.retain(|p| !joints.keeps_apart(p.a, p.b));
    }
}

/// Fills `CullScratch::reach`: each bounding radius widened by the body's speculative
/// distance (`Params::speculative_distance`; zero without gravity and friction, so the paper's
/// frictionless scenes see the paper's spheres); and `CullScratch::bounds`.
fn reach(ctx: &mut StepContext) {
    let mut reach = std::mem::take(&mut ctx.scratch.get_mut::<CullScratch>().reach);
    ctx.speculative_distances(&mut reach);
    let (b, params) = (&ctx.bodies, &ctx.params);
    let s = ctx.scratch.get_mut::<CullScratch>();
    s.bounds.fill(b, &ctx.meshes, params.contact_margin, &reach);
    reach.iter_mut().zip(&b.radius).for_each(|(r, radius)| *r += radius);
    s.reach = reach;
}

/// Each body's world box, widened so that two boxes apart prove a pair farther apart than any
/// margin `prune` holds it within (`prune::pair_margin`: the thinner body's contact margin plus
/// both speculative distances, at least the proof margin): such a pair is one `prune` would drop.
/// A box's box from its rotation; any other mesh's is its bounding sphere's, which the sphere
/// test already covers. Resting cubes' spheres reach well past their faces, and most of the
/// pairs they give are apart along a world axis: dropped here, they cost `prune` nothing.
#[derive(Clone, Debug, Default)]
pub struct Bounds {
    /// Each body's, by actor index.
    pub rows: Vec<BodyBounds>,
}

/// What the candidate test reads of one body, side by side: a kept list's filter reads two
/// rows a pair.
#[derive(Clone, Copy, Debug, Default)]
pub struct BodyBounds {
    /// Centre of mass [m].
    pub centre: Vector,
    /// Bounding radius widened by the speculative distance (`CullScratch::reach`) [m].
    pub reach: Scalar,
    /// Lower corner of the widened world box [m].
    pub lo: Vector,
    /// Upper corner of the widened world box [m].
    pub hi: Vector,
    /// Fixed (or asleep).
    pub fixed: bool,
}

impl Bounds {
    /// Body i's widening is its speculative distance, half its contact margin (two halves sum
    /// to at least the thinner body's) and its share of the proof margin.
    fn fill(&mut self, b: &Bodies, meshes: &MeshTable, contact_margin: Scalar, speculative: &[Scalar]) {
        self.rows.clear();
        self.rows.extend(speculative.iter().enumerate().map(|(i, &d)| {
            let mesh = meshes.get(b.mesh[i]);
            let widen = d + 0.5 * contact_margin * mesh.thickness + PRUNE_MARGIN * b.radius[i];
            let r = b.rotation[i];
            let half = match mesh.box_half_extents {
                Some(h) => Vector::new(r.row(0).abs().dot(h), r.row(1).abs().dot(h), r.row(2).abs().dot(h)),
                None => Vector::splat(b.radius[i]),
            };
            let (centre, half) = (b.position[i], half + Vector::splat(widen));
            BodyBounds { centre, reach: d + b.radius[i], lo: centre - half, hi: centre + half, fixed: b.is_fixed(i) }
        }));
    }

    /// The widened boxes of bodies i and j overlap (or touch).
    #[inline]
    fn meet(&self, i: usize, j: usize) -> bool {
        self.rows[i].meets(&self.rows[j])
    }
}

impl BodyBounds {
    /// The candidate test of a pair of these two bodies: spheres overlap, not both fixed, boxes
    /// meet (`cull_all_pairs`, the kept list's filter; the plain grid has tested the first two).
    #[inline]
    fn candidates(&self, other: &Self) -> bool {
        spheres_overlap(self.centre, self.reach, other.centre, other.reach)
            & !(self.fixed & other.fixed)
            & self.meets(other)
    }

    /// The widened boxes overlap (or touch).
    #[inline]
    fn meets(&self, other: &Self) -> bool {
        let ((lo_i, hi_i), (lo_j, hi_j)) = ((self.lo, self.hi), (other.lo, other.hi));
        // Six comparisons and no branch: which pairs meet is close to random.
        (lo_i.x <= hi_j.x)
            & (lo_j.x <= hi_i.x)
            & (lo_i.y <= hi_j.y)
            & (lo_j.y <= hi_i.y)
            & (lo_i.z <= hi_j.z)
            & (lo_j.z <= hi_i.z)
    }
}

/// Radii more than this many times the median go on the short "large" list tested against
/// everything, so one wall does not blow up the cell size for thousands of small bodies.
const LARGE_RADIUS_FACTOR: Scalar = 4.0;
/// The grid may have at most this many cells per ordinary body (memory bound for sparse
/// scenes: the cell grows until it fits).
const CELLS_PER_BODY: usize = 4;
/// Relative widening of the grid's cells over the largest overlap distance (see `Grid::build`).
const CELL_SLACK: Scalar = 1e-6;
/// Most cells along one axis while the cell size is being found (any larger count is cut
/// down by the size search anyway).
const MAX_DIM: Scalar = (1u64 << 32) as Scalar;
/// Bodies per parallel work chunk of the pair search: small enough that the rain's 1 000 cubes
/// make four (its cull went from 0.33 to 0.23 ms on two threads), the chunks' pairs joined
/// in order, so the list is the same for any count.
const CHUNK: usize = 256;
/// Fewest kept pairs a thread filters: fewer are not worth a thread's start.
const FILTER_CHUNK: usize = 1024;

/// Uniform-grid broad phase, the default: the same pairs, in the same order, as
/// `cull_all_pairs`. While bodies barely move it filters a kept list instead of rebuilding
/// the grid (`PairCache`).
///
/// - Reads: `ctx.bodies`, the joints. Writes: `ctx.pairs`, `ctx.stats`, its `CullScratch`.
/// - Paper: bounding box check (its all-pairs loop replaced; ARCHITECTURE.md says why a grid and
///   not sweep-and-prune: box-gas's slabs of equal cubes overlap on any one axis).
/// - Cost: O(N) to bin, O(N·k) for k neighbours per body, plus O(N·L) for L large bodies; on a
///   step the kept list still holds, O(N) plus its length.
pub fn cull(_world: &mut World, ctx: &mut StepContext) {
    reach(ctx);
    let s = ctx.scratch.get_mut::<CullScratch>();
    let (b, dt) = (&ctx.bodies, ctx.dt);
    if s.cache.holds(b, &s.reach) {
        if !s.cache.moved.is_empty() {
            s.cache.reanchor(b, dt, &s.reach);
        }
    } else {
        let reach = std::mem::take(&mut s.reach);
        if s.cache.rebuild_now() {
            let mut bound = std::mem::take(&mut s.cache.bound);
            bound.clear();
            bound.extend(reach.iter().enumerate().map(|(i, &r)| widened(b, dt, i, r)));
            let (chunks, grid) = grid_pairs(b, &bound, s);
            s.cache.rebuilt(b, bound, &s.chunks[..chunks], (grid, &s.cell_of));
        } else {
            let (chunks, _) = grid_pairs(b, &reach, s);
            for chunk in &s.chunks[..chunks] {
                let meet = chunk.iter().filter(|&&(i, j)| s.bounds.meet(i as usize, j as usize));
                ctx.pairs.extend(meet.map(|&(a, b)| Pair::candidate(a, b)));
            }
        }
        s.reach = reach;
    }
    if s.cache.valid {
        s.cache.filter(&s.bounds, &mut s.passed, &mut ctx.pairs);
    }
    drop_jointed(ctx);
    ctx.stats.candidates = ctx.pairs.len();
}

/// The grid search: every pair (a < b, not both fixed) whose spheres of radius `reach`
/// overlap, sorted, into `s.chunks[..count]` (concatenated in order); returns the count and
/// the grid (its bodies' cells in `s.cell_of`).
fn grid_pairs(b: &Bodies, reach: &[Scalar], s: &mut CullScratch) -> (usize, Grid) {
    let n = b.len();
    let threshold = large_threshold(reach, &mut s.radii);
    s.large.clear();
    s.large.extend((0..n as u32).filter(|&i| reach[i as usize] > threshold));
    let grid = Grid::build(b, reach, threshold, s);
    let chunks = n.div_ceil(CHUNK);
    if s.chunks.len() < chunks {
        s.chunks.resize_with(chunks, Vec::new);
    }
    let (large, cell_start, order) = (&s.large, &s.cell_start, &s.order);
    s.chunks[..chunks].par_iter_mut().enumerate().for_each(|(c, out)| {
        out.clear();
        for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
            let first = out.len();
            grid.pairs_of(i, b, reach, (cell_start, order), large, out);
            out[first..].sort_unstable_by_key(|&(_, b)| b);
        }
    });
    (chunks, grid)
}

/// The most room a body gets in a kept list, as a fraction of its reach: room to move before
/// the list must be built again (`widened`). A third of the reach keeps box-gas's fastest cubes
/// (0.18 m a step) in a list for several steps; a wider list costs more to filter each step
/// than its rarer rebuilds save (BENCH.md).
const MARGIN: Scalar = 0.3;
/// A slow body's room is what it would travel in this many steps at today's speed, at least
/// `MIN_ROOM` of its reach and at most `MARGIN`: a resting pile's list then holds little more
/// than its candidates, and the filter reads fewer pairs each step.
const ROOM_STEPS: Scalar = 8.0;
/// The least room, as a fraction of the reach.
const MIN_ROOM: Scalar = 0.05;
/// Relative room left for rounding in the two sphere tests and the distance moved (each a
/// few ulps, about 1e-15): see `PairCache`.
const SLACK: Scalar = 1e-9;
/// Relative rounding of a coordinate carried by a frame, with room: a few ulps.
const ROUNDING: Scalar = 4.0 * Scalar::EPSILON;
/// Bodies whose widened reach is below this [m] always rebuild: squares of smaller lengths
/// near the bottom of f64's range lose their relative precision.
const TINY: Scalar = 1e-140;
/// Most bodies anchored afresh in a step (each tested against the bodies of its neighbouring
/// cells, `AnchorCells`) before the whole list is built again instead: more cost more, in
/// sorting and merging their pairs into a list widened for fast bodies, than the grid (BENCH.md).
const MAX_MOVED: usize = 32;
/// A list that served fewer steps than this cost more than it saved: the plain grid runs for
/// a while (a list broken at once, as by cubes that fly apart). With moved bodies anchored
/// afresh by their cells, a list that serves two steps pays (BENCH.md).
const MIN_SERVED: u32 = 2;
/// Most plain grid steps in a row before a list is tried again, after lists that served fewer
/// than `MIN_SERVED` steps.
const MAX_BACKOFF: u32 = 32;

/// Body i's reach `r` widened by its room (`ROOM_STEPS`) for a kept list.
fn widened(b: &Bodies, dt: Scalar, i: usize, r: Scalar) -> Scalar {
    let travel = (b.velocity[i].length() + b.angular_velocity[i].length() * b.radius[i]) * dt;
    r + (ROOM_STEPS * travel).max(MIN_ROOM * r).min(MARGIN * r)
}

/// A superset of the candidate pairs, kept from step to step: the grid's pairs for reaches
/// widened by their room (`widened`) at some step (the rebuild), filtered each later step by the
/// exact test.
///
/// Why the filter gives exactly the grid's list: say body i was anchored (at the rebuild, or
/// later by `reanchor`) at `X_i` with widened reach `W_i`, the list holds every pair whose
/// spheres (X, W) overlap, and today, after every anchor is carried by one common translation
/// `T` (`frame`), body i is `d_i = |x_i − T − X_i|` away with reach `r_i`,
/// `d_i + r_i ≤ W_i·(1 − SLACK)` (`holds`). If a pair passes today's test,
/// `|x_i − x_j| ≤ r_i + r_j`, then by the triangle inequality
/// `|X_i − X_j| ≤ |(x_i − T) − (x_j − T)| + d_i + d_j ≤ (W_i + W_j)·(1 − SLACK)`: its anchored
/// spheres overlap with room to spare, so it is in the list. A common translation moves no
/// body relative to another, so a rain falling as one keeps its list (`holds` tries the free
/// bodies' mean shift). SLACK dwarfs the rounding of the two tests and of `d_i` (relative
/// errors of a few ulps while no square leaves f64's normal range, which `TINY` ensures;
/// `ROUNDING` adds the rounding of `x_i − T`). The list is sorted, so the filtered one is in
/// the grid's order. A pair of two bodies fixed at their anchoring is left out: a body fixed then (fixed
/// or asleep) and free now is anchored afresh. Joined pairs are dropped after, as always.
#[derive(Clone, Debug, Default)]
pub struct PairCache {
    /// `pairs` is a list built as above and not yet broken.
    pub valid: bool,
    /// The superset, sorted by (a, b).
    pub pairs: Vec<(u32, u32)>,
    /// Each body's centre at its anchoring, less the `frame` of then [m].
    pub anchor: Vec<Vector>,
    /// The common translation `T` carrying the anchors to today's bodies [m]: zero at a
    /// rebuild, then the one `holds` found.
    pub frame: Vector,
    /// Each body's widened reach at its anchoring [m].
    pub bound: Vec<Scalar>,
    /// `bound·(1 − SLACK) − TINY`: the most `d_i + r_i` may be [m].
    pub limit: Vec<Scalar>,
    /// Each body was fixed (or asleep) at its anchoring.
    pub fixed: Vec<bool>,
    /// Steps the list has served, the rebuild's included.
    pub served: u32,
    /// Plain grid steps left before the next rebuild.
    pub skip: u32,
    /// The next `skip`: doubled each time a list serves too few steps, up to `MAX_BACKOFF`.
    pub backoff: u32,
    /// Scratch: the bodies outside their bounds this step.
    pub moved: Vec<u32>,
    /// Scratch: body i is in `moved`.
    pub mark: Vec<bool>,
    /// Scratch: the moved bodies' pairs, sorted.
    pub fresh: Vec<(u32, u32)>,
    /// Scratch: the merged list, swapped with `pairs`.
    pub spare: Vec<(u32, u32)>,
    /// The bodies binned by their anchors, for `reanchor`.
    cells: AnchorCells,
}

impl PairCache {
    /// The list still covers every candidate once the bodies that left their bounds (at most
    /// `MAX_MOVED`, listed in `moved`) are anchored afresh (`reanchor`): same body count, the
    /// others within their bounds and none of them fixed at its anchoring and free now. The
    /// bounds are tried carried by the free bodies' mean shift since their anchoring, then by
    /// last step's `frame`; the first that holds becomes the `frame`.
    fn holds(&mut self, b: &Bodies, reach: &[Scalar]) -> bool {
        self.moved.clear();
        if !self.valid || self.anchor.len() != b.len() {
            return false;
        }
        let free = (0..b.len()).filter(|&i| !b.is_fixed(i));
        let (sum, count) = free.fold((Vector::ZERO, 0_u32), |(s, n), i| (s + (b.position[i] - self.anchor[i]), n + 1));
        let mean = if count == 0 { self.frame } else { sum / Scalar::from(count) };
        let held = self.within(b, reach, mean) || (mean != self.frame && self.within(b, reach, self.frame));
        if held {
            self.served += 1;
        } else {
            self.moved.clear();
        }
        held
    }

    /// Lists in `moved` the bodies outside their bounds carried by `frame`, and sets the frame,
    /// unless more than `MAX_MOVED` are outside. `ROUNDING` covers the one rounding of
    /// `x − frame` that `x − X` alone would not have.
    fn within(&mut self, b: &Bodies, reach: &[Scalar], frame: Vector) -> bool {
        self.moved.clear();
        let shift = frame.abs().max_element();
        for (i, &r) in reach.iter().enumerate() {
            let x = b.position[i];
            let rounding = ROUNDING * (x.abs().max_element() + shift);
            let inside = (!self.fixed[i] || b.is_fixed(i))
                && ((x - frame) - self.anchor[i]).length() + r + rounding <= self.limit[i];
            if !inside {
                if self.moved.len() == MAX_MOVED {
                    return false;
                }
                self.moved.push(i as u32);
            }
        }
        self.frame = frame;
        true
    }

    /// Anchors the `moved` bodies where they are now and replaces their pairs by the ones
    /// their new bounds give, tested against the anchors of the bodies in their neighbouring
    /// cells (`AnchorCells`; every body, for one too wide for the cells): the list is then the
    /// one a rebuild with these anchors would give, in the same order.
    fn reanchor(&mut self, b: &Bodies, dt: Scalar, reach: &[Scalar]) {
        self.mark.resize(b.len(), false);
        for &k in &self.moved {
            let k = k as usize;
            self.anchor[k] = b.position[k] - self.frame;
            self.bound[k] = widened(b, dt, k, reach[k]);
            self.limit[k] = self.bound[k] * (1.0 - SLACK) - TINY;
            self.fixed[k] = b.is_fixed(k);
            self.mark[k] = true;
            self.cells.rebin(k, self.anchor[k], self.bound[k]);
        }
        self.fresh.clear();
        let (anchor, bound, fixed, mark, fresh) = (&self.anchor, &self.bound, &self.fixed, &self.mark, &mut self.fresh);
        for &k in &self.moved {
            let k = k as usize;
            let mut test = |j: usize| {
                // A pair of two moved bodies once, from the lower; none of two fixed ones.
                let skip = (mark[j] && j <= k) || (fixed[k] && fixed[j]);
                if !skip && spheres_overlap(anchor[k], bound[k], anchor[j], bound[j]) {
                    fresh.push((k.min(j) as u32, k.max(j) as u32));
                }
            };
            if !self.cells.near(k, anchor[k], &mut test) {
                (0..b.len()).for_each(test);
            }
        }
        self.fresh.sort_unstable();
        // The old pairs without the moved bodies' merged with the fresh ones (no pair is in
        // both: each fresh pair has a moved body). The few fresh pairs are placed by binary
        // search, and the old pairs between them copied in runs.
        let (old, mark) = (std::mem::take(&mut self.pairs), &self.mark);
        let kept = |&(a, c): &(u32, u32)| !mark[a as usize] && !mark[c as usize];
        self.spare.clear();
        let mut rest = &old[..];
        for &pair in &self.fresh {
            let before = rest.partition_point(|&p| p < pair);
            self.spare.extend(rest[..before].iter().filter(|p| kept(p)));
            self.spare.push(pair);
            rest = &rest[before..];
        }
        self.spare.extend(rest.iter().filter(|p| kept(p)));
        self.pairs = std::mem::replace(&mut self.spare, old);
        for &k in &self.moved {
            self.mark[k as usize] = false;
        }
    }

    /// Whether to rebuild the list on a step it does not hold, or run the plain grid: after a
    /// list that served fewer than `MIN_SERVED` steps the next few steps go without.
    fn rebuild_now(&mut self) -> bool {
        if self.valid && self.served < MIN_SERVED {
            self.skip = self.backoff.max(1);
            self.backoff = (2 * self.skip).min(MAX_BACKOFF);
        } else if self.valid {
            self.backoff = 1;
        }
        self.valid = false;
        self.cells.clear();
        if self.skip > 0 {
            self.skip -= 1;
            return false;
        }
        true
    }

    /// Keeps the grid's pairs for the widened reaches `bound`, what they assumed, and the
    /// grid's cells with each body's (`cell_of`) for `reanchor`.
    fn rebuilt(&mut self, b: &Bodies, bound: Vec<Scalar>, chunks: &[Vec<(u32, u32)>], (grid, cell_of): (Grid, &[u32])) {
        self.cells.build(grid, cell_of);
        self.pairs.clear();
        for chunk in chunks {
            self.pairs.extend_from_slice(chunk);
        }
        self.anchor.clear();
        self.anchor.extend_from_slice(&b.position);
        self.frame = Vector::ZERO;
        self.limit.clear();
        self.limit.extend(bound.iter().map(|w| w * (1.0 - SLACK) - TINY));
        self.fixed.clear();
        self.fixed.extend((0..b.len()).map(|i| b.is_fixed(i)));
        self.bound = bound;
        self.valid = true;
        self.served = 1;
    }

    /// Appends the kept pairs that pass `cull_all_pairs`'s test today. Every kept pair is
    /// written and the count moved on past those that pass: about half of a resting rain's
    /// 12 000 pass, at random, and a branch on each, mispredicted that often, cost more. A part
    /// of the list per thread, into `passed`, joined in order: the same list on any count.
    fn filter(&self, bounds: &Bounds, passed: &mut Vec<(usize, Vec<(u32, u32)>)>, out: &mut Vec<Pair>) {
        let size = self.pairs.len().div_ceil(rayon::current_num_threads()).max(FILTER_CHUNK);
        let count = self.pairs.len().div_ceil(size);
        if passed.len() < count {
            passed.resize_with(count, Default::default);
        }
        let rows = &bounds.rows[..];
        // Each part's buffer keeps its length from step to step (no clearing, no zeroing);
        // the count says how much of it passed. The count is kept in a local until the end:
        // the parts' counts share a cache line, which two threads writing at every pair
        // passed back and forth (BENCH.md, session 36).
        self.pairs.par_chunks(size).zip(passed[..count].par_iter_mut()).for_each(|(pairs, (n, kept))| {
            if kept.len() < pairs.len() {
                kept.resize(pairs.len(), (0, 0));
            }
            let (kept, mut met) = (&mut kept[..pairs.len()], 0);
            for &(i, j) in pairs {
                kept[met] = (i, j);
                met += usize::from(rows[i as usize].candidates(&rows[j as usize]));
            }
            *n = met;
        });
        for (n, kept) in &passed[..count] {
            out.extend(kept[..*n].iter().map(|&(i, j)| Pair::candidate(i, j)));
        }
    }
}

/// `LARGE_RADIUS_FACTOR` × the median radius (∞ when there are no bodies).
fn large_threshold(radius: &[Scalar], buffer: &mut Vec<Scalar>) -> Scalar {
    if radius.is_empty() {
        return Scalar::INFINITY;
    }
    buffer.clear();
    buffer.extend_from_slice(radius);
    let mid = buffer.len() / 2;
    let (_, median, _) = buffer.select_nth_unstable_by(mid, Scalar::total_cmp);
    LARGE_RADIUS_FACTOR * *median
}

/// A dense grid over the ordinary bodies, binned by counting sort.
#[derive(Clone, Copy, Debug)]
struct Grid {
    origin: Vector,
    cell: Scalar,
    dims: [usize; 3],
    threshold: Scalar,
}

impl Grid {
    fn build(b: &Bodies, radius: &[Scalar], threshold: Scalar, s: &mut CullScratch) -> Self {
        let ordinary = || (0..b.len()).filter(|&i| radius[i] <= threshold);
        let (mut lo, mut hi, mut r_max) =
            (Vector::splat(Scalar::INFINITY), Vector::splat(Scalar::NEG_INFINITY), 0.0_f64);
        let mut count = 0;
        for i in ordinary() {
            lo = lo.min(b.position[i]);
            hi = hi.max(b.position[i]);
            r_max = r_max.max(radius[i]);
            count += 1;
        }
        // Two overlapping ordinary spheres have centres at most 2·r_max apart: with cells at
        // least that wide, they sit in the same or neighbouring cells. A hair wider, because
        // rounding in `coords` can put centres exactly 2·r_max apart two cells apart.
        let mut cell = (2.0 * r_max * (1.0 + CELL_SLACK)).max(Scalar::MIN_POSITIVE);
        let extent = if count == 0 { Vector::ZERO } else { hi - lo };
        // Capped before the cast: a scene 1e20 m across must not overflow the cell count.
        let dims_for = |cell: Scalar| (extent / cell).to_array().map(|e| e.floor().min(MAX_DIM) as usize + 1);
        let cells_for = |d: [usize; 3]| d.iter().fold(1_usize, |n, &k| n.saturating_mul(k));
        let mut dims = dims_for(cell);
        while cells_for(dims) > CELLS_PER_BODY * count.max(1) {
            cell *= 1.5;
            if !cell.is_finite() {
                // Spread over more than f64 can span: one cell holds them all.
                (cell, dims) = (Scalar::MAX, [1; 3]);
                break;
            }
            dims = dims_for(cell);
        }
        let grid = Self { origin: lo, cell, dims, threshold };
        let cells = dims.iter().product::<usize>();
        s.cell_of.clear();
        s.cell_of.resize(b.len(), u32::MAX);
        s.cell_start.clear();
        s.cell_start.resize(cells + 1, 0);
        for i in ordinary() {
            let c = grid.index(grid.coords(b.position[i]));
            s.cell_of[i] = c as u32;
            s.cell_start[c + 1] += 1;
        }
        for c in 0..cells {
            s.cell_start[c + 1] += s.cell_start[c];
        }
        s.order.reset(count);
        s.fill.clear();
        s.fill.extend_from_slice(&s.cell_start);
        for i in ordinary() {
            let c = s.cell_of[i] as usize;
            s.order.set(s.fill[c] as usize, b.position[i], radius[i], i as u32, b.is_fixed(i));
            s.fill[c] += 1;
        }
        grid
    }

    /// The widest radius two bodies may have for the grid to find them in neighbouring cells
    /// when their spheres overlap (the argument in `build`).
    fn fit(&self) -> Scalar {
        self.cell / (2.0 * (1.0 + CELL_SLACK))
    }

    /// The cell coordinates, axis by axis, of the cell of `x` and its neighbours.
    fn around(&self, x: Vector) -> [std::ops::RangeInclusive<usize>; 3] {
        let c = self.coords(x);
        [0, 1, 2].map(|k| c[k].saturating_sub(1)..=(c[k] + 1).min(self.dims[k] - 1))
    }

    fn coords(&self, x: Vector) -> [usize; 3] {
        let c = ((x - self.origin) / self.cell).to_array();
        [0, 1, 2].map(|k| (c[k].floor().max(0.0) as usize).min(self.dims[k] - 1))
    }

    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Appends the candidates (i, j > i) of body i, unsorted.
    fn pairs_of(
        &self,
        i: usize,
        b: &Bodies,
        radius: &[Scalar],
        (start, order): (&[u32], &CellBodies),
        large: &[u32],
        out: &mut Vec<(u32, u32)>,
    ) {
        let (xi, ri, fixed_i) = (b.position[i], radius[i], b.is_fixed(i));
        // The candidate test of `cull_all_pairs`, given body j's centre, radius and fixedness,
        // for the large bodies (the grid's cells go through `CellBodies::scan`). Every body
        // tested is written after the last candidate and counted only if it is one:
        // which neighbours pass is close to random, and a branch on it would be mispredicted
        // about as often as not.
        let mut n = out.len();
        let consider = |n: usize, (j, xj, rj, fixed_j): (usize, Vector, Scalar, bool), out: &mut [(u32, u32)]| {
            out[n] = (i as u32, j as u32);
            n + usize::from((j > i) & !(fixed_i & fixed_j) & spheres_overlap(xi, ri, xj, rj))
        };
        let row_of = |j: usize| (j, b.position[j], radius[j], b.is_fixed(j));
        if ri > self.threshold {
            out.resize(n + b.len() - (i + 1), (0, 0));
            for j in i + 1..b.len() {
                n = consider(n, row_of(j), out);
            }
            out.truncate(n);
            return;
        }
        let [xs, ys, zs] = self.around(xi);
        for z in zs {
            for y in ys.clone() {
                let row = self.index([0, y, z]);
                let (x0, x1) = (*xs.start(), *xs.end());
                let run = start[row + x0] as usize..start[row + x1 + 1] as usize;
                order.scan(run, (i as u32, xi, ri, fixed_i), out);
            }
        }
        n = out.len();
        out.resize(n + large.len(), (0, 0));
        for &j in large {
            n = consider(n, row_of(j as usize), out);
        }
        out.truncate(n);
    }
}

/// The grid's bodies sorted by cell, a field to an array, so that a neighbour scan tests four
/// bodies at once (`scan`). `SCAN_LANES − 1` entries infinitely far away follow the last, so
/// that the last four of a run may be read past its end.
#[derive(Clone, Debug, Default)]
pub struct CellBodies {
    /// Centres' x, y and z [m].
    pub x: Vec<Scalar>,
    pub y: Vec<Scalar>,
    pub z: Vec<Scalar>,
    /// Bounding radii (widened, as the search is asked) [m].
    pub radius: Vec<Scalar>,
    /// Actor indices.
    pub index: Vec<u32>,
    /// Fixed actors.
    pub fixed: Vec<bool>,
}

/// Bodies a scan tests at once: one `f64x4` register a field.
const SCAN_LANES: usize = 4;

impl CellBodies {
    /// Makes room for `count` bodies and the padding after them.
    fn reset(&mut self, count: usize) {
        let len = count + SCAN_LANES - 1;
        for v in [&mut self.x, &mut self.y, &mut self.z] {
            v.clear();
            v.resize(len, Scalar::INFINITY);
        }
        self.radius.clear();
        self.radius.resize(len, 0.0);
        self.index.clear();
        self.index.resize(len, 0);
        self.fixed.clear();
        self.fixed.resize(len, true);
    }

    /// Entry k: body `index` at `x`.
    fn set(&mut self, k: usize, x: Vector, radius: Scalar, index: u32, fixed: bool) {
        (self.x[k], self.y[k], self.z[k], self.radius[k]) = (x.x, x.y, x.z, radius);
        (self.index[k], self.fixed[k]) = (index, fixed);
    }

    /// Appends `(i, j)` for each body j of `run` that is a candidate partner of body i (centre
    /// `xi`, radius `ri`): `j > i`, not both fixed, spheres overlapping. `spheres_overlap`'s
    /// arithmetic four bodies at a time (the same bits: the difference's sign does not change
    /// its square), so only the rare overlaps branch.
    #[inline]
    fn scan(
        &self,
        run: std::ops::Range<usize>,
        (i, xi, ri, fixed_i): (u32, Vector, Scalar, bool),
        out: &mut Vec<(u32, u32)>,
    ) {
        type Reg = wide::f64x4;
        let (px, py, pz, pr) = (Reg::splat(xi.x), Reg::splat(xi.y), Reg::splat(xi.z), Reg::splat(ri));
        // One bounds check for a field's four lanes, not one a lane.
        let load = |v: &[Scalar], k: usize| -> Reg {
            let four: [Scalar; SCAN_LANES] = v[k..k + SCAN_LANES].try_into().expect("four lanes");
            Reg::new(four)
        };
        let mut k = run.start;
        while k < run.end {
            let (dx, dy, dz) = (load(&self.x, k) - px, load(&self.y, k) - py, load(&self.z, k) - pz);
            let r = load(&self.radius, k) + pr;
            let within = if run.end - k >= SCAN_LANES { 0b1111 } else { (1_u32 << (run.end - k)) - 1 };
            let mut hits = (dx * dx + dy * dy + dz * dz).simd_le(r * r).to_bitmask() & within;
            k += SCAN_LANES;
            while hits != 0 {
                let l = k - SCAN_LANES + hits.trailing_zeros() as usize;
                hits &= hits - 1;
                let j = self.index[l];
                if j > i && !(fixed_i && self.fixed[l]) {
                    out.push((i, j));
                }
            }
        }
    }
}

/// Reused buffers of the grid broad phase (`cull`).
#[derive(Clone, Debug, Default)]
pub struct CullScratch {
    /// Each body's bounding radius widened by its speculative distance [m]
    /// (`Params::speculative_distance`).
    pub reach: Vec<Scalar>,
    /// Each body's widened world box (`Bounds`).
    pub bounds: Bounds,
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
    /// Bodies sorted by cell, with what the sphere test reads, so a neighbour scan reads
    /// contiguous runs.
    pub order: CellBodies,
    /// Pairs (a, b) found per chunk of bodies, concatenated in order; 8 bytes each, not a
    /// whole `Pair`, because at 64 000 cubes they are 270 000 and memory traffic dominates.
    pub chunks: Vec<Vec<(u32, u32)>>,
    /// The pairs kept from step to step while bodies barely move.
    pub cache: PairCache,
    /// The kept list's filter: each thread's part, its count of passing pairs first.
    pub passed: Vec<(usize, Vec<(u32, u32)>)>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounding_check_matches_t_bc() {
        // T-BC: unit cubes (ρ = √3/2) 1.7 apart are candidates, 1.75 apart are not.
        let r = 3f64.sqrt() / 2.0;
        assert!(spheres_overlap(Vector::ZERO, r, Vector::new(1.7, 0.0, 0.0), r));
        assert!(!spheres_overlap(Vector::ZERO, r, Vector::new(1.75, 0.0, 0.0), r));
        // Case (c): 0.1 cube at (0.9, 0.14, 0) over the 2 m rod (ρ = 1.00995): candidate, which
        // both readings of the paper's check miss (E1).
        let rod = (1.0f64 + 0.01 + 0.01).sqrt();
        assert!(spheres_overlap(Vector::ZERO, rod, Vector::new(0.9, 0.14, 0.0), 0.1 * r));
    }

    use crate::model::components::{Material, Pose, Velocity};
    use crate::model::mesh::ConvexMesh;
    use crate::rng::SplitMix64;
    use crate::sim::{BodyDef, Sim};
    use proptest::prelude::*;

    /// Which way `cull` went on its last call.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    enum Way {
        Plain,
        Rebuilt,
        Reanchored,
        Kept,
    }

    fn way(ctx: &mut StepContext) -> Way {
        match ctx.scratch.get_mut::<CullScratch>().cache {
            PairCache { valid: false, .. } => Way::Plain,
            PairCache { served: 1, .. } => Way::Rebuilt,
            PairCache { ref moved, .. } if !moved.is_empty() => Way::Reanchored,
            _ => Way::Kept,
        }
    }

    fn listed(ctx: &StepContext) -> Vec<(u32, u32)> {
        ctx.pairs.iter().map(|p| (p.a, p.b)).collect()
    }

    /// Snapshots the sim, lets `edit` change the bodies, and asserts that `cull` and
    /// `cull_all_pairs` list the same pairs; returns `cull`'s way and the list.
    fn check(sim: &mut Sim, edit: impl FnOnce(&mut Bodies)) -> (Way, Vec<(u32, u32)>) {
        sim.ctx.begin_step(&sim.world);
        sim.ctx.step -= 1; // no step is taken
        edit(&mut sim.ctx.bodies);
        cull(&mut sim.world, &mut sim.ctx);
        let (grid, w) = (listed(&sim.ctx), way(&mut sim.ctx));
        sim.ctx.pairs.clear();
        cull_all_pairs(&mut sim.world, &mut sim.ctx);
        assert_eq!(grid, listed(&sim.ctx), "{w:?}");
        (w, grid)
    }

    /// A body: cube edge, centre, fixed.
    type Cube = (Scalar, Vector, bool);

    /// The default schedule over `cubes` (friction 0.5, no bounce), with gravity or without.
    fn sim_of(cubes: &[Cube], gravity: bool) -> Sim {
        sim_with(cubes, gravity, |edge| ConvexMesh::cuboid(Vector::splat(edge)))
    }

    /// `sim_of` with each body's mesh made by `mesh` from its edge.
    fn sim_with(cubes: &[Cube], gravity: bool, mesh: fn(Scalar) -> ConvexMesh) -> Sim {
        let gravity = if gravity { Vector::new(0.0, -9.81, 0.0) } else { Vector::ZERO };
        let params = crate::sim::context::Params { gravity, ..Default::default() };
        let mut sim = Sim::new(1.0 / 60.0, params, crate::systems::default_schedule());
        for (k, &(edge, at, fixed)) in cubes.iter().enumerate() {
            let mesh = sim.add_mesh(mesh(edge));
            sim.spawn(&BodyDef {
                name: format!("cube-{k}"),
                mesh,
                mass: edge.powi(3),
                pose: Pose::from_position(at),
                velocity: Velocity::default(),
                material: Material { restitution: 0.0, friction: 0.5 },
                fixed,
            });
        }
        sim
    }

    /// Octahedra of bounding radius 0.5 (a cube's of edge 1/√3) on a 1 m lattice, their
    /// spheres touching their neighbours'; the first two fixed. Not cubes: those are apart
    /// by their boxes (`Bounds`), and these tests are about the spheres.
    fn lattice(nx: usize) -> Sim {
        let cubes: Vec<Cube> = (0..nx * nx * 2)
            .map(|k| {
                let (x, y, z) = (k % nx, k / nx % nx, k / (nx * nx));
                (1.0 / 3f64.sqrt(), Vector::new(x as Scalar, y as Scalar, z as Scalar), k < 2)
            })
            .collect();
        sim_with(&cubes, false, |_| {
            let (v, t) = crate::model::shapes::octahedron_raw(0.5);
            ConvexMesh::new(v, t).expect("valid").0
        })
    }

    /// A ground slab (a fixed 40 m cube whose top is at y = 0) and `cubes` above it.
    fn on_ground(mut cubes: Vec<Cube>) -> Sim {
        cubes.insert(0, (40.0, Vector::new(0.0, -20.0, 0.0), true));
        sim_of(&cubes, true)
    }

    /// `check` on a copy of the cull's scratch, so the sim's own calls go on undisturbed: the
    /// way returned is the one the sim's next step takes.
    fn check_aside(sim: &mut Sim) -> (Way, Vec<(u32, u32)>) {
        let kept = sim.ctx.scratch.get_mut::<CullScratch>().clone();
        let out = check(sim, |_| {});
        *sim.ctx.scratch.get_mut::<CullScratch>() = kept;
        out
    }

    fn positions(sim: &mut Sim) -> Vec<Vector> {
        sim.ctx.begin_step(&sim.world);
        sim.ctx.step -= 1;
        sim.ctx.bodies.position.clone()
    }

    fn set(pos: &[Vector]) -> impl FnOnce(&mut Bodies) + '_ {
        |b| b.position.copy_from_slice(pos)
    }

    #[test]
    fn kept_list_equals_all_pairs_through_every_way() {
        let mut sim = lattice(6);
        let mut pos = positions(&mut sim);
        let r = sim.ctx.bodies.radius[5];
        let mut rng = SplitMix64::new(7);
        let mut ways = Vec::new();
        // Small random walks: the kept list serves, pairs of touching balls come and go.
        for _ in 0..12 {
            for x in pos.iter_mut().skip(2) {
                *x += Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)) * 0.002 * r;
            }
            ways.push(check(&mut sim, set(&pos)).0);
        }
        assert_eq!(ways[0], Way::Rebuilt);
        assert!(ways[1..].iter().all(|&w| w == Way::Kept), "{ways:?}");
        // One ball moves past its margin, towards a neighbour it did not touch, then two.
        pos[20] += Vector::new(0.0, 0.0, 0.6);
        assert_eq!(check(&mut sim, set(&pos)).0, Way::Reanchored);
        pos[20] += Vector::new(0.3, 0.0, 0.0);
        pos[30] += Vector::new(0.3, 0.0, 0.0);
        assert_eq!(check(&mut sim, set(&pos)).0, Way::Reanchored);
        assert_eq!(check(&mut sim, set(&pos)).0, Way::Kept);
        // All free balls move together, past the most room any has (MARGIN times its reach):
        // the list holds, carried by their shift; only the two fixed balls, left behind, are
        // anchored afresh.
        let far = 1.5 * MARGIN * r;
        pos.iter_mut().skip(2).for_each(|x| *x += Vector::new(far, far, 0.0));
        let (w, _) = check(&mut sim, set(&pos));
        assert_eq!((w, sim.ctx.scratch.get_mut::<CullScratch>().cache.moved.clone()), (Way::Reanchored, vec![0, 1]));
        assert_eq!(check(&mut sim, set(&pos)).0, Way::Kept);
        // All move apart from each other: rebuilt; and again at once: a list that served one
        // step, so the plain grid for a while.
        let shift = |pos: &mut Vec<Vector>| {
            let apart = |k: usize| Vector::new(if k.is_multiple_of(2) { far } else { -far }, 0.0, 0.0);
            pos.iter_mut().skip(2).enumerate().for_each(|(k, x)| *x += apart(k));
        };
        shift(&mut pos);
        assert_eq!(check(&mut sim, set(&pos)).0, Way::Rebuilt);
        shift(&mut pos);
        assert_eq!(check(&mut sim, set(&pos)).0, Way::Plain);
        let mut later = Vec::new();
        for _ in 0..4 {
            later.push(check(&mut sim, set(&pos)).0);
        }
        assert_eq!(later, [Way::Rebuilt, Way::Kept, Way::Kept, Way::Kept]);
        // The two fixed balls touch but are no pair; one of them freed (woken) must be.
        assert!(!check(&mut sim, set(&pos)).1.contains(&(0, 1)));
        let (w, pairs) = check(&mut sim, |b| {
            b.position.copy_from_slice(&pos);
            b.inv_mass[1] = 1.0;
        });
        assert_eq!(w, Way::Reanchored);
        assert!(pairs.contains(&(0, 1)));
        // A structural change: the kept list moved into a sim with more bodies, then into one
        // with the same count at other places.
        let scratch = std::mem::take(&mut sim.ctx.scratch);
        let mut bigger = lattice(7);
        bigger.ctx.scratch = scratch;
        assert_eq!(check(&mut bigger, |_| {}).0, Way::Rebuilt);
        for _ in 1..MIN_SERVED {
            assert_eq!(check(&mut bigger, |_| {}).0, Way::Kept);
        }
        let scratch = std::mem::take(&mut bigger.ctx.scratch);
        let mut other = lattice(7);
        other.ctx.scratch = scratch;
        let sign = |k: usize| if k.is_multiple_of(2) { 0.3 } else { -0.3 };
        let moved = |b: &mut Bodies| b.position.iter_mut().enumerate().for_each(|(k, x)| x.y += sign(k));
        assert_eq!(check(&mut other, moved).0, Way::Rebuilt);
    }

    #[test]
    fn plain_grid_finds_exactly_touching_pairs_off_the_origin() {
        // Centres y = j + 0.3 exactly 1 m apart: (2.3 − 0.3) rounds below 2, (3.3 − 0.3) to 3,
        // so with cells exactly 1 m wide the two rows were not neighbours.
        let mut sim = lattice(7);
        sim.ctx.scratch.get_mut::<CullScratch>().cache.skip = 5;
        let shifted = |b: &mut Bodies| b.position.iter_mut().for_each(|x| *x += Vector::new(0.0, 0.3, 0.0));
        assert_eq!(check(&mut sim, shifted).0, Way::Plain);
    }

    #[test]
    fn a_settling_pyramid_keeps_its_list() {
        let mut cubes = Vec::new();
        for row in 0..6 {
            for j in 0..6 - row {
                let x = j as Scalar - (5 - row) as Scalar * 0.5;
                cubes.push((1.0, Vector::new(x, 0.5 + row as Scalar, 0.0), false));
            }
        }
        let mut sim = on_ground(cubes);
        let mut ways = Vec::new();
        for _ in 0..80 {
            sim.step().expect("finite");
            ways.push(check_aside(&mut sim).0);
        }
        assert!(ways.iter().filter(|&&w| w == Way::Kept).count() > 60, "{ways:?}");
    }

    #[test]
    fn a_rain_takes_every_way() {
        let mut rng = SplitMix64::new(3);
        let cubes = (0..128)
            .map(|k| {
                let (x, z, y) = ((k % 4) as Scalar * 1.5, (k / 4 % 4) as Scalar * 1.5, 1.0 + (k / 16) as Scalar * 2.5);
                (1.0, Vector::new(x + rng.uniform(-0.2, 0.2), y, z + rng.uniform(-0.2, 0.2)), false)
            })
            .collect();
        let mut sim = on_ground(cubes);
        let mut ways = Vec::new();
        for _ in 0..200 {
            sim.step().expect("finite");
            ways.push(check_aside(&mut sim).0);
        }
        // Then the cubes fly apart, each its own way at 30 m/s (half a metre a step): every
        // list breaks at once, and the plain grid runs.
        for (v, pose) in sim.world.query_mut::<(&mut Velocity, &Pose)>() {
            if pose.position.y > -10.0 {
                let d = Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(0.1, 1.0), rng.uniform(-1.0, 1.0));
                v.linear = 30.0 * d.normalize();
            }
        }
        for _ in 0..10 {
            sim.step().expect("finite");
            ways.push(check_aside(&mut sim).0);
        }
        for w in [Way::Plain, Way::Rebuilt, Way::Reanchored, Way::Kept] {
            assert!(ways.contains(&w), "{w:?} in {ways:?}");
        }
    }

    #[test]
    fn cubes_apart_by_their_world_boxes_are_no_pair_until_one_turns() {
        // Unit cubes 1.2 m apart along x and y: their centres 1.70 m apart, under the spheres'
        // 1.73, their boxes 0.2 m apart, ten times the widening (no gravity, no speed: only the
        // contact margin).
        let mut sim = sim_of(&[(1.0, Vector::ZERO, false), (1.0, Vector::new(1.2, 1.2, 0.0), false)], false);
        let r = 3f64.sqrt() / 2.0;
        assert!(spheres_overlap(Vector::ZERO, r, Vector::new(1.2, 1.2, 0.0), r));
        assert_eq!(check(&mut sim, |_| {}).1, []);
        // An eighth of a turn about z, the second reaches √½ m along x and y: the boxes meet.
        let q = crate::math::Quat::from_rotation_z(std::f64::consts::FRAC_PI_4);
        let turned = |b: &mut Bodies| (b.orientation[1], b.rotation[1]) = (q, crate::math::Mat3::from_quat(q));
        assert_eq!(check(&mut sim, turned).1, [(0, 1)]);
    }

    #[test]
    fn world_boxes_hold_a_turned_box_tightly_widened_by_its_margins() {
        let mut sim = sim_with(&[(0.5, Vector::new(1.0, -2.0, 3.0), false)], false, |e| {
            ConvexMesh::cuboid(Vector::new(e, 2.0 * e, 3.0 * e))
        });
        let mut rng = SplitMix64::new(11);
        sim.ctx.begin_step(&sim.world);
        for _ in 0..50 {
            let axis = Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
            let q = crate::math::Quat::from_axis_angle(axis.normalize(), rng.uniform(-3.0, 3.0));
            let b = &mut sim.ctx.bodies;
            (b.orientation[0], b.rotation[0]) = (q, crate::math::Mat3::from_quat(q));
            reach(&mut sim.ctx);
            let (b, mesh) = (&sim.ctx.bodies, sim.ctx.meshes.get(sim.ctx.bodies.mesh[0]));
            let widen = 0.5 * sim.ctx.params.contact_margin * mesh.thickness + PRUNE_MARGIN * b.radius[0];
            let row = sim.ctx.scratch.get_mut::<CullScratch>().bounds.rows[0];
            let (lo, hi) = (row.lo, row.hi);
            let corners = mesh.vertices.iter().map(|&v| b.position[0] + b.rotation[0] * v);
            let (low, high) = corners.fold((Vector::INFINITY, Vector::NEG_INFINITY), |(l, h), x| (l.min(x), h.max(x)));
            assert!((low - (lo + Vector::splat(widen))).abs().max_element() < 1e-14, "{low} {lo}");
            assert!((high - (hi - Vector::splat(widen))).abs().max_element() < 1e-14, "{high} {hi}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        #[test]
        fn kept_list_equals_all_pairs_on_random_walks(
            seed in any::<u64>(),
            n in 2usize..60,
            step in 0.0..0.2f64,
        ) {
            let mut rng = SplitMix64::new(seed);
            let cubes: Vec<Cube> = (0..n).map(|_| {
                let at = Vector::new(rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0));
                (rng.uniform(0.1, 1.4), at, rng.unit() < 0.2)
            }).collect();
            let mut sim = sim_of(&cubes, false);
            let mut pos = positions(&mut sim);
            for _ in 0..30 {
                // Mostly tiny moves, now and then one past the margin, now and then all carried
                // together (a falling crowd) by up to five steps; sometimes a fixed body wakes.
                let scale = if rng.unit() < 0.1 { step * 5.0 } else { step * 0.05 };
                let together = rng.unit() < 0.3;
                let drift = Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)) * step * 5.0;
                for x in &mut pos {
                    *x += Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)) * scale;
                    if together {
                        *x += drift;
                    }
                }
                let wake = (rng.unit() < 0.1).then(|| rng.next_u64() as usize % n);
                check(&mut sim, |b| {
                    b.position.copy_from_slice(&pos);
                    if let Some(i) = wake {
                        b.inv_mass[i] = 1.0;
                    }
                });
            }
        }
    }
}
