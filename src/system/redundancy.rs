//! Redundant (over-constraining) joints: the constraint gradients at a configuration are
//! checked for linear dependence, and each dependence is traced back to the joints whose
//! rows take part in it, so that an over-constrained loop is reported by name instead of as
//! a singular Newton matrix.

use super::System;
use crate::joints::RateTerm;
use crate::state::State;

/// One linear dependence among constraint rows: the owners (joint or drive names) of the rows
/// that take part in it.
#[derive(Clone, Debug, PartialEq)]
pub struct Dependence {
    pub owners: Vec<String>,
}

/// The dense velocity-level constraint matrix `B` (rows: constraint rows; columns: each
/// node's `[v, ω]` and the coordinates). Friction rows are zero: they constrain nothing
/// unless their joint sticks (see [`can_stick`]).
fn constraint_matrix(sys: &System, state: &State) -> Vec<Vec<f64>> {
    let n_nodes = sys.layout.n_nodes;
    let cols = 6 * n_nodes + sys.layout.n_coords;
    let mut b = vec![vec![0.0; cols]; sys.layout.n_rows];
    let mut terms = Vec::new();
    for j in &sys.joints {
        terms.clear();
        j.rate_terms(state, &mut terms);
        for (r, term) in &terms {
            let row = &mut b[j.row0() + r];
            match *term {
                RateTerm::Node { node, v, omega } => {
                    for c in 0..3 {
                        row[6 * node + c] += v.0[c];
                        row[6 * node + 3 + c] += omega.0[c];
                    }
                }
                RateTerm::Coord { coord, value } => row[6 * n_nodes + coord] += value,
            }
        }
    }
    for d in &sys.drives {
        b[d.row][6 * n_nodes + d.coord] = 1.0;
    }
    b
}

/// Linear dependences among the constraint rows at `state` (empty when they are
/// independent). Rows and columns are scaled to unit max-norm (rank is unchanged, units no
/// longer matter); Gaussian elimination with full pivoting on `[B | I]` leaves, for each
/// dependent row, the combination of original rows that vanishes.
pub fn dependences(sys: &System, state: &State) -> Vec<Dependence> {
    let friction_rows: Vec<usize> = sys.frictions.iter().map(|f| f.row).collect();
    let mut a = constraint_matrix(sys, state);
    let rows: Vec<usize> = (0..a.len())
        .filter(|r| !friction_rows.contains(r))
        .collect();
    let a: Vec<Vec<f64>> = rows.iter().map(|&r| std::mem::take(&mut a[r])).collect();
    eliminate(sys, a, &rows)
}

/// Whether friction `k`'s joint can stick at `state`: its stick row (the slip held) is
/// independent of the joints' and drives' rows — not when a drive or the mechanism
/// prescribes the slip.
pub fn can_stick(sys: &System, state: &State, k: usize) -> bool {
    let f = &sys.frictions[k];
    let skip: Vec<usize> = sys
        .frictions
        .iter()
        .map(|g| g.row)
        .filter(|&r| r != f.row)
        .collect();
    let mut a = constraint_matrix(sys, state);
    let n_nodes = sys.layout.n_nodes;
    let (_, rates) = f.stick_gradient(state);
    for (&c, &b) in f.coords().iter().zip(rates.iter()) {
        a[f.row][6 * n_nodes + c] = b;
    }
    let rows: Vec<usize> = (0..a.len()).filter(|r| !skip.contains(r)).collect();
    let a: Vec<Vec<f64>> = rows.iter().map(|&r| std::mem::take(&mut a[r])).collect();
    eliminate(sys, a, &rows).is_empty()
}

/// Which of the coordinates `coords` the mechanism of `sys` at `state` determines with its
/// beams made rigid: the unit row of a coordinate's rate is a combination of the constraint
/// rows (the rigid mechanism cannot move it by itself: a connecting rod's pins), or it is not
/// (a free degree of freedom, a collar's η on a rigid beam). A rigid beam's nodes move with
/// its first node, `v_k = v_m + ω_m × (x_k − x_m)`, `ω_k = ω_m`, so each row's terms on them
/// fold onto that node's columns: only the joints' and drives' rows remain, and one
/// rank-revealing factorization of them (faer's full pivoting, `P B Qᵀ = L U`) decides.
pub fn determined_coords(sys: &System, state: &State, coords: &[usize]) -> Vec<bool> {
    let mut a = constraint_matrix(sys, state);
    for f in &sys.frictions {
        a[f.row].iter_mut().for_each(|v| *v = 0.0);
    }
    let n = 6 * sys.layout.n_nodes + sys.layout.n_coords;
    fold_rigid_beams(sys, state, &mut a);
    if a.is_empty() {
        return vec![false; coords.len()];
    }
    scale_rows(&mut a, n);
    scale_columns(&mut a, n);
    let lu = faer::Mat::from_fn(a.len(), n, |i, j| a[i][j]).full_piv_lu();
    let u = lu.U();
    let rank = numerical_rank(u);
    let (q, _) = lu.Q().arrays();
    coords
        .iter()
        .map(|&c| {
            let col = 6 * sys.layout.n_nodes + c;
            let Some(at) = q[..rank].iter().position(|&k| k == col) else {
                return false; // outside the pivot columns: the rows leave it free
            };
            // Uᵀ y = e_at over the leading block; the coordinate's row is in the rows' span
            // if yᵀ U vanishes on the columns past it.
            let mut y = vec![0.0; rank];
            for i in at..rank {
                let v = if i == at { 1.0 } else { 0.0 };
                let sum: f64 = (at..i).map(|k| u[(k, i)] * y[k]).sum();
                y[i] = (v - sum) / u[(i, i)];
            }
            let size = y.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            (rank..n).all(|j| {
                let r: f64 = (at..rank).map(|k| u[(k, j)] * y[k]).sum();
                r.abs() <= 1e-8 * size
            })
        })
        .collect()
}

