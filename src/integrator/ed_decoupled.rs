//! ED's Newton system solved as one complex system of EP's size.
//!
//! ED's unknowns come in pairs — increments Δ and jumps `X = h V_j` per motion, λ and λ_d per
//! constraint row — and so do its equations ([`Layout::pair`]). For a linear system (mass
//! `M`, stiffness `K`, constant constraint gradient `B`, multipliers scaled by `s`) the Newton
//! matrix is, in the pairs' 2 × 2 structure (ed-scheme-notes §3.3, the rows as assembled: f-
//! and j-rows divided by h, the j-condition `s h (B_i V_j − B_f V_f)`),
//!
//! ```text
//!            Δ              X               λ       λ_d
//!   f  [ 2M/h² + K/3   −M/h² + K/6        sBᵀ       0     ]
//!   j  [   −2K/9        M/h² + K/18        0     −sBᵀ/6   ]
//!   C  [     sB              0             0        0     ]
//!   Cj [   −2sB             2sB            0        0     ]
//! ```
//!
//! that is `P⊗M/h² + Q⊗K` bordered by `D⊗sBᵀ` and `E⊗sB`, with P = [[2, −1], [0, 1]],
//! Q = [[1/3, 1/6], [−2/9, 1/18]]. `P⁻¹Q` has the eigenvalues `μ, μ̄ = 1/18 ± i√2/9` with
//! eigenvectors `(1, ±i√2)`; changing variables along them (and the multipliers along
//! `D⁻¹P·(1, ±i√2)`, the constraint rows by `(E·V)⁻¹`) splits the system into two complex
//! conjugate systems `[[M/h² + μK, sBᵀ], [sB, 0]]`. A real right-hand side gives conjugate
//! solutions, so one complex solve of EP's size gives the whole update:
//!
//! - right-hand side per motion pair `g = r_f/4 + (1/4 − i/(2√2)) r_j`, per row pair
//!   `g = (1/2 − i/(2√2)) r_C − i/(4√2) r_Cj`;
//! - update per motion pair `Δ = 2 Re z`, `X = −2√2 Im z`; per row pair
//!   `λ = 2(2 Re w + √2 Im w)`, `λ_d = 12√2 Im w`.
//!
//! The complex matrix comes from the assembled ED tangent itself: `M/h² + μK` is
//! `J_jX − i(√2/2) J_jΔ` (the j-rows), `sBᵀ` the f-rows' λ columns, `sB` the C rows' Δ columns.
//! For a linear system the complex solve *is* the Newton update; otherwise it approximates
//! it (the j-rows' geometric and gyroscopic terms stand for the f-rows'), which modified
//! Newton tolerates like any kept factor. The residual is ED's unchanged, so a converged
//! step has ED's exact energy identity whichever matrix led there. One complex LU of EP's
//! size costs ~⅓ of the real LU of ED's size and a solve about half (12-element beam
//! pendulum: complex 225-unknown solve 6.4 µs against the real 450-unknown 13.7 µs).
//!
//! What bounds the approximation was measured (docs/validation.md, session 46). The
//! decoupled iteration's linear rate is the spectral radius of `A⁻¹(J − A)`, where `A` is the
//! real matrix this system inverts. It grows with the rotation over a step: 1.3e-3 at 1 ms and
//! 2.4e-2 at 5 ms on the beam pendulum. The cause is the f-rows: their jump columns are not in
//! the template's ratio to their increment columns, and `P`, `Q` cannot express that. A
//! sliding joint adds its velocity rows, whose gradients drift from its position rows' over the
//! step. The surrogate is not the cause: `A` formed from the exact j-rows contracts alike. No
//! choice of the common `K` lowers the rate either.

use super::positions::KernelPositions;
use crate::math::layout::Layout;
use crate::system::sparse::{compress_columns, NewtonMatrix};
use faer::c64;

const SQRT2: f64 = std::f64::consts::SQRT_2;

