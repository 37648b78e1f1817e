//! `lewis import carmen` on real logs of `../shared/data/carmen/`, read back by independent
//! readers, and `lewis replay` over the import: the real-log check (ObstacleAvoider
//! with a goal and Distance over freiburg-079, with and without `--inject-fault laser`, the
//! recording having a sonar-like fallback derived from the laser), and a split import
//! replayed as one run from its parts index or its parts in any order.
//!
//! The logs are cut with `--limit-scans` so that each test takes seconds in a debug build.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::record_common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lewis_interfaces::msg::Mover;
use lewis_tests::doctor;
use lewis_tests::{lewis_exe, shared_data};
use record_common::{Recording, assert_python_agrees, decode, header_of};
use serde_json::Value;

const FREIBURG: &str = "carmen/freiburg-079-corrected.log.gz";

/// Runs `lewis ARGS` in `dir`.
fn lewis(dir: &Path, args: &[&str]) -> Output {
    Command::new(lewis_exe())
        .args(args)
        .current_dir(dir)
        .output()
        .expect("lewis runs")
}

/// Runs `lewis ARGS` in `dir` and returns its stdout; fails with everything it printed
/// unless it exits 0.
fn lewis_ok(dir: &Path, args: &[&str]) -> String {
    let output = lewis(dir, args);
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "lewis {args:?} failed ({}):\n{stdout}\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    stdout
}

/// Imports `log` (a path under `../shared/data`) into `dir/out` with `extra` arguments.
fn import(dir: &Path, log: &str, out: &str, extra: &[&str]) -> (PathBuf, String) {
    let log = shared_data(log);
    let mut args = vec!["import", "carmen", log.to_str().unwrap(), "-o", out];
    args.extend_from_slice(extra);
    let stdout = lewis_ok(dir, &args);
    (dir.join(out), stdout)
}

/// Replays `inputs` in `dir` into `out` with `extra` arguments; returns the JSON report.
fn replay(dir: &Path, inputs: &[&str], out: &str, extra: &[&str]) -> Value {
    let report = format!("{out}.json");
    let mut args = vec!["replay"];
    args.extend_from_slice(inputs);
    args.extend_from_slice(&["-o", out, "--report", &report]);
    args.extend_from_slice(extra);
    lewis_ok(dir, &args);
    serde_json::from_str(&std::fs::read_to_string(dir.join(&report)).unwrap()).unwrap()
}

/// The samples the report says `client` got of `interface` from `provider`, with the
/// times of the first and the last.
fn feed(report: &Value, client: &str, interface: &str, provider: &str) -> Option<(u64, i64, i64)> {
    report["feeds"].as_array().unwrap().iter().find_map(|f| {
        (f["client"] == client && f["interface"] == interface && f["provider"] == provider).then(
            || {
                (
                    f["samples"].as_u64().unwrap(),
                    f["first_ns"].as_i64().unwrap(),
                    f["last_ns"].as_i64().unwrap(),
                )
            },
        )
    })
}

/// Log times never go backwards in the file, in the order it stores the messages.
fn assert_time_never_goes_back(file: &Path) {
    let bytes = std::fs::read(file).unwrap();
    let mut last = 0;
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        assert!(
            message.log_time >= last,
            "{}: {} at {} after {last}",
            file.display(),
            message.channel.topic,
            message.log_time
        );
        last = message.log_time;
    }
}

#[test]
fn an_imported_log_is_a_recording_with_its_robot_that_independent_readers_accept() {
    let dir = tempfile::tempdir().unwrap();
    let (file, stdout) = import(dir.path(), FREIBURG, "f.mcap", &["--limit-scans", "40"]);
    assert!(stdout.contains("40 FLASER scans of 360 beams"), "{stdout}");
    // The log's odometry lines are stamped 0 by the tool that made it: said and re-timed.
    assert!(
        stdout.contains("odometry timestamps:") && stdout.contains("re-timed"),
        "{stdout}"
    );
    assert!(
        stdout.contains("provider `sonar` is derived from the laser"),
        "{stdout}"
    );

    doctor(&file);
    let recording = Recording::read(std::slice::from_ref(&file));
    assert_python_agrees(std::slice::from_ref(&file), &recording);
    assert_time_never_goes_back(&file);
    assert_eq!(recording.of("/laser/RangeFinder").len(), 40);
    assert_eq!(recording.of("/distance/Distance").len(), 40);
    assert_eq!(recording.of("/sonar/RangeFinder").len(), 20);
    assert!(!recording.of("/base/Egomotion").is_empty());
    for source in ["laser", "base", "sonar"] {
        assert!(!recording.of(&format!("/lewis/health/{source}")).is_empty());
    }
    let derived = &recording.channels["/sonar/RangeFinder"]["derived"];
    assert!(derived.contains("derived from the laser"), "{derived}");

    // The robot that made it, as `lewis up` stores it, and the interface XML.
    let robots = &recording.metadata[lewis_recorder::ROBOT_METADATA];
    let (name, toml) = robots.iter().next().unwrap();
    assert_eq!(name, "carmen-freiburg-079-corrected.toml");
    let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    let robot = lewis_robot::parse(toml, Path::new(name), &known).unwrap();
    let services: Vec<&str> = robot.services.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(
        services,
        [
            "laser",
            "base",
            "sonar",
            "distance",
            "obstacle_avoider",
            "vector_mover"
        ]
    );
    let interfaces = &recording.metadata[lewis_recorder::INTERFACES_METADATA];
    assert!(interfaces["RangeFinder.xml"].contains("<interface name=\"RangeFinder\""));
}

