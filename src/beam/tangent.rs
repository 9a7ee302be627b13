//! The beam element's exact tangent by the chain rule through its Gauss points.
//!
//! The residual is staged (`element.rs`): nodal unknowns → spatial node quantities `q`
//! (nonlinear per node) → point inputs `p` (shape-function sums) → point outputs `o` (the
//! sectional forces, nonlinear per point) → row quantities `u` (shape-function sums) → nodal
//! rows (the nodes' rotations, nonlinear per node). Differentiating the whole element with
//! dual numbers costs `⌈n/8⌉` passes over every point (6 for a cubic ED element); here each
//! point is differentiated once, over its 9 geometric inputs (plus, under ED, the 6 strains of
//! the j-state, through which its 18 velocity inputs act linearly), and the stages are chained
//! with 3×3 blocks. A time step's point Jacobian is in closed form
//! ([`closed_point_derivatives`]: EP's element costs half, ED's four fifths of a dual pass per
//! point); statics keep the dual pass. The generic finite-difference harness checks the
//! result like any kernel's.

use super::element::{
    mat6_mul, BeamElement, PointStep, O_GROUPS, P_FROM, P_GROUPS, Q_GROUPS, U_FROM, U_GROUPS,
};
use super::lanes::{B3Lanes, LaneKind, Lanes};
use super::shape::MAX_NODES;
use crate::elements::{v3, StepCtx, ValuePos};
use crate::math::layout::Layout;
use crate::math::layout::Scheme;
use crate::math::rotation::{cayley, cayley_tangent, rodrigues_h};
use crate::math::scalar::Dual;
use crate::math::vec3::{M3, V3};

type B3 = M3<f64>;

/// An element's unknowns at most: 12 per node under ED.
const MAX_ELEMENT: usize = 12 * MAX_NODES;

/// Directions of the per-point dual pass: the geometric inputs `Δx′, ρ, ρ′` (9), and under
/// ED the offsets of ε_j (6).
const GEO: usize = 9;

/// Residual into `res` and exact tangent into `vals` at `pos` (row-major over the element's
/// unknowns), for a time step of either scheme or a static step. Only the row quantities
/// that can be nonzero are chained (EP: f-force and f-moment at i; statics: f-force and
/// f-moment at f; ED: all), over the point inputs and node quantities the mode has.
pub(super) fn evaluate(
    el: &BeamElement,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    crate::math::wide::wide(
        #[inline(always)]
        || evaluate_body(el, ctx, y, res, vals, pos),
    )
}

#[inline(always)]
fn evaluate_body(
    el: &BeamElement,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    let idx = crate::elements::Kernel::unknowns(el);
    let n = idx.len();
    let mut yl = [0.0f64; MAX_ELEMENT];
    for (l, &g) in idx.iter().enumerate() {
        yl[l] = y[g];
    }
    let mut rl = [0.0f64; MAX_ELEMENT];
    let per = n / el.nodes.len();
    // Block (a, b)'s entries into the element's row-major tangent.
    macro_rules! emit {
        () => {
            |a: usize, b: usize, k: &[[B3Lanes; _]]| {
                for (rg, row) in k.iter().enumerate() {
                    for (yg, blk) in row.iter().enumerate() {
                        for (i, entries) in blk.0.iter().enumerate() {
                            let r = (per * a + 3 * rg + i) * n + per * b + 3 * yg;
                            for (&p, v) in pos[r..r + 3].iter().zip(entries) {
                                vals[p as usize] += v[b];
                            }
                        }
                    }
                }
            }
        };
    }
    let (yl, rl_out) = (&yl[..n], Some(&mut rl[..n]));
    if ctx.ed() {
        chained::<{ GEO + 6 }, U_GROUPS, Q_GROUPS, O_GROUPS, P_GROUPS, 4>(
            el,
            ctx,
            yl,
            rl_out,
            [0, 1, 2, 3, 4],
            emit!(),
        );
    } else if ctx.is_static() {
        chained::<GEO, 2, 2, O_GROUPS, 3, 2>(el, ctx, yl, rl_out, [0, 2], emit!());
    } else {
        chained::<GEO, 2, 2, 3, 3, 2>(el, ctx, yl, rl_out, [0, 1], emit!());
    }
    if !ctx.is_static() && !el.mass_damping.is_empty() {
        el.add_mass_damping(ctx, yl, &mut rl[..n]);
        // Its rows are linear: `α m/h` on Δx, `α J/h` on r.
        for (a, (am, aj)) in el.mass_damping.iter().enumerate() {
            for i in 0..3 {
                let (t, r) = (per * a + i, per * a + 3 + i);
                vals[pos[t * n + t] as usize] += am / ctx.h;
                for j in 0..3 {
                    vals[pos[r * n + per * a + 3 + j] as usize] += aj.0[i][j] / ctx.h;
                }
            }
        }
    }
    for (l, &g) in idx.iter().enumerate() {
        res[g] += rl[l];
    }
}

