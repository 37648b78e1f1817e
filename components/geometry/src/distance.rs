//! Distance from range readings: the nearest obstacle in each angular sector of the robot
//! frame. Pure, and the same for the laser, the sonar and the real drivers, so that an
//! application using Distance sees the same thing whichever sensor is behind it.

use std::f64::consts::{PI, TAU};

use lewis_interfaces::msg::{Distance, Pose3D, RangeFinder};

use crate::wrap_angle;

/// One range reading placed in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeReading {
    /// Bearing of the point seen, from the robot's centre, in rad.
    pub bearing_rad: f64,
    /// Distance of the point seen from the robot's centre, in m.
    pub distance_m: f64,
}

/// How the circle around the robot is cut into sectors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SectorLayout {
    /// Centre bearing of sector 0, in rad.
    pub first_sector_angle_rad: f64,
    /// Width of each sector, in rad.
    pub sector_width_rad: f64,
    /// Number of sectors.
    pub sector_count: usize,
}

impl SectorLayout {
    /// `sector_count` sectors covering the whole circle, sector 0 starting right behind the
    /// robot (bearing -pi) and the others counter-clockwise.
    #[must_use]
    pub fn full_circle(sector_count: usize) -> Self {
        Self::spanning(-PI, PI, sector_count)
    }

    /// `sector_count` sectors covering bearings `from_rad` to `to_rad` (counter-clockwise).
    #[must_use]
    pub fn spanning(from_rad: f64, to_rad: f64, sector_count: usize) -> Self {
        // sector counts are small
        let width = (to_rad - from_rad) / sector_count.max(1) as f64;
        Self {
            first_sector_angle_rad: from_rad + width / 2.0,
            sector_width_rad: width,
            sector_count,
        }
    }

    /// The sector holding `bearing_rad`, if any.
    #[must_use]
    pub fn sector_of(&self, bearing_rad: f64) -> Option<usize> {
        if self.sector_count == 0 || self.sector_width_rad <= 0.0 {
            return None;
        }
        let start = self.first_sector_angle_rad - self.sector_width_rad / 2.0;
        let offset = wrap_angle(bearing_rad - start).rem_euclid(TAU);
        let k = (offset / self.sector_width_rad).floor();
        let in_span = k >= 0.0 && k < self.sector_count as f64;
        // checked above
        in_span.then_some(k as usize)
    }
}

/// The Distance publication from readings in the robot frame: per sector the nearest reading
/// (`max_range_m` where nothing was seen), and the nearest reading overall. Readings at or
/// beyond `max_range_m`, non-finite ones and those outside the layout are not obstacles.
#[must_use]
pub fn distance_from_readings(
    readings: impl IntoIterator<Item = RangeReading>,
    max_range_m: f64,
    layout: SectorLayout,
) -> Distance {
    let mut sectors = vec![max_range_m; layout.sector_count];
    let mut min_distance = max_range_m;
    let mut min_bearing = 0.0;
    for r in readings {
        if !(r.distance_m.is_finite() && r.bearing_rad.is_finite()) || r.distance_m >= max_range_m {
            continue;
        }
        let Some(k) = layout.sector_of(r.bearing_rad) else {
            continue;
        };
        sectors[k] = sectors[k].min(r.distance_m);
        if r.distance_m < min_distance {
            min_distance = r.distance_m;
            min_bearing = wrap_angle(r.bearing_rad);
        }
    }
    Distance {
        sector_count: i32::try_from(layout.sector_count).unwrap_or(i32::MAX),
        sector_distances: sectors,
        first_sector_angle: layout.first_sector_angle_rad,
        sector_width: layout.sector_width_rad,
        max_range: max_range_m,
        min_distance,
        min_bearing,
        ..Distance::default()
    }
}

