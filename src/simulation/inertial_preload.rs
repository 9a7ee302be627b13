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

use std::collections::HashMap;

use super::{SimError, Simulation};
use crate::compile;
use crate::elements::loads::{LoadKind, PointLoad};
use crate::integrator::Integrator;
use crate::math::time_function::TimeFunction;
use crate::math::vec3::V3;
use crate::model::{Analysis, ClampJoint, Joint, Model, Scheme, SimulationSettings};
use crate::state::State;
use crate::system::System;

use super::quasi_static_rate::NodeLoad;

/// Moves `state`'s positions to the quasi-static equilibrium with the inertial loads of its
/// motion, and its velocities to the rate at which that equilibrium moves
/// ([`super::quasi_static_rate`]). `Err` says why it could not, and leaves `state` as it was.
pub(super) fn preload(
    model: &Model,
    system: &System,
    settings: &SimulationSettings,
    state: &mut State,
) -> Result<(), String> {
    let rigid = rigid_system(model)?;
    let accelerations = rigid_accelerations(&rigid, settings, state, Drives::AsGiven)?;
    // The coordinates the rigid mechanism leaves free stay where they are (a collar on a
    // tumbling beam where it was placed): the loads balance on them, but nothing else would
    // fix them in the static solve.
    let held = holding_free_coordinates(model, system, state);
    let loads = dalembert_loads(system, state, &accelerations);
    let mut pre = preload_with(&held, system, state, &loads, MOVING_ELASTIC)?;
    super::initial_velocities::project_initial_velocities(system, state);
    super::quasi_static_rate::correct_velocities(&mut pre, system, state, &loads);
    Ok(())
}

/// The largest move of a node (plus its turn times the model's size) a pre-load may make,
/// relative to the model's size: of a mechanism in motion, whose loads balance its rigid
/// motions only as far as its rigidification holds, 1 %; of a structure at rest, whose
/// supports take the loads, 10 % (a 2 m steel cantilever's 15 mm tip sag and 0.011 rad tip
/// slope add up to 1.1 %).
const MOVING_ELASTIC: f64 = 1e-2;
const AT_REST_ELASTIC: f64 = 0.1;

/// A model at rest whose beams carry gravity, loads or joint springs off their rest at t = 0
/// starts with its beams in quasi-static equilibrium with those loads.
/// - If its rigidified mechanism, its drives held, stays at rest too — a structure, whose
///   supports and drives take the loads (a boom with a carriage, a tower, a rotor before its
///   spin-up) — that is its static equilibrium: started unstrained, its beams rang about their
///   static deflection for the whole run (a 20 kg carriage on a 2 m steel cantilever, ±14 mm
///   about its 10 mm sag). With it the d'Alembert loads of drives accelerating from rest at
///   t = 0 (a pitch bearing's `sin · smoothstep`).
/// - If it moves by itself (a pendulum released, a boom deployed by its hinge springs), the
///   loads of the motion it starts are added, as for a moving start ([`preload`]): its beams
///   start strained by the accelerations of their rigid motion. Unstrained, a spring's torque
///   was a step load on the panels it drives, and their ring set every step (a three-panel
///   boom: 5 206 steps of its first second, the first 1.7 µs long).
///
/// The coordinates the rigid mechanism leaves free are held where they are for the static
/// solve; the loads balance on its motions, so holding them takes no reaction.
pub(super) fn preload_at_rest(
    model: &Model,
    system: &System,
    settings: &SimulationSettings,
    state: &mut State,
) -> Result<(), String> {
    let rigid = rigid_system(model)?;
    let by_itself = rigid_accelerations(&rigid, settings, state, Drives::Held)?;
    let l = system.length_ref;
    let moves = by_itself
        .iter()
        .any(|(a, w_dot)| a.norm() + w_dot.norm() * l > AT_REST);
    // Without motion or accelerating drives, the static equilibrium itself: the rigidified
    // accelerations are round-off, whose d'Alembert loads would only strain the beams off it
    // (a cantilever at 30° to x bent sideways by 2e-5 of its sag moment).
    let accelerating = system
        .drives
        .iter()
        .any(|d| d.function.accel(state.t).abs() > DRIVE_AT_REST);
    // At rest the drives differ from held ones only by their accelerations: without those,
    // the mechanism's own motion is the one already solved for.
    let accelerations = match (moves, accelerating) {
        (_, true) => rigid_accelerations(&rigid, settings, state, Drives::AsGiven)?,
        (true, false) => by_itself,
        (false, false) => vec![(V3::zero(), V3::zero()); by_itself.len()],
    };
    // Refused beyond 10 % of the model's size either way: from rest, the rigid accelerations
    // are those of the start itself, and the held coordinates leave no free motion to drift
    // (a 2 m strip of EI = 50 N·m² released as a pendulum bends by 5 %).
    let held = holding_free_coordinates(model, system, state);
    let loads = dalembert_loads(system, state, &accelerations);
    preload_with(&held, system, state, &loads, AT_REST_ELASTIC)?;
    super::initial_velocities::project_initial_velocities(system, state);
    Ok(())
}

