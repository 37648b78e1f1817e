//! `lewis up ROBOT --script MISSION.seq`, recorded: the mission's records on
//! `/lewis/sequencer` are in the file, and `lewis seq replay` on that file makes the same
//! decisions (exit 0).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::record_common;

use std::process::{Command, Stdio};

use lewis_interfaces::msg::Sequencer;
use lewis_runtime::ipc::Namespace;
use lewis_tests::doctor;
use lewis_tests::{lewis_exe, repo_root, wait_child};
use record_common::{Recording, decode};

/// Exits 0, exits 1, crashes (restarted once, then recovery), recovers: every kind of
/// record, with programs every system has.
const MISSION: &str = r#"
start first
restart 1
recovery fix

state first /bin/true
  action 0 trans second

state second /bin/false
  action 1 trans crash

state crash /bin/sh -c "kill -SEGV $$"
  action 0 trans stop

state fix /bin/true
  action 0 trans stop
"#;

#[test]
fn a_mission_run_by_lewis_up_is_recorded_and_replays_identically_from_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("mission.seq");
    std::fs::write(&script, MISSION).unwrap();
    let output = dir.path().join("run.mcap");
    let mut up = Command::new(lewis_exe())
        .arg("up")
        .arg(repo_root().join("robots/test.toml"))
        .args(["--namespace", Namespace::unique("record-mission").as_str()])
        .args(["--stop-grace-ms", "300"])
        .arg("-o")
        .arg(&output)
        .arg("--script")
        .arg(&script)
        .current_dir(dir.path())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = up.stderr.take().unwrap();
    let reader = std::thread::spawn(move || std::io::read_to_string(stderr).unwrap_or_default());
    let status = wait_child(&mut up);
    let log = reader.join().unwrap();
    // The script ends through its recovery state: a failed mission (the verdict), so
    // `lewis up` exits 1, and the recording is still closed whole.
    assert_eq!(status.code(), Some(1), "lewis up wrote:\n{log}");
    assert!(log.contains("recording closed"), "{log}");

    doctor(&output);
    let recording = Recording::read(std::slice::from_ref(&output));
    let records: Vec<Sequencer> = recording
        .of(lewis_runtime::names::SEQUENCER_CHANNEL)
        .iter()
        .map(decode)
        .collect();
    assert!(
        records.len() >= 10,
        "too few records on /lewis/sequencer: {records:?}"
    );
    assert_eq!(
        recording.channels[lewis_runtime::names::SEQUENCER_CHANNEL]["provider"],
        lewis_runtime::names::SEQUENCER_NODE
    );
    assert_eq!(
        recording.seq_runs(lewis_runtime::names::SEQUENCER_CHANNEL),
        [[1, records.len() as u64]],
        "every record, from the first"
    );

    let replay = Command::new(lewis_exe())
        .args(["seq", "replay"])
        .arg(&output)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&replay.stdout).into_owned()
        + &String::from_utf8_lossy(&replay.stderr);
    assert_eq!(
        replay.status.code(),
        Some(0),
        "lewis seq replay said:\n{said}"
    );
    assert!(said.contains("identical"), "{said}");
}
