//! `gravity`: external forces change velocities before the contact stages, so a body resting
//! on another is held in the same step gravity pulls it (semi-implicit Euler: v += g·dt here,
//! x += v·dt in `integrate`). Applied after the contacts, a resting body would sink g·dt² every
//! step and be pushed back, never at rest.

use crate::sim::context::StepContext;
use hecs::World;

/// Adds `gravity · dt` to every free body's velocity.
///
/// - Reads: `ctx.params.gravity`, `ctx.dt`, `ctx.bodies`.
/// - Writes: `ctx.bodies` velocities.
/// - Paper: none (the paper has no forces); docs/physics.md §2.7, linear part.
/// - Cost: O(N).
pub fn gravity(_world: &mut World, ctx: &mut StepContext) {
    let dv = ctx.params.gravity * ctx.dt;
    if dv == crate::math::Vector::ZERO {
        return;
    }
    let b = &mut ctx.bodies;
    for (v, &inv_mass) in b.velocity.iter_mut().zip(&b.inv_mass) {
        if inv_mass != 0.0 {
            *v += dv;
        }
    }
}
