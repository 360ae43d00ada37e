//! The four-lane kernel against the reference, and exact cases.

use super::PairRows;
use crate::math::{Mat3, Quat, Scalar, Vector};
use crate::solver::constraints::{make_idle, place_group, tangents};
use crate::solver::reference::fill::{couple_pairs, friction_patch};
use crate::solver::{
    Batch, Constraint, ConstraintGroup, ContactPoint, Friction, HeldPair, Softness, SolverBody, kernel, reference,
};
use proptest::prelude::*;
use proptest::sample::Index;

/// The kernel's copy of `pairs`: placed in batches by the solver's own `place_group` (and
/// so `place`), each constraint and point written into its lane as `fill` writes them.
fn lay_out(pairs: &[PairRows], static_slot: u32) -> ConstraintGroup {
    lay_out_quiet(pairs, static_slot, &[])
}

/// `lay_out`, with the pairs `quiet` marks (by index; the others and those past its end are
/// not) placed as quiet (`HeldPair::quiet`).
fn lay_out_quiet(pairs: &[PairRows], static_slot: u32, quiet: &[bool]) -> ConstraintGroup {
    let mut group = ConstraintGroup { static_slot, ..ConstraintGroup::default() };
    group.slots.extend(pairs.iter().map(|p| p.constraint.slot));
    let quiet = |c: usize| quiet.get(c).copied().unwrap_or(false);
    let held: Vec<HeldPair> = (0..pairs.len())
        .map(|c| HeldPair { pair: 0, group: 0, at: c as u32, len: pairs[c].points.len() as u8, quiet: quiet(c) })
        .collect();
    place_group(&held, 0, &mut group);
    make_idle(&held, 0, &mut group);
    for (pair, &(batch, lane)) in pairs.iter().zip(&group.placed) {
        let batch = &mut group.batches[batch as usize];
        batch.set(usize::from(lane), &pair.constraint);
        for (j, point) in pair.points.iter().enumerate() {
            group.points[batch.first as usize + j].set(usize::from(lane), point);
        }
    }
    group
}

/// One pass (or body step) of a substep plan, run on both solvers.
#[derive(Clone, Copy, Debug)]
enum Step {
    Warm,
    Solve,
    Move,
    Relax,
    Restitution,
}

/// Two substeps as `solve` plans them (two solve sweeps in the first; gravity's pushes left
/// out), then restitution.
const PLAN: [Step; 10] = {
    use Step::*;
    [Warm, Solve, Solve, Move, Relax, Warm, Solve, Move, Relax, Restitution]
};

/// Runs `step` on the kernel's batches and on the reference's pairs.
fn run(
    step: Step,
    kernel_side: (&mut [SolverBody], &mut ConstraintGroup),
    reference_side: (&mut [SolverBody], &mut [PairRows]),
    (h, threshold, fresh): (Scalar, Scalar, bool),
) {
    let ((kb, group), (rb, pairs)) = (kernel_side, reference_side);
    let soft = Softness::new(h);
    match step {
        Step::Warm => {
            kernel::warm_start(kb, &group.batches, &mut group.points);
            reference::warm_start(rb, pairs);
        }
        Step::Solve => {
            kernel::sweep(kb, &mut group.batches, &mut group.points, h, Some(soft), fresh);
            reference::sweep(rb, pairs, h, Some(soft));
        }
        Step::Relax => {
            kernel::sweep(kb, &mut group.batches, &mut group.points, h, None, fresh);
            reference::sweep(rb, pairs, h, None);
        }
        Step::Restitution => {
            // The batches `fill` would list.
            let rows = |b: &Batch| &group.points[b.rows()];
            let may =
                |&k: &u32| kernel::may_bounce(&group.batches[k as usize], rows(&group.batches[k as usize]), threshold);
            let bouncing: Vec<u32> = (0..group.batches.len() as u32).filter(may).collect();
            kernel::restitution(kb, (&group.batches, &bouncing), &mut group.points, threshold);
            reference::restitution(rb, pairs, threshold);
        }
        Step::Move => {
            for bodies in [kb, rb] {
                let free = bodies.len() - 1;
                for b in &mut bodies[..free] {
                    b.dx += b.v * h;
                    b.dq += b.w * h;
                }
            }
        }
    }
}

