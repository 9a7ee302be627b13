//! Starting a mechanism that drives already move at t = 0 with its beams strained by that
//! motion's inertial loads, so that they follow smoothly instead of ringing at their modes
//! (a connecting rod pushing a slider that must decelerate at once, a blade stretched by a
//! spin).
//!
//! 1. The accelerations of the *rigidified* mechanism — every beam made rigid by clamps
//!    between its consecutive nodes — from a solve over a vanishing step: by Gauss's
//!    principle they are the mass-weighted closest accelerations with rigid beams, so they
//!    hold for free degrees of freedom too, not only for driven ones.
//! 2. A static solve of the model under gravity, its loads at t = 0, and each node's
//!    d'Alembert force `−m a` and moment `−R(J Ẇ + W × J W)` of those accelerations (a
//!    spun node's steady-spin inertia instead, which a static solve has), drives held at
//!    t = 0. The
//!    loads balance on the rigid motions, so only the elastic ones respond.
//!
//! The beams then start in quasi-static equilibrium with the motion's loads; what remains of
//! the transient comes from their rate of change, smaller by the ratio of the motion's
//! frequency to the beams'.

use super::{SimError, Simulation};
use crate::compile;
use crate::elements::loads::{LoadKind, PointLoad};
use crate::integrator::Integrator;
use crate::math::vec3::V3;
use crate::model::{Analysis, ClampJoint, Joint, Model, Scheme, SimulationSettings};
use crate::state::State;
use crate::system::System;

/// Moves `state`'s positions to the quasi-static equilibrium with the inertial loads of its
/// motion (the velocities are then to be made consistent again at the new positions).
/// `Err` says why it could not, and leaves `state` as it was.
pub(super) fn preload(
    model: &Model,
    system: &System,
    settings: &SimulationSettings,
    state: &mut State,
) -> Result<(), String> {
    let accelerations = rigid_accelerations(model, settings, state)?;
    let mut pre = static_solve_of(model, state).map_err(|e| e.to_string())?;
    let lay = pre.system.layout;
    for inertia in &system.inertias {
        let a = inertia.node;
        if system.node_spin[a].is_some() {
            continue; // a static solve has its steady-spin inertia already
        }
        let (acc, w_dot) = accelerations[a];
        let n = &state.nodes[a];
        let force = acc.scale_f(-inertia.mass);
        let j = inertia.inertia;
        let moment =
            n.r.mul_v(&(j.mul_v(&w_dot) + n.w.cross(&j.mul_v(&n.w))))
                .scale_f(-1.0);
        for (kind, value) in [(LoadKind::Force, force), (LoadKind::Moment, moment)] {
            let load = PointLoad::new(a, kind, value, false, None, &lay);
            pre.system.loads.push(load);
        }
    }
    pre.integrator = Integrator::new(&pre.system, &pre.settings);
    pre.solve_static().map_err(|e| e.reason)?;
    check_elastic(system, state, &pre.state)?;
    super::adopt_static_positions(system, state, &pre.state);
    Ok(())
}

/// A static analysis of `model` starting from `state`'s positions.
fn static_solve_of(model: &Model, state: &State) -> Result<Simulation, SimError> {
    let mut static_model = model.clone();
    static_model.simulation.analysis = Analysis::Static;
    let mut pre = Simulation::with_scheme(&static_model, Scheme::Ep)?;
    for (p, n) in pre.state.nodes.iter_mut().zip(&state.nodes) {
        p.x = n.x;
        p.r = n.r;
    }
    pre.state.coords.clone_from(&state.coords);
    pre.state.history.clone_from(&state.history);
    Ok(pre)
}

/// A node's acceleration and material angular acceleration.
type Acceleration = (V3<f64>, V3<f64>);

/// Each node's acceleration and material angular acceleration in the rigidified mechanism.
fn rigid_accelerations(
    model: &Model,
    settings: &SimulationSettings,
    state: &State,
) -> Result<Vec<Acceleration>, String> {
    let mut rigid = compile::compile(&rigidified(model), Scheme::Ep)
        .map_err(|e| format!("the rigidified mechanism does not compile: {}", e.0[0]))?;
    let mut start = rigid.initial.clone();
    if start.nodes.len() != state.nodes.len() || start.coords.len() != state.coords.len() {
        return Err("the rigidified model numbers its nodes differently".into());
    }
    start.t = state.t;
    start.nodes.clone_from(&state.nodes);
    start.coords.clone_from(&state.coords);
    start.coord_rates.clone_from(&state.coord_rates);
    start.history.clone_from(&state.history);
    super::initial_velocities::project_velocities(&rigid, &mut start);
    super::stick_slip::start_frictions(&mut rigid, &mut start);
    let h = super::outputs::instant_step(&rigid, &start, settings.dt.min(settings.dt_max()));
    let mut ep = settings.clone();
    ep.scheme = Scheme::Ep;
    let mut integrator = Integrator::new(&rigid, &ep);
    let (end, _) = integrator
        .step(&rigid, &start, h)
        .map_err(|e| format!("the rigidified mechanism has no solution: {}", e.reason))?;
    Ok(start
        .nodes
        .iter()
        .zip(&end.nodes)
        .map(|(i, f)| ((f.v - i.v).scale_f(1.0 / h), (f.w - i.w).scale_f(1.0 / h)))
        .collect())
}

/// `model` with every beam made rigid: a clamp between each pair of consecutive nodes.
fn rigidified(model: &Model) -> Model {
    let mut rigid = model.clone();
    rigid.initial_spins.clear();
    rigid.simulation.preload = false;
    for (i, b) in model.beams.iter().enumerate() {
        for k in 0..b.node_count().saturating_sub(1) {
            rigid.joints.push(Joint::Clamp(ClampJoint {
                name: format!("__rigid_{i}_{k}"),
                node1: b.node_name(k),
                node2: b.node_name(k + 1),
            }));
        }
    }
    rigid
}

/// The pre-load may strain the beams, not move the mechanism: a free motion the loads do not
/// balance (they do only to the accuracy of the rigidification) must not run off.
fn check_elastic(system: &System, before: &State, after: &State) -> Result<(), String> {
    let l = system.length_ref;
    let (worst, a) = before
        .nodes
        .iter()
        .zip(&after.nodes)
        .map(|(b, a)| (a.x - b.x).norm() + a.r.transpose().mul_m(&b.r).axial().norm() * l)
        .zip(0..)
        .fold((0.0, 0), |m, (d, a)| if d > m.0 { (d, a) } else { m });
    if worst > 1e-2 * l {
        return Err(format!(
            "it would move node `{}` by {worst:.3e} m, more than an elastic deflection (1 % of the model size)",
            system.node_names[a]
        ));
    }
    Ok(())
}
