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
use crate::model::mass::equal_moments;
use crate::sim::bodies::rotate_tensor;
use crate::sim::context::StepContext;
use crate::systems::CcdScratch;
use hecs::World;
use rayon::prelude::*;

/// Largest turn [rad] of one splitting step of `rotate_free`: at a quarter radian a thin slab's
/// energy wanders by about 1e-5 of itself a step; at 2.5 rad (150 rad/s at 60 Hz) by several
/// per cent, which impacts then build on.
const MAX_TURN: Scalar = 0.25;

/// Most parts a step's free rotation is split into (a body spinning at 240 000 rad/s at 60 Hz).
const MAX_PARTS: Scalar = 16_000.0;

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
/// Each sub-step is an exact rotation and L is never changed, so L is kept to round-off. The
/// energy error is bounded but grows with the turn per step: a body turning faster than
/// `MAX_TURN` a step takes the splitting in as many equal parts as keep each within it.
#[must_use]
pub fn rotate_free(q: Quat, omega: Vector, axes: Quat, moments: Vector, dt: Scalar) -> (Quat, Vector) {
    if equal_moments(moments) {
        return ((exp_map(omega * dt) * q).normalize(), omega);
    }
    let mut q_p = q * axes;
    let l = q_p * (moments * (q_p.inverse() * omega));
    // ω never exceeds |L| / I_min while the body turns freely.
    let turn = l.length() / moments.min_element() * dt.abs();
    let parts = if turn > MAX_TURN { (turn / MAX_TURN).ceil().min(MAX_PARTS) } else { 1.0 };
    let dt = dt / parts;
    for _ in 0..parts as u32 {
        for (i, h) in [(0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)] {
            let l_b = q_p.inverse() * l;
            let axis = [Vector::X, Vector::Y, Vector::Z][i];
            q_p = (q_p * Quat::from_axis_angle(axis, h * dt * l_b[i] / moments[i])).normalize();
        }
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

    /// A 0.3 × 0.05 × 0.1 m slab of 0.2 kg spinning at 150 rad/s off its principal axes turns
    /// 2.5 rad a 1/60 s step: 600 steps keep its energy to 1e-5 and L to round-off (one
    /// splitting step a frame let the energy wander by per cents).
    #[test]
    fn a_fast_spinning_slab_keeps_its_energy_and_momentum() {
        let moments =
            Vector::new(0.05 * 0.05 + 0.1 * 0.1, 0.3 * 0.3 + 0.1 * 0.1, 0.3 * 0.3 + 0.05 * 0.05) * (0.2 / 12.0);
        let axes = Quat::from_rotation_x(0.4);
        let energy = |q: Quat, w: Vector| {
            let b = (q * axes).inverse() * w;
            0.5 * (moments * b).dot(b)
        };
        let momentum = |q: Quat, w: Vector| (q * axes) * (moments * ((q * axes).inverse() * w));
        let (mut q, mut w) = (Quat::from_rotation_y(0.2), Vector::new(45.0, 150.0, 30.0));
        let (e0, l0) = (energy(q, w), momentum(q, w));
        for _ in 0..600 {
            (q, w) = rotate_free(q, w, axes, moments, 1.0 / 60.0);
            assert!(((energy(q, w) - e0) / e0).abs() < 1e-5, "energy {e0} -> {}", energy(q, w));
        }
        assert!((momentum(q, w) - l0).length() < 1e-12 * l0.length(), "L {l0} -> {}", momentum(q, w));
    }
}
