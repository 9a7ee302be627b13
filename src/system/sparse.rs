//! The Newton matrix: a fixed compressed-column pattern built from the kernels' blocks, and a
//! sparse LU with partial pivoting whose ordering is done once per pattern; factor storage and
//! scratch memory are reused every iteration.
//!
//! The LU is faer's simplicial one (left-looking, Gilbert–Peierls) in a reverse Cuthill–McKee
//! column order, which chooses the pivots; the factorizations after it keep those pivots and
//! the factors' patterns and only recompute values ([`StaticPivotLu`]) until a kept pivot
//! falls below a tenth of its column's largest candidate, when faer pivots again. Newton
//! matrices change values, not patterns, so nearly every factorization is such a
//! refactorization: no depth-first searches, no pattern checks, no allocation. Measured
//! against faer's supernodal LU in its COLAMD order (the choice from 150 unknowns before):
//! 12-element beam pendulum EP factor 0.58×, solve 0.50×; ED's complex system 0.57× / 0.70×;
//! a 200-element beam EP 0.53× / 0.50×; ED's exact real matrix on beams about equal.

use dyn_stack::{MemBuffer, MemStack};
use faer::dyn_stack;
use faer::perm::PermRef;
use faer::sparse::linalg::lu::simplicial::{
    factorize_simplicial_numeric_lu, factorize_simplicial_numeric_lu_scratch, SimplicialLu,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::traits::ComplexField;

use super::paired::Block2;
use super::refactor::{Scalar, StaticPivotLu};
use crate::elements::{value_pos, ValuePos};

/// A pattern's compressed columns `(col_ptr, row_idx)` from each column's rows (sorted and
/// deduplicated in place).
pub fn compress_columns(cols: &mut [Vec<usize>]) -> (Vec<usize>, Vec<usize>) {
    let mut col_ptr = Vec::with_capacity(cols.len() + 1);
    col_ptr.push(0);
    let mut row_idx = Vec::new();
    for c in cols.iter_mut() {
        c.sort_unstable();
        c.dedup();
        row_idx.extend_from_slice(c);
        col_ptr.push(row_idx.len());
    }
    (col_ptr, row_idx)
}

/// The scalars a Newton matrix holds: `f64`, or `faer::c64` for ED's decoupled complex
/// system (`integrator::ed_decoupled`).
pub trait Entry: ComplexField + Copy + Default + Scalar<Vector = Self> {}
impl<T: ComplexField + Copy + Default + Scalar<Vector = T>> Entry for T {}

/// A border whose refresh costs more than this share of a refactorization (in multiply-adds,
/// [`StaticPivotLu::border_refresh_share`]) is dropped at its first factorization, the matrix
/// then factored without one. Many contacts spread over a model fill the border's rows and
/// columns across most of the factors: the VDTR's 58 border unknowns cost 0.68–0.77 of a
/// refactorization per refresh, and its EP runs 2.2× faster with the border dropped (0.545 →
/// 0.25 s for 0.3 s at 1 ms; ED unchanged, its decoupled border was never refreshed). One
/// contact costs 0.14–0.21 (free collar, beam
/// sliders, a carriage on a rail) and its refresh pays (the free collar's EP at 1 ms: 2.2
/// iterations per step with it, 5.0 without).
pub const MAX_BORDER_REFRESH_SHARE: f64 = 0.5;

pub struct NewtonMatrix<T: Entry = f64> {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    pub values: Vec<T>,
    /// Positions of the diagonal entries (every one is in the pattern).
    diagonal: Vec<usize>,
    /// Column order (reverse Cuthill–McKee) and its inverse.
    col_perm: Vec<usize>,
    col_perm_inv: Vec<usize>,
    /// Row order of the last pivoting factorization and its inverse.
    row_perm: Vec<usize>,
    row_perm_inv: Vec<usize>,
    /// faer's factors of the last pivoting factorization (its storage reused).
    pivoting: SimplicialLu<usize, T>,
    /// The factors in use; valid with `pivots` (once there was a pivoting factorization).
    factors: Box<StaticPivotLu<T>>,
    pivots: bool,
    scratch: MemBuffer,
    /// Unknowns whose rows and columns are a border ([`super::border`]), ascending; their
    /// columns come last in the column order.
    border: Vec<usize>,
    /// The values with the border's rows scaled down, for a pivoting factorization (which
    /// then chooses the leading block's pivots among its own rows).
    scaled: Vec<T>,
    pub numeric_factorizations: usize,
    /// Refreshes of the border's factors ([`Self::refresh_border`]).
    pub border_refreshes: usize,
    /// Of those, refactorizations with the pivots of an earlier one.
    pub refactorizations: usize,
    /// Fill-reducing orderings computed (once per sparsity pattern).
    pub orderings: usize,
}

impl<T: Entry> NewtonMatrix<T> {
    /// Pattern from local blocks (each a list of global indices, with an optional row-major
    /// mask of its structurally nonzero entries); returns the matrix and, per block, the value
    /// positions of its `n × n` entries. Masked-out entries point at a trailing slot that the
    /// factorization never reads, so a kernel may always write its full block.
    pub fn from_blocks(
        n: usize,
        blocks: &[&[usize]],
        masks: Option<&[Vec<bool>]>,
    ) -> (Self, Vec<Vec<ValuePos>>) {
        let keep =
            |b: usize, i: usize, j: usize| masks.is_none_or(|m| m[b][i * blocks[b].len() + j]);
        // Each column's entries counted first (the diagonal's among them), so that filling
        // them never grows a vector: a pattern is rebuilt whenever a sliding contact's window
        // moves, and growing its columns entry by entry was a tenth of that.
        let mut count = vec![1usize; n];
        for (bi, b) in blocks.iter().enumerate() {
            for (lj, &j) in b.iter().enumerate() {
                count[j] += (0..b.len()).filter(|&li| keep(bi, li, lj)).count();
            }
        }
        let mut cols: Vec<Vec<usize>> = count.into_iter().map(Vec::with_capacity).collect();
        for (bi, b) in blocks.iter().enumerate() {
            for (lj, &j) in b.iter().enumerate() {
                cols[j].extend(
                    b.iter()
                        .enumerate()
                        .filter(|(li, _)| keep(bi, *li, lj))
                        .map(|(_, &i)| i),
                );
            }
        }
        // Every diagonal entry exists so a pivot can always be chosen structurally.
        for (j, c) in cols.iter_mut().enumerate() {
            c.push(j);
        }
        let (col_ptr, row_idx) = compress_columns(&mut cols);
        let dump = row_idx.len();
        let positions = blocks
            .iter()
            .enumerate()
            .map(|(bi, b)| {
                let m = b.len();
                let mut p = vec![value_pos(dump); m * m];
                // The block's rows in ascending order, merged with each column's (sorted)
                // rows: a walk per column instead of a binary search per entry.
                let mut rows: Vec<usize> = (0..m).collect();
                rows.sort_unstable_by_key(|&i| b[i]);
                for (j, &gj) in b.iter().enumerate() {
                    let col = &row_idx[col_ptr[gj]..col_ptr[gj + 1]];
                    let mut at = 0;
                    for &i in &rows {
                        if !keep(bi, i, j) {
                            continue;
                        }
                        while col[at] < b[i] {
                            at += 1;
                        }
                        assert_eq!(col[at], b[i], "entry in pattern");
                        p[i * m + j] = value_pos(col_ptr[gj] + at);
                    }
                }
                p
            })
            .collect();
        (Self::from_pattern(n, col_ptr, row_idx), positions)
    }

    /// A matrix of the given pattern (rows sorted and unique in each column, every diagonal
    /// entry present), all values zero, with its factorization analysed.
    pub fn from_pattern(n: usize, col_ptr: Vec<usize>, row_idx: Vec<usize>) -> Self {
        let diagonal = (0..n)
            .map(|j| {
                let col = &row_idx[col_ptr[j]..col_ptr[j + 1]];
                col_ptr[j]
                    + col
                        .binary_search(&j)
                        .expect("every diagonal entry in the pattern")
            })
            .collect();
        let mut m = Self::unfactored(n, col_ptr, row_idx, diagonal, (vec![], vec![]));
        m.order_columns();
        m
    }

    /// A matrix of this one's pattern, column order and border, all values zero, no factors
    /// yet.
    pub fn same_pattern(&self) -> Self {
        let mut m = Self::unfactored(
            self.n,
            self.col_ptr.clone(),
            self.row_idx.clone(),
            self.diagonal.clone(),
            (self.col_perm.clone(), self.col_perm_inv.clone()),
        );
        m.border = self.border.clone();
        m
    }

    /// A matrix of the given pattern, diagonal positions and column order (and its
    /// inverse), all values zero, no pivots or factors, no counts.
    fn unfactored(
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        diagonal: Vec<usize>,
        (col_perm, col_perm_inv): (Vec<usize>, Vec<usize>),
    ) -> Self {
        let nnz = row_idx.len();
        NewtonMatrix {
            n,
            col_ptr,
            row_idx,
            values: vec![T::default(); nnz + 1],
            diagonal,
            col_perm,
            col_perm_inv,
            row_perm: vec![0; n],
            row_perm_inv: vec![0; n],
            pivoting: SimplicialLu::new(),
            factors: Box::default(),
            pivots: false,
            scratch: MemBuffer::new(factorize_simplicial_numeric_lu_scratch::<usize, T>(n, n)),
            border: Vec::new(),
            scaled: Vec::new(),
            numeric_factorizations: 0,
            border_refreshes: 0,
            refactorizations: 0,
            orderings: 0,
        }
    }

    /// Orders the columns by reverse Cuthill–McKee and forgets the pivots. Multibody systems
    /// are chains and trees of small blocks, so a narrow band keeps partial pivoting from
    /// filling the factors (64-link chain under ED: 67k factor entries with RCM, 324k with
    /// AMD).
    pub fn order_columns(&mut self) {
        let n = self.n;
        let cols: Vec<&[usize]> = (0..n)
            .map(|j| &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]])
            .collect();
        self.col_perm = reverse_cuthill_mckee(&cols);
        self.place_border();
        self.orderings += 1;
    }

    /// Makes `border` (unknowns, each below n) the matrix's border: their columns last in
    /// the column order, their rows pivots of those columns only, so that their values can
    /// be refreshed without a factorization ([`Self::refresh_border`]).
    pub fn set_border(&mut self, border: &[usize]) {
        self.border = border.to_vec();
        self.border.sort_unstable();
        self.border.dedup();
        assert!(
            self.border.iter().all(|&b| b < self.n),
            "border unknowns below n"
        );
        self.place_border();
    }

    /// The border's columns moved to the end of the column order (the others' order kept);
    /// the pivots are forgotten.
    fn place_border(&mut self) {
        let is_border = |c: &usize| self.border.binary_search(c).is_ok();
        let (mut order, border): (Vec<usize>, Vec<usize>) =
            self.col_perm.iter().partition(|c| !is_border(c));
        order.extend(border);
        self.col_perm = order;
        self.col_perm_inv = vec![0usize; self.n];
        for (k, &p) in self.col_perm.iter().enumerate() {
            self.col_perm_inv[p] = k;
        }
        self.pivots = false;
    }

    /// Forgets the border, for good: the columns are ordered afresh without it (its fill
    /// made every factorization and solve dearer) and the pivots are forgotten.
    fn drop_border(&mut self) {
        self.border.clear();
        self.order_columns();
    }

    /// The border's unknowns (ascending; empty without one).
    pub fn border(&self) -> &[usize] {
        &self.border
    }

    /// Whether the factors in hand have a border that [`Self::refresh_border`] can refresh
    /// (a leading block singular without it is factored whole).
    pub fn border_ready(&self) -> bool {
        self.pivots && self.factors.has_border()
    }

    /// Refactors only the border's part of the factors from the current values of its rows
    /// and columns (see [`super::border`]); false if it cannot (no border factored, or a
    /// border pivot failed): the factors are then to be computed afresh before a solve.
    pub fn refresh_border(&mut self) -> bool {
        if !self.border_ready() {
            return false;
        }
        let nnz = self.row_idx.len();
        let refreshed = self.factors.refresh_border(&self.values[..nnz]);
        self.border_refreshes += usize::from(refreshed);
        refreshed
    }

    /// The value positions of the border's rows and columns (each once).
    pub fn border_positions(&self) -> Vec<usize> {
        let is_border = |i: usize| self.border.binary_search(&i).is_ok();
        (0..self.n)
            .flat_map(|j| (self.col_ptr[j]..self.col_ptr[j + 1]).map(move |p| (j, p)))
            .filter(|&(j, p)| is_border(j) || is_border(self.row_idx[p]))
            .map(|(_, p)| p)
            .collect()
    }

    /// Makes `lu` the block factors of the patterns and pivots of this matrix's last
    /// pivoting factorization, values unset ([`super::paired`]: this matrix holds the blocks'
    /// images in ℂ).
    pub(super) fn rebuild_pattern_into(&self, lu: &mut StaticPivotLu<Block2>) {
        lu.rebuild(
            (&self.col_ptr, &self.row_idx),
            (&self.row_perm, &self.row_perm_inv),
            &self.col_perm,
            (&self.pivoting, |_| Block2::default()),
            self.n,
        );
    }

    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// The column order (reverse Cuthill–McKee).
    pub fn col_perm(&self) -> &[usize] {
        &self.col_perm
    }

    pub fn clear(&mut self) {
        self.values.iter_mut().for_each(|v| *v = T::default());
    }

    /// The pattern `(col_ptr, row_idx)`: rows sorted in each column.
    pub fn pattern(&self) -> (&[usize], &[usize]) {
        (&self.col_ptr, &self.row_idx)
    }

    /// LU of the current values: a refactorization with the kept pivots when they serve,
    /// else a factorization with partial pivoting whose pivots are kept from then on.
    pub fn factor(&mut self) -> Result<(), String> {
        let values = &self.values[..self.row_idx.len()];
        if self.pivots && self.factors.refactor(values) {
            self.refactorizations += 1;
        } else {
            self.factor_pivoting()?;
        }
        self.numeric_factorizations += 1;
        Ok(())
    }

    /// faer's simplicial LU with partial pivoting; its pivots and patterns become the
    /// refactorizations'.
    fn factor_pivoting(&mut self) -> Result<(), String> {
        if !self.border.is_empty() {
            if self.factor_bordered()?
                && self.factors.border_refresh_share() <= MAX_BORDER_REFRESH_SHARE
            {
                return Ok(());
            }
            // A leading block singular without the border (a massless node held by sliding
            // joints only) stays so, and a border too dear to refresh stays so: factor
            // without one from now on, not a bordered attempt first at each pivoting.
            self.drop_border();
        }
        self.factor_with_pivots(false)?;
        self.factors.rebuild(
            (&self.col_ptr, &self.row_idx),
            (&self.row_perm, &self.row_perm_inv),
            &self.col_perm,
            (&self.pivoting, |v| v),
            self.n,
        );
        self.pivots = true;
        Ok(())
    }

    /// The pivoting factorization with the border's rows kept out of the leading block's
    /// pivots (faer chooses them on values whose border rows are scaled by 1e-12, then the
    /// kept pivots refactor the true values); false if the leading block needs the border's
    /// rows (singular without them).
    fn factor_bordered(&mut self) -> Result<bool, String> {
        self.factor_with_pivots(true)?;
        let lead = self.n - self.border.len();
        let clean = self.row_perm[lead..]
            .iter()
            .all(|r| self.border.binary_search(r).is_ok());
        if !clean {
            return Ok(false);
        }
        self.factors.rebuild(
            (&self.col_ptr, &self.row_idx),
            (&self.row_perm, &self.row_perm_inv),
            &self.col_perm,
            (&self.pivoting, |v| v),
            lead,
        );
        self.pivots = self.factors.refactor(&self.values[..self.row_idx.len()]);
        Ok(self.pivots)
    }

    /// faer's simplicial LU with partial pivoting of the values, the border's rows scaled
    /// down if `scale_border`.
    pub(super) fn factor_with_pivots(&mut self, scale_border: bool) -> Result<(), String> {
        let n = self.n;
        let nnz = self.row_idx.len();
        let values = if scale_border {
            self.scaled.clear();
            self.scaled.extend_from_slice(&self.values[..nnz]);
            for (v, r) in self.scaled.iter_mut().zip(&self.row_idx) {
                if self.border.binary_search(r).is_ok() {
                    *v = v.scaled(1e-12);
                }
            }
            &self.scaled[..]
        } else {
            &self.values[..nnz]
        };
        let pattern = sym_ref(n, &self.col_ptr, &self.row_idx);
        let a = SparseColMatRef::new(pattern, values);
        // SAFETY: mutually inverse permutations of 0..n (`order_columns`).
        let cp = unsafe { PermRef::new_unchecked(&self.col_perm, &self.col_perm_inv, n) };
        let (rp, rp_inv) = (&mut self.row_perm, &mut self.row_perm_inv);
        let stack = MemStack::new(&mut self.scratch);
        factorize_simplicial_numeric_lu(rp, rp_inv, &mut self.pivoting, a, cp, stack)
            .map_err(|e| format!("sparse LU failed: {e:?}"))?;
        Ok(())
    }

    /// Solves `A x = rhs` in place with the last factorization.
    pub fn solve(&mut self, rhs: &mut [T]) {
        self.factors.solve(rhs);
    }

    /// [`Self::solve`] with the right-hand side read from and the solution written to
    /// `data` by the caller's maps (see [`StaticPivotLu::solve_mapped`]).
    pub fn solve_mapped<D: ?Sized>(
        &mut self,
        data: &mut D,
        load: impl Fn(&D, usize) -> T,
        store: impl FnMut(&mut D, usize, T),
    ) {
        self.factors.solve_mapped(data, load, store);
    }

    /// Whether kernels wrote more than `tolerance` times the largest entry outside the pattern
    /// since the last `clear` (round-off level when the detected block structures are right).
    pub fn wrote_outside(&self, tolerance: f64) -> bool {
        self.exceeds_entries(self.values[self.row_idx.len()].magnitude(), tolerance)
    }

    /// Whether `size` exceeds `tolerance` times the largest entry. The largest diagonal entry
    /// bounds that from below, so the pass over every value is taken only when `size` is
    /// large against the diagonal (kernels leave round-off outside the pattern, e.g. a sliding
    /// joint's, on every assembly).
    pub fn exceeds_entries(&self, size: f64, tolerance: f64) -> bool {
        let largest = |entries: &mut dyn Iterator<Item = &T>| {
            entries.fold(f64::MIN_POSITIVE, |m, v| m.max(v.magnitude()))
        };
        let nnz = self.row_idx.len();
        size > 0.0
            && size > tolerance * largest(&mut self.diagonal.iter().map(|&p| &self.values[p]))
            && size > tolerance * largest(&mut self.values[..nnz].iter())
    }
}

