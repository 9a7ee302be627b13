//! Parsing model text (YAML or JSON) into [`Model`], with the path of any offending item.

use super::{Model, ModelError, ModelErrors};

/// Parse a YAML model (checked by [`crate::compile::validate`]).
pub fn parse_yaml(text: &str) -> Result<Model, ModelErrors> {
    parse(serde_norway::Deserializer::from_str(text))
}

/// Parse a JSON model (what the Python builder sends).
pub fn parse_json(text: &str) -> Result<Model, ModelErrors> {
    parse(&mut serde_json::Deserializer::from_str(text))
}

fn parse<'de, D: serde::Deserializer<'de>>(de: D) -> Result<Model, ModelErrors>
where
    D::Error: std::fmt::Display,
{
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner().to_string();
        ModelErrors::one(ModelError::new(
            if path == "." { String::new() } else { path },
            clean(&inner),
        ))
    })
}

/// Serde's message for an untagged enum says nothing useful; say what is accepted. The YAML
/// parser prefixes its own (coarser) path, which is dropped in favour of the full path.
fn clean(msg: &str) -> String {
    let msg = match msg.split_once(": ") {
        Some((head, rest)) if !head.is_empty() && !head.contains(' ') => rest,
        _ => msg,
    };
    if msg.contains("did not match any variant of untagged enum Inertia") {
        return "must be [I11, I22, I33] or a 3×3 matrix of numbers".into();
    }
    if msg.contains("did not match any variant of untagged enum TimeFunctionSpec") {
        return "must be a number, an expression of t in quotes, or a table {t: [...], value: [...]} (with no other keys)".into();
    }
    msg.to_string()
}
