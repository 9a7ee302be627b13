//! The velocities a start pre-loaded in motion needs: the rate at which its quasi-static
//! equilibrium moves.
//!
//! The start first gives the beams the rigid motion of their supports (least strain rate,
//! `initial_velocities`), then strains them by the motion's loads (`inertial_preload`). For a
//! deflection that turns with the structure — a blade stretched by its spin — the rigid
//! motion of the deflected shape is its rate. For one that stays in space while the structure
//! turns through it — a shaft's sag under gravity, spinning on its bearings — it is not: the
//! sag was carried round with the spin (its mid-span given `Ω × sag`), and the shaft whirled
//! at its bending mode by about Ω/ω₁ of its sag for the whole run (a 2 m steel tube at 50
//! rad/s: ±1.2e-5 m on 9.0e-5 m).
//!
//! Here the velocities `V_r` become `V_r + δV` with the pre-load's static equations `R` kept
//! in balance to first order in time: `J δV = −∂R/∂t − J V_r` on the force rows (`J` their
//! static tangent), the constraint rows left as `V_r` meets them, the velocities the model
//! gave held. The d'Alembert loads, constant in the static solve, turn with their nodes
//! (`ω × f`); gravity and fixed loads do not, which is the whole correction for the shaft.
//! Where the tangent does not factor (free rigid motions) `V_r` stays.

use crate::math::layout::Layout;
use crate::math::vec3::V3;
use crate::state::State;
use crate::system::System;

use super::Simulation;

/// A node's d'Alembert force and moment in the pre-load (spatial).
pub(super) type NodeLoad = (usize, V3<f64>, V3<f64>);

/// Time over which `∂R/∂t` is differenced (s): central differences of drives and load
/// functions, exact for the linear and quadratic ones.
const RATE_DT: f64 = 1e-6;

/// Replaces `state`'s velocities by the quasi-static rate of the equilibrium `pre` found
/// (see the module notes), then projects them onto the joints' velocity conditions.
pub(super) fn correct_velocities(
    pre: &mut Simulation,
    system: &System,
    state: &mut State,
    loads: &[NodeLoad],
) {
    let lay = pre.system.layout;
    let rates = rates_of(&lay, state);
    let mut rhs = equilibrium_rate(pre, state, &rates, loads);
    let held = given_rows(system, &lay);
    if !solve_held(pre, &held, &mut rhs) {
        return;
    }
    if !beyond_round_off(pre, system, state, &rhs) {
        return;
    }
    for (a, node) in state.nodes.iter_mut().enumerate() {
        let d = lay.node_delta(a);
        node.v += V3([rhs[d], rhs[d + 1], rhs[d + 2]]);
        node.w += V3([rhs[d + 3], rhs[d + 4], rhs[d + 5]]);
    }
    for c in 0..lay.n_coords {
        state.coord_rates[c] += rhs[lay.coord_delta(c)];
    }
    super::initial_velocities::project_velocities(system, state);
}

/// `state`'s velocities as rates of the static unknowns: `v` and the material `W` per node,
/// the coordinates' rates, no multiplier rates.
fn rates_of(lay: &Layout, state: &State) -> Vec<f64> {
    let mut rates = vec![0.0; lay.n_unknowns()];
    for (a, node) in state.nodes.iter().enumerate() {
        let d = lay.node_delta(a);
        rates[d..d + 3].copy_from_slice(&node.v.0);
        rates[d + 3..d + 6].copy_from_slice(&node.w.0);
    }
    for c in 0..lay.n_coords {
        rates[lay.coord_delta(c)] = state.coord_rates[c];
    }
    rates
}

