//! Contact manifolds for resting contact: up to four points where two touching convex bodies
//! press on each other, so a box lying on a face is held at its corners and does not rock
//! about the single point the detection tests report.

use crate::collision::boxes::{BoxAt, box_contact_axis};
use crate::collision::hull::{contact_axis_hinted, contact_axis_near, is_many_faced};
use crate::collision::posed::Posed;
use crate::math::{Scalar, Vector};
use wide::f64x4;

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

    /// The index of the deepest point (least gap), `None` when there is none.
    #[must_use]
    pub fn deepest(&self) -> Option<usize> {
        (0..self.len).min_by(|&x, &y| self.gaps[x].total_cmp(&self.gaps[y]))
    }
}

/// Below this distance [fraction of the smaller radius] two candidate points are one.
const SAME_POINT: Scalar = 1e-6;

/// An edge axis within about 8° of a face normal (this cosine) is clipped against that face.
const EDGE_ON_FACE: Scalar = 0.99;

/// Reused buffers of `manifold`: the incident face as it is clipped, and the points kept.
#[derive(Clone, Debug, Default)]
pub struct ClipScratch {
    polygon: Vec<Vector>,
    clipped: Vec<Vector>,
    points: Vec<(Vector, Scalar)>,
}

/// The contact points of a pair held along `axis` (from `contact_axis`), by clipping as
/// Box2D, Bullet and rapier do: the other body's face most opposed to the *reference* face (the
/// one whose normal the axis is) is clipped to the prism over the reference face. Each clipped
/// corner within `reach` [m] of the reference plane is a point, halfway between corner and
/// plane, with its signed distance as its gap; at most four spanning the patch are kept.
///
/// Corners the step may bring into contact count while apart, so a tumbling cube landing on
/// another is stopped over its whole face, not pivoted about the corner that touched first.
/// Empty for an edge–edge axis or when nothing survives the clipping: the caller then holds the
/// pair at `support_point`.
#[must_use]
pub fn manifold(a: &Posed, b: &Posed, axis: &Axis, reach: Scalar, scratch: &mut ClipScratch) -> Manifold {
    let (reference, incident, face) = match axis.reference {
        Reference::FaceOfB(f) => (b, a, f as usize),
        Reference::FaceOfA(f) => (a, b, f as usize),
        Reference::Edges => {
            // An edge axis nearly along a face normal is a face resting on an edge (a cube over
            // a wall's edge, whose far corners make the wall's face axis read deeper): clipped
            // against that face it gets a point at each end of the edge, not one to seesaw on.
            let best = |p: &Posed, n: Vector| p.most_along(n);
            match (best(b, axis.normal), best(a, -axis.normal)) {
                (Some((cb, fb)), Some((ca, _))) if cb >= ca && cb >= EDGE_ON_FACE => (b, a, fb),
                (_, Some((ca, fa))) if ca >= EDGE_ON_FACE => (a, b, fa),
                _ => return Manifold::default(),
            }
        }
    };
    let plane = reference.plane(face);
    let n = plane.normal;
    let Some(incident_face) = incident_face(incident, n) else {
        return Manifold::default();
    };
    let ClipScratch { polygon, clipped, points } = scratch;
    polygon.clear();
    polygon.extend(outline(incident, incident_face).iter().map(|&i| incident.vertices[i as usize]));
    let side = outline(reference, face);
    for k in 0..side.len() {
        let (p, q) = (reference.vertices[side[k] as usize], reference.vertices[side[(k + 1) % side.len()] as usize]);
        // Outward for a counter-clockwise outline seen from outside (along n).
        let out = (q - p).cross(n);
        clip_polygon(polygon, clipped, out, out.dot(p));
        std::mem::swap(polygon, clipped);
        if polygon.is_empty() {
            return Manifold::default();
        }
    }
    points.clear();
    for &x in polygon.iter() {
        let gap = n.dot(x) - plane.offset;
        if gap <= reach {
            points.push((x - n * (0.5 * gap), gap));
        }
    }
    reduce(points, SAME_POINT * a.mesh.radius.min(b.mesh.radius))
}

