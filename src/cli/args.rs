//! Command-line interface types (docs/cli.md).

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// rigid: a rigid-body dynamics sandbox after "Rigid Body Dynamics Simulator Sandbox".
#[derive(Debug, Parser)]
#[command(
    name = "rigid",
    version,
    about,
    after_help = "With no subcommand, `rigid` runs the built-in demo scene (the same as `rigid run`).\n\
                  Scene format, commands and output files: docs/scenes.md and docs/cli.md."
)]
pub struct Cli {
    /// What to do (default: `run` on the built-in demo scene).
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Simulate a scene (the built-in demo when none is given) and print a summary.
    Run(RunArgs),
    /// Validate a scene and print what it contains; simulates nothing.
    Check {
        /// Scene file (RON).
        scene: PathBuf,
    },
    /// List every shipped system, the default schedule's in run order (marked), then the others.
    Systems {
        /// Every shipped system with what it does, the default schedule's marked, also when
        /// the output is not a terminal.
        #[arg(long)]
        all: bool,
    },
    /// Benchmark a built-in scene (docs/benchmarks.md).
    Bench(BenchArgs),
    /// Simulate a scene and draw PNG frames (and optionally an animated GIF), no GPU needed.
    Render(RenderArgs),
    /// Simulate a scene and write it as an animated binary glTF 2.0 file.
    Export(ExportArgs),
    /// Serve a web page that shows the scene running in 3-D, live, with a JSON API (docs/studio.md).
    Studio(StudioArgs),
}

/// `rigid studio`.
#[derive(Debug, Args)]
pub struct StudioArgs {
    /// Scene file (RON); the built-in demo scene when omitted.
    pub scene: Option<PathBuf>,
    /// Port to listen on; 0 picks a free one (the address is printed).
    #[arg(long, default_value_t = 7878)]
    pub port: u16,
    /// Address to listen on (loopback by default; anything else is reachable from the network).
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Do not try to open a browser; only print the address.
    #[arg(long)]
    pub no_open: bool,
}

/// The scene and its length, shared by `render` and `export`.
#[derive(Debug, Args)]
pub struct SceneArgs {
    /// Scene file (RON); the built-in demo scene when omitted.
    pub scene: Option<PathBuf>,
    /// Steps to simulate (overrides the scene's `steps`).
    #[arg(long, value_parser = parse_steps)]
    pub steps: Option<u64>,
    /// Seconds per step (overrides the scene's `dt`).
    #[arg(long, value_parser = parse_positive)]
    pub dt: Option<f64>,
    /// Sample every K-th step (step 0 and the last step are always included).
    #[arg(long, default_value_t = 5, value_parser = parse_every)]
    pub every: u64,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
    /// Worker threads (default: the number of cores); results are identical for any count.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Change one field of the scene before it is checked, e.g. `gravity=(0.0,-1.62,0.0)` or
    /// `actors["ball"].restitution=0.5` (repeatable, applied in order; docs/cli.md).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<String>,
}

/// `rigid render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Scene, steps and sampling.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Directory for the frames `frame-00000.png`, ... (created if missing; frames of an
    /// earlier render in it are removed first, and said so).
    #[arg(short, long, value_name = "DIR")]
    pub out: PathBuf,
    /// Image size.
    #[arg(long, default_value = "640x480", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Also write an animated GIF of the frames.
    #[arg(long, value_name = "FILE")]
    pub gif: Option<PathBuf>,
    /// Camera position `x,y,z` [m] (default: fitted to the scene, or the scene's `camera`).
    #[arg(long, value_parser = parse_vector, allow_hyphen_values = true)]
    pub eye: Option<[f64; 3]>,
    /// Point the camera looks at, `x,y,z` [m].
    #[arg(long, value_parser = parse_vector, allow_hyphen_values = true)]
    pub target: Option<[f64; 3]>,
    /// Draw the contact points (yellow) and normals (red) of the steps since the last frame.
    #[arg(long)]
    pub contacts: bool,
    /// Fill fixed actors (default: outlines, so closed boxes do not hide their contents).
    #[arg(long)]
    pub solid_fixed: bool,
}

/// `rigid export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Scene, steps and sampling.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The .glb file to write.
    #[arg(long, value_name = "FILE")]
    pub glb: PathBuf,
}

