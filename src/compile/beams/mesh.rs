//! Meshing a beam along its reference line (straight, arc or polyline; pre-twisted): nodes with
//! their reference triads, lumped nodal inertia, consistent load weights, and per element the
//! Gauss points with their section, reference strains and initial history.

use super::section_of;
use crate::beam::element::{write_history, GaussPoint, HISTORY_PER_POINT};
use crate::beam::geometry::ReferenceLine;
use crate::beam::section::Section;
use crate::beam::shape::{gauss, lagrange, node_coordinates, reduced_points, MAX_NODES};
use crate::compile::nodes::{Lumped, NodeTable};
use crate::math::vec3::{M3, V3};
use crate::model::Beam;
use crate::state::NodeState;
use crate::system::VelocityGiven;

/// One element before numbering of unknowns: its nodes, Gauss points and initial history.
pub struct MeshedElement {
    pub name: String,
    pub nodes: Vec<usize>,
    pub points: Vec<GaussPoint>,
    pub history: Vec<f64>,
    /// Mass-proportional damping per local node (`α m`, `α J`), empty if none.
    pub mass_damping: Vec<(f64, M3<f64>)>,
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
        return section_of(sec).expect("validated section");
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
        &section_of(&a.section).expect("validated section"),
        &section_of(&c.section).expect("validated section"),
        w,
    )
}

/// Adds the beam's nodes, inertia and elements along `line` from `start`. Validation has
/// checked the input.
pub fn mesh(b: &Beam, line: &ReferenceLine, start: V3<f64>, table: &mut NodeTable) -> BeamMesh {
    let length = line.length();
    let spans = line.element_spans(b.elements);
    let along = Along::new(b, &spans);
    let ids = place_nodes(b, line, &along, start, table);
    let mut out = Vec::with_capacity(spans.len());
    for (e, &(seg, sa, sb)) in spans.iter().enumerate() {
        let el_nodes: Vec<usize> = (0..along.nn).map(|a| ids[e * b.order + a]).collect();
        let alpha = b.damping.as_ref().and_then(|d| d.mass_proportional);
        let mut mass_damping = Vec::new();
        for (a, &id) in el_nodes.iter().enumerate() {
            let s = along.node_s(e, a);
            let (m, j) = lump(
                &mut table.lumped,
                id,
                &table.states[id],
                &line.section_triad(seg, s),
                &section_at(b, length, s),
                along.lumping[a] * (sb - sa),
            );
            if let Some(alpha) = alpha.filter(|&a| a > 0.0) {
                mass_damping.push((alpha * m, j.scale_f(alpha)));
            }
        }
        let (points, history) =
            gauss_points(b, line, length, (seg, sa, sb), &el_nodes, &table.states);
        out.push(MeshedElement {
            name: format!("{}[{e}]", b.name),
            nodes: el_nodes,
            points,
            history,
            mass_damping,
        });
    }
    BeamMesh {
        elements: out,
        nodes: ids,
        load_weights: load_weights(b, &spans),
        spans: spans.iter().map(|&(_, a, b)| (a, b)).collect(),
        length,
    }
}

/// Where the nodes of a beam's elements sit along it.
struct Along<'a> {
    spans: &'a [(usize, f64, f64)],
    /// Nodes per element and their parent coordinates.
    nn: usize,
    zs: &'static [f64],
    /// Each local node's share of the element's length in the lumped inertia.
    lumping: &'static [f64],
}

impl<'a> Along<'a> {
    fn new(b: &Beam, spans: &'a [(usize, f64, f64)]) -> Self {
        let nn = b.order + 1;
        Along {
            spans,
            nn,
            zs: node_coordinates(nn),
            lumping: lumping_weights(nn),
        }
    }

    /// Arc length of local node `a` of element `e`.
    fn node_s(&self, e: usize, a: usize) -> f64 {
        let (_, sa, sb) = self.spans[e];
        sa + 0.5 * (self.zs[a] + 1.0) * (sb - sa)
    }
}

