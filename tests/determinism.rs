//! Determinism: the same scene gives the same bits on every run and for every thread count
//! (pair order is sorted, each pair and each body has one writer, sums run in index order).

mod common;
use common::*;
use rigid_sandbox::io::output::state_hash;

/// `f` run in a pool of `threads` threads.
fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool").install(f)
}

fn hash_with_threads(threads: usize, steps: u64) -> u64 {
    on_threads(threads, || {
        let mut sim = rigid_sandbox::scene::benchmarks::box_gas_sim(512, 1);
        sim.run(steps).expect("finite");
        state_hash(&sim.actors())
    })
}

#[test]
fn box_gas_is_bit_identical_across_runs_and_thread_counts() {
    let one = hash_with_threads(1, 120);
    assert_eq!(one, hash_with_threads(1, 120), "two runs");
    assert_eq!(one, hash_with_threads(2, 120), "1 vs 2 threads");
    assert_eq!(one, hash_with_threads(3, 120), "1 vs 3 threads");
    assert_ne!(one, hash_with_threads(1, 119), "the hash sees one step's difference");
}

#[test]
fn mixed_shapes_are_bit_identical_across_thread_counts() {
    let run = |threads: usize| {
        on_threads(threads, || {
            let mut sim = sim_of("spawners.ron", |_| {});
            sim.run(200).expect("finite");
            state_hash(&sim.actors())
        })
    };
    assert_eq!(run(1), run(2));
}

/// The hash of box-gas (512 cubes, 120 steps), pinned: a change that moves it must be a
/// deliberate change of the physics, and updates this value saying why in its commit.
const PINNED_BOX_GAS_HASH: u64 = 0x454f_8833_798a_6c8d;

#[test]
fn box_gas_hash_is_pinned() {
    assert_eq!(hash_with_threads(2, 120), PINNED_BOX_GAS_HASH, "got {:#018x}", hash_with_threads(2, 120));
}

/// The 20-row pyramid (590 constraints, enough for `solve` to split them in two sides and
/// solve both at once) after `steps` steps in a pool of `threads`, handed to `look`.
fn pyramid_on<T: Send>(threads: usize, steps: u64, look: impl FnOnce(&rigid_sandbox::sim::Sim) -> T + Send) -> T {
    on_threads(threads, || {
        let mut sim =
            rigid_sandbox::scene::benchmarks::scene_sim(rigid_sandbox::scene::benchmarks::BenchScene::Pyramid, 20, 1);
        sim.run(steps).expect("finite");
        look(&sim)
    })
}

#[test]
fn a_pyramid_solved_in_two_sides_is_bit_identical_on_one_thread_or_two() {
    // The split follows the scene, never the thread count.
    let run = |threads: usize| {
        pyramid_on(threads, 40, |sim| {
            assert!(sim.ctx.stats.split, "split in two sides");
            state_hash(&sim.actors())
        })
    };
    assert_eq!(run(1), run(2));
}

/// A wall of bricks: four staggered rows of unit cubes, 60 long, each brick on two below
/// (as in a pyramid, whose rows chain brick to brick), far wider than tall.
const WALL: &str = r#"Scene(
    dt: 0.0166666667,
    actors: [
        Actor(name: "ground", shape: Box(size: (80.0, 1.0, 10.0)), position: (0.0, -0.5, 0.0), fixed: true),
    ],
    spawners: [
        Grid(actor: Actor(name: "row0", shape: Box(size: (1.0, 1.0, 1.0)), position: (-30.0, 0.5, 0.0)),
             counts: (60, 1, 1), spacing: (1.0, 1.0, 1.0)),
        Grid(actor: Actor(name: "row1", shape: Box(size: (1.0, 1.0, 1.0)), position: (-29.5, 1.5, 0.0)),
             counts: (59, 1, 1), spacing: (1.0, 1.0, 1.0)),
        Grid(actor: Actor(name: "row2", shape: Box(size: (1.0, 1.0, 1.0)), position: (-29.0, 2.5, 0.0)),
             counts: (58, 1, 1), spacing: (1.0, 1.0, 1.0)),
        Grid(actor: Actor(name: "row3", shape: Box(size: (1.0, 1.0, 1.0)), position: (-28.5, 3.5, 0.0)),
             counts: (57, 1, 1), spacing: (1.0, 1.0, 1.0)),
    ],
)"#;

/// `WALL` after `steps` steps in a pool of `threads`, handed to `look`.
fn wall_on<T: Send>(threads: usize, steps: u64, look: impl FnOnce(&rigid_sandbox::sim::Sim) -> T + Send) -> T {
    on_threads(threads, || {
        let mut sim = sim_from_text(WALL);
        sim.run(steps).expect("finite");
        look(&sim)
    })
}

