//! The FSM core on the paper's script: events in, decisions out, shown as text.

use std::path::Path;

use expect_test::{Expect, expect};
use lewis_sequencer::{
    Event, EventError, MemorySources, Mission, Sequencer, Supervision, TrustingResolver, check_with,
};

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

fn mission(script: &str) -> Mission {
    let sources = MemorySources::new().with("m.seq", script);
    match check_with(Path::new("m.seq"), &sources, &TrustingResolver) {
        Ok(checked) => checked.mission,
        Err(diagnostics) => panic!("the test script is broken:\n{diagnostics}"),
    }
}

fn exited(code: i32) -> Event {
    Event::Exited { code }
}

fn signalled(signal: i32) -> Event {
    Event::Signalled { signal }
}

fn chose(state: &str) -> Event {
    Event::SupervisorChose {
        state: state.into(),
    }
}

/// Starts `script` as `lewis seq run` does with no terminal (asked on the page with `use
/// gui`, unattended without), feeds `events` and shows every decision (and every refused
/// event).
fn check(script: &str, events: &[Event], expected: &Expect) {
    let mission = mission(script);
    let supervision = Supervision::decide(mission.use_gui(), false, false);
    check_supervised(mission, supervision, events, expected);
}

/// As [`check`], with `supervision` given.
fn check_supervised(
    mission: Mission,
    supervision: Supervision,
    events: &[Event],
    expected: &Expect,
) {
    let (mut sequencer, decisions) = Sequencer::start(mission, supervision);
    let mut out: Vec<String> = Vec::new();
    for decision in decisions {
        out.push(format!("{decision}"));
    }
    for event in events {
        out.push(format!("> {event}"));
        match sequencer.handle(event) {
            Ok(decisions) => {
                for decision in decisions {
                    out.push(format!("{decision}"));
                }
            }
            Err(error) => out.push(format!("refused: {error}")),
        }
    }
    let out: String = out.iter().map(|line| format!("{line}\n")).collect();
    expected.assert_eq(&out);
}

#[test]
fn a_normal_run_goes_through_every_state_to_stop() {
    check(
        PAPER,
        &[
            exited(0),
            exited(0),
            exited(0),
            exited(1),
            exited(0),
            exited(0),
        ],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > exit code 0
            transition door -> sign on 0 | `door` exited with code 0, which leads to `sign`
            run sign attempt 1: /usr/bin/SignFollower | transition from `door` on exit code 0
            > exit code 0
            transition sign -> sign on 0 | `sign` exited with code 0, which leads to `sign`
            run sign attempt 1: /usr/bin/SignFollower | transition from `sign` on exit code 0
            > exit code 0
            transition sign -> sign on 0 | `sign` exited with code 0, which leads to `sign`
            run sign attempt 1: /usr/bin/SignFollower | transition from `sign` on exit code 0
            > exit code 1
            transition sign -> queue on 1 | `sign` exited with code 1, which leads to `queue`
            run queue attempt 1: /usr/bin/QueueStander | transition from `sign` on exit code 1
            > exit code 0
            transition queue -> register on 0 | `queue` exited with code 0, which leads to `register`
            run register attempt 1: /usr/bin/Register | transition from `queue` on exit code 0
            > exit code 0
            transition register -> stop on 0 | `register` exited with code 0, which leads to `stop`
            finished | `register` led to `stop`
        "#]],
    );
}