impl NewtonMatrix<f64> {
    /// Entries of the L and U factors in use, diagonals included (fill diagnostics).
    pub fn factor_nnz(&self) -> usize {
        self.factors.nnz()
    }

    /// Adds `v` to diagonal entry `i` if the pattern holds it (returns whether it did).
    pub fn add_to_diagonal(&mut self, i: usize, v: f64) -> bool {
        let rows = &self.row_idx[self.col_ptr[i]..self.col_ptr[i + 1]];
        match rows.binary_search(&i) {
            Ok(p) => {
                self.values[self.col_ptr[i] + p] += v;
                true
            }
            Err(_) => false,
        }
    }

    /// The matrix in compressed sparse columns: `(col_ptr, row_idx, values)`, rows sorted
    /// in each column (a copy, for linearizations handed out of the core).
    pub fn to_csc(&self) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let nnz = self.col_ptr[self.n];
        (
            self.col_ptr.clone(),
            self.row_idx.clone(),
            self.values[..nnz].to_vec(),
        )
    }

    /// Adds `v` to entry `(i, j)` of the pattern (tests).
    #[cfg(test)]
    pub fn add_entry_for_test(&mut self, i: usize, j: usize, v: f64) {
        let rows = &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]];
        let p = rows.binary_search(&i).expect("entry in pattern");
        self.values[self.col_ptr[j] + p] += v;
    }

    /// Dense copy (for tests and diagnostics only).
    pub fn to_dense(&self) -> Vec<Vec<f64>> {
        let mut d = vec![vec![0.0; self.n]; self.n];
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                d[self.row_idx[p]][j] = self.values[p];
            }
        }
        d
    }
}

