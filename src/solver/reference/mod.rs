//! A plain scalar contact solver, for tests: the constraints one at a time in the order given,
//! each pass written out in `f64`s and `Vector`s, with no batches, lanes, masks or selects.
//!
//! Its arithmetic is the kernel's, step for step: the relative normal speed `u` kept as a
//! running number, the linear part of a pair's normal impulses applied once (`pending`), the
//! block solve multiplying by 1/det. That is the method, not an optimisation of it: the same
//! sums in another order differ in round-off, and round-off can flip which case of a block
//! solve holds. So the kernel, whose module docs promise a lane gives the bits of solving its
//! constraint alone, must agree with this bit for bit; the tests below check it on random
//! constraints laid out in batches by the solver's own `place`.

use super::{Constraint, ContactPoint, Softness, SolverBody, TOUCH_SHARE};
use crate::math::{Scalar, Vector};

/// One held pair: its constraint and its manifold's points, in order.
#[derive(Clone, Debug)]
pub(super) struct PairRows {
    pub constraint: Constraint,
    pub points: Vec<ContactPoint>,
}

/// a·b, summed x, y, z in that order.
fn dot(a: Vector, b: Vector) -> Scalar {
    a.x * b.x + a.y * b.y + a.z * b.z
}

/// The larger of `a` and `b`, `b` when they compare equal (so max(−0, +0) is +0): what the
/// kernel's `f64x4::max` does (x86's `maxpd`); `f64::max` leaves the sign of zero open.
fn max(a: Scalar, b: Scalar) -> Scalar {
    if a > b { a } else { b }
}

/// The two bodies of one constraint while it is solved.
struct Ends {
    va: Vector,
    wa: Vector,
    vb: Vector,
    wb: Vector,
    /// (v_a − v_b)·n, kept up to date by `push_normal`.
    u: Scalar,
    /// Normal impulse applied to `u` and the spins, not yet to the linear velocities.
    pending: Scalar,
}

impl Ends {
    fn open(bodies: &[SolverBody], c: &Constraint) -> Self {
        let (a, b) = (bodies[c.slot[0] as usize], bodies[c.slot[1] as usize]);
        Self { va: a.v, wa: a.w, vb: b.v, wb: b.w, u: dot(a.v - b.v, c.normal), pending: 0.0 }
    }

    /// Writes the velocities back, except into the static slot (the last).
    fn close(mut self, bodies: &mut [SolverBody], c: &Constraint) {
        self.flush(c);
        let static_slot = bodies.len() - 1;
        for (slot, v, w) in [(c.slot[0], self.va, self.wa), (c.slot[1], self.vb, self.wb)] {
            if slot as usize != static_slot {
                (bodies[slot as usize].v, bodies[slot as usize].w) = (v, w);
            }
        }
    }

    fn flush(&mut self, c: &Constraint) {
        self.va += c.normal * (self.pending * c.inv_mass[0]);
        self.vb -= c.normal * (self.pending * c.inv_mass[1]);
        self.pending = 0.0;
    }

    /// Relative normal speed at a point with scaled levers `g`.
    fn normal_speed(&self, g: [Vector; 2]) -> Scalar {
        self.u + dot(self.wa, g[0]) - dot(self.wb, g[1])
    }

    fn push_normal(&mut self, g: [Vector; 2], inv_mass_sum: Scalar, j: Scalar) {
        self.wa += g[0] * j;
        self.wb -= g[1] * j;
        self.u += j * inv_mass_sum;
        self.pending += j;
    }

    /// Impulse `j` along `d` at scaled levers `g`: +j on A, −j on B.
    fn push(&mut self, d: Vector, g: [Vector; 2], c: &Constraint, j: Scalar) {
        self.va += d * (j * c.inv_mass[0]);
        self.wa += g[0] * j;
        self.vb -= d * (j * c.inv_mass[1]);
        self.wb -= g[1] * j;
    }
}

