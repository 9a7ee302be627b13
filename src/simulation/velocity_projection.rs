//! The KKT system of a velocity projection at one configuration:
//! `min ½ VᵀHV − VᵀH V₀` subject to `B V + ∂C/∂t = 0`, i.e. `[H Bᵀ; B 0] [V; −λ] = [H V₀; −∂C/∂t]`,
//! with `H` the kinetic-energy weights plus, optionally, the beams' strain-rate stiffness
//! (so beams follow their supports rather than staying behind), and some nodes' velocities
//! held as they are. Factored once; several right-hand sides.

use crate::beam::section::Mat6;
use crate::joints::RateTerm;
use crate::math::layout::Layout;
use crate::math::vec3::{M3, V3};
use crate::model::Scheme;
use crate::state::State;
use crate::system::sparse::NewtonMatrix;
use crate::system::{BeamInfo, System};

/// Per node: a flag for its translation and one for its rotation.
pub(super) type Parts = [bool; 2];

/// How a projection weighs the nodes' translations and rotations.
pub(super) struct Weighting<'a> {
    /// Parts whose velocities are held as they are in the state (already projected).
    pub fixed: &'a [Parts],
    /// Parts that follow the others: 1e-6 of their kinetic energy, a weight the refinement
    /// then removes (a proximal iteration), so they take whatever the others impose.
    pub follow: &'a [Parts],
    /// Whether the beams' strain rates are penalised, weighted to dominate their kinetic
    /// energy: beams then move rigidly with their supports, or quasi-statically where the
    /// supports strain them, instead of lagging at rest behind them.
    pub beams: bool,
}

/// The factored, regularised matrix `[H Bᵀ; B −δI]` and what its refinement needs. `δ`
/// keeps rows that held nodes leave empty or dependent solvable; iterative refinement
/// against the unregularised matrix removes it, with the followers' and the coordinate
/// rates' weights.
pub(super) struct VelocityProjection {
    pub lay: Layout,
    /// Unknowns: the layout's, then six strain-rate stresses per beam Gauss point.
    pub n: usize,
    matrix: NewtonMatrix,
    /// The matrix without regularisation nor proximal weights: one triangle, diagonal once.
    entries: Vec<(usize, usize, f64)>,
    /// Weights of followers and coordinate rates (in the factor only).
    proximal: Vec<(usize, usize, f64)>,
    /// `(free row, held column, value)`: couplings to held velocities, moved to the
    /// right-hand side.
    eliminated: Vec<(usize, usize, f64)>,
    /// Per node: the translational and rotational weights (mass, material inertia).
    pub mass: Vec<f64>,
    pub inertia: Vec<M3<f64>>,
    fixed: Vec<Parts>,
    follow: Vec<Parts>,
}

/// Refinement stops when a correction is below this, relative to the solution.
const REFINED: f64 = 1e-14;
const MAX_REFINEMENTS: usize = 12;

impl VelocityProjection {
    /// Builds and factors the projection at `state`; `None` when the matrix is singular or
    /// there is nothing to project (no constraints, no beams).
    pub fn new(sys: &System, state: &State, w: &Weighting) -> Option<Self> {
        let l = sys.layout;
        if l.n_rows == 0 && (!w.beams || sys.beams.is_empty()) {
            return None;
        }
        let lay = Layout::new(Scheme::Ep, l.n_nodes, l.n_coords, l.n_rows);
        let (mass, inertia) = weights(sys, w.follow);
        let mut p = VelocityProjection {
            lay,
            n: lay.n_unknowns(),
            matrix: NewtonMatrix::from_blocks(0, &[], None).0,
            entries: Vec::new(),
            proximal: Vec::new(),
            eliminated: Vec::new(),
            mass,
            inertia,
            fixed: w.fixed.to_vec(),
            follow: w.follow.to_vec(),
        };
        p.add_weights(sys, w.follow);
        if w.beams {
            for info in &sys.beam_info {
                p.add_beam(sys, info, state);
            }
        }
        p.add_constraints(sys, state);
        let delta = 1e-12 / sys.mass_ref.max(f64::MIN_POSITIVE);
        let mut factored = p.entries.clone();
        factored.extend_from_slice(&p.proximal);
        factored.extend((0..l.n_rows).map(|r| (lay.mult(r), lay.mult(r), -delta)));
        p.matrix = symmetric_matrix(p.n, &factored)?;
        Some(p)
    }

