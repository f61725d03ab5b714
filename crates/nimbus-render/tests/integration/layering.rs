//! The crate's layers (see the crate docs): each module imports only the
//! layers below it, and a pass never imports another pass, in Rust
//! (`crate::` paths, including doc links) and in WGSL (`// import` lines).
//! Run with `--nocapture` to print the import graph.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, lowest first.
const LAYERS: [&str; 8] = [
    "core", "shader", "scene", "frame", "passes", "renderer", "headless", "export",
];

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn files(dir: &Path, extension: &str, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src readable") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            files(&path, extension, out);
        } else if path.extension().is_some_and(|e| e == extension) {
            out.push(path);
        }
    }
}

/// The module a path under `src/` belongs to: its layer, or
/// `passes::NAME` for a pass; `None` for the crate root.
fn module_of(relative: &str) -> Option<String> {
    let mut parts = relative.split('/');
    let first = parts.next()?.trim_end_matches(".rs");
    if first == "lib" {
        return None;
    }
    if first == "passes" {
        let pass = parts.next()?.trim_end_matches(".rs");
        return Some(if pass == "mod" {
            "passes".to_owned()
        } else {
            format!("passes::{pass}")
        });
    }
    Some(first.to_owned())
}

fn rank(module: &str) -> usize {
    let layer = module.split("::").next().unwrap_or(module);
    LAYERS
        .iter()
        .position(|l| *l == layer)
        .unwrap_or_else(|| panic!("{module} is not in a layer"))
}

/// The modules named by the `crate::` paths of a Rust source, e.g.
/// `crate::passes::rain::X` → `passes::rain`, `crate::{core::a, scene}` →
/// `core`, `scene`.
fn rust_imports(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("crate::") {
        rest = &rest[at + "crate::".len()..];
        let items: Vec<&str> = if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            group[..end].split(',').map(str::trim).collect()
        } else {
            vec![rest]
        };
        for item in items {
            let path: Vec<&str> = item
                .split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .next()
                .unwrap_or("")
                .split("::")
                .filter(|s| !s.is_empty())
                .collect();
            match path.as_slice() {
                ["passes", pass, ..] => found.push(format!("passes::{pass}")),
                [first, ..] => found.push((*first).to_owned()),
                [] => {}
            }
        }
    }
    found
}

/// Whether `from` may import `to`.
fn allowed(from: &str, to: &str) -> bool {
    if from == to || to == "passes" && from.starts_with("passes") {
        return true;
    }
    let (a, b) = (rank(from), rank(to));
    if a == b {
        // Two different passes, or a pass and the `passes` index.
        return from.split("::").next() != Some("passes");
    }
    b < a
}

#[test]
fn no_module_imports_a_higher_layer_or_a_sibling_pass() {
    let src = src_dir();
    let mut sources = Vec::new();
    files(&src, "rs", &mut sources);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut violations = Vec::new();
    for path in &sources {
        let relative = path
            .strip_prefix(&src)
            .expect("a file under src/")
            .to_string_lossy()
            .replace('\\', "/");
        let Some(from) = module_of(&relative) else {
            continue;
        };
        let text = std::fs::read_to_string(path).expect("a readable source file");
        for to in rust_imports(&text) {
            if !LAYERS.contains(&to.split("::").next().unwrap_or("")) {
                violations.push(format!(
                    "{relative}: crate::{to} is a re-export; name the module's own path"
                ));
                continue;
            }
            if to != from {
                graph.entry(from.clone()).or_default().insert(to.clone());
            }
            if !allowed(&from, &to) {
                violations.push(format!("{relative} ({from}) imports {to}"));
            }
        }
    }
    let mut wgsl = Vec::new();
    files(&src, "wgsl", &mut wgsl);
    for path in &wgsl {
        let relative = path
            .strip_prefix(&src)
            .expect("a file under src/")
            .to_string_lossy()
            .replace('\\', "/");
        let from = module_of(&relative).expect("WGSL lives in a module");
        for line in std::fs::read_to_string(path)
            .expect("a readable WGSL file")
            .lines()
        {
            if let Some(name) = line.strip_prefix("// import ") {
                let to = module_of(name.trim()).expect("an import names a module's file");
                if !allowed(&from, &to) {
                    violations.push(format!("{relative} ({from}) imports {}", name.trim()));
                }
            }
        }
    }
    println!("import graph of nimbus-render (module -> what it imports):");
    for (from, to) in &graph {
        let list: Vec<&str> = to.iter().map(String::as_str).collect();
        println!("  {from} -> {}", list.join(", "));
    }
    assert!(
        violations.is_empty(),
        "layering violations:\n  {}",
        violations.join("\n  ")
    );
    // The graph is acyclic: every edge goes down a layer (or into a pass's
    // own `passes` index), checked above; the passes reach no sibling.
    assert!(graph.keys().any(|k| k.starts_with("passes::")));
}

/// The checker itself: it reads grouped paths and rejects a sibling pass.
#[test]
fn the_checker_reads_paths_and_rejects_what_it_should() {
    assert_eq!(
        rust_imports("use crate::{core::gpu, scene::Scene};\nlet x = crate::passes::rain::X;"),
        ["core", "scene", "passes::rain"]
    );
    assert!(allowed("passes::rain", "frame"));
    assert!(!allowed("passes::rain", "passes::stratus"));
    assert!(!allowed("scene", "frame"));
    assert!(!allowed("core", "shader"));
    assert!(allowed("renderer", "passes::rain"));
    assert_eq!(
        module_of("passes/stratus/radiosity.rs").as_deref(),
        Some("passes::stratus")
    );
    assert_eq!(module_of("shader/common.wgsl").as_deref(), Some("shader"));
}
