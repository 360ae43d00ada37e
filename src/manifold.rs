//! Contact manifolds for resting contact: up to four points where two touching convex bodies
//! press on each other, so a box lying on a face is held at its corners and does not rock
//! about the single point the detection tests report.

use crate::geometry::Posed;
use crate::math::{Scalar, Vector};

/// Most points per pair: four span any flat contact patch of a convex pair.
pub const MAX_POINTS: usize = 4;

/// The points of one pair's contact.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Manifold {
    /// World points [m]; the first `len` are valid.
    pub points: [Vector; MAX_POINTS],
    /// Gap at each point [m]: ≤ 0 where the vertex is inside the other body, > 0 for a vertex
    /// just outside (a speculative point: it may close the gap this step, not more).
    pub gaps: [Scalar; MAX_POINTS],
    /// How many.
    pub len: usize,
}

impl Manifold {
    /// The valid points.
    #[must_use]
    pub fn points(&self) -> &[Vector] {
        &self.points[..self.len]
    }
}

/// Below this distance [fraction of the smaller radius] two candidate points are one.
const SAME_POINT: Scalar = 1e-6;

/// The vertices of each body inside the other or within `margin` [m] of it (the features the
/// vertex test sees, both ways; points just outside are speculative, so a box that tilts by a
/// hair keeps its corners supported instead of dropping to two points and tipping over),
/// reduced to at most four that span the patch: the deepest, the farthest from it, the one
/// making the largest triangle, and the one adding most area. A point's gap is its signed
/// distance to the other body's face that faces it (the face whose normal is closest to the
/// contact normal `n`, from B to A, for A's vertices; to −n for B's): the distance to the
/// *nearest* face would be a side face's for a corner on an edge, near zero however deep the
/// corner is. Empty when no vertex qualifies (an edge crossing an edge): the caller falls back
/// to the detected contact. `scratch` is reused.
#[must_use]
pub fn manifold(a: &Posed, b: &Posed, n: Vector, margin: Scalar, scratch: &mut Vec<(Vector, Scalar)>) -> Manifold {
    let facing = |p: &Posed, dir: Vector| {
        p.planes
            .iter()
            .copied()
            .max_by(|x, y| x.normal.dot(dir).total_cmp(&y.normal.dot(dir)))
            .map_or((n, 0.0), |pl| (pl.normal, pl.offset))
    };
    let (face_b, face_a) = (facing(b, n), facing(a, -n));
    scratch.clear();
    let near = |p: &Posed, v: Vector| p.max_plane_distance(v) <= margin;
    scratch.extend(a.vertices.iter().filter(|&&v| near(b, v)).map(|&v| (v, face_b.0.dot(v) - face_b.1)));
    scratch.extend(b.vertices.iter().filter(|&&v| near(a, v)).map(|&v| (v, face_a.0.dot(v) - face_a.1)));
    let mut m = Manifold::default();
    let Some(&(p0, g0)) = scratch.iter().min_by(|x, y| x.1.total_cmp(&y.1)) else { return m };
    m.len = 1;
    let same = SAME_POINT * a.mesh.radius.min(b.mesh.radius);
    (m.points[0], m.gaps[0]) = (p0, g0);
    let best = |score: &dyn Fn(Vector) -> Scalar| {
        scratch.iter().map(|&(p, gap)| (p, gap, score(p))).max_by(|x, y| x.2.total_cmp(&y.2)).filter(|x| x.2 > same)
    };
    let push = |m: &mut Manifold, (p, gap, _): (Vector, Scalar, Scalar)| {
        (m.points[m.len], m.gaps[m.len]) = (p, gap);
        m.len += 1;
    };
    let Some(x1) = best(&|p| (p - p0).length()) else { return m };
    push(&mut m, x1);
    let p1 = x1.0;
    let area = |p: Vector, q: Vector, r: Vector| 0.5 * (q - p).cross(r - p).length();
    let Some(x2) = best(&|p| area(p0, p1, p)) else { return m };
    push(&mut m, x2);
    let p2 = x2.0;
    let base = area(p0, p1, p2);
    if let Some(x3) = best(&|p| area(p0, p1, p) + area(p1, p2, p) + area(p2, p0, p) - base) {
        push(&mut m, x3);
    }
    m
}

/// For two bodies that do not touch but are within `margin` of each other, the normal (from B
/// to A) of the face plane that separates them most, and that gap [m]. `None` when they are
/// farther apart, or when no face plane separates them (then they touch, and the detection
/// tests own the pair). This keeps a resting contact alive across a hair's-breadth lift.
#[must_use]
pub fn near_normal(a: &Posed, b: &Posed, margin: Scalar) -> Option<(Vector, Scalar)> {
    let mut best: Option<(Vector, Scalar)> = None;
    for (p, q, sign) in [(b, a, 1.0), (a, b, -1.0)] {
        for pl in &p.planes {
            let gap = q.vertices.iter().map(|&v| pl.normal.dot(v) - pl.offset).fold(Scalar::INFINITY, Scalar::min);
            if best.is_none_or(|(_, g)| gap > g) {
                best = Some((pl.normal * sign, gap));
            }
        }
    }
    best.filter(|&(_, gap)| (0.0..=margin).contains(&gap))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::Pose;
    use crate::mesh::ConvexMesh;
    use std::sync::Arc;

    #[test]
    fn a_box_resting_on_a_floor_is_held_at_its_four_bottom_corners() {
        let floor = Posed::new(
            Arc::new(ConvexMesh::cuboid(Vector::new(10.0, 1.0, 10.0))),
            &Pose::from_position(-0.5 * Vector::Y),
        );
        let cube =
            Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &Pose::from_position(Vector::new(0.0, 0.499, 0.0)));
        let m = manifold(&cube, &floor, Vector::Y, 0.02, &mut Vec::new());
        assert_eq!(m.len, 4);
        let mut corners: Vec<(i64, i64)> =
            m.points().iter().map(|p| ((p.x * 2.0) as i64, (p.z * 2.0) as i64)).collect();
        corners.sort_unstable();
        assert_eq!(corners, [(-1, -1), (-1, 1), (1, -1), (1, 1)]);
        assert!(m.points().iter().all(|p| (p.y + 0.001).abs() < 1e-12));
        assert!(m.gaps[..4].iter().all(|g| (g + 0.001).abs() < 1e-12), "each corner 1 mm deep");
    }

    #[test]
    fn a_box_hovering_a_hair_above_the_floor_is_near_with_the_floor_normal() {
        let floor = Posed::new(
            Arc::new(ConvexMesh::cuboid(Vector::new(10.0, 1.0, 10.0))),
            &Pose::from_position(-0.5 * Vector::Y),
        );
        let at = |y: f64| {
            Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &Pose::from_position(Vector::new(0.0, y, 0.0)))
        };
        let (n, gap) = near_normal(&at(0.5001), &floor, 0.02).expect("0.1 mm apart");
        assert_eq!(n, Vector::Y);
        assert!((gap - 1e-4).abs() < 1e-12);
        assert!(near_normal(&at(0.6), &floor, 0.02).is_none(), "10 cm is not near");
        assert!(near_normal(&at(0.4), &floor, 0.02).is_none(), "overlapping is the tests' business");
        // Seen from the floor's side, the normal flips.
        assert_eq!(near_normal(&floor, &at(0.5001), 0.02).expect("near").0, -Vector::Y);
    }
}
