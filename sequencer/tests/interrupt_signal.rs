//! Ctrl-C for real: SIGINT to the sequencer's process, caught by the [`SignalForwarder`],
//! stops the running program (and what it started) and ends the mission as aborted.
//!
//! Alone in its test binary: it installs process-wide signal handlers.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::sync::mpsc;

use common::{is_gone, read_pid, run_live, show, wait_for_line, write_script};
use expect_test::expect;
use lewis_sequencer::record::Entry;
use lewis_sequencer::{Outcome, RunOptions, SignalForwarder};

#[test]
fn sigint_stops_the_running_program_and_aborts_the_mission() {
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(
        dir.path(),
        "start work\n\
         state work {P} pidfile:{D}/work.pid,child:{D}/child.pid,print:ready,sleep:60000\n\
           action 0 trans stop\n",
    );
    let (lines_tx, lines) = mpsc::sync_channel(64);
    let mut forwarder = None;
    let (outcome, records) = run_live(
        &script,
        mission,
        |o| RunOptions {
            log_lines: Some(lines_tx),
            ..o
        },
        None,
        &mut |record, controller| {
            if let Entry::MissionStarted { .. } = record.entry {
                forwarder = Some(SignalForwarder::start(controller.clone()).unwrap());
            }
            if let Entry::ProgramStarted { .. } = record.entry {
                wait_for_line(&lines, "work", "ready");
                nix::sys::signal::raise(nix::sys::signal::Signal::SIGINT).unwrap();
            }
        },
    );
    drop(forwarder);
    expect![[r#"
        mission work
        run work #1
        > an interruption (SIGINT)
        aborted
    "#]]
    .assert_eq(&show(&records));
    assert_eq!(
        outcome,
        Outcome::Aborted {
            reason: "the sequencer was interrupted (SIGINT) while `work` was running".into()
        }
    );
    assert!(is_gone(read_pid(&dir.path().join("work.pid"))));
    assert!(is_gone(read_pid(&dir.path().join("child.pid"))));
}
