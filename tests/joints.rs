//! Joints (issue #17, docs/joints.md): their physics against closed forms, their errors
//! through the binary, and their section of `--out`.

mod common;
use common::*;
use rigid_sandbox::math::{Quat, Vector};
use rigid_sandbox::sim::Sim;
use rigid_sandbox::solver::Joints;
use std::f64::consts::PI;
use std::process::{Command, Output};

/// Each joint's (position error, angle error) now.
fn errors(sim: &Sim) -> Vec<(f64, f64)> {
    let poses: Vec<(Vector, Quat)> = sim.actors().iter().map(|a| (a.pose.position, a.pose.orientation)).collect();
    sim.ctx.scratch.get::<Joints>().expect("the scene has joints").errors(&poses)
}

/// Times at which `x(t)` crosses zero upwards, interpolated between steps, over `steps`.
fn upward_crossings(sim: &mut Sim, steps: u64, x: impl Fn(&Sim) -> f64) -> Vec<f64> {
    let mut out = Vec::new();
    let (mut t0, mut x0) = (sim.time, x(sim));
    for _ in 0..steps {
        sim.step().expect("finite");
        let (t1, x1) = (sim.time, x(sim));
        if x0 < 0.0 && x1 >= 0.0 {
            out.push(t0 + (t1 - t0) * (-x0) / (x1 - x0));
        }
        (t0, x0) = (t1, x1);
    }
    out
}

/// The mean period between the first and last crossing.
fn period(crossings: &[f64]) -> f64 {
    assert!(crossings.len() >= 4, "too few crossings: {crossings:?}");
    (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64
}

#[test]
fn a_compound_pendulum_swings_with_its_period() {
    // A 1 × 0.1 × 0.1 rod hung by one end from a ball joint, 5° from hanging.
    let theta: f64 = 5.0;
    let (s, c) = (theta.to_radians().sin(), theta.to_radians().cos());
    let mut sim = sim_from_text(&format!(
        "Scene(steps: 0, actors: [Actor(name: \"rod\", shape: Box(size: (0.1, 1.0, 0.1)), mass: 2.0, \
         position: ({}, {}, 0.0), rotation: (0.0, 0.0, {theta}))], \
         joints: [Ball(a: \"rod\", anchor: (0.0, 2.0, 0.0))])",
        0.5 * s,
        2.0 - 0.5 * c
    ));
    let crossings = upward_crossings(&mut sim, 60 * 12, |sim| actor(sim, "rod").pose.position.x);
    let (m, d, g): (f64, f64, f64) = (2.0, 0.5, 9.81);
    let i_pivot = m * (1.0 + 0.01) / 12.0 + m * d * d;
    let want = 2.0 * PI * (i_pivot / (m * g * d)).sqrt();
    let got = period(&crossings);
    let error = (got - want).abs() / want;
    println!("pendulum period {got} s, closed form {want} s, error {:.4} %", 100.0 * error);
    assert!(error < 0.005, "period {got} s, want {want} s");
}

#[test]
fn welded_bodies_move_as_one() {
    // A handle welded to a pan, thrown tumbling with no gravity: their relative pose holds.
    let mut sim = sim_from_text(
        "Scene(gravity: (0.0, 0.0, 0.0), actors: [\
         Actor(name: \"pan\", shape: Box(size: (1.0, 0.1, 1.0)), mass: 3.0, velocity: (1.0, 0.5, 0.0), \
               angular_velocity: (2.0, 5.0, 1.0)),\
         Actor(name: \"handle\", shape: Box(size: (1.0, 0.1, 0.1)), mass: 0.5, position: (1.0, 0.0, 0.0))], \
         joints: [Fixed(a: \"handle\", b: \"pan\")])",
    );
    sim.run(300).expect("finite");
    let (pos, angle) = errors(&sim)[0];
    println!("weld after a tumble: {pos:e} m, {angle:e} rad");
    assert!(pos < 1e-3 && angle < 1e-3, "{pos} m, {angle} rad");
    // They spin together: the handle's angular velocity is the pan's, but for what each
    // body's own torque-free turn (`integrate`) adds after the joints were solved.
    let (p, h) = (actor(&sim, "pan"), actor(&sim, "handle"));
    let (wp, wh) = (p.velocity.angular, h.velocity.angular);
    assert!((wp - wh).length() < 0.05 * wp.length(), "{wp} vs {wh}");
}

fn rigid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("the binary runs")
}

