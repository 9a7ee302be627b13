//! Friction on a joint's sliding motion (`friction:` of prismatic, cylindrical, screw and the
//! sliding joints): its checks, and what each kind's friction is made of — its slip as a
//! function of the joint's coordinates and the constraint rows its normal force comes from
//! (`joints/friction.rs` has the law).

use super::rows::RowTable;
use crate::beam::path::ArcMap;
use crate::joints::friction::{Coefficients, Normal, Slip, Thread};
use crate::math::vec3::V3;
use crate::model::check::Checker;
use crate::model::{Friction, Joint};

/// Checks a joint's friction: coefficients, and the fields its kind uses.
pub fn check(j: &Joint, c: &mut Checker, p: &str) {
    let Some(f) = j.friction() else { return };
    let p = format!("{p}.friction");
    let who = format!("joint `{}`", j.name());
    c.non_negative(format!("{p}.static"), f.static_coefficient, &who);
    if let Some(k) = f.kinetic {
        c.non_negative(format!("{p}.kinetic"), k, &who);
        if k > f.static_coefficient {
            c.err(format!("{p}.kinetic"), format!("{who}: the kinetic coefficient ({k}) must not exceed the static one ({}): a joint that slides more easily than it starts would have no stable stick", f.static_coefficient));
        }
    }
    c.non_negative(format!("{p}.viscous"), f.viscous, &who);
    c.non_negative(format!("{p}.preload"), f.preload, &who);
    check_thread(j, f, c, &p, &who);
}

/// The thread's fields: `radius` where a thread needs it (screws, sliding joints with a
/// `lead`; a sliding screw's twisting moment), `lead` on sliding joints, `thread_angle` on
/// threads.
fn check_thread(j: &Joint, f: &Friction, c: &mut Checker, p: &str, who: &str) {
    let threaded = matches!(j, Joint::Screw(_)) || f.lead.is_some();
    match f.radius {
        Some(r) if !(r.is_finite() && r > 0.0) => {
            c.err(format!("{p}.radius"), format!("{who}: must be > 0 m (got {r})"));
        }
        Some(_) if !threaded && !matches!(j, Joint::SlidingScrew(_)) => c.err(
            format!("{p}.radius"),
            format!("{who}: `radius` is for threads (screw joints, sliding joints with a `lead`) and sliding screw joints; remove it"),
        ),
        None if threaded => c.err(
            format!("{p}.radius"),
            format!("{who}: the friction acts on a thread: give the thread's mean `radius` (m)"),
        ),
        _ => {}
    }
    if let Some(lead) = f.lead {
        if j.sliding().is_none() {
            c.err(format!("{p}.lead"), format!("{who}: `lead` is for sliding joints (a screw joint's lead is its pitch); remove it"));
        } else if !(lead.is_finite() && lead > 0.0) {
            c.err(
                format!("{p}.lead"),
                format!("{who}: must be > 0 m per turn (got {lead})"),
            );
        }
    }
    if let Some(b) = f.thread_angle {
        if !threaded {
            c.err(format!("{p}.thread_angle"), format!("{who}: `thread_angle` is for threads (screw joints, sliding joints with a `lead`); remove it"));
        } else if !(b.is_finite() && (0.0..1.4).contains(&b)) {
            c.err(format!("{p}.thread_angle"), format!("{who}: the thread's half-angle must be in [0, 1.4) rad (got {b}; 0.5236 for ISO metric threads)"));
        }
    }
}

fn coefficients(f: &Friction) -> Coefficients {
    Coefficients {
        static_: f.static_coefficient,
        kinetic: f.kinetic_coefficient(),
        viscous: f.viscous,
        preload: f.preload,
    }
}

/// A pair joint's friction on its coordinates `ids` (Δ first), joint kernel `kernel`.
pub fn pair(j: &Joint, f: &Friction, kernel: usize, ids: &[usize], rows: &mut RowTable) {
    // The separation's projections normal to the axis are the joint's rows 0 and 1.
    let axes = Normal::Axes { rows: [0, 1] };
    let (slip, coords, normal) = match j {
        Joint::Screw(s) => {
            let r = f.radius.expect("checked");
            let alpha = (s.pitch / r).atan();
            let beta = f.thread_angle.unwrap_or(0.0);
            let slip = Slip::Linear {
                weights: [alpha.sin(), r * alpha.cos()],
            };
            // Row 6 is the thread's Δ − pitch·φ = 0; its multiplier is the axial load.
            let factor = 1.0 / (alpha.cos() * beta.cos());
            (slip, ids.to_vec(), Normal::Thread { row: 6, factor })
        }
        _ => (
            Slip::Linear {
                weights: [1.0, 0.0],
            },
            vec![ids[0]],
            axes,
        ),
    };
    rows.friction(
        j.name(),
        kernel,
        coefficients(f),
        slip,
        coords,
        normal,
        None,
    );
}

/// A sliding joint's friction along the beam (coordinate ζ, `map` to η, beam `length`).
pub fn sliding(
    j: &Joint,
    f: &Friction,
    kernel: usize,
    coord: usize,
    map: ArcMap,
    length: f64,
    rows: &mut RowTable,
) {
    // Rows 0–2 are the contact force (spatial); a sliding screw's row 3 its twisting moment.
    let thread = f.lead.map(|lead| {
        let alpha = (lead / (2.0 * std::f64::consts::PI * f.radius.expect("checked"))).atan();
        Thread {
            sin_lead: alpha.sin(),
            cos_lead: alpha.cos(),
            cos_flank: f.thread_angle.unwrap_or(0.0).cos(),
        }
    });
    let normal = Normal::Lateral {
        row: 0,
        axis: V3([1.0, 0.0, 0.0]),
        thread,
    };
    let moment = match (j, f.radius, f.lead) {
        (Joint::SlidingScrew(_), Some(r), None) => Some((3, 1.0 / r)),
        _ => None,
    };
    let slip = Slip::Arc { map, length };
    rows.friction(
        j.name(),
        kernel,
        coefficients(f),
        slip,
        vec![coord],
        normal,
        moment,
    );
}
