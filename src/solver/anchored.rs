//! Lone ball joints to a fixed end (a pendulum hung from the world, a lamp from a fixed
//! beam), the one-body joints rapier also solves apart. Such a joint's three point rows
//! lie on the world axes and its fixed end neither moves nor turns, so half of the general
//! rows' products (`joint_system`, `joint_pass`) are by zero: here they are written out, and
//! the joint, sharing no moving body with another joint, is its own 3 × 3 block of K. Sharing
//! no body, any four are solved side by side in `f64x4` registers, as the contacts are
//! (`kernel`).
//!
//! Per joint the arithmetic is that of the general path for the same joint, operation for
//! operation, less the products by zero, so every value is the same but perhaps the sign of
//! an exact zero (a sum that is exactly zero); the tests below check it against the general path.

use super::joint_pass::End;
use super::joint_system::DROP;
use super::joints::{Joint, JointImpulses, JointKind};
use super::{BodyStore, LANES, SolverBody};
use crate::math::{Scalar, Vector, exp_map};
use wide::f64x4;

/// Four f64 lanes, one joint each.
type Reg = f64x4;

const _: () = assert!(LANES == 4, "the registers hold four lanes");

/// One vector per lane, a register per component.
#[derive(Clone, Copy, Debug, Default)]
struct Wide3 {
    x: Reg,
    y: Reg,
    z: Reg,
}

