//! The `rigid bench` driver (docs/benchmarks.md): builds a benchmark scene, warms up, times the
//! schedule's steps, and reports per size as a table row or a JSON line.

use super::{AppError, check_writable, outln, write_error, write_out};
use crate::cli::args::BenchArgs;
use crate::math::Vector;
use crate::scene::benchmarks::{BenchScene, DEFAULT_HULL_RAIN_SUBDIVISIONS, rain_half_width, scene_sim};
use crate::scene::spawners::box_gas_half_extent;
use crate::sim::schedule::StepProfile;
use crate::solver::Joints;
use std::collections::BTreeMap;
use std::time::Duration;

/// What one benchmark run measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BenchResult {
    /// Scene name.
    pub scene: &'static str,
    /// Number of free cubes (hull-rain: icospheres).
    pub actors: u32,
    /// Pyramid only: cubes in the base row.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub base: Option<u32>,
    /// Hull-rain only: subdivisions of the icospheres.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub subdivisions: Option<u32>,
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
    /// Pendulums: the largest joint position error at the end [m].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub joint_error_m: Option<f64>,
    /// Rain and hull-rain: bodies whose centre ended outside the container (or below the floor).
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
    run_set(scene, size, steps, warmup, seed, threads, sleep, &[])
}

