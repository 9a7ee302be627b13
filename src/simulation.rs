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
    /// Linear solves (Newton updates); with modified Newton more than factorizations.
    pub linear_solves: usize,
    /// Smallest and largest step taken, s.
    pub dt_smallest: f64,
    pub dt_largest: f64,
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
            linear_solves: 0,
            dt_smallest: f64::INFINITY,
            dt_largest: 0.0,
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
    /// Adaptive stepping: the size proposed for the next step; the previous step's size and
    /// its start velocities (for the error predictor).
    h_next: f64,
    previous_step: Option<(f64, Vec<(V3<f64>, V3<f64>)>)>,
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
            // at their t = 0 values): the dynamic run then begins without the transient of a
            // load appearing on an unloaded structure.
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
            for (n, p) in state.nodes.iter_mut().zip(&pre.state.nodes) {
                n.x = p.x;
                n.r = p.r;
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
            warnings.push(format!(
                "initial velocities of node(s) {} were adjusted to satisfy the joints' velocity constraints (largest change {worst:.4} m/s, or rad/s times the model size); give consistent velocities to avoid this",
                changed.join(", ")
            ));
        }
        let integrator = Integrator::new(&system, &settings);
        let channels = Channels::new(model, &system);
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
            previous_step: None,
            load_factor: 0.0,
        };
        sim.h_next = sim.settings.dt;
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
        let start_rates = self.node_rates();
        self.state = state;
        self.stats.steps += 1;
        self.stats.dt_smallest = self.stats.dt_smallest.min(h);
        self.stats.dt_largest = self.stats.dt_largest.max(h);
        self.previous_step = Some((h, start_rates));
        let e_f = self.energy();
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

    /// Each node's velocity and material angular velocity.
    fn node_rates(&self) -> Vec<(V3<f64>, V3<f64>)> {
        self.state.nodes.iter().map(|n| (n.v, n.w)).collect()
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
    /// meets the tolerance): the difference between the step's increments and a second-order
    /// predictor from the previous step (`x_i + h v_i + ½h² a_i`, `a_i` the previous step's
    /// mean acceleration; the same for the material rotation parameters), ~h³/6·x‴ — positions
    /// relative to the model's size, rotations in radians, over the tolerance. The first step
    /// has no previous one: its predictor is constant-velocity, a conservative O(h²) bound.
    fn local_error(&self, end: &State, h: f64) -> f64 {
        let mut worst = 0.0f64;
        for (a, (ni, nf)) in self.state.nodes.iter().zip(&end.nodes).enumerate() {
            let (acc, alpha) = match &self.previous_step {
                Some((hp, rates)) => (
                    (ni.v - rates[a].0).scale_f(1.0 / hp),
                    (ni.w - rates[a].1).scale_f(1.0 / hp),
                ),
                None => (V3::zero(), V3::zero()),
            };
            let dx = nf.x - ni.x;
            let dx_pred = ni.v.scale_f(h) + acc.scale_f(0.5 * h * h);
            let r = crate::rotation::cayley_log(&ni.r.transpose().mul_m(&nf.r))
                .unwrap_or_else(|_| V3([f64::INFINITY; 3]));
            let r_pred = ni.w.scale_f(h) + alpha.scale_f(0.5 * h * h);
            worst = worst
                .max((dx - dx_pred).norm() / self.system.length_ref)
                .max((r - r_pred).norm());
        }
        worst / self.settings.tolerance
    }

    /// One adaptive step: tried with the proposed size, rejected and retried smaller while its
    /// error indicator exceeds 1 or Newton fails; the next size follows the indicator
    /// (`h·min(grow, max(shrink, 0.9 e^(−1/3)))`, DESIGN 8.6).
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
        loop {
            self.follow_contacts();
            match self.integrator.step(&self.system, &self.state, h) {
                Ok((state, report)) => {
                    let e = self.local_error(&state, h);
                    let factor = if e > 0.0 {
                        (0.9 * e.powf(-1.0 / 3.0)).clamp(shrink, grow)
                    } else {
                        grow
                    };
                    if e <= 1.0 {
                        self.accept(state, report, h);
                        self.h_next = (h * factor).clamp(dt_min, dt_max);
                        return Ok(());
                    }
                    self.stats.rejected += 1;
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
                    h = (0.25 * h).max(dt_min);
                }
                Err(e) => return Err(e),
            }
        }
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
