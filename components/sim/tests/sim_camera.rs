//! The simulated camera's frames: signs are white boards with a black arrow pointing the
//! right way, coloured things have their colour, zoom magnifies. Pixel colours are checked
//! at image positions computed with the camera's own projection.
//!
//! Set LEWIS_SIM_FRAMES_DIR to a folder to also save the frames of the conference world
//! rendered here as PNG files, to look at them.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test helpers fail loudly on broken fixtures"
)]

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use lewis_geometry::{Pose2, Vec2};
use lewis_interfaces::msg::ImageSource;
use lewis_sim::world::{ArrowDirection, ObjectKind, OccupancyGrid, Person, Rgb, Sign, WorldObject};
use lewis_sim::{CameraConfig, Shape, SimCamera, World, WorldLook};

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

/// A 20 m x 10 m room (walls around its edge only) holding `objects`.
fn room(objects: Vec<WorldObject>) -> World {
    let grid = OccupancyGrid::from_fn(200, 100, 0.1, Vec2::new(0.0, 0.0), |c, r| {
        c == 0 || r == 0 || c == 199 || r == 99
    });
    World::new("room".to_owned(), grid, look(), objects)
}

fn sign(arrow: ArrowDirection) -> Sign {
    Sign {
        centre: Vec2::new(5.0, 5.0),
        facing_rad: PI,
        width_m: 0.6,
        height_m: 0.45,
        mounting_height_m: 1.3,
        arrow,
        post: true,
    }
}

fn camera() -> SimCamera {
    SimCamera::new(CameraConfig::default(), 1).unwrap()
}

fn pixel(frame: &ImageSource, (u, v): (f64, f64)) -> [u8; 3] {
    let (col, row) = (u.round() as usize, v.round() as usize);
    let step = usize::try_from(frame.step).unwrap();
    let i = row * step + col * 3;
    [frame.data[i], frame.data[i + 1], frame.data[i + 2]]
}

fn is_white(p: [u8; 3]) -> bool {
    p.iter().all(|&c| c > 200)
}

fn is_black(p: [u8; 3]) -> bool {
    p.iter().all(|&c| c < 50)
}

fn is_red(p: [u8; 3]) -> bool {
    p[0] > 120 && p[1] < 50 && p[2] < 50
}

/// The world point at (`along`, `across`) in the arrow's own frame (the square the arrow is
/// drawn in, side 0.8 of the board's smaller side; the tip towards +along).
fn arrow_point(s: &Sign, along: f64, across: f64) -> (Vec2, f64) {
    let side = 0.8 * s.width_m.min(s.height_m);
    let (a, b) = match s.arrow {
        // The desk's disc points nowhere: its own frame is the board's.
        ArrowDirection::Right | ArrowDirection::Desk => (along, across),
        ArrowDirection::Left => (-along, across),
        ArrowDirection::Up => (across, along),
        ArrowDirection::Down => (across, -along),
    };
    let point = s.centre + s.viewer_right() * (a * side);
    (point, s.mounting_height_m + b * side)
}

#[test]
fn a_sign_in_front_of_the_camera_is_a_white_board_with_a_black_arrow_pointing_its_way() {
    for arrow in [
        ArrowDirection::Left,
        ArrowDirection::Right,
        ArrowDirection::Up,
        ArrowDirection::Down,
    ] {
        let s = sign(arrow);
        let world = room(vec![WorldObject {
            name: "sign".to_owned(),
            kind: ObjectKind::Sign(s),
        }]);
        let robot = Pose2::new(3.0, 5.0, 0.0);
        let mut cam = camera();
        let frame = cam.render(&world, robot);
        let at = |along: f64, across: f64| {
            let (p, z) = arrow_point(&s, along, across);
            pixel(&frame, cam.project(robot, p, z).unwrap())
        };
        // Board corners are white; the shaft and the head are black.
        for (along, across) in [(-0.55, 0.55), (0.55, -0.55), (-0.55, -0.55), (0.55, 0.55)] {
            assert!(
                is_white(at(along, across)),
                "{arrow:?}: corner {along},{across} {:?}",
                at(along, across)
            );
        }
        for (along, across) in [(-0.3, 0.0), (0.0, 0.0), (0.3, 0.0), (0.1, 0.2), (0.1, -0.2)] {
            assert!(
                is_black(at(along, across)),
                "{arrow:?}: arrow at {along},{across} {:?}",
                at(along, across)
            );
        }
        // The head is wide and the tail thin: the arrow points the way it is named.
        for (along, across) in [(-0.1, 0.2), (-0.1, -0.2), (0.42, 0.1)] {
            assert!(
                is_white(at(along, across)),
                "{arrow:?}: beside the arrow at {along},{across} {:?}",
                at(along, across)
            );
        }
    }
}

