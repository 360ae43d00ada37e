//! `face`: the paper's face test. Triangle centroids of one body inside the other
//! (docs/physics.md §1.3, errata E2 and E3).

use crate::collision::contact::{Contact, Feature, Pair, PairState};
use crate::collision::hull::{
    Below, Flood, Hints, Kind, centre_walks, features_below, is_many_faced, outside_near_face,
};
use crate::collision::posed::{Posed, depth_along_from, is_inside};
use crate::math::{Scalar, Vector};
use crate::sim::context::StepContext;
use hecs::World;
use rayon::prelude::*;

/// Below this fraction of the colliding area, the summed area-normal has cancelled out (the
/// colliding triangles face every way) and the closest face of B gives the normal (§1.3).
const CANCELLED_NORMAL: Scalar = 1e-6;

/// Gives each candidate pair a face contact, testing both directions.
///
/// - Reads: `ctx.pairs` (`Candidate` only), `ctx.posed`.
/// - Writes: `ctx.pairs` (`Candidate` → `Found`), `ctx.posed` (fills the cache).
/// - Paper: face test; docs/physics.md §1.3, errata E2, E3; order of §1.6.
/// - Cost: O(F_A·F_B) per candidate pair.
pub fn face(_world: &mut World, ctx: &mut StepContext) {
    detect(ctx, face_contact_from, Feature::Face);
}

/// Runs `kernel` both ways on every candidate pair and records the first hit (docs/physics.md
/// §1.6): the (B, A) result has its normal flipped so it still points from B to A.
/// Both ways share the walks along the line of centres (`centre_walks`).
pub(crate) fn detect(ctx: &mut StepContext, kernel: Kernel, feature: Feature) {
    // Only this test reports `feature`, so its count is its hits once even when a schedule
    // runs it twice; hits of earlier tests keep their own feature.
    let found = |p: &Pair| matches!(p.state, PairState::Found(c) if c.feature == feature);
    // A resting scene's pairs all keep their points (`prune`): nothing to pose, walk or test.
    if !ctx.pairs.iter().any(Pair::is_candidate) {
        ctx.stats.found[feature as usize] = ctx.pairs.iter().filter(|p| found(p)).count() as u64;
        return;
    }
    // The candidates, and the hits so far: the one pass over all the pairs.
    let mut candidates = std::mem::take(&mut ctx.scratch.get_mut::<CentreWalks>().candidates);
    candidates.clear();
    let mut hits = 0;
    for (i, p) in ctx.pairs.iter().enumerate() {
        if p.is_candidate() {
            candidates.push(i as u32);
        } else {
            hits += u64::from(found(p));
        }
    }
    let ends = candidates.iter().flat_map(|&i| [ctx.pairs[i as usize].a, ctx.pairs[i as usize].b]);
    ctx.posed.pose(&ctx.bodies, ends);
    let mut walks = std::mem::take(ctx.scratch.get_mut::<CentreWalks>());
    walks.update(ctx, &candidates);
    let posed = &ctx.posed;
    // Each candidate with its entry in `walks`, if that is still its own (a custom system may
    // change the pairs between the tests): a serial pass, then the tests in parallel.
    let mut entries = walks.list.iter().zip(walks.floods.iter_mut()).peekable();
    let mut rows = Vec::with_capacity(candidates.len());
    let (mut rest, mut first) = (&mut ctx.pairs[..], 0);
    for &i in &candidates {
        let i = i as usize;
        let (pair, after) = std::mem::take(&mut rest)[i - first..].split_first_mut().expect("a candidate's index");
        (rest, first) = (after, i + 1);
        while entries.next_if(|(e, _)| (e.0 as usize) < i).is_some() {}
        let key = (pair.a, pair.b);
        let own = |(e, _): &(&Entry, &mut [Below; 2])| e.0 as usize == i && e.1 == key;
        rows.push((pair, entries.next_if(own)));
    }
    rows.par_iter_mut().for_each_init(Flood::default, |flood, (pair, entry)| {
        let (a, b) = (posed.get(pair.a), posed.get(pair.b));
        let [ha, hb] = entry.as_ref().map_or_else(|| centre_walks(a, b), |(e, _)| e.2);
        // Each way's flood is kept for the pair's next test (`Below`), or forgotten.
        let mut test = |(x, y): (&Posed, &Posed), hints: Hints, way: usize| {
            match entry {
                Some((_, floods)) => std::mem::swap(&mut flood.below, &mut floods[way]),
                None => flood.below.clear(),
            }
            let contact = kernel(x, y, hints, flood);
            if let Some((_, floods)) = entry {
                std::mem::swap(&mut flood.below, &mut floods[way]);
            }
            contact
        };
        let contact = test((a, b), [ha, hb], 0).or_else(|| test((b, a), [hb, ha], 1).map(Contact::flipped));
        if let Some(contact) = contact {
            pair.state = PairState::Found(contact);
        }
    });
    hits += rows.iter().filter(|(p, _)| found(p)).count() as u64;
    ctx.stats.found[feature as usize] = hits;
    drop(rows);
    walks.candidates = candidates;
    *ctx.scratch.get_mut::<CentreWalks>() = walks;
}

