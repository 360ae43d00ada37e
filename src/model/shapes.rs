//! The built-in shapes of docs/scenes.md as raw vertex and triangle lists, each built exactly
//! as the contract specifies so every implementation simulates the same solid. `ConvexMesh::new`
//! validates and re-centres them.

use crate::math::{Scalar, Vector};
use std::collections::HashMap;

/// Raw mesh data before validation.
pub type RawMesh = (Vec<Vector>, Vec<[u32; 3]>);

/// Most icosphere subdivisions accepted: n = 5 already has 20 480 triangles, and the narrow
/// phase costs O(F_A·F_B) per pair (docs/physics.md §1.7).
pub const MAX_SUBDIVISIONS: u32 = 5;
/// Fewest and most cylinder segments accepted: a prism needs 3; past 256 the mesh only gets
/// slower, not rounder to any visible degree.
pub const SEGMENTS_RANGE: std::ops::RangeInclusive<u32> = 3..=256;

/// The canonical box of docs/physics.md §0: vertex `k = 4ix + 2iy + iz`, 12 outward triangles.
#[must_use]
pub fn box_raw(size: Vector) -> RawMesh {
    let h = size * 0.5;
    let vertices = (0..8)
        .map(|k| {
            let s = |bit: u32| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
            Vector::new(s(2) * h.x, s(1) * h.y, s(0) * h.z)
        })
        .collect();
    let triangles = vec![
        [4, 6, 7],
        [4, 7, 5],
        [0, 1, 3],
        [0, 3, 2], // +x, −x
        [2, 3, 7],
        [2, 7, 6],
        [0, 4, 5],
        [0, 5, 1], // +y, −y
        [1, 5, 7],
        [1, 7, 3],
        [0, 2, 6],
        [0, 6, 4], // +z, −z
    ];
    (vertices, triangles)
}

