//! Samples a provider sent just before it was killed, which the recorder never received,
//! are counted as lost: no later sample of that run shows them as a gap, so the recorder
//! learns what was sent from the provider's publication ledger.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::record_common;

use std::ffi::OsStr;

use lewis_runtime::ipc::{LedgerReader, Namespace};
use lewis_tests::robot::{TestRobot, test_robot};
use lewis_tests::{RangeApp, Up, Watched, open_ipc, signal, wait_node};
use nix::sys::signal::Signal;
use record_common::Recording;

const TOPIC: &str = "/laser/RangeFinder";

#[test]
fn what_a_killed_provider_sent_and_the_recorder_never_received_is_counted_lost() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("lost.mcap");
    let robot = test_robot(&TestRobot {
        laser_start: "always",
        ..TestRobot::default()
    });
    let mut up = Up::start_with(
        dir,
        Namespace::unique("record-lost-exit"),
        &robot,
        &[OsStr::new("-o"), output.as_os_str()],
    );
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 10);
    let mut ledgers = LedgerReader::new(&up.namespace);
    let recorder = wait_node(&ipc, lewis_recorder::live::RECORDER_NODE, None);
    let mut sent = 0;
    let mut kill_laser = |app: &mut RangeApp, sent: &mut u64| {
        let laser = up.pid_of("laser");
        let watched = Watched::new(laser);
        signal(laser, Signal::SIGKILL);
        assert!(watched.wait_gone(), "the laser did not die");
        *sent += sent_on(&mut ledgers);
        // The broker starts it again, and the new run publishes.
        let _ = wait_node(&ipc, "laser", Some(laser));
        app.wait_for("laser", 10);
    };
    // The recorder stops reading. The laser dies twice: the first run's samples are in
    // memory the recorder has mapped; the second run sent to the stopped recorder only,
    // and its memory goes with it.
    signal(recorder, Signal::SIGSTOP);
    app.wait_for("laser", 10);
    kill_laser(&mut app, &mut sent);
    kill_laser(&mut app, &mut sent);
    signal(recorder, Signal::SIGCONT);
    app.wait_for("laser", 10);
    assert!(up.stop().success(), "{}", up.log());
    sent += sent_on(&mut ledgers);

    let recording = Recording::read(&[output]);
    let recorded = recording.of(TOPIC).len() as u64;
    let lost = recording.loss()[TOPIC];
    assert!(
        recorded < sent,
        "every sample sent was recorded ({recorded}): nothing went missing to count"
    );
    assert_eq!(
        recorded + lost,
        sent,
        "recorded {recorded} + lost {lost} against {sent} sent; {}",
        up.log()
    );
}

/// The samples the laser's run that died last sent on [`TOPIC`], from its ledger.
fn sent_on(ledgers: &mut LedgerReader) -> u64 {
    let ended = ledgers.ended();
    ended
        .iter()
        .filter(|e| e.channel == TOPIC)
        .map(|e| e.sent)
        .sum()
}
