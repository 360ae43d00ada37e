//! `rigid studio`'s page in a real browser, through its controls as a user would: Debian's
//! `chromium`, headless, driven by `chromedriver` over the W3C WebDriver protocol
//! (tests/common/studio/webdriver.rs). Files are chosen through the page's file inputs, buttons
//! and the viewport are clicked, screenshots are decoded. Needs `chromium` and `chromium-driver`:
//! `.ci/run` installs them and runs `cargo test --test studio_browser -- --ignored`.

mod common;
use common::studio::webdriver::{Browser, absolute};
use common::studio::{PAGE_TEST_IDS, Studio, get, request, start};
use serde_json::Value;
use std::path::Path;

fn state(studio: &Studio) -> Value {
    get(studio, "/api/state")
}

fn actors(studio: &Studio) -> Vec<Value> {
    state(studio)["actors"].as_array().expect("actors").clone()
}

/// A browser on the studio's page, loaded, drawn at every pixel (the adaptive render scale off,
/// so that screenshots do not depend on how fast this machine draws).
fn page(studio: &Studio) -> Browser {
    page_with(studio, "adapt=0")
}

fn page_with(studio: &Studio, query: &str) -> Browser {
    let b = Browser::start(800, 600);
    b.open(&format!("http://{}/?{query}", studio.addr));
    b
}

/// The render scale the page shows (`data-scale` of the frame-rate corner).
fn render_scale(b: &Browser) -> f64 {
    b.attribute("fps", "data-scale").and_then(|s| s.parse().ok()).expect("data-scale")
}

/// The viewport canvas's drawing-buffer width and its width on screen [pixels].
fn canvas_widths(b: &Browser) -> (f64, f64) {
    (b.property("viewport", "width").as_f64().expect("width"), b.rect("viewport")[2])
}

/// Waits until the page's `actor-count` shows `n`.
fn wait_count(b: &Browser, n: usize) {
    b.wait_for(&format!("actor-count {n}"), || (b.text("actor-count") == n.to_string()).then_some(()));
}

/// The page's `data-time` and `data-step` of the `time` element.
fn page_time(b: &Browser) -> (f64, u64) {
    let time = b.attribute("time", "data-time").and_then(|t| t.parse().ok()).expect("data-time");
    let step = b.attribute("time", "data-step").and_then(|t| t.parse().ok()).expect("data-step");
    (time, step)
}