/// The incident body's face most opposed to `n`: among all faces, or for a many-faced body
/// among those around its vertex lowest along `n` (the most opposed face is one of them
/// unless the vertex's faces are very uneven).
fn incident_face(incident: &Posed, n: Vector) -> Option<usize> {
    let opposed = |x: &(usize, Scalar), y: &(usize, Scalar)| x.1.total_cmp(&y.1);
    if is_many_faced(incident) {
        let m = &incident.mesh;
        let (v, _) = crate::collision::hull::lowest_vertex_seeded(incident, n);
        let around =
            &m.vertex_faces[m.vertex_face_start[v as usize] as usize..m.vertex_face_start[v as usize + 1] as usize];
        return around
            .iter()
            .map(|&f| (f as usize, incident.plane(f as usize).normal.dot(n)))
            .min_by(opposed)
            .map(|x| x.0);
    }
    incident.all_planes().enumerate().map(|(f, pl)| (f, pl.normal.dot(n))).min_by(opposed).map(|x| x.0)
}

/// Face `f`'s outline on the body (vertex indices, counter-clockwise seen from outside).
fn outline(p: &Posed, f: usize) -> &[u32] {
    let m = &p.mesh;
    &m.face_vertices[m.face_start[f] as usize..m.face_start[f + 1] as usize]
}

/// One Sutherland–Hodgman pass: the part of convex polygon `input` where `out·x ≤ offset`,
/// into `output`.
fn clip_polygon(input: &[Vector], output: &mut Vec<Vector>, out: Vector, offset: Scalar) {
    output.clear();
    let Some(&last) = input.last() else { return };
    let (mut prev, mut d_prev) = (last, out.dot(last) - offset);
    for &x in input {
        let d = out.dot(x) - offset;
        if (d <= 0.0) != (d_prev <= 0.0) {
            output.push(prev + (x - prev) * (d_prev / (d_prev - d)));
        }
        if d <= 0.0 {
            output.push(x);
        }
        (prev, d_prev) = (x, d);
    }
}

/// At most four of `points` (point, gap) spanning the patch: the deepest, then the farthest
/// from it, the one making the largest triangle with the two, and the one adding most area.
/// Points closer than `same` to the ones kept add nothing.
fn reduce(points: &[(Vector, Scalar)], same: Scalar) -> Manifold {
    let mut m = Manifold::default();
    let Some(&(p0, g0)) = points.iter().min_by(|x, y| x.1.total_cmp(&y.1)) else { return m };
    (m.points[0], m.gaps[0], m.len) = (p0, g0, 1);
    let best = |score: &dyn Fn(Vector) -> Scalar| {
        points.iter().map(|&(p, gap)| (p, gap, score(p))).max_by(|x, y| x.2.total_cmp(&y.2)).filter(|x| x.2 > same)
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

/// The axis along which two convex bodies overlap least, or are farthest apart, over the face
/// normals of both and the cross products of their edge directions (separating-axis test). The
/// paper's tests decide *whether* a pair touches, but their normal can jump between faces from
/// step to step and their depth be a body deep; resting contact held along this axis, by this
/// overlap, gets small pushes and steady normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    /// Unit normal from B to A.
    pub normal: Vector,
    /// Signed distance along it [m]: > 0 apart, < 0 overlapping by that much.
    pub separation: Scalar,
    /// What the axis is: a face normal of either body, or an edge–edge cross product.
    pub reference: Reference,
}

impl Axis {
    /// True for an edge–edge cross product.
    #[must_use]
    pub fn is_edge(&self) -> bool {
        self.reference == Reference::Edges
    }
}

/// The feature an `Axis` comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reference {
    /// The outward normal of B's face (plane index): the axis itself.
    FaceOfB(u32),
    /// The outward normal of A's face: minus the axis.
    FaceOfA(u32),
    /// The cross product of an edge direction of each body.
    Edges,
}

impl Reference {
    /// The face it names, as (of A, plane index); `None` for an edge axis.
    #[must_use]
    pub fn face(self) -> Option<(bool, u32)> {
        match self {
            Self::FaceOfB(f) => Some((false, f)),
            Self::FaceOfA(f) => Some((true, f)),
            Self::Edges => None,
        }
    }
}

/// A face of A is preferred to one of B, and an edge axis to a face, only when it separates
/// the pair by more than this fraction of the margin: near-ties then keep one choice from
/// step to step instead of flickering between parallel faces.
pub(crate) const PREFER: Scalar = 0.1;

