//! A pair joint's EP step equations with their tangent in closed form, no dual pass: the
//! multipliers' columns `s B^Dᵀ` and the translations' `s B` as the dual pass writes them
//! ([`equations::add_linear_columns`], [`equations::add_translation_columns`]), and the
//! geometric columns from
//! - the constraint rows `s C_f`: `s B(q_f)`, the rate operator at the end (`δC = B δz` for the
//!   end state's spatial variations `δz`);
//! - the force rows `B^Dᵀ sλ`: the law's [`ConstraintLaw::force_stiffness`];
//!
//! each mapped to the unknowns: a node's material rotation `r` moves its end triad by
//! `θ = R_f T(r) δr` (`rotation::cayley_tangent`), and the moments act on it through `R_iᵀ`.
//! EP's time steps and ED's decoupled surrogate (EP's equations on ED's block) use it; ED's
//! exact tangent and statics keep the dual pass ([`equations::evaluate_constraint`]).

use super::equations::{
    add_constraint_equations, add_geometric_entry, add_linear_columns, add_translation_columns,
    node_values, ColumnMap, ConstraintTerms, StepEquations, Tangent, MAX_SPLIT_LOCAL,
};
use super::stiffness::Stiffness;
use super::{zero_rows, ConstraintLaw, JointKernel, JointState, MAX_ROWS, NCOL};
use crate::elements::StepCtx;
use crate::math::rotation::cayley_tangent;
use crate::math::vec3::{M3, V3};

/// The geometric derivative's rows: the force columns `[x₁, θ₁, x₂, θ₂, q]` (the force
/// stiffness) and the constraint rows.
struct Geometric {
    force: Stiffness,
    constraint: [[f64; NCOL]; MAX_ROWS],
}

impl Geometric {
    fn row(&self, r: usize) -> &[f64; NCOL] {
        if r < NCOL {
            &self.force[r]
        } else {
            &self.constraint[r - NCOL]
        }
    }
}

impl JointKernel {
    /// EP's step equations at the block's unknowns `y` (global): the residual into `res` (if
    /// given) and the tangent into `vals[pos[row·n + col]]`, exactly or as ED's decoupled
    /// surrogate (`ctx` then EP's view of an ED step, [`super::equations::ep_equations`]).
    pub(super) fn evaluate_closed(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: Option<&mut [f64]>,
        (vals, pos): (&mut [f64], &[usize]),
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
        let mut jump_of = [None; MAX_SPLIT_LOCAL];
        if tangent == Tangent::Decoupled {
            node_values(&map, &mut jump_of);
        }
        let d = self.geometric_derivative(ctx, (&si, &sf), &rs, yl);
        self.for_each_geometric_entry(&d, |i, l, v| {
            add_geometric_entry(tangent, &jump_of[..n], n, (i, l, v), vals, pos)
        });
    }

    /// `∂(B^Dᵀ sλ, s C_f)/∂` the end state's variations, with each node's rotation columns
    /// turned to its material unknowns and its moment rows through `R_iᵀ`.
    fn geometric_derivative(
        &self,
        ctx: &StepCtx,
        (si, sf): (&JointState<f64>, &JointState<f64>),
        rs: &[V3<f64>; 2],
        yl: &[f64],
    ) -> Geometric {
        let nr = self.n_rows();
        let lam = self.multipliers(ctx, yl, false);
        let mut d = Geometric {
            force: [[0.0; NCOL]; NCOL],
            constraint: [[0.0; NCOL]; MAX_ROWS],
        };
        self.law.force_stiffness(si, sf, &lam[..nr], &mut d.force);
        self.law.rate(sf, &mut d.constraint);
        for row in &mut d.constraint[..nr] {
            for v in row.iter_mut() {
                *v *= ctx.s;
            }
        }
        for (side, r) in rs.iter().enumerate() {
            if self.slots[side].delta.is_none() {
                continue;
            }
            let th = 6 * side + 3;
            let gamma = sf.r[side].mul_m(&cayley_tangent(r));
            for row in d.force.iter_mut().chain(&mut d.constraint[..nr]) {
                let v = gamma.tmul_v(&V3([row[th], row[th + 1], row[th + 2]]));
                row[th..th + 3].copy_from_slice(&v.0);
            }
            turn_rows(&mut d.force, th, &si.r[side]);
        }
        d
    }

    /// Calls `f(local row, local geometric slot, value)` for each entry of the derivative.
    fn for_each_geometric_entry(&self, d: &Geometric, mut f: impl FnMut(usize, usize, f64)) {
        let first = if self.translations_linear() { 3 } else { 0 };
        let per = self.per;
        // (local slot, derivative row) of the rows; (local slot, derivative column) of the
        // geometric unknowns.
        let mut rows = [(0, 0); NCOL + MAX_ROWS];
        let mut cols = [(0, 0); NCOL];
        let (mut nr, mut nc) = (0, 0);
        for (side, s) in self.slots.iter().enumerate() {
            if let Some(delta) = s.delta {
                for c in 0..6 {
                    rows[nr] = (delta + c, 6 * side + c);
                    nr += 1;
                }
                for c in first..6 {
                    cols[nc] = (delta + c, 6 * side + c);
                    nc += 1;
                }
            }
        }
        for c in 0..self.coords.len() {
            rows[nr] = (self.coord_slot + per * c, 12 + c);
            cols[nc] = (self.coord_slot + per * c, 12 + c);
            (nr, nc) = (nr + 1, nc + 1);
        }
        for r in 0..self.n_rows() {
            rows[nr] = (self.mult_slot + per * r, NCOL + r);
            nr += 1;
        }
        // Structural zeros (the forces on a coincident point's translations) are skipped.
        for &(i, dr) in &rows[..nr] {
            for &(l, dc) in &cols[..nc] {
                let v = d.row(dr)[dc];
                if v != 0.0 {
                    f(i, l, v);
                }
            }
        }
    }
}

/// Moment rows `th..th+3` of `d` as they act on the material unknowns: `R_iᵀ` of them.
fn turn_rows(d: &mut Stiffness, th: usize, r_i: &M3<f64>) {
    let [a, b, c] = &mut d[th..th + 3] else {
        unreachable!("three moment rows")
    };
    for ((x, y), z) in a.iter_mut().zip(b.iter_mut()).zip(c.iter_mut()) {
        [*x, *y, *z] = r_i.tmul_v(&V3([*x, *y, *z])).0;
    }
}