/// The viewport's pixels in a screenshot.
fn viewport_pixels(b: &Browser) -> Vec<[u8; 3]> {
    let shot = b.screenshot();
    let [x, y, w, h] = b.rect("viewport").map(|v| v.round() as u32);
    assert!(w > 300 && h > 300, "viewport {w}x{h}");
    assert!(
        shot.width() >= x + w && shot.height() >= y + h,
        "screenshot {:?}, viewport at {x},{y} {w}x{h}",
        shot.dimensions()
    );
    image::imageops::crop_imm(&shot, x, y, w, h).to_image().pixels().map(|p| p.0).collect()
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn the_page_has_every_control_and_play_advances_time() {
    let s = start("scenes/box-drop.ron");
    let b = page(&s);
    for id in PAGE_TEST_IDS.iter().chain(&["system-gravity", "system-integrate"]) {
        b.find(id);
    }
    assert_eq!(b.text("actor-count"), "2");
    assert_eq!(page_time(&b), (0.0, 0), "the studio starts paused");

    b.click("play");
    let (time, step) = b.wait_for("time to advance", || Some(page_time(&b)).filter(|t| t.1 >= 10));
    assert!(time > 0.0 && step >= 10, "{time} s, step {step}");
    let text = b.text("time");
    assert!(text.ends_with(')') && text.contains(" s (step "), "{text}");
    assert_eq!(state(&s)["running"], true);
    b.wait_for("the timings", || b.text("timings").contains("integrate").then_some(()));

    b.click("pause");
    b.wait_for("a pause", || (state(&s)["running"] == false).then_some(()));
    let paused = state(&s)["step"].as_u64().expect("step");
    b.click("step");
    b.wait_for("one step", || (state(&s)["step"].as_u64() == Some(paused + 1)).then_some(()));
    b.wait_for("the page to show it", || (page_time(&b).1 == paused + 1).then_some(()));
    assert_eq!(b.text("error"), "", "the page shows an error");
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn the_viewport_draws_the_scene() {
    let s = start("scenes/mixed-shapes.ron");
    let b = page(&s);
    b.click("play");
    b.wait_for("time to advance", || (page_time(&b).1 >= 30).then_some(()));
    let pixels = viewport_pixels(&b);
    let colours: std::collections::HashSet<[u8; 3]> = pixels.iter().copied().collect();
    assert!(colours.len() > 50, "viewport looks blank: {} colours", colours.len());
    // The actors are coloured; the background, grid and panel are grey.
    let saturated = pixels
        .iter()
        .filter(|p| {
            let [r, g, b] = p.map(i32::from);
            r.max(g).max(b) - r.min(g).min(b) > 60
        })
        .count();
    assert!(saturated > 500, "no coloured bodies drawn ({saturated} coloured pixels)");
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn a_scene_and_a_mesh_load_through_the_file_inputs() {
    let s = start("scenes/box-drop.ron");
    let b = page(&s);
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = dir.path().join("three.ron");
    std::fs::write(
        &scene,
        "Scene(actors: [
            Actor(name: \"ground\", shape: Box(size: (10.0, 1.0, 10.0)), position: (0.0, -0.5, 0.0), fixed: true),
            Actor(name: \"a\", shape: Box(size: (1.0, 1.0, 1.0)), position: (0.0, 1.0, 0.0)),
            Actor(name: \"b\", shape: Icosphere(radius: 0.5, subdivisions: 1), position: (2.0, 1.0, 0.0)),
        ])",
    )
    .expect("write");
    b.send_keys("scene-file", &absolute(&scene).display().to_string());
    wait_count(&b, 3);
    let names: Vec<Value> = actors(&s).iter().map(|a| a["name"].clone()).collect();
    assert_eq!(names, ["ground", "a", "b"], "the file's scene is running");

    b.send_keys("mesh-file", &absolute(Path::new("scenes/models/gem.obj")).display().to_string());
    wait_count(&b, 4);
    let all = actors(&s);
    assert_eq!(all.len(), 4);
    let gem = &all[3];
    assert_eq!(gem["fixed"], false, "{gem}");
    assert!(gem["mass"].as_f64().expect("mass") > 0.0, "{gem}");
    assert_eq!(b.text("error"), "");
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn actors_are_added_from_the_palette_where_the_ground_was_clicked() {
    let s = start("scenes/box-drop.ron");
    let b = page(&s);
    b.click("add-box");
    wait_count(&b, 3);
    let first = actors(&s)[2]["position"].clone();
    // The camera frames the box at the centre: well below it is open floor.
    b.click_at("viewport", -150, 180);
    b.click("add-sphere");
    wait_count(&b, 4);
    let second = actors(&s)[3]["position"].clone();
    let d = |i: usize| first[i].as_f64().expect("x") - second[i].as_f64().expect("x");
    assert!(d(0).hypot(d(2)) > 1.0, "the click moved the drop point: {first} then {second}");
    b.click("add-cylinder");
    wait_count(&b, 5);
    assert_eq!(actors(&s).len(), 5);
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn unticking_a_system_takes_it_out_of_the_schedule() {
    let s = start("scenes/box-drop.ron");
    let b = page(&s);
    let schedule = |s: &Studio| -> Vec<String> {
        state(s)["schedule"]
            .as_array()
            .expect("schedule")
            .iter()
            .map(|n| n.as_str().expect("name").to_string())
            .collect()
    };
    let before = schedule(&s);
    assert!(before.iter().any(|n| n == "gravity"), "{before:?}");
    assert!(b.is_selected("system-gravity"));
    b.click("system-gravity");
    let after =
        b.wait_for("gravity out of the schedule", || Some(schedule(&s)).filter(|n| !n.iter().any(|n| n == "gravity")));
    let mut expected = before.clone();
    expected.retain(|n| n != "gravity");
    assert_eq!(after, expected, "only gravity left the schedule");
    assert!(!b.is_selected("system-gravity"));
    assert!(b.is_selected("system-integrate"));
    // Without gravity the box floats where it was.
    b.click("play");
    b.wait_for("steps", || (page_time(&b).1 >= 30).then_some(()));
    assert_eq!(actors(&s)[1]["position"][1].as_f64(), Some(2.0));
    b.click("system-gravity");
    b.wait_for("gravity back", || (schedule(&s) == before).then_some(()));
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn a_bad_scene_file_shows_its_error_and_the_scene_runs_on() {
    let s = start("scenes/box-drop.ron");
    let b = page(&s);
    let dir = tempfile::tempdir().expect("temp dir");
    let bad = dir.path().join("bad.ron");
    std::fs::write(&bad, "Scene(actors: [\n  Actor(shape: Sphere)])\n").expect("write");
    b.send_keys("scene-file", &absolute(&bad).display().to_string());
    let error = b.wait_for("the error", || Some(b.text("error")).filter(|e| !e.is_empty()));
    assert!(error.starts_with("<studio>:2:"), "a line:col message: {error}");
    let names: Vec<Value> = actors(&s).iter().map(|a| a["name"].clone()).collect();
    assert_eq!(names, ["floor", "box"], "the running scene is untouched");
    assert_eq!(b.text("actor-count"), "2");
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn a_clicked_actor_is_edited_through_its_fields_and_saved() {
    let s = start("scenes/box-drop.ron");
    let b = page(&s);
    // The camera frames the free box: a click at the viewport's centre picks it.
    b.click_at("viewport", 0, 0);
    b.wait_for("the box selected", || (b.text("actor-name") == "box").then_some(()));
    b.wait_for("its fields", || (b.property("actor-mass", "value") == "1").then_some(()));
    b.fill("actor-mass", "2.5");
    b.fill("actor-friction", "0.3");
    b.fill("actor-velocity", "1 0 -1");
    b.click("actor-apply");
    b.wait_for("the edit", || (actors(&s)[1]["mass"].as_f64() == Some(2.5)).then_some(()));
    let a = &actors(&s)[1];
    assert_eq!(a["name"], "box");
    assert_eq!(a["friction"].as_f64(), Some(0.3), "{a}");
    assert_eq!(a["velocity"], serde_json::json!([1.0, 0.0, -1.0]), "{a}");
    assert_eq!(a["restitution"].as_f64(), Some(0.0), "{a}");

    // A refused restitution shows the API's message and changes nothing.
    b.fill("actor-restitution", "7");
    b.click("actor-apply");
    let error = b.wait_for("the error", || Some(b.text("error")).filter(|e| !e.is_empty()));
    assert!(error.contains("restitution"), "{error}");
    assert_eq!(actors(&s)[1]["restitution"].as_f64(), Some(0.0));

    // The floor, clicked off the box: its mass and velocity cannot be edited.
    b.click_at("viewport", -150, 180);
    b.wait_for("the floor selected", || (b.text("actor-name") == "floor").then_some(()));
    assert_eq!(b.property("actor-mass", "disabled"), true);
    assert_eq!(b.property("actor-velocity", "disabled"), true);
    assert_eq!(b.property("actor-friction", "disabled"), false);

    b.click("save");
    let saved = b.downloads().join("scene.ron");
    let text =
        b.wait_for("scene.ron downloaded", || std::fs::read_to_string(&saved).ok().filter(|t| t.ends_with('\n')));
    assert!(text.starts_with("// Saved by rigid studio"), "{text}");
    assert!(text.contains("mass: 2.5"), "the edit is saved: {text}");
}

/// Pixels of the joints' colour (cyan, 0x28dce6) in the viewport.
fn joint_pixels(b: &Browser) -> usize {
    viewport_pixels(b).iter().filter(|p| p[0] < 110 && p[1] > 170 && p[2] > 180).count()
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn joints_are_drawn_where_there_are_any() {
    let s = start("scenes/chain.ron");
    let b = page(&s);
    b.wait_for("the joints drawn", || {
        (b.attribute("joint-count", "data-drawn").as_deref() == Some("31")).then_some(())
    });
    assert_eq!(b.text("joint-count"), "31");
    assert!(b.is_selected("show-joints"));
    let on = joint_pixels(&b);
    b.click("show-joints");
    b.wait_for("the joints hidden", || {
        (b.attribute("joint-count", "data-drawn").as_deref() == Some("0")).then_some(())
    });
    let off = joint_pixels(&b);
    assert!(on > off + 200, "joints drawn: {on} cyan pixels with, {off} without");

    // A scene without joints draws none and leaves the box unticked.
    let s = start("scenes/box-drop.ron");
    b.open(&format!("http://{}/?adapt=0", s.addr));
    assert_eq!(b.text("joint-count"), "0");
    assert!(!b.is_selected("show-joints"));
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn contacts_are_drawn_on_demand() {
    let s = start("scenes/box-drop.ron");
    let b = page(&s);
    b.click("play");
    // The box lands after about half a second.
    b.wait_for("the box to land", || (page_time(&b).1 >= 90).then_some(()));
    b.click("pause");
    assert_eq!(b.attribute("show-contacts", "data-drawn").as_deref(), Some("0"));
    b.click("show-contacts");
    let drawn: u32 = b.wait_for("contacts drawn", || {
        b.attribute("show-contacts", "data-drawn").and_then(|d| d.parse().ok()).filter(|&d| d >= 1)
    });
    assert!(drawn >= 1);
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn the_render_scale_adapts_shows_and_turns_off() {
    // Aimed at 1 000 frames/s with the server 4 times faster than the page can draw, any machine
    // is too slow: the scale steps down and says so.
    let s = start("scenes/box-drop.ron");
    request(&s, "POST", "/api/control", br#"{"action": "speed", "speed": 4}"#);
    let b = page_with(&s, "fps=1000&play=1");
    assert!(b.is_selected("adaptive-scale"));
    // Read twice around the text, so that a step between the reads is not taken for a mismatch.
    b.wait_for("a lower render scale, shown", || {
        let (before, text, after) = (render_scale(&b), b.text("render-scale"), render_scale(&b));
        (before == after && before <= 0.7 && text == format!("render scale {before}")).then_some(())
    });
    let (buffer, shown) = canvas_widths(&b);
    assert!(buffer <= (shown * 0.85).ceil() && buffer >= (shown * 0.4).floor(), "canvas {buffer} wide shown {shown}");
    b.click("adaptive-scale");
    b.wait_for("every pixel drawn", || (render_scale(&b) == 1.0).then_some(()));
    assert_eq!(b.text("render-scale"), "", "scale 1 is not shown");
    let (buffer, shown) = canvas_widths(&b);
    assert_eq!(buffer, shown.floor(), "canvas {buffer} wide shown {shown}");
    std::thread::sleep(std::time::Duration::from_secs(3));
    assert_eq!(render_scale(&b), 1.0, "turned off, the scale stays at 1");

    // Started at half the pixels and aimed at 2 frames/s, it goes back up to every pixel.
    b.open(&format!("http://{}/?scale=0.5&fps=2", s.addr));
    assert_eq!(render_scale(&b), 0.5);
    assert_eq!(b.text("render-scale"), "render scale 0.5");
    b.wait_for("every pixel again", || (render_scale(&b) == 1.0).then_some(()));
    assert_eq!(b.text("render-scale"), "");

    // ?adapt=0 keeps the scale asked for and the box unticked.
    b.open(&format!("http://{}/?adapt=0&scale=0.6&fps=1000", s.addr));
    assert!(!b.is_selected("adaptive-scale"));
    std::thread::sleep(std::time::Duration::from_secs(3));
    assert_eq!(render_scale(&b), 0.6);
}

#[test]
#[ignore = "needs Chromium and chromedriver: .ci/run installs them and runs these"]
fn small_boxes_drawn_as_points_look_as_their_triangles_do() {
    // 4 006 boxes at half the pixels: a few pixels each, drawn as points (points.js); the same
    // state drawn as triangles (`points=0`) must give the same picture but for edge pixels.
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = dir.path().join("box-gas-4000.ron");
    std::fs::write(&scene, "Scene(gravity: (0.0, 0.0, 0.0), actors: [], spawners: [BoxGas(actors: 4000, seed: 1)])")
        .expect("write");
    let s = start(&scene.display().to_string());
    request(&s, "POST", "/api/control", br#"{"action": "step", "steps": 30}"#);
    // Once the camera has come to rest (a second in which nothing was drawn), the picture and the
    // count of points (once a second) stay as they are.
    let shot = |query: &str| {
        // Large enough that the boxes are some pixels across: at two or three pixels every pixel
        // of a box is an edge pixel, and the stretched half-size picture blurs each over several.
        let b = Browser::start(1000, 850);
        b.open(&format!("http://{}/?{query}", s.addr));
        wait_count(&b, 4006);
        b.wait_for("the camera at rest", || (b.attribute("fps", "data-drawn-fps")? == "0.0").then_some(()));
        let points = b.attribute("fps", "data-points").and_then(|p| p.parse::<u64>().ok()).expect("data-points");
        (points, viewport_pixels(&b))
    };
    let (points, with_points) = shot("adapt=0&scale=0.5");
    let (none, triangles) = shot("adapt=0&scale=0.5&points=0");
    assert!(points >= 3000, "{points} of 4 000 boxes drawn as points");
    assert_eq!(none, 0);
    assert_eq!(with_points.len(), triangles.len());
    // The bodies' pixels (saturated; the background, walls and grid are grey): points drawn too
    // large or too small would change their count.
    let coloured =
        |px: &[[u8; 3]]| px.iter().filter(|p| p.iter().max().unwrap() - p.iter().min().unwrap() > 40).count();
    let (a, b) = (coloured(&with_points), coloured(&triangles));
    // Pixels that differ: along edges only (a box is a few pixels across, and the half-size
    // picture is stretched over twice the pixels), not a face in the wrong colour or a box in
    // front of the wrong one.
    let differ = with_points.iter().zip(&triangles).filter(|(p, q)| p.iter().zip(*q).any(|(x, y)| x.abs_diff(*y) > 24));
    let differ = differ.count();
    // The mean colour: faces lit or chosen wrongly would move it.
    let mean = |px: &[[u8; 3]], k: usize| px.iter().map(|p| f64::from(p[k])).sum::<f64>() / px.len() as f64;
    println!("{points} points; {a} against {b} coloured pixels, {differ} differ");
    assert!(b > 10_000 && a.abs_diff(b) * 100 < b, "{a} coloured pixels with points, {b} without");
    assert!(differ * 4 < b, "{differ} pixels differ, of {b} coloured");
    for k in 0..3 {
        let (m, n) = (mean(&with_points, k), mean(&triangles, k));
        assert!((m - n).abs() < 0.5, "channel {k}: mean {m} with points, {n} without");
    }
}
