//! Clusters of a many-faced mesh's features by direction from its centre, each with a
//! bounding sphere in the body frame: a contact test that asks which features may lie near
//! another body tries a few dozen spheres, then only the features of the clusters that pass.

use crate::math::{Scalar, Vector};

/// The features of one cluster and a sphere holding every point of them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cluster {
    /// Centre of the bounding sphere, body frame [m].
    pub centre: Vector,
    /// Its radius [m]: every point of the cluster's vertices, triangles and edges is within it.
    pub radius: Scalar,
    /// Vertex indices, increasing.
    pub vertices: Vec<u32>,
    /// Triangle indices, increasing.
    pub triangles: Vec<u32>,
    /// Edge indices (into the mesh's `edges`), increasing.
    pub edges: Vec<u32>,
}

/// About this many vertices to a cluster.
const VERTICES_PER_CLUSTER: usize = 12;

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

/// Groups the features by the nearest of evenly spread directions (a Fibonacci sphere): a
/// vertex by its own direction, a triangle by its centroid's, an edge by its midpoint's.
#[must_use]
pub fn clusters(vertices: &[Vector], triangles: &[[u32; 3]], edges: &[[u32; 2]]) -> Vec<Cluster> {
    let count = (vertices.len() / VERTICES_PER_CLUSTER).clamp(4, 256);
    let directions = directions(count);
    let nearest = |p: Vector| nearest(&directions, p);
    let mut out = vec![Cluster::default(); count];
    for (i, &v) in vertices.iter().enumerate() {
        out[nearest(v)].vertices.push(i as u32);
    }
    for (t, tri) in triangles.iter().enumerate() {
        let centroid = tri.iter().map(|&i| vertices[i as usize]).sum::<Vector>() / 3.0;
        out[nearest(centroid)].triangles.push(t as u32);
    }
    for (e, &[i, j]) in edges.iter().enumerate() {
        out[nearest(0.5 * (vertices[i as usize] + vertices[j as usize]))].edges.push(e as u32);
    }
    for c in &mut out {
        // Every point of a triangle or an edge is a mean of its vertices, so a sphere holding
        // the vertices holds them.
        let mut corners: Vec<u32> = c.vertices.clone();
        corners.extend(c.triangles.iter().flat_map(|&t| triangles[t as usize]));
        corners.extend(c.edges.iter().flat_map(|&e| edges[e as usize]));
        if corners.is_empty() {
            continue;
        }
        c.centre = corners.iter().map(|&i| vertices[i as usize]).sum::<Vector>() / corners.len() as Scalar;
        c.radius = corners.iter().map(|&i| (vertices[i as usize] - c.centre).length()).fold(0.0, Scalar::max);
    }
    out.retain(|c| !(c.vertices.is_empty() && c.triangles.is_empty() && c.edges.is_empty()));
    out
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
    fn every_feature_is_in_one_cluster_whose_sphere_holds_it() {
        let (raw_v, raw_t) = icosphere_raw(0.5, 3);
        let mesh = ConvexMesh::new(raw_v, raw_t).expect("an icosphere is valid").0;
        let (v, t, edges, cs) = (&mesh.vertices, &mesh.triangles, &mesh.edges, &mesh.clusters);
        let count = |f: fn(&Cluster) -> usize| cs.iter().map(f).sum::<usize>();
        assert_eq!(count(|c| c.vertices.len()), v.len());
        assert_eq!(count(|c| c.triangles.len()), t.len());
        assert_eq!(count(|c| c.edges.len()), edges.len());
        let inside = |c: &Cluster, i: u32| (v[i as usize] - c.centre).length() <= c.radius * (1.0 + 1e-12);
        for c in cs {
            assert!(c.vertices.iter().all(|&i| inside(c, i)));
            assert!(c.triangles.iter().all(|&k| t[k as usize].iter().all(|&i| inside(c, i))));
            assert!(c.edges.iter().all(|&k| edges[k as usize].iter().all(|&i| inside(c, i))));
        }
        assert!(cs.len() > 32, "{} clusters for 642 vertices", cs.len());
    }

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
