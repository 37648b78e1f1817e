//! The RFlex driver against the emulated base over real pseudo-terminals: start-up, velocity
//! bytes, odometry, watchdogs, sonar, bumpers, power and reconnection.

#![allow(clippy::unwrap_used)]

use crate::pty_common;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use lewis_drivers::io::{DriverHealth, RflexDriver, RflexDriverConfig, RflexEvent};
use lewis_drivers::rflex::{
    Axis, RflexCommand, RflexDevice, RflexDeviceConfig, StartupParams, startup_sequence,
};
use lewis_emulators::{FakeRflex, RflexEmulatorOptions, SharedPose, Unplug, WorldSonarSource};
use lewis_geometry::Pose2;
use lewis_sim::{SimSonar, SonarConfig};
use pty_common::{WATCHDOG, await_some, conference_world};

struct Bench {
    _dir: tempfile::TempDir,
    link: PathBuf,
    fake: FakeRflex,
}

/// A ring whose transducer i reads 0.5 + 0.1 i metres wherever the robot is.
fn ramp_sonar(_pose: &Pose2) -> Vec<f64> {
    (0..48).map(|i| 0.5 + 0.1 * f64::from(i)).collect()
}

fn bench_with(config: RflexDeviceConfig) -> Bench {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("ttyRFLEX");
    let fake = FakeRflex::start(
        config,
        ramp_sonar,
        RflexEmulatorOptions::default(),
        Some(&link),
    )
    .unwrap();
    Bench {
        _dir: dir,
        link,
        fake,
    }
}

fn bench() -> Bench {
    bench_with(RflexDeviceConfig::default())
}

fn config(path: &Path) -> RflexDriverConfig {
    RflexDriverConfig {
        reconnect_interval: Duration::from_millis(50),
        ..RflexDriverConfig::new(path)
    }
}

/// Pumps the driver until `pick` takes an event.
fn await_event<T>(
    driver: &mut RflexDriver,
    what: &str,
    mut pick: impl FnMut(&RflexDriver, RflexEvent) -> Option<T>,
) -> T {
    await_some(
        what,
        driver,
        |driver| {
            let event = driver.read_event(Duration::from_millis(50))?;
            pick(driver, event)
        },
        |driver| format!("{:?} {:?}", driver.stats(), driver.health()),
    )
}

/// Commands `velocity` as an adapter does (again at every step, which feeds the host
/// watchdog) and pumps the driver until the emulated base satisfies `done`.
fn drive_until(
    driver: &mut RflexDriver,
    fake: &FakeRflex,
    velocity: (f64, f64),
    what: &str,
    mut done: impl FnMut(&RflexDevice) -> bool,
) {
    await_some(
        what,
        driver,
        |driver| {
            driver.set_velocity(velocity.0, velocity.1).unwrap();
            driver.read_event(Duration::from_millis(20));
            fake.with_device(|device| done(device)).then_some(())
        },
        |_| format!("{:?}", fake.with_device(|device| device.kinematics())),
    );
}

fn open_started(bench: &Bench) -> RflexDriver {
    let mut driver = RflexDriver::open(config(&bench.link)).unwrap();
    assert!(
        bench
            .fake
            .wait_for(WATCHDOG, |device| !device.brake_engaged()),
        "the start-up sequence releases the brake"
    );
    await_event(&mut driver, "odometry from both axes", |driver, _| {
        driver.is_odometry_referenced().then_some(())
    });
    driver
}

fn xor(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |acc, byte| acc ^ byte)
}

/// A MOT 7 packet with `data`, framed by hand.
fn axis_packet(data: [u8; 14]) -> Vec<u8> {
    let mut body = vec![0x02, 0x00, 0x07, 14];
    body.extend_from_slice(&data);
    let mut packet = vec![0x1B, 0x02];
    packet.extend_from_slice(&body);
    packet.push(xor(&body));
    packet.extend_from_slice(&[0x1B, 0x03]);
    packet
}

#[test]
fn the_start_up_sequence_reaches_the_base_in_order() {
    let bench = bench();
    let _driver = open_started(&bench);
    let expected = startup_sequence(&StartupParams::default());
    bench.fake.with_device(|device| {
        let received: Vec<_> = device.recent_commands().iter().take(7).copied().collect();
        assert_eq!(received, expected);
        assert!(device.defaults_set());
        assert!(device.odometry_on());
        assert!(device.sonar().is_on());
    });
}

