//! The reference recording as a regression test: `tests/data/reference/sim-goal.mcap` is the
//! simulated B21r of `robots/sim-reference.toml` driving from the lobby into the corridor,
//! recorded by `lewis up` (`scripts/make-reference.sh` makes it again). `lewis replay`
//! re-simulates the ObstacleAvoider and the VectorMover over it:
//!
//! - unchanged, they reproduce every recorded output exactly (`--check` passes), and two
//!   replays write the same bytes;
//! - with a parameter of the avoider changed (`--set`, or an edited robot file with
//!   `--robot`), `--check` fails and the report says which channels differ, how many
//!   messages, from when and by how much;
//! - with the laser stalled half-way (`--inject-fault laser`), the broker moves the avoider
//!   to the sonar within the heartbeat deadline of virtual time, the avoider goes on with
//!   sonar readings, and its commands to the VectorMover change, the same way every time.
//! - it was made before recordings said which versions wrote them: `lewis info` says so,
//!   it replays all the same, and the file its replay writes says which versions wrote it.
//!
//! The replays run from the repository's root: the recorded robot names its world
//! relative to it, and the sonar that a fault starts renders from that world.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::Duration;

use lewis_tests::{lewis_exe, repo_root, run_ok, wait_child_within};
use serde_json::Value;

/// The reference recording, from the repository's root.
const REFERENCE: &str = "tests/data/reference/sim-goal.mcap";

/// A replay of the reference takes seconds; a debug build on a loaded machine, more.
const REPLAY_WATCHDOG: Duration = Duration::from_secs(600);

/// The reference robot's heartbeat deadline (robots/sim-reference.toml).
const HEARTBEAT_DEADLINE_NS: i64 = 3_000_000_000;

struct Replay {
    status: ExitStatus,
    text: String,
    report: Value,
    output: PathBuf,
}

impl Replay {
    fn channel(&self, name: &str) -> &Value {
        self.report["divergence"]
            .as_array()
            .unwrap()
            .iter()
            .find(|d| d["channel"] == name)
            .unwrap_or_else(|| panic!("no channel {name} in the report:\n{}", self.text))
    }

    fn inputs_of(&self, channel: &str) -> Vec<(String, i64, i64)> {
        self.channel(channel)["resimulated_inputs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|i| {
                (
                    i["channel"].as_str().unwrap().to_owned(),
                    i["first_ns"].as_i64().unwrap(),
                    i["last_ns"].as_i64().unwrap(),
                )
            })
            .collect()
    }
}

/// `lewis replay REFERENCE -o DIR/NAME.mcap --report DIR/NAME.json ARGS...`.
fn replay(dir: &Path, name: &str, args: &[&str]) -> Replay {
    let output = dir.join(format!("{name}.mcap"));
    let report = dir.join(format!("{name}.json"));
    let text = dir.join(format!("{name}.txt"));
    let mut child = Command::new(lewis_exe())
        .arg("replay")
        .arg(REFERENCE)
        .arg("-o")
        .arg(&output)
        .arg("--report")
        .arg(&report)
        .args(args)
        .current_dir(repo_root())
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&text).unwrap())
        .stderr(std::fs::File::create(dir.join(format!("{name}.err"))).unwrap())
        .spawn()
        .expect("lewis replay starts");
    let status = wait_child_within(&mut child, REPLAY_WATCHDOG);
    let text = std::fs::read_to_string(&text).unwrap();
    let errors = std::fs::read_to_string(dir.join(format!("{name}.err"))).unwrap();
    let report = std::fs::read_to_string(&report)
        .unwrap_or_else(|e| panic!("no report ({e}): {status}\n{text}\n{errors}"));
    println!("$ lewis replay {REFERENCE} {}\n{text}", args.join(" "));
    Replay {
        status,
        text,
        report: serde_json::from_str(&report).unwrap(),
        output,
    }
}

fn same_bytes(a: &Path, b: &Path) {
    let (a_bytes, b_bytes) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
    assert!(a_bytes.len() > 1_000_000, "{} is too small", a.display());
    assert!(
        a_bytes == b_bytes,
        "{} ({} bytes) and {} ({} bytes) differ",
        a.display(),
        a_bytes.len(),
        b.display(),
        b_bytes.len()
    );
}