/// Where a real ED tangent entry goes in the complex matrix's values (seen as `f64`s:
/// real, imaginary, real, …).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Part {
    /// Coefficient 1: the real part.
    Real,
    /// Coefficient `−i√2/2` (`J_jΔ`): summed into the imaginary part, scaled when formed.
    Imaginary,
    /// `(2 − i√2) α`: a row pair's own multipliers' α, in the real part until formed.
    OwnMultipliers,
}

/// The decoupled system and the kernels' block positions in its values: under modified
/// Newton the kernels assemble ED's tangent rows straight into the complex matrix (the
/// entries it does not read go to a discard slot), not into the real ED matrix that would
/// then be cleared, gathered from and cleared again.
pub struct DecoupledSystem {
    pub matrix: DecoupledMatrix,
    pub pos: KernelPositions,
}

impl DecoupledSystem {
    /// For the real ED tangent `real` whose kernel blocks are at `real_pos`; the pairs of
    /// `border` (ED unknowns) are the complex matrix's border (see `contact_border`).
    pub fn new(
        layout: Layout,
        real: &NewtonMatrix,
        real_pos: &KernelPositions,
        border: &[usize],
    ) -> Self {
        let (col_ptr, row_idx) = real.pattern();
        let mut matrix = DecoupledMatrix::new(layout, col_ptr, row_idx);
        let pairs: Vec<usize> = border.iter().map(|&u| layout.pair(u).0).collect();
        matrix.matrix.set_border(&pairs);
        let pos = real_pos.map(|p| matrix.slots[p]);
        DecoupledSystem { matrix, pos }
    }
}

pub struct DecoupledMatrix {
    matrix: NewtonMatrix<c64>,
    /// Per position of the real ED tangent (its trailing out-of-pattern slot included): the
    /// `f64` slot of the complex values it adds into — [`Self::discard`] for the entries the
    /// complex system does not read, [`Self::outside`] for the real pattern's own dump.
    slots: Vec<usize>,
    /// Complex positions of the row pairs' own multipliers' diagonals ([`Part::OwnMultipliers`]).
    own_multipliers: Vec<usize>,
    /// Whether the values assembled were turned into the complex matrix.
    formed: bool,
    /// Per pair: its two real unknowns and whether they are multipliers (`Layout::unpair`,
    /// `Layout::pair_is_multiplier`, looked up once).
    pairs: Vec<(usize, usize, bool)>,
}

/// The complex entry (row pair, column pair) that real ED tangent entry (row `i`, column
/// `j`) enters, and how; None if it does not.
fn coefficient(layout: &Layout, i: usize, j: usize) -> Option<(usize, usize, Part)> {
    let (pi, i_second) = layout.pair(i);
    let (pj, j_second) = layout.pair(j);
    let row_mult = layout.pair_is_multiplier(pi);
    let col_mult = layout.pair_is_multiplier(pj);
    let part = match (row_mult, col_mult, i_second, j_second) {
        // Motion rows, motion columns: J_jX − i(√2/2) J_jΔ.
        (false, false, true, true) => Part::Real,
        (false, false, true, false) => Part::Imaginary,
        // A row pair that sets its own multipliers — `[[α, 0], [0, −α]]` on (λ, λ_d), a
        // slipping friction's force — is `(2 − i√2) α` in the complex system; read from its
        // C-row (the Cj-row's −α is implied).
        (true, true, false, false) if pi == pj => Part::OwnMultipliers,
        (true, true, _, _) => return None,
        // The f-rows' λ columns (sBᵀ) and the C rows' Δ columns (sB).
        (false, true, false, false) | (true, _, false, false) => Part::Real,
        _ => return None,
    };
    Some((pi, pj, part))
}

