//! The simulated robot of `robots/sim.toml` around one program, in a scene.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use lewis_interfaces::msg::{GroundTruth, INTERFACES};
use lewis_robot::Robot;
use lewis_service::{Level, Service};
use lewis_testkit::repository_path;
use lewis_testkit::scene::Scene;

/// A second, in ns.
pub const S: i64 = 1_000_000_000;

/// `robots/sim.toml` with the base starting at (x, y, heading in degrees), the world found
/// from the repository's root, and the camera at `camera_px` (width, height).
pub fn sim_robot(start: (f64, f64, f64), camera_px: (i64, i64)) -> Robot {
    let path = repository_path("robots/sim.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let known: Vec<&str> = INTERFACES.iter().map(|i| i.name).collect();
    let mut robot = lewis_robot::parse(&text, &path, &known).unwrap();
    let world = repository_path("robots/worlds/conference");
    for service in &mut robot.services {
        let parameters = &mut service.parameters;
        if parameters.contains_key("world") {
            parameters.insert(
                "world".into(),
                toml::Value::String(world.to_string_lossy().into_owned()),
            );
        }
        if parameters.contains_key("colors") {
            let colors = repository_path("robots/colors/conference.txt");
            parameters.insert(
                "colors".into(),
                toml::Value::String(colors.to_string_lossy().into_owned()),
            );
        }
        match service.name.as_str() {
            "base" => {
                let mut pose = toml::Table::new();
                pose.insert("x_m".into(), start.0.into());
                pose.insert("y_m".into(), start.1.into());
                pose.insert("heading_deg".into(), start.2.into());
                parameters.insert("start".into(), pose.into());
            }
            "camera" => {
                parameters.insert("width_px".into(), camera_px.0.into());
                parameters.insert("height_px".into(), camera_px.1.into());
            }
            _ => {}
        }
    }
    robot
}

/// The services `services` of `robot` and `program` (named `name`, asking for `requires`),
/// GroundTruth tapped.
pub fn scene(
    robot: &Robot,
    services: &[&str],
    name: &str,
    program: Box<dyn Service>,
    requires: &[&str],
) -> Scene {
    let mut scene = Scene::new(robot, &lewis_kinds::registry(), services).unwrap();
    scene.add_program(name, program, requires, 7);
    scene.tap("GroundTruth");
    scene
}

/// The latest true pose and the collisions so far.
pub fn truth(scene: &Scene) -> GroundTruth {
    scene
        .tapped("GroundTruth")
        .last()
        .map(|t| t.publication.decode())
        .unwrap_or_default()
}

/// The services a program that reads signs needs: the base, the laser, the camera and its
/// sign detector, and the movers.
pub const SEEING: &[&str] = &[
    "base",
    "laser",
    "camera",
    "sign_detector",
    "vector_mover",
    "obstacle_avoider",
];

/// Adds `program` to `scene` as `name` (asking for `requires`) and runs it to its end, or
/// `limit_s` more: its exit code, and its Info lines.
pub fn run_program(
    scene: &mut Scene,
    name: &str,
    program: Box<dyn Service>,
    requires: &[&str],
    limit_s: i64,
) -> (Option<i32>, Vec<String>) {
    scene.add_program(name, program, requires, 7);
    let limit = scene.now_ns() + limit_s * S;
    scene.run_until(limit, |s| s.exit_code(name).is_some());
    (scene.exit_code(name), said(scene, name))
}

/// The Info lines member `name` of `scene` logged, in order.
pub fn said(scene: &Scene, name: &str) -> Vec<String> {
    scene
        .harness(name)
        .backend
        .logs
        .iter()
        .filter(|(level, _)| *level == Level::Info)
        .map(|(_, text)| text.clone())
        .collect()
}

/// A program that does nothing, for a scene's first member name.
pub struct Idle;

impl Service for Idle {}
