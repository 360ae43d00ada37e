//! A small software renderer for `rigid render`: perspective camera, z-buffered flat-shaded
//! triangles, a ground grid and axes, the joints' anchors, and an optional overlay of contacts. No GPU and no
//! window; `image` encodes the frames.

use crate::collision::contact::{Contact, Pair};
use crate::math::{Scalar, Vector};
use crate::sim::Sim;
use image::{Rgb, RgbImage};
use std::collections::HashSet;

/// A pinhole camera looking from `eye` at `target`, +y up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position [m].
    pub eye: Vector,
    /// Point looked at [m].
    pub target: Vector,
    /// Vertical field of view [rad].
    pub fov_y: Scalar,
}

/// Default vertical field of view [degrees].
pub const DEFAULT_FOV_DEGREES: Scalar = 45.0;
/// Direction from the target to a fitted camera's eye: a three-quarter view from above.
const VIEW_DIRECTION: Vector = Vector::new(0.9, 0.75, 1.3);
/// Light direction for flat shading (towards the light).
const LIGHT: Vector = Vector::new(0.4, 1.0, 0.6);
/// Nearest depth drawn [m]: triangles reaching closer than this are skipped, not clipped.
const NEAR: Scalar = 0.05;
/// Room left around the fitted actors, as a factor on the radius of the sphere holding them.
const FIT_MARGIN: Scalar = 1.15;
/// Smallest radius a camera is fitted to [m], so it stays well beyond `NEAR`.
const FIT_MIN_RADIUS: Scalar = 0.1;
const SKY: Rgb<u8> = Rgb([236, 240, 245]);
const GRID: Rgb<u8> = Rgb([180, 186, 196]);

impl Camera {
    /// A camera for `sim` from a three-quarter view, fitted to what moves: the bounding spheres
    /// of the free actors now, with a margin, and (under downward gravity) where each would
    /// come to lie on the fixed actor below it. Fixed actors are drawn as context but do not
    /// widen the view, so a 20 m floor does not shrink a pile on it to a few pixels. With no
    /// free actors, it sees every actor.
    #[must_use]
    pub fn fit(sim: &Sim) -> Self {
        let fov_y = DEFAULT_FOV_DEGREES.to_radians();
        let (target, radius) = fit_sphere(sim).unwrap_or_else(|| {
            let (lo, hi) = scene_bounds(sim);
            ((lo + hi) * 0.5, ((hi - lo) * 0.5).length().max(0.5))
        });
        let distance = radius / (fov_y * 0.5).sin() * 1.05;
        Self { eye: target + VIEW_DIRECTION.normalize() * distance, target, fov_y }
    }

    /// View-space coordinates (right, up, forward depth) of a world point.
    fn view(&self, p: Vector) -> Vector {
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(Vector::Y).try_normalize().unwrap_or(Vector::X);
        let up = right.cross(forward);
        let d = p - self.eye;
        Vector::new(d.dot(right), d.dot(up), d.dot(forward))
    }

    /// Pixel coordinates and depth of a world point, if in front of the camera.
    #[must_use]
    pub fn project(&self, p: Vector, width: u32, height: u32) -> Option<(Scalar, Scalar, Scalar)> {
        let v = self.view(p);
        if v.z < NEAR {
            return None;
        }
        let focal = f64::from(height) * 0.5 / (self.fov_y * 0.5).tan();
        Some((f64::from(width) * 0.5 + v.x / v.z * focal, f64::from(height) * 0.5 - v.y / v.z * focal, v.z))
    }
}