impl DecoupledMatrix {
    /// The complex matrix's pattern and each real entry's slot in it, from the real ED
    /// tangent's pattern (rows sorted in each column).
    pub fn new(layout: Layout, col_ptr: &[usize], row_idx: &[usize]) -> Self {
        let np = layout.n_pairs();
        // Room for every real entry of a pair's two columns, so no vector grows.
        let mut room = vec![1usize; np];
        for j in 0..col_ptr.len() - 1 {
            room[layout.pair(j).0] += col_ptr[j + 1] - col_ptr[j];
        }
        let mut cols: Vec<Vec<usize>> = room
            .into_iter()
            .enumerate()
            .map(|(p, room)| {
                let mut col = Vec::with_capacity(room);
                col.push(p);
                col
            })
            .collect();
        let mut sources = Vec::with_capacity(row_idx.len());
        for j in 0..col_ptr.len() - 1 {
            for (p, &i) in row_idx
                .iter()
                .enumerate()
                .take(col_ptr[j + 1])
                .skip(col_ptr[j])
            {
                if let Some((pi, pj, part)) = coefficient(&layout, i, j) {
                    cols[pj].push(pi);
                    sources.push((pi, pj, p, part));
                }
            }
        }
        let (c_ptr, c_rows) = compress_columns(&mut cols);
        let nnz = c_rows.len();
        let real_nnz = row_idx.len();
        // The trailing complex slot, which the factorization never reads: its real part
        // discards, its imaginary part receives what falls outside the real pattern.
        let mut slots = vec![2 * nnz; real_nnz + 1];
        slots[real_nnz] = 2 * nnz + 1;
        let mut own_multipliers = Vec::new();
        for (pi, pj, p, part) in sources {
            let col = &c_rows[c_ptr[pj]..c_ptr[pj + 1]];
            let at = c_ptr[pj] + col.binary_search(&pi).expect("entry in pattern");
            slots[p] = 2 * at + (part == Part::Imaginary) as usize;
            if part == Part::OwnMultipliers {
                own_multipliers.push(at);
            }
        }
        let pairs = (0..np)
            .map(|p| {
                let (a, b) = layout.unpair(p);
                (a, b, layout.pair_is_multiplier(p))
            })
            .collect();
        DecoupledMatrix {
            matrix: NewtonMatrix::from_pattern(np, c_ptr, c_rows),
            slots,
            own_multipliers,
            formed: false,
            pairs,
        }
    }

    /// Factorizations that chose their pivots (the others reused an earlier one's).
    pub fn pivoting_factorizations(&self) -> usize {
        self.matrix.numeric_factorizations - self.matrix.refactorizations
    }

    /// [`Self::pivoting_factorizations`], the counts then cleared: the matrix is kept for
    /// its pattern's return (`kept_patterns`), its work already counted.
    pub fn retire_counts(&mut self) -> usize {
        let pivoting = self.pivoting_factorizations();
        self.matrix.numeric_factorizations = 0;
        self.matrix.refactorizations = 0;
        pivoting
    }

    /// The values cleared for the kernels to add ED's tangent entries into, at their
    /// [`DecoupledSystem::pos`] (as `f64`s; see [`Part`]).
    pub fn start_assembly(&mut self) -> &mut [f64] {
        self.matrix.clear();
        self.formed = false;
        bytemuck::cast_slice_mut(&mut self.matrix.values[..])
    }

    /// Whether kernels wrote more than `tolerance` times the largest entry outside the real
    /// ED pattern since [`Self::start_assembly`] (as [`NewtonMatrix::wrote_outside`]).
    pub fn wrote_outside(&self, tolerance: f64) -> bool {
        let values = &self.matrix.values;
        let dump = values[values.len() - 1].im.abs();
        self.matrix.exceeds_entries(dump, tolerance)
    }

    /// Turns the assembled sums into the complex matrix (once per assembly) and factors it.
    pub fn factor(&mut self) -> Result<(), String> {
        if !self.formed {
            let values = &mut self.matrix.values;
            for v in values.iter_mut() {
                v.im *= -0.5 * SQRT2;
            }
            for &at in &self.own_multipliers {
                let alpha = values[at].re;
                values[at] = c64::new(2.0, -SQRT2) * alpha;
            }
            self.formed = true;
        }
        self.matrix.factor()
    }

