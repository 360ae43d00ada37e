//! A batch's constraints and points worked out four lanes at a time (`fill_lanes`), from
//! inputs gathered lane by lane (`LaneInputs`). Per lane the arithmetic is that of filling one
//! constraint alone (`constraints::tangents`, `couple_pairs`, `friction_patch` and glam's
//! vector and matrix products), operation for operation in the same order, so the lanes give
//! the same bits (IEEE f64 lane arithmetic, and Rust never fuses a multiply and an add). Where
//! the one-constraint code branches on a lane's value, both sides are computed and the lane's
//! own selected; idle lanes and points get the idle values (mostly +0: an AND with the mask).

use super::lanes::{Batch, LaneVectors, Lanes, PointRows};
use super::regs::{M, Reg, V, keep};
use super::{Constraint, LANES};
use crate::collision::manifold::MAX_POINTS;
use crate::math::Scalar;

/// `constraints::inverse` per lane: 1/k, or 0 where k ≤ 0.
#[inline(always)]
fn inverse(k: Reg) -> Reg {
    keep(k.simd_gt(Reg::ZERO), Reg::ONE / k)
}

/// What one batch's constraints are worked out from, lane by lane. An idle lane repeats a
/// used lane's inputs, and a lane's points beyond its own count its first point: finite
/// numbers whose results the masks then drop.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct LaneInputs {
    /// Solver-body slots of A and B.
    pub slot: [[u32; LANES]; 2],
    /// Unit normals, from B to A.
    pub normal: LaneVectors,
    /// Positions of A and B [m].
    pub position: [LaneVectors; 2],
    /// Velocities of A and B before gravity's pull this step [m/s].
    pub before: [LaneVectors; 2],
    /// Angular velocities of A and B [rad/s].
    pub spin: [LaneVectors; 2],
    /// S = (I⁻¹)^½ of A and B, by columns.
    pub scale: [[LaneVectors; 3]; 2],
    /// Inverse masses of A and B [1/kg].
    pub inv_mass: [Lanes; 2],
    /// Friction coefficients, restitutions, slops [m], fastest pushes [m/s].
    pub mu: Lanes,
    pub restitution: Lanes,
    pub slop: Lanes,
    pub max_push: Lanes,
    /// Points of each lane's manifold (1 to `MAX_POINTS`).
    pub len: Lanes,
    /// The manifolds' points [m] and gaps [m].
    pub points: [LaneVectors; MAX_POINTS],
    pub gap: [Lanes; MAX_POINTS],
    /// Each point's impulse taken from last step's [N·s] (0 for none).
    pub impulse: [Lanes; MAX_POINTS],
    /// 1 where a point took last step's impulse (it does not bounce), else 0.
    pub kept: [Lanes; MAX_POINTS],
    /// Last step's friction impulses at the patch centre [N·s] and about the normal [N·m·s].
    pub tangent_impulse: LaneVectors,
    pub twist_impulse: LaneVectors,
}

