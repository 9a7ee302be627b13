//! The Newton matrix: a fixed compressed-column pattern built from the kernels' blocks, and a
//! sparse LU with partial pivoting whose analysis is done once per pattern; factor storage
//! and scratch memory are reused every iteration.
//!
//! Two factorizations, chosen by size (deterministically, so results do not depend on the
//! machine): small systems use faer's simplicial LU in a reverse Cuthill–McKee column order;
//! from `SUPERNODAL_FROM` (150) unknowns on, faer's supernodal LU in its COLAMD order, whose dense
//! kernels win on beams (measured, one factorization: 12-cubic-element beam pendulum ED, 450
//! unknowns, 1.18 ms → 0.33 ms; EP 175 → 90 µs; 64-link chain ED 1.73 → 1.33 ms; the four-bar,
//! 80 unknowns, stays faster simplicial: 30 against 43 µs).

use dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::dyn_stack;
use faer::perm::PermRef;
use faer::sparse::linalg::lu::simplicial::{
    factorize_simplicial_numeric_lu, factorize_simplicial_numeric_lu_scratch, SimplicialLu,
};
use faer::sparse::linalg::lu::supernodal::{
    factorize_supernodal_numeric_lu, factorize_supernodal_numeric_lu_scratch,
    factorize_supernodal_symbolic_lu, factorize_supernodal_symbolic_lu_scratch, SupernodalLu,
    SymbolicSupernodalLu,
};
use faer::sparse::linalg::{colamd, qr, SymbolicSupernodalParams};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::traits::ComplexField;
use faer::{Conj, MatMut, Par};

/// The scalars a Newton matrix holds: `f64`, or `faer::c64` for ED's decoupled complex
/// system (`integrator::ed_decoupled`).
pub trait Entry: ComplexField + Copy + Default {}
impl<T: ComplexField + Copy + Default> Entry for T {}

/// Systems with at least this many unknowns use the supernodal LU.
pub const SUPERNODAL_FROM: usize = 150;

enum Backend<T: Entry> {
    /// Simplicial LU in a fixed column order (reverse Cuthill–McKee) and its inverse; the row
    /// permutation is the pivoting of the last factorization.
    Simplicial {
        col_perm: Vec<usize>,
        col_perm_inv: Vec<usize>,
        row_perm: Vec<usize>,
        row_perm_inv: Vec<usize>,
        lu: SimplicialLu<usize, T>,
    },
    /// faer's supernodal LU: symbolic analysis (COLAMD order, supernodes) once per pattern.
    Supernodal(Box<Supernodal<T>>),
}

/// The supernodal LU with everything that depends only on the pattern computed once: the
/// column order, the supernodal structure, and the pattern of Aᵀ (which the numeric
/// factorization reads alongside A) with the position in A of each of its entries, so that a
/// refactorization only gathers values (no transpose, no pattern checks).
struct Supernodal<T: Entry> {
    symbolic: SymbolicSupernodalLu<usize>,
    col_perm: Vec<usize>,
    col_perm_inv: Vec<usize>,
    row_perm: Vec<usize>,
    row_perm_inv: Vec<usize>,
    lu: SupernodalLu<usize, T>,
    t_col_ptr: Vec<usize>,
    t_row_idx: Vec<usize>,
    /// `t_values[p] = values[t_source[p]]`.
    t_source: Vec<usize>,
    t_values: Vec<T>,
}

