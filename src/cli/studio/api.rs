//! The studio's HTTP API and its static files (docs/studio.md lists every route).

use super::{POSTED_NAME, Shared, Studio, build_sim, clean_error, lock, save};
use crate::model::components::{ActorIndex, MassProps, Material, Mesh, Name, Pose, Velocity};
use crate::scene::{ActorDef, ShapeDef};
use serde_json::{Value, json};
use std::collections::HashMap;
use std::io::Read;
use tiny_http::{Header, Method, Request, Response};

/// The largest request body read (a scene or an OBJ file).
const MAX_BODY: u64 = 64 << 20;
/// The most steps one `step` action takes.
const MAX_STEP_ACTION: u64 = 100_000;

const PAGE: &str = include_str!("page.html");
const APP: &str = include_str!("app.js");
const THREE: &str = include_str!("three.module.min.js");
const ORBIT: &str = include_str!("OrbitControls.js");
const POINTS: &str = include_str!("points.js");

/// A response: status, content type, body and extra headers.
struct Reply {
    status: u16,
    kind: &'static str,
    body: Vec<u8>,
    headers: Vec<(&'static str, String)>,
}

impl Reply {
    fn json(status: u16, value: &Value) -> Self {
        Self { status, kind: "application/json", body: value.to_string().into_bytes(), headers: Vec::new() }
    }

    fn error(status: u16, message: impl Into<String>) -> Self {
        Self::json(status, &json!({"error": message.into()}))
    }

