//! Stick–slip events of the joints' friction (`joints/friction.rs`). A step is taken with
//! each friction in the mode its start state holds; once converged, each friction judges it
//! ([`Friction::verdict`]): a sticking joint whose force exceeds μs N breaks away — at the
//! step's start, at its end, or, when the crossing of |F|/(μs N) through 1 (linear between
//! the last step's and this step's middles) lies inside, the step is shortened to end there;
//! a slipping joint whose slip rate vanishes inside the step is shortened to end at the stop
//! (regula falsi between the trials short of and past it), then sticks (or, where it cannot
//! stick, slides back). A step is never accepted with
//! a joint slipping against its assumed direction, so friction never adds energy. After an
//! event the step controller starts afresh: the motion's history before the event says
//! nothing about the motion after it.

use super::Simulation;
use crate::integrator::{StepFailure, StepReport};
use crate::joints::friction::{Mode, StickRatio, Verdict, MIN_EVENT_FRACTION};
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
        f.set_mode(state, mode, None);
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
    /// mode that changes at the step's start is written into the current state. A slip that
    /// stops inside the step is located by regula falsi on its rate between the trials
    /// that ended short of the stop and past it (see [`StopBracket`]).
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
        let asked = h;
        let mut h = h;
        let mut event = false;
        let floor = self.settings.dt_min().max(MIN_EVENT_FRACTION * h);
        let mut stop: Option<StopBracket> = None;
        let mut short_of_stop: Option<Trial> = None;
        for _ in 0..MAX_EVENT_RETRIES {
            self.orient_frictions(h);
            let (end, report) = self.integrator.step(&self.system, &self.state, h)?;
            match self.judge(&end, &report, h, floor) {
                Judged::Accept(next_modes) => {
                    let trial = Trial {
                        end,
                        report,
                        next_modes,
                        h,
                    };
                    let refined = stop.as_mut().and_then(|b| b.short_of_stop(self, &trial));
                    match refined {
                        Some(next_h) => {
                            short_of_stop = Some(trial);
                            h = next_h;
                        }
                        None => return Ok(self.accept_trial(trial, event)),
                    }
                }
                Judged::Switch(switches) => {
                    for (k, mode) in switches {
                        self.switch_at_start(k, mode);
                    }
                    event = true;
                    (stop, short_of_stop) = (None, None);
                    // The modes change at the start: the step asked for is taken in them, not
                    // the sliver that located a stop there (whose forces, over so short a
                    // step, are the start velocities' mismatch with the motion's over it).
                    h = asked;
                }
                Judged::Shorten(fraction, k) => {
                    let rate = self.stop_rate(k, &end);
                    h = match (rate, &mut stop) {
                        (Some(g), Some(b)) if b.friction == k => b.past_stop(h, g),
                        (Some(g), _) => {
                            stop = StopBracket::new(self, k, h, g);
                            (fraction * h).max(floor)
                        }
                        (None, _) => {
                            (stop, short_of_stop) = (None, None);
                            (fraction * h).max(floor)
                        }
                    }
                    .max(floor)
                    .min(h); // an event inside the step shortens it, never lengthens it
                }
            }
        }
        // A stop located to within what the retries allow: the step just short of it stands.
        if let Some(trial) = short_of_stop {
            return Ok(self.accept_trial(trial, event));
        }
        Err(StepFailure {
            t: self.state.t,
            h,
            reason: "friction: the joints' stick–slip modes did not settle within the step (a joint that can neither stick nor slide consistently); lower `dt_min` or check the friction coefficients".into(),
            retry: true,
            load_factor: None,
            row: None,
        })
    }

    /// A converged trial judged consistent: its frictions take their next modes, those that
    /// stopped settle at rest.
    fn accept_trial(&self, trial: Trial, event: bool) -> FrictionStep {
        let Trial {
            mut end,
            mut report,
            next_modes,
            h,
        } = trial;
        let mut changed = false;
        for (f, (next, ratio)) in self.system.frictions.iter().zip(next_modes) {
            changed |= next != f.mode(&self.state);
            f.set_mode(&mut end, next, ratio);
        }
        self.settle_stops(&mut end, &mut report);
        FrictionStep {
            state: end,
            report,
            h,
            event: event || changed,
        }
    }

    /// Friction `k`'s slip rate towards its slipping direction at `end` (m/s), if it slips
    /// from this step's start.
    fn stop_rate(&self, k: usize, end: &State) -> Option<f64> {
        let f = &self.system.frictions[k];
        match f.mode(&self.state) {
            Mode::Slip { direction } if direction != 0.0 => Some(direction * f.slip_at(end).1),
            _ => None,
        }
    }

    /// The frictions' verdicts on a converged step, combined: any switch at the start wins
    /// (redo the step), then the earliest event inside it, else the step stands.
    fn judge(&self, end: &State, report: &StepReport, h: f64, floor: f64) -> Judged {
        let mut switches = Vec::new();
        let mut shortest: Option<(f64, usize)> = None;
        let mut next_modes = Vec::with_capacity(self.system.frictions.len());
        for (k, f) in self.system.frictions.iter().enumerate() {
            match f.verdict(&self.state, end, &report.frictions[k], h) {
                Verdict::Holds { next, ratio } => next_modes.push((next, ratio)),
                Verdict::Switch(mode) => switches.push((k, mode)),
                // An event the shortest step allowed cannot place is taken at the start.
                Verdict::Shorten(_) if h <= floor * (1.0 + 1e-9) => {
                    switches.push((k, f.after_event(&self.state, &report.frictions[k])));
                }
                Verdict::Shorten(x) => {
                    if shortest.is_none_or(|(s, _)| x < s) {
                        shortest = Some((x, k));
                    }
                }
            }
        }
        if !switches.is_empty() {
            Judged::Switch(switches)
        } else if let Some((x, k)) = shortest {
            Judged::Shorten(x, k)
        } else {
            Judged::Accept(next_modes)
        }
    }
}

