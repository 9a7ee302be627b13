//! Sensors: named quantities evaluated from the state after every recorded step. Each model
//! sensor expands into channels `<sensor>.<component>` with SI units.

use crate::integrator::StepReport;
use crate::math::rotation::{exp_map, log_map};
use crate::math::vec3::{M3, V3};
use crate::model::{Model, ModelError, ModelErrors, Sensor};
use crate::state::State;
use crate::system::energy_memo::EnergyMemo;
use crate::system::System;

#[derive(Clone, Debug)]
enum Source {
    Position(usize),
    /// A node relative to a reference node (node, reference), in the reference's triad.
    Relative(usize, usize),
    Displacement(usize),
    Rotation(usize),
    Velocity(usize),
    Coordinate(usize),
    Reaction(usize),
    Drive(usize),
    Energy,
    Momentum,
    /// Beam station: element index, parent coordinate ξ in it, and the reference section
    /// triad there.
    BeamSection(usize, f64, M3<f64>),
    /// Beam energies: index in `System::beam_info`.
    BeamEnergy(usize),
    /// Largest |C| of a joint kernel's rows.
    Violation(usize),
    /// A sliding joint (kernel index): η, η̇, arc length and the contact point.
    Contact(usize),
    /// A sliding joint's drive (drive index, kernel index): force along the beam, generalized
    /// force on η, work.
    SlidingDrive(usize, usize),
    /// A joint's friction (index in `System::frictions`): force, normal force (step
    /// quantities), slip, slip rate, stick, dissipation.
    Friction(usize),
}

#[derive(Clone, Debug)]
pub struct Channels {
    pub names: Vec<String>,
    pub units: Vec<&'static str>,
    sources: Vec<(Source, usize)>,
    /// Channels whose values are step quantities (multipliers: reactions, driving forces).
    step_channels: Vec<usize>,
    /// Full-field columns recorded after the named channels, if the run records them.
    pub fields: Option<crate::fields::Fields>,
}

/// Running totals over the run, needed by the energy sensor.
#[derive(Clone, Debug, Default)]
pub struct Totals {
    pub drive_work: f64,
    pub external_work: f64,
    pub damper_work: f64,
    pub numerical_dissipation: f64,
    pub per_drive_work: Vec<f64>,
    /// Work of all frictions (never positive), and of each.
    pub friction_work: f64,
    pub per_friction_work: Vec<f64>,
    pub initial_energy: f64,
}

const ENERGY: [&str; 9] = [
    "kinetic",
    "potential",
    "total",
    "drive_work",
    "external_work",
    "damper_work",
    "friction_dissipation",
    "numerical_dissipation",
    "balance",
];

impl Channels {
    /// Indices of the channels that are step quantities: the multipliers of a step are
    /// step-average forces, which belong to the mid-step time and are interpolated to the
    /// sample times by the simulation.
    pub fn step_channels(&self) -> &[usize] {
        &self.step_channels
    }

    /// Indices of the channels interpolated linearly between step ends rather than evaluated
    /// on the interpolated state: bookkeeping — energies and works (the energy identity holds
    /// at step ends), joint violations (the constraints hold at step ends) — and what comes
    /// from strains — section forces, strains, curvatures and strain energies. A strain is a
    /// small difference of large numbers (EA·e, e = Rᵀx′ − 1): interpolated kinematics exact to
    /// 1e-5 over a step of a quarter turn gave a 2 m steel-like bar spinning freely 1.2 kN of
    /// tension between steps instead of its steady 17 N.
    pub fn step_end_channels(&self) -> Vec<usize> {
        let n = self.names.len();
        let field_loads = self
            .fields
            .iter()
            .flat_map(|f| f.section_load_columns())
            .map(move |c| n + c);
        (0..self.sources.len())
            .filter(|&c| match &self.sources[c] {
                (Source::Energy | Source::Violation(_), _) => true,
                (Source::Drive(_), k) => *k == 1,
                (Source::SlidingDrive(..), k) => *k == 2,
                (Source::BeamSection(..), k) => *k < 12,
                (Source::BeamEnergy(_), k) => *k == 1,
                (Source::Friction(_), k) => *k == 5,
                _ => false,
            })
            .chain(field_loads)
            .collect()
    }

