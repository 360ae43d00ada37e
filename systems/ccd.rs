//! `ccd`: continuous collision (docs/physics.md §6.7). A body that moves more than a fraction
//! of the thinnest body's thickness in a step is swept, with its linear and angular motion,
//! along the path the earlier stages give it, against every body it can reach over the step;
//! each pair fast enough to pass through one another is advanced to its time of impact
//! (`collision::toi`), given the corrected impulse of §2.5 (with the pair's restitution, and
//! Coulomb friction) there, and flies on. Impacts are taken earliest first, so chains within a
//! step come out in order. A body that used up its impacts (squeezed) ends the squeeze with
//! the impulses of all its contacts solved at once, with restitution (`squeeze`).
//!
//! The bodies it moves are left at their last impact, with the time they have flown:
//! `integrate` moves them through the rest of the step. When no body is that fast (every
//! case of §4, box-gas) it looks at each body's speed once and does nothing else.

use crate::collision::manifold::ClipScratch;
use crate::collision::posed::Posed;
use crate::collision::toi::{Approach, impact_contact, meshes_time_of_impact};
use crate::math::{Mat3, Scalar, Vector, exp_map};
use crate::model::components::{ActorIndex, Pose};
use crate::model::mass::equal_moments;
use crate::model::mesh::{MeshId, MeshTable};
use crate::sim::bodies::{Bodies, rotate_tensor};
use crate::sim::context::StepContext;
use crate::solver::Joints;
use crate::systems::{collision_impulse, rotate_free, state};
use hecs::World;

mod squeeze;

/// A pair is swept when the two bodies travel more than this share of the thinner one's
/// thickness in a step relative to each other. Below half, the discrete tests find the near
/// face and the right normal (docs/physics.md §5); this leaves a margin, and keeps box-gas's
/// fastest pairs (about 0.37) discrete, so slow pairs keep their results bit for bit.
pub const FAST_FRACTION: Scalar = 0.4;

/// Gap [share of the thinner thickness] at which a swept pair is stopped and takes its impulse:
/// apart, so the discrete tests of the next step see no overlap to answer a second time.
pub const IMPACT_GAP: Scalar = 0.005;

/// Most impacts per body and step: a body squeezed between two walls bounces on, and a crowd
/// struck by a bullet passes the blow on; the last ends the squeeze (`squeeze`).
const IMPACTS_PER_BODY: u32 = 8;

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
    /// Each body's pose at the start of the step.
    start: Vec<Pose>,
    /// Body i had an impact: it flies freely from its pose at `taken[i]`.
    flown: Vec<bool>,
    /// Impacts of each body this step.
    impacts: Vec<u32>,
    /// Bodies faster than the cheap bound.
    mover: Vec<bool>,
    /// Bodies a joint holds: `solve` answers their contacts with their joints.
    jointed: Vec<bool>,
    /// The swept sphere each body's partners were searched within, if they were (`search`).
    searched: Vec<Option<Sphere>>,
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
/// - Reads: `ctx.bodies`, `ctx.pairs`, the joints, and the world's poses: where each body
///   stood when the step began (`solve` may have moved it since).
/// - Writes: `ctx.bodies` poses and velocities of the bodies it moves, `ctx.stats.impulses`,
///   its `CcdScratch` (how long each moved body has flown).
/// - Paper: none (its §5 limit; "beyond the paper", docs/physics.md §6.7).
/// - Cost: O(N) a step; with k fast bodies O(P + N·k) more, and O(advances) per impact.
pub fn ccd(world: &mut World, ctx: &mut StepContext) {
    let s = ctx.scratch.get_mut::<CcdScratch>();
    (s.step, s.active) = (ctx.step, false);
    if !ctx.params.ccd {
        return;
    }
    let speed = 0.5 * FAST_FRACTION * thinnest(&ctx.meshes) / ctx.dt;
    if !any_faster(&ctx.bodies, speed) {
        return;
    }
    let mut s = std::mem::take(ctx.scratch.get_mut::<CcdScratch>());
    prepare(world, ctx, &mut s, speed);
    candidates(ctx, &mut s);
    impacts(ctx, &mut s, speed);
    *ctx.scratch.get_mut::<CcdScratch>() = s;
}