impl Wide3 {
    #[inline(always)]
    fn dot(self, o: Self) -> Reg {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    fn plus(self, o: Self) -> Self {
        Self { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }

    #[inline(always)]
    fn minus(self, o: Self) -> Self {
        Self { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }

    #[inline(always)]
    fn times(self, s: Reg) -> Self {
        Self { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

/// The two fields `pick` gives of the bodies in `slot[..len]` (zero in the other lanes), each
/// body read once; a full batch with the count known, so its loop unrolls.
#[inline(always)]
fn gather<B: BodyStore + ?Sized>(
    bodies: &B,
    slot: &[u32; LANES],
    len: usize,
    pick: impl Fn(&SolverBody) -> [Vector; 2],
) -> [Wide3; 2] {
    let mut out = [[[0.0; LANES]; 3]; 2];
    let mut read = |l: usize| {
        for (side, v) in out.iter_mut().zip(pick(bodies.body(slot[l]))) {
            (side[0][l], side[1][l], side[2][l]) = (v.x, v.y, v.z);
        }
    };
    if len == LANES {
        for l in 0..LANES {
            read(l);
        }
    } else {
        for l in 0..len {
            read(l);
        }
    }
    out.map(|[x, y, z]| Wide3 { x: Reg::new(x), y: Reg::new(y), z: Reg::new(z) })
}

/// One anchored joint, before it takes its lane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct AnchoredJoint {
    pub joint: u32,
    end: End,
    anchor: Vector,
    pivot: Vector,
    acc: [Scalar; 3],
}

impl AnchoredJoint {
    /// The joint `k` as an anchored one, if it is one: a ball joint without a cone whose A is
    /// free and whose B is fixed (or the world). (That it shares A with no other joint is the
    /// caller's to know.) Its impulse starts from `imp`.
    pub fn of(k: usize, joint: &Joint, [a, b]: [End; 2], imp: &JointImpulses) -> Option<Self> {
        if joint.kind != (JointKind::Ball { cone: None }) || !a.free || b.free {
            return None;
        }
        // B's anchor as `Geometry::new` places it at B's (fixed) pose.
        let pivot = b.x0 + b.q0 * joint.anchor_b;
        let acc = [imp.point.dot(Vector::X), imp.point.dot(Vector::Y), imp.point.dot(Vector::Z)];
        Some(Self { joint: k as u32, end: a, anchor: joint.anchor_a, pivot, acc })
    }
}

/// Up to four anchored joints, lane by lane, and their rows at the last refresh.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Anchored {
    /// The joints' indices in the scene's joints and their bodies' slots, in `len` lanes.
    joints: [u32; LANES],
    slot: [u32; LANES],
    len: usize,
    inv_mass: Reg,
    /// S of A, by column.
    scale: [Wide3; 3],
    /// A's pose at the start of the step (the orientation as x, y, z, w).
    x0: Wide3,
    q0: [Reg; 4],
    /// The anchor on A (A's body frame) and on the fixed end (world frame).
    anchor: Wide3,
    pivot: Wide3,
    /// g = S (r × e_k) of the rows along the world axes e_k.
    g: [Wide3; 3],
    /// The position error along each axis.
    error: [Reg; 3],
    /// K = m⁻¹ 1 + G Gᵀ factorised by `ldl3`.
    factor: [Reg; 6],
    /// Accumulated impulse along each axis this substep.
    acc: [Reg; 3],
}

impl Anchored {
    /// The joints `lanes` (one to four) side by side; the other lanes idle (zero mass, at rest,
    /// turned by the identity, so nothing in them divides by zero).
    pub fn new(lanes: &[AnchoredJoint]) -> Self {
        debug_assert!((1..=LANES).contains(&lanes.len()));
        let (mut joints, mut slot, mut inv_mass) = ([u32::MAX; LANES], [0; LANES], [0.0; LANES]);
        // Vectors by field and component, lane by lane: S's three columns, x0, the two anchors,
        // the impulses; and the orientation, an idle lane's the identity.
        let mut v = [[[0.0; LANES]; 3]; 7];
        let mut q0 = [[0.0; LANES], [0.0; LANES], [0.0; LANES], [1.0; LANES]];
        for (l, j) in lanes.iter().enumerate() {
            (joints[l], slot[l], inv_mass[l]) = (j.joint, j.end.slot, j.end.inv_mass);
            let s = j.end.scale;
            let acc = Vector::from_array(j.acc);
            for (field, x) in v.iter_mut().zip([s.x_axis, s.y_axis, s.z_axis, j.end.x0, j.anchor, j.pivot, acc]) {
                (field[0][l], field[1][l], field[2][l]) = (x.x, x.y, x.z);
            }
            let q = j.end.q0;
            (q0[0][l], q0[1][l], q0[2][l], q0[3][l]) = (q.x, q.y, q.z, q.w);
        }
        let [c0, c1, c2, x0, anchor, pivot, acc] =
            v.map(|[x, y, z]| Wide3 { x: Reg::new(x), y: Reg::new(y), z: Reg::new(z) });
        Self {
            joints,
            slot,
            len: lanes.len(),
            inv_mass: Reg::new(inv_mass),
            scale: [c0, c1, c2],
            x0,
            q0: q0.map(Reg::new),
            anchor,
            pivot,
            g: [Wide3::default(); 3],
            error: [Reg::ZERO; 3],
            factor: [Reg::ZERO; 6],
            acc: [acc.x, acc.y, acc.z],
        }
    }

    /// The rows, errors and K at the bodies' current poses (each as `End::frame` and
    /// `Geometry::new` place it).
    #[inline]
    pub fn refresh<B: BodyStore + ?Sized>(&mut self, bodies: &B) {
        let [dx, dq] = gather(bodies, &self.slot, self.len, |b| [b.dx, b.dq]);
        let s = self.scale;
        let theta = s[0].times(dq.x).plus(s[1].times(dq.y)).plus(s[2].times(dq.z));
        let (tx, ty, tz) = (theta.x.to_array(), theta.y.to_array(), theta.z.to_array());
        let mut turn = [[0.0, 0.0, 0.0, 1.0]; LANES];
        for l in 0..self.len {
            turn[l] = exp_map(Vector::new(tx[l], ty[l], tz[l])).to_array();
        }
        let turn = [0, 1, 2, 3].map(|c| Reg::new(turn.map(|q| q[c])));
        let q = normalize(mul_quat(turn, self.q0));
        let r = rotate(q, self.anchor);
        let d = self.x0.plus(dx).plus(r).minus(self.pivot);
        // S (r × e_k) with r × X = (0, r_z, −r_y), r × Y = (−r_z, 0, r_x), r × Z = (r_y, −r_x, 0).
        self.g = [
            s[1].times(r.z).minus(s[2].times(r.y)),
            s[2].times(r.x).minus(s[0].times(r.z)),
            s[0].times(r.y).minus(s[1].times(r.x)),
        ];
        self.error = [d.x, d.y, d.z];
        let [g0, g1, g2] = self.g;
        let m = self.inv_mass;
        self.factor = ldl3([m + g0.dot(g0), g1.dot(g0), m + g1.dot(g1), g2.dot(g0), g2.dot(g1), m + g2.dot(g2)]);
    }

    /// One pass: λ = `mass_scale` K⁻¹(−J v − `bias_rate` C) − `impulse_scale` λ_acc, applied.
    #[inline]
    pub fn pass<B: BodyStore + ?Sized>(&mut self, bodies: &mut B, [bias_rate, mass_scale, impulse_scale]: [Scalar; 3]) {
        let [mut v, mut w] = gather(bodies, &self.slot, self.len, |b| [b.v, b.w]);
        let bias = Reg::splat(bias_rate);
        let speed = [v.x + self.g[0].dot(w), v.y + self.g[1].dot(w), v.z + self.g[2].dot(w)];
        let x = solve3(&self.factor, [0, 1, 2].map(|i| -(speed[i] + bias * self.error[i])));
        let (mass_scale, impulse_scale) = (Reg::splat(mass_scale), Reg::splat(impulse_scale));
        let mut l = [Reg::ZERO; 3];
        for i in 0..3 {
            l[i] = mass_scale * x[i] - impulse_scale * self.acc[i];
            self.acc[i] += l[i];
        }
        self.push(&mut v, &mut w, l);
        self.scatter(bodies, v, w);
    }

    /// Re-applies the accumulated impulses.
    #[inline]
    pub fn warm<B: BodyStore + ?Sized>(&self, bodies: &mut B) {
        let [mut v, mut w] = gather(bodies, &self.slot, self.len, |b| [b.v, b.w]);
        self.push(&mut v, &mut w, self.acc);
        self.scatter(bodies, v, w);
    }

    /// Applies impulses `l` along the three rows, in row order.
    #[inline(always)]
    fn push(&self, v: &mut Wide3, w: &mut Wide3, l: [Reg; 3]) {
        let m = self.inv_mass;
        v.x += m * l[0];
        *w = w.plus(self.g[0].times(l[0]));
        v.y += m * l[1];
        *w = w.plus(self.g[1].times(l[1]));
        v.z += m * l[2];
        *w = w.plus(self.g[2].times(l[2]));
    }

    /// Writes the lanes' velocities back to their bodies.
    #[inline(always)]
    fn scatter<B: BodyStore + ?Sized>(&self, bodies: &mut B, v: Wide3, w: Wide3) {
        let [vx, vy, vz, wx, wy, wz] = [v.x, v.y, v.z, w.x, w.y, w.z].map(|r| r.to_array());
        let mut write = |l: usize| {
            let b = bodies.body_mut(self.slot[l]);
            (b.v, b.w) = (Vector::new(vx[l], vy[l], vz[l]), Vector::new(wx[l], wy[l], wz[l]));
        };
        // A full batch with the count known, so the loop unrolls.
        if self.len == LANES {
            for l in 0..LANES {
                write(l);
            }
        } else {
            for l in 0..self.len {
                write(l);
            }
        }
    }

    /// Keeps the accumulated impulses in the joints' `JointImpulses` (world vectors).
    pub fn store(&self, impulses: &mut [JointImpulses]) {
        let [x, y, z] = self.acc.map(|r| r.to_array());
        for l in 0..self.len {
            let imp = &mut impulses[self.joints[l] as usize];
            (imp.point, imp.angular) = (Vector::new(x[l], y[l], z[l]), Vector::ZERO);
        }
    }
}

/// The product of quaternions (x, y, z, w) `a` `b`, as glam's.
#[inline(always)]
fn mul_quat([x0, y0, z0, w0]: [Reg; 4], [x1, y1, z1, w1]: [Reg; 4]) -> [Reg; 4] {
    [
        w0 * x1 + x0 * w1 + y0 * z1 - z0 * y1,
        w0 * y1 - x0 * z1 + y0 * w1 + z0 * x1,
        w0 * z1 + x0 * y1 - y0 * x1 + z0 * w1,
        w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1,
    ]
}

/// `q` over its length, as glam's.
#[inline(always)]
fn normalize(q: [Reg; 4]) -> [Reg; 4] {
    let recip = Reg::splat(1.0) / (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    q.map(|c| c * recip)
}

/// `v` turned by the unit quaternion `q`, as glam's.
#[inline(always)]
fn rotate([x, y, z, w]: [Reg; 4], v: Wide3) -> Wide3 {
    let b = Wide3 { x, y, z };
    let cross = Wide3 { x: b.y * v.z - v.y * b.z, y: b.z * v.x - v.z * b.x, z: b.x * v.y - v.x * b.y };
    v.times(w * w - b.dot(b)).plus(b.times(v.dot(b) * Reg::splat(2.0))).plus(cross.times(w * Reg::splat(2.0)))
}

/// LDLᵀ of the symmetric 3 × 3 `k` (lower triangle, row by row: K₀₀, K₁₀, K₁₁, K₂₀, K₂₁, K₂₂),
/// as `joint_system::ldl` does it for three rows: (1/d₀, 1/d₁, 1/d₂, L₁₀, L₂₀, L₂₁), a dropped
/// pivot as 0 with its column of L.
#[inline(always)]
fn ldl3([k00, k10, k11, k20, k21, k22]: [Reg; 6]) -> [Reg; 6] {
    let (zero, one) = (Reg::ZERO, Reg::splat(1.0));
    let keep = |own: Reg, dj: Reg| own.simd_gt(zero) & dj.simd_gt(Reg::splat(DROP) * own);
    let kept0 = keep(k00, k00);
    let (d0, i0) = (kept0.select(k00, zero), kept0.select(one / k00, zero));
    let (l10, l20) = (kept0.select(k10 / k00, zero), kept0.select(k20 / k00, zero));
    let d1 = k11 - l10 * l10 * d0;
    let kept1 = keep(k11, d1);
    let l21 = kept1.select((k21 - l20 * l10 * d0) / d1, zero);
    let (d1, i1) = (kept1.select(d1, zero), kept1.select(one / d1, zero));
    let d2 = k22 - (l20 * l20 * d0 + l21 * l21 * d1);
    let i2 = keep(k22, d2).select(one / d2, zero);
    [i0, i1, i2, l10, l20, l21]
}

/// Solves K x = `b` with K factorised by `ldl3` (as `joint_system::ldl_solve`).
#[inline(always)]
fn solve3([i0, i1, i2, l10, l20, l21]: &[Reg; 6], [b0, b1, b2]: [Reg; 3]) -> [Reg; 3] {
    let y1 = b1 - *l10 * b0;
    let y2 = b2 - (*l20 * b0 + *l21 * y1);
    let (z0, z1, z2) = (b0 * *i0, y1 * *i1, y2 * *i2);
    let x1 = z1 - *l21 * z2;
    let x0 = z0 - (*l10 * x1 + *l20 * z2);
    [x0, x1, z2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Mat3, Quat};
    use crate::rng::SplitMix64;
    use crate::solver::joint_pass::{JointPass, arrange, joint_pass, store_impulses};
    use crate::solver::joint_system::{MAX_ROWS, ldl, ldl_solve};
    use crate::solver::joints::Joints;

    fn vector(rng: &mut SplitMix64) -> Vector {
        Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5)
    }

    /// `n` pendulums of random bodies hung from the world at random anchors, with random
    /// impulses to start from, and their bodies (the last slot static), moved a little and
    /// spinning.
    fn pendulums(n: usize, rng: &mut SplitMix64) -> (Joints, Vec<SolverBody>) {
        let (mut list, mut ends) = (Vec::new(), Vec::new());
        for k in 0..n {
            let (x0, q0) = (vector(rng), Quat::from_scaled_axis(vector(rng) * 4.0).normalize());
            let anchor = x0 + vector(rng);
            let poses = [(x0, q0), (Vector::ZERO, Quat::IDENTITY)];
            let kind = JointKind::Ball { cone: None };
            list.push(Joint::new(format!("j{k}"), (k as u32, None), kind, [anchor; 2], Vector::X, poses));
            let r = Mat3::from_quat(Quat::from_scaled_axis(vector(rng) * 4.0));
            let scale = r * Mat3::from_diagonal(Vector::ONE + vector(rng)) * r.transpose();
            let a = End { slot: k as u32, free: true, inv_mass: 0.5 + rng.unit(), scale, x0, q0 };
            // The world's end, as `prepare` gives it: nothing turns it (S = 0).
            ends.push([a, End { slot: n as u32, scale: Mat3::ZERO, ..End::default() }]);
        }
        let mut joints = Joints::new(list);
        joints.ends = ends;
        joints.impulses.iter_mut().for_each(|imp| imp.point = vector(rng));
        let body = |rng: &mut SplitMix64| SolverBody {
            v: vector(rng),
            w: vector(rng),
            dx: vector(rng) * 0.1,
            dq: vector(rng) * 0.1,
        };
        let mut bodies: Vec<SolverBody> = (0..n).map(|_| body(rng)).collect();
        bodies.push(SolverBody::default());
        (joints, bodies)
    }

    #[test]
    fn anchored_joints_give_the_general_paths_values() {
        let mut rng = SplitMix64::new(11);
        // Four batches, the last with two idle lanes.
        let (mut joints, bodies) = pendulums(14, &mut rng);
        let mut general = joints.clone();
        arrange(&mut joints, true);
        arrange(&mut general, false);
        assert_eq!((joints.anchored.len(), joints.general.len()), (4, 0));
        assert_eq!((general.anchored.len(), general.general.len()), (0, 14));
        let (mut fast, mut slow) = (bodies.clone(), bodies);
        let h = 1.0 / 240.0;
        for pass in [JointPass::Warm, JointPass::Solve, JointPass::Solve, JointPass::Relax, JointPass::Relax] {
            joint_pass(fast.as_mut_slice(), &mut joints, pass, h);
            joint_pass(slow.as_mut_slice(), &mut general, pass, h);
            // == takes the two zeros for one; every other value matches to the bit.
            assert_eq!(fast, slow, "{pass:?}");
        }
        store_impulses(&mut joints);
        store_impulses(&mut general);
        assert_eq!(joints.impulses, general.impulses);
        assert_eq!(fast[14], SolverBody::default(), "the static slot stays zero");
    }

    #[test]
    fn the_written_out_factorisation_is_the_general_one() {
        let mut rng = SplitMix64::new(4);
        for round in 0..100 {
            let mut k = [[0.0; LANES]; 6];
            let mut b = [[0.0; LANES]; 3];
            for l in 0..LANES {
                let case = round * LANES + l;
                let g = [vector(&mut rng), vector(&mut rng), vector(&mut rng)];
                // Some with a row the others fix (dropped) when the mass adds nothing.
                let g = match case % 3 {
                    0 => g,
                    1 => [g[0], g[1], g[0] * 2.0 - g[1]],
                    _ => [g[0], g[0] * 1.5, g[2]],
                };
                let m = if case.is_multiple_of(4) { 0.0 } else { rng.unit() };
                let lane = [m + g[0].dot(g[0]), g[1].dot(g[0]), m + g[1].dot(g[1])];
                let lane = [lane[0], lane[1], lane[2], g[2].dot(g[0]), g[2].dot(g[1]), m + g[2].dot(g[2])];
                for e in 0..6 {
                    k[e][l] = lane[e];
                }
                for e in 0..3 {
                    b[e][l] = rng.unit() - 0.5;
                }
            }
            let x = solve3(&ldl3(k.map(Reg::new)), b.map(Reg::new)).map(|r| r.to_array());
            for l in 0..LANES {
                let mut block = [0.0; MAX_ROWS * MAX_ROWS];
                for (e, (i, j)) in [(0, 0), (1, 0), (1, 1), (2, 0), (2, 1), (2, 2)].into_iter().enumerate() {
                    block[i * MAX_ROWS + j] = k[e][l];
                }
                ldl(&mut block, 3);
                let mut y = [0.0; MAX_ROWS];
                for e in 0..3 {
                    y[e] = b[e][l];
                }
                ldl_solve(&block, 3, &mut y);
                // Bit for bit but for the sign of a zero (a dropped row's).
                let bits = |x: [Scalar; 3]| x.map(|x| if x == 0.0 { 0 } else { x.to_bits() });
                let ours = [x[0][l], x[1][l], x[2][l]];
                assert_eq!(bits(ours), bits([y[0], y[1], y[2]]), "round {round}, lane {l}");
            }
        }
    }
}
