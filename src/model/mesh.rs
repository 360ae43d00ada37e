//! Convex meshes: validated once when built, then shared read-only by every actor using them.
//!
//! A `ConvexMesh` stores its vertices in the body frame **about its exact centre of mass**
//! (docs/physics.md §0, §3), outward (counter-clockwise) triangles, deduplicated edges for the edge
//! test, and the distinct face planes that point-in-mesh and clipping need (coplanar triangles,
//! such as a box face's two halves, share one plane: same answers, half the work).

use crate::error::MeshError;
use crate::math::{Mat3, Scalar, Vector};
use crate::model::mass::{VolumeProps, isotropic_to_round_off, volume_props};
use std::collections::{HashMap, VecDeque};

/// Slack for convexity [fraction of the mesh size]: a vertex may stand this far in front of a
/// face plane. OBJ files print about 6 significant digits, so exact coplanarity cannot be asked.
pub const CONVEX_TOLERANCE: Scalar = 1e-6;
/// Two triangles share one plane when their normals and offsets agree to this (relative); a
/// looser merge would change answers, a stricter one only costs a duplicate plane.
pub const PLANE_MERGE_TOLERANCE: Scalar = 1e-10;
/// Smallest accepted volume, relative to the cube of the mesh size: flatter is degenerate.
pub const MIN_RELATIVE_VOLUME: Scalar = 1e-9;

/// A face plane in the body frame: signed distance `s(p) = normal·p − offset` (negative inside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Outward unit normal.
    pub normal: Vector,
    /// `normal · a` for any point `a` on the face [m].
    pub offset: Scalar,
}

/// Index of a mesh in the [`MeshTable`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MeshId(pub u32);

/// A closed, convex, outward-wound triangle mesh about its centre of mass.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvexMesh {
    /// Vertices in the body frame, relative to the centre of mass [m].
    pub vertices: Vec<Vector>,
    /// Triangles, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Each undirected edge once, `(i, j)` with `i < j`, in sorted order (docs/physics.md §1.5).
    pub edges: Vec<[u32; 2]>,
    /// Distinct face planes, in order of first triangle.
    pub planes: Vec<Plane>,
    /// The outline of face f (plane f): its vertices counter-clockwise seen from outside,
    /// `face_vertices[face_start[f]..face_start[f + 1]]`. Contact manifolds clip one body's
    /// face against another's outline.
    pub face_vertices: Vec<u32>,
    /// Where each face's outline starts in `face_vertices`, plus one entry for the end.
    pub face_start: Vec<u32>,
    /// Directions of the feature edges (between non-coplanar faces), each once up to sign:
    /// the edge axes of a separating-axis test (a box has 3).
    pub edge_directions: Vec<Vector>,
    /// The feature edges themselves, `(i, j)` with `i < j`, sorted: the outline a renderer draws
    /// (a box has 12).
    pub feature_edges: Vec<[u32; 2]>,
    /// Bounding-sphere radius about the centre of mass, `max |p|` [m] (docs/physics.md §1.2).
    pub radius: Scalar,
    /// Smallest width over the face normals [m]: the thickness that bounds safe speeds (§5).
    pub thickness: Scalar,
    /// Volume [m³].
    pub volume: Scalar,
    /// Inertia about the centre of mass at density 1 [kg·m² per kg/m³]; exactly isotropic when
    /// its moments agree to round-off (`mass::isotropic_to_round_off`).
    pub unit_inertia: Mat3,
    /// Half extents when the mesh is a box aligned with its body axes (its 8 vertices are
    /// (±x, ±y, ±z)): pairs of such boxes get the cheap oriented-box separation test.
    pub box_half_extents: Option<Vector>,
    /// For such a box, each face plane (in order) as the body axis its normal lies along and
    /// the side (±1), and each edge direction (in order) as its axis: the separating-axis
    /// search of two boxes (`collision::boxes`) visits them in the order of the general one.
    pub box_layout: Option<BoxLayout>,
    /// The vertices joined to vertex i by an edge:
    /// `neighbours[neighbour_start[i]..neighbour_start[i + 1]]`. Walking them finds the vertex
    /// farthest along a direction in about √V steps instead of V (a many-faced hull's support).
    pub neighbours: Vec<u32>,
    /// Where each vertex's neighbours start in `neighbours`, plus one entry for the end.
    pub neighbour_start: Vec<u32>,
    /// The two faces (plane indices) on either side of each feature edge, in `feature_edges`
    /// order: their normals bound the edge's arc on the Gauss map.
    pub feature_edge_faces: Vec<[u32; 2]>,
    /// The faces (plane indices) around vertex i:
    /// `vertex_faces[vertex_face_start[i]..vertex_face_start[i + 1]]`.
    pub vertex_faces: Vec<u32>,
    /// Where each vertex's faces start in `vertex_faces`, plus one entry for the end.
    pub vertex_face_start: Vec<u32>,
    /// The feature edges (indices into `feature_edges`) at vertex i, laid out as `vertex_faces`.
    pub vertex_edges: Vec<u32>,
    /// Where each vertex's feature edges start in `vertex_edges`, plus one entry for the end.
    pub vertex_edge_start: Vec<u32>,
    /// The triangles at vertex i, laid out as `vertex_faces`.
    pub vertex_triangles: Vec<u32>,
    /// Where each vertex's triangles start in `vertex_triangles`, plus one entry for the end.
    pub vertex_triangle_start: Vec<u32>,
    /// The edges (indices into `edges`) at vertex i, laid out as `vertex_faces`.
    pub vertex_all_edges: Vec<u32>,
    /// Where each vertex's edges start in `vertex_all_edges`, plus one entry for the end.
    pub vertex_all_edge_start: Vec<u32>,
    /// The face planes grouped by normal, each group with a bound (empty unless many-faced):
    /// plane scans skip the groups that cannot matter.
    pub plane_groups: Vec<crate::model::clusters::PlaneGroup>,
    /// The vertex farthest along each of the 26 directions (the faces, edges and corners of a
    /// cube), in the order of `seed_index`: a walk for the vertex lowest along any direction
    /// starts at the one of the nearest direction and has only a few steps left.
    pub seeds: Vec<u32>,
}

