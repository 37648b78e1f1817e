//! `lewis import carmen`: real CARMEN logs of `../shared/data/carmen/` become Lewis
//! recordings, read back by the independent Python readers (`mcap`, and `mcap-ros2-support`
//! decoding CDR from the schemas stored in the file):
//!
//! - freiburg-079 (4791 laser scans, 4772 odometry lines stamped zero): every scan and
//!   odometry line is there, the laser as the RangeFinder and Distance provider `laser`, the
//!   odometry as Egomotion, the derived sonar, the robot description stored; log time never
//!   goes backwards, and the import says what it re-timed;
//! - orebro (every scan stamped zero): re-timed from the scan period, said so;
//! - an output that exists is refused, naming it, and left as it was.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::time::Duration;

use lewis_tests::{lewis_exe, python_tool, repo_root, run_ok, shared_data, wait_child_for};
use serde_json::Value;

/// An import of the largest shared log takes seconds; a debug build on a loaded machine,
/// more.
const IMPORT_WATCHDOG: Duration = Duration::from_secs(300);

/// Runs `lewis import carmen LOG -o OUT` and returns its exit status, stdout and stderr.
fn import(log: &Path, output: &Path) -> (ExitStatus, String, String) {
    let dir = output.parent().unwrap();
    let name = output.file_name().unwrap().to_string_lossy().into_owned();
    let stdout_path = dir.join(format!("{name}.stdout"));
    let stderr_path = dir.join(format!("{name}.stderr"));
    let mut child = Command::new(lewis_exe())
        .args(["import", "carmen"])
        .arg(log)
        .arg("-o")
        .arg(output)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&stdout_path).unwrap())
        .stderr(std::fs::File::create(&stderr_path).unwrap())
        .spawn()
        .unwrap();
    let status = wait_child_for(&mut child, IMPORT_WATCHDOG);
    (
        status,
        std::fs::read_to_string(stdout_path).unwrap(),
        std::fs::read_to_string(stderr_path).unwrap(),
    )
}

/// The recording as the Python readers see it (tests/python/check_recording.py).
fn read_back(path: &Path) -> Value {
    let script = repo_root().join("tests/python/check_recording.py");
    let text = run_ok(python_tool("python").arg(script).arg(path));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// The data topics that went backwards or repeated a time (the recorder's own stats are
/// written at its close, not part of the log).
fn topics_not_increasing(summary: &Value) -> Vec<&str> {
    summary["not_increasing_per_topic"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .filter(|t| *t != "/lewis/recorder/stats")
        .collect()
}

#[test]
fn freiburg_079_is_imported_with_its_broken_odometry_clock_retimed() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("freiburg-079.mcap");
    let log = shared_data("carmen/freiburg-079-corrected.log.gz");
    let (status, stdout, stderr) = import(&log, &output);
    assert!(status.success(), "{status}\n{stdout}\n{stderr}");

    let summary = read_back(&output);
    let counts = &summary["counts"];
    // One RangeFinder and one Distance per FLASER line, one Egomotion per ODOM line.
    assert_eq!(counts["/laser/RangeFinder"], 4791, "{summary}");
    assert_eq!(counts["/laser/Distance"], 4791, "{summary}");
    assert_eq!(counts["/base/Egomotion"], 9725, "{summary}");
    // The derived sonar, every second scan.
    assert_eq!(counts["/sonar/RangeFinder"], 2396, "{summary}");
    assert_eq!(counts["/sonar/Distance"], 2396, "{summary}");
    assert!(stdout.contains("/laser/RangeFinder: 4791"), "{stdout}");

    assert_eq!(summary["backwards"], 0, "{summary}");
    assert_eq!(summary["negative"], 0, "{summary}");
    assert!(topics_not_increasing(&summary).is_empty(), "{summary}");

    // The first scan of the log: `FLASER 360 1.65 ...`, max range from
    // `PARAM robot_front_laser_max 80.99`.
    let laser = &summary["first_laser"];
    assert_eq!(laser["provider"], "laser");
    assert_eq!(laser["seq"], 1);
    assert_eq!(laser["range_count"], 360);
    assert_eq!(laser["ranges"], 360);
    assert!((laser["first_range"].as_f64().unwrap() - 1.65).abs() < 1e-6);
    assert!((laser["max_range"].as_f64().unwrap() - 80.99).abs() < 1e-4);
    assert_eq!(laser["publish_time_ns"], laser["log_time_ns"]);
    assert_eq!(summary["first_egomotion"]["provider"], "base");

    assert_eq!(
        summary["robot_files"],
        serde_json::json!(["carmen-freiburg-079-corrected.toml"])
    );
    let robot = summary["robot_text"].as_str().unwrap();
    assert!(robot.contains("kind = \"recorded\""), "{robot}");
    assert!(robot.contains("interface = \"Egomotion\""), "{robot}");

    // What was done about the clock is said.
    assert!(
        stdout.contains("odometry timestamps: 4791 of 9725 unusable (4772 zero"),
        "{stdout}"
    );
    assert!(stdout.contains("derived from the laser"), "{stdout}");
}

#[test]
fn a_log_stamped_all_zero_is_retimed_from_the_scan_period() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("orebro.mcap");
    let (status, stdout, stderr) = import(&shared_data("carmen/orebro-corrected.log.gz"), &output);
    assert!(status.success(), "{status}\n{stdout}\n{stderr}");
    assert!(
        stdout.contains("laser scan timestamps: 237 of 237 unusable (237 zero"),
        "{stdout}"
    );
    assert!(
        stdout.contains("all re-timed from the scan period"),
        "{stdout}"
    );
    let summary = read_back(&output);
    assert_eq!(summary["counts"]["/laser/RangeFinder"], 237, "{summary}");
    assert_eq!(summary["backwards"], 0, "{summary}");
    assert!(topics_not_increasing(&summary).is_empty(), "{summary}");
}

#[test]
fn an_existing_output_is_refused_and_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("taken.mcap");
    std::fs::write(&output, b"not mine").unwrap();
    let (status, stdout, stderr) = import(&shared_data("carmen/orebro-corrected.log.gz"), &output);
    assert_eq!(status.code(), Some(2), "{status}\n{stdout}\n{stderr}");
    assert!(stderr.contains("taken.mcap exists"), "{stderr}");
    assert_eq!(std::fs::read(&output).unwrap(), b"not mine");
}

#[test]
fn a_missing_log_or_one_without_scans_is_refused_with_its_reason_said_once() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.mcap");
    let (status, stdout, stderr) = import(&dir.path().join("missing.log"), &output);
    assert_eq!(status.code(), Some(2), "{status}\n{stdout}\n{stderr}");
    assert!(stderr.contains("cannot open"), "{stderr}");
    assert!(stderr.contains("missing.log"), "{stderr}");
    assert_eq!(stderr.matches("(os error 2)").count(), 1, "{stderr}");
    assert!(!output.exists());

    let log = dir.path().join("no-scans.log");
    std::fs::write(&log, "ODOM 1.0 2.0 0.0 0 0 0 1.5 host 1.5\n").unwrap();
    let (status, stdout, stderr) = import(&log, &output);
    assert_eq!(status.code(), Some(2), "{status}\n{stdout}\n{stderr}");
    assert!(stderr.contains("no laser scans"), "{stderr}");
    assert!(!output.exists());
}
