//! Joints between two nodes (or a node and the ground): the checks and compilation every
//! pair joint shares — its sides, the frame its geometry is given in, its relative
//! coordinates with their drives and springs — and the registry of joint kinds, one file
//! each, that place their law. Sliding joints (on a beam) have their own room,
//! [`super::sliding`].

mod clamp;
mod coordinates;
mod cylindrical;
mod prismatic;
mod revolute;
mod screw;
mod spherical;
mod universal;

pub use coordinates::spring_law;

use super::nodes::NodeTable;
use super::rows::RowTable;
use crate::joints::{Attachment, ConstraintLaw, Joint, JointKernel, JointLaw, Side};
use crate::math::rotation::exp_map;
use crate::math::vec3::{M3, V3};
use crate::model::check::{Checker, NodeNames};
use crate::model::{self, JointFrame, ModelError, Vec3, GROUND};
use crate::system::JointInfo;

/// What a pair joint kind adds to the shared compilation: its own checks and its law.
pub trait PairJoint {
    /// Checks of the kind's own fields (axes, pitch, …), reported under `path`.
    fn check(&self, _c: &mut Checker, _path: &str) {}
    /// The relative coordinates at t = 0 given the drives' values there (zero where not
    /// driven); a screw's thread ties its two.
    fn initial(&self, from_drives: [f64; 2]) -> [f64; 2] {
        from_drives
    }
    /// The law attached to both sides in the initial configuration, its relative coordinates
    /// at `at.initial`.
    fn law(&self, at: &Placement) -> Result<JointLaw, ModelError>;
}

/// The registry: each pair joint kind of the file format and the code that places it.
fn pair_joint(j: &model::Joint) -> Option<&dyn PairJoint> {
    match j {
        model::Joint::Spherical(s) => Some(s),
        model::Joint::Universal(u) => Some(u),
        model::Joint::Clamp(c) => Some(c),
        model::Joint::Revolute(r) => Some(r),
        model::Joint::Prismatic(p) => Some(p),
        model::Joint::Cylindrical(c) => Some(c),
        model::Joint::Screw(s) => Some(s),
        model::Joint::Sliding(_)
        | model::Joint::SlidingScrew(_)
        | model::Joint::SlidingClamp(_) => None,
    }
}

/// Checks every joint: references, geometry, coordinates, and each kind's own fields.
pub fn check(model: &model::Model, names: &NodeNames, c: &mut Checker) {
    for (i, j) in model.joints.iter().enumerate() {
        let p = format!("joints[{i}]");
        match j.sliding() {
            Some(sl) => super::sliding::check(model, sl, names, c, &p),
            None => check_sides(j, names, c, &p),
        }
        coordinates::check(j, c, &p);
        super::friction::check(j, c, &p);
        if let Some(kind) = pair_joint(j) {
            kind.check(c, &p);
        }
    }
}

