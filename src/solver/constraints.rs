//! Building the contact solver's constraints from the `solve` system's manifolds: solver
//! bodies (with the split in two sides), batches of independent constraints, and each held
//! pair's rows with the impulses of last step's matching points.

use super::fill::LaneInputs;
use super::{Batch, LANES, PointRows, SolverBody};
#[cfg(test)]
use super::{Constraint, ContactPoint};
use crate::collision::contact::Pair;
use crate::collision::manifold::Manifold;
use crate::math::{Mat3, Scalar, Vector, total_order_key};
use crate::sim::bodies::Bodies;
use crate::sim::context::StepContext;
use crate::solver::{CachedManifold, ConstraintGroup, ContactAnchors, HeldPair, PairEnds, SolveScratch, WarmStart};

/// Fastest push out of a penetration [m/s] (Box2D v3's and rapier's 3 m/s): faster, a cube
/// squeezed into a pile is shot out of it.
const MAX_PUSH: Scalar = 3.0;

/// A new point takes the impulse of last step's point within this distance on A [fraction of
/// A's radius]: the same corner one step later.
const MATCH_DISTANCE: Scalar = 0.05;

/// The impulses a pair's `len` points take from its cache entry `cached` (last step's points
/// and impulses), if any: a recycled point (`new` is `None`) is last step's own; a new one, at
/// `new`'s anchors, takes the impulse of the old point at the same place on A (within
/// `MATCH_DISTANCE` of A's radius `radius_a`), if any. Only a new point bounces (rapier's
/// rule): one held since last step is resting or rocking on it, and bouncing there keeps a
/// settling pile astir.
pub(crate) fn warm_start_of(
    cached: Option<&CachedManifold>,
    len: usize,
    new: Option<&ContactAnchors>,
    radius_a: Scalar,
) -> WarmStart {
    let mut warm = WarmStart::default();
    let Some(c) = cached else { return warm };
    for j in 0..len {
        let old = match new {
            None => Some(j),
            Some(a) => {
                (0..c.anchors.len).find(|&q| (c.anchors.on_a[q] - a.on_a[j]).length() <= MATCH_DISTANCE * radius_a)
            }
        };
        if let Some(q) = old {
            (warm.normal[j], warm.kept[j]) = (c.normal[q], true);
        }
    }
    (warm.tangent, warm.twist) = (c.tangent, c.twist);
    warm
}

