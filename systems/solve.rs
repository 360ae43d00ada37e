//! `solve`: resting contact, friction and impacts under gravity, the paper's "future work".
//! Sequential impulses over contact manifolds (up to four points a pair), with accumulated
//! normal impulses clamped at zero and Coulomb friction held within μ times them, warm-started
//! from the previous step's impulses (Catto, "Iterative Dynamics with Temporal Coherence",
//! 2005), solved as a "soft step" (Catto, "Solver2D", 2024; Box2D v3; rapier's TGS): the step
//! is cut into substeps, penetration is pushed out by a stiff damped spring and a rigid relax
//! pass takes the push-out velocity back, so penetration is removed without adding energy.
//! The kernel and its data are in `solver.rs`; this file finds the manifolds and builds the
//! constraints.
//!
//! Each pair is held along its least-overlap axis (`manifold::contact_axis`), not the detection
//! tests' normal, with speculative points for gaps that may close within the step
//! (`Params::speculative_distance`). A pair that has hardly moved since its points were found
//! keeps them (contact recycling). Constraints are solved lowest first, so one sweep carries a
//! stack's support from the ground up.
//!
//! It takes every contact under gravity (impacts bounce here, per point, after the substeps)
//! and every contact with friction. Without gravity and friction it does nothing, so the
//! paper's frictionless results, `resolve`'s, are unchanged. `correct` leaves the pairs held
//! here alone.

use crate::bodies::Bodies;
use crate::contact::{Contact, Feature, Pair, PairState};
use crate::manifold::{ClipScratch, Manifold, contact_axis, manifold, support_point};
use crate::math::{Mat3, Quat, Scalar, Vector, exp_map};
use crate::solver::{
    self, Batch, BodyStore, Constraint, ContactPoint, Friction, PointRows, Sides, Softness, SolverBody,
};
use crate::step::{CachedManifold, ConstraintGroup, Geometry, HeldPair, SolveScratch, StepContext};
use hecs::World;
use rayon::prelude::*;

/// A new point takes the impulse of last step's point within this distance on A [fraction of
/// A's radius]: the same corner one step later.
const MATCH_DISTANCE: Scalar = 0.05;

/// Fastest push out of a penetration [m/s] (Box2D v3's and rapier's 3 m/s): faster, a cube
/// squeezed into a pile is shot out of it.
const MAX_PUSH: Scalar = 3.0;

/// Relative motion [fraction of the thinner body] below which a pair keeps last step's contact
/// points: rapier recycles below 5 cm; a tenth of that keeps a sliding or tipping body's
/// points fresh.
const RECYCLE_DISTANCE: Scalar = 0.005;

/// Holds resting contacts, applies friction and bounces impacts (see the module docs).
///
/// - Reads: `ctx.pairs` (`Candidate`, `Found`, `Resolved`), `ctx.posed`, `ctx.bodies`,
///   `ctx.scratch.solve`.
/// - Writes: `ctx.bodies` velocities and the poses of the bodies it holds (and the world's),
///   `ctx.stats.impulses` (one per pair held), the warm-start cache.
/// - Paper: none (resting contact and friction are the paper's future work).
/// - Cost: O(P) to find and build P points, O(P · substeps · (iterations + 2)) to solve.
pub fn solve(world: &mut World, ctx: &mut StepContext) {
    let (b, params, dt) = (&ctx.bodies, &ctx.params, ctx.dt);
    let resting = |p: &Pair| params.resting_contacts(dt, b.pair_friction(p.a as usize, p.b as usize));
    let s = &mut ctx.scratch.solve;
    s.step = ctx.step;
    s.pairs.clear();
    let open = |p: &Pair| p.contact().is_some() || p.is_candidate() || p.is_near();
    s.pairs.extend(ctx.pairs.iter().filter(|p| open(p) && resting(p)).copied());
    if s.pairs.is_empty() {
        s.cache.clear();
        s.held.clear();
        return;
    }
    ctx.pose_pairs(open);
    find_manifolds(ctx);
    build_constraints(ctx);
    substeps(ctx);
    remember(ctx);
    ctx.bodies.store(world);
}

