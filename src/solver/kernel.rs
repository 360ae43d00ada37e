//! The substep passes over the batches: warm start, the solve and relax sweeps, restitution.
//! Each works on a batch's four lanes at once, in `f64x4` registers (`Reg`: one AVX instruction
//! per operation on the project's machines, two SSE2 ones elsewhere); per lane the arithmetic
//! is that of solving the constraint alone, in the order the `solve` system gave, operation for
//! operation, so the lanes and a one-by-one solve give the same bits (the tests of `reference`
//! check it). Where a row's case depends on its lane (speculative, pushed or rigid; which rows
//! of a block push), every case is computed and the lane's own selected: no branch on one lane
//! holds up the other three. The only branches ask whether any lane of the batch needs a costly
//! step (a division, a root, a block's rarer cases) and skip it when none does.

use super::lanes::{Batch, LaneVectors, Lanes, PointRows};
use super::{BodyStore, LANES, Softness, TOUCH_SHARE};
use crate::math::Scalar;
use wide::f64x4;

const _: () = assert!(LANES == 4, "the kernel's registers hold four lanes");

/// Four f64 lanes in one register: one value per lane of a batch.
type Reg = f64x4;

/// Loads one value per lane into a register.
#[inline(always)]
fn load(lanes: &Lanes) -> Reg {
    Reg::new(*lanes)
}

/// One vector per lane, a register per component.
#[derive(Clone, Copy)]
struct RegVec {
    x: Reg,
    y: Reg,
    z: Reg,
}

impl RegVec {
    /// Loads one vector per lane.
    #[inline(always)]
    fn load(w: &LaneVectors) -> Self {
        Self { x: load(&w.x), y: load(&w.y), z: load(&w.z) }
    }

