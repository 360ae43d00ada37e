//! Many-faced convex hulls (a ball of 1 280 faces): the paper names "high polygon counts" its
//! limit, because its tests visit every feature of both bodies. Here the features that matter
//! are found near the contact: the vertex lowest along a direction by walking over vertex
//! neighbours (about √V steps, not V), the least-overlap axis among the faces and edges near
//! the bodies' overlap only, edge pairs kept only where their arcs cross on the Gauss map
//! (Gregorius, "The Separating Axis Test between Convex Polyhedra", GDC 2013), and separation
//! proved by GJK (Gilbert, Johnson, Keerthi 1988) instead of every face against every vertex.
//! Small meshes (a box) keep the exhaustive forms, which cost them less.

use crate::collision::manifold::{Axis, PREFER, Reference};
use crate::collision::posed::{BOUNDS_SLACK, Posed, in_box};
use crate::math::{Quat, Scalar, Vector};
use crate::model::mesh::ConvexMesh;

pub use crate::collision::gjk::{Shape, distance_bound, distance_bound_from, proved_apart};

/// The slab across the line of centres (see `contact_axis_near`) is widened by this share of
/// the reach, so features a fast pair may bring into contact this step are among those tried.
const SLAB_REACH: Scalar = 0.5;

/// True for a mesh whose contact tests take the paths of this module.
#[must_use]
pub fn is_many_faced(p: &Posed) -> bool {
    p.mesh.is_many_faced()
}

/// The vertex of `p` lowest along `dir` (least `v·dir`) and that value, walking from `start`
/// to a lower neighbour while there is one. On a convex hull a linear function has no local
/// minimum but the global one, so the walk ends there.
#[must_use]
pub fn lowest_vertex(p: &Posed, dir: Vector, start: u32) -> (u32, Scalar) {
    walk_down(&p.mesh, &p.vertices, dir, start)
}

/// The walk of `lowest_vertex` over `vertices`, the mesh's own (body frame) or posed ones.
#[inline]
fn walk_down(m: &ConvexMesh, vertices: &[Vector], dir: Vector, start: u32) -> (u32, Scalar) {
    let (mut at, mut value) = (start, vertices[start as usize].dot(dir));
    loop {
        let mut next = at;
        for &j in &m.neighbours[m.neighbour_start[at as usize] as usize..m.neighbour_start[at as usize + 1] as usize] {
            let v = vertices[j as usize].dot(dir);
            if v < value {
                (next, value) = (j, v);
            }
        }
        if next == at {
            return (at, value);
        }
        at = next;
    }
}

/// A many-faced mesh at a pose without its world vertices: `prune`'s GJK and bounds walk the
/// mesh's body-frame vertices along the direction turned into the body frame, and turn only
/// the vertex a walk ends at, as posing would (`Posed::update`, the same arithmetic). A walk
/// ends at the lowest vertex in either frame; the two frames' round-off could part only
/// vertices tied to within it, which a turned body does not have.
#[derive(Clone, Copy)]
pub struct Placed<'a> {
    /// The body-frame mesh.
    pub mesh: &'a ConvexMesh,
    /// World centre of mass [m].
    pub position: Vector,
    /// Body → world rotation.
    pub rotation: crate::math::Mat3,
}

impl Placed<'_> {
    /// World point of vertex `i`, to the bit the posed one.
    #[must_use]
    pub fn vertex(&self, i: u32) -> Vector {
        self.position + self.rotation * self.mesh.vertices[i as usize]
    }

    /// The vertex lowest along world `dir`, walking from `start`.
    #[must_use]
    pub fn lowest(&self, dir: Vector, start: u32) -> u32 {
        walk_down(self.mesh, &self.mesh.vertices, self.rotation.transpose() * dir, start).0
    }

    /// `lowest` from the seed of the cube direction nearest `−dir` (`lowest_vertex_seeded`).
    #[must_use]
    pub fn lowest_seeded(&self, dir: Vector) -> u32 {
        let d = self.rotation.transpose() * dir;
        let seed = self.mesh.seeds.get(crate::model::mesh::seed_index(-d)).copied().unwrap_or(0);
        walk_down(self.mesh, &self.mesh.vertices, d, seed).0
    }

    /// The world bounds of the vertices, (min, max) [m], as posing finds them: each the extreme
    /// vertex along a world axis, found by a walk from `hints` (its six vertices, updated).
    #[must_use]
    pub fn bounds(&self, hints: &mut [u32; 6]) -> (Vector, Vector) {
        let rows = self.rotation.transpose();
        let (mut lo, mut hi) = (Vector::ZERO, Vector::ZERO);
        for k in 0..3 {
            let d = rows.col(k);
            hints[2 * k] = walk_down(self.mesh, &self.mesh.vertices, d, hints[2 * k]).0;
            hints[2 * k + 1] = walk_down(self.mesh, &self.mesh.vertices, -d, hints[2 * k + 1]).0;
            lo[k] = self.vertex(hints[2 * k])[k];
            hi[k] = self.vertex(hints[2 * k + 1])[k];
        }
        (lo, hi)
    }
}

/// A quick proof that `p` lies beyond `b`'s inside tolerance `eps`: a face around the vertex of
/// `b` farthest towards `p` has `p` more than `eps` outside its plane. `false` proves nothing
/// (the full test decides). `hint` is where the walk starts, and is left at its end: nearby
/// points share most of their walks.
#[must_use]
pub fn outside_near_face(b: &Posed, p: Vector, eps: Scalar, hint: &mut u32) -> bool {
    beyond_near_face(b, &[p], eps, hint)
}

/// As `outside_near_face` for every point of `points` (at most two) beyond one and the same
/// face plane: then their segment (or hull) lies outside `b` too.
///
/// The points are taken into `b`'s body frame, where the planes need no turning, and must be
/// beyond a plane there by `eps` plus a slack far above the round-off between the frames: a
/// proof here is one the world planes give too, and a point too near to tell is left to the
/// full test, which then answers as it would have.
#[must_use]
pub fn beyond_near_face(b: &Posed, points: &[Vector], eps: Scalar, hint: &mut u32) -> bool {
    debug_assert!(points.len() <= 2, "one point or a segment");
    let towards = points.iter().sum::<Vector>() / points.len().max(1) as Scalar - b.position;
    let rows = b.rotation.transpose();
    let (top, _) = walk_down(&b.mesh, &b.mesh.vertices, -(rows * towards), *hint);
    *hint = top;
    let mut body = [Vector::ZERO; 2];
    let mut far = 0.0;
    for (q, &p) in body.iter_mut().zip(points) {
        *q = rows * (p - b.position);
        far = p.length().max(far);
    }
    let body = &body[..points.len().min(2)];
    let margin = eps + 1e-9 * (1.0 + b.position.length() + b.mesh.radius + far);
    let m = &b.mesh;
    row(&m.vertex_faces, &m.vertex_face_start, top)
        .iter()
        .map(|&f| &m.planes[f as usize])
        .any(|pl| body.iter().all(|&q| pl.normal.dot(q) - pl.offset > margin))
}

