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
//! Everything that waits for the scanner (opening the port, probing its rate, setting it up,
//! reading, reconnecting) happens in the service's device reader ([`SickReader`], a thread),
//! so the service's own thread never blocks and its heartbeats keep flowing. While the
//! scanner is first set up the service is degraded (its clients stay and wait); once it has
//! streamed, any trouble (silence past the deadline, too many bad CRCs, the port gone, a
//! set-up that fails) is out of service, until scans flow again.

use std::path::PathBuf;

use lewis_geometry::{SectorLayout, distance_from_range_finder};
use lewis_interfaces::msg::{
    Distance, DistanceCommand, DistanceSetSectorCountReply, RangeFinder, RangeFinderCommand,
    RangeFinderGetGeometryReply,
};
use lewis_service::Health;
use lewis_service::{
    BuildError, CommandError, Context, IncomingCommand, Reply, Service, ServiceConfig,
};
use serde::Deserialize;

use super::{Mount, declare, health_of, invalid, millis, provides, publish, sector_count};
use crate::io::{LaserScan, LineParity, SickDriverConfig, SickNews, SickReader, SickReaderStatus};
use crate::sick::{AngularResolution, BaudRate, RangeUnit, ScanLayout, ScanWidth};

/// The kind name in robot files.
pub const KIND: &str = "sick";

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
    reader: Option<SickReader>,
    publisher: LaserPublisher,
    publish_range_finder: bool,
    publish_distance: bool,
    /// The rate the scanner streams at, while it does.
    baud: Option<BaudRate>,
    /// Whether scans have flowed since the start: trouble after that is out of service,
    /// a first set-up only degraded.
    streamed: bool,
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
        reader: None,
        publisher: LaserPublisher::new(params.mount, sectors),
        publish_range_finder: provides::<RangeFinder>(config),
        publish_distance: provides::<Distance>(config),
        baud: None,
        streamed: false,
    }))
}

/// The runtime's health for the reader's `status`, given the health declared now and
/// whether the scanner has streamed since the start. A set-up step never lifts an
/// out-of-service (the scanner has not proven itself yet): only streaming does.
#[must_use]
pub fn health_for(
    status: &SickReaderStatus,
    current: &Health,
    streamed: bool,
    path: &std::path::Path,
) -> Health {
    match status {
        SickReaderStatus::Streaming(_) => Health::Ok,
        SickReaderStatus::Trouble(trouble) => health_of(trouble),
        SickReaderStatus::SettingUp(_) if current.is_out_of_service() => current.clone(),
        SickReaderStatus::SettingUp(step) if streamed => Health::OutOfService(format!(
            "lost the SICK scanner on {}; setting it up again: {step}",
            path.display()
        )),
        SickReaderStatus::SettingUp(step) => Health::Degraded(format!(
            "setting up the SICK scanner on {}: {step}",
            path.display()
        )),
    }
}

impl SickService {
    /// Publishes the scans that arrived and declares what the reader says.
    fn take_news(&mut self, ctx: &mut Context<'_>) {
        let Some(reader) = &self.reader else {
            return;
        };
        let SickNews { scans, statuses } = reader.take();
        for report in statuses {
            if let SickReaderStatus::Streaming(baud) = report.status {
                if !self.streamed || self.baud != Some(baud) {
                    ctx.info(&format!(
                        "SICK scanner on {} streaming at {} baud",
                        self.config.path.display(),
                        baud.bits_per_second()
                    ));
                }
                self.streamed = true;
                self.baud = Some(baud);
            } else {
                self.baud = None;
            }
            let health = health_for(
                &report.status,
                ctx.health(),
                self.streamed,
                &self.config.path,
            );
            declare(ctx, health);
        }
        for scan in &scans {
            self.publish_scan(ctx, scan);
        }
    }

    fn publish_scan(&self, ctx: &mut Context<'_>, scan: &LaserScan) {
        let mut range_finder = self.publisher.range_finder(scan);
        if self.publish_distance {
            publish(ctx, &mut self.publisher.distance(&range_finder));
        }
        if self.publish_range_finder {
            publish(ctx, &mut range_finder);
        }
    }
}

impl Service for SickService {
    fn on_start(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        declare(
            ctx,
            Health::Degraded(format!(
                "setting up the SICK scanner on {}",
                self.config.path.display()
            )),
        );
        self.reader = Some(SickReader::spawn(self.config.clone()).map_err(|e| e.to_string())?);
        Ok(())
    }

    fn device(&self) -> Option<std::os::fd::BorrowedFd<'_>> {
        self.reader.as_ref().map(SickReader::fd)
    }

    fn on_device(&mut self, ctx: &mut Context<'_>) {
        self.take_news(ctx);
    }

    fn on_stop(&mut self, _ctx: &mut Context<'_>) {
        // Stops the reader, which tells the scanner to stop streaming.
        self.reader = None;
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
                    let rate = self.baud.map_or(0.0, |baud| {
                        // One telegram of the layout's values at the line's rate.
                        let bytes = 7 + 2 * layout.value_count() + 3;
                        let ns = baud.transmit_time_ns(bytes, self.config.parity.bits_per_byte());

                        if ns > 0 { 1e9 / ns as f64 } else { 0.0 }
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
    use std::path::{Path, PathBuf};
    use std::time::Duration;

    use super::*;
    use crate::io::{DriverHealth, SetupStep};

    #[test]
    fn the_readers_status_becomes_the_services_health() {
        let path = Path::new("/dev/ttyS0");
        let probing = SickReaderStatus::SettingUp(SetupStep::Probing(BaudRate::B9600));
        let no_data = SickReaderStatus::Trouble(DriverHealth::NoData {
            path: PathBuf::from(path),
            silent_for: Duration::from_millis(1200),
            deadline: Duration::from_secs(1),
        });
        let out = |why: &str| Health::OutOfService(why.to_owned());
        let check =
            |status: &SickReaderStatus, current: &Health, streamed: bool, expected: &Health| {
                assert_eq!(
                    &health_for(status, current, streamed, path),
                    expected,
                    "{status:?} from {current:?}, streamed {streamed}"
                );
            };
        // A first set-up: clients wait (degraded, not out of service).
        check(
            &probing,
            &Health::Ok,
            false,
            &Health::Degraded(
                "setting up the SICK scanner on /dev/ttyS0: probing at 9600 baud".to_owned(),
            ),
        );
        // Once it streamed, setting it up again is out of service.
        check(
            &probing,
            &Health::Ok,
            true,
            &out("lost the SICK scanner on /dev/ttyS0; setting it up again: probing at 9600 baud"),
        );
        // A set-up step never lifts an out-of-service: only scans do.
        check(&probing, &out("silent"), false, &out("silent"));
        check(
            &SickReaderStatus::Streaming(BaudRate::B38400),
            &out("silent"),
            true,
            &Health::Ok,
        );
        check(
            &no_data,
            &Health::Ok,
            true,
            &out("no valid data on /dev/ttyS0 for 1.200 s (deadline 1.000 s)"),
        );
    }

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
