//! Adaptive steps (DESIGN 8.6): a local error indicator judged against the tolerance decides
//! whether a converged step is accepted and how long the next one is.

use super::{Simulation, StepMeans};
use crate::integrator::{StepFailure, StepReport};
use crate::math::vec3::V3;
use crate::model::Scheme;
use crate::state::State;

impl Simulation {
    /// The local error indicator of a converged step from the current state to `end` (e ≤ 1
    /// meets the tolerance): error energies of the step relative to the motion's energy,
    /// `e = √(E_err/E)/tol` — relative velocity errors, O(h²) for smooth motion like the global
    /// error (DESIGN 8.6). Measured in energy, content that carries little of it (a faint
    /// high-frequency ring of a stiff beam) does not drive the step down.
    /// - Both schemes: the kinetic energy of the step's local error estimated from the mean
    ///   velocities of the last three steps (`Δx/h` and the spatial `R r/h`): h²v″/12, the
    ///   midpoint rule's h³x‴/12 per unit h, with v″ from divided differences. End-of-step
    ///   velocities are not used: with joints they carry EP's undamped period-2 ripple (an
    ///   index-3 trait of the midpoint rule) and ED's velocity off the joints' tangent. The
    ///   first two steps, lacking history, are checked by step doubling. Below the round-off
    ///   of positions it is not error.
    /// - ED also: the step's jump energy (ed-scheme-notes §3.4), the energy ED takes from
    ///   motion it does not resolve — the nutation of a fast top, the high-frequency ring a
    ///   sliding contact keeps exciting in a beam, which carries its loads (the beam slider's
    ///   mid-span force is 5× less accurate at the same tolerance without it).
    /// - Translations and rotations are each judged against their own kind of motion energy
    ///   (kinetic, plus the strain and spring energy either can take), strain jumps against
    ///   all of it: a heavy top's precession error against its precession, not its 35×
    ///   larger spin (measured: error per tolerance 3–26 → 1.6–3.3 under EP, 10–22 → 6–8
    ///   under ED).
    /// - E is never below the model's energy floor (`energy_scale.rs`): from rest the motion's
    ///   energy so far is ~0, and any error would be relatively huge at every step size.
    pub(super) fn local_error(
        &mut self,
        end: &State,
        h: f64,
        report: &StepReport,
    ) -> Result<(f64, SetBy), StepFailure> {
        let motion = if self.recent_means.len() < 2 {
            self.doubling_error(end, h)?
        } else {
            self.mean_velocity_error_energy(end, h)
        };
        let noise = self.roundoff_energy(h);
        let spin = [0.0, self.spin_rate_error_energy(end, h)];
        let scales = self.energy_scales(end);
        // [translational, rotational] errors against scales [total, translational, rotational].
        let tol = self.settings.tolerance;
        let judged = |spin: [f64; 2]| {
            (0..2)
                .map(|k| {
                    relative(
                        (motion[k] - noise[k]).max(0.0) + spin[k],
                        scales[k + 1],
                        tol,
                    )
                })
                .fold(0.0, f64::max)
        };
        let (smoothness, motion) = (judged([0.0; 2]), judged(spin));
        // ED's jumps likewise: of translations, rotations, and strains (against all).
        let d = report.jump_energies;
        let jump = match self.settings.scheme {
            Scheme::Ep => 0.0,
            Scheme::Ed => [(d[0], scales[1]), (d[1], scales[2]), (d[2], scales[0])]
                .iter()
                .map(|&(e, scale)| relative(e.max(0.0), scale, tol))
                .fold(0.0, f64::max),
        };
        // What set the step: the largest term; the spin when its error energy is the larger
        // part of `motion`'s (motion² = smoothness² + spin² within a kind).
        let by = if jump > motion {
            SetBy::Jumps
        } else if motion > std::f64::consts::SQRT_2 * smoothness {
            SetBy::Spin
        } else {
            SetBy::Motion
        };
        Ok((motion.max(jump), by))
    }

    /// The energy scales including the end state: total, translational and rotational
    /// motion energy (see [`Simulation::motion_energies`]), each the largest so far and
    /// never below the model's floor.
    fn energy_scales(&self, end: &State) -> [f64; 3] {
        let now = self.motion_energies(end);
        std::array::from_fn(|k| self.energy_scale[k].max(now[k]))
    }

