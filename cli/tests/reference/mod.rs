//! The guide's command reference (`docs/src/reference/cli.md`), generated from the clap
//! definition of the command line: every subcommand, its usage, its arguments and their
//! help. The test fails when the committed chapter differs from what the definition gives;
//! `UPDATE_DOCS=1` writes it again (as expect-test does for inline snapshots). Only with the
//! default features: without the viewer, `lewis view` is missing.

use std::fmt::Write as _;
use std::path::Path;

use clap::{Arg, ArgAction, Command, CommandFactory};

/// Where the chapter lives, from the repository's root.
const CHAPTER: &str = "docs/src/reference/cli.md";

/// The chapter for the command line `cli`.
fn markdown(mut cli: Command) -> String {
    cli.build();
    let mut out = String::from(
        "# Every command\n\n\
         <!-- Generated from the command line's definition (cli/src) by\n     \
         `UPDATE_DOCS=1 cargo test -p lewis --test commands reference`: do not edit. -->\n\n\
         Each command's `--help` says the same. Options of `lewis` itself (`-v`, `-q`) go\n\
         before or after the subcommand.\n",
    );
    command(&mut out, &cli, &[]);
    out
}

/// One command's section, then its subcommands'.
fn command(out: &mut String, cmd: &Command, parents: &[&str]) {
    let mut path: Vec<&str> = parents.to_vec();
    path.push(cmd.get_name());
    let title = path.join(" ");
    let level = "#".repeat(path.len().min(5) + 1);
    let _ = write!(out, "\n{level} `{title}`\n\n");
    if let Some(about) = cmd.get_long_about().or_else(|| cmd.get_about()) {
        let _ = write!(out, "{}\n\n", prose(about.to_string().trim_end()));
    }
    let usage = cmd.clone().render_usage().to_string();
    let usage = usage.trim_start_matches("Usage: ").trim_end();
    let _ = write!(out, "```text\n{usage}\n```\n");

    let args: Vec<&Arg> = cmd
        .get_arguments()
        .filter(|a| !a.is_hide_set())
        .filter(|a| !matches!(a.get_id().as_str(), "help" | "version"))
        .filter(|a| !a.is_global_set() || parents.is_empty())
        .collect();
    if !args.is_empty() {
        out.push('\n');
        for arg in args {
            argument(out, arg);
        }
    }
    let subcommands: Vec<&Command> = cmd
        .get_subcommands()
        .filter(|c| !c.is_hide_set() && c.get_name() != "help")
        .collect();
    if !subcommands.is_empty() {
        out.push_str("\nSubcommands:\n\n");
        for sub in &subcommands {
            let about = sub.get_about().map(ToString::to_string).unwrap_or_default();
            let about = prose(about.trim_end());
            let _ = writeln!(out, "- `{title} {}`: {about}", sub.get_name());
        }
    }
    for sub in subcommands {
        command(out, sub, &path);
    }
}

/// One argument as a list item: its forms, its value, its help, its default and choices.
fn argument(out: &mut String, arg: &Arg) {
    let value = || {
        arg.get_value_names().map_or_else(
            || format!("<{}>", arg.get_id().as_str().to_uppercase()),
            |names| {
                names
                    .iter()
                    .map(|n| format!("<{n}>"))
                    .collect::<Vec<_>>()
                    .join(" ")
            },
        )
    };
    let takes_value = matches!(arg.get_action(), ArgAction::Set | ArgAction::Append);
    let mut forms = Vec::new();
    if arg.is_positional() {
        let mut form = value();
        if matches!(arg.get_action(), ArgAction::Append)
            || arg.get_num_args().is_some_and(|n| n.max_values() > 1)
        {
            form.push_str("...");
        }
        forms.push(form);
    } else {
        if let Some(short) = arg.get_short() {
            forms.push(format!("-{short}"));
        }
        if let Some(long) = arg.get_long() {
            forms.push(format!("--{long}"));
        }
        if takes_value {
            let last = forms.pop().unwrap_or_default();
            forms.push(format!("{last} {}", value()));
        }
    }
    let forms = forms
        .iter()
        .map(|f| format!("`{f}`"))
        .collect::<Vec<_>>()
        .join(", ");
    let help = arg
        .get_long_help()
        .or_else(|| arg.get_help())
        .map(ToString::to_string)
        .unwrap_or_default();
    let help = prose(help.trim_end())
        .replace("\n\n", "\n")
        .replace('\n', "\n  ");
    let _ = write!(out, "- {forms}");
    if arg.is_required_set() {
        out.push_str(" (required)");
    }
    if !help.is_empty() {
        let _ = write!(out, ": {help}");
    }
    let defaults: Vec<String> = arg
        .get_default_values()
        .iter()
        .map(|v| v.to_string_lossy().into_owned())
        .collect();
    if !defaults.is_empty() && takes_value {
        let _ = write!(out, " (default: `{}`)", defaults.join(" "));
    }
    let choices: Vec<String> = arg
        .get_possible_values()
        .iter()
        .filter(|p| !p.is_hide_set())
        .map(|p| format!("`{}`", p.get_name()))
        .collect();
    if !choices.is_empty() && takes_value {
        let _ = write!(out, " (one of {})", choices.join(", "));
    }
    out.push('\n');
}

/// The chapter as the definition gives it, against the committed one.
#[test]
fn reference_chapter_lists_every_command_as_clap_defines_it() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(CHAPTER);
    let expected = markdown(lewis::Cli::command());
    if std::env::var_os("UPDATE_DOCS").is_some() {
        std::fs::write(&path, &expected).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == expected,
        "{CHAPTER} differs from the command line's definition: run \
         `UPDATE_DOCS=1 cargo test -p lewis --test commands reference` and commit it\n\
         (first difference at line {})",
        first_difference(&committed, &expected)
    );
}

/// The 1-based line of the first difference between two texts.
fn first_difference(a: &str, b: &str) -> usize {
    a.lines()
        .zip(b.lines())
        .position(|(x, y)| x != y)
        .unwrap_or_else(|| a.lines().count().min(b.lines().count()))
        + 1
}

/// Help text as Markdown: brackets outside code spans escaped, so that `[a, b]` is not
/// read as a link.
fn prose(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut in_code = false;
    for c in text.chars() {
        match c {
            '`' => in_code = !in_code,
            '[' | ']' if !in_code => out.push('\\'),
            _ => {}
        }
        out.push(c);
    }
    out
}
