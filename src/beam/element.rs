//! The geometrically exact beam element (Reissner/Simo, shear deformable) with the EP and ED
//! discretisations of its elastic forces (DESIGN §8.3, ed-scheme-notes §5.4, generalised to
//! 2-, 3- and 4-node elements).
//!
//! Rotations are interpolated *incrementally*: the spatial nodal Cayley increments
//! `ρ^α = R^α_i r^α` are interpolated, `ρ(s) = h^α ρ^α`, and each Gauss point carries its own
//! triad `R_g` and curvature `k*` as history, updated by the exact Cayley identities
//! `R_g,f = cay(ρ_g) R_g,i` and `k*_f = k*_i + R_mᵀ H ρ′` with `R_m = (R_g,i + R_g,f)/2` and
//! `H = I − ρρᵀ/(4 + ρᵀρ)`. The strains `e* = R_gᵀ x′ − ī₁ − e₀`, `κ = k* − k₀` then satisfy
//! `e*_f − e*_i = R_mᵀ(Δx′ + x̃′_a ρ_g)` exactly, so with the mean sectional forces
//! `N_m = C (ε_i + ε_f)/2` the work of the internal forces over a step is `U_f − U_i`.
//! Inertia is lumped at the nodes (the rigid-body kernel). In statics the element adds
//! `∫ B(q_f)ᵀ C ε_f ds`, the exact gradient of its strain energy.

use super::section::Mat6;
use super::shape::MAX_NODES;
use crate::elements::{add3, v3, Kernel, StepCtx, ValuePos};
use crate::math::layout::Layout;
use crate::math::rotation::{cayley, cayley_rotate};
use crate::math::scalar::Real;
use crate::math::vec3::{M3, V3};

/// History entries per Gauss point: the triad (9, row-major) and the curvature k* (3).
pub const HISTORY_PER_POINT: usize = 12;

/// Node quantities of the chain rule through the Gauss points (spatial):
/// `Δx, ρ = R_i r, v_j, ω_j, v_f, ω_f` (the last four under ED only).
pub(super) const Q_GROUPS: usize = 6;
/// Point inputs: `Δx′, ρ, ρ′, v_j′, ω_j, ω_j′, v_f′, ω_f, ω_f′`.
pub(super) const P_GROUPS: usize = 9;
/// Each point input as (node quantity, true: Σ h′ᵅ · / false: Σ hᵅ ·).
pub(super) const P_FROM: [(usize, bool); P_GROUPS] = [
    (0, true),
    (1, false),
    (1, true),
    (2, true),
    (3, false),
    (3, true),
    (4, true),
    (5, false),
    (5, true),
];
/// Point outputs: `[ne, arm, nk]` of the groups D (discrete gradient, moments at i),
/// I (rate form at i) and F (rate form at f, moments through the nodes' R_f).
pub(super) const O_GROUPS: usize = 9;
/// Row quantities of a node before its rotations: f-force, f-moment (R_iᵀ), f-moment (R_fᵀ),
/// j-force, j-moment (R_iᵀ).
pub(super) const U_GROUPS: usize = 5;
/// Each row quantity as Σ sign · (h′ᵅ if true, else hᵅ) · output.
pub(super) const U_FROM: [&[(usize, bool, f64)]; U_GROUPS] = [
    &[(0, true, 1.0), (3, true, 1.0), (6, true, -1.0)],
    &[
        (1, false, 1.0),
        (4, false, 1.0),
        (2, true, 1.0),
        (5, true, 1.0),
    ],
    &[(7, false, -1.0), (8, true, -1.0)],
    &[(3, true, 1.0), (6, true, 1.0)],
    &[(4, false, 1.0), (5, true, 1.0)],
];

#[derive(Clone, Debug)]
pub struct GaussPoint {
    /// Parent coordinate ξ of the point.
    pub xi: f64,
    /// Quadrature weight times ds/dξ: integrates over arc length.
    pub weight: f64,
    /// Shape functions and their arc-length derivatives at the point.
    pub h: [f64; MAX_NODES],
    pub dh: [f64; MAX_NODES],
    /// Sectional stiffness at the point (section frame).
    pub stiffness: Mat6,
    /// Strains of the unloaded reference configuration (pre-curvature, pre-twist).
    pub e0: V3<f64>,
    pub k0: V3<f64>,
    /// Sectional damping matrix D (section frame, N·s per unit strain rate), if damped:
    /// viscous sectional forces `D ε̇`.
    pub damping: Option<Mat6>,
}

#[derive(Clone, Debug)]
pub struct BeamElement {
    pub name: String,
    /// Global node indices, in order along the element.
    pub nodes: Vec<usize>,
    pub points: Vec<GaussPoint>,
    /// Offset of the element's history in `State::history`.
    pub history: usize,
    /// Mass-proportional damping per node: `α m` (kg/s) and `α J` (N·m·s, the node's triad)
    /// of this element's share of the lumped inertia; empty if undamped.
    pub mass_damping: Vec<(f64, M3<f64>)>,
    unknowns: Vec<usize>,
}

/// A Gauss point's triad and curvature read from the history.
pub fn read_history(h: &[f64]) -> (M3<f64>, V3<f64>) {
    let r = M3([[h[0], h[1], h[2]], [h[3], h[4], h[5]], [h[6], h[7], h[8]]]);
    (r, V3([h[9], h[10], h[11]]))
}

pub fn write_history(h: &mut [f64], r: &M3<f64>, k: &V3<f64>) {
    for i in 0..3 {
        for j in 0..3 {
            h[3 * i + j] = r.0[i][j];
        }
    }
    h[9..12].copy_from_slice(&k.0);
}

/// Mid-point kinematics of one Gauss point over a step.
pub(super) struct PointStep<T> {
    /// Strains at i and f, `[e*, κ]` relative to the reference.
    pub(super) eps_i: [T; 6],
    pub(super) eps_f: [T; 6],
    pub(super) rg_i: M3<T>,
    pub(super) rg_f: M3<T>,
    pub(super) rm: M3<T>,
    pub(super) hm: M3<T>,
    pub(super) xp_i: V3<T>,
    pub(super) xp_f: V3<T>,
}

#[inline(always)]
pub(super) fn mat6_mul<T: Real>(c: &Mat6, e: &[T; 6]) -> [T; 6] {
    let mut n = [T::zero(); 6];
    for (i, ni) in n.iter_mut().enumerate() {
        for (j, ej) in e.iter().enumerate() {
            *ni += *ej * c[i][j];
        }
    }
    n
}