/// Writes the `count` constraints of `input` (lanes 0..count; the others idle, both ends
/// `static_slot`) into `batch` and their points into `rows` (the batch's `batch.len` points),
/// as `Batch::set` and `PointRows::set` would write each lane's `Constraint` and
/// `ContactPoint`s. `compliance` is the soft rows' `Softness::compliance`.
pub(super) fn fill_lanes(
    input: &LaneInputs,
    count: usize,
    static_slot: u32,
    compliance: Scalar,
    batch: &mut Batch,
    rows: &mut [PointRows],
) {
    let lane = Reg::new([0.0, 1.0, 2.0, 3.0]);
    let active = lane.simd_lt(Reg::splat(count as Scalar));
    let len = Reg::new(input.len);
    let on: [Reg; MAX_POINTS] = std::array::from_fn(|j| active & len.simd_gt(Reg::splat(j as Scalar)));
    let zero = Reg::ZERO;
    let n = V::load(&input.normal);
    let position = input.position.each_ref().map(V::load);
    let scale = input.scale.each_ref().map(|s| M(s.each_ref().map(V::load)));
    let inv_mass = input.inv_mass.map(Reg::new);
    let linear = inv_mass[0] + inv_mass[1];

    // `constraints::tangents`: the helper axis X or Y, normalised as glam's `normalize` does.
    let use_x = n.x.abs().simd_lt(Reg::splat(0.57));
    let helper = V { x: keep(use_x, Reg::ONE), y: use_x.select(zero, Reg::ONE), z: zero };
    let t1 = n.cross(helper);
    let t1 = t1.scale(Reg::ONE / t1.dot(t1).sqrt());
    let tangents = [t1, n.cross(t1)];

    // The friction patch's centre: glam's `Sum` (from zero) over each lane's own points.
    let mut sum = V::splat(0.0, 0.0, 0.0);
    for j in 0..rows.len() {
        let more = len.simd_gt(Reg::splat(j as Scalar));
        sum = sum.add(V::load(&input.points[j])).select(more, sum);
    }
    let centre = sum.over(len);

    // The points' rows.
    let [before_a, before_b] = input.before.each_ref().map(V::load);
    let [spin_a, spin_b] = input.spin.each_ref().map(V::load);
    let mut g = [[V::splat(0.0, 0.0, 0.0); 2]; MAX_POINTS];
    let mut k = [zero; MAX_POINTS];
    for (j, row) in rows.iter_mut().enumerate() {
        let p = V::load(&input.points[j]);
        let r = [p.sub(position[0]), p.sub(position[1])];
        g[j] = [scale[0].mul(r[0].cross(n)), scale[1].mul(r[1].cross(n))];
        k[j] = linear + g[j][0].dot(g[j][0]) + g[j][1].dot(g[j][1]);
        let kept = Reg::new(input.kept[j]).simd_gt(zero);
        // Only a new point needs its approach speed: skipped when every lane's is kept.
        let approach = if (on[j] & !kept).any() {
            let relative = before_a.add(spin_a.cross(r[0])).sub(before_b).sub(spin_b.cross(r[1]));
            kept.select(zero, relative.dot(n))
        } else {
            zero
        };
        let lever = p.sub(centre);
        let lever = lever.dot(lever).sqrt();
        let m = on[j];
        g[j][0].keep(m).store(&mut row.g[0]);
        g[j][1].keep(m).store(&mut row.g[1]);
        row.mass = keep(m, inverse(k[j])).to_array();
        row.k = keep(m, k[j]).to_array();
        row.impulse = keep(m, Reg::new(input.impulse[j])).to_array();
        row.gap = keep(m, Reg::new(input.gap[j])).to_array();
        row.approach = keep(m, approach).to_array();
        row.max_impulse = [0.0; LANES];
        row.lever = keep(m, lever).to_array();
        row.coupling = [0.0; LANES];
        row.inv_det = [[0.0; LANES]; 2];
    }
    // `constraints::couple_pairs`: the pairs (0, 1) and (2, 3) of the lanes that have both.
    for j in (0..rows.len().saturating_sub(1)).step_by(2) {
        let (p, q) = (j, j + 1);
        let coupling = linear + g[p][0].dot(g[q][0]) + g[p][1].dot(g[q][1]);
        let c = Reg::splat(compliance);
        let soft = |k: Reg| k + c * k;
        let det = [k[p] * k[q] - coupling * coupling, soft(k[p]) * soft(k[q]) - coupling * coupling];
        let m = on[q];
        rows[j].coupling = keep(m, coupling).to_array();
        rows[j].inv_det = det.map(|d| keep(m, Reg::ONE / d).to_array());
    }

    // The constraint, `Batch::set`'s fields; an idle lane's are `Constraint::idle`'s.
    let idle = Constraint::idle(static_slot);
    for l in 0..LANES {
        let used = l < count;
        batch.slot[0][l] = if used { input.slot[0][l] } else { idle.slot[0] };
        batch.slot[1][l] = if used { input.slot[1][l] } else { idle.slot[1] };
    }
    n.select(active, V::splat(idle.normal.x, idle.normal.y, idle.normal.z)).store(&mut batch.normal);
    for (t, (into, idle)) in tangents.iter().zip(batch.tangents.iter_mut().zip(idle.tangents)) {
        t.select(active, V::splat(idle.x, idle.y, idle.z)).store(into);
    }
    batch.inv_mass = inv_mass.map(|m| keep(active, m).to_array());
    batch.inv_mass_sum = keep(active, linear).to_array();
    let mu = Reg::new(input.mu);
    batch.mu = keep(active, mu).to_array();
    batch.restitution = keep(active, Reg::new(input.restitution)).to_array();
    batch.slop = keep(active, Reg::new(input.slop)).to_array();
    batch.max_push = keep(active, Reg::new(input.max_push)).to_array();

    // `constraints::friction_patch`, where μ > 0; else `Friction::IDLE` (zeros).
    let has = active & mu.simd_gt(zero);
    let r = [centre.sub(position[0]), centre.sub(position[1])];
    let gt = tangents.map(|t| [scale[0].mul(r[0].cross(t)), scale[1].mul(r[1].cross(t))]);
    let k11 = linear + gt[0][0].dot(gt[0][0]) + gt[0][1].dot(gt[0][1]);
    let k22 = linear + gt[1][0].dot(gt[1][0]) + gt[1][1].dot(gt[1][1]);
    let k12 = gt[0][0].dot(gt[1][0]) + gt[0][1].dot(gt[1][1]);
    let det = k11 * k22 - k12 * k12;
    let invertible = det.simd_gt(zero);
    let mass = [
        invertible.select(k22 / det, inverse(k11)),
        keep(invertible, -k12 / det),
        invertible.select(k11 / det, inverse(k22)),
    ];
    let twist = [scale[0].mul(n), scale[1].mul(n)];
    let twist_mass = inverse(twist[0].dot(twist[0]) + twist[1].dot(twist[1]));
    let (jt, jw) = (V::load(&input.tangent_impulse), V::load(&input.twist_impulse));
    let impulse = [jt.dot(tangents[0]), jt.dot(tangents[1]), jw.dot(n)];
    let f = &mut batch.friction;
    for t in 0..2 {
        for end in 0..2 {
            gt[t][end].keep(has).store(&mut f.g[t][end]);
        }
        twist[t].keep(has).store(&mut f.twist[t]);
    }
    f.mass = mass.map(|m| keep(has, m).to_array());
    f.twist_mass = keep(has, twist_mass).to_array();
    f.impulse = impulse.map(|i| keep(has, i).to_array());
}
