//! A run's laser scans and the poses they were taken at, read from a Lewis recording, a
//! CARMEN log or a ROS 2 bag. Foreign files go through the importers of `lewis-formats`
//! in memory (nothing is written): one parser per format in the project.

use std::io::Read as _;
use std::path::{Path, PathBuf};

use lewis_formats::import::carmen::parse::{LaserId, Record};
use lewis_formats::import::carmen::{self, CarmenImport, ImportedMessage, LogReader, Payload};
use lewis_formats::import::ros2::{self, Out, Ros2Import};
use lewis_geometry::{Pose2, Vec2, wrap_angle};
use lewis_interfaces::msg::{Egomotion, GroundTruth, RangeFinder};
use lewis_interfaces::{Interface as _, Struct as _};
use lewis_recording::RecordingFiles;

/// The fewest scans a world is built from.
pub const MIN_SCANS: usize = 10;

/// A range at or below this is no reading (the scanner's own housing, or a code).
const MIN_RANGE_M: f32 = 0.05;

/// How far from the nearest pose a scan may be and still take it, in ns.
const POSE_GAP_NS: i64 = 1_000_000_000;

/// One laser scan: uniform beams from a sensor mounted on the robot.
#[derive(Debug, Clone, PartialEq)]
pub struct Scan {
    /// When it was taken, in ns on the recording's clock.
    pub time_ns: i64,
    /// The ranges, beam 0 first, in m (single precision: a laser's millimetres fit, and
    /// a ten-minute run stays tens of MB).
    pub ranges_m: Vec<f32>,
    /// The bearing of beam 0 in the robot frame, in rad.
    pub first_bearing_rad: f64,
    /// The angle between neighbouring beams, in rad.
    pub step_rad: f64,
    /// Where the sensor sits in the robot frame, in m.
    pub mount_m: Vec2,
    /// The range reported for no return, in m.
    pub max_range_m: f64,
    /// The robot's recorded pose at the scan's time (odometry or localisation, as
    /// [`Run::poses`] says), when the run has poses around it.
    pub recorded_pose: Option<Pose2>,
}

impl Scan {
    /// Whether beam `range_m` hit something (not a no-return code, not too close).
    #[must_use]
    pub fn is_return(&self, range_m: f32) -> bool {
        range_m.is_finite() && range_m > MIN_RANGE_M && f64::from(range_m) < self.max_range_m - 1e-3
    }

    /// Beam `index`'s bearing in the robot frame, in rad.
    #[must_use]
    pub fn bearing_rad(&self, index: usize) -> f64 {
        self.first_bearing_rad + self.step_rad * index as f64
    }

    /// The end points of its returns in the robot frame.
    #[must_use]
    pub fn points_in_robot(&self) -> Vec<Vec2> {
        self.ranges_m
            .iter()
            .enumerate()
            .filter(|(_, r)| self.is_return(**r))
            .map(|(i, r)| self.mount_m + Vec2::from_angle(self.bearing_rad(i)) * f64::from(*r))
            .collect()
    }
}

/// Where a run's poses come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PoseSource {
    /// Poses already in a fixed frame (the simulator's ground truth).
    Localised(String),
    /// Odometry (a CARMEN corrected log's odometry is its corrected trajectory).
    Odometry(String),
    /// None: the scans alone.
    None,
}

impl std::fmt::Display for PoseSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Localised(what) => write!(f, "localised poses ({what})"),
            Self::Odometry(what) => write!(f, "odometry ({what})"),
            Self::None => f.write_str("no poses (scan matching alone)"),
        }
    }
}

/// What kind of file a run was read from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunFormat {
    /// A Lewis recording.
    Lewis,
    /// A CARMEN log, imported in memory.
    Carmen,
    /// A ROS 2 bag, imported in memory.
    Ros2,
}

impl std::fmt::Display for RunFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Lewis => "Lewis recording",
            Self::Carmen => "CARMEN log",
            Self::Ros2 => "ROS 2 bag",
        })
    }
}

/// A run's scans in time order, with their recorded poses.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The file.
    pub path: PathBuf,
    /// What it was.
    pub format: RunFormat,
    /// The laser's topic (or the imported channel).
    pub laser: String,
    /// Where the recorded poses come from.
    pub poses: PoseSource,
    /// The scans.
    pub scans: Vec<Scan>,
    /// Scans left out because their beams are not evenly spread (`uniform` false).
    pub non_uniform: u64,
}

impl Run {
    /// From the first scan to the last, in s.
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        match (self.scans.first(), self.scans.last()) {
            (Some(a), Some(b)) => (b.time_ns - a.time_ns) as f64 / 1e9,
            _ => 0.0,
        }
    }
}

