//! `Obj(path: .., hull: true)`: the convex hull of an OBJ file's points (docs/scenes.md).
//! Interior, repeated and coplanar points are dropped, the hull's coplanar triangles merge into
//! one face, a non-convex OBJ without `hull: true` is refused with a hint, and flat or too few
//! points are bad input naming the file (exit 2).

use rigid_sandbox::math::Vector;
use rigid_sandbox::rng::SplitMix64;
use rigid_sandbox::scene;
use rigid_sandbox::{ActorIndex, ConvexMesh, MassProps, Mesh, Sim};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn rigid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("the binary runs")
}

/// An OBJ of `v` lines only; `{:?}` prints each f64 so that it reads back to the same bits.
fn point_cloud(points: &[[f64; 3]]) -> String {
    points.iter().fold(String::new(), |mut s, p| {
        writeln!(s, "v {:?} {:?} {:?}", p[0], p[1], p[2]).expect("a String takes any text");
        s
    })
}

/// Writes `obj` and a scene of `actors` (their text) in `dir`; returns the scene's path.
fn files(dir: &Path, obj: &str, actors: &[&str]) -> PathBuf {
    std::fs::write(dir.join("model.obj"), obj).expect("obj file");
    let scene = dir.join("scene.ron");
    std::fs::write(&scene, format!("Scene(actors: [{}])", actors.join(", "))).expect("scene file");
    scene
}

/// Builds a scene file with the library, as `rigid run` does.
fn build(scene: &Path) -> Result<Sim, String> {
    let text = std::fs::read_to_string(scene).expect("scene file");
    let def = scene::parse(&text, scene).map_err(|e| e.to_string())?;
    scene::build(&def, scene).map_err(|e| e.to_string())
}

/// Each actor's mesh and mass properties, by actor index.
fn bodies(sim: &Sim) -> Vec<(ConvexMesh, MassProps)> {
    let mut out = vec![None; sim.len()];
    for (index, mesh, mass) in sim.world.query::<(&ActorIndex, &Mesh, &MassProps)>().iter() {
        out[index.0 as usize] = Some((sim.ctx.meshes.get(mesh.id).clone(), *mass));
    }
    out.into_iter().map(|b| b.expect("every actor has a mesh")).collect()
}