    #[inline(always)]
    fn dot(self, o: Self) -> Reg {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// `self − o`.
    #[inline(always)]
    fn minus(self, o: Self) -> Self {
        Self { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }

    /// `self += o · s`.
    #[inline(always)]
    fn add_scaled(&mut self, o: Self, s: Reg) {
        self.x += o.x * s;
        self.y += o.y * s;
        self.z += o.z * s;
    }

    /// `self -= o · s`.
    #[inline(always)]
    fn sub_scaled(&mut self, o: Self, s: Reg) {
        self.x -= o.x * s;
        self.y -= o.y * s;
        self.z -= o.z * s;
    }
}

/// The velocities of each lane's two bodies (A, B) while a batch is solved: loaded by `open`,
/// written back by `close`.
#[derive(Clone, Copy)]
struct LaneBodies {
    va: RegVec,
    wa: RegVec,
    vb: RegVec,
    wb: RegVec,
    /// (v_a − v_b)·n, kept up to date by `push_normal`: the normal rows' linear part.
    u: Reg,
    /// Normal impulse applied to `u` and the spins but not yet to the linear velocities
    /// (`flush`): a normal row's linear part is the same for every point of a pair, so it is
    /// kept as one number until something else needs the velocities.
    pending: Reg,
}

/// How far the substeps have moved each lane's bodies: what the passes that read gaps need.
#[derive(Clone, Copy)]
struct Motion {
    dqa: RegVec,
    dqb: RegVec,
    /// (dx_a − dx_b)·n: the bodies' relative displacement along the normal.
    normal_dx: Reg,
}

/// The lanes' (A, B) bodies' `N` fields picked by `pick`, as register vectors (`[end][field]`):
/// one look-up of each slot serves every field, so each slot is bounds-checked once.
#[inline(always)]
fn gather<B: BodyStore + ?Sized, const N: usize>(
    bodies: &B,
    batch: &Batch,
    pick: impl Fn(&super::SolverBody) -> [crate::math::Vector; N],
) -> [[RegVec; N]; 2] {
    let mut out = [[[[0.0; LANES]; 3]; N]; 2];
    for end in 0..2 {
        for l in 0..LANES {
            for (field, v) in pick(bodies.body(batch.slot[end][l])).into_iter().enumerate() {
                (out[end][field][0][l], out[end][field][1][l], out[end][field][2][l]) = (v.x, v.y, v.z);
            }
        }
    }
    out.map(|e| e.map(|[x, y, z]| RegVec { x: Reg::new(x), y: Reg::new(y), z: Reg::new(z) }))
}

/// The lanes' velocities and motion of a batch in one gather (a sweep that works the gaps out).
#[inline(always)]
fn open_moved<B: BodyStore + ?Sized>(bodies: &B, batch: &Batch) -> (Motion, LaneBodies) {
    let [[va, wa, xa, dqa], [vb, wb, xb, dqb]] = gather(bodies, batch, |b| [b.v, b.w, b.dx, b.dq]);
    (Motion::new(xa, xb, dqa, dqb, batch), LaneBodies::new(va, wa, vb, wb, batch))
}

impl LaneBodies {
    /// Loads the velocities of the bodies of a batch's lanes.
    #[inline(always)]
    fn open<B: BodyStore + ?Sized>(bodies: &B, batch: &Batch) -> Self {
        let [[va, wa], [vb, wb]] = gather(bodies, batch, |b| [b.v, b.w]);
        Self::new(va, wa, vb, wb, batch)
    }

    #[inline(always)]
    fn new(va: RegVec, wa: RegVec, vb: RegVec, wb: RegVec, batch: &Batch) -> Self {
        let u = va.minus(vb).dot(RegVec::load(&batch.normal));
        Self { va, wa, vb, wb, u, pending: Reg::ZERO }
    }

    /// Writes the velocities back, except into a static slot, which must stay zero and whose
    /// writes would chain every ground contact to the one before.
    #[inline(always)]
    fn close<B: BodyStore + ?Sized>(&mut self, bodies: &mut B, batch: &Batch) {
        self.flush(batch);
        let arrays = |v: RegVec| [v.x.to_array(), v.y.to_array(), v.z.to_array()];
        let ends = [(arrays(self.va), arrays(self.wa)), (arrays(self.vb), arrays(self.wb))];
        for (end, (v, w)) in ends.iter().enumerate() {
            for l in 0..LANES {
                if let Some(body) = bodies.moving_mut(batch.slot[end][l]) {
                    body.v = crate::math::Vector::new(v[0][l], v[1][l], v[2][l]);
                    body.w = crate::math::Vector::new(w[0][l], w[1][l], w[2][l]);
                }
            }
        }
    }

    /// Applies the pending normal impulses to the linear velocities.
    #[inline(always)]
    fn flush(&mut self, batch: &Batch) {
        let n = RegVec::load(&batch.normal);
        let (sa, sb) = (self.pending * load(&batch.inv_mass[0]), self.pending * load(&batch.inv_mass[1]));
        self.va.add_scaled(n, sa);
        self.vb.sub_scaled(n, sb);
        self.pending = Reg::ZERO;
    }

    /// Relative normal speeds of A against B at points with scaled levers `g`.
    #[inline(always)]
    fn normal_speed(&self, g: &[LaneVectors; 2]) -> Reg {
        with_levers(self.u, (self.wa, self.wb), g)
    }

    /// Normal impulses `j` at points with scaled levers `g`; `inv_mass_sum` is m_a⁻¹ + m_b⁻¹.
    #[inline(always)]
    fn push_normal(&mut self, g: &[LaneVectors; 2], inv_mass_sum: Reg, j: Reg) {
        self.wa.add_scaled(RegVec::load(&g[0]), j);
        self.wb.sub_scaled(RegVec::load(&g[1]), j);
        self.u += j * inv_mass_sum;
        self.pending += j;
    }

    /// Impulses `j` along `d` at the points with scaled levers `g`: +j on A, −j on B.
    #[inline(always)]
    fn push(&mut self, d: &LaneVectors, g: &[LaneVectors; 2], batch: &Batch, j: Reg) {
        let (sa, sb) = (j * load(&batch.inv_mass[0]), j * load(&batch.inv_mass[1]));
        let d = RegVec::load(d);
        self.va.add_scaled(d, sa);
        self.wa.add_scaled(RegVec::load(&g[0]), j);
        self.vb.sub_scaled(d, sb);
        self.wb.sub_scaled(RegVec::load(&g[1]), j);
    }
}

impl Motion {
    /// How far the substeps have moved the bodies of a batch's lanes, from their
    /// displacements `xa`, `xb` and turns `dqa`, `dqb`.
    #[inline(always)]
    fn new(xa: RegVec, xb: RegVec, dqa: RegVec, dqb: RegVec, batch: &Batch) -> Self {
        let normal_dx = xa.minus(xb).dot(RegVec::load(&batch.normal));
        Self { dqa, dqb, normal_dx }
    }

    /// The gaps of points with scaled levers `g` and starting gaps `gap`, moved on by the
    /// substeps' displacements.
    #[inline(always)]
    fn gap(&self, g: &[LaneVectors; 2], gap: &Lanes) -> Reg {
        with_levers(load(gap) + self.normal_dx, (self.dqa, self.dqb), g)
    }
}

/// A batch's points.
#[inline(always)]
fn points_of<'a>(batch: &Batch, points: &'a mut [PointRows]) -> &'a mut [PointRows] {
    &mut points[batch.rows()]
}

