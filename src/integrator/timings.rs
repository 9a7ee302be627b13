//! Where a run's wall time goes, phase by phase of its steps (`simulation.timings: true`,
//! `flexdyn run --timings`): how a slow model is made faster depends on which phase holds
//! its time — residuals (a coarser mesh), factorizations (modified Newton, fewer pattern
//! changes), outputs (a longer `output_dt`).
//!
//! Measured only when asked: a clock read costs ~20 ns and a step takes a few dozen — 3 %
//! of a four-bar linkage's steps, nothing measurable on a beam's. Each phase is timed at the one function that does its work,
//! and no timed function calls another, so no time is counted twice; what no phase holds (step
//! control, friction events, moving contact windows, bookkeeping) is the total's remainder,
//! [`Timings::other`].

use std::time::Instant;

/// A phase of a run's steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// The starting guess of each step's Newton iteration.
    Predictor,
    /// Assemblies of the Newton equations' residual alone (and constraint-only checks).
    Residuals,
    /// Assemblies of the residual with the Newton matrix, for fresh factors.
    Tangents,
    /// LU factorizations of the Newton matrix (numeric, and symbolic for a new pattern).
    Factorizations,
    /// Back-substitutions with the factors in hand, and the updates they give.
    Solves,
    /// Kept factors' sliding-contact rows and columns refreshed at a step's start.
    ContactBorders,
    /// A converged step's end: element histories, energy books of the integrator.
    StepEnds,
    /// Newton-matrix patterns rebuilt because a sliding contact's window moved.
    Patterns,
    /// Accepted steps' books and outputs: energies, totals, sensors, recorded samples.
    Outputs,
}

impl Phase {
    pub const ALL: [Phase; 9] = [
        Phase::Predictor,
        Phase::Residuals,
        Phase::Tangents,
        Phase::Factorizations,
        Phase::Solves,
        Phase::ContactBorders,
        Phase::StepEnds,
        Phase::Patterns,
        Phase::Outputs,
    ];

    /// The phase's name in run statistics (`time_<name>_s`) and reports.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Predictor => "predictor",
            Phase::Residuals => "residuals",
            Phase::Tangents => "tangents",
            Phase::Factorizations => "factorizations",
            Phase::Solves => "solves",
            Phase::ContactBorders => "contact_borders",
            Phase::StepEnds => "step_ends",
            Phase::Patterns => "patterns",
            Phase::Outputs => "outputs",
        }
    }
}

/// Wall time per phase and in all (s), accumulated over a run if enabled.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Timings {
    enabled: bool,
    seconds: [f64; Phase::ALL.len()],
    total: f64,
}

impl Timings {
    pub fn new(enabled: bool) -> Self {
        Timings {
            enabled,
            ..Timings::default()
        }
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// A clock reading to time a phase from, if timing.
    #[inline]
    pub fn start(&self) -> Option<Instant> {
        self.enabled.then(Instant::now)
    }

    /// Adds the time since `start` (from [`Self::start`]) to `phase`.
    #[inline]
    pub fn add(&mut self, phase: Phase, start: Option<Instant>) {
        if let Some(t) = start {
            self.seconds[phase as usize] += t.elapsed().as_secs_f64();
        }
    }

    /// Adds the time since `start` to the run's total (time spent advancing the run).
    #[inline]
    pub fn add_total(&mut self, start: Option<Instant>) {
        if let Some(t) = start {
            self.total += t.elapsed().as_secs_f64();
        }
    }

    /// Seconds spent in `phase`.
    pub fn seconds(&self, phase: Phase) -> f64 {
        self.seconds[phase as usize]
    }

    /// Seconds spent advancing the run (every phase, and the rest).
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Seconds of the total in no phase: step control, friction events, moving contact
    /// windows, bookkeeping.
    pub fn other(&self) -> f64 {
        (self.total - self.seconds.iter().sum::<f64>()).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Disabled, nothing is read from the clock or counted; enabled, a phase gets the time
    /// since its start and the total's remainder is `other`.
    #[test]
    fn phases_add_their_time_only_when_enabled() {
        let mut off = Timings::new(false);
        assert!(off.start().is_none());
        off.add(Phase::Solves, off.start());
        off.add_total(off.start());
        assert_eq!(off, Timings::new(false));

        let mut on = Timings::new(true);
        let run = on.start();
        let t = on.start();
        std::thread::sleep(std::time::Duration::from_millis(2));
        on.add(Phase::Residuals, t);
        std::thread::sleep(std::time::Duration::from_millis(2));
        on.add_total(run);
        // Sleeps last at least as long as asked.
        assert!(on.seconds(Phase::Residuals) >= 2e-3);
        assert!(on.total() >= on.seconds(Phase::Residuals) + 2e-3);
        assert_eq!(on.seconds(Phase::Solves), 0.0);
        let other = on.total() - on.seconds(Phase::Residuals);
        assert!((on.other() - other).abs() < 1e-12);
    }

    /// The beam slider (ED, adaptive: a sliding contact whose window moves, so every phase
    /// has work) timed: each phase that did work holds time, and no time is counted twice —
    /// the phases, timed one inside none of the others, sum to at most the run's total.
    /// Untimed, the run is the same run and reads no clock.
    #[test]
    fn a_run_times_every_phase_it_works_in_within_its_total() {
        use crate::simulation::Simulation;
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/beam_slider/case1.yaml"
        ))
        .unwrap();
        let mut model = crate::compile::from_yaml_str(&text).unwrap();
        model.simulation.t_end = 0.3;
        model.simulation.timings = true;
        let mut timed = Simulation::new(&model).unwrap();
        timed.advance_to(0.3).unwrap();
        let (s, t) = (&timed.stats, &timed.stats.timings);
        let work = [
            (Phase::Predictor, s.steps),
            (Phase::Residuals, s.residual_evaluations - s.factorizations),
            (Phase::Tangents, s.factorizations),
            (Phase::Factorizations, s.factorizations),
            (Phase::Solves, s.linear_solves),
            (Phase::ContactBorders, s.border_refreshes),
            (Phase::StepEnds, s.steps),
            (Phase::Patterns, s.pattern_rebuilds),
            (Phase::Outputs, s.steps),
        ];
        for (phase, count) in work {
            assert!(count > 0, "{}: no work in this run", phase.name());
            assert!(t.seconds(phase) > 0.0, "{}: no time", phase.name());
        }
        let sum: f64 = Phase::ALL.iter().map(|&p| t.seconds(p)).sum();
        // Disjoint intervals inside the total's: only the sums' round-off can exceed it.
        assert!(sum <= t.total() * (1.0 + 1e-12), "{sum} > {}", t.total());
        assert!((t.other() - (t.total() - sum)).abs() <= 1e-12 * t.total());

        model.simulation.timings = false;
        let mut untimed = Simulation::new(&model).unwrap();
        untimed.advance_to(0.3).unwrap();
        assert_eq!(untimed.stats.timings, Timings::new(false));
        assert_eq!(untimed.stats.newton_iterations, s.newton_iterations);
        assert_eq!(untimed.state.t, timed.state.t);
        assert_eq!(untimed.energy(), timed.energy(), "timing changed the run");
    }

    #[test]
    fn every_phase_has_its_own_name() {
        let names: std::collections::HashSet<_> = Phase::ALL.iter().map(|p| p.name()).collect();
        assert_eq!(names.len(), Phase::ALL.len());
        for (i, p) in Phase::ALL.iter().enumerate() {
            assert_eq!(*p as usize, i, "ALL in discriminant order");
        }
    }
}