/// Why a run cannot be read for a world.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The file cannot be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The Lewis recording cannot be read.
    #[error(transparent)]
    Recording(#[from] lewis_recording::RecordingError),
    /// The CARMEN import failed.
    #[error(transparent)]
    Carmen(#[from] carmen::ImportError),
    /// The ROS 2 import failed.
    #[error(transparent)]
    Ros2(#[from] ros2::ImportError),
    /// A message does not decode.
    #[error("{}: message {seq} on {topic} does not decode as {what}: {reason}", path.display())]
    Decode {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Its sequence number.
        seq: u64,
        /// The type expected.
        what: &'static str,
        /// The decoder's words.
        reason: String,
    },
    /// The run has no laser.
    #[error(
        "{}: no laser scans (a RangeFinder of evenly spread beams, or a sensor_msgs/LaserScan): a world is built from a laser's scans",
        path.display()
    )]
    NoLaser {
        /// The file.
        path: PathBuf,
    },
    /// Too few scans.
    #[error(
        "{}: {scans} laser scans, too few to map (at least {MIN_SCANS}): record a longer run",
        path.display()
    )]
    TooShort {
        /// The file.
        path: PathBuf,
        /// Its scans.
        scans: usize,
    },
}

/// Reads the scans and poses of the run in `path`: a Lewis recording, a CARMEN log (plain
/// or gzip) or a ROS 2 bag, told apart by their contents.
///
/// # Errors
/// When the file cannot be read or imported, has no laser, or too few scans.
pub fn read_run(path: &Path) -> Result<Run, RunError> {
    let io = |source| RunError::Io {
        path: path.to_owned(),
        source,
    };
    let mut magic = [0_u8; 8];
    let mut file = std::fs::File::open(path).map_err(io)?;
    let got = file.read(&mut magic).map_err(io)?;
    let run = if magic[..got].starts_with(b"\x89MCAP") {
        let files = RecordingFiles::open(&[path.to_owned()])?;
        if files
            .topics()
            .values()
            .any(|t| t.schema_name == RangeFinder::SCHEMA_NAME)
        {
            read_lewis(path, &files)?
        } else {
            read_ros2(path)?
        }
    } else {
        read_carmen(path)?
    };
    if run.scans.is_empty() {
        return Err(RunError::NoLaser {
            path: path.to_owned(),
        });
    }
    if run.scans.len() < MIN_SCANS {
        return Err(RunError::TooShort {
            path: path.to_owned(),
            scans: run.scans.len(),
        });
    }
    Ok(run)
}

/// The parts of a run as they come, before poses are put on the scans.
#[derive(Default)]
struct Gathered {
    scans: Vec<Scan>,
    poses: Vec<(i64, Pose2)>,
    non_uniform: u64,
}

impl Gathered {
    fn scan(&mut self, time_ns: i64, scan: &RangeFinder) {
        if !scan.uniform || scan.ranges.len() < 2 || !scan.theta_separation.is_finite() {
            self.non_uniform += 1;
            return;
        }
        self.scans.push(Scan {
            time_ns,
            // single precision is the point: see `Scan::ranges_m`
            ranges_m: scan.ranges.iter().map(|r| *r as f32).collect(),
            first_bearing_rad: scan.theta_offset,
            step_rad: scan.theta_separation,
            mount_m: Vec2::new(scan.x_offset, scan.y_offset),
            max_range_m: scan.max_range,
            recorded_pose: None,
        });
    }

    fn pose(&mut self, time_ns: i64, pose: Pose2) {
        if pose.x_m.is_finite() && pose.y_m.is_finite() && pose.heading_rad.is_finite() {
            self.poses.push((time_ns, pose));
        }
    }

    fn into_run(
        mut self,
        path: &Path,
        format: RunFormat,
        laser: String,
        source: PoseSource,
    ) -> Run {
        self.scans.sort_by_key(|s| s.time_ns);
        self.poses.sort_by_key(|p| p.0);
        let has_poses = !self.poses.is_empty();
        for scan in &mut self.scans {
            scan.recorded_pose = pose_at(&self.poses, scan.time_ns);
        }
        Run {
            path: path.to_owned(),
            format,
            laser,
            poses: if has_poses { source } else { PoseSource::None },
            scans: self.scans,
            non_uniform: self.non_uniform,
        }
    }
}

