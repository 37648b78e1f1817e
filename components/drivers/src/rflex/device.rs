//! The base's side of the protocol, for the emulator: a state machine that takes the host's
//! bytes and produces the base's reports as time passes.
//!
//! No port and no clock: every call carries the time (`now_ns`, any epoch, never going back).
//! The physics is minimal and kept apart in [`Kinematics`]: the commanded velocities are
//! reached at once (accelerations are recorded, not simulated), the brake holds the robot,
//! and a watchdog zeroes the velocities when commands stop arriving.

use std::collections::VecDeque;

use lewis_geometry::{Pose2, wrap_angle};

use super::{
    Axis, DioReport, OdometryConversion, OdometryReport, RflexCommand, RflexDeframer, RflexFraming,
    RflexPacket, RflexReport, SONAR_COUNT, SONAR_UNITS_PER_M, SonarEcho, SonarReport, SonarRun,
    SysStatus, VelocityCommand,
};
use crate::faults::{FaultInjector, Faults};
use crate::framing::DeframerStats;

/// Echoes per sonar packet: (255 - 8) / 3.
const MAX_ECHOES_PER_PACKET: usize = 82;
/// Commands kept in [`RflexDevice::recent_commands`]; older ones are dropped.
const RECENT_COMMANDS: usize = 256;
/// Odometry and DIO periods are read as microseconds (guessed).
const PERIOD_UNIT_NS: i64 = 1_000;

/// Gives the sonar ranges for the robot's true pose: one per transducer, in metres.
/// Non-finite, negative or too-long ranges are sent as the largest value; missing ones too.
pub trait SonarSource {
    /// The ranges seen from `pose`.
    fn ranges_m(&mut self, pose: &Pose2) -> Vec<f64>;
}

impl<F: FnMut(&Pose2) -> Vec<f64>> SonarSource for F {
    fn ranges_m(&mut self, pose: &Pose2) -> Vec<f64> {
        self(pose)
    }
}

/// How the emulated base behaves.
#[derive(Debug, Clone, PartialEq)]
pub struct RflexDeviceConfig {
    /// Encoder units per metre and per radian.
    pub conversion: OdometryConversion,
    /// Velocities drop to zero when no velocity command arrives for this long.
    pub watchdog_timeout_ns: i64,
    /// Time between sonar reports while the ring runs (emulator setting).
    pub sonar_period_ns: i64,
    /// Transducers reported.
    pub sonar_count: usize,
    /// Sonar units per metre.
    pub sonar_units_per_m: f64,
    /// The raw voltage of status reports (hundredths of a volt before calibration).
    pub voltage_raw: u32,
    /// Injected faults.
    pub faults: Faults,
}

impl Default for RflexDeviceConfig {
    fn default() -> Self {
        Self {
            conversion: OdometryConversion::B21R,
            watchdog_timeout_ns: 1_000_000_000,
            sonar_period_ns: 100_000_000,
            sonar_count: SONAR_COUNT,
            sonar_units_per_m: SONAR_UNITS_PER_M,
            voltage_raw: 2_650,
            faults: Faults::default(),
        }
    }
}

/// The robot's true motion: pose and the accumulated encoder quantities.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Kinematics {
    /// The true pose.
    pub pose: Pose2,
    /// Signed path length driven, what the translation encoder counts.
    pub distance_m: f64,
    /// Signed angle turned, what the rotation encoder counts.
    pub bearing_rad: f64,
}

impl Kinematics {
    /// Moves at constant velocities for `dt_s` seconds along the exact arc.
    pub fn advance(&mut self, velocity_mps: f64, turn_rate_radps: f64, dt_s: f64) {
        if dt_s <= 0.0 {
            return;
        }
        let heading = self.pose.heading_rad;
        let turn = turn_rate_radps * dt_s;
        let distance = velocity_mps * dt_s;
        if turn.abs() < 1e-12 {
            self.pose.x_m += distance * heading.cos();
            self.pose.y_m += distance * heading.sin();
        } else {
            let radius = distance / turn;
            self.pose.x_m += radius * ((heading + turn).sin() - heading.sin());
            self.pose.y_m -= radius * ((heading + turn).cos() - heading.cos());
        }
        self.pose.heading_rad = wrap_angle(heading + turn);
        self.distance_m += distance;
        self.bearing_rad += turn;
    }
}