/// The pattern `(col_ptr, row_idx)` as faer's symbolic matrix. The pattern is built sorted
/// and deduplicated by `from_blocks`, so faer's per-call checks are skipped.
fn sym_ref<'a>(
    n: usize,
    col_ptr: &'a [usize],
    row_idx: &'a [usize],
) -> SymbolicSparseColMatRef<'a, usize> {
    debug_assert!(SymbolicSparseColMatRef::new_checked(n, n, col_ptr, None, row_idx).ncols() == n);
    // SAFETY: column pointers increasing from 0 to nnz, rows sorted and unique below n.
    unsafe { SymbolicSparseColMatRef::new_unchecked(n, n, col_ptr, None, row_idx) }
}

/// Reverse Cuthill–McKee order of the symmetrised pattern (`cols[j]`: rows of column j):
/// breadth-first from a minimum-degree vertex, neighbours by increasing degree, reversed.
/// Gives a narrow band, which partial pivoting can widen by at most a factor of two.
fn reverse_cuthill_mckee(cols: &[&[usize]]) -> Vec<usize> {
    let n = cols.len();
    let adj = symmetric_adjacency(cols);
    let deg: Vec<usize> = adj.iter().map(|a| a.len()).collect();
    // Each component starts from its vertex of least degree (first in this list unseen).
    let mut by_degree: Vec<usize> = (0..n).collect();
    by_degree.sort_by_key(|&v| deg[v]);
    let mut candidates = by_degree.into_iter();
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let mut next: Vec<usize> = Vec::new();
    while order.len() < n {
        let start = candidates.find(|&v| !seen[v]).expect("an unseen vertex");
        seen[start] = true;
        let mut head = order.len();
        order.push(start);
        while head < order.len() {
            let v = order[head];
            head += 1;
            next.clear();
            next.extend(adj[v].iter().copied().filter(|&w| !seen[w]));
            next.sort_by_key(|&w| deg[w]);
            for &w in &next {
                seen[w] = true;
                order.push(w);
            }
        }
    }
    order.reverse();
    order
}

