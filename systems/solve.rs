//! `solve`: resting contact, friction and impacts under gravity, the paper's "future work".
//! Sequential impulses over contact manifolds (up to four points a pair), with accumulated
//! normal impulses clamped at zero and Coulomb friction held within μ times them, warm-started
//! from the previous step's impulses (Catto, "Iterative Dynamics with Temporal Coherence",
//! 2005), solved as a "soft step" (Catto, "Solver2D", 2024; Box2D v3; rapier's TGS): the step
//! is cut into substeps, penetration is pushed out by a stiff damped spring and a rigid relax
//! pass takes the push-out velocity back, so penetration is removed without adding energy.
//! This file finds the manifolds and runs the substeps; the solver is in `src/solver/`: its
//! data (`mod.rs`, `lanes.rs`), the constraints built from the manifolds (`constraints.rs`), the
//! passes (`kernel.rs`) and how they are carried out on one thread or two (`drive.rs`).
//!
//! Each pair is held along its least-overlap axis (`manifold::contact_axis`), not the detection
//! tests' normal, with speculative points for gaps that may close within the step
//! (`Params::speculative_distance`). A pair that has hardly moved since its points were found
//! keeps them (contact recycling). Constraints are solved lowest first, so one sweep carries a
//! stack's support from the ground up.
//!
//! It takes every contact under gravity (impacts bounce here, per point, after the substeps)
//! and every contact with friction, and solves the scene's joints in the same substeps
//! (docs/joints.md). Without gravity, friction and joints it does nothing, so the paper's
//! frictionless results, `resolve`'s, are unchanged. `correct` leaves the pairs held
//! here alone.

use crate::collision::contact::{Contact, Feature, Pair, PairState};
use crate::collision::hull::climbed_axis;
use crate::collision::manifold::{
    ClipScratch, MAX_POINTS, Manifold, Reference, contact_axis_from, manifold, support_point,
};
use crate::math::{Quat, Scalar, Vector, exp_map};
use crate::sim::bodies::Bodies;
use crate::sim::context::StepContext;
use crate::solver::warm_start_of;
use crate::solver::{
    CachedManifold, ConstraintGroup, ContactAnchors, LANES, LaneImpulses, PairEnds, Recycling, SolveScratch, WarmStart,
    recycle_four,
};
use crate::solver::{Joints, Pass, Softness, Step, build_constraints, drive, prepare_joints, substep_plan};
use hecs::World;
use rayon::prelude::*;

/// Relative motion [fraction of the thinner body] since a pair's contact points were found
/// below which it keeps them: 3 cm for a 1 m cube. Each held point's end on B has then moved
/// less than that against its end on A, and a settling pile, which creeps and tumbles by
/// centimetres, keeps its points instead of finding them afresh every few steps (BENCH.md).
const RECYCLE_DISTANCE: Scalar = 0.03;

