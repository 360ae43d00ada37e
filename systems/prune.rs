//! `prune`: drops candidate pairs that a separating axis proves apart. Not a paper stage: an
//! early-out that keeps the paper's three tests as the deciders of every contact, because none
//! of them can fire on a pair it removes (proof on `separated`).

use crate::collision::contact::{Contact, Pair, PairState};
use crate::collision::hull::{Placed, Shape, distance_bound_from, is_many_faced, lowest_vertex_seeded, proved_apart};
use crate::collision::posed::Posed;
use crate::math::{Mat3, Quat, Scalar, Vector};
use crate::model::mesh::{MeshId, MeshTable};
use crate::sim::bodies::Bodies;
use crate::sim::context::Params;
use crate::sim::context::StepContext;
use crate::solver::{Recycling, SolveScratch, cache_entries};
use crate::systems::solve::recycled_four;
use hecs::World;
use rayon::prelude::*;

/// Margin of the separation proof, relative to the sum of the radii: 1000× the inside
/// tolerance, so the tests' inclusive slack (which reaches a little past corners) cannot make a
/// pruned pair a contact.
pub const PRUNE_MARGIN: Scalar = 1e-6;

/// Most edge-direction pairs tried as axes: a box pair has 3 × 3; finely tessellated meshes
/// would cost more than the tests they save, so they keep only the face axes.
const MAX_EDGE_AXES: usize = 64;

/// Added to |Rᵢⱼ| in the box test so that near-parallel edges, whose cross product is nearly
/// zero and numerically meaningless, can never prove a separation (Ericson, RTCD §4.4.1).
const PARALLEL_SLACK: Scalar = 1e-9;

/// True when an axis separates the two convex bodies by more than the margin: a world axis
/// (bounding boxes apart), a face normal of either body, the line of centres, or the cross
/// product of two feature-edge directions (the separating-axis theorem's candidates). Then
/// every vertex of one lies beyond the other's projection, so no centroid, vertex or edge
/// point of either (convex combinations of vertices) is inside the other: the face, vertex
/// and edge tests all return none.
///
/// A pair with a many-faced body (`hull::is_many_faced`) is proved apart by GJK after the
/// world axes and the line of centres, not by every face against every vertex.
///
/// `margin` [m] must be at least `PRUNE_MARGIN · (r_a + r_b)`; `prune` widens it to the contact
/// margin for pairs that may rest on each other.
#[must_use]
pub fn separated(a: &Posed, b: &Posed, margin: Scalar) -> bool {
    let apart_on = |axis: Vector| apart_along(a, b, axis, margin);
    let faces = |p: &Posed, q: &Posed| {
        p.all_planes().any(|pl| q.vertices.iter().all(|v| pl.normal.dot(*v) - pl.offset > margin))
    };
    if separated_cheaply(a, b, margin) {
        return true;
    }
    if is_many_faced(a) || is_many_faced(b) {
        // Every face against every vertex is the cost the paper could not pay: GJK walks.
        return proved_apart(a, b, margin);
    }
    if faces(b, a) || faces(a, b) {
        return true;
    }
    let (ea, eb) = (&a.edge_directions, &b.edge_directions);
    ea.len() * eb.len() <= MAX_EDGE_AXES
        && ea.iter().any(|&da| eb.iter().any(|&db| da.cross(db).length_squared() > 1e-12 && apart_on(da.cross(db))))
}

/// The first, cheap axes of `separated`: the world axes (bounding boxes) and the line of
/// centres.
fn separated_cheaply(a: &Posed, b: &Posed, margin: Scalar) -> bool {
    bounds_gap(a, b) > margin || apart_along(a, b, b.position - a.position, margin)
}

/// How far apart the bodies' bounding boxes are along the farthest world axis [m] (negative
/// when they overlap).
fn bounds_gap(a: &Posed, b: &Posed) -> Scalar {
    gap_between(a.bounds, b.bounds)
}

/// `bounds_gap` of two (min, max) boxes.
fn gap_between(a: (Vector, Vector), b: (Vector, Vector)) -> Scalar {
    (b.0 - a.1).max(a.0 - b.1).max_element()
}

/// True when the projections of `a` and `b` on `axis` are more than `margin` apart.
fn apart_along(a: &Posed, b: &Posed, axis: Vector, margin: Scalar) -> bool {
    let (lo_a, hi_a) = extent(a, axis);
    let (lo_b, hi_b) = extent(b, axis);
    lo_b - hi_a > margin * axis.length() || lo_a - hi_b > margin * axis.length()
}

