//! The user guide (`docs/src/`) against the code, so that it cannot rot:
//!
//! - every fenced block marked `sh,test` runs, in a scratch copy of the repository with the
//!   `lewis` under test first on the `PATH`, and must exit 0;
//! - every key the robot file's and the world file's parsers accept is in its reference
//!   chapter (the keys are read from the parsers' own "expected one of" errors);
//! - every keyword of the mission script language is in its chapter;
//! - the interfaces chapter is generated from `interfaces/idl/`, and compared with the
//!   committed one (`UPDATE_DOCS=1` writes it again);
//! - the README stays at most 300 lines and ARCHITECTURE.md at most 4,000 words.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use lewis_interfaces::idl::{Field, FieldType, Idl, StructType, load_dir};
use lewis_tests::{lewis_exe, repo_root};

/// The marker of a block the test runs: ` ```sh,test `.
const RUNNABLE: &str = "sh,test";

/// A fenced block of a chapter.
#[derive(Debug)]
struct Block {
    /// The chapter, from `docs/src`.
    chapter: String,
    /// Its first line's number in the chapter.
    line: usize,
    /// Its text.
    text: String,
}

/// Every `sh,test` block of every chapter, in order.
fn runnable_blocks() -> Vec<Block> {
    let mut blocks = Vec::new();
    for chapter in chapters() {
        let text = std::fs::read_to_string(docs().join(&chapter)).unwrap();
        // Inside a block: `Some(None)` for one not run, `Some(Some(block))` for one run.
        let mut open: Option<Option<Block>> = None;
        for (index, line) in text.lines().enumerate() {
            let fence = line.trim_start().starts_with("```");
            match (&mut open, fence) {
                (None, true) => {
                    let info = line.trim_start().trim_start_matches('`').trim();
                    open = Some((info == RUNNABLE).then(|| Block {
                        chapter: chapter.clone(),
                        line: index + 2,
                        text: String::new(),
                    }));
                }
                (None, false) => {}
                (Some(_), true) => {
                    if let Some(Some(block)) = open.take() {
                        blocks.push(block);
                    }
                }
                (Some(block), false) => {
                    if let Some(block) = block {
                        block.text.push_str(line);
                        block.text.push('\n');
                    }
                }
            }
        }
    }
    blocks
}

/// `docs/src`.
fn docs() -> PathBuf {
    repo_root().join("docs/src")
}

/// Every chapter's path from `docs/src`, sorted.
fn chapters() -> Vec<String> {
    fn walk(dir: &Path, base: &Path, out: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(&path, base, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                let relative = path.strip_prefix(base).unwrap();
                out.push(relative.to_string_lossy().into_owned());
            }
        }
    }
    let mut out = Vec::new();
    walk(&docs(), &docs(), &mut out);
    out.sort();
    out
}

/// A scratch copy of the repository: each of its top-level entries linked (but `target`,
/// `.git` and what the guide's commands write), and `../shared` beside it, so that a
/// command writes its files there and never into the repository.
fn scratch() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let work = dir.path().join("repo");
    let root = repo_root();
    // logs/ is where commands write by default, and a replay writes beside its input: folders
    // of their own, with the reference recording linked in.
    link_all_but(&root, &work, &["target", ".git", "logs", "tests"]);
    link_all_but(&root.join("tests"), &work.join("tests"), &["data"]);
    link_all_but(
        &root.join("tests/data"),
        &work.join("tests/data"),
        &["reference"],
    );
    link_all_but(
        &root.join("tests/data/reference"),
        &work.join("tests/data/reference"),
        &[],
    );
    let shared = root.join("../shared");
    if shared.exists() {
        std::os::unix::fs::symlink(&shared, dir.path().join("shared")).unwrap();
    }
    dir
}

/// Makes `to` a folder of links to each entry of `from` but those named in `except`.
fn link_all_but(from: &Path, to: &Path, except: &[&str]) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap().flatten() {
        let name = entry.file_name();
        if name.to_str().is_some_and(|n| except.contains(&n)) {
            continue;
        }
        std::os::unix::fs::symlink(entry.path(), to.join(&name)).unwrap();
    }
}

