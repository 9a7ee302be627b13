//! Numbering of a step's unknowns. The layout depends on the scheme: EP solves for the
//! increments Δ and one multiplier per constraint row; ED (strain-rate-jump form) also solves
//! for the jump velocities V_j and a second, velocity-level multiplier per row
//! (`reference/ed-scheme-notes.md` §3.1). The jump velocities are carried as `h V_j`
//! (displacement units), so that every column of the Newton matrix scales as m/h² and its
//! conditioning does not degrade as the step shrinks (`tests/conditioning.rs`). Every unknown also names a residual row, so the
//! Newton matrix is square with a structurally symmetric pattern.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// The time scheme, which fixes the unknowns a step solves for (also the model file's
/// `simulation.scheme`).
#[derive(Serialize, Deserialize, JsonSchema, Clone, Copy, Debug, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum Scheme {
    /// Energy preserving: total energy conserved to Newton tolerance, no numerical damping.
    Ep,
    /// Energy decaying (strain-rate jump form): energy never increases; unresolved high
    /// frequencies are annihilated.
    #[default]
    Ed,
}

#[derive(Clone, Copy, Debug)]
pub struct Layout {
    pub scheme: Scheme,
    pub n_nodes: usize,
    pub n_coords: usize,
    pub n_rows: usize,
}

/// Which equation a global row is (for diagnostics).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowOwner {
    NodeForce { node: usize, component: usize },
    NodeJump { node: usize, component: usize },
    CoordForce { coord: usize },
    CoordJump { coord: usize },
    Constraint { row: usize },
    ConstraintRate { row: usize },
}

