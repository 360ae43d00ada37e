//! A system written outside the crate: `wind` pushes every free body along +z with a constant
//! acceleration, inserted just before `integrate`. Run with
//! `cargo run --release --example custom_system`.

use rigid_sandbox::math::Vector;
use rigid_sandbox::{StepContext, System, cli, scene};

/// Wind acceleration [m/s²].
const WIND: Vector = Vector::new(0.0, 0.0, 0.5);

/// Adds `WIND · dt` to every free body's velocity. Systems change `ctx.bodies`, the step's
/// arrays; the step writes them to the world once, at its end.
fn wind(_world: &mut hecs::World, ctx: &mut StepContext) {
    let dt = ctx.dt;
    let b = &mut ctx.bodies;
    for i in 0..b.len() {
        if !b.is_fixed(i) {
            b.velocity[i] += WIND * dt;
        }
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (scene, path) = cli::load_scene(None)?; // the built-in demo
    let mut sim = scene::build(&scene, &path)?;
    sim.schedule.insert_before("integrate", System { name: "wind", run: wind })?;
    println!("schedule: {}", sim.schedule.names().join(" → "));
    sim.run(100)?;
    for a in sim.actors() {
        println!("{:>8}: z = {:+.4} m, v_z = {:+.4} m/s", a.name, a.pose.position.z, a.velocity.linear.z);
    }
    // After 1 s of wind every free body has gained 0.5 m/s along z (no collision acts along z).
    Ok(())
}
