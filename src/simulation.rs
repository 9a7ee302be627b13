//! A running simulation: consistent initial velocities, fixed-step advance with step halving
//! on Newton failure, and sensor samples handed out in chunks so memory stays flat.

use crate::elements::StepCtx;
use crate::integrator::{Integrator, StepFailure, StepReport};
use crate::joints::{Joint, RateTerm};
use crate::model::{Analysis, Model, ModelErrors, Scheme, SimulationSettings, StepControl};
use crate::sensors::{Channels, Totals};
use crate::state::State;
use crate::system::layout::Layout;
use crate::system::sparse::NewtonMatrix;
use crate::system::System;
use crate::vec3::V3;

/// One step's size and the mean velocity and spatial angular velocity of each node carrying
/// inertia (in `System::inertias` order).
struct StepMeans {
    h: f64,
    means: Vec<(V3<f64>, V3<f64>)>,
}

#[derive(Clone, Debug)]
pub struct RunStats {
    pub steps: usize,
    /// Steps whose Newton iteration failed and were retried with half the step.
    pub halvings: usize,
    pub newton_iterations: usize,
    pub factorizations: usize,
    /// Fill-reducing orderings computed (once per sparsity pattern).
    pub orderings: usize,
    pub max_constraint_violation: f64,
    pub max_constraint_work: f64,
    /// Largest |ΔE − W_drive − W_ext − W_damp + D| of a step: the energy identity's defect.
    pub max_energy_defect: f64,
    /// Assemblies whose tangent had an entry outside the detected sparsity pattern.
    pub pattern_misses: usize,
    /// Newton-matrix patterns rebuilt because a sliding contact point changed element.
    pub pattern_rebuilds: usize,
    /// Adaptive stepping: steps rejected (error too large, or Newton failed) and retried.
    pub rejected: usize,
    /// Adaptive stepping: steps taken above the tolerance because a shorter one would not
    /// lower the error — an event such as a velocity jump, which no step resolves.
    pub over_tolerance: usize,
    /// Linear solves (Newton updates); with modified Newton more than factorizations.
    pub linear_solves: usize,
    /// Smallest and largest step taken, s.
    pub dt_smallest: f64,
    pub dt_largest: f64,
    /// The last step taken.
    pub last_dt: f64,
}

impl Default for RunStats {
    fn default() -> Self {
        RunStats {
            steps: 0,
            halvings: 0,
            newton_iterations: 0,
            factorizations: 0,
            orderings: 0,
            max_constraint_violation: 0.0,
            max_constraint_work: 0.0,
            max_energy_defect: 0.0,
            pattern_misses: 0,
            pattern_rebuilds: 0,
            rejected: 0,
            over_tolerance: 0,
            linear_solves: 0,
            dt_smallest: f64::INFINITY,
            dt_largest: 0.0,
            last_dt: 0.0,
        }
    }
}

#[derive(Debug)]
pub enum SimError {
    Model(ModelErrors),
    Step(StepFailure),
}

impl std::fmt::Display for SimError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SimError::Model(e) => write!(f, "{e}"),
            SimError::Step(e) => write!(f, "{e}"),
        }
    }
}

pub struct Simulation {
    pub system: System,
    pub settings: SimulationSettings,
    pub state: State,
    integrator: Integrator,
    pub channels: Channels,
    pub totals: Totals,
    pub stats: RunStats,
    pub warnings: Vec<String>,
    pub last_report: Option<StepReport>,
    /// Recorded samples not yet taken: times and row-major values.
    times: Vec<f64>,
    values: Vec<f64>,
    /// Samples waiting for the next step to interpolate their step channels.
    pending: std::collections::VecDeque<(f64, Vec<f64>)>,
    /// Step-channel values of the last two steps, with their mid-step times.
    recent: std::collections::VecDeque<(f64, Vec<f64>)>,
    step_index: u64,
    /// Index of the next requested output time (k·output_dt).
    output_index: u64,
    /// State channels at the current state (the start of the next step).
    last_row: Vec<f64>,
    /// Adaptive stepping: the size proposed for the next step; the last two steps' sizes and
    /// mean velocities (for EP's error estimate), latest last.
    h_next: f64,
    recent_means: std::collections::VecDeque<StepMeans>,
    /// Adaptive stepping: the last trial's (h, e) and the indicator's observed order in h.
    last_trial: Option<(f64, f64)>,
    error_order: f64,
    /// The largest kinetic + strain + spring energy so far: the error indicator's scale.
    energy_scale: f64,
    /// Static analysis: the load factor of the current state.
    load_factor: f64,
}

impl Simulation {
    pub fn new(model: &Model) -> Result<Simulation, SimError> {
        Self::with_scheme(model, model.simulation.scheme)
    }

