//! Numeric refactorization of a sparse LU with the pivot order and factor patterns of an
//! earlier partial-pivoting factorization: the left-looking LU of Gilbert & Peierls without
//! its depth-first searches (as KLU's refactor). A Newton matrix changes its values, never its
//! pattern, and rarely enough to want other pivots; when it does — a pivot below
//! [`PIVOT_THRESHOLD`] of its column's largest candidate — [`StaticPivotLu::refactor`] says so
//! and the caller factors with pivoting again.
//!
//! Factor space: factor column `k` is column `col_perm[k]` of A, factor row `k` is row
//! `row_perm[k]` of A; `P A Q = L U` with L unit lower and U upper triangular.

use super::substitution;
use faer::c64;
use faer::sparse::linalg::lu::simplicial::SimplicialLu;
use faer::sparse::SparseColMatRef;
use faer::traits::ComplexField;
use std::ops::{Add, AddAssign, Div, Mul, Sub, SubAssign};

/// A pivot is kept while its magnitude is at least this fraction of the largest candidate in
/// its column (threshold partial pivoting: element growth at most 1/threshold per
/// elimination step instead of 1×). 0.01 is MUMPS's and MA57's default; UMFPACK's and MA48's
/// 0.1 threw away pivots as a pendulum swung — ED's beam pendulum with adaptive steps
/// refactored from scratch 8 times in 2 s at ratios 0.012–0.092, each a pivoting LU at
/// three refactorizations' cost. Factors only lead Newton (its residual judges every
/// iterate), so a larger growth slows an iteration at worst and never passes a step.
pub const PIVOT_THRESHOLD: f64 = 0.01;

/// A pivot before a border ([`super::border`]) is kept while it is at least this fraction of
/// the border rows' entries in its column: they are no candidates, but a pivot that small
/// against them means the leading block is singular without the border (a massless node held
/// by a sliding joint only), and the factors are taken without a border.
pub const BORDER_GUARD: f64 = 1e-8;

/// The scalar arithmetic a refactorization needs (`f64` and `c64`).
pub trait Scalar:
    Copy
    + Default
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + AddAssign
    + SubAssign
{
    /// What the substitutions carry: the scalar itself, or a pair of reals for a 2 × 2
    /// block ([`super::paired::Block2`]).
    type Vector: Copy + Default + Add<Output = Self::Vector> + AddAssign + SubAssign;
    /// A magnitude for pivot comparisons (the 1-norm for complex numbers: within √2 of the
    /// modulus, and without a square root).
    fn magnitude(self) -> f64;
    /// A pivot's size against its column's candidates' [`Self::magnitude`]s: the same for a
    /// scalar; `1/‖B⁻¹‖` for a block (what bounds the multipliers `x B⁻¹`).
    fn pivot_size(self) -> f64 {
        self.magnitude()
    }
    /// This times `v`.
    fn apply(self, v: Self::Vector) -> Self::Vector;
    /// The multiplicative identity.
    fn one() -> Self;
    /// `s` times this number.
    fn scaled(self, s: f64) -> Self;

    /// `Σ a_i b_i` ([`substitution::dot`] unless a type orders its products otherwise).
    #[inline(always)]
    fn dot(a: &[Self], b: &[Self::Vector]) -> Self::Vector {
        substitution::dot(a, b)
    }

    /// [`Self::dot`], where the caller runs compiled for AVX2: the same operations in the
    /// same order.
    ///
    /// # Safety
    /// The processor has AVX2.
    #[inline(always)]
    unsafe fn dot_avx2(a: &[Self], b: &[Self::Vector]) -> Self::Vector {
        Self::dot(a, b)
    }

    /// `x_i −= l_i u` for the rows `rows` of the dense column `x`: a refactorization's
    /// update of a column by an earlier one.
    ///
    /// # Safety
    /// Every row is below `x.len()`.
    #[inline(always)]
    unsafe fn sub_products(x: &mut [Self], rows: &[usize], l: &[Self], u: Self) {
        for (&i, &li) in rows.iter().zip(l) {
            // SAFETY: the caller's.
            unsafe { *x.get_unchecked_mut(i) -= li * u };
        }
    }

    /// [`Self::sub_products`], where the caller runs compiled for AVX2: the same operations
    /// in the same order.
    ///
    /// # Safety
    /// The processor has AVX2, and [`Self::sub_products`]'s condition holds.
    #[inline(always)]
    unsafe fn sub_products_avx2(x: &mut [Self], rows: &[usize], l: &[Self], u: Self) {
        // SAFETY: the caller's.
        unsafe { Self::sub_products(x, rows, l, u) }
    }

    /// [`substitution::sub_scaled`], where the caller runs compiled for AVX2.
    ///
    /// # Safety
    /// The processor has AVX2.
    #[inline(always)]
    unsafe fn sub_scaled_avx2(y: &mut [Self::Vector], u: &[Self], s: Self::Vector) {
        substitution::sub_scaled(y, u, s)
    }
}

