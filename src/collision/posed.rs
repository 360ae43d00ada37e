//! Kernels the detection tests share: posed meshes, point-in-mesh, closest face, segment
//! clipping and penetration depth (docs/physics.md §1.1, §1.5, §2.6).

use crate::math::{Scalar, Vector};
use crate::model::components::Pose;
use crate::model::mesh::{ConvexMesh, Plane};
use std::sync::Arc;

/// Inside tolerance relative to the body's radius: points this far outside a face still count
/// as inside, so bodies placed exactly touching are seen (docs/physics.md §1.1, test (g)); the
/// approach test of §2.5 keeps touching-but-separating bodies from getting impulses.
pub const INSIDE_TOLERANCE: Scalar = 1e-9;

/// Planes this close to the nearest one [fraction of the body's radius] are candidates for a
/// point's "closest face": a corner resting on an edge or next to a neighbour's corner is
/// nearly as close to a side face as to the top, and rounding must not decide which.
pub const FACE_TIE_TOLERANCE: Scalar = 1e-2;

/// Slack of `Posed::reach_box` relative to the radius: a million times the inside tolerance,
/// so the tolerance's widening at any corner sharper than a needle stays within it.
pub const BOUNDS_SLACK: Scalar = 1e-3;

/// Where a body's points can be: a box and a sphere (`Posed::reach`).
#[derive(Clone, Copy, Debug)]
pub struct Reach {
    /// The box, (min, max) [m].
    pub bounds: (Vector, Vector),
    /// The sphere's centre [m].
    pub centre: Vector,
    /// The sphere's radius [m].
    pub radius: Scalar,
}

impl Reach {
    /// True when `p` may be a point of the body.
    #[must_use]
    pub fn contains(&self, p: Vector) -> bool {
        in_box(p, self.bounds) && (p - self.centre).length_squared() <= self.radius * self.radius
    }

    /// True when segment `p`–`q` may meet the body.
    #[must_use]
    pub fn meets_segment(&self, p: Vector, q: Vector) -> bool {
        let d = q - p;
        let t = ((self.centre - p).dot(d) / d.length_squared().max(Scalar::MIN_POSITIVE)).clamp(0.0, 1.0);
        boxes_overlap((p.min(q), p.max(q)), self.bounds) && (p + d * t - self.centre).length() <= self.radius
    }
}

/// Appends `x + r · v` for each of `vertices` to `out` and returns their bounds (min, max), with
/// the arithmetic of glam's `x + r * v`, `min` and `max` lane for lane, one vertex a 4-lane
/// vector (x, y, z, 0): a few vector operations a vertex on an AVX build instead of a score of
/// scalar ones. Each lane sums in glam's order, `x[k] + ((r[0][k]·v.x + r[1][k]·v.y) +
/// r[2][k]·v.z)`, and Rust never fuses a multiply and an add, so every vertex and bound is the
/// same to the bit; `fast_min(lo, w)` is `lo < w ? lo : w`, glam's `min` (`max` likewise).
fn pose_into(vertices: &[Vector], r: crate::math::Mat3, x: Vector, out: &mut Vec<Vector>) -> (Vector, Vector) {
    use wide::f64x4;
    let lanes = |v: Vector| f64x4::new([v.x, v.y, v.z, 0.0]);
    let (c0, c1, c2, at) = (lanes(r.x_axis), lanes(r.y_axis), lanes(r.z_axis), lanes(x));
    let (mut lo, mut hi) = (lanes(Vector::INFINITY), lanes(Vector::NEG_INFINITY));
    out.reserve(vertices.len());
    out.extend(vertices.iter().map(|v| {
        let w = at + (c0 * f64x4::splat(v.x) + c1 * f64x4::splat(v.y) + c2 * f64x4::splat(v.z));
        (lo, hi) = (lo.fast_min(w), hi.fast_max(w));
        let [wx, wy, wz, _] = w.to_array();
        Vector::new(wx, wy, wz)
    }));
    let corner = |v: f64x4| {
        let [cx, cy, cz, _] = v.to_array();
        Vector::new(cx, cy, cz)
    };
    (corner(lo), corner(hi))
}

/// True when `p` lies in the box `(lo, hi)`.
#[must_use]
pub fn in_box(p: Vector, (lo, hi): (Vector, Vector)) -> bool {
    p.cmpge(lo).all() && p.cmple(hi).all()
}

