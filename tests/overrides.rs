//! `--set PATH=VALUE` on `run`, `render`, `export` and `bench` (docs/cli.md "Overrides: --set").

use std::path::Path;
use std::process::{Command, Output};

fn rigid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("the binary runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn write(dir: &tempfile::TempDir, name: &str, contents: &str) -> String {
    let p = dir.path().join(name);
    std::fs::write(&p, contents).expect("temp file");
    p.display().to_string()
}

/// A box falling freely (nothing to hit) and a ball above a floor.
const SCENE: &str = r#"// overrides test scene
Scene(
    dt: 0.02,
    steps: 10,
    actors: [
        Actor(name: "box", shape: Box(size: (1.0, 1.0, 1.0)), position: (20.0, 50.0, 0.0)),
        Actor(name: "b", shape: Icosphere(radius: 0.5, subdivisions: 1), position: (0.0, 0.6, 0.0),
              velocity: (0.0, -3.0, 0.0), restitution: 0.9),
        Actor(name: "floor", shape: Box(size: (8.0, 0.2, 8.0)), position: (0.0, -0.1, 0.0), fixed: true),
    ],
)
"#;

/// Runs `rigid run SCENE ARGS --out FILE` and returns the JSON written.
fn run_json(scene: &str, args: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.json").display().to_string();
    let mut all = vec!["run", scene, "--quiet", "--out", &out];
    all.extend_from_slice(args);
    let o = rigid(&all);
    assert!(o.status.success(), "{all:?}: {}", stderr(&o));
    serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap()
}

fn actor<'a>(json: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    json["actors"].as_array().unwrap().iter().find(|a| a["name"] == name).expect("actor in --out")
}

fn vec3(v: &serde_json::Value) -> [f64; 3] {
    let a = v.as_array().unwrap();
    [a[0].as_f64().unwrap(), a[1].as_f64().unwrap(), a[2].as_f64().unwrap()]
}

/// Exit 2, and stderr names the `--set` argument.
fn refused(args: &[&str], arg: &str) -> String {
    let o = rigid(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(err.contains(&format!("--set {arg}")), "{args:?}: {err}");
    err
}

#[test]
fn gravity_sets_the_free_fall() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(&dir, "s.ron", SCENE);
    let json = run_json(&scene, &["--set", "gravity=(0.0,-1.62,0.0)"]);
    // Semi-implicit Euler: after n steps v = n·g·dt exactly (up to rounding).
    let v = vec3(&actor(&json, "box")["velocity"]);
    let expected = 10.0 * -1.62 * 0.02;
    assert!((v[1] - expected).abs() < 1e-12 && v[0] == 0.0 && v[2] == 0.0, "{v:?} vs {expected}");
}

#[test]
fn dt_changes_time_and_repeated_sets_apply_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(&dir, "s.ron", SCENE);
    let json = run_json(&scene, &["--set", "dt=0.01"]);
    assert!((json["time"].as_f64().unwrap() - 0.1).abs() < 1e-12, "{}", json["time"]);
    let json = run_json(&scene, &["--set", "dt=0.01", "--set", "dt=0.005", "--set", "steps=4"]);
    assert!((json["time"].as_f64().unwrap() - 0.02).abs() < 1e-12, "{}", json["time"]);
    assert_eq!(json["steps"], 4);
}

#[test]
fn actor_fields_by_name_and_index() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(&dir, "s.ron", SCENE);
    let base = run_json(&scene, &["--steps", "8"]);
    let dead = run_json(&scene, &["--steps", "8", "--set", r#"actors["b"].restitution=0.0"#]);
    let up = |j: &serde_json::Value| vec3(&actor(j, "b")["velocity"])[1];
    // With restitution 0.9 the ball bounces up; with 0 it stays down.
    assert!(up(&base) > 0.5 && up(&dead) < 0.1, "{} {}", up(&base), up(&dead));
    let json = run_json(&scene, &["--steps", "1", "--set", "actors[0].velocity=(2.0, 0.0, 0.0)"]);
    assert_eq!(vec3(&actor(&json, "box")["velocity"])[0], 2.0);
    // A missing field is added.
    let json = run_json(&scene, &["--steps", "1", "--set", "actors[0].mass=3.0"]);
    assert_eq!(actor(&json, "box")["mass"], 3.0);
}

#[test]
fn solver_fields_reach_the_checks() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(&dir, "s.ron", SCENE);
    run_json(&scene, &["--set", "solver.substeps=8", "--set", "solver.iterations=3"]);
    let err = refused(&["run", &scene, "--set", "solver.substeps=65"], "solver.substeps=65");
    assert!(err.contains("solver.substeps") && err.contains("1..=64"), "{err}");
}