/// `model` with every joint coordinate that no drive prescribes and the rigidified mechanism
/// leaves free held where `state` has it: the at-rest pre-load strains the beams under the
/// loads with the mechanism as the rigidified gate found it, at rest. A free collar on a
/// cantilever has no static equilibrium once the beam sags (it would slide to the tip), nor
/// a static restraint where the beam is level: its static solve failed, and the cantilever
/// rang about its sag. Held, the beams start in their sag and the collar slides from there.
/// A coordinate the rigid mechanism determines is not held: only the beams' flexibility
/// moves it (a slider-crank rod's pins, held, would start the rod clamped at both ends).
fn holding_free_coordinates(model: &Model, system: &System, state: &State) -> Model {
    let free: Vec<usize> = system
        .joint_info
        .iter()
        .flat_map(|info| {
            info.coords
                .iter()
                .filter(|c| c.drive.is_none())
                .map(|c| c.coord)
        })
        .collect();
    let determined = crate::system::redundancy::determined_coords(system, state, &free);
    let held_coords: Vec<usize> = free
        .iter()
        .zip(&determined)
        .filter(|(_, &d)| !d)
        .map(|(&c, _)| c)
        .collect();
    let mut held = model.clone();
    for info in &system.joint_info {
        let Some(joint) = held.joints.iter_mut().find(|j| j.name() == info.name) else {
            continue;
        };
        let sliding = system.joints[info.kernel].as_sliding();
        for (k, c) in info.coords.iter().enumerate() {
            if held_coords.contains(&c.coord) {
                let q = state.coords[c.coord];
                joint.hold_coordinate(k, sliding.map_or(q, |sl| sl.arc.eta(q)));
            }
        }
    }
    held
}

/// A drive's acceleration (m/s² or rad/s²) below which it is at rest: round-off of an
/// expression smooth from rest (a spin-up's `0.4 (t²/2 + c (cos(2πt/15) − 1))`: ~1e-16).
const DRIVE_AT_REST: f64 = 1e-9;

/// The rigidified mechanism's drives: as given, or held at their values (does the mechanism
/// move by itself?).
#[derive(Clone, Copy, PartialEq)]
enum Drives {
    AsGiven,
    Held,
}

/// The largest acceleration (m/s², angular ones times the model size) of a rigidified
/// mechanism taken to be at rest: 1 % of standard gravity. A mechanism released under
/// gravity accelerates at a good part of g; a structure at rest by round-off, and by what
/// its drives' motion does over the vanishing step the accelerations are taken over (a
/// carriage driven from rest: 1.5e-3 m/s²).
const AT_REST: f64 = 0.01 * 9.80665;

/// [`preload`] under the d'Alembert `loads` of the rigidified mechanism's accelerations.
fn preload_with(
    model: &Model,
    system: &System,
    state: &mut State,
    loads: &[NodeLoad],
    elastic_within: f64,
) -> Result<Simulation, String> {
    let mut pre = static_solve_of(model, state).map_err(|e| e.to_string())?;
    let lay = pre.system.layout;
    for &(a, force, moment) in loads {
        for (kind, value) in [(LoadKind::Force, force), (LoadKind::Moment, moment)] {
            let load = PointLoad::new(a, kind, value, false, None, &lay);
            pre.system.loads.push(load);
        }
    }
    pre.integrator = Integrator::new(&pre.system, &pre.settings);
    pre.solve_static().map_err(|e| e.reason)?;
    check_elastic(system, state, &pre.state, elastic_within)?;
    super::adopt_static_positions(system, state, &pre.state);
    Ok(pre)
}

