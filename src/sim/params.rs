//! `Params`: the pipeline's settings that a scene or the CLI may change, and the quantities
//! derived from them that several systems share (substeps, speculative distances).

use crate::math::{Scalar, Vector};
use crate::sim::bodies::Bodies;

/// Settings of the pipeline that a scene or the CLI may change.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// Gravity [m/s²].
    pub gravity: Vector,
    /// Most impulse sweeps over the contacts per step (docs/physics.md §2.5). Sweeps stop earlier
    /// when one applies no impulse; the cap matters for e = 1 bodies squeezed between walls.
    pub max_sweeps: u32,
    /// Fraction β of the penetration removed per step by `correct` (docs/physics.md §2.6).
    pub correction: Scalar,
    /// Penetration left alone, as a fraction of the thinner body's thickness (the slop).
    pub slop: Scalar,
    /// Largest correction per step, as a fraction of the thinner body's thickness: a wrong
    /// normal must not throw a body across the scene (§2.6).
    pub max_correction: Scalar,
    /// Approach speed [m/s] above which a contact bounces (in `solve`, or `resolve` where
    /// `solve` is idle); below it the contact rests. `None`: 2|g|·dt, the speed gravity alone
    /// gives in two steps, so resting bodies never hop, and zero without gravity.
    pub restitution_threshold: Option<Scalar>,
    /// Substeps of the contact solver (`solve`): each adds its share of gravity, solves and
    /// relaxes, so a tall stack's weight is carried in small pieces; the contacts' stiffness is
    /// a quarter of the substep rate. Scenes choose it by `Params::substeps_for` unless they
    /// set it.
    pub substeps: u32,
    /// Solve sweeps in each of the first half of the substeps of `solve` (rounded up); the
    /// later ones take one (`sweeps`). One relax sweep follows them.
    pub iterations: u32,
    /// Bodies that have been still for a while sleep (the `sleep` system): they are treated
    /// as fixed until something touching them moves. Off by default.
    pub sleep: bool,
    /// Distance within which two bodies count as in resting contact though apart, as a fraction
    /// of the thinner one's thickness: `prune` keeps such pairs and `solve` holds them
    /// (speculatively), so a stack does not lose a contact to a micro-bounce.
    pub contact_margin: Scalar,
    /// Continuous collision (the `ccd` system, docs/physics.md §6.7): a body fast enough to pass
    /// through another in one step is swept to its time of impact. Off: the paper's discrete
    /// model, in which only overlaps at the step times are seen (§5).
    pub ccd: bool,
}

/// Substep rate [Hz] the contact solver keeps at least, unless a scene sets its substeps: 4
/// substeps of a 1/60 s step. A soft contact sinks under a load by load / (m ω²), ω being a
/// quarter of the substep rate, so with a longer step and the same substeps a stack sinks by
/// the square of the ratio.
pub const MIN_SUBSTEP_RATE: Scalar = 240.0;

impl Params {
    /// The substeps a scene with time step `dt` [s] gets by default: 4, or as many more as keep
    /// each substep within 1/`MIN_SUBSTEP_RATE` s (8 for 1/30 s), at most 64. The same
    /// stiffness, sinking and stability at any step, for the same cost per simulated second.
    #[must_use]
    pub fn substeps_for(dt: Scalar) -> u32 {
        // The small allowance keeps 1/60 s at 4 substeps despite its rounding.
        let needed = (dt * MIN_SUBSTEP_RATE - 1e-9).ceil();
        if needed.is_finite() { needed.clamp(4.0, 64.0) as u32 } else { 4 }
    }

    /// True when `solve` holds contacts of a pair with this friction: under gravity all of
    /// them, otherwise only those with friction.
    #[must_use]
    pub fn resting_contacts(&self, dt: Scalar, friction: Scalar) -> bool {
        self.restitution_threshold(dt) > 0.0 || friction > 0.0
    }