impl Scalar for f64 {
    type Vector = f64;
    fn magnitude(self) -> f64 {
        self.abs()
    }
    fn apply(self, v: f64) -> f64 {
        self * v
    }
    fn one() -> Self {
        1.0
    }
    fn scaled(self, s: f64) -> Self {
        s * self
    }
}

impl Scalar for c64 {
    type Vector = c64;
    fn magnitude(self) -> f64 {
        self.re.abs() + self.im.abs()
    }
    fn apply(self, v: c64) -> c64 {
        self * v
    }
    fn one() -> Self {
        c64::new(1.0, 0.0)
    }
    fn scaled(self, s: f64) -> Self {
        c64::new(s * self.re, s * self.im)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn dot_avx2(a: &[Self], b: &[Self]) -> Self {
        // SAFETY: the caller's.
        unsafe { substitution::dot_c64_avx2(a, b) }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn sub_scaled_avx2(y: &mut [Self], u: &[Self], s: Self) {
        // SAFETY: the caller's.
        unsafe { substitution::sub_scaled_c64_avx2(y, u, s) }
    }
}

/// L and U with fixed patterns and pivots; every buffer is reused across refactorizations
/// and rebuilt (capacity kept) only after a pivoting factorization.
#[derive(Default)]
pub struct StaticPivotLu<T: Scalar> {
    pub(super) n: usize,
    /// Factor rows and columns from here on are the border's (see [`super::border`]): the
    /// pivots before it are chosen among the other rows only. `n` without a border.
    pub(super) lead: usize,
    /// Per factor column: the factor rows of A's column `col_perm[k]` and where its values
    /// are in A's value array.
    pub(super) a_ptr: Vec<usize>,
    pub(super) a_row: Vec<usize>,
    pub(super) a_pos: Vec<usize>,
    /// A's entries in the border's rows and the leading columns: `(factor row, factor
    /// column, value position)`.
    pub(super) border_a: Vec<(usize, usize, usize)>,
    /// Strictly lower part of L (unit diagonal implied).
    pub(super) l: Triangle<T>,
    /// Strictly upper part of U, rows ascending in each column (a topological order for the
    /// left-looking updates), and U's diagonal.
    pub(super) u: Triangle<T>,
    /// Reciprocals of U's diagonal (the pivots): one division per column, not per entry.
    pub(super) u_inv: Vec<T>,
    /// U's columns as runs of consecutive rows (the back substitution's axpys).
    pub(super) u_runs: Runs,
    /// L by rows, as runs of consecutive columns (the forward substitution's dot products):
    /// L's columns are short runs (row pivoting scatters them; 2.9 entries on the beam
    /// pendulum), its rows long ones (14).
    pub(super) l_rows: RowCopy<T>,
    row_perm: Vec<usize>,
    col_perm: Vec<usize>,
    /// Dense column in factor space; all zero between refactorizations.
    pub(super) work: Vec<T>,
    /// The right-hand side in factor space (the solves').
    rhs: Vec<T::Vector>,
    /// One column of U being sorted (`rebuild`).
    sort_scratch: Vec<(usize, T)>,
    /// Run the baseline kernels even where wider instructions would pay (tests compare).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    portable_only: bool,
}

impl<T: Scalar> StaticPivotLu<T> {
    /// Takes patterns, pivots and values from faer's simplicial LU of the matrix with pattern
    /// `(a_col_ptr, a_row_idx)`, factored in column order `col_perm` with row order
    /// `row_perm` (`row_perm_inv` its inverse); factor rows and columns from `lead` on are a
    /// border (`n` for none), whose rows were not pivots of the columns before it.
    pub fn rebuild<P: ComplexField + Copy>(
        &mut self,
        (a_col_ptr, a_row_idx): (&[usize], &[usize]),
        (row_perm, row_perm_inv): (&[usize], &[usize]),
        col_perm: &[usize],
        (lu, value): (&SimplicialLu<usize, P>, impl Fn(P) -> T),
        lead: usize,
    ) {
        let n = col_perm.len();
        self.n = n;
        self.lead = lead;
        self.row_perm.clear();
        self.row_perm.extend_from_slice(row_perm);
        self.col_perm.clear();
        self.col_perm.extend_from_slice(col_perm);
        self.work.clear();
        self.work.resize(n, T::default());
        self.rhs.clear();
        self.rhs.resize(n, T::Vector::default());
        self.a_ptr.clear();
        self.a_row.clear();
        self.a_pos.clear();
        self.a_ptr.push(0);
        for &c in col_perm {
            for p in a_col_ptr[c]..a_col_ptr[c + 1] {
                self.a_row.push(row_perm_inv[a_row_idx[p]]);
                self.a_pos.push(p);
            }
            self.a_ptr.push(self.a_row.len());
        }
        self.border_a.clear();
        for k in 0..lead {
            for p in self.a_ptr[k]..self.a_ptr[k + 1] {
                if self.a_row[p] >= lead {
                    self.border_a.push((self.a_row[p], k, self.a_pos[p]));
                }
            }
        }
        // faer stores L's unit diagonal explicitly; U's diagonal is the pivots.
        self.l
            .take_strict(lu.l_factor_unsorted(), &value, |_, _| {});
        self.u_inv.clear();
        self.u_inv.resize(n, T::default());
        let inv = &mut self.u_inv;
        self.u
            .take_strict(lu.u_factor_unsorted(), &value, |k, v| inv[k] = T::one() / v);
        self.u.sort_columns(&mut self.sort_scratch);
        self.u_runs.index(&self.u.ptr, &self.u.row);
        self.l_rows.rebuild(n, &self.l);

        // The refactorization and the solves index the work vector by these unchecked.
        let rows = self.a_row.iter().chain(&self.l.row).chain(&self.u.row);
        assert!(
            rows.into_iter().all(|&r| r < n),
            "LU factor rows within 0..n"
        );
    }

    /// Lines of the substitutions (rows of L, columns of U) whose entries are not one run
    /// of consecutive indices (tests: the run structure is exercised).
    #[cfg(test)]
    pub fn gapped_lines(&self) -> usize {
        let gapped = |r: &Runs| (0..r.ptr.len() - 1).filter(|&k| r.of(k).len() > 1).count();
        gapped(&self.l_rows.runs) + gapped(&self.u_runs)
    }

    /// Entries of L and U, diagonals included.
    pub fn nnz(&self) -> usize {
        self.l.row.len() + self.u.row.len() + 2 * self.n
    }

    /// Refactors A (`values` on the pattern given to [`Self::rebuild`]) with the kept pivots;
    /// false, with the factors unusable, when a pivot falls below [`PIVOT_THRESHOLD`] of its
    /// column's largest candidate (or is zero or not finite).
    pub fn refactor(&mut self, values: &[T]) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.wide() {
            // SAFETY: the processor has AVX2 (`wide`).
            return unsafe { self.refactor_avx2(values) };
        }
        self.refactor_with::<false>(values)
    }

    /// Whether the kernels run compiled for AVX2: on processors that have it, unless the
    /// baseline ones are asked for (detection is cached by the standard library).
    #[cfg(target_arch = "x86_64")]
    pub(super) fn wide(&self) -> bool {
        !self.portable_only && std::is_x86_feature_detected!("avx2")
    }

    /// Runs the baseline kernels only (`true`), or the widest that pay (the default).
    pub fn set_portable_only(&mut self, portable_only: bool) {
        self.portable_only = portable_only;
    }

    /// [`Self::refactor`] compiled for AVX2 (see [`Self::solve`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn refactor_avx2(&mut self, values: &[T]) -> bool {
        self.refactor_with::<true>(values)
    }

