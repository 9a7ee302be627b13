//! A joint's EP step equations with their tangent in closed form, no dual pass: the
//! multipliers' columns `s B^Dᵀ` and the translations' `s B` as the dual pass writes them
//! ([`equations::add_linear_columns`], [`equations::add_translation_columns`]), and the
//! geometric columns from
//! - the constraint rows `s C_f`: `s B(q_f)`, the rate operator at the end (`δC = B δz` for the
//!   end state's spatial variations `δz`);
//! - the force rows `B^Dᵀ sλ`: the law's [`ConstraintLaw::force_stiffness`];
//!
//! each mapped to the unknowns: a node's material rotation `r` moves its end triad by
//! `θ = R_f T(r) δr` (`rotation::cayley_tangent`), and the moments act on it through `R_iᵀ`.
//! EP's time steps and ED's decoupled surrogate (EP's equations on ED's block) use it, for
//! pair joints here and for a sliding joint's node shares (`sliding::NodeShare`, whose
//! weights add their ζ columns); ED's exact tangent and statics keep the dual pass
//! ([`equations::evaluate_constraint`]).

use super::equations::{
    add_constraint_equations, add_geometric_entry, add_linear_columns, add_translation_columns,
    ep_equations, evaluate_constraint, ColumnMap, ConstraintTerms, StepEquations, Tangent,
    MAX_SPLIT_LOCAL,
};
use super::stiffness::Stiffness;
use super::{zero_rows, ConstraintLaw, JointKernel, JointState, MAX_ROWS, NCOL};
use crate::elements::{eval_kernel, StepCtx, ValuePos};
use crate::math::rotation::cayley_tangent;
use crate::math::vec3::{M3, V3};

/// A constraint kernel whose EP step tangent is written in closed form (a pair joint, a
/// sliding joint's node share).
pub trait ClosedTangent<const NC: usize>: StepEquations<NC> {
    /// EP's step equations at the block's unknowns `y` (global): the residual into `res` (if
    /// given) and the tangent into `vals[pos[row·n + col]]`, exactly or as ED's decoupled
    /// surrogate (`ctx` then EP's view of an ED step, [`ep_equations`]).
    fn evaluate_closed(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: Option<&mut [f64]>,
        jac: (&mut [f64], &[ValuePos]),
        tangent: Tangent,
    );
}

/// `Kernel::evaluate` of such a kernel: EP's time steps in closed form, ED's and statics'
/// tangents by the dual pass ([`evaluate_constraint`]).
pub fn evaluate<K: ClosedTangent<NC>, const NC: usize>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    jac: Option<(&mut [f64], &[ValuePos])>,
) {
    match jac {
        Some(jac) if !ctx.ed() && !ctx.is_static() => {
            k.evaluate_closed(ctx, y, Some(res), jac, Tangent::Exact)
        }
        jac => evaluate_constraint(k, ctx, y, res, jac),
    }
}

/// `Kernel::evaluate_decoupled` of such a kernel: ED's residual and, from EP's closed-form
/// tangent, the decoupled surrogate ([`super::equations::evaluate_constraint_decoupled`] says
/// what it holds).
pub fn evaluate_decoupled<K: ClosedTangent<NC>, const NC: usize>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    eval_kernel(k, ctx, y, res, None);
    decoupled_tangent(k, ctx, y, vals, pos)
}

/// [`evaluate_decoupled`]'s tangent entries alone (`Kernel::decoupled_tangent`): the ED
/// residual it would add is a pass of its own.
pub fn decoupled_tangent<K: ClosedTangent<NC>, const NC: usize>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    k.evaluate_closed(&ep_equations(ctx), y, None, (vals, pos), Tangent::Decoupled)
}

/// The geometric derivative of a block's equations over the end state's spatial
/// variations `[x₁, θ₁, x₂, θ₂, q]`: its force rows (the force columns in the same order)
/// and its constraint rows.
pub struct Geometric {
    pub force: Stiffness,
    pub constraint: [[f64; NCOL]; MAX_ROWS],
}

impl Geometric {
    pub fn zero() -> Self {
        Geometric {
            force: [[0.0; NCOL]; NCOL],
            constraint: [[0.0; NCOL]; MAX_ROWS],
        }
    }

    fn row(&self, r: usize) -> &[f64; NCOL] {
        if r < NCOL {
            &self.force[r]
        } else {
            &self.constraint[r - NCOL]
        }
    }