/// As `run`, with `--set` overrides (`dt`, `gravity`, `solver.<field>`) applied to the built
/// scene after `sleep`; check them first with `crate::scene::overrides::apply_to_sim`.
#[allow(clippy::too_many_arguments)]
pub fn run_set(
    scene: BenchScene,
    size: u32,
    steps: u64,
    warmup: u64,
    seed: u64,
    threads: usize,
    sleep: bool,
    set: &[String],
) -> Result<BenchResult, crate::error::StepError> {
    let mut sim = scene_sim(scene, size, seed);
    sim.ctx.params.sleep = sleep;
    crate::scene::overrides::apply_to_sim(&mut sim, set).expect("overrides are checked before the runs");
    let sleep = sim.ctx.params.sleep;
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
        per_step.push(p.snapshot + p.store + p.systems.iter().map(|s| s.1).sum::<Duration>());
        *parts.entry("snapshot".into()).or_default() += p.snapshot;
        *parts.entry("store".into()).or_default() += p.store;
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
        BenchScene::Rain | BenchScene::HullRain { .. } => {
            let a = rain_half_width(size);
            (None, None, Some(end.iter().filter(|x| x.x.abs() > a || x.z.abs() > a || x.y < 0.0).count()))
        }
        BenchScene::Pendulums { .. } => (None, None, None),
    };
    let joint_error_m = sim.ctx.scratch.get::<Joints>().filter(|j| !j.joints.is_empty()).map(|j| {
        let poses: Vec<_> = sim.actors().iter().map(|a| (a.pose.position, a.pose.orientation)).collect();
        j.errors(&poses).iter().map(|e| e.0).fold(0.0, f64::max)
    });
    Ok(BenchResult {
        scene: scene.name(),
        actors: cubes.len() as u32,
        joint_error_m,
        base: (scene == BenchScene::Pyramid).then_some(size),
        subdivisions: match scene {
            BenchScene::HullRain { subdivisions } => Some(subdivisions),
            _ => None,
        },
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

/// `rigid bench`: runs each size and prints a table or JSON lines, and the CSV and plot asked for.
pub(super) fn bench(args: &BenchArgs) -> Result<(), AppError> {
    for (file, flag) in [(&args.csv, "--csv"), (&args.plot, "--plot")] {
        if let Some(file) = file {
            check_writable(file, flag)?;
        }
    }
    use crate::scene::benchmarks::BenchScene;
    let threads = rayon::current_num_threads();
    let subdivisions = args.subdivisions.unwrap_or(DEFAULT_HULL_RAIN_SUBDIVISIONS);
    // clap admits only the names `BenchScene::named` knows.
    let scene = BenchScene::named(&args.scene, subdivisions).unwrap_or(BenchScene::BoxGas);
    let mut sizes = if scene == BenchScene::Pyramid { args.base.clone() } else { args.actors.clone() };
    if args.subdivisions.is_some() && !matches!(scene, BenchScene::HullRain { .. }) {
        return Err(AppError::Usage(format!("bench {}: --subdivisions applies to hull-rain only", scene.name())));
    }
    if sizes.is_empty() {
        let flag = if scene == BenchScene::Pyramid { "--base" } else { "--actors" };
        return Err(AppError::Usage(format!("bench {}: give {flag} N[,N...]", scene.name())));
    }
    // Checked once, before any run, on a throwaway sim: a bad `--set` is bad input.
    let mut probe = crate::sim::Sim::new(1.0 / 60.0, Default::default(), crate::systems::default_schedule());
    crate::scene::overrides::apply_to_sim(&mut probe, &args.set).map_err(AppError::Usage)?;
    sizes.sort_unstable();
    let gas = scene == BenchScene::BoxGas;
    let steps = args.steps.unwrap_or(if gas { 200 } else { 600 });
    let warmup = args.warmup.unwrap_or(if gas { 20 } else { 0 });
    let mut rows = Vec::new();
    if !args.json {
        outln!(
            "{:>8} {:>8} {:>12} {:>12} {:>14} {:>14} {:>12} {:>10}",
            "actors",
            "threads",
            "mean ms",
            "median ms",
            "ke start",
            "ke end",
            "check",
            "rss MiB"
        );
    }
    for size in sizes {
        let r = run_set(scene, size, steps, warmup, args.seed, threads, args.sleep, &args.set)?;
        if args.json {
            outln!("{}", serde_json::to_string(&r).expect("plain data serialises"));
        } else {
            let check = match (r.escaped, r.max_displacement_m, r.outside) {
                (Some(e), _, _) => format!("{e} escaped"),
                (_, Some(d), _) => format!("{d:.4} m moved"),
                (_, _, Some(o)) => format!("{o} outside"),
                _ => String::new(),
            };
            outln!(
                "{:>8} {:>8} {:>12.3} {:>12.3} {:>14.4} {:>14.4} {:>12} {:>10.1}",
                r.actors,
                r.threads,
                r.mean_ms_per_step,
                r.median_ms_per_step,
                r.ke_start,
                r.ke_end,
                check,
                r.peak_rss_mib
            );
            let parts: Vec<String> = r.systems_ms.iter().map(|(k, v)| format!("{k} {v:.3}")).collect();
            outln!("         ms/step by system: {}", parts.join(", "));
        }
        rows.push(r);
    }
    if let Some(path) = &args.csv {
        let mut csv = String::from(
            "scene,actors,threads,steps,mean_ms_per_step,median_ms_per_step,ke_start,ke_end,escaped,max_displacement_m,outside,peak_rss_mib\n",
        );
        let opt = |v: Option<String>| v.unwrap_or_default();
        for r in &rows {
            csv += &format!(
                "{},{},{},{},{},{},{},{},{},{},{},{}\n",
                r.scene,
                r.actors,
                r.threads,
                r.steps,
                r.mean_ms_per_step,
                r.median_ms_per_step,
                r.ke_start,
                r.ke_end,
                opt(r.escaped.map(|v| v.to_string())),
                opt(r.max_displacement_m.map(|v| v.to_string())),
                opt(r.outside.map(|v| v.to_string())),
                r.peak_rss_mib
            );
        }
        write_out(path, csv)?;
    }
    if let Some(path) = &args.plot {
        let tmp = crate::io::output::temp_path(path);
        crate::cli::plot::plot_svg(&tmp, &rows)
            .and_then(|()| std::fs::rename(&tmp, path).map_err(|e| e.to_string()))
            .map_err(|reason| write_error(path, std::io::Error::other(reason)))?;
    }
    Ok(())
}
