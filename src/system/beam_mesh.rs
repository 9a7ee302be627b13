//! Meshing a straight, possibly pre-twisted beam: nodes with their reference triads, lumped
//! nodal inertia, and per element the Gauss points with their initial history.

use crate::beam::element::{write_history, GaussPoint, HISTORY_PER_POINT};
use crate::beam::section::Section;
use crate::beam::shape::{gauss, lagrange, node_coordinates, reduced_points, MAX_NODES};
use crate::model::Beam;
use crate::rotation::exp_map;
use crate::state::NodeState;
use crate::vec3::{M3, V3};

/// One element before numbering of unknowns: its nodes, Gauss points and initial history.
pub struct MeshedElement {
    pub name: String,
    pub nodes: Vec<usize>,
    pub points: Vec<GaussPoint>,
    pub history: Vec<f64>,
}

/// A meshed beam: its elements and, per node along it, what distributed loads need.
pub struct BeamMesh {
    pub elements: Vec<MeshedElement>,
    /// Global node index of each node along the beam.
    pub nodes: Vec<usize>,
    /// `∫ h_α ds` per node along the beam: a uniform load per unit length q lumps to `w_α q`
    /// (the consistent load vector).
    pub load_weights: Vec<f64>,
    /// Reference section triad at each node along the beam (a shared node's own triad may
    /// differ).
    pub section_triads: Vec<M3<f64>>,
    pub length: f64,
}

/// Nodal weights of the lumped mass of an n-node element (closed Newton–Cotes: trapezoid,
/// Simpson, Simpson 3/8), all positive.
fn lumping_weights(n: usize) -> &'static [f64] {
    match n {
        2 => &[0.5, 0.5],
        3 => &[1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0],
        4 => &[1.0 / 8.0, 3.0 / 8.0, 3.0 / 8.0, 1.0 / 8.0],
        _ => unreachable!("2 to 4 nodes"),
    }
}

/// Section triad at arc length s: columns `[t, e2, e3]`, turned by the pre-twist about t.
fn triad(start: &M3<f64>, t: V3<f64>, twist_rate: f64, s: f64) -> M3<f64> {
    exp_map(&t.scale_f(twist_rate * s)).mul_m(start)
}

