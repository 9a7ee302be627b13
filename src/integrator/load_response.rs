//! How much energy the loads can put into the model: the response of the model, at rest, to
//! the forces acting on it at one instant (gravity, applied loads, initial strains), in one
//! linearized step. It scales the step-error indicator before the motion has built up.

use super::Integrator;
use crate::elements::StepCtx;
use crate::state::State;
use crate::system::System;

/// The response to the loads at `state.t`: `(energy, bound)`.
pub struct LoadResponse {
    /// `½|fᵀu|` for the displacement `u` of one linearized step of size h from rest, with
    /// the joints and drives held: `u ≈ (2M/h² + K/2)⁻¹ f`, so where the structure is stiff
    /// within h it is twice the static strain energy (the peak of a load applied suddenly),
    /// and where nothing resists the load (a mechanism) the kinetic energy of a fall
    /// lasting about h.
    pub energy: f64,
    /// The work of the loads over the model's size (`Σ |F| L_ref + |M|`), which bounds the
    /// energy a mechanism can take from them.
    pub bound: f64,
}

impl Integrator {
    /// The model's response to its loads at `state.t` over a step `h` (see
    /// [`LoadResponse`]); `None` if the Newton matrix is singular there. Leaves no valid
    /// factors behind.
    pub fn load_response(&mut self, sys: &System, state: &State, h: f64) -> Option<LoadResponse> {
        let mut rest = state.clone();
        for n in &mut rest.nodes {
            n.v = crate::math::vec3::V3::zero();
            n.w = crate::math::vec3::V3::zero();
        }
        rest.coord_rates.iter_mut().for_each(|r| *r = 0.0);
        // Joints with friction slide (with no normal force yet, freely): the scale is the
        // motion the loads can cause, not the one friction lets them start with.
        for f in &sys.frictions {
            let free = crate::joints::friction::Mode::Slip { direction: 1.0 };
            f.set_mode(&mut rest, free, None);
        }
        let layout = sys.layout;
        let ctx = StepCtx {
            layout,
            h,
            t_i: state.t,
            t_f: state.t,
            s: Self::scaling(sys, h),
            state: &rest,
            gravity: sys.gravity,
            statics: None,
        };
        self.y.iter_mut().for_each(|v| *v = 0.0);
        self.assemble(sys, &ctx, true);
        self.factored_for = None;
        // The joints (and drives, frozen at t) hold: the response moves along them.
        let first_row = layout.mult(0).min(self.res.len());
        self.res[first_row..].iter_mut().for_each(|r| *r = 0.0);
        let f = self.res.clone();
        self.matrix.factor().ok()?;
        self.matrix.solve(&mut self.res);
        let work: f64 = f[..first_row]
            .iter()
            .zip(&self.res[..first_row])
            .map(|(a, b)| a * b)
            .sum();
        let bound = (0..layout.n_nodes)
            .map(|a| {
                let d = layout.node_delta(a);
                let norm = |k: usize| {
                    (f[d + k].powi(2) + f[d + k + 1].powi(2) + f[d + k + 2].powi(2)).sqrt()
                };
                norm(0) * sys.length_ref + norm(3)
            })
            .sum();
        let energy = 0.5 * work.abs();
        energy.is_finite().then_some(LoadResponse { energy, bound })
    }
}
