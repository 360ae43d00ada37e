//! Wavefront OBJ reader: `tobj` parses the file, this module turns it into a validated mesh; with
//! `hull: true`, the convex hull of the file's `v` points instead.

use crate::math::{Scalar, Vector};
use crate::model::shapes::RawMesh;
use std::path::Path;

/// Most vertices accepted from one OBJ: the narrow phase is O(F_A·F_B) per pair (docs/physics.md
/// §1.7), so bigger models would stall every step; the bound also caps memory on bad input.
pub const MAX_OBJ_VERTICES: usize = 100_000;

/// Loads every object of an OBJ file as one triangle soup (all its models merged, faces
/// triangulated), scaled by `scale`. Errors are worded for the user and name no path (the
/// caller adds it).
pub fn load_obj(path: &Path, scale: Scalar) -> Result<RawMesh, String> {
    let options = tobj::LoadOptions { triangulate: true, single_index: false, ..Default::default() };
    let (models, _materials) = tobj::load_obj(path, &options).map_err(|e| match e {
        tobj::LoadError::OpenFileFailed => "cannot open the file".to_string(),
        tobj::LoadError::ReadError => "cannot read the file".to_string(),
        other => format!("not a valid OBJ file: {other}"),
    })?;
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = u32::try_from(vertices.len()).map_err(|_| "too many vertices".to_string())?;
        vertices.extend(m.positions.chunks_exact(3).map(|p| Vector::new(p[0], p[1], p[2]) * scale));
        if vertices.len() > MAX_OBJ_VERTICES {
            return Err(format!("more than {MAX_OBJ_VERTICES} vertices"));
        }
        triangles.extend(m.indices.chunks_exact(3).map(|t| [base + t[0], base + t[1], base + t[2]]));
    }
    if triangles.is_empty() {
        return Err(
            "no faces: an OBJ body needs `f` lines, or `hull: true` for the convex hull of its `v` points".to_string()
        );
    }
    if triangles.iter().flatten().any(|&i| i as usize >= vertices.len()) {
        return Err("a face refers to a vertex that does not exist".to_string());
    }
    Ok(drop_unused(&vertices, &triangles))
}

/// The convex hull of every `v` point of an OBJ file, scaled by `scale` (`hull: true`):
/// faces, if any, are ignored, so a bare point cloud, a model with concave parts, repeated or
/// inner vertices all become the convex body of their points (`model::quickhull`). Errors are
/// worded for the user and name no path (the caller adds it).
pub fn load_obj_hull(path: &Path, scale: Scalar) -> Result<RawMesh, String> {
    let points = load_points(path, scale)?;
    crate::model::quickhull::convex_hull(&points).map_err(|e| e.to_string())
}

/// The `v` lines of an OBJ file, in order, scaled: their first three numbers (a fourth, or
/// colours after them, are ignored, as `tobj` does); every other line is ignored.
fn load_points(path: &Path, scale: Scalar) -> Result<Vec<Vector>, String> {
    let bytes = std::fs::read(path).map_err(|_| "cannot open the file".to_string())?;
    let text = String::from_utf8(bytes).map_err(|_| "cannot read the file: it is not UTF-8 text".to_string())?;
    let mut points = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() != Some("v") {
            continue;
        }
        let mut xyz = [0.0; 3];
        for x in &mut xyz {
            *x = words
                .next()
                .and_then(|w| w.parse::<Scalar>().ok())
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("line {}: a `v` line needs three finite numbers", n + 1))?;
        }
        points.push(Vector::from_array(xyz) * scale);
        if points.len() > MAX_OBJ_VERTICES {
            return Err(format!("more than {MAX_OBJ_VERTICES} vertices"));
        }
    }
    if points.is_empty() {
        return Err("no vertices: `hull: true` needs `v` lines".to_string());
    }
    Ok(points)
}

/// Keeps only the vertices some face uses, in their order: a stray `v` line would otherwise
/// widen the bounding sphere and take part in the vertex test.
fn drop_unused(vertices: &[Vector], triangles: &[[u32; 3]]) -> RawMesh {
    let mut used = vec![false; vertices.len()];
    for &i in triangles.iter().flatten() {
        used[i as usize] = true;
    }
    let mut new_index = vec![0u32; vertices.len()];
    let mut kept = Vec::new();
    for (i, &v) in vertices.iter().enumerate() {
        if used[i] {
            new_index[i] = kept.len() as u32;
            kept.push(v);
        }
    }
    (kept, triangles.iter().map(|t| t.map(|i| new_index[i as usize])).collect())
}
