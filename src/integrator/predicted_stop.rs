//! Stopping modified Newton one assembly early where its forces contract steadily and only
//! the constraints lag — ED's velocity-level rows of a sliding contact: on the free collar
//! the forces balance after three updates while the j-conditions are still four tolerances
//! off, and the fourth update's full assembly only confirmed them.
//!
//! With kept factors Newton contracts linearly. Where the last two updates, both made with
//! the factors kept now, each left at most `THETA_MAX` (¼) of the force residual before
//! them, the next update is predicted to leave θ times the present one, θ the slower of the
//! two (Hairer & Wanner II, IV.8, on residuals). If that is within `PREDICTED_MAX` (3 %) of
//! the tolerance, and the constraints are predicted by their own rate to hold, the update
//! is taken and then only the constraint rows are evaluated, by the kernels that own them
//! (joints and drives: a small part of an assembly in a model with beams). The step has
//! converged if they hold; otherwise Newton goes on with a full assembly.
//!
//! So the constraints are verified at the end of the step. The forces are trusted to one
//! update past an iterate whose forces contracted steadily, as they already are by the
//! back-substitution after every convergence on kept factors. The constraint rows are
//! checked rather than predicted because their contraction is not steady. In the examples
//! (2 s at 1 ms, fixed and adaptive), a prediction on both rows left the heavy top's pivot
//! outside its tolerance after thousands of predicted updates. The forces never were: each
//! such update was checked by a full assembly, and none left the forces outside their
//! tolerance or round-off floor.

use super::convergence::Measure;
use super::Integrator;
use crate::elements::{Kernel, StepCtx};
use crate::system::System;

/// The slowest contraction per update a prediction trusts.
const THETA_MAX: f64 = 0.25;
/// The largest predicted force residual, in units of its tolerance, that stops Newton.
const PREDICTED_MAX: f64 = 0.03;

/// A solve's last two iterates: their force residuals and constraint violations, in units
/// of their tolerances, and whether the update after each kept the factors.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ForceTrend {
    last: [Iterate; 2],
    seen: usize,
}

#[derive(Clone, Copy, Debug, Default)]
struct Iterate {
    force: f64,
    constraint: f64,
    kept: bool,
}

impl ForceTrend {
    /// Records an iterate's force residual and constraint violation (units of their
    /// tolerances) and whether its update keeps the factors; returns the force residual that
    /// update is predicted to leave, if it is small enough to stop on and the constraints are
    /// predicted to hold (so that checking them is not wasted: a failed check costs the
    /// joints' evaluation on top of the assembly it was to save).
    pub(super) fn record(&mut self, force: f64, constraint: f64, kept: bool) -> Option<f64> {
        let [before_last, last] = self.last;
        self.last = [
            last,
            Iterate {
                force,
                constraint,
                kept,
            },
        ];
        self.seen += 1;
        // Both ratios come from updates with the factors kept now only if the last update
        // kept them too.
        if !(kept && last.kept && self.seen >= 3) {
            return None;
        }
        let rate = |now: f64, last: f64, before: f64| (now / last).max(last / before);
        let theta = rate(force, last.force, before_last.force);
        let predicted = force * theta;
        let constraints = if constraint <= 1.0 {
            constraint
        } else {
            constraint * rate(constraint, last.constraint, before_last.constraint)
        };
        (theta <= THETA_MAX && predicted <= PREDICTED_MAX && constraints <= 1.0)
            .then_some(predicted)
    }
}

/// Whether stopping on a prediction can pay in `sys`: its beam elements make a full
/// assembly dear next to the joints' and drives' rows alone (in a model of rigid bodies the
/// check costs about what it saves, and the heavy top ran 2–4 % slower with it). Frictions'
/// rows switch between forces and constraints, so a model with them is never judged this
/// way.
pub(super) fn pays(sys: &System) -> bool {
    !sys.beams.is_empty() && sys.frictions.is_empty()
}

impl Integrator {
    /// After an update predicted to balance the forces: the constraint rows' violation over
    /// its tolerance (judged against `full`, the last fully assembled iterate's scales) if
    /// they hold, None if not.
    pub(super) fn constraints_hold_after_update(
        &mut self,
        sys: &System,
        ctx: &StepCtx,
        full: &Measure,
    ) -> Option<f64> {
        let started = self.timings.start();
        self.res.fill(0.0);
        self.activity.fill(0.0);
        let (y, res, activity) = (&self.y, &mut self.res, &mut self.activity);
        for k in &sys.joints {
            Kernel::residual_with_activity(k, ctx, y, res, activity);
        }
        for k in &sys.drives {
            Kernel::residual_with_activity(k, ctx, y, res, activity);
        }
        self.constraint_checks += 1;
        self.timings.add(super::timings::Phase::Residuals, started);
        // The constraint rows of this residual, judged against the full iterate's scales.
        let mut m = Measure::with_floor(sys, ctx, &self.res, &self.activity, full.force_floor);
        (m.force_scale, m.constraint_scale) = (full.force_scale, full.constraint_scale);
        m.constraints_hold(sys, self.tol, None)
            .then(|| m.constraint_ratio(sys, self.tol))
    }
}

#[cfg(test)]
mod tests {
    use super::ForceTrend;
    use crate::compile::from_yaml_str;
    use crate::integrator::convergence::Measure;
    use crate::integrator::Integrator;
    use crate::joints::Joint;
    use crate::model::{Scheme, StepControl};
    use crate::simulation::Simulation;

