//! `ccd`: continuous collision (docs/physics.md §6.7). A body that moves more than a fraction
//! of the thinnest body's thickness in a step is swept, with its linear and angular motion,
//! against every body its bounding sphere can reach over the step; each pair fast enough to
//! pass through one another is advanced to its time of impact (`collision::toi`), given the
//! corrected impulse of §2.5 (with the pair's restitution, and Coulomb friction) there, and
//! flies on. Impacts are taken earliest first, so chains within a step come out in order.
//!
//! The bodies it moves are left at their last impact, with the time they have flown:
//! `integrate` moves them through the rest of the step. When no body is that fast (every
//! case of §4, the benchmark scenes) it looks at each body's speed once and does nothing else.
//!
//! It takes the pairs `resolve` answers. Under gravity (a positive restitution threshold)
//! every contact is `solve`'s, whose speculative contacts hold a pair before it meets (§6.3),
//! and bodies `solve` or a joint moves this step are left to it.

use crate::collision::manifold::ClipScratch;
use crate::collision::posed::Posed;
use crate::collision::toi::{Approach, impact_contact, time_of_impact};
use crate::math::{Mat3, Scalar, Vector, exp_map};
use crate::model::components::Pose;
use crate::model::mesh::{MeshId, MeshTable};
use crate::sim::bodies::{Bodies, rotate_tensor};
use crate::sim::context::StepContext;
use crate::solver::Joints;
use crate::systems::{collision_impulse, state};
use hecs::World;

/// A pair is swept when the two bodies travel more than this share of the thinner one's
/// thickness in a step. Below half, the discrete tests find the near face and the right normal
/// (docs/physics.md §5); this leaves a margin, and keeps box-gas's fastest pairs (about 0.37)
/// discrete, so slow pairs keep their results bit for bit.
pub const FAST_FRACTION: Scalar = 0.4;

/// Gap [share of the thinner thickness] at which a swept pair is stopped and takes its impulse:
/// apart, so the discrete tests of the next step see no overlap to answer a second time.
pub const IMPACT_GAP: Scalar = 0.005;

/// Most impacts per swept pair and step: a body squeezed between two walls bounces on.
const IMPACTS_PER_PAIR: usize = 8;

/// One pair being swept, `a < b`, and its next impact time, if any.
#[derive(Clone, Copy, Debug)]
struct Swept {
    a: u32,
    b: u32,
    next: Option<Scalar>,
}

/// The state of `ccd` within a step; `integrate` reads `taken`.
#[derive(Clone, Debug, Default)]
pub struct CcdScratch {
    step: u64,
    active: bool,
    /// Time [s] each body has flown this step under `ccd` (0 for bodies it left alone).
    taken: Vec<Scalar>,
    /// Bodies `ccd` leaves alone this step (moved by `solve` or a joint).
    excluded: Vec<bool>,
    /// Bodies whose reach has been searched for pairs.
    searched: Vec<bool>,
    pairs: Vec<Swept>,
    clip: ClipScratch,
}

impl CcdScratch {
    /// The time each body has already flown in step `step` [s], when `ccd` moved any.
    #[must_use]
    pub fn taken(&self, step: u64) -> Option<&[Scalar]> {
        (self.active && self.step == step).then_some(&self.taken[..])
    }
}

/// Sweeps the fast bodies to their impacts (see the module docs).
///
/// - Reads: `ctx.bodies`, `ctx.pairs` (to leave `solve`'s bodies alone), the joints.
/// - Writes: `ctx.bodies` poses and velocities of the bodies it moves, `ctx.stats.impulses`,
///   its `CcdScratch` (how long each moved body has flown).
/// - Paper: none (its §5 limit; "beyond the paper", docs/physics.md §6.7).
/// - Cost: O(N) a step; with k fast bodies O(N·k) more, and O(advances) per impact.
pub fn ccd(_world: &mut World, ctx: &mut StepContext) {
    let s = ctx.scratch.get_mut::<CcdScratch>();
    (s.step, s.active) = (ctx.step, false);
    if !ctx.params.ccd || ctx.params.resting_contacts(ctx.dt, 0.0) {
        return;
    }
    let speed = 0.5 * FAST_FRACTION * thinnest(&ctx.meshes) / ctx.dt;
    if !(0..ctx.bodies.len()).any(|i| faster(&ctx.bodies, i, speed)) {
        return;
    }
    let mut s = std::mem::take(ctx.scratch.get_mut::<CcdScratch>());
    prepare(ctx, &mut s);
    for i in 0..ctx.bodies.len() {
        if faster(&ctx.bodies, i, speed) && !s.excluded[i] {
            search(ctx, &mut s, i);
        }
    }
    impacts(ctx, &mut s, speed);
    *ctx.scratch.get_mut::<CcdScratch>() = s;
}

/// The thinnest mesh's thickness [m]: the bound of the cheap test, over every mesh of the
/// table (a handful), not every body.
fn thinnest(meshes: &MeshTable) -> Scalar {
    (0..meshes.len() as u32).map(|k| meshes.get(MeshId(k)).thickness).fold(Scalar::INFINITY, Scalar::min)
}

