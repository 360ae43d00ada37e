//! `solve`: resting contact and friction, the paper's "future work". Sequential impulses over
//! contact manifolds (up to four points a pair), with accumulated normal impulses clamped at
//! zero and Coulomb friction clamped to the cone |j_t| ≤ μ j_n, warm-started from the previous
//! step's impulses (Catto, "Iterative Dynamics with Temporal Coherence", 2005), solved as a
//! "soft step" (Catto, "Solver2D", 2024; Box2D v3; rapier's TGS): the step is cut into
//! substeps, penetration is pushed out by a stiff damped spring and a rigid relax pass takes
//! the push-out velocity back, so penetration is removed without adding energy.
//!
//! Each pair is held along its least-overlap axis (`manifold::contact_axis`), not the detection
//! tests' normal, with speculative points for gaps that may close within the step
//! (`Params::speculative_distance`). Rows are solved lowest first, so one sweep carries a
//! stack's support from the ground up.
//!
//! It takes the contacts `resolve` leaves: under gravity every contact (impacts were bounced
//! there, resting ones are held here with no bounce), and contacts with friction. Without
//! gravity and friction it does nothing, so the paper's frictionless results are unchanged.
//! `correct` leaves the pairs held here alone.

use crate::bodies::Bodies;
use crate::contact::{Contact, Feature, Pair, PairState};
use crate::manifold::{ClipScratch, Manifold, contact_axis, manifold, support_point};
use crate::math::{Scalar, Vector, exp_map};
use crate::step::{CachedManifold, CachedPoint, RowAxis, SolverRow, StepContext};
use hecs::World;
use rayon::prelude::*;

/// A cached point matches a new one within this distance in A's body frame [fraction of A's
/// radius]: the same corner one step later.
const MATCH_DISTANCE: Scalar = 0.05;

/// Holds resting contacts and applies friction (see the module docs).
///
/// - Reads: `ctx.pairs` (`Found`, `Resolved`), `ctx.posed`, `ctx.bodies`, `ctx.scratch.solve`.
/// - Writes: `ctx.bodies` velocities and the poses of the bodies it holds (and the world's),
///   `ctx.stats.impulses` (one per pair held), the warm-start cache.
/// - Paper: none (resting contact and friction are the paper's future work).
/// - Cost: O(P) to build P points, O(P · substeps · (iterations + 2)) to solve.
pub fn solve(world: &mut World, ctx: &mut StepContext) {
    let (b, params, dt) = (&ctx.bodies, &ctx.params, ctx.dt);
    let resting = |p: &Pair| params.resting_contacts(dt, b.pair_friction(p.a as usize, p.b as usize));
    let s = &mut ctx.scratch.solve;
    s.step = ctx.step;
    s.pairs.clear();
    s.pairs.extend(ctx.pairs.iter().filter(|p| (p.contact().is_some() || p.is_candidate()) && resting(p)).copied());
    if s.pairs.is_empty() {
        s.cache.clear();
        s.rows.clear();
        return;
    }
    ctx.pose_pairs(|p| p.contact().is_some() || p.is_candidate());
    let s = &mut ctx.scratch.solve;
    let (posed, meshes, b, params, dt) = (&ctx.posed, &ctx.meshes, &ctx.bodies, &ctx.params, ctx.dt);
    let margin = params.contact_margin;
    s.manifolds.resize(s.pairs.len(), Manifold::default());
    s.near.clear();
    s.near.extend(s.pairs.iter().map(Pair::is_candidate));
    s.pairs.par_iter_mut().zip(s.manifolds.par_iter_mut()).for_each_init(ClipScratch::default, |scratch, (pair, m)| {
        let (pa, pb) = (posed.get(pair.a), posed.get(pair.b));
        let thin = b.thinner(meshes, pair.a as usize, pair.b as usize);
        // Held along the pair's least-overlap axis (see `contact_axis`), touching or a hair
        // apart (speculatively); the tests' own normal and depth decide only that it touches.
        let (ia, ib) = (pair.a as usize, pair.b as usize);
        let reach = margin * thin + params.speculative_distance(dt, b, ia) + params.speculative_distance(dt, b, ib);
        let Some(axis) = contact_axis(pa, pb, (margin * thin, reach)) else {
            m.len = 0;
            pair.state = PairState::Candidate; // apart: no rows
            return;
        };
        let feature = pair.contact().map_or(Feature::Face, |c| c.feature);
        let point = support_point(pa, pb, &axis);
        pair.state = PairState::Resolved(Contact { point, normal: axis.normal, depth: -axis.separation, feature });
        *m = manifold(pa, pb, &axis, reach, scratch);
        if m.len == 0 {
            // Edge across edge, or no vertex on the other body: one point where they meet.
            (m.points[0], m.gaps[0], m.len) = (point, axis.separation, 1);
        }
    });
    build_rows(ctx);
    substeps(ctx);
    remember(ctx);
    ctx.bodies.store(world);
}

