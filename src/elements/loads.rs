//! Applied point forces and moments (dead: fixed direction in the inertial frame), scaled by
//! a function of time. They are known over the step, so they enter as their average over it
//! (ed-scheme-notes §3.2) and add nothing to the tangent.

use super::StepCtx;
use crate::time_function::TimeFunction;
use crate::vec3::V3;

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LoadKind {
    Force,
    Moment,
}

#[derive(Clone, Debug)]
pub struct PointLoad {
    pub node: usize,
    pub kind: LoadKind,
    pub value: V3<f64>,
    pub scale: Option<TimeFunction>,
}

impl PointLoad {
    fn average(&self, ctx: &StepCtx) -> V3<f64> {
        let s = match &self.scale {
            None => 1.0,
            Some(f) => 0.5 * (f.value(ctx.t_i) + f.value(ctx.t_f)),
        };
        self.value.scale_f(s)
    }

    /// Generalised force on the node's row block `[force; material moment]`.
    fn generalised(&self, ctx: &StepCtx) -> (usize, V3<f64>) {
        let avg = self.average(ctx);
        let base = ctx.layout.node_delta(self.node);
        match self.kind {
            LoadKind::Force => (base, avg),
            // The rotation unknown is material at i, so its conjugate moment is R_iᵀ M.
            LoadKind::Moment => (base + 3, ctx.state.nodes[self.node].r.tmul_v(&avg)),
        }
    }

    pub fn add_to_residual(&self, ctx: &StepCtx, res: &mut [f64]) {
        let (at, g) = self.generalised(ctx);
        for k in 0..3 {
            res[at + k] -= g.0[k];
        }
    }

    /// Work over a converged step: `Δx·F̄` or `r·R_iᵀ M̄`.
    pub fn step_work(&self, ctx: &StepCtx, y: &[f64]) -> f64 {
        let (at, g) = self.generalised(ctx);
        (0..3).map(|k| y[at + k] * g.0[k]).sum()
    }
}
