//! `rigid render` and `rigid export` from a newcomer's side (issue "A newcomer's first hour"):
//! output paths judged before simulating, stale frames removed, contacts between frames drawn,
//! the camera fitted to what moves, and `--quiet`.

mod common;
use common::*;
use rigid_sandbox::io::render::{Camera, Overlay, actor_colour, render, step_contacts};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `rigid` with `args`; panics if it is still running after `limit` (it is killed).
fn rigid_within(args: &[&str], limit: Duration) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_rigid"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starts");
    let start = Instant::now();
    while child.try_wait().expect("waits").is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("rigid {args:?} still running after {limit:?}: it is simulating before judging its output");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().expect("output")
}

/// Runs `rigid` with `args` and asserts it succeeded.
fn rigid_ok(args: &[&str]) -> Output {
    let o = rigid_within(args, Duration::from_secs(120));
    assert!(o.status.success(), "rigid {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    o
}

fn text(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The frame files in `dir`, sorted.
fn frames_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("folder")
        .map(|e| e.expect("entry").file_name().into_string().expect("utf-8"))
        .filter(|n| n.starts_with("frame-"))
        .collect();
    names.sort();
    names
}

// Every step the scene limit allows: a command that simulated before failing would run for
// far longer than the time allowed.
const ALL_STEPS: &str = "100000000";
const QUICK: Duration = Duration::from_secs(30);

#[test]
fn a_gif_in_a_missing_folder_is_refused_before_simulating() {
    let dir = tempfile::tempdir().expect("temp dir");
    let frames = dir.path().join("frames");
    let gif = dir.path().join("no-such-folder").join("run.gif");
    let scene = scene_path("box-drop.ron");
    let o = rigid_within(
        &["render", text(&scene), "--steps", ALL_STEPS, "--size", "64x48", "-o", text(&frames), "--gif", text(&gif)],
        QUICK,
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("--gif") && err.contains(text(&gif)), "names the flag and the path: {err}");
    assert!(!frames.exists(), "nothing was rendered, not even the frames folder made");
}

#[test]
fn a_glb_in_a_missing_folder_is_refused_before_simulating() {
    let dir = tempfile::tempdir().expect("temp dir");
    let glb = dir.path().join("no-such-folder").join("run.glb");
    let scene = scene_path("box-drop.ron");
    let o = rigid_within(&["export", text(&scene), "--steps", ALL_STEPS, "--glb", text(&glb)], QUICK);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("--glb") && err.contains(text(&glb)), "names the flag and the path: {err}");
    assert!(!glb.exists());
    // A folder given as the file: also refused at once.
    let o = rigid_within(&["export", text(&scene), "--steps", ALL_STEPS, "--glb", text(dir.path())], QUICK);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn an_out_that_is_a_file_is_refused_before_simulating() {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("frames");
    std::fs::write(&file, "not a folder").expect("write");
    let scene = scene_path("box-drop.ron");
    let o = rigid_within(&["render", text(&scene), "--steps", ALL_STEPS, "--size", "64x48", "-o", text(&file)], QUICK);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("--out") && err.contains(text(&file)), "names the flag and the path: {err}");
    assert_eq!(std::fs::read_to_string(&file).expect("kept"), "not a folder");
}

#[test]
fn a_gif_inside_a_new_frames_folder_is_fine() {
    let dir = tempfile::tempdir().expect("temp dir");
    let frames = dir.path().join("a").join("frames");
    let gif = frames.join("run.gif");
    let scene = scene_path("newtons-cradle.ron");
    rigid_ok(
        &["render", text(&scene), "--steps", "4", "--every", "2", "--size", "64x48"]
            .into_iter()
            .chain(["-o", text(&frames), "--gif", text(&gif)])
            .collect::<Vec<_>>(),
    );
    assert_eq!(frames_in(&frames), ["frame-00000.png", "frame-00001.png", "frame-00002.png"]);
    assert_eq!(&std::fs::read(&gif).expect("gif written")[..6], b"GIF89a");
}