/// One row per manifold point: lever arms, tangent basis, effective masses, and the impulses
/// of the matching point of the previous step.
fn build_rows(ctx: &mut StepContext) {
    let b = &ctx.bodies;
    let s = &mut ctx.scratch.solve;
    s.rows.clear();
    // Lowest contacts first: each forward sweep then carries the support up a stack in one
    // pass. The order matters: top-down sweeps let a tall pyramid wobble. Ties keep pair order.
    let up = -ctx.params.gravity.normalize_or_zero();
    s.order.clear();
    s.order.extend(s.manifolds.iter().enumerate().map(|(k, m)| {
        let height = m.points().iter().map(|p| p.dot(up)).sum::<Scalar>() / m.len.max(1) as Scalar;
        (height, k as u32)
    }));
    s.order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    s.spans.clear();
    for &(_, k) in &s.order {
        let (pair, m, near) = (&s.pairs[k as usize], &s.manifolds[k as usize], s.near[k as usize]);
        let (ia, ib) = (pair.a as usize, pair.b as usize);
        let Some(contact) = pair.contact() else { continue }; // apart along some axis
        let n = contact.normal;
        let (t1, t2) = tangents(n);
        let mu = b.pair_friction(ia, ib);
        let thin = b.thinner(&ctx.meshes, ia, ib);
        let inv_mass = [b.inv_mass[ia], b.inv_mass[ib]];
        let inv_inertia = [&b.inv_inertia_world[ia], &b.inv_inertia_world[ib]];
        let cached = s.cache.get(&(pair.a, pair.b));
        let start = s.rows.len();
        for (&p, &gap) in m.points().iter().zip(&m.gaps) {
            let r = [p - b.position[ia], p - b.position[ib]];
            let axis = |dir: Vector| {
                let arm = [r[0].cross(dir), r[1].cross(dir)];
                let spin = [*inv_inertia[0] * arm[0], *inv_inertia[1] * arm[1]];
                let k = inv_mass[0] + inv_mass[1] + arm[0].dot(spin[0]) + arm[1].dot(spin[1]);
                RowAxis { dir, arm, spin, mass: if k > 0.0 { 1.0 / k } else { 0.0 } }
            };
            let local = b.rotation[ia].transpose() * r[0];
            let reach = MATCH_DISTANCE * b.radius[ia];
            let old = cached.and_then(|c| c.points().iter().find(|q| (q.local - local).length() <= reach));
            let (jn, jt) = old.map_or((0.0, Vector::ZERO), |q| (q.normal, q.tangent));
            s.rows.push(SolverRow {
                a: pair.a,
                b: pair.b,
                feature: (!near).then_some(contact.feature),
                inv_mass,
                local,
                axes: [axis(n), axis(t1), axis(t2)],
                mu,
                gap,
                slop: ctx.params.slop * thin,
                max_push: ctx.params.max_correction * thin / ctx.dt,
                impulse: [jn, jt.dot(t1), jt.dot(t2)],
            });
        }
        if s.rows.len() > start {
            s.spans.push((start as u32, (s.rows.len() - start) as u32));
        }
    }
}