/// Writes a scene with these joints (actors: `p`, `q`, fixed `floor`) and checks that both
/// commands reject it with exit 2 and every needle.
fn rejects(dir: &tempfile::TempDir, name: &str, joints: &str, needles: &[&str]) {
    let path = dir.path().join(name);
    let text = format!(
        "Scene(\n  actors: [\n    Actor(name: \"p\", shape: Box(size: (1.0, 1.0, 1.0))),\n    \
         Actor(name: \"q\", shape: Box(size: (1.0, 1.0, 1.0)), position: (3.0, 0.0, 0.0)),\n    \
         Actor(name: \"floor\", shape: Box(size: (1.0, 1.0, 1.0)), position: (0.0, -5.0, 0.0), fixed: true),\n  ],\n  \
         joints: [\n    {joints}\n  ],\n)"
    );
    std::fs::write(&path, text).expect("temp file");
    let p = path.to_str().expect("utf-8");
    for cmd in [vec!["check", p], vec!["run", p, "--quiet"]] {
        let o = rigid(&cmd);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name} via {}: {err}", cmd[0]);
        assert!(err.starts_with(&format!("error: {p}")), "{name}: names the file first: {err}");
        for needle in needles {
            assert!(err.contains(needle), "{name}: wants '{needle}' in: {err}");
        }
        assert!(!err.contains("panicked"), "{name}: {err}");
    }
}

#[test]
fn bad_joints_are_bad_input_naming_the_joint_and_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases = [
        (
            "unknown-a.ron",
            "Ball(name: \"j\", a: \"nobody\", anchor: (0.0, 0.0, 0.0))",
            &[":8:", "joint 'j'", "a:", "nobody"][..],
        ),
        (
            "unknown-b.ron",
            "Ball(a: \"p\", b: \"ghost\", anchor: (0.0, 0.0, 0.0))",
            &[":8:", "joint 'joint-0'", "b:", "ghost"],
        ),
        ("same.ron", "Fixed(name: \"w\", a: \"p\", b: \"p\")", &[":8:", "joint 'w'", "b:", "differ"]),
        ("both-fixed.ron", "Fixed(name: \"w\", a: \"floor\")", &[":8:", "joint 'w'", "fixed"]),
        (
            "zero-axis.ron",
            "Hinge(name: \"h\", a: \"p\", b: \"q\", anchor: (1.5, 0.0, 0.0), axis: (0.0, 0.0, 0.0))",
            &[":8:", "joint 'h'", "axis", "zero"],
        ),
        (
            "limits.ron",
            "Slider(a: \"p\", b: \"q\", anchor: (1.5, 0.0, 0.0), axis: (1.0, 0.0, 0.0), limits: (1.0, -1.0))",
            &[":8:", "joint #0", "limits"],
        ),
        (
            "torque.ron",
            "Hinge(name: \"h\", a: \"p\", anchor: (0.0, 0.0, 0.0), axis: (0.0, 1.0, 0.0), motor: Motor(speed: 1.0, max_torque: -2.0))",
            &[":8:", "joint 'h'", "max_torque"],
        ),
        (
            "force.ron",
            "Slider(name: \"s\", a: \"p\", anchor: (0.0, 0.0, 0.0), axis: (0.0, 1.0, 0.0), motor: Motor(speed: 1.0, max_force: -2.0))",
            &[":8:", "joint 's'", "max_force"],
        ),
        (
            "length.ron",
            "Distance(name: \"d\", a: \"p\", b: \"q\", anchor_a: (0.0, 0.0, 0.0), anchor_b: (3.0, 0.0, 0.0), max: -1.0)",
            &[":8:", "joint 'd'", "max"],
        ),
        (
            "frequency.ron",
            "Distance(name: \"d\", a: \"p\", b: \"q\", anchor_a: (0.0, 0.0, 0.0), anchor_b: (3.0, 0.0, 0.0), spring: Spring(frequency: -1.0))",
            &[":8:", "joint 'd'", "frequency"],
        ),
        ("unknown-field.ron", "Ball(a: \"p\", anchr: (0.0, 0.0, 0.0))", &[":8:", "anchr"]),
        (
            "duplicate.ron",
            "Ball(name: \"j\", a: \"p\", anchor: (0.0, 0.0, 0.0)), Ball(name: \"j\", a: \"q\", anchor: (0.0, 0.0, 0.0))",
            &[":8:", "joint 'j'", "unique"],
        ),
    ];
    for (name, joints, needles) in cases {
        rejects(&dir, name, joints, needles);
    }
}

