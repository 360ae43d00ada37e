//! Every class of bad input (issue #7) through `rigid check` and `rigid run`: exit code 2,
//! the file named (with `line:col` where the text is at fault, the actor and field where a
//! value is), what is expected, never a panic, and no output file left behind.

use std::process::{Command, Output};

fn rigid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("the binary runs")
}

/// Writes `contents` as a scene in `dir` and checks both commands on it.
fn rejects(dir: &tempfile::TempDir, name: &str, contents: &[u8], needles: &[&str]) {
    let path = dir.path().join(name);
    std::fs::write(&path, contents).expect("temp file");
    let p = path.to_str().expect("utf-8");
    let out = dir.path().join(format!("{name}.json"));
    for cmd in [vec!["check", p], vec!["run", p, "--quiet", "--out", out.to_str().expect("utf-8")]] {
        let o = rigid(&cmd);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name} via {}: {err}", cmd[0]);
        assert!(err.starts_with(&format!("error: {p}")), "{name}: names the file first: {err}");
        for needle in needles {
            assert!(err.contains(needle), "{name}: wants '{needle}' in: {err}");
        }
        assert!(!err.contains("panicked") && !err.contains("RUST_BACKTRACE"), "{name}: {err}");
        assert!(!out.exists(), "{name}: no output file after bad input");
    }
}

const CUBE: &str = "shape: Box(size: (1.0, 1.0, 1.0))";

#[test]
fn text_errors_name_line_and_column() {
    let dir = tempfile::tempdir().expect("temp dir");
    rejects(
        &dir,
        "syntax.ron",
        b"Scene(\n  actors: [\n    Actor(shape: Box(size: (1.0, 1.0 1.0))),\n  ],\n)",
        &[":3:"],
    );
    rejects(&dir, "unknown.ron", format!("Scene(actors: [Actor({CUBE}, mas: 1.0)])").as_bytes(), &[":1:", "mas"]);
    rejects(&dir, "type.ron", format!("Scene(actors: [Actor({CUBE}, mass: \"heavy\")])").as_bytes(), &[":1:", "mass"]);
    rejects(&dir, "missing.ron", b"Scene(dt: 0.01)", &[":1:", "actors"]);
    rejects(&dir, "noshape.ron", b"Scene(actors: [Actor(mass: 1.0)])", &[":1:", "shape"]);
    rejects(&dir, "empty.ron", b"", &[":1:1:"]);
    rejects(&dir, "garbage.ron", &[0xff, 0xfe, 0x00, 0x12, 0x80, 0x99, 0xc3], &["not UTF-8"]);
    rejects(&dir, "text-garbage.ron", b"\x01\x02 lorem ipsum }}}", &[":1:"]);
    let deep = format!("Scene(actors: [], spawners: {}{})", "[".repeat(5000), "]".repeat(5000));
    rejects(&dir, "deep.ron", deep.as_bytes(), &[":1:"]);
}