/// A periodic report: its period and when it is next due.
#[derive(Debug, Clone, Copy, Default)]
struct Schedule {
    period_ns: i64,
    next_ns: Option<i64>,
}

impl Schedule {
    fn start(&mut self, period_ns: i64, now_ns: i64) {
        self.period_ns = period_ns;
        self.next_ns = (period_ns > 0).then_some(now_ns + period_ns);
    }

    /// Whether a report is due; if so, schedules the next one (never a burst of catch-ups).
    fn due(&mut self, now_ns: i64) -> bool {
        match self.next_ns {
            Some(next) if next <= now_ns => {
                let following = next + self.period_ns;
                self.next_ns = Some(if following <= now_ns {
                    now_ns + self.period_ns
                } else {
                    following
                });
                true
            }
            _ => false,
        }
    }
}

/// The emulated base.
#[derive(Debug, Clone)]
pub struct RflexDevice {
    config: RflexDeviceConfig,
    deframer: RflexDeframer,
    injector: FaultInjector,
    start_ns: i64,
    now_ns: i64,
    kinematics: Kinematics,
    brake_engaged: bool,
    defaults_set: bool,
    translation: VelocityCommand,
    rotation: VelocityCommand,
    last_velocity_command_ns: Option<i64>,
    watchdog_trips: u64,
    odometry: Schedule,
    odometry_mask: u32,
    sonar: SonarRun,
    sonar_schedule: Schedule,
    dio: Schedule,
    pending_dio: VecDeque<DioReport>,
    recent_commands: VecDeque<RflexCommand>,
    commands_received: u64,
    undecodable_packets: u64,
}

impl RflexDevice {
    /// A base just powered up at `now_ns`: brake engaged, no reports, at the origin.
    pub fn new(config: RflexDeviceConfig, now_ns: i64) -> Self {
        let faults = config.faults;
        Self {
            config,
            deframer: RflexDeframer::new(RflexFraming),
            injector: FaultInjector::new(faults),
            start_ns: now_ns,
            now_ns,
            kinematics: Kinematics::default(),
            brake_engaged: true,
            defaults_set: false,
            translation: VelocityCommand::stop(Axis::Translation, 0),
            rotation: VelocityCommand::stop(Axis::Rotation, 0),
            last_velocity_command_ns: None,
            watchdog_trips: 0,
            odometry: Schedule::default(),
            odometry_mask: 0,
            sonar: SonarRun::OFF,
            sonar_schedule: Schedule::default(),
            dio: Schedule::default(),
            pending_dio: VecDeque::new(),
            recent_commands: VecDeque::new(),
            commands_received: 0,
            undecodable_packets: 0,
        }
    }

    /// Takes bytes from the host at `now_ns`; returns the replies (status reports).
    pub fn receive(&mut self, bytes: &[u8], now_ns: i64) -> Vec<u8> {
        self.advance(now_ns);
        let mut out = Vec::new();
        if self.injector.faults().silent {
            return out;
        }
        for frame in self.deframer.push(bytes) {
            let command = RflexPacket::decode(&frame).and_then(|p| RflexCommand::from_packet(&p));
            match command {
                Ok(command) => self.execute(command, &mut out),
                Err(_) => self.undecodable_packets += 1,
            }
        }
        out
    }

    /// Advances to `now_ns` and returns the reports due: odometry (one packet per axis in the
    /// mask), sonar (ranges from `sonar` at the true pose) and queued digital I/O.
    pub fn tick(&mut self, now_ns: i64, sonar: &mut dyn SonarSource) -> Vec<u8> {
        self.advance(now_ns);
        let mut out = Vec::new();
        let silent = self.injector.faults().silent;
        if self.odometry.due(self.now_ns) && !silent {
            for axis in [Axis::Translation, Axis::Rotation] {
                if self.odometry_mask & (1 << axis.number()) != 0 {
                    let report = RflexReport::Odometry(self.odometry_report(axis));
                    self.send(&report, &mut out);
                }
            }
        }
        if self.sonar_schedule.due(self.now_ns) && !silent {
            let pose = self.kinematics.pose;
            let mut ranges_m = sonar.ranges_m(&pose);
            ranges_m.resize(self.config.sonar_count, f64::INFINITY);
            let units_per_m = self.config.sonar_units_per_m;
            let echoes: Vec<SonarEcho> = ranges_m
                .iter()
                .enumerate()
                .map(|(index, &range_m)| SonarEcho {
                    id: u8::try_from(index).unwrap_or(u8::MAX),
                    range: to_sonar_units(range_m, units_per_m),
                })
                .collect();
            let timestamp = self.timestamp();
            for chunk in echoes.chunks(MAX_ECHOES_PER_PACKET) {
                let report = RflexReport::Sonar(SonarReport {
                    word0: 0,
                    timestamp,
                    echoes: chunk.to_vec(),
                });
                self.send(&report, &mut out);
            }
        }
        if self.dio.due(self.now_ns) && !silent {
            while let Some(report) = self.pending_dio.pop_front() {
                self.send(&RflexReport::Dio(report), &mut out);
            }
        }
        out
    }

