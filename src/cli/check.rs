//! `rigid check`: loads and builds a scene without running it, and prints what it holds.

use super::{AppError, load_scene_text, outln, print_warnings, significant};
use std::path::Path;

pub(super) fn check(path: &Path) -> Result<(), AppError> {
    let (def, path, text) = load_scene_text(Some(path))?;
    let mut sim = crate::scene::build_from_text(&def, &path, &text)?;
    print_warnings(&mut sim, &path);
    outln!("{}: ok", path.display());
    outln!("dt {} s, {} steps, gravity {:?}", def.dt, def.steps, def.gravity);
    outln!("schedule: {}", sim.schedule.names().join(", "));
    outln!("{} actors, {} distinct meshes", sim.len(), sim.ctx.meshes.len());
    for a in sim.actors().iter().take(20) {
        let fixed = if a.mass.is_fixed() { " (fixed)" } else { "" };
        let p = a.pose.position;
        let at = [p.x, p.y, p.z].map(significant).join(", ");
        outln!("  {}: mass {} kg at [{at}]{fixed}", a.name, significant(a.mass.mass));
    }
    if sim.len() > 20 {
        outln!("  ... and {} more", sim.len() - 20);
    }
    if let Some(joints) = sim.ctx.scratch.get::<crate::solver::Joints>().filter(|j| !j.joints.is_empty()) {
        outln!("{} joints", joints.joints.len());
        for j in &joints.joints {
            let b = j.b.map_or("the world", |b| sim.names()[b as usize].as_str());
            let collide = if j.collide { " (colliding)" } else { "" };
            outln!("  {}: {} joining {} to {b}{collide}", j.name, j.kind.name(), sim.names()[j.a as usize]);
        }
    }
    Ok(())
}
