//! The Robot Challenge's door and corridor legs on the B21r's emulators, end to end, as the
//! README tells a team to run them: `lewis fake-device rflex` and `lewis fake-device sick` on
//! pseudo-terminals in the conference world, sharing the robot's true pose; `lewis up
//! robots/b21r-emulated.toml --script robots/missions/door-corridor.seq`, where the real SICK
//! and RFlex drivers talk to the emulators, the simulator's camera renders from the shared
//! pose (`emulated-camera`), and perception, motion and the programs are the robot's. The
//! robot must go through the door (DoorNavigator exits 0) and follow the corridor's sign to
//! the next one (SignFollower exits 0), judged from the sequencer's records; the signs must
//! be on the sign detector's channel.
//!
//! Its own test binary: a closed loop in real time, like `challenge`, that should not share
//! the machine with other end-to-end tests.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::os::fd::AsFd as _;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{SignArrow, Signs};
use lewis_runtime::ipc::{FdSource, Namespace, WaitSet, WakeMode};
use lewis_runtime::names;
use lewis_sequencer::replay::read_json_lines;
use lewis_sequencer::verdict::Verdict;
use lewis_tests::fake_device::FakeDeviceProcess;
use lewis_tests::{lewis_exe, open_ipc, repo_root};

/// The shared directory the emulated robot file names, for the ports and the true pose.
const SHARED_DIR: &str = "/tmp/lewis-b21r";
/// Longer than the mission can take on a loaded machine (about 45 s in a debug build): a
/// watchdog against a robot that never finishes, not a timing assertion.
const MISSION_WATCHDOG: Duration = Duration::from_secs(240);
/// SignFollower's own threshold: readings less sure are not read.
const MIN_CONFIDENCE: f64 = 0.5;

/// `robots/b21r-emulated.toml` with its shared directory moved to `dir`.
fn emulated_robot_in(dir: &Path) -> String {
    let text = std::fs::read_to_string(repo_root().join("robots/b21r-emulated.toml")).unwrap();
    // The two ports and the camera's robot_state, besides the comments.
    assert!(text.matches(SHARED_DIR).count() >= 3, "{text}");
    text.replace(SHARED_DIR, dir.to_str().unwrap())
}