/// ED under modified Newton: the decoupled complex system (`integrator::ed_decoupled`) reads
/// only the j-rows of the tangent, which for a linear beam are `K/18` (jump columns) and
/// `−2K/9` (increment columns) of one stiffness `K`. This writes them from `K ≈ 2 ∂P_f/∂Δ` of
/// EP's equations at the same increments (material and geometric stiffness at mid-step) —
/// an EP tangent, a third of ED's — and leaves the f-rows out; the residual is ED's.
pub(super) fn decoupled_surrogate(
    el: &BeamElement,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    crate::math::wide::wide(
        #[inline(always)]
        || decoupled_surrogate_body(el, ctx, y, res, vals, pos),
    )
}

#[inline(always)]
fn decoupled_surrogate_body(
    el: &BeamElement,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    crate::elements::residual_sized(el, ctx, y, res, None);
    let idx = crate::elements::Kernel::unknowns(el);
    let n = idx.len();
    let mut yl = [0.0f64; MAX_ELEMENT];
    for (a, node) in idx.chunks(12).enumerate() {
        for k in 0..6 {
            yl[6 * a + k] = y[node[k]];
        }
    }
    let ep = StepCtx {
        layout: Layout {
            scheme: Scheme::Ep,
            ..ctx.layout
        },
        ..*ctx
    };
    let emit = |a: usize, b: usize, k: &[[B3Lanes; 2]]| {
        for (rg, row) in k.iter().enumerate() {
            for (yg, blk) in row.iter().enumerate() {
                for i in 0..3 {
                    let r = (12 * a + 6 + 3 * rg + i) * n + 12 * b + 3 * yg;
                    for j in 0..3 {
                        let v = blk.0[i][j][b];
                        vals[pos[r + j] as usize] -= (4.0 / 9.0) * v;
                        vals[pos[r + j + 6] as usize] += v / 9.0;
                    }
                }
            }
        }
    };
    let nn = el.nodes.len();
    chained::<GEO, 2, 2, 3, 3, 2>(el, &ep, &yl[..6 * nn], None, [0, 1], emit);
}

/// [`evaluate`] with `N` dual directions per point, the row quantities `active` (`NU`), `NQ`
/// node quantities, `NO` point outputs, `NP` point inputs and `NY` unknown groups per node:
/// the working arrays are no larger than the mode needs (they are zeroed on every call).
#[inline(always)]
fn chained<
    const N: usize,
    const NU: usize,
    const NQ: usize,
    const NO: usize,
    const NP: usize,
    const NY: usize,
>(
    el: &BeamElement,
    ctx: &StepCtx,
    yl: &[f64],
    res: Option<&mut [f64]>,
    active: [usize; NU],
    mut emit: impl FnMut(usize, usize, &[[B3Lanes; NY]]),
) {
    let nn = el.nodes.len();
    let q = el.node_quantities::<f64>(ctx, yl);
    let mut u = [[V3::<f64>::zero(); U_GROUPS]; MAX_NODES];
    // G[a][k][qg], lane b: ∂u^a_active[k]/∂q^b accumulated over the points.
    let mut gab = [[[B3Lanes::ZERO; NQ]; NU]; MAX_NODES];
    // Every point writes all of it.
    let mut jac = [[B3::zero(); NP]; NO];
    // The row quantities serve the residual and the end triad's moment term (ED, statics)
    // only: ED's decoupled surrogate (EP's equations, no residual) skips them.
    let rows_needed = res.is_some() || ctx.ed() || ctx.is_static();
    let mut w = [[B3Lanes::ZERO; NP]; NU];
    for g in 0..el.points.len() {
        let o = point_jacobian::<N, NO, NP>(el, ctx, g, &q, &mut jac);
        if rows_needed {
            el.add_row_quantities(g, &o, &mut u);
        }
        let pt = &el.points[g];
        row_weights::<NU, NO, NP>(pt, &jac, &active, &mut w);
        for (a, ga) in gab.iter_mut().enumerate().take(nn) {
            add_point_to_row_node::<NU, NQ, NP>(pt, &w, a, ga);
        }
    }
    if let Some(rl) = res {
        el.add_nodal_rows(ctx, yl, &u, rl);
    }
    let nodal = NodalMaps::<NQ, NY>::new(el, ctx, yl, &u);
    let mut k = [[B3Lanes::ZERO; NY]; NY];
    for (a, ga) in gab.iter().enumerate().take(nn) {
        nodal.blocks::<NU>(a, ga, &active, &mut k);
        for b in 0..nn {
            emit(a, b, &k);
        }
    }
}

/// `G[k][qg] += Σ_pg W[k][pg] ∂p/∂q^b` in lane b for row node `a`: one point's share. The
/// inputs of one node quantity (`ρ`, `ρ′` of `ρ`; [`P_FROM`] lists them side by side) go in
/// one pass, so that each block of `G` is loaded and stored once per point.
#[inline(always)]
fn add_point_to_row_node<const NU: usize, const NQ: usize, const NP: usize>(
    pt: &crate::beam::element::GaussPoint,
    w: &[[B3Lanes; NP]; NU],
    a: usize,
    ga: &mut [[B3Lanes; NQ]; NU],
) {
    let mut pg = 0;
    while pg < NP {
        let (qg, derivative) = P_FROM[pg];
        let c = if derivative { &pt.dh } else { &pt.h };
        if pg + 1 < NP && P_FROM[pg + 1].0 == qg {
            let d = if P_FROM[pg + 1].1 { &pt.dh } else { &pt.h };
            for (gk, wk) in ga.iter_mut().zip(w) {
                gk[qg].add_two_scaled_lanes((&wk[pg], c), (&wk[pg + 1], d), a);
            }
            pg += 2;
        } else {
            for (gk, wk) in ga.iter_mut().zip(w) {
                gk[qg].add_scaled_lane(&wk[pg], a, c);
            }
            pg += 1;
        }
    }
}

