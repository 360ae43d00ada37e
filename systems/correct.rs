//! `correct`: positional correction of penetration (docs/physics.md §2.6, erratum E14). Moves
//! positions only: velocities, momentum and kinetic energy are untouched.

use crate::collision::contact::Pair;
use crate::math::{Scalar, Vector};
use crate::sim::context::{Params, StepContext};
use crate::solver::SolveScratch;
use hecs::World;

/// How far to push a pair apart along its normal [m]:
/// `C = min(β · max(depth − slop, 0), cap)`, with slop and cap scaled by the thinner body's
/// thickness.
#[must_use]
pub fn correction(depth: Scalar, thickness: Scalar, params: &Params) -> Scalar {
    (params.correction * (depth - params.slop * thickness).max(0.0)).min(params.max_correction * thickness)
}

/// Pushes every contact's bodies apart in proportion to their inverse masses, which keeps the
/// system's centre of mass fixed (§2.6). It changes the angular momentum about the origin, so
/// conservation tests measure before it or remove it (`Schedule::remove("correct")`).
///
/// - Reads: `ctx.pairs` (`Found`, `Resolved`), `ctx.bodies`, `ctx.meshes`.
/// - Writes: `ctx.bodies` positions; marks moved bodies for re-posing.
/// - Paper: none (the paper leaves overlaps in place: E14); docs/physics.md §2.6.
/// - Cost: O(C) for C contacts.
pub fn correct(_world: &mut World, ctx: &mut StepContext) {
    // The pairs `solve` held this step: its soft contacts push their penetration out.
    let solved: &[Pair] = match ctx.scratch.get::<SolveScratch>() {
        Some(s) if s.step == ctx.step && !s.held.is_empty() => &s.pairs,
        _ => &[],
    };
    // `solve`'s pairs are a subset of these in the same (pair) order: one walk finds them.
    let mut next_held = 0;
    for pair in &ctx.pairs {
        let Some(contact) = pair.contact() else { continue };
        while next_held < solved.len() && (solved[next_held].a, solved[next_held].b) < (pair.a, pair.b) {
            next_held += 1;
        }
        if next_held < solved.len() && (solved[next_held].a, solved[next_held].b) == (pair.a, pair.b) {
            continue;
        }
        let (ia, ib) = (pair.a as usize, pair.b as usize);
        let b = &ctx.bodies;
        let (wa, wb) = (b.inv_mass[ia], b.inv_mass[ib]);
        let thickness = b.thinner(&ctx.meshes, ia, ib);
        let c = correction(contact.depth, thickness, &ctx.params);
        if c <= 0.0 || wa + wb == 0.0 {
            continue;
        }
        let shift: Vector = contact.normal * (c / (wa + wb));
        ctx.bodies.position[ia] += shift * wa;
        ctx.bodies.position[ib] -= shift * wb;
        ctx.posed.mark_moved(ia);
        ctx.posed.mark_moved(ib);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correction_removes_beta_of_the_depth_past_the_slop_and_is_capped() {
        let p = Params { correction: 0.5, slop: 0.01, max_correction: 0.2, ..Params::default() };
        assert_eq!(correction(0.11, 1.0, &p), 0.5 * (0.11 - 0.01));
        assert_eq!(correction(0.005, 1.0, &p), 0.0);
        assert_eq!(correction(5.0, 1.0, &p), 0.2);
    }
}
