//! The solver reads no environment variable but the documented ones: a debugging switch left
//! in the core (an `XNOBORDER` that turned off the contact borders shipped for a session)
//! would change a user's run from outside the model, where nothing records it. Every name a
//! source file outside its tests passes to `env::var`/`env::var_os` must be listed here and
//! documented under `docs/`.

mod common;

/// Environment variables the core may read, each documented in `docs/`.
const ALLOWED: &[&str] = &["FLEXDYN_DEBUG_PANICS"];

/// The names passed to `env::var(` or `env::var_os(` as string literals, before the file's
/// tests; a call with anything else (a computed name) is reported as `?`.
fn names_read(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in text.lines() {
        let line = line.trim_start();
        if line.starts_with("#[cfg(test)]") {
            break;
        }
        if line.starts_with("//") {
            continue;
        }
        for call in ["env::var_os(", "env::var("] {
            let mut rest = line;
            while let Some(i) = rest.find(call) {
                rest = &rest[i + call.len()..];
                let name = rest
                    .strip_prefix('"')
                    .and_then(|r| r.split('"').next())
                    .unwrap_or("?");
                out.push(name.to_string());
            }
        }
    }
    out
}

#[test]
fn only_documented_environment_variables_are_read() {
    let mut unexpected = Vec::new();
    for (rel, f) in common::rust_sources() {
        for name in names_read(&std::fs::read_to_string(&f).unwrap()) {
            if !ALLOWED.contains(&name.as_str()) {
                unexpected.push(format!("{rel}: {name}"));
            }
        }
    }
    assert!(
        unexpected.is_empty(),
        "environment variables read by the solver that tests/environment.rs does not allow: \
         {unexpected:?}"
    );
    let docs = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs");
    let text: String = std::fs::read_dir(docs)
        .unwrap()
        .filter_map(|e| std::fs::read_to_string(e.unwrap().path()).ok())
        .collect();
    for name in ALLOWED {
        assert!(
            text.contains(name),
            "{name} is read but not documented in docs/"
        );
    }
}

#[test]
fn a_name_read_is_found_and_tests_are_skipped() {
    let text = "let a = std::env::var_os(\"ONE\");\nif std::env::var(\"TWO\").is_ok() {}\n\
                // std::env::var(\"COMMENT\")\n#[cfg(test)]\nstd::env::var(\"TEST\")";
    assert_eq!(names_read(text), ["ONE", "TWO"]);
}