#[test]
fn non_physical_values_name_the_actor_and_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    let actor = |extra: &str| format!("Scene(actors: [Actor(name: \"left\", {CUBE}, {extra})])");
    let cases = [
        ("mass0.ron", actor("mass: 0.0"), "actor 'left': mass"),
        ("massneg.ron", actor("mass: -2.0"), "actor 'left': mass"),
        ("density.ron", actor("density: -1.0"), "actor 'left': density"),
        ("both.ron", actor("mass: 1.0, density: 1.0"), "not both"),
        ("rest.ron", actor("restitution: 1.5"), "actor 'left': restitution"),
        ("restnan.ron", actor("restitution: NaN"), "actor 'left': restitution"),
        ("fric.ron", actor("friction: -0.1"), "actor 'left': friction"),
        ("posinf.ron", actor("position: (inf, 0.0, 0.0)"), "actor 'left': position"),
        ("velnan.ron", actor("velocity: (0.0, NaN, 0.0)"), "actor 'left': velocity"),
        ("size.ron", "Scene(actors: [Actor(name: \"b\", shape: Box(size: (1.0, 0.0, 1.0)))])".into(), "shape.size.y"),
        ("edge.ron", "Scene(actors: [Actor(name: \"t\", shape: Tetrahedron(edge: -1.0))])".into(), "shape.edge"),
        (
            "subdiv.ron",
            "Scene(actors: [Actor(name: \"s\", shape: Icosphere(radius: 1.0, subdivisions: 9))])".into(),
            "shape.subdivisions",
        ),
        (
            "segments.ron",
            "Scene(actors: [Actor(name: \"c\", shape: Cylinder(radius: 1.0, height: 1.0, segments: 2))])".into(),
            "shape.segments",
        ),
        ("dt.ron", format!("Scene(dt: 0.0, actors: [Actor({CUBE})])"), "dt"),
        ("dtnan.ron", format!("Scene(dt: NaN, actors: [Actor({CUBE})])"), "dt"),
        ("gravity.ron", format!("Scene(gravity: (0.0, inf, 0.0), actors: [Actor({CUBE})])"), "gravity"),
        (
            "dup.ron",
            format!(
                "Scene(actors: [Actor(name: \"x\", {CUBE}), Actor(name: \"x\", {CUBE}, position: (3.0, 0.0, 0.0))])"
            ),
            "actor 'x': name",
        ),
        (
            "system.ron",
            format!("Scene(schedule: [\"cull\", \"fcae\"], actors: [Actor({CUBE})])"),
            "unknown system 'fcae'",
        ),
        (
            "spawn.ron",
            format!(
                "Scene(actors: [], spawners: [Grid(actor: Actor({CUBE}), counts: (100000, 100000, 100000), spacing: (2.0, 2.0, 2.0))])"
            ),
            "limit",
        ),
        ("gas.ron", "Scene(actors: [], spawners: [BoxGas(actors: 4000000000)])".into(), "limit"),
        ("steps.ron", format!("Scene(steps: 1000000000000, actors: [Actor({CUBE})])"), "steps"),
        ("substeps.ron", format!("Scene(solver: Solver(substeps: 0), actors: [Actor({CUBE})])"), "solver.substeps"),
        ("sweeps.ron", format!("Scene(solver: Solver(iterations: 0), actors: [Actor({CUBE})])"), "solver.iterations"),
    ];
    for (name, text, needle) in cases {
        rejects(&dir, name, text.as_bytes(), &[needle]);
    }
}

#[test]
fn bad_meshes_name_the_actor_and_the_obj_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let obj = |name: &str, body: &str| std::fs::write(dir.path().join(name), body).expect("obj");
    // A unit cube with its top (+y) face missing.
    obj(
        "open.obj",
        "v 0 0 0\nv 0 0 1\nv 0 1 0\nv 0 1 1\nv 1 0 0\nv 1 0 1\nv 1 1 0\nv 1 1 1\n\
                     f 5 7 8\nf 5 8 6\nf 1 2 4\nf 1 4 3\nf 1 5 6\nf 1 6 2\nf 2 6 8\nf 2 8 4\nf 1 3 7\nf 1 7 5\n",
    );
    // A tetrahedron whose four corners lie in one plane: closed, but no volume.
    obj("flat.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n");
    obj("empty.obj", "# nothing\n");
    obj("concave.obj", concave_obj());
    let scene = |file: &str| format!("Scene(actors: [\n  Actor(name: \"rock\", shape: Obj(path: \"{file}\"))])");
    // The error points at the path as written: line 2, column 40.
    let place = |file: &str| format!("{file}.ron:2:40: ");
    for (file, needle) in [
        ("open.obj", "not closed"),
        ("flat.obj", "degenerate"),
        ("empty.obj", "no faces"),
        ("concave.obj", "not convex"),
        ("missing.obj", "cannot open"),
    ] {
        rejects(&dir, &format!("{file}.ron"), scene(file).as_bytes(), &[&place(file), "actor 'rock'", file, needle]);
    }
}