/// A sphere (centre, radius) holding the free actors' bounding spheres and, when gravity pulls
/// down, each one's landing place on the highest fixed actor under its centre; `None` when no
/// actor is free.
fn fit_sphere(sim: &Sim) -> Option<(Vector, Scalar)> {
    let mut moving = Vec::new();
    let mut fixed = Vec::new();
    let mut query = sim.world.query::<(&crate::Pose, &crate::Mesh, &crate::BoundingSphere, &crate::MassProps)>();
    for (pose, mesh, sphere, mass) in query.iter() {
        if mass.is_fixed() {
            fixed.push(actor_bounds(sim, pose, mesh));
        } else {
            moving.push((pose.position, sphere.radius));
        }
    }
    drop(query);
    if moving.is_empty() {
        return None;
    }
    if sim.ctx.params.gravity.y < 0.0 {
        let landings: Vec<_> = moving
            .iter()
            .filter_map(|&(c, r)| {
                let top = fixed
                    .iter()
                    .filter(|(lo, hi)| hi.y <= c.y && (lo.x..=hi.x).contains(&c.x) && (lo.z..=hi.z).contains(&c.z))
                    .map(|(_, hi)| hi.y)
                    .fold(Scalar::NEG_INFINITY, Scalar::max);
                top.is_finite().then_some((Vector::new(c.x, (top + r).min(c.y), c.z), r))
            })
            .collect();
        moving.extend(landings);
    }
    let (lo, hi) = moving
        .iter()
        .fold((Vector::INFINITY, Vector::NEG_INFINITY), |(lo, hi), &(c, r)| (lo.min(c - r), hi.max(c + r)));
    let centre = (lo + hi) * 0.5;
    let radius = moving.iter().map(|&(c, r)| (c - centre).length() + r).fold(0.0, Scalar::max);
    (centre.is_finite() && radius.is_finite()).then_some((centre, (radius * FIT_MARGIN).max(FIT_MIN_RADIUS)))
}

/// Axis-aligned bounds of one actor's vertices [m].
fn actor_bounds(sim: &Sim, pose: &crate::Pose, mesh: &crate::Mesh) -> (Vector, Vector) {
    sim.ctx.meshes.get(mesh.id).vertices.iter().fold((Vector::INFINITY, Vector::NEG_INFINITY), |(lo, hi), &v| {
        let p = pose.transform_point(v);
        (lo.min(p), hi.max(p))
    })
}

/// The top of the floor: the lowest fixed actor that is flat (no taller than a tenth of its
/// width) and covers at least a quarter of the scene's footprint.
fn floor_top(sim: &Sim, (lo, hi): (Vector, Vector)) -> Option<Scalar> {
    let area = |lo: Vector, hi: Vector| (hi.x - lo.x) * (hi.z - lo.z);
    let mut query = sim.world.query::<(&crate::Pose, &crate::Mesh, &crate::MassProps)>();
    query
        .iter()
        .filter(|(_, _, mass)| mass.is_fixed())
        .map(|(pose, mesh, _)| actor_bounds(sim, pose, mesh))
        .filter(|&(flo, fhi)| {
            fhi.y - flo.y <= 0.1 * (fhi.x - flo.x).min(fhi.z - flo.z) && area(flo, fhi) >= 0.25 * area(lo, hi)
        })
        .map(|(_, fhi)| fhi.y)
        .min_by(Scalar::total_cmp)
}

/// Axis-aligned bounds of every actor's vertices [m].
#[must_use]
pub fn scene_bounds(sim: &Sim) -> (Vector, Vector) {
    let mut query = sim.world.query::<(&crate::Pose, &crate::Mesh)>();
    let (lo, hi) = query.iter().fold((Vector::INFINITY, Vector::NEG_INFINITY), |bounds, (pose, mesh)| {
        sim.ctx.meshes.get(mesh.id).vertices.iter().fold(bounds, |(lo, hi), &v| {
            let p = pose.transform_point(v);
            (lo.min(p), hi.max(p))
        })
    });
    if lo.is_finite() { (lo, hi) } else { (Vector::splat(-1.0), Vector::splat(1.0)) }
}

/// The colour of actor `index`: hues spread by the golden ratio; fixed actors grey.
#[must_use]
pub fn actor_colour(index: usize, fixed: bool) -> [u8; 3] {
    if fixed {
        return [150, 150, 155];
    }
    let h = (index as f64 * 0.618_033_988_749_895).fract() * 6.0;
    let (s, v) = (0.6, 0.92);
    let c = v * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r, g, b].map(|k| ((k + m) * 255.0).round() as u8)
}