/// `lowest_vertex` started from the mesh's seed vertex of the cube direction nearest `−dir`
/// (found by turning `dir` into the body frame, not by trying every seed).
#[must_use]
pub fn lowest_vertex_seeded(p: &Posed, dir: Vector) -> (u32, Scalar) {
    let k = crate::model::mesh::seed_index(-(p.rotation.transpose() * dir));
    lowest_vertex(p, dir, p.mesh.seeds.get(k).copied().unwrap_or(0))
}

/// Where walks over the two bodies of a pair (A, B) start: a vertex of each found by an
/// earlier walk along a nearby direction, or `None` (start from the seeds). A walk ends at the
/// lowest vertex from any start, so hints change only how long it takes.
pub type Hints = [Option<u32>; 2];

/// The unit line of centres from `b` to `a`.
fn centre_line(a: &Posed, b: &Posed) -> Vector {
    (a.position - b.position).normalize_or(Vector::Y)
}

/// `lowest_vertex` from `hint`, or from the seeds without one.
#[must_use]
pub fn walk_from(p: &Posed, dir: Vector, hint: Option<u32>) -> (u32, Scalar) {
    hint.map_or_else(|| lowest_vertex_seeded(p, dir), |h| lowest_vertex(p, dir, h))
}

/// Hints for the tests of pair (A, B): each many-faced body's extreme vertex along the line of
/// centres, towards the other, which each test's walks along that line (and the normals near
/// it) then reach in a step or two.
#[must_use]
pub fn centre_walks(a: &Posed, b: &Posed) -> Hints {
    let d = centre_line(a, b);
    [is_many_faced(a).then(|| lowest_vertex_seeded(a, d).0), is_many_faced(b).then(|| lowest_vertex_seeded(b, -d).0)]
}

/// The normal of a face of small mesh `b` that many-faced `a` lies beyond, or sinks least
/// below, with `a`'s lowest vertex along it and its value: a thin slab of `a` for a flood to
/// visit (a ball on a floor: the floor's top, not the slanted line of centres). The face is
/// the one whose bound on the separation (`a` reaches no more than its radius below its
/// centre) is best, so one walk finds the vertex; any face would give the same answers.
fn apart_face(a: &Posed, b: &Posed, hint: Option<u32>) -> (Vector, (u32, Scalar)) {
    let bound = |pl: &crate::model::mesh::Plane| pl.normal.dot(a.position) - pl.offset;
    let best = b.all_planes().max_by(|x, y| bound(x).total_cmp(&bound(y)));
    let n = best.map_or(Vector::Y, |pl| pl.normal);
    (n, walk_from(a, n, hint))
}

/// The kinds of feature the tests gather near a contact.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Vertices (the vertex test).
    Vertices,
    /// Triangles (the face test's centroids).
    Triangles,
    /// Edges, indices into the mesh's `edges` (the edge test).
    Edges,
}

/// The features of many-faced `a` of one kind that have a vertex no higher along `d` than
/// `b`'s highest point plus `b`'s bounds slack, into `scratch.features` in increasing order;
/// `d` is the line of centres (from `b` to `a`) when `b` is many-faced too, else the normal of
/// the face of `b` that `apart_face` picks: any direction gives every feature that can touch.
/// A point of `a` inside `b` is no higher than that, and so is the lowest vertex of its
/// triangle or edge; those vertices are connected over vertex neighbours on a convex hull (a
/// level set of a linear function), so a flood from `a`'s lowest vertex along `d` finds them,
/// visiting only them and their neighbours. Returns `d` and the level: no point of `a` higher
/// along `d` can be inside `b`.
pub fn features_below(a: &Posed, b: &Posed, (kind, hints): (Kind, &Hints), scratch: &mut Flood) -> (Vector, Scalar) {
    let key = Some(([a.position, b.position], [a.orientation, b.orientation]));
    if scratch.below.key != key {
        flood_below(a, b, hints, scratch);
        scratch.below.key = key;
    }
    let m = &a.mesh;
    let Flood { features: out, set, below, .. } = scratch;
    let rows = match kind {
        Kind::Vertices => {
            out.clear();
            out.extend_from_slice(&below.vertices);
            return (below.d, below.level);
        }
        Kind::Triangles => (&m.vertex_triangles, &m.vertex_triangle_start, m.triangles.len()),
        Kind::Edges => (&m.vertex_all_edges, &m.vertex_all_edge_start, m.edges.len()),
    };
    out.clear();
    if below.vertices.is_empty() {
        return (below.d, below.level);
    }
    set.reset(rows.2);
    for &v in &below.vertices {
        set.extend(row(rows.0, rows.1, v));
    }
    set.sorted_into(out);
    (below.d, below.level)
}

/// The flood of `features_below` into `scratch.below`: the direction, the level and `a`'s
/// vertices no higher, increasing.
fn flood_below(a: &Posed, b: &Posed, hints: &Hints, scratch: &mut Flood) {
    let (d, (start, low)) = if is_many_faced(b) {
        let d = centre_line(a, b);
        (d, walk_from(a, d, hints[0]))
    } else {
        apart_face(a, b, hints[0])
    };
    let high_b = if is_many_faced(b) {
        -walk_from(b, -d, hints[1]).1
    } else {
        b.vertices.iter().map(|v| v.dot(d)).fold(Scalar::NEG_INFINITY, Scalar::max)
    };
    let level = high_b + BOUNDS_SLACK * b.mesh.radius;
    let m = &a.mesh;
    let Flood { seen, stack, below, .. } = scratch;
    (below.d, below.level) = (d, level);
    below.vertices.clear();
    if low > level {
        return;
    }
    seen.reset(m.vertices.len());
    stack.clear();
    stack.push(start);
    seen.extend(&[start]);
    while let Some(i) = stack.pop() {
        for &j in row(&m.neighbours, &m.neighbour_start, i) {
            if !seen.contains(j) && a.vertices[j as usize].dot(d) <= level {
                seen.extend(&[j]);
                stack.push(j);
            }
        }
    }
    seen.sorted_into(&mut below.vertices);
}

