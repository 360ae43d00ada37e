//! What each `rigid` subcommand does, as library functions so tests can call them; `main`
//! only parses arguments, prints errors and maps them to exit codes (CONTRACTS.md §3).

use crate::cli::{BenchArgs, Command, ExportArgs, RenderArgs, RunArgs, SceneArgs};
use crate::error::{SceneError, SnapshotError, StepError};
use crate::output::{TRAJECTORY_HEADER, state_json, trajectory_rows, write_atomic};
use crate::scene::{self, SceneDef};
use crate::sim::{ActorState, Sim};
use crate::snapshot::Snapshot;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// The scene `rigid run` uses when given none (also `scenes/demo.ron`).
pub const DEMO_SCENE: &str = include_str!("../scenes/demo.ron");

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
    /// CONTRACTS.md §3: 2 for bad input, 1 for any other failure.
    #[must_use]
    pub fn exit_code(&self) -> i32 {
        match self {
            Self::Scene(_) | Self::Snapshot(_) | Self::Usage(_) => 2,
            Self::Interrupted { .. } => 130,
            _ => 1,
        }
    }
}

/// Runs a parsed command, printing to stdout.
pub fn execute(command: Command) -> Result<(), AppError> {
    match command {
        Command::Run(args) => {
            let threads = args.threads;
            in_pool(threads, || run(&args))
        }
        Command::Check { scene } => check(&scene),
        Command::Systems => {
            for name in crate::systems::default_schedule().names() {
                println!("{name}");
            }
            Ok(())
        }
        Command::Bench(args) => {
            let threads = args.threads;
            in_pool(threads, || bench(&args))
        }
        Command::Render(args) => in_pool(None, || render(&args)),
        Command::Export(args) => in_pool(None, || export(&args)),
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

/// Set by the Ctrl-C handler; the run loop stops at the next step boundary.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The sim to run, with its scene text and path: a fresh scene, or a resumed snapshot.
fn prepare(args: &RunArgs) -> Result<(Sim, PathBuf, String, u64), AppError> {
    if let Some(file) = &args.resume {
        let snap = read_snapshot(file)?;
        let path = PathBuf::from(&snap.scene_path);
        let mut def = scene::parse(&snap.scene_text, &path)?;
        def.dt = snap.dt;
        def.schedule = Some(snap.schedule.clone());
        let steps = args.steps.unwrap_or(def.steps);
        let mut sim = crate::build::build(&def, &path)?;
        snap.restore(&mut sim).map_err(|message| SnapshotError { path: file.clone(), at: None, message })?;
        return Ok((sim, path, snap.scene_text, steps));
    }
    let (mut def, path, text) = load_scene_text(args.scene.as_deref())?;
    if let Some(dt) = args.dt {
        def.dt = dt;
    }
    if let Some(names) = &args.schedule {
        def.schedule = Some(names.clone());
    }
    let steps = args.steps.unwrap_or(def.steps);
    Ok((crate::build::build(&def, &path)?, path, text, steps))
}

fn read_snapshot(file: &Path) -> Result<Snapshot, SnapshotError> {
    let fail = |at, message: String| SnapshotError { path: file.to_path_buf(), at, message };
    let text = std::fs::read_to_string(file).map_err(|e| fail(None, format!("cannot read: {e}")))?;
    let snap: Snapshot =
        serde_json::from_str(&text).map_err(|e| fail(Some((e.line(), e.column())), format!("not a snapshot: {e}")))?;
    if snap.format != crate::snapshot::SNAPSHOT_FORMAT {
        return Err(fail(None, format!("snapshot format {} is not {}", snap.format, crate::snapshot::SNAPSHOT_FORMAT)));
    }
    Ok(snap)
}

fn print_warnings(sim: &mut Sim, path: &Path) {
    let warnings = crate::warnings::scene_warnings(sim);
    for w in warnings.iter().take(10) {
        eprintln!("warning: {}: {w}", path.display());
    }
    if warnings.len() > 10 {
        eprintln!("warning: {}: ... and {} more", path.display(), warnings.len() - 10);
    }
}

fn run(args: &RunArgs) -> Result<(), AppError> {
    let (mut sim, path, text, steps) = prepare(args)?;
    if args.resume.is_none() {
        print_warnings(&mut sim, &path);
    }
    // Ctrl-C stops at the next step boundary, so the saved state is a whole step's. A second
    // handler cannot be set (tests call `run` repeatedly): then Ctrl-C just ends the process.
    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::SeqCst));
    let save = |sim: &Sim| match &args.save {
        Some(file) => write_out(
            file,
            serde_json::to_string(&Snapshot::capture(sim, &path.display().to_string(), &text)).expect("plain data"),
        ),
        None => Ok(()),
    };
    let show = !args.quiet && std::io::stderr().is_terminal();
    let before = sim.totals();
    let mut trajectory = match &args.trajectory {
        Some(p) => Some((p, trajectory_start(p, &sim)?)),
        None => None,
    };
    let bar = show.then(|| progress_bar(steps));
    let start = Instant::now();
    let mut last_good: Option<Vec<ActorState>> = None;
    for _ in 0..steps {
        if INTERRUPTED.swap(false, Ordering::SeqCst) {
            // Keep what the run has made so far: state, snapshot and trajectory to this step.
            save(&sim)?;
            if let Some(out) = &args.out {
                write_out(out, state_json(&sim, &sim.actors()))?;
            }
            finish_trajectory(trajectory)?;
            return Err(AppError::Interrupted { step: sim.steps });
        }
        if args.out.is_some() {
            last_good = Some(sim.actors());
        }
        if let Err(e) = sim.step() {
            if let (Some(out), Some(state)) = (&args.out, &last_good) {
                write_out(out, state_json(&sim, state))?;
            }
            if let Some((p, _)) = &trajectory {
                let _ = std::fs::remove_file(crate::output::temp_path(p));
            }
            return Err(e.into());
        }
        if let Some((p, buf)) = &mut trajectory
            && sim.steps % args.every == 0
        {
            trajectory_rows(buf, sim.steps, sim.time, &sim.actors()).map_err(|e| write_error(p, e))?;
        }
        if let Some(bar) = &bar {
            bar.inc(1);
        }
    }
    let wall = start.elapsed();
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    finish_trajectory(trajectory)?;
    if let Some(out) = &args.out {
        write_out(out, state_json(&sim, &sim.actors()))?;
    }
    save(&sim)?;
    if !args.quiet {
        print_summary(&sim, &before, wall);
    }
    Ok(())
}