/// True when free body `i` moves faster than `speed` [m/s], counting spin at its radius. Two
/// squares first: most bodies of a scene pass on them alone.
fn faster(b: &Bodies, i: usize, speed: Scalar) -> bool {
    let (v2, w2) = (b.velocity[i].length_squared(), b.angular_velocity[i].length_squared() * b.radius[i] * b.radius[i]);
    let half = 0.25 * speed * speed;
    (v2 > half || w2 > half) && b.inv_mass[i] != 0.0 && v2.sqrt() + w2.sqrt() > speed
}

/// Clears the step's state and marks the bodies `solve` may move (open pairs with friction,
/// which it holds) and the jointed ones: their poses are `solve`'s.
fn prepare(ctx: &StepContext, s: &mut CcdScratch) {
    let n = ctx.bodies.len();
    for v in [&mut s.excluded, &mut s.searched] {
        v.clear();
        v.resize(n, false);
    }
    s.taken.clear();
    s.taken.resize(n, 0.0);
    s.pairs.clear();
    let b = &ctx.bodies;
    let open = |p: &&crate::collision::contact::Pair| p.contact().is_some() || p.is_candidate() || p.is_near();
    for p in ctx.pairs.iter().filter(open) {
        if ctx.params.resting_contacts(ctx.dt, b.pair_friction(p.a as usize, p.b as usize)) {
            (s.excluded[p.a as usize], s.excluded[p.b as usize]) = (true, true);
        }
    }
    if let Some(joints) = ctx.scratch.get::<Joints>() {
        for i in joints.joints.iter().flat_map(|j| std::iter::once(j.a).chain(j.b)) {
            s.excluded[i as usize] = true;
        }
    }
}

/// Adds the pairs of body `i` (flying from its time so far) with every body its swept sphere
/// can reach within the step, when the two together travel fast enough to pass through.
fn search(ctx: &StepContext, s: &mut CcdScratch, i: usize) {
    s.searched[i] = true;
    let (b, dt) = (&ctx.bodies, ctx.dt);
    let sphere = |k: usize| {
        let rest = b.velocity[k] * (dt - s.taken[k]);
        (b.position[k] + 0.5 * rest, b.radius[k] + 0.5 * rest.length())
    };
    let travel = |k: usize| (b.velocity[k].length() + b.angular_velocity[k].length() * b.radius[k]) * dt;
    let (ci, ri) = sphere(i);
    for j in (0..b.len()).filter(|&j| j != i && !s.excluded[j]) {
        // A box about j's swept sphere first (no square root): most bodies are far.
        let rest = b.velocity[j] * (dt - s.taken[j]);
        let d = ci - (b.position[j] + 0.5 * rest);
        if d.abs().max_element() > ri + b.radius[j] + 0.5 * rest.abs().element_sum() {
            continue;
        }
        let (cj, rj) = sphere(j);
        if (ci - cj).length() > ri + rj || travel(i) + travel(j) <= FAST_FRACTION * b.thinner(&ctx.meshes, i, j) {
            continue;
        }
        let key = (i.min(j) as u32, i.max(j) as u32);
        if !s.pairs.iter().any(|p| (p.a, p.b) == key) {
            s.pairs.push(Swept { a: key.0, b: key.1, next: None });
            let k = s.pairs.len() - 1;
            s.pairs[k].next = next_impact(ctx, s, k);
        }
    }
}

/// The impacts of the step, earliest first (ties in pair order), each followed by a fresh
/// look at the pairs of its two bodies, and a search from a body the impact made fast.
fn impacts(ctx: &mut StepContext, s: &mut CcdScratch, speed: Scalar) {
    let mut count = 0;
    while count < IMPACTS_PER_PAIR * s.pairs.len() {
        let earliest = s.pairs.iter().filter_map(|p| p.next.map(|t| (t, p.a, p.b)));
        let Some((t, a, b)) = earliest.min_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2)))) else {
            break;
        };
        count += 1;
        for i in [a, b] {
            fly(&mut ctx.bodies, &mut s.taken, i as usize, t);
        }
        collide(ctx, s, a as usize, b as usize);
        for i in [a as usize, b as usize] {
            if !s.searched[i] && faster(&ctx.bodies, i, speed) {
                search(ctx, s, i);
            }
        }
        for k in 0..s.pairs.len() {
            if [s.pairs[k].a, s.pairs[k].b].iter().any(|&i| i == a || i == b) {
                s.pairs[k].next = next_impact(ctx, s, k);
            }
        }
    }
    s.active = s.taken.iter().any(|&t| t > 0.0);
}

