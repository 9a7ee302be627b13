//! Sensors' checks: each sensor's node, joint or beam exists and its station or coordinate
//! makes sense. (Their channels are compiled at run time, in [`crate::sensors`].)

use crate::model::check::{Checker, NodeNames};
use crate::model::{driven_coordinate, Joint, Model, Sensor};
use std::collections::HashMap;

/// Checks each sensor's references.
pub fn check(model: &Model, names: &NodeNames, c: &mut Checker) {
    let joints: HashMap<&str, &Joint> = model.joints.iter().map(|j| (j.name(), j)).collect();
    for (i, s) in model.sensors.iter().enumerate() {
        let p = format!("sensors[{i}]");
        match s {
            Sensor::NodePosition { node, .. }
            | Sensor::NodeDisplacement { node, .. }
            | Sensor::NodeRotation { node, .. }
            | Sensor::NodeVelocity { node, .. } => names.check(c, format!("{p}.node"), node, false),
            Sensor::RelativePosition {
                node, reference, ..
            } => {
                names.check(c, format!("{p}.node"), node, false);
                names.check(c, format!("{p}.reference"), reference, false);
            }
            Sensor::JointCoordinate { joint, .. }
            | Sensor::JointReaction { joint, .. }
            | Sensor::DriveForce { joint, .. }
            | Sensor::Friction { joint, .. } => match joints.get(joint.as_str()) {
                None => c.err(
                    format!("{p}.joint"),
                    format!("refers to joint `{joint}`, which is not defined in `joints`"),
                ),
                Some(j) => check_joint_sensor(s, j, c, &p),
            },
            Sensor::Energy { .. } | Sensor::Momentum { .. } => {}
            Sensor::BeamEnergy { beam, .. } => check_beam(model, beam, c, &p),
            Sensor::BeamSection { beam, eta, s, .. } => {
                check_beam(model, beam, c, &p);
                check_station(model, beam, (*eta, *s), c, &p);
            }
        }
    }
}

/// A coordinate sensor needs a joint with coordinates; a drive-force sensor a driven one.
fn check_joint_sensor(s: &Sensor, j: &Joint, c: &mut Checker, p: &str) {
    match s {
        Sensor::JointCoordinate { joint, .. } if j.coordinates().is_empty() => c.err(
            format!("{p}.joint"),
            format!(
                "joint `{joint}` is a {} joint, which has no relative coordinate",
                j.kind()
            ),
        ),
        Sensor::Friction { joint, .. } if j.friction().is_none() => c.err(
            format!("{p}.joint"),
            format!("joint `{joint}` has no `friction`; give it one, or sense another joint"),
        ),
        Sensor::DriveForce { coordinate, .. } => {
            if let Err(e) = driven_coordinate(j, coordinate.as_deref()) {
                let field = if coordinate.is_some() {
                    "coordinate"
                } else {
                    "joint"
                };
                c.err(format!("{p}.{field}"), e);
            }
        }
        _ => {}
    }
}

fn check_beam(model: &Model, beam: &str, c: &mut Checker, p: &str) {
    if !model.beams.iter().any(|b| b.name == beam) {
        c.err(
            format!("{p}.beam"),
            format!("refers to beam `{beam}`, which is not defined in `beams`"),
        );
    }
}

/// A beam station: a fraction `eta` of the length or an arc length `s` on the beam.
fn check_station(
    model: &Model,
    beam: &str,
    at: (Option<f64>, Option<f64>),
    c: &mut Checker,
    p: &str,
) {
    match at {
        (Some(eta), None) => {
            if !(eta.is_finite() && (0.0..=1.0).contains(&eta)) {
                c.err(
                    format!("{p}.eta"),
                    format!("must be a fraction of the beam length between 0 and 1 (got {eta})"),
                );
            }
        }
        (None, Some(s)) => {
            let b = model.beams.iter().find(|b| b.name == beam);
            let length = b.and_then(|b| super::beams::length(b, model));
            let ok = s.is_finite() && s >= 0.0 && length.is_none_or(|l| s <= l * (1.0 + 1e-12));
            if !ok {
                let l = length.map_or(String::new(), |l| format!(" (the beam is {l} m long)"));
                c.err(
                    format!("{p}.s"),
                    format!("must be an arc length along the beam{l}, got {s}"),
                );
            }
        }
        _ => c.err(
            p.to_string(),
            "give exactly one of `eta` (fraction of the length) and `s` (arc length)",
        ),
    }
}
