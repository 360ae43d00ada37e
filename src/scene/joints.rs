//! Joints in scene files (docs/joints.md): the RON forms, their checks (values while parsing,
//! with `file:line:col`; actor names after parsing, pointed at in the text), and building
//! them into the simulation's joint set. Degrees become radians here.

use crate::error::SceneError;
use crate::math::{Quat, Scalar, Vector};
use crate::scene::{SceneDef, V3, invalid, vector};
use crate::sim::Sim;
use crate::solver::{Joint, JointKind, Joints, Motor, Spring};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::Path;

/// A motor as written: `Motor(speed: .., max_torque: ..)` on a hinge, `max_force` on a slider.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Motor")]
struct RawMotor {
    speed: Scalar,
    #[serde(default)]
    max_torque: Option<Scalar>,
    #[serde(default)]
    max_force: Option<Scalar>,
}

/// A spring as written: `Spring(frequency: .., damping_ratio: ..)`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Spring")]
struct RawSpring {
    frequency: Scalar,
    #[serde(default)]
    damping_ratio: Scalar,
}

/// A joint as written (checked into `JointDef`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
enum RawJoint {
    Ball {
        #[serde(default)]
        name: Option<String>,
        a: String,
        #[serde(default)]
        b: Option<String>,
        #[serde(default)]
        collide: bool,
        anchor: V3,
        #[serde(default)]
        cone: Option<Scalar>,
    },
    Hinge {
        #[serde(default)]
        name: Option<String>,
        a: String,
        #[serde(default)]
        b: Option<String>,
        #[serde(default)]
        collide: bool,
        anchor: V3,
        axis: V3,
        #[serde(default)]
        limits: Option<(Scalar, Scalar)>,
        #[serde(default)]
        motor: Option<RawMotor>,
    },
    Slider {
        #[serde(default)]
        name: Option<String>,
        a: String,
        #[serde(default)]
        b: Option<String>,
        #[serde(default)]
        collide: bool,
        anchor: V3,
        axis: V3,
        #[serde(default)]
        limits: Option<(Scalar, Scalar)>,
        #[serde(default)]
        motor: Option<RawMotor>,
    },
    Fixed {
        #[serde(default)]
        name: Option<String>,
        a: String,
        #[serde(default)]
        b: Option<String>,
        #[serde(default)]
        collide: bool,
    },
    Distance {
        #[serde(default)]
        name: Option<String>,
        a: String,
        #[serde(default)]
        b: Option<String>,
        #[serde(default)]
        collide: bool,
        anchor_a: V3,
        anchor_b: V3,
        #[serde(default)]
        min: Option<Scalar>,
        #[serde(default)]
        max: Option<Scalar>,
        #[serde(default)]
        spring: Option<RawSpring>,
    },
}

/// A checked joint: names of its actors, what it holds (angles in radians), its anchors and
/// axis in world coordinates at the start.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(try_from = "RawJoint")]
pub struct JointDef {
    /// Name, if given (default `joint-<index>`).
    pub name: Option<String>,
    /// Actor A.
    pub a: String,
    /// Actor B, or `None` for the world.
    pub b: Option<String>,
    /// The two actors still collide with each other.
    pub collide: bool,
    /// What it holds.
    pub kind: JointKind,
    /// Anchors on A and on B [m], or `None` for a weld (`Fixed`), anchored between the centres.
    pub anchors: Option<[Vector; 2]>,
    /// The axis (hinge, slider; zero for the others).
    pub axis: Vector,
}

impl JointDef {
    /// The joint's name: its own, or `joint-<index>`.
    #[must_use]
    pub fn name_or(&self, index: usize) -> String {
        self.name.clone().unwrap_or_else(|| format!("joint-{index}"))
    }
}

type Fail = (String, String);

fn finite(field: &str, v: V3) -> Result<Vector, Fail> {
    let v = vector(v);
    if crate::math::is_finite_vector(v) { Ok(v) } else { Err((field.into(), format!("must be finite, got {v}"))) }
}

fn axis(v: V3) -> Result<Vector, Fail> {
    let v = finite("axis", v)?;
    if v.length() > 1e-9 { Ok(v) } else { Err(("axis".into(), "must not be zero".into())) }
}

fn at_least_zero(field: &str, v: Scalar, unit: &str) -> Result<Scalar, Fail> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err((field.into(), format!("must be a finite number >= 0 {unit}, got {v}")))
    }
}

/// Limits `(lo, hi)` in file units, checked, scaled by `to_si`; hinge turns within ±180°.
fn limits(l: Option<(Scalar, Scalar)>, bound: Scalar, to_si: Scalar) -> Result<Option<[Scalar; 2]>, Fail> {
    let Some((lo, hi)) = l else { return Ok(None) };
    if !(lo.is_finite() && hi.is_finite()) || lo > hi {
        return Err(("limits".into(), format!("must be finite with lo <= hi, got ({lo}, {hi})")));
    }
    if lo < -bound || hi > bound {
        return Err(("limits".into(), format!("must be within -{bound}..={bound}, got ({lo}, {hi})")));
    }
    Ok(Some([lo * to_si, hi * to_si]))
}

