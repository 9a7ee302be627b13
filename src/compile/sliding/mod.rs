//! Sliding joints (a follower in contact with a beam at a moving point η; the sliding screw
//! also follows the beam's twist, the sliding clamp its whole section): their checks and their
//! compilation into the η coordinate, its drive, spring and end stops, and the contact kernel.

mod placement;

use super::nodes::NodeTable;
use super::rows::RowTable;
use crate::beam::path::{ArcMap, BeamPath};
use crate::joints::sliding::{ContactLaw, SlidingJoint as Kernel, SlidingKind};
use crate::joints::{Attachment, ConstraintLaw, Joint, Side};
use crate::math::time_function::TimeFunction;
use crate::math::vec3::{M3, V3};
use crate::model::check::{Checker, NodeNames};
use crate::model::{self, Model, ModelError, SlidingJoint, GROUND};
use crate::system::{BeamInfo, JointCoordinate, JointInfo};

/// A sliding joint's beam exists, its follower is another body's node, its η stays on the
/// beam, and a free contact point can start anywhere on it.
pub fn check(model: &Model, sl: &SlidingJoint, names: &NodeNames, c: &mut Checker, p: &str) {
    let who = format!("sliding joint `{}`", sl.name);
    if check_beam(model, sl, c, p, &who) {
        check_eta(model, sl, c, p, &who);
    }
    names.check(c, format!("{p}.follower"), &sl.follower, true);
}

/// How far a given η may be from its drive's value at t = 0 and still be the same start
/// (both typed to ~9 digits; 1e-9 of a 100 m beam is 0.1 µm).
const DRIVEN_ETA_AGREES: f64 = 1e-9;

/// η given, driven or held by end stops, consistently.
fn check_eta(model: &Model, sl: &SlidingJoint, c: &mut Checker, p: &str, who: &str) {
    let drive = sl.drive.as_ref().map(TimeFunction::new);
    if let Some(eta) = sl.eta {
        if !(0.0..=1.0).contains(&eta) {
            c.err(
                format!("{p}.eta"),
                format!("{who}: η must lie on the beam, in [0, 1] (got {eta})"),
            );
        }
        // The drive sets the initial η; a given η must say the same (or be left out).
        if let Some(Ok(f)) = &drive {
            let start = f.value(0.0);
            if (start - eta).abs() > DRIVEN_ETA_AGREES {
                c.err(
                    format!("{p}.eta"),
                    format!("{who}: the drive sets the initial η, its value at t = 0, which is {start} (got eta = {eta}); remove `eta` or make the drive start there"),
                );
            }
        }
    }
    if let Some(stops) = &sl.end_stops {
        if !(stops.stiffness.is_finite() && stops.stiffness > 0.0) {
            c.err(
                format!("{p}.end_stops.stiffness"),
                format!(
                    "{who}: must be a positive number of N/m (got {})",
                    stops.stiffness
                ),
            );
        }
        if sl.drive.is_some() {
            c.err(
                format!("{p}.end_stops"),
                format!(
                    "{who}: a prescribed η never reaches a stop; remove `end_stops` or the drive"
                ),
            );
        }
    }
    if let Some(Ok(f)) = &drive {
        if let Some((t, eta)) = drive_leaves_beam(f, model.simulation.t_end) {
            c.err(format!("{p}.drive"), format!("{who}: the prescribed η leaves the beam at t = {} s (η = {eta:.6}); η must stay in [0, 1] over the whole run", crate::math::seconds::Seconds(t)));
        }
    }
}

/// The beam exists (else `false`) and the follower is not one of its own nodes.
fn check_beam(model: &Model, sl: &SlidingJoint, c: &mut Checker, p: &str, who: &str) -> bool {
    let Some(beam) = model.beams.iter().find(|b| b.name == sl.beam) else {
        c.err(
            format!("{p}.beam"),
            format!(
                "{who} refers to beam `{}`, which is not defined in `beams`",
                sl.beam
            ),
        );
        return false;
    };
    let own_node = sl
        .follower
        .strip_prefix(&format!("{}.", sl.beam))
        .is_some_and(|k| k.parse::<usize>().is_ok());
    if own_node
        || [&beam.start_node, &beam.end_node]
            .iter()
            .any(|n| n.as_deref() == Some(sl.follower.as_str()))
    {
        c.err(format!("{p}.follower"), format!("{who}: the follower `{}` is a node of beam `{}` itself; a follower must belong to another body", sl.follower, sl.beam));
    }
    true
}

/// The first time in [0, t_end] at which a prescribed η leaves [0, 1], with its value
/// (sampled finely enough for any smooth motion of a run).
pub fn drive_leaves_beam(f: &TimeFunction, t_end: f64) -> Option<(f64, f64)> {
    if !t_end.is_finite() {
        return None; // reported as a bad `simulation.t_end`
    }
    let samples = 20_000;
    (0..=samples).find_map(|k| {
        let t = t_end * k as f64 / samples as f64;
        let eta = f.value(t);
        (!(-1e-12..=1.0 + 1e-12).contains(&eta)).then_some((t, eta))
    })
}

