//! GJK (Gilbert, Johnson, Keerthi 1988) on many-faced hulls: a lower bound on the distance
//! between two bodies from support points found by walking vertex neighbours, which proves a
//! pair apart without testing every face against every vertex.

use crate::collision::hull::{Placed, lowest_vertex, lowest_vertex_seeded};
use crate::collision::posed::Posed;
use crate::math::{Scalar, Vector};

/// Up to four points of the Minkowski difference, kept in place (no allocation a step).
#[derive(Clone, Copy, Debug, Default)]
struct Simplex {
    p: [Vector; 4],
    len: usize,
}

impl Simplex {
    fn of(points: &[Vector]) -> Self {
        let mut p = [Vector::ZERO; 4];
        p[..points.len()].copy_from_slice(points);
        Self { p, len: points.len() }
    }

    fn points(&self) -> &[Vector] {
        &self.p[..self.len]
    }

    fn push(&mut self, w: Vector) {
        self.p[self.len] = w;
        self.len += 1;
    }

    /// True when `w` is one of the points, to round-off at the scale `length`: no progress.
    fn holds(&self, w: Vector, length: Scalar) -> bool {
        self.points().iter().any(|&p| (p - w).length_squared() <= 1e-24 * length * length)
    }
}

/// Support points of A − B, each pair of walks starting where the last ended (`ends`).
struct Walks<'a> {
    a: Shape<'a>,
    b: Shape<'a>,
    ends: [u32; 2],
}

impl Walks<'_> {
    /// The support of the Minkowski difference A − B along d: A's highest minus B's lowest.
    fn support(&mut self, d: Vector) -> Vector {
        let (i, wa) = self.a.lowest(-d, self.ends[0]);
        let (j, wb) = self.b.lowest(d, self.ends[1]);
        self.ends = [i, j];
        wa - wb
    }
}

/// Most GJK iterations before giving up on a proof (it then says "not proved apart", which
/// only costs the tests' time).
const GJK_ITERATIONS: usize = 64;

/// A body GJK takes support points of: posed (its world vertices at hand) or placed (only
/// its pose, `hull::Placed`, walking its body-frame vertices). Both give the same vertices.
#[derive(Clone, Copy)]
pub enum Shape<'a> {
    /// World vertices at hand.
    Posed(&'a Posed),
    /// A many-faced body left unposed.
    Placed(Placed<'a>),
}

impl Shape<'_> {
    fn centre(&self) -> Vector {
        match self {
            Self::Posed(p) => p.position,
            Self::Placed(p) => p.position,
        }
    }

    /// The vertex lowest along `dir` walking from `start`, and its world point.
    fn lowest(&self, dir: Vector, start: u32) -> (u32, Vector) {
        match self {
            Self::Posed(p) => {
                let i = lowest_vertex(p, dir, start).0;
                (i, p.vertices[i as usize])
            }
            Self::Placed(p) => {
                let i = p.lowest(dir, start);
                (i, p.vertex(i))
            }
        }
    }

    /// `lowest` from the seed of the cube direction nearest `−dir`.
    fn lowest_seeded(&self, dir: Vector) -> (u32, Vector) {
        match self {
            Self::Posed(p) => {
                let i = lowest_vertex_seeded(p, dir).0;
                (i, p.vertices[i as usize])
            }
            Self::Placed(p) => {
                let i = p.lowest_seeded(dir);
                (i, p.vertex(i))
            }
        }
    }
}

/// True when GJK proves `a` and `b` more than `margin` apart: a direction `v` whose support
/// points bound their distance from below by more than `margin`. `false` when they are within
/// `margin`, overlap, or no proof came within `GJK_ITERATIONS`.
#[must_use]
pub fn proved_apart(a: &Posed, b: &Posed, margin: Scalar) -> bool {
    distance_bound(Shape::Posed(a), Shape::Posed(b), margin) > margin
}

