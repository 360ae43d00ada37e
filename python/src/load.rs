//! Scenes from Python: `set={"PATH": value}` becomes the `--set PATH=VALUE` arguments of
//! `rigid`, and loading goes through the library's own functions, so a bad scene or override
//! raises `SceneError` with the message `rigid` prints.

use crate::SceneError;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyList, PyString, PyTuple};
use rigid_sandbox::Sim;
use std::path::Path;

/// The `--set` arguments a `set` mapping stands for, in its order.
pub fn set_args(set: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    let Some(set) = set.filter(|s| !s.is_none()) else { return Ok(Vec::new()) };
    let dict = set.cast::<PyDict>().map_err(|_| PyTypeError::new_err("set must be a dict of PATH: value"))?;
    let mut args = Vec::with_capacity(dict.len());
    for (key, value) in dict.iter() {
        let path: String =
            key.extract().map_err(|_| PyTypeError::new_err(format!("set: the key {key} is not a str PATH")))?;
        args.push(format!("{path}={}", ron_value(&value)?));
    }
    Ok(args)
}

/// A Python value as RON: bool, int, float (shortest round-trip digits), a tuple as `(..)`, a
/// list as `[..]`, and a str as RON text already (`"(0.0, -1.62, 0.0)"`, `'"ball"'`).
pub fn ron_value(value: &Bound<'_, PyAny>) -> PyResult<String> {
    if value.is_instance_of::<PyBool>() {
        return Ok(value.extract::<bool>()?.to_string());
    }
    if value.is_instance_of::<PyString>() {
        return value.extract();
    }
    if value.is_instance_of::<PyFloat>() {
        // Debug prints the shortest digits that read back as the same f64, with a '.' or 'e'.
        return Ok(format!("{:?}", value.extract::<f64>()?));
    }
    if let Ok(i) = value.extract::<i64>() {
        return Ok(i.to_string());
    }
    if let Ok(x) = value.extract::<f64>() {
        return Ok(format!("{x:?}"));
    }
    let items = |open: &str, close: &str, list: Vec<Bound<'_, PyAny>>| -> PyResult<String> {
        let parts: PyResult<Vec<String>> = list.iter().map(ron_value).collect();
        Ok(format!("{open}{}{close}", parts?.join(", ")))
    };
    if let Ok(t) = value.cast::<PyTuple>() {
        return items("(", ")", t.iter().collect());
    }
    if let Ok(l) = value.cast::<PyList>() {
        return items("[", "]", l.iter().collect());
    }
    Err(PyTypeError::new_err(format!(
        "set: cannot write {} as a scene value; give a number, bool, tuple, list or RON text",
        value.get_type().name()?
    )))
}

/// Builds the scene `text` (named `path`) with the `--set` arguments `sets`; returns it with
/// the scene's own step count.
pub fn build(text: &str, path: &Path, sets: &[String]) -> PyResult<(Sim, u64)> {
    let scene_error = |e: &dyn std::fmt::Display| SceneError::new_err(e.to_string());
    let (def, _) = rigid_sandbox::cli::parse_scene_set(text, path, sets).map_err(|e| scene_error(&e))?;
    let sim = rigid_sandbox::scene::build(&def, path).map_err(|e| scene_error(&e))?;
    Ok((sim, def.steps))
}
