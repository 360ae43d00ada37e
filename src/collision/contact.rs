//! Contacts and candidate pairs. Convention (docs/physics.md §0): the normal points **from B to
//! A**, where A is the pair's lower actor index, so a positive impulse pushes A along `normal`.

use crate::math::{Scalar, Vector};

/// Which of the paper's three detection tests found a contact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Feature {
    /// Triangle centroids of one body inside the other (docs/physics.md §1.3).
    Face,
    /// Vertices of one body inside the other (§1.4).
    Vertex,
    /// An edge of one body crossing the other (§1.5).
    Edge,
}

impl Feature {
    /// All features in the paper's test order.
    pub const ALL: [Self; 3] = [Self::Face, Self::Vertex, Self::Edge];

    /// The name used in output files and by `rigid systems`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Face => "face",
            Self::Vertex => "vertex",
            Self::Edge => "edge",
        }
    }
}

/// A contact between two bodies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// World contact point [m].
    pub point: Vector,
    /// Unit normal from B to A.
    pub normal: Vector,
    /// Penetration depth along `normal`, ≥ 0 [m] (docs/physics.md §2.6).
    pub depth: Scalar,
    /// The test that found it.
    pub feature: Feature,
}

impl Contact {
    /// The same contact seen from the other body: a test run as (B, A) reports a normal from A
    /// to B, so it is negated to keep the pair's convention (docs/physics.md §1.6).
    #[must_use]
    pub fn flipped(self) -> Self {
        Self { normal: -self.normal, ..self }
    }
}

/// Where a pair stands in the step. States only move forward, so a system can be repeated,
/// moved or removed without applying an impulse twice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PairState {
    /// Bounding spheres overlap; no test has fired yet.
    Candidate,
    /// A pruning system proved the bodies apart: no test can fire (`prune` marks these, then
    /// drops them from the list).
    Separated,
    /// A pruning system proved the bodies apart by more than the tests' tolerance, but by less
    /// than the contact margin: no test can fire, so they are not run, and `solve` may still
    /// hold the pair speculatively (a gap that may close within the step).
    Near,
    /// A detection test found this contact.
    Found(Contact),
    /// `resolve` has processed this contact (impulse applied if the bodies approached).
    Resolved(Contact),
}

/// A candidate pair, `a < b` (actor indices).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// Lower actor index (body A).
    pub a: u32,
    /// Higher actor index (body B).
    pub b: u32,
    /// How far the step has got with it.
    pub state: PairState,
}

impl Pair {
    /// A fresh candidate.
    #[must_use]
    pub fn candidate(a: u32, b: u32) -> Self {
        debug_assert!(a < b, "pairs are ordered");
        Self { a, b, state: PairState::Candidate }
    }

    /// True while no test has fired.
    #[must_use]
    pub fn is_candidate(&self) -> bool {
        matches!(self.state, PairState::Candidate)
    }

    /// True when proved apart but within the contact margin (`PairState::Near`).
    #[must_use]
    pub fn is_near(&self) -> bool {
        matches!(self.state, PairState::Near)
    }

    /// The contact, once found.
    #[must_use]
    pub fn contact(&self) -> Option<Contact> {
        match self.state {
            PairState::Found(c) | PairState::Resolved(c) => Some(c),
            _ => None,
        }
    }
}
