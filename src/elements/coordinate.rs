//! Springs, dampers and drives acting on a joint's relative coordinate q (φ, Δ, …).
//!
//! A linear spring is an element with strain `ε = q`, stiffness `k`, unloaded at `q_rest`:
//! EP takes the force at the mean strain (exact discrete gradient of a quadratic energy);
//! ED uses the strain-rate jump `ε_j = ε_i + h/6 (q̇_j − q̇_f)` (ed-scheme-notes §3.2).
//! A damper adds `−c Δq/h`, whose work `−c Δq²/h` is never positive.
//! A drive is the rheonomic constraint `q − f(t) = 0`; its multiplier is the driving force.

use super::{Kernel, StepCtx, ValuePos};
use crate::beam::path::ArcMap;
use crate::math::layout::Layout;
use crate::math::scalar::Real;
use crate::math::time_function::TimeFunction;

/// The elastic law of a spring on a coordinate: its force `F(q)` (acting as `−F` on the
/// coordinate) and energy `V(q)`.
#[derive(Clone, Debug)]
pub enum SpringLaw {
    /// `F = k (q − rest)`.
    Linear { stiffness: f64, rest: f64 },
    /// `F(q)` piecewise linear through the points, extended with the end slopes; `V` is its
    /// integral from where the force vanishes (or from the first point if it never does).
    Table {
        q: Vec<f64>,
        force: Vec<f64>,
        /// `∫ F` from the first point to the unloaded point.
        offset: f64,
    },
}

impl SpringLaw {
    /// A tabulated spring (abscissae strictly increasing, forces non-decreasing).
    pub fn table(q: Vec<f64>, force: Vec<f64>) -> SpringLaw {
        let mut law = SpringLaw::Table {
            q: q.clone(),
            force: force.clone(),
            offset: 0.0,
        };
        // The unloaded point: where the piecewise-linear force crosses zero.
        let zero = (0..q.len() - 1).find_map(|j| {
            let (f0, f1) = (force[j], force[j + 1]);
            let last = j + 2 == q.len();
            let first = j == 0;
            let t = if f1 != f0 { -f0 / (f1 - f0) } else { f64::NAN };
            let inside = (t >= 0.0 || first) && (t <= 1.0 || last);
            (t.is_finite() && inside).then(|| q[j] + t * (q[j + 1] - q[j]))
        });
        if let Some(z) = zero {
            let v = law.energy(z);
            if let SpringLaw::Table { offset, .. } = &mut law {
                *offset = v;
            }
        }
        law
    }

    /// Segment of the table holding `q` (the end segments extend to infinity).
    fn segment(q: &[f64], x: f64) -> usize {
        let n = q.len();
        q[1..n - 1].iter().take_while(|&&b| x >= b).count()
    }

    pub fn force<T: Real>(&self, x: T) -> T {
        match self {
            SpringLaw::Linear { stiffness, rest } => (x - *rest) * *stiffness,
            SpringLaw::Table { q, force, .. } => {
                let j = Self::segment(q, x.re());
                let slope = (force[j + 1] - force[j]) / (q[j + 1] - q[j]);
                (x - q[j]) * slope + force[j]
            }
        }
    }

    /// Tangent stiffness dF/dq (its largest value for a table), for scaling.
    pub fn stiffness_scale(&self) -> f64 {
        match self {
            SpringLaw::Linear { stiffness, .. } => *stiffness,
            SpringLaw::Table { q, force, .. } => q
                .windows(2)
                .zip(force.windows(2))
                .map(|(a, f)| ((f[1] - f[0]) / (a[1] - a[0])).abs())
                .fold(0.0, f64::max),
        }
    }

    /// The size of the coordinate values the law refers to (its rest value, its table's
    /// extent): its force is computed from differences of numbers of that size.
    pub fn reference_magnitude(&self) -> f64 {
        match self {
            SpringLaw::Linear { rest, .. } => rest.abs(),
            SpringLaw::Table { q, .. } => q.iter().fold(0.0f64, |m, v| m.max(v.abs())),
        }
    }

    pub fn energy(&self, x: f64) -> f64 {
        match self {
            SpringLaw::Linear { stiffness, rest } => 0.5 * stiffness * (x - rest).powi(2),
            SpringLaw::Table { q, offset, .. } => {
                // ∫ F from q₀, exact for a piecewise-linear F (trapezoids).
                let j = Self::segment(q, x);
                let mut v = 0.0;
                for k in 0..j {
                    v += 0.5 * (self.force(q[k]) + self.force(q[k + 1])) * (q[k + 1] - q[k]);
                }
                v + 0.5 * (self.force(q[j]) + self.force(x)) * (x - q[j]) - offset
            }
        }
    }

