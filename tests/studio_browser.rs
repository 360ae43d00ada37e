//! `rigid studio`'s page in a real browser: Debian's `chromium`, headless, from the command line
//! (no driver). The page reads URL parameters (`?play=1`, `?script=...`, docs/studio.md) to
//! act without clicks; `--dump-dom` shows the result and `--screenshot` what was drawn.
//! Needs Chromium (`CHROMIUM` names another binary): `.ci/run` installs it and runs
//! `cargo test --test studio_browser -- --ignored`.

mod common;
use common::studio::{CHROMIUM_FLAGS, PAGE_TEST_IDS, Studio, get, start};
use serde_json::Value;
use std::process::{Command, Stdio};

fn state(studio: &Studio) -> Value {
    get(studio, "/api/state")
}

/// Percent-encodes a URL query value.
fn encode(text: &str) -> String {
    text.bytes()
        .map(|b| {
            if b.is_ascii_alphanumeric() || b"-_.~".contains(&b) {
                (b as char).to_string()
            } else {
                format!("%{b:02X}")
            }
        })
        .collect()
}

/// Runs headless Chromium on `url` with `mode` (`--dump-dom` or `--screenshot=FILE`) after
/// `budget_ms` of virtual time; returns stdout.
fn chromium(url: &str, mode: &str, budget_ms: u32) -> String {
    let profile = tempfile::tempdir().expect("temp dir");
    let binary = std::env::var("CHROMIUM").unwrap_or_else(|_| "chromium".to_string());
    let out = Command::new("timeout")
        .arg("90")
        .arg(binary)
        .args(CHROMIUM_FLAGS)
        .args(["--window-size=800,600"])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg(format!("--virtual-time-budget={budget_ms}"))
        .arg(mode)
        .arg(url)
        .stderr(Stdio::null())
        .output()
        .expect("chromium runs (apt-get install chromium)");
    assert!(out.status.success(), "chromium failed: {:?}", out.status);
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The text of the element with `data-testid="id"` in a dumped DOM, and its opening tag.
fn element<'a>(dom: &'a str, id: &str) -> (&'a str, &'a str) {
    let marker = format!("data-testid=\"{id}\"");
    let at = dom.find(&marker).unwrap_or_else(|| panic!("no {id} in the page"));
    let open = dom[..at].rfind('<').expect("tag start");
    let end = at + dom[at..].find('>').expect("tag end");
    let text_end = end + dom[end..].find('<').unwrap_or(dom.len() - end);
    (&dom[open..=end], &dom[end + 1..text_end])
}

fn attribute(tag: &str, name: &str) -> Option<String> {
    let at = tag.find(&format!(" {name}=\""))? + name.len() + 3;
    Some(tag[at..at + tag[at..].find('"')?].to_string())
}

#[test]
#[ignore = "needs Chromium: .ci/run installs it and runs these"]
fn the_page_has_every_control_and_time_advances() {
    let s = start("scenes/box-drop.ron");
    let dom = chromium(&format!("http://{}/?play=1", s.addr), "--dump-dom", 3000);
    for id in PAGE_TEST_IDS.iter().chain(&["system-gravity", "system-integrate"]) {
        element(&dom, id);
    }
    let (tag, text) = element(&dom, "time");
    let time: f64 = attribute(tag, "data-time").and_then(|t| t.parse().ok()).expect("data-time");
    assert!(time > 0.0, "time does not advance: {tag}{text}");
    assert!(text.ends_with(')') && text.contains(" s (step "), "{text}");
    assert_eq!(element(&dom, "actor-count").1, "2");
    assert!(element(&dom, "timings").1.contains("integrate"), "{}", element(&dom, "timings").1);
    assert_eq!(element(&dom, "error").1, "", "the page shows an error");
    assert_eq!(state(&s)["running"], true);
}

#[test]
#[ignore = "needs Chromium: .ci/run installs it and runs these"]
fn the_viewport_draws_the_scene() {
    let s = start("scenes/mixed-shapes.ron");
    let dir = tempfile::tempdir().expect("temp dir");
    let png = dir.path().join("shot.png");
    chromium(&format!("http://{}/?play=1", s.addr), &format!("--screenshot={}", png.display()), 3000);
    let image = image::open(&png).expect("a PNG").to_rgb8();
    assert_eq!(image.dimensions(), (800, 600));
    // The viewport is right of the 270-pixel side panel.
    let mut colours = std::collections::HashSet::new();
    let mut saturated = 0;
    for (_, _, p) in image.enumerate_pixels().filter(|(x, _, _)| *x >= 280) {
        colours.insert(p.0);
        let [r, g, b] = p.0.map(i32::from);
        if r.max(g).max(b) - r.min(g).min(b) > 60 {
            saturated += 1;
        }
    }
    assert!(colours.len() > 50, "viewport looks blank: {} colours", colours.len());
    // The actors are coloured; the background, grid and panel are grey.
    assert!(saturated > 500, "no coloured bodies drawn ({saturated} coloured pixels)");
}

