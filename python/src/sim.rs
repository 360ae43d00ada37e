//! `rigid_sandbox.Sim`: one simulation, stepped with the GIL released on its own thread pool,
//! its state read and written as numpy arrays (`arrays.rs`).

use crate::arrays::{self, Field};
use crate::{SceneError, SimulationError, load};
use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyType;
use rigid_sandbox::io::output::{state_hash, state_json};
use rigid_sandbox::scene::benchmarks::{BenchScene, DEFAULT_HULL_RAIN_SUBDIVISIONS, scene_sim};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

/// How often the thread waiting for a `step` looks for Ctrl-C.
const SIGNAL_CHECK: Duration = Duration::from_millis(50);

/// Steps sims in a rayon pool of its own, as `rigid --threads T` does: results are the same
/// for any thread count.
pub struct Runner {
    pool: rayon::ThreadPool,
}

impl Runner {
    /// A pool of `threads` workers (default: the number of cores), 1..=1024 as for `rigid`.
    pub fn new(threads: Option<usize>) -> PyResult<Self> {
        let n = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from));
        if !(1..=1024).contains(&n) {
            return Err(PyValueError::new_err(format!("threads must be in 1..=1024, got {n}")));
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| PyValueError::new_err(format!("cannot start {n} worker threads: {e}")))?;
        Ok(Self { pool })
    }

    /// Runs `n` steps with the GIL released, all on one worker of the pool as `rigid` runs
    /// them. This thread waits, taking the GIL now and then to let Ctrl-C through: the run then
    /// stops at a step boundary, the steps done kept.
    pub fn run(&mut self, py: Python<'_>, sim: &mut rigid_sandbox::Sim, n: u64) -> PyResult<()> {
        let stop = AtomicBool::new(false);
        let mut interrupted = None;
        let result = py.detach(|| {
            let (done_tx, done_rx) = mpsc::channel();
            self.pool.in_place_scope(|scope| {
                let stop = &stop;
                scope.spawn(move |_| {
                    let mut steps = (0..n).take_while(|_| !stop.load(Ordering::Relaxed));
                    let _ = done_tx.send(steps.try_for_each(|_| sim.step()));
                });
                loop {
                    match done_rx.recv_timeout(SIGNAL_CHECK) {
                        Ok(result) => return Ok(result),
                        // The job panicked; the scope passes the panic on.
                        Err(RecvTimeoutError::Disconnected) => return Err(()),
                        Err(RecvTimeoutError::Timeout) if interrupted.is_none() => {
                            if let Err(e) = Python::attach(|py| py.check_signals()) {
                                interrupted = Some(e);
                                stop.store(true, Ordering::Relaxed);
                            }
                        }
                        Err(RecvTimeoutError::Timeout) => {}
                    }
                }
            })
        });
        if let Some(e) = interrupted {
            return Err(e);
        }
        match result {
            Ok(Ok(())) => Ok(()),
            Ok(Err(e)) => Err(SimulationError::new_err(e.to_string())),
            Err(()) => Err(SimulationError::new_err("the step panicked")),
        }
    }

    fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }
}

/// A simulation: a scene built and ready to step (docs/python.md).
#[pyclass(module = "rigid_sandbox")]
pub struct Sim {
    sim: rigid_sandbox::Sim,
    runner: Runner,
}

#[pymethods]
impl Sim {
    /// Loads a scene file; `set` overrides fields as `rigid run --set PATH=VALUE` does.
    #[classmethod]
    #[pyo3(signature = (path, set=None, threads=None))]
    fn from_file(
        _cls: &Bound<'_, PyType>,
        path: PathBuf,
        set: Option<&Bound<'_, PyAny>>,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        let text = rigid_sandbox::scene::read(&path).map_err(|e| SceneError::new_err(e.to_string()))?;
        Self::build(&text, path, set, threads)
    }

    /// Loads a scene from RON text; OBJ paths in it are found from `base_dir`.
    #[classmethod]
    #[pyo3(signature = (text, base_dir=PathBuf::from("."), set=None, threads=None))]
    fn from_ron(
        _cls: &Bound<'_, PyType>,
        text: &str,
        base_dir: PathBuf,
        set: Option<&Bound<'_, PyAny>>,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        // Errors name the text "<string>", placed in base_dir so its OBJ files are found.
        let path = if base_dir == std::path::Path::new(".") { "<string>".into() } else { base_dir.join("<string>") };
        Self::build(text, path, set, threads)
    }

