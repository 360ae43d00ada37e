//! `resolve`: the corrected impulse of the paper's "Collision Resolution" (docs/physics.md §2.5,
//! errata E9–E13), applied by sequential sweeps over the step's contacts.
//!
//! Contact model: one contact per pair per step; pairs are swept in (a, b) order with the
//! current velocities, and sweeps repeat until one applies no impulse or `max_sweeps` is
//! reached. This is the "pairwise sequential" model of docs/physics.md §4 (g): a Newton's cradle of
//! touching cubes ends (0, 0, 0, 0, 1). A pair's restitution is the mean of its two actors'.
//!
//! It takes the pairs `solve` leaves: those of scenes without gravity and without friction,
//! the paper's model (docs/physics.md §4). Under gravity or with friction `solve` holds the pair
//! and bounces its impacts itself, over the whole manifold. Only contacts approaching faster
//! than the restitution threshold get an impulse (zero without gravity unless a scene sets
//! one).

use crate::collision::contact::{Contact, PairState};
use crate::math::{Mat3, Scalar, Vector};
use crate::sim::context::StepContext;
use hecs::World;

/// What the impulse needs of one body, in world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    /// Centre of mass [m].
    pub position: Vector,
    /// Linear velocity [m/s].
    pub velocity: Vector,
    /// Angular velocity [rad/s].
    pub angular_velocity: Vector,
    /// 1/m [1/kg] (0 when fixed).
    pub inv_mass: Scalar,
    /// R I⁻¹ Rᵀ [1/(kg·m²)] (zero when fixed).
    pub inv_inertia: Mat3,
}

impl BodyState {
    /// Velocity of the material point at world position `p`.
    #[must_use]
    pub fn point_velocity(&self, p: Vector) -> Vector {
        self.velocity + self.angular_velocity.cross(p - self.position)
    }

    /// Applies impulse `impulse` [N·s] at world point `p`: v += J/m, ω += I⁻¹ (r × J).
    pub fn apply_impulse(&mut self, p: Vector, impulse: Vector) {
        self.velocity += impulse * self.inv_mass;
        self.angular_velocity += self.inv_inertia * (p - self.position).cross(impulse);
    }
}

/// How fast the bodies approach at the contact, `−u_n` [m/s] (negative when separating).
#[must_use]
pub fn approach_speed(a: &BodyState, b: &BodyState, contact: &Contact) -> Scalar {
    -(a.point_velocity(contact.point) - b.point_velocity(contact.point)).dot(contact.normal)
}

/// The impulse magnitude j ≥ 0 on A along the contact normal, or `None` when the bodies do not
/// approach at the contact (E13):
///
/// ```text
/// u_n = [(v_A + ω_A×r_A) − (v_B + ω_B×r_B)]·n          (spin terms inside, E10)
/// K   = 1/m_A + 1/m_B + (r_A×n)·I_A⁻¹(r_A×n) + (r_B×n)·I_B⁻¹(r_B×n)   (world I⁻¹, E9)
/// j   = −(1 + e) u_n / K
/// ```
/// A receives `+j n`, B `−j n` (E11, E12).
#[must_use]
pub fn collision_impulse(a: &BodyState, b: &BodyState, contact: &Contact, restitution: Scalar) -> Option<Scalar> {
    let (p, n) = (contact.point, contact.normal);
    let u_n = (a.point_velocity(p) - b.point_velocity(p)).dot(n);
    if u_n >= 0.0 {
        return None;
    }
    let ka = (p - a.position).cross(n);
    let kb = (p - b.position).cross(n);
    let k = a.inv_mass + b.inv_mass + ka.dot(a.inv_inertia * ka) + kb.dot(b.inv_inertia * kb);
    (k > 0.0).then(|| -(1.0 + restitution) * u_n / k)
}

