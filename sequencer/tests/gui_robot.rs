//! The robot beside the question on the supervisor's page, over plain HTTP: the robot's
//! view as JSON, the camera frame as a BMP, the world map, the robot on the event stream,
//! the answers for its Speech provider, and what a robot description says to watch. The
//! page is fed a snapshot (no robot runs).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::net::{Ipv4Addr, SocketAddr};
use std::path::Path;
use std::time::Duration;

use crate::common::http::{EventStream, Reply, command, request};
use lewis_interfaces::msg::ImageSource;
use lewis_sequencer::gui::{
    BindingView, CameraView, Frame, MapView, PoseInterface, PoseView, RobotView, RobotWatchOptions,
    ServiceView, png_size,
};
use lewis_sequencer::live::control_channel;
use lewis_sequencer::{GuiServer, MemorySources, TrustingResolver, check_with};

const SCRIPT: &str = "\
start a
recovery r
use gui
state a /bin/a
  action 0 trans stop
state r /bin/r
  action 0 trans stop
";

/// The smallest PNG header: the signature and an IHDR of 800 x 500 pixels.
fn png_800x500() -> Vec<u8> {
    let mut png = b"\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR".to_vec();
    png.extend_from_slice(&800u32.to_be_bytes());
    png.extend_from_slice(&500u32.to_be_bytes());
    png.extend_from_slice(&[8, 2, 0, 0, 0, 0, 0, 0, 0]);
    png
}

fn server() -> GuiServer {
    let sources = MemorySources::new().with("m.seq", SCRIPT);
    let mission = check_with(Path::new("m.seq"), &sources, &TrustingResolver)
        .unwrap_or_else(|d| panic!("{d}"))
        .mission;
    let (controller, _control) = control_channel().unwrap();
    GuiServer::start(
        SocketAddr::from((Ipv4Addr::LOCALHOST, 0)),
        &mission,
        controller,
    )
    .unwrap()
}

fn snapshot(speech: Option<&str>) -> RobotView {
    RobotView {
        pose: Some(PoseView {
            x: 12.5,
            y: 13.0,
            theta: 0.5,
            interface: PoseInterface::GroundTruth,
            service: "base".into(),
        }),
        map: Some(MapView {
            width_px: 800,
            height_px: 500,
            metres_per_pixel: 0.05,
            origin_m: [0.0, 0.0],
        }),
        camera: Some(CameraView {
            frame: 7,
            width_px: 3,
            height_px: 2,
            service: "camera".into(),
        }),
        people: Vec::new(),
        services: vec![
            ServiceView {
                name: "laser".into(),
                state: "failed".into(),
                health: "ok".into(),
                reason: "crashed 3 times".into(),
            },
            ServiceView {
                name: "sonar".into(),
                state: "ready".into(),
                health: "ok".into(),
                reason: String::new(),
            },
        ],
        bindings: vec![BindingView {
            client: "obstacle_avoider".into(),
            interface: "RangeFinder".into(),
            service: "sonar".into(),
        }],
        broker_answers: true,
        speech: speech.map(str::to_owned),
        answer: None,
    }
}

/// A frame of 3 x 2 pixels, each a different colour.
fn frame() -> Frame {
    Frame {
        width: 3,
        height: 2,
        rgb: (0u8..18).map(|i| i * 10).collect(),
    }
}

fn answer(addr: SocketAddr, body: &str) -> Reply {
    command(addr, "/answer", body)
}

