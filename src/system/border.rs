//! A bordered LU: the factors of a Newton matrix whose last rows and columns (the border —
//! a sliding joint's multipliers and contact coordinate) are refreshed from new values while
//! the leading block's factors are kept.
//!
//! With the border's columns last in the column order and its rows pivots of those columns
//! only, `P A Q = L U` splits as
//!
//! ```text
//! [A₁₁ A₁₂]   [L₁₁  0 ] [U₁₁ U₁₂]
//! [A₂₁ A₂₂] = [L₂₁ L₂₂] [ 0  U₂₂]
//! ```
//!
//! and new border values `A₁₂, A₂₁, A₂₂` change only `L₂₁ = A₂₁ U₁₁⁻¹` (a row-wise
//! substitution through `U₁₁` per border row), `U₁₂ = L₁₁⁻¹ A₁₂` and `L₂₂ U₂₂` (the
//! left-looking columns of the border): a few solves' work instead of a factorization. The
//! result is the exact LU of the matrix with the kept leading block and the new border.
//!
//! Modified Newton uses it where kept factors go stale in a few rows and columns only: a
//! collar sliding along a beam moves its contact weights `h(ζ)` by ~15 % of a node spacing per
//! step, which made one-step-old factors contract at 0.02–0.07 per iteration; with the border
//! refreshed, ~0.009 (sliding-joint models refactored at most steps before).
//!
//! The refresh's cost is the fill of `L₂₁` and `U₁₂`, which runs from the first unknown the
//! border couples to down to the end of the leading block: [`StaticPivotLu::border_refresh_share`]
//! counts it against a refactorization, and the Newton matrix drops a border too dear to
//! refresh (`MAX_BORDER_REFRESH_SHARE` in `sparse.rs`).

use super::refactor::{Scalar, StaticPivotLu};
use super::substitution;

impl<T: Scalar<Vector = T>> StaticPivotLu<T> {
    /// Whether factor rows and columns from [`Self::lead`] on are a border.
    pub fn has_border(&self) -> bool {
        self.lead < self.n
    }

    /// What refreshing the border costs against refactoring the whole matrix, counted in
    /// multiply-adds of the factors' patterns: the border rows' `L₂₁` substitutions and the
    /// border columns' left-looking updates, over every column's updates (the dense
    /// kernels' cost per multiply-add is alike in both).
    pub fn border_refresh_share(&self) -> f64 {
        let update = |k: usize| -> usize {
            let upper = &self.u.row[self.u.ptr[k]..self.u.ptr[k + 1]];
            upper
                .iter()
                .map(|&j| self.l.ptr[j + 1] - self.l.ptr[j])
                .sum::<usize>()
                + self.l.ptr[k + 1]
                - self.l.ptr[k]
        };
        let whole: usize = (0..self.n).map(update).sum();
        let columns: usize = (self.lead..self.n).map(update).sum();
        let rows: usize = (self.lead..self.n)
            .map(|r| {
                let mut cost = 0;
                for &(first, len) in self.l_rows.runs.of(r) {
                    for j in first..(first + len).min(self.lead) {
                        cost += self.u.ptr[j + 1] - self.u.ptr[j] + 1;
                    }
                }
                cost
            })
            .sum();
        (rows + columns) as f64 / whole.max(1) as f64
    }

    /// Recomputes the border's part of the factors from `values` (the matrix's, of which only
    /// the border's rows and columns are read): exact for a matrix whose leading block is the
    /// one factored. False, with the factors unusable, if a border pivot falls below the
    /// threshold (the caller factors afresh).
    pub fn refresh_border(&mut self, values: &[T]) -> bool {
        debug_assert!(self.has_border());
        #[cfg(target_arch = "x86_64")]
        if self.wide() {
            // SAFETY: the processor has AVX2 (`wide`).
            return unsafe { self.refresh_border_avx2(values) };
        }
        self.refresh_border_with::<false>(values)
    }

    /// [`Self::refresh_border`] compiled for AVX2 (see [`Self::refactor`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn refresh_border_avx2(&mut self, values: &[T]) -> bool {
        self.refresh_border_with::<true>(values)
    }

    /// The refresh, with the refactorization's AVX2 kernels if `AVX2` (only from
    /// [`Self::refresh_border_avx2`]).
    #[inline(always)]
    fn refresh_border_with<const AVX2: bool>(&mut self, values: &[T]) -> bool {
        for r in self.lead..self.n {
            self.border_row(r, values);
        }
        for k in self.lead..self.n {
            if !self.refactor_column::<AVX2>(k, values) {
                self.work.iter_mut().for_each(|w| *w = T::default());
                return false;
            }
        }
        self.l_rows.gather(&self.l.val);
        true
    }

    /// Row `r` of `L₂₁ = A₂₁ U₁₁⁻¹`: `L[r,j] = (A[r,j] − Σ_{i<j} L[r,i] U[i,j]) / U[j,j]`,
    /// columns ascending, in the work vector (`work[i]` holds `L[r,i]` once computed, zero
    /// off the row's pattern, which holds A's row).
    #[inline(always)]
    fn border_row(&mut self, r: usize, values: &[T]) {
        let lead = self.lead;
        for &(_, k, p) in self.border_a.iter().filter(|e| e.0 == r) {
            self.work[k] = values[p];
        }
        let mut q = self.l_rows.ptr[r];
        for &(first, len) in self.l_rows.runs.of(r) {
            for j in first..(first + len).min(lead) {
                let mut s = self.work[j];
                let mut p = self.u.ptr[j];
                for &(i0, m) in self.u_runs.of(j) {
                    s -= substitution::dot(&self.u.val[p..p + m], &self.work[i0..i0 + m]);
                    p += m;
                }
                let l = s * self.u_inv[j];
                self.work[j] = l;
                self.l.val[self.l_rows.source[q]] = l;
                q += 1;
            }
        }
        self.work[..lead].iter_mut().for_each(|w| *w = T::default());
    }
}
