//! The live driver with real processes: the paper's script with test programs, timeouts,

#![allow(clippy::unwrap_used, clippy::expect_used)]
//! stops, the terminal's answers.

use crate::common;

use std::io::Write;
use std::sync::mpsc;
use std::time::Duration;

use common::{PAPER, answering, is_gone, read_pid, run_live, show, wait_for_line, write_script};
use expect_test::expect;
use lewis_sequencer::record::{Entry, RecordSink};
use lewis_sequencer::{Decision, Outcome, TerminalChooser};

#[test]
fn the_papers_script_restarts_three_times_recovers_and_reaches_stop() {
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(dir.path(), PAPER);
    let (outcome, records) = run_live(
        &script,
        mission,
        |o| o,
        None,
        &mut answering(&["queue", "register"]),
    );
    expect![[r#"
        mission door sign queue register oops
        run door #1
        > exit code 0
        transition door -> sign on 0
        run sign #1
        > exit code 0
        transition sign -> sign on 0
        run sign #1
        > exit code 0
        transition sign -> sign on 0
        run sign #1
        > exit code 1
        transition sign -> queue on 1
        run queue #1
        > signal 11
        restart queue attempt 2
        run queue #2
        > signal 11
        restart queue attempt 3
        run queue #3
        > signal 11
        restart queue attempt 4
        run queue #4
        > signal 11
        recover from queue
        run oops #1
        > exit code 0
        ask the supervisor: door, sign, queue, register, oops or stop (suggested stop)
        > the supervisor's choice of `queue`
        resume at queue
        run queue #1
        > exit code 0
        transition queue -> register on 0
        run register #1
        > exit code 7
        recover from register
        run oops #1
        > exit code 0
        ask the supervisor: door, sign, queue, register, oops or stop (suggested stop)
        > the supervisor's choice of `register`
        resume at register
        run register #1
        > exit code 0
        transition register -> stop on 0
        finished
    "#]]
    .assert_eq(&show(&records));
    assert!(outcome.is_finished(), "{outcome:?}");
    let seqs: Vec<u64> = records.iter().map(|r| r.seq).collect();
    assert_eq!(seqs, (0..records.len() as u64).collect::<Vec<_>>());
    assert!(records.windows(2).all(|w| w[0].time_ns <= w[1].time_ns));
}

#[test]
fn without_use_gui_the_recovery_states_transition_is_followed_to_stop() {
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(dir.path(), &PAPER.replace("use gui\n", ""));
    let (outcome, records) = run_live(&script, mission, |o| o, None, &mut |_, _| {});
    let shown = show(&records);
    let tail: Vec<&str> = shown.lines().rev().take(6).collect();
    assert_eq!(
        tail,
        [
            "finished",
            "transition oops -> stop on 0",
            "> exit code 0",
            "run oops #1",
            "recover from queue",
            "> signal 11"
        ]
    );
    assert!(outcome.is_finished());
}

#[test]
fn a_program_that_outlives_its_timeout_is_killed_and_counts_as_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(
        dir.path(),
        "start slow\nrestart 1\n\
         state slow {P} --runs {D}/slow.runs pidfile:{D}/slow.pid,sleep:60000 exit:0\n\
           timeout 300ms\n  action 0 trans fast\n\
         state fast {P} ignore-term,pidfile:{D}/fast.pid,sleep:60000\n\
           timeout 300ms\n  action 0 trans stop\n",
    );
    let (outcome, records) = run_live(&script, mission, |o| o, None, &mut |_, _| {});
    expect![[r#"
        mission slow fast
        run slow #1
        > timeout
        restart slow attempt 2
        run slow #2
        > exit code 0
        transition slow -> fast on 0
        run fast #1
        > timeout
        restart fast attempt 2
        run fast #2
        > timeout
        aborted
    "#]]
    .assert_eq(&show(&records));
    assert_eq!(
        outcome,
        Outcome::Aborted {
            reason: "`fast` ran past its 300ms timeout after 1 restart, and the script has no \
                     recovery state; nobody can be asked where to resume (unattended)"
                .into()
        }
    );
    // `fast` ignores SIGTERM: only the SIGKILL after the grace period stopped it.
    assert!(is_gone(read_pid(&dir.path().join("slow.pid"))));
    assert!(is_gone(read_pid(&dir.path().join("fast.pid"))));
}

#[test]
fn a_program_that_cannot_start_is_a_crash_and_leads_to_recovery() {
    let dir = tempfile::tempdir().unwrap();
    // The program exists when the script is checked, and is gone when it should run.
    let vanishing = dir.path().join("vanishing");
    std::fs::copy(common::TESTPROG, &vanishing).unwrap();
    let (script, mission) = write_script(
        dir.path(),
        "start gone\nrestart 1\nrecovery safe\n\
         state gone {D}/vanishing\n  action 0 trans stop\n\
         state safe {P} exit:0\n  action 0 trans stop\n",
    );
    std::fs::remove_file(&vanishing).unwrap();
    let (outcome, records) = run_live(&script, mission, |o| o, None, &mut |_, _| {});
    let shown = show(&records).replace(&dir.path().display().to_string(), "DIR");
    expect![[r#"
        mission gone safe
        run gone #1
        > failure to start (cannot start `gone`: program `DIR/vanishing` not found; check the path or PATH)
        restart gone attempt 2
        run gone #2
        > failure to start (cannot start `gone`: program `DIR/vanishing` not found; check the path or PATH)
        recover from gone
        run safe #1
        > exit code 0
        transition safe -> stop on 0
        finished
    "#]]
    .assert_eq(&shown);
    assert!(outcome.is_finished());
}

#[test]
fn the_stop_hook_stops_the_running_program_and_its_children_and_aborts() {
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(
        dir.path(),
        "start work\n\
         state work {P} pidfile:{D}/work.pid,child:{D}/child.pid,print:ready,sleep:60000\n\
           action 0 trans stop\n",
    );
    let (lines_tx, lines) = mpsc::sync_channel(64);
    let (outcome, records) = run_live(
        &script,
        mission,
        |o| lewis_sequencer::RunOptions {
            log_lines: Some(lines_tx),
            ..o
        },
        None,
        &mut |record, controller| {
            if let Entry::ProgramStarted { .. } = record.entry {
                wait_for_line(&lines, "work", "ready");
                controller.interrupt("the test's stop");
            }
        },
    );
    expect![[r#"
        mission work
        run work #1
        > an interruption (the test's stop)
        aborted
    "#]]
    .assert_eq(&show(&records));
    assert_eq!(
        outcome,
        Outcome::Aborted {
            reason: "the sequencer was interrupted (the test's stop) while `work` was running"
                .into()
        }
    );
    assert!(is_gone(read_pid(&dir.path().join("work.pid"))));
    assert!(is_gone(read_pid(&dir.path().join("child.pid"))));
}

#[test]
fn a_choice_while_nothing_is_asked_is_refused_and_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(
        dir.path(),
        "start work\nstate work {P} print:ready,wait:{D}/go\n  action 0 trans stop\n",
    );
    let (lines_tx, lines) = mpsc::sync_channel(64);
    let go = dir.path().join("go");
    let (outcome, records) = run_live(
        &script,
        mission,
        |o| lewis_sequencer::RunOptions {
            log_lines: Some(lines_tx),
            ..o
        },
        None,
        &mut |record, controller| match &record.entry {
            Entry::ProgramStarted { .. } => {
                wait_for_line(&lines, "work", "ready");
                controller.choose("work");
            }
            Entry::Refused { .. } => std::fs::write(&go, "").unwrap(),
            _ => {}
        },
    );
    expect![[r#"
        mission work
        run work #1
        refused the supervisor's choice of `work`: the supervisor's choice of `work` is unexpected while `work` runs
        > exit code 0
        transition work -> stop on 0
        finished
    "#]]
    .assert_eq(&show(&records));
    assert!(outcome.is_finished());
}

#[test]
fn the_programs_output_is_forwarded_line_by_line_with_the_states_name() {
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(
        dir.path(),
        "start talk\nstate talk {P} print:hello,eprint:oops,print:bye\n  action 0 trans stop\n",
    );
    let (lines_tx, lines) = mpsc::sync_channel(64);
    let (outcome, _) = run_live(
        &script,
        mission,
        |o| lewis_sequencer::RunOptions {
            log_lines: Some(lines_tx),
            ..o
        },
        None,
        &mut |_, _| {},
    );
    assert!(outcome.is_finished());
    let mut got: Vec<String> = lines
        .iter()
        .map(|l| format!("{} {} {}", l.name, l.stream, l.text))
        .collect();
    got.sort();
    assert_eq!(
        got,
        ["talk stderr oops", "talk stdout bye", "talk stdout hello"]
    );
}

/// A sink that hands every record to the terminal chooser and feeds its input through a
/// pipe when it is asked.
struct Typist<W: Write> {
    chooser: TerminalChooser<Vec<u8>>,
    keyboard: Option<W>,
    answers: Vec<&'static str>,
}

impl<W: Write> RecordSink for Typist<W> {
    fn record(&mut self, record: &lewis_sequencer::Record) {
        self.chooser.record(record);
        let asked = matches!(
            &record.entry,
            Entry::Decided {
                decision: Decision::AskSupervisor { .. }
            } | Entry::Refused { .. }
        );
        if asked {
            match self.answers.pop() {
                Some(answer) => {
                    let keyboard = self.keyboard.as_mut().unwrap();
                    keyboard.write_all(answer.as_bytes()).unwrap();
                    keyboard.flush().unwrap();
                }
                None => self.keyboard = None,
            }
        }
    }
}

#[test]
fn on_the_terminal_an_unknown_state_is_refused_and_a_known_one_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(
        dir.path(),
        "start a\nrecovery r\nuse gui\n\
         state a {P} --runs {D}/a.runs exit:3 exit:0\n  action 0 trans stop\n\
         state r {P} exit:0\n  action 0 trans stop\n",
    );
    let (input, keyboard) = std::io::pipe().unwrap();
    let (controller, control) = lewis_sequencer::control_channel().unwrap();
    let chooser =
        TerminalChooser::start(std::io::BufReader::new(input), Vec::new(), controller).unwrap();
    let mut typist = Typist {
        chooser,
        keyboard: Some(keyboard),
        answers: vec!["a\n", "  nowhere \n"],
    };
    let (tx, rx) = mpsc::channel();
    let mut tee = lewis_sequencer::Tee::new()
        .with(&mut typist)
        .with(lewis_sequencer::ChannelSink(tx));
    let outcome = lewis_sequencer::run_mission(
        mission,
        lewis_sequencer::RunOptions {
            supervision: lewis_sequencer::Supervision::Terminal,
            ..lewis_sequencer::RunOptions::new(&script)
        },
        &control,
        &mut tee,
    )
    .unwrap();
    drop(tee);
    let records: Vec<_> = rx.iter().collect();
    expect![[r#"
        mission a r
        run a #1
        > exit code 3
        recover from a
        run r #1
        > exit code 0
        ask the supervisor: a, r or stop (suggested stop)
        refused the supervisor's choice of `nowhere`: the supervisor chose `nowhere`, which is not a state of the mission
        > the supervisor's choice of `a`
        resume at a
        run a #1
        > exit code 0
        transition a -> stop on 0
        finished
    "#]]
    .assert_eq(&show(&records));
    assert!(outcome.is_finished());
    let printed = String::from_utf8(typist.chooser.output().clone()).unwrap();
    assert!(
        printed.contains(
            "Type the state to resume from (a, r) or `stop` (the script suggests stop: just Enter)"
        ),
        "{printed}"
    );
    assert!(printed.contains("not a state of the mission"), "{printed}");
}

#[test]
fn when_the_terminal_input_ends_while_asked_the_mission_aborts() {
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(
        dir.path(),
        "start a\nrecovery r\nuse gui\n\
         state a {P} exit:3\n  action 0 trans stop\n\
         state r {P} exit:0\n  action 0 trans stop\n",
    );
    let (input, keyboard) = std::io::pipe().unwrap();
    let (controller, control) = lewis_sequencer::control_channel().unwrap();
    let chooser =
        TerminalChooser::start(std::io::BufReader::new(input), Vec::new(), controller).unwrap();
    let mut typist = Typist {
        chooser,
        keyboard: Some(keyboard),
        answers: Vec::new(),
    };
    let outcome = lewis_sequencer::run_mission(
        mission,
        lewis_sequencer::RunOptions {
            stop_grace: Duration::from_millis(500),
            supervision: lewis_sequencer::Supervision::Terminal,
            ..lewis_sequencer::RunOptions::new(&script)
        },
        &control,
        &mut typist,
    )
    .unwrap();
    assert!(
        matches!(&outcome, Outcome::Aborted { reason } if reason.contains("terminal")),
        "{outcome:?}"
    );
}
