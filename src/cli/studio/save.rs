//! Edits of actors made through the studio (kept across resets) and the scene written back as
//! RON (`GET /api/scene`, docs/studio.md).

use super::Studio;
use crate::math::{Scalar, Vector};
use crate::model::components::{ActorIndex, MassProps, Material, Mesh, Name, Pose, Velocity};
use crate::scene::ShapeDef;
use crate::sim::Sim;
use serde_json::Value;
use std::fmt::Write as _;

/// One actor's edited values; `None` leaves a value as the scene has it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct ActorEdit {
    /// Mass [kg]; the inertia keeps its shape.
    pub mass: Option<Scalar>,
    /// 0..=1.
    pub restitution: Option<Scalar>,
    /// ≥ 0.
    pub friction: Option<Scalar>,
    /// Linear velocity [m/s].
    pub velocity: Option<Vector>,
}

impl ActorEdit {
    /// Reads `{"name": ..., "mass"?, "restitution"?, "friction"?, "velocity"?}`; `Err` says what
    /// is wrong.
    pub fn from_json(v: &Value) -> Result<(String, Self), String> {
        let Some(obj) = v.as_object() else {
            return Err("expected a JSON object: {\"name\": ..., \"mass\"?, \"restitution\"?, \"friction\"?, \
                        \"velocity\"?}"
                .into());
        };
        if let Some(k) =
            obj.keys().find(|k| !["name", "mass", "restitution", "friction", "velocity"].contains(&k.as_str()))
        {
            return Err(format!("unknown field '{k}'; valid: name, mass, restitution, friction, velocity"));
        }
        let name = obj.get("name").and_then(Value::as_str).ok_or("missing \"name\": the actor's name")?.to_string();
        let number = |field: &str| -> Result<Option<Scalar>, String> {
            match obj.get(field) {
                None => Ok(None),
                Some(x) => match x.as_f64() {
                    Some(x) if x.is_finite() => Ok(Some(x)),
                    _ => Err(format!("{field} must be a finite number, got {x}")),
                },
            }
        };
        let mass = number("mass")?;
        if let Some(m) = mass
            && m <= 0.0
        {
            return Err(format!("mass must be a finite number > 0 kg, got {m}"));
        }
        let restitution = number("restitution")?;
        if let Some(r) = restitution
            && !(0.0..=1.0).contains(&r)
        {
            return Err(format!("restitution must be in 0..=1, got {r}"));
        }
        let friction = number("friction")?;
        if let Some(f) = friction
            && f < 0.0
        {
            return Err(format!("friction must be a finite number >= 0, got {f}"));
        }
        let velocity = match obj.get("velocity") {
            None => None,
            Some(x) => {
                let parts: Option<Vec<f64>> =
                    x.as_array().map(|a| a.iter().map(Value::as_f64).collect::<Option<Vec<_>>>()).unwrap_or(None);
                match parts.as_deref() {
                    Some(&[a, b, c]) if a.is_finite() && b.is_finite() && c.is_finite() => Some(Vector::new(a, b, c)),
                    _ => return Err(format!("velocity must be [x, y, z] of finite numbers [m/s], got {x}")),
                }
            }
        };
        Ok((name, Self { mass, restitution, friction, velocity }))
    }

    /// This edit with `later`'s values on top.
    pub fn merged(self, later: Self) -> Self {
        Self {
            mass: later.mass.or(self.mass),
            restitution: later.restitution.or(self.restitution),
            friction: later.friction.or(self.friction),
            velocity: later.velocity.or(self.velocity),
        }
    }
}

/// Applies `edit` to the actor `name` of `sim` in place; refuses (changing nothing) an unknown
/// actor and mass or velocity edits of a fixed one.
pub(crate) fn apply(sim: &mut Sim, name: &str, edit: &ActorEdit) -> Result<(), String> {
    let mut found = None;
    for (index, n, mesh, mass, material, velocity) in
        sim.world.query_mut::<(&ActorIndex, &Name, &Mesh, &mut MassProps, &mut Material, &mut Velocity)>()
    {
        if n.0 != name {
            continue;
        }
        if mass.is_fixed() && (edit.mass.is_some() || edit.velocity.is_some()) {
            return Err(format!("actor '{name}' is fixed: its mass and velocity cannot be edited"));
        }
        if let Some(m) = edit.mass {
            *mass = MassProps::dynamic(m, mesh.shape.unit_inertia * (m / mesh.shape.volume));
        }
        if let Some(r) = edit.restitution {
            material.restitution = r;
        }
        if let Some(f) = edit.friction {
            material.friction = f;
        }
        if let Some(v) = edit.velocity {
            velocity.linear = v;
        }
        found = Some(index.0 as usize);
        break;
    }
    let Some(i) = found else {
        return Err(format!("no actor named '{name}'"));
    };
    // A sleeping body would ignore its new values until touched.
    if let Some(a) = sim.ctx.sleep.asleep.get_mut(i) {
        *a = false;
    }
    if let Some(t) = sim.ctx.sleep.still.get_mut(i) {
        *t = 0.0;
    }
    Ok(())
}

/// A float as RON reads it back exactly: the shortest round-trip digits, with a `.0` on whole
/// numbers.
pub(super) fn num(x: Scalar) -> String {
    let s = format!("{x}");
    if s.contains(['.', 'e', 'E', 'i', 'N']) { s } else { format!("{s}.0") }
}

pub(super) fn v3(v: Vector) -> String {
    format!("({}, {}, {})", num(v.x), num(v.y), num(v.z))
}

