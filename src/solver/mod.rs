//! The contact solver: the `solve` system's manifolds become one `Constraint` per held pair and
//! one `ContactPoint` per manifold point (`build`), solved as a "soft step" (Catto,
//! "Solver2D", 2024; Box2D v3; rapier's TGS) by the passes of `kernel`, carried out on one
//! thread or two by `drive`. The scene's joints (`joints`: what they hold) are solved in the
//! same substeps, a pass over them after each pass over the contacts (`joint_pass`).
//!
//! Layout, for speed: the bodies a step's contacts touch are gathered into a dense
//! `SolverBody` array (fixed bodies share a static slot of zeros, so no branch asks which end
//! is fixed), and angular velocities are kept in *inertia-scaled* coordinates
//! ŵ = S⁻¹ω with S = (I⁻¹)^½ in world axes (rapier's trick). Then one vector per body and axis,
//! g = S (r × d), serves both ways: the relative speed along d is Δv·d + ŵ_a·g_a − ŵ_b·g_b, an
//! impulse j changes ŵ by ±g j, and the effective mass is 1 / (m_a⁻¹ + m_b⁻¹ + |g_a|² + |g_b|²)
//! (the K of the corrected collision resolution in docs/physics.md, since
//! (r×d)·I⁻¹(r×d) = |S (r×d)|²).
//!
//! Gauss–Seidel is a chain of dependent steps, so one pair after another runs at the latency
//! of its arithmetic, not the machine's throughput. The constraints are therefore solved
//! `LANES` at a time, interleaved, in `Batch`es of pairs that share no free body (`place`).
//! A batch never reorders two constraints that share a free body, and the others do not
//! interact, so the result is exactly that of solving them one by one in the given order.
//! Large scenes are split in two sides whose constraints are solved at once, then those
//! across (`build`, `drive`); the split follows the scene, never the thread count.

// Lane loops (`for l in 0..LANES`) index several lane arrays in step: the ends, the
// constraints and the points of a batch; an index reads plainer than a four-way zip.
#![allow(clippy::needless_range_loop)]

use crate::math::{Scalar, Vector};

mod anchored;
mod constraints;
mod drive;
mod fill;
mod joint_pass;
mod joint_system;
mod joints;
mod kernel;
mod lanes;
mod recycle;
#[cfg(test)]
mod reference;
mod regs;
mod scratch;

pub(crate) use constraints::{build_constraints, warm_start_of};
pub(crate) use drive::{Pass, Step, drive, substep_plan};
pub(crate) use joint_pass::prepare as prepare_joints;
pub use joints::{Frame, Joint, JointImpulses, JointKind, Joints, Motor, Spring};
pub use kernel::{may_bounce, restitution, sweep, warm_start};
pub use lanes::{Batch, FrictionRows, LaneVectors, Lanes, PointRows};
pub use recycle::recycle_four;
pub use scratch::{
    CachedManifold, ConstraintGroup, ContactAnchors, HeldPair, LaneImpulses, PairEnds, Recycling, SolveScratch,
    WarmStart, cache_entries,
};

/// A body as the substeps see it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolverBody {
    /// Linear velocity [m/s].
    pub v: Vector,
    /// Scaled angular velocity ŵ = S⁻¹ω.
    pub w: Vector,
    /// Displacement over the substeps done so far [m].
    pub dx: Vector,
    /// Scaled rotation vector over the substeps done so far (S⁻¹ times the rotation).
    pub dq: Vector,
}

/// Where a pass finds its solver bodies by slot: one slice whose last body is its static
/// slot, or both sides of a split scene (`Sides`) for the constraints across.
pub trait BodyStore {
    /// The body in `slot`.
    fn body(&self, slot: u32) -> &SolverBody;
    /// The body in `slot`, to write.
    fn body_mut(&mut self, slot: u32) -> &mut SolverBody;
    /// True for a static slot: nothing may write it.
    fn is_static(&self, slot: u32) -> bool;
    /// The body in `slot` to write, or `None` for a static slot (one bounds check for both).
    fn moving_mut(&mut self, slot: u32) -> Option<&mut SolverBody>;
}