    /// The refactorization, with the kernels for AVX2 if `AVX2` (only from
    /// [`Self::refactor_avx2`]).
    #[inline(always)]
    fn refactor_with<const AVX2: bool>(&mut self, values: &[T]) -> bool {
        for k in 0..self.n {
            if !self.refactor_column::<AVX2>(k, values) {
                self.work.iter_mut().for_each(|w| *w = T::default());
                return false;
            }
        }
        self.l_rows.gather(&self.l.val);
        true
    }

    /// Column `k` of L and U: scatter A's column, apply the earlier columns of L that U's
    /// pattern names (in ascending order), gather and scale (left-looking).
    /// `AVX2` as in [`Self::refactor_with`].
    #[inline(always)]
    pub(super) fn refactor_column<const AVX2: bool>(&mut self, k: usize, values: &[T]) -> bool {
        let x = &mut self.work;
        for p in self.a_ptr[k]..self.a_ptr[k + 1] {
            x[self.a_row[p]] = values[self.a_pos[p]];
        }
        let upper = self.u.ptr[k]..self.u.ptr[k + 1];
        for (&j, u) in self.u.row[upper.clone()].iter().zip(&mut self.u.val[upper]) {
            let ujk = x[j];
            x[j] = T::default();
            *u = ujk;
            // Nothing to subtract. A sliding window's pattern holds the couplings of every
            // node the contact may reach during a step, most of them zero at any one time
            // (the beam slider's refactorizations: 5–8 % faster at 5 ms).
            if ujk.magnitude() == 0.0 {
                continue;
            }
            let col = self.l.ptr[j]..self.l.ptr[j + 1];
            let (rows, l) = (&self.l.row[col.clone()], &self.l.val[col]);
            // SAFETY: factor rows are below n = x.len() (checked in `rebuild`); AVX2 only
            // from `refactor_avx2`, run where the processor has it.
            unsafe {
                if AVX2 {
                    T::sub_products_avx2(x, rows, l, ujk);
                } else {
                    T::sub_products(x, rows, l, ujk);
                }
            }
        }
        let pivot = x[k];
        x[k] = T::default();
        let lower = self.l.ptr[k]..self.l.ptr[k + 1];
        // A border's rows are no candidates before it: only a pivot lost against them
        // (a singular leading block) fails the factors.
        let (mut largest, mut border) = (0.0f64, 0.0f64);
        for &i in &self.l.row[lower.clone()] {
            let m = x[i].magnitude();
            if k >= self.lead || i < self.lead {
                largest = largest.max(m);
            } else {
                border = border.max(m);
            }
        }
        let size = pivot.pivot_size();
        let kept = size >= PIVOT_THRESHOLD * largest && size >= BORDER_GUARD * border;
        if !(size.is_finite() && size > 0.0 && kept) {
            return false;
        }
        let inv = T::one() / pivot;
        self.u_inv[k] = inv;
        for (&i, l) in self.l.row[lower.clone()].iter().zip(&mut self.l.val[lower]) {
            *l = x[i] * inv;
            x[i] = T::default();
        }
        true
    }

