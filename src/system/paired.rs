//! ED's real Newton matrix factored as 2 × 2 blocks of its pairs.
//!
//! ED's unknowns and equations come in pairs ([`Layout::pair`]: a motion's increment and
//! jump, a row's λ and λ_d), so its real matrix is EP's pattern with every entry a 2 × 2
//! block. Factored block by block ([`StaticPivotLu`] over [`Block2`]), its LU does the real
//! matrix's arithmetic without the scalar LU's index per entry, and its solves carry two
//! reals per index.
//!
//! The pivots. For a linear system the blocks are `P m + Q k` (motion rows and columns),
//! `D b` (motion rows, multiplier columns) and `E b` (constraint rows, motion columns), with
//! P, Q, D, E of `integrator::ed_decoupled`'s notes. Each row pair taken times `R` (`P⁻¹` for
//! a motion's, `E⁻¹` for a constraint's) and each multiplier column pair times `C = D⁻¹P`
//! turns every block into `a I + b N` (`N = P⁻¹Q`), an algebra isomorphic to ℂ through
//! `N ↦ μ = 1/18 + i√2/9`: the block LU of `R A C` is then the complex LU of the decoupled
//! system, element for element. So the transformed blocks are factored, each projected onto
//! that algebra (least squares) to choose the pivots by faer's complex LU, and a kept block
//! pivot is checked against its column's blocks like a scalar one ([`Scalar::pivot_size`]).
//! A solve is `x = C (R A C)⁻¹ R b`. Where the blocks cannot be factored with those pivots,
//! the caller factors the real matrix by scalars.

use super::refactor::{Scalar, StaticPivotLu};
use super::sparse::{compress_columns, NewtonMatrix};
use super::substitution;
use crate::math::layout::Layout;
use faer::c64;
use std::ops::{Add, AddAssign, Div, Mul, Sub, SubAssign};

/// A 2 × 2 real block, row-major: `[[a, b], [c, d]]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Block2(pub [f64; 4]);

/// A pair of reals, what a [`Block2`] acts on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pair2(pub [f64; 2]);

impl Block2 {
    fn det(self) -> f64 {
        let [a, b, c, d] = self.0;
        a * d - b * c
    }

    /// The inverse (non-finite entries for a singular block).
    fn inverse(self) -> Block2 {
        let [a, b, c, d] = self.0;
        let r = 1.0 / self.det();
        Block2([d * r, -b * r, -c * r, a * r])
    }
}

impl Add for Block2 {
    type Output = Block2;
    fn add(self, o: Block2) -> Block2 {
        Block2(std::array::from_fn(|k| self.0[k] + o.0[k]))
    }
}

impl Sub for Block2 {
    type Output = Block2;
    fn sub(self, o: Block2) -> Block2 {
        Block2(std::array::from_fn(|k| self.0[k] - o.0[k]))
    }
}

impl Mul for Block2 {
    type Output = Block2;
    fn mul(self, o: Block2) -> Block2 {
        let ([a, b, c, d], [e, f, g, h]) = (self.0, o.0);
        Block2([a * e + b * g, a * f + b * h, c * e + d * g, c * f + d * h])
    }
}

impl Div for Block2 {
    type Output = Block2;
    /// `self · o⁻¹`.
    #[allow(clippy::suspicious_arithmetic_impl)] // a block's quotient is a product
    fn div(self, o: Block2) -> Block2 {
        self * o.inverse()
    }
}

impl AddAssign for Block2 {
    fn add_assign(&mut self, o: Block2) {
        *self = *self + o;
    }
}

impl SubAssign for Block2 {
    fn sub_assign(&mut self, o: Block2) {
        *self = *self - o;
    }
}

impl Add for Pair2 {
    type Output = Pair2;
    fn add(self, o: Pair2) -> Pair2 {
        Pair2([self.0[0] + o.0[0], self.0[1] + o.0[1]])
    }
}

impl AddAssign for Pair2 {
    fn add_assign(&mut self, o: Pair2) {
        *self = *self + o;
    }
}

impl SubAssign for Pair2 {
    fn sub_assign(&mut self, o: Pair2) {
        *self = Pair2([self.0[0] - o.0[0], self.0[1] - o.0[1]]);
    }
}

