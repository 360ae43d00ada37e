//! `cull`: the broad phase. Bounding spheres about the centre of mass overlap
//! (docs/physics.md §1.2, erratum E1). Two systems share the predicate and emit the same sorted pair
//! list: `cull_all_pairs`, the paper's O(N²) loop kept as the reference, and `cull`, a uniform
//! grid, near-linear in N.

use crate::collision::contact::Pair;
use crate::math::{Scalar, Vector};
use crate::sim::context::StepContext;
use crate::solver::Joints;
use hecs::World;
use rayon::prelude::*;

/// The candidate test: `|x_a − x_b| ≤ r_a + r_b`. The paper compares half a centre-to-corner
/// distance against each radius separately, which misses touching cubes (E1).
#[must_use]
pub fn spheres_overlap(xa: Vector, ra: Scalar, xb: Vector, rb: Scalar) -> bool {
    let r = ra + rb;
    (xa - xb).length_squared() <= r * r
}

/// The paper's all-pairs broad phase: every pair (a < b) whose spheres overlap, skipping
/// pairs of two fixed actors (they never move, so never need an impulse).
///
/// - Reads: `ctx.bodies`, the joints (`Joints`: joined pairs are skipped). Writes: `ctx.pairs` (appends
///   `Candidate`s, sorted), `ctx.stats`.
/// - Paper: bounding box check; docs/physics.md §1.2, E1. Cost: O(N²).
pub fn cull_all_pairs(_world: &mut World, ctx: &mut StepContext) {
    reach(ctx);
    let (b, reach) = (&ctx.bodies, &ctx.scratch.get_mut::<CullScratch>().reach);
    for i in 0..b.len() {
        for j in i + 1..b.len() {
            if !(b.is_fixed(i) && b.is_fixed(j)) && spheres_overlap(b.position[i], reach[i], b.position[j], reach[j]) {
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
/// frictionless scenes see the paper's spheres).
fn reach(ctx: &mut StepContext) {
    let (b, params, dt) = (&ctx.bodies, &ctx.params, ctx.dt);
    let reach = &mut ctx.scratch.get_mut::<CullScratch>().reach;
    reach.clear();
    reach.extend((0..b.len()).map(|i| b.radius[i] + params.speculative_distance(dt, b, i)));
}

/// Radii more than this many times the median go on the short "large" list tested against
/// everything, so one wall does not blow up the cell size for thousands of small bodies.
const LARGE_RADIUS_FACTOR: Scalar = 4.0;
/// The grid may have at most this many cells per ordinary body (memory bound for sparse
/// scenes: the cell grows until it fits).
const CELLS_PER_BODY: usize = 4;
/// Most cells along one axis while the cell size is being found (any larger count is cut
/// down by the size search anyway).
const MAX_DIM: Scalar = (1u64 << 32) as Scalar;
/// Bodies per parallel work chunk of the pair search: small enough that the rain's 1 000 cubes
/// make four (its cull went from 0.33 to 0.23 ms on two threads), the chunks' pairs joined
/// in order, so the list is the same for any count.
const CHUNK: usize = 256;

/// Uniform-grid broad phase, the default: the same pairs, in the same order, as
/// `cull_all_pairs`.
///
/// - Reads: `ctx.bodies`, the joints. Writes: `ctx.pairs`, `ctx.stats`, its `CullScratch`.
/// - Paper: bounding box check (its all-pairs loop replaced; ARCHITECTURE.md says why a grid and
///   not sweep-and-prune: box-gas's slabs of equal cubes overlap on any one axis).
/// - Cost: O(N) to bin, O(N·k) for k neighbours per body, plus O(N·L) for L large bodies.
pub fn cull(_world: &mut World, ctx: &mut StepContext) {
    let n = ctx.bodies.len();
    reach(ctx);
    let s = ctx.scratch.get_mut::<CullScratch>();
    let b = &ctx.bodies;
    let reach = std::mem::take(&mut s.reach);
    let threshold = large_threshold(&reach, &mut s.radii);
    s.large.clear();
    s.large.extend((0..n as u32).filter(|&i| reach[i as usize] > threshold));
    let grid = Grid::build(b, &reach, threshold, s);
    let chunks = n.div_ceil(CHUNK);
    if s.chunks.len() < chunks {
        s.chunks.resize_with(chunks, Vec::new);
    }
    let (large, cell_start, order) = (&s.large, &s.cell_start, &s.order);
    s.chunks[..chunks].par_iter_mut().enumerate().for_each(|(c, out)| {
        out.clear();
        for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
            let first = out.len();
            grid.pairs_of(i, b, &reach, (cell_start, order), large, out);
            out[first..].sort_unstable_by_key(|&(_, b)| b);
        }
    });
    for chunk in &s.chunks[..chunks] {
        ctx.pairs.extend(chunk.iter().map(|&(a, b)| Pair::candidate(a, b)));
    }
    s.reach = reach;
    drop_jointed(ctx);
    ctx.stats.candidates = ctx.pairs.len();
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
#[derive(Clone, Copy)]
struct Grid {
    origin: Vector,
    cell: Scalar,
    dims: [usize; 3],
    threshold: Scalar,
}

impl Grid {
    fn build(b: &crate::sim::bodies::Bodies, radius: &[Scalar], threshold: Scalar, s: &mut CullScratch) -> Self {
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
        // least that wide, they sit in the same or neighbouring cells.
        let mut cell = (2.0 * r_max).max(Scalar::MIN_POSITIVE);
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
        s.order.clear();
        s.order.resize(count, CellEntry::default());
        s.fill.clear();
        s.fill.extend_from_slice(&s.cell_start);
        for i in ordinary() {
            let c = s.cell_of[i] as usize;
            s.order[s.fill[c] as usize] =
                CellEntry { position: b.position[i], radius: radius[i], index: i as u32, fixed: b.is_fixed(i) };
            s.fill[c] += 1;
        }
        grid
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
        b: &crate::sim::bodies::Bodies,
        radius: &[Scalar],
        (start, order): (&[u32], &[CellEntry]),
        large: &[u32],
        out: &mut Vec<(u32, u32)>,
    ) {
        let (xi, ri, fixed_i) = (b.position[i], radius[i], b.is_fixed(i));
        // The candidate test of `cull_all_pairs`, given body j's centre, radius and fixedness.
        let consider = |j: usize, xj: Vector, rj: Scalar, fixed_j: bool, out: &mut Vec<(u32, u32)>| {
            if j > i && !(fixed_i && fixed_j) && spheres_overlap(xi, ri, xj, rj) {
                out.push((i as u32, j as u32));
            }
        };
        let consider_row =
            |j: usize, out: &mut Vec<(u32, u32)>| consider(j, b.position[j], radius[j], b.is_fixed(j), out);
        if ri > self.threshold {
            (i + 1..b.len()).for_each(|j| consider_row(j, out));
            return;
        }
        let c = self.coords(xi);
        let range = |k: usize| c[k].saturating_sub(1)..=(c[k] + 1).min(self.dims[k] - 1);
        for z in range(2) {
            for y in range(1) {
                let row = self.index([0, y, z]);
                let (x0, x1) = (*range(0).start(), *range(0).end());
                for e in &order[start[row + x0] as usize..start[row + x1 + 1] as usize] {
                    consider(e.index as usize, e.position, e.radius, e.fixed, out);
                }
            }
        }
        for &j in large {
            consider_row(j as usize, out);
        }
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
}
