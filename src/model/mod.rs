//! The model file: plain serde types, and errors with precise paths.
//!
//! A model is what a user writes in YAML (or builds in Python, which produces the same JSON).
//! Everything here is declarative and imports nothing from the physics; [`crate::compile`]
//! validates it and compiles it into numbered unknowns, elements and constraints. The JSON Schema printed by `flexdyn schema` is generated from these
//! very types.

pub mod check;
mod flatten;
mod load;
mod pattern;
pub mod placement;
mod section;

pub use check::{ModelError, ModelErrors};
pub use load::{parse_json, parse_yaml};
pub use pattern::{Pattern, MAX_PATTERN_COPIES};
pub use section::{
    BeamDamping, MaterialShape, MaterialSpec, Matrices, SectionSpec, ShapeSpec, Shorthand,
};

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

pub type Vec3 = [f64; 3];
pub type Mat3 = [[f64; 3]; 3];

/// Reserved node name for the inertial frame.
pub const GROUND: &str = "ground";

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug, Default)]
#[serde(deny_unknown_fields)]
pub struct Model {
    /// A name for the model (used in result files and reports).
    #[serde(default)]
    pub name: String,
    /// Gravitational acceleration, m/s², inertial frame.
    #[serde(default)]
    pub gravity: Vec3,
    #[serde(default)]
    pub nodes: Vec<Node>,
    #[serde(default)]
    pub bodies: Vec<RigidBody>,
    #[serde(default)]
    pub beams: Vec<Beam>,
    #[serde(default)]
    pub joints: Vec<Joint>,
    #[serde(default)]
    pub loads: Vec<Load>,
    #[serde(default)]
    pub sensors: Vec<Sensor>,
    /// Initial rigid-body spins of groups of items (a rotor turning from t = 0).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub initial_spins: Vec<InitialSpin>,
    /// Groups of items copied turn by turn about an axis (the blades of a rotor).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub patterns: Vec<Pattern>,
    #[serde(default)]
    pub simulation: SimulationSettings,
    /// Where each item of a flattened model came from (see [`Model::flattened`]): its path in
    /// the flat lists and the path the user wrote, for error messages.
    #[serde(skip)]
    pub origins: Vec<(String, String)>,
}

/// Starts the listed nodes and beams (all their nodes) turning together about an axis: each
/// node gets `v = ω × (x − center)` and angular velocity ω (replacing what it was given).
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct InitialSpin {
    /// Unit vector of the spin axis, inertial frame.
    pub axis: Vec3,
    /// Spin rate, rad/s (right-handed about `axis`).
    pub rate: f64,
    /// A point of the axis, m (default: the origin).
    #[serde(default)]
    pub center: Vec3,
    /// Names of nodes and beams that spin.
    pub items: Vec<String>,
}

/// A node: a point with a triad, the carrier of 3 displacement and 3 rotation unknowns.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct Node {
    pub name: String,
    /// Initial position, m, inertial frame (or `frame`'s).
    pub position: Vec3,
    /// Initial orientation of the node's triad relative to the inertial frame (or `frame`'s).
    #[serde(default)]
    pub orientation: Orientation,
    /// Initial velocity, m/s, inertial frame (default zero; completed to satisfy the joints).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<Vec3>,
    /// Initial angular velocity, rad/s, inertial frame (default zero).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular_velocity: Option<Vec3>,
    /// A node (of `nodes`) in whose initial frame this node is given: `position` relative to
    /// it and every vector and the orientation in its triad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<String>,
}

/// Orientation of a triad: give at most one of the fields (none means aligned with the
/// inertial frame).
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug, Default)]
#[serde(deny_unknown_fields)]
pub struct Orientation {
    /// Rotation matrix whose columns are the triad's unit vectors in the inertial frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub matrix: Option<Mat3>,
    /// Rotation vector (axis × angle, rad) from the inertial frame to the triad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation_vector: Option<Vec3>,
}

/// A rigid body carried by a node.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct RigidBody {
    pub name: String,
    /// The node that carries the body.
    pub node: String,
    /// Mass, kg.
    pub mass: f64,
    /// Inertia tensor about the centre of mass, kg·m², in the node's triad: either the three
    /// principal values `[I11, I22, I33]` or the full symmetric 3×3 matrix.
    pub inertia: Inertia,
    /// Position of the centre of mass relative to the node, m, in the node's triad.
    #[serde(default)]
    pub cm_offset: Vec3,
}

/// A geometrically exact beam meshed from `start` to `end`: straight, an `arc`, or a polyline
/// through `via` points; pre-twisted by `twist_rate` or a `twist` table. Its nodes are named
/// `<beam>.0` … `<beam>.N` (N = elements × order) unless `start_node`/`end_node` name existing
/// nodes to share (with rigid bodies, joints or other beams).
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct Beam {
    pub name: String,
    /// Start point, m (or give `start_node`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<Vec3>,
    /// End point, m (or give `end_node`); optional for an arc, whose end it must match.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end: Option<Vec3>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_node: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_node: Option<String>,
    /// Number of elements (for a polyline, shared among its segments by length, at least one
    /// each).
    pub elements: usize,
    /// Element order: 1 linear (2 nodes), 2 quadratic (3 nodes), 3 cubic (4 nodes).
    #[serde(default = "default_order")]
    pub order: usize,
    /// Sectional properties, uniform along the span (or give `sections`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section: Option<SectionSpec>,
    /// Sections at stations along the span, interpolated linearly between them; the first
    /// station at eta = 0, the last at eta = 1.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sections: Vec<SectionStation>,
    /// Direction of the section's axis 2 at the start (projected normal to the beam axis);
    /// defaults to `ẑ × axis`: horizontal, with axis 3 in the vertical plane through the beam
    /// on the +z side (+z itself for a horizontal beam); +y for a vertical beam.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub e2: Option<Vec3>,
    /// Constant pre-twist rate k₁, rad/m: the section frame turns about the axis along the span.
    #[serde(default)]
    pub twist_rate: f64,
    /// Pre-twist as a table of section angles about the beam axis (rad, relative to `e2`
    /// carried along the beam) at fractions of its length, interpolated linearly.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub twist: Option<TwistTable>,
    /// A circular arc from the start point, turning by `angle` about `axis` through `center`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arc: Option<ArcSpec>,
    /// Corner points of a polyline from start to end, m.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub via: Vec<Vec3>,
    /// Initial rigid-body motion of the beam's own nodes: velocity of the start point (m/s) and
    /// angular velocity (rad/s), inertial frame. Shared end nodes keep their own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<Vec3>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular_velocity: Option<Vec3>,
    /// Structural damping: stiffness-proportional (μ, or a ratio at a frequency), a sectional
    /// damping matrix, and/or mass-proportional.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<BeamDamping>,
    /// A node (of `nodes`) in whose initial frame the beam is given: points relative to it,
    /// directions in its triad; the default `e2` is then the default rule in that frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<String>,
}