/// Holds resting contacts, applies friction and bounces impacts (see the module docs).
///
/// - Reads: `ctx.pairs` (`Candidate`, `Found`, `Resolved`), `ctx.posed`, `ctx.bodies`,
///   its `SolveScratch`, the joints (`Joints`, docs/joints.md).
/// - Writes: `ctx.bodies` velocities and the poses of the bodies it holds or the joints hold,
///   `ctx.stats.impulses` (one per pair held), the warm-start cache, the joints' impulses.
/// - Paper: none (resting contact and friction are the paper's future work).
/// - Cost: O(P) to find and build P points, O(P · substeps · (iterations + 2)) to solve.
pub fn solve(_world: &mut World, ctx: &mut StepContext) {
    let (b, params, dt) = (&ctx.bodies, &ctx.params, ctx.dt);
    let rule = params.resting_rule(dt);
    let resting = |p: &Pair| rule(b.pair_friction(p.a as usize, p.b as usize));
    let s = ctx.scratch.get_mut::<SolveScratch>();
    s.step = ctx.step;
    let open = |p: &Pair| p.contact().is_some() || p.is_candidate() || p.is_near();
    copy_pairs(&ctx.pairs, &mut s.pairs, |p| open(p) && resting(p));
    // Joints run the substeps even with no contact to hold (and without gravity).
    let mut joints = match ctx.scratch.get::<Joints>() {
        Some(j) if !j.joints.is_empty() => std::mem::take(ctx.scratch.get_mut::<Joints>()),
        _ => Joints::default(),
    };
    let s = ctx.scratch.get_mut::<SolveScratch>();
    if s.pairs.is_empty() && joints.joints.is_empty() {
        s.cache.clear();
        s.cache_keys.clear();
        s.held.clear();
        return;
    }
    // Each jointed actor once, in order of first mention, marked by actor (a search of the
    // list so far was quadratic in the joints).
    s.jointed.clear();
    let mut seen = vec![false; ctx.bodies.len()];
    for i in joints.joints.iter().flat_map(|j| std::iter::once(j.a).chain(j.b)) {
        if !std::mem::replace(&mut seen[i as usize], true) {
            s.jointed.push(i);
        }
    }
    find_manifolds(ctx);
    build_constraints(ctx);
    let s = ctx.scratch.get_mut::<SolveScratch>();
    (ctx.stats.held, ctx.stats.split) = (s.held.len(), s.split);
    prepare_joints(&mut joints, &ctx.bodies, &s.slot, &s.scale, s.bodies.len() as u32 - 1);
    substeps(ctx, &mut joints);
    remember(ctx);
    if !joints.joints.is_empty() {
        *ctx.scratch.get_mut::<Joints>() = joints;
    }
}

/// The pairs of `pairs` that `wanted` takes, in order, into `out`. With other threads and
/// every pair wanted (a pile under gravity), the two halves are copied at once, each by the
/// thread that `find_manifolds` next gives it, so the stores go to lines its core wrote last
/// step instead of taking them back from the other core (BENCH.md, session 35).
fn copy_pairs(pairs: &[Pair], out: &mut Vec<Pair>, wanted: impl Fn(&Pair) -> bool + Sync) {
    if rayon::current_num_threads() == 1 || !pairs.par_iter().all(&wanted) {
        out.clear();
        out.extend(pairs.iter().filter(|p| wanted(p)).copied());
        return;
    }
    // Only a longer list than last step's is extended here; the rest is overwritten in place.
    let kept = out.len().min(pairs.len());
    out.truncate(kept);
    out.extend_from_slice(&pairs[kept..]);
    let half = kept.div_ceil(2).max(1);
    out[..kept].par_chunks_mut(half).zip(pairs[..kept].par_chunks(half)).for_each(|(o, p)| o.copy_from_slice(p));
}

