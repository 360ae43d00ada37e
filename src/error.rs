//! Typed errors per layer, and which of them are bad input (exit code 2, docs/cli.md).

use miette::{NamedSource, SourceSpan};
use std::path::PathBuf;

/// Why a triangle mesh cannot be a body (docs/physics.md §3.3).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshError {
    /// The mesh file could not be read or parsed.
    #[error("{reason}")]
    Unreadable {
        /// What went wrong.
        reason: String,
    },
    /// Too few vertices or triangles to enclose a volume.
    #[error(
        "mesh is empty or too small: {vertices} vertices, {triangles} triangles (a closed solid needs at least 4 of each)"
    )]
    Empty {
        /// Vertex count.
        vertices: usize,
        /// Triangle count.
        triangles: usize,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a NaN or infinite coordinate")]
    NonFinite {
        /// Vertex index (0-based).
        vertex: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to a vertex past the {vertices} vertices")]
    BadIndex {
        /// Triangle index (0-based).
        triangle: usize,
        /// Vertex count.
        vertices: usize,
    },
    /// A triangle uses one vertex twice.
    #[error("triangle {triangle} is degenerate: it uses one vertex twice")]
    RepeatedIndex {
        /// Triangle index (0-based).
        triangle: usize,
    },
    /// An edge is not shared by exactly two triangles.
    #[error(
        "mesh is not closed: edge ({a}, {b}) is used by {triangles} triangle(s), a closed mesh uses every edge exactly twice"
    )]
    Open {
        /// First vertex of the edge.
        a: u32,
        /// Second vertex of the edge.
        b: u32,
        /// How many triangles use it.
        triangles: usize,
    },
    /// The triangles form more than one piece.
    #[error("mesh is not one connected surface: triangle {triangle} cannot be reached from triangle 0")]
    Disconnected {
        /// A triangle of another piece.
        triangle: usize,
    },
    /// The mesh encloses no volume.
    #[error("mesh is degenerate: it encloses (almost) no volume ({volume:e} m^3)")]
    Degenerate {
        /// The volume found [m³].
        volume: f64,
    },
    /// A vertex stands in front of a face plane.
    #[error(
        "mesh is not convex: vertex {vertex} lies {distance:e} m in front of face plane {face}; use `hull: true` for the convex hull of its points"
    )]
    NonConvex {
        /// Vertex index.
        vertex: usize,
        /// Plane index.
        face: usize,
        /// Distance in front [m].
        distance: f64,
    },
}

/// Bad scene input: every variant is exit code 2.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// RON syntax, unknown field, wrong type, or a value rejected while parsing.
    #[error("{}:{}:{}: {}", .path.display(), .line, .col, .message)]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        col: usize,
        /// What is wrong.
        message: String,
        /// The file's text, for the snippet.
        #[source_code]
        text: NamedSource<String>,
        /// Where.
        #[label("here")]
        at: SourceSpan,
    },
    /// A value that parsed but is not allowed, found after parsing.
    #[error("{}: {}{}: {}", .path.display(), subject(.actor), .field, .reason)]
    Invalid {
        /// The scene file.
        path: PathBuf,
        /// The actor's name (or "scene" for scene-wide fields, which name no actor).
        actor: String,
        /// The field.
        field: String,
        /// What is expected.
        reason: String,
    },
    /// An actor's mesh is not a valid convex body.
    #[error("{}: actor '{}': shape: {}: {source}", .path.display(), .actor, .mesh.display())]
    Mesh {
        /// The scene file.
        path: PathBuf,
        /// The actor.
        actor: String,
        /// The mesh (OBJ path, or the shape's name).
        mesh: PathBuf,
        /// What is wrong with it.
        source: MeshError,
    },
}

/// A snapshot file that cannot be resumed (exit 2).
#[derive(Debug, thiserror::Error)]
#[error("{}{}: {message}", .path.display(), .at.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
pub struct SnapshotError {
    /// The file.
    pub path: PathBuf,
    /// Line and column, where the problem is in the text.
    pub at: Option<(usize, usize)>,
    /// What is wrong.
    pub message: String,
}

/// The simulation reached a non-finite state (NaN guard).
#[derive(Debug, Clone, thiserror::Error)]
#[error("non-finite state at step {step} after system '{system}': actor '{actor}' ({field})")]
pub struct StepError {
    /// The step that failed (1-based: the step being computed).
    pub step: u64,
    /// The system after which the state was first non-finite.
    pub system: String,
    /// The actor's name.
    pub actor: String,
    /// Which quantity.
    pub field: &'static str,
}

/// Editing a schedule by name failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScheduleError {
    /// No system of that name in the schedule (or registry).
    #[error("unknown system '{name}'; valid names: {}", .valid.join(", "))]
    Unknown {
        /// The name asked for.
        name: String,
        /// The names that exist.
        valid: Vec<String>,
    },
    /// A system of that name is already in the schedule.
    #[error("system '{name}' is already in the schedule")]
    Duplicate {
        /// The name.
        name: String,
    },
}

/// The "actor 'x': " an `Invalid` error starts with, or nothing for a scene-wide field.
fn subject(actor: &str) -> String {
    if actor == "scene" { String::new() } else { format!("actor '{actor}': ") }
}
