//! The simulated devices against known geometry: ray casting, the base's kinematics and
//! collisions, the sonar's cone and specular misses, the RangeFinder layouts, Distance, the
//! battery; and determinism: the same seed and commands give the same outputs, bit for bit.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test helpers fail loudly on broken fixtures"
)]

use std::f64::consts::{FRAC_PI_2, PI};
use std::path::{Path, PathBuf};

use lewis_geometry::{Pose2, SensorMount, Vec2};
use lewis_interfaces::Struct;
use lewis_interfaces::msg::{Egomotion, Power, RangeFinder, Synchrodrive};
use lewis_sim::world::{ObjectKind, OccupancyGrid, Rgb, WorldObject};
use lewis_sim::{
    BaseConfig, LaserConfig, OdometryNoise, Shape, SimBase, SimLaser, SimSonar, SonarConfig, World,
    WorldLook,
};

const NS_PER_S: i64 = 1_000_000_000;

fn repository_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(relative)
}

fn look() -> WorldLook {
    WorldLook {
        wall_height_m: 2.5,
        wall_colour: Rgb::new(196, 186, 158),
        floor_colour: Rgb::new(96, 92, 88),
        ceiling_colour: Rgb::new(172, 172, 178),
    }
}

/// A 10 m x 10 m room of 0.05 m cells, walled around, with a wall of cells at x in
/// [6.0, 6.05) and `objects`.
fn room(objects: Vec<WorldObject>) -> World {
    let grid = OccupancyGrid::from_fn(200, 200, 0.05, Vec2::new(0.0, 0.0), |c, r| {
        c == 0 || r == 0 || c == 199 || r == 199 || c == 120
    });
    World::new("room".to_owned(), grid, look(), objects)
}

fn noiseless_laser() -> SimLaser {
    let config = LaserConfig {
        range_noise_std_m: 0.0,
        ..LaserConfig::default()
    };
    SimLaser::new(config, 0).unwrap()
}

fn assert_near(got: f64, expected: f64, tolerance: f64, what: &str) {
    assert!(
        (got - expected).abs() <= tolerance,
        "{what}: got {got}, expected {expected}"
    );
}

#[test]
fn laser_beams_measure_a_wall_at_a_known_distance() {
    let world = room(Vec::new());
    let mut laser = noiseless_laser();
    // The laser sits 0.12 m ahead of the centre: 6.0 - 1.0 - 0.12 to the wall.
    let scan = laser.scan(&world, Pose2::new(1.0, 5.0, 0.0));
    assert_eq!(scan.ranges.len(), 361);
    assert_near(scan.ranges[180], 4.88, 1e-9, "straight ahead");
    // 30 degrees to the left (beam 180 + 60): the same wall, further.
    assert_near(
        scan.ranges[240],
        4.88 / (PI / 6.0).cos(),
        1e-9,
        "30 degrees left",
    );
    // Straight right: the room's south wall, whose cells end at y = 0.05.
    assert_near(scan.ranges[0], 4.95, 1e-9, "right");
    // Nothing within 8.191 m reads max range: the robot turned to face the far end of a
    // 40 m corridor would see that; here rotate so the wall is behind.
    let back = laser.scan(&world, Pose2::new(5.0, 5.0, PI));
    assert_near(back.ranges[180], 5.0 - 0.12 - 0.05, 1e-9, "west wall");
}

#[test]
fn laser_beams_stop_at_objects_that_reach_their_height_and_pass_over_lower_ones() {
    let pillar = |name: &str, y: f64, height_m: f64| WorldObject {
        name: name.to_owned(),
        kind: ObjectKind::Landmark {
            shape: Shape::Circle {
                centre: Vec2::new(4.0, y),
                radius_m: 0.25,
            },
            height_m,
            colour: Rgb::new(200, 0, 0),
        },
    };
    let world = room(vec![pillar("tall", 5.0, 1.0), pillar("low", 3.0, 0.2)]);
    let mut laser = noiseless_laser();
    let robot = Pose2::new(1.0, 5.0, 0.0);
    let scan = laser.scan(&world, robot);
    assert_near(scan.ranges[180], 4.0 - 0.25 - 1.12, 1e-9, "pillar ahead");
    let low = laser.scan(&world, Pose2::new(1.0, 3.0, 0.0));
    assert_near(low.ranges[180], 4.88, 1e-9, "over the low pillar");
}

