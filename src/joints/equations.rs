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

use super::MAX_ROWS;
use crate::elements::{add3, v3, StepCtx};
use crate::scalar::Real;
use crate::vec3::{M3, V3};

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
    pub n_rows: usize,
}

#[derive(Clone, Copy, PartialEq)]
enum At {
    Start,
    End,
}

impl<T: Real> ColumnMap<'_, T> {
    fn per(ctx: &StepCtx) -> usize {
        if ctx.ed() {
            2
        } else {
            1
        }
    }

    /// Multipliers as forces `sλ` (or `sλ_d`) from the local block.
    pub fn multipliers(&self, ctx: &StepCtx, y: &[T], jump: bool) -> [T; MAX_ROWS] {
        let per = Self::per(ctx);
        let mut l = [T::zero(); MAX_ROWS];
        for (r, lr) in l.iter_mut().enumerate().take(self.n_rows) {
            *lr = y[self.mult + per * r + usize::from(jump)] * ctx.s;
        }
        l
    }

    /// Adds `Bᵀ lam` to the momentum rows (or, with `jump_rows`, to the ED jump rows).
    fn add_forces<const NC: usize>(
        &self,
        b: &Grad<T, NC>,
        lam: &[T],
        at: At,
        jump_rows: bool,
        out: &mut [T],
    ) {
        let mut g = [T::zero(); NC];
        for (c, gc) in g.iter_mut().enumerate() {
            for r in 0..self.n_rows {
                *gc += b[r][c] * lam[r];
            }
        }
        for n in self.nodes {
            let slot = if jump_rows { n.jump } else { Some(n.delta) };
            if let Some(s) = slot {
                let rot = if at == At::Start { &n.r_i } else { &n.r_f };
                add3(out, s, v3(&g, n.col));
                add3(out, s + 3, rot.tmul_v(&v3(&g, n.col + 3)));
            }
        }
        for c in self.coords {
            out[c.slot + usize::from(jump_rows)] += g[c.col];
        }
    }

    /// `B V` for the jump (`at = Start`) or end (`at = End`) velocities of the local block.
    fn apply_rate<const NC: usize>(
        &self,
        ctx: &StepCtx,
        b: &Grad<T, NC>,
        y: &[T],
        at: At,
        out: &mut [T],
    ) {
        let h = ctx.h;
        let mut acc = [T::zero(); MAX_ROWS];
        for n in self.nodes {
            let j = n.jump.expect("ED layout");
            let (vj, wj) = (v3(y, j).scale_f(1.0 / h), v3(y, j + 3).scale_f(1.0 / h));
            let (v, w) = if at == At::Start {
                (vj, n.r_i.mul_v(&wj))
            } else {
                let vf = v3(y, n.delta).scale_f(2.0 / h) - vj;
                let wf = v3(y, n.delta + 3).scale_f(2.0 / h) - wj;
                (vf, n.r_f.mul_v(&wf))
            };
            for (r, a) in acc.iter_mut().enumerate().take(self.n_rows) {
                for c in 0..3 {
                    *a += b[r][n.col + c] * v.0[c] + b[r][n.col + 3 + c] * w.0[c];
                }
            }
        }
        for c in self.coords {
            let qj = y[c.slot + 1] / h;
            let q = if at == At::Start {
                qj
            } else {
                y[c.slot] * (2.0 / h) - qj
            };
            for (r, a) in acc.iter_mut().enumerate().take(self.n_rows) {
                *a += b[r][c.col] * q;
            }
        }
        out[..self.n_rows].copy_from_slice(&acc[..self.n_rows]);
    }
}

/// What a constraint supplies for one evaluation of its step equations.
pub struct ConstraintTerms<'a, T, const NC: usize> {
    /// `C` at the end of the step.
    pub c_f: &'a [T],
    /// Time step: the exact discrete gradient `B^D`; statics: `B(q_f)`.
    pub b: &'a Grad<T, NC>,
    /// ED only: the rate operators `B(q_i)` and `B(q_f)`.
    pub rates: Option<(&'a Grad<T, NC>, &'a Grad<T, NC>)>,
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
    let per = ColumnMap::<T>::per(ctx);
    let lam = map.multipliers(ctx, y, false);
    let at = if ctx.is_static() { At::End } else { At::Start };
    map.add_forces(terms.b, &lam[..n], at, false, res);
    for r in 0..n {
        res[map.mult + per * r] += terms.c_f[r] * ctx.s;
    }
    if !ctx.ed() {
        return;
    }
    let (b_i, b_f) = terms.rates.expect("ED needs the rate operators");
    let lam_d = map.multipliers(ctx, y, true);
    let mut pos = [T::zero(); MAX_ROWS];
    let mut neg = [T::zero(); MAX_ROWS];
    for r in 0..n {
        pos[r] = lam_d[r] / 12.0;
        neg[r] = -pos[r];
    }
    // −P_f ∋ (1/12)(B_f − B_i)ᵀ λ_d ; −P_j/6 ∋ −(1/12)(B_i + B_f)ᵀ λ_d.
    map.add_forces(b_f, &pos[..n], At::End, false, res);
    map.add_forces(b_i, &neg[..n], At::Start, false, res);
    map.add_forces(b_i, &neg[..n], At::Start, true, res);
    map.add_forces(b_f, &neg[..n], At::End, true, res);
    // Velocity-level j-condition: B(q_i) V_j − B(q_f) V_f = 0.
    let mut ci = [T::zero(); MAX_ROWS];
    let mut cf = [T::zero(); MAX_ROWS];
    map.apply_rate(ctx, b_i, y, At::Start, &mut ci);
    map.apply_rate(ctx, b_f, y, At::End, &mut cf);
    for r in 0..n {
        res[map.mult + 2 * r + 1] += (ci[r] - cf[r]) * (ctx.s * ctx.h);
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