/// Sweeps the found contacts, applying impulses to the velocities in `ctx.bodies`.
///
/// - Reads: `ctx.pairs` (`Found`, `Resolved`), `ctx.bodies`.
/// - Writes: `ctx.bodies` velocities, `ctx.pairs` (`Found` → `Resolved`),
///   `ctx.stats` (impulses by feature, sweeps).
/// - Paper: collision resolution; docs/physics.md §2.5, errata E9–E13.
/// - Cost: O(C) per sweep for C contacts, at most `max_sweeps` sweeps.
pub fn resolve(_world: &mut World, ctx: &mut StepContext) {
    let threshold = ctx.params.restitution_threshold(ctx.dt);
    let resting = ctx.params.resting_rule(ctx.dt);
    for sweep in 1..=ctx.params.max_sweeps {
        let mut applied = false;
        for pair in &mut ctx.pairs {
            let Some(contact) = pair.contact() else { continue };
            pair.state = PairState::Resolved(contact);
            let (ia, ib) = (pair.a as usize, pair.b as usize);
            let b = &mut ctx.bodies;
            // Where `solve` runs it takes the impacts too: it stops the approach over the whole
            // manifold and bounces each point (`solver::restitution`), where one impulse at one
            // point would set the body turning.
            if resting(b.pair_friction(ia, ib)) {
                continue;
            }
            let (mut sa, mut sb) = (state(b, ia), state(b, ib));
            let e = 0.5 * (b.restitution[ia] + b.restitution[ib]);
            if approach_speed(&sa, &sb, &contact) <= threshold {
                continue;
            }
            let Some(j) = collision_impulse(&sa, &sb, &contact, e) else { continue };
            sa.apply_impulse(contact.point, j * contact.normal);
            sb.apply_impulse(contact.point, -j * contact.normal);
            for (i, s) in [(ia, sa), (ib, sb)] {
                b.velocity[i] = s.velocity;
                b.angular_velocity[i] = s.angular_velocity;
            }
            ctx.stats.count_impulse(contact.feature);
            applied = true;
        }
        ctx.stats.sweeps = sweep;
        if !applied {
            break;
        }
    }
}

/// Row `i` of the snapshot as a `BodyState`.
#[must_use]
pub fn state(b: &crate::sim::bodies::Bodies, i: usize) -> BodyState {
    BodyState {
        position: b.position[i],
        velocity: b.velocity[i],
        angular_velocity: b.angular_velocity[i],
        inv_mass: b.inv_mass[i],
        inv_inertia: b.inv_inertia_world[i],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::contact::Feature;

    fn body(x: Vector, v: Vector, m: Scalar, inv_i: Mat3) -> BodyState {
        BodyState { position: x, velocity: v, angular_velocity: Vector::ZERO, inv_mass: 1.0 / m, inv_inertia: inv_i }
    }

    #[test]
    fn off_centre_hit_on_the_rod_matches_case_c() {
        // docs/physics.md §4 (c), e = 1: j = 202/445, v_A' = −243/445, v_B' = −202/445,
        // ω_B' = −108/89 about z.
        let inv_rod = Mat3::from_diagonal(Vector::new(150.0, 300.0 / 101.0, 300.0 / 101.0));
        let mut a = body(Vector::new(0.9, 0.14, 0.0), -Vector::Y, 1.0, Mat3::IDENTITY * 600.0);
        let mut b = body(Vector::ZERO, Vector::ZERO, 1.0, inv_rod);
        let c = Contact { point: Vector::new(0.9, 0.09, 0.0), normal: Vector::Y, depth: 0.01, feature: Feature::Face };
        let j = collision_impulse(&a, &b, &c, 1.0).expect("approaching");
        assert!((j - 202.0 / 445.0).abs() < 1e-12);
        a.apply_impulse(c.point, j * c.normal);
        b.apply_impulse(c.point, -j * c.normal);
        assert!((a.velocity.y + 243.0 / 445.0).abs() < 1e-12);
        assert!((b.velocity.y + 202.0 / 445.0).abs() < 1e-12);
        assert!((b.angular_velocity.z + 108.0 / 89.0).abs() < 1e-12);
        assert!(a.angular_velocity.length() < 1e-15, "r_A ∥ n: no spin for A");
    }

    #[test]
    fn separating_bodies_get_no_impulse() {
        let a = body(Vector::new(-0.99, 0.0, 0.0), -Vector::X, 1.0, Mat3::IDENTITY * 6.0);
        let b = body(Vector::ZERO, Vector::ZERO, 1.0, Mat3::IDENTITY * 6.0);
        let c =
            Contact { point: Vector::new(-0.49, 0.0, 0.0), normal: -Vector::X, depth: 0.01, feature: Feature::Face };
        assert_eq!(collision_impulse(&a, &b, &c, 1.0), None);
    }
}
