//! When a Newton iterate is a converged step. Two separate conditions, never one traded
//! against the other:
//! - the equations of motion balance to `newton_tol` relative to the forces acting in them:
//!   the largest *activity* of a force row (the sum of the magnitudes of every kernel's
//!   contribution to it — inertia, elastic, constraint, applied forces) or the model's
//!   weight; a residual that stops falling is accepted at its round-off floor: of the
//!   stiffest elastic force (`System::force_roundoff`), or of the terms inside an inertia
//!   row, momentum per unit step (they cancel for a body spinning freely, whose rows have
//!   no other force to be judged against);
//! - every constraint holds at f, `|C_f|` in its own units (m or rad; ED's velocity-level
//!   rows as `h |B_i V_j − B_f V_f|`) within what the force tolerance means for it,
//!   `newton_tol·F/s` (never looser than `newton_tol·L_ref`); a violation that stops falling
//!   (round-off of a rotor's large angle, of a tiny step) is accepted within
//!   `newton_tol·L_ref`.
//!
//! Constraint rows are stored scaled, `s C` with `s = m_ref/h²` (conditioning); they are
//! judged unscaled, so round-off in C (1e-16 of a rotated triad) is not magnified by 1/h² into
//! a force that fails the force test at tiny steps, and a huge force scale (a stiff spring)
//! cannot let a violated joint through.

use crate::elements::StepCtx;
use crate::system::System;

/// How far an iterate is from a converged step.
#[derive(Clone, Copy, Debug, Default)]
pub struct Measure {
    /// ∞-norm of the force rows (momentum, jump and coordinate equations), N or N·m.
    pub force: f64,
    pub force_row: usize,
    /// The force scale the force residual is judged against.
    pub force_scale: f64,
    /// Below this the force residual is round-off.
    pub force_floor: f64,
    /// Largest constraint violation |C_f| (or h|B V| of an ED velocity row), m or rad.
    pub constraint: f64,
    pub constraint_row: usize,
    /// The force tolerance's equivalent for constraint rows, `F/s` (times the tolerance).
    pub constraint_scale: f64,
    /// Whether any row is NaN or infinite (`force_row` or `constraint_row` names it).
    pub finite: bool,
    /// ∞-norm of the whole residual as stored (constraint rows scaled).
    pub stored: f64,
}

impl Measure {
    /// Measures the residual `res` of the step in `ctx` whose force rows had the
    /// contribution magnitudes `activity`.
    pub fn of(sys: &System, ctx: &StepCtx, res: &[f64], activity: &[f64]) -> Measure {
        Self::with_floor(sys, ctx, res, activity, Self::force_floor(sys, ctx))
    }

    /// The force residual below which a residual that stopped falling is round-off (N or
    /// N·m): of the stiffest elastic force, or of the terms inside an inertia row. Fixed
    /// over a step, so Newton computes it once per step.
    pub fn force_floor(sys: &System, ctx: &StepCtx) -> f64 {
        sys.force_roundoff
            .max(1e3 * f64::EPSILON * momentum_per_step(sys, ctx))
    }