    /// Adds `H[i][j] = v` (and its mirror): kept between free unknowns, moved to the
    /// right-hand side where one side is held, dropped where both are.
    fn add(&mut self, i: usize, j: usize, v: f64) {
        match (self.held(i), self.held(j)) {
            (false, false) => self.entries.push((i, j, v)),
            (false, true) => self.eliminated.push((i, j, v)),
            (true, false) => self.eliminated.push((j, i, v)),
            (true, true) => {}
        }
    }

    /// Whether unknown `i` is a held node part's velocity.
    fn held(&self, i: usize) -> bool {
        i < self.lay.n_nodes * 6 && self.fixed[i / 6][(i % 6) / 3]
    }

    /// Kinetic-energy weights (identity rows for held parts), and the coordinate rates'
    /// negligible weight (relative coordinates take up what the nodes do not).
    fn add_weights(&mut self, sys: &System, follow: &[Parts]) {
        let lay = self.lay;
        for (a, parts) in follow.iter().enumerate() {
            for (part, &follows) in parts.iter().enumerate() {
                let d = lay.node_delta(a) + 3 * part;
                if self.fixed[a][part] {
                    self.entries.extend((0..3).map(|k| (d + k, d + k, 1.0)));
                    continue;
                }
                let to = if follows {
                    &mut self.proximal
                } else {
                    &mut self.entries
                };
                for k in 0..3 {
                    if part == 0 {
                        to.push((d + k, d + k, self.mass[a]));
                    } else {
                        to.extend((k..3).map(|m| (d + k, d + m, self.inertia[a].0[k][m])));
                    }
                }
            }
        }
        let coord_weight = 1e-14 * sys.mass_ref * sys.length_ref.powi(2);
        for c in 0..lay.n_coords {
            let d = lay.coord_delta(c);
            self.proximal.push((d, d, coord_weight));
        }
    }

    /// A beam's strain rates, penalised by `½ τ² ∫ ε̇ᵀ C ε̇ ds` in mixed form: per Gauss
    /// point six unknowns `σ = τ² w C ε̇` with rows `B_g V − (τ² w C)⁻¹ σ = 0` (as `τ → ∞`,
    /// the constraint `ε̇ = 0`; the mixed form stays well conditioned however large `τ`).
    /// `τ` is 1e6 times the period scale `1/ω` of the beam's first bending mode
    /// (pinned–pinned, `(π/L)² √(EI/m)`): over its kinetic energy the penalty weighs ~1e12 in
    /// that mode (~1e11 for a cantilever), so a start leaves ~1e-11 of the strain rates of a
    /// beam left at rest.
    fn add_beam(&mut self, sys: &System, info: &BeamInfo, state: &State) {
        let Some(omega) = first_mode(sys, info) else {
            return;
        };
        let tau2 = (1e6 / omega).powi(2);
        for el in &sys.beams[info.first..info.first + info.count] {
            let lay = self.lay;
            let global = |c: usize| lay.node_delta(el.nodes[c / 6]) + c % 6;
            for (g, columns) in el.strain_rate_operators(state).iter().enumerate() {
                let point = &el.points[g];
                let Some(compliance) = inverse6(&point.stiffness) else {
                    continue;
                };
                let row = self.n;
                self.n += 6;
                for (c, column) in columns.iter().enumerate() {
                    for (r, &value) in column.iter().enumerate() {
                        if value != 0.0 {
                            self.add(row + r, global(c), value);
                        }
                    }
                }
                let scale = -1.0 / (tau2 * point.weight);
                for (r, line) in compliance.iter().enumerate() {
                    for (q, &c) in line.iter().enumerate().skip(r) {
                        self.entries.push((row + r, row + q, scale * c));
                    }
                }
            }
        }
    }