#[test]
fn three_crashes_restart_and_the_fourth_enters_recovery() {
    check(
        PAPER,
        &[
            signalled(11),
            signalled(11),
            signalled(6),
            signalled(11),
            exited(0),
        ],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > signal 11
            restart door attempt 2 | `door` was killed by signal 11; restart 1 of 3
            run door attempt 2: /usr/bin/DoorNavigator | `door` was killed by signal 11; restart 1 of 3
            > signal 11
            restart door attempt 3 | `door` was killed by signal 11; restart 2 of 3
            run door attempt 3: /usr/bin/DoorNavigator | `door` was killed by signal 11; restart 2 of 3
            > signal 6
            restart door attempt 4 | `door` was killed by signal 6; restart 3 of 3
            run door attempt 4: /usr/bin/DoorNavigator | `door` was killed by signal 6; restart 3 of 3
            > signal 11
            recover from door | `door` was killed by signal 11 after 3 restarts
            run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` was killed by signal 11 after 3 restarts
            > exit code 0
            ask the supervisor: door, sign, queue, register, oops or stop (suggested stop) | recovery `oops` is over (exit code 0)
        "#]],
    );
}

#[test]
fn an_unlisted_exit_code_enters_recovery_without_restarting() {
    check(
        PAPER,
        &[exited(0), exited(7)],
        &expect![[r#"
        run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
        > exit code 0
        transition door -> sign on 0 | `door` exited with code 0, which leads to `sign`
        run sign attempt 1: /usr/bin/SignFollower | transition from `door` on exit code 0
        > exit code 7
        recover from sign | `sign` exited with code 7, which the script does not list
        run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `sign` exited with code 7, which the script does not list
    "#]],
    );
}

#[test]
fn the_supervisors_choice_resumes_the_mission_there() {
    check(
        PAPER,
        &[exited(9), exited(0), chose("queue"), exited(0), exited(0)],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > exit code 9
            recover from door | `door` exited with code 9, which the script does not list
            run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 9, which the script does not list
            > exit code 0
            ask the supervisor: door, sign, queue, register, oops or stop (suggested stop) | recovery `oops` is over (exit code 0)
            > the supervisor's choice of `queue`
            resume at queue | the supervisor chose `queue`
            run queue attempt 1: /usr/bin/QueueStander | the supervisor chose `queue`
            > exit code 0
            transition queue -> register on 0 | `queue` exited with code 0, which leads to `register`
            run register attempt 1: /usr/bin/Register | transition from `queue` on exit code 0
            > exit code 0
            transition register -> stop on 0 | `register` exited with code 0, which leads to `stop`
            finished | `register` led to `stop`
        "#]],
    );
}

#[test]
fn the_supervisor_can_stop_after_recovery() {
    check(
        PAPER,
        &[exited(9), exited(0), chose("stop")],
        &expect![[r#"
        run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
        > exit code 9
        recover from door | `door` exited with code 9, which the script does not list
        run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 9, which the script does not list
        > exit code 0
        ask the supervisor: door, sign, queue, register, oops or stop (suggested stop) | recovery `oops` is over (exit code 0)
        > the supervisor's choice of `stop`
        finished | the supervisor chose to stop
    "#]],
    );
    check(
        PAPER,
        &[exited(9), exited(0), Event::SupervisorStopped],
        &expect![[r#"
        run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
        > exit code 9
        recover from door | `door` exited with code 9, which the script does not list
        run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 9, which the script does not list
        > exit code 0
        ask the supervisor: door, sign, queue, register, oops or stop (suggested stop) | recovery `oops` is over (exit code 0)
        > the supervisor's stop
        finished | the supervisor chose to stop
    "#]],
    );
}

#[test]
fn a_timeout_counts_as_a_crash() {
    let script = PAPER.replace(
        "state door /usr/bin/DoorNavigator\n",
        "state door /usr/bin/DoorNavigator\n  timeout 30s\n  restart 1\n",
    );
    check(
        &script,
        &[Event::TimedOut, Event::TimedOut, exited(0)],
        &expect![[r#"
        run door attempt 1: /usr/bin/DoorNavigator (timeout 30s) | the mission starts at `door`
        > timeout
        restart door attempt 2 | `door` ran past its 30s timeout; restart 1 of 1
        run door attempt 2: /usr/bin/DoorNavigator (timeout 30s) | `door` ran past its 30s timeout; restart 1 of 1
        > timeout
        recover from door | `door` ran past its 30s timeout after 1 restart
        run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` ran past its 30s timeout after 1 restart
        > exit code 0
        ask the supervisor: door, sign, queue, register, oops or stop (suggested stop) | recovery `oops` is over (exit code 0)
    "#]],
    );
}

