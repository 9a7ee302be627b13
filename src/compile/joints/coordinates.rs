//! A joint's relative coordinates (Δ, φ or a sliding joint's η): the checks of their drives
//! and springs, and their compilation into coordinates, drive rows and springs.

use super::super::rows::RowTable;
use crate::elements::coordinate::SpringLaw;
use crate::math::time_function::TimeFunction;
use crate::model::check::Checker;
use crate::model::{CoordinateSpec, Joint, ModelError, SpringDamper};
use crate::system::JointCoordinate;

/// Checks each coordinate's drive function and spring.
pub fn check(j: &Joint, c: &mut Checker, p: &str) {
    for co in j.coordinates() {
        if let Some(d) = co.drive {
            c.time_function(format!("{p}.{}", co.drive_field), d);
        }
        if let Some(s) = co.spring {
            check_spring(s, c, &format!("{p}.{}", co.spring_field), j.name());
        }
    }
}

fn check_spring(s: &SpringDamper, c: &mut Checker, path: &str, joint: &str) {
    let who = format!("joint `{joint}`");
    c.non_negative(format!("{path}.stiffness"), s.stiffness, &who);
    c.non_negative(format!("{path}.damping"), s.damping, &who);
    if !s.rest.is_finite() {
        c.err(format!("{path}.rest"), "must be a finite number");
    }
    let Some(t) = &s.table else { return };
    let path = format!("{path}.table");
    if s.stiffness != 0.0 || s.rest != 0.0 {
        c.err(
            path,
            format!("{who}: give either `stiffness`/`rest` (linear) or a `table`, not both"),
        );
    } else if t.at.len() < 2 || t.at.len() != t.force.len() {
        c.err(
            path,
            format!("{who}: `at` and `force` must have the same length, at least 2"),
        );
    } else if !t.at.iter().chain(&t.force).all(|v| v.is_finite())
        || !t.at.windows(2).all(|w| w[1] > w[0])
    {
        c.err(
            path,
            format!("{who}: `at` must increase strictly and all entries be finite"),
        );
    } else if !t.force.windows(2).all(|w| w[1] >= w[0]) {
        c.err(path, format!("{who}: the force must not decrease as the coordinate grows (a convex spring energy is what lets the ED scheme guarantee decay)"));
    }
}

/// The elastic law a joint coordinate's spring describes.
pub fn spring_law(s: &SpringDamper) -> SpringLaw {
    match &s.table {
        Some(t) => SpringLaw::table(t.at.clone(), t.force.clone()),
        None => SpringLaw::Linear {
            stiffness: s.stiffness,
            rest: s.rest,
        },
    }
}

/// Each coordinate's drive function, if driven (an error names the drive's field).
pub fn drives(
    coords: &[CoordinateSpec<'_>],
    path: &str,
) -> Result<Vec<Option<TimeFunction>>, ModelError> {
    coords
        .iter()
        .map(|co| {
            co.drive
                .map(|d| {
                    TimeFunction::new(d)
                        .map_err(|e| ModelError::new(format!("{path}.{}", co.drive_field), e))
                })
                .transpose()
        })
        .collect()
}

/// Numbers joint `name`'s coordinates (values `initial` at t = 0) with their drives and
/// springs; returns their indices and what sensors need of them.
pub fn compile(
    name: &str,
    coords: &[CoordinateSpec<'_>],
    drives: Vec<Option<TimeFunction>>,
    initial: &[f64; 2],
    rows: &mut RowTable,
) -> (Vec<usize>, Vec<JointCoordinate>) {
    let mut ids = Vec::new();
    let mut info = Vec::new();
    for ((co, f), &value0) in coords.iter().zip(drives).zip(initial) {
        let c = rows.coordinate(format!("{name}.{}", co.name), value0);
        let drive = f.map(|f| rows.drive(c, format!("{name}.drive_{}", co.name), f, None));
        let spring = co.spring.map(|s| rows.spring(c, spring_law(s), s.damping));
        ids.push(c);
        info.push(JointCoordinate {
            name: co.name,
            coord: c,
            drive,
            spring,
        });
    }
    (ids, info)
}
