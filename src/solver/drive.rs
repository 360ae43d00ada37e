//! Carrying out the substeps' plan over the constraint groups, on one thread or two.

use super::joint_pass::{JointPass, joint_pass, store_impulses};
use super::{BodyStore, Joints, Sides, Softness, SolverBody};
use crate::math::{Scalar, Vector};
use crate::solver::{ConstraintGroup, SolveScratch};

/// A pass of the kernel over a constraint group.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Pass {
    /// Re-apply the accumulated impulses.
    Warm,
    /// A solve sweep with this contact spring.
    Solve(Softness),
    /// The rigid relax sweep, with friction.
    Relax,
    /// Bounce the impacts faster than this [m/s].
    Restitution(Scalar),
}

/// One step of the substeps' plan.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Step {
    /// A pass over every group.
    Pass(Pass),
    /// Add this to every free body's velocity (gravity's share).
    Push(Vector),
    /// Move every free body on by its velocity over this time [s].
    Move(Scalar),
    /// Keep every free body's velocities, for the next `Repeat`.
    Keep,
    /// Start a substep by re-applying, body by body, what the last one applied: velocities v
    /// become v + (v − v_kept), and are kept. Over a substep a body's velocities change by
    /// gravity's share plus M⁻¹Jᵀλ for the rows' accumulated impulses λ (the warm start applies
    /// the λ of the substep before, each sweep its change), and levers and normals stay fixed
    /// through the step; so this is `Push` then `Pass(Warm)`, to rounding, without a pass over
    /// the constraints. Not for joints, whose passes alone warm-start them.
    Repeat,
}

/// The passes and body steps of `substeps` substeps of length `h`: each adds gravity's share
/// `push`, warm-starts, runs `sweeps(k)` solve sweeps with spring `soft` in substep k, moves
/// the bodies and relaxes. With `repeat`, substeps after the first take the push and the
/// warm start body by body (`Step::Repeat`); without (joints), by the passes.
pub(crate) fn substep_plan(
    substeps: u32,
    sweeps: impl Fn(u32) -> u32,
    (h, soft): (Scalar, Softness),
    push: Vector,
    repeat: bool,
) -> Vec<Step> {
    let mut plan = Vec::new();
    for k in 0..substeps {
        match (k, repeat) {
            (0, true) => plan.extend([Step::Keep, Step::Push(push), Step::Pass(Pass::Warm)]),
            (_, true) => plan.push(Step::Repeat),
            (_, false) => plan.extend([Step::Push(push), Step::Pass(Pass::Warm)]),
        }
        plan.extend((0..sweeps(k)).map(|_| Step::Pass(Pass::Solve(soft))));
        plan.extend([Step::Move(h), Step::Pass(Pass::Relax)]);
    }
    plan
}

/// Runs `pass` on `group` with its bodies `bodies`; `fresh`: the bodies have moved since the
/// last sweep, which must work the gaps out again (`kernel::sweep`).
fn run<B: BodyStore + ?Sized>(pass: Pass, bodies: &mut B, group: &mut ConstraintGroup, h: Scalar, fresh: bool) {
    match pass {
        Pass::Warm => super::warm_start(bodies, &group.batches, &mut group.points),
        Pass::Solve(soft) => super::sweep(bodies, &mut group.batches, &mut group.points, h, Some(soft), fresh),
        Pass::Relax => super::sweep(bodies, &mut group.batches, &mut group.points, h, None, fresh),
        Pass::Restitution(threshold) => {
            super::restitution(bodies, (&group.batches, &group.bouncing), &mut group.points, threshold);
        }
    }
}

/// Applies the body steps `steps` in order to the free bodies of one side (`apply`).
fn apply_all(steps: &[Step], side: &mut [SolverBody], kept: &mut [[Vector; 2]]) {
    for &step in steps {
        apply(step, side, kept);
    }
}

/// Applies a body step to the free bodies of one side (its last slot is static), with their
/// kept velocities `kept` (`Step::Keep`).
fn apply(step: Step, side: &mut [SolverBody], kept: &mut [[Vector; 2]]) {
    let free = side.len() - 1;
    match step {
        Step::Push(dv) => side[..free].iter_mut().for_each(|b| b.v += dv),
        Step::Move(h) => side[..free].iter_mut().for_each(|b| {
            b.dx += b.v * h;
            b.dq += b.w * h;
        }),
        Step::Keep => side[..free].iter().zip(kept.iter_mut()).for_each(|(b, k)| *k = [b.v, b.w]),
        Step::Repeat => side[..free].iter_mut().zip(kept.iter_mut()).for_each(|(b, k)| {
            let now = [b.v, b.w];
            (b.v, b.w) = (b.v + (b.v - k[0]), b.w + (b.w - k[1]));
            *k = now;
        }),
        Step::Pass(_) => {}
    }
}

