//! The configuration and velocities of the system at one instant.

use crate::math::vec3::{M3, V3};

/// A node's state: position `x`, rotation `R` (stored as a matrix, never as parameters),
/// velocity `v` (inertial frame) and *material* angular velocity `W` (node triad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeState {
    pub x: V3<f64>,
    pub r: M3<f64>,
    pub v: V3<f64>,
    pub w: V3<f64>,
}

impl NodeState {
    /// Angular velocity in the inertial frame, `ω = R W`.
    pub fn omega(&self) -> V3<f64> {
        self.r.mul_v(&self.w)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct State {
    pub t: f64,
    pub nodes: Vec<NodeState>,
    /// Joints' relative coordinates (φ, Δ, …) and their rates.
    pub coords: Vec<f64>,
    pub coord_rates: Vec<f64>,
    /// Constraint forces per constraint row (unscaled multipliers of the last step).
    pub lambda: Vec<f64>,
    /// Path-dependent element history (beam Gauss points: triad and curvature; frictions:
    /// stick or slip, see `joints::friction`), flat; each element knows its offset. Committed at the end of every step, never at the j-state.
    pub history: Vec<f64>,
}

impl State {
    /// Becomes a copy of `other` in the buffers it has (derived `clone_from` reallocates).
    pub fn copy_from(&mut self, other: &State) {
        self.t = other.t;
        self.nodes.clone_from(&other.nodes);
        self.coords.clone_from(&other.coords);
        self.coord_rates.clone_from(&other.coord_rates);
        self.lambda.clone_from(&other.lambda);
        self.history.clone_from(&other.history);
    }

    /// No velocities (a static state).
    pub fn at_rest(&mut self) {
        for n in &mut self.nodes {
            n.v = V3::zero();
            n.w = V3::zero();
        }
        self.coord_rates.iter_mut().for_each(|r| *r = 0.0);
    }

    /// Nodes only, at t = 0: no joint coordinates, multipliers or element history.
    pub fn of_nodes(nodes: Vec<NodeState>) -> State {
        State {
            t: 0.0,
            nodes,
            coords: vec![],
            coord_rates: vec![],
            lambda: vec![],
            history: vec![],
        }
    }
}
