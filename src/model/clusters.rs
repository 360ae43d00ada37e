//! A many-faced mesh's face planes grouped by normal, each group with one bound for all its
//! planes: a plane scan tries a few dozen bounds, then only the planes of the groups that pass.

use crate::math::{Scalar, Vector};

/// `count` evenly spread unit directions (a Fibonacci sphere).
fn directions(count: usize) -> Vec<Vector> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as Scalar + 0.5) / count as Scalar;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * k as Scalar;
            Vector::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

/// The index of the direction most along `p`.
fn nearest(directions: &[Vector], p: Vector) -> usize {
    let dots = directions.iter().map(|d| d.dot(p));
    dots.enumerate().max_by(|x, y| x.1.total_cmp(&y.1)).map_or(0, |(k, _)| k)
}

/// Face planes of a many-faced mesh grouped by normal, with a bound on every plane of the
/// group: for any point q (body frame), `n_f·q − d_f ≤ normal·q + spread·|q| − min_offset`.
/// A plane scan skips a whole group whose bound shows none of its planes can matter.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlaneGroup {
    /// The group's direction (unit).
    pub normal: Vector,
    /// Largest `|n_f − normal|` over the group, widened past round-off.
    pub spread: Scalar,
    /// Smallest plane offset `d_f` of the group [m].
    pub min_offset: Scalar,
    /// Plane indices, increasing.
    pub planes: Vec<u32>,
}

impl PlaneGroup {
    /// An upper bound of `n_f·q − d_f` over the group's planes, past the round-off of
    /// computing either side, for `q` at length `len`.
    #[must_use]
    pub fn bound(&self, q: Vector, len: Scalar) -> Scalar {
        let value = self.normal.dot(q) + self.spread * len - self.min_offset;
        value + 1e-12 * (len + self.min_offset.abs())
    }
}

/// The planes grouped by the nearest of about √P evenly spread directions to their normal.
#[must_use]
pub fn plane_groups(planes: &[crate::model::mesh::Plane]) -> Vec<PlaneGroup> {
    let count = ((planes.len() as Scalar).sqrt() as usize).clamp(4, 256);
    let directions = directions(count);
    let mut out: Vec<PlaneGroup> = directions
        .iter()
        .map(|&normal| PlaneGroup { normal, min_offset: Scalar::INFINITY, ..Default::default() })
        .collect();
    for (f, p) in planes.iter().enumerate() {
        let g = &mut out[nearest(&directions, p.normal)];
        g.planes.push(f as u32);
        g.spread = g.spread.max((p.normal - g.normal).length() * (1.0 + 1e-9));
        g.min_offset = g.min_offset.min(p.offset);
    }
    out.retain(|g| !g.planes.is_empty());
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::mesh::ConvexMesh;
    use crate::model::shapes::icosphere_raw;

    #[test]
    fn every_plane_is_in_one_group_whose_bound_holds_it() {
        let (raw_v, raw_t) = icosphere_raw(0.5, 3);
        let mesh = ConvexMesh::new(raw_v, raw_t).expect("an icosphere is valid").0;
        let groups = &mesh.plane_groups;
        assert_eq!(groups.iter().map(|g| g.planes.len()).sum::<usize>(), mesh.planes.len());
        let mut rng = crate::rng::SplitMix64::new(9);
        for _ in 0..200 {
            let q = Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5) * 1.5;
            for g in groups {
                let bound = g.bound(q, q.length());
                let p = &mesh.planes;
                assert!(g.planes.iter().all(|&f| p[f as usize].normal.dot(q) - p[f as usize].offset <= bound));
            }
        }
    }
}