    /// Values of the step channels (in `step_channels` order) for a converged step.
    pub fn step_values(&self, report: &StepReport, out: &mut Vec<f64>) {
        for &c in &self.step_channels {
            let (src, k) = &self.sources[c];
            out.push(match src {
                Source::Reaction(j) => {
                    let (f, m, frame) = report.reactions[*j];
                    match *k {
                        0..=2 => f.0[*k],
                        3..=5 => m.0[k - 3],
                        // Components in the joint frame (axis 3 is the joint's axis).
                        6..=8 => frame.tmul_v(&f).0[k - 6],
                        _ => frame.tmul_v(&m).0[k - 9],
                    }
                }
                Source::Drive(d) => report.drive_forces[*d],
                Source::SlidingDrive(d, j) => {
                    let (speed, dzeta_deta) = report.path_rates[*j];
                    let f_zeta = report.drive_forces[*d];
                    if *k == 0 {
                        f_zeta / speed
                    } else {
                        f_zeta * dzeta_deta
                    }
                }
                Source::Friction(f) => {
                    let step = &report.frictions[*f];
                    if *k == 0 {
                        step.force
                    } else {
                        step.normal
                    }
                }
                _ => unreachable!("only multiplier channels are step channels"),
            });
        }
    }

    /// Former spellings `(current, old)` of sensor `sensor`'s channels just added, kept as
    /// channels reading the same (node_displacement and node_rotation were `.x .y .z`; one
    /// scheme now: positions `x`, displacements `ux`, rotations `rx`). They go in 0.3.
    fn alias(&mut self, sensor: &str, pairs: &[(&str, &str)]) {
        for (current, old) in pairs {
            let wanted = format!("{sensor}.{current}");
            let k = self
                .names
                .iter()
                .rposition(|n| *n == wanted)
                .expect("just added");
            self.names.push(format!("{sensor}.{old}"));
            self.units.push(self.units[k]);
            self.sources.push(self.sources[k].clone());
        }
    }

    /// Of the channels from `first` on (one sensor's), keeps only `<name>.<comp>`, renamed
    /// `<name>`.
    fn keep_only(&mut self, first: usize, name: &str, comp: &str) -> Result<(), String> {
        let wanted = format!("{name}.{comp}");
        let Some(k) = (first..self.names.len()).find(|&k| self.names[k] == wanted) else {
            let have: Vec<&str> = self.names[first..]
                .iter()
                .map(|n| n.rsplit('.').next().unwrap_or(n))
                .collect();
            return Err(format!(
                "`{comp}` is not a component of sensor `{name}`; it has {}",
                have.join(", ")
            ));
        };
        let is_step = self.step_channels.contains(&k);
        let (unit, source) = (self.units[k], self.sources[k].clone());
        self.names.truncate(first);
        self.units.truncate(first);
        self.sources.truncate(first);
        self.step_channels.retain(|&c| c < first);
        if is_step {
            self.step_channels.push(first);
        }
        self.names.push(name.to_string());
        self.units.push(unit);
        self.sources.push(source);
        Ok(())
    }

    pub fn new(model: &Model, sys: &System) -> Result<Channels, ModelErrors> {
        let mut c = Channels {
            names: vec![],
            units: vec![],
            sources: vec![],
            step_channels: vec![],
            fields: None,
        };
        let mut errors = Vec::new();
        for (i, s) in model.sensors.iter().enumerate() {
            let first = c.names.len();
            c.add_sensor(s, model, sys);
            if let Some(comp) = s.component() {
                if let Err(e) = c.keep_only(first, s.name(), comp) {
                    errors.push(ModelError::new(format!("sensors[{i}].component"), e));
                }
            }
        }
        let mut seen = std::collections::HashSet::new();
        for n in &c.names {
            if !seen.insert(n.as_str()) {
                errors.push(ModelError::new(
                    "sensors",
                    format!("two sensors give a channel named `{n}`; rename one of them"),
                ));
            }
        }
        if !errors.is_empty() {
            return Err(ModelErrors(errors));
        }
        Ok(c)
    }

