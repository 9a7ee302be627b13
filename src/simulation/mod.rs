//! A running simulation: consistent initial velocities, fixed-step advance with step halving
//! on Newton failure, and sensor samples handed out in chunks so memory stays flat.

mod energy_scale;
mod failures;
mod inertial_preload;
mod initial_velocities;
mod outputs;
mod quasi_static_rate;
mod step_control;
mod stick_slip;
mod velocity_projection;

pub use initial_velocities::project_initial_velocities;

use crate::elements::StepCtx;
use crate::integrator::timings::{Phase, Timings};
use crate::integrator::{Integrator, StepFailure, StepReport};
use crate::joints::Joint;
use crate::math::vec3::V3;
use crate::model::{Analysis, Model, ModelErrors, Scheme, SimulationSettings, StepControl};
use crate::sensors::{Channels, Totals};
use crate::state::State;
use crate::system::energy_memo::EnergyMemo;
use crate::system::System;

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
    /// Of them, those of the exact Newton matrix (the rest: ED's decoupled complex system).
    pub exact_factorizations: usize,
    /// Of all factorizations, those that chose their pivots; the rest reused the pivots and
    /// factor patterns of an earlier one (numeric refactorizations).
    pub pivoting_factorizations: usize,
    /// Fill-reducing orderings computed (once per sparsity pattern).
    pub orderings: usize,
    /// Steps whose kept factors had their sliding contacts' rows and columns refreshed
    /// instead of a factorization (modified Newton with sliding joints).
    pub border_refreshes: usize,
    /// Steps modified Newton ended on an update predicted to balance the forces, the
    /// constraint rows alone evaluated after it (`integrator/predicted_stop.rs`), and the
    /// constraint-only evaluations made (the others found the constraints not yet holding).
    pub predicted_stops: usize,
    pub constraint_checks: usize,
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
    /// Adaptive stepping: accepted steps whose error indicator was set by the motion's
    /// smoothness, by a spin's rate (Cayley parameters' (ωh)²/12), by ED's jumps.
    pub steps_set_by: [usize; 3],
    /// Linear solves (Newton updates); with modified Newton more than factorizations.
    pub linear_solves: usize,
    /// Assemblies of the Newton equations (residuals, some with a tangent).
    pub residual_evaluations: usize,
    /// Smallest and largest step taken, s.
    pub dt_smallest: f64,
    pub dt_largest: f64,
    /// The last step taken.
    pub last_dt: f64,
    /// Wall time per phase of the steps, if `simulation.timings` asked for it.
    pub timings: Timings,
}