#[test]
fn a_second_render_into_the_same_folder_leaves_only_its_own_frames() {
    let dir = tempfile::tempdir().expect("temp dir");
    let frames = dir.path().join("frames");
    let scene = scene_path("newtons-cradle.ron");
    let render = |steps: &str, size: &str| {
        rigid_ok(&["render", text(&scene), "--steps", steps, "--every", "2", "--size", size, "-o", text(&frames)])
    };
    let first = render("20", "80x60");
    assert!(!stderr(&first).contains("note: removed"), "nothing to remove the first time: {}", stderr(&first));
    assert_eq!(frames_in(&frames).len(), 11, "steps 0, 2, ..., 20");
    // Files that are not this command's frames stay, however close their names.
    let keep = ["notes.txt", "frame-1.png", "frame-000001.png", "frame-00001.png.bak", "my-frame-00001.png"];
    for name in keep {
        std::fs::write(frames.join(name), name).expect("write");
    }
    let second = render("4", "64x48");
    let err = stderr(&second);
    let note = format!("note: removed 11 frames of an earlier render from {}", frames.display());
    assert!(err.contains(&note), "says what it removed: {err}");
    let mut left: Vec<String> = std::fs::read_dir(&frames)
        .expect("folder")
        .map(|e| e.expect("entry").file_name().into_string().expect("utf-8"))
        .collect();
    left.sort();
    let mut want: Vec<String> =
        ["frame-00000.png", "frame-00001.png", "frame-00002.png"].into_iter().chain(keep).map(String::from).collect();
    want.sort();
    assert_eq!(left, want);
    for name in keep {
        assert_eq!(std::fs::read_to_string(frames.join(name)).expect("kept"), name);
    }
    for k in 0..3 {
        let img = image::open(frames.join(format!("frame-{k:05}.png"))).expect("a PNG frame");
        assert_eq!((img.width(), img.height()), (64, 48), "every frame is the second run's");
    }
}

/// Pixels exactly the colours of the contact overlay: (points yellow, normals red).
fn overlay_pixels(img: &image::RgbImage) -> (usize, usize) {
    let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count();
    (count([250, 200, 0]), count([220, 30, 30]))
}

#[test]
fn contacts_between_frames_are_drawn_on_the_next_frame() {
    // face-collision: the cubes meet at step 10 and part at once. With a frame every 7 steps
    // (steps 0, 7, 14) the impact falls between frames 1 and 2, and step 14 itself has no
    // contact, so drawing only the frame's own step showed nothing.
    let mut sim = sim_of("face-collision.ron", |_| {});
    let mut touched = Vec::new();
    for _ in 0..14 {
        sim.step().expect("finite");
        if step_contacts(&sim).next().is_some() {
            touched.push(sim.steps);
        }
    }
    assert!(!touched.is_empty() && touched.iter().all(|s| (8..14).contains(s)), "contacts at steps {touched:?}");
    let camera = Camera::fit(&sim);
    let own_step = render(&sim, &camera, 128, 96, Overlay { contacts: true, ..Overlay::default() });
    assert_eq!(overlay_pixels(&own_step), (0, 0), "the frame's own step draws no contact");

    let dir = tempfile::tempdir().expect("temp dir");
    let scene = scene_path("face-collision.ron");
    let run = |name: &str, contacts: bool| {
        let out = dir.path().join(name);
        let mut args = vec!["render", text(&scene), "--steps", "14", "--every", "7", "--size", "128x96"];
        args.extend(["-o", text(&out)]);
        if contacts {
            args.push("--contacts");
        }
        rigid_ok(&args);
        (0..3)
            .map(|k| image::open(out.join(format!("frame-{k:05}.png"))).expect("a PNG frame").into_rgb8())
            .collect::<Vec<_>>()
    };
    let plain = run("plain", false);
    let overlaid = run("contacts", true);
    for k in 0..2 {
        assert_eq!(plain[k], overlaid[k], "frame {k}: no contact yet, so the same picture");
    }
    assert_eq!(overlay_pixels(&plain[2]), (0, 0));
    let (points, normals) = overlay_pixels(&overlaid[2]);
    assert!(
        points >= 2 && normals >= 2,
        "the impact of step 10 is drawn on the frame of step 14: {points} yellow and {normals} red pixels"
    );
    let drawn = points + normals;
    let differ = plain[2].pixels().zip(overlaid[2].pixels()).filter(|(a, b)| a != b).count();
    assert_eq!(differ, drawn, "only the overlay differs");
}

