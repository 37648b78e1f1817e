//! A recorder killed with SIGKILL in the middle of a run: `lewis recover` repairs its file
//! up to the last complete chunk, and the robot keeps running.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::record_common;

use std::ffi::OsStr;
use std::process::Command;

use lewis_runtime::ipc::Namespace;
use lewis_tests::doctor;
use lewis_tests::robot::{TestRobot, test_robot};
use lewis_tests::{RangeApp, Up, Watched, lewis_exe, open_ipc, run_ok, signal, wait_node};
use nix::sys::signal::Signal;
use record_common::{Recording, assert_every_run_complete, assert_python_agrees};

#[test]
fn a_recorder_killed_with_sigkill_leaves_a_file_that_lewis_recover_repairs() {
    let dir = tempfile::tempdir().unwrap();
    let broken = dir.path().join("killed.mcap");
    let fixed = dir.path().join("fixed.mcap");
    let robot = test_robot(&TestRobot {
        laser_start: "always",
        ..TestRobot::default()
    });
    let mut up = Up::start_with(
        dir,
        Namespace::unique("record-kill"),
        &robot,
        &[OsStr::new("-o"), broken.as_os_str()],
    );
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    // Three seconds of samples at 50 Hz: the recorder has flushed chunks (at least every
    // second of receive time).
    app.wait_for("laser", 150);
    let recorder = wait_node(&ipc, lewis_recorder::live::RECORDER_NODE, None);
    let watched = Watched::new(recorder);
    signal(recorder, Signal::SIGKILL);
    assert!(watched.wait_gone(), "the recorder did not die");
    // The robot does not care.
    app.wait_for("laser", 20);
    assert!(up.stop().success(), "{}", up.log());

    let out = run_ok(
        Command::new(lewis_exe())
            .arg("recover")
            .arg(&broken)
            .arg("-o")
            .arg(&fixed),
    );
    assert!(out.contains("was cut off"), "{out}");
    doctor(&fixed);
    let files = [fixed];
    let recording = Recording::read(&files);
    assert_python_agrees(&files, &recording);
    assert_every_run_complete(&recording, "/laser/RangeFinder");
    let runs = recording.seq_runs("/laser/RangeFinder");
    assert_eq!(runs.len(), 1, "{runs:?}");
    // At least the first second of the run survived.
    assert!(runs[0][1] >= 50, "{runs:?}");
}
