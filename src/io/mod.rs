//! What a run writes: final-state JSON and trajectory CSV, snapshots to resume from, rendered
//! frames, and glTF export.

pub mod export;
pub mod output;
pub mod render;
pub mod snapshot;
