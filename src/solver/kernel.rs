//! The substep passes over the batches: warm start, the solve and relax sweeps, restitution.
//! Each works on a batch's four lanes at once, in `f64x4` registers (one AVX instruction per
//! operation on the project's machines, two SSE2 ones elsewhere); per lane the arithmetic is
//! that of solving the constraint alone, in the order the `solve` system gave, operation for
//! operation, so the lanes and a one-by-one solve give the same bits. Where a row's case
//! depends on its lane (speculative, pushed or rigid; which rows of a block push), every case
//! is computed and the lane's own selected: no branch on one lane holds up the other three.
//! The only branches ask whether any lane of the batch needs a costly step (a division, a
//! root, a block's rarer cases) and skip it when none does.

use super::lanes::{Batch, Lanes, PointRows, Wide};
use super::{BodyStore, LANES, Softness};
use crate::math::Scalar;
use wide::f64x4;

const _: () = assert!(LANES == 4, "the kernel's registers hold four lanes");

/// One value per lane, in a register.
type F = f64x4;

/// Loads lanes.
#[inline(always)]
fn ld(lanes: &Lanes) -> F {
    F::new(*lanes)
}

/// One vector per lane, in registers.
#[derive(Clone, Copy)]
struct V {
    x: F,
    y: F,
    z: F,
}

impl V {
    #[inline(always)]
    fn load(w: &Wide) -> Self {
        Self { x: ld(&w.x), y: ld(&w.y), z: ld(&w.z) }
    }