impl Default for RunStats {
    fn default() -> Self {
        RunStats {
            steps: 0,
            halvings: 0,
            newton_iterations: 0,
            factorizations: 0,
            exact_factorizations: 0,
            border_refreshes: 0,
            predicted_stops: 0,
            timings: Timings::default(),
            constraint_checks: 0,
            pivoting_factorizations: 0,
            orderings: 0,
            max_constraint_violation: 0.0,
            max_constraint_work: 0.0,
            max_energy_defect: 0.0,
            pattern_misses: 0,
            pattern_rebuilds: 0,
            rejected: 0,
            over_tolerance: 0,
            steps_set_by: [0; 3],
            linear_solves: 0,
            residual_evaluations: 0,
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
    /// Steps that failed and were retried shorter, by the equation left unbalanced.
    failures: failures::FailureLog,
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
    /// State channels at the current state (the start of the next step); None where no
    /// output needed them (with `output_dt`, see `outputs.rs`).
    last_row: Option<Vec<f64>>,
    /// Channels that are step-end bookkeeping, interpolated linearly between step ends.
    step_end_channels: Vec<usize>,
    /// Adaptive stepping: the size proposed for the next step; the last two steps' sizes and
    /// mean velocities (for EP's error estimate), latest last.
    h_next: f64,
    recent_means: std::collections::VecDeque<StepMeans>,
    /// Adaptive stepping: the step-size controller.
    controller: step_control::Controller,
    /// Adaptive stepping: the times a load scale jumps at, ascending (steps end on them).
    load_jumps: Vec<f64>,
    /// The error indicator's energy scales (total, translational, rotational motion energy;
    /// see `motion_energies`): the largest so far, never less than `energy_floor`.
    energy_scale: [f64; 3],
    /// The energy scale the model's drives and loads set before the run (see
    /// `energy_scale.rs`).
    pub energy_floor: f64,
    /// Static analysis: the load factor of the current state.
    load_factor: f64,
    /// The model's topology (JSON, see `fields::topology`) when the run records fields.
    pub topology: Option<String>,
    /// The energies of the last state asked about (a step's end is the next one's start).
    energy_memo: EnergyMemo,
}

impl Simulation {
    pub fn new(model: &Model) -> Result<Simulation, SimError> {
        Self::with_scheme(model, model.simulation.scheme)
    }

    pub fn with_scheme(model: &Model, scheme: Scheme) -> Result<Simulation, SimError> {
        // Patterns expanded and frames placed once; everything below sees the flat model.
        let flat = model.flattened().map_err(SimError::Model)?;
        let model = &flat;
        let statics = model.simulation.analysis == Analysis::Static;
        // A static solve has no velocities: it uses the EP layout whatever the scheme.
        let layout_scheme = if statics { Scheme::Ep } else { scheme };
        let mut system = crate::compile::compile(model, layout_scheme).map_err(SimError::Model)?;
        check_redundancy(model, &system).map_err(|e| SimError::Model(e.located(model)))?;
        let mut settings = model.simulation.clone();
        settings.scheme = scheme;
        let (mut state, mut warnings) = initial_state(model, &system, &settings, statics)?;
        stick_slip::start_frictions(&mut system, &mut state);
        warnings.extend(stick_slip::static_friction_warning(&system, statics));
        let mut load_jumps = Vec::new();
        if !statics {
            warnings.extend(system.time_function_jumps(settings.t_end));
            load_jumps = system.load_jump_times(settings.t_end);
        }
        let mut integrator = Integrator::new(&system, &settings);
        let energy_floor = if statics || settings.step_control == StepControl::Fixed {
            0.0
        } else {
            energy_scale::energy_floor(&system, &state, &mut integrator, &settings)
        };
        // The run's timings start with its first step (that linearized step is set-up).
        integrator.timings = Timings::new(settings.timings);
        let mut channels =
            Channels::new(model, &system).map_err(|e| SimError::Model(e.located(model)))?;
        let fields = crate::fields::Fields::new(&system);
        let mut topology = None;
        if crate::fields::fields_enabled(&settings, &fields) {
            channels.fields = Some(fields);
            topology = Some(crate::fields::topology(model, &system).to_string());
        }
        let e0 = {
            let e = system.energies(&state);
            e.kinetic() + e.potential()
        };
        let totals = Totals {
            initial_energy: e0,
            per_drive_work: vec![0.0; system.drives.len()],
            per_friction_work: vec![0.0; system.frictions.len()],
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
            failures: Default::default(),
            last_report: None,
            times: vec![],
            values: vec![],
            pending: Default::default(),
            recent: Default::default(),
            step_index: 0,
            output_index: 1,
            last_row: None,
            step_end_channels: vec![],
            h_next: 0.0,
            recent_means: Default::default(),
            controller: Default::default(),
            load_jumps,
            energy_scale: [0.0; 3],
            energy_floor,
            load_factor: 0.0,
            topology,
            energy_memo: EnergyMemo::default(),
        };
        sim.h_next = sim.settings.dt;
        sim.energy_scale = sim.motion_energies(&sim.state).map(|e| e.max(energy_floor));
        sim.step_end_channels = sim.channels.step_end_channels();
        sim.record_start(statics);
        Ok(sim)
    }

    /// The first sample: a static run's unloaded state, with no reactions yet; a dynamic
    /// run's initial state with its instant values.
    fn record_start(&mut self, statics: bool) {
        if statics {
            let mut row = self.sample_channels();
            for &c in self.channels.step_channels() {
                row[c] = 0.0;
            }
            self.times.push(0.0);
            self.values.extend_from_slice(&row);
        } else {
            self.record();
            self.push_instant_values();
        }
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
            let started = self.integrator.timings.start();
            let result = self.advance_load(target, 0);
            self.integrator.timings.add_total(started);
            self.update_stats();
            result.map_err(|mut e| {
                e.reason.push_str(&self.free_contacts_hint());
                e
            })?;
        }
        Ok(())
    }

    /// For a failed static solve: the sliding joints whose contact point η is free (no drive,
    /// no spring). Statics must also find where such a follower rests along the beam, and
    /// while nothing acts along the beam yet (a straight beam at the first load step) η has
    /// no stiffness at all: a drive or a spring gives it one. Empty without such joints.
    fn free_contacts_hint(&self) -> String {
        let free: Vec<String> = self
            .system
            .joint_info
            .iter()
            .filter(|info| self.system.joints[info.kernel].as_sliding().is_some())
            .filter(|info| {
                info.coords
                    .iter()
                    .any(|c| c.drive.is_none() && c.spring.is_none())
            })
            .map(|info| format!("`{}`", info.name))
            .collect();
        if free.is_empty() {
            return String::new();
        }
        format!(
            "; the contact point η of sliding joint(s) {} is free (no drive, no spring): a \
             static solve must also find where along the beam the follower comes to rest, and \
             nothing restrains η while nothing acts along the beam — prescribe it (`drive`) \
             or give it a `spring` along the beam",
            free.join(", ")
        )
    }

    /// Linearization about the current (static) state for modal analysis: the static tangent
    /// K and the mass matrix M, sparse over the EP layout, and a label per unknown:
    /// `<node>.<x|y|z|rx|ry|rz>` (rotations material), `coord:<name>`, or `row:<owner>.<k>`
    /// for constraint rows (no mass; they border K with the constraint gradients).
    pub fn linearize(&mut self) -> Linearization {
        assert!(self.is_static(), "linearization needs a static analysis");
        self.follow_contacts();
        let sys = &self.system;
        let lay = sys.layout;
        let lf = if self.load_factor > 0.0 {
            self.load_factor
        } else {
            1.0
        };
        let stiffness = self.integrator.static_tangent(sys, &self.state, lf);
        let mut mass = (Vec::new(), Vec::new(), Vec::new());
        for inertia in &sys.inertias {
            let d = lay.node_delta(inertia.node);
            for i in 0..3 {
                push_entry(&mut mass, d + i, d + i, inertia.mass);
                for j in 0..3 {
                    push_entry(&mut mass, d + 3 + i, d + 3 + j, inertia.inertia.0[i][j]);
                }
            }
        }
        // Friction rows come last in the layout; statics and modes leave friction out, so
        // its rows (only `F = 0` in statics) are dropped.
        let n = lay.n_unknowns() - sys.frictions.len();
        let mut labels = self.unknown_labels();
        labels.truncate(n);
        Linearization {
            n,
            stiffness: leading_block(stiffness, n),
            mass,
            damping: self.damping_matrix(),
            labels,
        }
    }

    /// A static analysis's linearization about `state`, a state of a run of the same model
    /// (e.g. a dynamic one, sampled along its trajectory): its positions, joint coordinates,
    /// element history and constraint forces replace this analysis's, at its time (drives
    /// there), velocities dropped. The tangent is then the one at that configuration under the
    /// forces acting there — frozen-time natural frequencies along a motion. `Err` names
    /// what does not match when the state is not of this model.
    pub fn linearize_about(&mut self, state: &State) -> Result<Linearization, String> {
        let own = &self.state;
        let sizes = |s: &State| {
            (
                s.nodes.len(),
                s.coords.len(),
                s.lambda.len(),
                s.history.len(),
            )
        };
        if sizes(own) != sizes(state) {
            return Err(format!(
                "the state is not of this model: (nodes, coordinates, constraint rows, history) \
                 {:?} against {:?}",
                sizes(state),
                sizes(own)
            ));
        }
        self.state = state.clone();
        self.state.at_rest();
        self.state_changed_between_steps();
        self.load_factor = 1.0;
        Ok(self.linearize())
    }

    /// The gyroscopic (Coriolis) matrix `G` of the linearized equations `M q̈ + G q̇ + K q = 0`
    /// in the frame turning with the nodes' initial spins, as triplets over the EP layout:
    /// `2 m Ω̃` on a spinning node's translations (inertial components) and
    /// `J W̃ + W̃ J − (J W)~`, `W = Rᵀ Ω`, on its material rotation increments — the θ̇ terms of
    /// Euler's equations for `w = W + W̃ θ + θ̇`, whose θ terms the static tangent already
    /// holds (with the centrifugal softening `m Ω̃ Ω̃`). Skew-symmetric; empty without spins.
    pub fn gyroscopic_matrix(&self) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let sys = &self.system;
        let mut out = (Vec::new(), Vec::new(), Vec::new());
        for inertia in &sys.inertias {
            let Some(spin) = &inertia.spin else { continue };
            let d = sys.layout.node_delta(inertia.node);
            let translation = spin.omega.tilde().scale_f(2.0 * inertia.mass);
            let w = self.state.nodes[inertia.node].r.tmul_v(&spin.omega);
            let j = inertia.inertia;
            let rotation = j.mul_m(&w.tilde()) + w.tilde().mul_m(&j) - j.mul_v(&w).tilde();
            for a in 0..3 {
                for b in 0..3 {
                    push_entry(&mut out, d + a, d + b, translation.0[a][b]);
                    push_entry(&mut out, d + 3 + a, d + 3 + b, rotation.0[a][b]);
                }
            }
        }
        out
    }

