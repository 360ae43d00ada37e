//! `prune`: drops candidate pairs that a face plane of either body proves apart. Not a paper
//! stage: an early-out that keeps the paper's three tests as the deciders of every contact,
//! because none of them can fire on a pair it removes (proof on `separated`).

use crate::contact::PairState;
use crate::geometry::Posed;
use crate::step::StepContext;
use hecs::World;
use rayon::prelude::*;

/// Margin of the separation proof, relative to the sum of the radii: 1000× the inside
/// tolerance, so the tests' inclusive slack (which reaches a little past corners) cannot make a
/// pruned pair a contact.
pub const PRUNE_MARGIN: f64 = 1e-6;

/// True when every vertex of one body lies in front of some face plane of the other by more
/// than the margin. Then no centroid, vertex or edge point of either body is inside the other
/// (all are convex combinations of vertices), so face, vertex and edge tests all return none.
#[must_use]
pub fn separated(a: &Posed, b: &Posed) -> bool {
    let margin = PRUNE_MARGIN * (a.mesh.radius + b.mesh.radius);
    let apart = |p: &Posed, q: &Posed| {
        p.planes.iter().any(|pl| q.vertices.iter().all(|v| pl.normal.dot(*v) - pl.offset > margin))
    };
    apart(b, a) || apart(a, b)
}

/// Marks candidate pairs proved apart as `Separated`.
///
/// - Reads: `ctx.pairs` (`Candidate` only), `ctx.posed`. Writes: `ctx.pairs`, `ctx.posed`.
/// - Paper: none (an early-out before the detection tests of "Collision Detection").
/// - Cost: O(P_A·V_B + P_B·V_A) per candidate pair, with early exits.
pub fn prune(_world: &mut World, ctx: &mut StepContext) {
    ctx.pose_candidates();
    let posed = &ctx.posed;
    ctx.pairs.par_iter_mut().filter(|p| p.is_candidate()).for_each(|pair| {
        if separated(posed.get(pair.a), posed.get(pair.b)) {
            pair.state = PairState::Separated;
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::Pose;
    use crate::math::Vector;
    use crate::mesh::ConvexMesh;
    use std::sync::Arc;

    fn cube(x: f64) -> Posed {
        Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &Pose::from_position(Vector::new(x, 0.0, 0.0)))
    }

    #[test]
    fn touching_cubes_are_not_pruned_but_a_gap_is() {
        assert!(!separated(&cube(0.0), &cube(1.0)));
        assert!(!separated(&cube(0.0), &cube(0.99)));
        assert!(separated(&cube(0.0), &cube(1.01)));
    }
}