/// Flushes the trajectory's temporary file and renames it into place.
fn finish_trajectory(trajectory: Option<(&PathBuf, std::io::BufWriter<std::fs::File>)>) -> Result<(), AppError> {
    let Some((p, buf)) = trajectory else { return Ok(()) };
    buf.into_inner()
        .map_err(|e| e.into_error())
        .and_then(|file| file.sync_all())
        .and_then(|()| std::fs::rename(crate::output::temp_path(p), p))
        .map_err(|e| write_error(p, e))
}

/// Opens the trajectory's temporary file and writes the header and the starting state (step 0,
/// or the step a resumed run starts from). Rows stream to disk: a long run of many actors does
/// not hold its trajectory in memory.
fn trajectory_start(path: &Path, sim: &Sim) -> Result<std::io::BufWriter<std::fs::File>, AppError> {
    let file = std::fs::File::create(crate::output::temp_path(path)).map_err(|e| write_error(path, e))?;
    let mut buf = std::io::BufWriter::new(file);
    writeln!(buf, "{TRAJECTORY_HEADER}").map_err(|e| write_error(path, e))?;
    trajectory_rows(&mut buf, sim.steps, sim.time, &sim.actors()).map_err(|e| write_error(path, e))?;
    Ok(buf)
}

fn write_error(path: &Path, source: std::io::Error) -> AppError {
    AppError::Write { path: path.to_path_buf(), source }
}

fn write_out(path: &Path, bytes: impl AsRef<[u8]>) -> Result<(), AppError> {
    write_atomic(path, bytes.as_ref()).map_err(|e| write_error(path, e))
}

fn progress_bar(steps: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(steps);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} steps  {per_sec}  eta {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar
}