/// The pose at `time_ns`, interpolated between the poses around it (or the nearest, within
/// [`POSE_GAP_NS`]).
fn pose_at(poses: &[(i64, Pose2)], time_ns: i64) -> Option<Pose2> {
    let after = poses.partition_point(|p| p.0 < time_ns);
    let next = poses.get(after);
    let previous = after.checked_sub(1).and_then(|i| poses.get(i));
    match (previous, next) {
        (Some(&(t0, a)), Some(&(t1, b))) if t1 - t0 <= 2 * POSE_GAP_NS => {
            let f = if t1 > t0 {
                (time_ns - t0) as f64 / (t1 - t0) as f64
            } else {
                0.0
            };
            Some(Pose2::new(
                a.x_m + (b.x_m - a.x_m) * f,
                a.y_m + (b.y_m - a.y_m) * f,
                wrap_angle(a.heading_rad + wrap_angle(b.heading_rad - a.heading_rad) * f),
            ))
        }
        (Some(&(t, p)), _) | (None, Some(&(t, p))) if (time_ns - t).abs() <= POSE_GAP_NS => Some(p),
        _ => None,
    }
}

fn read_lewis(path: &Path, files: &RecordingFiles) -> Result<Run, RunError> {
    let topics = files.topics();
    // The laser: `/laser/RangeFinder` when there is one, else the RangeFinder topic with
    // the most messages (a sonar ring is not uniform and is left out scan by scan anyway).
    let lasers: Vec<_> = topics
        .values()
        .filter(|t| t.schema_name == RangeFinder::SCHEMA_NAME)
        .collect();
    let Some(laser) = lasers
        .iter()
        .find(|t| &*t.name == "/laser/RangeFinder")
        .or_else(|| lasers.iter().max_by_key(|t| t.message_count))
    else {
        return Err(RunError::NoLaser {
            path: path.to_owned(),
        });
    };
    let truth = topics
        .values()
        .find(|t| t.schema_name == GroundTruth::SCHEMA_NAME);
    let odometry = topics
        .values()
        .filter(|t| t.schema_name == Egomotion::SCHEMA_NAME)
        .max_by_key(|t| t.message_count);
    let (pose_topic, source) = match (truth, odometry) {
        (Some(t), _) => (
            Some(t.name.clone()),
            PoseSource::Localised(format!("the simulator's ground truth on {}", t.name)),
        ),
        (None, Some(t)) => (
            Some(t.name.clone()),
            PoseSource::Odometry(format!("Egomotion on {}", t.name)),
        ),
        (None, None) => (None, PoseSource::None),
    };
    let mut wanted: Vec<&str> = vec![&laser.name];
    if let Some(t) = &pose_topic {
        wanted.push(t);
    }
    let mut gathered = Gathered::default();
    let decode_error =
        |topic: &str, seq: u64, what: &'static str, reason: String| RunError::Decode {
            path: path.to_owned(),
            topic: topic.to_owned(),
            seq,
            what,
            reason,
        };
    for message in files.messages_on(&wanted)? {
        let message = message?;
        if message.topic == laser.name {
            let scan: RangeFinder =
                lewis_interfaces::cdr::from_bytes(&message.data).map_err(|e| {
                    decode_error(&message.topic, message.seq, "RangeFinder", e.to_string())
                })?;
            gathered.scan(message.log_time_ns, &scan);
        } else if matches!(source, PoseSource::Localised(_)) {
            let truth: GroundTruth =
                lewis_interfaces::cdr::from_bytes(&message.data).map_err(|e| {
                    decode_error(&message.topic, message.seq, "GroundTruth", e.to_string())
                })?;
            gathered.pose(message.log_time_ns, Pose2::from_msg(&truth.pose));
        } else {
            let ego: Egomotion = lewis_interfaces::cdr::from_bytes(&message.data).map_err(|e| {
                decode_error(&message.topic, message.seq, "Egomotion", e.to_string())
            })?;
            gathered.pose(message.log_time_ns, Pose2::from_msg(&ego.pose));
        }
    }
    Ok(gathered.into_run(path, RunFormat::Lewis, laser.name.to_string(), source))
}

/// Takes one imported message: the laser's scans and the base's odometry.
fn take(gathered: &mut Gathered, message: &ImportedMessage, laser_channel: &str) {
    match &message.payload {
        Payload::RangeFinder(scan) if message.channel == laser_channel => {
            gathered.scan(message.time_ns, scan);
        }
        Payload::Egomotion(ego) => gathered.pose(message.time_ns, Pose2::from_msg(&ego.pose)),
        _ => {}
    }
}

fn laser_channel() -> String {
    format!("/{}/{}", carmen::LASER, RangeFinder::NAME)
}