impl BeamElement {
    pub fn new(
        name: String,
        nodes: Vec<usize>,
        points: Vec<GaussPoint>,
        history: usize,
        layout: &Layout,
    ) -> Self {
        assert!(
            (2..=MAX_NODES).contains(&nodes.len()),
            "beam elements have 2 to 4 nodes"
        );
        let mut unknowns = Vec::new();
        for &a in &nodes {
            unknowns.extend((0..6).map(|k| layout.node_delta(a) + k));
            if layout.ed() {
                unknowns.extend((0..6).map(|k| layout.node_jump(a) + k));
            }
        }
        BeamElement {
            name,
            nodes,
            points,
            history,
            mass_damping: Vec::new(),
            unknowns,
        }
    }

    pub fn history_len(&self) -> usize {
        self.points.len() * HISTORY_PER_POINT
    }

    fn per(ctx: &StepCtx) -> usize {
        if ctx.ed() {
            12
        } else {
            6
        }
    }

    /// Kinematics of Gauss point `g` from the i-state, its history and the local increments.
    #[cfg(test)]
    fn point_step<T: Real>(&self, ctx: &StepCtx, g: usize, y: &[T]) -> PointStep<T> {
        self.point_steps(ctx, y)
            .nth(g)
            .expect("a Gauss point of the element")
    }

