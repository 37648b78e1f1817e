//! `lewis tune label-sim`, `lewis tune check` and `lewis tune fit` end to end.
//!
//! The simulator recording is made here, as the simulated robot records one: frames of the
//! simulator's camera on `/camera/ImageSource`, each naming in its provenance the
//! GroundTruth (and WorldState) sample it was rendered from, and a robot description whose
//! `sim-camera` names the conference world. The labels come from the simulator's ground
//! truth; the shipped colour file must pass a check on them, a narrowed one must not.
//! The fit runs on the real photos of ../shared/data/images with the labels drawn by hand
//! in `tests/data/tune/`, and is judged on photos it did not see.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

use lewis_geometry::{Pose2, Vec2};
use lewis_interfaces::msg::{GroundTruth, ImageSource, InputRef, PersonState, Point2D, WorldState};
use lewis_interfaces::{Interface, interface_info};
use lewis_recorder::{ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};
use lewis_sim::world::ObjectKind;
use lewis_sim::{CameraConfig, SimCamera, World};
use lewis_tests::{lewis_exe, repo_root, run_ok, shared_data};

const ROBOT: &str = r#"
[robot]
name = "sim-camera-only"
description = "The simulator's camera, for lewis tune label-sim"

[broker]
heartbeat_period_ms = 50
heartbeat_deadline_ms = 1000
startup_deadline_ms = 5000
fail_back = false
restart = { max_restarts = 1, window_ms = 10000, backoff_initial_ms = 100, backoff_max_ms = 1000 }

[[services]]
name = "camera"
kind = "sim-camera"
start = "always"
provides = [{ interface = "ImageSource", quality = 10, cost = 1, data_rate_hz = 5.0 }]
[services.parameters]
world = "robots/worlds/conference"
rate_hz = 5.0
"#;

fn conference() -> World {
    World::load(&repo_root().join("robots/worlds/conference")).expect("the conference world loads")
}

/// Where the guide in the red cap stands at the start.
fn guide() -> Vec2 {
    let ObjectKind::Person(guide) = conference().object("red-cap").unwrap().kind.clone() else {
        panic!("red-cap is not a person");
    };
    guide.centre
}

/// What one frame is rendered from: the robot's pose, and whether the guide has left.
struct Shot {
    pose: Pose2,
    guide_gone: bool,
}

/// The shots: the corridor's corner sign from 7 m to 3 m, the guide from 6 m to 3 m, then
/// the same place once the guide has walked away, and the bare wall of the lobby.
fn shots() -> Vec<Shot> {
    let g = guide();
    let mut shots: Vec<Shot> = [20.0, 22.0, 24.0, 26.0, 27.0]
        .into_iter()
        .map(|x| Shot {
            pose: Pose2::new(x, 12.75, 0.0),
            guide_gone: false,
        })
        .collect();
    for d in [6.0, 4.5, 3.0] {
        shots.push(Shot {
            pose: Pose2::new(g.x - d, g.y + d / 2.0, (-0.5f64).atan()),
            guide_gone: false,
        });
    }
    shots.push(Shot {
        pose: Pose2::new(g.x - 4.5, g.y + 2.25, (-0.5f64).atan()),
        guide_gone: true,
    });
    shots
}

/// Records the shots as the simulator would: GroundTruth at each frame's pose, WorldState
/// with the guide present or gone, and the camera's frame naming both.
pub(crate) fn record_sim(dir: &Path) -> PathBuf {
    let path = dir.join("sim.mcap");
    let mut options = RecorderOptions::new(&path);
    options.sync_on_flush = false;
    options.robot_description = Some(RobotDescription {
        file_name: "sim-camera-only.toml".to_owned(),
        toml: ROBOT.to_owned(),
    });
    let mut recorder = Recorder::create(options).unwrap();
    let mut channel = |interface: &str, provider: &str, topic: &str| {
        let info = interface_info(interface).unwrap();
        recorder
            .add_channel(ChannelSpec::publication(info, provider, topic))
            .unwrap()
    };
    let truth_channel = channel(GroundTruth::NAME, "base", "/base/GroundTruth");
    let state_channel = channel(WorldState::NAME, "base", "/base/WorldState");
    let image_channel = channel(ImageSource::NAME, "camera", "/camera/ImageSource");
    let mut world = conference();
    let guide_index = world.object_index("red-cap").unwrap();
    let mut camera = SimCamera::new(CameraConfig::default(), 7).unwrap();
    for (seq, shot) in (1u64..).zip(shots()) {
        let time_ns = i64::try_from(seq).unwrap() * 200_000_000;
        let g = guide();
        world.place_person(guide_index, (!shot.guide_gone).then_some(g));
        let mut truth = GroundTruth::default();
        truth.pose.x = shot.pose.x_m;
        truth.pose.y = shot.pose.y_m;
        truth.pose.theta = shot.pose.heading_rad;
        truth.header.provider = "base".into();
        truth.header.seq = seq;
        let mut state = WorldState::default();
        state.people.push(PersonState {
            name: "red-cap".into(),
            position: Point2D { x: g.x, y: g.y },
            present: !shot.guide_gone,
            ..PersonState::default()
        });
        state.header.provider = "base".into();
        state.header.seq = seq;
        let mut frame = camera.render(&world, shot.pose);
        frame.header.provider = "camera".into();
        frame.header.seq = seq;
        frame.header.inputs = vec![
            InputRef {
                channel: "/base/GroundTruth".into(),
                seq,
            },
            InputRef {
                channel: "/base/WorldState".into(),
                seq,
            },
        ];
        for (channel, bytes, offset) in [
            (truth_channel, lewis_interfaces::cdr::to_vec(&truth), 0),
            (state_channel, lewis_interfaces::cdr::to_vec(&state), 1),
            (image_channel, lewis_interfaces::cdr::to_vec(&frame), 2),
        ] {
            recorder
                .write(&Sample {
                    channel,
                    seq,
                    publish_time_ns: time_ns + offset,
                    log_time_ns: time_ns + offset,
                    data: &bytes,
                })
                .unwrap();
        }
    }
    recorder.close().unwrap();
    path
}

