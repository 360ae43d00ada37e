//! What a new user meets first, through the binary: any finite scene runs or is refused with
//! a message (never a panic), a closed output ends the program quietly, output paths are
//! checked before simulating, and messages and summaries say what they mean.

use proptest::prelude::*;
use std::process::{Command, Output, Stdio};

fn rigid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("the binary runs")
}

fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// Writes `contents` to `name` in a fresh folder; returns the folder (kept alive) and path.
fn scene_file(name: &str, contents: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join(name);
    std::fs::write(&path, contents).expect("temp file");
    let path = path.display().to_string();
    (dir, path)
}

/// Runs a scene for a few steps: it must finish (0), or fail with a message (1 or 2).
fn runs_or_refuses(scene: &str) -> Result<(), TestCaseError> {
    let (_dir, path) = scene_file("extreme.ron", scene);
    let o = rigid(&["run", &path, "--steps", "3", "--quiet"]);
    let (_, err) = text(&o);
    let code = o.status.code();
    prop_assert!(matches!(code, Some(0..=2)), "exit {code:?}\n{scene}\n{err}");
    prop_assert!(!err.contains("panicked"), "{scene}\n{err}");
    if code != Some(0) {
        prop_assert!(err.lines().any(|l| l.starts_with("error: ")), "a failure says why: {err}");
    }
    Ok(())
}

#[test]
fn two_boxes_1e20_m_apart_run() {
    let (_dir, path) = scene_file(
        "far.ron",
        "Scene(actors: [
            Actor(name: \"a\", shape: Box(size: (1.0, 1.0, 1.0)), position: (1e20, 0.0, 0.0)),
            Actor(name: \"b\", shape: Box(size: (1.0, 1.0, 1.0)), velocity: (1e21, 0.0, 0.0)),
        ])",
    );
    let o = rigid(&["run", &path, "--steps", "10", "--quiet"]);
    assert!(o.status.success(), "{}", text(&o).1);
}