pub struct NewtonMatrix<T: Entry = f64> {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    pub values: Vec<T>,
    backend: Backend<T>,
    scratch: MemBuffer,
    pub numeric_factorizations: usize,
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
    ) -> (Self, Vec<Vec<usize>>) {
        let keep =
            |b: usize, i: usize, j: usize| masks.is_none_or(|m| m[b][i * blocks[b].len() + j]);
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n];
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
            c.sort_unstable();
            c.dedup();
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::new();
        for c in &cols {
            row_idx.extend_from_slice(c);
            col_ptr.push(row_idx.len());
        }
        let dump = row_idx.len();
        let positions = blocks
            .iter()
            .enumerate()
            .map(|(bi, b)| {
                let m = b.len();
                let mut p = vec![dump; m * m];
                for (i, &gi) in b.iter().enumerate() {
                    for (j, &gj) in b.iter().enumerate() {
                        if keep(bi, i, j) {
                            let col = &row_idx[col_ptr[gj]..col_ptr[gj + 1]];
                            p[i * m + j] =
                                col_ptr[gj] + col.binary_search(&gi).expect("entry in pattern");
                        }
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
        let nnz = row_idx.len();
        let mut m = NewtonMatrix {
            n,
            col_ptr,
            row_idx,
            values: vec![T::default(); nnz + 1],
            // Replaced just below by the backend for this size.
            backend: Backend::Simplicial {
                col_perm: vec![],
                col_perm_inv: vec![],
                row_perm: vec![],
                row_perm_inv: vec![],
                lu: SimplicialLu::new(),
            },
            scratch: MemBuffer::new(StackReq::EMPTY),
            numeric_factorizations: 0,
            orderings: 0,
        };
        if n >= SUPERNODAL_FROM {
            m.use_supernodal();
        } else {
            m.use_simplicial();
        }
        m
    }

    /// Switches to the simplicial LU in reverse Cuthill–McKee order. Multibody systems are
    /// chains and trees of small blocks, so a narrow band keeps partial pivoting from filling
    /// the factors (64-link chain under ED: 67k factor entries with RCM, 324k with AMD).
    pub fn use_simplicial(&mut self) {
        let n = self.n;
        let cols: Vec<&[usize]> = (0..n)
            .map(|j| &self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]])
            .collect();
        let col_perm = reverse_cuthill_mckee(&cols);
        let mut col_perm_inv = vec![0usize; n];
        for (k, &p) in col_perm.iter().enumerate() {
            col_perm_inv[p] = k;
        }
        let req = StackReq::any_of(&[
            factorize_simplicial_numeric_lu_scratch::<usize, T>(n, n),
            faer::perm::permute_rows_in_place_scratch::<usize, T>(n, 1),
        ]);
        self.scratch = MemBuffer::new(req);
        self.backend = Backend::Simplicial {
            col_perm,
            col_perm_inv,
            row_perm: vec![0; n],
            row_perm_inv: vec![0; n],
            lu: SimplicialLu::new(),
        };
        self.orderings += 1;
    }

    /// Switches to faer's supernodal LU (COLAMD order, symbolic analysis now).
    pub fn use_supernodal(&mut self) {
        let (t_col_ptr, t_row_idx, t_source) =
            transpose_pattern(self.n, &self.col_ptr, &self.row_idx);
        let a = sym_ref(self.n, &self.col_ptr, &self.row_idx);
        let at = sym_ref(self.n, &t_col_ptr, &t_row_idx);
        let symbolic = supernodal_analysis(a, at);
        let (symbolic, col_perm, col_perm_inv) = symbolic;
        let req = StackReq::any_of(&[
            factorize_supernodal_numeric_lu_scratch::<usize, T>(&symbolic, Default::default()),
            faer::sparse::linalg::lu::supernodal::solve_in_place_scratch::<usize, T>(
                self.n,
                1,
                Par::Seq,
            ),
        ]);
        self.scratch = MemBuffer::new(req);
        let nnz = t_row_idx.len();
        self.backend = Backend::Supernodal(Box::new(Supernodal {
            symbolic,
            col_perm,
            col_perm_inv,
            row_perm: vec![0; self.n],
            row_perm_inv: vec![0; self.n],
            lu: SupernodalLu::new(),
            t_col_ptr,
            t_row_idx,
            t_source,
            t_values: vec![T::default(); nnz],
        }));
        self.orderings += 1;
    }

    /// Whether the supernodal LU is in use.
    pub fn is_supernodal(&self) -> bool {
        matches!(self.backend, Backend::Supernodal(_))
    }

    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    pub fn clear(&mut self) {
        self.values.iter_mut().for_each(|v| *v = T::default());
    }

    /// The pattern `(col_ptr, row_idx)`: rows sorted in each column.
    pub fn pattern(&self) -> (&[usize], &[usize]) {
        (&self.col_ptr, &self.row_idx)
    }

    /// Numeric LU (partial pivoting) of the current values, with the analysis of the pattern
    /// reused; the factor storage and scratch memory are reused.
    pub fn factor(&mut self) -> Result<(), String> {
        let n = self.n;
        let values = &self.values[..self.row_idx.len()];
        let a = SparseColMatRef::new(sym_ref(n, &self.col_ptr, &self.row_idx), values);
        let stack = MemStack::new(&mut self.scratch);
        match &mut self.backend {
            Backend::Simplicial {
                col_perm,
                col_perm_inv,
                row_perm,
                row_perm_inv,
                lu,
            } => {
                // SAFETY: built as mutually inverse permutations of 0..n (`use_simplicial_with`).
                let cp = unsafe { PermRef::new_unchecked(col_perm, col_perm_inv, n) };
                factorize_simplicial_numeric_lu(row_perm, row_perm_inv, lu, a, cp, stack)
                    .map_err(|e| format!("sparse LU failed: {e:?}"))?;
            }
            Backend::Supernodal(sn) => {
                for (t, &src) in sn.t_values.iter_mut().zip(&sn.t_source) {
                    *t = values[src];
                }
                let at =
                    SparseColMatRef::new(sym_ref(n, &sn.t_col_ptr, &sn.t_row_idx), &sn.t_values);
                // SAFETY: COLAMD's permutation and its inverse (`supernodal_analysis`).
                let cp = unsafe { PermRef::new_unchecked(&sn.col_perm, &sn.col_perm_inv, n) };
                factorize_supernodal_numeric_lu(
                    &mut sn.row_perm,
                    &mut sn.row_perm_inv,
                    &mut sn.lu,
                    a,
                    at,
                    cp,
                    &sn.symbolic,
                    Par::Seq,
                    stack,
                    Default::default(),
                )
                .map_err(|e| format!("sparse LU failed: {e:?}"))?;
            }
        }
        self.numeric_factorizations += 1;
        Ok(())
    }

    /// Solves `A x = rhs` in place with the last factorization.
    pub fn solve(&mut self, rhs: &mut [T]) {
        let n = self.n;
        let mat = MatMut::from_column_major_slice_mut(rhs, n, 1);
        let stack = MemStack::new(&mut self.scratch);
        // SAFETY (all permutations): the factorization's own, mutually inverse, of 0..n.
        match &self.backend {
            Backend::Simplicial {
                col_perm,
                col_perm_inv,
                row_perm,
                row_perm_inv,
                lu,
            } => {
                let rp = unsafe { PermRef::new_unchecked(row_perm, row_perm_inv, n) };
                let cp = unsafe { PermRef::new_unchecked(col_perm, col_perm_inv, n) };
                lu.solve_in_place_with_conj(rp, cp, Conj::No, mat, Par::Seq, stack);
            }
            Backend::Supernodal(sn) => {
                let rp = unsafe { PermRef::new_unchecked(&sn.row_perm, &sn.row_perm_inv, n) };
                let cp = unsafe { PermRef::new_unchecked(&sn.col_perm, &sn.col_perm_inv, n) };
                sn.lu
                    .solve_in_place_with_conj(rp, cp, Conj::No, mat, Par::Seq, stack);
            }
        }
    }
}

