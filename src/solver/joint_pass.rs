//! Solving the joints within the contact solver's substeps (docs/joints.md): after each pass
//! over the contacts, one pass over every joint in scene order, on the same solver bodies, so
//! a body held by both sees one set of velocities. Scalar code: joints are few.
//!
//! Each joint is a few rows solved as Box2D v3 solves its joints: soft equality rows (the
//! bias from the position error as it stands after the earlier substeps, with the joints'
//! spring of `JOINT_HERTZ_PER_SUBSTEP_RATE`), rigid in the relax pass; limits as one-sided
//! rows, speculative while apart; motors as velocity rows within their largest torque or force
//! times the substep; springs as soft rows of their own frequency. Points and locked rotations
//! are solved as 2×2 or 3×3 blocks, so one joint's rows do not fight each other.

use super::joints::{Frame, Geometry, Joint, JointImpulses, JointKind, Joints};
use super::{BodyStore, SolverBody};
use crate::math::{Mat3, Quat, Scalar, Vector, exp_map};

/// Natural frequency of the joints' spring as a fraction of the substep rate: a quarter, as
/// the contacts' (Box2D v3's bound for a stable spring). Stiffer, a hanging chain of ten links
/// shakes itself apart: Gauss–Seidel over many joints does not settle a spring near the
/// substep rate. A soft joint gives under a load by load / (effective mass · ω²), so a light
/// chain holding a heavy load needs more substeps (scenes/chain.ron takes 32).
const JOINT_HERTZ_PER_SUBSTEP_RATE: Scalar = 0.25;

/// Damping ratio of the joints' spring (Box2D v3's joint damping ratio).
const JOINT_DAMPING_RATIO: Scalar = 2.0;

/// A distance below which a distance joint has no direction [m].
const DEGENERATE: Scalar = 1e-9;

/// One end of a joint as the substeps see it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct End {
    /// Solver-body slot (a static slot for a fixed body or the world).
    pub slot: u32,
    /// Moves: a free body.
    pub free: bool,
    /// Inverse mass [1/kg] (0 unless free).
    pub inv_mass: Scalar,
    /// S = (I⁻¹)^½ in world axes (zero unless free): ω = S ŵ, and I⁻¹ = S².
    pub scale: Mat3,
    /// Pose at the start of the step.
    pub x0: Vector,
    /// Orientation at the start of the step.
    pub q0: Quat,
}

impl End {
    /// The end's pose after the substeps done so far (as `solve` will place it).
    fn frame(&self, body: &SolverBody) -> Frame {
        if self.free {
            (self.x0 + body.dx, (exp_map(self.scale * body.dq) * self.q0).normalize())
        } else {
            (self.x0, self.q0)
        }
    }
}

/// A pass over the joints.
#[derive(Clone, Copy, Debug)]
pub(crate) enum JointPass {
    /// Re-apply the accumulated impulses.
    Warm,
    /// Solve with position feedback.
    Solve,
    /// Solve rigidly, without position feedback.
    Relax,
}

/// Soft-constraint coefficients (Catto, "Solver2D"): a damped spring as a bias rate and mass
/// and impulse scales.
#[derive(Clone, Copy, Debug)]
struct Soft {
    bias_rate: Scalar,
    mass_scale: Scalar,
    impulse_scale: Scalar,
}

impl Soft {
    /// No position feedback, full mass: the rigid relax row.
    const RIGID: Self = Self { bias_rate: 0.0, mass_scale: 1.0, impulse_scale: 0.0 };

    /// A spring of `hertz` and damping ratio `zeta` over substeps of `h` [s].
    fn new(hertz: Scalar, zeta: Scalar, h: Scalar) -> Self {
        if hertz <= 0.0 {
            return Self { bias_rate: 0.0, mass_scale: 0.0, impulse_scale: 1.0 }; // no spring
        }
        let omega = 2.0 * std::f64::consts::PI * hertz;
        let a1 = 2.0 * zeta + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Self { bias_rate: omega / a1, mass_scale: a2 * a3, impulse_scale: a3 }
    }
}

/// A row's Jacobian: the speed it measures is lin·(v_a − v_b) + ang_a·ω_a − ang_b·ω_b.
#[derive(Clone, Copy, Debug)]
struct Row {
    lin: Vector,
    ang_a: Vector,
    ang_b: Vector,
}

impl Row {
    /// Along `n` between points at levers `r_a` and `r_b` from the centres.
    fn linear(n: Vector, r_a: Vector, r_b: Vector) -> Self {
        Self { lin: n, ang_a: r_a.cross(n), ang_b: r_b.cross(n) }
    }

