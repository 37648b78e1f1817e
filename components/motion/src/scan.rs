//! Range readings of any sensor as beams and obstacle points in the robot frame.
//!
//! A uniform RangeFinder (a laser) places its beams by offsets and separations; a
//! non-uniform one (the sonar ring) gives a Pose3D per transducer; a Distance reading gives
//! angular sectors around the robot centre. All become the same [`RangeScan`], so the
//! avoider works unchanged when the broker switches it from laser to sonar.

use lewis_geometry::Vec2;
use lewis_interfaces::msg::{Distance, RangeFinder};

/// One reading: a wedge from the sensor, in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Beam {
    /// Where the sensor is, in the robot frame, in m.
    pub origin: Vec2,
    /// Direction of the beam's axis in the robot frame, in rad.
    pub bearing_rad: f64,
    /// Half the beam's angular width, in rad (the sonar cone, the laser's beam spacing).
    pub half_width_rad: f64,
    /// The reading, in m: where the obstacle is, or the max range when nothing was seen.
    pub range_m: f64,
    /// Something was seen at `range_m` (false: free up to `range_m`).
    pub hit: bool,
}

impl Beam {
    /// The obstacle the reading implies, as points along its arc (robot frame), no more than
    /// `spacing_m` apart and at most `max_points` of them; none when nothing was seen.
    pub fn obstacle_points(
        &self,
        spacing_m: f64,
        max_points: usize,
    ) -> impl Iterator<Item = Vec2> + '_ {
        let arc_m = 2.0 * self.half_width_rad * self.range_m;
        let wanted = if spacing_m > 0.0 {
            (arc_m / spacing_m).ceil()
        } else {
            0.0
        };
        let count = if self.hit {
            (wanted.max(0.0) as usize + 1).min(max_points.max(1))
        } else {
            0
        };
        (0..count).map(move |i| {
            let fraction = if count == 1 {
                0.5
            } else {
                i as f64 / (count - 1) as f64
            };
            let angle =
                self.bearing_rad - self.half_width_rad + 2.0 * self.half_width_rad * fraction;
            self.origin + Vec2::from_angle(angle) * self.range_m
        })
    }
}

/// A reading that cannot be turned into beams.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScanError {
    /// A count field disagrees with the length of its array.
    #[error(
        "{interface}.{field} has {len} elements but {count_field} = {count}: the provider must publish as many as it counts"
    )]
    CountMismatch {
        /// RangeFinder or Distance.
        interface: &'static str,
        /// The array.
        field: &'static str,
        /// Its length.
        len: usize,
        /// The count field.
        count_field: &'static str,
        /// Its value.
        count: i32,
    },
    /// A geometry field is NaN, infinite or out of range.
    #[error("{interface}.{field} = {value} is invalid: expected {expected}")]
    BadField {
        /// RangeFinder or Distance.
        interface: &'static str,
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
}

/// A range reading as beams in the robot frame, whatever the sensor.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RangeScan {
    beams: Vec<Beam>,
    max_range_m: f64,
    unusable: usize,
}

fn check_count(
    interface: &'static str,
    field: &'static str,
    len: usize,
    count: i32,
) -> Result<(), ScanError> {
    if usize::try_from(count).ok() == Some(len) {
        Ok(())
    } else {
        Err(ScanError::CountMismatch {
            interface,
            field,
            len,
            count_field: field_count(field),
            count,
        })
    }
}

fn field_count(field: &'static str) -> &'static str {
    match field {
        "sector_distances" => "sector_count",
        _ => "range_count",
    }
}

fn check_finite(
    interface: &'static str,
    field: &'static str,
    value: f64,
) -> Result<f64, ScanError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ScanError::BadField {
            interface,
            field,
            value,
            expected: "a finite number",
        })
    }
}

fn check_max_range(interface: &'static str, value: f64) -> Result<f64, ScanError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ScanError::BadField {
            interface,
            field: "max_range",
            value,
            expected: "a finite number > 0",
        })
    }
}

