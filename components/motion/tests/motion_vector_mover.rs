//! VectorMover driving the simulated B21r in an empty world.

// The helpers shared by the tests unwrap values the tests themselves built.
#![allow(clippy::unwrap_used)]

use crate::motion_support;

use lewis_interfaces::msg::{MoverCommand, MoverGoto, MoverReply, MoverRotate, MoverStop, Pose2D};
use lewis_motion::{GoalId, MoverStatus, VectorMover, VectorMoverConfig, VelocityCommand};
use motion_support::{Robot, STEP_NS, STEP_S, World};
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

fn wrap(angle: f64) -> f64 {
    (angle + PI).rem_euclid(TAU) - PI
}

/// Runs the mover until the goal is over (or the step budget is spent), then a few more
/// steps to let it come to rest.
fn run(mover: &mut VectorMover, robot: &mut Robot, max_steps: usize) -> MoverStatus {
    let world = World::default();
    for _ in 0..max_steps {
        let command = mover.step(&robot.odom_pose(), robot.now_ns);
        robot.drive(&world, command);
        if mover.status() != MoverStatus::Moving && command == VelocityCommand::ZERO {
            break;
        }
    }
    mover.status()
}

/// Every command within the velocity limits, and every change within the accelerations.
fn check_limits(commands: &[VelocityCommand], config: &VectorMoverConfig) {
    let eps = 1e-9;
    let mut last = VelocityCommand::ZERO;
    for (i, c) in commands.iter().enumerate() {
        assert!(
            c.translation_m_s.abs() <= config.max_translation_m_s + eps,
            "step {i}: {c:?}"
        );
        assert!(
            c.rotation_rad_s.abs() <= config.max_rotation_rad_s + eps,
            "step {i}: {c:?}"
        );
        let dv = (c.translation_m_s - last.translation_m_s).abs();
        let dw = (c.rotation_rad_s - last.rotation_rad_s).abs();
        assert!(
            dv <= config.translation_accel_m_s2 * STEP_S + eps,
            "step {i}: dv {dv}"
        );
        assert!(
            dw <= config.rotation_accel_rad_s2 * STEP_S + eps,
            "step {i}: dw {dw}"
        );
        last = *c;
    }
}

fn check_goto(start: Pose2D, goal: (f64, f64), config: &VectorMoverConfig) {
    let mut mover = VectorMover::new(config.clone()).unwrap();
    let mut robot = Robot::at(start);
    let (gx, gy) = robot.world_to_odom(goal.0, goal.1);
    mover.goto(gx, gy).unwrap();
    let status = run(&mut mover, &mut robot, 600);
    assert_eq!(status, MoverStatus::Arrived, "goal {goal:?}");
    let end = &robot.world_pose;
    let miss = (end.x - goal.0).hypot(end.y - goal.1);
    // The tolerance, plus what the robot rolls while braking from the arrival speed.
    assert!(
        miss <= config.position_tolerance_m + 0.01,
        "goal {goal:?}: ended {miss} m away at {end:?}"
    );
    check_limits(&robot.commands, config);
}

#[test]
fn goals_in_all_four_quadrants_are_reached_within_the_limits() {
    let config = VectorMoverConfig::default();
    for goal in [
        (2.0, 1.5),
        (-2.0, 1.5),
        (-2.0, -1.5),
        (2.0, -1.5),
        (0.0, 3.0),
        (-3.0, 0.0),
        (0.3, 0.1),
    ] {
        check_goto(Pose2D::default(), goal, &config);
    }
}

#[test]
fn goals_are_in_the_odometry_frame_wherever_the_robot_started() {
    // The odometry frame starts at a world pose that is neither the origin nor axis-aligned.
    check_goto(
        Pose2D {
            x: 5.0,
            y: -3.0,
            theta: 2.0,
        },
        (3.0, -1.0),
        &VectorMoverConfig::default(),
    );
}

#[test]
fn tighter_limits_are_respected_too() {
    let config = VectorMoverConfig {
        max_translation_m_s: 0.3,
        max_rotation_rad_s: 0.5,
        translation_accel_m_s2: 0.2,
        rotation_accel_rad_s2: 0.5,
        ..VectorMoverConfig::default()
    };
    check_goto(Pose2D::default(), (-2.0, -2.0), &config);
}

#[test]
fn a_goal_behind_is_turned_to_before_driving() {
    let mut mover = VectorMover::new(VectorMoverConfig::default()).unwrap();
    let mut robot = Robot::at(Pose2D::default());
    mover.goto(-2.0, 0.1).unwrap();
    run(&mut mover, &mut robot, 600);
    let limit = mover.config().drive_heading_limit_rad;
    for (pose, command) in robot.path.iter().zip(&robot.commands).take(20) {
        let heading_error = wrap((0.1 - pose.y).atan2(-2.0 - pose.x) - pose.theta);
        if heading_error.abs() > limit {
            assert!(
                command.translation_m_s.abs() < 1e-12,
                "drove with heading error {heading_error}"
            );
        }
    }
    assert_eq!(mover.status(), MoverStatus::Arrived);
}