    /// Every Gauss point's kinematics in order, the node quantities computed once.
    fn point_steps<'a, T: Real + 'a>(
        &'a self,
        ctx: &'a StepCtx,
        y: &[T],
    ) -> impl Iterator<Item = PointStep<T>> + 'a {
        let q = self.node_quantities(ctx, y);
        (0..self.points.len()).map(move |g| {
            let p = self.point_inputs(g, &q);
            self.point_kinematics(ctx, g, &p[0], &p[1], &p[2])
        })
    }

    /// Kinematics of Gauss point `g` from the interpolated increments `Δx′`, `ρ` and `ρ′`.
    #[inline(always)]
    pub(super) fn point_kinematics<T: Real>(
        &self,
        ctx: &StepCtx,
        g: usize,
        dxp: &V3<T>,
        rho: &V3<T>,
        rho_p: &V3<T>,
    ) -> PointStep<T> {
        let p = &self.points[g];
        let hist = &ctx.state.history[self.history + g * HISTORY_PER_POINT..];
        let (rg_i64, k_i64) = read_history(hist);
        let rg_i = M3::<T>::from_f64(&rg_i64);
        let mut xp_i = V3::<f64>::zero();
        for (a, &node) in self.nodes.iter().enumerate() {
            xp_i += ctx.state.nodes[node].x.scale_f(p.dh[a]);
        }
        let xp_i = V3::<T>::from_f64(xp_i);
        let xp_f = xp_i + *dxp;
        let rg_f = cayley(rho).mul_m(&rg_i);
        let rm = (rg_i + rg_f).scale_f(0.5);
        let hm = M3::identity() - rho.outer(rho).scale(T::one() / (rho.norm_sq() + 4.0));
        let e1 = V3::<T>::new(T::one(), T::zero(), T::zero());
        let e_i = rg_i.tmul_v(&xp_i) - e1 - V3::from_f64(p.e0);
        let e_f = rg_f.tmul_v(&xp_f) - e1 - V3::from_f64(p.e0);
        let k_i = V3::<T>::from_f64(k_i64) - V3::from_f64(p.k0);
        let k_f = k_i + rm.tmul_v(&hm.mul_v(rho_p));
        let mut eps_i = [T::zero(); 6];
        let mut eps_f = [T::zero(); 6];
        e_i.write_to(&mut eps_i[..3]);
        k_i.write_to(&mut eps_i[3..]);
        e_f.write_to(&mut eps_f[..3]);
        k_f.write_to(&mut eps_f[3..]);
        PointStep {
            eps_i,
            eps_f,
            rg_i,
            rg_f,
            rm,
            hm,
            xp_i,
            xp_f,
        }
    }

    /// Spatial node quantities `[Δx, ρ = R_i r, v_j, ω_j = R_i W_j, v_f, ω_f = R_f W_f]` of
    /// each node (the last four under ED only; the jump velocities are carried as h·V_j).
    #[inline(always)]
    pub(super) fn node_quantities<T: Real>(
        &self,
        ctx: &StepCtx,
        y: &[T],
    ) -> [[V3<T>; Q_GROUPS]; MAX_NODES] {
        let per = Self::per(ctx);
        let mut q = [[V3::<T>::zero(); Q_GROUPS]; MAX_NODES];
        for (a, &node) in self.nodes.iter().enumerate() {
            let ri = M3::<T>::from_f64(&ctx.state.nodes[node].r);
            let r = v3(y, per * a + 3);
            q[a][0] = v3(y, per * a);
            q[a][1] = ri.mul_v(&r);
            if ctx.ed() {
                let inv_h = 1.0 / ctx.h;
                let vj = v3(y, per * a + 6).scale_f(inv_h);
                let wj = v3(y, per * a + 9).scale_f(inv_h);
                q[a][2] = vj;
                q[a][3] = ri.mul_v(&wj);
                q[a][4] = q[a][0].scale_f(2.0 * inv_h) - vj;
                // R_f W_f = R_i cay(r)(2r/h − W_j) = R_i (2r/h − cay(r) W_j).
                q[a][5] = ri.mul_v(&(r.scale_f(2.0 * inv_h) - cayley_rotate(&r, &wj)));
            }
        }
        q
    }

    /// The point inputs (see [`P_FROM`]) of Gauss point `g`.
    #[inline(always)]
    pub(super) fn point_inputs<T: Real>(
        &self,
        g: usize,
        q: &[[V3<T>; Q_GROUPS]; MAX_NODES],
    ) -> [V3<T>; P_GROUPS] {
        let p = &self.points[g];
        // Node by node over whole groups: a node's quantities are 18 contiguous numbers, so
        // the sums vectorize (input by input, strided over the nodes, they did not).
        let mut at = [V3::<T>::zero(); Q_GROUPS];
        let mut along = [V3::<T>::zero(); Q_GROUPS];
        for (a, qa) in q.iter().enumerate().take(self.nodes.len()) {
            let (h, dh) = (p.h[a], p.dh[a]);
            for k in 0..Q_GROUPS {
                along[k] += qa[k].scale_f(dh);
            }
            // Only the quantities interpolated themselves (ρ, ω_j, ω_f).
            for &(k, derivative) in &P_FROM {
                if !derivative {
                    at[k] += qa[k].scale_f(h);
                }
            }
        }
        // A plain loop, not `array::from_fn`: its closure is not inlined into wide kernels.
        let mut inputs = [V3::<T>::zero(); P_GROUPS];
        for (s, &(from, derivative)) in inputs.iter_mut().zip(&P_FROM) {
            *s = if derivative { along[from] } else { at[from] };
        }
        inputs
    }

    /// The forces of Gauss point `g` as the outputs `[ne, arm, nk]` of three groups (see
    /// [`O_GROUPS`]); `deps_j` is added to the ED strain jump state ε_j (zero, but seeded to
    /// obtain `∂/∂ε_j` for the tangent).
    /// - EP (D only): the mean sectional forces `C(ε_i + ε_f)/2` through the exact discrete
    ///   gradient: `ne = w R_m n`, `nk = w H R_m m`, `arm = ne × (x′_i + x′_f)/2`.
    /// - ED (ed-scheme-notes §3.2): `ε_j = ε_i + h/6 (B_i V_j − B_f V_f)`, D with
    ///   `N̄ = C(ε_j + ε_f)/2`; I and F are the rate forms `B(q)ᵀ(−dN/12)` at i and f, with
    ///   `dN = C(ε_f − ε_j)`: `ne = w R_g n`, `nk = w R_g m`, `arm = ne × x′`.
    /// - Statics: F with `−C ε_f` (so that the f-rows receive `B(q_f)ᵀ C ε_f`).
    #[inline(always)]
    pub(super) fn point_outputs<T: Real>(
        &self,
        ctx: &StepCtx,
        g: usize,
        p: &[V3<T>; P_GROUPS],
        deps_j: &[T; 6],
    ) -> [V3<T>; O_GROUPS] {
        let ps = self.point_kinematics(ctx, g, &p[0], &p[1], &p[2]);
        self.point_outputs_at(ctx, g, &ps, p, deps_j)
    }

    /// [`BeamElement::point_outputs`] from the point's kinematics `ps` (of the inputs `p`).
    #[inline(always)]
    pub(super) fn point_outputs_at<T: Real>(
        &self,
        ctx: &StepCtx,
        g: usize,
        ps: &PointStep<T>,
        p: &[V3<T>; P_GROUPS],
        deps_j: &[T; 6],
    ) -> [V3<T>; O_GROUPS] {
        let pt = &self.points[g];
        let c = &pt.stiffness;
        let w = pt.weight;
        let mut o = [V3::<T>::zero(); O_GROUPS];
        let rate_form = |o: &mut [V3<T>], rg: &M3<T>, xp: &V3<T>, n: &[T; 6]| {
            o[0] = rg.mul_v(&V3([n[0], n[1], n[2]])).scale_f(w);
            o[2] = rg.mul_v(&V3([n[3], n[4], n[5]])).scale_f(w);
            o[1] = o[0].cross(xp);
        };
        if ctx.is_static() {
            let n = mat6_mul(c, &ps.eps_f).map(|v| -v);
            rate_form(&mut o[6..], &ps.rg_f, &ps.xp_f, &n);
            return o;
        }
        let mut mean = [T::zero(); 6];
        let mut jump = [T::zero(); 6];
        if ctx.ed() {
            let eps_j = self.strain_jump_state(ctx, ps, p);
            for k in 0..6 {
                let eps_j = eps_j[k] + deps_j[k];
                mean[k] = (eps_j + ps.eps_f[k]) * 0.5;
                jump[k] = ps.eps_f[k] - eps_j;
            }
        } else {
            for k in 0..6 {
                mean[k] = (ps.eps_i[k] + ps.eps_f[k]) * 0.5;
            }
        }
        let mut n = mat6_mul(c, &mean);
        if let Some(d) = &pt.damping {
            let nd = mat6_mul(d, &Self::strain_rate_over_step(ctx, ps));
            for k in 0..6 {
                n[k] += nd[k];
            }
        }
        o[0] = ps.rm.mul_v(&V3([n[0], n[1], n[2]])).scale_f(w);
        o[2] = ps
            .hm
            .mul_v(&ps.rm.mul_v(&V3([n[3], n[4], n[5]])))
            .scale_f(w);
        o[1] = o[0].cross(&(ps.xp_i + ps.xp_f).scale_f(0.5));
        if ctx.ed() {
            let neg = mat6_mul(c, &jump).map(|v| v * (-1.0 / 12.0));
            rate_form(&mut o[3..6], &ps.rg_i, &ps.xp_i, &neg);
            rate_form(&mut o[6..], &ps.rg_f, &ps.xp_f, &neg);
        }
        o
    }

    /// The mean strain rate over the step, `(ε_f − ε_i)/h`: the sectional damping forces
    /// `D (ε_f − ε_i)/h` join the mean forces, so that through the exact discrete gradient
    /// they do the work `−(ε_f − ε_i)ᵀ D (ε_f − ε_i)/h ≤ 0` (both schemes).
    pub(super) fn strain_rate_over_step<T: Real>(ctx: &StepCtx, ps: &PointStep<T>) -> [T; 6] {
        std::array::from_fn(|k| (ps.eps_f[k] - ps.eps_i[k]) * (1.0 / ctx.h))
    }

    /// Mass-proportional damping on the f-rows: `α m Δx/h` and `α J r/h` (material), the
    /// force and moment of the mean velocities `Δx/h` and `r/h` over the step (work
    /// `−α (m|Δx|² + rᵀJ r)/h ≤ 0`, as the rows' work is `−row · (Δx, r)`). None in statics.
    pub(super) fn add_mass_damping<T: Real>(&self, ctx: &StepCtx, y: &[T], res: &mut [T]) {
        if ctx.is_static() {
            return;
        }
        let per = Self::per(ctx);
        for (a, (am, aj)) in self.mass_damping.iter().enumerate() {
            let o = per * a;
            add3(res, o, v3(y, o).scale_f(am / ctx.h));
            add3(
                res,
                o + 3,
                M3::<T>::from_f64(aj)
                    .mul_v(&v3(y, o + 3))
                    .scale_f(1.0 / ctx.h),
            );
        }
    }

    /// Work of the structural damping over a converged step (≤ 0; `y` is the local block).
    pub fn damping_work(&self, ctx: &StepCtx, y: &[f64]) -> f64 {
        let mut res = vec![0.0; y.len()];
        self.add_mass_damping(ctx, y, &mut res);
        let mass: f64 = -res.iter().zip(y).map(|(r, v)| r * v).sum::<f64>();
        let sections: f64 = self
            .point_steps::<f64>(ctx, y)
            .enumerate()
            .filter_map(|(g, ps)| {
                let d = self.points[g].damping.as_ref()?;
                let rate = Self::strain_rate_over_step(ctx, &ps);
                let n = mat6_mul(d, &rate);
                Some(-ctx.h * self.points[g].weight * (0..6).map(|k| n[k] * rate[k]).sum::<f64>())
            })
            .sum();
        mass + sections
    }

    /// The element's viscous damping matrix at `state`, local and dense (row-major over the
    /// `[v, W]` of its nodes, W material): `Σ_g w B_gᵀ D B_g` of the sections plus the
    /// mass-proportional `α m`, `α J` (the damping of the linearized equations, for modes).
    pub fn damping_matrix(&self, state: &crate::state::State) -> Vec<f64> {
        let n = 6 * self.nodes.len();
        let mut c = vec![0.0; n * n];
        for (g, b) in self.strain_rate_operators(state).iter().enumerate() {
            let Some(d) = &self.points[g].damping else {
                continue;
            };
            let w = self.points[g].weight;
            for (j, bj) in b.iter().enumerate() {
                let dbj = mat6_mul(d, bj);
                for (i, bi) in b.iter().enumerate() {
                    c[i * n + j] += w * (0..6).map(|k| bi[k] * dbj[k]).sum::<f64>();
                }
            }
        }
        for (a, (am, aj)) in self.mass_damping.iter().enumerate() {
            for i in 0..3 {
                c[(6 * a + i) * n + 6 * a + i] += am;
                for j in 0..3 {
                    c[(6 * a + 3 + i) * n + 6 * a + 3 + j] += aj.0[i][j];
                }
            }
        }
        c
    }

    /// Whether the element carries structural damping.
    pub fn is_damped(&self) -> bool {
        !self.mass_damping.is_empty() || self.points.iter().any(|p| p.damping.is_some())
    }

    /// ED's strain state `ε_j = ε_i + h/6 (B_i V_j − B_f V_f)` of a point (ed-scheme-notes §3.2).
    #[inline(always)]
    pub(super) fn strain_jump_state<T: Real>(
        &self,
        ctx: &StepCtx,
        ps: &PointStep<T>,
        p: &[V3<T>; P_GROUPS],
    ) -> [T; 6] {
        let jump = Self::strain_jump(ctx, ps, p);
        std::array::from_fn(|k| ps.eps_i[k] + jump[k])
    }

    /// ED's strain jump `ε_j − ε_i = h/6 (B_i V_j − B_f V_f)` of a point, from its inputs
    /// (the velocities' interpolations, [`P_FROM`]).
    #[inline(always)]
    fn strain_jump<T: Real>(ctx: &StepCtx, ps: &PointStep<T>, p: &[V3<T>; P_GROUPS]) -> [T; 6] {
        let h6 = ctx.h / 6.0;
        let bi_e = ps.rg_i.tmul_v(&(p[3] + ps.xp_i.cross(&p[4])));
        let bi_k = ps.rg_i.tmul_v(&p[5]);
        let bf_e = ps.rg_f.tmul_v(&(p[6] + ps.xp_f.cross(&p[7])));
        let bf_k = ps.rg_f.tmul_v(&p[8]);
        let mut jump = [T::zero(); 6];
        for k in 0..3 {
            jump[k] = (bi_e.0[k] - bf_e.0[k]) * h6;
            jump[k + 3] = (bi_k.0[k] - bf_k.0[k]) * h6;
        }
        jump
    }

    /// Adds Gauss point `g`'s outputs to each node's row quantities (see [`U_FROM`]).
    #[inline(always)]
    pub(super) fn add_row_quantities<T: Real>(
        &self,
        g: usize,
        o: &[V3<T>; O_GROUPS],
        u: &mut [[V3<T>; U_GROUPS]; MAX_NODES],
    ) {
        let p = &self.points[g];
        // Each row quantity is hᵅ·(its h-terms) + h′ᵅ·(its h′-terms): the two sums once per
        // point, then two products a node over whole groups (15 contiguous numbers).
        let mut at = [V3::<T>::zero(); U_GROUPS];
        let mut along = [V3::<T>::zero(); U_GROUPS];
        for (k, terms) in U_FROM.iter().enumerate() {
            for &(out, derivative, sign) in terms.iter() {
                let sum = if derivative {
                    &mut along[k]
                } else {
                    &mut at[k]
                };
                *sum += o[out].scale_f(sign);
            }
        }
        for (a, ua) in u.iter_mut().enumerate().take(self.nodes.len()) {
            let (h, dh) = (p.h[a], p.dh[a]);
            for k in 0..U_GROUPS {
                ua[k] += at[k].scale_f(h) + along[k].scale_f(dh);
            }
        }
    }

    /// The nodal rows from the row quantities: f-force `u0`; f-moment `R_iᵀ u1 + R_fᵀ u2`;
    /// ED j-force `u3` and j-moment `R_iᵀ u4 − R_fᵀ u2` (material moments).
    #[inline(always)]
    pub(super) fn add_nodal_rows<T: Real>(
        &self,
        ctx: &StepCtx,
        y: &[T],
        u: &[[V3<T>; U_GROUPS]; MAX_NODES],
        res: &mut [T],
    ) {
        let per = Self::per(ctx);
        let at_f = ctx.ed() || ctx.is_static();
        for (a, &node) in self.nodes.iter().enumerate() {
            let ri = M3::<T>::from_f64(&ctx.state.nodes[node].r);
            let ua = &u[a];
            add3(res, per * a, ua[0]);
            let mut m = ri.tmul_v(&ua[1]);
            let mf = if at_f {
                // R_fᵀ u = cay(r)ᵀ R_iᵀ u = cay(−r) R_iᵀ u: the rotation applied to a vector,
                // not formed as a tensor (was 14 % of ED's element residual).
                let r = v3(y, per * a + 3);
                cayley_rotate(&(-r), &ri.tmul_v(&ua[2]))
            } else {
                V3::zero()
            };
            m += mf;
            add3(res, per * a + 3, m);
            if ctx.ed() {
                add3(res, per * a + 6, ua[3]);
                add3(res, per * a + 9, ri.tmul_v(&ua[4]) - mf);
            }
        }
    }

    /// Triad of Gauss point `g` at i (history) and at f (`cay(ρ_g) R_g,i`), for loads that
    /// follow the sections.
    pub fn gauss_triads<T: Real>(&self, ctx: &StepCtx, g: usize, y: &[T]) -> (M3<T>, M3<T>) {
        let p = &self.points[g];
        let per = Self::per(ctx);
        let hist = &ctx.state.history[self.history + g * HISTORY_PER_POINT..];
        let rg_i = M3::<T>::from_f64(&read_history(hist).0);
        let mut rho = V3::<T>::zero();
        for (a, &node) in self.nodes.iter().enumerate() {
            let ri = M3::<T>::from_f64(&ctx.state.nodes[node].r);
            rho += ri.mul_v(&v3(y, per * a + 3)).scale_f(p.h[a]);
        }
        (rg_i, cayley(&rho).mul_m(&rg_i))
    }

    /// Offset of node `a`'s increments `[Δx, r]` in the element's local block.
    pub fn local_delta(&self, ctx: &StepCtx, a: usize) -> usize {
        Self::per(ctx) * a
    }

    /// Strain rate `ε̇ = B(q) V` at a state with triad `rg`, tangent `xp` and nodal rotations
    /// `rot`, for nodal velocities (v, material W): `ė* = R_gᵀ(v′ + x̃′ ω_g)`, `κ̇ = R_gᵀ ω′`.
    fn strain_rate<T: Real>(
        &self,
        g: usize,
        rg: &M3<T>,
        xp: &V3<T>,
        rot: &[M3<T>],
        vel: &[(V3<T>, V3<T>)],
    ) -> [T; 6] {
        let p = &self.points[g];
        let mut vp = V3::<T>::zero();
        let mut wg = V3::<T>::zero();
        let mut wp = V3::<T>::zero();
        for a in 0..self.nodes.len() {
            let w = rot[a].mul_v(&vel[a].1);
            vp += vel[a].0.scale_f(p.dh[a]);
            wg += w.scale_f(p.h[a]);
            wp += w.scale_f(p.dh[a]);
        }
        let e = rg.tmul_v(&(vp + xp.cross(&wg)));
        let k = rg.tmul_v(&wp);
        [e.0[0], e.0[1], e.0[2], k.0[0], k.0[1], k.0[2]]
    }

    /// The strain-rate operator `B_g` of each Gauss point at `state`, `ε̇_g = B_g V`, as its
    /// columns: column `c` is the strain rate `[ė*, κ̇]` of a unit velocity in unknown `c`
    /// (`[v, W]` node after node, W material). Zero on rigid motions; the initial-velocity
    /// projection uses it to make a beam follow its supports without straining.
    pub fn strain_rate_operators(&self, state: &crate::state::State) -> Vec<Vec<[f64; 6]>> {
        let n = 6 * self.nodes.len();
        let rot: Vec<M3<f64>> = self.nodes.iter().map(|&a| state.nodes[a].r).collect();
        (0..self.points.len())
            .map(|g| {
                let p = &self.points[g];
                let (rg, _) = read_history(&state.history[self.history + g * HISTORY_PER_POINT..]);
                let mut xp = V3::zero();
                for (a, &node) in self.nodes.iter().enumerate() {
                    xp += state.nodes[node].x.scale_f(p.dh[a]);
                }
                (0..n)
                    .map(|c| {
                        let mut vel = vec![(V3::zero(), V3::zero()); self.nodes.len()];
                        let unit = &mut vel[c / 6];
                        let axis = if c % 6 < 3 { &mut unit.0 } else { &mut unit.1 };
                        axis.0[c % 3] = 1.0;
                        self.strain_rate(g, &rg, &xp, &rot, &vel)
                    })
                    .collect()
            })
            .collect()
    }

    /// ED: nodal rotations at i and f, and nodal velocities (v, material W) of the j- and
    /// f-states, from the local unknowns (jump velocities carried as h·V_j, system::layout).
    #[cfg(test)]
    #[allow(clippy::type_complexity)]
    fn ed_motion<T: Real>(
        &self,
        ctx: &StepCtx,
        y: &[T],
    ) -> (
        [M3<T>; MAX_NODES],
        [M3<T>; MAX_NODES],
        [(V3<T>, V3<T>); MAX_NODES],
        [(V3<T>, V3<T>); MAX_NODES],
    ) {
        let h = ctx.h;
        let mut rot_i = [M3::<T>::identity(); MAX_NODES];
        let mut rot_f = [M3::<T>::identity(); MAX_NODES];
        let mut vel_j = [(V3::<T>::zero(), V3::<T>::zero()); MAX_NODES];
        let mut vel_f = [(V3::<T>::zero(), V3::<T>::zero()); MAX_NODES];
        for (a, &node) in self.nodes.iter().enumerate() {
            let ri = M3::<T>::from_f64(&ctx.state.nodes[node].r);
            let r = v3(y, 12 * a + 3);
            rot_i[a] = ri;
            rot_f[a] = crate::math::rotation::rotate_material(&ctx.state.nodes[node].r, &r);
            vel_j[a] = (
                v3(y, 12 * a + 6).scale_f(1.0 / h),
                v3(y, 12 * a + 9).scale_f(1.0 / h),
            );
            vel_f[a] = (
                v3(y, 12 * a).scale_f(2.0 / h) - vel_j[a].0,
                r.scale_f(2.0 / h) - vel_j[a].1,
            );
        }
        (rot_i, rot_f, vel_j, vel_f)
    }

    /// Strain energy `Σ_g w ½ εᵀ C ε` of a state (its nodes and this element's history).
    /// Per point, without collecting the points' values: the energy bookkeeping calls it
    /// for every element at every step.
    pub fn strain_energy(&self, state: &crate::state::State) -> f64 {
        (0..self.points.len())
            .map(|g| {
                let (eps, n) = self.gauss_value(state, g);
                0.5 * self.points[g].weight * (0..6).map(|i| n[i] * eps[i]).sum::<f64>()
            })
            .sum()
    }

    /// Strains `[e*, κ]` and sectional forces/moments `C ε` (section frame) at each Gauss point.
    pub fn gauss_values(&self, state: &crate::state::State) -> Vec<([f64; 6], [f64; 6])> {
        (0..self.points.len())
            .map(|g| self.gauss_value(state, g))
            .collect()
    }

    /// [`Self::gauss_values`] of Gauss point `g`.
    fn gauss_value(&self, state: &crate::state::State, g: usize) -> ([f64; 6], [f64; 6]) {
        let p = &self.points[g];
        let (rg, k) = read_history(&state.history[self.history + g * HISTORY_PER_POINT..]);
        let mut xp = V3::zero();
        for (a, &node) in self.nodes.iter().enumerate() {
            xp += state.nodes[node].x.scale_f(p.dh[a]);
        }
        let e = rg.tmul_v(&xp) - V3([1.0, 0.0, 0.0]) - p.e0;
        let k = k - p.k0;
        let eps = [e.0[0], e.0[1], e.0[2], k.0[0], k.0[1], k.0[2]];
        (eps, mat6_mul(&p.stiffness, &eps))
    }

    /// The element's history at the end of a converged step (the local block `y`).
    pub fn history_f(&self, ctx: &StepCtx, y: &[f64], out: &mut [f64]) {
        self.history_and_jump(ctx, y, out, false);
    }

    /// [`Self::history_f`] and, under ED, the strain-jump part of the step's numerical
    /// dissipation, `½ Σ_g w (ε_j − ε_i)ᵀ C (ε_j − ε_i)` (0 under EP), in one pass over the
    /// points. The jump is the one the residual's D-part uses ([`Self::strain_jump`]), so
    /// the step's energy identity closes on it.
    pub fn end_of_step(&self, ctx: &StepCtx, y: &[f64], out: &mut [f64]) -> f64 {
        self.history_and_jump(ctx, y, out, ctx.ed())
    }

    fn history_and_jump(&self, ctx: &StepCtx, y: &[f64], out: &mut [f64], jump: bool) -> f64 {
        let q = self.node_quantities(ctx, y);
        let mut dissipation = 0.0;
        for (g, pt) in self.points.iter().enumerate() {
            let p = self.point_inputs(g, &q);
            let ps = self.point_kinematics(ctx, g, &p[0], &p[1], &p[2]);
            let k = V3([ps.eps_f[3], ps.eps_f[4], ps.eps_f[5]]) + pt.k0;
            write_history(
                &mut out[g * HISTORY_PER_POINT..],
                &crate::math::rotation::orthonormalize(&ps.rg_f),
                &k,
            );
            if jump {
                let d = Self::strain_jump(ctx, &ps, &p);
                let n = mat6_mul(&pt.stiffness, &d);
                dissipation += 0.5 * pt.weight * (0..6).map(|k| n[k] * d[k]).sum::<f64>();
            }
        }
        dissipation
    }

    /// Gathers the element's local unknowns from the global vector.
    pub fn gather(&self, y: &[f64]) -> Vec<f64> {
        self.unknowns.iter().map(|&g| y[g]).collect()
    }
}