/// Each pair's manifold: recycled from the previous step when the two bodies have hardly
/// moved relative to each other (`still`), else found afresh along the pair's least-overlap
/// axis (`contact_axis`, `manifold`).
fn find_manifolds(ctx: &mut StepContext) {
    let s = &mut ctx.scratch.solve;
    let (posed, meshes, b, params, dt) = (&ctx.posed, &ctx.meshes, &ctx.bodies, &ctx.params, ctx.dt);
    let margin = params.contact_margin;
    let n = s.pairs.len();
    s.manifolds.resize(n, Manifold::default());
    s.geometry.resize(n, Geometry::default());
    s.recycled.resize(n, false);
    s.near.clear();
    s.near.extend(s.pairs.iter().map(|p| p.is_candidate() || p.is_near()));
    // Each pair's entry in last step's cache: both lists are in pair order, so one merge.
    s.cached.clear();
    let mut at = 0;
    for pair in &s.pairs {
        let key = (pair.a, pair.b);
        while at < s.cache.len() && s.cache[at].0 < key {
            at += 1;
        }
        s.cached.push(if at < s.cache.len() && s.cache[at].0 == key { at as u32 } else { u32::MAX });
    }
    let cache = &s.cache;
    let cached = &s.cached;
    let rows = s.pairs.par_iter_mut().zip(s.manifolds.par_iter_mut());
    let rows = rows.zip(s.geometry.par_iter_mut().zip(s.recycled.par_iter_mut())).zip(cached.par_iter());
    rows.for_each_init(ClipScratch::default, |scratch, (((pair, m), (geometry, recycled)), &entry)| {
        let (ia, ib) = (pair.a as usize, pair.b as usize);
        let thin = b.thinner(meshes, ia, ib);
        let reach = margin * thin + params.speculative_distance(dt, b, ia) + params.speculative_distance(dt, b, ib);
        let feature = pair.contact().map_or(Feature::Face, |c| c.feature);
        let old = (entry != u32::MAX).then(|| &cache[entry as usize].1.geometry);
        *recycled = false;
        if let Some(old) = old.filter(|g| still(g, b, ia, ib, RECYCLE_DISTANCE * thin)) {
            *recycled = true;
            *geometry = *old;
            *m = placed(old, b, ia, ib);
            let deepest = (0..m.len).min_by(|&x, &y| m.gaps[x].total_cmp(&m.gaps[y])).unwrap_or(0);
            if m.len == 0 || m.gaps[deepest] > reach {
                m.len = 0;
                pair.state = PairState::Candidate; // drawn apart
            } else {
                let normal = b.rotation[ia] * old.normal;
                pair.state =
                    PairState::Resolved(Contact { point: m.points[deepest], normal, depth: -m.gaps[deepest], feature });
            }
            return;
        }
        let (pa, pb) = (posed.get(pair.a), posed.get(pair.b));
        // Held along the pair's least-overlap axis (see `contact_axis`), touching or a hair
        // apart (speculatively); the tests' own normal and depth decide only that it touches.
        let Some(axis) = contact_axis(pa, pb, (margin * thin, reach)) else {
            m.len = 0;
            pair.state = PairState::Candidate; // apart: no constraint
            return;
        };
        let point = support_point(pa, pb, &axis);
        pair.state = PairState::Resolved(Contact { point, normal: axis.normal, depth: -axis.separation, feature });
        *m = manifold(pa, pb, &axis, reach, scratch);
        if m.len == 0 {
            // Edge across edge, or nothing left by the clipping: one point where they meet.
            (m.points[0], m.gaps[0], m.len) = (point, axis.separation, 1);
        }
        *geometry = fixed_to_bodies(m, axis.normal, b, ia, ib);
    });
}

/// True when B has moved, relative to A, by less than `distance` [m] since `g` was found: the
/// shift of its centre plus the arc its rotation sweeps at its bounding radius.
fn still(g: &Geometry, b: &Bodies, ia: usize, ib: usize, distance: Scalar) -> bool {
    let (offset, turn) = relative(b, ia, ib);
    let arc = turn.angle_between(g.turn) * b.radius[ib];
    (offset - g.offset).length() + arc < distance
}

/// B's centre in A's frame and its orientation relative to A's.
fn relative(b: &Bodies, ia: usize, ib: usize) -> (Vector, Quat) {
    (b.rotation[ia].transpose() * (b.position[ib] - b.position[ia]), b.orientation[ia].inverse() * b.orientation[ib])
}