/// Re-applies each row's accumulated impulse (the previous substep's, or the previous step's
/// at the first substep): a resting stack starts each substep near its solution. `solve` runs
/// it at the first substep only, unless there are joints; later substeps do the same body by
/// body (`drive::Step::Repeat`).
pub fn warm_start<B: BodyStore + ?Sized>(bodies: &mut B, batches: &[Batch], points: &mut [PointRows]) {
    for batch in batches {
        if batch.quiet && no_impulse(batch, points_of(batch, points)) {
            continue; // it would push nothing
        }
        let mut lane_bodies = LaneBodies::open(bodies, batch);
        let inv_mass_sum = load(&batch.inv_mass_sum);
        for p in points_of(batch, points).iter() {
            lane_bodies.push_normal(&p.g, inv_mass_sum, load(&p.impulse));
        }
        lane_bodies.flush(batch);
        let f = &batch.friction;
        lane_bodies.push(&batch.tangents[0], &f.g[0], batch, load(&f.impulse[0]));
        lane_bodies.push(&batch.tangents[1], &f.g[1], batch, load(&f.impulse[1]));
        lane_bodies.wa.add_scaled(RegVec::load(&f.twist[0]), load(&f.impulse[2]));
        lane_bodies.wb.sub_scaled(RegVec::load(&f.twist[1]), load(&f.impulse[2]));
        lane_bodies.close(bodies, batch);
    }
}

/// One Gauss–Seidel sweep through the batches in order (the `solve` system orders the
/// constraints lowest first, so one sweep carries a stack's support from the ground up).
///
/// The points' gaps change only when the substeps move the bodies on: with `fresh` the sweep
/// works them out from the bodies' displacements and keeps them (`PointRows::now`), else it
/// reads those kept by the last fresh sweep, the same numbers without gathering the motion.
///
/// The solve pass (`soft` given) holds the normals with soft position feedback; the relax
/// pass (`None`) solves friction, holds the normals rigidly, taking a manifold's pairs of
/// points in reverse order (so neither end of a manifold is always first), and solves friction
/// again. Friction only in the relax pass (rapier's "no friction when applying bias"): friction
/// reacting to the push-out velocities pumps a tall stack's lean.
pub fn sweep<B: BodyStore + ?Sized>(
    bodies: &mut B,
    batches: &mut [Batch],
    points: &mut [PointRows],
    h: Scalar,
    soft: Option<Softness>,
    fresh: bool,
) {
    for batch in batches {
        let (motion, mut lane_bodies) = if fresh {
            let (motion, lane_bodies) = open_moved(bodies, batch);
            (Some(motion), lane_bodies)
        } else {
            (None, LaneBodies::open(bodies, batch))
        };
        let motion = motion.as_ref();
        let batch_points = points_of(batch, points);
        if batch.quiet && stays_quiet(&lane_bodies, motion, batch, batch_points, (h, soft)) {
            continue;
        }
        // Points go in pairs (0, 1), (2, 3): a manifold's diagonals (`manifold::reduce`).
        if soft.is_none() {
            // Friction before the normal rows as well as after: friction at the contact plane
            // turns a body it stops (a block on a slope starts to roll), the normal rows then
            // take that roll back at the corners, and the second friction solve stops the slip
            // that remains. With friction after the normal rows only, a block on a slope just
            // short of slipping creeps until the warm start catches up.
            friction(&mut lane_bodies, batch, batch_points);
            for pair in batch_points.chunks_mut(2).rev() {
                normal_pair::<true>(&mut lane_bodies, motion, batch, pair, h, None);
            }
            lane_bodies.flush(batch);
            friction(&mut lane_bodies, batch, batch_points);
        } else {
            for pair in batch_points.chunks_mut(2) {
                normal_pair::<false>(&mut lane_bodies, motion, batch, pair, h, soft);
            }
        }
        lane_bodies.close(bodies, batch);
    }
}