/// Where the contact starts: the follower's side, the initial element coordinate ζ₀ (the
/// drive's η(0), the given η, or the beam point closest to the follower) and the
/// attachments (the beam's point; the follower's contact point and triad).
struct Start {
    follower: Side,
    zeta0: f64,
    at: [Attachment; 2],
}

fn start(
    sl: &SlidingJoint,
    kind: SlidingKind,
    (path, map, info): (&BeamPath, &ArcMap, &BeamInfo),
    drive: Option<&TimeFunction>,
    table: &NodeTable,
) -> Start {
    let (follower, pose) = if sl.follower == GROUND {
        let (x, r) = (V3::zero(), M3::identity());
        (Side::Ground { x, r }, (x, r))
    } else {
        let a = table.index(&sl.follower);
        (Side::Node(a), (table.states[a].x, table.states[a].r))
    };
    let nodes = &table.states;
    let zeta0 = match (drive, sl.eta) {
        (Some(f), _) => map.zeta(f.value(0.0)),
        (None, Some(eta)) => map.zeta(eta),
        (None, None) => placement::closest_point(path, info, nodes, pose.0),
    };
    let (point, _) = placement::beam_point(path, info, nodes, zeta0);
    let triad = placement::follower_triad(kind, path, info, nodes, zeta0);
    let beam_side = Attachment {
        offset: V3::zero(),
        triad: M3::identity(),
    };
    Start {
        follower,
        zeta0,
        at: [
            beam_side,
            placement::follower_attachment(pose, point, triad),
        ],
    }
}

/// Compiles sliding joint `j` (at `path`) into its η coordinate, drive, spring, end stops
/// and contact kernel.
pub fn compile(
    j: &model::Joint,
    path: &str,
    table: &NodeTable,
    beam_info: &[BeamInfo],
    rows: &mut RowTable,
) -> Result<(), ModelError> {
    let sl = j.sliding().expect("a sliding joint");
    let kind = match j {
        model::Joint::SlidingScrew(_) => SlidingKind::Screw,
        model::Joint::SlidingClamp(_) => SlidingKind::Clamp,
        _ => SlidingKind::Point,
    };
    let beam = beam_info
        .iter()
        .position(|b| b.name == sl.beam)
        .expect("validated");
    let info = &beam_info[beam];
    let beam_path = BeamPath::new(info.count, info.order);
    let map = ArcMap::new(&info.spans, info.length);
    let drive = sl
        .drive
        .as_ref()
        .map(|d| TimeFunction::new(d).map_err(|e| ModelError::new(format!("{path}.drive"), e)))
        .transpose()?;
    let s = start(sl, kind, (&beam_path, &map, info), drive.as_ref(), table);
    let eta = coordinate(sl, path, info, &map, drive, s.zeta0, rows)?;
    let law = ContactLaw { kind, at: s.at };
    let n_rows = law.n_rows();
    let (name, beam_nodes) = (sl.name.clone(), info.nodes.clone());
    let end_stops = sl.end_stops.is_some();
    let arc = map.clone();
    let build = move |row, layout: &_| {
        let mut kernel = Kernel::new(
            name, law, beam_path, beam_nodes, s.follower, eta.coord, row, layout, s.zeta0,
        );
        kernel.beam = beam;
        kernel.arc = map;
        kernel.end_stops = end_stops;
        Joint::Sliding(kernel)
    };
    let kernel = rows.joint(sl.name.clone(), n_rows, Box::new(build));
    if let Some(f) = &sl.friction {
        super::friction::sliding(j, f, kernel, eta.coord, arc, info.length, rows);
    }
    rows.joint_info.push(JointInfo {
        name: sl.name.clone(),
        kernel,
        coords: vec![eta],
    });
    Ok(())
}

/// The η coordinate (stored as ζ) with its drive, spring and end stops.
fn coordinate(
    sl: &SlidingJoint,
    path: &str,
    info: &BeamInfo,
    map: &ArcMap,
    drive: Option<TimeFunction>,
    zeta0: f64,
    rows: &mut RowTable,
) -> Result<JointCoordinate, ModelError> {
    let c = rows.coordinate(format!("{}.eta", sl.name), zeta0);
    let drive =
        drive.map(|f| rows.drive(c, format!("{}.drive_eta", sl.name), f, Some(map.clone())));
    let spring = match &sl.spring {
        Some(s) => {
            let (law, damping) = placement::spring_on_zeta(s, map, info.length).map_err(|e| {
                ModelError::new(
                    format!("{path}.spring"),
                    format!("sliding joint `{}`: {e}", sl.name),
                )
            })?;
            Some(rows.spring(c, law, damping))
        }
        None => None,
    };
    if let Some(stops) = &sl.end_stops {
        rows.spring(c, placement::end_stops_on_zeta(stops.stiffness, info), 0.0);
    }
    Ok(JointCoordinate {
        name: "eta",
        coord: c,
        drive,
        spring,
    })
}
