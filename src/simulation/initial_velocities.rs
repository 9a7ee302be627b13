//! Velocities that satisfy the joints: the model's initial velocities projected onto the
//! velocity-level constraints (drives moving at t = 0 included), and the least kinetic energy
//! with which the drives can move the model (a scale for the step-error indicator).
//!
//! Both solve `min ½|V − V₀|²_W` subject to `B V + ∂C/∂t = 0` (at the initial configuration)
//! for some weights W ([`super::velocity_projection`]), the beams' strain rates included.

use super::velocity_projection::{Parts, VelocityProjection, Weighting};
use crate::math::rotation::{exp_map, orthonormalize};
use crate::math::vec3::V3;
use crate::model::Model;
use crate::state::State;
use crate::system::System;

/// Makes the initial velocities consistent with the joints, in two stages.
///
/// 1. The velocities the model gave are projected onto the velocity-level constraints, as
///    the closest in the kinetic-energy norm, the other nodes and the relative coordinates
///    following freely (`min ½|V − V₀|²_M` subject to `B V + ∂C/∂t = 0`).
/// 2. With those held, every other node — beam interiors included — takes the velocities of
///    least strain rate in the beams and, among those, of least kinetic energy: a mechanism
///    driven from t = 0 starts in its rigid motion, its flexible parts moving with their
///    supports instead of lagging at rest behind them (which would ring at their modes).
///
/// Returns each node's velocity change (translational, or rotational times the model size).
pub fn project_initial_velocities(sys: &System, state: &mut State) -> Vec<f64> {
    let n = sys.layout.n_nodes;
    let mut change = vec![0.0; n];
    if at_rest(sys, state) {
        // Rest meets every joint's velocity condition when no drive moves: nothing to
        // project (a 2000-element beam's pre-loads projected rest three times, a third of
        // their cost).
        return change;
    }
    let given: Vec<Parts> = sys
        .velocity_given
        .iter()
        .map(|g| [g.translation, g.rotation])
        .collect();
    let none = vec![[false; 2]; n];
    let any_given = sys.velocity_given.iter().any(|g| g.any());
    if any_given {
        // Parts not given follow; relative coordinates (joint rates, a sliding contact
        // point's ζ̇) move first: a collar launched along a beam at rest slides along it
        // rather than dragging the beam, and one given only its velocity takes its spin
        // from the joint rather than holding the beam's section still.
        let follow: Vec<Parts> = given.iter().map(|g| [!g[0], !g[1]]).collect();
        let w = Weighting {
            fixed: &none,
            follow: &follow,
            beams: false,
        };
        let Some(mut p) = VelocityProjection::new(sys, state, &w) else {
            return change;
        };
        let x = p.solve(&p.rhs(sys, state, state.t));
        for a in 0..n {
            change[a] = set_velocities(state, a, p.node(&x, a), given[a], sys.length_ref);
        }
    }
    let w = Weighting {
        fixed: if any_given { &given } else { &none },
        follow: &none,
        beams: true,
    };
    if let Some(mut p) = VelocityProjection::new(sys, state, &w) {
        let x = p.solve(&p.rhs(sys, state, state.t));
        for a in 0..n {
            let free = [!w.fixed[a][0], !w.fixed[a][1]];
            set_velocities(state, a, p.node(&x, a), free, sys.length_ref);
        }
        for c in 0..p.lay.n_coords {
            state.coord_rates[c] = x[p.lay.coord_delta(c)];
        }
    }
    change
}

/// Sets the `parts` (translation, rotation) of node `a`'s velocity and material angular
/// velocity; returns their change (translational, or rotational times the model size `l`).
fn set_velocities(
    state: &mut State,
    a: usize,
    (v, w): (V3<f64>, V3<f64>),
    parts: Parts,
    l: f64,
) -> f64 {
    let nd = &mut state.nodes[a];
    let mut change = 0.0f64;
    if parts[0] {
        change = change.max((v - nd.v).norm());
        nd.v = v;
    }
    if parts[1] {
        change = change.max(nd.r.mul_v(&(w - nd.w)).norm() * l);
        nd.w = w;
    }
    change
}