    /// Motion energies of a state: total (kinetic + strain + spring), and the translational
    /// and rotational kinetic energies each with the strain and spring energy. From the memo:
    /// the error indicator asks about a step's end, which its acceptance then asks about again.
    pub(super) fn motion_energies(&self, s: &State) -> [f64; 3] {
        self.energy_memo.energies(&self.system, s).motion_parts()
    }

    /// Mean velocity and spatial angular velocity over a step to `end`, of each node carrying
    /// inertia. The angle turned is the exact one (the rotation vector), not Cayley's
    /// `2 tan(θ/2)`: that reads a steady spin ω as `ω (1 + (ωh)²/12)`, a bias that changes
    /// with h, so every change of step size showed a spinning body as accelerating (a
    /// jackscrew's nut at 100 rad/s: indicator 0.003 at h, 1.96 at 2h; every other step
    /// rejected).
    pub(super) fn step_means(&self, end: &State, h: f64) -> StepMeans {
        let means = self
            .system
            .inertias
            .iter()
            .map(|k| {
                let (a, b) = (&self.state.nodes[k.node], &end.nodes[k.node]);
                let v = (b.x - a.x).scale_f(1.0 / h);
                let w = a.r.mul_v(&turned(&a.r, &b.r)).scale_f(1.0 / h);
                (v, w)
            })
            .collect();
        StepMeans { h, means }
    }

    /// EP's error energy `Σ ½ m |δv|² + ½ δωᵀ J δω` (J turned to the inertial frame): δ the
    /// step's mean velocities minus their linear extrapolation from the previous two steps'
    /// (an error ≈ h² v″ at equal steps), over 12 — the midpoint rule's local error, h³x‴/12,
    /// per unit h.
    pub(super) fn mean_velocity_error_energy(&self, end: &State, h: f64) -> [f64; 2] {
        let (older, last) = (&self.recent_means[0], &self.recent_means[1]);
        let now = self.step_means(end, h);
        // Mid-step times, relative to the last step's middle; v″ from divided differences,
        // so the estimate h²v″/12 is the current step's whatever the previous sizes.
        let (t_older, t_now) = (-0.5 * (older.h + last.h), 0.5 * (last.h + h));
        let second = |a: V3<f64>, b: V3<f64>, c: V3<f64>| {
            ((c - b).scale_f(1.0 / t_now) - (b - a).scale_f(1.0 / -t_older))
                .scale_f(2.0 / (t_now - t_older) * h * h / 12.0)
        };
        let mut energy = [0.0; 2];
        for (k, inertia) in self.system.inertias.iter().enumerate() {
            let dv = second(older.means[k].0, last.means[k].0, now.means[k].0);
            let dw = second(older.means[k].1, last.means[k].1, now.means[k].1);
            let dw_body = end.nodes[inertia.node].r.transpose().mul_v(&dw);
            energy[0] += 0.5 * inertia.mass * dv.norm_sq();
            energy[1] += 0.5 * dw_body.dot(&inertia.inertia.mul_v(&dw_body));
        }
        energy
    }

    /// The error energy of the schemes' angular velocities on a spin, `Σ ½ δᵀ J δ`. Both
    /// schemes tie a step's rotation to their angular velocities through Cayley's parameters
    /// (`r = h (W_i + W_f)/2`), so a steady spin ω turning θ = ωh per step carries the
    /// angular velocity `2 tan(θ/2)/h = ω (1 + (ωh)²/12 + …)`: the reported spin is off by
    /// δ, and a free spin's phase drifts at the same rate. The divided differences of
    /// [`Simulation::mean_velocity_error_energy`] cannot see it (it is steady), and without
    /// it a driven nut at ωh = 1.3 reported its spin 28 % high at the default tolerance.
    pub(super) fn spin_rate_error_energy(&self, end: &State, h: f64) -> f64 {
        self.system.inertias.iter().fold(0.0, |energy, k| {
            let (a, b) = (&self.state.nodes[k.node].r, &end.nodes[k.node].r);
            let angle = turned(a, b);
            let delta = angle.scale_f(cayley_excess(0.5 * angle.norm()) / h);
            energy + 0.5 * delta.dot(&k.inertia.mul_v(&delta))
        })
    }