    /// Channels `<sensor>.<comp>` of one source, component `k` of it for each `comps[k]`, in
    /// `unit[k]` (the last unit repeats).
    fn add(&mut self, sensor: &str, comps: &[&str], unit: &[&'static str], src: Source) {
        for (k, comp) in comps.iter().enumerate() {
            let step_quantity = matches!(src, Source::Reaction(_))
                || (matches!(src, Source::Drive(_)) && k == 0)
                || (matches!(src, Source::SlidingDrive(..)) && k < 2)
                || (matches!(src, Source::Friction(_)) && k < 2);
            if step_quantity {
                self.step_channels.push(self.names.len());
            }
            self.names.push(format!("{sensor}.{comp}"));
            self.units.push(unit[k.min(unit.len() - 1)]);
            self.sources.push((src.clone(), k));
        }
    }

    /// The channels of sensor `s` (validated: its nodes, joints and beams exist).
    fn add_sensor(&mut self, s: &Sensor, model: &Model, sys: &System) {
        let name = s.name();
        let node = |n: &str| sys.node_index(n).expect("validated");
        match s {
            Sensor::NodePosition { node: n, .. } => {
                self.add(name, &["x", "y", "z"], &["m"], Source::Position(node(n)))
            }
            Sensor::RelativePosition {
                node: n, reference, ..
            } => self.add(
                name,
                &["x1", "x2", "x3", "r1", "r2", "r3"],
                &["m"],
                Source::Relative(node(n), node(reference)),
            ),
            Sensor::NodeDisplacement { node: n, .. } => {
                let src = Source::Displacement(node(n));
                self.add(name, &["ux", "uy", "uz"], &["m"], src);
                self.alias(name, &[("ux", "x"), ("uy", "y"), ("uz", "z")]);
            }
            Sensor::NodeRotation { node: n, .. } => {
                let comps = [
                    "rx", "ry", "rz", "R11", "R12", "R13", "R21", "R22", "R23", "R31", "R32", "R33",
                ];
                let src = Source::Rotation(node(n));
                self.add(name, &comps, &["rad", "rad", "rad", "1"], src);
                self.alias(name, &[("rx", "x"), ("ry", "y"), ("rz", "z")]);
            }
            Sensor::NodeVelocity { node: n, .. } => self.add(
                name,
                &["vx", "vy", "vz", "wx", "wy", "wz"],
                &["m/s", "m/s", "m/s", "rad/s"],
                Source::Velocity(node(n)),
            ),
            Sensor::JointCoordinate { joint, .. } => self.add_joint_coordinates(name, joint, sys),
            Sensor::JointReaction { joint, .. } => {
                let k = sys.joint(joint).expect("validated").kernel;
                self.add(
                    name,
                    &[
                        "Fx", "Fy", "Fz", "Mx", "My", "Mz", "F1", "F2", "F3", "M1", "M2", "M3",
                    ],
                    &["N", "N", "N", "N*m", "N*m", "N*m", "N", "N", "N", "N*m"],
                    Source::Reaction(k),
                );
                self.names.push(format!("{name}.violation"));
                self.units.push("m|1");
                self.sources.push((Source::Violation(k), 0));
            }
            Sensor::DriveForce {
                joint, coordinate, ..
            } => self.add_drive_force(name, joint, coordinate.as_deref(), model, sys),
            Sensor::Energy { .. } => self.add(name, &ENERGY, &["J"], Source::Energy),
            Sensor::Friction { joint, .. } => self.add_friction(name, joint, sys),
            Sensor::BeamSection { beam, eta, s, .. } => {
                self.add_beam_section(name, beam, *eta, *s, sys)
            }
            Sensor::BeamEnergy { beam, .. } => {
                let i = sys.beam_info.iter().position(|b| &b.name == beam);
                let src = Source::BeamEnergy(i.expect("validated"));
                self.add(name, &["kinetic", "strain"], &["J"], src)
            }
            Sensor::Momentum { .. } => self.add(
                name,
                &["px", "py", "pz", "Hx", "Hy", "Hz"],
                &["N*s", "N*s", "N*s", "N*m*s"],
                Source::Momentum,
            ),
        }
    }

    /// A joint's friction: force, normal force, slip, its rate, stick, dissipation.
    fn add_friction(&mut self, name: &str, joint: &str, sys: &System) {
        let f = sys.frictions.iter().position(|f| f.joint == joint);
        let comps = [
            "force",
            "normal",
            "slip",
            "slip_rate",
            "stick",
            "dissipation",
        ];
        let units = ["N", "N", "m", "m/s", "1", "J"];
        self.add(
            name,
            &comps,
            &units,
            Source::Friction(f.expect("validated")),
        )
    }

    /// A joint's coordinates and rates; a sliding joint's contact point (η, its rate, arc
    /// length, position).
    fn add_joint_coordinates(&mut self, name: &str, joint: &str, sys: &System) {
        let j = sys.joint(joint).expect("validated");
        if sys.joints[j.kernel].as_sliding().is_some() {
            return self.add(
                name,
                &["eta", "eta_rate", "s", "x", "y", "z"],
                &["1", "1/s", "m", "m", "m", "m"],
                Source::Contact(j.kernel),
            );
        }
        for co in &j.coords {
            let rate = format!("{}_rate", co.name);
            let units = if co.name.starts_with("phi") {
                ["rad", "rad/s"]
            } else {
                ["m", "m/s"]
            };
            self.add(
                name,
                &[co.name, rate.as_str()],
                &units,
                Source::Coordinate(co.coord),
            )
        }
    }

    /// A drive's force (or torque) and work; a sliding drive's force along the beam, its
    /// generalized force on η, and work.
    fn add_drive_force(
        &mut self,
        name: &str,
        joint: &str,
        coordinate: Option<&str>,
        model: &Model,
        sys: &System,
    ) {
        let spec = model
            .joints
            .iter()
            .find(|j| j.name() == joint)
            .and_then(|j| crate::model::driven_coordinate(j, coordinate).ok())
            .expect("validated");
        let j = sys.joint(joint).expect("validated");
        let d = j
            .coords
            .iter()
            .find(|c| c.name == spec.name)
            .and_then(|c| c.drive)
            .expect("validated");
        if sys.joints[j.kernel].as_sliding().is_some() {
            let src = Source::SlidingDrive(d, j.kernel);
            return self.add(
                name,
                &["force", "force_eta", "work"],
                &["N", "N*m", "J"],
                src,
            );
        }
        let (force, unit) = if spec.is_rotation() {
            ("torque", "N*m")
        } else {
            ("force", "N")
        };
        self.add(name, &[force, "work"], &[unit, "J"], Source::Drive(d))
    }

    /// A beam station's forces, strains, position and rotation, at `eta` (or arc length
    /// `s`), with the section triad of the reference line there.
    fn add_beam_section(
        &mut self,
        name: &str,
        beam: &str,
        eta: Option<f64>,
        s: Option<f64>,
        sys: &System,
    ) {
        let info = sys
            .beam_info
            .iter()
            .find(|b| b.name == beam)
            .expect("validated");
        let s = eta.map_or(s.unwrap_or(0.0), |eta| eta * info.length);
        let (e, xi) = info.locate(s);
        let line = &info.line;
        let r0 = line.section_triad(line.segment_at(s.min(info.length)), s);
        self.add(
            name,
            &[
                "F1", "F2", "F3", "M1", "M2", "M3", "e1", "g2", "g3", "k1", "k2", "k3", "x", "y",
                "z", "phi1", "phi2", "phi3", "ux", "uy", "uz", "rx", "ry", "rz",
            ],
            &[
                "N", "N", "N", "N*m", "N*m", "N*m", "1", "1", "1", "1/m", "1/m", "1/m", "m", "m",
                "m", "rad", "rad", "rad", "m", "m", "m", "rad",
            ],
            Source::BeamSection(e, xi, r0),
        )
    }

    /// Columns per sample: the named channels, then the field columns if recorded.
    pub fn len(&self) -> usize {
        self.names.len() + self.fields.as_ref().map_or(0, |f| f.width())
    }

    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// Appends one sample of the state channels; step channels get a NaN placeholder.
    pub fn sample(
        &self,
        sys: &System,
        state: &State,
        totals: &Totals,
        energies: &EnergyMemo,
        out: &mut Vec<f64>,
    ) {
        let mut energy: Option<[f64; 9]> = None;
        for (src, k) in &self.sources {
            let v = match src {
                Source::Position(_)
                | Source::Relative(..)
                | Source::Displacement(_)
                | Source::Rotation(_)
                | Source::Velocity(_)
                | Source::Coordinate(_) => node_channel(src, *k, sys, state),
                // Step quantities are filled in by `step_values` and interpolation.
                Source::Reaction(_) => f64::NAN,
                Source::Contact(j) => contact_channel(*j, *k, sys, state),
                Source::SlidingDrive(d, _) => {
                    if *k < 2 {
                        f64::NAN
                    } else {
                        totals.per_drive_work.get(*d).copied().unwrap_or(0.0)
                    }
                }
                Source::Drive(d) => {
                    if *k == 0 {
                        f64::NAN
                    } else {
                        totals.per_drive_work.get(*d).copied().unwrap_or(0.0)
                    }
                }
                Source::BeamSection(e, xi, r0) => {
                    let el = &sys.beams[*e];
                    match *k {
                        15..=17 => r0.tmul_v(&beam_rotation(el, sys, state, *xi)).0[k - 15],
                        18..=20 => {
                            beam_station(el, state, *xi, k - 6)
                                - beam_station(el, &sys.initial, *xi, k - 6)
                        }
                        21..=23 => beam_rotation(el, sys, state, *xi).0[k - 21],
                        _ => beam_station(el, state, *xi, *k),
                    }
                }
                Source::Violation(j) => {
                    let kernel = &sys.joints[*j];
                    kernel.values_at(state)[..kernel.n_rows()]
                        .iter()
                        .fold(0.0f64, |m, v| m.max(v.abs()))
                }
                Source::BeamEnergy(i) => {
                    let (t, u) = sys.beam_energies(&sys.beam_info[*i], state);
                    if *k == 0 {
                        t
                    } else {
                        u
                    }
                }
                Source::Momentum => {
                    let (p, h) = sys.momentum(state);
                    if *k < 3 {
                        p.0[*k]
                    } else {
                        h.0[k - 3]
                    }
                }
                Source::Energy => {
                    energy.get_or_insert_with(|| energy_channels(sys, state, totals, energies))[*k]
                }
                Source::Friction(i) => friction_channel(*i, *k, sys, state, totals),
            };
            out.push(v);
        }
        if let Some(f) = &self.fields {
            f.sample(sys, state, out);
        }
    }
}

/// Component `k` of a node's or coordinate's channel: position, position relative to
/// another node's triad (components in it, then distances from its axes), displacement,
/// rotation (vector from the initial triad, then the triad's entries), velocity (linear, then
/// angular, inertial), coordinate value and rate.
fn node_channel(src: &Source, k: usize, sys: &System, state: &State) -> f64 {
    match src {
        Source::Position(a) => state.nodes[*a].x.0[k],
        Source::Relative(a, b) => {
            let (n, r) = (&state.nodes[*a], &state.nodes[*b]);
            let d = r.r.tmul_v(&(n.x - r.x));
            if k < 3 {
                d.0[k]
            } else {
                (d.norm_sq() - d.0[k - 3].powi(2)).max(0.0).sqrt()
            }
        }
        Source::Displacement(a) => state.nodes[*a].x.0[k] - sys.initial.nodes[*a].x.0[k],
        Source::Rotation(a) => {
            let r = &state.nodes[*a].r;
            if k < 3 {
                log_map(&r.mul_m(&sys.initial.nodes[*a].r.transpose())).0[k]
            } else {
                r.0[(k - 3) / 3][(k - 3) % 3]
            }
        }
        Source::Velocity(a) => {
            let n = &state.nodes[*a];
            if k < 3 {
                n.v.0[k]
            } else {
                n.omega().0[k - 3]
            }
        }
        Source::Coordinate(c) => {
            if k == 0 {
                state.coords[*c]
            } else {
                state.coord_rates[*c]
            }
        }
        _ => unreachable!("not a node or coordinate channel"),
    }
}

/// The energy sensor's channels: kinetic, potential, total, the drives', external loads' and
/// dampers' work, the energy friction dissipated, numerical dissipation, and the balance of
/// them all against the initial energy (J).
fn energy_channels(sys: &System, state: &State, totals: &Totals, memo: &EnergyMemo) -> [f64; 9] {
    let energies = memo.energies(sys, state);
    let (t, p) = (energies.kinetic(), energies.potential());
    let balance = t + p
        - totals.initial_energy
        - totals.drive_work
        - totals.external_work
        - totals.damper_work
        - totals.friction_work
        + totals.numerical_dissipation;
    [
        t,
        p,
        t + p,
        totals.drive_work,
        totals.external_work,
        totals.damper_work,
        -totals.friction_work,
        totals.numerical_dissipation,
        balance,
    ]
}

/// Component `k` of sliding joint `j`'s contact channels: η, its rate, arc length, point.
fn contact_channel(j: usize, k: usize, sys: &System, state: &State) -> f64 {
    let sl = sys.joints[j].as_sliding().expect("a sliding joint");
    let z = state.coords[sl.coord];
    match k {
        0 => sl.arc.eta(z),
        1 => state.coord_rates[sl.coord] * sl.arc.deta_dzeta(z),
        2 => sl.arc.eta(z) * sys.beam_info[sl.beam].length,
        _ => sl.contact(state, z).0 .0[k - 3],
    }
}

/// Component `k` of friction `i`'s state channels: slip, slip rate, whether it sticks, the
/// energy it has dissipated (force and normal force are step quantities).
fn friction_channel(i: usize, k: usize, sys: &System, state: &State, totals: &Totals) -> f64 {
    use crate::joints::friction::Mode;
    let f = &sys.frictions[i];
    match k {
        2 => f.slip_at(state).0,
        3 => f.slip_at(state).1,
        4 => f64::from(matches!(f.mode(state), Mode::Stick { .. })),
        5 => -totals.per_friction_work.get(i).copied().unwrap_or(0.0),
        _ => f64::NAN,
    }
}

/// Component `k` of a beam station's channels (forces/moments, strains/curvatures, position)
/// at parent coordinate `xi`: Gauss-point values interpolated by the polynomial through the
/// element's Gauss points (constant for one point).
fn beam_station(el: &crate::beam::element::BeamElement, state: &State, xi: f64, k: usize) -> f64 {
    if k >= 12 {
        let (h, _) = crate::beam::shape::lagrange(el.nodes.len(), xi);
        return el
            .nodes
            .iter()
            .enumerate()
            .map(|(a, &n)| h[a] * state.nodes[n].x.0[k - 12])
            .sum();
    }
    let values = el.gauss_values(state);
    if k < 6 {
        return section_loads_at(el, &values, xi)[k];
    }
    gauss_interpolation(el, xi)
        .map(|(g, w)| w * values[g].0[k - 6])
        .sum()
}

/// The weights of the polynomial through an element's Gauss points at parent coordinate
/// `xi`: `(point, weight)` (weight 1 for a single point).
fn gauss_interpolation(
    el: &crate::beam::element::BeamElement,
    xi: f64,
) -> impl Iterator<Item = (usize, f64)> + '_ {
    let xs = &el.points;
    (0..xs.len()).map(move |g| {
        let w: f64 = (0..xs.len())
            .filter(|&o| o != g)
            .map(|o| (xi - xs[o].xi) / (xs[g].xi - xs[o].xi))
            .product();
        (g, w)
    })
}