#[test]
fn a_failure_to_start_counts_as_a_crash() {
    let script = PAPER.replace("restart 3", "restart 0");
    check(
        &script,
        &[Event::SpawnFailed {
            error: "No such file or directory (os error 2)".into(),
        }],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > failure to start (No such file or directory (os error 2))
            recover from door | `door` could not start (No such file or directory (os error 2)), with no restart allowed
            run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` could not start (No such file or directory (os error 2)), with no restart allowed
        "#]],
    );
}

#[test]
fn panic_and_signal_exit_codes_count_as_crashes_unless_listed() {
    check(
        PAPER,
        &[exited(101), exited(139), exited(0)],
        &expect![[r#"
        run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
        > exit code 101
        restart door attempt 2 | `door` exited with code 101, which the script does not list; restart 1 of 3
        run door attempt 2: /usr/bin/DoorNavigator | `door` exited with code 101, which the script does not list; restart 1 of 3
        > exit code 139
        restart door attempt 3 | `door` exited with code 139, which the script does not list; restart 2 of 3
        run door attempt 3: /usr/bin/DoorNavigator | `door` exited with code 139, which the script does not list; restart 2 of 3
        > exit code 0
        transition door -> sign on 0 | `door` exited with code 0, which leads to `sign`
        run sign attempt 1: /usr/bin/SignFollower | transition from `door` on exit code 0
    "#]],
    );
    let script = PAPER.replace(
        "  action 0 trans sign\n\nstate sign",
        "  action 0 trans sign\n  action 101 trans stop\n\nstate sign",
    );
    check(
        &script,
        &[exited(101)],
        &expect![[r#"
        run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
        > exit code 101
        transition door -> stop on 101 | `door` exited with code 101, which leads to `stop`
        finished | `door` led to `stop`
    "#]],
    );
}

#[test]
fn the_restart_count_starts_again_on_each_visit() {
    check(
        PAPER,
        &[
            exited(0),
            signalled(9),
            signalled(9),
            exited(0),
            signalled(9),
            signalled(9),
            signalled(9),
            exited(1),
        ],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > exit code 0
            transition door -> sign on 0 | `door` exited with code 0, which leads to `sign`
            run sign attempt 1: /usr/bin/SignFollower | transition from `door` on exit code 0
            > signal 9
            restart sign attempt 2 | `sign` was killed by signal 9; restart 1 of 3
            run sign attempt 2: /usr/bin/SignFollower | `sign` was killed by signal 9; restart 1 of 3
            > signal 9
            restart sign attempt 3 | `sign` was killed by signal 9; restart 2 of 3
            run sign attempt 3: /usr/bin/SignFollower | `sign` was killed by signal 9; restart 2 of 3
            > exit code 0
            transition sign -> sign on 0 | `sign` exited with code 0, which leads to `sign`
            run sign attempt 1: /usr/bin/SignFollower | transition from `sign` on exit code 0
            > signal 9
            restart sign attempt 2 | `sign` was killed by signal 9; restart 1 of 3
            run sign attempt 2: /usr/bin/SignFollower | `sign` was killed by signal 9; restart 1 of 3
            > signal 9
            restart sign attempt 3 | `sign` was killed by signal 9; restart 2 of 3
            run sign attempt 3: /usr/bin/SignFollower | `sign` was killed by signal 9; restart 2 of 3
            > signal 9
            restart sign attempt 4 | `sign` was killed by signal 9; restart 3 of 3
            run sign attempt 4: /usr/bin/SignFollower | `sign` was killed by signal 9; restart 3 of 3
            > exit code 1
            transition sign -> queue on 1 | `sign` exited with code 1, which leads to `queue`
            run queue attempt 1: /usr/bin/QueueStander | transition from `sign` on exit code 1
        "#]],
    );
}

#[test]
fn a_state_restart_override_beats_the_global_limit() {
    let script = PAPER.replace(
        "state door /usr/bin/DoorNavigator\n",
        "state door /usr/bin/DoorNavigator\n  restart 1\n",
    );
    check(
        &script,
        &[signalled(11), signalled(11)],
        &expect![[r#"
        run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
        > signal 11
        restart door attempt 2 | `door` was killed by signal 11; restart 1 of 1
        run door attempt 2: /usr/bin/DoorNavigator | `door` was killed by signal 11; restart 1 of 1
        > signal 11
        recover from door | `door` was killed by signal 11 after 1 restart
        run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` was killed by signal 11 after 1 restart
    "#]],
    );
}

#[test]
fn unattended_without_the_gui_recovery_follows_its_listed_transition() {
    let script = PAPER.replace("use gui\n", "");
    check(
        &script,
        &[exited(5), exited(0)],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > exit code 5
            recover from door | `door` exited with code 5, which the script does not list
            run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 5, which the script does not list
            > exit code 0
            transition oops -> stop on 0 | `oops` exited with code 0, which leads to `stop`; nobody can be asked where to resume (unattended)
            finished | `oops` led to `stop`
        "#]],
    );
}