    /// When [`RflexDevice::tick`] next has something to send or the watchdog next fires:
    /// what the I/O loop sleeps until.
    pub fn next_event_ns(&self) -> Option<i64> {
        [
            self.odometry.next_ns,
            self.sonar_schedule.next_ns,
            self.dio.next_ns.filter(|_| !self.pending_dio.is_empty()),
            self.watchdog_deadline_ns(),
        ]
        .into_iter()
        .flatten()
        .min()
    }

    /// Queues a digital I/O report (a bumper press), sent when DIO reports are on.
    pub fn set_dio(&mut self, address: u8, value: u16) {
        let report = DioReport {
            timestamp: self.timestamp(),
            address,
            value,
        };
        self.pending_dio.push_back(report);
        while self.pending_dio.len() > RECENT_COMMANDS {
            self.pending_dio.pop_front();
        }
    }

    /// The true pose.
    pub fn true_pose(&self) -> Pose2 {
        self.kinematics.pose
    }

    /// The true motion, encoder quantities included.
    pub fn kinematics(&self) -> Kinematics {
        self.kinematics
    }

    /// Whether the brake holds the robot (it does at power-up).
    pub fn brake_engaged(&self) -> bool {
        self.brake_engaged
    }

    /// Whether `MOT 10` (set defaults) has been received.
    pub fn defaults_set(&self) -> bool {
        self.defaults_set
    }

    /// The velocity command in force on `axis` (zero after the watchdog fired).
    pub fn velocity_command(&self, axis: Axis) -> VelocityCommand {
        match axis {
            Axis::Translation => self.translation,
            Axis::Rotation => self.rotation,
        }
    }

    /// The velocities the robot moves at: (m/s, rad/s), zero while braked.
    pub fn velocities(&self) -> (f64, f64) {
        if self.brake_engaged {
            return (0.0, 0.0);
        }
        let conversion = self.config.conversion;
        (
            self.translation.velocity() as f64 / conversion.distance_units_per_m,
            self.rotation.velocity() as f64 / conversion.angle_units_per_rad,
        )
    }

    /// Times the watchdog stopped a moving robot.
    pub fn watchdog_trips(&self) -> u64 {
        self.watchdog_trips
    }

    /// Whether odometry reports are on.
    pub fn odometry_on(&self) -> bool {
        self.odometry.next_ns.is_some()
    }

    /// The sonar settings in force.
    pub fn sonar(&self) -> SonarRun {
        self.sonar
    }

    /// The last commands received, oldest first (at most 256).
    pub fn recent_commands(&self) -> &VecDeque<RflexCommand> {
        &self.recent_commands
    }

    /// Commands received in all.
    pub fn commands_received(&self) -> u64 {
        self.commands_received
    }

    /// Well-framed packets that were not a known command.
    pub fn undecodable_packets(&self) -> u64 {
        self.undecodable_packets
    }

    /// What the base's deframer saw of the host's bytes.
    pub fn host_stats(&self) -> DeframerStats {
        self.deframer.stats()
    }

    /// The injected faults.
    pub fn faults(&self) -> Faults {
        self.injector.faults()
    }

    /// Changes the injected faults.
    pub fn set_faults(&mut self, faults: Faults) {
        self.injector.set_faults(faults);
    }

    /// The fault injector's counters.
    pub fn injector(&self) -> &FaultInjector {
        &self.injector
    }

