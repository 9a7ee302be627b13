//! The PyO3 module `flexdyn._core`: conversions and error mapping only.

use crate::integrator::timings::Phase;
use crate::model::{self, Scheme, StepControl};
use crate::simulation::{SimError, Simulation};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyDict;

create_exception!(
    _core,
    FlexdynError,
    PyException,
    "Base class of flexdyn's errors."
);
create_exception!(
    _core,
    ModelError,
    FlexdynError,
    "The model is invalid; the message names the offending item."
);
create_exception!(
    _core,
    SolverError,
    FlexdynError,
    "A step could not be completed; the message says where and why."
);

// The message of the last panic on this thread, with its place (kept by the hook that
// `install_panic_hook` sets, which prints nothing: the panic becomes a Python error).
thread_local! {
    static LAST_PANIC: std::cell::RefCell<String> = const { std::cell::RefCell::new(String::new()) };
}

fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let msg = if let Some(s) = info.payload().downcast_ref::<&str>() {
            (*s).to_string()
        } else if let Some(s) = info.payload().downcast_ref::<String>() {
            s.clone()
        } else {
            "panic".to_string()
        };
        let place = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        LAST_PANIC.with(|p| *p.borrow_mut() = format!("{msg}{place}"));
        if std::env::var_os("FLEXDYN_DEBUG_PANICS").is_some() {
            eprintln!("flexdyn panic: {msg}{place}");
        }
    }));
}

/// Runs `f`; a Rust panic in it comes back as `Err(description)`.
fn caught<T>(what: &str, f: impl FnOnce() -> T) -> Result<T, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|_| {
        let detail = LAST_PANIC.with(|p| std::mem::take(&mut *p.borrow_mut()));
        format!(
            "internal error in {what}: {detail}. This is a bug in flexdyn: please report it with the model file."
        )
    })
}

/// A sparse matrix as three numpy arrays (compressed columns, or triplets).
type SparseArrays<'py> = (
    Bound<'py, PyArray1<usize>>,
    Bound<'py, PyArray1<usize>>,
    Bound<'py, PyArray1<f64>>,
);

/// A linearization for Python: `(n, K, M, C, labels)` (see `PySimulation::linearize`).
type LinearizationArrays<'py> = (
    usize,
    SparseArrays<'py>,
    SparseArrays<'py>,
    SparseArrays<'py>,
    Vec<String>,
);

fn linearization_arrays(
    py: Python<'_>,
    lin: crate::simulation::Linearization,
) -> LinearizationArrays<'_> {
    (
        lin.n,
        sparse_arrays(py, lin.stiffness),
        sparse_arrays(py, lin.mass),
        sparse_arrays(py, lin.damping),
        lin.labels,
    )
}

fn sparse_arrays(
    py: Python<'_>,
    (a, b, v): (Vec<usize>, Vec<usize>, Vec<f64>),
) -> SparseArrays<'_> {
    (
        PyArray1::from_vec(py, a),
        PyArray1::from_vec(py, b),
        PyArray1::from_vec(py, v),
    )
}

/// Runs `f`, turning a Rust panic into `FlexdynError`: no panic crosses into Python as
/// `PanicException`, which `except Exception` does not catch.
fn guarded<T>(what: &str, f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    caught(what, f).unwrap_or_else(|msg| Err(FlexdynError::new_err(msg)))
}

fn model_err(e: model::ModelErrors) -> PyErr {
    ModelError::new_err(e.to_string())
}

/// Parses and validates YAML model text; returns the canonical JSON of the model.
#[pyfunction]
fn parse_yaml(text: &str) -> PyResult<String> {
    guarded("parsing the model", || {
        let m = crate::compile::from_yaml_str(text).map_err(model_err)?;
        Ok(serde_json::to_string(&m).expect("model serialises"))
    })
}