/// Each non-spinning node's d'Alembert force `−m a` and moment `−R(J Ẇ + W × J W)` (spatial)
/// of the rigid `accelerations` in `state` (a spun node's steady-spin inertia is the static
/// solve's own).
fn dalembert_loads(
    system: &System,
    state: &State,
    accelerations: &[Acceleration],
) -> Vec<NodeLoad> {
    system
        .inertias
        .iter()
        .filter(|inertia| system.node_spin[inertia.node].is_none())
        .map(|inertia| {
            let a = inertia.node;
            let ((acc, w_dot), n, j) = (accelerations[a], &state.nodes[a], inertia.inertia);
            let moment = n.r.mul_v(&(j.mul_v(&w_dot) + n.w.cross(&j.mul_v(&n.w))));
            (a, acc.scale_f(-inertia.mass), moment.scale_f(-1.0))
        })
        .collect()
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

/// The rigidified mechanism of `model` (see [`rigidified`]), compiled.
fn rigid_system(model: &Model) -> Result<System, String> {
    compile::compile(&rigidified(model), Scheme::Ep)
        .map_err(|e| format!("the rigidified mechanism does not compile: {}", e.0[0]))
}

/// Each node's acceleration and material angular acceleration in the rigidified mechanism
/// `rigid`.
fn rigid_accelerations(
    rigid: &System,
    settings: &SimulationSettings,
    state: &State,
    drives: Drives,
) -> Result<Vec<Acceleration>, String> {
    // Its own copy: the drives may be held, and the frictions start in their modes.
    let mut rigid = rigid.clone();
    if drives == Drives::Held {
        for d in &mut rigid.drives {
            d.function = TimeFunction::Constant(d.function.value(state.t));
        }
    }
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
    // Rigid beams over-constrain the loops their flexibility closed (a slider-crank's rod
    // between parallel pins, a shaft on two bearings): the accelerations are unique still.
    integrator.redundant_rows = true;
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

/// `model` with every beam made rigid: a clamp between each pair of consecutive nodes,
/// except where the pair is already rigidly joined (through the model's clamps or the clamps
/// added so far): a closed frame — a portal's columns and girder clamped to the ground and
/// to each other — would otherwise be clamped around its loop, redundantly, and the
/// rigidified mechanism's matrix be singular.
fn rigidified(model: &Model) -> Model {
    let mut rigid = model.clone();
    rigid.initial_spins.clear();
    rigid.simulation.preload = Some(false);
    let mut joined = RigidSets::of_clamps(model);
    for (i, b) in model.beams.iter().enumerate() {
        for k in 0..b.node_count().saturating_sub(1) {
            let (node1, node2) = (b.node_name(k), b.node_name(k + 1));
            if joined.join(&node1, &node2) {
                rigid.joints.push(Joint::Clamp(ClampJoint {
                    name: format!("__rigid_{i}_{k}"),
                    node1,
                    node2,
                }));
            }
        }
    }
    rigid
}

/// Nodes joined rigidly to each other (union–find by name; `ground` is one of them).
struct RigidSets {
    index: HashMap<String, usize>,
    parent: Vec<usize>,
    aliases: HashMap<String, String>,
}

impl RigidSets {
    /// The sets the model's own clamps join (beam end aliases resolved).
    fn of_clamps(model: &Model) -> Self {
        let aliases = model.beams.iter().flat_map(|b| b.end_aliases()).collect();
        let mut sets = RigidSets {
            index: HashMap::new(),
            parent: Vec::new(),
            aliases,
        };
        for joint in &model.joints {
            if let Joint::Clamp(c) = joint {
                sets.join(&c.node1, &c.node2);
            }
        }
        sets
    }

    fn root(&mut self, name: &str) -> usize {
        let name = self.aliases.get(name).map_or(name, String::as_str);
        let next = self.parent.len();
        let mut a = *self.index.entry(name.to_string()).or_insert(next);
        if a == next {
            self.parent.push(next);
        }
        while self.parent[a] != a {
            self.parent[a] = self.parent[self.parent[a]];
            a = self.parent[a];
        }
        a
    }

    /// Joins the sets of `a` and `b`; `false` if they were one already.
    fn join(&mut self, a: &str, b: &str) -> bool {
        let (ra, rb) = (self.root(a), self.root(b));
        self.parent[ra] = rb;
        ra != rb
    }
}

/// The pre-load may strain the beams, not move the mechanism: a free motion the loads do not
/// balance (they do only to the accuracy of the rigidification) must not run off. `within`
/// is the largest elastic move allowed, relative to the model's size.
fn check_elastic(
    system: &System,
    before: &State,
    after: &State,
    within: f64,
) -> Result<(), String> {
    let l = system.length_ref;
    let (worst, a) = before
        .nodes
        .iter()
        .zip(&after.nodes)
        .map(|(b, a)| (a.x - b.x).norm() + a.r.transpose().mul_m(&b.r).axial().norm() * l)
        .zip(0..)
        .fold((0.0, 0), |m, (d, a)| if d > m.0 { (d, a) } else { m });
    if worst > within * l {
        return Err(format!(
            "it would move node `{}` by {worst:.3e} m, more than an elastic deflection ({} % of the model size)",
            system.node_names[a],
            100.0 * within
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulation::Simulation;

    /// A slider-crank whose 0.6 m rod is a beam between parallel pins (y), the crank (0.15 m)
    /// turning at a constant 20 rad/s, no gravity: made rigid, the loop is over-constrained
    /// (three redundant rows), yet its motion is determined. At dead centre the piston
    /// accelerates at `−r ω² (1 + r/L)` = −75 m/s².
    const CRANK: &str = "
nodes:
  - {name: tip, position: [0.15, 0, 0]}
  - {name: piston, position: [0.75, 0, 0]}
bodies:
  - {name: crank, node: tip, mass: 1.0, inertia: [1e-3, 1e-3, 1e-3]}
  - {name: slider, node: piston, mass: 0.5, inertia: [1e-4, 1e-4, 1e-4]}
beams:
  - {name: rod, start: [0.15, 0, 0], end: [0.75, 0, 0], elements: 4,
     section: {material: {E: 2.1e11, G: 8.1e10, density: 7850}, shape: {circle: {diameter: 0.012}}}}
joints:
  - {type: revolute, name: main, node1: ground, node2: tip, position: [0, 0, 0], axis: [0, 1, 0],
     drive: '20*t'}
  - {type: revolute, name: crank_pin, node1: tip, node2: rod.start, axis: [0, 1, 0]}
  - {type: revolute, name: wrist_pin, node1: rod.end, node2: piston, axis: [0, 1, 0]}
  - {type: prismatic, name: guide, node1: ground, node2: piston, axis: [1, 0, 0]}
simulation: {t_end: 0.01, dt: 0.001}
";

    #[test]
    fn an_over_constrained_rigidified_loop_gets_its_kinematic_accelerations() {
        let model = compile::from_yaml_str(CRANK).unwrap();
        // The run takes its pre-load: no start warning about an unstrained rod.
        let sim = Simulation::with_scheme(&model, Scheme::Ep).unwrap();
        assert!(sim.warnings.is_empty(), "{:?}", sim.warnings);
        // From the unstrained start the pre-load works from (the rigid beams' clamps hold
        // the model's geometry; a strained start would violate them by microns, which a
        // vanishing step corrects with huge accelerations).
        let unstrained = model_without_preload(&model);
        let sim = Simulation::with_scheme(&unstrained, Scheme::Ep).unwrap();
        let rigid = rigid_system(&model).unwrap();
        let accelerations =
            rigid_accelerations(&rigid, &sim.settings, &sim.state, Drives::AsGiven).unwrap();
        let piston = sim
            .system
            .node_names
            .iter()
            .position(|n| n == "piston")
            .unwrap();
        let expected = -0.15 * 20.0f64.powi(2) * (1.0 + 0.15 / 0.6);
        // The vanishing step's O(h) and the regularization's 1e-8: 1e-5 of it.
        let got = accelerations[piston].0 .0[0];
        assert!(
            (got - expected).abs() < 1e-5 * expected.abs(),
            "{got} vs {expected}"
        );
    }

    fn model_without_preload(model: &Model) -> Model {
        let mut m = model.clone();
        m.simulation.inertial_preload = false;
        m
    }

    /// With the crank driven, its rigid mechanism moves the pins and the guide itself: all
    /// determined. Undriven, the crank, the pins are free (one degree of freedom turns them
    /// all) — but not the guide: at dead centre the slider's rate is zero whatever the crank's
    /// (to first order), which the rows say.
    #[test]
    fn the_coordinates_a_rigid_mechanism_moves_itself_are_determined() {
        for drive in [true, false] {
            let text = if drive {
                CRANK.to_string()
            } else {
                CRANK.replace(",\n     drive: '20*t'}", "}")
            };
            let model = compile::from_yaml_str(&text).unwrap();
            let sim = Simulation::with_scheme(&model, Scheme::Ep).unwrap();
            let coords: Vec<(String, usize)> = sim
                .system
                .joint_info
                .iter()
                .flat_map(|j| j.coords.iter().map(move |c| (j.name.clone(), c.coord)))
                .collect();
            let ids: Vec<usize> = coords.iter().map(|c| c.1).collect();
            let got = crate::system::redundancy::determined_coords(&sim.system, &sim.state, &ids);
            for ((name, _), determined) in coords.iter().zip(got) {
                let expected = drive || name == "guide";
                assert_eq!(determined, expected, "drive {drive}: `{name}`");
            }
        }
    }
}
