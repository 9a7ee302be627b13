//! Meshing a beam along its reference line (straight, arc or polyline; pre-twisted): nodes with
//! their reference triads, lumped nodal inertia, consistent load weights, and per element the
//! Gauss points with their section, reference strains and initial history.

use crate::beam::element::{write_history, GaussPoint, HISTORY_PER_POINT};
use crate::beam::geometry::ReferenceLine;
use crate::beam::section::Section;
use crate::beam::shape::{gauss, lagrange, node_coordinates, reduced_points, MAX_NODES};
use crate::math::vec3::{M3, V3};
use crate::model::Beam;
use crate::state::NodeState;

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
    /// Arc-length span `(s_start, s_end)` of each element.
    pub spans: Vec<(f64, f64)>,
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

/// The section at arc length `s` of a beam of length `length`: its one section, or the
/// linear blend of the stations around `s`.
pub fn section_at(b: &Beam, length: f64, s: f64) -> Section {
    if let Some(sec) = &b.section {
        return sec.section().expect("validated section");
    }
    let eta = (s / length).clamp(0.0, 1.0);
    let st = &b.sections;
    let j = st
        .windows(2)
        .position(|w| eta <= w[1].eta)
        .unwrap_or(st.len() - 2);
    let (a, c) = (&st[j], &st[j + 1]);
    let w = (eta - a.eta) / (c.eta - a.eta);
    Section::blend(
        &a.section.section().expect("validated section"),
        &c.section.section().expect("validated section"),
        w,
    )
}

/// Lumped inertia per node, about the node and in its triad: mass, first moment of mass
/// `Σ m c` (non-zero when sections have an offset centre of mass) and inertia tensor.
#[derive(Clone, Debug, Default)]
pub struct Lumped {
    pub mass: Vec<f64>,
    pub first_moment: Vec<V3<f64>>,
    pub inertia: Vec<M3<f64>>,
}

impl Lumped {
    pub fn push_node(&mut self) {
        self.mass.push(0.0);
        self.first_moment.push(V3::zero());
        self.inertia.push(M3::zero());
    }
}

/// Adds the beam's nodes, inertia and elements. Validation has checked the input.
pub fn mesh(
    b: &Beam,
    names: &mut Vec<String>,
    nodes: &mut Vec<NodeState>,
    velocity_given: &mut Vec<bool>,
    lumped: &mut Lumped,
) -> BeamMesh {
    let find =
        |names: &Vec<String>, n: &str| names.iter().position(|x| x == n).expect("validated node");
    let start = match (&b.start, &b.start_node) {
        (Some(p), _) => V3(*p),
        (None, Some(n)) => nodes[find(names, n)].x,
        _ => unreachable!("validated"),
    };
    let end = match (&b.end, &b.end_node, &b.arc) {
        (_, _, Some(arc)) => V3(crate::beam::geometry::arc_end(start.0, arc)),
        (Some(p), _, _) => V3(*p),
        (None, Some(n), _) => nodes[find(names, n)].x,
        _ => unreachable!("validated"),
    };
    let line = ReferenceLine::new(b, start.0, end.0).expect("validated geometry");
    let length = line.length();
    let spans = line.element_spans(b.elements);
    let n_el = spans.len();
    let nn = b.order + 1;
    let zs = node_coordinates(nn);
    // Arc length of local node `a` of element `e`, and its segment.
    let node_s = |e: usize, a: usize| {
        let (_, sa, sb) = spans[e];
        sa + 0.5 * (zs[a] + 1.0) * (sb - sa)
    };
    // Global node indices along the beam.
    let count = b.node_count();
    let mut ids = Vec::with_capacity(count);
    for k in 0..count {
        let e = (k / b.order).min(n_el - 1);
        let local = k - e * b.order;
        let s = node_s(e, local);
        let r = line.section_triad(spans[e].0, s);
        let name = b.node_name(k);
        // Only the end nodes can be existing nodes (`start_node`/`end_node`); the others are
        // new `<beam>.k` (names cannot contain `.`), so no search: meshing stays linear.
        let shared = (k == 0 && b.start_node.is_some()) || (k + 1 == count && b.end_node.is_some());
        if shared {
            ids.push(find(names, &name));
            continue;
        }
        let x = line.point(spans[e].0, s);
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
        lumped.push_node();
        ids.push(nodes.len() - 1);
    }
    // Consistent load weights ∫ h_α ds (full Gauss integration, exact).
    let mut load_weights = vec![0.0; count];
    let (xl, wl) = gauss(nn);
    for (e, &(_, sa, sb)) in spans.iter().enumerate() {
        for (&xi, &wq) in xl.iter().zip(wl) {
            let (h, _) = lagrange(nn, xi);
            for a in 0..nn {
                load_weights[e * b.order + a] += h[a] * wq * 0.5 * (sb - sa);
            }
        }
    }
    let weights = lumping_weights(nn);
    let (xg, wg) = gauss(reduced_points(nn));
    let mut out = Vec::with_capacity(n_el);
    for (e, &(seg, sa, sb)) in spans.iter().enumerate() {
        let le = sb - sa;
        let el_nodes: Vec<usize> = (0..nn).map(|a| ids[e * b.order + a]).collect();
        for (a, &id) in el_nodes.iter().enumerate() {
            let s = node_s(e, a);
            let w = weights[a] * le;
            let section = section_at(b, length, s);
            let m = w * section.mass_per_length();
            // Section properties expressed in the node's own triad (a shared node may differ).
            let q = nodes[id].r.transpose().mul_m(&line.section_triad(seg, s));
            lumped.mass[id] += m;
            lumped.first_moment[id] += q.mul_v(&section.cm_offset()).scale_f(m);
            lumped.inertia[id] = lumped.inertia[id]
                + q.mul_m(&section.inertia_per_length())
                    .mul_m(&q.transpose())
                    .scale_f(w);
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
            let s = sa + 0.5 * (xi + 1.0) * le;
            let rg = line.section_triad(seg, s);
            // The interpolated reference tangent sets e₀ so that the reference configuration
            // is strain free (it differs from t on curved lines by the interpolation error).
            let mut xp = V3::zero();
            for a in 0..nn {
                xp += nodes[el_nodes[a]].x.scale_f(dh[a]);
            }
            let e0 = rg.tmul_v(&xp) - V3([1.0, 0.0, 0.0]);
            let k0 = line.curvature(seg, s);
            let mut hist = [0.0; HISTORY_PER_POINT];
            write_history(&mut hist, &rg, &k0);
            history.extend_from_slice(&hist);
            points.push(GaussPoint {
                xi,
                weight: wq * jac,
                h,
                dh,
                stiffness: section_at(b, length, s).stiffness,
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
        spans: spans.iter().map(|&(_, a, b)| (a, b)).collect(),
        length,
    }
}
