//! Many-faced convex bodies behave as the shapes they are: a faceted ball rolls down a slope
//! without slipping at nearly a sphere's 5/7·g·sin θ, a rain of icospheres comes to rest in its
//! container, and the same scene gives the same bits on one thread or two.

mod common;
use common::*;
use rigid_sandbox::math::Vector;
use rigid_sandbox::scene::benchmarks::{BenchScene, scene_sim};

#[test]
fn a_ball_of_1280_faces_rolls_down_a_20_degree_slope_without_slipping_or_hopping() {
    let theta = 20f64.to_radians();
    let normal = Vector::new(theta.sin(), theta.cos(), 0.0);
    let downhill = Vector::new(theta.cos(), -theta.sin(), 0.0);
    let mut sim = sim_from_text(&format!(
        "Scene(actors: [
            Actor(name: \"slope\", shape: Box(size: (40.0, 1.0, 4.0)), rotation: (0.0, 0.0, -20.0),
                  fixed: true, friction: 0.5, restitution: 0.0),
            Actor(name: \"ball\", shape: Icosphere(radius: 0.5, subdivisions: 3), friction: 0.5,
                  restitution: 0.0, position: ({}, {}, 0.0)),
        ])",
        normal.x, normal.y
    ));
    let start = actor(&sim, "ball").pose.position;
    for _ in 0..30 {
        sim.step().expect("finite");
        let ball = actor(&sim, "ball");
        let off = (ball.pose.position - start).dot(normal);
        // Faceted: the centre rocks by the facets' sag (about 0.6 mm), never lifts off.
        assert!(off.abs() < 1.5e-3, "step {}: {off} m off the slope", sim.steps);
        // The contact point keeps (almost) still: rolling, not sliding.
        let contact_speed = ball.velocity.linear + ball.velocity.angular.cross(-0.5 * normal);
        assert!(contact_speed.dot(downhill).abs() < 0.01, "step {}: slipping at {contact_speed}", sim.steps);
    }
    // Over the first half second, s = a t²/2: within 10 % of a sphere's 5/7·g·sin θ, and below
    // it (each facet's edge it rolls over costs a little energy at e = 0).
    let s = (actor(&sim, "ball").pose.position - start).dot(downhill);
    let (a, sphere) = (2.0 * s / 0.25, 5.0 / 7.0 * 9.81 * theta.sin());
    assert!(a > 0.9 * sphere && a < sphere, "a = {a} m/s², a sphere's {sphere}");
}

#[test]
fn a_rain_of_icospheres_comes_to_rest_inside_its_container() {
    let mut sim = scene_sim(BenchScene::HullRain { subdivisions: 1 }, 20, 1);
    sim.run(600).expect("finite");
    let totals = sim.totals();
    assert!(totals.kinetic_energy < 1e-2, "still moving: {} J", totals.kinetic_energy);
    let half = rigid_sandbox::scene::benchmarks::rain_half_width(20);
    for ball in sim.actors().iter().skip(5) {
        let p = ball.pose.position;
        assert!(p.x.abs() < half && p.z.abs() < half && p.y > 0.0, "{} ended at {p}", ball.name);
    }
}

#[test]
fn many_faced_scenes_give_the_same_bits_on_one_thread_or_two() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        pool.install(|| {
            let mut sim = scene_sim(BenchScene::HullRain { subdivisions: 2 }, 40, 3);
            sim.run(150).expect("finite");
            sim.actors().iter().map(|a| (a.pose.position.to_array(), a.velocity.angular.to_array())).collect::<Vec<_>>()
        })
    };
    assert_eq!(run(1), run(2));
}

/// Pairs `unskip` put back to the tests.
static UNSKIPPED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// A user system after `prune`: hands the pairs it took out of the tests for recycling (the
/// only `Found` pairs it leaves) back to them, so the tests run on every pair as before.
fn unskip(_world: &mut hecs::World, ctx: &mut rigid_sandbox::StepContext) {
    for p in ctx.pairs.iter_mut().filter(|p| matches!(p.state, rigid_sandbox::PairState::Found(_))) {
        p.state = rigid_sandbox::PairState::Candidate;
        UNSKIPPED.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    }
}

