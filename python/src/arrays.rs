//! Whole-state numpy arrays: one pass over the world per array, rows in actor (scene) order.
//! Writes are checked whole before any row changes, and leave the sim as a step would find it.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rigid_sandbox::{ActorIndex, MassProps, Pose, Sim, Velocity};

/// A per-actor quantity exposed as an array.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// Centre of mass [m].
    Position,
    /// Unit quaternion [x, y, z, w].
    Orientation,
    /// [m/s].
    Velocity,
    /// World frame [rad/s].
    AngularVelocity,
}

impl Field {
    fn width(self) -> usize {
        if self == Self::Orientation { 4 } else { 3 }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Position => "positions",
            Self::Orientation => "orientations",
            Self::Velocity => "velocities",
            Self::AngularVelocity => "angular_velocities",
        }
    }

    fn get(self, pose: &Pose, vel: &Velocity) -> [f64; 4] {
        let [x, y, z] = match self {
            Self::Orientation => return pose.orientation.to_array(),
            Self::Position => pose.position.to_array(),
            Self::Velocity => vel.linear.to_array(),
            Self::AngularVelocity => vel.angular.to_array(),
        };
        [x, y, z, 0.0]
    }
}

/// The field of every actor as an (N, width) float64 array.
pub fn read<'py>(py: Python<'py>, sim: &Sim, field: Field) -> Bound<'py, PyArray2<f64>> {
    let (n, w) = (sim.len(), field.width());
    let mut out = vec![0.0; n * w];
    // hecs yields archetype order; the actor index places each row.
    for (index, pose, vel) in sim.world.query::<(&ActorIndex, &Pose, &Velocity)>().iter() {
        let i = index.0 as usize * w;
        out[i..i + w].copy_from_slice(&field.get(pose, vel)[..w]);
    }
    Array2::from_shape_vec((n, w), out).expect("n rows of w values").into_pyarray(py)
}

/// Sets the field (positions, velocities or angular velocities) of every actor from `array`,
/// anything numpy reads as (N, 3) floats. Refused whole, with a ValueError, if the shape is
/// wrong, a value is not finite, or a fixed actor's row would give it a velocity.
pub fn write(sim: &mut Sim, field: Field, array: &Bound<'_, PyAny>) -> PyResult<()> {
    debug_assert!(field != Field::Orientation, "orientations are read-only");
    let py = array.py();
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let converted = py.import("numpy")?.getattr("ascontiguousarray")?.call((array,), Some(&kwargs))?;
    let values: PyReadonlyArrayDyn<'_, f64> = converted.extract()?;
    let n = sim.len();
    if values.shape() != [n, 3] {
        return Err(PyValueError::new_err(format!(
            "set_{}: expected an array of shape ({n}, 3), one row per actor, got shape {:?}",
            field.name(),
            values.shape()
        )));
    }
    let rows: Vec<[f64; 3]> = values.as_slice()?.chunks_exact(3).map(|r| [r[0], r[1], r[2]]).collect();
    check_rows(sim, field, &rows)?;
    let mut changed = vec![false; n];
    let moves = field == Field::Position;
    for (index, pose, vel, mass) in sim.world.query_mut::<(&ActorIndex, &mut Pose, &mut Velocity, &MassProps)>() {
        let i = index.0 as usize;
        if !moves && mass.is_fixed() {
            continue; // checked to be 0; a -0.0 must not change the state's bits
        }
        let target = match field {
            Field::Position => &mut pose.position,
            Field::Velocity => &mut vel.linear,
            _ => &mut vel.angular,
        };
        let new = rigid_sandbox::math::Vector::from_array(rows[i]);
        changed[i] = *target != new;
        *target = new;
    }
    // A sleeping body would ignore its new state until something touched it.
    for (i, _) in changed.iter().enumerate().filter(|(_, c)| **c) {
        if let Some(a) = sim.ctx.sleep.asleep.get_mut(i) {
            *a = false;
        }
        if let Some(t) = sim.ctx.sleep.still.get_mut(i) {
            *t = 0.0;
        }
    }
    // The step's arrays and posed meshes follow the world, as after a custom system's edit.
    sim.ctx.reload(&sim.world);
    Ok(())
}

/// Every row finite; fixed actors keep zero velocities (they never move).
fn check_rows(sim: &Sim, field: Field, rows: &[[f64; 3]]) -> PyResult<()> {
    let names = sim.names();
    if let Some(i) = rows.iter().position(|r| !r.iter().all(|x| x.is_finite())) {
        return Err(PyValueError::new_err(format!(
            "set_{}: row {i} (actor '{}') is not finite: {:?}",
            field.name(),
            names[i],
            rows[i]
        )));
    }
    if field == Field::Position {
        return Ok(());
    }
    for (index, mass) in sim.world.query::<(&ActorIndex, &MassProps)>().iter() {
        let i = index.0 as usize;
        if mass.is_fixed() && rows[i] != [0.0; 3] {
            return Err(PyValueError::new_err(format!(
                "set_{}: row {i}: actor '{}' is fixed, so its row must be 0, got {:?}",
                field.name(),
                names[i],
                rows[i]
            )));
        }
    }
    Ok(())
}
