//! `lewis export ros2`: a Lewis recording (laser, sonar ring, odometry, camera, placed
//! blobs, signs, the broker's bindings) copied with companion channels of ROS 2's standard
//! types, which the independent readers decode and find equal to the Lewis messages they
//! came from: mcap-ros2-support (`tools/python/check_companions.py`) and Foxglove's own
//! `@mcap/core` + `@foxglove/rosmsg2-serialization` (`tools/node/companions.mjs`);
//! the images' pixels unchanged; `pymcap-cli doctor` passes. Bad input is refused with the
//! file and the reason, and nothing is written.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Output};

use lewis_interfaces::dynamic::{Decoder, Value};
use lewis_interfaces::msg::{
    Blob, Blob3D, Blobs3D, Broker, Egomotion, ImageSource, Point3D, Pose2D, Pose3D, RangeFinder,
    Sign, Signs,
};
use lewis_interfaces::{Struct, cdr};
use lewis_recorder::{ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};
use lewis_tests::{doctor, lewis_exe, python_tool, repo_root, run_ok, shared_data};

const ROBOT: &str = r#"name = "export-test"

[[services]]
name = "camera"
kind = "sim-camera"
provides = [{ interface = "ImageSource", quality = 10, cost = 1 }]

[services.parameters]
mount = { x_m = 0.1, y_m = 0.05, heading_deg = 0.0, height_m = 1.2 }
"#;

const WIDTH: usize = 16;
const HEIGHT: usize = 8;

fn lewis(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(lewis_exe())
        .args(args)
        .output()
        .expect("lewis runs")
}

/// The camera's pixels of frame `i`: a pattern that a lossy codec would change.
fn pixels(i: usize) -> Vec<u8> {
    (0..WIDTH * HEIGHT * 3)
        .map(|k| u8::try_from((k * 7 + i * 13) % 256).unwrap())
        .collect()
}

struct Writer {
    recorder: Recorder,
    channels: BTreeMap<String, lewis_recorder::ChannelId>,
    seq: u64,
}

impl Writer {
    fn write<T: Struct>(&mut self, topic: &str, provider: &str, message: &mut T, time_ns: i64) {
        let channel = *self.channels.entry(topic.to_owned()).or_insert_with(|| {
            let mut extra = BTreeMap::new();
            extra.insert("kind".to_owned(), "data".to_owned());
            self.recorder
                .add_channel(ChannelSpec {
                    topic: topic.to_owned(),
                    schema_name: T::SCHEMA_NAME.to_owned(),
                    schema_text: T::SCHEMA_TEXT.to_owned(),
                    provider: provider.to_owned(),
                    interface: T::SCHEMA_NAME.rsplit('/').next().unwrap().to_owned(),
                    interface_version: "1.0".to_owned(),
                    extra_metadata: extra,
                })
                .unwrap()
        });
        self.seq += 1;
        let data = cdr::to_vec(message);
        self.recorder
            .write(&Sample {
                channel,
                seq: self.seq,
                publish_time_ns: time_ns,
                log_time_ns: time_ns,
                data: &data,
            })
            .unwrap();
    }
}