/// Each pair's manifold: recycled from the previous step when the two bodies have hardly
/// moved relative to each other (`still`), else found afresh along the pair's least-overlap
/// axis (`contact_axis`, `manifold`). Each pair's `PairEnds` (whether and where it is held,
/// all that building the constraints reads of it) is written as soon as its manifold is.
fn find_manifolds(ctx: &mut StepContext) {
    let mut speculative = std::mem::take(&mut ctx.scratch.get_mut::<SolveScratch>().speculative);
    ctx.speculative_distances(&mut speculative);
    let s = ctx.scratch.get_mut::<SolveScratch>();
    s.speculative = speculative;
    let speculative = &s.speculative;
    let (meshes, b, params, step) = (&ctx.meshes, &ctx.bodies, &ctx.params, ctx.step);
    let margin = params.contact_margin;
    let reach = |ia: usize, ib: usize, thin: Scalar| margin * thin + speculative[ia] + speculative[ib];
    let n = s.pairs.len();
    s.manifolds.resize(n, Manifold::default());
    s.anchors.resize(n, ContactAnchors::default());
    s.recycled.resize(n, false);
    s.ends.resize(n, PairEnds::default());
    s.warm.resize(n, WarmStart::default());
    let up = -params.gravity.normalize_or_zero();
    s.near.clear();
    s.near.extend(s.pairs.iter().map(|p| p.is_candidate() || p.is_near()));
    let mut cached = std::mem::take(&mut s.cached);
    s.entries_of(&s.pairs, &mut cached);
    s.cached = cached;
    let cache = &s.cache;
    let cached = &s.cached;
    // `prune`'s verdicts, if no body moved since it worked them out (each of this step).
    let judged: &[Recycling] = if s.recycling_moves == ctx.posed.moves() { &s.recycling } else { &[] };
    let rows = s.pairs.par_iter_mut().zip(s.manifolds.par_iter_mut());
    let rows = rows.zip(s.recycled.par_iter_mut()).zip(cached.par_iter()).zip(s.ends.par_iter_mut());
    let rows = rows.zip(s.warm.par_iter_mut());
    rows.for_each(|(((((pair, m), recycled), &entry), ends), warm)| {
        let (ia, ib) = (pair.a as usize, pair.b as usize);
        let thin = b.thinner(meshes, ia, ib);
        let old = (entry != u32::MAX).then(|| &cache[entry as usize].1);
        *recycled = false;
        let verdict = judged.get(entry as usize).filter(|v| v.step == Some(step));
        let kept =
            old.and_then(|g| verdict.map_or_else(|| recycled_points(&g.anchors, b, thin, ia, ib), |v| v.manifold));
        if let (Some(old), Some(kept)) = (old, kept) {
            // The anchors stay in the cache entry (`remember` reads them there).
            (*recycled, *m) = (true, kept);
            let feature = pair.contact().map_or(Feature::Face, |c| c.feature);
            let contact = match verdict {
                Some(v) => v.contact.map(|c| Contact { feature, ..c }),
                None => recycled_contact(m, &old.anchors, b, ia, feature),
            };
            match contact {
                Some(c) if -c.depth <= reach(ia, ib, thin) => pair.state = PairState::Resolved(c),
                _ => {
                    m.len = 0;
                    pair.state = PairState::Candidate; // drawn apart
                }
            }
            *ends = PairEnds::of(pair, m, up);
            *warm = warm_start_of(Some(old), m.len, None, b.radius[ia]);
            ends.quiet = warm.is_zero(m.len);
        }
    });
    // Only the pairs found afresh need their bodies posed.
    let fresh = s.pairs.iter().zip(&s.recycled).filter(|(_, r)| !**r).flat_map(|(p, _)| [p.a, p.b]);
    ctx.posed.pose(b, fresh);
    let posed = &ctx.posed;
    let rows = s.pairs.par_iter_mut().zip(s.manifolds.par_iter_mut());
    let rows =
        rows.zip(s.anchors.par_iter_mut().zip(s.recycled.par_iter())).zip(cached.par_iter().zip(s.near.par_iter()));
    let rows = rows.zip(s.ends.par_iter_mut().zip(s.warm.par_iter_mut())).filter(|(((_, (_, r)), _), _)| !**r);
    rows.for_each_init(ClipScratch::default, |clip, ((((pair, m), (anchors, _)), (&entry, &near)), (ends, warm))| {
        let (ia, ib) = (pair.a as usize, pair.b as usize);
        let thin = b.thinner(meshes, ia, ib);
        let reach = reach(ia, ib, thin);
        let feature = pair.contact().map_or(Feature::Face, |c| c.feature);
        let (pa, pb) = (posed.get(pair.a), posed.get(pair.b));
        // Held along the pair's least-overlap axis (see `contact_axis`), touching or a hair
        // apart (speculatively); the tests' own normal and depth decide only that it touches.
        // Searched from last step's axis, if the pair was held then. A pair no test found
        // touching is held only speculatively: if the face that axis climbs to parts the
        // bodies, it will do (`climbed_axis`).
        let last = cache.get(entry as usize).map(|e| &e.1);
        let hint = last.and_then(|e| e.anchors.axis);
        let climbed = hint.and_then(Reference::face).filter(|_| near).and_then(|f| climbed_axis(pa, pb, f));
        let axis = match climbed {
            Some(x) => (x.separation <= reach).then_some(x),
            None => contact_axis_from(pa, pb, (margin * thin, reach), hint),
        };
        let Some(axis) = axis else {
            m.len = 0;
            pair.state = PairState::Candidate; // apart: no constraint
            *ends = PairEnds::of(pair, m, up);
            return;
        };
        *m = manifold(pa, pb, &axis, reach, clip);
        if m.len == 0 {
            // Edge across edge, or nothing left by the clipping: one point where they meet.
            (m.points[0], m.gaps[0], m.len) = (support_point(pa, pb, &axis), axis.separation, 1);
        }
        // Held at its deepest point, as a recycled pair is (`held_at`).
        let deepest = m.deepest().unwrap_or(0);
        let contact = Contact { point: m.points[deepest], normal: axis.normal, depth: -axis.separation, feature };
        pair.state = PairState::Resolved(contact);
        *anchors = ContactAnchors { axis: Some(axis.reference), ..fixed_to_bodies(m, axis.normal, b, ia, ib) };
        *ends = PairEnds::of(pair, m, up);
        *warm = warm_start_of(last, m.len, Some(anchors), b.radius[ia]);
        ends.quiet = warm.is_zero(m.len);
    });
}

