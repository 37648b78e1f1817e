//! A failover during a recording: the provider the broker starts is recorded from its
//! first sample, and the decision is in the file.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::record_common;

use std::ffi::OsStr;

use lewis_interfaces::msg::{Broker, RangeFinder};
use lewis_runtime::ipc::Namespace;
use lewis_tests::doctor;
use lewis_tests::robot::{TestRobot, set_fault, test_robot};
use lewis_tests::{RangeApp, Up, open_ipc};
use record_common::{Recording, assert_every_run_complete, decode};

#[test]
fn the_sonar_started_by_a_failover_is_recorded_from_its_first_sample_with_the_rebind() {
    let dir = tempfile::tempdir().unwrap();
    let fault = dir.path().join("laser.fault");
    let output = dir.path().join("failover.mcap");
    let robot = test_robot(&TestRobot {
        laser_fault_file: Some(&fault),
        laser_max_restarts: 0,
        ..TestRobot::default()
    });
    let mut up = Up::start_with(
        dir,
        Namespace::unique("record-failover"),
        &robot,
        &[OsStr::new("-o"), output.as_os_str()],
    );
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);
    set_fault(&fault, "crash");
    app.wait_for("sonar", 10);
    assert!(up.stop().success(), "{}", up.log());

    doctor(&output);
    let recording = Recording::read(std::slice::from_ref(&output));
    // The sonar's channel was subscribed from the start: its first sample is there.
    assert_every_run_complete(&recording, "/sonar/RangeFinder");
    assert_eq!(recording.seq_runs("/sonar/RangeFinder").len(), 1);
    let first: RangeFinder = decode(&recording.of("/sonar/RangeFinder")[0]);
    assert_eq!(
        (first.header.provider.as_str(), first.header.seq),
        ("sonar", 1)
    );
    assert_every_run_complete(&recording, "/laser/RangeFinder");
    let decisions: Vec<Broker> = recording.of("/lewis/broker").iter().map(decode).collect();
    let rebind = decisions
        .iter()
        .find(|d| d.action == "rebind")
        .unwrap_or_else(|| panic!("no rebind in /lewis/broker: {decisions:?}"));
    assert_eq!(
        (
            rebind.client.as_str(),
            rebind.interface.as_str(),
            rebind.from_service.as_str(),
            rebind.to_service.as_str()
        ),
        ("app", "RangeFinder", "laser", "sonar")
    );
    assert!(
        decisions
            .iter()
            .any(|d| d.action == "start" && d.service == "sonar"),
        "{decisions:?}"
    );
    assert!(recording.of("/sonar/RangeFinder").len() >= 10);
}
