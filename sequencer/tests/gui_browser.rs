//! The supervisor's page in a real browser: headless Chromium, driven by Playwright
//! (`gui-test/drive.mjs`), watches a live mission, taps the state to resume from when the
//! sequencer asks, and the mission resumes there. Beside the question the page shows the
//! robot it is fed (a moving pose on the conference map, a camera frame, the bindings with
//! their health) and sends the "registered" answer for its Speech provider.
//!
//! Needs Debian's `chromium` (or `LEWIS_CHROMIUM=/path/to/chromium`), `node`, and
//! `npm ci --prefix tools/node`; fails with a message saying which is missing.
//! Screenshots go to `$TMPDIR/lewis-seq-gui/` (`running.png`, `asking.png`,
//! `finished.png`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use std::net::{Ipv4Addr, SocketAddr};
use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

use common::write_script;
use lewis_sequencer::gui::{
    BindingView, CameraView, Frame, MapView, PoseInterface, PoseView, RobotFeed, RobotView,
    ServiceView,
};
use lewis_sequencer::live::{RunOptions, control_channel, run_mission};
use lewis_sequencer::record::{ChannelSink, Entry, Tee};
use lewis_sequencer::{Decision, GuiServer, Supervision};
use lewis_testkit::browser::{browser_tools, gui_test_dir};

const SCRIPT: &str = "\
start door
restart 1
recovery oops
use gui

state door {P} print:waiting,wait:{D}/release,exit:0
  action 0 trans sign

state sign {P} signal:SEGV
  action 0 trans queue

state queue {P} exit:0
  action 0 trans register

state register {P} exit:0
  action 0 trans stop

state oops {P} print:recovering,exit:0
  action 0 trans stop
";

/// Feeds the page a robot driving east along the corridor, every 200 ms until `done`.
fn feed_robot(feed: &RobotFeed, done: &AtomicBool) {
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/worlds/conference/map.png");
    feed.map(std::fs::read(map).unwrap());
    // A 64 x 48 frame: red rising to the right, green downwards.
    let rgb = (0..48u8)
        .flat_map(|y| (0..64u8).flat_map(move |x| [x * 4, y * 5, 128]))
        .collect();
    feed.frame(&Frame {
        width: 64,
        height: 48,
        rgb,
    });
    let service = |name: &str, state: &str, reason: &str| ServiceView {
        name: name.into(),
        state: state.into(),
        health: "ok".into(),
        reason: reason.into(),
    };
    let mut view = RobotView {
        map: Some(MapView {
            width_px: 800,
            height_px: 500,
            metres_per_pixel: 0.05,
            origin_m: [0.0, 0.0],
        }),
        services: vec![
            service("laser", "failed", "crashed 3 times in 60 s"),
            service("sonar", "ready", ""),
            service("camera", "ready", ""),
        ],
        bindings: vec![
            BindingView {
                client: "obstacle_avoider".into(),
                interface: "RangeFinder".into(),
                service: "sonar".into(),
            },
            BindingView {
                client: "sign_detector".into(),
                interface: "ImageSource".into(),
                service: "camera".into(),
            },
        ],
        broker_answers: true,
        speech: Some("speech".into()),
        ..RobotView::default()
    };
    let mut frame = 0;
    let mut x_m = 9.0;
    while !done.load(Ordering::SeqCst) {
        frame += 1;
        x_m += 0.1;
        view.pose = Some(PoseView {
            x: x_m,
            y: 12.5,
            theta: 0.0,
            interface: PoseInterface::GroundTruth,
            service: "base".into(),
        });
        view.camera = Some(CameraView {
            frame,
            width_px: 64,
            height_px: 48,
            service: "camera".into(),
        });
        feed.show(&view);
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[test]
fn the_supervisor_resumes_the_mission_from_the_page_in_a_real_browser() {
    let chromium = browser_tools();
    let dir = tempfile::tempdir().unwrap();
    let (script, mission) = write_script(dir.path(), SCRIPT);
    let shots = std::env::temp_dir().join("lewis-seq-gui");
    std::fs::create_dir_all(&shots).unwrap();

    let (controller, control) = control_channel().unwrap();
    let gui = GuiServer::start(
        SocketAddr::from((Ipv4Addr::LOCALHOST, 0)),
        &mission,
        controller.clone(),
    )
    .unwrap();
    let (tx, rx) = mpsc::channel();
    let mut sink = Tee::new().with(gui.sink()).with(ChannelSink(tx));
    let feed = gui.robot_feed();
    let answers = feed.answers();
    let done = AtomicBool::new(false);
    let (outcome, browser) = std::thread::scope(|scope| {
        scope.spawn(|| feed_robot(&feed, &done));
        let options = RunOptions {
            supervision: Supervision::Page,
            ..RunOptions::new(&script)
        };
        let sink = &mut sink;
        let driver = scope.spawn(move || run_mission(mission, options, &control, sink));
        let browser = Command::new("node")
            .arg(gui_test_dir().join("drive.mjs"))
            .arg(gui.url())
            .arg(dir.path().join("release"))
            .arg(&shots)
            .env("LEWIS_CHROMIUM", &chromium)
            .current_dir(gui_test_dir())
            .output()
            .unwrap();
        done.store(true, Ordering::SeqCst);
        if !browser.status.success() {
            // Whatever the page did not do, the mission must not wait for it forever.
            controller.interrupt("the browser test failed");
        }
        (driver.join().unwrap().unwrap(), browser)
    });
    drop(sink);
    let stdout = String::from_utf8_lossy(&browser.stdout);
    let stderr = String::from_utf8_lossy(&browser.stderr);
    assert!(
        browser.status.success(),
        "the browser test failed:\n{stdout}\n{stderr}"
    );
    assert!(stdout.contains("gui-test: ok"), "{stdout}\n{stderr}");
    assert!(outcome.is_finished(), "{outcome:?}");
    let resumed: Vec<String> = rx
        .iter()
        .filter_map(|r| match r.entry {
            Entry::Decided {
                decision: Decision::Resume { state, .. },
            } => Some(state),
            _ => None,
        })
        .collect();
    assert_eq!(resumed, ["queue"]);
    let answer = answers
        .try_recv()
        .expect("the page sent the registered answer");
    assert_eq!(
        (answer.answer.as_str(), answer.text.as_str()),
        ("yes", "registered")
    );
    for shot in ["running.png", "asking.png", "finished.png"] {
        assert!(shots.join(shot).is_file(), "no screenshot {shot}");
    }
    gui.shutdown();
}
