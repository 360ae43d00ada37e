//! Solving the joints within the contact solver's substeps (docs/joints.md): after each pass
//! over the contacts, one pass over every joint, on the same solver bodies, so a body held by
//! both sees one set of velocities.
//!
//! The rows are solved as Box2D v3 solves its joints: soft rows in the solve passes (the bias
//! from the position error as it stands after the earlier substeps, with the joints' spring of
//! `JOINT_HERTZ_PER_SUBSTEP_RATE`), rigid in the relax pass; limits as one-sided rows,
//! speculative while apart; motors as velocity rows within their largest torque or force times
//! the substep; springs as soft rows of their own frequency. The equality rows of all joints
//! (points, locked rotations, rods) are solved together, exactly (`JointSystem`); the others
//! one joint after another, before them.

use super::anchored::{Anchored, AnchoredJoint};
use super::joint_system::{MAX_ROWS, ScaledRow};
use super::joints::{Frame, Geometry, Joint, JointImpulses, JointKind, Joints};
use super::{BodyStore, SolverBody};
use crate::math::{Mat3, Quat, Scalar, Vector, exp_map};

/// Natural frequency of the joints' spring as a fraction of the substep rate: one, four times
/// the contacts' quarter. Gauss–Seidel needs a spring well below the substep rate to settle;
/// the equality rows are solved exactly (`JointSystem`), so they can be stiff, and a soft joint
/// gives under a load by load / (effective mass · ω²).
const JOINT_HERTZ_PER_SUBSTEP_RATE: Scalar = 1.0;

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
    pub(super) fn frame(&self, body: &SolverBody) -> Frame {
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

    /// One soft equality row (a spring).
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

/// Where an equality row's accumulated impulse is kept between refreshes (`JointImpulses`):
/// along a direction of the point's or the rotation's impulse, or as the axial one.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) enum Carry {
    Point(Vector),
    Angular(Vector),
    #[default]
    Axial,
}

/// The equality rows of a joint of `kind`: how many.
pub(crate) fn equality_count(kind: &JointKind) -> usize {
    match kind {
        JointKind::Ball { .. } => 3,
        JointKind::Hinge { .. } | JointKind::Slider { .. } => 5,
        JointKind::Fixed => 6,
        JointKind::Distance { rod, .. } => usize::from(*rod),
    }
}

/// Whether a joint of `kind` has rows solved one joint at a time (limits, motors, a cone, a
/// distance's range or spring), beside its equality rows.
fn one_by_one(kind: &JointKind) -> bool {
    match kind {
        JointKind::Ball { cone } => cone.is_some(),
        JointKind::Hinge { limits, motor } | JointKind::Slider { limits, motor } => limits.is_some() || motor.is_some(),
        JointKind::Fixed => false,
        JointKind::Distance { .. } => true,
    }
}

/// A joint's equality rows at geometry `g`, written to `out` in order (their count returned):
/// each row, its position error and where its impulse is kept. Points and locked rotations on
/// world axes where all three are held, across the axis where two are.
fn equality_rows(joint: &Joint, g: &Geometry, out: &mut [(Row, Scalar, Carry); MAX_ROWS]) -> usize {
    let mut count = 0;
    let mut push = |row: Row, c: Scalar, how: Carry| {
        out[count] = (row, c, how);
        count += 1;
    };
    let axes = [Vector::X, Vector::Y, Vector::Z];
    if matches!(joint.kind, JointKind::Ball { .. } | JointKind::Hinge { .. } | JointKind::Fixed) {
        for (k, n) in axes.into_iter().enumerate() {
            push(Row::linear(n, g.r_a, g.r_b), g.d[k], Carry::Point(n));
        }
    }
    match joint.kind {
        JointKind::Hinge { .. } => {
            let bend = g.u_b.cross(g.u_a);
            for t in across(g.u_b) {
                push(Row::angular(t), bend.dot(t), Carry::Angular(t));
            }
        }
        JointKind::Slider { .. } => {
            // B's lever to the point that meets A's anchor: A's anchor slides on B.
            for t in across(g.u_b) {
                push(Row::linear(t, g.r_a, g.r_b + g.d), g.d.dot(t), Carry::Point(t));
            }
        }
        JointKind::Distance { rod: true, .. } => match axial(joint, g) {
            Some((row, l)) => push(row, l - joint.length, Carry::Axial),
            None => push(Row::angular(Vector::ZERO), 0.0, Carry::Axial),
        },
        _ => {}
    }
    if matches!(joint.kind, JointKind::Slider { .. } | JointKind::Fixed) {
        let twist = g.twist();
        for (k, u) in axes.into_iter().enumerate() {
            push(Row::angular(u), twist[k], Carry::Angular(u));
        }
    }
    count
}

