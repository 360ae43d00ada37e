//! `rigid render` and `rigid export` (issue #6): image size and content with the camera math
//! checked at a pixel; the .glb read back with the `gltf` crate, its animation ending on the
//! simulated final poses.

mod common;
use common::*;
use rigid_sandbox::io::render::{Camera, Overlay, actor_colour, render};
use rigid_sandbox::math::Vector;
use std::process::Command;

#[test]
fn an_actor_is_drawn_in_its_colour_where_the_camera_projects_its_centre() {
    // One unit cube at (1, 2, 3), looked at straight along −z from 5 m away: its +z face fills
    // the middle of the picture, lit by (0.4, 1, 0.6)/|·| at cos = 0.6/√1.52.
    let sim = sim_from_text("Scene(actors: [Actor(shape: Box(size: (1.0, 1.0, 1.0)), position: (1.0, 2.0, 3.0))])");
    let camera =
        Camera { eye: Vector::new(1.0, 2.0, 8.5), target: Vector::new(1.0, 2.0, 3.0), fov_y: 40f64.to_radians() };
    let (w, h) = (64, 48);
    let (x, y, depth) = camera.project(Vector::new(1.0, 2.0, 3.5), w, h).expect("in front");
    assert_eq!((x, y, depth), (32.0, 24.0, 5.0), "the target projects to the image centre");
    let image = render(&sim, &camera, w, h, Overlay::default());
    assert_eq!(image.dimensions(), (w, h));
    let shade = 0.35 + 0.65 * (0.6 / 1.52f64.sqrt());
    let want = actor_colour(0, false).map(|c| (f64::from(c) * shade) as u8);
    assert_eq!(image.get_pixel(32, 24).0, want);
    // The corner is sky, and the picture is not one flat colour.
    assert_ne!(image.get_pixel(0, 0).0, want);
    let first = image.get_pixel(0, 0);
    assert!(image.pixels().any(|p| p != first));
}

#[test]
fn render_writes_numbered_frames_and_a_gif() {
    let dir = tempfile::tempdir().expect("temp dir");
    let frames = dir.path().join("frames");
    let gif = dir.path().join("run.gif");
    let scene = scene_path("newtons-cradle.ron");
    let o = Command::new(env!("CARGO_BIN_EXE_rigid"))
        .args(["render", scene.to_str().expect("utf-8"), "--steps", "20", "--every", "10", "--size", "80x60"])
        .args(["--out", frames.to_str().expect("utf-8"), "--gif", gif.to_str().expect("utf-8"), "--contacts"])
        .output()
        .expect("runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for k in 0..3 {
        let img = image::open(frames.join(format!("frame-{k:05}.png"))).expect("a PNG frame");
        assert_eq!((img.width(), img.height()), (80, 60));
    }
    assert!(!frames.join("frame-00003.png").exists(), "steps 0, 10, 20 only");
    let bytes = std::fs::read(&gif).expect("gif written");
    assert_eq!(&bytes[..6], b"GIF89a");
}

#[test]
fn export_reads_back_with_one_node_per_actor_and_the_final_poses() {
    let dir = tempfile::tempdir().expect("temp dir");
    let glb = dir.path().join("run.glb");
    let out = dir.path().join("state.json");
    let scene = scene_path("rod-off-centre.ron");
    let scene = scene.to_str().expect("utf-8");
    let rigid = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("runs");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    rigid(&["export", scene, "--steps", "50", "--every", "7", "--glb", glb.to_str().expect("utf-8")]);
    rigid(&["run", scene, "--steps", "50", "--quiet", "--out", out.to_str().expect("utf-8")]);
    let gltf = gltf::Gltf::from_slice(&std::fs::read(&glb).expect("written")).expect("a valid glb");
    let blob = gltf.blob.clone().expect("binary chunk");
    assert_eq!(gltf.nodes().count(), 2);
    assert_eq!(gltf.meshes().count(), 2, "rod and cube are distinct shapes");
    let names: Vec<_> = gltf.nodes().map(|n| n.name().unwrap_or("").to_string()).collect();
    assert_eq!(names, ["rod", "cube"]);
    let state: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).expect("json")).expect("json");
    let animation = gltf.animations().next().expect("an animation");
    for channel in animation.channels() {
        let node = channel.target().node().index();
        let reader = channel.reader(|_| Some(&blob));
        let times: Vec<f32> = reader.read_inputs().expect("times").collect();
        // Steps 0, 7, ..., 49 and the last one, 50.
        assert_eq!(times.len(), 9);
        assert_eq!(times[1], 0.07_f32);
        assert_eq!(*times.last().expect("keyframes"), 0.5_f32);
        let actor = &state["actors"][node];
        let f32s = |field: &str| {
            actor[field]
                .as_array()
                .expect("array")
                .iter()
                .map(|v| v.as_f64().expect("number") as f32)
                .collect::<Vec<_>>()
        };
        match reader.read_outputs().expect("outputs") {
            gltf::animation::util::ReadOutputs::Translations(t) => {
                assert_eq!(t.last().expect("last").to_vec(), f32s("position"))
            }
            gltf::animation::util::ReadOutputs::Rotations(r) => {
                assert_eq!(r.into_f32().last().expect("last").to_vec(), f32s("orientation"))
            }
            _ => panic!("only translation and rotation channels"),
        }
    }
    assert_eq!(animation.channels().count(), 4, "two channels per moving actor");
}