#[test]
fn a_failing_recovery_asks_the_supervisor_with_the_gui_and_aborts_unattended() {
    check(
        PAPER,
        &[exited(5), exited(3)],
        &expect![[r#"
        run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
        > exit code 5
        recover from door | `door` exited with code 5, which the script does not list
        run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 5, which the script does not list
        > exit code 3
        ask the supervisor: door, sign, queue, register, oops or stop | recovery failed: `oops` exited with code 3, which the script does not list
    "#]],
    );
    let script = PAPER.replace("use gui\n", "");
    check(
        &script,
        &[
            exited(5),
            signalled(11),
            signalled(11),
            signalled(11),
            signalled(11),
        ],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > exit code 5
            recover from door | `door` exited with code 5, which the script does not list
            run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 5, which the script does not list
            > signal 11
            restart oops attempt 2 | `oops` was killed by signal 11; restart 1 of 3
            run oops attempt 2: /usr/bin/Recovery | `oops` was killed by signal 11; restart 1 of 3
            > signal 11
            restart oops attempt 3 | `oops` was killed by signal 11; restart 2 of 3
            run oops attempt 3: /usr/bin/Recovery | `oops` was killed by signal 11; restart 2 of 3
            > signal 11
            restart oops attempt 4 | `oops` was killed by signal 11; restart 3 of 3
            run oops attempt 4: /usr/bin/Recovery | `oops` was killed by signal 11; restart 3 of 3
            > signal 11
            aborted | recovery failed: `oops` was killed by signal 11 after 3 restarts; nobody can be asked where to resume (unattended)
        "#]],
    );
}

#[test]
fn without_a_recovery_state_a_failure_asks_or_aborts_unattended() {
    let script = "start a\nuse gui\nstate a ./a\n  action 0 trans stop\n";
    check(
        script,
        &[exited(3), chose("a"), exited(0)],
        &expect![[r#"
        run a attempt 1: ./a | the mission starts at `a`
        > exit code 3
        ask the supervisor: a or stop | `a` exited with code 3, which the script does not list, and the script has no recovery state
        > the supervisor's choice of `a`
        resume at a | the supervisor chose `a`
        run a attempt 1: ./a | the supervisor chose `a`
        > exit code 0
        transition a -> stop on 0 | `a` exited with code 0, which leads to `stop`
        finished | `a` led to `stop`
    "#]],
    );
    check(
        &script.replace("use gui\n", ""),
        &[exited(3)],
        &expect![[r#"
            run a attempt 1: ./a | the mission starts at `a`
            > exit code 3
            aborted | `a` exited with code 3, which the script does not list, and the script has no recovery state; nobody can be asked where to resume (unattended)
        "#]],
    );
}

#[test]
fn the_supervisor_stopping_a_running_program_aborts() {
    check(
        PAPER,
        &[exited(0), Event::SupervisorStopped],
        &expect![[r#"
        run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
        > exit code 0
        transition door -> sign on 0 | `door` exited with code 0, which leads to `sign`
        run sign attempt 1: /usr/bin/SignFollower | transition from `door` on exit code 0
        > the supervisor's stop
        aborted | the supervisor stopped the mission while `sign` was running
    "#]],
    );
}

#[test]
fn events_that_do_not_fit_are_refused_and_change_nothing() {
    check(
        PAPER,
        &[
            chose("sign"),
            exited(9),
            exited(0),
            chose("nowhere"),
            exited(0),
            chose("register"),
            exited(0),
            exited(0),
        ],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > the supervisor's choice of `sign`
            refused: the supervisor's choice of `sign` is unexpected while `door` runs
            > exit code 9
            recover from door | `door` exited with code 9, which the script does not list
            run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 9, which the script does not list
            > exit code 0
            ask the supervisor: door, sign, queue, register, oops or stop (suggested stop) | recovery `oops` is over (exit code 0)
            > the supervisor's choice of `nowhere`
            refused: the supervisor chose `nowhere`, which is not a state of the mission
            > exit code 0
            refused: exit code 0 is unexpected while the supervisor is asked
            > the supervisor's choice of `register`
            resume at register | the supervisor chose `register`
            run register attempt 1: /usr/bin/Register | the supervisor chose `register`
            > exit code 0
            transition register -> stop on 0 | `register` exited with code 0, which leads to `stop`
            finished | `register` led to `stop`
            > exit code 0
            refused: exit code 0 is unexpected while the mission is finished
        "#]],
    );
}

#[test]
fn decisions_carry_everything_the_driver_needs() {
    let script = "start a\nrecovery a\nenv G=1\nstate a ./bin/a --x \"y z\"\n  env S=2\n  timeout 500ms\n  action 0 trans stop\n";
    let (sequencer, decisions) = Sequencer::start(mission(script), Supervision::Page);
    assert_eq!(
        decisions,
        [lewis_sequencer::Decision::Run {
            state: "a".into(),
            program: "./bin/a".into(),
            args: vec!["--x".into(), "y z".into()],
            env: [
                ("G".to_owned(), "1".to_owned()),
                ("S".to_owned(), "2".to_owned())
            ]
            .into(),
            timeout_ns: Some(500_000_000),
            attempt: 1,
            reason: "the mission starts at `a`".into(),
        }]
    );
    assert_eq!(sequencer.running(), Some(("a", 1)));
    assert!(!sequencer.is_asking());
    assert!(!sequencer.is_over());
}

#[test]
fn after_the_end_every_event_is_refused() {
    let (mut sequencer, _) = Sequencer::start(mission(PAPER), Supervision::Page);
    for code in [0, 1, 0, 0] {
        sequencer.handle(&exited(code)).unwrap();
    }
    assert!(sequencer.is_over());
    assert_eq!(
        sequencer.handle(&exited(0)),
        Err(EventError::Unexpected {
            event: "exit code 0".into(),
            phase: "the mission is finished".into()
        })
    );
}

#[test]
fn an_interruption_aborts_while_running_and_while_asking_but_not_after_the_end() {
    let interrupted = || Event::Interrupted {
        reason: "SIGINT".into(),
    };
    check(
        PAPER,
        &[interrupted(), interrupted()],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > an interruption (SIGINT)
            aborted | the sequencer was interrupted (SIGINT) while `door` was running
            > an interruption (SIGINT)
            refused: an interruption (SIGINT) is unexpected while the mission is aborted
        "#]],
    );
    let (mut sequencer, _) = Sequencer::start(mission(PAPER), Supervision::Page);
    for event in [
        signalled(11),
        signalled(11),
        signalled(11),
        signalled(11),
        exited(0),
    ] {
        sequencer.handle(&event).unwrap();
    }
    assert!(sequencer.is_asking());
    let decisions = sequencer.handle(&interrupted()).unwrap();
    assert_eq!(
        decisions[0].to_string(),
        "aborted | the sequencer was interrupted (SIGINT) while the supervisor was asked"
    );
    assert!(sequencer.is_over());
}

#[test]
fn on_a_terminal_without_use_gui_the_supervisor_is_asked_after_recovery() {
    let script = PAPER.replace("use gui\n", "");
    check_supervised(
        mission(&script),
        Supervision::Terminal,
        &[exited(5), exited(0), chose("sign"), exited(1)],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > exit code 5
            recover from door | `door` exited with code 5, which the script does not list
            run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 5, which the script does not list
            > exit code 0
            ask the supervisor: door, sign, queue, register, oops or stop (suggested stop) | recovery `oops` is over (exit code 0)
            > the supervisor's choice of `sign`
            resume at sign | the supervisor chose `sign`
            run sign attempt 1: /usr/bin/SignFollower | the supervisor chose `sign`
            > exit code 1
            transition sign -> queue on 1 | `sign` exited with code 1, which leads to `queue`
            run queue attempt 1: /usr/bin/QueueStander | transition from `sign` on exit code 1
        "#]],
    );
}

#[test]
fn unattended_with_use_gui_the_recovery_actions_apply_and_the_reason_says_why() {
    check_supervised(
        mission(PAPER),
        Supervision::Unattended,
        &[exited(5), exited(0)],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > exit code 5
            recover from door | `door` exited with code 5, which the script does not list
            run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 5, which the script does not list
            > exit code 0
            transition oops -> stop on 0 | `oops` exited with code 0, which leads to `stop`; nobody can be asked where to resume (unattended)
            finished | `oops` led to `stop`
        "#]],
    );
    check_supervised(
        mission(PAPER),
        Supervision::Unattended,
        &[exited(5), exited(3)],
        &expect![[r#"
            run door attempt 1: /usr/bin/DoorNavigator | the mission starts at `door`
            > exit code 5
            recover from door | `door` exited with code 5, which the script does not list
            run oops attempt 1: /usr/bin/Recovery | recovery `oops`: `door` exited with code 5, which the script does not list
            > exit code 3
            aborted | recovery failed: `oops` exited with code 3, which the script does not list; nobody can be asked where to resume (unattended)
        "#]],
    );
}

#[test]
fn the_page_with_use_gui_else_a_terminal_else_nobody_answers() {
    use Supervision::{Page, Terminal, Unattended};
    let got: Vec<(bool, bool, bool, Supervision)> = [false, true]
        .into_iter()
        .flat_map(|gui| [false, true].map(move |no_gui| (gui, no_gui)))
        .flat_map(|(gui, no_gui)| [false, true].map(move |tty| (gui, no_gui, tty)))
        .map(|(gui, no_gui, tty)| (gui, no_gui, tty, Supervision::decide(gui, no_gui, tty)))
        .collect();
    assert_eq!(
        got,
        [
            (false, false, false, Unattended),
            (false, false, true, Terminal),
            (false, true, false, Unattended),
            (false, true, true, Terminal),
            (true, false, false, Page),
            (true, false, true, Page),
            (true, true, false, Unattended),
            (true, true, true, Terminal),
        ]
    );
    assert!(Page.is_attended() && Terminal.is_attended() && !Unattended.is_attended());
}