/// A box at a pose: the oriented-box form of `separated` for two body-aligned boxes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxPose {
    /// Centre [m].
    pub position: Vector,
    /// Body → world rotation matrix.
    pub rotation: Mat3,
    /// Half extents along the body axes [m].
    pub half: Vector,
}

/// The separating-axis test of two oriented boxes over its 15 axes (3 + 3 face normals, 9
/// edge cross products; Gottschalk 1996, Ericson RTCD §4.4.1), in A's frame, from the poses
/// alone: the same proof as `separated`, without touching vertices, which at 64 000 cubes is
/// what costs. For two margins at once, `[wide, proof]` with `wide ≥ proof`: whether some axis
/// shows a gap larger than each. One pass over the axes, stopping at the first that proves the
/// wide one, so a resting pair, which neither proves, is not tested twice.
#[must_use]
pub fn boxes_separated_by(a: &BoxPose, b: &BoxPose, [wide, proof]: [Scalar; 2]) -> [bool; 2] {
    debug_assert!(wide >= proof, "the wide margin proves the proof margin too");
    let (ra_m, rb_m) = (a.rotation, b.rotation);
    // r[i][j] = A_i · B_j, t = centre of B in A's axes.
    let r = ra_m.transpose() * rb_m;
    let r = [r.row(0), r.row(1), r.row(2)];
    let abs_r = r.map(|row| row.abs() + Vector::splat(PARALLEL_SLACK));
    let t = ra_m.transpose() * (b.position - a.position);
    let (ha, hb) = (a.half, b.half);
    let mut by_proof = false;
    // Projected distance `gap` against the two boxes' reach along one axis.
    let mut apart = |gap: Scalar, reach: Scalar| {
        by_proof |= gap > reach + proof;
        gap > reach + wide
    };
    for i in 0..3 {
        if apart(t[i].abs(), ha[i] + hb.dot(abs_r[i])) {
            return [true, true];
        }
    }
    for j in 0..3 {
        let col = Vector::new(r[0][j], r[1][j], r[2][j]);
        let abs_col = Vector::new(abs_r[0][j], abs_r[1][j], abs_r[2][j]);
        if apart(t.dot(col).abs(), ha.dot(abs_col) + hb[j]) {
            return [true, true];
        }
    }
    // Axis A_i × B_j: with (i, i1, i2) and (j, j1, j2) cyclic.
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let reach_a = ha[i1] * abs_r[i2][j] + ha[i2] * abs_r[i1][j];
            let reach_b = hb[j1] * abs_r[i][j2] + hb[j2] * abs_r[i][j1];
            if apart((t[i2] * r[i1][j] - t[i1] * r[i2][j]).abs(), reach_a + reach_b) {
                return [true, true];
            }
        }
    }
    [false, by_proof]
}

/// The margin a pair must be apart by to be dropped [m], and the proof margin: the first is
/// the proof margin widened to the contact margin for pairs that may rest on each other, so
/// `solve` still sees them while apart by less (a micro-bounce must not lose a stack's
/// contact); apart by more than the second, no detection test can fire (`separated`).
/// `speculative` holds each body's speculative distance; `resting` says from a pair's friction
/// whether it may rest (`Params::resting_rule`); `thin` is the thinner body's thickness
/// (`Bodies::thinner`).
#[inline]
fn pair_margin(
    p: &Pair,
    b: &Bodies,
    thin: Scalar,
    params: &Params,
    (resting, speculative): (impl Fn(Scalar) -> bool, &[Scalar]),
) -> (Scalar, Scalar) {
    let (ia, ib) = (p.a as usize, p.b as usize);
    let proof = PRUNE_MARGIN * (b.radius[ia] + b.radius[ib]);
    if resting(b.pair_friction(ia, ib)) {
        let speculative = speculative[ia] + speculative[ib];
        (proof.max(params.contact_margin * thin + speculative), proof)
    } else {
        (proof, proof)
    }
}

/// Marks `pair` `Separated` when `apart` proves it apart by the wide margin, else `Near` when
/// it proves it apart by the proof margin (`pair_margin`). `apart([wide, proof])` says whether
/// it is proved apart by each (the second only asked for when the first fails).
fn classify(pair: &mut Pair, (wide, proof): (Scalar, Scalar), mut apart: impl FnMut([Scalar; 2]) -> [bool; 2]) {
    let [by_wide, by_proof] = apart([wide, proof]);
    if by_wide {
        pair.state = PairState::Separated;
    } else if wide > proof && by_proof {
        pair.state = PairState::Near;
    }
}