    /// A benchmark scene of `rigid bench` (box-gas, pyramid, rain, hull-rain, pendulums,
    /// free-boxes) of size `n` (actors, or the pyramid's base).
    #[classmethod]
    #[pyo3(signature = (scene, n, seed=1, threads=None))]
    fn bench(_cls: &Bound<'_, PyType>, scene: &str, n: u32, seed: u64, threads: Option<usize>) -> PyResult<Self> {
        let kind = BenchScene::named(scene, DEFAULT_HULL_RAIN_SUBDIVISIONS).ok_or_else(|| {
            SceneError::new_err(format!(
                "unknown benchmark scene '{scene}': box-gas, pyramid, rain, hull-rain, pendulums or free-boxes"
            ))
        })?;
        if !(1..=1_000_000).contains(&n) {
            return Err(SceneError::new_err(format!("bench {scene}: n must be in 1..=1000000, got {n}")));
        }
        Ok(Self { sim: scene_sim(kind, n, seed), runner: Runner::new(threads)? })
    }

    /// Advances `n` steps (default 1), with the GIL released.
    #[pyo3(signature = (n=1))]
    fn step(&mut self, py: Python<'_>, n: u64) -> PyResult<()> {
        self.runner.run(py, &mut self.sim, n)
    }

    /// Simulated time [s].
    #[getter]
    fn time(&self) -> f64 {
        self.sim.time
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.sim.steps
    }

    /// Seconds per step.
    #[getter]
    fn dt(&self) -> f64 {
        self.sim.ctx.dt
    }

    /// Worker threads the steps run on.
    #[getter]
    fn threads(&self) -> usize {
        self.runner.threads()
    }

    /// Actor names in scene order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.sim.names().to_vec()
    }

    fn __len__(&self) -> usize {
        self.sim.len()
    }

    fn __repr__(&self) -> String {
        format!("<rigid_sandbox.Sim: {} actors, step {}, t = {} s>", self.sim.len(), self.sim.steps, self.sim.time)
    }

    /// Centres of mass [m], shape (N, 3).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        arrays::read(py, &self.sim, Field::Position)
    }

    /// Orientations as unit quaternions [x, y, z, w], shape (N, 4).
    #[getter]
    fn orientations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        arrays::read(py, &self.sim, Field::Orientation)
    }

    /// Velocities of the centres of mass [m/s], shape (N, 3).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        arrays::read(py, &self.sim, Field::Velocity)
    }

    /// Angular velocities in the world frame [rad/s], shape (N, 3).
    #[getter]
    fn angular_velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        arrays::read(py, &self.sim, Field::AngularVelocity)
    }

    /// Moves every actor's centre of mass; `array` has shape (N, 3).
    fn set_positions(&mut self, array: &Bound<'_, PyAny>) -> PyResult<()> {
        arrays::write(&mut self.sim, Field::Position, array)
    }

    /// Sets every actor's velocity; shape (N, 3), fixed actors' rows 0.
    fn set_velocities(&mut self, array: &Bound<'_, PyAny>) -> PyResult<()> {
        arrays::write(&mut self.sim, Field::Velocity, array)
    }

    /// Sets every actor's angular velocity (world frame); shape (N, 3), fixed actors' rows 0.
    fn set_angular_velocities(&mut self, array: &Bound<'_, PyAny>) -> PyResult<()> {
        arrays::write(&mut self.sim, Field::AngularVelocity, array)
    }

    /// The final-state document of `rigid run --out`, as a dict.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let text = state_json(&self.sim, &self.sim.actors());
        py.import("json")?.call_method1("loads", (text,))
    }

    /// The `state_hash` of `rigid run --out`: 16 hex digits, equal for bit-identical states.
    fn state_hash(&self) -> String {
        format!("{:016x}", state_hash(&self.sim.actors()))
    }
}

impl Sim {
    fn build(text: &str, path: PathBuf, set: Option<&Bound<'_, PyAny>>, threads: Option<usize>) -> PyResult<Self> {
        let sets = load::set_args(set)?;
        let (sim, _) = load::build(text, &path, &sets)?;
        Ok(Self { sim, runner: Runner::new(threads)? })
    }
}
