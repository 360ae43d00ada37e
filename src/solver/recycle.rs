//! Contact recycling four pairs at a time (`recycle_four`): whether each pair has stayed
//! still since its points were found (`solve::still`), and its kept
//! points placed at the bodies' poses (`solve::placed`). Per lane the arithmetic is the
//! one-pair code's (glam's matrix, quaternion and dot products), operation for operation in
//! the same order, so the lanes give the same bits (IEEE f64 lanes; Rust fuses nothing).

use super::regs::{M, Reg, V};
use super::{ContactAnchors, LANES};
use crate::collision::manifold::{MAX_POINTS, Manifold};
use crate::math::{Scalar, Vector};
use crate::sim::bodies::Bodies;

/// A quaternion per lane.
struct Q {
    x: Reg,
    y: Reg,
    z: Reg,
    w: Reg,
}

impl Q {
    #[inline(always)]
    fn gather(f: impl Fn(usize) -> crate::math::Quat) -> Self {
        let q: [crate::math::Quat; LANES] = std::array::from_fn(f);
        Self {
            x: Reg::new(q.map(|q| q.x)),
            y: Reg::new(q.map(|q| q.y)),
            z: Reg::new(q.map(|q| q.z)),
            w: Reg::new(q.map(|q| q.w)),
        }
    }

    /// glam's `self.inverse() * o` for unit quaternions (the conjugate, then `mul_quat`).
    #[inline(always)]
    fn inverse_mul(&self, o: &Self) -> Self {
        let (x0, y0, z0, w0) = (-self.x, -self.y, -self.z, self.w);
        let (x1, y1, z1, w1) = (o.x, o.y, o.z, o.w);
        Self {
            x: w0 * x1 + x0 * w1 + y0 * z1 - z0 * y1,
            y: w0 * y1 - x0 * z1 + y0 * w1 + z0 * x1,
            z: w0 * z1 + x0 * y1 - y0 * x1 + z0 * w1,
            w: w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1,
        }
    }

    /// glam's `DQuat::dot`: x, y, z, w summed in that order.
    #[inline(always)]
    fn dot(&self, o: &Self) -> Reg {
        self.x * o.x + self.y * o.y + self.z * o.z + self.w * o.w
    }
}

/// Four pairs' recycling at once: lane l is the pair of bodies `ends[l]` with the kept points
/// `old[l]`, allowed to have moved `distance[l]` [m] (`solve::still`: the quick bound on the
/// arc, else the exact arc, worked out alone). Into `out[l]` (lanes without one are idle) go
/// the kept points placed at the bodies' poses, or `None` when the pair has moved. Returns each
/// lane's normal turned with A.
pub fn recycle_four(
    old: [&ContactAnchors; LANES],
    ends: [(usize, usize); LANES],
    distance: [Scalar; LANES],
    b: &Bodies,
    mut out: [Option<&mut Option<Manifold>>; LANES],
) -> [Vector; LANES] {
    let (ia, ib) = (ends.map(|e| e.0), ends.map(|e| e.1));
    let (pa, pb) = (V::gather(|l| b.position[ia[l]]), V::gather(|l| b.position[ib[l]]));
    let ra = M::gather(&b.rotation, ia);
    // `solve::relative`: B's centre in A's frame, B's orientation relative to A's.
    let offset = ra.transpose_mul(pb.sub(pa));
    let turn = Q::gather(|l| b.orientation[ia[l]]).inverse_mul(&Q::gather(|l| b.orientation[ib[l]]));
    // `solve::still`'s bounds (`acos_bounds`), and between them the exact arc.
    let moved = offset.sub(V::gather(|l| old[l].offset));
    let shift = moved.dot(moved).sqrt();
    let c = turn.dot(&Q::gather(|l| old[l].turn)).abs();
    let x = Reg::ONE - c;
    let root = (Reg::splat(2.0) * x).sqrt();
    let (low, high) = (root * Reg::splat(1.0 - 1e-9), root * (Reg::ONE + x / Reg::splat(6.0)) * Reg::splat(1.0 + 1e-9));
    let (radius, distance) = (Reg::new(ib.map(|i| b.radius[i])), Reg::new(distance));
    let arc = |bound: Reg| shift + Reg::splat(2.0) * bound * radius;
    let (quick, moved) = (arc(high).simd_lt(distance).to_bitmask(), arc(low).simd_ge(distance).to_bitmask());
    let (shift, radius, distance) = (shift.to_array(), radius.to_array(), distance.to_array());
    let (tx, ty, tz, tw) = (turn.x.to_array(), turn.y.to_array(), turn.z.to_array(), turn.w.to_array());
    let still: [bool; LANES] = std::array::from_fn(|l| {
        let turn = crate::math::Quat::from_xyzw(tx[l], ty[l], tz[l], tw[l]);
        quick & (1 << l) != 0
            || (moved & (1 << l) == 0 && shift[l] + turn.angle_between(old[l].turn) * radius[l] < distance[l])
    });
    let normal = ra.mul(V::gather(|l| old[l].normal));
    for (l, o) in out.iter_mut().enumerate() {
        if let Some(o) = o {
            **o = still[l].then(|| Manifold { len: old[l].len, ..Manifold::default() });
        }
    }
    // `solve::placed`, if any lane keeps its points.
    let placing = out.iter().zip(still).any(|(o, s)| o.is_some() && s);
    let rb = M::gather(&b.rotation, ib);
    let half = Reg::splat(0.5);
    let most = if placing { old.iter().map(|g| g.len).max().unwrap_or(0).min(MAX_POINTS) } else { 0 };
    for k in 0..most {
        let on_a = pa.add(ra.mul(V::gather(|l| old[l].on_a[k])));
        let on_b = pb.add(rb.mul(V::gather(|l| old[l].on_b[k])));
        let sum = on_a.add(on_b);
        let (x, y, z) = ((half * sum.x).to_array(), (half * sum.y).to_array(), (half * sum.z).to_array());
        let gap = on_a.sub(on_b).dot(normal).to_array();
        for (l, o) in out.iter_mut().enumerate() {
            if let Some(m) = o.as_deref_mut().and_then(Option::as_mut).filter(|m| k < m.len) {
                (m.points[k], m.gaps[k]) = (Vector::new(x[l], y[l], z[l]), gap[l]);
            }
        }
    }
    std::array::from_fn(|l| normal.lane(l))
}