/// True when the boxes `a` and `b` overlap (touching counts).
#[must_use]
pub fn boxes_overlap(a: (Vector, Vector), b: (Vector, Vector)) -> bool {
    a.0.cmple(b.1).all() && b.0.cmple(a.1).all()
}

/// A mesh at a pose: world-space vertices and face planes, computed once per body per step.
#[derive(Clone, Debug)]
pub struct Posed {
    /// The body-frame mesh (topology: triangles, edges).
    pub mesh: Arc<ConvexMesh>,
    /// World centre of mass [m].
    pub position: Vector,
    /// Body → world rotation it was posed at.
    pub orientation: crate::math::Quat,
    /// The same rotation as a matrix.
    pub rotation: crate::math::Mat3,
    /// World vertices, in the mesh's order [m].
    pub vertices: Vec<Vector>,
    /// World face planes, in the mesh's order (`Posed::all_planes`): turned when posed for a
    /// small mesh; for a many-faced one, whose tests mostly visit a few planes near the contact
    /// (`Posed::plane` turns one), only when a test first needs them all in a step.
    planes: std::sync::OnceLock<Vec<Plane>>,
    /// World feature-edge directions, in the mesh's order (empty for a many-faced mesh).
    pub edge_directions: Vec<Vector>,
    /// World centroids of the triangles, in the mesh's order [m] (the face test's points:
    /// found once per body and step, not once per pair and direction; empty for a many-faced
    /// mesh, whose face test finds the few near the contact: `Posed::centroid`).
    pub centroids: Vec<Vector>,
    /// World axis-aligned bounds of the vertices, (min, max) [m].
    pub bounds: (Vector, Vector),
}

impl Posed {
    /// Poses `mesh` at `pose`.
    #[must_use]
    pub fn new(mesh: Arc<ConvexMesh>, pose: &Pose) -> Self {
        let mut posed = Self {
            mesh,
            position: Vector::ZERO,
            orientation: crate::math::Quat::IDENTITY,
            rotation: crate::math::Mat3::IDENTITY,
            vertices: Vec::new(),
            planes: std::sync::OnceLock::new(),
            edge_directions: Vec::new(),
            centroids: Vec::new(),
            bounds: (Vector::ZERO, Vector::ZERO),
        };
        posed.update(pose);
        posed
    }

    /// Re-poses in place, reusing the buffers (allocation-free once sized).
    pub fn update(&mut self, pose: &Pose) {
        let r = crate::math::Mat3::from_quat(pose.orientation);
        let x = pose.position;
        (self.position, self.orientation, self.rotation) = (x, pose.orientation, r);
        let many = crate::collision::hull::is_many_faced(self);
        self.vertices.clear();
        self.bounds = pose_into(&self.mesh.vertices, r, x, &mut self.vertices);
        let mut planes = self.planes.take().unwrap_or_default();
        planes.clear();
        self.edge_directions.clear();
        // A many-faced body's tests use its planes and edges near the contact only.
        if !many {
            planes.extend(self.mesh.planes.iter().map(|&p| turned(p, r, x)));
            self.planes.set(planes).expect("taken just above");
            self.edge_directions.extend(self.mesh.edge_directions.iter().map(|&d| r * d));
        }
        self.centroids.clear();
        if many {
            return;
        }
        let vertices = &self.vertices;
        self.centroids.extend(self.mesh.triangles.iter().map(|t| {
            let [p0, p1, p2] = t.map(|i| vertices[i as usize]);
            (p0 + p1 + p2) / 3.0
        }));
    }

    /// The world centroid of triangle `t`.
    #[must_use]
    pub fn centroid(&self, t: usize) -> Vector {
        self.centroids.get(t).copied().unwrap_or_else(|| {
            let [p0, p1, p2] = self.mesh.triangles[t].map(|i| self.vertices[i as usize]);
            (p0 + p1 + p2) / 3.0
        })
    }

    /// World plane `f`.
    #[must_use]
    pub fn plane(&self, f: usize) -> Plane {
        match self.planes.get() {
            Some(planes) => planes[f],
            None => turned(self.mesh.planes[f], self.rotation, self.position),
        }
    }

    /// How many face planes.
    #[must_use]
    pub fn plane_count(&self) -> usize {
        self.mesh.planes.len()
    }

