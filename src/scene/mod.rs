//! Scenes: the RON format and its checks, spawners that expand into many actors, the
//! benchmark scenes, OBJ models, joints, building a `Sim` from a scene, and start-of-run
//! warnings.

pub mod benchmarks;
pub mod instantiate;
pub mod joints;
pub mod obj;
pub mod overrides;
mod schema;
pub mod spawners;
pub mod warnings;

pub use instantiate::{build, build_from_text};
pub use schema::*;
