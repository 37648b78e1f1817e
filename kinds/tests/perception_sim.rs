//! Perception on frames rendered by the simulator's camera model: the sign detector reads
//! every arrow at several distances and angles, and in the conference world; the blob
//! finder finds the guide's red cap, and blobfinder3d places it where the simulator has it.
//! All services run through the `Service` trait.
//!
//! Set LEWIS_PERCEPTION_FRAMES_DIR to a folder to also save the rendered frames as PNG.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::support;

use std::f64::consts::PI;
use std::path::Path;

use lewis_geometry::{Pose2, Vec2};
use lewis_interfaces::msg::{Blobs, Blobs3D, ImageSource, Signs};
use lewis_sim::world::{ArrowDirection, ObjectKind, OccupancyGrid, Rgb, Sign, WorldObject};
use lewis_sim::{CameraConfig, LaserConfig, SimCamera, SimLaser, World, WorldLook};
use lewis_testkit::{Harness, repository_path as repository};
use support::{build, robot};

fn save(frame: &ImageSource, name: &str) {
    let Some(dir) = std::env::var_os("LEWIS_PERCEPTION_FRAMES_DIR") else {
        return;
    };
    let image =
        image::RgbImage::from_raw(frame.width as u32, frame.height as u32, frame.data.clone())
            .unwrap();
    image
        .save(Path::new(&dir).join(format!("{name}.png")))
        .unwrap();
}

/// A 20 m x 20 m room (walls around its edge only) with one sign at (14, 10), its printed
/// side facing -x.
fn room_with_sign(arrow: ArrowDirection) -> (World, Sign) {
    let sign = Sign {
        centre: Vec2::new(14.0, 10.0),
        facing_rad: PI,
        width_m: 0.6,
        height_m: 0.45,
        mounting_height_m: 1.3,
        arrow,
        post: true,
    };
    let grid = OccupancyGrid::from_fn(200, 200, 0.1, Vec2::new(0.0, 0.0), |c, r| {
        c == 0 || r == 0 || c == 199 || r == 199
    });
    let look = WorldLook {
        wall_height_m: 2.5,
        wall_colour: Rgb::new(196, 186, 158),
        floor_colour: Rgb::new(96, 92, 88),
        ceiling_colour: Rgb::new(172, 172, 178),
    };
    let objects = vec![WorldObject {
        name: "sign".to_owned(),
        kind: ObjectKind::Sign(sign),
    }];
    (World::new("room".to_owned(), grid, look, objects), sign)
}

fn sign_detector() -> Harness {
    let mut detector = build(
        &robot("sign_detector", &["ImageSource"], &["Signs"], ""),
        "under-test",
    )
    .expect("sign_detector builds");
    detector.start(0).unwrap();
    detector
}

fn detect(detector: &mut Harness, frame: &ImageSource) -> Signs {
    detector.send(0, "camera", frame);
    let mut published = detector.take::<Signs>();
    assert_eq!(published.len(), 1);
    published.remove(0)
}

/// `point` (world, at height `z_m`) in the frame of a robot at `pose`.
fn in_robot_frame(pose: Pose2, point: Vec2, z_m: f64) -> (f64, f64, f64) {
    let (dx, dy) = (point.x - pose.x_m, point.y - pose.y_m);
    let (s, c) = pose.heading_rad.sin_cos();
    (c * dx + s * dy, -s * dx + c * dy, z_m)
}

#[test]
fn the_sign_detector_reads_every_arrow_from_near_and_far_and_from_the_side() {
    let mut detector = sign_detector();
    let mut camera = SimCamera::new(CameraConfig::default(), 7).unwrap();
    for arrow in [
        ArrowDirection::Left,
        ArrowDirection::Right,
        ArrowDirection::Up,
        ArrowDirection::Down,
    ] {
        let (world, sign) = room_with_sign(arrow);
        for distance_m in [1.5, 3.0, 5.0, 7.0] {
            for view_deg in [-50.0f64, -25.0, 0.0, 25.0, 50.0] {
                // Stand `distance_m` from the sign, `view_deg` off its face's normal, and look
                // at it.
                let from = sign.facing_rad + view_deg.to_radians();
                let position = sign.centre + Vec2::from_angle(from) * distance_m;
                let heading = (sign.centre - position).angle();
                let pose = Pose2::new(position.x, position.y, heading);
                let frame = camera.render(&world, pose);
                let name = format!("sign-{}-{distance_m}m-{view_deg}deg", arrow.name());
                save(&frame, &name);
                let signs = detect(&mut detector, &frame);
                assert_eq!(signs.signs.len(), 1, "{name}: {:#?}", signs.signs);
                let found = &signs.signs[0];
                assert_eq!(found.arrow, arrow.name(), "{name}: {found:#?}");
                let (x, y, z) = in_robot_frame(pose, sign.centre, sign.mounting_height_m);
                let error = ((found.position.x - x).powi(2)
                    + (found.position.y - y).powi(2)
                    + (found.position.z - z).powi(2))
                .sqrt();
                assert!(
                    error < 0.06 * distance_m + 0.05,
                    "{name}: found at {:?}, truth ({x:.2}, {y:.2}, {z:.2})",
                    found.position
                );
                assert!(found.confidence > 0.3, "{name}: {found:#?}");
            }
        }
    }
}

