//! The contact solver's data and its substep kernel: the `solve` system builds one
//! `Constraint` per held pair and one `ContactPoint` per manifold point, and this file solves
//! them as a "soft step" (Catto, "Solver2D", 2024; Box2D v3; rapier's TGS).
//!
//! Layout, for speed: the bodies a step's contacts touch are gathered into a dense
//! `SolverBody` array (every fixed body shares one static slot of zeros, so no branch asks
//! which end is fixed), and angular velocities are kept in *inertia-scaled* coordinates
//! ŵ = S⁻¹ω with S = (I⁻¹)^½ in world axes (rapier's trick). Then one vector per body and axis,
//! g = S (r × d), serves both ways: the relative speed along d is Δv·d + ŵ_a·g_a − ŵ_b·g_b, an
//! impulse j changes ŵ by ±g j, and the effective mass is 1 / (m_a⁻¹ + m_b⁻¹ + |g_a|² + |g_b|²)
//! (PHYSICS.md §2.5's K, since (r×d)·I⁻¹(r×d) = |S (r×d)|²).
//!
//! Gauss–Seidel is a chain of dependent steps, so one pair after another runs at the latency
//! of its arithmetic, not the machine's throughput. The constraints are therefore solved
//! `LANES` at a time, interleaved, in `Batch`es of pairs that share no free body (`place`).
//! A batch never reorders two constraints that share a free body, and the others do not
//! interact, so the result is exactly that of solving them one by one in the given order.

// Lane loops (`for l in 0..LANES`) index several lane arrays in step: the ends, the
// constraints and the points of a batch; an index reads plainer than a four-way zip.
#![allow(clippy::needless_range_loop)]

use crate::math::{Scalar, Vector};

/// A body as the substeps see it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolverBody {
    /// Linear velocity [m/s].
    pub v: Vector,
    /// Scaled angular velocity ŵ = S⁻¹ω.
    pub w: Vector,
    /// Displacement over the substeps done so far [m].
    pub dx: Vector,
    /// Scaled rotation vector over the substeps done so far (S⁻¹ times the rotation).
    pub dq: Vector,
}

/// Constraints solved side by side in a batch.
pub const LANES: usize = 4;

/// One held pair: its bodies, normal, material and friction rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Constraint {
    /// Solver-body slots of A and B (the static slot for a fixed body).
    pub slot: [u32; 2],
    /// Unit normal from B to A.
    pub normal: Vector,
    /// Two unit tangents completing the normal to a right-handed basis.
    pub tangents: [Vector; 2],
    /// Inverse masses of A and B [1/kg].
    pub inv_mass: [Scalar; 2],
    /// Friction coefficient of the pair.
    pub mu: Scalar,
    /// Restitution of the pair.
    pub restitution: Scalar,
    /// Penetration left alone [m] (`Params::slop` times the thinner body's thickness).
    pub slop: Scalar,
    /// Fastest push out of a penetration [m/s].
    pub max_push: Scalar,
    /// The pair's friction, held at the centre of its points.
    pub friction: Friction,
}

impl Constraint {
    /// An unused lane: both ends the static slot, so it applies nothing.
    #[must_use]
    pub fn idle(static_slot: u32) -> Self {
        Self {
            slot: [static_slot; 2],
            normal: Vector::Y,
            tangents: [Vector::Z, Vector::X],
            inv_mass: [0.0; 2],
            mu: 0.0,
            restitution: 0.0,
            slop: 0.0,
            max_push: 0.0,
            friction: Friction::IDLE,
        }
    }
}

/// A pair's friction as one patch (rapier's "simplified" model, PhysX's patch friction): two
/// tangent rows at the centre of the manifold's points, coupled through their 2×2 effective
/// mass and held together within the Coulomb disc |j_t| ≤ μ Σ j_n, and one twist row about the
/// normal within μ Σ j_n·d (d: each point's distance from the centre). Three rows a pair
/// instead of two a point, and no point is favoured by being solved first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Friction {
    /// g = S (r × t) of the two tangents (outer index) at the centre, for A and B.
    pub g: [[Vector; 2]; 2],
    /// S n for A and B: the twist row's scaled axis.
    pub twist: [Vector; 2],
    /// The inverse of the tangent rows' 2×2 effective-mass matrix [kg]: (xx, xy, yy).
    pub mass: [Scalar; 3],
    /// Effective mass of the twist row [kg·m²].
    pub twist_mass: Scalar,
    /// Accumulated impulses of the current substep: the two tangents [N·s], the twist [N·m·s].
    pub impulse: [Scalar; 3],
}

