//! Snapshots: the complete state of a run, so `rigid run --resume` continues it bit for bit
//! (100 + 100 steps give the same bits as 200). A snapshot embeds the scene's text (meshes
//! and settings are rebuilt from it) and every actor's pose and velocities; JSON floats are
//! written shortest-round-trip and read back exactly.

use crate::components::{Pose, Velocity};
use crate::math::{Quat, Vector};
use crate::sim::Sim;
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
            contacts: sim.contacts,
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
            let finite = s
                .position
                .iter()
                .chain(&s.orientation)
                .chain(&s.velocity)
                .chain(&s.angular_velocity)
                .all(|x| x.is_finite());
            if !finite {
                return Err(format!("actor '{}': non-finite state", s.name));
            }
            let q = Quat::from_array(s.orientation);
            if (q.length() - 1.0).abs() > 1e-9 {
                return Err(format!("actor '{}': orientation is not a unit quaternion", s.name));
            }
        }
        let mut query = sim.world.query::<(&crate::components::ActorIndex, &mut Pose, &mut Velocity)>();
        for (index, pose, vel) in query.iter() {
            let s = &self.actors[index.0 as usize];
            *pose = Pose { position: Vector::from_array(s.position), orientation: Quat::from_array(s.orientation) };
            *vel = Velocity { linear: Vector::from_array(s.velocity), angular: Vector::from_array(s.angular_velocity) };
        }
        drop(query);
        sim.time = self.time;
        sim.steps = self.steps;
        sim.contacts = self.contacts;
        Ok(())
    }
}
