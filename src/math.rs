//! Numeric types and rotations. The engine is f64 throughout, and only this file names glam.
//!
//! Conventions (docs/physics.md §0): SI units, radians inside, +y up, right-handed;
//! quaternions map body to world; scene Euler angles mean R = Rz(γ)·Ry(β)·Rx(α).

/// The one floating-point type of the engine.
pub type Scalar = f64;
/// A 3-vector in f64 (position [m], velocity [m/s], ...).
pub type Vector = glam::DVec3;
/// A unit quaternion in f64, body → world.
pub type Quat = glam::DQuat;
/// A 3×3 matrix in f64 (inertia tensors, rotations).
pub type Mat3 = glam::DMat3;

/// Below this rotation angle [rad] the exponential map uses its first-order form, as
/// docs/physics.md §0 prescribes, so `sin(θ/2)/θ` is never evaluated at 0.
pub const SMALL_ANGLE: Scalar = 1e-12;

/// World-frame inverse inertia R I⁻¹ Rᵀ [1/(kg·m²)]. The paper applies the body-frame
/// tensor directly, which is wrong as soon as the body has turned (docs/physics.md E9).
#[must_use]
pub fn world_inverse_inertia(orientation: Quat, inv_inertia_body: Mat3) -> Mat3 {
    let r = Mat3::from_quat(orientation);
    r * inv_inertia_body * r.transpose()
}

/// The rotation by the rotation vector `theta` (axis × angle [rad]): the exponential map of
/// docs/physics.md §0, `(cos(|θ|/2), sin(|θ|/2) θ/|θ|)`.
#[must_use]
pub fn exp_map(theta: Vector) -> Quat {
    let angle = theta.length();
    if angle < SMALL_ANGLE {
        let half = theta * 0.5;
        return Quat::from_xyzw(half.x, half.y, half.z, 1.0).normalize();
    }
    let (s, c) = (angle * 0.5).sin_cos();
    let axis = theta * (s / angle);
    Quat::from_xyzw(axis.x, axis.y, axis.z, c)
}

/// The orientation of a scene's `rotation: (rx, ry, rz)` [degrees]: R = Rz·Ry·Rx, i.e. rotate
/// about world x, then world y, then world z (docs/physics.md §0; the paper leaves the order open).
#[must_use]
pub fn from_euler_degrees(degrees: Vector) -> Quat {
    let r = degrees * (std::f64::consts::PI / 180.0);
    Quat::from_rotation_z(r.z) * Quat::from_rotation_y(r.y) * Quat::from_rotation_x(r.x)
}

/// True if every component is finite (no NaN, no ±∞).
#[must_use]
pub fn is_finite_vector(v: Vector) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

/// An integer key ordered as `f64::total_cmp` orders `x` (−NaN < −∞ < … < −0 < +0 < … < +∞ <
/// NaN): sorting by it (with a tie-breaking index) sorts as `total_cmp` does, with plain
/// integer comparisons.
#[must_use]
pub fn total_order_key(x: Scalar) -> u64 {
    let bits = x.to_bits();
    // Negative numbers: all bits flipped, so larger magnitudes come first; positive numbers:
    // the sign bit set, so they follow every negative one.
    if bits >> 63 == 1 { !bits } else { bits | 1 << 63 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn total_order_keys_sort_as_total_cmp() {
        let mut rng = crate::rng::SplitMix64::new(3);
        let mut values = vec![0.0, -0.0, 1.0, -1.0, Scalar::INFINITY, Scalar::NEG_INFINITY, Scalar::MIN_POSITIVE];
        values.extend([Scalar::NAN, -Scalar::NAN, 5e-324, -5e-324, Scalar::MAX, Scalar::MIN]);
        values.extend((0..500).map(|_| rng.uniform(-1e3, 1e3)));
        for x in &values {
            for y in &values {
                assert_eq!(total_order_key(*x).cmp(&total_order_key(*y)), x.total_cmp(y), "{x} against {y}");
            }
        }
    }

    #[test]
    fn exp_map_of_quarter_turn_about_z_maps_x_to_y() {
        let q = exp_map(Vector::new(0.0, 0.0, std::f64::consts::FRAC_PI_2));
        let v = q * Vector::X;
        assert!((v - Vector::Y).length() < 1e-15);
    }

    #[test]
    fn euler_order_is_x_then_y_then_z() {
        // x by 90° sends y to z; then z by 90° sends that z unchanged: Rz·Rx (y) = z.
        let q = from_euler_degrees(Vector::new(90.0, 0.0, 90.0));
        assert!((q * Vector::Y - Vector::Z).length() < 1e-15);
        // And x: Rx leaves x, Rz sends x to y.
        assert!((q * Vector::X - Vector::Y).length() < 1e-15);
    }

    #[test]
    fn world_inverse_inertia_rotates_the_rod_of_case_c2() {
        // docs/physics.md §4 (c2): rod along x turned by Ry(90°) has its small moment along z.
        let inv = Mat3::from_diagonal(Vector::new(150.0, 300.0 / 101.0, 300.0 / 101.0));
        let w = world_inverse_inertia(from_euler_degrees(Vector::new(0.0, 90.0, 0.0)), inv);
        assert!((w.z_axis.z - 150.0).abs() < 1e-12);
        assert!((w.x_axis.x - 300.0 / 101.0).abs() < 1e-12);
    }
}
