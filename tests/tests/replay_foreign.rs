//! `lewis replay` on the ROS 2 recordings of `../shared/data/mcap/` (written by rosbag2, not
//! by Lewis): each is refused with the reason (no robot description says which services
//! ran), exit code 2, nothing written, never a crash.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::{Command, Stdio};
use std::time::Duration;

use lewis_tests::{lewis_exe, shared_data, wait_child_for};

/// Refusing a file takes a moment; a loaded machine, more.
const WATCHDOG: Duration = Duration::from_secs(120);

#[test]
fn every_ros2_recording_is_refused_with_its_reason() {
    let dir = tempfile::tempdir().unwrap();
    let mut files: Vec<_> = std::fs::read_dir(shared_data("mcap"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    files.sort();
    assert!(files.len() >= 5, "{files:?}");
    for file in files {
        let name = file.file_name().unwrap().to_string_lossy().into_owned();
        let output = dir.path().join(format!("{name}.replay.mcap"));
        let stderr_path = dir.path().join(format!("{name}.stderr"));
        let mut child = Command::new(lewis_exe())
            .arg("replay")
            .arg(&file)
            .arg("-o")
            .arg(&output)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&stderr_path).unwrap())
            .spawn()
            .unwrap();
        let status = wait_child_for(&mut child, WATCHDOG);
        let stderr = std::fs::read_to_string(&stderr_path).unwrap();
        assert_eq!(status.code(), Some(2), "{name}: {status}\n{stderr}");
        assert!(
            stderr.contains("no robot description") && stderr.contains(&name),
            "{name}: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert!(!output.exists(), "{name}: {} written", output.display());
    }
}