/// How far the substeps have moved a constraint's bodies.
struct Motion {
    dqa: Vector,
    dqb: Vector,
    normal_dx: Scalar,
}

impl Motion {
    fn open(bodies: &[SolverBody], c: &Constraint) -> Self {
        let (a, b) = (bodies[c.slot[0] as usize], bodies[c.slot[1] as usize]);
        Self { dqa: a.dq, dqb: b.dq, normal_dx: dot(a.dx - b.dx, c.normal) }
    }

    /// A point's gap now.
    fn gap(&self, p: &ContactPoint) -> Scalar {
        p.gap + self.normal_dx + dot(self.dqa, p.g[0]) - dot(self.dqb, p.g[1])
    }
}

/// A point's normal row.
struct Row {
    mass: Scalar,
    k: Scalar,
    impulse: Scalar,
    bias: Scalar,
    mass_scale: Scalar,
    impulse_scale: Scalar,
    compliance: Scalar,
}

impl Row {
    fn rigid(p: &ContactPoint, bias: Scalar) -> Self {
        Self { mass: p.mass, k: p.k, impulse: p.impulse, bias, mass_scale: 1.0, impulse_scale: 0.0, compliance: 0.0 }
    }

    /// Speculative while the gap is open, soft (solve pass) where it penetrates beyond the
    /// slop, else rigid.
    fn new(p: &ContactPoint, gap: Scalar, c: &Constraint, h: Scalar, soft: Option<Softness>) -> Self {
        let open = gap > 0.0;
        let mut row = Self::rigid(p, if open { gap / h } else { 0.0 });
        if let Some(s) = soft
            && !open
            && gap + c.slop < 0.0
        {
            row.bias = max(s.bias_rate * (gap + c.slop), -c.max_push);
            (row.mass_scale, row.impulse_scale, row.compliance) = (s.mass_scale, s.impulse_scale, s.compliance);
        }
        row
    }

    /// The new accumulated impulse of the row solved alone at relative normal speed `u`.
    fn single(&self, u: Scalar) -> Scalar {
        let dj = -self.mass * self.mass_scale * (u + self.bias) - self.impulse_scale * self.impulse;
        max(self.impulse + dj, 0.0)
    }
}

/// One Gauss–Seidel step for each of two rows.
fn gauss_seidel(p: &Row, q: &Row, up: Scalar, uq: Scalar, m01: Scalar) -> (Scalar, Scalar) {
    let new_p = p.single(up);
    (new_p, q.single(uq + m01 * (new_p - p.impulse)))
}

/// Two rows with coupling `m01` solved as a 2×2 block: the first case that holds of idle
/// (Gauss–Seidel), both apart, both pushing, the first only, the second only, neither, and
/// else Gauss–Seidel.
fn block(p: &Row, q: &Row, up: Scalar, uq: Scalar, m01: Scalar) -> (Scalar, Scalar) {
    if p.mass == 0.0 || q.mass == 0.0 {
        return gauss_seidel(p, q, up, uq, m01);
    }
    let (l0, l1) = (p.impulse, q.impulse);
    let (cp, cq) = (p.compliance * p.k, q.compliance * q.k);
    let (r0, r1) = (up + p.bias + cp * l0, uq + q.bias + cq * l1);
    if l0 == 0.0 && l1 == 0.0 && r0 >= 0.0 && r1 >= 0.0 {
        return (0.0, 0.0);
    }
    let (m00, m11) = (p.k + cp, q.k + cq);
    let det = m00 * m11 - m01 * m01;
    let inv = 1.0 / det;
    let (both0, both1) = (l0 - (m11 * r0 - m01 * r1) * inv, l1 - (m00 * r1 - m01 * r0) * inv);
    if det > 1e-9 * m00 * m11 && both0 >= 0.0 && both1 >= 0.0 {
        return (both0, both1);
    }
    let first = l0 - (r0 - m01 * l1) * (p.mass * p.mass_scale);
    if first >= 0.0 && r1 + m01 * (first - l0) - m11 * l1 >= 0.0 {
        return (first, 0.0);
    }
    let second = l1 - (r1 - m01 * l0) * (q.mass * q.mass_scale);
    if second >= 0.0 && r0 + m01 * (second - l1) - m00 * l0 >= 0.0 {
        return (0.0, second);
    }
    if r0 - m00 * l0 - m01 * l1 >= 0.0 && r1 - m01 * l0 - m11 * l1 >= 0.0 {
        return (0.0, 0.0);
    }
    gauss_seidel(p, q, up, uq, m01)
}