/// One way of a pair's flood (`features_below`), kept for the poses it was found at so the
/// three detection tests of a step flood once: the same poses give the same flood.
#[derive(Default)]
pub struct Below {
    /// A's and B's centres and orientations when found; `None` until then.
    key: Option<([Vector; 2], [Quat; 2])>,
    d: Vector,
    level: Scalar,
    vertices: Vec<u32>,
}

impl Below {
    /// Forgets the flood (keeping the buffer), so the next test floods afresh.
    pub fn clear(&mut self) {
        self.key = None;
    }
}

/// The reused buffers of `features_below`; `features` holds its answer.
#[derive(Default)]
pub struct Flood {
    /// The features found, increasing.
    pub features: Vec<u32>,
    /// The flood of the pair and way being tested: a caller that keeps one per pair and way
    /// swaps it in and out around each test (`Below`).
    pub below: Below,
    seen: BitSet,
    set: BitSet,
    stack: Vec<u32>,
}

/// A set of small indices, read back in increasing order: cheaper than sorting and
/// deduplicating the lists it gathers.
#[derive(Default)]
struct BitSet {
    words: Vec<u64>,
}

impl BitSet {
    /// Empties the set and sizes it for indices below `count`.
    fn reset(&mut self, count: usize) {
        self.words.clear();
        self.words.resize(count.div_ceil(64), 0);
    }

    /// Adds `items`, each below the count the set was `reset` for (mesh indices are).
    fn extend(&mut self, items: &[u32]) {
        for &i in items {
            self.words[i as usize / 64] |= 1 << (i % 64);
        }
    }

    fn contains(&self, i: u32) -> bool {
        self.words[i as usize / 64] & (1 << (i % 64)) != 0
    }

    fn sorted_into(&self, out: &mut Vec<u32>) {
        out.clear();
        out.reserve(self.words.iter().map(|w| w.count_ones() as usize).sum());
        for (w, &word) in self.words.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                out.push(w as u32 * 64 + bits.trailing_zeros());
                bits &= bits - 1;
            }
        }
    }
}

/// The features of one body near the overlap of two: the faces around its vertices in the
/// region, the feature edges at those also in the tight region, and a vertex to start walks
/// from. A small mesh gives all its features. With its buffers, reused per thread (`NEAR`).
#[derive(Default)]
struct Near {
    faces: Vec<u32>,
    edges: Vec<u32>,
    start: u32,
    seen: BitSet,
    face_set: BitSet,
    edge_set: BitSet,
    stack: Vec<u32>,
    /// B's edges' arcs on the Gauss map (`best_among`).
    arcs: Vec<(Vector, Vector)>,
    /// True when `faces` is every face (an unlimited reach).
    all: bool,
    /// Scratch of `best_grouped`: each plane group's bound and index.
    groups: Vec<(Scalar, u32)>,
    /// The world normals of the faces around the edges `best_among` pairs.
    normals: Normals,
}

/// World face normals of one body, each turned once a search (`best_among`'s edge pairs read
/// a face's normal for each edge around it): the same arithmetic as `Posed::plane`, so the
/// same bits.
#[derive(Default)]
struct Normals {
    /// The search in which each face's normal was turned; 0 for none.
    stamp: Vec<u32>,
    normal: Vec<Vector>,
    search: u32,
}

impl Normals {
    /// Starts a search of body `p`: every normal is to be turned afresh.
    fn begin(&mut self, p: &Posed) {
        let count = p.plane_count();
        if self.stamp.len() < count || self.search == u32::MAX {
            self.stamp.clear();
            self.stamp.resize(count.max(self.normal.len()), 0);
            self.normal.resize(self.stamp.len(), Vector::ZERO);
            self.search = 0;
        }
        self.search += 1;
    }

    /// The world normal of face `f` of the body of this search.
    fn get(&mut self, p: &Posed, f: u32) -> Vector {
        let i = f as usize;
        if self.stamp[i] != self.search {
            (self.stamp[i], self.normal[i]) = (self.search, p.plane(i).normal);
        }
        self.normal[i]
    }
}

thread_local! {
    /// `contact_axis_near`'s two `Near`s, one pair a thread: no allocation once sized.
    static NEAR: std::cell::RefCell<[Near; 2]> = std::cell::RefCell::default();
}

/// Where the bodies may meet: a box, and a slab across the line of centres `d` (`lo ≤ p·d ≤
/// hi`) from A's lowest point along `d` to B's highest, so one body's features far round the
/// other's side are left out.
#[derive(Clone, Copy)]
struct Region {
    bounds: (Vector, Vector),
    d: Vector,
    slab: (Scalar, Scalar),
}

impl Region {
    /// True when the region holds every finite point (an unlimited reach).
    fn is_everywhere(&self) -> bool {
        let (lo, hi) = self.bounds;
        lo.cmpeq(Vector::NEG_INFINITY).all()
            && hi.cmpeq(Vector::INFINITY).all()
            && self.slab == (Scalar::NEG_INFINITY, Scalar::INFINITY)
    }
}

/// The features of `p` near `region`, into `out`: flooding from `from` (a vertex in it) over
/// neighbours that are in it too, then the faces and feature edges at the vertices reached. A
/// contact patch is one connected piece of a convex surface, so the flood reaches all of it
/// while visiting only it.
fn near(p: &Posed, (wide, tight): (&Region, &Region), from: u32, out: &mut Near) {
    let m = &p.mesh;
    out.start = from;
    out.faces.clear();
    out.edges.clear();
    out.all = wide.is_everywhere();
    if !is_many_faced(p) {
        out.faces.extend(0..m.planes.len() as u32);
        out.edges.extend(0..m.feature_edges.len() as u32);
        return;
    }
    let within = |region: &Region, i: u32| {
        let v = p.vertices[i as usize];
        let s = v.dot(region.d);
        in_box(v, region.bounds) && s >= region.slab.0 && s <= region.slab.1
    };
    let Near { faces, edges, seen, face_set, edge_set, stack, .. } = out;
    edge_set.reset(m.feature_edges.len());
    if wide.is_everywhere() {
        // The flood would reach every vertex (the mesh is connected), so every face: the same
        // lists without the flood, the faces left implied by `all` (`best_among` lists them
        // only if it iterates them rather than taking them by plane group).
        // An empty tight box (bodies apart along a world axis) holds no vertex: only the
        // start's edges.
        let (lo, hi) = tight.bounds;
        let vertices = if lo.cmpgt(hi).any() { from..from + 1 } else { 0..m.vertices.len() as u32 };
        for i in vertices {
            if i == from || within(tight, i) {
                edge_set.extend(row(&m.vertex_edges, &m.vertex_edge_start, i));
            }
        }
        edge_set.sorted_into(edges);
        return;
    }
    seen.reset(m.vertices.len());
    face_set.reset(m.planes.len());
    stack.clear();
    stack.push(from);
    seen.extend(&[from]);
    while let Some(i) = stack.pop() {
        face_set.extend(row(&m.vertex_faces, &m.vertex_face_start, i));
        // The start is the body's point nearest the other: its edges are always tried.
        if i == from || within(tight, i) {
            edge_set.extend(row(&m.vertex_edges, &m.vertex_edge_start, i));
        }
        for &j in row(&m.neighbours, &m.neighbour_start, i) {
            if !seen.contains(j) && within(wide, j) {
                seen.extend(&[j]);
                stack.push(j);
            }
        }
    }
    face_set.sorted_into(faces);
    edge_set.sorted_into(edges);
}

