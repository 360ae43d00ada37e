//! Snapshots: `--save` then `--resume` continues a run bit for bit (100 + 100 steps equal 200),
//! and `--out` carries a `state_hash` that makes that cheap to check.

use std::process::{Command, Output};

fn rigid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("the binary runs")
}

fn hash(path: &std::path::Path) -> (String, serde_json::Value) {
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).expect("written")).expect("JSON");
    (v["state_hash"].as_str().expect("hash").to_string(), v)
}

#[test]
fn resume_continues_bit_for_bit() {
    let dir = tempfile::tempdir().expect("temp dir");
    let p = |name: &str| dir.path().join(name).to_str().expect("utf-8").to_string();
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/mixed-shapes.ron");
    let scene = scene.to_str().expect("utf-8");
    let whole = rigid(&["run", scene, "--steps", "200", "--quiet", "--out", &p("whole.json")]);
    assert!(whole.status.success(), "{}", String::from_utf8_lossy(&whole.stderr));
    let first = rigid(&["run", scene, "--steps", "100", "--quiet", "--save", &p("half.snap")]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let second = rigid(&["run", "--resume", &p("half.snap"), "--steps", "100", "--quiet", "--out", &p("resumed.json")]);
    assert!(second.status.success(), "{}", String::from_utf8_lossy(&second.stderr));
    let (h1, whole) = hash(std::path::Path::new(&p("whole.json")));
    let (h2, resumed) = hash(std::path::Path::new(&p("resumed.json")));
    assert_eq!(h1, h2, "100 + 100 steps = 200 steps");
    assert_eq!(whole, resumed, "every field, contacts and time included");
    assert_eq!(resumed["steps"], 200);
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
