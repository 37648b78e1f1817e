//! The host's side of the iRobot RFlex base over a serial port: the start-up sequence,
//! velocity commands per axis in the robot's RFlex units, odometry integrated into a pose, the
//! sonar ring in metres, digital I/O (bumpers), power; a host-side watchdog that stops the
//! robot when the caller stops commanding it; health; reconnection when the port comes back.
//!
//! Reads block for at most a caller's timeout ([`RflexDriver::read_event`]), which also runs
//! the watchdog, resends the current velocity so that the base's own watchdog stays quiet
//! while the caller is alive, and asks for status reports.

use std::collections::{BTreeMap, VecDeque};
use std::os::fd::BorrowedFd;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use lewis_geometry::Pose2;

use super::health::DriverHealth;
use super::link::{LinkDown, SerialLink};
use super::port::{LineParity, PortError};
use super::receiver::RflexReceiver;
use super::retry::Retry;
use crate::framing::DeframerStats;
use crate::rflex::{
    Axis, DioReport, OdometryConversion, OdometryIntegrator, RflexCommand, RflexPacket,
    RflexReport, SONAR_COUNT, SONAR_UNITS_PER_M, StartupParams, VelocityCommand, startup_sequence,
};

/// The RFlex's only rate.
const RFLEX_BAUD_BPS: u32 = 115_200;

/// How the driver talks to the base.
#[derive(Debug, Clone, PartialEq)]
pub struct RflexDriverConfig {
    /// The serial port.
    pub path: PathBuf,
    /// The robot file's conversion factors (RFlex units per metre and per radian).
    pub conversion: OdometryConversion,
    /// The start-up sequence's parameters.
    pub startup: StartupParams,
    /// Acceleration sent with translation commands, in m/s^2.
    pub translation_acceleration_mps2: f64,
    /// Acceleration sent with rotation commands, in rad/s^2.
    pub rotation_acceleration_radps2: f64,
    /// The torque limit sent with velocity commands (RFlex units; Player's value guessed).
    pub torque: u32,
    /// The host watchdog: no [`RflexDriver::set_velocity`] for this long stops the robot.
    pub command_timeout: Duration,
    /// The current velocity is sent again this often while commands are fresh.
    pub command_refresh: Duration,
    /// No odometry report for this long is [`DriverHealth::NoData`].
    pub report_deadline: Duration,
    /// Status (power, brake) is asked for this often; `None`: never.
    pub status_period: Option<Duration>,
    /// Transducers in the sonar ring.
    pub sonar_count: usize,
    /// Sonar units per metre.
    pub sonar_units_per_m: f64,
    /// Added to raw voltage / 100 (the robot's calibration).
    pub voltage_offset_v: f64,
    /// A fraction of bad checksums among the recent packets above this is
    /// [`DriverHealth::ChecksumErrors`].
    pub checksum_error_threshold: f64,
    /// Packets in the checksum error window.
    pub checksum_window: usize,
    /// Time between attempts to reopen a port that went away.
    pub reconnect_interval: Duration,
}

impl RflexDriverConfig {
    /// The B21r's defaults on `path`: the PROTOCOLS.md conversions, Player's start-up values,
    /// 0.7 m/s^2 and 1 rad/s^2, torque 30000 (guessed), a 1 s host watchdog refreshed every
    /// 200 ms, 1 s report deadline, status every second, 48 sonars at 1476 units per metre,
    /// checksum threshold 50% over 40 packets, reconnection every second.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self {
            path: path.into(),
            conversion: OdometryConversion::B21R,
            startup: StartupParams::default(),
            translation_acceleration_mps2: 0.7,
            rotation_acceleration_radps2: 1.0,
            torque: 30_000,
            command_timeout: Duration::from_secs(1),
            command_refresh: Duration::from_millis(200),
            report_deadline: Duration::from_secs(1),
            status_period: Some(Duration::from_secs(1)),
            sonar_count: SONAR_COUNT,
            sonar_units_per_m: SONAR_UNITS_PER_M,
            voltage_offset_v: 0.0,
            checksum_error_threshold: 0.5,
            checksum_window: 40,
            reconnect_interval: Duration::from_secs(1),
        }
    }
}

/// Why the base could not be opened or commanded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RflexDriverError {
    /// The port could not be opened.
    #[error(transparent)]
    Port(#[from] PortError),
    /// The port is away (the driver retries while [`RflexDriver::read_event`] is called).
    #[error("the RFlex base is disconnected: {reason}")]
    Disconnected {
        /// What happened.
        reason: String,
    },
}