/// The closest velocities (kinetic-energy norm) that satisfy the velocity-level constraints
/// at `state`: a step's end velocities satisfy them only to the scheme's accuracy (its
/// positions satisfy the constraints exactly), and a solve at that instant needs them exact.
pub fn project_velocities(sys: &System, state: &mut State) {
    // At rest with no drive moving the right-hand side is zero, and so is the projection (a
    // pre-load's rigidified mechanism, a 2000-element beam's: 0.1 s for nothing).
    if !at_rest(sys, state) {
        project_velocities_with(sys, state, |_, _, _| {});
    }
}

/// [`project_velocities`] with the right-hand side `adjust`ed first (e.g. rows that are to
/// keep their present values); false if there was nothing to project or the matrix is
/// singular.
pub fn project_velocities_with(
    sys: &System,
    state: &mut State,
    adjust: impl FnOnce(&VelocityProjection, &State, &mut [f64]),
) -> bool {
    let none = vec![[false; 2]; sys.layout.n_nodes];
    let w = Weighting {
        fixed: &none,
        follow: &none,
        beams: false,
    };
    let Some(mut p) = VelocityProjection::new(sys, state, &w) else {
        return false;
    };
    let mut rhs = p.rhs(sys, state, state.t);
    adjust(&p, state, &mut rhs);
    let x = p.solve(&rhs);
    for (a, nd) in state.nodes.iter_mut().enumerate() {
        (nd.v, nd.w) = p.node(&x, a);
    }
    for c in 0..p.lay.n_coords {
        state.coord_rates[c] = x[p.lay.coord_delta(c)];
    }
    true
}

/// Moves `state`'s positions onto the constraints (drives at their values at `state.t`) by
/// the least displacement in the kinetic-energy norm: a few Newton iterations of
/// `B Δ = −C`. A step's end satisfies them to round-off, a model's input only to the digits
/// it was typed with; a solve over a vanishing step needs them exact, since it would take
/// the violation `C` out in that step, with forces ~ m C/h².
pub fn project_positions(sys: &System, state: &mut State) {
    let none = vec![[false; 2]; sys.layout.n_nodes];
    let w = Weighting {
        fixed: &none,
        follow: &none,
        beams: false,
    };
    for _ in 0..3 {
        let Some(mut p) = VelocityProjection::new(sys, state, &w) else {
            return;
        };
        let lay = p.lay;
        let mut rhs = vec![0.0; p.n];
        for j in &sys.joints {
            let c = j.values_at(state);
            for r in 0..j.n_rows() {
                rhs[lay.mult(j.row0() + r)] = -c[r];
            }
        }
        for d in &sys.drives {
            rhs[lay.mult(d.row)] = d.target(state.t) - state.coords[d.coord];
        }
        let x = p.solve(&rhs);
        for (a, nd) in state.nodes.iter_mut().enumerate() {
            let (dx, dw) = p.node(&x, a);
            nd.x += dx;
            nd.r = orthonormalize(&nd.r.mul_m(&exp_map(&dw)));
        }
        for c in 0..lay.n_coords {
            state.coords[c] += x[lay.coord_delta(c)];
        }
    }
}

/// Makes the initial velocities consistent with the joints (see
/// [`project_initial_velocities`]). Velocities the model did not give are simply completed;
/// changing given ones returns a warning that says which nodes, by how much, and — when
/// drives already moving at t = 0 make the start impulsive — which drives.
pub fn make_consistent(model: &Model, system: &System, state: &mut State) -> Option<String> {
    let change = project_initial_velocities(system, state);
    let v_scale = state
        .nodes
        .iter()
        .map(|n| n.v.norm() + n.omega().norm() * system.length_ref)
        .fold(1e-12f64, f64::max);
    let adjusted = |a: usize| system.velocity_given[a].any() && change[a] > 1e-9 * v_scale;
    let changed: Vec<String> = (0..change.len())
        .filter(|&a| adjusted(a))
        .map(|a| format!("`{}`", system.node_names[a]))
        .collect();
    if changed.is_empty() {
        return None;
    }
    let worst = change.iter().cloned().fold(0.0, f64::max);
    let moving = drives_moving_adjusted_nodes(model, system, &adjusted);
    let why = if moving.is_empty() {
        "give consistent velocities to avoid this".to_string()
    } else {
        format!(
            "the drive(s) of {} start moving at t = 0, so the start is impulsive; give the nodes those velocities, or start the drives from rest, to avoid this",
            moving.join(", ")
        )
    };
    Some(format!(
        "initial velocities of node(s) {} were adjusted to satisfy the joints' velocity constraints (largest change {worst:.4} m/s, or rad/s times the model size); {why}",
        changed.join(", ")
    ))
}

