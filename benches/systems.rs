//! Each system of the default schedule alone on box-gas, with `cull` beside the paper's
//! `cull_all_pairs` (the latter only up to 4000 actors: it is O(N²)).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use rigid_sandbox::{Sim, systems};
use std::time::{Duration, Instant};

/// Starts a step and runs the default systems before `anchor`, so the timed system sees the
/// inputs it sees in a real step. Untimed.
fn run_up_to(sim: &mut Sim, anchor: &str) {
    sim.ctx.begin_step(&sim.world);
    for s in systems::default_schedule().names().into_iter().take_while(|name| *name != anchor) {
        (systems::find(s).expect("shipped").run)(&mut sim.world, &mut sim.ctx);
    }
}

fn each_system(c: &mut Criterion) {
    for name in systems::DEFAULT_ORDER.iter().copied().chain(["cull_all_pairs"]) {
        let mut group = c.benchmark_group(format!("system/{name}"));
        group.sample_size(10);
        let counts: &[u32] = if name == "cull_all_pairs" { &[1000, 4000] } else { &[1000, 4000, 16000] };
        // `cull_all_pairs` stands where `cull` does.
        let anchor = if name == "cull_all_pairs" { "cull" } else { name };
        let run = systems::find(name).expect("shipped").run;
        for &n in counts {
            let mut sim = rigid_sandbox::scene::benchmarks::box_gas_sim(n, 1);
            sim.run(20).expect("finite"); // warm-up, as in docs/benchmarks.md
            group.throughput(Throughput::Elements(u64::from(n)));
            group.bench_function(BenchmarkId::new(name, n), |b| {
                b.iter_custom(|iters| {
                    let mut total = Duration::ZERO;
                    for _ in 0..iters {
                        run_up_to(&mut sim, anchor);
                        let start = Instant::now();
                        run(&mut sim.world, &mut sim.ctx);
                        total += start.elapsed();
                    }
                    total
                });
            });
        }
        group.finish();
    }
}

criterion_group!(benches, each_system);
criterion_main!(benches);