/// The interval of `p`'s vertices projected on `axis`.
fn extent(p: &Posed, axis: Vector) -> (Scalar, Scalar) {
    if is_many_faced(p) {
        return (lowest_vertex_seeded(p, axis).1, -lowest_vertex_seeded(p, -axis).1);
    }
    p.vertices.iter().fold((Scalar::INFINITY, Scalar::NEG_INFINITY), |(lo, hi), v| {
        let s = v.dot(axis);
        (lo.min(s), hi.max(s))
    })
}

/// Drops the candidate pairs proved apart, and marks `Near` those proved apart by less than
/// the contact margin (kept for `solve`, skipped by the tests), so later systems walk only
/// pairs that may touch. The broad phase's count stays in `ctx.stats.candidates`. Box–box
/// pairs are tested from their poses (`boxes_separated_by`) before anything is posed; the rest
/// by `separated` on posed meshes.
///
/// First, the resting pairs of small meshes whose points `solve` will recycle skip the proofs
/// and the tests (`take_recycled`), last those with a many-faced body skip the tests.
///
/// - Reads: `ctx.pairs` (`Candidate` only), `ctx.bodies`, `ctx.meshes`, `ctx.posed`, `solve`'s
///   warm-start cache.
/// - Writes: `ctx.pairs` (removes separated pairs, keeps order; `Candidate` → `Near`, and for
///   recycled pairs → `Found`), `ctx.posed`.
/// - Paper: none (an early-out before the detection tests of "Collision Detection").
/// - Cost: O(1) per box pair; otherwise O(V_A + V_B) per axis tried, at most
///   1 + P_A + P_B + 64 axes per pair, with early exits.
pub fn prune(_world: &mut World, ctx: &mut StepContext) {
    let mut speculative = std::mem::take(&mut ctx.scratch.get_mut::<PruneScratch>().speculative);
    let mut touching = std::mem::take(&mut ctx.scratch.get_mut::<PruneScratch>().touching);
    let step = ctx.step;
    ctx.speculative_distances(&mut speculative);
    // Resting pairs of small meshes that keep their points skip the proofs too (`recycled_state`),
    // in the same pass as the box pairs' proofs.
    let judged = judge_recycling(ctx);
    let (b, meshes, params) = (&ctx.bodies, &ctx.meshes, &ctx.params);
    let may_rest = params.resting_rule(ctx.dt);
    let pose =
        |i: u32, half: Vector| BoxPose { position: b.position[i as usize], rotation: b.rotation[i as usize], half };
    // `judge_recycling` left each pair's cache entry in `cached`.
    let cached = ctx.scratch.get::<PruneScratch>().map_or(&[][..], |p| &p.cached[..]);
    let verdicts = ctx.scratch.get::<SolveScratch>().filter(|_| judged);
    ctx.pairs.par_iter_mut().enumerate().filter(|(_, p)| p.is_candidate()).for_each(|(k, pair)| {
        // Each body's mesh looked up once, for all three questions.
        let (ma, mb) = (meshes.get(b.mesh[pair.a as usize]), meshes.get(b.mesh[pair.b as usize]));
        let small = !ma.is_many_faced() && !mb.is_many_faced();
        let recycled = verdicts.filter(|_| small).and_then(|s| recycled_state(s, cached[k], step));
        if let Some(state) = recycled {
            pair.state = state;
        } else if let (Some(ha), Some(hb)) = (ma.box_half_extents, mb.box_half_extents) {
            let thin = ma.thickness.min(mb.thickness);
            let margins = pair_margin(pair, b, thin, params, (may_rest, &speculative));
            let (ba, bb) = (pose(pair.a, ha), pose(pair.b, hb));
            classify(pair, margins, |m| boxes_separated_by(&ba, &bb, m));
        }
    });
    ctx.pairs.retain(|p| p.state != PairState::Separated);
    let (meshes, b) = (&ctx.meshes, &ctx.bodies);
    let many = |i: u32| meshes.get(b.mesh[i as usize]).is_many_faced();
    let is_box = |i: u32| meshes.get(b.mesh[i as usize]).box_half_extents.is_some();
    // A candidate the box pass above did not classify: one of its bodies is not a box.
    let unproved = |p: &Pair| p.is_candidate() && !(is_box(p.a) && is_box(p.b));
    // Boxes only (a rain of cubes; a pile at rest, whose pairs all kept their points or were
    // proved apart): each candidate left was classified by the box pass above, and none has
    // a GJK record to carry over, so nothing is left to pose or prove (the tests pose the
    // bodies they take).
    let scratch = ctx.scratch.get_mut::<PruneScratch>();
    if scratch.starts.is_empty() && !ctx.pairs.iter().any(unproved) {
        touching.clear();
        (scratch.speculative, scratch.touching) = (speculative, touching);
        return;
    }
    // Small meshes are posed whole; many-faced ones are left unposed (`Placed`): their GJK and
    // bounds walk the body-frame vertices, and the tests and `solve` pose only the bodies of
    // the pairs they take (a recycled pair's need none).
    let candidates = ctx.pairs.iter().filter(|p| p.is_candidate()).flat_map(|p| [p.a, p.b]);
    ctx.posed.pose(b, candidates.clone().filter(|&i| !many(i)));
    let PruneScratch { wanted, bounds, hints, starts, next, starts_out, cached, resting, .. } =
        ctx.scratch.get_mut::<PruneScratch>();
    cache_entries(&touching, &ctx.pairs, resting);
    // Each pair's GJK starts from where last step's first walks ended (its entry in `starts`;
    // `cached` is scratch here, `take_recycled` fills it afresh).
    cache_entries(starts, &ctx.pairs, cached);
    starts_out.clear();
    starts_out.resize(ctx.pairs.len(), None);
    let placed = |i: usize| Placed { mesh: meshes.get(b.mesh[i]), position: b.position[i], rotation: b.rotation[i] };
    wanted.clear();
    wanted.resize(b.len(), false);
    candidates.filter(|&i| many(i)).for_each(|i| wanted[i as usize] = true);
    bounds.resize(b.len(), (Vector::ZERO, Vector::ZERO));
    hints.resize(b.len(), [0; 6]);
    let rows = bounds.par_iter_mut().zip(hints.par_iter_mut()).zip(wanted.par_iter()).enumerate();
    rows.filter(|(_, (_, w))| **w).for_each(|(i, ((bounds, hints), _))| {
        let p = placed(i);
        hints.iter_mut().filter(|h| **h as usize >= p.mesh.vertices.len()).for_each(|h| *h = 0);
        *bounds = p.bounds(hints);
    });
    let bounds = &*bounds;
    let (posed, params) = (&ctx.posed, &ctx.params);
    let margin =
        |p: &Pair| pair_margin(p, b, b.thinner(meshes, p.a as usize, p.b as usize), params, (may_rest, &speculative));
    let shape = |i: u32| if many(i) { Shape::Placed(placed(i as usize)) } else { Shape::Posed(posed.get(i)) };
    let bounds_of = |i: u32| if many(i) { bounds[i as usize] } else { posed.get(i).bounds };
    let old = |e: u32| starts.get(e as usize).map(|s| &s.1);
    let rows = ctx.pairs.par_iter_mut().zip(cached.par_iter().zip(starts_out.par_iter_mut())).zip(resting.par_iter());
    let rows = rows.filter(|((p, _), _)| unproved(p));
    rows.for_each(|((pair, (&entry, out)), &resting)| {
        let kept = old(entry);
        let (ia, ib) = (pair.a, pair.b);
        // An actor index may name another mesh after a structural change: such starts go.
        let size = |i: u32| meshes.get(b.mesh[i as usize]).vertices.len();
        let from = kept.map(|k| k.ends).filter(|&[i, j]| (i as usize) < size(ia) && (j as usize) < size(ib));
        let apart = kept.and_then(|k| k.apart);
        let (resting, first) = (resting != u32::MAX, u64::from(ia));
        classify(pair, margin(pair), |[wide, proof]| {
            if many(ia) || many(ib) {
                let gap = gap_between(bounds_of(ia), bounds_of(ib));
                if resting && !(step + first).is_multiple_of(RETEST_EVERY) {
                    return [gap > wide, gap <= wide && wide > proof && gap > proof];
                }
                // Proved apart before by more than the bodies have moved since and the margin:
                // GJK would prove it again (the pair keeps its record).
                if apart.is_some_and(|x| x.still_apart(b, meshes, (ia as usize, ib as usize)) > wide) {
                    return [true, true];
                }
                // One GJK bound answers both margins (its first direction is the line of
                // centres, which `separated` tries).
                let (bound, first) = distance_bound_from(shape(ia), shape(ib), wide, from);
                let bound = bound.max(gap);
                let apart = (bound > wide).then(|| Apart::at(bound, b, (ia as usize, ib as usize)));
                *out = Some(Kept { ends: first, apart });
                return [bound > wide, bound <= wide && wide > proof && bound > proof];
            }
            let (pa, pb) = (posed.get(ia), posed.get(ib));
            let by_wide = separated(pa, pb, wide);
            [by_wide, !by_wide && wide > proof && separated(pa, pb, proof)]
        });
    });
    // A pair GJK skipped this step keeps its old record.
    next.clear();
    let kept = starts_out.iter().zip(cached.iter()).map(|(now, &e)| now.as_ref().or_else(|| old(e)));
    next.extend(ctx.pairs.iter().zip(kept).filter_map(|(p, k)| k.map(|k| ((p.a, p.b), *k))));
    std::mem::swap(starts, next);
    ctx.pairs.retain(|p| p.state != PairState::Separated);
    touching.clear();
    let touches = |p: &&Pair| p.is_candidate() && (many(p.a) || many(p.b));
    touching.extend(ctx.pairs.iter().filter(touches).map(|p| ((p.a, p.b), ())));
    let scratch = ctx.scratch.get_mut::<PruneScratch>();
    (scratch.speculative, scratch.touching) = (speculative, touching);
    if judged {
        take_recycled(ctx);
    }
}