#[test]
fn a_goal_slightly_off_the_heading_is_driven_to_while_turning() {
    let mut mover = VectorMover::new(VectorMoverConfig::default()).unwrap();
    mover.goto(3.0, 0.4).unwrap();
    let mut first = VelocityCommand::ZERO;
    for i in 0..3 {
        first = mover.step(&Pose2D::default(), i * STEP_NS);
    }
    assert!(
        first.translation_m_s > 0.0 && first.rotation_rad_s > 0.0,
        "{first:?}"
    );
}

fn check_rotate(angle_rad: f64) {
    let config = VectorMoverConfig::default();
    let mut mover = VectorMover::new(config.clone()).unwrap();
    let start = Pose2D {
        x: 1.0,
        y: 2.0,
        theta: 0.3,
    };
    let mut robot = Robot::at(start.clone());
    mover.rotate(angle_rad).unwrap();
    assert_eq!(run(&mut mover, &mut robot, 600), MoverStatus::Arrived);
    let turned = robot.world_pose.theta - start.theta;
    assert!(
        (turned - angle_rad).abs() <= config.heading_tolerance_rad + 0.005,
        "asked {angle_rad}, turned {turned}"
    );
    let moved = (robot.world_pose.x - start.x).hypot(robot.world_pose.y - start.y);
    assert!(moved < 1e-9, "a rotation moved the robot {moved} m");
    check_limits(&robot.commands, &config);
}

#[test]
fn rotations_turn_by_exactly_the_angle_asked_even_beyond_a_turn() {
    for angle in [FRAC_PI_2, -3.0 * PI / 4.0, PI, TAU + 0.5, -0.05] {
        check_rotate(angle);
    }
}

fn check_translate(distance_m: f64) {
    let config = VectorMoverConfig::default();
    let mut mover = VectorMover::new(config.clone()).unwrap();
    let start = Pose2D {
        x: -1.0,
        y: 0.5,
        theta: -0.7,
    };
    let mut robot = Robot::at(start.clone());
    mover.translate(distance_m).unwrap();
    assert_eq!(run(&mut mover, &mut robot, 600), MoverStatus::Arrived);
    let (dx, dy) = (robot.world_pose.x - start.x, robot.world_pose.y - start.y);
    let along = dx * start.theta.cos() + dy * start.theta.sin();
    let across = -dx * start.theta.sin() + dy * start.theta.cos();
    assert!(
        (along - distance_m).abs() <= config.position_tolerance_m + 0.01,
        "asked {distance_m}, went {along}"
    );
    assert!(across.abs() < 1e-6, "drifted {across} m sideways");
    assert!(wrap(robot.world_pose.theta - start.theta).abs() < 1e-6);
    check_limits(&robot.commands, &config);
}

#[test]
fn translations_go_exactly_forward_and_backward() {
    for distance in [1.5, -0.7, 0.2] {
        check_translate(distance);
    }
}

#[test]
fn stop_brings_the_robot_to_rest_within_the_limits_and_clears_the_goal() {
    let config = VectorMoverConfig::default();
    let mut mover = VectorMover::new(config.clone()).unwrap();
    let mut robot = Robot::at(Pose2D::default());
    let world = World::default();
    mover.goto(10.0, 0.0).unwrap();
    for _ in 0..30 {
        let command = mover.step(&robot.odom_pose(), robot.now_ns);
        robot.drive(&world, command);
    }
    assert!((mover.last_command().translation_m_s - config.max_translation_m_s).abs() < 1e-9);
    mover.stop();
    assert_eq!(mover.status(), MoverStatus::Idle);
    assert_eq!(mover.publication().goal_id, 0);
    // From full speed: max speed / acceleration seconds to rest, then nothing more.
    let braking_steps =
        (config.max_translation_m_s / config.translation_accel_m_s2 / STEP_S).ceil() as usize;
    for i in 0..braking_steps + 5 {
        let command = mover.step(&robot.odom_pose(), robot.now_ns);
        robot.drive(&world, command);
        if i >= braking_steps {
            assert_eq!(
                command,
                VelocityCommand::ZERO,
                "still moving {i} steps after stop"
            );
        }
    }
    check_limits(&robot.commands, &config);
}