/// `W[k][pg] = ∂u^a_active[k]/∂p` at point `pt` for every row node `a` (lane a) into `w`: its
/// Jacobian `jac` weighted by the nodes' shape functions as the row quantities take them
/// ([`U_FROM`]). Each row's first term is written, not added to zeros: `w` is reused across
/// the points, not zero-filled and returned by value.
#[inline(always)]
fn row_weights<const NU: usize, const NO: usize, const NP: usize>(
    pt: &crate::beam::element::GaussPoint,
    jac: &[[B3; NP]; NO],
    active: &[usize; NU],
    w: &mut [[B3Lanes; NP]; NU],
) {
    for (wk, &ug) in w.iter_mut().zip(active) {
        let mut written = false;
        // Outputs past `NO` are zero in this mode (EP: D only).
        for &(out, derivative, sign) in U_FROM[ug].iter().filter(|u| u.0 < NO) {
            let shape = if derivative { &pt.dh } else { &pt.h };
            let c: Lanes = std::array::from_fn(|a| sign * shape[a]);
            for (wkp, jp) in wk.iter_mut().zip(&jac[out]) {
                if written {
                    wkp.add_scaled(jp, &c);
                } else {
                    *wkp = B3Lanes::scaled(jp, &c);
                }
            }
            written = true;
        }
        if !written {
            *wk = [B3Lanes::ZERO; NP];
        }
    }
}

/// Point outputs, and their Jacobian `∂o/∂p` into `jac` in 3×3 blocks `[output group][input
/// group]`, the first `NO` outputs and `NP` inputs (the others are zero in the mode): in
/// closed form for a time step ([`closed_point_jacobian`]), by one dual pass in statics.
#[inline(always)]
fn point_jacobian<const N: usize, const NO: usize, const NP: usize>(
    el: &BeamElement,
    ctx: &StepCtx,
    g: usize,
    q: &[[V3<f64>; Q_GROUPS]; MAX_NODES],
    jac: &mut [[B3; NP]; NO],
) -> [V3<f64>; O_GROUPS] {
    let p = el.point_inputs(g, q);
    if ctx.is_static() {
        let (o, full) = dual_point_jacobian::<N>(el, ctx, g, &p);
        for (row, full_row) in jac.iter_mut().zip(&full) {
            row.copy_from_slice(&full_row[..NP]);
        }
        return o;
    }
    closed_point_jacobian::<NO, NP>(el, ctx, g, &p, jac)
}

/// [`point_jacobian`] of a time step from [`closed_point_derivatives`]: EP's `NO = NP = 3`
/// (D's outputs over the geometric inputs), ED's `NO = NP = 9`.
#[inline(always)]
fn closed_point_jacobian<const NO: usize, const NP: usize>(
    el: &BeamElement,
    ctx: &StepCtx,
    g: usize,
    p: &[V3<f64>; P_GROUPS],
    jac: &mut [[B3; NP]; NO],
) -> [V3<f64>; O_GROUPS] {
    if !ctx.ed() {
        return closed_point_derivatives::<3, NO, NP>(el, ctx, g, p, jac);
    }
    let o = closed_point_derivatives::<CLOSED_DIRS, NO, NP>(el, ctx, g, p, jac);
    // Columns 3 and 4 hold ∂o/∂ε_j until the velocity inputs' columns replace them.
    let d_j: [[B3; 2]; NO] = std::array::from_fn(|og| [jac[og][3], jac[og][4]]);
    velocity_columns(el, ctx, g, p, &d_j, jac);
    o
}

/// `∂(H(ρ) z)/∂ρ` for a fixed `z`, with `H = I − ρρᵀ/(4 + ρᵀρ)`:
/// `−((ρ·z) I + ρ zᵀ)/(4 + ρᵀρ) + 2 (ρ·z) ρρᵀ/(4 + ρᵀρ)²`.
#[inline(always)]
fn h_times_gradient(rho: &V3<f64>, z: &V3<f64>) -> B3 {
    let d = 1.0 / (4.0 + rho.norm_sq());
    let rz = rho.dot(z);
    let mut m = rho.outer(rho).scale_f(2.0 * rz * d * d) - rho.outer(z).scale_f(d);
    for i in 0..3 {
        m.0[i][i] -= rz * d;
    }
    m
}

/// Directions of the closed-form point Jacobian: `Δx′, ρ, ρ′` and, under ED, the two halves
/// (`e*`, `κ`) of the strain state ε_j, through which the velocity inputs act.
const CLOSED_DIRS: usize = 5;

