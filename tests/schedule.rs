//! Schedule surgery by name, and a system defined here, outside the crate, running in its
//! place with the same powers as the shipped ones.

mod common;
use common::*;
use rigid_sandbox::error::ScheduleError;
use rigid_sandbox::{PairState, StepContext, System, systems};

/// Runs of `census` and the pairs it saw (1000 per run plus the pairs).
static CENSUS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// A user system: records how many pairs it saw, and proves it ran after `cull` and before
/// `face` (no pair is `Found` yet).
fn census(_world: &mut hecs::World, ctx: &mut StepContext) {
    assert!(ctx.pairs.iter().all(|p| !matches!(p.state, PairState::Found(_) | PairState::Resolved(_))));
    CENSUS.fetch_add(1000 + ctx.pairs.len(), std::sync::atomic::Ordering::SeqCst);
}

/// A user system that stops everything: zeroes every velocity in `ctx.bodies`, which the step
/// stores back to the world.
fn freeze(_world: &mut hecs::World, ctx: &mut StepContext) {
    ctx.bodies.velocity.iter_mut().for_each(|v| *v = rigid_sandbox::math::Vector::ZERO);
}

#[test]
fn default_order_is_the_papers() {
    let names = systems::default_schedule().names();
    assert_eq!(
        names,
        [
            "cull",
            "prune",
            "face",
            "vertex",
            "edge",
            "gravity",
            "resolve",
            "solve",
            "correct",
            "sleep",
            "ccd",
            "integrate"
        ]
    );
}

#[test]
fn insert_replace_remove_by_name() {
    let mut s = systems::default_schedule();
    s.insert_before("face", System { name: "census", run: census }).expect("face exists");
    s.insert_after("integrate", System { name: "freeze", run: freeze }).expect("integrate exists");
    s.replace("cull", systems::find("cull_all_pairs").expect("shipped")).expect("cull exists");
    s.remove("prune").expect("prune exists");
    assert_eq!(
        s.names(),
        [
            "cull_all_pairs",
            "census",
            "face",
            "vertex",
            "edge",
            "gravity",
            "resolve",
            "solve",
            "correct",
            "sleep",
            "ccd",
            "integrate",
            "freeze"
        ]
    );
}

#[test]
fn unknown_and_duplicate_names_are_clear_errors() {
    let mut s = systems::default_schedule();
    let err = s.remove("cul").expect_err("no such system");
    assert!(matches!(&err, ScheduleError::Unknown { name, .. } if name == "cul"));
    let text = err.to_string();
    assert!(text.contains("unknown system 'cul'") && text.contains("cull, prune, face"), "{text}");
    let err = s.insert_after("face", systems::find("edge").expect("shipped")).expect_err("edge is there");
    assert_eq!(err, ScheduleError::Duplicate { name: "edge".into() });
    assert!(systems::find("nope").is_err());
}

#[test]
fn a_user_system_runs_in_its_place_and_can_change_the_outcome() {
    // The face-collision scene: its cubes' spheres overlap from step 1, their boxes do not.
    let mut sim = sim_of("face-collision.ron", |_| {});
    sim.schedule.insert_before("face", System { name: "census", run: census }).expect("face exists");
    sim.step().expect("finite");
    // The cubes are 0.0975 m apart, past the contact margin: `cull` dropped the pair by their
    // boxes, so no system after it saw a pair.
    assert_eq!(sim.ctx.stats.candidates, 0);
    assert_eq!(CENSUS.load(std::sync::atomic::Ordering::SeqCst), 1000, "census ran once, saw no pair");
    // Freezing at the start of every step stops the cubes: no impulse ever happens.
    let mut sim = sim_of("face-collision.ron", |_| {});
    sim.schedule.insert_before("cull", System { name: "freeze", run: freeze }).expect("cull exists");
    sim.run(30).expect("finite");
    assert_eq!(sim.impulses, [0, 0, 0]);
    assert_eq!(actor(&sim, "a").pose.position.x, -1.0975);
}

#[test]
fn all_pairs_cull_and_no_prune_give_the_same_run() {
    // The paper's reference broad phase without the early-out: identical final states, for
    // mixed shapes and for boxes alone (which `prune` finishes with its box pass).
    for scene in ["mixed-shapes.ron", "dominoes.ron"] {
        let run = |edit: fn(&mut rigid_sandbox::Schedule)| {
            let mut sim = sim_of(scene, |_| {});
            edit(&mut sim.schedule);
            sim.run(300).expect("finite");
            rigid_sandbox::io::output::state_hash(&sim.actors())
        };
        let default = run(|_| {});
        let reference = run(|s| {
            s.replace("cull", systems::find("cull_all_pairs").expect("shipped")).expect("cull");
            s.remove("prune").expect("prune");
        });
        assert_eq!(default, reference, "{scene}");
    }
}

/// A user system that breaks a body: one velocity becomes NaN.
fn poison(_world: &mut hecs::World, ctx: &mut StepContext) {
    ctx.bodies.velocity[0].y = f64::NAN;
}

#[test]
fn the_nan_guard_names_a_user_system_among_those_it_need_not_check() {
    // The guard skips the bodies after a shipped system that never writes them (`prune`,
    // `face`, ...) once it has passed them in the step; a user system among those is checked.
    for after in ["cull", "prune", "face", "vertex"] {
        let mut sim = sim_of("face-collision.ron", |_| {});
        sim.schedule.insert_after(after, System { name: "poison", run: poison }).expect("shipped");
        let err = sim.step().expect_err("the guard stops the step");
        assert_eq!((err.system.as_str(), err.step, err.field), ("poison", 1, "velocity"), "after {after}");
    }
}

/// A user system that doubles every velocity: the bodies change between `cull` and `prune`.
fn double(_world: &mut hecs::World, ctx: &mut StepContext) {
    ctx.bodies.velocity.iter_mut().for_each(|v| *v *= 2.0);
}

/// Runs of `shared_speculative` and how many of them saw a body with a speculative distance.
static SHARED: [std::sync::atomic::AtomicUsize; 2] = [const { std::sync::atomic::AtomicUsize::new(0) }; 2];

/// A user system: the speculative distances the step shares between systems are those of the
/// bodies as they are now.
fn shared_speculative(_world: &mut hecs::World, ctx: &mut StepContext) {
    let (mut shared, mut direct) = (Vec::new(), Vec::new());
    ctx.speculative_distances(&mut shared);
    ctx.params.speculative_distances(ctx.dt, &ctx.bodies, &mut direct);
    assert_eq!(shared, direct, "step {}", ctx.step);
    SHARED[0].fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    SHARED[1].fetch_add(usize::from(direct.iter().any(|&d| d > 0.0)), std::sync::atomic::Ordering::SeqCst);
}

#[test]
fn speculative_distances_are_worked_out_again_after_a_user_system_moves_the_bodies() {
    // `cull` works them out and `prune` reuses them; `double` between changes every speed.
    let mut sim = sim_of("box-drop.ron", |_| {});
    sim.schedule.insert_after("cull", System { name: "double", run: double }).expect("cull exists");
    sim.schedule.insert_after("double", System { name: "check", run: shared_speculative }).expect("added");
    sim.schedule.insert_after("prune", System { name: "check again", run: shared_speculative }).expect("exists");
    sim.run(20).expect("finite");
    let [runs, moving] = [0, 1].map(|k| SHARED[k].load(std::sync::atomic::Ordering::SeqCst));
    assert_eq!(runs, 40);
    assert!(moving >= 30, "the falling box has a speculative distance: {moving} of {runs}");
}