/// `rigid check` on the scene fails as bad input; returns its message.
fn refused(scene: &Path) -> String {
    let o = rigid(&["check", scene.to_str().expect("utf-8 path")]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// The 8 corners of the box of these full sizes centred on the origin.
fn corners(size: [f64; 3]) -> Vec<[f64; 3]> {
    let h = size.map(|s| s / 2.0);
    (0..8).map(|k| [0, 1, 2].map(|a| if k >> a & 1 == 1 { h[a] } else { -h[a] })).collect()
}

fn close(a: f64, b: f64, tolerance: f64) -> bool {
    (a - b).abs() <= tolerance * b.abs().max(1.0)
}

#[test]
fn a_cube_with_inner_and_repeated_points_is_the_cube() {
    let size = [2.0, 2.0, 2.0];
    let mut points = corners(size);
    let mut rng = SplitMix64::new(42);
    for _ in 0..50 {
        points.push([0, 1, 2].map(|_| rng.uniform(-0.999, 0.999)));
    }
    points.extend(corners(size));
    points.extend(corners(size).into_iter().rev());
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = files(
        dir.path(),
        &point_cloud(&points),
        &[
            "Actor(name: \"hull\", shape: Obj(path: \"model.obj\", hull: true), density: 3.0)",
            "Actor(name: \"box\", shape: Box(size: (2.0, 2.0, 2.0)), density: 3.0, position: (5.0, 0.0, 0.0))",
        ],
    );
    let sim = build(&scene).expect("the hull builds");
    let b = bodies(&sim);
    let ((hull, hull_mass), (cube, cube_mass)) = (&b[0], &b[1]);
    assert_eq!(hull.vertices.len(), 8, "the 8 corners, nothing else");
    assert_eq!(hull.planes.len(), 6, "each face's two triangles merged into one plane");
    let half = hull.box_half_extents.expect("recognised as a box");
    assert!((half - Vector::ONE).abs().max_element() < 1e-15, "half extents {half}");
    assert!(close(hull.volume, 8.0, 1e-12), "volume {}", hull.volume);
    assert!(close(hull_mass.mass, cube_mass.mass, 1e-12), "{} vs {}", hull_mass.mass, cube_mass.mass);
    let (i, j) = (hull_mass.inertia.to_cols_array(), cube_mass.inertia.to_cols_array());
    assert!(i.iter().zip(&j).all(|(a, b)| (a - b).abs() <= 1e-12 * 16.0), "inertia {i:?} vs {j:?}");
    let (p, q) = (hull_mass.principal_moments, cube_mass.principal_moments);
    assert!((p - q).abs().max_element() <= 1e-12 * 16.0, "principal moments {p} vs {q}");
    assert!(close(hull.thickness, cube.thickness, 1e-15), "{} vs {}", hull.thickness, cube.thickness);
}

/// An L-shaped prism (the square [0, 2]² less its corner [1, 2]², 1 deep): closed and
/// consistently wound, but not convex.
const L_PRISM: &str = "v 0 0 0\nv 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\n\
     v 0 0 1\nv 2 0 1\nv 2 1 1\nv 1 1 1\nv 1 2 1\nv 0 2 1\n\
     f 1 4 3\nf 1 3 2\nf 1 6 5\nf 1 5 4\n\
     f 7 8 9\nf 7 9 10\nf 7 10 11\nf 7 11 12\n\
     f 1 2 8\nf 1 8 7\nf 2 3 9\nf 2 9 8\nf 3 4 10\nf 3 10 9\nf 4 5 11\nf 4 11 10\nf 5 6 12\nf 5 12 11\nf 6 1 7\nf 6 7 12\n";

#[test]
fn a_non_convex_obj_is_refused_with_a_hint_and_its_hull_has_the_hull_volume() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = files(dir.path(), L_PRISM, &["Actor(name: \"ell\", shape: Obj(path: \"model.obj\"))"]);
    let err = refused(&scene);
    assert!(err.contains("not convex") && err.contains("hull: true"), "{err}");
    assert!(err.contains("model.obj") && err.contains("actor 'ell'"), "{err}");

    let scene = files(dir.path(), L_PRISM, &["Actor(name: \"ell\", shape: Obj(path: \"model.obj\", hull: true))"]);
    let sim = build(&scene).expect("the hull builds");
    let (mesh, _) = &bodies(&sim)[0];
    // The hull's cross-section is the pentagon (0,0), (2,0), (2,1), (1,2), (0,2): the square
    // less the triangle cut off by the segment (2,1)-(1,2), area 4 - 1/2; depth 1.
    assert!(close(mesh.volume, 3.5, 1e-12), "volume {}", mesh.volume);
    assert_eq!(mesh.vertices.len(), 10, "the inner corner's two points are dropped");
    assert_eq!(mesh.planes.len(), 7, "5 sides and 2 caps");
    let o = rigid(&["check", scene.to_str().expect("utf-8 path")]);
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn points_on_a_sphere_are_all_corners_of_a_hull_just_inside_it() {
    let (n, r) = (300, 1.5);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let points: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
            let (ring, a) = ((1.0 - y * y).sqrt(), golden * f64::from(i));
            [r * ring * a.cos(), r * y, r * ring * a.sin()]
        })
        .collect();
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = files(dir.path(), &point_cloud(&points), &["Actor(shape: Obj(path: \"model.obj\", hull: true))"]);
    let sim = build(&scene).expect("the hull builds");
    let (mesh, _) = &bodies(&sim)[0];
    assert_eq!(mesh.vertices.len(), n as usize, "every point is a corner");
    assert_eq!(mesh.triangles.len(), 2 * n as usize - 4, "a triangulated sphere: F = 2V - 4");
    let ball = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    assert!(mesh.volume < ball && mesh.volume > 0.95 * ball, "volume {} of the ball's {ball}", mesh.volume);
}

