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

use crate::contact::{Contact, Feature, Pair, PairState};
use crate::geometry::Posed;
use crate::manifold::{Manifold, manifold, near_normal};
use crate::math::{Mat3, Scalar, Vector};
use crate::step::{CachedManifold, CachedPoint, SolverRow, StepContext};
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
    let resting = |p: &Pair| params.resting_contacts(dt, 0.5 * (b.friction[p.a as usize] + b.friction[p.b as usize]));
    let s = &mut ctx.scratch.solve;
    s.step = ctx.step;
    s.pairs.clear();
    s.pairs.extend(ctx.pairs.iter().filter(|p| (p.contact().is_some() || p.is_candidate()) && resting(p)).copied());
    if s.pairs.is_empty() {
        s.cache.clear();
        return;
    }
    ctx.pose_contacts();
    ctx.pose_candidates();
    let s = &mut ctx.scratch.solve;
    let (posed, meshes, b) = (&ctx.posed, &ctx.meshes, &ctx.bodies);
    let margin = ctx.params.contact_margin;
    s.manifolds.resize(s.pairs.len(), Manifold::default());
    s.near.clear();
    s.near.extend(s.pairs.iter().map(Pair::is_candidate));
    s.pairs.par_iter_mut().zip(s.manifolds.par_iter_mut()).for_each_init(Vec::new, |scratch, (pair, m)| {
        let (pa, pb) = (posed.get(pair.a), posed.get(pair.b));
        let thin = meshes.get(b.mesh[pair.a as usize]).thickness.min(meshes.get(b.mesh[pair.b as usize]).thickness);
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
        let mu = 0.5 * (b.friction[ia] + b.friction[ib]);
        let cached = s.cache.get(&(pair.a, pair.b));
        for (&p, &gap) in m.points().iter().zip(&m.gaps) {
            let (r_a, r_b) = (p - b.position[ia], p - b.position[ib]);
            let k = |d: Vector| {
                effective_mass(
                    b.inv_mass[ia] + b.inv_mass[ib],
                    &b.inv_inertia_world[ia],
                    r_a,
                    &b.inv_inertia_world[ib],
                    r_b,
                    d,
                )
            };
            let local = b.rotation[ia].transpose() * r_a;
            let reach = MATCH_DISTANCE * b.radius[ia];
            let old = cached.and_then(|c| c.points().iter().find(|q| (q.local - local).length() <= reach));
            let (jn, jt) = old.map_or((0.0, Vector::ZERO), |q| (q.normal, q.tangent));
            s.rows.push(SolverRow {
                a: pair.a,
                b: pair.b,
                feature: (!near).then_some(contact.feature),
                r_a,
                r_b,
                local,
                n,
                t1,
                t2,
                k_n: k(n),
                k_t1: k(t1),
                k_t2: k(t2),
                mu,
                gap,
                jn,
                jt1: jt.dot(t1),
                jt2: jt.dot(t2),
            });
        }
    }
}

/// `1 / (1/m_a + 1/m_b + (r_a×d)·I_a⁻¹(r_a×d) + (r_b×d)·I_b⁻¹(r_b×d))`, the mass the impulse
/// along `d` sees at the point (PHYSICS.md §2.5's K, inverted).
fn effective_mass(inv_m: Scalar, ia: &Mat3, r_a: Vector, ib: &Mat3, r_b: Vector, d: Vector) -> Scalar {
    let (ka, kb) = (r_a.cross(d), r_b.cross(d));
    let k = inv_m + ka.dot(*ia * ka) + kb.dot(*ib * kb);
    if k > 0.0 { 1.0 / k } else { 0.0 }
}

/// Two unit vectors completing `n` to a right-handed orthonormal basis.
fn tangents(n: Vector) -> (Vector, Vector) {
    let helper = if n.x.abs() < 0.57 { Vector::X } else { Vector::Y };
    let t1 = n.cross(helper).normalize();
    (t1, n.cross(t1))
}

/// Applies impulse `p` at the row's point: +p on A, −p on B.
fn apply(ctx: &mut StepContext, row: &SolverRow, p: Vector) {
    let b = &mut ctx.bodies;
    let (ia, ib) = (row.a as usize, row.b as usize);
    b.velocity[ia] += p * b.inv_mass[ia];
    b.angular_velocity[ia] += b.inv_inertia_world[ia] * row.r_a.cross(p);
    b.velocity[ib] -= p * b.inv_mass[ib];
    b.angular_velocity[ib] -= b.inv_inertia_world[ib] * row.r_b.cross(p);
}

fn relative_velocity(ctx: &StepContext, row: &SolverRow) -> Vector {
    let b = &ctx.bodies;
    let (ia, ib) = (row.a as usize, row.b as usize);
    (b.velocity[ia] + b.angular_velocity[ia].cross(row.r_a)) - (b.velocity[ib] + b.angular_velocity[ib].cross(row.r_b))
}

/// Re-applies last step's impulses: a resting stack starts near its solution.
fn warm_start(ctx: &mut StepContext) {
    let rows = std::mem::take(&mut ctx.scratch.solve.rows);
    for row in &rows {
        apply(ctx, row, row.n * row.jn + row.t1 * row.jt1 + row.t2 * row.jt2);
    }
    ctx.scratch.solve.rows = rows;
}

/// One Gauss–Seidel sweep, forwards or backwards through the rows (alternating, so the weight
/// of a stack travels down as fast as the support travels up): friction at every point first (within the Coulomb cone of the
/// current normal impulse), then the normal impulses that stop approach (accumulated, never
/// pulling). Normal rows last, as in Box2D: non-penetration matters more than friction, so it
/// gets the final word in each sweep.
fn iterate(ctx: &mut StepContext, backwards: bool) {
    let dt = ctx.dt;
    let mut rows = std::mem::take(&mut ctx.scratch.solve.rows);
    if backwards {
        rows.reverse();
    }
    for row in rows.iter_mut().filter(|r| r.mu > 0.0) {
        let u = relative_velocity(ctx, row);
        let (mut j1, mut j2) = (row.jt1 - u.dot(row.t1) * row.k_t1, row.jt2 - u.dot(row.t2) * row.k_t2);
        let limit = row.mu * row.jn;
        let len = (j1 * j1 + j2 * j2).sqrt();
        if len > limit {
            (j1, j2) = (j1 * limit / len, j2 * limit / len);
        }
        let p = row.t1 * (j1 - row.jt1) + row.t2 * (j2 - row.jt2);
        (row.jt1, row.jt2) = (j1, j2);
        apply(ctx, row, p);
    }
    for row in &mut rows {
        // Speculative points may approach by their gap this step: u_n ≥ −gap/dt.
        let u_n = relative_velocity(ctx, row).dot(row.n) + row.gap.max(0.0) / dt;
        let jn = (row.jn - u_n * row.k_n).max(0.0);
        let dn = jn - row.jn;
        row.jn = jn;
        apply(ctx, row, row.n * dn);
    }
    if backwards {
        rows.reverse();
    }
    ctx.scratch.solve.rows = rows;
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
            entry.points[entry.len] =
                CachedPoint { local: row.local, normal: row.jn, tangent: row.t1 * row.jt1 + row.t2 * row.jt2 };
            entry.len += 1;
        }
        if let Some(feature) = row.feature
            && row.jn > 0.0
            && held != Some((row.a, row.b))
        {
            held = Some((row.a, row.b));
            ctx.stats.impulses[feature as usize] += 1;
        }
    }
}