/// The thinnest mesh's thickness [m]: the bound of the cheap test, over every mesh of the
/// table (a handful), not every body.
fn thinnest(meshes: &MeshTable) -> Scalar {
    (0..meshes.len() as u32).map(|k| meshes.get(MeshId(k)).thickness).fold(Scalar::INFINITY, Scalar::min)
}

/// True when any free body moves faster than `speed` [m/s]: the whole cost of a step without
/// fast bodies, so one pass over three arrays, two squares a body, no square root.
fn any_faster(b: &Bodies, speed: Scalar) -> bool {
    let half = 0.25 * speed * speed;
    let rows = b.velocity.iter().zip(&b.angular_velocity).zip(&b.radius).enumerate();
    rows.into_iter()
        .any(|(i, ((v, w), r))| (v.length_squared() > half || w.length_squared() * r * r > half) && faster(b, i, speed))
}

/// True when free body `i` moves faster than `speed` [m/s], counting spin at its radius. Two
/// squares first: most bodies of a scene pass on them alone.
fn faster(b: &Bodies, i: usize, speed: Scalar) -> bool {
    let (v2, w2) = (b.velocity[i].length_squared(), b.angular_velocity[i].length_squared() * b.radius[i] * b.radius[i]);
    let half = 0.25 * speed * speed;
    (v2 > half || w2 > half) && b.inv_mass[i] != 0.0 && v2.sqrt() + w2.sqrt() > speed
}

/// Clears the step's state, marks the movers and reads where each body began the step: the
/// world still holds the poses the step loaded.
fn prepare(world: &World, ctx: &StepContext, s: &mut CcdScratch, speed: Scalar) {
    let (b, n) = (&ctx.bodies, ctx.bodies.len());
    s.mover.clear();
    s.mover.extend((0..n).map(|i| faster(b, i, speed)));
    for v in [&mut s.flown, &mut s.jointed] {
        v.clear();
        v.resize(n, false);
    }
    s.searched.clear();
    s.searched.resize(n, None);
    s.taken.clear();
    s.taken.resize(n, 0.0);
    s.impacts.clear();
    s.impacts.resize(n, 0);
    s.start.clear();
    s.start.resize(n, Pose::IDENTITY);
    for (index, pose) in world.query::<(&ActorIndex, &Pose)>().iter() {
        s.start[index.0 as usize] = *pose;
    }
    s.pairs.clear();
    if let Some(joints) = ctx.scratch.get::<Joints>() {
        for i in joints.joints.iter().flat_map(|j| std::iter::once(j.a).chain(j.b)) {
            s.jointed[i as usize] = true;
        }
    }
}

/// The swept pairs: a mover with a speculative distance (under gravity or friction) finds
/// every body it may reach among the step's pairs, which the broad phase widened by that
/// distance; any other mover searches all bodies. Nothing has flown yet, so each body's sphere
/// and travel are worked out once here, not once per pair.
fn candidates(ctx: &StepContext, s: &mut CcdScratch) {
    let (b, params, dt) = (&ctx.bodies, &ctx.params, ctx.dt);
    let spheres: Vec<Sphere> = (0..b.len()).map(|k| sphere_of(ctx, s, k)).collect();
    let travels: Vec<(Scalar, Scalar)> = (0..b.len()).map(|k| travel_of(ctx, k)).collect();
    let widened: Vec<bool> = (0..b.len()).map(|i| s.mover[i] && params.speculative_distance(dt, b, i) > 0.0).collect();
    for i in 0..b.len() {
        if s.mover[i] && !widened[i] {
            s.searched[i] = Some(spheres[i]);
            for j in (0..b.len()).filter(|&j| j != i) {
                consider(ctx, s, (i, j), (&spheres[i], &spheres[j]), |k| travels[k]);
            }
        }
    }
    for p in ctx.pairs.iter().filter(|p| widened[p.a as usize] || widened[p.b as usize]) {
        let (i, j) = (p.a as usize, p.b as usize);
        consider(ctx, s, (i, j), (&spheres[i], &spheres[j]), |k| travels[k]);
    }
    s.pairs.sort_unstable_by_key(|p| (p.a, p.b));
    s.pairs.dedup_by_key(|p| (p.a, p.b));
    for k in 0..s.pairs.len() {
        s.pairs[k].next = next_impact(ctx, s, k);
    }
}

