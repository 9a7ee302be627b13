//! Inertia of a node carrying rigid-body mass `m` and material inertia `J` about its centre of
//! mass, plus gravity (an affine potential, so it has no jump term).
//!
//! EP (Simo–Wong midpoint, DESIGN §8.2): `x_f − x_i = h(v_i + v_f)/2`, `R_f = R_i cay(r)` with
//! `r = h(W_i + W_f)/2`, `m(v_f − v_i) = h P`, and `J(W_f − W_i) + ½ r̃ J(W_f + W_i) = h(I − r̃/2) P`,
//! which is the spatial angular-momentum balance `R_f J W_f = R_i J W_i + h R_i P`.
//! ED (strain-rate-jump form, ed-scheme-notes §3.3): the same f-equations with
//! `Δ = h(V_j + V_f)/2`, plus the j-equations `m(v_j − v_i) = h/6 P_j` and
//! `J(W_j − W_i) + ½ r̃_j J(W_j + W_i) = h/6 (I − r̃_j/2) P_j`, `r_j = h/6 (W_j − W_f)`.
//! Rows are premultiplied by `(I − r̃/2)⁻¹/h` so that every other kernel adds plain forces.
//! In statics the weight remains and, for a node given an initial spin, the inertia of that
//! steady rotation (centrifugal force and gyroscopic moment): the static solution is then the
//! rotor's equilibrium in the frame turning with it, from which it spins steadily.

use super::{add3, v3, Kernel, StepCtx, ValuePos};
use crate::math::rotation::{inv_i_minus_half_tilde, rotate_material};
use crate::math::scalar::Real;
use crate::math::vec3::{M3, V3};
use crate::math::wide::wide;

/// A steady rotation at angular velocity `omega` (inertial frame, rad/s) about the axis through
/// `center`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SteadySpin {
    pub omega: V3<f64>,
    pub center: V3<f64>,
}

#[derive(Clone, Debug)]
pub struct NodeInertia {
    pub node: usize,
    pub mass: f64,
    /// Material inertia about the centre of mass (the node).
    pub inertia: M3<f64>,
    /// The node's initial spin: in statics, the inertia of that steady rotation.
    pub spin: Option<SteadySpin>,
    unknowns: Vec<usize>,
}

impl NodeInertia {
    /// Adds the 3×3 block `blk` at local (`row`, `col`) of the kernel's tangent (a method,
    /// not a closure: closures are not inlined into wide kernels).
    #[inline(always)]
    fn put(&self, vals: &mut [f64], pos: &[ValuePos], row: usize, col: usize, blk: &M3<f64>) {
        let n = self.unknowns.len();
        for (i, bi) in blk.0.iter().enumerate() {
            for (k, v) in bi.iter().enumerate() {
                vals[pos[(row + i) * n + col + k] as usize] += v;
            }
        }
    }

    pub fn new(
        node: usize,
        mass: f64,
        inertia: M3<f64>,
        spin: Option<SteadySpin>,
        layout: &crate::math::layout::Layout,
    ) -> Self {
        let mut unknowns: Vec<usize> = (0..6).map(|k| layout.node_delta(node) + k).collect();
        if layout.ed() {
            unknowns.extend((0..6).map(|k| layout.node_jump(node) + k));
        }
        NodeInertia {
            node,
            mass,
            inertia,
            spin,
            unknowns,
        }
    }
}

/// `(I − r̃/2)⁻¹ [J (W_b − W_a) + ½ r̃ J (W_b + W_a)] / h`: the rotational momentum row.
#[inline(always)]
fn rotational_row<T: Real>(j: &M3<T>, r: &V3<T>, wa: &V3<T>, wb: &V3<T>, h: f64) -> V3<T> {
    let dw = j.mul_v(&(*wb - *wa));
    let gyro = r.cross(&j.mul_v(&(*wb + *wa))).scale_f(0.5);
    inv_i_minus_half_tilde(r)
        .mul_v(&(dw + gyro))
        .scale_f(1.0 / h)
}

