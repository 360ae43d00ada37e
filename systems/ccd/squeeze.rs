//! The end of a squeeze (docs/physics.md §6.7): a body that used up its impacts in a step, a
//! light one between a wall and a heavy body closing on it, would bounce on without end. Its
//! contacts with every body it could still reach in the step take their impulses together,
//! frictionless and exact, with the pairs' restitution where that makes no energy; it flies
//! on, unswept, approaching none of them.

use super::{CcdScratch, FAST_FRACTION, IMPACT_GAP, fly, path};
use crate::collision::contact::Contact;
use crate::collision::manifold::contact_axis;
use crate::collision::posed::Posed;
use crate::collision::toi::impact_contact;
use crate::math::{Scalar, Vector};
use crate::model::components::Pose;
use crate::sim::context::StepContext;
use crate::systems::{BodyState, state};

/// Most contacts a squeeze is solved over, the nearest: the exact solution tries each set of
/// them that may push (2⁶ at most).
const SQUEEZE_CONTACTS: usize = 6;

/// A squeezed body's contact with partner `j`: the normal points from `j` into the body.
struct Touch {
    j: usize,
    contact: Contact,
}

/// Ends the squeeze of free body `i`, which used up its impacts at time `t`: its contacts with
/// the bodies it could reach in the rest of the step get the impulses, equal and opposite,
/// that leave none of them approaching and none pulling (Signorini, solved exactly), then the
/// pairs' restitution on top (`restituted`), so an elastic gas keeps its energy and a heavy
/// body closing on a wall through a light one bounces back, as e = 1 has it. Only when one of
/// them closes fast: a slow one is the discrete tests'. Returns the partners it moved, flown
/// to `t`.
pub(super) fn squeeze(ctx: &mut StepContext, s: &mut CcdScratch, i: usize, t: Scalar) -> Vec<usize> {
    let touches = touches(ctx, s, i, t);
    // A contact closing slower than a fast pair (a resting pair that met eight times) is the
    // discrete tests' to answer, as it would be without `ccd`.
    let b = &ctx.bodies;
    let fast = |k: &Touch| {
        -separating(&state(b, i), &state(b, k.j), &k.contact) * ctx.dt > FAST_FRACTION * b.thinner(&ctx.meshes, i, k.j)
    };
    if !touches.iter().any(fast) {
        return Vec::new();
    }
    for k in &touches {
        fly(ctx, s, k.j, t);
    }
    let b = &ctx.bodies;
    let (mut me, mut others): (BodyState, Vec<BodyState>) =
        (state(b, i), touches.iter().map(|k| state(b, k.j)).collect());
    let w0: Vec<Scalar> = touches.iter().zip(&others).map(|(k, o)| separating(&me, o, &k.contact)).collect();
    let a = response(&me, &others, &touches);
    let p = complementary(&a, &w0).unwrap_or_default();
    let e: Vec<Scalar> = touches.iter().map(|k| 0.5 * (b.restitution[i] + b.restitution[k.j])).collect();
    let p = restituted(&a, &w0, p, &e);
    for ((k, o), p) in touches.iter().zip(&mut others).zip(p).filter(|(_, p)| *p > 0.0) {
        me.apply_impulse(k.contact.point, p * k.contact.normal);
        o.apply_impulse(k.contact.point, -p * k.contact.normal);
        ctx.stats.count_impulse(k.contact.feature);
    }
    let b = &mut ctx.bodies;
    for (i, st) in std::iter::once((i, me)).chain(touches.iter().map(|k| k.j).zip(others)) {
        (b.velocity[i], b.angular_velocity[i]) = (st.velocity, st.angular_velocity);
    }
    touches.iter().map(|k| k.j).collect()
}

/// Body `i`'s contacts at time `t` with its swept partners within reach: apart by at most the
/// impact gap plus what the two can travel in the rest of the step; the nearest first.
fn touches(ctx: &StepContext, s: &mut CcdScratch, i: usize, t: Scalar) -> Vec<Touch> {
    let (b, dt) = (&ctx.bodies, ctx.dt);
    // A body flown to `t` stands where it is (its path would round its pose afresh).
    let posed = |k: usize| {
        let pose = if s.flown[k] && t <= s.taken[k] {
            Pose { position: b.position[k], orientation: b.orientation[k] }
        } else {
            path(b, s, dt, k).at(t)
        };
        Posed::new(ctx.meshes.get_arc(b.mesh[k]), &pose)
    };
    let speed = |k: usize| b.velocity[k].length() + b.angular_velocity[k].length() * b.radius[k];
    let me = posed(i);
    let partners = s.pairs.iter().filter(|p| p.a as usize == i || p.b as usize == i);
    let mut near: Vec<(Scalar, usize, Posed)> = partners
        .filter_map(|p| {
            let j = (p.a + p.b) as usize - i;
            let other = posed(j);
            let apart = contact_axis(&me, &other, (0.0, Scalar::INFINITY))?.separation;
            let reach = IMPACT_GAP * b.thinner(&ctx.meshes, i, j) + (speed(i) + speed(j)) * (dt - t);
            (apart <= reach).then_some((apart, j, other))
        })
        .collect();
    near.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    near.truncate(SQUEEZE_CONTACTS);
    near.into_iter()
        .filter_map(|(_, j, other)| Some(Touch { j, contact: impact_contact(&me, &other, &mut s.clip)? }))
        .collect()
}

