//! `sick`: the SICK LMS2xx / PLS laser on a serial port, as RangeFinder (uniform beams, from
//! the scanner's right to its left) and Distance (the nearest reading in each sector all
//! around the robot, the same layout as the sonar's so that a client that fails over from one
//! to the other sees the same sectors).
//!
//! ```toml
//! [services.parameters]
//! port = "/dev/ttyS0"
//! baud = 38400                  # 9600, 19200, 38400 or 500000 (RS-422)
//! angle_deg = 180               # 180 or 100
//! resolution_deg = 0.5          # 1, 0.5 or 0.25 (0.25 only with 100 degrees)
//! unit = "mm"                   # "mm" (8.191 m at most) or "cm" (81.91 m)
//! parity = "none"               # "even" for the PLS
//! mount = { x_m = 0.12, y_m = 0.0, heading_deg = 0.0, height_m = 0.42 }
//! distance_sectors = 24
//! scan_deadline_ms = 1000       # no valid scan for this long: out of service
//! crc_error_threshold = 0.5     # more bad CRCs than this among recent telegrams: out of service
//! reply_timeout_ms = 1000
//! reconnect_interval_ms = 1000
//! ```
//!
//! Setting the scanner up (at start and after the port comes back) blocks the service for up
//! to a reply timeout per command, and up to two per candidate rate while probing.

use std::path::PathBuf;
use std::time::Duration;

use lewis_interfaces::msg::{
    Distance, DistanceCommand, DistanceSetSectorCountReply, RangeFinder, RangeFinderCommand,
    RangeFinderGetGeometryReply,
};
use lewis_runtime::broker::Health;
use lewis_runtime::service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Service, ServiceConfig,
};
use serde::Deserialize;

use super::{Mount, declare, health_of, invalid, millis, provides, publish, sector_count};
use crate::drivers::io::{LaserScan, LineParity, SickDriver, SickDriverConfig};
use crate::drivers::sick::{AngularResolution, BaudRate, RangeUnit, ScanLayout, ScanWidth};
use crate::sim::{SectorLayout, distance_from_range_finder};

/// The kind name in robot files.
pub const KIND: &str = "sick";

/// How often the service looks at the driver's health and retries a port that went away.
const TICK_NS: i64 = 100_000_000;

/// The parameters of `sick`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SickParams {
    /// The serial port.
    pub port: PathBuf,
    /// The rate to run at, in baud.
    #[serde(default = "defaults::baud")]
    pub baud: u32,
    /// The scan's width, in degrees: 180 or 100.
    #[serde(default = "defaults::angle_deg")]
    pub angle_deg: u16,
    /// The angle between beams, in degrees: 1, 0.5 or 0.25.
    #[serde(default = "defaults::resolution_deg")]
    pub resolution_deg: f64,
    /// The range unit: "mm" or "cm".
    #[serde(default = "defaults::unit")]
    pub unit: String,
    /// The line's parity: "none" (LMS) or "even" (PLS).
    #[serde(default = "defaults::parity")]
    pub parity: String,
    /// Where the scanner sits on the robot.
    #[serde(default)]
    pub mount: Mount,
    /// Sectors of the Distance publication, all around the robot.
    #[serde(default = "defaults::distance_sectors")]
    pub distance_sectors: i64,
    /// No valid scan for this long is out of service, in ms.
    #[serde(default = "defaults::scan_deadline_ms")]
    pub scan_deadline_ms: u64,
    /// A fraction of bad CRCs among recent telegrams above this is out of service.
    #[serde(default = "defaults::crc_error_threshold")]
    pub crc_error_threshold: f64,
    /// How long to wait for a reply, in ms.
    #[serde(default = "defaults::reply_timeout_ms")]
    pub reply_timeout_ms: u64,
    /// Time between attempts to reopen a port that went away, in ms.
    #[serde(default = "defaults::reconnect_interval_ms")]
    pub reconnect_interval_ms: u64,
}

