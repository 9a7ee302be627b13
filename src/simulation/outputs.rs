//! Samples: sensor channels at the requested output times — on states interpolated within
//! the step to the scheme's order — with the multiplier channels (step averages)
//! interpolated between mid-steps, and at the run's first and last instants solved there.

use super::Simulation;
use crate::integrator::dense_output::state_between;
use crate::integrator::StepReport;
use crate::state::State;
use crate::system::energy_memo::EnergyMemo;
use crate::system::System;

impl Simulation {
    /// Records a sample at the current time (the start of a run). Its state channels are
    /// final; its step channels (multipliers) wait in `pending` for the step after it.
    pub(super) fn record(&mut self) {
        let row = self.sample_channels();
        self.last_row = Some(row.clone());
        self.emit(self.state.t, row);
    }

    /// Every channel at the current state (step channels as placeholders).
    pub(super) fn sample_channels(&self) -> Vec<f64> {
        let mut row = Vec::with_capacity(self.channels.len());
        let (sys, state, totals) = (&self.system, &self.state, &self.totals);
        self.channels
            .sample(sys, state, totals, &self.energy_memo, &mut row);
        row
    }

    /// The next requested output time, with `output_dt`.
    fn next_output_time(&self) -> Option<f64> {
        let out = self.settings.output_dt?;
        Some((self.output_index as f64 * out).min(self.settings.t_end))
    }

    /// With `output_dt`, the channels are sampled at a step's end only if an output time
    /// falls in the step (sensors and fields cost ~7–10 % of a short-step run), so the next
    /// step may start without them. A step that has an output time strictly inside it
    /// interpolates its step-end channels from its start: sampled here if they were not (or
    /// no longer describe it), on the start state with the totals before the step's books —
    /// called before them.
    pub(super) fn sample_start_for_outputs(&mut self, t_f: f64) {
        let t_i = self.state.t;
        let slack = 1e-9 * (t_f - t_i).max(1e-300);
        let inside = self.next_output_time().is_some_and(|t_o| t_o < t_f - slack);
        if inside && self.last_row.is_none() {
            self.last_row = Some(self.sample_channels());
        }
    }

    /// The state changed between steps (a friction's mode set at a step's start and its
    /// stop's projection, with their work booked; a state set for linearization): the last
    /// step's end sample no longer describes the next step's start.
    pub(super) fn state_changed_between_steps(&mut self) {
        self.last_row = None;
    }

    /// After a step from `start` to the current state: records every requested output time
    /// in (t_i, t_f] — on the state interpolated to the scheme's order (`dense_output`), so
    /// outputs land on the requested times whatever the steps were, as accurate as the step
    /// ends — or the step's end when every step is recorded.
    pub(super) fn record_outputs(&mut self, start: &State) {
        let (t_i, t_f) = (start.t, self.state.t);
        let slack = 1e-9 * (t_f - t_i).max(1e-300);
        if self.next_output_time().is_some_and(|t_o| t_o > t_f + slack) {
            self.last_row = None;
            return;
        }
        let row_f = self.sample_channels();
        let row_i = self.last_row.take().unwrap_or_default();
        match self.settings.output_dt {
            None => self.emit(t_f, row_f.clone()),
            Some(out) => {
                let t_end = self.settings.t_end;
                loop {
                    let t_o = (self.output_index as f64 * out).min(t_end);
                    if t_o > t_f + slack {
                        break;
                    }
                    let row = if t_o >= t_f - slack {
                        row_f.clone()
                    } else if t_o <= t_i + slack {
                        row_i.clone()
                    } else {
                        self.row_between(start, &row_i, &row_f, t_o)
                    };
                    self.emit(t_o, row);
                    if t_o >= t_end {
                        self.output_index = u64::MAX / 2;
                        break;
                    }
                    self.output_index += 1;
                }
            }
        }
        self.last_row = Some(row_f);
    }

    /// The channels at time `t` inside the step from `start` (channels `row_i`) to the
    /// current state (`row_f`): sensors on the interpolated state, bookkeeping channels
    /// (energies, works, violations: exact at step ends) linear between the ends.
    fn row_between(&self, start: &State, row_i: &[f64], row_f: &[f64], t: f64) -> Vec<f64> {
        let mid = state_between(&self.system, start, &self.state, t);
        let mut row = Vec::with_capacity(self.channels.len());
        self.channels
            // Not the run's memo: it keeps the step's end for the next step's start.
            .sample(
                &self.system,
                &mid,
                &self.totals,
                &EnergyMemo::default(),
                &mut row,
            );
        let w = (t - start.t) / (self.state.t - start.t);
        for &c in &self.step_end_channels {
            row[c] = row_i[c] + (row_f[c] - row_i[c]) * w;
        }
        row
    }

    /// Adds a sample; its step channels are completed when the steps around it are known.
    pub(super) fn emit(&mut self, t: f64, row: Vec<f64>) {
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
    pub(super) fn finalize_pending(&mut self, flush: bool) {
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

    /// The step channels at the current instant, from the consistent solution of the
    /// equations of motion there: a step of vanishing length (1e-3 of the step size, from a
    /// fresh integrator so the run's own factors are untouched, from the state with its
    /// positions and velocities projected onto the constraints), whose step-average
    /// accelerations and multipliers are the instant's to O(1e-3 of a step's change). Samples between this
    /// instant and the nearest mid-step interpolate from it, instead of extrapolating the
    /// mid-steps. Nothing when that step fails (e.g. a drive undefined past the end): the
    /// samples then extrapolate as before.
    pub(super) fn push_instant_values(&mut self) {
        if self.channels.step_channels().is_empty() {
            return;
        }
        let step = self.h_next.min(self.settings.dt_max());
        let h = instant_step(&self.system, &self.state, step);
        let mut integrator = self.integrator.sibling(&self.system, &self.settings);
        // A step's end velocities meet the velocity constraints only to the scheme's
        // accuracy; over so short a step the difference would take an impulse.
        let mut instant = self.state.clone();
        super::initial_velocities::project_positions(&self.system, &mut instant);
        super::initial_velocities::project_velocities(&self.system, &mut instant);
        if let Ok((_, report)) = integrator.step(&self.system, &instant, h) {
            self.push_step_values(self.state.t, &report);
        }
    }

    /// Keeps the step values of the last two steps (time of each: its mid-step).
    pub(super) fn push_step_values(&mut self, t_mid: f64, report: &StepReport) {
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
}

/// The length of a step that solves for an instant's accelerations and forces: short against
/// a step of `step` (1e-3 of it), but long enough that the motion over it, ~½ a h², stands 1e4
/// above the round-off of positions ~ε L (a from gravity and the speeds) — up to a whole step,
/// so that the round-off floor wins over shortness for fine steps. (A four-bar at 1 µs steps
/// took 1e-7 s instants, whose motion stood only ~250× above round-off: forces off by 0.3 %.)
pub(super) fn instant_step(system: &System, state: &State, step: f64) -> f64 {
    let l = system.length_ref;
    let speed = state
        .nodes
        .iter()
        .fold(0.0f64, |m, n| m.max(n.v.norm() + n.omega().norm() * l));
    let accel = system.gravity.norm().max(speed * speed / l);
    let floor = if accel > 0.0 {
        (1e4 * f64::EPSILON * l / accel).sqrt()
    } else {
        0.0
    };
    (1e-3 * step).max(floor.min(step))
}