/// The strains' derivatives at a Gauss point, `∂ε_f` and `∂ε_j` as [strain half][direction]
/// (directions: the point's position and rotation inputs, its curvature input, and under ED
/// the strain jump's offsets), and the strains at j (under EP those at i).
#[inline(always)]
fn strain_derivatives<const ND: usize>(
    el: &BeamElement,
    ctx: &StepCtx,
    ps: &PointStep<f64>,
    p: &[V3<f64>; P_GROUPS],
    hs: &B3,
) -> ([[B3; ND]; 2], [[B3; ND]; 2], [f64; 6]) {
    let (rho, rho_p) = (&p[1], &p[2]);
    let (rf_t, rm_t) = (ps.rg_f.transpose(), ps.rm.transpose());
    let mut d_f = [[B3::zero(); ND]; 2];
    d_f[0][0] = rf_t;
    d_f[0][1] = rf_t.mul_m(&ps.xp_f.tilde()).mul_m(hs);
    d_f[1][1] = rf_t
        .mul_m(&ps.hm.mul_v(rho_p).tilde())
        .mul_m(hs)
        .scale_f(0.5)
        + rm_t.mul_m(&h_times_gradient(rho, rho_p));
    d_f[1][2] = rm_t.mul_m(&ps.hm);
    let mut d_j = [[B3::zero(); ND]; 2];
    let eps_j = if ctx.ed() {
        let h6 = ctx.h / 6.0;
        let z_e = p[6] + ps.xp_f.cross(&p[7]);
        d_j[0][0] = rf_t.mul_m(&p[7].tilde()).scale_f(h6);
        d_j[0][1] = rf_t.mul_m(&z_e.tilde()).mul_m(hs).scale_f(-h6);
        d_j[1][1] = rf_t.mul_m(&p[8].tilde()).mul_m(hs).scale_f(-h6);
        (d_j[0][3], d_j[1][4]) = (B3::identity(), B3::identity());
        el.strain_jump_state(ctx, ps, p)
    } else {
        ps.eps_i
    };
    (d_f, d_j, eps_j)
}

/// A step's point outputs (see [`BeamElement::point_outputs`]) differentiated by hand. With
/// `a = H_s(ρ) δρ` the spatial variation of `R_f = cay(ρ) R_i` (`δR_f = ã R_f`, `H_s` =
/// [`rodrigues_h`]), `v = Hρ′` and `z_e = v′_f + x′_f × ω_f`:
/// - `δe_f = R_fᵀ δΔx′ + R_fᵀ x̃′_f a`, `δκ_f = ½ R_fᵀ ṽ a + R_mᵀ ∂(Hρ′)/∂ρ δρ + R_mᵀ H δρ′`;
/// - ED: `δε_j = h/6 (R_fᵀ ω̃_f δΔx′ − R_fᵀ z̃_e a ; −R_fᵀ ω̃′_f a) + δε_j^seed` (strain halves
///   `e*` ; `κ`, with `ε_j` from `B_f V_f = (R_fᵀ z_e ; R_fᵀ ω′_f)`);
/// - D: `n = C ε̄` (ε̄ the mean strain), `δo₀ = w R_m δn_F − ½ w (R_f n_F)~ a`,
///   `δo₂ = w H R_m δn_M + w ∂(H R_m n_M)/∂ρ δρ − ½ w H (R_f n_M)~ a`, `δo₁ = −x̃_m δo₀ + ½ õ₀ δΔx′`;
/// - ED's I and F, `−C(ε_f − ε_j)/12` through `R_i` and `R_f`: `δo₆ = w R_f δn − õ₆ a`,
///   `δo₇ = −x̃′_f δo₆ + õ₆ δΔx′`, `δo₈ = w R_f δn_M − õ₈ a`, and at i the same without the
///   triad's variation.
///
/// Returns the outputs, and writes into `jac`'s first `ND` columns `∂o/∂p` for the geometric
/// inputs and `∂o/∂ε_j` by strain half, of the first `NO` outputs (EP: 3, the others being
/// zero).
#[inline(always)]
fn closed_point_derivatives<const ND: usize, const NO: usize, const NP: usize>(
    el: &BeamElement,
    ctx: &StepCtx,
    g: usize,
    p: &[V3<f64>; P_GROUPS],
    jac: &mut [[B3; NP]; NO],
) -> [V3<f64>; O_GROUPS] {
    let (ed, pt) = (ctx.ed(), &el.points[g]);
    assert_eq!(
        (ND, NO),
        if ed { (CLOSED_DIRS, O_GROUPS) } else { (3, 3) },
        "directions and outputs of the mode"
    );
    assert!(ND <= NP, "the Jacobian holds the directions");
    let (c, w) = (&pt.stiffness, pt.weight);
    let (rho, rho_p) = (&p[1], &p[2]);
    let ps = el.point_kinematics(ctx, g, &p[0], rho, rho_p);
    let o = el.point_outputs_at(ctx, g, &ps, p, &[0.0; 6]);
    let hs = rodrigues_h(rho);
    let (d_f, d_j, eps_j) = strain_derivatives::<ND>(el, ctx, &ps, p, &hs);
    // w C by 3×3 blocks; `cb.half_force(half, ∂ε, …)` = the sectional forces' half of w C ∂ε.
    let cb = SectionBlocks::of(c, w);
    // Sectional damping: the mean forces gain `D (ε_f − ε_i)/h`, so `w D/h ∂ε_f`.
    let db = pt.damping.as_ref().map(|d| SectionBlocks::of(d, w / ctx.h));
    let (n_f, n_m) = mean_forces(el, ctx, g, &ps, &eps_j);
    let xm_t = (ps.xp_i + ps.xp_f).scale_f(0.5).tilde();
    let hrm = ps.hm.mul_m(&ps.rm);
    // Whether `jac[0][k]` is zero by structure (a decoupled section's force along ρ′); k = 1
    // gains terms below whatever its force.
    let mut force_zero = [false; ND];
    // Plain loops and functions, not closures: those are not inlined into wide kernels.
    for k in 0..ND {
        let force = mean_force_derivative(k, &d_f, &d_j, &cb, db.as_ref());
        force_zero[k] = force[0].is_none();
        jac[0][k] = force[0].map_or(B3::zero(), |f| ps.rm.mul_m(&f));
        jac[2][k] = force[1].map_or(B3::zero(), |f| hrm.mul_m(&f));
    }
    jac[0][1] = jac[0][1] - ps.rg_f.mul_v(&n_f).tilde().mul_m(&hs).scale_f(0.5 * w);
    jac[2][1] = jac[2][1] + h_times_gradient(rho, &ps.rm.mul_v(&n_m)).scale_f(w)
        - ps.hm
            .mul_m(&ps.rg_f.mul_v(&n_m).tilde())
            .mul_m(&hs)
            .scale_f(0.5 * w);
    for k in 0..ND {
        jac[1][k] = if force_zero[k] && k != 1 {
            B3::zero()
        } else {
            B3::zero() - xm_t.mul_m(&jac[0][k])
        };
    }
    jac[1][0] = jac[1][0] + o[0].tilde().scale_f(0.5);
    if ed {
        jump_output_columns(&ps, &o, &hs, (&d_f, &d_j), &cb, jac);
    }
    o
}

