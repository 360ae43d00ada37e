//! Filling one constraint at a time, in plain `f64`s and glam vectors: the reference for the
//! four-lane `fill::fill_lanes`, which must give the same bits lane by lane (the test below
//! checks it on random inputs, axis-aligned normals, cubes and fixed ends among them).

use crate::math::{Mat3, Quat, Scalar, Vector};
use crate::rng::SplitMix64;
use crate::solver::constraints::tangents;
use crate::solver::fill::{LaneInputs, fill_lanes};
use crate::solver::{Batch, CachedManifold, Constraint, ContactPoint, Friction, LANES, PointRows};
use proptest::prelude::*;

/// Each pair of points' coupling and inverse determinants (`solver::ContactPoint::coupling`,
/// `inv_det`), for the points `rows` of one manifold with inverse masses `inv_mass`, and the soft
/// rows' `Softness::compliance`.
pub(in crate::solver) fn couple_pairs(rows: &mut [ContactPoint], inv_mass: [Scalar; 2], compliance: Scalar) {
    for j in (0..rows.len().saturating_sub(1)).step_by(2) {
        let (p, q) = (&rows[j], &rows[j + 1]);
        let coupling = inv_mass[0] + inv_mass[1] + p.g[0].dot(q.g[0]) + p.g[1].dot(q.g[1]);
        // The same arithmetic as the kernel's (a rigid row's compliance term is zero).
        let soft = |k: Scalar| k + compliance * k;
        let det = [p.k * q.k - coupling * coupling, soft(p.k) * soft(q.k) - coupling * coupling];
        rows[j].inv_det = det.map(|d| 1.0 / d);
        rows[j].coupling = coupling;
    }
}

/// 1/k, or 0 for k = 0 (a row between two fixed bodies, or an idle one).
fn inverse(k: Scalar) -> Scalar {
    if k > 0.0 { 1.0 / k } else { 0.0 }
}

/// The friction rows of a pair at its patch `centre` (see `solver::Friction`), warm-started
/// from last step's patch impulses.
pub(in crate::solver) fn friction_patch(
    centre: Vector,
    position: [Vector; 2],
    n: Vector,
    tangents: [Vector; 2],
    inv_mass: [Scalar; 2],
    scale: [Mat3; 2],
    cached: Option<&CachedManifold>,
) -> Friction {
    let r = [centre - position[0], centre - position[1]];
    let g = tangents.map(|t| [scale[0] * r[0].cross(t), scale[1] * r[1].cross(t)]);
    // K = J M⁻¹ Jᵀ over the two tangent rows (their linear parts are orthogonal).
    let linear = inv_mass[0] + inv_mass[1];
    let k11 = linear + g[0][0].length_squared() + g[0][1].length_squared();
    let k22 = linear + g[1][0].length_squared() + g[1][1].length_squared();
    let k12 = g[0][0].dot(g[1][0]) + g[0][1].dot(g[1][1]);
    let det = k11 * k22 - k12 * k12;
    let mass = if det > 0.0 { [k22 / det, -k12 / det, k11 / det] } else { [inverse(k11), 0.0, inverse(k22)] };
    let twist = [scale[0] * n, scale[1] * n];
    let (jt, jw) = cached.map_or((Vector::ZERO, Vector::ZERO), |c| (c.tangent, c.twist));
    Friction {
        g,
        twist,
        mass,
        twist_mass: inverse(twist[0].length_squared() + twist[1].length_squared()),
        impulse: [jt.dot(tangents[0]), jt.dot(tangents[1]), jw.dot(n)],
    }
}

