//! Property tests of the impulse kernel (docs/physics.md §4 (d), random property test): random
//! masses, inertias, contact geometry and restitution; momentum, angular momentum, Newton's
//! restitution law and the energy change all hold.

use proptest::prelude::*;
use rigid_sandbox::math::{Mat3, Quat, Vector, world_inverse_inertia};
use rigid_sandbox::systems::{BodyState, collision_impulse};
use rigid_sandbox::{Contact, Feature};

fn vector(range: f64) -> impl Strategy<Value = Vector> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vector::new(x, y, z))
}

fn rotation() -> impl Strategy<Value = Quat> {
    (vector(1.0), -3.0..3.0f64)
        .prop_filter("an axis", |(a, _)| a.length() > 1e-3)
        .prop_map(|(a, angle)| Quat::from_axis_angle(a.normalize(), angle))
}

/// A body with mass in [0.1, 10] and a random SPD inertia (random moments, rotated).
fn body() -> impl Strategy<Value = (BodyState, Mat3, f64)> {
    (0.1..10.0f64, vector(5.0), vector(3.0), vector(3.0), (0.05..5.0f64, 0.05..5.0f64, 0.05..5.0f64), rotation())
        .prop_map(|(m, x, v, w, (i1, i2, i3), q)| {
            let inertia_body = Mat3::from_diagonal(Vector::new(i1, i2, i3));
            let inv = world_inverse_inertia(q, inertia_body.inverse());
            let r = Mat3::from_quat(q);
            let inertia = r * inertia_body * r.transpose();
            (
                BodyState { position: x, velocity: v, angular_velocity: w, inv_mass: 1.0 / m, inv_inertia: inv },
                inertia,
                m,
            )
        })
}

fn momentum(b: &BodyState, m: f64) -> Vector {
    m * b.velocity
}

fn angular_momentum(b: &BodyState, inertia: Mat3, m: f64) -> Vector {
    b.position.cross(m * b.velocity) + inertia * b.angular_velocity
}

fn energy(b: &BodyState, inertia: Mat3, m: f64) -> f64 {
    0.5 * m * b.velocity.length_squared() + 0.5 * b.angular_velocity.dot(inertia * b.angular_velocity)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn impulse_conserves_and_obeys_restitution(
        (mut a, ia, ma) in body(),
        (mut b, ib, mb) in body(),
        point in vector(5.0),
        normal in vector(1.0).prop_filter("a direction", |n| n.length() > 1e-2),
        e in 0.0..=1.0f64,
    ) {
        let n = normal.normalize();
        let contact = Contact { point, normal: n, depth: 0.0, feature: Feature::Face };
        let u = |a: &BodyState, b: &BodyState| (a.point_velocity(point) - b.point_velocity(point)).dot(n);
        let u_n = u(&a, &b);
        let before = (momentum(&a, ma) + momentum(&b, mb), angular_momentum(&a, ia, ma) + angular_momentum(&b, ib, mb), energy(&a, ia, ma) + energy(&b, ib, mb));
        let j = collision_impulse(&a, &b, &contact, e);
        if u_n >= 0.0 {
            prop_assert!(j.is_none(), "no impulse when not approaching (E13)");
            return Ok(());
        }
        let j = j.expect("approaching bodies get an impulse");
        prop_assert!(j >= 0.0);
        let spin_before = ia * a.angular_velocity;
        a.apply_impulse(point, j * n);
        b.apply_impulse(point, -j * n);
        let after = (momentum(&a, ma) + momentum(&b, mb), angular_momentum(&a, ia, ma) + angular_momentum(&b, ib, mb), energy(&a, ia, ma) + energy(&b, ib, mb));
        let scale = 1.0 + before.0.length() + before.1.length() + j * 10.0;
        prop_assert!((after.0 - before.0).length() <= 1e-12 * scale, "momentum");
        prop_assert!((after.1 - before.1).length() <= 1e-11 * scale, "angular momentum");
        prop_assert!((u(&a, &b) + e * u_n).abs() <= 1e-11 * (1.0 + u_n.abs()), "u'_n = −e u_n");
        // ΔT = −(1 − e²) u_n² / (2K), with K = −(1 + e) u_n / j.
        let k = -(1.0 + e) * u_n / j;
        let dt_want = -(1.0 - e * e) * u_n * u_n / (2.0 * k);
        prop_assert!((after.2 - before.2 - dt_want).abs() <= 1e-10 * (1.0 + before.2), "energy change");
        // A's spin change r_A × J is perpendicular to n and to r_A.
        let dl = ia * a.angular_velocity - spin_before;
        let r_a = point - a.position;
        prop_assert!(dl.dot(n).abs() <= 1e-9 * (1.0 + dl.length()) && dl.dot(r_a).abs() <= 1e-9 * (1.0 + dl.length() * r_a.length()));
    }
}
