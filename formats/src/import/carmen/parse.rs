//! One line of a CARMEN log as a typed record: pure, no I/O.
//!
//! Formats (CARMEN's logger; fields separated by any whitespace):
//!
//! | line | fields |
//! |---|---|
//! | `PARAM` | `name value` then anything (`ts host ts`, `nohost 0`, or nothing) |
//! | `ODOM` | `x y theta tv rv accel` then `ipc_ts host logger_ts` or nothing |
//! | `FLASER`, `RLASER` | `n r1..rn x y theta odom_x odom_y odom_theta` then `ipc_ts host logger_ts` or nothing |
//! | `ROBOTLASER1`..`9` | `laser_type start_angle fov angular_resolution max_range accuracy remission_mode n r1..rn m e1..em laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv forward_safety side_safety turn_axis` then `ipc_ts host logger_ts` or nothing |
//!
//! `NEFF` (a particle filter's effective sample size, in the corrected Radish logs) is
//! ignored; blank lines and lines starting with `#` are comments; any other line type is
//! unknown (the caller counts it). A declared count is checked against the fields the line
//! actually has before anything is allocated for it.

use std::fmt;

use lewis_interfaces::msg::Pose2D;

use super::timing::PrintedTime;

/// What one line of the log is.
#[derive(Debug, Clone, PartialEq)]
pub enum Line {
    /// Empty or only whitespace.
    Blank,
    /// Starts with `#`.
    Comment,
    /// A known line type that carries nothing to import (`NEFF`).
    Ignored(&'static str),
    /// A line type this importer does not know (its first word).
    Unknown(String),
    /// A record to import.
    Record(Record),
}

/// A record of the log.
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    /// `PARAM name value`.
    Param(Param),
    /// `ODOM`.
    Odometry(Odometry),
    /// `FLASER`, `RLASER` or `ROBOTLASERn`.
    Laser(LaserScan),
}

/// A configuration parameter of the robot that made the log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Param {
    /// Its name (`robot_front_laser_max`).
    pub name: String,
    /// Its value, as text.
    pub value: String,
}

/// The timestamps at the end of a line.
#[derive(Debug, Clone, PartialEq)]
pub struct LogStamps {
    /// When the message was sent (IPC time).
    pub ipc: PrintedTime,
    /// The host that sent it.
    pub host: String,
    /// When the logger wrote it: the time the importer uses.
    pub logger: PrintedTime,
}

/// An `ODOM` line: the base's odometry.
#[derive(Debug, Clone, PartialEq)]
pub struct Odometry {
    /// Pose in the odometry frame (m, m, rad).
    pub pose: Pose2D,
    /// Translational velocity, in m/s.
    pub translation_velocity_mps: f64,
    /// Rotational velocity, in rad/s.
    pub rotation_velocity_radps: f64,
    /// Acceleration, in m/s².
    pub acceleration_mps2: f64,
    /// The line's timestamps, when it has them.
    pub stamps: Option<LogStamps>,
}

/// Which laser a scan came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LaserId {
    /// `FLASER`: the front laser, old format.
    Front,
    /// `RLASER`: the rear laser, old format.
    Rear,
    /// `ROBOTLASERn`: laser `n` (1 is the front laser), new format.
    Robot(u8),
}

impl LaserId {
    /// The line type that carries it.
    #[must_use]
    pub fn line_type(self) -> String {
        match self {
            Self::Front => "FLASER".to_owned(),
            Self::Rear => "RLASER".to_owned(),
            Self::Robot(n) => format!("ROBOTLASER{n}"),
        }
    }
}

/// The geometry a `ROBOTLASERn` line states (old-format lines leave it to the importer).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatedGeometry {
    /// Bearing of the first beam relative to the laser, in rad.
    pub start_angle_rad: f64,
    /// Field of view, in rad.
    pub field_of_view_rad: f64,
    /// Angle between beams, in rad.
    pub angular_resolution_rad: f64,
    /// Maximum range, in m.
    pub max_range_m: f64,
}

/// A laser scan line.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserScan {
    /// Which laser.
    pub laser: LaserId,
    /// The readings as logged, in m, beam 0 rightmost (may hold "no return" values, NaN…).
    pub ranges_m: Vec<f64>,
    /// The geometry the line states, for `ROBOTLASERn`.
    pub geometry: Option<StatedGeometry>,
    /// The laser's pose (`x y theta`; world frame when localised).
    pub laser_pose: Pose2D,
    /// The robot's odometry pose when the scan was taken.
    pub odometry_pose: Pose2D,
    /// The line's timestamps, when it has them.
    pub stamps: Option<LogStamps>,
}