/// `rigid run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Scene file (RON); the built-in demo scene when omitted.
    #[arg(conflicts_with = "resume")]
    pub scene: Option<PathBuf>,
    /// Steps to simulate (overrides the scene's `steps`).
    #[arg(long, value_parser = parse_steps)]
    pub steps: Option<u64>,
    /// Seconds per step (overrides the scene's `dt`).
    #[arg(long, value_parser = parse_positive)]
    pub dt: Option<f64>,
    /// Write the final state as JSON to FILE.
    #[arg(short, long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Write the trajectory as CSV to FILE.
    #[arg(long, value_name = "FILE")]
    pub trajectory: Option<PathBuf>,
    /// Record every K-th step in the trajectory.
    #[arg(long, default_value_t = 1, value_parser = parse_every)]
    pub every: u64,
    /// No progress bar and no summary.
    #[arg(short, long)]
    pub quiet: bool,
    /// Worker threads (default: the number of cores); results are identical for any count.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Comma-separated system names replacing the schedule, e.g. `cull_all_pairs,face,...`.
    #[arg(long, value_delimiter = ',')]
    pub schedule: Option<Vec<String>>,
    /// Write the complete state to FILE at the end, and on Ctrl-C, for `--resume`.
    #[arg(long, value_name = "FILE")]
    pub save: Option<PathBuf>,
    /// Continue the run saved in FILE (by `--save`) for `--steps` more steps.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["dt", "schedule", "set"])]
    pub resume: Option<PathBuf>,
    /// Change one field of the scene before it is checked, e.g. `gravity=(0.0,-1.62,0.0)` or
    /// `actors["ball"].restitution=0.5` (repeatable, applied in order; docs/cli.md).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<String>,
}

impl Default for RunArgs {
    /// The built-in demo with the scene's own settings: what `rigid` alone runs.
    fn default() -> Self {
        Self {
            scene: None,
            steps: None,
            dt: None,
            out: None,
            trajectory: None,
            every: 1,
            quiet: false,
            threads: None,
            schedule: None,
            save: None,
            resume: None,
            set: Vec::new(),
        }
    }
}

/// `rigid bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Scene: `box-gas`, `pyramid`, `rain`, `hull-rain`, `pendulums` or `free-boxes`
    /// (docs/benchmarks.md).
    #[arg(value_parser = ["box-gas", "pyramid", "rain", "hull-rain", "pendulums", "free-boxes"])]
    pub scene: String,
    /// Body counts, comma-separated (box-gas, rain, hull-rain).
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub actors: Vec<u32>,
    /// Base rows, comma-separated (pyramid).
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub base: Vec<u32>,
    /// Subdivisions of hull-rain's icospheres, 0..=5 (hull-rain only; default 2: 162 vertices).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=i64::from(crate::model::shapes::MAX_SUBDIVISIONS)))]
    pub subdivisions: Option<u32>,
    /// Timed steps (default 200 for box-gas, 600 for pyramid, rain and hull-rain).
    #[arg(long, value_parser = parse_steps)]
    pub steps: Option<u64>,
    /// Untimed warm-up steps (default 20 for box-gas, 0 for pyramid, rain and hull-rain).
    #[arg(long, value_parser = parse_steps)]
    pub warmup: Option<u64>,
    /// Scene seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (default: the number of cores).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// One JSON object per line instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Let still bodies sleep (off by default, so the contact solver is measured on every
    /// body; docs/benchmarks.md).
    #[arg(long)]
    pub sleep: bool,
    /// Also write the results as CSV to FILE.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Also draw time per step against actor count (log–log, a line per system) as SVG.
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Change a setting of the built scene: `dt`, `gravity` or `solver.<field>` only, e.g.
    /// `solver.substeps=8` (repeatable, applied in order; docs/cli.md).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub set: Vec<String>,
}

use crate::scene::MAX_STEPS;

fn parse_steps(s: &str) -> Result<u64, String> {
    let n: u64 = s.parse().map_err(|_| format!("'{s}' is not a whole number of steps"))?;
    if n > MAX_STEPS {
        return Err(format!("{n} steps is more than the limit of {MAX_STEPS}"));
    }
    Ok(n)
}

fn parse_every(s: &str) -> Result<u64, String> {
    match s.parse::<u64>() {
        Ok(0) => Err("must be at least 1 (every step), got 0".to_string()),
        Ok(k) => Ok(k),
        Err(_) => Err(format!("'{s}' is not a whole number of steps (1 or more)")),
    }
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT, e.g. 640x480"))?;
    let dim = |d: &str| d.trim().parse::<u32>().ok().filter(|v| (16..=8192).contains(v));
    match (dim(w), dim(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("'{s}': width and height must be whole numbers from 16 to 8192")),
    }
}

fn parse_vector(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not x,y,z"))?;
    match parts[..] {
        [x, y, z] if parts.iter().all(|v| v.is_finite()) => Ok([x, y, z]),
        _ => Err(format!("'{s}' is not three finite numbers x,y,z")),
    }
}

fn parse_positive(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && v > 0.0 { Ok(v) } else { Err(format!("must be a finite number > 0, got {s}")) }
}
