//! A measurement, not a check (no timed tests in this project): `rigid studio` with 4 000
//! bodies, what a frame costs the server and what the page achieves in headless Chromium, in
//! real time. Prints; asserts only that there was something to measure. Run on demand:
//! `cargo test --release --test studio_fps -- --ignored --nocapture` (BENCH.md, "Studio at
//! 4 000 bodies"). `CHROMIUM` names another browser binary; `STUDIO_FPS_SCENE` another scene.

mod common;
use common::studio::{CHROMIUM_FLAGS, Studio, get, request, start};
use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BOX_GAS_4000: &str = "Scene(dt: 0.016666666666666666, gravity: (0.0, 0.0, 0.0), actors: [],
      spawners: [BoxGas(actors: 4000, seed: 1)])";

/// `GET /api/frame` `n` times in a row: the mean time a frame [ms] and its size [bytes].
fn frames(s: &Studio, n: u32) -> (f64, usize) {
    let start = Instant::now();
    let mut bytes = 0;
    for _ in 0..n {
        let (status, body) = request(s, "GET", "/api/frame", b"");
        assert_eq!(status, 200);
        bytes = body.len();
    }
    (start.elapsed().as_secs_f64() * 1e3 / f64::from(n), bytes)
}

/// The two ways to reach SwiftShader compared in one run: the GL flag the browser tests use, and
/// ANGLE's SwiftShader Vulkan backend named directly.
const GL_PATHS: [(&str, &str); 2] = [("--use-gl=swiftshader", "use-gl"), ("--use-angle=swiftshader", "use-angle")];

/// Runs headless Chromium on `url` for `seconds` of real time with SwiftShader reached by
/// `gl_flag` and returns the page's `studio-fps` console lines (`?log=1`).
fn page_fps(url: &str, seconds: u32, gl_flag: &str) -> Vec<String> {
    let profile = tempfile::tempdir().expect("temp dir");
    let binary = std::env::var("CHROMIUM").unwrap_or_else(|_| "chromium".to_string());
    let mut child = Command::new("timeout")
        .arg(seconds.to_string())
        .arg(binary)
        .args(CHROMIUM_FLAGS.iter().filter(|f| !f.starts_with("--use-gl=")))
        .arg(gl_flag)
        .args(["--window-size=1000,700", "--enable-logging=stderr", "--v=0"])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg(url)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("chromium runs (apt-get install chromium)");
    let lines = BufReader::new(child.stderr.take().expect("stderr")).lines();
    let found = lines
        .map_while(Result::ok)
        .filter_map(|l| {
            l.find("studio-fps ").map(|at| l[at..].trim_end_matches(|c| c != '"').trim_end_matches('"').to_string())
        })
        .collect();
    let _ = child.wait();
    found
}

/// The number after `key=` in a `studio-fps` line.
fn field(line: &str, key: &str) -> f64 {
    line.split_whitespace().find_map(|w| w.strip_prefix(key)?.strip_prefix('=')?.parse().ok()).unwrap_or(f64::NAN)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

#[test]
#[ignore = "a measurement that prints: cargo test --release --test studio_fps -- --ignored --nocapture"]
fn studio_at_4000_bodies() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = std::env::var("STUDIO_FPS_SCENE").unwrap_or_else(|_| {
        let path = dir.path().join("box-gas-4000.ron");
        std::fs::write(&path, BOX_GAS_4000).expect("write");
        path.display().to_string()
    });
    let s = start(&scene);
    let bodies = get(&s, "/api/state?actors=0")["actor_count"].as_u64().expect("actor_count");
    let (paused_ms, bytes) = frames(&s, 200);
    println!("{bodies} bodies: /api/frame {bytes} bytes, {paused_ms:.3} ms a request paused (200 in a row)");
    let (_, step) = request(&s, "POST", "/api/control", br#"{"action": "step", "steps": 60}"#);
    assert!(!step.is_empty());
    let st = get(&s, "/api/state?actors=0");
    println!("a step: {:.2} ms (the last of 60 stepped at once)", st["step_ms"].as_f64().unwrap_or(f64::NAN));

    request(&s, "POST", "/api/control", br#"{"action": "play"}"#);
    std::thread::sleep(Duration::from_secs(2));
    let (playing_ms, _) = frames(&s, 200);
    let sps = get(&s, "/api/state?actors=0")["steps_per_second"].as_f64().unwrap_or(f64::NAN);
    println!("playing at 1x: {playing_ms:.3} ms a request, {sps:.1} steps/s (real time: 60)");

    // Each way to SwiftShader with the adaptive render scale (the page's default), then the first
    // once more with every pixel drawn (`?adapt=0`).
    let runs =
        GL_PATHS.iter().map(|&(flag, label)| (flag, label, "")).chain([(GL_PATHS[0].0, "use-gl, scale 1", "&adapt=0")]);
    for (flag, label, query) in runs {
        let lines = page_fps(&format!("http://{}/?log=1{query}", s.addr), 30, flag);
        for l in &lines {
            println!("  {label}: {l}");
        }
        let sps = get(&s, "/api/state?actors=0")["steps_per_second"].as_f64().unwrap_or(f64::NAN);
        // The first seconds load the page and the meshes.
        let settled: Vec<&String> = lines.iter().skip(3).collect();
        assert!(!settled.is_empty(), "the page reported no frame rate with {flag}: {lines:?}");
        let drawn = median(settled.iter().map(|l| field(l, "drawn")).collect());
        let fetched = median(settled.iter().map(|l| field(l, "frames")).collect());
        let scales: Vec<f64> = settled.iter().map(|l| field(l, "scale")).collect();
        let last = scales.last().copied().unwrap_or(f64::NAN);
        // Once the adaptive scale has found its level: the seconds after its last change, less
        // the second the change fell in.
        let since = scales.iter().rposition(|&x| x != last).map_or(0, |i| i + 2);
        let steady: Vec<f64> = settled.iter().skip(since).map(|l| field(l, "drawn")).collect();
        let steady_seconds = steady.len();
        println!(
            "page, headless Chromium ({flag}{query} --enable-unsafe-swiftshader, 1000x700), playing: median \
             {drawn:.1} frames drawn/s, {fetched:.1} new states/s, render scale {:.2} (median; {last} at the end); \
             at scale {last} after its last change: median {:.1} frames drawn/s over {steady_seconds} s; \
             server meanwhile {sps:.1} steps/s",
            median(scales.clone()),
            median(steady)
        );
    }
}
