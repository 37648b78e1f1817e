//! `lewis import ros2`: bags written by an independent writer (Python's
//! `mcap-ros2-support`, with ROS 2's own message definitions, `tools/python/write_ros2_bag.py`)
//! imported and checked field by field; replay over the import (deterministic, `--check`,
//! a laser fault moving the avoider to the fallback, the blob finder's outputs over the
//! camera re-simulated); bad bags refused with the file, the
//! topic, the message and what is wrong, nothing written; and the real bags of
//! `../shared/data/ros2/` and rosbag2's test bags imported or refused clearly.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Egomotion, ImageSource, RangeFinder};
use lewis_tests::{lewis_exe, python_tool, repo_root, run_ok, shared_data};
use serde_json::Value;

const BEAMS: usize = 181;

fn lewis(dir: &Path, args: &[&str]) -> Output {
    Command::new(lewis_exe())
        .args(args)
        .current_dir(dir)
        .output()
        .expect("lewis runs")
}

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

/// Writes the test bag `variant` at `dir/name` with the Python writer.
fn write_bag(dir: &Path, name: &str, variant: &str) -> PathBuf {
    let path = dir.join(name);
    let script = repo_root().join("tools/python/write_ros2_bag.py");
    let _ = run_ok(python_tool("python").arg(script).arg(&path).arg(variant));
    path
}

/// The messages of a file per topic, in file order, as (log time, bytes).
fn messages(file: &Path) -> BTreeMap<String, Vec<(u64, Vec<u8>)>> {
    let bytes = std::fs::read(file).unwrap();
    let mut out: BTreeMap<String, Vec<(u64, Vec<u8>)>> = BTreeMap::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        out.entry(message.channel.topic.clone())
            .or_default()
            .push((message.log_time, message.data.into_owned()));
    }
    out
}

/// Each channel's `offered_qos_profiles` (empty when it has none), by topic.
fn offered_qos(file: &Path) -> BTreeMap<String, String> {
    let bytes = std::fs::read(file).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    summary
        .channels
        .values()
        .map(|c| {
            let qos = c.metadata.get("offered_qos_profiles").cloned();
            (c.topic.clone(), qos.unwrap_or_default())
        })
        .collect()
}

fn replay(dir: &Path, input: &str, out: &str, extra: &[&str]) -> Value {
    let report = format!("{out}.json");
    let mut args = vec!["replay", input, "-o", out, "--report", &report];
    args.extend_from_slice(extra);
    lewis_ok(dir, &args);
    serde_json::from_str(&std::fs::read_to_string(dir.join(&report)).unwrap()).unwrap()
}

fn feed(report: &Value, client: &str, interface: &str, provider: &str) -> Option<u64> {
    report["feeds"].as_array().unwrap().iter().find_map(|f| {
        (f["client"] == client && f["interface"] == interface && f["provider"] == provider)
            .then(|| f["samples"].as_u64().unwrap())
    })
}

// The values the writer script wrote, as functions of the message index.
fn ranges(i: usize) -> Vec<f64> {
    let mut out: Vec<f64> = (0..BEAMS)
        .map(|b| f64::from((0.5 + ((i * 31 + b * 7) % 900) as f64 / 100.0) as f32))
        .collect();
    // 30 + i m is beyond range_max (30 m) but for i = 0: published as max range.
    out[7] = 30.0;
    out
}

fn pose(i: usize) -> (f64, f64, f64) {
    let i = i as f64;
    (0.1 * i, 0.02 * i, 0.05 * i)
}

fn pixels(i: usize) -> Vec<u8> {
    (0..6 * 4 * 3)
        .map(|k| ((i * 17 + k * 5) % 256) as u8)
        .collect()
}

