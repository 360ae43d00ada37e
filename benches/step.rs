//! A full step against actor count: box-gas (docs/benchmarks.md, no gravity, every pair colliding)
//! and a resting pyramid (gravity, friction: the contact solver's cost).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};

fn step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step/box-gas");
    group.sample_size(10);
    for n in [1000_u32, 4000, 16000] {
        let mut sim = rigid_sandbox::scene::benchmarks::box_gas_sim(n, 1);
        sim.run(20).expect("finite"); // untimed warm-up, as in docs/benchmarks.md
        group.throughput(Throughput::Elements(u64::from(n)));
        group.bench_function(BenchmarkId::from_parameter(n), |b| b.iter(|| sim.step().expect("finite")));
    }
    group.finish();
}

/// A resting pyramid (docs/benchmarks.md) after it has settled: the contact solver's steady cost.
fn pyramid(c: &mut Criterion) {
    let mut group = c.benchmark_group("step/pyramid");
    group.sample_size(10);
    for base in [10_u32, 20, 40] {
        let mut sim =
            rigid_sandbox::scene::benchmarks::scene_sim(rigid_sandbox::scene::benchmarks::BenchScene::Pyramid, base, 1);
        sim.run(60).expect("finite"); // settled
        group.throughput(Throughput::Elements(u64::from(base * (base + 1) / 2)));
        group.bench_function(BenchmarkId::from_parameter(base), |b| b.iter(|| sim.step().expect("finite")));
    }
    group.finish();
}

criterion_group!(benches, step, pyramid);
criterion_main!(benches);
