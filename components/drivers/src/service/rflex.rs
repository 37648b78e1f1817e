//! `rflex`: the B21r's base on its RFlex serial port, as Synchrodrive (velocity commands per
//! axis, in the robot file's RFlex units; brake), Egomotion (odometry integrated from the
//! base's reports), Power (the battery voltage of the status reports), and the sonar ring as
//! RangeFinder (`uniform = false`, one Pose3D per transducer) and Distance (sectors all
//! around the robot).
//!
//! The driver's host watchdog stops the robot when no velocity command has come for
//! `command_timeout_ms`: a client that wants motion keeps commanding it.
//!
//! ```toml
//! [services.parameters]
//! port = "/dev/ttyUSB0"
//! distance_units_per_m = 103000.0   # RFlex translation units per metre (B21r)
//! angle_units_per_rad = 35000.0     # RFlex rotation units per radian (B21r)
//! translation_acceleration_mps2 = 0.7
//! rotation_acceleration_radps2 = 1.0
//! torque = 30000
//! command_timeout_ms = 1000         # the host watchdog
//! report_deadline_ms = 1000         # no odometry report for this long: out of service
//! reconnect_interval_ms = 1000
//! sonar_units_per_m = 1476.0
//! sonar_max_range_m = 5.0           # readings missing or beyond read this
//! voltage_offset_v = 0.0            # added to raw / 100 (the robot's calibration)
//! full_voltage_v = 28.0             # Power's charge fraction: linear between these
//! empty_voltage_v = 22.0
//! low_charge_fraction = 0.2
//! distance_sectors = 24
//! rate_hz = 10.0                    # Synchrodrive, Egomotion and Power publications
//! sonar_count = 48                  # transducers the base reports
//! transducers = [ { x_m = 0.26, y_m = 0.0, heading_deg = 0.0, height_m = 0.62 }, ... ]
//!                                   # one per transducer in RFlex order (default: the B21r's
//!                                   # two rings of 24); there must be `sonar_count` of them
//! bumper_address = 64               # the DIO address of the first bumper panel (0x40)
//! bumper_count = 14                 # panels (Synchrodrive's `bumpers`)
//! bumper_style = "address"          # "address": one address per panel; "bit": 8 per address
//! ```
//!
//! Bumpers are published in Synchrodrive (`bumpers`, one per panel, true while pressed), at
//! once when a panel changes and with every periodic publication.

use std::path::PathBuf;
use std::time::Duration;

use lewis_geometry::{
    Pose2, SectorLayout, SensorMount, b21r_sonar_ring, distance_from_range_finder,
};
use lewis_interfaces::msg::{
    Distance, DistanceCommand, DistanceSetSectorCountReply, Egomotion, EgomotionCommand,
    EgomotionResetOdometryReply, Pose2D, Power, PowerCommand, PowerSetLowThresholdReply,
    RangeFinder, RangeFinderCommand, RangeFinderGetGeometryReply, Synchrodrive,
    SynchrodriveCommand, SynchrodriveSetBrakeReply, SynchrodriveSetVelocityReply,
    SynchrodriveStopReply,
};
use lewis_service::Health;
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Service, ServiceConfig,
};
use serde::Deserialize;

use super::{Mount, declare, health_of, invalid, millis, provides, publish, sector_count};
use crate::io::{RflexDriver, RflexDriverConfig, RflexEvent};
use crate::rflex::{
    BumperLayout, BumperStyle, Bumpers, OdometryConversion, SONAR_COUNT, SONAR_UNITS_PER_M,
};

/// The kind name in robot files.
pub const KIND: &str = "rflex";

/// Ring updates per second the geometry announces (the RFlex's own pace; guessed from
/// Player's driver).
const SONAR_RATE_HZ: f64 = 10.0;