    /// The first two steps have too little history: their error energy is estimated by step
    /// doubling — the full step against two halves, whose end positions differ by ¾ of the
    /// full step's local error (local error ∝ h³) — in the same energy measure. Under EP the
    /// end velocities are compared too (their ripple has not built up yet): a mechanism
    /// whose drives prescribe every motion has exact positions at any step size, and
    /// positions alone let its second step grow tenfold, which starts EP's undamped
    /// multiplier ripple for the whole run (a slider-crank's rail force ±200 N off a 37 N
    /// peak).
    pub(super) fn doubling_error(&mut self, end: &State, h: f64) -> Result<[f64; 2], StepFailure> {
        let (mid, _) = self.integrator.step(&self.system, &self.state, 0.5 * h)?;
        let (half, _) = self.integrator.step(&self.system, &mid, 0.5 * h)?;
        let velocities = self.settings.scheme == Scheme::Ep;
        let mut energy = [0.0; 2];
        for k in &self.system.inertias {
            let (a, b) = (&end.nodes[k.node], &half.nodes[k.node]);
            let mut dv = (a.x - b.x).scale_f(4.0 / 3.0 / h);
            let mut dw = rotation_between(&b.r, &a.r).scale_f(4.0 / 3.0 / h);
            if velocities {
                dv = dv + (a.v - b.v).scale_f(4.0 / 3.0);
                dw = dw + (a.w - b.w).scale_f(4.0 / 3.0);
            }
            energy[0] += 0.5 * k.mass * dv.norm_sq();
            energy[1] += 0.5 * dw.dot(&k.inertia.mul_v(&dw));
        }
        Ok(energy)
    }

    /// The error energy round-off alone shows at step `h`: positions are known to ~ε of the
    /// model's size, so mean velocities carry ~ε L/h of noise, and a drive's own round-off
    /// (cancellation in its expression) a few times that. An estimate below 16 times it is
    /// noise, not error — without this, smaller steps would only look worse.
    pub(super) fn roundoff_energy(&self, h: f64) -> [f64; 2] {
        let dv = 16.0 * f64::EPSILON * self.system.length_ref / h;
        let dw = 16.0 * f64::EPSILON / h;
        self.system.inertias.iter().fold([0.0; 2], |[t, r], k| {
            [
                t + 0.5 * k.mass * dv * dv,
                r + 0.5 * k.inertia.trace() * dw * dw,
            ]
        })
    }

    /// One adaptive step: tried with the proposed size, rejected and retried smaller while
    /// its error indicator exceeds 1 or Newton fails; the next size comes from the
    /// [`Controller`]. A trial whose indicator a 1.5× shorter step barely lowered measures
    /// the state, not the step (ED's jump settling a velocity the step before left off its
    /// joints' tangent; a prescribed velocity jump): no shorter step would meet it, so it is
    /// taken and counted in `over_tolerance`.
    pub(super) fn adaptive_step(&mut self) -> Result<(), StepFailure> {
        let (dt_min, dt_max) = (self.settings.dt_min(), self.settings.dt_max());
        let mut h = self.first_trial();
        let first_h = h;
        let mut previous_trial: Option<(f64, f64)> = None;
        loop {
            self.follow_contacts();
            let tried = self.step_with_friction(h).and_then(|step| {
                let (e, by) = self.local_error(&step.state, step.h, &step.report)?;
                Ok((step, e, by))
            });
            match tried {
                Ok((step, e, by)) => {
                    let (state, report, event) = (step.state, step.report, step.event);
                    // A friction event ends the step early: that is the step taken. The
                    // size after it comes from the size tried, not from the sliver a
                    // located event left (which would make every next event's sliver
                    // smaller still).
                    let tried_h = h;
                    h = step.h;
                    let jump = self.load_jump_at(self.state.t + h);
                    let stuck =
                        previous_trial.is_some_and(|(h0, e0)| h < 0.67 * h0 && e > 0.9 * e0);
                    previous_trial = Some((h, e));
                    if e <= 1.0 || stuck {
                        if e > 1.0 {
                            self.stats.over_tolerance += 1;
                        }
                        let mut state = state;
                        if let Some(t) = jump {
                            // Exactly on the jump: the next step starts on its far side.
                            state.t = t;
                        }
                        self.accept(state, report, h);
                        self.stats.steps_set_by[by as usize] += 1;
                        let factor = self.controller.accepted(e, &self.settings);
                        let scheme = self.settings.scheme;
                        let keep =
                            self.settings.modified_newton && Controller::holds(e, factor, scheme);
                        self.h_next = if keep {
                            h
                        } else {
                            (h * factor).clamp(dt_min, dt_max)
                        };
                        if h < tried_h {
                            self.h_next = self.h_next.max(tried_h.min(dt_max));
                        }
                        if event || jump.is_some() {
                            // The motion's history says nothing about the motion after a
                            // stick–slip event or a load's jump: start afresh, from the
                            // size asked before it.
                            self.recent_means.clear();
                            self.controller = Controller::default();
                            self.h_next = self.h_next.max(first_h.min(dt_max));
                        }
                        return Ok(());
                    }
                    self.stats.rejected += 1;
                    if h <= dt_min * (1.0 + 1e-12) {
                        return Err(self.cannot_continue(h, first_h, format!("the error tolerance {:.1e} cannot be met even with the smallest step dt_min = {dt_min:.3e} s (error indicator {e:.2}); loosen `tolerance` or lower `dt_min`", self.settings.tolerance)));
                    }
                    h = (h * self.controller.rejected(e, &self.settings)).max(dt_min);
                }
                Err(e) if e.retry && h > dt_min * (1.0 + 1e-12) => {
                    self.stats.rejected += 1;
                    self.stats.halvings += 1;
                    self.note_retried_failure(&e);
                    self.controller.failed();
                    h = (0.25 * h).max(dt_min);
                }
                Err(e) if e.retry => return Err(self.cannot_continue(h, first_h, e.reason)),
                Err(e) => return Err(e),
            }
        }
    }

