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

/// The dependences among rows `a` (original row numbers `rows`).
fn eliminate(sys: &System, mut a: Vec<Vec<f64>>, rows: &[usize]) -> Vec<Dependence> {
    let m = a.len();
    if m == 0 {
        return vec![];
    }
    let n = a[0].len();
    for row in a.iter_mut() {
        let s = row.iter().fold(0.0f64, |x, v| x.max(v.abs()));
        if s > 0.0 {
            row.iter_mut().for_each(|v| *v /= s);
        }
    }
    for c in 0..n {
        let s = a.iter().fold(0.0f64, |x, row| x.max(row[c].abs()));
        if s > 0.0 {
            a.iter_mut().for_each(|row| row[c] /= s);
        }
    }
    let mut comb: Vec<Vec<f64>> = (0..m)
        .map(|i| (0..m).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    let mut col_used = vec![false; n];
    let tol = 1e-9;
    let mut rank = 0;
    while rank < m {
        let mut best = (0.0, 0, 0);
        for (i, row) in a.iter().enumerate().skip(rank) {
            for (j, v) in row.iter().enumerate() {
                if !col_used[j] && v.abs() > best.0 {
                    best = (v.abs(), i, j);
                }
            }
        }
        if best.0 <= tol {
            break;
        }
        let (_, pi, pj) = best;
        a.swap(rank, pi);
        comb.swap(rank, pi);
        col_used[pj] = true;
        let (pivot_row, pivot_comb) = (a[rank].clone(), comb[rank].clone());
        for i in rank + 1..m {
            let f = a[i][pj] / pivot_row[pj];
            if f != 0.0 {
                for (x, p) in a[i].iter_mut().zip(&pivot_row) {
                    *x -= f * p;
                }
                for (x, p) in comb[i].iter_mut().zip(&pivot_comb) {
                    *x -= f * p;
                }
            }
        }
        rank += 1;
    }
    comb[rank..]
        .iter()
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