/// Folds each row's terms on a beam's nodes onto the beam's first node (see
/// [`determined_coords`]); beams joined by their elements' shared nodes move as one.
fn fold_rigid_beams(sys: &System, state: &State, a: &mut [Vec<f64>]) {
    let mut master: Vec<usize> = (0..sys.layout.n_nodes).collect();
    let root = |master: &[usize], mut k: usize| {
        while master[k] != k {
            k = master[k];
        }
        k
    };
    for b in &sys.beams {
        for &k in &b.nodes[1..] {
            let (rk, r0) = (root(&master, k), root(&master, b.nodes[0]));
            if rk != r0 {
                master[rk.max(r0)] = rk.min(r0);
            }
        }
    }
    for k in 0..sys.layout.n_nodes {
        let m = root(&master, k);
        if m == k {
            continue;
        }
        let d = state.nodes[k].x - state.nodes[m].x;
        for row in a.iter_mut() {
            let bv = crate::math::vec3::V3([row[6 * k], row[6 * k + 1], row[6 * k + 2]]);
            let turn = d.cross(&bv);
            for c in 0..3 {
                row[6 * m + c] += bv.0[c];
                row[6 * m + 3 + c] += row[6 * k + 3 + c] + turn.0[c];
            }
            row[6 * k..6 * k + 6].iter_mut().for_each(|v| *v = 0.0);
        }
    }
}

/// The numerical rank of a full-pivoting LU's `U`: its diagonal (non-increasing in
/// magnitude) down to `1e-10` of its first entry, the rows and columns equilibrated before.
fn numerical_rank(u: faer::MatRef<'_, f64>) -> usize {
    let k = u.nrows().min(u.ncols());
    let first = if k > 0 { u[(0, 0)].abs() } else { 0.0 };
    (0..k)
        .take_while(|&i| u[(i, i)].abs() > 1e-10 * first && first > 0.0)
        .count()
}

/// Scales each row of `a` to unit max-norm over its first `n` entries (the rest of the row,
/// a right-hand side, with them).
fn scale_rows(a: &mut [Vec<f64>], n: usize) {
    for row in a.iter_mut() {
        let s = row[..n].iter().fold(0.0f64, |x, v| x.max(v.abs()));
        if s > 0.0 {
            row.iter_mut().for_each(|v| *v /= s);
        }
    }
}

/// Scales each of the first `n` columns of `a` to unit max-norm; returns the divisors (the
/// scaled system's unknowns are the originals times them).
fn scale_columns(a: &mut [Vec<f64>], n: usize) -> Vec<f64> {
    (0..n)
        .map(|c| {
            let s = a.iter().fold(0.0f64, |x, row| x.max(row[c].abs()));
            if s > 0.0 {
                a.iter_mut().for_each(|row| row[c] /= s);
                s
            } else {
                1.0
            }
        })
        .collect()
}

/// Gaussian elimination with full pivoting over the first `n` columns of the rows `a`, in
/// place, to their numerical rank (pivots above `tol`); the columns past `n` ride along (the
/// combinations of `[B | I]`, the right-hand side of `[A | b]`). Rows `..rank` become the
/// pivot rows, each reduced against those before it, their columns returned in order; rows
/// `rank..` are what is left of the others (the dependent ones, zero to `tol`).
fn reduce(a: &mut [Vec<f64>], n: usize, tol: f64) -> Vec<usize> {
    let mut col_used = vec![false; n];
    let mut pivots = Vec::new();
    for rank in 0..a.len() {
        let mut best = (tol, usize::MAX, 0);
        for (i, row) in a.iter().enumerate().skip(rank) {
            for (j, v) in row[..n].iter().enumerate() {
                if !col_used[j] && v.abs() > best.0 {
                    best = (v.abs(), i, j);
                }
            }
        }
        if best.1 == usize::MAX {
            break;
        }
        let (_, pi, pj) = best;
        a.swap(rank, pi);
        col_used[pj] = true;
        let (pivot, rest) = a[rank..].split_first_mut().expect("row `rank` exists");
        for row in rest {
            let f = row[pj] / pivot[pj];
            if f != 0.0 {
                row.iter_mut()
                    .zip(pivot.iter())
                    .for_each(|(x, p)| *x -= f * p);
            }
        }
        pivots.push(pj);
    }
    pivots
}

/// The dependences among rows `a` (original row numbers `rows`): elimination on `[B | I]`,
/// whose rows left over hold, in their `I` part, the combinations of rows that vanish.
fn eliminate(sys: &System, mut a: Vec<Vec<f64>>, rows: &[usize]) -> Vec<Dependence> {
    let m = a.len();
    if m == 0 {
        return vec![];
    }
    let n = a[0].len();
    scale_rows(&mut a, n);
    scale_columns(&mut a, n);
    for (i, row) in a.iter_mut().enumerate() {
        row.extend((0..m).map(|j| if i == j { 1.0 } else { 0.0 }));
    }
    let rank = reduce(&mut a, n, 1e-9).len();
    a[rank..]
        .iter()
        .map(|row| &row[n..])
        .map(|c| {
            let big = c.iter().fold(0.0f64, |x, v| x.max(v.abs()));
            let mut owners: Vec<String> = Vec::new();
            for (r, v) in c.iter().enumerate() {
                let owner = &sys.row_names[rows[r]].0;
                if v.abs() > 1e-6 * big && !owners.contains(owner) {
                    owners.push(owner.clone());
                }
            }
            Dependence { owners }
        })
        .collect()
}
