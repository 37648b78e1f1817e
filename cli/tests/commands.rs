//! The `lewis` binary as a user runs it: output and exit codes.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

#[cfg(feature = "viewer")]
mod reference;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn lewis(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lewis"))
        .args(args)
        .current_dir(repo())
        .output()
        .unwrap()
}

fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

#[test]
fn idl_check_passes_on_the_shipped_definitions() {
    let out = lewis(&["idl", "check"]);
    assert_eq!(out.status.code(), Some(0), "{}", stdout(&out));
    assert!(
        stdout(&out).starts_with("interfaces/idl: "),
        "{}",
        stdout(&out)
    );
}

#[test]
fn idl_check_on_broken_files_exits_1_with_one_error_each() {
    let out = lewis(&["idl", "check", "interfaces/tests/idl-broken"]);
    assert_eq!(out.status.code(), Some(1));
    let text = stdout(&out);
    assert!(text.ends_with("18 errors\n"), "{text}");
    assert!(
        text.contains("UnknownType.xml:5:24: error: unknown type `Flaot`"),
        "{text}"
    );
}

#[test]
fn idl_check_on_a_missing_folder_exits_2() {
    let out = lewis(&["idl", "check", "no/such/folder"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no/such/folder is not a folder"));
}

#[test]
fn idl_show_prints_the_ros2msg_schema_and_names_unknown_ones() {
    let out = lewis(&["idl", "show", "Distance"]);
    assert_eq!(out.status.code(), Some(0));
    assert!(stdout(&out).starts_with(
        "lewis_interfaces/Header header\nint32 sector_count\nfloat64[] sector_distances\n"
    ));
    let out = lewis(&["idl", "show", "Laser"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("no interface or type named `Laser`; known: Blobs")
    );
}

#[test]
fn info_reads_every_ros2_recording_of_the_shared_data() {
    let dir = repo().join("../shared/data/mcap");
    assert!(dir.is_dir(), "{} is missing", dir.display());
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert_eq!(files.len(), 5);
    for file in files {
        let out = lewis(&["info", file.to_str().unwrap(), "--messages", "100"]);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{}: {}",
            file.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        let json = lewis(&["info", file.to_str().unwrap(), "--json"]);
        let report: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
        assert!(report["channels"].as_array().is_some_and(|c| !c.is_empty()));
    }
}

#[test]
fn info_on_a_file_that_is_not_mcap_exits_2() {
    let out = lewis(&["info", "README.md"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("README.md is not an MCAP file"));
}

#[test]
fn up_refuses_a_misspelt_kind_or_parameter_before_starting_anything() {
    let dir = tempfile::tempdir().unwrap();
    let robot = std::fs::read_to_string(repo().join("robots/sim.toml")).unwrap();
    let bad = robot
        .replacen("kind = \"sim-laser\"", "kind = \"sim-lazer\"", 1)
        .replacen("max_range_m = 5.0", "max_rnage_m = 5.0", 1);
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, &bad).unwrap();
    // A namespace of its own, so that nothing could meet another test's services.
    let out = Command::new(env!("CARGO_BIN_EXE_lewis"))
        .args([
            "up",
            path.to_str().unwrap(),
            "--duration",
            "5s",
            "--no-record",
        ])
        .env(
            "LEWIS_NAMESPACE",
            format!("bad-robot-{}", std::process::id()),
        )
        .current_dir(repo())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    let line_of = |text: &str| bad.lines().position(|l| l.contains(text)).unwrap() + 1;
    assert!(
        stderr.contains(&format!(
            "bad.toml:{}:8: service `laser` has kind `sim-lazer`, which this lewis does not know: did you mean `sim-laser`?",
            line_of("sim-lazer")
        )),
        "{stderr}"
    );
    assert!(
        stderr.contains(&format!(
            "bad.toml:{}:1: parameters of service `sonar` (kind `sim-sonar`): unknown field `max_rnage_m`: did you mean `max_range_m`?",
            line_of("max_rnage_m")
        )),
        "{stderr}"
    );
    // Found at load: the broker never came up, so no service was started.
    assert!(!stderr.contains("broker up"), "{stderr}");
}

#[test]
fn durations_are_written_with_a_unit_everywhere() {
    let out = lewis(&["up", "robots/sim.toml", "--duration", "5"]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("invalid duration `5`: it has no unit"),
        "{stderr}"
    );
}

#[test]
fn demo_pictures_only_draws_the_demo_already_there_and_runs_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let out_arg = out.to_str().unwrap();
    let missing = lewis(&["demo", "--pictures-only", "--out", out_arg]);
    assert_ne!(missing.status.code(), Some(0));
    let error = String::from_utf8_lossy(&missing.stderr);
    assert!(error.contains("run `lewis demo` first"), "{error}");

    std::fs::create_dir_all(&out).unwrap();
    std::fs::copy(
        repo().join("tests/data/reference/sim-goal.mcap"),
        out.join("run.mcap"),
    )
    .unwrap();
    let drawn = lewis(&["demo", "--pictures-only", "--out", out_arg]);
    assert_eq!(drawn.status.code(), Some(0), "{}", stdout(&drawn));
    assert!(stdout(&drawn).contains("rerun: "), "{}", stdout(&drawn));
    for file in ["run.png", "run.rrd"] {
        assert!(out.join(file).is_file(), "{file}: {}", stdout(&drawn));
    }
    // Nothing ran: no mission records, no replay.
    assert!(!out.join("events.jsonl").exists());
    assert!(!out.join("replay.mcap").exists());
}

/// The real laser-only ROS 2 bag of `../shared/data/ros2/`.
fn shared_bag(name: &str) -> PathBuf {
    let path = repo().join("../shared/data/ros2").join(name);
    assert!(
        path.is_file(),
        "{} is missing: the real ROS 2 recordings live in ../shared/data/ros2 (see its README)",
        path.display()
    );
    path
}

#[test]
fn world_from_a_laser_bag_and_its_check_on_held_out_scans_meet_the_goal() {
    let bag = shared_bag("hokuyo-scan-matcher-demo.mcap");
    let dir = tempfile::tempdir().unwrap();
    let world = dir.path().join("hokuyo");
    let (bag, world_arg) = (bag.to_str().unwrap(), world.to_str().unwrap());
    let out = lewis(&["world", "from", bag, "-o", world_arg, "--hold-out"]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}{}",
        stdout(&out),
        String::from_utf8_lossy(&out.stderr)
    );
    let text = stdout(&out);
    assert!(
        text.contains("poses: no poses (scan matching alone)"),
        "{text}"
    );
    for file in [
        "world.toml",
        "map.png",
        "trajectory.csv",
        "moving.png",
        "rebuild.png",
    ] {
        assert!(world.join(file).is_file(), "{file} missing: {text}");
    }
    let out = lewis(&["world", "check", bag, world_arg]);
    let text = stdout(&out);
    assert_eq!(out.status.code(), Some(0), "{text}");
    assert!(text.starts_with("held out (180 scans, "), "{text}");
    assert!(text.contains("meets the goal"), "{text}");
    assert!(world.join("check-time.png").is_file() && world.join("check-map.png").is_file());
}

#[test]
fn world_from_a_bag_without_a_laser_exits_2_naming_the_file() {
    let bag = shared_bag("husky-outdoor-imu-odom-gps.mcap");
    let dir = tempfile::tempdir().unwrap();
    let out = lewis(&[
        "world",
        "from",
        bag.to_str().unwrap(),
        "-o",
        dir.path().join("w").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let error = String::from_utf8_lossy(&out.stderr);
    assert!(
        error.contains("husky-outdoor-imu-odom-gps.mcap: no laser scans"),
        "{error}"
    );
    assert!(!dir.path().join("w").exists());
}