/// Runs `pass` over every joint with substeps of `h` [s]: the one-sided and driven rows joint
/// by joint in scene order, then the equality rows of all at once; twice when there are both.
pub(crate) fn joint_pass<B: BodyStore + ?Sized>(bodies: &mut B, joints: &mut Joints, pass: JointPass, h: Scalar) {
    if joints.stale {
        refresh(&*bodies, joints);
    }
    let soft = match pass {
        JointPass::Solve => Soft::new(JOINT_HERTZ_PER_SUBSTEP_RATE / h, JOINT_DAMPING_RATIO, h),
        JointPass::Warm | JointPass::Relax => Soft::RIGID,
    };
    let Joints { joints: list, impulses, ends, geometry, system, anchored, limited, mixed, .. } = joints;
    let mut one_by_one_rows = |bodies: &mut B| {
        for &k in limited.iter() {
            let k = k as usize;
            let (joint, imp, g) = (&list[k], &mut impulses[k], &geometry[k]);
            let mut pair = Pair { bodies: &mut *bodies, ends: ends[k] };
            match pass {
                JointPass::Warm => warm(&mut pair, joint, g, imp),
                JointPass::Solve | JointPass::Relax => solve(&mut pair, joint, g, imp, soft, pass, h),
            }
        }
    };
    one_by_one_rows(bodies);
    // The anchored joints share no moving body with any other joint: where they go among
    // the others changes nothing.
    match pass {
        JointPass::Warm => {
            anchored.iter().for_each(|a| a.warm(bodies));
            system.warm(bodies);
        }
        JointPass::Solve | JointPass::Relax => {
            let rates = [soft.bias_rate, soft.mass_scale, soft.impulse_scale];
            let mut equality_rows = |bodies: &mut B| {
                anchored.iter_mut().for_each(|a| a.pass(bodies, rates));
                system.pass(bodies, rates);
            };
            equality_rows(bodies);
            // Limits and the equality rows push against each other (a door stopped by its
            // limit needs the hinge's point to stop its centre): a second round lets them
            // agree, or the hit comes back as a rebound.
            if *mixed {
                one_by_one_rows(bodies);
                equality_rows(bodies);
            }
        }
    }
}

/// The joints' geometry and equality rows at the bodies' current poses, K factorised, and the
/// accumulated impulses carried over to the new rows.
fn refresh<B: BodyStore + ?Sized>(bodies: &B, joints: &mut Joints) {
    carry_impulses(joints);
    let Joints { joints: list, impulses, ends, geometry, system, carry, spans, anchored, general, .. } = joints;
    for &k in general.iter() {
        let k = k as usize;
        let [a, b] = ends[k].map(|e| e.frame(bodies.body(e.slot)));
        geometry[k] = Geometry::new(&list[k], a, b);
    }
    anchored.iter_mut().for_each(|a| a.refresh(bodies));
    for &(k, first, len) in spans.iter() {
        let (joint, imp, e) = (&list[k], &impulses[k], &ends[k]);
        // Gathered first and written in one place, so the writing is inlined (a callback per
        // row was a call per row).
        let mut out = [(Row::angular(Vector::ZERO), 0.0, Carry::Axial); MAX_ROWS];
        let count = equality_rows(joint, &geometry[k], &mut out);
        debug_assert_eq!(count, len, "equality_count and equality_rows disagree");
        for (i, &(row, c, how)) in (first..first + len).zip(&out[..count]) {
            system.rows[i] = ScaledRow { lin: row.lin, g_a: e[0].scale * row.ang_a, g_b: e[1].scale * row.ang_b };
            system.error[i] = c;
            system.acc[i] = match how {
                Carry::Point(n) => imp.point.dot(n),
                Carry::Angular(u) => imp.angular.dot(u),
                Carry::Axial => imp.axial,
            };
            carry[i] = how;
        }
    }
    system.factorise();
    joints.stale = false;
    joints.rows_valid = true;
}

/// Keeps the equality rows' accumulated impulses in the joints' `JointImpulses` (world
/// vectors), which outlive the rows: the next rows, turned a little, start from them.
pub(crate) fn store_impulses(joints: &mut Joints) {
    carry_impulses(joints);
    for a in &joints.anchored {
        a.store(&mut joints.impulses);
    }
}

