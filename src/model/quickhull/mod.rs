//! The convex hull of a point cloud, for OBJ files read with `hull: true` (docs/scenes.md).
//!
//! Quickhull (Barber, Dobkin & Huhdanpaa, 1996) on the points snapped to an integer grid whose
//! step is 2⁻⁴⁰ of the cloud's size (or the coordinates' own precision, when that is coarser).
//! On the grid every orientation test is exact in 128-bit integers, so the hull is closed and
//! exactly convex whatever the input: duplicates, interior points and points lying on a face or
//! an edge are decided without rounding, never by a tolerance that could disagree with itself.
//! Two clean-ups follow, each rebuilding the hull from the points it keeps:
//!
//! 1. a vertex whose triangles lie in fewer than three planes sits inside a face or an edge of
//!    the hull, not at a corner: it is dropped;
//! 2. a triangle thinner than [`HULL_TOLERANCE`] of the cloud's size drops the vertex opposite
//!    its longest edge (that vertex is this close to the edge): floating point cannot give such
//!    a sliver a reliable plane.
//!
//! The result is the hull's corners, each its input point snapped to the grid, and triangles
//! wound outward, in a fixed order: the input of `ConvexMesh::new`, which merges coplanar
//! triangles into polygon faces.

use crate::math::{Scalar, Vector};
use crate::model::mass::volume_props;
use crate::model::mesh::MIN_RELATIVE_VOLUME;
use crate::model::shapes::RawMesh;

/// Thinnest triangle kept [fraction of the cloud's size]: a hull vertex closer than this to the
/// edge of one of its triangles is dropped, which moves the hull's surface by less than this.
pub const HULL_TOLERANCE: Scalar = 1e-8;

/// The grid step is the cloud's half extent times 2^−`GRID_BITS`: differences of grid points
/// stay below 2^41, cross products below 2^83 and orientation tests below 2^126, within `i128`.
const GRID_BITS: i32 = 39;

/// Why a point cloud has no convex hull with a volume.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum HullError {
    /// A coordinate is NaN or infinite.
    #[error("point {index} has a NaN or infinite coordinate")]
    NonFinite {
        /// Point index (0-based).
        index: usize,
    },
    /// Fewer than four distinct points.
    #[error("only {distinct} distinct point(s): a hull needs at least 4 that are not in one plane")]
    TooFew {
        /// How many distinct points there are.
        distinct: usize,
    },
    /// The points lie on a line or in a plane, or their hull is too thin to be a body.
    #[error("the points are flat: no volume ({why})")]
    Flat {
        /// How flat.
        why: String,
    },
}

/// A point on the grid, relative to the grid's centre.
type Grid = [i64; 3];
/// An exact normal: the cross product of two grid differences.
type Normal = [i128; 3];

/// The convex hull of `points`: its corners (each a point of the input snapped to the grid, in
/// input order) and outward (counter-clockwise seen from outside) triangles. Points inside the
/// hull, on its faces or edges, repeated, or closer than [`HULL_TOLERANCE`] to it are dropped.
/// The same input always gives the same bits.
///
/// # Errors
/// A non-finite coordinate, fewer than 4 distinct points, or points that enclose no volume.
pub fn convex_hull(points: &[Vector]) -> Result<RawMesh, HullError> {
    if let Some(index) = points.iter().position(|p| !p.is_finite()) {
        return Err(HullError::NonFinite { index });
    }
    let snap = Snap::new(points).ok_or(HullError::TooFew { distinct: points.len().min(1) })?;
    // The distinct grid points, each at its first appearance, in input order.
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| snap.grid[a].cmp(&snap.grid[b]).then(a.cmp(&b)));
    order.dedup_by(|later, first| snap.grid[*later] == snap.grid[*first]);
    order.sort_unstable();
    let pts: Vec<Grid> = order.iter().map(|&i| snap.grid[i]).collect();
    if pts.len() < 4 {
        return Err(HullError::TooFew { distinct: pts.len() });
    }
    let tolerance = HULL_TOLERANCE * grid_extent(&pts);
    let mut keep: Vec<u32> = (0..pts.len() as u32).collect();
    loop {
        if keep.len() < 4 {
            return Err(HullError::Flat { why: "no corners are left once the slivers are dropped".into() });
        }
        let triangles = hull(&pts, &keep)?;
        let used = vertices_of(&triangles);
        let raw = output(&snap, &pts, &used, &triangles);
        check_volume(&raw)?;
        let corners = corners(&pts, &triangles, &used);
        if corners.len() < used.len() {
            keep = corners;
            continue;
        }
        let thin = slivers(&pts, &triangles, tolerance);
        if thin.is_empty() {
            return Ok(raw);
        }
        keep = used.into_iter().filter(|v| thin.binary_search(v).is_err()).collect();
    }
}