/// One constraint per held pair and one point per manifold point (lever vectors, effective
/// masses, the impulses of last step's matching point), placed in batches of independent
/// constraints (`solver::place`), and the solver bodies they act on.
pub(crate) fn build_constraints(ctx: &mut StepContext) {
    let b = &ctx.bodies;
    let (params, dt) = (&ctx.params, ctx.dt);
    let s = ctx.scratch.get_mut::<SolveScratch>();
    // Lowest contacts first: each forward sweep then carries the support up a stack in one
    // pass. The order matters: top-down sweeps let a tall pyramid wobble. Ties keep pair order.
    // Sorted by integer keys (`PairEnds::key`), cheaper to compare than floats.
    s.order.clear();
    s.order.extend(s.ends.iter().enumerate().filter(|(_, e)| e.len > 0).map(|(k, e)| (e.key, k as u32)));
    // The sort and the solver bodies at once (the bodies do not depend on the order).
    let SolveScratch { order, by_pair, cached, cache, ranked, unranked, .. } = s;
    let last = Ranks { by_pair, cached, entries: cache.len() };
    let held = order.len();
    let SolveScratch { ends, jointed, slot, moving, fixed, keys, upright, left, scale, bodies, .. } = s;
    let parts = BodyParts { ends, held, jointed, slot, moving, fixed, keys, upright, left, scale, bodies };
    rayon::join(|| sort_from_last_order(order, &last, ranked, unranked), || gather_bodies(b, parts));
    // Each constraint's group: within the first side, within the second, or across; then its
    // batches, each group placed on its own. One thread solves the sides one after the other:
    // then both go in the first group, numbered across both sides as the constraints across
    // are. The sides share no free body, so each constraint meets its bodies in the same order
    // and does the same arithmetic (the same bits), and the batches, which one side's chains
    // of contacts leave partly empty, fill up with the other side's constraints.
    s.merged = s.left < s.moving.len() && rayon::current_num_threads() == 1;
    s.split = false;
    let (left, last) = (s.left as u32, s.bodies.len() as u32 - 1);
    s.groups[0].offset = 0;
    s.groups[0].static_slot = if s.merged { last } else { left };
    s.groups[1].offset = left + 1;
    s.groups[1].static_slot = last - (left + 1);
    s.groups[2].offset = 0;
    s.groups[2].static_slot = last;
    for group in &mut s.groups {
        group.slots.clear();
    }
    // Each group solves its quiet constraints (no impulse carried over: contacts at the side
    // of a stack, speculative ones) after the others, so that they fill batches of their own,
    // which a sweep leaves alone while they stay quiet (`Batch::quiet`). A body's constraints
    // keep their order among the loud and among the quiet.
    s.held.clear();
    s.quiet.clear();
    for &(_, k) in &s.order {
        let ends = s.ends[k as usize];
        let slot = [s.slot[ends.a as usize], s.slot[ends.b as usize]];
        let side = |i: u32| if i == left || i == last { None } else { Some(i > left) };
        let group = match (side(slot[0]), side(slot[1])) {
            (Some(true), Some(true) | None) | (None, Some(true)) => 1,
            (Some(false), Some(false) | None) | (None, Some(false)) | (None, None) => 0,
            _ => 2,
        };
        s.split |= group == 1;
        let group = if s.merged && group == 1 { 0 } else { group };
        let g = &mut s.groups[group];
        let local = |i: u32| if i == left || i == last { g.static_slot } else { i - g.offset };
        let slot = [local(slot[0]), local(slot[1])];
        let (len, quiet) = (ends.len as u8, ends.quiet);
        let at = if quiet {
            s.quiet.push((s.held.len() as u32, slot));
            0 // given below
        } else {
            g.slots.push(slot);
            g.slots.len() as u32 - 1
        };
        s.held.push(HeldPair { pair: k, group: group as u8, at, len, quiet });
    }
    for &(h, slot) in &s.quiet {
        let held = &mut s.held[h as usize];
        let g = &mut s.groups[usize::from(held.group)];
        held.at = g.slots.len() as u32;
        g.slots.push(slot);
    }
    // The two sides' groups placed and filled at once (they write disjoint batches), the third
    // by whichever thread is free first.
    let SolveScratch { groups, held, pairs, manifolds, slot, scale, warm, .. } = s;
    let shared = Shared { bodies: b, params, dt, meshes: &ctx.meshes, held, pairs, manifolds, slot, scale, warm };
    let [first, second, across] = groups;
    let build = |which: u8, group: &mut ConstraintGroup| {
        place_group(held, which, group);
        fill(&shared, which, group);
    };
    if second_side_first(first, second) {
        rayon::join(|| build(1, second), || rayon::join(|| build(0, first), || build(2, across)));
    } else {
        rayon::join(|| build(0, first), || rayon::join(|| build(1, second), || build(2, across)));
    }
}

/// True when the stepping thread takes the second side, building it here and solving it in
/// every pass of `drive`: it takes the side with more constraints (the other thread starts a
/// little later), and the one rule for both keeps each side's rows on the core that wrote them.
pub(super) fn second_side_first(first: &ConstraintGroup, second: &ConstraintGroup) -> bool {
    second.slots.len() > first.slots.len()
}

/// Last step's order of the held pairs (lowest first), as `sort_from_last_order` reads it.
struct Ranks<'a> {
    /// Each cache entry's place in last step's order (`SolveScratch::by_pair`).
    by_pair: &'a [u32],
    /// Each pair's cache entry (`SolveScratch::cached`).
    cached: &'a [u32],
    /// The number of cache entries.
    entries: usize,
}

