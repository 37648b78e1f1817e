//! ObstacleAvoider driving the simulated B21r around walls in a small world, on the
//! simulated laser, sonar ring and Distance readings.

// The helpers shared by the tests unwrap values the tests themselves built.
#![allow(clippy::unwrap_used)]

use crate::motion_support;

use lewis_interfaces::msg::{MoverReply, Pose2D, RangeFinder};
use lewis_motion::{
    AvoiderDrive, HoldReason, MoverRequest, MoverStatus, ObstacleAvoider, ObstacleAvoiderConfig,
    RangeScan, VectorMover, VectorMoverConfig, VelocityCommand,
};
use motion_support::{B21R_RADIUS_M, Robot, STEP_NS, Sensors, World, p};

/// What the robot reads at a step.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Sensor {
    Laser,
    Sonar,
    /// Distance sectors computed from the laser.
    Distance,
    /// Nothing arrives (the device is down).
    Silent,
}

struct Outcome {
    status: MoverStatus,
    robot: Robot,
    holds: Vec<HoldReason>,
    steps: usize,
}

/// Anything that turns readings and poses into velocities: the drive that owns its
/// VectorMover, or an avoider talking to a separate VectorMover through Mover commands.
trait Driver {
    fn observe(&mut self, sensor: Sensor, world: &World, robot: &Robot, sensors: &mut Sensors);
    fn step(&mut self, pose: &Pose2D, now_ns: i64) -> VelocityCommand;
    fn status(&self) -> MoverStatus;
    fn hold(&self) -> Option<HoldReason>;
}

fn read(sensor: Sensor, world: &World, robot: &Robot, sensors: &mut Sensors) -> Option<Reading> {
    match sensor {
        Sensor::Laser => Some(Reading::Range(sensors.laser(world, &robot.world_pose))),
        Sensor::Sonar => Some(Reading::Range(sensors.sonar(world, &robot.world_pose))),
        Sensor::Distance => Some(Reading::Distance(sensors.distance(
            world,
            &robot.world_pose,
            36,
        ))),
        Sensor::Silent => None,
    }
}

enum Reading {
    Range(RangeFinder),
    Distance(lewis_interfaces::msg::Distance),
}

impl Driver for AvoiderDrive {
    fn observe(&mut self, sensor: Sensor, world: &World, robot: &Robot, sensors: &mut Sensors) {
        let pose = robot.odom_pose();
        match read(sensor, world, robot, sensors) {
            Some(Reading::Range(r)) => self.observe_range_finder(&r, &pose, robot.now_ns).unwrap(),
            Some(Reading::Distance(d)) => self.observe_distance(&d, &pose, robot.now_ns).unwrap(),
            None => {}
        }
    }
    fn step(&mut self, pose: &Pose2D, now_ns: i64) -> VelocityCommand {
        AvoiderDrive::step(self, pose, now_ns)
    }
    fn status(&self) -> MoverStatus {
        AvoiderDrive::status(self)
    }
    fn hold(&self) -> Option<HoldReason> {
        self.avoider().hold_reason()
    }
}

/// The avoider and a VectorMover as two services would be: Mover commands between them.
struct Split {
    avoider: ObstacleAvoider,
    mover: VectorMover,
    commands_sent: usize,
}

impl Driver for Split {
    fn observe(&mut self, sensor: Sensor, world: &World, robot: &Robot, sensors: &mut Sensors) {
        let pose = robot.odom_pose();
        match read(sensor, world, robot, sensors) {
            Some(Reading::Range(r)) => self
                .avoider
                .observe_range_finder(&r, &pose, robot.now_ns)
                .unwrap(),
            Some(Reading::Distance(d)) => self
                .avoider
                .observe_distance(&d, &pose, robot.now_ns)
                .unwrap(),
            None => {}
        }
    }
    fn step(&mut self, pose: &Pose2D, now_ns: i64) -> VelocityCommand {
        if let Some(request) = self.avoider.step(pose, now_ns).request {
            self.commands_sent += 1;
            self.mover.handle(&request.to_command()).unwrap();
        }
        self.mover.step(pose, now_ns)
    }
    fn status(&self) -> MoverStatus {
        self.avoider.status()
    }
    fn hold(&self) -> Option<HoldReason> {
        self.avoider.hold_reason()
    }
}

fn drive() -> AvoiderDrive {
    AvoiderDrive::new(
        ObstacleAvoiderConfig::default(),
        VectorMoverConfig::default(),
    )
    .unwrap()
}

