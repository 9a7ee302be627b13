//! Kept LU factors carried through rigid rotations: co-rotated modified Newton.
//!
//! Modified Newton keeps the LU factors of the Newton matrix `J₀` of some iterate and uses them
//! at later iterates and steps while the iteration contracts fast enough. A flexible member
//! that has turned by `Q` since (a rotor blade a few degrees further round, a pendulum further
//! into its swing) has, to first order in its change of shape, the Newton matrix `D J₀ Dᵀ`:
//! its stiffness turns with it, so the *spatial* components — a node's force rows and
//! translation increments (under ED also its translational jump rows and jump velocities), and
//! the constraint rows that are spatial vectors, a joint's coincident-point rows, with their
//! multipliers — are `J₀`'s turned by `Q`, while the *material* ones (rotation rows and
//! increments, joint coordinates, rows projected on a side's triad) are unchanged. The kept
//! factors then serve as `D J₀⁻¹ Dᵀ`: the residual's spatial parts are turned back by `Qᵀ`
//! before the solve and the update's turned forward by `Q` after it.
//!
//! Without it a beam's axial stiffness, turned by a few hundredths of a radian against the
//! factors, leaks into its soft swinging and bending motion (`EA/ℓ ≈ 2e8 N/m` against
//! `m/h² ≈ 5e3 N/m` for the beam pendulum at 5 ms steps), and the rate test refactored at
//! every step of a spinning rotor, under both schemes.
//!
//! Only the approximation of the Newton matrix changes: the residual is the scheme's own, so
//! a converged step, its energy identity and its constraints are the same whatever the factors.
//!
//! Which nodes turn their rows: beam nodes always (their stiffness turns with them); a node
//! without a beam when it turns together with the nodes it is jointed to — none of them has
//! turned relative to it, since the factors, by more than half its own turn. That keeps rigid
//! rotors (a hub, hinges a few degrees about a fast spin) and single bodies (a pendulum, a top)
//! co-rotated and leaves linkages in the inertial frame: the links of a four-bar turn against
//! each other as much as they turn, and their joints' translation columns `∓I` are invariant
//! only there. A joint's spatial rows turn with side 2's node if it is co-rotated, else with
//! side 1's, else not at all.

use crate::joints::SpatialRows;
use crate::math::layout::Layout;
use crate::math::rotation::cayley;
use crate::math::vec3::{M3, V3};
use crate::state::State;
use crate::system::System;

pub struct CoRotation {
    /// Node rotations at the iterate the factors in hand were computed at.
    factored: Vec<M3<f64>>,
    /// Per node, for the current step: its rotation since then if it is co-rotated, else the
    /// identity.
    turns: Vec<M3<f64>>,
    corotated: Vec<bool>,
    /// Whether any turn is not the identity (solves skip the transformation otherwise).
    turning: bool,
    beam_node: Vec<bool>,
    /// The nodes each node is jointed to by a pair joint.
    partners: Vec<Vec<usize>>,
    spatial_rows: Vec<SpatialRows>,
    layout: Layout,
}

impl CoRotation {
    pub fn new(sys: &System) -> Self {
        let mut beam_node = vec![false; sys.layout.n_nodes];
        for b in &sys.beams {
            for &a in &b.nodes {
                beam_node[a] = true;
            }
        }
        let pairs: Vec<[usize; 2]> = sys
            .joints
            .iter()
            .filter(|j| j.as_sliding().is_none())
            .filter_map(|j| match j.nodes() {
                [Some(a), Some(b)] => Some([a, b]),
                _ => None,
            })
            .collect();
        let rows = sys.joints.iter().filter_map(|j| j.spatial_rows()).collect();
        Self::with_parts(sys.layout, beam_node, &pairs, rows)
    }

    /// From the layout, which nodes are beam nodes, the node pairs that joints connect, and
    /// the joints' spatial rows.
    pub fn with_parts(
        layout: Layout,
        beam_node: Vec<bool>,
        pairs: &[[usize; 2]],
        spatial_rows: Vec<SpatialRows>,
    ) -> Self {
        let n = layout.n_nodes;
        let mut partners = vec![Vec::new(); n];
        for &[a, b] in pairs {
            partners[a].push(b);
            partners[b].push(a);
        }
        CoRotation {
            factored: vec![M3::identity(); n],
            turns: vec![M3::identity(); n],
            corotated: vec![false; n],
            turning: false,
            beam_node,
            partners,
            spatial_rows,
            layout,
        }
    }

    /// The rotation of node `a` at the iterate `y` of the step from `state`: `R_i cay(r)`.
    fn rotation_at(&self, state: &State, y: &[f64], a: usize) -> M3<f64> {
        let d = self.layout.node_delta(a) + 3;
        state.nodes[a]
            .r
            .mul_m(&cayley(&V3([y[d], y[d + 1], y[d + 2]])))
    }

    /// Fresh factors computed at the iterate `y` of the step from `state`.
    pub fn record(&mut self, state: &State, y: &[f64]) {
        for a in 0..self.factored.len() {
            self.factored[a] = self.rotation_at(state, y, a);
        }
        self.turning = false;
    }