#[test]
fn nothing_of_the_robot_is_served_until_it_is_fed() {
    let gui = server();
    for path in ["/robot", "/camera.bmp", "/map.png"] {
        assert_eq!(
            request(gui.addr(), "GET", path, "", "").status,
            404,
            "{path}"
        );
    }
    let refused = answer(gui.addr(), r#"{"answer":"yes","text":"registered"}"#);
    assert_eq!(refused.status, 409);
}

#[test]
fn the_robot_is_served_as_json_a_bmp_and_the_map() {
    let gui = server();
    let feed = gui.robot_feed();
    feed.map(png_800x500());
    feed.frame(&frame());
    feed.show(&snapshot(None));

    let robot = request(gui.addr(), "GET", "/robot", "", "");
    assert_eq!(robot.status, 200);
    assert!(robot.head.contains("application/json"), "{}", robot.head);
    let json: serde_json::Value = serde_json::from_slice(&robot.body).unwrap();
    assert_eq!(json["pose"]["x"], 12.5);
    assert_eq!(json["pose"]["interface"], "GroundTruth");
    assert_eq!(json["map"]["width_px"], 800);
    assert_eq!(json["map"]["metres_per_pixel"], 0.05);
    assert_eq!(json["map"]["origin_m"], serde_json::json!([0.0, 0.0]));
    assert_eq!(json["camera"]["frame"], 7);
    assert_eq!(
        json["bindings"][0],
        serde_json::json!({"client": "obstacle_avoider", "interface": "RangeFinder", "service": "sonar"})
    );
    assert_eq!(json["services"][0]["state"], "failed");
    assert_eq!(json["services"][0]["reason"], "crashed 3 times");
    assert_eq!(json["speech"], serde_json::Value::Null);

    let map = request(gui.addr(), "GET", "/map.png", "", "");
    assert_eq!(map.status, 200);
    assert!(map.head.contains("image/png"), "{}", map.head);
    assert_eq!(map.body, png_800x500());
    assert_eq!(png_size(&map.body), Some((800, 500)));

    let bmp = request(gui.addr(), "GET", "/camera.bmp", "", "");
    assert_eq!(bmp.status, 200);
    assert!(bmp.head.contains("image/bmp"), "{}", bmp.head);
    let b = &bmp.body;
    let u32_at = |at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let i32_at = |at: usize| i32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    assert_eq!(&b[..2], b"BM");
    // Rows of 3 pixels are 9 bytes, padded to 12.
    assert_eq!(b.len(), 54 + 2 * 12);
    assert_eq!(u32_at(2) as usize, b.len());
    assert_eq!(u32_at(10), 54, "the pixels' offset");
    assert_eq!(u32_at(14), 40, "BITMAPINFOHEADER");
    assert_eq!(
        (i32_at(18), i32_at(22)),
        (3, 2),
        "positive height: bottom-up"
    );
    assert_eq!(u16::from_le_bytes([b[28], b[29]]), 24, "bits per pixel");
    // The bottom row first, each pixel blue, green, red.
    let rgb = frame().rgb;
    assert_eq!(&b[54..57], &[rgb[11], rgb[10], rgb[9]]);
    assert_eq!(&b[54 + 12..54 + 15], &[rgb[2], rgb[1], rgb[0]]);
    assert_eq!(&b[54 + 9..54 + 12], &[0, 0, 0], "padding");
    gui.shutdown();
}

#[test]
fn the_event_stream_sends_the_robot_as_its_own_event() {
    let gui = server();
    let feed = gui.robot_feed();
    feed.show(&snapshot(None));
    let mut events = EventStream::open(gui.addr());
    let mut next_robot = || events.next("robot");
    // The latest robot at once, then every new one.
    assert_eq!(next_robot()["pose"]["x"], 12.5);
    let mut moved = snapshot(None);
    moved.pose.as_mut().unwrap().x = 14.0;
    feed.show(&moved);
    assert_eq!(next_robot()["pose"]["x"], 14.0);
    gui.shutdown();
}

#[test]
fn an_answer_goes_to_the_speech_provider_only_when_there_is_one() {
    let gui = server();
    let feed = gui.robot_feed();
    let answers = feed.answers();
    feed.show(&snapshot(None));
    let body = r#"{"answer":"yes","text":"registered"}"#;
    assert_eq!(answer(gui.addr(), body).status, 409, "no Speech provider");

    feed.show(&snapshot(Some("speech")));
    let refused = request(gui.addr(), "POST", "/answer", "", body);
    assert_eq!(refused.status, 403, "the supervisor's header is required");
    assert_eq!(answer(gui.addr(), r#"{"answer":"maybe"}"#).status, 400);
    let sent = answer(gui.addr(), body);
    assert_eq!(sent.status, 202, "{}", sent.text());
    let got = answers.recv_timeout(Duration::from_secs(5)).unwrap();
    assert_eq!(
        (got.answer.as_str(), got.text.as_str()),
        ("yes", "registered")
    );
    gui.shutdown();
}

#[test]
fn a_camera_frame_is_shrunk_to_a_thumbnail_in_rgb() {
    let (width, height) = (640usize, 480usize);
    let mut data = vec![0u8; width * height * 3];
    // The pixel at (2, 4) in bgr8: blue 1, green 2, red 3.
    data[(4 * width + 2) * 3..][..3].copy_from_slice(&[1, 2, 3]);
    let image = ImageSource {
        width: 640,
        height: 480,
        encoding: "bgr8".into(),
        step: 640 * 3,
        data,
        ..ImageSource::default()
    };
    let frame = Frame::from_image(&image).unwrap();
    assert_eq!((frame.width, frame.height), (320, 240));
    // Shrunk by 2: (2, 4) is (1, 2) of the thumbnail, now red, green, blue.
    assert_eq!(&frame.rgb[(2 * 320 + 1) * 3..][..3], &[3, 2, 1]);
    let short = ImageSource {
        data: vec![0; 10],
        ..image.clone()
    };
    assert_eq!(Frame::from_image(&short), None);
    let unknown = ImageSource {
        encoding: "yuv422".into(),
        ..image
    };
    assert_eq!(Frame::from_image(&unknown), None);
}

#[test]
fn the_simulated_robot_is_watched_on_its_true_pose_and_world_map() {
    let robot_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/sim.toml");
    let robot = lewis_robot::load(&robot_path, &lewis_interfaces::interface_names())
        .unwrap_or_else(|e| panic!("{e}"));
    // From elsewhere than the repository's root: the world is found above the robot file.
    let options = RobotWatchOptions::from_robot(&robot, &robot_path);
    assert_eq!(
        options.pose,
        Some(("base".into(), PoseInterface::GroundTruth))
    );
    assert_eq!(options.camera.as_deref(), Some("camera"));
    let map = options.world_map.expect("the conference world's map");
    assert!(map.image.ends_with("robots/worlds/conference/map.png"));
    assert!(map.image.is_file(), "{}", map.image.display());
    assert!((map.metres_per_pixel - 0.05).abs() < 1e-12);
    assert_eq!(map.origin_m, [0.0, 0.0]);
    let png = std::fs::read(&map.image).unwrap();
    assert_eq!(png_size(&png), Some((800, 500)));

    // A robot without a simulator: the odometry, and no map.
    let test_path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/test.toml");
    let test = lewis_robot::load(&test_path, &lewis_interfaces::interface_names())
        .unwrap_or_else(|e| panic!("{e}"));
    let options = RobotWatchOptions::from_robot(&test, &test_path);
    assert_ne!(
        options.pose.map(|(_, interface)| interface),
        Some(PoseInterface::GroundTruth)
    );
    assert_eq!(options.world_map, None);
}

#[test]
fn the_robot_is_watched_for_the_page_only_while_a_page_looks() {
    let gui = server();
    let feed = gui.robot_feed();
    feed.show(&snapshot(None));
    assert!(!feed.is_viewed(), "nobody looks yet");
    assert_eq!(request(gui.addr(), "GET", "/robot", "", "").status, 200);
    assert!(feed.is_viewed(), "the robot's view was just asked for");

    let other = server();
    let feed = other.robot_feed();
    feed.show(&snapshot(None));
    let mut events = EventStream::open(other.addr());
    assert_eq!(events.next("robot")["pose"]["x"], 12.5);
    assert!(feed.is_viewed(), "an event stream is open");
    drop(events);
    other.shutdown();
    gui.shutdown();
}
