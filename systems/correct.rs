//! `correct`: positional correction of penetration (PHYSICS.md §2.6, erratum E14). Moves
//! positions only: velocities, momentum and kinetic energy are untouched.

use crate::math::{Scalar, Vector};
use crate::step::{Params, StepContext};
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
/// - Writes: `ctx.bodies` positions (and the world's); marks moved bodies for re-posing.
/// - Paper: none (the paper leaves overlaps in place: E14); PHYSICS.md §2.6.
/// - Cost: O(C) for C contacts.
pub fn correct(world: &mut World, ctx: &mut StepContext) {
    let held = ctx.scratch.solve.step == ctx.step && !ctx.scratch.solve.rows.is_empty();
    let mut moved = false;
    for k in 0..ctx.pairs.len() {
        let pair = ctx.pairs[k];
        let Some(contact) = pair.contact() else { continue };
        if held && ctx.scratch.solve.pairs.binary_search_by_key(&(pair.a, pair.b), |p| (p.a, p.b)).is_ok() {
            continue; // held by `solve`: corrected below, at its manifold points
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
        ctx.mark_moved(ia);
        ctx.mark_moved(ib);
        moved = true;
    }
    if held {
        split_impulses(ctx);
        moved = true;
    }
    if moved {
        ctx.bodies.store(world);
    }
}

/// Removes penetration at `solve`'s manifold points with split impulses (Catto's "split
/// impulse"; Bullet): impulses on separate pseudo-velocities, clamped like contact impulses,
/// turned into a displacement and a rotation over one step and then dropped. The real
/// velocities never see them, so resting bodies neither gain energy nor pop apart, and a
/// tilted box is turned back flat rather than only pushed up at one corner.
fn split_impulses(ctx: &mut StepContext) {
    let (dt, beta, slop, cap) = (ctx.dt, ctx.params.correction, ctx.params.slop, ctx.params.max_correction);
    let n = ctx.bodies.len();
    let s = &mut ctx.scratch.solve;
    s.pseudo.clear();
    s.pseudo.resize(n, (Vector::ZERO, Vector::ZERO));
    let b = &ctx.bodies;
    s.lambda.clear();
    s.lambda.resize(s.rows.len(), 0.0);
    // Each row's separation speed, once: capped like the paper-pair correction, so a wrong
    // normal must not throw a body away.
    s.targets.clear();
    s.targets.extend(s.rows.iter().map(|row| {
        let thin = b.thinner(&ctx.meshes, row.a as usize, row.b as usize);
        (beta * (-row.gap - slop * thin)).clamp(0.0, cap * thin) / dt
    }));
    for _ in 0..ctx.params.iterations {
        for ((row, acc), &target) in s.rows.iter().zip(&mut s.lambda).zip(&s.targets) {
            let (ia, ib) = (row.a as usize, row.b as usize);
            let ((va, wa), (vb, wb)) = (s.pseudo[ia], s.pseudo[ib]);
            let n = &row.axes[0];
            let u = (va - vb).dot(n.dir) + wa.dot(n.arm[0]) - wb.dot(n.arm[1]);
            let next = (*acc + (target - u) * n.mass).max(0.0);
            let dj = next - *acc;
            *acc = next;
            s.pseudo[ia].0 += n.dir * (dj * row.inv_mass[0]);
            s.pseudo[ia].1 += n.spin[0] * dj;
            s.pseudo[ib].0 -= n.dir * (dj * row.inv_mass[1]);
            s.pseudo[ib].1 -= n.spin[1] * dj;
        }
    }
    for i in 0..n {
        let (v, w) = ctx.scratch.solve.pseudo[i];
        if v != Vector::ZERO || w != Vector::ZERO {
            let b = &mut ctx.bodies;
            b.position[i] += v * dt;
            b.orientation[i] = (crate::math::exp_map(w * dt) * b.orientation[i]).normalize();
            ctx.mark_moved(i);
        }
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