/// The derivative along direction `k` of the mean sectional forces `w C ε̄` (ε̄ = (ε_j +
/// ε_f)/2), with the damping's `w D/h ∂ε_f`, by half (force, moment): None where it is zero
/// by structure ([`STRAIN_HALVES`], a decoupled section).
#[inline(always)]
fn mean_force_derivative<const ND: usize>(
    k: usize,
    d_f: &[[B3; ND]; 2],
    d_j: &[[B3; ND]; 2],
    cb: &SectionBlocks,
    db: Option<&SectionBlocks>,
) -> [Option<B3>; 2] {
    let mean = [
        (d_f[0][k] + d_j[0][k]).scale_f(0.5),
        (d_f[1][k] + d_j[1][k]).scale_f(0.5),
    ];
    let halves = STRAIN_HALVES[k];
    let mut force = [
        cb.half_force(0, &mean, halves),
        cb.half_force(1, &mean, halves),
    ];
    if let Some(db) = db {
        // ε_f does not move with ε_j's offsets.
        let rate = if k < 3 { halves } else { [false; 2] };
        for (half, f) in force.iter_mut().enumerate() {
            for (s, d) in d_f.iter().enumerate() {
                if db.nonzero[half][s] && rate[s] {
                    let t = db.m[half][s].mul_m(&d[k]);
                    *f = Some(f.map_or(t, |f| f + t));
                }
            }
        }
    }
    force
}

/// ED's rate-form outputs I and F (groups 3–8) over the directions, from the jump's sectional
/// forces `−C(ε_f − ε_j)/12` through `R_i` and `R_f` (see [`closed_point_derivatives`]).
#[inline(always)]
fn jump_output_columns<const ND: usize, const NO: usize, const NP: usize>(
    ps: &PointStep<f64>,
    o: &[V3<f64>; O_GROUPS],
    hs: &B3,
    (d_f, d_j): (&[[B3; ND]; 2], &[[B3; ND]; 2]),
    cb: &SectionBlocks,
    jac: &mut [[B3; NP]; NO],
) {
    let (xi_t, xf_t) = (ps.xp_i.tilde(), ps.xp_f.tilde());
    for k in 0..ND {
        let jump = [
            (d_f[0][k] - d_j[0][k]).scale_f(-1.0 / 12.0),
            (d_f[1][k] - d_j[1][k]).scale_f(-1.0 / 12.0),
        ];
        let halves = STRAIN_HALVES[k];
        let zero = B3::zero();
        let (dn_f, dn_m) = (
            cb.half_force(0, &jump, halves).unwrap_or(zero),
            cb.half_force(1, &jump, halves).unwrap_or(zero),
        );
        jac[3][k] = ps.rg_i.mul_m(&dn_f);
        jac[5][k] = ps.rg_i.mul_m(&dn_m);
        jac[4][k] = B3::zero() - xi_t.mul_m(&jac[3][k]);
        jac[6][k] = ps.rg_f.mul_m(&dn_f);
        jac[8][k] = ps.rg_f.mul_m(&dn_m);
    }
    jac[6][1] = jac[6][1] - o[6].tilde().mul_m(hs);
    jac[8][1] = jac[8][1] - o[8].tilde().mul_m(hs);
    for k in 0..ND {
        jac[7][k] = B3::zero() - xf_t.mul_m(&jac[6][k]);
    }
    jac[7][0] = jac[7][0] + o[6].tilde();
}

