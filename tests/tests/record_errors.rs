//! When recording fails (a full disk, a missing folder), the recorder says which file, the
//! failure is published on `/lewis/broker`, the file is left valid, and the robot keeps
//! running. The full disk is a small tmpfs where one can be mounted, else a file size
//! limit on the recorder process ([`SmallDisk`]); the test checks the outcome of the kind
//! it got.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::record_common;

use std::ffi::OsStr;
use std::process::Command;
use std::time::Instant;

use lewis_interfaces::cdr;
use lewis_interfaces::msg::Broker;
use lewis_recorder::live::RECORDER_FAILED;
use lewis_runtime::ipc::{Ipc, Namespace, WaitSet, WakeMode};
use lewis_runtime::names;
use lewis_tests::doctor;
use lewis_tests::robot::{TestRobot, test_robot};
use lewis_tests::small_disk::{Kind, SmallDisk};
use lewis_tests::{RangeApp, Up, WATCHDOG, lewis_exe, open_ipc};
use record_common::{RecordProcess, Recording};

/// Waits (watchdog) for a `recorder-failed` decision on `/lewis/broker`.
fn wait_recorder_failed(subscriber: &mut lewis_runtime::ipc::Subscriber) -> Broker {
    let deadline = Instant::now() + WATCHDOG;
    let waits = WaitSet::new(WakeMode::Event);
    let mut seen = Vec::new();
    loop {
        while let Some(sample) = subscriber.receive().unwrap() {
            let message: Broker = cdr::from_bytes(sample.bytes()).unwrap();
            if message.action == RECORDER_FAILED {
                return message;
            }
            seen.push(message.action);
        }
        assert!(
            Instant::now() < deadline,
            "no recorder-failed on /lewis/broker; seen: {seen:?} (lost {})",
            subscriber.lost()
        );
        waits.wait(&[&*subscriber], Some(deadline)).unwrap();
    }
}

#[test]
fn a_full_disk_stops_the_recorder_with_a_valid_file_tells_the_broker_and_spares_the_robot() {
    let dir = tempfile::tempdir().unwrap();
    let disk_dir = dir.path().join("disk");
    std::fs::create_dir(&disk_dir).unwrap();
    // A 6 MiB tmpfs, or a 6 MiB file size limit on the recorder where none can be mounted.
    let disk = SmallDisk::new(&disk_dir, 6 * 1024 * 1024);
    let output = disk.dir().join("full.mcap");
    // Big scans, fast: the 2 MiB left beside the recorder's 4 MiB reserve fill in a second.
    let robot = test_robot(&TestRobot {
        laser_start: "always",
        rate_hz: 200.0,
        ..TestRobot::default()
    })
    .replace("beams = 181", "beams = 4000");
    let robot_path = dir.path().join("robot.toml");
    std::fs::write(&robot_path, &robot).unwrap();
    let namespace = Namespace::unique("record-full");
    let watcher = Ipc::open(&namespace, "test-broker-watch").unwrap();
    let mut decisions = watcher
        .subscriber(names::BROKER_CHANNEL, &names::broker_config())
        .unwrap();
    let recorder = RecordProcess::start_with(
        &namespace,
        &[
            OsStr::new("--robot"),
            robot_path.as_os_str(),
            OsStr::new("-o"),
            output.as_os_str(),
            OsStr::new("--compression"),
            OsStr::new("none"),
        ],
        |command| disk.apply(command),
    );
    let mut up = Up::start_with(
        tempfile::tempdir().unwrap(),
        namespace,
        &robot,
        &[OsStr::new("--no-record")],
    );
    up.wait_line("broker up");

    // Taken while the recorder lingers: a sample not taken goes with its publisher.
    let failure = wait_recorder_failed(&mut decisions);
    let (ok, out) = recorder.wait();
    assert!(!ok, "lewis record did not fail:\n{out}");
    let said = match disk.kind() {
        Kind::Tmpfs => "the disk is full",
        Kind::FileSizeLimit => "the file reached the largest size allowed",
    };
    assert!(out.contains(said), "{out}");
    assert!(out.contains(&output.display().to_string()), "{out}");
    assert!(
        failure.reason.contains(&output.display().to_string()),
        "{failure:?}"
    );
    assert!(
        failure.reason.contains("closed valid"),
        "the file was not closed valid: {failure:?}"
    );

    // The robot runs on.
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 20);
    assert!(up.stop().success(), "{}", up.log());

    doctor(&output);
    let recording = Recording::read(std::slice::from_ref(&output));
    assert!(!recording.of("/laser/RangeFinder").is_empty());
    drop(disk);
}

#[test]
fn a_missing_folder_is_named_and_lewis_up_runs_the_robot_without_recording() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-folder").join("run.mcap");
    let output = Command::new(lewis_exe())
        .args(["record", "--namespace"])
        .arg(Namespace::unique("record-missing").as_str())
        .arg("-o")
        .arg(&missing)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("does not exist"), "{stderr}");
    assert!(stderr.contains(&missing.display().to_string()), "{stderr}");

    let robot = test_robot(&TestRobot {
        laser_start: "always",
        ..TestRobot::default()
    });
    let mut up = Up::start_with(
        dir,
        Namespace::unique("record-missing-up"),
        &robot,
        &[OsStr::new("-o"), missing.as_os_str()],
    );
    up.wait_line("without recording");
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 10);
    assert!(up.stop().success(), "{}", up.log());
    assert!(up.log().contains("does not exist"), "{}", up.log());
}