impl ConvexMesh {
    /// Validates and builds a mesh from raw vertices and triangles (docs/physics.md §3.3): closed,
    /// consistently wound (mixed windings repaired by a breadth-first walk, an inside-out mesh
    /// flipped), non-degenerate and convex. Returns the mesh and the centroid of the input
    /// coordinates, which the vertices were shifted by.
    pub fn new(vertices: Vec<Vector>, triangles: Vec<[u32; 3]>) -> Result<(Self, Vector), MeshError> {
        check_input(&vertices, &triangles)?;
        let mut triangles = triangles;
        orient_consistently(&mut triangles)?;
        let mut props = volume_props(&vertices, &triangles);
        let size = extent(&vertices);
        if props.volume.abs() <= MIN_RELATIVE_VOLUME * size.powi(3) || !props.volume.is_finite() {
            return Err(MeshError::Degenerate { volume: props.volume });
        }
        if props.volume < 0.0 {
            // Inside out (§3.3 step 3): flip every triangle; the centroid is unchanged.
            for t in &mut triangles {
                t.swap(1, 2);
            }
            props = VolumeProps { volume: -props.volume, inertia: -props.inertia, ..props };
        }
        let vertices: Vec<Vector> = vertices.iter().map(|&v| v - props.centroid).collect();
        let (planes, plane_of) = face_planes(&vertices, &triangles, size);
        check_convex(&vertices, &planes, size)?;
        let (face_vertices, face_start) = face_outlines(&vertices, &triangles, &planes, &plane_of);
        let radius = vertices.iter().map(|v| v.length()).fold(0.0, Scalar::max);
        let thickness = planes
            .iter()
            .map(|p| vertices.iter().map(|&v| p.offset - p.normal.dot(v)).fold(0.0, Scalar::max))
            .fold(Scalar::INFINITY, Scalar::min);
        let box_half_extents = cuboid_half_extents(&vertices);
        let edges = unique_edges(&triangles);
        let (feature_edges, edge_directions) = feature_edges(&vertices, &triangles);
        let box_layout = box_half_extents.and_then(|_| BoxLayout::new(&planes, &edge_directions));
        let (neighbours, neighbour_start) = adjacency(vertices.len(), &edges);
        let feature_edge_faces = edge_faces(&feature_edges, &triangles, &plane_of);
        let (vertex_faces, vertex_face_start) = grouped(
            vertices.len(),
            triangles
                .iter()
                .zip(&plane_of)
                .filter_map(|(t, p)| p.map(|p| (t, p as u32)))
                .flat_map(|(t, p)| t.map(|v| (v, p))),
        );
        let (vertex_edges, vertex_edge_start) = grouped(
            vertices.len(),
            feature_edges.iter().enumerate().flat_map(|(e, &[i, j])| [(i, e as u32), (j, e as u32)]),
        );
        let (vertex_triangles, vertex_triangle_start) =
            grouped(vertices.len(), triangles.iter().enumerate().flat_map(|(k, t)| t.map(|v| (v, k as u32))));
        let (vertex_all_edges, vertex_all_edge_start) =
            grouped(vertices.len(), edges.iter().enumerate().flat_map(|(e, &[i, j])| [(i, e as u32), (j, e as u32)]));
        let seeds = seeds(&vertices);
        let plane_groups =
            if many_faced(&feature_edges) { crate::model::clusters::plane_groups(&planes) } else { Vec::new() };
        let mesh = Self {
            seeds,
            plane_groups,
            vertices,
            triangles,
            edges,
            planes,
            face_vertices,
            face_start,
            edge_directions,
            feature_edges,
            box_half_extents,
            box_layout,
            neighbours,
            neighbour_start,
            feature_edge_faces,
            vertex_faces,
            vertex_face_start,
            vertex_edges,
            vertex_edge_start,
            vertex_triangles,
            vertex_triangle_start,
            vertex_all_edges,
            vertex_all_edge_start,
            radius,
            thickness,
            volume: props.volume,
            unit_inertia: isotropic_to_round_off(props.inertia),
        };
        Ok((mesh, props.centroid))
    }

