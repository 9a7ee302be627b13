//! The compiled system: numbered nodes (including internal centre-of-mass ones),
//! coordinates, constraint rows and the kernels on them, with the energies and momenta that
//! sensors and checks read. [`crate::compile`] builds it from a model.

mod border;
pub mod energy_memo;
pub use energy_memo::Energies;
pub mod paired;
pub mod redundancy;
pub mod refactor;
pub mod sparse;
mod substitution;
mod time_functions;

use crate::beam::element::BeamElement;
use crate::beam::geometry::ReferenceLine;
use crate::beam::line_load::FollowerLineLoad;
use crate::elements::coordinate::{CoordinateDrive, CoordinateSpring};
use crate::elements::inertia::{NodeInertia, SteadySpin};
use crate::elements::loads::PointLoad;
use crate::joints::friction::Friction;
use crate::joints::Joint;
use crate::math::layout::Layout;
use crate::math::time_function::TimeFunction;
use crate::math::vec3::{M3, V3};
use crate::state::State;

/// The elements a model beam became: `beams[first .. first + count]`, in order along it.
#[derive(Clone, Debug)]
pub struct BeamInfo {
    pub name: String,
    pub first: usize,
    pub count: usize,
    /// Reference length, m.
    pub length: f64,
    /// Arc-length span of each element.
    pub spans: Vec<(f64, f64)>,
    /// The beam's own lumped inertia.
    pub inertia: Vec<BeamNodeInertia>,
    /// System node of each node along the beam, and the elements' order (nodes − 1).
    pub nodes: Vec<usize>,
    pub order: usize,
    /// The reference line (for section triads at any station).
    pub line: ReferenceLine,
}

impl BeamInfo {
    /// The element (global index) and parent coordinate ξ of the station at arc length `s`.
    /// A station on an element boundary belongs to the element after it.
    pub fn locate(&self, s: f64) -> (usize, f64) {
        let s = s.clamp(0.0, self.length);
        let tol = 1e-9 * self.length;
        let e = self
            .spans
            .iter()
            .position(|&(_, b)| s < b - tol)
            .unwrap_or(self.count - 1);
        let (a, b) = self.spans[e];
        let xi = (2.0 * (s - a) / (b - a) - 1.0).clamp(-1.0, 1.0);
        (self.first + e, xi)
    }
}

/// A beam's share of a node's lumped inertia, about the node in its triad.
#[derive(Clone, Debug)]
pub struct BeamNodeInertia {
    pub node: usize,
    pub mass: f64,
    pub first_moment: V3<f64>,
    pub inertia: M3<f64>,
}

/// What a model joint became: its kernel and its relative coordinates.
#[derive(Clone, Debug)]
pub struct JointInfo {
    pub name: String,
    pub kernel: usize,
    pub coords: Vec<JointCoordinate>,
}

/// A joint's relative coordinate (Δ or φ): its index, and its drive and spring if any.
#[derive(Clone, Debug)]
pub struct JointCoordinate {
    /// `delta` or `phi`.
    pub name: &'static str,
    pub coord: usize,
    pub drive: Option<usize>,
    pub spring: Option<usize>,
}

