//! The `rigid` binary through its contract (docs/cli.md): exit codes, error positions,
//! the JSON and CSV files, and mass properties of every shape read back from `--out`.

use std::path::Path;
use std::process::{Command, Output};

fn rigid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("the binary runs")
}

fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

fn scene(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name).display().to_string()
}

fn write(dir: &tempfile::TempDir, name: &str, contents: &str) -> String {
    let p = dir.path().join(name);
    std::fs::write(&p, contents).expect("temp file");
    p.display().to_string()
}

#[test]
fn systems_prints_the_default_order() {
    let o = rigid(&["systems"]);
    assert!(o.status.success());
    assert_eq!(
        text(&o).0,
        "cull\nprune\nface\nvertex\nedge\ngravity\nresolve\nsolve\ncorrect\nsleep\nccd\nintegrate\n"
    );
}

#[test]
fn run_without_a_scene_simulates_the_demo() {
    let o = rigid(&["run"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("impulses: face 1, vertex 1, edge 1"), "{out}");
    // `rigid` alone does the same.
    let o = rigid(&[]);
    assert!(o.status.success() && text(&o).0.contains("impulses: face 1, vertex 1, edge 1"));
}

#[test]
fn out_json_has_the_contract_fields_and_exact_results() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("state.json");
    let o = rigid(&["run", &scene("face-collision.ron"), "--out", out.to_str().expect("utf-8"), "--quiet"]);
    assert!(o.status.success(), "{}", text(&o).1);
    assert!(text(&o).0.is_empty(), "--quiet prints nothing");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).expect("written")).expect("JSON");
    assert_eq!(v["steps"], 50);
    assert!((v["time"].as_f64().expect("number") - 0.5).abs() < 1e-12);
    let a = &v["actors"][0];
    assert_eq!(a["name"], "a");
    for (field, len) in [("position", 3), ("orientation", 4), ("velocity", 3), ("angular_velocity", 3)] {
        assert_eq!(a[field].as_array().map(Vec::len), Some(len), "{field}");
    }
    assert_eq!(a["orientation"], serde_json::json!([0.0, 0.0, 0.0, 1.0]));
    assert_eq!((a["mass"].as_f64(), a["fixed"].as_bool()), (Some(1.0), Some(false)));
    assert_eq!(v["actors"][1]["velocity"], serde_json::json!([1.0, 0.0, 0.0]));
    assert_eq!(v["totals"]["linear_momentum"], serde_json::json!([1.0, 0.0, 0.0]));
    assert_eq!(v["totals"]["kinetic_energy"], 0.5);
    assert_eq!(v["contacts"], serde_json::json!({"face": 1, "vertex": 0, "edge": 0}));
    assert_eq!(v["state_hash"].as_str().map(str::len), Some(16));
}