/// The bound of `best_among` on a face of many-faced `q` measured in `q`'s body frame, where
/// its plane need not be turned: the start vertex and the last walk's end of the other body
/// taken into that frame, and a slack far above the round-off between the two frames, so a
/// face this bound rules out is one the exact bound rules out too.
struct Rough {
    points: [Vector; 2],
    slack: Scalar,
}

impl Rough {
    /// For the faces of `q` against world points `[start, last]`; `None` for a small mesh,
    /// whose world planes are at hand.
    fn of(q: &Posed, [start, last]: [Vector; 2]) -> Option<Self> {
        let slack = 1e-9 * (1.0 + q.position.length() + q.mesh.radius + start.length().max(last.length()));
        let to_body = |p: Vector| q.rotation.transpose() * (p - q.position);
        is_many_faced(q).then(|| Self { points: [to_body(start), to_body(last)], slack })
    }

    /// Replaces the last walk's end, and widens the slack for it if need be.
    fn set_last(&mut self, q: &Posed, last: Vector) {
        self.points[1] = q.rotation.transpose() * (last - q.position);
        self.slack = self.slack.max(1e-9 * (1.0 + q.position.length() + q.mesh.radius + last.length()));
    }

    /// At least the exact bound on face `f` (the lower point's height above its plane).
    fn bound(&self, q: &Posed, f: u32) -> Scalar {
        let pl = &q.mesh.planes[f as usize];
        self.points[0].dot(pl.normal).min(self.points[1].dot(pl.normal)) - pl.offset + self.slack
    }
}

/// Where a walk over `p` along `normal` starts: the start vertex or the last walk's end,
/// whichever is lower along it (faces in a row lie near each other), and its value. Any
/// vertex bounds the lowest, so the lower one skips more faces and walks fewer steps, to the
/// same lowest vertex.
fn pick(p: &Posed, normal: Vector, (start, last): (u32, u32)) -> (u32, Scalar) {
    let (at_start, at_last) = (p.vertices[start as usize].dot(normal), p.vertices[last as usize].dot(normal));
    if at_last < at_start { (last, at_last) } else { (start, at_start) }
}

/// A face of many-faced `b` among those `best_among` tries (one around `start_b`, the flood's
/// start, which every flood takes in), the one most along the line of centres, and `a`'s
/// exact separation along its normal, walked from `start_a`: (separation, the walk's end).
/// Any face would do; this one tends to be near the best, so its separation prunes most.
fn floor_face(a: &Posed, b: &Posed, (start_a, start_b): (u32, u32)) -> (Scalar, u32) {
    let m = &b.mesh;
    let d = b.rotation.transpose() * (a.position - b.position);
    let around = row(&m.vertex_faces, &m.vertex_face_start, start_b);
    let along = |f: &&u32| m.planes[**f as usize].normal.dot(d);
    let face = *around.iter().max_by(|x, y| along(x).total_cmp(&along(y))).unwrap_or(&0);
    let pl = b.plane(face as usize);
    let (end, lowest) = lowest_vertex(a, pl.normal, start_a);
    (lowest - pl.offset, end)
}

/// Among every face of many-faced `q`, the one along whose normal `p` lies farthest out (or
/// sinks least), by more than `floor` if given: the face, its world normal and that
/// separation. The answer of a scan in index order keeping only strict gains (the first
/// face of the largest separation), found by visiting `q`'s plane groups (`PlaneGroup`) best
/// bound first and stopping at the first whose bound cannot reach the best so far, so every
/// face that could win is walked and, ties broken by index, the same one wins. `start` is a
/// vertex of `p` near `q`; `order` is scratch.
fn best_grouped(
    q: &Posed,
    p: &Posed,
    start: u32,
    floor: Option<Scalar>,
    order: &mut Vec<(Scalar, u32)>,
) -> Option<(u32, Vector, Scalar)> {
    let mut rough = Rough::of(q, [p.vertices[start as usize]; 2])?;
    let (point, groups) = (rough.points[0], &q.mesh.plane_groups);
    order.clear();
    order.extend(groups.iter().enumerate().map(|(k, g)| (g.bound(point, point.length()), k as u32)));
    order.sort_unstable_by(|x, y| y.0.total_cmp(&x.0));
    let mut top: Option<(Scalar, u32, Vector)> = None;
    // True when face `f` (or a group, as face 0) bounded by `bound` cannot win: not above the
    // floor, below the best, or level with it at a later face.
    let out = |top: &Option<(Scalar, u32, Vector)>, bound: Scalar, f: u32| {
        floor.is_some_and(|x| bound <= x) || top.is_some_and(|t| bound < t.0 || (bound == t.0 && f > t.1))
    };
    let mut last = start;
    for &(bound, g) in order.iter() {
        // The group's bound holds in `q`'s frame; the rough slack covers the world's round-off.
        if out(&top, bound + rough.slack, 0) {
            break; // and every later group, bounded lower
        }
        for &f in &groups[g as usize].planes {
            if out(&top, rough.bound(q, f), f) {
                continue;
            }
            let pl = q.plane(f as usize);
            let (from, at) = pick(p, pl.normal, (start, last));
            if out(&top, at - pl.offset, f) {
                continue;
            }
            let (end, lowest) = lowest_vertex(p, pl.normal, from);
            last = end;
            rough.set_last(q, p.vertices[end as usize]);
            if !out(&top, lowest - pl.offset, f) {
                top = Some((lowest - pl.offset, f, pl.normal));
            }
        }
    }
    top.map(|(separation, f, normal)| (f, normal, separation))
}

/// Row `i` of a flat list with start offsets.
fn row<'a>(flat: &'a [u32], start: &[u32], i: u32) -> &'a [u32] {
    &flat[start[i as usize] as usize..start[i as usize + 1] as usize]
}