/// A warning when drives already moving at t = 0 carry beams along: the model starts in
/// that motion, but its beams start unstrained under the motion's inertial loads (a
/// connecting rod's bending, a blade's centrifugal stretch), so they ring at their modes —
/// an impulsive start of the loads, which no choice of velocities removes. Spun and
/// pre-loaded beams start in their steady state and do not count.
pub fn unstrained_start(system: &System, state: &State, preload: bool) -> Option<String> {
    let moving: Vec<String> = system
        .joint_info
        .iter()
        .flat_map(|info| info.coords.iter().map(move |c| (info, c)))
        .filter_map(|(info, c)| {
            let rate = system.drives[c.drive?].target_rate(state.t);
            (rate != 0.0 && rate.is_finite())
                .then(|| format!("`{}` ({} rate {rate:.4})", info.name, c.name))
        })
        .collect();
    if moving.is_empty() {
        return None;
    }
    let l = system.length_ref;
    let speed = |a: usize| state.nodes[a].v.norm() + state.nodes[a].omega().norm() * l;
    let v_scale = (0..state.nodes.len()).map(speed).fold(1e-12f64, f64::max);
    let steady = |a: usize| preload && system.node_spin[a].is_some();
    let carried = beams_with_a_node(system, |a| speed(a) > 1e-9 * v_scale && !steady(a))?;
    Some(format!(
        "drive(s) {} already move at t = 0: the model starts in that motion, but beam(s) {carried} start unstrained under its inertial loads and will ring at their modes; to start smoothly, bring the drive(s) up from rest with a smooth rate (docs/expressions.md, \"Starting a drive from rest\"), or let the inertial pre-load start them strained (`simulation.inertial_preload`, on by default)",
        moving.join(", "),
    ))
}

/// The beams (their names, listed) with a node that `node` picks; None if none has.
fn beams_with_a_node(system: &System, node: impl Fn(usize) -> bool) -> Option<String> {
    let beams: Vec<String> = system
        .beam_info
        .iter()
        .filter(|b| b.nodes.iter().any(|&a| node(a)))
        .map(|b| format!("`{}`", b.name))
        .collect();
    (!beams.is_empty()).then(|| beams.join(", "))
}

/// Whether nothing moves at `state`: no node, no joint coordinate, no drive's target.
fn at_rest(sys: &System, state: &State) -> bool {
    let still = |v: V3<f64>| v.norm() == 0.0;
    state.nodes.iter().all(|n| still(n.v) && still(n.w))
        && state.coord_rates.iter().all(|&q| q == 0.0)
        && sys.drives.iter().all(|d| d.target_rate(state.t) == 0.0)
}

/// The model's beams (their names, listed) that move at t = 0 with no drive moving — given
/// velocities or spins, a tumbling or freely spinning start: they start unstrained under
/// their motion's inertial loads (a tumbling beam's or a rotor blade's centrifugal stretch)
/// unless the inertial pre-load starts them strained (see `inertial_preload::preload`).
pub fn beams_in_free_motion(system: &System, state: &State) -> Option<String> {
    let drives_move = system.drives.iter().any(|d| d.target_rate(state.t) != 0.0);
    if drives_move {
        return None;
    }
    beams_with_a_node(system, |a| {
        state.nodes[a].v.norm() > 0.0 || state.nodes[a].w.norm() > 0.0
    })
}