    #[inline(always)]
    fn dot(self, o: Self) -> F {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// `self − o`.
    #[inline(always)]
    fn minus(self, o: Self) -> Self {
        Self { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }

    /// `self += o · s`.
    #[inline(always)]
    fn add_scaled(&mut self, o: Self, s: F) {
        self.x += o.x * s;
        self.y += o.y * s;
        self.z += o.z * s;
    }

    /// `self -= o · s`.
    #[inline(always)]
    fn sub_scaled(&mut self, o: Self, s: F) {
        self.x -= o.x * s;
        self.y -= o.y * s;
        self.z -= o.z * s;
    }
}

/// The two bodies of each lane of a batch while it is solved.
#[derive(Clone, Copy)]
struct Ends {
    va: V,
    wa: V,
    vb: V,
    wb: V,
    /// (v_a − v_b)·n, kept up to date by `push_normal`: the normal rows' linear part.
    u: F,
    /// Normal impulse applied to `u` and the spins but not yet to the linear velocities
    /// (`flush`): a normal row's linear part is the same for every point of a pair, so it is
    /// kept as one number until something else needs the velocities.
    held: F,
}

/// How far the substeps have moved each lane's bodies: what the passes that read gaps need.
#[derive(Clone, Copy)]
struct Motion {
    dqa: V,
    dqb: V,
    /// (dx_a − dx_b)·n: along the normal.
    d: F,
}

/// The lanes' (A, B) bodies' fields picked by `pick`, as two register vectors.
#[inline(always)]
fn gather<B: BodyStore + ?Sized>(
    bodies: &B,
    batch: &Batch,
    pick: impl Fn(&super::SolverBody) -> crate::math::Vector,
) -> [V; 2] {
    let mut out = [[[0.0; LANES]; 3]; 2];
    for end in 0..2 {
        for l in 0..LANES {
            let v = pick(bodies.body(batch.slot[end][l]));
            (out[end][0][l], out[end][1][l], out[end][2][l]) = (v.x, v.y, v.z);
        }
    }
    out.map(|[x, y, z]| V { x: F::new(x), y: F::new(y), z: F::new(z) })
}

impl Ends {
    /// Loads the velocities of the bodies of a batch's lanes.
    #[inline(always)]
    fn open<B: BodyStore + ?Sized>(bodies: &B, batch: &Batch) -> Self {
        let [va, vb] = gather(bodies, batch, |b| b.v);
        let [wa, wb] = gather(bodies, batch, |b| b.w);
        let u = va.minus(vb).dot(V::load(&batch.normal));
        Self { va, wa, vb, wb, u, held: F::ZERO }
    }

    /// Writes the velocities back, except into a static slot, which must stay zero and whose
    /// writes would chain every ground contact to the one before.
    #[inline(always)]
    fn close<B: BodyStore + ?Sized>(&mut self, bodies: &mut B, batch: &Batch) {
        self.flush(batch);
        let lanes = |v: V| [v.x.to_array(), v.y.to_array(), v.z.to_array()];
        let ends = [(lanes(self.va), lanes(self.wa)), (lanes(self.vb), lanes(self.wb))];
        for (end, (v, w)) in ends.iter().enumerate() {
            for l in 0..LANES {
                let slot = batch.slot[end][l];
                if !bodies.is_static(slot) {
                    let body = bodies.body_mut(slot);
                    body.v = crate::math::Vector::new(v[0][l], v[1][l], v[2][l]);
                    body.w = crate::math::Vector::new(w[0][l], w[1][l], w[2][l]);
                }
            }
        }
    }

    /// Applies the held normal impulses to the linear velocities.
    #[inline(always)]
    fn flush(&mut self, batch: &Batch) {
        let n = V::load(&batch.normal);
        let (sa, sb) = (self.held * ld(&batch.inv_mass[0]), self.held * ld(&batch.inv_mass[1]));
        self.va.add_scaled(n, sa);
        self.vb.sub_scaled(n, sb);
        self.held = F::ZERO;
    }

    /// Relative normal speeds of A against B at points with scaled levers `g`.
    #[inline(always)]
    fn normal_speed(&self, g: &[Wide; 2]) -> F {
        with_levers(self.u, (self.wa, self.wb), g)
    }

    /// Normal impulses `j` at points with scaled levers `g`; `im` is m_a⁻¹ + m_b⁻¹.
    #[inline(always)]
    fn push_normal(&mut self, g: &[Wide; 2], im: F, j: F) {
        self.wa.add_scaled(V::load(&g[0]), j);
        self.wb.sub_scaled(V::load(&g[1]), j);
        self.u += j * im;
        self.held += j;
    }

    /// Impulses `j` along `d` at the points with scaled levers `g`: +j on A, −j on B.
    #[inline(always)]
    fn push(&mut self, d: &Wide, g: &[Wide; 2], batch: &Batch, j: F) {
        let (sa, sb) = (j * ld(&batch.inv_mass[0]), j * ld(&batch.inv_mass[1]));
        let d = V::load(d);
        self.va.add_scaled(d, sa);
        self.wa.add_scaled(V::load(&g[0]), j);
        self.vb.sub_scaled(d, sb);
        self.wb.sub_scaled(V::load(&g[1]), j);
    }
}

impl Motion {
    /// Loads how far the substeps have moved the bodies of a batch's lanes.
    #[inline(always)]
    fn open<B: BodyStore + ?Sized>(bodies: &B, batch: &Batch) -> Self {
        let [xa, xb] = gather(bodies, batch, |b| b.dx);
        let [dqa, dqb] = gather(bodies, batch, |b| b.dq);
        let d = xa.minus(xb).dot(V::load(&batch.normal));
        Self { dqa, dqb, d }
    }

    /// The gaps of points with scaled levers `g` and starting gaps `gap`, moved on by the
    /// substeps' displacements.
    #[inline(always)]
    fn gap(&self, g: &[Wide; 2], gap: &Lanes) -> F {
        with_levers(ld(gap) + self.d, (self.dqa, self.dqb), g)
    }
}

/// A batch's points.
#[inline(always)]
fn entries<'a>(batch: &Batch, points: &'a mut [PointRows]) -> &'a mut [PointRows] {
    &mut points[batch.first as usize..(batch.first + batch.len) as usize]
}

/// Re-applies each row's accumulated impulse (the previous substep's, or the previous step's
/// at the first substep): a resting stack starts each substep near its solution.
pub fn warm_start<B: BodyStore + ?Sized>(bodies: &mut B, batches: &[Batch], points: &mut [PointRows]) {
    for batch in batches {
        let mut e = Ends::open(bodies, batch);
        let im = ld(&batch.im);
        for p in entries(batch, points).iter() {
            e.push_normal(&p.g, im, ld(&p.impulse));
        }
        e.flush(batch);
        let f = &batch.friction;
        e.push(&batch.tangents[0], &f.g[0], batch, ld(&f.impulse[0]));
        e.push(&batch.tangents[1], &f.g[1], batch, ld(&f.impulse[1]));
        e.wa.add_scaled(V::load(&f.twist[0]), ld(&f.impulse[2]));
        e.wb.sub_scaled(V::load(&f.twist[1]), ld(&f.impulse[2]));
        e.close(bodies, batch);
    }
}