fn print_summary(sim: &Sim, before: &crate::sim::Totals, wall: std::time::Duration) {
    let after = sim.totals();
    let secs = wall.as_secs_f64();
    let rate = if secs > 0.0 { sim.steps as f64 / secs } else { f64::INFINITY };
    println!("simulated {:.4} s in {} steps of {} s, {} actors", sim.time, sim.steps, sim.ctx.dt, sim.len());
    println!("wall time {secs:.3} s ({rate:.0} steps/s)");
    let [f, v, e] = sim.contacts;
    println!("impulses: face {f}, vertex {v}, edge {e}");
    println!("momentum drift |Δp| = {:.3e} kg·m/s", (after.linear_momentum - before.linear_momentum).length());
    let ke0 = before.kinetic_energy;
    let rel =
        if ke0 > 0.0 { format!(" ({:+.3e} relative)", (after.kinetic_energy - ke0) / ke0) } else { String::new() };
    println!("kinetic energy {ke0} J -> {} J{rel}", after.kinetic_energy);
}

fn check(path: &Path) -> Result<(), AppError> {
    let (def, path) = load_scene(Some(path))?;
    let mut sim = crate::build::build(&def, &path)?;
    print_warnings(&mut sim, &path);
    println!("{}: ok", path.display());
    println!("dt {} s, {} steps, gravity {:?}", def.dt, def.steps, def.gravity);
    println!("schedule: {}", sim.schedule.names().join(", "));
    println!("{} actors, {} distinct meshes", sim.len(), sim.ctx.meshes.len());
    for a in sim.actors().iter().take(20) {
        let fixed = if a.mass.is_fixed() { " (fixed)" } else { "" };
        println!("  {}: mass {} kg at {}{fixed}", a.name, a.mass.mass, a.pose.position);
    }
    if sim.len() > 20 {
        println!("  ... and {} more", sim.len() - 20);
    }
    Ok(())
}

