//! Scene files (docs/scenes.md): the RON schema, parsing with positions in errors, checks
//! of every value, and building a `Sim`. Degrees become radians here, once.

use crate::error::SceneError;
use crate::math::{Scalar, Vector};
use crate::scene::spawners::SpawnerDef;
use miette::NamedSource;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Largest scene file read [bytes]: bounds memory and time on hostile input.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;
/// Most steps a scene may ask for: a typo should not start a run of centuries.
pub const MAX_STEPS: u64 = 100_000_000;
/// Deepest nesting the parser follows before giving up with an error.
pub const MAX_NESTING: usize = 64;

/// A 3-vector as written in a scene: `(x, y, z)`.
pub type V3 = (Scalar, Scalar, Scalar);

/// Converts a scene triple to a vector.
#[must_use]
pub fn vector((x, y, z): V3) -> Vector {
    Vector::new(x, y, z)
}

/// A whole scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Scene")]
pub struct SceneDef {
    /// Seconds per step (default 1/60).
    #[serde(default = "default_dt")]
    pub dt: Scalar,
    /// Steps for `rigid run` (default 600).
    #[serde(default = "default_steps")]
    pub steps: u64,
    /// Gravity [m/s²] (default (0, −9.81, 0)).
    #[serde(default = "default_gravity")]
    pub gravity: V3,
    /// The listed actors.
    pub actors: Vec<ActorDef>,
    /// Generators of many actors, spawned after `actors` in order.
    #[serde(default)]
    pub spawners: Vec<SpawnerDef>,
    /// System names in run order (default: the default schedule).
    #[serde(default)]
    pub schedule: Option<Vec<String>>,
    /// Contact-solver settings.
    #[serde(default)]
    pub solver: SolverDef,
    /// Camera for `rigid render` (default: fitted to the scene).
    #[serde(default)]
    pub camera: Option<CameraDef>,
    /// Joints between actors, or an actor and the world (docs/joints.md).
    #[serde(default)]
    pub joints: Vec<crate::scene::joints::JointDef>,
}

/// A camera for `rigid render`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, rename = "Camera")]
pub struct CameraDef {
    /// Eye position [m].
    pub eye: V3,
    /// Point looked at [m].
    pub target: V3,
    /// Vertical field of view [degrees] (default 45).
    #[serde(default = "default_fov")]
    pub fov: Scalar,
}

fn default_fov() -> Scalar {
    crate::io::render::DEFAULT_FOV_DEGREES
}

fn default_dt() -> Scalar {
    1.0 / 60.0
}
fn default_steps() -> u64 {
    600
}
fn default_gravity() -> V3 {
    (0.0, -9.81, 0.0)
}

/// Settings of `resolve` and `correct` (docs/physics.md §2.5–2.6); defaults in `Params`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, rename = "Solver", default)]
pub struct SolverDef {
    /// Most impulse sweeps per step (1..=1000, default 20).
    pub max_sweeps: u32,
    /// Fraction of penetration removed per step, 0..=1 (default 0.4).
    pub correction: Scalar,
    /// Penetration left alone, fraction of the thinner body, 0..=1 (default 0.0005).
    pub slop: Scalar,
    /// Substeps of the contact solver `solve`, 1..=64 (default `Params::substeps_for(dt)`: 4,
    /// or more for steps longer than 1/60 s, so that each substep is at most 1/240 s).
    pub substeps: Option<u32>,
    /// Solve sweeps in each of the first half of the substeps of `solve` (the rest take one; a
    /// relax sweep follows them), 1..=1000 (default 2).
    pub iterations: u32,
    /// Still bodies sleep until touched in motion (the `sleep` system; default false).
    pub sleep: bool,
    /// Approach speed [m/s] above which contacts bounce (default 2|g|·dt).
    pub restitution_threshold: Option<Scalar>,
    /// Continuous collision: fast bodies are swept to their time of impact (the `ccd` system;
    /// default true). False: the paper's discrete model.
    pub ccd: bool,
}

impl Default for SolverDef {
    fn default() -> Self {
        let p = crate::sim::context::Params::default();
        Self {
            max_sweeps: p.max_sweeps,
            correction: p.correction,
            slop: p.slop,
            substeps: None,
            iterations: p.iterations,
            sleep: p.sleep,
            restitution_threshold: p.restitution_threshold,
            ccd: p.ccd,
        }
    }
}

