//! The running scene's joints for the studio: where their anchors are now (`/api/state`), their
//! anchors in the bodies' frames for the page to place from each frame's poses (`/api/meshes`),
//! and as RON for a saved scene (`GET /api/scene`).

use super::save::{num, quoted, v3};
use crate::math::{Quat, Scalar, Vector};
use crate::sim::Sim;
use crate::solver::{Frame, Joint, JointKind, Joints};
use serde_json::{Value, json};
use std::fmt::Write as _;

const WORLD: Frame = (Vector::ZERO, Quat::IDENTITY);

/// The scene's joints, in the scene's order (none when it has none).
fn joints(sim: &Sim) -> &[Joint] {
    sim.ctx.scratch.get::<Joints>().map_or(&[], |j| j.joints.as_slice())
}

/// Every actor's pose, by actor index.
fn poses(sim: &Sim) -> Vec<Frame> {
    sim.actors().iter().map(|a| (a.pose.position, a.pose.orientation)).collect()
}

/// A joint's two ends' poses (the world's for a joint to the world).
fn ends(j: &Joint, poses: &[Frame]) -> (Frame, Frame) {
    (poses[j.a as usize], j.b.map_or(WORLD, |b| poses[b as usize]))
}

/// The two anchor points in world coordinates at these poses.
fn world_anchors(j: &Joint, (xa, qa): Frame, (xb, qb): Frame) -> [Vector; 2] {
    [xa + qa * j.anchor_a, xb + qb * j.anchor_b]
}

/// `/api/state`'s `joints`: name, kind, the actors' names (`b` null for the world), both anchors
/// in world coordinates now and how far the joint is violated (as `--out` reports it).
pub(crate) fn state(sim: &Sim) -> Vec<Value> {
    let poses = poses(sim);
    let names = sim.names();
    joints(sim)
        .iter()
        .map(|j| {
            let (pa, pb) = ends(j, &poses);
            let [on_a, on_b] = world_anchors(j, pa, pb);
            let (position_error, angle_error) = j.errors(pa, pb);
            json!({
                "name": j.name,
                "kind": j.kind.name(),
                "a": names[j.a as usize],
                "b": j.b.map(|b| names[b as usize].clone()),
                "anchor_a": on_a.to_array(),
                "anchor_b": on_b.to_array(),
                "position_error": position_error,
                "angle_error": angle_error,
            })
        })
        .collect()
}

/// `/api/meshes`' `joints`: the actors by index and the anchors in their body frames (the world
/// frame for the world), so the page places them from each frame's poses with no more bytes.
pub(crate) fn frames(sim: &Sim) -> Vec<Value> {
    joints(sim)
        .iter()
        .map(|j| {
            json!({
                "name": j.name,
                "kind": j.kind.name(),
                "a": j.a,
                "b": j.b,
                "anchor_a": j.anchor_a.to_array(),
                "anchor_b": j.anchor_b.to_array(),
            })
        })
        .collect()
}

/// The degrees that the scene reader turns back into exactly `radians`.
fn degrees(radians: Scalar) -> Scalar {
    let to_radians = std::f64::consts::PI / 180.0;
    let mut d = radians / to_radians;
    // One division can miss by an ulp; the reader multiplies, so step to the value it maps back.
    for _ in 0..4 {
        let back = d * to_radians;
        if back == radians {
            break;
        }
        d = if back < radians { d.next_up() } else { d.next_down() };
    }
    d
}

/// A's turn about the hinge's axis since the start [rad], as the solver measures it.
fn turn(j: &Joint, (_, qa): Frame, (_, qb): Frame) -> Scalar {
    let e = qa * (qb * j.rest).inverse();
    let e = if e.w < 0.0 { -e } else { e };
    2.0 * Vector::new(e.x, e.y, e.z).dot(qb * j.axis_b).atan2(e.w)
}

/// The `joints: [...]` field of a saved scene, each joint as it stands now: a scene's anchors
/// and axes are world coordinates at its start, and the saved scene starts here. Hinge and
/// slider limits are shifted by the turn or slide so far, so they stay where they were; a ball
/// joint's cone is centred on the limb as it is now, and a spring pulls to the distance now.
pub(crate) fn ron(sim: &Sim) -> String {
    let joints = joints(sim);
    if joints.is_empty() {
        return String::new();
    }
    let poses = poses(sim);
    let names = sim.names();
    let mut out = String::from("    joints: [\n");
    for j in joints {
        let (pa, pb) = ends(j, &poses);
        let [on_a, on_b] = world_anchors(j, pa, pb);
        let axis = pb.1 * j.axis_b;
        let _ = write!(out, "        {}(name: {}, a: {}", j.kind.name(), quoted(&j.name), quoted(&names[j.a as usize]));
        if let Some(b) = j.b {
            let _ = write!(out, ", b: {}", quoted(&names[b as usize]));
        }
        if j.collide {
            out.push_str(", collide: true");
        }
        match j.kind {
            JointKind::Ball { cone } => {
                let _ = write!(out, ", anchor: {}", v3(on_a));
                if let Some(c) = cone {
                    let _ = write!(out, ", cone: {}", num(degrees(c)));
                }
            }
            JointKind::Hinge { limits, motor } => {
                let _ = write!(out, ", anchor: {}, axis: {}", v3(on_a), v3(axis));
                if let Some([lo, hi]) = limits {
                    let t = turn(j, pa, pb);
                    let shift = |x: Scalar| num(degrees(x - t).clamp(-180.0, 180.0));
                    let _ = write!(out, ", limits: ({}, {})", shift(lo), shift(hi));
                }
                if let Some(m) = motor {
                    let _ = write!(out, ", motor: Motor(speed: {}, max_torque: {})", num(m.speed), num(m.max));
                }
            }
            JointKind::Slider { limits, motor } => {
                let _ = write!(out, ", anchor: {}, axis: {}", v3(on_a), v3(axis));
                if let Some([lo, hi]) = limits {
                    let slide = (on_a - on_b).dot(axis);
                    let _ = write!(out, ", limits: ({}, {})", num(lo - slide), num(hi - slide));
                }
                if let Some(m) = motor {
                    let _ = write!(out, ", motor: Motor(speed: {}, max_force: {})", num(m.speed), num(m.max));
                }
            }
            JointKind::Fixed => {}
            JointKind::Distance { rod, range: [lo, hi], spring } => {
                let _ = write!(out, ", anchor_a: {}, anchor_b: {}", v3(on_a), v3(on_b));
                // A rod has no range; anything else keeps `min`, so it reads back as no rod.
                if !rod {
                    let _ = write!(out, ", min: {}", num(lo));
                    if hi.is_finite() {
                        let _ = write!(out, ", max: {}", num(hi));
                    }
                }
                if let Some(s) = spring {
                    let _ = write!(
                        out,
                        ", spring: Spring(frequency: {}, damping_ratio: {})",
                        num(s.frequency),
                        num(s.damping_ratio)
                    );
                }
            }
        }
        out.push_str("),\n");
    }
    out.push_str("    ],\n");
    out
}

#[cfg(test)]
mod tests {
    use super::degrees;

    #[test]
    fn degrees_read_back_to_the_same_radians() {
        for d in [0.0, 1.0, 40.0, 90.0, 140.0, -90.0, 180.0, 33.3, 1e-9] {
            let r = d * (std::f64::consts::PI / 180.0);
            assert_eq!(degrees(r) * (std::f64::consts::PI / 180.0), r, "{d}");
        }
    }
}