#[test]
fn mass_properties_of_every_shape_come_out_exact() {
    let dir = tempfile::tempdir().expect("temp dir");
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/models/wedge.obj");
    let scene = format!(
        "Scene(gravity: (0.0, 0.0, 0.0), actors: [
        Actor(name: \"box\", shape: Box(size: (1.0, 2.0, 3.0)), density: 2.0),
        Actor(name: \"tet\", shape: Tetrahedron(edge: 2.0), density: 3.0, position: (5.0, 0.0, 0.0)),
        Actor(name: \"oct\", shape: Octahedron(radius: 0.5), density: 6.0, position: (10.0, 0.0, 0.0)),
        Actor(name: \"cyl\", shape: Cylinder(radius: 0.5, height: 2.0, segments: 6), position: (15.0, 0.0, 0.0)),
        Actor(name: \"ico\", shape: Icosphere(radius: 1.0, subdivisions: 0), position: (20.0, 0.0, 0.0)),
        Actor(name: \"obj\", shape: Obj(path: {:?}, scale: 2.0), density: 10.0, position: (25.0, 0.0, 0.0), fixed: true),
    ])",
        models.display().to_string()
    );
    let path = write(&dir, "shapes.ron", &scene);
    let out = dir.path().join("s.json");
    let o = rigid(&["run", &path, "--steps", "0", "--out", out.to_str().expect("utf-8"), "--quiet"]);
    assert!(o.status.success(), "{}", text(&o).1);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).expect("written")).expect("JSON");
    let mass = |i: usize| v["actors"][i]["mass"].as_f64().expect("mass");
    let golden = (1.0 + 5f64.sqrt()) / 2.0;
    let ico_edge = 1.0 / (golden * golden + 1.0).sqrt() * 2.0; // unit circumradius
    let want = [
        2.0 * 6.0,
        3.0 * 8.0 / (6.0 * 2f64.sqrt()),
        6.0 * 4.0 / 3.0 * 0.125,
        6.0 / 2.0 * 0.25 * (std::f64::consts::TAU / 6.0).sin() * 2.0,
        5.0 / 12.0 * (3.0 + 5f64.sqrt()) * ico_edge.powi(3),
        10.0 * (0.5 * 1.0 * 0.6 * 0.6) * 8.0, // wedge: triangle ½·1·0.6, depth 0.6, scale 2³
    ];
    for (i, w) in want.iter().enumerate() {
        assert!((mass(i) - w).abs() <= 1e-12 * w, "actor {i}: mass {} want {w}", mass(i));
    }
    assert_eq!(v["actors"][5]["fixed"], true);
}

#[test]
fn trajectory_has_the_header_and_every_kth_step() {
    let dir = tempfile::tempdir().expect("temp dir");
    let csv = dir.path().join("t.csv");
    let o = rigid(&[
        "run",
        &scene("newtons-cradle.ron"),
        "--steps",
        "10",
        "--every",
        "5",
        "--trajectory",
        csv.to_str().expect("utf-8"),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let body = std::fs::read_to_string(&csv).expect("written");
    let lines: Vec<&str> = body.lines().collect();
    assert_eq!(lines[0], "step,time,name,px,py,pz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz");
    assert_eq!(lines.len(), 1 + 5 * 3, "steps 0, 5, 10 for five cubes");
    assert!(lines[1].starts_with("0,0,c1,0,0,0,0,0,0,1,1,0,0,0,0,0"), "{}", lines[1]);
    assert!(lines[15].starts_with("10,0.1,c5,"), "{}", lines[15]);
}

#[test]
fn bad_input_exits_2_with_file_line_and_column() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases = [
        ("syntax.ron", "Scene(\n  actors: [\n    Actor(shape: Box(size: (1.0, 1.0, 1.0)),,\n  ],\n)", ":3:"),
        ("field.ron", "Scene(\n  actors: [\n    Actor(shape: Box(size: (1.0, 1.0, 1.0)), mas: 2.0),\n  ],\n)", "mas"),
        (
            "mass.ron",
            "Scene(actors: [Actor(name: \"left\", shape: Box(size: (1.0, 1.0, 1.0)), mass: -2.0)])",
            "actor 'left': mass",
        ),
        (
            "both.ron",
            "Scene(actors: [Actor(name: \"x\", shape: Box(size: (1.0, 1.0, 1.0)), mass: 1.0, density: 2.0)])",
            "not both",
        ),
        ("system.ron", "Scene(schedule: [\"cull\", \"fcae\"], actors: [])", "unknown system 'fcae'"),
    ];
    for (name, contents, needle) in cases {
        let path = write(&dir, name, contents);
        for cmd in ["check", "run"] {
            let o = rigid(&[cmd, &path]);
            let err = text(&o).1;
            assert_eq!(o.status.code(), Some(2), "{name} via {cmd}: {err}");
            assert!(err.starts_with(&format!("error: {path}")), "{name}: names the file: {err}");
            assert!(err.contains(needle), "{name}: wants '{needle}' in: {err}");
            assert!(!err.contains("panicked"), "{err}");
        }
    }
    // The unknown field is reported at the field itself: line 3, column of `mas`.
    let path = dir.path().join("field.ron");
    let err = text(&rigid(&["check", path.to_str().expect("utf-8")])).1;
    assert!(err.contains("field.ron:3:46"), "{err}");
    let o = rigid(&["run", "no/such/file.ron"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).1.contains("no/such/file.ron"));
    let o = rigid(&["run", "--dt", "-1"]);
    assert_eq!(o.status.code(), Some(2), "bad flag");
}

#[test]
fn bench_json_has_the_fields_of_benchmarks_md_and_the_scene_check_value() {
    let o = rigid(&[
        "bench",
        "box-gas",
        "--actors",
        "1000,125",
        "--steps",
        "2",
        "--warmup",
        "1",
        "--threads",
        "1",
        "--json",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    let rows: Vec<serde_json::Value> =
        out.lines().map(|l| serde_json::from_str(l).expect("one JSON object a line")).collect();
    assert_eq!(rows.iter().map(|r| r["actors"].as_u64()).collect::<Vec<_>>(), [Some(125), Some(1000)], "ascending N");
    let r = &rows[1];
    for field in [
        "scene",
        "steps",
        "warmup",
        "seed",
        "threads",
        "mean_ms_per_step",
        "median_ms_per_step",
        "ke_end",
        "escaped",
        "peak_rss_mib",
    ] {
        assert!(!r[field].is_null(), "missing {field}: {r}");
    }
    assert_eq!((r["scene"].as_str(), r["steps"].as_u64(), r["threads"].as_u64()), (Some("box-gas"), Some(2), Some(1)));
    // docs/benchmarks.md: total kinetic energy at start for N = 1000 is 2104.5686 J.
    assert!((r["ke_start"].as_f64().expect("number") - 2104.5686).abs() < 1e-4, "{}", r["ke_start"]);
    let systems = r["systems_ms"].as_object().expect("per-system times");
    for name in ["cull", "face", "vertex", "edge", "resolve", "integrate"] {
        assert!(systems.contains_key(name), "systems_ms lacks {name}");
    }
    let o = rigid(&["bench", "pyramid", "--base", "3", "--steps", "2", "--json"]);
    let r: serde_json::Value = serde_json::from_str(text(&o).0.trim()).expect("JSON");
    assert_eq!(
        (r["scene"].as_str(), r["base"].as_u64(), r["actors"].as_u64(), r["sleep"].as_bool()),
        (Some("pyramid"), Some(3), Some(6), Some(false))
    );
    assert!(r["max_displacement_m"].as_f64().is_some());
    let o = rigid(&["bench", "pyramid", "--base", "3", "--steps", "60", "--sleep", "--json"]);
    let r: serde_json::Value = serde_json::from_str(text(&o).0.trim()).expect("JSON");
    assert_eq!(r["sleep"].as_bool(), Some(true), "--sleep is reported");
    assert_eq!(r["ke_end"].as_f64(), Some(0.0), "a settled pyramid of six sleeps within a second");
}
