//! Time of impact of two convex bodies in free flight, by conservative advancement (Mirtich;
//! Box2D's `b2TimeOfImpact`), and the contact where they meet (docs/physics.md §6.7).
//!
//! Any separating axis bounds the bodies' distance from below, and no point of a body moves
//! along an axis faster than its centre's speed plus its spin times its bounding radius. So a
//! pair `s` apart along their best axis, closing at most `μ`, cannot touch for `s/μ`: advancing
//! by that, again and again, reaches the first time they come within the wanted gap and never
//! passes it, whatever the shapes, spins and speeds.

use crate::collision::boxes::{BoxAt, box_contact_axis};
use crate::collision::contact::{Contact, Feature};
use crate::collision::gjk::{Shape, separation};
use crate::collision::hull::Placed;
use crate::collision::manifold::{Axis, ClipScratch, Reference, contact_axis, manifold, support_point};
use crate::collision::posed::Posed;
use crate::math::{Mat3, Scalar, Vector};
use crate::model::components::Pose;
use crate::model::mesh::ConvexMesh;
use std::sync::Arc;

/// Most advances per pair and query. Each closes a fixed share of the gap when spin dominates
/// the bound; a query that runs out reports the (safe) time it reached as the impact.
pub const MAX_ADVANCES: usize = 64;

/// A pair closer than this share of the wanted gap at the start is touching: its contact is
/// the discrete tests' (docs/physics.md §1), not a new impact.
const TOUCHING: Scalar = 0.01;

/// An advance stops within this share of the wanted gap above it.
const TOLERANCE: Scalar = 0.5;

/// Corners within this share of the gap of the nearest one belong to the contact patch.
const PATCH: Scalar = 0.1;

/// How fast two bodies in free flight can approach each other.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Approach {
    /// `v_A − v_B` [m/s].
    pub relative_velocity: Vector,
    /// `|ω_A| ρ_A + |ω_B| ρ_B` [m/s]: the fastest any point turns about its centre.
    pub spin: Scalar,
}

impl Approach {
    /// The fastest the gap along `n` (from B to A) can close [m/s].
    #[must_use]
    pub fn closing_speed(&self, n: Vector) -> Scalar {
        (-self.relative_velocity.dot(n)).max(0.0) + self.spin
    }
}

/// The first time in `(start, end]` at which `a` and `b` come within `gap` [m] of each other,
/// or `None` if they stay farther apart until `end`, or already touch at `start`. `place(t)`
/// gives both poses at time t; `a` and `b` are posed there as the search goes.
///
/// After an impact the pair is within the gap: the next query of the same pair then looks for
/// half its separation, so a second impact within the step is still found.
pub fn time_of_impact(
    (a, b): (&mut Posed, &mut Posed),
    place: impl Fn(Scalar) -> (Pose, Pose),
    approach: &Approach,
    window: (Scalar, Scalar),
    gap: Scalar,
) -> Option<Scalar> {
    let axis_at = |t: Scalar| {
        let (pa, pb) = place(t);
        a.update(&pa);
        b.update(&pb);
        contact_axis(a, b, (0.0, Scalar::INFINITY))
    };
    advance(axis_at, approach, window, gap)
}

