//! `edge`: the paper's edge test. An edge of one body crossing the other
//! (docs/physics.md §1.5, erratum E4).

use crate::collision::contact::{Contact, Feature};
use crate::collision::hull::{Flood, Hints, Kind, beyond_near_face, features_below, is_many_faced};
use crate::collision::posed::{Posed, clip_segment, depth_along_from};
use crate::math::Scalar;
use crate::sim::context::StepContext;
use hecs::World;

/// Smallest |n_in × n_out| (unit normals) taken as two distinct planes; below it the edge
/// passes through (nearly) parallel faces and the closest-face fallback gives the normal.
const PARALLEL_PLANES: Scalar = 1e-9;
/// The closest face wins over the edge-edge normal when penetration along the edge-edge normal
/// is more than this many times the penetration along the face normal. In docs/physics.md §4 (f2)
/// the ratio is √2 (a true ridge crossing); a misread shallow contact gives 100 or more.
const SHALLOW_FACE: Scalar = 2.0;

/// Gives each remaining candidate pair an edge contact, testing both directions.
///
/// - Reads: `ctx.pairs` (`Candidate` only), `ctx.posed`.
/// - Writes: `ctx.pairs` (`Candidate` → `Found`), `ctx.posed` (fills the cache).
/// - Paper: edge test; docs/physics.md §1.5 and erratum E4.
/// - Cost: O(E_A·F_B + E_B·F_A) per candidate pair (clipping, not the paper's sort).
pub fn edge(_world: &mut World, ctx: &mut StepContext) {
    super::face::detect(ctx, edge_contact_from, Feature::Edge);
}

/// The first edge of `a` (sorted order) that crosses convex `b`: the midpoint of its inside
/// part as the point, and the edge–edge normal `e_A × e_B` with `e_B = n_in × n_out`, the line
/// where the entry and exit planes meet, oriented into the cone of `b`'s outward normals
/// (from `b` to `a`). The paper's `e_A × n_f` lies in the face plane: tangential, no impulse
/// (E4).
#[must_use]
pub fn edge_contact(a: &Posed, b: &Posed) -> Option<Contact> {
    edge_contact_from(a, b, [None; 2], &mut Flood::default())
}

/// `edge_contact` with walks starting at `hints`.
fn edge_contact_from(a: &Posed, b: &Posed, hints: Hints, flood: &mut Flood) -> Option<Contact> {
    let eps = b.tolerance();
    let reach = b.reach();
    // The near-face walks start at b's vertex nearest a (its centre walk's end): the edges
    // tried lie around it, and any start gives a sound proof.
    let (many, mut hint) = (is_many_faced(b), hints[1].unwrap_or(0));
    if is_many_faced(a) {
        features_below(a, b, (Kind::Edges, &hints), flood);
    }
    // The flood's edges, or all of them: two plain iterators, not a boxed one (no allocation
    // a call).
    let (flooded, all) = match is_many_faced(a) {
        true => (&flood.features[..], &[][..]),
        false => (&[][..], &a.mesh.edges[..]),
    };
    let edges = flooded.iter().map(|&k| &a.mesh.edges[k as usize]).chain(all);
    for &[i, j] in edges {
        let (v0, v1) = (a.vertices[i as usize], a.vertices[j as usize]);
        if !reach.meets_segment(v0, v1) || (many && beyond_near_face(b, &[v0, v1], eps, &mut hint)) {
            continue; // a segment outside b's bounds, or beyond one of its faces, cannot cross b
        }
        let Some(clip) = clip_segment(b, v0, v1, eps) else { continue };
        let point = v0 + 0.5 * (clip.t_in + clip.t_out) * (v1 - v0);
        let e_a = v1 - v0;
        let crossing = match (clip.plane_in, clip.plane_out) {
            (Some(fi), Some(fo)) => {
                let (n_in, n_out) = (b.plane(fi).normal, b.plane(fo).normal);
                let e_b = n_in.cross(n_out);
                let n = e_a.cross(e_b);
                // The guard of §1.5: a positive combination of the two outward normals.
                (e_b.length() > PARALLEL_PLANES && n.length() > PARALLEL_PLANES * e_a.length() * e_b.length())
                    .then(|| n.normalize())
                    .map(|n| if n.dot(n_in + n_out) < 0.0 { -n } else { n })
            }
            _ => None,
        };
        let face = b.closest_face_normal_from(point, a, hints);
        let mut h = hints;
        let mut depth = |n| depth_along_from(a, b, n, &mut h);
        let normal = match crossing {
            // The entry and exit planes meet in B's edge only if the segment passes near it. An
            // edge of A just under a face of B (a box across two others in a pyramid) crosses
            // two side faces instead, giving a sideways normal a whole body deep: take the
            // face when it is the clear minimum (§6.5).
            Some(n) if depth(n) > SHALLOW_FACE * depth(face) + b.tolerance() => face,
            Some(n) => n,
            None => face,
        };
        return Some(Contact { point, normal, depth: depth(normal), feature: Feature::Edge });
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Vector, from_euler_degrees};
    use crate::model::components::Pose;
    use crate::model::mesh::ConvexMesh;
    use std::sync::Arc;

    fn cube(x: Vector, degrees: Vector) -> Posed {
        let pose = Pose { position: x, orientation: from_euler_degrees(degrees) };
        Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &pose)
    }

    #[test]
    fn crossing_ridges_give_the_vertical_edge_edge_normal() {
        // docs/physics.md §4 (f2), x_A = 0.25: p = (0.25, √2/2 − 0.01, 0), n = (0, 1, 0).
        let h = 2f64.sqrt();
        let a = cube(Vector::new(0.25, h - 0.01, 0.0), Vector::new(0.0, 0.0, 45.0));
        let b = cube(Vector::ZERO, Vector::new(45.0, 0.0, 0.0));
        let c = edge_contact(&a, &b).expect("A's lowest edge crosses B's ridge");
        assert!((c.point - Vector::new(0.25, h / 2.0 - 0.01, 0.0)).length() < 1e-9, "{c:?}");
        assert!((c.normal - Vector::Y).length() < 1e-12, "{c:?}");
        assert!((c.depth - 0.01).abs() < 1e-12);
    }
}
