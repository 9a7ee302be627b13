//! Diagnostics of the model's functions of time (drives and load scales): a run that meets
//! one that is undefined (`sqrt(0.3 - t)` after 0.3 s, a division by zero) must say so, not
//! blame the step size or a joint row.

use super::System;
use crate::math::seconds::Seconds;
use crate::math::time_function::jet::Jet;
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

impl System {
    /// The times inside `(0, t_end)` at which a load scale's value jumps (a force switched on
    /// or off, a pulse's edges), ascending: adaptive steps end on them
    /// (`Simulation::next_landing`). A step across one carries the scale's mean over it,
    /// which balances the work but not the motion: a cantilever's tip load released inside
    /// a first step two periods long left it with 29 % of its strain energy. Found on the grid
    /// of [`JUMP_GRID`] intervals, so a pulse shorter than `t_end / JUMP_GRID` may pass
    /// unseen (its mean still carries its impulse).
    pub fn load_jump_times(&self, t_end: f64) -> Vec<f64> {
        let mut times: Vec<f64> = self
            .load_scales
            .iter()
            .flat_map(|(_, f)| value_jumps(f, t_end))
            .filter(|&t| t > 0.0 && t < t_end)
            .collect();
        times.sort_by(f64::total_cmp);
        times.dedup_by(|later, earlier| *later - *earlier <= 1e-9 * t_end);
        times
    }
}

/// Where in `[0, t_end]` `f`'s value jumps, each pinned down ([`pin_down`]).
fn value_jumps(f: &TimeFunction, t_end: f64) -> Vec<f64> {
    if matches!(f, TimeFunction::Constant(_)) || t_end.is_nan() || t_end <= 0.0 {
        return Vec::new();
    }
    let step = t_end / JUMP_GRID as f64;
    (0..JUMP_GRID)
        .filter(|&k| value_leaps(f, k as f64 * step, (k + 1) as f64 * step))
        .map(|k| {
            pin_down(k as f64 * step, (k + 1) as f64 * step, |a, b| {
                value_leaps(f, a, b)
            })
        })
        .collect()
}

/// The first number at or past the jump that `leaps` sees in `[a, b]`: the interval halved
/// towards the half that still leaps, down to adjacent numbers (a run of microseconds needs
/// its jump to the last bit, not to 1e-9 s).
fn pin_down(mut a: f64, mut b: f64, leaps: impl Fn(f64, f64) -> bool) -> f64 {
    loop {
        let m = 0.5 * (a + b);
        if m <= a || m >= b {
            return b;
        } else if leaps(a, m) {
            b = m;
        } else if leaps(m, b) {
            a = m;
        } else {
            return b;
        }
    }
}

/// Intervals of the grid [`System::time_function_jumps`] samples a function on.
pub const JUMP_GRID: usize = 4096;

/// Where in `[0, t_end]` `f` first jumps in value or rate ([`pin_down`]).
fn first_jump(f: &TimeFunction, t_end: f64) -> Option<f64> {
    if t_end.is_nan() || t_end <= 0.0 {
        return None;
    }
    let step = t_end / JUMP_GRID as f64;
    let k = (0..JUMP_GRID).find(|&k| leaps(f, k as f64 * step, (k + 1) as f64 * step))?;
    Some(pin_down(k as f64 * step, (k + 1) as f64 * step, |a, b| {
        leaps(f, a, b)
    }))
}

/// Whether `f`'s value or rate moves from `a` to `b` by far more (10×) than its rate, or
/// its acceleration, at either end allows.
fn leaps(f: &TimeFunction, a: f64, b: f64) -> bool {
    let (fa, fb) = (f.jet(a), f.jet(b));
    let h = b - a;
    let acceleration = fa.dd.abs().max(fb.dd.abs());
    let rate = fa.d.abs().max(fb.d.abs());
    let rate_leaps = (fb.d - fa.d).abs() > 10.0 * h * acceleration + 1e-6 * rate + 1e-300;
    jets_leap(&fa, &fb, h) || rate_leaps
}

/// Whether `f`'s value moves from `a` to `b` by far more (10×) than its rate and
/// acceleration at either end allow.
fn value_leaps(f: &TimeFunction, a: f64, b: f64) -> bool {
    jets_leap(&f.jet(a), &f.jet(b), b - a)
}

/// [`value_leaps`] of the jets at the ends of an interval `h` long.
fn jets_leap(fa: &Jet, fb: &Jet, h: f64) -> bool {
    let rate = fa.d.abs().max(fb.d.abs());
    let acceleration = fa.dd.abs().max(fb.dd.abs());
    let scale = 1e-9 * fa.v.abs().max(fb.v.abs()).max(1e-300);
    (fb.v - fa.v).abs() > 10.0 * (h * rate + h * h * acceleration) + scale
}

/// How `f`'s value or rate jumps at `t`, if it does: each compared a hair before and after
/// `t` (1e-7 of it), where a smooth function's moves by its next derivative times that hair.
fn jump_at(f: &TimeFunction, t: f64) -> Option<String> {
    let hair = 1e-7 * t.abs().max(1.0);
    let (before, after) = (f.jet(t - hair), f.jet(t + hair));
    let jumps = |a: f64, b: f64, smooth: f64| {
        (b - a).abs() > 1e-3 * a.abs().max(b.abs()) + 10.0 * smooth.abs() * hair
    };
    let at = format!("at t = {} s", Seconds(t));
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
    let t = Seconds(t);
    format!(
        "{what} `{name}` is not defined at t = {t} s (value {value}, rate {rate}): a function of time must be finite over the whole run (check its expression or table there, or end the run before t = {t} s)"
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

    /// Every value jump of a load scale is found, to the last bit of its time (the steps
    /// land on it), over a run of seconds and one of microseconds alike; kinks (a ramp that
    /// stops) and smooth functions are not jumps.
    #[test]
    fn a_load_scales_value_jumps_are_all_found_to_the_bit() {
        let cases: [(&str, f64, &[f64]); 6] = [
            ("t < 0.3 ? 1 : 0", 1.0, &[0.3]),
            ("(t >= 0.2) * (t < 0.55)", 1.0, &[0.2, 0.55]),
            ("step(t - 7.2694667e-6)", 1.5e-4, &[7.2694667e-6]),
            ("2 + 3 * (t > 1.75)", 2.0, &[1.75]),
            ("min(t, 0.4)", 1.0, &[]),
            ("sin(1300*t)", 20.0, &[]),
        ];
        for (text, t_end, at) in cases {
            let found = value_jumps(&expression(text), t_end);
            assert_eq!(found.len(), at.len(), "{text}: {found:?}");
            for (&t, &want) in found.iter().zip(at) {
                // The first number at or past the switch: the value there is the new one.
                assert!(
                    (t - want).abs() <= 2.0 * f64::EPSILON * want,
                    "{text}: {t} not {want}"
                );
                let f = expression(text);
                let before = f.value(t - 4.0 * f64::EPSILON * t);
                assert!(
                    (f.value(t) - before).abs() > 0.5,
                    "{text}: not across it at {t}"
                );
            }
        }
    }
}