    pub fn with_scheme(model: &Model, scheme: Scheme) -> Result<Simulation, SimError> {
        let statics = model.simulation.analysis == Analysis::Static;
        // A static solve has no velocities: it uses the EP layout whatever the scheme.
        let layout_scheme = if statics { Scheme::Ep } else { scheme };
        let system = System::compile_with(model, layout_scheme).map_err(SimError::Model)?;
        check_redundancy(model, &system).map_err(SimError::Model)?;
        let mut settings = model.simulation.clone();
        settings.scheme = scheme;
        let mut state = system.initial.clone();
        let mut warnings = Vec::new();
        if !statics && settings.preload {
            // Start from the static equilibrium under the loads and gravity at t = 0 (drives
            // at their t = 0 values) and, for initial spins, their steady-rotation inertia:
            // the dynamic run then begins without the transient of a load (or a rotor's
            // centrifugal stretch) appearing on an unloaded structure.
            let mut static_model = model.clone();
            static_model.simulation.analysis = Analysis::Static;
            let mut pre = Simulation::with_scheme(&static_model, Scheme::Ep)?;
            pre.solve_static().map_err(|e| {
                SimError::Step(StepFailure {
                    reason: format!(
                        "the static pre-load (simulation.preload) found no equilibrium: {}",
                        e.reason
                    ),
                    ..e
                })
            })?;
            for ((n, p), spin) in state
                .nodes
                .iter_mut()
                .zip(&pre.state.nodes)
                .zip(&system.node_spin)
            {
                n.x = p.x;
                n.r = p.r;
                // A spinning node's velocities follow it to its steady-spin position.
                if let Some(spin) = spin {
                    n.v = spin.omega.cross(&(n.x - spin.center));
                    n.w = n.r.tmul_v(&spin.omega);
                }
            }
            state.coords.clone_from(&pre.state.coords);
            state.history.clone_from(&pre.state.history);
            state.lambda.clone_from(&pre.state.lambda);
        }
        let change = if statics {
            for n in &mut state.nodes {
                n.v = V3::zero();
                n.w = V3::zero();
            }
            state.coord_rates.iter_mut().for_each(|r| *r = 0.0);
            vec![0.0; state.nodes.len()]
        } else {
            project_initial_velocities(&system, &mut state)
        };
        let v_scale = state
            .nodes
            .iter()
            .map(|n| n.v.norm() + n.omega().norm() * system.length_ref)
            .fold(1e-12f64, f64::max);
        // Velocities the model did not give are simply completed; changing given ones is said.
        let changed: Vec<String> = (0..change.len())
            .filter(|&a| system.velocity_given[a] && change[a] > 1e-9 * v_scale)
            .map(|a| format!("`{}`", system.node_names[a]))
            .collect();
        if !changed.is_empty() {
            let worst = change.iter().cloned().fold(0.0, f64::max);
            // A drive already moving at t = 0 on a joint of an adjusted node makes the start
            // impulsive: say which, since the fix is then the model's choice, not a slip.
            let adjusted = |n: &str| {
                (0..change.len()).any(|a| {
                    system.velocity_given[a] && change[a] > 1e-9 * v_scale && {
                        let name = &system.node_names[a];
                        name == n || name.strip_prefix(n).is_some_and(|k| k.starts_with('.'))
                    }
                })
            };
            let moving: Vec<String> = model
                .joints
                .iter()
                .filter(|j| {
                    let (n1, n2) = j.nodes();
                    adjusted(n1) || adjusted(n2)
                })
                .filter_map(|j| system.joint(j.name()))
                .flat_map(|info| info.coords.iter().map(move |c| (info, c)))
                .filter(|(_, c)| {
                    c.drive
                        .is_some_and(|d| system.drives[d].function.rate(0.0) != 0.0)
                })
                .map(|(info, c)| format!("`{}` ({})", info.name, c.name))
                .collect();
            let why = if moving.is_empty() {
                "give consistent velocities to avoid this".to_string()
            } else {
                format!(
                    "the drive(s) of {} start moving at t = 0, so the start is impulsive; give the nodes those velocities, or start the drives from rest, to avoid this",
                    moving.join(", ")
                )
            };
            warnings.push(format!(
                "initial velocities of node(s) {} were adjusted to satisfy the joints' velocity constraints (largest change {worst:.4} m/s, or rad/s times the model size); {why}",
                changed.join(", ")
            ));
        }
        let integrator = Integrator::new(&system, &settings);
        let channels = Channels::new(model, &system).map_err(SimError::Model)?;
        let e0 = system.kinetic_energy(&state) + system.potential_energy(&state);
        let totals = Totals {
            initial_energy: e0,
            per_drive_work: vec![0.0; system.drives.len()],
            ..Default::default()
        };
        let mut sim = Simulation {
            system,
            settings,
            state,
            integrator,
            channels,
            totals,
            stats: RunStats::default(),
            warnings,
            last_report: None,
            times: vec![],
            values: vec![],
            pending: Default::default(),
            recent: Default::default(),
            step_index: 0,
            output_index: 1,
            last_row: vec![],
            h_next: 0.0,
            recent_means: Default::default(),
            last_trial: None,
            error_order: 2.0,
            energy_scale: 0.0,
            load_factor: 0.0,
        };
        sim.h_next = sim.settings.dt;
        sim.energy_scale = sim.system.motion_energy(&sim.state);
        if statics {
            // The unloaded state, with no reactions yet.
            let mut row = Vec::with_capacity(sim.channels.len());
            sim.channels
                .sample(&sim.system, &sim.state, &sim.totals, &mut row);
            for &c in sim.channels.step_channels() {
                row[c] = 0.0;
            }
            sim.times.push(0.0);
            sim.values.extend_from_slice(&row);
        } else {
            sim.record();
        }
        Ok(sim)
    }

    pub fn is_static(&self) -> bool {
        self.settings.analysis == Analysis::Static
    }

    /// Static analysis: equilibrium under the loads ramped from the current load factor to 1
    /// in `load_steps` equal increments, each halved (recursively) if Newton fails. Records
    /// one sample per converged load step, keyed by its load factor.
    pub fn solve_static(&mut self) -> Result<(), StepFailure> {
        assert!(self.is_static(), "the model's analysis is not static");
        let n = self.settings.load_steps.max(1);
        let start = self.load_factor;
        for k in 1..=n {
            let target = start + (1.0 - start) * k as f64 / n as f64;
            let result = self.advance_load(target, 0);
            self.update_stats();
            result?;
        }
        Ok(())
    }