/// Works out, once a step, whether each resting pair with an entry in `solve`'s warm-start
/// cache keeps its points, and leaves the answer for `solve` (`SolveScratch::recycling`): the
/// kept points at the bodies' poses and the contact `solve` holds the pair at
/// (`solve::recycled_contact`). Only while the cache is last step's; false otherwise.
fn judge_recycling(ctx: &mut StepContext) -> bool {
    let (step, b, meshes, params, dt) = (ctx.step, &ctx.bodies, &ctx.meshes, &ctx.params, ctx.dt);
    let last_step = |s: &SolveScratch| s.step + 1 == step && !s.cache.is_empty();
    if !ctx.scratch.get::<SolveScratch>().is_some_and(last_step) {
        return false;
    }
    let scratch = ctx.scratch.get_mut::<PruneScratch>();
    let (mut cached, mut pair_of) = (std::mem::take(&mut scratch.cached), std::mem::take(&mut scratch.pair_of));
    let s = ctx.scratch.get_mut::<SolveScratch>();
    s.entries_of(&ctx.pairs, &mut cached);
    s.recycling_moves = ctx.posed.moves();
    // Entries of earlier steps are left as they are (stale by their step), not rewritten.
    if s.recycling.len() < s.cache.len() {
        s.recycling.resize(s.cache.len(), Recycling::default());
    }
    // Each entry's pair (`u32::MAX` for none), so that the entries are marked in parallel.
    pair_of.clear();
    pair_of.resize(s.cache.len(), u32::MAX);
    for (k, &entry) in cached.iter().enumerate().filter(|(_, e)| **e != u32::MAX) {
        pair_of[entry as usize] = k as u32;
    }
    // An entry is judged if its pair is open and may rest. Four entries at a time
    // (`recycled_four`); lanes past the chunk's judged entries repeat its first one and are
    // idle.
    let open = |p: &Pair| p.is_candidate() || p.is_near();
    let resting = params.resting_rule(dt);
    let judged_now = |k: u32| {
        let pair = ctx.pairs.get(k as usize).filter(|p| open(p));
        pair.is_some_and(|p| resting(b.pair_friction(p.a as usize, p.b as usize)))
    };
    let rows = s.recycling.par_chunks_mut(4).zip(s.cache.par_chunks(4)).zip(pair_of.par_chunks(4));
    rows.for_each(|((r, entries), pairs)| {
        for (r, &k) in r.iter_mut().zip(pairs) {
            if judged_now(k) {
                r.step = Some(step);
            }
        }
        let mut lanes = [0; 4];
        let mut out = [None, None, None, None];
        let mut n = 0;
        let judged = r.iter_mut().zip(entries).enumerate().filter(|(_, (r, _))| r.step == Some(step));
        for (j, (r, _)) in judged {
            (lanes[n], out[n], n) = (j, Some(r), n + 1);
        }
        if n == 0 {
            return;
        }
        let first = lanes[0];
        lanes[n..].fill(first);
        let ends = lanes.map(|j| (entries[j].0.0 as usize, entries[j].0.1 as usize));
        let thin = ends.map(|(ia, ib)| b.thinner(meshes, ia, ib));
        recycled_four(lanes.map(|j| &entries[j].1.anchors), b, thin, ends, out);
    });
    let scratch = ctx.scratch.get_mut::<PruneScratch>();
    (scratch.cached, scratch.pair_of) = (cached, pair_of);
    true
}