impl Scalar for Block2 {
    type Vector = Pair2;
    /// The ∞-norm (largest row sum).
    fn magnitude(self) -> f64 {
        let [a, b, c, d] = self.0;
        (a.abs() + b.abs()).max(c.abs() + d.abs())
    }
    /// `1/‖B⁻¹‖∞ = |det B| / ‖adj B‖∞`: the multipliers `x B⁻¹` are at most
    /// `‖x‖/pivot_size`, as a scalar pivot's.
    fn pivot_size(self) -> f64 {
        let [a, b, c, d] = self.0;
        let adj = (d.abs() + b.abs()).max(c.abs() + a.abs());
        if adj > 0.0 {
            self.det().abs() / adj
        } else {
            0.0
        }
    }
    fn one() -> Self {
        Block2([1.0, 0.0, 0.0, 1.0])
    }
    fn scaled(self, s: f64) -> Self {
        Block2(self.0.map(|v| s * v))
    }
    fn apply(self, v: Pair2) -> Pair2 {
        let ([a, b, c, d], [x, y]) = (self.0, v.0);
        Pair2([a * x + b * y, c * x + d * y])
    }

    #[inline(always)]
    fn dot(a: &[Self], b: &[Pair2]) -> Pair2 {
        substitution::dot_block2(a, b)
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn dot_avx2(a: &[Self], b: &[Pair2]) -> Pair2 {
        // SAFETY: the caller's.
        unsafe { substitution::dot_block2_avx2(a, b) }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn sub_products_avx2(x: &mut [Self], rows: &[usize], l: &[Self], u: Self) {
        // SAFETY: the caller's.
        unsafe { substitution::sub_products_block2_avx2(x, rows, l, u) }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn sub_scaled_avx2(y: &mut [Pair2], u: &[Self], s: Pair2) {
        // SAFETY: the caller's.
        unsafe { substitution::sub_scaled_block2_avx2(y, u, s) }
    }
}

/// No real entry at this block slot: the block's entry is zero.
const ABSENT: usize = usize::MAX;

/// A motion row pair's transform `P⁻¹` (P = [[2, −1], [0, 1]]).
const MOTION_ROWS: Block2 = Block2([0.5, 0.5, 0.0, 1.0]);
/// A constraint row pair's transform `E⁻¹` (E = [[1, 0], [−2, 2]]).
const CONSTRAINT_ROWS: Block2 = Block2([1.0, 0.0, 1.0, 0.5]);
/// A multiplier column pair's transform `D⁻¹P` (D = [[1, 0], [0, −1/6]]).
const MULTIPLIER_COLUMNS: Block2 = Block2([2.0, -1.0, 0.0, -6.0]);

/// The complex image of block `[[p, q], [r, t]]` projected (least squares) onto the algebra
/// `a I + b N`, `N = [[1/18, 1/9], [−2/9, 1/18]]`: `a + b μ`.
fn image(block: Block2) -> c64 {
    let [p, q, r, t] = block.0;
    let b = 9.0 * (q - 2.0 * r) / 5.0;
    c64::new(0.5 * (p + t), b * std::f64::consts::SQRT_2 / 9.0)
}

/// The block-wise LU of an ED real matrix of a fixed pattern.
pub struct PairedLu {
    /// Per pair: its two real unknowns (`Layout::unpair`) and its row and column transforms.
    pairs: Vec<(usize, usize)>,
    rows: Vec<Block2>,
    columns: Vec<Block2>,
    /// Per block of the pattern (in `proxy`'s value order): its pairs and the real values'
    /// positions of its entries, row-major, or [`ABSENT`].
    sources: Vec<(usize, usize, [usize; 4])>,
    blocks: Vec<Block2>,
    /// The blocks' pattern, with their images in ℂ as values when pivots are chosen (faer's
    /// LU and the column order of a complex matrix).
    proxy: NewtonMatrix<c64>,
    lu: StaticPivotLu<Block2>,
    /// Whether `lu` holds pivots and patterns to refactor with.
    pivots: bool,
}

impl PairedLu {
    /// For the ED matrix of pattern `(col_ptr, row_idx)` (rows sorted in each column) on
    /// `layout`'s unknowns.
    pub fn new(layout: &Layout, col_ptr: &[usize], row_idx: &[usize]) -> Self {
        let np = layout.n_pairs();
        let mut cols: Vec<Vec<usize>> = (0..np).map(|p| vec![p]).collect();
        for j in 0..col_ptr.len() - 1 {
            for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
                cols[layout.pair(j).0].push(layout.pair(i).0);
            }
        }
        let (b_ptr, b_rows) = compress_columns(&mut cols);
        let mut sources = vec![(0, 0, [ABSENT; 4]); b_rows.len()];
        for (pj, col) in cols.iter().enumerate() {
            for (q, &pi) in col.iter().enumerate() {
                sources[b_ptr[pj] + q].0 = pi;
                sources[b_ptr[pj] + q].1 = pj;
            }
        }
        for j in 0..col_ptr.len() - 1 {
            let (pj, j_second) = layout.pair(j);
            for (p, &i) in row_idx
                .iter()
                .enumerate()
                .take(col_ptr[j + 1])
                .skip(col_ptr[j])
            {
                let (pi, i_second) = layout.pair(i);
                let col = &b_rows[b_ptr[pj]..b_ptr[pj + 1]];
                let at = b_ptr[pj] + col.binary_search(&pi).expect("block in pattern");
                sources[at].2[2 * usize::from(i_second) + usize::from(j_second)] = p;
            }
        }
        let multiplier = |p: usize| layout.pair_is_multiplier(p);
        PairedLu {
            pairs: (0..np).map(|p| layout.unpair(p)).collect(),
            rows: (0..np)
                .map(|p| {
                    if multiplier(p) {
                        CONSTRAINT_ROWS
                    } else {
                        MOTION_ROWS
                    }
                })
                .collect(),
            columns: (0..np)
                .map(|p| {
                    if multiplier(p) {
                        MULTIPLIER_COLUMNS
                    } else {
                        Block2::one()
                    }
                })
                .collect(),
            blocks: vec![Block2::default(); sources.len()],
            sources,
            proxy: NewtonMatrix::from_pattern(np, b_ptr, b_rows),
            lu: StaticPivotLu::default(),
            pivots: false,
        }
    }

    /// Factors the real matrix of `values` by blocks: `Some(true)` refactored with the kept
    /// pivots, `Some(false)` with pivots chosen afresh, None if the blocks could not be
    /// factored (the caller factors by scalars).
    pub fn factor(&mut self, values: &[f64]) -> Option<bool> {
        for (b, &(pi, pj, src)) in self.blocks.iter_mut().zip(&self.sources) {
            let a = Block2(src.map(|p| if p == ABSENT { 0.0 } else { values[p] }));
            *b = self.rows[pi] * a * self.columns[pj];
        }
        if self.pivots && self.lu.refactor(&self.blocks) {
            return Some(true);
        }
        self.pivots = false;
        let nnz = self.blocks.len();
        for (v, &b) in self.proxy.values[..nnz].iter_mut().zip(&self.blocks) {
            *v = image(b);
        }
        let proxy = &mut self.proxy;
        proxy.factor_with_pivots(false).ok()?;
        proxy.rebuild_pattern_into(&mut self.lu);
        self.pivots = self.lu.refactor(&self.blocks);
        self.pivots.then_some(false)
    }

    /// Solves `A x = rhs` in place with the last factorization (which succeeded):
    /// `x = C (R A C)⁻¹ R rhs`.
    pub fn solve(&mut self, rhs: &mut [f64]) {
        let (pairs, rows, columns) = (&self.pairs, &self.rows, &self.columns);
        self.lu.solve_mapped(
            rhs,
            |r, p| rows[p].apply(Pair2([r[pairs[p].0], r[pairs[p].1]])),
            |r, p, v| [r[pairs[p].0], r[pairs[p].1]] = columns[p].apply(v).0,
        );
    }

    /// Runs the baseline kernels only (tests compare them with the wide ones).
    #[cfg(test)]
    fn set_portable_only(&mut self, portable_only: bool) {
        self.lu.set_portable_only(portable_only);
    }

    /// Entries of the block factors, diagonals included (fill diagnostics).
    pub fn factor_nnz(&self) -> usize {
        4 * self.lu.nnz()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::layout::Scheme;

    const SQRT2: f64 = std::f64::consts::SQRT_2;

    fn pseudo(k: usize) -> f64 {
        ((k as f64 * 12.9898).sin() * 43758.5453).fract()
    }

    /// The algebra `a I + b N` and its image `a + b μ`.
    fn element(a: f64, b: f64) -> Block2 {
        Block2([a + b / 18.0, b / 9.0, -2.0 * b / 9.0, a + b / 18.0])
    }

    /// The transforms turn a linear system's blocks into the decoupled complex system's
    /// entries (`integrator::ed_decoupled`): `P m + Q k → m + μ k`, `D b` and `E b → b`, a
    /// row pair's own multipliers `[[α, 0], [0, −α]] → (2 − i√2) α`; and products and
    /// inverses of the algebra's elements are those of their images (the block LU follows
    /// the complex one's pivots).
    #[test]
    fn transformed_linear_blocks_are_the_decoupled_systems_entries() {
        let mu = c64::new(1.0 / 18.0, SQRT2 / 9.0);
        let (m, k, b, alpha) = (3.7, -1.3, 2.9, 0.6);
        let p = Block2([2.0, -1.0, 0.0, 1.0]);
        let q = Block2([1.0 / 3.0, 1.0 / 6.0, -2.0 / 9.0, 1.0 / 18.0]);
        let d = Block2([1.0, 0.0, 0.0, -1.0 / 6.0]);
        let e = Block2([1.0, 0.0, -2.0, 2.0]);
        let own = Block2([alpha, 0.0, 0.0, -alpha]);
        let cases = [
            (MOTION_ROWS * (p.scaled(m) + q.scaled(k)), mu * k + m),
            (
                MOTION_ROWS * d.scaled(b) * MULTIPLIER_COLUMNS,
                c64::new(b, 0.0),
            ),
            (CONSTRAINT_ROWS * e.scaled(b), c64::new(b, 0.0)),
            (
                CONSTRAINT_ROWS * own * MULTIPLIER_COLUMNS,
                c64::new(2.0, -SQRT2) * alpha,
            ),
        ];
        for (block, expected) in cases {
            let z = image(block);
            // Round-off of a few products of numbers of order 1.
            assert!((z - expected).norm() < 1e-14, "{block:?}: {z} ≠ {expected}");
            let (a, bb) = (z.re - z.im / (SQRT2 / 9.0) / 18.0, z.im * 9.0 / SQRT2);
            let back = element(a, bb);
            assert!(
                (block - back).magnitude() < 1e-14,
                "{block:?} outside the algebra"
            );
        }
        let (x, y) = (element(0.7, -2.1), element(-1.4, 0.3));
        let to_c = |e: Block2| image(e);
        assert!((to_c(x * y) - to_c(x) * to_c(y)).norm() < 1e-14);
        assert!((to_c(x / y) - to_c(x) / to_c(y)).norm() < 1e-14);
    }

    /// An ED matrix on a layout with node, coordinate and constraint pairs: a linear system's
    /// blocks (module notes) plus `perturbation` times entries of no such form (a nonlinear
    /// tangent's), with the real matrix's pattern and value positions.
    fn ed_matrix(layout: &Layout, perturbation: f64, seed: usize) -> NewtonMatrix<f64> {
        let n = layout.n_unknowns();
        let all: Vec<usize> = (0..n).collect();
        let (mut real, pos) = NewtonMatrix::<f64>::from_blocks(n, &[&all], None);
        let (h, s) = (0.01, 1e4);
        let motions = layout.n_pairs() - layout.n_rows;
        for pa in 0..layout.n_pairs() {
            let (fa, ja) = layout.unpair(pa);
            for pc in 0..layout.n_pairs() {
                let (dc, xc) = layout.unpair(pc);
                let r = |k: usize| pseudo(seed + 4 * (pa * 97 + pc) + k);
                let block = match (pa < motions, pc < motions) {
                    (true, true) => {
                        let mh = (r(0) + if pa == pc { 4.0 } else { 0.0 }) / (h * h);
                        let kk = 1e3 * r(1) + if pa == pc { 5e3 } else { 0.0 };
                        [
                            2.0 * mh + kk / 3.0,
                            -mh + kk / 6.0,
                            -2.0 * kk / 9.0,
                            mh + kk / 18.0,
                        ]
                    }
                    (true, false) => [s * r(2), 0.0, 0.0, -s * r(2) / 6.0],
                    (false, true) => [s * r(3), 0.0, -2.0 * s * r(3), 2.0 * s * r(3)],
                    (false, false) => [0.0; 4],
                };
                let scale = block.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let cells = [(fa, dc), (fa, xc), (ja, dc), (ja, xc)];
                for (q, (&(i, j), v)) in cells.iter().zip(block).enumerate() {
                    let bump = perturbation * scale * r(q);
                    real.values[pos[0][i * n + j] as usize] = v + bump;
                }
            }
        }
        real
    }

    fn assert_solves_alike(lu: &mut PairedLu, real: &mut NewtonMatrix<f64>) {
        let n = real.values.len() - 1;
        let n = (n as f64).sqrt().round() as usize;
        let rhs: Vec<f64> = (0..n).map(|i| pseudo(900 + i) - 0.5).collect();
        let mut paired = rhs.clone();
        lu.solve(&mut paired);
        let mut scalar = rhs;
        real.factor().unwrap();
        real.solve(&mut scalar);
        let size = scalar.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (i, (a, b)) in paired.iter().zip(&scalar).enumerate() {
            // Two LUs' round-off on entries spanning m/h² ~ 4e4 to s ~ 1e4.
            assert!((a - b).abs() <= 1e-10 * size, "unknown {i}: {a:e} ≠ {b:e}");
        }
    }

    /// The block LU solves like the scalar LU: fresh pivots on a perturbed linear system,
    /// kept pivots on values changed by a further perturbation.
    #[test]
    fn block_lu_solves_like_the_scalar_lu() {
        let layout = Layout::new(Scheme::Ed, 2, 1, 3);
        let mut real = ed_matrix(&layout, 0.05, 0);
        let (col_ptr, row_idx) = real.pattern();
        let mut lu = PairedLu::new(&layout, col_ptr, row_idx);
        assert_eq!(lu.factor(&real.values), Some(false), "pivots chosen");
        assert_solves_alike(&mut lu, &mut real);
        let mut changed = ed_matrix(&layout, 0.08, 0);
        assert_eq!(lu.factor(&changed.values), Some(true), "pivots kept");
        assert_solves_alike(&mut lu, &mut changed);
    }

    /// The block kernels compiled for AVX2 (where the processor has it) factor and solve as
    /// the baseline ones do, bit for bit: the same products, summed in the same order. Rows
    /// of L and columns of U of odd and even lengths exercise the two-block loops and their
    /// remainders.
    #[test]
    fn block_kernels_agree_across_instruction_sets() {
        let layout = Layout::new(Scheme::Ed, 3, 1, 3);
        let real = ed_matrix(&layout, 0.05, 0);
        let (col_ptr, row_idx) = real.pattern();
        let mut lu = PairedLu::new(&layout, col_ptr, row_idx);
        let n = layout.n_unknowns();
        let rhs: Vec<f64> = (0..n).map(|i| pseudo(500 + i) - 0.5).collect();
        let mut solutions = Vec::new();
        for portable_only in [false, true] {
            lu.set_portable_only(portable_only);
            assert!(lu.factor(&real.values).is_some());
            let mut x = rhs.clone();
            lu.solve(&mut x);
            solutions.push(x);
        }
        assert!(solutions[0].iter().all(|v| v.is_finite()));
        assert!(
            solutions[0] == solutions[1],
            "wide and baseline kernels differ"
        );
    }

    /// A matrix the blocks cannot factor is left to the scalar LU: singular (all zero), or
    /// not finite.
    #[test]
    fn unfactorable_blocks_are_refused() {
        let layout = Layout::new(Scheme::Ed, 1, 0, 1);
        let mut real = ed_matrix(&layout, 0.05, 7);
        let (col_ptr, row_idx) = real.pattern();
        let mut lu = PairedLu::new(&layout, col_ptr, row_idx);
        assert_eq!(lu.factor(&real.values), Some(false));
        real.values[0] = f64::NAN;
        assert_eq!(lu.factor(&real.values), None);
        real.clear();
        assert_eq!(lu.factor(&real.values), None);
    }
}