    /// A rotation about `u`.
    fn angular(u: Vector) -> Self {
        Self { lin: Vector::ZERO, ang_a: u, ang_b: u }
    }

    /// The same row the other way.
    fn flip(self) -> Self {
        Self { lin: -self.lin, ang_a: -self.ang_a, ang_b: -self.ang_b }
    }
}

/// The bodies of one joint, read and written through the store.
struct Pair<'a, B: BodyStore + ?Sized> {
    bodies: &'a mut B,
    ends: [End; 2],
}

impl<B: BodyStore + ?Sized> Pair<'_, B> {
    /// The speed `row` measures.
    fn speed(&self, row: &Row) -> Scalar {
        let [a, b] = self.ends.map(|e| *self.bodies.body(e.slot));
        let (wa, wb) = (self.ends[0].scale * a.w, self.ends[1].scale * b.w);
        row.lin.dot(a.v - b.v) + row.ang_a.dot(wa) - row.ang_b.dot(wb)
    }

    /// Applies impulse `lambda` along `row`.
    fn apply(&mut self, row: &Row, lambda: Scalar) {
        let [ea, eb] = self.ends;
        if ea.free {
            let a = self.bodies.body_mut(ea.slot);
            a.v += row.lin * (ea.inv_mass * lambda);
            a.w += ea.scale * row.ang_a * lambda;
        }
        if eb.free {
            let b = self.bodies.body_mut(eb.slot);
            b.v -= row.lin * (eb.inv_mass * lambda);
            b.w -= eb.scale * row.ang_b * lambda;
        }
    }

    /// K_ij = J_i M⁻¹ J_jᵀ of two rows.
    fn k(&self, p: &Row, q: &Row) -> Scalar {
        let [ea, eb] = self.ends;
        (ea.inv_mass + eb.inv_mass) * p.lin.dot(q.lin)
            + (ea.scale * p.ang_a).dot(ea.scale * q.ang_a)
            + (eb.scale * p.ang_b).dot(eb.scale * q.ang_b)
    }

    /// Solves up to three equality rows as one block, with errors `c` and accumulated
    /// impulses `acc` (both per row).
    fn block(&mut self, rows: &[Row], c: [Scalar; 3], acc: &mut [Scalar; 3], soft: Soft) {
        let mut k = Mat3::IDENTITY;
        let mut rhs = Vector::ZERO;
        for (i, p) in rows.iter().enumerate() {
            for (j, q) in rows.iter().enumerate() {
                k.col_mut(j)[i] = self.k(p, q);
            }
            rhs[i] = -soft.mass_scale * (self.speed(p) + soft.bias_rate * c[i]);
        }
        let det = k.determinant();
        if det.is_nan() || det.abs() <= 1e-300 {
            return; // both ends fixed, or a degenerate lever: nothing to move
        }
        let lambda = k.inverse() * rhs;
        for (i, row) in rows.iter().enumerate() {
            let l = lambda[i] - soft.impulse_scale * acc[i];
            acc[i] += l;
            self.apply(row, l);
        }
    }

    /// One equality row (a rod, a spring).
    fn equal(&mut self, row: &Row, c: Scalar, acc: &mut Scalar, soft: Soft) {
        let k = self.k(row, row);
        if k > 0.0 {
            let l = -soft.mass_scale * (self.speed(row) + soft.bias_rate * c) / k - soft.impulse_scale * *acc;
            *acc += l;
            self.apply(row, l);
        }
    }

    /// A one-sided row holding c ≥ 0: speculative while apart (it may close the gap within
    /// the substep, no more), soft or rigid when violated.
    fn limit(&mut self, row: &Row, c: Scalar, acc: &mut Scalar, soft: Soft, h: Scalar) {
        let k = self.k(row, row);
        if k <= 0.0 {
            return;
        }
        let soft = if c > 0.0 { Soft { bias_rate: 1.0 / h, ..Soft::RIGID } } else { soft };
        let l = -soft.mass_scale * (self.speed(row) + soft.bias_rate * c) / k - soft.impulse_scale * *acc;
        let new = (*acc + l).max(0.0);
        let l = new - *acc;
        *acc = new;
        self.apply(row, l);
    }

    /// A motor row driving the speed to `speed` within ±`max` accumulated impulse.
    fn motor(&mut self, row: &Row, speed: Scalar, acc: &mut Scalar, max: Scalar) {
        let k = self.k(row, row);
        if k > 0.0 {
            let l = -(self.speed(row) - speed) / k;
            let new = (*acc + l).clamp(-max, max);
            let l = new - *acc;
            *acc = new;
            self.apply(row, l);
        }
    }
}