/// The readings of a RangeFinder publication in the robot frame: each range turned into the
/// point it saw (from its sensor's pose: the per-element poses when `uniform` is false, the
/// offsets and separations when it is true), then into bearing and distance from the robot's
/// centre. Readings at or beyond the max range are left out: they saw nothing.
#[must_use]
pub fn range_readings(scan: &RangeFinder) -> Vec<RangeReading> {
    let mut out = Vec::with_capacity(scan.ranges.len());
    for (i, &range) in scan.ranges.iter().enumerate() {
        if !(range.is_finite() && range >= 0.0 && range < scan.max_range) {
            continue;
        }
        let pose = if scan.uniform {
            let k = i as f64;
            Pose3D {
                x: scan.x_offset + k * scan.x_separation,
                y: scan.y_offset + k * scan.y_separation,
                z: scan.z_offset + k * scan.z_separation,
                theta: scan.theta_offset + k * scan.theta_separation,
                phi: scan.phi_offset + k * scan.phi_separation,
                psi: scan.psi_offset + k * scan.psi_separation,
            }
        } else {
            match scan.sensor_positions.get(i) {
                Some(p) => p.clone(),
                None => continue,
            }
        };
        let x = pose.x + range * pose.theta.cos();
        let y = pose.y + range * pose.theta.sin();
        out.push(RangeReading {
            bearing_rad: y.atan2(x),
            distance_m: x.hypot(y),
        });
    }
    out
}

/// The Distance publication for a RangeFinder publication (see [`range_readings`]).
#[must_use]
pub fn distance_from_range_finder(scan: &RangeFinder, layout: SectorLayout) -> Distance {
    distance_from_readings(range_readings(scan), scan.max_range, layout)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(readings: &[(f64, f64)], layout: SectorLayout, sectors: &[f64], min: (f64, f64)) {
        let d = distance_from_readings(
            readings
                .iter()
                .map(|&(bearing_rad, distance_m)| RangeReading {
                    bearing_rad,
                    distance_m,
                }),
            5.0,
            layout,
        );
        assert_eq!(d.sector_distances, sectors);
        assert_eq!((d.min_distance, d.min_bearing), min);
        assert_eq!(usize::try_from(d.sector_count).ok(), Some(sectors.len()));
    }

    #[test]
    fn each_sector_keeps_its_nearest_reading() {
        // Four sectors centred on the right, ahead, the left and behind.
        let layout = SectorLayout::spanning(-PI * 0.75, PI * 1.25, 4);
        check(
            &[
                (0.1, 2.0),
                (-0.1, 1.5),
                (PI / 2.0, 3.0),
                (-PI / 2.0, 4.0),
                (PI, 1.0),
            ],
            layout,
            &[4.0, 1.5, 3.0, 1.0],
            (1.0, wrap_angle(PI)),
        );
    }

    #[test]
    fn readings_at_max_range_and_outside_the_span_are_not_obstacles() {
        let layout = SectorLayout::spanning(-PI / 2.0, PI / 2.0, 2);
        check(
            &[(0.3, 5.0), (PI, 1.0), (0.3, f64::NAN)],
            layout,
            &[5.0, 5.0],
            (5.0, 0.0),
        );
    }

    #[test]
    fn full_circle_sectors_start_behind_the_robot() {
        let layout = SectorLayout::full_circle(8);
        assert_eq!(layout.sector_of(-PI), Some(0));
        assert_eq!(layout.sector_of(PI - 1e-9), Some(7));
        assert_eq!(layout.sector_of(0.01), Some(4));
    }

    #[test]
    fn a_uniform_scan_is_placed_with_its_offsets() {
        // Three beams at -90, 0, +90 degrees from a laser 0.1 m ahead of the centre.
        let scan = RangeFinder {
            range_count: 3,
            ranges: vec![1.0, 2.0, 8.0],
            max_range: 8.0,
            uniform: true,
            x_offset: 0.1,
            theta_offset: -PI / 2.0,
            theta_separation: PI / 2.0,
            sensor_positions: vec![Pose3D::default(); 3],
            ..RangeFinder::default()
        };
        let r = range_readings(&scan);
        assert_eq!(r.len(), 2);
        assert!((r[1].distance_m - 2.1).abs() < 1e-12 && r[1].bearing_rad.abs() < 1e-12);
        assert!((r[0].distance_m - 1.01f64.sqrt()).abs() < 1e-12);
    }
}