/// A section at a station along a beam.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct SectionStation {
    /// Fraction of the beam length.
    pub eta: f64,
    pub section: SectionSpec,
}

/// Section angle θ(η) about the beam axis, rad, piecewise linear in η.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct TwistTable {
    /// Fractions of the beam length, increasing from 0 to 1.
    pub eta: Vec<f64>,
    /// Angles at those stations, rad.
    pub angle: Vec<f64>,
}

/// A circular arc.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct ArcSpec {
    /// Centre of the circle, m.
    pub center: Vec3,
    /// Unit normal of the arc's plane; the arc turns right-handedly about it.
    pub axis: Vec3,
    /// Angle swept, rad (0 < |angle| ≤ 2π; negative turns the other way).
    pub angle: f64,
}

impl ArcSpec {
    /// Where the arc from `start` ends.
    pub fn end(&self, start: Vec3) -> Vec3 {
        use crate::math::{rotation::exp_map, vec3::V3};
        let axis = V3(self.axis).scale_f(1.0 / V3(self.axis).norm().max(1e-300));
        let c = V3(self.center);
        (c + exp_map(&axis.scale_f(self.angle)).mul_v(&(V3(start) - c))).0
    }
}

fn default_order() -> usize {
    3
}

impl Beam {
    /// The start and end points, if known (given, or nodes of `model`); an arc's end follows
    /// from its start.
    pub fn end_points(&self, model: &Model) -> Option<(Vec3, Vec3)> {
        let at = |p: &Option<Vec3>, n: &Option<String>| -> Option<Vec3> {
            p.or_else(|| {
                n.as_ref().and_then(|n| {
                    model
                        .nodes
                        .iter()
                        .find(|x| &x.name == n)
                        .map(|x| x.position)
                })
            })
        };
        let a = at(&self.start, &self.start_node)?;
        let b = match &self.arc {
            Some(arc) => arc.end(a),
            None => at(&self.end, &self.end_node)?,
        };
        Some((a, b))
    }

    /// Nodes along the beam: elements × order + 1.
    pub fn node_count(&self) -> usize {
        self.elements * self.order + 1
    }
    /// The names `<beam>.start` and `<beam>.end` with the end nodes they stand for (which
    /// may be shared nodes with their own names).
    pub fn end_aliases(&self) -> [(String, String); 2] {
        [
            (format!("{}.start", self.name), self.node_name(0)),
            (
                format!("{}.end", self.name),
                self.node_name(self.node_count() - 1),
            ),
        ]
    }

    /// Name of the k-th node along the beam (a shared end node keeps its own name).
    pub fn node_name(&self, k: usize) -> String {
        let last = self.node_count() - 1;
        match (k, &self.start_node, &self.end_node) {
            (0, Some(n), _) => n.clone(),
            (k, _, Some(n)) if k == last => n.clone(),
            _ => format!("{}.{k}", self.name),
        }
    }
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(untagged)]
pub enum Inertia {
    Principal(Vec3),
    Full(Mat3),
}

impl Inertia {
    pub fn matrix(&self) -> Mat3 {
        match self {
            Inertia::Principal(d) => [[d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]],
            Inertia::Full(m) => *m,
        }
    }
}

pub use crate::math::time_function::{TableSpec, TimeFunctionSpec};

/// A spring and damper on a joint's relative coordinate: linear (`stiffness`, `rest`) or
/// nonlinear (`table`), with linear viscous `damping`.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug, Default)]
#[serde(deny_unknown_fields)]
pub struct SpringDamper {
    /// N·m/rad for rotations (N/m for displacements).
    #[serde(default)]
    pub stiffness: f64,
    /// N·m·s/rad for rotations (N·s/m for displacements).
    #[serde(default)]
    pub damping: f64,
    /// Value of the coordinate at which the spring is unloaded.
    #[serde(default)]
    pub rest: f64,
    /// Nonlinear spring instead of `stiffness`/`rest`: its force (N or N·m; it acts against
    /// the coordinate) at coordinate values `at`, piecewise linear, extended beyond the ends
    /// with the end slopes. The force must not decrease as the coordinate grows. Its energy is
    /// zero where the force vanishes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub table: Option<SpringTable>,
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug, Default)]
#[serde(deny_unknown_fields)]
pub struct SpringTable {
    /// Coordinate values, strictly increasing (m or rad).
    pub at: Vec<f64>,
    /// The spring force at those values.
    pub force: Vec<f64>,
}

