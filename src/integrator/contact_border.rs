//! Kept factors with the sliding contacts' rows and columns refreshed at each step.
//!
//! A follower sliding along a beam moves its contact weights `h(ζ)` by a good part of a node
//! spacing per step (the free collar at 5 ms: ~15 %), so the kept factors of modified Newton
//! go stale in a sliding joint's rows and columns — its multipliers' columns, its constraint
//! and contact-coordinate rows — while the rest of the Newton matrix barely changes. Sliding
//! models therefore refactored at most steps (free collar 0.54 factorizations per step at
//! 5 ms, the paper's beam slider 0.78, the beam pendulum 0.02).
//!
//! The Newton matrix takes those unknowns as its border ([`NewtonMatrix::set_border`]: their
//! columns last, their rows pivots of those columns only); at the start of each step that
//! keeps the exact factors, only the kernels on them are evaluated, and the border's part of
//! the factors is recomputed from their rows and columns ([`NewtonMatrix::refresh_border`]):
//! the factors are then the exact LU of the kept leading block with the current border,
//! turned into the factors' frame where co-rotation turns them ([`CoRotation`]). The free
//! collar under EP: 0.54 → 0.015 factorizations per step at 5 ms and 4.8 → 2.2 iterations per
//! step at 1 ms (−34 % and −32 % instructions).
//!
//! EP only, for now. Under ED modified Newton mostly keeps the decoupled complex system's
//! factors, which this does not refresh; with the exact matrix's border refreshed, ED chose
//! those factors (they lasted), and paid more for their solves and for the sliding joint's
//! exact ED tangent at every step than the factorizations saved (free collar at 1 ms +11 %
//! instructions, beam slider +51 %). The decoupled system's border is the next step.

use super::corotation::{turn_triplet, CoRotation};
use super::positions::KernelPositions;
use super::{Factors, Integrator};
use crate::elements::{Kernel, StepCtx};
use crate::system::sparse::NewtonMatrix;
use crate::system::System;

/// The sliding contacts' unknowns as a border of the Newton matrix, and what refreshing it
/// needs (positions and scratch, allocated once per pattern).
pub struct ContactBorder {
    /// The border's unknowns, ascending.
    unknowns: Vec<usize>,
    /// Per kernel list (in `KernelPositions` order), the kernels on border unknowns.
    kernels: [Vec<usize>; 8],
    /// Value positions of the border's rows and columns.
    positions: Vec<usize>,
    /// Per border unknown: its column's `(row, value position)`, and its row's `(column,
    /// value position)` off the border's columns.
    columns: Vec<Vec<(usize, usize)>>,
    rows: Vec<Vec<(usize, usize)>>,
    /// Scratch: the kernels' residual, one dense vector per border column and row, and the
    /// turn restricted to the border.
    res: Vec<f64>,
    dense: Vec<Vec<f64>>,
    turn: Vec<Vec<f64>>,
    /// The unknowns the border's rows and columns have entries at (ascending), as a mask.
    touched: Vec<usize>,
    is_touched: Vec<bool>,
    mixed: Vec<usize>,
}

/// Whether a system's Newton matrix gets the border: modified Newton, EP, sliding joints.
pub fn applies(sys: &System, modified_newton: bool) -> bool {
    modified_newton && !sys.layout.ed() && sys.joints.iter().any(|j| j.as_sliding().is_some())
}