    /// Every world plane, in order.
    pub fn all_planes(&self) -> impl Iterator<Item = Plane> + '_ {
        self.world_planes().iter().copied()
    }

    /// This body's bounds and bounding sphere widened by `BOUNDS_SLACK` of its radius: every
    /// point that `is_inside` accepts lies within both, so a test may skip the features of
    /// another body outside them without changing its answer (and, iterating the rest in
    /// order, its sums).
    #[must_use]
    pub fn reach(&self) -> Reach {
        let slack = BOUNDS_SLACK * self.mesh.radius;
        Reach {
            bounds: (self.bounds.0 - Vector::splat(slack), self.bounds.1 + Vector::splat(slack)),
            centre: self.position,
            radius: self.mesh.radius + slack,
        }
    }

    /// The inside tolerance for this body [m].
    #[must_use]
    pub fn tolerance(&self) -> Scalar {
        INSIDE_TOLERANCE * self.mesh.radius
    }

    /// The outward normal of the face of this body (B) closest to inside point `p`, for a
    /// contact with `other` (A): docs/physics.md §1.1's closest face, with near ties (within
    /// `FACE_TIE_TOLERANCE`) going to the face along which the bodies overlap least (§2.6's
    /// depth), then to the one facing A (§6.5): a corner of a box beside another may dip a hair
    /// below its bottom face, yet the side is the contact normal.
    #[must_use]
    pub fn closest_face_normal(&self, p: Vector, other: &Self) -> Vector {
        self.closest_face_normal_from(p, other, [None; 2])
    }

    /// `closest_face_normal` with walks over `other` and this body starting at `hints`.
    #[must_use]
    pub fn closest_face_normal_from(&self, p: Vector, other: &Self, hints: [Option<u32>; 2]) -> Vector {
        self.closest_face_normal_given(p, self.max_plane_distance(p), other, hints)
    }

    /// `closest_face_normal_from` for a caller that has `best = self.max_plane_distance(p)`.
    #[must_use]
    pub fn closest_face_normal_given(&self, p: Vector, best: Scalar, other: &Self, hints: [Option<u32>; 2]) -> Vector {
        let tie = FACE_TIE_TOLERANCE * self.mesh.radius;
        let toward = other.position - self.position;
        let mut chosen = (Scalar::INFINITY, Scalar::NEG_INFINITY, Vector::ZERO);
        // The candidates' normals are close: each walk starts where the last one ended.
        let mut hints = hints;
        let mut consider = |normal: Vector| {
            let (depth, facing) = (depth_along_from(other, self, normal, &mut hints), normal.dot(toward));
            if depth < chosen.0 || (depth == chosen.0 && facing > chosen.1) {
                chosen = (depth, facing, normal);
            }
        };
        let (q, planes, turn) = self.planes_for(p);
        if let Some(r) = turn {
            let mut near = Vec::new();
            crate::collision::planes::planes_above(&self.mesh, q, best - tie, &mut near);
            near.iter().for_each(|&f| consider(r * self.mesh.planes[f as usize].normal));
        } else {
            planes.iter().filter(|pl| pl.normal.dot(q) - pl.offset >= best - tie).for_each(|pl| consider(pl.normal));
        }
        chosen.2
    }

    /// Largest signed distance of `p` to a face plane: `p` is inside iff it is ≤ the inside
    /// tolerance, and minus it is the depth below the closest face (docs/physics.md §1.1).
    #[must_use]
    pub fn max_plane_distance(&self, p: Vector) -> Scalar {
        let (q, planes, turn) = self.planes_for(p);
        if turn.is_some() {
            return crate::collision::planes::max_distance(&self.mesh, q);
        }
        planes.iter().map(|pl| pl.normal.dot(q) - pl.offset).fold(Scalar::NEG_INFINITY, Scalar::max)
    }

    /// The planes to measure `p` against, `p` in their frame, and the rotation that takes their
    /// normals to the world: a small mesh's world planes, or a many-faced mesh's body-frame
    /// planes with `p` taken into the body frame, so no plane need be turned.
    fn planes_for(&self, p: Vector) -> (Vector, &[Plane], Option<crate::math::Mat3>) {
        if !self.mesh.is_many_faced() {
            (p, self.world_planes(), None)
        } else {
            (self.rotation.transpose() * (p - self.position), &self.mesh.planes, Some(self.rotation))
        }
    }

    fn world_planes(&self) -> &[Plane] {
        self.planes.get_or_init(|| self.mesh.planes.iter().map(|&p| turned(p, self.rotation, self.position)).collect())
    }

    /// The face whose outward normal is most along `dir` (world), with that cosine.
    #[must_use]
    pub fn most_along(&self, dir: Vector) -> Option<(Scalar, usize)> {
        if !self.mesh.is_many_faced() {
            let planes = self.world_planes();
            return planes.iter().enumerate().map(|(f, pl)| (pl.normal.dot(dir), f)).max_by(|x, y| x.0.total_cmp(&y.0));
        }
        most_along_grouped(&self.mesh, self.rotation.transpose() * dir)
    }
}

