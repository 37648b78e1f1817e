//! `sim-sonar`: the B21r's sonar ring, each transducer a cone of rays cast from the latest
//! GroundTruth pose, with specular misses (a surface met too far from its normal sends the
//! sound away). Publishes RangeFinder (`uniform = false`, one Pose3D per transducer) and
//! Distance (sectors all around the robot), each for the interfaces the robot file lets it
//! provide.
//!
//! The specular limit is a parameter, `specular_incidence_deg`. A bare Polaroid transducer
//! on a smooth wall loses the echo beyond about 30 degrees; the default is 60, because the
//! walls of a real building (door frames, skirting, posters) return more than a mirror
//! does, and because at 30 degrees a wall met obliquely is seen only by the transducer that
//! faces it square, which leaves a sonar-only obstacle avoider little margin. Measured with
//! the ObstacleAvoider of `motion` driving on sonar alone from the lobby through the
//! entrance door along the corridor (tests/sim_sonar_avoidance.rs): 30, 45 and 60 degrees
//! all arrived with no collision; routes with long walls met at grazing angles are not
//! measured yet.
//!
//! ```toml
//! [services.parameters]
//! world = "robots/worlds/conference"
//! seed = 3
//! rate_hz = 10.0
//! max_range_m = 5.0
//! min_range_m = 0.15
//! cone_half_angle_deg = 12.5
//! rays_per_cone = 7
//! specular_incidence_deg = 60.0
//! range_noise_std_m = 0.02
//! range_noise_fraction = 0.01
//! distance_sectors = 24       # Distance's sectors around the robot (set_sector_count)
//! # transducers = [ { x_m = 0.26, y_m = 0.0, heading_deg = 0.0, height_m = 0.62 }, ... ]
//! #   (default: the B21r's 48, two rings of 24)
//! ```

use std::path::PathBuf;

use lewis_geometry::Pose2;
use lewis_geometry::b21r_sonar_ring;
use lewis_interfaces::msg::{Distance, RangeFinder, RangeFinderGetGeometryReply};
use lewis_service::{BuildError, Service, ServiceConfig};
use serde::Deserialize;

use super::range::{RangeSensor, RangeService};
use super::{MountParams, invalid, load_world, period_ns, sector_count};
use crate::sonar::{SimSonar, SonarConfig};
use crate::world::World;

/// The kind name in robot files.
pub const KIND: &str = "sim-sonar";

/// The default specular limit, in degrees (see the module documentation).
pub const DEFAULT_SPECULAR_INCIDENCE_DEG: f64 = 60.0;

/// The parameters of `sim-sonar`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SonarParams {
    /// The world folder (`world.toml` and its map).
    pub world: PathBuf,
    /// Seed of the range noise.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Ring scans per second.
    #[serde(default = "defaults::rate_hz")]
    pub rate_hz: f64,
    /// Largest range, in m; no echo reads this.
    #[serde(default = "defaults::max_range_m")]
    pub max_range_m: f64,
    /// Smallest measurable range, in m: nearer echoes read this.
    #[serde(default = "defaults::min_range_m")]
    pub min_range_m: f64,
    /// Half of the cone's opening angle, in degrees.
    #[serde(default = "defaults::cone_half_angle_deg")]
    pub cone_half_angle_deg: f64,
    /// Rays cast across each cone.
    #[serde(default = "defaults::rays_per_cone")]
    pub rays_per_cone: usize,
    /// A ray meeting a surface further than this from its normal gets no echo, in degrees.
    #[serde(default = "defaults::specular_incidence_deg")]
    pub specular_incidence_deg: f64,
    /// Standard deviation of the range noise, constant part, in m.
    #[serde(default = "defaults::range_noise_std_m")]
    pub range_noise_std_m: f64,
    /// Standard deviation of the range noise, part proportional to the range.
    #[serde(default = "defaults::range_noise_fraction")]
    pub range_noise_fraction: f64,
    /// Sectors of the Distance publication, all around the robot.
    #[serde(default = "defaults::distance_sectors")]
    pub distance_sectors: i64,
    /// The transducers, in RangeFinder order (default: the B21r's two rings of 24).
    #[serde(default)]
    pub transducers: Option<Vec<MountParams>>,
}

mod defaults {
    use super::{DEFAULT_SPECULAR_INCIDENCE_DEG, SonarConfig};

    pub(super) fn rate_hz() -> f64 {
        SonarConfig::default().rate_hz
    }
    pub(super) fn max_range_m() -> f64 {
        SonarConfig::default().max_range_m
    }
    pub(super) fn min_range_m() -> f64 {
        SonarConfig::default().min_range_m
    }
    pub(super) fn cone_half_angle_deg() -> f64 {
        SonarConfig::default().cone_half_angle_rad.to_degrees()
    }
    pub(super) fn rays_per_cone() -> usize {
        SonarConfig::default().rays_per_cone
    }
    pub(super) fn specular_incidence_deg() -> f64 {
        DEFAULT_SPECULAR_INCIDENCE_DEG
    }
    pub(super) fn range_noise_std_m() -> f64 {
        SonarConfig::default().range_noise_std_m
    }
    pub(super) fn range_noise_fraction() -> f64 {
        SonarConfig::default().range_noise_fraction
    }
    pub(super) fn distance_sectors() -> i64 {
        24
    }
}

impl SonarParams {
    /// The model's configuration.
    #[must_use]
    pub fn sonar_config(&self) -> SonarConfig {
        SonarConfig {
            transducers: self.transducers.as_ref().map_or_else(b21r_sonar_ring, |t| {
                t.iter().map(|m| m.to_mount()).collect()
            }),
            max_range_m: self.max_range_m,
            min_range_m: self.min_range_m,
            cone_half_angle_rad: self.cone_half_angle_deg.to_radians(),
            rays_per_cone: self.rays_per_cone,
            specular_incidence_rad: self.specular_incidence_deg.to_radians(),
            range_noise_std_m: self.range_noise_std_m,
            range_noise_fraction: self.range_noise_fraction,
            rate_hz: self.rate_hz,
        }
    }
}

/// The `sim-sonar` service.
pub type SimSonarService = RangeService<SimSonar>;

/// Builds a `sim-sonar` service from its robot-file entry.
///
/// # Errors
/// When a parameter is missing, unknown or cannot work, or the world does not load.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: SonarParams = config.parameters()?;
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
    if !(0.0..=90.0).contains(&params.specular_incidence_deg) {
        return Err(invalid(
            config,
            format!(
                "`specular_incidence_deg` is {}: give 0 to 90 (90: no specular misses)",
                params.specular_incidence_deg
            ),
        ));
    }
    let sonar = SimSonar::new(params.sonar_config(), config.seed())
        .map_err(|e| invalid(config, e.to_string()))?;
    let world = load_world(config, &params.world)?;
    Ok(Box::new(RangeService::new(
        config, world, sonar, period_ns, sectors,
    )))
}

impl RangeSensor for SimSonar {
    const KIND: &'static str = KIND;

    fn scan(&mut self, world: &World, pose: Pose2) -> RangeFinder {
        SimSonar::scan(self, world, pose)
    }

    fn distance(&self, scan: &RangeFinder, sectors: usize) -> Distance {
        SimSonar::distance(scan, sectors)
    }

    fn geometry(&self) -> RangeFinderGetGeometryReply {
        SimSonar::geometry(self)
    }
}
