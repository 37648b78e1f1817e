//! CARMEN laser scans as Lewis RangeFinder readings: beam geometry, "no return" readings,
//! the Distance derived from a scan, and the sonar-like fallback derived from the laser.
//!
//! **No return.** The SICK scanners of the Radish logs report "nothing seen" (and dazzle and
//! other errors) as special values near the top of their range: 81.83 to 81.91 m (cm mode),
//! 32.759 to 32.767 m (mm mode), 50.00 m and 51.0x to 51.1x m (logs converted by other
//! tools). Such readings, readings at or beyond the max range, and invalid ones (NaN,
//! infinite, zero or negative) are all published as **`max_range`**: the convention of the
//! simulator's laser and of ObstacleAvoider and Distance, which treat a reading at
//! `max_range` as "free up to there". (+inf would be dropped by ObstacleAvoider as
//! unusable, losing the free space a no-return reading shows.) Each kind is counted.
//!
//! **Geometry.** Old-format lines (`FLASER`) do not state it: the beams span 180 degrees
//! from the right (-90 degrees) to the left; 180 or 181 beams are 1 degree apart, 360 or
//! 361 beams 0.5 degree (so 180 and 360 beams stop one step short of +90 degrees), any
//! other count spreads over exactly 180 degrees. `ROBOTLASERn` lines state their start
//! angle and resolution.

use std::f64::consts::{FRAC_PI_2, PI};

use lewis_interfaces::msg::{Pose3D, RangeFinder};

/// The SICK LMS's largest reading in cm mode, in m: the max range when the log does not
/// say (no `robot_front_laser_max` parameter).
pub const DEFAULT_MAX_RANGE_M: f64 = 81.91;

/// Bands of "no return" values, in m (inclusive).
pub const NO_RETURN_BANDS_M: &[(f64, f64)] = &[
    (49.995, 50.005),   // 50.00 (aces)
    (51.0, 51.2),       // 51.05 to 51.16 (edmonton, infinite corridor)
    (81.825, 81.915),   // 81.83 to 81.91: SICK cm-mode codes 8183 to 8191
    (32.7585, 32.7595), // 32.759: SICK mm-mode codes (orebro), printed to the mm
    (32.7605, 32.7615), // 32.761
    (32.7625, 32.7635), // 32.763
    (32.7645, 32.7655), // 32.765
    (32.7665, 32.7675), // 32.767 = 0x7fff mm
];

/// What one logged reading is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadingKind {
    /// Something seen at that range.
    Hit,
    /// A "no return" code of the scanner ([`NO_RETURN_BANDS_M`]).
    NoReturn,
    /// At or beyond the max range (and not a known code).
    BeyondMaxRange,
    /// NaN, infinite, zero or negative.
    Invalid,
}

/// Classifies a logged reading (see the module documentation).
#[must_use]
pub fn classify_reading(range_m: f64, max_range_m: f64) -> ReadingKind {
    if !range_m.is_finite() || range_m <= 0.0 {
        ReadingKind::Invalid
    } else if NO_RETURN_BANDS_M
        .iter()
        .any(|&(low, high)| (low..=high).contains(&range_m))
    {
        ReadingKind::NoReturn
    } else if range_m >= max_range_m {
        ReadingKind::BeyondMaxRange
    } else {
        ReadingKind::Hit
    }
}

/// Counts of readings by kind, over a whole import.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReadingCounts {
    /// Readings converted.
    pub readings: u64,
    /// Readings that saw something.
    pub hits: u64,
    /// "No return" codes, published as max range.
    pub no_return: u64,
    /// Readings at or beyond the max range, published as max range.
    pub beyond_max_range: u64,
    /// NaN, infinite, zero or negative readings, published as max range.
    pub invalid: u64,
}

/// Where the laser sits on the robot (CARMEN's `robot_frontlaser_offset`,
/// `robot_frontlaser_side_offset`, `robot_frontlaser_angular_offset`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LaserMount {
    /// Forward of the robot's centre, in m.
    pub x_m: f64,
    /// Left of the robot's centre, in m.
    pub y_m: f64,
    /// Heading relative to the robot, in rad.
    pub heading_rad: f64,
}

/// The bearings of a scan's beams relative to the laser.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamGeometry {
    /// Bearing of beam 0 (the rightmost), in rad.
    pub first_beam_rad: f64,
    /// Angle from one beam to the next (counter-clockwise), in rad.
    pub separation_rad: f64,
}

impl BeamGeometry {
    /// The geometry of an old-format scan of `beam_count` beams (see the module
    /// documentation).
    #[must_use]
    pub fn old_format(beam_count: usize) -> Self {
        let separation_rad = match beam_count {
            180 | 181 => PI / 180.0,
            360 | 361 => PI / 360.0,
            0 | 1 => 0.0,
            // beam counts are small
            n => PI / (n - 1) as f64,
        };
        Self {
            first_beam_rad: -FRAC_PI_2,
            separation_rad,
        }
    }
}

