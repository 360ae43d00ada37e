//! Running a scene: `Sim` owns the world, the step context and the schedule; a step loads the
//! bodies into plain arrays once, runs the systems in order, and stores them back once.

pub mod bodies;
pub mod context;
pub mod params;
pub mod schedule;
mod simulation;

pub use simulation::{ActorState, BodyDef, Sim, Totals, totals};
