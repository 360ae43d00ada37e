//! rigid-sandbox: a rigid-body dynamics sandbox after the paper "Rigid Body Dynamics
//! Simulator Sandbox" (Phipps, Narayanan), with its errors corrected (docs/physics.md §2).
//!
//! Actors are `hecs` entities with `Mesh`, `MassProps`, `Velocity`, `BoundingSphere`, `Pose`,
//! `Material` and `Name` components. Each step loads them into plain arrays once, runs an
//! ordered list of named systems (`systems::default_schedule`) mirroring the paper's
//! pipeline, and stores them back once (ARCHITECTURE.md):
//!
//! 1. `cull`: bounding spheres give candidate pairs;
//! 2. `prune`: candidates a separating axis proves apart are dropped (an early-out);
//! 3. `face`, 4. `vertex`, 5. `edge`: the paper's three detection tests, first hit wins;
//! 6. `gravity`: external forces change velocities;
//! 7. `resolve`: the corrected impulse on each impact (the paper's model: no gravity, no
//!    friction);
//! 8. `solve`: resting contact, friction and impacts under gravity (idle without either);
//! 9. `correct`: positional correction of penetration;
//! 10. `sleep`: still bodies stop being simulated (off unless `Params::sleep`);
//! 11. `integrate`: poses advance.
//!
//! The code is in one folder per part: `model` (what an actor is), `collision`, `sim` (the
//! step), `solver` (the contact solver), `systems` (the stages), `scene`, `io` and `cli`.
//!
//! ```
//! use rigid_sandbox::scene;
//! // docs/physics.md §4 (a): two unit cubes head-on, e = 1: they exchange velocities.
//! let text = r#"Scene(dt: 0.01, gravity: (0.0, 0.0, 0.0), actors: [
//!     Actor(name: "a", shape: Box(size: (1.0, 1.0, 1.0)), mass: 1.0, restitution: 1.0,
//!           position: (-1.0975, 0.0, 0.0), velocity: (1.0, 0.0, 0.0)),
//!     Actor(name: "b", shape: Box(size: (1.0, 1.0, 1.0)), mass: 1.0, restitution: 1.0),
//! ])"#;
//! let path = std::path::Path::new("inline.ron");
//! let mut sim = scene::build(&scene::parse(text, path)?, path)?;
//! sim.run(20)?;
//! let actors = sim.actors();
//! assert_eq!(actors[0].velocity.linear.x, 0.0);
//! assert_eq!(actors[1].velocity.linear.x, 1.0);
//! assert_eq!(sim.impulses, [1, 0, 0]); // one impulse, found by the face test
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]
#![forbid(unsafe_code)]
// Scene errors carry the file's text for miette's snippet; they are built once, on the way out
// of a failed command, so their size costs nothing where it matters.
#![allow(clippy::result_large_err)]

pub mod cli;
pub mod collision;
pub mod error;
pub mod io;
pub mod math;
pub mod model;
pub mod rng;
pub mod scene;
pub mod sim;
pub mod solver;

/// The pipeline's stages, one file each, kept in the top-level `systems/` folder.
// The crate's only `#[path]`: the design card keeps `systems/` beside `src/` (ARCHITECTURE.md).
#[path = "../systems/mod.rs"]
pub mod systems;

pub use collision::contact::{Contact, Feature, Pair, PairState};
pub use collision::posed::Posed;
pub use model::components::{ActorIndex, BoundingSphere, MassProps, Material, Mesh, Name, Pose, Velocity};
pub use model::mesh::{ConvexMesh, MeshId, MeshTable};
pub use sim::Sim;
pub use sim::context::{Params, StepContext};
pub use sim::schedule::{Schedule, StepProfile, System, SystemFn};

/// The README's examples compile and run as doc-tests, so a stale example fails `cargo test`.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