    /// Discrete gradient `(V(b) − V(a))/(b − a)`, without dividing differences of energies:
    /// the mean of F over [a, b], a weighted sum of F at the midpoints of the pieces between
    /// breakpoints (each weight a length ratio in [0, 1]); exact, and `F(a)` when b = a.
    pub fn secant<T: Real>(&self, a: T, b: T) -> T {
        match self {
            SpringLaw::Linear { .. } => self.force((a + b) * 0.5),
            SpringLaw::Table { q, .. } => {
                let (lo, hi) = if a.re() <= b.re() { (a, b) } else { (b, a) };
                let width = hi - lo;
                let mut acc = T::zero();
                let mut start = lo;
                let mut crossed = false;
                // No allocation: this runs inside Newton's loop.
                for &t in q[1..q.len() - 1]
                    .iter()
                    .filter(|&&t| t > lo.re() && t < hi.re())
                {
                    let end = T::cst(t);
                    acc += self.force((start + end) * 0.5) * ((end - start) / width);
                    start = end;
                    crossed = true;
                }
                if !crossed {
                    return self.force((a + b) * 0.5);
                }
                acc + self.force((start + hi) * 0.5) * ((hi - start) / width)
            }
        }
    }
}

/// A spring and damper on a coordinate (`ε = q`).
///
/// EP takes the discrete gradient of the spring energy between i and f (for a linear spring,
/// the force at the mean strain). ED (ed-scheme-notes §3.2, generalised): with the j-strain
/// `ε_j = ε_i + h/6 (q̇_j − q̇_f)`, the f-force is the discrete gradient between j and f,
/// `N̄ = (V(ε_f) − V(ε_j))/(ε_f − ε_j)`, and the j-force `dN = 2 (N̄ − F(ε_j))`; then the step
/// dissipates exactly `D = V(ε_i) − V(ε_j) − F(ε_j)(ε_i − ε_j) ≥ 0` for a force that grows
/// with q (for a linear spring: ½ k (ε_j − ε_i)², N̄ = k ε̄, dN = k(ε_f − ε_j)). Statics: F(ε_f).
/// A damper adds `−c Δq/h`, whose work `−c Δq²/h` is never positive.
#[derive(Clone, Debug)]
pub struct CoordinateSpring {
    pub coord: usize,
    pub law: SpringLaw,
    pub damping: f64,
    unknowns: Vec<usize>,
}

impl CoordinateSpring {
    pub fn new(coord: usize, law: SpringLaw, damping: f64, layout: &Layout) -> Self {
        let mut unknowns = vec![layout.coord_delta(coord)];
        if layout.ed() {
            unknowns.push(layout.coord_jump(coord));
        }
        CoordinateSpring {
            coord,
            law,
            damping,
            unknowns,
        }
    }

    /// ED: the j-strain `ε_j` of a converged step (the local block `y`).
    fn eps_j<T: Real>(&self, ctx: &StepCtx, y: &[T]) -> T {
        let h = ctx.h;
        let qi = ctx.state.coords[self.coord];
        let rate_j = y[1] / h;
        let rate_f = y[0] * (2.0 / h) - rate_j;
        (rate_j - rate_f) * (h / 6.0) + qi
    }

    /// ED: the spring's numerical dissipation over a converged step (zero for EP).
    pub fn dissipation(&self, ctx: &StepCtx, y: &[f64]) -> f64 {
        if !ctx.ed() {
            return 0.0;
        }
        let yl = [y[self.unknowns[0]], y[self.unknowns[1]]];
        let ei = ctx.state.coords[self.coord];
        let ej = self.eps_j(ctx, &yl);
        self.law.energy(ei) - self.law.energy(ej) - self.law.force(ej) * (ei - ej)
    }
}

