//! Distributed loads that follow the sections of a beam: a force or moment per unit length
//! given in the section frame, integrated over each element at its Gauss points with the
//! points' own triads, `f_α = ∫ h_α R(s) q* ds` (the consistent load vector; lumping with
//! nodal triads instead would be only O(h²) accurate on curved or bending beams). Over a
//! time step the load acts with the mean triad `(R_i + R_f)/2` and the mean scale; in statics
//! with `R_f` times the load factor. Dead distributed loads need no kernel: constant
//! inertial loads lump exactly to nodal forces.

use super::element::BeamElement;
use crate::elements::loads::LoadKind;
use crate::elements::{add3, v3, Kernel, StepCtx};
use crate::math::rotation::rotate_material;
use crate::math::scalar::Real;
use crate::math::time_function::TimeFunction;
use crate::math::vec3::{M3, V3};

#[derive(Clone, Debug)]
pub struct FollowerLineLoad {
    pub name: String,
    /// The element the load acts on (its nodes, Gauss points and history).
    pub element: BeamElement,
    pub kind: LoadKind,
    /// Per unit length, section frame.
    pub value: V3<f64>,
    pub scale: Option<TimeFunction>,
}

impl FollowerLineLoad {
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
        let yl = self.element.gather(y);
        let mut r = vec![0.0; yl.len()];
        self.residual(ctx, &yl, &mut r);
        -yl.iter().zip(&r).map(|(a, b)| a * b).sum::<f64>()
    }
}

impl Kernel for FollowerLineLoad {
    fn unknowns(&self) -> &[usize] {
        self.element.unknowns()
    }

    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], res: &mut [T]) {
        let el = &self.element;
        let q = self.value.scale_f(self.factor(ctx));
        for (g, p) in el.points.iter().enumerate() {
            let (rg_i, rg_f) = el.gauss_triads(ctx, g, y);
            let load = if ctx.is_static() {
                rg_f.mul_vf(&q)
            } else {
                (rg_i + rg_f).mul_vf(&q).scale_f(0.5)
            };
            for (a, &node) in el.nodes.iter().enumerate() {
                let at = el.local_delta(ctx, a);
                let share = load.scale_f(p.weight * p.h[a]);
                match self.kind {
                    LoadKind::Force => add3(res, at, -share),
                    LoadKind::Moment => {
                        // Material rotation rows: the i-triad in a step, the f-triad in statics.
                        let ri = M3::<T>::from_f64(&ctx.state.nodes[node].r);
                        let rn = if ctx.is_static() {
                            rotate_material(&ctx.state.nodes[node].r, &v3(y, at + 3))
                        } else {
                            ri
                        };
                        add3(res, at + 3, -rn.tmul_v(&share));
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::beam::element::tests::{ctx, fixture};
    use crate::elements::fd_harness::tangent_error;
    use crate::math::layout::Scheme;

    #[test]
    fn tangents_match_finite_differences_for_every_order_scheme_and_kind() {
        for (scheme, statics) in [
            (Scheme::Ep, None),
            (Scheme::Ed, None),
            (Scheme::Ep, Some(0.6)),
        ] {
            for n in 2..=4 {
                let (el, state, layout) = fixture(n, scheme);
                let c = StepCtx {
                    statics,
                    ..ctx(layout, &state)
                };
                for kind in [LoadKind::Force, LoadKind::Moment] {
                    let load = FollowerLineLoad {
                        name: "q".into(),
                        element: el.clone(),
                        kind,
                        value: V3([0.3, -2.0, 1.1]),
                        scale: None,
                    };
                    let y: Vec<f64> = (0..layout.n_unknowns())
                        .map(|i| 0.05 * ((i as f64) * 0.9).cos())
                        .collect();
                    let e = tangent_error(&load, &c, &y);
                    // Same bound as the other kernels (FD truncation and round-off).
                    assert!(e < 1e-7, "{scheme:?} {statics:?} n={n} {kind:?}: {e:e}");
                }
            }
        }
    }

    #[test]
    fn an_undeformed_element_gets_the_resultant_of_its_load() {
        // With no increment the nodal forces add up to ∫ R(s) q ds over the element.
        let (el, state, layout) = fixture(4, Scheme::Ep);
        let c = StepCtx {
            statics: Some(1.0),
            ..ctx(layout, &state)
        };
        let q = V3([0.0, 1.0, 0.0]);
        let load = FollowerLineLoad {
            name: "q".into(),
            element: el.clone(),
            kind: LoadKind::Force,
            value: q,
            scale: None,
        };
        let y = vec![0.0; layout.n_unknowns()];
        let mut r = vec![0.0; y.len()];
        load.residual(&c, &y, &mut r);
        let mut total = V3::zero();
        for a in 0..4 {
            total -= v3(&r, 6 * a);
        }
        let mut expect = V3::zero();
        for (g, p) in el.points.iter().enumerate() {
            let (rg, _) = el.gauss_triads::<f64>(&c, g, &y);
            expect += rg.mul_v(&q).scale_f(p.weight);
        }
        assert!((total - expect).norm() < 1e-14);
    }
}