#[test]
fn a_bag_of_an_independent_writer_arrives_unchanged_field_by_field() {
    let dir = tempfile::tempdir().unwrap();
    let bag = write_bag(dir.path(), "good.mcap", "good");
    let stdout = lewis_ok(
        dir.path(),
        &["import", "ros2", "good.mcap", "-o", "out.mcap"],
    );
    assert!(
        stdout.contains("laser: /scan -> /laser/RangeFinder: 30 scans of 181 beams"),
        "{stdout}"
    );
    assert!(
        stdout.contains("odometry: /odom -> /base/Egomotion: 30 readings"),
        "{stdout}"
    );
    assert!(
        stdout.contains("camera: /camera/image_raw -> /camera/ImageSource"),
        "{stdout}"
    );
    assert!(
        stdout.contains("the recording keeps the log times"),
        "{stdout}"
    );
    let out = messages(&dir.path().join("out.mcap"));

    let scans = &out["/laser/RangeFinder"];
    assert_eq!(scans.len(), 30);
    for (i, (_, data)) in scans.iter().enumerate() {
        let scan: RangeFinder = cdr::from_bytes(data).unwrap();
        assert_eq!(scan.range_count, 181);
        assert_eq!(scan.max_range, 30.0);
        assert_eq!(scan.ranges, ranges(i), "scan {i}");
        assert_eq!(scan.theta_offset, f64::from(-std::f32::consts::FRAC_PI_2));
        assert_eq!(
            scan.theta_separation,
            f64::from((std::f64::consts::PI / 180.0) as f32)
        );
    }
    let odometry = &out["/base/Egomotion"];
    assert_eq!(odometry.len(), 30);
    for (i, (_, data)) in odometry.iter().enumerate() {
        let e: Egomotion = cdr::from_bytes(data).unwrap();
        let (x, y, yaw) = pose(i);
        assert_eq!((e.pose.x, e.pose.y), (x, y), "pose {i}");
        assert!(
            (e.pose.theta - yaw).abs() < 1e-12,
            "heading {i}: {}",
            e.pose.theta
        );
        assert_eq!((e.translation_velocity, e.rotation_velocity), (1.0, 0.5));
    }
    let images = &out["/camera/ImageSource"];
    assert_eq!(images.len(), 6);
    for (k, (_, data)) in images.iter().enumerate() {
        let image: ImageSource = cdr::from_bytes(data).unwrap();
        assert_eq!((image.width, image.height, image.step), (6, 4, 18));
        assert_eq!(image.encoding, "rgb8");
        assert_eq!(image.data, pixels(k * 5), "image {k}");
    }
    // The bag's own messages are kept, byte for byte, at their log times.
    let original = messages(&bag);
    for topic in ["/scan", "/odom", "/tf", "/camera/image_raw"] {
        assert_eq!(out[topic], original[topic], "{topic}");
    }
    // And so is the QoS their publishers offered; Lewis's own channels offer Lewis's.
    let bag_qos = offered_qos(&bag);
    let out_qos = offered_qos(&dir.path().join("out.mcap"));
    assert!(bag_qos["/scan"].contains("reliability: 2"), "{bag_qos:?}");
    assert_eq!(out_qos["/scan"], bag_qos["/scan"]);
    assert!(out_qos["/laser/RangeFinder"].contains("reliability: 1\n  durability: 2"));
    assert_eq!(
        out_qos.len(),
        out_qos.values().filter(|q| !q.is_empty()).count()
    );
    // The import's times are the bag's log times.
    let log_times: Vec<u64> = original["/scan"].iter().map(|(t, _)| *t).collect();
    let laser_times: Vec<u64> = scans.iter().map(|(t, _)| *t).collect();
    assert_eq!(laser_times, log_times);
    // Nothing else is left beside the output.
    let mut files: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files, ["good.mcap", "out.mcap"]);
    // An existing output is not overwritten.
    let again = lewis(
        dir.path(),
        &["import", "ros2", "good.mcap", "-o", "out.mcap"],
    );
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("out.mcap exists"));
}

#[test]
fn replaying_an_imported_bag_is_deterministic_and_a_laser_fault_moves_the_avoider_to_the_fallback()
{
    let dir = tempfile::tempdir().unwrap();
    write_bag(dir.path(), "good.mcap", "good");
    let colors = repo_root().join("robots/colors/conference.txt");
    let stdout = lewis_ok(
        dir.path(),
        &[
            "import",
            "ros2",
            "good.mcap",
            "-o",
            "in.mcap",
            "--colors",
            colors.to_str().unwrap(),
        ],
    );
    assert!(
        stdout.contains("re-simulated by `lewis replay`: blobfinder, distance, obstacle_avoider"),
        "{stdout}"
    );
    assert_eq!(
        messages(&dir.path().join("in.mcap"))["/blobfinder/Blobs"].len(),
        6
    );
    let first = replay(dir.path(), "in.mcap", "a.mcap", &["--check"]);
    let second = replay(dir.path(), "in.mcap", "b.mcap", &["--check"]);
    assert_eq!(first["check"]["passed"], true, "{:#}", first["divergence"]);
    let resimulated: Vec<&str> = first["resimulated"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap())
        .collect();
    assert_eq!(
        resimulated,
        ["blobfinder", "distance", "obstacle_avoider", "vector_mover"]
    );
    assert_eq!(feed(&first, "blobfinder", "ImageSource", "camera"), Some(6));
    assert_eq!(
        feed(&first, "obstacle_avoider", "RangeFinder", "laser"),
        Some(30)
    );
    assert_eq!(second["check"]["passed"], true);
    assert_eq!(
        std::fs::read(dir.path().join("a.mcap")).unwrap(),
        std::fs::read(dir.path().join("b.mcap")).unwrap(),
        "two replays of one import differ"
    );

    let faulted = replay(
        dir.path(),
        "in.mcap",
        "fault.mcap",
        &["--inject-fault", "laser"],
    );
    let takeovers = faulted["faults"][0]["takeovers"].as_array().unwrap();
    let avoider = takeovers
        .iter()
        .find(|t| t["client"] == "obstacle_avoider" && t["interface"] == "RangeFinder")
        .unwrap_or_else(|| panic!("no takeover for the avoider: {takeovers:?}"));
    assert_eq!(avoider["provider"], "sonar");
    assert!(feed(&faulted, "obstacle_avoider", "RangeFinder", "sonar").unwrap() > 0);
}