/// True when edge arcs (a, b) and (c, d) cross on the Gauss map, the arcs given by their end
/// normals and `c`, `d` already negated (the Minkowski difference's face test of Gregorius):
/// only such edge pairs can give the least-overlap axis.
fn arcs_cross(a: Vector, b: Vector, c: Vector, d: Vector) -> bool {
    let (bxa, dxc) = (b.cross(a), d.cross(c));
    let (cba, dba, adc, bdc) = (c.dot(bxa), d.dot(bxa), a.dot(dxc), b.dot(dxc));
    cba * dba < 0.0 && adc * bdc < 0.0 && cba * bdc > 0.0
}

/// `manifold::contact_axis` for a pair with a many-faced body: the same choice among the faces
/// and edge pairs near the bodies' overlap (their bounds' intersection widened by `reach`).
/// `None` when some axis parts them by more than `reach`.
#[must_use]
pub fn contact_axis_near(a: &Posed, b: &Posed, (margin, reach): (Scalar, Scalar)) -> Option<Axis> {
    let (lo, hi) = bounds_overlap(a, b, reach)?;
    let d = (a.position - b.position).normalize_or(Vector::Y);
    let ((from_a, low_a), (from_b, low_b)) = (lowest_vertex_seeded(a, d), lowest_vertex_seeded(b, -d));
    let high_b = -low_b;
    let slack = BOUNDS_SLACK * a.mesh.radius.max(b.mesh.radius) + SLAB_REACH * reach.max(0.0);
    let slab = (low_a.min(high_b) - slack, low_a.max(high_b) + slack);
    let region = Region { bounds: (lo, hi), d, slab };
    // Edge pairs only where the bodies meet now: an edge axis matters for edges that touch or
    // cross, and a pair still apart by up to the reach is held along a face axis as well.
    let tight = BOUNDS_SLACK * a.mesh.radius.max(b.mesh.radius);
    let edges_region = Region {
        bounds: (a.bounds.0.max(b.bounds.0) - Vector::splat(tight), a.bounds.1.min(b.bounds.1) + Vector::splat(tight)),
        d,
        slab: (low_a.min(high_b) - tight, low_a.max(high_b) + tight),
    };
    with_near(|na, nb| {
        near(a, (&region, &edges_region), from_a, na);
        near(b, (&region, &edges_region), from_b, nb);
        best_among(a, b, (na, nb), (margin, reach))
    })
}

/// Runs `f` on this thread's two `Near` buffers (A's, B's). A nested call (none today) would
/// find them taken: it gets its own.
fn with_near<R>(f: impl FnOnce(&mut Near, &mut Near) -> R) -> R {
    NEAR.with(|cell| {
        let (mut held, mut fresh) = (cell.try_borrow_mut(), None);
        let [na, nb] = match held.as_deref_mut() {
            Ok(buffers) => buffers,
            Err(_) => fresh.insert(<[Near; 2]>::default()),
        };
        f(na, nb)
    })
}

/// The overlap of the two bodies' bounds widened by `reach` (and the bounds' slack), or
/// `None` when they are apart along a coordinate axis by more than that.
fn bounds_overlap(a: &Posed, b: &Posed, reach: Scalar) -> Option<(Vector, Vector)> {
    let widen = reach.max(0.0) + BOUNDS_SLACK * a.mesh.radius.max(b.mesh.radius);
    let lo = a.bounds.0.max(b.bounds.0) - Vector::splat(widen);
    let hi = a.bounds.1.min(b.bounds.1) + Vector::splat(widen);
    (!lo.cmpgt(hi).any()).then_some((lo, hi))
}

/// `contact_axis_near` for a pair whose axis last step was face `f` of `hint` (B's, or A's
/// when `of_a`): the features near that face's neighbourhood instead of the floods. A climb
/// over the hinted body's faces, from `f` to the neighbouring face (sharing a vertex) that
/// parts the bodies more while there is one, finds where the least overlap has moved to (the
/// separation over a ball's faces has a single hump where the bodies meet); then the same
/// choice as `contact_axis_near` among the faces and edges around that face and the other
/// body's vertex lowest along its normal. A pair that moved a little needs a step or two of
/// the climb, not two floods (Box3D's SAT cache, rapier's manifold reuse).
#[must_use]
pub fn contact_axis_hinted(
    a: &Posed,
    b: &Posed,
    (margin, reach): (Scalar, Scalar),
    (of_a, f): (bool, u32),
) -> Option<Axis> {
    let (q, p) = if of_a { (a, b) } else { (b, a) };
    if f as usize >= q.plane_count() || !(is_many_faced(a) || is_many_faced(b)) {
        return crate::collision::manifold::contact_axis(a, b, (margin, reach));
    }
    bounds_overlap(a, b, reach)?;
    let (face, low, separation) = climb(q, p, f);
    // Edge pairs only where the bodies meet now, as `contact_axis_near` takes them.
    let touching = separation <= BOUNDS_SLACK * a.mesh.radius.max(b.mesh.radius);
    with_near(|na, nb| {
        let (nq, np) = if of_a { (na, nb) } else { (nb, na) };
        around_face(q, face, p.vertices[low as usize], touching, nq);
        around_vertex(p, low, np);
        let (na, nb) = if of_a { (nq, np) } else { (np, nq) };
        best_among(a, b, (na, nb), (margin, reach))
    })
}

/// An axis for a pair no test found touching whose axis last step was face `f` (A's when
/// `of_a`, else B's): the climb of `contact_axis_hinted` over that body's faces, without the choice among
/// the features around it. The face it ends at parts the bodies by its separation, so it is a
/// separating axis, and the gap along it no more than their distance: what a speculative
/// contact needs. `None` when the face does not part them (the full search decides).
#[must_use]
pub fn climbed_axis(a: &Posed, b: &Posed, (of_a, f): (bool, u32)) -> Option<Axis> {
    let (q, p) = if of_a { (a, b) } else { (b, a) };
    if f as usize >= q.plane_count() || !(is_many_faced(a) || is_many_faced(b)) {
        return None;
    }
    let (face, _, separation) = climb(q, p, f);
    let n = q.plane(face as usize).normal;
    let (normal, reference) = if of_a { (-n, Reference::FaceOfA(face)) } else { (n, Reference::FaceOfB(face)) };
    (separation > 0.0).then_some(Axis { normal, separation, reference })
}

