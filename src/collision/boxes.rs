//! The least-overlap axis of two boxes from their poses (`box_contact_axis`): the same 15
//! axes as `manifold::contact_axis_all` (6 + 6 face normals, 9 edge cross products), each
//! box's extent along an axis from its half extents (Gottschalk 1996; Ericson, RTCD §4.4.1)
//! instead of a scan of its 8 vertices. A pile of falling cubes finds most of its pairs'
//! axes afresh every step, so this is most of what those pairs cost before clipping.

use crate::collision::manifold::{Axis, PREFER, Reference};
use crate::collision::posed::Posed;
use crate::math::{Mat3, Scalar, Vector};
use crate::model::components::Pose;
use crate::model::mesh::{BoxLayout, ConvexMesh};

/// Edge pairs whose cross product is shorter than this squared are parallel: their plane's
/// normal is a face axis already (as in `contact_axis_all`).
const PARALLEL: Scalar = 1e-12;

/// A box body at a pose, as `box_contact_axis` reads it: no vertices posed.
#[derive(Clone, Copy, Debug)]
pub struct BoxAt<'a> {
    /// Centre [m].
    pub position: Vector,
    /// Body → world rotation.
    pub rotation: Mat3,
    /// Half extents along the body axes [m].
    pub half: Vector,
    /// The order of the box mesh's faces and edge directions.
    pub layout: &'a BoxLayout,
}

impl<'a> BoxAt<'a> {
    /// `mesh` at `pose`, if it is a box aligned with its body axes.
    #[must_use]
    pub fn new(mesh: &'a ConvexMesh, pose: &Pose) -> Option<Self> {
        let (half, layout) = (mesh.box_half_extents?, mesh.box_layout.as_ref()?);
        Some(Self { position: pose.position, rotation: Mat3::from_quat(pose.orientation), half, layout })
    }

    /// A posed body, if it is such a box.
    #[must_use]
    pub fn posed(p: &'a Posed) -> Option<Self> {
        let (half, layout) = (p.mesh.box_half_extents?, p.mesh.box_layout.as_ref()?);
        Some(Self { position: p.position, rotation: p.rotation, half, layout })
    }
}

/// `contact_axis_all` of two boxes aligned with their body axes: the faces of B, then of A,
/// then the edge pairs, in the scan's order and with its preferences, each separation worked
/// out from the centres, the rotations and the half extents. The same axis up to round-off (the
/// unit test compares them on random poses).
#[must_use]
pub fn box_contact_axis(a: &BoxAt, b: &BoxAt, (margin, reach): (Scalar, Scalar)) -> Option<Axis> {
    let (ra, rb, ha, hb) = (a.rotation, b.rotation, a.half.to_array(), b.half.to_array());
    let (axes_a, axes_b) = ([ra.x_axis, ra.y_axis, ra.z_axis], [rb.x_axis, rb.y_axis, rb.z_axis]);
    // |a_i · b_j|: how far each box reaches along the other's axes.
    let cos = axes_a.map(|ai| axes_b.map(|bj| ai.dot(bj).abs()));
    let d = a.position - b.position;
    let (along_a, along_b) = (axes_a.map(|ai| d.dot(ai)), axes_b.map(|bj| d.dot(bj)));
    let reach_a: [Scalar; 3] = std::array::from_fn(|j| ha[0] * cos[0][j] + ha[1] * cos[1][j] + ha[2] * cos[2][j]);
    let reach_b: [Scalar; 3] = std::array::from_fn(|i| hb[0] * cos[i][0] + hb[1] * cos[i][1] + hb[2] * cos[i][2]);
    // The best so far, and how to build its normal: the scan's `consider` (the first axis
    // tried always stands; a later one must beat it by `prefer`).
    let mut best = (Scalar::NAN, Found::None);
    let mut consider = |separation: Scalar, found: Found, prefer: Scalar| {
        if matches!(best.1, Found::None) || separation > best.0 + prefer {
            best = (separation, found);
        }
    };
    // A face's separation is `d · n` less both reaches; d · (±b_j) is ±(d · b_j) exactly.
    for (f, &(j, sign)) in b.layout.faces.iter().enumerate() {
        consider(sign * along_b[j] - reach_a[j] - hb[j], Found::FaceOfB(f as u32, j, sign), 0.0);
    }
    for (f, &(i, sign)) in a.layout.faces.iter().enumerate() {
        consider(-(sign * along_a[i]) - reach_b[i] - ha[i], Found::FaceOfA(f as u32, i, sign), PREFER * margin);
    }
    // In the order of the meshes' edge directions: with the preference, the order can decide.
    let cross = |i: usize, j: usize| axes_a[i].cross(axes_b[j]);
    for &i in &a.layout.edges {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for &j in &b.layout.edges {
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let c = cross(i, j);
            let length2 = c.length_squared();
            if length2 < PARALLEL {
                continue;
            }
            // Along a_i × b_j, A reaches over its other two axes and B over its.
            let reach_a = ha[i1] * cos[i2][j] + ha[i2] * cos[i1][j];
            let reach_b = hb[j1] * cos[i][j2] + hb[j2] * cos[i][j1];
            let length = length2.sqrt();
            let along = d.dot(c);
            consider(
                (along.abs() - reach_a - reach_b) / length,
                Found::Edges(i, j, along < 0.0, length),
                PREFER * margin,
            );
        }
    }
    let (separation, found) = best;
    let (normal, reference) = match found {
        Found::FaceOfB(f, j, sign) => (axes_b[j] * sign, Reference::FaceOfB(f)),
        Found::FaceOfA(f, i, sign) => (axes_a[i] * -sign, Reference::FaceOfA(f)),
        Found::Edges(i, j, flip, length) => {
            let c = if flip { -cross(i, j) } else { cross(i, j) };
            (c / length, Reference::Edges)
        }
        Found::None => return None,
    };
    (separation <= reach).then_some(Axis { normal, separation, reference })
}