impl NewtonMatrix<f64> {
    /// Entries of the L and U factors of the simplicial factorization (fill diagnostics;
    /// `None` for the supernodal one).
    pub fn factor_nnz(&self) -> Option<usize> {
        match &self.backend {
            Backend::Simplicial { lu, .. } => {
                Some(lu.l_factor_unsorted().compute_nnz() + lu.u_factor_unsorted().compute_nnz())
            }
            Backend::Supernodal(_) => None,
        }
    }

    /// Whatever kernels wrote outside the pattern since the last `clear`, relative to the
    /// largest entry (round-off level when the detected block structures are right).
    pub fn outside_pattern(&self) -> f64 {
        let dump = self.values[self.row_idx.len()].abs();
        if dump == 0.0 {
            return 0.0;
        }
        dump / self
            .values
            .iter()
            .fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()))
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

/// The pattern of Aᵀ and, for each of its entries, the position of the same entry in A.
fn transpose_pattern(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
    let mut count = vec![0usize; n + 1];
    for &i in row_idx {
        count[i + 1] += 1;
    }
    for i in 0..n {
        count[i + 1] += count[i];
    }
    let t_col_ptr = count.clone();
    let mut next = count;
    let mut t_row_idx = vec![0; row_idx.len()];
    let mut t_source = vec![0; row_idx.len()];
    for j in 0..n {
        for p in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[p];
            t_row_idx[next[i]] = j;
            t_source[next[i]] = p;
            next[i] += 1;
        }
    }
    (t_col_ptr, t_row_idx, t_source)
}