#[test]
fn check_lists_the_joints_and_out_reports_their_errors() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("swing.ron");
    std::fs::write(
        &path,
        "Scene(steps: 30, actors: [Actor(name: \"bob\", shape: Box(size: (0.2, 0.2, 0.2)), position: (1.0, 2.0, 0.0))], \
         joints: [Ball(name: \"pivot\", a: \"bob\", anchor: (0.0, 2.0, 0.0))])",
    )
    .expect("temp file");
    let p = path.to_str().expect("utf-8");
    let o = rigid(&["check", p]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && text.contains("1 joints") && text.contains("pivot: Ball joining bob to the world"),
        "{text}"
    );
    let out = dir.path().join("out.json");
    let o = rigid(&["run", p, "--quiet", "--out", out.to_str().expect("utf-8")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).expect("written")).expect("JSON");
    let j = &doc["joints"][0];
    assert_eq!((j["name"].as_str(), j["kind"].as_str(), j["a"].as_str()), (Some("pivot"), Some("Ball"), Some("bob")));
    assert!(j["b"].is_null());
    assert!(j["position_error"].as_f64().expect("a number") < 1e-3 && j["angle_error"].as_f64() == Some(0.0), "{j}");
    // A scene without joints writes no `joints` key.
    let plain = dir.path().join("plain.ron");
    std::fs::write(&plain, "Scene(steps: 3, actors: [Actor(shape: Box(size: (1.0, 1.0, 1.0)))])").expect("temp file");
    let o = rigid(&["run", plain.to_str().expect("utf-8"), "--quiet", "--out", out.to_str().expect("utf-8")]);
    assert!(o.status.success());
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).expect("written")).expect("JSON");
    assert!(doc.get("joints").is_none(), "{doc}");
}

#[test]
fn jointed_bodies_do_not_collide_unless_asked() {
    // Two overlapping boxes joined by a ball joint: no contact between them...
    let scene = |collide: bool| {
        format!(
            "Scene(gravity: (0.0, 0.0, 0.0), actors: [Actor(name: \"p\", shape: Box(size: (1.0, 1.0, 1.0)), velocity: (0.0, 0.1, 0.0)), \
             Actor(name: \"q\", shape: Box(size: (1.0, 1.0, 1.0)), position: (0.8, 0.0, 0.0))], \
             joints: [Ball(a: \"p\", b: \"q\", anchor: (0.4, 0.0, 0.0), collide: {collide})])"
        )
    };
    let mut sim = sim_from_text(&scene(false));
    sim.run(20).expect("finite");
    assert_eq!(sim.found, [0; 3], "no contact is looked for");
    // ...and with `collide: true` the overlap is found.
    let mut sim = sim_from_text(&scene(true));
    sim.run(20).expect("finite");
    assert!(sim.found.iter().sum::<u64>() > 0, "the overlap is found");
}

#[test]
fn a_motor_brings_a_wheel_to_its_speed_within_its_torque() {
    // A wheel on a hinge to the world, no gravity: the motor's torque is its limit, so the
    // wheel speeds up at max_torque / I until it turns at the motor's speed.
    let mut sim = sim_from_text(
        "Scene(gravity: (0.0, 0.0, 0.0), actors: [Actor(name: \"wheel\", shape: Cylinder(radius: 0.5, height: 0.2, segments: 32), mass: 4.0)], \
         joints: [Hinge(a: \"wheel\", anchor: (0.0, 0.0, 0.0), axis: (0.0, 1.0, 0.0), motor: Motor(speed: 3.0, max_torque: 1.0))])",
    );
    let inertia = sim.actors()[0].world_inertia().y_axis.y;
    sim.run(6).expect("finite");
    let w = actor(&sim, "wheel").velocity.angular;
    assert_close(w.y, 1.0 / inertia * sim.time, 0.01 * w.y, "spin-up at the torque limit");
    sim.run(600).expect("finite");
    let w = actor(&sim, "wheel").velocity.angular;
    assert_close(w.y, 3.0, 1e-6, "the motor's speed");
    assert!(w.x.abs() + w.z.abs() < 1e-9, "turns about its axis only: {w}");
}