/// Sorts `order` starting from last step's: the pairs held then in that order (`by_pair`,
/// each cache entry's place in it, left by `solve::remember`)
/// finished by an insertion sort (past a budget of moves, sorted afresh), the others sorted on
/// their own and merged in. A resting pile keeps most of its order, so this does less work than
/// sorting afresh; the keys are distinct (pair indices break ties), so the result is the same.
/// `ranked` and `keys` are scratch.
fn sort_from_last_order(
    order: &mut Vec<(u64, u32)>,
    last: &Ranks,
    ranked: &mut Vec<(u64, u32)>,
    keys: &mut Vec<(u64, u32)>,
) {
    let Ranks { by_pair, cached, entries } = *last;
    if by_pair.len() != entries || order.len() < 2 {
        order.sort_unstable();
        return;
    }
    // `ranked[r]`: the entry of `order` that was solved r-th last step; the rest in `keys`.
    ranked.clear();
    ranked.resize(by_pair.len(), (u64::MAX, u32::MAX));
    keys.clear();
    for &(key, k) in order.iter() {
        let rank = cached.get(k as usize).and_then(|&e| by_pair.get(e as usize)).map(|&r| r as usize);
        match rank.filter(|&r| r < ranked.len() && ranked[r].1 == u32::MAX) {
            Some(r) => ranked[r] = (key, k),
            None => keys.push((key, k)),
        }
    }
    ranked.retain(|e| e.1 != u32::MAX);
    let budget = 4 * ranked.len();
    let mut moves = 0;
    for i in 1..ranked.len() {
        let x = ranked[i];
        let mut j = i;
        while j > 0 && ranked[j - 1] > x {
            ranked[j] = ranked[j - 1];
            j -= 1;
        }
        ranked[j] = x;
        moves += i - j;
        if moves > budget {
            ranked.sort_unstable();
            break;
        }
    }
    // The new pairs sorted on their own, then merged in.
    keys.sort_unstable();
    order.clear();
    let (mut i, mut j) = (0, 0);
    while i < ranked.len() && j < keys.len() {
        if ranked[i] < keys[j] {
            order.push(ranked[i]);
            i += 1;
        } else {
            order.push(keys[j]);
            j += 1;
        }
    }
    order.extend_from_slice(&ranked[i..]);
    order.extend_from_slice(&keys[j..]);
}

/// The group of the constraints across the two sides (`SolveScratch::groups`).
const ACROSS: u8 = 2;

/// The bit of a constraint's kind (its point count, `place`) that marks it quiet.
const QUIET: u8 = 0x80;

/// Places group `which`'s constraints in batches (`solver::place`, manifolds of one point count
/// together, and quiet ones apart: `Batch::quiet`), each batch as long as its longest
/// manifold, and makes room for their points. `fill` writes every lane and point of them, idle
/// ones included, so nothing is cleared here.
pub(super) fn place_group(held: &[HeldPair], which: u8, group: &mut ConstraintGroup) {
    group.kinds.clear();
    group.kinds.resize(group.slots.len(), 0);
    for h in held.iter().filter(|h| h.group == which) {
        group.kinds[h.at as usize] = h.len | if h.quiet { QUIET } else { 0 };
    }
    if which == ACROSS {
        // One chain up the cut: packed, not one constraint a batch (`place_packed`).
        super::place_packed(&group.slots, group.static_slot, &mut group.fill, &mut group.placed);
    } else {
        let scratch = (&mut group.last, &mut group.kind_of);
        super::place((&group.slots, &group.kinds), group.static_slot, scratch, &mut group.fill, &mut group.placed);
    }
    let ConstraintGroup { batches, points, fill, placed, kinds, .. } = group;
    batches.resize(fill.len(), Batch::default());
    for batch in batches.iter_mut() {
        (batch.len, batch.quiet) = (0, true);
    }
    for (&kind, &(batch, _)) in kinds.iter().zip(placed.iter()) {
        let batch = &mut batches[batch as usize];
        batch.len = batch.len.max(u32::from(kind & !QUIET));
        // The constraints across are packed whatever their kinds.
        batch.quiet &= kind & QUIET != 0;
    }
    let mut first = 0;
    for batch in batches.iter_mut() {
        batch.first = first;
        first += batch.len;
    }
    points.resize(first as usize, PointRows::default());
}

/// Makes a placed group's lanes and points idle: every unused lane, and a lane's points beyond
/// its own manifold's (`held`, as for `place_group`). For tests that write the lanes one by one
/// (`Batch::set`, `PointRows::set`) instead of `fill`.
#[cfg(test)]
pub(super) fn make_idle(held: &[HeldPair], which: u8, group: &mut ConstraintGroup) {
    let ConstraintGroup { batches, points, fill, placed, static_slot, .. } = group;
    let idle = Constraint::idle(*static_slot);
    for (batch, &count) in batches.iter_mut().zip(fill.iter()) {
        for l in usize::from(count)..LANES {
            batch.set(l, &idle);
        }
        for row in &mut points[batch.rows()] {
            for l in usize::from(count)..LANES {
                row.set(l, &ContactPoint::IDLE);
            }
        }
    }
    for held in held.iter().filter(|h| h.group == which) {
        let (batch, lane) = placed[held.at as usize];
        let batch = &batches[batch as usize];
        for row in &mut points[(batch.first + u32::from(held.len)) as usize..(batch.first + batch.len) as usize] {
            row.set(usize::from(lane), &ContactPoint::IDLE);
        }
    }
}

