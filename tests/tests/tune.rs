//! `lewis tune` end to end, on recordings made here with the recorder: photos of
//! ../shared/data/images and a frame rendered by the simulator's camera, as ImageSource
//! messages of a `camera` service. The output MCAP is read back by the Python readers
//! (`mcap`, `mcap-ros2-support`), independent of Lewis.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

use lewis_geometry::Pose2;
use lewis_images::sequence::load_rgb;
use lewis_images::{ImageIntrinsics, image_message};
use lewis_interfaces::msg::ImageSource;
use lewis_interfaces::{Interface, interface_info};
use lewis_recorder::{ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};
use lewis_sim::{CameraConfig, SimCamera, World};
use lewis_tests::{lewis_exe, python_tool, repo_root, run_ok, shared_data};

/// The robot the recordings say they come from: a camera reading a folder.
const ROBOT: &str = r#"
[robot]
name = "camera-only"
description = "A camera, for lewis tune"

[broker]
heartbeat_period_ms = 50
heartbeat_deadline_ms = 1000
startup_deadline_ms = 5000
fail_back = false
restart = { max_restarts = 1, window_ms = 10000, backoff_initial_ms = 100, backoff_max_ms = 1000 }

[[services]]
name = "camera"
kind = "camera"
start = "always"
provides = [{ interface = "ImageSource", quality = 10, cost = 1, data_rate_hz = 1.0 }]
[services.parameters]
images = "frames"
"#;

const TOPIC: &str = "/camera/ImageSource";

/// A photo of the shared data as an ImageSource frame.
fn photo(name: &str) -> ImageSource {
    let photo = load_rgb(&shared_data(&format!("images/{name}"))).expect("the photo decodes");
    image_message(
        photo.width_px,
        photo.height_px,
        photo.rgb,
        ImageIntrinsics::from_fov(photo.width_px, photo.height_px, 1.0),
    )
}

/// A uniform grey frame, with no colour of any class.
fn grey(width: u32, height: u32) -> ImageSource {
    image_message(
        width,
        height,
        vec![128; (width * height * 3) as usize],
        ImageIntrinsics::from_fov(width, height, 1.0),
    )
}

/// What the simulator's camera sees from the corridor, looking at the corner's sign (its
/// arrow points left).
fn corner_sign() -> ImageSource {
    let world = World::load(&repo_root().join("robots/worlds/conference"))
        .expect("the conference world loads");
    let mut camera = SimCamera::new(CameraConfig::default(), 3).expect("the default camera");
    camera.render(&world, Pose2::new(25.0, 12.75, 0.0))
}

/// Records `frames` on `/camera/ImageSource`, one a second from 1 s, into `dir/run.mcap`.
fn record(dir: &Path, frames: Vec<ImageSource>) -> PathBuf {
    let path = dir.join("run.mcap");
    let mut options = RecorderOptions::new(&path);
    options.sync_on_flush = false;
    options.robot_description = Some(RobotDescription {
        file_name: "camera-only.toml".to_owned(),
        toml: ROBOT.to_owned(),
    });
    let mut recorder = Recorder::create(options).expect("the recording can be created");
    let info = interface_info(ImageSource::NAME).expect("ImageSource is compiled in");
    let channel = recorder
        .add_channel(ChannelSpec::publication(info, "camera", TOPIC))
        .expect("the channel is added");
    for (seq, mut frame) in (1u64..).zip(frames) {
        let time_ns = i64::try_from(seq).unwrap() * 1_000_000_000;
        frame.header.provider = "camera".to_owned();
        frame.header.seq = seq;
        frame.header.publish_time_ns = time_ns;
        let data = lewis_interfaces::cdr::to_vec(&frame);
        recorder
            .write(&Sample {
                channel,
                seq,
                publish_time_ns: time_ns,
                log_time_ns: time_ns,
                data: &data,
            })
            .expect("the frame is written");
    }
    recorder.close().expect("the recording closes");
    path
}