#[test]
fn velocity_commands_reach_the_base_with_the_documented_bytes() {
    let bench = bench();
    let mut driver = open_started(&bench);
    bench.fake.clear_host_bytes();
    driver.set_velocity(0.5, -0.25).unwrap();
    assert!(bench.fake.wait_for(WATCHDOG, |device| {
        device.velocity_command(Axis::Rotation).speed != 0
    }));
    // 0.5 m/s x 103000 = 51500 (C92C), 0.7 m/s^2 x 103000 = 72100 (119A4), torque 30000
    // (7530), forward. 0.25 rad/s x 35000 = 8750 (222E), 1 rad/s^2 x 35000 = 35000 (88B8),
    // backward.
    let translation = axis_packet([
        0, 0, 0, 0xC9, 0x2C, 0, 0x01, 0x19, 0xA4, 0, 0, 0x75, 0x30, 1,
    ]);
    let rotation = axis_packet([1, 0, 0, 0x22, 0x2E, 0, 0, 0x88, 0xB8, 0, 0, 0x75, 0x30, 0]);
    let host = bench.fake.host_bytes();
    let mut expected = translation.clone();
    expected.extend_from_slice(&rotation);
    assert!(
        host.windows(expected.len())
            .any(|window| window == expected),
        "{host:02X?}"
    );
    bench.fake.with_device(|device| {
        let (velocity_mps, turn_rate_radps) = device.velocities();
        assert!((velocity_mps - 0.5).abs() < 1e-12);
        assert!((turn_rate_radps + 0.25).abs() < 1e-12);
    });
}

#[test]
fn odometry_integrates_to_the_true_pose_after_a_drive() {
    let bench = bench();
    let mut driver = open_started(&bench);
    drive_until(
        &mut driver,
        &bench.fake,
        (0.4, 0.0),
        "0.4 m forward",
        |device| device.kinematics().distance_m >= 0.4,
    );
    drive_until(
        &mut driver,
        &bench.fake,
        (0.0, 0.8),
        "a 0.6 rad turn",
        |device| device.kinematics().bearing_rad >= 0.6,
    );
    drive_until(&mut driver, &bench.fake, (0.3, 0.3), "an arc", |device| {
        device.kinematics().distance_m >= 0.8
    });
    driver.stop().unwrap();
    assert!(
        bench
            .fake
            .wait_for(WATCHDOG, |device| device.velocities() == (0.0, 0.0))
    );
    // Reports of both axes taken after the stop carry the final counts.
    for axis in [Axis::Translation, Axis::Rotation] {
        await_event(&mut driver, "a report at rest", |_, event| match event {
            RflexEvent::Odometry {
                axis: reported,
                translation_mps,
                rotation_radps,
                ..
            } if reported == axis && translation_mps == 0.0 && rotation_radps == 0.0 => Some(()),
            _ => None,
        });
    }
    let truth = bench.fake.with_device(|device| device.true_pose());
    let pose = driver.pose();
    assert!(
        (pose.x_m - truth.x_m).hypot(pose.y_m - truth.y_m) < 0.03,
        "{pose:?} against {truth:?}"
    );
    assert!(
        (pose.heading_rad - truth.heading_rad).abs() < 0.01,
        "{pose:?} against {truth:?}"
    );
    assert!(truth.y_m > 0.1, "the drive turned: {truth:?}");
}

#[test]
fn the_host_watchdog_stops_the_robot_when_commands_stop() {
    let bench = bench_with(RflexDeviceConfig {
        watchdog_timeout_ns: 60_000_000_000,
        ..RflexDeviceConfig::default()
    });
    let mut driver = RflexDriver::open(RflexDriverConfig {
        command_timeout: Duration::from_millis(300),
        ..config(&bench.link)
    })
    .unwrap();
    driver.set_velocity(0.3, 0.1).unwrap();
    assert!(
        bench
            .fake
            .wait_for(WATCHDOG, |device| device.velocities().0 > 0.0)
    );
    await_event(&mut driver, "the watchdog stop", |_, event| {
        (event == RflexEvent::WatchdogStop).then_some(())
    });
    assert_eq!(driver.commanded_velocity(), (0.0, 0.0));
    assert_eq!(driver.stats().watchdog_stops, 1);
    assert!(
        bench
            .fake
            .wait_for(WATCHDOG, |device| device.velocities() == (0.0, 0.0))
    );
    bench
        .fake
        .with_device(|device| assert_eq!(device.watchdog_trips(), 0, "the host stopped it"));
}

#[test]
fn the_base_watchdog_stops_the_robot_when_the_host_goes_quiet() {
    let bench = bench_with(RflexDeviceConfig {
        watchdog_timeout_ns: 300_000_000,
        ..RflexDeviceConfig::default()
    });
    let mut driver = RflexDriver::open(config(&bench.link)).unwrap();
    driver.set_velocity(0.3, 0.0).unwrap();
    // The driver is not pumped from here on: no refresh reaches the base.
    assert!(bench.fake.wait_for(WATCHDOG, |device| {
        device.watchdog_trips() == 1 && device.velocities() == (0.0, 0.0)
    }));
}

#[test]
fn sonar_reports_are_decoded_into_ranges_in_metres() {
    let bench = bench();
    let mut driver = open_started(&bench);
    let ranges = await_event(&mut driver, "a sonar report", |_, event| match event {
        RflexEvent::Sonar { ranges_m } => Some(ranges_m),
        _ => None,
    });
    assert_eq!(ranges.len(), 48);
    for (index, range) in ranges.iter().enumerate() {
        let expected = 0.5 + 0.1 * index as f64;
        let range = range.unwrap();
        assert!(
            (range - expected).abs() <= 0.5 / 1476.0,
            "sonar {index}: {range}"
        );
    }
    assert_eq!(driver.sonar_ranges_m(), &ranges[..]);
}

