//! The substep passes over the batches: warm start, the solve and relax sweeps, restitution.
//! Each works on a batch's lanes side by side (see `lanes`); per lane the arithmetic is that
//! of solving the constraint alone, in the order the `solve` system gave.

use super::lanes::{Batch, Lanes, PointRows, Wide};
use super::{BodyStore, LANES, Softness};
use crate::math::Scalar;

/// The two bodies of each lane of a batch while it is solved.
#[derive(Clone, Copy)]
struct Ends {
    va: Wide,
    wa: Wide,
    dqa: Wide,
    vb: Wide,
    wb: Wide,
    dqb: Wide,
    /// (v_a − v_b)·n, kept up to date by `push_normal`: the normal rows' linear part.
    u: Lanes,
    /// (dx_a − dx_b)·n: how far the substeps have moved the bodies along the normal.
    d: Lanes,
    /// Normal impulse applied to `u` and the spins but not yet to the linear velocities
    /// (`flush`): a normal row's linear part is the same for every point of a pair, so it is
    /// kept as one number until something else needs the velocities.
    held: Lanes,
}

impl Ends {
    /// Loads the bodies of a batch's lanes: their velocities, and with `MOTION` how far the
    /// substeps have moved them (which only the passes that read gaps need).
    #[inline(always)]
    fn open<const MOTION: bool, B: BodyStore + ?Sized>(bodies: &B, batch: &Batch) -> Self {
        let z = Wide::ZERO;
        let mut e =
            Self { va: z, wa: z, dqa: z, vb: z, wb: z, dqb: z, u: [0.0; LANES], d: [0.0; LANES], held: [0.0; LANES] };
        for l in 0..LANES {
            let (a, b) = (bodies.body(batch.slot[0][l]), bodies.body(batch.slot[1][l]));
            let n = batch.normal.get(l);
            e.u[l] = (a.v - b.v).dot(n);
            e.va.set(l, a.v);
            e.wa.set(l, a.w);
            e.vb.set(l, b.v);
            e.wb.set(l, b.w);
            if MOTION {
                e.d[l] = (a.dx - b.dx).dot(n);
                e.dqa.set(l, a.dq);
                e.dqb.set(l, b.dq);
            }
        }
        e
    }

    /// Writes the velocities back, except into a static slot, which must stay zero and whose
    /// writes would chain every ground contact to the one before.
    #[inline(always)]
    fn close<B: BodyStore + ?Sized>(&mut self, bodies: &mut B, batch: &Batch) {
        self.flush(batch);
        for l in 0..LANES {
            let [ia, ib] = [batch.slot[0][l], batch.slot[1][l]];
            if !bodies.is_static(ia) {
                let a = bodies.body_mut(ia);
                (a.v, a.w) = (self.va.get(l), self.wa.get(l));
            }
            if !bodies.is_static(ib) {
                let b = bodies.body_mut(ib);
                (b.v, b.w) = (self.vb.get(l), self.wb.get(l));
            }
        }
    }

    /// Applies the held normal impulses to the linear velocities.
    #[inline(always)]
    fn flush(&mut self, batch: &Batch) {
        let (mut sa, mut sb) = ([0.0; LANES], [0.0; LANES]);
        for l in 0..LANES {
            (sa[l], sb[l]) = (self.held[l] * batch.inv_mass[0][l], self.held[l] * batch.inv_mass[1][l]);
        }
        self.va.add_scaled(&batch.normal, &sa);
        self.vb.sub_scaled(&batch.normal, &sb);
        self.held = [0.0; LANES];
    }

    /// Relative normal speeds of A against B at points with scaled levers `g`.
    #[inline(always)]
    fn normal_speed(&self, g: &[Wide; 2]) -> Lanes {
        with_levers(self.u, (&self.wa, &self.wb), g)
    }

    /// Normal impulses `j` at points with scaled levers `g`; `im` is m_a⁻¹ + m_b⁻¹.
    #[inline(always)]
    fn push_normal(&mut self, g: &[Wide; 2], im: &Lanes, j: &Lanes) {
        self.wa.add_scaled(&g[0], j);
        self.wb.sub_scaled(&g[1], j);
        for l in 0..LANES {
            self.u[l] += j[l] * im[l];
            self.held[l] += j[l];
        }
    }

    /// Impulses `j` along `d` at the points with scaled levers `g`: +j on A, −j on B.
    #[inline(always)]
    fn push(&mut self, d: &Wide, g: &[Wide; 2], batch: &Batch, j: &Lanes) {
        let (mut sa, mut sb) = ([0.0; LANES], [0.0; LANES]);
        for l in 0..LANES {
            (sa[l], sb[l]) = (j[l] * batch.inv_mass[0][l], j[l] * batch.inv_mass[1][l]);
        }
        self.va.add_scaled(d, &sa);
        self.wa.add_scaled(&g[0], j);
        self.vb.sub_scaled(d, &sb);
        self.wb.sub_scaled(&g[1], j);
    }

