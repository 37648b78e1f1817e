//! `lewis bench long-recording`, the long recording the README's replay memory figure is
//! measured on: laps of the reference recording, read back by the Python `mcap` readers.
//! Every data channel holds exactly laps x its reference count, log time never goes
//! backwards from one lap to the next, and the robot description is kept. The output may
//! not be the reference itself.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use lewis_tests::{lewis_exe, python_tool, repo_root, run_ok, wait_child_within};
use serde_json::Value;

const REFERENCE: &str = "tests/data/reference/sim-goal.mcap";

/// Writing three laps takes a moment; a loaded machine, more.
const WATCHDOG: Duration = Duration::from_secs(120);

/// What the Python readers make of `path`: the JSON of
/// `tools/python/check_recording.py`.
fn read_back(path: &Path) -> Value {
    let script = repo_root().join("tools/python/check_recording.py");
    let text = run_ok(python_tool("python").arg(script).arg(path));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

/// Runs `lewis bench long-recording REFERENCE -o OUTPUT --size-mb MB`: status, stdout, stderr.
fn long_recording(output: &Path, size_mb: u64) -> (Option<i32>, String, String) {
    let dir = output.parent().unwrap();
    let (out, err) = (dir.join("stdout"), dir.join("stderr"));
    let mut child = Command::new(lewis_exe())
        .current_dir(repo_root())
        .args(["bench", "long-recording", REFERENCE, "-o"])
        .arg(output)
        .args(["--size-mb", &size_mb.to_string()])
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(std::fs::File::create(&err).unwrap())
        .spawn()
        .unwrap();
    let status = wait_child_within(&mut child, WATCHDOG);
    (
        status.code(),
        std::fs::read_to_string(out).unwrap(),
        std::fs::read_to_string(err).unwrap(),
    )
}

#[test]
fn laps_of_the_reference_hold_each_message_once_per_lap_in_time_order() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("long.mcap");
    // The reference is 2.5 MB: 5 MB takes three laps.
    let (code, stdout, stderr) = long_recording(&output, 5);
    assert_eq!(code, Some(0), "{stdout}\n{stderr}");
    assert!(stdout.contains("3 laps"), "{stdout}");

    let reference = read_back(&repo_root().join(REFERENCE));
    let long = read_back(&output);
    // The recorder's own statistics are written anew, not copied.
    let stats = "/lewis/recorder/stats";
    let reference_topics = reference["topics"].as_object().unwrap();
    let long_topics = long["topics"].as_object().unwrap();
    for (topic, t) in reference_topics.iter().filter(|(t, _)| *t != stats) {
        assert_eq!(
            long_topics[topic]["count"].as_u64(),
            Some(3 * t["count"].as_u64().unwrap()),
            "{topic}"
        );
    }
    assert_eq!(
        long_topics.keys().filter(|t| *t != stats).count(),
        reference_topics.keys().filter(|t| *t != stats).count()
    );
    let file = &long["files"][0];
    assert_eq!(file["log_time_backwards"], 0);
    let repeated: Vec<&String> = long_topics
        .iter()
        .filter(|(t, v)| *t != stats && v["log_time_increasing"] != true)
        .map(|(t, _)| t)
        .collect();
    assert!(repeated.is_empty(), "{repeated:?}");
    let robot = "lewis.robot";
    assert!(
        file["metadata"][robot]
            .as_object()
            .is_some_and(|m| !m.is_empty())
    );
    assert_eq!(
        file["metadata"][robot],
        reference["files"][0]["metadata"][robot]
    );
}

#[test]
fn the_reference_itself_is_refused_as_the_output() {
    let dir = tempfile::tempdir().unwrap();
    let copy = dir.path().join("ref.mcap");
    std::fs::copy(repo_root().join(REFERENCE), &copy).unwrap();
    let before = std::fs::read(&copy).unwrap();
    let mut child = Command::new(lewis_exe())
        .args(["bench", "long-recording"])
        .arg(&copy)
        .arg("-o")
        .arg(&copy)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(dir.path().join("stderr")).unwrap())
        .spawn()
        .unwrap();
    let status = wait_child_within(&mut child, WATCHDOG);
    let stderr = std::fs::read_to_string(dir.path().join("stderr")).unwrap();
    assert_eq!(status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("the reference itself"), "{stderr}");
    assert_eq!(std::fs::read(&copy).unwrap(), before);
}
