//! Full-field output: at every output time, every node's position and orientation, each
//! beam's section loads at its nodes and each sliding joint's contact point; and the model's
//! topology (which nodes form which beam, the bodies, the joints), so that a viewer or an
//! exporter can draw the whole mechanism. Recorded as extra columns after the sensors'
//! channels, so they share the channels' output times and interpolation within steps.

use serde_json::{json, Value};

use crate::math::vec3::M3;
use crate::model::{Model, SimulationSettings};
use crate::sensors::section_loads_at;
use crate::state::State;
use crate::system::System;

/// A Gauss point's strains and section loads (`BeamElement::gauss_values`).
type GaussValues = ([f64; 6], [f64; 6]);

/// Field output is recorded by default when the run's estimated field data stay below this
/// many bytes (a 200-node model sampled 1000 times takes ~11 MB).
pub const AUTO_FIELDS_BYTES: f64 = 100e6;

/// Columns per node (position x, y, z; orientation quaternion w, x, y, z), per beam point
/// (section loads F1 F2 F3 M1 M2 M3) and per sliding joint (η; contact point x, y, z).
pub const NODE_COLUMNS: usize = 7;
pub const POINT_COLUMNS: usize = 6;
pub const CONTACT_COLUMNS: usize = 4;

/// What the field columns hold, in order: all node positions (node-major, x y z), all node
/// orientations (w x y z), all beam points' section forces (F1 F2 F3), then their moments
/// (M1 M2 M3), all contacts' η, then their points.
#[derive(Clone, Debug)]
pub struct Fields {
    nodes: usize,
    /// Each beam point (every beam's nodes in order along it): its element (global index)
    /// and parent coordinate in it.
    points: Vec<(usize, f64)>,
    /// The sliding joints (kernel indices).
    contacts: Vec<usize>,
}

impl Fields {
    pub fn new(sys: &System) -> Fields {
        let mut points = Vec::new();
        for info in &sys.beam_info {
            let zs = crate::beam::shape::node_coordinates(info.order + 1);
            for k in 0..info.nodes.len() {
                // A node between two elements belongs to the one after it (the last to its own).
                let e = (k / info.order).min(info.count - 1);
                points.push((info.first + e, zs[k - e * info.order]));
            }
        }
        let contacts = (0..sys.joints.len())
            .filter(|&j| sys.joints[j].as_sliding().is_some())
            .collect();
        Fields {
            nodes: sys.layout.n_nodes,
            points,
            contacts,
        }
    }

    pub fn node_count(&self) -> usize {
        self.nodes
    }
    pub fn point_count(&self) -> usize {
        self.points.len()
    }
    pub fn contact_count(&self) -> usize {
        self.contacts.len()
    }

    /// Number of columns per sample.
    pub fn width(&self) -> usize {
        NODE_COLUMNS * self.nodes
            + POINT_COLUMNS * self.points.len()
            + CONTACT_COLUMNS * self.contacts.len()
    }

    /// The columns (relative to the first field column) of the section loads, which come from
    /// strains and are interpolated between step ends like the section sensors.
    pub fn section_load_columns(&self) -> std::ops::Range<usize> {
        let first = NODE_COLUMNS * self.nodes;
        first..first + POINT_COLUMNS * self.points.len()
    }

    /// Appends one sample of the field columns.
    pub fn sample(&self, sys: &System, state: &State, out: &mut Vec<f64>) {
        out.reserve(self.width());
        for n in &state.nodes {
            out.extend_from_slice(&n.x.0);
        }
        for n in &state.nodes {
            out.extend_from_slice(&quaternion(&n.r));
        }
        let mut cached: Option<(usize, Vec<GaussValues>)> = None;
        let first = out.len();
        // Forces of every point, then moments: room for both halves first.
        out.resize(first + POINT_COLUMNS * self.points.len(), 0.0);
        let moments = first + 3 * self.points.len();
        for (p, &(e, xi)) in self.points.iter().enumerate() {
            if cached.as_ref().is_none_or(|(c, _)| *c != e) {
                cached = Some((e, sys.beams[e].gauss_values(state)));
            }
            let values = &cached.as_ref().expect("just set").1;
            let loads = section_loads_at(&sys.beams[e], values, xi);
            out[first + 3 * p..first + 3 * p + 3].copy_from_slice(&loads[..3]);
            out[moments + 3 * p..moments + 3 * p + 3].copy_from_slice(&loads[3..]);
        }
        let contact = |j: usize| {
            let sl = sys.joints[j].as_sliding().expect("a sliding joint");
            let z = state.coords[sl.coord];
            (sl.arc.eta(z), sl.contact(state, z).0)
        };
        out.extend(self.contacts.iter().map(|&j| contact(j).0));
        out.extend(self.contacts.iter().flat_map(|&j| contact(j).1 .0));
    }
}

