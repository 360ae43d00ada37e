//! `rigid render`: PNG frames (and optionally a GIF) of a run, drawn by `io::render`.

use super::{AppError, check_writable, progress_bar, sample, scene_sim, write_error, write_out};
use crate::cli::args::RenderArgs;
use crate::sim::Sim;
use std::path::Path;

pub(super) fn render(args: &RenderArgs) -> Result<(), AppError> {
    use crate::io::render::{ContactTrail, Overlay, render_with_contacts};
    // Every output path is judged before anything is simulated: a run must not compute for
    // minutes and then fail to write.
    check_out_dir(&args.out)?;
    if let Some(gif) = &args.gif
        && gif.parent() != Some(args.out.as_path())
    {
        check_writable(gif, "--gif")?;
    }
    let (def, mut sim, steps) = scene_sim(&args.scene)?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| AppError::Usage(format!("--out {}: cannot create the folder: {e}", args.out.display())))?;
    if let Some(gif) = &args.gif {
        check_writable(gif, "--gif")?;
    }
    let removed = remove_old_frames(&args.out)?;
    if removed > 0 {
        eprintln!("note: removed {removed} frames of an earlier render from {}", args.out.display());
    }
    let (w, h) = args.size;
    let overlay = Overlay { contacts: args.contacts, solid_fixed: args.solid_fixed };
    let camera = choose_camera(args, def.camera, &sim);
    let mut gif = Vec::new();
    let mut frames = 0_u32;
    let mut encoder = args.gif.as_ref().map(|_| {
        let mut e = image::codecs::gif::GifEncoder::new_with_speed(&mut gif, 10);
        let _ = e.set_repeat(image::codecs::gif::Repeat::Infinite);
        e
    });
    // Real-time playback where GIF delays allow (at least 20 ms a frame).
    let delay_ms = ((def.dt * args.scene.every as f64 * 1000.0).round() as u32).max(20);
    // The contacts of every step since the last frame, so an impact between frames shows.
    let mut trail = ContactTrail::default();
    sample_steps(&mut sim, steps, args.scene.every, args.scene.quiet, |sim, frame| {
        if args.contacts {
            trail.record(sim);
        }
        if !frame {
            return Ok(());
        }
        let image = render_with_contacts(sim, &camera, w, h, overlay, trail.contacts());
        trail.clear();
        let file = args.out.join(frame_name(frames));
        let mut png = Vec::new();
        image
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(|e| write_error(&file, std::io::Error::other(e)))?;
        write_out(&file, png)?;
        if let (Some(enc), Some(path)) = (encoder.as_mut(), &args.gif) {
            let rgba = image::DynamicImage::ImageRgb8(image).into_rgba8();
            let frame = image::Frame::from_parts(rgba, 0, 0, image::Delay::from_numer_denom_ms(delay_ms, 1));
            enc.encode_frame(frame).map_err(|e| write_error(path, std::io::Error::other(e)))?;
        }
        frames += 1;
        Ok(())
    })?;
    drop(encoder);
    if let Some(path) = &args.gif {
        write_out(path, gif)?;
    }
    if !args.scene.quiet {
        println!("wrote {frames} frames of {w}x{h} to {}", args.out.display());
    }
    Ok(())
}

/// Runs `steps` steps with a progress bar (unless `quiet`), calling `visit(sim, frame)` at
/// step 0 and after every step; `frame` is true where `sample` would visit: step 0, every
/// `every`-th step and the last.
pub(super) fn sample_steps(
    sim: &mut Sim,
    steps: u64,
    every: u64,
    quiet: bool,
    mut visit: impl FnMut(&Sim, bool) -> Result<(), AppError>,
) -> Result<(), AppError> {
    let bar = progress_bar(steps, quiet);
    let mut first = true;
    let result = sample(sim, steps, 1, |sim| {
        let frame = first || sim.steps.is_multiple_of(every) || sim.steps == steps;
        if let (Some(bar), false) = (&bar, first) {
            bar.inc(1);
        }
        first = false;
        visit(sim, frame)
    });
    // Cleared on failure too, so an error is not printed after a stale bar.
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    result
}

/// The file name of frame `k`.
fn frame_name(k: u32) -> String {
    format!("frame-{k:05}.png")
}

/// True for a name `frame_name` makes: `frame-` and exactly five digits, then `.png`.
fn is_frame_name(name: &str) -> bool {
    name.strip_prefix("frame-")
        .and_then(|rest| rest.strip_suffix(".png"))
        .is_some_and(|digits| digits.len() == 5 && digits.bytes().all(|b| b.is_ascii_digit()))
}

/// `--out` must be a folder or not exist yet (it is created after the scene loads).
fn check_out_dir(dir: &Path) -> Result<(), AppError> {
    if dir.exists() && !dir.is_dir() {
        return Err(AppError::Usage(format!("--out {}: is not a folder; give a folder for the frames", dir.display())));
    }
    Ok(())
}

/// Removes the frames an earlier render left in `dir`, which would otherwise mix with this
/// one's (a shorter run leaves the tail of a longer one); other files stay. Returns how many.
fn remove_old_frames(dir: &Path) -> Result<usize, AppError> {
    let mut removed = 0;
    for entry in std::fs::read_dir(dir).map_err(|e| write_error(dir, e))? {
        let entry = entry.map_err(|e| write_error(dir, e))?;
        let is_frame = entry.file_name().to_str().is_some_and(is_frame_name);
        if is_frame && !entry.file_type().map_err(|e| write_error(&entry.path(), e))?.is_dir() {
            std::fs::remove_file(entry.path()).map_err(|e| write_error(&entry.path(), e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// The camera: `--eye`/`--target` over the scene's `camera`, over one fitted to the scene.
fn choose_camera(args: &RenderArgs, scene: Option<crate::scene::CameraDef>, sim: &Sim) -> crate::io::render::Camera {
    use crate::math::Vector;
    let base = scene.map_or_else(
        || crate::io::render::Camera::fit(sim),
        |c| crate::io::render::Camera {
            eye: crate::scene::vector(c.eye),
            target: crate::scene::vector(c.target),
            fov_y: c.fov.to_radians(),
        },
    );
    crate::io::render::Camera {
        eye: args.eye.map_or(base.eye, Vector::from_array),
        target: args.target.map_or(base.target, Vector::from_array),
        fov_y: base.fov_y,
    }
}

#[cfg(test)]
mod tests {
    use super::is_frame_name;

    #[test]
    fn only_this_commands_frame_names_match() {
        for name in ["frame-00000.png", "frame-00064.png", "frame-99999.png"] {
            assert!(is_frame_name(name), "{name}");
        }
        for name in ["frame-0000.png", "frame-000000.png", "frame-0000a.png", "frame-00001.PNG", "xframe-00001.png"] {
            assert!(!is_frame_name(name), "{name}");
        }
        assert!(!is_frame_name("frame-00001.png.tmp"), "a temporary file of write_atomic is not a frame");
    }
}