/// Adds the beam's nodes, inertia and elements. Validation has checked the input.
pub fn mesh(
    b: &Beam,
    names: &mut Vec<String>,
    nodes: &mut Vec<NodeState>,
    velocity_given: &mut Vec<bool>,
    mass: &mut Vec<f64>,
    inertia: &mut Vec<M3<f64>>,
) -> BeamMesh {
    let find =
        |names: &Vec<String>, n: &str| names.iter().position(|x| x == n).expect("validated node");
    let start = match (&b.start, &b.start_node) {
        (Some(p), _) => V3(*p),
        (None, Some(n)) => nodes[find(names, n)].x,
        _ => unreachable!("validated"),
    };
    let end = match (&b.end, &b.end_node) {
        (Some(p), _) => V3(*p),
        (None, Some(n)) => nodes[find(names, n)].x,
        _ => unreachable!("validated"),
    };
    let length = (end - start).norm();
    let t = (end - start).scale_f(1.0 / length);
    let trial = b.e2.map(V3).unwrap_or(if t.0[0].abs() < 0.9 {
        V3([1.0, 0.0, 0.0])
    } else {
        V3([0.0, 1.0, 0.0])
    });
    let e2 = trial - t.scale_f(trial.dot(&t));
    let e2 = e2.scale_f(1.0 / e2.norm());
    let start_triad = M3::from_cols(t, e2, t.cross(&e2));
    let section = Section::from_shorthand(&b.section).expect("validated section");
    let j_section = M3([
        [section.mass[3][3], section.mass[3][4], section.mass[3][5]],
        [section.mass[4][3], section.mass[4][4], section.mass[4][5]],
        [section.mass[5][3], section.mass[5][4], section.mass[5][5]],
    ]);
    let n_el = b.elements;
    let nn = b.order + 1;
    let le = length / n_el as f64;
    let zs = node_coordinates(nn);
    // Global node indices along the beam.
    let count = b.node_count();
    let mut ids = Vec::with_capacity(count);
    for k in 0..count {
        let name = b.node_name(k);
        if let Some(i) = names.iter().position(|x| *x == name) {
            ids.push(i);
            continue;
        }
        let e = (k / b.order).min(n_el - 1);
        let local = k - e * b.order;
        let s = le * (e as f64 + 0.5 * (zs[local] + 1.0));
        let x = start + t.scale_f(s);
        let r = triad(&start_triad, t, b.twist_rate, s);
        let omega = V3(b.angular_velocity.unwrap_or_default());
        let v = V3(b.velocity.unwrap_or_default()) + omega.cross(&(x - start));
        names.push(name);
        nodes.push(NodeState {
            x,
            r,
            v,
            w: r.tmul_v(&omega),
        });
        velocity_given.push(b.velocity.is_some() || b.angular_velocity.is_some());
        mass.push(0.0);
        inertia.push(M3::zero());
        ids.push(nodes.len() - 1);
    }
    let mut load_weights = vec![0.0; count];
    let section_triads: Vec<M3<f64>> = (0..count)
        .map(|k| {
            let e = (k / b.order).min(n_el - 1);
            let local = k - e * b.order;
            triad(
                &start_triad,
                t,
                b.twist_rate,
                le * (e as f64 + 0.5 * (zs[local] + 1.0)),
            )
        })
        .collect();
    // Full Gauss integration of the shape functions (exact for straight elements).
    let (xl, wl) = gauss(nn);
    for e in 0..n_el {
        for (&xi, &wq) in xl.iter().zip(wl) {
            let (h, _) = lagrange(nn, xi);
            for a in 0..nn {
                load_weights[e * b.order + a] += h[a] * wq * 0.5 * le;
            }
        }
    }
    let weights = lumping_weights(nn);
    let (xg, wg) = gauss(reduced_points(nn));
    let mut out = Vec::with_capacity(n_el);
    for e in 0..n_el {
        let el_nodes: Vec<usize> = (0..nn).map(|a| ids[e * b.order + a]).collect();
        for (a, &id) in el_nodes.iter().enumerate() {
            let s = le * (e as f64 + 0.5 * (zs[a] + 1.0));
            let w = weights[a] * le;
            mass[id] += w * b.section.m;
            // Section inertia expressed in the node's own triad (a shared node may differ).
            let q = nodes[id]
                .r
                .transpose()
                .mul_m(&triad(&start_triad, t, b.twist_rate, s));
            inertia[id] = inertia[id] + q.mul_m(&j_section).mul_m(&q.transpose()).scale_f(w);
        }
        let mut points = Vec::new();
        let mut history = Vec::new();
        for (&xi, &wq) in xg.iter().zip(wg) {
            let (h, dxi) = lagrange(nn, xi);
            let jac = 0.5 * le;
            let mut dh = [0.0; MAX_NODES];
            for a in 0..nn {
                dh[a] = dxi[a] / jac;
            }
            let s = le * (e as f64 + 0.5 * (xi + 1.0));
            let rg = triad(&start_triad, t, b.twist_rate, s);
            // The interpolated reference tangent (t for a straight beam) sets e₀ so the
            // reference configuration is strain free; the pre-twist is the reference curvature.
            let mut xp = V3::zero();
            for a in 0..nn {
                xp += nodes[el_nodes[a]].x.scale_f(dh[a]);
            }
            let e0 = rg.tmul_v(&xp) - V3([1.0, 0.0, 0.0]);
            let k0 = V3([b.twist_rate, 0.0, 0.0]);
            let mut hist = [0.0; HISTORY_PER_POINT];
            write_history(&mut hist, &rg, &k0);
            history.extend_from_slice(&hist);
            points.push(GaussPoint {
                xi,
                weight: wq * jac,
                h,
                dh,
                stiffness: section.stiffness,
                e0,
                k0,
            });
        }
        out.push(MeshedElement {
            name: format!("{}[{e}]", b.name),
            nodes: el_nodes,
            points,
            history,
        });
    }
    BeamMesh {
        elements: out,
        nodes: ids,
        load_weights,
        section_triads,
        length,
    }
}