    /// True for a many-faced mesh (more than `MANY_EDGES` feature edges): its contact tests
    /// visit the features near the contact only (`collision::hull`).
    #[must_use]
    pub fn is_many_faced(&self) -> bool {
        many_faced(&self.feature_edges)
    }

    /// The canonical box of docs/physics.md §0 with these full edge lengths [m].
    ///
    /// # Panics
    /// If a size is not positive and finite: callers pass checked or literal sizes.
    #[must_use]
    pub fn cuboid(size: Vector) -> Self {
        let (v, t) = crate::model::shapes::box_raw(size);
        Self::new(v, t).expect("a box with positive sizes is a valid convex mesh").0
    }
}

/// A mesh with more feature edges than this is many-faced: its contact tests visit the
/// features near the contact only (`collision::hull`; an icosphere of one subdivision has 120,
/// a box 12, a 16-sided cylinder 48).
pub const MANY_EDGES: usize = 48;

/// True for a mesh of these feature edges that is many-faced (see `MANY_EDGES`).
fn many_faced(feature_edges: &[[u32; 2]]) -> bool {
    feature_edges.len() > MANY_EDGES
}

/// Every mesh of a simulation, once: box-gas's 64 000 cubes share one.
#[derive(Clone, Debug, Default)]
pub struct MeshTable {
    meshes: Vec<std::sync::Arc<ConvexMesh>>,
}

impl MeshTable {
    /// Adds a mesh, reusing an identical one already present.
    pub fn insert(&mut self, mesh: ConvexMesh) -> MeshId {
        if let Some(i) = self.meshes.iter().position(|m| **m == mesh) {
            return MeshId(i as u32);
        }
        self.meshes.push(std::sync::Arc::new(mesh));
        MeshId((self.meshes.len() - 1) as u32)
    }

    /// The mesh with this id (ids come only from `insert`, so it exists).
    #[must_use]
    pub fn get(&self, id: MeshId) -> &ConvexMesh {
        &self.meshes[id.0 as usize]
    }

    /// The shared handle of a mesh, for caches that outlive a borrow of the table.
    #[must_use]
    pub fn get_arc(&self, id: MeshId) -> std::sync::Arc<ConvexMesh> {
        std::sync::Arc::clone(&self.meshes[id.0 as usize])
    }

    /// Number of distinct meshes.
    #[must_use]
    pub fn len(&self) -> usize {
        self.meshes.len()
    }