/// The state of a candidate pair whose points `solve` will recycle (`judge_recycling`), which
/// takes it out of the paper's tests: the verdict the tests gave when they last ran on it with
/// the recycled contact, which is all `solve` reads of it there (docs/physics.md §6.3). `None`
/// for a pair that keeps no points, or that no test found last time (held as near: it is
/// tested again, to see it touch). `entry`: the pair's entry in `solve`'s cache.
///
/// The pairs of two small meshes are taken before their separation proofs (a pair that keeps
/// its points is held or let go by `solve` from those points alone, so proving it apart would
/// only drop it a step early); those with a many-faced body after their GJK, whose records and
/// retest turns stay as they were (`take_recycled`).
fn recycled_state(s: &SolveScratch, entry: u32, step: u64) -> Option<PairState> {
    let (kept, r) = (&s.cache.get(entry as usize)?.1, &s.recycling[entry as usize]);
    let (feature, contact, _) = (kept.found?, r.contact?, r.step.filter(|&t| t == step)?);
    Some(PairState::Found(Contact { feature, ..contact }))
}

/// `recycled_state` for the candidate pairs with a many-faced body, after their GJK.
fn take_recycled(ctx: &mut StepContext) {
    let (step, b, meshes) = (ctx.step, &ctx.bodies, &ctx.meshes);
    let many = |i: u32| meshes.get(b.mesh[i as usize]).is_many_faced();
    let taken = |p: &Pair| p.is_candidate() && (many(p.a) || many(p.b));
    if !ctx.pairs.iter().any(taken) {
        return;
    }
    let mut cached = std::mem::take(&mut ctx.scratch.get_mut::<PruneScratch>().cached);
    let s = ctx.scratch.get_mut::<SolveScratch>();
    s.entries_of(&ctx.pairs, &mut cached);
    for (pair, &entry) in ctx.pairs.iter_mut().zip(&cached).filter(|(p, _)| taken(p)) {
        if let Some(state) = recycled_state(s, entry, step) {
            pair.state = state;
        }
    }
    ctx.scratch.get_mut::<PruneScratch>().cached = cached;
}