impl Friction {
    /// No friction (zero effective masses).
    pub const IDLE: Self = Self {
        g: [[Vector::ZERO; 2]; 2],
        twist: [Vector::ZERO; 2],
        mass: [0.0; 3],
        twist_mass: 0.0,
        impulse: [0.0; 3],
    };
}

/// Up to `LANES` constraints that share no free body, solved together; their points are
/// `points[first..first + len]`, lane l of each entry belonging to constraint l (lanes with
/// fewer points, or no constraint, hold `ContactPoint::IDLE`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Batch {
    /// The constraints.
    pub lanes: [Constraint; LANES],
    /// First entry of the batch's points.
    pub first: u32,
    /// Most points of any lane.
    pub len: u32,
}

/// One manifold point: its normal row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactPoint {
    /// g = S (r × n) for A and B.
    pub g: [Vector; 2],
    /// Effective mass along the normal [kg] (0: an idle point).
    pub mass: Scalar,
    /// Its inverse K_ii [1/kg] (0 for an idle point).
    pub k: Scalar,
    /// Accumulated normal impulse of the current substep [N·s] (≥ 0).
    pub impulse: Scalar,
    /// Gap when the step began [m]: > 0 apart (speculative), < 0 penetrating.
    pub gap: Scalar,
    /// Relative normal speed when the step began [m/s] (< 0 approaching): what restitution
    /// reverses.
    pub approach: Scalar,
    /// Largest normal impulse of any substep [N·s]: > 0 when the point touched.
    pub max_impulse: Scalar,
    /// Distance from the friction centre [m]: the point's lever against twisting.
    pub lever: Scalar,
    /// For the first point of a pair (0 of 0–1, 2 of 2–3), the off-diagonal K₀₁ of the pair's
    /// effective-mass matrix, m_a⁻¹ + m_b⁻¹ + g_a·g'_a + g_b·g'_b [1/kg]; else 0.
    pub coupling: Scalar,
}

impl ContactPoint {
    /// A point that applies nothing (zero effective mass).
    pub const IDLE: Self = Self {
        g: [Vector::ZERO; 2],
        mass: 0.0,
        k: 0.0,
        impulse: 0.0,
        gap: 0.0,
        approach: 0.0,
        max_impulse: 0.0,
        lever: 0.0,
        coupling: 0.0,
    };
}

/// Places constraints, given in solving order by their solver-body slots, into batches of
/// `LANES` that share no free body: each goes to the first batch with room after the last
/// batch holding either of its bodies (the static slot, which nothing moves, is shared
/// freely). So any two constraints of one body keep their order, and the batched sweep equals
/// the sequential one. Returns, in `out`, (batch, lane) per constraint; `fill` ends holding each
/// batch's count. `last` is scratch, indexed by slot.
pub fn place(slots: &[[u32; 2]], static_slot: u32, last: &mut Vec<u32>, fill: &mut Vec<u8>, out: &mut Vec<(u32, u8)>) {
    last.clear();
    last.resize(static_slot as usize + 1, 0);
    fill.clear();
    out.clear();
    let mut first_open = 0;
    for s in slots {
        // Batches are numbered from 1 in `last`, so 0 means "none yet".
        let after = s.iter().filter(|&&i| i != static_slot).map(|&i| last[i as usize]).max().unwrap_or(0);
        while first_open < fill.len() && usize::from(fill[first_open]) == LANES {
            first_open += 1;
        }
        let mut j = (after as usize).max(first_open);
        while j < fill.len() && usize::from(fill[j]) == LANES {
            j += 1;
        }
        if j == fill.len() {
            fill.push(0);
        }
        out.push((j as u32, fill[j]));
        fill[j] += 1;
        for &i in s.iter().filter(|&&i| i != static_slot) {
            last[i as usize] = j as u32 + 1;
        }
    }
}

/// Damping ratio of the soft contact (Box2D v3's and rapier's default): heavily overdamped, so
/// pushing a penetration out never overshoots into a bounce.
const CONTACT_DAMPING_RATIO: Scalar = 10.0;

