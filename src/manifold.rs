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
pub fn manifold(
    a: &Posed,
    b: &Posed,
    n: Vector,
    (margin, reach): (Scalar, Scalar),
    scratch: &mut Vec<(Vector, Scalar)>,
) -> Manifold {
    let facing = |p: &Posed, dir: Vector| {
        p.planes
            .iter()
            .copied()
            .max_by(|x, y| x.normal.dot(dir).total_cmp(&y.normal.dot(dir)))
            .map_or((n, 0.0), |pl| (pl.normal, pl.offset))
    };
    let (face_b, face_a) = (facing(b, n), facing(a, -n));
    scratch.clear();
    // A vertex counts when it is within `reach` of the other body and the face it is nearest
    // to is (within `margin`) the facing face: a corner that went in through a side face
    // belongs to another contact, and its distance to the facing face (up to a whole body
    // deep) would push the pair apart far too hard.
    let candidates =
        |p: &Posed, (normal, offset): (Vector, Scalar), vertices: &[Vector], out: &mut Vec<(Vector, Scalar)>| {
            for &v in vertices {
                let nearest = p.max_plane_distance(v);
                let gap = normal.dot(v) - offset;
                if nearest <= reach && gap >= nearest - margin {
                    out.push((v, gap));
                }
            }
        };
    candidates(b, face_b, &a.vertices, scratch);
    candidates(a, face_a, &b.vertices, scratch);
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

/// The axis along which two convex bodies overlap least, or are farthest apart: the
/// separating-axis test over the face normals of both and the cross products of their edge
/// directions, as resting contact needs it. The paper's detection tests decide *whether* a
/// pair touches; their normal is that of the first test that fires (a face centroid, a vertex,
/// an edge), which in a pile of tumbled boxes can point along a side face one step and the top
/// face the next, and their depth can be a whole body deep. Holding a resting pair along its
/// least-overlap axis, by the amount of that overlap, keeps the pushes small and the normals
/// steady.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    /// Unit normal from B to A.
    pub normal: Vector,
    /// Signed distance along it [m]: > 0 apart, < 0 overlapping by that much.
    pub separation: Scalar,
    /// Whether the axis is an edge–edge cross product (else a face normal).
    pub edge: bool,
}

/// A face of A is preferred to one of B, and an edge axis to a face, only when it separates
/// the pair by more than this fraction of the margin: near-ties then keep one choice from
/// step to step instead of flickering between parallel faces.
const PREFER: Scalar = 0.1;

/// The least-overlap axis of A and B (see `Axis`), or `None` when they are more than `reach`
/// apart along some axis. `margin` (the contact margin, without the speculative distance a
/// fast pair's `reach` adds) sets how much better another axis must be to replace B's face.
#[must_use]
pub fn contact_axis(a: &Posed, b: &Posed, (margin, reach): (Scalar, Scalar)) -> Option<Axis> {
    let lowest = |p: &Posed, dir: Vector| p.vertices.iter().map(|v| v.dot(dir)).fold(Scalar::INFINITY, Scalar::min);
    let mut best: Option<Axis> = None;
    let mut consider = |normal: Vector, separation: Scalar, edge: bool, prefer: Scalar| {
        if best.is_none_or(|x| separation > x.separation + prefer) {
            best = Some(Axis { normal, separation, edge });
        }
    };
    for pl in &b.planes {
        consider(pl.normal, lowest(a, pl.normal) - pl.offset, false, 0.0);
    }
    for pl in &a.planes {
        consider(-pl.normal, lowest(b, pl.normal) - pl.offset, false, PREFER * margin);
    }
    let centre = a.position - b.position;
    for &da in &a.edge_directions {
        for &db in &b.edge_directions {
            let cross = da.cross(db);
            if cross.length_squared() < 1e-12 {
                continue; // parallel edges: their plane's normal is a face axis already
            }
            let n = if cross.dot(centre) < 0.0 { -cross.normalize() } else { cross.normalize() };
            consider(n, lowest(a, n) + lowest(b, -n), true, PREFER * margin);
        }
    }
    best.filter(|x| x.separation <= reach)
}

/// Where A and B meet along `axis` when no vertex of either lies on the other (edge across
/// edge): halfway between the closest points of A's deepest and B's highest features along
/// the normal (edges when both are edges, else the features' centroids).
#[must_use]
pub fn support_point(a: &Posed, b: &Posed, axis: &Axis) -> Vector {
    let n = axis.normal;
    let tol = 1e-6 * a.mesh.radius.max(b.mesh.radius);
    let feature = |p: &Posed, dir: Vector| {
        let low = p.vertices.iter().map(|v| v.dot(dir)).fold(Scalar::INFINITY, Scalar::min);
        let mut out = [Vector::ZERO; 2];
        let (mut count, mut sum) = (0, Vector::ZERO);
        for &v in p.vertices.iter().filter(|v| v.dot(dir) <= low + tol) {
            if count < 2 {
                out[count] = v;
            }
            count += 1;
            sum += v;
        }
        (out, count, sum / count.max(1) as Scalar)
    };
    let ((ea, ca, ma), (eb, cb, mb)) = (feature(a, n), feature(b, -n));
    if ca == 2 && cb == 2 {
        let (p, q) = closest_points(ea[0], ea[1], eb[0], eb[1]);
        0.5 * (p + q)
    } else {
        0.5 * (ma + mb)
    }
}