    /// The gaps of points with scaled levers `g` and starting gaps `gap`, moved on by the
    /// substeps' displacements.
    #[inline(always)]
    fn gap(&self, g: &[Wide; 2], gap: &Lanes) -> Lanes {
        let mut linear = *gap;
        for l in 0..LANES {
            linear[l] += self.d[l];
        }
        with_levers(linear, (&self.dqa, &self.dqb), g)
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
        let mut e = Ends::open::<false, B>(bodies, batch);
        for p in entries(batch, points).iter() {
            e.push_normal(&p.g, &batch.im, &p.impulse);
        }
        e.flush(batch);
        let f = &batch.friction;
        e.push(&batch.tangents[0], &f.g[0], batch, &f.impulse[0]);
        e.push(&batch.tangents[1], &f.g[1], batch, &f.impulse[1]);
        e.wa.add_scaled(&f.twist[0], &f.impulse[2]);
        e.wb.sub_scaled(&f.twist[1], &f.impulse[2]);
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
        let mut e = Ends::open::<true, B>(bodies, batch);
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
                normal_pair(&mut e, batch, pair, h, soft);
            }
            e.flush(batch);
            friction(&mut e, batch, entries);
        } else {
            for pair in entries.chunks_mut(2) {
                normal_pair(&mut e, batch, pair, h, soft);
            }
        }
        e.close(bodies, batch);
    }
}

/// The normal rows of a pair of points (or a last single one) of each lane.
#[inline(always)]
fn normal_pair(e: &mut Ends, batch: &Batch, pair: &mut [PointRows], h: Scalar, soft: Option<Softness>) {
    match pair {
        [p, q] => {
            let (gp, gq) = (e.gap(&p.g, &p.gap), e.gap(&q.g, &q.gap));
            let (up, uq) = (e.normal_speed(&p.g), e.normal_speed(&q.g));
            let (mut dp, mut dq) = ([0.0; LANES], [0.0; LANES]);
            for l in 0..LANES {
                let row = |r: &PointRows, gap: Scalar| Row::new(r, l, gap, batch.slop[l], batch.max_push[l], h, soft);
                let (new_p, new_q) = block(row(p, gp[l]), row(q, gq[l]), up[l], uq[l], p.coupling[l]);
                (dp[l], dq[l]) = (new_p - p.impulse[l], new_q - q.impulse[l]);
                (p.impulse[l], q.impulse[l]) = (new_p, new_q);
                p.max_impulse[l] = p.max_impulse[l].max(new_p);
                q.max_impulse[l] = q.max_impulse[l].max(new_q);
            }
            e.push_normal(&p.g, &batch.im, &dp);
            e.push_normal(&q.g, &batch.im, &dq);
        }
        [p] => {
            let (gap, u) = (e.gap(&p.g, &p.gap), e.normal_speed(&p.g));
            let mut dp = [0.0; LANES];
            for l in 0..LANES {
                let new = Row::new(p, l, gap[l], batch.slop[l], batch.max_push[l], h, soft).single(u[l]);
                dp[l] = new - p.impulse[l];
                p.impulse[l] = new;
                p.max_impulse[l] = p.max_impulse[l].max(new);
            }
            e.push_normal(&p.g, &batch.im, &dp);
        }
        _ => {}
    }
}

/// One normal row as a pass sees it.
#[derive(Clone, Copy)]
struct Row {
    /// Effective mass m and K_ii = 1/m.
    mass: Scalar,
    k: Scalar,
    /// Accumulated impulse λ.
    impulse: Scalar,
    /// Velocity bias b: u + b ≥ 0 is the target.
    bias: Scalar,
    /// The soft step's mass and impulse scales (1, 0 when rigid): its update
    /// Δλ = −m s_m (u + b) − s_i λ is a Gauss–Seidel step on the compliant row
    /// u + b + C λ = 0 with C = K_ii s_i / s_m, whose diagonal K_ii + C has inverse m s_m.
    mass_scale: Scalar,
    impulse_scale: Scalar,
    /// s_i / s_m (0 when rigid).
    compliance: Scalar,
}

impl Row {
    /// Lane `l` of `r`, whose gap is `gap` now.
    ///
    /// A gap still open may close within this substep (speculative contact, u ≥ −gap/h); a
    /// penetration beyond the slop is pushed out by the soft spring in the solve pass, never
    /// faster than `max_push`, and not at all in the relax pass, which takes the push-out
    /// velocity back.
    #[inline(always)]
    fn new(
        r: &PointRows,
        l: usize,
        gap: Scalar,
        slop: Scalar,
        max_push: Scalar,
        h: Scalar,
        soft: Option<Softness>,
    ) -> Self {
        let rigid = |bias| Self::rigid(r, l, bias);
        match soft {
            _ if gap > 0.0 => rigid(gap / h),
            Some(s) if gap + slop < 0.0 => Self {
                bias: (s.bias_rate * (gap + slop)).max(-max_push),
                mass_scale: s.mass_scale,
                impulse_scale: s.impulse_scale,
                compliance: s.compliance,
                ..rigid(0.0)
            },
            _ => rigid(0.0),
        }
    }