/// The contacts `sim`'s last step found (none before the first step).
pub fn step_contacts(sim: &Sim) -> impl Iterator<Item = Contact> + '_ {
    sim.ctx.pairs.iter().filter_map(Pair::contact)
}

/// The contacts of the steps since the last frame, for that frame's overlay: a frame shows one
/// step in K, and an impact between two frames would otherwise never be seen. A contact found
/// again at the same place (a body resting) is kept once.
#[derive(Clone, Debug, Default)]
pub struct ContactTrail {
    contacts: Vec<Contact>,
    seen: HashSet<[i64; 6]>,
}

impl ContactTrail {
    /// Adds the contacts of `sim`'s last step.
    pub fn record(&mut self, sim: &Sim) {
        for c in step_contacts(sim) {
            // Same place to a tenth of a millimetre, same direction to a thousandth.
            let p = (c.point * 1e4).round();
            let n = (c.normal * 1e3).round();
            if self.seen.insert([p.x, p.y, p.z, n.x, n.y, n.z].map(|k| k as i64)) {
                self.contacts.push(c);
            }
        }
    }

    /// The contacts recorded since the last `clear`.
    #[must_use]
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Forgets them (after a frame is drawn).
    pub fn clear(&mut self) {
        self.contacts.clear();
        self.seen.clear();
    }
}

/// What to draw besides the bodies.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Overlay {
    /// Draw contact points and normals: this step's (`render`) or the ones given
    /// (`render_with_contacts`).
    pub contacts: bool,
    /// Fill fixed actors too. By default they are drawn as outlines, so the walls of a closed
    /// box do not hide what moves inside it.
    pub solid_fixed: bool,
}

/// Renders the current state of `sim`, with the contacts of its last step if asked.
#[must_use]
pub fn render(sim: &Sim, camera: &Camera, width: u32, height: u32, overlay: Overlay) -> RgbImage {
    let contacts: Vec<Contact> = if overlay.contacts { step_contacts(sim).collect() } else { Vec::new() };
    render_with_contacts(sim, camera, width, height, overlay, &contacts)
}

/// Renders the current state of `sim`, with `contacts` (e.g. a `ContactTrail`'s) if
/// `overlay.contacts`.
#[must_use]
pub fn render_with_contacts(
    sim: &Sim,
    camera: &Camera,
    width: u32,
    height: u32,
    overlay: Overlay,
    contacts: &[Contact],
) -> RgbImage {
    let mut canvas = Canvas::new(width, height);
    canvas.grid(sim, camera);
    let light = LIGHT.normalize();
    let mut query = sim.world.query::<(&crate::ActorIndex, &crate::Pose, &crate::Mesh, &crate::MassProps)>();
    let mut actors: Vec<_> = query.iter().map(|(i, p, m, mass)| (i.0 as usize, *p, m.id, mass.is_fixed())).collect();
    actors.sort_by_key(|a| a.0);
    for (index, pose, mesh, fixed) in actors {
        let mesh = sim.ctx.meshes.get(mesh);
        let base = actor_colour(index, fixed).map(f64::from);
        let world: Vec<Vector> = mesh.vertices.iter().map(|&v| pose.transform_point(v)).collect();
        if fixed && !overlay.solid_fixed {
            for &[i, j] in &mesh.feature_edges {
                canvas.line(camera, world[i as usize], world[j as usize], Rgb([120, 124, 132]), true);
            }
            continue;
        }
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| world[i as usize]);
            let Some(n) = (b - a).cross(c - a).try_normalize() else { continue };
            if n.dot(camera.eye - a) <= 0.0 {
                continue; // back face of a closed convex body
            }
            let shade = 0.35 + 0.65 * n.dot(light).max(0.0);
            canvas.triangle(camera, [a, b, c], Rgb(base.map(|k| (k * shade).min(255.0) as u8)));
        }
    }
    draw_joints(sim, camera, &mut canvas);
    if overlay.contacts {
        let scale = (camera.target - camera.eye).length() * 0.04;
        for c in contacts {
            canvas.line(camera, c.point, c.point + c.normal * scale * 2.0, Rgb([220, 30, 30]), false);
            for axis in [Vector::X, Vector::Y, Vector::Z] {
                canvas.line(
                    camera,
                    c.point - axis * scale * 0.3,
                    c.point + axis * scale * 0.3,
                    Rgb([250, 200, 0]),
                    false,
                );
            }
        }
    }
    canvas.image
}