/// [`rotational_row`] `f = B(ρ) z / h` with its derivatives `(∂f/∂ρ, ∂f/∂W_b)`, where
/// `B = (I − ρ̃/2)⁻¹` and `z = J (W_b − W_a) + ½ ρ̃ J (W_b + W_a)`: from `dB = ½ B δ̃ B`,
/// `∂f/∂ρ = B (−½ (J(W_b + W_a))~ − ½ (B z)~)/h` and `∂f/∂W_b = B (J + ½ ρ̃ J)/h`.
#[inline(always)]
fn rotational_row_jacobian(
    j: &M3<f64>,
    rho: &V3<f64>,
    wa: &V3<f64>,
    wb: &V3<f64>,
    h: f64,
) -> (V3<f64>, M3<f64>, M3<f64>) {
    let b = inv_i_minus_half_tilde(rho);
    let js = j.mul_v(&(*wb + *wa));
    let z = j.mul_v(&(*wb - *wa)) + rho.cross(&js).scale_f(0.5);
    let bz = b.mul_v(&z);
    let d_rho = b.mul_m(&(js.tilde() + bz.tilde())).scale_f(-0.5 / h);
    let d_wb = b
        .mul_m(&(*j + rho.tilde().mul_m(j).scale_f(0.5)))
        .scale_f(1.0 / h);
    (bz.scale_f(1.0 / h), d_rho, d_wb)
}

impl Kernel for NodeInertia {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns
    }

    /// Time steps: the translational rows are linear (`2m/h²` on Δx; under ED `∓m/h²` on the
    /// jump) and the rotational rows depend on `r` (and under ED `h W_j`) only, both written
    /// in closed form ([`rotational_row_jacobian`]); statics take the generic dual pass.
    fn evaluate(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        jac: Option<(&mut [f64], &[ValuePos])>,
    ) {
        match jac {
            Some(jac) if !ctx.is_static() => wide(
                #[inline(always)]
                || self.step_tangent(ctx, y, res, jac, false),
            ),
            jac => super::eval_kernel(self, ctx, y, res, jac),
        }
    }

    /// ED's decoupled system reads a node's j-rows only: the f-rows' blocks (half the
    /// rotational work) are skipped.
    fn evaluate_decoupled(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        debug_assert!(ctx.ed());
        wide(
            #[inline(always)]
            || self.step_tangent(ctx, y, res, (vals, pos), true),
        )
    }

    #[inline(always)]
    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], res: &mut [T]) {
        if let Some(lf) = ctx.statics {
            add3(
                res,
                0,
                V3::<T>::from_f64(ctx.gravity.scale_f(-self.mass * lf)),
            );
            if let Some(spin) = &self.spin {
                // Steady rotation of the end state: m a = m Ω×(Ω×(x − c)), and the rate of
                // the angular momentum R J Rᵀ Ω, Ω×(R J Rᵀ Ω), in the material rows (Rᵀ·):
                // W×(J W), W = Rᵀ Ω. Times the load factor (Ω² ramps with the loads).
                let ni = &ctx.state.nodes[self.node];
                let omega = V3::<T>::from_f64(spin.omega);
                let arm = V3::<T>::from_f64(ni.x - spin.center) + v3(y, 0);
                add3(
                    res,
                    0,
                    omega.cross(&omega.cross(&arm)).scale_f(self.mass * lf),
                );
                let rf = rotate_material(&ni.r, &v3(y, 3));
                let w = rf.tmul_v(&omega);
                let j = M3::<T>::from_f64(&self.inertia);
                add3(res, 3, w.cross(&j.mul_v(&w)).scale_f(lf));
            }
            return;
        }
        let h = ctx.h;
        let ni = &ctx.state.nodes[self.node];
        let j = M3::<T>::from_f64(&self.inertia);
        let wi = V3::<T>::from_f64(ni.w);
        self.translational_rows(ctx, y, res);
        let (ws, wf) = self.angular_velocities(ctx, y);
        add3(res, 3, rotational_row(&j, &v3(y, 3), &wi, &wf, h));
        if ctx.ed() {
            let rj = (ws - wf).scale_f(h / 6.0);
            add3(res, 9, rotational_row(&j, &rj, &wi, &ws, h));
        }
    }
}