fn read_carmen(path: &Path) -> Result<Run, RunError> {
    let options = carmen::ImportOptions {
        sonar: None,
        ..carmen::ImportOptions::default()
    };
    let import = CarmenImport::open(path, options)?;
    let channel = laser_channel();
    let mut gathered = Gathered::default();
    for message in import.messages()? {
        take(&mut gathered, &message?, &channel);
    }
    let report = import.report();
    let laser_source = report.laser.source;
    let laser = laser_source.line_type().to_owned();
    // The pose in each scan line: in a corrected log, the corrected trajectory (its ODOM
    // lines are only near it: centimetres and degrees off). The import makes Egomotion
    // from the ODOM lines, so the scan lines are read again here, by the same reader, and
    // their poses put on the imported scans in order.
    if let Some(poses) = scan_line_poses(path, laser_source)?
        && poses.len() == gathered.scans.len()
    {
        let mut run = gathered.into_run(path, RunFormat::Carmen, laser, PoseSource::None);
        for (scan, laser_pose) in run.scans.iter_mut().zip(poses) {
            // The line gives the laser's pose: the robot is the mount's offset behind it.
            let back = (-scan.mount_m).rotated(laser_pose.heading_rad);
            scan.recorded_pose = Some(Pose2::new(
                laser_pose.x_m + back.x,
                laser_pose.y_m + back.y,
                laser_pose.heading_rad,
            ));
        }
        run.poses = PoseSource::Odometry(format!(
            "the pose of each {} line; a corrected log's corrected trajectory",
            laser_source.line_type()
        ));
        return Ok(run);
    }
    let source = PoseSource::Odometry(match report.odometry {
        carmen::OdometrySource::OdomLines => "the log's ODOM lines".to_owned(),
        carmen::OdometrySource::ScanPoses => "the odometry pose of each scan line".to_owned(),
    });
    Ok(gathered.into_run(path, RunFormat::Carmen, laser, source))
}

/// The pose of every scan line of the imported laser, in order; `None` when a line has
/// none that is finite.
fn scan_line_poses(
    path: &Path,
    source: carmen::LaserSource,
) -> Result<Option<Vec<Pose2>>, RunError> {
    let id = match source {
        carmen::LaserSource::Flaser => LaserId::Front,
        carmen::LaserSource::RobotLaser1 => LaserId::Robot(1),
    };
    let mut reader = LogReader::open(path).map_err(carmen::ImportError::from)?;
    let mut poses = Vec::new();
    while let Some(record) = reader.next_record().map_err(carmen::ImportError::from)? {
        if let Record::Laser(scan) = record.value
            && scan.laser == id
        {
            let pose = Pose2::from_msg(&scan.laser_pose);
            if !(pose.x_m.is_finite() && pose.y_m.is_finite() && pose.heading_rad.is_finite()) {
                return Ok(None);
            }
            poses.push(pose);
        }
    }
    Ok(Some(poses))
}

fn read_ros2(path: &Path) -> Result<Run, RunError> {
    let options = ros2::ImportOptions {
        sonar: None,
        ..ros2::ImportOptions::default()
    };
    let import = match Ros2Import::open(path, &options) {
        Ok(import) => import,
        // A bag with neither laser nor odometry: the import's refusal names it, but a world
        // needs only the laser, so say that.
        Err(ros2::ImportError::NothingToImport { .. }) => {
            return Err(RunError::NoLaser {
                path: path.to_owned(),
            });
        }
        Err(e) => return Err(e.into()),
    };
    let report = import.report();
    let Some(laser) = report.choice.laser.clone() else {
        return Err(RunError::NoLaser {
            path: path.to_owned(),
        });
    };
    let source = match &report.choice.odometry {
        Some((topic, _)) => PoseSource::Odometry(topic.clone()),
        None => PoseSource::None,
    };
    let channel = laser_channel();
    let mut gathered = Gathered::default();
    import.stream(|out| -> Result<(), RunError> {
        if let Out::Lewis(message) = out {
            take(&mut gathered, &message, &channel);
        }
        Ok(())
    })?;
    Ok(gathered.into_run(path, RunFormat::Ros2, laser, source))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_between_two_is_interpolated_across_the_angle_wrap() {
        let poses = [
            (0, Pose2::new(0.0, 0.0, 3.1)),
            (100, Pose2::new(1.0, 2.0, -3.1)),
        ];
        let p = pose_at(&poses, 50).unwrap_or_default();
        assert!((p.x_m - 0.5).abs() < 1e-9 && (p.y_m - 1.0).abs() < 1e-9);
        assert!(p.heading_rad.abs() > 3.1, "{p:?}");
        assert_eq!(pose_at(&poses, 10 * POSE_GAP_NS), None);
    }
}