/// What `fill` reads.
struct Shared<'a> {
    bodies: &'a Bodies,
    params: &'a crate::sim::context::Params,
    dt: Scalar,
    meshes: &'a crate::model::mesh::MeshTable,
    held: &'a [HeldPair],
    pairs: &'a [Pair],
    manifolds: &'a [Manifold],
    slot: &'a [u32],
    scale: &'a [Mat3],
    warm: &'a [WarmStart],
}

/// Writes the constraints and points of group `which`'s held pairs into its batches (their
/// slots in the group's numbering are `group.slots`, in the same order): each batch's lanes
/// gathered here, then worked out four at a time (`fill::fill_lanes`), which also writes the
/// idle lanes and points.
fn fill(sh: &Shared, which: u8, group: &mut ConstraintGroup) {
    let (b, params, dt) = (sh.bodies, sh.params, sh.dt);
    let ConstraintGroup { slots, placed, batches, points, fill: counts, static_slot, lanes, bouncing, .. } = group;
    // Each batch's lanes: (pair, index in the group).
    lanes.clear();
    lanes.resize(batches.len(), [(0, 0); LANES]);
    for held in sh.held.iter().filter(|h| h.group == which) {
        let (batch, lane) = placed[held.at as usize];
        lanes[batch as usize][usize::from(lane)] = (held.pair, held.at);
    }
    // Restitution reverses the approach before gravity's pull this step (Box2D v3 measures it
    // before integrating forces).
    let before = |i: usize| b.velocity[i] - if b.is_fixed(i) { Vector::ZERO } else { params.gravity * dt };
    let compliance = super::Softness::new(params.substep(dt)).compliance;
    let threshold = params.restitution_threshold(dt);
    bouncing.clear();
    let mut input = LaneInputs::default();
    for (at, ((batch, &count), lanes)) in batches.iter_mut().zip(counts.iter()).zip(lanes.iter()).enumerate() {
        let count = usize::from(count);
        let rows = &mut points[batch.rows()];
        // An idle lane repeats lane 0 (`LaneInputs`).
        for l in 0..LANES {
            let (k, c) = lanes[if l < count { l } else { 0 }];
            let (pair, m) = (&sh.pairs[k as usize], &sh.manifolds[k as usize]);
            let contact = pair.contact().expect("ordered pairs have contacts");
            let (ia, ib) = (pair.a as usize, pair.b as usize);
            let n = contact.normal;
            (input.slot[0][l], input.slot[1][l]) = (slots[c as usize][0], slots[c as usize][1]);
            input.normal.set(l, n);
            for (end, i) in [ia, ib].into_iter().enumerate() {
                input.position[end].set(l, b.position[i]);
                input.before[end].set(l, before(i));
                input.spin[end].set(l, b.angular_velocity[i]);
                let s = &sh.scale[sh.slot[i] as usize];
                input.scale[end][0].set(l, s.x_axis);
                input.scale[end][1].set(l, s.y_axis);
                input.scale[end][2].set(l, s.z_axis);
                input.inv_mass[end][l] = b.inv_mass[i];
            }
            let thin = b.thinner(sh.meshes, ia, ib);
            input.mu[l] = b.pair_friction(ia, ib);
            input.restitution[l] = 0.5 * (b.restitution[ia] + b.restitution[ib]);
            input.slop[l] = params.slop * thin;
            input.max_push[l] = (params.max_correction * thin / dt).min(MAX_PUSH);
            input.len[l] = m.len as Scalar;
            let warm = &sh.warm[k as usize];
            for j in 0..rows.len() {
                // Past the lane's own points: its first again, taking an impulse (so no bounce).
                let own = j < m.len;
                let at = if own { j } else { 0 };
                input.points[j].set(l, m.points[at]);
                input.gap[j][l] = m.gaps[at];
                let kept = !own || warm.kept[j];
                input.impulse[j][l] = if own { warm.normal[j] } else { 0.0 };
                input.kept[j][l] = if kept { 1.0 } else { 0.0 };
            }
            input.tangent_impulse.set(l, warm.tangent);
            input.twist_impulse.set(l, warm.twist);
        }
        super::fill::fill_lanes(&input, count, *static_slot, compliance, batch, rows);
        if super::may_bounce(batch, rows, threshold) {
            bouncing.push(at as u32);
        }
    }
}

