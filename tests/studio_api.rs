//! `rigid studio`'s JSON API (docs/studio.md), driven through the binary over plain HTTP/1.1.
//! Each test starts its own server on a free port (`--port 0`) and kills it when done.

mod common;
use common::studio::{PAGE_TEST_IDS, Studio, get, request, start};
use serde_json::{Value, json};
use std::process::Command;
use std::time::{Duration, Instant};

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
    for id in PAGE_TEST_IDS {
        assert!(page.contains(&format!("data-testid=\"{id}\"")), "page lacks {id}");
    }
    for script in ["/app.js", "/three.module.min.js", "/OrbitControls.js"] {
        assert_eq!(request(&s, "GET", script, b"").0, 200, "{script}");
    }
}

/// GET `path` as text.
fn get_text(studio: &Studio, path: &str) -> String {
    let (status, body) = request(studio, "GET", path, b"");
    assert_eq!(status, 200, "GET {path}: {}", String::from_utf8_lossy(&body));
    String::from_utf8(body).expect("utf-8")
}

fn actor<'a>(state: &'a Value, name: &str) -> &'a Value {
    state["actors"].as_array().expect("actors").iter().find(|a| a["name"] == name).expect("the actor")
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(|x| x.as_f64().expect("number")).collect()
}

/// Two boxes in free space, `a` flying at `b`: a heavier `a` pushes `b` harder.
const COLLIDE: &str = "Scene(gravity: (0.0, 0.0, 0.0), actors: [\n\
    Actor(name: \"a\", shape: Box(size: (1.0, 1.0, 1.0)), mass: 1.0, velocity: (2.0, 0.0, 0.0), restitution: 0.5),\n\
    Actor(name: \"b\", shape: Box(size: (1.0, 1.0, 1.0)), mass: 1.0, position: (1.5, 0.0, 0.0), restitution: 0.5),\n\
    Actor(name: \"wall\", shape: Box(size: (1.0, 1.0, 1.0)), position: (0.0, -5.0, 0.0), fixed: true),\n])";

/// Steps `COLLIDE` 60 times with `a` of mass `mass` (edited when given); b's x velocity.
fn push_b(mass: Option<f64>) -> f64 {
    let s = start("scenes/box-drop.ron");
    post_ok(&s, "/api/scene", COLLIDE);
    if let Some(m) = mass {
        let v = post_ok(&s, "/api/actor", &json!({"name": "a", "mass": m}).to_string());
        assert_eq!(v["mass"].as_f64(), Some(m), "{v}");
        assert_eq!(actor(&get(&s, "/api/state"), "a")["mass"].as_f64(), Some(m));
    }
    control(&s, json!({"action": "step", "steps": 60}));
    let state = get(&s, "/api/state");
    let (a, b) = (actor(&state, "a"), actor(&state, "b"));
    let m_a = a["mass"].as_f64().expect("mass");
    // Momentum is kept through the collision, with the edited mass.
    let p = m_a * f64s(&a["velocity"])[0] + f64s(&b["velocity"])[0];
    assert!((p - 2.0 * m_a).abs() < 1e-6, "momentum {p}, expected {}", 2.0 * m_a);
    f64s(&b["velocity"])[0]
}

#[test]
fn an_edited_mass_shows_in_the_state_and_changes_the_response() {
    let equal = push_b(None);
    let heavy = push_b(Some(10.0));
    // Restitution 0.5: b leaves at 1.5 m/s from an equal a, at 1.5·10/11·2 from a ten times heavier.
    assert!((equal - 1.5).abs() < 0.05, "equal masses: b at {equal} m/s");
    assert!((heavy - 30.0 / 11.0).abs() < 0.05, "heavy a: b at {heavy} m/s");
}

