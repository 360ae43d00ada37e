//! `rigid run`: steps a scene (or resumes a snapshot), streams the trajectory, writes the
//! final state and snapshot, and prints a summary; Ctrl-C stops at a step boundary.

use super::{
    AppError, check_writable, load_scene_set, outln, print_warnings, progress_bar, significant, write_error, write_out,
};
use crate::cli::args::RunArgs;
use crate::error::SnapshotError;
use crate::io::output::{TRAJECTORY_HEADER, state_json, trajectory_rows};
use crate::io::snapshot::Snapshot;
use crate::scene;
use crate::sim::{ActorState, Sim};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Set by the Ctrl-C handler; the run loop stops at the next step boundary.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The sim to run, with its scene text and path: a fresh scene, or a resumed snapshot.
fn prepare(args: &RunArgs) -> Result<(Sim, PathBuf, String, u64), AppError> {
    if let Some(file) = &args.resume {
        if !args.set.is_empty() {
            return Err(AppError::Usage("--set changes a fresh scene; it cannot be used with --resume".into()));
        }
        let snap = read_snapshot(file)?;
        let path = PathBuf::from(&snap.scene_path);
        let mut def = scene::parse(&snap.scene_text, &path)?;
        def.dt = snap.dt;
        def.schedule = Some(snap.schedule.clone());
        let steps = args.steps.unwrap_or(def.steps);
        let mut sim = crate::scene::build(&def, &path)?;
        snap.restore(&mut sim).map_err(|message| SnapshotError { path: file.clone(), at: None, message })?;
        return Ok((sim, path, snap.scene_text, steps));
    }
    let (mut def, path, text) = load_scene_set(args.scene.as_deref(), &args.set)?;
    if let Some(dt) = args.dt {
        def.dt = dt;
    }
    if let Some(names) = &args.schedule {
        // Checked here, so a typo is blamed on the flag, not on the scene file.
        crate::systems::schedule_of(names).map_err(|e| AppError::Usage(format!("--schedule: {e}")))?;
        def.schedule = Some(names.clone());
    }
    let steps = args.steps.unwrap_or(def.steps);
    Ok((crate::scene::build_from_text(&def, &path, &text)?, path, text, steps))
}

fn read_snapshot(file: &Path) -> Result<Snapshot, SnapshotError> {
    let fail = |at, message: String| SnapshotError { path: file.to_path_buf(), at, message };
    let text = std::fs::read_to_string(file).map_err(|e| fail(None, format!("cannot read: {e}")))?;
    let snap: Snapshot =
        serde_json::from_str(&text).map_err(|e| fail(Some((e.line(), e.column())), format!("not a snapshot: {e}")))?;
    if snap.format != crate::io::snapshot::SNAPSHOT_FORMAT {
        return Err(fail(
            None,
            format!("snapshot format {} is not {}", snap.format, crate::io::snapshot::SNAPSHOT_FORMAT),
        ));
    }
    Ok(snap)
}

pub(super) fn run(args: &RunArgs) -> Result<(), AppError> {
    for (file, flag) in [(&args.out, "--out"), (&args.trajectory, "--trajectory"), (&args.save, "--save")] {
        if let Some(file) = file {
            check_writable(file, flag)?;
        }
    }
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
    let before = sim.totals();
    let mut trajectory = match &args.trajectory {
        Some(p) => Some((p, trajectory_start(p, &sim)?)),
        None => None,
    };
    let bar = progress_bar(steps, args.quiet);
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
                let _ = std::fs::remove_file(crate::io::output::temp_path(p));
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
        print_summary(&sim, &before, wall)?;
    }
    Ok(())
}

/// Flushes the trajectory's temporary file and renames it into place.
fn finish_trajectory(trajectory: Option<(&PathBuf, std::io::BufWriter<std::fs::File>)>) -> Result<(), AppError> {
    let Some((p, buf)) = trajectory else { return Ok(()) };
    buf.into_inner()
        .map_err(|e| e.into_error())
        .and_then(|file| file.sync_all())
        .and_then(|()| std::fs::rename(crate::io::output::temp_path(p), p))
        .map_err(|e| write_error(p, e))
}

/// Opens the trajectory's temporary file and writes the header and the starting state (step 0,
/// or the step a resumed run starts from). Rows stream to disk: a long run of many actors does
/// not hold its trajectory in memory.
fn trajectory_start(path: &Path, sim: &Sim) -> Result<std::io::BufWriter<std::fs::File>, AppError> {
    let file = std::fs::File::create(crate::io::output::temp_path(path)).map_err(|e| write_error(path, e))?;
    let mut buf = std::io::BufWriter::new(file);
    writeln!(buf, "{TRAJECTORY_HEADER}").map_err(|e| write_error(path, e))?;
    trajectory_rows(&mut buf, sim.steps, sim.time, &sim.actors()).map_err(|e| write_error(path, e))?;
    Ok(buf)
}

fn print_summary(sim: &Sim, before: &crate::sim::Totals, wall: std::time::Duration) -> Result<(), AppError> {
    let after = sim.totals();
    let secs = wall.as_secs_f64();
    let rate = if secs > 0.0 { sim.steps as f64 / secs } else { f64::INFINITY };
    outln!("simulated {:.4} s in {} steps of {} s, {} actors", sim.time, sim.steps, sim.ctx.dt, sim.len());
    outln!("wall time {secs:.3} s ({rate:.0} steps/s)");
    let by_test = |c: [u64; 3]| format!("face {}, vertex {}, edge {}", c[0], c[1], c[2]);
    outln!("contacts found: {} (by the detection test that found each)", by_test(sim.found));
    outln!("impulses: {} (by the test that found the contact)", by_test(sim.impulses));
    outln!("contact solver: {} pair-steps held (resting and sliding contact, friction)", sim.held);
    let ke0 = before.kinetic_energy;
    let change =
        if ke0 > 0.0 { format!(" ({:+.1} %)", 100.0 * (after.kinetic_energy - ke0) / ke0) } else { String::new() };
    outln!("kinetic energy {} J -> {} J{change}", significant(ke0), significant(after.kinetic_energy));
    // Momentum is kept only without outside forces: no gravity and nothing fixed to push on.
    let fixed = sim.actors().iter().any(|a| a.mass.is_fixed());
    if sim.ctx.params.gravity == crate::math::Vector::ZERO && !fixed {
        let drift = (after.linear_momentum - before.linear_momentum).length();
        outln!("momentum drift |Δp| = {} kg·m/s (kept: no gravity, nothing fixed)", significant(drift));
    }
    Ok(())
}