/// Natural frequency of the contact spring as a fraction of the substep rate: a quarter,
/// Box2D v3's bound for a stable spring (120 Hz at 8 substeps of a 1/60 s step). Box2D and
/// rapier default to 30 Hz (60 against fixed bodies), which lets a tall stack buckle: a tower
/// of 20 cubes on 30 Hz contacts, or a 40-row pyramid's out-of-plane lean on 60 Hz ones, has
/// less bending stiffness than its weight's toppling moment, and falls. A soft contact also
/// sinks under load by (load)/(effective mass · ω²): the stiffest stable spring keeps a 40-row
/// pyramid's bottom row within a few millimetres.
const HERTZ_PER_SUBSTEP_RATE: Scalar = 0.25;

/// The soft-constraint coefficients of a contact (Catto, "Solver2D", 2024): a damped spring
/// written as a bias rate and mass/impulse scales.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Softness {
    bias_rate: Scalar,
    mass_scale: Scalar,
    impulse_scale: Scalar,
    /// `impulse_scale / mass_scale`: the row's compliance per unit of its K_ii.
    compliance: Scalar,
}

impl Softness {
    /// The contact spring for substep length `h` [s].
    #[must_use]
    pub fn new(h: Scalar) -> Self {
        let omega = 2.0 * std::f64::consts::PI * HERTZ_PER_SUBSTEP_RATE / h;
        let a1 = 2.0 * CONTACT_DAMPING_RATIO + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Self { bias_rate: omega / a1, mass_scale: a2 * a3, impulse_scale: a3, compliance: 1.0 / a2 }
    }
}

/// The two bodies of a constraint while it is solved, in registers.
#[derive(Clone, Copy)]
struct Ends {
    a: SolverBody,
    b: SolverBody,
    /// (v_a − v_b)·n, kept up to date by `push_normal`: the normal rows' linear part.
    u: Scalar,
    /// (dx_a − dx_b)·n: how far the substeps have moved the bodies along the normal.
    d: Scalar,
    /// Normal impulse applied to `u` and the spins but not yet to the linear velocities
    /// (`flush`): a normal row's linear part is the same for every point of a pair, so it is
    /// kept as one number until something else needs the velocities.
    held: Scalar,
}

impl Ends {
    /// The ends of constraint `c` as `bodies` stand.
    #[inline(always)]
    fn load(&mut self, bodies: &[SolverBody], c: &Constraint) {
        let [ia, ib] = c.slot;
        self.a = bodies[ia as usize];
        self.b = bodies[ib as usize];
        self.u = (self.a.v - self.b.v).dot(c.normal);
        self.d = (self.a.dx - self.b.dx).dot(c.normal);
        self.held = 0.0;
    }

    /// Applies the held normal impulse to the linear velocities.
    #[inline(always)]
    fn flush(&mut self, c: &Constraint) {
        self.a.v += c.normal * (self.held * c.inv_mass[0]);
        self.b.v -= c.normal * (self.held * c.inv_mass[1]);
        self.held = 0.0;
    }

    /// Relative speed of A against B along the normal at a point with scaled levers `g`.
    #[inline(always)]
    fn normal_speed(&self, g: &[Vector; 2]) -> Scalar {
        self.u + self.a.w.dot(g[0]) - self.b.w.dot(g[1])
    }

    /// A normal impulse `j` at a point with scaled levers `g`; `im` is m_a⁻¹ + m_b⁻¹.
    #[inline(always)]
    fn push_normal(&mut self, g: &[Vector; 2], im: Scalar, j: Scalar) {
        self.a.w += g[0] * j;
        self.b.w -= g[1] * j;
        self.u += j * im;
        self.held += j;
    }

    /// Writes the velocities back, except into the static slot (the last), which must stay
    /// zero and whose writes would chain every ground contact to the one before.
    #[inline(always)]
    fn store(&self, bodies: &mut [SolverBody], c: &Constraint) {
        let fixed = bodies.len() - 1;
        let [ia, ib] = c.slot.map(|s| s as usize);
        if ia != fixed {
            (bodies[ia].v, bodies[ia].w) = (self.a.v, self.a.w);
        }
        if ib != fixed {
            (bodies[ib].v, bodies[ib].w) = (self.b.v, self.b.w);
        }
    }