    /// The joints' velocity-level rows and the drives' rows.
    fn add_constraints(&mut self, sys: &System, state: &State) {
        let lay = self.lay;
        for j in &sys.joints {
            let mut terms = Vec::new();
            j.rate_terms(state, &mut terms);
            for (r, term) in terms {
                let row = lay.mult(j.row0() + r);
                match term {
                    RateTerm::Node { node, v, omega } => {
                        let d = lay.node_delta(node);
                        // Material angular velocity: B_W = B_ω R.
                        let bw = state.nodes[node].r.tmul_v(&omega);
                        for c in 0..3 {
                            self.add(row, d + c, v.0[c]);
                            self.add(row, d + 3 + c, bw.0[c]);
                        }
                    }
                    RateTerm::Coord { coord, value } => {
                        self.add(row, lay.coord_delta(coord), value);
                    }
                }
            }
        }
        for d in &sys.drives {
            self.add(lay.mult(d.row), lay.coord_delta(d.coord), 1.0);
        }
        // A sticking joint's friction holds its slip like a drive at rest.
        for f in &sys.frictions {
            if let crate::joints::friction::Mode::Stick { .. } = f.mode(state) {
                let (_, rates) = f.stick_gradient(state);
                for (&c, &b) in f.coords().iter().zip(&rates) {
                    self.add(lay.mult(f.row), lay.coord_delta(c), b);
                }
            }
        }
    }

    /// The rows' velocity-level values `B V` at `state`'s velocities, per constraint row.
    pub fn rows_at(&self, state: &State) -> Vec<f64> {
        let lay = self.lay;
        let mut x = vec![0.0; self.n];
        for (a, n) in state.nodes.iter().enumerate() {
            n.v.write_to(&mut x[lay.node_delta(a)..]);
            n.w.write_to(&mut x[lay.node_delta(a) + 3..]);
        }
        for (c, &r) in state.coord_rates.iter().enumerate() {
            x[lay.coord_delta(c)] = r;
        }
        let first_row = lay.mult(0);
        let mut rows = vec![0.0; lay.n_rows];
        for &(i, j, v) in self.entries.iter().chain(&self.eliminated) {
            if i >= first_row && j < first_row {
                rows[i - first_row] += v * x[j];
            }
        }
        rows
    }

    /// The right-hand side for target velocities `state`'s (held ones kept, followers'
    /// ignored) and the drives' rates at `t`.
    pub fn rhs(&self, sys: &System, state: &State, t: f64) -> Vec<f64> {
        let lay = self.lay;
        let mut velocities = vec![0.0; self.n];
        for (a, n) in state.nodes.iter().enumerate() {
            let d = lay.node_delta(a);
            n.v.write_to(&mut velocities[d..]);
            n.w.write_to(&mut velocities[d + 3..]);
        }
        let mut rhs = vec![0.0; self.n];
        for (a, n) in state.nodes.iter().enumerate() {
            let d = lay.node_delta(a);
            let weighted = [n.v.scale_f(self.mass[a]), self.inertia[a].mul_v(&n.w)];
            for (part, w) in weighted.iter().enumerate() {
                let d = d + 3 * part;
                if self.fixed[a][part] {
                    rhs[d..d + 3].copy_from_slice(&velocities[d..d + 3]);
                } else if !self.follow[a][part] {
                    w.write_to(&mut rhs[d..]);
                }
            }
        }
        for &(i, j, v) in &self.eliminated {
            rhs[i] -= v * velocities[j];
        }
        for d in &sys.drives {
            rhs[lay.mult(d.row)] = d.target_rate(t);
        }
        rhs
    }

    /// Solves for `rhs`, refined against the matrix without regularisation nor proximal
    /// weights: `x ← x + A_δ⁻¹ (b − A x)` until the correction is round-off.
    pub fn solve(&mut self, rhs: &[f64]) -> Vec<f64> {
        let mut x = rhs.to_vec();
        self.matrix.solve(&mut x);
        for _ in 0..MAX_REFINEMENTS {
            let mut r = rhs.to_vec();
            for &(i, j, v) in &self.entries {
                r[i] -= v * x[j];
                if i != j {
                    r[j] -= v * x[i];
                }
            }
            self.matrix.solve(&mut r);
            let size = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let step = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            x.iter_mut().zip(&r).for_each(|(x, r)| *x += r);
            if step <= REFINED * size {
                break;
            }
        }
        x
    }