#[test]
fn the_sign_detector_reads_the_desk_sign_from_far_and_from_the_side() {
    let mut detector = sign_detector();
    let mut camera = SimCamera::new(CameraConfig::default(), 8).unwrap();
    let (world, sign) = room_with_sign(ArrowDirection::Desk);
    for distance_m in [2.5, 4.0, 6.0, 8.0] {
        for view_deg in [-30.0f64, -15.0, 0.0, 15.0, 30.0] {
            let from = sign.facing_rad + view_deg.to_radians();
            let position = sign.centre + Vec2::from_angle(from) * distance_m;
            let pose = Pose2::new(position.x, position.y, (sign.centre - position).angle());
            let frame = camera.render(&world, pose);
            let name = format!("sign-desk-{distance_m}m-{view_deg}deg");
            save(&frame, &name);
            let signs = detect(&mut detector, &frame);
            assert_eq!(signs.signs.len(), 1, "{name}: {:#?}", signs.signs);
            let found = &signs.signs[0];
            assert_eq!(found.arrow, "desk", "{name}: {found:#?}");
            assert!(found.confidence >= 0.5, "{name}: {found:#?}");
            let (x, y, z) = in_robot_frame(pose, sign.centre, sign.mounting_height_m);
            let error = ((found.position.x - x).powi(2)
                + (found.position.y - y).powi(2)
                + (found.position.z - z).powi(2))
            .sqrt();
            assert!(
                error < 0.06 * distance_m + 0.05,
                "{name}: found at {:?}, truth ({x:.2}, {y:.2}, {z:.2})",
                found.position
            );
        }
    }
}

fn conference() -> World {
    World::load(&repository("robots/worlds/conference")).expect("the conference world loads")
}

