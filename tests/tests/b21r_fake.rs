//! The real robot's description against the device emulators, end to end: `lewis up` on a
//! copy of `robots/b21r.toml` whose ports point at emulated devices on pseudo-terminals, and
//! clients talking to the `sick` and `rflex` services through the broker, as applications do.
//!
//! Most tests run the emulators in the test process (so that they can check what the device
//! sent and received, and change its faults at the right moment); the first runs them as
//! `lewis fake-device` processes, as a user does.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::f64::consts::FRAC_PI_2;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use lewis_drivers::faults::Faults;
use lewis_drivers::io::{
    DriverHealth, RflexDriver, RflexDriverConfig, RflexEvent, SickDriver, SickDriverConfig,
};
use lewis_drivers::rflex::{BumperLayout, RflexDeviceConfig};
use lewis_drivers::sick::{ScanLayout, SickDeviceConfig};
use lewis_emulators::{FakeRflex, FakeSick, PoseFile, RflexEmulatorOptions};
use lewis_geometry::Pose2;
use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Broker, RangeFinder, Synchrodrive, SynchrodriveSetVelocity};
use lewis_runtime::client::Client;
use lewis_runtime::ipc::{Ipc, Namespace, Subscriber};
use lewis_runtime::names;
use lewis_tests::fake_device::FakeDeviceProcess;
use lewis_tests::{RangeApp, Up, WATCHDOG, open_ipc, repo_root};

/// `robots/b21r.toml` with its ports replaced by `laser` and `base`, and `changes` made
/// (`(from, to)` text replacements, each of which must apply once).
fn b21r_with_ports(laser: &Path, base: &Path, changes: &[(&str, &str)]) -> String {
    let path: PathBuf = repo_root().join("robots/b21r.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{} ships with the repository: {e}", path.display()));
    let replace = |text: &str, from: &str, to: &str| {
        assert_eq!(text.matches(from).count(), 1, "b21r.toml has one `{from}`");
        text.replace(from, to)
    };
    let port = |path: &Path| format!("port = \"{}\"", path.display());
    let mut text = replace(&text, "port = \"/dev/ttyS0\"", &port(laser));
    text = replace(&text, "port = \"/dev/ttyS1\"", &port(base));
    for (from, to) in changes {
        text = replace(&text, from, to);
    }
    text
}

/// The emulated devices of one test, on pseudo-terminals in its temporary directory.
struct Devices {
    dir: tempfile::TempDir,
    laser: FakeSick,
    base: FakeRflex,
    sent: Sent,
}

impl Devices {
    /// A scanner whose scans are [`Sent::source`]'s (with `laser_faults` from the start) and
    /// a base whose sonar ring reads 0.5 + 0.1 i metres.
    fn start(laser_faults: Faults) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let sent = Sent::default();
        let laser = FakeSick::start(
            SickDeviceConfig {
                faults: laser_faults,
                ..SickDeviceConfig::default()
            },
            sent.source(),
            Some(&dir.path().join("ttySICK")),
        )
        .unwrap();
        let base = FakeRflex::start(
            RflexDeviceConfig::default(),
            |_: &Pose2| (0..48).map(|i| 0.5 + 0.1 * f64::from(i)).collect(),
            RflexEmulatorOptions::default(),
            Some(&dir.path().join("ttyRFLEX")),
        )
        .unwrap();
        Self {
            dir,
            laser,
            base,
            sent,
        }
    }

    /// `lewis up` on the B21r pointing at these devices, in a fresh namespace.
    fn up(self, tag: &str, changes: &[(&str, &str)]) -> (Up, FakeSick, FakeRflex, Sent) {
        let robot = b21r_with_ports(&self.laser.path(), &self.base.path(), changes);
        let mut up = Up::start_in(self.dir, Namespace::unique(tag), &robot);
        up.wait_line("broker up");
        (up, self.laser, self.base, self.sent)
    }
}

/// The millimetre values of every scan the emulated scanner sent, in order.
#[derive(Clone, Default)]
struct Sent(Arc<Mutex<Vec<Vec<u16>>>>);

