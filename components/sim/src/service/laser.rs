//! `sim-laser`: a SICK LMS-like scanner, ray cast from the latest GroundTruth pose at the
//! scanner's rate. Publishes RangeFinder (uniform, beam 0 rightmost) and Distance (sectors
//! over its field of view), each for the interfaces the robot file lets it provide.
//!
//! ```toml
//! [services.parameters]
//! world = "robots/worlds/conference"
//! seed = 2
//! beam_count = 361            # SICK: 181 (1 degree) or 361 (half a degree)
//! field_of_view_deg = 180.0
//! max_range_m = 8.191
//! rate_hz = 37.5              # a SICK LMS200 at 500 kbaud, interlaced half degrees
//! range_noise_std_m = 0.01
//! dropout_probability = 0.0
//! distance_sectors = 36       # Distance's sectors over the field of view (set_sector_count)
//! mount = { x_m = 0.12, y_m = 0.0, heading_deg = 0.0, height_m = 0.38 }
//! ```

use std::path::PathBuf;

use lewis_geometry::Pose2;
use lewis_interfaces::msg::{Distance, RangeFinder, RangeFinderGetGeometryReply};
use lewis_service::{BuildError, Service, ServiceConfig};
use serde::Deserialize;

use super::range::{RangeSensor, RangeService};
use super::{MountParams, invalid, load_world, period_ns, sector_count};
use crate::laser::{LaserConfig, SimLaser};
use crate::world::World;

/// The kind name in robot files.
pub const KIND: &str = "sim-laser";

/// The parameters of `sim-laser`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserParams {
    /// The world folder (`world.toml` and its map).
    pub world: PathBuf,
    /// Seed of the range noise and drop-outs.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Beams, spread evenly over the field of view (SICK: 181 or 361).
    #[serde(default = "defaults::beam_count")]
    pub beam_count: usize,
    /// Field of view, centred ahead, in degrees.
    #[serde(default = "defaults::field_of_view_deg")]
    pub field_of_view_deg: f64,
    /// Largest range reported, in m; a beam that hits nothing reads this.
    #[serde(default = "defaults::max_range_m")]
    pub max_range_m: f64,
    /// Scans per second.
    #[serde(default = "defaults::rate_hz")]
    pub rate_hz: f64,
    /// Standard deviation of the range noise, in m.
    #[serde(default = "defaults::range_noise_std_m")]
    pub range_noise_std_m: f64,
    /// Probability that a beam returns nothing (reads max range).
    #[serde(default)]
    pub dropout_probability: f64,
    /// Sectors of the Distance publication, spread over the field of view.
    #[serde(default = "defaults::distance_sectors")]
    pub distance_sectors: i64,
    /// Where the scanner sits on the robot.
    #[serde(default = "defaults::mount")]
    pub mount: MountParams,
}

mod defaults {
    use super::{LaserConfig, MountParams};

    pub(super) fn beam_count() -> usize {
        LaserConfig::default().beam_count
    }
    pub(super) fn field_of_view_deg() -> f64 {
        LaserConfig::default().field_of_view_rad.to_degrees()
    }
    pub(super) fn max_range_m() -> f64 {
        LaserConfig::default().max_range_m
    }
    pub(super) fn rate_hz() -> f64 {
        LaserConfig::default().rate_hz
    }
    pub(super) fn range_noise_std_m() -> f64 {
        LaserConfig::default().range_noise_std_m
    }
    pub(super) fn distance_sectors() -> i64 {
        36
    }
    pub(super) fn mount() -> MountParams {
        MountParams::from_mount(LaserConfig::default().mount)
    }
}

impl LaserParams {
    /// The model's configuration.
    #[must_use]
    pub fn laser_config(&self) -> LaserConfig {
        LaserConfig {
            beam_count: self.beam_count,
            field_of_view_rad: self.field_of_view_deg.to_radians(),
            max_range_m: self.max_range_m,
            mount: self.mount.to_mount(),
            range_noise_std_m: self.range_noise_std_m,
            dropout_probability: self.dropout_probability,
            rate_hz: self.rate_hz,
        }
    }
}

/// The `sim-laser` service.
pub type SimLaserService = RangeService<SimLaser>;

/// Builds a `sim-laser` service from its robot-file entry.
///
/// # Errors
/// When a parameter is missing, unknown or cannot work, or the world does not load.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: LaserParams = config.parameters()?;
    let period_ns = period_ns(config, "rate_hz", params.rate_hz)?;
    let sectors = sector_count(params.distance_sectors).ok_or_else(|| {
        invalid(
            config,
            format!(
                "`distance_sectors` is {}: give 1 to 360",
                params.distance_sectors
            ),
        )
    })?;
    let laser = SimLaser::new(params.laser_config(), config.seed())
        .map_err(|e| invalid(config, e.to_string()))?;
    let world = load_world(config, &params.world)?;
    Ok(Box::new(RangeService::new(
        config, world, laser, period_ns, sectors,
    )))
}

impl RangeSensor for SimLaser {
    const KIND: &'static str = KIND;

    fn scan(&mut self, world: &World, pose: Pose2) -> RangeFinder {
        SimLaser::scan(self, world, pose)
    }

    fn distance(&self, scan: &RangeFinder, sectors: usize) -> Distance {
        SimLaser::distance(self, scan, sectors)
    }

    fn geometry(&self) -> RangeFinderGetGeometryReply {
        SimLaser::geometry(self)
    }
}
