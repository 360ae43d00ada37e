//! Vectors and matrices four lanes wide, one `f64x4` register per component, for the code
//! that works four constraints or pairs at once (`fill`, `recycle`). Each operation is glam's
//! per lane, operation for operation in glam's order, so a lane gives the bits glam would
//! (IEEE f64 lanes; Rust fuses no multiply and add).

use super::LANES;
use super::lanes::LaneVectors;
use crate::math::{Mat3, Scalar, Vector};
use wide::f64x4;

/// Four f64 lanes in one register.
pub(super) type Reg = f64x4;

/// One vector per lane, a register per component.
#[derive(Clone, Copy)]
pub(super) struct V {
    pub x: Reg,
    pub y: Reg,
    pub z: Reg,
}

impl V {
    #[inline(always)]
    pub fn load(v: &LaneVectors) -> Self {
        Self { x: Reg::new(v.x), y: Reg::new(v.y), z: Reg::new(v.z) }
    }

    /// Lane l's vector is `f(l)`.
    #[inline(always)]
    pub fn gather(f: impl Fn(usize) -> Vector) -> Self {
        let v: [Vector; LANES] = std::array::from_fn(f);
        Self { x: Reg::new(v.map(|v| v.x)), y: Reg::new(v.map(|v| v.y)), z: Reg::new(v.map(|v| v.z)) }
    }

    #[inline(always)]
    pub fn splat(x: Scalar, y: Scalar, z: Scalar) -> Self {
        Self { x: Reg::splat(x), y: Reg::splat(y), z: Reg::splat(z) }
    }

    #[inline(always)]
    pub fn add(self, o: Self) -> Self {
        Self { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }

    #[inline(always)]
    pub fn sub(self, o: Self) -> Self {
        Self { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }

    /// Each component times `s` (glam's `DVec3 * f64`).
    #[inline(always)]
    pub fn scale(self, s: Reg) -> Self {
        Self { x: self.x * s, y: self.y * s, z: self.z * s }
    }

    /// Each component over `s` (glam's `DVec3 / f64`).
    #[inline(always)]
    pub fn over(self, s: Reg) -> Self {
        Self { x: self.x / s, y: self.y / s, z: self.z / s }
    }

    /// glam's `dot`: x, y, z summed in that order.
    #[inline(always)]
    pub fn dot(self, o: Self) -> Reg {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// glam's `cross`.
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Self { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }

    /// Per lane `self` where `mask` holds, else +0.
    #[inline(always)]
    pub fn keep(self, mask: Reg) -> Self {
        Self { x: keep(mask, self.x), y: keep(mask, self.y), z: keep(mask, self.z) }
    }

    /// Per lane `self` where `mask` holds, else `other`.
    #[inline(always)]
    pub fn select(self, mask: Reg, other: Self) -> Self {
        Self { x: mask.select(self.x, other.x), y: mask.select(self.y, other.y), z: mask.select(self.z, other.z) }
    }

    #[inline(always)]
    pub fn store(self, into: &mut LaneVectors) {
        (into.x, into.y, into.z) = (self.x.to_array(), self.y.to_array(), self.z.to_array());
    }

    /// Lane `l`'s vector.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Vector {
        Vector::new(self.x.as_array()[l], self.y.as_array()[l], self.z.as_array()[l])
    }
}

/// `x` where `mask` holds, else +0 (the idle value of most fields): one AND, not a blend.
#[inline(always)]
pub(super) fn keep(mask: Reg, x: Reg) -> Reg {
    x & mask
}

/// A 3×3 matrix per lane, by columns (glam's `DMat3` axes).
#[derive(Clone, Copy)]
pub(super) struct M(pub [V; 3]);

impl M {
    /// Lane l's matrix is `rotation[i[l]]`.
    #[inline(always)]
    pub fn gather(rotation: &[Mat3], i: [usize; LANES]) -> Self {
        Self([
            V::gather(|l| rotation[i[l]].x_axis),
            V::gather(|l| rotation[i[l]].y_axis),
            V::gather(|l| rotation[i[l]].z_axis),
        ])
    }

    /// glam's `mul_vec3`: the columns times x, y, z, summed first to last.
    #[inline(always)]
    pub fn mul(&self, v: V) -> V {
        self.0[0].scale(v.x).add(self.0[1].scale(v.y)).add(self.0[2].scale(v.z))
    }

    /// `self.transpose() * v` as glam computes it: each column dotted with `v`.
    #[inline(always)]
    pub fn transpose_mul(&self, v: V) -> V {
        V { x: self.0[0].dot(v), y: self.0[1].dot(v), z: self.0[2].dot(v) }
    }
}