/// The points `old` of a pair's cache entry placed at the bodies' current poses when the pair
/// keeps them (B has moved little relative to A since they were found, `still`), else `None`.
/// `prune` works this out for the pairs it may take out of the tests (`Recycling`), and
/// `solve` reads its answer if no body moved since.
pub(super) fn recycled_points(
    old: &ContactAnchors,
    b: &Bodies,
    thin: Scalar,
    ia: usize,
    ib: usize,
) -> Option<Manifold> {
    still(old, b, ia, ib, RECYCLE_DISTANCE * thin).then(|| placed(old, b, ia, ib))
}

/// `prune`'s verdicts of four pairs at once: `recycled_points` and `recycled_contact` (with the
/// feature `Face`) into `out[l]` for lane l, the cache entry `old[l]` of the bodies `ends[l]`,
/// `thin[l]` the thinner one's thickness; lanes without an `out` are idle. The same bits as
/// one pair at a time (`solver::recycle_four`).
pub(super) fn recycled_four(
    old: [&ContactAnchors; 4],
    b: &Bodies,
    thin: [Scalar; 4],
    ends: [(usize, usize); 4],
    mut out: [Option<&mut Recycling>; 4],
) {
    let placed = out.each_mut().map(|r| r.as_deref_mut().map(|r| &mut r.manifold));
    let normal = recycle_four(old, ends, thin.map(|t| RECYCLE_DISTANCE * t), b, placed);
    for (l, r) in out.into_iter().enumerate() {
        if let Some(r) = r {
            r.contact = r.manifold.as_ref().and_then(|m| held_at(m, normal[l], Feature::Face));
        }
    }
}

/// The contact a recycled pair is held at, found by `feature`: the deepest of its kept points
/// `m`, with the kept normal turned with A; `None` when no point is kept. It is also the
/// contact `prune` gives a pair it takes out of the tests (docs/physics.md §6.3).
pub(super) fn recycled_contact(
    m: &Manifold,
    old: &ContactAnchors,
    b: &Bodies,
    ia: usize,
    feature: Feature,
) -> Option<Contact> {
    held_at(m, b.rotation[ia] * old.normal, feature)
}

/// `recycled_contact` given the kept normal turned with A.
fn held_at(m: &Manifold, normal: Vector, feature: Feature) -> Option<Contact> {
    let deepest = m.deepest()?;
    Some(Contact { point: m.points[deepest], normal, depth: -m.gaps[deepest], feature })
}

/// True when B has moved, relative to A, by less than `distance` [m] since `g` was found: the
/// shift of its centre plus the arc its rotation sweeps at its bounding radius.
fn still(g: &ContactAnchors, b: &Bodies, ia: usize, ib: usize, distance: Scalar) -> bool {
    let (offset, turn) = relative(b, ia, ib);
    let shift = (offset - g.offset).length();
    // The arc is 2 acos(c) r, c = |cos| of half the turn. A resting pair turns little: when an
    // upper bound of the arc already fits, the exact arc does too, and the arc cosine (a sixth
    // of finding a resting pyramid's manifolds) is not needed; when a lower bound does not fit,
    // neither does the arc. The answer is the same either way.
    let [low, high] = acos_bounds(turn.dot(g.turn).abs());
    if shift + 2.0 * high * b.radius[ib] < distance {
        return true;
    }
    if shift + 2.0 * low * b.radius[ib] >= distance {
        return false;
    }
    shift + turn.angle_between(g.turn) * b.radius[ib] < distance
}

