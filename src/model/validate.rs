//! Semantic checks of a parsed model. Every error names the item by its path in the file
//! (`joints[3].axis`) and its name, and says how to fix it.

use super::*;
use crate::math::time_function::TimeFunction;
use std::collections::HashMap;
use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub struct ModelError {
    pub path: String,
    pub message: String,
}

impl ModelError {
    pub fn new(path: impl Into<String>, message: impl Into<String>) -> Self {
        ModelError {
            path: path.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            write!(f, "{}", self.message)
        } else {
            write!(f, "{}: {}", self.path, self.message)
        }
    }
}

/// All problems found in a model, one line each.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelErrors(pub Vec<ModelError>);

impl ModelErrors {
    pub fn one(e: ModelError) -> Self {
        ModelErrors(vec![e])
    }
}

impl fmt::Display for ModelErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let lines: Vec<String> = self.0.iter().map(|e| e.to_string()).collect();
        write!(f, "{}", lines.join("\n"))
    }
}

impl std::error::Error for ModelErrors {}

const UNIT_TOL: f64 = 1e-6;

fn finite3(v: &Vec3) -> bool {
    v.iter().all(|x| x.is_finite())
}
fn norm(v: &Vec3) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Cholesky test of a symmetric 3×3 matrix.
fn is_spd(m: &Mat3) -> bool {
    let a = m[0][0];
    if a <= 0.0 {
        return false;
    }
    let l10 = m[1][0] / a.sqrt();
    let d1 = m[1][1] - l10 * l10;
    if d1 <= 0.0 {
        return false;
    }
    let l20 = m[2][0] / a.sqrt();
    let l21 = (m[2][1] - l20 * l10) / d1.sqrt();
    m[2][2] - l20 * l20 - l21 * l21 > 0.0
}

struct Checker {
    errors: Vec<ModelError>,
}

impl Checker {
    fn err(&mut self, path: impl Into<String>, msg: impl Into<String>) {
        self.errors.push(ModelError::new(path, msg));
    }
    fn vec3(&mut self, path: String, v: &Vec3) {
        if !finite3(v) {
            self.err(path, "must contain three finite numbers");
        }
    }
    fn unit(&mut self, path: String, v: &Vec3, what: &str) {
        let n = norm(v);
        if !finite3(v) || (n - 1.0).abs() > UNIT_TOL {
            self.err(
                path,
                format!("must be a unit vector (|{what}| = {n:.6}); divide it by its length"),
            );
        }
    }
    fn time_function(&mut self, path: String, f: &TimeFunctionSpec) {
        if let Err(e) = TimeFunction::new(f) {
            self.err(path, e);
        }
    }
}

impl Model {
    /// A sliding joint's beam exists, its η stays on it, and a free contact point can start
    /// anywhere on it.
    fn check_sliding(&self, c: &mut Checker, p: &str, sl: &super::SlidingJoint) {
        let who = format!("sliding joint `{}`", sl.name);
        let Some(beam) = self.beams.iter().find(|b| b.name == sl.beam) else {
            c.err(
                format!("{p}.beam"),
                format!(
                    "{who} refers to beam `{}`, which is not defined in `beams`",
                    sl.beam
                ),
            );
            return;
        };
        let own_node = sl
            .follower
            .strip_prefix(&format!("{}.", sl.beam))
            .is_some_and(|k| k.parse::<usize>().is_ok());
        if own_node
            || [&beam.start_node, &beam.end_node]
                .iter()
                .any(|n| n.as_deref() == Some(sl.follower.as_str()))
        {
            c.err(format!("{p}.follower"), format!("{who}: the follower `{}` is a node of beam `{}` itself; a follower must belong to another body", sl.follower, sl.beam));
        }
        if let Some(eta) = sl.eta {
            if !(0.0..=1.0).contains(&eta) {
                c.err(
                    format!("{p}.eta"),
                    format!("{who}: η must lie on the beam, in [0, 1] (got {eta})"),
                );
            }
            if sl.drive.is_some() {
                c.err(
                    format!("{p}.eta"),
                    format!(
                        "{who}: the drive sets the initial η (its value at t = 0); remove `eta`"
                    ),
                );
            }
        }
        if let Some(stops) = &sl.end_stops {
            if !(stops.stiffness.is_finite() && stops.stiffness > 0.0) {
                c.err(
                    format!("{p}.end_stops.stiffness"),
                    format!(
                        "{who}: must be a positive number of N/m (got {})",
                        stops.stiffness
                    ),
                );
            }
            if sl.drive.is_some() {
                c.err(format!("{p}.end_stops"), format!("{who}: a prescribed η never reaches a stop; remove `end_stops` or the drive"));
            }
        }
        if let Some(Ok(f)) = sl.drive.as_ref().map(TimeFunction::new) {
            if let Some((t, eta)) = drive_leaves_beam(&f, self.simulation.t_end) {
                c.err(format!("{p}.drive"), format!("{who}: the prescribed η leaves the beam at t = {t:.6} s (η = {eta:.6}); η must stay in [0, 1] over the whole run"));
            }
        }
    }

