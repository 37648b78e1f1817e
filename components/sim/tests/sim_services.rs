//! The simulated devices as services (`sim-base`, `sim-laser`, `sim-sonar`, `sim-camera`),
//! driven through the `Service` trait on a test clock, in the conference world: what they
//! publish, what they answer, that they are deterministic, and how they refuse bad
//! parameters.

#![allow(clippy::unwrap_used)]

use lewis_interfaces::msg::{
    CameraControl, CameraControlSetZoom, Distance, DistanceSetSectorCount, Egomotion,
    EgomotionResetOdometry, GroundTruth, ImageSource, ImageSourceSetRate, InputRef, Pose2D, Power,
    PowerSetLowThreshold, RangeFinder, RangeFinderGetGeometry, Synchrodrive,
    SynchrodriveSetVelocity,
};
use lewis_runtime::names::data_channel;
use lewis_service::{Level, ServiceRegistry};
use lewis_sim::World;
use lewis_testkit::{Harness, Publication, decoded, repository_path, robot};

const MS: i64 = 1_000_000;
const S: i64 = 1_000_000_000;

fn registry() -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    lewis_sim::service::register(&mut registry);
    registry
}

fn world_dir() -> String {
    repository_path("robots/worlds/conference")
        .to_string_lossy()
        .into_owned()
}

/// A robot file with one service `name` of `kind` providing `provides`, requiring
/// GroundTruth unless it is the base, with `parameters` (TOML lines) and the world.
fn robot_text(name: &str, kind: &str, provides: &[&str], parameters: &str) -> String {
    let provides = provides
        .iter()
        .map(|i| format!("{{ interface = \"{i}\", quality = 5, cost = 1 }}"))
        .collect::<Vec<_>>()
        .join(", ");
    let world = world_dir();
    let mut text = format!(
        "[robot]\nname = \"t\"\n\n[[services]]\nname = \"{name}\"\nkind = \"{kind}\"\n\
         provides = [{provides}]\n"
    );
    if kind == "sim-base" {
        text += &format!("\n[services.parameters]\nworld = {world:?}\n{parameters}\n");
    } else {
        // The provider of the GroundTruth it requires.
        text += &format!(
            "requires = [\"GroundTruth\"]\n\n[services.parameters]\nworld = {world:?}\n{parameters}\n\n\
             [[services]]\nname = \"truth\"\nkind = \"sim-base\"\n\
             provides = [{{ interface = \"GroundTruth\", quality = 5, cost = 1 }}]\n\n\
             [services.parameters]\nworld = {world:?}\nstart = {{ x_m = 3.0, y_m = 12.5 }}\n"
        );
    }
    text
}

fn build(name: &str, kind: &str, provides: &[&str], parameters: &str) -> Harness {
    let robot = robot(&robot_text(name, kind, provides, parameters));
    Harness::build(&robot, name, &registry())
        .unwrap_or_else(|e| panic!("{name} does not build: {e}"))
}

fn build_error(kind: &str, parameters: &str) -> String {
    let provides = if kind == "sim-base" {
        "GroundTruth"
    } else {
        "Distance"
    };
    let robot = robot(&robot_text("dev", kind, &[provides], parameters));
    match Harness::build(&robot, "dev", &registry()) {
        Ok(_) => panic!("{kind} built with parameters {parameters:?}"),
        Err(e) => e.to_string(),
    }
}

fn base(start: &str, extra: &str) -> Harness {
    build(
        "base",
        "sim-base",
        &["GroundTruth", "Synchrodrive", "Egomotion", "Power"],
        &format!("start = {start}\nseed = 7\n{extra}"),
    )
}

fn laser(extra: &str) -> Harness {
    build("laser", "sim-laser", &["RangeFinder", "Distance"], extra)
}

fn sonar(extra: &str) -> Harness {
    build("sonar", "sim-sonar", &["RangeFinder", "Distance"], extra)
}

fn camera(extra: &str) -> Harness {
    build(
        "camera",
        "sim-camera",
        &["ImageSource", "CameraControl"],
        extra,
    )
}

/// A GroundTruth sample as the base would publish it, with sequence number `seq`.
fn truth_sample(x_m: f64, y_m: f64, heading_deg: f64, seq: u64) -> Publication {
    let mut truth = GroundTruth {
        pose: Pose2D {
            x: x_m,
            y: y_m,
            theta: heading_deg.to_radians(),
        },
        ..GroundTruth::default()
    };
    truth.header.provider = "base".into();
    truth.header.seq = seq;
    Publication {
        interface: "GroundTruth".into(),
        bytes: lewis_interfaces::cdr::to_vec(&truth),
    }
}

