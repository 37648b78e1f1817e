//! Robot files for the failover tests: a laser (quality 10) and a sonar (quality 5), both
//! `test-range` services providing RangeFinder and Distance, with the knobs the tests turn.

#![allow(clippy::expect_used)]

use std::fmt::Write;
use std::path::Path;

pub use lewis_testkit::robot_files::{shipped_robot, sim_on_two_hosts, with_absolute_paths};

/// The knobs of [`test_robot`].
#[derive(Debug, Clone)]
pub struct TestRobot<'a> {
    /// The laser's fault file, if the test injects faults.
    pub laser_fault_file: Option<&'a Path>,
    /// The laser's start mode.
    pub laser_start: &'a str,
    /// The sonar's start mode (`standby` keeps it warm for a faster failover).
    pub sonar_start: &'a str,
    /// Whether clients move back to the laser once it is healthy again.
    pub fail_back: bool,
    /// Restarts allowed to the laser within its window.
    pub laser_max_restarts: u32,
    /// Restarts allowed to the sonar within its window.
    pub sonar_max_restarts: u32,
    /// How long the laser's `on_start` blocks (a slow device), in milliseconds.
    pub laser_start_delay_ms: u64,
    /// Heartbeat deadline of both services, in milliseconds (generous by default: the
    /// tests run on loaded machines, and only the stall test waits for it).
    pub heartbeat_deadline_ms: u64,
    /// Scans per second of each service.
    pub rate_hz: f64,
    /// Whether the broker checks the providers' data (`[broker] data_checks`).
    pub data_checks: bool,
    /// Whether each provision declares its `data_rate_hz` (the service's rate), which turns
    /// the broker's rate check on for RangeFinder.
    pub declare_rate: bool,
    /// Extra `[broker]` lines (the retry of failed services).
    pub broker_extra: &'a str,
    /// Extra TOML appended (more services).
    pub extra: &'a str,
}

impl Default for TestRobot<'_> {
    fn default() -> Self {
        Self {
            laser_fault_file: None,
            laser_start: "on-demand",
            sonar_start: "on-demand",
            fail_back: false,
            laser_max_restarts: 2,
            sonar_max_restarts: 3,
            laser_start_delay_ms: 0,
            heartbeat_deadline_ms: 1000,
            rate_hz: 50.0,
            data_checks: false,
            declare_rate: false,
            broker_extra: "",
            extra: "",
        }
    }
}

/// The robot file text.
#[must_use]
pub fn test_robot(robot: &TestRobot<'_>) -> String {
    let mut text = format!(
        r#"[robot]
name = "failover-test"
description = "a synthetic laser and a synthetic sonar"

[broker]
heartbeat_period_ms = 10
heartbeat_deadline_ms = {deadline}
startup_deadline_ms = 10000
fail_back = {fail_back}
data_checks = {data_checks}
restart = {{ max_restarts = 3, window_ms = 10000, backoff_initial_ms = 20, backoff_max_ms = 200 }}
{broker_extra}

[[services]]
name = "laser"
kind = "test-range"
start = "{laser_start}"
heartbeat_deadline_ms = {deadline}
restart = {{ max_restarts = {max_restarts}, window_ms = 60000, backoff_initial_ms = 20, backoff_max_ms = 100 }}
provides = [
    {{ interface = "RangeFinder", quality = 10, cost = 2{declared} }},
    {{ interface = "Distance", quality = 10, cost = 2{declared} }},
]

[services.parameters]
beams = 181
rate_hz = {rate}
seed = 1
start_delay_ms = {start_delay}
"#,
        deadline = robot.heartbeat_deadline_ms,
        fail_back = robot.fail_back,
        data_checks = robot.data_checks,
        laser_start = robot.laser_start,
        max_restarts = robot.laser_max_restarts,
        rate = robot.rate_hz,
        start_delay = robot.laser_start_delay_ms,
        declared = declared_rate(robot),
        broker_extra = robot.broker_extra,
    );
    if let Some(fault) = robot.laser_fault_file {
        let _ = writeln!(text, "fault_file = {:?}", fault.display().to_string());
    }
    let _ = write!(
        text,
        r#"
[[services]]
name = "sonar"
kind = "test-range"
start = "{sonar_start}"
heartbeat_deadline_ms = {deadline}
restart = {{ max_restarts = {sonar_max_restarts}, window_ms = 10000, backoff_initial_ms = 20, backoff_max_ms = 200 }}
provides = [
    {{ interface = "RangeFinder", quality = 5, cost = 1{declared} }},
    {{ interface = "Distance", quality = 5, cost = 1{declared} }},
]

[services.parameters]
beams = 24
field_of_view_deg = 360.0
max_range_m = 5.0
rate_hz = {rate}
noise_m = 0.05
seed = 2
"#,
        deadline = robot.heartbeat_deadline_ms,
        rate = robot.rate_hz,
        sonar_start = robot.sonar_start,
        sonar_max_restarts = robot.sonar_max_restarts,
        declared = declared_rate(robot),
    );
    text.push_str(robot.extra);
    text
}

/// The `data_rate_hz` entry of a provision, when the robot declares rates.
fn declared_rate(robot: &TestRobot<'_>) -> String {
    if robot.declare_rate {
        format!(", data_rate_hz = {:?}", robot.rate_hz)
    } else {
        String::new()
    }
}

/// Writes a fault word into a fault file atomically (a reader never sees half a word).
///
/// # Panics
/// When the file cannot be written.
pub fn set_fault(path: &Path, word: &str) {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, word).expect("the fault file can be written");
    std::fs::rename(&tmp, path).expect("the fault file can be renamed into place");
}