/// Steps between GJK tests of a pair with a many-faced body that GJK could not prove apart
/// last time: such a pair rests or slides on its neighbour, and GJK, which cannot part it,
/// costs more than the tests it would spare. Until its turn it stays a candidate, which is
/// always safe (the tests decide), and its turn comes on a step spread by its first body.
const RETEST_EVERY: u64 = 8;

/// `prune`'s reused buffers and the one thing it remembers from step to step.
#[derive(Default)]
struct PruneScratch {
    /// Each body's speculative distance this step (`StepContext::speculative_distances`).
    speculative: Vec<Scalar>,
    /// The pairs with a many-faced body not proved apart last step, sorted (with nothing
    /// beside them: a per-pair list `cache_entries` merges with the pairs).
    touching: Vec<((u32, u32), ())>,
    /// Scratch: each pair's index in `touching` (`u32::MAX`: not there).
    resting: Vec<u32>,
    /// Each pair's index in `solve`'s cache (`u32::MAX`: none), left by `judge_recycling` for the
    /// box pairs' pass and found again by `take_recycled`; scratch for the GJK starts between.
    cached: Vec<u32>,
    /// Each of `solve`'s cache entries' pair (`u32::MAX` for none), for `judge_recycling`.
    pair_of: Vec<u32>,
    /// Scratch: body i is a many-faced body of a candidate pair.
    wanted: Vec<bool>,
    /// Each such body's world bounds this step (`Placed::bounds`).
    bounds: Vec<(Vector, Vector)>,
    /// Each body's extreme vertices along the world axes when last bounded: where the next
    /// step's walks start (a resting body's are where they end).
    hints: Vec<[u32; 6]>,
    /// Each pair's last GJK (`Kept`), in pair order.
    starts: Vec<((u32, u32), Kept)>,
    /// Scratch: each pair's GJK this step, and the next `starts`.
    starts_out: Vec<Option<Kept>>,
    next: Vec<((u32, u32), Kept)>,
}