/// The beam's global node indices along it, creating its nodes (`<beam>.k`) with their triads
/// and initial velocities (rigid motion from the beam's `velocity` and `angular_velocity`).
fn place_nodes(
    b: &Beam,
    line: &ReferenceLine,
    along: &Along,
    start: V3<f64>,
    table: &mut NodeTable,
) -> Vec<usize> {
    let n_el = along.spans.len();
    let count = b.node_count();
    let mut ids = Vec::with_capacity(count);
    for k in 0..count {
        let e = (k / b.order).min(n_el - 1);
        let s = along.node_s(e, k - e * b.order);
        let seg = along.spans[e].0;
        let name = b.node_name(k);
        // Only the end nodes can be existing nodes (`start_node`/`end_node`); the others are
        // new `<beam>.k` (names cannot contain `.`), so no search: meshing stays linear.
        let shared = (k == 0 && b.start_node.is_some()) || (k + 1 == count && b.end_node.is_some());
        if shared {
            ids.push(table.index(&name));
            continue;
        }
        let (x, r) = (line.point(seg, s), line.section_triad(seg, s));
        let omega = V3(b.angular_velocity.unwrap_or_default());
        let v = V3(b.velocity.unwrap_or_default()) + omega.cross(&(x - start));
        let state = NodeState {
            x,
            r,
            v,
            w: r.tmul_v(&omega),
        };
        // A beam's velocities are a rigid motion: given whole, or not at all.
        let moving = b.velocity.is_some() || b.angular_velocity.is_some();
        let given = if moving {
            VelocityGiven::BOTH
        } else {
            VelocityGiven::default()
        };
        ids.push(table.push(name, state, given));
    }
    ids
}

/// Consistent load weights `∫ h_α ds` per beam node (full Gauss integration, exact).
fn load_weights(b: &Beam, spans: &[(usize, f64, f64)]) -> Vec<f64> {
    let nn = b.order + 1;
    let mut out = vec![0.0; b.node_count()];
    let (xl, wl) = gauss(nn);
    for (e, &(_, sa, sb)) in spans.iter().enumerate() {
        for (&xi, &wq) in xl.iter().zip(wl) {
            let (h, _) = lagrange(nn, xi);
            for a in 0..nn {
                out[e * b.order + a] += h[a] * wq * 0.5 * (sb - sa);
            }
        }
    }
    out
}

/// Adds a length `w` of `section` (at section triad `rs`) to node `id`'s lumped inertia,
/// expressed in the node's own triad (a shared node's may differ). Returns the mass and the
/// rotary inertia (about the node, its triad) it added.
fn lump(
    lumped: &mut Lumped,
    id: usize,
    node: &NodeState,
    rs: &M3<f64>,
    section: &Section,
    w: f64,
) -> (f64, M3<f64>) {
    let m = w * section.mass_per_length();
    let q = node.r.transpose().mul_m(rs);
    let j = q
        .mul_m(&section.inertia_per_length())
        .mul_m(&q.transpose())
        .scale_f(w);
    lumped.mass[id] += m;
    lumped.first_moment[id] += q.mul_v(&section.cm_offset()).scale_f(m);
    lumped.inertia[id] = lumped.inertia[id] + j;
    (m, j)
}

/// An element's Gauss points (reduced integration) with their sections, reference strains
/// and initial history.
fn gauss_points(
    b: &Beam,
    line: &ReferenceLine,
    length: f64,
    (seg, sa, sb): (usize, f64, f64),
    el_nodes: &[usize],
    nodes: &[NodeState],
) -> (Vec<GaussPoint>, Vec<f64>) {
    let (nn, le) = (b.order + 1, sb - sa);
    let (xg, wg) = gauss(reduced_points(nn));
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
        let stiffness = section_at(b, length, s).stiffness;
        points.push(GaussPoint {
            xi,
            weight: wq * jac,
            h,
            dh,
            damping: b
                .damping
                .as_ref()
                .and_then(|d| d.section_matrix(&stiffness)),
            stiffness,
            e0,
            k0,
        });
    }
    (points, history)
}
