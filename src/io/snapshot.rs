//! Snapshots: the complete state of a run, so `rigid run --resume` continues it bit for bit
//! (100 + 100 steps give the same bits as 200). A snapshot embeds the scene's text (meshes
//! and settings are rebuilt from it), every actor's pose and velocities, and what the contact
//! solver and sleeping carry from one step to the next (the warm-start cache, how long each
//! body has been still); JSON floats are written shortest-round-trip and read back exactly.

use crate::collision::contact::Feature;
use crate::collision::manifold::{MAX_POINTS, Reference};
use crate::math::{Quat, Vector};
use crate::model::components::{Pose, Velocity};
use crate::sim::Sim;
use crate::sim::context::SleepState;
use crate::solver::{CachedManifold, ContactAnchors, JointImpulses, Joints, SolveScratch};
use serde::{Deserialize, Serialize};

/// Version of the snapshot format; a reader refuses other versions.
pub const SNAPSHOT_FORMAT: u32 = 1;

/// One actor's dynamic state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActorSnapshot {
    /// Name (checked against the rebuilt scene).
    pub name: String,
    /// Centre of mass [m].
    pub position: [f64; 3],
    /// Orientation `[x, y, z, w]`.
    pub orientation: [f64; 4],
    /// [m/s].
    pub velocity: [f64; 3],
    /// [rad/s], world frame.
    pub angular_velocity: [f64; 3],
}

/// A held pair's entry in the contact solver's warm-start cache (`step::CachedManifold`):
/// its points fixed to both bodies and their impulses. Without it a resumed run under gravity
/// starts its contacts cold and drifts from the unbroken one (a pyramid by a millimetre).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactSnapshot {
    /// The pair's actor indices (a < b).
    pub pair: [u32; 2],
    /// B's centre in A's body frame when the points were found [m].
    pub offset: [f64; 3],
    /// B's orientation relative to A's then, `[x, y, z, w]`.
    pub turn: [f64; 4],
    /// The normal (from B to A) in A's body frame.
    pub normal: [f64; 3],
    /// Each point on A, A's body frame [m].
    pub on_a: Vec<[f64; 3]>,
    /// Each point on B, B's body frame [m].
    pub on_b: Vec<[f64; 3]>,
    /// Each point's normal impulse [N·s].
    pub impulses: Vec<f64>,
    /// Friction impulse at the patch's centre, world frame [N·s].
    pub tangent: [f64; 3],
    /// Twist impulse about the normal, world frame [N·m·s].
    pub twist: [f64; 3],
    /// The test that last found the pair (`face`, `vertex`, `edge`; absent: none did), which
    /// it keeps while its points are recycled (docs/physics.md §6.3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub found: Option<String>,
    /// The axis the points were found along, where the pair's next search starts: `b:F` or
    /// `a:F` for face F of B or A, `edges` for an edge pair (absent: none known).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<String>,
}

/// The `sleep` system's state (`step::SleepState`), one entry per actor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SleepSnapshot {
    /// Seconds each body has been still.
    pub still: Vec<f64>,
    /// Each body sleeps.
    pub asleep: Vec<bool>,
    /// Where each body was to end its last step (position + v·dt), `null` before the first.
    pub reached: Vec<Option<[f64; 3]>>,
}

/// The complete state of a simulation run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Snapshot {
    /// `SNAPSHOT_FORMAT`.
    pub format: u32,
    /// Where the scene came from (OBJ paths resolve against it).
    pub scene_path: String,
    /// The scene file's text.
    pub scene_text: String,
    /// Time step in force (after `--dt`) [s].
    pub dt: f64,
    /// Schedule in force (after `--schedule`).
    pub schedule: Vec<String>,
    /// Simulated time [s].
    pub time: f64,
    /// Steps taken.
    pub steps: u64,
    /// Impulses so far by feature (face, vertex, edge).
    pub contacts: [u64; 3],
    /// Every actor, in index order.
    pub actors: Vec<ActorSnapshot>,
    /// The contact solver's warm-start cache, in pair order (absent: none).
    #[serde(default)]
    pub warm_start: Vec<ContactSnapshot>,
    /// Sleeping's state (absent: every body awake and never still).
    #[serde(default)]
    pub sleep: Option<SleepSnapshot>,
    /// Each joint's warm-start impulses, in scene order: point [3], angular [3], axial, lower
    /// and upper limit, motor (absent: a scene without joints).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub joints: Vec<[f64; 10]>,
}