impl BodyStore for [SolverBody] {
    #[inline(always)]
    fn body(&self, slot: u32) -> &SolverBody {
        &self[slot as usize]
    }

    #[inline(always)]
    fn body_mut(&mut self, slot: u32) -> &mut SolverBody {
        &mut self[slot as usize]
    }

    #[inline(always)]
    fn is_static(&self, slot: u32) -> bool {
        slot as usize == self.len() - 1
    }

    #[inline(always)]
    fn moving_mut(&mut self, slot: u32) -> Option<&mut SolverBody> {
        // The static slot is the last: the slice without it holds exactly the moving slots.
        self.split_last_mut().and_then(|(_, moving)| moving.get_mut(slot as usize))
    }
}

/// The two sides' solver bodies, numbered as one array (the first side's, its static slot,
/// the second side's, the last static slot), for the constraints across the split.
pub struct Sides<'a> {
    /// The first side, ending with its static slot.
    pub left: &'a mut [SolverBody],
    /// The second side, ending with the last static slot.
    pub right: &'a mut [SolverBody],
}

impl BodyStore for Sides<'_> {
    #[inline(always)]
    fn body(&self, slot: u32) -> &SolverBody {
        let (slot, n) = (slot as usize, self.left.len());
        if slot < n { &self.left[slot] } else { &self.right[slot - n] }
    }

    #[inline(always)]
    fn body_mut(&mut self, slot: u32) -> &mut SolverBody {
        let (slot, n) = (slot as usize, self.left.len());
        if slot < n { &mut self.left[slot] } else { &mut self.right[slot - n] }
    }

    #[inline(always)]
    fn is_static(&self, slot: u32) -> bool {
        let slot = slot as usize;
        slot == self.left.len() - 1 || slot == self.left.len() + self.right.len() - 1
    }

    #[inline(always)]
    fn moving_mut(&mut self, slot: u32) -> Option<&mut SolverBody> {
        let (slot, n) = (slot as usize, self.left.len());
        if slot < n { self.left.moving_mut(slot as u32) } else { self.right.moving_mut((slot - n) as u32) }
    }
}

/// Constraints solved side by side in a batch.
pub const LANES: usize = 4;

/// Share of its manifold's largest impulse in the substeps above which a point counts as having
/// touched, and may bounce (`kernel::restitution`): far above the round-off a block solve
/// leaves on a point it did not push (1e-15 of the others' impulses, on a cube landing flat,
/// whose lone corner then bounced and set it spinning), far below any share it really carried.
pub const TOUCH_SHARE: Scalar = 1e-9;

/// One held pair: its bodies, normal, material and friction rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Constraint {
    /// Solver-body slots of A and B (the static slot for a fixed body).
    pub slot: [u32; 2],
    /// Unit normal from B to A.
    pub normal: Vector,
    /// Two unit tangents completing the normal to a right-handed basis.
    pub tangents: [Vector; 2],
    /// Inverse masses of A and B [1/kg].
    pub inv_mass: [Scalar; 2],
    /// Friction coefficient of the pair.
    pub mu: Scalar,
    /// Restitution of the pair.
    pub restitution: Scalar,
    /// Penetration left alone [m] (`Params::slop` times the thinner body's thickness).
    pub slop: Scalar,
    /// Fastest push out of a penetration [m/s].
    pub max_push: Scalar,
    /// The pair's friction, held at the centre of its points.
    pub friction: Friction,
}

impl Constraint {
    /// An unused lane: both ends the static slot, so it applies nothing.
    #[must_use]
    pub fn idle(static_slot: u32) -> Self {
        Self {
            slot: [static_slot; 2],
            normal: Vector::Y,
            tangents: [Vector::Z, Vector::X],
            inv_mass: [0.0; 2],
            mu: 0.0,
            restitution: 0.0,
            slop: 0.0,
            max_push: 0.0,
            friction: Friction::IDLE,
        }
    }
}

