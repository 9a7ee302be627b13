//! The discrete equations a holonomic constraint adds to a step, whatever it connects: two
//! nodes (the classic joints) or a follower and the nodes of the beam elements its contact
//! point visits (the sliding joints). A constraint supplies its end value `C_f` and gradient
//! rows over *columns*: blocks of six spatial columns `[Δx, ρ]` per node and one column per
//! relative coordinate; [`ColumnMap`] says where each column's unknowns sit in the kernel's
//! local block.
//!
//! - EP: `B^Dᵀ sλ` on the momentum rows (the forces do no work: `Δ·B^Dᵀλ = λ·(C_f − C_i)`),
//!   and `s C_f = 0`.
//! - ED (ed-scheme-notes §3.2–3.3): adds the velocity-level multiplier λ_d:
//!   `(1/12)(B_f − B_i)ᵀ λ_d` on the f-rows, `−(1/12)(B_i + B_f)ᵀ λ_d` on the jump rows, and the
//!   condition `B(q_i) V_j − B(q_f) V_f = 0`.
//! - Statics: `B(q_f)ᵀ sλ` (rotation columns material at f) and `s C_f = 0`.
//!
//! Rotation columns are spatial (`R_f = cay(ρ) R_i`); the unknowns are material (`ρ = R_i r`),
//! so forces on them are `R_iᵀ g` (or `R_fᵀ g` for operators evaluated at f).
//!
//! The equations are linear in the multipliers and the jump velocities, with coefficients that
//! depend on the geometry alone. [`evaluate_constraint`] uses that: one dual-number pass over
//! the geometric unknowns (a node's 6 increments, the coordinates), and the columns of the
//! multipliers and jumps in closed form from the same pass's values ([`add_linear_columns`]).

use super::MAX_ROWS;
use crate::elements::{add3, eval_kernel, v3, Kernel, StepCtx, ValuePos};
use crate::math::layout::Layout;
use crate::math::layout::Scheme;
use crate::math::scalar::{Dual, Real};
use crate::math::vec3::{M3, V3};

/// Gradient rows over `NC` columns.
pub type Grad<T, const NC: usize> = [[T; NC]; MAX_ROWS];

pub fn zero_grad<T: Real, const NC: usize>() -> Grad<T, NC> {
    [[T::zero(); NC]; MAX_ROWS]
}

/// Six gradient columns `[Δx, ρ]` of one node and where its unknowns are.
#[derive(Clone, Copy, Debug)]
pub struct NodeColumns<T> {
    /// First gradient column of the block.
    pub col: usize,
    /// Local slot of the node's `[Δx, r]`; of its jump velocities `h [v_j, W_j]` (ED).
    pub delta: usize,
    pub jump: Option<usize>,
    /// The node's triad at the start and at the end of the step.
    pub r_i: M3<T>,
    pub r_f: M3<T>,
}

/// One coordinate column: its gradient column and the local slot of its increment (its jump
/// follows it under ED).
#[derive(Clone, Copy, Debug)]
pub struct CoordColumn {
    pub col: usize,
    pub slot: usize,
}

pub struct ColumnMap<'a, T> {
    pub nodes: &'a [NodeColumns<T>],
    pub coords: &'a [CoordColumn],
    /// Local slot of the first multiplier (under ED each row's λ_d follows its λ).
    pub mult: usize,
    /// Slots per multiplier and per coordinate in the local block: 2 if it was laid out for
    /// ED (λ_d, the jump follow), else 1 — the block's layout, whichever equations are
    /// evaluated on it (ED's decoupled surrogate evaluates EP's on an ED block).
    pub per: usize,
    pub n_rows: usize,
}

#[derive(Clone, Copy, PartialEq)]
enum At {
    Start,
    End,
}

