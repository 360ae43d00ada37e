//! Helpers shared by the integration tests (public API only).
#![allow(dead_code)]

pub mod studio;

use rigid_sandbox::scene::instantiate::build;
use rigid_sandbox::scene::{self, SceneDef};
use rigid_sandbox::sim::{ActorState, Sim};
use std::path::{Path, PathBuf};

/// A file under `scenes/`.
pub fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

/// Loads `scenes/<name>`, lets the test edit it, builds the sim.
pub fn sim_of(name: &str, edit: impl FnOnce(&mut SceneDef)) -> Sim {
    let path = scene_path(name);
    let mut def = scene::load(&path).expect("shipped scenes parse");
    edit(&mut def);
    build(&def, &path).expect("shipped scenes build")
}

/// Builds a sim from inline RON.
pub fn sim_from_text(text: &str) -> Sim {
    let path = Path::new("inline.ron");
    build(&scene::parse(text, path).expect("test scene parses"), path).expect("test scene builds")
}

/// Steps until the first impulse (or panics after `max` steps); returns the step number.
pub fn run_until_impulse(sim: &mut Sim, max: u64) -> u64 {
    for _ in 0..max {
        sim.step().expect("finite");
        if sim.impulses.iter().sum::<u64>() > 0 {
            return sim.steps;
        }
    }
    panic!("no impulse within {max} steps");
}

/// The actor called `name`.
pub fn actor(sim: &Sim, name: &str) -> ActorState {
    sim.actors().into_iter().find(|a| a.name == name).unwrap_or_else(|| panic!("no actor '{name}'"))
}

/// Sets every actor's restitution.
pub fn set_restitution(def: &mut SceneDef, e: f64) {
    for a in &mut def.actors {
        a.restitution = e;
    }
}

/// Asserts |a − b| ≤ tol with a message.
#[track_caller]
pub fn assert_close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: got {a}, want {b} (tolerance {tol})");
}