pub(super) fn quoted(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{{{:x}}}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn shape_ron(shape: &ShapeDef) -> String {
    match shape {
        ShapeDef::Box { size: (x, y, z) } => format!("Box(size: ({}, {}, {}))", num(*x), num(*y), num(*z)),
        ShapeDef::Tetrahedron { edge } => format!("Tetrahedron(edge: {})", num(*edge)),
        ShapeDef::Octahedron { radius } => format!("Octahedron(radius: {})", num(*radius)),
        ShapeDef::Icosphere { radius, subdivisions } => {
            format!("Icosphere(radius: {}, subdivisions: {subdivisions})", num(*radius))
        }
        ShapeDef::Cylinder { radius, height, segments } => {
            format!("Cylinder(radius: {}, height: {}, segments: {segments})", num(*radius), num(*height))
        }
        ShapeDef::Obj { path, scale, hull } => {
            format!("Obj(path: {}, scale: {}, hull: {hull})", quoted(path), num(*scale))
        }
    }
}

/// Euler angles [degrees] of `q` in the scenes' convention, R = Rz·Ry·Rx.
fn euler_degrees(q: crate::math::Quat) -> Vector {
    let (z, y, x) = q.normalize().to_euler(glam::EulerRot::ZYX);
    // `+ 0.0` turns −0 into 0.
    Vector::new(x, y, z) * (180.0 / std::f64::consts::PI) + Vector::ZERO
}

/// The running scene as RON text `rigid check` accepts: every actor (spawners' included) where
/// it is now, with its current mass, velocities and material; the scene's `dt`, `steps`,
/// gravity, solver and camera; the schedule in use; the joints as they stand now.
pub(crate) fn scene_ron(s: &Studio) -> Result<String, String> {
    let instances = crate::scene::instantiate::instances(&s.def, &s.path).map_err(|e| e.to_string())?;
    let base = crate::scene::base_dir(&s.path);
    let sim = &s.sim;
    let mut rows: Vec<(usize, Pose, Velocity, MassProps, Material)> = sim
        .world
        .query::<(&ActorIndex, &Pose, &Velocity, &MassProps, &Material)>()
        .iter()
        .map(|(i, p, v, m, mat)| (i.0 as usize, *p, *v, *m, *mat))
        .collect();
    rows.sort_by_key(|r| r.0);

    let d = &s.def;
    let mut out = String::new();
    let _ = writeln!(out, "// Saved by rigid studio at t = {} s (step {}).", num(sim.time), sim.steps);
    out.push_str("Scene(\n");
    let _ = writeln!(out, "    dt: {},", num(sim.ctx.dt));
    let _ = writeln!(out, "    steps: {},", d.steps);
    let _ = writeln!(out, "    gravity: ({}, {}, {}),", num(d.gravity.0), num(d.gravity.1), num(d.gravity.2));
    let names: Vec<String> = sim.schedule.names().iter().map(|n| quoted(n)).collect();
    let _ = writeln!(out, "    schedule: [{}],", names.join(", "));
    let sv = &d.solver;
    let _ = write!(
        out,
        "    solver: Solver(max_sweeps: {}, correction: {}, slop: {}, iterations: {}, sleep: {}",
        sv.max_sweeps,
        num(sv.correction),
        num(sv.slop),
        sv.iterations,
        sv.sleep
    );
    if let Some(n) = sv.substeps {
        let _ = write!(out, ", substeps: {n}");
    }
    if let Some(t) = sv.restitution_threshold {
        let _ = write!(out, ", restitution_threshold: {}", num(t));
    }
    out.push_str("),\n");
    if let Some(c) = &d.camera {
        let _ = writeln!(
            out,
            "    camera: Camera(eye: {}, target: {}, fov: {}),",
            v3(crate::scene::vector(c.eye)),
            v3(crate::scene::vector(c.target)),
            num(c.fov)
        );
    }
    out.push_str("    actors: [\n");
    for (i, pose, vel, mass, mat) in rows {
        let Some(inst) = instances.get(i) else {
            return Err(format!("actor {i} has no definition"));
        };
        let mut shape = inst.shape.clone();
        if let ShapeDef::Obj { path, .. } = &mut shape {
            let p = std::path::Path::new(path.as_str());
            let full = if p.is_relative() { base.join(p) } else { p.to_path_buf() };
            // Absolute: the saved file may go anywhere.
            let full = std::path::absolute(&full).unwrap_or(full);
            // Uploads live in a folder that goes with the studio: name the file alone.
            *path = if full.starts_with(&s.mesh_dir) {
                full.file_name().map_or_else(|| path.clone(), |n| n.to_string_lossy().into_owned())
            } else {
                full.display().to_string()
            };
        }
        let fixed = mass.is_fixed();
        let _ = write!(
            out,
            "        Actor(name: {}, shape: {}, mass: {}, position: {}, rotation: {}",
            quoted(&sim.names()[i]),
            shape_ron(&shape),
            num(mass.mass),
            v3(pose.position),
            v3(euler_degrees(pose.orientation)),
        );
        if !fixed {
            let _ = write!(out, ", velocity: {}, angular_velocity: {}", v3(vel.linear), v3(vel.angular));
        }
        let _ =
            writeln!(out, ", restitution: {}, friction: {}, fixed: {fixed}),", num(mat.restitution), num(mat.friction));
    }
    out.push_str("    ],\n");
    out.push_str(&super::joints::ron(sim));
    out.push_str(")\n");
    Ok(out)
}
