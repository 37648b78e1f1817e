//! `emulated-camera`: the simulator's camera rendering from the true pose that the base's
//! emulator writes (`--robot-state`), for a B21r whose devices are emulated.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use lewis_emulators::PoseFile;
use lewis_geometry::Pose2;
use lewis_interfaces::msg::{GroundTruth, ImageSource, Pose2D};
use lewis_service::{Level, ServiceRegistry};
use lewis_testkit::{Harness, repository_path, robot};

const MS: i64 = 1_000_000;

/// The camera service `kind` of a one-service robot, with `extra` parameters.
fn camera(kind: &str, extra: &str) -> Harness {
    let text = format!(
        r#"
[robot]
name = "emulated"

[[services]]
name = "camera"
kind = "{kind}"
provides = [{{ interface = "ImageSource", quality = 10, cost = 5 }}]

[services.parameters]
world = "{}"
seed = 4
rate_hz = 10.0
{extra}
"#,
        repository_path("robots/worlds/conference").display()
    );
    let mut registry = ServiceRegistry::new();
    lewis_emulators::camera::register(&mut registry);
    lewis_sim::service::register(&mut registry);
    Harness::build(&robot(&text), "camera", &registry).unwrap()
}

fn emulated_camera(state: &Path) -> Harness {
    camera(
        lewis_emulators::camera::KIND,
        &format!("robot_state = \"{}\"", state.display()),
    )
}

fn warnings(camera: &Harness) -> Vec<&str> {
    camera
        .backend
        .logs
        .iter()
        .filter(|(level, _)| *level == Level::Warn)
        .map(|(_, text)| text.as_str())
        .collect()
}

#[test]
fn without_a_pose_file_the_camera_renders_nothing_and_says_what_to_start_once() {
    let dir = tempfile::tempdir().unwrap();
    let mut camera = emulated_camera(dir.path());
    camera.start(0).unwrap();
    camera.tick(100 * MS);
    camera.tick(200 * MS);
    assert!(camera.take::<ImageSource>().is_empty());
    let warned = warnings(&camera);
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(
        warned[0].contains("true-pose") && warned[0].contains("lewis fake-device rflex"),
        "{warned:?}"
    );
}

#[test]
fn the_frame_is_the_one_sim_camera_renders_from_the_same_true_pose() {
    let dir = tempfile::tempdir().unwrap();
    let pose = Pose2::new(9.5, 12.5, 0.1);
    PoseFile::in_dir(dir.path()).write(pose).unwrap();
    let mut emulated = emulated_camera(dir.path());
    emulated.start(0).unwrap();
    emulated.tick(100 * MS);
    let from_file = emulated.take::<ImageSource>().pop().expect("a frame");
    assert!(warnings(&emulated).is_empty());
    assert_eq!(
        (
            from_file.width,
            from_file.height,
            from_file.encoding.as_str()
        ),
        (640, 480, "rgb8")
    );
    assert!(
        from_file.header.inputs.is_empty(),
        "rendered from no input: {:?}",
        from_file.header.inputs
    );

    let mut simulated = camera(lewis_sim::service::camera::KIND, "");
    simulated.start(0).unwrap();
    simulated.send(
        0,
        "base",
        &GroundTruth {
            pose: Pose2D {
                x: pose.x_m,
                y: pose.y_m,
                theta: pose.heading_rad,
            },
            ..GroundTruth::default()
        },
    );
    simulated.tick(100 * MS);
    let from_truth = simulated.take::<ImageSource>().pop().expect("a frame");
    assert!(
        from_file.data == from_truth.data,
        "the emulated camera's frame differs from sim-camera's at the same pose and seed"
    );

    // The base drove on: the next frame follows.
    PoseFile::in_dir(dir.path())
        .write(Pose2::new(10.5, 12.5, 0.1))
        .unwrap();
    emulated.tick(200 * MS);
    let moved = emulated.take::<ImageSource>().pop().expect("a frame");
    assert!(
        moved.data != from_file.data,
        "the view changed with the pose"
    );
}
