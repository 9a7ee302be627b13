//! Stick–slip events of the joints' friction (`joints/friction.rs`). A step is taken with
//! each friction in the mode its start state holds; once converged, each friction judges it
//! ([`Friction::verdict`]): a sticking joint whose force exceeds μs N breaks away — at the
//! step's start, at its end, or, when the crossing of |F|/(μs N) through 1 (linear from the
//! last step's ratio) lies inside, the step is shortened to end there; a slipping joint whose
//! slip rate vanishes inside the step (linear between its ends) is shortened to end at the
//! stop, then sticks (or, where it cannot stick, slides back). A step is never accepted with
//! a joint slipping against its assumed direction, so friction never adds energy. After an
//! event the step controller starts afresh: the motion's history before the event says
//! nothing about the motion after it.

use super::Simulation;
use crate::integrator::{StepFailure, StepReport};
use crate::joints::friction::{Mode, Verdict, MIN_EVENT_FRACTION};
use crate::joints::Joint;
use crate::state::State;
use crate::system::System;

/// Most retries of one step for friction events (each locates an event more closely or
/// switches a mode; a handful suffice).
const MAX_EVENT_RETRIES: usize = 12;

/// A step taken with its frictions' modes checked.
pub(super) struct FrictionStep {
    pub state: State,
    pub report: StepReport,
    /// The step size taken (shorter than asked when it ends at an event).
    pub h: f64,
    /// Whether a friction changed its mode at the step's start or end.
    pub event: bool,
}

/// At the start of a run: which frictions can stick (not those whose slip the drives or the
/// mechanism prescribe: a stick row would over-constrain them), and each one's initial mode.
pub(super) fn start_frictions(system: &mut System, state: &mut State) {
    for k in 0..system.frictions.len() {
        let free = crate::system::redundancy::can_stick(system, state, k);
        system.frictions[k].can_stick = free;
    }
    for f in &system.frictions {
        let mode = f.initial_mode(state);
        f.set_mode(state, mode, -1.0);
    }
}

/// A static analysis leaves friction out: the warning that says whose.
pub(super) fn static_friction_warning(system: &System, statics: bool) -> Option<String> {
    if !statics || system.frictions.is_empty() {
        return None;
    }
    let names: Vec<String> = system
        .frictions
        .iter()
        .map(|f| format!("`{}`", f.joint))
        .collect();
    Some(format!("the friction of {} is left out of this static analysis (and of modes): an equilibrium with friction is not unique", names.join(", ")))
}

impl Simulation {
    /// Sliding joints' frictions take the beam's axis at the contact point predicted at the
    /// middle of a step of `h`: their normal force is the (step-mean) contact force normal to
    /// it. (The start's axis would leak the friction force into the normal force by the
    /// angle the beam turns in half a step: a first-order error.)
    fn orient_frictions(&mut self, h: f64) {
        let sys = &mut self.system;
        for f in &mut sys.frictions {
            if let Joint::Sliding(sl) = &sys.joints[f.kernel] {
                f.set_axis(sl.mid_step_axis(&self.state, h));
            }
        }
    }