/// The parameters of `rflex`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RflexParams {
    /// The serial port.
    pub port: PathBuf,
    /// RFlex translation units per metre.
    #[serde(default = "defaults::distance_units_per_m")]
    pub distance_units_per_m: f64,
    /// RFlex rotation units per radian.
    #[serde(default = "defaults::angle_units_per_rad")]
    pub angle_units_per_rad: f64,
    /// Acceleration sent with translation commands, in m/s^2.
    #[serde(default = "defaults::translation_acceleration_mps2")]
    pub translation_acceleration_mps2: f64,
    /// Acceleration sent with rotation commands, in rad/s^2.
    #[serde(default = "defaults::rotation_acceleration_radps2")]
    pub rotation_acceleration_radps2: f64,
    /// The torque limit sent with velocity commands (RFlex units).
    #[serde(default = "defaults::torque")]
    pub torque: u32,
    /// No velocity command for this long stops the robot, in ms.
    #[serde(default = "defaults::command_timeout_ms")]
    pub command_timeout_ms: u64,
    /// No odometry report for this long is out of service, in ms.
    #[serde(default = "defaults::report_deadline_ms")]
    pub report_deadline_ms: u64,
    /// Time between attempts to reopen a port that went away, in ms.
    #[serde(default = "defaults::reconnect_interval_ms")]
    pub reconnect_interval_ms: u64,
    /// Sonar units per metre.
    #[serde(default = "defaults::sonar_units_per_m")]
    pub sonar_units_per_m: f64,
    /// The sonar's largest range, in m: missing readings and those beyond read this.
    #[serde(default = "defaults::sonar_max_range_m")]
    pub sonar_max_range_m: f64,
    /// Added to the raw voltage / 100, in V.
    #[serde(default)]
    pub voltage_offset_v: f64,
    /// The battery's voltage when full, in V.
    #[serde(default = "defaults::full_voltage_v")]
    pub full_voltage_v: f64,
    /// The battery's voltage when empty, in V.
    #[serde(default = "defaults::empty_voltage_v")]
    pub empty_voltage_v: f64,
    /// Charge below which Power says `low`, 0 to 1.
    #[serde(default = "defaults::low_charge_fraction")]
    pub low_charge_fraction: f64,
    /// Sectors of the sonar's Distance publication, all around the robot.
    #[serde(default = "defaults::distance_sectors")]
    pub distance_sectors: i64,
    /// Rate of the Synchrodrive, Egomotion and Power publications, in Hz.
    #[serde(default = "defaults::rate_hz")]
    pub rate_hz: f64,
    /// Transducers the base reports.
    #[serde(default = "defaults::sonar_count")]
    pub sonar_count: usize,
    /// The sonar transducers in RFlex order (default: the B21r's 48).
    #[serde(default)]
    pub transducers: Option<Vec<Mount>>,
    /// The DIO address of the first bumper panel.
    #[serde(default = "defaults::bumper_address")]
    pub bumper_address: u8,
    /// Bumper panels.
    #[serde(default = "defaults::bumper_count")]
    pub bumper_count: usize,
    /// How panels map to DIO addresses: "address" (one each) or "bit" (8 per address).
    #[serde(default = "defaults::bumper_style")]
    pub bumper_style: String,
}

mod defaults {
    use crate::rflex::OdometryConversion;

    pub(super) fn distance_units_per_m() -> f64 {
        OdometryConversion::B21R.distance_units_per_m
    }
    pub(super) fn angle_units_per_rad() -> f64 {
        OdometryConversion::B21R.angle_units_per_rad
    }
    pub(super) fn translation_acceleration_mps2() -> f64 {
        0.7
    }
    pub(super) fn rotation_acceleration_radps2() -> f64 {
        1.0
    }
    pub(super) fn torque() -> u32 {
        30_000
    }
    pub(super) fn command_timeout_ms() -> u64 {
        1_000
    }
    pub(super) fn report_deadline_ms() -> u64 {
        1_000
    }
    pub(super) fn reconnect_interval_ms() -> u64 {
        1_000
    }
    pub(super) fn sonar_units_per_m() -> f64 {
        super::SONAR_UNITS_PER_M
    }
    pub(super) fn sonar_max_range_m() -> f64 {
        5.0
    }
    pub(super) fn full_voltage_v() -> f64 {
        28.0
    }
    pub(super) fn empty_voltage_v() -> f64 {
        22.0
    }
    pub(super) fn low_charge_fraction() -> f64 {
        0.2
    }
    pub(super) fn distance_sectors() -> i64 {
        24
    }
    pub(super) fn rate_hz() -> f64 {
        10.0
    }
    pub(super) fn sonar_count() -> usize {
        super::SONAR_COUNT
    }
    pub(super) fn bumper_address() -> u8 {
        super::BumperLayout::B21R.first_address
    }
    pub(super) fn bumper_count() -> usize {
        super::BumperLayout::B21R.count
    }
    pub(super) fn bumper_style() -> String {
        "address".to_owned()
    }
}

