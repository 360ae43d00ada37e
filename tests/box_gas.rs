//! Many bodies, all colliding, e = 1, in a closed box: the kinetic energy is kept, no cube
//! escapes, and nothing goes non-finite (issue #4; docs/benchmarks.md's box-gas at small N).

use rigid_sandbox::scene::benchmarks::box_gas_sim;
use rigid_sandbox::scene::spawners::box_gas_half_extent;

#[test]
fn box_gas_keeps_energy_and_its_cubes_for_600_steps() {
    let n = 343;
    let mut sim = box_gas_sim(n, 1);
    let e0 = sim.totals().kinetic_energy;
    let mut impulses = 0;
    for _ in 0..600 {
        sim.step().expect("finite state every step");
        impulses = sim.impulses.iter().sum::<u64>();
    }
    let e1 = sim.totals().kinetic_energy;
    assert!(((e1 - e0) / e0).abs() <= 1e-3, "kinetic energy {e0} -> {e1}");
    assert!(impulses > 1000, "a real collision workload: {impulses} impulses");
    let a = box_gas_half_extent(n);
    let escaped = sim.actors()[..n as usize].iter().filter(|s| s.pose.position.abs().max_element() > a).count();
    assert_eq!(escaped, 0);
}