/// The least-overlap axis of A and B (see `Axis`), or `None` when they are more than `reach`
/// apart along some axis. `margin` (the contact margin, without the speculative distance a
/// fast pair's `reach` adds) sets how much better another axis must be to replace B's face.
/// A pair with a many-faced body searches only the features near the contact
/// (`hull::contact_axis_near`); others try every face and edge pair (`contact_axis_all`).
#[must_use]
pub fn contact_axis(a: &Posed, b: &Posed, (margin, reach): (Scalar, Scalar)) -> Option<Axis> {
    if is_many_faced(a) || is_many_faced(b) {
        contact_axis_near(a, b, (margin, reach))
    } else {
        contact_axis_all(a, b, (margin, reach))
    }
}

/// `contact_axis` for a pair held last step along a face axis (`hint`, that axis's
/// reference): a pair with a many-faced body searches near that face
/// (`hull::contact_axis_hinted`) instead of flooding the bodies' overlap; any other pair, or
/// an edge axis, as `contact_axis`.
#[must_use]
pub fn contact_axis_from(
    a: &Posed,
    b: &Posed,
    (margin, reach): (Scalar, Scalar),
    hint: Option<Reference>,
) -> Option<Axis> {
    match hint.and_then(Reference::face).filter(|_| is_many_faced(a) || is_many_faced(b)) {
        Some(face) => contact_axis_hinted(a, b, (margin, reach), face),
        None => contact_axis(a, b, (margin, reach)),
    }
}

/// `contact_axis` over every face of both bodies and every pair of their edge directions; two
/// boxes from their poses and half extents (`boxes::box_contact_axis`), any other pair by
/// projecting the vertices (`contact_axis_scan`).
#[must_use]
pub fn contact_axis_all(a: &Posed, b: &Posed, (margin, reach): (Scalar, Scalar)) -> Option<Axis> {
    match (BoxAt::posed(a), BoxAt::posed(b)) {
        (Some(a), Some(b)) => box_contact_axis(&a, &b, (margin, reach)),
        _ => contact_axis_scan(a, b, (margin, reach)),
    }
}

/// `contact_axis_all` by projecting both bodies' vertices on each axis.
#[must_use]
pub fn contact_axis_scan(a: &Posed, b: &Posed, (margin, reach): (Scalar, Scalar)) -> Option<Axis> {
    let (lanes_a, lanes_b) = (LaneVertices::new(a), LaneVertices::new(b));
    let lowest = |lanes: &Option<LaneVertices>, p: &Posed, dir: Vector| match lanes {
        Some(l) => l.lowest(dir),
        None => p.vertices.iter().map(|v| v.dot(dir)).fold(Scalar::INFINITY, Scalar::min),
    };
    let mut best: Option<Axis> = None;
    let mut consider = |normal: Vector, separation: Scalar, reference: Reference, prefer: Scalar| {
        if best.is_none_or(|x| separation > x.separation + prefer) {
            best = Some(Axis { normal, separation, reference });
        }
    };
    for (f, pl) in b.all_planes().enumerate() {
        consider(pl.normal, lowest(&lanes_a, a, pl.normal) - pl.offset, Reference::FaceOfB(f as u32), 0.0);
    }
    for (f, pl) in a.all_planes().enumerate() {
        consider(-pl.normal, lowest(&lanes_b, b, pl.normal) - pl.offset, Reference::FaceOfA(f as u32), PREFER * margin);
    }
    let centre = a.position - b.position;
    let (edges_a, edges_b) = (edge_directions(a), edge_directions(b));
    for &da in edges_a.iter() {
        for &db in edges_b.iter() {
            let cross = da.cross(db);
            if cross.length_squared() < 1e-12 {
                continue; // parallel edges: their plane's normal is a face axis already
            }
            let n = if cross.dot(centre) < 0.0 { -cross.normalize() } else { cross.normalize() };
            consider(n, lowest(&lanes_a, a, n) + lowest(&lanes_b, b, -n), Reference::Edges, PREFER * margin);
        }
    }
    best.filter(|x| x.separation <= reach)
}

/// Most vertices `LaneVertices` holds (four a register); larger small meshes are scanned.
const LANE_VERTICES: usize = 32;

/// A small body's vertices four to a register, for `contact_axis_all`'s many projections (a
/// box pair's 240): each lane's dot product is glam's (x, y, z summed in that order) and a
/// minimum is exact, so `lowest` is the scalar scan's value. The last register is filled up
/// with repeats of the first vertex, which cannot change a minimum.
struct LaneVertices {
    x: [f64x4; LANE_VERTICES / 4],
    y: [f64x4; LANE_VERTICES / 4],
    z: [f64x4; LANE_VERTICES / 4],
    registers: usize,
}

