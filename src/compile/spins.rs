//! Initial spins: the listed nodes and beams turn rigidly about an axis at t = 0. Each node
//! keeps its spin: static solves (and the pre-load) add its steady-rotation inertia.

use super::nodes::NodeTable;
use crate::elements::inertia::SteadySpin;
use crate::math::vec3::V3;
use crate::model::check::{Checker, NodeNames};
use crate::model::Model;
use crate::system::VelocityGiven;

/// Checks each spin's axis, centre, rate and items.
pub fn check(model: &Model, names: &NodeNames, c: &mut Checker) {
    for (i, spin) in model.initial_spins.iter().enumerate() {
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
                n.parse::<usize>().is_ok() && model.beams.iter().any(|x| x.name == b)
            });
            if !names.contains(item) && !model.beams.iter().any(|b| &b.name == item) && !beam_node {
                c.err(
                    format!("{p}.items[{k}]"),
                    format!("`{item}` is neither a node nor a beam of the model"),
                );
            }
        }
    }
}

/// Sets the spinning nodes' velocities; `beam_nodes[i]` are the nodes of beam `i`.
pub fn apply(model: &Model, beam_nodes: &[&[usize]], table: &mut NodeTable) {
    for spin in &model.initial_spins {
        let axis = V3(spin.axis);
        let omega = axis.scale_f(spin.rate / axis.norm());
        let center = V3(spin.center);
        let mut targets: Vec<usize> = Vec::new();
        for item in &spin.items {
            match model.beams.iter().position(|b| &b.name == item) {
                Some(bi) => targets.extend(beam_nodes[bi]),
                None => targets.push(table.index(item)),
            }
        }
        for a in targets {
            let n = &mut table.states[a];
            n.v = omega.cross(&(n.x - center));
            n.w = n.r.tmul_v(&omega);
            table.velocity_given[a] = VelocityGiven::BOTH;
            table.spin[a] = Some(SteadySpin { omega, center });
        }
    }
}