/// `−∂R/∂t − J V_r` with the d'Alembert `loads` turning with their nodes, on the force rows;
/// zero on the constraint rows.
fn equilibrium_rate(
    pre: &mut Simulation,
    state: &State,
    rates: &[f64],
    loads: &[NodeLoad],
) -> Vec<f64> {
    let lay = pre.system.layout;
    let mut at = pre.state.clone();
    at.t = pre.state.t + RATE_DT;
    let later = pre
        .integrator
        .static_residual(&pre.system, &at, 1.0)
        .to_vec();
    at.t = pre.state.t - RATE_DT;
    let earlier = pre.integrator.static_residual(&pre.system, &at, 1.0);
    let mut rhs: Vec<f64> = later
        .iter()
        .zip(earlier)
        .map(|(l, e)| -(l - e) / (2.0 * RATE_DT))
        .collect();
    let (col_ptr, row_idx, values) = pre.integrator.static_tangent(&pre.system, &pre.state, 1.0);
    for (j, &x) in rates.iter().enumerate() {
        for p in col_ptr[j]..col_ptr[j + 1] {
            rhs[row_idx[p]] -= values[p] * x;
        }
    }
    // A load's residual is `−f` on the force rows, `−R_fᵀ m` on the (material) moment rows.
    for &(a, force, moment) in loads {
        let omega = state.nodes[a].r.mul_v(&state.nodes[a].w);
        let d = lay.node_delta(a);
        let df = omega.cross(&force);
        let dm = pre.state.nodes[a].r.tmul_v(&omega.cross(&moment));
        for i in 0..3 {
            rhs[d + i] += df.0[i];
            rhs[d + 3 + i] += dm.0[i];
        }
    }
    let first_row = if lay.n_rows > 0 {
        lay.mult(0)
    } else {
        rhs.len()
    };
    rhs[first_row..].iter_mut().for_each(|r| *r = 0.0);
    rhs
}

/// The static unknowns of the velocities the model gave (`system.velocity_given`).
fn given_rows(system: &System, lay: &Layout) -> Vec<bool> {
    let mut held = vec![false; lay.n_unknowns()];
    for (a, given) in system.velocity_given.iter().enumerate() {
        let d = lay.node_delta(a);
        for (part, on) in [given.translation, given.rotation].into_iter().enumerate() {
            held[d + 3 * part..d + 3 * part + 3].fill(on);
        }
    }
    held
}

/// Solves the tangent assembled last (`equilibrium_rate`) for `rhs` in place, the `held`
/// unknowns' rows made `δ = 0`; false if it does not factor or the solution is not finite.
fn solve_held(pre: &mut Simulation, held: &[bool], rhs: &mut [f64]) -> bool {
    let matrix = &mut pre.integrator.matrix;
    let (col_ptr, row_idx) = matrix.pattern();
    let (col_ptr, row_idx) = (col_ptr.to_vec(), row_idx.to_vec());
    for (j, w) in col_ptr.windows(2).enumerate() {
        let column = matrix.values[w[0]..w[1]]
            .iter_mut()
            .zip(&row_idx[w[0]..w[1]]);
        for (v, &i) in column.filter(|(_, &i)| held[i]) {
            *v = if i == j { 1.0 } else { 0.0 };
        }
    }
    for (r, &h) in rhs.iter_mut().zip(held) {
        if h {
            *r = 0.0;
        }
    }
    if matrix.factor().is_err() {
        return false;
    }
    matrix.solve(rhs);
    rhs.iter().all(|v| v.is_finite())
}

/// Whether the correction `delta` exceeds what the static solve's tolerance leaves: below it,
/// it is that solve's residual turned by the motion (a rotor's exact rigid spin moved by
/// 2e-11 of its speed), and the rigid motion stays.
fn beyond_round_off(pre: &Simulation, system: &System, state: &State, delta: &[f64]) -> bool {
    let (lay, l) = (pre.system.layout, system.length_ref);
    let size =
        |v: &[f64], w: &[f64]| V3([v[0], v[1], v[2]]).norm() + V3([w[0], w[1], w[2]]).norm() * l;
    let scale = state
        .nodes
        .iter()
        .map(|node| size(&node.v.0, &node.w.0))
        .fold(0.0, f64::max);
    let change = (0..state.nodes.len())
        .map(|a| {
            let d = lay.node_delta(a);
            size(&delta[d..d + 3], &delta[d + 3..d + 6])
        })
        .fold(0.0, f64::max);
    change > pre.settings.newton_tol * scale
}
