//! Parsing model text (YAML or JSON) into [`Model`], with the path of any offending item.

use super::{Model, ModelError, ModelErrors};

/// Parse a YAML model (checked by [`crate::compile::validate`]).
pub fn parse_yaml(text: &str) -> Result<Model, ModelErrors> {
    parse(serde_norway::Deserializer::from_str(text), Source::Yaml)
}

/// Parse a JSON model (what the Python builder sends).
pub fn parse_json(text: &str) -> Result<Model, ModelErrors> {
    parse(&mut serde_json::Deserializer::from_str(text), Source::Json)
}

/// What a model's text came from: a YAML file a user wrote, or the JSON the Python builder
/// serialized (whose line and column mean nothing to its user).
#[derive(Clone, Copy, PartialEq)]
enum Source {
    Yaml,
    Json,
}

fn parse<'de, D: serde::Deserializer<'de>>(de: D, source: Source) -> Result<Model, ModelErrors>
where
    D::Error: std::fmt::Display,
{
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner().to_string();
        ModelErrors::one(ModelError::new(
            if path == "." { String::new() } else { path },
            clean(&inner, source),
        ))
    })
}

/// Serde's message for an untagged enum says nothing useful; say what is accepted. The YAML
/// parser prefixes its own (coarser) path, which is dropped in favour of the full path; the
/// JSON parser appends the position in the builder's serialized text, which is dropped.
fn clean(msg: &str, source: Source) -> String {
    let msg = match (source, msg.split_once(": ")) {
        (Source::Yaml, Some((head, rest))) if !head.is_empty() && !head.contains(' ') => rest,
        _ => msg,
    };
    let msg = match (source, msg.rfind(" at line ")) {
        (Source::Json, Some(at)) if msg[at..].contains(" column ") => &msg[..at],
        _ => msg,
    };
    if msg.contains("did not match any variant of untagged enum Inertia") {
        return "must be [I11, I22, I33] or a 3×3 matrix of numbers".into();
    }
    if msg.contains("did not match any variant of untagged enum TimeFunctionSpec") {
        return "must be a number, an expression of t in quotes, or a table {t: [...], value: [...]} (with no other keys)".into();
    }
    with_suggestion(msg)
}

/// Serde's "unknown field" or "unknown variant" message (which lists every name accepted)
/// with the name likely meant right after the one given — a near spelling — or, for a
/// beam's `material` and `shape`, where they go (inside its `section`) at the end.
fn with_suggestion(msg: &str) -> String {
    // Anywhere in it: a nested form's message starts with its own path.
    let Some((prefix, rest)) = ["unknown field `", "unknown variant `"]
        .iter()
        .find_map(|m| {
            let at = msg.find(m)? + m.len();
            Some((&msg[..at], &msg[at..]))
        })
    else {
        return msg.to_string();
    };
    let Some((given, after)) = rest.split_once('`') else {
        return msg.to_string();
    };
    // "…, expected one of `a`, `b`" or "expected `a` or `b`": every other piece is a name.
    let accepted: Vec<&str> = after.split('`').skip(1).step_by(2).collect();
    if matches!(given, "material" | "shape") && accepted.contains(&"section") {
        return format!(
            "{msg}. A beam's material and shape go inside its section: `section: {{material: \
             {{E: …, nu: … (or G: …), density: …}}, shape: {{rectangle: {{width: …, height: \
             …}}}}}}`"
        );
    }
    match nearest(given, &accepted) {
        Some(near) => format!("{prefix}{given}` (did you mean `{near}`?){after}"),
        None => msg.to_string(),
    }
}

/// The accepted name within a typo of `given` (case ignored): one edit in a name of under six
/// letters, two from six on — closer than another word.
fn nearest<'a>(given: &str, accepted: &[&'a str]) -> Option<&'a str> {
    let lower = given.to_lowercase();
    let (distance, near) = accepted
        .iter()
        .map(|a| (strsim::damerau_levenshtein(&lower, &a.to_lowercase()), *a))
        .min()?;
    let allowed = if given.chars().count() < 6 { 1 } else { 2 };
    (distance <= allowed).then_some(near)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(yaml: &str) -> String {
        match parse_yaml(yaml) {
            Ok(_) => panic!("parsed: {yaml}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn a_misspelt_name_gets_the_accepted_one_it_was_likely_meant_as() {
        let joint =
            "joints: [{type: revolute, name: pin, node1: ground, node2: a, axsi: [0, 0, 1]}]";
        assert!(
            message(joint).contains("did you mean `axis`?"),
            "{}",
            message(joint)
        );
        let kind = "joints: [{type: revolut, name: pin, node1: ground, node2: a}]";
        assert!(
            message(kind).contains("did you mean `revolute`?"),
            "{}",
            message(kind)
        );
        // Case and a transposition are one edit each; a different word gets no guess.
        let body = "bodies: [{name: b, node: a, Mass: 1, inertia: [1, 1, 1]}]";
        assert!(
            message(body).contains("did you mean `mass`?"),
            "{}",
            message(body)
        );
        // Inside a section's form, whose message starts with the path within it.
        let shape = "beams: [{name: b, start: [0, 0, 0], end: [1, 0, 0], section: {material: \
                     {E: 7.0e10, nu: 0.33, density: 2700}, shape: {rectangle: {width: 0.04, heigth: 0.03}}}}]";
        let m = message(shape);
        assert!(
            m.contains("shape.rectangle.heigth") && m.contains("did you mean `height`?"),
            "{m}"
        );
        // From the Python builder (JSON): the same path inside the section, and no position
        // in the serialized text.
        let json = r#"{"beams": [{"name": "b", "start": [0, 0, 0], "end": [1, 0, 0], "section":
            {"material": {"E": 7.0e10, "nu": 0.33, "density": 2700},
             "shape": {"tube": {"outer_diameter": 0.04, "wall": 0.003}}}}]}"#;
        let m = parse_json(json)
            .err()
            .expect("an unknown field")
            .to_string();
        assert!(
            m.contains("shape.tube.outer_diameter") && !m.contains(" at line "),
            "{m}"
        );
        let hinge = "joints: [{type: hinge, name: pin, node1: ground, node2: a}]";
        assert!(
            !message(hinge).contains("did you mean"),
            "{}",
            message(hinge)
        );
    }

    #[test]
    fn a_beams_material_outside_its_section_is_told_where_it_goes() {
        for field in [
            "material: {E: 7.0e10, nu: 0.33, density: 2700}",
            "shape: {circle: {diameter: 0.1}}",
        ] {
            let yaml = format!("beams: [{{name: b, start: [0, 0, 0], end: [1, 0, 0], {field}}}]");
            let m = message(&yaml);
            assert!(
                m.contains("beams[0]") && m.contains("go inside its section"),
                "{m}"
            );
        }
    }

    #[test]
    fn a_shape_written_with_a_type_key_is_told_its_form() {
        // serde alone said "invalid value: map, expected map with a single key".
        let yaml = "beams: [{name: b, start: [0, 0, 0], end: [1, 0, 0], section: {material: \
                    {E: 7.0e10, nu: 0.33, density: 2700}, shape: {type: rectangle, width: 0.04, height: 0.03}}}]";
        let m = message(yaml);
        assert!(
            m.contains("beams[0].section: shape: name the kind as its only key"),
            "{m}"
        );
        assert!(
            m.contains("{rectangle: {width: 0.04, height: 0.03}}"),
            "{m}"
        );
    }
}