    /// Linearization about the current (static) state for modal analysis: the static tangent
    /// K and the mass matrix M (dense, row-major, n × n over the EP layout), and a label per
    /// unknown: `<node>.<x|y|z|rx|ry|rz>` (rotations material), `coord:<name>`, or
    /// `row:<owner>.<k>` for constraint rows (no mass; they border K with the constraint
    /// gradients).
    pub fn linearize(&mut self) -> (usize, Vec<f64>, Vec<f64>, Vec<String>) {
        assert!(self.is_static(), "linearization needs a static analysis");
        self.follow_contacts();
        let sys = &self.system;
        let lay = sys.layout;
        let n = lay.n_unknowns();
        let lf = if self.load_factor > 0.0 {
            self.load_factor
        } else {
            1.0
        };
        let k = self.integrator.static_tangent(sys, &self.state, lf);
        let mut m = vec![0.0; n * n];
        for inertia in &sys.inertias {
            let d = lay.node_delta(inertia.node);
            for i in 0..3 {
                m[(d + i) * n + d + i] += inertia.mass;
                for j in 0..3 {
                    m[(d + 3 + i) * n + d + 3 + j] += inertia.inertia.0[i][j];
                }
            }
        }
        let mut labels = vec![String::new(); n];
        const COMP: [&str; 6] = ["x", "y", "z", "rx", "ry", "rz"];
        for (a, name) in sys.node_names.iter().enumerate() {
            for (c, comp) in COMP.iter().enumerate() {
                labels[lay.node_delta(a) + c] = format!("{name}.{comp}");
            }
        }
        for (c, name) in sys.coord_names.iter().enumerate() {
            labels[lay.coord_delta(c)] = format!("coord:{name}");
        }
        for (r, (owner, k)) in sys.row_names.iter().enumerate() {
            labels[lay.mult(r)] = format!("row:{owner}.{k}");
        }
        (n, k, m, labels)
    }

    /// Load factor reached by a static analysis (0 before it starts, 1 when done).
    pub fn load_factor(&self) -> f64 {
        self.load_factor
    }

    /// Moves each sliding joint's window of unknowns to where its contact point is; a moved
    /// window changes the Newton matrix's pattern.
    fn follow_contacts(&mut self) {
        let mut moved = false;
        for j in &mut self.system.joints {
            if let Joint::Sliding(s) = j {
                moved |= s.place_window(self.state.coords[s.coord]);
            }
        }
        if moved {
            self.integrator
                .rebuild_pattern(&self.system, self.settings.dt);
        }
    }

    fn advance_load(&mut self, target: f64, depth: u32) -> Result<(), StepFailure> {
        self.follow_contacts();
        match self
            .integrator
            .static_step(&self.system, &self.state, target)
        {
            Ok((state, report)) => {
                self.state = state;
                self.load_factor = target;
                self.stats.steps += 1;
                self.stats.max_constraint_violation = self
                    .stats
                    .max_constraint_violation
                    .max(report.max_violation);
                let mut row = Vec::with_capacity(self.channels.len());
                self.channels
                    .sample(&self.system, &self.state, &self.totals, &mut row);
                let mut step = Vec::new();
                self.channels.step_values(&report, &mut step);
                for (&c, v) in self.channels.step_channels().iter().zip(step) {
                    row[c] = v;
                }
                self.times.push(target);
                self.values.extend_from_slice(&row);
                self.last_report = Some(report);
                Ok(())
            }
            Err(e) if e.retry && depth < self.settings.max_step_halvings => {
                self.stats.halvings += 1;
                let mid = 0.5 * (self.load_factor + target);
                self.advance_load(mid, depth + 1)?;
                self.advance_load(target, depth + 1)
            }
            Err(e) => Err(e),
        }
    }

    /// Records a sample at the current time (the start of a run). Its state channels are
    /// final; its step channels (multipliers) wait in `pending` for the step after it.
    fn record(&mut self) {
        let mut row = Vec::with_capacity(self.channels.len());
        self.channels
            .sample(&self.system, &self.state, &self.totals, &mut row);
        self.last_row = row.clone();
        self.emit(self.state.t, row);
    }

    /// After a step from `t_i`: records every requested output time in (t_i, t_f] — state
    /// channels interpolated linearly between the step's ends (the schemes move positions
    /// with the step's mean velocity), so outputs land on the requested times whatever the
    /// steps were — or the step's end when every step is recorded.
    fn record_outputs(&mut self, t_i: f64) {
        let mut row_f = Vec::with_capacity(self.channels.len());
        self.channels
            .sample(&self.system, &self.state, &self.totals, &mut row_f);
        let t_f = self.state.t;
        let row_i = std::mem::take(&mut self.last_row);
        match self.settings.output_dt {
            None => self.emit(t_f, row_f.clone()),
            Some(out) => {
                let t_end = self.settings.t_end;
                let slack = 1e-9 * (t_f - t_i).max(1e-300);
                loop {
                    let t_o = (self.output_index as f64 * out).min(t_end);
                    if t_o > t_f + slack {
                        break;
                    }
                    let w = ((t_o - t_i) / (t_f - t_i)).clamp(0.0, 1.0);
                    let row = row_i
                        .iter()
                        .zip(&row_f)
                        .map(|(a, b)| a + (b - a) * w)
                        .collect();
                    self.emit(t_o, row);
                    if t_o >= t_end {
                        self.output_index = u64::MAX / 2;
                        break;
                    }
                    self.output_index += 1;
                }
            }
        }
        self.last_row = row_f;
    }