/// A lower bound on the distance between `a` and `b` [m] found by GJK, stopping as soon as it
/// exceeds `enough` (and 0 when they touch, overlap or come within `enough`).
#[must_use]
pub fn distance_bound(a: Shape, b: Shape, enough: Scalar) -> Scalar {
    distance_bound_from(a, b, enough, None).0
}

/// `distance_bound` with the first walks (along the line of centres) started at `starts`, A's
/// and B's vertices, or from the seeds without them; also returns where those walks ended,
/// for the pair's next step. A walk ends at the same vertex from any start, so the answer is
/// the same.
#[must_use]
pub fn distance_bound_from(a: Shape, b: Shape, enough: Scalar, starts: Option<[u32; 2]>) -> (Scalar, [u32; 2]) {
    let (ca, cb) = (a.centre(), b.centre());
    let centre = cb - ca;
    let ((sa, wa), (sb, wb)) = match starts {
        Some([i, j]) => (a.lowest(-centre, i), b.lowest(centre, j)),
        None => (a.lowest_seeded(-centre), b.lowest_seeded(centre)),
    };
    let first = [sa, sb];
    // The first support direction is this line of centres, whose walks just ended at these
    // vertices: walking again from them would stay there.
    let mut first_support = Some(wa - wb);
    let mut walks = Walks { a, b, ends: first };
    let mut simplex = Simplex::default();
    let mut v = ca - cb;
    let mut bound: Scalar = 0.0;
    if v == Vector::ZERO {
        return (bound, first);
    }
    for _ in 0..GJK_ITERATIONS {
        let w = first_support.take().unwrap_or_else(|| walks.support(-v));
        let length = v.length();
        // Every point of A − B lies at least v·w/|v| from the origin along v's direction.
        bound = bound.max(v.dot(w) / length);
        if bound > enough {
            return (bound, first);
        }
        if simplex.holds(w, length) {
            return (bound, first); // no progress: as close as GJK gets (or round-off)
        }
        simplex.push(w);
        match closest_to_origin(&mut simplex) {
            Some(closest) if closest.length() > enough => v = closest,
            _ => return (bound, first), // within `enough` (or overlapping)
        }
    }
    (bound, first)
}

/// How far apart `a` and `b` are along the best axis GJK finds, run until its lower bound is
/// within `tolerance` [m] of the distance it closes in on: that separation [m] (0 when they
/// touch or overlap) and the axis, a unit vector from B to A. Any such axis is a separating
/// axis, so the separation bounds the distance from below (conservative advancement,
/// `toi::meshes_time_of_impact`). `ends` holds where the support walks start and is left
/// where they ended: the next call, at nearby poses, starts there.
#[must_use]
pub fn separation(a: Shape, b: Shape, tolerance: Scalar, ends: &mut [u32; 2]) -> (Scalar, Vector) {
    let (ca, cb) = (a.centre(), b.centre());
    let mut walks = Walks { a, b, ends: *ends };
    let mut simplex = Simplex::default();
    let mut v = ca - cb;
    let mut best = (0.0, Vector::ZERO);
    if v != Vector::ZERO {
        for _ in 0..GJK_ITERATIONS {
            let w = walks.support(-v);
            let length = v.length();
            // Every point of A − B lies at least v·w/|v| from the origin along v's direction.
            let bound = v.dot(w) / length;
            if bound > best.0 {
                best = (bound, v / length);
            }
            if simplex.holds(w, length) || length - best.0 <= tolerance {
                break;
            }
            simplex.push(w);
            match closest_to_origin(&mut simplex) {
                Some(closest) if closest != Vector::ZERO => v = closest,
                _ => break, // touching or overlapping
            }
        }
    }
    *ends = walks.ends;
    best
}

/// The point of the hull of `s` (1 to 4 points) closest to the origin; `s` keeps only the
/// points that point is a combination of. `None` when the origin is inside (or on) the hull.
fn closest_to_origin(s: &mut Simplex) -> Option<Vector> {
    match s.len {
        1 => Some(s.p[0]),
        2 => Some(closest_on_segment(s)),
        3 => Some(closest_on_triangle(s)),
        _ => closest_on_tetrahedron(s),
    }
}

