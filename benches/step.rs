//! A full box-gas step (BENCHMARKS.md scene) against actor count.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};

fn step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step/box-gas");
    group.sample_size(10);
    for n in [1000_u32, 4000, 16000] {
        let mut sim = rigid_sandbox::bench::box_gas_sim(n, 1);
        sim.run(20).expect("finite"); // untimed warm-up, as in BENCHMARKS.md
        group.throughput(Throughput::Elements(u64::from(n)));
        group.bench_function(BenchmarkId::from_parameter(n), |b| b.iter(|| sim.step().expect("finite")));
    }
    group.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);