    fn row_mut(&mut self, r: usize) -> &mut [f64; NCOL] {
        if r < NCOL {
            &mut self.force[r]
        } else {
            &mut self.constraint[r - NCOL]
        }
    }
}

/// One side's unknowns in a block: the local slot of its `[Δx, r]`, its triads at the start
/// and end of the step and its material rotation increment `r`.
#[derive(Clone, Copy)]
pub struct SideFrame {
    pub delta: usize,
    pub r_i: M3<f64>,
    pub r_f: M3<f64>,
    pub r: V3<f64>,
}

/// Where a block's geometric derivative goes: side k's rows and columns at `6k`, the
/// coordinates' at `12 + c`, the constraint rows at the multipliers' slots.
pub struct BlockColumns<'a> {
    pub sides: [Option<SideFrame>; 2],
    /// Local slots of the coordinates.
    pub coords: &'a [usize],
    pub mult: usize,
    /// Slots per multiplier and coordinate: 2 on an ED block (the jump follows), else 1.
    pub per: usize,
    pub n_rows: usize,
    /// Whether the translations' columns are written by `add_translation_columns`.
    pub translations_linear: bool,
}

impl BlockColumns<'_> {
    /// Adds `d` to the tangent of a block of `n` unknowns: each side's rotation columns
    /// turned to its material unknowns (`θ = R_f T(r) δr`) and its moment rows through
    /// `R_iᵀ`; exactly or as ED's decoupled surrogate ([`add_geometric_entry`]).
    pub fn add(
        &self,
        d: &mut Geometric,
        tangent: Tangent,
        n: usize,
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        let (rows, cols) = self.entries();
        for (k, side) in self.sides.iter().enumerate() {
            let Some(side) = side else { continue };
            let th = 6 * k + 3;
            let gamma = side.r_f.mul_m(&cayley_tangent(&side.r));
            for &(_, dr) in rows.listed() {
                let row = d.row_mut(dr);
                let v = gamma.tmul_v(&V3([row[th], row[th + 1], row[th + 2]]));
                row[th..th + 3].copy_from_slice(&v.0);
            }
            turn_rows(&mut d.force, th, &side.r_i, cols.listed());
        }
        let jump_of = self.jumps(tangent);
        for &(i, dr) in rows.listed() {
            let row = d.row(dr);
            for &(l, dc) in cols.listed() {
                add_geometric_entry(tangent, &jump_of[..n], n, (i, l, row[dc]), vals, pos);
            }
        }
    }

    /// Each motion slot's jump slot on an ED block (the jumps follow the increments), for
    /// the decoupled surrogate.
    fn jumps(&self, tangent: Tangent) -> [Option<usize>; MAX_SPLIT_LOCAL] {
        let mut jump_of = [None; MAX_SPLIT_LOCAL];
        if tangent == Tangent::Decoupled {
            for side in self.sides.iter().flatten() {
                for c in 0..6 {
                    jump_of[side.delta + c] = Some(side.delta + 6 + c);
                }
            }
            for &slot in self.coords {
                jump_of[slot] = Some(slot + 1);
            }
        }
        jump_of
    }

    /// The rows and the geometric columns the block writes: (local slot, row or column of
    /// the derivative). The forces on the translations of a law affine in them are `∓λ` (no
    /// geometric stiffness), and their columns are `add_translation_columns`'.
    fn entries(&self) -> (Slots<{ NCOL + MAX_ROWS }>, Slots<NCOL>) {
        let first = if self.translations_linear { 3 } else { 0 };
        let (mut rows, mut cols) = (Slots::new(), Slots::new());
        for (k, side) in self.sides.iter().enumerate() {
            if let Some(side) = side {
                for c in first..6 {
                    rows.push(side.delta + c, 6 * k + c);
                    cols.push(side.delta + c, 6 * k + c);
                }
            }
        }
        for (c, &slot) in self.coords.iter().enumerate() {
            rows.push(slot, 12 + c);
            cols.push(slot, 12 + c);
        }
        for r in 0..self.n_rows {
            rows.push(self.mult + self.per * r, NCOL + r);
        }
        (rows, cols)
    }
}

/// Up to `N` pairs (local slot, index in the derivative).
struct Slots<const N: usize> {
    pairs: [(usize, usize); N],
    len: usize,
}

impl<const N: usize> Slots<N> {
    fn new() -> Self {
        Slots {
            pairs: [(0, 0); N],
            len: 0,
        }
    }

    fn push(&mut self, slot: usize, index: usize) {
        self.pairs[self.len] = (slot, index);
        self.len += 1;
    }

