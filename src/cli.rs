//! Command-line interface types (CONTRACTS.md §3).

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// rigid: a rigid-body dynamics sandbox after "Rigid Body Dynamics Simulator Sandbox".
#[derive(Debug, Parser)]
#[command(name = "rigid", version, about)]
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
    /// Print the default schedule, one system a line, in run order.
    Systems,
    /// Benchmark a built-in scene (BENCHMARKS.md).
    Bench(BenchArgs),
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
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Write the trajectory as CSV to FILE.
    #[arg(long, value_name = "FILE")]
    pub trajectory: Option<PathBuf>,
    /// Record every K-th step in the trajectory.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    pub every: u64,
    /// No progress bar and no summary.
    #[arg(long)]
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
    #[arg(long, value_name = "FILE", conflicts_with_all = ["dt", "schedule"])]
    pub resume: Option<PathBuf>,
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
        }
    }
}

/// `rigid bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Scene: `box-gas`.
    #[arg(value_parser = ["box-gas"])]
    pub scene: String,
    /// Actor counts, comma-separated.
    #[arg(long, value_delimiter = ',', required = true, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    pub actors: Vec<u32>,
    /// Timed steps.
    #[arg(long, default_value_t = 200, value_parser = parse_steps)]
    pub steps: u64,
    /// Untimed warm-up steps.
    #[arg(long, default_value_t = 20, value_parser = parse_steps)]
    pub warmup: u64,
    /// Scene seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads (default: the number of cores).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// One JSON object per line instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Also write the results as CSV to FILE.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Also draw time per step against actor count (log–log, a line per system) as SVG.
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
}

use crate::scene::MAX_STEPS;

fn parse_steps(s: &str) -> Result<u64, String> {
    let n: u64 = s.parse().map_err(|_| format!("'{s}' is not a whole number of steps"))?;
    if n > MAX_STEPS {
        return Err(format!("{n} steps is more than the limit of {MAX_STEPS}"));
    }
    Ok(n)
}

fn parse_positive(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && v > 0.0 { Ok(v) } else { Err(format!("must be a finite number > 0, got {s}")) }
}
