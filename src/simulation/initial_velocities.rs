//! Velocities that satisfy the joints: the model's initial velocities projected onto the
//! velocity-level constraints (drives moving at t = 0 included), and the least kinetic energy
//! with which the drives can move the model (a scale for the step-error indicator).
//!
//! Both solve `min ½|V − V₀|²_W` subject to `B V + ∂C/∂t = 0` (at the initial configuration)
//! for some weights W: one KKT matrix, factored once, several right-hand sides.

use crate::joints::RateTerm;
use crate::math::layout::Layout;
use crate::math::vec3::{M3, V3};
use crate::model::{Model, Scheme};
use crate::state::State;
use crate::system::sparse::NewtonMatrix;
use crate::system::System;

/// The factored KKT matrix of a velocity projection at one configuration, and its weights.
struct VelocityProjection {
    lay: Layout,
    matrix: NewtonMatrix,
    /// Per node: the translational and rotational weights (mass, material inertia).
    mass: Vec<f64>,
    inertia: Vec<M3<f64>>,
    /// Weight of the coordinate rates.
    coord_weight: f64,
}

impl VelocityProjection {
    /// Builds and factors the projection at `state`. `follow` marks the nodes whose
    /// velocities should follow the others' (weight 1e-6 of their kinetic energy).
    /// `None` when the model has no constraints, or the matrix is singular.
    fn new(sys: &System, state: &State, follow: &[bool]) -> Option<Self> {
        if sys.layout.n_rows == 0 {
            return None;
        }
        let l = sys.layout;
        let lay = Layout::new(Scheme::Ep, l.n_nodes, l.n_coords, l.n_rows);
        let (mass, inertia) = weights(sys, follow);
        let coord_weight = 1e-14 * sys.mass_ref * sys.length_ref.powi(2);
        let mut entries: Vec<(usize, usize, f64)> = Vec::new();
        for a in 0..lay.n_nodes {
            let d = lay.node_delta(a);
            for k in 0..3 {
                entries.push((d + k, d + k, mass[a]));
                for m in 0..3 {
                    entries.push((d + 3 + k, d + 3 + m, inertia[a].0[k][m]));
                }
            }
        }
        for c in 0..lay.n_coords {
            entries.push((lay.coord_delta(c), lay.coord_delta(c), coord_weight));
        }
        for j in &sys.joints {
            let mut terms = Vec::new();
            j.rate_terms(state, &mut terms);
            for (r, term) in terms {
                let row = lay.mult(j.row0() + r);
                match term {
                    RateTerm::Node { node, v, omega } => {
                        let d = lay.node_delta(node);
                        // Material angular velocity: B_W = B_ω R.
                        let bw = state.nodes[node].r.tmul_v(&omega);
                        for c in 0..3 {
                            entries.push((row, d + c, v.0[c]));
                            entries.push((row, d + 3 + c, bw.0[c]));
                        }
                    }
                    RateTerm::Coord { coord, value } => {
                        entries.push((row, lay.coord_delta(coord), value));
                    }
                }
            }
        }
        for d in &sys.drives {
            entries.push((lay.mult(d.row), lay.coord_delta(d.coord), 1.0));
        }
        let matrix = symmetric_matrix(lay.n_unknowns(), &entries)?;
        Some(VelocityProjection {
            lay,
            matrix,
            mass,
            inertia,
            coord_weight,
        })
    }

    /// The right-hand side for targets `state`'s velocities and the drives' rates at `t`.
    fn rhs(&self, sys: &System, state: &State, t: f64) -> Vec<f64> {
        let lay = self.lay;
        let mut rhs = vec![0.0; lay.n_unknowns()];
        for (a, n) in state.nodes.iter().enumerate() {
            let d = lay.node_delta(a);
            n.v.scale_f(self.mass[a]).write_to(&mut rhs[d..]);
            self.inertia[a].mul_v(&n.w).write_to(&mut rhs[d + 3..]);
        }
        for c in 0..lay.n_coords {
            rhs[lay.coord_delta(c)] = self.coord_weight * state.coord_rates[c];
        }
        for d in &sys.drives {
            rhs[lay.mult(d.row)] = d.target_rate(t);
        }
        rhs
    }

    /// Node `a`'s velocity and material angular velocity in a solution.
    fn node(&self, x: &[f64], a: usize) -> (V3<f64>, V3<f64>) {
        let d = self.lay.node_delta(a);
        (
            V3([x[d], x[d + 1], x[d + 2]]),
            V3([x[d + 3], x[d + 4], x[d + 5]]),
        )
    }
}