/// faer's supernodal LU analysis (as its `factorize_symbolic_lu` does, forced supernodal):
/// COLAMD column order, column elimination tree, column counts of AᵀA, supernodes.
fn supernodal_analysis(
    a: SymbolicSparseColMatRef<'_, usize>,
    at: SymbolicSparseColMatRef<'_, usize>,
) -> (SymbolicSupernodalLu<usize>, Vec<usize>, Vec<usize>) {
    let n = a.ncols();
    let nnz = a.row_idx().len();
    let mut perm = vec![0usize; n];
    let mut perm_inv = vec![0usize; n];
    let mut mem = MemBuffer::new(StackReq::any_of(&[
        colamd::order_scratch::<usize>(n, n, nnz),
        qr::col_etree_scratch::<usize>(n, n),
        qr::postorder_scratch::<usize>(n),
        StackReq::new::<usize>(5 * n + n),
        factorize_supernodal_symbolic_lu_scratch::<usize>(n, n),
    ]));
    colamd::order(
        &mut perm,
        &mut perm_inv,
        a,
        Default::default(),
        MemStack::new(&mut mem),
    )
    .expect("COLAMD order of the pattern");
    let cp = PermRef::new_checked(&perm, &perm_inv, n);
    let mut etree = vec![0usize; n];
    let mut post = vec![0usize; n];
    let mut col_counts = vec![0usize; n];
    let mut min_col = vec![0usize; n];
    let etree = qr::col_etree(a, Some(cp), &mut etree, MemStack::new(&mut mem));
    qr::postorder(&mut post, etree, MemStack::new(&mut mem));
    qr::column_counts_ata(
        &mut col_counts,
        &mut min_col,
        at,
        Some(cp),
        etree,
        &post,
        MemStack::new(&mut mem),
    );
    let symbolic = factorize_supernodal_symbolic_lu(
        a,
        Some(cp),
        &min_col,
        etree,
        &col_counts,
        MemStack::new(&mut mem),
        SymbolicSupernodalParams::default(),
    )
    .expect("supernodal LU analysis of the pattern");
    (symbolic, perm, perm_inv)
}

/// Reverse Cuthill–McKee order of the symmetrised pattern (`cols[j]`: rows of column j):
/// breadth-first from a minimum-degree vertex, neighbours by increasing degree, reversed.
/// Gives a narrow band, which partial pivoting can widen by at most a factor of two.
fn reverse_cuthill_mckee(cols: &[&[usize]]) -> Vec<usize> {
    let n = cols.len();
    let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (j, c) in cols.iter().enumerate() {
        for &i in c.iter() {
            if i != j {
                adj[i].push(j);
                adj[j].push(i);
            }
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    let deg: Vec<usize> = adj.iter().map(|a| a.len()).collect();
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    while order.len() < n {
        let start = (0..n)
            .filter(|&v| !seen[v])
            .min_by_key(|&v| deg[v])
            .unwrap();
        seen[start] = true;
        let mut head = order.len();
        order.push(start);
        while head < order.len() {
            let v = order[head];
            head += 1;
            let mut next: Vec<usize> = adj[v].iter().copied().filter(|&w| !seen[w]).collect();
            next.sort_by_key(|&w| deg[w]);
            for w in next {
                seen[w] = true;
                order.push(w);
            }
        }
    }
    order.reverse();
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn supernodal_and_simplicial_factorizations_agree() {
        // A chain of overlapping 12×12 blocks, large enough for the supernodal path.
        // A multiple of 6, so the last block ends on the last unknown.
        let n = 6 * (super::SUPERNODAL_FROM / 6 + 2);
        let blocks: Vec<Vec<usize>> = (0..n - 11)
            .step_by(6)
            .map(|s| (s..s + 12).collect())
            .collect();
        let refs: Vec<&[usize]> = blocks.iter().map(|b| b.as_slice()).collect();
        let (mut m, pos) = NewtonMatrix::from_blocks(n, &refs, None);
        assert!(m.is_supernodal());
        for (k, p) in pos.iter().enumerate() {
            for (e, &at) in p.iter().enumerate() {
                let (i, j) = (e / 12, e % 12);
                // Unsymmetric, diagonally weighted entries.
                m.values[at] += if i == j {
                    10.0
                } else {
                    ((k * 31 + e * 7) % 13) as f64 / 13.0 - 0.4
                };
            }
        }
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut x1 = rhs.clone();
        m.factor().unwrap();
        m.solve(&mut x1);
        m.use_simplicial();
        let mut x2 = rhs.clone();
        m.factor().unwrap();
        m.solve(&mut x2);
        let a = m.to_dense();
        for i in 0..n {
            let r: f64 = (0..n).map(|j| a[i][j] * x1[j]).sum();
            assert!((r - rhs[i]).abs() < 1e-12, "residual {i}");
            assert!((x1[i] - x2[i]).abs() < 1e-12);
        }
        assert_eq!(m.orderings, 2);
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
            m.values[*p] += v;
        }
        for (p, v) in pos[1].iter().zip(k2) {
            m.values[*p] += v;
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
}