    /// Solves `A x = rhs` in place.
    pub fn solve(&mut self, rhs: &mut [T::Vector]) {
        self.solve_mapped(rhs, |r, i| r[i], |r, i, x| r[i] = x);
    }

    /// Solves `A x = b` with `b_i = load(data, i)`, handing each `x_i` to
    /// `store(data, i, x_i)` once every `b_i` is read: a caller whose right-hand side and
    /// solution are mixtures of other quantities (ED's decoupled system) forms and unmixes
    /// them in the permutations' passes, not in passes of its own.
    #[inline]
    pub fn solve_mapped<D: ?Sized>(
        &mut self,
        data: &mut D,
        load: impl Fn(&D, usize) -> T::Vector,
        mut store: impl FnMut(&mut D, usize, T::Vector),
    ) {
        for (yk, &r) in self.rhs.iter_mut().zip(&self.row_perm) {
            *yk = load(data, r);
        }
        self.substitute();
        for (&yk, &c) in self.rhs.iter().zip(&self.col_perm) {
            store(data, c, yk);
        }
    }

    /// The forward and back substitutions on the work vector (the permuted right-hand side),
    /// compiled for AVX2 where the processor has it: their inner loops run over contiguous
    /// slices ([`Runs`]), which wider vectors carry (−15 % per real solve; complex products
    /// by explicit instructions, see [`substitution`]).
    fn substitute(&mut self) {
        #[cfg(target_arch = "x86_64")]
        if self.wide() {
            // SAFETY: the processor has AVX2 (`wide`).
            return unsafe { self.substitute_avx2() };
        }
        self.substitute_with::<false>();
    }