/// Adds the pairs of body `i` with every body whose swept sphere meets its own.
fn search(ctx: &StepContext, s: &mut CcdScratch, i: usize) {
    let si = sphere_of(ctx, s, i);
    s.searched[i] = Some(si);
    for j in (0..ctx.bodies.len()).filter(|&j| j != i) {
        let sj = sphere_of(ctx, s, j);
        consider(ctx, s, (i, j), (&si, &sj), |k| travel_of(ctx, k));
    }
}

/// The sphere a body sweeps over the rest of the step along its centre's path: centre and
/// radius [m].
#[derive(Clone, Copy, Debug)]
struct Sphere(Vector, Scalar);

impl Sphere {
    fn within(&self, outer: &Sphere) -> bool {
        (self.0 - outer.0).length() + self.1 <= outer.1
    }
}

/// Body k's `Sphere` as it stands.
fn sphere_of(ctx: &StepContext, s: &CcdScratch, k: usize) -> Sphere {
    let (b, dt) = (&ctx.bodies, ctx.dt);
    let from = if s.flown[k] { b.position[k] } else { s.start[k].position };
    let to = b.position[k] + b.velocity[k] * (dt - s.taken[k]);
    Sphere(0.5 * (from + to), b.radius[k] + 0.5 * (to - from).abs().element_sum())
}

/// How far body k's points may travel in the step by its spin [m], and its thickness [m].
fn travel_of(ctx: &StepContext, k: usize) -> (Scalar, Scalar) {
    let (b, dt) = (&ctx.bodies, ctx.dt);
    (b.angular_velocity[k].length() * b.radius[k] * dt, ctx.meshes.get(b.mesh[k]).thickness)
}

/// Adds pair (i, j) when the two may meet within the step (their swept spheres meet) and
/// travel fast enough to pass through each other (`travel` of each: `travel_of`); not a
/// jointed body's (its joints and contacts are solved together, by `solve`).
fn consider(
    ctx: &StepContext,
    s: &mut CcdScratch,
    (i, j): (usize, usize),
    (si, sj): (&Sphere, &Sphere),
    travel: impl Fn(usize) -> (Scalar, Scalar),
) {
    let b = &ctx.bodies;
    if s.jointed[i] || s.jointed[j] {
        return;
    }
    let (gap, reach) = (si.0 - sj.0, si.1 + sj.1);
    // Box about the spheres (no square root): most bodies are far.
    if gap.abs().max_element() > reach || gap.length() > reach {
        return;
    }
    let key = (i.min(j) as u32, i.max(j) as u32);
    // Passing through is a matter of the pair's relative motion: two bodies falling side by
    // side are each fast, but not to each other.
    let ((ti, hi), (tj, hj)) = (travel(i), travel(j));
    let relative = (b.velocity[i] - b.velocity[j]).length() * ctx.dt + ti + tj;
    if b.is_fixed(i) && b.is_fixed(j) || relative <= FAST_FRACTION * hi.min(hj) {
        return;
    }
    s.pairs.push(Swept { a: key.0, b: key.1, next: None });
}