    /// True when no mesh was added.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.meshes.is_empty()
    }
}

fn extent(vertices: &[Vector]) -> Scalar {
    let (lo, hi) =
        vertices.iter().fold((Vector::splat(Scalar::INFINITY), Vector::splat(Scalar::NEG_INFINITY)), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    (hi - lo).max_element()
}

fn check_input(vertices: &[Vector], triangles: &[[u32; 3]]) -> Result<(), MeshError> {
    if vertices.len() < 4 || triangles.len() < 4 {
        return Err(MeshError::Empty { vertices: vertices.len(), triangles: triangles.len() });
    }
    if let Some(i) = vertices.iter().position(|v| !crate::math::is_finite_vector(*v)) {
        return Err(MeshError::NonFinite { vertex: i });
    }
    for (i, t) in triangles.iter().enumerate() {
        if t.iter().any(|&k| k as usize >= vertices.len()) {
            return Err(MeshError::BadIndex { triangle: i, vertices: vertices.len() });
        }
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return Err(MeshError::RepeatedIndex { triangle: i });
        }
    }
    Ok(())
}

/// Each undirected edge must be used by exactly two triangles (closed manifold, §3.3 step 1);
/// then a breadth-first walk from triangle 0 flips neighbours wound against it (step 2).
fn orient_consistently(triangles: &mut [[u32; 3]]) -> Result<(), MeshError> {
    let mut by_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (i, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            by_edge.entry((a.min(b), a.max(b))).or_default().push(i);
        }
    }
    if let Some((&(a, b), users)) = by_edge.iter().filter(|(_, u)| u.len() != 2).min_by_key(|(e, _)| **e) {
        return Err(MeshError::Open { a, b, triangles: users.len() });
    }
    let mut seen = vec![false; triangles.len()];
    let mut queue = VecDeque::from([0]);
    seen[0] = true;
    while let Some(i) = queue.pop_front() {
        let t = triangles[i];
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let users = &by_edge[&(a.min(b), a.max(b))];
            let j = if users[0] == i { users[1] } else { users[0] };
            if seen[j] {
                continue;
            }
            // A consistent neighbour walks the shared edge b→a; a→b means it is flipped.
            if directed(&triangles[j], a, b) {
                triangles[j].swap(1, 2);
            }
            seen[j] = true;
            queue.push_back(j);
        }
    }
    if let Some(i) = seen.iter().position(|s| !s) {
        return Err(MeshError::Disconnected { triangle: i });
    }
    Ok(())
}

fn directed(t: &[u32; 3], a: u32, b: u32) -> bool {
    (0..3).any(|k| t[k] == a && t[(k + 1) % 3] == b)
}

/// The distinct planes of the triangles, and which plane each triangle lies in (`None` for a
/// zero-area triangle).
fn face_planes(vertices: &[Vector], triangles: &[[u32; 3]], size: Scalar) -> (Vec<Plane>, Vec<Option<usize>>) {
    let mut planes: Vec<Plane> = Vec::new();
    let mut plane_of = Vec::with_capacity(triangles.len());
    for t in triangles {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        // Zero-area triangles carry no direction (§3.3 step 5).
        let Some(normal) = (b - a).cross(c - a).try_normalize() else {
            plane_of.push(None);
            continue;
        };
        let plane = Plane { normal, offset: normal.dot(a) };
        let same = |p: &Plane| {
            (p.normal - normal).length() <= PLANE_MERGE_TOLERANCE
                && (p.offset - plane.offset).abs() <= PLANE_MERGE_TOLERANCE * size
        };
        if let Some(k) = planes.iter().position(same) {
            plane_of.push(Some(k));
        } else {
            plane_of.push(Some(planes.len()));
            planes.push(plane);
        }
    }
    (planes, plane_of)
}

