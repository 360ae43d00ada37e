//! `integrate`: advances velocities and poses by one step (docs/physics.md §2.7, errata E15, E16).
//!
//! Linear: semi-implicit (symplectic) Euler: `gravity` did `v += g·dt` before the contacts,
//! this does `x += v·dt`.
//! Angular: torque-free, so the world angular momentum L is constant; the orientation moves by
//! the symplectic splitting of §2.7 with L fixed, and ω is recomputed from L at the new
//! orientation (§2.7 compares it with the midpoint scheme and others). The paper keeps ω
//! constant and applies it as Euler-angle increments, which never shows the intermediate-axis
//! flip and drifts L (E15, E16).

use crate::math::{Mat3, Quat, Scalar, Vector, exp_map};
use crate::sim::bodies::rotate_tensor;
use crate::sim::context::StepContext;
use crate::systems::CcdScratch;
use hecs::World;
use rayon::prelude::*;

/// One torque-free rotation step with the world angular momentum L fixed (docs/physics.md §2.7),
/// returning the new orientation and ω.
///
/// Isotropic bodies (equal principal moments) keep ω, and turn exactly by `exp(ω dt)`.
/// Others use the symplectic splitting of Dullweber, Leimkuhler and McLachlan (1997) in the
/// principal frame, `q_p = q ⊗ P`:
///
/// ```text
/// L = R(q_p) Λ R(q_p)ᵀ ω
/// for (axis i, h) in [(1,½), (2,½), (3,1), (2,½), (1,½)]:
///     L_b = R(q_p)ᵀ L;   q_p = normalize(q_p ⊗ rotation(axis i, h·dt·L_b,i / Λ_i))
/// q' = q_p ⊗ P⁻¹;   ω' = R(q_p) Λ⁻¹ R(q_p)ᵀ L
/// ```
/// Each sub-step is an exact rotation and L is never changed, so L is kept to round-off and
/// the energy error stays bounded (docs/physics.md §2.7).
#[must_use]
pub fn rotate_free(q: Quat, omega: Vector, axes: Quat, moments: Vector, dt: Scalar) -> (Quat, Vector) {
    if moments.x == moments.y && moments.y == moments.z {
        return ((exp_map(omega * dt) * q).normalize(), omega);
    }
    let mut q_p = q * axes;
    let l = q_p * (moments * (q_p.inverse() * omega));
    for (i, h) in [(0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)] {
        let l_b = q_p.inverse() * l;
        let axis = [Vector::X, Vector::Y, Vector::Z][i];
        q_p = (q_p * Quat::from_axis_angle(axis, h * dt * l_b[i] / moments[i])).normalize();
    }
    let omega = q_p * ((q_p.inverse() * l) / moments);
    ((q_p * axes.inverse()).normalize(), omega)
}

/// Advances every non-fixed body; fixed bodies never move. A body `ccd` already moved to an
/// impact within the step flies the rest of it from there (docs/physics.md §6.7); every other
/// body the whole step, so without fast bodies the results are those of the plain step.
///
/// - Reads: `ctx.bodies`, `ctx.dt`, the time `ccd` flew each body this step (`CcdScratch`).
/// - Writes: `ctx.bodies` poses, velocities, world inverse inertia; marks
///   every body for re-posing.
/// - Paper: integration; docs/physics.md §2.7, errata E15, E16.
/// - Cost: O(N), in parallel, each row written by one thread.
pub fn integrate(_world: &mut World, ctx: &mut StepContext) {
    let dt = ctx.dt;
    let taken = ctx.scratch.get::<CcdScratch>().and_then(|s| s.taken(ctx.step));
    let b = &mut ctx.bodies;
    let rows = b.position.par_iter_mut().zip(b.orientation.par_iter_mut()).zip(b.velocity.par_iter());
    let rest = b.angular_velocity.par_iter_mut().zip(b.inv_inertia_world.par_iter_mut()).zip(b.rotation.par_iter_mut());
    let props = (&b.inv_mass, &b.principal_axes, &b.principal_moments, &b.inv_inertia_body);
    rows.zip(rest).enumerate().for_each(|(i, (((x, q), v), ((w, inv_w), rotation)))| {
        if props.0[i] == 0.0 {
            return;
        }
        let h = taken.map_or(dt, |t| dt - t[i]);
        *x += *v * h;
        (*q, *w) = rotate_free(*q, *w, props.1[i], props.2[i], h);
        *inv_w = rotate_tensor(*q, props.3[i]);
        *rotation = Mat3::from_quat(*q);
    });
    for i in (0..ctx.bodies.len()).filter(|&i| ctx.bodies.inv_mass[i] != 0.0) {
        ctx.posed.mark_moved(i); // fixed (and sleeping) bodies keep their posed meshes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_spin_of_a_cube_matches_the_exponential_map() {
        // T-rot: ω = (1,1,0), 100 steps of 0.01 s: rotation by √2 rad about (1,1,0)/√2.
        let (mut q, mut w) = (Quat::IDENTITY, Vector::new(1.0, 1.0, 0.0));
        for _ in 0..100 {
            (q, w) = rotate_free(q, w, Quat::IDENTITY, Vector::splat(1.0 / 6.0), 0.01);
        }
        let want = Quat::from_axis_angle(Vector::new(1.0, 1.0, 0.0).normalize(), 2f64.sqrt());
        assert!(q.angle_between(want) < 1e-12, "{}", q.angle_between(want));
        assert_eq!(w, Vector::new(1.0, 1.0, 0.0));
    }
}