/// The sliding joints' multipliers and contact coordinates (under ED with their jump
/// unknowns), and the multipliers of drives prescribing those coordinates: without them a
/// drive's row and multiplier, coupled to the coordinate only, would leave the leading block
/// singular.
pub fn sliding_unknowns(sys: &System) -> Vec<usize> {
    let l = sys.layout;
    let mut out = Vec::new();
    for s in sys.joints.iter().filter_map(|j| j.as_sliding()) {
        for r in s.row0..s.row0 + s.n_rows() {
            out.push(l.mult(r));
            if l.ed() {
                out.push(l.mult_jump(r));
            }
        }
        out.push(l.coord_delta(s.coord));
        if l.ed() {
            out.push(l.coord_jump(s.coord));
        }
    }
    let contact_coord = |c: usize| {
        sys.joints
            .iter()
            .filter_map(|j| j.as_sliding())
            .any(|s| s.coord == c)
    };
    for d in sys.drives.iter().filter(|d| contact_coord(d.coord)) {
        out.extend(d.unknowns());
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// The kernels' block masks with every entry in a border row or column kept: the border
/// the kept factors need is the current one turned into their frame (`Dᵀ Z D`), whose
/// rotations fill a node's triplets (a contact force's x component acts on x rows only, until
/// turned).
pub fn open_border(blocks: &[&[usize]], masks: &[Vec<bool>], border: &[usize]) -> Vec<Vec<bool>> {
    let on = |g: &usize| border.binary_search(g).is_ok();
    blocks
        .iter()
        .zip(masks)
        .map(|(b, m)| {
            let n = b.len();
            let mut m = m.clone();
            for (i, gi) in b.iter().enumerate() {
                for (j, gj) in b.iter().enumerate() {
                    m[i * n + j] |= on(gi) || on(gj);
                }
            }
            m
        })
        .collect()
}

impl ContactBorder {
    /// The border of `matrix` (set by [`sliding_unknowns`]) with its positions; None for a
    /// system without sliding joints.
    pub fn new(sys: &System, matrix: &NewtonMatrix) -> Option<Self> {
        let unknowns = sliding_unknowns(sys);
        if unknowns.is_empty() {
            return None;
        }
        let on = |u: &[usize]| u.iter().any(|g| unknowns.binary_search(g).is_ok());
        let pick = |ks: &mut dyn Iterator<Item = &[usize]>| {
            ks.enumerate()
                .filter(|(_, u)| on(u))
                .map(|(i, _)| i)
                .collect()
        };
        let kernels = [
            pick(&mut sys.inertias.iter().map(|k| k.unknowns())),
            pick(&mut sys.beams.iter().map(|k| k.unknowns())),
            pick(&mut sys.joints.iter().map(|k| k.unknowns())),
            pick(&mut sys.springs.iter().map(|k| k.unknowns())),
            pick(&mut sys.drives.iter().map(|k| k.unknowns())),
            pick(&mut sys.frictions.iter().map(|k| k.unknowns())),
            pick(&mut sys.loads.iter().map(|k| k.unknowns())),
            pick(&mut sys.line_loads.iter().map(|k| k.unknowns())),
        ];
        let (col_ptr, row_idx) = matrix.pattern();
        let is_border = |i: usize| unknowns.binary_search(&i).is_ok();
        let columns: Vec<Vec<(usize, usize)>> = unknowns
            .iter()
            .map(|&c| {
                (col_ptr[c]..col_ptr[c + 1])
                    .map(|p| (row_idx[p], p))
                    .collect()
            })
            .collect();
        let mut rows = vec![Vec::new(); unknowns.len()];
        for (j, w) in col_ptr.windows(2).enumerate().filter(|(j, _)| !is_border(*j)) {
            for p in w[0]..w[1] {
                if let Ok(q) = unknowns.binary_search(&row_idx[p]) {
                    rows[q].push((j, p));
                }
            }
        }
        let n = col_ptr.len() - 1;
        let mut is_touched = vec![false; n];
        let entries = columns.iter().chain(&rows).flatten();
        for &(i, _) in entries {
            is_touched[i] = true;
        }
        let touched = (0..n).filter(|&i| is_touched[i]).collect();
        Some(ContactBorder {
            touched,
            is_touched,
            mixed: Vec::with_capacity(unknowns.len()),
            positions: matrix.border_positions(),
            dense: vec![vec![0.0; n]; 2 * unknowns.len()],
            turn: vec![vec![0.0; unknowns.len()]; unknowns.len()],
            res: vec![0.0; n],
            unknowns,
            kernels,
            columns,
            rows,
        })
    }
}

impl Integrator {
    /// At the start of a step that keeps the exact factors: the sliding contacts' rows and
    /// columns of the Newton matrix at the predicted iterate, and the factors' border
    /// refreshed from them. False if the factors cannot serve (a border pivot failed): the
    /// caller takes fresh ones. True, doing nothing, without a border to refresh.
    pub(super) fn refresh_contact_border(&mut self, sys: &System, ctx: &StepCtx) -> bool {
        let Some(b) = self.contact_border.as_mut() else {
            return true;
        };
        if self.factors != Factors::Exact || !self.matrix.border_ready() {
            return true;
        }
        let values = &mut self.matrix.values;
        for &p in &b.positions {
            values[p] = 0.0;
        }
        b.res.iter_mut().for_each(|r| *r = 0.0);
        evaluate_border_kernels(sys, ctx, &self.y, b, values, &self.pos);
        if self.corotation.is_turning() {
            turn_border(b, values, &self.corotation);
        }
        // The values now hold the border's entries only, over stale ones elsewhere.
        self.values_exact = false;
        self.matrix.refresh_border()
    }
}

/// The kernels on the border's unknowns, their tangents added into `values`.
fn evaluate_border_kernels(
    sys: &System,
    ctx: &StepCtx,
    y: &[f64],
    b: &mut ContactBorder,
    values: &mut [f64],
    pos: &KernelPositions,
) {
    macro_rules! run {
        ($k:expr, $list:expr, $pos:expr) => {
            for &i in &b.kernels[$k] {
                let jac = Some((&mut *values, &$pos[i][..]));
                Kernel::evaluate(&$list[i], ctx, y, &mut b.res, jac);
            }
        };
    }
    run!(0, sys.inertias, pos.inertia);
    run!(1, sys.beams, pos.beam);
    run!(2, sys.joints, pos.joint);
    run!(3, sys.springs, pos.spring);
    run!(4, sys.drives, pos.drive);
    run!(5, sys.frictions, pos.friction);
    run!(6, sys.loads, pos.load);
    run!(7, sys.line_loads, pos.line_load);
}

/// The border's rows and columns `Z` of the current matrix in the kept factors' frame: the
/// factors serve as `D J₀⁻¹ Dᵀ`, so the border they need is `Dᵀ Z D` (columns `Dᵀ X D_BB`,
/// rows transposed `Dᵀ Yᵀ D_BB`; `D_BB` turns the contact's own spatial rows). Dense
/// vectors, read and written at the border's entries only (zero elsewhere between calls).
fn turn_border(b: &mut ContactBorder, values: &mut [f64], c: &CoRotation) {
    let nb = b.unknowns.len();
    let (cols, rows) = b.dense.split_at_mut(nb);
    for (q, d) in cols.iter_mut().enumerate() {
        for &(i, p) in &b.columns[q] {
            d[i] = values[p];
        }
    }
    for (q, d) in rows.iter_mut().enumerate() {
        for &(j, p) in &b.rows[q] {
            d[j] = values[p];
        }
        // The border block, from the columns (the same entries).
        for (k, col) in cols.iter().enumerate() {
            d[b.unknowns[k]] = col[b.unknowns[q]];
        }
    }
    border_turn(&b.unknowns, c, &mut b.turn);
    for set in [&mut *cols, &mut *rows] {
        mix_columns(set, &b.turn, &b.touched, (&mut b.mixed, &mut b.res));
    }
    c.for_each_turn(|at, q| {
        if b.is_touched[at[0]] {
            for d in cols.iter_mut().chain(rows.iter_mut()) {
                turn_triplet(q, d, at, true);
            }
        }
    });
    for (q, d) in cols.iter().enumerate() {
        for &(i, p) in &b.columns[q] {
            values[p] = d[i];
        }
    }
    for (q, d) in rows.iter().enumerate() {
        for &(j, p) in &b.rows[q] {
            values[p] = d[j];
        }
    }
    for d in b.dense.iter_mut() {
        for &i in &b.touched {
            d[i] = 0.0;
        }
    }
}

/// `d[k][q] = D_BB[k][q]`: the turn `D` restricted to the border's unknowns (the identity
/// but for the turning triplets among them, a contact's spatial rows).
fn border_turn(unknowns: &[usize], c: &CoRotation, d: &mut [Vec<f64>]) {
    for (k, row) in d.iter_mut().enumerate() {
        for (q, v) in row.iter_mut().enumerate() {
            *v = f64::from(u8::from(k == q));
        }
    }
    let slot = |g: usize| unknowns.binary_search(&g).ok();
    c.for_each_turn(|at, q| {
        let [Some(a), Some(b), Some(c)] = at.map(slot) else {
            return;
        };
        let s = [a, b, c];
        for (i, &k) in s.iter().enumerate() {
            for (j, &l) in s.iter().enumerate() {
                d[k][l] = q.0[i][j];
            }
        }
    });
}

/// `set ← set · D_BB` (each vector of `set` a column) at the entries `at`. `D_BB` is the
/// identity but on the contact's turning triplets, so only their columns are recomputed, each
/// from the triplet's (`mixed`: the vectors `D_BB` mixes, `scratch` as long).
fn mix_columns(
    set: &mut [Vec<f64>],
    d_bb: &[Vec<f64>],
    at: &[usize],
    (mixed, scratch): (&mut Vec<usize>, &mut [f64]),
) {
    let nb = set.len();
    let unit = |q: usize| (0..nb).all(|k| d_bb[k][q] == f64::from(u8::from(k == q)));
    mixed.clear();
    mixed.extend((0..nb).filter(|&q| !unit(q)));
    for &i in at {
        for &q in mixed.iter() {
            scratch[q] = mixed.iter().map(|&k| set[k][i] * d_bb[k][q]).sum();
        }
        for &q in mixed.iter() {
            set[q][i] = scratch[q];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::layout::Scheme;
    use crate::model::{Model, StepControl};
    use crate::simulation::Simulation;
    use faer::prelude::Solve;
    use faer::Mat;

    fn example(name: &str) -> Model {
        let path = format!("{}/examples/{name}", env!("CARGO_MANIFEST_DIR"));
        crate::compile::from_yaml_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    }

    fn dense(m: &NewtonMatrix) -> Mat<f64> {
        let d = m.to_dense();
        Mat::from_fn(d.len(), d.len(), |i, j| d[i][j])
    }

    /// The co-rotation `D` as a matrix (its columns: `D e_j`).
    fn turning_matrix(c: &CoRotation, n: usize) -> Mat<f64> {
        let mut d = Mat::<f64>::zeros(n, n);
        let mut e = vec![0.0; n];
        for j in 0..n {
            e.iter_mut().for_each(|v| *v = 0.0);
            e[j] = 1.0;
            c.from_factored(&mut e);
            for (i, &v) in e.iter().enumerate() {
                d[(i, j)] = v;
            }
        }
        d
    }

    /// Kept factors of the tumbling free collar's Newton matrix `J₀`, a few steps on with the
    /// beam turned: the refreshed factors solve `D J₀ Dᵀ` with the sliding joint's rows and
    /// columns replaced by the current matrix's — the border turned into the factors' frame.
    #[test]
    fn refreshed_factors_solve_the_kept_matrix_with_the_current_border() {
        let mut model = example("free_collar.yaml");
        model.simulation.dt = 5e-3;
        let mut sim = Simulation::with_scheme(&model, Scheme::Ep).unwrap();
        sim.advance_to(0.3).unwrap();
        let (sys, h) = (&sim.system, sim.settings.dt);
        let mut integ = Integrator::new(sys, &sim.settings);
        let ctx = sim.ctx(h);
        integ.predict(sys, &sim.state, h);
        integ.assemble_for(sys, &ctx, Some(Factors::Exact));
        let j0 = dense(&integ.matrix);
        integ.factor_tangent(Factors::Exact).unwrap();
        integ.corotation.record(&sim.state, &integ.y);
        assert!(integ.matrix.border_ready());

        sim.advance_to(0.35).unwrap();
        let (sys, ctx) = (&sim.system, sim.ctx(h));
        integ.predict(sys, &sim.state, h);
        integ.corotation.follow(&sim.state, &integ.y);
        assert!(integ.corotation.is_turning());
        let n = integ.y.len();
        let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.61).sin()).collect();
        let kept_solve = |integ: &mut Integrator| {
            let mut x = b.clone();
            integ.corotation.to_factored(&mut x);
            integ.matrix.solve(&mut x);
            integ.corotation.from_factored(&mut x);
            x
        };
        let stale = kept_solve(&mut integ);
        assert!(integ.refresh_contact_border(sys, &ctx));
        let refreshed = kept_solve(&mut integ);

        let mut now = integ.sibling(sys, &sim.settings);
        now.y.copy_from_slice(&integ.y);
        now.assemble_for(sys, &ctx, Some(Factors::Exact));
        let j_now = dense(&now.matrix);
        let d = turning_matrix(&integ.corotation, n);
        let mut expected = &d * &j0 * d.transpose();
        for &u in &sliding_unknowns(sys) {
            for k in 0..n {
                expected[(u, k)] = j_now[(u, k)];
                expected[(k, u)] = j_now[(k, u)];
            }
        }
        let x = expected
            .partial_piv_lu()
            .solve(Mat::<f64>::from_fn(n, 1, |i, _| b[i]));
        let apart = |y: &[f64]| {
            let scale = (0..n).fold(0.0f64, |m, i| m.max(x[(i, 0)].abs()));
            (0..n).fold(0.0f64, |m, i| m.max((y[i] - x[(i, 0)]).abs())) / scale
        };
        // Two solves of the same matrix (dense and bordered sparse LU): round-off (3e-14
        // measured); the factors before the refresh miss by 1e-2, and so do refreshed ones
        // whose border is not turned (2e-3).
        assert!(apart(&refreshed) < 1e-10, "{:e}", apart(&refreshed));
        assert!(apart(&stale) > 1e-3, "{:e}", apart(&stale));
    }

    /// Sliding models keep their factors as others do under EP: fixed steps of the free
    /// collar (a collar sliding freely on a tumbling beam) and of the paper's beam slider
    /// (contact point driven along the beam). Before the border refresh the free collar
    /// refactored at 0.54 of its steps at 5 ms and the beam slider at 0.26 at 1 ms; now at
    /// 0.015 and 0.04 (the bounds leave room for round-off to move a refresh).
    #[test]
    fn sliding_contacts_keep_their_factors() {
        let cases = [
            ("free_collar.yaml", 5e-3, 0.5, 0.05),
            ("beam_slider/case1.yaml", 1e-3, 0.3, 0.1),
        ];
        for (file, h, t_end, bound) in cases {
            let mut model = example(file);
            model.simulation.dt = h;
            model.simulation.step_control = StepControl::Fixed;
            let mut sim = Simulation::with_scheme(&model, Scheme::Ep).unwrap();
            sim.advance_to(t_end).unwrap();
            let s = &sim.stats;
            let per_step = s.factorizations as f64 / s.steps as f64;
            assert!(
                per_step < bound,
                "{file}: {per_step} factorizations per step"
            );
            assert!(s.border_refreshes > s.steps / 2, "{file}: {s:?}");
        }
    }
}