    /// Lane `l` of `r` as a rigid row with velocity bias `bias`.
    #[inline(always)]
    fn rigid(r: &PointRows, l: usize, bias: Scalar) -> Self {
        Self {
            mass: r.mass[l],
            k: r.k[l],
            impulse: r.impulse[l],
            bias,
            mass_scale: 1.0,
            impulse_scale: 0.0,
            compliance: 0.0,
        }
    }

    /// The row's new impulse solved alone, from relative normal speed `u`.
    #[inline(always)]
    fn single(&self, u: Scalar) -> Scalar {
        let dj = -self.mass * self.mass_scale * (u + self.bias) - self.impulse_scale * self.impulse;
        (self.impulse + dj).max(0.0)
    }
}

/// Two normal rows of one manifold solved together, from their relative speeds `u`, `v` and
/// coupling K₀₁: the 2×2 linear complementarity problem (K + C) Δλ = −(u + b + C λ),
/// λ + Δλ ≥ 0, by trying which rows push (Box2D v2's block solver, here over a manifold's
/// diagonals, whose rows fight each other: pushing one corner tips the body away from the
/// opposite one, so one Gauss–Seidel sweep of the four corners of a box landing flat leaves it
/// spinning, and the next substep's warm start bounces it). Returns the new impulses.
#[inline(always)]
fn block(p: Row, q: Row, u: Scalar, v: Scalar, m01: Scalar) -> (Scalar, Scalar) {
    if q.mass == 0.0 || p.mass == 0.0 {
        // A last single point (the other idle), or an idle pair: one after the other.
        let new_p = p.single(u);
        return (new_p, q.single(v + m01 * (new_p - p.impulse)));
    }
    let (cp, cq) = (p.compliance * p.k, q.compliance * q.k);
    let lambda = [p.impulse, q.impulse];
    let r = [u + p.bias + cp * lambda[0], v + q.bias + cq * lambda[1]];
    if lambda == [0.0, 0.0] && r[0] >= 0.0 && r[1] >= 0.0 {
        return (0.0, 0.0); // apart, or touching without pushing, and staying so
    }
    let (m00, m11) = (p.k + cp, q.k + cq);
    let det = m00 * m11 - m01 * m01;
    if det > 1e-9 * m00 * m11 {
        let inv = 1.0 / det;
        let both = [lambda[0] - (m11 * r[0] - m01 * r[1]) * inv, lambda[1] - (m00 * r[1] - m01 * r[0]) * inv];
        if both[0] >= 0.0 && both[1] >= 0.0 {
            return (both[0], both[1]);
        }
    }
    // Only the first pushes; only the second; neither.
    let l0 = lambda[0] - (r[0] - m01 * lambda[1]) * (p.mass * p.mass_scale);
    if l0 >= 0.0 && r[1] + m01 * (l0 - lambda[0]) - m11 * lambda[1] >= 0.0 {
        return (l0, 0.0);
    }
    let l1 = lambda[1] - (r[1] - m01 * lambda[0]) * (q.mass * q.mass_scale);
    if l1 >= 0.0 && r[0] + m01 * (l1 - lambda[1]) - m00 * lambda[0] >= 0.0 {
        return (0.0, l1);
    }
    if r[0] - m00 * lambda[0] - m01 * lambda[1] >= 0.0 && r[1] - m01 * lambda[0] - m11 * lambda[1] >= 0.0 {
        return (0.0, 0.0);
    }
    // Round-off left no case exact: one Gauss–Seidel step each.
    let new_p = p.single(u);
    (new_p, q.single(v + m01 * (new_p - p.impulse)))
}