    /// A step starts on kept factors at the iterate `y`: each node's turn since they were
    /// computed, kept for the step (the Newton corrections turn nodes by far less than a step).
    pub fn follow(&mut self, state: &State, y: &[f64]) {
        for a in 0..self.turns.len() {
            self.turns[a] = self
                .rotation_at(state, y, a)
                .mul_m(&self.factored[a].transpose());
        }
        for a in 0..self.turns.len() {
            self.corotated[a] = self.beam_node[a] || self.turns_with_partners(a);
        }
        self.turning = false;
        for (t, &co) in self.turns.iter_mut().zip(&self.corotated) {
            if !co {
                *t = M3::identity();
            }
            self.turning |= *t != M3::identity();
        }
    }

    /// Whether no partner of node `a` has turned relative to it by more than half its own
    /// turn: `cos θ_rel ≥ cos(θ/2)`, with `cos θ = (tr Q − 1)/2` and `tr(QₐᵀQₘ) = Qₐ : Qₘ`.
    fn turns_with_partners(&self, a: usize) -> bool {
        let q = &self.turns[a];
        let cos_own = 0.5 * (q.trace() - 1.0);
        let cos_half = (0.5 * (1.0 + cos_own)).max(0.0).sqrt();
        self.partners[a].iter().all(|&m| {
            let p = &self.turns[m];
            let inner: f64 = (0..3)
                .flat_map(|i| (0..3).map(move |j| (i, j)))
                .map(|(i, j)| q.0[i][j] * p.0[i][j])
                .sum();
            0.5 * (inner - 1.0) >= cos_half
        })
    }

    /// Whether the factors in hand are being used away from the rotations they were computed at.
    pub fn is_turning(&self) -> bool {
        self.turning
    }

    /// The turn the rows `s` follow this step.
    fn rows_turn(&self, s: &SpatialRows) -> Option<&M3<f64>> {
        s.nodes
            .iter()
            .flatten()
            .find(|&&a| self.corotated[a])
            .map(|&a| &self.turns[a])
    }

    /// Turns the spatial parts of `v` (a residual, or an update) by `Qᵀ` (`back`) or `Q`.
    fn apply(&self, v: &mut [f64], back: bool) {
        self.for_each_turn(|at, q| turn_triplet(q, v, at, back));
    }

    /// Calls `f(indices, Q)` for each triplet of unknowns that turns (a co-rotated node's
    /// translation increments, under ED its jumps, a joint's spatial rows), with its turn.
    #[inline(always)]
    pub fn for_each_turn(&self, mut f: impl FnMut([usize; 3], &M3<f64>)) {
        let l = self.layout;
        for (a, q) in self.turns.iter().enumerate() {
            if !self.corotated[a] {
                continue;
            }
            let d = l.node_delta(a);
            f([d, d + 1, d + 2], q);
            if l.ed() {
                let j = l.node_jump(a);
                f([j, j + 1, j + 2], q);
            }
        }
        for s in &self.spatial_rows {
            if let Some(q) = self.rows_turn(s) {
                f([0, 1, 2].map(|k| l.mult(s.row + k)), q);
                if l.ed() {
                    f([0, 1, 2].map(|k| l.mult_jump(s.row + k)), q);
                }
            }
        }
    }

    pub fn to_factored(&self, res: &mut [f64]) {
        self.apply(res, true);
    }

    /// The update turned from the factors' frames to the current ones (after the solve).
    pub fn from_factored(&self, update: &mut [f64]) {
        self.apply(update, false);
    }

    /// Which nodes are co-rotated this step (tests, diagnostics).
    pub fn corotated(&self) -> &[bool] {
        &self.corotated
    }
}