fn truth_channel() -> String {
    data_channel("base", "GroundTruth")
}

fn assert_near(got: f64, expected: f64, tolerance: f64, what: &str) {
    assert!(
        (got - expected).abs() <= tolerance,
        "{what}: got {got}, expected {expected} +- {tolerance}"
    );
}

// ---------------------------------------------------------------------------------------
// sim-base

/// Runs the base for `duration_ns` from `from_ns`, ticking at its rate; returns the time
/// reached.
fn run_base(base: &mut Harness, from_ns: i64, duration_ns: i64) -> i64 {
    let period = base.tick_period_ns().unwrap();
    let mut t = from_ns;
    while t < from_ns + duration_ns {
        t += period;
        base.tick(t);
    }
    t
}

#[test]
fn the_base_publishes_its_true_pose_odometry_and_state_at_its_rate() {
    let mut base = base(
        "{ x_m = 4.0, y_m = 10.0, heading_deg = 30.0 }",
        "rate_hz = 50.0",
    );
    assert_eq!(base.tick_period_ns(), Some(20 * MS));
    base.start(0).unwrap();
    // The sensors get a true pose before the first tick.
    let first = decoded::<GroundTruth>(&base.take_published());
    assert_eq!(first.len(), 1);
    assert_near(first[0].pose.x, 4.0, 1e-12, "start x");
    assert_near(
        first[0].pose.theta,
        30f64.to_radians(),
        1e-12,
        "start heading",
    );
    run_base(&mut base, 0, S);
    let published = base.take_published();
    assert_eq!(decoded::<GroundTruth>(&published).len(), 50);
    assert_eq!(decoded::<Egomotion>(&published).len(), 50);
    assert_eq!(decoded::<Synchrodrive>(&published).len(), 50);
    // Power at its own rate (1 Hz): due at the start, then a second later.
    assert_eq!(decoded::<Power>(&published).len(), 1);
    let drive = decoded::<Synchrodrive>(&published).pop().unwrap();
    assert_eq!(drive.bumper_count, 12);
    assert_eq!(drive.bumpers, vec![false; 12]);
}

#[test]
fn set_velocity_drives_the_true_pose_and_the_odometry_follows_with_drift() {
    let mut base = base("{ x_m = 3.0, y_m = 12.5, heading_deg = 0.0 }", "");
    base.start(0).unwrap();
    base.command(
        0,
        &SynchrodriveSetVelocity {
            translation_velocity: 0.5,
            rotation_velocity: 0.0,
            ..SynchrodriveSetVelocity::default()
        },
    )
    .unwrap();
    run_base(&mut base, 0, 4 * S);
    let published = base.take_published();
    let truth = decoded::<GroundTruth>(&published).pop().unwrap();
    // 0.6 m/s^2 to 0.5 m/s takes 0.833 s (0.208 m), then 3.167 s at 0.5 m/s.
    assert_near(
        truth.pose.x,
        3.0 + 0.5 * 0.5 / 0.6 / 2.0 + 0.5 * (4.0 - 0.5 / 0.6),
        0.02,
        "x",
    );
    assert_near(truth.pose.y, 12.5, 1e-9, "y");
    assert_near(truth.translation_velocity, 0.5, 1e-9, "velocity");
    assert_eq!((truth.collisions, truth.bumped), (0, false));
    let odometry = decoded::<Egomotion>(&published).pop().unwrap();
    // The odometry starts at zero and drifts, but not far over 1.8 m.
    assert_near(odometry.pose.x, truth.pose.x - 3.0, 0.15, "odometry x");
    assert!(
        odometry.pose.x != truth.pose.x - 3.0,
        "the odometry has no noise: {odometry:?}"
    );
    let drive = decoded::<Synchrodrive>(&published).pop().unwrap();
    assert_eq!(drive.commanded_translation_velocity, 0.5);

    base.command(
        4 * S,
        &EgomotionResetOdometry {
            pose: Pose2D {
                x: 10.0,
                y: 0.0,
                theta: 0.0,
            },
            ..EgomotionResetOdometry::default()
        },
    )
    .unwrap();
    base.tick(4 * S + 20 * MS);
    let odometry = decoded::<Egomotion>(&base.take_published()).pop().unwrap();
    assert_near(odometry.pose.x, 10.01, 0.01, "odometry after the reset");
}