/// What is wrong with a line.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LineErrorKind {
    /// The line ends before a field.
    #[error("{record} line ends before `{field}`: the line is truncated")]
    Missing {
        /// The line type.
        record: String,
        /// The first missing field.
        field: &'static str,
    },
    /// A field is not a number.
    #[error("{record} field `{field}` is `{text}`: expected {expected}")]
    BadNumber {
        /// The line type.
        record: String,
        /// The field.
        field: String,
        /// What the line has there (at most 40 characters).
        text: String,
        /// What it must be.
        expected: &'static str,
    },
    /// A count declares more values than the line has.
    #[error(
        "{record} declares {declared} {what} but only {available} fields follow the count: the line is truncated or the count is wrong"
    )]
    CountNotBacked {
        /// The line type.
        record: String,
        /// What is counted.
        what: &'static str,
        /// The count on the line.
        declared: u64,
        /// The fields after it.
        available: usize,
    },
    /// Fields after the last one this line type has.
    #[error(
        "{record} has {extra} fields after `{after}` where 0 or 3 (`ipc_timestamp host logger_timestamp`) belong: is a count wrong?"
    )]
    Trailing {
        /// The line type.
        record: String,
        /// The last field before the timestamps.
        after: &'static str,
        /// How many fields follow it.
        extra: usize,
    },
    /// Longer than the reader accepts.
    #[error("the line is longer than {limit} bytes: not a CARMEN log line")]
    TooLong {
        /// The limit, in bytes.
        limit: usize,
    },
    /// Not UTF-8 text.
    #[error("the line is not text (invalid UTF-8): is this a CARMEN log?")]
    NotText,
}

/// Reads one line of a CARMEN log (without its line break).
///
/// # Errors
/// What is wrong with the line; the caller reports it, counts it and moves on.
pub fn parse_line(text: &str) -> Result<Line, LineErrorKind> {
    let trimmed = text.trim_start();
    if trimmed.is_empty() {
        return Ok(Line::Blank);
    }
    if trimmed.starts_with('#') {
        return Ok(Line::Comment);
    }
    let tokens: Vec<&str> = trimmed.split_ascii_whitespace().collect();
    let kind = tokens[0];
    let mut f = Fields {
        record: kind,
        tokens: &tokens,
        at: 1,
    };
    match kind {
        "PARAM" => {
            let name = f.text("name")?.to_owned();
            let value = f.text("value")?.to_owned();
            Ok(Line::Record(Record::Param(Param { name, value })))
        }
        "ODOM" => {
            let pose = f.pose(["x", "y", "theta"])?;
            let translation_velocity_mps = f.finite("tv")?;
            let rotation_velocity_radps = f.finite("rv")?;
            let acceleration_mps2 = f.finite("accel")?;
            let stamps = f.stamps("accel")?;
            Ok(Line::Record(Record::Odometry(Odometry {
                pose,
                translation_velocity_mps,
                rotation_velocity_radps,
                acceleration_mps2,
                stamps,
            })))
        }
        "FLASER" | "RLASER" => {
            let laser = if kind == "FLASER" {
                LaserId::Front
            } else {
                LaserId::Rear
            };
            let ranges_m = f.ranges("num_readings", "readings", 6)?;
            let laser_pose = f.pose(["x", "y", "theta"])?;
            let odometry_pose = f.pose(["odom_x", "odom_y", "odom_theta"])?;
            let stamps = f.stamps("odom_theta")?;
            Ok(Line::Record(Record::Laser(LaserScan {
                laser,
                ranges_m,
                geometry: None,
                laser_pose,
                odometry_pose,
                stamps,
            })))
        }
        "NEFF" => Ok(Line::Ignored("NEFF")),
        _ => match robot_laser_number(kind) {
            Some(n) => robot_laser(&mut f, n).map(|s| Line::Record(Record::Laser(s))),
            None => Ok(Line::Unknown(kind.to_owned())),
        },
    }
}

fn robot_laser_number(kind: &str) -> Option<u8> {
    let digits = kind.strip_prefix("ROBOTLASER")?;
    match digits.as_bytes() {
        [d @ b'1'..=b'9'] => Some(d - b'0'),
        _ => None,
    }
}