/// Where the kernel's and the reference's results differ in any bit: every body's
/// velocities, every point's accumulated and largest impulses, every friction impulse, and
/// the idle points of a batch (a lane's beyond its own count), which must stay zero.
fn differences(kb: &[SolverBody], group: &ConstraintGroup, rb: &[SolverBody], pairs: &[PairRows]) -> Vec<String> {
    let mut out = Vec::new();
    let mut same = |what: String, k: Scalar, r: Scalar| {
        if k.to_bits() != r.to_bits() {
            out.push(format!("{what}: kernel {k:e}, reference {r:e}"));
        }
    };
    for (slot, (k, r)) in kb.iter().zip(rb).enumerate() {
        for axis in 0..3 {
            same(format!("body {slot} v[{axis}]"), k.v[axis], r.v[axis]);
            same(format!("body {slot} w[{axis}]"), k.w[axis], r.w[axis]);
        }
    }
    for (i, (pair, &(batch, lane))) in pairs.iter().zip(&group.placed).enumerate() {
        let (batch, lane) = (&group.batches[batch as usize], usize::from(lane));
        for k in 0..3 {
            same(
                format!("pair {i} friction impulse {k}"),
                batch.friction.impulse[k][lane],
                pair.constraint.friction.impulse[k],
            );
        }
        for j in 0..batch.len as usize {
            let kernel = group.points[batch.first as usize + j].get(lane);
            let reference = pair.points.get(j).copied().unwrap_or(ContactPoint::IDLE);
            same(format!("pair {i} point {j} impulse"), kernel.impulse, reference.impulse);
            same(format!("pair {i} point {j} max impulse"), kernel.max_impulse, reference.max_impulse);
        }
    }
    out
}

fn vector(range: Scalar) -> impl Strategy<Value = Vector> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vector::new(x, y, z))
}

fn unit() -> impl Strategy<Value = Vector> {
    vector(1.0).prop_filter("a direction", |n| n.length() > 0.1).prop_map(Vector::normalize)
}

fn rotation() -> impl Strategy<Value = Quat> {
    (unit(), -3.0..3.0f64).prop_map(|(axis, angle)| Quat::from_axis_angle(axis, angle))
}

/// A free body: mass, principal moments and axes, position, and its solver state.
#[derive(Clone, Debug)]
struct BodySpec {
    mass: Scalar,
    moments: Vector,
    axes: Quat,
    position: Vector,
    state: SolverBody,
}

fn body() -> impl Strategy<Value = BodySpec> {
    let moments = (0.05..5.0f64, 0.05..5.0f64, 0.05..5.0f64).prop_map(|(a, b, c)| Vector::new(a, b, c));
    let state =
        (vector(3.0), vector(3.0), vector(0.02), vector(0.02)).prop_map(|(v, w, dx, dq)| SolverBody { v, w, dx, dq });
    (0.2..5.0f64, moments, rotation(), vector(2.0), state).prop_map(|(mass, moments, axes, position, state)| BodySpec {
        mass,
        moments,
        axes,
        position,
        state,
    })
}

/// A manifold point: its offset from the pair's centre, gap, approach speed and warm start.
#[derive(Clone, Debug)]
struct PointSpec {
    offset: Vector,
    gap: Scalar,
    approach: Scalar,
    impulse: Scalar,
}

fn point() -> impl Strategy<Value = PointSpec> {
    (vector(0.5), -0.06..0.03f64, -4.0..1.0f64, prop_oneof![Just(0.0), 0.0..3.0f64])
        .prop_map(|(offset, gap, approach, impulse)| PointSpec { offset, gap, approach, impulse })
}

/// A held pair: its two bodies (`ground` 0: B is the static slot, 1: A is, else both free
/// when there are two bodies), normal, centre, points, material and friction warm start.
#[derive(Clone, Debug)]
struct PairSpec {
    a: Index,
    b: Index,
    ground: u8,
    normal: Vector,
    centre: Vector,
    points: Vec<PointSpec>,
    mu: Scalar,
    friction: [Scalar; 3],
    restitution: Scalar,
    slop: Scalar,
    max_push: Scalar,
}