    /// Adds a sample; its step channels are completed when the steps around it are known.
    fn emit(&mut self, t: f64, row: Vec<f64>) {
        if self.channels.step_channels().is_empty() {
            self.times.push(t);
            self.values.extend_from_slice(&row);
        } else {
            self.pending.push_back((t, row));
            self.finalize_pending(false);
        }
    }

    /// Fills the step channels of pending samples from the step values around their time:
    /// a step's multipliers are step-average forces belonging to its mid-step time, so the
    /// value at a sample time is interpolated between the steps before and after it (which
    /// also cancels EP's period-2 multiplier oscillation). Samples before the first step's
    /// mid-time are extrapolated from the first two steps. With `flush`, every pending sample
    /// is completed with what is available (extrapolating from the last steps).
    fn finalize_pending(&mut self, flush: bool) {
        while let Some((t, _)) = self.pending.front() {
            let t = *t;
            let n = self.recent.len();
            // Interpolation needs two steps, the newer one after the sample time.
            let ready = n >= 2 && self.recent[n - 1].0 >= t;
            if !ready && !flush {
                break;
            }
            let (_, mut row) = self.pending.pop_front().expect("front exists");
            let step = self.channels.step_channels();
            for (slot, &c) in step.iter().enumerate() {
                row[c] = match n {
                    0 => f64::NAN,
                    1 => self.recent[0].1[slot],
                    _ => {
                        let (ta, va) = (self.recent[n - 2].0, self.recent[n - 2].1[slot]);
                        let (tb, vb) = (self.recent[n - 1].0, self.recent[n - 1].1[slot]);
                        va + (vb - va) * (t - ta) / (tb - ta)
                    }
                };
            }
            self.times.push(t);
            self.values.extend_from_slice(&row);
        }
    }

    /// Keeps the step values of the last two steps (time of each: its mid-step).
    fn push_step_values(&mut self, t_mid: f64, report: &StepReport) {
        if self.channels.step_channels().is_empty() {
            return;
        }
        let mut v = Vec::with_capacity(self.channels.step_channels().len());
        self.channels.step_values(report, &mut v);
        if self.recent.len() == 2 {
            self.recent.pop_front();
        }
        self.recent.push_back((t_mid, v));
        self.finalize_pending(false);
    }

    /// Completes the samples still waiting for a next step (extrapolating their step
    /// channels), e.g. when a run is interrupted.
    pub fn flush(&mut self) {
        self.finalize_pending(true);
    }

    /// Takes the samples recorded since the last call: (times, row-major values).
    pub fn take_samples(&mut self) -> (Vec<f64>, Vec<f64>) {
        (
            std::mem::take(&mut self.times),
            std::mem::take(&mut self.values),
        )
    }

    pub fn energy(&self) -> f64 {
        self.system.kinetic_energy(&self.state) + self.system.potential_energy(&self.state)
    }

    /// Takes a converged step: energy bookkeeping, checks, the step's multipliers, and the
    /// samples whose times it covers.
    fn accept(&mut self, state: State, report: StepReport, h: f64) {
        let t_i = self.state.t;
        let e_i = self.energy();
        if self.settings.step_control == StepControl::Adaptive {
            let means = self.step_means(&state, h);
            if self.recent_means.len() == 2 {
                self.recent_means.pop_front();
            }
            self.recent_means.push_back(means);
        }
        self.state = state;
        self.stats.steps += 1;
        self.stats.dt_smallest = self.stats.dt_smallest.min(h);
        self.stats.dt_largest = self.stats.dt_largest.max(h);
        self.stats.last_dt = h;
        let e_f = self.energy();
        self.energy_scale = self
            .energy_scale
            .max(self.system.motion_energy(&self.state));
        let t = &mut self.totals;
        t.drive_work += report.drive_work;
        t.external_work += report.external_work;
        t.damper_work += report.damper_work;
        t.numerical_dissipation += report.numerical_dissipation;
        for (w, dw) in t.per_drive_work.iter_mut().zip(report.drive_works.iter()) {
            *w += dw;
        }
        let defect = e_f - e_i - report.drive_work - report.external_work - report.damper_work
            + report.numerical_dissipation;
        self.stats.max_energy_defect = self.stats.max_energy_defect.max(defect.abs());
        self.stats.max_constraint_violation = self
            .stats
            .max_constraint_violation
            .max(report.max_violation);
        self.stats.max_constraint_work = self
            .stats
            .max_constraint_work
            .max(report.constraint_work.abs());
        self.push_step_values(t_i + 0.5 * h, &report);
        self.last_report = Some(report);
    }

    /// One step of `h`, retried as two halves (recursively) if Newton fails.
    fn advance_interval(&mut self, h: f64, depth: u32) -> Result<(), StepFailure> {
        self.follow_contacts();
        match self.integrator.step(&self.system, &self.state, h) {
            Ok((state, report)) => {
                self.accept(state, report, h);
                Ok(())
            }
            Err(e) if e.retry && depth < self.settings.max_step_halvings => {
                self.stats.halvings += 1;
                let _ = e;
                self.advance_interval(0.5 * h, depth + 1)?;
                self.advance_interval(0.5 * h, depth + 1)
            }
            Err(e) => Err(e),
        }
    }