impl<T: Real> ColumnMap<'_, T> {
    /// Multipliers as forces `sλ` (or `sλ_d`) from the local block.
    pub fn multipliers(&self, ctx: &StepCtx, y: &[T], jump: bool) -> [T; MAX_ROWS] {
        let mut l = [T::zero(); MAX_ROWS];
        for (r, lr) in l.iter_mut().enumerate().take(self.n_rows) {
            *lr = y[self.mult + self.per * r + usize::from(jump)] * ctx.s;
        }
        l
    }

    /// Adds `Bᵀ lam` to the momentum rows (rotation rows through the triad at `at`).
    fn add_forces<const NC: usize>(&self, b: &Grad<T, NC>, lam: &[T], at: At, out: &mut [T]) {
        let mut g = [T::zero(); NC];
        for (c, gc) in g.iter_mut().enumerate() {
            for r in 0..self.n_rows {
                *gc += b[r][c] * lam[r];
            }
        }
        for n in self.nodes {
            let rot = if at == At::Start { &n.r_i } else { &n.r_f };
            add3(out, n.delta, v3(&g, n.col));
            add3(out, n.delta + 3, rot.tmul_v(&v3(&g, n.col + 3)));
        }
        for c in self.coords {
            out[c.slot] += g[c.col];
        }
    }

    /// ED's velocity-level multiplier forces from `l = λ_d/12`: `(B_f − B_i)ᵀ l` on the
    /// momentum rows and `−(B_i + B_f)ᵀ l` on the jump rows (each `Bᵀ l` formed once).
    fn add_jump_forces<const NC: usize>(
        &self,
        b_i: &Grad<f64, NC>,
        b_f: &Grad<T, NC>,
        l: &[T],
        out: &mut [T],
    ) {
        let mut gi = [T::zero(); NC];
        let mut gf = [T::zero(); NC];
        for r in 0..self.n_rows {
            for c in 0..NC {
                gi[c] += l[r] * b_i[r][c];
                gf[c] += b_f[r][c] * l[r];
            }
        }
        for n in self.nodes {
            let (fi, ff) = (v3(&gi, n.col), v3(&gf, n.col));
            let mi = n.r_i.tmul_v(&v3(&gi, n.col + 3));
            let mf = n.r_f.tmul_v(&v3(&gf, n.col + 3));
            add3(out, n.delta, ff - fi);
            add3(out, n.delta + 3, mf - mi);
            let j = n.jump.expect("ED layout");
            add3(out, j, -(fi + ff));
            add3(out, j + 3, -(mi + mf));
        }
        for c in self.coords {
            out[c.slot] += gf[c.col] - gi[c.col];
            out[c.slot + 1] -= gi[c.col] + gf[c.col];
        }
    }

    /// ED's velocity-level j-condition `B(q_i) V_j − B(q_f) V_f` of the local block, in one
    /// pass over its nodes and coordinates (`V_f = 2Δ/h − V_j`, angular velocities spatial).
    fn jump_condition<const NC: usize>(
        &self,
        ctx: &StepCtx,
        b_i: &Grad<f64, NC>,
        b_f: &Grad<T, NC>,
        y: &[T],
        out: &mut [T],
    ) {
        let inv_h = 1.0 / ctx.h;
        for o in out.iter_mut().take(self.n_rows) {
            *o = T::zero();
        }
        for n in self.nodes {
            let j = n.jump.expect("ED layout");
            let (vj, wj) = (v3(y, j).scale_f(inv_h), v3(y, j + 3).scale_f(inv_h));
            let vf = v3(y, n.delta).scale_f(2.0 * inv_h) - vj;
            let wf = v3(y, n.delta + 3).scale_f(2.0 * inv_h) - wj;
            let (wj, wf) = (n.r_i.mul_v(&wj), n.r_f.mul_v(&wf));
            for (r, o) in out.iter_mut().enumerate().take(self.n_rows) {
                let (bi, bf) = (&b_i[r][n.col..n.col + 6], &b_f[r][n.col..n.col + 6]);
                let mut acc = *o;
                for c in 0..3 {
                    acc += vj.0[c] * bi[c] + wj.0[c] * bi[3 + c];
                    acc -= bf[c] * vf.0[c] + bf[3 + c] * wf.0[c];
                }
                *o = acc;
            }
        }
        for c in self.coords {
            let qj = y[c.slot + 1] * inv_h;
            let qf = y[c.slot] * (2.0 * inv_h) - qj;
            for (r, o) in out.iter_mut().enumerate().take(self.n_rows) {
                *o += qj * b_i[r][c.col] - b_f[r][c.col] * qf;
            }
        }
    }
}