fn pair() -> impl Strategy<Value = PairSpec> {
    let material = (
        prop_oneof![Just(0.0), 0.05..1.2f64],
        (-0.5..0.5f64, -0.5..0.5f64, -0.2..0.2f64),
        prop_oneof![Just(0.0), 0.1..0.9f64],
        0.0..0.01f64,
        0.05..3.0f64,
    );
    (any::<Index>(), any::<Index>(), 0..4u8, unit(), vector(2.0), proptest::collection::vec(point(), 1..=4), material)
        .prop_map(|(a, b, ground, normal, centre, points, (mu, (t1, t2, tw), restitution, slop, max_push))| PairSpec {
            a,
            b,
            ground,
            normal,
            centre,
            points,
            mu,
            friction: [t1, t2, tw],
            restitution,
            slop,
            max_push,
        })
}

/// The solver bodies (the static slot last) and the pairs' rows, built as
/// `build_constraints` builds them: g = S (r × n) with S = (I⁻¹)^½, effective masses,
/// couplings, friction patches; then the warm-start impulses.
fn build(bodies: &[BodySpec], specs: &[PairSpec], h: Scalar) -> (Vec<SolverBody>, Vec<PairRows>) {
    let static_slot = bodies.len();
    let mut solver_bodies: Vec<SolverBody> = bodies.iter().map(|b| b.state).collect();
    solver_bodies.push(SolverBody::default());
    let scale_of = |i: usize| {
        bodies.get(i).map_or(Mat3::ZERO, |b| {
            let r = Mat3::from_quat(b.axes);
            r * Mat3::from_diagonal(b.moments.map(|m| 1.0 / m.sqrt())) * r.transpose()
        })
    };
    let inv_mass_of = |i: usize| bodies.get(i).map_or(0.0, |b| 1.0 / b.mass);
    let position_of = |i: usize| bodies.get(i).map_or(Vector::ZERO, |b| b.position);
    let compliance = Softness::new(h).compliance;
    let pairs = specs
        .iter()
        .map(|s| {
            let a = s.a.index(bodies.len());
            let other = if bodies.len() > 1 { (a + 1 + s.b.index(bodies.len() - 1)) % bodies.len() } else { a };
            let slot = match s.ground {
                0 => [a, static_slot],
                1 => [static_slot, a],
                _ if bodies.len() > 1 => [a, other],
                _ => [a, static_slot],
            };
            let (n, inv_mass, scale, position) =
                (s.normal, slot.map(inv_mass_of), slot.map(scale_of), slot.map(position_of));
            let mut points: Vec<ContactPoint> = s
                .points
                .iter()
                .map(|p| {
                    let at = s.centre + p.offset;
                    let g = [0, 1].map(|end| scale[end] * (at - position[end]).cross(n));
                    let k = inv_mass[0] + inv_mass[1] + g[0].length_squared() + g[1].length_squared();
                    ContactPoint {
                        g,
                        mass: 1.0 / k,
                        k,
                        impulse: p.impulse,
                        gap: p.gap,
                        approach: p.approach,
                        ..ContactPoint::IDLE
                    }
                })
                .collect();
            couple_pairs(&mut points, inv_mass, compliance);
            let centre = s.points.iter().map(|p| s.centre + p.offset).sum::<Vector>() / s.points.len() as Scalar;
            for (point, spec) in points.iter_mut().zip(&s.points) {
                point.lever = (s.centre + spec.offset - centre).length();
            }
            let tangents = tangents(n);
            let friction = if s.mu > 0.0 {
                let patch = friction_patch(centre, position, n, tangents, inv_mass, scale, None);
                Friction { impulse: s.friction, ..patch }
            } else {
                Friction::IDLE
            };
            let constraint = Constraint {
                slot: slot.map(|i| i as u32),
                normal: n,
                tangents,
                inv_mass,
                mu: s.mu,
                restitution: s.restitution,
                slop: s.slop,
                max_push: s.max_push,
                friction,
            };
            PairRows { constraint, points }
        })
        .collect();
    (solver_bodies, pairs)
}