    /// The local error indicator of a converged step from the current state to `end` (e ≤ 1
    /// meets the tolerance): error energies of the step relative to the motion's energy scale
    /// (the largest kinetic + strain + spring energy so far), `e = √(E_err/E)/tol` — relative
    /// velocity errors, O(h²) for smooth motion, like the global error, so errors follow the
    /// tolerance in proportion (DESIGN 8.6). Measured in energy, content that carries little
    /// of it (a faint high-frequency ring of a stiff beam) does not drive the step down.
    /// - Both schemes: the kinetic energy of the step's local error estimated from the mean
    ///   velocities of the last three steps (`Δx/h` and the spatial `R r/h`): h²v″/12, the
    ///   midpoint rule's h³x‴/12 per unit h, with v″ from divided differences. End-of-step
    ///   velocities are not used: with joints they carry EP's undamped period-2 ripple (an
    ///   index-3 trait of the midpoint rule) and ED's velocity off the joints' tangent, which a
    ///   predictor built on them would read as error at any step size. The first two steps,
    ///   lacking history, are checked by step doubling.
    /// - ED also: the step's jump energy D (a weighted norm of the jumps, ed-scheme-notes
    ///   §3.4), which measures what the scheme dissipates — on a fast gyroscopic motion it
    ///   grows far beyond the motion estimate (ED's phase and amplitude error there).
    fn local_error(
        &mut self,
        end: &State,
        h: f64,
        report: &StepReport,
    ) -> Result<f64, StepFailure> {
        let motion = if self.recent_means.len() < 2 {
            self.doubling_error(end, h)?
        } else {
            let energy = self.mean_velocity_error_energy(end, h);
            self.relative_error(energy, end)
        };
        Ok(match self.settings.scheme {
            Scheme::Ep => motion,
            Scheme::Ed => {
                motion.max(self.relative_error(report.numerical_dissipation.max(0.0), end))
            }
        })
    }

    /// `√(E_err/E)/tol`, E the motion's energy scale including the end state; zero while
    /// nothing moves or strains.
    fn relative_error(&self, error_energy: f64, end: &State) -> f64 {
        let scale = self.energy_scale.max(self.system.motion_energy(end));
        if scale <= 0.0 {
            return 0.0;
        }
        (error_energy / scale).sqrt() / self.settings.tolerance
    }

    /// Mean velocity and spatial angular velocity over a step to `end`, of each node carrying
    /// inertia.
    fn step_means(&self, end: &State, h: f64) -> StepMeans {
        let means = self
            .system
            .inertias
            .iter()
            .map(|k| {
                let (a, b) = (&self.state.nodes[k.node], &end.nodes[k.node]);
                let v = (b.x - a.x).scale_f(1.0 / h);
                let w = a.r.mul_v(&rotation_between(&a.r, &b.r)).scale_f(1.0 / h);
                (v, w)
            })
            .collect();
        StepMeans { h, means }
    }

    /// EP's error energy `Σ ½ m |δv|² + ½ δωᵀ J δω` (J turned to the inertial frame): δ the
    /// step's mean velocities minus their linear extrapolation from the previous two steps'
    /// (an error ≈ h² v″ at equal steps), over 12 — the midpoint rule's local error, h³x‴/12,
    /// per unit h.
    fn mean_velocity_error_energy(&self, end: &State, h: f64) -> f64 {
        let (older, last) = (&self.recent_means[0], &self.recent_means[1]);
        let now = self.step_means(end, h);
        // Mid-step times, relative to the last step's middle; v″ from divided differences,
        // so the estimate h²v″/12 is the current step's whatever the previous sizes.
        let (t_older, t_now) = (-0.5 * (older.h + last.h), 0.5 * (last.h + h));
        let second = |a: V3<f64>, b: V3<f64>, c: V3<f64>| {
            ((c - b).scale_f(1.0 / t_now) - (b - a).scale_f(1.0 / -t_older))
                .scale_f(2.0 / (t_now - t_older) * h * h / 12.0)
        };
        let mut energy = 0.0;
        for (k, inertia) in self.system.inertias.iter().enumerate() {
            let dv = second(older.means[k].0, last.means[k].0, now.means[k].0);
            let dw = second(older.means[k].1, last.means[k].1, now.means[k].1);
            let dw_body = end.nodes[inertia.node].r.transpose().mul_v(&dw);
            energy += 0.5 * inertia.mass * dv.norm_sq()
                + 0.5 * dw_body.dot(&inertia.inertia.mul_v(&dw_body));
        }
        energy
    }

    /// EP's first two steps have too little history: their error is estimated by step
    /// doubling — the full step against two halves, whose end positions differ by ¾ of the
    /// full step's local error (local error ∝ h³) — in the same energy measure.
    fn doubling_error(&mut self, end: &State, h: f64) -> Result<f64, StepFailure> {
        let (mid, _) = self.integrator.step(&self.system, &self.state, 0.5 * h)?;
        let (half, _) = self.integrator.step(&self.system, &mid, 0.5 * h)?;
        let mut energy = 0.0;
        for k in &self.system.inertias {
            let (a, b) = (&end.nodes[k.node], &half.nodes[k.node]);
            let dv = (a.x - b.x).scale_f(4.0 / 3.0 / h);
            let dw = rotation_between(&b.r, &a.r).scale_f(4.0 / 3.0 / h);
            energy += 0.5 * k.mass * dv.norm_sq() + 0.5 * dw.dot(&k.inertia.mul_v(&dw));
        }
        Ok(self.relative_error(energy, end))
    }