/// True when no lane of `batch` holds an impulse, normal or friction.
#[inline(always)]
fn no_impulse(batch: &Batch, batch_points: &[PointRows]) -> bool {
    let zero = |lanes: &Lanes| load(lanes).simd_eq(Reg::ZERO);
    let f = &batch.friction.impulse;
    let none = zero(&f[0]) & zero(&f[1]) & zero(&f[2]);
    batch_points.iter().fold(none, |none, p| none & zero(&p.impulse)).all()
}

/// True when a sweep would leave a quiet batch (`Batch::quiet`) as it is: no lane holds an
/// impulse and every normal row is satisfied, u + b ≥ 0. `block` then finds each pair of rows
/// apart, a single row's step is not positive, and friction, bounded by the normal impulses
/// (before the normal rows as after), stays at zero, so nothing pushes the bodies. The gaps
/// are worked out (and kept) as the sweep would.
#[inline(always)]
fn stays_quiet(
    lane_bodies: &LaneBodies,
    motion: Option<&Motion>,
    batch: &Batch,
    batch_points: &mut [PointRows],
    (h, soft): (Scalar, Option<Softness>),
) -> bool {
    if !no_impulse(batch, batch_points) {
        return false;
    }
    let mut satisfied = true;
    for p in batch_points.iter_mut() {
        let gap = gap_now(p, motion);
        let bias = NormalRows::new(p, gap, batch, h, soft).bias;
        satisfied &= (lane_bodies.normal_speed(&p.g) + bias).simd_ge(Reg::ZERO).all();
    }
    satisfied
}

/// The gaps of point `p` now: worked out from `motion` and kept, or as last kept.
#[inline(always)]
fn gap_now(p: &mut PointRows, motion: Option<&Motion>) -> Reg {
    match motion {
        Some(motion) => {
            let gap = motion.gap(&p.g, &p.gap);
            p.now = gap.to_array();
            gap
        }
        None => load(&p.now),
    }
}

/// The normal rows of a pair of points (or a last single one) of each lane; `RIGID`: every
/// row is rigid (the relax pass, `soft` is `None`), see `block`.
#[inline(always)]
fn normal_pair<const RIGID: bool>(
    lane_bodies: &mut LaneBodies,
    motion: Option<&Motion>,
    batch: &Batch,
    pair: &mut [PointRows],
    h: Scalar,
    soft: Option<Softness>,
) {
    let inv_mass_sum = load(&batch.inv_mass_sum);
    match pair {
        [p, q] => {
            let (gp, gq) = (gap_now(p, motion), gap_now(q, motion));
            let (rp, rq) = (NormalRows::new(p, gp, batch, h, soft), NormalRows::new(q, gq, batch, h, soft));
            let (up, uq) = (lane_bodies.normal_speed(&p.g), lane_bodies.normal_speed(&q.g));
            let (new_p, new_q) = block::<RIGID>(&rp, &rq, up, uq, (load(&p.coupling), p.inv_det.map(|d| load(&d))));
            let (dp, dq) = (settle::<RIGID>(p, new_p), settle::<RIGID>(q, new_q));
            lane_bodies.push_normal(&p.g, inv_mass_sum, dp);
            lane_bodies.push_normal(&q.g, inv_mass_sum, dq);
        }
        [p] => {
            let gap = gap_now(p, motion);
            let row = NormalRows::new(p, gap, batch, h, soft);
            let dp = settle::<RIGID>(p, row.single::<RIGID>(lane_bodies.normal_speed(&p.g)));
            lane_bodies.push_normal(&p.g, inv_mass_sum, dp);
        }
        _ => {}
    }
}