/// Lane `l` of `input` filled alone, as `constraints::fill` filled each constraint before it
/// worked four at a time: the constraint and its manifold's points.
fn fill_one(input: &LaneInputs, l: usize, compliance: Scalar) -> (Constraint, Vec<ContactPoint>) {
    let n = input.normal.get(l);
    let tangents = tangents(n);
    let position = input.position.map(|p| p.get(l));
    let scale = input.scale.map(|s| Mat3::from_cols(s[0].get(l), s[1].get(l), s[2].get(l)));
    let inv_mass = input.inv_mass.map(|m| m[l]);
    let len = input.len[l] as usize;
    let points: Vec<Vector> = (0..len).map(|j| input.points[j].get(l)).collect();
    let centre = points.iter().sum::<Vector>() / len as Scalar;
    let (before_a, before_b) = (input.before[0].get(l), input.before[1].get(l));
    let spin = input.spin.map(|w| w.get(l));
    let mut rows: Vec<ContactPoint> = points
        .iter()
        .enumerate()
        .map(|(j, &p)| {
            let r = [p - position[0], p - position[1]];
            let g = [scale[0] * r[0].cross(n), scale[1] * r[1].cross(n)];
            let approach = || (before_a + spin[0].cross(r[0]) - before_b - spin[1].cross(r[1])).dot(n);
            let k = inv_mass[0] + inv_mass[1] + g[0].length_squared() + g[1].length_squared();
            ContactPoint {
                g,
                mass: inverse(k),
                k,
                impulse: input.impulse[j][l],
                gap: input.gap[j][l],
                approach: if input.kept[j][l] > 0.0 { 0.0 } else { approach() },
                max_impulse: 0.0,
                lever: (p - centre).length(),
                coupling: 0.0,
                inv_det: [0.0; 2],
            }
        })
        .collect();
    couple_pairs(&mut rows, inv_mass, compliance);
    let mu = input.mu[l];
    let cached = CachedManifold {
        tangent: input.tangent_impulse.get(l),
        twist: input.twist_impulse.get(l),
        ..CachedManifold::default()
    };
    let constraint = Constraint {
        slot: [input.slot[0][l], input.slot[1][l]],
        normal: n,
        tangents,
        inv_mass,
        mu,
        restitution: input.restitution[l],
        slop: input.slop[l],
        max_push: input.max_push[l],
        friction: if mu > 0.0 {
            friction_patch(centre, position, n, tangents, inv_mass, scale, Some(&cached))
        } else {
            Friction::IDLE
        },
    };
    (constraint, rows)
}

/// One lane's random inputs: axis-aligned normals, cubes (S a multiple of the identity), fixed
/// ends (S and m⁻¹ zero), no friction and no cached impulses each now and then.
fn random_lane(rng: &mut SplitMix64, input: &mut LaneInputs, l: usize) {
    let vector =
        |rng: &mut SplitMix64, r: Scalar| Vector::new(rng.uniform(-r, r), rng.uniform(-r, r), rng.uniform(-r, r));
    let axes = [Vector::X, Vector::Y, Vector::Z, -Vector::X, -Vector::Y, -Vector::Z];
    let n = if rng.unit() < 0.3 {
        axes[(rng.next_u64() % 6) as usize]
    } else {
        vector(rng, 1.0).try_normalize().unwrap_or(Vector::Y)
    };
    input.normal.set(l, n);
    input.slot[0][l] = (rng.next_u64() % 8) as u32;
    input.slot[1][l] = (rng.next_u64() % 8) as u32;
    let centre = vector(rng, 3.0);
    for end in 0..2 {
        input.position[end].set(l, centre + vector(rng, 1.0));
        input.before[end].set(l, vector(rng, 2.0));
        input.spin[end].set(l, vector(rng, 2.0));
        let kind = rng.next_u64() % 4;
        let (scale, inv_mass) = match kind {
            0 => (Mat3::ZERO, 0.0),
            1 => (Mat3::from_diagonal(Vector::splat(1.0 / rng.uniform(0.1, 3.0).sqrt())), rng.uniform(0.2, 5.0)),
            _ => {
                let turn = Quat::from_axis_angle(
                    vector(rng, 1.0).try_normalize().unwrap_or(Vector::X),
                    rng.uniform(-3.0, 3.0),
                );
                let r = Mat3::from_quat(turn);
                let moments = Vector::new(rng.uniform(0.1, 3.0), rng.uniform(0.1, 3.0), rng.uniform(0.1, 3.0));
                (r * Mat3::from_diagonal(moments.map(|m| 1.0 / m.sqrt())) * r.transpose(), rng.uniform(0.2, 5.0))
            }
        };
        for c in 0..3 {
            input.scale[end][c].set(l, scale.col(c));
        }
        input.inv_mass[end][l] = inv_mass;
    }
    input.mu[l] = if rng.unit() < 0.2 { 0.0 } else { rng.uniform(0.05, 1.2) };
    input.restitution[l] = rng.uniform(0.0, 0.9);
    input.slop[l] = rng.uniform(0.0, 0.01);
    input.max_push[l] = rng.uniform(0.05, 3.0);
    let len = 1 + (rng.next_u64() % 4) as usize;
    input.len[l] = len as Scalar;
    for j in 0..4 {
        let at = if j < len { j } else { 0 };
        if j == at {
            input.points[j].set(l, centre + vector(rng, 0.5));
            input.gap[j][l] = rng.uniform(-0.06, 0.03);
            let kept = rng.unit() < 0.5;
            input.kept[j][l] = if kept { 1.0 } else { 0.0 };
            input.impulse[j][l] = if kept && rng.unit() < 0.8 { rng.uniform(0.0, 3.0) } else { 0.0 };
        } else {
            // As `constraints::fill` gathers them: the first point again, with an impulse.
            let first = input.points[0].get(l);
            input.points[j].set(l, first);
            input.gap[j][l] = input.gap[0][l];
            (input.kept[j][l], input.impulse[j][l]) = (1.0, 0.0);
        }
    }
    let cached = rng.unit() < 0.7;
    let impulse = |rng: &mut SplitMix64| if cached { vector(rng, 1.0) } else { Vector::ZERO };
    let (jt, jw) = (impulse(rng), impulse(rng));
    input.tangent_impulse.set(l, jt);
    input.twist_impulse.set(l, jw);
}