    /// Checks references, physical admissibility and settings; returns every problem found.
    pub fn validate(&self) -> Result<(), ModelErrors> {
        let mut c = Checker { errors: Vec::new() };
        // Size first: a model over the limits is refused before its mesh is even named.
        self.check_size(&mut c);
        if !c.errors.is_empty() {
            return Err(ModelErrors(c.errors));
        }
        c.vec3("gravity".into(), &self.gravity);

        // Names are unique across all items so that every reference is unambiguous.
        let mut seen: HashMap<String, String> = HashMap::new();
        let mut name = |c: &mut Checker, path: String, n: &str| {
            if let Err(e) = safe_name(n) {
                c.err(format!("{path}.name"), e);
            } else if n == GROUND {
                c.err(
                    format!("{path}.name"),
                    "`ground` is reserved for the inertial frame; choose another name",
                );
            } else if let Some(first) = seen.get(n) {
                c.err(
                    format!("{path}.name"),
                    format!("duplicate name `{n}` (already used by {first}); names must be unique"),
                );
            } else {
                seen.insert(n.to_string(), path);
            }
        };
        let items = || {
            let a = self
                .nodes
                .iter()
                .enumerate()
                .map(|(i, n)| (format!("nodes[{i}]"), n.name.as_str()));
            let b = self
                .bodies
                .iter()
                .enumerate()
                .map(|(i, n)| (format!("bodies[{i}]"), n.name.as_str()))
                .chain(
                    self.beams
                        .iter()
                        .enumerate()
                        .map(|(i, n)| (format!("beams[{i}]"), n.name.as_str())),
                );
            let j = self
                .joints
                .iter()
                .enumerate()
                .map(|(i, n)| (format!("joints[{i}]"), n.name()));
            let l = self
                .loads
                .iter()
                .enumerate()
                .map(|(i, n)| (format!("loads[{i}]"), n.name()));
            let s = self
                .sensors
                .iter()
                .enumerate()
                .map(|(i, n)| (format!("sensors[{i}]"), n.name()));
            a.chain(b).chain(j).chain(l).chain(s).collect::<Vec<_>>()
        };
        for (path, n) in items() {
            name(&mut c, path, n);
        }

        let model_nodes: HashMap<String, usize> = self
            .nodes
            .iter()
            .enumerate()
            .map(|(i, n)| (n.name.clone(), i))
            .collect();
        // Beams add their nodes `<beam>.k` (shared end nodes keep their own names).
        let mut node_names = model_nodes.clone();
        for b in &self.beams {
            if (1..=3).contains(&b.order) && b.elements >= 1 {
                for k in 0..b.node_count() {
                    let next = node_names.len();
                    node_names.entry(b.node_name(k)).or_insert(next);
                }
            }
        }
        let node_ref = |c: &mut Checker, path: String, n: &str, allow_ground: bool| {
            if n == GROUND {
                if !allow_ground {
                    c.err(path, "cannot be `ground` here; give a node name");
                }
            } else if !node_names.contains_key(n) {
                c.err(
                    path,
                    format!("refers to node `{n}`, which is not defined in `nodes`"),
                );
            }
        };

        for (i, n) in self.nodes.iter().enumerate() {
            let p = format!("nodes[{i}]");
            c.vec3(format!("{p}.position"), &n.position);
            if let Some(v) = &n.velocity {
                c.vec3(format!("{p}.velocity"), v);
            }
            if let Some(v) = &n.angular_velocity {
                c.vec3(format!("{p}.angular_velocity"), v);
            }
            let o = &n.orientation;
            if o.matrix.is_some() && o.rotation_vector.is_some() {
                c.err(
                    format!("{p}.orientation"),
                    format!(
                        "node `{}`: give either `matrix` or `rotation_vector`, not both",
                        n.name
                    ),
                );
            }
            if let Some(m) = &o.matrix {
                let r = crate::math::vec3::M3(*m);
                if let Err(e) = crate::math::rotation::check_rotation(&r, 1e-9) {
                    c.err(
                        format!("{p}.orientation.matrix"),
                        format!(
                            "node `{}`: {e}; columns must be orthonormal unit vectors",
                            n.name
                        ),
                    );
                }
            }
            if let Some(v) = &o.rotation_vector {
                c.vec3(format!("{p}.orientation.rotation_vector"), v);
            }
        }

        for (i, b) in self.beams.iter().enumerate() {
            let p = format!("beams[{i}]");
            let name = &b.name;
            for (field, point, node) in [
                ("start", &b.start, &b.start_node),
                ("end", &b.end, &b.end_node),
            ] {
                match (point, node) {
                    (Some(_), Some(_)) => c.err(
                        format!("{p}.{field}"),
                        format!("beam `{name}`: give only one of `{field}` and `{field}_node`"),
                    ),
                    // An arc's end follows from its start, angle and axis.
                    (None, None) if field == "end" && b.arc.is_some() => {}
                    (None, None) => c.err(
                        format!("{p}.{field}"),
                        format!("beam `{name}`: give exactly one of `{field}` and `{field}_node`"),
                    ),
                    (Some(v), None) => c.vec3(format!("{p}.{field}"), v),
                    (None, Some(n)) => {
                        if !model_nodes.contains_key(n.as_str()) {
                            c.err(
                                format!("{p}.{field}_node"),
                                format!("refers to node `{n}`, which is not defined in `nodes`"),
                            );
                        }
                    }
                }
            }
            if b.elements == 0 {
                c.err(
                    format!("{p}.elements"),
                    format!("beam `{name}`: needs at least one element"),
                );
            }
            if !(1..=3).contains(&b.order) {
                c.err(
                    format!("{p}.order"),
                    format!("beam `{name}`: order must be 1 (linear), 2 (quadratic) or 3 (cubic), got {}", b.order),
                );
            }
            let check_section =
                |c: &mut Checker, path: String, spec: &crate::beam::section::SectionSpec| match spec
                    .section()
                    .and_then(|s| s.check_lumpable())
                {
                    Err(e) => c.err(path, format!("beam `{name}`: {e}")),
                    Ok(()) => {}
                };
            match (&b.section, b.sections.is_empty()) {
                (Some(_), false) | (None, true) => c.err(
                    format!("{p}.section"),
                    format!("beam `{name}`: give either `section` (uniform) or `sections` (stations along the span)"),
                ),
                (Some(spec), true) => check_section(&mut c, format!("{p}.section"), spec),
                (None, false) => {
                    let etas: Vec<f64> = b.sections.iter().map(|st| st.eta).collect();
                    if let Err(e) = stations(&etas) {
                        c.err(format!("{p}.sections"), format!("beam `{name}`: section stations {e}"));
                    }
                    for (k, st) in b.sections.iter().enumerate() {
                        check_section(&mut c, format!("{p}.sections[{k}].section"), &st.section);
                    }
                }
            }
            if let Some(e2) = &b.e2 {
                c.vec3(format!("{p}.e2"), e2);
            }
            for (field, v) in [
                ("velocity", &b.velocity),
                ("angular_velocity", &b.angular_velocity),
            ] {
                if let Some(v) = v {
                    c.vec3(format!("{p}.{field}"), v);
                }
            }
            if !b.twist_rate.is_finite() {
                c.err(format!("{p}.twist_rate"), "must be a finite number");
            }
            if let Some(t) = &b.twist {
                if b.twist_rate != 0.0 {
                    c.err(
                        format!("{p}.twist"),
                        format!(
                            "beam `{name}`: give either `twist_rate` or a `twist` table, not both"
                        ),
                    );
                }
                if t.eta.len() != t.angle.len() || !t.angle.iter().all(|a| a.is_finite()) {
                    c.err(format!("{p}.twist"), format!("beam `{name}`: `eta` and `angle` must be lists of finite numbers of the same length"));
                } else if let Err(e) = stations(&t.eta) {
                    c.err(
                        format!("{p}.twist.eta"),
                        format!("beam `{name}`: twist stations {e}"),
                    );
                }
            }
            if let Some(arc) = &b.arc {
                c.vec3(format!("{p}.arc.center"), &arc.center);
                c.vec3(format!("{p}.arc.axis"), &arc.axis);
                if !b.via.is_empty() {
                    c.err(
                        format!("{p}.via"),
                        format!("beam `{name}`: give either `arc` or `via` points, not both"),
                    );
                }
            }
            for (k, v) in b.via.iter().enumerate() {
                c.vec3(format!("{p}.via[{k}]"), v);
            }
            if b.elements > 0 && b.elements < b.via.len() + 1 {
                c.err(
                    format!("{p}.elements"),
                    format!("beam `{name}`: a polyline of {} segments needs at least one element per segment", b.via.len() + 1),
                );
            }
            // The line itself (arc in its plane and reaching the end, no folds, no repeated
            // points), once its end points are known.
            if let Some((a, e)) = b.end_points(self) {
                if let Err(msg) = crate::beam::geometry::ReferenceLine::new(b, a, e) {
                    c.err(p.clone(), format!("beam `{name}`: {msg}"));
                }
            }
        }

        for (i, b) in self.bodies.iter().enumerate() {
            let p = format!("bodies[{i}]");
            node_ref(&mut c, format!("{p}.node"), &b.node, false);
            if !(b.mass.is_finite() && b.mass > 0.0) {
                c.err(
                    format!("{p}.mass"),
                    format!("body `{}`: mass must be positive (got {})", b.name, b.mass),
                );
            }
            let m = b.inertia.matrix();
            let finite = m.iter().flatten().all(|x| x.is_finite());
            let scale = m.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
            let sym = (0..3).all(|r| (0..3).all(|s| (m[r][s] - m[s][r]).abs() <= 1e-9 * scale));
            if !finite || !sym {
                c.err(
                    format!("{p}.inertia"),
                    format!(
                        "body `{}`: inertia must be a symmetric matrix of finite numbers",
                        b.name
                    ),
                );
            } else if !is_spd(&m) {
                c.err(
                    format!("{p}.inertia"),
                    format!(
                        "body `{}`: inertia must be positive definite (all principal moments > 0)",
                        b.name
                    ),
                );
            }
            c.vec3(format!("{p}.cm_offset"), &b.cm_offset);
        }

        let joint_names: HashMap<&str, &Joint> =
            self.joints.iter().map(|j| (j.name(), j)).collect();
        for (i, j) in self.joints.iter().enumerate() {
            let p = format!("joints[{i}]");
            let (n1, n2) = j.nodes();
            if let Some(sl) = j.sliding() {
                self.check_sliding(&mut c, &p, sl);
                node_ref(&mut c, format!("{p}.follower"), &sl.follower, true);
            } else {
                node_ref(&mut c, format!("{p}.node1"), n1, true);
                node_ref(&mut c, format!("{p}.node2"), n2, true);
            }
            if j.sliding().is_none() && n1 == n2 {
                c.err(
                    format!("{p}.node2"),
                    format!(
                        "joint `{}` connects `{n1}` to itself; node1 and node2 must differ",
                        j.name()
                    ),
                );
            }
            if let Some(pos) = j.position() {
                c.vec3(format!("{p}.position"), &pos);
            }
            for co in j.coordinates() {
                if let Some(d) = co.drive {
                    c.time_function(format!("{p}.{}", co.drive_field), d);
                }
                if let Some(s) = co.spring {
                    for (f, v) in [("stiffness", s.stiffness), ("damping", s.damping)] {
                        if !(v.is_finite() && v >= 0.0) {
                            c.err(
                                format!("{p}.{}.{f}", co.spring_field),
                                format!("joint `{}`: must be ≥ 0 (got {v})", j.name()),
                            );
                        }
                    }
                    if !s.rest.is_finite() {
                        c.err(
                            format!("{p}.{}.rest", co.spring_field),
                            "must be a finite number",
                        );
                    }
                    if let Some(t) = &s.table {
                        let path = format!("{p}.{}.table", co.spring_field);
                        let who = format!("joint `{}`", j.name());
                        if s.stiffness != 0.0 || s.rest != 0.0 {
                            c.err(path.clone(), format!("{who}: give either `stiffness`/`rest` (linear) or a `table`, not both"));
                        } else if t.at.len() < 2 || t.at.len() != t.force.len() {
                            c.err(
                                path,
                                format!(
                                    "{who}: `at` and `force` must have the same length, at least 2"
                                ),
                            );
                        } else if !t.at.iter().chain(&t.force).all(|v| v.is_finite())
                            || !t.at.windows(2).all(|w| w[1] > w[0])
                        {
                            c.err(
                                path,
                                format!(
                                    "{who}: `at` must increase strictly and all entries be finite"
                                ),
                            );
                        } else if !t.force.windows(2).all(|w| w[1] >= w[0]) {
                            c.err(path, format!("{who}: the force must not decrease as the coordinate grows (a convex spring energy is what lets the ED scheme guarantee decay)"));
                        }
                    }
                }
            }
            match j {
                Joint::Revolute(r) => c.unit(format!("{p}.axis"), &r.axis, "axis"),
                Joint::Prismatic(r) => c.unit(format!("{p}.axis"), &r.axis, "axis"),
                Joint::Cylindrical(r) => c.unit(format!("{p}.axis"), &r.axis, "axis"),
                Joint::Screw(r) => {
                    c.unit(format!("{p}.axis"), &r.axis, "axis");
                    if !(r.pitch.is_finite() && r.pitch != 0.0) {
                        c.err(
                            format!("{p}.pitch"),
                            format!(
                                "joint `{}`: the pitch must be a nonzero number of m/rad (got {})",
                                r.name, r.pitch
                            ),
                        );
                    }
                    if r.drive_delta.is_some() && r.drive_phi.is_some() {
                        c.err(format!("{p}.drive_phi"), format!("joint `{}`: Δ and φ are tied by the thread (Δ = pitch·φ); prescribe only one of drive_delta and drive_phi", r.name));
                    }
                }
                Joint::Universal(u) => {
                    c.unit(format!("{p}.axis1"), &u.axis1, "axis1");
                    c.unit(format!("{p}.axis2"), &u.axis2, "axis2");
                    let d: f64 = (0..3).map(|k| u.axis1[k] * u.axis2[k]).sum();
                    if d.abs() > UNIT_TOL {
                        c.err(format!("{p}.axis2"), format!("joint `{}`: axis1 and axis2 must be orthogonal (axis1·axis2 = {d:.3e})", u.name));
                    }
                }
                _ => {}
            }
        }

        for (i, l) in self.loads.iter().enumerate() {
            let p = format!("loads[{i}]");
            match l {
                Load::Force(s) | Load::Moment(s) => {
                    node_ref(&mut c, format!("{p}.node"), &s.node, false)
                }
                Load::DistributedForce(s) | Load::DistributedMoment(s) => {
                    if !self.beams.iter().any(|b| b.name == s.beam) {
                        c.err(
                            format!("{p}.beam"),
                            format!(
                                "load `{}` refers to beam `{}`, which is not defined in `beams`",
                                s.name, s.beam
                            ),
                        );
                    }
                }
            }
            c.vec3(format!("{p}.value"), l.value());
            if let Some(f) = l.scale() {
                c.time_function(format!("{p}.scale"), f);
            }
        }

        for (i, s) in self.sensors.iter().enumerate() {
            let p = format!("sensors[{i}]");
            match s {
                Sensor::NodePosition { node, .. }
                | Sensor::NodeDisplacement { node, .. }
                | Sensor::NodeRotation { node, .. }
                | Sensor::NodeVelocity { node, .. } => {
                    node_ref(&mut c, format!("{p}.node"), node, false)
                }
                Sensor::RelativePosition {
                    node, reference, ..
                } => {
                    node_ref(&mut c, format!("{p}.node"), node, false);
                    node_ref(&mut c, format!("{p}.reference"), reference, false);
                }
                Sensor::JointCoordinate { joint, .. }
                | Sensor::JointReaction { joint, .. }
                | Sensor::DriveForce { joint, .. } => match joint_names.get(joint.as_str()) {
                    None => c.err(
                        format!("{p}.joint"),
                        format!("refers to joint `{joint}`, which is not defined in `joints`"),
                    ),
                    Some(j) => match s {
                        Sensor::JointCoordinate { .. } if j.coordinates().is_empty() => c.err(
                            format!("{p}.joint"),
                            format!(
                                "joint `{joint}` is a {} joint, which has no relative coordinate",
                                j.kind()
                            ),
                        ),
                        Sensor::DriveForce { coordinate, .. } => {
                            if let Err(e) = driven_coordinate(j, coordinate.as_deref()) {
                                c.err(
                                    format!(
                                        "{p}.{}",
                                        if coordinate.is_some() {
                                            "coordinate"
                                        } else {
                                            "joint"
                                        }
                                    ),
                                    e,
                                );
                            }
                        }
                        _ => {}
                    },
                },
                Sensor::Energy { .. } | Sensor::Momentum { .. } => {}
                Sensor::BeamEnergy { beam, .. } => {
                    if !self.beams.iter().any(|b| &b.name == beam) {
                        c.err(
                            format!("{p}.beam"),
                            format!("refers to beam `{beam}`, which is not defined in `beams`"),
                        );
                    }
                }
                Sensor::BeamSection { beam, eta, s, .. } => {
                    let b = self.beams.iter().find(|b| &b.name == beam);
                    if b.is_none() {
                        c.err(
                            format!("{p}.beam"),
                            format!("refers to beam `{beam}`, which is not defined in `beams`"),
                        );
                    }
                    match (eta, s) {
                        (Some(eta), None) => {
                            if !(eta.is_finite() && (0.0..=1.0).contains(eta)) {
                                c.err(format!("{p}.eta"), format!("must be a fraction of the beam length between 0 and 1 (got {eta})"));
                            }
                        }
                        (None, Some(s)) => {
                            let length = b.and_then(|b| b.length(self));
                            let ok = s.is_finite() && *s >= 0.0 && length.is_none_or(|l| *s <= l * (1.0 + 1e-12));
                            if !ok {
                                let l = length.map_or(String::new(), |l| format!(" (the beam is {l} m long)"));
                                c.err(format!("{p}.s"), format!("must be an arc length along the beam{l}, got {s}"));
                            }
                        }
                        _ => c.err(p.clone(), "give exactly one of `eta` (fraction of the length) and `s` (arc length)"),
                    }
                }
            }
        }

        for (i, spin) in self.initial_spins.iter().enumerate() {
            let p = format!("initial_spins[{i}]");
            c.unit(format!("{p}.axis"), &spin.axis, "axis");
            c.vec3(format!("{p}.center"), &spin.center);
            if !spin.rate.is_finite() {
                c.err(format!("{p}.rate"), "must be a finite number of rad/s");
            }
            if spin.items.is_empty() {
                c.err(format!("{p}.items"), "name the nodes and beams that spin");
            }
            for (k, item) in spin.items.iter().enumerate() {
                let beam_node = item.rsplit_once('.').is_some_and(|(b, n)| {
                    n.parse::<usize>().is_ok() && self.beams.iter().any(|x| x.name == b)
                });
                if !node_names.contains_key(item.as_str())
                    && !self.beams.iter().any(|b| &b.name == item)
                    && !beam_node
                {
                    c.err(
                        format!("{p}.items[{k}]"),
                        format!("`{item}` is neither a node nor a beam of the model"),
                    );
                }
            }
        }

        let s = &self.simulation;
        if !(s.t_end.is_finite() && s.t_end > 0.0) {
            c.err(
                "simulation.t_end",
                format!("must be positive (got {})", s.t_end),
            );
        }
        if !(s.dt.is_finite() && s.dt > 0.0) {
            c.err("simulation.dt", format!("must be positive (got {})", s.dt));
        }
        if let Some(o) = s.output_dt {
            if !(o.is_finite() && o > 0.0) {
                c.err(
                    "simulation.output_dt",
                    format!("must be a positive interval in s (got {o})"),
                );
            }
        }
        if !(s.tolerance.is_finite() && s.tolerance > 0.0 && s.tolerance < 1.0) {
            c.err(
                "simulation.tolerance",
                format!("must be between 0 and 1 (got {})", s.tolerance),
            );
        }
        let (lo, hi) = (s.dt_min(), s.dt_max());
        if !(lo.is_finite() && lo > 0.0 && hi.is_finite() && lo <= s.dt && s.dt <= hi) {
            c.err(
                "simulation.dt_min",
                format!(
                    "need 0 < dt_min ≤ dt ≤ dt_max (got dt_min = {lo}, dt = {}, dt_max = {hi})",
                    s.dt
                ),
            );
        }
        if !(s.max_growth > 1.0 && s.max_growth.is_finite()) {
            c.err(
                "simulation.max_growth",
                format!("must be greater than 1 (got {})", s.max_growth),
            );
        }
        if !(s.max_shrink > 0.0 && s.max_shrink < 1.0) {
            c.err(
                "simulation.max_shrink",
                format!("must be between 0 and 1 (got {})", s.max_shrink),
            );
        }
        if !(s.newton_tol.is_finite() && s.newton_tol > 0.0 && s.newton_tol < 1.0) {
            c.err("simulation.newton_tol", "must be between 0 and 1");
        }
        if !(s.newton_increment_tol.is_finite() && s.newton_increment_tol > 0.0) {
            c.err(
                "simulation.newton_increment_tol",
                format!("must be positive (got {})", s.newton_increment_tol),
            );
        }
        if s.load_steps == 0 {
            c.err("simulation.load_steps", "must be at least 1");
        }
        if s.max_newton_iterations < 2 {
            c.err("simulation.max_newton_iterations", "must be at least 2");
        }

        if c.errors.is_empty() {
            Ok(())
        } else {
            Err(ModelErrors(c.errors))
        }
    }
}

