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

use super::{Constraint, ContactPoint, Softness, SolverBody};
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

/// Stores a point's new accumulated impulse; returns the change.
fn settle(p: &mut ContactPoint, new: Scalar) -> Scalar {
    let change = new - p.impulse;
    p.impulse = new;
    p.max_impulse = max(p.max_impulse, new);
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
            let (dp, dq) = (settle(p, new_p), settle(q, new_q));
            e.push_normal(p.g, inv_mass_sum, dp);
            e.push_normal(q.g, inv_mass_sum, dq);
        }
        [p] => {
            let row = Row::new(p, motion.gap(p), c, h, soft);
            let dp = settle(p, row.single(e.normal_speed(p.g)));
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
        let bounces = |p: &ContactPoint| e_n > 0.0 && p.approach <= -threshold && p.max_impulse > 0.0;
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
mod tests {
    use super::PairRows;
    use crate::math::{Mat3, Quat, Scalar, Vector};
    use crate::solver::constraints::{couple_pairs, friction_patch, place_group, tangents};
    use crate::solver::{
        Constraint, ConstraintGroup, ContactPoint, Friction, HeldPair, Softness, SolverBody, kernel, reference,
    };
    use proptest::prelude::*;
    use proptest::sample::Index;

    /// The kernel's copy of `pairs`: placed in batches by the solver's own `place_group` (and
    /// so `place`), each constraint and point written into its lane as `fill` writes them.
    fn lay_out(pairs: &[PairRows], static_slot: u32) -> ConstraintGroup {
        let mut group = ConstraintGroup { static_slot, ..ConstraintGroup::default() };
        group.slots.extend(pairs.iter().map(|p| p.constraint.slot));
        let held: Vec<HeldPair> = pairs
            .iter()
            .map(|p| HeldPair { pair: 0, group: 0, batch: 0, lane: 0, len: p.points.len() as u8 })
            .collect();
        place_group(&held, 0, &mut group);
        for (pair, &(batch, lane)) in pairs.iter().zip(&group.placed) {
            let batch = &mut group.batches[batch as usize];
            batch.set(usize::from(lane), &pair.constraint);
            for (j, point) in pair.points.iter().enumerate() {
                group.points[batch.first as usize + j].set(usize::from(lane), point);
            }
        }
        group
    }

    /// One pass (or body step) of a substep plan, run on both solvers.
    #[derive(Clone, Copy, Debug)]
    enum Step {
        Warm,
        Solve,
        Move,
        Relax,
        Restitution,
    }

    /// Two substeps as `solve` plans them (two solve sweeps in the first; gravity's pushes left
    /// out), then restitution.
    const PLAN: [Step; 10] = {
        use Step::*;
        [Warm, Solve, Solve, Move, Relax, Warm, Solve, Move, Relax, Restitution]
    };

    /// Runs `step` on the kernel's batches and on the reference's pairs.
    fn run(
        step: Step,
        kernel_side: (&mut [SolverBody], &mut ConstraintGroup),
        reference_side: (&mut [SolverBody], &mut [PairRows]),
        h: Scalar,
        threshold: Scalar,
    ) {
        let ((kb, group), (rb, pairs)) = (kernel_side, reference_side);
        let soft = Softness::new(h);
        match step {
            Step::Warm => {
                kernel::warm_start(kb, &group.batches, &mut group.points);
                reference::warm_start(rb, pairs);
            }
            Step::Solve => {
                kernel::sweep(kb, &mut group.batches, &mut group.points, h, Some(soft));
                reference::sweep(rb, pairs, h, Some(soft));
            }
            Step::Relax => {
                kernel::sweep(kb, &mut group.batches, &mut group.points, h, None);
                reference::sweep(rb, pairs, h, None);
            }
            Step::Restitution => {
                kernel::restitution(kb, &group.batches, &mut group.points, threshold);
                reference::restitution(rb, pairs, threshold);
            }
            Step::Move => {
                for bodies in [kb, rb] {
                    let free = bodies.len() - 1;
                    for b in &mut bodies[..free] {
                        b.dx += b.v * h;
                        b.dq += b.w * h;
                    }
                }
            }
        }
    }

    /// Where the kernel's and the reference's results differ in any bit: every body's
    /// velocities, every point's accumulated and largest impulses, every friction impulse, and
    /// the idle points of a batch (a lane's beyond its own count), which must stay zero.
    fn differences(kb: &[SolverBody], group: &ConstraintGroup, rb: &[SolverBody], pairs: &[PairRows]) -> Vec<String> {
        let mut out = Vec::new();
        let mut same = |what: String, k: Scalar, r: Scalar| {
            if k.to_bits() != r.to_bits() {
                out.push(format!("{what}: kernel {k:e}, reference {r:e}"));
            }
        };
        for (slot, (k, r)) in kb.iter().zip(rb).enumerate() {
            for axis in 0..3 {
                same(format!("body {slot} v[{axis}]"), k.v[axis], r.v[axis]);
                same(format!("body {slot} w[{axis}]"), k.w[axis], r.w[axis]);
            }
        }
        for (i, (pair, &(batch, lane))) in pairs.iter().zip(&group.placed).enumerate() {
            let (batch, lane) = (&group.batches[batch as usize], usize::from(lane));
            for k in 0..3 {
                same(
                    format!("pair {i} friction impulse {k}"),
                    batch.friction.impulse[k][lane],
                    pair.constraint.friction.impulse[k],
                );
            }
            for j in 0..batch.len as usize {
                let kernel = group.points[batch.first as usize + j].get(lane);
                let reference = pair.points.get(j).copied().unwrap_or(ContactPoint::IDLE);
                same(format!("pair {i} point {j} impulse"), kernel.impulse, reference.impulse);
                same(format!("pair {i} point {j} max impulse"), kernel.max_impulse, reference.max_impulse);
            }
        }
        out
    }

    fn vector(range: Scalar) -> impl Strategy<Value = Vector> {
        (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vector::new(x, y, z))
    }

    fn unit() -> impl Strategy<Value = Vector> {
        vector(1.0).prop_filter("a direction", |n| n.length() > 0.1).prop_map(Vector::normalize)
    }

    fn rotation() -> impl Strategy<Value = Quat> {
        (unit(), -3.0..3.0f64).prop_map(|(axis, angle)| Quat::from_axis_angle(axis, angle))
    }

    /// A free body: mass, principal moments and axes, position, and its solver state.
    #[derive(Clone, Debug)]
    struct BodySpec {
        mass: Scalar,
        moments: Vector,
        axes: Quat,
        position: Vector,
        state: SolverBody,
    }

    fn body() -> impl Strategy<Value = BodySpec> {
        let moments = (0.05..5.0f64, 0.05..5.0f64, 0.05..5.0f64).prop_map(|(a, b, c)| Vector::new(a, b, c));
        let state = (vector(3.0), vector(3.0), vector(0.02), vector(0.02)).prop_map(|(v, w, dx, dq)| SolverBody {
            v,
            w,
            dx,
            dq,
        });
        (0.2..5.0f64, moments, rotation(), vector(2.0), state)
            .prop_map(|(mass, moments, axes, position, state)| BodySpec { mass, moments, axes, position, state })
    }

    /// A manifold point: its offset from the pair's centre, gap, approach speed and warm start.
    #[derive(Clone, Debug)]
    struct PointSpec {
        offset: Vector,
        gap: Scalar,
        approach: Scalar,
        impulse: Scalar,
    }

    fn point() -> impl Strategy<Value = PointSpec> {
        (vector(0.5), -0.06..0.03f64, -4.0..1.0f64, prop_oneof![Just(0.0), 0.0..3.0f64])
            .prop_map(|(offset, gap, approach, impulse)| PointSpec { offset, gap, approach, impulse })
    }

    /// A held pair: its two bodies (`ground` 0: B is the static slot, 1: A is, else both free
    /// when there are two bodies), normal, centre, points, material and friction warm start.
    #[derive(Clone, Debug)]
    struct PairSpec {
        a: Index,
        b: Index,
        ground: u8,
        normal: Vector,
        centre: Vector,
        points: Vec<PointSpec>,
        mu: Scalar,
        friction: [Scalar; 3],
        restitution: Scalar,
        slop: Scalar,
        max_push: Scalar,
    }

    fn pair() -> impl Strategy<Value = PairSpec> {
        let material = (
            prop_oneof![Just(0.0), 0.05..1.2f64],
            (-0.5..0.5f64, -0.5..0.5f64, -0.2..0.2f64),
            prop_oneof![Just(0.0), 0.1..0.9f64],
            0.0..0.01f64,
            0.05..3.0f64,
        );
        (
            any::<Index>(),
            any::<Index>(),
            0..4u8,
            unit(),
            vector(2.0),
            proptest::collection::vec(point(), 1..=4),
            material,
        )
            .prop_map(
                |(a, b, ground, normal, centre, points, (mu, (t1, t2, tw), restitution, slop, max_push))| PairSpec {
                    a,
                    b,
                    ground,
                    normal,
                    centre,
                    points,
                    mu,
                    friction: [t1, t2, tw],
                    restitution,
                    slop,
                    max_push,
                },
            )
    }

    /// The solver bodies (the static slot last) and the pairs' rows, built as
    /// `build_constraints` builds them: g = S (r × n) with S = (I⁻¹)^½, effective masses,
    /// couplings, friction patches; then the warm-start impulses.
    fn build(bodies: &[BodySpec], specs: &[PairSpec], h: Scalar) -> (Vec<SolverBody>, Vec<PairRows>) {
        let static_slot = bodies.len();
        let mut solver_bodies: Vec<SolverBody> = bodies.iter().map(|b| b.state).collect();
        solver_bodies.push(SolverBody::default());
        let scale_of = |i: usize| {
            bodies.get(i).map_or(Mat3::ZERO, |b| {
                let r = Mat3::from_quat(b.axes);
                r * Mat3::from_diagonal(b.moments.map(|m| 1.0 / m.sqrt())) * r.transpose()
            })
        };
        let inv_mass_of = |i: usize| bodies.get(i).map_or(0.0, |b| 1.0 / b.mass);
        let position_of = |i: usize| bodies.get(i).map_or(Vector::ZERO, |b| b.position);
        let compliance = Softness::new(h).compliance;
        let pairs = specs
            .iter()
            .map(|s| {
                let a = s.a.index(bodies.len());
                let other = if bodies.len() > 1 { (a + 1 + s.b.index(bodies.len() - 1)) % bodies.len() } else { a };
                let slot = match s.ground {
                    0 => [a, static_slot],
                    1 => [static_slot, a],
                    _ if bodies.len() > 1 => [a, other],
                    _ => [a, static_slot],
                };
                let (n, inv_mass, scale, position) =
                    (s.normal, slot.map(inv_mass_of), slot.map(scale_of), slot.map(position_of));
                let mut points: Vec<ContactPoint> = s
                    .points
                    .iter()
                    .map(|p| {
                        let at = s.centre + p.offset;
                        let g = [0, 1].map(|end| scale[end] * (at - position[end]).cross(n));
                        let k = inv_mass[0] + inv_mass[1] + g[0].length_squared() + g[1].length_squared();
                        ContactPoint {
                            g,
                            mass: 1.0 / k,
                            k,
                            impulse: p.impulse,
                            gap: p.gap,
                            approach: p.approach,
                            ..ContactPoint::IDLE
                        }
                    })
                    .collect();
                couple_pairs(&mut points, inv_mass, compliance);
                let centre = s.points.iter().map(|p| s.centre + p.offset).sum::<Vector>() / s.points.len() as Scalar;
                for (point, spec) in points.iter_mut().zip(&s.points) {
                    point.lever = (s.centre + spec.offset - centre).length();
                }
                let tangents = tangents(n);
                let friction = if s.mu > 0.0 {
                    let patch = friction_patch(centre, position, n, tangents, inv_mass, scale, None);
                    Friction { impulse: s.friction, ..patch }
                } else {
                    Friction::IDLE
                };
                let constraint = Constraint {
                    slot: slot.map(|i| i as u32),
                    normal: n,
                    tangents,
                    inv_mass,
                    mu: s.mu,
                    restitution: s.restitution,
                    slop: s.slop,
                    max_push: s.max_push,
                    friction,
                };
                PairRows { constraint, points }
            })
            .collect();
        (solver_bodies, pairs)
    }

    /// Runs `PLAN` on both solvers from the same start; the first pass after which they differ
    /// and how, if any.
    fn compare(bodies: &[BodySpec], specs: &[PairSpec], h: Scalar, threshold: Scalar) -> Result<(), String> {
        let (mut rb, mut pairs) = build(bodies, specs, h);
        let mut kb = rb.clone();
        let mut group = lay_out(&pairs, bodies.len() as u32);
        for (k, step) in PLAN.into_iter().enumerate() {
            run(step, (&mut kb, &mut group), (&mut rb, &mut pairs), h, threshold);
            let diff = differences(&kb, &group, &rb, &pairs);
            if !diff.is_empty() {
                return Err(format!(
                    "after step {k} ({step:?}), {} differences: {:#?}",
                    diff.len(),
                    &diff[..diff.len().min(8)]
                ));
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The four-lane kernel, on random constraints placed in batches as the solver places
        /// them, gives the bits of the plain one-at-a-time reference: every pass of two
        /// substeps and restitution, soft, speculative and rigid rows, blocks and single
        /// points, friction, bodies shared between constraints and the static slot.
        #[test]
        fn the_kernel_gives_the_bits_of_solving_the_constraints_one_at_a_time(
            bodies in proptest::collection::vec(body(), 1..9),
            pairs in proptest::collection::vec(pair(), 1..20),
            h in 1.0 / 480.0..1.0 / 60.0f64,
            threshold in 0.3..2.0f64,
        ) {
            let result = compare(&bodies, &pairs, h, threshold);
            prop_assert!(result.is_ok(), "{}", result.unwrap_err());
        }
    }

    /// A lone body, mass 2, and the static slot under it; one point on the normal through its
    /// centre (no lever), so K = 1/m and one rigid row stops the body.
    fn falling_body(v: Scalar, gap: Scalar) -> (Vec<SolverBody>, Vec<PairRows>) {
        let body = SolverBody { v: Vector::new(0.0, v, 0.0), ..SolverBody::default() };
        let point = ContactPoint { mass: 2.0, k: 0.5, gap, ..ContactPoint::IDLE };
        let constraint = Constraint { slot: [0, 1], inv_mass: [0.5, 0.0], ..Constraint::idle(1) };
        (vec![body, SolverBody::default()], vec![PairRows { constraint, points: vec![point] }])
    }

    /// Runs one relax sweep (rigid rows) of substep `h` on both solvers; returns each one's
    /// body velocity and point impulse.
    fn relax_both(bodies: &[SolverBody], pairs: &[PairRows], h: Scalar) -> [(Vector, Scalar); 2] {
        let (mut kb, mut rb, mut pairs) = (bodies.to_vec(), bodies.to_vec(), pairs.to_vec());
        let mut group = lay_out(&pairs, bodies.len() as u32 - 1);
        run(Step::Relax, (&mut kb, &mut group), (&mut rb, &mut pairs), h, 1.0);
        [(kb[0].v, group.points[0].impulse[0]), (rb[0].v, pairs[0].points[0].impulse)]
    }

    #[test]
    fn a_body_landing_on_the_static_slot_takes_m_v_and_stops() {
        let (bodies, pairs) = falling_body(-3.0, 0.0);
        for (v, impulse) in relax_both(&bodies, &pairs, 1.0 / 240.0) {
            assert_eq!(impulse, 6.0, "m v = 2 kg · 3 m/s");
            assert_eq!(v, Vector::ZERO);
        }
    }

    #[test]
    fn an_open_gap_lets_a_body_close_it_in_one_substep_and_no_faster() {
        // Gap 0.25 m, substep 0.125 s: the row allows 2 m/s of approach.
        let (bodies, pairs) = falling_body(-3.0, 0.25);
        for (v, impulse) in relax_both(&bodies, &pairs, 0.125) {
            assert_eq!(impulse, 2.0, "2 kg · (3 − 2) m/s");
            assert_eq!(v, Vector::new(0.0, -2.0, 0.0));
        }
        let (bodies, pairs) = falling_body(-1.0, 0.25);
        for (v, impulse) in relax_both(&bodies, &pairs, 0.125) {
            assert_eq!(impulse, 0.0, "slower than the gap allows: no impulse");
            assert_eq!(v, Vector::new(0.0, -1.0, 0.0));
        }
    }

    #[test]
    fn a_box_landing_flat_on_two_corners_stops_without_spin() {
        // Mass 1, S = identity, corners at r = (±1, −1, 0) from the centre, normal +y: g = r × n
        // = (0, 0, ±1), K₀₀ = K₁₁ = 2, K₀₁ = 1 − 1 = 0, det K = 4. The block gives each corner
        // half of m v; one Gauss–Seidel sweep would leave the box spinning.
        let n = Vector::Y;
        let corner = |x: Scalar| {
            let g = [Vector::new(x, -1.0, 0.0).cross(n), Vector::ZERO];
            ContactPoint { g, mass: 0.5, k: 2.0, ..ContactPoint::IDLE }
        };
        let mut points = vec![corner(1.0), corner(-1.0)];
        couple_pairs(&mut points, [1.0, 0.0], Softness::new(0.01).compliance);
        assert_eq!((points[0].coupling, points[0].inv_det[0]), (0.0, 0.25));
        let constraint = Constraint { slot: [0, 1], inv_mass: [1.0, 0.0], ..Constraint::idle(1) };
        let body = SolverBody { v: Vector::new(0.0, -4.0, 0.0), ..SolverBody::default() };
        let bodies = [body, SolverBody::default()];
        let pairs = [PairRows { constraint, points }];
        let (mut kb, mut rb, mut reference_pairs) = (bodies.to_vec(), bodies.to_vec(), pairs.to_vec());
        let mut group = lay_out(&pairs, 1);
        run(Step::Relax, (&mut kb, &mut group), (&mut rb, &mut reference_pairs), 0.01, 1.0);
        let kernel_impulses = [group.points[0].impulse[0], group.points[1].impulse[0]];
        let reference_impulses = reference_pairs[0].points.iter().map(|p| p.impulse).collect::<Vec<_>>();
        for (b, impulses) in [(kb[0], kernel_impulses.to_vec()), (rb[0], reference_impulses)] {
            assert_eq!(impulses, [2.0, 2.0]);
            assert_eq!((b.v, b.w), (Vector::ZERO, Vector::ZERO));
        }
    }
}
