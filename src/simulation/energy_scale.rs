//! The energy the step-error indicator measures errors against. Errors are judged relative
//! to the motion's energy; a run that starts from rest has none, so the largest energy so far
//! is too small a scale at first (round-off then passes for error and the steps collapse).
//! The model itself says what energy its motion will have: the kinetic energy its drives
//! impose, the energy its loads can put in, and what it starts with.

use super::initial_velocities::drive_energy;
use crate::integrator::Integrator;
use crate::model::SimulationSettings;
use crate::state::State;
use crate::system::System;

/// The energy scale known before the run: the largest of the drives' kinetic energy over the
/// run and the loads' response energy (each load at the time its scale peaks).
pub fn energy_floor(
    sys: &System,
    state: &State,
    integ: &mut Integrator,
    settings: &SimulationSettings,
) -> f64 {
    let drives = drive_energy(sys, state, settings.t_end);
    // Over the whole run: a stiff structure answers with its static deflection whatever h,
    // and a mechanism's fall is then bounded by the loads' work over the model's size.
    let h = (settings.t_end - state.t).max(settings.dt);
    let loads = load_times(sys, state.t, settings.t_end)
        .into_iter()
        .filter_map(|t| {
            let mut at = state.clone();
            at.t = t;
            integ.load_response(sys, &at, h)
        })
        .fold(0.0f64, |m, r| m.max(r.energy.min(r.bound)));
    drives.max(loads)
}

/// The start, and the time at which each load's scale is largest (of 257 samples): at most
/// eight times (one factorization each).
fn load_times(sys: &System, t0: f64, t_end: f64) -> Vec<f64> {
    let mut times = vec![t0];
    for (_, f) in sys.load_scales.iter().take(7) {
        let peak = (0..=256)
            .map(|k| t0 + (t_end - t0) * k as f64 / 256.0)
            .map(|t| (t, f.value(t).abs()))
            .filter(|(_, v)| v.is_finite())
            .fold((t0, 0.0), |best, x| if x.1 > best.1 { x } else { best });
        if !times
            .iter()
            .any(|t| (t - peak.0).abs() <= 1e-12 * t_end.abs().max(1.0))
        {
            times.push(peak.0);
        }
    }
    times
}