/// A laser's setup for the whole import.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserSetup {
    /// Where it sits.
    pub mount: LaserMount,
    /// Its max range, in m.
    pub max_range_m: f64,
    /// Sectors of its Distance, over its field of view.
    pub distance_sectors: usize,
}

fn count_i32(n: usize) -> i32 {
    i32::try_from(n).unwrap_or(i32::MAX)
}

/// The RangeFinder reading of a logged scan (header left for the caller): uniform, one
/// Pose3D per beam as the interface requires, readings classified into `counts`.
#[must_use]
pub fn range_finder(
    ranges_m: &[f64],
    geometry: BeamGeometry,
    setup: &LaserSetup,
    counts: &mut ReadingCounts,
) -> RangeFinder {
    let max = setup.max_range_m;
    let ranges: Vec<f64> = ranges_m
        .iter()
        .map(|&r| {
            counts.readings += 1;
            match classify_reading(r, max) {
                ReadingKind::Hit => {
                    counts.hits += 1;
                    return r;
                }
                ReadingKind::NoReturn => counts.no_return += 1,
                ReadingKind::BeyondMaxRange => counts.beyond_max_range += 1,
                ReadingKind::Invalid => counts.invalid += 1,
            }
            max
        })
        .collect();
    let theta_offset = setup.mount.heading_rad + geometry.first_beam_rad;
    let sensor_positions = (0..ranges.len())
        .map(|i| {
            let theta = theta_offset + geometry.separation_rad * i as f64;
            Pose3D {
                x: setup.mount.x_m,
                y: setup.mount.y_m,
                theta,
                ..Pose3D::default()
            }
        })
        .collect();
    RangeFinder {
        range_count: count_i32(ranges.len()),
        ranges,
        max_range: max,
        uniform: true,
        sensor_positions,
        x_offset: setup.mount.x_m,
        y_offset: setup.mount.y_m,
        theta_offset,
        theta_separation: geometry.separation_rad,
        ..RangeFinder::default()
    }
}

/// A span of bearings in the robot frame, counter-clockwise from `from_rad` to `to_rad`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SectorSpan {
    /// Where the span starts, in rad.
    pub from_rad: f64,
    /// Where it ends, in rad.
    pub to_rad: f64,
}

/// The bearings (robot frame) covered by a uniform scan: from half a beam before the first
/// beam to half a beam after the last: the span of the derived sonar's transducers and of
/// the imported robot's Distance sectors.
#[must_use]
pub fn field_of_view(scan: &RangeFinder) -> SectorSpan {
    let last = scan.ranges.len().saturating_sub(1);
    let last_beam = scan.theta_offset + scan.theta_separation * last as f64;
    let half = scan.theta_separation.abs() / 2.0;
    SectorSpan {
        from_rad: scan.theta_offset.min(last_beam) - half,
        to_rad: scan.theta_offset.max(last_beam) + half,
    }
}

/// The sonar-like fallback derived from the laser: **not a real sensor.** The logs have no
/// sonar; this gives replay a second, worse RangeFinder provider so that a laser failure can
/// be replayed on a real log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SonarOptions {
    /// Transducers, spread evenly over the laser's field of view.
    pub transducers: usize,
    /// Half the width of each transducer's cone, in rad.
    pub cone_half_angle_rad: f64,
    /// Max range, in m (never more than the laser's).
    pub max_range_m: f64,
    /// One sonar reading for every this many laser scans.
    pub every_nth_scan: u32,
}

impl Default for SonarOptions {
    /// 24 transducers of 15-degree cones (7.5 degrees apart, so neighbours overlap like a
    /// real ring's), 5 m like the B21r's sonar, every 2nd scan.
    fn default() -> Self {
        Self {
            transducers: 24,
            cone_half_angle_rad: 7.5f64.to_radians(),
            max_range_m: 5.0,
            every_nth_scan: 2,
        }
    }
}

