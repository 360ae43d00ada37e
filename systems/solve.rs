//! `solve`: resting contact and friction, the paper's "future work". Sequential impulses over
//! contact manifolds (up to four points a pair), with accumulated normal impulses clamped at
//! zero and Coulomb friction clamped to the cone |j_t| ≤ μ j_n, warm-started from the previous
//! step's impulses (Catto, "Iterative Dynamics with Temporal Coherence", 2005).
//!
//! It takes the contacts `resolve` leaves: under gravity every contact (impacts were bounced
//! there, resting ones are held here with no bounce), and contacts with friction. Without
//! gravity and friction it does nothing, so the paper's frictionless results are unchanged.
//! Penetration is left to `correct`, which removes it with split impulses on these same rows:
//! positions move, velocities do not, so no energy is added.

use crate::bodies::Bodies;
use crate::contact::{Contact, Feature, Pair, PairState};
use crate::geometry::Posed;
use crate::manifold::{Manifold, manifold, near_normal};
use crate::math::{Scalar, Vector};
use crate::step::{CachedManifold, CachedPoint, RowAxis, SolverRow, StepContext};
use hecs::World;
use rayon::prelude::*;

/// A cached point matches a new one within this distance in A's body frame [fraction of A's
/// radius]: the same corner one step later.
const MATCH_DISTANCE: Scalar = 0.05;

/// Holds resting contacts and applies friction (see the module docs).
///
/// - Reads: `ctx.pairs` (`Found`, `Resolved`), `ctx.posed`, `ctx.bodies`, `ctx.scratch.solve`.
/// - Writes: `ctx.bodies` velocities (and the world's), `ctx.stats.impulses` (one per pair
///   held), the warm-start cache.
/// - Paper: none (resting contact and friction are the paper's future work).
/// - Cost: O(P) to build P points, O(P · iterations) to solve.
pub fn solve(world: &mut World, ctx: &mut StepContext) {
    let (b, params, dt) = (&ctx.bodies, &ctx.params, ctx.dt);
    let resting = |p: &Pair| params.resting_contacts(dt, b.pair_friction(p.a as usize, p.b as usize));
    let s = &mut ctx.scratch.solve;
    s.step = ctx.step;
    s.pairs.clear();
    s.pairs.extend(ctx.pairs.iter().filter(|p| (p.contact().is_some() || p.is_candidate()) && resting(p)).copied());
    if s.pairs.is_empty() {
        s.cache.clear();
        return;
    }
    ctx.pose_pairs(|p| p.contact().is_some() || p.is_candidate());
    let s = &mut ctx.scratch.solve;
    let (posed, meshes, b) = (&ctx.posed, &ctx.meshes, &ctx.bodies);
    let margin = ctx.params.contact_margin;
    s.manifolds.resize(s.pairs.len(), Manifold::default());
    s.near.clear();
    s.near.extend(s.pairs.iter().map(Pair::is_candidate));
    s.pairs.par_iter_mut().zip(s.manifolds.par_iter_mut()).for_each_init(Vec::new, |scratch, (pair, m)| {
        let (pa, pb) = (posed.get(pair.a), posed.get(pair.b));
        let thin = b.thinner(meshes, pair.a as usize, pair.b as usize);
        // A pair the tests passed over may still be resting a hair apart: hold it speculatively
        // along the face normal that separates it (a touching pair's contact is the tests').
        let near = pair.is_candidate();
        if near {
            let Some((normal, _)) = near_normal(pa, pb, margin * thin) else {
                m.len = 0;
                return;
            };
            pair.state = PairState::Resolved(near_contact(pa, pb, normal));
        }
        let contact = pair.contact().expect("a contact by now");
        *m = manifold(pa, pb, contact.normal, margin * thin, scratch);
        if m.len == 0 && !near {
            // No vertex in or near the other body (an edge crossing an edge): hold the contact
            // the tests found, at its depth. A near pair without such vertices is not held.
            (m.points[0], m.gaps[0], m.len) = (contact.point, -contact.depth, 1);
        }
    });
    build_rows(ctx);
    warm_start(ctx);
    for k in 0..ctx.params.iterations {
        iterate(ctx, k % 2 == 1);
    }
    remember(ctx);
    ctx.bodies.store(world);
}

/// The contact of a near pair: its normal is what matters (the manifold's vertices are its
/// points); the point is halfway between the centres and is never used as a manifold point.
fn near_contact(a: &Posed, b: &Posed, normal: Vector) -> Contact {
    let point = 0.5 * (a.position + b.position);
    Contact { point, normal, depth: 0.0, feature: Feature::Face }
}

