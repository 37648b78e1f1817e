//! Failover after crashes, end to end: a real `lewis up`, real `test-range` processes
//! killed with SIGKILL from outside, and an application that holds a `Client<RangeFinder>`
//! with no failover logic of its own. The broker's reactions are read on `/lewis/broker`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use lewis_interfaces::msg::Broker;
use lewis_tests::broker::Decisions;
use lewis_tests::robot::{TestRobot, test_robot};
use lewis_tests::{RangeApp, Up, Watched, open_ipc, signal};
use nix::sys::signal::Signal;

fn is(action: &str, service: &str) -> impl Fn(&Broker) -> bool {
    move |d| d.action == action && d.service == service
}

/// Kills the laser's current process with SIGKILL and waits until it is gone; returns its
/// pid.
fn kill_laser(up: &Up) -> u32 {
    let pid = up.pid_of("laser");
    let watched = Watched::new(pid);
    signal(pid, Signal::SIGKILL);
    assert!(watched.wait_gone(), "the laser (pid {pid}) did not die");
    pid
}

#[test]
fn laser_killed_with_sigkill_is_restarted_and_the_stream_resumes() {
    let mut up = Up::start("kill9", &test_robot(&TestRobot::default()));
    up.wait_line("broker up");
    let mut decisions = Decisions::subscribe(&up.namespace);
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);

    let first = kill_laser(&up);
    decisions.wait_for("a restart of the laser", is("restart-scheduled", "laser"));
    decisions.wait_for("a new laser process", is("start", "laser"));
    assert_ne!(up.pid_of("laser"), first);
    app.wait_for("laser", 5);
    assert_eq!(app.provider(), Some("laser"));
    assert!(
        !app.providers.iter().any(|p| p == "sonar"),
        "a restart within the policy must not move the client: {:?}",
        app.providers
    );
    up.stop();
}

#[test]
fn laser_killed_with_sigkill_beyond_its_restart_limit_rebinds_the_client_to_sonar() {
    let max_restarts = 2;
    let robot = test_robot(&TestRobot {
        laser_max_restarts: max_restarts,
        ..TestRobot::default()
    });
    let mut up = Up::start("kill9-limit", &robot);
    up.wait_line("broker up");
    let mut decisions = Decisions::subscribe(&up.namespace);
    let ipc = open_ipc(&up.namespace, "test-app");
    // Reading in place: zero-copy views follow the rebinding as decoded samples do.
    let mut app = RangeApp::connect_in_place(&ipc);
    app.wait_for("laser", 5);

    // Every kill within the policy is followed by a restart; the client stays on the laser.
    let mut killed = Vec::new();
    for _ in 0..max_restarts {
        killed.push(kill_laser(&up));
        decisions.wait_for("a restart of the laser", is("restart-scheduled", "laser"));
        decisions.wait_for("a new laser process", is("start", "laser"));
    }
    // One kill more is beyond the policy: the laser has failed, the client goes to sonar.
    killed.push(kill_laser(&up));
    let failed = decisions.wait_for("the laser given up", is("service-failed", "laser"));
    assert!(
        failed.reason.contains("beyond its restart policy"),
        "{}",
        failed.reason
    );
    let rebind = decisions.wait_for("the client moved", |d| {
        d.action == "rebind" && d.client == "app" && d.interface == "RangeFinder"
    });
    assert_eq!(
        (rebind.from_service.as_str(), rebind.to_service.as_str()),
        ("laser", "sonar")
    );
    assert!(
        !decisions
            .seen
            .iter()
            .any(|d| d.action == "restart-scheduled"
                && d.service == "laser"
                && d.at_ns > failed.at_ns),
        "no restart after the laser was given up:\n{}",
        decisions.describe()
    );

    // The application keeps receiving, now from the sonar, without doing anything.
    app.wait_for("sonar", 5);
    assert_eq!(app.provider(), Some("sonar"));
    assert_eq!(killed.len(), 3);
    let report = up.status();
    assert!(
        report.contains("client app RangeFinder -> sonar"),
        "{report}"
    );
    assert!(report.contains("service laser: failed"), "{report}");
    up.stop();
}

#[test]
fn a_laser_given_up_is_retried_after_its_cool_down_and_gets_its_client_back_once_proven() {
    let robot = test_robot(&TestRobot {
        laser_max_restarts: 0,
        fail_back: true,
        broker_extra: "retry_failed_after_ms = 300\nretry_probation_ms = 600",
        ..TestRobot::default()
    });
    let mut up = Up::start("retry", &robot);
    up.wait_line("broker up");
    let mut decisions = Decisions::subscribe(&up.namespace);
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);

    // No restart allowed: one kill fails the laser, and the client goes to the sonar.
    kill_laser(&up);
    let failed = decisions.wait_for("the laser given up", is("service-failed", "laser"));
    assert!(
        failed.reason.contains("it will be retried in 300 ms"),
        "{}",
        failed.reason
    );
    decisions.wait_for("the client moved to the sonar", |d| {
        d.action == "rebind" && d.client == "app" && d.to_service == "sonar"
    });
    app.wait_for("sonar", 5);

    // After the cool-down the laser runs again, on trial: the client stays on the sonar
    // until the laser has stayed up through its probation, then fails back.
    let retried = decisions.wait_for("the laser retried", is("start", "laser"));
    assert!(retried.reason.contains("retry laser"), "{}", retried.reason);
    assert!(retried.at_ns - failed.at_ns >= 300_000_000);
    let back = decisions.wait_for("the client back on the laser", |d| {
        d.action == "rebind" && d.client == "app" && d.to_service == "laser"
    });
    assert!(back.reason.starts_with("fail back"), "{}", back.reason);
    assert!(
        back.at_ns - retried.at_ns >= 600_000_000,
        "the client failed back before the laser's probation was over:\n{}",
        decisions.describe()
    );
    app.wait_for("laser", 5);
    assert!(up.status().contains("client app RangeFinder -> laser"));
    // The broker's messages carry a header as every publication does.
    let seqs: Vec<u64> = decisions.seen.iter().map(|d| d.header.seq).collect();
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
    assert!(
        decisions
            .seen
            .iter()
            .all(|d| d.header.provider == "lewis-broker" && d.header.publish_time_ns > 0),
        "{:?}",
        decisions.seen.first().map(|d| &d.header)
    );
    up.stop();
}
