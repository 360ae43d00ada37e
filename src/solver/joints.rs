//! Joints (docs/joints.md): what each kind holds, fixed to its bodies as the scene starts, and
//! how far each is from holding it (`Joint::errors`). The joint set lives in the scratch store
//! (`ctx.scratch.get::<Joints>()`), put there by `scene::build`; the `solve` system solves it
//! together with the contacts (`joint_pass`), and `cull` skips the pairs it joins.

use crate::math::{Quat, Scalar, Vector};

/// A motor: drives a hinge's turning speed [rad/s] or a slider's sliding speed [m/s] within a
/// largest torque [N·m] or force [N].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motor {
    /// Target speed of A relative to B about or along the axis [rad/s or m/s].
    pub speed: Scalar,
    /// Largest torque or force it applies [N·m or N].
    pub max: Scalar,
}

/// A damped spring: its natural frequency on the row's effective mass and its damping ratio.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spring {
    /// Natural frequency [Hz].
    pub frequency: Scalar,
    /// Damping ratio (1: critical).
    pub damping_ratio: Scalar,
}

/// What a joint holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointKind {
    /// The anchor points of both bodies together; with a cone, the swing of A's cone axis
    /// (from the anchor to A's centre at the start) from B's within `cone` [rad].
    Ball {
        /// Largest swing [rad].
        cone: Option<Scalar>,
    },
    /// A ball joint that only turns about the axis; the turn of A relative to B from the
    /// start within `limits` [rad], driven by `motor`.
    Hinge {
        /// Lowest and highest turn [rad].
        limits: Option<[Scalar; 2]>,
        /// The motor.
        motor: Option<Motor>,
    },
    /// No turning, and the anchors together but for sliding along the axis; the slide of A
    /// relative to B within `limits` [m], driven by `motor`.
    Slider {
        /// Lowest and highest slide [m].
        limits: Option<[Scalar; 2]>,
        /// The motor.
        motor: Option<Motor>,
    },
    /// The bodies welded as they start.
    Fixed,
    /// The anchors' distance: held at the start distance (a rod) when `rod`, kept within
    /// `[min, max]` (a rope when only `max` binds), and pulled to the start distance by
    /// `spring`.
    Distance {
        /// Hold the start distance exactly.
        rod: bool,
        /// Shortest and longest distance [m] (0 and ∞ when unbounded).
        range: [Scalar; 2],
        /// The spring towards the start distance.
        spring: Option<Spring>,
    },
}

impl JointKind {
    /// The kind's name as written in scene files.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Ball { .. } => "Ball",
            Self::Hinge { .. } => "Hinge",
            Self::Slider { .. } => "Slider",
            Self::Fixed => "Fixed",
            Self::Distance { .. } => "Distance",
        }
    }
}

/// A joint between actors `a` and `b` (or `a` and the world), its anchors and axes fixed to
/// the bodies as they stood at the start.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// Name (unique among the joints).
    pub name: String,
    /// Actor index of A.
    pub a: u32,
    /// Actor index of B, or `None` for the world.
    pub b: Option<u32>,
    /// What it holds.
    pub kind: JointKind,
    /// The two bodies still collide with each other.
    pub collide: bool,
    /// Anchor on A, A's body frame [m].
    pub anchor_a: Vector,
    /// Anchor on B, B's body frame (world frame for the world) [m].
    pub anchor_b: Vector,
    /// The joint's axis (hinge, slider; a ball joint's cone axis) in A's body frame.
    pub axis_a: Vector,
    /// The same axis in B's body frame (world frame for the world).
    pub axis_b: Vector,
    /// A's orientation relative to B's at the start, q_b⁻¹ q_a.
    pub rest: Quat,
    /// The anchors' distance at the start [m].
    pub length: Scalar,
}

/// A body's pose: centre of mass and orientation.
pub type Frame = (Vector, Quat);

impl Joint {
    /// A joint of `kind` between A at pose `pa` and B at pose `pb` (identity for the world),
    /// with anchors `anchor_a`, `anchor_b` and `axis` in world coordinates at the start (the
    /// axis need not be unit; a ball joint's cone axis is found here).
    #[must_use]
    pub fn new(
        name: String,
        ends: (u32, Option<u32>),
        kind: JointKind,
        anchors: [Vector; 2],
        axis: Vector,
        poses: [Frame; 2],
    ) -> Self {
        let [(xa, qa), (xb, qb)] = poses;
        let axis = match kind {
            // The limb's direction: from the joint to A's centre.
            JointKind::Ball { .. } => (xa - anchors[0]).try_normalize().unwrap_or(Vector::Y),
            _ => axis.try_normalize().unwrap_or(Vector::X),
        };
        Self {
            name,
            a: ends.0,
            b: ends.1,
            kind,
            collide: false,
            anchor_a: qa.inverse() * (anchors[0] - xa),
            anchor_b: qb.inverse() * (anchors[1] - xb),
            axis_a: qa.inverse() * axis,
            axis_b: qb.inverse() * axis,
            rest: (qb.inverse() * qa).normalize(),
            length: (anchors[0] - anchors[1]).length(),
        }
    }