/// The closest points of segments p0p1 and q0q1 (Ericson, "Real-Time Collision Detection",
/// §5.1.9).
fn closest_points(p0: Vector, p1: Vector, q0: Vector, q1: Vector) -> (Vector, Vector) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let c = d1.dot(r);
    let b = d1.dot(d2);
    let denom = a * e - b * b;
    let mut s = if denom > 1e-12 * a * e { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
    let mut t = if e > 0.0 { (b * s + f) / e } else { 0.0 };
    if t < 0.0 {
        t = 0.0;
        s = if a > 0.0 { (-c / a).clamp(0.0, 1.0) } else { 0.0 };
    } else if t > 1.0 {
        t = 1.0;
        s = if a > 0.0 { ((b - c) / a).clamp(0.0, 1.0) } else { 0.0 };
    }
    (p0 + d1 * s, q0 + d2 * t)
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
        let m = manifold(&cube, &floor, Vector::Y, (0.02, 0.02), &mut Vec::new());
        assert_eq!(m.len, 4);
        let mut corners: Vec<(i64, i64)> =
            m.points().iter().map(|p| ((p.x * 2.0) as i64, (p.z * 2.0) as i64)).collect();
        corners.sort_unstable();
        assert_eq!(corners, [(-1, -1), (-1, 1), (1, -1), (1, 1)]);
        assert!(m.points().iter().all(|p| (p.y + 0.001).abs() < 1e-12));
        assert!(m.gaps[..4].iter().all(|g| (g + 0.001).abs() < 1e-12), "each corner 1 mm deep");
    }

    #[test]
    fn a_box_on_a_floor_is_held_along_the_floor_normal_by_its_overlap() {
        let floor = Posed::new(
            Arc::new(ConvexMesh::cuboid(Vector::new(10.0, 1.0, 10.0))),
            &Pose::from_position(-0.5 * Vector::Y),
        );
        let at = |y: f64| {
            Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &Pose::from_position(Vector::new(0.0, y, 0.0)))
        };
        let axis = contact_axis(&at(0.5001), &floor, (0.02, 0.02)).expect("0.1 mm apart");
        assert_eq!((axis.normal, axis.edge), (Vector::Y, false));
        assert!((axis.separation - 1e-4).abs() < 1e-12);
        assert!(contact_axis(&at(0.6), &floor, (0.02, 0.02)).is_none(), "10 cm is not near");
        let sunk = contact_axis(&at(0.4), &floor, (0.02, 0.02)).expect("overlapping");
        assert_eq!(sunk.normal, Vector::Y);
        assert!((sunk.separation + 0.1).abs() < 1e-12, "10 cm deep: {}", sunk.separation);
        // Seen from the floor's side, the normal flips.
        assert_eq!(contact_axis(&floor, &at(0.5001), (0.02, 0.02)).expect("near").normal, -Vector::Y);
    }

    #[test]
    fn two_boxes_crossed_edge_on_edge_meet_along_the_cross_product_of_their_edges() {
        use crate::math::from_euler_degrees;
        let cube = Arc::new(ConvexMesh::cuboid(Vector::ONE));
        // The lower box's top edge along z, the upper box's bottom edge along x, 1 cm deep.
        let h = 0.5 * 2f64.sqrt();
        let lower = Posed::new(
            Arc::clone(&cube),
            &Pose { position: Vector::ZERO, orientation: from_euler_degrees(Vector::new(0.0, 0.0, 45.0)) },
        );
        let upper = Posed::new(
            cube,
            &Pose {
                position: Vector::new(0.0, 2.0 * h - 0.01, 0.0),
                orientation: from_euler_degrees(Vector::new(45.0, 0.0, 0.0)),
            },
        );
        let axis = contact_axis(&upper, &lower, (0.02, 0.02)).expect("touching");
        assert!(axis.edge, "{axis:?}");
        // A fast pair's wider reach (speculative distance) does not change which axis wins.
        assert_eq!(contact_axis(&upper, &lower, (0.02, 0.5)), Some(axis));
        assert!((axis.normal - Vector::Y).length() < 1e-12, "{axis:?}");
        assert!((axis.separation + 0.01).abs() < 1e-12, "{axis:?}");
        let p = support_point(&upper, &lower, &axis);
        assert!((p - Vector::new(0.0, h - 0.005, 0.0)).length() < 1e-12, "halfway between the edges: {p}");
        assert_eq!(manifold(&upper, &lower, axis.normal, (0.02, 0.02), &mut Vec::new()).len, 0, "no vertex inside");
    }
}