impl Sent {
    /// A deterministic source: value i of scan k is 500 + 7 i + 13 k millimetres.
    fn source(&self) -> impl FnMut(ScanLayout) -> Vec<f64> + Send + 'static {
        let sent = self.clone();
        move |layout: ScanLayout| {
            let mut scans = sent.0.lock().unwrap();
            let k = scans.len();
            let values: Vec<u16> = (0..layout.value_count())
                .map(|i| u16::try_from(500 + 7 * i + 13 * (k % 300)).unwrap())
                .collect();
            let ranges = values.iter().map(|&mm| f64::from(mm) / 1000.0).collect();
            scans.push(values);
            ranges
        }
    }

    fn scans(&self) -> Vec<Vec<u16>> {
        self.0.lock().unwrap().clone()
    }
}

/// The broker's decisions, read from `/lewis/broker` as they come.
struct Decisions {
    subscriber: Subscriber,
    seen: Vec<Broker>,
}

impl Decisions {
    fn subscribe(ipc: &Ipc) -> Self {
        Self {
            subscriber: ipc
                .subscriber(names::BROKER_CHANNEL, &names::broker_config())
                .expect("the broker's decisions can be read"),
            seen: Vec::new(),
        }
    }

    /// Reads what was published so far and returns everything seen.
    fn read(&mut self) -> &[Broker] {
        while let Some(sample) = self
            .subscriber
            .receive()
            .expect("decisions can be received")
        {
            self.seen
                .push(cdr::from_bytes(sample.bytes()).expect("a broker decision decodes"));
        }
        &self.seen
    }

    /// The rebinding of `client`'s `interface` from `from` to `to`.
    fn rebind(&mut self, client: &str, interface: &str, from: &str, to: &str) -> Broker {
        self.read()
            .iter()
            .find(|d| {
                d.action == "rebind"
                    && d.client == client
                    && d.interface == interface
                    && d.from_service == from
                    && d.to_service == to
            })
            .cloned()
            .unwrap_or_else(|| {
                panic!(
                    "no rebind of {client}'s {interface} from {from} to {to} on /lewis/broker: {:#?}",
                    self.seen
                )
            })
    }
}

#[test]
fn laser_scans_reach_the_client_and_the_sonar_takes_over_when_the_laser_emulator_dies() {
    let dir = tempfile::tempdir().unwrap();
    let laser_port = dir.path().join("ttySICK");
    let base_port = dir.path().join("ttyRFLEX");
    let mut laser_device = FakeDeviceProcess::start("sick", &laser_port, &[]);
    // `--link` is the older name of `--pty`.
    let _base_device = FakeDeviceProcess::start_with("--link", "rflex", &base_port, &[]);
    let robot = b21r_with_ports(&laser_port, &base_port, &[]);

    let mut up = Up::start_in(dir, Namespace::unique("b21r-fake"), &robot);
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 5);

    laser_device.kill();
    app.wait_for("base", 5);
    up.stop();
    let log = up.log();
    assert!(log.contains("rebind app from laser to base"), "{log}");
    assert!(
        log.contains("ttySICK"),
        "the laser's reason names its port: {log}"
    );
}

#[test]
fn a_fake_device_unplugged_by_its_fault_schedule_is_reconnected_by_the_driver() {
    let dir = tempfile::tempdir().unwrap();
    let port = dir.path().join("ttyRFLEX");
    // Long enough after the start for the driver below to have opened the port first.
    let _base = FakeDeviceProcess::start("rflex", &port, &["--fault", "unplug@2s-2500ms"]);
    let mut driver = RflexDriver::open(RflexDriverConfig {
        reconnect_interval: Duration::from_millis(50),
        ..RflexDriverConfig::new(&port)
    })
    .unwrap();
    let deadline = Instant::now() + WATCHDOG;
    let mut disconnected = false;
    loop {
        assert!(
            Instant::now() < deadline,
            "no reconnection: {:?} {:?}",
            driver.stats(),
            driver.health()
        );
        let event = driver.read_event(Duration::from_millis(50));
        disconnected |= matches!(driver.health(), DriverHealth::Disconnected { .. });
        if event == Some(RflexEvent::Reconnected) {
            break;
        }
    }
    assert!(disconnected, "the port went away first");
    assert_eq!(driver.stats().reconnects, 1);
}