impl Snapshot {
    /// Captures `sim`, which was built from `scene_text` read at `scene_path`.
    #[must_use]
    pub fn capture(sim: &Sim, scene_path: &str, scene_text: &str) -> Self {
        Self {
            format: SNAPSHOT_FORMAT,
            scene_path: scene_path.to_string(),
            scene_text: scene_text.to_string(),
            dt: sim.ctx.dt,
            schedule: sim.schedule.names().iter().map(ToString::to_string).collect(),
            time: sim.time,
            steps: sim.steps,
            contacts: sim.impulses,
            actors: sim
                .actors()
                .into_iter()
                .map(|a| ActorSnapshot {
                    name: a.name,
                    position: a.pose.position.to_array(),
                    orientation: a.pose.orientation.to_array(),
                    velocity: a.velocity.linear.to_array(),
                    angular_velocity: a.velocity.angular.to_array(),
                })
                .collect(),
            warm_start: sim.ctx.scratch.get::<SolveScratch>().map_or_else(Vec::new, |s| {
                s.cache.iter().map(|&((a, b), ref c)| ContactSnapshot::of([a, b], c)).collect()
            }),
            sleep: (!sim.ctx.sleep.still.is_empty()).then(|| SleepSnapshot::of(&sim.ctx.sleep)),
            joints: sim
                .ctx
                .scratch
                .get::<Joints>()
                .map_or_else(Vec::new, |j| j.impulses.iter().map(joint_row).collect()),
        }
    }

    /// Puts the captured state into `sim`, rebuilt from the same scene; `Err` says what does
    /// not match.
    pub fn restore(&self, sim: &mut Sim) -> Result<(), String> {
        if sim.names().len() != self.actors.len() {
            return Err(format!("the scene now has {} actors, the snapshot {}", sim.names().len(), self.actors.len()));
        }
        if let Some((a, s)) = sim.names().iter().zip(&self.actors).find(|(a, s)| **a != s.name) {
            return Err(format!("actor '{a}' of the scene is '{}' in the snapshot", s.name));
        }
        for s in &self.actors {
            if ![&s.position[..], &s.orientation, &s.velocity, &s.angular_velocity].iter().all(|xs| finite(xs)) {
                return Err(format!("actor '{}': non-finite state", s.name));
            }
            if !unit(s.orientation) {
                return Err(format!("actor '{}': orientation is not a unit quaternion", s.name));
            }
        }
        let n = self.actors.len();
        let mut cache = Vec::with_capacity(self.warm_start.len());
        for (k, c) in self.warm_start.iter().enumerate() {
            let entry = c.cached().map_err(|e| format!("warm_start[{k}]: {e}"))?;
            let [a, b] = c.pair;
            if a >= b || b as usize >= n {
                return Err(format!("warm_start[{k}]: pair [{a}, {b}] is not two actors a < b of {n}"));
            }
            if cache.last().is_some_and(|&(last, _)| last >= (a, b)) {
                return Err(format!("warm_start[{k}]: pairs must be in increasing order"));
            }
            cache.push(((a, b), entry));
        }
        let sleep = match &self.sleep {
            Some(s) => s.state(n)?,
            None => SleepState::default(),
        };
        let joint_count = sim.ctx.scratch.get::<Joints>().map_or(0, |j| j.joints.len());
        if !self.joints.is_empty() && self.joints.len() != joint_count {
            return Err(format!("joints: {} rows for a scene of {joint_count} joints", self.joints.len()));
        }
        if let Some(k) = self.joints.iter().position(|r| !finite(r)) {
            return Err(format!("joints[{k}]: not finite"));
        }
        let mut query = sim.world.query::<(&crate::model::components::ActorIndex, &mut Pose, &mut Velocity)>();
        for (index, pose, vel) in query.iter() {
            let s = &self.actors[index.0 as usize];
            *pose = Pose { position: Vector::from_array(s.position), orientation: Quat::from_array(s.orientation) };
            *vel = Velocity { linear: Vector::from_array(s.velocity), angular: Vector::from_array(s.angular_velocity) };
        }
        drop(query);
        sim.time = self.time;
        sim.steps = self.steps;
        sim.impulses = self.contacts;
        sim.ctx.scratch.get_mut::<SolveScratch>().set_cache(cache);
        sim.ctx.sleep = sleep;
        if !self.joints.is_empty() {
            let joints = sim.ctx.scratch.get_mut::<Joints>();
            joints.impulses = self.joints.iter().map(joint_impulses).collect();
        }
        Ok(())
    }
}

/// A joint's impulses as a snapshot row.
fn joint_row(j: &JointImpulses) -> [f64; 10] {
    let [p, a] = [j.point.to_array(), j.angular.to_array()];
    [p[0], p[1], p[2], a[0], a[1], a[2], j.axial, j.limits[0], j.limits[1], j.motor]
}

/// A snapshot row as a joint's impulses.
fn joint_impulses(r: &[f64; 10]) -> JointImpulses {
    JointImpulses {
        point: Vector::new(r[0], r[1], r[2]),
        angular: Vector::new(r[3], r[4], r[5]),
        axial: r[6],
        limits: [r[7], r[8]],
        motor: r[9],
    }
}

