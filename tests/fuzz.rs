//! Property tests of robustness (issue #7): random bytes and random mutations of valid scenes
//! never panic the loader; random valid scenes step 100 times without NaN.

use proptest::prelude::*;
use rigid_sandbox::scene;
use std::path::Path;

fn load(text: &str) {
    let path = Path::new("fuzz.ron");
    if let Ok(def) = scene::parse(text, path) {
        // Building may fail (bad mesh, limits) but must not panic; keep spawners small.
        if def.spawners.iter().map(rigid_sandbox::scene::spawners::SpawnerDef::count).sum::<u64>() < 5000 {
            let _ = scene::build(&def, path);
        }
    }
}

const SEED: &str = include_str!("../scenes/mixed-shapes.ron");

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_bytes_never_panic_the_loader(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        load(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn mutated_scenes_never_panic_the_loader(edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0..3u8), 1..8)) {
        let mut bytes = SEED.as_bytes().to_vec();
        for (at, byte, kind) in edits {
            let i = at.index(bytes.len().max(1));
            match kind {
                0 if !bytes.is_empty() => { bytes.remove(i.min(bytes.len() - 1)); }
                1 => bytes.insert(i.min(bytes.len()), byte),
                _ if !bytes.is_empty() => { let j = i.min(bytes.len() - 1); bytes[j] = byte; }
                _ => {}
            }
        }
        load(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn random_valid_scenes_stay_finite(
        actors in proptest::collection::vec((0..5u8, (-4.0..4.0f64, -4.0..4.0f64, -4.0..4.0f64), (-3.0..3.0f64, -3.0..3.0f64, -3.0..3.0f64), (-180.0..180.0f64, -90.0..90.0f64, -180.0..180.0f64), 0.0..=1.0f64), 1..10),
    ) {
        let shapes = ["Box(size: (0.8, 0.5, 1.1))", "Tetrahedron(edge: 1.0)", "Octahedron(radius: 0.6)", "Icosphere(radius: 0.5, subdivisions: 1)", "Cylinder(radius: 0.4, height: 0.8, segments: 8)"];
        let list: Vec<String> = actors.iter().enumerate().map(|(i, (s, p, v, r, e))| format!(
            "Actor(name: \"a{i}\", shape: {}, position: ({}, {}, {}), velocity: ({}, {}, {}), rotation: ({}, {}, {}), restitution: {e})",
            shapes[*s as usize], p.0, p.1, p.2, v.0, v.1, v.2, r.0, r.1, r.2)).collect();
        let text = format!("Scene(dt: 0.01, actors: [Actor(name: \"floor\", shape: Box(size: (20.0, 1.0, 20.0)), position: (0.0, -6.0, 0.0), fixed: true), {}])", list.join(", "));
        let path = Path::new("random.ron");
        let mut sim = scene::build(&scene::parse(&text, path).expect("valid"), path).expect("builds");
        prop_assert!(sim.run(100).is_ok(), "NaN guard tripped");
    }
}