/// `most_along` of a many-faced mesh for body-frame `d`, by plane group: the group of the
/// largest bound is scanned first, then only groups whose bound (`n·d ≤ c·d + spread |d|`,
/// past round-off) reaches the best so far. The answer of a scan in index order keeping the
/// last of equal cosines (as `max_by` does), so the same face to the bit.
fn most_along_grouped(mesh: &ConvexMesh, d: Vector) -> Option<(Scalar, usize)> {
    let len = d.length();
    let bound = |g: &crate::model::clusters::PlaneGroup| g.normal.dot(d) + g.spread * len + 1e-12 * len;
    let groups = &mesh.plane_groups;
    let first = groups.iter().enumerate().max_by(|x, y| bound(x.1).total_cmp(&bound(y.1)))?.0;
    let mut best: Option<(Scalar, usize)> = None;
    for k in std::iter::once(first).chain((0..groups.len()).filter(|&k| k != first)) {
        let g = &groups[k];
        if best.is_some_and(|b| bound(g) < b.0) {
            continue;
        }
        for &f in &g.planes {
            let value = mesh.planes[f as usize].normal.dot(d);
            // A later face of an equal cosine wins, as in a scan in index order.
            let wins = |b: (Scalar, usize)| match value.total_cmp(&b.0) {
                std::cmp::Ordering::Greater => true,
                std::cmp::Ordering::Equal => f as usize > b.1,
                std::cmp::Ordering::Less => false,
            };
            if best.is_none_or(wins) {
                best = Some((value, f as usize));
            }
        }
    }
    best
}

/// Body-frame plane `p` in the world, for a body turned by `r` with its centre at `x`.
fn turned(p: Plane, r: crate::math::Mat3, x: Vector) -> Plane {
    let normal = r * p.normal;
    Plane { normal, offset: p.offset + normal.dot(x) }
}

/// Point-in-mesh for convex `b` (docs/physics.md §1.1, erratum E2): inside iff
/// `max_f (p − a_f)·n_f ≤ ε`. The paper dots `p` itself with `n_f`, which can never report a
/// point inside a closed mesh.
///
/// ```
/// # use rigid_sandbox::{collision::posed::{is_inside, Posed}, ConvexMesh, Pose, math::Vector};
/// # use std::sync::Arc;
/// let cube = Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &Pose::IDENTITY);
/// assert!(is_inside(&cube, Vector::new(0.5, 0.0, 0.0)));   // on a face: touching counts
/// assert!(!is_inside(&cube, Vector::new(0.625, 0.0, 0.0)));
/// ```
#[must_use]
pub fn is_inside(b: &Posed, p: Vector) -> bool {
    let eps = b.tolerance();
    let (q, planes, turn) = b.planes_for(p);
    if turn.is_some() {
        return crate::collision::planes::inside(&b.mesh, q, eps);
    }
    planes.iter().all(|pl| pl.normal.dot(q) - pl.offset <= eps)
}

/// Where a segment meets a convex body (docs/physics.md §1.5, Cyrus–Beck form).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clip {
    /// Segment parameter where it enters [0, 1].
    pub t_in: Scalar,
    /// Where it leaves.
    pub t_out: Scalar,
    /// Plane it enters through, if it starts outside.
    pub plane_in: Option<usize>,
    /// Plane it leaves through, if it ends outside.
    pub plane_out: Option<usize>,
}

