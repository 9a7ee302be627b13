//! Applied point forces and moments, scaled by a function of time.
//!
//! A *dead* load keeps its direction in the inertial frame; a *follower* load is fixed in the
//! node's triad and turns with it. Over a time step a load enters as its average (the scale's
//! mean over the step, ed-scheme-notes §3.2); a follower force as the mean of its directions at
//! i and f. Rotation rows are material (conjugate to the Cayley increment r, which is the same
//! vector in the i and f triads), so a follower moment adds just `M*`. In statics the load
//! acts at the end state, times the load factor. Distributed loads on beams are lumped to the
//! beam's nodes as point loads when the system is compiled.

use super::{add3, v3, Kernel, StepCtx};
use crate::math::layout::Layout;
use crate::math::rotation::rotate_material;
use crate::math::scalar::Real;
use crate::math::time_function::TimeFunction;
use crate::math::vec3::{M3, V3};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LoadKind {
    Force,
    Moment,
}

#[derive(Clone, Debug)]
pub struct PointLoad {
    pub node: usize,
    pub kind: LoadKind,
    /// Inertial frame (dead) or the node's triad (follower).
    pub value: V3<f64>,
    pub follower: bool,
    pub scale: Option<TimeFunction>,
    unknowns: Vec<usize>,
}

impl PointLoad {
    pub fn new(
        node: usize,
        kind: LoadKind,
        value: V3<f64>,
        follower: bool,
        scale: Option<TimeFunction>,
        layout: &Layout,
    ) -> Self {
        PointLoad {
            node,
            kind,
            value,
            follower,
            scale,
            unknowns: (0..6).map(|k| layout.node_delta(node) + k).collect(),
        }
    }

    /// The scale factor the load carries over the step (or at the static state).
    fn factor(&self, ctx: &StepCtx) -> f64 {
        let f = |t: f64| self.scale.as_ref().map_or(1.0, |s| s.value(t));
        match ctx.statics {
            Some(lf) => lf * f(ctx.t_f),
            // The step's mean (module `time_function::mean`): a pulse between the step's
            // ends carries its impulse.
            None => self
                .scale
                .as_ref()
                .map_or(1.0, |s| s.mean(ctx.t_i, ctx.t_f)),
        }
    }

    /// Work over a converged step: the increments times the generalised load.
    pub fn step_work(&self, ctx: &StepCtx, y: &[f64]) -> f64 {
        let yl: Vec<f64> = self.unknowns.iter().map(|&g| y[g]).collect();
        let mut r = [0.0; 6];
        self.residual(ctx, &yl, &mut r);
        -yl.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>()
    }
}

impl Kernel for PointLoad {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns
    }

    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], res: &mut [T]) {
        let s = self.factor(ctx);
        let ri = M3::<T>::from_f64(&ctx.state.nodes[self.node].r);
        let rf = || rotate_material(&ctx.state.nodes[self.node].r, &v3(y, 3));
        let value = V3::<T>::from_f64(self.value.scale_f(s));
        let (at, load) = match (self.kind, self.follower, ctx.is_static()) {
            (LoadKind::Force, false, _) => (0, value),
            (LoadKind::Force, true, false) => (0, (ri + rf()).mul_v(&value).scale_f(0.5)),
            (LoadKind::Force, true, true) => (0, rf().mul_v(&value)),
            // Rotation rows are material: at i in a time step, at f in statics.
            (LoadKind::Moment, false, false) => (3, ri.tmul_v(&value)),
            (LoadKind::Moment, false, true) => (3, rf().tmul_v(&value)),
            (LoadKind::Moment, true, _) => (3, value),
        };
        add3(res, at, -load);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elements::fd_harness::tangent_error;
    use crate::math::layout::Scheme;
    use crate::math::rotation::exp_map;
    use crate::state::{NodeState, State};

    #[test]
    fn tangents_match_finite_differences_for_dead_and_follower_loads() {
        let state = State {
            t: 0.0,
            nodes: vec![NodeState {
                x: V3([0.1, 0.2, 0.3]),
                r: exp_map(&V3([0.4, -0.2, 0.9])),
                v: V3([0.0; 3]),
                w: V3([0.0; 3]),
            }],
            coords: vec![],
            coord_rates: vec![],
            lambda: vec![],
            history: vec![],
        };
        let layout = Layout::new(Scheme::Ep, 1, 0, 0);
        let y: Vec<f64> = (0..6).map(|i| 0.3 * ((i as f64) * 0.7).sin()).collect();
        for statics in [None, Some(0.7)] {
            let ctx = StepCtx {
                layout,
                h: 0.01,
                t_i: 0.0,
                t_f: 0.01,
                s: 1.0,
                state: &state,
                gravity: V3([0.0; 3]),
                statics,
            };
            for kind in [LoadKind::Force, LoadKind::Moment] {
                for follower in [false, true] {
                    let l = PointLoad::new(0, kind, V3([1.0, -2.0, 3.0]), follower, None, &layout);
                    let e = tangent_error(&l, &ctx, &y);
                    // Same bound as the other kernels (FD truncation and round-off).
                    assert!(e < 1e-7, "{kind:?} follower={follower} {statics:?}: {e}");
                }
            }
        }
    }

    #[test]
    fn a_follower_force_turns_with_its_node() {
        // A follower force given along the node's axis 1 acts along the rotated axis 1.
        let state = State {
            t: 0.0,
            nodes: vec![NodeState {
                x: V3([0.0; 3]),
                r: M3::identity(),
                v: V3([0.0; 3]),
                w: V3([0.0; 3]),
            }],
            coords: vec![],
            coord_rates: vec![],
            lambda: vec![],
            history: vec![],
        };
        let layout = Layout::new(Scheme::Ep, 1, 0, 0);
        let ctx = StepCtx {
            layout,
            h: 1.0,
            t_i: 0.0,
            t_f: 0.0,
            s: 1.0,
            state: &state,
            gravity: V3([0.0; 3]),
            statics: Some(1.0),
        };
        // A quarter turn about z: Cayley parameter 2 tan(θ/2) = 2.
        let r = 2.0;
        let y = [0.0, 0.0, 0.0, 0.0, 0.0, r];
        let l = PointLoad::new(0, LoadKind::Force, V3([5.0, 0.0, 0.0]), true, None, &layout);
        let mut res = [0.0; 6];
        l.residual(&ctx, &y, &mut res);
        assert!((res[0]).abs() < 1e-14 && (res[1] + 5.0).abs() < 1e-14);
    }
}