#[test]
fn a_log_whose_clock_goes_backwards_is_retimed_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let (file, stdout) = import(dir.path(), "carmen/intel-corrected.log.gz", "i.mcap", &[]);
    assert!(
        stdout.contains("laser scan timestamps: 4 of 910 unusable (4 out of order"),
        "{stdout}"
    );
    assert!(
        stdout.contains("time never goes backwards in the recording"),
        "{stdout}"
    );
    // (Read back by the independent readers in the test above: the whole log takes pymcap-cli
    // half a minute.)
    assert_time_never_goes_back(&file);
    // The strict policy refuses it instead, saying why.
    let log = shared_data("carmen/intel-corrected.log.gz");
    let refused = lewis(
        dir.path(),
        &[
            "import",
            "carmen",
            log.to_str().unwrap(),
            "-o",
            "strict.mcap",
            "--strict-time",
        ],
    );
    assert_eq!(refused.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        stderr.contains("4 of 910 laser scan timestamps are unusable"),
        "{stderr}"
    );
    assert!(!dir.path().join("strict.mcap").exists());
}

#[test]
fn replaying_freiburg_079_the_avoider_runs_on_the_laser_and_after_a_laser_fault_on_the_derived_sonar()
 {
    let dir = tempfile::tempdir().unwrap();
    import(dir.path(), FREIBURG, "f.mcap", &["--limit-scans", "120"]);

    // Without a fault: the avoider and Distance work from the laser only, and the
    // re-simulated Distance is the one recorded.
    let clean = replay(dir.path(), &["f.mcap"], "clean.mcap", &["--check"]);
    let resimulated: Vec<&str> = clean["resimulated"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap())
        .collect();
    assert_eq!(
        resimulated,
        ["distance", "obstacle_avoider", "vector_mover"]
    );
    for client in ["obstacle_avoider", "distance"] {
        let (samples, _, _) = feed(&clean, client, "RangeFinder", "laser").unwrap();
        assert_eq!(samples, 120, "{client}");
        assert_eq!(
            feed(&clean, client, "RangeFinder", "sonar"),
            None,
            "{client}"
        );
    }
    assert_eq!(clean["check"]["passed"], true, "{:#}", clean["divergence"]);
    // The VectorMover's commands to the logged base were answered by replay (no base).
    assert!(clean["harness"]["calls_defaulted"].as_u64().unwrap() > 0);

    // The laser stalls half-way: the broker fails over to the derived sonar within the
    // heartbeat deadline, and the avoider goes on with sonar readings.
    let faulted = replay(
        dir.path(),
        &["f.mcap"],
        "fault.mcap",
        &["--inject-fault", "laser"],
    );
    let fault = &faulted["faults"][0];
    let fault_ns = fault["at_ns"].as_i64().unwrap();
    let takeovers = fault["takeovers"].as_array().unwrap();
    for client in ["obstacle_avoider", "distance"] {
        let takeover = takeovers
            .iter()
            .find(|t| t["client"] == client && t["interface"] == "RangeFinder")
            .unwrap_or_else(|| panic!("no takeover for {client}: {takeovers:?}"));
        assert_eq!(takeover["provider"], "sonar");
        let latency = takeover["latency_ns"].as_i64().unwrap();
        assert!((0..=500_000_000).contains(&latency), "{latency}");
        let (_, _, last_laser) = feed(&faulted, client, "RangeFinder", "laser").unwrap();
        let (sonar, first_sonar, _) = feed(&faulted, client, "RangeFinder", "sonar").unwrap();
        assert!(last_laser < fault_ns && first_sonar > fault_ns);
        assert!(sonar >= 20, "{client}: {sonar} sonar readings");
    }
    // Its Mover outputs after the failover were computed from sonar readings.
    let output = Recording::read(&[dir.path().join("fault.mcap")]);
    let start_ns = u64::try_from(faulted["start_ns"].as_i64().unwrap()).unwrap();
    let after: Vec<_> = output
        .of("/replay/obstacle_avoider/Mover")
        .iter()
        .filter(|m| m.log_time_ns > start_ns + u64::try_from(fault_ns).unwrap() + 1_000_000_000)
        .collect();
    assert!(!after.is_empty());
    for message in &after {
        let inputs = header_of(&message.data).inputs;
        assert!(
            inputs.iter().any(|i| i.channel == "/sonar/RangeFinder"),
            "{inputs:?}"
        );
        let status: Mover = decode(message);
        assert_ne!(status.status, "failed");
    }
    // Distance diverges from the recording once it comes from the sonar.
    let distance = faulted["divergence"]
        .as_array()
        .unwrap()
        .iter()
        .find(|d| d["channel"] == "/distance/Distance")
        .unwrap();
    assert!(distance["differing"].as_u64().unwrap() > 0);
    assert!(distance["first_divergence_ns"].as_i64().unwrap() >= fault_ns);
    assert_eq!(faulted["check"]["passed"], false);

    // `--all` cannot live a real robot's log again: it says so and replays open loop, the
    // logged laser and odometry fed as they were.
    let all = replay(
        dir.path(),
        &["f.mcap"],
        "all.mcap",
        &["--all", "--inject-fault", "laser"],
    );
    let mission = &all["mission"];
    assert_eq!(mission["loop"], "open", "{mission:#}");
    let because = mission["because"].as_str().unwrap();
    assert!(because.contains("not simulated"), "{because}");
    assert!(mission["replayed"].is_null(), "{mission:#}");
    let fed: Vec<&str> = all["fed"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap())
        .collect();
    assert!(fed.contains(&"laser"), "{fed:?}");
    let text = lewis_ok(
        dir.path(),
        &["replay", "f.mcap", "--all", "-o", "all-again.mcap"],
    );
    assert!(text.contains("open loop: not a prediction"), "{text}");
}