#[test]
#[ignore = "needs Chromium: .ci/run installs it and runs these"]
fn scripted_actions_reach_the_api_and_errors_show() {
    let s = start("scenes/box-drop.ron");
    let script = "add-box,add-sphere,add-cylinder,untick:gravity,step:5";
    let dom = chromium(&format!("http://{}/?script={}", s.addr, encode(script)), "--dump-dom", 4000);
    let st = state(&s);
    assert_eq!(st["actors"].as_array().expect("actors").len(), 5, "{st}");
    assert!(!st["schedule"].as_array().expect("schedule").iter().any(|n| n == "gravity"), "{st}");
    assert_eq!(st["step"], 5);
    assert_eq!(element(&dom, "actor-count").1, "5");
    let (tag, _) = element(&dom, "system-gravity");
    assert!(!tag.contains("checked"), "{tag}");
    assert!(element(&dom, "system-integrate").0.contains("checked"));

    // A bad scene: the page's error element shows the API's message with line:col.
    let script = "scene:Scene(actors: [Actor(shape: Sphere)])";
    let dom = chromium(&format!("http://{}/?script={}", s.addr, encode(script)), "--dump-dom", 3000);
    let (_, error) = element(&dom, "error");
    assert!(error.starts_with("&lt;studio&gt;:1:") || error.starts_with("<studio>:1:"), "{error}");
    assert_eq!(state(&s)["actors"].as_array().expect("actors").len(), 5);
}

#[test]
#[ignore = "needs Chromium: .ci/run installs it and runs these"]
fn a_clicked_actor_is_selected_and_edited() {
    let s = start("scenes/box-drop.ron");
    // The camera frames the free box: a click at the viewport's centre picks it.
    let script = "click:0.5/0.5,edit:mass=2.5,edit:friction=0.3,edit:velocity=1 0 -1,edit:restitution=7";
    let dom = chromium(&format!("http://{}/?script={}", s.addr, encode(script)), "--dump-dom", 4000);
    assert_eq!(element(&dom, "actor-name").1, "box");
    let st = state(&s);
    let b = &st["actors"][1];
    assert_eq!(b["name"], "box");
    assert_eq!(b["mass"].as_f64(), Some(2.5), "{b}");
    assert_eq!(b["friction"].as_f64(), Some(0.3), "{b}");
    assert_eq!(b["velocity"], serde_json::json!([1.0, 0.0, -1.0]), "{b}");
    // The refused restitution leaves the old one and shows the API's message.
    assert_eq!(b["restitution"].as_f64(), Some(0.0), "{b}");
    assert!(element(&dom, "error").1.contains("restitution"), "{}", element(&dom, "error").1);
    assert_eq!(attribute(element(&dom, "actor-mass").0, "value").as_deref(), Some("2.5"));
    for id in ["actor-restitution", "actor-friction", "actor-velocity", "actor-apply", "save"] {
        element(&dom, id);
    }

    // Selecting by name; a fixed actor's mass and velocity cannot be edited.
    let script = "select:floor,save";
    let dom = chromium(&format!("http://{}/?script={}", s.addr, encode(script)), "--dump-dom", 3000);
    assert_eq!(element(&dom, "actor-name").1, "floor");
    assert!(element(&dom, "actor-mass").0.contains("disabled"), "{}", element(&dom, "actor-mass").0);
    assert!(!element(&dom, "actor-friction").0.contains("disabled"), "{}", element(&dom, "actor-friction").0);
    assert!(dom.contains("data-saved=\"// Saved by rigid studio"), "the page did not fetch the saved scene");
}

/// Pixels of the joints' colour (cyan, 0x28dce6) right of the side panel in a screenshot.
fn joint_pixels(url: &str) -> usize {
    let dir = tempfile::tempdir().expect("temp dir");
    let png = dir.path().join("shot.png");
    chromium(url, &format!("--screenshot={}", png.display()), 3000);
    let image = image::open(&png).expect("a PNG").to_rgb8();
    image.enumerate_pixels().filter(|(x, _, p)| *x >= 280 && p.0[0] < 110 && p.0[1] > 170 && p.0[2] > 180).count()
}

#[test]
#[ignore = "needs Chromium: .ci/run installs it and runs these"]
fn joints_are_drawn_where_there_are_any() {
    let s = start("scenes/chain.ron");
    let dom = chromium(&format!("http://{}/", s.addr), "--dump-dom", 3000);
    let (tag, text) = element(&dom, "joint-count");
    assert_eq!(text, "31");
    assert_eq!(attribute(tag, "data-drawn").as_deref(), Some("31"), "{tag}");
    assert!(element(&dom, "show-joints").0.contains("checked"), "{}", element(&dom, "show-joints").0);
    // Drawn: the joints' colour is on screen, and goes when they are turned off.
    let on = joint_pixels(&format!("http://{}/", s.addr));
    let off = joint_pixels(&format!("http://{}/?script=joints:off", s.addr));
    assert!(on > off + 200, "joints drawn: {on} cyan pixels with, {off} without");
    let dom = chromium(&format!("http://{}/?script=joints:off", s.addr), "--dump-dom", 3000);
    assert_eq!(attribute(element(&dom, "joint-count").0, "data-drawn").as_deref(), Some("0"));

    // A scene without joints draws none and leaves the box unticked.
    let s = start("scenes/box-drop.ron");
    let dom = chromium(&format!("http://{}/", s.addr), "--dump-dom", 3000);
    assert_eq!(element(&dom, "joint-count").1, "0");
    assert!(!element(&dom, "show-joints").0.contains("checked"), "{}", element(&dom, "show-joints").0);
}

#[test]
#[ignore = "needs Chromium: .ci/run installs it and runs these"]
fn contacts_are_drawn_on_demand() {
    let s = start("scenes/box-drop.ron");
    let dom = chromium(&format!("http://{}/?script=step:120", s.addr), "--dump-dom", 3000);
    assert_eq!(attribute(element(&dom, "show-contacts").0, "data-drawn").as_deref(), Some("0"));
    let dom = chromium(&format!("http://{}/?script=contacts:on", s.addr), "--dump-dom", 3000);
    let drawn: u32 =
        attribute(element(&dom, "show-contacts").0, "data-drawn").and_then(|d| d.parse().ok()).expect("data-drawn");
    assert!(drawn >= 1, "{}", element(&dom, "show-contacts").0);
}