/// Stores a point's new accumulated impulses `new`, and with `RIGID` (the relax sweep, which
/// ends a substep) the largest so far; returns the change, the impulse still to apply.
#[inline(always)]
fn settle<const RIGID: bool>(p: &mut PointRows, new: Reg) -> Reg {
    let change = new - load(&p.impulse);
    p.impulse = new.to_array();
    if RIGID {
        p.max_impulse = load(&p.max_impulse).max(new).to_array();
    }
    change
}

/// The normal rows of one point of every lane.
#[derive(Clone, Copy)]
struct NormalRows {
    /// Effective mass m and K_ii = 1/m.
    mass: Reg,
    k: Reg,
    /// Accumulated impulse λ.
    impulse: Reg,
    /// Velocity bias b: u + b ≥ 0 is the target.
    bias: Reg,
    /// The soft step's mass and impulse scales (1, 0 when rigid): its update
    /// Δλ = −m s_m (u + b) − s_i λ is a Gauss–Seidel step on the compliant row
    /// u + b + C λ = 0 with C = K_ii s_i / s_m, whose diagonal K_ii + C has inverse m s_m.
    mass_scale: Reg,
    impulse_scale: Reg,
    /// s_i / s_m (0 when rigid).
    compliance: Reg,
}

impl NormalRows {
    /// The rows of `point`, whose gaps are `gap` now.
    ///
    /// A gap still open may close within this substep (speculative contact, u ≥ −gap/h); a
    /// penetration beyond the slop is pushed out by the soft spring in the solve pass, never
    /// faster than `max_push`, and not at all in the relax pass, which takes the push-out
    /// velocity back; otherwise the row is rigid.
    #[inline(always)]
    fn new(point: &PointRows, gap: Reg, batch: &Batch, h: Scalar, soft: Option<Softness>) -> Self {
        // Divisions are the kernel's slowest operations: only where a lane needs one.
        let open = gap.simd_gt(Reg::ZERO);
        let speculative = if open.any() { open.select(gap / Reg::splat(h), Reg::ZERO) } else { Reg::ZERO };
        let rigid = Self::rigid(point, speculative);
        let Some(s) = soft else { return rigid };
        let slop = load(&batch.slop);
        let pushed = !open & (gap + slop).simd_lt(Reg::ZERO);
        let push = (Reg::splat(s.bias_rate) * (gap + slop)).max(-load(&batch.max_push));
        Self {
            bias: pushed.select(push, rigid.bias),
            mass_scale: pushed.select(Reg::splat(s.mass_scale), rigid.mass_scale),
            impulse_scale: pushed.select(Reg::splat(s.impulse_scale), rigid.impulse_scale),
            compliance: pushed.select(Reg::splat(s.compliance), rigid.compliance),
            ..rigid
        }
    }

    /// The rows of `point` held rigidly with velocity bias `bias`.
    #[inline(always)]
    fn rigid(point: &PointRows, bias: Reg) -> Self {
        Self {
            mass: load(&point.mass),
            k: load(&point.k),
            impulse: load(&point.impulse),
            bias,
            mass_scale: Reg::ONE,
            impulse_scale: Reg::ZERO,
            compliance: Reg::ZERO,
        }
    }

