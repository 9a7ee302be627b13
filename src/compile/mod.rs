//! From the model file to the system: every item kind has a room here that owns its checks
//! and its compilation into nodes, kernels and constraint rows —
//! [`nodes`], [`bodies`], [`beams`], [`spins`], [`joints`] (one file per joint kind),
//! [`sliding`], [`loads`], [`sensors`] — and [`validate`] and [`compile`] only call them in
//! order. Layering: the file format ([`crate::model`], plain data) → this compiler → the
//! kernels (beams, joints, elements) → math.

pub mod beams;
pub mod bodies;
pub mod friction;
pub mod joints;
pub mod loads;
pub mod names;
pub mod nodes;
pub mod rows;
pub mod sensors;
pub mod settings;
pub mod sliding;
pub mod spins;

use crate::beam::element::BeamElement;
use crate::elements::coordinate::CoordinateSpring;
use crate::elements::inertia::NodeInertia;
use crate::joints::clamp::Clamp;
use crate::joints::{Attachment, Joint, JointKernel, JointLaw, Side};
use crate::math::layout::{Layout, Scheme};
use crate::math::vec3::{M3, V3};
use crate::model::check::{Checker, NodeNames};
use crate::model::{Model, ModelError, ModelErrors};
use crate::state::{NodeState, State};
use crate::system::System;
use bodies::CmLink;
use nodes::NodeTable;
use rows::RowTable;

/// Parses and checks a YAML model.
pub fn from_yaml_str(text: &str) -> Result<Model, ModelErrors> {
    let model = crate::model::parse_yaml(text)?;
    validate(&model)?;
    Ok(model)
}

/// Parses and checks a JSON model (what the Python builder sends).
pub fn from_json_str(text: &str) -> Result<Model, ModelErrors> {
    let model = crate::model::parse_json(text)?;
    validate(&model)?;
    Ok(model)
}

/// Checks references, physical admissibility and settings; returns every problem found (with
/// the paths the user wrote, for items a pattern copied).
pub fn validate(model: &Model) -> Result<(), ModelErrors> {
    let flat = model.flattened()?;
    validate_flat(&flat).map_err(|e| e.located(&flat))
}

/// [`validate`] on a flattened model.
fn validate_flat(model: &Model) -> Result<(), ModelErrors> {
    let mut c = Checker::default();
    // Size first: a model over the limits is refused before its mesh is even named.
    settings::check_size(model, &mut c);
    if !c.errors.is_empty() {
        return c.finish();
    }
    c.vec3("gravity".into(), &model.gravity);
    names::check(model, &mut c);
    let node_names = NodeNames::of(model);
    nodes::check(model, &mut c);
    beams::check(model, &mut c);
    bodies::check(model, &node_names, &mut c);
    joints::check(model, &node_names, &mut c);
    loads::check(model, &node_names, &mut c);
    sensors::check(model, &node_names, &mut c);
    spins::check(model, &node_names, &mut c);
    settings::check(model, &mut c);
    c.finish()
}

/// Compiles a model with the scheme its settings name.
pub fn system(model: &Model) -> Result<System, ModelErrors> {
    compile(model, model.simulation.scheme)
}

/// Checks `model` and compiles it for `scheme`: nodes (the model's, the beams', internal
/// centre-of-mass ones), then coordinates and rows, then the kernels on the layout.
pub fn compile(model: &Model, scheme: Scheme) -> Result<System, ModelErrors> {
    let flat = model.flattened()?;
    let model = &flat;
    validate_flat(model).map_err(|e| e.located(model))?;
    let one = |e: ModelError| ModelErrors::one(e).located(model);
    let placed = place(model).map_err(one)?;
    let rows = number_rows(model, &placed).map_err(one)?;
    assemble(model, scheme, placed, rows).map_err(one)
}

/// Every node with its initial state and inertia, and the beams meshed on them.
struct Placed {
    table: NodeTable,
    meshed: Vec<beams::Meshed>,
    links: Vec<CmLink>,
    beam_info: Vec<crate::system::BeamInfo>,
}

fn place(model: &Model) -> Result<Placed, ModelError> {
    let mut table = NodeTable::of(model);
    let meshed = beams::mesh_all(model, &mut table);
    let beam_nodes: Vec<&[usize]> = meshed.iter().map(|m| m.mesh.nodes.as_slice()).collect();
    spins::apply(model, &beam_nodes, &mut table);
    let mut links = bodies::add(model, &mut table);
    bodies::centre_offset_masses(&mut table, &mut links);
    nodes::check_determined(model, &table, &links)?;
    let beam_info = beams::info(model, &meshed);
    Ok(Placed {
        table,
        meshed,
        links,
        beam_info,
    })
}

/// The centre-of-mass links, then the joints in file order.
fn number_rows(model: &Model, placed: &Placed) -> Result<RowTable, ModelError> {
    let mut rows = RowTable::default();
    for link in &placed.links {
        cm_link(link, &mut rows);
    }
    for (i, j) in model.joints.iter().enumerate() {
        let path = format!("joints[{i}]");
        match j.sliding() {
            Some(_) => sliding::compile(j, &path, &placed.table, &placed.beam_info, &mut rows)?,
            None => joints::compile(j, &path, &placed.table, &mut rows)?,
        }
    }
    Ok(rows)
}

