//! What each `rigid` subcommand does, as library functions so tests can call them; `main`
//! only parses arguments, prints errors and maps them to exit codes (docs/cli.md).

pub mod args;
pub mod bench;
mod check;
mod export;
mod plot;
mod render;
mod run;
mod studio;
mod systems;

use crate::cli::args::{Command, SceneArgs};
use crate::error::{SceneError, SnapshotError, StepError};
use crate::io::output::write_atomic;
use crate::scene::{self, SceneDef};
use crate::sim::Sim;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

/// The scene `rigid run` uses when given none (also `scenes/demo.ron`).
pub const DEMO_SCENE: &str = include_str!("../../scenes/demo.ron");

/// Any failure of a subcommand.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum AppError {
    /// Bad scene input (exit 2).
    #[error(transparent)]
    #[diagnostic(transparent)]
    Scene(#[from] SceneError),
    /// A snapshot to resume is unreadable or does not fit its scene (exit 2).
    #[error(transparent)]
    Snapshot(#[from] SnapshotError),
    /// The simulation went non-finite (exit 1).
    #[error(transparent)]
    Step(#[from] StepError),
    /// Writing an output file failed (exit 1).
    #[error("{}: cannot write: {source}", .path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// Stopped by Ctrl-C after saving what was asked (exit 130, the shell's code for SIGINT).
    #[error("interrupted at step {step}")]
    Interrupted {
        /// Steps completed.
        step: u64,
    },
    /// Standard output was closed (`rigid check big.ron | head -1`): the program ends quietly
    /// with exit code 0, as a reader that has seen enough is no failure.
    #[error("standard output closed")]
    OutputClosed,
    /// A command line the argument parser cannot judge alone (exit 2).
    #[error("{0}")]
    Usage(String),
    /// The thread pool could not start (exit 1).
    #[error("cannot start {threads} worker threads: {reason}")]
    Threads {
        /// Threads asked for.
        threads: u32,
        /// Why not.
        reason: String,
    },
}

impl AppError {
    /// docs/cli.md: 2 for bad input, 1 for any other failure.
    #[must_use]
    pub fn exit_code(&self) -> i32 {
        match self {
            Self::Scene(_) | Self::Snapshot(_) | Self::Usage(_) => 2,
            Self::Interrupted { .. } => 130,
            Self::OutputClosed => 0,
            _ => 1,
        }
    }
}

/// Prints a line to standard output; a closed output (a pipe whose reader stopped) becomes
/// `AppError::OutputClosed` instead of the panic `println!` would raise.
macro_rules! outln {
    ($($arg:tt)*) => { $crate::cli::print_line(format_args!($($arg)*))? };
}
pub(crate) use outln;

/// `outln!`'s writer.
pub(crate) fn print_line(args: std::fmt::Arguments) -> Result<(), AppError> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_fmt(args).and_then(|()| out.write_all(b"\n")) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(AppError::OutputClosed),
        Err(e) => Err(AppError::Write { path: PathBuf::from("<standard output>"), source: e }),
        Ok(()) => Ok(()),
    }
}

/// Runs a parsed command, printing to stdout.
pub fn execute(command: Command) -> Result<(), AppError> {
    match command {
        Command::Run(args) => {
            let threads = args.threads;
            in_pool(threads, || run::run(&args))
        }
        Command::Check { scene } => check::check(&scene),
        Command::Systems { all } => systems::list(all),
        Command::Bench(args) => {
            let threads = args.threads;
            in_pool(threads, || bench::bench(&args))
        }
        Command::Render(args) => in_pool(args.scene.threads, || render::render(&args)),
        Command::Export(args) => in_pool(args.scene.threads, || export::export(&args)),
        Command::Studio(args) => studio::studio(&args),
    }
}

/// Runs `f` in a rayon pool of `threads` workers (default: all cores).
fn in_pool(threads: Option<u32>, f: impl FnOnce() -> Result<(), AppError> + Send) -> Result<(), AppError> {
    let n = threads.map_or_else(|| std::thread::available_parallelism().map_or(1, usize::from), |t| t as usize);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| AppError::Threads { threads: n as u32, reason: e.to_string() })?;
    pool.install(f)
}

/// The name the built-in demo scene goes by in messages and snapshots.
pub const DEMO_PATH: &str = "<built-in demo>";

/// Loads a scene file, or the built-in demo for `None`; returns it with the path errors name.
pub fn load_scene(path: Option<&Path>) -> Result<(SceneDef, PathBuf), SceneError> {
    let (def, path, _) = load_scene_text(path)?;
    Ok((def, path))
}