/// A pair's friction as one patch (rapier's "simplified" model, PhysX's patch friction): two
/// tangent rows at the centre of the manifold's points, coupled through their 2×2 effective
/// mass and held together within the Coulomb disc |j_t| ≤ μ Σ j_n, and one twist row about the
/// normal within μ Σ j_n·d (d: each point's distance from the centre). Three rows a pair
/// instead of two a point, and no point is favoured by being solved first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Friction {
    /// g = S (r × t) of the two tangents (outer index) at the centre, for A and B.
    pub g: [[Vector; 2]; 2],
    /// S n for A and B: the twist row's scaled axis.
    pub twist: [Vector; 2],
    /// The inverse of the tangent rows' 2×2 effective-mass matrix [kg]: (xx, xy, yy).
    pub mass: [Scalar; 3],
    /// Effective mass of the twist row [kg·m²].
    pub twist_mass: Scalar,
    /// Accumulated impulses of the current substep: the two tangents [N·s], the twist [N·m·s].
    pub impulse: [Scalar; 3],
}

impl Friction {
    /// No friction (zero effective masses).
    pub const IDLE: Self = Self {
        g: [[Vector::ZERO; 2]; 2],
        twist: [Vector::ZERO; 2],
        mass: [0.0; 3],
        twist_mass: 0.0,
        impulse: [0.0; 3],
    };
}

/// One manifold point: its normal row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactPoint {
    /// g = S (r × n) for A and B.
    pub g: [Vector; 2],
    /// Effective mass along the normal [kg] (0: an idle point).
    pub mass: Scalar,
    /// Its inverse K_ii [1/kg] (0 for an idle point).
    pub k: Scalar,
    /// Accumulated normal impulse of the current substep [N·s] (≥ 0).
    pub impulse: Scalar,
    /// Gap when the step began [m]: > 0 apart (speculative), < 0 penetrating.
    pub gap: Scalar,
    /// Relative normal speed when the step began [m/s] (< 0 approaching): what restitution
    /// reverses.
    pub approach: Scalar,
    /// Largest normal impulse at the end of any substep (after its relax sweep) [N·s]: > 0
    /// when the point touched.
    pub max_impulse: Scalar,
    /// Distance from the friction centre [m]: the point's lever against twisting.
    pub lever: Scalar,
    /// For the first point of a pair (0 of 0–1, 2 of 2–3), the off-diagonal K₀₁ of the pair's
    /// effective-mass matrix, m_a⁻¹ + m_b⁻¹ + g_a·g'_a + g_b·g'_b [1/kg]; else 0.
    pub coupling: Scalar,
    /// For the first point of a pair, 1 / det K of the pair held rigidly, K₀₀ K₁₁ − K₀₁², and
    /// with both rows soft, (K₀₀ + C₀)(K₁₁ + C₁) − K₀₁² [kg²]: what the block solve divides by
    /// (`Softness::compliance`); else 0.
    pub inv_det: [Scalar; 2],
}

impl ContactPoint {
    /// A point that applies nothing (zero effective mass).
    pub const IDLE: Self = Self {
        g: [Vector::ZERO; 2],
        mass: 0.0,
        k: 0.0,
        impulse: 0.0,
        gap: 0.0,
        approach: 0.0,
        max_impulse: 0.0,
        lever: 0.0,
        coupling: 0.0,
        inv_det: [0.0; 2],
    };
}

