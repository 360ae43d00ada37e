//! The `Rain` spawner's `shape` and `rigid bench hull-rain` (docs/benchmarks.md, docs/scenes.md):
//! any shape falls on the cube rain's lattice at density 1, the default stays the unit cube bit
//! for bit, and bad shapes or flags are refused with exit code 2.

use rigid_sandbox::math::Vector;
use rigid_sandbox::scene::spawners::Instance;
use rigid_sandbox::scene::{self, MassSpec, ShapeDef};
use rigid_sandbox::{ActorIndex, Mesh, Sim};
use std::path::Path;
use std::process::{Command, Output};

fn rigid(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rigid")).args(args).output().expect("the binary runs")
}

fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// The actors of a scene's text, in spawn order, and the built simulation.
fn build(text: &str) -> (Vec<Instance>, Sim) {
    let path = Path::new("inline.ron");
    let def = scene::parse(text, path).unwrap_or_else(|e| panic!("{e}"));
    let instances = scene::instantiate::instances(&def, path).unwrap_or_else(|e| panic!("{e}"));
    (instances, scene::build(&def, path).unwrap_or_else(|e| panic!("{e}")))
}

/// Vertex count of each actor's mesh, by actor index.
fn vertex_counts(sim: &Sim) -> Vec<usize> {
    let mut out = vec![0; sim.len()];
    for (index, mesh) in sim.world.query::<(&ActorIndex, &Mesh)>().iter() {
        out[index.0 as usize] = sim.ctx.meshes.get(mesh.id).vertices.len();
    }
    out
}

/// Volume of an icosphere computed here, apart from the library's shapes and mass properties:
/// the icosahedron's faces found as the triples of vertices at edge length from each other,
/// each cut in four `subdivisions` times with the midpoints pushed onto the sphere, and the
/// volume summed over the tetrahedra from the centre.
fn icosphere_volume(radius: f64, subdivisions: u32) -> f64 {
    let p = (1.0 + 5f64.sqrt()) / 2.0;
    let mut vertices = Vec::new();
    for a in [-1.0, 1.0] {
        for b in [-p, p] {
            vertices.extend([Vector::new(0.0, a, b), Vector::new(a, b, 0.0), Vector::new(b, 0.0, a)]);
        }
    }
    let vertices: Vec<Vector> = vertices.iter().map(|v| v.normalize() * radius).collect();
    // The nearest neighbours of a vertex are at the edge length.
    let edge = vertices[1..].iter().map(|v| (*v - vertices[0]).length()).fold(f64::INFINITY, f64::min);
    let adjacent = |a: Vector, b: Vector| ((a - b).length() - edge).abs() < 1e-9;
    let mut faces = Vec::new();
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                let (a, b, c) = (vertices[i], vertices[j], vertices[k]);
                if adjacent(a, b) && adjacent(b, c) && adjacent(c, a) {
                    faces.push([a, b, c]);
                }
            }
        }
    }
    assert_eq!(faces.len(), 20, "an icosahedron has 20 faces");
    for _ in 0..subdivisions {
        let mid = |a: Vector, b: Vector| (a + b).normalize() * radius;
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    faces.iter().map(|[a, b, c]| a.dot(b.cross(*c)).abs() / 6.0).sum()
}

#[test]
fn a_rain_of_icospheres_falls_on_the_cube_rain_lattice_at_density_1() {
    let (cubes, _) = build("Scene(actors: [], spawners: [Rain(actors: 20, seed: 3)])");
    let (balls, sim) = build(
        "Scene(actors: [], spawners: [Rain(actors: 20, seed: 3, shape: Icosphere(radius: 0.5, subdivisions: 1))])",
    );
    assert_eq!((cubes.len(), balls.len(), sim.len()), (25, 25, 25));
    assert_eq!(balls[..5], cubes[..5], "the same floor and walls");
    let icosphere = ShapeDef::Icosphere { radius: 0.5, subdivisions: 1 };
    for (i, (b, c)) in balls[5..].iter().zip(&cubes[5..]).enumerate() {
        assert_eq!(b.pose, c.pose, "body {i}: same lattice, jitter and orientation, bit for bit");
        assert_eq!((b.velocity, b.material, b.fixed), (c.velocity, c.material, c.fixed), "body {i}");
        assert_eq!((&b.shape, b.mass, b.name.clone()), (&icosphere, MassSpec::Density(1.0), format!("icosphere-{i}")));
    }
    assert_eq!((balls[5].material.friction, balls[5].material.restitution), (0.5, 0.2));

    let counts = vertex_counts(&sim);
    assert!(counts[5..].iter().all(|&n| n == 42), "S = 1: 12 + 30 vertices, got {counts:?}");
    assert!(counts[..5].iter().all(|&n| n == 8), "the container is boxes: {counts:?}");
    let exact = icosphere_volume(0.5, 1);
    let sphere = 4.0 / 3.0 * std::f64::consts::PI * 0.5f64.powi(3);
    assert!((0.85 * sphere..sphere).contains(&exact), "inscribed in the sphere: {exact} of {sphere}");
    for a in &sim.actors()[5..] {
        assert!(
            (a.mass.mass - exact).abs() < 1e-12 * exact,
            "{}: mass {} kg, want 1 kg/m³ × {exact} m³",
            a.name,
            a.mass.mass
        );
    }
    let cube_sim = build("Scene(actors: [], spawners: [Rain(actors: 20, seed: 3)])").1;
    for (b, c) in sim.actors().iter().zip(cube_sim.actors()) {
        assert_eq!(b.pose, c.pose, "{}: built where the cube rain puts it", b.name);
    }
}