fn bench(args: &BenchArgs) -> Result<(), AppError> {
    use crate::bench::BenchScene;
    let threads = rayon::current_num_threads();
    let (scene, mut sizes) = match args.scene.as_str() {
        "pyramid" => (BenchScene::Pyramid, args.base.clone()),
        "rain" => (BenchScene::Rain, args.actors.clone()),
        _ => (BenchScene::BoxGas, args.actors.clone()),
    };
    if sizes.is_empty() {
        let flag = if scene == BenchScene::Pyramid { "--base" } else { "--actors" };
        return Err(AppError::Usage(format!("bench {}: give {flag} N[,N...]", scene.name())));
    }
    sizes.sort_unstable();
    let gas = scene == BenchScene::BoxGas;
    let steps = args.steps.unwrap_or(if gas { 200 } else { 600 });
    let warmup = args.warmup.unwrap_or(if gas { 20 } else { 0 });
    let mut rows = Vec::new();
    if !args.json {
        println!(
            "{:>8} {:>8} {:>12} {:>12} {:>14} {:>14} {:>12} {:>10}",
            "actors", "threads", "mean ms", "median ms", "ke start", "ke end", "check", "rss MiB"
        );
    }
    for size in sizes {
        let r = crate::bench::run(scene, size, steps, warmup, args.seed, threads, args.sleep)?;
        if args.json {
            println!("{}", serde_json::to_string(&r).expect("plain data serialises"));
        } else {
            let check = match (r.escaped, r.max_displacement_m, r.outside) {
                (Some(e), _, _) => format!("{e} escaped"),
                (_, Some(d), _) => format!("{d:.4} m moved"),
                (_, _, Some(o)) => format!("{o} outside"),
                _ => String::new(),
            };
            println!(
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
            println!("         ms/step by system: {}", parts.join(", "));
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
        let tmp = crate::output::temp_path(path);
        crate::plot::plot_svg(&tmp, &rows)
            .and_then(|()| std::fs::rename(&tmp, path).map_err(|e| e.to_string()))
            .map_err(|reason| write_error(path, std::io::Error::other(reason)))?;
    }
    Ok(())
}

/// Loads and builds the scene of `render`/`export`; returns it with the number of steps.
fn scene_sim(args: &SceneArgs) -> Result<(SceneDef, Sim, u64), AppError> {
    let (mut def, path) = load_scene(args.scene.as_deref())?;
    if let Some(dt) = args.dt {
        def.dt = dt;
    }
    let steps = args.steps.unwrap_or(def.steps);
    let sim = crate::build::build(&def, &path)?;
    Ok((def, sim, steps))
}

/// Runs `steps` steps, calling `visit` at step 0, every `every`-th step and the last step.
fn sample(
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

fn render(args: &RenderArgs) -> Result<(), AppError> {
    use crate::render::Overlay;
    let (def, mut sim, steps) = scene_sim(&args.scene)?;
    std::fs::create_dir_all(&args.out).map_err(|e| write_error(&args.out, e))?;
    let (w, h) = args.size;
    let overlay = Overlay { contacts: args.contacts, solid_fixed: args.solid_fixed };
    let camera = choose_camera(args, def.camera, &sim);
    let mut gif = Vec::new();
    let mut frames = 0_u32;
    let mut encoder = args.gif.as_ref().map(|_| {
        let mut e = image::codecs::gif::GifEncoder::new_with_speed(&mut gif, 10);
        let _ = e.set_repeat(image::codecs::gif::Repeat::Infinite);
        e
    });
    // Real-time playback where GIF delays allow (at least 20 ms a frame).
    let delay_ms = ((def.dt * args.scene.every as f64 * 1000.0).round() as u32).max(20);
    sample(&mut sim, steps, args.scene.every, |sim| {
        let image = crate::render::render(sim, &camera, w, h, overlay);
        let file = args.out.join(format!("frame-{frames:05}.png"));
        let mut png = Vec::new();
        image
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(|e| write_error(&file, std::io::Error::other(e)))?;
        write_out(&file, png)?;
        if let (Some(enc), Some(path)) = (encoder.as_mut(), &args.gif) {
            let rgba = image::DynamicImage::ImageRgb8(image).into_rgba8();
            let frame = image::Frame::from_parts(rgba, 0, 0, image::Delay::from_numer_denom_ms(delay_ms, 1));
            enc.encode_frame(frame).map_err(|e| write_error(path, std::io::Error::other(e)))?;
        }
        frames += 1;
        Ok(())
    })?;
    drop(encoder);
    if let Some(path) = &args.gif {
        write_out(path, gif)?;
    }
    println!("wrote {frames} frames of {w}x{h} to {}", args.out.display());
    Ok(())
}

/// The camera: `--eye`/`--target` over the scene's `camera`, over one fitted to the scene.
fn choose_camera(args: &RenderArgs, scene: Option<crate::scene::CameraDef>, sim: &Sim) -> crate::render::Camera {
    use crate::math::Vector;
    let base = scene.map_or_else(
        || crate::render::Camera::fit(sim),
        |c| crate::render::Camera {
            eye: crate::scene::vector(c.eye),
            target: crate::scene::vector(c.target),
            fov_y: c.fov.to_radians(),
        },
    );
    crate::render::Camera {
        eye: args.eye.map_or(base.eye, Vector::from_array),
        target: args.target.map_or(base.target, Vector::from_array),
        fov_y: base.fov_y,
    }
}

fn export(args: &ExportArgs) -> Result<(), AppError> {
    use crate::export::{ExportScene, Keyframe, glb};
    let (_, mut sim, steps) = scene_sim(&args.scene)?;
    let mut keyframes = Vec::new();
    sample(&mut sim, steps, args.scene.every, |sim| {
        let poses = sim.actors().iter().map(|a| (a.pose.position.to_array(), a.pose.orientation.to_array())).collect();
        keyframes.push(Keyframe { time: sim.time, poses });
        Ok(())
    })?;
    let mut query = sim.world.query::<(&crate::ActorIndex, &crate::Mesh, &crate::MassProps)>();
    let mut rows: Vec<_> = query.iter().map(|(i, m, mass)| (i.0 as usize, m.id, mass.is_fixed())).collect();
    drop(query);
    rows.sort_by_key(|r| r.0);
    let meshes = (0..sim.ctx.meshes.len()).map(|k| sim.ctx.meshes.get(crate::MeshId(k as u32))).collect();
    let actors = rows
        .iter()
        .map(|&(i, mesh, fixed)| {
            (sim.names()[i].clone(), mesh.0 as usize, fixed, crate::render::actor_colour(i, fixed))
        })
        .collect();
    let bytes = glb(&ExportScene { actors, meshes }, &keyframes);
    write_out(&args.glb, &bytes)?;
    println!("wrote {} actors, {} keyframes to {}", sim.len(), keyframes.len(), args.glb.display());
    Ok(())
}