impl Kernel for BeamElement {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns
    }

    /// The residual through the Gauss points' forces (see [`BeamElement::point_outputs`]):
    /// node quantities → point inputs → point outputs → row quantities → nodal rows. The
    /// tangent (`beam/tangent.rs`) is the chain rule through the same stages.
    #[inline(always)]
    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], res: &mut [T]) {
        let q = self.node_quantities(ctx, y);
        let mut u = [[V3::<T>::zero(); U_GROUPS]; MAX_NODES];
        let none = [T::zero(); 6];
        for g in 0..self.points.len() {
            let p = self.point_inputs(g, &q);
            let o = self.point_outputs(ctx, g, &p, &none);
            self.add_row_quantities(g, &o, &mut u);
        }
        self.add_nodal_rows(ctx, y, &u, res);
        self.add_mass_damping(ctx, y, res);
    }

    fn evaluate(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        jac: Option<(&mut [f64], &[ValuePos])>,
    ) {
        match jac {
            None => crate::elements::eval_kernel(self, ctx, y, res, None),
            Some((vals, pos)) => super::tangent::evaluate(self, ctx, y, res, vals, pos),
        }
    }

    /// ED: the residual and, of the tangent, only the j-rows the decoupled complex system
    /// reads, written from the EP stiffness (see `tangent::decoupled_surrogate`).
    fn evaluate_decoupled(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        debug_assert!(ctx.ed());
        super::tangent::decoupled_surrogate(self, ctx, y, res, vals, pos)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::beam::section::{Section, SectionProperties};
    use crate::beam::shape::{gauss, lagrange, node_coordinates, reduced_points};
    use crate::elements::fd_harness::tangent_error;
    use crate::math::layout::Scheme;
    use crate::math::rotation::exp_map;
    use crate::state::{NodeState, State};

    const L: f64 = 2.0;

    fn section() -> Mat6 {
        let s = SectionProperties {
            ea: 1e4,
            ga2: 5e3,
            ga3: 4e3,
            gj: 50.0,
            ei2: 80.0,
            ei3: 60.0,
            m: 1.0,
            i22: 0.01,
            i33: 0.02,
            ..Default::default()
        };
        Section::from_properties(&s).unwrap().stiffness
    }

    /// A deformed, stressed `n`-node element along x with generic nodal states and history.
    pub(crate) fn fixture(n: usize, scheme: Scheme) -> (BeamElement, State, Layout) {
        let layout = Layout::new(scheme, n, 0, 0);
        let zs = node_coordinates(n);
        let mut nodes = Vec::new();
        for (a, &z) in zs.iter().enumerate() {
            let s = 0.5 * (z + 1.0) * L;
            let k = a as f64;
            nodes.push(NodeState {
                x: V3([s + 0.01 * k, 0.05 * (s * 1.3).sin(), -0.03 * s * s]),
                r: exp_map(&V3([0.2 * s, -0.1 + 0.05 * k, 0.15 * s])),
                v: V3([0.3, -0.2 * k, 0.1]),
                w: V3([1.0, 0.5 * k, -0.7]),
            });
        }
        let (xg, wg) = gauss(reduced_points(n));
        let mut points = Vec::new();
        let mut history = Vec::new();
        for (&xi, &w) in xg.iter().zip(wg) {
            let (h, dxi) = lagrange(n, xi);
            let jac = L / 2.0;
            let mut dh = [0.0; MAX_NODES];
            for a in 0..n {
                dh[a] = dxi[a] / jac;
            }
            points.push(GaussPoint {
                xi,
                weight: w * jac,
                h,
                dh,
                stiffness: section(),
                e0: V3([0.0; 3]),
                k0: V3([0.01, 0.0, 0.02]),
                damping: None,
            });
            let mut hist = [0.0; HISTORY_PER_POINT];
            write_history(
                &mut hist,
                &exp_map(&V3([0.2 * xi + 0.1, -0.08, 0.15 * xi])),
                &V3([0.05, -0.02, 0.03 * xi]),
            );
            history.extend_from_slice(&hist);
        }
        let state = State {
            t: 0.0,
            nodes,
            coords: vec![],
            coord_rates: vec![],
            lambda: vec![],
            history,
        };
        let el = BeamElement::new("e".into(), (0..n).collect(), points, 0, &layout);
        (el, state, layout)
    }

    pub(crate) fn ctx<'a>(layout: Layout, state: &'a State) -> StepCtx<'a> {
        StepCtx {
            layout,
            h: 0.01,
            t_i: 0.0,
            t_f: 0.01,
            s: 1.0,
            state,
            gravity: V3([0.0; 3]),
            statics: None,
        }
    }

    /// The fixture with structural damping: stiffness-proportional plus a coupled matrix on
    /// its sections, and mass-proportional at its nodes.
    pub(crate) fn damped(mut el: BeamElement) -> BeamElement {
        let c = section();
        for p in &mut el.points {
            p.damping = Some(std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    3e-3 * c[i][j]
                        + if (i, j) == (1, 4) || (i, j) == (4, 1) {
                            20.0
                        } else {
                            0.0
                        }
                })
            }));
        }
        let j = M3([[0.3, 0.02, 0.0], [0.02, 0.2, 0.01], [0.0, 0.01, 0.25]]);
        el.mass_damping = (0..el.nodes.len())
            .map(|a| (1.5 + a as f64, j.scale_f(1.0 + 0.1 * a as f64)))
            .collect();
        el
    }

    /// The fixture with a fully coupled sectional stiffness (stretch–bending, shear–torsion
    /// and bending–bending terms, still positive definite): the tangent's general 3×3 blocks
    /// of C, where the principal-axis fixture takes its diagonal ones.
    pub(crate) fn coupled(mut el: BeamElement) -> BeamElement {
        let couplings = [
            ((0, 4), 30.0),
            ((1, 3), 8.0),
            ((4, 5), 5.0),
            ((1, 2), 300.0),
        ];
        for p in &mut el.points {
            for &((i, j), v) in &couplings {
                p.stiffness[i][j] += v;
                p.stiffness[j][i] += v;
            }
        }
        el
    }

    #[test]
    fn damping_forces_do_exactly_the_reported_negative_work_in_both_schemes() {
        for scheme in [Scheme::Ep, Scheme::Ed] {
            for n in 2..=4 {
                let (el, state, layout) = fixture(n, scheme);
                let c = ctx(layout, &state);
                let per = if scheme == Scheme::Ed { 12 } else { 6 };
                let y: Vec<f64> = (0..per * n)
                    .map(|i| 0.05 * ((i as f64) * 1.7 + 0.3).sin())
                    .collect();
                let mut plain = vec![0.0; y.len()];
                el.residual(&c, &y, &mut plain);
                let el = damped(el);
                let mut res = vec![0.0; y.len()];
                el.residual(&c, &y, &mut res);
                // Work of the damping's rows on the increments (Δx, r): the f-rows only.
                let work: f64 = (0..y.len())
                    .filter(|i| i % per < 6)
                    .map(|i| -(res[i] - plain[i]) * y[i])
                    .sum();
                let reported = el.damping_work(&c, &y);
                assert!(reported < 0.0, "{scheme:?} n={n}: damping must dissipate");
                // Algebraic identity: round-off relative to the work.
                assert!(
                    (work - reported).abs() < 1e-12 * reported.abs(),
                    "{scheme:?} n={n}: rows' work {work} vs reported {reported}"
                );
                // ED's jump rows carry no damping.
                for i in (0..y.len()).filter(|i| i % per >= 6) {
                    assert!((res[i] - plain[i]).abs() < 1e-9 * reported.abs());
                }
            }
        }
    }

    #[test]
    fn ep_internal_work_equals_the_strain_energy_change_exactly() {
        for n in 2..=4 {
            let (el, state, layout) = fixture(n, Scheme::Ep);
            let c = ctx(layout, &state);
            // Large increments: rotations of ~0.5 rad and displacements of 10 % of the length.
            let y: Vec<f64> = (0..6 * n)
                .map(|i| 0.2 * ((i as f64) * 1.7 + 0.3).sin())
                .collect();
            let mut res = vec![0.0; 6 * n];
            el.residual(&c, &y, &mut res);
            let work: f64 = y.iter().zip(&res).map(|(a, b)| a * b).sum();
            let (mut ui, mut uf) = (0.0, 0.0);
            for g in 0..el.points.len() {
                let ps = el.point_step::<f64>(&c, g, &y);
                let k = &el.points[g].stiffness;
                let w = el.points[g].weight;
                let ni = mat6_mul(k, &ps.eps_i);
                let nf = mat6_mul(k, &ps.eps_f);
                ui += 0.5 * w * (0..6).map(|j| ni[j] * ps.eps_i[j]).sum::<f64>();
                uf += 0.5 * w * (0..6).map(|j| nf[j] * ps.eps_f[j]).sum::<f64>();
            }
            // Round-off relative to the energies involved (the identity is algebraic).
            assert!(
                (work - (uf - ui)).abs() < 1e-12 * uf.abs().max(ui.abs()),
                "n={n}: {work} vs {}",
                uf - ui
            );
            assert!(
                (uf - ui).abs() > 1e-3 * ui,
                "the increment must change the strain energy"
            );
        }
    }

    #[test]
    fn rigid_increments_leave_the_strains_unchanged() {
        for n in 2..=4 {
            let (el, state, layout) = fixture(n, Scheme::Ep);
            let c = ctx(layout, &state);
            let rho = V3([0.7, -1.1, 0.4]);
            let q = cayley(&rho);
            let centre = V3([0.3, 0.2, -0.1]);
            let mut y = vec![0.0; 6 * n];
            for (a, nd) in state.nodes.iter().enumerate() {
                let dx = q.mul_v(&(nd.x - centre)) - (nd.x - centre);
                dx.write_to(&mut y[6 * a..]);
                nd.r.tmul_v(&rho).write_to(&mut y[6 * a + 3..]);
            }
            for g in 0..el.points.len() {
                let ps = el.point_step::<f64>(&c, g, &y);
                for k in 0..6 {
                    assert!(
                        (ps.eps_f[k] - ps.eps_i[k]).abs() < 1e-13,
                        "n={n} g={g} k={k}"
                    );
                }
            }
        }
    }

    #[test]
    fn tangents_match_finite_differences_for_every_order_and_scheme() {
        // Time steps of both schemes, and static solves (EP layout).
        for (scheme, statics) in [
            (Scheme::Ep, None),
            (Scheme::Ed, None),
            (Scheme::Ep, Some(0.6)),
        ] {
            let variants =
                (2..=4).flat_map(|n| [(n, false, false), (n, true, false), (n, false, true)]);
            for (n, damp, couple) in variants {
                let (el, state, layout) = fixture(n, scheme);
                // Structural damping acts in time steps only (statics ignore it).
                let el = if damp { damped(el) } else { el };
                let el = if couple { coupled(el) } else { el };
                let c = StepCtx {
                    statics,
                    ..ctx(layout, &state)
                };
                let y: Vec<f64> = (0..layout.n_unknowns())
                    .map(|i| 0.01 * ((i as f64) * 0.9).cos())
                    .collect();
                let e = tangent_error(&el, &c, &y);
                // Same bound as the other kernels: FD truncation and round-off relative to |J|.
                assert!(
                    e < 1e-7,
                    "{scheme:?} statics={statics:?} n={n} damped={damp} coupled={couple}: {e:e}"
                );
            }
        }
    }

    #[test]
    fn strain_rate_operators_give_the_strain_rates_and_nothing_on_rigid_motions() {
        for n in 2..=4 {
            let (el, state, _) = fixture(n, Scheme::Ep);
            let ops = el.strain_rate_operators(&state);
            let apply = |g: usize, vel: &[(V3<f64>, V3<f64>)]| -> [f64; 6] {
                let y: Vec<f64> = vel
                    .iter()
                    .flat_map(|(v, w)| v.0.into_iter().chain(w.0))
                    .collect();
                std::array::from_fn(|r| (0..6 * n).map(|c| ops[g][c][r] * y[c]).sum())
            };
            let rot: Vec<M3<f64>> = state.nodes.iter().map(|nd| nd.r).collect();
            // A generic motion: the operator's product is the strain rate.
            let vel: Vec<(V3<f64>, V3<f64>)> = (0..n)
                .map(|a| {
                    (
                        V3([0.3, -0.5 * a as f64, 0.2]),
                        V3([0.4, -0.3, 0.9 + 0.2 * a as f64]),
                    )
                })
                .collect();
            // A rigid motion v = v₀ + ω × x, W = Rᵀω strains nothing.
            let omega = V3([0.7, -1.1, 0.4]);
            let rigid: Vec<(V3<f64>, V3<f64>)> = state
                .nodes
                .iter()
                .map(|nd| {
                    (
                        V3([0.2, 0.1, -0.3]) + omega.cross(&nd.x),
                        nd.r.tmul_v(&omega),
                    )
                })
                .collect();
            for g in 0..el.points.len() {
                let (rg, _) = read_history(&state.history[g * HISTORY_PER_POINT..]);
                let p = &el.points[g];
                let xp = (0..n).fold(V3::zero(), |s, a| s + state.nodes[a].x.scale_f(p.dh[a]));
                let direct = el.strain_rate(g, &rg, &xp, &rot, &vel);
                let (product, still) = (apply(g, &vel), apply(g, &rigid));
                for r in 0..6 {
                    // O(1) rates; a linear operator's columns reproduce them to round-off.
                    assert!((product[r] - direct[r]).abs() < 1e-13, "n={n} g={g} r={r}");
                    assert!(still[r].abs() < 1e-13, "n={n} g={g} r={r}: {}", still[r]);
                }
            }
        }
    }

    /// ED's strain jump as the residual forms it from the interpolated velocities
    /// (`strain_jump`, which the numerical dissipation reports) against its definition
    /// `h/6 (B_i V_j − B_f V_f)` by the strain-rate operator at i and at f, node velocities
    /// rotated per node: the same to round-off on the stressed, moving fixture at increments of
    /// ~0.3 rad (a 1e-9 change of either route fails).
    #[test]
    fn strain_jump_is_the_strain_rate_operators_difference() {
        for n in 2..=4 {
            let (el, state, layout) = fixture(n, Scheme::Ed);
            let c = ctx(layout, &state);
            let y: Vec<f64> = (0..layout.n_unknowns())
                .map(|i| 0.15 * ((i as f64) * 1.3 + 0.4).sin())
                .collect();
            let (rot_i, rot_f, vel_j, vel_f) = el.ed_motion(&c, &y);
            let q = el.node_quantities::<f64>(&c, &y);
            for g in 0..el.points.len() {
                let p = el.point_inputs(g, &q);
                let ps = el.point_kinematics(&c, g, &p[0], &p[1], &p[2]);
                let jump = BeamElement::strain_jump(&c, &ps, &p);
                let bi = el.strain_rate(g, &ps.rg_i, &ps.xp_i, &rot_i[..n], &vel_j[..n]);
                let bf = el.strain_rate(g, &ps.rg_f, &ps.xp_f, &rot_f[..n], &vel_f[..n]);
                let scale = bi.iter().chain(&bf).fold(0.0f64, |m, v| m.max(v.abs())) * c.h;
                for k in 0..6 {
                    let by_operator = (bi[k] - bf[k]) * c.h / 6.0;
                    assert!(
                        (jump[k] - by_operator).abs() <= 1e-13 * scale,
                        "n={n} g={g} k={k}: {} vs {by_operator}",
                        jump[k]
                    );
                }
            }
        }
    }

    #[test]
    fn strain_rate_operator_matches_differences_of_the_strains() {
        use crate::math::rotation::cayley_log;
        for n in 2..=4 {
            let (el, state, layout) = fixture(n, Scheme::Ep);
            let c = ctx(layout, &state);
            let vel: Vec<(V3<f64>, V3<f64>)> = (0..n)
                .map(|a| {
                    (
                        V3([0.3, -0.5 * a as f64, 0.2]),
                        V3([0.4, -0.3, 0.9 + 0.2 * a as f64]),
                    )
                })
                .collect();
            // Increments of the motion x + t v, R(t) = exp(t ω) R over a time t.
            let incr = |t: f64| {
                let mut y = vec![0.0; 6 * n];
                for (a, nd) in state.nodes.iter().enumerate() {
                    vel[a].0.scale_f(t).write_to(&mut y[6 * a..]);
                    let q = exp_map(&vel[a].1.scale_f(t));
                    nd.r.tmul_v(&cayley_log(&q).unwrap())
                        .write_to(&mut y[6 * a + 3..]);
                }
                y
            };
            let rot: Vec<M3<f64>> = state.nodes.iter().map(|nd| nd.r).collect();
            let material: Vec<(V3<f64>, V3<f64>)> = vel
                .iter()
                .zip(&rot)
                .map(|((v, w), r)| (*v, r.tmul_v(w)))
                .collect();
            let e = 1e-6;
            for g in 0..el.points.len() {
                let p = el.point_step::<f64>(&c, g, &incr(e));
                let m = el.point_step::<f64>(&c, g, &incr(-e));
                let ps = el.point_step::<f64>(&c, g, &incr(0.0));
                let rate = el.strain_rate(g, &ps.rg_i, &ps.xp_i, &rot, &material);
                for k in 0..6 {
                    let fd = (p.eps_f[k] - m.eps_f[k]) / (2.0 * e);
                    // Central difference: truncation ~e² and round-off ~1e-16/e.
                    assert!(
                        (fd - rate[k]).abs() < 1e-8,
                        "n={n} g={g} k={k}: {fd} vs {}",
                        rate[k]
                    );
                }
            }
        }
    }
}