    /// The size of the first trial: the proposed one, landing on the next load jump or
    /// t_end without leaving a last step much shorter than the one before it.
    fn first_trial(&self) -> f64 {
        let remaining = self.next_landing() - self.state.t;
        let h = self.h_next.min(self.settings.dt_max());
        if remaining < 4.0 * h {
            // The last few steps equal, rather than h and a sliver: a step much shorter
            // than the one before excites EP's undamped period-2 multiplier ripple.
            remaining / (remaining / h).ceil()
        } else {
            h
        }
    }

    /// Where the next steps must end: the first load jump after the current time
    /// ([`crate::system::System::load_jump_times`]), else t_end.
    fn next_landing(&self) -> f64 {
        let t = self.state.t;
        let ahead = self
            .load_jumps
            .partition_point(|&j| j <= t + LANDED * j.abs());
        self.load_jumps
            .get(ahead)
            .map_or(self.settings.t_end, |&j| j.min(self.settings.t_end))
    }

    /// The load jump a step ending at `t` ends on, if any (within round-off of it).
    fn load_jump_at(&self, t: f64) -> Option<f64> {
        let near = self
            .load_jumps
            .partition_point(|&j| j < t - LANDED * j.abs());
        self.load_jumps
            .get(near)
            .copied()
            .filter(|&j| (j - t).abs() <= LANDED * j.abs())
    }

    /// The failure of a step that shrank to dt_min. If a drive or load is undefined just
    /// ahead (the steps shrank towards a singularity such as `sqrt(0.3 - t)` at 0.3 s), that
    /// is the cause, and the message says so.
    fn cannot_continue(&self, h: f64, first_h: f64, reason: String) -> StepFailure {
        let t = self.state.t;
        // Up to the longest step taken so far: the steps may have shrunk over many of them.
        let horizon = (2.0 * first_h)
            .max(self.stats.dt_largest)
            .min(self.settings.t_end - t);
        let ahead = (1..=64).map(|k| t + horizon * k as f64 / 64.0);
        let reason = match ahead
            .filter_map(|t_f| self.system.undefined_time_function(t, t_f))
            .next()
        {
            Some(why) => format!("the steps shrank to dt_min approaching a singularity: {why}"),
            None => match self.system.time_function_jump(t) {
                Some(why) => format!("the steps shrank to dt_min: {why}"),
                None => reason,
            },
        };
        StepFailure {
            t,
            h,
            reason,
            retry: false,
            load_factor: None,
            row: None,
        }
    }
}