/// A shape (docs/scenes.md); every one becomes a closed convex mesh.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum ShapeDef {
    /// Box with these full edge lengths [m].
    Box {
        /// (x, y, z) sizes.
        size: V3,
    },
    /// Regular tetrahedron.
    Tetrahedron {
        /// Edge length [m].
        edge: Scalar,
    },
    /// Regular octahedron.
    Octahedron {
        /// Distance of the vertices from the centre [m].
        radius: Scalar,
    },
    /// Subdivided icosahedron.
    Icosphere {
        /// Radius [m].
        radius: Scalar,
        /// Subdivisions, 0..=5.
        subdivisions: u32,
    },
    /// Prism about y approximating a cylinder.
    Cylinder {
        /// Radius [m].
        radius: Scalar,
        /// Height [m].
        height: Scalar,
        /// Sides, 3..=256.
        segments: u32,
    },
    /// Wavefront OBJ file, path relative to the scene file.
    Obj {
        /// The file.
        path: String,
        /// Uniform scale (default 1).
        #[serde(default = "one")]
        scale: Scalar,
        /// Take the convex hull of the file's `v` points, faces ignored (default false): for
        /// point clouds and non-convex or messy models.
        #[serde(default)]
        hull: bool,
    },
}

fn one() -> Scalar {
    1.0
}

impl ShapeDef {
    /// Checks sizes and counts; `Err((field, reason))`.
    pub(crate) fn check(&self) -> Result<(), (String, String)> {
        let positive = |field: &str, v: Scalar| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((format!("shape.{field}"), format!("must be a finite number > 0 m, got {v}")))
            }
        };
        match self {
            Self::Box { size: (x, y, z) } => {
                [("size.x", *x), ("size.y", *y), ("size.z", *z)].iter().try_for_each(|(f, v)| positive(f, *v))
            }
            Self::Tetrahedron { edge } => positive("edge", *edge),
            Self::Octahedron { radius } => positive("radius", *radius),
            Self::Icosphere { radius, subdivisions } => {
                positive("radius", *radius)?;
                if *subdivisions > crate::model::shapes::MAX_SUBDIVISIONS {
                    return Err((
                        "shape.subdivisions".into(),
                        format!("must be 0..={}, got {subdivisions}", crate::model::shapes::MAX_SUBDIVISIONS),
                    ));
                }
                Ok(())
            }
            Self::Cylinder { radius, height, segments } => {
                positive("radius", *radius)?;
                positive("height", *height)?;
                if !crate::model::shapes::SEGMENTS_RANGE.contains(segments) {
                    let r = crate::model::shapes::SEGMENTS_RANGE;
                    return Err((
                        "shape.segments".into(),
                        format!("must be {}..={}, got {segments}", r.start(), r.end()),
                    ));
                }
                Ok(())
            }
            Self::Obj { path, scale, .. } => {
                if path.is_empty() {
                    return Err(("shape.path".into(), "must name an OBJ file".into()));
                }
                positive("scale", *scale)
            }
        }
    }
}

/// An actor as written, every field optional but `shape` (checked into `ActorDef`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Actor")]
struct RawActor {
    #[serde(default)]
    name: Option<String>,
    shape: ShapeDef,
    #[serde(default)]
    mass: Option<Scalar>,
    #[serde(default)]
    density: Option<Scalar>,
    #[serde(default)]
    position: Option<V3>,
    #[serde(default)]
    rotation: Option<V3>,
    #[serde(default)]
    velocity: Option<V3>,
    #[serde(default)]
    angular_velocity: Option<V3>,
    #[serde(default)]
    restitution: Option<Scalar>,
    #[serde(default)]
    friction: Option<Scalar>,
    #[serde(default)]
    fixed: Option<bool>,
}

/// How an actor's mass is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MassSpec {
    /// Total mass [kg].
    Mass(Scalar),
    /// Density [kg/m³].
    Density(Scalar),
}