/// The axis `box_contact_axis` chose, by what it needs to build the axis's normal.
#[derive(Clone, Copy)]
enum Found {
    None,
    /// Plane f of B, along B's axis j, on side ±1.
    FaceOfB(u32, usize, Scalar),
    /// Plane f of A, along A's axis i, on side ±1.
    FaceOfA(u32, usize, Scalar),
    /// a_i × b_j, flipped to point from B to A, and its length.
    Edges(usize, usize, bool, Scalar),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::manifold::contact_axis_scan;
    use crate::math::Quat;
    use crate::rng::SplitMix64;
    use std::sync::Arc;

    fn box_of(p: &Posed) -> BoxAt<'_> {
        BoxAt::posed(p).expect("a box")
    }

    fn turn(rng: &mut SplitMix64) -> Quat {
        let v = Vector::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        Quat::from_axis_angle(v.normalize_or(Vector::X), rng.uniform(-3.2, 3.2))
    }

    /// Random pairs of boxes of different sizes, apart, touching and deep, some turned exactly
    /// onto each other's axes (parallel faces and edges): the pose form gives the scan's axis,
    /// separation and normal to round-off, and the same face or edge pair unless two axes tie.
    #[test]
    fn the_pose_form_finds_the_scans_axis() {
        let mut rng = SplitMix64::new(5);
        let sizes = [Vector::ONE, Vector::new(0.3, 1.0, 2.0), Vector::new(4.0, 0.1, 4.0), Vector::splat(0.05)];
        let (mut found, mut edges, mut apart, mut ties) = (0, 0, 0, 0);
        for k in 0..4000 {
            let (sa, sb) = (sizes[k % 4], sizes[(k / 4) % 4]);
            let (ma, mb) = (Arc::new(ConvexMesh::cuboid(sa)), Arc::new(ConvexMesh::cuboid(sb)));
            let qa = if k % 5 == 0 { Quat::IDENTITY } else { turn(&mut rng) };
            let qb = if k % 7 == 0 { qa } else { turn(&mut rng) };
            let spread = 0.6 * (sa.length() + sb.length()) * rng.uniform(0.0, 1.0);
            let offset = turn(&mut rng) * Vector::X * spread;
            let a = Posed::new(ma.clone(), &Pose { position: Vector::new(1.0, 2.0, 3.0), orientation: qa });
            let b = Posed::new(mb.clone(), &Pose { position: Vector::new(1.0, 2.0, 3.0) + offset, orientation: qb });
            let (margin, reach) = (0.02 * sa.min_element().min(sb.min_element()), rng.uniform(0.0, 0.5));
            let (fast, scan) = (
                box_contact_axis(&box_of(&a), &box_of(&b), (margin, reach)),
                contact_axis_scan(&a, &b, (margin, reach)),
            );
            let scale = 1e-12 * (1.0 + spread + sa.length() + sb.length());
            match (fast, scan) {
                (Some(f), Some(s)) => {
                    found += 1;
                    edges += usize::from(s.is_edge());
                    assert!((f.separation - s.separation).abs() < scale, "case {k}: {f:?} against {s:?}");
                    // Only a tie (parallel faces) may choose the other axis, at the same separation.
                    if f.reference == s.reference {
                        assert!((f.normal - s.normal).length() < 1e-9, "case {k}: {f:?} against {s:?}");
                    } else {
                        ties += 1;
                    }
                }
                (None, None) => apart += 1,
                // At the reach itself, round-off may fall either way.
                (f, s) => {
                    let sep = f.or(s).expect("one of them").separation;
                    assert!((sep - reach).abs() < scale, "case {k}: {f:?} against {s:?} at reach {reach}");
                }
            }
        }
        assert!(found > 1000 && edges > 50 && apart > 500, "{found} found ({edges} on edges), {apart} apart");
        assert!(ties * 100 < found, "{ties} of {found} chose another axis");
    }
}