/// The step's candidate pairs as the first detection test found them, each with its
/// `centre_walks`, shared by the other tests (the bodies do not move between them), and its
/// floods both ways (`Below`), kept by the first test that floods and reused for the same
/// poses. Only the candidates: a resting pile's pairs mostly keep their points and skip the
/// tests, and walking or clearing all of them cost more than the tests. Each entry names its
/// pair (index and bodies); one that does not match is found afresh, so a schedule that changes
/// the pairs between the tests only loses the sharing.
#[derive(Default)]
struct CentreWalks {
    step: u64,
    /// The number of pairs when `list` was made.
    pairs: usize,
    /// Each candidate's index among the pairs, its bodies and its walks, in pair order.
    list: Vec<Entry>,
    /// Each entry's floods, both ways.
    floods: Vec<[Below; 2]>,
    /// Scratch: the indices of the pairs a test finds to be candidates.
    candidates: Vec<u32>,
}

/// A candidate's index among the pairs, its bodies and its walks.
type Entry = (u32, (u32, u32), Hints);

impl CentreWalks {
    /// The list for the candidates (`candidates`, their indices among the pairs), unless it
    /// was made this step for as many pairs.
    fn update(&mut self, ctx: &StepContext, candidates: &[u32]) {
        if self.step == ctx.step && self.pairs == ctx.pairs.len() {
            return;
        }
        let posed = &ctx.posed;
        (self.step, self.pairs) = (ctx.step, ctx.pairs.len());
        self.list.clear();
        let pairs = candidates.iter().map(|&i| (i, &ctx.pairs[i as usize]));
        self.list.extend(pairs.map(|(i, p)| (i, (p.a, p.b), [None; 2])));
        let walk = |e: &mut Entry| e.2 = centre_walks(posed.get(e.1.0), posed.get(e.1.1));
        self.list.par_iter_mut().for_each(walk);
        // The buffers stay, for the next step's floods.
        self.floods.resize_with(self.list.len(), Default::default);
        self.floods.iter_mut().flatten().for_each(Below::clear);
    }
}

/// Triangles of `a` whose centroid is inside convex `b`, as one contact: the mean of those
/// centroids, the normal `−normalize(Σ area·n)` of `a`'s colliding triangles (they face from
/// `a` into `b`; negated, from `b` to `a`: E3), and the projection overlap as depth (§2.6).
/// The mean of a square face's two centroids is its centre, so aligned boxes get no spin.
#[must_use]
pub fn face_contact(a: &Posed, b: &Posed) -> Option<Contact> {
    face_contact_from(a, b, [None; 2], &mut Flood::default())
}