    /// `resting_contacts` for the pairs of one step, the threshold (a square root) worked out
    /// once: `rule(friction)` says whether `solve` holds a pair's contacts.
    pub fn resting_rule(&self, dt: Scalar) -> impl Fn(Scalar) -> bool + Copy + Send + Sync {
        let all = self.resting_contacts(dt, 0.0);
        move |friction| all || friction > 0.0
    }

    /// How far body `i` may travel towards another within one step [m], when `solve` may hold
    /// its contacts (else 0): its speed, gravity's gain over the step and its bounding sphere's
    /// spin, times `dt`. The broad phase widens the body's sphere by it, and `prune` and
    /// `solve` widen the pair's contact margin by the sum of the two, so a contact is held
    /// speculatively the step *before* the bodies meet and a fast body lands on another, not in it.
    #[must_use]
    pub fn speculative_distance(&self, dt: Scalar, b: &Bodies, i: usize) -> Scalar {
        self.speculative_with(self.step_terms(dt), dt, b, i)
    }

    /// `speculative_distance` of every body, into `out` (by actor index): the systems that
    /// need it for every pair compute it once per body, not twice per pair.
    pub fn speculative_distances(&self, dt: Scalar, b: &Bodies, out: &mut Vec<Scalar>) {
        let terms = self.step_terms(dt);
        out.clear();
        out.extend((0..b.len()).map(|i| self.speculative_with(terms, dt, b, i)));
    }

    /// What `speculative_distance` takes from the step alone: whether every pair may rest
    /// (`resting_contacts` without friction) and gravity's gain of speed over the step.
    fn step_terms(&self, dt: Scalar) -> (bool, Scalar) {
        (self.resting_contacts(dt, 0.0), self.gravity.length() * dt)
    }

    fn speculative_with(&self, (all_rest, fall): (bool, Scalar), dt: Scalar, b: &Bodies, i: usize) -> Scalar {
        if !(all_rest || b.friction[i] > 0.0) || b.inv_mass[i] == 0.0 {
            return 0.0;
        }
        let speed = b.velocity[i].length() + fall + b.angular_velocity[i].length() * b.radius[i];
        speed * dt
    }

    /// The length of a substep of `solve` [s] for a step of `dt`.
    #[must_use]
    pub fn substep(&self, dt: Scalar) -> Scalar {
        dt / Scalar::from(self.substeps.max(1))
    }

    /// Solve sweeps in substep `k` (0-based): `iterations` in the first half, one after. The
    /// later substeps start from the earlier ones' impulses, near the solution, and one sweep
    /// holds them (a rain of cubes even settles sooner than with more); one sweep in every
    /// substep leaves a tall pyramid bouncing.
    #[must_use]
    pub fn sweeps(&self, k: u32) -> u32 {
        if k < self.substeps.div_ceil(2) { self.iterations } else { 1 }
    }

    /// The restitution threshold in force for time step `dt` [m/s].
    #[must_use]
    pub fn restitution_threshold(&self, dt: Scalar) -> Scalar {
        self.restitution_threshold.unwrap_or(2.0 * self.gravity.length() * dt)
    }
}

impl Default for Params {
    fn default() -> Self {
        Self {
            gravity: Vector::new(0.0, -9.81, 0.0),
            max_sweeps: 20,
            correction: 0.4,
            slop: 0.0005,
            max_correction: 0.2,
            restitution_threshold: None,
            substeps: 4,
            iterations: 2,
            sleep: false,
            contact_margin: 0.02,
            ccd: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substeps_keep_each_at_most_a_240th_of_a_second() {
        let cases = [(1.0 / 60.0, 4), (0.01, 4), (1e-4, 4), (1.0 / 30.0, 8), (0.05, 12), (0.1, 24), (1.0, 64)];
        for (dt, substeps) in cases {
            assert_eq!(Params::substeps_for(dt), substeps, "dt = {dt}");
        }
    }
}