/// The manifold's points fixed to the bodies: each point's ends on A and on B (half its gap
/// either side along the normal) in their body frames.
fn fixed_to_bodies(m: &Manifold, normal: Vector, b: &Bodies, ia: usize, ib: usize) -> Geometry {
    let (offset, turn) = relative(b, ia, ib);
    let (ra, rb) = (b.rotation[ia].transpose(), b.rotation[ib].transpose());
    let mut g = Geometry { offset, turn, normal: ra * normal, len: m.len, ..Geometry::default() };
    for k in 0..m.len {
        let half = normal * (0.5 * m.gaps[k]);
        g.on_a[k] = ra * (m.points[k] + half - b.position[ia]);
        g.on_b[k] = rb * (m.points[k] - half - b.position[ib]);
    }
    g
}

/// The manifold of the fixed points `g` at the bodies' current poses: each point halfway
/// between its two ends, its gap their separation along the normal (turned with A).
fn placed(g: &Geometry, b: &Bodies, ia: usize, ib: usize) -> Manifold {
    let normal = b.rotation[ia] * g.normal;
    let mut m = Manifold { len: g.len, ..Manifold::default() };
    for k in 0..g.len {
        let on_a = b.position[ia] + b.rotation[ia] * g.on_a[k];
        let on_b = b.position[ib] + b.rotation[ib] * g.on_b[k];
        (m.points[k], m.gaps[k]) = (0.5 * (on_a + on_b), (on_a - on_b).dot(normal));
    }
    m
}

/// One constraint per held pair and one point per manifold point (lever vectors, effective
/// masses, the impulses of last step's matching point), placed in batches of independent
/// constraints (`solver::place`), and the solver bodies they act on.
fn build_constraints(ctx: &mut StepContext) {
    let b = &ctx.bodies;
    let (params, dt) = (&ctx.params, ctx.dt);
    let s = &mut ctx.scratch.solve;
    // Lowest contacts first: each forward sweep then carries the support up a stack in one
    // pass. The order matters: top-down sweeps let a tall pyramid wobble. Ties keep pair order.
    let up = -params.gravity.normalize_or_zero();
    s.order.clear();
    let held = s.manifolds.iter().enumerate().filter(|&(k, m)| m.len > 0 && s.pairs[k].contact().is_some());
    s.order
        .extend(held.map(|(k, m)| (m.points().iter().map(|p| p.dot(up)).sum::<Scalar>() / m.len as Scalar, k as u32)));
    s.order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    gather_bodies(b, s);
    // Each constraint's group: within the first side, within the second, or across; then its
    // batches, each group placed on its own.
    let (left, last) = (s.left as u32, s.bodies.len() as u32 - 1);
    s.groups[0].offset = 0;
    s.groups[0].fixed = left;
    s.groups[1].offset = left + 1;
    s.groups[1].fixed = last - (left + 1);
    s.groups[2].offset = 0;
    s.groups[2].fixed = last;
    for group in &mut s.groups {
        group.slots.clear();
    }
    s.held.clear();
    for &(_, k) in &s.order {
        let pair = &s.pairs[k as usize];
        let slot = [s.slot[pair.a as usize], s.slot[pair.b as usize]];
        let side = |i: u32| if i == left || i == last { None } else { Some(i > left) };
        let group = match (side(slot[0]), side(slot[1])) {
            (Some(true), Some(true) | None) | (None, Some(true)) => 1,
            (Some(false), Some(false) | None) | (None, Some(false)) | (None, None) => 0,
            _ => 2,
        };
        let g = &mut s.groups[group];
        let local = |i: u32| if i == left || i == last { g.fixed } else { i - g.offset };
        let slot = [local(slot[0]), local(slot[1])];
        g.slots.push(slot);
        s.held.push(HeldPair {
            pair: k,
            group: group as u8,
            batch: 0,
            lane: 0,
            len: s.manifolds[k as usize].len as u8,
        });
    }
    for group in &mut s.groups {
        solver::place(&group.slots, group.fixed, &mut s.last, &mut group.fill, &mut group.placed);
        group.batches.clear();
        group.batches.extend(group.fill.iter().map(|_| Batch::idle(group.fixed)));
    }
    let mut next = [0_usize; 3];
    for held in &mut s.held {
        let g = &mut s.groups[usize::from(held.group)];
        (held.batch, held.lane) = g.placed[next[usize::from(held.group)]];
        next[usize::from(held.group)] += 1;
        let batch = &mut g.batches[held.batch as usize];
        batch.len = batch.len.max(u32::from(held.len));
    }
    for group in &mut s.groups {
        let mut first = 0;
        for batch in &mut group.batches {
            batch.first = first;
            first += batch.len;
        }
        group.points.clear();
        group.points.resize(first as usize, PointRows::default());
    }
    // The two sides' groups filled at once (they write disjoint batches), then the third.
    let SolveScratch {
        groups,
        held,
        pairs,
        manifolds,
        slot,
        scale,
        left,
        bodies,
        cache,
        cached,
        geometry,
        recycled,
        ..
    } = s;
    let shared = Shared {
        b,
        params,
        dt,
        meshes: &ctx.meshes,
        held,
        pairs,
        manifolds,
        slot,
        scale,
        statics: [*left as u32, bodies.len() as u32 - 1],
        cache,
        cached,
        geometry,
        recycled,
    };
    let [first, second, across] = groups;
    rayon::join(|| fill(&shared, 0, first), || (fill(&shared, 1, second), fill(&shared, 2, across)));
}