/// Something the base reported, decoded.
#[derive(Debug, Clone, PartialEq)]
pub enum RflexEvent {
    /// An odometry report of one axis moved the integrated pose.
    Odometry {
        /// The axis reported.
        axis: Axis,
        /// The integrated pose (in the frame of the first reports).
        pose: Pose2,
        /// The last reported translational velocity, in m/s.
        translation_mps: f64,
        /// The last reported rotational velocity, in rad/s.
        rotation_radps: f64,
    },
    /// A sonar report: the whole ring, latest range of every transducer (`None`: not yet).
    Sonar {
        /// Ranges in metres by transducer index.
        ranges_m: Vec<Option<f64>>,
    },
    /// A digital I/O report (the bumpers report here).
    Dio(DioReport),
    /// A status report.
    Status {
        /// Battery voltage.
        voltage_v: f64,
        /// Whether the brake holds the robot.
        brake_engaged: bool,
    },
    /// The host watchdog stopped the robot: no velocity command within the timeout.
    WatchdogStop,
    /// The port came back and the start-up sequence was sent again.
    Reconnected,
    /// A packet of a kind this driver does not interpret.
    Other(RflexPacket),
}

/// What the driver counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RflexStats {
    /// Odometry reports.
    pub odometry_reports: u64,
    /// Sonar reports.
    pub sonar_reports: u64,
    /// Packets with a good checksum that could not be decoded.
    pub undecodable_packets: u64,
    /// Velocity commands sent (one per axis each).
    pub velocity_commands: u64,
    /// Times the host watchdog stopped the robot.
    pub watchdog_stops: u64,
    /// The deframer's counters.
    pub frames: DeframerStats,
    /// Times the port came back.
    pub reconnects: u64,
}

/// The commanded velocities and when they were last asked for and last sent.
#[derive(Debug, Clone, Copy)]
struct Command {
    translation_mps: f64,
    rotation_radps: f64,
    asked_at: Instant,
    sent_at: Instant,
}

impl Command {
    fn is_moving(&self) -> bool {
        self.translation_mps != 0.0 || self.rotation_radps != 0.0
    }
}

/// The driver of one base.
#[derive(Debug)]
pub struct RflexDriver {
    config: RflexDriverConfig,
    link: SerialLink,
    receiver: RflexReceiver,
    events: VecDeque<RflexEvent>,
    stats: RflexStats,
    odometry: OdometryIntegrator,
    /// The pose where the current integrator's frame starts (moves at a reconnection).
    pose_offset: Pose2,
    sonar_ranges_m: Vec<Option<f64>>,
    dio: BTreeMap<u8, u16>,
    voltage_v: Option<f64>,
    brake_engaged: Option<bool>,
    command: Command,
    next_status_at: Instant,
    started_at: Instant,
    last_report_at: Option<Instant>,
    down_reason: Option<String>,
    retry: Retry,
    buf: Vec<u8>,
}

impl RflexDriver {
    /// Opens the port at 115200 baud and sends the start-up sequence (odometry and bumper
    /// reports on, defaults, zero velocity, sonar on, brake released).
    pub fn open(config: RflexDriverConfig) -> Result<Self, RflexDriverError> {
        let link = SerialLink::open(&config.path, RFLEX_BAUD_BPS, LineParity::None)?;
        let now = Instant::now();
        let mut driver = Self {
            retry: Retry::new(config.reconnect_interval),
            receiver: RflexReceiver::new(config.checksum_window),
            events: VecDeque::new(),
            stats: RflexStats::default(),
            odometry: OdometryIntegrator::new(config.conversion),
            pose_offset: Pose2::default(),
            sonar_ranges_m: vec![None; config.sonar_count],
            dio: BTreeMap::new(),
            voltage_v: None,
            brake_engaged: None,
            command: Command {
                translation_mps: 0.0,
                rotation_radps: 0.0,
                asked_at: now,
                sent_at: now,
            },
            next_status_at: now,
            started_at: now,
            last_report_at: None,
            down_reason: None,
            buf: vec![0; 4096],
            config,
            link,
        };
        driver
            .start_up()
            .map_err(|down| RflexDriverError::Disconnected {
                reason: down.reason,
            })?;
        Ok(driver)
    }