    /// How far the joint is from holding at these poses of A and B (identity for the world):
    /// (position error [m], angle error [rad]). Limits count by how far they are exceeded; a
    /// spring's stretch is no error.
    #[must_use]
    pub fn errors(&self, pa: Frame, pb: Frame) -> (Scalar, Scalar) {
        let g = Geometry::new(self, pa, pb);
        let excess = |x: Scalar, [lo, hi]: [Scalar; 2]| (lo - x).max(x - hi).max(0.0);
        match self.kind {
            JointKind::Ball { cone } => (g.d.length(), cone.map_or(0.0, |c| (g.u_a.angle_between(g.u_b) - c).max(0.0))),
            JointKind::Hinge { limits, .. } => {
                let tilt = g.u_a.angle_between(g.u_b);
                let turn = limits.map_or(0.0, |l| excess(g.turn(), l));
                (g.d.length(), tilt + turn)
            }
            JointKind::Slider { limits, .. } => {
                let slide = g.d.dot(g.u_b);
                let off = (g.d - g.u_b * slide).length();
                (off + limits.map_or(0.0, |l| excess(slide, l)), g.twist().length())
            }
            JointKind::Fixed => (g.d.length(), g.twist().length()),
            JointKind::Distance { rod, range, .. } => {
                let l = g.d.length();
                (if rod { (l - self.length).abs() } else { excess(l, range) }, 0.0)
            }
        }
    }
}

/// A joint's state at given poses, in world coordinates.
#[derive(Clone, Debug, Default)]
pub(crate) struct Geometry {
    /// The anchor's lever from A's centre.
    pub r_a: Vector,
    /// The anchor's lever from B's centre.
    pub r_b: Vector,
    /// p_a − p_b.
    pub d: Vector,
    /// The axis as fixed to A.
    pub u_a: Vector,
    /// The axis as fixed to B.
    pub u_b: Vector,
    /// A's orientation, and where B's orientation says A's should be.
    q_a: Quat,
    q_target: Quat,
}

impl Geometry {
    /// The geometry of `joint` with A at `pa` and B at `pb`.
    pub fn new(joint: &Joint, (xa, qa): Frame, (xb, qb): Frame) -> Self {
        let (r_a, r_b) = (qa * joint.anchor_a, qb * joint.anchor_b);
        let (p_a, p_b) = (xa + r_a, xb + r_b);
        // Only what the kind uses: a plain ball joint (a pendulum, a chain) needs its point alone.
        let (axis, rest) = match joint.kind {
            JointKind::Ball { cone } => (cone.is_some(), false),
            JointKind::Hinge { .. } | JointKind::Slider { .. } => (true, true),
            JointKind::Fixed => (false, true),
            JointKind::Distance { .. } => (false, false),
        };
        Self {
            r_a,
            r_b,
            d: p_a - p_b,
            u_a: if axis { qa * joint.axis_a } else { Vector::ZERO },
            u_b: if axis { qb * joint.axis_b } else { Vector::ZERO },
            q_a: qa,
            q_target: if rest { qb * joint.rest } else { Quat::IDENTITY },
        }
    }

    /// The rotation A has beyond where B's orientation says it should be, as a rotation
    /// vector (world frame; small-angle: twice the quaternion's vector part).
    pub fn twist(&self) -> Vector {
        let e = self.q_a * self.q_target.inverse();
        let e = if e.w < 0.0 { -e } else { e };
        2.0 * Vector::new(e.x, e.y, e.z)
    }

    /// A's turn about the axis (as fixed to B) relative to B since the start [rad], in
    /// (−π, π].
    pub fn turn(&self) -> Scalar {
        let e = self.q_a * self.q_target.inverse();
        let e = if e.w < 0.0 { -e } else { e };
        2.0 * Vector::new(e.x, e.y, e.z).dot(self.u_b).atan2(e.w)
    }
}

