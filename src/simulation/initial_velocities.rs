//! Consistent initial velocities: the model's velocities projected onto the joints'
//! velocity-level constraints (drives moving at t = 0 included), in the kinetic-energy metric.

use crate::joints::RateTerm;
use crate::model::Scheme;
use crate::state::State;
use crate::system::layout::Layout;
use crate::system::sparse::NewtonMatrix;
use crate::system::System;
use crate::vec3::V3;

/// Projects the initial velocities onto the velocity-level constraints, as the closest
/// velocities in the kinetic-energy norm: `min ½|V − V₀|²_M` subject to `B V + ∂C/∂t = 0`.
/// Coordinate rates, and the velocities of nodes the model gave none for, carry a negligible
/// weight, so they follow from the constraints and the given velocities. Returns
/// each node's velocity change (translational, or rotational times the model size).
pub fn project_initial_velocities(sys: &System, state: &mut State) -> Vec<f64> {
    let mut change = vec![0.0; sys.layout.n_nodes];
    if sys.layout.n_rows == 0 {
        return change;
    }
    let lay = Layout::new(
        Scheme::Ep,
        sys.layout.n_nodes,
        sys.layout.n_coords,
        sys.layout.n_rows,
    );
    let mut blocks: Vec<Vec<usize>> = Vec::new();
    for a in 0..lay.n_nodes {
        blocks.push((0..6).map(|k| lay.node_delta(a) + k).collect());
    }
    // Each joint's block: the unknowns its velocity-level rows touch.
    let mut joint_terms: Vec<Vec<(usize, RateTerm)>> = Vec::new();
    for j in &sys.joints {
        let mut terms = Vec::new();
        j.rate_terms(state, &mut terms);
        let mut b = Vec::new();
        for (_, t) in &terms {
            match *t {
                RateTerm::Node { node, .. } => b.extend((0..6).map(|k| lay.node_delta(node) + k)),
                RateTerm::Coord { coord, .. } => b.push(lay.coord_delta(coord)),
            }
        }
        b.extend((0..j.n_rows()).map(|r| lay.mult(j.row0() + r)));
        b.sort_unstable();
        b.dedup();
        blocks.push(b);
        joint_terms.push(terms);
    }
    for d in &sys.drives {
        blocks.push(vec![lay.coord_delta(d.coord), lay.mult(d.row)]);
    }
    for c in 0..lay.n_coords {
        blocks.push(vec![lay.coord_delta(c)]);
    }
    let refs: Vec<&[usize]> = blocks.iter().map(|b| b.as_slice()).collect();
    let (mut m, pos) = NewtonMatrix::from_blocks(lay.n_unknowns(), &refs, None);
    let mut rhs = vec![0.0; lay.n_unknowns()];
    let add = |m: &mut NewtonMatrix, block: usize, i: usize, j: usize, v: f64| {
        let b = &blocks[block];
        let n = b.len();
        let li = b.iter().position(|&g| g == i).unwrap();
        let lj = b.iter().position(|&g| g == j).unwrap();
        m.values[pos[block][li * n + lj]] += v;
    };
    // Mass-weighting; massless nodes get a small weight so the problem stays regular.
    let floor = 1e-8 * sys.mass_ref;
    let mut mass = vec![0.0; lay.n_nodes];
    let mut inertia = vec![crate::vec3::M3::<f64>::zero(); lay.n_nodes];
    for k in &sys.inertias {
        mass[k.node] += k.mass;
        inertia[k.node] = inertia[k.node] + k.inertia;
    }
    // Nodes whose velocities the model did not give follow the others: when any node's
    // velocity was given, theirs carry a negligible weight (relative weighting among them
    // stays the kinetic-energy metric).
    let any_given = sys.velocity_given.iter().any(|&g| g);
    for a in 0..lay.n_nodes {
        if mass[a] <= 0.0 {
            mass[a] = floor;
        }
        if inertia[a].max_abs() <= 0.0 {
            inertia[a] = crate::vec3::M3::identity().scale_f(floor * sys.length_ref.powi(2));
        }
        // Nodes without given velocities follow the given ones (weight 1e-6), but relative
        // coordinates (joint rates, a sliding contact point's ζ̇: weight 1e-14 below) move
        // first: a collar launched along a beam at rest slides along it rather than dragging
        // the beam with it.
        if any_given && !sys.velocity_given[a] {
            mass[a] *= 1e-6;
            inertia[a] = inertia[a].scale_f(1e-6);
        }
    }
    for a in 0..lay.n_nodes {
        let d = lay.node_delta(a);
        let n = &state.nodes[a];
        for k in 0..3 {
            add(&mut m, a, d + k, d + k, mass[a]);
            rhs[d + k] = mass[a] * n.v.0[k];
            let jw = inertia[a].mul_v(&n.w);
            rhs[d + 3 + k] = jw.0[k];
            for l in 0..3 {
                add(&mut m, a, d + 3 + k, d + 3 + l, inertia[a].0[k][l]);
            }
        }
    }
    let coord_weight = 1e-14 * sys.mass_ref * sys.length_ref.powi(2);
    for c in 0..lay.n_coords {
        let b = blocks.len() - lay.n_coords + c;
        add(
            &mut m,
            b,
            lay.coord_delta(c),
            lay.coord_delta(c),
            coord_weight,
        );
        rhs[lay.coord_delta(c)] = coord_weight * state.coord_rates[c];
    }
    for (ji, j) in sys.joints.iter().enumerate() {
        let blk = lay.n_nodes + ji;
        for (r, term) in &joint_terms[ji] {
            let row = lay.mult(j.row0() + r);
            match *term {
                RateTerm::Node { node, v, omega } => {
                    let d = lay.node_delta(node);
                    // Material angular velocity: B_W = B_ω R.
                    let bw = state.nodes[node].r.tmul_v(&omega);
                    for c in 0..3 {
                        for (col, val) in [(d + c, v.0[c]), (d + 3 + c, bw.0[c])] {
                            add(&mut m, blk, row, col, val);
                            add(&mut m, blk, col, row, val);
                        }
                    }
                }
                RateTerm::Coord { coord, value } => {
                    add(&mut m, blk, row, lay.coord_delta(coord), value);
                    add(&mut m, blk, lay.coord_delta(coord), row, value);
                }
            }
        }
    }
    for (di, d) in sys.drives.iter().enumerate() {
        let blk = lay.n_nodes + sys.joints.len() + di;
        let row = lay.mult(d.row);
        add(&mut m, blk, row, lay.coord_delta(d.coord), 1.0);
        add(&mut m, blk, lay.coord_delta(d.coord), row, 1.0);
        rhs[row] = d.target_rate(state.t);
    }
    if m.factor().is_err() {
        return change;
    }
    // The small weights of unspecified velocities and coordinate rates keep the matrix
    // regular but pull them towards their guesses (zero), which moves the given velocities
    // by ~1e-6. Re-solving with the last solution as their guesses (a proximal iteration)
    // shrinks that bias by the weight ratio each time: three solves leave ~1e-18.
    let base = rhs.clone();
    m.solve(&mut rhs);
    for _ in 0..2 {
        let mut next = base.clone();
        for a in (0..lay.n_nodes).filter(|&a| any_given && !sys.velocity_given[a]) {
            let d = lay.node_delta(a);
            let w = inertia[a].mul_v(&V3([rhs[d + 3], rhs[d + 4], rhs[d + 5]]));
            for k in 0..3 {
                next[d + k] = mass[a] * rhs[d + k];
                next[d + 3 + k] = w.0[k];
            }
        }
        for c in 0..lay.n_coords {
            next[lay.coord_delta(c)] = coord_weight * rhs[lay.coord_delta(c)];
        }
        m.solve(&mut next);
        rhs = next;
    }
    for a in 0..lay.n_nodes {
        let d = lay.node_delta(a);
        let v = V3([rhs[d], rhs[d + 1], rhs[d + 2]]);
        let w = V3([rhs[d + 3], rhs[d + 4], rhs[d + 5]]);
        let n = &mut state.nodes[a];
        change[a] = (v - n.v)
            .norm()
            .max((n.r.mul_v(&(w - n.w))).norm() * sys.length_ref);
        n.v = v;
        n.w = w;
    }
    for c in 0..lay.n_coords {
        state.coord_rates[c] = rhs[lay.coord_delta(c)];
    }
    change
}