impl Kernel for CoordinateSpring {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns
    }
    /// The whole block (1 × 1, ED 2 × 2): a piecewise law is flat where the probe happens to
    /// look — end stops exert nothing until the contact point passes a beam's end, and then
    /// wrote their stiffness outside the pattern at every step on the stop.
    fn structure(&self, _ctx: &StepCtx, _y: &[f64]) -> Vec<bool> {
        vec![true; self.unknowns.len().pow(2)]
    }
    /// ED's decoupled system: the spring's exact block (its j-rows are what the complex
    /// system reads, exact for a linear spring) and the damper's f-row term `c/h` projected
    /// onto the complex unknowns. That term is not of the `P⊗M + Q⊗K` form the decoupling
    /// assumes (it sits on the f-row's increment column only); the complex equation's share
    /// of it, `¼ c/h` (ed_decoupled's row weight ¼ of an f-row times the increment's column
    /// weight 1), enters the complex diagonal through the real slot of the j-row's jump
    /// column. Without it the complex system knows no damping, and a damped coordinate's
    /// kept factors contracted by ~c h/2m per iteration instead of ~c h/4m.
    fn evaluate_decoupled(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        self.evaluate(ctx, y, res, Some((&mut *vals, pos)));
        vals[pos[3] as usize] += 0.25 * self.damping / ctx.h;
    }
    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], r: &mut [T]) {
        let h = ctx.h;
        let qi = T::cst(ctx.state.coords[self.coord]);
        let dq = y[0];
        let eps_f = dq + qi;
        if ctx.is_static() {
            // Statics: the spring force at the end state; a damper carries nothing.
            r[0] += self.law.force(eps_f);
            return;
        }
        // Residual rows hold −P (force on the coordinate with the sign of the inertia rows).
        r[0] += dq * (self.damping / h);
        if ctx.ed() {
            let eps_j = self.eps_j(ctx, y);
            let mean = self.law.secant(eps_j, eps_f);
            let dn = (mean - self.law.force(eps_j)) * 2.0;
            r[0] += mean;
            r[1] -= dn / 6.0;
        } else {
            r[0] += self.law.secant(qi, eps_f);
        }
    }
}