/// What `fill` reads.
struct Shared<'a> {
    b: &'a Bodies,
    params: &'a crate::step::Params,
    dt: Scalar,
    meshes: &'a crate::mesh::MeshTable,
    held: &'a [HeldPair],
    pairs: &'a [Pair],
    manifolds: &'a [Manifold],
    slot: &'a [u32],
    scale: &'a [Mat3],
    statics: [u32; 2],
    cache: &'a [((u32, u32), CachedManifold)],
    cached: &'a [u32],
    geometry: &'a [Geometry],
    recycled: &'a [bool],
}

/// Writes the constraints and points of group `which`'s held pairs into its batches.
fn fill(sh: &Shared, which: u8, group: &mut ConstraintGroup) {
    let (b, params, dt) = (sh.b, sh.params, sh.dt);
    // Restitution reverses the approach before gravity's pull this step (Box2D v3 measures it
    // before integrating forces).
    let before = |i: usize| b.velocity[i] - if b.is_fixed(i) { Vector::ZERO } else { params.gravity * dt };
    for held in sh.held.iter().filter(|h| h.group == which) {
        let (k, lane) = (held.pair, held.lane);
        let (pair, m) = (&sh.pairs[k as usize], &sh.manifolds[k as usize]);
        let contact = pair.contact().expect("ordered pairs have contacts");
        let (ia, ib) = (pair.a as usize, pair.b as usize);
        let n = contact.normal;
        let tangents = tangents(n);
        let thin = b.thinner(sh.meshes, ia, ib);
        let global = [sh.slot[ia], sh.slot[ib]];
        let scale = [sh.scale[global[0] as usize], sh.scale[global[1] as usize]];
        let slot = global.map(|i| if sh.statics.contains(&i) { group.fixed } else { i - group.offset });
        let inv_mass = [b.inv_mass[ia], b.inv_mass[ib]];
        let cached = (sh.cached[k as usize] != u32::MAX).then(|| &sh.cache[sh.cached[k as usize] as usize].1);
        let mu = b.pair_friction(ia, ib);
        let (geometry, recycled) = (&sh.geometry[k as usize], sh.recycled[k as usize]);
        let into = &mut group.batches[held.batch as usize];
        let first = into.first as usize;
        // The friction patch's centre: the mean of the points.
        let centre = m.points().iter().sum::<Vector>() / m.len as Scalar;
        let mut rows = [ContactPoint::IDLE; crate::manifold::MAX_POINTS];
        for (j, (&p, &gap)) in m.points().iter().zip(&m.gaps).enumerate() {
            let r = [p - b.position[ia], p - b.position[ib]];
            let g = [scale[0] * r[0].cross(n), scale[1] * r[1].cross(n)];
            let approach =
                (before(ia) + b.angular_velocity[ia].cross(r[0]) - before(ib) - b.angular_velocity[ib].cross(r[1]))
                    .dot(n);
            // A recycled point is last step's own; a new one takes the impulse of the old
            // point at the same place on A, if any.
            let old = cached.and_then(|c| {
                let near = |q: usize| (c.geometry.on_a[q] - geometry.on_a[j]).length() <= MATCH_DISTANCE * b.radius[ia];
                if recycled { Some(j) } else { (0..c.geometry.len).find(|&q| near(q)) }.map(|q| c.normal[q])
            });
            let k = inv_mass[0] + inv_mass[1] + g[0].length_squared() + g[1].length_squared();
            rows[j] = ContactPoint {
                g,
                mass: inverse(k),
                k,
                impulse: old.unwrap_or(0.0),
                gap,
                // Only a new point bounces (rapier's rule): one held since last step is resting
                // or rocking on it, and bouncing there keeps a settling pile astir.
                approach: if old.is_some() { 0.0 } else { approach },
                max_impulse: 0.0,
                lever: (p - centre).length(),
                coupling: 0.0,
            };
        }
        // Each pair of points' coupling (`solver::ContactPoint::coupling`).
        for j in (0..m.len.saturating_sub(1)).step_by(2) {
            let (p, q) = (&rows[j], &rows[j + 1]);
            rows[j].coupling = inv_mass[0] + inv_mass[1] + p.g[0].dot(q.g[0]) + p.g[1].dot(q.g[1]);
        }
        for (j, row) in rows[..m.len].iter().enumerate() {
            group.points[first + j].set(lane as usize, row);
        }
        into.set(
            lane as usize,
            &Constraint {
                slot,
                normal: n,
                tangents,
                inv_mass,
                mu,
                restitution: 0.5 * (b.restitution[ia] + b.restitution[ib]),
                slop: params.slop * thin,
                max_push: (params.max_correction * thin / dt).min(MAX_PUSH),
                friction: if mu > 0.0 {
                    friction_patch(centre, [b.position[ia], b.position[ib]], n, tangents, inv_mass, scale, cached)
                } else {
                    Friction::IDLE
                },
            },
        );
    }
}