/// Each vertex's neighbours in the pattern made symmetric (`A + Aᵀ` without the diagonal),
/// sorted: its column's rows merged with its row's columns — O(nnz), no sort.
fn symmetric_adjacency(cols: &[&[usize]]) -> Vec<Vec<usize>> {
    let n = cols.len();
    // The rows' columns (the transpose), each in increasing order as the columns are walked;
    // sized by a count first (no vector grows).
    let mut count = vec![0usize; n];
    for &i in cols.iter().flat_map(|c| c.iter()) {
        count[i] += 1;
    }
    let mut row_cols: Vec<Vec<usize>> = count.into_iter().map(Vec::with_capacity).collect();
    for (j, c) in cols.iter().enumerate() {
        for &i in c.iter() {
            row_cols[i].push(j);
        }
    }
    (0..n)
        .map(|v| {
            let (a, b) = (cols[v], &row_cols[v][..]);
            let mut out = Vec::with_capacity(a.len().max(b.len()));
            let (mut p, mut q) = (0, 0);
            while p < a.len() || q < b.len() {
                let next = match (a.get(p), b.get(q)) {
                    (Some(&x), Some(&y)) if x == y => {
                        p += 1;
                        q += 1;
                        x
                    }
                    (Some(&x), Some(&y)) if x < y => {
                        p += 1;
                        x
                    }
                    (Some(&x), None) => {
                        p += 1;
                        x
                    }
                    (_, Some(&y)) => {
                        q += 1;
                        y
                    }
                    (None, None) => unreachable!(),
                };
                if next != v {
                    out.push(next);
                }
            }
            out
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The merged adjacency is the sorted, duplicate-free neighbour list of `A + Aᵀ` (what
    /// the ordering reads), on an unsymmetric pattern with repeated and diagonal entries.
    #[test]
    fn symmetric_adjacency_is_that_of_a_plus_a_transpose() {
        let n = 9;
        let pseudo = |k: usize| ((k as f64 * 12.9898).sin() * 43758.5453).fract().abs();
        let cols: Vec<Vec<usize>> = (0..n)
            .map(|j| {
                let mut c: Vec<usize> = (0..n).filter(|&i| pseudo(n * j + i) < 0.3).collect();
                c.push(j);
                c.sort_unstable();
                c.dedup();
                c
            })
            .collect();
        let refs: Vec<&[usize]> = cols.iter().map(|c| &c[..]).collect();
        let mut expected: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (j, c) in cols.iter().enumerate() {
            for &i in c {
                if i != j {
                    expected[i].push(j);
                    expected[j].push(i);
                }
            }
        }
        for e in &mut expected {
            e.sort_unstable();
            e.dedup();
        }
        assert!(expected.iter().any(|e| e.len() > 1));
        assert_eq!(symmetric_adjacency(&refs), expected);
    }

    /// `A x − b` relative to `b`, densely.
    fn relative_residual<T: Entry + std::ops::Sub<Output = T> + std::ops::AddAssign>(
        m: &NewtonMatrix<T>,
        x: &[T],
        b: &[T],
    ) -> f64 {
        let n = b.len();
        let mut ax = vec![T::default(); n];
        for (j, &xj) in x.iter().enumerate() {
            for p in m.col_ptr[j]..m.col_ptr[j + 1] {
                ax[m.row_idx[p]] += m.values[p] * xj;
            }
        }
        let worst = (0..n).fold(0.0f64, |w, i| w.max((ax[i] - b[i]).magnitude()));
        worst / b.iter().fold(0.0f64, |w, v| w.max(v.magnitude()))
    }

    /// A 30-unknown chain of overlapping 6×6 blocks with entries `value(block, i, j)`.
    fn chain<T: Entry + std::ops::AddAssign>(
        value: impl Fn(usize, usize, usize) -> T,
    ) -> NewtonMatrix<T> {
        let blocks: Vec<Vec<usize>> = (0..25).step_by(3).map(|s| (s..s + 6).collect()).collect();
        let refs: Vec<&[usize]> = blocks.iter().map(|b| b.as_slice()).collect();
        let (mut m, pos) = NewtonMatrix::from_blocks(30, &refs, None);
        for (k, p) in pos.iter().enumerate() {
            for (e, &at) in p.iter().enumerate() {
                m.values[at as usize] += value(k, e / 6, e % 6);
            }
        }
        m
    }

    fn entry(k: usize, i: usize, j: usize) -> f64 {
        let v = ((k * 31 + i * 7 + j * 3) % 13) as f64 / 13.0 - 0.4;
        // Rows 2 and 5 of each block have no diagonal term: their pivots come from elsewhere.
        match (i == j, i % 3 == 2) {
            (true, true) => 0.0,
            (true, false) => 3.0 + v,
            _ => v,
        }
    }

    #[test]
    fn refactorization_keeps_the_pivots_while_they_stay_large() {
        let mut m = chain(entry);
        let b: Vec<f64> = (0..30).map(|i| (i as f64 * 0.37).sin()).collect();
        m.factor().unwrap();
        // Values change as from one Newton iteration to the next: the pivots serve.
        for (p, v) in m.values.iter_mut().enumerate() {
            *v *= 1.0 + 0.05 * (p as f64 * 0.7).cos();
        }
        m.factor().unwrap();
        assert_eq!((m.numeric_factorizations, m.refactorizations), (2, 1));
        solves_as_a_fresh_lu(&mut m, &b);
    }

    /// The factors in hand solve `m x = b` to round-off (a well-conditioned 30 × 30 system:
    /// a few hundred operations), and as the same values factored with fresh pivots do.
    fn solves_as_a_fresh_lu(m: &mut NewtonMatrix<f64>, b: &[f64]) {
        let mut x = b.to_vec();
        m.solve(&mut x);
        assert!(relative_residual(m, &x, b) < 1e-13);
        m.order_columns();
        m.factor().unwrap();
        let mut y = b.to_vec();
        m.solve(&mut y);
        let diff = x
            .iter()
            .zip(&y)
            .fold(0.0f64, |d, (a, c)| d.max((a - c).abs()));
        assert!(diff < 1e-12, "{diff}");
    }

    /// Entries of the pattern whose values are zero — a sliding window's nodes away from
    /// the contact, whose couplings the pattern holds for every place of the contact — are
    /// skipped by the refactorization (nothing to subtract): it must still solve as the
    /// pivoting LU of the same values does.
    #[test]
    fn a_refactorization_through_zero_entries_solves_as_a_fresh_lu() {
        let mut m = chain(entry);
        let b: Vec<f64> = (0..30).map(|i| (i as f64 * 0.37).cos()).collect();
        m.factor().unwrap();
        // Couplings among unknowns 9..21 zeroed, but those of the rows and columns without a
        // diagonal term (every third: their pivots come from their couplings).
        let zeroed = |i: usize| (9..21).contains(&i) && i % 3 != 2;
        let mut zeros = 0;
        for j in 0..30 {
            for p in m.col_ptr[j]..m.col_ptr[j + 1] {
                let i = m.row_idx[p];
                if i != j && zeroed(i) && zeroed(j) {
                    m.values[p] = 0.0;
                    zeros += 1;
                }
            }
        }
        assert!(zeros > 20, "{zeros}");
        m.factor().unwrap();
        assert_eq!(m.refactorizations, 1, "the kept pivots served");
        solves_as_a_fresh_lu(&mut m, &b);
    }

    #[test]
    fn a_pivot_that_became_small_is_chosen_again() {
        let mut m = chain(entry);
        m.factor().unwrap();
        // In the column eliminated first (no updates reach it) every entry but the pivot
        // partial pivoting chose — its largest — grows 10⁶×: the kept pivot falls far below
        // PIVOT_THRESHOLD of the column's largest candidate, so the refactorization declines
        // and pivots afresh.
        let first = m.col_perm()[0];
        let column = m.col_ptr[first]..m.col_ptr[first + 1];
        let pivot = column
            .clone()
            .max_by(|&a, &b| m.values[a].abs().total_cmp(&m.values[b].abs()))
            .unwrap();
        for p in column.filter(|&p| p != pivot) {
            m.values[p] *= 1e6;
        }
        m.factor().unwrap();
        assert_eq!((m.numeric_factorizations, m.refactorizations), (2, 0));
        let b: Vec<f64> = (0..30).map(|i| 1.0 + i as f64).collect();
        let mut x = b.clone();
        m.solve(&mut x);
        assert!(relative_residual(&m, &x, &b) < 1e-12);
        m.factor().unwrap();
        assert_eq!(
            m.refactorizations, 1,
            "the new pivots serve the same values"
        );
    }

    #[test]
    fn complex_systems_refactor_and_solve() {
        use faer::c64;
        let mut m = chain(|k, i, j| c64::new(entry(k, i, j), 0.3 * entry(k + 1, j, i)));
        m.factor().unwrap();
        for v in m.values.iter_mut() {
            *v *= c64::new(1.0, 0.02);
        }
        m.factor().unwrap();
        assert_eq!(m.refactorizations, 1);
        let b: Vec<c64> = (0..30).map(|i| c64::new(1.0, -(i as f64))).collect();
        let mut x = b.clone();
        m.solve(&mut x);
        assert!(relative_residual(&m, &x, &b) < 1e-13);
    }

    /// The chain with a border of four unknowns after the chain: three constraint rows on
    /// unknowns 12–17 with their multipliers' columns (a zero diagonal block, as a joint's)
    /// and a contact coordinate coupled to all of them; `shift` changes the border's values.
    fn bordered<T: Entry + std::ops::AddAssign>(
        value: impl Fn(usize, usize, usize) -> T,
        border: impl Fn(usize, usize) -> T,
    ) -> (NewtonMatrix<T>, Vec<usize>) {
        bordered_chain(BORDERED_CHAIN, &[12], value, border)
    }

    /// Unknowns of [`bordered`]'s chain: long enough for its one contact to stay local (its
    /// refresh 0.40 of a refactorization, below [`MAX_BORDER_REFRESH_SHARE`]; 0.6 or more
    /// with 30), short enough for the fixtures' pivots (at 90 the refresh test's residual grew
    /// to 1.4e-11, at 120 a border pivot failed).
    const BORDERED_CHAIN: usize = 60;

    /// [`bordered`] with a chain of `len` unknowns (a multiple of 3, at least 30) and a
    /// contact at each of `at`: four border unknowns (after the chain, contact by contact)
    /// coupled to the six chain unknowns from there.
    fn bordered_chain<T: Entry + std::ops::AddAssign>(
        len: usize,
        at: &[usize],
        value: impl Fn(usize, usize, usize) -> T,
        border: impl Fn(usize, usize) -> T,
    ) -> (NewtonMatrix<T>, Vec<usize>) {
        let n = len + 4 * at.len();
        let mut blocks: Vec<Vec<usize>> = (0..len - 5)
            .step_by(3)
            .map(|s| (s..s + 6).collect())
            .collect();
        let chain_blocks = blocks.len();
        for (c, &s) in at.iter().enumerate() {
            let own = len + 4 * c;
            blocks.push((s..s + 6).chain(own..own + 4).collect());
        }
        let refs: Vec<&[usize]> = blocks.iter().map(|b| b.as_slice()).collect();
        let (mut m, pos) = NewtonMatrix::from_blocks(n, &refs, None);
        m.set_border(&(len..n).collect::<Vec<_>>());
        for (k, p) in pos[..chain_blocks].iter().enumerate() {
            for (e, &at) in p.iter().enumerate() {
                m.values[at as usize] += value(k, e / 6, e % 6);
            }
        }
        for p in &pos[chain_blocks..] {
            for (e, &at) in p.iter().enumerate() {
                let (i, j) = (e / 10, e % 10);
                // Node–node entries are the chain's; the multipliers' block is zero.
                if (i >= 6 || j >= 6) && !(i >= 6 && j >= 6 && i < 9 && j < 9) {
                    m.values[at as usize] += border(i, j);
                }
            }
        }
        let at_border = m.border_positions();
        (m, at_border)
    }

    fn border_entry(shift: f64) -> impl Fn(usize, usize) -> f64 {
        // Pseudo-random (a sum of sines of i and j alone would be of rank 2).
        move |i, j| {
            let k = (i * 10 + j) as f64;
            ((k * 12.9898 + shift).sin() * 43758.5453).fract() + if i == j { 2.0 } else { 0.0 }
        }
    }

    /// New values in a border's rows and columns: its refresh is the LU of the new matrix,
    /// without a factorization; where the leading block changed too, of the matrix with the
    /// factored leading block and the new border (what modified Newton then iterates with).
    #[test]
    fn a_border_refresh_factors_the_new_border_with_the_kept_leading_block() {
        let (mut m, at_border) = bordered(entry, border_entry(0.0));
        m.factor().unwrap();
        assert!(m.border_ready());
        let (new, _) = bordered(entry, border_entry(0.7));
        let b: Vec<f64> = (0..BORDERED_CHAIN + 4)
            .map(|i| (i as f64 * 0.37).sin())
            .collect();
        let kept = m.values.clone();
        for &p in &at_border {
            m.values[p] = new.values[p];
        }
        // The leading block's values in hand differ from the factored ones (later iterates):
        // the refresh reads only the border's.
        for (p, v) in m.values.iter_mut().enumerate() {
            if at_border.binary_search(&p).is_err() {
                *v *= 1.3;
            }
        }
        assert!(m.refresh_border());
        assert_eq!((m.numeric_factorizations, m.border_refreshes), (1, 1));
        let mut x = b.clone();
        m.solve(&mut x);
        let residual_with = |m: &mut NewtonMatrix, leading: &[f64]| {
            for (p, v) in m.values.iter_mut().enumerate() {
                if at_border.binary_search(&p).is_err() {
                    *v = leading[p];
                }
            }
            relative_residual(m, &x, &b)
        };
        // Round-off: 5e-13 measured, a fresh bordered factorization of the same matrix 2e-13
        // (the leading pivots chosen without the border's rows grow the factors a little); a
        // stale or misplaced entry leaves O(1e-3) or more, as below.
        assert!(residual_with(&mut m, &kept) < 1e-11);
        let scaled: Vec<f64> = kept.iter().map(|v| 1.3 * v).collect();
        assert!(
            residual_with(&mut m, &scaled) > 1e-3,
            "not the changed leading block's"
        );
    }

    /// The border refresh compiled for AVX2 (where the processor has it) gives the baseline
    /// kernels' factors bit for bit, as refactorizations and solves do.
    #[test]
    fn border_refreshes_agree_across_instruction_sets() {
        let (new, _) = bordered(entry, border_entry(0.7));
        let b: Vec<f64> = (0..BORDERED_CHAIN + 4)
            .map(|i| (i as f64 * 0.37).sin())
            .collect();
        let mut results = Vec::new();
        for portable_only in [false, true] {
            let (mut m, at_border) = bordered(entry, border_entry(0.0));
            m.factors.set_portable_only(portable_only);
            m.factor().unwrap();
            for &p in &at_border {
                m.values[p] = new.values[p];
            }
            assert!(m.refresh_border());
            let mut x = b.clone();
            m.solve(&mut x);
            results.push(x);
        }
        assert!(results[0] == results[1]);
    }

    #[test]
    fn complex_borders_refresh() {
        use faer::c64;
        let value = |k, i, j| c64::new(entry(k, i, j), 0.3 * entry(k + 1, j, i));
        let border = |shift: f64| move |i, j| c64::new(border_entry(shift)(i, j), 0.2);
        let (mut m, at_border) = bordered(value, border(0.0));
        m.factor().unwrap();
        let (new, _) = bordered(value, border(1.1));
        for &p in &at_border {
            m.values[p] = new.values[p];
        }
        assert!(m.refresh_border());
        let b: Vec<c64> = (0..BORDERED_CHAIN + 4)
            .map(|i| c64::new(1.0, -(i as f64)))
            .collect();
        let mut x = b.clone();
        m.solve(&mut x);
        assert!(relative_residual(&m, &x, &b) < 1e-13);
    }

    /// A border coupled to one place of a chain refreshes at a small share of a
    /// refactorization and is kept; one coupled all along it (many contacts spread over a
    /// model) would cost most of one and is dropped at the first factorization, the matrix
    /// ordered afresh and factored without it — solved all the same.
    #[test]
    fn a_border_that_costs_most_of_a_refactorization_is_dropped() {
        // Measured shares: one contact 0.40, a contact every 12 unknowns 0.94.
        let (mut local, _) = bordered(entry, border_entry(0.0));
        local.factor().unwrap();
        let share = local.factors.border_refresh_share();
        assert!(
            local.border_ready() && share < MAX_BORDER_REFRESH_SHARE,
            "{share}"
        );
        // A contact every 12 unknowns.
        let places: Vec<usize> = (0..BORDERED_CHAIN - 6).step_by(12).collect();
        let (mut spread, _) = bordered_chain(BORDERED_CHAIN, &places, entry, border_entry(0.0));
        let n = spread.n;
        // Its bordered factors, as the first factorization makes them.
        assert!(spread.factor_bordered().unwrap());
        let share = spread.factors.border_refresh_share();
        assert!(share > MAX_BORDER_REFRESH_SHARE, "{share}");
        let orderings = spread.orderings;
        spread.pivots = false;
        spread.factor().unwrap();
        assert!(spread.border().is_empty() && !spread.border_ready());
        assert_eq!(spread.orderings, orderings + 1, "ordered afresh");
        assert!(!spread.refresh_border());
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut x = b.clone();
        spread.solve(&mut x);
        assert!(relative_residual(&spread, &x, &b) < 1e-12);
    }

    /// An unknown held by the border's rows only (a massless node on a sliding joint): the
    /// leading block is singular without them, so the matrix is factored whole, and solved.
    #[test]
    fn a_leading_block_singular_without_its_border_is_factored_whole() {
        let (mut m, _) = bordered(entry, border_entry(0.0));
        let dense = m.to_dense();
        // Unknown 14's column and row keep only their border entries.
        for j in 0..BORDERED_CHAIN {
            for (r, c) in [(14, j), (j, 14)] {
                if dense[r][c] != 0.0 {
                    m.add_entry_for_test(r, c, -dense[r][c]);
                }
            }
        }
        m.factor().unwrap();
        assert!(!m.border_ready());
        assert!(!m.refresh_border());
        let b: Vec<f64> = (0..BORDERED_CHAIN + 4).map(|i| 1.0 + i as f64).collect();
        let mut x = b.clone();
        m.solve(&mut x);
        assert!(relative_residual(&m, &x, &b) < 1e-12);
    }

    /// Refactorizations and solves compiled for AVX2 (where the processor has it) give what
    /// the baseline kernels give, bit for bit, for real and complex systems: the same IEEE
    /// operations in the same order (no fused multiply-adds; the dot products' four partial
    /// sums whatever the vector width), so either may serve.
    #[test]
    fn kernels_agree_across_instruction_sets() {
        use faer::c64;
        fn agree<T: Entry + std::ops::Sub<Output = T> + std::ops::AddAssign + PartialEq>(
            mut m: NewtonMatrix<T>,
            b: Vec<T>,
        ) {
            m.factor().unwrap();
            let mut results = Vec::new();
            for portable_only in [false, true] {
                m.factors.set_portable_only(portable_only);
                m.factor().unwrap();
                let mut x = b.clone();
                m.solve(&mut x);
                assert!(relative_residual(&m, &x, &b) < 1e-13);
                results.push(x);
            }
            assert_eq!(m.refactorizations, 2);
            assert!(results[0] == results[1]);
        }
        agree(
            chain(|k, i, j| c64::new(entry(k, i, j), 0.3 * entry(k + 1, j, i))),
            (0..30).map(|i| c64::new(1.0, -(i as f64))).collect(),
        );
        agree(
            chain(entry),
            (0..30).map(|i| (i as f64 * 0.37).sin()).collect(),
        );
    }

    /// A scattered pattern (elements coupling unknowns far apart, some without a diagonal
    /// entry) whose factors' rows of L and columns of U come in several runs each: the
    /// run-structured substitutions solve it, after the pivoting factorization and after a
    /// refactorization with other values (f64 and complex).
    #[test]
    fn scattered_patterns_solve_through_runs() {
        use faer::c64;
        // A beam-like band of overlapping elements plus springs between distant unknowns.
        let mut owned: Vec<Vec<usize>> = (0..36).step_by(3).map(|s| (s..s + 4).collect()).collect();
        owned
            .extend((0..6).map(|k| vec![k * 5 % 39, (k * 13 + 20) % 39, (k * 7 + 3) % 39, 38 - k]));
        let blocks: Vec<&[usize]> = owned.iter().map(|b| b.as_slice()).collect();
        let value = |k: usize, i: usize, j: usize| {
            let v = ((k * 17 + i * 5 + j * 11) % 19) as f64 / 19.0 - 0.45;
            if i == j && (k + i) % 3 != 0 {
                2.5 + v
            } else {
                v
            }
        };
        let (mut m, pos) = NewtonMatrix::<f64>::from_blocks(39, &blocks, None);
        let (mut c, _) = NewtonMatrix::<c64>::from_blocks(39, &blocks, None);
        for (k, p) in pos.iter().enumerate() {
            for (e, &at) in p.iter().enumerate() {
                m.values[at as usize] += value(k, e / 4, e % 4);
                c.values[at as usize] +=
                    c64::new(value(k, e / 4, e % 4), 0.2 * value(k + 3, e % 4, e / 4));
            }
        }
        let b: Vec<f64> = (0..39).map(|i| (i as f64 * 0.61).cos()).collect();
        let bc: Vec<c64> = b.iter().map(|&v| c64::new(v, 1.0 - v)).collect();
        for round in 0..2 {
            m.factor().unwrap();
            c.factor().unwrap();
            assert!(m.factors.gapped_lines() > 0 && c.factors.gapped_lines() > 0);
            let mut x = b.clone();
            m.solve(&mut x);
            assert!(relative_residual(&m, &x, &b) < 1e-13, "round {round}");
            let mut xc = bc.clone();
            c.solve(&mut xc);
            assert!(relative_residual(&c, &xc, &bc) < 1e-13, "round {round}");
            // Values change as between Newton iterations: the next round refactors.
            for (p, v) in m.values.iter_mut().enumerate() {
                *v *= 1.0 + 0.03 * (p as f64).sin();
            }
            for v in c.values.iter_mut() {
                *v *= c64::new(1.0, 0.01);
            }
        }
        assert_eq!((m.refactorizations, c.refactorizations), (1, 1));
    }

    #[test]
    fn assembles_blocks_and_solves() {
        let b1 = [0usize, 1];
        let b2 = [1usize, 2];
        let (mut m, pos) = NewtonMatrix::from_blocks(3, &[&b1, &b2], None);
        // [[4,1,0],[1,5,2],[0,2,6]] from two overlapping blocks.
        let k1 = [4.0, 1.0, 1.0, 2.0];
        let k2 = [3.0, 2.0, 2.0, 6.0];
        for (p, v) in pos[0].iter().zip(k1) {
            m.values[*p as usize] += v;
        }
        for (p, v) in pos[1].iter().zip(k2) {
            m.values[*p as usize] += v;
        }
        m.factor().unwrap();
        let mut x = [1.0, 2.0, 3.0];
        m.solve(&mut x);
        let a = m.to_dense();
        for i in 0..3 {
            let r: f64 = (0..3).map(|j| a[i][j] * x[j]).sum();
            assert!((r - [1.0, 2.0, 3.0][i]).abs() < 1e-14);
        }
        m.factor().unwrap();
        assert_eq!((m.numeric_factorizations, m.orderings), (2, 1));
    }

    /// A write outside the pattern (to a masked-out entry) counts when it exceeds the
    /// tolerance against the largest entry — an off-diagonal one here, larger than every
    /// diagonal entry, so the cheap diagonal bound alone would misjudge it — and round-off
    /// does not.
    #[test]
    fn writes_outside_the_pattern_are_told_from_round_off() {
        let block = [0usize, 1, 2];
        // Entry (0, 2) is masked out.
        let mask = vec![vec![true, true, false, true, true, true, true, true, true]];
        let (mut m, pos) = NewtonMatrix::<f64>::from_blocks(3, &[&block], Some(&mask));
        let k = [1.0, 1e6, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0];
        let mut assemble = |outside: f64| {
            m.clear();
            for (&p, v) in pos[0].iter().zip(k) {
                m.values[p as usize] += v;
            }
            m.values[pos[0][2] as usize] += outside;
            m.wrote_outside(1e-10)
        };
        assert!(!assemble(0.0));
        // 5e-5 is 2.5e-5 of the diagonal's largest, 5e-11 of the largest entry: round-off.
        assert!(!assemble(5e-5));
        assert!(assemble(1e-3));
    }
}
