//! Blame that follows the cause, end to end: the simulated sonar renders from the base's
//! true pose, so when the base fails for good the sonar falls silent through no fault of
//! its own. The broker must say the sonar waits for its input and name the base, keep the
//! client on the sonar, and have it served again, with no restart of the sonar, when the
//! base is retried.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use lewis_interfaces::msg::Broker;
use lewis_tests::broker::Decisions;
use lewis_tests::robot::with_absolute_paths;
use lewis_tests::{RangeApp, Up, Watched, open_ipc, signal};
use nix::sys::signal::Signal;

/// The simulated base and sonar of `robots/sim.toml`, nothing else: the base may restart
/// once, and a failed service is retried after 5 s.
const ROBOT: &str = r#"
[robot]
name = "blame"
description = "the simulated sonar, which needs the simulated base's pose"

[broker]
heartbeat_period_ms = 50
heartbeat_deadline_ms = 1000
startup_deadline_ms = 15000
data_checks = true
restart = { max_restarts = 3, window_ms = 60000, backoff_initial_ms = 100, backoff_max_ms = 1000 }
retry_failed_after_ms = 5000
retry_probation_ms = 1000

[[services]]
name = "base"
kind = "sim-base"
start = "always"
restart = { max_restarts = 1, window_ms = 60000, backoff_initial_ms = 100, backoff_max_ms = 100 }
provides = [
    { interface = "GroundTruth", quality = 10, cost = 1, data_rate_hz = 50.0 },
    { interface = "WorldState", quality = 10, cost = 1, data_rate_hz = 50.0 },
]
[services.parameters]
world = "robots/worlds/conference"
start = { x_m = 3.0, y_m = 12.5, heading_deg = 0.0 }
seed = 1
rate_hz = 50.0

[[services]]
name = "sonar"
kind = "sim-sonar"
start = "on-demand"
requires = ["GroundTruth", "WorldState"]
provides = [
    { interface = "RangeFinder", quality = 5, cost = 1, data_rate_hz = 10.0, checks = { frozen = 0 } },
]
[services.parameters]
world = "robots/worlds/conference"
seed = 3
rate_hz = 10.0
max_range_m = 5.0
"#;

fn is(action: &str, service: &str) -> impl Fn(&Broker) -> bool {
    move |d| d.action == action && d.service == service
}

/// Kills the base's current process with SIGKILL and waits until it is gone.
fn kill_base(up: &Up) {
    let pid = up.pid_of("base");
    let watched = Watched::new(pid);
    signal(pid, Signal::SIGKILL);
    assert!(watched.wait_gone(), "the base (pid {pid}) did not die");
}

#[test]
fn a_sonar_silent_for_want_of_the_failed_base_waits_and_is_served_again_on_its_retry() {
    let mut up = Up::start("blame", &with_absolute_paths(ROBOT));
    up.wait_line("broker up");
    let mut decisions = Decisions::subscribe(&up.namespace);
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("sonar", 5);
    let sonar_pid = up.pid_of("sonar");

    // One death within the base's policy, one beyond it: the base has failed.
    kill_base(&up);
    decisions.wait_for("a new base process", is("start", "base"));
    kill_base(&up);
    let failed = decisions.wait_for("the base given up", is("service-failed", "base"));

    // The sonar's silence is blamed on the base, not on the sonar.
    let waiting = decisions.wait_for("the sonar waiting", is("service-waiting", "sonar"));
    assert!(
        waiting.interface == "GroundTruth" || waiting.interface == "WorldState",
        "the sonar waits for an input of its own: {}",
        waiting.interface
    );
    assert!(
        waiting.reason.contains("base failed"),
        "the decision names the root cause: {}\n(the base's failure: {})",
        waiting.reason,
        failed.reason
    );

    // The retry brings the base back, and with it the sonar's data, to the same client.
    decisions.wait_for("the base retried", is("start", "base"));
    decisions.wait_for("the sonar resumed", is("service-resumed", "sonar"));
    app.wait_for("sonar", 5);
    decisions.take();
    up.stop();

    assert!(
        app.providers.iter().all(|p| p == "sonar"),
        "the client stayed on the sonar throughout: {:?}",
        app.providers
    );
    let sonar = |action: &str| {
        decisions
            .seen
            .iter()
            .filter(|d| d.service == "sonar" && d.action == action)
            .count()
    };
    assert_eq!(
        (
            sonar("start"),
            sonar("service-failed"),
            sonar("restart-scheduled")
        ),
        (1, 0, 0),
        "the sonar was started once, never failed nor restarted:\n{}",
        decisions.describe()
    );
    assert_eq!(
        up.log()
            .lines()
            .filter(|l| l.starts_with("sonar: started"))
            .count(),
        1,
        "one sonar process from start to end (pid {sonar_pid}):\n{}",
        up.log()
    );
}