/// Bounds of `acos(c)` for c in [0, 1], as the library computes it: √(2x) below and
/// √(2x) (1 + x/6) above, for x = 1 − c (acos(1 − x) = √(2x) (1 + x/12 + 3x²/160 + …), every
/// term positive and the sum under x/6 for x ≤ 1), with room for the round-off of both. NaN
/// above 1.
fn acos_bounds(c: Scalar) -> [Scalar; 2] {
    let x = 1.0 - c;
    let root = (2.0 * x).sqrt();
    [root * (1.0 - 1e-9), root * (1.0 + x / 6.0) * (1.0 + 1e-9)]
}

/// B's centre in A's frame and its orientation relative to A's.
fn relative(b: &Bodies, ia: usize, ib: usize) -> (Vector, Quat) {
    (b.rotation[ia].transpose() * (b.position[ib] - b.position[ia]), b.orientation[ia].inverse() * b.orientation[ib])
}

/// The manifold's points fixed to the bodies: each point's ends on A and on B (half its gap
/// either side along the normal) in their body frames.
fn fixed_to_bodies(m: &Manifold, normal: Vector, b: &Bodies, ia: usize, ib: usize) -> ContactAnchors {
    let (offset, turn) = relative(b, ia, ib);
    let (ra, rb) = (b.rotation[ia].transpose(), b.rotation[ib].transpose());
    let mut g = ContactAnchors { offset, turn, normal: ra * normal, len: m.len, ..ContactAnchors::default() };
    for k in 0..m.len {
        let half = normal * (0.5 * m.gaps[k]);
        g.on_a[k] = ra * (m.points[k] + half - b.position[ia]);
        g.on_b[k] = rb * (m.points[k] - half - b.position[ib]);
    }
    g
}

/// The manifold of the fixed points `g` at the bodies' current poses: each point halfway
/// between its two ends, its gap their separation along the normal (turned with A).
fn placed(g: &ContactAnchors, b: &Bodies, ia: usize, ib: usize) -> Manifold {
    let normal = b.rotation[ia] * g.normal;
    let mut m = Manifold { len: g.len, ..Manifold::default() };
    for k in 0..g.len {
        let on_a = b.position[ia] + b.rotation[ia] * g.on_a[k];
        let on_b = b.position[ib] + b.rotation[ib] * g.on_b[k];
        (m.points[k], m.gaps[k]) = (0.5 * (on_a + on_b), (on_a - on_b).dot(normal));
    }
    m
}

/// The substepped solve (a "soft step", as in Box2D v3 and rapier's TGS): the step is cut into
/// `substeps` of length h. Each substep adds its share of gravity, re-applies the accumulated
/// impulses, solves with soft position feedback from the gaps as they stand after the earlier
/// substeps, moves the bodies' (virtual) displacements on, and relaxes: a rigid pass that takes
/// back the push-out velocity so penetration is removed without adding energy. Then impacts
/// bounce (`solver::restitution`). Positions end where the substeps took them: `integrate` adds
/// v·dt, so `solve` moves each body by the rest. Gravity's change of velocity, which the
/// `gravity` system applied whole, is re-timed over the substeps (net change unchanged), so a
/// stack's weight is carried substep by substep.
fn substeps(ctx: &mut StepContext, joints: &mut Joints) {
    let (params, dt) = (&ctx.params, ctx.dt);
    let (count, h) = (params.substeps.max(1), params.substep(dt));
    let soft = Softness::new(h);
    let s = ctx.scratch.get_mut::<SolveScratch>();
    let mut plan = vec![Step::Push(-params.gravity * dt)];
    // Without joints, a substep after the first starts from the last one's velocities
    // (`Step::Repeat`) instead of a warm-start pass over the constraints.
    let repeat = joints.joints.is_empty();
    plan.extend(substep_plan(count, |k| params.sweeps(k), (h, soft), params.gravity * h, repeat));
    plan.push(Step::Pass(Pass::Restitution(params.restitution_threshold(dt))));
    drive(s, &plan, h, joints);
    // Written in place, body by body in parallel: a body is held here if its solver slot's
    // moving body is itself (a fixed, untouched or sleeping body's slot is a static one or stale).
    let (moving, slots, solver_bodies, scales, left) = (&s.moving, &s.slot, &s.bodies, &s.scale, s.left);
    let b = &mut ctx.bodies;
    let poses = b.position.par_iter_mut().zip(b.orientation.par_iter_mut());
    let rows = b.velocity.par_iter_mut().zip(b.angular_velocity.par_iter_mut()).zip(poses).zip(slots.par_iter());
    rows.enumerate().for_each(|(i, (((v, w), (x, q)), &slot))| {
        let slot = slot as usize;
        let k = if slot < left { slot } else { slot.wrapping_sub(1) };
        if moving.get(k) != Some(&(i as u32)) {
            return;
        }
        let (body, scale) = (&solver_bodies[slot], scales[slot]);
        let spin = scale * body.w;
        let turn = exp_map(scale * body.dq - spin * dt);
        (*v, *w, *x, *q) = (body.v, spin, *x + (body.dx - body.v * dt), (turn * *q).normalize());
    });
    for &i in &s.moving {
        ctx.posed.mark_moved(i as usize);
    }
}