/// Section forces and moments `[F1, F2, F3, M1, M2, M3]` (section triad) at parent coordinate
/// `xi`, interpolated from the element's Gauss-point `values` (`gauss_values`).
pub fn section_loads_at(
    el: &crate::beam::element::BeamElement,
    values: &[([f64; 6], [f64; 6])],
    xi: f64,
) -> [f64; 6] {
    let mut out = [0.0; 6];
    for (g, w) in gauss_interpolation(el, xi) {
        for (o, v) in out.iter_mut().zip(values[g].1) {
            *o += w * v;
        }
    }
    out
}

/// Rotation of the section at parent coordinate `xi` from its reference, as a rotation
/// vector (inertial frame). The nodes' rotations from their initial triads are interpolated
/// relative to the element's first node (objective: a rigid rotation of the element adds
/// nothing to the interpolation error), as rotation vectors.
fn beam_rotation(
    el: &crate::beam::element::BeamElement,
    sys: &System,
    state: &State,
    xi: f64,
) -> V3<f64> {
    let (h, _) = crate::beam::shape::lagrange(el.nodes.len(), xi);
    let delta = |n: usize| state.nodes[n].r.mul_m(&sys.initial.nodes[n].r.transpose());
    let base = delta(el.nodes[0]);
    let mut phi = V3::zero();
    for (a, &n) in el.nodes.iter().enumerate() {
        phi += log_map(&delta(n).mul_m(&base.transpose())).scale_f(h[a]);
    }
    log_map(&exp_map(&phi).mul_m(&base))
}