#[test]
fn grids_of_points_on_a_box_faces_leave_its_corners_and_six_faces() {
    let size = [2.0, 1.0, 3.0];
    let mut points = Vec::new();
    for axis in 0..3 {
        for side in [-0.5, 0.5] {
            for i in 0..5 {
                for j in 0..5 {
                    let (u, v) = (f64::from(i) / 4.0 - 0.5, f64::from(j) / 4.0 - 0.5);
                    let mut p = [side; 3];
                    p[(axis + 1) % 3] = u;
                    p[(axis + 2) % 3] = v;
                    points.push([0, 1, 2].map(|k| p[k] * size[k]));
                }
            }
        }
    }
    assert_eq!(points.len(), 150);
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = files(dir.path(), &point_cloud(&points), &["Actor(shape: Obj(path: \"model.obj\", hull: true))"]);
    let sim = build(&scene).expect("the hull builds");
    let (mesh, _) = &bodies(&sim)[0];
    assert_eq!(mesh.vertices.len(), 8, "only the corners: face and edge points dropped");
    assert_eq!(mesh.planes.len(), 6);
    assert_eq!(mesh.feature_edges.len(), 12);
    assert!(close(mesh.volume, 6.0, 1e-12), "volume {}", mesh.volume);
    let half = mesh.box_half_extents.expect("recognised as a box");
    assert!((half - Vector::new(1.0, 0.5, 1.5)).abs().max_element() < 1e-15, "half extents {half}");
}

#[test]
fn flat_or_too_few_points_are_bad_input_naming_the_file() {
    let dir = tempfile::tempdir().expect("temp dir");
    let actor = ["Actor(name: \"rock\", shape: Obj(path: \"model.obj\", hull: true))"];
    let mut plane: Vec<[f64; 3]> = (0..20).map(|i| [f64::from(i % 5), 1.0, f64::from(i / 5)]).collect();
    plane.push([2.0, 1.0, 2.0]);
    let line: Vec<[f64; 3]> = (0..6).map(|i| [f64::from(i), 2.0 * f64::from(i), 0.5]).collect();
    let cases = [
        (point_cloud(&plane), "the points are flat: no volume (they lie in one plane)"),
        (point_cloud(&line), "the points are flat: no volume (they lie on one line)"),
        (
            point_cloud(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
            "only 3 distinct point(s)",
        ),
        (point_cloud(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1e-12]]), "the points are flat"),
        ("# no points\n".into(), "no vertices"),
        ("v 0 0 0\nv 1 0 zero\n".into(), "line 2: a `v` line needs three finite numbers"),
        ("v 0 0 0\nv 1 0 nan\n".into(), "line 2"),
    ];
    for (obj, needle) in cases {
        let scene = files(dir.path(), &obj, &actor);
        let err = refused(&scene);
        assert!(err.contains(needle), "wants '{needle}' in: {err}");
        let file = dir.path().join("model.obj");
        assert!(err.contains(&file.display().to_string()) && err.contains("actor 'rock'"), "{err}");
    }
}

#[test]
fn a_point_cloud_without_hull_is_refused_with_a_hint() {
    let dir = tempfile::tempdir().expect("temp dir");
    let obj = point_cloud(&corners([1.0, 1.0, 1.0]));
    let err = refused(&files(dir.path(), &obj, &["Actor(shape: Obj(path: \"model.obj\"))"]));
    assert!(err.contains("no faces") && err.contains("hull: true"), "{err}");
    let sim = build(&files(dir.path(), &obj, &["Actor(shape: Obj(path: \"model.obj\", hull: false))"]));
    assert!(sim.is_err(), "hull: false is the default");
}

#[test]
fn the_rock_fixture_is_a_convex_body_of_its_outer_points() {
    let rock = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/models/rock-points.obj");
    let text = std::fs::read_to_string(&rock).expect("fixture");
    let points = text.lines().filter(|l| l.starts_with("v ")).count();
    assert_eq!(points, 60);
    assert!(!text.lines().any(|l| l.starts_with("f ")), "a bare point cloud");
    let dir = tempfile::tempdir().expect("temp dir");
    let actor = format!("Actor(shape: Obj(path: {:?}, scale: 2.0, hull: true), position: (0.0, 2.0, 0.0))", rock);
    let scene = files(dir.path(), "", &[&actor, "Actor(shape: Box(size: (10.0, 1.0, 10.0)), fixed: true)"]);
    let mut sim = build(&scene).expect("the rock builds");
    let first = bodies(&sim)[0].0.clone();
    assert!((20..=42).contains(&first.vertices.len()), "{} corners: the 18 inner points dropped", first.vertices.len());
    assert!(first.radius > 0.7 && first.radius < 1.3 * 1.3, "scaled by 2: radius {}", first.radius);
    // The same file gives the same mesh, and the rock falls onto the slab and stays there.
    assert_eq!(bodies(&build(&scene).expect("again"))[0].0, first);
    sim.run(300).expect("finite");
    let y = sim.actors()[0].pose.position.y;
    assert!(y > 0.5 && y < 2.0, "resting on the slab at y = {y}");
}