    /// One adaptive step: tried with the proposed size, rejected and retried smaller while its
    /// error indicator exceeds 1 or Newton fails. The next size aims at e = 0.8:
    /// `h·(0.8/e)^(1/q)` within the growth and shrink limits (DESIGN 8.6), with q the indicator's
    /// observed order in h — nominally 2, but ED's jump energy steepens to q ≈ 4 as ωh nears 1
    /// on a fast mode, where a fixed exponent would alternate between too long and rejected
    /// steps. A step right after a rejection does not grow, nor one that would grow by less
    /// than 25 %.
    fn adaptive_step(&mut self) -> Result<(), StepFailure> {
        let set = &self.settings;
        let (dt_min, dt_max) = (set.dt_min(), set.dt_max());
        let (grow, shrink) = (set.max_growth, set.max_shrink);
        let remaining = set.t_end - self.state.t;
        let mut h = self.h_next.min(dt_max);
        // Land on t_end, without leaving a sliver of a last step.
        if h >= remaining || remaining < 1.25 * h {
            h = if h >= remaining {
                remaining
            } else {
                0.5 * remaining
            };
        }
        let mut rejected = false;
        let mut previous_trial = None;
        loop {
            self.follow_contacts();
            let tried =
                self.integrator
                    .step(&self.system, &self.state, h)
                    .and_then(|(state, report)| {
                        let e = self.local_error(&state, h, &report)?;
                        Ok((state, report, e))
                    });
            match tried {
                Ok((state, report, e)) => {
                    let factor = self.step_factor(h, e).clamp(shrink, grow);
                    // An indicator that a step 1.5× shorter barely lowered (an order in h below
                    // 0.26) measures the state, not the step — ED's jump settling the velocity
                    // the step before left off its joints' tangent: no shorter step would meet
                    // it, so take this one.
                    let stuck =
                        previous_trial.is_some_and(|(h0, e0)| h < 0.67 * h0 && e > 0.9 * e0);
                    previous_trial = Some((h, e));
                    if e <= 1.0 || stuck {
                        if e > 1.0 {
                            self.stats.over_tolerance += 1;
                        }
                        self.accept(state, report, h);
                        let factor = if rejected { factor.min(1.0) } else { factor };
                        // Keep h through small increases: an unchanged step keeps modified
                        // Newton's factors valid (the Newton matrix depends on h).
                        let factor = if (1.0..1.25).contains(&factor) {
                            1.0
                        } else {
                            factor
                        };
                        self.h_next = (h * factor).clamp(dt_min, dt_max);
                        return Ok(());
                    }
                    self.stats.rejected += 1;
                    rejected = true;
                    if h <= dt_min * (1.0 + 1e-12) {
                        return Err(StepFailure {
                            t: self.state.t,
                            h,
                            reason: format!("the error tolerance {:.1e} cannot be met even with the smallest step dt_min = {dt_min:.3e} s (error indicator {e:.2}); loosen `tolerance` or lower `dt_min`", self.settings.tolerance),
                            retry: false,
                            load_factor: None,
                        });
                    }
                    h = (h * factor.min(0.9)).max(dt_min);
                }
                Err(e) if e.retry && h > dt_min * (1.0 + 1e-12) => {
                    self.stats.rejected += 1;
                    self.stats.halvings += 1;
                    rejected = true;
                    h = (0.25 * h).max(dt_min);
                }
                Err(e) => return Err(e),
            }
        }
    }

    /// The factor on `h` that brings the indicator `e` to 0.8, updating the indicator's
    /// observed order q from the previous trial (kept within [1, 4]; 2 until measured).
    fn step_factor(&mut self, h: f64, e: f64) -> f64 {
        if e <= 0.0 {
            return f64::INFINITY;
        }
        if let Some((h0, e0)) = self.last_trial {
            let ratio = h / h0;
            if e0 > 0.0 && !(0.9..=1.1).contains(&ratio) {
                self.error_order = ((e / e0).ln() / ratio.ln()).clamp(1.0, 4.0);
            }
        }
        self.last_trial = Some((h, e));
        (0.8 / e).powf(1.0 / self.error_order)
    }

    /// Advances up to `t_target` (not past `t_end`), recording samples: fixed steps of `dt`
    /// on the grid k·dt, or adaptive steps (which may end past `t_target`, never past t_end).
    pub fn advance_to(&mut self, t_target: f64) -> Result<(), StepFailure> {
        let dt = self.settings.dt;
        let t_end = self.settings.t_end;
        let target = t_target.min(t_end);
        let adaptive = self.settings.step_control == StepControl::Adaptive;
        while self.state.t < target - 1e-9 * dt {
            let t_i = self.state.t;
            let result = if adaptive {
                self.adaptive_step()
            } else {
                // Land exactly on t_end; otherwise steps are k·dt from 0 to avoid drift in t.
                let next = ((self.step_index + 1) as f64 * dt).min(t_end);
                let h = next - self.state.t;
                self.advance_interval(h, 0).map(|()| {
                    self.state.t = next;
                })
            };
            if let Err(e) = result {
                // Keep every completed step: complete the pending samples and stop.
                self.finalize_pending(true);
                self.update_stats();
                return Err(e);
            }
            self.step_index += 1;
            self.record_outputs(t_i);
        }
        if self.done() {
            self.finalize_pending(true);
        }
        self.update_stats();
        Ok(())
    }

