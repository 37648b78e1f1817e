//! Robot files for the failover tests: a laser (quality 10) and a sonar (quality 5), both
//! `test-range` services providing RangeFinder and Distance, with the knobs the tests turn.

#![allow(clippy::expect_used)]

use std::fmt::Write;
use std::path::Path;

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

/// The text of the shipped robot file `robots/NAME` with every `= "robots/..."` path (the
/// world, colour files) made absolute: the tests run `lewis up` in a temporary directory.
///
/// # Panics
/// When the file is not in the repository.
#[must_use]
pub fn shipped_robot(name: &str) -> String {
    let text = std::fs::read_to_string(crate::repo_root().join("robots").join(name))
        .unwrap_or_else(|e| panic!("robots/{name} is in the repository: {e}"));
    with_absolute_paths(&text)
}

/// A robot file's text with every `= "robots/..."` path made absolute.
#[must_use]
pub fn with_absolute_paths(text: &str) -> String {
    text.replace(
        "= \"robots/",
        &format!("= \"{}/robots/", crate::repo_root().display()),
    )
}

/// `robots/sim.toml` on two hosts, as the multi-host tests and benchmarks run it: the robot
/// host `robot` (10.0.0.1) with the simulated devices, the workstation `workstation`
/// (10.0.0.2) with the perception (blobfinder, sign_detector), and an on-board blobfinder
/// (quality 5) that stands in when the workstation is gone; `extra` appended. Its paths
/// are relative to the repository's root, where `lewis up` must run.
///
/// # Panics
/// When `robots/sim.toml` is not in the repository or has no service.
#[must_use]
pub fn sim_on_two_hosts(extra: &str) -> String {
    let sim = std::fs::read_to_string(crate::repo_root().join("robots/sim.toml"))
        .expect("robots/sim.toml is in the repository");
    let first_service = sim.find("[[services]]").expect("the robot has services");
    let hosts = "[[hosts]]\nname = \"robot\"\nlisten = [\"tcp/10.0.0.1:7447\"]\n\n\
                 [[hosts]]\nname = \"workstation\"\nlisten = [\"tcp/10.0.0.2:7447\"]\n\n";
    let mut text = format!("{}{hosts}{}", &sim[..first_service], &sim[first_service..]);
    for service in ["blobfinder", "sign_detector"] {
        text = text.replacen(
            &format!("name = \"{service}\"\n"),
            &format!("name = \"{service}\"\nhost = \"workstation\"\n"),
            1,
        );
    }
    text.push_str(
        r#"
[[services]]
name = "blobfinder_onboard"
kind = "blobfinder"
start = "on-demand"
requires = ["ImageSource"]
provides = [{ interface = "Blobs", quality = 5, cost = 3, data_rate_hz = 5.0 }]

[services.parameters]
colors = "robots/colors/conference.txt"
min_area_px = 20
max_blobs_per_color = 16
"#,
    );
    text.push_str(extra);
    text
}