/// Validates JSON model text (what the builder produces); returns its canonical JSON.
#[pyfunction]
fn parse_json(text: &str) -> PyResult<String> {
    guarded("parsing the model", || {
        let m = crate::compile::from_json_str(text).map_err(model_err)?;
        Ok(serde_json::to_string(&m).expect("model serialises"))
    })
}

/// Validates JSON model text; returns the canonical JSON of the model with its patterns
/// expanded and every node and beam given in the inertial frame.
#[pyfunction]
fn expand_json(text: &str) -> PyResult<String> {
    guarded("expanding the model", || {
        let m = crate::compile::from_json_str(text).map_err(model_err)?;
        let flat = m.flattened().map_err(model_err)?;
        Ok(serde_json::to_string(&flat).expect("model serialises"))
    })
}

/// Panics on purpose, to test that a panic reaches Python as `FlexdynError`.
#[pyfunction]
fn _panic_for_test() -> PyResult<()> {
    guarded("a test", || panic!("deliberate panic"))
}

/// The JSON Schema of the model file.
#[pyfunction]
fn schema() -> String {
    model::json_schema()
}

/// A compiled model being simulated: advance it in time (or load steps), read its samples,
/// linearize it. Built from the model's JSON by `flexdyn.simulate` / `solve_static`.
#[pyclass(name = "Simulation", module = "flexdyn._core", unsendable)]
struct PySimulation {
    sim: Simulation,
    /// Set by a panic during a run: the state may be half-updated, so no further steps.
    broken: Option<String>,
}

impl PySimulation {
    fn compile(model_json: &str, scheme: Option<&str>) -> PyResult<Self> {
        let m = crate::compile::from_json_str(model_json).map_err(model_err)?;
        let scheme = match scheme {
            None => m.simulation.scheme,
            Some("ep") => Scheme::Ep,
            Some("ed") => Scheme::Ed,
            Some(other) => {
                return Err(ModelError::new_err(format!(
                    "scheme: must be \"ep\" or \"ed\" (got \"{other}\")"
                )))
            }
        };
        let sim = Simulation::with_scheme(&m, scheme).map_err(|e| match e {
            SimError::Model(e) => model_err(e),
            SimError::Step(e) => SolverError::new_err(e.to_string()),
        })?;
        Ok(PySimulation { sim, broken: None })
    }

    fn check_not_broken(&self) -> PyResult<()> {
        match &self.broken {
            Some(msg) => Err(SolverError::new_err(format!(
                "the run cannot continue after an internal error: {msg}"
            ))),
            None => Ok(()),
        }
    }

    /// Remembers an internal error (a panic during a step): the state may be half-updated,
    /// so no further step is taken. Returns the message.
    fn break_with(&mut self, panic: String) -> String {
        self.broken = Some(panic.clone());
        panic
    }
}

#[pymethods]
impl PySimulation {
    /// Builds a simulation from JSON model text; `scheme` ("ep"/"ed") overrides the model's.
    #[new]
    #[pyo3(signature = (model_json, scheme=None))]
    fn new(model_json: &str, scheme: Option<&str>) -> PyResult<Self> {
        guarded("compiling the model", || Self::compile(model_json, scheme))
    }

    /// Advances to time `t` (clamped to t_end), returning early after `wall_s` seconds of
    /// wall time if given (so results reach disk and signals are answered that often).
    /// Raises SolverError if a step cannot be completed; the samples recorded before the
    /// failure stay available via take_samples().
    #[pyo3(signature = (t, wall_s=None))]
    fn advance_to(&mut self, py: Python<'_>, t: f64, wall_s: Option<f64>) -> PyResult<()> {
        self.check_not_broken()?;
        let deadline = wall_s
            .filter(|w| w.is_finite() && *w >= 0.0)
            .map(|w| std::time::Instant::now() + std::time::Duration::from_secs_f64(w));
        let sim = &mut self.sim;
        let r = caught("a step", || py.detach(|| sim.advance_until(t, deadline)));
        let t_now = self.sim.state.t;
        let stopped = |e: String| {
            SolverError::new_err(format!(
                "{e}\nThe run stopped at t = {} s; every completed step was recorded.",
                crate::math::seconds::Seconds(t_now)
            ))
        };
        match r {
            Ok(r) => r.map_err(|e| stopped(e.to_string())),
            Err(panic) => Err(stopped(self.break_with(panic))),
        }
    }