/// Runs until the goal is over and the robot at rest, or `max_steps`.
fn run(
    driver: &mut dyn Driver,
    world: &World,
    mut robot: Robot,
    schedule: &dyn Fn(usize) -> Sensor,
    max_steps: usize,
    seed: u64,
) -> Outcome {
    let mut sensors = Sensors::new(seed);
    let mut holds = Vec::new();
    let mut steps = 0;
    for step in 0..max_steps {
        steps = step + 1;
        let sensor = schedule(step);
        // The sonar ring is slower than the laser: every other step.
        if sensor != Sensor::Sonar || step % 2 == 0 {
            driver.observe(sensor, world, &robot, &mut sensors);
        }
        let command = driver.step(&robot.odom_pose(), robot.now_ns);
        if let Some(hold) = driver.hold()
            && holds.last() != Some(&hold)
        {
            holds.push(hold);
        }
        robot.drive(world, command);
        if driver.status().is_final() && command == VelocityCommand::ZERO {
            break;
        }
    }
    Outcome {
        status: driver.status(),
        robot,
        holds,
        steps,
    }
}

fn wall_world() -> World {
    World::default().wall(p(2.0, -1.5), p(2.0, 1.5))
}

/// The robot reached the world goal without ever touching anything.
fn check_arrival(outcome: &Outcome, goal: (f64, f64), what: &str) {
    assert_eq!(
        outcome.status,
        MoverStatus::Arrived,
        "{what}: after {} steps, holds {:?}",
        outcome.steps,
        outcome.holds
    );
    let end = &outcome.robot.world_pose;
    let miss = (end.x - goal.0).hypot(end.y - goal.1);
    assert!(
        miss <= ObstacleAvoiderConfig::default().position_tolerance_m + 0.01,
        "{what}: ended {miss} m from the goal"
    );
    assert!(
        outcome.robot.min_clearance_m >= B21R_RADIUS_M,
        "{what}: the robot came {} m from an obstacle, closer than its radius",
        outcome.robot.min_clearance_m
    );
}

#[test]
fn a_goal_in_plain_sight_is_approached_in_a_straight_line() {
    let world = World::default().wall(p(6.0, -3.0), p(6.0, 3.0));
    let mut d = drive();
    d.goto(3.0, 1.0).unwrap();
    let outcome = run(
        &mut d,
        &world,
        Robot::at(Pose2D::default()),
        &|_| Sensor::Laser,
        400,
        1,
    );
    check_arrival(&outcome, (3.0, 1.0), "laser, open");
    let worst = outcome
        .robot
        .path
        .iter()
        .map(|q| (q.x * 1.0 - q.y * 3.0).abs() / 10f64.sqrt())
        .fold(0.0, f64::max);
    assert!(worst < 0.1, "strayed {worst} m from the straight line");
}

#[test]
fn a_goal_behind_a_wall_is_reached_around_it_on_the_laser() {
    let mut d = drive();
    d.goto(4.0, 0.0).unwrap();
    let outcome = run(
        &mut d,
        &wall_world(),
        Robot::at(Pose2D::default()),
        &|_| Sensor::Laser,
        600,
        2,
    );
    check_arrival(&outcome, (4.0, 0.0), "laser");
    assert!(
        outcome.robot.path.iter().any(|q| q.y.abs() > 1.5),
        "the robot went through the wall?"
    );
}

#[test]
fn a_goal_behind_a_wall_is_reached_on_a_coarse_noisy_sonar_ring() {
    for seed in 3..7 {
        let mut d = drive();
        d.goto(4.0, 0.0).unwrap();
        let outcome = run(
            &mut d,
            &wall_world(),
            Robot::at(Pose2D::default()),
            &|_| Sensor::Sonar,
            // The way is shut by the wall: 8 s of waiting before going round it.
            1000,
            seed,
        );
        check_arrival(&outcome, (4.0, 0.0), &format!("sonar, noise seed {seed}"));
    }
}

#[test]
fn a_goal_behind_a_wall_is_reached_on_distance_sectors() {
    let mut d = drive();
    d.goto(4.0, 0.0).unwrap();
    let outcome = run(
        &mut d,
        &wall_world(),
        Robot::at(Pose2D::default()),
        &|_| Sensor::Distance,
        600,
        4,
    );
    check_arrival(&outcome, (4.0, 0.0), "distance");
}