#[test]
fn the_reference_replays_exactly_and_twice_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    // Same file name in two folders: the name is in the recorder's statistics.
    std::fs::create_dir(dir.path().join("a")).unwrap();
    std::fs::create_dir(dir.path().join("b")).unwrap();
    let first = replay(&dir.path().join("a"), "out", &["--check"]);
    assert!(first.status.success(), "{}", first.text);
    assert_eq!(first.report["check"]["passed"], true);
    assert_eq!(
        first.report["followed"],
        serde_json::json!(["obstacle_avoider", "vector_mover"])
    );
    for channel in [
        "/obstacle_avoider/Mover",
        "/vector_mover/Mover",
        "/lewis/commands/vector_mover",
        "/lewis/commands/obstacle_avoider",
    ] {
        let d = first.channel(channel);
        assert!(d["recorded"].as_u64().unwrap() > 0, "{}", first.text);
        assert_eq!(d["recorded"], d["resimulated"], "{}", first.text);
        assert_eq!(d["compared"], d["recorded"], "{}", first.text);
        assert_eq!(d["differing"], 0, "{}", first.text);
        assert_eq!(d["max_numeric_difference"], 0.0, "{}", first.text);
    }
    let second = replay(&dir.path().join("b"), "out", &["--check"]);
    assert!(second.status.success(), "{}", second.text);
    same_bytes(&first.output, &second.output);
}

/// `lewis info --json FILE`.
fn info(file: &Path) -> Value {
    let out = run_ok(
        Command::new(lewis_exe())
            .arg("info")
            .arg("--json")
            .arg(file),
    );
    serde_json::from_str(&out).unwrap()
}

#[test]
fn the_reference_and_its_replay_say_which_versions_wrote_them() {
    // Made again when the motion services became event driven (the reflex), by a lewis
    // that writes its versions. A recording made before versioning is still read and said
    // to be so: replay/tests/versions.rs.
    let reference = info(&repo_root().join(REFERENCE));
    assert_eq!(reference["written_by"]["kind"], "versioned", "{reference}");
    assert_eq!(reference["written_by"]["format_version"], 1, "{reference}");
    let dir = tempfile::tempdir().unwrap();
    let replayed = replay(dir.path(), "out", &["--check"]);
    assert!(replayed.status.success(), "{}", replayed.text);
    assert_eq!(replayed.report["check"]["passed"], true);
    let written = info(&replayed.output)["written_by"].clone();
    assert_eq!(written["kind"], "versioned", "{written}");
    assert_eq!(written["format_version"], 1, "{written}");
    assert_eq!(
        written["lewis_version"],
        env!("CARGO_PKG_VERSION"),
        "{written}"
    );
    assert!(
        written["interfaces"]
            .as_str()
            .is_some_and(|d| d.starts_with("crc32:")),
        "{written}"
    );
}

#[test]
fn a_changed_avoider_parameter_fails_the_check_with_a_readable_divergence_report() {
    let dir = tempfile::tempdir().unwrap();
    let set = replay(
        dir.path(),
        "set",
        &["--check", "--set", "obstacle_avoider.clearance_m=0.3"],
    );
    assert_eq!(set.status.code(), Some(1), "{}", set.text);
    assert!(
        set.text
            .contains("changed: obstacle_avoider.clearance_m = 0.3 (recorded: its default)"),
        "{}",
        set.text
    );
    let avoider = set.channel("/obstacle_avoider/Mover");
    assert!(avoider["differing"].as_u64().unwrap() > 0, "{}", set.text);
    assert!(avoider["first_divergence_ns"].as_i64().is_some());
    assert!(avoider["max_numeric_difference"].as_f64().unwrap() > 0.01);
    assert!(avoider["max_difference_field"].as_str().is_some());
    let commands = set.channel("/lewis/commands/vector_mover");
    assert!(commands["differing"].as_u64().unwrap() > 0, "{}", set.text);
    let failing = set.report["check"]["failing"].as_array().unwrap();
    assert!(failing.iter().any(|c| c == "/obstacle_avoider/Mover"));
    let line = set
        .text
        .lines()
        .find(|l| l.starts_with("/obstacle_avoider/Mover:"))
        .unwrap();
    for part in [
        "recorded",
        "re-simulated",
        "differ, first at",
        "max difference",
    ] {
        assert!(line.contains(part), "{line}");
    }
    assert!(
        set.text
            .contains("check: outputs differ from the recording")
    );

    // The same change in an edited robot file: the same replay.
    let robot = std::fs::read_to_string(repo_root().join("robots/sim-reference.toml")).unwrap();
    let (before, after) = robot
        .split_once("kind = \"obstacle_avoider\"")
        .expect("the reference robot has an obstacle_avoider");
    let params = "[services.parameters]\nrate_hz = 10.0\n";
    assert!(after.contains(params), "the avoider's parameters changed");
    let edited = format!(
        "{before}kind = \"obstacle_avoider\"{}",
        after.replacen(params, &format!("{params}clearance_m = 0.3\n"), 1)
    );
    let edited_path = dir.path().join("edited.toml");
    std::fs::write(&edited_path, edited).unwrap();
    let robot = replay(
        dir.path(),
        "robot",
        &["--check", "--robot", edited_path.to_str().unwrap()],
    );
    assert_eq!(robot.status.code(), Some(1), "{}", robot.text);
    assert_eq!(
        robot.report["parameter_changes"],
        set.report["parameter_changes"]
    );
    assert_eq!(robot.report["divergence"], set.report["divergence"]);
}