    /// Relative speed of A against B along `d` with A's and B's scaled lever vectors `g`.
    #[inline(always)]
    fn speed(&self, d: Vector, g: &[Vector; 2]) -> Scalar {
        (self.a.v - self.b.v).dot(d) + self.a.w.dot(g[0]) - self.b.w.dot(g[1])
    }

    /// An angular impulse `j` about the normal, whose scaled axes are `g`: +j on A, −j on B.
    #[inline(always)]
    fn twist(&mut self, g: &[Vector; 2], j: Scalar) {
        self.a.w += g[0] * j;
        self.b.w -= g[1] * j;
    }

    /// An impulse `j` along `d`: +j on A, −j on B.
    #[inline(always)]
    fn push(&mut self, d: Vector, g: &[Vector; 2], inv_mass: [Scalar; 2], j: Scalar) {
        self.a.v += d * (j * inv_mass[0]);
        self.a.w += g[0] * j;
        self.b.v -= d * (j * inv_mass[1]);
        self.b.w -= g[1] * j;
    }
}

/// Loads a batch's bodies (one pair of ends per lane).
#[inline(always)]
fn open(bodies: &[SolverBody], batch: &Batch) -> [Ends; LANES] {
    // Body by body into a local: building an `Ends` and copying it in made the compiler call
    // memcpy per lane, a tenth of the solve's time.
    let body = SolverBody::default();
    let mut ends = [Ends { a: body, b: body, u: 0.0, d: 0.0, held: 0.0 }; LANES];
    for l in 0..LANES {
        ends[l].load(bodies, &batch.lanes[l]);
    }
    ends
}

/// Writes a batch's bodies back.
#[inline(always)]
fn close(bodies: &mut [SolverBody], batch: &Batch, ends: &mut [Ends; LANES]) {
    for l in 0..LANES {
        ends[l].flush(&batch.lanes[l]);
        ends[l].store(bodies, &batch.lanes[l]);
    }
}

/// A batch's points.
#[inline(always)]
fn entries<'a>(batch: &Batch, points: &'a mut [[ContactPoint; LANES]]) -> &'a mut [[ContactPoint; LANES]] {
    &mut points[batch.first as usize..(batch.first + batch.len) as usize]
}

/// Re-applies each row's accumulated impulse (the previous substep's, or the previous step's
/// at the first substep): a resting stack starts each substep near its solution.
pub fn warm_start(bodies: &mut [SolverBody], batches: &[Batch], points: &mut [[ContactPoint; LANES]]) {
    for batch in batches {
        let mut ends = open(bodies, batch);
        for entry in entries(batch, points).iter() {
            for l in 0..LANES {
                let (c, p) = (&batch.lanes[l], &entry[l]);
                ends[l].push_normal(&p.g, c.inv_mass[0] + c.inv_mass[1], p.impulse);
            }
        }
        for l in 0..LANES {
            let (c, e) = (&batch.lanes[l], &mut ends[l]);
            e.flush(c);
            let f = &c.friction;
            e.push(c.tangents[0], &f.g[0], c.inv_mass, f.impulse[0]);
            e.push(c.tangents[1], &f.g[1], c.inv_mass, f.impulse[1]);
            e.twist(&f.twist, f.impulse[2]);
        }
        close(bodies, batch, &mut ends);
    }
}

/// One Gauss–Seidel sweep through the batches in order (the `solve` system orders the
/// constraints lowest first, so one sweep carries a stack's support from the ground up); the
/// lanes of a batch are interleaved, so their arithmetic overlaps.
///
/// The solve pass (`soft` given) holds the normals with soft position feedback; the relax
/// pass (`None`) holds them rigidly, takes the pair's points in reverse order (so neither end of a
/// manifold is always first: a box landing flat is stopped evenly at its corners), and then
/// solves friction. Friction only in the relax pass (rapier's "no friction when applying
/// bias"): friction reacting to the push-out velocities pumps a tall stack's lean.
pub fn sweep(
    bodies: &mut [SolverBody],
    batches: &mut [Batch],
    points: &mut [[ContactPoint; LANES]],
    h: Scalar,
    soft: Option<Softness>,
) {
    for batch in batches {
        let mut ends = open(bodies, batch);
        let entries = entries(batch, points);
        // Points go in pairs (0, 1), (2, 3): a manifold's diagonals (`manifold::reduce`).
        if soft.is_none() {
            for pair in entries.chunks_mut(2).rev() {
                normal_pair(&mut ends, &batch.lanes, pair, h, soft);
            }
        } else {
            for pair in entries.chunks_mut(2) {
                normal_pair(&mut ends, &batch.lanes, pair, h, soft);
            }
        }
        if soft.is_none() {
            for l in 0..LANES {
                if batch.lanes[l].mu > 0.0 {
                    ends[l].flush(&batch.lanes[l]);
                    friction(&mut ends[l], &mut batch.lanes[l], entries, l);
                }
            }
        }
        close(bodies, batch, &mut ends);
    }
}