#[test]
fn the_base_reports_a_collision_when_driven_into_a_wall() {
    // The lobby's east wall is at x = 7.9 (south of the entrance door); the body's radius is
    // 0.26 m.
    let mut base = base("{ x_m = 4.0, y_m = 10.0, heading_deg = 0.0 }", "");
    base.start(0).unwrap();
    base.command(
        0,
        &SynchrodriveSetVelocity {
            translation_velocity: 0.8,
            ..SynchrodriveSetVelocity::default()
        },
    )
    .unwrap();
    let mut t = 0;
    let mut first_contact = None;
    while t < 10 * S {
        t = run_base(&mut base, t, 100 * MS);
        let truth = decoded::<GroundTruth>(&base.take_published())
            .pop()
            .unwrap();
        if truth.collisions > 0 && first_contact.is_none() {
            first_contact = Some(truth);
        }
    }
    let contact = first_contact.expect("the base never hit the wall");
    assert_eq!(contact.collisions, 1);
    assert!(contact.bumped);
    assert_near(contact.pose.x, 7.9 - 0.26, 0.02, "x against the wall");
    // Pushing on against the same wall counts no second collision.
    base.tick(t + 20 * MS);
    let published = base.take_published();
    let truth = decoded::<GroundTruth>(&published).pop().unwrap();
    assert_eq!((truth.collisions, truth.bumped), (1, true));
    assert_eq!(truth.translation_velocity, 0.0);
    let drive = decoded::<Synchrodrive>(&published).pop().unwrap();
    assert!(
        drive.bumpers[0],
        "the front bumper is not pressed: {:?}",
        drive.bumpers
    );
    let warnings: Vec<_> = base
        .backend
        .logs
        .iter()
        .filter(|(level, text)| *level == Level::Warn && text.contains("collision 1"))
        .collect();
    assert_eq!(warnings.len(), 1, "{:?}", base.backend.logs);
}

#[test]
fn the_battery_drains_and_the_low_threshold_is_a_command() {
    let mut base = base(
        "{ x_m = 3.0, y_m = 12.5 }",
        "battery = { capacity_wh = 1.0, initial_charge_fraction = 0.5 }",
    );
    base.start(0).unwrap();
    let start = decoded::<Power>(&base.take_published()).pop().unwrap();
    assert_near(start.charge_fraction, 0.5, 1e-12, "charge at the start");
    assert!(!start.low);
    run_base(&mut base, 0, 2 * S);
    let later = decoded::<Power>(&base.take_published()).pop().unwrap();
    // 90 W idle from 1 Wh for 2 s (Power is due every second).
    assert_near(
        later.charge_fraction,
        0.5 - 2.0 * 90.0 / 3600.0,
        1e-3,
        "charge after 2 s",
    );
    base.command(
        2 * S,
        &PowerSetLowThreshold {
            charge_fraction: 0.9,
            ..PowerSetLowThreshold::default()
        },
    )
    .unwrap();
    run_base(&mut base, 2 * S, S);
    assert!(decoded::<Power>(&base.take_published()).pop().unwrap().low);
    let refused = base.command(
        3 * S,
        &PowerSetLowThreshold {
            charge_fraction: 1.5,
            ..PowerSetLowThreshold::default()
        },
    );
    assert!(refused.unwrap_err().0.contains("between 0 and 1"));
}

// ---------------------------------------------------------------------------------------
// sim-laser

