//! A SICK LMS-like laser: beams fanned over 180 degrees in a horizontal plane, ray cast
//! against the world, with range noise and drop-outs. Published as a uniform RangeFinder.

use std::f64::consts::PI;

use lewis_geometry::{Pose2, SectorLayout, SensorMount, Vec2, distance_from_range_finder};
use lewis_interfaces::msg::{Pose3D, RangeFinder, RangeFinderGetGeometryReply};

use super::world::World;
use lewis_service::Rng;

/// The laser's parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserConfig {
    /// Number of beams, spread evenly from -fov/2 to +fov/2 (SICK: 181 or 361).
    pub beam_count: usize,
    /// Field of view, in rad (SICK: pi).
    pub field_of_view_rad: f64,
    /// Largest range reported, in m (SICK in mm mode: 8.191); a beam that hits nothing
    /// within it reads this.
    pub max_range_m: f64,
    /// Where the scanner sits on the robot.
    pub mount: SensorMount,
    /// Standard deviation of the range noise, in m (SICK LMS200: about 0.01).
    pub range_noise_std_m: f64,
    /// Probability that a beam returns nothing (reads max range).
    pub dropout_probability: f64,
    /// Scans per second, reported in the geometry (the service's rate).
    pub rate_hz: f64,
}

impl Default for LaserConfig {
    /// A SICK LMS200 at 0.5 degree resolution in mm mode, streaming at 500 kbaud: the
    /// scanner's 75 Hz sweeps interlace two half-degree passes, so full 361-beam scans come
    /// at 37.5 Hz (a 732-byte telegram needs about 15 ms at 500 kbaud, so the link keeps up;
    /// at 38400 baud it would limit the rate to about 5 Hz). Mounted at the B21r's front.
    fn default() -> Self {
        Self {
            beam_count: 361,
            field_of_view_rad: PI,
            max_range_m: 8.191,
            mount: SensorMount {
                pose: Pose2::new(0.12, 0.0, 0.0),
                height_m: 0.38,
            },
            range_noise_std_m: 0.01,
            dropout_probability: 0.0,
            rate_hz: 37.5,
        }
    }
}

/// A laser or sonar parameter that cannot work.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{device} parameter `{field}` is {value}: {expected}")]
pub struct SensorConfigError {
    /// The device.
    pub device: &'static str,
    /// The parameter.
    pub field: &'static str,
    /// Its value.
    pub value: f64,
    /// What it must be.
    pub expected: &'static str,
}

