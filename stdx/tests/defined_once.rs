//! The `file:line:column` diagnostic is written once, here: a search of the workspace's
//! sources for its definitions finds one of each, in `stdx/src/diagnostic.rs`.
//!
//! (It was written four times: the IDL's, the script's, the robot file's and the world
//! file's; a fifth copy would be found here.)

use std::path::{Path, PathBuf};

/// Every `.rs` file of the workspace but build output and this test, with its text.
fn workspace_sources() -> Vec<(PathBuf, String)> {
    fn walk(dir: &Path, out: &mut Vec<(PathBuf, String)>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name();
            let name = name.to_string_lossy();
            if path.is_dir() {
                if !(name.starts_with('.') || name == "target" || name == "node_modules") {
                    walk(&path, out);
                }
            } else if name.ends_with(".rs")
                && !path.ends_with("tests/defined_once.rs")
                && let Ok(text) = std::fs::read_to_string(&path)
            {
                out.push((path, text));
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut out = Vec::new();
    walk(&root, &mut out);
    assert!(out.len() > 100, "the workspace's sources were not found");
    out
}

/// The files (relative to the workspace) with a line that defines `item` (`struct
/// Diagnostic`): the words followed by a character that cannot go on a name.
fn definitions(sources: &[(PathBuf, String)], item: &str) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut found = Vec::new();
    for (path, text) in sources {
        for line in text.lines() {
            let line = line.trim_start();
            let line = line.strip_prefix("pub ").unwrap_or(line);
            let line = line.strip_prefix("pub(crate) ").unwrap_or(line);
            if let Some(rest) = line.strip_prefix(item)
                && !rest.starts_with(|c: char| c.is_alphanumeric() || c == '_')
            {
                let shown = path.strip_prefix(&root).unwrap_or(path);
                found.push(shown.display().to_string());
            }
        }
    }
    found
}

#[test]
fn the_diagnostic_its_list_severity_and_position_are_defined_once() {
    let sources = workspace_sources();
    for item in [
        "struct Diagnostic",
        "struct Diagnostics",
        "enum Severity",
        "fn line_column",
        "fn of_offset",
    ] {
        let found = definitions(&sources, item);
        assert_eq!(
            found.len(),
            1,
            "`{item}` should be defined once, in stdx; found in {found:?}"
        );
        assert!(found[0].starts_with("stdx/src/"), "{item}: {found:?}");
    }
}