/// The model's beams (their names, listed) if it starts at rest — no node moving, no
/// coordinate or drive changing, nothing spun — with gravity, loads or a joint spring off its
/// rest on it: beams that would start unstrained under them (see `inertial_preload::preload_at_rest`).
pub fn loaded_at_rest(system: &System, state: &State) -> Option<String> {
    let sprung = system
        .springs
        .iter()
        .any(|sp| sp.law.force(state.coords[sp.coord]) != 0.0);
    let loaded = system.gravity.norm() > 0.0
        || !system.loads.is_empty()
        || !system.line_loads.is_empty()
        || sprung;
    let at_rest = at_rest(system, state) && system.node_spin.iter().all(Option::is_none);
    if !(loaded && at_rest) {
        return None;
    }
    beams_with_a_node(system, |_| true)
}

/// The drives already moving at t = 0 on joints of nodes whose given velocities were
/// adjusted (`adjusted(node)`): they make the start impulsive — the fix is then the model's
/// choice, not a slip.
fn drives_moving_adjusted_nodes(
    model: &Model,
    system: &System,
    adjusted: &dyn Fn(usize) -> bool,
) -> Vec<String> {
    // A model node, or one of a beam's nodes `<beam>.<k>`.
    let touches = |n: &str| {
        (0..system.node_names.len()).any(|a| {
            let name = &system.node_names[a];
            adjusted(a) && (name == n || name.strip_prefix(n).is_some_and(|k| k.starts_with('.')))
        })
    };
    model
        .joints
        .iter()
        .filter(|j| {
            let (n1, n2) = j.nodes();
            touches(n1) || touches(n2)
        })
        .filter_map(|j| system.joint(j.name()))
        .flat_map(|info| info.coords.iter().map(move |c| (info, c)))
        .filter(|(_, c)| {
            c.drive
                .is_some_and(|d| system.drives[d].function.rate(0.0) != 0.0)
        })
        .map(|(info, c)| format!("`{}` ({})", info.name, c.name))
        .collect()
}

/// The largest kinetic energy the drives impose over `[0, t_end]`: at each time, the least
/// kinetic energy of velocities that give the drives their rates, at the initial
/// configuration. It is `½ q̇ᵀ G q̇` with `G` the drives' effective mass matrix (one solve
/// per drive), so it is sampled densely at no cost — 256 times, and at the middle of every
/// table segment (a short burst between samples).
pub fn drive_energy(sys: &System, state: &State, t_end: f64) -> f64 {
    if sys.drives.is_empty() {
        return 0.0;
    }
    let none = vec![[false; 2]; sys.layout.n_nodes];
    let w = Weighting {
        fixed: &none,
        follow: &none,
        beams: true,
    };
    let Some(mut p) = VelocityProjection::new(sys, state, &w) else {
        return 0.0;
    };
    // Velocities per unit rate of each drive.
    let unit: Vec<Vec<f64>> = sys
        .drives
        .iter()
        .map(|d| {
            let mut rhs = vec![0.0; p.n];
            rhs[p.lay.mult(d.row)] = 1.0;
            p.solve(&rhs)
        })
        .collect();
    let nd = unit.len();
    let mut g = vec![0.0; nd * nd];
    for i in 0..nd {
        for j in i..nd {
            let e = sys.inertias.iter().fold(0.0, |acc, k| {
                let ((vi, wi), (vj, wj)) = (p.node(&unit[i], k.node), p.node(&unit[j], k.node));
                acc + k.mass * vi.dot(&vj) + wi.dot(&k.inertia.mul_v(&wj))
            });
            g[i * nd + j] = e;
            g[j * nd + i] = e;
        }
    }
    let mut times: Vec<f64> = (0..=256).map(|k| t_end * k as f64 / 256.0).collect();
    for d in &sys.drives {
        times.extend(
            d.function
                .segment_midpoints()
                .filter(|t| (0.0..=t_end).contains(t)),
        );
    }
    times.iter().fold(0.0f64, |m, &t| {
        let rates: Vec<f64> = sys.drives.iter().map(|d| d.target_rate(t)).collect();
        let e: f64 = (0..nd)
            .flat_map(|i| (0..nd).map(move |j| (i, j)))
            .map(|(i, j)| rates[i] * g[i * nd + j] * rates[j])
            .sum();
        // An undefined rate is reported when a step meets it, not here.
        if e.is_finite() {
            m.max(0.5 * e)
        } else {
            m
        }
    })
}