    /// A step of (at most) `h` from the current state with its frictions' modes checked; a
    /// mode that changes at the step's start is written into the current state.
    pub(super) fn step_with_friction(&mut self, h: f64) -> Result<FrictionStep, StepFailure> {
        if self.system.frictions.is_empty() {
            let (state, report) = self.integrator.step(&self.system, &self.state, h)?;
            return Ok(FrictionStep {
                state,
                report,
                h,
                event: false,
            });
        }
        let mut h = h;
        let mut event = false;
        let floor = self.settings.dt_min().max(MIN_EVENT_FRACTION * h);
        for _ in 0..MAX_EVENT_RETRIES {
            self.orient_frictions(h);
            let (mut end, mut report) = self.integrator.step(&self.system, &self.state, h)?;
            match self.judge(&end, &report, h, floor) {
                Judged::Accept(next_modes) => {
                    let mut changed = false;
                    for (f, (next, ratio)) in self.system.frictions.iter().zip(next_modes) {
                        changed |= next != f.mode(&self.state);
                        f.set_mode(&mut end, next, ratio);
                    }
                    self.settle_stops(&mut end, &mut report);
                    return Ok(FrictionStep {
                        state: end,
                        report,
                        h,
                        event: event || changed,
                    });
                }
                Judged::Switch(switches) => {
                    for (k, mode) in switches {
                        let f = &self.system.frictions[k];
                        f.set_mode(&mut self.state, mode, -1.0);
                    }
                    event = true;
                }
                Judged::Shorten(fraction) => h = (fraction * h).max(floor),
            }
        }
        Err(StepFailure {
            t: self.state.t,
            h,
            reason: "friction: the joints' stick–slip modes did not settle within the step (a joint that can neither stick nor slide consistently); lower `dt_min` or check the friction coefficients".into(),
            retry: true,
            load_factor: None,
        })
    }

    /// The frictions' verdicts on a converged step, combined: any switch at the start wins
    /// (redo the step), then the earliest event inside it, else the step stands.
    fn judge(&self, end: &State, report: &StepReport, h: f64, floor: f64) -> Judged {
        let mut switches = Vec::new();
        let mut shortest: Option<f64> = None;
        let mut next_modes = Vec::with_capacity(self.system.frictions.len());
        for (k, f) in self.system.frictions.iter().enumerate() {
            match f.verdict(&self.state, end, &report.frictions[k]) {
                Verdict::Holds { next, ratio } => next_modes.push((next, ratio)),
                Verdict::Switch(mode) => switches.push((k, mode)),
                // An event the shortest step allowed cannot place is taken at the start.
                Verdict::Shorten(_) if h <= floor * (1.0 + 1e-9) => {
                    switches.push((k, f.after_event(&self.state, &report.frictions[k])));
                }
                Verdict::Shorten(x) => shortest = Some(shortest.map_or(x, |s: f64| s.min(x))),
            }
        }
        if !switches.is_empty() {
            Judged::Switch(switches)
        } else if let Some(x) = shortest {
            Judged::Shorten(x)
        } else {
            Judged::Accept(next_modes)
        }
    }
}

impl Simulation {
    /// Joints that stopped sliding at the end of this step stick from rest: the end
    /// velocities are projected (kinetic-energy weights) onto the stick row, every other row
    /// keeping its velocity residual. What that takes out — the residual slip rate of a stop
    /// located to a fraction of the step — is the stop's impulse, friction's work.
    fn settle_stops(&self, end: &mut State, report: &mut StepReport) {
        let sys = &self.system;
        for (k, f) in sys.frictions.iter().enumerate() {
            let stopped = matches!(f.mode(&self.state), Mode::Slip { .. })
                && matches!(f.mode(end), Mode::Stick { .. });
            if !stopped {
                continue;
            }
            let before = sys.kinetic_energy(end);
            if !project_onto_stick(sys, end, f.row) {
                continue;
            }
            let work = sys.kinetic_energy(end) - before;
            report.frictions[k].work += work;
            report.friction_work += work;
        }
    }
}

/// Projects `state`'s velocities so that friction row `row` holds (its slip rate zero), the
/// other rows keeping their present values; false if the projection is singular.
fn project_onto_stick(sys: &System, state: &mut State, row: usize) -> bool {
    super::initial_velocities::project_velocities_with(sys, state, |p, state, rhs| {
        for (r, v) in p.rows_at(state).into_iter().enumerate() {
            rhs[p.lay.mult(r)] = if r == row { 0.0 } else { v };
        }
    })
}

enum Judged {
    /// Each friction's mode for the next step, and its force ratio.
    Accept(Vec<(Mode, f64)>),
    Switch(Vec<(usize, Mode)>),
    Shorten(f64),
}
