//! Loads: their checks, and their compilation into point loads (a dead distributed load is
//! lumped consistently onto its beam's nodes) and follower line loads (one per element).

use super::beams::Meshed;
use super::nodes::NodeTable;
use crate::beam::element::BeamElement;
use crate::beam::line_load::FollowerLineLoad;
use crate::elements::loads::{LoadKind, PointLoad};
use crate::math::layout::Layout;
use crate::math::time_function::TimeFunction;
use crate::math::vec3::V3;
use crate::model::check::{Checker, NodeNames};
use crate::model::{Load, Model, ModelError};
use crate::system::BeamInfo;

/// Checks each load's node or beam, value and scale.
pub fn check(model: &Model, names: &NodeNames, c: &mut Checker) {
    for (i, l) in model.loads.iter().enumerate() {
        let p = format!("loads[{i}]");
        match l {
            Load::Force(s) | Load::Moment(s) => names.check(c, format!("{p}.node"), &s.node, false),
            Load::DistributedForce(s) | Load::DistributedMoment(s) => {
                if !model.beams.iter().any(|b| b.name == s.beam) {
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
}

/// The compiled loads.
#[derive(Default)]
pub struct Loads {
    pub points: Vec<PointLoad>,
    pub lines: Vec<FollowerLineLoad>,
    /// Each load's scale function, with the load's name (for diagnostics).
    pub scales: Vec<(String, TimeFunction)>,
}

/// Where loads land: node indices, the beams' meshes and elements.
pub struct Targets<'a> {
    pub nodes: &'a NodeTable,
    pub meshed: &'a [Meshed],
    pub beam_info: &'a [BeamInfo],
    pub elements: &'a [BeamElement],
}

/// Compiles every load.
pub fn compile(model: &Model, to: &Targets, layout: &Layout) -> Result<Loads, ModelError> {
    let mut out = Loads::default();
    for (i, l) in model.loads.iter().enumerate() {
        let scale = l
            .scale()
            .map(TimeFunction::new)
            .transpose()
            .map_err(|e| ModelError::new(format!("loads[{i}].scale"), e))?;
        if let Some(f) = &scale {
            out.scales.push((l.name().to_string(), f.clone()));
        }
        let kind = if l.is_moment() {
            LoadKind::Moment
        } else {
            LoadKind::Force
        };
        let value = V3(*l.value());
        match l {
            Load::Force(p) | Load::Moment(p) => out.points.push(PointLoad::new(
                to.nodes.index(&p.node),
                kind,
                value,
                p.follower,
                scale,
                layout,
            )),
            Load::DistributedForce(d) | Load::DistributedMoment(d) => {
                let beam = model.beams.iter().position(|b| b.name == d.beam);
                let beam = beam.expect("validated");
                if d.follower {
                    let info = &to.beam_info[beam];
                    out.lines
                        .extend(
                            (info.first..info.first + info.count).map(|e| FollowerLineLoad {
                                name: d.name.clone(),
                                element: to.elements[e].clone(),
                                kind,
                                value,
                                scale: scale.clone(),
                            }),
                        );
                } else {
                    let m = &to.meshed[beam].mesh;
                    for (k, &node) in m.nodes.iter().enumerate() {
                        let v = value.scale_f(m.load_weights[k]);
                        let load = PointLoad::new(node, kind, v, false, scale.clone(), layout);
                        out.points.push(load);
                    }
                }
            }
        }
    }
    Ok(out)
}