/// `store_impulses` for the joints of the system (an anchored joint's rows stay on the world
/// axes, so its impulses stay in its rows).
fn carry_impulses(joints: &mut Joints) {
    if !joints.rows_valid {
        return;
    }
    let Joints { impulses, system, carry, spans, .. } = joints;
    for &(k, first, len) in spans.iter() {
        let imp = &mut impulses[k];
        (imp.point, imp.angular) = (Vector::ZERO, Vector::ZERO);
        for i in first..first + len {
            match carry[i] {
                Carry::Point(n) => imp.point += n * system.acc[i],
                Carry::Angular(u) => imp.angular += u * system.acc[i],
                Carry::Axial => imp.axial = system.acc[i],
            }
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

/// Re-applies the accumulated impulses of the one-sided and driven rows (the equality rows'
/// are the system's).
fn warm<B: BodyStore + ?Sized>(pair: &mut Pair<B>, joint: &Joint, g: &Geometry, imp: &JointImpulses) {
    if let JointKind::Ball { cone: Some(c) } = joint.kind
        && let Some((row, _)) = cone(g, c)
    {
        pair.apply(&row, imp.limits[1]);
    }
    if let Some((row, _)) = axial(joint, g) {
        let spring = if matches!(joint.kind, JointKind::Distance { rod: false, .. }) { imp.axial } else { 0.0 };
        pair.apply(&row, spring + imp.motor + imp.limits[0] - imp.limits[1]);
    }
}

/// One solve (with position feedback `soft`) or relax pass of a joint's one-sided and driven
/// rows: motor and spring, then limits (Box2D's order; the equality rows, the stiffest, come
/// after all of these).
fn solve<B: BodyStore + ?Sized>(
    pair: &mut Pair<B>,
    joint: &Joint,
    g: &Geometry,
    imp: &mut JointImpulses,
    soft: Soft,
    pass: JointPass,
    h: Scalar,
) {
    let limits = match joint.kind {
        JointKind::Hinge { limits, .. } | JointKind::Slider { limits, .. } => limits,
        JointKind::Distance { range, .. } => Some(range),
        _ => None,
    };
    if let Some((row, value)) = axial(joint, g) {
        if let JointKind::Hinge { motor: Some(m), .. } | JointKind::Slider { motor: Some(m), .. } = joint.kind {
            pair.motor(&row, m.speed, &mut imp.motor, m.max * h);
        }
        // Its own spring, solved with position feedback only (one implicit step a substep).
        if let (JointKind::Distance { spring: Some(s), .. }, JointPass::Solve) = (joint.kind, pass) {
            let spring = Soft::new(s.frequency, s.damping_ratio, h);
            pair.equal(&row, value - joint.length, &mut imp.axial, spring);
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
    arrange(joints, true);
}

/// Sorts the joints, their ends set, into anchored ones (`anchored`, when `write_out`), those
/// of the system and those with one-by-one rows, for a new step.
pub(super) fn arrange(joints: &mut Joints, write_out: bool) {
    let n = joints.joints.len();
    joints.impulses.resize(n, JointImpulses::default());
    joints.geometry.resize(n, Geometry::default());
    let Joints {
        joints: list,
        impulses,
        ends,
        anchored,
        general,
        limited,
        system,
        spans,
        carry,
        mixed,
        held,
        lone,
        rows,
        ..
    } = &mut *joints;
    anchored.clear();
    general.clear();
    lone.clear();
    rows.clear();
    // How many joints hold each free body: an anchored joint must be its body's only one.
    let free = |e: &End| e.free.then_some(e.slot as usize);
    let top = ends.iter().flatten().filter_map(free).max().map_or(0, |s| s + 1);
    held.clear();
    held.resize(top, 0);
    ends.iter().flatten().filter_map(free).for_each(|s| held[s] += 1);
    for (k, joint) in list.iter().enumerate() {
        let alone = write_out && ends[k].iter().filter_map(free).all(|s| held[s] == 1);
        // An anchored joint's rows are not the system's.
        let system_rows = match AnchoredJoint::of(k, joint, ends[k], &impulses[k]).filter(|_| alone) {
            Some(a) => {
                lone.push(a);
                0
            }
            None => {
                general.push(k as u32);
                equality_count(&joint.kind)
            }
        };
        rows.push(system_rows);
    }
    anchored.extend(lone.chunks(super::LANES).map(Anchored::new));
    limited.clear();
    limited.extend((0..n as u32).filter(|&k| one_by_one(&list[k as usize].kind)));
    system.set_nodes(ends, rows.iter().copied());
    spans.clear();
    spans.extend(system.spans().map(|(k, r)| (k, r.start, r.len())));
    carry.resize(system.rows.len(), Carry::Axial);
    *mixed = !limited.is_empty();
    (joints.stale, joints.rows_valid) = (true, false);
}