    /// The viscous damping matrix of the linearized equations, as triplets over the EP
    /// layout: the beams' structural damping and the joints' dampers (N·s/m, N·m·s/rad).
    fn damping_matrix(&self) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let sys = &self.system;
        let lay = sys.layout;
        let mut out = (Vec::new(), Vec::new(), Vec::new());
        for b in sys.beams.iter().filter(|b| b.is_damped()) {
            let c = b.damping_matrix(&self.state);
            let n = 6 * b.nodes.len();
            let global = |l: usize| lay.node_delta(b.nodes[l / 6]) + l % 6;
            for i in 0..n {
                for j in 0..n {
                    push_entry(&mut out, global(i), global(j), c[i * n + j]);
                }
            }
        }
        for sp in &sys.springs {
            let d = lay.coord_delta(sp.coord);
            push_entry(&mut out, d, d, sp.damping);
        }
        out
    }

    /// A label per unknown of the EP layout: `<node>.<x|y|z|rx|ry|rz>`, `coord:<name>`,
    /// `row:<owner>.<k>` (constraint rows).
    fn unknown_labels(&self) -> Vec<String> {
        let sys = &self.system;
        let lay = sys.layout;
        let mut labels = vec![String::new(); lay.n_unknowns()];
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
        labels
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
                let mut row = self.sample_channels();
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
                self.note_retried_failure(&e);
                let mid = 0.5 * (self.load_factor + target);
                self.advance_load(mid, depth + 1)?;
                self.advance_load(target, depth + 1)
            }
            Err(e) => Err(e),
        }
    }

    pub fn energy(&self) -> f64 {
        let energies = self.energy_memo.energies(&self.system, &self.state);
        energies.kinetic() + energies.potential()
    }

    /// Takes a converged step: energy bookkeeping, checks, the step's multipliers, and the
    /// samples whose times it covers.
    fn accept(&mut self, state: State, report: StepReport, h: f64) {
        let started = self.integrator.timings.start();
        self.accept_books(state, report, h);
        self.integrator.timings.add(Phase::Outputs, started);
    }

    /// [`Self::accept`]'s work: the step's energy books, totals, statistics and outputs.
    fn accept_books(&mut self, state: State, report: StepReport, h: f64) {
        let t_i = self.state.t;
        let e_i = self.energy();
        // Before the step's books change the totals: the start's channels, if an output
        // falls inside the step and they were not sampled.
        self.sample_start_for_outputs(state.t);
        if self.settings.step_control == StepControl::Adaptive {
            let means = self.step_means(&state, h);
            if self.recent_means.len() == 2 {
                self.recent_means.pop_front();
            }
            self.recent_means.push_back(means);
        }
        let start = std::mem::replace(&mut self.state, state);
        self.stats.steps += 1;
        self.stats.dt_smallest = self.stats.dt_smallest.min(h);
        self.stats.dt_largest = self.stats.dt_largest.max(h);
        self.stats.last_dt = h;
        let e_f = self.energy();
        let now = self.motion_energies(&self.state);
        for (scale, e) in self.energy_scale.iter_mut().zip(now) {
            *scale = scale.max(e);
        }
        let t = &mut self.totals;
        t.drive_work += report.drive_work;
        t.external_work += report.external_work;
        t.damper_work += report.damper_work;
        t.friction_work += report.friction_work;
        for (w, f) in t.per_friction_work.iter_mut().zip(&report.frictions) {
            *w += f.work;
        }
        t.numerical_dissipation += report.numerical_dissipation;
        for (w, dw) in t.per_drive_work.iter_mut().zip(report.drive_works.iter()) {
            *w += dw;
        }
        let defect = e_f
            - e_i
            - report.drive_work
            - report.external_work
            - report.damper_work
            - report.friction_work
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
        self.record_outputs(&start);
    }

    /// One step to time `end`, retried as two halves (recursively) if Newton fails; a
    /// friction event inside it ends a step there and the rest follows.
    fn advance_interval(&mut self, end: f64, depth: u32) -> Result<(), StepFailure> {
        self.follow_contacts();
        let h = end - self.state.t;
        match self.step_with_friction(h) {
            Ok(step) if step.h < h => {
                self.accept(step.state, step.report, step.h);
                self.advance_interval(end, depth)
            }
            Ok(step) => {
                let mut state = step.state;
                // Exactly on the grid k·dt (no drift in t).
                state.t = end;
                self.accept(state, step.report, h);
                Ok(())
            }
            Err(e) if e.retry && depth < self.settings.max_step_halvings => {
                self.stats.halvings += 1;
                self.note_retried_failure(&e);
                self.advance_interval(self.state.t + 0.5 * h, depth + 1)?;
                self.advance_interval(end, depth + 1)
            }
            Err(e) => Err(e),
        }
    }

    /// Advances up to `t_target` (not past `t_end`), recording samples: fixed steps of `dt`
    /// on the grid k·dt, or adaptive steps (which may end past `t_target`, never past t_end).
    pub fn advance_to(&mut self, t_target: f64) -> Result<(), StepFailure> {
        self.advance_until(t_target, None)
    }

    /// As [`advance_to`](Self::advance_to), but returns early (after a whole step) once the
    /// wall clock passes `deadline`: the caller flushes results and answers signals at least
    /// that often, however small the steps.
    pub fn advance_until(
        &mut self,
        t_target: f64,
        deadline: Option<std::time::Instant>,
    ) -> Result<(), StepFailure> {
        let started = self.integrator.timings.start();
        let advanced = self.advance_steps(t_target, deadline);
        self.integrator.timings.add_total(started);
        self.update_stats();
        advanced
    }

    /// [`Self::advance_until`]'s steps and their samples (statistics updated by the caller).
    fn advance_steps(
        &mut self,
        t_target: f64,
        deadline: Option<std::time::Instant>,
    ) -> Result<(), StepFailure> {
        let dt = self.settings.dt;
        let t_end = self.settings.t_end;
        let target = t_target.min(t_end);
        let adaptive = self.settings.step_control == StepControl::Adaptive;
        while self.state.t < target - 1e-9 * dt {
            let result = if adaptive {
                self.adaptive_step()
            } else {
                // Land exactly on t_end; otherwise steps are k·dt from 0 to avoid drift in t.
                let next = ((self.step_index + 1) as f64 * dt).min(t_end);
                self.advance_interval(next, 0)
            };
            if let Err(e) = result {
                // Keep every completed step: complete the pending samples and stop.
                self.finalize_pending(true);
                return Err(e);
            }
            self.step_index += 1;
            if deadline.is_some_and(|d| std::time::Instant::now() >= d) {
                break;
            }
        }
        if self.done() && !self.pending.is_empty() {
            // The last samples: interpolated towards the end instant's own values.
            if self.recent.back().is_some_and(|(t, _)| *t < self.state.t) {
                self.push_instant_values();
            }
            self.finalize_pending(true);
        }
        Ok(())
    }

    fn update_stats(&mut self) {
        self.stats.newton_iterations = self.integrator.total_iterations;
        self.stats.factorizations = self.integrator.factorizations();
        self.stats.exact_factorizations = self.integrator.matrix.numeric_factorizations;
        self.stats.pivoting_factorizations = self.integrator.pivoting_factorizations();
        self.stats.linear_solves = self.integrator.solves;
        self.stats.residual_evaluations = self.integrator.residual_evaluations;
        self.stats.orderings = self.integrator.matrix.orderings;
        self.stats.border_refreshes = self.integrator.border_refreshes;
        self.stats.predicted_stops = self.integrator.predicted_stops;
        self.stats.constraint_checks = self.integrator.constraint_checks;
        self.stats.pattern_misses = self.integrator.pattern_misses;
        self.stats.pattern_rebuilds = self.integrator.pattern_rebuilds;
        self.stats.timings = self.integrator.timings.clone();
    }

    pub fn done(&self) -> bool {
        if self.is_static() {
            return self.load_factor >= 1.0;
        }
        self.state.t >= self.settings.t_end - 1e-9 * self.settings.dt
    }

    /// Used by tests: the step context of the current state.
    pub fn ctx(&self, h: f64) -> StepCtx<'_> {
        Integrator::step_ctx(&self.system, &self.state, h)
    }
}