    fn update_stats(&mut self) {
        self.stats.newton_iterations = self.integrator.total_iterations;
        self.stats.factorizations = self.integrator.matrix.numeric_factorizations;
        self.stats.linear_solves = self.integrator.solves;
        self.stats.orderings = self.integrator.matrix.orderings;
        self.stats.pattern_misses = self.integrator.pattern_misses;
        self.stats.pattern_rebuilds = self.integrator.pattern_rebuilds;
    }

    pub fn done(&self) -> bool {
        if self.is_static() {
            return self.load_factor >= 1.0;
        }
        self.state.t >= self.settings.t_end - 1e-9 * self.settings.dt
    }

    /// Used by tests: the step context of the current state.
    pub fn ctx(&self, h: f64) -> StepCtx<'_> {
        StepCtx {
            layout: self.system.layout,
            h,
            t_i: self.state.t,
            t_f: self.state.t + h,
            s: Integrator::scaling(&self.system, h),
            state: &self.state,
            gravity: self.system.gravity,
            statics: None,
        }
    }
}

/// Projects the initial velocities onto the velocity-level constraints, as the closest
/// velocities in the kinetic-energy norm: `min ½|V − V₀|²_M` subject to `B V + ∂C/∂t = 0`.
/// Coordinate rates, and the velocities of nodes the model gave none for, carry a negligible
/// weight, so they follow from the constraints and the given velocities. Returns
/// each node's velocity change (translational, or rotational times the model size).
pub fn project_initial_velocities(sys: &System, state: &mut State) -> Vec<f64> {
    let mut change = vec![0.0; sys.layout.n_nodes];
    if sys.layout.n_rows == 0 {
        return change;
    }
    let lay = Layout::new(
        Scheme::Ep,
        sys.layout.n_nodes,
        sys.layout.n_coords,
        sys.layout.n_rows,
    );
    let mut blocks: Vec<Vec<usize>> = Vec::new();
    for a in 0..lay.n_nodes {
        blocks.push((0..6).map(|k| lay.node_delta(a) + k).collect());
    }
    // Each joint's block: the unknowns its velocity-level rows touch.
    let mut joint_terms: Vec<Vec<(usize, RateTerm)>> = Vec::new();
    for j in &sys.joints {
        let mut terms = Vec::new();
        j.rate_terms(state, &mut terms);
        let mut b = Vec::new();
        for (_, t) in &terms {
            match *t {
                RateTerm::Node { node, .. } => b.extend((0..6).map(|k| lay.node_delta(node) + k)),
                RateTerm::Coord { coord, .. } => b.push(lay.coord_delta(coord)),
            }
        }
        b.extend((0..j.n_rows()).map(|r| lay.mult(j.row0() + r)));
        b.sort_unstable();
        b.dedup();
        blocks.push(b);
        joint_terms.push(terms);
    }
    for d in &sys.drives {
        blocks.push(vec![lay.coord_delta(d.coord), lay.mult(d.row)]);
    }
    for c in 0..lay.n_coords {
        blocks.push(vec![lay.coord_delta(c)]);
    }
    let refs: Vec<&[usize]> = blocks.iter().map(|b| b.as_slice()).collect();
    let (mut m, pos) = NewtonMatrix::from_blocks(lay.n_unknowns(), &refs, None);
    let mut rhs = vec![0.0; lay.n_unknowns()];
    let add = |m: &mut NewtonMatrix, block: usize, i: usize, j: usize, v: f64| {
        let b = &blocks[block];
        let n = b.len();
        let li = b.iter().position(|&g| g == i).unwrap();
        let lj = b.iter().position(|&g| g == j).unwrap();
        m.values[pos[block][li * n + lj]] += v;
    };
    // Mass-weighting; massless nodes get a small weight so the problem stays regular.
    let floor = 1e-8 * sys.mass_ref;
    let mut mass = vec![0.0; lay.n_nodes];
    let mut inertia = vec![crate::vec3::M3::<f64>::zero(); lay.n_nodes];
    for k in &sys.inertias {
        mass[k.node] += k.mass;
        inertia[k.node] = inertia[k.node] + k.inertia;
    }
    // Nodes whose velocities the model did not give follow the others: when any node's
    // velocity was given, theirs carry a negligible weight (relative weighting among them
    // stays the kinetic-energy metric).
    let any_given = sys.velocity_given.iter().any(|&g| g);
    for a in 0..lay.n_nodes {
        if mass[a] <= 0.0 {
            mass[a] = floor;
        }
        if inertia[a].max_abs() <= 0.0 {
            inertia[a] = crate::vec3::M3::identity().scale_f(floor * sys.length_ref.powi(2));
        }
        // Nodes without given velocities follow the given ones (weight 1e-6), but relative
        // coordinates (joint rates, a sliding contact point's ζ̇: weight 1e-14 below) move
        // first: a collar launched along a beam at rest slides along it rather than dragging
        // the beam with it.
        if any_given && !sys.velocity_given[a] {
            mass[a] *= 1e-6;
            inertia[a] = inertia[a].scale_f(1e-6);
        }
    }
    for a in 0..lay.n_nodes {
        let d = lay.node_delta(a);
        let n = &state.nodes[a];
        for k in 0..3 {
            add(&mut m, a, d + k, d + k, mass[a]);
            rhs[d + k] = mass[a] * n.v.0[k];
            let jw = inertia[a].mul_v(&n.w);
            rhs[d + 3 + k] = jw.0[k];
            for l in 0..3 {
                add(&mut m, a, d + 3 + k, d + 3 + l, inertia[a].0[k][l]);
            }
        }
    }
    let coord_weight = 1e-14 * sys.mass_ref * sys.length_ref.powi(2);
    for c in 0..lay.n_coords {
        let b = blocks.len() - lay.n_coords + c;
        add(
            &mut m,
            b,
            lay.coord_delta(c),
            lay.coord_delta(c),
            coord_weight,
        );
        rhs[lay.coord_delta(c)] = coord_weight * state.coord_rates[c];
    }
    for (ji, j) in sys.joints.iter().enumerate() {
        let blk = lay.n_nodes + ji;
        for (r, term) in &joint_terms[ji] {
            let row = lay.mult(j.row0() + r);
            match *term {
                RateTerm::Node { node, v, omega } => {
                    let d = lay.node_delta(node);
                    // Material angular velocity: B_W = B_ω R.
                    let bw = state.nodes[node].r.tmul_v(&omega);
                    for c in 0..3 {
                        for (col, val) in [(d + c, v.0[c]), (d + 3 + c, bw.0[c])] {
                            add(&mut m, blk, row, col, val);
                            add(&mut m, blk, col, row, val);
                        }
                    }
                }
                RateTerm::Coord { coord, value } => {
                    add(&mut m, blk, row, lay.coord_delta(coord), value);
                    add(&mut m, blk, lay.coord_delta(coord), row, value);
                }
            }
        }
    }
    for (di, d) in sys.drives.iter().enumerate() {
        let blk = lay.n_nodes + sys.joints.len() + di;
        let row = lay.mult(d.row);
        add(&mut m, blk, row, lay.coord_delta(d.coord), 1.0);
        add(&mut m, blk, lay.coord_delta(d.coord), row, 1.0);
        rhs[row] = d.target_rate(state.t);
    }
    if m.factor().is_err() {
        return change;
    }
    // The small weights of unspecified velocities and coordinate rates keep the matrix
    // regular but pull them towards their guesses (zero), which moves the given velocities
    // by ~1e-6. Re-solving with the last solution as their guesses (a proximal iteration)
    // shrinks that bias by the weight ratio each time: three solves leave ~1e-18.
    let base = rhs.clone();
    m.solve(&mut rhs);
    for _ in 0..2 {
        let mut next = base.clone();
        for a in (0..lay.n_nodes).filter(|&a| any_given && !sys.velocity_given[a]) {
            let d = lay.node_delta(a);
            let w = inertia[a].mul_v(&V3([rhs[d + 3], rhs[d + 4], rhs[d + 5]]));
            for k in 0..3 {
                next[d + k] = mass[a] * rhs[d + k];
                next[d + 3 + k] = w.0[k];
            }
        }
        for c in 0..lay.n_coords {
            next[lay.coord_delta(c)] = coord_weight * rhs[lay.coord_delta(c)];
        }
        m.solve(&mut next);
        rhs = next;
    }
    for a in 0..lay.n_nodes {
        let d = lay.node_delta(a);
        let v = V3([rhs[d], rhs[d + 1], rhs[d + 2]]);
        let w = V3([rhs[d + 3], rhs[d + 4], rhs[d + 5]]);
        let n = &mut state.nodes[a];
        change[a] = (v - n.v)
            .norm()
            .max((n.r.mul_v(&(w - n.w))).norm() * sys.length_ref);
        n.v = v;
        n.w = w;
    }
    for c in 0..lay.n_coords {
        state.coord_rates[c] = rhs[lay.coord_delta(c)];
    }
    change
}