/// What a constraint supplies for one evaluation of its step equations.
pub struct ConstraintTerms<'a, T, const NC: usize> {
    /// `C` at the end of the step.
    pub c_f: &'a [T],
    /// Time step: the exact discrete gradient `B^D`; statics: `B(q_f)`.
    pub b: &'a Grad<T, NC>,
    /// ED only: the rate operators `B(q_i)` and `B(q_f)` (`B(q_i)` a constant of the step,
    /// so plain numbers: no derivatives to carry through a tangent's dual pass).
    pub rates: Option<(&'a Grad<f64, NC>, &'a Grad<T, NC>)>,
}

/// Adds the constraint's equations (EP, ED or static, after `ctx`) to the local residual.
pub fn add_constraint_equations<T: Real, const NC: usize>(
    ctx: &StepCtx,
    map: &ColumnMap<T>,
    terms: &ConstraintTerms<T, NC>,
    y: &[T],
    res: &mut [T],
) {
    let n = map.n_rows;
    let per = map.per;
    let lam = map.multipliers(ctx, y, false);
    let at = if ctx.is_static() { At::End } else { At::Start };
    map.add_forces(terms.b, &lam[..n], at, res);
    for r in 0..n {
        res[map.mult + per * r] += terms.c_f[r] * ctx.s;
    }
    if !ctx.ed() {
        return;
    }
    let (b_i, b_f) = terms.rates.expect("ED needs the rate operators");
    let mut l = map.multipliers(ctx, y, true);
    for v in &mut l[..n] {
        *v = *v / 12.0;
    }
    // −P_f ∋ (1/12)(B_f − B_i)ᵀ λ_d ; −P_j/6 ∋ −(1/12)(B_i + B_f)ᵀ λ_d.
    map.add_jump_forces(b_i, b_f, &l[..n], res);
    // Velocity-level j-condition: B(q_i) V_j − B(q_f) V_f = 0.
    let mut cj = [T::zero(); MAX_ROWS];
    map.jump_condition(ctx, b_i, b_f, y, &mut cj);
    for r in 0..n {
        res[map.mult + 2 * r + 1] += cj[r] * (ctx.s * ctx.h);
    }
}

/// A kernel whose residual is [`add_constraint_equations`] of one constraint (or of one share
/// of it) over `NC` gradient columns.
pub trait StepEquations<const NC: usize>: Kernel + Sized {
    /// Local slots of the unknowns the geometry depends on (node increments `[Δx, r]`,
    /// coordinate increments) into `out`; returns how many (at most `NC`).
    fn geometric_slots(&self, ctx: &StepCtx, out: &mut [usize; NC]) -> usize;
    /// Whether the residual is linear in the nodes' translations with the gradient's own
    /// coefficients (see `ConstraintLaw::affine_in_translations`): `geometric_slots` then
    /// leaves them out and [`add_translation_columns`] writes their columns.
    fn translations_linear(&self) -> bool {
        false
    }
    /// Calls `f` with the constraint's column map and step terms at the local unknowns `y`.
    fn with_equations<T: Real, R>(
        &self,
        ctx: &StepCtx,
        y: &[T],
        f: impl FnOnce(&ColumnMap<T>, &ConstraintTerms<T, NC>) -> R,
    ) -> R;

    /// The residual: the step equations at `y`.
    fn equations_residual<T: Real>(&self, ctx: &StepCtx, y: &[T], res: &mut [T]) {
        self.with_equations(ctx, y, |map, terms| {
            add_constraint_equations(ctx, map, terms, y, res)
        })
    }
}

/// Largest local block [`evaluate_constraint`] differentiates by the split (a two-node screw
/// joint under ED: 2×12 + 2×2 + 2×7 = 42).
pub const MAX_SPLIT_LOCAL: usize = 44;