#[test]
fn the_laser_range_finder_is_uniform_with_offsets_and_separations() {
    let world = room(Vec::new());
    let mut laser = SimLaser::new(LaserConfig::default(), 3).unwrap();
    let scan = laser.scan(&world, Pose2::new(2.0, 5.0, 0.0));
    assert!(scan.uniform);
    assert_eq!(scan.range_count, 361);
    assert_eq!(scan.sensor_positions.len(), 361);
    assert_eq!(scan.max_range, 8.191);
    assert_near(scan.theta_offset, -FRAC_PI_2, 1e-12, "first beam");
    assert_near(scan.theta_separation, PI / 360.0, 1e-12, "separation");
    assert_near(scan.x_offset, 0.12, 1e-12, "x offset");
    assert_near(scan.z_offset, 0.38, 1e-12, "z offset");
    assert_near(
        scan.sensor_positions[360].theta,
        FRAC_PI_2,
        1e-12,
        "last beam",
    );
    scan.check_sizes().unwrap();
    let geometry = laser.geometry();
    assert_eq!(
        (geometry.range_count, geometry.max_range, geometry.rate),
        (361, 8.191, 37.5)
    );
}

#[test]
fn the_sonar_ring_is_not_uniform_and_has_a_pose_per_transducer() {
    let world = room(Vec::new());
    let mut sonar = SimSonar::new(SonarConfig::default(), 3).unwrap();
    let scan = sonar.scan(&world, Pose2::new(3.0, 5.0, 0.0));
    assert!(!scan.uniform);
    assert_eq!(scan.range_count, 48);
    assert_eq!(scan.sensor_positions.len(), 48);
    scan.check_sizes().unwrap();
    for (i, p) in scan.sensor_positions.iter().enumerate() {
        assert_near(p.x.hypot(p.y), 0.26, 1e-9, "on the body's edge");
        let off = lewis_geometry::wrap_angle(p.y.atan2(p.x) - p.theta);
        assert_near(off, 0.0, 1e-9, "facing out");
        let expected_z = if i < 24 { 0.62 } else { 0.30 };
        assert_near(p.z, expected_z, 1e-12, "ring height");
    }
    // Transducers 0 and 24 face the wall 3 m ahead (2.74 m from the body's edge) head on.
    assert_near(scan.ranges[0], 2.74, 0.15, "upper ring ahead");
    assert_near(scan.ranges[24], 2.74, 0.15, "base ring ahead");
}

/// One transducer with a thin beam unless `rays` says otherwise.
fn one_transducer(rays: usize) -> SimSonar {
    let config = SonarConfig {
        transducers: vec![SensorMount {
            pose: Pose2::new(0.0, 0.0, 0.0),
            height_m: 0.5,
        }],
        rays_per_cone: rays,
        range_noise_std_m: 0.0,
        range_noise_fraction: 0.0,
        ..SonarConfig::default()
    };
    SimSonar::new(config, 0).unwrap()
}

#[test]
fn a_sonar_meeting_a_wall_at_a_grazing_angle_hears_no_echo() {
    let world = room(Vec::new());
    let sonar = one_transducer(7);
    let mount = sonar.config().transducers[0];
    let range_at = |heading_deg: f64| {
        sonar.true_range(
            &world,
            Pose2::new(4.0, 5.0, heading_deg.to_radians()),
            &mount,
        )
    };
    // Head on: 2 m.
    assert_near(range_at(0.0), 2.0, 1e-9, "head on");
    // 35 degrees: the cone's edge (12.5 degrees) meets the wall within 30 degrees of its
    // normal, and that ray's echo is the reading.
    let edge = range_at(35.0);
    assert_near(
        edge,
        2.0 / (35.0f64 - 12.5).to_radians().cos(),
        1e-9,
        "35 degrees",
    );
    // 60 degrees: every ray of the cone is beyond 30 degrees: a specular miss.
    assert_eq!(range_at(60.0), 5.0);
    // A round pillar always shows a face square to some ray, whatever the heading.
    let pillar = room(vec![WorldObject {
        name: "pillar".to_owned(),
        kind: ObjectKind::Landmark {
            shape: Shape::Circle {
                centre: Vec2::new(5.5, 5.0),
                radius_m: 0.3,
            },
            height_m: 1.0,
            colour: Rgb::new(0, 0, 200),
        },
    }]);
    let r = sonar.true_range(&pillar, Pose2::new(4.0, 5.0, 0.2), &mount);
    // The nearest of the seven rays passes a little off the centre line.
    assert_near(r, 1.2, 2e-3, "pillar");
}