/// The scene's joints, in the scene's order, and what the solver keeps of each from step to
/// step (its impulses, to warm-start the next step).
#[derive(Clone, Debug, Default)]
pub struct Joints {
    /// The joints.
    pub joints: Vec<Joint>,
    /// Each joint's accumulated impulses of the last substep.
    pub impulses: Vec<JointImpulses>,
    /// The pairs (a < b) that a joint joins without `collide`, sorted: `cull` drops them.
    pub no_collide: Vec<(u32, u32)>,
    /// Scratch of the solver: each joint's ends this step, its geometry at the last refresh,
    /// and the equality rows solved together (`JointSystem`) with where each row's impulse is
    /// kept and which rows are whose ((joint, first row, rows)).
    pub(crate) ends: Vec<[super::joint_pass::End; 2]>,
    pub(crate) geometry: Vec<Geometry>,
    pub(crate) system: super::joint_system::JointSystem,
    pub(crate) carry: Vec<super::joint_pass::Carry>,
    pub(crate) spans: Vec<(usize, usize, usize)>,
    /// The lone ball joints to a fixed end, solved apart four at a time (`anchored`), in scene
    /// order; the other joints; those with rows solved one joint at a time (limits, motors...).
    pub(crate) anchored: Vec<super::anchored::Anchored>,
    pub(crate) general: Vec<u32>,
    pub(crate) limited: Vec<u32>,
    /// `arrange`'s per-step scratch, kept to spare three allocations a step: joints holding
    /// each free body, the lone anchored joints, each joint's rows in the system.
    pub(crate) held: Vec<u32>,
    pub(crate) lone: Vec<super::anchored::AnchoredJoint>,
    pub(crate) rows: Vec<usize>,
    /// The bodies moved since the last refresh; the rows hold impulses not yet stored.
    pub(crate) stale: bool,
    pub(crate) rows_valid: bool,
    /// Some joint has rows solved one joint at a time (a limit, motor, cone or distance).
    pub(crate) mixed: bool,
}

impl Joints {
    /// The set of `joints`, with no impulses yet.
    #[must_use]
    pub fn new(joints: Vec<Joint>) -> Self {
        let mut no_collide: Vec<(u32, u32)> =
            joints.iter().filter(|j| !j.collide).filter_map(|j| j.b.map(|b| (j.a.min(b), j.a.max(b)))).collect();
        no_collide.sort_unstable();
        no_collide.dedup();
        let impulses = vec![JointImpulses::default(); joints.len()];
        Self { joints, impulses, no_collide, ..Self::default() }
    }

    /// True when the pair (a < b) is joined by a joint that keeps them from colliding.
    #[must_use]
    pub fn keeps_apart(&self, a: u32, b: u32) -> bool {
        self.no_collide.binary_search(&(a, b)).is_ok()
    }

    /// Each joint's (position error [m], angle error [rad]) at the poses `poses` (by actor).
    #[must_use]
    pub fn errors(&self, poses: &[Frame]) -> Vec<(Scalar, Scalar)> {
        let world = (Vector::ZERO, Quat::IDENTITY);
        self.joints.iter().map(|j| j.errors(poses[j.a as usize], j.b.map_or(world, |b| poses[b as usize]))).collect()
    }
}

/// A joint's accumulated impulses over one substep, world frame where they are vectors, so
/// they carry over as the rows turn.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JointImpulses {
    /// On A at the anchor [N·s] (B takes the opposite): ball, hinge, fixed; the slider's two
    /// rows across its axis.
    pub point: Vector,
    /// Angular, on A [N·m·s]: the locked rotations.
    pub angular: Vector,
    /// Along the axis or the distance: a rod's or a spring's [N·s or N·m·s].
    pub axial: Scalar,
    /// The lower and upper limit (cone: the upper) [N·s or N·m·s], each ≥ 0.
    pub limits: [Scalar; 2],
    /// The motor [N·s or N·m·s].
    pub motor: Scalar,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hinge(axis: Vector) -> Joint {
        let kind = JointKind::Hinge { limits: None, motor: None };
        let start = [(Vector::X, Quat::IDENTITY), (Vector::ZERO, Quat::IDENTITY)];
        Joint::new("h".into(), (0, Some(1)), kind, [Vector::ZERO; 2], axis, start)
    }

    #[test]
    fn a_hinge_turn_is_right_handed_about_its_axis_and_zero_at_the_start() {
        let j = hinge(Vector::new(0.0, 2.0, 0.0));
        let b = (Vector::ZERO, Quat::IDENTITY);
        let at = |angle: Scalar| {
            let q = Quat::from_rotation_y(angle);
            Geometry::new(&j, (q * Vector::X, q), b)
        };
        assert_eq!(at(0.0).turn(), 0.0);
        for angle in [0.3, -1.2, 2.5] {
            let g = at(angle);
            assert!((g.turn() - angle).abs() < 1e-12, "{angle}: {}", g.turn());
            assert_eq!(j.errors((Quat::from_rotation_y(angle) * Vector::X, Quat::from_rotation_y(angle)), b).0, 0.0);
        }
    }

    #[test]
    fn errors_measure_the_anchor_gap_and_the_tilt() {
        let j = hinge(Vector::Y);
        let b = (Vector::ZERO, Quat::IDENTITY);
        let (gap, tilt) = j.errors((Vector::new(1.0, 0.25, 0.0), Quat::from_rotation_x(0.1)), b);
        assert!((gap - 0.25).abs() < 1e-12 && (tilt - 0.1).abs() < 1e-12, "{gap}, {tilt}");
    }

    #[test]
    fn only_joints_without_collide_keep_their_pair_apart() {
        let mut welded = hinge(Vector::Y);
        let joints = Joints::new(vec![welded.clone()]);
        assert!(joints.keeps_apart(0, 1) && !joints.keeps_apart(0, 2));
        welded.collide = true;
        assert!(!Joints::new(vec![welded]).keeps_apart(0, 1));
    }
}