    /// [`Self::substitute`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn substitute_avx2(&mut self) {
        self.substitute_with::<true>();
    }

    /// The substitutions, with the kernels for AVX2 if `AVX2` (only from
    /// [`Self::substitute_avx2`]). Inlined only into `substitute` and `substitute_avx2`:
    /// inlined into other callers its loops compiled ~15 % longer.
    #[inline(always)]
    fn substitute_with<const AVX2: bool>(&mut self) {
        let y = &mut self.rhs;
        let l = &self.l_rows;
        for i in 0..self.n {
            let mut s = y[i];
            let mut p = l.ptr[i];
            for &(first, len) in l.runs.of(i) {
                let (a, b) = (&l.val[p..p + len], &y[first..first + len]);
                // SAFETY: AVX2 only from `substitute_avx2`, run where the processor has it.
                s -= if AVX2 {
                    unsafe { T::dot_avx2(a, b) }
                } else {
                    T::dot(a, b)
                };
                p += len;
            }
            y[i] = s;
        }
        for k in (0..self.n).rev() {
            let yk = self.u_inv[k].apply(y[k]);
            y[k] = yk;
            let mut p = self.u.ptr[k];
            for &(first, len) in self.u_runs.of(k) {
                let (y, u) = (&mut y[first..first + len], &self.u.val[p..p + len]);
                if AVX2 {
                    // SAFETY: as above.
                    unsafe { T::sub_scaled_avx2(y, u, yk) };
                } else {
                    substitution::sub_scaled(y, u, yk);
                }
                p += len;
            }
        }
    }
}

/// Where the entries of a compressed triangle's lines (columns or rows) lie as runs of
/// consecutive indices: the substitutions' inner loops then run over contiguous slices, no
/// index per entry.
#[derive(Default)]
pub(super) struct Runs {
    ptr: Vec<usize>,
    /// `(first index, length)`.
    runs: Vec<(usize, usize)>,
}

impl Runs {
    /// From the lines' indices `idx[ptr[k]..ptr[k + 1]]`, ascending in each line.
    fn index(&mut self, ptr: &[usize], idx: &[usize]) {
        self.ptr.clear();
        self.runs.clear();
        self.ptr.push(0);
        for k in 0..ptr.len() - 1 {
            for (q, &i) in idx[ptr[k]..ptr[k + 1]].iter().enumerate() {
                match self.runs.last_mut() {
                    Some((first, len)) if q > 0 && *first + *len == i => *len += 1,
                    _ => self.runs.push((i, 1)),
                }
            }
            self.ptr.push(self.runs.len());
        }
    }