#[derive(Clone, Debug)]
pub struct System {
    pub name: String,
    pub layout: Layout,
    pub node_names: Vec<String>,
    /// Other names of nodes: a beam's `<beam>.start` and `<beam>.end`.
    pub node_aliases: Vec<(String, usize)>,
    pub coord_names: Vec<String>,
    /// Per constraint row: the owning item's name and its local row.
    pub row_names: Vec<(String, usize)>,
    pub inertias: Vec<NodeInertia>,
    pub beams: Vec<BeamElement>,
    pub beam_info: Vec<BeamInfo>,
    pub joints: Vec<Joint>,
    pub joint_info: Vec<JointInfo>,
    pub springs: Vec<CoordinateSpring>,
    pub drives: Vec<CoordinateDrive>,
    /// Friction on joints' sliding motion, one row each (after the drives' rows).
    pub frictions: Vec<Friction>,
    pub loads: Vec<PointLoad>,
    /// Distributed loads following a beam's sections, one kernel per element.
    pub line_loads: Vec<FollowerLineLoad>,
    pub gravity: V3<f64>,
    pub initial: State,
    /// Mean nodal mass, for the multiplier scaling `s = m_ref/h²`.
    pub mass_ref: f64,
    /// Characteristic length (extent of the initial configuration), for tolerances.
    pub length_ref: f64,
    /// Force of a 1e-8 strain of the stiffest section: the scale of round-off in elastic forces.
    pub force_ref: f64,
    /// Round-off of the largest elastic force a kernel computes (a section's `EA·e`, a
    /// spring's `k (q − q₀)`): a Newton residual below it is converged whatever the tolerance.
    pub force_roundoff: f64,
    /// Per node: which of its initial velocities the model gave (the rest are zero, to be
    /// completed by the joints).
    pub velocity_given: Vec<VelocityGiven>,
    /// Per node whose mass was moved to an internal centre-of-mass node: that node and the
    /// offset (carrier triad).
    pub cm_node: Vec<Option<(usize, V3<f64>)>>,
    /// Per node: the initial spin it was given, if any.
    pub node_spin: Vec<Option<SteadySpin>>,
    /// Each load's scale function, with the load's name (for diagnostics).
    pub load_scales: Vec<(String, TimeFunction)>,
}

impl System {
    /// The node a name (or an alias) names.
    pub fn node_index(&self, name: &str) -> Option<usize> {
        self.node_names.iter().position(|n| n == name).or_else(|| {
            self.node_aliases
                .iter()
                .find(|(alias, _)| alias == name)
                .map(|&(_, a)| a)
        })
    }

    pub fn joint(&self, name: &str) -> Option<&JointInfo> {
        self.joint_info.iter().find(|j| j.name == name)
    }

    /// Kinetic energy `Σ ½ m v·v + ½ W·J W`.
    /// Kinetic energy of the nodes' translations and of their rotations.
    pub fn kinetic_energies(&self, s: &State) -> [f64; 2] {
        self.inertias.iter().fold([0.0; 2], |[t, r], k| {
            let n = &s.nodes[k.node];
            [
                t + 0.5 * k.mass * n.v.norm_sq(),
                r + 0.5 * n.w.dot(&k.inertia.mul_v(&n.w)),
            ]
        })
    }

    pub fn kinetic_energy(&self, s: &State) -> f64 {
        self.kinetic_energies(s).iter().sum()
    }

    /// Kinetic and strain energy of one beam (its share of the lumped inertia; the strain
    /// energy of its elements).
    pub fn beam_energies(&self, info: &BeamInfo, s: &State) -> (f64, f64) {
        // ½ m v² + v·(ω × R S) + ½ Wᵀ J W about the node carrying the mass (S: first moment
        // of the beam's share about it). Where the node's mass sits on an internal
        // centre-of-mass node, that node's motion is used, so that the beams' shares add up
        // to the model's kinetic energy exactly.
        let kinetic = info
            .inertia
            .iter()
            .map(|b| {
                let (at, first, j) = match self.cm_node[b.node] {
                    None => (b.node, b.first_moment, b.inertia),
                    Some((cm, c)) => {
                        // Shift the share's first moment and inertia from the node to cm.
                        let s_cm = b.first_moment - c.scale_f(b.mass);
                        let cb = b.first_moment.scale_f(1.0 / b.mass);
                        let own = b.inertia
                            - (M3::identity().scale_f(cb.norm_sq()) - cb.outer(&cb))
                                .scale_f(b.mass);
                        let d = cb - c;
                        let j_cm = own
                            + (M3::identity().scale_f(d.norm_sq()) - d.outer(&d)).scale_f(b.mass);
                        (cm, s_cm, j_cm)
                    }
                };
                let n = &s.nodes[at];
                0.5 * b.mass * n.v.norm_sq()
                    + n.v.dot(&n.omega().cross(&n.r.mul_v(&first)))
                    + 0.5 * n.w.dot(&j.mul_v(&n.w))
            })
            .sum();
        let strain = self.beams[info.first..info.first + info.count]
            .iter()
            .map(|b| b.strain_energy(s))
            .sum();
        (kinetic, strain)
    }