/// What `gather_bodies` reads (every pair's ends, the number of held pairs, the jointed
/// actors) and writes of `SolveScratch`, its fields of the same names.
struct BodyParts<'a> {
    ends: &'a [PairEnds],
    held: usize,
    jointed: &'a [u32],
    slot: &'a mut Vec<u32>,
    moving: &'a mut Vec<u32>,
    fixed: &'a mut Vec<u32>,
    keys: &'a mut Vec<(u64, u32)>,
    upright: &'a mut Vec<(u64, u32)>,
    left: &'a mut usize,
    scale: &'a mut Vec<Mat3>,
    bodies: &'a mut Vec<SolverBody>,
}

/// Constraints below this many are solved as one group: splitting costs more than it saves.
const SPLIT_MIN: usize = 256;

/// Gives each free body of the held pairs a solver body and computes each one's
/// S = (I⁻¹)^½ in world axes, S = R diag(1/√I_p) Rᵀ with R the principal frame in world axes.
///
/// The free bodies are split in two sides at their median along the horizontal axis of
/// widest spread, or along the vertical for a tall pile where that cut crosses clearly fewer
/// held pairs (a scene with fewer than `SPLIT_MIN` constraints stays on one side); solver
/// bodies are the first side's, its static slot, the second side's, and the last static slot.
/// Every fixed body maps to a static slot. The split depends on the scene only, never on the
/// thread count, so runs are the same on one thread or two.
fn gather_bodies(b: &Bodies, parts: BodyParts) {
    let BodyParts { ends, held, jointed, slot, moving, fixed, keys, upright, left, scale, bodies } = parts;
    // Last step's bodies let go, so that every slot is unmarked.
    for &i in moving.iter().chain(fixed.iter()) {
        slot[i as usize] = u32::MAX;
    }
    slot.resize(b.len(), u32::MAX);
    moving.clear();
    fixed.clear();
    // Each end of the held pairs once, marked in `slot` (values no slot takes) on first sight.
    // Their numbering changes no result (constraints are placed and solved by which bodies
    // they share, never by their numbers), so it is the order they come in, pair order, and
    // the solving order is sorted meanwhile.
    const MARKED: u32 = u32::MAX - 1;
    // The joints' bodies after the contacts' (none in a scene without joints).
    let held_ends = ends.iter().filter(|e| e.len > 0).flat_map(|e| [e.a, e.b]);
    for i in held_ends.chain(jointed.iter().copied()) {
        let mark = &mut slot[i as usize];
        if *mark == u32::MAX {
            *mark = MARKED;
            if b.is_fixed(i as usize) { fixed.push(i) } else { moving.push(i) }
        }
    }
    *left = moving.len();
    if held >= SPLIT_MIN {
        *left = moving.len() / 2;
        let half = *left;
        // The bodies' extent along each world axis.
        let (lo, hi) = moving
            .iter()
            .map(|&i| b.position[i as usize])
            .fold((Vector::splat(Scalar::INFINITY), Vector::splat(Scalar::NEG_INFINITY)), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            });
        let spread = hi - lo;
        // Cut across the horizontal axis of widest spread; or, for a pile at least half as tall
        // as wide (a pyramid, a tower), across the vertical if that saves a fifth of the held
        // pairs that cross: fewer constraints across, solved after the sides, but sides unlike
        // in shape, whose batches one thread fills less well when it shares them.
        let level = if spread.x >= spread.z { Vector::X } else { Vector::Z };
        // The median partition along `axis` into `keys` (only which side each body is on
        // matters, a side's numbering changes no result, so no sort).
        let cut_along = |axis: Vector, keys: &mut Vec<(u64, u32)>| {
            keys.clear();
            keys.extend(moving.iter().map(|&i| (total_order_key(b.position[i as usize].dot(axis)), i)));
            keys.select_nth_unstable(half);
        };
        // How many held pairs of two free bodies a partition puts on different sides (marked
        // 0 and 1 in `slot`; fixed bodies stay marked otherwise).
        let crossing = |keys: &[(u64, u32)], slot: &mut [u32]| {
            for (k, &(_, i)) in keys.iter().enumerate() {
                slot[i as usize] = u32::from(k >= half);
            }
            let crosses = |e: &&PairEnds| {
                let (sa, sb) = (slot[e.a as usize], slot[e.b as usize]);
                sa <= 1 && sb <= 1 && sa != sb
            };
            ends.iter().filter(|e| e.len > 0).filter(crosses).count()
        };
        cut_along(level, keys);
        if 2.0 * spread.y >= spread.x.max(spread.z) {
            cut_along(Vector::Y, upright);
            if 5 * crossing(upright, slot) < 4 * crossing(keys, slot) {
                std::mem::swap(keys, upright);
            }
        }
        moving.clear();
        moving.extend(keys.iter().map(|k| k.1));
    }
    let (cut, last) = (*left as u32, moving.len() as u32 + 1);
    for (k, &i) in moving.iter().enumerate() {
        slot[i as usize] = if (k as u32) < cut { k as u32 } else { k as u32 + 1 };
    }
    for &i in fixed.iter() {
        slot[i as usize] = last;
    }
    // S and S⁻¹; for equal principal moments (cubes, spheres) multiples of the identity,
    // whatever the orientation.
    let scales = |i: usize| {
        let m = b.principal_moments[i];
        if crate::model::mass::equal_moments(m) {
            return (
                Mat3::from_diagonal(Vector::splat(1.0 / m.x.sqrt())),
                Mat3::from_diagonal(Vector::splat(m.x.sqrt())),
            );
        }
        let r = Mat3::from_quat(b.orientation[i] * b.principal_axes[i]);
        let s = |d: Vector| r * Mat3::from_diagonal(d) * r.transpose();
        (s(m.map(|m| 1.0 / m.sqrt())), s(m.map(Scalar::sqrt)))
    };
    // Each side's bodies, then its static slot; the sides at once (a square root or three a
    // body).
    let n = moving.len() + 2;
    bodies.resize(n, SolverBody::default());
    scale.resize(n, Mat3::ZERO);
    let side = |ids: &[u32], bodies: &mut [SolverBody], scale: &mut [Mat3]| {
        for ((&i, out), s) in ids.iter().zip(bodies.iter_mut()).zip(scale.iter_mut()) {
            let (i, (scale, unscale)) = (i as usize, scales(i as usize));
            *out = SolverBody { v: b.velocity[i], w: unscale * b.angular_velocity[i], ..SolverBody::default() };
            *s = scale;
        }
        (bodies[ids.len()], scale[ids.len()]) = (SolverBody::default(), Mat3::ZERO);
    };
    let (first, second) = moving.split_at(*left);
    let (bodies_first, bodies_second) = bodies.split_at_mut(*left + 1);
    let (scale_first, scale_second) = scale.split_at_mut(*left + 1);
    rayon::join(|| side(first, bodies_first, scale_first), || side(second, bodies_second, scale_second));
}