fn robot_laser(f: &mut Fields<'_, '_>, n: u8) -> Result<LaserScan, LineErrorKind> {
    f.finite("laser_type")?;
    let start_angle_rad = f.finite("start_angle")?;
    let field_of_view_rad = f.finite("field_of_view")?;
    let angular_resolution_rad = f.finite("angular_resolution")?;
    let max_range_m = f.finite("maximum_range")?;
    f.finite("accuracy")?;
    f.finite("remission_mode")?;
    // After the readings: the remission count, then 6 pose and 5 motion fields.
    let ranges_m = f.ranges("num_readings", "readings", 12)?;
    let remissions = f.count("num_remissions", "remissions", 11)?;
    f.skip(remissions);
    let laser_pose = f.pose(["laser_pose_x", "laser_pose_y", "laser_pose_theta"])?;
    let odometry_pose = f.pose(["robot_pose_x", "robot_pose_y", "robot_pose_theta"])?;
    for field in [
        "laser_tv",
        "laser_rv",
        "forward_safety_dist",
        "side_safety_dist",
        "turn_axis",
    ] {
        f.finite(field)?;
    }
    let stamps = f.stamps("turn_axis")?;
    Ok(LaserScan {
        laser: LaserId::Robot(n),
        ranges_m,
        geometry: Some(StatedGeometry {
            start_angle_rad,
            field_of_view_rad,
            angular_resolution_rad,
            max_range_m,
        }),
        laser_pose,
        odometry_pose,
        stamps,
    })
}

/// A cursor over a line's fields.
struct Fields<'t, 's> {
    record: &'s str,
    tokens: &'t [&'s str],
    at: usize,
}