/// The snapping of a cloud to the grid: `grid[i]` is point i as whole grid steps from the
/// grid's centre, and `(grid[i] + centre)·step` is exactly its snapped position.
struct Snap {
    grid: Vec<Grid>,
    centre: Grid,
    step: Scalar,
}

impl Snap {
    /// `None` when every point is the same (or there is none).
    fn new(points: &[Vector]) -> Option<Self> {
        let lo = points.iter().copied().reduce(Vector::min)?;
        let hi = points.iter().copied().reduce(Vector::max)?;
        let half = (hi * 0.5 - lo * 0.5).max_element();
        if half <= 0.0 {
            return None;
        }
        let largest = lo.abs().max(hi.abs()).max_element();
        // 2^e maps the half extent to at most 2^GRID_BITS steps and every coordinate to at most
        // 2^52 (below, a whole number of steps is exact in an f64).
        let e = (GRID_BITS - half.log2().ceil() as i32).min(52 - largest.log2().ceil() as i32).min(1000);
        let (scale, step) = (pow2(e), pow2(-e));
        let whole = |x: Scalar| (x * scale).round() as i64;
        let mid = lo * 0.5 + hi * 0.5;
        let centre = [whole(mid.x), whole(mid.y), whole(mid.z)];
        let grid =
            points.iter().map(|p| [whole(p.x) - centre[0], whole(p.y) - centre[1], whole(p.z) - centre[2]]).collect();
        Some(Self { grid, centre, step })
    }

    /// The snapped position of a grid point: exact, as `|g + centre| ≤ 2^52`.
    fn position(&self, g: Grid) -> Vector {
        let at = |k: usize| (g[k] + self.centre[k]) as Scalar * self.step;
        Vector::new(at(0), at(1), at(2))
    }
}

/// 2^e, exactly.
fn pow2(e: i32) -> Scalar {
    debug_assert!((-1022..=1023).contains(&e));
    Scalar::from_bits(((e + 1023) as u64) << 52)
}

/// Largest bounding-box side of grid points [steps].
fn grid_extent(pts: &[Grid]) -> Scalar {
    (0..3)
        .map(|k| {
            let (lo, hi) = pts.iter().fold((i64::MAX, i64::MIN), |(lo, hi), p| (lo.min(p[k]), hi.max(p[k])));
            (hi - lo) as Scalar
        })
        .fold(0.0, Scalar::max)
}

fn sub(a: Grid, b: Grid) -> Grid {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: Grid, b: Grid) -> Normal {
    let [a0, a1, a2] = a.map(i128::from);
    let [b0, b1, b2] = b.map(i128::from);
    [a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0]
}

fn dot(n: Normal, d: Grid) -> i128 {
    n[0] * i128::from(d[0]) + n[1] * i128::from(d[1]) + n[2] * i128::from(d[2])
}

fn neg(n: Normal) -> Normal {
    n.map(|x| -x)
}

/// A triangle of the hull under construction.
struct Face {
    /// Its corners, counter-clockwise seen from outside (indices into the points).
    v: [u32; 3],
    /// `(v1 − v0) × (v2 − v0)`: outward, exact.
    normal: Normal,
    /// `adj[k]` is the face across the edge `v[k] → v[k + 1]`.
    adj: [usize; 3],
    /// The points above this face (and above no face before it when they were assigned).
    outside: Vec<u32>,
    alive: bool,
}

/// How far above face `f` point `p` is, times the face's doubled area (exact; > 0 above).
fn height(faces: &[Face], pts: &[Grid], f: usize, p: u32) -> i128 {
    dot(faces[f].normal, sub(pts[p as usize], pts[faces[f].v[0] as usize]))
}

