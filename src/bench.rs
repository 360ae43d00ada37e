//! The `rigid bench` driver (BENCHMARKS.md): builds a benchmark scene, warms up, times the
//! schedule's steps, and reports per size as a table row or a JSON line.

use crate::build::spawn_all;
use crate::math::Vector;
use crate::schedule::StepProfile;
use crate::sim::Sim;
use crate::spawners::{Instance, box_gas, box_gas_half_extent};
use crate::stacks::{pyramid, rain, rain_half_width};
use crate::step::Params;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

/// The benchmark scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchScene {
    /// Unit cubes in a closed box, no gravity, e = 1 (size = cubes).
    BoxGas,
    /// A pyramid of cubes on the ground (size = cubes in the base row).
    Pyramid,
    /// Cubes dropped into an open box (size = cubes).
    Rain,
}

impl BenchScene {
    /// The scene's name in output.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::BoxGas => "box-gas",
            Self::Pyramid => "pyramid",
            Self::Rain => "rain",
        }
    }

    /// The actors of the scene of this size.
    fn instances(self, size: u32, seed: u64) -> Vec<Instance> {
        match self {
            Self::BoxGas => box_gas(size, seed),
            Self::Pyramid => pyramid(size),
            Self::Rain => rain(size, seed),
        }
    }

    /// Which actor indices are the cubes: box-gas puts its 6 walls after them, the others
    /// their ground (1) or floor and walls (5) before, as the peer harness does.
    fn cubes(self, actors: usize) -> std::ops::Range<usize> {
        match self {
            Self::BoxGas => 0..actors - 6,
            Self::Pyramid => 1..actors,
            Self::Rain => 5..actors,
        }
    }
}

/// What one benchmark run measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchResult {
    /// Scene name.
    pub scene: &'static str,
    /// Number of free cubes.
    pub actors: u32,
    /// Pyramid only: cubes in the base row.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base: Option<u32>,
    /// Timed steps.
    pub steps: u64,
    /// Untimed warm-up steps.
    pub warmup: u64,
    /// Scene seed.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
    /// Sleeping of resting bodies (the sandbox has none: always false).
    pub sleep: bool,
    /// Mean wall time of the schedule per timed step [ms].
    pub mean_ms_per_step: f64,
    /// Median of the same [ms].
    pub median_ms_per_step: f64,
    /// Kinetic energy before the first step [J].
    pub ke_start: f64,
    /// Kinetic energy after warm-up and timed steps [J].
    pub ke_end: f64,
    /// Box-gas: cubes whose centre ended outside the box's inner half-extent.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub escaped: Option<usize>,
    /// Pyramid: largest distance of any cube centre from its start [m].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_displacement_m: Option<f64>,
    /// Rain: cubes whose centre ended outside the container (or below the floor).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outside: Option<usize>,
    /// Peak resident memory of the process so far [MiB] (runs go in ascending size, so each
    /// row's value is its own peak as long as sizes only grow).
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
    scene_sim(BenchScene::BoxGas, n, seed)
}

/// A benchmark scene as a simulation: dt = 1/60, gravity −9.81 but none for box-gas.
#[must_use]
pub fn scene_sim(scene: BenchScene, size: u32, seed: u64) -> Sim {
    let gravity = if scene == BenchScene::BoxGas { Vector::ZERO } else { Vector::new(0.0, -9.81, 0.0) };
    let mut sim = Sim::new(1.0 / 60.0, Params { gravity, ..Params::default() }, crate::systems::default_schedule());
    spawn_all(&mut sim, &scene.instances(size, seed), Path::new(scene.name())).expect("benchmark scenes are valid");
    sim
}

/// Runs a benchmark scene: `warmup` untimed steps, then `steps` timed ones. Call it inside the
/// rayon pool of the wanted thread count. `sleep` lets still bodies sleep (`Params::sleep`).
pub fn run(
    scene: BenchScene,
    size: u32,
    steps: u64,
    warmup: u64,
    seed: u64,
    threads: usize,
    sleep: bool,
) -> Result<BenchResult, crate::error::StepError> {
    let mut sim = scene_sim(scene, size, seed);
    sim.ctx.params.sleep = sleep;
    let cubes = scene.cubes(sim.len());
    let start: Vec<Vector> = sim.actors()[cubes.clone()].iter().map(|a| a.pose.position).collect();
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
    let per = |x: f64| x / steps.max(1) as f64;
    let mean = per(per_step.iter().map(|d| ms(*d)).sum::<f64>());
    per_step.sort_unstable();
    let median = per_step.get(per_step.len() / 2).map_or(0.0, |d| ms(*d));
    // The snapshot is refreshed: with no steps it was never taken.
    sim.ctx.bodies.load(&sim.world);
    let end = &sim.ctx.bodies.position[cubes.clone()];
    let (escaped, max_displacement_m, outside) = match scene {
        BenchScene::BoxGas => {
            let a = box_gas_half_extent(size);
            (Some(end.iter().filter(|x| x.abs().max_element() > a).count()), None, None)
        }
        BenchScene::Pyramid => {
            (None, Some(end.iter().zip(&start).map(|(x, x0)| (*x - *x0).length()).fold(0.0, f64::max)), None)
        }
        BenchScene::Rain => {
            let a = rain_half_width(size);
            (None, None, Some(end.iter().filter(|x| x.x.abs() > a || x.z.abs() > a || x.y < 0.0).count()))
        }
    };
    Ok(BenchResult {
        scene: scene.name(),
        actors: cubes.len() as u32,
        base: (scene == BenchScene::Pyramid).then_some(size),
        steps,
        warmup,
        seed,
        threads,
        sleep,
        mean_ms_per_step: mean,
        median_ms_per_step: median,
        ke_start,
        ke_end: sim.totals().kinetic_energy,
        escaped,
        max_displacement_m,
        outside,
        peak_rss_mib: peak_rss_mib(),
        candidates_per_step: per(candidates as f64),
        contacts_per_step: per(contacts as f64),
        systems_ms: parts.into_iter().map(|(k, d)| (k, per(ms(d)))).collect(),
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
