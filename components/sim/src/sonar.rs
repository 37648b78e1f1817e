//! The B21r's sonar ring: each transducer sends a cone, modelled by several rays across it;
//! the reading is the nearest echo, and a surface met at a grazing angle reflects the sound
//! away (a specular miss: nothing comes back). Published as a RangeFinder with
//! `uniform = false` and one Pose3D per transducer.

use lewis_interfaces::msg::{Distance, RangeFinder, RangeFinderGetGeometryReply};

use lewis_geometry::{
    Pose2, SectorLayout, SensorMount, Vec2, b21r_sonar_ring, distance_from_range_finder,
};

use super::laser::{SensorConfigError, check_non_negative, check_positive};
use super::world::World;
use lewis_service::Rng;

/// The sonar's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct SonarConfig {
    /// The transducers, in RangeFinder order.
    pub transducers: Vec<SensorMount>,
    /// Largest range, in m; no echo reads this.
    pub max_range_m: f64,
    /// Smallest range the transducer can measure, in m: nearer echoes read this.
    pub min_range_m: f64,
    /// Half of the cone's opening angle, in rad.
    pub cone_half_angle_rad: f64,
    /// Rays cast across the cone (at least 1; one means a thin beam).
    pub rays_per_cone: usize,
    /// A ray meeting a surface further than this from its normal gets no echo, in rad.
    pub specular_incidence_rad: f64,
    /// Standard deviation of the range noise, constant part, in m.
    pub range_noise_std_m: f64,
    /// Standard deviation of the range noise, part proportional to the range.
    pub range_noise_fraction: f64,
    /// Ring scans per second, reported in the geometry.
    pub rate_hz: f64,
}

impl Default for SonarConfig {
    /// The B21r's ring of Polaroid transducers: a 25 degree cone, 5 m, specular beyond 30
    /// degrees of incidence, 10 ring scans per second.
    fn default() -> Self {
        Self {
            transducers: b21r_sonar_ring(),
            max_range_m: 5.0,
            min_range_m: 0.15,
            cone_half_angle_rad: 12.5f64.to_radians(),
            rays_per_cone: 7,
            specular_incidence_rad: 30f64.to_radians(),
            range_noise_std_m: 0.02,
            range_noise_fraction: 0.01,
            rate_hz: 10.0,
        }
    }
}

impl SonarConfig {
    /// Checks that every parameter can work.
    ///
    /// # Errors
    /// The first parameter that cannot.
    pub fn validate(&self) -> Result<(), SensorConfigError> {
        let count = |n: usize| n as f64;
        if self.transducers.is_empty() || i32::try_from(self.transducers.len()).is_err() {
            return Err(SensorConfigError {
                device: "sonar",
                field: "transducers",
                value: count(self.transducers.len()),
                expected: "at least one transducer",
            });
        }
        if self.rays_per_cone == 0 {
            return Err(SensorConfigError {
                device: "sonar",
                field: "rays_per_cone",
                value: 0.0,
                expected: "at least 1",
            });
        }
        check_positive(
            "sonar",
            &[("max_range_m", self.max_range_m), ("rate_hz", self.rate_hz)],
        )?;
        check_non_negative(
            "sonar",
            &[
                ("min_range_m", self.min_range_m),
                ("cone_half_angle_rad", self.cone_half_angle_rad),
                ("specular_incidence_rad", self.specular_incidence_rad),
                ("range_noise_std_m", self.range_noise_std_m),
                ("range_noise_fraction", self.range_noise_fraction),
            ],
        )
    }
}

/// The simulated sonar ring.
#[derive(Debug, Clone)]
pub struct SimSonar {
    config: SonarConfig,
    rng: Rng,
}

impl SimSonar {
    /// A sonar ring with its own random generator seeded from `seed`.
    ///
    /// # Errors
    /// When a parameter cannot work.
    pub fn new(config: SonarConfig, seed: u64) -> Result<Self, SensorConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            rng: Rng::for_device(seed, "sonar"),
        })
    }

    /// Its parameters.
    #[must_use]
    pub fn config(&self) -> &SonarConfig {
        &self.config
    }

    /// The noiseless reading of transducer `mount` with the robot at `robot_pose`: the
    /// nearest echo over the rays of the cone, or max range when every ray missed or was
    /// reflected away.
    #[must_use]
    pub fn true_range(&self, world: &World, robot_pose: Pose2, mount: &SensorMount) -> f64 {
        let c = &self.config;
        let sensor = robot_pose.compose(mount.pose);
        let origin = sensor.position();
        let mut nearest = c.max_range_m;
        let cos_specular = c.specular_incidence_rad.cos();
        for k in 0..c.rays_per_cone {
            let offset = if c.rays_per_cone == 1 {
                0.0
            } else {
                let t = k as f64 / (c.rays_per_cone - 1) as f64;
                -c.cone_half_angle_rad + 2.0 * c.cone_half_angle_rad * t
            };
            let dir = Vec2::from_angle(sensor.heading_rad + offset);
            if let Some(hit) = world.cast_ray(origin, dir, nearest, mount.height_m)
                && (-dir).dot(hit.normal) >= cos_specular
            {
                nearest = nearest.min(hit.range_m);
            }
        }
        nearest
    }

    /// One scan of the ring from `robot_pose` in `world`, as the RangeFinder publication
    /// (header left for the service to fill).
    pub fn scan(&mut self, world: &World, robot_pose: Pose2) -> RangeFinder {
        let c = &self.config;
        let mut ranges = Vec::with_capacity(c.transducers.len());
        for mount in &c.transducers {
            let r = self.true_range(world, robot_pose, mount);
            let r = if r < c.max_range_m {
                let std = c.range_noise_std_m + c.range_noise_fraction * r;
                (r + self.rng.normal(0.0, std)).clamp(c.min_range_m, c.max_range_m)
            } else {
                r
            };
            ranges.push(r);
        }
        RangeFinder {
            range_count: i32::try_from(ranges.len()).unwrap_or(i32::MAX),
            ranges,
            max_range: c.max_range_m,
            uniform: false,
            sensor_positions: c.transducers.iter().map(|m| m.to_pose3d()).collect(),
            ..RangeFinder::default()
        }
    }

    /// The reply to `get_geometry`.
    #[must_use]
    pub fn geometry(&self) -> RangeFinderGetGeometryReply {
        RangeFinderGetGeometryReply {
            range_count: i32::try_from(self.config.transducers.len()).unwrap_or(i32::MAX),
            max_range: self.config.max_range_m,
            rate: self.config.rate_hz,
            ..RangeFinderGetGeometryReply::default()
        }
    }

    /// The sonar's Distance: `sector_count` sectors around the whole robot.
    #[must_use]
    pub fn distance(scan: &RangeFinder, sector_count: usize) -> Distance {
        distance_from_range_finder(scan, SectorLayout::full_circle(sector_count))
    }
}