#[test]
fn the_back_of_a_sign_shows_no_arrow() {
    let mut s = sign(ArrowDirection::Left);
    s.facing_rad = 0.0;
    let world = room(vec![WorldObject {
        name: "sign".to_owned(),
        kind: ObjectKind::Sign(s),
    }]);
    let robot = Pose2::new(3.0, 5.0, 0.0);
    let mut cam = camera();
    let frame = cam.render(&world, robot);
    let centre = pixel(
        &frame,
        cam.project(robot, s.centre, s.mounting_height_m).unwrap(),
    );
    assert!(!is_white(centre) && !is_black(centre), "{centre:?}");
}

fn red_pillar_world() -> World {
    room(vec![WorldObject {
        name: "red".to_owned(),
        kind: ObjectKind::Landmark {
            shape: Shape::Circle {
                centre: Vec2::new(6.0, 5.0),
                radius_m: 0.2,
            },
            height_m: 1.5,
            colour: Rgb::parse("red").unwrap(),
        },
    }])
}

/// Length of the run of red pixels through the image row at `v` around column `u`.
fn red_run(frame: &ImageSource, (u, v): (f64, f64)) -> usize {
    let width = usize::try_from(frame.width).unwrap();
    let (u, v) = (u.round() as usize, v.round());
    let red = |c: usize| is_red(pixel(frame, (c as f64, v)));
    let left = (0..=u).rev().take_while(|&c| red(c)).count();
    let right = (u + 1..width).take_while(|&c| red(c)).count();
    left + right
}

#[test]
fn a_red_object_appears_red_and_zoom_magnifies_it() {
    let world = red_pillar_world();
    let robot = Pose2::new(2.0, 5.0, 0.0);
    let mut cam = camera();
    let frame = cam.render(&world, robot);
    let centre = cam.project(robot, Vec2::new(5.8, 5.0), 1.0).unwrap();
    assert!(is_red(pixel(&frame, centre)), "{:?}", pixel(&frame, centre));
    let wide = red_run(&frame, centre);
    // 0.4 m seen from 3.9 m with a focal length of 704 px: about 72 px.
    assert!((60..=80).contains(&wide), "{wide} px");

    assert_eq!(cam.set_zoom(2.0), 2.0);
    let zoomed = cam.render(&world, robot);
    let centre = cam.project(robot, Vec2::new(5.8, 5.0), 1.0).unwrap();
    let narrow = red_run(&zoomed, centre);
    assert!(
        narrow.abs_diff(2 * wide) <= 6,
        "zoom 2: {narrow} px, zoom 1: {wide} px"
    );
    assert_eq!(cam.set_zoom(40.0), 12.0);
    assert!((zoomed.focal_length_x - 2.0 * frame.focal_length_x).abs() < 1e-9);
}

#[test]
fn panning_the_camera_turns_the_view() {
    let world = red_pillar_world();
    // The robot faces north; the pillar is to its right (east).
    let robot = Pose2::new(2.0, 5.0, PI / 2.0);
    let mut cam = camera();
    assert!(cam.project(robot, Vec2::new(5.8, 5.0), 1.0).is_none());
    cam.set_pan_tilt(-PI / 2.0, 0.0);
    let frame = cam.render(&world, robot);
    let centre = cam.project(robot, Vec2::new(5.8, 5.0), 1.0).unwrap();
    assert!(is_red(pixel(&frame, centre)));
}

#[test]
fn frames_are_identical_for_the_same_seed_and_differ_in_grain_for_another() {
    let world = red_pillar_world();
    let robot = Pose2::new(2.0, 4.0, 0.3);
    let a = SimCamera::new(CameraConfig::default(), 5)
        .unwrap()
        .render(&world, robot);
    let b = SimCamera::new(CameraConfig::default(), 5)
        .unwrap()
        .render(&world, robot);
    let c = SimCamera::new(CameraConfig::default(), 6)
        .unwrap()
        .render(&world, robot);
    assert_eq!(a, b);
    assert_ne!(a.data, c.data);
    assert_eq!(
        (a.width, a.height, a.step, a.data.len()),
        (640, 480, 1920, 640 * 480 * 3)
    );
    assert_eq!(a.encoding, "rgb8");
}