/// Regular tetrahedron with the given edge: the alternate cube corners (1,1,1), (1,−1,−1),
/// (−1,1,−1), (−1,−1,1) scaled so their distance (2√2) becomes `edge`.
#[must_use]
pub fn tetrahedron_raw(edge: Scalar) -> RawMesh {
    let s = edge / (2.0 * 2f64.sqrt());
    let vertices = [(1.0, 1.0, 1.0), (1.0, -1.0, -1.0), (-1.0, 1.0, -1.0), (-1.0, -1.0, 1.0)]
        .map(|(x, y, z)| Vector::new(x, y, z) * s)
        .to_vec();
    (vertices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
}

/// Regular octahedron with vertices at (±r,0,0), (0,±r,0), (0,0,±r).
#[must_use]
pub fn octahedron_raw(radius: Scalar) -> RawMesh {
    let r = radius;
    let vertices = vec![
        Vector::new(r, 0.0, 0.0),
        Vector::new(-r, 0.0, 0.0),
        Vector::new(0.0, r, 0.0),
        Vector::new(0.0, -r, 0.0),
        Vector::new(0.0, 0.0, r),
        Vector::new(0.0, 0.0, -r),
    ];
    let triangles = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    (vertices, triangles)
}

/// Icosahedron on the sphere of `radius`, each subdivision splitting every triangle in four
/// and pushing the new vertices out to the sphere (n = 1: 80 triangles).
#[must_use]
pub fn icosphere_raw(radius: Scalar, subdivisions: u32) -> RawMesh {
    let p = (1.0 + 5f64.sqrt()) / 2.0;
    let mut vertices: Vec<Vector> = [
        (-1.0, p, 0.0),
        (1.0, p, 0.0),
        (-1.0, -p, 0.0),
        (1.0, -p, 0.0),
        (0.0, -1.0, p),
        (0.0, 1.0, p),
        (0.0, -1.0, -p),
        (0.0, 1.0, -p),
        (p, 0.0, -1.0),
        (p, 0.0, 1.0),
        (-p, 0.0, -1.0),
        (-p, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vector::new(x, y, z).normalize() * radius)
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vector>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let m = (vertices[a as usize] + vertices[b as usize]).normalize() * radius;
                vertices.push(m);
                (vertices.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = midpoint(a, b, &mut vertices);
            let bc = midpoint(b, c, &mut vertices);
            let ca = midpoint(c, a, &mut vertices);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    (vertices, triangles)
}

/// Prism of `segments` sides approximating a cylinder about y: cap vertices lie on the circle
/// of `radius`, the first at angle 0 on +x; caps at y = ±height/2, fanned from vertex 0.
#[must_use]
pub fn cylinder_raw(radius: Scalar, height: Scalar, segments: u32) -> RawMesh {
    let n = segments;
    let h = height * 0.5;
    let ring = |y: Scalar| {
        (0..n).map(move |i| {
            let a = std::f64::consts::TAU * Scalar::from(i) / Scalar::from(n);
            Vector::new(radius * a.cos(), y, radius * a.sin())
        })
    };
    let vertices: Vec<Vector> = ring(-h).chain(ring(h)).collect();
    let mut triangles = Vec::with_capacity(4 * n as usize);
    for i in 0..n {
        let j = (i + 1) % n;
        // Side quad (bottom i, j; top i, j) as two triangles; orientation is fixed by validation.
        triangles.push([i, n + i, j]);
        triangles.push([j, n + i, n + j]);
    }
    for i in 1..n - 1 {
        triangles.push([0, i, i + 1]);
        triangles.push([n, n + i + 1, n + i]);
    }
    (vertices, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::mesh::ConvexMesh;

    fn build((v, t): RawMesh) -> ConvexMesh {
        ConvexMesh::new(v, t).expect("built-in shapes are valid").0
    }

    #[test]
    fn box_volume_and_inertia_are_exact() {
        // docs/physics.md §3.2: I = (m/12) diag(b²+c², a²+c², a²+b²), at ρ = 1 m = abc = 6.
        let m = build(box_raw(Vector::new(1.0, 2.0, 3.0)));
        assert!((m.volume - 6.0).abs() < 1e-14);
        let d = m.unit_inertia;
        assert!((d.x_axis.x - 13.0 / 2.0).abs() < 1e-13);
        assert!((d.y_axis.y - 10.0 / 2.0).abs() < 1e-13);
        assert!((d.z_axis.z - 5.0 / 2.0).abs() < 1e-13);
    }

    #[test]
    fn regular_tetrahedron_is_isotropic_with_ms2_over_20() {
        // Edge 2√2 at ρ = 1: V = 8/3, I = (16/15) E3 = m s²/20.
        let m = build(tetrahedron_raw(2.0 * 2f64.sqrt()));
        assert!((m.volume - 8.0 / 3.0).abs() < 1e-14);
        for (i, col) in m.unit_inertia.to_cols_array_2d().iter().enumerate() {
            for (j, x) in col.iter().enumerate() {
                let want = if i == j { 16.0 / 15.0 } else { 0.0 };
                assert!((x - want).abs() < 1e-14, "I[{i}][{j}] = {x}");
            }
        }
    }

    #[test]
    fn octahedron_volume_is_four_thirds_r_cubed() {
        let m = build(octahedron_raw(0.5));
        assert!((m.volume - 4.0 / 3.0 * 0.125).abs() < 1e-15);
    }

    #[test]
    fn cylinder_prism_volume_is_exact() {
        // n triangles of area r² sin(2π/n)/2 per cap, times the height.
        let (r, h, n) = (0.5, 2.0, 12);
        let m = build(cylinder_raw(r, h, n));
        let want = f64::from(n) * 0.5 * r * r * (std::f64::consts::TAU / f64::from(n)).sin() * h;
        assert!((m.volume - want).abs() < 1e-14);
        assert_eq!(m.planes.len(), n as usize + 2);
    }

    #[test]
    fn icosphere_counts_and_radius() {
        let m = build(icosphere_raw(1.0, 1));
        assert_eq!((m.triangles.len(), m.vertices.len()), (80, 42));
        assert!((m.radius - 1.0).abs() < 1e-15);
    }
}