    fn text(kind: &'static str, body: &str) -> Self {
        Self { status: 200, kind, body: body.as_bytes().to_vec(), headers: Vec::new() }
    }
}

/// Answers one request.
pub(super) fn handle(mut request: Request, shared: &Shared) {
    let url = request.url().to_string();
    let (route, query) = url.split_once('?').unwrap_or((url.as_str(), ""));
    let method = request.method().clone();
    let reply = match (&method, route) {
        (Method::Get, "/" | "/index.html") => Reply::text("text/html; charset=utf-8", PAGE),
        (Method::Get, "/app.js") => Reply::text("text/javascript; charset=utf-8", APP),
        (Method::Get, "/three.module.min.js") => Reply::text("text/javascript; charset=utf-8", THREE),
        (Method::Get, "/OrbitControls.js") => Reply::text("text/javascript; charset=utf-8", ORBIT),
        (Method::Get, "/points.js") => Reply::text("text/javascript; charset=utf-8", POINTS),
        (Method::Get, "/api/state") => Reply::json(200, &state(&lock(shared), !query.contains("actors=0"))),
        (Method::Get, "/api/frame") => frame(&lock(shared)),
        (Method::Get, "/api/contacts") => contacts(&lock(shared)),
        (Method::Get, "/api/meshes") => Reply::json(200, &meshes(&lock(shared))),
        (Method::Get, "/api/scene") => match save::scene_ron(&lock(shared)) {
            Ok(text) => Reply {
                status: 200,
                kind: "application/ron; charset=utf-8",
                body: text.into_bytes(),
                headers: vec![("Content-Disposition", "attachment; filename=\"scene.ron\"".to_string())],
            },
            Err(e) => Reply::error(409, e),
        },
        (Method::Post, _) => match read_body(&mut request) {
            Err(e) => Reply::error(400, e),
            Ok(body) => match route {
                "/api/control" => control(shared, &body),
                "/api/scene" => post_scene(shared, &body),
                "/api/actors" => post_actor(shared, &body),
                "/api/actor" => edit_actor(shared, &body),
                "/api/schedule" => post_schedule(shared, &body),
                "/api/mesh" => post_mesh(shared, query, &body),
                _ => Reply::error(404, format!("no such route: POST {route}")),
            },
        },
        (Method::Get, _) => Reply::error(404, format!("no such route: GET {route}")),
        _ => Reply::error(405, format!("method {method} not allowed")),
    };
    let mut response = Response::from_data(reply.body).with_status_code(reply.status);
    let mut headers = vec![("Content-Type", reply.kind.to_string()), ("Cache-Control", "no-store".to_string())];
    headers.extend(reply.headers);
    for (name, value) in headers {
        if let Ok(h) = Header::from_bytes(name.as_bytes(), value.as_bytes()) {
            response.add_header(h);
        }
    }
    // The client may have gone; nothing to do about it.
    let _ = request.respond(response);
}

fn read_body(request: &mut Request) -> Result<String, String> {
    let mut body = String::new();
    request.as_reader().take(MAX_BODY + 1).read_to_string(&mut body).map_err(|e| format!("cannot read body: {e}"))?;
    if body.len() as u64 > MAX_BODY {
        return Err(format!("body larger than {} MiB", MAX_BODY >> 20));
    }
    Ok(body)
}

/// The systems the page offers as checkboxes: the scene's schedule, then any others in use.
fn offered_systems(s: &Studio) -> Vec<String> {
    let mut names: Vec<String> = match &s.def.schedule {
        Some(names) => names.clone(),
        None => crate::systems::DEFAULT_ORDER.iter().map(|n| (*n).to_string()).collect(),
    };
    for n in s.sim.schedule.names() {
        if !names.iter().any(|m| m == n) {
            names.push(n.to_string());
        }
    }
    names
}

/// The state document; `with_actors` false leaves the actor and joint lists empty (the page's
/// poll).
fn state(s: &Studio, with_actors: bool) -> Value {
    let sim = &s.sim;
    let all = if with_actors { sim.actors() } else { Vec::new() };
    let mut materials = vec![None; all.len()];
    if with_actors {
        for (i, m) in sim.world.query::<(&ActorIndex, &Material)>().iter() {
            if let Some(slot) = materials.get_mut(i.0 as usize) {
                *slot = Some(*m);
            }
        }
    }
    let actors: Vec<Value> = all
        .iter()
        .zip(&materials)
        .map(|(a, m)| {
            json!({
                "name": a.name,
                "position": a.pose.position.to_array(),
                "orientation": a.pose.orientation.to_array(),
                "velocity": a.velocity.linear.to_array(),
                "angular_velocity": a.velocity.angular.to_array(),
                "mass": a.mass.mass,
                "restitution": m.map(|m| m.restitution),
                "friction": m.map(|m| m.friction),
                "fixed": a.mass.is_fixed(),
            })
        })
        .collect();
    let systems_ms: serde_json::Map<String, Value> =
        sim.profile.systems.iter().map(|(n, d)| ((*n).to_string(), json!(d.as_secs_f64() * 1e3))).collect();
    let step_ms = sim.profile.systems.iter().map(|(_, d)| d.as_secs_f64()).sum::<f64>() * 1e3
        + (sim.profile.snapshot + sim.profile.store).as_secs_f64() * 1e3;
    json!({
        "time": sim.time,
        "step": sim.steps,
        "dt": sim.ctx.dt,
        "running": s.running,
        "speed": s.speed,
        "scene": s.scene_name,
        "version": s.version,
        "actor_count": sim.len(),
        "actors": actors,
        "joints": if with_actors { super::joints::state(sim) } else { Vec::new() },
        "schedule": sim.schedule.names(),
        "systems": offered_systems(s),
        "systems_ms": systems_ms,
        "step_ms": step_ms,
        "steps_per_second": s.steps_per_second,
        "contacts": crate::io::render::step_contacts(sim).count(),
        "energy": sim.totals().kinetic_energy,
        "error": s.error,
    })
}

/// Every actor's position and orientation (x, y, z, w) as 7 little-endian f32s, in actor order;
/// time, step and scene version in headers.
fn frame(s: &Studio) -> Reply {
    let sim = &s.sim;
    let mut floats = vec![0.0_f32; sim.len() * 7];
    for (index, pose) in sim.world.query::<(&ActorIndex, &Pose)>().iter() {
        let (p, q) = (pose.position, pose.orientation);
        let row = index.0 as usize * 7;
        floats[row..row + 7].copy_from_slice(&[p.x, p.y, p.z, q.x, q.y, q.z, q.w].map(|v| v as f32));
    }
    let body = floats.iter().flat_map(|v| v.to_le_bytes()).collect();
    Reply {
        status: 200,
        kind: "application/octet-stream",
        body,
        headers: vec![
            ("X-Time", sim.time.to_string()),
            ("X-Step", sim.steps.to_string()),
            ("X-Version", s.version.to_string()),
            ("X-Running", s.running.to_string()),
        ],
    }
}

/// The last step's contacts, one a touching pair: the point and the unit normal (from B to A)
/// as 6 little-endian f32s each; step and scene version in headers.
fn contacts(s: &Studio) -> Reply {
    let body = crate::io::render::step_contacts(&s.sim)
        .flat_map(|c| {
            [c.point.x, c.point.y, c.point.z, c.normal.x, c.normal.y, c.normal.z].map(|v| (v as f32).to_le_bytes())
        })
        .flatten()
        .collect();
    Reply {
        status: 200,
        kind: "application/octet-stream",
        body,
        headers: vec![("X-Step", s.sim.steps.to_string()), ("X-Version", s.version.to_string())],
    }
}

fn meshes(s: &Studio) -> Value {
    let sim = &s.sim;
    let meshes: Vec<Value> = (0..sim.ctx.meshes.len())
        .map(|k| {
            let m = sim.ctx.meshes.get(crate::MeshId(k as u32));
            let vertices: Vec<f32> = m.vertices.iter().flat_map(|v| v.to_array().map(|x| x as f32)).collect();
            let triangles: Vec<u32> = m.triangles.iter().flatten().copied().collect();
            json!({"vertices": vertices, "triangles": triangles})
        })
        .collect();
    let mut rows: Vec<(usize, usize, bool)> = sim
        .world
        .query::<(&ActorIndex, &Mesh, &MassProps)>()
        .iter()
        .map(|(i, m, mass)| (i.0 as usize, m.id.0 as usize, mass.is_fixed()))
        .collect();
    rows.sort_by_key(|r| r.0);
    let actors: Vec<Value> = rows
        .iter()
        .map(|&(i, mesh, fixed)| {
            json!({
                "name": sim.names()[i],
                "mesh": mesh,
                "fixed": fixed,
                "colour": crate::io::render::actor_colour(i, fixed),
            })
        })
        .collect();
    json!({"version": s.version, "meshes": meshes, "actors": actors, "joints": super::joints::frames(sim)})
}

fn parse_json(body: &str) -> Result<Value, Reply> {
    serde_json::from_str(body).map_err(|e| Reply::error(400, format!("bad JSON: {e}")))
}

fn control(shared: &Shared, body: &str) -> Reply {
    let v = match parse_json(body) {
        Ok(v) => v,
        Err(r) => return r,
    };
    let mut s = lock(shared);
    match v.get("action").and_then(Value::as_str) {
        Some("play") => s.running = true,
        Some("pause") => s.running = false,
        Some("step") => {
            let n = match v.get("steps") {
                None => 1,
                Some(n) => match n.as_u64() {
                    Some(n) if (1..=MAX_STEP_ACTION).contains(&n) => n,
                    _ => return Reply::error(400, format!("steps must be an integer in 1..={MAX_STEP_ACTION}")),
                },
            };
            s.running = false;
            if let Err(e) = s.sim.run(n) {
                s.error = Some(e.to_string());
                return Reply::error(500, e.to_string());
            }
        }
        Some("reset") => {
            if let Err(e) = s.rebuild() {
                return Reply::error(400, e);
            }
        }
        Some("speed") => match v.get("speed").and_then(Value::as_f64) {
            Some(x) if x.is_finite() && (0.01..=100.0).contains(&x) => s.speed = x,
            _ => return Reply::error(400, "speed must be a number in 0.01..=100"),
        },
        Some(other) => {
            return Reply::error(400, format!("unknown action '{other}'; valid: play, pause, step, reset, speed"));
        }
        None => return Reply::error(400, "missing \"action\": play, pause, step, reset or speed"),
    }
    Reply::json(200, &json!({"ok": true, "step": s.sim.steps, "time": s.sim.time, "running": s.running}))
}

fn post_scene(shared: &Shared, body: &str) -> Reply {
    let mesh_dir = lock(shared).mesh_dir.clone();
    let path = mesh_dir.join(POSTED_NAME);
    let def = match crate::scene::parse(body, &path) {
        Ok(def) => def,
        Err(e) => return Reply::error(400, clean_error(&e.to_string(), &mesh_dir)),
    };
    // Built outside the lock: a big scene does not stall the page meanwhile.
    let sim = match crate::scene::build_from_text(&def, &path, body) {
        Ok(sim) => sim,
        Err(e) => return Reply::error(400, clean_error(&e.to_string(), &mesh_dir)),
    };
    let mut s = lock(shared);
    s.def = def;
    s.path = path;
    s.scene_name = POSTED_NAME.to_string();
    s.schedule = None;
    s.sim = sim;
    s.version += 1;
    s.error = None;
    s.edits.clear();
    Reply::json(200, &json!({"ok": true, "actors": s.sim.len()}))
}

/// `<studio>:line:col: message` for a RON error in posted text.
fn ron_error(e: &ron::error::SpannedError) -> String {
    format!("{POSTED_NAME}:{}:{}: {}", e.span.start.line.max(1), e.span.start.col.max(1), e.code)
}

fn post_actor(shared: &Shared, body: &str) -> Reply {
    let mut actor: ActorDef = match crate::scene::ron_options().from_str(body) {
        Ok(a) => a,
        Err(e) => return Reply::error(400, ron_error(&e)),
    };
    let mut s = lock(shared);
    if let ShapeDef::Obj { path, .. } = &mut actor.shape {
        let uploaded = s.mesh_dir.join(&*path);
        if std::path::Path::new(path).is_relative() && uploaded.is_file() {
            *path = uploaded.display().to_string();
        }
    }
    if actor.name.is_none() {
        let name = loop {
            s.added += 1;
            let name = format!("added-{}", s.added);
            if !s.sim.names().contains(&name) {
                break name;
            }
        };
        actor.name = Some(name);
    }
    let mut def = s.def.clone();
    def.actors.push(actor);
    let mut sim = match build_sim(&def, &s.path, s.schedule.as_deref(), &s.mesh_dir) {
        Ok(sim) => sim,
        Err(e) => return Reply::error(400, e),
    };
    s.apply_edits(&mut sim);
    // Existing actors keep their poses and velocities; the clock goes on.
    let old: HashMap<String, (Pose, Velocity)> =
        s.sim.world.query::<(&Name, &Pose, &Velocity)>().iter().map(|(n, p, v)| (n.0.clone(), (*p, *v))).collect();
    for (name, pose, vel) in sim.world.query_mut::<(&Name, &mut Pose, &mut Velocity)>() {
        if let Some(&(p, v)) = old.get(name.0.as_str()) {
            *pose = p;
            *vel = v;
        }
    }
    sim.time = s.sim.time;
    sim.steps = s.sim.steps;
    s.def = def;
    s.sim = sim;
    s.version += 1;
    Reply::json(200, &json!({"ok": true, "actors": s.sim.len()}))
}

/// `POST /api/actor`: edits one actor of the running scene in place and records the edit.
fn edit_actor(shared: &Shared, body: &str) -> Reply {
    let v = match parse_json(body) {
        Ok(v) => v,
        Err(r) => return r,
    };
    let (name, edit) = match save::ActorEdit::from_json(&v) {
        Ok(e) => e,
        Err(e) => return Reply::error(400, e),
    };
    let mut s = lock(shared);
    if let Err(e) = save::apply(&mut s.sim, &name, &edit) {
        return Reply::error(400, e);
    }
    s.record_edit(&name, edit);
    let actor = s.sim.actors().into_iter().find(|a| a.name == name);
    let material = s.sim.world.query::<(&Name, &Material)>().iter().find(|(n, _)| n.0 == name).map(|(_, m)| *m);
    Reply::json(
        200,
        &json!({
            "ok": true,
            "name": name,
            "mass": actor.as_ref().map(|a| a.mass.mass),
            "velocity": actor.as_ref().map(|a| a.velocity.linear.to_array()),
            "restitution": material.map(|m| m.restitution),
            "friction": material.map(|m| m.friction),
        }),
    )
}

fn post_schedule(shared: &Shared, body: &str) -> Reply {
    let v = match parse_json(body) {
        Ok(v) => v,
        Err(r) => return r,
    };
    let Some(list) = v.get("systems").and_then(Value::as_array) else {
        return Reply::error(400, "expected {\"systems\": [names]}");
    };
    let names: Option<Vec<String>> = list.iter().map(|n| n.as_str().map(str::to_string)).collect();
    let Some(names) = names else {
        return Reply::error(400, "system names must be strings");
    };
    let schedule = match crate::systems::schedule_of(&names) {
        Ok(s) => s,
        Err(e) => return Reply::error(400, e.to_string()),
    };
    let mut s = lock(shared);
    s.sim.schedule = schedule;
    s.schedule = Some(names);
    Reply::json(200, &json!({"ok": true, "schedule": s.sim.schedule.names()}))
}

fn post_mesh(shared: &Shared, query: &str, body: &str) -> Reply {
    let name = query.split('&').find_map(|kv| kv.strip_prefix("name=")).unwrap_or("");
    let valid = !name.is_empty()
        && name.len() <= 100
        && !name.starts_with('.')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || "._-".contains(c));
    if !valid {
        return Reply::error(400, "give ?name=NAME: letters, digits, '.', '_' and '-', not starting with '.'");
    }
    let path = lock(shared).mesh_dir.join(name);
    match path.parent().map_or(Ok(()), std::fs::create_dir_all).and_then(|()| std::fs::write(&path, body)) {
        Ok(()) => Reply::json(200, &json!({"ok": true, "path": name})),
        Err(e) => Reply::error(500, format!("cannot store {name}: {e}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A measurement, printed (no timed tests here): what one `/api/frame` of 4 006 bodies
    /// costs the server, the HTTP exchange left out (BENCH.md, "Studio at 4 000 bodies").
    #[test]
    #[ignore = "a measurement that prints: cargo test --release --lib frame_of_4000 -- --ignored --nocapture"]
    fn frame_of_4000_bodies() {
        let text = "Scene(gravity: (0.0, 0.0, 0.0), actors: [], spawners: [BoxGas(actors: 4000, seed: 1)])";
        let path = std::path::Path::new("box-gas-4000.ron");
        let def = crate::scene::parse(text, path).expect("parses");
        let sim = crate::scene::build(&def, path).expect("builds");
        let studio = Studio::new(def, path.into(), "box-gas-4000".into(), sim, std::env::temp_dir());
        for round in 0..3 {
            let n = 1000;
            let start = std::time::Instant::now();
            let mut bytes = 0;
            for _ in 0..n {
                bytes = std::hint::black_box(frame(&studio)).body.len();
            }
            let us = start.elapsed().as_secs_f64() * 1e6 / f64::from(n);
            println!("round {round}: {} bodies, {bytes} bytes, {us:.1} us a frame", studio.sim.len());
        }
    }
}