#[test]
fn a_sonar_cone_sees_what_a_thin_beam_misses() {
    let world = room(vec![WorldObject {
        name: "pole".to_owned(),
        kind: ObjectKind::Landmark {
            shape: Shape::Circle {
                centre: Vec2::new(6.0 - 2.0, 5.0 + 2.0 * 0.15),
                radius_m: 0.05,
            },
            height_m: 1.0,
            colour: Rgb::new(0, 0, 200),
        },
    }]);
    let robot = Pose2::new(2.0, 5.0, 0.0);
    let thin = one_transducer(1);
    let cone = one_transducer(7);
    let mount = thin.config().transducers[0];
    assert_near(
        thin.true_range(&world, robot, &mount),
        4.0,
        1e-9,
        "thin beam: the wall",
    );
    assert!(
        cone.true_range(&world, robot, &mount) < 2.1,
        "the cone sees the pole"
    );
}

fn drive(base: &mut SimBase, world: &World, translation: f64, rotation: f64, seconds: f64) {
    base.set_velocity(translation, rotation);
    // Steps of 20 ms, as a 50 Hz service would.
    let steps = (seconds * 50.0).round() as i64;
    for _ in 0..steps {
        base.step(world, NS_PER_S / 50);
    }
}

fn exact_base(start: Pose2) -> SimBase {
    let config = BaseConfig {
        odometry: OdometryNoise::NONE,
        ..BaseConfig::default()
    };
    SimBase::new(config, start, 0).unwrap()
}

#[test]
fn the_base_drives_a_straight_line_with_its_acceleration_limit() {
    let world = room(Vec::new());
    let mut base = exact_base(Pose2::new(1.0, 5.0, 0.0));
    drive(&mut base, &world, 0.5, 0.0, 4.0);
    // 0.6 m/s^2 reaches 0.5 m/s in 5/6 s, covering 5/24 m less than at full speed.
    let expected = 1.0 + 0.5 * 4.0 - 0.5 * 0.5 * (0.5 / 0.6);
    let pose = base.true_pose();
    assert_near(pose.x_m, expected, 1e-3, "x");
    assert_near(pose.y_m, 5.0, 1e-12, "y");
    assert_eq!(base.velocity(), (0.5, 0.0));
    let odometry = base.egomotion();
    assert_near(
        odometry.pose.x,
        expected - 1.0,
        1e-3,
        "odometry x (from its zero)",
    );
    assert_near(
        odometry.distance_travelled,
        expected - 1.0,
        1e-3,
        "distance",
    );
    assert_near(
        odometry.translation_velocity,
        0.5,
        1e-9,
        "measured velocity",
    );
    assert_eq!(base.collision_count(), 0);
}

#[test]
fn the_base_turns_in_place_and_drives_an_arc_to_the_expected_pose() {
    let world = room(Vec::new());
    let mut base = exact_base(Pose2::new(3.0, 5.0, 0.0));
    drive(&mut base, &world, 0.0, 1.0, 2.0);
    // 1.5 rad/s^2 reaches 1 rad/s in 2/3 s: 2 - 1/3 rad.
    assert_near(
        base.true_pose().heading_rad,
        2.0 - 1.0 / 3.0,
        1e-3,
        "heading",
    );
    assert_near(base.true_pose().x_m, 3.0, 1e-12, "in place");
    // Stop, then a half circle of radius 1 m at 0.5 m/s and 0.5 rad/s, starting east.
    drive(&mut base, &world, 0.0, 0.0, 2.0);
    base.teleport(Pose2::new(3.0, 3.0, 0.0));
    let mut base = SimBase::new(
        BaseConfig {
            // Instant acceleration for an exact arc.
            translation_acceleration_mps2: 1e9,
            rotation_acceleration_radps2: 1e9,
            odometry: OdometryNoise::NONE,
            ..BaseConfig::default()
        },
        Pose2::new(3.0, 3.0, 0.0),
        0,
    )
    .unwrap();
    drive(&mut base, &world, 0.5, 0.5, PI / 0.5);
    // 314 steps of 20 ms (6.28 s); the first 5 ms integration step ramps from rest
    // (trapezoid), losing half of it.
    let turned: f64 = 0.5 * (314.0 * 0.02 - 0.0025);
    let pose = base.true_pose();
    assert_near(pose.x_m, 3.0 + turned.sin(), 1e-9, "x after a half circle");
    assert_near(pose.y_m, 4.0 - turned.cos(), 1e-9, "y after a half circle");
    assert_near(
        pose.heading_rad,
        turned,
        1e-9,
        "heading after a half circle",
    );
}