/// Each plane's outline: the vertices of its triangles, each once, ordered by angle about
/// their centroid counter-clockwise seen from outside. The mesh is convex, so a face is a
/// convex polygon and angle order is its boundary order.
fn face_outlines(
    vertices: &[Vector],
    triangles: &[[u32; 3]],
    planes: &[Plane],
    plane_of: &[Option<usize>],
) -> (Vec<u32>, Vec<u32>) {
    let (mut flat, mut start) = (Vec::new(), vec![0_u32]);
    for (f, plane) in planes.iter().enumerate() {
        let mut ids: Vec<u32> =
            triangles.iter().zip(plane_of).filter(|(_, p)| **p == Some(f)).flat_map(|(t, _)| *t).collect();
        ids.sort_unstable();
        ids.dedup();
        let centre = ids.iter().map(|&i| vertices[i as usize]).sum::<Vector>() / ids.len() as Scalar;
        let u = plane.normal.any_orthonormal_vector();
        let v = plane.normal.cross(u);
        let angle = |i: &u32| {
            let d = vertices[*i as usize] - centre;
            d.dot(v).atan2(d.dot(u))
        };
        ids.sort_by(|x, y| angle(x).total_cmp(&angle(y)).then(x.cmp(y)));
        flat.extend_from_slice(&ids);
        start.push(flat.len() as u32);
    }
    (flat, start)
}

fn check_convex(vertices: &[Vector], planes: &[Plane], size: Scalar) -> Result<(), MeshError> {
    for (f, p) in planes.iter().enumerate() {
        for (i, &v) in vertices.iter().enumerate() {
            let s = p.normal.dot(v) - p.offset;
            if s > CONVEX_TOLERANCE * size {
                return Err(MeshError::NonConvex { vertex: i, face: f, distance: s });
            }
        }
    }
    Ok(())
}

/// A box's faces and edge directions by body axis (`ConvexMesh::box_layout`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxLayout {
    /// Face plane f lies on the side `faces[f].1` (±1) of body axis `faces[f].0`.
    pub faces: [(usize, Scalar); 6],
    /// Edge direction e lies along body axis `edges[e]`.
    pub edges: [usize; 3],
}

impl BoxLayout {
    /// The layout of a box's 6 planes and 3 edge directions, if it has that many.
    fn new(planes: &[Plane], edge_directions: &[Vector]) -> Option<Self> {
        let axis_of =
            |v: Vector| v.abs().to_array().iter().enumerate().max_by(|x, y| x.1.total_cmp(y.1)).map_or(0, |m| m.0);
        let faces: [(usize, Scalar); 6] = std::array::from_fn(|f| {
            let n = planes.get(f).map_or(Vector::X, |p| p.normal);
            (axis_of(n), n.to_array()[axis_of(n)].signum())
        });
        let edges = std::array::from_fn(|e| edge_directions.get(e).map_or(0, |&d| axis_of(d)));
        (planes.len() == 6 && edge_directions.len() == 3).then_some(Self { faces, edges })
    }
}

/// `Some(h)` when the vertices are exactly the 8 corners (±h.x, ±h.y, ±h.z).
fn cuboid_half_extents(vertices: &[Vector]) -> Option<Vector> {
    let h = vertices.first()?.abs();
    let corner = |v: &Vector| (v.abs() - h).abs().max_element() <= 1e-12 * h.max_element();
    let mut signs: Vec<[bool; 3]> = vertices.iter().map(|v| [v.x > 0.0, v.y > 0.0, v.z > 0.0]).collect();
    signs.sort_unstable();
    signs.dedup();
    (vertices.len() == 8 && vertices.iter().all(corner) && signs.len() == 8).then_some(h)
}

/// The edges whose two triangles are not coplanar, and their unit directions deduplicated up
/// to sign (a box's face diagonals are not feature edges: its 18 edges give 12 and 3
/// directions).
fn feature_edges(vertices: &[Vector], triangles: &[[u32; 3]]) -> (Vec<[u32; 2]>, Vec<Vector>) {
    let normal = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        (b - a).cross(c - a).try_normalize()
    };
    let mut by_edge: HashMap<(u32, u32), Vec<Option<Vector>>> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
            by_edge.entry((a, b)).or_default().push(normal(t));
        }
    }
    let mut keys: Vec<_> = by_edge.keys().copied().collect();
    keys.sort_unstable();
    let (mut edges, mut dirs): (Vec<[u32; 2]>, Vec<Vector>) = (Vec::new(), Vec::new());
    for (a, b) in keys {
        let coplanar = match by_edge[&(a, b)][..] {
            [Some(n1), Some(n2)] => (n1 - n2).length() <= PLANE_MERGE_TOLERANCE,
            _ => false,
        };
        let Some(d) = (vertices[b as usize] - vertices[a as usize]).try_normalize() else { continue };
        if coplanar {
            continue;
        }
        edges.push([a, b]);
        if !dirs.iter().any(|e| e.cross(d).length() <= PLANE_MERGE_TOLERANCE) {
            dirs.push(d);
        }
    }
    (edges, dirs)
}