/// Which strain halves (`e*`, `κ`) of `∂ε_f` and `∂ε_j` can be nonzero along each
/// direction of the closed-form Jacobian (`Δx′, ρ, ρ′`, and `ε_j`'s offsets by half): the
/// zero blocks of [`strain_derivatives`], whose products are skipped.
const STRAIN_HALVES: [[bool; 2]; CLOSED_DIRS] = [
    [true, false],
    [true, true],
    [false, true],
    [true, false],
    [false, true],
];

/// `a` times a 6×6 section matrix as 3×3 blocks `[[11, 12], [21, 22]]`, with which of them
/// are nonzero: most sections couple neither extension and shear to bending and torsion
/// nor the converse, and their off-diagonal blocks' products are skipped.
struct SectionBlocks {
    m: [[B3; 2]; 2],
    nonzero: [[bool; 2]; 2],
}

impl SectionBlocks {
    #[inline(always)]
    fn of(m: &crate::beam::section::Mat6, a: f64) -> Self {
        let blk = |i: usize, j: usize| {
            M3(std::array::from_fn(|r| {
                std::array::from_fn(|s| a * m[3 * i + r][3 * j + s])
            }))
        };
        let m = [[blk(0, 0), blk(0, 1)], [blk(1, 0), blk(1, 1)]];
        let nonzero = m.map(|row| row.map(|b: B3| b.0.iter().flatten().any(|&v| v != 0.0)));
        SectionBlocks { m, nonzero }
    }

    /// The sectional forces' half `half` (force 0, moment 1) of the product with `∂ε` (by
    /// strain half, `e_nonzero` saying which can be nonzero); None where it is zero by
    /// structure.
    #[inline(always)]
    fn half_force(&self, half: usize, e: &[B3; 2], e_nonzero: [bool; 2]) -> Option<B3> {
        let mut out: Option<B3> = None;
        for s in 0..2 {
            if self.nonzero[half][s] && e_nonzero[s] {
                let t = self.m[half][s].mul_m(&e[s]);
                out = Some(out.map_or(t, |o| o + t));
            }
        }
        out
    }
}

/// The D-part's mean sectional force and moment, `C (ε_j + ε_f)/2 + D (ε_f − ε_i)/h` (EP:
/// ε_j is ε_i), as in [`BeamElement::point_outputs`].
#[inline(always)]
fn mean_forces(
    el: &BeamElement,
    ctx: &StepCtx,
    g: usize,
    ps: &PointStep<f64>,
    eps_j: &[f64; 6],
) -> (V3<f64>, V3<f64>) {
    let pt = &el.points[g];
    let mut n = mat6_mul(
        &pt.stiffness,
        &std::array::from_fn(|k| 0.5 * (eps_j[k] + ps.eps_f[k])),
    );
    if let Some(d) = &pt.damping {
        let nd = mat6_mul(d, &BeamElement::strain_rate_over_step(ctx, ps));
        n = std::array::from_fn(|k| n[k] + nd[k]);
    }
    (V3([n[0], n[1], n[2]]), V3([n[3], n[4], n[5]]))
}

/// [`point_jacobian`] by one dual pass over the geometric inputs (and under ED the strain
/// jump's offsets).
fn dual_point_jacobian<const N: usize>(
    el: &BeamElement,
    ctx: &StepCtx,
    g: usize,
    p: &[V3<f64>; P_GROUPS],
) -> ([V3<f64>; O_GROUPS], [[B3; P_GROUPS]; O_GROUPS]) {
    let mut pd = [V3::<Dual<N>>::zero(); P_GROUPS];
    for (k, v) in p.iter().enumerate() {
        for i in 0..3 {
            let dir = (k < 3).then_some(3 * k + i);
            pd[k].0[i] = Dual::seeded(v.0[i], dir);
        }
    }
    let deps: [Dual<N>; 6] =
        std::array::from_fn(|k| Dual::seeded(0.0, ctx.ed().then_some(GEO + k)));
    let od = el.point_outputs(ctx, g, &pd, &deps);
    let o: [V3<f64>; O_GROUPS] = std::array::from_fn(|k| od[k].re());
    let mut jac = [[B3::zero(); P_GROUPS]; O_GROUPS];
    for (og, v) in od.iter().enumerate() {
        for pg in 0..3 {
            for i in 0..3 {
                for j in 0..3 {
                    jac[og][pg].0[i][j] = v.0[i].du[3 * pg + j];
                }
            }
        }
    }
    if ctx.ed() {
        let d_j: [[B3; 2]; O_GROUPS] = std::array::from_fn(|og| {
            std::array::from_fn(|half| {
                M3(std::array::from_fn(|i| {
                    std::array::from_fn(|j| od[og].0[i].du[GEO + 3 * half + j])
                }))
            })
        });
        velocity_columns(el, ctx, g, p, &d_j, &mut jac);
    }
    (o, jac)
}

