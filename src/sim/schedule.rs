//! The schedule: an ordered list of named systems, edited by name, run and timed by one
//! runner (ARCHITECTURE.md). Systems are plain functions, so a user's own system from outside the
//! crate has the same powers as the shipped ones.

use crate::error::{ScheduleError, StepError};
use crate::model::components::Name;
use crate::sim::context::StepContext;
use hecs::World;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// The signature of every system.
pub type SystemFn = fn(&mut World, &mut StepContext);

/// A named stage of the pipeline.
#[derive(Clone, Copy, Debug)]
pub struct System {
    /// Unique name in a schedule (`cull`, `face`, ...).
    pub name: &'static str,
    /// The function run each step.
    pub run: SystemFn,
}

/// Time spent in each part of one step; `rigid bench` averages these into `systems_ms`.
#[derive(Clone, Debug, Default)]
pub struct StepProfile {
    /// `begin_step`: clearing buffers and loading the bodies from the world.
    pub snapshot: Duration,
    /// `end_step`: storing the bodies back into the world.
    pub store: Duration,
    /// Each system, in run order.
    pub systems: Vec<(&'static str, Duration)>,
}

/// Ordered systems, run in sequence each step.
#[derive(Clone, Debug, Default)]
pub struct Schedule {
    systems: Vec<System>,
    /// Systems known never to write `ctx.bodies` (`leave_bodies`).
    readers: Vec<SystemFn>,
}

impl Schedule {
    /// A schedule of these systems, in order; names must be unique.
    pub fn new(systems: impl IntoIterator<Item = System>) -> Result<Self, ScheduleError> {
        let mut schedule = Self::default();
        for s in systems {
            schedule.push(s)?;
        }
        Ok(schedule)
    }

    /// Declares that these shipped systems never write `ctx.bodies`: once the NaN guard has
    /// passed the bodies in a step it does not look again after them, and what was worked out
    /// from the bodies stays fresh (`StepContext::bodies_changed`). Recognised by address: two
    /// functions share one only if their code is the same, so a user's system is always checked.
    pub(crate) fn leave_bodies(&mut self, runs: &[SystemFn]) {
        self.readers.extend_from_slice(runs);
    }

    fn leaves_bodies(&self, run: SystemFn) -> bool {
        self.readers.iter().any(|&f| std::ptr::fn_addr_eq(f, run))
    }

    /// Appends a system at the end.
    pub fn push(&mut self, system: System) -> Result<(), ScheduleError> {
        self.check_new(system.name)?;
        self.systems.push(system);
        Ok(())
    }

    /// Inserts `system` just before the system named `anchor`.
    pub fn insert_before(&mut self, anchor: &str, system: System) -> Result<(), ScheduleError> {
        let at = self.position(anchor)?;
        self.check_new(system.name)?;
        self.systems.insert(at, system);
        Ok(())
    }

    /// Inserts `system` just after the system named `anchor`.
    pub fn insert_after(&mut self, anchor: &str, system: System) -> Result<(), ScheduleError> {
        let at = self.position(anchor)?;
        self.check_new(system.name)?;
        self.systems.insert(at + 1, system);
        Ok(())
    }

    /// Puts `system` in the place of the one named `name` (it may keep or change the name).
    pub fn replace(&mut self, name: &str, system: System) -> Result<(), ScheduleError> {
        let at = self.position(name)?;
        if system.name != name {
            self.check_new(system.name)?;
        }
        self.systems[at] = system;
        Ok(())
    }

    /// Removes the system named `name` and returns it.
    pub fn remove(&mut self, name: &str) -> Result<System, ScheduleError> {
        let at = self.position(name)?;
        Ok(self.systems.remove(at))
    }

    /// The names, in run order.
    #[must_use]
    pub fn names(&self) -> Vec<&'static str> {
        self.systems.iter().map(|s| s.name).collect()
    }

    /// Runs one step: load the bodies from the world, every system in order, each timed into
    /// `profile`, then store the bodies back. After each system the NaN guard checks the
    /// bodies, so a bad state is stopped where it starts and named (system, actor, field)
    /// instead of spreading; the world then keeps the last good step.
    pub fn run(&self, world: &mut World, ctx: &mut StepContext, profile: &mut StepProfile) -> Result<(), StepError> {
        // A small scene's parallel parts are too short to wait for: keeping the other threads
        // awake would cost more than it saves.
        if ctx.bodies.len() < KEEP_AWAKE_MIN_BODIES {
            return self.run_systems(world, ctx, profile);
        }
        with_pool_awake(|| self.run_systems(world, ctx, profile))
    }

    fn run_systems(
        &self,
        world: &mut World,
        ctx: &mut StepContext,
        profile: &mut StepProfile,
    ) -> Result<(), StepError> {
        let start = Instant::now();
        ctx.begin_step(world);
        profile.snapshot = start.elapsed();
        profile.systems.clear();
        // Once the guard has passed the bodies, a shipped system that never writes them
        // leaves nothing new to check.
        let mut checked = false;
        for system in &self.systems {
            let start = Instant::now();
            (system.run)(world, ctx);
            profile.systems.push((system.name, start.elapsed()));
            let leaves = self.leaves_bodies(system.run);
            if !leaves {
                ctx.bodies_changed();
            }
            if checked && leaves {
                continue;
            }
            checked = true;
            if let Some((row, field)) = ctx.bodies.first_non_finite() {
                let actor =
                    world.get::<&Name>(ctx.bodies.entity[row]).map_or_else(|_| format!("#{row}"), |n| n.0.clone());
                return Err(StepError { step: ctx.step, system: system.name.to_string(), actor, field });
            }
        }
        let start = Instant::now();
        ctx.end_step(world);
        profile.store = start.elapsed();
        Ok(())
    }