#[test]
fn motor_speed_changes_the_wheel() {
    let wheel = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/wheel.ron").display().to_string();
    let spin = |args: &[&str]| {
        let mut all = vec!["--steps", "60"];
        all.extend_from_slice(args);
        vec3(&actor(&run_json(&wheel, &all), "wheel")["angular_velocity"])[2]
    };
    let slow = spin(&[]);
    let fast = spin(&["--set", "joints[0].motor.speed=3.0"]);
    let named = spin(&["--set", r#"joints["axle"].motor.speed=3.0"#]);
    assert!((slow - 1.5).abs() < 0.3 && (fast - 3.0).abs() < 0.3, "{slow} {fast}");
    assert_eq!(fast, named);
}

#[test]
fn the_demo_render_and_export_take_set() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("d.json").display().to_string();
    let o = rigid(&["run", "--quiet", "--steps", "3", "--set", "dt=0.01", "--out", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!((json["time"].as_f64().unwrap() - 0.03).abs() < 1e-12);
    let frames = dir.path().join("frames").display().to_string();
    let o =
        rigid(&["render", "-q", "--steps", "2", "--size", "32x32", "--out", &frames, "--set", "gravity=(0.0,0.0,0.0)"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let glb = dir.path().join("a.glb").display().to_string();
    let o = rigid(&["export", "-q", "--steps", "2", "--glb", &glb, "--set", "dt=0.01"]);
    assert!(o.status.success(), "{}", stderr(&o));
    refused(&["render", "--steps", "2", "--out", &frames, "--set", "nope=1"], "nope=1");
    refused(&["export", "--steps", "2", "--glb", &glb, "--set", "dt=-1"], "dt=-1");
}

#[test]
fn bad_paths_and_values_are_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(&dir, "s.ron", SCENE);
    for (arg, says) in [
        ("bogus=1", "bogus"),
        ("actors[7].mass=1", "index out of range"),
        (r#"actors["nobody"].mass=1"#, "no element named \"nobody\""),
        ("actors[0].colour=1", "colour"),
        ("dt", "PATH=VALUE"),
        ("=1", "PATH"),
        ("dt=(0.1", "unbalanced"),
        ("dt=fast", "dt"),
        ("dt=0.1, steps: 5", "one value"),
    ] {
        let err = refused(&["run", &scene, "--set", arg], arg);
        assert!(err.contains(says), "{arg}: {err}");
    }
}

#[test]
fn set_with_resume_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(&dir, "s.ron", SCENE);
    let snap = dir.path().join("snap.json").display().to_string();
    let o = rigid(&["run", &scene, "--quiet", "--save", &snap]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = rigid(&["run", "--resume", &snap, "--set", "dt=0.01"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--set"), "{}", stderr(&o));
    // `--save` keeps the edited scene: the resumed run goes on with its dt.
    let o = rigid(&["run", &scene, "--quiet", "--set", "dt=0.01", "--save", &snap]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("out.json").display().to_string();
    let o = rigid(&["run", "--resume", &snap, "--quiet", "--steps", "1", "--out", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!((json["time"].as_f64().unwrap() - 0.11).abs() < 1e-12, "{}", json["time"]);
}

#[test]
fn bench_takes_step_and_solver_settings_only() {
    let o = rigid(&["bench", "box-gas", "--actors", "8", "--steps", "2", "--set", "dt=0.01", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = rigid(&["bench", "box-gas", "--actors", "8", "--steps", "2", "--set", "solver.substeps=8", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = refused(
        &["bench", "box-gas", "--actors", "8", "--steps", "2", "--set", "actors[0].mass=2"],
        "actors[0].mass=2",
    );
    assert!(err.contains("only dt, gravity and solver"), "{err}");
    refused(&["bench", "box-gas", "--actors", "8", "--steps", "2", "--set", "solver.substeps=0"], "solver.substeps=0");
}