/// A checked actor definition. Defaults: name `actor-<index>`, density 1, origin, no
/// rotation, at rest, restitution 0.5, friction 0, not fixed.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(try_from = "RawActor")]
pub struct ActorDef {
    /// Name, if given.
    pub name: Option<String>,
    /// Shape.
    pub shape: ShapeDef,
    /// Mass or density.
    pub mass: MassSpec,
    /// Centre of mass [m].
    pub position: Vector,
    /// Euler angles [degrees], R = Rz·Ry·Rx.
    pub rotation: Vector,
    /// [m/s].
    pub velocity: Vector,
    /// [rad/s], world frame.
    pub angular_velocity: Vector,
    /// 0..=1.
    pub restitution: Scalar,
    /// ≥ 0.
    pub friction: Scalar,
    /// Never moves.
    pub fixed: bool,
}

/// Default restitution (docs/scenes.md).
pub const DEFAULT_RESTITUTION: Scalar = 0.5;

impl TryFrom<RawActor> for ActorDef {
    type Error = String;

    fn try_from(raw: RawActor) -> Result<Self, String> {
        let who = raw.name.as_deref().map_or_else(|| "actor".to_string(), |n| format!("actor '{n}'"));
        let fail = |(field, reason): (String, String)| format!("{who}: {field}: {reason}");
        raw.shape.check().map_err(fail)?;
        let mass = match (raw.mass, raw.density) {
            (Some(_), Some(_)) => return Err(fail(("mass".into(), "give `mass` or `density`, not both".into()))),
            (Some(m), None) => MassSpec::Mass(invertible(positive("mass", m, "kg").map_err(fail)?).map_err(fail)?),
            (None, Some(d)) => MassSpec::Density(positive("density", d, "kg/m^3").map_err(fail)?),
            (None, None) => MassSpec::Density(1.0),
        };
        let v3 = |field: &str, v: Option<V3>| -> Result<Vector, String> {
            let v = vector(v.unwrap_or_default());
            if crate::math::is_finite_vector(v) {
                Ok(v)
            } else {
                Err(fail((field.into(), format!("must be finite, got {v}"))))
            }
        };
        let restitution = raw.restitution.unwrap_or(DEFAULT_RESTITUTION);
        if !(0.0..=1.0).contains(&restitution) {
            return Err(fail(("restitution".into(), format!("must be in 0..=1, got {restitution}"))));
        }
        let friction = raw.friction.unwrap_or(0.0);
        if !(friction.is_finite() && friction >= 0.0) {
            return Err(fail(("friction".into(), format!("must be a finite number >= 0, got {friction}"))));
        }
        if raw.name.as_deref() == Some("") {
            return Err(fail(("name".into(), "must not be empty".into())));
        }
        Ok(Self {
            position: v3("position", raw.position)?,
            rotation: v3("rotation", raw.rotation)?,
            velocity: v3("velocity", raw.velocity)?,
            angular_velocity: v3("angular_velocity", raw.angular_velocity)?,
            name: raw.name,
            shape: raw.shape,
            mass,
            restitution,
            friction,
            fixed: raw.fixed.unwrap_or(false),
        })
    }
}

fn positive(field: &str, v: Scalar, unit: &str) -> Result<Scalar, (String, String)> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err((field.into(), format!("must be a finite number > 0 {unit}, got {v}")))
    }
}

/// A mass whose inverse is finite: the solver works with 1/m, which a subnormal mass overflows.
fn invertible(m: Scalar) -> Result<Scalar, (String, String)> {
    if m.is_normal() {
        Ok(m)
    } else {
        Err((
            "mass".into(),
            format!("{m:e} kg is too small: its inverse overflows (the least is {:e})", Scalar::MIN_POSITIVE),
        ))
    }
}

/// The RON options of every scene: bare optionals (`mass: 1.0`, docs/scenes.md) and a
/// nesting bound.
#[must_use]
pub fn ron_options() -> ron::Options {
    ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .with_recursion_limit(MAX_NESTING)
}

/// Parses scene text; `path` names it in errors.
pub fn parse(text: &str, path: &Path) -> Result<SceneDef, SceneError> {
    let scene: SceneDef = ron_options().from_str(text).map_err(|e| parse_error(e, text, path))?;
    check_scene(&scene, path)?;
    crate::scene::joints::check_references(&scene, text, path)?;
    Ok(scene)
}

/// Reads and parses a scene file.
pub fn load(path: &Path) -> Result<SceneDef, SceneError> {
    parse(&read(path)?, path)
}

