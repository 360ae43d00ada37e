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
    let (s, c) = half_turn_sin_cos(angle * 0.5);
    let axis = theta * (s / angle);
    Quat::from_xyzw(axis.x, axis.y, axis.z, c)
}

/// Half-angles up to this [rad] take `half_turn_sin_cos`'s series: every step turns each
/// body a little, and the library's general `sin_cos` (argument reduction, tables) costs more
/// than the rest of the turn.
const SERIES_HALF_ANGLE: Scalar = 0.125;

/// `x.sin_cos()`, by Taylor series for |x| ≤ `SERIES_HALF_ANGLE`: the first omitted terms,
/// x¹³/13! and x¹²/12!, are below 1e-19 of the result there, so each value is the library's
/// to within an ulp (the rounding of its last additions).
#[inline]
fn half_turn_sin_cos(x: Scalar) -> (Scalar, Scalar) {
    if x.abs() > SERIES_HALF_ANGLE {
        return x.sin_cos();
    }
    let x2 = x * x;
    // Small corrections added last, to the leading term, so their rounding stays small.
    let sin_tail =
        x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0 - x2 / 39_916_800.0))));
    let cos_tail = x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 - x2 / 3_628_800.0))));
    (x + x * sin_tail, 1.0 + cos_tail)
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
    fn the_half_turn_series_is_within_an_ulp_of_the_library() {
        let mut rng = crate::rng::SplitMix64::new(3);
        let small = (0..20_000).map(|_| rng.uniform(-SERIES_HALF_ANGLE, SERIES_HALF_ANGLE));
        let edges = [0.0, 1e-300, -1e-9, SERIES_HALF_ANGLE, -SERIES_HALF_ANGLE, 0.3, -2.0];
        let ulps = |a: Scalar, b: Scalar| (a - b).abs() / (Scalar::EPSILON * b.abs().max(Scalar::MIN_POSITIVE));
        let mut worst: Scalar = 0.0;
        for x in small.chain(edges) {
            let ((s, c), (s0, c0)) = (half_turn_sin_cos(x), x.sin_cos());
            worst = worst.max(ulps(s, s0)).max(ulps(c, c0));
        }
        assert!(worst <= 1.0, "worst difference {worst} ulps");
        assert_eq!(half_turn_sin_cos(0.3), 0.3_f64.sin_cos(), "past the series: the library's own");
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