fn lewis(args: &[&str], dir: &Path) -> Command {
    let mut command = Command::new(lewis_exe());
    command.args(args).current_dir(dir);
    command
}

/// What the Python readers decode of an MCAP file: per topic, one line per message with
/// the fields this test looks at.
fn decoded(path: &Path) -> String {
    let script = r#"
import sys
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
with open(sys.argv[1], "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()])
    for schema, channel, message, ros in reader.iter_decoded_messages():
        name = schema.name.rsplit("/", 1)[-1]
        inputs = ",".join(f"{i.channel}#{i.seq}" for i in ros.header.inputs)
        if name == "ImageSource":
            detail = f"{ros.width}x{ros.height} {ros.encoding}"
        elif name == "Blobs":
            colours = {}
            for b in ros.blobs:
                colours[b.colour_name] = colours.get(b.colour_name, 0) + 1
            detail = " ".join(f"{k}={v}" for k, v in sorted(colours.items()))
        elif name == "Signs":
            detail = " ".join(s.arrow for s in ros.signs)
        else:
            continue
        print(f"{channel.topic} {message.log_time} {ros.header.provider} [{inputs}] {detail}")
"#;
    run_ok(python_tool("python").arg("-c").arg(script).arg(path))
}

#[test]
fn tune_blobfinder_prints_the_statistics_and_writes_the_blobs_beside_the_images() {
    let dir = tempfile::tempdir().unwrap();
    let run = record(
        dir.path(),
        vec![photo("smarties.png"), grey(64, 48), photo("smarties.png")],
    );
    let colors = repo_root().join("robots/colors/smarties.txt");
    let out = dir.path().join("tuned.mcap");
    let pngs = dir.path().join("boxes");
    let said = run_ok(
        lewis(&["tune", "blobfinder"], dir.path())
            .arg(&run)
            .arg("--colors")
            .arg(&colors)
            .arg("-o")
            .arg(&out)
            .arg("--png")
            .arg(&pngs),
    );
    // smarties.png has 4 red, 2 orange, 3 green and 3 blue candies; the grey frame none.
    assert!(said.contains("3 frames of"), "{said}");
    for line in [
        "Red: 2.67 blobs/frame, 1 of 3 frames without",
        "Orange: 1.33 blobs/frame, 1 of 3 frames without",
        "Green: 2.00 blobs/frame, 1 of 3 frames without",
        "Blue: 2.00 blobs/frame, 1 of 3 frames without",
    ] {
        assert!(said.contains(line), "no `{line}` in:\n{said}");
    }
    assert!(said.contains("wrote "), "{said}");
    assert!(pngs.join("camera_ImageSource-000001.png").exists());
    assert!(pngs.join("summary.txt").exists());

    // The images, unchanged, and the tuned blobs at the same times, naming their image.
    let lines = decoded(&out);
    let expected = [
        "/camera/ImageSource 1000000000 camera [] 413x356 rgb8",
        "/tune/blobfinder/Blobs 1000000000 tune [/camera/ImageSource#1] Blue=3 Green=3 Orange=2 Red=4",
        "/camera/ImageSource 2000000000 camera [] 64x48 rgb8",
        "/tune/blobfinder/Blobs 2000000000 tune [/camera/ImageSource#2] ",
        "/camera/ImageSource 3000000000 camera [] 413x356 rgb8",
        "/tune/blobfinder/Blobs 3000000000 tune [/camera/ImageSource#3] Blue=3 Green=3 Orange=2 Red=4",
    ];
    let got: Vec<&str> = lines.lines().collect();
    assert_eq!(got, expected, "{lines}");
}

#[test]
fn tune_blobfinder_with_signs_reads_the_arrow_of_a_simulated_sign() {
    let dir = tempfile::tempdir().unwrap();
    let run = record(dir.path(), vec![corner_sign()]);
    let out = dir.path().join("tuned.mcap");
    let said = run_ok(
        lewis(&["tune", "blobfinder"], dir.path())
            .arg(&run)
            .arg("--colors")
            .arg(repo_root().join("robots/colors/conference.txt"))
            .args(["--signs", "--channel", TOPIC, "-o"])
            .arg(&out),
    );
    assert!(said.contains("1 frames of"), "{said}");
    assert!(said.contains("signs: 1.00 per frame, 1 in all"), "{said}");
    let lines = decoded(&out);
    assert!(
        lines.contains("/tune/sign_detector/Signs 1000000000 tune [/camera/ImageSource#1] left"),
        "{lines}"
    );
}

#[test]
fn tune_blobfinder_refuses_what_it_cannot_use_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let run = record(dir.path(), vec![grey(8, 8)]);
    let colors = repo_root().join("robots/colors/smarties.txt");
    let failed = |args: &[&str]| {
        let output = lewis(&["tune", "blobfinder"], dir.path())
            .arg(&run)
            .args(args)
            .output()
            .unwrap();
        assert!(!output.status.success(), "{args:?} succeeded");
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    let colors_arg = colors.to_str().unwrap();
    let said = failed(&["--colors", colors_arg, "--channel", "/nope"]);
    assert!(
        said.contains("has no ImageSource topic /nope: its image topics are /camera/ImageSource"),
        "{said}"
    );
    // smarties.txt has no White and Black classes for the sign detector.
    let said = failed(&["--colors", colors_arg, "--signs"]);
    assert!(
        said.contains("colour class `White` is not in the colour file"),
        "{said}"
    );
}

#[test]
fn tune_pick_prints_the_colour_lines_of_a_rectangle_of_an_image_or_a_recording() {
    let dir = tempfile::tempdir().unwrap();
    let smarties = shared_data("images/smarties.png");
    // A 9x9 square inside the blue candy at (377, 80).
    let from_file = run_ok(lewis(&["tune", "pick"], dir.path()).arg(&smarties).args([
        "--rect",
        "373,76,9,9",
        "--name",
        "Blue",
    ]));
    assert!(
        from_file.starts_with("# 81 pixels of the 9x9 rectangle at 373,76 in "),
        "{from_file}"
    );
    let lines: Vec<&str> = from_file.lines().collect();
    assert_eq!(lines[2], "[Colors]");
    assert!(lines[3].ends_with(" 0.000000 1 Blue"), "{from_file}");
    assert_eq!(lines[4], "[Thresholds]");
    // The line it prints is a colour file that loads, and its class holds the candy.
    let file = dir.path().join("picked.txt");
    std::fs::write(&file, lines[2..].join("\n")).unwrap();
    let config = lewis_perception::ColorConfig::load(&file).unwrap();
    let blue = &config.colors[0];
    assert!(blue.u.lo > 150 && blue.v.hi < 140, "{blue:?}");

    // The same patch from a recording, 1.5 s into it: the second frame, recorded 1 s after
    // the first.
    let run = record(
        dir.path(),
        vec![grey(640, 480), photo("smarties.png"), grey(640, 480)],
    );
    let at = format!("{}@1.5s", run.display());
    let from_run = run_ok(lewis(&["tune", "pick", &at], dir.path()).args([
        "--rect",
        "373,76,9,9",
        "--name",
        "Blue",
    ]));
    assert!(
        from_run.contains("/camera/ImageSource seq 2 at 1.000 s"),
        "{from_run}"
    );
    assert_eq!(
        from_run.lines().skip(1).collect::<Vec<_>>(),
        from_file.lines().skip(1).collect::<Vec<_>>(),
        "the same pixels give the same lines"
    );
    // Outside the image: a clear error.
    let output = lewis(&["tune", "pick", &at], dir.path())
        .args(["--rect", "700,10,5,5"])
        .output()
        .unwrap();
    assert!(!output.status.success());
    let said = String::from_utf8_lossy(&output.stderr);
    assert!(
        said.contains("the 5x5 rectangle at 700,10 is outside the 413x356 image"),
        "{said}"
    );
}