/// Pixels in a shade of actor `index`'s colour (flat shading scales it by 0.35 to 1).
fn actor_pixels(img: &image::RgbImage, index: usize) -> Vec<(u32, u32)> {
    let base = actor_colour(index, false).map(f64::from);
    let top = (0..3).max_by(|&a, &b| base[a].total_cmp(&base[b])).expect("three channels");
    img.enumerate_pixels()
        .filter(|(_, _, p)| {
            let shade = (f64::from(p.0[top]) + 0.5) / base[top];
            (0.34..=1.01).contains(&shade)
                && (0..3).all(|c| (f64::from(p.0[c]) - (base[c] * shade).floor()).abs() <= 1.5)
        })
        .map(|(x, y, _)| (x, y))
        .collect()
}

/// A 0.5 m cube resting on a fixed 20 m floor.
const CUBE_ON_FLOOR: &str = "Scene(
    dt: 0.01,
    steps: 1,
    actors: [
        Actor(name: \"floor\", shape: Box(size: (20.0, 1.0, 20.0)), position: (0.0, -0.5, 0.0), fixed: true),
        Actor(name: \"cube\", shape: Box(size: (0.5, 0.5, 0.5)), mass: 1.0, position: (0.0, 0.25, 0.0)),
    ],
)";

#[test]
fn the_fitted_camera_frames_the_cube_not_the_floor() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = dir.path().join("cube.ron");
    std::fs::write(&scene, CUBE_ON_FLOOR).expect("write scene");
    let (w, h) = (64, 48);
    let frame = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec!["render", text(&scene), "--steps", "0", "--size", "64x48", "-o", text(&out)];
        args.extend(extra);
        rigid_ok(&args);
        image::open(out.join("frame-00000.png")).expect("a PNG frame").into_rgb8()
    };
    let fitted = frame("fitted", &[]);
    let cube = actor_pixels(&fitted, 1);
    // Framing the whole floor (the old fit) put the cube about 40 m away: a pixel or two.
    assert!(cube.len() > (w * h / 10) as usize, "the cube covers {} of {} pixels", cube.len(), w * h);
    assert!(
        cube.iter().all(|&(x, y)| x > 0 && y > 0 && x < w - 1 && y < h - 1),
        "the whole cube is in the picture, not cut by its edges"
    );
    let (cx, cy) = cube.iter().fold((0, 0), |(sx, sy), &(x, y)| (sx + x, sy + y));
    let (cx, cy) = (cx / cube.len() as u32, cy / cube.len() as u32);
    assert!(cx.abs_diff(w / 2) < w / 5 && cy.abs_diff(h / 2) < h / 4, "near the centre: ({cx}, {cy})");

    // The same scene as the fit saw it, through the library.
    let sim = sim_from_text(CUBE_ON_FLOOR);
    let camera = Camera::fit(&sim);
    assert_eq!(render(&sim, &camera, w, h, Overlay::default()), fitted, "the CLI uses Camera::fit");
    assert!((camera.target - rigid_sandbox::math::Vector::new(0.0, 0.25, 0.0)).length() < 1e-9, "aimed at the cube");

    // An explicit camera still wins over the fit: from 50 m the cube is a few pixels.
    let far = frame("far", &["--eye", "0,30,40", "--target", "0,0,0"]);
    assert!(actor_pixels(&far, 1).len() < 20, "--eye/--target override the fit");
    // So does the scene's own camera.
    let with_camera = CUBE_ON_FLOOR.replacen(
        "dt: 0.01,",
        "dt: 0.01, camera: Camera(eye: (0.0, 30.0, 40.0), target: (0.0, 0.0, 0.0)),",
        1,
    );
    std::fs::write(&scene, with_camera).expect("write scene");
    assert_eq!(frame("scene-camera", &[]), far, "the scene's camera overrides the fit");
}