/// The normal rows of a pair of points (or a last single one) of each lane.
#[inline(always)]
fn normal_pair(
    ends: &mut [Ends; LANES],
    lanes: &[Constraint; LANES],
    pair: &mut [[ContactPoint; LANES]],
    h: Scalar,
    soft: Option<Softness>,
) {
    match pair {
        [first, second] => {
            for l in 0..LANES {
                normal_block(&mut ends[l], &lanes[l], &mut first[l], &mut second[l], h, soft);
            }
        }
        [single] => {
            for l in 0..LANES {
                normal_impulse(&mut ends[l], &lanes[l], &mut single[l], h, soft);
            }
        }
        _ => {}
    }
}

/// What a normal row asks of its impulse this pass: the velocity bias and the softness,
/// (compliance per unit of K_ii, effective-mass factor): the soft step's update
/// Δλ = −m·s_m (u + b) − s_i λ is a Gauss–Seidel step on the compliant row u + b + C λ = 0 with
/// C = K_ii s_i / s_m, whose diagonal K_ii + C has the inverse m·s_m (s_m + s_i = 1). A rigid
/// row is (0, 1).
#[inline(always)]
fn row_target(
    e: &Ends,
    c: &Constraint,
    p: &ContactPoint,
    h: Scalar,
    soft: Option<Softness>,
) -> (Scalar, Scalar, Scalar) {
    let g = &p.g;
    let gap = p.gap + (e.a.dx - e.b.dx).dot(c.normal) + e.a.dq.dot(g[0]) - e.b.dq.dot(g[1]);
    match soft {
        _ if gap > 0.0 => (gap / h, 0.0, 1.0),
        Some(k) if gap + c.slop < 0.0 => ((k.bias_rate * (gap + c.slop)).max(-c.max_push), k.compliance, k.mass_scale),
        _ => (0.0, 0.0, 1.0),
    }
}