#[test]
fn losing_the_laser_mid_run_and_going_on_with_sonar_still_reaches_the_goal() {
    // Laser for 4 s, nothing for 1.5 s (the broker failing over), then the sonar ring.
    let schedule = |step: usize| match step {
        0..40 => Sensor::Laser,
        40..55 => Sensor::Silent,
        _ => Sensor::Sonar,
    };
    let mut d = drive();
    d.goto(4.0, 0.0).unwrap();
    let outcome = run(
        &mut d,
        &wall_world(),
        Robot::at(Pose2D::default()),
        &schedule,
        900,
        5,
    );
    check_arrival(&outcome, (4.0, 0.0), "laser then sonar");
    assert_eq!(
        outcome.holds,
        vec![HoldReason::StaleReadings],
        "held while no readings came, then went on"
    );
}

#[test]
fn goals_and_poses_are_in_the_odometry_frame_and_readings_in_the_robot_frame() {
    // The odometry frame starts at a rotated, shifted world pose: the wall is behind the
    // robot's start in odometry terms, and the goal is given in odometry coordinates.
    let start = Pose2D {
        x: 5.0,
        y: 1.0,
        theta: std::f64::consts::PI,
    };
    let robot = Robot::at(start);
    let goal_world = (1.0, 0.5);
    let (gx, gy) = robot.world_to_odom(goal_world.0, goal_world.1);
    let world = World::default().wall(p(3.0, -0.5), p(3.0, 2.5));
    let mut d = drive();
    d.goto(gx, gy).unwrap();
    let outcome = run(&mut d, &world, robot, &|_| Sensor::Laser, 600, 6);
    check_arrival(&outcome, goal_world, "odometry frame");
}

#[test]
fn readings_older_than_the_limit_stop_the_robot_and_then_fail_the_goal() {
    let avoider = ObstacleAvoiderConfig {
        fail_after_ns: 5_000_000_000,
        ..ObstacleAvoiderConfig::default()
    };
    let mover = VectorMoverConfig::default();
    let mut d = AvoiderDrive::new(avoider.clone(), mover.clone()).unwrap();
    d.goto(4.0, 0.0).unwrap();
    let last_reading_step = 30;
    let schedule = move |step: usize| {
        if step <= last_reading_step {
            Sensor::Laser
        } else {
            Sensor::Silent
        }
    };
    let outcome = run(
        &mut d,
        &wall_world(),
        Robot::at(Pose2D::default()),
        &schedule,
        300,
        7,
    );
    assert_eq!(outcome.status, MoverStatus::Failed);
    assert_eq!(outcome.holds, vec![HoldReason::StaleReadings]);
    // At rest within the age limit plus the braking time, and never moving again.
    let stale_step = last_reading_step + (avoider.max_reading_age_ns / STEP_NS) as usize + 1;
    let braking_steps =
        (mover.max_translation_m_s / mover.translation_accel_m_s2 / 0.1).ceil() as usize;
    for (i, c) in outcome
        .robot
        .commands
        .iter()
        .enumerate()
        .skip(stale_step + braking_steps + 1)
    {
        assert_eq!(
            *c,
            VelocityCommand::ZERO,
            "moving at step {i} without readings"
        );
    }
    assert!(outcome.robot.min_clearance_m >= B21R_RADIUS_M);
    assert_eq!(d.publication().status, "failed");
}

/// A corridor 2.4 m wide along x, closed at both ends further than the laser reaches, with
/// a person across it at x = 2.5 (a short wall) while `shut`.
fn corridor(shut: bool) -> World {
    let world = World::default()
        .wall(p(-12.0, -1.2), p(20.0, -1.2))
        .wall(p(-12.0, 1.2), p(20.0, 1.2));
    if shut {
        world.wall(p(2.5, -1.2), p(2.5, 1.2))
    } else {
        world
    }
}

