//! Adaptive steps (DESIGN 8.6): a local error indicator judged against the tolerance decides
//! whether a converged step is accepted and how long the next one is.

use super::{Simulation, StepMeans};
use crate::integrator::{StepFailure, StepReport};
use crate::model::Scheme;
use crate::state::State;
use crate::vec3::V3;

impl Simulation {
    /// The local error indicator of a converged step from the current state to `end` (e ≤ 1
    /// meets the tolerance): error energies of the step relative to the motion's energy scale
    /// (the largest kinetic + strain + spring energy so far), `e = √(E_err/E)/tol` — relative
    /// velocity errors, O(h²) for smooth motion, like the global error, so errors follow the
    /// tolerance in proportion (DESIGN 8.6). Measured in energy, content that carries little
    /// of it (a faint high-frequency ring of a stiff beam) does not drive the step down.
    /// - Both schemes: the kinetic energy of the step's local error estimated from the mean
    ///   velocities of the last three steps (`Δx/h` and the spatial `R r/h`): h²v″/12, the
    ///   midpoint rule's h³x‴/12 per unit h, with v″ from divided differences. End-of-step
    ///   velocities are not used: with joints they carry EP's undamped period-2 ripple (an
    ///   index-3 trait of the midpoint rule) and ED's velocity off the joints' tangent, which a
    ///   predictor built on them would read as error at any step size. The first two steps,
    ///   lacking history, are checked by step doubling.
    /// - ED also: the step's jump energy D (a weighted norm of the jumps, ed-scheme-notes
    ///   §3.4), which measures what the scheme dissipates — on a fast gyroscopic motion it
    ///   grows far beyond the motion estimate (ED's phase and amplitude error there).
    pub(super) fn local_error(
        &mut self,
        end: &State,
        h: f64,
        report: &StepReport,
    ) -> Result<f64, StepFailure> {
        let motion = if self.recent_means.len() < 2 {
            self.doubling_error(end, h)?
        } else {
            let energy = self.mean_velocity_error_energy(end, h);
            self.relative_error(energy, end)
        };
        Ok(match self.settings.scheme {
            Scheme::Ep => motion,
            Scheme::Ed => {
                motion.max(self.relative_error(report.numerical_dissipation.max(0.0), end))
            }
        })
    }

    /// `√(E_err/E)/tol`, E the motion's energy scale including the end state; zero while
    /// nothing moves or strains.
    pub(super) fn relative_error(&self, error_energy: f64, end: &State) -> f64 {
        let scale = self.energy_scale.max(self.system.motion_energy(end));
        if scale <= 0.0 {
            return 0.0;
        }
        (error_energy / scale).sqrt() / self.settings.tolerance
    }

    /// Mean velocity and spatial angular velocity over a step to `end`, of each node carrying
    /// inertia.
    pub(super) fn step_means(&self, end: &State, h: f64) -> StepMeans {
        let means = self
            .system
            .inertias
            .iter()
            .map(|k| {
                let (a, b) = (&self.state.nodes[k.node], &end.nodes[k.node]);
                let v = (b.x - a.x).scale_f(1.0 / h);
                let w = a.r.mul_v(&rotation_between(&a.r, &b.r)).scale_f(1.0 / h);
                (v, w)
            })
            .collect();
        StepMeans { h, means }
    }

    /// EP's error energy `Σ ½ m |δv|² + ½ δωᵀ J δω` (J turned to the inertial frame): δ the
    /// step's mean velocities minus their linear extrapolation from the previous two steps'
    /// (an error ≈ h² v″ at equal steps), over 12 — the midpoint rule's local error, h³x‴/12,
    /// per unit h.
    pub(super) fn mean_velocity_error_energy(&self, end: &State, h: f64) -> f64 {
        let (older, last) = (&self.recent_means[0], &self.recent_means[1]);
        let now = self.step_means(end, h);
        // Mid-step times, relative to the last step's middle; v″ from divided differences,
        // so the estimate h²v″/12 is the current step's whatever the previous sizes.
        let (t_older, t_now) = (-0.5 * (older.h + last.h), 0.5 * (last.h + h));
        let second = |a: V3<f64>, b: V3<f64>, c: V3<f64>| {
            ((c - b).scale_f(1.0 / t_now) - (b - a).scale_f(1.0 / -t_older))
                .scale_f(2.0 / (t_now - t_older) * h * h / 12.0)
        };
        let mut energy = 0.0;
        for (k, inertia) in self.system.inertias.iter().enumerate() {
            let dv = second(older.means[k].0, last.means[k].0, now.means[k].0);
            let dw = second(older.means[k].1, last.means[k].1, now.means[k].1);
            let dw_body = end.nodes[inertia.node].r.transpose().mul_v(&dw);
            energy += 0.5 * inertia.mass * dv.norm_sq()
                + 0.5 * dw_body.dot(&inertia.inertia.mul_v(&dw_body));
        }
        energy
    }

