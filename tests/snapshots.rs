//! Snapshots: `--save` then `--resume` continues a run bit for bit (100 + 100 steps equal 200,
//! also under gravity, with resting contacts and sleeping), and `--out` carries a `state_hash`
//! that makes that cheap to check.

use std::process::{Command, Output};

fn rigid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("the binary runs")
}

fn hash(path: &std::path::Path) -> (String, serde_json::Value) {
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).expect("written")).expect("JSON");
    (v["state_hash"].as_str().expect("hash").to_string(), v)
}

/// Runs `scene` for 2·`half` steps whole and as `half` + `half` through `--save`/`--resume`,
/// asserts both give the same output, and returns the snapshot taken halfway.
fn resumes_exactly(dir: &tempfile::TempDir, scene: &str, half: u64) -> serde_json::Value {
    let p = |name: &str| dir.path().join(name).to_str().expect("utf-8").to_string();
    let (half_steps, all_steps) = (half.to_string(), (2 * half).to_string());
    let whole = rigid(&["run", scene, "--steps", &all_steps, "--quiet", "--out", &p("whole.json")]);
    assert!(whole.status.success(), "{}", String::from_utf8_lossy(&whole.stderr));
    let first = rigid(&["run", scene, "--steps", &half_steps, "--quiet", "--save", &p("half.snap")]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let second =
        rigid(&["run", "--resume", &p("half.snap"), "--steps", &half_steps, "--quiet", "--out", &p("resumed.json")]);
    assert!(second.status.success(), "{}", String::from_utf8_lossy(&second.stderr));
    let (h1, whole) = hash(std::path::Path::new(&p("whole.json")));
    let (h2, resumed) = hash(std::path::Path::new(&p("resumed.json")));
    assert_eq!(h1, h2, "{scene}: {half} + {half} steps = {} steps", 2 * half);
    assert_eq!(whole, resumed, "{scene}: every field, contacts and time included");
    assert_eq!(resumed["steps"], 2 * half);
    serde_json::from_str(&std::fs::read_to_string(p("half.snap")).expect("saved")).expect("JSON")
}

#[test]
fn resume_continues_bit_for_bit() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/mixed-shapes.ron");
    resumes_exactly(&dir, scene.to_str().expect("utf-8"), 100);
}

#[test]
fn resume_under_gravity_keeps_the_contact_solver_and_sleeping_state() {
    // Resting contacts are warm-started from last step's impulses and keep their points while
    // still; sleeping counts how long each body has been still. The snapshot carries both, so
    // a settling pyramid (sleeping on) and a rain pile resume exactly.
    let dir = tempfile::tempdir().expect("temp dir");
    for (name, text, half) in [
        ("sleeping.ron", "Scene(solver: Solver(sleep: true), actors: [], spawners: [Pyramid(base: 6)])", 90),
        ("pyramid.ron", "Scene(actors: [], spawners: [Pyramid(base: 6)])", 30),
        ("rain.ron", "Scene(actors: [], spawners: [Rain(actors: 40, seed: 3)])", 150),
    ] {
        let scene = dir.path().join(name);
        std::fs::write(&scene, text).expect("scene");
        let snap = resumes_exactly(&dir, scene.to_str().expect("utf-8"), half);
        if name == "sleeping.ron" {
            let asleep = snap["sleep"]["asleep"].as_array().expect("sleep state");
            assert!(asleep.iter().any(|s| s.as_bool() == Some(true)), "some of the pyramid sleeps by then");
        } else {
            assert!(!snap["warm_start"].as_array().expect("warm start").is_empty(), "{name}: contacts are held");
        }
    }
}

#[test]
fn jointed_runs_resume_bit_for_bit() {
    // Joints are warm-started from last substep's impulses: the snapshot carries them.
    let dir = tempfile::tempdir().expect("temp dir");
    for scene in ["double-pendulum.ron", "chain.ron"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(scene);
        let snap = resumes_exactly(&dir, path.to_str().expect("utf-8"), 30);
        assert!(!snap["joints"].as_array().expect("joint impulses").is_empty(), "{scene}");
    }
}

#[test]
fn a_snapshot_with_a_pulling_contact_impulse_is_bad_input() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = dir.path().join("drop.ron");
    std::fs::write(
        &scene,
        "Scene(actors: [Actor(name: \"floor\", shape: Box(size: (9.0, 1.0, 9.0)), position: (0.0, -0.5, 0.0), fixed: true),\
                        Actor(name: \"box\", shape: Box(size: (1.0, 1.0, 1.0)), position: (0.0, 0.5, 0.0))])",
    )
    .expect("scene");
    let snap = dir.path().join("s.snap");
    let o = rigid(&[
        "run",
        scene.to_str().expect("utf-8"),
        "--steps",
        "5",
        "--quiet",
        "--save",
        snap.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&snap).expect("saved")).expect("JSON");
    v["warm_start"][0]["impulses"][0] = serde_json::json!(-1.0);
    std::fs::write(&snap, v.to_string()).expect("rewritten");
    let o = rigid(&["run", "--resume", snap.to_str().expect("utf-8"), "--steps", "1", "--quiet"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("s.snap") && err.contains("warm_start[0]") && err.contains("negative"), "{err}");
}

#[test]
fn same_scene_same_hash_and_threads_do_not_matter() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/spawners.ron");
    let run = |threads: &str, name: &str| {
        let out = dir.path().join(name);
        let o = rigid(&[
            "run",
            scene.to_str().expect("utf-8"),
            "--steps",
            "150",
            "--threads",
            threads,
            "--quiet",
            "--out",
            out.to_str().expect("utf-8"),
        ]);
        assert!(o.status.success());
        std::fs::read(&out).expect("written")
    };
    let a = run("1", "a.json");
    assert_eq!(a, run("1", "b.json"), "byte-identical reruns");
    assert_eq!(a, run("2", "c.json"), "byte-identical with two threads");
}

#[test]
fn a_broken_snapshot_is_bad_input() {
    let dir = tempfile::tempdir().expect("temp dir");
    let snap = dir.path().join("bad.snap");
    std::fs::write(&snap, "{\"format\": 1,\n \"scene_path\": 3}").expect("file");
    let o = rigid(&["run", "--resume", snap.to_str().expect("utf-8")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("bad.snap:2:"), "{err}");
}

#[test]
fn ctrl_c_saves_the_run_and_it_resumes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let snap = dir.path().join("interrupted.snap");
    // A tiny scene: built in milliseconds, so the handler is in place long before the signal.
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/newtons-cradle.ron");
    let mut child = Command::new(env!("CARGO_BIN_EXE_rigid"))
        .args(["run", scene.to_str().expect("utf-8"), "--steps", "100000000", "--quiet", "--save"])
        .arg(&snap)
        .spawn()
        .expect("starts");
    // Let it get going, then interrupt it as a terminal's Ctrl-C would.
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let status = Command::new("kill").args(["-INT", &child.id().to_string()]).status().expect("kill runs");
    assert!(status.success());
    let exit = child.wait().expect("exits");
    assert_eq!(exit.code(), Some(130), "interrupted, not failed");
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&snap).expect("saved on Ctrl-C")).expect("JSON");
    let steps = saved["steps"].as_u64().expect("steps");
    assert!(steps > 0, "some steps were taken");
    let o = rigid(&[
        "run",
        "--resume",
        snap.to_str().expect("utf-8"),
        "--steps",
        "2",
        "--quiet",
        "--out",
        dir.path().join("after.json").to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, after) = hash(&dir.path().join("after.json"));
    assert_eq!(after["steps"].as_u64(), Some(steps + 2));
}