#[test]
fn the_emulated_b21r_goes_through_the_door_and_follows_the_corridors_sign() {
    let dir = tempfile::tempdir().unwrap();
    let shared = dir.path().to_str().unwrap();
    let world = [
        "--world",
        "robots/worlds/conference",
        "--start",
        "3,12.5,0",
        "--robot-state",
        shared,
    ];
    // The base first: it writes the true pose the laser and the camera render from.
    let _base = FakeDeviceProcess::start("rflex", &dir.path().join("ttyRFLEX"), &world);
    let _laser = FakeDeviceProcess::start("sick", &dir.path().join("ttySICK"), &world);
    let robot = dir.path().join("robot.toml");
    std::fs::write(&robot, emulated_robot_in(dir.path())).unwrap();
    let events = dir.path().join("events.jsonl");
    let output = dir.path().join("up.log");

    // The sign detector's output, subscribed before anything is published.
    let namespace = Namespace::unique("b21r-mission");
    let ipc = open_ipc(&namespace, "test-signs");
    let mut signs = ipc
        .subscriber(
            &names::data_channel("sign_detector", "Signs"),
            &names::data_config("Signs"),
        )
        .expect("the sign detector's Signs can be read");

    let log = std::fs::File::create(&output).unwrap();
    let mut up = Command::new(lewis_exe())
        .arg("up")
        .arg(&robot)
        .arg("--script")
        .arg(repo_root().join("robots/missions/door-corridor.seq"))
        .args(["--no-gui", "--no-record", "--stop-grace-ms", "300"])
        .args(["--namespace", namespace.as_str()])
        .arg("--events")
        .arg(&events)
        // From the repository's root, as a team runs it: the robot file names its world and
        // colour files relative to it.
        .current_dir(repo_root())
        .env_remove("RUST_LOG")
        .stdin(Stdio::null())
        .stdout(log.try_clone().unwrap())
        .stderr(log)
        .spawn()
        .expect("lewis up starts");
    let ended = rustix::process::pidfd_open(
        rustix::process::Pid::from_child(&up),
        rustix::process::PidfdFlags::empty(),
    )
    .unwrap();

    let mut read: Vec<Signs> = Vec::new();
    let deadline = Instant::now() + MISSION_WATCHDOG;
    let status = loop {
        while let Some(sample) = signs.receive().unwrap() {
            read.push(cdr::from_bytes(sample.bytes()).expect("Signs decodes"));
        }
        if let Some(status) = up.try_wait().unwrap() {
            break status;
        }
        if Instant::now() >= deadline {
            let _ = up.kill();
            let _ = up.wait();
            panic!(
                "the mission did not end within {MISSION_WATCHDOG:?}; lewis up wrote:\n{}",
                std::fs::read_to_string(&output).unwrap_or_default()
            );
        }
        WaitSet::new(WakeMode::Event)
            .wait(&[&signs, &FdSource::new(ended.as_fd())], Some(deadline))
            .expect("the test can wait");
    };
    let printed = std::fs::read_to_string(&output).unwrap();
    assert!(
        status.success(),
        "lewis up exited with {status}:\n{printed}"
    );

    // The mission, judged from its records: door, then sign, each left on exit 0.
    let records = read_json_lines(std::io::BufReader::new(
        std::fs::File::open(&events).expect("lewis up writes the events"),
    ))
    .unwrap();
    let verdict = Verdict::of(&records);
    assert!(verdict.succeeded, "{}\n{printed}", verdict.reason);
    let left: Vec<(&str, Option<&str>)> = verdict
        .states_visited
        .iter()
        .map(|v| (v.state.as_str(), v.left_by.as_deref()))
        .collect();
    assert_eq!(
        left,
        [
            ("door", Some("transition door -> sign on 0")),
            // 0: SignFollower followed a direction sign and read the next one.
            ("sign", Some("transition sign -> stop on 0")),
        ],
        "{printed}"
    );
    assert_eq!(
        (verdict.restarts, verdict.recoveries),
        (0, 0),
        "{}\n{printed}",
        verdict.reason
    );

    // The camera rendered the corridor from the emulated base's pose: the sign detector read
    // direction signs in its frames.
    let directions: std::collections::BTreeSet<&str> = read
        .iter()
        .flat_map(|message| &message.signs)
        .filter(|sign| sign.confidence >= MIN_CONFIDENCE)
        .filter_map(|sign| match SignArrow::parse(&sign.arrow) {
            Some(SignArrow::Desk) | None => None,
            Some(arrow) => Some(arrow.as_str()),
        })
        .collect();
    assert!(
        !directions.is_empty(),
        "no direction sign on the sign detector's channel in {} messages:\n{printed}",
        read.len()
    );
}

#[test]
fn the_emulated_b21r_is_the_b21r_with_its_name_ports_camera_and_deadline_changed() {
    let read = |name: &str| -> toml::Table {
        let path = repo_root().join("robots").join(name);
        toml::from_str(&std::fs::read_to_string(&path).unwrap())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    };
    let mut real = read("b21r.toml");
    let mut emulated = read("b21r-emulated.toml");
    for robot in [&mut real, &mut emulated] {
        let head = robot["robot"].as_table_mut().unwrap();
        head.remove("name");
        head.remove("description");
        robot["broker"]
            .as_table_mut()
            .unwrap()
            .remove("heartbeat_deadline_ms");
        for service in robot["services"].as_array_mut().unwrap() {
            let service = service.as_table_mut().unwrap();
            let name = service["name"].as_str().unwrap().to_owned();
            let parameters = service["parameters"].as_table_mut().unwrap();
            if matches!(name.as_str(), "laser" | "base") {
                assert!(parameters.remove("port").is_some(), "{name} has a port");
            }
            if name == "camera" {
                service.remove("kind");
                service.remove("description");
                service.remove("parameters");
            }
        }
    }
    assert_eq!(
        real, emulated,
        "robots/b21r-emulated.toml differs from robots/b21r.toml in more than its name, the ports, the camera and the heartbeat deadline"
    );
    let camera = emulated_camera(&read("b21r-emulated.toml"));
    assert_eq!(camera["kind"].as_str(), Some("emulated-camera"));
}

/// The camera service of a robot file.
fn emulated_camera(robot: &toml::Table) -> toml::Table {
    robot["services"]
        .as_array()
        .unwrap()
        .iter()
        .map(|service| service.as_table().unwrap())
        .find(|service| service["name"].as_str() == Some("camera"))
        .expect("the robot has a camera")
        .clone()
}