    /// Linear momentum and angular momentum about the origin, `Σ m v` and `Σ x × m v + R J W`.
    pub fn momentum(&self, s: &State) -> (V3<f64>, V3<f64>) {
        let mut p = V3::zero();
        let mut h = V3::zero();
        for k in &self.inertias {
            let n = &s.nodes[k.node];
            let mv = n.v.scale_f(k.mass);
            p += mv;
            h += n.x.cross(&mv) + n.r.mul_v(&k.inertia.mul_v(&n.w));
        }
        (p, h)
    }

    /// Every part of a state's energy, each summed once (the strain energy over every Gauss
    /// point, the costly part).
    pub fn energies(&self, s: &State) -> Energies {
        let [translational, rotational] = self.kinetic_energies(s);
        let gravity: f64 = self
            .inertias
            .iter()
            .map(|k| -k.mass * self.gravity.dot(&s.nodes[k.node].x))
            .sum();
        let springs: f64 = self
            .springs
            .iter()
            .map(|sp| sp.law.energy(s.coords[sp.coord]))
            .sum();
        let strain: f64 = self.beams.iter().map(|b| b.strain_energy(s)).sum();
        Energies {
            translational,
            rotational,
            gravity,
            springs,
            strain,
        }
    }

    /// If `row` is a sliding joint's contact-coordinate equation (ζ's, or ED's jump) and its
    /// contact point `state` starts on an interior node of the beam: the joint's index and
    /// why that equation can fail there ([`crate::joints::sliding::SlidingJoint::node_kink_hint`]).
    pub fn node_kink_hint(
        &self,
        row: usize,
        state: &crate::state::State,
    ) -> Option<(usize, String)> {
        let lay = self.layout;
        self.joints.iter().enumerate().find_map(|(j, joint)| {
            let sl = joint.as_sliding()?;
            let own =
                row == lay.coord_delta(sl.coord) || (lay.ed() && row == lay.coord_jump(sl.coord));
            own.then(|| sl.node_kink_hint(state.coords[sl.coord]))
                .flatten()
                .map(|hint| (j, hint))
        })
    }

    /// Human-readable owner of a global unknown/row, for diagnostics.
    pub fn describe_row(&self, i: usize) -> String {
        use crate::math::layout::RowOwner::*;
        const COMP: [&str; 6] = [
            "force x", "force y", "force z", "moment 1", "moment 2", "moment 3",
        ];
        match self.layout.owner(i) {
            NodeForce { node, component } => format!(
                "node `{}` momentum balance ({})",
                self.node_names[node], COMP[component]
            ),
            NodeJump { node, component } => format!(
                "node `{}` ED jump equation ({})",
                self.node_names[node], COMP[component]
            ),
            CoordForce { coord } => {
                format!("coordinate `{}` force balance", self.coord_names[coord])
            }
            CoordJump { coord } => {
                format!("coordinate `{}` ED jump equation", self.coord_names[coord])
            }
            Constraint { row } => format!(
                "joint `{}` constraint {}",
                self.row_names[row].0,
                self.row_names[row].1 + 1
            ),
            ConstraintRate { row } => {
                format!(
                    "joint `{}` velocity-level constraint {}",
                    self.row_names[row].0,
                    self.row_names[row].1 + 1
                )
            }
        }
    }
}

/// Which of a node's initial velocities the model gave: its velocity (translation) and its
/// angular velocity (rotation). A part not given is completed from the joints (a collar
/// launched along a spinning beam takes the beam's spin), not held at zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VelocityGiven {
    pub translation: bool,
    pub rotation: bool,
}

impl VelocityGiven {
    pub const BOTH: VelocityGiven = VelocityGiven {
        translation: true,
        rotation: true,
    };

    /// Whether part `k` (0 translation, 1 rotation) was given.
    pub fn part(self, k: usize) -> bool {
        if k == 0 {
            self.translation
        } else {
            self.rotation
        }
    }

    pub fn any(self) -> bool {
        self.translation || self.rotation
    }
}