fn lewis(args: &[&str]) -> Command {
    let mut command = Command::new(lewis_exe());
    // label-sim finds the world as the robot did, from the repository's root.
    command.args(args).current_dir(repo_root());
    command
}

/// Runs a command that must fail; its standard error.
fn fails(command: &mut Command) -> String {
    let output = command.output().unwrap();
    assert!(!output.status.success(), "{command:?} succeeded");
    String::from_utf8_lossy(&output.stderr).into_owned()
}

fn labels_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn labels_from_the_simulators_truth_pass_the_shipped_colours_and_fail_narrowed_ones() {
    let dir = tempfile::tempdir().unwrap();
    let run = record_sim(dir.path());
    let labels = dir.path().join("sim.labels.json");
    let said = run_ok(
        lewis(&["tune", "label-sim"])
            .arg(&run)
            .arg("-o")
            .arg(&labels),
    );
    assert!(said.starts_with("9 frames of "), "{said}");

    // The cap is labelled where the guide stands, and not once they have left; the corner
    // sign's board and arrow on each of its frames.
    let json = labels_json(&labels);
    let classes_of = |frame: usize| -> Vec<String> {
        json["frames"][frame]["objects"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|o| o.get("optional").is_none())
            .map(|o| o["class"].as_str().unwrap().to_owned())
            .collect()
    };
    assert_eq!(json["frames"][0]["frame"], "camera_ImageSource-000001");
    for frame in 0..5 {
        let classes = classes_of(frame);
        assert!(
            classes.contains(&"White".to_owned()) && classes.contains(&"Black".to_owned()),
            "frame {frame}: {classes:?}"
        );
    }
    for frame in 5..8 {
        assert!(
            classes_of(frame).contains(&"Red".to_owned()),
            "frame {frame}: {:?}",
            classes_of(frame)
        );
    }
    assert!(
        !classes_of(8).contains(&"Red".to_owned()),
        "{:?}",
        classes_of(8)
    );

    // The shipped colour file scores 0.9 or better on the cap and the signs.
    let colors = repo_root().join("robots/colors/conference.txt");
    let check = |colors: &Path| {
        let mut command = lewis(&["tune", "check"]);
        command
            .arg(&run)
            .arg("--colors")
            .arg(colors)
            .arg("--labels")
            .arg(&labels)
            .args(["--min-precision", "0.9", "--min-recall", "0.9"]);
        command
    };
    let said = run_ok(&mut check(&colors));
    assert!(said.starts_with("9 labelled frames of "), "{said}");
    for line in [
        "Red: precision 1.000 recall 1.000 (3 found, 0 false, 0 missed)",
        "White: precision 1.000 recall 1.000",
        "Black: precision 1.000 recall 1.000",
        "not labelled, not scored: Yellow, Blue, Pink",
    ] {
        assert!(said.contains(line), "no `{line}` in:\n{said}");
    }

    // A red whose V range is narrowed to its lowest levels finds the cap no more.
    let narrowed = dir.path().join("narrowed.txt");
    let text = std::fs::read_to_string(&colors).unwrap();
    let red = "( 40:105, 94:120,166:225)";
    assert!(
        text.contains(red),
        "the shipped red has changed: update this test"
    );
    std::fs::write(&narrowed, text.replace(red, "( 40:105, 94:120,166:170)")).unwrap();
    let output = check(&narrowed).output().unwrap();
    assert_eq!(output.status.code(), Some(1), "{output:?}");
    let out = String::from_utf8_lossy(&output.stdout);
    assert!(
        out.contains("Red: precision - recall 0.000 (0 found, 0 false, 3 missed)"),
        "{out}"
    );
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(
        err.contains("check failed: Red recall 0.000 is below 0.9"),
        "{err}"
    );
}