#[test]
fn one_thread_places_both_sides_in_shared_batches() {
    // On one thread the two sides' constraints are placed as one group: the same constraints
    // in fewer batches (a side's rows chain body to body and leave lanes empty), with the same
    // bits as two threads.
    use rigid_sandbox::solver::{ConstraintGroup, SolveScratch};
    let batches = |threads: usize| {
        pyramid_on(threads, 10, |sim| {
            let s = sim.ctx.scratch.get::<SolveScratch>().expect("solve ran");
            let [first, second, across] = &s.groups;
            let lanes = |g: &ConstraintGroup| g.fill.iter().map(|&f| usize::from(f)).sum::<usize>();
            assert_eq!(lanes(first) + lanes(second) + lanes(across), s.held.len(), "every held pair placed once");
            let batches = first.batches.len() + second.batches.len();
            (s.merged, second.batches.is_empty(), batches, rigid_sandbox::io::output::state_hash(&sim.actors()))
        })
    };
    let (merged, second_empty, one, bits) = batches(1);
    assert!(merged && second_empty, "one thread: one group for both sides");
    let (merged, second_empty, two, bits_two) = batches(2);
    assert!(!merged && !second_empty, "two threads: a group a side");
    assert_eq!(bits, bits_two, "the same bits");
    // B = 20, cut across its height: 154 batches against 158 (cut upright, alike sides: 146
    // against 95 + 93, before quiet constraints were placed apart).
    assert!(one < two, "shared batches fill up: {one} against {two}");
}

#[test]
fn a_pile_is_cut_where_fewer_held_pairs_cross() {
    // A pyramid is as tall as it is wide, and fewer of its contacts cross a level cut at half
    // its bodies than an upright one: its lower half is one side. The wall is cut upright,
    // across x, its long axis.
    use rigid_sandbox::solver::SolveScratch;
    let sides = |sim: &rigid_sandbox::sim::Sim, axis: usize| {
        let s = sim.ctx.scratch.get::<SolveScratch>().expect("solve ran");
        assert!(sim.ctx.stats.split, "cut in two sides");
        let along = |i: &u32| sim.ctx.bodies.position[*i as usize].to_array()[axis];
        let (first, second) = s.moving.split_at(s.left);
        let highest = first.iter().map(along).fold(f64::NEG_INFINITY, f64::max);
        (highest, second.iter().map(along).fold(f64::INFINITY, f64::min))
    };
    let (below, above) = pyramid_on(1, 10, |sim| sides(sim, 1));
    assert!(below <= above, "the pyramid cut across its height: {below} against {above}");
    let (left, right) = wall_on(1, 10, |sim| sides(sim, 0));
    assert!(left <= right, "the wall cut across x: {left} against {right}");
}

#[test]
fn a_split_pile_with_joints_is_bit_identical_on_one_thread_or_two() {
    // 512 boxes on the ground (about 1 400 held pairs: cut in two sides) beside a hinged door
    // held by a ball joint: on one thread both sides share batches and the joints' passes run
    // over the same bodies after each pass.
    const SCENE: &str = r#"Scene(
        dt: 0.0166666667,
        actors: [
            Actor(name: "ground", shape: Box(size: (40.0, 1.0, 40.0)), position: (0.0, -0.5, 0.0), fixed: true,
                  friction: 0.5),
            Actor(name: "frame", shape: Box(size: (0.2, 2.2, 0.2)), position: (-12.0, 1.1, 0.0), fixed: true),
            Actor(name: "door", shape: Box(size: (1.0, 2.0, 0.1)), position: (-11.4, 1.1, 0.0), friction: 0.5),
        ],
        joints: [
            Hinge(name: "hinge", a: "door", b: "frame", anchor: (-11.9, 1.1, 0.0), axis: (0.0, 1.0, 0.0)),
            Ball(name: "ball", a: "door", anchor: (-10.9, 2.1, 0.0)),
        ],
        spawners: [
            Grid(actor: Actor(name: "box", shape: Box(size: (1.0, 1.0, 1.0)), position: (-8.0, 0.5, -4.0),
                              friction: 0.5, velocity: (0.3, 0.0, 0.1)),
                 counts: (16, 4, 8), spacing: (1.0, 1.0, 1.0)),
        ],
    )"#;
    let run = |threads: usize| {
        on_threads(threads, || {
            let mut sim = sim_from_text(SCENE);
            sim.run(30).expect("finite");
            assert!(sim.ctx.stats.split && sim.ctx.stats.held > 256, "held {}", sim.ctx.stats.held);
            state_hash(&sim.actors())
        })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn pyramids_stepped_side_by_side_in_one_pool_match_each_alone() {
    // A user may step several sims at once in one pool's parallel loop: each still gives its
    // own bits, and none waits for ever on the threads another step keeps awake.
    let pyramid =
        || rigid_sandbox::scene::benchmarks::scene_sim(rigid_sandbox::scene::benchmarks::BenchScene::Pyramid, 20, 1);
    let alone = {
        let mut sim = pyramid();
        sim.run(15).expect("finite");
        state_hash(&sim.actors())
    };
    let hashes: Vec<u64> = on_threads(2, || {
        use rayon::prelude::*;
        (0..4)
            .into_par_iter()
            .map(|_| {
                let mut sim = pyramid();
                sim.run(15).expect("finite");
                state_hash(&sim.actors())
            })
            .collect()
    });
    assert_eq!(hashes, [alone; 4]);
}
