//! `integrate`: advances velocities and poses by one step (PHYSICS.md §2.7, errata E15, E16).
//!
//! Linear: semi-implicit (symplectic) Euler, `v += g·dt; x += v·dt`.
//! Angular: torque-free, so the world angular momentum L is constant; the orientation moves by
//! the midpoint rule with L fixed (the default scheme of §2.7), and ω is recomputed from L at
//! the new orientation. The paper keeps ω constant and applies it as Euler-angle increments,
//! which never shows the intermediate-axis flip and drifts L by 6 % (E15, E16).

use crate::bodies::rotate_tensor;
use crate::math::{exp_map, Mat3, Quat, Scalar, Vector};
use crate::step::StepContext;
use hecs::World;
use rayon::prelude::*;

/// One torque-free rotation step with L fixed, midpoint rule (PHYSICS.md §2.7):
///
/// ```text
/// L   = R I_b Rᵀ ω
/// q_h = normalize(exp(ω dt/2) ⊗ q);   ω_h = R(q_h) I_b⁻¹ R(q_h)ᵀ L
/// q'  = normalize(exp(ω_h dt) ⊗ q);   ω'  = R(q') I_b⁻¹ R(q')ᵀ L
/// ```
/// Returns `(q', ω')`. For isotropic inertia ω is constant and q' = exp(ω dt) q exactly.
#[must_use]
pub fn rotate_free(q: Quat, omega: Vector, inertia: Mat3, inv_inertia: Mat3, dt: Scalar) -> (Quat, Vector) {
    let l = rotate_tensor(q, inertia) * omega;
    let q_half = (exp_map(omega * (0.5 * dt)) * q).normalize();
    let omega_half = rotate_tensor(q_half, inv_inertia) * l;
    let q_next = (exp_map(omega_half * dt) * q).normalize();
    (q_next, rotate_tensor(q_next, inv_inertia) * l)
}

/// Advances every non-fixed body; fixed bodies never move.
///
/// - Reads: `ctx.bodies`, `ctx.dt`, `ctx.params.gravity`.
/// - Writes: `ctx.bodies` poses, velocities, world inverse inertia (and the world's); marks
///   every body for re-posing.
/// - Paper: integration; PHYSICS.md §2.7, errata E15, E16.
/// - Cost: O(N), in parallel, each row written by one thread.
pub fn integrate(world: &mut World, ctx: &mut StepContext) {
    let (dt, g) = (ctx.dt, ctx.params.gravity);
    let b = &mut ctx.bodies;
    let rows = b.position.par_iter_mut().zip(b.orientation.par_iter_mut()).zip(b.velocity.par_iter_mut());
    let rest = b.angular_velocity.par_iter_mut().zip(b.inv_inertia_world.par_iter_mut());
    let fixed = (&b.inv_mass, &b.inertia_body, &b.inv_inertia_body);
    rows.zip(rest).enumerate().for_each(|(i, (((x, q), v), (w, inv_w)))| {
        if fixed.0[i] == 0.0 {
            return;
        }
        *v += g * dt;
        *x += *v * dt;
        (*q, *w) = rotate_free(*q, *w, fixed.1[i], fixed.2[i], dt);
        *inv_w = rotate_tensor(*q, fixed.2[i]);
    });
    for i in 0..ctx.bodies.len() {
        ctx.mark_moved(i);
    }
    ctx.bodies.store(world);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_spin_of_a_cube_matches_the_exponential_map() {
        // T-rot: ω = (1,1,0), 100 steps of 0.01 s: rotation by √2 rad about (1,1,0)/√2.
        let (i, inv) = (Mat3::IDENTITY / 6.0, Mat3::IDENTITY * 6.0);
        let (mut q, mut w) = (Quat::IDENTITY, Vector::new(1.0, 1.0, 0.0));
        for _ in 0..100 {
            (q, w) = rotate_free(q, w, i, inv, 0.01);
        }
        let want = Quat::from_axis_angle(Vector::new(1.0, 1.0, 0.0).normalize(), 2f64.sqrt());
        assert!(q.angle_between(want) < 1e-12, "{}", q.angle_between(want));
        assert!((w - Vector::new(1.0, 1.0, 0.0)).length() < 1e-14);
    }
}