/// The vertex farthest along each of the 26 directions with components in {−1, 0, 1}, x
/// slowest, z fastest.
fn seeds(vertices: &[Vector]) -> Vec<u32> {
    let mut out: Vec<u32> = Vec::new();
    for x in -1..=1 {
        for y in -1..=1 {
            for z in -1..=1 {
                let d = Vector::new(f64::from(x), f64::from(y), f64::from(z));
                if d == Vector::ZERO {
                    continue;
                }
                let best = (0..vertices.len()).max_by(|&i, &j| vertices[i].dot(d).total_cmp(&vertices[j].dot(d)));
                out.extend(best.map(|i| i as u32));
            }
        }
    }
    out
}

/// Where the seed of the cube direction nearest `d` (body frame) is in `ConvexMesh::seeds`:
/// each component kept, as its sign, when above 0.414 (tan 22.5°) of the largest.
#[must_use]
pub fn seed_index(d: Vector) -> usize {
    let big = 0.414 * d.abs().max_element();
    let digit = |x: Scalar| usize::from(x >= -big) + usize::from(x > big);
    match digit(d.x) * 9 + digit(d.y) * 3 + digit(d.z) {
        13 => 0, // no direction (a zero or NaN `d`): any seed
        k if k > 13 => k - 1,
        k => k,
    }
}

/// `(vertex, item)` pairs as each vertex's sorted, distinct items in one flat list with start
/// offsets.
fn grouped(count: usize, pairs: impl Iterator<Item = (u32, u32)>) -> (Vec<u32>, Vec<u32>) {
    let mut lists = vec![Vec::new(); count];
    for (v, item) in pairs {
        lists[v as usize].push(item);
    }
    let mut start = Vec::with_capacity(count + 1);
    start.push(0);
    let mut flat = Vec::new();
    for mut list in lists {
        list.sort_unstable();
        list.dedup();
        flat.extend(list);
        start.push(flat.len() as u32);
    }
    (flat, start)
}

/// Each vertex's neighbours along `edges`, as flat lists with start offsets.
fn adjacency(count: usize, edges: &[[u32; 2]]) -> (Vec<u32>, Vec<u32>) {
    let mut lists = vec![Vec::new(); count];
    for &[i, j] in edges {
        lists[i as usize].push(j);
        lists[j as usize].push(i);
    }
    let mut start = Vec::with_capacity(count + 1);
    start.push(0);
    let mut flat = Vec::with_capacity(2 * edges.len());
    for list in lists {
        flat.extend(list);
        start.push(flat.len() as u32);
    }
    (flat, start)
}

/// The planes of the two triangles on either side of each edge.
fn edge_faces(edges: &[[u32; 2]], triangles: &[[u32; 3]], plane_of: &[Option<usize>]) -> Vec<[u32; 2]> {
    let mut by_edge: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (t, tri) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k].min(tri[(k + 1) % 3]), tri[k].max(tri[(k + 1) % 3]));
            if let Some(plane) = plane_of[t] {
                by_edge.entry((a, b)).or_default().push(plane as u32);
            }
        }
    }
    edges
        .iter()
        .map(|&[a, b]| match by_edge.get(&(a, b)).map(Vec::as_slice) {
            Some(&[f, g, ..]) => [f, g],
            Some(&[f]) => [f, f],
            _ => [0, 0],
        })
        .collect()
}