/// Two unit vectors across `u`, as the contacts' tangents.
fn across(u: Vector) -> [Vector; 2] {
    super::constraints::tangents(u)
}

/// The three point rows at the anchors.
fn point_rows(g: &Geometry) -> [Row; 3] {
    [Vector::X, Vector::Y, Vector::Z].map(|n| Row::linear(n, g.r_a, g.r_b))
}

/// Runs `pass` over every joint, in order, with substeps of `h` [s].
pub(crate) fn joint_pass<B: BodyStore + ?Sized>(bodies: &mut B, joints: &mut Joints, pass: JointPass, h: Scalar) {
    let soft = match pass {
        JointPass::Solve => Soft::new(JOINT_HERTZ_PER_SUBSTEP_RATE / h, JOINT_DAMPING_RATIO, h),
        JointPass::Warm | JointPass::Relax => Soft::RIGID,
    };
    let Joints { joints, impulses, ends, .. } = joints;
    for ((joint, imp), &ends) in joints.iter().zip(impulses.iter_mut()).zip(ends.iter()) {
        let frames = ends.map(|e| e.frame(bodies.body(e.slot)));
        let g = Geometry::new(joint, frames[0], frames[1]);
        let mut pair = Pair { bodies: &mut *bodies, ends };
        match pass {
            JointPass::Warm => warm(&mut pair, joint, &g, imp),
            JointPass::Solve | JointPass::Relax => solve(&mut pair, joint, &g, imp, soft, pass, h),
        }
    }
}

/// The rows of a joint's axial degree of freedom (hinge: turning about the axis; slider:
/// sliding along it; distance: along the line between the anchors), its value, or `None`.
fn axial(joint: &Joint, g: &Geometry) -> Option<(Row, Scalar)> {
    match joint.kind {
        JointKind::Hinge { .. } => Some((Row::angular(g.u_b), g.turn())),
        // B's lever to the point that meets A's anchor, so the rows measure A's anchor
        // sliding on B.
        JointKind::Slider { .. } => Some((Row::linear(g.u_b, g.r_a, g.r_b + g.d), g.d.dot(g.u_b))),
        JointKind::Distance { .. } => {
            let l = g.d.length();
            (l > DEGENERATE).then(|| (Row::linear(g.d / l, g.r_a, g.r_b), l))
        }
        JointKind::Ball { .. } | JointKind::Fixed => None,
    }
}

/// A ball joint's cone row (closing the swing), and the room left to the cone [rad].
fn cone(g: &Geometry, cone: Scalar) -> Option<(Row, Scalar)> {
    let n = g.u_b.cross(g.u_a);
    let swing = g.u_a.angle_between(g.u_b);
    (n.length() > 1e-9).then(|| (Row::angular(-n.normalize()), cone - swing))
}

/// Re-applies the accumulated impulses at the current geometry.
fn warm<B: BodyStore + ?Sized>(pair: &mut Pair<B>, joint: &Joint, g: &Geometry, imp: &JointImpulses) {
    if !matches!(joint.kind, JointKind::Distance { .. }) {
        let lever = if matches!(joint.kind, JointKind::Slider { .. }) { g.r_b + g.d } else { g.r_b };
        for (k, n) in [Vector::X, Vector::Y, Vector::Z].into_iter().enumerate() {
            pair.apply(&Row::linear(n, g.r_a, lever), imp.point[k]);
        }
        for (k, u) in [Vector::X, Vector::Y, Vector::Z].into_iter().enumerate() {
            pair.apply(&Row::angular(u), imp.angular[k]);
        }
    }
    if let JointKind::Ball { cone: Some(c) } = joint.kind
        && let Some((row, _)) = cone(g, c)
    {
        pair.apply(&row, imp.limits[1]);
    }
    if let Some((row, _)) = axial(joint, g) {
        pair.apply(&row, imp.axial + imp.motor + imp.limits[0] - imp.limits[1]);
    }
}

