//! The workspace's crates can be published: no source of a crate (its
//! `src/`, `examples/` and build script, unit tests included) embeds a file
//! from outside the crate's directory with `include_str!`, `include_bytes!`,
//! `include!` or `#[path]`, since a published crate holds only its own
//! directory. (`cargo package --no-verify` in CI does not build the packages;
//! this is the check of what building them would need. Integration tests
//! under `tests/` may read the repository's files at run time.)

use std::path::{Component, Path, PathBuf};

fn crates_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("crates/")
        .to_path_buf()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `path` with `.` and `..` resolved lexically (symbolic links are kept: a
/// link inside a crate is packaged as the file it points to).
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// The first string literal of `text` (after optional spaces), unescaped
/// only as far as paths need.
fn leading_literal(text: &str) -> Option<&str> {
    let rest = text.trim_start().strip_prefix('"')?;
    rest.find('"').map(|end| &rest[..end])
}

/// The files a Rust source embeds or declares as modules: each with the
/// path it resolves to and the line that names it.
fn embedded_paths(file: &Path, crate_dir: &Path, text: &str) -> Vec<(PathBuf, usize)> {
    let dir = file.parent().expect("a file's directory");
    let mut found = Vec::new();
    for (number, line) in text.lines().enumerate() {
        for marker in ["include_str!(", "include_bytes!(", "include!("] {
            let mut rest = line;
            while let Some(at) = rest.find(marker) {
                rest = &rest[at + marker.len()..];
                if let Some(literal) = leading_literal(rest) {
                    found.push((dir.join(literal), number + 1));
                } else if let Some(tail) = rest
                    .trim_start()
                    .strip_prefix("concat!(env!(\"CARGO_MANIFEST_DIR\"),")
                    && let Some(literal) = leading_literal(tail)
                {
                    found.push((crate_dir.join(literal.trim_start_matches('/')), number + 1));
                }
            }
        }
        if let Some(at) = line.find("#[path = ")
            && let Some(literal) = leading_literal(&line[at + "#[path = ".len()..])
        {
            found.push((dir.join(literal), number + 1));
        }
    }
    found
}

#[test]
fn no_crate_embeds_a_file_from_outside_it() {
    let mut crates = Vec::new();
    for entry in std::fs::read_dir(crates_dir()).expect("crates/") {
        let path = entry.expect("entry").path();
        if path.join("Cargo.toml").is_file() {
            crates.push(path);
        }
    }
    assert!(
        crates.len() >= 3,
        "expected the workspace's crates: {crates:?}"
    );
    let mut outside = Vec::new();
    let mut checked = 0;
    for crate_dir in &crates {
        let mut files = Vec::new();
        rust_files(&crate_dir.join("src"), &mut files);
        rust_files(&crate_dir.join("examples"), &mut files);
        let build_script = crate_dir.join("build.rs");
        if build_script.is_file() {
            files.push(build_script);
        }
        let root = normalise(crate_dir);
        for file in files {
            let text = std::fs::read_to_string(&file).expect("read source");
            for (path, line) in embedded_paths(&file, crate_dir, &text) {
                checked += 1;
                if !normalise(&path).starts_with(&root) {
                    outside.push(format!(
                        "{}:{line}: {}",
                        file.display(),
                        normalise(&path).display()
                    ));
                }
            }
        }
    }
    assert!(checked > 10, "found only {checked} embedded files");
    assert!(
        outside.is_empty(),
        "files embedded from outside their crate (move them into it):\n{}",
        outside.join("\n")
    );
}

#[test]
fn embedded_paths_are_found_and_resolved() {
    let crate_dir = Path::new("/w/crates/a");
    let file = Path::new("/w/crates/a/src/scene/mod.rs");
    let text = "const A: &str = include_str!(\"default.toml\");\n\
                let b = include_bytes!( \"../../../../scenes/x.toml\");\n\
                let c = include_str!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/../../docs/d.md\"));\n\
                #[path = \"support/e.rs\"]\n";
    let found: Vec<(PathBuf, usize)> = embedded_paths(file, crate_dir, text)
        .into_iter()
        .map(|(p, l)| (normalise(&p), l))
        .collect();
    assert_eq!(
        found,
        vec![
            (PathBuf::from("/w/crates/a/src/scene/default.toml"), 1),
            (PathBuf::from("/w/scenes/x.toml"), 2),
            (PathBuf::from("/w/docs/d.md"), 3),
            (PathBuf::from("/w/crates/a/src/scene/support/e.rs"), 4),
        ]
    );
    let root = normalise(crate_dir);
    let inside: Vec<bool> = found.iter().map(|(p, _)| p.starts_with(&root)).collect();
    assert_eq!(inside, [true, false, false, true]);
}
