//! Failover on bad data, end to end: a laser whose process is healthy by every other
//! measure (heartbeats, declared health) publishes junk, NaNs, a frozen scan or a third of
//! its scans, and the broker's checks of its data move the client to the sonar; the sonar,
//! under the same checks, is never moved.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use lewis_runtime::ipc::Namespace;
use lewis_tests::broker::Decisions;
use lewis_tests::robot::{TestRobot, set_fault, test_robot};
use lewis_tests::{RangeApp, Up, open_ipc};

/// The test robot with every data check on (rates declared) and the laser's fault file;
/// the client receiving from the laser, and the broker's decisions from then on.
fn running(tag: &str) -> (Up, RangeApp, Decisions, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let fault = dir.path().join("laser.fault");
    let robot = test_robot(&TestRobot {
        laser_fault_file: Some(&fault),
        data_checks: true,
        declare_rate: true,
        rate_hz: 20.0,
        ..TestRobot::default()
    });
    let mut up = Up::start_in(dir, Namespace::unique(tag), &robot);
    up.wait_line("broker up");
    let decisions = Decisions::subscribe(&up.namespace);
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);
    (up, app, decisions, fault)
}

/// The laser gets fault `word`: the check named `check` fails it and the client moves to
/// the sonar, which then serves a good while without being moved itself.
fn bad_data_moves_the_client(word: &str, check: &str) {
    let (mut up, mut app, mut decisions, fault) = running(&format!("data-{word}"));
    set_fault(&fault, word);
    app.wait_for("sonar", 5);
    let failed = decisions.wait_for("the laser failed", |d| {
        d.action == "service-failed" && d.service == "laser"
    });
    assert!(
        failed
            .reason
            .contains(&format!("laser failed its {check} check on RangeFinder")),
        "the reason names the check: {}",
        failed.reason
    );
    // Two seconds of the sonar (more than a rate window) under the same checks.
    app.wait_for("sonar", 40);
    decisions.take();
    up.stop();
    assert!(
        !decisions
            .seen
            .iter()
            .any(|d| d.service == "sonar" && d.action == "service-failed"),
        "the sonar was failed:\n{}",
        decisions.describe()
    );
}

#[test]
fn a_laser_publishing_garbage_fails_its_values_check() {
    bad_data_moves_the_client("garbage", "values");
}

#[test]
fn a_laser_publishing_nans_fails_its_values_check() {
    bad_data_moves_the_client("nan", "values");
}

#[test]
fn a_frozen_laser_fails_its_frozen_check() {
    bad_data_moves_the_client("frozen", "frozen");
}

#[test]
fn a_laser_at_a_third_of_its_rate_fails_its_rate_check() {
    bad_data_moves_the_client("slow", "rate");
}

#[test]
fn healthy_providers_under_every_check_are_never_moved() {
    let (mut up, mut app, mut decisions, _fault) = running("data-healthy");
    // Five seconds of scans at 20 Hz, every check on.
    app.wait_for("laser", 100);
    decisions.take();
    up.stop();
    assert!(
        !decisions.seen.iter().any(|d| matches!(
            d.action.as_str(),
            "service-failed" | "service-degraded" | "rebind"
        )),
        "a healthy provider was judged:\n{}",
        decisions.describe()
    );
}
