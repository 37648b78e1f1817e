//! The fault vocabulary and the noise generator are written once, here in the service
//! crate: a search of the workspace's sources finds one definition of each fault family,
//! one table of their words and one xorshift step.
//!
//! (The fault words were written five times: live faults, replay, two in the emulators and
//! the drivers; the xorshift noise four times.)

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
    let mut out = Vec::new();
    walk(&root(), &mut out);
    assert!(out.len() > 100, "the workspace's sources were not found");
    out
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The files (relative to the workspace) holding a line for which `matches` holds, once
/// per line.
fn lines_where(sources: &[(PathBuf, String)], matches: impl Fn(&str) -> bool) -> Vec<String> {
    let root = root();
    let mut found = Vec::new();
    for (path, text) in sources {
        for line in text.lines().filter(|line| matches(line.trim())) {
            let shown = path.strip_prefix(&root).unwrap_or(path).display();
            found.push(format!("{shown}: {}", line.trim()));
        }
    }
    found
}

/// Whether `line` defines `item` (`enum ServiceFault`), whatever its visibility.
fn defines(line: &str, item: &str) -> bool {
    let line = line.strip_prefix("pub ").unwrap_or(line);
    let line = line.strip_prefix("pub(crate) ").unwrap_or(line);
    line.strip_prefix(item)
        .is_some_and(|rest| !rest.starts_with(|c: char| c.is_alphanumeric() || c == '_'))
}

fn assert_only_in(found: &[String], file: &str, count: usize, what: &str) {
    assert_eq!(
        found.len(),
        count,
        "{what}: expected {count}, found {found:#?}"
    );
    assert!(
        found.iter().all(|f| f.starts_with(file)),
        "{what}: only {file} may hold it; found {found:#?}"
    );
}

#[test]
fn each_fault_family_and_its_words_are_defined_once() {
    let sources = workspace_sources();
    for item in ["enum ServiceFault", "enum LineFault", "struct LineFaults"] {
        let found = lines_where(&sources, |line| defines(line, item));
        assert_only_in(&found, "service/src/fault.rs", 1, item);
    }
    // The old names of the copies are gone as definitions (they live on as re-exports).
    for item in [
        "enum FaultKind",
        "enum InjectedFault",
        "enum Fault",
        "struct Faults",
        "struct FaultPlan",
        "struct Unplug",
    ] {
        let found = lines_where(&sources, |line| defines(line, item));
        let allowed = usize::from(item == "struct Unplug");
        assert_eq!(found.len(), allowed, "{item}: {found:#?}");
    }
    // A word table maps a word to a fault or back, in a match arm (`"stall" =>`,
    // `=> "stall"`, `("noise", value) =>`): one of each word.
    for word in [
        "\"stall\"",
        "\"out-of-service\"",
        "\"garbage\"",
        "\"bad-crc-every\"",
    ] {
        let found = lines_where(&sources, |line| {
            line.contains(word)
                && (line.contains(&format!("=> {word}"))
                    || line.contains(&format!("{word} =>"))
                    || (line.starts_with(&format!("({word},")) && line.contains("=>")))
        });
        assert_only_in(&found, "service/src/fault.rs", 1, word);
    }
}

#[test]
fn the_noise_generators_step_is_written_once() {
    let sources = workspace_sources();
    // The xorshift step (`x ^= x << 13`), and xoshiro's last rotation.
    let found = lines_where(&sources, |line| {
        line.contains("^=") && line.contains("<< 13")
    });
    assert_only_in(&found, "service/src/rng.rs", 1, "xorshift step");
    let found = lines_where(&sources, |line| line.contains("rotate_left(45)"));
    assert_only_in(&found, "service/src/rng.rs", 1, "xoshiro256++ step");
}