/// Carries out the plan. Each pass runs over the first side's constraints and the second's,
/// which share no free body and whose bodies are separate slices, then over the constraints
/// across. With two threads the two sides run as a rayon join: this thread takes the side with
/// more constraints, which it built (`build_constraints`), and the pool's other thread, kept
/// awake through the step (`schedule`), takes the other at once, and when it is busy or
/// off its core (a machine loaded with other work) this thread runs both sides itself instead
/// of waiting. On one thread the sides' constraints are one group (`SolveScratch::merged`),
/// solved over all the bodies at once. Either way the arithmetic is the same, so the result
/// does not depend on threads.
/// After each pass over the contacts, the joints (if any) take theirs, in scene order, over
/// both sides' bodies (`joint_pass`): joints and contacts converge together.
pub(crate) fn drive(s: &mut SolveScratch, plan: &[Step], h: Scalar, joints: &mut Joints) {
    s.kept.resize(s.bodies.len(), [Vector::ZERO; 2]);
    let SolveScratch { groups: [first, second, across], bodies, kept, left: cut, merged, .. } = s;
    let (kept_left, kept_right) = kept.split_at_mut(*cut + 1);
    let threaded = !second.batches.is_empty() && rayon::current_num_threads() > 1;
    let second_first = super::constraints::second_side_first(first, second);
    // The gaps change only with a move: the first sweep after one works them out for the rest.
    let mut moved = true;
    // The body steps since the last pass (`plan[since..at]`), applied just before the next
    // one: with two threads each side's by the thread that runs its pass.
    let mut since = 0;
    for (at, &step) in plan.iter().enumerate() {
        let Step::Pass(pass) = step else {
            joints.stale |= matches!(step, Step::Move(_));
            moved |= matches!(step, Step::Move(_));
            continue;
        };
        let steps = &plan[since..at];
        since = at + 1;
        let fresh = moved && matches!(pass, Pass::Solve(_) | Pass::Relax);
        moved &= !fresh;
        let (left, right) = bodies.split_at_mut(*cut + 1);
        // A restitution pass with no batch to visit in any group (a pile at rest): only its
        // body steps, and no fork.
        let idle =
            matches!(pass, Pass::Restitution(_)) && [&*first, &*second, &*across].iter().all(|g| g.bouncing.is_empty());
        if *merged || idle {
            apply_all(steps, left, kept_left);
            apply_all(steps, right, kept_right);
            // Both sides' constraints in one group, numbered across both (`build_constraints`).
            if !idle {
                run(pass, &mut bodies[..], first, h, fresh);
                run(pass, &mut bodies[..], across, h, fresh);
            }
        } else {
            let mut left_side = || {
                apply_all(steps, left, kept_left);
                run(pass, left, first, h, fresh);
            };
            let mut right_side = || {
                apply_all(steps, right, kept_right);
                run(pass, right, second, h, fresh);
            };
            if threaded && second_first {
                rayon::join(right_side, left_side);
            } else if threaded {
                rayon::join(left_side, right_side);
            } else {
                left_side();
                right_side();
            }
            if !across.batches.is_empty() {
                run(pass, &mut Sides { left: &mut *left, right: &mut *right }, across, h, fresh);
            }
        }
        let joint = match pass {
            Pass::Warm => Some(JointPass::Warm),
            Pass::Solve(_) => Some(JointPass::Solve),
            Pass::Relax => Some(JointPass::Relax),
            Pass::Restitution(_) => Some(JointPass::Relax),
        };
        if let Some(joint) = joint.filter(|_| !joints.joints.is_empty()) {
            let (left, right) = bodies.split_at_mut(*cut + 1);
            joint_pass(&mut Sides { left, right }, joints, joint, h);
        }
    }
    let (left, right) = bodies.split_at_mut(*cut + 1);
    apply_all(&plan[since..], left, kept_left);
    apply_all(&plan[since..], right, kept_right);
    store_impulses(joints);
}