    fn position(&self, name: &str) -> Result<usize, ScheduleError> {
        self.systems.iter().position(|s| s.name == name).ok_or_else(|| ScheduleError::Unknown {
            name: name.to_string(),
            valid: self.names().iter().map(ToString::to_string).collect(),
        })
    }

    fn check_new(&self, name: &str) -> Result<(), ScheduleError> {
        if self.systems.iter().any(|s| s.name == name) {
            return Err(ScheduleError::Duplicate { name: name.to_string() });
        }
        Ok(())
    }
}

/// Runs `f` on this pool thread while the pool's other threads stay awake, taking the step's
/// parallel work as soon as it is offered: otherwise they fall asleep in each serial part of the
/// step, and waking them costs more than many parallel parts take. Outside a pool, or in a pool
/// of one, `f` runs plainly. Results never depend on it: it changes only who runs the parts.
///
/// A kept-awake thread gives up after `MAX_IDLE` without work: in a pool stepping several sims
/// at once it may take up the spinning job inside work the stepper waits for, and must not spin
/// there for ever. One step in the process at a time keeps threads awake; others run plainly.
fn with_pool_awake<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    static KEEPING_AWAKE: AtomicBool = AtomicBool::new(false);
    let Some(me) = rayon::current_thread_index() else { return f() };
    if rayon::current_num_threads() < 2
        || KEEPING_AWAKE.compare_exchange(false, true, Ordering::AcqRel, Ordering::Acquire).is_err()
    {
        return f();
    }
    let _free = Release(&KEEPING_AWAKE, false);
    let done = AtomicBool::new(false);
    rayon::scope(|scope| {
        scope.spawn_broadcast(|_, thread| {
            if thread.index() == me {
                return;
            }
            let (mut idle_since, mut idle_rounds) = (None::<Instant>, 0_u32);
            while !done.load(Ordering::Acquire) {
                if rayon::yield_now() == Some(rayon::Yield::Executed) {
                    (idle_since, idle_rounds) = (None, 0);
                    continue;
                }
                idle_rounds = idle_rounds.wrapping_add(1);
                // Spin through a short gap; past it, offer the core to the system at every
                // round: on a machine busy with other work, a thread spinning while the stepping
                // thread waits for a core slows the step badly.
                if idle_rounds < SPIN_ROUNDS {
                    std::hint::spin_loop();
                } else {
                    std::thread::yield_now();
                }
                // The clock only now and then: reading it costs more than a round.
                if idle_rounds % 64 == 0 && idle_since.get_or_insert_with(Instant::now).elapsed() > MAX_IDLE {
                    return;
                }
            }
        });
        // Set on the way out even if `f` panics, or the scope would wait for the others forever.
        let _release = Release(&done, true);
        f()
    })
}

/// Bodies (as of the previous step) from which a step keeps the pool awake: below it, the
/// spinning threads cost more than they save.
const KEEP_AWAKE_MIN_BODIES: usize = 32;

/// Idle rounds a kept-awake thread spins before it starts yielding its core between rounds.
const SPIN_ROUNDS: u32 = 64;

/// How long a thread kept awake for a step spins without work before it sleeps: longer than
/// any serial part of a step of the benchmark scenes, short enough that a thread caught
/// spinning where it blocks others holds them up barely.
const MAX_IDLE: Duration = Duration::from_millis(1);

/// Sets its flag to the value it holds when dropped.
struct Release<'a>(&'a AtomicBool, bool);

impl Drop for Release<'_> {
    fn drop(&mut self) {
        self.0.store(self.1, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool")
    }

    #[test]
    fn the_awake_pool_runs_nested_parallel_work_and_lets_go() {
        for threads in [1, 2, 3] {
            let sum = pool(threads).install(|| {
                with_pool_awake(|| {
                    let (a, b) = rayon::join(|| (1..=1000_u64).into_par_iter().sum::<u64>(), || 7_u64);
                    let c = rayon::broadcast(|ctx| ctx.index() as u64).iter().sum::<u64>();
                    a + b + c
                })
            });
            assert_eq!(sum, 500_500 + 7 + (0..threads as u64).sum::<u64>(), "{threads} threads");
        }
        // Outside any pool it only calls `f`.
        assert_eq!(with_pool_awake(|| 3), 3);
    }

    #[test]
    fn a_panic_in_the_awake_pool_comes_out_instead_of_hanging() {
        let outcome = pool(2).install(|| {
            std::panic::catch_unwind(|| {
                with_pool_awake(|| {
                    (0..64).into_par_iter().for_each(|k| assert!(k != 40, "a system failed"));
                })
            })
        });
        assert!(outcome.is_err());
    }

    #[test]
    fn steps_run_side_by_side_in_one_pool_finish() {
        // Each item stands for a step of its own sim; without `MAX_IDLE` a kept-awake thread
        // could spin here for ever.
        let work = |k: u64| (0..2000_u64).map(|x| x ^ k).sum::<u64>();
        let total: u64 = pool(2).install(|| {
            (0..64_u64)
                .into_par_iter()
                .map(|k| with_pool_awake(|| (0..2000_u64).into_par_iter().map(|x| x ^ k).sum::<u64>()))
                .sum()
        });
        assert_eq!(total, (0..64).map(work).sum::<u64>());
    }
}