#[test]
fn hinge_limits_hold_against_a_motor_and_gravity() {
    // A door hung on a vertical hinge, driven past its limit by a strong motor.
    let mut sim = sim_from_text(
        "Scene(actors: [Actor(name: \"door\", shape: Box(size: (1.0, 2.0, 0.05)), mass: 10.0, position: (0.5, 1.0, 0.0))], \
         joints: [Hinge(a: \"door\", anchor: (0.0, 1.0, 0.0), axis: (0.0, 1.0, 0.0), limits: (-30.0, 45.0), \
                  motor: Motor(speed: 4.0, max_torque: 50.0))])",
    );
    sim.run(180).expect("finite");
    let (pos, angle) = errors(&sim)[0];
    let door = actor(&sim, "door");
    // Turned by +45° about y: the door's centre at (cos 45°, ·, −sin 45°) / 2.
    let c = door.pose.position;
    let turned = (-c.z).atan2(c.x).to_degrees();
    println!("door at {turned}°, errors {pos:e} m, {angle:e} rad");
    assert_close(turned, 45.0, 0.5, "held at the upper limit");
    assert!(pos < 2e-3 && angle < 0.01, "{pos} m, {angle} rad");
}

#[test]
fn a_door_swung_into_its_limit_stops_there() {
    // scenes/door.ron: spinning open at 1.5 rad/s into its 90° limit, no restitution anywhere.
    let mut sim = sim_of("door.ron", |_| {});
    let turned = |sim: &Sim| {
        let c = actor(sim, "door").pose.position;
        (-c.z).atan2(c.x).to_degrees()
    };
    let (mut slowest, mut widest): (f64, f64) = (0.0, 0.0);
    for _ in 0..600 {
        sim.step().expect("finite");
        slowest = slowest.min(actor(&sim, "door").velocity.angular.y);
        widest = widest.max(turned(&sim));
    }
    println!("door: fastest back swing {slowest} rad/s, widest {widest}°, at {}° after 5 s", turned(&sim));
    assert!(slowest > -0.015, "rebounds at {slowest} rad/s, over 1 % of the 1.5 rad/s hit");
    assert!((widest - 90.0).abs() < 0.05, "reaches the limit and stops there: widest {widest}°");
    // What rebound there is, a few thousandths of a rad/s, carries it back by under a degree.
    assert!(turned(&sim) > 89.0, "still at the limit: {}°", turned(&sim));
}

#[test]
fn a_slider_on_a_frictionless_incline_accelerates_at_g_sin_theta() {
    // A block on a slider along a 30° slope, joined to the world.
    let theta: f64 = 30f64.to_radians();
    let (c, s) = (theta.cos(), theta.sin());
    let mut sim = sim_from_text(&format!(
        "Scene(actors: [Actor(name: \"cart\", shape: Box(size: (0.4, 0.2, 0.3)), mass: 2.0, position: (0.0, 3.0, 0.0), rotation: (0.0, 0.0, -30.0))], \
         joints: [Slider(a: \"cart\", anchor: (0.0, 3.0, 0.0), axis: ({c}, {}, 0.0))])",
        -s
    ));
    let x0 = actor(&sim, "cart").pose.position;
    sim.run(60).expect("finite");
    let cart = actor(&sim, "cart");
    let d = cart.pose.position - x0;
    let along = d.dot(Vector::new(c, -s, 0.0));
    let a = cart.velocity.linear.dot(Vector::new(c, -s, 0.0)) / sim.time;
    let want = 9.81 * s;
    println!("slider: a = {a} m/s², g sin θ = {want}, off axis {:e} m", (d - Vector::new(c, -s, 0.0) * along).length());
    assert_close(a, want, 0.01 * want, "acceleration along the slope");
    assert!(errors(&sim)[0].0 < 1e-3 && errors(&sim)[0].1 < 1e-3, "{:?}", errors(&sim));
}

#[test]
fn slider_limits_and_motor() {
    // Driven along x by its motor to the upper limit at 0.5 m (no gravity).
    let mut sim = sim_from_text(
        "Scene(gravity: (0.0, 0.0, 0.0), actors: [Actor(name: \"cart\", shape: Box(size: (0.4, 0.2, 0.3)), mass: 2.0)], \
         joints: [Slider(a: \"cart\", anchor: (0.0, 0.0, 0.0), axis: (1.0, 0.0, 0.0), limits: (-1.0, 0.5), \
                  motor: Motor(speed: 1.0, max_force: 100.0))])",
    );
    sim.run(20).expect("finite");
    assert_close(actor(&sim, "cart").velocity.linear.x, 1.0, 1e-6, "motor speed");
    sim.run(100).expect("finite");
    assert_close(actor(&sim, "cart").pose.position.x, 0.5, 2e-3, "held at the limit");
}

