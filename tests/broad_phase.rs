//! The grid broad phase (`cull`) and the paper's all-pairs loop (`cull_all_pairs`) produce
//! the identical, sorted pair list: on random sphere sets, on box-gas after 100 steps, and on
//! mixed sizes with walls.

mod common;
use common::*;
use proptest::prelude::*;
use rigid_sandbox::systems::{cull, cull_all_pairs};
use rigid_sandbox::{Pair, Sim, StepContext};

fn pairs_of(sim: &mut Sim, system: fn(&mut hecs::World, &mut StepContext)) -> Vec<(u32, u32)> {
    sim.ctx.begin_step(&sim.world);
    system(&mut sim.world, &mut sim.ctx);
    let out: Vec<(u32, u32)> = sim.ctx.pairs.iter().map(|p: &Pair| (p.a, p.b)).collect();
    sim.ctx.step -= 1; // begin_step counted a step that was never taken
    out
}

fn assert_same(sim: &mut Sim) -> usize {
    let grid = pairs_of(sim, cull);
    let all = pairs_of(sim, cull_all_pairs);
    assert!(all.windows(2).all(|w| w[0] < w[1]), "sorted, no duplicates");
    assert_eq!(grid, all);
    all.len()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn grid_equals_all_pairs_on_random_spheres(
        bodies in proptest::collection::vec(((-6.0..6.0f64, -6.0..6.0f64, -6.0..6.0f64), 0.1..1.5f64, any::<bool>()), 1..80),
    ) {
        let actors: Vec<String> = bodies.iter().map(|((x, y, z), r, fixed)| {
            format!("Actor(shape: Icosphere(radius: {r}, subdivisions: 0), position: ({x}, {y}, {z}), fixed: {fixed})")
        }).collect();
        let mut sim = sim_from_text(&format!("Scene(actors: [{}])", actors.join(",")));
        assert_same(&mut sim);
    }
}

#[test]
fn grid_equals_all_pairs_on_box_gas_after_100_steps() {
    let mut sim = rigid_sandbox::scene::benchmarks::box_gas_sim(1000, 1);
    sim.run(100).expect("finite");
    assert!(assert_same(&mut sim) > 100, "a real workload");
}

#[test]
fn grid_equals_all_pairs_with_walls_and_mixed_sizes() {
    for name in ["mixed-shapes.ron", "spawners.ron"] {
        let mut sim = sim_of(name, |_| {});
        // Every other step of the first 300, while the bodies fly and meet the walls (whose
        // spheres hold the room, whose boxes only its rim).
        let mut listed = 0;
        for _ in 0..150 {
            sim.run(2).expect("finite");
            listed += assert_same(&mut sim);
        }
        assert!(listed > 10, "{name}: a real workload");
    }
}
