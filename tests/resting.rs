//! Resting contact, friction and stacking (issue #8): a block on a slope sticks or slides as
//! Coulomb says, a dropped box comes to rest and stays, a tower of ten stands.

mod common;
use common::*;
use rigid_sandbox::math::Vector;

/// Runs `steps` steps and returns the block's position and velocity.
fn block_after(scene: &str, mu: f64, steps: u64) -> (Vector, Vector) {
    let mut sim = sim_of(scene, |d| d.actors.iter_mut().for_each(|a| a.friction = mu));
    sim.run(steps).expect("finite");
    let b = actor(&sim, "block");
    (b.pose.position, b.velocity.linear)
}

#[test]
fn a_block_sticks_on_a_slope_shallower_than_atan_mu() {
    // θ = 20°, tan θ = 0.364 < μ = 0.5: static friction holds it; drift under 1 mm in 2 s.
    let start = actor(&sim_of("slope-stick.ron", |_| {}), "block").pose.position;
    let (end, v) = block_after("slope-stick.ron", 0.5, 120);
    assert!((end - start).length() < 1e-3, "drifted {} m", (end - start).length());
    assert!(v.length() < 1e-3, "still moving at {v}");
}

#[test]
fn a_block_slides_down_a_steeper_slope_at_the_coulomb_acceleration() {
    // tan θ = 0.364 > μ = 0.2: a = g(sin θ − μ cos θ) along the slope, within 2 %.
    let theta = 20f64.to_radians();
    let want = 9.81 * (theta.sin() - 0.2 * theta.cos());
    let down = Vector::new(-theta.cos(), -theta.sin(), 0.0);
    let (_, v1) = block_after("slope-slide.ron", 0.2, 60);
    let (_, v2) = block_after("slope-slide.ron", 0.2, 120);
    // From the velocity gained between t = 1 s and t = 2 s (after any landing transient).
    let a = (v2 - v1).dot(down) / 1.0;
    assert!((a - want).abs() <= 0.02 * want, "a = {a}, want {want}");
    assert!(v2.dot(Vector::new(-theta.sin(), theta.cos(), 0.0)).abs() < 1e-3, "stays on the slope: {v2}");
}

/// A fixed 20 m slope at `theta_deg` about z with a unit block of 1 kg resting on its top face,
/// both with friction `mu`, stepped at `dt`.
fn slope(theta_deg: f64, mu: f64, dt: f64) -> rigid_sandbox::sim::Sim {
    let t = theta_deg.to_radians();
    let at = Vector::new(-t.sin(), t.cos(), 0.0);
    sim_from_text(&format!(
        "Scene(dt: {dt:?}, actors: [\
           Actor(name: \"slope\", shape: Box(size: (20.0, 1.0, 20.0)), rotation: (0.0, 0.0, {theta_deg:?}), fixed: true, restitution: 0.0, friction: {mu:?}),\
           Actor(name: \"block\", shape: Box(size: (1.0, 1.0, 1.0)), mass: 1.0, rotation: (0.0, 0.0, {theta_deg:?}), position: ({:?}, {:?}, 0.0), restitution: 0.0, friction: {mu:?})])",
        at.x, at.y
    ))
}

#[test]
fn coulomb_holds_at_every_slope_angle_either_side_of_atan_mu() {
    // Slopes from 10° to 40° (a unit cube tips at 45°), μ 2 % either side of tan θ: 2 % more
    // holds the block within 1 mm over 2 s at 60 and 120 steps a second (the slip before the
    // first step's friction takes hold grows as dt²), 2 % less lets it slide at
    // g(sin θ − μ cos θ) within 2 %.
    for theta_deg in [10.0, 25.0, 40.0_f64] {
        let (t, dt) = (theta_deg.to_radians(), 1.0 / 60.0);
        let down = Vector::new(-t.cos(), -t.sin(), 0.0);
        for step in [dt, 1.0 / 120.0] {
            let mut sim = slope(theta_deg, 1.02 * t.tan(), step);
            let start = actor(&sim, "block").pose.position;
            sim.run((2.0 / step).round() as u64).expect("finite");
            let drift = (actor(&sim, "block").pose.position - start).length();
            assert!(drift < 1e-3, "θ = {theta_deg}°, dt = {step}: drifted {drift} m");
        }
        let mu = 0.98 * t.tan();
        let mut sim = slope(theta_deg, mu, dt);
        sim.run(60).expect("finite");
        let v1 = actor(&sim, "block").velocity.linear.dot(down);
        sim.run(60).expect("finite");
        let a = actor(&sim, "block").velocity.linear.dot(down) - v1;
        let want = 9.81 * (t.sin() - mu * t.cos());
        assert!((a - want).abs() <= 0.02 * want, "θ = {theta_deg}°: a = {a}, want {want}");
    }
}