    /// Node `a`'s velocity and material angular velocity in a solution.
    pub fn node(&self, x: &[f64], a: usize) -> (V3<f64>, V3<f64>) {
        let d = self.lay.node_delta(a);
        (
            V3([x[d], x[d + 1], x[d + 2]]),
            V3([x[d + 3], x[d + 4], x[d + 5]]),
        )
    }
}

/// The symmetric KKT matrix from entries `(row, col, value)` of one triangle (diagonal
/// entries once), mirrored; factored.
fn symmetric_matrix(n: usize, entries: &[(usize, usize, f64)]) -> Option<NewtonMatrix> {
    let blocks: Vec<Vec<usize>> = entries
        .iter()
        .map(|&(i, j, _)| if i == j { vec![i] } else { vec![i, j] })
        .collect();
    let refs: Vec<&[usize]> = blocks.iter().map(|b| &b[..]).collect();
    let (mut m, pos) = NewtonMatrix::from_blocks(n, &refs, None);
    for (&(i, j, v), p) in entries.iter().zip(&pos) {
        if i == j {
            m.values[p[0] as usize] += v;
        } else {
            // Block [i, j], row-major: (i, j) at 1, (j, i) at 2.
            m.values[p[1] as usize] += v;
            m.values[p[2] as usize] += v;
        }
    }
    m.factor().ok()?;
    Some(m)
}

/// Kinetic-energy weights per node; massless nodes get a small weight so the problem stays
/// regular; parts in `follow` 1e-6 of theirs.
fn weights(sys: &System, follow: &[Parts]) -> (Vec<f64>, Vec<M3<f64>>) {
    let n = sys.layout.n_nodes;
    let floor = 1e-8 * sys.mass_ref;
    let mut mass = vec![0.0; n];
    let mut inertia = vec![M3::<f64>::zero(); n];
    for k in &sys.inertias {
        mass[k.node] += k.mass;
        inertia[k.node] = inertia[k.node] + k.inertia;
    }
    for a in 0..n {
        if mass[a] <= 0.0 {
            mass[a] = floor;
        }
        if inertia[a].max_abs() <= 0.0 {
            inertia[a] = M3::identity().scale_f(floor * sys.length_ref.powi(2));
        }
        if follow[a][0] {
            mass[a] *= 1e-6;
        }
        if follow[a][1] {
            inertia[a] = inertia[a].scale_f(1e-6);
        }
    }
    (mass, inertia)
}

/// The circular frequency scale of a beam's first bending mode, pinned–pinned
/// `(π/L)² √(EI_min/m)` (its axial one `π/L √(EA/m)` without bending stiffness).
fn first_mode(sys: &System, info: &BeamInfo) -> Option<f64> {
    let elements = &sys.beams[info.first..info.first + info.count];
    let floor = 1e-8 * sys.mass_ref * info.nodes.len() as f64;
    let mass = info.inertia.iter().map(|b| b.mass).sum::<f64>().max(floor) / info.length;
    let points = elements.iter().flat_map(|e| &e.points);
    let least = |k: usize| {
        points
            .clone()
            .map(|p| p.stiffness[k][k])
            .fold(f64::INFINITY, f64::min)
    };
    let k = std::f64::consts::PI / info.length;
    let bending = k * k * (least(4).min(least(5)) / mass).sqrt();
    let omega = if bending > 0.0 && bending.is_finite() {
        bending
    } else {
        k * (least(0) / mass).sqrt()
    };
    (omega > 0.0 && omega.is_finite()).then_some(omega)
}

/// The inverse of a 6×6 matrix (Gauss–Jordan with partial pivoting); `None` if singular.
fn inverse6(m: &Mat6) -> Option<Mat6> {
    let mut a = *m;
    let mut inv = [[0.0; 6]; 6];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let scale = m.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    for col in 0..6 {
        let pivot = (col..6).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
        if a[pivot][col].abs() <= 1e-14 * scale {
            return None;
        }
        a.swap(col, pivot);
        inv.swap(col, pivot);
        let d = a[col][col];
        for k in 0..6 {
            a[col][k] /= d;
            inv[col][k] /= d;
        }
        for r in (0..6).filter(|&r| r != col) {
            let f = a[r][col];
            for k in 0..6 {
                a[r][k] -= f * a[col][k];
                inv[r][k] -= f * inv[col][k];
            }
        }
    }
    Some(inv)
}