/// One Gauss–Seidel sweep through the batches in order (the `solve` system orders the
/// constraints lowest first, so one sweep carries a stack's support from the ground up).
///
/// The solve pass (`soft` given) holds the normals with soft position feedback; the relax
/// pass (`None`) solves friction, holds the normals rigidly, taking a pair's points in reverse
/// order (so neither end of a manifold is always first), and solves friction again. Friction
/// only in the relax pass (rapier's "no friction when applying bias"): friction reacting to the
/// push-out velocities pumps a tall stack's lean.
pub fn sweep<B: BodyStore + ?Sized>(
    bodies: &mut B,
    batches: &mut [Batch],
    points: &mut [PointRows],
    h: Scalar,
    soft: Option<Softness>,
) {
    for batch in batches {
        let motion = Motion::open(bodies, batch);
        let mut e = Ends::open(bodies, batch);
        let entries = entries(batch, points);
        // Points go in pairs (0, 1), (2, 3): a manifold's diagonals (`manifold::reduce`).
        if soft.is_none() {
            // Friction before the normal rows as well as after: friction at the contact plane
            // turns a body it stops (a block on a slope starts to roll), the normal rows then
            // take that roll back at the corners, and the second friction solve stops the slip
            // that remains. Once after only, a block on a slope 1 % short of slipping crept
            // 2 mm before the warm start caught up; with both, 0.8 mm.
            friction(&mut e, batch, entries);
            for pair in entries.chunks_mut(2).rev() {
                normal_pair(&mut e, &motion, batch, pair, h, soft);
            }
            e.flush(batch);
            friction(&mut e, batch, entries);
        } else {
            for pair in entries.chunks_mut(2) {
                normal_pair(&mut e, &motion, batch, pair, h, soft);
            }
        }
        e.close(bodies, batch);
    }
}

/// The normal rows of a pair of points (or a last single one) of each lane.
#[inline(always)]
fn normal_pair(e: &mut Ends, m: &Motion, batch: &Batch, pair: &mut [PointRows], h: Scalar, soft: Option<Softness>) {
    let im = ld(&batch.im);
    match pair {
        [p, q] => {
            let (rp, rq) =
                (Rows::new(p, m.gap(&p.g, &p.gap), batch, h, soft), Rows::new(q, m.gap(&q.g, &q.gap), batch, h, soft));
            let (up, uq) = (e.normal_speed(&p.g), e.normal_speed(&q.g));
            let (new_p, new_q) = block(&rp, &rq, up, uq, (ld(&p.coupling), p.inv_det.map(|d| ld(&d))));
            let (dp, dq) = (settle(p, new_p), settle(q, new_q));
            e.push_normal(&p.g, im, dp);
            e.push_normal(&q.g, im, dq);
        }
        [p] => {
            let row = Rows::new(p, m.gap(&p.g, &p.gap), batch, h, soft);
            let dp = settle(p, row.single(e.normal_speed(&p.g)));
            e.push_normal(&p.g, im, dp);
        }
        _ => {}
    }
}

/// Stores a point's new accumulated impulses `new` (and the largest so far); returns the
/// change, the impulse still to apply.
#[inline(always)]
fn settle(p: &mut PointRows, new: F) -> F {
    let change = new - ld(&p.impulse);
    p.impulse = new.to_array();
    p.max_impulse = ld(&p.max_impulse).max(new).to_array();
    change
}

/// The normal rows of one point of every lane.
#[derive(Clone, Copy)]
struct Rows {
    /// Effective mass m and K_ii = 1/m.
    mass: F,
    k: F,
    /// Accumulated impulse λ.
    impulse: F,
    /// Velocity bias b: u + b ≥ 0 is the target.
    bias: F,
    /// The soft step's mass and impulse scales (1, 0 when rigid): its update
    /// Δλ = −m s_m (u + b) − s_i λ is a Gauss–Seidel step on the compliant row
    /// u + b + C λ = 0 with C = K_ii s_i / s_m, whose diagonal K_ii + C has inverse m s_m.
    mass_scale: F,
    impulse_scale: F,
    /// s_i / s_m (0 when rigid).
    compliance: F,
}