/// What [`split_pass`] (or a closed-form tangent) writes of the tangent.
#[derive(Clone, Copy, PartialEq)]
pub enum Tangent {
    /// The exact tangent (and the residual from the same pass).
    Exact,
    /// ED's decoupled surrogate (see [`evaluate_constraint_decoupled`]); no residual.
    Decoupled,
}

/// Residual and exact tangent of a constraint kernel: a dual pass of width ≥ the number of
/// geometric unknowns (6 for a joint to the ground, 12–14 between two nodes) instead of
/// `⌈n/8⌉` passes over all `n` unknowns (3 for an EP revolute joint, 5 under ED).
pub fn evaluate_constraint<K: StepEquations<NC>, const NC: usize>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    jac: Option<(&mut [f64], &[ValuePos])>,
) {
    let Some((vals, pos)) = jac else {
        return eval_kernel(k, ctx, y, res, None);
    };
    if k.unknowns().len() > MAX_SPLIT_LOCAL {
        return eval_kernel(k, ctx, y, res, Some((vals, pos)));
    }
    split(k, ctx, y, (Some(res), vals, pos), Tangent::Exact);
}

/// ED under modified Newton ([`crate::elements::Kernel::evaluate_decoupled`]): ED's residual,
/// and the rows the decoupled complex system reads written from EP's equations on the same
/// increments, as the beams do (`beam::tangent::decoupled_surrogate`): the f-rows' λ columns
/// `s B^Dᵀ`, the constraint rows' increment columns `s ∂C_f/∂Δ` (both exactly ED's), and on
/// the j-rows the constraint forces' geometric stiffness `K ≈ 2 ∂(B^Dᵀ sλ)/∂Δ` as a linear
/// stiffness enters them (`−2K/9` on the increments, `K/18` on the jumps). One EP-sized dual
/// pass without the rate operators, instead of ED's.
pub fn evaluate_constraint_decoupled<K: StepEquations<NC>, const NC: usize>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    debug_assert!(ctx.ed());
    if k.unknowns().len() > MAX_SPLIT_LOCAL {
        return eval_kernel(k, ctx, y, res, Some((vals, pos)));
    }
    eval_kernel(k, ctx, y, res, None);
    split(
        k,
        &ep_equations(ctx),
        y,
        (None, vals, pos),
        Tangent::Decoupled,
    );
}

/// The step `ctx` with EP's equations on its block's layout (ED's decoupled surrogate).
pub fn ep_equations<'a>(ctx: &StepCtx<'a>) -> StepCtx<'a> {
    StepCtx {
        layout: Layout {
            scheme: Scheme::Ep,
            ..ctx.layout
        },
        ..*ctx
    }
}

/// [`split_pass`] with widths and buffers no larger than needed (dual buffers are zeroed on
/// every call).
fn split<K: StepEquations<NC>, const NC: usize>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    out: (Option<&mut [f64]>, &mut [f64], &[ValuePos]),
    tangent: Tangent,
) {
    let mut slots = [0usize; NC];
    let g = k.geometric_slots(ctx, &mut slots);
    let slots = &slots[..g];
    let small = k.unknowns().len() <= 24;
    match (g, small) {
        (0..=6, true) => split_pass::<K, NC, 6, 24>(k, ctx, y, out, slots, tangent),
        (0..=6, false) => split_pass::<K, NC, 6, MAX_SPLIT_LOCAL>(k, ctx, y, out, slots, tangent),
        // Two-node joints affine in the translations: two rotations and one or two angles.
        (7, true) => split_pass::<K, NC, 7, 24>(k, ctx, y, out, slots, tangent),
        (7, false) => split_pass::<K, NC, 7, MAX_SPLIT_LOCAL>(k, ctx, y, out, slots, tangent),
        (8, true) => split_pass::<K, NC, 8, 24>(k, ctx, y, out, slots, tangent),
        (8, false) => split_pass::<K, NC, 8, MAX_SPLIT_LOCAL>(k, ctx, y, out, slots, tangent),
        (9..=12, true) => split_pass::<K, NC, 12, 24>(k, ctx, y, out, slots, tangent),
        (9..=12, false) => split_pass::<K, NC, 12, MAX_SPLIT_LOCAL>(k, ctx, y, out, slots, tangent),
        (13, true) => split_pass::<K, NC, 13, 24>(k, ctx, y, out, slots, tangent),
        (13, false) => split_pass::<K, NC, 13, MAX_SPLIT_LOCAL>(k, ctx, y, out, slots, tangent),
        _ => split_pass::<K, NC, 14, MAX_SPLIT_LOCAL>(k, ctx, y, out, slots, tangent),
    }
}

