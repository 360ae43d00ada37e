//! Building a `Sim` from a parsed scene: listed actors, then spawners in order; each shape's
//! mesh built, validated and shared; masses from `mass` or `density` (docs/physics.md §3).

use crate::error::SceneError;
use crate::model::mesh::{ConvexMesh, MeshId};
use crate::model::shapes;
use crate::scene::spawners::{Instance, MAX_ACTORS};
use crate::scene::{MassSpec, SceneDef, ShapeDef, invalid, vector};
use crate::sim::context::Params;
use crate::sim::{BodyDef, Sim};
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Every actor of the scene in spawn order: listed actors, then each spawner's.
pub fn instances(scene: &SceneDef, path: &Path) -> Result<Vec<Instance>, SceneError> {
    let total =
        scene.actors.len() as u64 + scene.spawners.iter().map(crate::scene::spawners::SpawnerDef::count).sum::<u64>();
    if total > MAX_ACTORS {
        return Err(invalid(
            path,
            "scene",
            "spawners",
            format!("{total} actors is more than the limit of {MAX_ACTORS}"),
        ));
    }
    let mut out: Vec<Instance> = scene
        .actors
        .iter()
        .enumerate()
        .map(|(i, a)| Instance::from_def(a, a.name.clone().unwrap_or_else(|| format!("actor-{i}"))))
        .collect();
    for (k, spawner) in scene.spawners.iter().enumerate() {
        let who = format!("spawner {k}");
        spawner.check().map_err(|(field, reason)| invalid(path, &who, &field, reason))?;
        out.extend(spawner.expand(&format!("spawner{k}")));
    }
    let mut seen = HashSet::with_capacity(out.len());
    if let Some(dup) = out.iter().find(|a| !seen.insert(a.name.as_str())) {
        return Err(invalid(path, &dup.name, "name", "names must be unique; this one is used twice".into()));
    }
    Ok(out)
}

/// Builds the simulation a scene describes; `path` locates OBJ files and names errors.
pub fn build(scene: &SceneDef, path: &Path) -> Result<Sim, SceneError> {
    let schedule = match &scene.schedule {
        Some(names) => {
            crate::systems::schedule_of(names).map_err(|e| invalid(path, "scene", "schedule", e.to_string()))?
        }
        None => crate::systems::default_schedule(),
    };
    let mut sim = Sim::new(scene.dt, params(scene), schedule);
    spawn_all(&mut sim, &instances(scene, path)?, path)?;
    crate::scene::joints::build_joints(scene, &mut sim, path)?;
    Ok(sim)
}

/// As `build`, with an actor's error (its mesh, or a mass from its density) placed at
/// `line:column` in the scene's `text`: at the OBJ path as written, or else at the actor's
/// name. These are found after parsing, so the parser cannot place them.
pub fn build_from_text(scene: &SceneDef, path: &Path, text: &str) -> Result<Sim, SceneError> {
    let quoted = |s: &str| text.find(&format!("\"{s}\"")).map(|at| (at, s.len() + 2));
    build(scene, path).map_err(|e| {
        let at = match &e {
            SceneError::Mesh { actor, .. } => instances(scene, path)
                .ok()
                .and_then(|all| match &all.iter().find(|i| &i.name == actor)?.shape {
                    ShapeDef::Obj { path: obj, .. } => quoted(obj),
                    _ => None,
                })
                .or_else(|| quoted(actor)),
            SceneError::Invalid { actor, .. } if actor != "scene" => quoted(actor),
            _ => None,
        };
        // The message is the error's own, less the file it starts with.
        let placed = at.map(|at| {
            let message = e.to_string();
            let message = message.strip_prefix(&format!("{}: ", path.display())).unwrap_or(&message);
            crate::scene::error_at(path, text, at, message.to_string())
        });
        placed.unwrap_or(e)
    })
}

/// The pipeline settings a scene gives: its gravity and solver settings, substeps by
/// `Params::substeps_for` unless it sets them.
#[must_use]
pub fn params(scene: &SceneDef) -> Params {
    Params {
        gravity: vector(scene.gravity),
        max_sweeps: scene.solver.max_sweeps,
        correction: scene.solver.correction,
        slop: scene.solver.slop,
        substeps: scene.solver.substeps.unwrap_or_else(|| Params::substeps_for(scene.dt)),
        iterations: scene.solver.iterations,
        sleep: scene.solver.sleep,
        restitution_threshold: scene.solver.restitution_threshold,
        ccd: scene.solver.ccd,
        ..Params::default()
    }
}

/// Spawns instances into `sim`, building each distinct shape's mesh once.
pub fn spawn_all(sim: &mut Sim, instances: &[Instance], path: &Path) -> Result<(), SceneError> {
    let mut cache: HashMap<String, (MeshId, f64)> = HashMap::new();
    for inst in instances {
        let key = format!("{:?}", inst.shape);
        let (mesh, volume) = match cache.get(&key) {
            Some(&hit) => hit,
            None => {
                let mesh = mesh_of(&inst.shape, path).map_err(|(mesh, source)| SceneError::Mesh {
                    path: path.to_path_buf(),
                    actor: inst.name.clone(),
                    mesh: mesh.into(),
                    source,
                })?;
                let volume = mesh.volume;
                let hit = (sim.add_mesh(mesh), volume);
                cache.insert(key, hit);
                hit
            }
        };
        let mass = match inst.mass {
            MassSpec::Mass(m) => m,
            MassSpec::Density(rho) => rho * volume,
        };
        // A subnormal mass is refused too: its inverse overflows (see `schema::invertible`).
        if !(mass.is_normal() && mass > 0.0) {
            return Err(invalid(
                path,
                &inst.name,
                "mass",
                format!(
                    "comes out as {mass:e} kg; give a mass or density that makes it at least {:e} kg",
                    f64::MIN_POSITIVE
                ),
            ));
        }
        sim.spawn(&BodyDef {
            name: inst.name.clone(),
            mesh,
            mass,
            pose: inst.pose,
            velocity: inst.velocity,
            material: inst.material,
            fixed: inst.fixed,
        });
    }
    Ok(())
}

/// Builds and validates the mesh of a shape; an error carries what names the mesh (the OBJ
/// file, or the shape as written) beside what is wrong with it.
fn mesh_of(shape: &ShapeDef, path: &Path) -> Result<ConvexMesh, (String, crate::error::MeshError)> {
    let raw = match shape {
        ShapeDef::Box { size } => shapes::box_raw(vector(*size)),
        ShapeDef::Tetrahedron { edge } => shapes::tetrahedron_raw(*edge),
        ShapeDef::Octahedron { radius } => shapes::octahedron_raw(*radius),
        ShapeDef::Icosphere { radius, subdivisions } => shapes::icosphere_raw(*radius, *subdivisions),
        ShapeDef::Cylinder { radius, height, segments } => shapes::cylinder_raw(*radius, *height, *segments),
        ShapeDef::Obj { path: obj, scale, hull } => {
            let file = crate::scene::base_dir(path).join(obj);
            let load = if *hull { crate::scene::obj::load_obj_hull } else { crate::scene::obj::load_obj };
            let raw = load(&file, *scale)
                .map_err(|reason| (file.display().to_string(), crate::error::MeshError::Unreadable { reason }))?;
            return ConvexMesh::new(raw.0, raw.1).map(|(m, _)| m).map_err(|e| (file.display().to_string(), e));
        }
    };
    let name = format!("{shape:?}");
    ConvexMesh::new(raw.0, raw.1).map(|(m, _)| m).map_err(|e| (name, e))
}