/// Prescribed coordinate `q = f(t)`, one constraint row. For a sliding joint the user
/// prescribes η(t) and the coordinate is the element coordinate ζ = ζ(η) (`map`).
#[derive(Clone, Debug)]
pub struct CoordinateDrive {
    pub coord: usize,
    pub row: usize,
    pub function: TimeFunction,
    pub map: Option<ArcMap>,
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
            map: None,
            unknowns,
        }
    }

    /// The prescribed value of the coordinate at `t`.
    pub fn target(&self, t: f64) -> f64 {
        let v = self.function.value(t);
        self.map.as_ref().map_or(v, |m| m.zeta(v))
    }

    /// Its rate (chain rule through the map).
    pub fn target_rate(&self, t: f64) -> f64 {
        let f = self.function.jet(t); // value and rate from one evaluation
        self.map.as_ref().map_or(f.d, |m| f.d * m.dzeta_deta(f.v))
    }

    /// Work done by the drive over a converged step: from the energy identity, the terms the
    /// rheonomic constraint leaves behind (EP: `−λ (f_f − f_i)`; ED adds the velocity-level
    /// term `h/12 λ_d (ḟ_i − ḟ_f)`).
    pub fn step_work(&self, ctx: &StepCtx, y: &[f64]) -> f64 {
        let (ff, fi) = (self.target(ctx.t_f), self.target(ctx.t_i));
        if ctx.ed() {
            let lf = ctx.s * y[self.unknowns[2]];
            let ld = ctx.s * y[self.unknowns[3]];
            let (ri, rf) = (self.target_rate(ctx.t_i), self.target_rate(ctx.t_f));
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
            r[2] += (dq + (qi - self.target(ctx.t_f))) * s;
            let ci = rate_j - self.target_rate(ctx.t_i);
            let cf = rate_f - self.target_rate(ctx.t_f);
            r[3] += (ci - cf) * (s * ctx.h);
        } else {
            r[0] += y[1] * s;
            r[1] += (dq + (qi - self.target(ctx.t_f))) * s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elements::fd_harness::tangent_error;
    use crate::math::layout::Scheme;
    use crate::math::vec3::V3;
    use crate::model::TimeFunctionSpec;
    use crate::state::State;

    /// One coordinate at `q` moving at 1 per second, at t = 0.3 s.
    fn one_coordinate(q: f64) -> State {
        State {
            t: 0.3,
            nodes: vec![],
            coords: vec![q],
            coord_rates: vec![1.0],
            lambda: vec![0.0],
            history: vec![],
        }
    }

    /// A step of 20 ms from t = 0.3 s (a static solve at load factor `statics` if given).
    fn step<'a>(layout: Layout, state: &'a State, statics: Option<f64>) -> StepCtx<'a> {
        StepCtx {
            layout,
            h: 0.02,
            t_i: 0.3,
            t_f: 0.32,
            s: 50.0,
            state,
            gravity: V3([0.0; 3]),
            statics,
        }
    }

    #[test]
    fn spring_and_drive_tangents_match_finite_differences() {
        let state = one_coordinate(0.4);
        // Time steps of both schemes, and static solves (EP layout).
        for (scheme, statics) in [
            (Scheme::Ep, None),
            (Scheme::Ed, None),
            (Scheme::Ep, Some(0.6)),
        ] {
            let layout = Layout::new(scheme, 0, 1, 1);
            let ctx = step(layout, &state, statics);
            let y: Vec<f64> = (0..layout.n_unknowns())
                .map(|i| 0.1 + 0.05 * i as f64)
                .collect();
            let sp = CoordinateSpring::new(
                0,
                SpringLaw::Linear {
                    stiffness: 300.0,
                    rest: 0.1,
                },
                4.0,
                &layout,
            );
            assert!(tangent_error(&sp, &ctx, &y) < 1e-8);
            let f = TimeFunction::new(&TimeFunctionSpec::Expression("sin(3*t)".into())).unwrap();
            let dr = CoordinateDrive::new(0, 0, f, &layout);
            assert!(tangent_error(&dr, &ctx, &y) < 1e-8);
        }
    }

    /// ED's decoupled evaluation of a spring-damper: the exact 2 × 2 block and residual, and
    /// on the j-row's jump column (the real part of the complex diagonal) the damper's share
    /// `¼ c/h` of the complex equation. Fails if the damper is left out of the complex system
    /// again or enters with another weight.
    #[test]
    fn decoupled_spring_damper_adds_the_dampers_projection() {
        let state = one_coordinate(0.4);
        let layout = Layout::new(Scheme::Ed, 0, 1, 0);
        let ctx = step(layout, &state, None);
        let (h, c) = (ctx.h, 4.0);
        let y = vec![0.013, 0.021];
        let law = SpringLaw::Linear {
            stiffness: 300.0,
            rest: 0.1,
        };
        let sp = CoordinateSpring::new(0, law, c, &layout);
        let pos = crate::elements::own_block_positions(2);
        let (mut exact, mut decoupled) = (vec![0.0; 4], vec![0.0; 4]);
        let (mut r_exact, mut r_decoupled) = (vec![0.0; 2], vec![0.0; 2]);
        sp.evaluate(&ctx, &y, &mut r_exact, Some((&mut exact, &pos)));
        sp.evaluate_decoupled(&ctx, &y, &mut r_decoupled, &mut decoupled, &pos);
        assert_eq!(r_exact, r_decoupled);
        exact[3] += 0.25 * c / h;
        assert_eq!(exact, decoupled);
    }

    fn table() -> SpringLaw {
        SpringLaw::table(vec![-0.5, 0.0, 0.2, 0.6], vec![-30.0, 0.0, 10.0, 90.0])
    }

    #[test]
    fn table_energy_is_zero_where_the_force_vanishes() {
        let law = SpringLaw::table(vec![-1.0, 1.0, 3.0], vec![-2.0, 2.0, 10.0]);
        assert!(law.energy(0.0).abs() < 1e-15);
        assert!(law.energy(2.0) > 0.0 && law.energy(-0.5) > 0.0);
    }

    #[test]
    fn table_secant_is_the_exact_discrete_gradient_of_its_energy() {
        let law = table();
        // Pairs inside one segment, across one or several breakpoints, and beyond the ends.
        for (a, b) in [
            (0.05, 0.15),
            (-0.2, 0.1),
            (-0.7, 0.9),
            (0.9, 0.3),
            (0.2, 0.2),
            (0.3, 0.3 + 1e-12),
        ] {
            let sec = law.secant(a, b);
            if a == b {
                assert_eq!(sec, law.force(a));
                continue;
            }
            let exact = (law.energy(b) - law.energy(a)) / (b - a);
            // The energy quotient itself loses ~1e-16·V/|b − a|: that is the bound.
            let tol = 1e-14 * (1.0 + law.energy(a).abs() / (b - a).abs());
            assert!((sec - exact).abs() < tol, "{a} {b}: {sec} vs {exact}");
        }
    }

    #[test]
    fn table_spring_tangents_match_finite_differences_across_breakpoints() {
        let state = one_coordinate(0.15);
        for (scheme, statics) in [
            (Scheme::Ep, None),
            (Scheme::Ed, None),
            (Scheme::Ep, Some(0.6)),
        ] {
            let layout = Layout::new(scheme, 0, 1, 0);
            let ctx = step(layout, &state, statics);
            // Δq = 0.3 crosses the breakpoint at 0.2; the j-strain sits elsewhere.
            let y = vec![0.3, 0.011];
            let sp = CoordinateSpring::new(0, table(), 2.0, &layout);
            let e = tangent_error(&sp, &ctx, &y[..layout.n_unknowns()]);
            assert!(e < 1e-7, "{scheme:?} {statics:?}: {e}");
        }
    }
}
