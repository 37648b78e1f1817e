//! The sonar ring's default specular limit lets the ObstacleAvoider drive on sonar alone
//! without touching a wall: the simulated base, the simulated sonar ring and the avoider in
//! a closed loop through the conference world's entrance door and along its corridor.

#![allow(clippy::unwrap_used)]

use lewis_geometry::Pose2;
use lewis_motion::{AvoiderDrive, MoverStatus, ObstacleAvoiderConfig, VectorMoverConfig};
use lewis_sim::service::SonarParams;
use lewis_sim::{BaseConfig, SimBase, SimSonar, World};
use lewis_testkit::repository_path as repository;

const STEP_NS: i64 = 20_000_000;

struct Outcome {
    status: MoverStatus,
    collisions: u64,
    end: Pose2,
    seconds: f64,
}

/// Drives from the lobby to `goal` (world frame) on the sonar alone, with the sonar's
/// parameters from `sonar_toml` (the service's defaults for the rest).
fn drive_on_sonar(sonar_toml: &str, goal: (f64, f64), seed: u64) -> Outcome {
    let world_dir = repository("robots/worlds/conference");
    let world = World::load(&world_dir).unwrap();
    let params: SonarParams = toml::from_str(&format!(
        "world = {:?}\n{sonar_toml}",
        world_dir.to_string_lossy()
    ))
    .unwrap();
    let mut sonar = SimSonar::new(params.sonar_config(), seed).unwrap();
    let start = Pose2::new(3.0, 12.5, 0.0);
    let mut base = SimBase::new(BaseConfig::default(), start, seed).unwrap();
    let mut drive = AvoiderDrive::new(
        ObstacleAvoiderConfig::default(),
        VectorMoverConfig::default(),
    )
    .unwrap();
    // The odometry starts at zero where the robot starts, facing the world's +x.
    drive.goto(goal.0 - start.x_m, goal.1 - start.y_m).unwrap();
    let sonar_every = (1e9 / params.rate_hz / STEP_NS as f64).round() as i64;
    let mut now = 0;
    let mut step = 0;
    while now < 120_000_000_000 {
        let odometry = base.egomotion().pose;
        if step % sonar_every == 0 {
            let scan = sonar.scan(&world, base.true_pose());
            drive.observe_range_finder(&scan, &odometry, now).unwrap();
        }
        let command = drive.step(&odometry, now);
        base.set_velocity(command.translation_m_s, command.rotation_rad_s);
        base.step(&world, STEP_NS);
        now += STEP_NS;
        step += 1;
        if drive.status().is_final() && base.velocity() == (0.0, 0.0) {
            break;
        }
    }
    Outcome {
        status: drive.status(),
        collisions: base.collision_count(),
        end: base.true_pose(),
        seconds: now as f64 * 1e-9,
    }
}

#[test]
fn with_the_default_specular_limit_sonar_alone_drives_through_the_door_without_a_collision() {
    // From the lobby through the entrance door (1.5 m wide) into the corridor.
    let goal = (12.0, 12.75);
    let outcome = drive_on_sonar("", goal, 1);
    assert_eq!(
        outcome.collisions, 0,
        "the robot hit something, ending at {:?}",
        outcome.end
    );
    assert_eq!(
        outcome.status,
        MoverStatus::Arrived,
        "after {:.1} s at {:?}",
        outcome.seconds,
        outcome.end
    );
    // The goal is in the odometry frame, which drifts: close, not exact.
    let miss = (outcome.end.x_m - goal.0).hypot(outcome.end.y_m - goal.1);
    assert!(
        miss < 0.6,
        "ended {miss} m from the goal, at {:?}",
        outcome.end
    );
}
