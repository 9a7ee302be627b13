//! Compiling a [`Model`] into a [`System`]: node numbering (including internal centre-of-mass
//! nodes), joint attachments in each node's triad, coordinates, constraint rows and kernels.

mod beam_mesh;
pub mod redundancy;
mod sliding;
pub mod sparse;
mod time_functions;

use crate::beam::element::BeamElement;
use crate::beam::line_load::FollowerLineLoad;
use crate::beam::path::{ArcMap, BeamPath};
use crate::elements::coordinate::{CoordinateDrive, CoordinateSpring, SpringLaw};
use crate::elements::inertia::{NodeInertia, SteadySpin};
use crate::elements::loads::{LoadKind, PointLoad};
use crate::joints::sliding::{ContactLaw, SlidingJoint, SlidingKind};
use crate::joints::{
    clamp::Clamp, cylindrical::Cylindrical, prismatic::Prismatic, revolute::Revolute, screw::Screw,
    spherical::Spherical, universal::Universal,
};
use crate::joints::{Attachment, ConstraintLaw, Joint, JointKernel, JointLaw, Side};
use crate::math::layout::Layout;
use crate::math::rotation::{exp_map, orthonormalize};
use crate::math::time_function::TimeFunction;
use crate::math::vec3::{M3, V3};
use crate::model::{self, Model, ModelError, ModelErrors, Scheme, GROUND};
use crate::state::{NodeState, State};
use std::collections::HashMap;

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

