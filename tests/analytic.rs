//! The analytic cases of docs/physics.md §4, in unit form (bodies placed overlapping by 0.01,
//! one detection + resolution, 1e-9) and scene form (the shipped scene run until the first
//! impulse), with the conservation checks of §4 (d) and the actor-order swap (T-swap).

mod common;
use common::*;
use rigid_sandbox::Feature;
use rigid_sandbox::math::Vector;
use rigid_sandbox::scene::SceneDef;
use rigid_sandbox::sim::Sim;

/// One expected value: actor, linear (`v`) or angular (`w`) velocity, component, value.
type Expect = (&'static str, char, usize, f64);

struct Case {
    scene: &'static str,
    /// The actor that moves at 1 m/s towards the other.
    mover: &'static str,
    restitution: f64,
    feature: Feature,
    expect: &'static [Expect],
}

const CASES: &[Case] = &[
    // (a) equal cubes head-on, e = 1, 0, 0.5.
    Case {
        scene: "face-collision.ron",
        mover: "a",
        restitution: 1.0,
        feature: Feature::Face,
        expect: &[("a", 'v', 0, 0.0), ("b", 'v', 0, 1.0)],
    },
    Case {
        scene: "face-collision.ron",
        mover: "a",
        restitution: 0.0,
        feature: Feature::Face,
        expect: &[("a", 'v', 0, 0.5), ("b", 'v', 0, 0.5)],
    },
    Case {
        scene: "face-collision.ron",
        mover: "a",
        restitution: 0.5,
        feature: Feature::Face,
        expect: &[("a", 'v', 0, 0.25), ("b", 'v', 0, 0.75)],
    },
    // (b) masses 1 and 3.
    Case {
        scene: "unequal-masses.ron",
        mover: "a",
        restitution: 1.0,
        feature: Feature::Face,
        expect: &[("a", 'v', 0, -0.5), ("b", 'v', 0, 0.5)],
    },
    Case {
        scene: "unequal-masses.ron",
        mover: "a",
        restitution: 0.5,
        feature: Feature::Face,
        expect: &[("a", 'v', 0, -0.125), ("b", 'v', 0, 0.375)],
    },
    // (c) off-centre hit on the rod.
    Case {
        scene: "rod-off-centre.ron",
        mover: "cube",
        restitution: 1.0,
        feature: Feature::Face,
        expect: &[
            ("cube", 'v', 1, -243.0 / 445.0),
            ("rod", 'v', 1, -202.0 / 445.0),
            ("rod", 'w', 2, -108.0 / 89.0),
            ("cube", 'w', 2, 0.0),
        ],
    },
    Case {
        scene: "rod-off-centre.ron",
        mover: "cube",
        restitution: 0.5,
        feature: Feature::Face,
        expect: &[
            ("cube", 'v', 1, -1.0 + 151.5 / 445.0),
            ("rod", 'v', 1, -151.5 / 445.0),
            ("rod", 'w', 2, -81.0 / 89.0),
        ],
    },
    // (c2) rod turned Ry(90°): spin about +x.
    Case {
        scene: "rod-rotated.ron",
        mover: "cube",
        restitution: 1.0,
        feature: Feature::Face,
        expect: &[
            ("cube", 'v', 1, -243.0 / 445.0),
            ("rod", 'v', 1, -202.0 / 445.0),
            ("rod", 'w', 0, 108.0 / 89.0),
            ("rod", 'w', 2, 0.0),
        ],
    },
    // (f1) corner first: vertex test.
    Case {
        scene: "vertex-landing.ron",
        mover: "corner",
        restitution: 1.0,
        feature: Feature::Vertex,
        expect: &[
            ("corner", 'v', 1, 53.0 / 75.0),
            ("block", 'v', 1, -16.0 / 75.0),
            ("block", 'w', 2, -0.16),
            ("corner", 'w', 0, 0.0),
            ("corner", 'w', 2, 0.0),
        ],
    },
    // (f2) crossing ridges: edge test.
    Case {
        scene: "edge-crossing.ron",
        mover: "upper",
        restitution: 1.0,
        feature: Feature::Edge,
        expect: &[
            ("upper", 'v', 1, -3.0 / 19.0),
            ("lower", 'v', 1, -16.0 / 19.0),
            ("lower", 'w', 2, -24.0 / 19.0),
            ("upper", 'w', 2, 0.0),
        ],
    },
    // (f3) edge-flat landing, resolved by the vertex test at the edge midpoint.
    Case {
        scene: "edge-landing.ron",
        mover: "edge",
        restitution: 1.0,
        feature: Feature::Vertex,
        expect: &[
            ("edge", 'v', 1, 221.0 / 291.0),
            ("block", 'v', 1, -64.0 / 291.0),
            ("block", 'w', 2, -24.0 / 291.0),
            ("edge", 'w', 0, 0.0),
        ],
    },
];

/// Collision-only schedule for the unit form: no correction, no integration.
const DETECT_AND_RESOLVE: &[&str] = &["cull", "face", "vertex", "edge", "resolve"];

fn component(sim: &Sim, (name, kind, k, _): &Expect) -> f64 {
    let a = actor(sim, name);
    let v = if *kind == 'v' { a.velocity.linear } else { a.velocity.angular };
    v[*k]
}

fn check(sim: &Sim, case: &Case, tol: f64, form: &str) {
    for e in case.expect {
        assert_close(
            component(sim, e),
            e.3,
            tol,
            &format!("{} e={} ({form}): {} {}[{}]", case.scene, case.restitution, e.0, e.1, e.2),
        );
    }
    let mut want = [0; 3];
    want[case.feature as usize] = 1;
    assert_eq!(sim.impulses, want, "{} ({form}): one impulse, from the {:?} test", case.scene, case.feature);
}

/// The scene-form file edited into the unit form: the mover advanced 0.1075 m along its
/// velocity (from 0.0975 m apart to 0.01 m overlap).
fn unit_form(case: &Case, swap: bool) -> Sim {
    sim_of(case.scene, |def| {
        set_restitution(def, case.restitution);
        let mover = def.actors.iter_mut().find(|a| a.name.as_deref() == Some(case.mover)).expect("mover");
        mover.position += mover.velocity * 0.1075;
        def.schedule = Some(DETECT_AND_RESOLVE.iter().map(ToString::to_string).collect());
        if swap {
            def.actors.reverse();
        }
    })
}

#[test]
fn unit_form_matches_physics_md_to_1e_9() {
    for case in CASES {
        for swap in [false, true] {
            let mut sim = unit_form(case, swap);
            sim.step().expect("finite");
            check(&sim, case, 1e-9, if swap { "unit, swapped" } else { "unit" });
        }
    }
}

#[test]
fn scene_form_matches_physics_md_to_1e_9() {
    for case in CASES {
        let mut sim = sim_of(case.scene, |d| set_restitution(d, case.restitution));
        let step = run_until_impulse(&mut sim, 20);
        // Gap 0.0975 at 1 m/s and dt = 0.01: first overlap at t = 0.1, seen in step 11.
        assert_eq!(step, 11, "{}: impulse at the first overlapped state", case.scene);
        check(&sim, case, 1e-9, "scene");
    }
}

#[test]
fn swapping_actor_order_gives_the_same_physics() {
    // T-swap on the scene form: every actor's final velocities agree to round-off.
    for case in CASES {
        let run = |swap: bool| {
            let mut sim = sim_of(case.scene, |d: &mut SceneDef| {
                set_restitution(d, case.restitution);
                if swap {
                    d.actors.reverse();
                }
            });
            sim.run(30).expect("finite");
            let mut actors = sim.actors();
            actors.sort_by(|a, b| a.name.cmp(&b.name));
            actors
        };
        for (a, b) in run(false).iter().zip(run(true).iter()) {
            assert!((a.velocity.linear - b.velocity.linear).length() < 1e-12, "{}: {}", case.scene, a.name);
            assert!((a.velocity.angular - b.velocity.angular).length() < 1e-12, "{}: {}", case.scene, a.name);
            assert!((a.pose.position - b.pose.position).length() < 1e-12, "{}: {}", case.scene, a.name);
        }
    }
}

#[test]
fn every_collision_conserves_momentum_and_angular_momentum_and_obeys_restitution() {
    // docs/physics.md §4 (d), on the unit form: totals before and after the impulse.
    for case in CASES {
        let mut sim = unit_form(case, false);
        let before = sim.totals();
        let v_before: Vec<_> = sim.actors();
        sim.step().expect("finite");
        let after = sim.totals();
        let scale = 1.0 + before.linear_momentum.length();
        assert!((after.linear_momentum - before.linear_momentum).length() <= 1e-12 * scale, "{}: momentum", case.scene);
        assert!(
            (after.angular_momentum - before.angular_momentum).length()
                <= 1e-12 * (1.0 + before.angular_momentum.length()),
            "{}: L",
            case.scene
        );
        // Energy: kept for e = 1, strictly lost for e < 1.
        let dk = after.kinetic_energy - before.kinetic_energy;
        if case.restitution == 1.0 {
            assert!(dk.abs() <= 1e-12, "{}: e = 1 keeps energy, ΔT = {dk}", case.scene);
        } else {
            assert!(dk < -1e-3, "{}: e < 1 loses energy, ΔT = {dk}", case.scene);
        }
        // Newton's law at the contact point: u'_n = −e u_n.
        let pair = sim.ctx.pairs.iter().find(|p| p.contact().is_some()).expect("a contact");
        let c = pair.contact().expect("contact");
        let u = |states: &[rigid_sandbox::sim::ActorState]| {
            let (a, b) = (&states[pair.a as usize], &states[pair.b as usize]);
            let point_v = |s: &rigid_sandbox::sim::ActorState| {
                s.velocity.linear + s.velocity.angular.cross(c.point - s.pose.position)
            };
            (point_v(a) - point_v(b)).dot(c.normal)
        };
        let (u0, u1) = (u(&v_before), u(&sim.actors()));
        assert!(u0 < 0.0, "{}: approaching before", case.scene);
        assert_close(u1, -case.restitution * u0, 1e-12, &format!("{}: u'_n = −e u_n", case.scene));
    }
}

#[test]
fn energy_losses_match_the_closed_form() {
    // ΔT = −(1−e²) u_n² / (2K): (a) e = 0.5 → −0.1875; (b) e = 0.5 → −0.28125.
    for (case, want) in [(&CASES[2], -0.1875), (&CASES[4], -0.28125)] {
        let mut sim = unit_form(case, false);
        let before = sim.totals().kinetic_energy;
        sim.step().expect("finite");
        assert_close(sim.totals().kinetic_energy - before, want, 1e-12, case.scene);
    }
}

#[test]
fn inelastic_cubes_stay_together_without_further_impulses() {
    // (a) with e = 0: after the impulse u_n = 0, so later steps apply nothing (E13).
    let mut sim = sim_of("face-collision.ron", |d| set_restitution(d, 0.0));
    sim.run(40).expect("finite");
    assert_eq!(sim.impulses, [1, 0, 0]);
    assert_close(actor(&sim, "a").velocity.linear.x, 0.5, 1e-12, "common velocity");
    assert_close(actor(&sim, "b").velocity.linear.x, 0.5, 1e-12, "common velocity");
}

#[test]
fn head_on_with_both_moving_reverses_both() {
    let mut sim = sim_of("face-collision.ron", |d| {
        d.actors[1].velocity = Vector::new(-1.0, 0.0, 0.0);
        d.actors[1].position.x += 0.0975; // keep the first overlap off a step boundary
    });
    run_until_impulse(&mut sim, 20);
    assert_close(actor(&sim, "a").velocity.linear.x, -1.0, 1e-12, "a");
    assert_close(actor(&sim, "b").velocity.linear.x, 1.0, 1e-12, "b");
}

#[test]
fn newtons_cradle_passes_the_velocity_to_the_last_cube_in_one_step() {
    // docs/physics.md §4 (g), pairwise sequential sweeps: (0, 0, 0, 0, 1) after the first step.
    let mut sim = sim_of("newtons-cradle.ron", |_| {});
    sim.step().expect("finite");
    let v: Vec<f64> = sim.actors().iter().map(|a| a.velocity.linear.x).collect();
    assert_eq!(v, [0.0, 0.0, 0.0, 0.0, 1.0]);
    assert_eq!(sim.impulses, [4, 0, 0]);
    let t = sim.totals();
    assert_close(t.linear_momentum.x, 1.0, 1e-15, "momentum");
    assert_close(t.kinetic_energy, 0.5, 1e-15, "energy");
}

#[test]
fn newtons_cradle_in_reverse_order_needs_four_sweeps_and_gets_the_same_answer() {
    let mut sim = sim_of("newtons-cradle.ron", |d| d.actors.reverse());
    sim.step().expect("finite");
    assert_close(actor(&sim, "c5").velocity.linear.x, 1.0, 1e-15, "last cube");
    assert_close(actor(&sim, "c1").velocity.linear.x, 0.0, 1e-15, "first cube");
    assert_eq!(sim.ctx.stats.sweeps, 5, "four sweeps apply impulses, the fifth finds none");
}
