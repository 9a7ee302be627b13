//! The model's size limits and the simulation settings: checked before anything else.

use crate::model::check::Checker;
use crate::model::{Model, StepControl};

/// Most beam elements in a model: beyond it, memory and compile time run to gigabytes and
/// minutes before the first step (about 10 kB per cubic element with ED).
pub const MAX_BEAM_ELEMENTS: usize = 100_000;
/// Most output samples in a run (each a row of every channel).
pub const MAX_SAMPLES: f64 = 1e8;

/// Limits checked before anything is allocated, each with what to change.
pub fn check_size(model: &Model, c: &mut Checker) {
    if model.nodes.is_empty() && model.beams.is_empty() {
        c.err(
            "nodes",
            "the model is empty: add `nodes`, `beams` (and `bodies`, `joints`) to simulate something",
        );
    }
    let elements: usize = model
        .beams
        .iter()
        .map(|b| b.elements)
        .fold(0, usize::saturating_add);
    if elements > MAX_BEAM_ELEMENTS {
        let (i, b) = model
            .beams
            .iter()
            .enumerate()
            .max_by_key(|(_, b)| b.elements)
            .expect("elements > 0 means a beam");
        c.err(
            format!("beams[{i}].elements"),
            format!(
                "the beams have {elements} elements in all (`{}` has {}); the limit is {MAX_BEAM_ELEMENTS}: use fewer, higher-order elements",
                b.name, b.elements
            ),
        );
    }
    let s = &model.simulation;
    let (interval, key) = match s.output_dt {
        Some(o) => (o, "simulation.output_dt"),
        None if s.step_control == StepControl::Fixed => (s.dt, "simulation.dt"),
        None => return,
    };
    let samples = s.t_end / interval;
    // inf (a subnormal interval) is over the limit too; NaN is a bad t_end, reported there.
    if samples > MAX_SAMPLES {
        c.err(
            key,
            format!(
                "{samples:.3e} output samples over t_end = {} s; at most {MAX_SAMPLES:.0e}: raise `{}` or shorten the run",
                s.t_end,
                key.trim_start_matches("simulation.")
            ),
        );
    }
}

/// Checks the `simulation:` settings.
pub fn check(model: &Model, c: &mut Checker) {
    let s = &model.simulation;
    if !(s.t_end.is_finite() && s.t_end > 0.0) {
        c.err(
            "simulation.t_end",
            format!("must be positive (got {})", s.t_end),
        );
    }
    if !(s.dt.is_finite() && s.dt > 0.0) {
        c.err("simulation.dt", format!("must be positive (got {})", s.dt));
    }
    if let Some(o) = s.output_dt {
        if !(o.is_finite() && o > 0.0) {
            c.err(
                "simulation.output_dt",
                format!("must be a positive interval in s (got {o})"),
            );
        }
    }
    if !(s.tolerance.is_finite() && s.tolerance > 0.0 && s.tolerance < 1.0) {
        c.err(
            "simulation.tolerance",
            format!("must be between 0 and 1 (got {})", s.tolerance),
        );
    }
    let (lo, hi) = (s.dt_min(), s.dt_max());
    if !(lo.is_finite() && lo > 0.0 && hi.is_finite() && lo <= s.dt && s.dt <= hi) {
        c.err(
            "simulation.dt_min",
            format!(
                "need 0 < dt_min ≤ dt ≤ dt_max (got dt_min = {lo}, dt = {}, dt_max = {hi})",
                s.dt
            ),
        );
    }
    if !(s.max_growth > 1.0 && s.max_growth.is_finite()) {
        c.err(
            "simulation.max_growth",
            format!("must be greater than 1 (got {})", s.max_growth),
        );
    }
    if !(s.max_shrink > 0.0 && s.max_shrink < 1.0) {
        c.err(
            "simulation.max_shrink",
            format!("must be between 0 and 1 (got {})", s.max_shrink),
        );
    }
    if !(s.newton_tol.is_finite() && s.newton_tol > 0.0 && s.newton_tol < 1.0) {
        c.err("simulation.newton_tol", "must be between 0 and 1");
    }
    if !(s.newton_increment_tol.is_finite() && s.newton_increment_tol >= 0.0) {
        c.err(
            "simulation.newton_increment_tol",
            format!(
                "must be positive, or 0 to turn the increment test off (got {})",
                s.newton_increment_tol
            ),
        );
    }
    if s.load_steps == 0 {
        c.err("simulation.load_steps", "must be at least 1");
    }
    if s.max_newton_iterations < 2 {
        c.err("simulation.max_newton_iterations", "must be at least 2");
    }
}
