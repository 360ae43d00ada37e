//! The solver's data laid out lane by lane (structure of arrays): each field holds one value
//! per lane of a batch, so the kernel loads it into one four-lane register (`kernel`) with no
//! shuffling of vector components.

use super::{Constraint, ContactPoint, Friction, LANES};
use crate::math::{Scalar, Vector};

/// One scalar per lane.
pub type Lanes = [Scalar; LANES];

/// One vector per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LaneVectors {
    /// x of each lane.
    pub x: Lanes,
    /// y of each lane.
    pub y: Lanes,
    /// z of each lane.
    pub z: Lanes,
}

impl LaneVectors {
    /// Zero in every lane.
    pub const ZERO: Self = Self { x: [0.0; LANES], y: [0.0; LANES], z: [0.0; LANES] };

    /// Lane `l`'s vector.
    #[inline(always)]
    #[must_use]
    pub fn get(&self, l: usize) -> Vector {
        Vector::new(self.x[l], self.y[l], self.z[l])
    }

    /// Sets lane `l`'s vector.
    #[inline(always)]
    pub fn set(&mut self, l: usize, v: Vector) {
        (self.x[l], self.y[l], self.z[l]) = (v.x, v.y, v.z);
    }
}

/// Up to `LANES` constraints that share no free body, solved together (`super::place`); their
/// points are `points[first..first + len]`, one `PointRows` per point index. Unused lanes, and
/// a lane's points beyond its own count, are idle: zero masses, both ends the static slot.
///
/// Every sweep streams its batches through the cache (on two threads, both sides at once): the
/// fields a solve sweep reads come first, on cache lines of their own, so a solve sweep does
/// not load the lines of friction it never reads.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct Batch {
    /// Solver-body slots of A (index 0) and B of each lane.
    pub slot: [[u32; LANES]; 2],
    /// Unit normals, from B to A.
    pub normal: LaneVectors,
    /// Inverse masses of A and B [1/kg].
    pub inv_mass: [Lanes; 2],
    /// Their sum m_a⁻¹ + m_b⁻¹, the normal rows' linear part of K.
    pub inv_mass_sum: Lanes,
    /// Penetration left alone [m].
    pub slop: Lanes,
    /// Fastest push out of a penetration [m/s].
    pub max_push: Lanes,
    /// First entry of the batch's points.
    pub first: u32,
    /// Most points of any lane.
    pub len: u32,
    /// Every lane started the step with no impulse (`PairEnds::quiet`): while its impulses
    /// stay zero and no normal row asks for a push, a pass leaves it as it is (`kernel`).
    pub quiet: bool,
    /// The two tangents.
    pub tangents: [LaneVectors; 2],
    /// Friction coefficients.
    pub mu: Lanes,
    /// Restitutions.
    pub restitution: Lanes,
    /// The friction patches.
    pub friction: FrictionRows,
}

impl Batch {
    /// A batch of idle lanes whose ends are the static slot.
    #[must_use]
    pub fn idle(static_slot: u32) -> Self {
        let mut batch = Self::default();
        for l in 0..LANES {
            batch.set(l, &Constraint::idle(static_slot));
        }
        batch
    }

    /// Where its points are in its group's point rows: `first..first + len`.
    #[must_use]
    pub fn rows(&self) -> std::ops::Range<usize> {
        self.first as usize..(self.first + self.len) as usize
    }

    /// Puts constraint `c` in lane `l`.
    pub fn set(&mut self, l: usize, c: &Constraint) {
        (self.slot[0][l], self.slot[1][l]) = (c.slot[0], c.slot[1]);
        self.normal.set(l, c.normal);
        self.tangents[0].set(l, c.tangents[0]);
        self.tangents[1].set(l, c.tangents[1]);
        (self.inv_mass[0][l], self.inv_mass[1][l]) = (c.inv_mass[0], c.inv_mass[1]);
        self.inv_mass_sum[l] = c.inv_mass[0] + c.inv_mass[1];
        self.mu[l] = c.mu;
        self.restitution[l] = c.restitution;
        self.slop[l] = c.slop;
        self.max_push[l] = c.max_push;
        self.friction.set(l, &c.friction);
    }

