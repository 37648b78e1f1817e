//! `lewis demo --chaos --duration 3m`: the Challenge mission again and again while random
//! providers are killed, stalled, frozen, garbled and put out of service. Whatever the
//! missions' fates, nothing recorded is lost, no run leaves anything in shared memory, the
//! machine's use is read, and a mission that failed keeps its recording and faults with
//! the command that lives it again.
//!
//! Its own test binary: live missions in real time, which should not share the machine
//! with other end-to-end tests.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stderr)]

use std::path::Path;
use std::process::{Command, Stdio};

use lewis_tests::{lewis_exe, repo_root};
use serde_json::Value;

#[test]
fn three_minutes_of_chaos_lose_nothing_and_leave_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("chaos");
    let child = Command::new(lewis_exe())
        .current_dir(repo_root())
        .args([
            "-q",
            "demo",
            "--chaos",
            "--duration",
            "3m",
            "--seed",
            "3",
            "--out",
        ])
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lewis demo --chaos starts");
    // The run's namespaces are `chaos-PID-...`, made by this process.
    let namespaces = format!("chaos-{}-", child.id());
    let run = child.wait_with_output().expect("lewis demo --chaos runs");
    let printed = format!(
        "{}{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    let report: Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("chaos.json"))
            .unwrap_or_else(|e| panic!("no chaos.json ({e}):\n{printed}")),
    )
    .unwrap();
    let missions = report["missions"].as_array().unwrap();
    // Three minutes hold at least two missions of about two minutes: the second starts
    // before the time is up, and is cut short by it.
    assert!(
        missions.len() >= 2,
        "{} missions:\n{printed}",
        missions.len()
    );
    for m in missions {
        let number = &m["number"];
        assert_eq!(m["lost"], 0, "mission {number} lost messages:\n{printed}");
        assert_eq!(
            m["leftovers"], 0,
            "mission {number} left shared memory:\n{printed}"
        );
        assert!(
            m["recorded"].as_u64().unwrap() > 1000,
            "mission {number}: {m}"
        );
        if m["cut_short"] == true {
            assert!(
                m["kept"].is_null(),
                "a mission cut short by the run's end is not judged"
            );
        } else if m["succeeded"] == false {
            let kept = Path::new(m["kept"].as_str().expect("a failed mission is kept"));
            for file in ["run.mcap", "faults.json", "events.jsonl", "robot.toml"] {
                assert!(kept.join(file).is_file(), "mission {number} keeps {file}");
            }
            let command = m["replay_command"].as_str().unwrap();
            assert!(
                command.starts_with("lewis replay ") && command.contains(" --all"),
                "{command}"
            );
            assert!(
                m["replay_fails_too"].is_boolean() || m["replay_error"].is_string(),
                "mission {number} was lived again: {m}"
            );
        } else {
            assert!(
                m["kept"].is_null(),
                "a mission that succeeded leaves only its line"
            );
        }
    }
    let struck = missions
        .iter()
        .flat_map(|m| m["faults"].as_array().unwrap())
        .filter(|f| !f["struck_ns"].is_null())
        .count();
    assert!(struck >= 5, "{struck} faults struck:\n{printed}");
    assert!(
        missions
            .iter()
            .any(|m| m["broker"]["restarts"].as_u64() > Some(0)
                || m["broker"]["failovers"].as_u64() > Some(0)),
        "the broker did something about the faults:\n{printed}"
    );

    // The machine's use was read all along, for every process of the run.
    let samples = report["samples"].as_array().unwrap();
    assert!(samples.len() >= 20, "{} samples", samples.len());
    let names: Vec<&str> = report["memory"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    for name in ["lewis", "record", "base", "laser"] {
        assert!(names.contains(&name), "{name} measured: {names:?}");
    }
    assert!(out.join("chaos.png").is_file(), "the picture is drawn");

    // Nothing of this run is left in shared memory.
    for root in ["/dev/shm", "/tmp/iceoryx2"] {
        let left: Vec<String> = std::fs::read_dir(root)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|name| name.contains(&namespaces))
            .collect();
        assert!(left.is_empty(), "left in {root}: {left:?}");
    }
    // The lines for people: one per mission and the totals.
    assert!(printed.contains("mission 1: "), "{printed}");
    assert!(printed.contains("messages recorded, 0 lost"), "{printed}");
}