/// Copies lane `from` of every input into lane `to` (an idle lane repeats a used one).
fn repeat_lane(input: &mut LaneInputs, from: usize, to: usize) {
    let copy = |v: &mut crate::solver::LaneVectors| {
        let x = v.get(from);
        v.set(to, x);
    };
    copy(&mut input.normal);
    copy(&mut input.tangent_impulse);
    copy(&mut input.twist_impulse);
    for end in 0..2 {
        input.slot[end][to] = input.slot[end][from];
        copy(&mut input.position[end]);
        copy(&mut input.before[end]);
        copy(&mut input.spin[end]);
        for c in 0..3 {
            copy(&mut input.scale[end][c]);
        }
        input.inv_mass[end][to] = input.inv_mass[end][from];
    }
    for lanes in [&mut input.mu, &mut input.restitution, &mut input.slop, &mut input.max_push, &mut input.len] {
        lanes[to] = lanes[from];
    }
    for j in 0..4 {
        copy(&mut input.points[j]);
        for lanes in [&mut input.gap[j], &mut input.impulse[j], &mut input.kept[j]] {
            lanes[to] = lanes[from];
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// `fill_lanes` writes, lane for lane and bit for bit (zeros' signs included), what the
    /// one-constraint fill writes, and the idle values everywhere else.
    #[test]
    fn four_lanes_fill_as_one_at_a_time(seed in any::<u64>(), count in 1..=LANES) {
        let mut rng = SplitMix64::new(seed);
        let mut input = LaneInputs::default();
        for l in 0..count {
            random_lane(&mut rng, &mut input, l);
        }
        for l in count..LANES {
            repeat_lane(&mut input, 0, l);
        }
        let (static_slot, compliance) = (9, rng.uniform(0.0, 2.0));
        let points = (0..count).map(|l| input.len[l] as u32).max().unwrap_or(0);
        let mut expected = Batch::idle(static_slot);
        expected.len = points;
        let mut expected_rows = vec![PointRows::default(); points as usize];
        for l in 0..count {
            let (constraint, rows) = fill_one(&input, l, compliance);
            expected.set(l, &constraint);
            for (j, row) in rows.iter().enumerate() {
                expected_rows[j].set(l, row);
            }
        }
        let mut batch = Batch { len: points, ..Batch::default() };
        let mut rows = vec![PointRows::default(); points as usize];
        fill_lanes(&input, count, static_slot, compliance, &mut batch, &mut rows);
        prop_assert_eq!(format!("{batch:?}"), format!("{expected:?}"));
        prop_assert_eq!(format!("{rows:?}"), format!("{expected_rows:?}"));
    }
}
