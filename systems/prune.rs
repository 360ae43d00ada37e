//! `prune`: drops candidate pairs that a separating axis proves apart. Not a paper stage: an
//! early-out that keeps the paper's three tests as the deciders of every contact, because none
//! of them can fire on a pair it removes (proof on `separated`).

use crate::contact::PairState;
use crate::geometry::Posed;
use crate::math::{Scalar, Vector};
use crate::step::StepContext;
use hecs::World;
use rayon::prelude::*;

/// Margin of the separation proof, relative to the sum of the radii: 1000× the inside
/// tolerance, so the tests' inclusive slack (which reaches a little past corners) cannot make a
/// pruned pair a contact.
pub const PRUNE_MARGIN: Scalar = 1e-6;

/// Most edge-direction pairs tried as axes: a box pair has 3 × 3; finely tessellated meshes
/// would cost more than the tests they save, so they keep only the face axes.
const MAX_EDGE_AXES: usize = 64;

/// True when an axis separates the two convex bodies by more than the margin: a world axis
/// (bounding boxes apart), the line of centres, a face normal of either body, or the cross product of two feature-edge
/// directions (the separating-axis theorem's candidates). Then every vertex of one lies
/// beyond the other's projection, so no centroid, vertex or edge point of either (convex
/// combinations of vertices) is inside the other: the face, vertex and edge tests all return
/// none.
#[must_use]
pub fn separated(a: &Posed, b: &Posed) -> bool {
    let margin = PRUNE_MARGIN * (a.mesh.radius + b.mesh.radius);
    let apart_on = |axis: Vector| {
        let (lo_a, hi_a) = extent(a, axis);
        let (lo_b, hi_b) = extent(b, axis);
        lo_b - hi_a > margin * axis.length() || lo_a - hi_b > margin * axis.length()
    };
    let faces = |p: &Posed, q: &Posed| {
        p.planes.iter().any(|pl| q.vertices.iter().all(|v| pl.normal.dot(*v) - pl.offset > margin))
    };
    let boxes_apart = (b.bounds.0 - a.bounds.1).max(a.bounds.0 - b.bounds.1).max_element() > margin;
    if boxes_apart || faces(b, a) || faces(a, b) || apart_on(b.position - a.position) {
        return true;
    }
    let (ea, eb) = (&a.edge_directions, &b.edge_directions);
    ea.len() * eb.len() <= MAX_EDGE_AXES
        && ea.iter().any(|&da| eb.iter().any(|&db| da.cross(db).length_squared() > 1e-12 && apart_on(da.cross(db))))
}

/// The interval of `p`'s vertices projected on `axis`.
fn extent(p: &Posed, axis: Vector) -> (Scalar, Scalar) {
    p.vertices.iter().fold((Scalar::INFINITY, Scalar::NEG_INFINITY), |(lo, hi), v| {
        let s = v.dot(axis);
        (lo.min(s), hi.max(s))
    })
}

/// Drops the candidate pairs proved apart, so later systems walk only pairs that may touch
/// (at 64 000 box-gas cubes: 2 400 of 267 000 sphere candidates). The broad phase's count stays
/// in `ctx.stats.candidates`.
///
/// - Reads: `ctx.pairs` (`Candidate` only), `ctx.posed`.
/// - Writes: `ctx.pairs` (removes separated pairs, keeps order), `ctx.posed`.
/// - Paper: none (an early-out before the detection tests of "Collision Detection").
/// - Cost: O(1) for the bounding boxes, then O(V_A + V_B) per axis tried, at most
///   1 + P_A + P_B + 64 axes per pair, with early exits.
pub fn prune(_world: &mut World, ctx: &mut StepContext) {
    ctx.pose_candidates();
    let (posed, radius) = (&ctx.posed, &ctx.bodies.radius);
    ctx.pairs.par_iter_mut().filter(|p| p.is_candidate()).for_each(|pair| {
        // The bounding boxes first, from compact arrays: most candidates end here without
        // touching the posed meshes (the same test `separated` starts with).
        let ((lo_a, hi_a), (lo_b, hi_b)) = (posed.bounds(pair.a), posed.bounds(pair.b));
        let margin = PRUNE_MARGIN * (radius[pair.a as usize] + radius[pair.b as usize]);
        if (lo_b - hi_a).max(lo_a - hi_b).max_element() > margin || separated(posed.get(pair.a), posed.get(pair.b)) {
            pair.state = PairState::Separated;
        }
    });
    ctx.pairs.retain(|p| p.state != PairState::Separated);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::Pose;
    use crate::math::from_euler_degrees;
    use crate::mesh::ConvexMesh;
    use std::sync::Arc;

    fn cube(x: Vector, degrees: Vector) -> Posed {
        let pose = Pose { position: x, orientation: from_euler_degrees(degrees) };
        Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &pose)
    }

    #[test]
    fn touching_cubes_are_not_pruned_but_a_gap_is() {
        let at = |x| cube(Vector::new(x, 0.0, 0.0), Vector::ZERO);
        assert!(!separated(&at(0.0), &at(1.0)));
        assert!(!separated(&at(0.0), &at(0.99)));
        assert!(separated(&at(0.0), &at(1.01)));
    }

    #[test]
    fn crossed_ridges_apart_are_found_only_on_an_edge_axis() {
        // PHYSICS.md §4 (f2) geometry lifted 0.02 above touching: the ridges are 0.01 apart,
        // which no face normal and not the line of centres can show (offset along x).
        let h = 2f64.sqrt();
        let a = cube(Vector::new(0.25, h + 0.01, 0.0), Vector::new(0.0, 0.0, 45.0));
        let b = cube(Vector::ZERO, Vector::new(45.0, 0.0, 0.0));
        assert!(separated(&a, &b));
        // And crossing (0.01 overlap) they are not.
        let a = cube(Vector::new(0.25, h - 0.01, 0.0), Vector::new(0.0, 0.0, 45.0));
        assert!(!separated(&a, &b));
    }
}