/// A motor; `field` names the largest effort this kind takes (`max_torque` or `max_force`).
fn motor(m: Option<RawMotor>, field: &str) -> Result<Option<Motor>, Fail> {
    let Some(m) = m else { return Ok(None) };
    let (wanted, other) = if field == "max_torque" { (m.max_torque, m.max_force) } else { (m.max_force, m.max_torque) };
    if other.is_some() {
        let other = if field == "max_torque" { "max_force" } else { "max_torque" };
        return Err((format!("motor.{other}"), format!("this joint's motor takes `{field}`")));
    }
    let Some(max) = wanted else { return Err((format!("motor.{field}"), "is required".into())) };
    if !m.speed.is_finite() {
        return Err(("motor.speed".into(), format!("must be finite, got {}", m.speed)));
    }
    let unit = if field == "max_torque" { "N*m" } else { "N" };
    Ok(Some(Motor { speed: m.speed, max: at_least_zero(&format!("motor.{field}"), max, unit)? }))
}

impl TryFrom<RawJoint> for JointDef {
    type Error = String;

    fn try_from(raw: RawJoint) -> Result<Self, String> {
        let (name, a, b, collide) = match &raw {
            RawJoint::Ball { name, a, b, collide, .. }
            | RawJoint::Hinge { name, a, b, collide, .. }
            | RawJoint::Slider { name, a, b, collide, .. }
            | RawJoint::Fixed { name, a, b, collide }
            | RawJoint::Distance { name, a, b, collide, .. } => (name.clone(), a.clone(), b.clone(), *collide),
        };
        let who = name.as_deref().map_or_else(|| "joint".to_string(), |n| format!("joint '{n}'"));
        let fail = |(field, reason): Fail| format!("{who}: {field}: {reason}");
        if name.as_deref() == Some("") {
            return Err(fail(("name".into(), "must not be empty".into())));
        }
        let deg = std::f64::consts::PI / 180.0;
        let (kind, anchors, axis) = match raw {
            RawJoint::Ball { anchor, cone, .. } => {
                let anchor = finite("anchor", anchor).map_err(fail)?;
                if let Some(c) = cone
                    && !(c.is_finite() && c > 0.0 && c <= 180.0)
                {
                    return Err(fail(("cone".into(), format!("must be in (0, 180] degrees, got {c}"))));
                }
                (JointKind::Ball { cone: cone.map(|c| c * deg) }, Some([anchor; 2]), Vector::ZERO)
            }
            RawJoint::Hinge { anchor, axis: ax, limits: l, motor: m, .. } => {
                let anchor = finite("anchor", anchor).map_err(fail)?;
                let kind = JointKind::Hinge {
                    limits: limits(l, 180.0, deg).map_err(fail)?,
                    motor: motor(m, "max_torque").map_err(fail)?,
                };
                (kind, Some([anchor; 2]), axis(ax).map_err(fail)?)
            }
            RawJoint::Slider { anchor, axis: ax, limits: l, motor: m, .. } => {
                let anchor = finite("anchor", anchor).map_err(fail)?;
                let kind = JointKind::Slider {
                    limits: limits(l, Scalar::MAX, 1.0).map_err(fail)?,
                    motor: motor(m, "max_force").map_err(fail)?,
                };
                (kind, Some([anchor; 2]), axis(ax).map_err(fail)?)
            }
            RawJoint::Fixed { .. } => (JointKind::Fixed, None, Vector::ZERO),
            RawJoint::Distance { anchor_a, anchor_b, min, max, spring, .. } => {
                let anchors =
                    [finite("anchor_a", anchor_a).map_err(fail)?, finite("anchor_b", anchor_b).map_err(fail)?];
                let lo = min.map(|v| at_least_zero("min", v, "m")).transpose().map_err(fail)?;
                let hi = max.map(|v| at_least_zero("max", v, "m")).transpose().map_err(fail)?;
                let range = [lo.unwrap_or(0.0), hi.unwrap_or(Scalar::INFINITY)];
                if range[0] > range[1] {
                    return Err(fail(("min".into(), format!("must be <= max, got {} > {}", range[0], range[1]))));
                }
                let spring = match spring {
                    Some(s) => Some(Spring {
                        frequency: at_least_zero("spring.frequency", s.frequency, "Hz").map_err(fail)?,
                        damping_ratio: at_least_zero("spring.damping_ratio", s.damping_ratio, "").map_err(fail)?,
                    }),
                    None => None,
                };
                let rod = lo.is_none() && hi.is_none() && spring.is_none();
                (JointKind::Distance { rod, range, spring }, Some(anchors), Vector::ZERO)
            }
        };
        Ok(Self { name, a, b, collide, kind, anchors, axis })
    }
}

/// How to name a joint without a `name` whose text ends at `offset`: by its place in `joints`.
#[must_use]
pub fn unnamed_joint(text: &str, offset: usize) -> String {
    let before = text.get(..offset).unwrap_or(text);
    let index = joint_starts(before).len().saturating_sub(1);
    format!("joint #{index} (no name; it would be 'joint-{index}')")
}

