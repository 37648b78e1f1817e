//! `lewis fault` and `lewis status` through the command line against a running `lewis up`:
//! the fault goes over the service's live fault channel, and the broker's reaction is read
//! on `/lewis/broker` and in `lewis status`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::{Command, Output};

use lewis_interfaces::msg::Broker;
use lewis_tests::broker::Decisions;
use lewis_tests::robot::{TestRobot, test_robot};
use lewis_tests::{RangeApp, Up, Watched, lewis_exe, open_ipc};

/// Runs `lewis ARGS... --namespace NS` and returns what it did.
fn lewis(up: &Up, args: &[&str]) -> Output {
    Command::new(lewis_exe())
        .args(args)
        .args(["--namespace", up.namespace.as_str(), "--timeout", "10"])
        .output()
        .expect("lewis runs")
}

/// `lewis fault laser FLAG`, which must succeed and say so.
fn fault(up: &Up, flag: &str, word: &str) {
    let output = lewis(up, &["fault", "laser", flag]);
    let said = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "lewis fault laser {flag} failed ({}): {said}{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    assert_eq!(said.trim(), format!("laser: {word}"));
}

fn rebind(from: &'static str, to: &'static str) -> impl Fn(&Broker) -> bool {
    move |d| {
        d.action == "rebind" && d.client == "app" && d.from_service == from && d.to_service == to
    }
}

/// `lewis up` on the test robot, an application receiving from the laser, and the broker's
/// decisions from then on.
fn running(tag: &str, robot: &TestRobot<'_>) -> (Up, RangeApp, Decisions) {
    let mut up = Up::start(tag, &test_robot(robot));
    up.wait_line("broker up");
    let decisions = Decisions::subscribe(&up.namespace);
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);
    (up, app, decisions)
}

#[test]
fn lewis_fault_stall_makes_the_broker_kill_the_laser_and_move_the_client_to_sonar() {
    let (mut up, mut app, mut decisions) = running(
        "cli-stall",
        &TestRobot {
            heartbeat_deadline_ms: 300,
            ..TestRobot::default()
        },
    );
    let laser = Watched::new(up.pid_of("laser"));
    fault(&up, "--stall", "stall");

    let failed = decisions.wait_for("the stalled laser failed", |d| {
        d.action == "service-failed" && d.service == "laser"
    });
    assert!(
        failed.reason.starts_with("laser stalled: no heartbeat for")
            && failed.reason.contains("(its deadline: 300 ms)"),
        "{}",
        failed.reason
    );
    decisions.wait_for("the stalled laser stopped", |d| {
        d.action == "stop" && d.service == "laser"
    });
    decisions.wait_for("the client moved to sonar", rebind("laser", "sonar"));
    assert!(
        laser.wait_gone(),
        "the stalled laser (pid {}) was not killed",
        laser.pid()
    );
    app.wait_for("sonar", 5);
    up.stop();
}

#[test]
fn lewis_fault_out_of_service_moves_the_client_at_once_and_clear_brings_it_back() {
    let (mut up, mut app, mut decisions) = running(
        "cli-oos",
        &TestRobot {
            fail_back: true,
            ..TestRobot::default()
        },
    );
    let laser = up.pid_of("laser");
    fault(&up, "--out-of-service", "out-of-service");
    let moved = decisions.wait_for("the client moved to sonar", rebind("laser", "sonar"));
    assert!(moved.reason.contains("out of service"), "{}", moved.reason);
    app.wait_for("sonar", 5);
    let report = up.wait_status("the laser out of service", |r| {
        r.lines()
            .any(|l| l.starts_with("service laser:") && l.contains("health out of service"))
    });
    assert!(
        report.contains(&format!("process laser: pid {laser}")),
        "kept running: {report}"
    );

    fault(&up, "--clear", "clear");
    decisions.wait_for("the client back on the laser", rebind("sonar", "laser"));
    app.wait_for("laser", 5);
    assert!(
        !decisions
            .seen
            .iter()
            .any(|d| d.action == "stop" && d.service == "laser"),
        "an out-of-service laser is not stopped:\n{}",
        decisions.describe()
    );
    assert_eq!(up.pid_of("laser"), laser);
    up.stop();
}

/// `lewis fault laser FLAG` under the broker's data checks: the harness publishes bad
/// data under good heartbeats, the check named `check` fails the laser and the client
/// moves to the sonar.
fn bad_live_data_is_caught(flag: &str, word: &str, check: &str) {
    let (mut up, mut app, mut decisions) = running(
        &format!("cli-{word}"),
        &TestRobot {
            data_checks: true,
            declare_rate: true,
            rate_hz: 20.0,
            ..TestRobot::default()
        },
    );
    fault(&up, flag, word);
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
    decisions.wait_for("the client moved to sonar", rebind("laser", "sonar"));
    app.wait_for("sonar", 5);
    up.stop();
}

#[test]
fn lewis_fault_frozen_is_caught_by_the_frozen_check() {
    bad_live_data_is_caught("--frozen", "frozen", "frozen");
}

#[test]
fn lewis_fault_garbage_is_caught_by_the_values_check() {
    bad_live_data_is_caught("--garbage", "garbage", "values");
}

#[test]
fn lewis_fault_kill_beyond_the_limit_of_every_provider_asks_for_help() {
    let (mut up, mut app, mut decisions) = running(
        "cli-help",
        &TestRobot {
            laser_max_restarts: 0,
            sonar_max_restarts: 0,
            ..TestRobot::default()
        },
    );
    // No restart allowed: the first kill of each provider is beyond its limit.
    for (service, next) in [("laser", Some("sonar")), ("sonar", None)] {
        let watched = Watched::new(up.pid_of(service));
        let output = lewis(&up, &["fault", service, "--kill"]);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        assert!(watched.wait_gone(), "{service} did not die");
        decisions.wait_for("the provider given up", |d| {
            d.action == "service-failed" && d.service == service
        });
        if let Some(next) = next {
            decisions.wait_for("the client moved", rebind(service, next));
            app.wait_for(next, 5);
        }
    }
    decisions.wait_for("the client left without a provider", |d| {
        d.action == "unbind" && d.client == "app" && d.service == "sonar"
    });
    let help = decisions.wait_for("help asked for", |d| d.action == "ask-for-help");
    assert_eq!(help.interface, "RangeFinder");

    let output = lewis(&up, &["status"]);
    let report = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{report}");
    assert!(report.contains("help asked for RangeFinder"), "{report}");
    assert!(
        report.contains("client app RangeFinder -> (waiting)"),
        "{report}"
    );
    assert!(report.contains("service laser: failed"), "{report}");
    assert!(report.contains("service sonar: failed"), "{report}");
    up.stop();
}
