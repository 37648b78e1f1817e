//! The host driving the emulated base, as the driver will over a pseudo-terminal.

use std::f64::consts::FRAC_PI_2;

use lewis_geometry::Pose2;

use super::*;
use crate::faults::Faults;

const MS: i64 = 1_000_000;

/// The host's side: sends commands and integrates what comes back.
struct Host {
    deframer: RflexDeframer,
    odometry: OdometryIntegrator,
    sonar: Vec<Option<f64>>,
    statuses: Vec<SysStatus>,
    dio: Vec<DioReport>,
}

impl Host {
    fn new() -> Self {
        Self {
            deframer: RflexDeframer::new(RflexFraming),
            odometry: OdometryIntegrator::new(OdometryConversion::B21R),
            sonar: vec![None; SONAR_COUNT],
            statuses: Vec::new(),
            dio: Vec::new(),
        }
    }

    fn take(&mut self, bytes: &[u8]) {
        for packet in self.deframer.push(bytes) {
            match RflexReport::decode(&packet).unwrap() {
                RflexReport::Odometry(report) => {
                    self.odometry.update(&report);
                }
                RflexReport::Sonar(report) => {
                    for (slot, range) in self
                        .sonar
                        .iter_mut()
                        .zip(report.ranges_m(SONAR_COUNT, SONAR_UNITS_PER_M))
                    {
                        if range.is_some() {
                            *slot = range;
                        }
                    }
                }
                RflexReport::SysStatus(status) => self.statuses.push(status),
                RflexReport::Dio(report) => self.dio.push(report),
                RflexReport::Other(packet) => panic!("unexpected {packet:?}"),
            }
        }
    }

    fn send(&mut self, device: &mut RflexDevice, commands: &[RflexCommand], now_ns: i64) {
        let bytes: Vec<u8> = commands.iter().flat_map(RflexCommand::encode).collect();
        let reply = device.receive(&bytes, now_ns);
        self.take(&reply);
    }

    fn drive(
        &mut self,
        device: &mut RflexDevice,
        velocity_mps: f64,
        turn_rate_radps: f64,
        now_ns: i64,
    ) {
        let conversion = OdometryConversion::B21R;
        let commands = [
            RflexCommand::AxisSetDir(VelocityCommand::from_si(
                Axis::Translation,
                velocity_mps,
                0.7,
                30_000,
                &conversion,
            )),
            RflexCommand::AxisSetDir(VelocityCommand::from_si(
                Axis::Rotation,
                turn_rate_radps,
                1.0,
                35_000,
                &conversion,
            )),
        ];
        self.send(device, &commands, now_ns);
    }
}

fn no_sonar() -> impl FnMut(&Pose2) -> Vec<f64> {
    |_: &Pose2| Vec::new()
}

/// A base after the start-up sequence at time -10 ms and its first odometry reports at 0 (the
/// integrator's reference), and the host that sent it.
fn started() -> (RflexDevice, Host) {
    let mut device = RflexDevice::new(RflexDeviceConfig::default(), -10 * MS);
    let mut host = Host::new();
    let params = StartupParams {
        odometry_period: 10_000,
        ..StartupParams::default()
    };
    host.send(&mut device, &startup_sequence(&params), -10 * MS);
    host.take(&device.tick(0, &mut no_sonar()));
    assert!(host.odometry.is_referenced());
    (device, host)
}

/// Drives for `duration_ns` from `start_ns`, resending the command every 100 ms and ticking
/// every 10 ms; returns the end time.
fn run(
    device: &mut RflexDevice,
    host: &mut Host,
    command: (f64, f64),
    start_ns: i64,
    duration_ns: i64,
) -> i64 {
    let mut now = start_ns;
    let mut sonar = no_sonar();
    while now < start_ns + duration_ns {
        if (now - start_ns) % (100 * MS) == 0 {
            host.drive(device, command.0, command.1, now);
        }
        now += 10 * MS;
        let bytes = device.tick(now, &mut sonar);
        host.take(&bytes);
    }
    now
}

#[test]
fn the_startup_sequence_releases_the_brake_and_turns_reports_on() {
    let (device, _) = started();
    assert!(!device.brake_engaged());
    assert!(device.defaults_set());
    assert!(device.odometry_on());
    assert_eq!(device.sonar(), SonarRun::B21R_ON);
    assert_eq!(device.commands_received(), 7);
    assert_eq!(device.undecodable_packets(), 0);
}

#[test]
fn velocity_commands_reach_the_base_with_their_values() {
    let (mut device, mut host) = started();
    host.drive(&mut device, -0.25, 0.5, 0);
    let translation = device.velocity_command(Axis::Translation);
    assert_eq!(translation.speed, 25_750);
    assert!(!translation.forward);
    assert_eq!(translation.acceleration, 72_100);
    assert_eq!(device.velocity_command(Axis::Rotation).speed, 17_500);
    assert_eq!(device.velocities(), (-0.25, 0.5));
}

#[test]
fn a_straight_drive_integrates_to_the_true_pose() {
    let (mut device, mut host) = started();
    let end = run(&mut device, &mut host, (0.5, 0.0), 0, 2_000 * MS);
    assert_eq!(end, 2_000 * MS);
    let truth = device.true_pose();
    assert!((truth.x_m - 1.0).abs() < 1e-9, "{truth:?}");
    assert!(truth.y_m.abs() < 1e-9);
    let estimate = host.odometry.pose();
    assert!(
        (estimate.x_m - truth.x_m).abs() < 1e-4,
        "{estimate:?} vs {truth:?}"
    );
    assert!(estimate.y_m.abs() < 1e-4);
    assert!((host.odometry.translation_velocity_mps() - 0.5).abs() < 1e-4);
}