    /// EP's first two steps have too little history: their error is estimated by step
    /// doubling — the full step against two halves, whose end positions differ by ¾ of the
    /// full step's local error (local error ∝ h³) — in the same energy measure.
    pub(super) fn doubling_error(&mut self, end: &State, h: f64) -> Result<f64, StepFailure> {
        let (mid, _) = self.integrator.step(&self.system, &self.state, 0.5 * h)?;
        let (half, _) = self.integrator.step(&self.system, &mid, 0.5 * h)?;
        let mut energy = 0.0;
        for k in &self.system.inertias {
            let (a, b) = (&end.nodes[k.node], &half.nodes[k.node]);
            let dv = (a.x - b.x).scale_f(4.0 / 3.0 / h);
            let dw = rotation_between(&b.r, &a.r).scale_f(4.0 / 3.0 / h);
            energy += 0.5 * k.mass * dv.norm_sq() + 0.5 * dw.dot(&k.inertia.mul_v(&dw));
        }
        Ok(self.relative_error(energy, end))
    }

    /// One adaptive step: tried with the proposed size, rejected and retried smaller while its
    /// error indicator exceeds 1 or Newton fails. The next size aims at e = 0.8:
    /// `h·(0.8/e)^(1/q)` within the growth and shrink limits (DESIGN 8.6), with q the indicator's
    /// observed order in h — nominally 2, but ED's jump energy steepens to q ≈ 4 as ωh nears 1
    /// on a fast mode, where a fixed exponent would alternate between too long and rejected
    /// steps. A step right after a rejection does not grow, nor one that would grow by less
    /// than 25 %.
    pub(super) fn adaptive_step(&mut self) -> Result<(), StepFailure> {
        let set = &self.settings;
        let (dt_min, dt_max) = (set.dt_min(), set.dt_max());
        let (grow, shrink) = (set.max_growth, set.max_shrink);
        let remaining = set.t_end - self.state.t;
        let mut h = self.h_next.min(dt_max);
        // Land on t_end, without leaving a sliver of a last step.
        if h >= remaining || remaining < 1.25 * h {
            h = if h >= remaining {
                remaining
            } else {
                0.5 * remaining
            };
        }
        let mut rejected = false;
        let mut previous_trial = None;
        loop {
            self.follow_contacts();
            let tried =
                self.integrator
                    .step(&self.system, &self.state, h)
                    .and_then(|(state, report)| {
                        let e = self.local_error(&state, h, &report)?;
                        Ok((state, report, e))
                    });
            match tried {
                Ok((state, report, e)) => {
                    let factor = self.step_factor(h, e).clamp(shrink, grow);
                    // An indicator that a step 1.5× shorter barely lowered (an order in h below
                    // 0.26) measures the state, not the step — ED's jump settling the velocity
                    // the step before left off its joints' tangent: no shorter step would meet
                    // it, so take this one.
                    let stuck =
                        previous_trial.is_some_and(|(h0, e0)| h < 0.67 * h0 && e > 0.9 * e0);
                    previous_trial = Some((h, e));
                    if e <= 1.0 || stuck {
                        if e > 1.0 {
                            self.stats.over_tolerance += 1;
                        }
                        self.accept(state, report, h);
                        let factor = if rejected { factor.min(1.0) } else { factor };
                        // Keep h through small increases: an unchanged step keeps modified
                        // Newton's factors valid (the Newton matrix depends on h).
                        let factor = if (1.0..1.25).contains(&factor) {
                            1.0
                        } else {
                            factor
                        };
                        self.h_next = (h * factor).clamp(dt_min, dt_max);
                        return Ok(());
                    }
                    self.stats.rejected += 1;
                    rejected = true;
                    if h <= dt_min * (1.0 + 1e-12) {
                        return Err(StepFailure {
                            t: self.state.t,
                            h,
                            reason: format!("the error tolerance {:.1e} cannot be met even with the smallest step dt_min = {dt_min:.3e} s (error indicator {e:.2}); loosen `tolerance` or lower `dt_min`", self.settings.tolerance),
                            retry: false,
                            load_factor: None,
                        });
                    }
                    h = (h * factor.min(0.9)).max(dt_min);
                }
                Err(e) if e.retry && h > dt_min * (1.0 + 1e-12) => {
                    self.stats.rejected += 1;
                    self.stats.halvings += 1;
                    rejected = true;
                    h = (0.25 * h).max(dt_min);
                }
                Err(e) => return Err(e),
            }
        }
    }

    /// The factor on `h` that brings the indicator `e` to 0.8, updating the indicator's
    /// observed order q from the previous trial (kept within [1, 4]; 2 until measured).
    pub(super) fn step_factor(&mut self, h: f64, e: f64) -> f64 {
        if e <= 0.0 {
            return f64::INFINITY;
        }
        if let Some((h0, e0)) = self.last_trial {
            let ratio = h / h0;
            if e0 > 0.0 && !(0.9..=1.1).contains(&ratio) {
                self.error_order = ((e / e0).ln() / ratio.ln()).clamp(1.0, 4.0);
            }
        }
        self.last_trial = Some((h, e));
        (0.8 / e).powf(1.0 / self.error_order)
    }
}

/// The rotation parameters (Cayley) taking `from` to `to` in `from`'s frame; a half-turn or
/// more (never within a converged step) reads as infinite.
pub(super) fn rotation_between(from: &crate::vec3::M3<f64>, to: &crate::vec3::M3<f64>) -> V3<f64> {
    crate::rotation::cayley_log(&from.transpose().mul_m(to)).unwrap_or(V3([f64::INFINITY; 3]))
}
