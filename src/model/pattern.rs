//! Patterns: a group of items copied `count` times, each copy turned by `step` about an axis
//! (the blades of a rotor with their hinges, pitch links and sensors). `{i}` in any text of a
//! pattern's items — names, references, expressions — becomes the copy's number, 1 … count.

use super::{Beam, InitialSpin, Joint, Load, Node, RigidBody, Sensor, Vec3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// At most this many copies in one pattern (a typo of `count` must not exhaust memory).
pub const MAX_PATTERN_COPIES: usize = 1000;

/// Copies of a group of items turned about an axis: copy i (1 … count) is the group turned by
/// (i − 1)·step about `axis` through `center` — its points, directions, triads and default
/// section axes alike. Its items are written like the model's own, with `{i}` in every name
/// (replaced by the copy number, in references and expressions too). Items may refer to the
/// model's own items (a hub) and to items of their own copy.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct Pattern {
    /// A name for error messages.
    #[serde(default)]
    pub name: String,
    /// Number of copies, 1 … 1000.
    pub count: usize,
    /// Direction of the axis the copies turn about (right-handed), inertial frame.
    pub axis: Vec3,
    /// A point of the axis, m (default: the origin).
    #[serde(default)]
    pub center: Vec3,
    /// Angle between neighbouring copies, rad (default 2π/count: evenly round the axis).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<f64>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nodes: Vec<Node>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bodies: Vec<RigidBody>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub beams: Vec<Beam>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub joints: Vec<Joint>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub loads: Vec<Load>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sensors: Vec<Sensor>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub initial_spins: Vec<InitialSpin>,
}

impl Pattern {
    /// The angle of copy `k` (0-based), rad.
    pub fn angle(&self, k: usize) -> f64 {
        let step = self
            .step
            .unwrap_or(2.0 * std::f64::consts::PI / self.count as f64);
        k as f64 * step
    }

    /// How it is named in messages.
    pub fn label(&self, p: usize) -> String {
        if self.name.is_empty() {
            format!("patterns[{p}]")
        } else {
            format!("pattern `{}`", self.name)
        }
    }

    /// Problems with the pattern itself (what the copies cannot be made without), each with
    /// its path and message.
    pub fn problems(&self, p: usize) -> Vec<(String, String)> {
        let path = format!("patterns[{p}]");
        let mut out = vec![];
        if self.count == 0 || self.count > MAX_PATTERN_COPIES {
            out.push((
                format!("{path}.count"),
                format!("{} copies: give 1 … {MAX_PATTERN_COPIES}", self.count),
            ));
        }
        let n = self.axis.iter().map(|a| a * a).sum::<f64>().sqrt();
        if !(n.is_finite() && n > 0.0) {
            out.push((
                format!("{path}.axis"),
                "must be a nonzero direction of finite numbers, e.g. [0, 0, 1]".into(),
            ));
        }
        if self.center.iter().any(|c| !c.is_finite()) {
            out.push((format!("{path}.center"), "must be finite numbers, m".into()));
        }
        if self.step.is_some_and(|s| !s.is_finite()) {
            out.push((format!("{path}.step"), "must be a finite angle, rad".into()));
        }
        if self.count > 1 {
            out.extend(self.unnumbered_names(p));
        }
        out
    }

    /// Names without `{i}`: their copies would all have the same name.
    fn unnumbered_names(&self, p: usize) -> Vec<(String, String)> {
        let names = self
            .nodes
            .iter()
            .map(|x| ("nodes", x.name.as_str()))
            .chain(self.bodies.iter().map(|x| ("bodies", x.name.as_str())))
            .chain(self.beams.iter().map(|x| ("beams", x.name.as_str())))
            .chain(self.joints.iter().map(|x| ("joints", x.name())))
            .chain(self.loads.iter().map(|x| ("loads", x.name())))
            .chain(self.sensors.iter().map(|x| ("sensors", x.name())));
        let mut index = std::collections::HashMap::<&str, usize>::new();
        let mut out = vec![];
        for (kind, name) in names {
            let k = index.entry(kind).or_default();
            if !name.contains("{i}") {
                out.push((
                    format!("patterns[{p}].{kind}[{k}].name"),
                    format!(
                        "`{name}` is copied {} times by {}: put `{{i}}` in the name (e.g. `{name}{{i}}`), which becomes the copy number 1 … {}",
                        self.count,
                        self.label(p),
                        self.count
                    ),
                ));
            }
            *k += 1;
        }
        out
    }

    /// Copy `k` (0-based) with `{i}` replaced by its number, not yet turned.
    pub fn numbered(&self, k: usize) -> Result<Pattern, String> {
        // Through YAML's data model, which keeps every number (JSON's has no NaN).
        let mut v = serde_norway::to_value(self).map_err(|e| e.to_string())?;
        substitute(&mut v, &(k + 1).to_string());
        serde_norway::from_value(v).map_err(|e| e.to_string())
    }
}

/// Replaces `{i}` by `number` in every string of `v`, and writes enum variants (which
/// serialize as YAML tags, `!tube {…}`) as the file does, `{tube: {…}}`, for the untagged
/// enums that read them back.
fn substitute(v: &mut serde_norway::Value, number: &str) {
    use serde_norway::{Mapping, Value};
    match v {
        Value::String(s) if s.contains("{i}") => *s = s.replace("{i}", number),
        Value::Sequence(a) => a.iter_mut().for_each(|x| substitute(x, number)),
        Value::Mapping(o) => o.iter_mut().for_each(|(_, x)| substitute(x, number)),
        Value::Tagged(t) => {
            let mut inner = std::mem::take(&mut t.value);
            substitute(&mut inner, number);
            let mut m = Mapping::new();
            m.insert(
                Value::String(t.tag.to_string().trim_start_matches('!').into()),
                inner,
            );
            *v = Value::Mapping(m);
        }
        _ => {}
    }
}