impl LaneVertices {
    fn new(p: &Posed) -> Option<Self> {
        let v = &p.vertices;
        if v.is_empty() || v.len() > LANE_VERTICES {
            return None;
        }
        let mut out = Self {
            x: [f64x4::ZERO; LANE_VERTICES / 4],
            y: [f64x4::ZERO; LANE_VERTICES / 4],
            z: [f64x4::ZERO; LANE_VERTICES / 4],
            registers: v.len().div_ceil(4),
        };
        for r in 0..out.registers {
            let at = |l: usize| v.get(4 * r + l).unwrap_or(&v[0]);
            out.x[r] = f64x4::new(std::array::from_fn(|l| at(l).x));
            out.y[r] = f64x4::new(std::array::from_fn(|l| at(l).y));
            out.z[r] = f64x4::new(std::array::from_fn(|l| at(l).z));
        }
        Some(out)
    }

    /// The least `v·dir` over the vertices.
    fn lowest(&self, dir: Vector) -> Scalar {
        let (dx, dy, dz) = (f64x4::splat(dir.x), f64x4::splat(dir.y), f64x4::splat(dir.z));
        let mut low = f64x4::splat(Scalar::INFINITY);
        for r in 0..self.registers {
            low = low.min(self.x[r] * dx + self.y[r] * dy + self.z[r] * dz);
        }
        let [l0, l1, l2, l3] = low.to_array();
        l0.min(l1).min(l2.min(l3))
    }
}

/// The world directions of `p`'s feature edges: the posed ones, or for a many-faced body
/// (which poses none) each feature edge's own.
fn edge_directions(p: &Posed) -> std::borrow::Cow<'_, [Vector]> {
    if p.edge_directions.is_empty() {
        let along = |&[i, j]: &[u32; 2]| (p.vertices[j as usize] - p.vertices[i as usize]).normalize_or_zero();
        std::borrow::Cow::Owned(p.mesh.feature_edges.iter().map(along).collect())
    } else {
        std::borrow::Cow::Borrowed(&p.edge_directions)
    }
}

/// Where A and B meet along `axis` when no vertex of either lies on the other (edge across
/// edge): halfway between the closest points of A's deepest and B's highest features along
/// the normal (edges when both are edges, else the features' centroids).
#[must_use]
pub fn support_point(a: &Posed, b: &Posed, axis: &Axis) -> Vector {
    let n = axis.normal;
    let tol = 1e-6 * a.mesh.radius.max(b.mesh.radius);
    let feature = |p: &Posed, dir: Vector| {
        LOWEST.with_borrow_mut(|(found, stack)| {
            lowest_vertices(p, dir, tol, (found, stack));
            let mut out = [Vector::ZERO; 2];
            let (mut count, mut sum) = (0, Vector::ZERO);
            for v in found.iter().map(|&i| p.vertices[i as usize]) {
                if count < 2 {
                    out[count] = v;
                }
                count += 1;
                sum += v;
            }
            (out, count, sum / count.max(1) as Scalar)
        })
    };
    let ((ea, ca, ma), (eb, cb, mb)) = (feature(a, n), feature(b, -n));
    if ca == 2 && cb == 2 {
        let (p, q) = closest_points(ea[0], ea[1], eb[0], eb[1]);
        0.5 * (p + q)
    } else {
        0.5 * (ma + mb)
    }
}

thread_local! {
    /// `support_point`'s buffers (`lowest_vertices`), one pair a thread: no allocation a call.
    static LOWEST: std::cell::RefCell<(Vec<u32>, Vec<u32>)> = std::cell::RefCell::default();
}