impl RangeScan {
    /// The beams of a RangeFinder reading. Uniform readings place beam `i` at
    /// offset + i * separation (x, y, theta; z, phi and psi are ignored: the plane is the
    /// floor) with half the angular separation as width; non-uniform ones take beam `i` from
    /// `sensor_positions[i]` with `non_uniform_half_width_rad` as width (the RangeFinder
    /// does not carry a cone width). Ranges that are NaN, infinite or not positive are
    /// skipped and counted in [`RangeScan::unusable`].
    ///
    /// # Errors
    /// The counts disagree with the arrays, or the geometry is not finite.
    pub fn from_range_finder(
        reading: &RangeFinder,
        non_uniform_half_width_rad: f64,
    ) -> Result<Self, ScanError> {
        const RF: &str = "RangeFinder";
        check_count(RF, "ranges", reading.ranges.len(), reading.range_count)?;
        let max_range_m = check_max_range(RF, reading.max_range)?;
        let poses: Vec<(Vec2, f64, f64)> = if reading.uniform {
            let x0 = check_finite(RF, "x_offset", reading.x_offset)?;
            let y0 = check_finite(RF, "y_offset", reading.y_offset)?;
            let t0 = check_finite(RF, "theta_offset", reading.theta_offset)?;
            let dx = check_finite(RF, "x_separation", reading.x_separation)?;
            let dy = check_finite(RF, "y_separation", reading.y_separation)?;
            let dt = check_finite(RF, "theta_separation", reading.theta_separation)?;
            (0..reading.ranges.len())
                .map(|i| {
                    let i = i as f64;
                    (
                        Vec2::new(x0 + i * dx, y0 + i * dy),
                        t0 + i * dt,
                        dt.abs() / 2.0,
                    )
                })
                .collect()
        } else {
            check_count(
                RF,
                "sensor_positions",
                reading.sensor_positions.len(),
                reading.range_count,
            )?;
            let half_width =
                if non_uniform_half_width_rad.is_finite() && non_uniform_half_width_rad >= 0.0 {
                    non_uniform_half_width_rad
                } else {
                    return Err(ScanError::BadField {
                        interface: RF,
                        field: "non_uniform_half_width_rad",
                        value: non_uniform_half_width_rad,
                        expected: "a finite number >= 0 (a configuration value)",
                    });
                };
            reading
                .sensor_positions
                .iter()
                .map(|p| {
                    let x = check_finite(RF, "sensor_positions.x", p.x)?;
                    let y = check_finite(RF, "sensor_positions.y", p.y)?;
                    let theta = check_finite(RF, "sensor_positions.theta", p.theta)?;
                    Ok((Vec2::new(x, y), theta, half_width))
                })
                .collect::<Result<_, ScanError>>()?
        };
        let mut scan = Self {
            beams: Vec::with_capacity(poses.len()),
            max_range_m,
            unusable: 0,
        };
        for ((origin, bearing_rad, half_width_rad), &range_m) in
            poses.into_iter().zip(&reading.ranges)
        {
            scan.push(origin, bearing_rad, half_width_rad, range_m);
        }
        Ok(scan)
    }

    /// The sectors of a Distance reading as beams from the robot centre, each as wide as
    /// its sector.
    ///
    /// # Errors
    /// The count disagrees with the array, or the geometry is not finite.
    pub fn from_distance(reading: &Distance) -> Result<Self, ScanError> {
        const D: &str = "Distance";
        check_count(
            D,
            "sector_distances",
            reading.sector_distances.len(),
            reading.sector_count,
        )?;
        let max_range_m = check_max_range(D, reading.max_range)?;
        let first = check_finite(D, "first_sector_angle", reading.first_sector_angle)?;
        let width = check_finite(D, "sector_width", reading.sector_width)?;
        let mut scan = Self {
            beams: Vec::with_capacity(reading.sector_distances.len()),
            max_range_m,
            unusable: 0,
        };
        for (i, &range_m) in reading.sector_distances.iter().enumerate() {
            let bearing = first + i as f64 * width;
            scan.push(Vec2::default(), bearing, width.abs() / 2.0, range_m);
        }
        Ok(scan)
    }