/// The state a run starts from, and what the start warns about: at rest for statics; else
/// pre-loaded if asked, with its velocities made consistent.
fn initial_state(
    model: &Model,
    system: &System,
    settings: &SimulationSettings,
    statics: bool,
) -> Result<(State, Vec<String>), SimError> {
    let mut state = system.initial.clone();
    let mut warnings = Vec::new();
    if statics {
        state.at_rest();
        return Ok((state, warnings));
    }
    let static_start = settings.preload == Some(true);
    if static_start {
        start_from_static_equilibrium(model, system, &mut state)?;
    }
    warnings.extend(initial_velocities::make_consistent(
        model, system, &mut state,
    ));
    let unstrained = initial_velocities::unstrained_start(system, &state, static_start);
    if unstrained.is_none() && settings.preload.is_none() && settings.inertial_preload {
        warnings.extend(start_strained(model, system, settings, &mut state));
    }
    if let Some(warning) = unstrained {
        if !settings.inertial_preload {
            warnings.push(warning);
            return Ok((state, warnings));
        }
        let outcome = inertial_preload::preload(model, system, settings, &mut state);
        warnings.extend(outcome.err().map(|why| {
            format!("{warning} (the inertial pre-load that starts them strained failed: {why})")
        }));
    }
    Ok((state, warnings))
}

