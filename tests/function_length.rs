//! Functions stay short (issue 18): no function outside tests longer than `LIMIT` lines,
//! except those in `KNOWN`, which still wait to be split — each at most its listed length, so
//! the list only shrinks (the test fails on a new long function, on a listed one that grew,
//! and on a listed one that is now short or gone, which must leave the list). Lengths count the
//! lines from `fn` to its closing brace in rustfmt's layout.

mod common;

use std::collections::BTreeMap;

const LIMIT: usize = 80;

/// (file, function, its length now): to be split.
const KNOWN: &[(&str, &str, usize)] = &[];

/// Every function (outside a file's tests) with its length: (file, name) → lines.
fn functions() -> BTreeMap<(String, String), usize> {
    let mut out = BTreeMap::new();
    for (rel, f) in common::rust_sources() {
        let text = std::fs::read_to_string(&f).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let end = lines
            .iter()
            .position(|l| l.trim_start().starts_with("#[cfg(test)]"))
            .unwrap_or(lines.len());
        for (i, line) in lines[..end].iter().enumerate() {
            let Some(name) = fn_name(line) else { continue };
            let indent = line.len() - line.trim_start().len();
            // The body ends at the first `}` at the `fn`'s indentation (a signature ending
            // in `;` declares a trait method without a body).
            let close = lines[i..end].iter().position(|l| {
                l.len() - l.trim_start().len() == indent && l.trim_start().starts_with('}')
            });
            let semicolon = lines[i..end]
                .iter()
                .position(|l| l.trim_end().ends_with(';'));
            let opens = lines[i..end]
                .iter()
                .position(|l| l.trim_end().ends_with('{'));
            if let (Some(c), Some(o)) = (close, opens) {
                if semicolon.is_none_or(|s| s > o) {
                    let key = (rel.clone(), name);
                    let len = c + 1;
                    out.entry(key)
                        .and_modify(|v: &mut usize| *v = (*v).max(len))
                        .or_insert(len);
                }
            }
        }
    }
    out
}

fn fn_name(line: &str) -> Option<String> {
    let t = line.trim_start();
    if t.starts_with("//") {
        return None;
    }
    let i = t.find("fn ")?;
    let before = &t[..i];
    let prefix_ok = before.split_whitespace().all(|w| {
        matches!(
            w,
            "pub" | "const" | "unsafe" | "async" | "extern" | "default"
        ) || w.starts_with("pub(")
    });
    if !prefix_ok {
        return None;
    }
    let name: String = t[i + 3..]
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    (!name.is_empty()).then_some(name)
}

#[test]
fn functions_stay_short() {
    let found = functions();
    let known: BTreeMap<(String, String), usize> = KNOWN
        .iter()
        .map(|(f, n, l)| ((f.to_string(), n.to_string()), *l))
        .collect();
    let mut problems = Vec::new();
    for ((file, name), len) in &found {
        match known.get(&(file.clone(), name.clone())) {
            None if *len > LIMIT => {
                problems.push(format!("{file}: fn {name} has {len} lines (limit {LIMIT})"))
            }
            Some(k) if len > k => problems.push(format!(
                "{file}: fn {name} grew to {len} lines (listed {k})"
            )),
            Some(_) if *len <= LIMIT => problems.push(format!(
                "{file}: fn {name} is short now ({len}): remove it from KNOWN"
            )),
            _ => {}
        }
    }
    for (key, _) in known.iter().filter(|(k, _)| !found.contains_key(*k)) {
        problems.push(format!(
            "{}: fn {} is gone: remove it from KNOWN",
            key.0, key.1
        ));
    }
    assert!(
        problems.is_empty(),
        "tests/function_length.rs:\n{}",
        problems.join("\n")
    );
}
