//! The pipeline's stages, one file each. The default schedule follows the paper's
//! "Algorithm Overview", one system per stage (ARCHITECTURE.md):
//!
//! 1. `cull` — bounding-sphere test gives candidate pairs (paper: bounding box check;
//!    docs/physics.md §1.2, erratum E1). A uniform grid; `cull_all_pairs` is the paper's O(N²)
//!    loop.
//! 2. `prune` — drops candidates that a separating plane proves apart, so the paper's tests
//!    below only see pairs they could fire on (they still decide every contact).
//! 3. `face` — triangle centroids inside the other body (§1.3, errata E2, E3).
//! 4. `vertex` — vertices inside the other body (§1.4, E5).
//! 5. `edge` — edges crossing the other body (§1.5, E4). First hit wins per pair (§1.6, E6).
//! 6. `gravity` — external forces change velocities (semi-implicit Euler, first half).
//! 7. `resolve` — impulse sweeps over the impacts (§2.5, errata E9–E13), where `solve` is idle.
//! 8. `solve` — resting contact, friction and impacts under gravity: clipped manifolds,
//!    clamped accumulated impulses, warm starting, a substepped soft step (the paper's future
//!    work; idle without gravity and friction).
//! 9. `correct` — positional correction of penetration (§2.6, E14).
//! 10. `sleep` — bodies still for half a second sleep until touched in motion (off unless
//!     `Params::sleep`). Before `integrate`, which the paper's stages end with (docs/cli.md).
//! 11. `ccd` — bodies fast enough to pass through others are swept to their time of impact
//!     and bounce there (§6.7); idle unless a body is that fast.
//! 12. `integrate` — poses from velocities, through the rest of the step for bodies `ccd`
//!     moved; angular momentum kept (§2.7, E15, E16).

mod ccd;
mod correct;
mod cull;
mod edge;
mod face;
mod gravity;
mod integrate;
mod prune;
mod resolve;
mod sleep;
mod solve;
mod vertex;

pub use ccd::{CcdScratch, ccd, friction_impulse};
pub use correct::{correct, correction};
pub use cull::{cull, cull_all_pairs, spheres_overlap};
pub use edge::{edge, edge_contact};
pub use face::{face, face_contact};
pub use gravity::gravity;
pub use integrate::{integrate, rotate_free};
pub use prune::{prune, separated};
pub use resolve::{BodyState, approach_speed, collision_impulse, resolve, state};
pub use sleep::sleep;
pub use solve::solve;
pub use vertex::{vertex, vertex_contact};

use crate::error::ScheduleError;
use crate::sim::schedule::{Schedule, System, SystemFn};

/// Every shipped system, by name. `find` looks them up; a scene's `schedule` and the CLI's
/// `--schedule` name them.
pub const REGISTRY: &[System] = &[
    System { name: "cull", run: cull },
    System { name: "cull_all_pairs", run: cull_all_pairs },
    System { name: "prune", run: prune },
    System { name: "face", run: face },
    System { name: "vertex", run: vertex },
    System { name: "edge", run: edge },
    System { name: "gravity", run: gravity },
    System { name: "resolve", run: resolve },
    System { name: "solve", run: solve },
    System { name: "correct", run: correct },
    System { name: "sleep", run: sleep },
    System { name: "ccd", run: ccd },
    System { name: "integrate", run: integrate },
];

/// The shipped systems that never write `ctx.bodies` (they read the bodies and write pairs,
/// posed meshes and their own scratch): `Schedule::leave_bodies`.
const LEAVE_BODIES: [SystemFn; 6] = [cull, cull_all_pairs, prune, face, vertex, edge];

/// The default order (see the module docs).
pub const DEFAULT_ORDER: &[&str] =
    &["cull", "prune", "face", "vertex", "edge", "gravity", "resolve", "solve", "correct", "sleep", "ccd", "integrate"];

/// The shipped system called `name`.
pub fn find(name: &str) -> Result<System, ScheduleError> {
    REGISTRY.iter().copied().find(|s| s.name == name).ok_or_else(|| ScheduleError::Unknown {
        name: name.to_string(),
        valid: REGISTRY.iter().map(|s| s.name.to_string()).collect(),
    })
}

/// A schedule of shipped systems in the given order.
pub fn schedule_of<S: AsRef<str>>(names: &[S]) -> Result<Schedule, ScheduleError> {
    let systems = names.iter().map(|n| find(n.as_ref())).collect::<Result<Vec<_>, _>>()?;
    let mut schedule = Schedule::new(systems)?;
    schedule.leave_bodies(&LEAVE_BODIES);
    Ok(schedule)
}

/// The default schedule: `cull, prune, face, vertex, edge, gravity, resolve, solve, correct,
/// sleep, ccd, integrate`.
#[must_use]
pub fn default_schedule() -> Schedule {
    schedule_of(DEFAULT_ORDER).expect("the registry holds every default name once")
}