/// Beams that would start unstrained under the loads acting at t = 0 start strained by them,
/// or a warning says why they could not:
/// - a model at rest under gravity, loads or springs (`inertial_preload::preload_at_rest`):
///   it would otherwise ring about that deflection (a 20 kg carriage on a 2 m steel
///   cantilever: ±14 mm about its 10 mm sag, and five times the steps; a spring-deployed
///   boom: 1.7 µs steps);
/// - beams in free motion, given velocities and no drive moving (`inertial_preload::preload`):
///   unstrained, a tumbling beam's centrifugal stretch is a step load at its axial and
///   bending modes.
fn start_strained(
    model: &Model,
    system: &System,
    settings: &SimulationSettings,
    state: &mut State,
) -> Option<String> {
    if let Some(beams) = initial_velocities::loaded_at_rest(system, state) {
        let outcome = inertial_preload::preload_at_rest(model, system, settings, state);
        return outcome.err().map(|why| {
            format!("beam(s) {beams} start unstrained under gravity, the loads and springs at t = 0 and will ring about their deflection under them: the pre-load that starts them in equilibrium failed ({why}); `simulation.preload: true` asks for the static equilibrium itself, `preload: false` for this start without this warning")
        });
    }
    let beams = initial_velocities::beams_in_free_motion(system, state)?;
    let outcome = inertial_preload::preload(model, system, settings, state);
    outcome.err().map(|why| {
        format!("beam(s) {beams} start unstrained under the inertial loads of their initial motion and will ring at their modes: the inertial pre-load that starts them strained failed ({why}); `simulation.inertial_preload: false` asks for this start without this warning")
    })
}