/// The unit quaternion `(w, x, y, z)` of a rotation, with `w ≥ 0`. Shepperd's method: the
/// largest of `4w², 4x², 4y², 4z²` (from the trace and the diagonal) by a square root, the
/// other components from sums and differences of off-diagonal pairs — no trigonometry (the
/// fields sample every node at every step).
pub fn quaternion(rm: &M3<f64>) -> [f64; 4] {
    let m = &rm.0;
    let trace = m[0][0] + m[1][1] + m[2][2];
    let q = if trace >= m[0][0].max(m[1][1]).max(m[2][2]) {
        let s = 2.0 * (1.0 + trace).sqrt(); // 4w
        [
            0.25 * s,
            (m[2][1] - m[1][2]) / s,
            (m[0][2] - m[2][0]) / s,
            (m[1][0] - m[0][1]) / s,
        ]
    } else if m[0][0] >= m[1][1] && m[0][0] >= m[2][2] {
        let s = 2.0 * (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt(); // 4x
        [
            (m[2][1] - m[1][2]) / s,
            0.25 * s,
            (m[0][1] + m[1][0]) / s,
            (m[0][2] + m[2][0]) / s,
        ]
    } else if m[1][1] >= m[2][2] {
        let s = 2.0 * (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt(); // 4y
        [
            (m[0][2] - m[2][0]) / s,
            (m[0][1] + m[1][0]) / s,
            0.25 * s,
            (m[1][2] + m[2][1]) / s,
        ]
    } else {
        let s = 2.0 * (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt(); // 4z
        [
            (m[1][0] - m[0][1]) / s,
            (m[0][2] + m[2][0]) / s,
            (m[1][2] + m[2][1]) / s,
            0.25 * s,
        ]
    };
    // Unit to round-off, and the hemisphere w ≥ 0.
    let scale = q[0].signum() / q.iter().map(|c| c * c).sum::<f64>().sqrt();
    q.map(|c| c * scale)
}

/// Expected number of samples of a run: one per `output_dt`, else one per step of `dt`
/// (adaptive steps usually grow past it, so this errs high).
pub fn estimated_samples(settings: &SimulationSettings) -> f64 {
    if settings.analysis == crate::model::Analysis::Static {
        return f64::from(settings.load_steps) + 1.0;
    }
    let interval = settings.output_dt.unwrap_or(settings.dt);
    (settings.t_end / interval).ceil() + 1.0
}

/// Whether a run records fields: as the model says, else when their estimated size is
/// below `AUTO_FIELDS_BYTES`.
pub fn fields_enabled(settings: &SimulationSettings, fields: &Fields) -> bool {
    settings.fields.unwrap_or_else(|| {
        estimated_samples(settings) * 8.0 * fields.width() as f64 <= AUTO_FIELDS_BYTES
    })
}

/// The model's topology, for drawing it: nodes (names, indices into the field arrays), beams
/// (their nodes in order, arc lengths, and each node's section triad relative to the node's
/// own triad as a quaternion), rigid bodies (node, mass, inertia, centre-of-mass offset),
/// joints (type, the nodes of their two sides, `null` for the ground, the attachment points
/// in the nodes' triads) and sliding joints (beam, follower, index among the contacts).
pub fn topology(model: &Model, sys: &System) -> Value {
    let beams: Vec<Value> = sys
        .beam_info
        .iter()
        .map(|b| beam_topology(b, sys))
        .collect();
    let bodies: Vec<Value> = model
        .bodies
        .iter()
        .map(|b| {
            json!({
                "name": b.name, "node": sys.node_index(&b.node), "mass": b.mass,
                "inertia": b.inertia.matrix(), "cm_offset": b.cm_offset,
            })
        })
        .collect();
    let mut joints = Vec::new();
    let mut contacts = Vec::new();
    for (j, kernel) in sys.joints.iter().enumerate() {
        let kind = model
            .joints
            .iter()
            .find(|m| m.name() == kernel.name())
            .map_or("internal", |m| m.kind());
        match kernel {
            crate::joints::Joint::Pair(k) => joints.push(pair_topology(k, kind)),
            crate::joints::Joint::Sliding(s) => {
                let follower = match s.follower {
                    crate::joints::Side::Node(n) => Some(n),
                    crate::joints::Side::Ground { .. } => None,
                };
                contacts.push(json!({
                    "name": s.name, "type": kind, "beam": s.beam, "follower": follower,
                    "kernel": j,
                }));
            }
        }
    }
    json!({
        "nodes": sys.node_names,
        "beams": beams,
        "bodies": bodies,
        "joints": joints,
        "contacts": contacts,
        "length_ref": sys.length_ref,
    })
}

fn beam_topology(b: &crate::system::BeamInfo, sys: &System) -> Value {
    let zs = crate::beam::shape::node_coordinates(b.order + 1);
    let (mut s_of, mut offsets) = (Vec::new(), Vec::new());
    for (k, &n) in b.nodes.iter().enumerate() {
        let e = (k / b.order).min(b.count - 1);
        let (sa, sb) = b.spans[e];
        let s = sa + 0.5 * (zs[k - e * b.order] + 1.0) * (sb - sa);
        let section = b.line.section_triad(b.line.segment_at(s.min(b.length)), s);
        // The section triad in the node's own triad (identity but for shared end nodes).
        offsets.push(quaternion(
            &sys.initial.nodes[n].r.transpose().mul_m(&section),
        ));
        s_of.push(s);
    }
    json!({
        "name": b.name, "nodes": b.nodes, "order": b.order, "length": b.length,
        "s": s_of, "section_offsets": offsets,
    })
}

fn pair_topology(k: &crate::joints::JointKernel, kind: &str) -> Value {
    use crate::joints::{ConstraintLaw, Side};
    let att = k.law.attachments();
    let sides: Vec<Value> = k
        .sides
        .iter()
        .zip(att.iter())
        .map(|(side, a)| match side {
            Side::Node(n) => json!({"node": n, "offset": a.offset.0}),
            Side::Ground { x, r } => json!({"node": null, "point": (*x + r.mul_v(&a.offset)).0}),
        })
        .collect();
    json!({"name": k.name, "type": kind, "sides": sides})
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rotation::exp_map;
    use crate::math::vec3::V3;

    /// `R` rebuilt from a unit quaternion (w, x, y, z).
    fn matrix(q: [f64; 4]) -> M3<f64> {
        let [w, x, y, z] = q;
        M3([
            [
                1.0 - 2.0 * (y * y + z * z),
                2.0 * (x * y - w * z),
                2.0 * (x * z + w * y),
            ],
            [
                2.0 * (x * y + w * z),
                1.0 - 2.0 * (x * x + z * z),
                2.0 * (y * z - w * x),
            ],
            [
                2.0 * (x * z - w * y),
                2.0 * (y * z + w * x),
                1.0 - 2.0 * (x * x + y * y),
            ],
        ])
    }

    #[test]
    fn quaternions_rebuild_their_rotation_to_round_off_up_to_a_half_turn() {
        // Angles from 0 through π, about axes that make each of Shepperd's four branches the
        // largest (w near no turn; x, y or z near a half turn about that axis).
        let axes = [
            V3([1.0, -2.0, 0.5]),
            V3([1.0, 0.1, -0.2]),
            V3([0.1, -1.0, 0.3]),
            V3([-0.2, 0.3, 1.0]),
        ];
        for axis in axes {
            for angle in [0.0, 1e-10, 1e-3, 0.7, 2.0, 3.1, std::f64::consts::PI] {
                let rm = exp_map(&axis.scale_f(angle / axis.norm()));
                let q = quaternion(&rm);
                let norm: f64 = q.iter().map(|c| c * c).sum();
                assert!((norm - 1.0).abs() < 1e-15, "unit: {norm}");
                assert!(q[0] >= 0.0);
                let err = (matrix(q) - rm).max_abs();
                // A few ε of the unit entries.
                assert!(err < 2e-15, "angle {angle} about {axis:?}: {err:e}");
                // The rotation's own angle and axis: w = cos(φ/2), (x, y, z) = sin(φ/2) n.
                let n = axis.scale_f(1.0 / axis.norm());
                let (w, v) = ((0.5 * angle).cos(), n.scale_f((0.5 * angle).sin()));
                let off_by = |sign: f64| {
                    (q[0] - sign * w)
                        .abs()
                        .max((V3([q[1], q[2], q[3]]) - v.scale_f(sign)).norm())
                };
                // At a half turn w is round-off, and ±(0, n) are the same rotation.
                let off = if angle == std::f64::consts::PI {
                    off_by(1.0).min(off_by(-1.0))
                } else {
                    off_by(1.0)
                };
                assert!(off < 1e-15, "angle {angle} about {axis:?}: {off:e}");
            }
        }
    }
}