#[test]
fn a_dropped_box_comes_to_rest_flat_and_stays() {
    let mut sim = sim_of("box-drop.ron", |_| {});
    sim.run(60).expect("finite");
    let rest = actor(&sim, "box");
    assert!(
        rest.velocity.linear.length() < 1e-3 && rest.velocity.angular.length() < 1e-6,
        "at rest within 1 s: {:?}",
        rest.velocity
    );
    // It lands flat and stays flat, but for a small twist: the contact solver stops the four
    // corners one after another within a substep.
    let tilt = rest.pose.orientation.angle_between(rigid_sandbox::math::Quat::IDENTITY);
    assert!(tilt < 2e-4, "rotated by {tilt} rad");
    let penetration = 0.5 - rest.pose.position.y;
    assert!((0.0..1e-3).contains(&penetration), "penetration {penetration} m");
    for _ in 0..600 {
        sim.step().expect("finite");
        let b = actor(&sim, "box");
        assert!((b.pose.position - rest.pose.position).length() < 1e-5, "moved again at step {}", sim.steps);
    }
}

/// How far the top box of the shipped tower of ten moves in `steps` steps of `dt`.
fn tower_top_moved(dt: f64, steps: u64) -> f64 {
    let mut sim = sim_of("tower.ron", |d| d.dt = dt);
    let start = actor(&sim, "box-9").pose.position;
    sim.run(steps).expect("finite");
    (actor(&sim, "box-9").pose.position - start).length()
}

#[test]
fn a_tower_of_ten_boxes_stands_for_ten_seconds() {
    let moved = tower_top_moved(1.0 / 60.0, 600);
    assert!(moved < 0.01, "the top box moved {moved} m");
}

#[test]
fn a_tower_of_ten_stands_at_a_longer_step_too() {
    // At 1/30 s the default substeps double (`Params::substeps_for`), so the contacts are as
    // stiff as at 1/60 s and the tower sinks no deeper than there.
    let moved = tower_top_moved(1.0 / 30.0, 300);
    assert!(moved < 0.01, "the top box moved {moved} m");
}

#[test]
fn a_tower_of_twenty_boxes_does_not_buckle() {
    // On 30 Hz contacts (Box2D's and rapier's default) a tower this tall has less bending
    // stiffness than its weight's toppling moment and falls; at a quarter of the substep rate
    // it stands, sinking by its contacts' compliance only, and comes to rest.
    let mut sim = sim_of("tower.ron", |d| {
        let rigid_sandbox::scene::spawners::SpawnerDef::Grid { counts, .. } = &mut d.spawners[0] else {
            panic!("a grid")
        };
        counts.1 = 20;
    });
    let start = actor(&sim, "box-19").pose.position;
    sim.run(600).expect("finite");
    let top = actor(&sim, "box-19");
    assert!((top.pose.position - start).length() < 0.05, "the top box moved {}", top.pose.position - start);
    assert!((top.pose.position.x.abs()).max(top.pose.position.z.abs()) < 1e-6, "no lean: {}", top.pose.position);
    assert!(sim.totals().kinetic_energy < 1e-9, "at rest: {} J", sim.totals().kinetic_energy);
}

#[test]
fn a_rain_of_cubes_comes_to_rest_in_its_box() {
    // The rain scene of docs/benchmarks.md with 100 cubes: dropped from 10 m to 18 m, they land at
    // up to 19 m/s, pile up and are still within 10 s, none through the floor.
    let mut sim = sim_from_text("Scene(actors: [], spawners: [Rain(actors: 100, seed: 1)])");
    sim.run(600).expect("finite");
    let ke = sim.totals().kinetic_energy;
    assert!(ke < 1e-6, "kinetic energy {ke} J");
    let cubes: Vec<_> = sim.actors().into_iter().filter(|a| a.mass.inv_mass > 0.0).collect();
    assert_eq!(cubes.len(), 100);
    assert!(cubes.iter().all(|c| c.pose.position.y > 0.49), "none through the floor");
}