/// Clips segment `v0 → v1` against the planes of `b`, each pushed out by `eps`; `None` when it
/// misses. Equivalent to the paper's sort-and-test-midpoints procedure for convex `b`, in
/// O(F_B) instead of O(F_B²):
///
/// ```text
/// t_in = 0, t_out = 1
/// for each plane: d0, d1 = signed distances of v0, v1
///     both > 0: miss;  d0 > 0 ≥ d1: entering at d0/(d0−d1);  d0 ≤ 0 < d1: leaving there
/// hit ⇔ t_in < t_out
/// ```
#[must_use]
pub fn clip_segment(b: &Posed, v0: Vector, v1: Vector, eps: Scalar) -> Option<Clip> {
    let (v0, planes, turn) = b.planes_for(v0);
    if turn.is_some() {
        let v1 = b.rotation.transpose() * (v1 - b.position);
        return crate::collision::planes::clip(&b.mesh, v0, v1, eps);
    }
    let mut clip = Clip { t_in: 0.0, t_out: 1.0, plane_in: None, plane_out: None };
    for (f, pl) in planes.iter().enumerate() {
        let d0 = pl.normal.dot(v0) - pl.offset - eps;
        let d1 = pl.normal.dot(v1) - pl.offset - eps;
        if !clip.cut(f, d0, d1) {
            return None;
        }
    }
    Some(clip)
}

impl Clip {
    /// Cuts the clip by plane `f`, where the segment's ends are `d0` and `d1` outside it;
    /// `false` when nothing is left. Of planes cutting at the same parameter the lowest index
    /// is kept, whatever order they come in.
    pub(crate) fn cut(&mut self, f: usize, d0: Scalar, d1: Scalar) -> bool {
        if d0 > 0.0 && d1 > 0.0 {
            return false;
        }
        let lower = |p: Option<usize>| p.is_some_and(|p| f < p);
        if d0 > 0.0 && d1 <= 0.0 {
            let t = d0 / (d0 - d1);
            if t > self.t_in || (t == self.t_in && lower(self.plane_in)) {
                (self.t_in, self.plane_in) = (t, Some(f));
            }
        } else if d0 <= 0.0 && d1 > 0.0 {
            let t = d0 / (d0 - d1);
            if t < self.t_out || (t == self.t_out && lower(self.plane_out)) {
                (self.t_out, self.plane_out) = (t, Some(f));
            }
        }
        self.t_in < self.t_out
    }
}

/// Overlap of the two bodies' projections on `n` (from B to A), docs/physics.md §2.6:
/// `max_b b·n − min_a a·n`, clamped at 0. Moving A by this along `n` separates them.
#[must_use]
pub fn depth_along(a: &Posed, b: &Posed, n: Vector) -> Scalar {
    depth_along_from(a, b, n, &mut [None; 2])
}

