//! Tests of the convex hull: random clouds, degenerate input, determinism.

use super::*;
use crate::model::mesh::ConvexMesh;
use crate::rng::SplitMix64;
use std::collections::BTreeSet;

fn random_cloud(seed: u64, n: usize) -> Vec<Vector> {
    let mut rng = SplitMix64::new(seed);
    (0..n).map(|_| Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-0.5, 2.0), rng.uniform(-3.0, 0.1))).collect()
}

fn size(points: &[Vector]) -> Scalar {
    let lo = points.iter().copied().reduce(Vector::min).expect("points");
    let hi = points.iter().copied().reduce(Vector::max).expect("points");
    (hi - lo).max_element()
}

/// Every input point inside or on the hull, V − E + F = 2, normals outward, every edge
/// used once each way, no zero-area triangle, every vertex an input point (within a grid
/// step), and `ConvexMesh::new` accepts it.
fn check_hull(points: &[Vector], (vertices, triangles): &RawMesh) {
    let s = size(points);
    let centre = vertices.iter().copied().sum::<Vector>() / vertices.len() as Scalar;
    let mut edges = BTreeSet::new();
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        let n = (b - a).cross(c - a);
        assert!(n.length() > 0.0, "zero-area triangle {t:?}");
        let n = n.normalize();
        assert!(n.dot(a - centre) > 0.0, "triangle {t:?} faces inward");
        for p in points {
            assert!(n.dot(*p - a) <= 2.0 * HULL_TOLERANCE * s, "{p} is outside triangle {t:?}");
        }
        for k in 0..3 {
            assert!(edges.insert((t[k], t[(k + 1) % 3])), "directed edge used twice");
        }
    }
    assert!(edges.iter().all(|&(a, b)| edges.contains(&(b, a))), "every edge has a twin");
    let (v, e, f) = (vertices.len() as i64, edges.len() as i64 / 2, triangles.len() as i64);
    assert_eq!(v - e + f, 2, "Euler's formula");
    let used: BTreeSet<u32> = triangles.iter().flatten().copied().collect();
    assert_eq!(used.len(), vertices.len(), "no unused vertex");
    for v in vertices {
        let nearest = points.iter().map(|p| (*p - *v).length()).fold(Scalar::INFINITY, Scalar::min);
        assert!(nearest <= 2e-12 * s, "vertex {v} is {nearest:e} from the nearest input point");
    }
    let (mesh, _) = ConvexMesh::new(vertices.clone(), triangles.clone()).expect("a valid convex mesh");
    assert_eq!(mesh.triangles.len(), triangles.len());
}

#[test]
fn random_clouds_give_valid_hulls() {
    for seed in 0..40 {
        let points = random_cloud(seed, 4 + (seed as usize * 37) % 400);
        let hull = convex_hull(&points).expect("a hull");
        check_hull(&points, &hull);
    }
}

#[test]
fn the_same_cloud_gives_the_same_bits() {
    let points = random_cloud(7, 500);
    let (v1, t1) = convex_hull(&points).expect("a hull");
    let (v2, t2) = convex_hull(&points).expect("a hull");
    assert_eq!(t1, t2);
    assert!(v1.iter().zip(&v2).all(|(a, b)| a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits)));
}

#[test]
fn a_tetrahedron_is_its_own_hull_in_input_order() {
    let points = [Vector::ZERO, Vector::X, Vector::Y, Vector::Z];
    let (v, t) = convex_hull(&points).expect("a hull");
    assert_eq!(v, points.to_vec(), "corners kept exactly, in input order");
    assert_eq!(t.len(), 4);
    check_hull(&points, &(v, t));
}

#[test]
fn grid_points_on_a_box_leave_its_eight_corners() {
    // 5 × 5 × 5 lattice: its surface points lie on faces and edges, its inner ones inside.
    let mut points = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            for k in 0..5 {
                points.push(Vector::new(f64::from(i) * 0.5, f64::from(j) * 0.25, f64::from(k) * 0.75));
            }
        }
    }
    let hull = convex_hull(&points).expect("a hull");
    check_hull(&points, &hull);
    assert_eq!(hull.0.len(), 8);
    let (mesh, _) = ConvexMesh::new(hull.0, hull.1).expect("valid");
    assert_eq!(mesh.planes.len(), 6);
    assert!((mesh.volume - 2.0 * 1.0 * 3.0).abs() < 1e-12);
}

#[test]
fn points_on_a_circle_and_its_axis_make_a_cylinder_with_flat_caps() {
    let n = 64;
    let mut points = Vec::new();
    for y in [-0.5, 0.0, 0.5] {
        for k in 0..n {
            let a = std::f64::consts::TAU * f64::from(k) / f64::from(n);
            points.push(Vector::new(a.cos(), y, a.sin()));
        }
        points.push(Vector::new(0.0, y, 0.0));
    }
    let hull = convex_hull(&points).expect("a hull");
    check_hull(&points, &hull);
    assert_eq!(hull.0.len(), 2 * n as usize, "the rim points of both caps, no middle ring");
    let (mesh, _) = ConvexMesh::new(hull.0, hull.1).expect("valid");
    assert_eq!(mesh.planes.len(), n as usize + 2, "two caps and the sides");
}