#[test]
fn every_runnable_command_of_the_guide_works() {
    let blocks = runnable_blocks();
    assert!(
        blocks.len() >= 10,
        "only {} runnable blocks found",
        blocks.len()
    );
    let scratch = scratch();
    // The guide says `lewis`: a folder first on PATH where that name is the binary under
    // test, whatever LEWIS_EXE names it.
    let bin = scratch.path().join("bin");
    std::fs::create_dir(&bin).unwrap();
    std::os::unix::fs::symlink(lewis_exe(), bin.join("lewis")).unwrap();
    let path = std::env::join_paths(std::iter::once(bin).chain(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    )))
    .unwrap();
    let work = scratch.path().join("repo");
    let mut failures = Vec::new();
    for (index, block) in blocks.iter().enumerate() {
        let output = Command::new("bash")
            .args(["-euo", "pipefail", "-c", &block.text])
            .current_dir(&work)
            .env("PATH", &path)
            .env(
                "LEWIS_NAMESPACE",
                format!("docs-{}-{index}", std::process::id()),
            )
            .env("NO_COLOR", "1")
            .env_remove("LEWIS_EXE")
            .output()
            .unwrap();
        if !output.status.success() {
            failures.push(format!(
                "docs/src/{}:{}: {}\n{}\n--- stdout\n{}\n--- stderr\n{}",
                block.chapter,
                block.line,
                output.status,
                block.text.trim_end(),
                tail(&String::from_utf8_lossy(&output.stdout)),
                tail(&String::from_utf8_lossy(&output.stderr)),
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// The last 30 lines of a command's output.
fn tail(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(30)..].join("\n")
}

/// The keys serde names in an "unknown field `zz_probe`, expected one of `a`, `b`" error.
fn expected_keys(error: &str) -> BTreeSet<String> {
    let Some((_, rest)) = error.split_once("expected") else {
        panic!("no list of expected keys in: {error}");
    };
    let rest = rest.lines().next().unwrap_or_default();
    rest.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_owned)
        .collect()
}

/// The text of the section of `chapter` under the heading line `heading`, to the next
/// heading of the same or a higher level.
fn section<'a>(chapter: &'a str, heading: &str) -> &'a str {
    let start = chapter
        .find(&format!("\n{heading}\n"))
        .unwrap_or_else(|| panic!("no heading `{heading}`"))
        + 1;
    let level = heading.chars().take_while(|c| *c == '#').count();
    let body = &chapter[start + heading.len()..];
    let end = body
        .match_indices("\n#")
        .find(|(at, _)| {
            let hashes = body[at + 1..].chars().take_while(|c| *c == '#').count();
            hashes <= level && body[at + 1 + hashes..].starts_with(' ')
        })
        .map_or(body.len(), |(at, _)| at);
    &body[..end]
}

/// The keys of `keys` that `text` does not name at the start of a code span: `` `key` ``,
/// `` `key = ...` `` or `` `key ARGUMENTS` ``.
fn missing(text: &str, keys: &BTreeSet<String>) -> Vec<String> {
    keys.iter()
        .filter(|k| !text.contains(&format!("`{k}`")) && !text.contains(&format!("`{k} ")))
        .cloned()
        .collect()
}

/// Each table of the robot file: the heading of its section in the chapter, and a robot
/// file with an unknown key `zz_probe` in that table.
const ROBOT_TABLES: &[(&str, &str)] = &[
    ("## The file", "zz_probe = 1\n[robot]\nname = \"p\"\n"),
    ("## `[robot]`", "[robot]\nname = \"p\"\nzz_probe = 1\n"),
    (
        "## `[broker]`",
        "[robot]\nname = \"p\"\n[broker]\nzz_probe = 1\n",
    ),
    (
        "### `restart`",
        "[robot]\nname = \"p\"\n[broker]\nrestart = { zz_probe = 1 }\n",
    ),
    (
        "### `[broker.interfaces.NAME]`",
        "[robot]\nname = \"p\"\n[broker.interfaces.RangeFinder]\nzz_probe = 1\n",
    ),
    (
        "### `checks`",
        "[robot]\nname = \"p\"\n[broker.interfaces.RangeFinder]\nchecks = { zz_probe = 1 }\n",
    ),
    (
        "## `[[services]]`",
        "[robot]\nname = \"p\"\n[[services]]\nname = \"s\"\nzz_probe = 1\n",
    ),
    (
        "### `provides`",
        "[robot]\nname = \"p\"\n[[services]]\nname = \"s\"\nprovides = [{ interface = \"RangeFinder\", quality = 1, cost = 1, zz_probe = 1 }]\n",
    ),
    (
        "### `requires`",
        "[robot]\nname = \"p\"\n[[services]]\nname = \"s\"\nrequires = [{ interface = \"Distance\", zz_probe = 1 }]\n",
    ),
    (
        "## `[[hosts]]`",
        "[robot]\nname = \"p\"\n[[hosts]]\nname = \"robot\"\nzz_probe = 1\n",
    ),
    (
        "## `[network]`",
        "[robot]\nname = \"p\"\n[network]\nzz_probe = 1\n",
    ),
    (
        "### `[network.tls]`",
        "[robot]\nname = \"p\"\n[network.tls]\nzz_probe = 1\n",
    ),
];