/// Quickhull of the points `keep` (indices into `pts`, distinct): the hull's triangles, outward.
/// Exact, so a point counts as outside a face only when strictly above it: points on the hull's
/// surface are dropped unless they were picked as corners first.
fn hull(pts: &[Grid], keep: &[u32]) -> Result<Vec<[u32; 3]>, HullError> {
    let simplex = initial_simplex(pts, keep)?;
    let mut faces: Vec<Face> = Vec::new();
    for (a, b, c, o) in [(0, 1, 2, 3), (0, 1, 3, 2), (0, 2, 3, 1), (1, 2, 3, 0)] {
        let [a, mut b, mut c, o] = [a, b, c, o].map(|k| simplex[k]);
        let g = |i: u32| pts[i as usize];
        if dot(cross(sub(g(b), g(a)), sub(g(c), g(a))), sub(g(o), g(a))) > 0 {
            std::mem::swap(&mut b, &mut c);
        }
        let normal = cross(sub(g(b), g(a)), sub(g(c), g(a)));
        faces.push(Face { v: [a, b, c], normal, adj: [0; 3], outside: Vec::new(), alive: true });
    }
    for f in 0..4 {
        for k in 0..3 {
            let (a, b) = (faces[f].v[k], faces[f].v[(k + 1) % 3]);
            faces[f].adj[k] = (0..4).find(|&g| has_edge(&faces[g].v, b, a)).expect("a tetrahedron is closed");
        }
    }
    for &p in keep.iter().filter(|p| !simplex.contains(p)) {
        if let Some(f) = (0..4).find(|&f| height(&faces, pts, f, p) > 0) {
            faces[f].outside.push(p);
        }
    }
    let mut pending: Vec<usize> = (0..4).rev().filter(|&f| !faces[f].outside.is_empty()).collect();
    let mut free: Vec<usize> = Vec::new();
    // Flood marks: `seen[f] == round` when face f was classified this round, `lit[f]` if visible.
    let (mut seen, mut lit) = (vec![0_u64; 4], vec![false; 4]);
    let mut round = 0_u64;
    while let Some(f) = pending.pop() {
        if !faces[f].alive || faces[f].outside.is_empty() {
            continue;
        }
        // The eye: the point farthest above the face (ties: the greatest coordinates).
        let eye = *faces[f]
            .outside
            .iter()
            .max_by(|&&a, &&b| {
                let (ha, hb) = (height(&faces, pts, f, a), height(&faces, pts, f, b));
                ha.cmp(&hb).then(pts[a as usize].cmp(&pts[b as usize]))
            })
            .expect("not empty");
        // The faces the eye sees, flooded from f, and the horizon: their edges to faces it
        // does not see. Exact tests make the seen faces a disc and the horizon one loop.
        round += 1;
        seen.resize(faces.len(), 0);
        lit.resize(faces.len(), false);
        seen[f] = round;
        lit[f] = true;
        let mut visible = vec![f];
        let mut horizon: Vec<(u32, u32, usize)> = Vec::new();
        let mut i = 0;
        while i < visible.len() {
            let g = visible[i];
            i += 1;
            for k in 0..3 {
                let h = faces[g].adj[k];
                if seen[h] != round {
                    seen[h] = round;
                    lit[h] = height(&faces, pts, h, eye) > 0;
                    if lit[h] {
                        visible.push(h);
                    }
                }
                if !lit[h] {
                    horizon.push((faces[g].v[k], faces[g].v[(k + 1) % 3], h));
                }
            }
        }
        let horizon = chain(horizon);
        let mut orphans: Vec<u32> = Vec::new();
        for &g in &visible {
            orphans.append(&mut faces[g].outside);
            faces[g].alive = false;
            free.push(g);
        }
        // A cone of new faces from the horizon to the eye.
        let m = horizon.len();
        let new: Vec<usize> = (0..m)
            .map(|_| {
                free.pop().unwrap_or_else(|| {
                    faces.push(Face { v: [0; 3], normal: [0; 3], adj: [0; 3], outside: Vec::new(), alive: false });
                    faces.len() - 1
                })
            })
            .collect();
        for (j, &(a, b, h)) in horizon.iter().enumerate() {
            let g = |i: u32| pts[i as usize];
            faces[new[j]] = Face {
                v: [a, b, eye],
                normal: cross(sub(g(b), g(a)), sub(g(eye), g(a))),
                adj: [h, new[(j + 1) % m], new[(j + m - 1) % m]],
                outside: Vec::new(),
                alive: true,
            };
            let k = (0..3).find(|&k| faces[h].v[k] == b && faces[h].v[(k + 1) % 3] == a).expect("shared edge");
            faces[h].adj[k] = new[j];
        }
        // Points above a removed face are above a new face or inside the new hull.
        for p in orphans.into_iter().filter(|&p| p != eye) {
            if let Some(&g) = new.iter().find(|&&g| height(&faces, pts, g, p) > 0) {
                faces[g].outside.push(p);
            }
        }
        pending.extend(new.iter().rev().filter(|&&g| !faces[g].outside.is_empty()));
    }
    Ok(faces.iter().filter(|f| f.alive).map(|f| f.v).collect())
}