/// `depth_along`, a many-faced body's walk starting where `hints` says (the end of an earlier
/// walk along a nearby direction, so only a few steps are left) and leaving its end there.
/// The walk ends at the lowest vertex from any start, so the depth is the same.
pub(crate) fn depth_along_from(a: &Posed, b: &Posed, n: Vector, hints: &mut [Option<u32>; 2]) -> Scalar {
    use crate::collision::hull::is_many_faced;
    let walk = |p: &Posed, dir: Vector, hint: &mut Option<u32>| {
        let (end, value) = crate::collision::hull::walk_from(p, dir, *hint);
        *hint = Some(end);
        value
    };
    let [hint_a, hint_b] = hints;
    let max_b = if is_many_faced(b) {
        -walk(b, -n, hint_b)
    } else {
        b.vertices.iter().map(|v| v.dot(n)).fold(Scalar::NEG_INFINITY, Scalar::max)
    };
    let min_a = if is_many_faced(a) {
        walk(a, n, hint_a)
    } else {
        a.vertices.iter().map(|v| v.dot(n)).fold(Scalar::INFINITY, Scalar::min)
    };
    (max_b - min_a).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::from_euler_degrees;

    fn cube_at(x: Vector, degrees: Vector) -> Posed {
        let pose = Pose { position: x, orientation: from_euler_degrees(degrees) };
        Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &pose)
    }

    #[test]
    fn posing_four_lanes_at_a_time_gives_the_scalar_arithmetic_to_the_bit() {
        let mut rng = crate::rng::SplitMix64::new(21);
        let mut random = || Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5);
        // Icospheres of 642 and 162 vertices and a box.
        let meshes = [3, 2].map(|s| {
            let (v, t) = crate::model::shapes::icosphere_raw(0.5, s);
            ConvexMesh::new(v, t).expect("an icosphere is valid").0
        });
        for mesh in meshes.iter().chain([&ConvexMesh::cuboid(Vector::new(1.0, 2.0, 3.0))]) {
            for _ in 0..30 {
                let axis = random().normalize_or(Vector::Y);
                let turn = crate::math::Quat::from_axis_angle(axis, 7.0 * random().x);
                let (r, x) = (crate::math::Mat3::from_quat(turn), random() * 1e3);
                let mut out = Vec::new();
                let (lo, hi) = pose_into(&mesh.vertices, r, x, &mut out);
                let scalar: Vec<Vector> = mesh.vertices.iter().map(|&v| x + r * v).collect();
                let bits = |p: &[Vector]| p.iter().flat_map(|v| v.to_array().map(f64::to_bits)).collect::<Vec<_>>();
                assert_eq!(bits(&out), bits(&scalar));
                let lo_scalar = scalar.iter().fold(Vector::INFINITY, |a, &b| a.min(b));
                let hi_scalar = scalar.iter().fold(Vector::NEG_INFINITY, |a, &b| a.max(b));
                assert_eq!((lo, hi), (lo_scalar, hi_scalar));
            }
        }
    }

    #[test]
    fn point_in_mesh_matches_t_pim() {
        // docs/physics.md §4 T-PIM: centre inside, (0.6,0,0) outside, (0.5,0,0) on the face inside.
        let cube = cube_at(Vector::ZERO, Vector::ZERO);
        assert!(is_inside(&cube, Vector::ZERO));
        assert!(!is_inside(&cube, Vector::new(0.6, 0.0, 0.0)));
        assert!(is_inside(&cube, Vector::new(0.5, 0.0, 0.0)));
        // The paper's literal test p·n_f < 0 fails for the centre: every p·n_f is 0 (E2).
        assert!(cube.all_planes().all(|pl| Vector::ZERO.dot(pl.normal) >= 0.0));
    }

    #[test]
    fn clip_matches_t_edge() {
        // T-edge: segment (0,0,−2) → (0,0,2) through the unit cube: t_in 0.375, t_out 0.625.
        let cube = cube_at(Vector::ZERO, Vector::ZERO);
        let c = clip_segment(&cube, Vector::new(0.0, 0.0, -2.0), Vector::new(0.0, 0.0, 2.0), 0.0).expect("crosses");
        assert_eq!((c.t_in, c.t_out), (0.375, 0.625));
        assert!(clip_segment(&cube, Vector::new(1.0, 0.0, -2.0), Vector::new(1.0, 0.0, 2.0), 0.0).is_none());
    }

    #[test]
    fn clip_of_crossing_ridges_matches_t_edge() {
        // T-edge (f2 geometry): A = cube Rz(45°) at y = √2 − 0.01, its lowest edge along z;
        // B = cube Rx(45°) at the origin with its ridge along x at y = √2/2.
        let b = cube_at(Vector::ZERO, Vector::new(45.0, 0.0, 0.0));
        let y = 2f64.sqrt() / 2.0 - 0.01;
        let c = clip_segment(&b, Vector::new(0.0, y, -0.5), Vector::new(0.0, y, 0.5), 0.0).expect("crosses");
        assert!((c.t_in - 0.49).abs() < 1e-12 && (c.t_out - 0.51).abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn the_face_most_along_a_direction_by_plane_group_is_the_scanned_one() {
        let mut rng = crate::rng::SplitMix64::new(23);
        let mut random = || Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5);
        for s in [2, 3] {
            let (v, t) = crate::model::shapes::icosphere_raw(0.5, s);
            let mesh = ConvexMesh::new(v, t).expect("an icosphere is valid").0;
            let scan = |d: Vector| {
                let cosines = mesh.planes.iter().enumerate().map(|(f, pl)| (pl.normal.dot(d), f));
                cosines.max_by(|x, y| x.0.total_cmp(&y.0))
            };
            // Random directions, and the axes and diagonals, where faces tie.
            let mut directions: Vec<Vector> = (0..500).map(|_| random()).collect();
            directions.extend([Vector::X, Vector::Y, Vector::Z, -Vector::Y, Vector::ONE, Vector::new(1.0, -1.0, 0.0)]);
            for d in directions {
                assert_eq!(most_along_grouped(&mesh, d), scan(d), "{d}");
            }
        }
    }

    #[test]
    fn depth_of_overlapping_cubes_is_the_overlap() {
        let a = cube_at(Vector::new(-0.99, 0.0, 0.0), Vector::ZERO);
        let b = cube_at(Vector::ZERO, Vector::ZERO);
        assert!((depth_along(&a, &b, -Vector::X) - 0.01).abs() < 1e-15);
    }
}
