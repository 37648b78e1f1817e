//! `my-lewis`, a binary of a team's own, is `lewis` with its kind added: `up` loads a robot
//! file that uses the kind and runs its service, `replay` re-simulates it and finds the same
//! outputs; Lewis's own `lewis` refuses the same robot file when it loads it.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::{Command, Output};

use lewis_runtime::ipc::Namespace;

/// A synthetic laser and the kind of this crate reading it.
const ROBOT: &str = r#"
[robot]
name = "front"

[broker]
heartbeat_period_ms = 20
heartbeat_deadline_ms = 1000

[[services]]
name = "laser"
kind = "test-range"
provides = [{ interface = "RangeFinder", quality = 10, cost = 1, data_rate_hz = 10.0 }]
[services.parameters]
beams = 181
field_of_view_deg = 180.0
rate_hz = 10.0
seed = 4

[[services]]
name = "front"
kind = "front-clearance"
start = "always"
requires = ["RangeFinder"]
provides = [{ interface = "Distance", quality = 5, cost = 1 }]
[services.parameters]
half_angle_deg = 30.0
"#;

fn run(command: &mut Command) -> Output {
    let output = command.output().expect("the command runs");
    assert!(
        output.status.success(),
        "{command:?}: {}\n{}\n{}",
        output.status,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

fn my_lewis() -> Command {
    Command::new(env!("CARGO_BIN_EXE_my-lewis"))
}

fn write_robot(dir: &Path) -> std::path::PathBuf {
    let robot = dir.join("front.toml");
    std::fs::write(&robot, ROBOT).unwrap();
    robot
}

#[test]
fn my_lewis_runs_records_and_replays_a_kind_of_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write_robot(dir.path());
    let run_file = dir.path().join("run.mcap");
    let namespace = Namespace::unique("my-lewis");
    run(my_lewis()
        .arg("up")
        .arg(&robot)
        .args(["--duration", "2s", "--no-companions", "--namespace"])
        .arg(namespace.as_str())
        .arg("--output")
        .arg(&run_file));

    let report_file = dir.path().join("report.json");
    run(my_lewis()
        .arg("replay")
        .arg(&run_file)
        .args(["--check", "--report"])
        .arg(&report_file));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report_file).unwrap()).unwrap();
    // The laser is fed from the recording; the new kind is run again and, given the same
    // scans, publishes what it published live (`--check` exits 1 otherwise).
    assert_eq!(report["resimulated"], serde_json::json!(["front"]));
    assert_eq!(report["followed"], serde_json::json!(["front"]));
}

#[test]
fn lewis_without_the_kind_refuses_the_robot_file_when_it_loads_it() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write_robot(dir.path());
    let output = Command::new(lewis_testkit::lewis_exe())
        .arg("up")
        .arg(&robot)
        .args(["--duration", "1s", "--no-record"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("front-clearance"), "{stderr}");
}

#[test]
fn the_kind_answers_a_scan_in_the_test_kits_harness() {
    use lewis_interfaces::msg::{Distance, RangeFinder};
    use lewis_service::ServiceRegistry;
    use lewis_testkit::{Harness, robot};

    let robot = robot(ROBOT);
    let mut registry = ServiceRegistry::new();
    lewis_example_front_clearance::register(&mut registry);
    let mut front = Harness::build(&robot, "front", &registry).unwrap();
    front.start(0).unwrap();
    // Beams at -90, 0 and +90 degrees: only the one straight ahead is in the cone.
    let scan = RangeFinder {
        range_count: 3,
        ranges: vec![0.5, 2.5, 0.7],
        max_range: 8.0,
        uniform: true,
        theta_offset: -std::f64::consts::FRAC_PI_2,
        theta_separation: std::f64::consts::FRAC_PI_2,
        ..RangeFinder::default()
    };
    front.send(10_000_000, "laser", &scan);
    let published = front.take::<Distance>();
    assert_eq!(published.len(), 1);
    assert_eq!(published[0].sector_distances, [2.5]);
}