impl<'s> Fields<'_, 's> {
    fn remaining(&self) -> usize {
        self.tokens.len() - self.at
    }

    fn text(&mut self, field: &'static str) -> Result<&'s str, LineErrorKind> {
        let token = self
            .tokens
            .get(self.at)
            .copied()
            .ok_or_else(|| LineErrorKind::Missing {
                record: self.record.to_owned(),
                field,
            })?;
        self.at += 1;
        Ok(token)
    }

    fn bad(&self, field: impl fmt::Display, text: &str, expected: &'static str) -> LineErrorKind {
        LineErrorKind::BadNumber {
            record: self.record.to_owned(),
            field: field.to_string(),
            text: text.chars().take(40).collect(),
            expected,
        }
    }

    fn finite(&mut self, field: &'static str) -> Result<f64, LineErrorKind> {
        let text = self.text(field)?;
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.bad(field, text, "a finite number")),
        }
    }

    fn pose(&mut self, fields: [&'static str; 3]) -> Result<Pose2D, LineErrorKind> {
        Ok(Pose2D {
            x: self.finite(fields[0])?,
            y: self.finite(fields[1])?,
            theta: self.finite(fields[2])?,
        })
    }

    /// A count of values that follow it, checked against the fields left on the line
    /// (`after` more fields must follow the values).
    fn count(
        &mut self,
        field: &'static str,
        what: &'static str,
        after: usize,
    ) -> Result<usize, LineErrorKind> {
        let text = self.text(field)?;
        let declared: u64 = text
            .parse()
            .map_err(|_| self.bad(field, text, "a count (a whole number, 0 or more)"))?;
        let available = self.remaining();
        match usize::try_from(declared) {
            Ok(n) if n.checked_add(after).is_some_and(|need| need <= available) => Ok(n),
            _ => Err(LineErrorKind::CountNotBacked {
                record: self.record.to_owned(),
                what,
                declared,
                available,
            }),
        }
    }

    fn ranges(
        &mut self,
        field: &'static str,
        what: &'static str,
        after: usize,
    ) -> Result<Vec<f64>, LineErrorKind> {
        let n = self.count(field, what, after)?;
        let mut ranges = Vec::with_capacity(n);
        for k in 0..n {
            let text = self.tokens[self.at];
            self.at += 1;
            // NaN and infinities are kept: the importer counts them as invalid readings.
            let value = text
                .parse::<f64>()
                .map_err(|_| self.bad(format_args!("r{}", k + 1), text, "a range in m"))?;
            ranges.push(value);
        }
        Ok(ranges)
    }

    fn skip(&mut self, n: usize) {
        self.at = (self.at + n).min(self.tokens.len());
    }

    /// The optional `ipc_ts host logger_ts` at the end of the line; nothing may follow.
    fn stamps(&mut self, last_field: &'static str) -> Result<Option<LogStamps>, LineErrorKind> {
        match self.remaining() {
            0 => Ok(None),
            1 | 2 => Err(LineErrorKind::Missing {
                record: self.record.to_owned(),
                field: if self.remaining() == 1 {
                    "host"
                } else {
                    "logger_timestamp"
                },
            }),
            3 => {
                let ipc = self.time("ipc_timestamp")?;
                let host = self.text("host")?.to_owned();
                let logger = self.time("logger_timestamp")?;
                Ok(Some(LogStamps { ipc, host, logger }))
            }
            extra => Err(LineErrorKind::Trailing {
                record: self.record.to_owned(),
                after: last_field,
                extra,
            }),
        }
    }

    fn time(&mut self, field: &'static str) -> Result<PrintedTime, LineErrorKind> {
        let text = self.text(field)?;
        PrintedTime::parse(text).ok_or_else(|| self.bad(field, text, "a time in seconds"))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    fn check_error(line: &str, expected: &str) {
        match parse_line(line) {
            Err(e) => assert_eq!(e.to_string(), expected),
            Ok(other) => panic!("{line:?} parsed as {other:?}"),
        }
    }

    fn laser(line: &str) -> LaserScan {
        match parse_line(line).unwrap() {
            Line::Record(Record::Laser(scan)) => scan,
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_flaser_line_gives_ranges_poses_and_the_logger_time() {
        let scan = laser("FLASER 3 1.5 2 81.91 0.1 0.2 0.3 0.4 0.5 0.6 10.25 pippo 10.5");
        assert_eq!(scan.laser, LaserId::Front);
        assert_eq!(scan.ranges_m, [1.5, 2.0, 81.91]);
        assert_eq!((scan.laser_pose.x, scan.odometry_pose.theta), (0.1, 0.6));
        let stamps = scan.stamps.unwrap();
        assert_eq!((stamps.ipc.seconds, stamps.logger.seconds), (10.25, 10.5));
        assert_eq!(stamps.host, "pippo");
    }

    #[test]
    fn a_flaser_line_without_timestamps_is_accepted() {
        assert!(laser("RLASER 1 2.0 0 0 0 0 0 0").stamps.is_none());
    }

    #[test]
    fn a_robotlaser_line_states_its_geometry_and_skips_remissions() {
        let scan = laser(
            "ROBOTLASER1 0 -1.5 3.1 0.0174533 81.9 0.01 0 2 1.0 2.0 2 7 8 \
             0.1 0 0 0.2 0 0 0.3 0.1 0.5 0.4 0 5.0 host 5.0",
        );
        assert_eq!(scan.laser, LaserId::Robot(1));
        assert_eq!(scan.ranges_m, [1.0, 2.0]);
        let g = scan.geometry.unwrap();
        assert_eq!((g.start_angle_rad, g.max_range_m), (-1.5, 81.9));
        assert_eq!((scan.laser_pose.x, scan.odometry_pose.x), (0.1, 0.2));
    }

    #[test]
    fn params_odometry_comments_and_unknown_lines() {
        assert_eq!(
            parse_line("PARAM robot_front_laser_max 80.99 nohost 0").unwrap(),
            Line::Record(Record::Param(Param {
                name: "robot_front_laser_max".into(),
                value: "80.99".into()
            }))
        );
        match parse_line("ODOM 1 2 0.5 0.3 0.1 0 0.2 pippo 0.2").unwrap() {
            Line::Record(Record::Odometry(o)) => {
                assert_eq!((o.pose.x, o.translation_velocity_mps), (1.0, 0.3));
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(parse_line("  ").unwrap(), Line::Blank);
        assert_eq!(parse_line("#PARAM x").unwrap(), Line::Comment);
        assert_eq!(parse_line("NEFF 30").unwrap(), Line::Ignored("NEFF"));
        assert_eq!(
            parse_line("TRUEPOS 1 2 3").unwrap(),
            Line::Unknown("TRUEPOS".into())
        );
        assert_eq!(
            parse_line("ROBOTLASER12 0").unwrap(),
            Line::Unknown("ROBOTLASER12".into())
        );
    }

    #[test]
    fn malformed_lines_say_what_is_wrong() {
        check_error(
            "FLASER 360 1 2 3",
            "FLASER declares 360 readings but only 3 fields follow the count: the line is truncated or the count is wrong",
        );
        check_error(
            "FLASER 18446744073709551615 1",
            "FLASER declares 18446744073709551615 readings but only 1 fields follow the count: the line is truncated or the count is wrong",
        );
        check_error(
            "FLASER -3 1 2 3",
            "FLASER field `num_readings` is `-3`: expected a count (a whole number, 0 or more)",
        );
        check_error(
            "FLASER 2 1 x 0 0 0 0 0 0",
            "FLASER field `r2` is `x`: expected a range in m",
        );
        check_error(
            "ODOM 1 2 nan 0 0 0",
            "ODOM field `theta` is `nan`: expected a finite number",
        );
        check_error(
            "ODOM 1 2",
            "ODOM line ends before `theta`: the line is truncated",
        );
        check_error(
            "ODOM 1 2 3 0 0 0 0.1 host",
            "ODOM line ends before `logger_timestamp`: the line is truncated",
        );
        check_error(
            "ODOM 1 2 3 0 0 0 0.1 host 0.1 extra",
            "ODOM has 4 fields after `accel` where 0 or 3 (`ipc_timestamp host logger_timestamp`) belong: is a count wrong?",
        );
        check_error(
            "ODOM 1 2 3 0 0 0 0.1 host later",
            "ODOM field `logger_timestamp` is `later`: expected a time in seconds",
        );
        check_error(
            "PARAM name",
            "PARAM line ends before `value`: the line is truncated",
        );
    }
}