#[test]
fn the_laser_sees_the_wall_distances_the_world_predicts() {
    // In the lobby (free x 0.5..7.9, y 7.5..17.5) at (4, 10) facing east: the laser sits
    // 0.12 m ahead of the centre, at (4.12, 10).
    let mut laser = laser("range_noise_std_m = 0.0\nbeam_count = 361");
    assert_eq!(laser.tick_period_ns(), Some(26_666_667));
    laser.start(0).unwrap();
    // Nothing to render before the first true pose.
    laser.tick(30 * MS);
    assert!(laser.take_published().is_empty());
    laser.input(
        40 * MS,
        "base",
        &truth_channel(),
        &truth_sample(4.0, 10.0, 0.0, 17),
    );
    laser.tick(60 * MS);
    let published = laser.take_published();
    let scan = decoded::<RangeFinder>(&published).pop().unwrap();
    assert_eq!((scan.range_count, scan.ranges.len()), (361, 361));
    assert!(scan.uniform);
    assert_near(scan.theta_offset, -90f64.to_radians(), 1e-12, "first beam");
    assert_near(
        scan.theta_separation,
        0.5f64.to_radians(),
        1e-12,
        "separation",
    );
    let beam = |deg: f64| {
        let i = ((deg + 90.0) * 2.0).round() as usize;
        scan.ranges[i]
    };
    assert_near(beam(-90.0), 10.0 - 7.5, 0.01, "south wall");
    assert_near(beam(0.0), 7.9 - 4.12, 0.01, "east wall");
    assert_near(beam(90.0), 17.5 - 10.0, 0.01, "north wall");
    // 45 degrees left meets the east wall above the entrance door (y 11.75..13.25).
    assert_near(
        beam(45.0),
        (7.9 - 4.12) * 2f64.sqrt(),
        0.01,
        "east wall, diagonal",
    );
    // Every beam agrees with the world's own ray cast.
    let world = World::load(&repository_path("robots/worlds/conference")).unwrap();
    for (i, &range) in scan.ranges.iter().enumerate() {
        let bearing = scan.theta_offset + scan.theta_separation * i as f64;
        let dir = lewis_geometry::Vec2::from_angle(bearing);
        let expected = world
            .cast_ray(lewis_geometry::Vec2::new(4.12, 10.0), dir, 8.191, 0.38)
            .map_or(8.191, |h| h.range_m);
        assert_near(range, expected, 1e-9, &format!("beam {i}"));
    }
    // The rendering names the GroundTruth sample it came from.
    let expected_inputs = vec![InputRef {
        channel: truth_channel(),
        seq: 17,
    }];
    assert_eq!(scan.header.inputs, expected_inputs);
    let distance = decoded::<Distance>(&published).pop().unwrap();
    assert_eq!(distance.header.inputs, expected_inputs);
    assert_eq!(distance.sector_count, 36);
    // The nearest point the laser sees is straight right of it: (4.12, 7.5), seen from the
    // robot's centre.
    assert_near(
        distance.min_distance,
        0.12f64.hypot(2.5),
        0.01,
        "nearest obstacle",
    );
    assert_near(
        distance.min_bearing,
        (-2.5f64).atan2(0.12),
        0.01,
        "its bearing",
    );
}

#[test]
fn the_laser_answers_get_geometry_and_set_sector_count() {
    let mut laser = laser("beam_count = 181\nrate_hz = 75.0");
    laser.start(0).unwrap();
    let geometry = laser
        .command(0, &RangeFinderGetGeometry::default())
        .unwrap();
    assert_eq!(
        (geometry.range_count, geometry.max_range, geometry.rate),
        (181, 8.191, 75.0)
    );
    let reply = laser
        .command(
            0,
            &DistanceSetSectorCount {
                sector_count: 9,
                ..DistanceSetSectorCount::default()
            },
        )
        .unwrap();
    assert_eq!(reply.sector_count, 9);
    laser.input(
        1,
        "base",
        &truth_channel(),
        &truth_sample(4.0, 10.0, 0.0, 1),
    );
    laser.tick(20 * MS);
    let distance = decoded::<Distance>(&laser.take_published()).pop().unwrap();
    assert_eq!(distance.sector_distances.len(), 9);
    let refused = laser.command(
        0,
        &DistanceSetSectorCount {
            sector_count: 0,
            ..DistanceSetSectorCount::default()
        },
    );
    assert!(refused.unwrap_err().0.contains("expected 1 to 360"));
}

// ---------------------------------------------------------------------------------------
// sim-sonar