/// Stores a point's new accumulated impulse, and in the relax sweep (`soft` is `None`) the
/// largest so far; returns the change.
fn settle(p: &mut ContactPoint, new: Scalar, soft: Option<Softness>) -> Scalar {
    let change = new - p.impulse;
    p.impulse = new;
    if soft.is_none() {
        p.max_impulse = max(p.max_impulse, new);
    }
    change
}

/// Re-applies every accumulated impulse.
pub(super) fn warm_start(bodies: &mut [SolverBody], pairs: &[PairRows]) {
    for PairRows { constraint: c, points } in pairs {
        let mut e = Ends::open(bodies, c);
        for p in points {
            e.push_normal(p.g, c.inv_mass[0] + c.inv_mass[1], p.impulse);
        }
        e.flush(c);
        let f = &c.friction;
        e.push(c.tangents[0], f.g[0], c, f.impulse[0]);
        e.push(c.tangents[1], f.g[1], c, f.impulse[1]);
        e.wa += f.twist[0] * f.impulse[2];
        e.wb -= f.twist[1] * f.impulse[2];
        e.close(bodies, c);
    }
}

/// One Gauss–Seidel sweep: soft normals (`soft` given), or friction, rigid normals with the
/// pairs of points last to first, and friction again (`None`).
pub(super) fn sweep(bodies: &mut [SolverBody], pairs: &mut [PairRows], h: Scalar, soft: Option<Softness>) {
    for PairRows { constraint: c, points } in pairs {
        let motion = Motion::open(bodies, c);
        let mut e = Ends::open(bodies, c);
        if soft.is_none() {
            friction(&mut e, c, points);
            for pair in points.chunks_mut(2).rev() {
                normal_pair(&mut e, &motion, c, pair, h, soft);
            }
            e.flush(c);
            friction(&mut e, c, points);
        } else {
            for pair in points.chunks_mut(2) {
                normal_pair(&mut e, &motion, c, pair, h, soft);
            }
        }
        e.close(bodies, c);
    }
}

/// The normal rows of two points of a manifold, or of its last one.
fn normal_pair(
    e: &mut Ends,
    motion: &Motion,
    c: &Constraint,
    pair: &mut [ContactPoint],
    h: Scalar,
    soft: Option<Softness>,
) {
    let inv_mass_sum = c.inv_mass[0] + c.inv_mass[1];
    match pair {
        [p, q] => {
            let (rp, rq) = (Row::new(p, motion.gap(p), c, h, soft), Row::new(q, motion.gap(q), c, h, soft));
            let (up, uq) = (e.normal_speed(p.g), e.normal_speed(q.g));
            let (new_p, new_q) = block(&rp, &rq, up, uq, p.coupling);
            let (dp, dq) = (settle(p, new_p, soft), settle(q, new_q, soft));
            e.push_normal(p.g, inv_mass_sum, dp);
            e.push_normal(q.g, inv_mass_sum, dq);
        }
        [p] => {
            let row = Row::new(p, motion.gap(p), c, h, soft);
            let dp = settle(p, row.single(e.normal_speed(p.g)), soft);
            e.push_normal(p.g, inv_mass_sum, dp);
        }
        _ => unreachable!("chunks of two"),
    }
}

