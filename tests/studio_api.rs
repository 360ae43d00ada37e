//! `rigid studio`'s JSON API (docs/studio.md), driven through the binary over plain HTTP/1.1.
//! Each test starts its own server on a free port (`--port 0`) and kills it when done.

use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A running studio; killed when dropped, also when a test fails.
struct Studio {
    child: Child,
    addr: String,
}

impl Drop for Studio {
    /// Ctrl-C first, so the studio removes its upload folder; then, if need be, a kill.
    fn drop(&mut self) {
        let _ = Command::new("kill").args(["-INT", &self.child.id().to_string()]).status();
        let deadline = std::time::Instant::now() + Duration::from_secs(2);
        while std::time::Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start(scene: &str) -> Studio {
    let mut child = Command::new(env!("CARGO_BIN_EXE_rigid"))
        .args(["studio", scene, "--port", "0", "--no-open"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("rigid starts");
    let stdout = child.stdout.take().expect("stdout");
    let mut studio = Studio { child, addr: String::new() };
    let mut lines = BufReader::new(stdout).lines();
    let line = lines.next().expect("a line").expect("utf-8");
    let at = line.find("http://").unwrap_or_else(|| panic!("no address in {line:?}"));
    studio.addr = line[at + "http://".len()..].trim_end_matches('/').to_string();
    // Keep draining stdout so the server never blocks on a full pipe.
    std::thread::spawn(move || lines.for_each(drop));
    studio
}

/// One request; returns the status and the body.
fn request(studio: &Studio, method: &str, path: &str, body: &[u8]) -> (u16, Vec<u8>) {
    let mut stream = TcpStream::connect(&studio.addr).expect("connect");
    stream.set_read_timeout(Some(Duration::from_secs(20))).expect("timeout");
    let head = format!(
        "{method} {path} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\nContent-Length: {}\r\n\r\n",
        studio.addr,
        body.len()
    );
    stream.write_all(head.as_bytes()).expect("write");
    stream.write_all(body).expect("write");
    let mut response = Vec::new();
    stream.read_to_end(&mut response).expect("read");
    let split = response.windows(4).position(|w| w == b"\r\n\r\n").expect("headers end");
    let head = String::from_utf8_lossy(&response[..split]).to_string();
    let status = head.split(' ').nth(1).and_then(|s| s.parse().ok()).expect("status");
    (status, response[split + 4..].to_vec())
}

fn get(studio: &Studio, path: &str) -> Value {
    let (status, body) = request(studio, "GET", path, b"");
    assert_eq!(status, 200, "GET {path}: {}", String::from_utf8_lossy(&body));
    serde_json::from_slice(&body).expect("JSON")
}

fn post(studio: &Studio, path: &str, body: &str) -> (u16, Value) {
    let (status, body) = request(studio, "POST", path, body.as_bytes());
    (status, serde_json::from_slice(&body).unwrap_or(Value::Null))
}

fn post_ok(studio: &Studio, path: &str, body: &str) -> Value {
    let (status, v) = post(studio, path, body);
    assert_eq!(status, 200, "POST {path}: {v}");
    v
}

fn control(studio: &Studio, body: Value) -> Value {
    post_ok(studio, "/api/control", &body.to_string())
}

fn names(state: &Value) -> Vec<String> {
    state["actors"].as_array().expect("actors").iter().map(|a| a["name"].as_str().expect("name").to_string()).collect()
}

/// True when `message` holds `:line:col:` after the file name.
fn has_line_col(message: &str) -> bool {
    message
        .split(':')
        .collect::<Vec<_>>()
        .windows(2)
        .any(|w| w[0].parse::<u32>().is_ok() && w[1].parse::<u32>().is_ok())
}

#[test]
fn state_play_pause_and_step() {
    let s = start("scenes/box-drop.ron");
    let state = get(&s, "/api/state");
    assert_eq!(names(&state), ["floor", "box"]);
    assert_eq!(state["scene"], "box-drop.ron");
    assert_eq!(state["running"], false);
    assert_eq!(state["step"], 0);
    assert!(state["schedule"].as_array().expect("schedule").iter().any(|n| n == "gravity"));
    assert!(state["actors"][0]["fixed"].as_bool().expect("fixed"));
    assert_eq!(state["actors"][1]["position"].as_array().expect("position").len(), 3);
    assert_eq!(state["actors"][1]["orientation"].as_array().expect("orientation").len(), 4);

    control(&s, json!({"action": "play"}));
    let deadline = Instant::now() + Duration::from_secs(5);
    while get(&s, "/api/state")["time"].as_f64().expect("time") == 0.0 {
        assert!(Instant::now() < deadline, "time does not advance while playing");
        std::thread::sleep(Duration::from_millis(50));
    }
    let state = get(&s, "/api/state");
    assert_eq!(state["running"], true);
    assert!(state["systems_ms"].as_object().expect("systems_ms").contains_key("integrate"));

    control(&s, json!({"action": "pause"}));
    let t1 = get(&s, "/api/state")["time"].as_f64().expect("time");
    std::thread::sleep(Duration::from_millis(300));
    let paused = get(&s, "/api/state");
    assert_eq!(paused["time"].as_f64(), Some(t1), "time moves while paused");
    assert_eq!(paused["running"], false);

    let before = paused["step"].as_u64().expect("step");
    control(&s, json!({"action": "step", "steps": 5}));
    assert_eq!(get(&s, "/api/state")["step"].as_u64(), Some(before + 5));
    control(&s, json!({"action": "step"}));
    assert_eq!(get(&s, "/api/state")["step"].as_u64(), Some(before + 6));

    control(&s, json!({"action": "reset"}));
    let state = get(&s, "/api/state");
    assert_eq!(state["step"], 0);
    assert_eq!(state["actors"][1]["position"][1].as_f64(), Some(2.0));

    let (status, v) = post(&s, "/api/control", r#"{"action": "fly"}"#);
    assert_eq!(status, 400);
    assert!(v["error"].as_str().expect("error").contains("fly"));
}

#[test]
fn a_bad_scene_is_refused_and_the_old_one_keeps_running() {
    let s = start("scenes/box-drop.ron");
    control(&s, json!({"action": "step", "steps": 3}));
    let bad = "Scene(\n    actors: [\n        Actor(name: \"a\", shape: Box(size: (1.0, 1.0, 1.0)), mass: -1.0),\n    ],\n)\n";
    let (status, v) = post(&s, "/api/scene", bad);
    assert_eq!(status, 400, "{v}");
    let message = v["error"].as_str().expect("error message");
    assert!(message.starts_with("<studio>:3:"), "{message}");
    assert!(has_line_col(message), "{message}");
    assert!(message.contains("mass"), "{message}");
    let (status, v) = post(&s, "/api/scene", "Scene(actors: [Actor(shape: Sphere)])");
    assert_eq!(status, 400, "{v}");
    assert!(has_line_col(v["error"].as_str().expect("error")), "{v}");
    let state = get(&s, "/api/state");
    assert_eq!(names(&state), ["floor", "box"]);
    assert_eq!(state["step"], 3);
    assert_eq!(state["scene"], "box-drop.ron");

    let good = "Scene(gravity: (0.0, 0.0, 0.0), actors: [\n  Actor(name: \"x\", shape: Box(size: (1.0, 1.0, 1.0))),\n  \
                Actor(name: \"y\", shape: Box(size: (1.0, 1.0, 1.0)), position: (3.0, 0.0, 0.0)),\n  \
                Actor(name: \"z\", shape: Box(size: (1.0, 1.0, 1.0)), position: (6.0, 0.0, 0.0)),\n])";
    post_ok(&s, "/api/scene", good);
    let state = get(&s, "/api/state");
    assert_eq!(names(&state), ["x", "y", "z"]);
    assert_eq!(state["scene"], "<studio>");
    assert_eq!(state["step"], 0);
}

#[test]
fn actors_are_added_and_bad_ones_refused() {
    let s = start("scenes/box-drop.ron");
    control(&s, json!({"action": "step", "steps": 10}));
    let before = get(&s, "/api/state");
    let y_box = before["actors"][1]["position"][1].as_f64().expect("y");
    post_ok(
        &s,
        "/api/actors",
        r#"Actor(name: "ball", shape: Icosphere(radius: 0.5, subdivisions: 1), position: (3.0, 4.0, 0.0))"#,
    );
    let after = get(&s, "/api/state");
    assert_eq!(after["actors"].as_array().expect("actors").len(), 3);
    assert_eq!(names(&after), ["floor", "box", "ball"]);
    // The existing actors keep their poses and the clock goes on.
    assert_eq!(after["actors"][1]["position"][1].as_f64(), Some(y_box));
    assert_eq!(after["step"], before["step"]);
    // Unnamed actors get a name of their own.
    post_ok(&s, "/api/actors", "Actor(shape: Box(size: (1.0, 1.0, 1.0)), position: (-3.0, 4.0, 0.0))");
    assert_eq!(get(&s, "/api/state")["actors"].as_array().expect("actors").len(), 4);

    for bad in [
        r#"Actor(name: "b", shape: Box(size: (1.0, 1.0, 1.0)), wings: 2)"#,
        r#"Actor(name: "b", shape: Box(size: (-1.0, 1.0, 1.0)))"#,
        r#"Actor(name: "box", shape: Box(size: (1.0, 1.0, 1.0)))"#,
        "Actor(",
    ] {
        let (status, v) = post(&s, "/api/actors", bad);
        assert_eq!(status, 400, "{bad}: {v}");
        assert!(v["error"].as_str().is_some_and(|e| !e.is_empty()), "{bad}: {v}");
    }
    assert_eq!(get(&s, "/api/state")["actors"].as_array().expect("actors").len(), 4);
    // A reset restarts the edited scene, added actors included.
    control(&s, json!({"action": "reset"}));
    let reset = get(&s, "/api/state");
    assert_eq!(reset["actors"].as_array().expect("actors").len(), 4);
    assert_eq!(reset["step"], 0);
}

#[test]
fn the_schedule_can_be_changed() {
    let s = start("scenes/box-drop.ron");
    let (status, v) = post(&s, "/api/schedule", r#"{"systems": ["cull", "warp_drive", "integrate"]}"#);
    assert_eq!(status, 400, "{v}");
    assert!(v["error"].as_str().expect("error").contains("warp_drive"));
    let no_gravity: Vec<&str> =
        ["cull", "prune", "face", "vertex", "edge", "resolve", "solve", "correct", "sleep", "integrate"].to_vec();
    post_ok(&s, "/api/schedule", &json!({ "systems": no_gravity }).to_string());
    control(&s, json!({"action": "step", "steps": 20}));
    let state = get(&s, "/api/state");
    assert_eq!(state["schedule"], json!(no_gravity));
    assert_eq!(state["actors"][1]["velocity"], json!([0.0, 0.0, 0.0]));
    assert_eq!(state["actors"][1]["position"][1].as_f64(), Some(2.0));
    // The page still offers gravity, unticked.
    assert!(state["systems"].as_array().expect("systems").iter().any(|n| n == "gravity"));
}

const CUBE_OBJ: &str = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n\
                        v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n\
                        f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n\
                        f 4 8 7\nf 4 7 3\nf 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n";

#[test]
fn uploaded_meshes_serve_scenes_and_actors() {
    let s = start("scenes/box-drop.ron");
    post_ok(&s, "/api/mesh?name=crate.obj", CUBE_OBJ);
    let (status, _) = post(&s, "/api/mesh?name=../evil.obj", CUBE_OBJ);
    assert_eq!(status, 400);
    // An actor from the upload joins the scene loaded from a file.
    post_ok(&s, "/api/actors", r#"Actor(name: "c", shape: Obj(path: "crate.obj"), position: (2.0, 3.0, 0.0))"#);
    assert_eq!(names(&get(&s, "/api/state")), ["floor", "box", "c"]);
    // And a posted scene finds it too.
    post_ok(&s, "/api/scene", r#"Scene(actors: [Actor(name: "k", shape: Obj(path: "crate.obj"))])"#);
    assert_eq!(names(&get(&s, "/api/state")), ["k"]);
    let meshes = get(&s, "/api/meshes");
    assert_eq!(meshes["meshes"].as_array().expect("meshes").len(), 1);
    assert_eq!(meshes["meshes"][0]["vertices"].as_array().expect("vertices").len(), 24);
    let (status, v) = post(&s, "/api/scene", r#"Scene(actors: [Actor(name: "k", shape: Obj(path: "nope.obj"))])"#);
    assert_eq!(status, 400, "{v}");
    assert!(!v["error"].as_str().expect("error").contains("rigid-studio-"), "{v}");
}

#[test]
fn frames_are_seven_floats_per_actor() {
    let s = start("scenes/box-drop.ron");
    let (status, body) = request(&s, "GET", "/api/frame", b"");
    assert_eq!(status, 200);
    assert_eq!(body.len(), 28 * 2);
    let f: Vec<f32> = body.chunks(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    assert_eq!(&f[7..14], &[0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    let meshes = get(&s, "/api/meshes");
    assert_eq!(meshes["actors"].as_array().expect("actors").len(), 2);
    assert_eq!(meshes["actors"][1]["mesh"], 1);
    assert_eq!(meshes["actors"][1]["colour"].as_array().expect("colour").len(), 3);
    let (status, page) = request(&s, "GET", "/", b"");
    assert_eq!(status, 200);
    let page = String::from_utf8(page).expect("utf-8");
    for id in ["viewport", "play", "pause", "step", "reset", "time", "actor-count", "scene-file", "mesh-file"] {
        assert!(page.contains(&format!("data-testid=\"{id}\"")), "page lacks {id}");
    }
    for script in ["/app.js", "/three.module.min.js", "/OrbitControls.js"] {
        assert_eq!(request(&s, "GET", script, b"").0, 200, "{script}");
    }
}