#[test]
fn png_images_of_an_independent_encoder_arrive_as_their_pixels() {
    let dir = tempfile::tempdir().unwrap();
    write_bag(dir.path(), "png.mcap", "compressed");
    let stdout = lewis_ok(
        dir.path(),
        &["import", "ros2", "png.mcap", "-o", "out.mcap"],
    );
    assert!(
        stdout.contains(
            "camera: /camera/image_raw/compressed -> /camera/ImageSource (rgb8): 6 images of 6x4 (6 rgb8; png compressed rgb8)"
        ),
        "{stdout}"
    );
    let images = &messages(&dir.path().join("out.mcap"))["/camera/ImageSource"];
    assert_eq!(images.len(), 6);
    for (k, (_, data)) in images.iter().enumerate() {
        let image: ImageSource = cdr::from_bytes(data).unwrap();
        assert_eq!((image.width, image.height), (6, 4));
        assert_eq!(image.data, pixels(k * 5), "image {k}");
    }
}

#[test]
fn header_stamps_that_disagree_with_the_log_times_are_said_and_the_log_times_kept() {
    let dir = tempfile::tempdir().unwrap();
    let bag = write_bag(dir.path(), "stamps.mcap", "stamps-off");
    let stdout = lewis_ok(
        dir.path(),
        &["import", "ros2", "stamps.mcap", "-o", "out.mcap"],
    );
    assert!(
        stdout
            .contains("timestamps: /scan: 30 header stamps, log time minus stamp 5.000 to 5.000 s"),
        "{stdout}"
    );
    assert!(
        stdout.contains(
            "warning: /scan: of 30 header stamps, 1 are zero, 29 differ from their log time by more than 1 s and 0 go backwards; the recording keeps the log times"
        ),
        "{stdout}"
    );
    let log_times: Vec<u64> = messages(&bag)["/scan"].iter().map(|(t, _)| *t).collect();
    let laser_times: Vec<u64> = messages(&dir.path().join("out.mcap"))["/laser/RangeFinder"]
        .iter()
        .map(|(t, _)| *t)
        .collect();
    assert_eq!(laser_times, log_times);
}