/// Joints connect two nodes (`node1` is body k of the paper, `node2` body l); either may be
/// `ground`. Positions and axes are given in the initial configuration, in the inertial frame
/// or (with `frame: node1` / `node2`) in that node's triad.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Joint {
    /// Coincident points (3 constraints).
    Spherical(SphericalJoint),
    /// Coincident points and a common axis; relative rotation φ about it (eqs. 17–23).
    Revolute(RevoluteJoint),
    /// Coincident points, `axis1` on node1 stays orthogonal to `axis2` on node2 (eqs. 11–16).
    Universal(UniversalJoint),
    /// Rigid connection: no relative motion at all.
    Clamp(ClampJoint),
    /// Identical orientations; node2 slides along the axis by Δ (eqs. 3–10).
    Prismatic(PrismaticJoint),
    /// Slides along and turns about a common axis: Δ and φ (section 4.3).
    Cylindrical(CylindricalJoint),
    /// A cylindrical joint with Δ = pitch·φ (eq. 24).
    Screw(ScrewJoint),
    /// The follower's point stays on a flexible beam at a moving point η (section 5).
    Sliding(SlidingJoint),
    /// A sliding joint whose follower also turns with the beam's section about the beam's
    /// axis, following its pre-twist and elastic twist (section 6).
    SlidingScrew(SlidingJoint),
    /// A sliding joint whose follower keeps its orientation relative to the beam's section
    /// (a sleeve that can neither tilt nor turn on the beam).
    SlidingClamp(SlidingJoint),
}

/// A contact point that moves along a beam. η = s/L is the fraction of the beam's reference
/// length from its first end; the follower's contact point is the beam point at the initial η
/// (the follower's node may be offset from it: it is carried rigidly).
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct SlidingJoint {
    pub name: String,
    /// The beam the contact point moves along.
    pub beam: String,
    /// The node kept on the beam, or `ground` (a fixed guide the beam slides through).
    pub follower: String,
    /// Initial contact point η ∈ [0, 1]. Default: the drive's value at t = 0, else the beam
    /// point closest to the follower's node. With a drive it may be given only as the drive's
    /// value at t = 0 (within 1e-9).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eta: Option<f64>,
    /// Prescribed η(t) ∈ [0, 1]. Its multiplier is the driving force along the beam.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive: Option<TimeFunctionSpec>,
    /// Spring and damper along the beam: stiffness N/m, damping N·s/m, `rest` as an η (a
    /// `table` gives the force in N against η). Needs a uniformly meshed beam.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring: Option<SpringDamper>,
    /// Elastic stops at the beam's ends (else a free contact point that reaches an end stops
    /// the run): the contact point bounces off them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_stops: Option<EndStops>,
    /// Coulomb friction on the sliding motion (see [`Friction`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<Friction>,
}