#[test]
fn nearly_flat_and_far_away_clouds_still_pass_the_mesh_checks() {
    // A slab 1e-3 thick whose faces are rotated grids (coplanar only up to rounding), far
    // from the origin.
    let (u, v) = (Vector::new(0.6, 0.8, 0.0), Vector::new(-0.48, 0.36, 0.8));
    let w = u.cross(v);
    let mut points = Vec::new();
    for i in 0..20 {
        for j in 0..20 {
            for s in [0.0, 1e-3] {
                let p = u * (f64::from(i) / 19.0) + v * (f64::from(j) / 19.0) + w * s;
                points.push(p + Vector::new(1000.0, -2000.0, 500.0));
            }
        }
    }
    let hull = convex_hull(&points).expect("a hull");
    check_hull(&points, &hull);
}

#[test]
fn nearly_coplanar_noise_is_cleaned_of_slivers() {
    // A pyramid whose base is a unit square of points up to 1e-10 off its plane, with more
    // points along the square's sides, as much off the sides' lines: the exact hull of the
    // base has triangles far thinner than the tolerance.
    let mut rng = SplitMix64::new(3);
    let mut points = vec![Vector::new(0.5, 1.0, 0.5)];
    let mut noise = || rng.uniform(-1e-10, 1e-10);
    for corner in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        points.push(Vector::new(corner.0, 0.0, corner.1));
    }
    for i in 0..400 {
        let t = f64::from(i) / 400.0;
        points.push(Vector::new(t, noise(), noise()));
        points.push(Vector::new(1.0 + noise(), noise(), t));
        points.push(Vector::new(noise(), noise(), t));
        points.push(Vector::new(t, noise(), 1.0 + noise()));
        points.push(Vector::new(t, noise(), (t * 7.0).fract()));
    }
    let hull = convex_hull(&points).expect("a hull");
    check_hull(&points, &hull);
    let thinnest = hull
        .1
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| hull.0[i as usize]);
            let longest = [b - a, c - b, a - c].iter().map(|e| e.length()).fold(0.0, Scalar::max);
            (b - a).cross(c - a).length() / longest
        })
        .fold(Scalar::INFINITY, Scalar::min);
    assert!(thinnest >= HULL_TOLERANCE, "a triangle {thinnest:e} thin is left");
    let exact = hull_of_all(&points);
    assert!(exact < 1e-9, "without the clean-up the base has slivers ({exact:e} thin)");
}

/// The thinnest triangle of the exact hull, before any clean-up.
fn hull_of_all(points: &[Vector]) -> Scalar {
    let snap = Snap::new(points).expect("points");
    let keep: Vec<u32> = (0..points.len() as u32).collect();
    let triangles = hull(&snap.grid, &keep).expect("a hull");
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| snap.position(snap.grid[i as usize]));
            let longest = [b - a, c - b, a - c].iter().map(|e| e.length()).fold(0.0, Scalar::max);
            (b - a).cross(c - a).length() / longest
        })
        .fold(Scalar::INFINITY, Scalar::min)
}

#[test]
fn duplicates_and_interior_points_are_dropped() {
    let mut points = random_cloud(11, 200);
    let copy = points.clone();
    points.extend(copy);
    let once = convex_hull(&random_cloud(11, 200)).expect("a hull");
    let twice = convex_hull(&points).expect("a hull");
    assert_eq!(once, twice, "the second copy changes nothing");
}

#[test]
fn flat_and_tiny_clouds_are_refused() {
    let flat = |why: &str| HullError::Flat { why: why.into() };
    let line: Vec<Vector> = (0..10).map(|i| Vector::splat(f64::from(i))).collect();
    assert_eq!(convex_hull(&line), Err(flat("they lie on one line")));
    let plane: Vec<Vector> = (0..30).map(|i| Vector::new(f64::from(i % 6), f64::from(i / 6), 2.0)).collect();
    assert_eq!(convex_hull(&plane), Err(flat("they lie in one plane")));
    assert_eq!(convex_hull(&[Vector::ONE; 9]), Err(HullError::TooFew { distinct: 1 }));
    assert_eq!(convex_hull(&[]), Err(HullError::TooFew { distinct: 0 }));
    assert_eq!(convex_hull(&[Vector::ZERO, Vector::X, Vector::Y]), Err(HullError::TooFew { distinct: 3 }));
    let thin = [Vector::ZERO, Vector::X, Vector::Y, Vector::new(0.2, 0.2, 1e-12)];
    assert!(matches!(convex_hull(&thin), Err(HullError::Flat { .. })));
    let nan = [Vector::ZERO, Vector::X, Vector::new(0.0, f64::NAN, 0.0)];
    assert_eq!(convex_hull(&nan), Err(HullError::NonFinite { index: 2 }));
}

#[test]
fn points_on_a_sphere_are_all_corners() {
    let n = 500;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let points: Vec<Vector> = (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
            let r = (1.0 - y * y).sqrt();
            let a = golden * f64::from(i);
            Vector::new(r * a.cos(), y, r * a.sin()) * 3.0
        })
        .collect();
    let hull = convex_hull(&points).expect("a hull");
    check_hull(&points, &hull);
    assert_eq!(hull.0.len(), n as usize);
}