/// Reads a scene file's text: bounded in size, and UTF-8 (a binary file is named as such).
pub fn read(path: &Path) -> Result<String, SceneError> {
    let io = |source| SceneError::Io { path: path.to_path_buf(), source };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut std::io::Read::take(file, MAX_SCENE_BYTES + 1), &mut bytes).map_err(io)?;
    if bytes.len() as u64 > MAX_SCENE_BYTES {
        return Err(invalid(path, "scene", "file", format!("larger than {} MiB", MAX_SCENE_BYTES >> 20)));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let text = String::from_utf8_lossy(e.as_bytes()).into_owned();
        error_at(path, &text, (at, 0), "not UTF-8 text (is this a binary file?)".into())
    })?;
    Ok(text)
}

fn parse_error(e: ron::error::SpannedError, text: &str, path: &Path) -> SceneError {
    let (mut line, mut col) = (e.span.start.line.max(1), e.span.start.col.max(1));
    let mut offset = offset_of(text, line, col);
    let mut message = e.code.to_string();
    // RON reports an unknown field after its name: point at the name itself.
    if let ron::Error::NoSuchStructField { found, .. } = &e.code
        && let Some(start) = text.get(..offset).and_then(|t| t.rfind(found.as_str()))
    {
        offset = start;
        (line, col) = line_col(text, offset);
    }
    // RON reports an actor's checked field (`actor 'a': mass: ...`) at the actor's end.
    if let ron::Error::Message(m) = &e.code
        && let Some(at) = actor_field(text, offset, m)
    {
        offset = at;
        (line, col) = line_col(text, offset);
    }
    // An actor without a name is reported by its place in the list.
    if let Some(rest) = message.strip_prefix("actor: ") {
        message = format!("{}: {rest}", unnamed_actor(text, offset));
    }
    if let Some(rest) = message.strip_prefix("joint: ") {
        message = format!("{}: {rest}", crate::scene::joints::unnamed_joint(text, offset));
    }
    // RON's type errors ("Expected float") do not say where; name the field being read.
    if let ron::Error::ExpectedFloat
    | ron::Error::ExpectedInteger
    | ron::Error::ExpectedBoolean
    | ron::Error::ExpectedString
    | ron::Error::ExpectedArray
    | ron::Error::ExpectedNamedStructLike(_)
    | ron::Error::ExpectedStructLike
    | ron::Error::ExpectedMap = e.code
        && let Some(field) = field_before(text, offset)
    {
        message = format!("{message} for field `{field}`");
    }
    SceneError::Parse {
        path: path.to_path_buf(),
        line,
        col,
        message,
        text: NamedSource::new(path.display().to_string(), text.to_string()),
        at: (offset, token_len(text, offset)).into(),
    }
}

/// Where the field an actor's check names (`actor 'a': shape.size.x: ...` names `shape`) is
/// written in the actor whose text ends at `offset`.
fn actor_field(text: &str, offset: usize, message: &str) -> Option<usize> {
    let rest =
        message.strip_prefix("actor: ").or_else(|| Some(message.strip_prefix("actor '")?.split_once("': ")?.1))?;
    let field = rest.split([':', '.']).next()?;
    let before = text.get(..offset)?;
    let start = before.rfind("Actor(")?;
    let mut from = offset;
    while let Some(i) = before[start..from].rfind(field) {
        let at = start + i;
        let after = before[at + field.len()..].trim_start();
        let boundary = !before[..at].ends_with(|c: char| c.is_alphanumeric() || c == '_');
        if boundary && after.starts_with(':') {
            return Some(at);
        }
        from = at;
    }
    None
}

/// The length of the word or number at `offset` (at least one character, unless at the end):
/// the snippet underlines it instead of pointing between two characters.
fn token_len(text: &str, offset: usize) -> usize {
    let rest = text.get(offset..).unwrap_or("");
    let word = rest.find(|c: char| !(c.is_alphanumeric() || "_.-+".contains(c))).unwrap_or(rest.len());
    if word > 0 { word } else { rest.chars().next().map_or(0, char::len_utf8) }
}

/// How to name an actor without a `name` whose text ends at `offset`: its index in `actors`
/// (the default name `actor-<index>` says the same), or the template of a spawner.
fn unnamed_actor(text: &str, offset: usize) -> String {
    let before = text.get(..offset).unwrap_or(text);
    let list = before.rfind("actors").unwrap_or(0);
    if before.rfind("spawners").is_some_and(|s| s > list) {
        return "a spawner's actor (no name)".to_string();
    }
    let index = before[list..].matches("Actor(").count().saturating_sub(1);
    format!("actor #{index} (no name; it would be 'actor-{index}')")
}