#[test]
fn every_key_the_robot_file_accepts_is_in_its_chapter() {
    let interfaces = lewis_interfaces::interface_names();
    assert_every_key_documented("reference/robot-file.md", ROBOT_TABLES, |heading, text| {
        match lewis_robot::parse(text, Path::new("probe.toml"), &interfaces) {
            Ok(_) => panic!("the probe of {heading} loaded:\n{text}"),
            Err(e) => e.to_string(),
        }
    });
}

/// Checks that `chapter` names, under each table's heading, every key its parser lists
/// when `probe` feeds it that table with an unknown key (and returns the error's text).
fn assert_every_key_documented(
    chapter: &str,
    tables: &[(&str, &str)],
    mut probe: impl FnMut(&str, &str) -> String,
) {
    let text = std::fs::read_to_string(docs().join(chapter)).unwrap();
    let mut gaps = Vec::new();
    for (heading, table) in tables {
        let error = probe(heading, table);
        let keys = expected_keys(&error);
        assert!(!keys.is_empty(), "{heading}: {error}");
        let absent = missing(section(&text, heading), &keys);
        if !absent.is_empty() {
            gaps.push(format!("{heading}: {}", absent.join(", ")));
        }
    }
    assert!(
        gaps.is_empty(),
        "docs/src/{chapter} lacks keys the parser accepts:\n{}",
        gaps.join("\n")
    );
}

/// Each table of the world file: its section's heading, and the lines that put an unknown
/// key `zz_probe` in it after the required header.
const WORLD_TABLES: &[(&str, &str)] = &[
    ("## The header", "zz_probe = 1\n"),
    (
        "## `[[objects]]`",
        "[[objects]]\nkind = \"wall\"\nzz_probe = 1\n",
    ),
    ("## `[queue]`", "[queue]\nzz_probe = 1\n"),
    ("## `[[walks]]`", "[[walks]]\nzz_probe = 1\n"),
];

#[test]
fn every_key_the_world_file_accepts_is_in_its_chapter() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(
        repo_root().join("robots/worlds/conference/map.png"),
        dir.path().join("map.png"),
    )
    .unwrap();
    let header = "map = \"map.png\"\nmetres_per_pixel = 0.05\nsize_m = [40.0, 25.0]\n";
    assert_every_key_documented("reference/world-file.md", WORLD_TABLES, |heading, lines| {
        std::fs::write(dir.path().join("world.toml"), format!("{header}{lines}")).unwrap();
        match lewis_sim::world::World::load(dir.path()) {
            Ok(_) => panic!("the probe of {heading} loaded"),
            Err(e) => e.to_string(),
        }
    });
}

#[test]
fn every_keyword_of_the_script_language_is_in_its_chapter() {
    let chapter = std::fs::read_to_string(docs().join("reference/script.md")).unwrap();
    let keywords: BTreeSet<String> = lewis_sequencer::script::KEYWORDS
        .iter()
        .map(|k| (*k).to_owned())
        .collect();
    let absent = missing(&chapter, &keywords);
    assert!(
        absent.is_empty(),
        "docs/src/reference/script.md lacks the keywords {}",
        absent.join(", ")
    );
}