/// ED: the outputs are affine in the velocity inputs, which act only through ε_j:
/// `∂o/∂p_k = (∂o/∂ε_j) (∂ε_j/∂p_k)`, with `ε_j = ε_i + h/6 (B_i V_j − B_f V_f)`.
/// `d_j[og][half]` is `∂o/∂ε_j` by strain half.
#[inline(always)]
fn velocity_columns<const NO: usize, const NP: usize>(
    el: &BeamElement,
    ctx: &StepCtx,
    g: usize,
    p: &[V3<f64>; P_GROUPS],
    d_j: &[[B3; 2]; NO],
    jac: &mut [[B3; NP]; NO],
) {
    let ps = el.point_kinematics(ctx, g, &p[0], &p[1], &p[2]);
    let h6 = ctx.h / 6.0;
    let (rgi_t, rgf_t) = (ps.rg_i.transpose(), ps.rg_f.transpose());
    // ∂ε_j/∂p_k: (strain half: 0 = e*, 1 = κ; its 3×3 block).
    let de: [(usize, B3); 6] = [
        (0, rgi_t.scale_f(h6)),
        (0, rgi_t.mul_m(&ps.xp_i.tilde()).scale_f(h6)),
        (1, rgi_t.scale_f(h6)),
        (0, rgf_t.scale_f(-h6)),
        (0, rgf_t.mul_m(&ps.xp_f.tilde()).scale_f(-h6)),
        (1, rgf_t.scale_f(-h6)),
    ];
    for (row, e) in jac.iter_mut().zip(d_j) {
        for (k, (half, blk)) in de.iter().enumerate() {
            row[3 + k] = e[*half].mul_m(blk);
        }
    }
}

/// The per-node maps around the chained point Jacobians: `∂q^b/∂y^b` on the column side (all
/// column nodes `b` side by side, see [`B3Lanes`]), the nodal rotations on the row side, and
/// the derivative of `R_fᵀ` on the diagonal. `NQ` node quantities and `NY` unknown groups per
/// node, as in [`chained`].
struct NodalMaps<const NQ: usize, const NY: usize> {
    /// `Q[qg][yg]`, lane b, with its kind (zero blocks skipped, multiples of the identity
    /// scaled).
    q: [[B3Lanes; NY]; NQ],
    q_kind: [[LaneKind; NY]; NQ],
    /// `R_iᵀ`, `R_fᵀ` per node.
    ri_t: [B3; MAX_NODES],
    rf_t: [B3; MAX_NODES],
    /// `(R_fᵀ u2)~ T(r)`: the derivative of the f-moment's `R_fᵀ u2` with respect to r.
    diag: [B3; MAX_NODES],
    ed: bool,
    at_f: bool,
}

impl<const NQ: usize, const NY: usize> NodalMaps<NQ, NY> {
    #[inline(always)]
    fn new(
        el: &BeamElement,
        ctx: &StepCtx,
        y: &[f64],
        u: &[[V3<f64>; U_GROUPS]; MAX_NODES],
    ) -> Self {
        let ed = ctx.ed();
        let per = if ed { 12 } else { 6 };
        let mut m = NodalMaps {
            q: [[B3Lanes::ZERO; NY]; NQ],
            q_kind: [[LaneKind::Zero; NY]; NQ],
            ri_t: [B3::identity(); MAX_NODES],
            rf_t: [B3::identity(); MAX_NODES],
            diag: [B3::zero(); MAX_NODES],
            ed,
            at_f: ed || ctx.is_static(),
        };
        let id = B3::identity();
        for (b, &node) in el.nodes.iter().enumerate() {
            let ri = ctx.state.nodes[node].r;
            let r = v3(y, per * b + 3);
            m.ri_t[b] = ri.transpose();
            let q = &mut m.q;
            q[0][0].set_lane(b, &id);
            q[1][1].set_lane(b, &ri);
            // The end triad only where rows are taken through it (ED, statics).
            let (cay, t) = if m.at_f {
                (cayley(&r), cayley_tangent(&r))
            } else {
                (id, id)
            };
            if m.at_f {
                m.rf_t[b] = ri.mul_m(&cay).transpose();
                m.diag[b] = m.rf_t[b].mul_v(&u[b][2]).tilde().mul_m(&t);
            }
            if ed {
                let inv_h = 1.0 / ctx.h;
                let wj = v3(y, per * b + 9).scale_f(inv_h);
                q[2][2].set_lane(b, &id.scale_f(inv_h));
                q[3][3].set_lane(b, &ri.scale_f(inv_h));
                q[4][0].set_lane(b, &id.scale_f(2.0 * inv_h));
                q[4][2].set_lane(b, &id.scale_f(-inv_h));
                // ω_f = R_i (2r/h − cay(r) W_j); ∂(cay(r) W)/∂r = −cay(r) W̃ T(r).
                let q51 = ri.mul_m(&(id.scale_f(2.0 * inv_h) + cay.mul_m(&wj.tilde()).mul_m(&t)));
                q[5][1].set_lane(b, &q51);
                q[5][3].set_lane(b, &ri.mul_m(&cay).scale_f(-inv_h));
            }
        }
        for (kinds, q) in m.q_kind.iter_mut().zip(&m.q) {
            for (kind, blk) in kinds.iter_mut().zip(q) {
                *kind = LaneKind::of(blk, el.nodes.len());
            }
        }
        m
    }

    /// `GQ = Σ_qg G[k][qg] Q[qg][yg]` for row quantity `gk` and unknown group `yg`: one block
    /// per column node, formed in registers (no zero-filled scratch array).
    #[inline(always)]
    fn through_q(&self, gk: &[B3Lanes; NQ], yg: usize) -> B3Lanes {
        let mut out = B3Lanes::ZERO;
        for (qg, gblk) in gk.iter().enumerate() {
            match &self.q_kind[qg][yg] {
                LaneKind::Zero => {}
                LaneKind::Identity(c) => out.add_lane_scaled(c, gblk),
                LaneKind::Full => out.add_product(gblk, &self.q[qg][yg]),
            }
        }
        out
    }