/// Views of the conference world: (file name, robot pose, what must be seen where).
#[test]
fn the_conference_world_shows_its_signs_and_the_red_cap() {
    let world = World::load(&repository_path("robots/worlds/conference")).unwrap();
    let frames_dir = std::env::var_os("LEWIS_SIM_FRAMES_DIR").map(PathBuf::from);
    let object = |name: &str| world.object(name).unwrap().kind.clone();
    let mut cam = camera();
    let views = [
        ("lobby", Pose2::new(3.0, 12.5, 0.0)),
        ("corridor", Pose2::new(11.0, 12.5, 0.0)),
        ("corridor-end", Pose2::new(25.0, 12.75, 0.0)),
        ("hall-entry", Pose2::new(28.25, 18.0, PI / 2.0)),
        ("queue", Pose2::new(24.0, 21.0, PI)),
        ("red-cap", Pose2::new(28.0, 17.5, 2.4)),
    ];
    for (name, robot) in views {
        let frame = cam.render(&world, robot);
        if let Some(dir) = &frames_dir {
            std::fs::create_dir_all(dir).unwrap();
            let image = image::RgbImage::from_raw(640, 480, frame.data.clone()).unwrap();
            image.save(dir.join(format!("{name}.png"))).unwrap();
        }
        match name {
            "lobby" | "corridor" | "corridor-end" | "hall-entry" => {
                let sign_name = match name {
                    "lobby" => "sign-lobby",
                    "corridor" => "sign-corridor",
                    "corridor-end" => "sign-corner",
                    _ => "sign-hall",
                };
                let ObjectKind::Sign(s) = object(sign_name) else {
                    panic!("{sign_name}")
                };
                let at = |along: f64, across: f64| {
                    let (p, z) = arrow_point(&s, along, across);
                    pixel(&frame, cam.project(robot, p, z).unwrap())
                };
                assert!(
                    is_white(at(-0.55, 0.55)),
                    "{name}: board {:?}",
                    at(-0.55, 0.55)
                );
                assert!(is_black(at(0.0, 0.0)), "{name}: arrow {:?}", at(0.0, 0.0));
            }
            "red-cap" => {
                let ObjectKind::Person(Person {
                    centre, height_m, ..
                }) = object("red-cap")
                else {
                    panic!("red-cap")
                };
                let cap = cam.project(robot, centre, height_m - 0.04).unwrap();
                assert!(is_red(pixel(&frame, cap)), "cap {:?}", pixel(&frame, cap));
            }
            _ => {
                let ObjectKind::Desk { shape, .. } = object("registration") else {
                    panic!()
                };
                let (lo, hi) = shape.bounds();
                let desk = cam.project(robot, Vec2::new(hi.x, (lo.y + hi.y) / 2.0 + 1.2), 0.6);
                assert!(desk.is_some(), "the desk is in view");
            }
        }
    }
}

#[test]
fn a_frame_rendered_over_stale_bytes_is_the_same_frame() {
    // Published in place, a frame is rendered into a shared-memory loan that still holds
    // an earlier frame: every byte must be written. Two cameras with the same seed give
    // the same noise, so the frames must match byte for byte.
    let world = room(vec![WorldObject {
        name: "sign".to_owned(),
        kind: ObjectKind::Sign(sign(ArrowDirection::Left)),
    }]);
    let robot = Pose2::new(3.0, 5.0, 0.0);
    let expected = camera().render(&world, robot).data;
    for stale in [0x00, 0xFF, 0x5A] {
        let mut cam = camera();
        let mut loan = vec![stale; cam.frame_len()];
        cam.render_into(&world, robot, &mut loan);
        assert!(loan == expected, "stale byte {stale:#x} shows through");
    }
    // A buffer of the wrong length is refused, not half painted.
    let mut cam = camera();
    let mut short = vec![7; cam.frame_len() - 1];
    cam.render_into(&world, robot, &mut short);
    assert!(short.iter().all(|b| *b == 7));
}