#[test]
fn a_rope_goes_slack_and_taut() {
    // A bob 0.6 m from the anchor on a 1 m rope: it falls freely, then the rope catches it.
    let mut sim = sim_from_text(
        "Scene(actors: [Actor(name: \"bob\", shape: Box(size: (0.1, 0.1, 0.1)), mass: 1.0, position: (0.6, 2.0, 0.0))], \
         joints: [Distance(a: \"bob\", anchor_a: (0.6, 2.0, 0.0), anchor_b: (0.0, 2.0, 0.0), max: 1.0)])",
    );
    let anchor = Vector::new(0.0, 2.0, 0.0);
    sim.run(10).expect("finite");
    let bob = actor(&sim, "bob");
    // Slack: free fall, gravity added substep by substep (y = y0 − g h² n(n+1)/2 after n
    // substeps of h).
    let n = 10.0 * f64::from(sim.ctx.params.substeps);
    let h = sim.ctx.dt / f64::from(sim.ctx.params.substeps);
    let fall = 9.81 * h * h * n * (n + 1.0) / 2.0;
    assert_close(bob.pose.position.y, 2.0 - fall, 1e-9, "free fall while slack");
    let mut longest: f64 = 0.0;
    let mut shortest_later = f64::INFINITY;
    for step in 0..240 {
        sim.step().expect("finite");
        let r = (actor(&sim, "bob").pose.position - anchor).length();
        longest = longest.max(r);
        if step > 120 {
            shortest_later = shortest_later.min(r);
        }
    }
    println!("rope: longest {longest} m, shortest while swinging {shortest_later} m");
    assert!(longest < 1.0 + 2e-3 && longest > 0.999, "taut at its length: {longest}");
    assert!(shortest_later > 0.99, "and it stays taut as the bob swings: {shortest_later}");
}

#[test]
fn a_spring_oscillates_at_its_frequency() {
    // A 3 kg box on a 2 Hz spring to the world, no gravity, pulled out and let go.
    let mut sim = sim_from_text(
        "Scene(gravity: (0.0, 0.0, 0.0), steps: 0, actors: [Actor(name: \"m\", shape: Box(size: (0.2, 0.2, 0.2)), mass: 3.0, \
         position: (1.0, 0.0, 0.0), velocity: (0.5, 0.0, 0.0))], \
         joints: [Distance(a: \"m\", anchor_a: (1.0, 0.0, 0.0), anchor_b: (0.0, 0.0, 0.0), spring: Spring(frequency: 2.0, damping_ratio: 0.0))])",
    );
    let crossings = upward_crossings(&mut sim, 60 * 5, |sim| actor(sim, "m").pose.position.x - 1.0);
    let f = 1.0 / period(&crossings);
    println!("spring: {f} Hz for 2 Hz");
    assert_close(f, 2.0, 0.04, "frequency within 2 %");
}

#[test]
fn a_rod_keeps_its_length() {
    let mut sim = sim_from_text(
        "Scene(actors: [Actor(name: \"p\", shape: Box(size: (0.2, 0.2, 0.2)), position: (1.0, 2.0, 0.0)), \
         Actor(name: \"q\", shape: Box(size: (0.2, 0.2, 0.2)), position: (1.0, 1.0, 0.0), velocity: (2.0, 0.0, 0.0))], \
         joints: [Ball(a: \"p\", anchor: (0.0, 2.0, 0.0)), Distance(a: \"q\", b: \"p\", anchor_a: (1.0, 1.0, 0.0), anchor_b: (1.0, 2.0, 0.0))])",
    );
    let mut worst: f64 = 0.0;
    for _ in 0..300 {
        sim.step().expect("finite");
        worst = worst.max(errors(&sim)[1].0);
    }
    println!("rod: worst length error {worst} m");
    assert!(worst < 5e-3, "{worst}");
}

/// Kinetic plus potential energy (against gravity g along −y) of the free actors.
fn energy(sim: &Sim) -> f64 {
    let g = -sim.ctx.params.gravity.y;
    let potential: f64 =
        sim.actors().iter().filter(|a| !a.mass.is_fixed()).map(|a| a.mass.mass * g * a.pose.position.y).sum();
    sim.totals().kinetic_energy + potential
}