/// Two unit vectors completing `n` to a right-handed orthonormal basis.
fn tangents(n: Vector) -> (Vector, Vector) {
    let helper = if n.x.abs() < 0.57 { Vector::X } else { Vector::Y };
    let t1 = n.cross(helper).normalize();
    (t1, n.cross(t1))
}

/// The relative motion of A against B along `axis` at the row's point, given each body's
/// (linear, angular) pair: a speed from velocities, a displacement from the substeps' `delta`.
#[inline(always)]
fn along(axis: &RowAxis, (la, aa): (Vector, Vector), (lb, ab): (Vector, Vector)) -> Scalar {
    (la - lb).dot(axis.dir) + aa.dot(axis.arm[0]) - ab.dot(axis.arm[1])
}

/// Applies an impulse of `j` along `axis` at the row's point: +j on A, −j on B.
#[inline(always)]
fn push(b: &mut Bodies, row: &SolverRow, axis: &RowAxis, j: Scalar) {
    let (ia, ib) = (row.a as usize, row.b as usize);
    b.velocity[ia] += axis.dir * (j * row.inv_mass[0]);
    b.angular_velocity[ia] += axis.spin[0] * j;
    b.velocity[ib] -= axis.dir * (j * row.inv_mass[1]);
    b.angular_velocity[ib] -= axis.spin[1] * j;
}

/// Damping ratio of the soft contact (Box2D v3's default): heavily overdamped, so pushing a
/// penetration out never overshoots into a bounce.
const CONTACT_DAMPING_RATIO: Scalar = 10.0;

/// Stiffness of the soft contact as a fraction of the substep rate: a quarter, Box2D v3's upper
/// bound for a stable spring (120 Hz with 8 substeps of a 1/60 s step). A soft contact sinks
/// under load by (load)/(effective mass · ω²), so the stiffest stable spring keeps a 40-row
/// pyramid's bottom row within a millimetre or two.
const CONTACT_HERTZ_PER_SUBSTEP_RATE: Scalar = 0.25;

/// The soft-constraint coefficients of a contact for substep `h` (Catto, "Solver2D", 2024): a
/// damped spring of `CONTACT_HERTZ_PER_SUBSTEP_RATE` written as a bias rate and mass/impulse scales.
#[derive(Clone, Copy, Debug)]
struct Softness {
    bias_rate: Scalar,
    mass_scale: Scalar,
    impulse_scale: Scalar,
}

impl Softness {
    fn new(h: Scalar) -> Self {
        let omega = 2.0 * std::f64::consts::PI * CONTACT_HERTZ_PER_SUBSTEP_RATE / h;
        let a1 = 2.0 * CONTACT_DAMPING_RATIO + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Self { bias_rate: omega / a1, mass_scale: a2 * a3, impulse_scale: a3 }
    }
}