impl Rows {
    /// The rows of `r`, whose gaps are `gap` now.
    ///
    /// A gap still open may close within this substep (speculative contact, u ≥ −gap/h); a
    /// penetration beyond the slop is pushed out by the soft spring in the solve pass, never
    /// faster than `max_push`, and not at all in the relax pass, which takes the push-out
    /// velocity back; otherwise the row is rigid.
    #[inline(always)]
    fn new(r: &PointRows, gap: F, batch: &Batch, h: Scalar, soft: Option<Softness>) -> Self {
        // Divisions are the kernel's slowest operations: only where a lane needs one.
        let open = gap.simd_gt(F::ZERO);
        let speculative = if open.any() { open.select(gap / F::splat(h), F::ZERO) } else { F::ZERO };
        let rigid = Self::rigid(r, speculative);
        let Some(s) = soft else { return rigid };
        let slop = ld(&batch.slop);
        let pushed = !open & (gap + slop).simd_lt(F::ZERO);
        let push = (F::splat(s.bias_rate) * (gap + slop)).max(-ld(&batch.max_push));
        Self {
            bias: pushed.select(push, rigid.bias),
            mass_scale: pushed.select(F::splat(s.mass_scale), rigid.mass_scale),
            impulse_scale: pushed.select(F::splat(s.impulse_scale), rigid.impulse_scale),
            compliance: pushed.select(F::splat(s.compliance), rigid.compliance),
            ..rigid
        }
    }

    /// The rows of `r` held rigidly with velocity bias `bias`.
    #[inline(always)]
    fn rigid(r: &PointRows, bias: F) -> Self {
        Self {
            mass: ld(&r.mass),
            k: ld(&r.k),
            impulse: ld(&r.impulse),
            bias,
            mass_scale: F::ONE,
            impulse_scale: F::ZERO,
            compliance: F::ZERO,
        }
    }

    /// Each row's new impulse solved alone, from relative normal speeds `u`.
    #[inline(always)]
    fn single(&self, u: F) -> F {
        let dj = -self.mass * self.mass_scale * (u + self.bias) - self.impulse_scale * self.impulse;
        (self.impulse + dj).max(F::ZERO)
    }
}