/// The `rflex` service.
#[derive(Debug)]
pub struct RflexService {
    config: RflexDriverConfig,
    driver: Option<RflexDriver>,
    sonar: SonarPublisher,
    battery: Battery,
    period_ns: i64,
    next_state_ns: i64,
    next_open_ns: i64,
    last_open_error: Option<String>,
    distance_travelled_m: f64,
    last_pose: Option<Pose2>,
    bumpers: Bumpers,
    outputs: Outputs,
}

/// Which interfaces the robot file lets the base publish.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Outputs {
    synchrodrive: bool,
    egomotion: bool,
    power: bool,
    range_finder: bool,
    distance: bool,
}

/// The battery's charge from its voltage: linear between empty and full.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Battery {
    /// Voltage when full, in V.
    pub full_voltage_v: f64,
    /// Voltage when empty, in V.
    pub empty_voltage_v: f64,
    /// Charge below which Power says `low`.
    pub low_charge_fraction: f64,
}

impl Battery {
    /// The Power publication for a voltage.
    #[must_use]
    pub fn power(&self, voltage_v: f64) -> Power {
        let span = self.full_voltage_v - self.empty_voltage_v;
        let charge = if span > 0.0 {
            ((voltage_v - self.empty_voltage_v) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        Power {
            voltage: voltage_v,
            charge_fraction: charge,
            charging: false,
            low: charge < self.low_charge_fraction,
            ..Power::default()
        }
    }
}

/// Turns the sonar ring's ranges into publications.
#[derive(Debug, Clone, PartialEq)]
pub struct SonarPublisher {
    transducers: Vec<SensorMount>,
    max_range_m: f64,
    sectors: usize,
}

impl SonarPublisher {
    /// Publications for `transducers` (RFlex order), reading at most `max_range_m`.
    #[must_use]
    pub fn new(transducers: Vec<SensorMount>, max_range_m: f64, sectors: usize) -> Self {
        Self {
            transducers,
            max_range_m,
            sectors,
        }
    }

    /// The RangeFinder of the ring's latest ranges: one reading per transducer, missing or
    /// out-of-range ones at the max range (nothing seen).
    #[must_use]
    pub fn range_finder(&self, ranges_m: &[Option<f64>]) -> RangeFinder {
        let ranges: Vec<f64> = (0..self.transducers.len())
            .map(|i| {
                ranges_m
                    .get(i)
                    .copied()
                    .flatten()
                    .filter(|r| r.is_finite() && *r >= 0.0)
                    .map_or(self.max_range_m, |r| r.min(self.max_range_m))
            })
            .collect();
        RangeFinder {
            range_count: i32::try_from(ranges.len()).unwrap_or(i32::MAX),
            ranges,
            max_range: self.max_range_m,
            uniform: false,
            sensor_positions: self.transducers.iter().map(|m| m.to_pose3d()).collect(),
            ..RangeFinder::default()
        }
    }

    /// The Distance of the ring's RangeFinder.
    #[must_use]
    pub fn distance(&self, scan: &RangeFinder) -> Distance {
        distance_from_range_finder(scan, SectorLayout::full_circle(self.sectors))
    }
}

/// Builds an `rflex` service from its robot-file entry.
///
/// # Errors
/// When a parameter is missing, unknown or cannot work.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: RflexParams = config.parameters()?;
    let positive = |field: &str, value: f64| {
        if value.is_finite() && value > 0.0 {
            Ok(value)
        } else {
            Err(invalid(
                config,
                format!("`{field}` is {value}: give a positive number"),
            ))
        }
    };
    let conversion = OdometryConversion {
        distance_units_per_m: positive("distance_units_per_m", params.distance_units_per_m)?,
        angle_units_per_rad: positive("angle_units_per_rad", params.angle_units_per_rad)?,
    };
    let transducers = transducers(config, &params)?;
    let bumpers = bumper_layout(config, &params)?;
    if !(params.rate_hz.is_finite() && (1.0..=1000.0).contains(&params.rate_hz)) {
        return Err(invalid(
            config,
            format!("`rate_hz` is {}: give 1 to 1000 Hz", params.rate_hz),
        ));
    }
    // checked above
    let period_ns = (1e9 / params.rate_hz).round() as i64;
    let driver_config = RflexDriverConfig {
        conversion,
        translation_acceleration_mps2: positive(
            "translation_acceleration_mps2",
            params.translation_acceleration_mps2,
        )?,
        rotation_acceleration_radps2: positive(
            "rotation_acceleration_radps2",
            params.rotation_acceleration_radps2,
        )?,
        torque: params.torque,
        command_timeout: millis(config, "command_timeout_ms", params.command_timeout_ms)?,
        report_deadline: millis(config, "report_deadline_ms", params.report_deadline_ms)?,
        reconnect_interval: millis(
            config,
            "reconnect_interval_ms",
            params.reconnect_interval_ms,
        )?,
        sonar_count: transducers.len(),
        sonar_units_per_m: positive("sonar_units_per_m", params.sonar_units_per_m)?,
        voltage_offset_v: params.voltage_offset_v,
        ..RflexDriverConfig::new(&params.port)
    };
    let sectors = sector_count(config, params.distance_sectors)?;
    Ok(Box::new(RflexService {
        config: driver_config,
        driver: None,
        sonar: SonarPublisher::new(
            transducers,
            positive("sonar_max_range_m", params.sonar_max_range_m)?,
            sectors,
        ),
        battery: Battery {
            full_voltage_v: params.full_voltage_v,
            empty_voltage_v: params.empty_voltage_v,
            low_charge_fraction: params.low_charge_fraction,
        },
        period_ns,
        next_state_ns: 0,
        next_open_ns: 0,
        last_open_error: None,
        distance_travelled_m: 0.0,
        last_pose: None,
        bumpers: Bumpers::new(bumpers),
        outputs: Outputs {
            synchrodrive: provides::<Synchrodrive>(config),
            egomotion: provides::<Egomotion>(config),
            power: provides::<Power>(config),
            range_finder: provides::<RangeFinder>(config),
            distance: provides::<Distance>(config),
        },
    }))
}

/// The sonar ring of the robot file, or the B21r's when it gives none; checked against
/// `sonar_count`.
fn transducers(
    config: &ServiceConfig<'_>,
    params: &RflexParams,
) -> Result<Vec<SensorMount>, BuildError> {
    if !(1..=usize::from(u8::MAX) + 1).contains(&params.sonar_count) {
        return Err(invalid(
            config,
            format!(
                "`sonar_count` is {}: give 1 to 256 (transducer ids are one byte)",
                params.sonar_count
            ),
        ));
    }
    let Some(mounts) = &params.transducers else {
        let ring = b21r_sonar_ring();
        if ring.len() != params.sonar_count {
            return Err(invalid(
                config,
                format!(
                    "`sonar_count` is {} but no `transducers` are given and the B21r's default ring has {}: give one `transducers` entry per transducer",
                    params.sonar_count,
                    ring.len()
                ),
            ));
        }
        return Ok(ring);
    };
    if mounts.len() != params.sonar_count {
        return Err(invalid(
            config,
            format!(
                "`transducers` has {} entries but `sonar_count` is {}: give one entry per transducer, in RFlex order",
                mounts.len(),
                params.sonar_count
            ),
        ));
    }
    for (index, mount) in mounts.iter().enumerate() {
        let values = [mount.x_m, mount.y_m, mount.heading_deg, mount.height_m];
        if !values.iter().all(|v| v.is_finite()) {
            return Err(invalid(
                config,
                format!("`transducers[{index}]` has a value that is not a finite number"),
            ));
        }
    }
    Ok(mounts.iter().map(|m| m.to_sensor_mount()).collect())
}

/// The bumper panels of the robot file.
fn bumper_layout(
    config: &ServiceConfig<'_>,
    params: &RflexParams,
) -> Result<BumperLayout, BuildError> {
    let style = match params.bumper_style.as_str() {
        "address" => BumperStyle::Address,
        "bit" => BumperStyle::Bit,
        other => {
            return Err(invalid(
                config,
                format!(
                    "`bumper_style` is `{other}`: give \"address\" (one DIO address per panel, the B21r) or \"bit\" (8 panels per address)"
                ),
            ));
        }
    };
    let layout = BumperLayout {
        first_address: params.bumper_address,
        count: params.bumper_count,
        style,
    };
    if params.bumper_count > 0 && layout.report_for(params.bumper_count - 1, true).is_none() {
        return Err(invalid(
            config,
            format!(
                "{} bumper panels from DIO address {} go past address 255: lower `bumper_address` or `bumper_count`",
                params.bumper_count, params.bumper_address
            ),
        ));
    }
    Ok(layout)
}

impl RflexService {
    /// Opens the port and starts the base up when an attempt is due.
    fn open(&mut self, ctx: &mut Context<'_>) {
        if ctx.now() < self.next_open_ns {
            return;
        }
        let interval_ns =
            i64::try_from(self.config.reconnect_interval.as_nanos()).unwrap_or(i64::MAX);
        self.next_open_ns = ctx.now().saturating_add(interval_ns);
        match RflexDriver::open(self.config.clone()) {
            Ok(driver) => {
                ctx.info(&format!(
                    "RFlex base on {} started up",
                    self.config.path.display()
                ));
                self.last_open_error = None;
                self.driver = Some(driver);
            }
            Err(error) => {
                let reason = error.to_string();
                if self.last_open_error.as_deref() != Some(reason.as_str()) {
                    ctx.warn(&reason);
                }
                declare(ctx, Health::OutOfService(reason.clone()));
                self.last_open_error = Some(reason);
            }
        }
    }

