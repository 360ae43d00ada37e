//! `rigid_sandbox._native`: the Python package's compiled part (docs/python.md). It loads
//! scenes through the library's own loaders, so errors read as `rigid`'s, steps with the GIL
//! released, and hands state to numpy as whole arrays, never one body at a time.

mod arrays;
mod load;
mod sim;

use pyo3::prelude::*;

pyo3::create_exception!(
    rigid_sandbox,
    SceneError,
    pyo3::exceptions::PyValueError,
    "A scene, or a `set` override of it, is bad input: the message is the one `rigid` prints."
);
pyo3::create_exception!(
    rigid_sandbox,
    SimulationError,
    pyo3::exceptions::PyRuntimeError,
    "The simulation reached a non-finite state; the message names the step, system, actor and field."
);

/// The text of a scene file, read as `rigid` reads it (so a sweep can ship it to its workers).
#[pyfunction]
fn read_scene(path: std::path::PathBuf) -> PyResult<String> {
    rigid_sandbox::scene::read(&path).map_err(|e| SceneError::new_err(e.to_string()))
}

/// Checks that `text` (named `path`) with the overrides `set` is a valid scene, without
/// building it: a sweep checks every grid point before it runs any.
#[pyfunction]
#[pyo3(signature = (text, path, set=None))]
fn check_scene(text: &str, path: std::path::PathBuf, set: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
    let sets = load::set_args(set)?;
    rigid_sandbox::cli::parse_scene_set(text, &path, &sets).map_err(|e| SceneError::new_err(e.to_string()))?;
    Ok(())
}

/// Runs one scene for `steps` steps (default: the scene's own) and returns the final state as
/// the JSON text of `rigid run --out`. `text` is the scene's text if already read, else the
/// file at `path` is read. The GIL is released while it steps.
#[pyfunction]
#[pyo3(signature = (path, set=None, steps=None, threads=None, text=None))]
fn run_scene(
    py: Python<'_>,
    path: std::path::PathBuf,
    set: Option<&Bound<'_, PyAny>>,
    steps: Option<u64>,
    threads: Option<usize>,
    text: Option<&str>,
) -> PyResult<String> {
    let sets = load::set_args(set)?;
    let text = match text {
        Some(t) => t.to_string(),
        None => read_scene(path.clone())?,
    };
    let (mut sim, scene_steps) = load::build(&text, &path, &sets)?;
    let mut runner = sim::Runner::new(threads)?;
    runner.run(py, &mut sim, steps.unwrap_or(scene_steps))?;
    Ok(rigid_sandbox::io::output::state_json(&sim, &sim.actors()))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<sim::Sim>()?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add("SimulationError", m.py().get_type::<SimulationError>())?;
    m.add_function(wrap_pyfunction!(read_scene, m)?)?;
    m.add_function(wrap_pyfunction!(check_scene, m)?)?;
    m.add_function(wrap_pyfunction!(run_scene, m)?)?;
    Ok(())
}
