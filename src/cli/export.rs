//! `rigid export`: the run as an animated binary glTF file, built by `io::export`.

use super::render::sample_steps;
use super::{AppError, check_writable, scene_sim, write_out};
use crate::cli::args::ExportArgs;

pub(super) fn export(args: &ExportArgs) -> Result<(), AppError> {
    use crate::io::export::{ExportScene, Keyframe, glb};
    // Before simulating: a run must not compute for minutes and then fail to write.
    check_writable(&args.glb, "--glb")?;
    let (_, mut sim, steps) = scene_sim(&args.scene)?;
    let mut keyframes = Vec::new();
    sample_steps(&mut sim, steps, args.scene.every, args.scene.quiet, |sim, keyframe| {
        if keyframe {
            let poses =
                sim.actors().iter().map(|a| (a.pose.position.to_array(), a.pose.orientation.to_array())).collect();
            keyframes.push(Keyframe { time: sim.time, poses });
        }
        Ok(())
    })?;
    let mut query = sim.world.query::<(&crate::ActorIndex, &crate::Mesh, &crate::MassProps)>();
    let mut rows: Vec<_> = query.iter().map(|(i, m, mass)| (i.0 as usize, m.id, mass.is_fixed())).collect();
    drop(query);
    rows.sort_by_key(|r| r.0);
    let meshes = (0..sim.ctx.meshes.len()).map(|k| sim.ctx.meshes.get(crate::MeshId(k as u32))).collect();
    let actors = rows
        .iter()
        .map(|&(i, mesh, fixed)| {
            (sim.names()[i].clone(), mesh.0 as usize, fixed, crate::io::render::actor_colour(i, fixed))
        })
        .collect();
    let bytes = glb(&ExportScene { actors, meshes }, &keyframes);
    write_out(&args.glb, &bytes)?;
    if !args.scene.quiet {
        println!("wrote {} actors, {} keyframes to {}", sim.len(), keyframes.len(), args.glb.display());
    }
    Ok(())
}