fn closest_on_segment(s: &mut Simplex) -> Vector {
    let [p, q, ..] = s.p;
    let d = q - p;
    let t = -p.dot(d) / d.length_squared().max(Scalar::MIN_POSITIVE);
    if t <= 0.0 {
        *s = Simplex::of(&[p]);
        p
    } else if t >= 1.0 {
        *s = Simplex::of(&[q]);
        q
    } else {
        p + d * t
    }
}

/// Closest point of triangle `s` to the origin by its Voronoi regions (Ericson, "Real-Time
/// Collision Detection", §5.1.5).
fn closest_on_triangle(s: &mut Simplex) -> Vector {
    let [a, b, c, _] = s.p;
    let (ab, ac, ap) = (b - a, c - a, -a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        *s = Simplex::of(&[a]);
        return a;
    }
    let bp = -b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        *s = Simplex::of(&[b]);
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        *s = Simplex::of(&[a, b]);
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = -c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        *s = Simplex::of(&[c]);
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        *s = Simplex::of(&[a, c]);
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        *s = Simplex::of(&[b, c]);
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Closest point of tetrahedron `s` to the origin: the best of the faces the origin lies
/// outside of, or `None` when it is outside none (inside the tetrahedron).
fn closest_on_tetrahedron(s: &mut Simplex) -> Option<Vector> {
    let faces = [[0, 1, 2, 3], [0, 1, 3, 2], [0, 2, 3, 1], [1, 2, 3, 0]];
    let mut best: Option<(Scalar, Vector, Simplex)> = None;
    for [i, j, k, opposite] in faces {
        let (p, q, r) = (s.p[i], s.p[j], s.p[k]);
        let n = (q - p).cross(r - p);
        // The origin is beyond this face when it and the opposite vertex are on either side.
        let (origin_side, other_side) = (n.dot(-p), n.dot(s.p[opposite] - p));
        if origin_side * other_side >= 0.0 {
            continue;
        }
        let mut face = Simplex::of(&[p, q, r]);
        let point = closest_on_triangle(&mut face);
        if best.as_ref().is_none_or(|b| point.length_squared() < b.0) {
            best = Some((point.length_squared(), point, face));
        }
    }
    let (_, point, face) = best?;
    *s = face;
    Some(point)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::manifold::contact_axis_all;
    use crate::math::Quat;
    use crate::model::components::Pose;
    use crate::model::mesh::ConvexMesh;
    use crate::model::shapes::icosphere_raw;
    use crate::rng::SplitMix64;
    use std::sync::Arc;

    fn random_turn(rng: &mut SplitMix64) -> Quat {
        let axis = Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5).normalize_or(Vector::Y);
        Quat::from_axis_angle(axis, 6.3 * rng.unit())
    }

    #[test]
    fn gjk_proves_apart_exactly_the_pairs_farther_than_the_margin() {
        let (v, t) = icosphere_raw(0.5, 1);
        let mesh = Arc::new(ConvexMesh::new(v, t).expect("an icosphere is valid").0);
        let mut rng = SplitMix64::new(5);
        for case in 0..200 {
            let dir = Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5).normalize();
            let a = Posed::new(
                mesh.clone(),
                &Pose { position: dir * (0.9 + 0.3 * rng.unit()), orientation: random_turn(&mut rng) },
            );
            let b = Posed::new(mesh.clone(), &Pose { position: Vector::ZERO, orientation: random_turn(&mut rng) });
            // The true gap of two convex hulls is the largest separation over the SAT axes.
            let gap = contact_axis_all(&a, &b, (0.0, Scalar::INFINITY)).map_or(Scalar::INFINITY, |x| x.separation);
            let margin = 0.01;
            if gap > margin + 1e-9 {
                assert!(proved_apart(&a, &b, margin), "case {case}: gap {gap} not proved");
            }
            if gap <= margin {
                assert!(!proved_apart(&a, &b, margin), "case {case}: gap {gap} 'proved' beyond {margin}");
            }
        }
    }
}