/// Runs `PLAN` on both solvers from the same start; the first pass after which they differ
/// and how, if any.
fn compare(bodies: &[BodySpec], specs: &[PairSpec], h: Scalar, threshold: Scalar) -> Result<(), String> {
    let (mut rb, mut pairs) = build(bodies, specs, h);
    let mut kb = rb.clone();
    let mut group = lay_out(&pairs, bodies.len() as u32);
    // As `drive` runs it: a sweep after a move works the gaps out, the others reuse them.
    let mut moved = true;
    for (k, step) in PLAN.into_iter().enumerate() {
        let fresh = moved && matches!(step, Step::Solve | Step::Relax);
        moved = (moved && !fresh) || matches!(step, Step::Move);
        run(step, (&mut kb, &mut group), (&mut rb, &mut pairs), (h, threshold, fresh));
        let diff = differences(&kb, &group, &rb, &pairs);
        if !diff.is_empty() {
            return Err(format!(
                "after step {k} ({step:?}), {} differences: {:#?}",
                diff.len(),
                &diff[..diff.len().min(8)]
            ));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The four-lane kernel, on random constraints placed in batches as the solver places
    /// them, gives the bits of the plain one-at-a-time reference: every pass of two
    /// substeps and restitution, soft, speculative and rigid rows, blocks and single
    /// points, friction, bodies shared between constraints and the static slot.
    #[test]
    fn the_kernel_gives_the_bits_of_solving_the_constraints_one_at_a_time(
        bodies in proptest::collection::vec(body(), 1..9),
        pairs in proptest::collection::vec(pair(), 1..20),
        h in 1.0 / 480.0..1.0 / 60.0f64,
        threshold in 0.3..2.0f64,
    ) {
        let result = compare(&bodies, &pairs, h, threshold);
        prop_assert!(result.is_ok(), "{}", result.unwrap_err());
    }

    /// Quiet batches, which a pass leaves alone while no lane holds an impulse and every
    /// normal row holds (`Batch::quiet`), come out with the numbers of solving them: random
    /// constraints, some made quiet (no warm start, gaps open, so the slower ones hold), placed
    /// as quiet or not. Equal as numbers: a pass that solves a lane with nothing to push may
    /// leave −0 where one left alone keeps +0.
    #[test]
    fn a_quiet_batch_left_alone_gives_the_numbers_of_solving_it(
        bodies in proptest::collection::vec(body(), 1..9),
        pairs in proptest::collection::vec(pair(), 1..20),
        quiet in proptest::collection::vec(any::<bool>(), 20),
        h in 1.0 / 480.0..1.0 / 60.0f64,
    ) {
        let mut pairs = pairs;
        for (pair, _) in pairs.iter_mut().zip(&quiet).filter(|(_, q)| **q) {
            pair.friction = [0.0; 3];
            for point in &mut pair.points {
                (point.impulse, point.gap) = (0.0, point.gap.abs());
            }
        }
        let (start, rows) = build(&bodies, &pairs, h);
        let (solved, marked) = (planned(&start, &rows, h, &[]), planned(&start, &rows, h, &quiet));
        prop_assert!(solved.iter().zip(&marked).all(|(a, b)| a == b), "{solved:?} against {marked:?}");
    }

    /// `Step::Repeat` (a substep re-applies, body by body, what the last one applied) gives
    /// the velocities of gravity's push and a warm-start pass, to rounding: random
    /// constraints with friction, soft, speculative and rigid rows, shared bodies.
    #[test]
    fn repeating_the_last_substep_body_by_body_is_the_warm_start_pass(
        bodies in proptest::collection::vec(body(), 1..9),
        pairs in proptest::collection::vec(pair(), 1..20),
        h in 1.0 / 480.0..1.0 / 60.0f64,
    ) {
        let (start, rows) = build(&bodies, &pairs, h);
        let (warm, repeat) = (driven(&start, &rows, h, false), driven(&start, &rows, h, true));
        let scale = warm.iter().map(|b| b.v.length().max(b.w.length())).fold(1.0, Scalar::max);
        for (k, (a, b)) in warm.iter().zip(&repeat).enumerate() {
            let off = (a.v - b.v).length().max((a.w - b.w).length()).max((a.dx - b.dx).length());
            prop_assert!(off <= 1e-12 * scale, "body {k}: {a:?} against {b:?}");
        }
    }
}

/// The restitution threshold of `planned` [m/s].
const RESTITUTION_THRESHOLD: Scalar = 0.5;

/// The kernel's results after `PLAN` on `pairs` laid out with the quiet marks `quiet`: every
/// body's velocities, then each pair's friction impulses and its points' accumulated and
/// largest impulses, in pair order.
fn planned(bodies: &[SolverBody], pairs: &[PairRows], h: Scalar, quiet: &[bool]) -> Vec<Scalar> {
    let (mut kb, mut group) = (bodies.to_vec(), lay_out_quiet(pairs, bodies.len() as u32 - 1, quiet));
    let soft = Some(Softness::new(h));
    let mut moved = true;
    for step in PLAN {
        let fresh = moved && matches!(step, Step::Solve | Step::Relax);
        moved = (moved && !fresh) || matches!(step, Step::Move);
        match step {
            Step::Warm => kernel::warm_start(&mut kb[..], &group.batches, &mut group.points),
            Step::Solve => kernel::sweep(&mut kb[..], &mut group.batches, &mut group.points, h, soft, fresh),
            Step::Relax => kernel::sweep(&mut kb[..], &mut group.batches, &mut group.points, h, None, fresh),
            Step::Move => {
                let free = kb.len() - 1;
                kb[..free].iter_mut().for_each(|b| (b.dx, b.dq) = (b.dx + b.v * h, b.dq + b.w * h));
            }
            Step::Restitution => {
                let may = |&k: &u32| {
                    let batch = &group.batches[k as usize];
                    kernel::may_bounce(batch, &group.points[batch.rows()], RESTITUTION_THRESHOLD)
                };
                let bouncing: Vec<u32> = (0..group.batches.len() as u32).filter(may).collect();
                kernel::restitution(&mut kb[..], (&group.batches, &bouncing), &mut group.points, RESTITUTION_THRESHOLD);
            }
        }
    }
    let mut out: Vec<Scalar> = kb.iter().flat_map(|b| b.v.to_array().into_iter().chain(b.w.to_array())).collect();
    for (pair, &(batch, lane)) in pairs.iter().zip(&group.placed) {
        let (batch, lane) = (&group.batches[batch as usize], usize::from(lane));
        out.extend(batch.friction.impulse.map(|j| j[lane]));
        for j in 0..pair.points.len() {
            let point = group.points[batch.first as usize + j].get(lane);
            out.extend([point.impulse, point.max_impulse]);
        }
    }
    out
}

/// The solver bodies after three substeps (gravity's push, the warm start, a solve sweep, the
/// move and the relax sweep each), carried out by `drive` on the constraints of `pairs` in one
/// group of bodies `bodies` (the static slot last); with `repeat`, the second and third start
/// with `Step::Repeat` instead of the push and the warm-start pass.
fn driven(bodies: &[SolverBody], pairs: &[PairRows], h: Scalar, repeat: bool) -> Vec<SolverBody> {
    // The second side empty: its static slot only.
    let static_slot = bodies.len() - 1;
    let mut s = crate::solver::SolveScratch { bodies: bodies.to_vec(), left: static_slot, ..Default::default() };
    s.bodies.push(SolverBody::default());
    s.groups[0] = lay_out(pairs, static_slot as u32);
    let g = Vector::new(0.3, -9.81, 0.2) * h;
    let plan = crate::solver::substep_plan(3, |_| 1, (h, Softness::new(h)), g, repeat);
    crate::solver::drive(&mut s, &plan, h, &mut crate::solver::Joints::default());
    s.bodies.truncate(bodies.len());
    s.bodies
}

/// A lone body, mass 2, and the static slot under it; one point on the normal through its
/// centre (no lever), so K = 1/m and one rigid row stops the body.
fn falling_body(v: Scalar, gap: Scalar) -> (Vec<SolverBody>, Vec<PairRows>) {
    let body = SolverBody { v: Vector::new(0.0, v, 0.0), ..SolverBody::default() };
    let point = ContactPoint { mass: 2.0, k: 0.5, gap, ..ContactPoint::IDLE };
    let constraint = Constraint { slot: [0, 1], inv_mass: [0.5, 0.0], ..Constraint::idle(1) };
    (vec![body, SolverBody::default()], vec![PairRows { constraint, points: vec![point] }])
}

/// Runs one relax sweep (rigid rows) of substep `h` on both solvers; returns each one's
/// body velocity and point impulse.
fn relax_both(bodies: &[SolverBody], pairs: &[PairRows], h: Scalar) -> [(Vector, Scalar); 2] {
    let (mut kb, mut rb, mut pairs) = (bodies.to_vec(), bodies.to_vec(), pairs.to_vec());
    let mut group = lay_out(&pairs, bodies.len() as u32 - 1);
    run(Step::Relax, (&mut kb, &mut group), (&mut rb, &mut pairs), (h, 1.0, true));
    [(kb[0].v, group.points[0].impulse[0]), (rb[0].v, pairs[0].points[0].impulse)]
}

#[test]
fn a_body_landing_on_the_static_slot_takes_m_v_and_stops() {
    let (bodies, pairs) = falling_body(-3.0, 0.0);
    for (v, impulse) in relax_both(&bodies, &pairs, 1.0 / 240.0) {
        assert_eq!(impulse, 6.0, "m v = 2 kg · 3 m/s");
        assert_eq!(v, Vector::ZERO);
    }
}

#[test]
fn an_open_gap_lets_a_body_close_it_in_one_substep_and_no_faster() {
    // Gap 0.25 m, substep 0.125 s: the row allows 2 m/s of approach.
    let (bodies, pairs) = falling_body(-3.0, 0.25);
    for (v, impulse) in relax_both(&bodies, &pairs, 0.125) {
        assert_eq!(impulse, 2.0, "2 kg · (3 − 2) m/s");
        assert_eq!(v, Vector::new(0.0, -2.0, 0.0));
    }
    let (bodies, pairs) = falling_body(-1.0, 0.25);
    for (v, impulse) in relax_both(&bodies, &pairs, 0.125) {
        assert_eq!(impulse, 0.0, "slower than the gap allows: no impulse");
        assert_eq!(v, Vector::new(0.0, -1.0, 0.0));
    }
}

#[test]
fn a_box_landing_flat_on_two_corners_stops_without_spin() {
    // Mass 1, S = identity, corners at r = (±1, −1, 0) from the centre, normal +y: g = r × n
    // = (0, 0, ±1), K₀₀ = K₁₁ = 2, K₀₁ = 1 − 1 = 0, det K = 4. The block gives each corner
    // half of m v; one Gauss–Seidel sweep would leave the box spinning.
    let n = Vector::Y;
    let corner = |x: Scalar| {
        let g = [Vector::new(x, -1.0, 0.0).cross(n), Vector::ZERO];
        ContactPoint { g, mass: 0.5, k: 2.0, ..ContactPoint::IDLE }
    };
    let mut points = vec![corner(1.0), corner(-1.0)];
    couple_pairs(&mut points, [1.0, 0.0], Softness::new(0.01).compliance);
    assert_eq!((points[0].coupling, points[0].inv_det[0]), (0.0, 0.25));
    let constraint = Constraint { slot: [0, 1], inv_mass: [1.0, 0.0], ..Constraint::idle(1) };
    let body = SolverBody { v: Vector::new(0.0, -4.0, 0.0), ..SolverBody::default() };
    let bodies = [body, SolverBody::default()];
    let pairs = [PairRows { constraint, points }];
    let (mut kb, mut rb, mut reference_pairs) = (bodies.to_vec(), bodies.to_vec(), pairs.to_vec());
    let mut group = lay_out(&pairs, 1);
    run(Step::Relax, (&mut kb, &mut group), (&mut rb, &mut reference_pairs), (0.01, 1.0, true));
    let kernel_impulses = [group.points[0].impulse[0], group.points[1].impulse[0]];
    let reference_impulses = reference_pairs[0].points.iter().map(|p| p.impulse).collect::<Vec<_>>();
    for (b, impulses) in [(kb[0], kernel_impulses.to_vec()), (rb[0], reference_impulses)] {
        assert_eq!(impulses, [2.0, 2.0]);
        assert_eq!((b.v, b.w), (Vector::ZERO, Vector::ZERO));
    }
}

/// A body (mass 1, S = identity) at rest on the static slot at four corners r = (±1, −1, ±1),
/// paired as a manifold's diagonals, each as `corners` gives (approach [m/s], impulse held
/// [N·s], also its largest); restitution 1. Returns the body's (v, ŵ) and the impulses after
/// the restitution pass, from both solvers.
fn bounce_four_corners(corners: [(Scalar, Scalar); 4]) -> [(SolverBody, Vec<Scalar>); 2] {
    let n = Vector::Y;
    let corner = |(x, z): (Scalar, Scalar), (approach, impulse): (Scalar, Scalar)| {
        let g = [Vector::new(x, -1.0, z).cross(n), Vector::ZERO];
        let k = 1.0 + g[0].length_squared();
        ContactPoint { g, mass: 1.0 / k, k, impulse, max_impulse: impulse, approach, ..ContactPoint::IDLE }
    };
    let at = [(1.0, 1.0), (-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0)];
    let mut points: Vec<ContactPoint> = at.iter().zip(corners).map(|(&r, c)| corner(r, c)).collect();
    couple_pairs(&mut points, [1.0, 0.0], Softness::new(0.01).compliance);
    let constraint = Constraint { slot: [0, 1], inv_mass: [1.0, 0.0], restitution: 1.0, ..Constraint::idle(1) };
    let pairs = [PairRows { constraint, points }];
    let bodies = [SolverBody::default(); 2];
    let (mut kb, mut rb, mut reference_pairs) = (bodies.to_vec(), bodies.to_vec(), pairs.to_vec());
    let mut group = lay_out(&pairs, 1);
    run(Step::Restitution, (&mut kb, &mut group), (&mut rb, &mut reference_pairs), (0.01, 1.0, true));
    let kernel_impulses = (0..4).map(|j| group.points[j].impulse[0]).collect();
    let reference_impulses = reference_pairs[0].points.iter().map(|p| p.impulse).collect();
    [(kb[0], kernel_impulses), (rb[0], reference_impulses)]
}

#[test]
fn a_corner_whose_share_of_the_stop_was_round_off_does_not_bounce() {
    // Flat on four corners that all approached at 2 m/s; the stop fell on the diagonal (2, 3),
    // corner 1 carried round-off. Only that diagonal bounces: K = [[3, −1], [−1, 3]] takes
    // (1, 1) N·s more to leave at 2 m/s, v_y = 2 and no spin. Counted as touched, corner 1
    // bounced alone first and set the body spinning.
    let corners = [(-2.0, 0.0), (-2.0, 1e-15), (-2.0, 0.5), (-2.0, 0.5)];
    for (b, impulses) in bounce_four_corners(corners) {
        assert_eq!((b.v, b.w), (Vector::new(0.0, 2.0, 0.0), Vector::ZERO));
        assert_eq!(impulses, [0.0, 1e-15, 1.5, 1.5]);
    }
}

/// A body sliding over the static slot 1 cm above it, no impulse carried in: its rows hold (it
/// does not approach), so a relax sweep leaves its quiet batch alone. Solved, friction finds
/// the slip and the zero normal impulse bounds it to zero, written as −0; left alone, the
/// impulse stays +0, and the body's velocities are the same.
#[test]
fn a_relax_sweep_leaves_a_quiet_batch_whose_rows_hold_alone() {
    let h = 1.0 / 240.0;
    let (mut bodies, mut pairs) = falling_body(0.0, 0.01);
    let c = &mut pairs[0].constraint;
    (c.normal, c.tangents, c.mu) = (Vector::Y, [Vector::X, Vector::Z], 0.5);
    c.friction.mass = [1.0, 0.0, 1.0];
    bodies[0].v = Vector::new(3.0, 0.0, 0.0);
    let relaxed = |quiet: &[bool]| {
        let (mut bodies, mut group) = (bodies.clone(), lay_out_quiet(&pairs, 1, quiet));
        kernel::sweep(&mut bodies[..], &mut group.batches, &mut group.points, h, None, true);
        (bodies, group.batches[0].friction.impulse[0][0], group.batches[0].quiet)
    };
    let ((solved, j_solved, _), (left, j_left, quiet)) = (relaxed(&[]), relaxed(&[true]));
    assert!(quiet, "placed as quiet");
    assert_eq!((j_solved.to_bits(), j_left.to_bits()), ((-0.0f64).to_bits(), 0.0f64.to_bits()));
    assert_eq!(solved, left, "nothing pushed either way");
    assert_eq!(left[0].v, Vector::new(3.0, 0.0, 0.0));
}