/// The derived sonar reading for a laser reading (header left for the caller): each
/// transducer sits at the laser and reads the nearest laser hit within its cone, or its max
/// range when there is none; `uniform = false` with one Pose3D per transducer.
#[must_use]
pub fn derived_sonar(laser: &RangeFinder, options: &SonarOptions) -> RangeFinder {
    let span = field_of_view(laser);
    let max = options.max_range_m.min(laser.max_range);
    let n = options.transducers;
    let step = (span.to_rad - span.from_rad) / n.max(1) as f64;
    let mut ranges = Vec::with_capacity(n);
    let mut sensor_positions = Vec::with_capacity(n);
    for j in 0..n {
        let axis = span.from_rad + step * (j as f64 + 0.5);
        let mut nearest = max;
        for (i, &r) in laser.ranges.iter().enumerate() {
            let bearing = laser.theta_offset + laser.theta_separation * i as f64;
            if (bearing - axis).abs() <= options.cone_half_angle_rad && r < laser.max_range {
                nearest = nearest.min(r);
            }
        }
        ranges.push(nearest);
        sensor_positions.push(Pose3D {
            x: laser.x_offset,
            y: laser.y_offset,
            theta: axis,
            ..Pose3D::default()
        });
    }
    RangeFinder {
        range_count: count_i32(n),
        ranges,
        max_range: max,
        uniform: false,
        sensor_positions,
        ..RangeFinder::default()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    fn check_reading(range_m: f64, max_range_m: f64, expected: ReadingKind) {
        assert_eq!(
            classify_reading(range_m, max_range_m),
            expected,
            "{range_m} with max {max_range_m}"
        );
    }

    #[test]
    fn no_return_codes_are_told_from_real_readings() {
        use ReadingKind::*;
        for (range, kind) in [
            (81.91, NoReturn),
            (81.83, NoReturn),
            (50.0, NoReturn),
            (49.91, Hit),
            (50.01, Hit),
            (51.15, NoReturn),
            (50.86, Hit),
            (32.767, NoReturn),
            (32.759, NoReturn),
            (32.76, Hit), // freiburg-079 prints real readings to the cm
            (32.77, Hit),
            (73.98, Hit),
            (1.65, Hit),
            (0.0, Invalid),
            (-1.0, Invalid),
            (f64::NAN, Invalid),
            (f64::INFINITY, Invalid),
        ] {
            check_reading(range, DEFAULT_MAX_RANGE_M, kind);
        }
        check_reading(12.0, 10.0, BeyondMaxRange);
        check_reading(10.0, 10.0, BeyondMaxRange);
    }

    #[test]
    fn old_format_beams_are_one_or_half_a_degree_apart_from_the_right() {
        for (beams, step_deg) in [(180, 1.0), (181, 1.0), (360, 0.5), (361, 0.5), (91, 2.0)] {
            let g = BeamGeometry::old_format(beams);
            assert!((g.separation_rad.to_degrees() - step_deg).abs() < 1e-12);
            assert!((g.first_beam_rad.to_degrees() + 90.0).abs() < 1e-12);
        }
    }

    fn scan(ranges: &[f64]) -> RangeFinder {
        let setup = LaserSetup {
            mount: LaserMount::default(),
            max_range_m: 80.0,
            distance_sectors: 4,
        };
        let mut counts = ReadingCounts::default();
        range_finder(
            ranges,
            BeamGeometry::old_format(ranges.len()),
            &setup,
            &mut counts,
        )
    }

    #[test]
    fn no_return_readings_become_max_range_and_are_counted() {
        let setup = LaserSetup {
            mount: LaserMount {
                x_m: 0.1,
                y_m: 0.0,
                heading_rad: 0.0,
            },
            max_range_m: 80.0,
            distance_sectors: 4,
        };
        let mut counts = ReadingCounts::default();
        let ranges = [1.0, 81.91, 85.0, f64::NAN];
        let rf = range_finder(&ranges, BeamGeometry::old_format(4), &setup, &mut counts);
        assert_eq!(rf.ranges, [1.0, 80.0, 80.0, 80.0]);
        assert_eq!(rf.range_count, 4);
        assert_eq!(rf.sensor_positions.len(), 4);
        assert_eq!(rf.sensor_positions[0].x, 0.1);
        assert_eq!(
            counts,
            ReadingCounts {
                readings: 4,
                hits: 1,
                no_return: 1,
                beyond_max_range: 1,
                invalid: 1
            }
        );
    }

    #[test]
    fn the_sonar_reads_the_nearest_laser_hit_in_its_cone() {
        // 181 beams; an obstacle at 2 m straight ahead (beams 89..=91), 0.5 m far left.
        let mut ranges = vec![81.91; 181];
        ranges[89..=91].fill(2.0);
        ranges[180] = 0.5;
        let laser = scan(&ranges);
        let options = SonarOptions {
            transducers: 4,
            cone_half_angle_rad: 10f64.to_radians(),
            max_range_m: 5.0,
            every_nth_scan: 2,
        };
        let sonar = derived_sonar(&laser, &options);
        assert!(!sonar.uniform);
        assert_eq!(sonar.sensor_positions.len(), 4);
        // Axes at -67.9, -22.6, 22.6 and 67.9 degrees: the obstacle ahead is in no cone.
        assert_eq!(sonar.ranges, [5.0, 5.0, 5.0, 5.0]);
        let wide = derived_sonar(
            &laser,
            &SonarOptions {
                cone_half_angle_rad: 25f64.to_radians(),
                ..options
            },
        );
        assert_eq!(wide.ranges, [5.0, 2.0, 2.0, 0.5]);
    }

    #[test]
    fn the_field_of_view_spans_half_a_beam_beyond_the_outer_beams() {
        let laser = scan(&vec![81.91; 180]);
        let span = field_of_view(&laser);
        assert!((span.from_rad.to_degrees() + 90.5).abs() < 1e-9, "{span:?}");
        assert!((span.to_rad.to_degrees() - 89.5).abs() < 1e-9, "{span:?}");
    }
}