/// Elastic end stops of a sliding joint: no force on the beam, a linear spring of the given
/// stiffness as the contact point runs past an end (its energy is conserved by EP).
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct EndStops {
    /// N/m of penetration past the end.
    pub stiffness: f64,
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct PrismaticJoint {
    pub name: String,
    pub node1: String,
    pub node2: String,
    /// The frame in which `position` and the axes are given: `inertial` (default), or
    /// `node1` / `node2`: that node's initial triad, the position relative to the node.
    #[serde(default, skip_serializing_if = "JointFrame::is_inertial")]
    pub frame: JointFrame,
    /// Joint location, m (defaults to node2's initial position).
    #[serde(default)]
    pub position: Option<Vec3>,
    /// Unit vector of the sliding axis.
    pub axis: Vec3,
    /// Prescribed relative displacement Δ(t), m. Its multiplier is the driving force.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive: Option<TimeFunctionSpec>,
    /// Spring and damper on Δ (N/m, N·s/m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring: Option<SpringDamper>,
    /// Coulomb friction on the sliding motion (see [`Friction`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<Friction>,
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct CylindricalJoint {
    pub name: String,
    pub node1: String,
    pub node2: String,
    /// The frame in which `position` and the axes are given: `inertial` (default), or
    /// `node1` / `node2`: that node's initial triad, the position relative to the node.
    #[serde(default, skip_serializing_if = "JointFrame::is_inertial")]
    pub frame: JointFrame,
    /// Joint location, m (defaults to node2's initial position).
    #[serde(default)]
    pub position: Option<Vec3>,
    /// Unit vector of the common axis.
    pub axis: Vec3,
    /// Prescribed Δ(t), m (multiplier: the driving force).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive_delta: Option<TimeFunctionSpec>,
    /// Spring and damper on Δ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring_delta: Option<SpringDamper>,
    /// Prescribed φ(t), rad (multiplier: the driving torque).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive_phi: Option<TimeFunctionSpec>,
    /// Spring and damper on φ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring_phi: Option<SpringDamper>,
    /// Coulomb friction on the sliding motion (see [`Friction`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<Friction>,
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct ScrewJoint {
    pub name: String,
    pub node1: String,
    pub node2: String,
    /// The frame in which `position` and the axes are given: `inertial` (default), or
    /// `node1` / `node2`: that node's initial triad, the position relative to the node.
    #[serde(default, skip_serializing_if = "JointFrame::is_inertial")]
    pub frame: JointFrame,
    #[serde(default)]
    pub position: Option<Vec3>,
    /// Unit vector of the screw axis.
    pub axis: Vec3,
    /// Advance per radian of turn, m/rad (Δ = pitch·φ; a full turn advances 2π·pitch);
    /// negative for a left-handed thread.
    pub pitch: f64,
    /// Prescribed Δ(t) (or give `drive_phi`; not both, they are tied by the thread).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive_delta: Option<TimeFunctionSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring_delta: Option<SpringDamper>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive_phi: Option<TimeFunctionSpec>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring_phi: Option<SpringDamper>,
    /// Thread friction (see [`Friction`]; needs its `radius`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<Friction>,
}

/// Coulomb friction on a joint's sliding motion: a friction force opposing the slip, at most
/// `static`·N while the joint sticks and `kinetic`·N + `viscous`·(slip rate) while it slides,
/// with N the joint's own normal force (its constraint forces normal to the slip) plus
/// `preload`. Sticking is exact (the joint is held, no creep); static and dynamic analyses
/// with the same model differ in that statics and modes leave friction out.
///
/// - prismatic, cylindrical: slip along the axis (Δ); N = the force normal to the axis;
/// - sliding, sliding clamp: slip along the beam (arc length); N = the contact force normal to
///   the beam's axis;
/// - sliding screw: as sliding, plus (with `radius`) the twisting moment the follower exerts
///   about the beam's axis over `radius`;
/// - sliding joints with a `lead` (and `radius`): as sliding, plus a thread's normal force
///   from the axial load (a nut on a jackscrew);
/// - screw: thread friction along the helix at the mean thread `radius` (lead angle
///   α = atan(pitch/radius)); N = the thread's normal force, axial load/(cos α cos β) with
///   β the `thread_angle`. The thread holds its load without a torque (self-locking) when
///   `static` ≥ tan α · cos β.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct Friction {
    /// Static coefficient μs (–): the largest friction force while sticking is μs·N.
    #[serde(rename = "static")]
    pub static_coefficient: f64,
    /// Kinetic coefficient μk ≤ μs (–), the friction force μk·N while sliding. Default: μs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kinetic: Option<f64>,
    /// Viscous part while sliding, N·s/m of slip rate (default 0).
    #[serde(default)]
    pub viscous: f64,
    /// Normal force present whatever the joint carries (a spring-loaded guide), N (default 0).
    #[serde(default)]
    pub preload: f64,
    /// m: a screw's mean thread radius (required for a screw joint, and with a `lead`); for a
    /// sliding screw without a `lead`, the radius at which its twisting moment is carried.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// m per turn: a thread between a sliding joint's follower and its beam (a nut on a
    /// jackscrew whose turn the slide's drive stands for), at `radius`: its normal force comes
    /// from the axial load, so the drive pays the screw's friction and a free nut holds its
    /// load when `static` ≥ tan α · cos β (tan α = lead/(2π radius)). Sliding joints only (a
    /// screw joint's lead is its pitch).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lead: Option<f64>,
    /// Half-angle of the thread's profile, rad (0: square thread; 0.5236 for ISO metric
    /// threads, 0.2531 for Acme). Screw joints, and sliding joints with a `lead`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thread_angle: Option<f64>,
}

impl Friction {
    /// μk (μs when not given).
    pub fn kinetic_coefficient(&self) -> f64 {
        self.kinetic.unwrap_or(self.static_coefficient)
    }
}

/// Where a joint's geometry is given.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Copy, Debug, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum JointFrame {
    #[default]
    Inertial,
    Node1,
    Node2,
}

impl JointFrame {
    pub fn is_inertial(&self) -> bool {
        *self == JointFrame::Inertial
    }
}

/// A relative coordinate of a joint (Δ or φ) with its optional drive and spring, and the
/// model fields they came from.
#[derive(Clone, Copy, Debug)]
pub struct CoordinateSpec<'a> {
    /// `delta`, `phi`, or `eta` (a sliding joint's contact point).
    pub name: &'static str,
    pub drive: Option<&'a TimeFunctionSpec>,
    pub spring: Option<&'a SpringDamper>,
    pub drive_field: &'static str,
    pub spring_field: &'static str,
}