/// One dual pass of width `W` seeded on `slots` (buffers of `M` ≥ n entries), then the
/// linear columns.
fn split_pass<K: StepEquations<NC>, const NC: usize, const W: usize, const M: usize>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    (res, vals, pos): (Option<&mut [f64]>, &mut [f64], &[ValuePos]),
    slots: &[usize],
    tangent: Tangent,
) {
    assert!(
        slots.len() <= W,
        "more geometric unknowns than dual directions"
    );
    let idx = k.unknowns();
    let n = idx.len();
    let mut yd = [Dual::<W>::constant(0.0); M];
    for (l, &g) in idx.iter().enumerate() {
        yd[l].re = y[g];
    }
    for (d, &l) in slots.iter().enumerate() {
        yd[l].du[d] = 1.0;
    }
    let mut rd = [Dual::<W>::constant(0.0); M];
    // Each motion row's (and column's) jump slot, for the decoupled surrogate.
    let mut jump_of = [None; M];
    let (yd, rd) = (&yd[..n], &mut rd[..n]);
    k.with_equations(ctx, yd, |map, terms| {
        add_constraint_equations(ctx, map, terms, yd, rd);
        let (nodes, nn) = node_values(map, &mut jump_of);
        let map_re = ColumnMap {
            nodes: &nodes[..nn],
            coords: map.coords,
            mult: map.mult,
            per: map.per,
            n_rows: map.n_rows,
        };
        let b = grad_values(terms.b);
        let b_f = terms.rates.map(|(_, bf)| grad_values(bf));
        let terms_re = ConstraintTerms {
            c_f: &[],
            b: &b,
            rates: terms.rates.zip(b_f.as_ref()).map(|((bi, _), bf)| (bi, bf)),
        };
        add_linear_columns(ctx, &map_re, &terms_re, n, vals, pos);
        if k.translations_linear() {
            add_translation_columns(ctx, &map_re, &terms_re, n, vals, pos);
        }
    });
    if let Some(res) = res {
        for (i, r) in rd.iter().enumerate() {
            res[idx[i]] += r.re;
        }
    }
    add_dual_columns(rd, slots, &jump_of[..n], tangent, vals, pos);
}

/// The geometric columns from the dual parts of the residual `rd` (seeded on `slots`): as
/// they are, or for ED's decoupled surrogate each motion row's stiffness moved to its jump
/// row as a linear stiffness enters it (`−4/9` on the increments, `1/9` on the jumps: `K/18`
/// and `−2K/9` of `K = 2 ∂P/∂Δ`).
fn add_dual_columns<const W: usize>(
    rd: &[Dual<W>],
    slots: &[usize],
    jump_of: &[Option<usize>],
    tangent: Tangent,
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    let n = rd.len();
    for (i, r) in rd.iter().enumerate() {
        for (d, &l) in slots.iter().enumerate() {
            add_geometric_entry(tangent, jump_of, n, (i, l, r.du[d]), vals, pos);
        }
    }
}