/// One solve (with position feedback `soft`) or relax pass of a joint: motor and spring,
/// limits, locked rotations, then the point, Box2D's order (the point, the stiffest, last).
fn solve<B: BodyStore + ?Sized>(
    pair: &mut Pair<B>,
    joint: &Joint,
    g: &Geometry,
    imp: &mut JointImpulses,
    soft: Soft,
    pass: JointPass,
    h: Scalar,
) {
    let axial = axial(joint, g);
    let limits = match joint.kind {
        JointKind::Hinge { limits, .. } | JointKind::Slider { limits, .. } => limits,
        JointKind::Distance { range, .. } => Some(range),
        _ => None,
    };
    if let Some((row, value)) = axial {
        if let JointKind::Hinge { motor: Some(m), .. } | JointKind::Slider { motor: Some(m), .. } = joint.kind {
            pair.motor(&row, m.speed, &mut imp.motor, m.max * h);
        }
        match joint.kind {
            // Its own spring, solved with position feedback only (one implicit step a substep).
            JointKind::Distance { spring: Some(s), .. } if matches!(pass, JointPass::Solve) => {
                let spring = Soft::new(s.frequency, s.damping_ratio, h);
                pair.equal(&row, value - joint.length, &mut imp.axial, spring);
            }
            JointKind::Distance { rod: true, .. } => pair.equal(&row, value - joint.length, &mut imp.axial, soft),
            _ => {}
        }
        if let Some([lo, hi]) = limits {
            if lo > Scalar::NEG_INFINITY && !(matches!(joint.kind, JointKind::Distance { .. }) && lo <= 0.0) {
                pair.limit(&row, value - lo, &mut imp.limits[0], soft, h);
            }
            if hi < Scalar::INFINITY {
                pair.limit(&row.flip(), hi - value, &mut imp.limits[1], soft, h);
            }
        }
    }
    if let JointKind::Ball { cone: Some(c) } = joint.kind
        && let Some((row, room)) = cone(g, c)
    {
        pair.limit(&row, room, &mut imp.limits[1], soft, h);
    }
    match joint.kind {
        JointKind::Hinge { .. } => {
            let t = across(g.u_b);
            let bend = g.u_b.cross(g.u_a);
            let mut acc = [imp.angular.dot(t[0]), imp.angular.dot(t[1]), 0.0];
            pair.block(&t.map(Row::angular), [bend.dot(t[0]), bend.dot(t[1]), 0.0], &mut acc, soft);
            imp.angular = t[0] * acc[0] + t[1] * acc[1];
        }
        JointKind::Slider { .. } | JointKind::Fixed => {
            let rows = [Vector::X, Vector::Y, Vector::Z].map(Row::angular);
            let mut acc = imp.angular.to_array();
            pair.block(&rows, g.twist().to_array(), &mut acc, soft);
            imp.angular = Vector::from_array(acc);
        }
        _ => {}
    }
    match joint.kind {
        JointKind::Ball { .. } | JointKind::Hinge { .. } | JointKind::Fixed => {
            let mut acc = imp.point.to_array();
            pair.block(&point_rows(g), g.d.to_array(), &mut acc, soft);
            imp.point = Vector::from_array(acc);
        }
        JointKind::Slider { .. } => {
            let t = across(g.u_b);
            let rows = t.map(|n| Row::linear(n, g.r_a, g.r_b + g.d));
            let mut acc = [imp.point.dot(t[0]), imp.point.dot(t[1]), 0.0];
            pair.block(&rows, [g.d.dot(t[0]), g.d.dot(t[1]), 0.0], &mut acc, soft);
            imp.point = t[0] * acc[0] + t[1] * acc[1];
        }
        JointKind::Distance { .. } => {}
    }
}

/// Each joint's ends for this step: solver slots from `slot` (by actor) with their S from
/// `scale` (by slot), the world's end at the static slot `world`.
pub(crate) fn prepare(
    joints: &mut Joints,
    bodies: &crate::sim::bodies::Bodies,
    slot: &[u32],
    scale: &[Mat3],
    world: u32,
) {
    let end = |i: u32| {
        let i = i as usize;
        let free = !bodies.is_fixed(i);
        End {
            slot: slot[i],
            free,
            inv_mass: if free { bodies.inv_mass[i] } else { 0.0 },
            scale: if free { scale[slot[i] as usize] } else { Mat3::ZERO },
            x0: bodies.position[i],
            q0: bodies.orientation[i],
        }
    };
    let world =
        End { slot: world, free: false, inv_mass: 0.0, scale: Mat3::ZERO, x0: Vector::ZERO, q0: Quat::IDENTITY };
    joints.ends.clear();
    joints.ends.extend(joints.joints.iter().map(|j| [end(j.a), j.b.map_or(world, end)]));
    joints.impulses.resize(joints.joints.len(), JointImpulses::default());
}