/// Most beam elements in a model: beyond it, memory and compile time run to gigabytes and
/// minutes before the first step (about 10 kB per cubic element with ED).
pub const MAX_BEAM_ELEMENTS: usize = 100_000;
/// Most output samples in a run (each a row of every channel).
pub const MAX_SAMPLES: f64 = 1e8;

impl Model {
    /// Limits checked before anything is allocated, each with what to change.
    fn check_size(&self, c: &mut Checker) {
        if self.nodes.is_empty() && self.beams.is_empty() {
            c.err(
                "nodes",
                "the model is empty: add `nodes`, `beams` (and `bodies`, `joints`) to simulate something",
            );
        }
        let elements: usize = self
            .beams
            .iter()
            .map(|b| b.elements)
            .fold(0, usize::saturating_add);
        if elements > MAX_BEAM_ELEMENTS {
            let (i, b) = self
                .beams
                .iter()
                .enumerate()
                .max_by_key(|(_, b)| b.elements)
                .expect("elements > 0 means a beam");
            c.err(
                format!("beams[{i}].elements"),
                format!(
                    "the beams have {elements} elements in all (`{}` has {}); the limit is {MAX_BEAM_ELEMENTS}: use fewer, higher-order elements",
                    b.name, b.elements
                ),
            );
        }
        let s = &self.simulation;
        let (interval, key) = match s.output_dt {
            Some(o) => (o, "simulation.output_dt"),
            None if s.step_control == super::StepControl::Fixed => (s.dt, "simulation.dt"),
            None => return,
        };
        let samples = s.t_end / interval;
        // inf (a subnormal interval) is over the limit too; NaN is a bad t_end, reported there.
        if samples > MAX_SAMPLES {
            c.err(
                key,
                format!(
                    "{samples:.3e} output samples over t_end = {} s; at most {MAX_SAMPLES:.0e}: raise `{}` or shorten the run",
                    s.t_end,
                    key.trim_start_matches("simulation.")
                ),
            );
        }
    }
}