/// A magnitude from 1e-300 to 1e300 (or 0), with a random sign when `signed`.
fn magnitude(signed: bool) -> impl Strategy<Value = f64> {
    (-300_i32..=300, 1.0_f64..10.0, any::<bool>(), 0..20_u8).prop_map(move |(e, m, negative, zero)| {
        let v = if zero == 0 { 0.0 } else { m * 10f64.powi(e) };
        if signed && negative { -v } else { v }
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Positions and velocities up to 1e300, sizes from 1e-9 to 1e9, masses from 1e-300 to
    /// 1e300: each scene runs, or is refused with a message.
    #[test]
    fn extreme_finite_scenes_run_or_are_refused(
        position in prop::array::uniform3(magnitude(true)),
        velocity in prop::array::uniform3(magnitude(true)),
        size in (-9_i32..=9, 1.0_f64..10.0).prop_map(|(e, m)| m * 10f64.powi(e)),
        mass in (-300_i32..=300, 1.0_f64..10.0).prop_map(|(e, m)| m * 10f64.powi(e)),
        spin in magnitude(true),
        gravity in any::<bool>(),
    ) {
        let g = if gravity { "(0.0, -9.81, 0.0)" } else { "(0.0, 0.0, 0.0)" };
        let scene = format!(
            "Scene(gravity: {g}, actors: [
                Actor(name: \"floor\", shape: Box(size: (10.0, 1.0, 10.0)), fixed: true),
                Actor(name: \"a\", shape: Box(size: ({size:e}, {size:e}, {size:e})), mass: {mass:e},
                      position: ({:e}, {:e}, {:e}), velocity: ({:e}, {:e}, {:e}),
                      angular_velocity: ({spin:e}, 0.0, 0.0)),
                Actor(name: \"b\", shape: Icosphere(radius: {size:e}, subdivisions: 1), mass: {mass:e},
                      position: (0.0, {size:e}, 0.0)),
            ])",
            position[0], position[1], position[2], velocity[0], velocity[1], velocity[2]
        );
        runs_or_refuses(&scene)?;
    }
}

#[test]
fn a_closed_output_ends_the_program_quietly() {
    // The pipe's reading end is closed before the program writes, as `| head -0` does.
    for args in [&["systems"][..], &["check", "scenes/spawners.ron"], &["run", "--steps", "2"]] {
        let (reader, writer) = std::io::pipe().expect("a pipe");
        drop(reader);
        let o = Command::new(env!("CARGO_BIN_EXE_rigid"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .stdout(Stdio::from(writer))
            .stderr(Stdio::piped())
            .output()
            .expect("the binary runs");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {err}");
        assert!(!err.contains("panicked") && !err.contains("error"), "{args:?}: {err}");
    }
}

#[test]
fn output_paths_are_checked_before_simulating() {
    for flag in ["--out", "--trajectory", "--save"] {
        let o = rigid(&["run", "scenes/box-gas.ron", flag, "/nonexistent/folder/x.json"]);
        let (out, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{flag}: {err}");
        assert!(err.contains(flag) && err.contains("/nonexistent/folder"), "{err}");
        assert!(out.is_empty(), "nothing was simulated, so no summary: {out}");
    }
    let o = rigid(&["bench", "box-gas", "--actors", "8", "--csv", "/nonexistent/folder/b.csv"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).0.is_empty(), "no table: the bench did not run");
}

#[test]
fn a_schedule_typo_is_blamed_on_the_flag() {
    let o = rigid(&["run", "scenes/box-drop.ron", "--schedule", "cull,fase"]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(2));
    assert!(err.starts_with("error: --schedule: unknown system 'fase'"), "{err}");
    assert!(!err.contains("box-drop.ron"), "{err}");
}

#[test]
fn scene_fields_and_unnamed_actors_are_named_as_such() {
    let (_dir, path) = scene_file("dt.ron", "Scene(dt: -1.0, actors: [])");
    let (_, err) = text(&rigid(&["check", &path]));
    assert_eq!(err.trim_end(), format!("error: {path}: dt: must be a finite number > 0 s, got -1"));

    let (_dir, path) = scene_file(
        "unnamed.ron",
        "Scene(actors: [\n  Actor(name: \"a\", shape: Box(size: (1.0, 1.0, 1.0))),\n  \
         Actor(shape: Box(size: (1.0, 1.0, 1.0)), mass: -2.0),\n])",
    );
    let (_, err) = text(&rigid(&["check", &path]));
    assert!(err.contains(":3:") && err.contains("actor #1 (no name; it would be 'actor-1'): mass:"), "{err}");
}

#[test]
fn a_typo_is_reported_at_its_first_character() {
    let (_dir, path) = scene_file(
        "typo.ron",
        "Scene(actors: [\n  Actor(name: \"a\", shape: Box(size: (1.0, 1.0, 1.0)), mas: 1.0),\n])",
    );
    let (_, err) = text(&rigid(&["check", &path]));
    let col = "  Actor(name: \"a\", shape: Box(size: (1.0, 1.0, 1.0)), ".len() + 1;
    assert!(err.starts_with(&format!("error: {path}:2:{col}: Unexpected field named `mas`")), "{err}");
    assert_eq!(err.lines().count(), 1, "one message, not two: {err}");
}

#[test]
fn the_summary_reports_momentum_only_where_it_is_kept_and_energy_readably() {
    // A box sliding down a slope under gravity: momentum is not kept, so no drift is reported.
    let (out, _) = text(&rigid(&["run", "scenes/slope-slide.ron"]));
    assert!(!out.contains("momentum"), "{out}");
    assert!(out.contains("contact solver: 180 pair-steps held"), "the solver's work is counted: {out}");
    // The demo has no gravity and nothing fixed: momentum is kept and reported.
    let (out, _) = text(&rigid(&["run"]));
    assert!(out.contains("momentum drift |Δp| = 0 kg·m/s"), "{out}");
    assert!(out.contains("kinetic energy 1.5 J -> 1.5 J (+0.0 %)"), "{out}");
    // A box dropped on the floor comes to rest: no 30-digit decimals.
    let (out, _) = text(&rigid(&["run", "scenes/box-drop.ron"]));
    let energy = out.lines().find(|l| l.starts_with("kinetic energy")).expect("an energy line");
    assert!(energy.len() < 60, "{energy}");
}

#[test]
fn flags_read_as_a_newcomer_expects() {
    let (help, _) = text(&rigid(&["--help"]));
    assert!(help.contains("With no subcommand, `rigid` runs the built-in demo scene"), "{help}");
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("s.json").display().to_string();
    let o = rigid(&["run", "-q", "-o", &out]);
    assert!(o.status.success() && text(&o).0.is_empty() && std::path::Path::new(&out).exists());
    let (_, err) = text(&rigid(&["run", "--every", "0"]));
    assert!(err.contains("must be at least 1") && !err.contains("18446744073709551615"), "{err}");
}

#[test]
fn systems_all_lists_every_shipped_system_and_marks_the_default_ones() {
    let (out, _) = text(&rigid(&["systems", "--all"]));
    // The default order itself is pinned by tests/schedule.rs.
    for name in rigid_sandbox::systems::DEFAULT_ORDER {
        assert!(out.lines().any(|l| l.starts_with('*') && l.contains(&format!(" {name} "))), "{name}: {out}");
    }
    let other = out.lines().find(|l| l.contains(" cull_all_pairs ")).expect("the paper's all-pairs cull is listed");
    assert!(!other.starts_with('*'), "not in the default schedule: {other}");
    // Into a pipe without --all: the default schedule's names, one a line, as scripts read it.
    let (plain, _) = text(&rigid(&["systems"]));
    assert_eq!(plain.lines().count(), rigid_sandbox::systems::DEFAULT_ORDER.len());
}

#[test]
fn render_and_export_take_threads_and_quiet() {
    let dir = tempfile::tempdir().expect("temp dir");
    let frames = dir.path().join("frames").display().to_string();
    let o = rigid(&["render", "--steps", "4", "--size", "32x24", "--threads", "1", "-q", "-o", &frames]);
    assert!(o.status.success() && text(&o).0.is_empty(), "{}", text(&o).1);
    let glb = dir.path().join("run.glb").display().to_string();
    let o = rigid(&["export", "--steps", "4", "--threads", "2", "--quiet", "--glb", &glb]);
    assert!(o.status.success() && text(&o).0.is_empty(), "{}", text(&o).1);
    assert!(std::path::Path::new(&glb).exists());
}

#[test]
fn a_schedule_that_integrates_before_detecting_is_warned_about() {
    let order = "cull,prune,face,vertex,edge,gravity,integrate,solve";
    let (_, err) = text(&rigid(&["run", "scenes/box-drop.ron", "--schedule", order, "--steps", "1", "-q"]));
    assert!(err.contains("warning:") && err.contains("'integrate' runs before 'solve'"), "{err}");
    let (_, err) = text(&rigid(&["run", "scenes/box-drop.ron", "--steps", "1", "-q"]));
    assert!(!err.contains("warning"), "the default order is not warned about: {err}");
}
