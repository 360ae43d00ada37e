//! `sleep`: bodies that have been still for a while stop being simulated until something that
//! touches them moves (`Params::sleep`, off by default and in `rigid bench` unless `--sleep`).
//! A sleeping body is fixed for every other system (`StepContext::reload` zeroes its inverse
//! mass and inertia in the snapshot), so a settled pile costs no contact solving and cannot
//! creep; pairs of two sleeping bodies are not even tested.

use crate::math::Vector;
use crate::sim::context::{SleepState, StepContext};
use hecs::World;

/// Below this speed [m/s] (linear, and of the bounding sphere's rim) a body counts as still.
/// Above Box2D's 0.01 m/s: a tall pyramid on soft contacts sways slowly, which must not keep
/// it awake.
pub const STILL_SPEED: f64 = 0.05;

/// A body still for this long [s], with every moving body it touches also still as long,
/// falls asleep (Box2D's default).
pub const TIME_TO_SLEEP: f64 = 0.5;

/// A sleeping body wakes when a body touching it moves faster than this [m/s].
pub const WAKE_SPEED: f64 = 2.0 * STILL_SPEED;

/// Puts still bodies to sleep and wakes sleeping ones that something touches in motion.
///
/// - Reads: `ctx.pairs` (every pair the broad phase and `prune` kept: touching or about to),
///   `ctx.bodies`, `ctx.params.sleep`.
/// - Writes: `ctx.sleep`; the velocities of bodies falling asleep (zeroed).
/// - Paper: none (the paper's bodies never come to rest).
/// - Cost: O(N + P) for N bodies and P pairs.
pub fn sleep(_world: &mut World, ctx: &mut StepContext) {
    let n = ctx.bodies.len();
    if !ctx.params.sleep {
        ctx.sleep = SleepState::default();
        return;
    }
    ctx.sleep.resize(n);
    let (b, s, dt) = (&mut ctx.bodies, &mut ctx.sleep, ctx.dt);
    // Free means simulated this step: neither fixed nor asleep (both have zero inverse mass).
    // Speeds include the bounding sphere's rim: a spinning wheel is not still.
    // And how far the body travelled this step: a box falling onto a sleeping one at 14 m/s is
    // stopped within the step by a speculative contact and ends it at rest, yet it hit hard.
    s.reached.resize(n, Vector::NAN);
    s.speed.clear();
    s.speed.extend((0..n).map(|i| {
        let reached = b.position[i] + b.velocity[i] * dt;
        let moved = if s.reached[i].is_nan() { 0.0 } else { (reached - s.reached[i]).length() / dt };
        s.reached[i] = reached;
        let free = b.inv_mass[i] > 0.0;
        if free { (b.velocity[i].length() + b.angular_velocity[i].length() * b.radius[i]).max(moved) } else { 0.0 }
    }));
    // Wake a sleeping body that a free one touches in motion. It moves from the next step on,
    // and wakes its own sleeping neighbours once it moves in turn.
    for p in &ctx.pairs {
        for (sleeper, other) in [(p.a as usize, p.b as usize), (p.b as usize, p.a as usize)] {
            if s.asleep[sleeper] && s.speed[other] > WAKE_SPEED {
                s.asleep[sleeper] = false;
                s.still[sleeper] = 0.0;
            }
        }
    }
    // How long each free body has been still.
    for i in (0..n).filter(|&i| b.inv_mass[i] > 0.0) {
        s.still[i] = if s.speed[i] < STILL_SPEED { s.still[i] + dt } else { 0.0 };
    }
    // A body still long enough sleeps, unless it touches a free body that is not: a box on a
    // sliding block stays awake with it, and a settling pile falls asleep together.
    s.ready.clear();
    s.ready.extend((0..n).map(|i| b.inv_mass[i] > 0.0 && s.still[i] >= TIME_TO_SLEEP));
    for p in &ctx.pairs {
        let (ia, ib) = (p.a as usize, p.b as usize);
        let restless = |i: usize| b.inv_mass[i] > 0.0 && s.still[i] < TIME_TO_SLEEP;
        if restless(ib) {
            s.ready[ia] = false;
        }
        if restless(ia) {
            s.ready[ib] = false;
        }
    }
    for i in (0..n).filter(|&i| s.ready[i]) {
        s.asleep[i] = true;
        b.velocity[i] = Vector::ZERO;
        b.angular_velocity[i] = Vector::ZERO;
    }
}