    /// The 3×3 blocks `[row group][unknown group]` of `∂rows^a/∂y^b` for every column node `b`
    /// (lane b) from `G = ∂u^a/∂q^b` (`NY` groups: 2 for EP and statics, 4 for ED), written
    /// over `k` (every block of it).
    // `yg` indexes every row group of `k` and picks the column of `Q`.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn blocks<const NU: usize>(
        &self,
        a: usize,
        g: &[[B3Lanes; NQ]; NU],
        active: &[usize; NU],
        k: &mut [[B3Lanes; NY]; NY],
    ) {
        // Row quantity `ug`'s G (None: not active in this mode, zero).
        let row = |ug: usize| active.iter().position(|&u| u == ug).map(|i| &g[i]);
        let u0 = row(0).expect("the f-force is always active");
        let (u1, u2) = (row(1), row(2));
        for yg in 0..NY {
            k[0][yg] = self.through_q(u0, yg);
            // The f-moment's blocks through R_i (its i-half) and R_f (its f-half).
            let mut f2 = B3Lanes::ZERO;
            if let Some(u2) = u2 {
                f2 = B3Lanes::pre_mul(&self.rf_t[a], &self.through_q(u2, yg));
            }
            k[1][yg] = match (u1, u2) {
                (Some(u1), Some(_)) => {
                    B3Lanes::pre_mul(&self.ri_t[a], &self.through_q(u1, yg)).plus(&f2)
                }
                (Some(u1), None) => B3Lanes::pre_mul(&self.ri_t[a], &self.through_q(u1, yg)),
                (None, _) => f2,
            };
            if self.ed {
                let (Some(u3), Some(u4)) = (row(3), row(4)) else {
                    unreachable!("ED chains every row quantity")
                };
                k[2][yg] = self.through_q(u3, yg);
                k[3][yg] = B3Lanes::pre_mul(&self.ri_t[a], &self.through_q(u4, yg)).minus(&f2);
            }
        }
        if self.at_f {
            let k11 = k[1][1].lane(a) + self.diag[a];
            k[1][1].set_lane(a, &k11);
            if self.ed {
                let k31 = k[3][1].lane(a) - self.diag[a];
                k[3][1].set_lane(a, &k31);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::beam::element::tests::{coupled, ctx, damped, fixture};

    /// The closed-form point Jacobian against the dual pass it replaced, for both schemes, at
    /// increments of ~0.3 rad and 6 % of the element's length on the stressed, moving fixture:
    /// both are exact, so they agree to round-off (1e-12 of the largest entry; a 1e-6 change
    /// of any term fails), on a decoupled section (the off-diagonal blocks' products
    /// skipped) and on a coupled and damped one.
    #[test]
    fn closed_form_point_jacobian_is_the_dual_one() {
        for (scheme, general) in [Scheme::Ep, Scheme::Ed]
            .into_iter()
            .flat_map(|s| [(s, false), (s, true)])
        {
            for n in 2..=4 {
                let (el, state, layout) = fixture(n, scheme);
                // Every block of C and D nonzero: none of their products skipped.
                let el = if general { damped(coupled(el)) } else { el };
                let c = ctx(layout, &state);
                let y: Vec<f64> = (0..layout.n_unknowns())
                    .map(|i| 0.15 * ((i as f64) * 1.3 + 0.4).sin())
                    .collect();
                let q = el.node_quantities::<f64>(&c, &y);
                for g in 0..el.points.len() {
                    let p = el.point_inputs(g, &q);
                    let (od, jd) = dual_point_jacobian::<{ GEO + 6 }>(&el, &c, g, &p);
                    let scale = jd.iter().flatten().map(|b| b.max_abs()).fold(0.0, f64::max);
                    // EP's closed form has D's outputs over the geometric inputs: the dual
                    // pass's other blocks must be zero.
                    let (o, jac): (_, Vec<Vec<B3>>) = if scheme == Scheme::Ed {
                        let mut j = [[B3::zero(); P_GROUPS]; O_GROUPS];
                        let o = closed_point_jacobian(&el, &c, g, &p, &mut j);
                        (o, j.iter().map(|r| r.to_vec()).collect())
                    } else {
                        let mut j = [[B3::zero(); 3]; 3];
                        let o = closed_point_jacobian(&el, &c, g, &p, &mut j);
                        (o, j.iter().map(|r| r.to_vec()).collect())
                    };
                    for (a, b) in o.iter().zip(&od) {
                        assert!((*a - *b).max_abs() <= 1e-12 * a.max_abs().max(1.0));
                    }
                    for (og, rb) in jd.iter().enumerate() {
                        for (pg, b) in rb.iter().enumerate() {
                            let a = jac.get(og).and_then(|r| r.get(pg)).copied();
                            let e = (a.unwrap_or(B3::zero()) - *b).max_abs();
                            let at = format!("{scheme:?} {general} n={n} g={g} ∂o{og}/∂p{pg}");
                            assert!(e <= 1e-12 * scale, "{at}: {e:e}");
                        }
                    }
                }
            }
        }
    }
}