impl Simulation {
    /// Friction `k` takes `mode` from the present state on. A slip that stops there sticks
    /// from rest, as one whose stop ends a step does ([`Self::settle_stops`]): the state's
    /// velocities are projected onto its stick row and the kinetic energy that takes is
    /// booked at once as its work. Left with its residual slip rate, the stick step must stop
    /// it within the step: with the shortest step allowed that takes a stick force of that
    /// momentum over `dt_min`, hundreds of times μs N, and the joint breaks away again the
    /// way it was slipping, step after step (EP's end velocities carry the midpoint rule's
    /// ripple, so a slip under EP can end a step still moving while stopped in the mean).
    fn switch_at_start(&mut self, k: usize, mode: Mode) {
        self.state_changed_between_steps();
        let sys = &self.system;
        let f = &sys.frictions[k];
        let stops =
            matches!(f.mode(&self.state), Mode::Slip { .. }) && matches!(mode, Mode::Stick { .. });
        f.set_mode(&mut self.state, mode, None);
        if !stops {
            return;
        }
        let before = sys.kinetic_energy(&self.state);
        if project_onto_stick(sys, &mut self.state, f.row) {
            let work = sys.kinetic_energy(&self.state) - before;
            self.totals.friction_work += work;
            self.totals.per_friction_work[k] += work;
        }
    }

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
    Accept(Vec<(Mode, Option<StickRatio>)>),
    Switch(Vec<(usize, Mode)>),
    /// The earliest event, at this fraction of the step, is friction `.1`'s.
    Shorten(f64, usize),
}

/// A converged trial step and each friction's mode after it.
struct Trial {
    end: State,
    report: StepReport,
    next_modes: Vec<(Mode, Option<StickRatio>)>,
    h: f64,
}

/// A slipping friction's stop bracketed between the longest trial that ended short of it
/// (`lo`, at first the step's start) and the shortest that ended past it (`hi`): step
/// lengths (s) and slip rates towards the slip (m/s) at their ends. The next trial ends where
/// the rate, linear between them, vanishes (regula falsi, Illinois-modified: an end kept
/// twice has its rate halved, so the bracket closes from both sides). A stop placed from the
/// start alone leaves each next step a fixed fraction of its rate when the deceleration
/// grows inside the step (a normal force rising): without the bracket the stop is never
/// reached.
struct StopBracket {
    friction: usize,
    lo: (f64, f64),
    hi: (f64, f64),
    /// Which end moved last (−1 lo, +1 hi), for the Illinois modification.
    moved: i8,
}

