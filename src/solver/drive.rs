//! Carrying out the substeps' plan over the constraint groups, on one thread or two.

use super::{BodyStore, Sides, Softness, SolverBody};
use crate::math::{Scalar, Vector};
use crate::step::{ConstraintGroup, SolveScratch};

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
}

/// Runs `pass` on group `g` with its bodies `bodies`.
fn run<B: BodyStore + ?Sized>(pass: Pass, bodies: &mut B, g: &mut ConstraintGroup, h: Scalar) {
    match pass {
        Pass::Warm => super::warm_start(bodies, &g.batches, &mut g.points),
        Pass::Solve(soft) => super::sweep(bodies, &mut g.batches, &mut g.points, h, Some(soft)),
        Pass::Relax => super::sweep(bodies, &mut g.batches, &mut g.points, h, None),
        Pass::Restitution(threshold) => super::restitution(bodies, &g.batches, &mut g.points, threshold),
    }
}

/// Applies a body step to the free bodies of one side (its last slot is static).
fn apply(step: Step, side: &mut [SolverBody]) {
    let free = side.len() - 1;
    match step {
        Step::Push(dv) => side[..free].iter_mut().for_each(|b| b.v += dv),
        Step::Move(h) => side[..free].iter_mut().for_each(|b| {
            b.dx += b.v * h;
            b.dq += b.w * h;
        }),
        Step::Pass(_) => {}
    }
}

/// Carries out the plan. Each pass runs over the first side's constraints and the second's,
/// which share no free body and whose bodies are separate slices, then over the constraints
/// across. With two threads the second side runs on the other thread of the pool, handed its
/// slice for each pass and spinning between passes (a rayon join a pass cost more in waking
/// a worker than it saved). Either way the arithmetic is the same, so the result does not
/// depend on threads.
pub(crate) fn drive(s: &mut SolveScratch, plan: &[Step], h: Scalar) {
    let [first, second, across] = &mut s.groups;
    let (left, right) = s.bodies.split_at_mut(s.left + 1);
    let threaded = !second.batches.is_empty() && rayon::current_num_threads() > 1;
    if !threaded {
        for &step in plan {
            let Step::Pass(pass) = step else {
                apply(step, left);
                apply(step, right);
                continue;
            };
            run(pass, left, first, h);
            if !second.batches.is_empty() {
                run(pass, right, second, h);
            }
            if !across.batches.is_empty() {
                run(pass, &mut Sides { left: &mut *left, right: &mut *right }, across, h);
            }
        }
        return;
    }
    // Two of the pool's own threads, not a new one each step: a fresh thread lands on either
    // core, away from the cache that holds its side's constraints. `broadcast` runs the
    // closure on every thread of the pool at once; the calling thread drives the plan, the
    // next one solves the second side, any others return.
    let me = rayon::current_thread_index().unwrap_or(0);
    let helper_index = (me + 1) % rayon::current_num_threads();
    let (to_helper, work) = std::sync::mpsc::channel::<Option<(&mut [SolverBody], Pass)>>();
    let (to_main, done) = std::sync::mpsc::channel::<&mut [SolverBody]>();
    let helper = std::sync::Mutex::new(Some((second, work, to_main)));
    let main = std::sync::Mutex::new(Some((left, right, first, across, to_helper, done)));
    rayon::broadcast(|ctx| {
        if ctx.index() == helper_index {
            let taken = helper.lock().map(|mut h| h.take()).ok().flatten();
            let Some((second, work, to_main)) = taken else { return };
            while let Some(Some((right, pass))) = spin(&work) {
                run(pass, right, second, h);
                if to_main.send(right).is_err() {
                    return;
                }
            }
        } else if ctx.index() == me {
            let taken = main.lock().map(|mut m| m.take()).ok().flatten();
            let Some((left, right, first, across, to_helper, done)) = taken else { return };
            let mut right = right;
            for &step in plan {
                let Step::Pass(pass) = step else {
                    apply(step, left);
                    apply(step, right);
                    continue;
                };
                to_helper.send(Some((right, pass))).expect("the helper runs until told to stop");
                run(pass, left, first, h);
                right = spin(&done).expect("the helper hands the second side back");
                if !across.batches.is_empty() {
                    run(pass, &mut Sides { left: &mut *left, right: &mut *right }, across, h);
                }
            }
            // A failed send means the helper has stopped already (it panicked).
            let _ = to_helper.send(None);
        }
    });
}

/// The next message on `channel`, spinning while it is empty (a pass takes tens of
/// microseconds: parking the thread would cost more); `None` once the sender is gone.
fn spin<T>(channel: &std::sync::mpsc::Receiver<T>) -> Option<T> {
    loop {
        match channel.try_recv() {
            Ok(message) => return Some(message),
            Err(std::sync::mpsc::TryRecvError::Empty) => std::hint::spin_loop(),
            Err(std::sync::mpsc::TryRecvError::Disconnected) => return None,
        }
    }
}
