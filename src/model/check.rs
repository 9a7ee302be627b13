//! Reporting problems in a model: every error names the item by its path in the file
//! (`joints[3].axis`) and says how to fix it. [`Checker`] collects them; the compiler's rooms
//! (one per item kind) fill it.

use super::{Model, Vec3, GROUND};
use crate::math::time_function::{TimeFunction, TimeFunctionSpec};
use std::collections::HashSet;
use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub struct ModelError {
    pub path: String,
    pub message: String,
}

impl ModelError {
    pub fn new(path: impl Into<String>, message: impl Into<String>) -> Self {
        ModelError {
            path: path.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for ModelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            write!(f, "{}", self.message)
        } else {
            write!(f, "{}: {}", self.path, self.message)
        }
    }
}

/// All problems found in a model, one line each.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelErrors(pub Vec<ModelError>);

impl ModelErrors {
    pub fn one(e: ModelError) -> Self {
        ModelErrors(vec![e])
    }
}

impl fmt::Display for ModelErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let lines: Vec<String> = self.0.iter().map(|e| e.to_string()).collect();
        write!(f, "{}", lines.join("\n"))
    }
}

impl std::error::Error for ModelErrors {}

/// How far a unit vector may be from length 1.
pub const UNIT_TOL: f64 = 1e-6;

/// Collects every problem found, with the checks most items share.
#[derive(Default)]
pub struct Checker {
    pub errors: Vec<ModelError>,
}

impl Checker {
    pub fn err(&mut self, path: impl Into<String>, msg: impl Into<String>) {
        self.errors.push(ModelError::new(path, msg));
    }
    pub fn vec3(&mut self, path: String, v: &Vec3) {
        if !v.iter().all(|x| x.is_finite()) {
            self.err(path, "must contain three finite numbers");
        }
    }
    pub fn unit(&mut self, path: String, v: &Vec3, what: &str) {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if !v.iter().all(|x| x.is_finite()) || (n - 1.0).abs() > UNIT_TOL {
            self.err(
                path,
                format!("must be a unit vector (|{what}| = {n:.6}); divide it by its length"),
            );
        }
    }
    pub fn time_function(&mut self, path: String, f: &TimeFunctionSpec) {
        if let Err(e) = TimeFunction::new(f) {
            self.err(path, e);
        }
    }
    /// A finite number ≥ 0.
    pub fn non_negative(&mut self, path: String, v: f64, who: &str) {
        if !(v.is_finite() && v >= 0.0) {
            self.err(path, format!("{who}: must be ≥ 0 (got {v})"));
        }
    }
    pub fn finish(self) -> Result<(), ModelErrors> {
        if self.errors.is_empty() {
            Ok(())
        } else {
            Err(ModelErrors(self.errors))
        }
    }
}

/// The node names a model defines: its `nodes`, its beams' nodes `<beam>.k` (shared end
/// nodes keep their own names) and the aliases `<beam>.start`, `<beam>.end`; and per beam
/// its name and node count, to say which names a beam has.
pub struct NodeNames {
    names: HashSet<String>,
    beams: Vec<(String, usize)>,
}

impl NodeNames {
    pub fn of(model: &Model) -> NodeNames {
        let mut names: HashSet<String> = model.nodes.iter().map(|n| n.name.clone()).collect();
        let mut beams = Vec::new();
        for b in &model.beams {
            if (1..=3).contains(&b.order) && b.elements >= 1 {
                names.extend((0..b.node_count()).map(|k| b.node_name(k)));
                names.extend(b.end_aliases().into_iter().map(|(alias, _)| alias));
                beams.push((b.name.clone(), b.node_count()));
            }
        }
        NodeNames { names, beams }
    }

    pub fn contains(&self, n: &str) -> bool {
        self.names.contains(n)
    }

    /// Why `n` names no node: the nodes of the beam it names or seems to name, else that it
    /// is not among `nodes`.
    fn unknown(&self, n: &str) -> String {
        let beam = n.split_once('.').map_or(n, |(b, _)| b);
        match self.beams.iter().find(|(b, _)| b == beam) {
            Some((b, count)) => format!(
                "refers to node `{n}`, which beam `{b}` does not have: its nodes are `{b}.0` … `{b}.{}` (`{b}.start`, `{b}.end`)",
                count - 1
            ),
            None => format!("refers to node `{n}`, which is not defined in `nodes` nor a beam's node"),
        }
    }

    /// Reports `n` at `path` unless it names a node (or, where allowed, `ground`).
    pub fn check(&self, c: &mut Checker, path: String, n: &str, allow_ground: bool) {
        if n == GROUND {
            if !allow_ground {
                c.err(path, "cannot be `ground` here; give a node name");
            }
        } else if !self.contains(n) {
            c.err(path, self.unknown(n));
        }
    }
}
