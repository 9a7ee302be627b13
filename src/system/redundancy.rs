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

/// Which of the coordinates `coords` the constraint rows of `sys` at `state` determine: the
/// unit row of a coordinate's rate is a combination of the rows (the mechanism cannot move
/// it by itself), or it is not (a free degree of freedom, a collar's η on a rigid beam).
/// One elimination of the rows, then each coordinate's row reduced against them.
pub fn determined_coords(sys: &System, state: &State, coords: &[usize]) -> Vec<bool> {
    let mut a = constraint_matrix(sys, state);
    for f in &sys.frictions {
        a[f.row].iter_mut().for_each(|v| *v = 0.0);
    }
    let n = 6 * sys.layout.n_nodes + sys.layout.n_coords;
    scale_rows(&mut a, n);
    scale_columns(&mut a, n);
    let pivots = reduce(&mut a, n, 1e-9);
    coords
        .iter()
        .map(|&c| {
            let mut e = vec![0.0; n];
            e[6 * sys.layout.n_nodes + c] = 1.0;
            for (pivot, &pj) in a.iter().zip(&pivots) {
                let f = e[pj] / pivot[pj];
                if f != 0.0 {
                    e.iter_mut().zip(pivot).for_each(|(x, p)| *x -= f * p);
                }
            }
            e.iter().all(|v| v.abs() <= 1e-9)
        })
        .collect()
}

/// Solves the dense system `a x = b` (`a` by rows, square) that is singular because some of
/// its rows depend on others — a Newton matrix whose constraint rows are redundant — and
/// consistent to first order: elimination with full pivoting of the equilibrated `[a | b]`
/// stops at its numerical rank (pivots below `1e-10` of the largest entry), the remaining
/// unknowns are set to zero, the dependent rows dropped. The unknowns every solution shares
/// (a mechanism's motion) come out exact; of those that differ (the multipliers of
/// redundant rows), one solution.
pub fn solve_consistent(mut a: Vec<Vec<f64>>, b: &[f64]) -> Vec<f64> {
    let n = a.len();
    for (row, &bi) in a.iter_mut().zip(b) {
        row.push(bi);
    }
    scale_rows(&mut a, n);
    let col_scale = scale_columns(&mut a, n);
    let pivots = reduce(&mut a, n, 1e-10);
    let mut x = vec![0.0; n];
    for (row, &pj) in a.iter().zip(&pivots).rev() {
        // Earlier pivots' columns are zero in this row; later ones are solved, free ones 0.
        let sum: f64 = (0..n).filter(|&j| j != pj).map(|j| row[j] * x[j]).sum();
        x[pj] = (row[n] - sum) / row[pj];
    }
    x.iter().zip(&col_scale).map(|(v, s)| v / s).collect()
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

#[cfg(test)]
mod tests {
    use super::solve_consistent;

    /// A mass on a line held by the same constraint twice (`x = 0.3` as rows 2 and 3, the
    /// second scaled): `[[k, 1, 2], [1, 0, 0], [2, 0, 0]] [x, μ₁, μ₂] = [f, 0.3, 0.6]`. Singular,
    /// consistent; x is unique (0.3) and the multipliers satisfy `μ₁ + 2μ₂ = f − k x`.
    #[test]
    fn a_redundant_consistent_system_gets_its_unique_motion_and_a_valid_force() {
        let (k, f) = (5.0e3, 40.0);
        let a = vec![vec![k, 1.0, 2.0], vec![1.0, 0.0, 0.0], vec![2.0, 0.0, 0.0]];
        let x = solve_consistent(a, &[f, 0.3, 0.6]);
        assert!((x[0] - 0.3).abs() < 1e-14, "{x:?}");
        // Round-off of the entries' scale (k · 1e-16 relative).
        assert!(
            (x[1] + 2.0 * x[2] - (f - k * 0.3)).abs() < 1e-9 * k,
            "{x:?}"
        );
        assert!(x.iter().all(|v| v.is_finite()));
    }

    /// A regular system is solved as by any LU (full rank: nothing dropped).
    #[test]
    fn a_regular_system_is_solved_exactly() {
        let a = vec![
            vec![4.0, -2.0, 1.0],
            vec![-2.0, 4.0, -2.0],
            vec![1.0, -2.0, 4.0],
        ];
        let want = [1.0, -2.0, 0.5];
        let b: Vec<f64> = a
            .iter()
            .map(|row| row.iter().zip(want).map(|(r, w)| r * w).sum())
            .collect();
        let x = solve_consistent(a, &b);
        for (got, w) in x.iter().zip(want) {
            assert!((got - w).abs() < 1e-14, "{x:?}");
        }
    }
}