/// Each joint's anchors (cyan crosses, joined by a line where they are apart: a rod, a rope,
/// a spring), and a hinge's or slider's axis (magenta), drawn over the bodies.
fn draw_joints(sim: &Sim, camera: &Camera, canvas: &mut Canvas) {
    let Some(joints) = sim.ctx.scratch.get::<crate::solver::Joints>().filter(|j| !j.joints.is_empty()) else {
        return;
    };
    let actors = sim.actors();
    let to_world = |i: u32, p: Vector| {
        let pose = &actors[i as usize].pose;
        pose.position + pose.orientation * p
    };
    let scale = (camera.target - camera.eye).length() * 0.03;
    let (cyan, magenta) = (Rgb([40, 220, 230]), Rgb([230, 60, 220]));
    for joint in &joints.joints {
        let on_a = to_world(joint.a, joint.anchor_a);
        let on_b = joint.b.map_or(joint.anchor_b, |b| to_world(b, joint.anchor_b));
        for p in [on_a, on_b] {
            for axis in [Vector::X, Vector::Y, Vector::Z] {
                canvas.line(camera, p - axis * scale * 0.4, p + axis * scale * 0.4, cyan, false);
            }
        }
        canvas.line(camera, on_a, on_b, cyan, false);
        if matches!(joint.kind, crate::solver::JointKind::Hinge { .. } | crate::solver::JointKind::Slider { .. }) {
            let axis = actors[joint.a as usize].pose.orientation * joint.axis_a;
            canvas.line(camera, on_a - axis * scale * 2.0, on_a + axis * scale * 2.0, magenta, false);
        }
    }
}

/// Colour and depth buffers.
struct Canvas {
    image: RgbImage,
    depth: Vec<Scalar>,
}

impl Canvas {
    fn new(width: u32, height: u32) -> Self {
        Self {
            image: RgbImage::from_pixel(width, height, SKY),
            depth: vec![Scalar::INFINITY; (width * height) as usize],
        }
    }

    fn plot(&mut self, x: i64, y: i64, z: Scalar, colour: Rgb<u8>, depth_test: bool) {
        let (w, h) = (i64::from(self.image.width()), i64::from(self.image.height()));
        if x < 0 || y < 0 || x >= w || y >= h {
            return;
        }
        let k = (y * w + x) as usize;
        if !depth_test || z < self.depth[k] {
            if depth_test {
                self.depth[k] = z;
            }
            self.image.put_pixel(x as u32, y as u32, colour);
        }
    }