#[test]
fn the_sonar_is_a_non_uniform_ring_of_48_with_distance_all_around() {
    let mut sonar = sonar("");
    assert_eq!(sonar.tick_period_ns(), Some(100 * MS));
    sonar.start(0).unwrap();
    sonar.input(
        0,
        "base",
        &truth_channel(),
        &truth_sample(4.0, 10.0, 0.0, 3),
    );
    sonar.tick(100 * MS);
    let published = sonar.take_published();
    let scan = decoded::<RangeFinder>(&published).pop().unwrap();
    assert!(!scan.uniform);
    assert_eq!((scan.range_count, scan.sensor_positions.len()), (48, 48));
    // Transducer 18 of the upper ring faces right (270 degrees): the south wall 2.5 m from
    // the centre, 2.24 m from the transducer on the body's edge.
    assert_near(
        scan.sensor_positions[18].theta,
        270f64.to_radians(),
        1e-9,
        "heading",
    );
    assert_near(scan.ranges[18], 2.5 - 0.26, 0.1, "south wall");
    let distance = decoded::<Distance>(&published).pop().unwrap();
    assert_eq!(distance.sector_count, 24);
    assert_near(distance.min_distance, 2.5, 0.1, "nearest obstacle");
    assert_eq!(
        distance.header.inputs,
        vec![InputRef {
            channel: truth_channel(),
            seq: 3
        }]
    );
    let geometry = sonar
        .command(0, &RangeFinderGetGeometry::default())
        .unwrap();
    assert_eq!((geometry.range_count, geometry.rate), (48, 10.0));
}

#[test]
fn a_sensor_falls_silent_when_the_pose_goes_stale_and_renders_again_when_it_comes() {
    // The base (the simulator) failed: the last pose is of a world that no longer runs.
    let mut sonar = sonar("");
    sonar.start(0).unwrap();
    let pose_at = |sonar: &mut Harness, at: i64, seq: u64| {
        sonar.input(
            at,
            "base",
            &truth_channel(),
            &truth_sample(4.0, 10.0, 0.0, seq),
        );
    };
    pose_at(&mut sonar, 0, 1);
    let scans_between = |sonar: &mut Harness, from: i64, to: i64| {
        for k in from..=to {
            sonar.tick(k * 100 * MS);
        }
        decoded::<RangeFinder>(&sonar.take_published()).len()
    };
    assert_eq!(
        scans_between(&mut sonar, 1, 5),
        5,
        "a pose at most 500 ms old"
    );
    assert_eq!(
        scans_between(&mut sonar, 6, 20),
        0,
        "a pose older than 500 ms"
    );
    pose_at(&mut sonar, 2050 * MS, 2);
    assert_eq!(scans_between(&mut sonar, 21, 25), 5, "a new pose");
}

#[test]
fn the_sonar_specular_limit_is_a_parameter() {
    // Facing the east wall at 50 degrees of incidence: a 30-degree limit hears nothing from
    // the forward transducer, the 60-degree default hears the wall.
    let reading = |limit: &str| {
        let mut sonar = sonar(&format!(
            "{limit}\nrange_noise_std_m = 0.0\nrange_noise_fraction = 0.0\ncone_half_angle_deg = 0.0\nrays_per_cone = 1"
        ));
        sonar.start(0).unwrap();
        sonar.input(
            0,
            "base",
            &truth_channel(),
            &truth_sample(6.0, 9.0, 50.0, 1),
        );
        sonar.tick(100 * MS);
        decoded::<RangeFinder>(&sonar.take_published())
            .pop()
            .unwrap()
            .ranges[0]
    };
    assert_eq!(reading("specular_incidence_deg = 30.0"), 5.0);
    assert!(reading("") < 5.0);
}

// ---------------------------------------------------------------------------------------
// sim-camera

#[test]
fn the_camera_renders_640_by_480_and_zooms_on_command() {
    let mut camera = camera("rate_hz = 10.0");
    assert_eq!(camera.tick_period_ns(), Some(100 * MS));
    camera.start(0).unwrap();
    camera.input(
        0,
        "base",
        &truth_channel(),
        &truth_sample(3.0, 12.5, 0.0, 5),
    );
    camera.tick(100 * MS);
    let published = camera.take_published();
    let control = decoded::<CameraControl>(&published).pop().unwrap();
    assert_eq!(control.zoom, 1.0);
    let image = decoded::<ImageSource>(&published).pop().unwrap();
    assert_eq!((image.width, image.height, image.step), (640, 480, 1920));
    assert_eq!(
        (image.encoding.as_str(), image.data.len()),
        ("rgb8", 640 * 480 * 3)
    );
    assert_eq!(
        image.header.inputs,
        vec![InputRef {
            channel: truth_channel(),
            seq: 5
        }]
    );
    let wide_focal = image.focal_length_x;

    let reply = camera
        .command(
            150 * MS,
            &CameraControlSetZoom {
                zoom: 40.0,
                ..CameraControlSetZoom::default()
            },
        )
        .unwrap();
    assert_eq!(reply.zoom, 12.0, "the zoom is clamped to max_zoom");
    camera.tick(200 * MS);
    let published = camera.take_published();
    assert_eq!(
        decoded::<CameraControl>(&published).pop().unwrap().zoom,
        12.0
    );
    let zoomed = decoded::<ImageSource>(&published).pop().unwrap();
    assert_near(
        zoomed.focal_length_x,
        wide_focal * 12.0,
        1e-6,
        "focal length",
    );
    assert_ne!(zoomed.data, image.data);
}

