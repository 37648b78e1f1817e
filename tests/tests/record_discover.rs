//! `lewis record --namespace NS` without `--robot`: the recorder asks the namespace's
//! broker which robot it runs and records every channel of that robot, whether the robot
//! was up before the recorder or comes up after it.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::record_common;

use std::ffi::OsStr;

use lewis_runtime::ipc::Namespace;
use lewis_tests::{RangeApp, Up, open_ipc};
use record_common::{RecordProcess, Recording, assert_every_run_complete, test_robot_file};

/// Lets an application take 20 laser samples through the broker, stops the recorder and
/// the robot, and checks the file: the laser's channels from their first sample, the
/// broker's decisions, and the robot description the broker read.
fn drive_and_check(mut up: Up, recorder: RecordProcess, output: &std::path::Path) {
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 20);
    drop(app);
    let (ok, out) = recorder.stop();
    assert!(ok, "{out}");
    assert!(up.stop().success(), "{}", up.log());

    let recording = Recording::read(&[output.to_path_buf()]);
    for topic in [
        "/laser/RangeFinder",
        "/lewis/health/laser",
        "/lewis/commands/laser",
    ] {
        assert!(
            recording.channels.contains_key(topic),
            "{topic} is not in the file: {:?}",
            recording.channels.keys()
        );
    }
    assert_every_run_complete(&recording, "/laser/RangeFinder");
    assert!(recording.of("/laser/RangeFinder").len() >= 20);
    // A provider the broker never started is tapped too (a failover would start it).
    assert!(
        recording.channels.contains_key("/sonar/RangeFinder"),
        "/sonar/RangeFinder is not in the file: {:?}\nthe recorder said:\n{out}",
        recording.channels.keys()
    );
    assert!(!recording.of("/lewis/broker").is_empty());
    assert_eq!(
        recording.metadata[lewis_recorder::ROBOT_METADATA]["robot.toml"],
        test_robot_file(),
        "the robot description the broker read"
    );
}

#[test]
fn a_recorder_without_robot_file_records_every_channel_of_the_running_robot() {
    let namespace = Namespace::unique("record-discover");
    let mut up = Up::start_with(
        tempfile::tempdir().unwrap(),
        namespace.clone(),
        &test_robot_file(),
        &[OsStr::new("--no-record")],
    );
    up.wait_line("broker up");
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("run.mcap");
    let recorder = RecordProcess::start(&namespace, &[OsStr::new("-o"), output.as_os_str()]);
    assert!(
        recorder.ready_line().ends_with("(robot test)"),
        "{}",
        recorder.seen.join("\n")
    );
    drive_and_check(up, recorder, &output);
}

#[test]
fn a_recorder_started_before_the_robot_adds_its_channels_when_its_broker_answers() {
    let namespace = Namespace::unique("record-discover-late");
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("run.mcap");
    let mut recorder = RecordProcess::start(&namespace, &[OsStr::new("-o"), output.as_os_str()]);
    assert!(
        recorder.ready_line().ends_with("(no robot yet)"),
        "{}",
        recorder.seen.join("\n")
    );
    let up = Up::start_with(
        tempfile::tempdir().unwrap(),
        namespace,
        &test_robot_file(),
        &[OsStr::new("--no-record")],
    );
    recorder.wait_line("robot `test` found from its broker");
    drive_and_check(up, recorder, &output);
}