/// FNV-1a over every field of the instances, floats by their bits.
fn fingerprint(instances: &[Instance]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for b in bytes {
            h = (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3);
        }
    };
    for i in instances {
        eat(i.name.as_bytes());
        eat(format!("{:?} {:?} {}", i.shape, i.mass, i.fixed).as_bytes());
        let (p, q, v, w) = (i.pose.position, i.pose.orientation, i.velocity.linear, i.velocity.angular);
        let m = i.material;
        for x in [p.x, p.y, p.z, q.x, q.y, q.z, q.w, v.x, v.y, v.z, w.x, w.y, w.z, m.restitution, m.friction] {
            eat(&x.to_bits().to_le_bytes());
        }
    }
    h
}

#[test]
fn rain_without_a_shape_is_the_cube_rain_of_before_bit_for_bit() {
    // Fingerprints of `benchmarks::rain` taken before `shape` existed.
    for (n, seed, pinned) in
        [(20, 3, 0xc344_ea28_a5d4_e20a_u64), (1000, 1, 0xd532_aca6_dd53_bf58), (7, 42, 0x291a_37b9_3a00_4af5)]
    {
        let rain = rigid_sandbox::scene::benchmarks::rain(n, seed);
        assert_eq!(fingerprint(&rain), pinned, "rain({n}, {seed})");
        let (spawned, _) = build(&format!("Scene(actors: [], spawners: [Rain(actors: {n}, seed: {seed})])"));
        assert_eq!(spawned, rain, "Rain(actors: {n}, seed: {seed})");
        let (unit, _) = build(&format!(
            "Scene(actors: [], spawners: [Rain(actors: {n}, seed: {seed}, shape: Box(size: (1.0, 1.0, 1.0)))])"
        ));
        assert_eq!(unit, rain, "the unit cube given explicitly is the default");
    }
    let rain = rigid_sandbox::scene::benchmarks::rain(20, 3);
    assert!(rain[5..].iter().all(|c| c.mass == MassSpec::Mass(1.0) && c.name.starts_with("cube-")));
}

#[test]
fn bench_hull_rain_reports_subdivisions_and_bodies_outside() {
    let o = rigid(&[
        "bench",
        "hull-rain",
        "--actors",
        "8",
        "--subdivisions",
        "1",
        "--steps",
        "5",
        "--threads",
        "1",
        "--json",
    ]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let r: serde_json::Value = serde_json::from_str(out.trim()).expect("one JSON line");
    assert_eq!(
        (
            r["scene"].as_str(),
            r["subdivisions"].as_u64(),
            r["actors"].as_u64(),
            r["steps"].as_u64(),
            r["warmup"].as_u64()
        ),
        (Some("hull-rain"), Some(1), Some(8), Some(5), Some(0))
    );
    assert_eq!(r["outside"].as_u64(), Some(0), "{r}");
    assert!(r.get("base").is_none() && r.get("escaped").is_none(), "{r}");

    let o = rigid(&["bench", "hull-rain", "--actors", "2", "--subdivisions", "0", "--steps", "1", "--threads", "1"]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(out.contains("0 outside"), "the check column: {out}");

    let o = rigid(&["bench", "rain", "--actors", "2", "--steps", "1", "--threads", "1", "--json"]);
    let r: serde_json::Value = serde_json::from_str(text(&o).0.trim()).expect("one JSON line");
    assert!(r.get("subdivisions").is_none(), "rain's JSON is unchanged: {r}");
}

#[test]
fn a_bad_shape_in_rain_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().expect("temp dir");
    for (shape, field) in [
        ("Icosphere(radius: -1.0, subdivisions: 1)", "shape.radius"),
        ("Icosphere(radius: 0.5, subdivisions: 9)", "shape.subdivisions"),
        ("Box(size: (1.0, 0.0, 1.0))", "shape.size.y"),
    ] {
        let file = dir.path().join("bad.ron");
        std::fs::write(&file, format!("Scene(actors: [], spawners: [Rain(actors: 4, shape: {shape})])"))
            .expect("write");
        let o = rigid(&["check", file.to_str().expect("utf-8")]);
        let err = text(&o).1;
        assert_eq!(o.status.code(), Some(2), "{shape}: {err}");
        assert!(err.contains(field), "{shape}: the message names {field}: {err}");
    }
}

#[test]
fn subdivisions_out_of_range_or_for_another_scene_are_usage_errors() {
    let o = rigid(&["bench", "hull-rain", "--actors", "8", "--subdivisions", "9", "--steps", "1"]);
    let err = text(&o).1;
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--subdivisions") && err.contains("0..=5"), "{err}");

    let o = rigid(&["bench", "rain", "--actors", "8", "--subdivisions", "1", "--steps", "1"]);
    let err = text(&o).1;
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--subdivisions applies to hull-rain only"), "{err}");
}
