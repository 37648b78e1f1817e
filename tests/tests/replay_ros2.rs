//! Every MCAP file written by ROS 2 in `../shared/data/mcap/` given to `lewis replay` is
//! refused with a reason that says what to do (they hold no robot description, so nothing
//! says which services to re-simulate), and `lewis play` publishes every message of each
//! into live IPC. Neither crashes.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::{Command, Stdio};

use lewis_runtime::ipc::Namespace;
use lewis_tests::{lewis_exe, shared_data};

const FILES: [&str; 5] = [
    "cdr_test_0.mcap",
    "rewriter_b_0.mcap",
    "talker.mcap",
    "test_bag_for_seek_0.mcap",
    "topics_and_services.mcap",
];

fn messages_in(file: &std::path::Path) -> usize {
    let bytes = std::fs::read(file).unwrap();
    mcap::MessageStream::new(&bytes).unwrap().count()
}

#[test]
fn ros2_recordings_are_refused_by_replay_with_what_to_do_instead() {
    let dir = tempfile::tempdir().unwrap();
    for name in FILES {
        let file = shared_data(&format!("mcap/{name}"));
        let out = dir.path().join(format!("{name}.replay.mcap"));
        let output = Command::new(lewis_exe())
            .arg("replay")
            .arg(&file)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{name}: {stderr}");
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        for expected in [
            "no robot description (metadata `lewis.robot`)",
            "(profile `ros2`)",
            &format!("lewis play {}", file.display()),
            &format!("lewis info {}", file.display()),
        ] {
            assert!(
                stderr.contains(expected),
                "{name}: no `{expected}` in {stderr}"
            );
        }
        assert!(!out.exists(), "{name}: an output was written");
    }
}

#[test]
fn ros2_recordings_play_every_message_into_live_ipc() {
    for name in FILES {
        let file = shared_data(&format!("mcap/{name}"));
        let namespace = Namespace::unique("play-ros2");
        let output = Command::new(lewis_exe())
            .arg("play")
            .arg(&file)
            .args(["--rate", "1000", "--namespace", namespace.as_str()])
            .stdin(Stdio::null())
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{name}: {stdout}\n{stderr}");
        let expected = format!(
            "played {}: {} messages on ",
            file.display(),
            messages_in(&file)
        );
        assert!(stdout.starts_with(&expected), "{name}: {stdout}");
        assert!(!stdout.contains("refused"), "{name}: {stdout}");
    }
}