/// Body `i`'s pose and spin after flying freely for `h` [s] from where it stands: its centre
/// straight on, its orientation turning at its present spin, the world angular momentum kept
/// (ω recomputed from it at the new orientation, as in docs/physics.md §2.7). No point then
/// moves faster than `|v| + |ω| ρ`, the bound the time of impact rests on.
fn flown(b: &Bodies, i: usize, h: Scalar) -> (Pose, Vector) {
    let (x, q, w) = (b.position[i], b.orientation[i], b.angular_velocity[i]);
    if b.inv_mass[i] == 0.0 {
        return (Pose { position: x, orientation: q }, w);
    }
    let turned = (exp_map(w * h) * q).normalize();
    let moments = b.principal_moments[i];
    let w = if moments.x == moments.y && moments.y == moments.z {
        w
    } else {
        let (before, after) = (q * b.principal_axes[i], turned * b.principal_axes[i]);
        let l = before * (moments * (before.inverse() * w));
        after * ((after.inverse() * l) / moments)
    };
    (Pose { position: x + b.velocity[i] * h, orientation: turned }, w)
}

/// Moves free body `i` on to time `t` of the step.
fn fly(b: &mut Bodies, taken: &mut [Scalar], i: usize, t: Scalar) {
    if b.inv_mass[i] == 0.0 || t <= taken[i] {
        return;
    }
    let (pose, w) = flown(b, i, t - taken[i]);
    (b.position[i], b.orientation[i], b.angular_velocity[i]) = (pose.position, pose.orientation, w);
    b.rotation[i] = Mat3::from_quat(pose.orientation);
    b.inv_inertia_world[i] = rotate_tensor(pose.orientation, b.inv_inertia_body[i]);
    taken[i] = t;
}

/// When swept pair `k` next comes within the impact gap, from the later of its bodies'
/// times on, if within the step.
fn next_impact(ctx: &StepContext, s: &CcdScratch, k: usize) -> Option<Scalar> {
    let (b, dt) = (&ctx.bodies, ctx.dt);
    let (ia, ib) = (s.pairs[k].a as usize, s.pairs[k].b as usize);
    let start = s.taken[ia].max(s.taken[ib]);
    let place = |t: Scalar| (flown(b, ia, t - s.taken[ia]).0, flown(b, ib, t - s.taken[ib]).0);
    let (pa, pb) = place(start);
    let (mut a, mut b_) =
        (Posed::new(ctx.meshes.get_arc(b.mesh[ia]), &pa), Posed::new(ctx.meshes.get_arc(b.mesh[ib]), &pb));
    let spin = |i: usize| if b.inv_mass[i] == 0.0 { 0.0 } else { b.angular_velocity[i].length() * b.radius[i] };
    let approach = Approach { relative_velocity: b.velocity[ia] - b.velocity[ib], spin: spin(ia) + spin(ib) };
    let gap = IMPACT_GAP * b.thinner(&ctx.meshes, ia, ib);
    time_of_impact((&mut a, &mut b_), place, &approach, (start, dt), gap)
}

/// The impact of bodies `ia < ib`, both flown to its time: the corrected impulse (§2.5) with
/// the pair's restitution, then Coulomb friction up to μ times it.
fn collide(ctx: &mut StepContext, s: &mut CcdScratch, ia: usize, ib: usize) {
    let b = &ctx.bodies;
    let posed = |i: usize| {
        Posed::new(ctx.meshes.get_arc(b.mesh[i]), &Pose { position: b.position[i], orientation: b.orientation[i] })
    };
    let Some(contact) = impact_contact(&posed(ia), &posed(ib), &mut s.clip) else { return };
    let (mut sa, mut sb) = (state(b, ia), state(b, ib));
    let e = 0.5 * (b.restitution[ia] + b.restitution[ib]);
    let Some(j) = collision_impulse(&sa, &sb, &contact, e) else { return };
    sa.apply_impulse(contact.point, j * contact.normal);
    sb.apply_impulse(contact.point, -j * contact.normal);
    let friction = friction_impulse(&sa, &sb, contact.point, contact.normal, b.pair_friction(ia, ib) * j);
    sa.apply_impulse(contact.point, friction);
    sb.apply_impulse(contact.point, -friction);
    let b = &mut ctx.bodies;
    for (i, st) in [(ia, sa), (ib, sb)] {
        (b.velocity[i], b.angular_velocity[i]) = (st.velocity, st.angular_velocity);
    }
    ctx.stats.count_impulse(contact.feature);
}

/// The friction impulse on A [N·s] at `p`: against the sliding velocity, enough to stop it
/// along its direction, at most `limit` (μ times the normal impulse).
#[must_use]
pub fn friction_impulse(
    a: &crate::systems::BodyState,
    b: &crate::systems::BodyState,
    p: Vector,
    n: Vector,
    limit: Scalar,
) -> Vector {
    let u = a.point_velocity(p) - b.point_velocity(p);
    let slide = u - u.dot(n) * n;
    let Some(t) = slide.try_normalize().filter(|_| limit > 0.0) else { return Vector::ZERO };
    let (ka, kb) = ((p - a.position).cross(t), (p - b.position).cross(t));
    let k = a.inv_mass + b.inv_mass + ka.dot(a.inv_inertia * ka) + kb.dot(b.inv_inertia * kb);
    -t * (slide.length() / k).min(limit)
}