/// The substepped solve (a "soft step", as in Box2D v3 and rapier's TGS): the step is cut into
/// `substeps` of length h. Each substep adds its share of gravity, re-applies the accumulated
/// impulses, solves with soft position feedback from the gaps as they stand after the earlier
/// substeps, moves the bodies' (virtual) displacements on, and relaxes: a rigid pass that takes
/// back the push-out velocity so penetration is removed without adding energy. Positions then
/// end where the substeps took them: `integrate` adds v·dt, so `solve` moves each body by the
/// rest. Gravity's change of velocity, which the `gravity` system applied whole, is re-timed
/// over the substeps (net change unchanged), so a stack's weight is carried substep by substep.
fn substeps(ctx: &mut StepContext) {
    let (params, dt) = (&ctx.params, ctx.dt);
    let count = params.substeps.max(1);
    let h = dt / Scalar::from(count);
    let soft = Softness::new(h);
    let s = &mut ctx.scratch.solve;
    let b = &mut ctx.bodies;
    s.moving.clear();
    s.moving.extend(s.rows.iter().flat_map(|r| [r.a, r.b]).filter(|&i| b.inv_mass[i as usize] > 0.0));
    s.moving.sort_unstable();
    s.moving.dedup();
    s.delta.clear();
    s.delta.resize(b.len(), (Vector::ZERO, Vector::ZERO));
    let (g_step, g_sub) = (params.gravity * dt, params.gravity * h);
    for &i in &s.moving {
        b.velocity[i as usize] -= g_step;
    }
    for _ in 0..count {
        for &i in &s.moving {
            b.velocity[i as usize] += g_sub;
        }
        warm_start(b, &s.rows);
        for _ in 0..params.iterations {
            iterate(b, &mut s.rows, &s.spans, &s.delta, h, Some(soft));
        }
        for &i in &s.moving {
            let i = i as usize;
            s.delta[i].0 += b.velocity[i] * h;
            s.delta[i].1 += b.angular_velocity[i] * h;
        }
        iterate(b, &mut s.rows, &s.spans, &s.delta, h, None);
    }
    for &i in &s.moving {
        let i = i as usize;
        let (dx, dtheta) = s.delta[i];
        b.position[i] += dx - b.velocity[i] * dt;
        b.orientation[i] = (exp_map(dtheta - b.angular_velocity[i] * dt) * b.orientation[i]).normalize();
    }
    for i in 0..ctx.scratch.solve.moving.len() {
        ctx.mark_moved(ctx.scratch.solve.moving[i] as usize);
    }
}

/// Re-applies the accumulated impulses (last step's at the first substep): a resting stack
/// starts each substep near its solution.
fn warm_start(b: &mut Bodies, rows: &[SolverRow]) {
    for row in rows {
        for (axis, &j) in row.axes.iter().zip(&row.impulse) {
            push(b, row, axis, j);
        }
    }
}

/// One Gauss–Seidel sweep through the rows, lowest contacts first (see `build_rows`). At
/// each point the normal impulse first (accumulated, never pulling), then friction within the
/// Coulomb cone of it.
///
/// The gap is the step's starting gap moved on by the substeps' displacements `delta`
/// (linearised about the step's start). A gap still open may close within this substep
/// (speculative contact, u_n ≥ −gap/h); a penetration is pushed out by the soft spring when
/// `soft` is given (the solve pass), never faster than the row's cap, and not at all when it
/// is `None` (the relax pass, which takes the push-out velocity back).
fn iterate(
    b: &mut Bodies,
    rows: &mut [SolverRow],
    spans: &[(u32, u32)],
    delta: &[(Vector, Vector)],
    h: Scalar,
    soft: Option<Softness>,
) {
    for &(start, len) in spans {
        let pair = &mut rows[start as usize..(start + len) as usize];
        // The relax pass takes a pair's points in the reverse order, so neither end of a
        // manifold is always first: a box landing flat is stopped evenly at its corners.
        if soft.is_none() {
            pair.iter_mut().rev().for_each(|row| solve_point(b, row, delta, h, soft));
        } else {
            pair.iter_mut().for_each(|row| solve_point(b, row, delta, h, soft));
        }
    }
}

/// The velocities of a row's two bodies, held in registers while the row is solved: its
/// three impulses then update them without a round trip through memory each.
#[derive(Clone, Copy)]
struct Motion {
    a: (Vector, Vector),
    b: (Vector, Vector),
}

impl Motion {
    #[inline(always)]
    fn load(b: &Bodies, row: &SolverRow) -> Self {
        let (ia, ib) = (row.a as usize, row.b as usize);
        Self { a: (b.velocity[ia], b.angular_velocity[ia]), b: (b.velocity[ib], b.angular_velocity[ib]) }
    }

    #[inline(always)]
    fn store(self, b: &mut Bodies, row: &SolverRow) {
        let (ia, ib) = (row.a as usize, row.b as usize);
        (b.velocity[ia], b.angular_velocity[ia]) = self.a;
        (b.velocity[ib], b.angular_velocity[ib]) = self.b;
    }