    /// The complex matrix (its pattern and border).
    pub fn inner(&self) -> &NewtonMatrix<c64> {
        &self.matrix
    }

    /// The complex values as assembled, for a border refresh (see `contact_border`).
    pub fn values_mut(&mut self) -> &mut [c64] {
        &mut self.matrix.values
    }

    /// Turns the sums assembled at value `positions` into the complex matrix's entries (as
    /// [`Self::factor`] does for all of them).
    pub fn form(&mut self, positions: &[usize]) {
        let values = &mut self.matrix.values;
        for &p in positions {
            values[p].im *= -0.5 * SQRT2;
        }
        for &at in &self.own_multipliers {
            if positions.binary_search(&at).is_ok() {
                values[at] = c64::new(2.0, -SQRT2) * values[at].re;
            }
        }
    }

    /// Refactors the border's part of the factors from its formed values (see
    /// [`NewtonMatrix::refresh_border`]).
    pub fn refresh_border(&mut self) -> bool {
        self.matrix.refresh_border()
    }

    /// Factors the complex matrix of a real ED tangent's `values` (tests: the map of every
    /// real entry that [`DecoupledSystem::pos`] assembles through).
    #[cfg(test)]
    fn factor_real(&mut self, values: &[f64]) -> Result<(), String> {
        let slots = std::mem::take(&mut self.slots);
        let parts = self.start_assembly();
        for (&slot, v) in slots.iter().zip(values) {
            parts[slot] += v;
        }
        self.slots = slots;
        self.factor()
    }