#[test]
fn a_laser_fault_moves_the_avoider_to_the_sonar_within_the_deadline_the_same_way_twice() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("a")).unwrap();
    std::fs::create_dir(dir.path().join("b")).unwrap();
    let run = replay(&dir.path().join("a"), "fault", &["--inject-fault", "laser"]);
    assert!(run.status.success(), "{}", run.text);
    let fault = &run.report["faults"][0];
    assert_eq!(fault["provider"], "laser");
    assert_eq!(fault["kind"], "stall");
    let fault_at = fault["at_ns"].as_i64().unwrap();
    let duration = run.report["duration_ns"].as_i64().unwrap();
    assert_eq!(fault_at, duration / 2, "half-way: {}", run.text);

    // The broker saw the laser's heartbeats stop and moved the avoider to the sonar once
    // the deadline had passed since the last one, in virtual time.
    let takeover = fault["takeovers"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["client"] == "obstacle_avoider" && t["interface"] == "RangeFinder")
        .unwrap_or_else(|| panic!("the avoider was not moved:\n{}", run.text));
    assert_eq!(takeover["provider"], "sonar", "{}", run.text);
    let latency = takeover["latency_ns"].as_i64().unwrap();
    assert!(
        latency > 0 && latency <= HEARTBEAT_DEADLINE_NS,
        "{latency} ns:\n{}",
        run.text
    );
    let switched_at = takeover["at_ns"].as_i64().unwrap();

    // The avoider went on with sonar readings: its outputs name the sonar from then on,
    // and the laser no more.
    let inputs = run.inputs_of("/obstacle_avoider/Mover");
    let (_, sonar_from, sonar_to) = inputs
        .iter()
        .find(|(c, ..)| c == "/sonar/RangeFinder")
        .unwrap_or_else(|| panic!("the avoider never used the sonar:\n{}", run.text))
        .clone();
    assert!(sonar_from >= switched_at, "{}", run.text);
    assert!(sonar_to > sonar_from + 1_000_000_000, "{}", run.text);
    let (_, _, laser_to) = inputs
        .iter()
        .find(|(c, ..)| c == "/laser/RangeFinder")
        .unwrap()
        .clone();
    assert!(laser_to < sonar_from, "{}", run.text);

    // Its outputs and its commands to the VectorMover diverged after the fault, not before.
    for channel in ["/obstacle_avoider/Mover", "/lewis/commands/vector_mover"] {
        let d = run.channel(channel);
        assert!(d["differing"].as_u64().unwrap() > 0, "{}", run.text);
        assert!(
            d["first_divergence_ns"].as_i64().unwrap() >= fault_at,
            "{}",
            run.text
        );
    }
    assert_eq!(run.report["check"]["passed"], false);

    let again = replay(&dir.path().join("b"), "fault", &["--inject-fault", "laser"]);
    same_bytes(&run.output, &again.output);
}