impl Layout {
    pub fn new(scheme: Scheme, n_nodes: usize, n_coords: usize, n_rows: usize) -> Self {
        Layout {
            scheme,
            n_nodes,
            n_coords,
            n_rows,
        }
    }
    #[inline]
    pub fn ed(&self) -> bool {
        self.scheme == Scheme::Ed
    }
    #[inline]
    fn per(&self) -> usize {
        if self.ed() {
            2
        } else {
            1
        }
    }
    /// First of node `a`'s six increment unknowns `[Δx, r]`.
    #[inline]
    pub fn node_delta(&self, a: usize) -> usize {
        6 * self.per() * a
    }
    /// First of node `a`'s six jump velocities `[v_j, W_j]` (ED only).
    #[inline]
    pub fn node_jump(&self, a: usize) -> usize {
        debug_assert!(self.ed());
        12 * a + 6
    }
    #[inline]
    pub fn coord_delta(&self, c: usize) -> usize {
        6 * self.per() * self.n_nodes + self.per() * c
    }
    #[inline]
    pub fn coord_jump(&self, c: usize) -> usize {
        debug_assert!(self.ed());
        self.coord_delta(c) + 1
    }
    #[inline]
    pub fn mult(&self, row: usize) -> usize {
        self.per() * (6 * self.n_nodes + self.n_coords) + self.per() * row
    }
    #[inline]
    pub fn mult_jump(&self, row: usize) -> usize {
        debug_assert!(self.ed());
        self.mult(row) + 1
    }
    pub fn n_unknowns(&self) -> usize {
        self.per() * (6 * self.n_nodes + self.n_coords + self.n_rows)
    }
    /// ED's unknowns come in pairs stored side by side: a node component's increment and
    /// jump, a coordinate's increment and jump, a row's λ and λ_d (and so do its rows: the
    /// f- and j-equations, `C_f` and the j-condition). `pair(i)` is unknown `i`'s pair in an
    /// EP-sized numbering (`0..n_pairs()`, nodes, coordinates, then rows) and whether it is
    /// the pair's second (jump) member.
    #[inline]
    pub fn pair(&self, i: usize) -> (usize, bool) {
        debug_assert!(self.ed());
        let nn = 12 * self.n_nodes;
        if i < nn {
            (6 * (i / 12) + i % 6, i % 12 >= 6)
        } else {
            (6 * self.n_nodes + (i - nn) / 2, (i - nn) % 2 == 1)
        }
    }
    /// The two unknowns of pair `p` (inverse of [`Layout::pair`]).
    #[inline]
    pub fn unpair(&self, p: usize) -> (usize, usize) {
        debug_assert!(self.ed());
        let np = 6 * self.n_nodes;
        if p < np {
            let first = 12 * (p / 6) + p % 6;
            (first, first + 6)
        } else {
            let first = 12 * self.n_nodes + 2 * (p - np);
            (first, first + 1)
        }
    }
    pub fn n_pairs(&self) -> usize {
        6 * self.n_nodes + self.n_coords + self.n_rows
    }
    /// Whether pair `p` is a constraint row's (λ, λ_d) rather than a motion's.
    #[inline]
    pub fn pair_is_multiplier(&self, p: usize) -> bool {
        p >= 6 * self.n_nodes + self.n_coords
    }
    pub fn owner(&self, i: usize) -> RowOwner {
        let p = self.per();
        let nn = 6 * p * self.n_nodes;
        if i < nn {
            let node = i / (6 * p);
            let k = i % (6 * p);
            return if k < 6 {
                RowOwner::NodeForce { node, component: k }
            } else {
                RowOwner::NodeJump {
                    node,
                    component: k - 6,
                }
            };
        }
        let i = i - nn;
        if i < p * self.n_coords {
            let coord = i / p;
            return if i % p == 0 {
                RowOwner::CoordForce { coord }
            } else {
                RowOwner::CoordJump { coord }
            };
        }
        let i = i - p * self.n_coords;
        let row = i / p;
        if i % p == 0 {
            RowOwner::Constraint { row }
        } else {
            RowOwner::ConstraintRate { row }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_unknown_has_one_owner_and_round_trips() {
        for scheme in [Scheme::Ep, Scheme::Ed] {
            let l = Layout::new(scheme, 3, 2, 5);
            let mut seen = vec![false; l.n_unknowns()];
            for a in 0..3 {
                for k in 0..6 {
                    let i = l.node_delta(a) + k;
                    assert_eq!(
                        l.owner(i),
                        RowOwner::NodeForce {
                            node: a,
                            component: k
                        }
                    );
                    seen[i] = true;
                    if l.ed() {
                        let j = l.node_jump(a) + k;
                        assert_eq!(
                            l.owner(j),
                            RowOwner::NodeJump {
                                node: a,
                                component: k
                            }
                        );
                        seen[j] = true;
                    }
                }
            }
            for c in 0..2 {
                seen[l.coord_delta(c)] = true;
                assert_eq!(l.owner(l.coord_delta(c)), RowOwner::CoordForce { coord: c });
                if l.ed() {
                    seen[l.coord_jump(c)] = true;
                }
            }
            for r in 0..5 {
                seen[l.mult(r)] = true;
                assert_eq!(l.owner(l.mult(r)), RowOwner::Constraint { row: r });
                if l.ed() {
                    seen[l.mult_jump(r)] = true;
                    assert_eq!(l.owner(l.mult_jump(r)), RowOwner::ConstraintRate { row: r });
                }
            }
            assert!(seen.iter().all(|&s| s));
        }
    }

    #[test]
    fn ed_unknowns_pair_up_increment_with_jump() {
        let l = Layout::new(Scheme::Ed, 3, 2, 5);
        assert_eq!(l.n_pairs(), 18 + 2 + 5);
        let mut seen = vec![0; l.n_pairs()];
        for i in 0..l.n_unknowns() {
            let (p, second) = l.pair(i);
            seen[p] += 1;
            let (a, b) = l.unpair(p);
            assert_eq!(if second { b } else { a }, i);
            // The second member is the jump of the first's quantity.
            let expected_second = matches!(
                l.owner(i),
                RowOwner::NodeJump { .. }
                    | RowOwner::CoordJump { .. }
                    | RowOwner::ConstraintRate { .. }
            );
            assert_eq!(second, expected_second, "unknown {i}");
            let mult = matches!(
                l.owner(i),
                RowOwner::Constraint { .. } | RowOwner::ConstraintRate { .. }
            );
            assert_eq!(l.pair_is_multiplier(p), mult);
        }
        assert!(seen.iter().all(|&c| c == 2));
        assert_eq!(l.pair(l.node_jump(1) + 4), (10, true));
        assert_eq!(l.pair(l.mult_jump(2)), (18 + 2 + 2, true));
    }
}
