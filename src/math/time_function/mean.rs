//! The mean of a time function over a step, `∫ f dt / h`: what a load scaled by it carries
//! over the step. The average of the step's end values missed whatever happens between
//! them: a 50 ms pulse inside a 0.1 s step carried nothing. A table is integrated exactly; an
//! expression by Gauss–Legendre on each piece where it is one smooth formula, its switches
//! (comparisons, conditionals, kinks, steps — [`Expression::branches`]) located by bisection.

use super::expression::Expression;
use super::TimeFunction;

/// Equal parts a step is first cut into to look for switches: a switch that flips and flips
/// back within one part is seen only if another switch of the expression flips there.
const PARTS: usize = 8;
/// Bisections locating a switch: its part shrinks to 2⁻⁴⁰ ≈ 1e-12 of itself.
const BISECTIONS: u32 = 40;

impl TimeFunction {
    /// The mean over `[t0, t1]` (the value at `t1` on an empty interval).
    pub fn mean(&self, t0: f64, t1: f64) -> f64 {
        let h = t1 - t0;
        if h.is_nan() || h <= 0.0 {
            return self.value(t1);
        }
        match self {
            TimeFunction::Constant(c) => *c,
            TimeFunction::Table { t, .. } => table_integral(self, t, t0, t1) / h,
            TimeFunction::Expression { expression, .. } => integral(expression, t0, t1) / h,
        }
    }
}

/// Exact integral over `[a, b]` of `table`, piecewise linear between its times `t` (and
/// constant beyond its ends).
fn table_integral(table: &TimeFunction, t: &[f64], a: f64, b: f64) -> f64 {
    let value = |x: f64| table.value(x);
    // Breakpoints inside (a, b), with the ends: the function is linear between them. Found
    // by bisection: a long signal table is evaluated at every residual of a step.
    let inner = &t[t.partition_point(|&x| x <= a)..t.partition_point(|&x| x < b)];
    let inner = inner.iter().copied();
    let mut points = std::iter::once(a).chain(inner).chain(std::iter::once(b));
    let mut left = points.next().unwrap_or(a);
    let mut sum = 0.0;
    for right in points {
        sum += 0.5 * (right - left) * (value(left) + value(right));
        left = right;
    }
    sum
}

/// `∫ₐᵇ f dt` of an expression: one Gauss–Legendre rule where no switch flips in the step (as
/// in most steps: 12 evaluations), else piece by piece.
fn integral(e: &Expression, a: f64, b: f64) -> f64 {
    if !e.has_branches() {
        return gauss(e, a, b);
    }
    let at = |k: usize| {
        if k == PARTS {
            b
        } else {
            a + (b - a) * k as f64 / PARTS as f64
        }
    };
    let codes: [u64; PARTS + 1] = std::array::from_fn(|k| e.branches(at(k)));
    if codes.iter().all(|&c| c == codes[0]) {
        return gauss(e, a, b);
    }
    (0..PARTS)
        .map(|k| piece(e, at(k), at(k + 1), codes[k], codes[k + 1], BISECTIONS))
        .sum()
}

/// `∫ₗʳ f dt` where the branches at the ends are `cl` and `cr`: one smooth piece if they are
/// the same; else halved, down to `depth` more times, where the switch's sliver is taken by
/// the trapezoid rule.
fn piece(e: &Expression, l: f64, r: f64, cl: u64, cr: u64, depth: u32) -> f64 {
    if cl == cr {
        return gauss(e, l, r);
    }
    if depth == 0 {
        return 0.5 * (r - l) * (e.eval(l).v + e.eval(r).v);
    }
    let m = 0.5 * (l + r);
    let cm = e.branches(m);
    piece(e, l, m, cl, cm, depth - 1) + piece(e, m, r, cm, cr, depth - 1)
}

/// Three-point Gauss–Legendre over `[l, r]` (exact for quintics; the ends are not sampled,
/// so a switch exactly at an end does not count).
fn gauss(e: &Expression, l: f64, r: f64) -> f64 {
    let (c, half) = (0.5 * (l + r), 0.5 * (r - l));
    let x = half * (0.6f64).sqrt();
    half * (5.0 * e.eval(c - x).v + 8.0 * e.eval(c).v + 5.0 * e.eval(c + x).v) / 9.0
}

#[cfg(test)]
mod tests {
    use super::super::{TableSpec, TimeFunctionSpec};

    use super::*;

    fn function(text: &str) -> TimeFunction {
        TimeFunction::expression(text)
    }

    #[test]
    fn a_smooth_expression_has_its_integral_mean() {
        // ∫ sin(3t) over [0.2, 0.7] = (cos 0.6 − cos 2.1)/3; the quadrature's error over a
        // step this long (1.5 rad of phase) is ~1e-5 of it, far below at a real step.
        let exact = ((0.6f64).cos() - (2.1f64).cos()) / 3.0 / 0.5;
        assert!((function("sin(3*t)").mean(0.2, 0.7) - exact).abs() < 1e-4 * exact);
        let short = ((0.6f64).cos() - (0.63f64).cos()) / 3.0 / 0.01;
        assert!((function("sin(3*t)").mean(0.2, 0.21) - short).abs() < 1e-12 * short);
        assert_eq!(function("t^2").mean(0.3, 0.3), 0.09);
    }

    #[test]
    fn a_pulse_inside_a_step_carries_its_impulse() {
        // A 50 ms pulse of 1 inside a 0.1 s step: mean 0.5. The end values are both 0 (the
        // average of the ends carried nothing). Located to 1e-12 of a part.
        let pulse = function("t > 0.1 && t < 0.15 ? 1 : 0");
        assert!((pulse.mean(0.1, 0.2) - 0.5).abs() < 1e-11);
        assert!((pulse.mean(0.0, 1.0) - 0.05).abs() < 1e-12);
        // A narrow pulse whose switch flips and flips back inside one part, seen through its
        // kink (abs): 10 ms of 2 at t = 0.15.
        let narrow = function("abs(t - 0.15) < 0.005 ? 2 : 0");
        assert!((narrow.mean(0.1, 0.2) - 0.2).abs() < 1e-11);
        // A step with a ramp: ∫ over [0, 2] of (t > 1 ? t − 1 : 0) = 0.5.
        assert!((function("t > 1 ? t - 1 : 0").mean(0.0, 2.0) - 0.25).abs() < 1e-12);
        // Stepped functions: floor(4t) over [0, 1] has mean (0 + 1 + 2 + 3)/4.
        assert!((function("floor(4*t)").mean(0.0, 1.0) - 1.5).abs() < 1e-11);
    }

    #[test]
    fn a_table_is_integrated_exactly() {
        let table = TimeFunction::new(&TimeFunctionSpec::Table(TableSpec {
            t: vec![0.0, 1.0, 2.0],
            value: vec![0.0, 2.0, 0.0],
        }))
        .unwrap();
        // A triangle of area 2 over [0, 2], held at 0 beyond: mean over [−1, 3] is 0.5.
        assert!((table.mean(-1.0, 3.0) - 0.5).abs() < 1e-15);
        assert!((table.mean(0.5, 1.5) - 1.5).abs() < 1e-15);
        assert_eq!(TimeFunction::Constant(3.0).mean(0.0, 1.0), 3.0);
    }
}
