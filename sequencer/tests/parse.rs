//! The parser on the paper's script, the extensions, and broken scripts (one clear error
//! each, at the right line and column).

use std::path::Path;

use expect_test::{Expect, expect};
use lewis_sequencer::{MemorySources, Script, TrustingResolver, check_with, parse};

const PAPER: &str = "\
start door
restart 3
recovery oops
use gui

state door /usr/bin/DoorNavigator
  action 0 trans sign

state sign /usr/bin/SignFollower
  action 0 trans sign
  action 1 trans queue

state queue /usr/bin/QueueStander
  action 0 trans register

state register /usr/bin/Register
  action 0 trans stop

state oops /usr/bin/Recovery
  action 0 trans stop
";

fn sources(files: &[(&str, &str)]) -> MemorySources {
    let mut sources = MemorySources::new();
    for (path, text) in files {
        sources.insert(path, *text);
    }
    sources
}

/// The script as compact text: every item with its place.
fn dump(script: &Script) -> String {
    let mut out: Vec<String> = Vec::new();
    let at =
        |l: &lewis_sequencer::Location| format!("{}:{}:{}", l.file.display(), l.line, l.column);
    if let Some(start) = &script.start {
        out.push(format!("start {} @{}", start.value, at(&start.location)));
    }
    if let Some(restart) = &script.restart {
        out.push(format!(
            "restart {} @{}",
            restart.value,
            at(&restart.location)
        ));
    }
    if let Some(recovery) = &script.recovery {
        out.push(format!(
            "recovery {} @{}",
            recovery.value,
            at(&recovery.location)
        ));
    }
    if let Some(gui) = &script.use_gui {
        out.push(format!("use gui @{}", at(gui)));
    }
    for var in &script.env {
        out.push(format!(
            "env {}={:?} @{}",
            var.key.value,
            var.value,
            at(&var.key.location)
        ));
    }
    for state in &script.states {
        let args: Vec<String> = state
            .args
            .iter()
            .map(|a| format!("{:?}", a.value))
            .collect();
        out.push(format!(
            "state {} @{} program {:?} @{} args [{}]",
            state.name.value,
            at(&state.name.location),
            state.program.value,
            at(&state.program.location),
            args.join(", ")
        ));
        if let Some(timeout) = &state.timeout_ns {
            out.push(format!(
                "  timeout {}ns @{}",
                timeout.value,
                at(&timeout.location)
            ));
        }
        if let Some(restart) = &state.restart {
            out.push(format!(
                "  restart {} @{}",
                restart.value,
                at(&restart.location)
            ));
        }
        for var in &state.env {
            out.push(format!(
                "  env {}={:?} @{}",
                var.key.value,
                var.value,
                at(&var.key.location)
            ));
        }
        for action in &state.actions {
            out.push(format!(
                "  action {} -> {} @{} (code @{}, target @{})",
                action.code.value,
                action.target.value,
                at(&action.location),
                at(&action.code.location),
                at(&action.target.location)
            ));
        }
    }
    out.iter().map(|line| format!("{line}\n")).collect()
}

/// Parses the first file (the others may be included) and shows the result or the errors.
fn check(files: &[(&str, &str)], expected: &Expect) {
    let actual = match parse(Path::new(files[0].0), &sources(files)) {
        Ok(script) => dump(&script),
        Err(diagnostics) => diagnostics.to_string(),
    };
    expected.assert_eq(&actual);
}

/// Parses and checks a broken script: exactly one finding, rendered.
fn check_broken(files: &[(&str, &str)], expected: &Expect) {
    let diagnostics = check_with(Path::new(files[0].0), &sources(files), &TrustingResolver)
        .map_or_else(|diagnostics| diagnostics, |checked| checked.warnings);
    assert_eq!(
        diagnostics.len(),
        1,
        "expected exactly one finding, got:\n{diagnostics}"
    );
    expected.assert_eq(&diagnostics.to_string());
}

/// The paper's script with line `line` (from 1) replaced by `replacement`.
fn paper_with(line: usize, replacement: &str) -> String {
    let mut lines: Vec<&str> = PAPER.lines().collect();
    lines[line - 1] = replacement;
    lines.join("\n")
}