#[test]
fn the_scans_the_laser_service_publishes_are_the_ones_the_scanner_sent() {
    let (mut up, _laser, _base, sent) = Devices::start(Faults::default()).up("b21r-scans", &[]);
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut client = Client::<RangeFinder>::connect(&ipc, "app").unwrap();
    let mut received: Vec<RangeFinder> = Vec::new();
    let deadline = Instant::now() + WATCHDOG;
    while received.len() < 5 {
        let left = deadline.saturating_duration_since(Instant::now());
        assert!(!left.is_zero(), "5 laser scans did not come: {received:?}");
        if let Some(sample) = client.recv_timeout(left).unwrap()
            && sample.message.header.provider == "laser"
        {
            received.push(sample.message);
        }
    }
    let sent = sent.scans();
    let millimetres = |scan: &RangeFinder| -> Vec<u16> {
        scan.ranges
            .iter()
            .map(|range| u16::try_from((range * 1000.0).round() as i64).unwrap())
            .collect()
    };
    let first = sent
        .iter()
        .position(|scan| *scan == millimetres(&received[0]))
        .unwrap_or_else(|| panic!("the first scan published was never sent: {:?}", received[0]));
    for (k, scan) in received.iter().enumerate() {
        // Each published scan is the next one the scanner sent: none lost, none altered.
        assert_eq!(millimetres(scan), sent[first + k], "scan {k}");
        for (range, mm) in scan.ranges.iter().zip(&sent[first + k]) {
            assert!((range - f64::from(*mm) / 1000.0).abs() < 1e-12);
        }
        assert_eq!(scan.range_count, 361);
        assert!(scan.uniform);
        assert!((scan.max_range - 8.191).abs() < 1e-12);
        // Mounted 0.12 m ahead, looking ahead: beams from the right, half a degree apart.
        assert!((scan.x_offset - 0.12).abs() < 1e-12);
        assert!((scan.theta_offset + FRAC_PI_2).abs() < 1e-12);
        assert!((scan.theta_separation - 0.5f64.to_radians()).abs() < 1e-12);
    }
    up.stop();
}

#[test]
fn a_silent_laser_is_declared_out_of_service_and_the_broker_moves_the_client_to_the_sonar() {
    let (mut up, laser, _base, _sent) = Devices::start(Faults::default()).up("b21r-silence", &[]);
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut decisions = Decisions::subscribe(&ipc);
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("laser", 3);

    laser.with_device(|device| {
        device.set_faults(Faults {
            silent: true,
            ..Faults::default()
        });
    });
    app.wait_for("base", 3);
    let rebind = decisions.rebind("app", "RangeFinder", "laser", "base");
    assert!(
        rebind.reason.contains("out of service")
            && rebind.reason.contains("no valid data")
            && rebind.reason.contains("ttySICK"),
        "{rebind:?}"
    );
    // The laser was not killed: it still runs, out of service, and watches its scanner.
    assert!(
        !decisions
            .read()
            .iter()
            .any(|d| d.service == "laser" && (d.action == "stop" || d.action == "service-failed")),
        "{:#?}",
        decisions.seen
    );
    up.stop();
}

#[test]
fn probing_a_mute_scanner_keeps_the_laser_alive_and_ends_in_a_failover() {
    let mute = Faults {
        silent: true,
        ..Faults::default()
    };
    // Probing: 4 rates, 2 attempts each, 250 ms per reply: 2 s without an answer, longer
    // than the heartbeat deadline.
    let (mut up, _laser, _base, _sent) = Devices::start(mute).up(
        "b21r-mute",
        &[("reply_timeout_ms = 1000", "reply_timeout_ms = 250")],
    );
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut decisions = Decisions::subscribe(&ipc);
    let mut app = RangeApp::connect(&ipc);
    app.wait_for("base", 3);
    let rebind = decisions.rebind("app", "RangeFinder", "laser", "base");
    assert!(
        rebind.reason.contains("no SICK scanner answered") && rebind.reason.contains("ttySICK"),
        "{rebind:?}"
    );
    let status = up.status();
    assert!(
        !decisions.read().iter().any(|d| d.service == "laser"
            && (d.action == "stop"
                || d.action == "service-failed"
                || d.action == "restart-scheduled")),
        "the laser kept its heartbeats while it probed: {:#?}\n{status}",
        decisions.seen
    );
    up.stop();
}