/// Two normal rows of one manifold solved together, from their relative speeds `u`, `v` and
/// coupling K₀₁: the 2×2 linear complementarity problem (K + C) Δλ = −(u + b + C λ),
/// λ + Δλ ≥ 0, by trying which rows push (Box2D v2's block solver, here over a manifold's
/// diagonals, whose rows fight each other: pushing one corner tips the body away from the
/// opposite one, so one Gauss–Seidel sweep of the four corners of a box landing flat leaves it
/// spinning, and the next substep's warm start bounces it). The cases are computed in every
/// lane and the first that holds is taken, in the order: an idle row (one Gauss–Seidel step
/// each), both apart and staying so, both pushing, only the first, only the second, neither,
/// and, when round-off left no case exact, one Gauss–Seidel step each; the later cases only
/// when some lane is in none of the first three. Returns the new impulses.
#[inline(always)]
fn block(p: &Rows, q: &Rows, u: F, v: F, (m01, [inv_rigid, inv_soft]): (F, [F; 2])) -> (F, F) {
    let zero = F::ZERO;
    let (l0, l1) = (p.impulse, q.impulse);
    let idle = q.mass.simd_eq(zero) | p.mass.simd_eq(zero);
    let (cp, cq) = (p.compliance * p.k, q.compliance * q.k);
    let (r0, r1) = (u + p.bias + cp * l0, v + q.bias + cq * l1);
    let apart = l0.simd_eq(zero) & l1.simd_eq(zero) & r0.simd_ge(zero) & r1.simd_ge(zero);
    let (m00, m11) = (p.k + cp, q.k + cq);
    let det = m00 * m11 - m01 * m01;
    // Both rows rigid (every row of a relax pass) or both soft: `fill` has divided already, by
    // the same numbers. Only a lane with one row of each divides here.
    let (soft_p, soft_q) = (!p.compliance.simd_eq(zero), !q.compliance.simd_eq(zero));
    let inv = if (soft_p ^ soft_q).any() { F::ONE / det } else { soft_p.select(inv_soft, inv_rigid) };
    let (both0, both1) = (l0 - (m11 * r0 - m01 * r1) * inv, l1 - (m00 * r1 - m01 * r0) * inv);
    let both = det.simd_gt(F::splat(1e-9) * m00 * m11) & both0.simd_ge(zero) & both1.simd_ge(zero);
    // The cases of a resting or separating manifold; the others only where a lane needs them.
    let (mut new_p, mut new_q) = (both0, both1);
    if !(idle | apart | both).all() {
        let first = l0 - (r0 - m01 * l1) * (p.mass * p.mass_scale);
        let first_only = first.simd_ge(zero) & (r1 + m01 * (first - l0) - m11 * l1).simd_ge(zero);
        let second = l1 - (r1 - m01 * l0) * (q.mass * q.mass_scale);
        let second_only = second.simd_ge(zero) & (r0 + m01 * (second - l1) - m00 * l0).simd_ge(zero);
        let neither = (r0 - m00 * l0 - m01 * l1).simd_ge(zero) & (r1 - m01 * l0 - m11 * l1).simd_ge(zero);
        let (gs0, gs1) = gauss_seidel(p, q, u, v, m01);
        // Chosen from the last case to the first, so the first that holds wins.
        (new_p, new_q) = (gs0, gs1);
        for (case, a, b) in [(neither, zero, zero), (second_only, zero, second), (first_only, first, zero)] {
            (new_p, new_q) = (case.select(a, new_p), case.select(b, new_q));
        }
        (new_p, new_q) = (both.select(both0, new_p), both.select(both1, new_q));
    }
    (new_p, new_q) = (apart.select(zero, new_p), apart.select(zero, new_q));
    if idle.any() {
        let (gs0, gs1) = gauss_seidel(p, q, u, v, m01);
        (new_p, new_q) = (idle.select(gs0, new_p), idle.select(gs1, new_q));
    }
    (new_p, new_q)
}

/// One Gauss–Seidel step for each of two rows: for an idle row (a last single point, an idle
/// pair), or where round-off left no case of `block` exact.
#[inline(always)]
fn gauss_seidel(p: &Rows, q: &Rows, u: F, v: F, m01: F) -> (F, F) {
    let new_p = p.single(u);
    (new_p, q.single(v + m01 * (new_p - p.impulse)))
}

/// The friction patches of a batch (see `super::Friction`): the two tangent rows together,
/// clamped to the Coulomb disc of the points' normal impulses, then the twist row. The linear
/// velocities must be up to date (`Ends::flush`).
#[inline(always)]
fn friction(e: &mut Ends, batch: &mut Batch, entries: &[PointRows]) {
    let (mut total, mut moment) = (F::ZERO, F::ZERO);
    for p in entries {
        let impulse = ld(&p.impulse);
        total += impulse;
        moment += impulse * ld(&p.lever);
    }
    let dv = e.va.minus(e.vb);
    let f = &mut batch.friction;
    let mu = ld(&batch.mu);
    let (t1, t2) = (V::load(&batch.tangents[0]), V::load(&batch.tangents[1]));
    let s1 = with_levers(dv.dot(t1), (e.wa, e.wb), &f.g[0]);
    let s2 = with_levers(dv.dot(t2), (e.wa, e.wb), &f.g[1]);
    let [m11, m12, m22] = f.mass.map(|m| ld(&m));
    let (old1, old2) = (ld(&f.impulse[0]), ld(&f.impulse[1]));
    let (j1, j2) = (old1 - (m11 * s1 + m12 * s2), old2 - (m12 * s1 + m22 * s2));
    let limit = mu * total;
    let len2 = j1 * j1 + j2 * j2;
    // Scaled back onto the disc where it left it (the scale is not used elsewhere).
    let outside = len2.simd_gt(limit * limit);
    let (j1, j2) = if outside.any() {
        let scale = limit / len2.sqrt();
        (outside.select(j1 * scale, j1), outside.select(j2 * scale, j2))
    } else {
        (j1, j2) // sticking: no root, no division
    };
    (f.impulse[0], f.impulse[1]) = (j1.to_array(), j2.to_array());
    let g = f.g;
    e.push(&batch.tangents[0], &g[0], batch, j1 - old1);
    e.push(&batch.tangents[1], &g[1], batch, j2 - old2);
    let f = &mut batch.friction;
    let (twist_a, twist_b) = (V::load(&f.twist[0]), V::load(&f.twist[1]));
    let (sa, sb) = (e.wa.dot(twist_a), e.wb.dot(twist_b));
    let limit = mu * moment;
    let old = ld(&f.impulse[2]);
    // f64::clamp's steps: up to −limit, then down to limit.
    let jt = old - ld(&f.twist_mass) * (sa - sb);
    let jt = jt.simd_lt(-limit).select(-limit, jt);
    let jt = jt.simd_gt(limit).select(limit, jt);
    f.impulse[2] = jt.to_array();
    e.wa.add_scaled(twist_a, jt - old);
    e.wb.sub_scaled(twist_b, jt - old);
}

