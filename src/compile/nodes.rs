//! Nodes: their checks, and the table of all nodes (the model's, the beams', internal
//! centre-of-mass ones) with their initial states and lumped inertia.

use super::bodies::CmLink;
use crate::elements::inertia::SteadySpin;
use crate::math::rotation::{check_rotation, exp_map, orthonormalize};
use crate::math::vec3::{M3, V3};
use crate::model::check::Checker;
use crate::model::{Model, ModelError, Orientation};
use crate::state::NodeState;
use crate::system::VelocityGiven;
use std::collections::HashMap;

/// Checks each node's position, velocities and orientation.
pub fn check(model: &Model, c: &mut Checker) {
    for (i, n) in model.nodes.iter().enumerate() {
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
            if let Err(e) = check_rotation(&M3(*m), 1e-9) {
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
}

/// Lumped inertia per node, about the node and in its triad: mass, first moment of mass
/// `Σ m c` (non-zero when sections have an offset centre of mass) and inertia tensor.
#[derive(Clone, Debug, Default)]
pub struct Lumped {
    pub mass: Vec<f64>,
    pub first_moment: Vec<V3<f64>>,
    pub inertia: Vec<M3<f64>>,
}

/// Every node of the system, in numbering order, with what compiling needs of it.
#[derive(Default)]
pub struct NodeTable {
    pub names: Vec<String>,
    pub states: Vec<NodeState>,
    /// Which of the node's initial velocities the model gave (the rest zero, to be completed).
    pub velocity_given: Vec<VelocityGiven>,
    /// The steady spin the node was given, if any.
    pub spin: Vec<Option<SteadySpin>>,
    pub lumped: Lumped,
    /// Other names of nodes (`<beam>.start`, `<beam>.end`) and the nodes they name.
    pub aliases: Vec<(String, usize)>,
    index: HashMap<String, usize>,
}

impl NodeTable {
    /// The model's own nodes, numbered first.
    pub fn of(model: &Model) -> NodeTable {
        let mut table = NodeTable::default();
        for n in &model.nodes {
            let r = orientation(&n.orientation);
            let state = NodeState {
                x: V3(n.position),
                r,
                v: V3(n.velocity.unwrap_or_default()),
                w: r.tmul_v(&V3(n.angular_velocity.unwrap_or_default())),
            };
            let given = VelocityGiven {
                translation: n.velocity.is_some(),
                rotation: n.angular_velocity.is_some(),
            };
            table.push(n.name.clone(), state, given);
        }
        table
    }

    /// Adds a node with no inertia and no spin; returns its index.
    pub fn push(&mut self, name: String, state: NodeState, velocity_given: VelocityGiven) -> usize {
        let a = self.states.len();
        self.index.insert(name.clone(), a);
        self.names.push(name);
        self.states.push(state);
        self.velocity_given.push(velocity_given);
        self.spin.push(None);
        self.lumped.mass.push(0.0);
        self.lumped.first_moment.push(V3::zero());
        self.lumped.inertia.push(M3::zero());
        a
    }

    /// Adds a node rigidly carried by node `a` at `offset` (a's triad), moving with it.
    pub fn push_carried(&mut self, name: String, a: usize, offset: V3<f64>) -> usize {
        let na = self.states[a];
        let arm = na.r.mul_v(&offset);
        let state = NodeState {
            x: na.x + arm,
            r: na.r,
            v: na.v + na.omega().cross(&arm),
            w: na.w,
        };
        let cm = self.push(name, state, self.velocity_given[a]);
        self.spin[cm] = self.spin[a];
        cm
    }

    /// Makes `alias` another name of node `target` (a beam's `<beam>.start` / `.end`).
    pub fn alias(&mut self, alias: String, target: &str) {
        let a = self.index(target);
        self.index.insert(alias.clone(), a);
        self.aliases.push((alias, a));
    }

    /// Index of a named node (validated names always have one).
    pub fn index(&self, name: &str) -> usize {
        self.index[name]
    }

    /// Size of the configuration, for relative tolerances: the largest node coordinate (m),
    /// what positions are known to ε of. Not floored at 1 m: a 200 µm cantilever judged as
    /// 1 m read its positions' round-off as 5000× its own and its step sizes oscillated. 1 m
    /// only where every node is at the origin.
    pub fn length_scale(&self) -> f64 {
        let largest = self
            .states
            .iter()
            .map(|n| n.x.max_abs())
            .fold(0.0f64, f64::max);
        if largest > 0.0 {
            largest
        } else {
            1.0
        }
    }
}

fn orientation(o: &Orientation) -> M3<f64> {
    if let Some(m) = o.matrix {
        orthonormalize(&M3(m))
    } else if let Some(v) = o.rotation_vector {
        exp_map(&V3(v))
    } else {
        M3::identity()
    }
}

/// A node with no mass that nothing refers to has an undetermined motion.
pub fn check_determined(
    model: &Model,
    table: &NodeTable,
    links: &[CmLink],
) -> Result<(), ModelError> {
    for (i, n) in model.nodes.iter().enumerate() {
        let a = table.index(&n.name);
        let used = model.joints.iter().any(|j| {
            let (n1, n2) = j.nodes();
            n1 == n.name || n2 == n.name
        });
        if table.lumped.mass[a] == 0.0 && !used && !links.iter().any(|l| l.node == a) {
            return Err(ModelError::new(
                format!("nodes[{i}]"),
                format!("node `{}` carries no body and no joint connects it, so its motion is undetermined; give it a body or remove it", n.name),
            ));
        }
    }
    Ok(())
}