#[test]
fn each_accepted_goal_gets_a_new_id_in_the_reply_and_publication() {
    let mut mover = VectorMover::new(VectorMoverConfig::default()).unwrap();
    let reply = mover
        .handle(&MoverCommand::Goto(MoverGoto {
            x: 1.0,
            y: 1.0,
            ..Default::default()
        }))
        .unwrap();
    let MoverReply::Goto(goto) = reply else {
        panic!("{reply:?}")
    };
    assert_eq!(goto.goal_id, 1);
    let reply = mover
        .handle(&MoverCommand::Rotate(MoverRotate {
            angle: 1.0,
            ..Default::default()
        }))
        .unwrap();
    assert!(matches!(reply, MoverReply::Rotate(r) if r.goal_id == 2));
    assert_eq!(mover.translate(1.0).unwrap(), GoalId::FIRST.next().next());
    let bad = mover.handle(&MoverCommand::Goto(MoverGoto {
        x: f64::NAN,
        ..Default::default()
    }));
    assert!(bad.is_err());
    assert_eq!(
        mover.goal_id().map(GoalId::get),
        Some(3),
        "a refused goal keeps the current one"
    );
    assert!(matches!(
        mover
            .handle(&MoverCommand::Stop(MoverStop::default()))
            .unwrap(),
        MoverReply::Stop(_)
    ));
    assert_eq!(mover.publication().status, "idle");
}

#[test]
fn the_publication_describes_the_goal_and_the_motion() {
    let mut mover = VectorMover::new(VectorMoverConfig::default()).unwrap();
    let id = mover.goto(3.0, 4.0).unwrap();
    let mut robot = Robot::at(Pose2D::default());
    let world = World::default();
    for _ in 0..10 {
        let command = mover.step(&robot.odom_pose(), robot.now_ns);
        robot.drive(&world, command);
    }
    let publication = mover.publication();
    assert_eq!(publication.goal_id, id.get());
    assert_eq!(publication.status, "moving");
    assert_eq!((publication.goal.x, publication.goal.y), (3.0, 4.0));
    assert!(
        (publication.goal.theta - 4.0_f64.atan2(3.0)).abs() < 1e-12,
        "goto's goal heading is the bearing"
    );
    assert_eq!((publication.waypoint.x, publication.waypoint.y), (3.0, 4.0));
    let pose = &robot.path[robot.path.len() - 2];
    assert!((publication.distance_to_goal - (3.0 - pose.x).hypot(4.0 - pose.y)).abs() < 1e-9);
    assert_eq!(
        publication.translation_velocity,
        mover.last_command().translation_m_s
    );
    assert_eq!(
        publication.rotation_velocity,
        mover.last_command().rotation_rad_s
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn any_goal_from_any_heading_is_reached_within_the_limits(
        x in -4.0f64..4.0, y in -4.0f64..4.0, theta in -PI..PI,
    ) {
        check_goto(Pose2D { x: 0.0, y: 0.0, theta }, (x, y), &VectorMoverConfig::default());
    }
}

#[test]
fn a_command_is_carried_out_at_once_as_if_it_had_come_before_the_last_step() {
    let mut mover = VectorMover::new(VectorMoverConfig::default()).unwrap();
    assert_eq!(
        mover.restep(),
        None,
        "nothing to do again before a first step"
    );
    let mut robot = Robot::at(Pose2D::default());
    let world = World::default();
    mover.goto(10.0, 0.0).unwrap();
    for _ in 0..12 {
        let command = mover.step(&robot.odom_pose(), robot.now_ns);
        robot.drive(&world, command);
    }
    let (pose, now_ns) = (robot.odom_pose(), robot.now_ns);
    let commands: [fn(&mut VectorMover); 3] = [
        |m| {
            m.goto(3.0, 4.0).unwrap();
        },
        |m| {
            m.rotate(-1.0).unwrap();
        },
        VectorMover::stop,
    ];
    for command in commands {
        // The twin hears the command before the step, the mover after it.
        let mut twin = mover.clone();
        command(&mut twin);
        let expected = twin.step(&pose, now_ns);
        let mut late = mover.clone();
        late.step(&pose, now_ns);
        command(&mut late);
        assert_eq!(late.restep(), Some(expected));
        assert_eq!(late.status(), twin.status());
        // And they go on alike.
        let later = now_ns + STEP_NS;
        assert_eq!(late.step(&pose, later), twin.step(&pose, later));
    }
}

#[test]
fn a_command_carried_out_at_once_keeps_a_cap_put_on_the_last_step() {
    let mut mover = VectorMover::new(VectorMoverConfig::default()).unwrap();
    let mut robot = Robot::at(Pose2D::default());
    mover.goto(10.0, 0.0).unwrap();
    for _ in 0..12 {
        let command = mover.step(&robot.odom_pose(), robot.now_ns);
        robot.drive(&World::default(), command);
    }
    mover.cap_translation(0.1);
    mover.goto(10.0, 0.5).unwrap();
    let command = mover.restep().unwrap();
    assert!(command.translation_m_s <= 0.1, "{command:?}");
}