/// `time_of_impact` of two meshes given their poses (`place`), posing only what the pair
/// needs: two boxes' best axis from the poses alone (`boxes::box_contact_axis`); a pair with a
/// many-faced body advances on GJK's separating axis (`gjk::separation`), walking the meshes'
/// body-frame vertices from the last advance's; any other pair is posed and searched.
pub fn meshes_time_of_impact(
    (a, b): (&Arc<ConvexMesh>, &Arc<ConvexMesh>),
    place: impl Fn(Scalar) -> (Pose, Pose),
    approach: &Approach,
    window: (Scalar, Scalar),
    gap: Scalar,
) -> Option<Scalar> {
    if a.box_layout.is_some() && b.box_layout.is_some() {
        let axis_at = |t: Scalar| {
            let (pa, pb) = place(t);
            box_contact_axis(&BoxAt::new(a, &pa)?, &BoxAt::new(b, &pb)?, (0.0, Scalar::INFINITY))
        };
        return advance(axis_at, approach, window, gap);
    }
    if a.is_many_faced() || b.is_many_faced() {
        let mut ends = [0, 0];
        let placed =
            |mesh, pose: &Pose| Placed { mesh, position: pose.position, rotation: Mat3::from_quat(pose.orientation) };
        let axis_at = |t: Scalar| {
            let (pa, pb) = place(t);
            let (a, b) = (Shape::Placed(placed(a, &pa)), Shape::Placed(placed(b, &pb)));
            // Within the touching share of the gap, GJK's bound is as good as the distance.
            let (separation, normal) = separation(a, b, TOUCHING * gap, &mut ends);
            Some(Axis { normal, separation, reference: Reference::Edges })
        };
        return advance(axis_at, approach, window, gap);
    }
    let (pa, pb) = place(window.0);
    let (mut a, mut b) = (Posed::new(a.clone(), &pa), Posed::new(b.clone(), &pb));
    time_of_impact((&mut a, &mut b), place, approach, window, gap)
}

/// Conservative advancement with `axis_at(t)`, the pair's best axis at time t.
fn advance(
    mut axis_at: impl FnMut(Scalar) -> Option<Axis>,
    approach: &Approach,
    (start, end): (Scalar, Scalar),
    gap: Scalar,
) -> Option<Scalar> {
    let (mut t, mut target) = (start, gap);
    for k in 0..MAX_ADVANCES {
        let Axis { separation, normal, .. } = axis_at(t)?;
        if k == 0 {
            if separation <= TOUCHING * gap {
                return None;
            }
            target = target.min(0.5 * separation);
        }
        if separation <= target * (1.0 + TOLERANCE) {
            return Some(t);
        }
        let closing = approach.closing_speed(normal);
        if closing <= 0.0 {
            return None;
        }
        t += (separation - target) / closing;
        if !t.is_finite() || t > end {
            return None;
        }
    }
    Some(t)
}