impl StopBracket {
    fn new(sim: &Simulation, k: usize, h: f64, rate: f64) -> Option<Self> {
        let f = &sim.system.frictions[k];
        let Mode::Slip { direction } = f.mode(&sim.state) else {
            return None;
        };
        let start = direction * f.slip_at(&sim.state).1;
        (start > 0.0 && rate < 0.0).then_some(StopBracket {
            friction: k,
            lo: (0.0, start),
            hi: (h, rate),
            moved: 1,
        })
    }

    /// Where the rate, linear between the bracket's ends, vanishes.
    fn next(&self) -> f64 {
        let ((a, ga), (b, gb)) = (self.lo, self.hi);
        a + (b - a) * ga / (ga - gb)
    }

    /// A trial of `h` that ended past the stop, at rate `rate` (< 0): the next trial.
    fn past_stop(&mut self, h: f64, rate: f64) -> f64 {
        if self.moved == 1 {
            self.lo.1 *= 0.5;
        }
        self.hi = (h, rate.min(0.0));
        self.moved = 1;
        self.next()
    }

    /// A trial judged consistent: if it ended short of the stop with its friction still
    /// slipping, the next trial (None: the trial stands).
    fn short_of_stop(&mut self, sim: &Simulation, trial: &Trial) -> Option<f64> {
        let k = self.friction;
        let still = trial.next_modes[k].0 == sim.system.frictions[k].mode(&sim.state);
        let rate = sim.stop_rate(k, &trial.end)?;
        if !still {
            return None;
        }
        self.short(trial.h, rate)
    }

    /// A trial of `h` that ended at rate `rate`: if short of the stop (rate > 0), the next
    /// trial, unless the bracket closed to a sliver.
    fn short(&mut self, h: f64, rate: f64) -> Option<f64> {
        if rate <= 0.0 || h >= self.hi.0 {
            return None;
        }
        if self.moved == -1 {
            self.hi.1 *= 0.5;
        }
        self.lo = (h, rate);
        self.moved = -1;
        let next = self.next();
        // Closed to a sliver: no trial would tell more.
        (next - h > MIN_EVENT_FRACTION * self.hi.0).then_some(next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A slip rate whose deceleration grows inside the step (a normal force rising), as
    /// on a ringing beam: v(h) = v₀ − a h − b h². Placing the stop from the start alone
    /// (a secant through (0, v₀)) leaves each next step the same fraction of its rate; the
    /// bracket closes on the stop within the retries a step allows, with every trial
    /// inside the bracket.
    #[test]
    fn the_bracket_closes_on_a_stop_whose_deceleration_grows() {
        let (v0, a, b) = (1e-6, 0.02, 3e4);
        let rate = |h: f64| v0 - a * h - b * h * h;
        let stop = (-a + (a * a + 4.0 * b * v0).sqrt()) / (2.0 * b);
        let h0 = 1.1e-5;
        let mut bracket = StopBracket {
            friction: 0,
            lo: (0.0, v0),
            hi: (h0, rate(h0)),
            moved: 1,
        };
        let mut h = bracket.next();
        let mut trials = 1;
        // Stopped: the trial's end rate within 10 % of the start's (the verdict's rule).
        while rate(h).abs() > 0.1 * v0 {
            assert!(
                bracket.lo.0 < h && h < bracket.hi.0,
                "{h} outside the bracket"
            );
            let g = rate(h);
            h = if g > 0.0 {
                bracket.short(h, g).expect("the bracket is far from closed")
            } else {
                bracket.past_stop(h, g)
            };
            trials += 1;
            assert!(trials < MAX_EVENT_RETRIES, "not located in {trials} trials");
        }
        assert!((h - stop).abs() < 0.1 * stop, "{h} vs the stop at {stop}");
        // The secant from the start alone stalls: each step keeps ~40 % of its rate.
        let from_start = v0 / (v0 - rate(h0)) * h0;
        assert!(rate(from_start) > 0.3 * v0);
    }
}