/// 1/k, or 0 for k = 0 (a row between two fixed bodies, or an idle one).
fn inverse(k: Scalar) -> Scalar {
    if k > 0.0 { 1.0 / k } else { 0.0 }
}

/// The friction rows of a pair at its patch `centre` (see `solver::Friction`), warm-started
/// from last step's patch impulses.
fn friction_patch(
    centre: Vector,
    position: [Vector; 2],
    n: Vector,
    tangents: [Vector; 2],
    inv_mass: [Scalar; 2],
    scale: [Mat3; 2],
    cached: Option<&CachedManifold>,
) -> Friction {
    let r = [centre - position[0], centre - position[1]];
    let g = tangents.map(|t| [scale[0] * r[0].cross(t), scale[1] * r[1].cross(t)]);
    // K = J M⁻¹ Jᵀ over the two tangent rows (their linear parts are orthogonal).
    let linear = inv_mass[0] + inv_mass[1];
    let k11 = linear + g[0][0].length_squared() + g[0][1].length_squared();
    let k22 = linear + g[1][0].length_squared() + g[1][1].length_squared();
    let k12 = g[0][0].dot(g[1][0]) + g[0][1].dot(g[1][1]);
    let det = k11 * k22 - k12 * k12;
    let mass = if det > 0.0 { [k22 / det, -k12 / det, k11 / det] } else { [inverse(k11), 0.0, inverse(k22)] };
    let twist = [scale[0] * n, scale[1] * n];
    let (jt, jw) = cached.map_or((Vector::ZERO, Vector::ZERO), |c| (c.tangent, c.twist));
    Friction {
        g,
        twist,
        mass,
        twist_mass: inverse(twist[0].length_squared() + twist[1].length_squared()),
        impulse: [jt.dot(tangents[0]), jt.dot(tangents[1]), jw.dot(n)],
    }
}

/// Constraints below this many are solved as one group: splitting costs more than it saves.
const SPLIT_MIN: usize = 256;