/// The pair's friction patch: both tangents within the Coulomb disc, then the twist.
fn friction(e: &mut Ends, c: &mut Constraint, points: &[ContactPoint]) {
    let (mut total, mut moment) = (0.0, 0.0);
    for p in points {
        total += p.impulse;
        moment += p.impulse * p.lever;
    }
    let f = &mut c.friction;
    let dv = e.va - e.vb;
    let s1 = dot(dv, c.tangents[0]) + dot(e.wa, f.g[0][0]) - dot(e.wb, f.g[0][1]);
    let s2 = dot(dv, c.tangents[1]) + dot(e.wa, f.g[1][0]) - dot(e.wb, f.g[1][1]);
    let [m11, m12, m22] = f.mass;
    let (old1, old2) = (f.impulse[0], f.impulse[1]);
    let (mut j1, mut j2) = (old1 - (m11 * s1 + m12 * s2), old2 - (m12 * s1 + m22 * s2));
    let limit = c.mu * total;
    let len2 = j1 * j1 + j2 * j2;
    if len2 > limit * limit {
        let scale = limit / len2.sqrt();
        (j1, j2) = (j1 * scale, j2 * scale);
    }
    (f.impulse[0], f.impulse[1]) = (j1, j2);
    let (g, twist, twist_mass, old) = (f.g, f.twist, f.twist_mass, f.impulse[2]);
    e.push(c.tangents[0], g[0], c, j1 - old1);
    e.push(c.tangents[1], g[1], c, j2 - old2);
    let limit = c.mu * moment;
    let mut jt = old - twist_mass * (dot(e.wa, twist[0]) - dot(e.wb, twist[1]));
    if jt < -limit {
        jt = -limit;
    }
    if jt > limit {
        jt = limit;
    }
    c.friction.impulse[2] = jt;
    e.wa += twist[0] * (jt - old);
    e.wb -= twist[1] * (jt - old);
}

/// Bounces each point that touched and approached faster than `threshold` by an added rigid
/// normal impulse towards `restitution` times its approach; a pair of points that both bounce
/// is solved as a block.
pub(super) fn restitution(bodies: &mut [SolverBody], pairs: &mut [PairRows], threshold: Scalar) {
    for PairRows { constraint: c, points } in pairs {
        let e_n = c.restitution;
        let touch = points.iter().fold(0.0, |m, p| max(m, p.max_impulse)) * TOUCH_SHARE;
        let bounces = |p: &ContactPoint| e_n > 0.0 && p.approach <= -threshold && p.max_impulse > touch;
        if !points.iter().any(bounces) {
            continue;
        }
        let mut e = Ends::open(bodies, c);
        let inv_mass_sum = c.inv_mass[0] + c.inv_mass[1];
        for pair in points.chunks_mut(2) {
            match pair {
                [p, q] => {
                    let (rp, rq) = (Row::rigid(p, e_n * p.approach), Row::rigid(q, e_n * q.approach));
                    let (up, uq) = (e.normal_speed(p.g), e.normal_speed(q.g));
                    let (new_p, new_q) = match (bounces(p), bounces(q)) {
                        (true, true) => block(&rp, &rq, up, uq, p.coupling),
                        (true, false) => (rp.single(up), rq.impulse),
                        (false, true) => (rp.impulse, rq.single(uq)),
                        (false, false) => (rp.impulse, rq.impulse),
                    };
                    let (dp, dq) = (new_p - rp.impulse, new_q - rq.impulse);
                    (p.impulse, q.impulse) = (new_p, new_q);
                    e.push_normal(p.g, inv_mass_sum, dp);
                    e.push_normal(q.g, inv_mass_sum, dq);
                }
                [p] => {
                    let rp = Row::rigid(p, e_n * p.approach);
                    let new = if bounces(p) { rp.single(e.normal_speed(p.g)) } else { rp.impulse };
                    let dp = new - rp.impulse;
                    p.impulse = new;
                    e.push_normal(p.g, inv_mass_sum, dp);
                }
                _ => unreachable!("chunks of two"),
            }
        }
        e.close(bodies, c);
    }
}

#[cfg(test)]
pub(super) mod fill;
#[cfg(test)]
mod tests;