#[test]
fn the_parts_of_a_split_import_replay_as_one_run_from_their_index_or_in_any_order() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    import(d, FREIBURG, "whole.mcap", &["--limit-scans", "50"]);
    let (_, stdout) = import(
        d,
        FREIBURG,
        "split.mcap",
        &["--limit-scans", "50", "--split-duration", "4s"],
    );
    assert!(
        stdout.contains("split_000.mcap, split_001.mcap, split_002.mcap"),
        "{stdout}"
    );
    let info = lewis_ok(d, &["info", "split.parts.json"]);
    assert!(info.contains("part 3 of 3"), "{info}");

    // The same re-simulation, byte for byte, whichever way the run is given (outputs of
    // the same name, since the recorder's stats name their file).
    for (folder, inputs) in [
        ("whole", vec!["../whole.mcap"]),
        ("index", vec!["../split.parts.json"]),
        (
            "parts",
            vec![
                "../split_002.mcap",
                "../split_000.mcap",
                "../split_001.mcap",
            ],
        ),
    ] {
        let folder = d.join(folder);
        std::fs::create_dir(&folder).unwrap();
        let report = replay(&folder, &inputs, "out.mcap", &["--inject-fault", "laser"]);
        assert_eq!(
            report["faults"][0]["takeovers"].as_array().unwrap().len(),
            2
        );
    }
    let bytes = |folder: &str| std::fs::read(d.join(folder).join("out.mcap")).unwrap();
    assert!(
        bytes("whole") == bytes("index"),
        "the index replays otherwise"
    );
    assert!(
        bytes("whole") == bytes("parts"),
        "the parts replay otherwise"
    );

    // A part given twice is refused, and so is an output that would replace a part.
    let twice = lewis(d, &["replay", "split.parts.json", "split_001.mcap"]);
    assert_eq!(twice.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&twice.stderr).contains("split_001.mcap is given twice"));
    let over = lewis(d, &["replay", "split.parts.json", "-o", "split_000.mcap"]);
    assert_eq!(over.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&over.stderr).contains("is one of the recordings replayed"));
}