    /// Replaces the ED residual `res` by the update the complex factors give (see the module
    /// notes; the exact Newton update for a linear system). The pairs' mixing into the
    /// complex right-hand side and out of its solution happen in the solve's permutations.
    pub fn solve(&mut self, res: &mut [f64]) {
        let pairs = &self.pairs;
        let load = |res: &[f64], p: usize| {
            let (a, b, multiplier) = pairs[p];
            let (first, second) = (res[a], res[b]);
            if multiplier {
                c64::new(0.5 * first, -(0.5 * first + 0.25 * second) / SQRT2)
            } else {
                c64::new(0.25 * (first + second), -0.5 * second / SQRT2)
            }
        };
        let store = |res: &mut [f64], p: usize, z: c64| {
            let (a, b, multiplier) = pairs[p];
            if multiplier {
                res[a] = 2.0 * (2.0 * z.re + SQRT2 * z.im);
                res[b] = 12.0 * SQRT2 * z.im;
            } else {
                res[a] = 2.0 * z.re;
                res[b] = -2.0 * SQRT2 * z.im;
            }
        };
        self.matrix.solve_mapped(res, load, store);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::layout::Scheme;

    /// A linear system's ED Newton matrix (module notes) for mass `m`, stiffness `k` over
    /// the motion pairs and constraint gradient `b`: the decoupled solve is its exact solve.
    #[test]
    fn decoupled_solve_is_the_exact_solve_of_a_linear_system() {
        // Rows 0 and 1 are constraints; row 2 a pair that sets its own multipliers (a
        // slipping friction: `s λ = …`, `−s λ_d = 0`) whose force acts like a constraint's.
        let layout = Layout::new(Scheme::Ed, 2, 1, 3);
        let n = layout.n_unknowns();
        let nm = 13; // motion pairs: 12 node components and one coordinate (massless)
        let pseudo = |k: usize| ((k as f64 * 12.9898).sin() * 43758.5453).fract();
        let (h, s) = (0.01, 1e4);
        let mut m = vec![vec![0.0; nm]; nm];
        let mut k = vec![vec![0.0; nm]; nm];
        for i in 0..nm {
            for j in 0..nm {
                let a = pseudo(i * nm + j) + pseudo(j * nm + i);
                k[i][j] = 1e3 * a + if i == j { 5e3 } else { 0.0 };
                if i < 12 && j < 12 {
                    m[i][j] = 0.1 * a + if i == j { 2.0 } else { 0.0 };
                }
            }
        }
        let b: Vec<Vec<f64>> = (0..3)
            .map(|r| (0..nm).map(|j| pseudo(500 + 20 * r + j)).collect())
            .collect();
        let all: Vec<usize> = (0..n).collect();
        let (mut real, pos) = NewtonMatrix::<f64>::from_blocks(n, &[&all], None);
        let mut set = |i: usize, j: usize, v: f64| real.values[pos[0][i * n + j] as usize] = v;
        for a in 0..nm {
            let (fa, ja) = layout.unpair(a);
            for c in 0..nm {
                let (dc, xc) = layout.unpair(c);
                let (mh, kk) = (m[a][c] / (h * h), k[a][c]);
                set(fa, dc, 2.0 * mh + kk / 3.0);
                set(fa, xc, -mh + kk / 6.0);
                set(ja, dc, -2.0 * kk / 9.0);
                set(ja, xc, mh + kk / 18.0);
            }
            for (r, br) in b.iter().enumerate() {
                let (lam, lam_d) = layout.unpair(nm + r);
                set(fa, lam, s * br[a]);
                set(ja, lam_d, -s * br[a] / 6.0);
                if r == 2 {
                    set(lam, lam, s);
                    set(lam_d, lam_d, -s);
                    continue;
                }
                let (dc, xc) = layout.unpair(a);
                set(lam, dc, s * br[a]);
                set(lam_d, dc, -2.0 * s * br[a]);
                set(lam_d, xc, 2.0 * s * br[a]);
            }
        }
        let rhs: Vec<f64> = (0..n).map(|i| pseudo(900 + i) * 10.0).collect();
        let mut exact = rhs.clone();
        real.factor().unwrap();
        real.solve(&mut exact);
        let (col_ptr, row_idx) = real.pattern();
        let mut dec = DecoupledMatrix::new(layout, col_ptr, row_idx);
        dec.factor_real(&real.values).unwrap();
        let mut split = rhs.clone();
        dec.solve(&mut split);
        let scale = exact.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        for i in 0..n {
            // Two LUs of a matrix with entries from 1 to 1e5: agreement to round-off.
            assert!(
                (exact[i] - split[i]).abs() <= 1e-10 * scale,
                "unknown {i}: exact {} decoupled {}",
                exact[i],
                split[i]
            );
        }
    }

    /// The kernels' ED tangent has the structure the decoupling assumes: for a model at rest
    /// (straight unstressed beam, no spin, constraint gradients constant over the step, no
    /// constraint forces yet) the tangent is that of a linear system, and the decoupled update
    /// — from the rows modified Newton assembles for it, the beams' from their EP stiffness,
    /// the joints' from EP's equations — equals the exact Newton update. A kernel whose j-rows
    /// were scaled otherwise than the f-rows' template, a beam or joint surrogate off its
    /// factor, or a transform coefficient off would break the equality. Models: the beam
    /// pendulum (a spherical pin) and a collar at rest on a free beam (a sliding joint).
    #[test]
    fn kernels_have_the_decoupled_structure_at_rest() {
        let pendulum = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/beam_pendulum.yaml"
        ))
        .unwrap();
        let collar = crate::testing::collar_on_free_beam_yaml(0.5417);
        for text in [pendulum.as_str(), collar.as_str()] {
            decoupled_update_is_exact_at_rest(text);
        }
    }

    /// In motion the decoupled system approximates ED's Newton matrix (module notes): ED's
    /// stiff terms use `B_i`, `B_f` and `B^D`, which the step's rotation sets apart, the
    /// increments' Cayley tangent enters their columns but not the jumps', and a rigid
    /// rotation's gyroscopic terms sit in the f-rows only. One decoupled update from the
    /// predictor must still cut the residual (in units of its tolerances) about as well as
    /// kept factors do. The 12-element beam pendulum swinging at 0.5 s: measured 5.1e-5 at
    /// 1 ms and 5.4e-3 at 5 ms (the exact matrix's update, quadratic: 1.5e-7 and 4.4e-5).
    /// The bounds, ~2.3× those, fail for a beam surrogate whose stiffness leaves out the
    /// step's increments (1.8e-4 and 1.6e-2); a stiffness off by a factor the test at rest
    /// catches (`kernels_have_the_decoupled_structure_at_rest`).
    #[test]
    fn decoupled_update_contracts_in_motion() {
        use crate::integrator::Factors;
        for (h, bound) in [(1e-3, 1.2e-4), (5e-3, 1.2e-2)] {
            let decoupled = first_update_contraction(h, Factors::Decoupled);
            let exact = first_update_contraction(h, Factors::Exact);
            assert!(
                decoupled <= bound,
                "h = {h}: decoupled update contracts by {decoupled:.3e}"
            );
            assert!(
                exact < 0.1 * decoupled,
                "h = {h}: exact {exact:.3e} vs {decoupled:.3e}"
            );
        }
    }

    /// The residual's distance to convergence after one update with fresh `factors` from the
    /// predictor, over the distance before it: the beam pendulum (ED, fixed steps of `h`)
    /// at 0.5 s.
    fn first_update_contraction(h: f64, factors: crate::integrator::Factors) -> f64 {
        use crate::integrator::convergence::Measure;
        use crate::integrator::Integrator;
        use crate::model::StepControl;
        use crate::simulation::Simulation;
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/examples/beam_pendulum.yaml"
        ))
        .unwrap();
        let mut model = crate::compile::from_yaml_str(&text).unwrap();
        model.simulation.dt = h;
        model.simulation.step_control = StepControl::Fixed;
        let mut sim = Simulation::with_scheme(&model, Scheme::Ed).unwrap();
        sim.advance_to(0.5).unwrap();
        let sys = &sim.system;
        let mut integ = Integrator::new(sys, &sim.settings);
        let ctx = sim.ctx(h);
        integ.predict(sys, &sim.state, h);
        let distance = |integ: &Integrator| {
            Measure::of(sys, &ctx, &integ.res, &integ.activity).distance(sys, integ.tol)
        };
        integ.assemble_for(sys, &ctx, Some(factors));
        let before = distance(&integ);
        integ.factor_tangent(factors).unwrap();
        integ.back_substitute();
        integ.assemble_for(sys, &ctx, None);
        distance(&integ) / before
    }

    fn decoupled_update_is_exact_at_rest(text: &str) {
        use crate::integrator::Integrator;
        let h = 1e-3;
        let (sys, mut integ) = crate::integrator::tests::predicted_start(text, Scheme::Ed, h);
        let ctx = Integrator::step_ctx(&sys, &sys.initial, h);
        // The rows the decoupled system reads, as modified Newton assembles them (the beams'
        // from their EP stiffness, straight into the complex matrix), then the exact tangent.
        let decoupled = crate::integrator::Factors::Decoupled;
        integ.assemble_for(&sys, &ctx, Some(decoupled));
        integ.factor_tangent(decoupled).unwrap();
        integ.solve_residual();
        let split = integ.res.clone();
        assert_eq!(
            integ.pattern_misses, 0,
            "decoupled entries outside the pattern"
        );
        integ.assemble(&sys, &ctx, true);
        let mut exact = integ.res.clone();
        integ.matrix.factor().unwrap();
        integ.matrix.solve(&mut exact);
        let scale = exact.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(scale > 0.0);
        for (i, (e, d)) in exact.iter().zip(&split).enumerate() {
            // Round-off of two LUs (the matrix spans m/h² ~ 1e6 to EA/L ~ 1e8).
            assert!(
                (e - d).abs() <= 1e-8 * scale,
                "{}: exact {e:.6e}, decoupled {d:.6e}",
                sys.describe_row(i)
            );
        }
    }
}