/// The symmetric KKT matrix from entries `(row, col, value)` of one triangle (diagonal
/// entries once), mirrored; factored.
fn symmetric_matrix(n: usize, entries: &[(usize, usize, f64)]) -> Option<NewtonMatrix> {
    let blocks: Vec<Vec<usize>> = entries
        .iter()
        .map(|&(i, j, _)| if i == j { vec![i] } else { vec![i, j] })
        .collect();
    let refs: Vec<&[usize]> = blocks.iter().map(|b| &b[..]).collect();
    let (mut m, pos) = NewtonMatrix::from_blocks(n, &refs, None);
    for (&(i, j, v), p) in entries.iter().zip(&pos) {
        if i == j {
            m.values[p[0]] += v;
        } else {
            // Block [i, j], row-major: (i, j) at 1, (j, i) at 2.
            m.values[p[1]] += v;
            m.values[p[2]] += v;
        }
    }
    m.factor().ok()?;
    Some(m)
}

/// Kinetic-energy weights per node; massless nodes get a small weight so the problem stays
/// regular; nodes in `follow` 1e-6 of theirs.
fn weights(sys: &System, follow: &[bool]) -> (Vec<f64>, Vec<M3<f64>>) {
    let n = sys.layout.n_nodes;
    let floor = 1e-8 * sys.mass_ref;
    let mut mass = vec![0.0; n];
    let mut inertia = vec![M3::<f64>::zero(); n];
    for k in &sys.inertias {
        mass[k.node] += k.mass;
        inertia[k.node] = inertia[k.node] + k.inertia;
    }
    for a in 0..n {
        if mass[a] <= 0.0 {
            mass[a] = floor;
        }
        if inertia[a].max_abs() <= 0.0 {
            inertia[a] = M3::identity().scale_f(floor * sys.length_ref.powi(2));
        }
        if follow[a] {
            mass[a] *= 1e-6;
            inertia[a] = inertia[a].scale_f(1e-6);
        }
    }
    (mass, inertia)
}

/// Projects the initial velocities onto the velocity-level constraints, as the closest
/// velocities in the kinetic-energy norm: `min ½|V − V₀|²_M` subject to `B V + ∂C/∂t = 0`.
/// Coordinate rates, and the velocities of nodes the model gave none for, carry a negligible
/// weight, so they follow from the constraints and the given velocities. Returns
/// each node's velocity change (translational, or rotational times the model size).
pub fn project_initial_velocities(sys: &System, state: &mut State) -> Vec<f64> {
    let mut change = vec![0.0; sys.layout.n_nodes];
    // Nodes without given velocities follow the given ones (weight 1e-6), but relative
    // coordinates (joint rates, a sliding contact point's ζ̇: weight 1e-14) move first: a
    // collar launched along a beam at rest slides along it rather than dragging the beam.
    let any_given = sys.velocity_given.iter().any(|&g| g);
    let follow: Vec<bool> = sys
        .velocity_given
        .iter()
        .map(|&g| any_given && !g)
        .collect();
    let Some(mut p) = VelocityProjection::new(sys, state, &follow) else {
        return change;
    };
    let lay = p.lay;
    let base = p.rhs(sys, state, state.t);
    // The small weights of unspecified velocities and coordinate rates keep the matrix
    // regular but pull them towards their guesses (zero), which moves the given velocities
    // by ~1e-6. Re-solving with the last solution as their guesses (a proximal iteration)
    // shrinks that bias by the weight ratio each time: three solves leave ~1e-18.
    let mut x = base.clone();
    p.matrix.solve(&mut x);
    for _ in 0..2 {
        let mut next = base.clone();
        for a in (0..lay.n_nodes).filter(|&a| follow[a]) {
            let (v, w) = p.node(&x, a);
            let d = lay.node_delta(a);
            v.scale_f(p.mass[a]).write_to(&mut next[d..]);
            p.inertia[a].mul_v(&w).write_to(&mut next[d + 3..]);
        }
        for c in 0..lay.n_coords {
            next[lay.coord_delta(c)] = p.coord_weight * x[lay.coord_delta(c)];
        }
        p.matrix.solve(&mut next);
        x = next;
    }
    for (a, (n, change)) in state.nodes.iter_mut().zip(change.iter_mut()).enumerate() {
        let (v, w) = p.node(&x, a);
        *change = (v - n.v)
            .norm()
            .max((n.r.mul_v(&(w - n.w))).norm() * sys.length_ref);
        n.v = v;
        n.w = w;
    }
    for c in 0..lay.n_coords {
        state.coord_rates[c] = x[lay.coord_delta(c)];
    }
    change
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
    let adjusted = |a: usize| system.velocity_given[a] && change[a] > 1e-9 * v_scale;
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
    let Some(mut p) = VelocityProjection::new(sys, state, &vec![false; sys.layout.n_nodes]) else {
        return 0.0;
    };
    // Velocities per unit rate of each drive.
    let unit: Vec<Vec<f64>> = sys
        .drives
        .iter()
        .map(|d| {
            let mut x = vec![0.0; p.lay.n_unknowns()];
            x[p.lay.mult(d.row)] = 1.0;
            p.matrix.solve(&mut x);
            x
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
