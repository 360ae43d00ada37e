//! Exact volume, centre of mass and inertia of a closed triangle mesh (docs/physics.md §3).
//!
//! The paper puts the mass at the vertices and the centre of mass at their average (errata E7,
//! E8): both depend on the tessellation and are wrong for a solid. Here every outward triangle
//! and a reference point form a signed tetrahedron, and the sums are exact integrals.

use crate::math::{Mat3, Scalar, Vector};

/// Volume integrals of a closed mesh at unit density [m³, m, kg·m² per kg/m³].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeProps {
    /// Signed volume [m³]: negative when the mesh is wound inside out (§3.3 step 3).
    pub volume: Scalar,
    /// Centroid (centre of mass at uniform density) in the mesh's own coordinates [m].
    pub centroid: Vector,
    /// Inertia tensor about the centroid at density 1 [kg·m²/(kg/m³)]; scale by ρ = m / V.
    pub inertia: Mat3,
}

/// Integrates a closed triangle mesh (docs/physics.md §3.1, Mirtich/Eberly/Tonon).
///
/// With `a, b, c` relative to the reference `o` (the vertex average, to limit cancellation):
/// `D = a·(b×c)`, `V = ΣD/6`, `g = o + ΣD(a+b+c)/(4ΣD)`,
/// `C = (1/120) ΣD (aaᵀ + bbᵀ + ccᵀ + ssᵀ)`, `I_o = tr(C)E − C`, then the parallel-axis shift.
/// Triangles must index into `vertices` (the caller validates).
#[must_use]
pub fn volume_props(vertices: &[Vector], triangles: &[[u32; 3]]) -> VolumeProps {
    let o = vertices.iter().copied().sum::<Vector>() / vertices.len().max(1) as Scalar;
    let mut sum_d = 0.0;
    let mut sum_ds = Vector::ZERO;
    let mut c = Mat3::ZERO;
    for t in triangles {
        let [a, b, cc] = t.map(|i| vertices[i as usize] - o);
        let d = a.dot(b.cross(cc));
        let s = a + b + cc;
        sum_d += d;
        sum_ds += d * s;
        c += d * (outer(a, a) + outer(b, b) + outer(cc, cc) + outer(s, s));
    }
    let volume = sum_d / 6.0;
    if sum_d == 0.0 {
        return VolumeProps { volume, centroid: o, inertia: Mat3::ZERO };
    }
    let offset = sum_ds / (4.0 * sum_d);
    let c = c * (1.0 / 120.0);
    let trace = c.x_axis.x + c.y_axis.y + c.z_axis.z;
    let inertia_o = Mat3::from_diagonal(Vector::splat(trace)) - c;
    // Parallel-axis shift from o to the centroid, with m = V at unit density.
    let shift = volume * (Mat3::from_diagonal(Vector::splat(offset.length_squared())) - outer(offset, offset));
    VolumeProps { volume, centroid: o + offset, inertia: inertia_o - shift }
}

/// The outer product a bᵀ.
#[must_use]
pub fn outer(a: Vector, b: Vector) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Principal axes of a symmetric tensor (docs/physics.md §3.4), by cyclic Jacobi rotations:
/// returns the moments and the rotation P (det +1) with `I = P diag(moments) Pᵀ`. Its columns
/// are the principal axes in the body frame.
#[must_use]
pub fn principal_axes(inertia: Mat3) -> (Vector, Mat3) {
    let mut a = inertia;
    let mut v = Mat3::IDENTITY;
    let at = |m: &Mat3, r: usize, c: usize| m.col(c)[r];
    for _sweep in 0..32 {
        let off = at(&a, 0, 1).abs() + at(&a, 0, 2).abs() + at(&a, 1, 2).abs();
        let diag = at(&a, 0, 0).abs() + at(&a, 1, 1).abs() + at(&a, 2, 2).abs();
        if off <= 1e-16 * diag {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            let apq = at(&a, p, q);
            if apq == 0.0 {
                continue;
            }
            // The plane rotation that zeroes a_pq (Numerical Recipes §11.1): A ← JᵀAJ, V ← VJ.
            let theta = (at(&a, q, q) - at(&a, p, p)) / (2.0 * apq);
            let t = if theta == 0.0 { 1.0 } else { theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt()) };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            let mut j = Mat3::IDENTITY;
            j.col_mut(p)[p] = c;
            j.col_mut(q)[q] = c;
            j.col_mut(q)[p] = s;
            j.col_mut(p)[q] = -s;
            a = j.transpose() * a * j;
            v *= j;
        }
    }
    let moments = Vector::new(at(&a, 0, 0), at(&a, 1, 1), at(&a, 2, 2));
    if v.determinant() < 0.0 {
        v.z_axis = -v.z_axis;
    }
    (moments, v)
}

/// Differences between principal moments below this fraction of the largest are round-off of
/// the integrals: a geodesic sphere is isotropic by its symmetry, yet its computed moments
/// differ in the 16th digit.
const ISOTROPIC_TOLERANCE: Scalar = 1e-12;

/// Principal moments all equal, bit for bit (cubes, and spheres after `isotropic_to_round_off`):
/// any turn leaves such a body's inertia as it is.
#[must_use]
pub fn equal_moments(m: Vector) -> bool {
    m.x == m.y && m.y == m.z
}

