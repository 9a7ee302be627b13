//! The crate's layering (issue 18): the math layer imports nothing else from the crate; the
//! kernels (beams, joints, elements) and the runtime state import nothing from the file format
//! or the layers above them; the file format imports nothing from the physics. Checked on the
//! `crate::` paths of every source file outside its tests. `KNOWN` lists the imports that still
//! run against the layering, to be removed one by one: the test fails on any new one, and on a
//! listed one that is gone (so the list only shrinks).

mod common;

use std::collections::BTreeSet;

/// The kernels: beams, joints and the other elements build on each other.
const KERNELS: &[&str] = &["beam", "elements", "joints", "state", "math"];

/// (layer, the top-level modules it may import besides itself); any other is against the
/// layering: file format (`model`) → `compile` → `system` and the kernels → `math`. Layers
/// not listed (integrator, simulation, sensors, Python glue) run the compiled system and may
/// import what they need.
const RULES: &[(&str, &[&str])] = &[
    ("math", &[]),
    ("state", &["math"]),
    ("beam", KERNELS),
    ("joints", KERNELS),
    ("elements", KERNELS),
    ("system", KERNELS),
    ("model", &["math"]),
    (
        "compile",
        &[
            "model", "system", "beam", "elements", "joints", "state", "math",
        ],
    ),
];

/// Imports that still run against the layering: (file, imported module).
const KNOWN: &[(&str, &str)] = &[];

fn crate_imports(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for line in text.lines() {
        let line = line.trim_start();
        if line.starts_with("#[cfg(test)]") {
            break; // tests sit at the end of a file and may use anything
        }
        if line.starts_with("//") {
            continue;
        }
        let mut rest = line;
        while let Some(i) = rest.find("crate::") {
            rest = &rest[i + 7..];
            let name: String = rest
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            out.insert(name);
        }
    }
    out
}

#[test]
fn imports_follow_the_layering() {
    let mut found = BTreeSet::new();
    for (rel, f) in common::rust_sources() {
        let layer = rel
            .trim_start_matches("src/")
            .split('/')
            .next()
            .unwrap()
            .trim_end_matches(".rs")
            .to_string();
        let Some((_, allowed)) = RULES.iter().find(|(l, _)| *l == layer) else {
            continue;
        };
        for m in crate_imports(&std::fs::read_to_string(&f).unwrap()) {
            if !m.is_empty() && m != layer && !allowed.contains(&m.as_str()) {
                found.insert((rel.clone(), m));
            }
        }
    }
    let known: BTreeSet<(String, String)> = KNOWN
        .iter()
        .map(|(f, m)| (f.to_string(), m.to_string()))
        .collect();
    let new: Vec<_> = found.difference(&known).collect();
    let gone: Vec<_> = known.difference(&found).collect();
    assert!(
        new.is_empty(),
        "imports against the layering (see tests/layering.rs): {new:?}"
    );
    assert!(
        gone.is_empty(),
        "fixed, so remove from KNOWN in tests/layering.rs: {gone:?}"
    );
}
