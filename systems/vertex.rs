//! `vertex`: the paper's vertex test. Vertices of one body inside the other
//! (docs/physics.md §1.4, erratum E5).

use crate::collision::contact::{Contact, Feature};
use crate::collision::hull::{Flood, Hints, Kind, features_below, is_many_faced, outside_near_face};
use crate::collision::posed::{Posed, depth_along_from, is_inside};
use crate::math::{Scalar, Vector};
use crate::sim::context::StepContext;
use hecs::World;

/// Gives each remaining candidate pair a vertex contact, testing both directions.
///
/// - Reads: `ctx.pairs` (`Candidate` only), `ctx.posed`.
/// - Writes: `ctx.pairs` (`Candidate` → `Found`), `ctx.posed` (fills the cache).
/// - Paper: vertex test; docs/physics.md §1.4 and erratum E5.
/// - Cost: O(V_A·F_B + V_B·F_A) per candidate pair.
pub fn vertex(_world: &mut World, ctx: &mut StepContext) {
    super::face::detect(ctx, vertex_contact_from, Feature::Vertex);
}

/// All vertices of `a` inside convex `b` as one contact: their mean point, the outward normal
/// of `b`'s face closest to the deepest one (so from `b` to `a`), and the projection overlap
/// as depth (§2.6). The mean, not the paper's first vertex, keeps an edge landing flat from
/// spinning (E5).
#[must_use]
pub fn vertex_contact(a: &Posed, b: &Posed) -> Option<Contact> {
    vertex_contact_from(a, b, [None; 2], &mut Flood::default())
}

/// `vertex_contact` with walks starting at `hints`.
fn vertex_contact_from(a: &Posed, b: &Posed, hints: Hints, flood: &mut Flood) -> Option<Contact> {
    let eps = b.tolerance();
    let (mut sum, mut count) = (Vector::ZERO, 0_u32);
    let mut deepest = (Scalar::INFINITY, Vector::ZERO);
    let reach = b.reach();
    // The near-face walks start at b's vertex nearest a (its centre walk's end): the points
    // tried lie around it, and any start gives a sound proof.
    let (many, mut hint) = (is_many_faced(b), hints[1].unwrap_or(0));
    // Only vertices within b's bounds can be inside it: on a many-faced body, a handful, and
    // of those most are shown outside by a face near them before all faces are tried.
    if is_many_faced(a) {
        features_below(a, b, (Kind::Vertices, &hints), flood);
    }
    // The flood's vertices, or all of them: two plain iterators, not a boxed one (no
    // allocation a call).
    let (flooded, all) = match is_many_faced(a) {
        true => (&flood.features[..], &[][..]),
        false => (&[][..], &a.vertices[..]),
    };
    let candidates = flooded.iter().map(|&i| &a.vertices[i as usize]).chain(all);
    let candidates = candidates.filter(|&&v| reach.contains(v));
    // On a many-faced body most candidates are outside: the point-in-mesh test leaves them at
    // the first plane they are beyond, and only the inside ones need the largest distance.
    let outside = |v: Vector, hint: &mut u32| many && (outside_near_face(b, v, eps, hint) || !is_inside(b, v));
    for &v in candidates.filter(|&&v| !outside(v, &mut hint)) {
        let s = b.max_plane_distance(v);
        if s <= eps {
            sum += v;
            count += 1;
            if s < deepest.0 {
                deepest = (s, v);
            }
        }
    }
    if count == 0 {
        return None;
    }
    // `deepest.0` is the deepest vertex's largest plane distance, found above.
    let normal = b.closest_face_normal_given(deepest.1, deepest.0, a, hints);
    Some(Contact {
        point: sum / Scalar::from(count),
        normal,
        depth: depth_along_from(a, b, normal, &mut hints.clone()),
        feature: Feature::Vertex,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::components::Pose;
    use crate::model::mesh::ConvexMesh;
    use crate::model::shapes::octahedron_raw;
    use std::sync::Arc;

    #[test]
    fn octahedron_tip_in_floor_gives_exact_contact() {
        // Tip at y = 0.375, 0.125 below the floor's top face: exact in binary, so assert_eq!.
        let floor = Posed::new(Arc::new(ConvexMesh::cuboid(Vector::new(4.0, 1.0, 4.0))), &Pose::IDENTITY);
        let (v, t) = octahedron_raw(0.5);
        let octahedron = Arc::new(ConvexMesh::new(v, t).expect("valid").0);
        let tip = Posed::new(octahedron, &Pose::from_position(Vector::Y * 0.875));
        let c = vertex_contact(&tip, &floor).expect("the tip is inside the floor");
        assert_eq!((c.point, c.normal, c.depth), (Vector::Y * 0.375, Vector::Y, 0.125));
    }
}