    /// [`Self::of`] with the step's [`Self::force_floor`] at hand.
    pub fn with_floor(
        sys: &System,
        ctx: &StepCtx,
        res: &[f64],
        activity: &[f64],
        force_floor: f64,
    ) -> Measure {
        let first_row = ctx.layout.mult(0).min(res.len());
        let (mut force, mut force_row) = inf_norm(&res[..first_row]);
        // Friction rows come last; a slipping one's rows set its force (N), a force row.
        let first_friction = sys
            .frictions
            .first()
            .map_or(res.len(), |f| ctx.layout.mult(f.row))
            .max(first_row);
        let (mut c_scaled, mut c_row) = inf_norm(&res[first_row..first_friction]);
        c_row += first_row;
        for f in &sys.frictions {
            let at = ctx.layout.mult(f.row);
            let rows = if ctx.layout.ed() {
                at..at + 2
            } else {
                at..at + 1
            };
            let slipping = !ctx.is_static()
                && matches!(
                    f.mode(ctx.state),
                    crate::joints::friction::Mode::Slip { .. }
                );
            for i in rows {
                let (norm, row) = if slipping {
                    (&mut force, &mut force_row)
                } else {
                    (&mut c_scaled, &mut c_row)
                };
                if res[i].abs() > *norm || res[i].is_nan() {
                    (*norm, *row) = (res[i].abs(), i);
                }
            }
        }
        let acting = max_magnitude(&activity[..first_row]).0;
        let weight = sys.mass_ref * sys.gravity.norm();
        let force_scale = acting.max(weight).max(sys.force_ref).max(1e-300);
        Measure {
            force,
            force_row,
            force_scale,
            force_floor,
            stored: if force.is_nan() || c_scaled.is_nan() {
                f64::NAN
            } else {
                force.max(c_scaled)
            },
            constraint: c_scaled / ctx.s,
            constraint_scale: force_scale / ctx.s,
            constraint_row: c_row,
            finite: force.is_finite() && c_scaled.is_finite(),
        }
    }

    /// The force residual relative to its tolerance (≤ 1: balanced).
    pub fn force_ratio(&self, tol: f64) -> f64 {
        self.force / (tol * self.force_scale)
    }

    /// Whether the forces balance: to the tolerance, or — once the residual has stopped
    /// falling (`previous`: the last iterate's force residual) — to the round-off of the
    /// model's stiffest elastic force.
    pub fn forces_balance(&self, tol: f64, previous: Option<&Measure>) -> bool {
        let stagnated = previous.is_some_and(|p| self.force > 0.5 * p.force);
        self.force_ratio(tol) <= 1.0 || (stagnated && self.force <= self.force_floor)
    }

    /// The loosest constraint tolerance: `tol` relative to the model's size (m; rad for
    /// angles), no finer than round-off of positions.
    pub fn constraint_tol(sys: &System, tol: f64) -> f64 {
        tol.max(1e3 * f64::EPSILON) * sys.length_ref
    }

    /// The constraint tolerance while Newton still improves the constraints.
    fn constraint_tight(&self, sys: &System, tol: f64) -> f64 {
        (tol * self.constraint_scale).min(Self::constraint_tol(sys, tol))
    }

    /// How far from converged, in units of the tolerances: the larger of the force
    /// residual over its tolerance and the violation over the tight constraint tolerance
    /// (≤ 1: converged). Modified Newton's contraction rate is its ratio between iterates.
    pub fn distance(&self, sys: &System, tol: f64) -> f64 {
        self.force_ratio(tol).max(self.constraint_ratio(sys, tol))
    }

    /// The constraint violation over its tight tolerance (≤ 1: held).
    pub fn constraint_ratio(&self, sys: &System, tol: f64) -> f64 {
        self.constraint / self.constraint_tight(sys, tol).max(f64::MIN_POSITIVE)
    }

    /// Both conditions met (`previous`: the last iterate's measure).
    pub fn converged(&self, sys: &System, tol: f64, previous: Option<&Measure>) -> bool {
        self.forces_balance(tol, previous) && self.constraints_hold(sys, tol, previous)
    }

    /// Whether the constraints hold: within the tight tolerance, or — once the violation
    /// has stopped falling — within the loosest.
    pub fn constraints_hold(&self, sys: &System, tol: f64, previous: Option<&Measure>) -> bool {
        let stagnated = previous.is_some_and(|p| self.constraint > 0.5 * p.constraint);
        self.finite
            && (self.constraint <= self.constraint_tight(sys, tol)
                || (stagnated && self.constraint <= Self::constraint_tol(sys, tol)))
    }