    /// Each row's new impulse solved alone, from relative normal speeds `u`; `RIGID`: the
    /// rows are rigid (`Self::rigid`), whose scales are exactly 1 and 0, so the soft terms are
    /// left out and the result is the same to the bit.
    #[inline(always)]
    fn single<const RIGID: bool>(&self, u: Reg) -> Reg {
        let dj = if RIGID {
            -self.mass * (u + self.bias)
        } else {
            -self.mass * self.mass_scale * (u + self.bias) - self.impulse_scale * self.impulse
        };
        (self.impulse + dj).max(Reg::ZERO)
    }
}

/// Two normal rows of one manifold solved together, from their relative speeds `up`, `uq` and
/// coupling K₀₁: the 2×2 linear complementarity problem (K + C) Δλ = −(u + b + C λ),
/// λ + Δλ ≥ 0, by trying which rows push (Box2D v2's block solver, here over a manifold's
/// diagonals, whose rows fight each other: pushing one corner tips the body away from the
/// opposite one, so one Gauss–Seidel sweep of the four corners of a box landing flat leaves it
/// spinning, and the next substep's warm start bounces it). The cases are computed in every
/// lane and the first that holds is taken, in the order: an idle row (one Gauss–Seidel step
/// each), both apart and staying so, both pushing, only the first, only the second, neither,
/// and, when round-off left no case exact, one Gauss–Seidel step each; the later cases only
/// when some lane is in none of the first three. Returns the new impulses.
///
/// `RIGID`: both rows are rigid in every lane (the relax and restitution passes), so the
/// compliance terms are exact zeros and their arithmetic is left out: the same impulses, with
/// fewer operations.
#[inline(always)]
fn block<const RIGID: bool>(
    p: &NormalRows,
    q: &NormalRows,
    up: Reg,
    uq: Reg,
    (m01, [inv_rigid, inv_soft]): (Reg, [Reg; 2]),
) -> (Reg, Reg) {
    let zero = Reg::ZERO;
    let (l0, l1) = (p.impulse, q.impulse);
    let idle = q.mass.simd_eq(zero) | p.mass.simd_eq(zero);
    let (r0, r1, m00, m11) = if RIGID {
        (up + p.bias, uq + q.bias, p.k, q.k)
    } else {
        let (cp, cq) = (p.compliance * p.k, q.compliance * q.k);
        (up + p.bias + cp * l0, uq + q.bias + cq * l1, p.k + cp, q.k + cq)
    };
    let apart = l0.simd_eq(zero) & l1.simd_eq(zero) & r0.simd_ge(zero) & r1.simd_ge(zero);
    let det = m00 * m11 - m01 * m01;
    // Both rows rigid (every row of a relax pass) or both soft: `fill` has divided already, by
    // the same numbers. Only a lane with one row of each divides here.
    let inv = if RIGID {
        inv_rigid
    } else {
        let (soft_p, soft_q) = (!p.compliance.simd_eq(zero), !q.compliance.simd_eq(zero));
        if (soft_p ^ soft_q).any() { Reg::ONE / det } else { soft_p.select(inv_soft, inv_rigid) }
    };
    let (both0, both1) = (l0 - (m11 * r0 - m01 * r1) * inv, l1 - (m00 * r1 - m01 * r0) * inv);
    let both = det.simd_gt(Reg::splat(1e-9) * m00 * m11) & both0.simd_ge(zero) & both1.simd_ge(zero);
    // The cases of a resting or separating manifold; the others only where a lane needs them.
    let (mut new_p, mut new_q) = (both0, both1);
    if !(idle | apart | both).all() {
        let (scale_p, scale_q) = if RIGID { (p.mass, q.mass) } else { (p.mass * p.mass_scale, q.mass * q.mass_scale) };
        let first = l0 - (r0 - m01 * l1) * scale_p;
        let first_only = first.simd_ge(zero) & (r1 + m01 * (first - l0) - m11 * l1).simd_ge(zero);
        let second = l1 - (r1 - m01 * l0) * scale_q;
        let second_only = second.simd_ge(zero) & (r0 + m01 * (second - l1) - m00 * l0).simd_ge(zero);
        let neither = (r0 - m00 * l0 - m01 * l1).simd_ge(zero) & (r1 - m01 * l0 - m11 * l1).simd_ge(zero);
        let (gs0, gs1) = gauss_seidel::<RIGID>(p, q, up, uq, m01);
        // Chosen from the last case to the first, so the first that holds wins.
        (new_p, new_q) = (gs0, gs1);
        for (case, a, b) in [(neither, zero, zero), (second_only, zero, second), (first_only, first, zero)] {
            (new_p, new_q) = (case.select(a, new_p), case.select(b, new_q));
        }
        (new_p, new_q) = (both.select(both0, new_p), both.select(both1, new_q));
    }
    (new_p, new_q) = (apart.select(zero, new_p), apart.select(zero, new_q));
    if idle.any() {
        let (gs0, gs1) = gauss_seidel::<RIGID>(p, q, up, uq, m01);
        (new_p, new_q) = (idle.select(gs0, new_p), idle.select(gs1, new_q));
    }
    (new_p, new_q)
}