/// The MOT 7 packet of one axis (PROTOCOLS.md), framed by hand.
fn axis_packet(data: [u8; 14]) -> Vec<u8> {
    let mut body = vec![0x02, 0x00, 0x07, 14];
    body.extend_from_slice(&data);
    let checksum = body.iter().fold(0, |acc, byte| acc ^ byte);
    let mut packet = vec![0x1B, 0x02];
    packet.extend_from_slice(&body);
    packet.push(checksum);
    packet.extend_from_slice(&[0x1B, 0x03]);
    packet
}

/// A Synchrodrive client of the base, as VectorMover is.
fn synchrodrive(ipc: &Rc<Ipc>) -> Client<Synchrodrive> {
    let mut client = Client::<Synchrodrive>::connect(ipc, "mover").unwrap();
    assert_eq!(client.wait_bound(WATCHDOG).unwrap(), "base");
    client
}

#[test]
fn a_velocity_command_to_the_base_service_reaches_the_base_with_the_documented_bytes() {
    let (mut up, _laser, base, _sent) = Devices::start(Faults::default()).up("b21r-drive", &[]);
    let ipc = open_ipc(&up.namespace, "test-mover");
    let mut client = synchrodrive(&ipc);
    // The base is started up (brake released) before it takes commands.
    assert!(base.wait_for(WATCHDOG, |device| !device.brake_engaged()));
    base.clear_host_bytes();
    client
        .call(
            &SynchrodriveSetVelocity {
                translation_velocity: 0.5,
                rotation_velocity: -0.25,
                ..SynchrodriveSetVelocity::default()
            },
            WATCHDOG,
        )
        .unwrap();
    // 0.5 m/s x 103000 = 51500 (C92C), 0.7 m/s^2 x 103000 = 72100 (119A4), torque 30000
    // (7530), forward; 0.25 rad/s x 35000 = 8750 (222E), 1 rad/s^2 x 35000 = 35000 (88B8),
    // backward: the values of robots/b21r.toml.
    let mut expected = axis_packet([
        0, 0, 0, 0xC9, 0x2C, 0, 0x01, 0x19, 0xA4, 0, 0, 0x75, 0x30, 1,
    ]);
    expected.extend(axis_packet([
        1, 0, 0, 0x22, 0x2E, 0, 0, 0x88, 0xB8, 0, 0, 0x75, 0x30, 0,
    ]));
    assert!(
        base.wait_for(WATCHDOG, |device| device.velocities() == (0.5, -0.25)),
        "the base drives as commanded"
    );
    let host = base.host_bytes();
    assert!(
        host.windows(expected.len())
            .any(|window| window == expected),
        "{host:02X?}"
    );
    up.stop();
}

#[test]
fn a_bumper_pressed_on_the_base_shows_in_the_base_services_synchrodrive() {
    let (mut up, _laser, base, _sent) = Devices::start(Faults::default()).up("b21r-bump", &[]);
    let ipc = open_ipc(&up.namespace, "test-mover");
    let mut client = synchrodrive(&ipc);
    let layout = BumperLayout::B21R;
    let next_bumpers = |client: &mut Client<Synchrodrive>, want: &dyn Fn(&[bool]) -> bool| {
        let deadline = Instant::now() + WATCHDOG;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            assert!(!left.is_zero(), "the bumpers never read as expected");
            if let Some(sample) = client.recv_timeout(left).unwrap() {
                let message = sample.message;
                assert_eq!(message.bumper_count, 14);
                if want(&message.bumpers) {
                    return message.bumpers;
                }
            }
        }
    };
    next_bumpers(&mut client, &|bumpers| {
        bumpers.iter().all(|pressed| !pressed)
    });
    let (address, value) = layout.report_for(3, true).unwrap();
    base.with_device(|device| device.set_dio(address, value));
    let pressed = next_bumpers(&mut client, &|bumpers| bumpers.contains(&true));
    let which: Vec<usize> = (0..14).filter(|&i| pressed[i]).collect();
    assert_eq!(which, vec![3]);
    let (address, value) = layout.report_for(3, false).unwrap();
    base.with_device(|device| device.set_dio(address, value));
    next_bumpers(&mut client, &|bumpers| {
        bumpers.iter().all(|pressed| !pressed)
    });
    up.stop();
}