    /// What is left to converge, e.g. for a failure message.
    pub fn describe(&self, sys: &System, tol: f64) -> String {
        let c_tol = self.constraint_tight(sys, tol);
        let mut parts = Vec::new();
        if self.force_ratio(tol) > 1.0 || !self.force.is_finite() {
            parts.push(format!(
                "force residual {:.3e} (tolerance {:.3e}) at {}",
                self.force,
                tol * self.force_scale,
                sys.describe_row(self.force_row)
            ));
        }
        if self.constraint > c_tol || !self.constraint.is_finite() {
            parts.push(format!(
                "constraint violation {:.3e} (tolerance {c_tol:.3e}) at {}",
                self.constraint,
                sys.describe_row(self.constraint_row)
            ));
        }
        if parts.is_empty() {
            "converged".to_string()
        } else {
            parts.join("; ")
        }
    }
}

/// The largest momentum of a node at the start of the step per unit step, `m|v|/h` or
/// `|J W|/h`: the size of the terms of an inertia row (0 in statics).
fn momentum_per_step(sys: &System, ctx: &StepCtx) -> f64 {
    if ctx.is_static() {
        return 0.0;
    }
    sys.inertias.iter().fold(0.0f64, |m, k| {
        let n = &ctx.state.nodes[k.node];
        let p = (k.mass * n.v.norm()).max(k.inertia.mul_v(&n.w).norm());
        m.max(p / ctx.h)
    })
}

/// Largest magnitude and its index (the first where it occurs); a NaN wins (and is
/// reported where it first occurs).
pub fn inf_norm(v: &[f64]) -> (f64, usize) {
    let (m, nan) = max_magnitude(v);
    if nan {
        return (f64::NAN, v.iter().position(|x| x.is_nan()).unwrap_or(0));
    }
    (m, v.iter().position(|x| x.abs() == m).unwrap_or(0))
}

/// The largest magnitude in `v` (0 if empty) and whether `v` holds a NaN: in lanes, without
/// a branch or a carried index, which the compiler turns into packed max and NaN tests
/// (Newton measures every iterate's residual).
fn max_magnitude(v: &[f64]) -> (f64, bool) {
    const LANES: usize = 4;
    let larger = |m: f64, a: f64| if a > m { a } else { m };
    let mut max = [0.0f64; LANES];
    let mut nan = [false; LANES];
    let chunks = v.chunks_exact(LANES);
    let tail = chunks.remainder();
    for c in chunks {
        for k in 0..LANES {
            let a = c[k].abs();
            max[k] = larger(max[k], a);
            nan[k] |= a.is_nan();
        }
    }
    let mut m = max.into_iter().fold(0.0, larger);
    let mut any_nan = nan.contains(&true);
    for x in tail {
        m = larger(m, x.abs());
        any_nan |= x.is_nan();
    }
    (m, any_nan)
}

#[cfg(test)]
mod tests {
    use super::inf_norm;

    /// The lanes and the tail (lengths around multiples of 4) give the scalar scan's answer:
    /// the largest magnitude at its first index, a NaN at its first index whatever is larger.
    #[test]
    fn inf_norm_finds_the_first_largest_magnitude_and_the_first_nan() {
        let scan = |v: &[f64]| {
            let (mut m, mut at) = (0.0, 0);
            for (i, x) in v.iter().enumerate() {
                if x.is_nan() {
                    return (f64::NAN, i);
                }
                if x.abs() > m {
                    (m, at) = (x.abs(), i);
                }
            }
            (m, at)
        };
        let same = |a: (f64, usize), b: (f64, usize)| {
            (a.0 == b.0 || (a.0.is_nan() && b.0.is_nan())) && a.1 == b.1
        };
        assert_eq!(inf_norm(&[]), (0.0, 0));
        for n in 1..=13 {
            let v: Vec<f64> = (0..n).map(|i| ((i * 7) % 5) as f64 - 2.5).collect();
            assert!(same(inf_norm(&v), scan(&v)), "{v:?}");
            for at in 0..n {
                let mut w = v.clone();
                w[at] = -1e9;
                assert!(same(inf_norm(&w), scan(&w)), "{w:?}");
                w[n - 1 - at] = f64::NAN;
                assert!(same(inf_norm(&w), scan(&w)), "{w:?}");
                w[at] = f64::INFINITY;
                assert!(same(inf_norm(&w), scan(&w)), "{w:?}");
            }
        }
    }
}
