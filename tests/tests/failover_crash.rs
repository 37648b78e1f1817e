//! Failover after crashes, end to end: a real `lewis up`, real `test-range` processes, and
//! an application that holds a `Client<RangeFinder>` with no failover logic of its own.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use lewis_tests::robot::{TestRobot, set_fault, test_robot};
use lewis_tests::{RangeApp, Up, Watched, open_ipc, signal, wait_node};
use nix::sys::signal::Signal;

#[test]
fn laser_killed_with_sigkill_is_restarted_and_the_stream_resumes() {
    let mut up = Up::start("kill9", &test_robot(&TestRobot::default()));
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);

    let first = wait_node(&ipc, "laser", None);
    let watched = Watched::new(first);
    signal(first, Signal::SIGKILL);
    assert!(watched.wait_gone(), "the laser did not die");

    let second = wait_node(&ipc, "laser", Some(first));
    assert_ne!(first, second);
    app.wait_for("laser", 5);
    assert_eq!(app.provider(), Some("laser"));
    assert!(
        !app.providers.iter().any(|p| p == "sonar"),
        "a restart within the policy must not move the client: {:?}",
        app.providers
    );
    up.stop();
    assert!(up.log().contains("restart laser"), "{}", up.log());
}

#[test]
fn laser_crashing_beyond_its_restart_limit_rebinds_the_client_to_sonar() {
    let dir = tempfile::tempdir().unwrap();
    let fault = dir.path().join("laser.fault");
    let robot = test_robot(&TestRobot {
        laser_fault_file: Some(&fault),
        laser_max_restarts: 2,
        ..TestRobot::default()
    });
    let mut up = Up::start_in(
        dir,
        lewis_runtime::ipc::Namespace::unique("crash-limit"),
        &robot,
    );
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);

    // From now on every laser process aborts at its first tick, restarts included.
    set_fault(&fault, "crash");
    app.wait_for("sonar", 5);
    assert_eq!(app.provider(), Some("sonar"));
    up.wait_line("laser failed");
    up.stop();
    let log = up.log();
    assert!(log.contains("rebind app from laser to sonar"), "{log}");
}