/// From face `f` of `q`, the face of `q` along whose normal `p` lies farthest out, as far as
/// moving to a better neighbour (a face sharing a vertex) reaches: (face, `p`'s vertex lowest
/// along its normal, the separation). A small `q` has no climb: its faces are all tried.
fn climb(q: &Posed, p: &Posed, f: u32) -> (u32, u32, Scalar) {
    let pl = q.plane(f as usize);
    let (mut low, lowest) = lowest_vertex_seeded(p, pl.normal);
    let (mut face, mut best) = (f, lowest - pl.offset);
    if !is_many_faced(q) {
        return (face, low, best);
    }
    let m = &q.mesh;
    loop {
        let mut rough = Rough::of(q, [p.vertices[low as usize]; 2]).expect("many-faced");
        let mut next = None;
        for &v in row(&m.face_vertices, &m.face_start, face) {
            for &g in row(&m.vertex_faces, &m.vertex_face_start, v) {
                if g == face || rough.bound(q, g) <= best {
                    continue;
                }
                let pl = q.plane(g as usize);
                let (end, lowest) = lowest_vertex(p, pl.normal, low);
                rough.set_last(q, p.vertices[end as usize]);
                if lowest - pl.offset > best {
                    (best, next) = (lowest - pl.offset, Some((g, end)));
                }
            }
        }
        let Some((g, end)) = next else { return (face, low, best) };
        (face, low) = (g, end);
    }
}

/// The features of `q` around its face `f` into `out`: the faces at its vertices, and the
/// feature edges there when `touching` (else only at the start), the start being the face's
/// vertex nearest `towards`. A small mesh gives all its features.
fn around_face(q: &Posed, f: u32, towards: Vector, touching: bool, out: &mut Near) {
    let m = &q.mesh;
    out.faces.clear();
    out.edges.clear();
    out.all = false;
    let corners = row(&m.face_vertices, &m.face_start, f);
    let distance = |v: &&u32| (q.vertices[**v as usize] - towards).length_squared();
    let start = *corners.iter().min_by(|x, y| distance(x).total_cmp(&distance(y))).unwrap_or(&0);
    out.start = start;
    if !is_many_faced(q) {
        out.faces.extend(0..m.planes.len() as u32);
        out.edges.extend(0..m.feature_edges.len() as u32);
        return;
    }
    let Near { faces, edges, face_set, edge_set, .. } = out;
    face_set.reset(m.planes.len());
    edge_set.reset(m.feature_edges.len());
    for &v in corners {
        face_set.extend(row(&m.vertex_faces, &m.vertex_face_start, v));
    }
    for &v in if touching { corners } else { std::slice::from_ref(&start) } {
        edge_set.extend(row(&m.vertex_edges, &m.vertex_edge_start, v));
    }
    face_set.sorted_into(faces);
    edge_set.sorted_into(edges);
}

/// The features of `p` at its vertex `v` into `out` (the faces and feature edges around it,
/// `v` the start), or all of a small mesh's. Only `v`'s edges: a ring further out multiplies
/// the edge pairs tried (and their cost) by about four, for deep overlaps a resting pair has not.
fn around_vertex(p: &Posed, v: u32, out: &mut Near) {
    let m = &p.mesh;
    out.faces.clear();
    out.edges.clear();
    out.all = false;
    out.start = v;
    if !is_many_faced(p) {
        out.faces.extend(0..m.planes.len() as u32);
        out.edges.extend(0..m.feature_edges.len() as u32);
        return;
    }
    out.faces.extend_from_slice(row(&m.vertex_faces, &m.vertex_face_start, v));
    out.faces.sort_unstable();
    out.edges.extend_from_slice(row(&m.vertex_edges, &m.vertex_edge_start, v));
    out.edges.sort_unstable();
}