mod defaults {
    pub(super) fn baud() -> u32 {
        38_400
    }
    pub(super) fn angle_deg() -> u16 {
        180
    }
    pub(super) fn resolution_deg() -> f64 {
        0.5
    }
    pub(super) fn unit() -> String {
        "mm".to_owned()
    }
    pub(super) fn parity() -> String {
        "none".to_owned()
    }
    pub(super) fn distance_sectors() -> i64 {
        24
    }
    pub(super) fn scan_deadline_ms() -> u64 {
        1_000
    }
    pub(super) fn crc_error_threshold() -> f64 {
        0.5
    }
    pub(super) fn reply_timeout_ms() -> u64 {
        1_000
    }
    pub(super) fn reconnect_interval_ms() -> u64 {
        1_000
    }
}

impl SickParams {
    /// The driver's configuration, or what is wrong with the parameters.
    ///
    /// # Errors
    /// The first parameter that names no rate, layout, unit or parity the scanner has.
    pub fn driver_config(&self) -> Result<SickDriverConfig, String> {
        let baud = BaudRate::from_bits_per_second(self.baud)
            .map_err(|_| format!("`baud` is {}: give 9600, 19200, 38400 or 500000", self.baud))?;
        let width = match self.angle_deg {
            180 => ScanWidth::Deg180,
            100 => ScanWidth::Deg100,
            other => return Err(format!("`angle_deg` is {other}: give 180 or 100")),
        };
        let resolution = if (self.resolution_deg - 1.0).abs() < 1e-9 {
            AngularResolution::OneDegree
        } else if (self.resolution_deg - 0.5).abs() < 1e-9 {
            AngularResolution::HalfDegree
        } else if (self.resolution_deg - 0.25).abs() < 1e-9 {
            AngularResolution::QuarterDegree
        } else {
            return Err(format!(
                "`resolution_deg` is {}: give 1, 0.5 or 0.25",
                self.resolution_deg
            ));
        };
        let layout = ScanLayout::from_raw(width.degrees(), resolution.centidegrees())
            .map_err(|e| format!("`angle_deg` and `resolution_deg`: {e}"))?;
        let unit = match self.unit.as_str() {
            "mm" => RangeUnit::Millimetre,
            "cm" => RangeUnit::Centimetre,
            other => return Err(format!("`unit` is `{other}`: give \"mm\" or \"cm\"")),
        };
        let parity = match self.parity.as_str() {
            "none" => LineParity::None,
            "even" => LineParity::Even,
            other => {
                return Err(format!(
                    "`parity` is `{other}`: give \"none\" (LMS) or \"even\" (PLS)"
                ));
            }
        };
        if !(self.crc_error_threshold.is_finite()
            && (0.0..=1.0).contains(&self.crc_error_threshold))
        {
            return Err(format!(
                "`crc_error_threshold` is {}: give a fraction from 0 to 1",
                self.crc_error_threshold
            ));
        }
        Ok(SickDriverConfig {
            baud,
            layout,
            unit,
            parity,
            crc_error_threshold: self.crc_error_threshold,
            ..SickDriverConfig::new(&self.port)
        })
    }
}

/// Turns decoded scans into the laser's publications.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserPublisher {
    mount: Mount,
    sectors: usize,
}

impl LaserPublisher {
    /// Publications for a scanner at `mount`, with `sectors` Distance sectors.
    #[must_use]
    pub fn new(mount: Mount, sectors: usize) -> Self {
        Self { mount, sectors }
    }