    fn execute(&mut self, command: RflexCommand, out: &mut Vec<u8>) {
        self.commands_received += 1;
        self.recent_commands.push_back(command);
        if self.recent_commands.len() > RECENT_COMMANDS {
            self.recent_commands.pop_front();
        }
        let now_ns = self.now_ns;
        match command {
            RflexCommand::SystemReportRequest { period, mask } => {
                self.odometry_mask = mask;
                let period_ns = if mask == 0 { 0 } else { period_ns(period) };
                self.odometry.start(period_ns, now_ns);
            }
            RflexCommand::DioReportsRequest { period } => {
                self.dio.start(period_ns(period), now_ns);
            }
            RflexCommand::SetDefaults => self.defaults_set = true,
            RflexCommand::AxisSetDir(velocity) => {
                match velocity.axis {
                    Axis::Translation => self.translation = velocity,
                    Axis::Rotation => self.rotation = velocity,
                }
                self.last_velocity_command_ns = Some(now_ns);
            }
            RflexCommand::SonarRun(run) => {
                self.sonar = run;
                let period_ns = if run.is_on() {
                    self.config.sonar_period_ns
                } else {
                    0
                };
                self.sonar_schedule.start(period_ns, now_ns);
            }
            RflexCommand::BrakeRelease => self.brake_engaged = false,
            RflexCommand::BrakeSet => self.brake_engaged = true,
            RflexCommand::SysStatusRequest => {
                let status = RflexReport::SysStatus(SysStatus {
                    timestamp: self.timestamp(),
                    voltage_raw: self.config.voltage_raw,
                    brake: u8::from(self.brake_engaged),
                });
                self.send(&status, out);
            }
        }
    }

    fn moving_commanded(&self) -> bool {
        self.translation.speed != 0 || self.rotation.speed != 0
    }

    fn watchdog_deadline_ns(&self) -> Option<i64> {
        if !self.moving_commanded() {
            return None;
        }
        self.last_velocity_command_ns
            .map(|last| last.saturating_add(self.config.watchdog_timeout_ns))
    }

    /// Integrates the motion up to `now_ns`, firing the watchdog on the way when due.
    fn advance(&mut self, now_ns: i64) {
        if now_ns <= self.now_ns {
            return;
        }
        if let Some(deadline) = self.watchdog_deadline_ns()
            && deadline < now_ns
        {
            self.integrate_to(deadline.max(self.now_ns));
            self.translation.speed = 0;
            self.rotation.speed = 0;
            self.watchdog_trips += 1;
        }
        self.integrate_to(now_ns);
    }

    fn integrate_to(&mut self, now_ns: i64) {
        let (velocity_mps, turn_rate_radps) = self.velocities();
        let dt_s = (now_ns - self.now_ns) as f64 * 1e-9;
        self.kinematics.advance(velocity_mps, turn_rate_radps, dt_s);
        self.now_ns = now_ns;
    }

    fn odometry_report(&self, axis: Axis) -> OdometryReport {
        let command = self.velocity_command(axis);
        let factor = self.config.conversion.units_per(axis);
        let (position, velocity) = match axis {
            Axis::Translation => (self.kinematics.distance_m, self.velocities().0),
            Axis::Rotation => (self.kinematics.bearing_rad, self.velocities().1),
        };
        OdometryReport {
            word0: 0,
            timestamp: self.timestamp(),
            axis,
            position: wrap_counts(position * factor),
            velocity: wrap_counts(velocity * factor),
            acceleration: command.acceleration,
            torque: command.torque,
        }
    }

    /// Microseconds since power-up, wrapping (the unit of the base's timestamps is guessed).
    fn timestamp(&self) -> u32 {
        ((self.now_ns - self.start_ns) / 1_000) as u32
    }

    fn send(&mut self, report: &RflexReport, out: &mut Vec<u8>) {
        // Reports built here always fit a packet.
        if let Ok(packet) = report.encode() {
            let checksum_index = packet.len() - 3;
            self.injector.emit(&packet, checksum_index, out);
        }
    }
}

fn period_ns(period: u32) -> i64 {
    i64::from(period) * PERIOD_UNIT_NS
}

/// Encoder counts as the base's 32-bit registers hold them: wrapping.
fn wrap_counts(value: f64) -> i32 {
    (value.round() as i64) as i32
}

fn to_sonar_units(range_m: f64, units_per_m: f64) -> u16 {
    let value = range_m * units_per_m;
    if value.is_finite() && value >= 0.0 && value < f64::from(u16::MAX) {
        value.round() as u16
    } else {
        u16::MAX
    }
}