impl CoordinateSpec<'_> {
    pub fn is_rotation(&self) -> bool {
        self.name.starts_with("phi")
    }
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct SphericalJoint {
    pub name: String,
    pub node1: String,
    pub node2: String,
    /// The frame in which `position` and the axes are given: `inertial` (default), or
    /// `node1` / `node2`: that node's initial triad, the position relative to the node.
    #[serde(default, skip_serializing_if = "JointFrame::is_inertial")]
    pub frame: JointFrame,
    /// Joint location, m (defaults to node2's initial position).
    #[serde(default)]
    pub position: Option<Vec3>,
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct RevoluteJoint {
    pub name: String,
    pub node1: String,
    pub node2: String,
    /// The frame in which `position` and the axes are given: `inertial` (default), or
    /// `node1` / `node2`: that node's initial triad, the position relative to the node.
    #[serde(default, skip_serializing_if = "JointFrame::is_inertial")]
    pub frame: JointFrame,
    /// Joint location, m (defaults to node2's initial position).
    #[serde(default)]
    pub position: Option<Vec3>,
    /// Unit vector of the rotation axis.
    pub axis: Vec3,
    /// Prescribed relative rotation φ(t), rad. Its multiplier is the driving torque.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive: Option<TimeFunctionSpec>,
    /// Spring and damper on φ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring: Option<SpringDamper>,
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct UniversalJoint {
    pub name: String,
    pub node1: String,
    pub node2: String,
    /// The frame in which `position` and the axes are given: `inertial` (default), or
    /// `node1` / `node2`: that node's initial triad, the position relative to the node.
    #[serde(default, skip_serializing_if = "JointFrame::is_inertial")]
    pub frame: JointFrame,
    #[serde(default)]
    pub position: Option<Vec3>,
    /// Unit vector fixed to node1.
    pub axis1: Vec3,
    /// Unit vector fixed to node2, orthogonal to `axis1`.
    pub axis2: Vec3,
    /// Prescribed rotation φ1(t) of the cross about `axis1`, rad (must be 0 at t = 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive1: Option<TimeFunctionSpec>,
    /// Spring and damper on φ1 (a gimbal's first rotation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring1: Option<SpringDamper>,
    /// Prescribed rotation φ2(t) of node2 about `axis2`, rad (must be 0 at t = 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive2: Option<TimeFunctionSpec>,
    /// Spring and damper on φ2.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring2: Option<SpringDamper>,
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct ClampJoint {
    pub name: String,
    pub node1: String,
    pub node2: String,
}

impl Joint {
    pub fn name(&self) -> &str {
        match self {
            Joint::Spherical(j) => &j.name,
            Joint::Revolute(j) => &j.name,
            Joint::Universal(j) => &j.name,
            Joint::Clamp(j) => &j.name,
            Joint::Prismatic(j) => &j.name,
            Joint::Cylindrical(j) => &j.name,
            Joint::Screw(j) => &j.name,
            Joint::Sliding(j) | Joint::SlidingScrew(j) | Joint::SlidingClamp(j) => &j.name,
        }
    }
    /// Holds relative coordinate `k` (in the order of [`Joint::coordinates`]) at `value` by a
    /// constant drive, without the spring, friction or end stops a held coordinate cannot use
    /// (a sliding joint's given `eta` goes too); the joint's other coordinates keep theirs.
    /// `false` for a screw joint, whose two coordinates are one motion (the caller holds
    /// neither).
    pub fn hold_coordinate(&mut self, k: usize, value: f64) -> bool {
        let held = Some(TimeFunctionSpec::Constant(value));
        match (self, k) {
            (Joint::Revolute(j), 0) => (j.drive, j.spring) = (held, None),
            (Joint::Universal(j), 0) => (j.drive1, j.spring1) = (held, None),
            (Joint::Universal(j), 1) => (j.drive2, j.spring2) = (held, None),
            (Joint::Prismatic(j), 0) => (j.drive, j.spring, j.friction) = (held, None, None),
            (Joint::Cylindrical(j), 0) => {
                (j.drive_delta, j.spring_delta, j.friction) = (held, None, None);
            }
            (Joint::Cylindrical(j), 1) => (j.drive_phi, j.spring_phi) = (held, None),
            (Joint::Sliding(j) | Joint::SlidingScrew(j) | Joint::SlidingClamp(j), 0) => {
                (j.drive, j.eta, j.spring) = (held, None, None);
                (j.friction, j.end_stops) = (None, None);
            }
            _ => return false,
        }
        true
    }
    /// The sliding joint's data, for the three sliding types.
    /// The joint's friction, for the kinds that can carry it.
    pub fn friction(&self) -> Option<&Friction> {
        match self {
            Joint::Prismatic(j) => j.friction.as_ref(),
            Joint::Cylindrical(j) => j.friction.as_ref(),
            Joint::Screw(j) => j.friction.as_ref(),
            Joint::Sliding(j) | Joint::SlidingScrew(j) | Joint::SlidingClamp(j) => {
                j.friction.as_ref()
            }
            _ => None,
        }
    }
    pub fn sliding(&self) -> Option<&SlidingJoint> {
        match self {
            Joint::Sliding(j) | Joint::SlidingScrew(j) | Joint::SlidingClamp(j) => Some(j),
            _ => None,
        }
    }
    /// The two nodes a joint connects; for a sliding joint, the beam's name and the follower.
    pub fn nodes(&self) -> (&str, &str) {
        match self {
            Joint::Spherical(j) => (&j.node1, &j.node2),
            Joint::Revolute(j) => (&j.node1, &j.node2),
            Joint::Universal(j) => (&j.node1, &j.node2),
            Joint::Clamp(j) => (&j.node1, &j.node2),
            Joint::Prismatic(j) => (&j.node1, &j.node2),
            Joint::Cylindrical(j) => (&j.node1, &j.node2),
            Joint::Screw(j) => (&j.node1, &j.node2),
            Joint::Sliding(j) | Joint::SlidingScrew(j) | Joint::SlidingClamp(j) => {
                (&j.beam, &j.follower)
            }
        }
    }
    pub fn kind(&self) -> &'static str {
        match self {
            Joint::Spherical(_) => "spherical",
            Joint::Revolute(_) => "revolute",
            Joint::Universal(_) => "universal",
            Joint::Clamp(_) => "clamp",
            Joint::Prismatic(_) => "prismatic",
            Joint::Cylindrical(_) => "cylindrical",
            Joint::Screw(_) => "screw",
            Joint::Sliding(_) => "sliding",
            Joint::SlidingScrew(_) => "sliding_screw",
            Joint::SlidingClamp(_) => "sliding_clamp",
        }
    }
    /// The frame its geometry is given in.
    pub fn frame(&self) -> JointFrame {
        match self {
            Joint::Spherical(j) => j.frame,
            Joint::Revolute(j) => j.frame,
            Joint::Universal(j) => j.frame,
            Joint::Clamp(_)
            | Joint::Sliding(_)
            | Joint::SlidingScrew(_)
            | Joint::SlidingClamp(_) => JointFrame::Inertial,
            Joint::Prismatic(j) => j.frame,
            Joint::Cylindrical(j) => j.frame,
            Joint::Screw(j) => j.frame,
        }
    }
    /// The joint location given in the model, if any.
    pub fn position(&self) -> Option<Vec3> {
        match self {
            Joint::Spherical(j) => j.position,
            Joint::Revolute(j) => j.position,
            Joint::Universal(j) => j.position,
            Joint::Clamp(_)
            | Joint::Sliding(_)
            | Joint::SlidingScrew(_)
            | Joint::SlidingClamp(_) => None,
            Joint::Prismatic(j) => j.position,
            Joint::Cylindrical(j) => j.position,
            Joint::Screw(j) => j.position,
        }
    }
    /// The joint's relative coordinates, in the order of its law (Δ before φ).
    pub fn coordinates(&self) -> Vec<CoordinateSpec<'_>> {
        fn c<'a>(
            name: &'static str,
            drive: &'a Option<TimeFunctionSpec>,
            spring: &'a Option<SpringDamper>,
            drive_field: &'static str,
            spring_field: &'static str,
        ) -> CoordinateSpec<'a> {
            CoordinateSpec {
                name,
                drive: drive.as_ref(),
                spring: spring.as_ref(),
                drive_field,
                spring_field,
            }
        }
        match self {
            Joint::Revolute(j) => vec![c("phi", &j.drive, &j.spring, "drive", "spring")],
            Joint::Universal(j) => vec![
                c("phi1", &j.drive1, &j.spring1, "drive1", "spring1"),
                c("phi2", &j.drive2, &j.spring2, "drive2", "spring2"),
            ],
            Joint::Prismatic(j) => vec![c("delta", &j.drive, &j.spring, "drive", "spring")],
            Joint::Cylindrical(j) => vec![
                c(
                    "delta",
                    &j.drive_delta,
                    &j.spring_delta,
                    "drive_delta",
                    "spring_delta",
                ),
                c(
                    "phi",
                    &j.drive_phi,
                    &j.spring_phi,
                    "drive_phi",
                    "spring_phi",
                ),
            ],
            Joint::Screw(j) => vec![
                c(
                    "delta",
                    &j.drive_delta,
                    &j.spring_delta,
                    "drive_delta",
                    "spring_delta",
                ),
                c(
                    "phi",
                    &j.drive_phi,
                    &j.spring_phi,
                    "drive_phi",
                    "spring_phi",
                ),
            ],
            Joint::Sliding(j) | Joint::SlidingScrew(j) | Joint::SlidingClamp(j) => {
                vec![c("eta", &j.drive, &j.spring, "drive", "spring")]
            }
            _ => vec![],
        }
    }
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