    /// Commands the velocities (m/s forward, rad/s counter-clockwise): one `MOT 7` packet per
    /// axis. Also feeds the host watchdog.
    pub fn set_velocity(
        &mut self,
        translation_mps: f64,
        rotation_radps: f64,
    ) -> Result<(), RflexDriverError> {
        let now = Instant::now();
        self.command = Command {
            translation_mps,
            rotation_radps,
            asked_at: now,
            sent_at: now,
        };
        self.send_velocity()
    }

    /// Commands zero velocity.
    pub fn stop(&mut self) -> Result<(), RflexDriverError> {
        self.set_velocity(0.0, 0.0)
    }

    /// Engages (true) or releases the brake.
    pub fn set_brake(&mut self, engaged: bool) -> Result<(), RflexDriverError> {
        let command = if engaged {
            RflexCommand::BrakeSet
        } else {
            RflexCommand::BrakeRelease
        };
        self.send(&[command])
    }

    /// Asks for a status report (voltage, brake), which comes as [`RflexEvent::Status`].
    pub fn request_status(&mut self) -> Result<(), RflexDriverError> {
        self.send(&[RflexCommand::SysStatusRequest])
    }

    /// The next event, waiting at most `timeout` (zero: only what has arrived); `None` when
    /// none came. Runs the host watchdog and the periodic resends; a port that went away is
    /// reopened every `reconnect_interval` while this is called.
    pub fn read_event(&mut self, timeout: Duration) -> Option<RflexEvent> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(event) = self.events.pop_front() {
                return Some(event);
            }
            if !self.link.is_open() {
                self.reconnect(deadline);
                if Instant::now() >= deadline && self.events.is_empty() {
                    return None;
                }
                continue;
            }
            let now = Instant::now();
            if let Err(down) = self.run_timers(now) {
                self.lost(down);
                continue;
            }
            if !self.events.is_empty() {
                continue;
            }
            let remaining = deadline.saturating_duration_since(now);
            let wait = self.next_timer().map_or(remaining, |at| {
                remaining.min(at.saturating_duration_since(now))
            });
            match self.read_some(wait) {
                Ok(_) if remaining.is_zero() => return self.events.pop_front(),
                Ok(_) => {}
                Err(down) => self.lost(down),
            }
        }
    }

    /// Makes the integrated pose `pose` from now on (odometry keeps integrating from there).
    pub fn reset_pose(&mut self, pose: Pose2) {
        let reference = self.odometry.pose();
        // The integrator's frame is kept: the offset is chosen so that it maps there.
        let (sin, cos) = (pose.heading_rad - reference.heading_rad).sin_cos();
        let heading_rad = pose.heading_rad - reference.heading_rad;
        self.pose_offset = Pose2 {
            x_m: pose.x_m - (cos * reference.x_m - sin * reference.y_m),
            y_m: pose.y_m - (sin * reference.x_m + cos * reference.y_m),
            heading_rad: heading_rad.sin().atan2(heading_rad.cos()),
        };
    }

    /// The integrated pose.
    pub fn pose(&self) -> Pose2 {
        compose(self.pose_offset, self.odometry.pose())
    }

    /// The last reported velocities: (m/s, rad/s).
    pub fn velocities(&self) -> (f64, f64) {
        (
            self.odometry.translation_velocity_mps(),
            self.odometry.rotation_velocity_radps(),
        )
    }

    /// Whether both axes have reported since the start (or the reconnection): before that,
    /// motion is not integrated.
    pub fn is_odometry_referenced(&self) -> bool {
        self.odometry.is_referenced()
    }

    /// The velocities last commanded (zero after the watchdog fired): (m/s, rad/s).
    pub fn commanded_velocity(&self) -> (f64, f64) {
        (self.command.translation_mps, self.command.rotation_radps)
    }

    /// The latest range of every transducer, in metres.
    pub fn sonar_ranges_m(&self) -> &[Option<f64>] {
        &self.sonar_ranges_m
    }

    /// The latest value at a digital I/O address (bumpers: one bit per panel).
    pub fn dio(&self, address: u8) -> Option<u16> {
        self.dio.get(&address).copied()
    }

    /// The latest battery voltage.
    pub fn voltage_v(&self) -> Option<f64> {
        self.voltage_v
    }

    /// Whether the brake holds the robot, as last reported.
    pub fn brake_engaged(&self) -> Option<bool> {
        self.brake_engaged
    }

    /// What the driver thinks of the base now.
    pub fn health(&self) -> DriverHealth {
        let path = self.config.path.clone();
        if let Some(reason) = &self.down_reason {
            return DriverHealth::Disconnected {
                path,
                reason: reason.clone(),
            };
        }
        let since = self
            .last_report_at
            .map_or(self.started_at, |last| last.max(self.started_at));
        let silent_for = since.elapsed();
        if silent_for > self.config.report_deadline {
            return DriverHealth::NoData {
                path,
                silent_for,
                deadline: self.config.report_deadline,
            };
        }
        let error_rate = self.receiver.error_rate();
        if error_rate > self.config.checksum_error_threshold {
            return DriverHealth::ChecksumErrors {
                path,
                error_rate,
                threshold: self.config.checksum_error_threshold,
            };
        }
        DriverHealth::Ok
    }

    /// The counters so far.
    pub fn stats(&self) -> RflexStats {
        RflexStats {
            frames: self.receiver.frames(),
            undecodable_packets: self.receiver.undecodable(),
            ..self.stats
        }
    }

    /// The configuration.
    pub fn config(&self) -> &RflexDriverConfig {
        &self.config
    }

    /// The port's descriptor while it is open (readable: call [`RflexDriver::read_event`]
    /// with a zero timeout; the timers also need `read_event` calls, at least every
    /// `command_refresh`).
    pub fn fd(&self) -> Option<BorrowedFd<'_>> {
        self.link.fd()
    }

    fn start_up(&mut self) -> Result<(), LinkDown> {
        let mut bytes = Vec::new();
        for command in startup_sequence(&self.config.startup) {
            bytes.extend(command.encode());
        }
        self.link.write_all(&bytes)?;
        let now = Instant::now();
        self.started_at = now;
        self.last_report_at = None;
        self.command = Command {
            translation_mps: 0.0,
            rotation_radps: 0.0,
            asked_at: now,
            sent_at: now,
        };
        self.receiver.clear_errors();
        Ok(())
    }

    fn velocity_commands(&self) -> [RflexCommand; 2] {
        let conversion = &self.config.conversion;
        [
            RflexCommand::AxisSetDir(VelocityCommand::from_si(
                Axis::Translation,
                self.command.translation_mps,
                self.config.translation_acceleration_mps2,
                self.config.torque,
                conversion,
            )),
            RflexCommand::AxisSetDir(VelocityCommand::from_si(
                Axis::Rotation,
                self.command.rotation_radps,
                self.config.rotation_acceleration_radps2,
                self.config.torque,
                conversion,
            )),
        ]
    }

    fn send_velocity(&mut self) -> Result<(), RflexDriverError> {
        let commands = self.velocity_commands();
        self.send(&commands)?;
        self.command.sent_at = Instant::now();
        self.stats.velocity_commands += 1;
        Ok(())
    }

    fn send(&mut self, commands: &[RflexCommand]) -> Result<(), RflexDriverError> {
        let mut bytes = Vec::new();
        for command in commands {
            bytes.extend(command.encode());
        }
        if let Some(reason) = &self.down_reason {
            return Err(RflexDriverError::Disconnected {
                reason: reason.clone(),
            });
        }
        self.link.write_all(&bytes).map_err(|down| {
            let reason = down.reason.clone();
            self.lost(down);
            RflexDriverError::Disconnected { reason }
        })
    }

    /// The watchdog, the velocity refresh and the status request, when due.
    fn run_timers(&mut self, now: Instant) -> Result<(), LinkDown> {
        if self.command.is_moving() {
            if now.duration_since(self.command.asked_at) >= self.config.command_timeout {
                self.command.translation_mps = 0.0;
                self.command.rotation_radps = 0.0;
                self.stats.watchdog_stops += 1;
                self.events.push_back(RflexEvent::WatchdogStop);
                self.write_commands(&self.velocity_commands())?;
                self.command.sent_at = now;
            } else if now.duration_since(self.command.sent_at) >= self.config.command_refresh {
                self.write_commands(&self.velocity_commands())?;
                self.command.sent_at = now;
                self.stats.velocity_commands += 1;
            }
        }
        if let Some(period) = self.config.status_period
            && now >= self.next_status_at
        {
            self.next_status_at = now + period;
            self.write_commands(&[RflexCommand::SysStatusRequest])?;
        }
        Ok(())
    }

    /// When [`RflexDriver::run_timers`] next has something to do.
    fn next_timer(&self) -> Option<Instant> {
        let command = self.command.is_moving().then(|| {
            (self.command.asked_at + self.config.command_timeout)
                .min(self.command.sent_at + self.config.command_refresh)
        });
        let status = self.config.status_period.map(|_| self.next_status_at);
        command.into_iter().chain(status).min()
    }

    fn write_commands(&mut self, commands: &[RflexCommand]) -> Result<(), LinkDown> {
        let mut bytes = Vec::new();
        for command in commands {
            bytes.extend(command.encode());
        }
        self.link.write_all(&bytes)
    }

    fn read_some(&mut self, timeout: Duration) -> Result<usize, LinkDown> {
        let count = self.link.read(&mut self.buf, timeout)?;
        if count == 0 {
            return Ok(0);
        }
        for report in self.receiver.push(&self.buf[..count]) {
            self.take_report(report);
        }
        Ok(count)
    }

    fn take_report(&mut self, report: RflexReport) {
        let event = match report {
            RflexReport::Odometry(report) => {
                self.stats.odometry_reports += 1;
                self.last_report_at = Some(Instant::now());
                self.odometry.update(&report);
                RflexEvent::Odometry {
                    axis: report.axis,
                    pose: self.pose(),
                    translation_mps: self.odometry.translation_velocity_mps(),
                    rotation_radps: self.odometry.rotation_velocity_radps(),
                }
            }
            RflexReport::Sonar(report) => {
                self.stats.sonar_reports += 1;
                let ranges =
                    report.ranges_m(self.config.sonar_count, self.config.sonar_units_per_m);
                for (latest, range) in self.sonar_ranges_m.iter_mut().zip(ranges) {
                    if range.is_some() {
                        *latest = range;
                    }
                }
                RflexEvent::Sonar {
                    ranges_m: self.sonar_ranges_m.clone(),
                }
            }
            RflexReport::Dio(report) => {
                self.dio.insert(report.address, report.value);
                RflexEvent::Dio(report)
            }
            RflexReport::SysStatus(status) => {
                let voltage_v = status.voltage_v(self.config.voltage_offset_v);
                self.voltage_v = Some(voltage_v);
                self.brake_engaged = Some(status.brake_engaged());
                RflexEvent::Status {
                    voltage_v,
                    brake_engaged: status.brake_engaged(),
                }
            }
            RflexReport::Other(packet) => RflexEvent::Other(packet),
        };
        self.events.push_back(event);
    }

    fn lost(&mut self, down: LinkDown) {
        self.link.close();
        self.down_reason = Some(down.reason);
        self.retry.now();
    }

    /// Tries to reopen the port and start the base up again when a retry is due; otherwise
    /// waits for the retry (at most until `deadline`).
    fn reconnect(&mut self, deadline: Instant) {
        if !self.retry.due_or_wait(deadline, None) {
            return;
        }
        if let Err(error) = self.link.reopen(RFLEX_BAUD_BPS) {
            self.down_reason = Some(error.to_string());
            return;
        }
        self.receiver.reset();
        match self.start_up() {
            Ok(()) => {
                // The base may have been power-cycled (counts from zero): integrate afresh
                // from the pose reached so far.
                self.pose_offset = self.pose();
                self.odometry = OdometryIntegrator::new(self.config.conversion);
                self.down_reason = None;
                self.stats.reconnects += 1;
                self.events.push_back(RflexEvent::Reconnected);
            }
            Err(down) => self.lost(down),
        }
    }
}

impl Drop for RflexDriver {
    /// Stops the robot (best effort: the port may be gone).
    fn drop(&mut self) {
        if self.link.is_open() {
            self.command.translation_mps = 0.0;
            self.command.rotation_radps = 0.0;
            let _ = self.write_commands(&self.velocity_commands());
        }
    }
}

/// `local` given in `base`'s frame, in the parent frame.
fn compose(base: Pose2, local: Pose2) -> Pose2 {
    let (sin, cos) = base.heading_rad.sin_cos();
    let heading = base.heading_rad + local.heading_rad;
    Pose2 {
        x_m: base.x_m + cos * local.x_m - sin * local.y_m,
        y_m: base.y_m + sin * local.x_m + cos * local.y_m,
        heading_rad: heading.sin().atan2(heading.cos()),
    }
}