/// Places constraints, given in solving order by their solver-body slots, into batches of
/// `LANES` that share no free body: each goes to the first batch of its kind with room after
/// the last batch holding either of its bodies (the static slot, which nothing moves, is shared
/// freely). So any two constraints of one body keep their order, and the batched sweep equals
/// the sequential one whatever the kinds. A batch is as long as its longest manifold, so
/// `kinds` (each constraint's point count) keeps like manifolds together: a resting pile's
/// one- and two-point manifolds no longer wait through idle rows beside four-point ones. With
/// one kind this is plain first fit. Returns, in `out`, (batch, lane) per constraint; `fill`
/// ends holding each batch's count. `last` and `kind_of` are scratch (by slot, by batch).
pub fn place(
    (slots, kinds): (&[[u32; 2]], &[u8]),
    static_slot: u32,
    (last, kind_of): (&mut Vec<u32>, &mut Vec<u8>),
    fill: &mut Vec<u8>,
    out: &mut Vec<(u32, u8)>,
) {
    debug_assert_eq!(slots.len(), kinds.len());
    last.clear();
    last.resize(static_slot as usize + 1, 0);
    // At most one batch per constraint: sized once, so the loop pushes nothing.
    fill.clear();
    fill.resize(slots.len(), 0);
    out.clear();
    out.resize(slots.len(), (0, 0));
    // Each batch's kind while it has room, `FULL` after: one comparison finds a batch to take.
    const FULL: u8 = u8::MAX;
    let open = kind_of;
    open.clear();
    open.resize(slots.len(), FULL);
    let mut batches = 0;
    // Per kind, the first batch that may still take one of its constraints.
    let mut first_open = [0_usize; 256];
    for ((&[p, q], &kind), out) in slots.iter().zip(kinds).zip(out.iter_mut()) {
        let kind = kind.min(FULL - 1);
        // Batches are numbered from 1 in `last`, so 0 means "none yet"; the static slot's
        // stays 0 (it is shared freely).
        let after = last[p as usize].max(last[q as usize]) as usize;
        let first = &mut first_open[usize::from(kind)];
        while *first < batches && open[*first] != kind {
            *first += 1;
        }
        let mut j = after.max(*first);
        while j < batches && open[j] != kind {
            j += 1;
        }
        if j == batches {
            open[j] = kind;
            batches += 1;
        }
        *out = (j as u32, fill[j]);
        fill[j] += 1;
        if usize::from(fill[j]) == LANES {
            open[j] = FULL;
        }
        (last[p as usize], last[q as usize]) = (j as u32 + 1, j as u32 + 1);
        last[static_slot as usize] = 0;
    }
    fill.truncate(batches);
}

/// Places constraints like `place`, but each in the first batch with room that holds neither
/// of its free bodies, earlier than the last batch of either if there is one: for the
/// constraints across a split scene's cut, which form one chain bottom to top (each shares a
/// body with the one before), so `place` gives each its own batch and the other three lanes
/// idle; packed, they take about a quarter of the batches. Their order is still roughly lowest
/// first (a batch of four from about eight consecutive ones), and depends on the scene only.
pub fn place_packed(slots: &[[u32; 2]], static_slot: u32, fill: &mut Vec<u8>, out: &mut Vec<(u32, u8)>) {
    fill.clear();
    out.clear();
    // Each batch's free bodies (the static slot where a lane is empty or fixed).
    let mut held: Vec<[u32; 2 * LANES]> = Vec::new();
    let mut first_open = 0;
    for s in slots {
        while first_open < fill.len() && usize::from(fill[first_open]) == LANES {
            first_open += 1;
        }
        let free = |i: u32| i != static_slot;
        let clear = |j: usize| usize::from(fill[j]) < LANES && !held[j].iter().any(|&h| free(h) && s.contains(&h));
        let j = (first_open..fill.len()).find(|&j| clear(j)).unwrap_or(fill.len());
        if j == fill.len() {
            fill.push(0);
            held.push([static_slot; 2 * LANES]);
        }
        let lane = usize::from(fill[j]);
        (held[j][2 * lane], held[j][2 * lane + 1]) = (s[0], s[1]);
        out.push((j as u32, fill[j]));
        fill[j] += 1;
    }
}

/// Damping ratio of the soft contact (Box2D v3's and rapier's default): heavily overdamped, so
/// pushing a penetration out never overshoots into a bounce.
const CONTACT_DAMPING_RATIO: Scalar = 10.0;

