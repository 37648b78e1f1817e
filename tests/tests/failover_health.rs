//! Failover on declared and missing health, end to end: a stalled laser (its heartbeat
//! thread says so), a laser that declares itself out of service, and fail back once it
//! recovers.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use lewis_runtime::ipc::Namespace;
use lewis_tests::robot::{TestRobot, set_fault, test_robot};
use lewis_tests::{RangeApp, Up, open_ipc};

/// Starts `lewis up` on the test robot with a fault file for the laser, connects the
/// application and waits until it receives from the laser.
fn start_with_fault_file(tag: &str, fail_back: bool) -> (Up, RangeApp, std::path::PathBuf) {
    start_reading(tag, fail_back, |app| app)
}

/// [`start_with_fault_file`], the application set up by `setup`.
fn start_reading(
    tag: &str,
    fail_back: bool,
    setup: impl FnOnce(RangeApp) -> RangeApp,
) -> (Up, RangeApp, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let fault = dir.path().join("laser.fault");
    let robot = test_robot(&TestRobot {
        laser_fault_file: Some(&fault),
        fail_back,
        ..TestRobot::default()
    });
    let mut up = Up::start_in(dir, Namespace::unique(tag), &robot);
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = setup(RangeApp::connect(&ipc));
    app.wait_for("laser", 5);
    (up, app, fault)
}

#[test]
fn stalled_laser_is_replaced_after_its_heartbeat_deadline() {
    let (mut up, mut app, fault) = start_with_fault_file("stall", false);
    set_fault(&fault, "stall");
    app.wait_for("sonar", 5);
    up.wait_line("SIGKILL");
    up.stop();
    let log = up.log();
    assert!(log.contains("rebind app from laser to sonar"), "{log}");
    // Its heartbeat thread saw the handler blocked and said so: failed on that word, not
    // after a second deadline of silence.
    assert!(
        log.contains("laser failed: laser stalled: its event loop is blocked in one step"),
        "the reason says what the heartbeat thread saw: {log}"
    );
}

#[test]
fn laser_out_of_service_rebinds_the_client_at_once() {
    let (mut up, mut app, fault) = start_with_fault_file("oos", false);
    set_fault(&fault, "out-of-service");
    app.wait_for("sonar", 5);
    up.stop();
    let log = up.log();
    assert!(log.contains("rebind app from laser to sonar"), "{log}");
    assert!(log.contains("out of service"), "{log}");
    assert!(
        !log.contains("stop laser"),
        "an out-of-service laser keeps running: {log}"
    );
}

#[test]
fn client_fails_back_to_the_laser_when_configured() {
    // Busy polling: the client that spins on its data follows both rebinds as well.
    let (mut up, mut app, fault) = start_reading("failback", true, RangeApp::busy_polling);
    set_fault(&fault, "out-of-service");
    app.wait_for("sonar", 5);
    set_fault(&fault, "ok");
    app.wait_for("laser", 5);
    up.stop();
    let log = up.log();
    assert!(log.contains("rebind app from sonar to laser"), "{log}");
}

#[test]
fn client_stays_on_sonar_without_fail_back() {
    let (mut up, mut app, fault) = start_with_fault_file("nofailback", false);
    set_fault(&fault, "out-of-service");
    app.wait_for("sonar", 5);
    set_fault(&fault, "ok");
    // Once the broker has heard the laser say it is healthy again (fail back would be
    // decided on that very heartbeat), the client is still on the sonar.
    let report = up.wait_status("the laser healthy again", |report| {
        report
            .lines()
            .any(|l| l.starts_with("service laser: ready") && l.contains("health ok"))
    });
    assert!(
        report.contains("client app RangeFinder -> sonar"),
        "{report}"
    );
    app.wait_for("sonar", 10);
    up.stop();
    assert!(
        !up.log().contains("rebind app from sonar to laser"),
        "{}",
        up.log()
    );
}

#[test]
fn a_laser_whose_start_blocks_past_its_heartbeat_deadline_is_not_taken_for_stalled() {
    // Opening the device takes three heartbeat deadlines; the startup deadline covers it,
    // because the harness says "ready" only once on_start has returned.
    let robot = test_robot(&TestRobot {
        heartbeat_deadline_ms: 200,
        laser_start_delay_ms: 600,
        ..TestRobot::default()
    });
    let mut up = Up::start("slow-start", &robot);
    up.wait_line("broker up");
    let mut decisions = lewis_tests::broker::Decisions::subscribe(&up.namespace);
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);
    decisions.take();
    up.stop();
    assert!(
        !app.providers.iter().any(|p| p == "sonar"),
        "the client never left the laser: {:?}",
        app.providers
    );
    assert!(
        !decisions
            .seen
            .iter()
            .any(|d| d.service == "laser" && d.action == "service-failed"),
        "the laser was taken for stalled:\n{}",
        decisions.describe()
    );
    assert!(
        up.log().contains("opening the device takes 600 ms"),
        "{}",
        up.log()
    );
}