/// All finite: the state read back must not carry NaN into the run.
fn finite(xs: &[f64]) -> bool {
    xs.iter().all(|x| x.is_finite())
}

/// A unit quaternion `[x, y, z, w]`, to within what the run's normalising leaves.
fn unit(q: [f64; 4]) -> bool {
    (Quat::from_array(q).length() - 1.0).abs() <= 1e-9
}

impl ContactSnapshot {
    fn of(pair: [u32; 2], c: &CachedManifold) -> Self {
        let g = &c.anchors;
        Self {
            pair,
            offset: g.offset.to_array(),
            turn: g.turn.to_array(),
            normal: g.normal.to_array(),
            on_a: g.on_a[..g.len].iter().map(|v| v.to_array()).collect(),
            on_b: g.on_b[..g.len].iter().map(|v| v.to_array()).collect(),
            impulses: c.normal[..g.len].to_vec(),
            tangent: c.tangent.to_array(),
            twist: c.twist.to_array(),
            found: c.found.map(|f| f.name().to_string()),
            axis: g.axis.map(|r| match r {
                Reference::FaceOfB(f) => format!("b:{f}"),
                Reference::FaceOfA(f) => format!("a:{f}"),
                Reference::Edges => "edges".to_string(),
            }),
        }
    }

    /// The cache entry, or what is wrong with it.
    fn cached(&self) -> Result<CachedManifold, String> {
        let len = self.impulses.len();
        if len > MAX_POINTS || self.on_a.len() != len || self.on_b.len() != len {
            return Err(format!("on_a, on_b and impulses must have the same length, at most {MAX_POINTS}"));
        }
        let vectors = [self.offset, self.normal, self.tangent, self.twist];
        let points = self.on_a.iter().chain(&self.on_b);
        if !finite(&self.turn) || !vectors.iter().chain(points).all(|v| finite(v)) || !finite(&self.impulses) {
            return Err("non-finite value".to_string());
        }
        if !unit(self.turn) {
            return Err("turn is not a unit quaternion".to_string());
        }
        if self.impulses.iter().any(|&j| j < 0.0) {
            return Err("a normal impulse is negative (they push, never pull)".to_string());
        }
        let mut g = ContactAnchors {
            offset: Vector::from_array(self.offset),
            turn: Quat::from_array(self.turn),
            normal: Vector::from_array(self.normal),
            len,
            ..ContactAnchors::default()
        };
        let found = match self.found.as_deref() {
            None => None,
            Some(name) => Some(
                Feature::ALL
                    .into_iter()
                    .find(|f| f.name() == name)
                    .ok_or_else(|| format!("found: '{name}' is not face, vertex or edge"))?,
            ),
        };
        let face = |f: &str| f.parse::<u32>().map_err(|_| format!("axis: '{f}' is not a face index"));
        g.axis = match self.axis.as_deref() {
            None => None,
            Some("edges") => Some(Reference::Edges),
            Some(s) if s.starts_with("b:") => Some(Reference::FaceOfB(face(&s[2..])?)),
            Some(s) if s.starts_with("a:") => Some(Reference::FaceOfA(face(&s[2..])?)),
            Some(s) => return Err(format!("axis: '{s}' is not b:F, a:F or edges")),
        };
        let mut entry = CachedManifold {
            tangent: Vector::from_array(self.tangent),
            twist: Vector::from_array(self.twist),
            found,
            ..CachedManifold::default()
        };
        for k in 0..len {
            (g.on_a[k], g.on_b[k]) = (Vector::from_array(self.on_a[k]), Vector::from_array(self.on_b[k]));
        }
        entry.normal[..len].copy_from_slice(&self.impulses);
        entry.anchors = g;
        Ok(entry)
    }
}

impl SleepSnapshot {
    fn of(s: &SleepState) -> Self {
        Self {
            still: s.still.clone(),
            asleep: s.asleep.clone(),
            reached: s.reached.iter().map(|v| (!v.is_nan()).then(|| v.to_array())).collect(),
        }
    }

    /// The sleep state for `n` actors, or what is wrong.
    fn state(&self, n: usize) -> Result<SleepState, String> {
        if self.still.len() != n || self.asleep.len() != n || self.reached.len() != n {
            return Err(format!("sleep: still, asleep and reached must have one entry per actor ({n})"));
        }
        if self.still.iter().any(|t| !t.is_finite() || *t < 0.0) || !self.reached.iter().flatten().all(|v| finite(v)) {
            return Err("sleep: non-finite or negative value".to_string());
        }
        Ok(SleepState {
            still: self.still.clone(),
            asleep: self.asleep.clone(),
            reached: self.reached.iter().map(|v| v.map_or(Vector::NAN, Vector::from_array)).collect(),
            ..SleepState::default()
        })
    }
}