impl NodeInertia {
    /// The momentum rows of translation (f, and under ED j), which are linear:
    /// `m (v_f − v_i)/h − m g` and `m (v_j − v_i)/h`.
    #[inline(always)]
    fn translational_rows<T: Real>(&self, ctx: &StepCtx, y: &[T], res: &mut [T]) {
        let (h, m) = (ctx.h, self.mass);
        let vi = V3::<T>::from_f64(ctx.state.nodes[self.node].v);
        // Velocities at f from Δ = h (V_start + V_f)/2, V_start = V_i (EP) or V_j (ED).
        let vs = if ctx.ed() {
            v3(y, 6).scale_f(1.0 / h)
        } else {
            vi
        };
        let vf = v3(y, 0).scale_f(2.0 / h) - vs;
        let g = V3::<T>::from_f64(ctx.gravity.scale_f(m));
        add3(res, 0, (vf - vi).scale_f(m / h) - g);
        if ctx.ed() {
            add3(res, 6, (vs - vi).scale_f(m / h));
        }
    }

    /// `(W_start, W_f)`: the material angular velocities the step starts from (`W_i` under
    /// EP, `W_j = y_9/h` under ED) and ends at, `W_f = 2r/h − W_start`.
    #[inline(always)]
    fn angular_velocities<T: Real>(&self, ctx: &StepCtx, y: &[T]) -> (V3<T>, V3<T>) {
        let h = ctx.h;
        let ws = if ctx.ed() {
            v3(y, 9).scale_f(1.0 / h)
        } else {
            V3::<T>::from_f64(ctx.state.nodes[self.node].w)
        };
        (ws, v3(y, 3).scale_f(2.0 / h) - ws)
    }
}

impl NodeInertia {
    /// See [`Kernel::evaluate`]. With `W_f = 2r/h − W_s` (`W_s` = `W_i` under EP, `W_j =
    /// y_9/h` under ED) and ED's `r_j = h (W_j − W_f)/6 = (y_9 − r)/3`, the rotational rows'
    /// derivatives follow from those of [`rotational_row_jacobian`] by the chain rule.
    /// With `j_rows_only` (ED's decoupled system, which reads no f-row of a motion pair),
    /// the f-rows' blocks are neither formed nor written.
    #[inline(always)]
    fn step_tangent(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        (vals, pos): (&mut [f64], &[ValuePos]),
        j_rows_only: bool,
    ) {
        let n = self.unknowns.len();
        let yl = y_local(self, y);
        // The residual's rows, the rotational ones from the evaluations that also give
        // their derivatives (the same arithmetic as `residual`).
        let mut rl = [0.0; 12];
        self.translational_rows(ctx, &yl[..n], &mut rl[..n]);
        let h = ctx.h;
        let k = M3::<f64>::identity().scale_f(self.mass / (h * h));
        let (wi, r) = (ctx.state.nodes[self.node].w, v3(&yl, 3));
        let (ws, wf) = self.angular_velocities(ctx, &yl);
        if !ctx.ed() {
            self.put(vals, pos, 0, 0, &k.scale_f(2.0));
            let (row, d_rho, d_wb) = rotational_row_jacobian(&self.inertia, &r, &wi, &wf, h);
            add3(&mut rl, 3, row);
            self.put(vals, pos, 3, 3, &(d_rho + d_wb.scale_f(2.0 / h)));
            self.add_rows(&rl[..n], res);
            return;
        }
        self.put(vals, pos, 6, 6, &k);
        if j_rows_only {
            add3(&mut rl, 3, rotational_row(&self.inertia, &r, &wi, &wf, h));
        } else {
            self.put(vals, pos, 0, 0, &k.scale_f(2.0));
            self.put(vals, pos, 0, 6, &k.scale_f(-1.0));
            let (row, d_rho, d_wb) = rotational_row_jacobian(&self.inertia, &r, &wi, &wf, h);
            add3(&mut rl, 3, row);
            self.put(vals, pos, 3, 3, &(d_rho + d_wb.scale_f(2.0 / h)));
            self.put(vals, pos, 3, 9, &d_wb.scale_f(-1.0 / h));
        }
        let rj = (ws - wf).scale_f(h / 6.0);
        let (row, d_rho, d_wb) = rotational_row_jacobian(&self.inertia, &rj, &wi, &ws, h);
        add3(&mut rl, 9, row);
        self.add_rows(&rl[..n], res);
        self.put(vals, pos, 9, 3, &d_rho.scale_f(-1.0 / 3.0));
        self.put(
            vals,
            pos,
            9,
            9,
            &(d_rho.scale_f(1.0 / 3.0) + d_wb.scale_f(1.0 / h)),
        );
    }
}