/// The interfaces chapter, generated.
fn interfaces_chapter(idl: &Idl) -> String {
    let mut out = String::from(
        "# Interfaces\n\n\
         <!-- Generated from interfaces/idl/*.xml by\n     \
         `UPDATE_DOCS=1 cargo test -p lewis-tests --test it docs::`: do not edit. -->\n\n\
         Every interface of `interfaces/idl/`, as its XML defines it: what a provider\n\
         publishes and the commands it accepts. Each becomes a Rust type\n\
         (`lewis_interfaces::msg::NAME`) and a ros2msg schema (`lewis_interfaces/msg/NAME`);\n\
         `lewis idl show NAME` prints the schema, `--format xml` or `--format rust` the rest.\n\
         Every publication, command and reply starts with the common `Header` (provider,\n\
         sequence number, publish time, provenance), which the tables leave out.\n",
    );
    for interface in &idl.interfaces {
        let _ = write!(out, "\n## {} {}\n\n", interface.name, interface.version);
        if let Some(description) = &interface.description {
            let _ = write!(out, "{}\n\n", one_paragraph(description));
        }
        let file = interface
            .file
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let _ = writeln!(out, "Defined in `interfaces/idl/{file}`.");
        out.push_str("\n### Published\n\n");
        fields(&mut out, &interface.publication);
        for command in &interface.commands {
            let _ = write!(out, "\n### Command `{}`\n\n", command.name);
            if let Some(description) = &command.description {
                let _ = write!(out, "{}\n\n", one_paragraph(description));
            }
            out.push_str("Arguments:\n\n");
            fields(&mut out, &command.request);
            out.push_str("\nReply:\n\n");
            fields(&mut out, &command.reply);
        }
    }
    out.push_str(
        "\n## Types\n\nThe compound types the interfaces use (`interfaces/idl/types.xml`).\n",
    );
    for ty in &idl.types {
        let _ = write!(out, "\n### {}\n\n", ty.name);
        if let Some(description) = &ty.description {
            let _ = write!(out, "{}\n\n", one_paragraph(description));
        }
        fields(&mut out, ty);
    }
    out
}

/// A struct's fields as a table, or a line saying there are none.
fn fields(out: &mut String, ty: &StructType) {
    if ty.fields.is_empty() {
        out.push_str("Nothing beyond the header.\n");
        return;
    }
    out.push_str("| field | type | unit | meaning |\n|---|---|---|---|\n");
    for field in &ty.fields {
        let _ = writeln!(
            out,
            "| `{}` | {} | {} | {} |",
            field.name,
            type_name(field),
            field.unit.as_deref().unwrap_or(""),
            meaning(field).replace('|', "\\|"),
        );
    }
}

/// A field's type as written in the IDL, with its array's size.
fn type_name(field: &Field) -> String {
    let base = match &field.ty {
        FieldType::Primitive { idl_name, .. } => idl_name.clone(),
        FieldType::Struct(name) => name.clone(),
    };
    let written = match (field.is_array, &field.array_size) {
        (true, Some(size)) => format!("{base}[{size}]"),
        (true, None) => format!("{base}[]"),
        (false, _) => base,
    };
    format!("`{written}`")
}

/// A field's description, and its vocabulary's words.
fn meaning(field: &Field) -> String {
    let mut text = field
        .description
        .as_deref()
        .map(one_paragraph)
        .unwrap_or_default();
    if !field.values.is_empty() {
        let words: Vec<String> = field
            .values
            .iter()
            .map(|v| format!("`{}`", v.name))
            .collect();
        if !text.is_empty() {
            text.push(' ');
        }
        let _ = write!(text, "One of {}.", words.join(", "));
    }
    text
}

/// A description's lines joined into one paragraph.
fn one_paragraph(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[test]
fn the_interfaces_chapter_is_generated_from_the_idl() {
    let idl = load_dir(&repo_root().join("interfaces/idl")).unwrap();
    let expected = interfaces_chapter(&idl);
    let path = docs().join("reference/interfaces.md");
    if std::env::var_os("UPDATE_DOCS").is_some() {
        std::fs::write(&path, &expected).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    let first = committed
        .lines()
        .zip(expected.lines())
        .position(|(a, b)| a != b)
        .unwrap_or_else(|| committed.lines().count().min(expected.lines().count()))
        + 1;
    assert!(
        committed == expected,
        "docs/src/reference/interfaces.md differs from interfaces/idl (first at line {first}): \
         run `UPDATE_DOCS=1 cargo test -p lewis-tests --test it docs::` and commit it"
    );
}

#[test]
fn the_readme_and_the_architecture_stay_short_enough_to_read() {
    // The README says what Lewis is and where to read on; the guide holds the rest. The
    // architecture is a map, not a changelog: history goes to commit messages.
    let readme = std::fs::read_to_string(repo_root().join("README.md")).unwrap();
    let lines = readme.lines().count();
    assert!(lines <= 300, "README.md has {lines} lines: at most 300");
    let architecture = std::fs::read_to_string(repo_root().join("ARCHITECTURE.md")).unwrap();
    let words = architecture.split_whitespace().count();
    assert!(
        words <= 4000,
        "ARCHITECTURE.md has {words} words: at most 4,000"
    );
}