/// Gives each free body of the held pairs a solver body and computes each one's
/// S = (I⁻¹)^½ in world axes, S = R diag(1/√I_p) Rᵀ with R the principal frame in world axes.
///
/// The free bodies are split in two sides at their median along the horizontal axis of
/// widest spread (a scene with fewer than `SPLIT_MIN` constraints stays on one side); solver
/// bodies are the first side's, its static slot, the second side's, and the last static slot.
/// Every fixed body maps to a static slot. The split depends on the scene only, never on the
/// thread count, so runs are the same on one thread or two.
fn gather_bodies(b: &Bodies, s: &mut SolveScratch) {
    for &i in &s.moving {
        s.slot[i as usize] = u32::MAX;
    }
    s.slot.resize(b.len(), u32::MAX);
    s.moving.clear();
    let ends = s.order.iter().flat_map(|&(_, k)| [s.pairs[k as usize].a, s.pairs[k as usize].b]);
    s.moving.extend(ends.filter(|&i| !b.is_fixed(i as usize)));
    s.moving.sort_unstable();
    s.moving.dedup();
    s.left = s.moving.len();
    if s.order.len() >= SPLIT_MIN {
        // The horizontal axis (across gravity) along which the bodies spread widest.
        let spread = |axis: Vector| {
            let along = s.moving.iter().map(|&i| b.position[i as usize].dot(axis));
            let (lo, hi) = along.fold((Scalar::INFINITY, Scalar::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)));
            hi - lo
        };
        let axis = if spread(Vector::X) >= spread(Vector::Z) { Vector::X } else { Vector::Z };
        s.keys.clear();
        s.keys.extend(s.moving.iter().map(|&i| (b.position[i as usize].dot(axis), i)));
        s.keys.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        s.moving.clear();
        s.moving.extend(s.keys.iter().map(|k| k.1));
        s.left = s.moving.len() / 2;
    }
    let (left, last) = (s.left as u32, s.moving.len() as u32 + 1);
    for (k, &i) in s.moving.iter().enumerate() {
        s.slot[i as usize] = if (k as u32) < left { k as u32 } else { k as u32 + 1 };
    }
    for pair in &s.pairs {
        for i in [pair.a, pair.b] {
            if b.is_fixed(i as usize) {
                s.slot[i as usize] = last;
            }
        }
    }
    // S and S⁻¹; for equal principal moments (cubes, spheres) multiples of the identity,
    // whatever the orientation.
    let scale = |i: usize| {
        let m = b.principal_moments[i];
        if m.x == m.y && m.y == m.z {
            return (
                Mat3::from_diagonal(Vector::splat(1.0 / m.x.sqrt())),
                Mat3::from_diagonal(Vector::splat(m.x.sqrt())),
            );
        }
        let r = Mat3::from_quat(b.orientation[i] * b.principal_axes[i]);
        let s = |d: Vector| r * Mat3::from_diagonal(d) * r.transpose();
        (s(m.map(|m| 1.0 / m.sqrt())), s(m.map(Scalar::sqrt)))
    };
    s.scale.clear();
    s.bodies.clear();
    for (k, &i) in s.moving.iter().enumerate() {
        if k == s.left {
            s.scale.push(Mat3::ZERO);
            s.bodies.push(SolverBody::default());
        }
        let (i, (scale, unscale)) = (i as usize, scale(i as usize));
        s.bodies.push(SolverBody { v: b.velocity[i], w: unscale * b.angular_velocity[i], ..SolverBody::default() });
        s.scale.push(scale);
    }
    if s.left == s.moving.len() {
        s.scale.push(Mat3::ZERO);
        s.bodies.push(SolverBody::default());
    }
    s.scale.push(Mat3::ZERO);
    s.bodies.push(SolverBody::default());
}

