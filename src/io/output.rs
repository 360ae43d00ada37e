//! Output files: the final-state JSON and the trajectory CSV (docs/cli.md). Floats are
//! printed so they round-trip an f64; files are written atomically (temp file + rename), so a
//! failed run never leaves a half-written file.

use crate::collision::contact::Feature;
use crate::sim::{ActorState, Sim, totals};
use crate::solver::Joints;
use serde::Serialize;
use std::io::Write;
use std::path::Path;

#[derive(Serialize)]
struct ActorJson<'a> {
    name: &'a str,
    position: [f64; 3],
    orientation: [f64; 4],
    velocity: [f64; 3],
    angular_velocity: [f64; 3],
    mass: f64,
    fixed: bool,
}

#[derive(Serialize)]
struct TotalsJson {
    linear_momentum: [f64; 3],
    angular_momentum: [f64; 3],
    kinetic_energy: f64,
}

#[derive(Serialize)]
struct StateJson<'a> {
    time: f64,
    steps: u64,
    actors: Vec<ActorJson<'a>>,
    totals: TotalsJson,
    contacts: serde_json::Map<String, serde_json::Value>,
    /// Absent without joints, so scenes without them write what they always did.
    #[serde(skip_serializing_if = "Option::is_none")]
    joints: Option<Vec<JointJson<'a>>>,
    state_hash: String,
}

/// A joint and how far it is from holding (docs/joints.md).
#[derive(Serialize)]
struct JointJson<'a> {
    name: &'a str,
    kind: &'static str,
    a: &'a str,
    b: Option<&'a str>,
    /// [m].
    position_error: f64,
    /// [rad].
    angle_error: f64,
}

/// The joints' section of the final state, or `None` for a scene without joints.
fn joints_json<'a>(sim: &'a Sim, actors: &[ActorState]) -> Option<Vec<JointJson<'a>>> {
    let joints = sim.ctx.scratch.get::<Joints>().filter(|j| !j.joints.is_empty())?;
    let poses: Vec<_> = actors.iter().map(|a| (a.pose.position, a.pose.orientation)).collect();
    let names = sim.names();
    let rows = joints.joints.iter().zip(joints.errors(&poses)).map(|(j, (position_error, angle_error))| JointJson {
        name: &j.name,
        kind: j.kind.name(),
        a: &names[j.a as usize],
        b: j.b.map(|b| names[b as usize].as_str()),
        position_error,
        angle_error,
    });
    Some(rows.collect())
}

/// The final-state document of docs/cli.md (plus `state_hash`, see `state_hash`).
#[must_use]
pub fn state_json(sim: &Sim, actors: &[ActorState]) -> String {
    let t = totals(actors);
    let contacts = Feature::ALL.iter().map(|f| (f.name().to_string(), sim.impulses[*f as usize].into())).collect();
    let doc = StateJson {
        time: sim.time,
        steps: sim.steps,
        actors: actors
            .iter()
            .map(|a| ActorJson {
                name: &a.name,
                position: a.pose.position.to_array(),
                orientation: a.pose.orientation.to_array(),
                velocity: a.velocity.linear.to_array(),
                angular_velocity: a.velocity.angular.to_array(),
                mass: a.mass.mass,
                fixed: a.mass.is_fixed(),
            })
            .collect(),
        totals: TotalsJson {
            linear_momentum: t.linear_momentum.to_array(),
            angular_momentum: t.angular_momentum.to_array(),
            kinetic_energy: t.kinetic_energy,
        },
        contacts,
        joints: joints_json(sim, actors),
        state_hash: format!("{:016x}", state_hash(actors)),
    };
    serde_json::to_string_pretty(&doc).expect("plain data serialises")
}

/// FNV-1a over the bits of every pose and velocity, in actor order: equal hashes mean (up to
/// a 2⁻⁶⁴ accident) bit-identical states, so runs can be compared cheaply.
#[must_use]
pub fn state_hash(actors: &[ActorState]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let q = |a: &ActorState| a.pose.orientation.to_array();
    for a in actors {
        let values = a
            .pose
            .position
            .to_array()
            .into_iter()
            .chain(q(a))
            .chain(a.velocity.linear.to_array())
            .chain(a.velocity.angular.to_array());
        for v in values {
            for byte in v.to_bits().to_le_bytes() {
                h = (h ^ u64::from(byte)).wrapping_mul(0x0100_0000_01b3);
            }
        }
    }
    h
}

/// CSV header of the trajectory file.
pub const TRAJECTORY_HEADER: &str = "step,time,name,px,py,pz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz";

/// Appends one row per actor for `step` at `time`.
pub fn trajectory_rows(out: &mut impl Write, step: u64, time: f64, actors: &[ActorState]) -> std::io::Result<()> {
    for a in actors {
        let (p, q, v, w) = (a.pose.position, a.pose.orientation, a.velocity.linear, a.velocity.angular);
        writeln!(
            out,
            "{step},{time},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            csv_field(&a.name),
            p.x,
            p.y,
            p.z,
            q.x,
            q.y,
            q.z,
            q.w,
            v.x,
            v.y,
            v.z,
            w.x,
            w.y,
            w.z
        )?;
    }
    Ok(())
}

/// Quotes a name holding a comma, quote or line break (RFC 4180).
fn csv_field(s: &str) -> std::borrow::Cow<'_, str> {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")).into() } else { s.into() }
}

/// Writes `contents` to `path` atomically: a temp file beside it, then a rename.
pub fn write_atomic(path: &Path, contents: &[u8]) -> std::io::Result<()> {
    let tmp = temp_path(path);
    let result = std::fs::write(&tmp, contents).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// The temporary name used while writing `path`.
#[must_use]
pub fn temp_path(path: &Path) -> std::path::PathBuf {
    let mut name = path.file_name().map(std::ffi::OsStr::to_os_string).unwrap_or_default();
    name.push(".tmp");
    path.with_file_name(name)
}