/// A detection kernel: test (A, B) one way, its walks starting at the hints (`Hints`).
pub(crate) type Kernel = fn(&Posed, &Posed, Hints, &mut Flood) -> Option<Contact>;

/// `face_contact` with walks starting at `hints`.
fn face_contact_from(a: &Posed, b: &Posed, hints: Hints, flood: &mut Flood) -> Option<Contact> {
    let (mut sum_point, mut count) = (Vector::ZERO, 0_u32);
    let (mut sum_normal, mut sum_area) = (Vector::ZERO, 0.0);
    let reach = b.reach();
    let (many, mut hint) = (is_many_faced(b), 0);
    // No centroid higher than `level` along `d` is inside b.
    let (d, level) = match is_many_faced(a) {
        true => features_below(a, b, (Kind::Triangles, &hints), flood),
        false => (Vector::ZERO, Scalar::INFINITY),
    };
    // The flood's triangles, or all of them: two plain iterators, not a boxed one (an
    // allocation per call was a tenth of a resting pyramid's face test).
    let (flooded, all) = match is_many_faced(a) {
        true => (&flood.features[..], 0..0),
        false => (&[][..], 0..a.mesh.triangles.len()),
    };
    let triangles = flooded.iter().map(|&k| k as usize).chain(all);
    for (t, centroid) in triangles.map(|k| (&a.mesh.triangles[k], a.centroid(k))) {
        if centroid.dot(d) <= level
            && reach.contains(centroid)
            && !(many && outside_near_face(b, centroid, b.tolerance(), &mut hint))
            && is_inside(b, centroid)
        {
            let [p0, p1, p2] = t.map(|i| a.vertices[i as usize]);
            let area_normal = 0.5 * (p1 - p0).cross(p2 - p0);
            sum_point += centroid;
            count += 1;
            sum_normal += area_normal;
            sum_area += area_normal.length();
        }
    }
    if count == 0 {
        return None;
    }
    let point = sum_point / Scalar::from(count);
    let normal = if sum_normal.length() < CANCELLED_NORMAL * sum_area {
        b.closest_face_normal_from(point, a, hints)
    } else {
        -sum_normal.normalize()
    };
    let depth = depth_along_from(a, b, normal, &mut hints.clone());
    Some(Contact { point, normal, depth, feature: Feature::Face })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::components::Pose;
    use crate::model::mesh::ConvexMesh;
    use std::sync::Arc;

    fn cube(size: Vector, x: Vector) -> Posed {
        Posed::new(Arc::new(ConvexMesh::cuboid(size)), &Pose::from_position(x))
    }

    #[test]
    fn head_on_cubes_give_the_face_centre_and_a_normal_from_b_to_a() {
        // docs/physics.md §4 (a): A at x = −0.99 into B at 0: p = (−0.49, 0, 0), n = (−1, 0, 0).
        let a = cube(Vector::ONE, Vector::new(-0.99, 0.0, 0.0));
        let b = cube(Vector::ONE, Vector::ZERO);
        let c = face_contact(&a, &b).expect("A's +x face is inside B");
        assert!((c.point - Vector::new(-0.49, 0.0, 0.0)).length() < 1e-15);
        assert_eq!(c.normal, -Vector::X);
        assert!((c.depth - 0.01).abs() < 1e-15);
    }

    #[test]
    fn small_cube_on_the_rod_of_case_c() {
        // (c): the cube's bottom-face centroids lie inside the rod; n from the rod to the cube.
        let a = cube(Vector::splat(0.1), Vector::new(0.9, 0.14, 0.0));
        let rod = cube(Vector::new(2.0, 0.2, 0.2), Vector::ZERO);
        let c = face_contact(&a, &rod).expect("bottom face inside");
        assert!((c.point - Vector::new(0.9, 0.09, 0.0)).length() < 1e-15);
        assert_eq!(c.normal, Vector::Y);
        // The other way nothing of the rod is inside the small cube.
        assert!(face_contact(&rod, &a).is_none());
    }
}