#[test]
fn the_papers_script_parses_unchanged() {
    check(
        &[("mission.seq", PAPER)],
        &expect![[r#"
            start door @mission.seq:1:7
            restart 3 @mission.seq:2:1
            recovery oops @mission.seq:3:10
            use gui @mission.seq:4:1
            state door @mission.seq:6:7 program "/usr/bin/DoorNavigator" @mission.seq:6:12 args []
              action 0 -> sign @mission.seq:7:3 (code @mission.seq:7:10, target @mission.seq:7:18)
            state sign @mission.seq:9:7 program "/usr/bin/SignFollower" @mission.seq:9:12 args []
              action 0 -> sign @mission.seq:10:3 (code @mission.seq:10:10, target @mission.seq:10:18)
              action 1 -> queue @mission.seq:11:3 (code @mission.seq:11:10, target @mission.seq:11:18)
            state queue @mission.seq:13:7 program "/usr/bin/QueueStander" @mission.seq:13:13 args []
              action 0 -> register @mission.seq:14:3 (code @mission.seq:14:10, target @mission.seq:14:18)
            state register @mission.seq:16:7 program "/usr/bin/Register" @mission.seq:16:16 args []
              action 0 -> stop @mission.seq:17:3 (code @mission.seq:17:10, target @mission.seq:17:18)
            state oops @mission.seq:19:7 program "/usr/bin/Recovery" @mission.seq:19:12 args []
              action 0 -> stop @mission.seq:20:3 (code @mission.seq:20:10, target @mission.seq:20:18)
        "#]],
    );
}

#[test]
fn the_papers_script_checks_without_findings() {
    let checked = check_with(
        Path::new("mission.seq"),
        &sources(&[("mission.seq", PAPER)]),
        &TrustingResolver,
    )
    .unwrap();
    assert!(checked.warnings.is_empty(), "{}", checked.warnings);
}

#[test]
fn extensions_parse_with_their_places() {
    check(
        &[
            (
                "missions/main.seq",
                r#"# A mission with every extension.
start door   # trailing comment
restart 3
env ROBOT=lewis "GREETING=hello world"
include "parts/recovery.seq"

state door ./bin/door --speed 0.3 "two words" "tab\there"
  timeout 1.5s
  restart 5
  env LOG=debug
  action 0 trans stop
"#,
            ),
            (
                "missions/parts/recovery.seq",
                "recovery oops\n\tstate oops ../bin/recover # relative to this file\n\t\taction 0 trans stop\n",
            ),
        ],
        &expect![[r#"
            start door @missions/main.seq:2:7
            restart 3 @missions/main.seq:3:1
            recovery oops @missions/parts/recovery.seq:1:10
            env ROBOT="lewis" @missions/main.seq:4:5
            env GREETING="hello world" @missions/main.seq:4:17
            state oops @missions/parts/recovery.seq:2:8 program "../bin/recover" @missions/parts/recovery.seq:2:13 args []
              action 0 -> stop @missions/parts/recovery.seq:3:3 (code @missions/parts/recovery.seq:3:10, target @missions/parts/recovery.seq:3:18)
            state door @missions/main.seq:7:7 program "./bin/door" @missions/main.seq:7:12 args ["--speed", "0.3", "two words", "tab\there"]
              timeout 1500000000ns @missions/main.seq:8:3
              restart 5 @missions/main.seq:9:3
              env LOG="debug" @missions/main.seq:10:7
              action 0 -> stop @missions/main.seq:11:3 (code @missions/main.seq:11:10, target @missions/main.seq:11:18)
        "#]],
    );
}

#[test]
fn restart_and_env_after_an_include_are_global_again() {
    check(
        &[
            ("a.seq", "state s ./s\ninclude b.seq\nrestart 2\nenv K=v\n"),
            ("b.seq", "state t ./t\n  restart 1\n"),
        ],
        &expect![[r#"
            restart 2 @a.seq:3:1
            env K="v" @a.seq:4:5
            state s @a.seq:1:7 program "./s" @a.seq:1:9 args []
            state t @b.seq:1:7 program "./t" @b.seq:1:9 args []
              restart 1 @b.seq:2:3
        "#]],
    );
}

#[test]
fn crlf_line_ends_and_a_byte_order_mark_are_accepted() {
    check(
        &[(
            "w.seq",
            "\u{feff}start a\r\nstate a ./a\r\n  action 0 trans stop\r\n",
        )],
        &expect![[r#"
            start a @w.seq:1:7
            state a @w.seq:2:7 program "./a" @w.seq:2:9 args []
              action 0 -> stop @w.seq:3:3 (code @w.seq:3:10, target @w.seq:3:18)
        "#]],
    );
}

#[test]
fn every_broken_line_is_reported_but_not_the_lines_of_a_broken_state() {
    check(
        &[(
            "m.seq",
            "start a\nstat b ./b\nstate c \"./c\n  action 0 trans stop\n  action x trans stop\naction 0 trans stop\n",
        )],
        &expect![[r#"
            m.seq:2:1: error: unknown keyword `stat`
              hint: did you mean `state`?
            m.seq:3:9: error: unterminated string
              hint: close the string with `"` on the same line"#]],
    );
}

#[test]
fn a_misspelt_trans_suggests_the_keyword() {
    check_broken(
        &[("mission.seq", &paper_with(7, "  action 0 trnas sign"))],
        &expect![[r#"
            mission.seq:7:12: error: expected `trans`, found `trnas`
              hint: did you mean `trans`?"#]],
    );
}

#[test]
fn a_misspelt_keyword_suggests_the_keyword() {
    check_broken(
        &[(
            "mission.seq",
            &paper_with(13, "stat queue /usr/bin/QueueStander"),
        )],
        &expect![[r#"
            mission.seq:13:1: error: unknown keyword `stat`
              hint: did you mean `state`?"#]],
    );
}

#[test]
fn an_undefined_target_suggests_the_closest_state() {
    check_broken(
        &[("mission.seq", &paper_with(7, "  action 0 trans sing"))],
        &expect![[r#"
            mission.seq:7:18: error: undefined state `sing` in `trans`
              hint: did you mean `sign`?"#]],
    );
}

#[test]
fn an_undefined_start_state_is_named() {
    check_broken(
        &[("mission.seq", &paper_with(1, "start dor"))],
        &expect![[r#"
            mission.seq:1:7: error: undefined state `dor` in `start`
              hint: did you mean `door`?"#]],
    );
}

#[test]
fn an_exit_code_out_of_range_is_refused() {
    check_broken(
        &[("mission.seq", &paper_with(11, "  action 256 trans queue"))],
        &expect![[r#"
            mission.seq:11:10: error: invalid exit code `256`
              hint: exit codes are integers from 0 to 255"#]],
    );
}

#[test]
fn a_restart_limit_in_words_is_refused() {
    check_broken(
        &[("mission.seq", &paper_with(2, "restart three"))],
        &expect![[r#"
            mission.seq:2:9: error: invalid restart limit `three`
              hint: write a whole number of restarts, such as `restart 3`"#]],
    );
}

#[test]
fn an_action_without_its_target_says_what_is_missing_at_the_line_end() {
    check_broken(
        &[("mission.seq", &paper_with(17, "  action 0 trans"))],
        &expect![[r#"
            mission.seq:17:17: error: `action` needs a state name
              hint: write `action CODE trans STATE`"#]],
    );
}

#[test]
fn words_after_the_end_of_a_line_are_refused() {
    check_broken(
        &[("mission.seq", &paper_with(20, "  action 0 trans stop now"))],
        &expect![[r#"
            mission.seq:20:23: error: unexpected `now` after the end of the `action` line
              hint: write `action CODE trans STATE`"#]],
    );
}

#[test]
fn an_unknown_feature_is_refused() {
    check_broken(
        &[("mission.seq", &paper_with(4, "use gu"))],
        &expect![[r#"
            mission.seq:4:5: error: unknown feature `gu`
              hint: the only feature is `gui`: write `use gui`"#]],
    );
}

#[test]
fn an_unterminated_program_string_hides_the_lines_of_its_state() {
    check_broken(
        &[(
            "mission.seq",
            &paper_with(9, "state sign \"/usr/bin/SignFollower"),
        )],
        &expect![[r#"
            mission.seq:9:12: error: unterminated string
              hint: close the string with `"` on the same line"#]],
    );
}

#[test]
fn a_state_named_stop_is_refused() {
    check_broken(
        &[(
            "mission.seq",
            &paper_with(16, "state stop /usr/bin/Register"),
        )],
        &expect![[r#"
            mission.seq:16:7: error: `stop` is the final state and cannot be defined
              hint: name the state differently; `action CODE trans stop` ends the mission"#]],
    );
}

#[test]
fn a_duration_without_unit_is_refused() {
    check_broken(
        &[("mission.seq", &paper_with(5, "  timeout 30"))],
        &expect![[r#"
            mission.seq:5:3: error: `timeout` outside a state
              hint: put `timeout` after the `state NAME PROGRAM` line it belongs to"#]],
    );
    check_broken(
        &[("mission.seq", &paper_with(8, "  timeout 30"))],
        &expect![[r#"
            mission.seq:8:11: error: invalid duration `30`: it has no unit
              hint: write a number and a unit: `500ms`, `30s`, `1.5s`, `2m` or `1h`"#]],
    );
}

#[test]
fn a_duplicate_state_points_at_the_first() {
    check_broken(
        &[(
            "mission.seq",
            &format!("{PAPER}state queue /usr/bin/Other\n"),
        )],
        &expect![[r#"
            mission.seq:21:7: error: duplicate state `queue`
              hint: first defined at mission.seq:13:7"#]],
    );
}

#[test]
fn a_duplicate_action_points_at_the_first() {
    check_broken(
        &[("mission.seq", &paper_with(11, "  action 0 trans queue"))],
        &expect![[r#"
            mission.seq:11:10: error: duplicate action for exit code 0 in state `sign`
              hint: first action for this code at mission.seq:10:3"#]],
    );
}

#[test]
fn a_second_start_points_at_the_first() {
    check_broken(
        &[("mission.seq", &paper_with(5, "start sign"))],
        &expect![[r#"
            mission.seq:5:1: error: duplicate `start`
              hint: first given at mission.seq:1:7"#]],
    );
}

#[test]
fn an_invalid_environment_name_is_refused() {
    check_broken(
        &[("mission.seq", &paper_with(5, "env 1A=b"))],
        &expect![[r#"
            mission.seq:5:5: error: invalid environment variable `1A=b`: the name must be letters, digits and `_`, not starting with a digit
              hint: write `env KEY=VALUE`, or `env "KEY=VALUE WITH SPACES"`; keys are letters, digits and `_`"#]],
    );
}

#[test]
fn a_missing_include_is_reported_at_the_include_line() {
    check_broken(
        &[(
            "m/mission.seq",
            &paper_with(5, "include \"parts/gone.seq\""),
        )],
        &expect![[r#"
            m/mission.seq:5:1: error: cannot read `m/parts/gone.seq`: entity not found
              hint: check the path; includes are relative to the including file"#]],
    );
}

#[test]
fn an_include_cycle_is_reported_once_with_its_chain() {
    check_broken(
        &[
            ("mission.seq", &paper_with(5, "include a.seq")),
            ("a.seq", "include sub/b.seq"),
            ("sub/b.seq", "include ../a.seq"),
        ],
        &expect![[r#"
            sub/b.seq:1:1: error: include cycle: `a.seq` -> `sub/b.seq` -> `sub/../a.seq`
              hint: remove one of the `include` lines of the cycle"#]],
    );
}

#[test]
fn a_keyword_in_quotes_is_refused() {
    check_broken(
        &[("mission.seq", &paper_with(5, "  \"state\" x ./x"))],
        &expect![[r#"
            mission.seq:5:3: error: a line must start with a keyword, not a quoted string
              hint: write the keyword without quotes"#]],
    );
}