/// Longest item name: names become channel names in results files.
const MAX_NAME: usize = 64;

/// Item names are identifiers (a letter or `_`, then letters, digits, `_` or `-`): they
/// become channel names `name.component` and NetCDF variables, where `.` and `/` would be
/// ambiguous.
fn safe_name(n: &str) -> Result<(), String> {
    let mut chars = n.chars();
    let Some(first) = chars.next() else {
        return Err("must not be empty".into());
    };
    let ok_first = first.is_ascii_alphabetic() || first == '_';
    if !ok_first || !chars.all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '-') {
        return Err(format!(
            "`{n}` is not a valid name: use a letter or `_` first, then letters, digits, `_` or `-` (e.g. `{}`)",
            suggest_name(n)
        ));
    }
    if n.len() > MAX_NAME {
        return Err(format!(
            "is {} characters long; at most {MAX_NAME}",
            n.len()
        ));
    }
    Ok(())
}

fn suggest_name(n: &str) -> String {
    let s: String = n
        .chars()
        .map(|ch| {
            if ch.is_ascii_alphanumeric() || ch == '-' {
                ch
            } else {
                '_'
            }
        })
        .collect();
    match s.chars().next() {
        Some(ch) if ch.is_ascii_alphabetic() || ch == '_' => s,
        _ => format!("_{s}"),
    }
}