#[test]
fn recycled_pairs_skip_the_tests_without_changing_a_bit() {
    // docs/physics.md §6.3: `solve` reads nothing of the tests' contact for a pair it recycles
    // but the feature, which the skipped pair keeps. Icospheres and a box pyramid, with the
    // tests run on every pair (`unskip`) and without: the same states and the same counts.
    let run = |scene: BenchScene, n: u32, steps: u64, all: bool| {
        let mut sim = scene_sim(scene, n, 3);
        if all {
            let unskip = rigid_sandbox::System { name: "unskip", run: unskip };
            sim.schedule.insert_after("prune", unskip).expect("prune is there");
        }
        sim.run(steps).expect("finite");
        (rigid_sandbox::io::output::state_hash(&sim.actors()), sim.impulses, sim.found)
    };
    for (scene, n, steps) in [(BenchScene::HullRain { subdivisions: 2 }, 30, 300), (BenchScene::Pyramid, 6, 200)] {
        let before = UNSKIPPED.load(std::sync::atomic::Ordering::SeqCst);
        let all = run(scene, n, steps, true);
        let skipped = UNSKIPPED.load(std::sync::atomic::Ordering::SeqCst) - before;
        assert!(skipped as u64 > steps, "{scene:?}: only {skipped} pairs skipped the tests");
        let skipping = run(scene, n, steps, false);
        assert_eq!(skipping.0, all.0, "{scene:?}: the same states");
        eprintln!("{scene:?}: impulses {:?} / {:?}, found {:?} / {:?}", skipping.1, all.1, skipping.2, all.2);
    }
}

/// Recycling verdicts `prune` left for `solve` this step (counted by `forget_verdicts`).
static VERDICTS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// A user system after `prune`: throws away its recycling verdicts, so `solve` works each out
/// again.
fn forget_verdicts(_world: &mut hecs::World, ctx: &mut rigid_sandbox::StepContext) {
    let s = ctx.scratch.get_mut::<rigid_sandbox::solver::SolveScratch>();
    let kept = s.recycling.iter().filter(|r| r.manifold.is_some()).count();
    VERDICTS.fetch_add(kept, std::sync::atomic::Ordering::SeqCst);
    s.recycling.clear();
}

/// A user system after `prune`: moves every third body by a nanometre (and marks it moved, as
/// a system that moves a body must), so the poses `prune` judged recycling at are no longer
/// the bodies' own.
fn nudge(_world: &mut hecs::World, ctx: &mut rigid_sandbox::StepContext) {
    for i in (5..ctx.bodies.len()).step_by(3) {
        ctx.bodies.position[i].x += 1e-9;
        ctx.mark_moved(i);
    }
}

#[test]
fn solve_takes_the_recycling_verdicts_of_prune_only_while_no_body_moved() {
    // docs/physics.md §6.3: `prune` works out once a step whether each resting pair keeps its
    // points; `solve` reads that answer if no body moved since, which must give the bits of
    // working it out again, and works it out again when a body moved in between.
    let run = |forget: bool, moved: bool| {
        let mut sim = scene_sim(BenchScene::HullRain { subdivisions: 2 }, 30, 3);
        if forget {
            let system = rigid_sandbox::System { name: "forget_verdicts", run: forget_verdicts };
            sim.schedule.insert_after("prune", system).expect("prune is there");
        }
        if moved {
            let system = rigid_sandbox::System { name: "nudge", run: nudge };
            sim.schedule.insert_after("prune", system).expect("prune is there");
        }
        sim.run(300).expect("finite");
        rigid_sandbox::io::output::state_hash(&sim.actors())
    };
    let before = VERDICTS.load(std::sync::atomic::Ordering::SeqCst);
    assert_eq!(run(false, false), run(true, false), "the same bits with the verdicts or without");
    let kept = VERDICTS.load(std::sync::atomic::Ordering::SeqCst) - before;
    assert!(kept > 300, "only {kept} verdicts kept the points");
    assert_eq!(run(false, true), run(true, true), "a moved pair is judged again");
}