/// The offsets where the joints of the `joints` list begin in `text` (a kind's name and its
/// opening parenthesis).
fn joint_starts(text: &str) -> Vec<usize> {
    let Some(list) = text.find("joints") else { return Vec::new() };
    let mut out = Vec::new();
    let bytes = text.as_bytes();
    for (at, _) in text[list..].char_indices() {
        let at = list + at;
        let boundary = at == 0 || !(bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_');
        let rest = &text[at..];
        let kind = ["Ball", "Hinge", "Slider", "Fixed", "Distance"]
            .iter()
            .any(|k| rest.strip_prefix(k).is_some_and(|r| r.trim_start().starts_with('(')));
        if boundary && kind {
            out.push(at);
        }
    }
    out
}

/// Checks what only the whole scene can tell: each joint's actors exist, differ and are not
/// both fixed (or fixed and joined to the world), and joint names are unique. The error
/// points at the joint's field in `text` where it can be found.
pub(crate) fn check_references(scene: &SceneDef, text: &str, path: &Path) -> Result<(), SceneError> {
    if scene.joints.is_empty() {
        return Ok(());
    }
    // The spawners' actors too; a spawner that is wrong itself is reported by `build`.
    let Ok(instances) = crate::scene::instantiate::instances(scene, path) else { return Ok(()) };
    let fixed: HashMap<&str, bool> = instances.iter().map(|i| (i.name.as_str(), i.fixed)).collect();
    let starts = joint_starts(text);
    let mut names = HashMap::new();
    for (k, j) in scene.joints.iter().enumerate() {
        let name = j.name_or(k);
        let fail = |field: &str, needle: Option<&str>, reason: String| {
            let start = starts.get(k).copied();
            let at = start.map(|s| {
                let end = starts.get(k + 1).copied().unwrap_or(text.len());
                needle.and_then(|n| text[s..end].find(n)).map_or(s, |i| s + i)
            });
            located(path, text, at, format!("joint '{name}': {field}: {reason}"))
        };
        let quoted = |s: &str| format!("\"{s}\"");
        let Some(&a_fixed) = fixed.get(j.a.as_str()) else {
            return Err(fail("a", Some(&quoted(&j.a)), format!("no actor named '{}'", j.a)));
        };
        let b_fixed = match &j.b {
            Some(b) => {
                let Some(&f) = fixed.get(b.as_str()) else {
                    return Err(fail("b", Some(&quoted(b)), format!("no actor named '{b}'")));
                };
                if *b == j.a {
                    return Err(fail("b", Some(&quoted(b)), "must differ from `a`: a joint joins two actors".into()));
                }
                f
            }
            None => true,
        };
        if a_fixed && b_fixed {
            let reason = "both ends are fixed (or fixed and the world): the joint could move nothing".into();
            return Err(fail("a", Some(&quoted(&j.a)), reason));
        }
        if let Some(first) = names.insert(name.clone(), k) {
            return Err(fail("name", Some("name"), format!("joint #{first} has the same name; names must be unique")));
        }
    }
    Ok(())
}

/// A `Parse` error at `offset` in `text` (or a plain `Invalid` one without a place).
fn located(path: &Path, text: &str, offset: Option<usize>, message: String) -> SceneError {
    match offset {
        Some(offset) => crate::scene::error_at(path, text, (offset, 1), message),
        None => invalid(path, "scene", "joints", message),
    }
}

/// Adds the scene's joints to `sim` (its actors spawned), fixed to the actors' start poses.
pub fn build_joints(scene: &SceneDef, sim: &mut Sim, path: &Path) -> Result<(), SceneError> {
    if scene.joints.is_empty() {
        return Ok(());
    }
    let index: HashMap<&str, u32> = sim.names().iter().enumerate().map(|(i, n)| (n.as_str(), i as u32)).collect();
    let actors = sim.actors();
    let mut joints = Vec::with_capacity(scene.joints.len());
    for (k, j) in scene.joints.iter().enumerate() {
        let name = j.name_or(k);
        let find = |field: &str, actor: &str| {
            index.get(actor).copied().ok_or_else(|| {
                invalid(path, "scene", &format!("joints: joint '{name}': {field}"), format!("no actor named '{actor}'"))
            })
        };
        let a = find("a", &j.a)?;
        let b = j.b.as_deref().map(|b| find("b", b)).transpose()?;
        let pose = |i: u32| (actors[i as usize].pose.position, actors[i as usize].pose.orientation);
        let (pa, pb) = (pose(a), b.map_or((Vector::ZERO, Quat::IDENTITY), pose));
        // A weld holds at the midpoint of the centres (at A's centre to the world).
        let anchors = j.anchors.unwrap_or_else(|| {
            let mid = if b.is_some() { 0.5 * (pa.0 + pb.0) } else { pa.0 };
            [mid; 2]
        });
        let mut joint = Joint::new(name, (a, b), j.kind, anchors, j.axis, [pa, pb]);
        joint.collide = j.collide;
        joints.push(joint);
    }
    *sim.ctx.scratch.get_mut::<Joints>() = Joints::new(joints);
    Ok(())
}