/// Stations along a span: at least two, strictly increasing from 0 to 1.
fn stations(eta: &[f64]) -> Result<(), String> {
    if eta.len() < 2 {
        return Err("need at least two entries (eta = 0 and eta = 1)".into());
    }
    if eta[0] != 0.0 || eta[eta.len() - 1] != 1.0 {
        return Err(format!(
            "must start at eta = 0 and end at eta = 1 (got {} … {})",
            eta[0],
            eta[eta.len() - 1]
        ));
    }
    if !eta.windows(2).all(|w| w[1] > w[0]) {
        return Err("must increase strictly".into());
    }
    Ok(())
}

/// The coordinate a `drive_force` sensor reads: the one named, or the joint's only driven one.
pub fn driven_coordinate<'a>(
    j: &'a Joint,
    name: Option<&str>,
) -> Result<CoordinateSpec<'a>, String> {
    let coords = j.coordinates();
    let driven: Vec<_> = coords
        .iter()
        .filter(|c| c.drive.is_some())
        .copied()
        .collect();
    match name {
        Some(n) => match coords.iter().find(|c| c.name == n) {
            None => Err(format!(
                "joint `{}` has no coordinate `{n}` (it has: {})",
                j.name(),
                if coords.is_empty() { "none".to_string() } else { coords.iter().map(|c| c.name).collect::<Vec<_>>().join(", ") }
            )),
            Some(c) if c.drive.is_none() => Err(format!(
                "joint `{}` has no drive on `{n}`; add `{}:` to it or remove this sensor",
                j.name(),
                c.drive_field
            )),
            Some(c) => Ok(*c),
        },
        None => match driven.len() {
            0 => Err(format!(
                "joint `{}` has no drive; add `{}:` to it or remove this sensor",
                j.name(),
                coords.first().map_or("drive", |c| c.drive_field)
            )),
            1 => Ok(driven[0]),
            _ => Err(format!(
                "joint `{}` has drives on both `delta` and `phi`; say which with `coordinate: delta` or `coordinate: phi`",
                j.name()
            )),
        },
    }
}

/// The first time in [0, t_end] at which a prescribed η leaves [0, 1], with its value
/// (sampled finely enough for any smooth motion of a run).
pub fn drive_leaves_beam(f: &TimeFunction, t_end: f64) -> Option<(f64, f64)> {
    if !t_end.is_finite() {
        return None; // reported as a bad `simulation.t_end`
    }
    let samples = 20_000;
    (0..=samples).find_map(|k| {
        let t = t_end * k as f64 / samples as f64;
        let eta = f.value(t);
        (!(-1e-12..=1.0 + 1e-12).contains(&eta)).then_some((t, eta))
    })
}