/// The kernels on the layout the counts fix, and the system around them.
fn assemble(
    model: &Model,
    scheme: Scheme,
    mut placed: Placed,
    mut rows: RowTable,
) -> Result<System, ModelError> {
    let table = &placed.table;
    let layout = Layout::new(
        scheme,
        table.states.len(),
        rows.coords0.len(),
        rows.n_rows(),
    );
    let (beams, mut history) = beams::elements(&mut placed.meshed, &layout);
    let targets = loads::Targets {
        nodes: table,
        meshed: &placed.meshed,
        beam_info: &placed.beam_info,
        elements: &beams,
    };
    let loads = loads::compile(model, &targets, &layout)?;
    let mut kernels = rows.build(&layout, &mut history);
    let scales = Scales::of(table, &beams, &kernels.springs, &rows.coords0);
    for f in &mut kernels.frictions {
        // A billionth of the weight of the mean node: below it a force is nothing.
        f.force_floor = 1e-9 * scales.mass * 9.81;
        // Rest: a slip of round-off of the model's size, a rate of 1e-9 of it per second.
        f.rest_slip = 1e-13 * scales.length;
        f.rest_rate = 1e-9 * scales.length;
    }
    let mut cm_node = vec![None; table.states.len()];
    for l in &placed.links {
        cm_node[l.node] = Some((l.cm, l.offset));
    }
    Ok(System {
        name: model.name.clone(),
        inertias: inertias(table, &layout),
        initial: initial_state(
            table.states.clone(),
            rows.coords0.clone(),
            layout.n_rows,
            history,
        ),
        layout,
        node_names: placed.table.names,
        node_aliases: placed.table.aliases,
        coord_names: rows.coord_names,
        row_names: kernels.row_names,
        beams,
        beam_info: placed.beam_info,
        joints: kernels.joints,
        joint_info: rows.joint_info,
        springs: kernels.springs,
        drives: kernels.drives,
        frictions: kernels.frictions,
        loads: loads.points,
        line_loads: loads.lines,
        gravity: V3(model.gravity),
        mass_ref: scales.mass,
        length_ref: scales.length,
        force_ref: scales.force,
        force_roundoff: scales.force_roundoff,
        velocity_given: placed.table.velocity_given,
        node_spin: placed.table.spin,
        load_scales: loads.scales,
        cm_node,
    })
}

/// The initial state: the nodes' and coordinates' values at t = 0, coordinate rates and
/// multipliers zero.
fn initial_state(
    nodes: Vec<NodeState>,
    coords: Vec<f64>,
    n_rows: usize,
    history: Vec<f64>,
) -> State {
    State {
        t: 0.0,
        nodes,
        coord_rates: vec![0.0; coords.len()],
        coords,
        lambda: vec![0.0; n_rows],
        history,
    }
}

/// The system's reference sizes, for scalings and tolerances.
struct Scales {
    /// Mean nodal mass, for the multiplier scaling `s = m_ref/h²`.
    mass: f64,
    /// Extent of the initial configuration.
    length: f64,
    /// Force of a 1e-8 strain of the stiffest section.
    force: f64,
    /// Round-off of the largest elastic force a kernel computes.
    force_roundoff: f64,
}

impl Scales {
    fn of(
        table: &NodeTable,
        beams: &[BeamElement],
        springs: &[CoordinateSpring],
        coords0: &[f64],
    ) -> Scales {
        let masses: Vec<f64> = table
            .lumped
            .mass
            .iter()
            .copied()
            .filter(|m| *m > 0.0)
            .collect();
        let mass = if masses.is_empty() {
            1.0
        } else {
            masses.iter().sum::<f64>() / masses.len() as f64
        };
        let force = 1e-8
            * beams
                .iter()
                .flat_map(|b| b.points.iter())
                .map(|p| {
                    p.stiffness[0][0]
                        .max(p.stiffness[1][1])
                        .max(p.stiffness[2][2])
                })
                .fold(0.0f64, f64::max);
        let force_roundoff = springs.iter().fold(1e-6 * force, |m, sp| {
            let reach = coords0[sp.coord]
                .abs()
                .max(sp.law.reference_magnitude())
                .max(1.0);
            m.max(1e-14 * sp.law.stiffness_scale() * reach)
        });
        Scales {
            mass,
            length: table.length_scale(),
            force,
            force_roundoff,
        }
    }
}

/// The clamp that carries an internal centre-of-mass node.
fn cm_link(link: &CmLink, rows: &mut RowTable) {
    let at = |offset| Attachment {
        offset,
        triad: M3::identity(),
    };
    let law = JointLaw::Clamp(Clamp {
        at: [at(link.offset), at(V3::zero())],
    });
    let sides = [Side::Node(link.node), Side::Node(link.cm)];
    let name = format!("{}.cm_link", link.owner);
    let kernel_name = name.clone();
    rows.joint(
        name,
        6,
        Box::new(move |row, layout| {
            Joint::Pair(JointKernel::new(
                kernel_name,
                law,
                sides,
                vec![],
                row,
                layout,
            ))
        }),
    );
}

/// An inertia kernel per node that carries mass or rotary inertia.
fn inertias(table: &NodeTable, layout: &Layout) -> Vec<NodeInertia> {
    let l = &table.lumped;
    (0..table.states.len())
        .filter(|&a| l.mass[a] > 0.0 || l.inertia[a].max_abs() > 0.0)
        .map(|a| NodeInertia::new(a, l.mass[a], l.inertia[a], table.spin[a], layout))
        .collect()
}