/// The impacts of the step, earliest first (ties in pair order), each followed by a fresh
/// look at the pairs of its two bodies, and a search from a body the impact made fast.
fn impacts(ctx: &mut StepContext, s: &mut CcdScratch, speed: Scalar) {
    loop {
        let earliest = s.pairs.iter().filter_map(|p| p.next.map(|t| (t, p.a, p.b)));
        let Some((t, a, b)) = earliest.min_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2)))) else {
            break;
        };
        for i in [a as usize, b as usize] {
            fly(ctx, s, i, t);
            s.impacts[i] += 1;
        }
        collide(ctx, s, a as usize, b as usize);
        let mut partners = Vec::new();
        for i in [a as usize, b as usize] {
            if s.impacts[i] == IMPACTS_PER_BODY && !ctx.bodies.is_fixed(i) {
                partners.extend(squeeze::squeeze(ctx, s, i, t));
            }
        }
        for i in [a as usize, b as usize].into_iter().chain(partners.iter().copied()) {
            // A body searched before may be turned out of that search's sphere (a bounce off
            // a wall early in the step): searched again from where it flies now.
            let unsearched = match &s.searched[i] {
                Some(sphere) => !ctx.bodies.is_fixed(i) && !sphere_of(ctx, s, i).within(sphere),
                None => faster(&ctx.bodies, i, speed),
            };
            if unsearched {
                let known = s.pairs.len();
                search(ctx, s, i);
                let added: Vec<Swept> = s.pairs.drain(known..).collect();
                for p in added {
                    if !s.pairs.iter().any(|q| (q.a, q.b) == (p.a, p.b)) {
                        s.pairs.push(p);
                    }
                }
            }
        }
        for k in 0..s.pairs.len() {
            if [s.pairs[k].a, s.pairs[k].b].iter().any(|&i| i == a || i == b || partners.contains(&(i as usize))) {
                s.pairs[k].next = next_impact(ctx, s, k);
            }
        }
    }
    s.active = s.taken.iter().any(|&t| t > 0.0);
}

/// How a body moves through the step: from `pose` at time `t0`, its centre at `v`, turning at
/// `w` (`exp(w·t)`), so no point moves faster than `|v| + |w| ρ`, the bound the time of impact
/// rests on. After an impact an unequal-moment body turns freely instead (`free`: its
/// principal axes and moments), as `integrate` turns it: its angular momentum and energy kept,
/// its ω precessing, never faster than |L| / I_min.
#[derive(Clone, Copy, Debug)]
struct Path {
    t0: Scalar,
    pose: Pose,
    v: Vector,
    w: Vector,
    free: Option<(crate::math::Quat, Vector)>,
}

impl Path {
    fn at(&self, t: Scalar) -> Pose {
        let h = t - self.t0;
        let orientation = match self.free {
            Some((axes, moments)) => rotate_free(self.pose.orientation, self.w, axes, moments, h).0,
            None => (exp_map(self.w * h) * self.pose.orientation).normalize(),
        };
        Pose { position: self.pose.position + self.v * h, orientation }
    }

    /// The fastest the body turns along the path [rad/s].
    fn spin(&self) -> Scalar {
        match self.free {
            Some((axes, moments)) => {
                let q = self.pose.orientation * axes;
                (moments * (q.inverse() * self.w)).length() / moments.min_element()
            }
            None => self.w.length(),
        }
    }
}