    fn push(&mut self, origin: Vec2, bearing_rad: f64, half_width_rad: f64, range_m: f64) {
        if !(range_m.is_finite() && range_m > 0.0) {
            self.unusable += 1;
            return;
        }
        // A reading at (or beyond) the max range means nothing was seen.
        let hit = range_m < self.max_range_m * (1.0 - 1e-9);
        let range_m = range_m.min(self.max_range_m);
        self.beams.push(Beam {
            origin,
            bearing_rad,
            half_width_rad,
            range_m,
            hit,
        });
    }

    /// The usable beams, in the reading's order.
    #[must_use]
    pub fn beams(&self) -> &[Beam] {
        &self.beams
    }

    /// The sensor's max range, in m.
    #[must_use]
    pub fn max_range_m(&self) -> f64 {
        self.max_range_m
    }

    /// How many readings were skipped as NaN, infinite or not positive.
    #[must_use]
    pub fn unusable(&self) -> usize {
        self.unusable
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lewis_interfaces::msg::Pose3D;
    use std::f64::consts::FRAC_PI_2;

    #[test]
    fn a_uniform_laser_places_beams_by_offset_and_separation() {
        let reading = RangeFinder {
            range_count: 3,
            ranges: vec![1.0, 8.0, f64::NAN],
            max_range: 8.0,
            uniform: true,
            x_offset: 0.1,
            theta_offset: -FRAC_PI_2,
            theta_separation: FRAC_PI_2,
            ..Default::default()
        };
        let scan = RangeScan::from_range_finder(&reading, 0.2).unwrap();
        assert_eq!(scan.unusable(), 1);
        let beams = scan.beams();
        assert_eq!(beams.len(), 2);
        assert!(beams[0].hit && !beams[1].hit);
        assert!((beams[1].bearing_rad).abs() < 1e-12);
        let point = beams[0].obstacle_points(10.0, 1).next().unwrap();
        assert!(point.distance(Vec2::new(0.1, -1.0)) < 1e-9, "{point:?}");
    }

    #[test]
    fn a_sonar_reading_without_positions_is_an_error() {
        let reading = RangeFinder {
            range_count: 2,
            ranges: vec![1.0, 2.0],
            max_range: 5.0,
            sensor_positions: vec![Pose3D::default()],
            ..Default::default()
        };
        assert_eq!(
            RangeScan::from_range_finder(&reading, 0.2),
            Err(ScanError::CountMismatch {
                interface: "RangeFinder",
                field: "sensor_positions",
                len: 1,
                count_field: "range_count",
                count: 2
            })
        );
    }

    #[test]
    fn distance_sectors_become_arcs_around_the_centre() {
        let reading = Distance {
            sector_count: 2,
            sector_distances: vec![2.0, 5.0],
            first_sector_angle: 0.0,
            sector_width: 0.5,
            max_range: 5.0,
            ..Default::default()
        };
        let scan = RangeScan::from_distance(&reading).unwrap();
        let points: Vec<Vec2> = scan.beams()[0].obstacle_points(0.1, 100).collect();
        assert_eq!(points.len(), 11);
        assert!(points.iter().all(|p| (p.norm() - 2.0).abs() < 1e-9));
        assert_eq!(scan.beams()[1].obstacle_points(0.1, 100).count(), 0);
        let bad = Distance {
            max_range: f64::NAN,
            ..reading
        };
        assert!(matches!(
            RangeScan::from_distance(&bad),
            Err(ScanError::BadField {
                field: "max_range",
                ..
            })
        ));
    }
}