#[test]
fn masses_whose_inverse_overflows_are_refused_where_they_are_written() {
    let dir = tempfile::tempdir().expect("temp dir");
    // Given as a mass, RON places it; from a density, the error points at the actor's name.
    let cases = [
        ("tiny-mass.ron", "mass: 1e-320", "tiny-mass.ron:2:58: actor 'rock': mass: 1e-320 kg is too small"),
        ("tiny-density.ron", "density: 1e-310", "tiny-density.ron:2:15: actor 'rock': mass: comes out as 1e-310 kg"),
    ];
    for (name, field, needle) in cases {
        let text = format!("Scene(actors: [\n  Actor(name: \"rock\", shape: Box(size: (1.0, 1.0, 1.0)), {field})])");
        rejects(&dir, name, text.as_bytes(), &[needle]);
    }
}

/// An L-shaped prism: closed and consistently wound, but not convex.
fn concave_obj() -> &'static str {
    "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\n\
     v 0 0 1\nv 2 0 1\nv 2 1 1\nv 1 1 1\nv 1 2 1\nv 0 2 1\n\
     f 1 4 3\nf 1 3 2\nf 1 6 5\nf 1 5 4\n\
     f 7 8 9\nf 7 9 10\nf 7 10 11\nf 7 11 12\n\
     f 1 2 8\nf 1 8 7\nf 2 3 9\nf 2 9 8\nf 3 4 10\nf 3 10 9\nf 4 5 11\nf 4 11 10\nf 5 6 12\nf 5 12 11\nf 6 1 7\nf 6 7 12\n"
}

#[test]
fn bad_flags_exit_2() {
    for args in [
        vec!["run", "--dt", "-1"],
        vec!["run", "--dt", "nan"],
        vec!["run", "--steps", "-5"],
        vec!["run", "--every", "0"],
        vec!["run", "--threads", "0"],
        vec!["run", "--schedule", "cull,nope"],
        vec!["bench", "box-gas"],
        vec!["bench", "box-gas", "--actors", "0"],
        vec!["bench", "nothing", "--actors", "10"],
        vec!["frobnicate"],
    ] {
        let o = rigid(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    }
}

#[test]
fn a_scene_that_blows_up_is_stopped_by_the_nan_guard_and_keeps_its_last_finite_state() {
    // Gravity 1e308 m/s², dt = 1: the velocity overflows to infinity in step 2.
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = dir.path().join("boom.ron");
    std::fs::write(&scene, "Scene(dt: 1.0, gravity: (1e308, 0.0, 0.0), actors: [Actor(name: \"rocket\", shape: Box(size: (1.0, 1.0, 1.0)))])").expect("scene");
    let out = dir.path().join("last.json");
    let o = rigid(&["run", scene.to_str().expect("utf-8"), "--quiet", "--out", out.to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("step 2") && err.contains("'gravity'") && err.contains("'rocket'") && err.contains("velocity"),
        "{err}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).expect("last state written")).expect("JSON");
    assert_eq!(v["steps"], 1);
    assert_eq!(v["actors"][0]["velocity"][0], 1e308);
}

#[test]
fn warnings_flag_overlapping_starts_and_tunnelling_speeds() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = dir.path().join("w.ron");
    std::fs::write(
        &scene,
        format!(
            "Scene(solver: Solver(ccd: false), \
                 actors: [Actor(name: \"a\", {CUBE}), Actor(name: \"b\", {CUBE}, position: (0.5, 0.0, 0.0)), \
                 Actor(name: \"fast\", {CUBE}, position: (9.0, 0.0, 0.0), velocity: (100.0, 0.0, 0.0))])"
        ),
    )
    .expect("scene");
    let o = rigid(&["check", scene.to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "warnings do not fail: {err}");
    assert!(err.contains("actors 'a' and 'b' start overlapping by 5.000e-1 m"), "{err}");
    assert!(err.contains("actor 'fast' moves") && err.contains("pass through"), "{err}");
    // No shipped scene starts with a warning; a touching start (Newton's cradle, the tower)
    // is not an overlap.
    let scenes = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut checked = 0;
    for entry in std::fs::read_dir(&scenes).expect("scenes/") {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "ron") {
            let o = rigid(&["check", path.to_str().expect("utf-8")]);
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(o.status.success() && !err.contains("warning"), "{}: {err}", path.display());
            checked += 1;
        }
    }
    assert!(checked >= 10, "found the shipped scenes ({checked})");
}
