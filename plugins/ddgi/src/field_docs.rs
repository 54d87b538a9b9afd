//! The doc comments of the fields of [`DdgiVolume`], [`DdgiAdaptive`] and [`DdgiWeights`] as
//! plain text, by field name ([`field_docs`]): what an editor shows as each field's tooltip (the
//! DDGI overlay's settings editors).
//!
//! The documentation has one source: the doc comments in this crate's `volume.rs`, which this
//! module compiles in with `include_str!` and parses once, so a tooltip cannot drift from the
//! docs. Why not a macro that emits both the struct and a table, or a build script: a macro would
//! move ddgi's most-read type into a macro invocation (rustdoc, rust-analyzer and readers all see
//! it worse), and a build script gains nothing over parsing a string the compiler already holds.
//!
//! [`DdgiVolume`]: crate::DdgiVolume
//! [`DdgiAdaptive`]: crate::DdgiAdaptive
//! [`DdgiWeights`]: crate::DdgiWeights

use std::collections::HashMap;
use std::sync::LazyLock;

/// The source the docs are read from: this crate's settings, as compiled.
const VOLUME_SOURCE: &str = include_str!("volume.rs");

/// The doc comment of every field of `struct_name` in this crate's `volume.rs`, by field name: the
/// `///` lines joined into one paragraph (blank doc lines keep a paragraph break), links written
/// as plain code.
pub fn field_docs(struct_name: &str) -> &'static HashMap<String, String> {
    static DOCS: LazyLock<HashMap<String, HashMap<String, String>>> = LazyLock::new(|| {
        ["DdgiVolume", "DdgiAdaptive", "DdgiWeights"].iter().map(|s| (s.to_string(), parse_field_docs(VOLUME_SOURCE, s))).collect()
    });
    static EMPTY: LazyLock<HashMap<String, String>> = LazyLock::new(HashMap::new);
    DOCS.get(struct_name).unwrap_or(&EMPTY)
}

/// The doc comments of the fields of `pub struct <name> {` in Rust source `source`, by field.
pub fn parse_field_docs(source: &str, name: &str) -> HashMap<String, String> {
    let mut out = HashMap::new();
    let open = format!("pub struct {name} {{");
    let Some(start) = source.find(&open) else { return out };
    let mut doc: Vec<&str> = Vec::new();
    for line in source[start + open.len()..].lines() {
        let line = line.trim();
        if line == "}" {
            break;
        }
        if let Some(text) = line.strip_prefix("///") {
            doc.push(text.strip_prefix(' ').unwrap_or(text));
        } else if let Some(rest) = line.strip_prefix("pub ") {
            if let Some((field, _)) = rest.split_once(':') {
                out.insert(field.trim().to_string(), plain_doc(&doc));
            }
            doc.clear();
        } else if !line.starts_with("#[") && !line.is_empty() && !line.starts_with("//") {
            doc.clear();
        }
    }
    out
}

/// Doc lines as one text: lines joined by spaces, blank lines as paragraph breaks, intra-doc links
/// (`` [`a`] ``, `` [`a`](b) ``) as `` `a` ``.
fn plain_doc(lines: &[&str]) -> String {
    let mut text = String::new();
    for line in lines {
        if line.is_empty() {
            text.push_str("\n\n");
        } else {
            if !text.is_empty() && !text.ends_with('\n') {
                text.push(' ');
            }
            text.push_str(line);
        }
    }
    let mut out = String::with_capacity(text.len());
    let mut rest = text.as_str();
    while let Some(i) = rest.find("[`") {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        match after.find("`]") {
            Some(j) => {
                out.push_str(&after[..j + 1]);
                rest = &after[j + 2..];
                if rest.starts_with('(')
                    && let Some(k) = rest.find(')')
                {
                    rest = &rest[k + 1..];
                }
            }
            None => {
                out.push('[');
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}
