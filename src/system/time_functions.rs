//! Diagnostics of the model's functions of time (drives and load scales): a run that meets
//! one that is undefined (`sqrt(0.3 - t)` after 0.3 s, a division by zero) must say so, not
//! blame the step size or a joint row.

use super::System;
use crate::math::time_function::TimeFunction;

impl System {
    /// The first drive or load scale whose value or rate is not finite at `t_i` or `t_f`,
    /// described for the user; `None` when all are defined over the step.
    pub fn undefined_time_function(&self, t_i: f64, t_f: f64) -> Option<String> {
        let bad = |v: f64, r: f64| !(v.is_finite() && r.is_finite());
        for d in &self.drives {
            for t in [t_i, t_f] {
                let f = d.function.jet(t);
                let (v, r) = (f.v, f.d);
                if bad(v, r) {
                    let name = &self.row_names[d.row].0;
                    return Some(undefined("the drive", name, t, v, r));
                }
            }
        }
        for (name, f) in &self.load_scales {
            for t in [t_i, t_f] {
                let (v, r) = (f.value(t), f.rate(t));
                if bad(v, r) {
                    return Some(undefined("the scale of load", name, t, v, r));
                }
            }
        }
        None
    }
}

impl System {
    /// The first drive or load scale whose value or rate jumps at `t` (an expression's
    /// `min`, `max`, `abs` or a step), described for the user: a prescribed motion whose
    /// velocity jumps needs an infinite force there, which no step, however short, resolves.
    /// A table's breakpoints are no such jumps: steps land on them.
    pub fn time_function_jump(&self, t: f64) -> Option<String> {
        let drives = self
            .drives
            .iter()
            .map(|d| ("the drive", self.row_names[d.row].0.as_str(), &d.function));
        let scales = self
            .load_scales
            .iter()
            .map(|(name, f)| ("the scale of load", name.as_str(), f));
        for (what, name, f) in drives.chain(scales) {
            if matches!(f, TimeFunction::Table { .. }) {
                continue;
            }
            if let Some(jump) = jump_at(f, t) {
                return Some(format!("{what} `{name}` {jump}"));
            }
        }
        None
    }
}

/// How `f`'s value or rate jumps at `t`, if it does: each compared a hair before and after
/// `t` (1e-7 of it), where a smooth function's moves by its next derivative times that hair.
fn jump_at(f: &TimeFunction, t: f64) -> Option<String> {
    let hair = 1e-7 * t.abs().max(1.0);
    let (before, after) = (f.jet(t - hair), f.jet(t + hair));
    let jumps = |a: f64, b: f64, smooth: f64| {
        (b - a).abs() > 1e-3 * a.abs().max(b.abs()) + 10.0 * smooth.abs() * hair
    };
    let at = format!("at t = {t:.6} s");
    if jumps(before.v, after.v, before.d.abs().max(after.d.abs())) {
        return Some(format!(
            "jumps {at} (from {:.6e} to {:.6e}): a function of time must be continuous, and a \
             drive's rate too (smooth the expression there, e.g. blend over a short time)",
            before.v, after.v
        ));
    }
    if jumps(before.d, after.d, before.dd.abs().max(after.dd.abs())) {
        return Some(format!(
            "changes its rate abruptly {at} (from {:.6e} to {:.6e} per s): a prescribed motion \
             whose velocity jumps needs an infinite force there, which no step resolves; make \
             the rate continuous (e.g. blend the two pieces over a short time)",
            before.d, after.d
        ));
    }
    None
}

fn undefined(what: &str, name: &str, t: f64, value: f64, rate: f64) -> String {
    format!(
        "{what} `{name}` is not defined at t = {t:.6} s (value {value}, rate {rate}): a function of time must be finite over the whole run (check its expression or table there, or end the run before t = {t:.6} s)"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn expression(text: &str) -> TimeFunction {
        TimeFunction::expression(text)
    }

    #[test]
    fn jumps_in_value_or_rate_are_told_and_smooth_functions_are_not() {
        let value = jump_at(&expression("0.2*(t > 0.3) + t"), 0.3).unwrap();
        assert!(value.starts_with("jumps at t = 0.300000 s"), "{value}");
        let rate = jump_at(&expression("0.5*min(t, 0.3)"), 0.3).unwrap();
        assert!(rate.starts_with("changes its rate abruptly"), "{rate}");
        // Fast and curved, or large, but smooth: what moves over the hair is its next
        // derivative's share.
        for (text, t) in [("sin(30*t)", 0.3), ("1e6*t*t", 2.0), ("exp(5*t)", 3.0)] {
            assert_eq!(jump_at(&expression(text), t), None, "{text}");
        }
        // Away from its kink, min() is smooth.
        assert_eq!(jump_at(&expression("0.5*min(t, 0.3)"), 0.2), None);
    }
}