/// What `prune` keeps of a pair's last GJK: where its first walks ended (the next GJK starts
/// there) and, when it proved the pair apart, by how much and where.
#[derive(Clone, Copy, Debug)]
struct Kept {
    ends: [u32; 2],
    apart: Option<Apart>,
}

/// A's and B's centres and orientations.
fn poses(b: &Bodies, ia: usize, ib: usize) -> ([Vector; 2], [Quat; 2]) {
    ([b.position[ia], b.position[ib]], [b.orientation[ia], b.orientation[ib]])
}

/// A lower bound on a pair's distance [m] at the poses and meshes it was found for.
#[derive(Clone, Copy, Debug)]
struct Apart {
    bound: Scalar,
    poses: ([Vector; 2], [Quat; 2]),
    meshes: [MeshId; 2],
}

impl Apart {
    /// Pair (A, B)'s `bound` at their current poses.
    fn at(bound: Scalar, b: &Bodies, (ia, ib): (usize, usize)) -> Self {
        Self { bound, poses: poses(b, ia, ib), meshes: [b.mesh[ia], b.mesh[ib]] }
    }

    /// A lower bound on the pair's distance now [m]: the old bound less the farthest any
    /// point of either body has moved since (its centre's shift plus the chord its turn sweeps
    /// at the mesh's radius), less a slack far above round-off. −∞ for other meshes.
    fn still_apart(&self, b: &Bodies, meshes: &MeshTable, (ia, ib): (usize, usize)) -> Scalar {
        if self.meshes != [b.mesh[ia], b.mesh[ib]] {
            return Scalar::NEG_INFINITY;
        }
        self.bound_at(poses(b, ia, ib), [ia, ib].map(|i| meshes.get(b.mesh[i]).radius))
    }