/// A static pre-load: the state becomes the static equilibrium under the loads and gravity at
/// t = 0 (drives at their t = 0 values) and, for initial spins, their steady-rotation inertia,
/// so the dynamic run begins without the transient of a load (or a rotor's centrifugal
/// stretch) appearing on an unloaded structure.
fn start_from_static_equilibrium(
    model: &Model,
    system: &System,
    state: &mut State,
) -> Result<(), SimError> {
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
    adopt_static_positions(system, state, &pre.state);
    state.lambda.clone_from(&pre.state.lambda);
    Ok(())
}

/// Starts from a static solve's positions, coordinates and history; a spinning node's
/// velocities follow it to where it now is (its steady-spin position).
fn adopt_static_positions(system: &System, state: &mut State, solved: &State) {
    for ((n, p), spin) in state
        .nodes
        .iter_mut()
        .zip(&solved.nodes)
        .zip(&system.node_spin)
    {
        n.x = p.x;
        n.r = p.r;
        if let Some(spin) = spin {
            n.v = spin.omega.cross(&(n.x - spin.center));
            n.w = n.r.tmul_v(&spin.omega);
        }
    }
    state.coords.clone_from(&solved.coords);
    state.history.clone_from(&solved.history);
}

/// Over-constrained joints are a model error, reported by name: a dependence among the
/// constraint rows in the initial configuration would only show up as a singular matrix.
/// Dependences among the same joints are reported once, with their number (a screw jack's
/// revolute, guide and thread over-constrain its loop by four equations, not four times).
fn check_redundancy(model: &Model, system: &System) -> Result<(), ModelErrors> {
    use crate::model::ModelError;
    let deps = crate::system::redundancy::dependences(system, &system.initial);
    // (joints, whether a drive row takes part, how many dependences).
    let mut groups: Vec<(Vec<String>, bool, usize)> = Vec::new();
    for d in &deps {
        // Drive rows are named `<joint>.drive_<coordinate>`.
        let joint_of = |o: &str| o.split(".drive_").next().unwrap_or(o).to_string();
        let mut joints: Vec<String> = Vec::new();
        for o in &d.owners {
            let j = joint_of(o);
            if !joints.contains(&j) {
                joints.push(j);
            }
        }
        let drives = d.owners.iter().any(|o| o.contains(".drive_"));
        match groups.iter_mut().find(|g| g.0 == joints && g.1 == drives) {
            Some(g) => g.2 += 1,
            None => groups.push((joints, drives, 1)),
        }
    }
    if groups.is_empty() {
        return Ok(());
    }
    let errors = groups
        .into_iter()
        .map(|(joints, drives, count)| {
            let path = joints
                .iter()
                .find_map(|j| model.joints.iter().position(|mj| mj.name() == j))
                .map_or("joints".to_string(), |i| format!("joints[{i}]"));
            let names = joints
                .iter()
                .map(|j| format!("`{j}`"))
                .collect::<Vec<_>>()
                .join(", ");
            let hint = if drives {
                "a drive prescribes a motion the joints already fix, or the joints over-constrain a loop"
            } else {
                "an over-constrained closed loop (e.g. a planar loop of revolutes: make one a universal or spherical joint), or a configuration where the joints are singular"
            };
            let how_many = match count {
                1 => String::new(),
                n => format!(" ({n} of their equations are redundant)"),
            };
            ModelError::new(
                path,
                format!("the constraints of {names} are not independent in the initial configuration{how_many}: {hint}; remove a redundant constraint"),
            )
        })
        .collect();
    Err(ModelErrors(errors))
}