/// How fast the body leaves partner `o` at the contact, `u_n` [m/s] (negative: approaching).
fn separating(me: &BodyState, o: &BodyState, c: &Contact) -> Scalar {
    (me.point_velocity(c.point) - o.point_velocity(c.point)).dot(c.normal)
}

/// Rounds of restitution a squeeze's end takes at most (`restituted`); the last is inelastic.
const RESTITUTION_ROUNDS: usize = 16;

/// The pairs' restitution on top of the inelastic impulses `p` (parting speeds `w0` before,
/// responses `a`, restitutions `e`), Poisson's way: each contact takes (1 + e) times the
/// inelastic impulse; where that leaves a contact approaching, the inelastic impulses from
/// there, again with restitution, round after round, the last inelastic. With one restitution
/// for all contacts no round makes energy (e = 1 keeps it exactly, docs/physics.md §6.7); the
/// result is kept only if it makes none, else `p` is.
fn restituted(a: &[Vec<Scalar>], w0: &[Scalar], p: Vec<Scalar>, e: &[Scalar]) -> Vec<Scalar> {
    let n = p.len();
    let (mut total, mut round, mut settled) = (vec![0.0; n], p.clone(), false);
    for r in 1..=RESTITUTION_ROUNDS {
        let bounce = |k: usize| if r < RESTITUTION_ROUNDS { 1.0 + e[k] } else { 1.0 };
        (0..n).for_each(|k| total[k] += bounce(k) * round[k]);
        // The inelastic impulses from here: none when no contact approaches.
        match complementary(a, &parting(a, w0, &total)) {
            Some(q) if q.iter().all(|&q| q == 0.0) => {
                settled = true;
                break;
            }
            Some(q) => round = q,
            None => break,
        }
    }
    let gain = energy_given(&total, w0, &parting(a, w0, &total));
    let scale: Scalar = (0..n).map(|k| (total[k] * w0[k]).abs()).sum();
    if settled && gain <= 1e-12 * scale { total } else { p }
}

/// The parting speeds `w = A p + w0` after impulses `p`.
fn parting(a: &[Vec<Scalar>], w0: &[Scalar], p: &[Scalar]) -> Vec<Scalar> {
    (0..w0.len()).map(|k| w0[k] + (0..p.len()).map(|l| a[k][l] * p[l]).sum::<Scalar>()).collect()
}

/// The energy impulses `p` give, p·(w0 + w)/2, `w` the parting speeds after them.
fn energy_given(p: &[Scalar], w0: &[Scalar], w: &[Scalar]) -> Scalar {
    (0..p.len()).map(|k| p[k] * (w0[k] + w[k])).sum::<Scalar>() / 2.0
}

/// `A[k][l]`: how much a unit impulse at contact l speeds up the parting at contact k.
fn response(me: &BodyState, others: &[BodyState], touches: &[Touch]) -> Vec<Vec<Scalar>> {
    let still = |s: &BodyState| BodyState { velocity: Vector::ZERO, angular_velocity: Vector::ZERO, ..*s };
    let mut a = vec![vec![0.0; touches.len()]; touches.len()];
    for (l, tl) in touches.iter().enumerate() {
        let (mut m, mut o) = (still(me), still(&others[l]));
        m.apply_impulse(tl.contact.point, tl.contact.normal);
        o.apply_impulse(tl.contact.point, -tl.contact.normal);
        for (k, tk) in touches.iter().enumerate() {
            let other = if k == l { o } else { still(&others[k]) };
            a[k][l] = separating(&m, &other, &tk.contact);
        }
    }
    a
}

/// The contact impulses `p ≥ 0` with partings `w = A p + w0 ≥ 0` and `p·w = 0`: each set of
/// pushing contacts in turn (none first), its equations solved, until one fits. `None` when
/// none does within round-off.
fn complementary(a: &[Vec<Scalar>], w0: &[Scalar]) -> Option<Vec<Scalar>> {
    let n = w0.len();
    let slack = 1e-9 * w0.iter().fold(0.0, |m: Scalar, w| m.max(w.abs()));
    (0..1u32 << n).find_map(|set| {
        let on: Vec<usize> = (0..n).filter(|&k| (set >> k) & 1 == 1).collect();
        let rows = on.iter().map(|&k| on.iter().map(|&l| a[k][l]).collect()).collect();
        let pushed = gauss(rows, on.iter().map(|&k| -w0[k]).collect())?;
        let mut p = vec![0.0; n];
        for (&k, &pk) in on.iter().zip(&pushed) {
            p[k] = pk;
        }
        let parts = || {
            let w = parting(a, w0, &p);
            (0..n).filter(|k| !on.contains(k)).all(|k| w[k] >= -slack)
        };
        (pushed.iter().all(|&pk| pk >= 0.0) && parts()).then_some(p)
    })
}