/// One Gauss–Seidel step for each of two rows: for an idle row (a last single point, an idle
/// pair), or where round-off left no case of `block` exact.
#[inline(always)]
fn gauss_seidel<const RIGID: bool>(p: &NormalRows, q: &NormalRows, up: Reg, uq: Reg, m01: Reg) -> (Reg, Reg) {
    let new_p = p.single::<RIGID>(up);
    (new_p, q.single::<RIGID>(uq + m01 * (new_p - p.impulse)))
}

/// The friction patches of a batch (see `super::Friction`): the two tangent rows together,
/// clamped to the Coulomb disc of the points' normal impulses, then the twist row. The linear
/// velocities must be up to date (`LaneBodies::flush`).
#[inline(always)]
fn friction(lane_bodies: &mut LaneBodies, batch: &mut Batch, batch_points: &[PointRows]) {
    let (mut total, mut moment) = (Reg::ZERO, Reg::ZERO);
    for p in batch_points {
        let impulse = load(&p.impulse);
        total += impulse;
        moment += impulse * load(&p.lever);
    }
    let dv = lane_bodies.va.minus(lane_bodies.vb);
    let f = &mut batch.friction;
    let mu = load(&batch.mu);
    let (t1, t2) = (RegVec::load(&batch.tangents[0]), RegVec::load(&batch.tangents[1]));
    let s1 = with_levers(dv.dot(t1), (lane_bodies.wa, lane_bodies.wb), &f.g[0]);
    let s2 = with_levers(dv.dot(t2), (lane_bodies.wa, lane_bodies.wb), &f.g[1]);
    let [m11, m12, m22] = f.mass.map(|m| load(&m));
    let (old1, old2) = (load(&f.impulse[0]), load(&f.impulse[1]));
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
    lane_bodies.push(&batch.tangents[0], &g[0], batch, j1 - old1);
    lane_bodies.push(&batch.tangents[1], &g[1], batch, j2 - old2);
    let f = &mut batch.friction;
    let (twist_a, twist_b) = (RegVec::load(&f.twist[0]), RegVec::load(&f.twist[1]));
    let (sa, sb) = (lane_bodies.wa.dot(twist_a), lane_bodies.wb.dot(twist_b));
    let limit = mu * moment;
    let old = load(&f.impulse[2]);
    // f64::clamp's steps: up to −limit, then down to limit.
    let jt = old - load(&f.twist_mass) * (sa - sb);
    let jt = jt.simd_lt(-limit).select(-limit, jt);
    let jt = jt.simd_gt(limit).select(limit, jt);
    f.impulse[2] = jt.to_array();
    lane_bodies.wa.add_scaled(twist_a, jt - old);
    lane_bodies.wb.sub_scaled(twist_b, jt - old);
}

