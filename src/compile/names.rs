//! Item names: identifiers, unique across all items, `ground` reserved.

use crate::model::check::Checker;
use crate::model::{Model, GROUND};
use std::collections::HashMap;

/// Longest item name: names become channel names in results files.
const MAX_NAME: usize = 64;

/// Paths `kind[i]` of a list's names.
fn paths<'a>(kind: &str, names: impl Iterator<Item = &'a str>) -> Vec<(String, &'a str)> {
    names
        .enumerate()
        .map(|(i, n)| (format!("{kind}[{i}]"), n))
        .collect()
}

/// Every named item with its path, in file order.
fn items(model: &Model) -> Vec<(String, &str)> {
    let mut out = paths("nodes", model.nodes.iter().map(|n| n.name.as_str()));
    out.extend(paths(
        "bodies",
        model.bodies.iter().map(|b| b.name.as_str()),
    ));
    out.extend(paths("beams", model.beams.iter().map(|b| b.name.as_str())));
    out.extend(paths("joints", model.joints.iter().map(|j| j.name())));
    out.extend(paths("loads", model.loads.iter().map(|l| l.name())));
    out.extend(paths("sensors", model.sensors.iter().map(|s| s.name())));
    out
}

/// Names are unique across all items so that every reference is unambiguous.
pub fn check(model: &Model, c: &mut Checker) {
    let mut seen: HashMap<&str, String> = HashMap::new();
    for (path, n) in items(model) {
        if let Err(e) = safe_name(n) {
            c.err(format!("{path}.name"), e);
        } else if n == GROUND {
            c.err(
                format!("{path}.name"),
                "`ground` is reserved for the inertial frame; choose another name",
            );
        } else if let Some(first) = seen.get(n) {
            c.err(
                format!("{path}.name"),
                format!("duplicate name `{n}` (already used by {first}); names must be unique"),
            );
        } else {
            seen.insert(n, path);
        }
    }
}

/// Item names are identifiers (a letter or `_`, then letters, digits, `_` or `-`): they
/// become channel names `name.component` and NetCDF variables, where `.` and `/` would be
/// ambiguous.
fn safe_name(n: &str) -> Result<(), String> {
    let mut chars = n.chars();
    let Some(first) = chars.next() else {
        return Err("must not be empty".into());
    };
    let ok_first = first.is_ascii_alphabetic() || first == '_';
    if !ok_first || !chars.all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '-') {
        return Err(format!(
            "`{n}` is not a valid name: use a letter or `_` first, then letters, digits, `_` or `-` (e.g. `{}`)",
            suggest_name(n)
        ));
    }
    if n.len() > MAX_NAME {
        return Err(format!(
            "is {} characters long; at most {MAX_NAME}",
            n.len()
        ));
    }
    Ok(())
}

fn suggest_name(n: &str) -> String {
    let s: String = n
        .chars()
        .map(|ch| {
            if ch.is_ascii_alphanumeric() || ch == '-' {
                ch
            } else {
                '_'
            }
        })
        .collect();
    match s.chars().next() {
        Some(ch) if ch.is_ascii_alphabetic() || ch == '_' => s,
        _ => format!("_{s}"),
    }
}