/// A pair joint's nodes exist and differ; its position is a point.
fn check_sides(j: &model::Joint, names: &NodeNames, c: &mut Checker, p: &str) {
    let (n1, n2) = j.nodes();
    names.check(c, format!("{p}.node1"), n1, true);
    names.check(c, format!("{p}.node2"), n2, true);
    if n1 == n2 {
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
}

/// Compiles joint `j` (at `path`) into its coordinates, drives, springs and kernel.
pub fn compile(
    j: &model::Joint,
    path: &str,
    table: &NodeTable,
    rows: &mut RowTable,
) -> Result<(), ModelError> {
    let kind = pair_joint(j).expect("sliding joints compile in their own room");
    let coords = j.coordinates();
    let drives = coordinates::drives(&coords, path)?;
    let mut from_drives = [0.0; 2];
    for (k, f) in drives.iter().enumerate() {
        from_drives[k] = f.as_ref().map_or(0.0, |f| f.value(0.0));
    }
    let at = Placement::new(j, path, table, kind.initial(from_drives));
    let law = kind.law(&at)?;
    let n_rows = law.n_rows();
    let name = j.name().to_string();
    let (ids, info) = coordinates::compile(&name, &coords, drives, &at.initial, rows);
    let (sides, kernel_name) = (at.sides, name.clone());
    let build = move |row, layout: &_| {
        Joint::Pair(JointKernel::new(kernel_name, law, sides, ids, row, layout))
    };
    let kernel = rows.joint(name.clone(), n_rows, Box::new(build));
    if let Some(f) = j.friction() {
        super::friction::pair(j, f, kernel, &ids_of(&info), rows);
    }
    rows.joint_info.push(JointInfo {
        name,
        kernel,
        coords: info,
    });
    Ok(())
}

fn ids_of(info: &[crate::system::JointCoordinate]) -> Vec<usize> {
    info.iter().map(|c| c.coord).collect()
}

/// A joint's sides and initial configuration: where its geometry is attached.
pub struct Placement {
    /// The joint's path in the file and its name, for errors.
    pub path: String,
    pub name: String,
    /// The relative coordinates (Δ or φ, then φ) at t = 0.
    pub initial: [f64; 2],
    sides: [Side; 2],
    poses: [(V3<f64>, M3<f64>); 2],
    /// The frame the joint's geometry is given in.
    frame: (V3<f64>, M3<f64>),
    /// Where the joint sits when no `position` is given: at node 2 (else node 1, else the
    /// origin).
    default_position: V3<f64>,
}

impl Placement {
    fn new(j: &model::Joint, path: &str, table: &NodeTable, initial: [f64; 2]) -> Placement {
        let side = |n: &str| {
            if n == GROUND {
                Side::Ground {
                    x: V3::zero(),
                    r: M3::identity(),
                }
            } else {
                Side::Node(table.index(n))
            }
        };
        let pose = |s: &Side| match s {
            Side::Node(a) => (table.states[*a].x, table.states[*a].r),
            Side::Ground { x, r } => (*x, *r),
        };
        let (n1, n2) = j.nodes();
        let sides = [side(n1), side(n2)];
        let poses = [pose(&sides[0]), pose(&sides[1])];
        let frame = match j.frame() {
            JointFrame::Inertial => (V3::zero(), M3::identity()),
            JointFrame::Node1 => poses[0],
            JointFrame::Node2 => poses[1],
        };
        let default_position = match sides {
            [_, Side::Node(_)] => poses[1].0,
            [Side::Node(_), _] => poses[0].0,
            _ => V3::zero(),
        };
        Placement {
            path: path.to_string(),
            name: j.name().to_string(),
            initial,
            sides,
            poses,
            frame,
            default_position,
        }
    }

    /// The joint's point: `position` (in the joint's frame) or the default.
    pub fn point(&self, position: Option<Vec3>) -> V3<f64> {
        position.map_or(self.default_position, |p| {
            self.frame.0 + self.frame.1.mul_v(&V3(p))
        })
    }

    /// A direction given in the joint's frame, in the inertial frame.
    pub fn along(&self, a: Vec3) -> V3<f64> {
        self.frame.1.mul_v(&V3(a))
    }

    /// Attachment of an inertial point and triad to side `k`, in that side's triad.
    pub fn attach(&self, k: usize, p: V3<f64>, q: M3<f64>) -> Attachment {
        let (x, r) = self.poses[k];
        Attachment {
            offset: r.tmul_v(&(p - x)),
            triad: r.transpose().mul_m(&q),
        }
    }

    /// The same point and triad on both sides.
    pub fn both(&self, p: V3<f64>, q: M3<f64>) -> [Attachment; 2] {
        [self.attach(0, p, q), self.attach(1, p, q)]
    }

    /// A joint along `axis` (joint frame) through `position`: side k's triad has axis 3 along
    /// it; side l's attachment sits Δ₀ along and φ₀ about the axis back from it, so that the
    /// relative coordinates start at (Δ₀, φ₀) (revolute, prismatic, cylindrical, screw).
    pub fn axial(
        &self,
        axis: Vec3,
        position: Option<Vec3>,
        delta0: f64,
        phi0: f64,
    ) -> [Attachment; 2] {
        let p = self.point(position);
        let a = self.along(axis);
        let q = triad_from_axis(a);
        let a = a.scale_f(1.0 / a.norm());
        let (pl, ql) = (p + a.scale_f(-delta0), exp_map(&a.scale_f(phi0)).mul_m(&q));
        [self.attach(0, p, q), self.attach(1, pl, ql)]
    }

    /// An error at `field` of this joint.
    pub fn error(&self, field: &str, message: String) -> ModelError {
        ModelError::new(format!("{}.{field}", self.path), message)
    }
}

/// The joint frame of an axis: a right-handed triad whose third unit vector is along `e3`
/// (the reaction sensor's axes 1, 2, 3). Axis 1 is horizontal, `ẑ × e3` (so axis 2 points up
/// and joints patterned about z, like the pitch bearings of a rotor's blades, have patterned
/// frames), for axes within 45° of horizontal; for steeper axes it is x̂ projected normal to
/// the axis (x̂, ŷ, ẑ for a joint about +z, as in a planar mechanism). Continuous except at
/// 45° elevation, where the two rules meet.
pub fn triad_from_axis(e3: V3<f64>) -> M3<f64> {
    let e3 = e3.scale_f(1.0 / e3.norm());
    let e1 = if e3.0[2].abs() <= std::f64::consts::FRAC_1_SQRT_2 {
        V3([0.0, 0.0, 1.0]).cross(&e3)
    } else {
        let x = V3([1.0, 0.0, 0.0]);
        x - e3.scale_f(x.dot(&e3))
    };
    let e1 = e1.scale_f(1.0 / e1.norm());
    M3::from_cols(e1, e3.cross(&e1), e3)
}
