//! `rigid render`: PNG frames (and optionally a GIF) of a run, drawn by `io::render`.

use super::{AppError, sample, scene_sim, write_error, write_out};
use crate::cli::args::RenderArgs;
use crate::sim::Sim;

pub(super) fn render(args: &RenderArgs) -> Result<(), AppError> {
    use crate::io::render::Overlay;
    let (def, mut sim, steps) = scene_sim(&args.scene)?;
    std::fs::create_dir_all(&args.out).map_err(|e| write_error(&args.out, e))?;
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
    sample(&mut sim, steps, args.scene.every, |sim| {
        let image = crate::io::render::render(sim, &camera, w, h, overlay);
        let file = args.out.join(format!("frame-{frames:05}.png"));
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
    println!("wrote {frames} frames of {w}x{h} to {}", args.out.display());
    Ok(())
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