    /// Every step stopped on a prediction, assembled in full at its end, has its forces
    /// within the tolerance (or at their round-off floor) and its constraints held: the
    /// check that decided the constants, kept as a test over a beam, a free sliding contact
    /// and the paper's beam slider under both schemes. On the free collar under ED, the case
    /// the stop was made for, a good part of the steps end that way.
    #[test]
    fn a_step_stopped_on_a_prediction_ends_balanced_and_held() {
        for name in ["beam_pendulum", "free_collar", "beam_slider/case1"] {
            let path = format!("{}/examples/{name}.yaml", env!("CARGO_MANIFEST_DIR"));
            let mut model = from_yaml_str(&std::fs::read_to_string(path).unwrap()).unwrap();
            model.simulation.step_control = StepControl::Fixed;
            for scheme in [Scheme::Ep, Scheme::Ed] {
                let sim = Simulation::with_scheme(&model, scheme).unwrap();
                let (mut sys, mut state, h) = (sim.system.clone(), sim.state.clone(), 1e-3);
                let mut integ = Integrator::new(&sys, &sim.settings);
                for _ in 0..400 {
                    // The sliding windows follow the contacts, as the run loop has them do.
                    let mut moved = false;
                    for j in &mut sys.joints {
                        if let Joint::Sliding(s) = j {
                            moved |= s.place_window(state.coords[s.coord]);
                        }
                    }
                    if moved {
                        integ.rebuild_pattern(&sys, h);
                    }
                    let sys = &sys;
                    let before = integ.predicted_stops;
                    let (end, _) = integ.step(sys, &state, h).unwrap();
                    if integ.predicted_stops > before {
                        let ctx = Integrator::step_ctx(sys, &state, h);
                        integ.assemble(sys, &ctx, false);
                        let m = Measure::of(sys, &ctx, &integ.res, &integ.activity);
                        let at_floor = m.force <= m.force_floor;
                        assert!(
                            m.constraints_hold(sys, integ.tol, None)
                                && (m.forces_balance(integ.tol, None) || at_floor),
                            "{name} {scheme:?} at t = {}: {}",
                            state.t,
                            m.describe(sys, integ.tol)
                        );
                    }
                    state = end;
                }
                if name == "free_collar" && scheme == Scheme::Ed {
                    // Measured 177 of the 400.
                    assert!(integ.predicted_stops > 100, "{}", integ.predicted_stops);
                }
            }
        }
    }

    #[test]
    fn a_stop_is_predicted_only_from_two_steady_contractions_with_the_kept_factors() {
        // 1e4 → 40 → 0.16: θ = 4e-3, the next update predicted to leave 6.4e-4.
        let mut trend = ForceTrend::default();
        assert_eq!(trend.record(1e4, 0.0, true), None);
        assert_eq!(trend.record(40.0, 0.0, true), None);
        let predicted = trend.record(0.16, 0.0, true).unwrap();
        assert!((predicted - 0.16 * 4e-3).abs() < 1e-12);
        // The slower of the two contractions counts: 1e4 → 100 (θ 1e-2) → 0.9 (θ 9e-3).
        let mut trend = ForceTrend::default();
        trend.record(1e4, 0.0, true);
        trend.record(100.0, 0.0, true);
        assert!((trend.record(0.9, 0.0, true).unwrap() - 0.9 * 1e-2).abs() < 1e-12);
        // Too far from balanced for the rate: 1e4 → 1e3 → 100 leaves a predicted 10.
        let mut trend = ForceTrend::default();
        trend.record(1e4, 0.0, true);
        trend.record(1e3, 0.0, true);
        assert_eq!(trend.record(100.0, 0.0, true), None);
        // A contraction slower than θ_max, however small the residual.
        let mut trend = ForceTrend::default();
        trend.record(1e-1, 0.0, true);
        trend.record(3e-2, 0.0, true);
        assert_eq!(trend.record(1e-2, 0.0, true), None);
    }

    /// A fresh trend's prediction at the last of `iterates` (force ratio, constraint ratio,
    /// whether the update from it keeps the factors).
    fn prediction(iterates: &[(f64, f64, bool)]) -> Option<f64> {
        let mut trend = ForceTrend::default();
        iterates
            .iter()
            .map(|&(f, c, kept)| trend.record(f, c, kept))
            .last()
            .flatten()
    }

    #[test]
    fn constraints_predicted_not_to_hold_are_not_checked() {
        // Forces steady (1e4 → 40 → 0.16) with the constraints at 2e5 → 99 → 3.8 tolerances:
        // θ_C = 0.038 predicts 0.15, held — checked. At 2e5 → 2e4 → 2e3 (θ_C = 0.1) they
        // would be left at 200: not checked.
        assert!(prediction(&[(1e4, 2e5, true), (40.0, 99.0, true), (0.16, 3.8, true)]).is_some());
        assert_eq!(
            prediction(&[(1e4, 2e5, true), (40.0, 2e4, true), (0.16, 2e3, true)]),
            None
        );
        // Constraints holding already need no rate.
        assert!(prediction(&[(1e4, 5.0, true), (40.0, 9.0, true), (0.16, 0.5, true)]).is_some());
    }

    #[test]
    fn fresh_factors_restart_the_trend() {
        // The update after the second iterate factored afresh (not kept): the first ratio
        // belongs to other factors, so the third iterate predicts nothing; the fourth does.
        let mut trend = ForceTrend::default();
        trend.record(1e4, 0.0, true);
        trend.record(40.0, 0.0, false);
        assert_eq!(trend.record(0.16, 0.0, true), None);
        assert!(trend.record(6e-4, 0.0, true).is_some());
        // An update that will factor afresh is not predicted from.
        assert_eq!(
            prediction(&[(1e4, 0.0, true), (40.0, 0.0, true), (0.16, 0.0, false)]),
            None
        );
        // NaN or zero residuals predict nothing.
        assert_eq!(
            prediction(&[(0.0, 0.0, true), (0.0, 0.0, true), (0.0, 0.0, true)]),
            None
        );
    }
}