/// Two normal rows of one manifold solved together: the 2×2 linear complementarity problem
/// (K + C) Δλ = −(u + b + C λ), λ + Δλ ≥ 0, by trying which rows push (Box2D v2's block solver,
/// here over a manifold's diagonals, whose rows fight each other: pushing one corner tips the
/// body away from the opposite one, so one Gauss–Seidel sweep of the four corners of a box
/// landing flat leaves it spinning, and the next substep's warm start bounces it).
#[inline(always)]
fn normal_block(
    e: &mut Ends,
    c: &Constraint,
    p: &mut ContactPoint,
    q: &mut ContactPoint,
    h: Scalar,
    soft: Option<Softness>,
) {
    if q.mass == 0.0 || p.mass == 0.0 {
        normal_impulse(e, c, p, h, soft);
        normal_impulse(e, c, q, h, soft);
        return;
    }
    let ((bp, sp, fp), (bq, sq, fq)) = (row_target(e, c, p, h, soft), row_target(e, c, q, h, soft));
    let (cp, cq) = (sp * p.k, sq * q.k);
    let lambda = [p.impulse, q.impulse];
    let r = [e.normal_speed(&p.g) + bp + cp * lambda[0], e.normal_speed(&q.g) + bq + cq * lambda[1]];
    if lambda == [0.0, 0.0] && r[0] >= 0.0 && r[1] >= 0.0 {
        return; // apart, or touching without pushing, and staying so: the LCP's unique answer
    }
    let (m00, m11, m01) = (p.k + cp, q.k + cq, p.coupling);
    let det = m00 * m11 - m01 * m01;
    // Both push; else only the first; only the second; neither.
    let both = || {
        (det > 1e-9 * m00 * m11).then(|| {
            let inv = 1.0 / det;
            [lambda[0] - (m11 * r[0] - m01 * r[1]) * inv, lambda[1] - (m00 * r[1] - m01 * r[0]) * inv]
        })
    };
    let only_first = || {
        let l0 = lambda[0] - (r[0] - m01 * lambda[1]) * (p.mass * fp);
        let w1 = r[1] + m01 * (l0 - lambda[0]) - m11 * lambda[1];
        (l0 >= 0.0 && w1 >= 0.0).then_some([l0, 0.0])
    };
    let only_second = || {
        let l1 = lambda[1] - (r[1] - m01 * lambda[0]) * (q.mass * fq);
        let w0 = r[0] + m01 * (l1 - lambda[1]) - m00 * lambda[0];
        (l1 >= 0.0 && w0 >= 0.0).then_some([0.0, l1])
    };
    let neither = || {
        let w = [r[0] - m00 * lambda[0] - m01 * lambda[1], r[1] - m01 * lambda[0] - m11 * lambda[1]];
        (w[0] >= 0.0 && w[1] >= 0.0).then_some([0.0, 0.0])
    };
    let chosen =
        both().filter(|l| l[0] >= 0.0 && l[1] >= 0.0).or_else(only_first).or_else(only_second).or_else(neither);
    let Some(new) = chosen else {
        // Round-off left no case exact: one Gauss–Seidel step each.
        normal_impulse(e, c, p, h, soft);
        normal_impulse(e, c, q, h, soft);
        return;
    };
    let im = c.inv_mass[0] + c.inv_mass[1];
    e.push_normal(&p.g, im, new[0] - lambda[0]);
    e.push_normal(&q.g, im, new[1] - lambda[1]);
    (p.impulse, q.impulse) = (new[0], new[1]);
    p.max_impulse = p.max_impulse.max(new[0]);
    q.max_impulse = q.max_impulse.max(new[1]);
}

/// The normal impulse at one point.
///
/// The gap is the starting gap moved on by the bodies' displacements so far (linearised about
/// the step's start). A gap still open may close within this substep (speculative contact,
/// u_n ≥ −gap/h); a penetration beyond the slop is pushed out by the soft spring in the solve
/// pass, never faster than the pair's cap, and not at all in the relax pass, which takes the
/// push-out velocity back.
#[inline(always)]
fn normal_impulse(e: &mut Ends, c: &Constraint, p: &mut ContactPoint, h: Scalar, soft: Option<Softness>) {
    let g = &p.g;
    let gap = p.gap + e.d + e.a.dq.dot(g[0]) - e.b.dq.dot(g[1]);
    let (bias, mass_scale, impulse_scale) = match soft {
        _ if gap > 0.0 => (gap / h, 1.0, 0.0),
        Some(k) if gap + c.slop < 0.0 => {
            ((k.bias_rate * (gap + c.slop)).max(-c.max_push), k.mass_scale, k.impulse_scale)
        }
        _ => (0.0, 1.0, 0.0),
    };
    let dj = -p.mass * mass_scale * (e.normal_speed(g) + bias) - impulse_scale * p.impulse;
    let jn = (p.impulse + dj).max(0.0);
    e.push_normal(g, c.inv_mass[0] + c.inv_mass[1], jn - p.impulse);
    p.impulse = jn;
    p.max_impulse = p.max_impulse.max(jn);
}