#[test]
fn the_camera_drops_frames_to_the_rate_asked_and_never_exceeds_its_own() {
    let mut camera = camera("rate_hz = 10.0\nwidth_px = 32\nheight_px = 24");
    camera.start(0).unwrap();
    camera.input(
        0,
        "base",
        &truth_channel(),
        &truth_sample(3.0, 12.5, 0.0, 1),
    );
    let reply = camera
        .command(
            0,
            &ImageSourceSetRate {
                rate: 2.5,
                ..ImageSourceSetRate::default()
            },
        )
        .unwrap();
    assert_eq!(reply.rate, 2.5);
    for k in 1..=20 {
        // A live clock's jitter: ticks a little early or late; the base's pose kept fresh.
        let at = k * 100 * MS + if k % 2 == 0 { 3 * MS } else { -3 * MS };
        camera.input(
            at,
            "base",
            &truth_channel(),
            &truth_sample(3.0, 12.5, 0.0, 1 + u64::try_from(k).unwrap()),
        );
        camera.tick(at);
    }
    assert_eq!(decoded::<ImageSource>(&camera.take_published()).len(), 5);
    let reply = camera
        .command(
            2 * S,
            &ImageSourceSetRate {
                rate: 100.0,
                ..ImageSourceSetRate::default()
            },
        )
        .unwrap();
    assert_eq!(reply.rate, 10.0);
}

// ---------------------------------------------------------------------------------------
// Determinism

/// A short drive with every device: the base takes commands, the sensors render from its
/// GroundTruth samples as they arrive, each at its own rate. Returns every publication of
/// every service, in order.
fn drive_all(seed: u64) -> Vec<(String, Publication)> {
    let seeded = |extra: &str| format!("seed = {seed}\n{extra}");
    let mut base = build(
        "base",
        "sim-base",
        &["GroundTruth", "Synchrodrive", "Egomotion", "Power"],
        &seeded("start = { x_m = 3.0, y_m = 12.5 }"),
    );
    let mut sensors = [
        build(
            "laser",
            "sim-laser",
            &["RangeFinder", "Distance"],
            &seeded(""),
        ),
        build(
            "sonar",
            "sim-sonar",
            &["RangeFinder", "Distance"],
            &seeded(""),
        ),
        build(
            "camera",
            "sim-camera",
            &["ImageSource", "CameraControl"],
            &seeded("width_px = 64\nheight_px = 48\nrate_hz = 5.0"),
        ),
    ];
    let mut out = Vec::new();
    base.start(0).unwrap();
    for sensor in &mut sensors {
        sensor.start(0).unwrap();
    }
    let mut next_tick = [0i64; 3];
    let base_period = base.tick_period_ns().unwrap();
    let mut t = 0;
    let mut pending = base.take_published();
    while t < 3 * S {
        for p in pending.drain(..) {
            if p.interface == "GroundTruth" {
                for sensor in &mut sensors {
                    sensor.input(t, "base", &truth_channel(), &p);
                }
            }
            out.push(("base".to_owned(), p));
        }
        if t == 200 * MS {
            base.command(
                t,
                &SynchrodriveSetVelocity {
                    translation_velocity: 0.7,
                    rotation_velocity: 0.3,
                    ..SynchrodriveSetVelocity::default()
                },
            )
            .unwrap();
        }
        t += MS;
        for (sensor, next) in sensors.iter_mut().zip(&mut next_tick) {
            if t >= *next {
                sensor.tick(t);
                *next = t + sensor.tick_period_ns().unwrap();
                let name = sensor.name().to_owned();
                out.extend(
                    sensor
                        .take_published()
                        .into_iter()
                        .map(|p| (name.clone(), p)),
                );
            }
        }
        if t % base_period == 0 {
            base.tick(t);
            pending = base.take_published();
        }
    }
    out.extend(pending.into_iter().map(|p| ("base".to_owned(), p)));
    out
}