    /// Relative speed of A against B along `axis`.
    #[inline(always)]
    fn speed(&self, axis: &RowAxis) -> Scalar {
        along(axis, self.a, self.b)
    }

    /// An impulse of `j` along `axis`: +j on A, −j on B (as `push`).
    #[inline(always)]
    fn push(&mut self, row: &SolverRow, axis: &RowAxis, j: Scalar) {
        self.a.0 += axis.dir * (j * row.inv_mass[0]);
        self.a.1 += axis.spin[0] * j;
        self.b.0 -= axis.dir * (j * row.inv_mass[1]);
        self.b.1 -= axis.spin[1] * j;
    }
}

/// One point: its normal impulse, then its friction.
#[inline(always)]
fn solve_point(b: &mut Bodies, row: &mut SolverRow, delta: &[(Vector, Vector)], h: Scalar, soft: Option<Softness>) {
    let mut m = Motion::load(b, row);
    normal_point(&mut m, row, delta, h, soft);
    if row.mu > 0.0 {
        friction_point(&mut m, row);
    }
    m.store(b, row);
}

/// The normal impulse at one point (see `iterate`).
#[inline(always)]
fn normal_point(m: &mut Motion, row: &mut SolverRow, delta: &[(Vector, Vector)], h: Scalar, soft: Option<Softness>) {
    let n = row.axes[0];
    let gap = row.gap + along(&n, delta[row.a as usize], delta[row.b as usize]);
    let (bias, mass_scale, impulse_scale) = match soft {
        _ if gap > 0.0 => (gap / h, 1.0, 0.0),
        Some(k) if gap + row.slop < 0.0 => {
            ((k.bias_rate * (gap + row.slop)).max(-row.max_push), k.mass_scale, k.impulse_scale)
        }
        _ => (0.0, 1.0, 0.0),
    };
    let dj = -n.mass * mass_scale * (m.speed(&n) + bias) - impulse_scale * row.impulse[0];
    let jn = (row.impulse[0] + dj).max(0.0);
    m.push(row, &n, jn - row.impulse[0]);
    row.impulse[0] = jn;
}

/// The friction impulse at one point, within the Coulomb cone of its normal impulse.
#[inline(always)]
fn friction_point(m: &mut Motion, row: &mut SolverRow) {
    let [_, t1, t2] = row.axes;
    let (mut j1, mut j2) = (row.impulse[1] - m.speed(&t1) * t1.mass, row.impulse[2] - m.speed(&t2) * t2.mass);
    let limit = row.mu * row.impulse[0];
    let len2 = j1 * j1 + j2 * j2;
    // Compared squared: the square root (a long-latency instruction on the solver's critical
    // path) is only taken when the impulse leaves the cone.
    if len2 > limit * limit {
        let len = len2.sqrt();
        (j1, j2) = (j1 * limit / len, j2 * limit / len);
    }
    m.push(row, &t1, j1 - row.impulse[1]);
    m.push(row, &t2, j2 - row.impulse[2]);
    (row.impulse[1], row.impulse[2]) = (j1, j2);
}

/// Keeps this step's impulses for the next step's warm start, and counts one impulse per pair
/// held (by the feature that found its contact; near pairs no test found are not counted).
fn remember(ctx: &mut StepContext) {
    let s = &mut ctx.scratch.solve;
    s.cache.clear();
    let mut held: Option<(u32, u32)> = None;
    for row in &s.rows {
        let entry: &mut CachedManifold = s.cache.entry((row.a, row.b)).or_default();
        if entry.len < entry.points.len() {
            let [jn, j1, j2] = row.impulse;
            let tangent = row.axes[1].dir * j1 + row.axes[2].dir * j2;
            entry.points[entry.len] = CachedPoint { local: row.local, normal: jn, tangent };
            entry.len += 1;
        }
        if let Some(feature) = row.feature
            && row.impulse[0] > 0.0
            && held != Some((row.a, row.b))
        {
            held = Some((row.a, row.b));
            ctx.stats.impulses[feature as usize] += 1;
        }
    }
}