/// Drives to (8, 0) in the corridor, shut for the first `shut_steps`: the lowest x the
/// robot went to, and the status at the end.
fn through_the_corridor(detour_wait_ns: i64, shut_steps: usize) -> (f64, MoverStatus) {
    let config = ObstacleAvoiderConfig {
        detour_wait_ns,
        ..ObstacleAvoiderConfig::default()
    };
    let mut d = AvoiderDrive::new(config, VectorMoverConfig::default()).unwrap();
    d.goto(8.0, 0.0).unwrap();
    let mut robot = Robot::at(Pose2D::default());
    let mut sensors = Sensors::new(4);
    let (shut, open) = (corridor(true), corridor(false));
    let mut lowest_x = 0.0_f64;
    for step in 0..400 {
        let world = if step < shut_steps { &shut } else { &open };
        // The sonar ring, every other step, as after the laser's failure.
        if step % 2 == 0 {
            d.observe(Sensor::Sonar, world, &robot, &mut sensors);
        }
        let command = d.step(&robot.odom_pose(), robot.now_ns);
        robot.drive(world, command);
        lowest_x = lowest_x.min(robot.world_pose.x);
        if d.status() == MoverStatus::Arrived {
            break;
        }
    }
    assert_eq!(robot.collisions(), 0);
    (lowest_x, d.status())
}

#[test]
fn a_person_across_the_way_is_waited_for_not_gone_round_through_the_unknown() {
    // The person stands 6 s: the robot waits before them, and goes on when they have gone.
    let (lowest_x, status) = through_the_corridor(8_000_000_000, 60);
    assert_eq!(status, MoverStatus::Arrived);
    assert!(lowest_x > -0.3, "went back to x {lowest_x:.2}");
    // Without the wait, the way round the person is back through the corridor the
    // avoider has forgotten (unknown counts as free): the robot turns back.
    let (lowest_x, _) = through_the_corridor(0, 60);
    assert!(lowest_x < -0.5, "went back only to x {lowest_x:.2}");
}

#[test]
fn a_goal_that_cannot_be_reached_is_reported_blocked_without_touching_anything() {
    // The goal is inside a closed box: wherever the robot goes around it, it gets no closer.
    let world = World::default()
        .wall(p(3.2, -0.8), p(4.8, -0.8))
        .wall(p(4.8, -0.8), p(4.8, 0.8))
        .wall(p(4.8, 0.8), p(3.2, 0.8))
        .wall(p(3.2, 0.8), p(3.2, -0.8));
    let mut d = drive();
    d.goto(4.0, 0.0).unwrap();
    let mut robot = Robot::at(Pose2D::default());
    let mut sensors = Sensors::new(8);
    let mut blocked_at = None;
    // 8 s waiting for the way to open, then the way round, then 15 s without progress.
    for step in 0..700 {
        d.observe(Sensor::Laser, &world, &robot, &mut sensors);
        let command = d.step(&robot.odom_pose(), robot.now_ns);
        robot.drive(&world, command);
        if d.status() == MoverStatus::Blocked && blocked_at.is_none() {
            blocked_at = Some(step);
        }
    }
    assert!(blocked_at.is_some(), "never reported blocked");
    assert_eq!(
        d.status(),
        MoverStatus::Blocked,
        "blocked is kept while the way stays shut"
    );
    assert_eq!(d.avoider().hold_reason(), Some(HoldReason::NoProgress));
    assert_eq!(d.publication().status, "blocked");
    assert_eq!(*robot.commands.last().unwrap(), VelocityCommand::ZERO);
    assert!(
        robot.min_clearance_m >= B21R_RADIUS_M,
        "came {} m from a wall",
        robot.min_clearance_m
    );
}

#[test]
fn an_avoider_and_a_separate_vector_mover_talking_mover_commands_reach_the_goal() {
    let mut split = Split {
        avoider: ObstacleAvoider::new(ObstacleAvoiderConfig::default()).unwrap(),
        mover: VectorMover::new(VectorMoverConfig::default()).unwrap(),
        commands_sent: 0,
    };
    let reply = split
        .avoider
        .handle(&MoverRequest::Goto { x_m: 4.0, y_m: 0.0 }.to_command());
    assert!(matches!(reply, Ok(MoverReply::Goto(r)) if r.goal_id == 1));
    let outcome = run(
        &mut split,
        &wall_world(),
        Robot::at(Pose2D::default()),
        &|_| Sensor::Laser,
        600,
        9,
    );
    check_arrival(&outcome, (4.0, 0.0), "split services");
    assert!(
        split.commands_sent < outcome.steps / 2,
        "{} commands in {} steps",
        split.commands_sent,
        outcome.steps
    );
}