#[test]
fn a_rotation_in_place_integrates_to_the_true_heading() {
    let (mut device, mut host) = started();
    run(&mut device, &mut host, (0.0, 0.5), 0, 3_140 * MS);
    let truth = device.true_pose();
    assert!((truth.heading_rad - 1.57).abs() < 1e-9, "{truth:?}");
    let estimate = host.odometry.pose();
    assert!((estimate.heading_rad - truth.heading_rad).abs() < 1e-4);
    assert!(estimate.x_m.abs() < 1e-9 && estimate.y_m.abs() < 1e-9);
}

#[test]
fn an_arc_integrates_close_to_the_true_pose() {
    let (mut device, mut host) = started();
    run(
        &mut device,
        &mut host,
        (0.5, FRAC_PI_2 / 2.0),
        0,
        2_000 * MS,
    );
    let truth = device.true_pose();
    let estimate = host.odometry.pose();
    assert!((truth.heading_rad - FRAC_PI_2).abs() < 1e-4);
    assert!(
        (estimate.x_m - truth.x_m).abs() < 0.01,
        "{estimate:?} vs {truth:?}"
    );
    assert!(
        (estimate.y_m - truth.y_m).abs() < 0.01,
        "{estimate:?} vs {truth:?}"
    );
    assert!((estimate.heading_rad - truth.heading_rad).abs() < 1e-4);
}

#[test]
fn the_watchdog_stops_the_robot_when_commands_stop() {
    let (mut device, mut host) = started();
    host.drive(&mut device, 0.5, 0.0, 0);
    assert_eq!(device.next_event_ns(), Some(10 * MS));
    let mut sonar = no_sonar();
    let mut now = 0;
    while now < 3_000 * MS {
        now += 10 * MS;
        host.take(&device.tick(now, &mut sonar));
    }
    assert_eq!(device.watchdog_trips(), 1);
    assert_eq!(device.velocity_command(Axis::Translation).speed, 0);
    // Moved for exactly the watchdog's second.
    assert!((device.true_pose().x_m - 0.5).abs() < 1e-9);
    assert!((host.odometry.pose().x_m - 0.5).abs() < 1e-4);
}

#[test]
fn the_brake_holds_the_robot_until_released() {
    let mut device = RflexDevice::new(RflexDeviceConfig::default(), 0);
    let mut host = Host::new();
    host.drive(&mut device, 0.5, 0.0, 0);
    device.tick(500 * MS, &mut no_sonar());
    assert_eq!(device.true_pose(), Pose2::default());
    host.send(&mut device, &[RflexCommand::BrakeRelease], 500 * MS);
    host.drive(&mut device, 0.5, 0.0, 500 * MS);
    device.tick(700 * MS, &mut no_sonar());
    assert!((device.true_pose().x_m - 0.1).abs() < 1e-9);
    host.send(&mut device, &[RflexCommand::BrakeSet], 700 * MS);
    device.tick(900 * MS, &mut no_sonar());
    assert!((device.true_pose().x_m - 0.1).abs() < 1e-9);
}

#[test]
fn sonar_reports_carry_the_provided_ranges() {
    let (mut device, mut host) = started();
    let mut ring = |_: &Pose2| (0..SONAR_COUNT).map(|i| 0.2 + 0.1 * i as f64).collect();
    host.take(&device.tick(100 * MS, &mut ring));
    for (index, range) in host.sonar.iter().enumerate() {
        let expected = 0.2 + 0.1 * index as f64;
        let range = range.unwrap_or_else(|| panic!("no range for sonar {index}"));
        assert!(
            (range - expected).abs() <= 0.5 / SONAR_UNITS_PER_M,
            "{index}: {range}"
        );
    }
}

#[test]
fn a_status_request_reports_voltage_and_brake() {
    let mut device = RflexDevice::new(RflexDeviceConfig::default(), 0);
    let mut host = Host::new();
    host.send(&mut device, &[RflexCommand::SysStatusRequest], 0);
    host.send(
        &mut device,
        &[RflexCommand::BrakeRelease, RflexCommand::SysStatusRequest],
        MS,
    );
    let brakes: Vec<bool> = host.statuses.iter().map(SysStatus::brake_engaged).collect();
    assert_eq!(brakes, vec![true, false]);
    assert_eq!(host.statuses[0].voltage_raw, 2_650);
}

#[test]
fn bumper_presses_are_reported_when_dio_reports_are_on() {
    let (mut device, mut host) = started();
    device.set_dio(0x40, 0b0100);
    host.take(&device.tick(50 * MS, &mut no_sonar()));
    assert!(host.dio.is_empty(), "DIO period is 100 ms");
    host.take(&device.tick(100 * MS, &mut no_sonar()));
    assert_eq!(host.dio.len(), 1);
    assert_eq!((host.dio[0].address, host.dio[0].value), (0x40, 0b0100));
}

#[test]
fn noise_and_bad_checksums_are_skipped_and_counted_by_the_host() {
    let (mut device, mut host) = started();
    device.set_faults(Faults {
        noise_bytes: 5,
        corrupt_checksum_every: 3,
        silent: false,
    });
    run(&mut device, &mut host, (0.5, 0.0), 0, 1_000 * MS);
    let stats = host.deframer.stats();
    assert!(stats.checksum_errors > 0);
    assert_eq!(stats.checksum_errors, device.injector().frames_corrupted());
    assert!(stats.frames_ok > 100);
}

#[test]
fn a_silent_base_ignores_commands_and_sends_nothing() {
    let (mut device, mut host) = started();
    device.set_faults(Faults {
        silent: true,
        ..Faults::default()
    });
    host.send(&mut device, &[RflexCommand::BrakeSet], 0);
    assert!(!device.brake_engaged());
    assert!(device.tick(1_000 * MS, &mut no_sonar()).is_empty());
}