/// Size of a configuration, for relative tolerances.
fn length_scale(nodes: &[NodeState]) -> f64 {
    nodes.iter().map(|n| n.x.max_abs()).fold(1.0f64, f64::max)
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

/// Constraint rows of a joint's law (its drives add one each).
/// The elastic law a joint coordinate's spring describes.
fn spring_law(s: &model::SpringDamper) -> SpringLaw {
    match &s.table {
        Some(t) => SpringLaw::table(t.at.clone(), t.force.clone()),
        None => SpringLaw::Linear {
            stiffness: s.stiffness,
            rest: s.rest,
        },
    }
}

fn law_rows(j: &model::Joint) -> usize {
    match j {
        model::Joint::Spherical(_) => 3,
        model::Joint::Universal(_) => 6,
        model::Joint::Screw(_) => 7,
        model::Joint::Clamp(_)
        | model::Joint::Revolute(_)
        | model::Joint::Prismatic(_)
        | model::Joint::Cylindrical(_) => 6,
        model::Joint::Sliding(_) => 3,
        model::Joint::SlidingScrew(_) => 4,
        model::Joint::SlidingClamp(_) => 6,
    }
}

#[derive(Clone, Debug)]
pub struct System {
    pub name: String,
    pub layout: Layout,
    pub node_names: Vec<String>,
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
    /// Per node: whether the model gave its initial velocity (else zero, to be completed).
    pub velocity_given: Vec<bool>,
    /// Per node whose mass was moved to an internal centre-of-mass node: that node and the
    /// offset (carrier triad).
    pub cm_node: Vec<Option<(usize, V3<f64>)>>,
    /// Per node: the initial spin it was given, if any.
    pub node_spin: Vec<Option<SteadySpin>>,
    /// Each load's scale function, with the load's name (for diagnostics).
    pub load_scales: Vec<(String, TimeFunction)>,
}

fn orientation(o: &model::Orientation) -> M3<f64> {
    if let Some(m) = o.matrix {
        orthonormalize(&M3(m))
    } else if let Some(v) = o.rotation_vector {
        exp_map(&V3(v))
    } else {
        M3::identity()
    }
}

/// A right-handed triad whose third unit vector is `e3`.
pub fn triad_from_axis(e3: V3<f64>) -> M3<f64> {
    let e3 = e3.scale_f(1.0 / e3.norm());
    let trial = if e3.0[0].abs() < 0.9 {
        V3([1.0, 0.0, 0.0])
    } else {
        V3([0.0, 1.0, 0.0])
    };
    let e1 = trial - e3.scale_f(trial.dot(&e3));
    let e1 = e1.scale_f(1.0 / e1.norm());
    M3::from_cols(e1, e3.cross(&e1), e3)
}

impl System {
    pub fn compile(model: &Model) -> Result<System, ModelErrors> {
        let scheme = model.simulation.scheme;
        Self::compile_with(model, scheme)
    }

    pub fn compile_with(model: &Model, scheme: Scheme) -> Result<System, ModelErrors> {
        model.validate()?;
        let err = |path: String, msg: String| ModelErrors::one(ModelError::new(path, msg));

        // Nodes, then one internal node per body whose centre of mass is offset.
        let mut node_names: Vec<String> = Vec::new();
        let mut nodes: Vec<NodeState> = Vec::new();
        let mut velocity_given: Vec<bool> = Vec::new();
        for n in &model.nodes {
            let r = orientation(&n.orientation);
            node_names.push(n.name.clone());
            let v = V3(n.velocity.unwrap_or_default());
            let w = r.tmul_v(&V3(n.angular_velocity.unwrap_or_default()));
            nodes.push(NodeState {
                x: V3(n.position),
                r,
                v,
                w,
            });
            velocity_given.push(n.velocity.is_some() || n.angular_velocity.is_some());
        }
        // Beams: their nodes (shared end nodes are reused), lumped inertia, and elements.
        let mut lumped = beam_mesh::Lumped::default();
        for _ in 0..nodes.len() {
            lumped.push_node();
        }
        let mut beam_meshes: Vec<beam_mesh::BeamMesh> = Vec::new();
        // Each beam's own share of the lumped inertia (for its kinetic-energy sensor).
        let mut beam_inertia: Vec<Vec<BeamNodeInertia>> = Vec::new();
        for b in &model.beams {
            let before = lumped.clone();
            beam_meshes.push(beam_mesh::mesh(
                b,
                &mut node_names,
                &mut nodes,
                &mut velocity_given,
                &mut lumped,
            ));
            beam_inertia.push(
                (0..lumped.mass.len())
                    .filter_map(|a| {
                        let m = lumped.mass[a] - before.mass.get(a).copied().unwrap_or(0.0);
                        (m > 0.0).then(|| BeamNodeInertia {
                            node: a,
                            mass: m,
                            first_moment: lumped.first_moment[a]
                                - before.first_moment.get(a).copied().unwrap_or(V3::zero()),
                            inertia: lumped.inertia[a]
                                - before.inertia.get(a).copied().unwrap_or(M3::zero()),
                        })
                    })
                    .collect(),
            );
        }
        // Initial spins: the listed nodes and beams turn rigidly about their axis. Each node
        // keeps its spin: static solves (and the pre-load) add its steady-rotation inertia.
        let mut node_spin: Vec<Option<SteadySpin>> = vec![None; nodes.len()];
        for spin in &model.initial_spins {
            let axis = V3(spin.axis);
            let omega = axis.scale_f(spin.rate / axis.norm());
            let center = V3(spin.center);
            let mut targets: Vec<usize> = Vec::new();
            for item in &spin.items {
                match model.beams.iter().position(|b| &b.name == item) {
                    Some(bi) => targets.extend(&beam_meshes[bi].nodes),
                    None => targets.extend(node_names.iter().position(|n| n == item)),
                }
            }
            for a in targets {
                let n = &mut nodes[a];
                n.v = omega.cross(&(n.x - center));
                n.w = n.r.tmul_v(&omega);
                velocity_given[a] = true;
                node_spin[a] = Some(SteadySpin { omega, center });
            }
        }
        let beam_mesh::Lumped {
            mut mass,
            first_moment,
            mut inertia,
        } = lumped;
        let index: HashMap<String, usize> = node_names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), i))
            .collect();
        // (owner name, carrier node, cm node, offset) for masses whose centre is offset from
        // their node: they sit on an internal node clamped to the carrier.
        let mut cm_links: Vec<(String, usize, usize, V3<f64>)> = Vec::new();
        for b in &model.bodies {
            let a = index[&b.node];
            let c = V3(b.cm_offset);
            let j = M3(b.inertia.matrix());
            if c.max_abs() == 0.0 {
                mass[a] += b.mass;
                inertia[a] = inertia[a] + j;
            } else {
                let na = nodes[a];
                let arm = na.r.mul_v(&c);
                let cm = NodeState {
                    x: na.x + arm,
                    r: na.r,
                    v: na.v + na.omega().cross(&arm),
                    w: na.w,
                };
                node_names.push(format!("{}.cm", b.name));
                nodes.push(cm);
                velocity_given.push(velocity_given[a]);
                mass.push(b.mass);
                inertia.push(j);
                node_spin.push(node_spin[a]);
                cm_links.push((b.name.clone(), a, nodes.len() - 1, c));
            }
        }
        // Beam nodes whose sections' centres of mass are offset: all of the node's mass moves
        // to its combined centre of mass, with the inertia about it (parallel axes).
        let scale = length_scale(&nodes); // once: per node it made compiling quadratic
        for (a, s1) in first_moment.iter().enumerate() {
            let m = mass[a];
            if m <= 0.0 || s1.norm() <= 1e-12 * m * scale {
                continue;
            }
            let c = s1.scale_f(1.0 / m);
            let j_cm = inertia[a] - (M3::identity().scale_f(c.norm_sq()) - c.outer(&c)).scale_f(m);
            let na = nodes[a];
            let arm = na.r.mul_v(&c);
            let name = node_names[a].clone();
            node_names.push(format!("{name}.cm"));
            nodes.push(NodeState {
                x: na.x + arm,
                r: na.r,
                v: na.v + na.omega().cross(&arm),
                w: na.w,
            });
            velocity_given.push(velocity_given[a]);
            node_spin.push(node_spin[a]);
            mass.push(m);
            inertia.push(j_cm);
            mass[a] = 0.0;
            inertia[a] = M3::zero();
            cm_links.push((name, a, nodes.len() - 1, c));
        }

        let mut cm_node = vec![None; nodes.len()];
        for (_, a, cm, c) in &cm_links {
            cm_node[*a] = Some((*cm, *c));
        }

        // Count coordinates and rows to fix the layout.
        let mut n_coords = 0;
        let mut n_drives = 0;
        let mut n_rows = 6 * cm_links.len();
        for j in &model.joints {
            let coords = j.coordinates();
            n_coords += coords.len();
            n_drives += coords.iter().filter(|c| c.drive.is_some()).count();
            n_rows += law_rows(j);
        }
        // Drive rows come after all joint rows.
        let mut drive_row = n_rows;
        n_rows += n_drives;
        let layout = Layout::new(scheme, nodes.len(), n_coords, n_rows);

        // Beam elements, their history laid out one after the other.
        let mut history = Vec::new();
        let mut beams = Vec::new();
        let beam_info: Vec<BeamInfo> = model
            .beams
            .iter()
            .zip(&beam_meshes)
            .scan(0, |first, (b, meshed)| {
                let info = BeamInfo {
                    name: b.name.clone(),
                    first: *first,
                    count: meshed.elements.len(),
                    length: meshed.length,
                    spans: meshed.spans.clone(),
                    inertia: Vec::new(),
                    nodes: meshed.nodes.clone(),
                    order: meshed.elements[0].nodes.len() - 1,
                };
                *first += meshed.elements.len();
                Some(info)
            })
            .collect();
        let mut beam_info = beam_info;
        for (info, bi) in beam_info.iter_mut().zip(beam_inertia) {
            info.inertia = bi;
        }
        for m in beam_meshes.iter_mut().flat_map(|m| m.elements.drain(..)) {
            beams.push(BeamElement::new(
                m.name,
                m.nodes,
                m.points,
                history.len(),
                &layout,
            ));
            history.extend_from_slice(&m.history);
        }

        // A node with no mass that nothing refers to has an undetermined motion.
        for (i, n) in model.nodes.iter().enumerate() {
            let a = index[&n.name];
            let used = model.joints.iter().any(|j| {
                let (n1, n2) = j.nodes();
                n1 == n.name || n2 == n.name
            });
            if mass[a] == 0.0 && !used && !cm_links.iter().any(|l| l.1 == a) {
                return Err(err(
                    format!("nodes[{i}]"),
                    format!("node `{}` carries no body and no joint connects it, so its motion is undetermined; give it a body or remove it", n.name),
                ));
            }
        }
        let inertias: Vec<NodeInertia> = (0..nodes.len())
            .filter(|&a| mass[a] > 0.0 || inertia[a].max_abs() > 0.0)
            .map(|a| NodeInertia::new(a, mass[a], inertia[a], node_spin[a], &layout))
            .collect();

        let mut joints = Vec::new();
        let mut joint_info = Vec::new();
        let mut springs = Vec::new();
        let mut drives = Vec::new();
        let mut row_names = Vec::new();
        let mut coord_names = Vec::new();
        let mut coords0 = Vec::new();
        let mut row = 0;

        for (body, a, cm, c) in &cm_links {
            let at = [
                Attachment {
                    offset: *c,
                    triad: M3::identity(),
                },
                Attachment {
                    offset: V3::zero(),
                    triad: M3::identity(),
                },
            ];
            let law = JointLaw::Clamp(Clamp { at });
            let name = format!("{body}.cm_link");
            for k in 0..6 {
                row_names.push((name.clone(), k));
            }
            joints.push(Joint::Pair(JointKernel::new(
                name,
                law,
                [Side::Node(*a), Side::Node(*cm)],
                vec![],
                row,
                &layout,
            )));
            row += 6;
        }

        for (ji, j) in model.joints.iter().enumerate() {
            let path = format!("joints[{ji}]");
            if let Some(sl) = j.sliding() {
                let kind = match j {
                    model::Joint::SlidingScrew(_) => SlidingKind::Screw,
                    model::Joint::SlidingClamp(_) => SlidingKind::Clamp,
                    _ => SlidingKind::Point,
                };
                let beam_index = beam_info
                    .iter()
                    .position(|b| b.name == sl.beam)
                    .expect("validated");
                let info = &beam_info[beam_index];
                let beam_path = BeamPath::new(info.count, info.order);
                let map = ArcMap::new(&info.spans, info.length);
                let drive = sl
                    .drive
                    .as_ref()
                    .map(|d| TimeFunction::new(d).map_err(|e| err(format!("{path}.drive"), e)))
                    .transpose()?;
                // Where the contact point starts: the drive's η(0), the given η, or the beam
                // point closest to the follower.
                let follower_side = if sl.follower == GROUND {
                    Side::Ground {
                        x: V3::zero(),
                        r: M3::identity(),
                    }
                } else {
                    Side::Node(index[&sl.follower])
                };
                let fol_pose = match follower_side {
                    Side::Node(a) => (nodes[a].x, nodes[a].r),
                    Side::Ground { x, r } => (x, r),
                };
                let zeta0 = match (&drive, sl.eta) {
                    (Some(f), _) => map.zeta(f.value(0.0)),
                    (None, Some(eta)) => map.zeta(eta),
                    (None, None) => sliding::closest_point(&beam_path, info, &nodes, fol_pose.0),
                };
                let (point, _) = sliding::beam_point(&beam_path, info, &nodes, zeta0);
                let triad = sliding::follower_triad(kind, &beam_path, info, &nodes, zeta0);
                let at = [
                    Attachment {
                        offset: V3::zero(),
                        triad: M3::identity(),
                    },
                    sliding::follower_attachment(fol_pose, point, triad),
                ];
                let c = coord_names.len();
                coord_names.push(format!("{}.eta", sl.name));
                coords0.push(zeta0);
                let drive_index = drive.map(|f| {
                    row_names.push((format!("{}.drive_eta", sl.name), 0));
                    drives.push((c, drive_row, f, Some(map.clone())));
                    drive_row += 1;
                    drives.len() - 1
                });
                let spring = match &sl.spring {
                    Some(s) => {
                        let (law, damping) = sliding::spring_on_zeta(s, &map, info.length)
                            .map_err(|e| {
                                err(
                                    format!("{path}.spring"),
                                    format!("sliding joint `{}`: {e}", sl.name),
                                )
                            })?;
                        springs.push(CoordinateSpring::new(c, law, damping, &layout));
                        Some(springs.len() - 1)
                    }
                    None => None,
                };
                if let Some(stops) = &sl.end_stops {
                    let law = sliding::end_stops_on_zeta(stops.stiffness, info);
                    springs.push(CoordinateSpring::new(c, law, 0.0, &layout));
                }
                let law = ContactLaw { kind, at };
                let nr = law.n_rows();
                for k in 0..nr {
                    row_names.push((sl.name.clone(), k));
                }
                joint_info.push(JointInfo {
                    name: sl.name.clone(),
                    kernel: joints.len(),
                    coords: vec![JointCoordinate {
                        name: "eta",
                        coord: c,
                        drive: drive_index,
                        spring,
                    }],
                });
                let mut kernel = SlidingJoint::new(
                    sl.name.clone(),
                    law,
                    beam_path,
                    info.nodes.clone(),
                    follower_side,
                    c,
                    row,
                    &layout,
                    zeta0,
                );
                kernel.beam = beam_index;
                kernel.arc = map;
                kernel.end_stops = sl.end_stops.is_some();
                joints.push(Joint::Sliding(kernel));
                row += nr;
                continue;
            }
            let (n1, n2) = j.nodes();
            let side_of = |n: &str| {
                if n == GROUND {
                    Side::Ground {
                        x: V3::zero(),
                        r: M3::identity(),
                    }
                } else {
                    Side::Node(index[n])
                }
            };
            let sides = [side_of(n1), side_of(n2)];
            let pose = |s: &Side| match s {
                Side::Node(a) => (nodes[*a].x, nodes[*a].r),
                Side::Ground { x, r } => (*x, *r),
            };
            // Geometry given in a node's triad is brought to the inertial frame.
            let (fx, fr) = match j.frame() {
                model::JointFrame::Inertial => (V3::zero(), M3::identity()),
                model::JointFrame::Node1 => pose(&sides[0]),
                model::JointFrame::Node2 => pose(&sides[1]),
            };
            let at_point = |p: [f64; 3]| fx + fr.mul_v(&V3(p));
            let along = |a: [f64; 3]| fr.mul_v(&V3(a));
            let default_pos = match sides[1] {
                Side::Node(a) => nodes[a].x,
                Side::Ground { .. } => match sides[0] {
                    Side::Node(a) => nodes[a].x,
                    Side::Ground { .. } => V3::zero(),
                },
            };
            // Attachment of a global point/triad to a side, in that side's triad.
            let attach = |s: &Side, p: V3<f64>, q: M3<f64>| {
                let (x, r) = pose(s);
                Attachment {
                    offset: r.tmul_v(&(p - x)),
                    triad: r.transpose().mul_m(&q),
                }
            };
            // Relative coordinates: zero in the initial configuration unless a drive prescribes
            // a value at t = 0; then the initial configuration is taken to be at that value
            // (side l's attachment is moved back by it).
            let mut coords = vec![];
            let mut info_coords = vec![];
            let mut initial = [0.0f64; 2];
            for (k, co) in j.coordinates().iter().enumerate() {
                let field = format!("{path}.{}", co.drive_field);
                let drive = co
                    .drive
                    .map(|d| TimeFunction::new(d).map_err(|e| err(field.clone(), e)))
                    .transpose()?;
                if let Some(f) = &drive {
                    initial[k] = f.value(0.0);
                }
                let c = coord_names.len();
                coord_names.push(format!("{}.{}", j.name(), co.name));
                coords.push(c);
                if let Some(f) = drive {
                    row_names.push((format!("{}.drive_{}", j.name(), co.name), 0));
                    drives.push((c, drive_row, f, None));
                    drive_row += 1;
                }
                let spring = co.spring.map(|s| {
                    springs.push(CoordinateSpring::new(c, spring_law(s), s.damping, &layout));
                    springs.len() - 1
                });
                info_coords.push(JointCoordinate {
                    name: co.name,
                    coord: c,
                    drive: co.drive.map(|_| drives.len() - 1),
                    spring,
                });
            }
            // A screw's thread ties the two: the one prescribed sets the other.
            if let model::Joint::Screw(sc) = j {
                if sc.drive_phi.is_some() {
                    initial[0] = sc.pitch * initial[1];
                } else {
                    initial[1] = initial[0] / sc.pitch;
                }
            }
            // Side l's attachment at Δ₀ along and φ₀ about the axis.
            let slid = |axis: V3<f64>, p: V3<f64>, q: M3<f64>, delta0: f64, phi0: f64| {
                let a = axis.scale_f(1.0 / axis.norm());
                (p + a.scale_f(delta0), exp_map(&a.scale_f(phi0)).mul_m(&q))
            };
            let law = match j {
                model::Joint::Spherical(s) => {
                    let p = s.position.map(at_point).unwrap_or(default_pos);
                    JointLaw::Spherical(Spherical {
                        at: [
                            attach(&sides[0], p, M3::identity()),
                            attach(&sides[1], p, M3::identity()),
                        ],
                    })
                }
                model::Joint::Universal(u) => {
                    if let Some(k) = initial.iter().position(|v| *v != 0.0) {
                        return Err(err(
                            format!("{path}.drive{}", k + 1),
                            format!("joint `{}`: a universal joint's drive must start at 0 (it gives {:.6} rad at t = 0); offset the function or turn the model to that angle", u.name, initial[k]),
                        ));
                    }
                    let p = u.position.map(at_point).unwrap_or(default_pos);
                    let (a1, a2) = (along(u.axis1), along(u.axis2));
                    // e₁ᵏ = axis2 and e₁ˡ = axis1, so that φ1 = φ2 = 0 initially.
                    let triad = |e3: V3<f64>, e1: V3<f64>| {
                        let e3 = e3.scale_f(1.0 / e3.norm());
                        let e1 = e1 - e3.scale_f(e1.dot(&e3));
                        let e1 = e1.scale_f(1.0 / e1.norm());
                        M3::from_cols(e1, e3.cross(&e1), e3)
                    };
                    JointLaw::Universal(Universal {
                        at: [
                            attach(&sides[0], p, triad(a1, a2)),
                            attach(&sides[1], p, triad(a2, a1)),
                        ],
                    })
                }
                model::Joint::Clamp(_) => {
                    let p = default_pos;
                    JointLaw::Clamp(Clamp {
                        at: [
                            attach(&sides[0], p, M3::identity()),
                            attach(&sides[1], p, M3::identity()),
                        ],
                    })
                }
                model::Joint::Revolute(r) => {
                    let p = r.position.map(at_point).unwrap_or(default_pos);
                    let q = triad_from_axis(along(r.axis));
                    let (pl, ql) = slid(along(r.axis), p, q, 0.0, initial[0]);
                    JointLaw::Revolute(Revolute {
                        at: [attach(&sides[0], p, q), attach(&sides[1], pl, ql)],
                    })
                }
                model::Joint::Prismatic(r) => {
                    let p = r.position.map(at_point).unwrap_or(default_pos);
                    let q = triad_from_axis(along(r.axis));
                    let (pl, ql) = slid(along(r.axis), p, q, -initial[0], 0.0);
                    JointLaw::Prismatic(Prismatic {
                        at: [attach(&sides[0], p, q), attach(&sides[1], pl, ql)],
                    })
                }
                model::Joint::Cylindrical(r) => {
                    let p = r.position.map(at_point).unwrap_or(default_pos);
                    let q = triad_from_axis(along(r.axis));
                    let (pl, ql) = slid(along(r.axis), p, q, -initial[0], initial[1]);
                    JointLaw::Cylindrical(Cylindrical {
                        at: [attach(&sides[0], p, q), attach(&sides[1], pl, ql)],
                    })
                }
                model::Joint::Screw(r) => {
                    let p = r.position.map(at_point).unwrap_or(default_pos);
                    let q = triad_from_axis(along(r.axis));
                    let (pl, ql) = slid(along(r.axis), p, q, -initial[0], initial[1]);
                    JointLaw::Screw(Screw {
                        cylinder: Cylindrical {
                            at: [attach(&sides[0], p, q), attach(&sides[1], pl, ql)],
                        },
                        pitch: r.pitch,
                    })
                }
                model::Joint::Sliding(_)
                | model::Joint::SlidingScrew(_)
                | model::Joint::SlidingClamp(_) => unreachable!("compiled above"),
            };
            coords0.extend_from_slice(&initial[..coords.len()]);
            let nr = law.n_rows();
            for k in 0..nr {
                row_names.push((j.name().to_string(), k));
            }
            joint_info.push(JointInfo {
                name: j.name().to_string(),
                kernel: joints.len(),
                coords: info_coords,
            });
            joints.push(Joint::Pair(JointKernel::new(
                j.name().to_string(),
                law,
                sides,
                coords,
                row,
                &layout,
            )));
            row += nr;
        }
        // Drive rows come after all joint rows; give names in row order.
        let (drive_names, mut names_sorted): (Vec<_>, Vec<_>) = row_names
            .into_iter()
            .partition(|(n, _): &(String, usize)| n.contains(".drive_"));
        names_sorted.extend(drive_names);
        debug_assert_eq!(names_sorted.len(), n_rows);
        let drive_kernels: Vec<CoordinateDrive> = drives
            .into_iter()
            .map(|(c, drow, f, map)| {
                let mut d = CoordinateDrive::new(c, drow, f, &layout);
                d.map = map;
                d
            })
            .collect();

        // Loads; a distributed load becomes one point load per node of its beam.
        let mut loads = Vec::new();
        let mut line_loads = Vec::new();
        let mut load_scales = Vec::new();
        for (i, l) in model.loads.iter().enumerate() {
            let scale = l
                .scale()
                .map(TimeFunction::new)
                .transpose()
                .map_err(|e| err(format!("loads[{i}].scale"), e))?;
            if let Some(f) = &scale {
                load_scales.push((l.name().to_string(), f.clone()));
            }
            let kind = if l.is_moment() {
                LoadKind::Moment
            } else {
                LoadKind::Force
            };
            let value = V3(*l.value());
            match l {
                model::Load::Force(p) | model::Load::Moment(p) => loads.push(PointLoad::new(
                    index[&p.node],
                    kind,
                    value,
                    p.follower,
                    scale,
                    &layout,
                )),
                model::Load::DistributedForce(d) | model::Load::DistributedMoment(d)
                    if d.follower =>
                {
                    let info = beam_info
                        .iter()
                        .find(|b| b.name == d.beam)
                        .expect("validated");
                    for e in info.first..info.first + info.count {
                        line_loads.push(FollowerLineLoad {
                            name: d.name.clone(),
                            element: beams[e].clone(),
                            kind,
                            value,
                            scale: scale.clone(),
                        });
                    }
                }
                model::Load::DistributedForce(d) | model::Load::DistributedMoment(d) => {
                    let bi = model
                        .beams
                        .iter()
                        .position(|b| b.name == d.beam)
                        .expect("validated");
                    let m = &beam_meshes[bi];
                    for (k, &node) in m.nodes.iter().enumerate() {
                        let v = value;
                        loads.push(PointLoad::new(
                            node,
                            kind,
                            v.scale_f(m.load_weights[k]),
                            false,
                            scale.clone(),
                            &layout,
                        ));
                    }
                }
            }
        }

        let masses: Vec<f64> = mass.iter().copied().filter(|m| *m > 0.0).collect();
        let mass_ref = if masses.is_empty() {
            1.0
        } else {
            masses.iter().sum::<f64>() / masses.len() as f64
        };
        let length_ref = nodes.iter().map(|n| n.x.max_abs()).fold(1.0f64, f64::max);
        let force_ref = 1e-8
            * beams
                .iter()
                .flat_map(|b| b.points.iter())
                .map(|p| {
                    p.stiffness[0][0]
                        .max(p.stiffness[1][1])
                        .max(p.stiffness[2][2])
                })
                .fold(0.0f64, f64::max);
        let force_roundoff = springs.iter().fold(1e-6 * force_ref, |m, sp| {
            let reach = coords0[sp.coord]
                .abs()
                .max(sp.law.reference_magnitude())
                .max(1.0);
            m.max(1e-14 * sp.law.stiffness_scale() * reach)
        });
        let n_c = coords0.len();
        let initial = State {
            t: 0.0,
            nodes,
            coords: coords0,
            coord_rates: vec![0.0; n_c],
            lambda: vec![0.0; n_rows],
            history,
        };
        Ok(System {
            name: model.name.clone(),
            layout,
            node_names,
            coord_names,
            row_names: names_sorted,
            inertias,
            beams,
            beam_info,
            joints,
            joint_info,
            springs,
            drives: drive_kernels,
            loads,
            line_loads,
            gravity: V3(model.gravity),
            initial,
            mass_ref,
            length_ref,
            force_ref,
            force_roundoff,
            velocity_given,
            node_spin,
            load_scales,
            cm_node,
        })
    }

    pub fn node_index(&self, name: &str) -> Option<usize> {
        self.node_names.iter().position(|n| n == name)
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

    /// The energy that measures a motion's size: kinetic, strain and spring energy (gravity's
    /// potential is left out: its datum is arbitrary).
    pub fn motion_energy(&self, s: &State) -> f64 {
        let springs: f64 = self
            .springs
            .iter()
            .map(|sp| sp.law.energy(s.coords[sp.coord]))
            .sum();
        let strain: f64 = self.beams.iter().map(|b| b.strain_energy(s)).sum();
        self.kinetic_energy(s) + springs + strain
    }

    /// Potential energy of gravity and springs.
    pub fn potential_energy(&self, s: &State) -> f64 {
        let grav: f64 = self
            .inertias
            .iter()
            .map(|k| -k.mass * self.gravity.dot(&s.nodes[k.node].x))
            .sum();
        let spr: f64 = self
            .springs
            .iter()
            .map(|sp| sp.law.energy(s.coords[sp.coord]))
            .sum();
        let strain: f64 = self.beams.iter().map(|b| b.strain_energy(s)).sum();
        grav + spr + strain
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