/// Two unit vectors completing `n` to a right-handed orthonormal basis.
fn tangents(n: Vector) -> [Vector; 2] {
    let helper = if n.x.abs() < 0.57 { Vector::X } else { Vector::Y };
    let t1 = n.cross(helper).normalize();
    [t1, n.cross(t1)]
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
fn substeps(ctx: &mut StepContext) {
    let (params, dt) = (&ctx.params, ctx.dt);
    let count = params.substeps.max(1);
    let h = dt / Scalar::from(count);
    let soft = Softness::new(h);
    let s = &mut ctx.scratch.solve;
    let mut plan = vec![Step::Push(-params.gravity * dt)];
    for _ in 0..count {
        plan.extend([Step::Push(params.gravity * h), Step::Pass(Pass::Warm)]);
        plan.extend((0..params.iterations).map(|_| Step::Pass(Pass::Solve(soft))));
        plan.extend([Step::Move(h), Step::Pass(Pass::Relax)]);
    }
    plan.push(Step::Pass(Pass::Restitution(params.restitution_threshold(dt))));
    drive(s, &plan, h);
    let statics = [s.left, s.bodies.len() - 1];
    let b = &mut ctx.bodies;
    let bodies = s.bodies.iter().zip(&s.scale).enumerate().filter(|(k, _)| !statics.contains(k));
    for (&i, (_, (body, scale))) in s.moving.iter().zip(bodies) {
        let i = i as usize;
        b.velocity[i] = body.v;
        b.angular_velocity[i] = *scale * body.w;
        b.position[i] += body.dx - body.v * dt;
        b.orientation[i] = (exp_map(*scale * body.dq - b.angular_velocity[i] * dt) * b.orientation[i]).normalize();
    }
    for k in 0..ctx.scratch.solve.moving.len() {
        ctx.mark_moved(ctx.scratch.solve.moving[k] as usize);
    }
}

/// A pass of the kernel over a constraint group.
#[derive(Clone, Copy, Debug)]
enum Pass {
    /// Re-apply the accumulated impulses.
    Warm,
    /// A solve sweep with this contact spring.
    Solve(Softness),
    /// The rigid relax sweep, with friction.
    Relax,
    /// Bounce the impacts faster than this [m/s].
    Restitution(Scalar),
}

/// One step of the substeps' plan.
#[derive(Clone, Copy, Debug)]
enum Step {
    /// A pass over every group.
    Pass(Pass),
    /// Add this to every free body's velocity (gravity's share).
    Push(Vector),
    /// Move every free body on by its velocity over this time [s].
    Move(Scalar),
}

/// Runs `pass` on group `g` with its bodies `bodies`.
fn run<B: BodyStore + ?Sized>(pass: Pass, bodies: &mut B, g: &mut ConstraintGroup, h: Scalar) {
    match pass {
        Pass::Warm => solver::warm_start(bodies, &g.batches, &mut g.points),
        Pass::Solve(soft) => solver::sweep(bodies, &mut g.batches, &mut g.points, h, Some(soft)),
        Pass::Relax => solver::sweep(bodies, &mut g.batches, &mut g.points, h, None),
        Pass::Restitution(threshold) => solver::restitution(bodies, &g.batches, &mut g.points, threshold),
    }
}

/// Applies a body step to the free bodies of one side (its last slot is static).
fn apply(step: Step, side: &mut [SolverBody]) {
    let free = side.len() - 1;
    match step {
        Step::Push(dv) => side[..free].iter_mut().for_each(|b| b.v += dv),
        Step::Move(h) => side[..free].iter_mut().for_each(|b| {
            b.dx += b.v * h;
            b.dq += b.w * h;
        }),
        Step::Pass(_) => {}
    }
}

/// Carries out the plan. Each pass runs over the first side's constraints and the second's,
/// which share no free body and whose bodies are separate slices, then over the constraints
/// across. With two threads the second side runs on the other thread of the pool, handed its
/// slice for each pass and spinning between passes (a rayon join a pass cost more in waking
/// a worker than it saved). Either way the arithmetic is the same, so the result does not
/// depend on threads.
fn drive(s: &mut SolveScratch, plan: &[Step], h: Scalar) {
    let [first, second, across] = &mut s.groups;
    let (left, right) = s.bodies.split_at_mut(s.left + 1);
    let threaded = !second.batches.is_empty() && rayon::current_num_threads() > 1;
    if !threaded {
        for &step in plan {
            let Step::Pass(pass) = step else {
                apply(step, left);
                apply(step, right);
                continue;
            };
            run(pass, left, first, h);
            if !second.batches.is_empty() {
                run(pass, right, second, h);
            }
            if !across.batches.is_empty() {
                run(pass, &mut Sides { left: &mut *left, right: &mut *right }, across, h);
            }
        }
        return;
    }
    // Two of the pool's own threads, not a new one each step: a fresh thread lands on either
    // core, away from the cache that holds its side's constraints. `broadcast` runs the
    // closure on every thread of the pool at once; the calling thread drives the plan, the
    // next one solves the second side, any others return.
    let me = rayon::current_thread_index().unwrap_or(0);
    let helper_index = (me + 1) % rayon::current_num_threads();
    let (to_helper, work) = std::sync::mpsc::channel::<Option<(&mut [SolverBody], Pass)>>();
    let (to_main, done) = std::sync::mpsc::channel::<&mut [SolverBody]>();
    let helper = std::sync::Mutex::new(Some((second, work, to_main)));
    let main = std::sync::Mutex::new(Some((left, right, first, across, to_helper, done)));
    rayon::broadcast(|ctx| {
        if ctx.index() == helper_index {
            let taken = helper.lock().map(|mut h| h.take()).ok().flatten();
            let Some((second, work, to_main)) = taken else { return };
            while let Some(Some((right, pass))) = spin(&work) {
                run(pass, right, second, h);
                if to_main.send(right).is_err() {
                    return;
                }
            }
        } else if ctx.index() == me {
            let taken = main.lock().map(|mut m| m.take()).ok().flatten();
            let Some((left, right, first, across, to_helper, done)) = taken else { return };
            let mut right = Some(right);
            for &step in plan {
                let mut r = right.take().expect("the second side is back between passes");
                let Step::Pass(pass) = step else {
                    apply(step, left);
                    apply(step, r);
                    right = Some(r);
                    continue;
                };
                to_helper.send(Some((r, pass))).expect("the helper runs until told to stop");
                run(pass, left, first, h);
                r = spin(&done).expect("the helper hands the second side back");
                if !across.batches.is_empty() {
                    run(pass, &mut Sides { left: &mut *left, right: &mut *r }, across, h);
                }
                right = Some(r);
            }
            // A failed send means the helper has stopped already (it panicked).
            let _ = to_helper.send(None);
        }
    });
}

/// The next message on `channel`, spinning while it is empty (a pass takes tens of
/// microseconds: parking the thread would cost more); `None` once the sender is gone.
fn spin<T>(channel: &std::sync::mpsc::Receiver<T>) -> Option<T> {
    loop {
        match channel.try_recv() {
            Ok(message) => return Some(message),
            Err(std::sync::mpsc::TryRecvError::Empty) => std::hint::spin_loop(),
            Err(std::sync::mpsc::TryRecvError::Disconnected) => return None,
        }
    }
}

/// Keeps this step's geometry and impulses for the next step, and counts one impulse per pair
/// held (by the feature that found its contact; near pairs no test found are not counted).
fn remember(ctx: &mut StepContext) {
    let s = &mut ctx.scratch.solve;
    s.cache.clear();
    // In pair order, which is the cache's: sorting the entries themselves (300 bytes each)
    // cost a third of a millisecond on a 40-row pyramid.
    s.by_pair.clear();
    s.by_pair.extend((0..s.held.len() as u32).map(|h| (s.held[h as usize].pair, h)));
    s.by_pair.sort_unstable();
    for &(_, h) in &s.by_pair {
        let held = &s.held[h as usize];
        let pair = &s.pairs[held.pair as usize];
        let group = &s.groups[usize::from(held.group)];
        let (batch, lane) = (&group.batches[held.batch as usize], usize::from(held.lane));
        let [n, t1, t2] = batch.axes(lane);
        let [j1, j2, jw] = batch.friction.impulse.map(|j| j[lane]);
        let mut entry = CachedManifold {
            geometry: s.geometry[held.pair as usize],
            tangent: t1 * j1 + t2 * j2,
            twist: n * jw,
            ..CachedManifold::default()
        };
        for j in 0..usize::from(held.len) {
            entry.normal[j] = group.points[batch.first as usize + j].impulse[lane];
        }
        s.cache.push(((pair.a, pair.b), entry));
        let pushed = entry.normal.iter().any(|&j| j > 0.0);
        if let (Some(contact), false, true) = (pair.contact(), s.near[held.pair as usize], pushed) {
            ctx.stats.impulses[contact.feature as usize] += 1;
        }
    }
}