/// Applied loads, each scaled by an optional function of time. A *dead* load keeps its
/// direction in the inertial frame; a *follower* load is given in the node's triad (for
/// distributed loads: in the beam's section frame, axis 1 along the beam) and turns with it.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Load {
    /// Point force, N.
    Force(PointLoad),
    /// Point moment, N·m.
    Moment(PointLoad),
    /// Force per unit length along a whole beam, N/m (lumped consistently to its nodes).
    DistributedForce(DistributedLoad),
    /// Moment per unit length along a whole beam, N·m/m.
    DistributedMoment(DistributedLoad),
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct PointLoad {
    pub name: String,
    pub node: String,
    /// Load vector: inertial frame (dead) or the node's triad (follower).
    pub value: Vec3,
    /// The load turns with the node.
    #[serde(default, skip_serializing_if = "is_false")]
    pub follower: bool,
    /// Multiplies `value`; defaults to 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<TimeFunctionSpec>,
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct DistributedLoad {
    pub name: String,
    pub beam: String,
    /// Load per unit length of the reference beam: inertial frame (dead) or the section frame
    /// (follower).
    pub value: Vec3,
    /// The load turns with the beam's sections.
    #[serde(default, skip_serializing_if = "is_false")]
    pub follower: bool,
    /// Multiplies `value`; defaults to 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<TimeFunctionSpec>,
}

fn is_false(b: &bool) -> bool {
    !*b
}

impl Load {
    pub fn name(&self) -> &str {
        match self {
            Load::Force(l) | Load::Moment(l) => &l.name,
            Load::DistributedForce(l) | Load::DistributedMoment(l) => &l.name,
        }
    }
    pub fn value(&self) -> &Vec3 {
        match self {
            Load::Force(l) | Load::Moment(l) => &l.value,
            Load::DistributedForce(l) | Load::DistributedMoment(l) => &l.value,
        }
    }
    pub fn scale(&self) -> Option<&TimeFunctionSpec> {
        match self {
            Load::Force(l) | Load::Moment(l) => l.scale.as_ref(),
            Load::DistributedForce(l) | Load::DistributedMoment(l) => l.scale.as_ref(),
        }
    }
    pub fn follower(&self) -> bool {
        match self {
            Load::Force(l) | Load::Moment(l) => l.follower,
            Load::DistributedForce(l) | Load::DistributedMoment(l) => l.follower,
        }
    }
    pub fn is_moment(&self) -> bool {
        matches!(self, Load::Moment(_) | Load::DistributedMoment(_))
    }
}

/// A named quantity recorded during the run. Each sensor gives one or more channels named
/// `<sensor>.<component>`, or with `component` just that one, named `<sensor>` (e.g.
/// `{type: beam_section, name: beam_mid_F1, beam: beam, eta: 0.5, component: F1}`).
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Sensor {
    /// `.x .y .z`, m.
    NodePosition {
        name: String,
        node: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// Position of `node` relative to the `reference` node, in the reference's triad:
    /// `.x1 .x2 .x3` (m), and `.r1 .r2 .r3`, the distance from the reference's axis 1, 2 or 3
    /// through it (m) — e.g. a blade tip's radius from the hub's spin axis.
    RelativePosition {
        name: String,
        node: String,
        reference: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// Displacement from the initial position: `.ux .uy .uz`, m, inertial (`.x .y .z`, the
    /// former names, read the same until 0.3).
    NodeDisplacement {
        name: String,
        node: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// Rotation vector from the initial orientation `.rx .ry .rz` (rad, inertial; `.x .y .z`
    /// until 0.3) and the triad matrix entries `.R11` … `.R33`.
    NodeRotation {
        name: String,
        node: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// Velocity `.vx .vy .vz` (m/s) and angular velocity `.wx .wy .wz` (rad/s), inertial frame.
    NodeVelocity {
        name: String,
        node: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// A joint's relative coordinates and their rates: `.phi .phi_rate` (rad, rad/s) and/or
    /// `.delta .delta_rate` (m, m/s).
    JointCoordinate {
        name: String,
        joint: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// Reaction on node2 at the joint point: inertial components `.Fx .Fy .Fz` (N) and
    /// `.Mx .My .Mz` (N·m), the same in the joint frame `.F1 .F2 .F3 .M1 .M2 .M3` (axis 3 along
    /// the joint's axis), and the constraint violation `.violation` (largest |C| of the
    /// joint's rows: m for points, 1 for directions).
    JointReaction {
        name: String,
        joint: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// Driving force `.force` (N, a prescribed Δ) or torque `.torque` (N·m, a prescribed φ),
    /// and the work `.work` it has done. `coordinate` (`delta` or `phi`) picks the drive of a
    /// joint that has two.
    DriveForce {
        name: String,
        joint: String,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        coordinate: Option<String>,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// A joint's friction (the joint must have `friction:`): the friction force on the slip
    /// `.force` (N; it opposes the slip: positive when it pushes towards −u), the normal force
    /// `.normal` (N), the slip `.slip` (m along the slip's direction: Δ, the arc length on the
    /// beam, or the length along a screw's helix) and its rate `.slip_rate` (m/s), the mode
    /// `.stick` (1 while stuck, 0 while sliding), and the energy it has dissipated
    /// `.dissipation` (J).
    Friction {
        name: String,
        joint: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// `.kinetic .potential .total .drive_work .external_work .damper_work
    /// .friction_dissipation .numerical_dissipation .balance`, J.
    Energy {
        name: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// At a station of a beam (`eta`: fraction of its length, or `s`: arc length): sectional forces
    /// `.F1 .F2 .F3` (N) and moments `.M1 .M2 .M3` (N·m) in the deformed section frame (axis 1
    /// along the beam), strains `.e1 .g2 .g3` and curvatures `.k1 .k2 .k3` (1/m) relative to the
    /// reference (recovered from the Gauss points), the position `.x .y .z` and displacement
    /// `.ux .uy .uz` (m), and the rotation of the section from its reference as a rotation
    /// vector, in the reference section frame `.phi1` (twist about the beam axis), `.phi2
    /// .phi3` (bending), and in the inertial frame `.rx .ry .rz` (rad).
    BeamSection {
        name: String,
        beam: String,
        /// Fraction of the beam length from its start (give `eta` or `s`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        eta: Option<f64>,
        /// Arc length from the start, m, in the reference configuration.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        s: Option<f64>,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// A beam's own `.kinetic` and `.strain` energy, J.
    BeamEnergy {
        name: String,
        beam: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
    /// Total linear momentum `.px .py .pz` (N·s) and angular momentum about the origin
    /// `.Hx .Hy .Hz` (N·m·s), inertial frame.
    Momentum {
        name: String,
        /// Keep only this component, as one channel named after the sensor.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        component: Option<String>,
    },
}

impl Sensor {
    /// The one component asked for, if any.
    pub fn component(&self) -> Option<&str> {
        match self {
            Sensor::NodePosition { component, .. }
            | Sensor::RelativePosition { component, .. }
            | Sensor::NodeDisplacement { component, .. }
            | Sensor::NodeRotation { component, .. }
            | Sensor::NodeVelocity { component, .. }
            | Sensor::JointCoordinate { component, .. }
            | Sensor::JointReaction { component, .. }
            | Sensor::DriveForce { component, .. }
            | Sensor::Friction { component, .. }
            | Sensor::BeamSection { component, .. }
            | Sensor::BeamEnergy { component, .. }
            | Sensor::Energy { component, .. }
            | Sensor::Momentum { component, .. } => component.as_deref(),
        }
    }

    pub fn name(&self) -> &str {
        match self {
            Sensor::NodePosition { name, .. }
            | Sensor::RelativePosition { name, .. }
            | Sensor::NodeDisplacement { name, .. }
            | Sensor::NodeRotation { name, .. }
            | Sensor::NodeVelocity { name, .. }
            | Sensor::JointCoordinate { name, .. }
            | Sensor::JointReaction { name, .. }
            | Sensor::DriveForce { name, .. }
            | Sensor::Friction { name, .. }
            | Sensor::BeamSection { name, .. }
            | Sensor::BeamEnergy { name, .. }
            | Sensor::Energy { name, .. }
            | Sensor::Momentum { name, .. } => name,
        }
    }
}

pub use crate::math::layout::Scheme;

/// What a run computes.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Copy, Debug, PartialEq, Eq, Default)]
#[serde(rename_all = "lowercase")]
pub enum Analysis {
    /// Time integration from t = 0 to `t_end`.
    #[default]
    Dynamic,
    /// Static equilibrium at t = 0: loads and gravity ramped by a load factor from 0 to 1 in
    /// `load_steps` equal steps (each halved on failure up to `max_step_halvings` times);
    /// drives held at their value at t = 0. One sample per load step.
    Static,
}

#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct SimulationSettings {
    #[serde(default)]
    pub analysis: Analysis,
    /// Static analysis: number of equal load-factor increments.
    #[serde(default = "default_load_steps")]
    pub load_steps: u32,
    #[serde(default)]
    pub scheme: Scheme,
    /// End time, s.
    #[serde(default = "default_t_end")]
    pub t_end: f64,
    /// Time step, s.
    #[serde(default = "default_dt")]
    pub dt: f64,
    /// Interval between recorded samples, s: outputs land exactly on k·output_dt whatever the
    /// steps (state channels interpolated within a step). Default: every step.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output_dt: Option<f64>,
    /// Full-field output at the output times: every node's position and orientation, the
    /// beams' section loads at their nodes, the sliding joints' contact points, with the
    /// model's topology — what `flexdyn view`, `animate` and `export` draw. Default: recorded
    /// when its estimated size (`flexdyn info`) is at most 100 MB.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fields: Option<bool>,
    /// How many times a step whose Newton iteration fails is halved before the run stops.
    #[serde(default = "default_max_halvings")]
    pub max_step_halvings: u32,
    /// Newton convergence: the force residual relative to the forces acting, and the
    /// constraints to what that means for them (never looser than this times the model's
    /// size, m or rad); both must hold for a step to be accepted.
    #[serde(default = "default_newton_tol")]
    pub newton_tol: f64,
    /// Newton convergence, second test: the last update moved every node by less than this,
    /// relative to the model's size (radians for rotations), with the residual below 1e-6 of
    /// its scale — for models whose residual round-off sits above `newton_tol`. 0 disables.
    #[serde(default = "default_newton_increment_tol")]
    pub newton_increment_tol: f64,
    #[serde(default = "default_max_iter")]
    pub max_newton_iterations: u32,
    /// Modified Newton (the default): keep the LU factors across iterations and across
    /// steps of the same size while the iteration contracts fast enough, factoring afresh
    /// when it does not, and retrying a step that failed on kept factors with fresh ones.
    /// The residual still meets `newton_tol`; it converges to it linearly instead of
    /// overshooting it quadratically. `false`: full Newton, a fresh tangent every iteration.
    #[serde(default = "default_true")]
    pub modified_newton: bool,
    /// `adaptive` steps (the default; `dt` is the first) chosen by a local error indicator
    /// against `tolerance`, or `fixed` steps of `dt`.
    #[serde(default)]
    pub step_control: StepControl,
    /// Adaptive stepping: the largest local error per unit step, as a velocity error relative
    /// to the motion's (√ of an error energy over the motion's energy, translations and
    /// rotations each against their own; for ED also the step's jump energy). The global
    /// relative error of a run is typically 0.3–8× it (measured on a pendulum, a heavy top, a
    /// flexible pendulum and the beam slider, docs/validation.md).
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Adaptive stepping: bounds on the step, s (defaults: 1e-6 of dt, or of t_end if shorter,
    /// and t_end/10 or dt if larger).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dt_min: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dt_max: Option<f64>,
    /// Dynamic analysis: `true` starts from the static equilibrium under the loads and
    /// gravity at t = 0 (solved with `load_steps`), with the given velocities made consistent
    /// there; `false` starts the beams unstrained, as given (a release). Unset (the default):
    /// a model at rest under gravity, loads or joint springs off their rest at t = 0 starts
    /// with its beams in equilibrium with them — a structure in its static equilibrium, a
    /// mechanism that moves by itself bent by the loads of the motion it starts —, anything
    /// else as given (see `simulation::inertial_preload::preload_at_rest`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preload: Option<bool>,
    /// Dynamic analysis: when drives already move at t = 0 and carry beams along, or beams
    /// move at t = 0 by given velocities, start the beams in quasi-static equilibrium with
    /// that motion's inertial loads (and gravity and the loads at t = 0), so they follow
    /// smoothly instead of ringing; `false` starts them unstrained.
    #[serde(default = "yes")]
    pub inertial_preload: bool,
    /// Adaptive stepping: the most a step may grow over the previous one, and shrink.
    #[serde(default = "default_max_growth")]
    pub max_growth: f64,
    #[serde(default = "default_max_shrink")]
    pub max_shrink: f64,
    /// Record where the run's wall time goes, phase by phase of its steps (residuals,
    /// tangents, factorizations, solves, …: `integrator::timings`), into the run statistics
    /// (`time_<phase>_s`); `flexdyn run --timings` prints them. Off by default: the clock
    /// reads cost up to 3 % of the cheapest models' steps (a four-bar linkage's).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub timings: bool,
}

/// How the time step is chosen.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Copy, Debug, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum StepControl {
    Fixed,
    #[default]
    Adaptive,
}

impl SimulationSettings {
    /// The smallest adaptive step: given, or a millionth of `dt` — of `t_end` if the run is
    /// shorter (a 100 µm cantilever plucked over 9 µs needs steps of 5e-10 s, below the
    /// 1e-9 s of the default `dt`'s millionth).
    pub fn dt_min(&self) -> f64 {
        let span = if self.t_end > 0.0 {
            self.dt.min(self.t_end)
        } else {
            self.dt
        };
        self.dt_min.unwrap_or(1e-6 * span)
    }
    pub fn dt_max(&self) -> f64 {
        self.dt_max.unwrap_or((0.1 * self.t_end).max(self.dt))
    }
}

/// Tight enough that default runs are within ~0.1 % on the benchmarks (at 1e-3 the heavy
/// top's precession was 0.8 % off after 0.5 s, the beam slider's load 0.9 %).
fn default_tolerance() -> f64 {
    1e-4
}
fn yes() -> bool {
    true
}
fn default_max_growth() -> f64 {
    2.0
}
fn default_max_shrink() -> f64 {
    0.2
}

fn default_load_steps() -> u32 {
    1
}
fn default_t_end() -> f64 {
    1.0
}
fn default_dt() -> f64 {
    1e-3
}
fn default_max_halvings() -> u32 {
    6
}
fn default_newton_tol() -> f64 {
    1e-10
}
fn default_newton_increment_tol() -> f64 {
    1e-12
}
fn default_true() -> bool {
    true
}

fn default_max_iter() -> u32 {
    25
}

impl Default for SimulationSettings {
    fn default() -> Self {
        SimulationSettings {
            analysis: Analysis::default(),
            load_steps: default_load_steps(),
            scheme: Scheme::default(),
            t_end: default_t_end(),
            dt: default_dt(),
            output_dt: None,
            fields: None,
            max_step_halvings: default_max_halvings(),
            newton_tol: default_newton_tol(),
            newton_increment_tol: default_newton_increment_tol(),
            max_newton_iterations: default_max_iter(),
            modified_newton: true,
            step_control: StepControl::default(),
            tolerance: default_tolerance(),
            preload: None,
            inertial_preload: true,
            dt_min: None,
            dt_max: None,
            max_growth: default_max_growth(),
            max_shrink: default_max_shrink(),
            timings: false,
        }
    }
}

/// The JSON Schema of the model file, generated from these types.
pub fn json_schema() -> String {
    let schema = schemars::schema_for!(Model);
    serde_json::to_string_pretty(&schema).expect("schema serialises")
}