#[test]
fn edits_change_material_and_velocity_and_survive_a_reset() {
    let s = start("scenes/box-drop.ron");
    let v = post_ok(
        &s,
        "/api/actor",
        r#"{"name": "box", "restitution": 0.25, "friction": 0.75, "velocity": [1.0, 0.0, -2.0]}"#,
    );
    assert_eq!(v["velocity"], json!([1.0, 0.0, -2.0]), "{v}");
    let state = get(&s, "/api/state");
    let b = actor(&state, "box");
    assert_eq!(b["restitution"].as_f64(), Some(0.25));
    assert_eq!(b["friction"].as_f64(), Some(0.75));
    assert_eq!(b["velocity"], json!([1.0, 0.0, -2.0]));
    assert_eq!(b["mass"].as_f64(), Some(1.0));
    post_ok(&s, "/api/actor", r#"{"name": "box", "mass": 4.0}"#);
    control(&s, json!({"action": "step", "steps": 5}));
    control(&s, json!({"action": "reset"}));
    let b = actor(&get(&s, "/api/state"), "box").clone();
    assert_eq!(b["mass"].as_f64(), Some(4.0), "{b}");
    assert_eq!(b["friction"].as_f64(), Some(0.75), "{b}");
    assert_eq!(b["restitution"].as_f64(), Some(0.25), "{b}");
    assert_eq!(b["velocity"], json!([1.0, 0.0, -2.0]), "{b}");
    assert_eq!(b["position"], json!([0.0, 2.0, 0.0]), "{b}");
    // An added actor rebuilds the scene: the edits stay.
    post_ok(&s, "/api/actors", r#"Actor(name: "extra", shape: Box(size: (1.0, 1.0, 1.0)), position: (4.0, 2.0, 0.0))"#);
    assert_eq!(actor(&get(&s, "/api/state"), "box")["mass"].as_f64(), Some(4.0));
    // A loaded scene drops them.
    post_ok(&s, "/api/scene", &std::fs::read_to_string("scenes/box-drop.ron").expect("scene"));
    assert_eq!(actor(&get(&s, "/api/state"), "box")["mass"].as_f64(), Some(1.0));
}

#[test]
fn bad_edits_are_refused_and_change_nothing() {
    let s = start("scenes/box-drop.ron");
    control(&s, json!({"action": "step", "steps": 3}));
    let before = get(&s, "/api/state");
    for (bad, says) in [
        (r#"{"name": "nobody", "mass": 2.0}"#, "nobody"),
        (r#"{"mass": 2.0}"#, "name"),
        (r#"{"name": "box", "mass": -1.0}"#, "mass"),
        (r#"{"name": "box", "mass": 0}"#, "mass"),
        (r#"{"name": "box", "mass": "heavy"}"#, "mass"),
        (r#"{"name": "box", "restitution": 1.5}"#, "restitution"),
        (r#"{"name": "box", "friction": -0.1}"#, "friction"),
        (r#"{"name": "box", "velocity": [1.0, 2.0]}"#, "velocity"),
        (r#"{"name": "box", "velocity": [1.0, 2.0, "x"]}"#, "velocity"),
        (r#"{"name": "box", "colour": "red"}"#, "colour"),
        (r#"{"name": "box", "mass": 2.0, "friction": -1.0}"#, "friction"),
        (r#"{"name": "floor", "mass": 2.0}"#, "fixed"),
        (r#"{"name": "floor", "velocity": [0.0, 1.0, 0.0]}"#, "fixed"),
        (r#"{"name": "box", "#, "JSON"),
    ] {
        let (status, v) = post(&s, "/api/actor", bad);
        assert_eq!(status, 400, "{bad}: {v}");
        let message = v["error"].as_str().unwrap_or_else(|| panic!("{bad}: no error in {v}"));
        assert!(message.contains(says), "{bad}: {message}");
    }
    assert_eq!(get(&s, "/api/state")["actors"], before["actors"]);
    // A fixed actor's material may change.
    post_ok(&s, "/api/actor", r#"{"name": "floor", "friction": 0.9}"#);
    assert_eq!(actor(&get(&s, "/api/state"), "floor")["friction"].as_f64(), Some(0.9));
}

/// Parses and builds saved scene text with the library; checks it against the studio's state.
fn rebuild_matches(text: &str, state: &Value) -> rigid_sandbox::Sim {
    let path = std::path::Path::new("saved.ron");
    let def = rigid_sandbox::scene::parse(text, path).unwrap_or_else(|e| panic!("{e:?}\n{text}"));
    let sim = rigid_sandbox::scene::build(&def, path).unwrap_or_else(|e| panic!("{e:?}"));
    let running = state["actors"].as_array().expect("actors");
    let rebuilt = sim.actors();
    assert_eq!(rebuilt.len(), running.len());
    for (a, r) in rebuilt.iter().zip(running) {
        assert_eq!(a.name, r["name"].as_str().expect("name"));
        let p = f64s(&r["position"]);
        for (x, y) in a.pose.position.to_array().iter().zip(&p) {
            assert!((x - y).abs() <= 1e-12, "{}: {:?} vs {p:?}", a.name, a.pose.position);
        }
        let q = f64s(&r["orientation"]);
        let dot: f64 = a.pose.orientation.to_array().iter().zip(&q).map(|(x, y)| x * y).sum();
        assert!(dot.abs() > 1.0 - 1e-12, "{}: orientation {:?} vs {q:?}", a.name, a.pose.orientation);
        let v = f64s(&r["velocity"]);
        for (x, y) in a.velocity.linear.to_array().iter().zip(&v) {
            assert!((x - y).abs() <= 1e-12, "{}: velocity {:?} vs {v:?}", a.name, a.velocity.linear);
        }
        assert_eq!(a.mass.mass, r["mass"].as_f64().expect("mass"), "{}", a.name);
        assert_eq!(a.mass.is_fixed(), r["fixed"].as_bool().expect("fixed"), "{}", a.name);
    }
    sim
}

#[test]
fn the_saved_scene_rebuilds_where_the_bodies_are_now() {
    // Spawners become actors; the OBJ shapes keep their files.
    for scene in ["scenes/spawners.ron", "scenes/mixed-shapes.ron"] {
        let s = start(scene);
        control(&s, json!({"action": "step", "steps": 30}));
        post_ok(
            &s,
            "/api/actors",
            "Actor(shape: Cylinder(radius: 0.5, height: 1.0, segments: 12), position: (0.0, 8.0, 0.0))",
        );
        let text = get_text(&s, "/api/scene");
        let state = get(&s, "/api/state");
        rebuild_matches(&text, &state);
        // `rigid check` accepts it too.
        let dir = tempfile::tempdir().expect("temp dir");
        let file = dir.path().join("scene.ron");
        std::fs::write(&file, &text).expect("write");
        let out = Command::new(env!("CARGO_BIN_EXE_rigid")).arg("check").arg(&file).output().expect("rigid check");
        assert!(out.status.success(), "{scene}: {}", String::from_utf8_lossy(&out.stderr));
    }
}

#[test]
fn a_saved_scene_keeps_edits_and_reloads() {
    let s = start("scenes/box-drop.ron");
    post_ok(&s, "/api/actor", r#"{"name": "box", "mass": 3.5, "friction": 0.2, "velocity": [0.5, 1.0, 0.0]}"#);
    control(&s, json!({"action": "step", "steps": 12}));
    let text = get_text(&s, "/api/scene");
    let state = get(&s, "/api/state");
    let sim = rebuild_matches(&text, &state);
    let def = rigid_sandbox::scene::parse(&text, std::path::Path::new("saved.ron")).expect("parses");
    let b = def.actors.iter().find(|a| a.name.as_deref() == Some("box")).expect("box");
    assert_eq!(b.mass, rigid_sandbox::scene::MassSpec::Mass(3.5));
    assert_eq!(b.friction, 0.2);
    assert!(sim.actors().iter().any(|a| a.name == "box" && a.mass.mass == 3.5));
    // Loaded back into the studio, it starts where it was saved.
    post_ok(&s, "/api/scene", &text);
    let reloaded = get(&s, "/api/state");
    assert_eq!(reloaded["step"], 0);
    assert_eq!(names(&reloaded), ["floor", "box"]);
    let b = actor(&reloaded, "box");
    assert_eq!(b["position"], actor(&state, "box")["position"]);
    assert_eq!(b["mass"].as_f64(), Some(3.5));
    assert_eq!(b["friction"].as_f64(), Some(0.2));
}

/// The scene's joints as the solver holds them (anchors in the bodies' frames).
fn solver_joints(sim: &rigid_sandbox::Sim) -> Vec<rigid_sandbox::solver::Joint> {
    sim.ctx.scratch.get::<rigid_sandbox::solver::Joints>().map_or_else(Vec::new, |j| j.joints.clone())
}

/// Every actor's pose and velocities as bits.
fn state_bits(sim: &rigid_sandbox::Sim) -> Vec<u64> {
    sim.actors()
        .iter()
        .flat_map(|a| {
            let mut v = a.pose.position.to_array().to_vec();
            v.extend(a.pose.orientation.to_array());
            v.extend(a.velocity.linear.to_array());
            v.extend(a.velocity.angular.to_array());
            v
        })
        .map(f64::to_bits)
        .collect()
}

/// `p` rotated by the unit quaternion `q` ([x, y, z, w]).
fn rotate(q: &[f64], p: &[f64]) -> [f64; 3] {
    let (u, w) = ([q[0], q[1], q[2]], q[3]);
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let t = cross(u, [p[0], p[1], p[2]]).map(|x| 2.0 * x);
    let c = cross(u, t);
    [0, 1, 2].map(|k| p[k] + w * t[k] + c[k])
}

#[test]
fn joints_are_reported_with_their_anchors_where_they_are_now() {
    let s = start("scenes/door.ron");
    let st = get(&s, "/api/state");
    let joints = st["joints"].as_array().expect("joints");
    assert_eq!(joints.len(), 1, "{st}");
    let j = &joints[0];
    assert_eq!(
        (j["name"].as_str(), j["kind"].as_str(), j["a"].as_str(), j["b"].as_str()),
        (Some("hinge"), Some("Hinge"), Some("door"), Some("frame"))
    );
    for end in ["anchor_a", "anchor_b"] {
        assert_eq!(f64s(&j[end]), [0.0, 1.1, 0.0], "{end}: {j}");
    }
    // The page's poll leaves the joints out, as the actors.
    assert_eq!(get(&s, "/api/state?actors=0")["joints"], json!([]));

    // Swung open, A's anchor is the door's body-frame anchor (from /api/meshes) where the door
    // is now, and both anchors stay together (a hinge).
    control(&s, json!({"action": "step", "steps": 90}));
    let st = get(&s, "/api/state");
    let j = &st["joints"][0];
    let meshes = get(&s, "/api/meshes");
    let m = &meshes["joints"][0];
    assert_eq!((m["a"].as_u64(), m["b"].as_u64(), m["kind"].as_str()), (Some(1), Some(0), Some("Hinge")), "{m}");
    let door = actor(&st, "door");
    let lever = rotate(&f64s(&door["orientation"]), &f64s(&m["anchor_a"]));
    let at = f64s(&door["position"]);
    let (on_a, on_b) = (f64s(&j["anchor_a"]), f64s(&j["anchor_b"]));
    for k in 0..3 {
        assert!((on_a[k] - (at[k] + lever[k])).abs() < 1e-12, "{on_a:?} vs {at:?} + {lever:?}");
        assert!((on_a[k] - on_b[k]).abs() < 1e-3, "{on_a:?} vs {on_b:?}");
    }
    assert!(j["position_error"].as_f64().expect("position_error") < 1e-3, "{j}");
    // The door has turned: its centre is no longer where it started.
    assert!((at[0] - 0.45).abs() > 0.05, "{at:?}");

    // A joint to the world names no `b`.
    let s = start("scenes/chain.ron");
    let st = get(&s, "/api/state");
    let joints = st["joints"].as_array().expect("joints");
    assert_eq!(joints.len(), 31);
    assert_eq!((joints[0]["name"].as_str(), joints[0]["b"].clone()), (Some("top"), Value::Null));
    assert_eq!(f64s(&joints[0]["anchor_b"]), [0.0, 7.0, 0.0]);
    assert_eq!(get(&s, "/api/meshes")["joints"].as_array().expect("joints").len(), 31);
}

#[test]
fn a_saved_scene_with_joints_loads_back_and_runs_the_same() {
    let path = std::path::Path::new("saved.ron");
    // Saved at the start: the same joints, bit for bit, and 120 steps to the same bits.
    for scene in ["scenes/chain.ron", "scenes/door.ron", "scenes/slider.ron", "scenes/ragdoll.ron"] {
        let s = start(scene);
        let text = get_text(&s, "/api/scene");
        let original = std::fs::read_to_string(scene).expect("scene");
        let mut a = rigid_sandbox::scene::build(&rigid_sandbox::scene::parse(&original, path).expect("parses"), path)
            .expect("builds");
        let def = rigid_sandbox::scene::parse(&text, path).unwrap_or_else(|e| panic!("{scene}: {e}\n{text}"));
        let mut b = rigid_sandbox::scene::build(&def, path).expect("builds");
        let (ja, jb) = (solver_joints(&a), solver_joints(&b));
        assert!(!ja.is_empty(), "{scene}");
        assert_eq!(ja, jb, "{scene}: the joints differ\n{text}");
        a.run(120).expect("steps");
        b.run(120).expect("steps");
        assert_eq!(state_bits(&a), state_bits(&b), "{scene}: 120 steps differ");
    }

    // Saved mid-swing: the joint stands where it stood, its limits where they were (shifted by
    // the turn so far), so the door stops at the same 90 degrees.
    let s = start("scenes/door.ron");
    control(&s, json!({"action": "step", "steps": 60}));
    let text = get_text(&s, "/api/scene");
    let st = get(&s, "/api/state");
    let mut saved = rebuild_matches(&text, &st);
    let j = &solver_joints(&saved)[0];
    let door = saved.actors()[1].pose;
    let on_a = door.position + door.orientation * j.anchor_a;
    for (x, y) in on_a.to_array().iter().zip(f64s(&st["joints"][0]["anchor_a"])) {
        assert!((x - y).abs() < 1e-12, "{on_a} vs {}", st["joints"][0]["anchor_a"]);
    }
    let rigid_sandbox::solver::JointKind::Hinge { limits: Some([lo, hi]), .. } = j.kind else { panic!("{j:?}") };
    let turned = 1.5 * 0.5; // rad: 60 steps of 1/120 s at 1.5 rad/s
    assert!((lo + turned).abs() < 0.02 && (hi - (std::f64::consts::FRAC_PI_2 - turned)).abs() < 0.02, "{lo} {hi}");
    control(&s, json!({"action": "step", "steps": 120}));
    saved.run(120).expect("steps");
    let running = f64s(&actor(&get(&s, "/api/state"), "door")["orientation"]);
    let reloaded = saved.actors()[1].pose.orientation.to_array();
    let dot: f64 = running.iter().zip(reloaded).map(|(x, y)| x * y).sum();
    assert!(dot.abs() > (0.5_f64 * 0.01).cos(), "the door turned differently: {running:?} vs {reloaded:?}");
    // `rigid check` accepts it.
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("scene.ron");
    std::fs::write(&file, &text).expect("write");
    let out = Command::new(env!("CARGO_BIN_EXE_rigid")).arg("check").arg(&file).output().expect("rigid check");
    assert!(out.status.success(), "{}\n{text}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn contacts_are_points_and_unit_normals() {
    let s = start("scenes/box-drop.ron");
    let (status, body) = request(&s, "GET", "/api/contacts", b"");
    assert_eq!((status, body.len()), (200, 0), "no contacts before the first step");
    // Landed and resting on the floor: one touching pair, its normal vertical.
    control(&s, json!({"action": "step", "steps": 120}));
    let (status, body) = request(&s, "GET", "/api/contacts", b"");
    assert_eq!(status, 200);
    let f: Vec<f32> = body.chunks(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let n = get(&s, "/api/state?actors=0")["contacts"].as_u64().expect("contacts") as usize;
    assert!(n >= 1);
    assert_eq!(f.len(), 6 * n, "6 floats a contact");
    for c in f.chunks(6) {
        let normal = (c[3] * c[3] + c[4] * c[4] + c[5] * c[5]).sqrt();
        assert!((normal - 1.0).abs() < 1e-5 && c[4].abs() > 0.99, "{c:?}");
        assert!(c[1].abs() < 0.05, "the contact is on the floor's top: {c:?}");
    }
}

#[test]
fn a_port_in_use_is_reported_as_such() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").expect("a free port");
    let port = taken.local_addr().expect("address").port().to_string();
    let out = Command::new(env!("CARGO_BIN_EXE_rigid"))
        .args(["studio", "scenes/box-drop.ron", "--port", &port, "--no-open"])
        .output()
        .expect("rigid runs");
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains(&format!("cannot listen on 127.0.0.1:{port}")), "{stderr}");
}