/// Two unit vectors completing `n` to a right-handed orthonormal basis.
pub(super) fn tangents(n: Vector) -> [Vector; 2] {
    let helper = if n.x.abs() < 0.57 { Vector::X } else { Vector::Y };
    let t1 = n.cross(helper).normalize();
    [t1, n.cross(t1)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_order_from_last_step_sorts_as_sort_unstable() {
        let mut rng = crate::rng::SplitMix64::new(5);
        let mut s = SolveScratch::default();
        for round in 0..200 {
            let n = (rng.next_u64() % 300) as usize;
            let keys: Vec<(u64, u32)> = (0..n as u32).map(|k| (rng.next_u64() % (1 + n as u64 / 8), k)).collect();
            // Last step's ranks and cache entries: a shuffle, stale or lying, or none.
            let last = if round % 5 == 0 { n + 3 } else { n };
            s.cache = vec![((0, 0), CachedManifold::default()); last];
            s.by_pair =
                (0..last as u32).map(|r| if round % 3 == 0 { (r * 7 + 1) % last.max(1) as u32 } else { r }).collect();
            s.cached = (0..n as u32)
                .map(|k| if rng.unit() < 0.1 { u32::MAX } else { (k * 13) % last.max(1) as u32 })
                .collect();
            s.order = keys.clone();
            let last = Ranks { by_pair: &s.by_pair, cached: &s.cached, entries: s.cache.len() };
            sort_from_last_order(&mut s.order, &last, &mut s.ranked, &mut s.unranked);
            let mut expect = keys;
            expect.sort_unstable();
            assert_eq!(s.order, expect, "round {round}");
        }
    }
}