pub(crate) fn check_positive(
    device: &'static str,
    fields: &[(&'static str, f64)],
) -> Result<(), SensorConfigError> {
    for &(field, value) in fields {
        if !(value.is_finite() && value > 0.0) {
            return Err(SensorConfigError {
                device,
                field,
                value,
                expected: "a positive number",
            });
        }
    }
    Ok(())
}

pub(crate) fn check_non_negative(
    device: &'static str,
    fields: &[(&'static str, f64)],
) -> Result<(), SensorConfigError> {
    for &(field, value) in fields {
        if !(value.is_finite() && value >= 0.0) {
            return Err(SensorConfigError {
                device,
                field,
                value,
                expected: "zero or more",
            });
        }
    }
    Ok(())
}

impl LaserConfig {
    /// Checks that every parameter can work.
    ///
    /// # Errors
    /// The first parameter that cannot.
    pub fn validate(&self) -> Result<(), SensorConfigError> {
        let beams = self.beam_count as f64;
        if self.beam_count < 2 || i32::try_from(self.beam_count).is_err() {
            return Err(SensorConfigError {
                device: "laser",
                field: "beam_count",
                value: beams,
                expected: "at least 2 (SICK: 181 or 361)",
            });
        }
        check_positive(
            "laser",
            &[
                ("field_of_view_rad", self.field_of_view_rad),
                ("max_range_m", self.max_range_m),
                ("rate_hz", self.rate_hz),
            ],
        )?;
        check_non_negative(
            "laser",
            &[
                ("range_noise_std_m", self.range_noise_std_m),
                ("mount.height_m", self.mount.height_m),
            ],
        )?;
        if !(0.0..=1.0).contains(&self.dropout_probability) {
            return Err(SensorConfigError {
                device: "laser",
                field: "dropout_probability",
                value: self.dropout_probability,
                expected: "between 0 and 1",
            });
        }
        Ok(())
    }

    /// Angle between two neighbouring beams, in rad.
    #[must_use]
    pub fn beam_separation_rad(&self) -> f64 {
        let gaps = (self.beam_count - 1) as f64;
        self.field_of_view_rad / gaps
    }

    /// Bearing of the first (rightmost) beam in the robot frame, in rad.
    #[must_use]
    pub fn first_beam_rad(&self) -> f64 {
        self.mount.pose.heading_rad - self.field_of_view_rad / 2.0
    }
}

/// The simulated laser.
#[derive(Debug, Clone)]
pub struct SimLaser {
    config: LaserConfig,
    rng: Rng,
}

impl SimLaser {
    /// A laser with its own random generator seeded from `seed`.
    ///
    /// # Errors
    /// When a parameter cannot work.
    pub fn new(config: LaserConfig, seed: u64) -> Result<Self, SensorConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            rng: Rng::for_device(seed, "laser"),
        })
    }

    /// Its parameters.
    #[must_use]
    pub fn config(&self) -> &LaserConfig {
        &self.config
    }

    /// The noiseless ranges seen from `robot_pose` (no drop-outs), beam 0 rightmost.
    pub fn true_ranges(&self, world: &World, robot_pose: Pose2, ranges: &mut Vec<f64>) {
        let c = &self.config;
        let sensor = robot_pose.compose(c.mount.pose);
        let origin = sensor.position();
        let first = robot_pose.heading_rad + c.first_beam_rad();
        let step = c.beam_separation_rad();
        ranges.clear();
        for i in 0..c.beam_count {
            let angle = first + step * i as f64;
            let hit = world.cast_ray(
                origin,
                Vec2::from_angle(angle),
                c.max_range_m,
                c.mount.height_m,
            );
            ranges.push(hit.map_or(c.max_range_m, |h| h.range_m));
        }
    }

    /// One scan from `robot_pose` in `world`, as the RangeFinder publication (header left
    /// for the service to fill): uniform, with the offsets of the first beam and the
    /// separation between beams, and one Pose3D per beam as the interface requires.
    pub fn scan(&mut self, world: &World, robot_pose: Pose2) -> RangeFinder {
        let mut ranges = Vec::with_capacity(self.config.beam_count);
        self.true_ranges(world, robot_pose, &mut ranges);
        let c = self.config;
        for r in &mut ranges {
            if self.rng.chance(c.dropout_probability) {
                *r = c.max_range_m;
            } else if *r < c.max_range_m {
                *r = (*r + self.rng.normal(0.0, c.range_noise_std_m)).clamp(0.0, c.max_range_m);
            }
        }
        let first = c.first_beam_rad();
        let step = c.beam_separation_rad();
        let mount = c.mount.to_pose3d();
        let sensor_positions = (0..c.beam_count)
            .map(|i| {
                let theta = first + step * i as f64;
                Pose3D {
                    theta,
                    ..mount.clone()
                }
            })
            .collect();
        RangeFinder {
            range_count: i32::try_from(c.beam_count).unwrap_or(i32::MAX),
            ranges,
            max_range: c.max_range_m,
            uniform: true,
            sensor_positions,
            x_offset: mount.x,
            y_offset: mount.y,
            z_offset: mount.z,
            theta_offset: first,
            theta_separation: step,
            ..RangeFinder::default()
        }
    }

    /// The reply to `get_geometry`.
    #[must_use]
    pub fn geometry(&self) -> RangeFinderGetGeometryReply {
        RangeFinderGetGeometryReply {
            range_count: i32::try_from(self.config.beam_count).unwrap_or(i32::MAX),
            max_range: self.config.max_range_m,
            rate: self.config.rate_hz,
            ..RangeFinderGetGeometryReply::default()
        }
    }

    /// The laser's Distance: `sector_count` sectors over its field of view.
    #[must_use]
    pub fn distance(
        &self,
        scan: &RangeFinder,
        sector_count: usize,
    ) -> lewis_interfaces::msg::Distance {
        let c = &self.config;
        let half = c.field_of_view_rad / 2.0;
        let centre = c.mount.pose.heading_rad;
        distance_from_range_finder(
            scan,
            SectorLayout::spanning(centre - half, centre + half, sector_count),
        )
    }
}