/// `contact_axis_near`'s choice among the features `na` of A and `nb` of B.
fn best_among(
    a: &Posed,
    b: &Posed,
    (na, nb): (&mut Near, &mut Near),
    (margin, reach): (Scalar, Scalar),
) -> Option<Axis> {
    // A many-faced body's faces at an unlimited reach are taken by plane group (below, B's
    // always, A's without a preference); A's are listed only if iterated.
    if na.all && na.faces.is_empty() && !(PREFER * margin == 0.0 && is_many_faced(a)) {
        na.faces.extend(0..a.plane_count() as u32);
    }
    if (na.faces.is_empty() && !na.all) || (nb.faces.is_empty() && !nb.all) {
        return crate::collision::manifold::contact_axis_all(a, b, (margin, reach));
    }
    let (ea, eb) = (&na.edges, &nb.edges);
    let mut best: Option<Axis> = None;
    // An axis is taken only if it beats the best so far by `prefer`; a face whose bound (the
    // other body's start vertex, no lower than its lowest) cannot do that needs no walk.
    let wins = |best: &Option<Axis>, separation: Scalar, prefer: Scalar| {
        best.is_none_or(|x| separation > x.separation + prefer)
    };
    let consider =
        |best: &mut Option<Axis>, normal: Vector, separation: Scalar, reference: Reference, prefer: Scalar| {
            if wins(best, separation, prefer) {
                *best = Some(Axis { normal, separation, reference });
            }
        };
    let mut groups = std::mem::take(&mut nb.groups);
    if nb.all && is_many_faced(b) {
        let face = best_grouped(b, a, na.start, None, &mut groups);
        best = face.map(|(f, normal, separation)| Axis { normal, separation, reference: Reference::FaceOfB(f) });
    } else {
        let mut last = na.start;
        let mut rough = Rough::of(b, [a.vertices[na.start as usize]; 2]);
        // B's faces give the first face of the largest separation, which is at least that of
        // any one face among them: with one walked first, faces bounded below it need no walk.
        let floor = rough.as_mut().map_or(Scalar::NEG_INFINITY, |r| {
            let (separation, end) = floor_face(a, b, (na.start, nb.start));
            last = end;
            r.set_last(b, a.vertices[end as usize]);
            separation
        });
        for &f in &nb.faces {
            if rough.as_ref().is_some_and(|r| {
                let bound = r.bound(b, f);
                bound < floor || !wins(&best, bound, 0.0)
            }) {
                continue;
            }
            let pl = b.plane(f as usize);
            let (from, bound) = pick(a, pl.normal, (na.start, last));
            if bound - pl.offset >= floor && wins(&best, bound - pl.offset, 0.0) {
                let (end, lowest) = lowest_vertex(a, pl.normal, from);
                last = end;
                if let Some(r) = rough.as_mut() {
                    r.set_last(b, a.vertices[end as usize]);
                }
                consider(&mut best, pl.normal, lowest - pl.offset, Reference::FaceOfB(f), 0.0);
            }
        }
    }
    // With no preference (`margin` 0) A's faces, too, need only beat the best strictly.
    if na.all && PREFER * margin == 0.0 && is_many_faced(a) {
        let floor = best.map(|x| x.separation);
        if let Some((f, n, separation)) = best_grouped(a, b, nb.start, floor, &mut groups) {
            best = Some(Axis { normal: -n, separation, reference: Reference::FaceOfA(f) });
        }
    } else {
        let mut last = nb.start;
        let mut rough = Rough::of(a, [b.vertices[nb.start as usize]; 2]);
        for &f in &na.faces {
            if rough.as_ref().is_some_and(|r| !wins(&best, r.bound(a, f), PREFER * margin)) {
                continue;
            }
            let pl = a.plane(f as usize);
            let (from, bound) = pick(b, pl.normal, (nb.start, last));
            if wins(&best, bound - pl.offset, PREFER * margin) {
                let (end, lowest) = lowest_vertex(b, pl.normal, from);
                last = end;
                if let Some(r) = rough.as_mut() {
                    r.set_last(a, b.vertices[end as usize]);
                }
                consider(&mut best, -pl.normal, lowest - pl.offset, Reference::FaceOfA(f), PREFER * margin);
            }
        }
    }
    nb.groups = groups;
    // B's edges' arcs, turned once for all of A's edges.
    let mut arcs_b = std::mem::take(&mut nb.arcs);
    let (mut turned_a, mut turned_b) = (std::mem::take(&mut na.normals), std::mem::take(&mut nb.normals));
    turned_b.begin(b);
    arcs_b.clear();
    arcs_b.extend(eb.iter().map(|&e| {
        let [h, m] = b.mesh.feature_edge_faces[e as usize].map(|f| -turned_b.get(b, f));
        (h, m)
    }));
    turned_a.begin(a);
    for &ea in if arcs_b.is_empty() { &[][..] } else { &ea[..] } {
        let ([i, j], [f, g]) = (a.mesh.feature_edges[ea as usize], a.mesh.feature_edge_faces[ea as usize]);
        let (a0, a1) = (a.vertices[i as usize], a.vertices[j as usize]);
        let (fa, ga) = (turned_a.get(a, f), turned_a.get(a, g));
        for (&eb, &(hb, mb)) in eb.iter().zip(&arcs_b) {
            if !arcs_cross(fa, ga, hb, mb) {
                continue;
            }
            let [k, l] = b.mesh.feature_edges[eb as usize];
            let (b0, b1) = (b.vertices[k as usize], b.vertices[l as usize]);
            let Some(n) = (a1 - a0).cross(b1 - b0).try_normalize() else { continue };
            // Outward of B at its edge, so from B to A; the gap is then between the two lines.
            let n = if n.dot(b0 - b.position) < 0.0 { -n } else { n };
            consider(&mut best, n, n.dot(a0 - b0), Reference::Edges, PREFER * margin);
        }
    }
    (nb.arcs, na.normals, nb.normals) = (arcs_b, turned_a, turned_b);
    best.filter(|x| x.separation <= reach)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::manifold::contact_axis_all;
    use crate::math::Quat;
    use crate::model::components::Pose;
    use crate::model::mesh::ConvexMesh;
    use crate::model::shapes::icosphere_raw;
    use crate::rng::SplitMix64;
    use std::sync::Arc;

    fn ball(subdivisions: u32) -> Arc<ConvexMesh> {
        let (v, t) = icosphere_raw(0.5, subdivisions);
        Arc::new(ConvexMesh::new(v, t).expect("an icosphere is valid").0)
    }

    fn random_turn(rng: &mut SplitMix64) -> Quat {
        let axis = Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5).normalize_or(Vector::Y);
        Quat::from_axis_angle(axis, 6.3 * rng.unit())
    }

    #[test]
    fn the_walk_finds_the_lowest_vertex_from_anywhere() {
        let mesh = ball(3);
        let mut rng = SplitMix64::new(7);
        for _ in 0..200 {
            let p = Posed::new(mesh.clone(), &Pose { position: Vector::ZERO, orientation: random_turn(&mut rng) });
            let dir = Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5);
            let start = (rng.unit() * 642.0) as u32 % 642;
            let lowest = p.vertices.iter().map(|v| v.dot(dir)).fold(Scalar::INFINITY, Scalar::min);
            assert_eq!(lowest_vertex(&p, dir, start).1, lowest);
        }
    }

    #[test]
    fn the_axis_searched_from_last_steps_face_is_as_good_as_the_exhaustive_one() {
        let (small, box_mesh) = (ball(1), Arc::new(ConvexMesh::cuboid(Vector::new(3.0, 1.0, 3.0))));
        let mut rng = SplitMix64::new(12);
        let (margin, reach) = (0.02, 0.05);
        let lowest = |p: &Posed, d: Vector| p.vertices.iter().map(|v| v.dot(d)).fold(Scalar::INFINITY, Scalar::min);
        let mut hinted = 0;
        for case in 0..300 {
            let dir = Vector::new(rng.unit() - 0.5, rng.unit() - 0.2, rng.unit() - 0.5).normalize();
            let other = if case % 2 == 0 { small.clone() } else { box_mesh.clone() };
            let d = 0.95 + 0.03 * (rng.unit() - 0.5);
            let (turn_a, turn_b) = (random_turn(&mut rng), random_turn(&mut rng));
            let b = Posed::new(other, &Pose { position: Vector::ZERO, orientation: turn_b });
            let before = Posed::new(small.clone(), &Pose { position: dir * d, orientation: turn_a });
            // Last step's axis, then A moved by up to 2 cm and turned by up to 0.05 rad.
            let Some(last) = contact_axis_near(&before, &b, (margin, reach)) else { continue };
            let shift = Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5) * 0.04;
            let nudge = Quat::from_axis_angle(dir.any_orthonormal_vector(), 0.1 * (rng.unit() - 0.5));
            let a = Posed::new(small.clone(), &Pose { position: dir * d + shift, orientation: nudge * turn_a });
            let hint = match last.reference {
                Reference::FaceOfB(f) => (false, f),
                Reference::FaceOfA(f) => (true, f),
                Reference::Edges => continue,
            };
            hinted += 1;
            let (from, all) =
                (contact_axis_hinted(&a, &b, (margin, reach), hint), contact_axis_all(&a, &b, (margin, reach)));
            match (from, all) {
                (Some(n), Some(x)) => {
                    let true_gap = lowest(&a, n.normal) + lowest(&b, -n.normal);
                    assert!((true_gap - n.separation).abs() < 1e-12, "case {case}: {n:?} really {true_gap}");
                    assert!(n.separation >= x.separation - PREFER * margin - 1e-12, "case {case}: {n:?} vs {x:?}");
                }
                (None, None) => {}
                // At the reach's edge the local search may keep a pair the exhaustive one parts.
                (Some(n), None) => assert!(n.separation > 0.0, "case {case}: {n:?}"),
                other => panic!("case {case}: {other:?}"),
            }
        }
        assert!(hinted > 200, "{hinted}");
    }

    #[test]
    fn the_near_axis_is_the_exhaustive_one_for_touching_balls_and_a_ball_on_a_box() {
        let (small, box_mesh) = (ball(1), Arc::new(ConvexMesh::cuboid(Vector::new(3.0, 1.0, 3.0))));
        let mut rng = SplitMix64::new(11);
        let (margin, reach) = (0.02, 0.05);
        for case in 0..200 {
            let turn = random_turn(&mut rng);
            let dir = Vector::new(rng.unit() - 0.5, rng.unit() - 0.2, rng.unit() - 0.5).normalize();
            let (other, distance) = if case % 2 == 0 { (small.clone(), 0.95) } else { (box_mesh.clone(), 0.95) };
            // Centres a little under or over touching, along a random direction.
            let d = distance + 0.06 * (rng.unit() - 0.5);
            let a = Posed::new(small.clone(), &Pose { position: dir * d, orientation: turn });
            let b = Posed::new(other, &Pose { position: Vector::ZERO, orientation: random_turn(&mut rng) });
            let (near, all) = (contact_axis_near(&a, &b, (margin, reach)), contact_axis_all(&a, &b, (margin, reach)));
            match (near, all) {
                (Some(n), Some(x)) => {
                    // Both are true separations along their normals, and the near search
                    // misses no better axis (beyond the hysteresis both apply).
                    let lowest =
                        |p: &Posed, d: Vector| p.vertices.iter().map(|v| v.dot(d)).fold(Scalar::INFINITY, Scalar::min);
                    let true_gap = lowest(&a, n.normal) + lowest(&b, -n.normal);
                    assert!((true_gap - n.separation).abs() < 1e-12, "case {case}: {n:?} really {true_gap}");
                    assert!(n.separation >= x.separation - PREFER * margin - 1e-12, "case {case}: {n:?} vs {x:?}");
                    assert!(x.separation >= n.separation - PREFER * margin - 1e-12, "case {case}: {n:?} vs {x:?}");
                }
                (None, None) => {}
                other => panic!("case {case}: {other:?}"),
            }
        }
    }

    #[test]
    fn a_near_face_proves_outside_only_points_that_are_outside() {
        let b = Posed::new(ball(3), &Pose { position: Vector::new(0.1, 0.2, 0.3), orientation: Quat::IDENTITY });
        let mut rng = SplitMix64::new(3);
        let (mut proved, mut hint) = (0, 0);
        for _ in 0..2000 {
            let dir = Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5).normalize();
            let p = b.position + dir * (0.47 + 0.06 * rng.unit());
            let inside = crate::collision::posed::is_inside(&b, p);
            if outside_near_face(&b, p, b.tolerance(), &mut hint) {
                assert!(!inside, "{p} is inside");
                proved += 1;
            } else {
                // Points this close to the surface are decided by their own face.
                assert!(inside || b.max_plane_distance(p) <= 1e-3, "{p} missed");
            }
        }
        assert!(proved > 1000, "most points outside are proved so: {proved}");
    }

    #[test]
    fn a_seeded_walk_finds_the_lowest_vertex_and_the_seeds_follow_their_directions() {
        let mesh = ball(3);
        let mut directions = Vec::new();
        for x in [-1.0, 0.0, 1.0] {
            for y in [-1.0, 0.0, 1.0] {
                directions
                    .extend([-1.0, 0.0, 1.0].map(|z| Vector::new(x, y, z)).into_iter().filter(|d| *d != Vector::ZERO));
            }
        }
        assert_eq!(mesh.seeds.len(), 26);
        for (k, (&seed, &d)) in mesh.seeds.iter().zip(&directions).enumerate() {
            // Seed k is farthest along its cube direction, which seed_index maps back to k.
            assert_eq!(crate::model::mesh::seed_index(d), k, "{d}");
            let top = mesh.vertices.iter().map(|v| v.dot(d)).fold(Scalar::NEG_INFINITY, Scalar::max);
            assert_eq!(mesh.vertices[seed as usize].dot(d), top, "{d}");
        }
        let mut rng = SplitMix64::new(5);
        for _ in 0..500 {
            let p = Posed::new(
                mesh.clone(),
                &Pose { position: Vector::new(3.0, -1.0, 2.0), orientation: random_turn(&mut rng) },
            );
            let dir = Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5);
            let lowest = p.vertices.iter().map(|v| v.dot(dir)).fold(Scalar::INFINITY, Scalar::min);
            assert_eq!(lowest_vertex_seeded(&p, dir).1, lowest);
        }
    }

    #[test]
    fn an_unlimited_reach_gives_the_axis_of_a_reach_that_covers_both_bodies() {
        // Unlimited, every face is taken without a flood; a reach of a kilometre floods every
        // vertex of both. The same faces and edges, so the same axis to the bit.
        let (small, box_mesh) = (ball(2), Arc::new(ConvexMesh::cuboid(Vector::new(3.0, 1.0, 3.0))));
        let mut rng = SplitMix64::new(13);
        for case in 0..200 {
            let dir = Vector::new(rng.unit() - 0.5, rng.unit() - 0.2, rng.unit() - 0.5).normalize();
            let other = if case % 2 == 0 { small.clone() } else { box_mesh.clone() };
            let a = Posed::new(
                small.clone(),
                &Pose { position: dir * (1.0 + 2.0 * rng.unit()), orientation: random_turn(&mut rng) },
            );
            let b = Posed::new(other, &Pose { position: Vector::ZERO, orientation: random_turn(&mut rng) });
            let unlimited = contact_axis_near(&a, &b, (0.0, Scalar::INFINITY));
            assert_eq!(unlimited, contact_axis_near(&a, &b, (0.0, 1e3)), "case {case}");
            let axis = unlimited.expect("an axis");
            let lowest = |p: &Posed, d: Vector| p.vertices.iter().map(|v| v.dot(d)).fold(Scalar::INFINITY, Scalar::min);
            let gap = lowest(&a, axis.normal) + lowest(&b, -axis.normal);
            assert!((gap - axis.separation).abs() < 1e-12, "case {case}: {axis:?} really {gap}");
        }
    }
}