/// A row's relative motion in each lane: its linear part plus A's angular part along its lever
/// minus B's, `linear + a·g_a − b·g_b` (speeds from spins, gaps from turns).
#[inline(always)]
fn with_levers(linear: Reg, (a, b): (RegVec, RegVec), g: &[LaneVectors; 2]) -> Reg {
    linear + a.dot(RegVec::load(&g[0])) - b.dot(RegVec::load(&g[1]))
}

/// True when some point of `batch` (its rows `batch_points`) may bounce: a lane with
/// restitution whose approach speed at the step's start was at least `threshold` [m/s]. Both
/// are fixed through the step, so `fill` lists these batches once (`ConstraintGroup::bouncing`).
#[must_use]
pub fn may_bounce(batch: &Batch, batch_points: &[PointRows], threshold: Scalar) -> bool {
    let bounces = |point: &PointRows| (0..LANES).any(|l| batch.restitution[l] > 0.0 && point.approach[l] <= -threshold);
    batch_points.iter().any(bounces)
}

/// Restitution after the substeps (Box2D v3): a point that touched (`TOUCH_SHARE`) and was
/// approaching faster than `threshold` [m/s] when the step began leaves at `restitution` times
/// that speed, by an added normal impulse (accumulated, never pulling). Slower contacts rest:
/// they do not hop. A manifold's diagonals are solved as blocks here too, so a box landing flat
/// leaves flat. Only the batches `bouncing` lists are visited: `fill` lists those with a point
/// that `may_bounce`, and the others' bodies are left as they are without loading them.
pub fn restitution<B: BodyStore + ?Sized>(
    bodies: &mut B,
    (batches, bouncing): (&[Batch], &[u32]),
    points: &mut [PointRows],
    threshold: Scalar,
) {
    for &b in bouncing {
        let batch = &batches[b as usize];
        let batch_points = points_of(batch, points);
        let mut lane_bodies = LaneBodies::open(bodies, batch);
        let (inv_mass_sum, e_n) = (load(&batch.inv_mass_sum), load(&batch.restitution));
        let largest = batch_points.iter().fold(Reg::ZERO, |m, p| m.max(load(&p.max_impulse)));
        let touch = largest * Reg::splat(TOUCH_SHARE);
        // A point's bouncing lanes, and its rows there: rigid, the target the reversed approach.
        let bounce = |point: &PointRows| {
            let approach = load(&point.approach);
            let touched = load(&point.max_impulse).simd_gt(touch);
            let bouncing = e_n.simd_gt(Reg::ZERO) & approach.simd_le(Reg::splat(-threshold)) & touched;
            (bouncing, NormalRows::rigid(point, e_n * approach))
        };
        for pair in batch_points.chunks_mut(2) {
            match pair {
                [p, q] => {
                    let ((bp, rp), (bq, rq)) = (bounce(p), bounce(q));
                    let (up, uq) = (lane_bodies.normal_speed(&p.g), lane_bodies.normal_speed(&q.g));
                    let (both_p, both_q) =
                        block::<true>(&rp, &rq, up, uq, (load(&p.coupling), p.inv_det.map(|d| load(&d))));
                    let both = bp & bq;
                    let new_p = both.select(both_p, bp.select(rp.single::<true>(up), rp.impulse));
                    let new_q = both.select(both_q, bq.select(rq.single::<true>(uq), rq.impulse));
                    let (dp, dq) = (new_p - rp.impulse, new_q - rq.impulse);
                    (p.impulse, q.impulse) = (new_p.to_array(), new_q.to_array());
                    lane_bodies.push_normal(&p.g, inv_mass_sum, dp);
                    lane_bodies.push_normal(&q.g, inv_mass_sum, dq);
                }
                [p] => {
                    let (bp, rp) = bounce(p);
                    let new = bp.select(rp.single::<true>(lane_bodies.normal_speed(&p.g)), rp.impulse);
                    let dp = new - rp.impulse;
                    p.impulse = new.to_array();
                    lane_bodies.push_normal(&p.g, inv_mass_sum, dp);
                }
                _ => {}
            }
        }
        lane_bodies.close(bodies, batch);
    }
}