/// As `load_scene`, also returning the scene's text (snapshots embed it).
pub fn load_scene_text(path: Option<&Path>) -> Result<(SceneDef, PathBuf, String), SceneError> {
    let path = path.map_or_else(|| PathBuf::from(DEMO_PATH), Path::to_path_buf);
    let text = if path == Path::new(DEMO_PATH) { DEMO_SCENE.to_string() } else { scene::read(&path)? };
    Ok((scene::parse(&text, &path)?, path, text))
}

/// As `load_scene_text`, with the `--set` overrides applied to the text before it is checked;
/// the text returned is the edited one.
pub fn load_scene_set(path: Option<&Path>, sets: &[String]) -> Result<(SceneDef, PathBuf, String), AppError> {
    if sets.is_empty() {
        return Ok(load_scene_text(path)?);
    }
    let path = path.map_or_else(|| PathBuf::from(DEMO_PATH), Path::to_path_buf);
    let text = if path == Path::new(DEMO_PATH) { DEMO_SCENE.to_string() } else { scene::read(&path)? };
    let (def, edited) = parse_scene_set(&text, &path, sets)?;
    Ok((def, path, edited))
}

/// Scene text parsed with the `--set` overrides applied (`path` names it in errors and locates
/// its OBJ files): the scene and the edited text, or the error `rigid run` reports.
pub fn parse_scene_set(text: &str, path: &Path, sets: &[String]) -> Result<(SceneDef, String), AppError> {
    scene::overrides::parse_with(text, path, sets).map_err(|e| match e {
        scene::overrides::SetError::Set(message) => AppError::Usage(message),
        scene::overrides::SetError::Scene(e) => e.into(),
    })
}

pub(crate) fn print_warnings(sim: &mut Sim, path: &Path) {
    let warnings = crate::scene::warnings::scene_warnings(sim);
    for w in warnings.iter().take(10) {
        eprintln!("warning: {}: {w}", path.display());
    }
    if warnings.len() > 10 {
        eprintln!("warning: {}: ... and {} more", path.display(), warnings.len() - 10);
    }
}

pub(crate) fn write_error(path: &Path, source: std::io::Error) -> AppError {
    AppError::Write { path: path.to_path_buf(), source }
}

pub(crate) fn write_out(path: &Path, bytes: impl AsRef<[u8]>) -> Result<(), AppError> {
    write_atomic(path, bytes.as_ref()).map_err(|e| write_error(path, e))
}

/// A progress bar over `steps` steps, or none when `quiet` or stderr is not a terminal.
pub(crate) fn progress_bar(steps: u64, quiet: bool) -> Option<indicatif::ProgressBar> {
    if quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new(steps);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} steps  {per_sec}  eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    Some(bar)
}

/// Checks, before any simulating, that `path` can be written: its folder exists and is a
/// folder, and `path` itself is not a folder. A run must not compute for minutes and then fail.
pub(crate) fn check_writable(path: &Path, flag: &str) -> Result<(), AppError> {
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let problem = if !parent.is_dir() {
        Some(format!("folder {} does not exist", parent.display()))
    } else if path.is_dir() {
        Some("is a folder; give a file name".to_string())
    } else {
        None
    };
    match problem {
        Some(p) => Err(AppError::Usage(format!("{flag} {}: cannot write: {p}", path.display()))),
        None => Ok(()),
    }
}

/// Loads and builds the scene of `render`/`export`; returns it with the number of steps.
pub(crate) fn scene_sim(args: &SceneArgs) -> Result<(SceneDef, Sim, u64), AppError> {
    let (mut def, path, text) = load_scene_set(args.scene.as_deref(), &args.set)?;
    if let Some(dt) = args.dt {
        def.dt = dt;
    }
    let steps = args.steps.unwrap_or(def.steps);
    let sim = crate::scene::build_from_text(&def, &path, &text)?;
    Ok((def, sim, steps))
}

/// Runs `steps` steps, calling `visit` at step 0, every `every`-th step and the last step.
pub(crate) fn sample(
    sim: &mut Sim,
    steps: u64,
    every: u64,
    mut visit: impl FnMut(&Sim) -> Result<(), AppError>,
) -> Result<(), AppError> {
    visit(sim)?;
    for _ in 0..steps {
        sim.step()?;
        if sim.steps.is_multiple_of(every) || sim.steps == steps {
            visit(sim)?;
        }
    }
    Ok(())
}

/// Six significant digits, in scientific notation outside 1e-3..1e6 (and plain 0).
pub(crate) fn significant(x: f64) -> String {
    if x == 0.0 || ((1e-3..1e6).contains(&x.abs())) {
        let s = format!("{x:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{x:.5e}")
    }
}