#[test]
fn a_second_laser_of_the_bag_is_the_fallback_once_mapped() {
    let dir = tempfile::tempdir().unwrap();
    write_bag(dir.path(), "two.mcap", "two-lasers");
    let refused = lewis(
        dir.path(),
        &["import", "ros2", "two.mcap", "-o", "out.mcap"],
    );
    assert_eq!(refused.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(stderr.contains("two.mcap"), "{stderr}");
    assert!(
        stderr.contains("2 LaserScan topics could be the RangeFinder; say which with --map"),
        "{stderr}"
    );
    assert!(
        stderr.contains("/scan_rear (sensor_msgs/msg/LaserScan): 30 messages at 10.0 Hz"),
        "{stderr}"
    );
    assert!(stderr.contains("--map /scan=RangeFinder"), "{stderr}");
    assert!(!dir.path().join("out.mcap").exists());

    let stdout = lewis_ok(
        dir.path(),
        &[
            "import",
            "ros2",
            "two.mcap",
            "-o",
            "out.mcap",
            "--map",
            "/scan=RangeFinder",
            "--map",
            "/scan_rear=RangeFinder",
        ],
    );
    assert!(
        stdout.contains("second range sensor: /scan_rear"),
        "{stdout}"
    );
    let faulted = replay(
        dir.path(),
        "out.mcap",
        "fault.mcap",
        &["--inject-fault", "laser"],
    );
    let takeovers = faulted["faults"][0]["takeovers"].as_array().unwrap();
    assert!(
        takeovers
            .iter()
            .any(|t| t["client"] == "obstacle_avoider" && t["provider"] == "laser2"),
        "{takeovers:?}"
    );
}

#[test]
fn bad_bags_are_refused_naming_the_file_topic_and_message_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "no-laser-no-odom",
            vec![
                "no laser (sensor_msgs/LaserScan) and no odometry",
                "/camera/image_raw (sensor_msgs/msg/Image",
            ],
        ),
        (
            "bad-encoding",
            vec![
                "/camera/image_raw message 2 (log time 1700000001.000003 s)",
                "image encoding `bayer_rggb16` is not converted",
            ],
        ),
        (
            "beams-change",
            vec![
                "/scan message 3 (log time 1700000000.300000 s)",
                "the scan has 171 ranges, the scans before it 181",
            ],
        ),
        (
            "time-backwards",
            vec![
                "/scan message 4 (log time 1700000000.250000 s)",
                "time goes backwards",
            ],
        ),
    ];
    for (variant, expected) in cases {
        let name = format!("{variant}.mcap");
        write_bag(dir.path(), &name, variant);
        let out = format!("{variant}-out.mcap");
        let refused = lewis(dir.path(), &["import", "ros2", &name, "-o", &out]);
        assert_eq!(refused.status.code(), Some(2), "{variant}");
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(stderr.contains(&name), "{variant}: {stderr}");
        for text in expected {
            assert!(stderr.contains(text), "{variant}: `{text}` not in {stderr}");
        }
        assert!(!dir.path().join(&out).exists(), "{variant}");
        assert!(
            !dir.path().join(format!(".{out}.importing.mcap")).exists(),
            "{variant}"
        );
    }
}

#[test]
fn the_real_bags_import_with_what_can_be_replayed_or_are_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let hokuyo = shared_data("ros2/hokuyo-scan-matcher-demo.mcap");
    let stdout = lewis_ok(
        dir.path(),
        &[
            "import",
            "ros2",
            hokuyo.to_str().unwrap(),
            "-o",
            "hokuyo.mcap",
        ],
    );
    assert!(stdout.contains("360 scans of 681 beams"), "{stdout}");
    assert!(stdout.contains("no odometry"), "{stdout}");
    assert!(
        stdout.contains("re-simulated by `lewis replay`: distance\n"),
        "{stdout}"
    );
    let report = replay(
        dir.path(),
        "hokuyo.mcap",
        "hokuyo-replay.mcap",
        &["--check"],
    );
    assert_eq!(
        report["check"]["passed"], true,
        "{:#}",
        report["divergence"]
    );
    assert_eq!(feed(&report, "distance", "RangeFinder", "laser"), Some(360));

    let husky = shared_data("ros2/husky-outdoor-imu-odom-gps.mcap");
    let stdout = lewis_ok(
        dir.path(),
        &[
            "import",
            "ros2",
            husky.to_str().unwrap(),
            "-o",
            "husky.mcap",
        ],
    );
    assert!(
        stdout.contains(
            "odometry: /husky_velocity_controller/odom -> /base/Egomotion: 3952 readings"
        ),
        "{stdout}"
    );
    assert!(stdout.contains("no laser"), "{stdout}");
    let kept = messages(&dir.path().join("husky.mcap"));
    assert_eq!(kept["/imu/data"].len(), 11865);
    assert_eq!(kept["/fix"].len(), 989);

    for bag in [
        "cdr_test_0.mcap",
        "rewriter_b_0.mcap",
        "talker.mcap",
        "test_bag_for_seek_0.mcap",
        "topics_and_services.mcap",
    ] {
        let path = shared_data(&format!("mcap/{bag}"));
        let out = format!("{bag}-out.mcap");
        let refused = lewis(
            dir.path(),
            &["import", "ros2", path.to_str().unwrap(), "-o", &out],
        );
        assert_eq!(refused.status.code(), Some(2), "{bag}");
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(stderr.contains(bag), "{bag}: {stderr}");
        assert!(stderr.contains("no laser"), "{bag}: {stderr}");
        assert!(!dir.path().join(&out).exists());
    }
}