    /// Lane `l`'s normal and tangents.
    #[must_use]
    pub fn axes(&self, l: usize) -> [Vector; 3] {
        [self.normal.get(l), self.tangents[0].get(l), self.tangents[1].get(l)]
    }
}

/// The friction patches of a batch (see `super::Friction`), lane by lane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrictionRows {
    /// g of the two tangents, for A and B.
    pub g: [[LaneVectors; 2]; 2],
    /// S n for A and B.
    pub twist: [LaneVectors; 2],
    /// Inverse 2×2 tangent mass (xx, xy, yy).
    pub mass: [Lanes; 3],
    /// Twist mass.
    pub twist_mass: Lanes,
    /// Accumulated impulses: tangents, twist.
    pub impulse: [Lanes; 3],
}

impl FrictionRows {
    fn set(&mut self, l: usize, f: &Friction) {
        for k in 0..2 {
            self.g[k][0].set(l, f.g[k][0]);
            self.g[k][1].set(l, f.g[k][1]);
            self.twist[k].set(l, f.twist[k]);
        }
        for k in 0..3 {
            self.mass[k][l] = f.mass[k];
            self.impulse[k][l] = f.impulse[k];
        }
        self.twist_mass[l] = f.twist_mass;
    }
}

/// One point of each lane of a batch (see `super::ContactPoint`). What every sweep reads comes
/// first, then what only the first point of a pair reads (its coupling), then what only the
/// sweeps after a move (`gap`), the relax sweep and restitution read, each on cache lines of
/// their own: a solve sweep between two moves loads five lines of a pair's second row and seven
/// of its first, of nine each.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct PointRows {
    /// g = S (r × n) for A and B.
    pub g: [LaneVectors; 2],
    /// Effective masses [kg].
    pub mass: Lanes,
    /// Their inverses K_ii [1/kg].
    pub k: Lanes,
    /// Accumulated normal impulses [N·s].
    pub impulse: Lanes,
    /// Gaps as the substeps have moved the bodies, kept by the last sweep that worked them
    /// out (`kernel::sweep`) [m].
    pub now: Lanes,
    /// K₀₁ with the next point, for the first of a pair [1/kg].
    pub coupling: Lanes,
    /// 1 / det K of the pair held rigidly and soft, for the first of a pair [kg²].
    pub inv_det: [Lanes; 2],
    /// Gaps when the step began [m].
    pub gap: Lanes,
    /// Largest normal impulse at the end of any substep (its relax sweep) [N·s].
    pub max_impulse: Lanes,
    /// Distances from the friction centre [m].
    pub lever: Lanes,
    /// Relative normal speeds when the step began [m/s].
    pub approach: Lanes,
}

impl PointRows {
    /// Puts point `p` in lane `l`.
    pub fn set(&mut self, l: usize, p: &ContactPoint) {
        self.g[0].set(l, p.g[0]);
        self.g[1].set(l, p.g[1]);
        self.mass[l] = p.mass;
        self.k[l] = p.k;
        self.impulse[l] = p.impulse;
        self.gap[l] = p.gap;
        self.approach[l] = p.approach;
        self.max_impulse[l] = p.max_impulse;
        self.lever[l] = p.lever;
        self.coupling[l] = p.coupling;
        (self.inv_det[0][l], self.inv_det[1][l]) = (p.inv_det[0], p.inv_det[1]);
    }

    /// Lane `l`'s point.
    #[must_use]
    pub fn get(&self, l: usize) -> ContactPoint {
        ContactPoint {
            g: [self.g[0].get(l), self.g[1].get(l)],
            mass: self.mass[l],
            k: self.k[l],
            impulse: self.impulse[l],
            gap: self.gap[l],
            approach: self.approach[l],
            max_impulse: self.max_impulse[l],
            lever: self.lever[l],
            coupling: self.coupling[l],
            inv_det: [self.inv_det[0][l], self.inv_det[1][l]],
        }
    }
}