/// One row per manifold point: lever arms, tangent basis, effective masses, and the impulses
/// of the matching point of the previous step.
fn build_rows(ctx: &mut StepContext) {
    let b = &ctx.bodies;
    let s = &mut ctx.scratch.solve;
    s.rows.clear();
    for ((pair, m), &near) in s.pairs.iter().zip(&s.manifolds).zip(&s.near) {
        let (ia, ib) = (pair.a as usize, pair.b as usize);
        let Some(contact) = pair.contact() else { continue }; // a candidate found not near
        let n = contact.normal;
        let (t1, t2) = tangents(n);
        let mu = b.pair_friction(ia, ib);
        let inv_mass = [b.inv_mass[ia], b.inv_mass[ib]];
        let inv_inertia = [&b.inv_inertia_world[ia], &b.inv_inertia_world[ib]];
        let cached = s.cache.get(&(pair.a, pair.b));
        for (&p, &gap) in m.points().iter().zip(&m.gaps) {
            let r = [p - b.position[ia], p - b.position[ib]];
            let axis = |dir: Vector| {
                let arm = [r[0].cross(dir), r[1].cross(dir)];
                let spin = [*inv_inertia[0] * arm[0], *inv_inertia[1] * arm[1]];
                let k = inv_mass[0] + inv_mass[1] + arm[0].dot(spin[0]) + arm[1].dot(spin[1]);
                RowAxis { dir, arm, spin, mass: if k > 0.0 { 1.0 / k } else { 0.0 } }
            };
            let local = b.rotation[ia].transpose() * r[0];
            let reach = MATCH_DISTANCE * b.radius[ia];
            let old = cached.and_then(|c| c.points().iter().find(|q| (q.local - local).length() <= reach));
            let (jn, jt) = old.map_or((0.0, Vector::ZERO), |q| (q.normal, q.tangent));
            s.rows.push(SolverRow {
                a: pair.a,
                b: pair.b,
                feature: (!near).then_some(contact.feature),
                inv_mass,
                local,
                axes: [axis(n), axis(t1), axis(t2)],
                mu,
                gap,
                impulse: [jn, jt.dot(t1), jt.dot(t2)],
            });
        }
    }
}

/// Two unit vectors completing `n` to a right-handed orthonormal basis.
fn tangents(n: Vector) -> (Vector, Vector) {
    let helper = if n.x.abs() < 0.57 { Vector::X } else { Vector::Y };
    let t1 = n.cross(helper).normalize();
    (t1, n.cross(t1))
}

/// Relative speed of A against B along `axis` at the row's point.
#[inline]
fn speed(b: &Bodies, row: &SolverRow, axis: &RowAxis) -> Scalar {
    let (ia, ib) = (row.a as usize, row.b as usize);
    (b.velocity[ia] - b.velocity[ib]).dot(axis.dir) + b.angular_velocity[ia].dot(axis.arm[0])
        - b.angular_velocity[ib].dot(axis.arm[1])
}

/// Applies an impulse of `j` along `axis` at the row's point: +j on A, −j on B.
#[inline]
fn push(b: &mut Bodies, row: &SolverRow, axis: &RowAxis, j: Scalar) {
    let (ia, ib) = (row.a as usize, row.b as usize);
    b.velocity[ia] += axis.dir * (j * row.inv_mass[0]);
    b.angular_velocity[ia] += axis.spin[0] * j;
    b.velocity[ib] -= axis.dir * (j * row.inv_mass[1]);
    b.angular_velocity[ib] -= axis.spin[1] * j;
}

/// Re-applies last step's impulses: a resting stack starts near its solution.
fn warm_start(ctx: &mut StepContext) {
    let b = &mut ctx.bodies;
    for row in &ctx.scratch.solve.rows {
        for (axis, &j) in row.axes.iter().zip(&row.impulse) {
            push(b, row, axis, j);
        }
    }
}

/// One Gauss–Seidel sweep, forwards or backwards through the rows (alternating, so the weight
/// of a stack travels down as fast as the support travels up): friction at every point first
/// (within the Coulomb cone of the current normal impulse), then the normal impulses that stop
/// approach (accumulated, never pulling). Normal rows last, as in Box2D: non-penetration
/// matters more than friction, so it gets the final word in each sweep.
fn iterate(ctx: &mut StepContext, backwards: bool) {
    let (b, rows, dt) = (&mut ctx.bodies, &mut ctx.scratch.solve.rows, ctx.dt);
    if backwards {
        rows.reverse();
    }
    for row in rows.iter_mut().filter(|r| r.mu > 0.0) {
        let [_, t1, t2] = row.axes;
        let (mut j1, mut j2) =
            (row.impulse[1] - speed(b, row, &t1) * t1.mass, row.impulse[2] - speed(b, row, &t2) * t2.mass);
        let limit = row.mu * row.impulse[0];
        let len = (j1 * j1 + j2 * j2).sqrt();
        if len > limit {
            (j1, j2) = (j1 * limit / len, j2 * limit / len);
        }
        push(b, row, &t1, j1 - row.impulse[1]);
        push(b, row, &t2, j2 - row.impulse[2]);
        (row.impulse[1], row.impulse[2]) = (j1, j2);
    }
    for row in rows.iter_mut() {
        let n = row.axes[0];
        // Speculative points may approach by their gap this step: u_n ≥ −gap/dt.
        let u_n = speed(b, row, &n) + row.gap.max(0.0) / dt;
        let jn = (row.impulse[0] - u_n * n.mass).max(0.0);
        push(b, row, &n, jn - row.impulse[0]);
        row.impulse[0] = jn;
    }
    if backwards {
        rows.reverse();
    }
}

/// Keeps this step's impulses for the next step's warm start, and counts one impulse per pair
/// held (by the feature that found its contact; near pairs no test found are not counted).
fn remember(ctx: &mut StepContext) {
    let s = &mut ctx.scratch.solve;
    s.cache.clear();
    let mut held: Option<(u32, u32)> = None;
    for row in &s.rows {
        let entry: &mut CachedManifold = s.cache.entry((row.a, row.b)).or_default();
        if entry.len < entry.points.len() {
            let [jn, j1, j2] = row.impulse;
            let tangent = row.axes[1].dir * j1 + row.axes[2].dir * j2;
            entry.points[entry.len] = CachedPoint { local: row.local, normal: jn, tangent };
            entry.len += 1;
        }
        if let Some(feature) = row.feature
            && row.impulse[0] > 0.0
            && held != Some((row.a, row.b))
        {
            held = Some((row.a, row.b));
            ctx.stats.impulses[feature as usize] += 1;
        }
    }
}