/// Keeps this step's anchors and impulses for the next step, and counts one impulse per pair
/// held (by the feature that found its contact; near pairs no test found are not counted).
fn remember(ctx: &mut StepContext) {
    let s = ctx.scratch.get_mut::<SolveScratch>();
    // In pair order, which is the cache's: each pair's held entry by its index (cheaper than
    // sorting the entries themselves, 300 bytes each).
    s.by_pair.clear();
    s.by_pair.resize(s.pairs.len(), u32::MAX);
    for (h, held) in s.held.iter().enumerate() {
        s.by_pair[held.pair as usize] = h as u32;
    }
    s.by_pair.retain(|&h| h != u32::MAX);
    // A pile at rest holds last step's pairs, in the cache's order: each entry is then its
    // pair's own and is rewritten in place, and a recycled pair's anchors, already there, are
    // not copied (most of an entry's bytes).
    let (held, cached) = (&s.held, &s.cached);
    let in_place = s.by_pair.len() == s.cache.len()
        && s.by_pair.iter().enumerate().all(|(e, &h)| cached[held[h as usize].pair as usize] == e as u32);
    // Each lane's impulses first, batch by batch: a batch's lines are read once for its four
    // lanes, not once for each at random in the cache's order.
    s.groups.par_iter_mut().for_each(lane_impulses);
    // Written in parallel: a serial part of the step waits for both threads.
    let (pairs, groups, anchors, near, recycled) = (&s.pairs, &s.groups, &s.anchors, &s.near, &s.recycled);
    // Held entry h's impulses, verdict and (if given) anchors into `out`; its feature if it
    // pushed (counted).
    let write = |out: &mut CachedManifold, h: u32, new: Option<&ContactAnchors>| {
        let held = &held[h as usize];
        let k = held.pair as usize;
        if let Some(anchors) = new {
            // Every field named, so a field added to the anchors cannot be left stale here;
            // field by field: a whole entry built and then moved in was two calls of memcpy.
            let ContactAnchors { offset, turn, normal, on_a, on_b, len, axis } = anchors;
            let to = &mut out.anchors;
            (to.offset, to.turn, to.normal, to.len, to.axis) = (*offset, *turn, *normal, *len, *axis);
            (to.on_a, to.on_b) = (*on_a, *on_b);
        }
        let group = &groups[usize::from(held.group)];
        let (batch, lane) = group.placed[held.at as usize];
        let kept = &group.impulses[batch as usize * LANES + usize::from(lane)];
        (out.tangent, out.twist) = (kept.tangent, kept.twist);
        out.found = pairs[k].contact().filter(|_| !near[k]).map(|c| c.feature);
        let len = usize::from(held.len);
        out.normal = [0.0; MAX_POINTS];
        out.normal[..len].copy_from_slice(&kept.normal[..len]);
        // Counted if it pushed.
        out.found.filter(|_| out.normal.iter().any(|&j| j > 0.0))
    };
    let count = |mut counts: [u64; 3], found: Option<Feature>| {
        if let Some(feature) = found {
            counts[feature as usize] += 1;
        }
        counts
    };
    let add = |a: [u64; 3], b: [u64; 3]| [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
    let impulses = if in_place {
        let rows = s.cache.par_iter_mut().zip(s.by_pair.par_iter());
        let entry = |((_, out), &h): (&mut ((u32, u32), CachedManifold), &u32)| {
            let k = held[h as usize].pair as usize;
            write(out, h, (!recycled[k]).then(|| &anchors[k]))
        };
        rows.map(entry).fold(|| [0; 3], count).reduce(|| [0; 3], add)
    } else {
        let cache = &s.cache;
        // Each entry's key goes into the entry and into the compact `cache_keys`, which
        // nothing reads until the swap below: (entry, its compact key), its held pair.
        type Row<'a> = ((&'a mut ((u32, u32), CachedManifold), &'a mut (u32, u32)), &'a u32);
        let entry = |(((key, out), compact), &h): Row| {
            let k = held[h as usize].pair as usize;
            let anchors = if recycled[k] { &cache[cached[k] as usize].1.anchors } else { &anchors[k] };
            *key = (pairs[k].a, pairs[k].b);
            *compact = *key;
            write(out, h, Some(anchors))
        };
        s.next_cache.resize(s.by_pair.len(), ((0, 0), CachedManifold::default()));
        s.cache_keys.resize(s.by_pair.len(), (0, 0));
        let rows = s.next_cache.par_iter_mut().zip(s.cache_keys.par_iter_mut()).zip(s.by_pair.par_iter());
        let impulses = rows.map(entry).fold(|| [0; 3], count).reduce(|| [0; 3], add);
        std::mem::swap(&mut s.cache, &mut s.next_cache);
        impulses
    };
    for (total, n) in ctx.stats.impulses.iter_mut().zip(impulses) {
        *total += n;
    }
}