#[test]
fn a_world_backed_base_reports_the_simulated_sonar_at_its_pose() {
    let world = Arc::new(conference_world());
    let origin = Pose2::new(3.0, 12.5, 0.0);
    let sonar_config = SonarConfig {
        range_noise_std_m: 0.0,
        range_noise_fraction: 0.0,
        ..SonarConfig::default()
    };
    let sonar = SimSonar::new(sonar_config.clone(), 3).unwrap();
    let shared_pose = SharedPose::default();
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("ttyRFLEX");
    let _fake = FakeRflex::start(
        RflexDeviceConfig::default(),
        WorldSonarSource::new(Arc::clone(&world), sonar.clone(), origin),
        RflexEmulatorOptions {
            origin,
            shared_pose: Some(shared_pose.clone()),
            pose_file: None,
        },
        Some(&link),
    )
    .unwrap();
    assert_eq!(shared_pose.get(), origin);
    let mut driver = RflexDriver::open(config(&link)).unwrap();
    let ranges = await_event(&mut driver, "a sonar report", |_, event| match event {
        RflexEvent::Sonar { ranges_m } => Some(ranges_m),
        _ => None,
    });
    for (index, mount) in sonar_config.transducers.iter().enumerate() {
        let expected = sonar.true_range(&world, origin, mount);
        let range = ranges[index].unwrap();
        assert!(
            (range - expected).abs() <= 0.5 / 1476.0 + 1e-9,
            "sonar {index}: {range} against {expected}"
        );
    }
    assert!(
        ranges.iter().flatten().any(|&range| range < 4.9),
        "walls in range"
    );
}

#[test]
fn bumpers_and_power_are_reported() {
    let bench = bench();
    let mut driver = open_started(&bench);
    bench.fake.with_device(|device| device.set_dio(0x20, 0b101));
    let report = await_event(&mut driver, "a bumper report", |_, event| match event {
        RflexEvent::Dio(report) if report.address == 0x20 => Some(report),
        _ => None,
    });
    assert_eq!(report.value, 0b101);
    assert_eq!(driver.dio(0x20), Some(0b101));

    driver.request_status().unwrap();
    let (voltage_v, brake_engaged) =
        await_event(&mut driver, "a status report", |_, event| match event {
            RflexEvent::Status {
                voltage_v,
                brake_engaged,
            } => Some((voltage_v, brake_engaged)),
            _ => None,
        });
    assert!((voltage_v - 26.5).abs() < 1e-9);
    assert!(!brake_engaged);
    assert_eq!(driver.voltage_v(), Some(voltage_v));
}

#[test]
fn unplugging_and_replugging_the_base_reconnects_and_restarts_it() {
    let bench = bench();
    let mut driver = open_started(&bench);
    bench.fake.unplug().unwrap();
    await_some(
        "the disconnected health",
        &mut driver,
        |driver| {
            driver.read_event(Duration::from_millis(20));
            matches!(driver.health(), DriverHealth::Disconnected { .. }).then_some(())
        },
        |driver| format!("{:?}", driver.health()),
    );
    assert!(driver.set_velocity(0.1, 0.0).is_err(), "nothing to send to");

    bench.fake.replug().unwrap();
    await_event(&mut driver, "the reconnection", |_, event| {
        (event == RflexEvent::Reconnected).then_some(())
    });
    assert!(bench.fake.wait_for(WATCHDOG, |device| {
        let releases = device.recent_commands().iter();
        releases
            .filter(|command| **command == RflexCommand::BrakeRelease)
            .count()
            == 2
    }));
    await_event(&mut driver, "odometry again", |_, event| {
        matches!(event, RflexEvent::Odometry { .. }).then_some(())
    });
    assert_eq!(driver.health(), DriverHealth::Ok);
    assert_eq!(driver.stats().reconnects, 1);
}

#[test]
fn a_scheduled_unplug_closes_the_port_and_brings_it_back_at_the_same_path() {
    let bench = bench();
    let mut driver = open_started(&bench);
    // Counted from the emulator's start, which is already past: the window opens at once.
    bench.fake.schedule_unplugs(&[Unplug {
        at: Duration::ZERO,
        until: Some(Duration::from_millis(200)),
    }]);
    assert!(
        bench
            .fake
            .wait_stats(WATCHDOG, |stats| stats.replugs == 1 && stats.plugged),
        "{:?}",
        bench.fake.stats()
    );
    assert_eq!(bench.fake.path(), bench.link);
    await_event(&mut driver, "the reconnection", |_, event| {
        (event == RflexEvent::Reconnected).then_some(())
    });
    assert_eq!(driver.stats().reconnects, 1);
}