/// Over-constrained joints are a model error, reported by name: a dependence among the
/// constraint rows in the initial configuration would only show up as a singular matrix.
fn check_redundancy(model: &Model, system: &System) -> Result<(), ModelErrors> {
    use crate::model::ModelError;
    let deps = crate::system::redundancy::dependences(system, &system.initial);
    if deps.is_empty() {
        return Ok(());
    }
    let errors = deps
        .iter()
        .map(|d| {
            // Drive rows are named `<joint>.drive_<coordinate>`.
            let joint_of = |o: &str| o.split(".drive_").next().unwrap_or(o).to_string();
            let mut joints: Vec<String> = Vec::new();
            for o in &d.owners {
                let j = joint_of(o);
                if !joints.contains(&j) {
                    joints.push(j);
                }
            }
            let path = joints
                .iter()
                .find_map(|j| model.joints.iter().position(|mj| mj.name() == j))
                .map_or("joints".to_string(), |i| format!("joints[{i}]"));
            let names = joints
                .iter()
                .map(|j| format!("`{j}`"))
                .collect::<Vec<_>>()
                .join(", ");
            let drives = d.owners.iter().any(|o| o.contains(".drive_"));
            let hint = if drives {
                "a drive prescribes a motion the joints already fix, or the joints over-constrain a loop"
            } else {
                "an over-constrained closed loop (e.g. a planar loop of revolutes: make one a universal or spherical joint), or a configuration where the joints are singular"
            };
            ModelError::new(
                path,
                format!("the constraints of {names} are not independent in the initial configuration: {hint}; remove a redundant constraint"),
            )
        })
        .collect();
    Err(ModelErrors(errors))
}

/// The rotation parameters (Cayley) taking `from` to `to` in `from`'s frame; a half-turn or
/// more (never within a converged step) reads as infinite.
fn rotation_between(from: &crate::vec3::M3<f64>, to: &crate::vec3::M3<f64>) -> V3<f64> {
    crate::rotation::cayley_log(&from.transpose().mul_m(to)).unwrap_or(V3([f64::INFINITY; 3]))
}