    /// Takes every event that has arrived (running the driver's timers), publishes the sonar
    /// as it comes, and declares the driver's health.
    fn drain(&mut self, ctx: &mut Context<'_>) {
        let Some(driver) = &mut self.driver else {
            return;
        };
        while let Some(event) = driver.read_event(Duration::ZERO) {
            match event {
                RflexEvent::Odometry { pose, .. } => {
                    if let Some(last) = self.last_pose {
                        self.distance_travelled_m +=
                            (pose.x_m - last.x_m).hypot(pose.y_m - last.y_m);
                    }
                    self.last_pose = Some(pose);
                }
                RflexEvent::Sonar { ranges_m } => {
                    let mut scan = self.sonar.range_finder(&ranges_m);
                    if self.outputs.distance {
                        publish(ctx, &mut self.sonar.distance(&scan));
                    }
                    if self.outputs.range_finder {
                        publish(ctx, &mut scan);
                    }
                }
                RflexEvent::WatchdogStop => {
                    ctx.warn("no velocity command within the timeout: the robot was stopped");
                }
                RflexEvent::Reconnected => {
                    ctx.info("the RFlex port came back: start-up sequence sent again");
                    self.last_pose = None;
                }
                RflexEvent::Dio(report) => {
                    let before = self.bumpers.clone();
                    if self.bumpers.update(&report) && self.bumpers != before {
                        // A bump is news for whoever drives: publish at once.
                        self.next_state_ns = ctx.now();
                    }
                }
                RflexEvent::Status { .. } | RflexEvent::Other(_) => {}
            }
        }
        declare(ctx, health_of(&driver.health()));
    }