/// A recording of every interface that has a companion, written without companions.
fn write_recording(path: &Path) {
    let mut options = RecorderOptions::new(path);
    options.robot_description = Some(RobotDescription {
        file_name: "export-test.toml".to_owned(),
        toml: ROBOT.to_owned(),
    });
    let mut w = Writer {
        recorder: Recorder::create(options).unwrap(),
        channels: BTreeMap::new(),
        seq: 0,
    };
    let start = 1_700_000_000_000_000_000i64;
    let mut bind = Broker {
        action: "bind".into(),
        client: "obstacle_avoider".into(),
        interface: "RangeFinder".into(),
        service: "laser".into(),
        ..Broker::default()
    };
    w.write("/lewis/broker", "broker", &mut bind, start);
    for i in 0..20usize {
        let t = start + i64::try_from(i).unwrap() * 100_000_000;
        let k = i as f64;
        let mut laser = RangeFinder {
            ranges: (0..181)
                .map(|b| 1.0 + f64::from(b) * 0.01 + k * 0.001)
                .collect(),
            range_count: 181,
            max_range: 8.0,
            uniform: true,
            x_offset: 0.12,
            z_offset: 0.38,
            theta_offset: -std::f64::consts::FRAC_PI_2,
            theta_separation: std::f64::consts::PI / 180.0,
            ..RangeFinder::default()
        };
        w.write("/laser/RangeFinder", "laser", &mut laser, t);
        let mut sonar = RangeFinder {
            ranges: (0..16)
                .map(|s| 0.5 + f64::from(s) * 0.1 + k * 0.01)
                .collect(),
            range_count: 16,
            max_range: 5.0,
            uniform: false,
            sensor_positions: (0..16)
                .map(|s| {
                    let theta = f64::from(s) * std::f64::consts::TAU / 16.0;
                    Pose3D {
                        x: 0.25 * theta.cos(),
                        y: 0.25 * theta.sin(),
                        z: 0.3,
                        theta,
                        ..Pose3D::default()
                    }
                })
                .collect(),
            ..RangeFinder::default()
        };
        w.write("/sonar/RangeFinder", "sonar", &mut sonar, t + 1);
        let mut ego = Egomotion {
            pose: Pose2D {
                x: 0.1 * k,
                y: -0.05 * k,
                theta: 0.3 * k - 2.5,
            },
            translation_velocity: 0.5,
            rotation_velocity: 0.1,
            ..Egomotion::default()
        };
        w.write("/base/Egomotion", "base", &mut ego, t + 2);
        if i % 5 == 0 {
            let mut image = ImageSource {
                width: WIDTH as i32,
                height: HEIGHT as i32,
                encoding: "rgb8".into(),
                step: (WIDTH * 3) as i32,
                data: pixels(i),
                ..ImageSource::default()
            };
            w.write("/camera/ImageSource", "camera", &mut image, t + 3);
            let blob = Blob3D {
                blob: Blob {
                    colour_name: "Red".into(),
                    ..Blob::default()
                },
                range_valid: true,
                position: Point3D {
                    x: 2.0 + k,
                    y: 0.5,
                    z: 0.4,
                },
                width: 0.2,
                height: 0.3,
            };
            let mut blobs = Blobs3D {
                blob_count: 1,
                blobs: vec![blob],
                ..Blobs3D::default()
            };
            w.write("/blobfinder3d/Blobs3D", "blobfinder3d", &mut blobs, t + 4);
            let sign = Sign {
                position: Point3D {
                    x: 3.0,
                    y: -k,
                    z: 1.0,
                },
                arrow: "left".into(),
                confidence: 0.9,
                ..Sign::default()
            };
            let mut signs = Signs {
                sign_count: 1,
                signs: vec![sign],
                ..Signs::default()
            };
            w.write("/sign_detector/Signs", "sign_detector", &mut signs, t + 5);
        }
        if i == 10 {
            let mut rebind = Broker {
                action: "rebind".into(),
                client: "obstacle_avoider".into(),
                interface: "RangeFinder".into(),
                from_service: "laser".into(),
                to_service: "sonar".into(),
                ..Broker::default()
            };
            w.write("/lewis/broker", "broker", &mut rebind, t + 6);
        }
    }
    w.recorder.close().unwrap();
}

/// The CompressedImage messages of `file`, decoded with their stored ros2msg text.
fn compressed_images(file: &Path) -> Vec<Value> {
    let bytes = std::fs::read(file).unwrap();
    let mut out = Vec::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        let Some(schema) = &message.channel.schema else {
            continue;
        };
        if schema.name != "sensor_msgs/msg/CompressedImage" {
            continue;
        }
        let text = String::from_utf8(schema.data.to_vec()).unwrap();
        let decoder = Decoder::new(&schema.name, &text).unwrap();
        out.push(decoder.decode(&message.data).unwrap());
    }
    out
}