    /// Line `k`'s runs.
    pub(super) fn of(&self, k: usize) -> &[(usize, usize)] {
        &self.runs[self.ptr[k]..self.ptr[k + 1]]
    }
}

/// A strict lower triangle's copy by rows, columns ascending, refreshed from its column
/// storage after every refactorization.
#[derive(Default)]
pub(super) struct RowCopy<T> {
    pub(super) ptr: Vec<usize>,
    /// Where each entry's value is in the column storage.
    pub(super) source: Vec<usize>,
    pub(super) runs: Runs,
    val: Vec<T>,
}

impl<T: Scalar> RowCopy<T> {
    /// The pattern of `by_columns` (an `n × n` triangle) by rows, with its values.
    fn rebuild(&mut self, n: usize, by_columns: &Triangle<T>) {
        let mut count = vec![0usize; n + 1];
        for &r in &by_columns.row {
            count[r + 1] += 1;
        }
        for r in 0..n {
            count[r + 1] += count[r];
        }
        self.ptr.clear();
        self.ptr.extend_from_slice(&count);
        let mut next = count;
        let mut column = vec![0usize; by_columns.row.len()];
        self.source.clear();
        self.source.resize(by_columns.row.len(), 0);
        // Columns in ascending order: each row's columns come out ascending.
        for k in 0..by_columns.ptr.len() - 1 {
            for p in by_columns.ptr[k]..by_columns.ptr[k + 1] {
                let r = by_columns.row[p];
                column[next[r]] = k;
                self.source[next[r]] = p;
                next[r] += 1;
            }
        }
        self.runs.index(&self.ptr, &column);
        self.val.clear();
        self.val.resize(by_columns.row.len(), T::default());
        self.gather(&by_columns.val);
    }

    /// The values from the column storage's.
    pub(super) fn gather(&mut self, by_columns: &[T]) {
        for (v, &p) in self.val.iter_mut().zip(&self.source) {
            *v = by_columns[p];
        }
    }
}

/// A strict triangle by compressed columns.
#[derive(Default)]
pub(super) struct Triangle<T> {
    pub(super) ptr: Vec<usize>,
    pub(super) row: Vec<usize>,
    pub(super) val: Vec<T>,
}

impl<T: Scalar> Triangle<T> {
    /// The off-diagonal entries of a factor (storage reused); each diagonal entry goes to
    /// `on_diagonal(column, value)`.
    fn take_strict<P: Copy>(
        &mut self,
        m: SparseColMatRef<'_, usize, P>,
        value: impl Fn(P) -> T,
        mut on_diagonal: impl FnMut(usize, T),
    ) {
        let (ptr, rows, vals) = (m.col_ptr(), m.row_idx(), m.val());
        self.ptr.clear();
        self.row.clear();
        self.val.clear();
        self.ptr.push(0);
        for k in 0..m.ncols() {
            for p in ptr[k]..ptr[k + 1] {
                if rows[p] == k {
                    on_diagonal(k, value(vals[p]));
                } else {
                    self.row.push(rows[p]);
                    self.val.push(value(vals[p]));
                }
            }
            self.ptr.push(self.row.len());
        }
    }

    /// Rows ascending in each column (`scratch` reused).
    fn sort_columns(&mut self, scratch: &mut Vec<(usize, T)>) {
        for k in 0..self.ptr.len() - 1 {
            let col = self.ptr[k]..self.ptr[k + 1];
            scratch.clear();
            scratch.extend(
                self.row[col.clone()]
                    .iter()
                    .copied()
                    .zip(self.val[col.clone()].iter().copied()),
            );
            scratch.sort_unstable_by_key(|e| e.0);
            for (q, &(r, v)) in col.zip(scratch.iter()) {
                self.row[q] = r;
                self.val[q] = v;
            }
        }
    }
}