#[test]
fn the_same_seed_and_commands_give_identical_bytes_and_another_seed_does_not() {
    let first = drive_all(11);
    let count = |service: &str, interface: &str| {
        first
            .iter()
            .filter(|(s, p)| s == service && p.interface == interface)
            .count()
    };
    // 3 s of each device at its rate.
    assert_eq!(count("base", "GroundTruth"), 151);
    assert!((111..=113).contains(&count("laser", "RangeFinder")));
    assert_eq!(count("sonar", "RangeFinder"), 30);
    assert_eq!(count("camera", "ImageSource"), 15);
    assert!(first == drive_all(11), "a second run with seed 11 differs");
    let other = drive_all(12);
    assert_eq!(other.len(), first.len());
    for service in ["base", "laser", "sonar", "camera"] {
        let of = |run: &[(String, Publication)]| {
            run.iter()
                .filter(|(s, _)| s == service)
                .map(|(_, p)| p.clone())
                .collect::<Vec<_>>()
        };
        assert!(
            of(&first) != of(&other),
            "{service}: seed 12 gives the same bytes as 11"
        );
    }
}

// ---------------------------------------------------------------------------------------
// Bad parameters and worlds

#[test]
fn bad_parameters_and_worlds_give_errors_naming_the_service() {
    fn check(kind: &str, parameters: &str, expected: &[&str]) {
        let error = build_error(kind, parameters);
        assert!(
            error.starts_with("parameters of service `dev`: "),
            "{kind} {parameters:?}: {error}"
        );
        for part in expected {
            assert!(
                error.contains(part),
                "{kind} {parameters:?}: `{error}` does not say `{part}`"
            );
        }
    }
    check("sim-laser", "beams = 181", &["unknown field `beams`"]);
    check("sim-laser", "beam_count = 1", &["beam_count", "at least 2"]);
    check(
        "sim-laser",
        "rate_hz = 0.0",
        &["rate_hz", "between 0.01 and 1000"],
    );
    check(
        "sim-laser",
        "distance_sectors = 0",
        &["distance_sectors", "1 to 360"],
    );
    check(
        "sim-sonar",
        "specular_incidence_deg = 120.0",
        &["specular_incidence_deg", "0 to 90"],
    );
    check("sim-sonar", "rays_per_cone = 0", &["rays_per_cone"]);
    check("sim-camera", "width_px = 0", &["width_px"]);
    check("sim-camera", "max_zoom = 0.5", &["max_zoom"]);
    check("sim-base", "", &["missing field `start`"]);
    check(
        "sim-base",
        "start = { x_m = 0.1, y_m = 0.1 }",
        &[
            "`start` (0.1, 0.1) puts the robot inside a wall",
            "conference",
        ],
    );
    check(
        "sim-base",
        "start = { x_m = 3.0, y_m = 12.5, heading = 1.0 }",
        &["unknown field `heading`"],
    );
    check(
        "sim-base",
        "start = { x_m = 3.0, y_m = 12.5 }\nlimits = { max_translation_velocity_mps = -1.0 }",
        &["max_translation_velocity_mps", "positive"],
    );
}

#[test]
fn a_missing_or_broken_world_is_an_error_naming_the_service_and_the_folder() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nowhere");
    let broken = dir.path().join("broken");
    std::fs::create_dir(&broken).unwrap();
    std::fs::write(
        broken.join("world.toml"),
        "map = \"map.png\"\nmetres_per_pixel = 0.05\nsize_m = [1.0, 1.0]\norigin_m = [0.0, 0.0]\n",
    )
    .unwrap();
    for (dir, says) in [(&missing, "cannot read world file"), (&broken, "map.png")] {
        let text = robot_text("laser", "sim-laser", &["RangeFinder"], "").replace(
            &format!("{:?}", world_dir()),
            &format!("{:?}", dir.to_string_lossy()),
        );
        let robot = robot(&text);
        let error = match Harness::build(&robot, "laser", &registry()) {
            Ok(_) => panic!("a laser built in {}", dir.display()),
            Err(e) => e.to_string(),
        };
        assert!(
            error.starts_with("parameters of service `laser`: world `"),
            "{error}"
        );
        assert!(error.contains(&dir.display().to_string()), "{error}");
        assert!(error.contains(says), "{error}");
    }
}