#[test]
fn driving_into_a_wall_stops_the_base_presses_its_front_bumper_and_counts_one_collision() {
    let world = room(Vec::new());
    let mut base = exact_base(Pose2::new(4.0, 5.0, 0.0));
    drive(&mut base, &world, 0.5, 0.0, 8.0);
    let pose = base.true_pose();
    assert!(
        pose.x_m < 6.0 - 0.26 && pose.x_m > 6.0 - 0.26 - 0.02,
        "stopped at {pose:?}"
    );
    assert_eq!(
        base.collision_count(),
        1,
        "one contact, however long it lasts"
    );
    assert!(base.is_blocked());
    let sd: Synchrodrive = base.synchrodrive();
    assert_eq!(sd.bumper_count, 12);
    assert!(sd.bumpers[0], "front bumper: {:?}", sd.bumpers);
    assert_eq!(
        sd.bumpers.iter().filter(|b| **b).count(),
        1,
        "{:?}",
        sd.bumpers
    );
    assert_eq!(sd.translation_velocity, 0.0);
    // Back off, then hit it again: a second collision.
    drive(&mut base, &world, -0.3, 0.0, 2.0);
    assert!(!base.synchrodrive().bumpers.iter().any(|b| *b));
    drive(&mut base, &world, 0.5, 0.0, 4.0);
    assert_eq!(base.collision_count(), 2);
}

#[test]
fn the_base_passes_under_signs_but_not_through_people() {
    let world = World::load(&repository_path("robots/worlds/conference")).unwrap();
    // Walk the queue's line towards queue-5 at (19.2, 21.0).
    let mut base = exact_base(Pose2::new(21.0, 21.0, PI));
    drive(&mut base, &world, 0.5, 0.0, 6.0);
    assert_eq!(base.collision_count(), 1);
    assert_near(
        base.true_pose().x_m,
        19.2 + 0.22 + 0.26,
        0.02,
        "stopped at the person",
    );
    // The wall sign at the corridor's end hangs at 1.4 m; the base is 1.2 m high: its
    // footprint overlaps the robot's only when the robot touches the wall itself.
    let sign_only = world.circle_collides(Vec2::new(29.98 - 0.27, 12.75), 0.26, 1.2);
    assert!(!sign_only);
}

#[test]
fn the_brake_stops_the_base_at_once() {
    let world = room(Vec::new());
    let mut base = exact_base(Pose2::new(1.0, 5.0, 0.0));
    drive(&mut base, &world, 0.5, 0.0, 2.0);
    base.set_brake(true);
    let before = base.true_pose();
    drive(&mut base, &world, 0.5, 0.0, 1.0);
    assert_eq!(base.true_pose(), before);
    assert!(base.synchrodrive().brake_on);
}

#[test]
fn odometry_drifts_from_the_truth_as_the_robot_moves() {
    let world = room(Vec::new());
    let mut base = SimBase::new(BaseConfig::default(), Pose2::new(1.0, 2.0, 0.0), 11).unwrap();
    base.reset_odometry(Pose2::new(1.0, 2.0, 0.0));
    drive(&mut base, &world, 0.6, 0.0, 8.0);
    drive(&mut base, &world, 0.3, 0.4, 6.0);
    let truth = base.true_pose();
    let odometry = base.odometry_pose();
    let error = (truth.position() - odometry.position()).norm();
    assert!(error > 1e-4, "odometry without drift: {error}");
    assert!(error < 0.5, "odometry drifted {error} m in about 6 m");
}

#[test]
fn the_battery_drains_with_time_and_motion() {
    let world = room(Vec::new());
    let mut base = exact_base(Pose2::new(1.0, 5.0, 0.0));
    let full: Power = base.power();
    assert_near(full.charge_fraction, 1.0, 0.0, "full");
    assert_near(full.voltage, 26.4, 0.1, "full voltage");
    drive(&mut base, &world, 0.0, 0.0, 600.0);
    // 90 W for 10 minutes out of 800 Wh.
    assert_near(
        base.charge_fraction(),
        1.0 - 90.0 * 600.0 / (800.0 * 3600.0),
        1e-9,
        "idle",
    );
    let idle = base.charge_fraction();
    drive(&mut base, &world, 0.0, 1.0, 60.0);
    assert!(
        1.0 - base.charge_fraction() > (1.0 - idle) * 1.1,
        "turning drains more"
    );
    assert!(!base.power().low);
}