    /// Publishes Synchrodrive, Egomotion and Power when due.
    fn publish_state(&mut self, ctx: &mut Context<'_>) {
        let Some(driver) = &self.driver else {
            return;
        };
        if ctx.now() < self.next_state_ns || !driver.health().is_ok() {
            return;
        }
        self.next_state_ns = ctx.now().saturating_add(self.period_ns);
        let (translation_mps, rotation_radps) = driver.velocities();
        if self.outputs.synchrodrive {
            let (commanded_translation, commanded_rotation) = driver.commanded_velocity();
            publish(
                ctx,
                &mut Synchrodrive {
                    translation_velocity: translation_mps,
                    rotation_velocity: rotation_radps,
                    commanded_translation_velocity: commanded_translation,
                    commanded_rotation_velocity: commanded_rotation,
                    brake_on: driver.brake_engaged().unwrap_or(true),
                    bumper_count: i32::try_from(self.bumpers.pressed().len()).unwrap_or(i32::MAX),
                    bumpers: self.bumpers.pressed().to_vec(),
                    ..Synchrodrive::default()
                },
            );
        }
        if self.outputs.egomotion && driver.is_odometry_referenced() {
            let pose = driver.pose();
            publish(
                ctx,
                &mut Egomotion {
                    pose: Pose2D {
                        x: pose.x_m,
                        y: pose.y_m,
                        theta: pose.heading_rad,
                    },
                    translation_velocity: translation_mps,
                    rotation_velocity: rotation_radps,
                    distance_travelled: self.distance_travelled_m,
                    ..Egomotion::default()
                },
            );
        }
        if self.outputs.power
            && let Some(voltage_v) = driver.voltage_v()
        {
            publish(ctx, &mut self.battery.power(voltage_v));
        }
    }