#[test]
fn the_sign_detector_reads_the_conference_signs_on_the_way() {
    let world = conference();
    let mut detector = sign_detector();
    let mut camera = SimCamera::new(CameraConfig::default(), 3).unwrap();
    // (robot pose, the sign in view, its arrow as the world file has it)
    let cases = [
        (Pose2::new(3.0, 12.5, 0.0), "sign-lobby", "up"),
        (Pose2::new(10.0, 12.75, 0.0), "sign-corridor", "up"),
        (Pose2::new(25.0, 12.75, 0.0), "sign-corner", "left"),
        // Coming west down the hall from its sign, 8 m and 4 m from the desk's.
        (Pose2::new(23.0, 23.2, PI), "sign-desk", "desk"),
        (Pose2::new(19.0, 22.8, PI), "sign-desk", "desk"),
    ];
    for (pose, name, arrow) in cases {
        let frame = camera.render(&world, pose);
        save(&frame, name);
        let signs = detect(&mut detector, &frame);
        // Every sign found is a sign of the world, placed within 6% of its distance; the
        // one the robot is heading for is among them, with its arrow.
        let mut read = None;
        for found in &signs.signs {
            let nearest = world
                .objects()
                .iter()
                .filter_map(|o| match o.kind {
                    ObjectKind::Sign(sign) => {
                        let (x, y, _) = in_robot_frame(pose, sign.centre, sign.mounting_height_m);
                        let error = (found.position.x - x).hypot(found.position.y - y);
                        Some((error / x.hypot(y), o.name.as_str()))
                    }
                    _ => None,
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap();
            assert!(
                nearest.0 < 0.06,
                "{name}: {found:#?} is no sign ({nearest:?})"
            );
            if nearest.1 == name {
                read = Some(found.arrow.clone());
            }
        }
        assert_eq!(read.as_deref(), Some(arrow), "{name}: {:#?}", signs.signs);
    }
}

/// The guide in the red cap, seen from the hall.
fn red_cap_view() -> (
    World,
    Pose2,
    ImageSource,
    lewis_interfaces::msg::RangeFinder,
) {
    let world = conference();
    // In the hall, 4.5 m west of the guide, looking at them.
    let ObjectKind::Person(guide) = world.object("red-cap").unwrap().kind else {
        panic!("red-cap is not a person");
    };
    let pose = Pose2::new(
        guide.centre.x - 4.0,
        guide.centre.y + 2.0,
        (-2.0f64).atan2(4.0),
    );
    let mut camera = SimCamera::new(CameraConfig::default(), 5).unwrap();
    let frame = camera.render(&world, pose);
    save(&frame, "red-cap");
    let mut laser = SimLaser::new(LaserConfig::default(), 5).unwrap();
    let scan = laser.scan(&world, pose);
    (world, pose, frame, scan)
}

fn red_blobs(frame: &ImageSource) -> Blobs {
    let colors = repository("robots/colors/conference.txt");
    let mut finder = build(
        &robot(
            "blobfinder",
            &["ImageSource"],
            &["Blobs"],
            &format!("colors = {colors:?}\nmin_area_px = 20"),
        ),
        "under-test",
    )
    .unwrap();
    finder.send(0, "camera", frame);
    finder.take::<Blobs>().remove(0)
}

#[test]
fn the_blob_finder_finds_the_red_cap_where_the_camera_sees_it() {
    let (world, pose, frame, _) = red_cap_view();
    let blobs = red_blobs(&frame);
    let red: Vec<_> = blobs
        .blobs
        .iter()
        .filter(|b| b.colour_name == "Red")
        .collect();
    assert_eq!(red.len(), 1, "{red:#?}");
    let ObjectKind::Person(guide) = world.object("red-cap").unwrap().kind else {
        panic!("red-cap is not a person");
    };
    let camera = SimCamera::new(CameraConfig::default(), 5).unwrap();
    let (u, v) = camera
        .project(pose, guide.centre, 0.96 * guide.height_m)
        .expect("the cap is in view");
    let cap = red[0];
    assert!(
        (f64::from(cap.left)..=f64::from(cap.right)).contains(&u)
            && (f64::from(cap.top) - 1.0..=f64::from(cap.bottom) + 1.0).contains(&v),
        "cap projected at ({u:.1}, {v:.1}), blob {cap:#?}"
    );
}

#[test]
fn blobfinder3d_places_the_red_cap_where_the_simulator_has_it() {
    let (world, pose, frame, scan) = red_cap_view();
    let blobs = red_blobs(&frame);
    let mut locator = build(
        &robot("blobfinder3d", &["Blobs", "RangeFinder"], &["Blobs3D"], ""),
        "under-test",
    )
    .unwrap();
    locator.start(0).unwrap();
    locator.send(0, "laser", &scan);
    locator.send(0, "blobfinder", &blobs);
    let placed = locator.take::<Blobs3D>().remove(0);
    let cap = placed
        .blobs
        .iter()
        .find(|b| b.blob.colour_name == "Red")
        .expect("the red cap is among the blobs");
    assert!(cap.range_valid, "{cap:#?}");
    let ObjectKind::Person(guide) = world.object("red-cap").unwrap().kind else {
        panic!("red-cap is not a person");
    };
    // The laser sees the guide's trousers (radius 0.18 m) and the camera the cap (radius
    // 0.11 m) on the same vertical axis: the cap's centre is within 0.25 m of the point
    // found, seen from above; its height (1.62 m to 1.77 m) within 0.1 m.
    let (x, y, _) = in_robot_frame(pose, guide.centre, 0.0);
    let horizontal_error = (cap.position.x - x).hypot(cap.position.y - y);
    assert!(
        horizontal_error < 0.25,
        "{:?} vs ({x:.2}, {y:.2})",
        cap.position
    );
    assert!((cap.position.z - 1.69).abs() < 0.1, "{:?}", cap.position);
    // The cap is 0.23 m wide.
    assert!((cap.width - 0.23).abs() < 0.08, "{cap:#?}");
    // Without a scan, blobs go out without a position and the service says why.
    let mut alone = build(
        &robot("blobfinder3d", &["Blobs", "RangeFinder"], &["Blobs3D"], ""),
        "under-test",
    )
    .unwrap();
    alone.send(0, "blobfinder", &blobs);
    let unplaced = alone.take::<Blobs3D>().remove(0);
    assert!(unplaced.blobs.iter().all(|b| !b.range_valid));
    assert!(matches!(
        alone.backend.health.as_slice(),
        [lewis_service::Health::Degraded(_)]
    ));
}
