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
    /// The first drive whose value or rate jumps at `t` (an expression's `min`, `max`, `abs`
    /// or a step), described for the user: a prescribed motion whose velocity jumps needs an
    /// infinite force there, which no step, however short, resolves. (A load may jump: a
    /// suddenly applied force is finite.)
    pub fn time_function_jump(&self, t: f64) -> Option<String> {
        self.drive_expressions()
            .find_map(|(name, f)| jump_at(f, t).map(|jump| format!("the drive `{name}` {jump}")))
    }

    /// A warning per drive whose value or rate jumps somewhere in `[0, t_end]` (its first
    /// such place): found on a grid of [`JUMP_GRID`] intervals — where a value or rate moves
    /// far more than its derivatives allow — and pinned down by bisection. A prescribed
    /// position that jumps is an impulsive motion and a rate that jumps an impulsive force,
    /// which a run would otherwise pass silently (fixed steps) or stall at (adaptive ones).
    pub fn time_function_jumps(&self, t_end: f64) -> Vec<String> {
        self.drive_expressions()
            .filter_map(|(name, f)| {
                let t = first_jump(f, t_end)?;
                jump_at(f, t).map(|jump| format!("the drive `{name}` {jump}"))
            })
            .collect()
    }

    /// The drives given as expressions, with their names (tables are piecewise linear by
    /// design, and steps land on their breakpoints).
    fn drive_expressions(&self) -> impl Iterator<Item = (&str, &TimeFunction)> {
        self.drives
            .iter()
            .map(|d| (self.row_names[d.row].0.as_str(), &d.function))
            .filter(|(_, f)| matches!(f, TimeFunction::Expression { .. }))
    }
}

/// Intervals of the grid [`System::time_function_jumps`] samples a function on.
pub const JUMP_GRID: usize = 4096;

/// Where in `[0, t_end]` `f` first jumps in value or rate (within round-off of the place).
fn first_jump(f: &TimeFunction, t_end: f64) -> Option<f64> {
    if t_end.is_nan() || t_end <= 0.0 {
        return None;
    }
    let step = t_end / JUMP_GRID as f64;
    let k = (0..JUMP_GRID).find(|&k| leaps(f, k as f64 * step, (k + 1) as f64 * step))?;
    let (mut a, mut b) = (k as f64 * step, (k + 1) as f64 * step);
    // Halve towards the half that still leaps, down to round-off of the place.
    while b - a > 1e-9 * b.abs().max(1.0) {
        let m = 0.5 * (a + b);
        if leaps(f, a, m) {
            b = m;
        } else if leaps(f, m, b) {
            a = m;
        } else {
            break;
        }
    }
    Some(0.5 * (a + b))
}

/// Whether `f`'s value or rate moves from `a` to `b` by far more (10×) than its rate, or
/// its acceleration, at either end allows.
fn leaps(f: &TimeFunction, a: f64, b: f64) -> bool {
    let (fa, fb) = (f.jet(a), f.jet(b));
    let h = b - a;
    let rate = fa.d.abs().max(fb.d.abs());
    let acceleration = fa.dd.abs().max(fb.dd.abs());
    let scale = |x: f64, y: f64| 1e-9 * x.abs().max(y.abs()).max(1e-300);
    let value_leaps =
        (fb.v - fa.v).abs() > 10.0 * (h * rate + h * h * acceleration) + scale(fa.v, fb.v);
    let rate_leaps = (fb.d - fa.d).abs() > 10.0 * h * acceleration + 1e-6 * rate + 1e-300;
    value_leaps || rate_leaps
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
            "jumps {at} (from {:.6e} to {:.6e}): a prescribed position that jumps is an \
             impulsive motion, which no step follows; make it continuous, and its rate too \
             (e.g. blend the pieces over a short time)",
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

    #[test]
    fn a_run_finds_where_a_function_first_jumps() {
        for (text, at) in [
            ("0.2*(t > 0.3) + t", 0.3),
            ("0.5*min(t, 0.7)", 0.7),
            ("abs(t - 1.2345)", 1.2345),
        ] {
            let t = first_jump(&expression(text), 2.0).unwrap_or_else(|| panic!("{text}"));
            assert!((t - at).abs() < 1e-8, "{text}: {t}");
            assert!(jump_at(&expression(text), t).is_some(), "{text} at {t}");
        }
        // Smooth, however fast or curved over the grid (a period of 0.2 grid intervals at
        // 20 s: 4096 intervals of 4.9 ms against sin(1300 t)'s 4.8 ms).
        for text in [
            "sin(1300*t)",
            "exp(3*t)",
            "t^3 - 2*t",
            "1 - cos(2*pi*t)",
            "0.3",
        ] {
            assert_eq!(first_jump(&expression(text), 20.0), None, "{text}");
        }
    }
}