#[test]
fn an_exported_recording_draws_in_ros2_tools_with_the_values_it_came_from() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("run.mcap");
    let output = dir.path().join("run.ros2.mcap");
    write_recording(&input);
    let out = lewis(&[
        "export".as_ref(),
        "ros2".as_ref(),
        input.as_os_str(),
        "-o".as_ref(),
        output.as_os_str(),
        "--images".as_ref(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for line in [
        "/laser/scan",
        "/sonar/points",
        "/base/odom",
        "/tf ",
        "/tf_static",
        "/camera/image/compressed",
        "/blobfinder3d/markers",
        "/sign_detector/markers",
        "/lewis/broker/markers",
    ] {
        assert!(stdout.contains(line), "{line} missing from:\n{stdout}");
    }
    doctor(&output);

    // mcap-ros2-support: every companion equals its source.
    let script = repo_root().join("tools/python/check_companions.py");
    let checked = run_ok(python_tool("python").arg(script).arg(&output));
    // Every channel carries MCAP's ros2 profile's QoS (the checker fails on one without).
    assert!(checked.contains("\noffered_qos_profiles on "), "{checked}");
    let counts: BTreeMap<&str, u64> = checked
        .lines()
        .filter(|line| !line.starts_with("decoded ") && !line.starts_with("offered_qos_profiles "))
        .map(|line| {
            let mut words = line.split_whitespace();
            let topic = words.next().unwrap();
            (topic, words.nth(1).unwrap().parse().unwrap())
        })
        .collect();
    let want = BTreeMap::from([
        ("/base/odom", 20),
        ("/blobfinder3d/markers", 4),
        ("/camera/image/compressed", 4),
        ("/laser/scan", 20),
        ("/lewis/broker/markers", 2),
        ("/sign_detector/markers", 4),
        ("/sonar/points", 20),
        ("/tf", 20),
        ("/tf_static", 3),
    ]);
    assert_eq!(counts, want, "{checked}");

    // Foxglove's own reader and CDR decoder.
    let node = Command::new("node")
        .arg(repo_root().join("tools/node/companions.mjs"))
        .arg(&output)
        .output()
        .expect("node runs (npm ci --prefix tools/node)");
    let report = String::from_utf8_lossy(&node.stdout);
    assert!(
        node.status.success(),
        "{report}\n{}",
        String::from_utf8_lossy(&node.stderr)
    );
    let report: serde_json::Value = serde_json::from_str(report.trim()).unwrap();
    assert_eq!(report["checked"]["/laser/scan"], 20, "{report}");
    assert_eq!(report["checked"]["/base/odom"], 20, "{report}");
    assert_eq!(report["decoded"]["/sonar/points"], 20, "{report}");

    // PNG is lossless: the pixels are the camera's.
    let images = compressed_images(&output);
    assert_eq!(images.len(), 4);
    for (n, image) in images.iter().enumerate() {
        assert_eq!(image.get("format").and_then(Value::as_str), Some("png"));
        let png = image.get("data").and_then(Value::as_bytes).unwrap();
        let rgb = image::load_from_memory(png).unwrap().to_rgb8();
        assert_eq!(rgb.dimensions(), (WIDTH as u32, HEIGHT as u32));
        assert_eq!(rgb.into_raw(), pixels(n * 5), "image {n}");
    }

    // Exported again, the companions are made again, not doubled.
    let again = dir.path().join("again.mcap");
    let out = lewis(&[
        "export".as_ref(),
        "ros2".as_ref(),
        output.as_os_str(),
        "-o".as_ref(),
        again.as_os_str(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("4 images left out"), "{stdout}");
    let checked = run_ok(
        python_tool("python")
            .arg(repo_root().join("tools/python/check_companions.py"))
            .arg(&again),
    );
    assert!(
        checked.contains("/laser/scan sensor_msgs/msg/LaserScan 20"),
        "{checked}"
    );
    assert!(!checked.contains("/camera/image/compressed"), "{checked}");
}

#[test]
fn bad_input_is_refused_with_the_file_and_the_reason_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("run.mcap");
    write_recording(&input);
    let refused = |input: &Path, output: &Path, words: &[&str]| {
        let out = lewis(&[
            "export".as_ref(),
            "ros2".as_ref(),
            input.as_os_str(),
            "-o".as_ref(),
            output.as_os_str(),
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        for word in words {
            assert!(stderr.contains(word), "`{word}` not in: {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{stderr}");
    };
    let listing = |dir: &Path| {
        let mut names: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        names
    };

    // The output exists: untouched.
    let existing = dir.path().join("existing.mcap");
    std::fs::write(&existing, b"keep me").unwrap();
    refused(&input, &existing, &["existing.mcap exists"]);
    assert_eq!(std::fs::read(&existing).unwrap(), b"keep me");

    let before = listing(dir.path());
    // Not a Lewis recording: a real robot's ROS 2 bag.
    let bag = shared_data("ros2/hokuyo-scan-matcher-demo.mcap");
    refused(
        &bag,
        &dir.path().join("bag.mcap"),
        &["hokuyo-scan-matcher-demo.mcap", "nothing to export"],
    );
    // A recording cut short.
    let bytes = std::fs::read(&input).unwrap();
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let after_cut = listing(dir.path());
    refused(&cut, &dir.path().join("out.mcap"), &["cut.mcap"]);
    // No such file.
    refused(
        &dir.path().join("missing.mcap"),
        &dir.path().join("out.mcap"),
        &["missing.mcap"],
    );
    assert_eq!(listing(dir.path()), after_cut, "something was left behind");
    assert_eq!(after_cut.len(), before.len() + 1);
}