#[test]
fn a_box_bounces_at_its_restitution_and_lands_flat() {
    // A cube falls 1.5 m flat onto a frictionless floor with e = 0.5 for both: the impact
    // speed is reversed at each of the four corners alike, so it leaves at half the speed,
    // without turning.
    let floor = "Actor(name: \"floor\", shape: Box(size: (20.0, 1.0, 20.0)), position: (0.0, -0.5, 0.0), fixed: true, restitution: 0.5)";
    let cube = "Actor(name: \"box\", shape: Box(size: (1.0, 1.0, 1.0)), mass: 1.0, position: (0.0, 2.0, 0.0), restitution: 0.5)";
    let mut sim = sim_from_text(&format!("Scene(actors: [{floor}, {cube}])"));
    let (mut falling, mut rising) = (0.0_f64, None);
    for _ in 0..120 {
        let v = actor(&sim, "box").velocity.linear.y;
        sim.step().expect("finite");
        let after = actor(&sim, "box").velocity;
        if after.linear.y > 0.0 && rising.is_none() {
            (falling, rising) = (v, Some(after.linear.y));
            assert!(after.angular.length() < 1e-9, "no spin: {}", after.angular);
        }
    }
    let rising = rising.expect("it bounced");
    // The approach reversed is the speed when the impact step began (Box2D's rule).
    let want = -0.5 * falling;
    assert!((rising - want).abs() < 1e-9 * want, "left at {rising} m/s after {falling}, want {want}");
}

#[test]
fn without_gravity_and_friction_the_contact_solver_is_idle() {
    // The paper's model is the e = 1 / no-friction special case: solve does nothing there.
    let mut sim = sim_of("face-collision.ron", |_| {});
    sim.run(20).expect("finite");
    assert_eq!(sim.ctx.stats.held, 0);
    assert_eq!(sim.impulses, [1, 0, 0]);
}

/// The pyramid of docs/benchmarks.md with `base` rows, sleeping on.
fn sleeping_pyramid(base: u32) -> rigid_sandbox::sim::Sim {
    let mut sim =
        rigid_sandbox::scene::benchmarks::scene_sim(rigid_sandbox::scene::benchmarks::BenchScene::Pyramid, base, 1);
    sim.ctx.params.sleep = true;
    sim
}

#[test]
fn with_sleeping_on_a_settled_pyramid_falls_asleep_and_stays_exactly_put() {
    let mut sim = sleeping_pyramid(10);
    sim.run(120).expect("finite");
    let cubes = 1..sim.len();
    assert!(cubes.clone().all(|i| sim.ctx.sleep.asleep[i]), "all 55 cubes asleep after 2 s");
    assert!(!sim.ctx.sleep.asleep[0], "the fixed ground is not a sleeper");
    assert_eq!(sim.totals().kinetic_energy, 0.0);
    let before = sim.actors();
    sim.run(60).expect("finite");
    assert_eq!(sim.actors(), before, "asleep, nothing moves, not even by round-off");
    assert_eq!(sim.ctx.stats.held, 0, "no pair of sleeping cubes is solved");
}

#[test]
fn a_box_dropped_on_a_sleeping_box_wakes_it_and_both_sleep_again() {
    let floor = "Actor(name: \"floor\", shape: Box(size: (20.0, 1.0, 20.0)), position: (0.0, -0.5, 0.0), fixed: true, friction: 0.5, restitution: 0.0)";
    let cube = |name: &str, y: f64| {
        format!(
            "Actor(name: \"{name}\", shape: Box(size: (1.0, 1.0, 1.0)), mass: 1.0, position: (0.0, {y}, 0.0), friction: 0.5, restitution: 0.0)"
        )
    };
    let text = format!(
        "Scene(solver: Solver(sleep: true), actors: [{floor}, {}, {}])",
        cube("lower", 0.5),
        cube("upper", 12.0)
    );
    let mut sim = sim_from_text(&text);
    let lower = 1;
    sim.run(40).expect("finite");
    assert!(sim.ctx.sleep.asleep[lower], "the resting box sleeps within 40 steps");
    let mut woken_at = None;
    for _ in 0..200 {
        sim.step().expect("finite");
        if woken_at.is_none() && !sim.ctx.sleep.asleep[lower] {
            woken_at = Some(sim.steps);
        }
    }
    let woken_at = woken_at.expect("the falling box wakes the sleeping one");
    // It falls 11 m: about 1.5 s, step 90 or so from the start.
    assert!((80..110).contains(&woken_at), "woken at step {woken_at}");
    assert!(sim.ctx.sleep.asleep[lower] && sim.ctx.sleep.asleep[2], "both asleep again");
    let top = actor(&sim, "upper").pose.position;
    assert!((top - rigid_sandbox::math::Vector::new(0.0, 1.5, 0.0)).length() < 2e-3, "stacked: {top}");
}