/// `v[at] ← Qᵀ v[at]` (`back`) or `Q v[at]`.
#[inline(always)]
pub fn turn_triplet(q: &M3<f64>, v: &mut [f64], at: [usize; 3], back: bool) {
    let x = V3(at.map(|i| v[i]));
    let y = if back { q.tmul_v(&x) } else { q.mul_v(&x) };
    for (k, &i) in at.iter().enumerate() {
        v[i] = y.0[k];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::layout::Scheme;
    use crate::math::rotation::exp_map;
    use crate::state::NodeState;
    use faer::prelude::Solve;
    use faer::Mat;

    /// Three nodes under ED (their jumps turn too): node 0 on a beam, nodes 1 and 2 rigid bodies
    /// joined by a joint whose rows 0–2 are a point separation (row 3 a projection), and one
    /// coordinate: 36 + 2 + 8 unknowns.
    fn system() -> CoRotation {
        let layout = Layout::new(Scheme::Ed, 3, 1, 4);
        let rows = vec![SpatialRows {
            row: 0,
            nodes: [Some(1), Some(2)],
        }];
        CoRotation::with_parts(layout, vec![true, false, false], &[[2, 1]], rows)
    }

    fn state(turns: [V3<f64>; 3]) -> State {
        let base = [
            V3([0.3, -0.2, 0.5]),
            V3([-0.7, 0.1, 0.2]),
            V3([0.2, 0.9, -0.4]),
        ];
        let nodes = (0..3)
            .map(|a| NodeState {
                x: V3::zero(),
                r: exp_map(&turns[a]).mul_m(&exp_map(&base[a])),
                v: V3::zero(),
                w: V3::zero(),
            })
            .collect();
        State::of_nodes(nodes)
    }

    /// `D`: each co-rotated node's translation and translational jump components turned by its
    /// turn, the spatial rows (and their jump rows) by the turn they follow.
    fn turning_matrix(c: &CoRotation, n: usize) -> Mat<f64> {
        let mut d = Mat::<f64>::identity(n, n);
        let l = c.layout;
        let mut put = |q: &M3<f64>, at: [usize; 3]| {
            for i in 0..3 {
                for j in 0..3 {
                    d[(at[i], at[j])] = q.0[i][j];
                }
            }
        };
        for a in 0..3 {
            if c.corotated[a] {
                let (dx, j) = (l.node_delta(a), l.node_jump(a));
                put(&c.turns[a], [dx, dx + 1, dx + 2]);
                put(&c.turns[a], [j, j + 1, j + 2]);
            }
        }
        for s in &c.spatial_rows {
            if let Some(q) = c.rows_turn(s) {
                put(q, [0, 1, 2].map(|k| l.mult(s.row + k)));
                put(q, [0, 1, 2].map(|k| l.mult_jump(s.row + k)));
            }
        }
        d
    }

    /// The kept factors of `J₀`, turned, solve `D J₀ Dᵀ` exactly; returns the largest error
    /// of the update relative to its size.
    fn turned_solve_error(c: &CoRotation, turned: bool) -> f64 {
        let n = c.layout.n_unknowns();
        let pseudo = |k: usize| ((k as f64 * 12.9898).sin() * 43758.5453).fract();
        let j0 = Mat::<f64>::from_fn(n, n, |i, j| {
            pseudo(i * n + j) + if i == j { 8.0 } else { 0.0 }
        });
        let d = turning_matrix(c, n);
        let j = &d * &j0 * d.transpose();
        let b = Mat::<f64>::from_fn(n, 1, |i, _| pseudo(7000 + i));
        let exact = j.partial_piv_lu().solve(&b);
        let mut res: Vec<f64> = (0..n).map(|i| b[(i, 0)]).collect();
        if turned {
            c.to_factored(&mut res);
        }
        let kept = j0
            .partial_piv_lu()
            .solve(Mat::<f64>::from_fn(n, 1, |i, _| res[i]));
        let mut update: Vec<f64> = (0..n).map(|i| kept[(i, 0)]).collect();
        if turned {
            c.from_factored(&mut update);
        }
        let scale = (0..n).fold(0.0f64, |m, i| m.max(exact[(i, 0)].abs()));
        (0..n).fold(0.0f64, |m, i| m.max((update[i] - exact[(i, 0)]).abs())) / scale
    }

    #[test]
    fn kept_factors_turned_with_the_nodes_solve_the_turned_matrix() {
        let mut c = system();
        let y = vec![0.0; c.layout.n_unknowns()];
        c.record(&state([V3::zero(); 3]), &y);
        // The beam node and both bodies turn about nearly the same axis, a rotor's way.
        let spin = V3([0.1, 0.2, 1.1]);
        c.follow(&state([spin, spin, spin + V3([0.02, 0.0, -0.03])]), &y);
        assert_eq!(c.corotated(), &[true, true, true]);
        assert!(c.is_turning());
        // Two LUs of a diagonally weighted 46 × 46 matrix: round-off.
        let e = turned_solve_error(&c, true);
        assert!(e < 1e-12, "{e:e}");
        // The same factors used as they are miss by about the turn (1.1 rad here).
        assert!(turned_solve_error(&c, false) > 0.1);
    }

    #[test]
    fn bodies_turning_against_their_partners_stay_in_the_inertial_frame() {
        let mut c = system();
        let y = vec![0.0; c.layout.n_unknowns()];
        c.record(&state([V3::zero(); 3]), &y);
        // A linkage: the two bodies turn 0.4 rad against each other, as much as each turns.
        let q = [
            V3([0.0, 0.0, 0.3]),
            V3([0.0, 0.0, 0.2]),
            V3([0.0, 0.0, -0.2]),
        ];
        c.follow(&state(q), &y);
        assert_eq!(c.corotated(), &[true, false, false]);
        // The joint's rows then stay unturned too (neither side is co-rotated), and the solve
        // is exact for the matrix turned that way.
        assert_eq!(c.rows_turn(&c.spatial_rows[0]), None);
        let e = turned_solve_error(&c, true);
        assert!(e < 1e-12, "{e:e}");
        // A body whose only partner turns with it is co-rotated, and the rows follow side 2
        // (node 1) when it is.
        let q = [
            V3([0.0, 0.0, 0.3]),
            V3([0.0, 0.1, 0.5]),
            V3([0.0, 0.1, 0.55]),
        ];
        c.follow(&state(q), &y);
        assert_eq!(c.corotated(), &[true, true, true]);
        assert_eq!(c.rows_turn(&c.spatial_rows[0]), Some(&c.turns[1]));
    }
}