    fn driver(&mut self) -> Result<&mut RflexDriver, CommandError> {
        self.driver.as_mut().ok_or_else(|| {
            CommandError::new(format!(
                "the RFlex base on {} is not connected: {}",
                self.config.path.display(),
                self.last_open_error.as_deref().unwrap_or("not opened yet")
            ))
        })
    }
}

impl Service for RflexService {
    fn tick_period_ns(&self) -> Option<i64> {
        // The driver's timers (watchdog, velocity refresh) need reads at least this often.
        let refresh_ns = i64::try_from(self.config.command_refresh.as_nanos() / 2)
            .unwrap_or(i64::MAX)
            .max(1_000_000);
        Some(self.period_ns.min(refresh_ns))
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        self.open(ctx);
        Ok(())
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        if self.driver.is_none() {
            self.open(ctx);
        }
        self.drain(ctx);
        self.publish_state(ctx);
    }

    fn device(&self) -> Option<std::os::fd::BorrowedFd<'_>> {
        self.driver.as_ref().and_then(RflexDriver::fd)
    }

    fn on_device(&mut self, ctx: &mut Context<'_>) {
        self.drain(ctx);
        // A bumper that changed is published now, not at the next tick.
        self.publish_state(ctx);
    }

    fn on_stop(&mut self, ctx: &mut Context<'_>) {
        if let Some(driver) = &mut self.driver
            && let Err(e) = driver.stop()
        {
            ctx.warn(&format!("cannot stop the robot: {e}"));
        }
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        let failed = |e: crate::io::RflexDriverError| CommandError::new(e.to_string());
        match command.interface {
            "Synchrodrive" => match command.decode::<Synchrodrive>()? {
                SynchrodriveCommand::SetVelocity(c) => {
                    if !(c.translation_velocity.is_finite() && c.rotation_velocity.is_finite()) {
                        return Err(CommandError::new(
                            "set_velocity: a velocity is not a number",
                        ));
                    }
                    self.driver()?
                        .set_velocity(c.translation_velocity, c.rotation_velocity)
                        .map_err(failed)?;
                    Ok(ctx.reply(SynchrodriveSetVelocityReply::default()))
                }
                SynchrodriveCommand::Stop(_) => {
                    self.driver()?.stop().map_err(failed)?;
                    Ok(ctx.reply(SynchrodriveStopReply::default()))
                }
                SynchrodriveCommand::SetBrake(c) => {
                    self.driver()?.set_brake(c.on).map_err(failed)?;
                    Ok(ctx.reply(SynchrodriveSetBrakeReply::default()))
                }
            },
            "Egomotion" => match command.decode::<Egomotion>()? {
                EgomotionCommand::ResetOdometry(c) => {
                    let pose = Pose2 {
                        x_m: c.pose.x,
                        y_m: c.pose.y,
                        heading_rad: c.pose.theta,
                    };
                    if !(pose.x_m.is_finite()
                        && pose.y_m.is_finite()
                        && pose.heading_rad.is_finite())
                    {
                        return Err(CommandError::new(
                            "reset_odometry: the pose has a coordinate that is not a number",
                        ));
                    }
                    self.driver()?.reset_pose(pose);
                    self.last_pose = None;
                    Ok(ctx.reply(EgomotionResetOdometryReply::default()))
                }
            },
            "Power" => match command.decode::<Power>()? {
                PowerCommand::SetLowThreshold(c) => {
                    if !(0.0..=1.0).contains(&c.charge_fraction) {
                        return Err(CommandError::new(format!(
                            "set_low_threshold: charge_fraction is {}, expected between 0 and 1",
                            c.charge_fraction
                        )));
                    }
                    self.battery.low_charge_fraction = c.charge_fraction;
                    Ok(ctx.reply(PowerSetLowThresholdReply::default()))
                }
            },
            "RangeFinder" => match command.decode::<RangeFinder>()? {
                RangeFinderCommand::GetGeometry(_) => Ok(ctx.reply(RangeFinderGetGeometryReply {
                    range_count: i32::try_from(self.sonar.transducers.len()).unwrap_or(i32::MAX),
                    max_range: self.sonar.max_range_m,
                    rate: SONAR_RATE_HZ,
                    ..RangeFinderGetGeometryReply::default()
                })),
            },
            "Distance" => match command.decode::<Distance>()? {
                DistanceCommand::SetSectorCount(c) => {
                    self.sonar.sectors = usize::try_from(c.sector_count)
                        .ok()
                        .filter(|n| (1..=360).contains(n))
                        .ok_or_else(|| {
                            CommandError::new(format!(
                                "set_sector_count: {} sectors, expected 1 to 360",
                                c.sector_count
                            ))
                        })?;
                    Ok(ctx.reply(DistanceSetSectorCountReply {
                        sector_count: c.sector_count,
                        ..DistanceSetSectorCountReply::default()
                    }))
                }
            },
            other => Err(CommandError::new(format!("{KIND} does not serve {other}"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use lewis_robot::Robot;
    use lewis_service::ServiceRegistry;

    use super::*;

    fn robot(text: &str, path: &Path) -> Robot {
        let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
            .iter()
            .map(|i| i.name)
            .collect();
        lewis_robot::parse(text, path, &known).unwrap()
    }

    /// Builds service `base` of `text`.
    fn build_base(text: &str) -> Result<Box<dyn Service>, BuildError> {
        let robot = robot(text, Path::new("rflex-test.toml"));
        let mut registry = ServiceRegistry::new();
        super::super::register(&mut registry);
        registry.build(&ServiceConfig {
            spec: robot.service("base").unwrap(),
            heartbeat_period_ms: 100,
        })
    }

    /// A robot whose base has `parameters` besides its port.
    fn base_with(parameters: &str) -> String {
        format!(
            r#"
[robot]
name = "rflex-test"

[[services]]
name = "base"
kind = "rflex"
provides = [{{ interface = "Synchrodrive", quality = 10, cost = 1 }}]

[services.parameters]
port = "/dev/ttyS1"
{parameters}
"#
        )
    }

    fn check_refused(parameters: &str, needle: &str) {
        match build_base(&base_with(parameters)) {
            Ok(_) => panic!("{parameters}: accepted"),
            Err(error) => {
                let message = error.to_string();
                assert!(message.contains(needle), "{parameters}: {message}");
            }
        }
    }

    #[test]
    fn the_b21r_robot_file_gives_its_sonar_ring_and_bumpers() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../robots/b21r.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        let robot = robot(&text, &path);
        let spec = robot.service("base").unwrap();
        let config = ServiceConfig {
            spec,
            heartbeat_period_ms: 100,
        };
        let params: RflexParams = config.parameters().unwrap();
        let ring = transducers(&config, &params).unwrap();
        assert_eq!(ring.len(), 48);
        // The robot file writes out the B21r's ring, to the 0.1 mm it is given with.
        for (index, (given, default)) in ring.iter().zip(b21r_sonar_ring()).enumerate() {
            assert!(
                (given.pose.x_m - default.pose.x_m).abs() < 1e-4
                    && (given.pose.y_m - default.pose.y_m).abs() < 1e-4
                    && (given.pose.heading_rad - default.pose.heading_rad).abs() < 1e-9
                    && (given.height_m - default.height_m).abs() < 1e-9,
                "transducer {index}: {given:?} against {default:?}"
            );
        }
        assert_eq!(bumper_layout(&config, &params).unwrap(), BumperLayout::B21R);
    }

    #[test]
    fn a_sonar_ring_that_does_not_match_its_count_is_refused() {
        assert!(build_base(&base_with("")).is_ok(), "the defaults build");
        check_refused(
            "sonar_count = 24",
            "`sonar_count` is 24 but no `transducers` are given",
        );
        check_refused(
            "transducers = [ { x_m = 0.26 }, { x_m = 0.25 } ]",
            "`transducers` has 2 entries but `sonar_count` is 48",
        );
        check_refused("sonar_count = 0", "`sonar_count` is 0");
        assert!(
            build_base(&base_with(
                "sonar_count = 2\ntransducers = [ { x_m = 0.26 }, { x_m = 0.25 } ]"
            ))
            .is_ok(),
            "two transducers when the count says two"
        );
    }

    #[test]
    fn bumper_parameters_are_checked() {
        check_refused("bumper_style = \"corner\"", "`bumper_style` is `corner`");
        check_refused(
            "bumper_address = 250\nbumper_count = 14",
            "go past address 255",
        );
        assert!(
            build_base(&base_with(
                "bumper_address = 250\nbumper_count = 14\nbumper_style = \"bit\""
            ))
            .is_ok(),
            "by bit, 14 panels need 2 addresses"
        );
        assert!(
            build_base(&base_with("bumper_count = 0")).is_ok(),
            "no bumpers"
        );
    }

    #[test]
    fn the_battery_charge_is_linear_between_empty_and_full() {
        let battery = Battery {
            full_voltage_v: 28.0,
            empty_voltage_v: 22.0,
            low_charge_fraction: 0.2,
        };
        let check = |voltage: f64, charge: f64, low: bool| {
            let power = battery.power(voltage);
            assert!(
                (power.charge_fraction - charge).abs() < 1e-9,
                "{voltage}: {power:?}"
            );
            assert_eq!(power.low, low, "{voltage}");
        };
        check(28.0, 1.0, false);
        check(25.0, 0.5, false);
        check(22.6, 0.1, true);
        check(30.0, 1.0, false);
        check(10.0, 0.0, true);
    }

    #[test]
    fn missing_and_far_sonar_readings_read_the_max_range() {
        let publisher = SonarPublisher::new(b21r_sonar_ring(), 5.0, 24);
        let mut ranges = vec![None; 48];
        ranges[0] = Some(1.5);
        ranges[1] = Some(7.0);
        ranges[2] = Some(f64::NAN);
        let scan = publisher.range_finder(&ranges);
        assert_eq!(scan.range_count, 48);
        assert!(!scan.uniform);
        assert_eq!(scan.sensor_positions.len(), 48);
        assert_eq!(&scan.ranges[..4], &[1.5, 5.0, 5.0, 5.0]);
        let distance = publisher.distance(&scan);
        assert!(
            (distance.min_distance - (1.5 + 0.26)).abs() < 1e-9,
            "{distance:?}"
        );
    }
}
