//! Springs, dampers and drives acting on a joint's relative coordinate q (φ, Δ, …).
//!
//! A linear spring is an element with strain `ε = q`, stiffness `k`, unloaded at `q_rest`:
//! EP takes the force at the mean strain (exact discrete gradient of a quadratic energy);
//! ED uses the strain-rate jump `ε_j = ε_i + h/6 (q̇_j − q̇_f)` (ed-scheme-notes §3.2).
//! A damper adds `−c Δq/h`, whose work `−c Δq²/h` is never positive.
//! A drive is the rheonomic constraint `q − f(t) = 0`; its multiplier is the driving force.

use super::{Kernel, StepCtx};
use crate::scalar::Real;
use crate::system::layout::Layout;
use crate::time_function::TimeFunction;

#[derive(Clone, Debug)]
pub struct CoordinateSpring {
    pub coord: usize,
    pub stiffness: f64,
    pub damping: f64,
    pub rest: f64,
    unknowns: Vec<usize>,
}

impl CoordinateSpring {
    pub fn new(coord: usize, stiffness: f64, damping: f64, rest: f64, layout: &Layout) -> Self {
        let mut unknowns = vec![layout.coord_delta(coord)];
        if layout.ed() {
            unknowns.push(layout.coord_jump(coord));
        }
        CoordinateSpring {
            coord,
            stiffness,
            damping,
            rest,
            unknowns,
        }
    }

    /// The strain jump `ε_j − ε_i` of the ED scheme for a converged step.
    pub fn jump(&self, ctx: &StepCtx, y: &[f64]) -> f64 {
        if !ctx.ed() {
            return 0.0;
        }
        let dq = y[self.unknowns[0]];
        let qj = y[self.unknowns[1]] / ctx.h;
        let qf = 2.0 * dq / ctx.h - qj;
        ctx.h / 6.0 * (qj - qf)
    }
}

impl Kernel for CoordinateSpring {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns
    }
    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], r: &mut [T]) {
        let h = ctx.h;
        let k = self.stiffness;
        let qi = ctx.state.coords[self.coord];
        let dq = y[0];
        let eps_f = dq + qi;
        if ctx.is_static() {
            // Statics: the spring force at the end state; a damper carries nothing.
            r[0] += (eps_f - self.rest) * k;
            return;
        }
        // Residual rows hold −P (force on the coordinate with the sign of the inertia rows).
        r[0] += dq * (self.damping / h);
        if ctx.ed() {
            let rate_j = y[1] / h;
            let rate_f = dq * (2.0 / h) - rate_j;
            let eps_j = (rate_j - rate_f) * (h / 6.0) + qi;
            let mean = (eps_j + eps_f) * 0.5 - self.rest;
            let dn = (eps_f - eps_j) * k;
            r[0] += mean * k;
            r[1] -= dn / 6.0;
        } else {
            let mean = dq * 0.5 + (qi - self.rest);
            r[0] += mean * k;
        }
    }
}

/// Prescribed coordinate `q = f(t)`, one constraint row.
#[derive(Clone, Debug)]
pub struct CoordinateDrive {
    pub coord: usize,
    pub row: usize,
    pub function: TimeFunction,
    unknowns: Vec<usize>,
}

impl CoordinateDrive {
    pub fn new(coord: usize, row: usize, function: TimeFunction, layout: &Layout) -> Self {
        let unknowns = if layout.ed() {
            vec![
                layout.coord_delta(coord),
                layout.coord_jump(coord),
                layout.mult(row),
                layout.mult_jump(row),
            ]
        } else {
            vec![layout.coord_delta(coord), layout.mult(row)]
        };
        CoordinateDrive {
            coord,
            row,
            function,
            unknowns,
        }
    }

    /// Work done by the drive over a converged step: from the energy identity, the terms the
    /// rheonomic constraint leaves behind (EP: `−λ (f_f − f_i)`; ED adds the velocity-level
    /// term `h/12 λ_d (ḟ_i − ḟ_f)`).
    pub fn step_work(&self, ctx: &StepCtx, y: &[f64]) -> f64 {
        let (ff, fi) = (self.function.value(ctx.t_f), self.function.value(ctx.t_i));
        if ctx.ed() {
            let lf = ctx.s * y[self.unknowns[2]];
            let ld = ctx.s * y[self.unknowns[3]];
            let (ri, rf) = (self.function.rate(ctx.t_i), self.function.rate(ctx.t_f));
            -lf * (ff - fi) + ctx.h / 12.0 * ld * (ri - rf)
        } else {
            -ctx.s * y[self.unknowns[1]] * (ff - fi)
        }
    }

    /// The driving force/torque on the coordinate (positive drives q up): `−λ`.
    pub fn force(&self, ctx: &StepCtx, y: &[f64]) -> f64 {
        let m = if ctx.ed() {
            self.unknowns[2]
        } else {
            self.unknowns[1]
        };
        -ctx.s * y[m]
    }
}

impl Kernel for CoordinateDrive {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns
    }
    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], r: &mut [T]) {
        let s = ctx.s;
        let qi = ctx.state.coords[self.coord];
        let dq = y[0];
        if ctx.ed() {
            let (rate_j, mf, md) = (y[1] / ctx.h, y[2], y[3]);
            let rate_f = dq * (2.0 / ctx.h) - rate_j;
            // B = 1: P_f = −λ_f, P_j = λ_d; rows hold −P_f and −P_j/6.
            r[0] += mf * s;
            r[1] -= md * (s / 6.0);
            r[2] += (dq + (qi - self.function.value(ctx.t_f))) * s;
            let ci = rate_j - self.function.rate(ctx.t_i);
            let cf = rate_f - self.function.rate(ctx.t_f);
            r[3] += (ci - cf) * (s * ctx.h);
        } else {
            r[0] += y[1] * s;
            r[1] += (dq + (qi - self.function.value(ctx.t_f))) * s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elements::fd_harness::tangent_error;
    use crate::model::{Scheme, TimeFunctionSpec};
    use crate::state::State;
    use crate::vec3::V3;

    #[test]
    fn spring_and_drive_tangents_match_finite_differences() {
        let state = State {
            t: 0.3,
            nodes: vec![],
            coords: vec![0.4],
            coord_rates: vec![1.0],
            lambda: vec![0.0],
            history: vec![],
        };
        // Time steps of both schemes, and static solves (EP layout).
        for (scheme, statics) in [
            (Scheme::Ep, None),
            (Scheme::Ed, None),
            (Scheme::Ep, Some(0.6)),
        ] {
            let layout = Layout::new(scheme, 0, 1, 1);
            let ctx = StepCtx {
                layout,
                h: 0.02,
                t_i: 0.3,
                t_f: 0.32,
                s: 50.0,
                state: &state,
                gravity: V3([0.0; 3]),
                statics,
            };
            let y: Vec<f64> = (0..layout.n_unknowns())
                .map(|i| 0.1 + 0.05 * i as f64)
                .collect();
            let sp = CoordinateSpring::new(0, 300.0, 4.0, 0.1, &layout);
            assert!(tangent_error(&sp, &ctx, &y) < 1e-8);
            let f = TimeFunction::new(&TimeFunctionSpec::Expression("sin(3*t)".into())).unwrap();
            let dr = CoordinateDrive::new(0, 0, f, &layout);
            assert!(tangent_error(&dr, &ctx, &y) < 1e-8);
        }
    }
}