impl NodeInertia {
    /// Adds the kernel's local rows `rl` to the global residual.
    #[inline(always)]
    fn add_rows(&self, rl: &[f64], res: &mut [f64]) {
        for (&g, r) in self.unknowns.iter().zip(rl) {
            res[g] += r;
        }
    }
}

/// The kernel's unknowns gathered from the global vector.
fn y_local(k: &NodeInertia, y: &[f64]) -> [f64; 12] {
    let mut yl = [0.0; 12];
    for (l, &g) in k.unknowns.iter().enumerate() {
        yl[l] = y[g];
    }
    yl
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elements::fd_harness::tangent_error;
    use crate::math::layout::Layout;
    use crate::math::layout::Scheme;
    use crate::state::{NodeState, State};

    /// A general inertia tensor and a node turned and moving in every direction.
    fn moving_node() -> (M3<f64>, State) {
        let jm = M3([[2.0, 0.1, -0.2], [0.1, 3.0, 0.3], [-0.2, 0.3, 4.0]]);
        let node = NodeState {
            x: V3([0.1, 0.2, 0.3]),
            r: crate::math::rotation::exp_map(&V3([0.4, -0.2, 0.9])),
            v: V3([1.0, -2.0, 0.5]),
            w: V3([0.3, 5.0, -1.0]),
        };
        (jm, State::of_nodes(vec![node]))
    }

    /// A step of 10 ms from `state` (a static solve at load factor `statics` if given), under
    /// gravity along −z, and unknowns away from zero in every component.
    fn step<'a>(layout: Layout, state: &'a State, statics: Option<f64>) -> (StepCtx<'a>, Vec<f64>) {
        let ctx = StepCtx {
            layout,
            h: 0.01,
            t_i: 0.0,
            t_f: 0.01,
            s: 1.0,
            state,
            gravity: V3([0.0, 0.0, -9.81]),
            statics,
        };
        let y = (0..layout.n_unknowns())
            .map(|i| 0.01 * ((i as f64) * 0.7).sin())
            .collect();
        (ctx, y)
    }

    #[test]
    fn tangent_matches_finite_differences_ep_and_ed() {
        let (jm, state) = moving_node();
        // Time steps of both schemes, and static solves (EP layout).
        // Static solves also with a steady spin (centrifugal and gyroscopic terms).
        let spin = SteadySpin {
            omega: V3([0.3, -1.2, 2.0]),
            center: V3([0.5, 0.1, -0.4]),
        };
        for (scheme, statics, spin) in [
            (Scheme::Ep, None, None),
            (Scheme::Ed, None, None),
            (Scheme::Ep, Some(0.6), None),
            (Scheme::Ep, Some(0.6), Some(spin)),
        ] {
            let layout = Layout::new(scheme, 1, 0, 0);
            let k = NodeInertia::new(0, 1.7, jm, spin, &layout);
            let (ctx, y) = step(layout, &state, statics);
            let e = tangent_error(&k, &ctx, &y);
            // Central differences with step 1e-6: truncation ~1e-12·|J'''|, round-off ~1e-10·|R|/|J|.
            assert!(e < 1e-7, "{scheme:?}: {e}");
        }
    }

    /// ED's decoupled evaluation: the same residual, the exact tangent's j-rows (the rows the
    /// decoupled complex system reads) to round-off, and nothing in the f-rows, which it
    /// skips. Fails if a j-row block is dropped or an f-row one still written.
    #[test]
    fn decoupled_evaluation_writes_the_exact_j_rows_only() {
        let (jm, state) = moving_node();
        let layout = Layout::new(Scheme::Ed, 1, 0, 0);
        let k = NodeInertia::new(0, 1.7, jm, None, &layout);
        let (ctx, y) = step(layout, &state, None);
        let pos = crate::elements::own_block_positions(12);
        let (mut exact, mut decoupled) = (vec![0.0; 144], vec![0.0; 144]);
        let (mut r_exact, mut r_decoupled) = (vec![0.0; 12], vec![0.0; 12]);
        k.evaluate(&ctx, &y, &mut r_exact, Some((&mut exact, &pos)));
        k.evaluate_decoupled(&ctx, &y, &mut r_decoupled, &mut decoupled, &pos);
        assert_eq!(r_exact, r_decoupled);
        let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..12 {
            for j in 0..12 {
                let (e, d) = (exact[i * 12 + j], decoupled[i * 12 + j]);
                // The j-rows (6..12) come from the same closed forms: equal to round-off.
                let want = if i >= 6 { e } else { 0.0 };
                assert!(
                    (d - want).abs() <= 1e-14 * scale,
                    "({i}, {j}): {d} vs {want}"
                );
            }
        }
        assert!(
            exact[..72].iter().any(|v| *v != 0.0),
            "the f-rows are not empty"
        );
    }

    /// The steady-spin terms of a static solve are the limit, as h → 0, of the time step's
    /// inertia rows over an exact steady rotation: same sign, same form (a test against the
    /// dynamic kernel, which the energy tests verify independently).
    #[test]
    fn steady_spin_inertia_is_the_limit_of_a_time_step_of_steady_rotation() {
        let jm = M3([[2.0, 0.1, -0.2], [0.1, 3.0, 0.3], [-0.2, 0.3, 4.0]]);
        let spin = SteadySpin {
            omega: V3([0.3, -1.2, 2.0]),
            center: V3([0.5, 0.1, -0.4]),
        };
        let (x, r) = (
            V3([0.1, 0.2, 0.3]),
            crate::math::rotation::exp_map(&V3([0.4, -0.2, 0.9])),
        );
        let node = NodeState {
            x,
            r,
            v: spin.omega.cross(&(x - spin.center)),
            w: r.tmul_v(&spin.omega),
        };
        let state = State::of_nodes(vec![node]);
        let layout = Layout::new(Scheme::Ep, 1, 0, 0);
        let k = NodeInertia::new(0, 1.7, jm, Some(spin), &layout);
        let h = 1e-5;
        let ctx = |statics| StepCtx {
            layout,
            h,
            t_i: 0.0,
            t_f: h,
            s: 1.0,
            state: &state,
            gravity: V3::zero(),
            statics,
        };
        let mut steady = [0.0; 6];
        k.residual(&ctx(Some(1.0)), &[0.0; 6], &mut steady);
        // The exact rotation over h: x_f − c = Q (x − c), R_f = Q R = R cay(r).
        let q = crate::math::rotation::exp_map(&spin.omega.scale_f(h));
        let dx = q.mul_v(&(x - spin.center)) - (x - spin.center);
        let rc = crate::math::rotation::cayley_log(&r.transpose().mul_m(&q).mul_m(&r)).unwrap();
        let mut y = [0.0; 6];
        dx.write_to(&mut y[..3]);
        rc.write_to(&mut y[3..]);
        let mut step = [0.0; 6];
        k.residual(&ctx(None), &y, &mut step);
        let scale = steady.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        for (a, b) in steady.iter().zip(&step) {
            // The step's rows are centred mid-step: they differ by O(hΩ) relative.
            assert!((a - b).abs() < 1e-4 * scale, "{steady:?} vs {step:?}");
        }
    }
}