    /// The RangeFinder of a scan: uniform beams from the scanner's right, in the robot frame
    /// (the offsets are the mount's). Readings at the unit's largest value saw nothing.
    #[must_use]
    pub fn range_finder(&self, scan: &LaserScan) -> RangeFinder {
        let ranges = scan.ranges_m();
        let count = ranges.len();
        let mount = self.mount.to_sensor_mount();
        let start_rad = scan.angle_rad(0);
        let step_rad = if count > 1 {
            scan.angle_rad(1) - start_rad
        } else {
            0.0
        };
        RangeFinder {
            range_count: i32::try_from(count).unwrap_or(i32::MAX),
            sensor_positions: (0..count)
                .map(|i| {
                    let mut pose = mount.to_pose3d();
                    pose.theta += scan.angle_rad(i);
                    pose
                })
                .collect(),
            ranges,
            max_range: scan.max_range_m(),
            uniform: true,
            x_offset: mount.pose.x_m,
            y_offset: mount.pose.y_m,
            z_offset: mount.height_m,
            theta_offset: mount.pose.heading_rad + start_rad,
            theta_separation: step_rad,
            ..RangeFinder::default()
        }
    }

    /// The Distance of a scan's RangeFinder.
    #[must_use]
    pub fn distance(&self, scan: &RangeFinder) -> Distance {
        distance_from_range_finder(scan, SectorLayout::full_circle(self.sectors))
    }
}

/// The `sick` service.
#[derive(Debug)]
pub struct SickService {
    config: SickDriverConfig,
    driver: Option<SickDriver>,
    publisher: LaserPublisher,
    publish_range_finder: bool,
    publish_distance: bool,
    /// When the next attempt to open the port is due (while there is no driver).
    next_open_ns: i64,
    last_open_error: Option<String>,
}

/// Builds a `sick` service from its robot-file entry.
///
/// # Errors
/// When a parameter is missing, unknown or names something the scanner does not have.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: SickParams = config.parameters()?;
    let mut driver_config = params
        .driver_config()
        .map_err(|reason| invalid(config, reason))?;
    driver_config.scan_deadline = millis(config, "scan_deadline_ms", params.scan_deadline_ms)?;
    driver_config.reply_timeout = millis(config, "reply_timeout_ms", params.reply_timeout_ms)?;
    driver_config.reconnect_interval = millis(
        config,
        "reconnect_interval_ms",
        params.reconnect_interval_ms,
    )?;
    let sectors = sector_count(config, params.distance_sectors)?;
    Ok(Box::new(SickService {
        config: driver_config,
        driver: None,
        publisher: LaserPublisher::new(params.mount, sectors),
        publish_range_finder: provides::<RangeFinder>(config),
        publish_distance: provides::<Distance>(config),
        next_open_ns: 0,
        last_open_error: None,
    }))
}