#[test]
fn distance_from_the_laser_gives_the_nearest_obstacle_per_sector() {
    let world = room(Vec::new());
    let mut laser = noiseless_laser();
    let scan = laser.scan(&world, Pose2::new(5.0, 5.0, 0.0));
    let distance = laser.distance(&scan, 9);
    assert_eq!(distance.sector_count, 9);
    // The wall ahead is 1.0 m from the robot's centre.
    assert_near(distance.sector_distances[4], 1.0, 1e-9, "ahead");
    assert_near(distance.min_distance, 1.0, 1e-9, "nearest");
    assert_near(distance.min_bearing, 0.0, 1e-9, "nearest bearing");
    assert_near(
        distance.first_sector_angle,
        -FRAC_PI_2 + PI / 18.0,
        1e-12,
        "first sector",
    );
    let sonar_scan = SimSonar::new(SonarConfig::default(), 0)
        .unwrap()
        .scan(&world, Pose2::new(5.0, 5.0, 0.0));
    let around = SimSonar::distance(&sonar_scan, 8);
    assert_eq!(around.sector_distances.len(), 8);
    assert_near(around.sector_distances[4], 1.0, 0.1, "sonar ahead");
}

/// Everything one run of the devices publishes.
#[derive(Debug, PartialEq)]
struct Run {
    scans: Vec<RangeFinder>,
    sonar: Vec<RangeFinder>,
    egomotion: Vec<Egomotion>,
    power: Vec<Power>,
    drive: Vec<Synchrodrive>,
    images: Vec<Vec<u8>>,
}

fn run(seed: u64) -> Run {
    let world = World::load(&repository_path("robots/worlds/conference")).unwrap();
    let start = Pose2::new(3.0, 12.5, 0.0);
    let mut base = SimBase::new(BaseConfig::default(), start, seed).unwrap();
    let mut laser = SimLaser::new(LaserConfig::default(), seed).unwrap();
    let mut sonar = SimSonar::new(SonarConfig::default(), seed).unwrap();
    let mut camera = lewis_sim::SimCamera::new(
        lewis_sim::CameraConfig {
            width_px: 64,
            height_px: 48,
            ..lewis_sim::CameraConfig::default()
        },
        seed,
    )
    .unwrap();
    let mut out = Run {
        scans: Vec::new(),
        sonar: Vec::new(),
        egomotion: Vec::new(),
        power: Vec::new(),
        drive: Vec::new(),
        images: Vec::new(),
    };
    let commands = [(0.6, 0.0), (0.6, 0.1), (0.4, -0.2), (0.0, 0.8), (0.7, 0.0)];
    for (i, &(v, w)) in commands.iter().cycle().take(40).enumerate() {
        base.set_velocity(v, w);
        base.step(&world, NS_PER_S / 10);
        let pose = base.true_pose();
        out.scans.push(laser.scan(&world, pose));
        out.sonar.push(sonar.scan(&world, pose));
        out.egomotion.push(base.egomotion());
        out.power.push(base.power());
        out.drive.push(base.synchrodrive());
        if i % 10 == 0 {
            out.images.push(camera.render(&world, pose).data);
        }
    }
    out
}

/// Bit patterns, so that the comparison is exact even for -0.0 and NaN.
fn bits(scans: &[RangeFinder]) -> Vec<u64> {
    scans
        .iter()
        .flat_map(|s| s.ranges.iter().map(|r| r.to_bits()))
        .collect()
}

#[test]
fn the_same_seed_and_commands_give_the_same_outputs_bit_for_bit() {
    let a = run(42);
    let b = run(42);
    assert_eq!(bits(&a.scans), bits(&b.scans));
    assert_eq!(bits(&a.sonar), bits(&b.sonar));
    assert_eq!(a, b);
    let c = run(43);
    assert_ne!(bits(&a.scans), bits(&c.scans));
    assert_ne!(a.egomotion, c.egomotion);
}

#[test]
fn bad_device_parameters_are_refused_with_their_name() {
    let err = SimLaser::new(
        LaserConfig {
            beam_count: 1,
            ..LaserConfig::default()
        },
        0,
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "laser parameter `beam_count` is 1: at least 2 (SICK: 181 or 361)"
    );
    let err = SimBase::new(
        BaseConfig {
            radius_m: -0.26,
            ..BaseConfig::default()
        },
        Pose2::default(),
        0,
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "base parameter `radius_m` is -0.26: a positive number"
    );
    let err = SimSonar::new(
        SonarConfig {
            transducers: Vec::new(),
            ..SonarConfig::default()
        },
        0,
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "sonar parameter `transducers` is 0: at least one transducer"
    );
}
