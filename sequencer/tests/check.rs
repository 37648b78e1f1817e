//! The checker: findings (errors and warnings) and the mission it builds.

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

use expect_test::{Expect, expect};
use lewis_sequencer::{
    MemorySources, ProgramResolver, ResolveError, TrustingResolver, check_file, check_with,
};

/// Checks `script` (a file `m.seq`) with programs resolved by `resolver` and shows every
/// finding, or `ok` when there are none.
fn check_resolved(script: &str, resolver: &dyn ProgramResolver, expected: &Expect) {
    let sources = MemorySources::new().with("m.seq", script);
    let actual = match check_with(Path::new("m.seq"), &sources, resolver) {
        Ok(checked) if checked.warnings.is_empty() => "ok".to_owned(),
        Ok(checked) => format!("ok with warnings:\n{}", checked.warnings),
        Err(diagnostics) => format!("refused:\n{diagnostics}"),
    };
    expected.assert_eq(&actual);
}

fn check(script: &str, expected: &Expect) {
    check_resolved(script, &TrustingResolver, expected);
}

#[test]
fn a_script_without_start_is_refused() {
    check(
        "recovery r\nstate r ./r\n  action 0 trans stop\n",
        &expect![[r#"
            refused:
            m.seq: error: no `start` line
              hint: add `start NAME` naming the first state"#]],
    );
}

#[test]
fn a_missing_recovery_is_a_warning_whose_hint_depends_on_the_gui() {
    check(
        "start a\nstate a ./a\n  action 0 trans stop\n",
        &expect![[r#"
            ok with warnings:
            m.seq: warning: no `recovery` state
              hint: a crash beyond the restart limit or an unlisted exit code aborts the mission; add `recovery STATE` to reach a safe state"#]],
    );
    check(
        "start a\nuse gui\nstate a ./a\n  action 0 trans stop\n",
        &expect![[r#"
            ok with warnings:
            m.seq: warning: no `recovery` state
              hint: a crash beyond the restart limit or an unlisted exit code asks the supervisor straight away; add `recovery STATE` to reach a safe state first"#]],
    );
}

#[test]
fn states_unreachable_from_start_are_warnings_even_with_the_gui() {
    let script = "start a\nrecovery r\nSTATE_GUI\nstate a ./a\n  action 0 trans stop\nstate lost ./lost\n  action 0 trans a\nstate r ./r\n  action 0 trans stop\n";
    check(
        &script.replace("STATE_GUI", ""),
        &expect![[r#"
            ok with warnings:
            m.seq:6:7: warning: state `lost` is unreachable from `start`
              hint: no action leads to it from `start`; add one or remove the state"#]],
    );
    check(
        &script.replace("STATE_GUI", "use gui"),
        &expect![[r#"
            ok with warnings:
            m.seq:6:7: warning: state `lost` is unreachable from `start`
              hint: only the supervisor can choose it after recovery; add an action leading to it if the mission should reach it by itself"#]],
    );
}

#[test]
fn the_recovery_state_and_what_it_leads_to_count_as_reachable() {
    check(
        "start a\nrecovery r\nstate a ./a\n  action 0 trans stop\nstate r ./r\n  action 0 trans home\nstate home ./home\n  action 0 trans stop\n",
        &expect!["ok"],
    );
}

#[test]
fn states_with_no_chain_of_actions_to_stop_are_warnings() {
    check(
        "start a\nrecovery r\nstate a ./a\n  action 0 trans b\n  action 1 trans stop\nstate b ./b\n  action 0 trans c\nstate c ./c\n  action 0 trans b\nstate r ./r\n  action 0 trans stop\n",
        &expect![[r#"
            ok with warnings:
            m.seq:6:7: warning: state `b` has no path to `stop` through its actions
              hint: every run through it ends in recovery or loops for ever; add an action leading towards `stop`
            m.seq:8:7: warning: state `c` has no path to `stop` through its actions
              hint: every run through it ends in recovery or loops for ever; add an action leading towards `stop`"#]],
    );
}

#[test]
fn an_undefined_recovery_is_an_error() {
    check(
        "start a\nrecovery oop\nstate a ./a\n  action 0 trans stop\nstate oops ./r\n  action 0 trans stop\n",
        &expect![[r#"
            refused:
            m.seq:2:10: error: undefined state `oop` in `recovery`
              hint: did you mean `oops`?"#]],
    );
}

#[test]
fn a_variable_set_twice_in_one_scope_is_a_warning() {
    check(
        "start a\nrecovery a\nenv A=1 B=2\nenv A=3\nstate a ./a\n  env A=4\n  action 0 trans stop\n",
        &expect![[r#"
            ok with warnings:
            m.seq:4:5: warning: `A` is set twice
              hint: first set at m.seq:3:5; the later value wins"#]],
    );
}

#[test]
fn programs_that_cannot_run_are_errors_with_their_state() {
    let resolver = |program: &str, folder: &Path| match program {
        "./missing" => Err(ResolveError::NotFound {
            searched: vec![folder.join(program)],
        }),
        "tool" => Err(ResolveError::NotFound {
            searched: vec!["/opt/bin".into(), "/usr/bin".into()],
        }),
        "./plain" => Err(ResolveError::NotExecutable {
            path: folder.join(program),
        }),
        "./dir" => Err(ResolveError::IsFolder {
            path: folder.join(program),
        }),
        _ => Ok(folder.join(program)),
    };
    check_resolved(
        "start a\nrecovery a\nstate a ./missing\n  action 0 trans b\nstate b tool\n  action 0 trans c\nstate c ./plain\n  action 0 trans d\nstate d ./dir\n  action 0 trans stop\n",
        &resolver,
        &expect![[r#"
            refused:
            m.seq:3:9: error: program `./missing` of state `a` not found
              hint: looked in `./missing`; relative paths with a `/` are relative to the script's folder
            m.seq:5:9: error: program `tool` of state `b` not found
              hint: looked in `/opt/bin`, `/usr/bin`; relative paths with a `/` are relative to the script's folder
            m.seq:7:9: error: program `./plain` of state `c` is not executable
              hint: make it executable: `chmod +x ./plain`
            m.seq:9:9: error: program `./dir` of state `d` is a folder
              hint: name the program file inside the folder"#]],
    );
}

#[test]
fn the_mission_merges_settings_and_resolves_programs_from_each_files_folder() {
    let sources = MemorySources::new()
        .with(
            "missions/main.seq",
            "start a\nrestart 3\nrecovery r\nenv A=global B=global\nstate a ./bin/a x \"y z\"\n  restart 1\n  env B=state\n  timeout 2m\n  action 0 trans stop\ninclude parts/r.seq\n",
        )
        .with("missions/parts/r.seq", "state r ../bin/r\n  action 0 trans stop\n");
    let checked = check_with(Path::new("missions/main.seq"), &sources, &TrustingResolver).unwrap();
    let mission = &checked.mission;
    let a = mission.start();
    assert_eq!(a.name, "a");
    assert_eq!(a.program, PathBuf::from("missions/./bin/a"));
    assert_eq!(a.args, ["x", "y z"]);
    assert_eq!(a.restart_limit, 1);
    assert_eq!(a.timeout_ns, Some(120_000_000_000));
    assert_eq!(
        a.env
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>(),
        ["A=global", "B=state"]
    );
    let r = mission.recovery().unwrap();
    assert_eq!(r.program, PathBuf::from("missions/parts/../bin/r"));
    assert_eq!(r.restart_limit, 3);
    assert_eq!(r.timeout_ns, None);
    assert!(!mission.use_gui());
}

#[test]
fn check_file_reads_the_disk_and_finds_programs_next_to_the_script() {
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("bin");
    std::fs::create_dir(&bin).unwrap();
    for (name, mode) in [("door", 0o755), ("oops", 0o644)] {
        std::fs::write(bin.join(name), "#!/bin/sh\n").unwrap();
        std::fs::set_permissions(bin.join(name), std::fs::Permissions::from_mode(mode)).unwrap();
    }
    let script = dir.path().join("mission.seq");
    std::fs::write(
        &script,
        "start door\nrecovery oops\nstate door bin/door\n  action 0 trans stop\nstate oops bin/oops\n  action 0 trans stop\n",
    )
    .unwrap();
    let diagnostics = check_file(&script).unwrap_err();
    let bin = bin.display();
    assert_eq!(
        diagnostics.to_string(),
        format!(
            "{}:5:12: error: program `{bin}/oops` of state `oops` is not executable\n  hint: make it executable: `chmod +x {bin}/oops`",
            script.display()
        )
    );

    std::fs::set_permissions(
        dir.path().join("bin/oops"),
        std::fs::Permissions::from_mode(0o755),
    )
    .unwrap();
    let checked = check_file(&script).unwrap();
    assert_eq!(checked.mission.start().program, dir.path().join("bin/door"));
    assert!(checked.warnings.is_empty(), "{}", checked.warnings);
}