#[test]
fn a_fitted_camera_sees_where_a_dropped_body_lands() {
    // box-drop: the box starts 1.5 m above the floor; the fit covers it there and on the floor.
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = scene_path("box-drop.ron");
    let out = dir.path().join("frames");
    rigid_ok(&["render", text(&scene), "--steps", "120", "--every", "120", "--size", "64x48", "-o", text(&out)]);
    for k in 0..2 {
        let img = image::open(out.join(format!("frame-{k:05}.png"))).expect("a PNG frame").into_rgb8();
        let cube = actor_pixels(&img, 1);
        assert!(cube.len() > 150, "frame {k}: the box covers {} pixels", cube.len());
        assert!(cube.iter().all(|&(x, y)| x > 0 && y > 0 && x < 63 && y < 47), "frame {k}: the whole box is in view");
    }
}

#[test]
fn quiet_prints_nothing_on_stdout() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = scene_path("newtons-cradle.ron");
    for (k, flag) in ["", "-q", "--quiet"].into_iter().enumerate() {
        let frames = dir.path().join(format!("frames-{k}"));
        let glb = dir.path().join(format!("run-{k}.glb"));
        let render = ["render", text(&scene), "--steps", "4", "--size", "64x48", "-o", text(&frames)];
        let export = ["export", text(&scene), "--steps", "4", "--glb", text(&glb)];
        for args in [&render[..], &export[..]] {
            let args: Vec<&str> = args.iter().copied().chain(Some(flag).filter(|f| !f.is_empty())).collect();
            let o = rigid_ok(&args);
            let stdout = String::from_utf8_lossy(&o.stdout);
            if flag.is_empty() {
                assert!(stdout.starts_with("wrote "), "{args:?} says what it wrote: {stdout}");
            } else {
                assert!(stdout.is_empty(), "{args:?}: {stdout}");
                assert!(o.stderr.is_empty(), "{args:?}: {}", stderr(&o));
            }
        }
        assert_eq!(frames_in(&frames).len(), 2, "steps 0 and 4, written however quiet");
        assert!(glb.exists());
    }
}

#[test]
fn joints_are_drawn_where_there_are_any() {
    // The joints' anchors are drawn in one colour no shaded body takes, at the anchor.
    let marks = |scene: &str| {
        let mut sim = sim_of(scene, |_| {});
        sim.run(2).expect("finite");
        let camera = Camera::fit(&sim);
        let image = render(&sim, &camera, 320, 240, Overlay { contacts: false, solid_fixed: false });
        let pixels: Vec<(u32, u32)> =
            image.enumerate_pixels().filter(|(_, _, p)| p.0 == [40, 220, 230]).map(|(x, y, _)| (x, y)).collect();
        (pixels, camera)
    };
    let (pixels, camera) = marks("pendulum.ron");
    assert!(pixels.len() > 10, "a pendulum's pivot is marked: {} pixels", pixels.len());
    let (px, py, _) = camera.project(rigid_sandbox::math::Vector::new(0.0, 2.0, 0.0), 320, 240).expect("in view");
    let near = |&(x, y): &(u32, u32)| (f64::from(x) - px).abs() < 12.0 && (f64::from(y) - py).abs() < 12.0;
    assert!(pixels.iter().all(near), "the marks are at the pivot ({px}, {py})");
    assert!(marks("box-drop.ron").0.is_empty(), "no joints, no marks");
}