/// Which term of the error indicator was the largest on an accepted adaptive step
/// (`RunStats::steps_set_by`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SetBy {
    /// The motion's smoothness, h²v″/12 (or step doubling).
    Motion = 0,
    /// A spin's rate error under Cayley's parameters (`spin_rate_error_energy`).
    Spin = 1,
    /// ED's jump energies.
    Jumps = 2,
}

/// A step end this close (relative) to a load jump is on it.
const LANDED: f64 = 1e-12;

/// `√(E_err/E)/tol`; zero while nothing moves or strains.
fn relative(error_energy: f64, scale: f64, tol: f64) -> f64 {
    if scale <= 0.0 {
        return 0.0;
    }
    (error_energy / scale).sqrt() / tol
}

/// Step-size selection: a PI controller (Gustafsson; Hairer & Wanner II, IV.2) on the error
/// indicator e ∝ h^q, aiming at e = 0.8. The proportional part, through the previous step's
/// indicator, damps the step-to-step oscillation of a plain `(0.8/e)^(1/q)` rule on a noisy
/// indicator (EP's undamped beam vibration), which otherwise grows steps into rejections.
#[derive(Clone, Debug, Default)]
pub struct Controller {
    /// The last accepted step's indicator.
    last: Option<f64>,
    /// Whether the step being chosen follows a rejection (it may not grow).
    after_rejection: bool,
}

/// The indicator's nominal order in h: relative velocity errors h²v″/12, jump velocities
/// h²v″/6.
const ORDER: f64 = 2.0;
/// The indicator a step aims at.
const TARGET: f64 = 0.6;
/// Modified Newton holds h while it could grow by less than this factor (e from 0.36 up to
/// the target).
const HOLD_ABOVE: f64 = 1.3;
/// Under ED it also holds h while it would shrink by less than this one (e from the target
/// up to 0.83): the controller aims at the target, so about half of the steps land just
/// above it, and each one's few-percent shrink cost a fresh tangent and LU (adaptive free
/// collar, 2 s: 1392 factorizations in 2568 steps, 737 in 2549 with the band; −11 % time;
/// beam pendulum −6 %). EP never holds a shrink: held runs then a shrink make the step
/// sizes change every two or three steps in a steady shrink, which drives EP's undamped
/// period-2 multiplier ripple (a spun-up arm's motor torque 3.8e-3 of its peak off, 1.3e-3
/// without; holding every other step, earlier, made it 10× worse); ED's dissipation
/// annihilates that mode (the same arm: 2.2e-4).
const HOLD_BELOW_ED: f64 = 0.85;

impl Controller {
    /// The factor on h for the step after an accepted one with indicator `e`.
    pub fn accepted(&mut self, e: f64, set: &crate::model::SimulationSettings) -> f64 {
        let e = e.max(1e-10);
        let integral = (TARGET / e).powf(0.7 / ORDER);
        let proportional = self.last.map_or((TARGET / e).powf(0.3 / ORDER), |last| {
            (last.max(1e-10) / TARGET).powf(0.4 / ORDER)
        });
        // The first step is only a guess (`dt`): it may grow tenfold at once, so a run whose
        // motion allows long steps does not crawl up to them.
        let growth = if self.last.is_none() {
            set.max_growth.max(10.0)
        } else {
            set.max_growth
        };
        let mut factor = (integral * proportional).clamp(set.max_shrink, growth);
        if std::mem::take(&mut self.after_rejection) {
            factor = factor.min(1.0);
        }
        self.last = Some(e);
        factor
    }

    /// Under modified Newton, whether the next step keeps this one's size `h` although the
    /// controller proposed `factor`: an unchanged step keeps its LU factors valid (the
    /// Newton matrix depends on h), worth more than a step 30 % longer. Judged on the
    /// elementary factor `(TARGET/e)^(1/q)`, not the PI one: held steps repeat the same
    /// indicator, and the PI factor's proportional part would then settle near 1 and
    /// never let h grow (measured: ED beam pendulum 726 steps instead of 316).
    /// `scheme`: ED also holds slight shrinks ([`HOLD_BELOW_ED`]).
    pub fn holds(e: f64, factor: f64, scheme: Scheme) -> bool {
        let elementary = (TARGET / e.max(1e-10)).powf(1.0 / ORDER);
        let lowest = match scheme {
            Scheme::Ed => HOLD_BELOW_ED,
            Scheme::Ep => 1.0,
        };
        factor < HOLD_ABOVE && (lowest..HOLD_ABOVE).contains(&elementary)
    }

