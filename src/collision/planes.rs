//! Plane scans over a many-faced mesh, in its body frame, that skip each group of planes
//! (`PlaneGroup`) whose bound shows none of its planes can change the answer: the answers of a
//! scan of every plane, for a few dozen bounds and the planes of the groups near the point.

use crate::collision::posed::Clip;
use crate::math::{Scalar, Vector};
use crate::model::clusters::PlaneGroup;
use crate::model::mesh::ConvexMesh;

/// Signed distance of body-frame `q` to plane `f`.
fn distance(m: &ConvexMesh, f: u32, q: Vector) -> Scalar {
    let pl = m.planes[f as usize];
    pl.normal.dot(q) - pl.offset
}

/// True when `q` is within `eps` of every plane's inside.
#[must_use]
pub fn inside(m: &ConvexMesh, q: Vector, eps: Scalar) -> bool {
    let len = q.length();
    m.plane_groups.iter().all(|g| g.bound(q, len) <= eps || g.planes.iter().all(|&f| distance(m, f, q) <= eps))
}

/// The largest signed distance of `q` to a plane: first over the group whose bound is
/// highest, then over the groups whose bound exceeds the best so far.
#[must_use]
pub fn max_distance(m: &ConvexMesh, q: Vector) -> Scalar {
    let len = q.length();
    let group_max =
        |g: &PlaneGroup| g.planes.iter().map(|&f| distance(m, f, q)).fold(Scalar::NEG_INFINITY, Scalar::max);
    let first = m.plane_groups.iter().max_by(|x, y| x.bound(q, len).total_cmp(&y.bound(q, len)));
    let mut best = first.map_or(Scalar::NEG_INFINITY, group_max);
    for g in &m.plane_groups {
        if g.bound(q, len) > best {
            best = best.max(group_max(g));
        }
    }
    best
}

/// The planes `q` is at least `level` above (signed distance ≥ `level`), in increasing order.
pub fn planes_above(m: &ConvexMesh, q: Vector, level: Scalar, out: &mut Vec<u32>) {
    let len = q.length();
    out.clear();
    for g in m.plane_groups.iter().filter(|g| g.bound(q, len) >= level) {
        out.extend(g.planes.iter().copied().filter(|&f| distance(m, f, q) >= level));
    }
    out.sort_unstable();
}

/// `posed::clip_segment` of body-frame `q0 → q1`: a group whose bound puts both ends inside
/// every one of its planes (pushed out by `eps`) neither enters, leaves nor misses, so it is
/// skipped; ties between planes go to the lower index, as in a scan in index order.
#[must_use]
pub fn clip(m: &ConvexMesh, q0: Vector, q1: Vector, eps: Scalar) -> Option<Clip> {
    let mut clip = Clip { t_in: 0.0, t_out: 1.0, plane_in: None, plane_out: None };
    let (l0, l1) = (q0.length(), q1.length());
    for g in m.plane_groups.iter().filter(|g| g.bound(q0, l0) > eps || g.bound(q1, l1) > eps) {
        for &f in &g.planes {
            let (d0, d1) = (distance(m, f, q0) - eps, distance(m, f, q1) - eps);
            if !clip.cut(f as usize, d0, d1) {
                return None;
            }
        }
    }
    Some(clip)
}