/// The `name` of the nearest `name:` before `offset`, if the text there is a field.
fn field_before(text: &str, offset: usize) -> Option<&str> {
    let before = text.get(..offset)?.trim_end();
    let before = before.strip_suffix(':')?.trim_end();
    let start = before.rfind(|c: char| !(c.is_alphanumeric() || c == '_')).map_or(0, |i| i + 1);
    let name = &before[start..];
    (!name.is_empty()).then_some(name)
}

fn offset_of(text: &str, line: usize, col: usize) -> usize {
    let start: usize = text.split_inclusive('\n').take(line - 1).map(str::len).sum();
    let line_text = text.get(start..).unwrap_or("").lines().next().unwrap_or("");
    (start + line_text.char_indices().nth(col - 1).map_or(line_text.len(), |(i, _)| i)).min(text.len())
}

/// A `Parse` error for the `len` bytes at byte `offset` of `text` (the snippet underlines them).
pub(crate) fn error_at(path: &Path, text: &str, (offset, len): (usize, usize), message: String) -> SceneError {
    let (line, col) = line_col(text, offset);
    SceneError::Parse {
        path: path.to_path_buf(),
        line,
        col,
        message,
        text: NamedSource::new(path.display().to_string(), text.to_string()),
        at: (offset, len).into(),
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text.as_bytes()[..offset.min(text.len())];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let col = before.iter().rev().take_while(|&&b| b != b'\n').count() + 1;
    (line, col)
}

/// An `Invalid` error for `actor`'s `field`.
pub fn invalid(path: &Path, actor: &str, field: &str, reason: String) -> SceneError {
    SceneError::Invalid { path: path.to_path_buf(), actor: actor.to_string(), field: field.to_string(), reason }
}

fn check_scene(scene: &SceneDef, path: &Path) -> Result<(), SceneError> {
    if !(scene.dt.is_finite() && scene.dt > 0.0) {
        return Err(invalid(path, "scene", "dt", format!("must be a finite number > 0 s, got {}", scene.dt)));
    }
    if scene.steps > MAX_STEPS {
        return Err(invalid(path, "scene", "steps", format!("{} is more than the limit of {MAX_STEPS}", scene.steps)));
    }
    if !crate::math::is_finite_vector(vector(scene.gravity)) {
        return Err(invalid(path, "scene", "gravity", "must be finite".into()));
    }
    if let Some(c) = scene.camera {
        let finite = crate::math::is_finite_vector(vector(c.eye)) && crate::math::is_finite_vector(vector(c.target));
        if !finite || vector(c.eye) == vector(c.target) {
            return Err(invalid(path, "scene", "camera", "eye and target must be finite and different".into()));
        }
        if !(c.fov > 1.0 && c.fov < 179.0) {
            return Err(invalid(path, "scene", "camera.fov", format!("must be in 1..179 degrees, got {}", c.fov)));
        }
    }
    let s = scene.solver;
    if !(1..=1000).contains(&s.max_sweeps) {
        return Err(invalid(path, "scene", "solver.max_sweeps", format!("must be 1..=1000, got {}", s.max_sweeps)));
    }
    if let Some(n) = s.substeps
        && !(1..=64).contains(&n)
    {
        return Err(invalid(path, "scene", "solver.substeps", format!("must be 1..=64, got {n}")));
    }
    if !(1..=1000).contains(&s.iterations) {
        return Err(invalid(path, "scene", "solver.iterations", format!("must be 1..=1000, got {}", s.iterations)));
    }
    if let Some(t) = s.restitution_threshold
        && !(t.is_finite() && t >= 0.0)
    {
        return Err(invalid(
            path,
            "scene",
            "solver.restitution_threshold",
            format!("must be a finite speed >= 0, got {t}"),
        ));
    }
    for (field, v) in [("solver.correction", s.correction), ("solver.slop", s.slop)] {
        if !(0.0..=1.0).contains(&v) {
            return Err(invalid(path, "scene", field, format!("must be in 0..=1, got {v}")));
        }
    }
    Ok(())
}

/// Where relative paths in a scene (OBJ files) are resolved from.
#[must_use]
pub fn base_dir(path: &Path) -> PathBuf {
    path.parent().map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}
