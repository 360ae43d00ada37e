//! Every shipped scene parses, builds and runs with finite state; defaults are as documented.

mod common;
use common::*;
use rigid_sandbox::math::Vector;
use rigid_sandbox::scene::{self, DEFAULT_RESTITUTION, MassSpec};

#[test]
fn every_shipped_scene_runs_with_finite_state() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).expect("scenes/ exists") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|e| e != "ron") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("readable");
        assert!(text.starts_with("//"), "{}: a scene opens with a comment saying what it shows", path.display());
        let def = scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let mut sim = rigid_sandbox::scene::build(&def, &path).unwrap_or_else(|e| panic!("{e}"));
        sim.run(def.steps.min(60)).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        for a in sim.actors() {
            let finite = a.pose.position.is_finite() && a.velocity.linear.is_finite() && a.velocity.angular.is_finite();
            assert!(finite && a.pose.orientation.is_normalized(), "{}: {}", path.display(), a.name);
        }
        count += 1;
    }
    assert!(count >= 12, "found {count} scenes");
}

#[test]
fn defaults_are_the_documented_ones() {
    let def =
        scene::parse("Scene(actors: [Actor(shape: Box(size: (1.0, 2.0, 3.0)))])", "t.ron".as_ref()).expect("parses");
    assert_eq!((def.dt, def.steps, def.gravity), (1.0 / 60.0, 600, (0.0, -9.81, 0.0)));
    assert!(def.spawners.is_empty() && def.schedule.is_none());
    let a = &def.actors[0];
    assert_eq!(a.mass, MassSpec::Density(1.0));
    assert_eq!(
        (a.position, a.rotation, a.velocity, a.angular_velocity),
        (Vector::ZERO, Vector::ZERO, Vector::ZERO, Vector::ZERO)
    );
    assert_eq!((a.restitution, a.friction, a.fixed, a.name.clone()), (DEFAULT_RESTITUTION, 0.0, false, None));
    // Density 1 and a 1×2×3 box: mass 6; the default name is actor-<index>.
    let sim = rigid_sandbox::scene::build(&def, "t.ron".as_ref()).expect("builds");
    let s = &sim.actors()[0];
    assert_eq!((s.name.as_str(), s.mass.mass), ("actor-0", 6.0));
}

#[test]
fn default_scene_values_round_trip_through_ron() {
    // Writing the defaults out explicitly gives the same scene as leaving them out.
    let short = "Scene(actors: [Actor(shape: Tetrahedron(edge: 1.0))])";
    let long = "Scene(dt: 0.016666666666666666, steps: 600, gravity: (0.0, -9.81, 0.0), spawners: [], \
        solver: Solver(max_sweeps: 20, correction: 0.4, slop: 0.005), actors: [Actor(name: \"actor-0\", \
        shape: Tetrahedron(edge: 1.0), density: 1.0, position: (0.0, 0.0, 0.0), rotation: (0.0, 0.0, 0.0), \
        velocity: (0.0, 0.0, 0.0), angular_velocity: (0.0, 0.0, 0.0), restitution: 0.5, friction: 0.0, fixed: false)])";
    let mut a = sim_from_text(short);
    let mut b = sim_from_text(long);
    a.run(10).expect("finite");
    b.run(10).expect("finite");
    assert_eq!(a.actors(), b.actors());
}

#[test]
fn spawners_place_and_name_copies_as_documented() {
    let sim = sim_from_text(
        "Scene(actors: [], spawners: [Grid(actor: Actor(name: \"t\", shape: Octahedron(radius: 0.5), position: (1.0, 2.0, 3.0)), \
         counts: (3, 2, 1), spacing: (1.5, 2.0, 9.0)), Random(actor: Actor(shape: Box(size: (1.0, 1.0, 1.0))), count: 8, spacing: 2.0)])",
    );
    let actors = sim.actors();
    assert_eq!(actors.len(), 14);
    assert_eq!(actors[4].name, "t-4");
    assert_eq!(actors[4].pose.position, Vector::new(1.0 + 1.5, 2.0 + 2.0, 3.0)); // (i, j) = (1, 1)
    assert_eq!(actors[6].name, "spawner1-0");
    assert_eq!(actors[6].pose.position, Vector::new(-1.0, -1.0, -1.0)); // 2×2×2 lattice, no jitter
}
