//! The `rigid bench` driver (BENCHMARKS.md): builds the box-gas scene, warms up, times the
//! schedule's steps, and reports per N as a table row or a JSON line.

use crate::build::spawn_all;
use crate::math::Vector;
use crate::schedule::StepProfile;
use crate::sim::Sim;
use crate::spawners::{box_gas, box_gas_half_extent};
use crate::step::Params;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

/// What one benchmark run measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchResult {
    /// Scene name.
    pub scene: &'static str,
    /// Number of cubes.
    pub actors: u32,
    /// Timed steps.
    pub steps: u64,
    /// Untimed warm-up steps.
    pub warmup: u64,
    /// Scene seed.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
    /// Mean wall time of the schedule per timed step [ms].
    pub mean_ms_per_step: f64,
    /// Median of the same [ms].
    pub median_ms_per_step: f64,
    /// Kinetic energy before the first step [J].
    pub ke_start: f64,
    /// Kinetic energy after warm-up and timed steps [J].
    pub ke_end: f64,
    /// Cubes whose centre ended outside the box's inner half-extent.
    pub escaped: usize,
    /// Peak resident memory of the process so far [MiB] (runs go in ascending N, so each
    /// row's value is its own peak as long as N only grows).
    pub peak_rss_mib: f64,
    /// Mean candidate pairs per timed step (broad-phase output).
    pub candidates_per_step: f64,
    /// Mean contacts found per timed step (narrow-phase output).
    pub contacts_per_step: f64,
    /// Mean time per step of each part of the step, by system name [ms].
    pub systems_ms: BTreeMap<String, f64>,
}

/// The box-gas simulation of BENCHMARKS.md with `n` cubes (walls after the cubes), no gravity,
/// dt = 1/60, the default schedule.
#[must_use]
pub fn box_gas_sim(n: u32, seed: u64) -> Sim {
    let params = Params { gravity: Vector::ZERO, ..Params::default() };
    let mut sim = Sim::new(1.0 / 60.0, params, crate::systems::default_schedule());
    spawn_all(&mut sim, &box_gas(n, seed), Path::new("box-gas")).expect("the box-gas scene is valid");
    sim
}

/// Runs box-gas with `n` cubes: `warmup` untimed steps, then `steps` timed ones. Call it
/// inside the rayon pool of the wanted thread count.
pub fn run_box_gas(
    n: u32,
    steps: u64,
    warmup: u64,
    seed: u64,
    threads: usize,
) -> Result<BenchResult, crate::error::StepError> {
    let mut sim = box_gas_sim(n, seed);
    let ke_start = sim.totals().kinetic_energy;
    sim.run(warmup)?;
    let mut per_step = Vec::with_capacity(steps as usize);
    let mut parts: BTreeMap<String, Duration> = BTreeMap::new();
    let (mut candidates, mut contacts) = (0_usize, 0_u64);
    for _ in 0..steps {
        sim.step()?;
        candidates += sim.ctx.stats.candidates;
        contacts += sim.ctx.stats.found.iter().sum::<u64>();
        let p: &StepProfile = &sim.profile;
        per_step.push(p.snapshot + p.systems.iter().map(|s| s.1).sum::<Duration>());
        *parts.entry("snapshot".into()).or_default() += p.snapshot;
        for (name, d) in &p.systems {
            *parts.entry((*name).to_string()).or_default() += *d;
        }
    }
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let mean = per_step.iter().map(|d| ms(*d)).sum::<f64>() / steps.max(1) as f64;
    per_step.sort_unstable();
    let median = per_step.get(per_step.len() / 2).map_or(0.0, |d| ms(*d));
    let a = box_gas_half_extent(n);
    // Cubes are rows 0..n of the snapshot (refreshed: with no steps it was never taken).
    sim.ctx.bodies.load(&sim.world);
    let escaped = sim.ctx.bodies.position[..n as usize].iter().filter(|x| x.abs().max_element() > a).count();
    Ok(BenchResult {
        scene: "box-gas",
        actors: n,
        steps,
        warmup,
        seed,
        threads,
        mean_ms_per_step: mean,
        median_ms_per_step: median,
        ke_start,
        ke_end: sim.totals().kinetic_energy,
        escaped,
        peak_rss_mib: peak_rss_mib(),
        candidates_per_step: candidates as f64 / steps.max(1) as f64,
        contacts_per_step: contacts as f64 / steps.max(1) as f64,
        systems_ms: parts.into_iter().map(|(k, d)| (k, ms(d) / steps.max(1) as f64)).collect(),
    })
}

/// Peak resident set size of this process [MiB] (Linux `VmHWM`; 0 where unavailable).
#[must_use]
pub fn peak_rss_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("VmHWM:")).and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kib| kib / 1024.0)
}