    /// `still_apart` for A and B now at `now` (centres, orientations), of radii `radii` [m].
    fn bound_at(&self, now: ([Vector; 2], [Quat; 2]), radii: [Scalar; 2]) -> Scalar {
        let moved = |k: usize| {
            // The chord of a turn by θ is 2 sin(θ/2) r, and |q·q'| = cos(θ/2); the 1e-15 covers
            // the round-off of 1 − c² near c = 1.
            let c = self.poses.1[k].dot(now.1[k]).abs().min(1.0);
            let chord = 2.0 * ((1.0 - c * c).max(0.0) + 1e-15).sqrt() * radii[k];
            (now.0[k] - self.poses.0[k]).length() + chord
        };
        self.bound - moved(0) - moved(1) - 1e-9 * (1.0 + radii[0] + radii[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::from_euler_degrees;
    use crate::model::components::Pose;
    use crate::model::mesh::ConvexMesh;
    use std::sync::Arc;

    fn pose(x: Vector, degrees: Vector) -> Pose {
        Pose { position: x, orientation: from_euler_degrees(degrees) }
    }

    /// Both forms of the test on two unit cubes; asserts they agree and returns the answer.
    fn apart(a: Pose, b: Pose) -> bool {
        let mesh = Arc::new(ConvexMesh::cuboid(Vector::ONE));
        let margin = PRUNE_MARGIN * 3f64.sqrt();
        let generic = separated(&Posed::new(Arc::clone(&mesh), &a), &Posed::new(mesh, &b), margin);
        let half = Vector::splat(0.5);
        let boxes = boxes_separated_by(
            &BoxPose { position: a.position, rotation: Mat3::from_quat(a.orientation), half },
            &BoxPose { position: b.position, rotation: Mat3::from_quat(b.orientation), half },
            [margin; 2],
        )[0];
        assert_eq!(generic, boxes, "{a:?} {b:?}");
        generic
    }

    #[test]
    fn touching_cubes_are_not_pruned_but_a_gap_is() {
        let at = |x| pose(Vector::new(x, 0.0, 0.0), Vector::ZERO);
        assert!(!apart(at(0.0), at(1.0)));
        assert!(!apart(at(0.0), at(0.99)));
        assert!(apart(at(0.0), at(1.01)));
    }

    #[test]
    fn crossed_ridges_apart_are_found_only_on_an_edge_axis() {
        // docs/physics.md §4 (f2) geometry lifted 0.02 above touching: the ridges are 0.01 apart,
        // which no face normal and not the line of centres can show (offset along x).
        let h = 2f64.sqrt();
        let b = pose(Vector::ZERO, Vector::new(45.0, 0.0, 0.0));
        assert!(apart(pose(Vector::new(0.25, h + 0.01, 0.0), Vector::new(0.0, 0.0, 45.0)), b));
        // And crossing (0.01 overlap) they are not.
        assert!(!apart(pose(Vector::new(0.25, h - 0.01, 0.0), Vector::new(0.0, 0.0, 45.0)), b));
    }

    #[test]
    fn box_and_generic_tests_agree_on_many_random_poses() {
        let mut rng = crate::rng::SplitMix64::new(7);
        let mut count = [0; 2];
        for _ in 0..2000 {
            let mut draw = || Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
            let (x, r1, r2) = (draw() * 1.2, draw() * 180.0, draw() * 180.0);
            count[usize::from(apart(pose(Vector::ZERO, r1), pose(x, r2)))] += 1;
        }
        assert!(count[0] > 100 && count[1] > 100, "both answers occur: {count:?}");
    }

    #[test]
    fn a_pair_proved_apart_stays_apart_by_its_bound_less_how_far_it_moved() {
        use crate::collision::hull::distance_bound;
        let (v, t) = crate::model::shapes::icosphere_raw(0.5, 2);
        let mesh = Arc::new(ConvexMesh::new(v, t).expect("an icosphere is valid").0);
        let mut rng = crate::rng::SplitMix64::new(17);
        let (mut checked, mut moved) = (0, 0);
        for _ in 0..400 {
            let mut draw = || Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
            let (xa, xb) = (draw() * 0.3, Vector::new(1.3, 0.0, 0.0) + draw() * 0.3);
            let (ra, rb) = (draw() * 180.0, draw() * 180.0);
            let (dxa, dxb, dra, drb) = (draw() * 0.05, draw() * 0.05, draw() * 10.0, draw() * 10.0);
            let at = |x: Vector, r: Vector| Posed::new(Arc::clone(&mesh), &pose(x, r));
            let (a, b) = (at(xa, ra), at(xb, rb));
            let bound = distance_bound(Shape::Posed(&a), Shape::Posed(&b), 10.0);
            if bound <= 0.0 {
                continue;
            }
            let then = Apart {
                bound,
                poses: ([a.position, b.position], [a.orientation, b.orientation]),
                meshes: [MeshId(0); 2],
            };
            let (a, b) = (at(xa + dxa, ra + dra), at(xb + dxb, rb + drb));
            let now = then.bound_at(([a.position, b.position], [a.orientation, b.orientation]), [mesh.radius; 2]);
            // The claim holds: GJK proves them apart by just under it (the true distance is more).
            if now > 0.0 {
                assert!(proved_apart(&a, &b, now - 1e-9), "claimed {now}, from {bound}");
                checked += 1;
            }
            // Unmoved, the bound is the old one less the slacks only (under 0.1 µm).
            let still = then.bound_at(then.poses, [mesh.radius; 2]);
            assert!(still < bound && still > bound - 1e-7, "{still} from {bound}");
            moved += usize::from(now < bound - 0.01);
        }
        assert!(checked > 200 && moved > 300, "both claims and motions are tried: {checked} {moved}");
    }

    #[test]
    fn one_pass_with_two_margins_answers_as_two_tests() {
        let mut rng = crate::rng::SplitMix64::new(11);
        let half = Vector::new(0.5, 0.3, 0.2);
        let mut seen = std::collections::BTreeSet::new();
        for _ in 0..3000 {
            let mut draw = || Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
            let (x, r1, r2) = (draw() * 1.3, draw() * 180.0, draw() * 180.0);
            let at = |p: Pose| BoxPose { position: p.position, rotation: Mat3::from_quat(p.orientation), half };
            let (a, b) = (at(pose(Vector::ZERO, r1)), at(pose(x, r2)));
            let (wide, proof) = (0.05, 1e-6);
            let both = boxes_separated_by(&a, &b, [wide, proof]);
            let one = |m| boxes_separated_by(&a, &b, [m; 2]);
            assert_eq!(both, [one(wide)[0], one(proof)[0]], "{a:?} {b:?}");
            seen.insert(both);
        }
        assert_eq!(seen.len(), 3, "apart by both, by the proof margin only, and by neither: {seen:?}");
    }
}