impl SickService {
    /// Opens the port and sets the scanner up when an attempt is due.
    fn open(&mut self, ctx: &mut Context<'_>) {
        if ctx.now() < self.next_open_ns {
            return;
        }
        let interval_ns =
            i64::try_from(self.config.reconnect_interval.as_nanos()).unwrap_or(i64::MAX);
        self.next_open_ns = ctx.now().saturating_add(interval_ns);
        match SickDriver::open(self.config.clone()) {
            Ok(driver) => {
                ctx.info(&format!(
                    "SICK scanner on {} streaming at {} baud",
                    self.config.path.display(),
                    driver.baud().map_or(0, BaudRate::bits_per_second)
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

    /// Publishes every scan that has arrived, then declares the driver's health.
    fn drain(&mut self, ctx: &mut Context<'_>) {
        let Some(driver) = &mut self.driver else {
            return;
        };
        while let Some(scan) = driver.read_scan(Duration::ZERO) {
            let mut range_finder = self.publisher.range_finder(&scan);
            if self.publish_distance {
                publish(ctx, &mut self.publisher.distance(&range_finder));
            }
            if self.publish_range_finder {
                publish(ctx, &mut range_finder);
            }
        }
        declare(ctx, health_of(&driver.health()));
    }
}

impl Service for SickService {
    fn tick_period_ns(&self) -> Option<i64> {
        Some(TICK_NS)
    }

    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        self.open(ctx);
        Ok(())
    }

    fn on_tick(&mut self, ctx: &mut Context<'_>) {
        if self.driver.is_none() {
            self.open(ctx);
        }
        // Also reopens a port that went away (the driver retries while it is read).
        self.drain(ctx);
    }

    fn device(&self) -> Option<std::os::fd::BorrowedFd<'_>> {
        self.driver.as_ref().and_then(SickDriver::fd)
    }

    fn on_device(&mut self, ctx: &mut Context<'_>) {
        self.drain(ctx);
    }

    fn on_command(
        &mut self,
        ctx: &mut Context<'_>,
        command: &IncomingCommand<'_>,
    ) -> Result<Reply, CommandError> {
        match command.interface {
            "RangeFinder" => match command.decode::<RangeFinder>()? {
                RangeFinderCommand::GetGeometry(_) => {
                    let layout = self.config.layout;
                    let baud = self.driver.as_ref().and_then(SickDriver::baud);
                    let rate = baud.map_or(0.0, |baud| {
                        // One telegram of the layout's values at the line's rate.
                        let bytes = 7 + 2 * layout.value_count() + 3;
                        let ns = baud.transmit_time_ns(bytes, self.config.parity.bits_per_byte());
                        #[allow(clippy::cast_precision_loss)]
                        let rate = if ns > 0 { 1e9 / ns as f64 } else { 0.0 };
                        rate
                    });
                    Ok(ctx.reply(RangeFinderGetGeometryReply {
                        range_count: i32::try_from(layout.value_count()).unwrap_or(i32::MAX),
                        max_range: match self.config.unit {
                            RangeUnit::Millimetre => 8.191,
                            _ => 81.91,
                        },
                        rate,
                        ..RangeFinderGetGeometryReply::default()
                    }))
                }
            },
            "Distance" => match command.decode::<Distance>()? {
                DistanceCommand::SetSectorCount(c) => {
                    let sectors = usize::try_from(c.sector_count)
                        .ok()
                        .filter(|n| (1..=360).contains(n))
                        .ok_or_else(|| {
                            CommandError::new(format!(
                                "set_sector_count: {} sectors, expected 1 to 360",
                                c.sector_count
                            ))
                        })?;
                    self.publisher.sectors = sectors;
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
    use super::*;

    fn params(extra: &str) -> Result<SickDriverConfig, String> {
        let text = format!("port = \"/dev/ttyS0\"\n{extra}");
        let params: SickParams = toml::from_str(&text).map_err(|e| e.to_string())?;
        params.driver_config()
    }

    #[test]
    fn parameters_become_the_driver_configuration_or_a_clear_error() {
        let config = params("").unwrap();
        assert_eq!(config.baud, BaudRate::B38400);
        assert_eq!(config.layout, ScanLayout::WIDE_HALF_DEGREE);
        assert_eq!(config.unit, RangeUnit::Millimetre);
        let config = params("baud = 500000\nunit = \"cm\"\nparity = \"even\"").unwrap();
        assert_eq!(
            (config.baud, config.unit, config.parity),
            (BaudRate::B500000, RangeUnit::Centimetre, LineParity::Even)
        );
        let check_error = |extra: &str, needle: &str| {
            let error = params(extra).unwrap_err();
            assert!(error.contains(needle), "{extra}: {error}");
        };
        check_error("baud = 115200", "`baud` is 115200");
        check_error("angle_deg = 90", "`angle_deg` is 90");
        check_error("resolution_deg = 0.3", "`resolution_deg` is 0.3");
        check_error(
            "angle_deg = 180\nresolution_deg = 0.25",
            "`angle_deg` and `resolution_deg`",
        );
        check_error("unit = \"m\"", "`unit` is `m`");
        check_error("parity = \"odd\"", "`parity` is `odd`");
        check_error("crc_error_threshold = 2.0", "`crc_error_threshold` is 2");
    }
}
