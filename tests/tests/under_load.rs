//! The shipped simulated robot, with its 100 ms heartbeat deadline, beside `stress-ng --cpu
//! 2` (both cores of a CI machine kept busy by other work) for two minutes: the broker makes
//! no failure decision about a provider whose process was responsive and whose data was
//! valid, and a real stall injected meanwhile is still caught.
//!
//! A binary of its own, run alone: the load would starve the other tests.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stderr)]

use std::ffi::OsStr;
use std::process::Command;
use std::time::Duration;

use lewis_interfaces::msg::Broker;
use lewis_runtime::ipc::Namespace;
use lewis_tests::broker::Decisions;
use lewis_tests::robot::shipped_robot;
use lewis_tests::stress::Stress;
use lewis_tests::{Up, lewis_exe};

/// The broker's decisions that act against a provider: a failure, a restart, a move of its
/// clients away from it.
const AGAINST_A_PROVIDER: [&str; 6] = [
    "restart-scheduled",
    "service-failed",
    "service-degraded",
    "stop",
    "rebind",
    "ask-for-help",
];

/// The provider a decision acts against, if it acts against one.
fn acted_against(decision: &Broker) -> Option<&str> {
    if !AGAINST_A_PROVIDER.contains(&decision.action.as_str()) {
        return None;
    }
    Some(if decision.action == "rebind" {
        &decision.from_service
    } else {
        &decision.service
    })
}

/// The decisions seen that act against a provider other than `except`.
fn against_others<'d>(decisions: &'d Decisions, except: Option<&str>) -> Vec<&'d Broker> {
    decisions
        .seen
        .iter()
        .filter(|d| acted_against(d).is_some_and(|provider| Some(provider) != except))
        .collect()
}

fn describe(decisions: &[&Broker]) -> String {
    decisions
        .iter()
        .map(|d| {
            format!(
                "{} {} {}: {}",
                d.action, d.service, d.from_service, d.reason
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn start(tag: &str, robot: &str, args: &[&str]) -> (Up, Decisions) {
    let namespace = Namespace::unique(tag);
    let args: Vec<&OsStr> = ["--no-record"].iter().chain(args).map(OsStr::new).collect();
    let dir = tempfile::tempdir().expect("a temporary directory");
    // Subscribed before the broker starts: every decision of the run is seen.
    let decisions = Decisions::subscribe(&namespace);
    let up = Up::start_with(dir, namespace, robot, &args);
    (up, decisions)
}

#[test]
fn beside_stress_ng_no_healthy_provider_fails_and_a_stall_is_caught() {
    let robot = shipped_robot("sim.toml");
    assert!(
        robot.contains("\nheartbeat_deadline_ms = 100\n"),
        "robots/sim.toml no longer has the 100 ms heartbeat deadline this test is about"
    );
    let _load = Stress::cpus(2);

    // A minute of driving, from the lobby toward the corridor's east end: the avoider
    // plans, the mover drives, the sensors render, perception runs.
    let (mut up, mut decisions) = start(
        "load-drive",
        &robot,
        &[
            "--goal",
            "29.5,12.5",
            "--goal-timeout",
            "90s",
            "--duration",
            "60s",
        ],
    );
    up.wait_line("goal 1 sent to obstacle_avoider");
    decisions.watch_for(Duration::from_secs(60));
    up.stop();
    decisions.take();
    let against = against_others(&decisions, None);
    assert!(
        against.is_empty(),
        "healthy providers were acted against while driving beside stress-ng:\n{}\n{}",
        describe(&against),
        up.log()
    );
    for service in ["obstacle_avoider", "camera", "laser"] {
        assert!(
            decisions
                .seen
                .iter()
                .any(|d| d.action == "start" && d.service == service),
            "{service} never ran, so it was never tried under load:\n{}",
            decisions.describe()
        );
    }
    eprintln!(
        "driving: {} decisions, none against a provider",
        decisions.seen.len()
    );

    // A minute standing, the laser stalled half-way through: caught, and nothing else.
    let (mut up, mut decisions) = start("load-stall", &robot, &[]);
    decisions.wait_for("the laser's start", |d| {
        d.action == "start" && d.service == "laser"
    });
    decisions.watch_for(Duration::from_secs(30));
    let fault = Command::new(lewis_exe())
        .args([
            "fault",
            "laser",
            "--stall",
            "--namespace",
            up.namespace.as_str(),
        ])
        .output()
        .expect("lewis fault runs");
    assert!(fault.status.success(), "{fault:?}");
    decisions.wait_for("the laser's stall", |d| {
        d.action == "service-failed" && d.service == "laser" && d.reason.contains("stalled")
    });
    decisions.watch_for(Duration::from_secs(20));
    up.stop();
    decisions.take();
    let against = against_others(&decisions, Some("laser"));
    assert!(
        against.is_empty(),
        "healthy providers were acted against beside stress-ng:\n{}\n{}",
        describe(&against),
        up.log()
    );
    let caught = decisions
        .seen
        .iter()
        .filter(|d| d.action == "service-failed" && d.service == "laser")
        .count();
    assert_eq!(caught, 1, "{}", decisions.describe());
}