fn has_edge(v: &[u32; 3], a: u32, b: u32) -> bool {
    (0..3).any(|k| v[k] == a && v[(k + 1) % 3] == b)
}

/// The horizon's edges `(a, b, face beyond)` in loop order, each edge's `b` the next one's `a`.
fn chain(mut edges: Vec<(u32, u32, usize)>) -> Vec<(u32, u32, usize)> {
    edges.sort_unstable_by_key(|e| e.0);
    let mut out = Vec::with_capacity(edges.len());
    let mut at = 0;
    for _ in 0..edges.len() {
        out.push(edges[at]);
        at = edges.binary_search_by_key(&edges[at].1, |e| e.0).expect("the horizon is one loop");
    }
    debug_assert_eq!(at, 0, "the horizon closes");
    out
}

/// Four corners of the hull that span a volume: the least and greatest points in coordinate
/// order, then the point farthest along a direction across their line, then the point farthest
/// from the plane of the three, each the greatest in coordinate order among equally far ones. A point that maximises a linear function, ties
/// broken in coordinate order, is a corner of the hull, never a point inside a face or edge.
fn initial_simplex(pts: &[Grid], keep: &[u32]) -> Result<[u32; 4], HullError> {
    let p = |i: u32| pts[i as usize];
    let i0 = *keep.iter().min_by_key(|&&i| p(i)).expect("4 points or more");
    let i1 = *keep.iter().max_by_key(|&&i| p(i)).expect("4 points or more");
    // The point farthest along `dir` from i0, if any lies beyond it.
    let farthest = |dir: Normal| {
        keep.iter()
            .map(|&i| (dot(dir, sub(p(i), p(i0))), i))
            .max_by(|a, b| a.0.cmp(&b.0).then(p(a.1).cmp(&p(b.1))))
            .filter(|&(s, _)| s > 0)
            .map(|(_, i)| i)
    };
    let d = sub(p(i1), p(i0));
    // Two directions across the line: d × the two axes other than d's largest component.
    let big = (0..3).max_by_key(|&k| d[k].unsigned_abs()).expect("3 axes");
    let across = [(big + 1) % 3, (big + 2) % 3].map(|a| {
        let mut axis = [0; 3];
        axis[a] = 1;
        cross(d, axis)
    });
    let i2 = [across[0], neg(across[0]), across[1], neg(across[1])]
        .into_iter()
        .find_map(farthest)
        .ok_or_else(|| HullError::Flat { why: "they lie on one line".into() })?;
    let n = cross(d, sub(p(i2), p(i0)));
    let i3 = [n, neg(n)]
        .into_iter()
        .find_map(farthest)
        .ok_or_else(|| HullError::Flat { why: "they lie in one plane".into() })?;
    Ok([i0, i1, i2, i3])
}

/// The vertices the triangles use, sorted.
fn vertices_of(triangles: &[[u32; 3]]) -> Vec<u32> {
    let mut used: Vec<u32> = triangles.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    used
}