/// The median of the 5 beams straight ahead (index 180 of 361), in m: robust to the
/// simulated noise and dropouts.
fn ahead_m(ranges: &[f64]) -> f64 {
    let mut ahead = ranges[178..=182].to_vec();
    ahead.sort_by(f64::total_cmp);
    ahead[2]
}

#[test]
fn the_laser_emulator_sees_the_wall_nearer_after_the_base_emulator_drove_toward_it() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("state");
    std::fs::create_dir(&state).unwrap();
    let laser_port = dir.path().join("ttySICK");
    let base_port = dir.path().join("ttyRFLEX");
    // In the lobby of the conference floor, facing its north wall, about 5 m away.
    let world = [
        "--world",
        "robots/worlds/conference",
        "--start",
        "3,12.5,90",
    ];
    let shared = ["--robot-state", state.to_str().unwrap()];
    let _base_device =
        FakeDeviceProcess::start("rflex", &base_port, &[&world[..], &shared[..]].concat());
    let _laser_device =
        FakeDeviceProcess::start("sick", &laser_port, &[&world[..], &shared[..]].concat());

    let mut laser = SickDriver::open(SickDriverConfig::new(&laser_port)).unwrap();
    let mut base = RflexDriver::open(RflexDriverConfig::new(&base_port)).unwrap();
    let scan = |laser: &mut SickDriver| {
        let deadline = Instant::now() + WATCHDOG;
        loop {
            assert!(Instant::now() < deadline, "no scan: {:?}", laser.health());
            if let Some(scan) = laser.read_scan(Duration::from_millis(100)) {
                return scan;
            }
        }
    };
    let pose_file = PoseFile::in_dir(&state);
    let start = pose_file.read().unwrap().expect("the base wrote its pose");
    let before = ahead_m(&scan(&mut laser).ranges_m());
    assert!(before < 8.0, "the wall is in range: {before} m");

    // Drive forward 0.5 m (commanding again and again, as a mover does), taking the scans
    // as they come so that none waits in the line.
    let deadline = Instant::now() + WATCHDOG;
    loop {
        base.set_velocity(0.4, 0.0).unwrap();
        base.read_event(Duration::from_millis(20));
        while laser.read_scan(Duration::ZERO).is_some() {}
        let pose = pose_file.read().unwrap().unwrap();
        if pose.y_m - start.y_m >= 0.5 {
            break;
        }
        assert!(Instant::now() < deadline, "the base did not move: {pose:?}");
    }
    base.stop().unwrap();
    // At rest when two odometry reports of the same count come after the stop.
    let deadline = Instant::now() + WATCHDOG;
    let mut resting = 0;
    while resting < 2 {
        assert!(Instant::now() < deadline, "the base did not stop");
        if let Some(RflexEvent::Odometry {
            translation_mps, ..
        }) = base.read_event(Duration::from_millis(100))
        {
            resting = if translation_mps == 0.0 {
                resting + 1
            } else {
                0
            };
        }
    }
    let end = pose_file.read().unwrap().unwrap();
    let driven_m = end.y_m - start.y_m;
    let nearer_by_the_drive = |after: f64| ((before - after) - driven_m).abs() < 0.05;
    // Scans rendered while the base still moved may still be on the line: the first one
    // rendered at rest comes within a few, and every one after it agrees.
    let deadline = Instant::now() + WATCHDOG;
    let mut seen = Vec::new();
    while !seen.last().copied().is_some_and(nearer_by_the_drive) {
        assert!(
            Instant::now() < deadline,
            "the wall never came {driven_m:.3} m nearer than {before:.3} m; ahead: {seen:.3?}"
        );
        seen.push(ahead_m(&scan(&mut laser).ranges_m()));
    }
    for _ in 0..3 {
        let after = ahead_m(&scan(&mut laser).ranges_m());
        assert!(
            nearer_by_the_drive(after),
            "the wall came {:.3} m nearer; the base drove {driven_m:.3} m (from {before:.3} m to {after:.3} m)",
            before - after
        );
    }
    assert!(
        (end.x_m - start.x_m).abs() < 1e-6,
        "straight north: {start:?} to {end:?}"
    );
}