/// The friction patches of a batch (see `super::Friction`): the two tangent rows together,
/// clamped to the Coulomb disc of the points' normal impulses, then the twist row. The linear
/// velocities must be up to date (`Ends::flush`).
#[inline(always)]
fn friction(e: &mut Ends, batch: &mut Batch, entries: &[PointRows]) {
    let (mut total, mut moment) = ([0.0; LANES], [0.0; LANES]);
    for p in entries {
        for l in 0..LANES {
            total[l] += p.impulse[l];
            moment[l] += p.impulse[l] * p.lever[l];
        }
    }
    let dv = {
        let mut dv = e.va;
        dv.sub_scaled(&e.vb, &[1.0; LANES]);
        dv
    };
    let f = &mut batch.friction;
    let (s1, s2) =
        (tangent_speed(&dv, e, &batch.tangents[0], &f.g[0]), tangent_speed(&dv, e, &batch.tangents[1], &f.g[1]));
    let (mut d1, mut d2) = ([0.0; LANES], [0.0; LANES]);
    for l in 0..LANES {
        let [m11, m12, m22] = [f.mass[0][l], f.mass[1][l], f.mass[2][l]];
        let mut j1 = f.impulse[0][l] - (m11 * s1[l] + m12 * s2[l]);
        let mut j2 = f.impulse[1][l] - (m12 * s1[l] + m22 * s2[l]);
        let limit = batch.mu[l] * total[l];
        let len2 = j1 * j1 + j2 * j2;
        // Compared squared: the square root is only taken when the impulse leaves the disc.
        if len2 > limit * limit {
            let scale = limit / len2.sqrt();
            (j1, j2) = (j1 * scale, j2 * scale);
        }
        (d1[l], d2[l]) = (j1 - f.impulse[0][l], j2 - f.impulse[1][l]);
        (f.impulse[0][l], f.impulse[1][l]) = (j1, j2);
    }
    let (t, g) = (batch.tangents, f.g);
    e.push(&t[0], &g[0], batch, &d1);
    e.push(&t[1], &g[1], batch, &d2);
    let f = &mut batch.friction;
    let (sa, sb) = (e.wa.dot(&f.twist[0]), e.wb.dot(&f.twist[1]));
    let mut dt = [0.0; LANES];
    for l in 0..LANES {
        let limit = batch.mu[l] * moment[l];
        let jt = (f.impulse[2][l] - f.twist_mass[l] * (sa[l] - sb[l])).clamp(-limit, limit);
        dt[l] = jt - f.impulse[2][l];
        f.impulse[2][l] = jt;
    }
    e.wa.add_scaled(&f.twist[0], &dt);
    e.wb.sub_scaled(&f.twist[1], &dt);
}

/// Relative speeds along tangents `t` at the friction centres (levers `g`), `dv` being
/// v_a − v_b.
#[inline(always)]
fn tangent_speed(dv: &Wide, e: &Ends, t: &Wide, g: &[Wide; 2]) -> Lanes {
    with_levers(dv.dot(t), (&e.wa, &e.wb), g)
}

/// A row's relative motion in each lane: its linear part plus A's angular part along its lever
/// minus B's, `linear + a·g_a − b·g_b` (speeds from spins, gaps from turns).
#[inline(always)]
fn with_levers(mut linear: Lanes, (a, b): (&Wide, &Wide), g: &[Wide; 2]) -> Lanes {
    let (ga, gb) = (a.dot(&g[0]), b.dot(&g[1]));
    for l in 0..LANES {
        linear[l] = linear[l] + ga[l] - gb[l];
    }
    linear
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
        let mut e = Ends::open::<false, B>(bodies, batch);
        for pair in entries(batch, points).chunks_mut(2) {
            // A bouncing row: rigid, its target the reversed approach; `None` if it rests.
            let row = |r: &PointRows, l: usize| {
                let bounce = batch.restitution[l] > 0.0 && r.approach[l] <= -threshold && r.max_impulse[l] > 0.0;
                bounce.then(|| Row::rigid(r, l, batch.restitution[l] * r.approach[l]))
            };
            match pair {
                [p, q] => {
                    let (u, v) = (e.normal_speed(&p.g), e.normal_speed(&q.g));
                    let (mut dp, mut dq) = ([0.0; LANES], [0.0; LANES]);
                    for l in 0..LANES {
                        let (new_p, new_q) = match (row(p, l), row(q, l)) {
                            (Some(rp), Some(rq)) => block(rp, rq, u[l], v[l], p.coupling[l]),
                            (Some(rp), None) => (rp.single(u[l]), q.impulse[l]),
                            (None, Some(rq)) => (p.impulse[l], rq.single(v[l])),
                            (None, None) => (p.impulse[l], q.impulse[l]),
                        };
                        (dp[l], dq[l]) = (new_p - p.impulse[l], new_q - q.impulse[l]);
                        (p.impulse[l], q.impulse[l]) = (new_p, new_q);
                    }
                    e.push_normal(&p.g, &batch.im, &dp);
                    e.push_normal(&q.g, &batch.im, &dq);
                }
                [p] => {
                    let u = e.normal_speed(&p.g);
                    let mut dp = [0.0; LANES];
                    for l in 0..LANES {
                        if let Some(rp) = row(p, l) {
                            let new = rp.single(u[l]);
                            dp[l] = new - p.impulse[l];
                            p.impulse[l] = new;
                        }
                    }
                    e.push_normal(&p.g, &batch.im, &dp);
                }
                _ => {}
            }
        }
        e.close(bodies, batch);
    }
}