/// `inertia` as the exact isotropic tensor (the mean moment on the diagonal) when its principal
/// moments agree to round-off but not bit for bit, else unchanged. Such a body then turns by
/// the exact isotropic rotation instead of the splitting's five (docs/physics.md §2.7), as a
/// sphere should; moments already equal (a cube's) or really different keep their bits.
#[must_use]
pub fn isotropic_to_round_off(inertia: Mat3) -> Mat3 {
    let (moments, _) = principal_axes(inertia);
    let (lo, hi) = (moments.min_element(), moments.max_element());
    if lo != hi && hi > 0.0 && hi - lo <= ISOTROPIC_TOLERANCE * hi {
        Mat3::from_diagonal(Vector::splat(moments.element_sum() / 3.0))
    } else {
        inertia
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Mat3, b: Mat3, tol: Scalar) -> bool {
        (a - b).to_cols_array().iter().all(|x| x.abs() <= tol)
    }

    #[test]
    fn corner_tetrahedron_has_the_exact_products_of_inertia() {
        // docs/physics.md §3.2: V = 1/6, g = 1/4, diagonal 1/80, off-diagonals +1/480 (ρ = 1).
        let v = [Vector::ZERO, Vector::X, Vector::Y, Vector::Z];
        let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let p = volume_props(&v, &t);
        assert!((p.volume - 1.0 / 6.0).abs() < 1e-15);
        assert!((p.centroid - Vector::splat(0.25)).length() < 1e-15);
        let d = 1.0 / 80.0;
        let o = 1.0 / 480.0;
        let want = Mat3::from_cols(Vector::new(d, o, o), Vector::new(o, d, o), Vector::new(o, o, d));
        assert!(close(p.inertia, want, 1e-15), "{:?}", p.inertia);
    }

    #[test]
    fn unit_cube_with_split_top_keeps_its_centroid() {
        // E7: nine vertices (extra one in the top face centre); the vertex average is at z = 5/9.
        let mut v: Vec<Vector> =
            (0..8).map(|k| Vector::new((k >> 2 & 1) as f64, (k >> 1 & 1) as f64, (k & 1) as f64)).collect();
        v.push(Vector::new(0.5, 0.5, 1.0)); // 8: top (z = 1) centre
        // Canonical cube triangles (docs/physics.md §0) with the +z face replaced by a fan of four.
        let t = [
            [4, 6, 7],
            [4, 7, 5],
            [0, 1, 3],
            [0, 3, 2],
            [2, 3, 7],
            [2, 7, 6],
            [0, 4, 5],
            [0, 5, 1],
            [1, 5, 8],
            [5, 7, 8],
            [7, 3, 8],
            [3, 1, 8],
            [0, 2, 6],
            [0, 6, 4],
        ];
        let p = volume_props(&v, &t);
        assert!((p.volume - 1.0).abs() < 1e-14);
        assert!((p.centroid - Vector::splat(0.5)).length() < 1e-14, "{:?}", p.centroid);
        assert!(close(p.inertia, Mat3::from_diagonal(Vector::splat(1.0 / 6.0)), 1e-14));
    }

    #[test]
    fn corner_tetrahedron_principal_moments_are_0_1_and_0_0625() {
        // docs/physics.md §3.2, m = 1 (ρ = 6): moments 0.1 about (1,1,1) and 0.0625 twice.
        let v = [Vector::ZERO, Vector::X, Vector::Y, Vector::Z];
        let p = volume_props(&v, &[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]);
        let (moments, axes) = principal_axes(p.inertia * 6.0);
        let mut m = moments.to_array();
        m.sort_by(f64::total_cmp);
        assert!((m[0] - 0.0625).abs() < 1e-14 && (m[1] - 0.0625).abs() < 1e-14 && (m[2] - 0.1).abs() < 1e-14, "{m:?}");
        let rebuilt = axes * Mat3::from_diagonal(moments) * axes.transpose();
        assert!(close(rebuilt, p.inertia * 6.0, 1e-15));
        assert!((axes.determinant() - 1.0).abs() < 1e-14);
    }

    #[test]
    fn an_icosphere_is_isotropic_to_the_bit_and_boxes_keep_their_integrals() {
        use crate::model::shapes::{box_raw, icosphere_raw};
        for subdivisions in 1..=3 {
            let (v, t) = icosphere_raw(0.5, subdivisions);
            let raw = volume_props(&v, &t).inertia;
            let (moments, _) = principal_axes(raw);
            assert_ne!(moments.min_element(), moments.max_element(), "the integrals' round-off this test is about");
            let snapped = isotropic_to_round_off(raw);
            let mean = moments.element_sum() / 3.0;
            assert_eq!(snapped, Mat3::from_diagonal(Vector::splat(mean)), "S = {subdivisions}");
            assert!(close(snapped, raw, 1e-15 * mean), "S = {subdivisions}: {snapped:?} against {raw:?}");
            // The scaled tensor is isotropic to the bit too, so the body takes the exact rotation.
            let (scaled, axes) = principal_axes(snapped * 2.7);
            assert!(scaled.x == scaled.y && scaled.y == scaled.z && axes == Mat3::IDENTITY, "{scaled:?}");
        }
        // A cube's moments are equal bit for bit already, a brick's differ for real: untouched.
        for size in [Vector::splat(1.0), Vector::new(1.0, 2.0, 3.0), Vector::new(1.0, 1.0, 1.0 + 1e-9)] {
            let (v, t) = box_raw(size);
            let raw = volume_props(&v, &t).inertia;
            assert_eq!(isotropic_to_round_off(raw), raw, "{size}");
        }
    }
}