#[test]
fn a_translate_towards_a_wall_stops_short_and_reports_blocked_and_rotate_needs_no_readings() {
    let world = World::default().wall(p(1.5, -1.0), p(1.5, 1.0));
    let mut d = drive();
    d.translate(3.0).unwrap();
    let outcome = run(
        &mut d,
        &world,
        Robot::at(Pose2D::default()),
        &|_| Sensor::Laser,
        150,
        10,
    );
    assert_eq!(outcome.status, MoverStatus::Blocked);
    assert_eq!(outcome.holds, vec![HoldReason::PathObstructed]);
    assert!(outcome.robot.min_clearance_m >= B21R_RADIUS_M);
    assert!(
        outcome.robot.world_pose.x > 0.5,
        "it did drive until the wall was near"
    );

    let mut d = drive();
    d.rotate(std::f64::consts::FRAC_PI_2).unwrap();
    let outcome = run(
        &mut d,
        &world,
        Robot::at(Pose2D::default()),
        &|_| Sensor::Silent,
        150,
        11,
    );
    assert_eq!(outcome.status, MoverStatus::Arrived);
    assert!((outcome.robot.world_pose.theta - std::f64::consts::FRAC_PI_2).abs() < 0.04);
}

#[test]
fn the_publication_carries_the_avoider_goal_waypoint_and_the_mover_velocities() {
    let mut d = drive();
    let id = d.goto(4.0, 0.0).unwrap();
    let world = wall_world();
    let mut robot = Robot::at(Pose2D::default());
    let mut sensors = Sensors::new(12);
    for _ in 0..15 {
        d.observe(Sensor::Laser, &world, &robot, &mut sensors);
        let command = d.step(&robot.odom_pose(), robot.now_ns);
        robot.drive(&world, command);
    }
    let publication = d.publication();
    assert_eq!(publication.goal_id, id.get());
    assert_eq!((publication.goal.x, publication.goal.y), (4.0, 0.0));
    assert_eq!(publication.status, "moving");
    assert!(
        publication.waypoint.y.abs() > 1.5,
        "the waypoint is past an end of the wall: {:?}",
        publication.waypoint
    );
    assert_eq!(
        publication.translation_velocity,
        d.mover().last_command().translation_m_s
    );
    assert!(publication.distance_to_goal > 3.0);
}

#[test]
fn the_reflex_stops_at_once_for_an_obstacle_that_comes_into_the_way_and_the_next_step_goes_around()
{
    let config = ObstacleAvoiderConfig::default();
    let mut avoider = ObstacleAvoider::new(config.clone()).unwrap();
    avoider.goto(4.0, 0.0).unwrap();
    let robot = Robot::at(Pose2D::default());
    let pose = robot.odom_pose();
    let mut sensors = Sensors::new(13);
    let mut scan_of = |world: &World| sensors.laser(world, &robot.world_pose);
    let beams = |reading: &RangeFinder| {
        RangeScan::from_range_finder(reading, config.non_uniform_half_width_rad).unwrap()
    };
    let clear = scan_of(&World::default());
    avoider.observe_range_finder(&clear, &pose, 0).unwrap();
    assert!(matches!(
        avoider.step(&pose, 0).request,
        Some(MoverRequest::Goto { .. })
    ));
    // Nothing new on the way, something beside it or beyond the lookahead: no reflex.
    let beside = World::default().wall(p(0.3, 1.0), p(1.5, 1.0));
    let beyond = World::default().wall(p(2.0, -0.3), p(2.0, 0.3));
    for world in [World::default(), beside, beyond] {
        assert_eq!(avoider.react(&beams(&scan_of(&world)), &pose), None);
    }
    // Someone steps in 0.7 m ahead: stop now, once; the goal goes on.
    let blocked = scan_of(&World::default().wall(p(0.7, -0.2), p(0.7, 0.2)));
    assert_eq!(
        avoider.react(&beams(&blocked), &pose),
        Some(MoverRequest::Stop)
    );
    assert_eq!(avoider.status(), MoverStatus::Moving);
    assert_eq!(avoider.waypoint(), None);
    assert_eq!(avoider.react(&beams(&blocked), &pose), None, "once");
    // The next step plans around it: a new waypoint, clear of the reflex with that reading.
    avoider
        .observe_range_finder(&blocked, &pose, 50_000_000)
        .unwrap();
    let step = avoider.step(&pose, 100_000_000);
    let Some(MoverRequest::Goto { y_m, .. }) = step.request else {
        panic!("a new waypoint: {step:?}");
    };
    assert!(y_m.abs() > 0.2, "around the obstacle: {y_m}");
    assert_eq!(avoider.react(&beams(&blocked), &pose), None);
}