/// Natural frequency of the contact spring as a fraction of the substep rate: a quarter,
/// Box2D v3's bound for a stable spring. Box2D's and rapier's softer default lets a tall stack
/// buckle: its contacts' bending stiffness falls short of its weight's toppling moment. A soft
/// contact also sinks under load by load / (effective mass · ω²), so the stiffest stable spring
/// sinks least. At this stiffness one solve sweep a substep leaves a tall pile bouncing, hence
/// `Params::iterations` sweeps in the early substeps.
const HERTZ_PER_SUBSTEP_RATE: Scalar = 0.25;

/// The soft-constraint coefficients of a contact (Catto, "Solver2D", 2024): a damped spring
/// written as a bias rate and mass/impulse scales.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Softness {
    bias_rate: Scalar,
    mass_scale: Scalar,
    impulse_scale: Scalar,
    /// `impulse_scale / mass_scale`: the row's compliance per unit of its K_ii.
    compliance: Scalar,
}

impl Softness {
    /// The contact spring for substep length `h` [s].
    #[must_use]
    pub fn new(h: Scalar) -> Self {
        let omega = 2.0 * std::f64::consts::PI * HERTZ_PER_SUBSTEP_RATE / h;
        let a1 = 2.0 * CONTACT_DAMPING_RATIO + h * omega;
        let a2 = h * omega * a1;
        let a3 = 1.0 / (1.0 + a2);
        Self { bias_rate: omega / a1, mass_scale: a2 * a3, impulse_scale: a3, compliance: 1.0 / a2 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placement_keeps_each_bodys_order_and_never_puts_one_body_twice_in_a_batch() {
        // Slot 9 is static. A chain 0-1, 1-2, 2-3 must go to three batches in order; 4-5 and the
        // ground contacts fill the lanes beside them.
        let slots = [[0, 1], [1, 2], [2, 3], [4, 5], [0, 9], [9, 6], [9, 7], [9, 8], [6, 7]];
        let (mut last, mut kinds, mut fill, mut out) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        place((&slots, &[4; 9]), 9, (&mut last, &mut kinds), &mut fill, &mut out);
        assert_eq!(out, [(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (0, 2), (0, 3), (1, 2), (1, 3)]);
        assert_eq!(fill, [4, 4, 1]);
        for (i, si) in slots.iter().enumerate() {
            for (j, sj) in slots.iter().enumerate().skip(i + 1) {
                let shared = si.iter().any(|x| *x != 9 && sj.contains(x));
                if shared {
                    assert!(out[i].0 < out[j].0, "{si:?} before {sj:?}");
                }
            }
        }
    }

    #[test]
    fn placement_by_kind_keeps_like_with_like_and_each_bodys_order() {
        // Ground contacts of one and four points alternate: each kind fills its own batch.
        let slots = [[0, 9], [1, 9], [2, 9], [3, 9], [4, 9], [5, 9]];
        let (mut last, mut kind_of, mut fill, mut out) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        place((&slots, &[1, 4, 1, 4, 1, 4]), 9, (&mut last, &mut kind_of), &mut fill, &mut out);
        assert_eq!(out, [(0, 0), (1, 0), (0, 1), (1, 1), (0, 2), (1, 2)]);
        assert_eq!(fill, [3, 3]);
        // Random piles: one kind a batch, no body twice in a batch, each body's order kept.
        let mut rng = crate::rng::SplitMix64::new(3);
        for _ in 0..200 {
            let n = 1 + (rng.uniform(0.0, 60.0) as usize);
            let body = |rng: &mut crate::rng::SplitMix64| (rng.uniform(0.0, 13.0) as u32).min(12);
            let slots: Vec<[u32; 2]> =
                (0..n).map(|_| [body(&mut rng), body(&mut rng)]).filter(|s| s[0] != s[1]).collect();
            let kinds: Vec<u8> = slots.iter().map(|_| 1 + rng.uniform(0.0, 4.0) as u8).collect();
            place((&slots, &kinds), 12, (&mut last, &mut kind_of), &mut fill, &mut out);
            let mut kind_of_batch = vec![None; fill.len()];
            for (k, &(batch, _)) in out.iter().enumerate() {
                let b = &mut kind_of_batch[batch as usize];
                assert!(b.is_none_or(|x| x == kinds[k]), "batch {batch} mixes kinds");
                *b = Some(kinds[k]);
            }
            for (i, si) in slots.iter().enumerate() {
                for (j, sj) in slots.iter().enumerate().skip(i + 1) {
                    if si.iter().any(|x| *x != 12 && sj.contains(x)) {
                        assert!(out[i].0 < out[j].0, "{si:?} before {sj:?}");
                    }
                }
            }
            let counted: Vec<u8> =
                (0..fill.len()).map(|b| out.iter().filter(|o| o.0 as usize == b).count() as u8).collect();
            assert_eq!(counted, fill);
        }
    }

    #[test]
    fn packed_placement_fills_a_chains_lanes_and_never_puts_one_body_twice_in_a_batch() {
        // Slot 9 is static. A chain 0-1, 1-2, ..., 7-8 takes eight batches in `place`; packed,
        // every other link shares a batch: two batches of four, then the last link.
        let slots = [[0, 1], [1, 2], [2, 3], [3, 4], [4, 5], [5, 6], [6, 7], [7, 8], [8, 9], [9, 0]];
        let (mut fill, mut out) = (Vec::new(), Vec::new());
        place_packed(&slots, 9, &mut fill, &mut out);
        assert_eq!(fill, [4, 4, 2]);
        assert_eq!(out[..4], [(0, 0), (1, 0), (0, 1), (1, 1)]);
        for (i, si) in slots.iter().enumerate() {
            for (j, sj) in slots.iter().enumerate().skip(i + 1) {
                let shared = si.iter().any(|x| *x != 9 && sj.contains(x));
                assert!(!(shared && out[i].0 == out[j].0), "{si:?} and {sj:?} share batch {}", out[i].0);
            }
        }
    }

    #[test]
    fn the_two_sides_are_numbered_as_one_array() {
        let (mut left, mut right) = ([SolverBody::default(); 3], [SolverBody::default(); 2]);
        right[0].v = Vector::Y;
        let mut sides = Sides { left: &mut left, right: &mut right };
        assert_eq!(sides.body(3).v, Vector::Y, "slot 3 is the second side's first body");
        sides.body_mut(1).v = Vector::X;
        assert_eq!(sides.left[1].v, Vector::X);
        let statics: Vec<u32> = (0..5).filter(|&k| sides.is_static(k)).collect();
        assert_eq!(statics, [2, 4], "each side ends with its static slot");
        let moving: Vec<u32> = (0..5).filter(|&k| sides.moving_mut(k).is_some()).collect();
        assert_eq!(moving, [0, 1, 3], "only the moving slots can be written");
        sides.moving_mut(3).unwrap().w = Vector::Z;
        assert_eq!(sides.right[0].w, Vector::Z);
    }

    #[test]
    fn an_idle_lane_leaves_the_bodies_alone() {
        let mut bodies = [SolverBody { v: Vector::X, ..SolverBody::default() }, SolverBody::default()];
        let mut batch = Batch::idle(1);
        batch.set(0, &Constraint { slot: [0, 1], inv_mass: [1.0, 0.0], ..Constraint::idle(1) });
        batch.len = 1;
        let mut points = vec![PointRows::default()];
        let mut batches = [batch];
        let store: &mut [SolverBody] = &mut bodies;
        sweep(store, &mut batches, &mut points, 1.0 / 240.0, Some(Softness::new(1.0 / 240.0)), true);
        sweep(store, &mut batches, &mut points, 1.0 / 240.0, None, false);
        warm_start(store, &batches, &mut points);
        assert_eq!(bodies[0].v, Vector::X);
        assert_eq!(bodies[1], SolverBody::default(), "the static slot stays zero");
    }
}