#[test]
fn tune_check_and_label_sim_refuse_bad_input_and_say_why() {
    let dir = tempfile::tempdir().unwrap();
    let run = record_sim(dir.path());
    let colors = repo_root().join("robots/colors/conference.txt");
    let labels = dir.path().join("l.json");
    let check = |labels: &Path, colors: &Path| {
        let mut command = lewis(&["tune", "check"]);
        command
            .arg(&run)
            .arg("--colors")
            .arg(colors)
            .arg("--labels")
            .arg(labels);
        command
    };

    std::fs::write(
        &labels,
        "{\"version\": 1,\n \"frames\": [\n {\"frame\": 3}]}",
    )
    .unwrap();
    let said = fails(&mut check(&labels, &colors));
    assert!(
        said.contains(&format!(
            "{}:3:12: invalid type: integer `3`, expected a string",
            labels.display()
        )),
        "{said}"
    );

    std::fs::write(
        &labels,
        "{\"version\": 1,\n \"frames\": [{\"frame\": \"camera_ImageSource-000001\", \"objects\": [\n {\"class\": \"Cap\", \"box\": [1, 2, 3, 4]}]}]}",
    )
    .unwrap();
    let said = fails(&mut check(&labels, &colors));
    assert!(
        said.contains(&format!(
            "{}:3:12: class `Cap` (frame camera_ImageSource-000001) is not a class of the colour file: its classes are Red, Yellow, Blue, Pink, White, Black",
            labels.display()
        )),
        "{said}"
    );

    std::fs::write(
        &labels,
        "{\"version\": 1, \"frames\": [{\"frame\": \"camera_ImageSource-000042\", \"objects\": []}]}",
    )
    .unwrap();
    let said = fails(&mut check(&labels, &colors));
    assert!(
        said.contains("frame camera_ImageSource-000042 is not a frame of")
            && said.contains("(its frames are named like camera_ImageSource-000001)"),
        "{said}"
    );

    // 33 classes: one more than CMVision classifies.
    let many = dir.path().join("many.txt");
    let mut text = "[Colors]\n".to_owned();
    text.push_str(&"(1,2,3) 0 1 A\n".repeat(33));
    text.push_str("[Thresholds]\n");
    text.push_str(&"(0:1,0:1,0:1)\n".repeat(33));
    std::fs::write(&many, text).unwrap();
    std::fs::write(&labels, "{\"version\": 1, \"frames\": []}").unwrap();
    let said = fails(&mut check(&labels, &many));
    assert!(
        said.contains(&format!(
            "{}:34:1: more than 32 colours: CMVision classifies at most 32 at once",
            many.display()
        )),
        "{said}"
    );

    // A recording without images.
    let empty = dir.path().join("no-images.mcap");
    let mut options = RecorderOptions::new(&empty);
    options.sync_on_flush = false;
    options.robot_description = Some(RobotDescription {
        file_name: "sim-camera-only.toml".to_owned(),
        toml: ROBOT.to_owned(),
    });
    let mut recorder = Recorder::create(options).unwrap();
    let channel = recorder
        .add_channel(ChannelSpec::publication(
            interface_info(GroundTruth::NAME).unwrap(),
            "base",
            "/base/GroundTruth",
        ))
        .unwrap();
    let bytes = lewis_interfaces::cdr::to_vec(&GroundTruth::default());
    recorder
        .write(&Sample {
            channel,
            seq: 1,
            publish_time_ns: 1,
            log_time_ns: 1,
            data: &bytes,
        })
        .unwrap();
    recorder.close().unwrap();
    let said = fails(
        lewis(&["tune", "check"])
            .arg(&empty)
            .arg("--colors")
            .arg(&colors)
            .arg("--labels")
            .arg(&labels),
    );
    assert!(
        said.contains(&format!("{} has no ImageSource topic", empty.display())),
        "{said}"
    );
    let said = fails(
        lewis(&["tune", "label-sim"])
            .arg(&empty)
            .arg("-o")
            .arg(dir.path().join("x.json")),
    );
    assert!(
        said.contains(&format!("{} has no ImageSource topic", empty.display())),
        "{said}"
    );
}

#[test]
fn tune_fit_on_real_photos_improves_the_score_on_photos_it_did_not_see() {
    let dir = tempfile::tempdir().unwrap();
    let data = repo_root().join("tests/data/tune");
    let out = dir.path().join("fitted.txt");
    let said = run_ok(
        lewis(&["tune", "fit"])
            .arg(shared_data("images"))
            .arg("--colors")
            .arg(shared_data("cmvision/player_cmvision_colors2.txt"))
            .arg("--labels")
            .arg(data.join("photos-fit.labels.json"))
            .arg("--held-out")
            .arg(data.join("photos-held-out.labels.json"))
            .arg("-o")
            .arg(&out),
    );
    let gain = |what: &str| -> f64 {
        let line = said
            .lines()
            .find(|l| l.contains(what) && l.contains("mean F1"))
            .unwrap_or_else(|| panic!("no `{what}` line in:\n{said}"));
        let (_, after) = line.rsplit_once('(').unwrap();
        after.trim_end_matches(')').parse().unwrap()
    };
    assert!(gain("fitted frames") > 0.0, "{said}");
    assert!(gain("held-out frames") > 0.0, "{said}");
    let fitted = std::fs::read_to_string(&out).unwrap();
    assert!(
        fitted.starts_with("# Fitted by `lewis tune fit` from "),
        "{fitted}"
    );
    lewis_perception::ColorConfig::load(&out).unwrap();
}