/// Body `i`'s path: a fixed body stays; one that had an impact flies on from it at its
/// velocities, turning freely; any other goes from where it began the step to where
/// `integrate` will put it, straight and at one rate of turn, which is the path `solve`'s and
/// `correct`'s moves imply.
fn path(b: &Bodies, s: &CcdScratch, dt: Scalar, i: usize) -> Path {
    let here = Pose { position: b.position[i], orientation: b.orientation[i] };
    if b.inv_mass[i] == 0.0 {
        return Path { t0: 0.0, pose: here, v: Vector::ZERO, w: Vector::ZERO, free: None };
    }
    if s.flown[i] {
        let m = b.principal_moments[i];
        let free = (!equal_moments(m)).then_some((b.principal_axes[i], m));
        return Path { t0: s.taken[i], pose: here, v: b.velocity[i], w: b.angular_velocity[i], free };
    }
    let start = s.start[i];
    let (end, _) =
        rotate_free(here.orientation, b.angular_velocity[i], b.principal_axes[i], b.principal_moments[i], dt);
    let turn = end * start.orientation.inverse();
    let turn = if turn.w < 0.0 { -turn } else { turn };
    let v = (here.position + b.velocity[i] * dt - start.position) / dt;
    Path { t0: 0.0, pose: start, v, w: turn.to_scaled_axis() / dt, free: None }
}

/// Moves free body `i` along its path to time `t` of the step. On a free flight its world
/// angular momentum is kept: ω is recomputed from it at the new orientation (§2.7).
fn fly(ctx: &mut StepContext, s: &mut CcdScratch, i: usize, t: Scalar) {
    let b = &mut ctx.bodies;
    if b.inv_mass[i] == 0.0 || (s.flown[i] && t <= s.taken[i]) {
        return;
    }
    let way = path(b, s, ctx.dt, i);
    let pose = way.at(t);
    if let Some((axes, moments)) = way.free {
        // The free turn's ω at its end: L and the energy kept (docs/physics.md §2.7).
        b.angular_velocity[i] = rotate_free(way.pose.orientation, way.w, axes, moments, t - way.t0).1;
    } else if !equal_moments(b.principal_moments[i]) {
        // Along the step's path an unequal-moment body turns with its spin: ω kept in its own
        // frame, so its energy too. Kept in the world frame while the inertia turns, it would
        // make energy (docs/physics.md §2.7).
        b.angular_velocity[i] = (pose.orientation * b.orientation[i].inverse()) * b.angular_velocity[i];
    }
    (b.position[i], b.orientation[i]) = (pose.position, pose.orientation);
    b.rotation[i] = Mat3::from_quat(pose.orientation);
    b.inv_inertia_world[i] = rotate_tensor(pose.orientation, b.inv_inertia_body[i]);
    (s.taken[i], s.flown[i]) = (t, true);
}

/// When swept pair `k` next comes within the impact gap, from the later of its bodies'
/// times on, if within the step.
fn next_impact(ctx: &StepContext, s: &CcdScratch, k: usize) -> Option<Scalar> {
    let (b, dt) = (&ctx.bodies, ctx.dt);
    let (ia, ib) = (s.pairs[k].a as usize, s.pairs[k].b as usize);
    if [ia, ib].iter().any(|&i| s.impacts[i] >= IMPACTS_PER_BODY && !b.is_fixed(i)) {
        return None;
    }
    let (pa, pb) = (path(b, s, dt, ia), path(b, s, dt, ib));
    let start = pa.t0.max(pb.t0);
    let spin = pa.spin() * b.radius[ia] + pb.spin() * b.radius[ib];
    // Bounding spheres that cannot meet within the step: no search needed.
    let apart = (pa.at(start).position - pb.at(start).position).length() - b.radius[ia] - b.radius[ib];
    if apart > ((pa.v - pb.v).length() + spin) * (dt - start) {
        return None;
    }
    let approach = Approach { relative_velocity: pa.v - pb.v, spin };
    let gap = IMPACT_GAP * b.thinner(&ctx.meshes, ia, ib);
    let meshes = (ctx.meshes.get_arc(b.mesh[ia]), ctx.meshes.get_arc(b.mesh[ib]));
    meshes_time_of_impact((&meshes.0, &meshes.1), |t| (pa.at(t), pb.at(t)), &approach, (start, dt), gap)
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