/// The vertices of `p` within `tol` of the lowest along `dir`, in index order, into `found`
/// (`stack` is scratch): all of them scanned, or for a many-faced body found by walking to the
/// lowest and flooding over neighbours (the vertices below any level of a linear function are
/// connected on a convex hull, so the flood reaches each).
fn lowest_vertices(p: &Posed, dir: Vector, tol: Scalar, (found, stack): (&mut Vec<u32>, &mut Vec<u32>)) {
    found.clear();
    if !is_many_faced(p) {
        let low = p.vertices.iter().map(|v| v.dot(dir)).fold(Scalar::INFINITY, Scalar::min);
        found.extend((0..p.vertices.len() as u32).filter(|&i| p.vertices[i as usize].dot(dir) <= low + tol));
        return;
    }
    let m = &p.mesh;
    let (first, low) = crate::collision::hull::lowest_vertex_seeded(p, dir);
    found.push(first);
    stack.clear();
    stack.push(first);
    while let Some(i) = stack.pop() {
        for &j in &m.neighbours[m.neighbour_start[i as usize] as usize..m.neighbour_start[i as usize + 1] as usize] {
            if p.vertices[j as usize].dot(dir) <= low + tol && !found.contains(&j) {
                found.push(j);
                stack.push(j);
            }
        }
    }
    found.sort_unstable();
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
    use crate::model::components::Pose;
    use crate::model::mesh::ConvexMesh;
    use std::sync::Arc;

    #[test]
    fn four_lane_lowest_projections_are_the_scans_bit_for_bit() {
        use crate::model::shapes::{cylinder_raw, octahedron_raw, tetrahedron_raw};
        let mesh = |(v, t): crate::model::shapes::RawMesh| Arc::new(ConvexMesh::new(v, t).expect("a shape").0);
        let meshes = [
            Arc::new(ConvexMesh::cuboid(Vector::new(0.3, 1.0, 2.0))),
            mesh(tetrahedron_raw(1.0)),
            mesh(octahedron_raw(0.7)),
            mesh(cylinder_raw(0.5, 1.0, 7)), // 14 vertices: the last register half repeats
            mesh(cylinder_raw(0.5, 1.0, 16)), // 32: every register full
        ];
        let mut rng = crate::rng::SplitMix64::new(7);
        for m in &meshes {
            for _ in 0..200 {
                let axis = Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
                let pose = Pose {
                    position: Vector::new(rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0)),
                    orientation: crate::math::Quat::from_axis_angle(
                        axis.normalize_or(Vector::X),
                        rng.uniform(-3.0, 3.0),
                    ),
                };
                let p = Posed::new(m.clone(), &pose);
                let dir = Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
                let scan = p.vertices.iter().map(|v| v.dot(dir)).fold(Scalar::INFINITY, Scalar::min);
                let lanes = LaneVertices::new(&p).expect("a small mesh");
                assert_eq!(lanes.lowest(dir).to_bits(), scan.to_bits(), "{} vertices", p.vertices.len());
            }
        }
        let many = Posed::new(mesh(cylinder_raw(0.5, 1.0, 17)), &Pose::IDENTITY);
        assert!(LaneVertices::new(&many).is_none(), "34 vertices are scanned");
    }

    #[test]
    fn a_box_resting_on_a_floor_is_held_at_its_four_bottom_corners() {
        let floor = Posed::new(
            Arc::new(ConvexMesh::cuboid(Vector::new(10.0, 1.0, 10.0))),
            &Pose::from_position(-0.5 * Vector::Y),
        );
        let cube =
            Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &Pose::from_position(Vector::new(0.0, 0.499, 0.0)));
        let axis = contact_axis(&cube, &floor, (0.02, 0.02)).expect("touching");
        let m = manifold(&cube, &floor, &axis, 0.02, &mut ClipScratch::default());
        assert_eq!(m.len, 4);
        let mut corners: Vec<(i64, i64)> =
            m.points().iter().map(|p| ((p.x * 2.0) as i64, (p.z * 2.0) as i64)).collect();
        corners.sort_unstable();
        assert_eq!(corners, [(-1, -1), (-1, 1), (1, -1), (1, 1)]);
        // Halfway between the corner 1 mm deep and the floor's top.
        assert!(m.points().iter().all(|p| (p.y + 0.0005).abs() < 1e-12));
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
        assert_eq!((axis.normal, axis.is_edge()), (Vector::Y, false));
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
        assert!(axis.is_edge(), "{axis:?}");
        // A fast pair's wider reach (speculative distance) does not change which axis wins.
        assert_eq!(contact_axis(&upper, &lower, (0.02, 0.5)), Some(axis));
        assert!((axis.normal - Vector::Y).length() < 1e-12, "{axis:?}");
        assert!((axis.separation + 0.01).abs() < 1e-12, "{axis:?}");
        let p = support_point(&upper, &lower, &axis);
        assert!((p - Vector::new(0.0, h - 0.005, 0.0)).length() < 1e-12, "halfway between the edges: {p}");
        assert_eq!(
            manifold(&upper, &lower, &axis, 0.02, &mut ClipScratch::default()).len,
            0,
            "edges meet at one point"
        );
    }
}