/// Solves `m x = r` by Gaussian elimination with partial pivoting; `None` when singular.
fn gauss(mut m: Vec<Vec<Scalar>>, mut r: Vec<Scalar>) -> Option<Vec<Scalar>> {
    let n = r.len();
    let scale = (0..n).map(|k| m[k][k].abs()).fold(0.0, Scalar::max);
    for c in 0..n {
        let pivot = (c..n).max_by(|&x, &y| m[x][c].abs().total_cmp(&m[y][c].abs()))?;
        if m[pivot][c].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(c, pivot);
        r.swap(c, pivot);
        let (done, below) = m.split_at_mut(c + 1);
        for (k, row) in below.iter_mut().enumerate() {
            let f = row[c] / done[c][c];
            for (x, y) in row[c..].iter_mut().zip(&done[c][c..]) {
                *x -= f * y;
            }
            r[c + 1 + k] -= f * r[c];
        }
    }
    let mut x = vec![0.0; n];
    for c in (0..n).rev() {
        x[c] = (r[c] - (c + 1..n).map(|k| m[c][k] * x[k]).sum::<Scalar>()) / m[c][c];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 g cube at 100 m/s towards a wall (contact 0) with a 1 kg cube behind it closing at 10
    /// m/s (contact 1), along x: both stop, the wall taking both momenta.
    #[test]
    fn a_light_cube_between_a_wall_and_a_heavy_one_stops_both() {
        let (m, big) = (0.01, 1.0);
        let a = [vec![1.0 / m, -1.0 / m], vec![-1.0 / m, 1.0 / m + 1.0 / big]];
        let p = complementary(&a, &[-100.0, 90.0]).expect("a solution");
        assert!((p[0] - 11.0).abs() < 1e-12 && (p[1] - 10.0).abs() < 1e-12, "{p:?}");
        assert_eq!(complementary(&a, &[1.0, 90.0]), Some(vec![0.0, 0.0]), "all parting: no impulse");
    }

    #[test]
    fn a_cube_between_two_walls_is_stopped_by_the_one_it_meets() {
        // The two contacts' equations are one (singular): the wall it approaches stops it.
        let a = [vec![100.0, -100.0], vec![-100.0, 100.0]];
        let p = complementary(&a, &[-100.0, 100.0]).expect("a solution");
        assert_eq!(p, vec![1.0, 0.0]);
    }

    /// The parting speeds after impulses `p` and the energy they gave.
    fn after(a: &[Vec<Scalar>], w0: &[Scalar], p: &[Scalar]) -> (Vec<Scalar>, Scalar) {
        let w = parting(a, w0, p);
        let gain = energy_given(p, w0, &w);
        (w, gain)
    }

    #[test]
    fn one_contact_parts_at_e_times_its_approach() {
        for e in [0.0, 0.5, 1.0] {
            let p = restituted(&[vec![2.0]], &[-3.0], vec![1.5], &[e]);
            assert_eq!(after(&[vec![2.0]], &[-3.0], &p).0, vec![3.0 * e], "e = {e}");
        }
    }

    /// The cubes of the first test with e = 1: no contact approaches after, and the energy of
    /// the approach (50 J of the light cube's, 50 J of the heavy one's) is all kept.
    #[test]
    fn an_elastic_squeeze_keeps_its_energy_and_leaves_no_contact_approaching() {
        let (m, big) = (0.01, 1.0);
        let a = [vec![1.0 / m, -1.0 / m], vec![-1.0 / m, 1.0 / m + 1.0 / big]];
        let w0 = [-100.0, 90.0];
        let p = complementary(&a, &w0).expect("a solution");
        let elastic = restituted(&a, &w0, p.clone(), &[1.0, 1.0]);
        let (w, gain) = after(&a, &w0, &elastic);
        assert!(w.iter().all(|&w| w >= 0.0), "{w:?}");
        assert!(gain.abs() <= 1e-12 * 100.0, "energy changed by {gain} J");
        // Inelastic pairs take the inelastic impulses themselves, which stop both cubes.
        assert_eq!(restituted(&a, &w0, p.clone(), &[0.0, 0.0]), p);
        assert!((after(&a, &w0, &p).1 + 100.0).abs() < 1e-9);
    }
}