fn unique_edges(triangles: &[[u32; 3]]) -> Vec<[u32; 2]> {
    let mut edges: Vec<[u32; 2]> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| [t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3])]))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    edges
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::shapes::box_raw;

    #[test]
    fn box_has_eight_vertices_eighteen_edges_six_planes() {
        let (v, t) = box_raw(Vector::ONE);
        let (m, c) = ConvexMesh::new(v, t).expect("valid box");
        assert_eq!((m.vertices.len(), m.triangles.len(), m.edges.len(), m.planes.len()), (8, 12, 18, 6));
        assert_eq!((m.edge_directions.len(), m.feature_edges.len()), (3, 12));
        assert_eq!(m.box_half_extents, Some(Vector::splat(0.5)));
        // Each body axis has a face on either side, and each is an edge direction once.
        let layout = m.box_layout.expect("a box's layout");
        for axis in 0..3 {
            let sides: Vec<Scalar> = layout.faces.iter().filter(|f| f.0 == axis).map(|f| f.1).collect();
            assert!(sides.len() == 2 && sides.contains(&1.0) && sides.contains(&-1.0), "axis {axis}: {sides:?}");
            assert_eq!(layout.edges.iter().filter(|&&e| e == axis).count(), 1, "axis {axis}");
        }
        for (f, &(axis, side)) in layout.faces.iter().enumerate() {
            assert_eq!(m.planes[f].normal.to_array()[axis], side, "face {f}");
        }
        assert_eq!(c, Vector::ZERO);
        assert!((m.radius - 3f64.sqrt() / 2.0).abs() < 1e-15);
        assert!((m.thickness - 1.0).abs() < 1e-15);
    }

    #[test]
    fn each_face_outline_runs_counter_clockwise_seen_from_outside() {
        let m = ConvexMesh::cuboid(Vector::new(1.0, 2.0, 3.0));
        assert_eq!(m.face_start.len(), 7);
        for (f, plane) in m.planes.iter().enumerate() {
            let ids = &m.face_vertices[m.face_start[f] as usize..m.face_start[f + 1] as usize];
            assert_eq!(ids.len(), 4, "a box face is a quadrilateral");
            let p: Vec<Vector> = ids.iter().map(|&i| m.vertices[i as usize]).collect();
            for k in 0..4 {
                assert!((plane.normal.dot(p[k]) - plane.offset).abs() < 1e-15, "on its plane");
                let turn = (p[(k + 1) % 4] - p[k]).cross(p[(k + 2) % 4] - p[(k + 1) % 4]);
                assert!(turn.dot(plane.normal) > 0.0, "face {f} turns left about its normal");
            }
        }
    }

    #[test]
    fn reversed_winding_is_repaired_with_the_same_properties() {
        // T-winding: every triangle reversed gives V < 0, which is detected and flipped.
        let (v, t) = box_raw(Vector::new(1.0, 2.0, 3.0));
        let reversed = t.iter().map(|&[a, b, c]| [a, c, b]).collect();
        let (good, _) = ConvexMesh::new(v.clone(), t).expect("valid");
        let (fixed, _) = ConvexMesh::new(v, reversed).expect("repaired");
        assert_eq!(good.volume, fixed.volume);
        assert!((good.unit_inertia - fixed.unit_inertia).to_cols_array().iter().all(|x| x.abs() < 1e-14));
        assert_eq!(good.planes.len(), fixed.planes.len());
        assert!(good.planes.iter().zip(&fixed.planes).all(|(a, b)| (a.normal - b.normal).length() < 1e-15));
    }

    #[test]
    fn one_flipped_triangle_is_repaired() {
        let (v, mut t) = box_raw(Vector::ONE);
        t[5].swap(0, 1);
        let (m, _) = ConvexMesh::new(v, t).expect("repaired");
        assert!((m.volume - 1.0).abs() < 1e-15);
    }

    #[test]
    fn open_box_is_rejected() {
        let (v, mut t) = box_raw(Vector::ONE);
        t.pop();
        assert!(matches!(ConvexMesh::new(v, t), Err(MeshError::Open { .. })));
    }

    #[test]
    fn dented_box_is_rejected_as_non_convex() {
        let (mut v, t) = box_raw(Vector::ONE);
        v[7] = Vector::splat(0.1); // pull a corner inside
        assert!(matches!(ConvexMesh::new(v, t), Err(MeshError::NonConvex { .. })));
    }

    #[test]
    fn flat_box_is_degenerate() {
        let (v, t) = box_raw(Vector::new(1.0, 0.0, 1.0));
        assert!(matches!(ConvexMesh::new(v, t), Err(MeshError::Degenerate { .. })));
    }
}