    /// The factor on h for the retry of a step rejected with indicator `e` (< 0.9).
    pub fn rejected(&mut self, e: f64, set: &crate::model::SimulationSettings) -> f64 {
        self.after_rejection = true;
        (0.9 * (TARGET / e).powf(1.0 / ORDER)).clamp(set.max_shrink, 0.9)
    }

    /// A step whose Newton iteration failed (retried at a quarter).
    pub fn failed(&mut self) {
        self.after_rejection = true;
    }
}

/// The rotation vector (angle × axis) taking `from` to `to` in `from`'s frame; a half-turn or
/// more (never within a converged step) reads as infinite.
fn turned(from: &crate::math::vec3::M3<f64>, to: &crate::math::vec3::M3<f64>) -> V3<f64> {
    let relative = from.transpose().mul_m(to);
    match crate::math::rotation::cayley_log(&relative) {
        Ok(_) => crate::math::rotation::log_map(&relative),
        Err(_) => V3([f64::INFINITY; 3]),
    }
}

/// `tan x / x − 1` (x half the angle turned): Cayley's parameters `2 tan(θ/2)` over the
/// angle θ, less one, without cancellation at small angles.
fn cayley_excess(x: f64) -> f64 {
    if x < 1e-3 {
        // tan x / x = 1 + x²/3 + 2x⁴/15 + …, the next term below 1e-15 relative.
        let x2 = x * x;
        x2 / 3.0 + 2.0 * x2 * x2 / 15.0
    } else if x < 0.5 * std::f64::consts::PI {
        x.tan() / x - 1.0
    } else {
        f64::INFINITY
    }
}

/// The rotation parameters (Cayley) taking `from` to `to` in `from`'s frame; a half-turn or
/// more (never within a converged step) reads as infinite.
pub(super) fn rotation_between(
    from: &crate::math::vec3::M3<f64>,
    to: &crate::math::vec3::M3<f64>,
) -> V3<f64> {
    crate::math::rotation::cayley_log(&from.transpose().mul_m(to)).unwrap_or(V3([f64::INFINITY; 3]))
}

#[cfg(test)]
mod tests {
    use super::{cayley_excess, Controller};

    /// The hold band under modified Newton: both schemes hold a step that could grow by
    /// less than 1.3, ED also one that would shrink by less than 15 %; neither holds a
    /// larger change, nor a step the PI factor would grow by 1.3 or more.
    #[test]
    fn steps_are_held_within_the_band_of_their_scheme() {
        use crate::model::Scheme::{Ed, Ep};
        // Indicators and their elementary factors (0.6/e)^½.
        let grow = 0.5; // 1.095
        let slight_shrink = 0.75; // 0.894
        let shrink = 0.9; // 0.816
        let big_grow = 0.3; // 1.414
        for scheme in [Ep, Ed] {
            assert!(Controller::holds(grow, 1.05, scheme));
            assert!(!Controller::holds(grow, 1.35, scheme));
            assert!(!Controller::holds(shrink, 0.85, scheme));
            assert!(!Controller::holds(big_grow, 1.2, scheme));
        }
        assert!(Controller::holds(slight_shrink, 0.92, Ed));
        assert!(!Controller::holds(slight_shrink, 0.92, Ep));
    }

    #[test]
    fn cayley_excess_is_tan_x_over_x_less_one_across_its_series_switch() {
        for x in [1e-6_f64, 1e-4, 0.999e-3, 1.001e-3, 0.1, 1.0, 1.5] {
            let series = x * x / 3.0 + 2.0 * x.powi(4) / 15.0 + 17.0 * x.powi(6) / 315.0;
            let direct = x.tan() / x - 1.0;
            // The direct form loses digits to cancellation below 1e-3 (ε/x²); the series
            // loses its x⁶ term above it: each is the reference where it is exact.
            let reference = if x < 0.01 { series } else { direct };
            assert!(
                (cayley_excess(x) - reference).abs() <= 1e-9 * reference,
                "{x}"
            );
        }
        assert_eq!(cayley_excess(1.6), f64::INFINITY);
    }
}