    /// Static analysis: solves the load steps to load factor 1. Raises SolverError if a load
    /// step cannot be completed; the converged load steps stay available via take_samples().
    fn solve_static(&mut self, py: Python<'_>) -> PyResult<()> {
        self.check_not_broken()?;
        let sim = &mut self.sim;
        let r = caught("a load step", || py.detach(|| sim.solve_static()));
        let factor = self.sim.load_factor();
        let stopped = |e: String| {
            SolverError::new_err(format!(
                "{e}\nThe static analysis stopped at load factor {factor:.4}; every converged load step was recorded."
            ))
        };
        match r {
            Ok(r) => r.map_err(|e| stopped(e.to_string())),
            Err(panic) => Err(stopped(self.break_with(panic))),
        }
    }

    /// Static analysis only, linearized about the current state (see
    /// `Simulation::linearize`): `(n, (k_indptr, k_indices, k_data), (m_rows, m_cols,
    /// m_data), (c_rows, c_cols, c_data), labels)` — K in compressed sparse columns, the mass
    /// M and viscous damping C as triplets.
    fn linearize<'py>(&mut self, py: Python<'py>) -> PyResult<LinearizationArrays<'py>> {
        if !self.sim.is_static() {
            return Err(ModelError::new_err(
                "linearize: the model's simulation.analysis must be \"static\"",
            ));
        }
        let sim = &mut self.sim;
        let lin = guarded("linearizing", || Ok(sim.linearize()))?;
        Ok(linearization_arrays(py, lin))
    }

    /// Static analysis only: as `linearize`, about the current state of `run`, a simulation
    /// of the same model (e.g. a dynamic one stopped at a time of interest): its positions,
    /// coordinates, element history and constraint forces, at its time.
    fn linearize_about<'py>(
        &mut self,
        py: Python<'py>,
        run: PyRef<'py, PySimulation>,
    ) -> PyResult<LinearizationArrays<'py>> {
        if !self.sim.is_static() {
            return Err(ModelError::new_err(
                "linearize_about: the model's simulation.analysis must be \"static\"",
            ));
        }
        let state = run.sim.state.clone();
        let sim = &mut self.sim;
        let lin = guarded("linearizing", || Ok(sim.linearize_about(&state)))?
            .map_err(ModelError::new_err)?;
        Ok(linearization_arrays(py, lin))
    }

    /// Static analysis only: the gyroscopic (Coriolis) matrix `G` about the current state, in
    /// the frame turning with the initial spins (see `Simulation::gyroscopic_matrix`), as
    /// `(rows, cols, values)` over the unknowns of `linearize`; empty without spins.
    fn gyroscopic<'py>(&self, py: Python<'py>) -> PyResult<SparseArrays<'py>> {
        if !self.sim.is_static() {
            return Err(ModelError::new_err(
                "gyroscopic: the model's simulation.analysis must be \"static\"",
            ));
        }
        Ok(sparse_arrays(py, self.sim.gyroscopic_matrix()))
    }

    /// Whether this is a static analysis (load steps instead of time).
    #[getter]
    fn is_static(&self) -> bool {
        self.sim.is_static()
    }

    /// Static analysis: the fraction of the loads applied so far (0 to 1).
    #[getter]
    fn load_factor(&self) -> f64 {
        self.sim.load_factor()
    }

    /// Completes samples still waiting for the next step (call before a final take_samples
    /// when a run is interrupted).
    fn flush(&mut self) -> PyResult<()> {
        let sim = &mut self.sim;
        guarded("completing the last samples", || {
            sim.flush();
            Ok(())
        })
    }

    /// Samples recorded since the last call: (times[n], values[n, channels]).
    fn take_samples<'py>(
        &mut self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray2<f64>>)> {
        let (t, v) = self.sim.take_samples();
        let n = t.len();
        let m = self.sim.channels.len();
        let times = PyArray1::from_vec(py, t);
        let values = PyArray1::from_vec(py, v).reshape([n, m])?;
        Ok((times, values))
    }

    /// The output channels, `<sensor>.<component>`, in sample order.
    #[getter]
    fn channel_names(&self) -> Vec<String> {
        self.sim.channels.names.clone()
    }
    /// Each channel's SI unit, in the order of `channel_names`.
    #[getter]
    fn channel_units(&self) -> Vec<String> {
        self.sim
            .channels
            .units
            .iter()
            .map(|s| s.to_string())
            .collect()
    }
    /// Time reached, s.
    #[getter]
    fn t(&self) -> f64 {
        self.sim.state.t
    }
    /// Size of the compiled model: nodes, joint coordinates, constraint equations (drives
    /// included), beam elements, global unknowns of the Newton system.
    #[getter]
    fn size<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let sys = &self.sim.system;
        let d = PyDict::new(py);
        d.set_item("nodes", sys.layout.n_nodes)?;
        d.set_item("coordinates", sys.layout.n_coords)?;
        d.set_item("constraints", sys.layout.n_rows)?;
        d.set_item("beam_elements", sys.beams.len())?;
        d.set_item("unknowns", sys.layout.n_unknowns())?;
        Ok(d)
    }

    /// The last step taken, s (0 before the first).
    #[getter]
    fn last_dt(&self) -> f64 {
        self.sim.stats.last_dt
    }
    /// End time of the run, s.
    #[getter]
    fn t_end(&self) -> f64 {
        self.sim.settings.t_end
    }
    /// The initial (fixed: the) step size, s.
    #[getter]
    fn dt(&self) -> f64 {
        self.sim.settings.dt
    }
    /// Adaptive stepping's tolerance (see `SimulationSettings::tolerance`).
    #[getter]
    fn tolerance(&self) -> f64 {
        self.sim.settings.tolerance
    }
    /// `adaptive` or `fixed`.
    #[getter]
    fn step_control(&self) -> &'static str {
        match self.sim.settings.step_control {
            StepControl::Adaptive => "adaptive",
            StepControl::Fixed => "fixed",
        }
    }
    /// `ep` (energy preserving) or `ed` (energy decaying).
    #[getter]
    fn scheme(&self) -> &'static str {
        match self.sim.system.layout.scheme {
            Scheme::Ep => "ep",
            Scheme::Ed => "ed",
        }
    }
    /// Whether the run reached its end.
    #[getter]
    fn done(&self) -> bool {
        self.sim.done()
    }
    /// Full-field output of this run, or None when it records none: `{"nodes": N,
    /// "points": P, "contacts": S, "topology": JSON}` — after the named channels each sample
    /// holds N×3 positions, N×4 orientation quaternions (w, x, y, z), P×3 section forces
    /// and P×3 moments (every beam's nodes in order, section triad), S contact η and S×3
    /// contact points.
    #[getter]
    fn field_layout<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let (Some(f), Some(topo)) = (&self.sim.channels.fields, &self.sim.topology) else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("nodes", f.node_count())?;
        d.set_item("points", f.point_count())?;
        d.set_item("contacts", f.contact_count())?;
        d.set_item("topology", topo)?;
        Ok(Some(d))
    }
    /// Field output's size: `(bytes per sample, estimated samples, recorded)`; the estimate
    /// is one sample per `output_dt` (else per `dt`), whether or not the run records fields.
    #[getter]
    fn field_estimate(&self) -> (usize, f64, bool) {
        let width = crate::fields::Fields::new(&self.sim.system).width();
        let samples = crate::fields::estimated_samples(&self.sim.settings);
        (8 * width, samples, self.sim.channels.fields.is_some())
    }
    /// Warnings raised so far (each once), for the user.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.sim.run_warnings()
    }
    /// Total energy of the current state (kinetic, strain, springs, gravity), J.
    #[getter]
    fn energy(&self) -> f64 {
        self.sim.energy()
    }
    /// Run statistics: steps, halvings, Newton iterations, factorizations, invariants.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.sim.stats;
        let d = PyDict::new(py);
        d.set_item("steps", s.steps)?;
        d.set_item("halvings", s.halvings)?;
        d.set_item("rejected", s.rejected)?;
        d.set_item("over_tolerance", s.over_tolerance)?;
        // Accepted adaptive steps by what set their size (the indicator's largest term).
        let [motion, spin, jumps] = s.steps_set_by;
        d.set_item("steps_set_by_motion", motion)?;
        d.set_item("steps_set_by_spin", spin)?;
        d.set_item("steps_set_by_jumps", jumps)?;
        d.set_item("linear_solves", s.linear_solves)?;
        d.set_item("residual_evaluations", s.residual_evaluations)?;
        d.set_item("dt_smallest", s.dt_smallest)?;
        d.set_item("dt_largest", s.dt_largest)?;
        d.set_item("newton_iterations", s.newton_iterations)?;
        d.set_item("factorizations", s.factorizations)?;
        d.set_item("exact_factorizations", s.exact_factorizations)?;
        d.set_item("pivoting_factorizations", s.pivoting_factorizations)?;
        d.set_item("orderings", s.orderings)?;
        d.set_item("border_refreshes", s.border_refreshes)?;
        d.set_item("predicted_stops", s.predicted_stops)?;
        d.set_item("constraint_checks", s.constraint_checks)?;
        d.set_item("max_constraint_violation", s.max_constraint_violation)?;
        d.set_item("max_constraint_work", s.max_constraint_work)?;
        d.set_item("max_energy_defect", s.max_energy_defect)?;
        d.set_item("pattern_misses", s.pattern_misses)?;
        d.set_item("pattern_rebuilds", s.pattern_rebuilds)?;
        d.set_item("unknowns", self.sim.system.layout.n_unknowns())?;
        // The energy the step-error indicator is never measured below (J).
        d.set_item("error_energy_floor", self.sim.energy_floor)?;
        // Where the wall time went (s), if the settings asked (`simulation.timings`).
        let t = &s.timings;
        if t.enabled() {
            for phase in Phase::ALL {
                d.set_item(format!("time_{}_s", phase.name()), t.seconds(phase))?;
            }
            d.set_item("time_other_s", t.other())?;
            d.set_item("time_core_s", t.total())?;
        }
        Ok(d)
    }
    /// Residual norms of the Newton iterations of the last step.
    #[getter]
    fn last_residuals(&self) -> Vec<f64> {
        self.sim
            .last_report
            .as_ref()
            .map(|r| r.residuals.clone())
            .unwrap_or_default()
    }
}

/// flexdyn's compiled core: model parsing and validation, the JSON Schema, and `Simulation`.
/// Use it through the `flexdyn` package.
#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(parse_yaml, m)?)?;
    m.add_function(wrap_pyfunction!(parse_json, m)?)?;
    m.add_function(wrap_pyfunction!(expand_json, m)?)?;
    m.add_function(wrap_pyfunction!(schema, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_for_test, m)?)?;
    install_panic_hook();
    m.add_class::<PySimulation>()?;
    // The compiled core's own version: a stale build beside newer Python sources shows here.
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    let py = m.py();
    m.add("FlexdynError", py.get_type::<FlexdynError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("SolverError", py.get_type::<SolverError>())?;
    Ok(())
}