/// Adds `v = ∂res_i/∂y_l` of a geometric slot `l` to a block of `n` unknowns: where it is, or
/// for ED's decoupled surrogate, on a motion row, moved to its jump row as a linear stiffness
/// enters it (`−4/9` on the increment, `1/9` on its jump).
#[inline(always)]
pub fn add_geometric_entry(
    tangent: Tangent,
    jump_of: &[Option<usize>],
    n: usize,
    (i, l, v): (usize, usize, f64),
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    match (tangent, jump_of[i]) {
        (Tangent::Decoupled, Some(ji)) => {
            let jl = jump_of[l].expect("a geometric slot has a jump under ED");
            vals[pos[ji * n + l] as usize] -= (4.0 / 9.0) * v;
            vals[pos[ji * n + jl] as usize] += v / 9.0;
        }
        _ => vals[pos[i * n + l] as usize] += v,
    }
}

/// The map's node blocks as values, and each motion slot's jump slot into `jump_of` (for
/// the decoupled surrogate).
fn node_values<T: Real>(
    map: &ColumnMap<T>,
    jump_of: &mut [Option<usize>],
) -> ([NodeColumns<f64>; MAX_MAP_NODES], usize) {
    let mut nodes = [NodeColumns {
        col: 0,
        delta: 0,
        jump: None,
        r_i: M3::identity(),
        r_f: M3::identity(),
    }; MAX_MAP_NODES];
    let nn = map.nodes.len();
    assert!(
        nn <= MAX_MAP_NODES,
        "the split differentiates two-node maps"
    );
    for (v, m) in nodes.iter_mut().zip(map.nodes) {
        *v = m.values();
        if let Some(j) = m.jump {
            for c in 0..6 {
                jump_of[m.delta + c] = Some(j + c);
            }
        }
    }
    if map.per == 2 {
        for c in map.coords {
            jump_of[c.slot] = Some(c.slot + 1);
        }
    }
    (nodes, nn)
}

/// Most node blocks in the map of a kernel differentiated by the split (two nodes).
const MAX_MAP_NODES: usize = 2;

impl<T: Real> NodeColumns<T> {
    fn values(&self) -> NodeColumns<f64> {
        NodeColumns {
            col: self.col,
            delta: self.delta,
            jump: self.jump,
            r_i: self.r_i.re(),
            r_f: self.r_f.re(),
        }
    }
}

fn grad_values<T: Real, const NC: usize>(b: &Grad<T, NC>) -> Grad<f64, NC> {
    let mut out = [[0.0; NC]; MAX_ROWS];
    for (o, row) in out.iter_mut().zip(b) {
        for (v, x) in o.iter_mut().zip(row) {
            *v = x.re();
        }
    }
    out
}

impl ColumnMap<'_, f64> {
    /// Calls `f(slot, value)` for each local unknown a gradient row acts on, mapped as the
    /// forces `Bᵀλ` are: a node's force columns as they are, its moment columns through `Rᵀ`
    /// of the start or end triad, the coordinates'; on the momentum rows (`delta`, the
    /// coordinate increment) or, with `jump`, the jump rows.
    fn for_each_entry<const NC: usize>(
        &self,
        row: &[f64; NC],
        at: At,
        jump: bool,
        mut f: impl FnMut(usize, f64),
    ) {
        for n in self.nodes {
            let Some(s) = (if jump { n.jump } else { Some(n.delta) }) else {
                continue;
            };
            let rot = if at == At::Start { &n.r_i } else { &n.r_f };
            let moment = rot.tmul_v(&v3(row, n.col + 3));
            for c in 0..3 {
                f(s + c, row[n.col + c]);
                f(s + 3 + c, moment.0[c]);
            }
        }
        for c in self.coords {
            f(c.slot + usize::from(jump), row[c.col]);
        }
    }
}

