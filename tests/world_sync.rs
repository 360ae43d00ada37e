//! One load and one store a step: systems work on `ctx.bodies`, and the world is written once,
//! at the end of the step. A custom system that edits the world says so with `ctx.reload`, and
//! one that reads it mid-step asks for it with `ctx.sync_world`.

use rigid_sandbox::math::Vector;
use rigid_sandbox::{Sim, StepContext, System, Velocity, scene};

/// One free unit cube, no gravity, moving at 1 m/s along x; nothing to collide with.
fn drifting_cube() -> Sim {
    let text = "Scene(dt: 0.125, gravity: (0.0, 0.0, 0.0), actors: [
        Actor(name: \"cube\", shape: Box(size: (1.0, 1.0, 1.0)), mass: 1.0, velocity: (1.0, 0.0, 0.0)),
    ])";
    let path = std::path::Path::new("inline.ron");
    scene::build(&scene::parse(text, path).expect("valid"), path).expect("builds")
}

/// Sets the cube's velocity to (0, 2, 0) in the world only.
fn kick_world(world: &mut hecs::World, _ctx: &mut StepContext) {
    for v in world.query_mut::<&mut Velocity>() {
        v.linear = Vector::new(0.0, 2.0, 0.0);
    }
}

/// As `kick_world`, then re-reads the world into the step's bodies.
fn kick_world_and_reload(world: &mut hecs::World, ctx: &mut StepContext) {
    kick_world(world, ctx);
    ctx.reload(world);
}

/// Doubles the cube's speed in the step's bodies.
fn double_in_bodies(_world: &mut hecs::World, ctx: &mut StepContext) {
    ctx.bodies.velocity[0] *= 2.0;
}

fn with_system(run: rigid_sandbox::SystemFn) -> Sim {
    let mut sim = drifting_cube();
    sim.schedule.insert_before("integrate", System { name: "custom", run }).expect("integrate exists");
    sim.step().expect("finite");
    sim
}

#[test]
fn a_change_to_the_bodies_reaches_the_world_at_the_end_of_the_step() {
    let a = &with_system(double_in_bodies).actors()[0];
    assert_eq!(a.velocity.linear, Vector::new(2.0, 0.0, 0.0));
    assert_eq!(a.pose.position, Vector::new(0.25, 0.0, 0.0)); // integrated at 2 m/s for 1/8 s
}

#[test]
fn a_world_edit_without_reload_is_overwritten_by_the_store() {
    let a = &with_system(kick_world).actors()[0];
    assert_eq!(a.velocity.linear, Vector::new(1.0, 0.0, 0.0));
    assert_eq!(a.pose.position, Vector::new(0.125, 0.0, 0.0));
}

#[test]
fn a_world_edit_with_reload_is_what_later_systems_see() {
    let a = &with_system(kick_world_and_reload).actors()[0];
    assert_eq!(a.velocity.linear, Vector::new(0.0, 2.0, 0.0));
    assert_eq!(a.pose.position, Vector::new(0.0, 0.25, 0.0));
}

/// The world's x velocity when `peek` ran, in thousandths of m/s (statics are per test binary).
static SEEN: std::sync::atomic::AtomicI64 = std::sync::atomic::AtomicI64::new(-1);

fn peek_after_sync(world: &mut hecs::World, ctx: &mut StepContext) {
    ctx.sync_world(world);
    let v = world.query_mut::<&Velocity>().into_iter().next().expect("one cube").linear.x;
    SEEN.store((v * 1000.0) as i64, std::sync::atomic::Ordering::SeqCst);
}

#[test]
fn sync_world_shows_the_bodies_as_the_step_has_them_so_far() {
    let mut sim = drifting_cube();
    let run = |s: &mut rigid_sandbox::Schedule, name, run| {
        s.insert_before("integrate", System { name, run }).expect("integrate exists");
    };
    run(&mut sim.schedule, "double", double_in_bodies);
    run(&mut sim.schedule, "peek", peek_after_sync);
    sim.step().expect("finite");
    assert_eq!(SEEN.load(std::sync::atomic::Ordering::SeqCst), 2000);
}