/// Each used lane's impulses after the substeps into `group.impulses` (`remember`): its points'
/// normal impulses and its friction patch's, turned into world vectors.
fn lane_impulses(group: &mut ConstraintGroup) {
    let ConstraintGroup { batches, points, fill, impulses, .. } = group;
    impulses.resize(batches.len() * LANES, LaneImpulses::default());
    let rows = impulses.par_chunks_mut(LANES).zip(batches.par_iter().zip(fill.par_iter()));
    rows.for_each(|(out, (batch, &count))| {
        let rows = &points[batch.rows()];
        for (lane, out) in out.iter_mut().enumerate().take(usize::from(count)) {
            let [n, t1, t2] = batch.axes(lane);
            let [j1, j2, jw] = batch.friction.impulse.map(|j| j[lane]);
            (out.tangent, out.twist) = (t1 * j1 + t2 * j2, n * jw);
            for (normal, row) in out.normal.iter_mut().zip(rows) {
                *normal = row.impulse[lane];
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random unit quaternion.
    fn turn(rng: &mut crate::rng::SplitMix64) -> Quat {
        let v = Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        Quat::from_axis_angle(v.normalize_or(Vector::X), rng.uniform(-3.0, 3.0))
    }

    /// In a pool of two, lists that grow, shrink and keep their length, all wanted or not: the
    /// copy is the plain filtered one, pair for pair.
    #[test]
    fn pairs_copied_in_a_pool_of_two_are_the_filtered_pairs_in_order() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let list = |n: u32, seed: u32| -> Vec<Pair> {
            (0..n)
                .map(|k| Pair {
                    state: if (k + seed).is_multiple_of(7) { PairState::Near } else { PairState::Candidate },
                    ..Pair::candidate(k, k + 1 + seed)
                })
                .collect()
        };
        let mut out = Vec::new();
        for (n, seed) in [(0, 0), (5, 1), (3000, 2), (3000, 3), (1200, 4), (4001, 5), (1, 6), (2, 7)] {
            let pairs = list(n, seed);
            let wants: [&(dyn Fn(&Pair) -> bool + Sync); 2] = [&|_| true, &|p| !p.is_near()];
            for wanted in wants {
                pool.install(|| copy_pairs(&pairs, &mut out, wanted));
                let plain: Vec<Pair> = pairs.iter().filter(|p| wanted(p)).copied().collect();
                assert_eq!(out, plain, "{n} pairs");
            }
        }
    }

    #[test]
    fn four_pairs_recycled_as_one_at_a_time() {
        let mut rng = crate::rng::SplitMix64::new(11);
        let mut b = Bodies::default();
        for _ in 0..8 {
            let q = turn(&mut rng);
            b.position.push(Vector::new(rng.uniform(-2.0, 2.0), rng.uniform(0.0, 3.0), rng.uniform(-2.0, 2.0)));
            b.orientation.push(q);
            b.rotation.push(crate::math::Mat3::from_quat(q));
            b.radius.push(rng.uniform(0.2, 1.5));
        }
        let (mut still, mut moved) = (0, 0);
        for _ in 0..400 {
            let ends: [(usize, usize); 4] = std::array::from_fn(|_| {
                let ia = (rng.next_u64() % 8) as usize;
                (ia, (ia + 1 + (rng.next_u64() % 7) as usize) % 8)
            });
            let anchors: [ContactAnchors; 4] = std::array::from_fn(|l| {
                let mut m = Manifold { len: 1 + (rng.next_u64() % 4) as usize, ..Manifold::default() };
                for k in 0..m.len {
                    m.points[k] = Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(0.0, 2.0), rng.uniform(-1.0, 1.0));
                    m.gaps[k] = rng.uniform(-0.01, 0.01);
                }
                let normal = turn(&mut rng) * Vector::Y;
                fixed_to_bodies(&m, normal, &b, ends[l].0, ends[l].1)
            });
            // Then the bodies move by anything from nothing to far more than the distance.
            let before = b.clone();
            for i in 0..8 {
                let size = 10.0_f64.powf(rng.uniform(-9.0, -1.0));
                b.position[i] +=
                    Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)) * size;
                let q = (Quat::from_scaled_axis(turn(&mut rng).xyz() * size) * b.orientation[i]).normalize();
                (b.orientation[i], b.rotation[i]) = (q, crate::math::Mat3::from_quat(q));
            }
            let thin: [Scalar; 4] = std::array::from_fn(|_| rng.uniform(0.1, 1.0));
            let mut four = [Recycling::default(); 4];
            let [r0, r1, r2, r3] = four.each_mut();
            recycled_four(anchors.each_ref(), &b, thin, ends, [Some(r0), Some(r1), Some(r2), Some(r3)]);
            for l in 0..4 {
                let (ia, ib) = ends[l];
                let m = recycled_points(&anchors[l], &b, thin[l], ia, ib);
                let c = m.as_ref().and_then(|m| recycled_contact(m, &anchors[l], &b, ia, Feature::Face));
                // Debug prints every distinct f64 (signed zeros too) differently.
                assert_eq!(format!("{:?}", (four[l].manifold, four[l].contact)), format!("{:?}", (m, c)));
                if m.is_some() { still += 1 } else { moved += 1 }
            }
            b = before;
        }
        assert!(still > 200 && moved > 200, "both kinds of pair: {still} still, {moved} moved");
    }

    #[test]
    fn the_arc_cosine_bounds_hold_the_arc_cosine_between_them() {
        let mut rng = crate::rng::SplitMix64::new(9);
        let near_one = (0..2000).map(|k| 1.0 - Scalar::EPSILON * Scalar::from(k) / 2.0);
        let spread = (0..20_000).map(|_| rng.unit());
        let tiny = (0..2000).map(|k| 1.0 - 1e-12 * Scalar::from(k));
        for c in near_one.chain(spread).chain(tiny).chain([0.0, 0.5, 1.0]) {
            let [low, high] = acos_bounds(c);
            assert!(low <= c.acos() && c.acos() <= high, "c = {c}: {} not in [{low}, {high}]", c.acos());
        }
    }
}