/// A row's relative motion in each lane: its linear part plus A's angular part along its lever
/// minus B's, `linear + a·g_a − b·g_b` (speeds from spins, gaps from turns).
#[inline(always)]
fn with_levers(linear: F, (a, b): (V, V), g: &[Wide; 2]) -> F {
    linear + a.dot(V::load(&g[0])) - b.dot(V::load(&g[1]))
}

/// Restitution after the substeps (Box2D v3): a point that touched and was approaching faster
/// than `threshold` [m/s] when the step began leaves at `restitution` times that speed, by an
/// added normal impulse (accumulated, never pulling). Slower contacts rest: they do not hop.
/// A manifold's diagonals are solved as blocks here too, so a box landing flat leaves flat.
pub fn restitution<B: BodyStore + ?Sized>(
    bodies: &mut B,
    batches: &[Batch],
    points: &mut [PointRows],
    threshold: Scalar,
) {
    for batch in batches {
        // Most batches have no point that bounces (resting, or no restitution): their bodies
        // are left as they are without loading them.
        let may_bounce = |r: &PointRows| (0..LANES).any(|l| batch.restitution[l] > 0.0 && r.approach[l] <= -threshold);
        if !entries(batch, points).iter().any(may_bounce) {
            continue;
        }
        let mut e = Ends::open(bodies, batch);
        let (im, e_n) = (ld(&batch.im), ld(&batch.restitution));
        // A point's bouncing lanes, and its rows there: rigid, the target the reversed approach.
        let bounce = |r: &PointRows| {
            let approach = ld(&r.approach);
            let lanes =
                e_n.simd_gt(F::ZERO) & approach.simd_le(F::splat(-threshold)) & ld(&r.max_impulse).simd_gt(F::ZERO);
            (lanes, Rows::rigid(r, e_n * approach))
        };
        for pair in entries(batch, points).chunks_mut(2) {
            match pair {
                [p, q] => {
                    let ((bp, rp), (bq, rq)) = (bounce(p), bounce(q));
                    let (u, v) = (e.normal_speed(&p.g), e.normal_speed(&q.g));
                    let (both_p, both_q) = block(&rp, &rq, u, v, (ld(&p.coupling), p.inv_det.map(|d| ld(&d))));
                    let both = bp & bq;
                    let new_p = both.select(both_p, bp.select(rp.single(u), rp.impulse));
                    let new_q = both.select(both_q, bq.select(rq.single(v), rq.impulse));
                    let (dp, dq) = (new_p - rp.impulse, new_q - rq.impulse);
                    (p.impulse, q.impulse) = (new_p.to_array(), new_q.to_array());
                    e.push_normal(&p.g, im, dp);
                    e.push_normal(&q.g, im, dq);
                }
                [p] => {
                    let (bp, rp) = bounce(p);
                    let new = bp.select(rp.single(e.normal_speed(&p.g)), rp.impulse);
                    let dp = new - rp.impulse;
                    p.impulse = new.to_array();
                    e.push_normal(&p.g, im, dp);
                }
                _ => {}
            }
        }
        e.close(bodies, batch);
    }
}