    /// Fills a triangle: edge functions over its pixel box, depth interpolated as 1/z (which is
    /// linear in screen space, so the z-buffer is perspective-correct).
    fn triangle(&mut self, camera: &Camera, corners: [Vector; 3], colour: Rgb<u8>) {
        let (w, h) = (self.image.width(), self.image.height());
        let Some(p) = corners.iter().map(|&c| camera.project(c, w, h)).collect::<Option<Vec<_>>>() else { return };
        let area = edge(p[0], p[1], p[2]);
        if area.abs() < 1e-12 {
            return;
        }
        let x0 = p.iter().map(|q| q.0).fold(Scalar::INFINITY, Scalar::min).floor().max(0.0) as i64;
        let x1 = p.iter().map(|q| q.0).fold(Scalar::NEG_INFINITY, Scalar::max).ceil().min(f64::from(w) - 1.0) as i64;
        let y0 = p.iter().map(|q| q.1).fold(Scalar::INFINITY, Scalar::min).floor().max(0.0) as i64;
        let y1 = p.iter().map(|q| q.1).fold(Scalar::NEG_INFINITY, Scalar::max).ceil().min(f64::from(h) - 1.0) as i64;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let s = (x as f64 + 0.5, y as f64 + 0.5, 0.0);
                let (w0, w1, w2) = (edge(p[1], p[2], s) / area, edge(p[2], p[0], s) / area, edge(p[0], p[1], s) / area);
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let inv_z = w0 / p[0].2 + w1 / p[1].2 + w2 / p[2].2;
                self.plot(x, y, 1.0 / inv_z, colour, true);
            }
        }
    }

    /// A world segment, sampled per pixel; `depth_test` false draws it on top.
    fn line(&mut self, camera: &Camera, a: Vector, b: Vector, colour: Rgb<u8>, depth_test: bool) {
        let (w, h) = (self.image.width(), self.image.height());
        let (Some(pa), Some(pb)) = (camera.project(a, w, h), camera.project(b, w, h)) else { return };
        let n = ((pb.0 - pa.0).abs().max((pb.1 - pa.1).abs()).ceil() as usize).clamp(1, 4 * (w + h) as usize);
        for k in 0..=n {
            let t = k as f64 / n as f64;
            let Some((x, y, z)) = camera.project(a + (b - a) * t, w, h) else { continue };
            // A small bias keeps grid lines on a floor's top face visible.
            self.plot(x as i64, y as i64, z * (1.0 - 1e-4), colour, depth_test);
        }
    }

    /// A ground grid under the scene, on the floor's top if there is one, and short axes at
    /// the origin (x red, y green, z blue). Its spacing follows what the camera sees, and it
    /// stops a few views' widths from the target, so a close view of a pile on a wide floor
    /// still gets a grid of useful size.
    fn grid(&mut self, sim: &Sim, camera: &Camera) {
        let (lo, hi) = scene_bounds(sim);
        // About the width of the picture at the target's distance.
        let view = 2.0 * (camera.target - camera.eye).length() * (camera.fov_y * 0.5).tan();
        let extent = (hi.x - lo.x).max(hi.z - lo.z).max(1.0);
        let reach = 2.0 * view;
        let (t, near) = (camera.target, |a: Scalar, b: Scalar, t: Scalar| (a.max(t - reach), b.min(t + reach)));
        let ((xa, xb), (za, zb)) = (near(lo.x, hi.x, t.x), near(lo.z, hi.z, t.z));
        // Looking away from the scene: the whole scene's grid, as coarse as before.
        let ((xa, xb), (za, zb), extent) = if xa <= xb && za <= zb && view > 0.0 {
            ((xa, xb), (za, zb), extent.min(view.max(0.1)))
        } else {
            ((lo.x, hi.x), (lo.z, hi.z), extent)
        };
        let step = nice_step(extent / 10.0);
        let (x0, x1) = ((xa / step).floor() * step, (xb / step).ceil() * step);
        let (z0, z1) = ((za / step).floor() * step, (zb / step).ceil() * step);
        let y = floor_top(sim, (lo, hi)).unwrap_or(lo.y);
        let mut x = x0;
        while x <= x1 + 1e-9 {
            self.line(camera, Vector::new(x, y, z0), Vector::new(x, y, z1), GRID, true);
            x += step;
        }
        let mut z = z0;
        while z <= z1 + 1e-9 {
            self.line(camera, Vector::new(x0, y, z), Vector::new(x1, y, z), GRID, true);
            z += step;
        }
        for (axis, colour) in [(Vector::X, [200, 40, 40]), (Vector::Y, [40, 160, 40]), (Vector::Z, [40, 70, 200])] {
            self.line(camera, Vector::ZERO, axis * step, Rgb(colour), true);
        }
    }
}

/// Twice the signed area of the screen triangle (a, b, c).
fn edge(a: (Scalar, Scalar, Scalar), b: (Scalar, Scalar, Scalar), c: (Scalar, Scalar, Scalar)) -> Scalar {
    (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
}

/// 1, 2 or 5 times a power of ten, at least `x`.
fn nice_step(x: Scalar) -> Scalar {
    let p = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * p).find(|&s| s >= x).unwrap_or(10.0 * p)
}