/// A model linearized about a static state (see [`Simulation::linearize`]), sparse.
pub struct Linearization {
    /// Unknowns of the EP layout (node increments, coordinates, constraint rows).
    pub n: usize,
    /// The static tangent, bordered by the scaled constraint gradients: `(col_ptr, row_idx,
    /// values)`, compressed sparse columns.
    pub stiffness: (Vec<usize>, Vec<usize>, Vec<f64>),
    /// The lumped mass matrix as `(rows, cols, values)` triplets (kg; kg·m² for rotations,
    /// body-frame inertia on the material rotation increments).
    pub mass: (Vec<usize>, Vec<usize>, Vec<f64>),
    /// The viscous damping matrix as triplets (zero for an undamped model).
    pub damping: (Vec<usize>, Vec<usize>, Vec<f64>),
    pub labels: Vec<String>,
}

/// The leading `n × n` block of a matrix in compressed sparse columns.
fn leading_block(
    (ptr, idx, val): (Vec<usize>, Vec<usize>, Vec<f64>),
    n: usize,
) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    if ptr.len() == n + 1 {
        return (ptr, idx, val);
    }
    let mut out = (vec![0], Vec::new(), Vec::new());
    for j in 0..n {
        for p in ptr[j]..ptr[j + 1] {
            if idx[p] < n {
                out.1.push(idx[p]);
                out.2.push(val[p]);
            }
        }
        out.0.push(out.1.len());
    }
    out
}

fn push_entry(t: &mut (Vec<usize>, Vec<usize>, Vec<f64>), i: usize, j: usize, v: f64) {
    if v != 0.0 {
        t.0.push(i);
        t.1.push(j);
        t.2.push(v);
    }
}