/// The vertices `used` that are corners: their triangles lie in three planes or more (in one
/// plane the vertex is inside a face, in two it is on an edge). Exact: a normal reduced by the
/// gcd of its components names its plane's direction.
fn corners(pts: &[Grid], triangles: &[[u32; 3]], used: &[u32]) -> Vec<u32> {
    let normals: Vec<Normal> = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| pts[i as usize]);
            let n = cross(sub(b, a), sub(c, a));
            let g = gcd(gcd(n[0].unsigned_abs(), n[1].unsigned_abs()), n[2].unsigned_abs()) as i128;
            n.map(|x| x / g)
        })
        .collect();
    let mut pairs: Vec<(u32, Normal)> = triangles.iter().zip(&normals).flat_map(|(t, &n)| t.map(|v| (v, n))).collect();
    pairs.sort_unstable();
    pairs.dedup();
    used.iter()
        .copied()
        .filter(|&v| {
            let from = pairs.partition_point(|e| e.0 < v);
            pairs[from..].iter().take_while(|e| e.0 == v).count() >= 3
        })
        .collect()
}

fn gcd(mut a: u128, mut b: u128) -> u128 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Vertices to drop because a triangle is thinner than `tolerance` [steps]: the vertex
/// opposite its longest edge, which lies that close to the edge. Never both a dropped vertex and
/// an end of the edge it is measured against, so the kept points' hull moves by less than
/// `tolerance`. Sorted.
fn slivers(pts: &[Grid], triangles: &[[u32; 3]], tolerance: Scalar) -> Vec<u32> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        Free,
        Kept,
        Dropped,
    }
    let mut mark = vec![Mark::Free; pts.len()];
    let length = |v: Grid| v.map(|x| x as Scalar).iter().map(|x| x * x).sum::<Scalar>().sqrt();
    for t in triangles {
        let [a, b, c] = t.map(|i| pts[i as usize]);
        let n = cross(sub(b, a), sub(c, a));
        let doubled_area = n.map(|x| x as Scalar).iter().map(|x| x * x).sum::<Scalar>().sqrt();
        // Edge k runs t[k] → t[k + 1]; the vertex opposite it is t[k + 2].
        let edges = [length(sub(b, a)), length(sub(c, b)), length(sub(a, c))];
        let k = (0..3).max_by(|&i, &j| edges[i].total_cmp(&edges[j])).expect("3 edges");
        if doubled_area / edges[k] >= tolerance {
            continue;
        }
        let (ends, apex) = ([t[k] as usize, t[(k + 1) % 3] as usize], t[(k + 2) % 3] as usize);
        if mark[apex] == Mark::Free && ends.iter().all(|&e| mark[e] != Mark::Dropped) {
            mark[apex] = Mark::Dropped;
            for e in ends {
                mark[e] = Mark::Kept;
            }
        }
    }
    (0..pts.len() as u32).filter(|&v| mark[v as usize] == Mark::Dropped).collect()
}

/// The hull as a raw mesh: the `used` vertices (in their order) at their snapped positions, and
/// the triangles renumbered, each turned to start at its least index, in sorted order.
fn output(snap: &Snap, pts: &[Grid], used: &[u32], triangles: &[[u32; 3]]) -> RawMesh {
    let vertices = used.iter().map(|&i| snap.position(pts[i as usize])).collect();
    let index = |i: u32| used.binary_search(&i).expect("a used vertex") as u32;
    let mut out: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| {
            let mut t = t.map(index);
            let least = (0..3).min_by_key(|&k| t[k]).expect("3 corners");
            t.rotate_left(least);
            t
        })
        .collect();
    out.sort_unstable();
    (vertices, out)
}

/// The volume test of `ConvexMesh::new`, computed the same way on the same data, so a hull that
/// passes here is not found degenerate there.
fn check_volume((vertices, triangles): &RawMesh) -> Result<(), HullError> {
    let volume = volume_props(vertices, triangles).volume;
    let (lo, hi) =
        vertices.iter().fold((Vector::splat(Scalar::INFINITY), Vector::splat(Scalar::NEG_INFINITY)), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    let size = (hi - lo).max_element();
    if volume <= MIN_RELATIVE_VOLUME * size.powi(3) || !volume.is_finite() {
        return Err(HullError::Flat { why: format!("their hull encloses only {volume:e} m^3") });
    }
    Ok(())
}

#[cfg(test)]
mod tests;