/// The contact of two bodies posed at their time of impact: the best axis's normal (from B to
/// A) at the centre of the patch where they are nearest (a face on a face meets at the
/// middle of their overlap, so a square hit gives no spin), found by clipping as resting
/// contact does; an edge across an edge meets where the two edges pass closest.
pub fn impact_contact(a: &Posed, b: &Posed, scratch: &mut ClipScratch) -> Option<Contact> {
    let axis = contact_axis(a, b, (0.0, Scalar::INFINITY))?;
    let reach = axis.separation + PATCH * axis.separation.abs();
    let m = manifold(a, b, &axis, reach, scratch);
    let (point, feature) = match m.len {
        0 => (support_point(a, b, &axis), Feature::Edge),
        n => (m.points().iter().sum::<Vector>() / n as Scalar, if n >= 3 { Feature::Face } else { Feature::Vertex }),
    };
    Some(Contact { point, normal: axis.normal, depth: 0.0, feature })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Quat;
    use std::sync::Arc;

    fn cube(x: Scalar) -> Posed {
        Posed::new(Arc::new(ConvexMesh::cuboid(Vector::ONE)), &Pose::from_position(Vector::new(x, 0.0, 0.0)))
    }

    #[test]
    fn a_cube_closing_head_on_stops_the_gap_short_in_one_advance() {
        // Unit cubes 3 m apart (2 m between faces), A at 10 m/s towards B: the gap g is left at
        // t = (2 − g)/10.
        let (mut a, mut b) = (cube(-3.0), cube(0.0));
        let place = |t: Scalar| (Pose::from_position(Vector::new(-3.0 + 10.0 * t, 0.0, 0.0)), Pose::IDENTITY);
        let approach = Approach { relative_velocity: Vector::new(10.0, 0.0, 0.0), spin: 0.0 };
        let t = time_of_impact((&mut a, &mut b), place, &approach, (0.0, 1.0), 0.005).expect("they meet");
        assert!((t - (2.0 - 0.005) / 10.0).abs() < 1e-12, "{t}");
        // From the poses alone, the same time.
        let cube = Arc::new(ConvexMesh::cuboid(Vector::ONE));
        assert_eq!(meshes_time_of_impact((&cube, &cube), place, &approach, (0.0, 1.0), 0.005), Some(t));
        // Too slow to meet within the step, or moving apart: none.
        assert_eq!(time_of_impact((&mut a, &mut b), place, &approach, (0.0, 0.1), 0.005), None);
        let away = Approach { relative_velocity: Vector::new(-10.0, 0.0, 0.0), spin: 0.0 };
        assert_eq!(time_of_impact((&mut a, &mut b), place, &away, (0.0, 1.0), 0.005), None);
    }

    #[test]
    fn a_spinning_ball_is_stopped_at_the_gap_from_its_pose_alone() {
        // A 1 280-face icosphere spinning at 20 rad/s closes at 10 m/s on a cube, off centre and
        // turned: GJK's advance stops where the posed search does, within its tolerance, and
        // never past the gap.
        let (v, t) = crate::model::shapes::icosphere_raw(0.5, 3);
        let ball = Arc::new(ConvexMesh::new(v, t).expect("an icosphere").0);
        let cube = Arc::new(ConvexMesh::cuboid(Vector::ONE));
        let tilt = Quat::from_rotation_z(0.3) * Quat::from_rotation_y(0.4);
        let at = |t: Scalar| Pose {
            position: Vector::new(-3.0 + 10.0 * t, 0.2, 0.1),
            orientation: Quat::from_rotation_x(20.0 * t) * Quat::from_rotation_y(0.7),
        };
        let place = |t: Scalar| (at(t), Pose { position: Vector::ZERO, orientation: tilt });
        let approach = Approach { relative_velocity: Vector::new(10.0, 0.0, 0.0), spin: 20.0 * ball.radius };
        let gap = 0.005;
        let (mut a, mut b) = (Posed::new(ball.clone(), &at(0.0)), Posed::new(cube.clone(), &place(0.0).1));
        let posed = time_of_impact((&mut a, &mut b), place, &approach, (0.0, 1.0), gap).expect("they meet");
        let placed = meshes_time_of_impact((&ball, &cube), place, &approach, (0.0, 1.0), gap).expect("they meet");
        let (pa, pb) = place(placed);
        a.update(&pa);
        b.update(&pb);
        let left = contact_axis(&a, &b, (0.0, Scalar::INFINITY)).expect("an axis").separation;
        assert!(left > 0.0 && left <= gap * (1.0 + TOLERANCE) + TOUCHING * gap, "stopped {left} short");
        assert!((placed - posed).abs() * 10.0 < gap, "placed {placed} s, posed {posed} s");
    }

    #[test]
    fn a_turning_bar_is_stopped_before_it_reaches_the_cube() {
        // A 2 × 0.1 × 0.1 bar about the origin turns at 30 rad/s about y towards a unit cube
        // whose near face is 0.6 m off its axis: the search never passes the contact.
        let bar = Arc::new(ConvexMesh::cuboid(Vector::new(2.0, 0.1, 0.1)));
        let turn = |t: Scalar| Pose { position: Vector::ZERO, orientation: Quat::from_rotation_y(-30.0 * t) };
        let (mut a, mut b) = (Posed::new(bar.clone(), &turn(0.0)), cube(0.0));
        b.update(&Pose::from_position(Vector::new(0.0, 0.0, 1.1)));
        let place = |t: Scalar| (turn(t), Pose::from_position(Vector::new(0.0, 0.0, 1.1)));
        let approach = Approach { relative_velocity: Vector::ZERO, spin: 30.0 * bar.radius };
        let t = time_of_impact((&mut a, &mut b), place, &approach, (0.0, 0.1), 0.005).expect("it hits");
        let (pa, pb) = place(t);
        a.update(&pa);
        b.update(&pb);
        let gap = contact_axis(&a, &b, (0.0, Scalar::INFINITY)).expect("an axis").separation;
        assert!(gap > 0.0 && gap <= 0.0075, "stopped {gap} short at t = {t}");
    }
}