/// The tangent columns of the multipliers λ (and under ED λ_d and the jump velocities) of
/// [`add_constraint_equations`], which is linear in them: `s B^Dᵀ` on the momentum rows;
/// `(s/12)(B_f − B_i)ᵀ` and `−(s/12)(B_i + B_f)ᵀ` for λ_d; `s (B_i + B_f)` on the j-condition's
/// jump columns (its `h` cancels the velocities' `1/h`). `vals[pos[row * n + col] as usize]`.
pub fn add_linear_columns<const NC: usize>(
    ctx: &StepCtx,
    map: &ColumnMap<f64>,
    terms: &ConstraintTerms<f64, NC>,
    n: usize,
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    let s = ctx.s;
    let per = map.per;
    let at = if ctx.is_static() { At::End } else { At::Start };
    // Structural zeros (a coincident point's rows on the other translations, an angle's on
    // any) are skipped: a branch the same for every joint of a kind, against a scattered add.
    let mut put = |row: usize, col: usize, v: f64| {
        if v != 0.0 {
            vals[pos[row * n + col] as usize] += v
        }
    };
    for r in 0..map.n_rows {
        let lam = map.mult + per * r;
        map.for_each_entry(&terms.b[r], at, false, |slot, v| put(slot, lam, s * v));
        let Some((b_i, b_f)) = terms.rates else {
            continue;
        };
        let (lam_d, q) = (lam + 1, s / 12.0);
        map.for_each_entry(&b_f[r], At::End, false, |slot, v| put(slot, lam_d, q * v));
        map.for_each_entry(&b_i[r], At::Start, false, |slot, v| {
            put(slot, lam_d, -q * v)
        });
        map.for_each_entry(&b_i[r], At::Start, true, |slot, v| {
            put(slot, lam_d, -q * v);
            put(lam_d, slot, s * v);
        });
        map.for_each_entry(&b_f[r], At::End, true, |slot, v| {
            put(slot, lam_d, -q * v);
            put(lam_d, slot, s * v);
        });
    }
}

/// The tangent columns of the nodes' translation increments of a constraint whose residual
/// is linear in them (`C = x₂ − x₁ + …`, gradients free of positions): `s B` on the
/// position rows and, under ED, `−2s B_f` on the j-condition (`V_f = 2Δ/h − V_j`); the
/// momentum rows do not depend on them.
pub fn add_translation_columns<const NC: usize>(
    ctx: &StepCtx,
    map: &ColumnMap<f64>,
    terms: &ConstraintTerms<f64, NC>,
    n: usize,
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    let s = ctx.s;
    for r in 0..map.n_rows {
        let row = map.mult + map.per * r;
        for node in map.nodes {
            for c in 0..3 {
                let col = node.delta + c;
                let b = terms.b[r][node.col + c];
                if b != 0.0 {
                    vals[pos[row * n + col] as usize] += s * b;
                }
                let b_f = terms.rates.map_or(0.0, |(_, b_f)| b_f[r][node.col + c]);
                if b_f != 0.0 {
                    vals[pos[(row + 1) * n + col] as usize] -= 2.0 * s * b_f;
                }
            }
        }
    }
}

/// `B^D·Δ` over a converged step (for the constraint-work check), with the spatial rotation
/// increments `ρ = R_i r` of each node and the coordinates' increments.
pub fn gradient_times_increment<const NC: usize>(
    map: &ColumnMap<f64>,
    b: &Grad<f64, NC>,
    y: &[f64],
    out: &mut [f64],
) {
    for (r, o) in out.iter_mut().enumerate().take(map.n_rows) {
        let mut acc = 0.0;
        for n in map.nodes {
            let rho = n.r_i.mul_v(&v3(y, n.delta + 3));
            let dx: V3<f64> = v3(y, n.delta);
            for c in 0..3 {
                acc += b[r][n.col + c] * dx.0[c] + b[r][n.col + 3 + c] * rho.0[c];
            }
        }
        for c in map.coords {
            acc += b[r][c.col] * y[c.slot];
        }
        *o = acc;
    }
}

/// `−Bᵀλ` on one node block: the constraint's force and moment (spatial) on that node.
pub fn node_force<const NC: usize>(
    b: &Grad<f64, NC>,
    lam: &[f64],
    col: usize,
) -> (V3<f64>, V3<f64>) {
    let mut f = V3::zero();
    let mut m = V3::zero();
    for (r, l) in lam.iter().enumerate() {
        for c in 0..3 {
            f.0[c] -= b[r][col + c] * l;
            m.0[c] -= b[r][col + 3 + c] * l;
        }
    }
    (f, m)
}