    fn listed(&self) -> &[(usize, usize)] {
        &self.pairs[..self.len]
    }
}

/// Moment rows `th..th+3` of `d` as they act on the material unknowns: `R_iᵀ` of them, in
/// the columns `cols` (derivative column second) that are written.
fn turn_rows(d: &mut Stiffness, th: usize, r_i: &M3<f64>, cols: &[(usize, usize)]) {
    let [a, b, c] = &mut d[th..th + 3] else {
        unreachable!("three moment rows")
    };
    for &(_, j) in cols {
        [a[j], b[j], c[j]] = r_i.tmul_v(&V3([a[j], b[j], c[j]])).0;
    }
}

impl ClosedTangent<NCOL> for JointKernel {
    fn evaluate_closed(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: Option<&mut [f64]>,
        (vals, pos): (&mut [f64], &[ValuePos]),
        tangent: Tangent,
    ) {
        debug_assert!(!ctx.ed() && !ctx.is_static());
        let n = self.unknowns.len();
        let buf = self.gather(y);
        let yl = &buf[..n];
        let si = self.state_i(ctx);
        let (sf, rs) = self.state_f(&si, &si, yl);
        let (blocks, nb, coords) = self.columns(&si, &sf);
        let nr = self.n_rows();
        let map = ColumnMap {
            nodes: &blocks[..nb],
            coords: &coords[..self.coords.len()],
            mult: self.mult_slot,
            per: self.per,
            n_rows: nr,
        };
        let mut c = [0.0; MAX_ROWS];
        self.law.value(&sf, &mut c);
        let mut b = zero_rows();
        self.law.discrete_gradient(&si, &sf, &mut b);
        let terms = ConstraintTerms {
            c_f: &c[..nr],
            b: &b,
            rates: None,
        };
        if let Some(res) = res {
            let mut rl = [0.0; MAX_SPLIT_LOCAL];
            add_constraint_equations(ctx, &map, &terms, yl, &mut rl[..n]);
            for (&g, r) in self.unknowns.iter().zip(&rl[..n]) {
                res[g] += r;
            }
        }
        add_linear_columns(ctx, &map, &terms, n, vals, pos);
        if self.translations_linear() {
            add_translation_columns(ctx, &map, &terms, n, vals, pos);
        }
        let mut d = Geometric::zero();
        self.geometric_derivative(ctx, (&si, &sf), yl, &mut d);
        let coord_slots: [usize; 2] = std::array::from_fn(|c| self.coord_slot + self.per * c);
        let frame = |k: usize| {
            self.slots[k].delta.map(|delta| SideFrame {
                delta,
                r_i: si.r[k],
                r_f: sf.r[k],
                r: rs[k],
            })
        };
        let block = BlockColumns {
            sides: [frame(0), frame(1)],
            coords: &coord_slots[..self.coords.len()],
            mult: self.mult_slot,
            per: self.per,
            n_rows: nr,
            translations_linear: self.translations_linear(),
        };
        block.add(&mut d, tangent, n, vals, pos);
    }
}

impl JointKernel {
    /// `∂(B^Dᵀ sλ, s C_f)/∂` the end state's spatial variations, added to `d` (zero).
    fn geometric_derivative(
        &self,
        ctx: &StepCtx,
        (si, sf): (&JointState<f64>, &JointState<f64>),
        yl: &[f64],
        d: &mut Geometric,
    ) {
        let nr = self.n_rows();
        let lam = self.multipliers(ctx, yl, false);
        self.law.force_stiffness(si, sf, &lam[..nr], &mut d.force);
        self.law.rate(sf, &mut d.constraint);
        for row in &mut d.constraint[..nr] {
            for v in row.iter_mut() {
                *v *= ctx.s;
            }
        }
    }
}

/// Test support: asserts that the closed form's `(residual, tangent)` is the dual pass's.
#[cfg(test)]
pub fn assert_same_evaluation(closed: (&[f64], &[f64]), dual: (&[f64], &[f64]), what: &str) {
    let largest = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let apart = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
    };
    // The same derivatives by other arithmetic: round-off of the largest entry.
    let (worst, scale) = (apart(closed.1, dual.1), largest(dual.1));
    assert!(
        worst <= 1e-13 * scale,
        "{what}: tangents differ by {worst:e} of {scale:e}"
    );
    let (worst, scale) = (apart(closed.0, dual.0), largest(dual.0));
    assert!(
        worst <= 1e-14 * scale,
        "{what}: residuals differ by {worst:e} of {scale:e}"
    );
}