#[test]
fn a_double_pendulum_never_gains_energy_and_loses_little() {
    // The shipped scene: two 1 m, 1 kg rods on hinges, let go from horizontal, 10 s.
    let mut sim = sim_of("double-pendulum.ron", |_| {});
    let e0 = energy(&sim);
    // The energy the swing can trade: from horizontal to hanging straight down, m g (L/2 + 3L/2).
    let swing = 9.81 * (0.5 + 1.5);
    let (mut most, mut least) = (e0, e0);
    for _ in 0..600 {
        sim.step().expect("finite");
        let e = energy(&sim);
        (most, least) = (most.max(e), least.min(e));
    }
    let (gain, loss) = ((most - e0) / swing, (e0 - least) / swing);
    println!("double pendulum over 10 s: most gained {:.4} %, most lost {:.4} % of m g L", 100.0 * gain, 100.0 * loss);
    // The joints' give stores a little energy and hands it back: at most a thousandth.
    assert!(gain < 1e-3, "gains energy: {gain}");
    assert!(loss < 0.02, "loses energy: {loss}");
}

#[test]
fn a_chain_holds_a_ball_of_a_hundred_links_within_a_percent_of_a_link() {
    // The shipped scene: 30 links of 0.1 kg and 20 cm, a 10 kg ball, swinging for 5 s.
    let mut sim = sim_of("chain.ron", |_| {});
    let mut worst: f64 = 0.0;
    for _ in 0..300 {
        sim.step().expect("finite");
        worst = errors(&sim).iter().fold(worst, |w, e| w.max(e.0));
    }
    println!("chain: worst joint error over 5 s {:.3} mm ({:.3} % of a link)", 1e3 * worst, 100.0 * worst / 0.2);
    assert!(worst < 0.01 * 0.2, "{worst} m");
}

#[test]
fn the_shipped_joint_scenes_keep_their_joints() {
    // Every shipped scene with joints, run for 5 s: no joint comes apart or passes a limit by
    // more than the joints' give.
    for name in ["pendulum", "double-pendulum", "chain", "door", "wheel", "slider", "rope-bridge", "ragdoll"]
        .map(|n| format!("{n}.ron"))
    {
        let mut sim = sim_of(&name, |_| {});
        let steps = sim.ctx.dt.recip().round() as u64 * 5;
        let (mut position, mut angle): (f64, f64) = (0.0, 0.0);
        for _ in 0..steps {
            sim.step().expect("finite");
            for (p, a) in errors(&sim) {
                (position, angle) = (position.max(p), angle.max(a));
            }
        }
        println!("{name}: worst over 5 s {:.3} mm, {:.4} rad", 1e3 * position, angle);
        // The ragdoll's landing jerks light limbs against the heavy torso and the crates: its
        // joints give more, for a step or two.
        let (most, most_angle) = if name == "ragdoll.ron" { (0.02, 0.1) } else { (0.01, 0.02) };
        assert!(position < most && angle < most_angle, "{name}: {position} m, {angle} rad");
    }
}

#[test]
fn the_pendulums_benchmark_scene_swings_on_its_joints_and_its_free_twin_falls() {
    use rigid_sandbox::scene::benchmarks::{BenchScene, scene_sim};
    let mut hung = scene_sim(BenchScene::Pendulums { jointed: true }, 9, 1);
    let mut free = scene_sim(BenchScene::Pendulums { jointed: false }, 9, 1);
    assert_eq!(
        hung.actors().iter().map(|a| a.pose).collect::<Vec<_>>(),
        free.actors().iter().map(|a| a.pose).collect::<Vec<_>>()
    );
    hung.run(60).expect("finite");
    free.run(60).expect("finite");
    let start = scene_sim(BenchScene::Pendulums { jointed: false }, 9, 1).actors();
    for ((h, f), s) in hung.actors().iter().zip(free.actors()).zip(&start) {
        // The free box falls as semi-implicit Euler says: y drops by g·dt²·n(n+1)/2.
        let drop = 9.81 / 3600.0 * 60.0 * 61.0 / 2.0;
        assert!((s.pose.position.y - f.pose.position.y - drop).abs() < 1e-9, "{}", f.name);
        // The hung one stays its half length (0.3 m) from its pivot, 2 m up.
        let pivot_y = 2.0;
        assert!(h.pose.position.y < pivot_y && h.pose.position.y > pivot_y - 0.31, "{} at {}", h.name, h.pose.position);
    }
}