/// The friction patch of lane `l` (see `Friction`): the two tangent rows together, clamped to
/// the Coulomb disc of the points' normal impulses, then the twist row.
#[inline(always)]
fn friction(e: &mut Ends, c: &mut Constraint, entries: &[[ContactPoint; LANES]], l: usize) {
    let f = &mut c.friction;
    let (mut total, mut moment) = (0.0, 0.0);
    for entry in entries {
        total += entry[l].impulse;
        moment += entry[l].impulse * entry[l].lever;
    }
    let [t1, t2] = c.tangents;
    let (s1, s2) = (e.speed(t1, &f.g[0]), e.speed(t2, &f.g[1]));
    let [m11, m12, m22] = f.mass;
    let mut j1 = f.impulse[0] - (m11 * s1 + m12 * s2);
    let mut j2 = f.impulse[1] - (m12 * s1 + m22 * s2);
    let limit = c.mu * total;
    let len2 = j1 * j1 + j2 * j2;
    // Compared squared: the square root is only taken when the impulse leaves the disc.
    if len2 > limit * limit {
        let scale = limit / len2.sqrt();
        (j1, j2) = (j1 * scale, j2 * scale);
    }
    e.push(t1, &f.g[0], c.inv_mass, j1 - f.impulse[0]);
    e.push(t2, &f.g[1], c.inv_mass, j2 - f.impulse[1]);
    let twist_limit = c.mu * moment;
    let spin = e.a.w.dot(f.twist[0]) - e.b.w.dot(f.twist[1]);
    let jt = (f.impulse[2] - f.twist_mass * spin).clamp(-twist_limit, twist_limit);
    e.twist(&f.twist, jt - f.impulse[2]);
    f.impulse = [j1, j2, jt];
}

/// Restitution after the substeps (Box2D v3): a point that touched and was approaching faster
/// than `threshold` [m/s] when the step began leaves at `restitution` times that speed, by an
/// added normal impulse (accumulated, never pulling). Slower contacts rest: they do not hop.
pub fn restitution(
    bodies: &mut [SolverBody],
    batches: &[Batch],
    points: &mut [[ContactPoint; LANES]],
    threshold: Scalar,
) {
    for batch in batches {
        let mut ends = open(bodies, batch);
        for entry in entries(batch, points).iter_mut() {
            for l in 0..LANES {
                let (c, p, e) = (&batch.lanes[l], &mut entry[l], &mut ends[l]);
                if c.restitution == 0.0 || p.approach > -threshold || p.max_impulse == 0.0 {
                    continue;
                }
                let dj = -p.mass * (e.normal_speed(&p.g) + c.restitution * p.approach);
                let jn = (p.impulse + dj).max(0.0);
                e.push_normal(&p.g, c.inv_mass[0] + c.inv_mass[1], jn - p.impulse);
                p.impulse = jn;
            }
        }
        close(bodies, batch, &mut ends);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placement_keeps_each_bodys_order_and_never_puts_one_body_twice_in_a_batch() {
        // Slot 9 is static. A chain 0-1, 1-2, 2-3 must go to three batches in order; 4-5 and the
        // ground contacts fill the lanes beside them.
        let slots = [[0, 1], [1, 2], [2, 3], [4, 5], [0, 9], [9, 6], [9, 7], [9, 8], [6, 7]];
        let (mut last, mut fill, mut out) = (Vec::new(), Vec::new(), Vec::new());
        place(&slots, 9, &mut last, &mut fill, &mut out);
        assert_eq!(out, [(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (0, 2), (0, 3), (1, 2), (1, 3)]);
        assert_eq!(fill, [4, 4, 1]);
        for (i, si) in slots.iter().enumerate() {
            for (j, sj) in slots.iter().enumerate().skip(i + 1) {
                let shared = si.iter().any(|x| *x != 9 && sj.contains(x));
                if shared {
                    assert!(out[i].0 < out[j].0, "{si:?} before {sj:?}");
                }
            }
        }
    }

    #[test]
    fn an_idle_lane_leaves_the_bodies_alone() {
        let mut bodies = vec![SolverBody { v: Vector::X, ..SolverBody::default() }, SolverBody::default()];
        let mut lanes = [Constraint::idle(1); LANES];
        lanes[0] = Constraint { slot: [0, 1], inv_mass: [1.0, 0.0], ..Constraint::idle(1) };
        let batch = Batch { lanes, first: 0, len: 1 };
        let mut points = vec![[ContactPoint::IDLE; LANES]];
        let mut batches = [batch];
        sweep(&mut bodies, &mut batches, &mut points, 1.0 / 240.0, Some(Softness::new(1.0 / 240.0)));
        sweep(&mut bodies, &mut batches, &mut points, 1.0 / 240.0, None);
        warm_start(&mut bodies, &batches, &mut points);
        assert_eq!(bodies[0].v, Vector::X);
        assert_eq!(bodies[1], SolverBody::default(), "the static slot stays zero");
    }
}
