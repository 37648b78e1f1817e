//! The import in two passes over the log: the first reads every record, keeps only what the
//! time policy and the summary need (one timestamp per scan and odometry line, the laser
//! parameters), and re-times; the second streams the messages out, one record at a time.
//! Memory does not grow with the scans' contents, only with their count.

use std::collections::{BTreeMap, VecDeque};
use std::path::{Path, PathBuf};

use lewis_interfaces::msg::{
    Blobs, Distance, Egomotion, Header, Health, HealthState, ImageSource, InputRef, Pose2D,
    RangeFinder,
};
use lewis_interfaces::{Interface, Struct};
use lewis_perception::range_distance::{self, RangeToDistance};
use lewis_runtime::names::{data_channel, health_channel};

use super::laser::{
    BeamGeometry, DEFAULT_MAX_RANGE_M, LaserMount, LaserSetup, ReadingCounts, SonarOptions,
    derived_sonar, range_finder,
};
use super::parse::{LaserId, LaserScan, Record};
use super::reader::{LineError, LogReader, ParseCounts, ReadError};
use super::timing::{StampInput, Stream, TimingError, TimingOptions, TimingReport, retime};

/// The provider name of the imported laser.
pub const LASER: &str = "laser";
/// The provider name of the imported odometry.
pub const BASE: &str = "base";
/// The provider name of the sonar-like fallback derived from the laser.
pub const SONAR: &str = "sonar";
/// The name of the imported robot's Distance service (`range_distance`), whose outputs the
/// import computes as that service would have published them live.
pub const DISTANCE: &str = "distance";

/// How to import a CARMEN log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImportOptions {
    /// The time policy.
    pub timing: TimingOptions,
    /// The laser's max range when the log has no `robot_front_laser_max` parameter, in m.
    pub default_max_range_m: f64,
    /// Sectors of the Distance readings, over the laser's field of view.
    pub distance_sectors: usize,
    /// The derived sonar-like fallback, or `None` for none.
    pub sonar: Option<SonarOptions>,
    /// Import only the log up to its Nth scan of the imported laser (`None`: all of it).
    pub max_scans: Option<u64>,
    /// The period of the sources' heartbeats (and of the robot's broker), in ns.
    pub heartbeat_period_ns: i64,
    /// The goal of the imported robot's obstacle avoider, in the odometry frame, in m
    /// (`None`: the odometry pose farthest from the first one).
    pub goal: Option<(f64, f64)>,
}

impl Default for ImportOptions {
    /// Re-time broken stamps, 81.91 m without a parameter, 8 Distance sectors, the derived
    /// sonar with its defaults, the whole log, heartbeats every 100 ms, the farthest pose as
    /// the goal.
    fn default() -> Self {
        Self {
            timing: TimingOptions::default(),
            default_max_range_m: DEFAULT_MAX_RANGE_M,
            distance_sectors: 8,
            sonar: Some(SonarOptions::default()),
            max_scans: None,
            heartbeat_period_ns: 100_000_000,
            goal: None,
        }
    }
}

/// Why a log cannot be imported.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// It cannot be read.
    #[error(transparent)]
    Read(#[from] ReadError),
    /// It has no laser scans.
    #[error(
        "{}: no laser scans (FLASER or ROBOTLASER1 lines) among its {lines} lines: nothing to import as a RangeFinder",
        path.display()
    )]
    NoScans {
        /// The log.
        path: PathBuf,
        /// Its line count.
        lines: u64,
    },
    /// The time policy refused it.
    #[error("{}: {source}", path.display())]
    Timing {
        /// The log.
        path: PathBuf,
        /// Why.
        source: TimingError,
    },
    /// An option is out of range.
    #[error("{0}")]
    Option(String),
    /// The file changed between the two passes.
    #[error(
        "{} changed while it was being imported (its records differ between the two passes): import it again",
        path.display()
    )]
    Changed {
        /// The log.
        path: PathBuf,
    },
}

/// Which line type is imported as the laser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LaserSource {
    /// `FLASER` (preferred when the log has both).
    Flaser,
    /// `ROBOTLASER1`, when the log has no `FLASER`.
    RobotLaser1,
}

impl LaserSource {
    fn id(self) -> LaserId {
        match self {
            Self::Flaser => LaserId::Front,
            Self::RobotLaser1 => LaserId::Robot(1),
        }
    }

    /// The line type.
    #[must_use]
    pub fn line_type(self) -> &'static str {
        match self {
            Self::Flaser => "FLASER",
            Self::RobotLaser1 => "ROBOTLASER1",
        }
    }
}

/// Where the Egomotion readings come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OdometrySource {
    /// The `ODOM` lines.
    OdomLines,
    /// The odometry pose in each scan line, because the log has no `ODOM` lines (velocities
    /// are then zero).
    ScanPoses,
}

/// What the imported laser is.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserSummary {
    /// The line type imported.
    pub source: LaserSource,
    /// Scans per beam count.
    pub beam_counts: BTreeMap<usize, u64>,
    /// The beam geometry of its first scan (stated by `ROBOTLASER1`, assumed for `FLASER`).
    pub geometry: BeamGeometry,
    /// The max range used, in m.
    pub max_range_m: f64,
    /// The line of the `robot_front_laser_max` parameter it came from; `None`: the default.
    pub max_range_line: Option<u64>,
    /// Where it sits on the robot (from the `robot_frontlaser_*` parameters).
    pub mount: LaserMount,
    /// Scans per second over the import, when there are at least two.
    pub rate_hz: Option<f64>,
}

impl LaserSummary {
    /// The most common beam count.
    #[must_use]
    pub fn beams(&self) -> usize {
        self.beam_counts
            .iter()
            .max_by_key(|(beams, count)| (**count, std::cmp::Reverse(**beams)))
            .map_or(0, |(beams, _)| *beams)
    }
}

/// What the first pass found and decided.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportReport {
    /// The log.
    pub path: PathBuf,
    /// Whether it is gzip-compressed.
    pub gzip: bool,
    /// Its lines, by kind.
    pub counts: ParseCounts,
    /// The first malformed lines (all are counted in `counts.malformed`).
    pub malformed: Vec<LineError>,
    /// The laser.
    pub laser: LaserSummary,
    /// Where the odometry comes from.
    pub odometry: OdometrySource,
    /// Egomotion readings per second, when there are at least two.
    pub odometry_rate_hz: Option<f64>,
    /// The derived sonar, if any.
    pub sonar: Option<SonarOptions>,
    /// Distance sectors.
    pub distance_sectors: usize,
    /// The bearings the Distance sectors cover (the laser's field of view), from and to, in
    /// degrees (rounded to a micro-degree, so that the robot file states them exactly).
    pub distance_span_deg: [f64; 2],
    /// The period of the sources' heartbeats, in ns.
    pub heartbeat_period_ns: i64,
    /// The goal of the imported obstacle avoider, in the odometry frame, in m.
    pub goal: (f64, f64),
    /// Whether [`ImportOptions::max_scans`] cut the log short.
    pub cut_short: bool,
    /// Laser scan lines not imported (`RLASER`, `ROBOTLASER2`.., or `ROBOTLASER1` when the
    /// log has `FLASER`).
    pub scans_not_imported: u64,
    /// Parameters that could not be used, as sentences.
    pub parameter_problems: Vec<String>,
    /// What the time policy found and did.
    pub timing: TimingReport,
}

impl ImportReport {
    /// One sentence per thing the user should know about this import.
    #[must_use]
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.counts.malformed > 0 {
            out.push(format!(
                "{} malformed lines skipped{}",
                self.counts.malformed,
                self.malformed
                    .first()
                    .map(|e| format!("; the first: {e}"))
                    .unwrap_or_default()
            ));
        }
        if !self.counts.unknown.is_empty() {
            let types: Vec<String> = self
                .counts
                .unknown
                .iter()
                .map(|(kind, n)| format!("{n} {kind}"))
                .collect();
            out.push(format!("line types not imported: {}", types.join(", ")));
        }
        if self.scans_not_imported > 0 {
            out.push(format!(
                "{} scans of other lasers not imported (only the front laser, {}, is)",
                self.scans_not_imported,
                self.laser.source.line_type()
            ));
        }
        out.extend(self.parameter_problems.iter().cloned());
        if self.odometry == OdometrySource::ScanPoses {
            out.push(
                "the log has no ODOM lines: Egomotion comes from the odometry pose in each scan, with zero velocities"
                    .to_owned(),
            );
        }
        out.extend(self.timing.warnings());
        if let Some(sonar) = &self.sonar {
            out.push(format!(
                "provider `{SONAR}` is derived from the laser, not a sensor of the logged robot: {} transducers, {:.1} m, every {} scans",
                sonar.transducers, sonar.max_range_m, sonar.every_nth_scan
            ));
        }
        if self.cut_short {
            out.push(format!(
                "only the log up to its scan {} was imported (line {})",
                self.laser.beam_counts.values().sum::<u64>(),
                self.counts.lines
            ));
        }
        out
    }

    /// The parameters of the imported robot's `range_distance` service: the import computes
    /// its Distance readings with exactly these.
    #[must_use]
    pub fn distance_params(&self) -> range_distance::Params {
        range_distance::Params {
            sector_count: self.distance_sectors,
            span_deg: Some(self.distance_span_deg),
            seed: None,
        }
    }
}

/// A message of the import, with the time it is recorded at.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedMessage {
    /// Log time and publish time, in ns (never negative; non-decreasing over the import;
    /// strictly increasing per channel).
    pub time_ns: i64,
    /// The data channel (`/laser/RangeFinder`).
    pub channel: String,
    /// The message.
    pub payload: Payload,
}

/// The message of an [`ImportedMessage`].
#[derive(Debug, Clone, PartialEq)]
pub enum Payload {
    /// A laser or derived sonar reading.
    RangeFinder(RangeFinder),
    /// Free distance around the robot.
    Distance(Distance),
    /// Odometry.
    Egomotion(Egomotion),
    /// A heartbeat of a source (the log says nothing of its health: it is taken as alive
    /// from the log's first record to its last).
    Health(Health),
    /// A camera image (a ROS 2 bag's; CARMEN logs have none).
    ImageSource(ImageSource),
    /// The blobs of a camera image (a ROS 2 bag's, computed at import).
    Blobs(Blobs),
}

impl Payload {
    /// Its interface's name.
    #[must_use]
    pub fn interface(&self) -> &'static str {
        match self {
            Self::RangeFinder(_) => RangeFinder::NAME,
            Self::Distance(_) => Distance::NAME,
            Self::Egomotion(_) => Egomotion::NAME,
            Self::Health(_) => Health::NAME,
            Self::ImageSource(_) => ImageSource::NAME,
            Self::Blobs(_) => Blobs::NAME,
        }
    }

    /// Its schema name (`lewis_interfaces/msg/RangeFinder`), for the recorder.
    #[must_use]
    pub fn schema_name(&self) -> &'static str {
        match self {
            Self::RangeFinder(_) => RangeFinder::SCHEMA_NAME,
            Self::Distance(_) => Distance::SCHEMA_NAME,
            Self::Egomotion(_) => Egomotion::SCHEMA_NAME,
            Self::Health(_) => Health::SCHEMA_NAME,
            Self::ImageSource(_) => ImageSource::SCHEMA_NAME,
            Self::Blobs(_) => Blobs::SCHEMA_NAME,
        }
    }

    /// Its ros2msg schema text, for the recorder.
    #[must_use]
    pub fn schema_text(&self) -> &'static str {
        match self {
            Self::RangeFinder(_) => RangeFinder::SCHEMA_TEXT,
            Self::Distance(_) => Distance::SCHEMA_TEXT,
            Self::Egomotion(_) => Egomotion::SCHEMA_TEXT,
            Self::Health(_) => Health::SCHEMA_TEXT,
            Self::ImageSource(_) => ImageSource::SCHEMA_TEXT,
            Self::Blobs(_) => Blobs::SCHEMA_TEXT,
        }
    }

    /// Its CDR encoding, replacing the contents of `buffer`.
    pub fn encode_to_vec(&self, buffer: &mut Vec<u8>) {
        match self {
            Self::RangeFinder(m) => lewis_interfaces::cdr::encode_to_vec(m, buffer),
            Self::Distance(m) => lewis_interfaces::cdr::encode_to_vec(m, buffer),
            Self::Egomotion(m) => lewis_interfaces::cdr::encode_to_vec(m, buffer),
            Self::Health(m) => lewis_interfaces::cdr::encode_to_vec(m, buffer),
            Self::ImageSource(m) => lewis_interfaces::cdr::encode_to_vec(m, buffer),
            Self::Blobs(m) => lewis_interfaces::cdr::encode_to_vec(m, buffer),
        }
    }

    /// Its header.
    #[must_use]
    pub fn header(&self) -> &Header {
        match self {
            Self::RangeFinder(m) => &m.header,
            Self::Distance(m) => &m.header,
            Self::Egomotion(m) => &m.header,
            Self::Health(m) => &m.header,
            Self::ImageSource(m) => &m.header,
            Self::Blobs(m) => &m.header,
        }
    }
}

/// A CARMEN log read once, re-timed, and ready to stream its messages.
#[derive(Debug, Clone)]
pub struct CarmenImport {
    path: PathBuf,
    options: ImportOptions,
    times_ns: Vec<i64>,
    report: ImportReport,
}

#[derive(Clone, Copy)]
enum Timed {
    Odometry,
    Scan(LaserSource),
}

struct FrontParams {
    max_range: Option<(f64, u64)>,
    mount: LaserMount,
    problems: Vec<String>,
}

impl FrontParams {
    fn take(&mut self, name: &str, value: &str, line: u64) {
        let target = match name {
            "robot_front_laser_max" => None,
            "robot_frontlaser_offset" => Some(&mut self.mount.x_m),
            "robot_frontlaser_side_offset" => Some(&mut self.mount.y_m),
            "robot_frontlaser_angular_offset" => Some(&mut self.mount.heading_rad),
            _ => return,
        };
        let parsed = value.parse::<f64>().ok().filter(|v| v.is_finite());
        match (target, parsed) {
            (None, Some(v)) if v > 0.0 => self.max_range = Some((v, line)),
            (Some(slot), Some(v)) => *slot = v,
            _ => self.problems.push(format!(
                "PARAM {name} at line {line} is `{}`: ignored",
                value.chars().take(40).collect::<String>()
            )),
        }
    }
}

/// The beam geometry a scan states, or the old format's for its beam count.
fn beam_geometry(scan: &LaserScan) -> BeamGeometry {
    match scan.geometry {
        Some(g) => BeamGeometry {
            first_beam_rad: g.start_angle_rad,
            separation_rad: g.angular_resolution_rad,
        },
        None => BeamGeometry::old_format(scan.ranges_m.len()),
    }
}

fn rate_hz(times_ns: impl Iterator<Item = i64>) -> Option<f64> {
    let (mut first, mut last, mut count) = (None, 0, 0u64);
    for t in times_ns {
        first.get_or_insert(t);
        last = t;
        count += 1;
    }
    let span_s = (last - first?) as f64 / 1e9;
    (count >= 2 && span_s > 0.0).then(|| (count - 1) as f64 / span_s)
}

/// Where odometry poses come from, for the default goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum PoseStream {
    Odom,
    Scan(LaserSource),
}

/// The first pose of a stream and the one farthest from it.
#[derive(Debug, Default)]
struct FarthestPose {
    first: Option<Pose2D>,
    farthest: Option<(f64, Pose2D)>,
}

impl FarthestPose {
    fn see(&mut self, pose: &Pose2D) {
        if !(pose.x.is_finite() && pose.y.is_finite()) {
            return;
        }
        let first = self.first.get_or_insert_with(|| pose.clone());
        let d = (pose.x - first.x).hypot(pose.y - first.y);
        if self.farthest.as_ref().is_none_or(|(best, _)| d > *best) {
            self.farthest = Some((d, pose.clone()));
        }
    }
}

/// Whether the import has its `max_scans` scans of the laser it imports (FLASER, or
/// ROBOTLASER1 in a log without FLASER so far).
fn limit_reached(beams: &BTreeMap<LaserSource, BTreeMap<usize, u64>>, max: Option<u64>) -> bool {
    let Some(max) = max else {
        return false;
    };
    let scans = |source| beams.get(&source).map_or(0, |b| b.values().sum::<u64>());
    let front = scans(LaserSource::Flaser);
    front >= max || (front == 0 && scans(LaserSource::RobotLaser1) >= max)
}

/// The field of view of the most common scan, in the robot frame, in degrees, rounded to a
/// micro-degree.
fn span_deg(
    geometry: BeamGeometry,
    beam_counts: &BTreeMap<usize, u64>,
    mount: &LaserMount,
) -> [f64; 2] {
    let beams = beam_counts
        .iter()
        .max_by_key(|(beams, count)| (**count, std::cmp::Reverse(**beams)))
        .map_or(0, |(beams, _)| *beams);
    let scan = RangeFinder {
        ranges: vec![0.0; beams],
        theta_offset: mount.heading_rad + geometry.first_beam_rad,
        theta_separation: geometry.separation_rad,
        ..RangeFinder::default()
    };
    crate::import::span_deg(&scan)
}

fn check_options(options: &ImportOptions) -> Result<(), ImportError> {
    if options.max_scans == Some(0) {
        return Err(ImportError::Option(
            "--limit-scans 0 would import nothing: give at least 1 scan".to_owned(),
        ));
    }
    crate::import::check_shared_options(
        options.heartbeat_period_ns,
        options.goal,
        options.distance_sectors,
    )
    .map_err(ImportError::Option)
}

impl CarmenImport {
    /// Reads the log at `path` once: counts its lines, reads the laser parameters, and
    /// re-times its records.
    ///
    /// # Errors
    /// It cannot be read, has no laser scans, or the time policy refuses it.
    pub fn open(path: &Path, options: ImportOptions) -> Result<Self, ImportError> {
        Self::from_reader(LogReader::open(path)?, options)
    }

    /// Like [`CarmenImport::open`], from a reader already opened (the second pass opens
    /// the same path again).
    ///
    /// # Errors
    /// As [`CarmenImport::open`].
    pub fn from_reader(mut reader: LogReader, options: ImportOptions) -> Result<Self, ImportError> {
        check_options(&options)?;
        let mut timed: Vec<(Timed, StampInput)> = Vec::new();
        let mut poses: BTreeMap<PoseStream, FarthestPose> = BTreeMap::new();
        let mut cut_short = false;
        let mut beams: BTreeMap<LaserSource, BTreeMap<usize, u64>> = BTreeMap::new();
        let mut geometry: BTreeMap<LaserSource, BeamGeometry> = BTreeMap::new();
        let mut params = FrontParams {
            max_range: None,
            mount: LaserMount::default(),
            problems: Vec::new(),
        };
        while let Some(entry) = reader.next_record()? {
            let line = entry.line;
            match entry.value {
                Record::Param(p) => params.take(&p.name, &p.value, line),
                Record::Odometry(o) => {
                    poses.entry(PoseStream::Odom).or_default().see(&o.pose);
                    timed.push((
                        Timed::Odometry,
                        StampInput {
                            stream: Stream::Odometry,
                            line,
                            time: o.stamps.map(|s| s.logger),
                        },
                    ));
                }
                Record::Laser(scan) => {
                    let source = match scan.laser {
                        LaserId::Front => LaserSource::Flaser,
                        LaserId::Robot(1) => LaserSource::RobotLaser1,
                        _ => continue,
                    };
                    geometry
                        .entry(source)
                        .or_insert_with(|| beam_geometry(&scan));
                    *beams
                        .entry(source)
                        .or_default()
                        .entry(scan.ranges_m.len())
                        .or_default() += 1;
                    poses
                        .entry(PoseStream::Scan(source))
                        .or_default()
                        .see(&scan.odometry_pose);
                    timed.push((
                        Timed::Scan(source),
                        StampInput {
                            stream: Stream::Scan,
                            line,
                            time: scan.stamps.map(|s| s.logger),
                        },
                    ));
                    if limit_reached(&beams, options.max_scans) {
                        cut_short = true;
                        break;
                    }
                }
            }
        }
        let path = reader.path().to_owned();
        let counts = reader.counts().clone();
        let source = if counts.scans_of(LaserId::Front) > 0 {
            LaserSource::Flaser
        } else if counts.scans_of(LaserId::Robot(1)) > 0 {
            LaserSource::RobotLaser1
        } else {
            return Err(ImportError::NoScans {
                path,
                lines: counts.lines,
            });
        };
        let odometry = if counts.odometry > 0 {
            OdometrySource::OdomLines
        } else {
            OdometrySource::ScanPoses
        };
        let inputs: Vec<StampInput> = timed
            .iter()
            .filter(|(kind, _)| match kind {
                Timed::Odometry => true,
                Timed::Scan(s) => *s == source,
            })
            .map(|(_, input)| *input)
            .collect();
        let retimed = retime(&inputs, &options.timing).map_err(|source| ImportError::Timing {
            path: path.clone(),
            source,
        })?;
        let times_of = |stream: Stream| {
            inputs
                .iter()
                .zip(&retimed.times_ns)
                .filter(move |(i, _)| i.stream == stream)
                .map(|(_, t)| *t)
        };
        let scan_rate = rate_hz(times_of(Stream::Scan));
        let odometry_rate_hz = match odometry {
            OdometrySource::OdomLines => rate_hz(times_of(Stream::Odometry)),
            OdometrySource::ScanPoses => scan_rate,
        };
        let all_scans: u64 = counts.scans.values().sum();
        let (max_range_m, max_range_line) = match params.max_range {
            Some((range, line)) => (range, Some(line)),
            None => (options.default_max_range_m, None),
        };
        let pose_stream = match odometry {
            OdometrySource::OdomLines => PoseStream::Odom,
            OdometrySource::ScanPoses => PoseStream::Scan(source),
        };
        let goal = options.goal.unwrap_or_else(|| {
            poses
                .get(&pose_stream)
                .and_then(|p| p.farthest.as_ref())
                .map_or((0.0, 0.0), |(_, pose)| (pose.x, pose.y))
        });
        let geometry = geometry
            .remove(&source)
            .unwrap_or_else(|| BeamGeometry::old_format(0));
        let beam_counts = beams.remove(&source).unwrap_or_default();
        let distance_span_deg = span_deg(geometry, &beam_counts, &params.mount);
        let report = ImportReport {
            gzip: reader.is_gzip(),
            malformed: reader.errors().to_vec(),
            scans_not_imported: all_scans - counts.scans_of(source.id()),
            laser: LaserSummary {
                source,
                beam_counts,
                geometry,
                max_range_m,
                max_range_line,
                mount: params.mount,
                rate_hz: scan_rate,
            },
            counts,
            odometry,
            odometry_rate_hz,
            sonar: options.sonar,
            distance_sectors: options.distance_sectors,
            distance_span_deg,
            heartbeat_period_ns: options.heartbeat_period_ns,
            goal,
            cut_short,
            parameter_problems: params.problems,
            timing: retimed.report,
            path: path.clone(),
        };
        Ok(Self {
            path,
            options,
            times_ns: retimed.times_ns,
            report,
        })
    }

    /// What the first pass found and decided.
    #[must_use]
    pub fn report(&self) -> &ImportReport {
        &self.report
    }

    /// The messages, streamed from a second pass over the file.
    ///
    /// # Errors
    /// The file cannot be opened again.
    pub fn messages(&self) -> Result<Messages<'_>, ImportError> {
        self.messages_from(LogReader::open(&self.path)?)
    }

    /// The messages, from a reader of the same log (for logs that are not files).
    ///
    /// # Errors
    /// Never for now; kept fallible for symmetry with [`CarmenImport::messages`].
    pub fn messages_from(&self, reader: LogReader) -> Result<Messages<'_>, ImportError> {
        let laser = &self.report.laser;
        let distance = RangeToDistance::from_params(&self.report.distance_params())
            .map_err(ImportError::Option)?;
        let mut sources = vec![BASE, LASER];
        if self.report.sonar.is_some() {
            sources.push(SONAR);
        }
        Ok(Messages {
            import: self,
            reader,
            next_time: 0,
            scans: 0,
            pending: VecDeque::new(),
            seq: BTreeMap::new(),
            readings: ReadingCounts::default(),
            last_pose: None,
            distance_travelled_m: 0.0,
            setup: LaserSetup {
                mount: laser.mount,
                max_range_m: laser.max_range_m,
                distance_sectors: self.options.distance_sectors,
            },
            distance,
            sources,
            next_heartbeat_ns: None,
            done: false,
        })
    }
}

/// The messages of an import, in log order (see [`CarmenImport::messages`]).
pub struct Messages<'a> {
    import: &'a CarmenImport,
    reader: LogReader,
    next_time: usize,
    scans: u64,
    pending: VecDeque<ImportedMessage>,
    seq: BTreeMap<(&'static str, &'static str), u64>,
    readings: ReadingCounts,
    last_pose: Option<Pose2D>,
    distance_travelled_m: f64,
    setup: LaserSetup,
    distance: RangeToDistance,
    /// The sources whose heartbeats are written.
    sources: Vec<&'static str>,
    next_heartbeat_ns: Option<i64>,
    done: bool,
}

impl std::fmt::Debug for Messages<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Messages")
            .field("reader", &self.reader)
            .field("next_time", &self.next_time)
            .finish_non_exhaustive()
    }
}

impl Messages<'_> {
    /// The readings converted so far, by kind.
    #[must_use]
    pub fn reading_counts(&self) -> ReadingCounts {
        self.readings
    }

    fn header(&mut self, provider: &'static str, interface: &'static str, time_ns: i64) -> Header {
        let seq = self.seq.entry((provider, interface)).or_default();
        *seq += 1;
        Header {
            provider: provider.to_owned(),
            seq: *seq,
            publish_time_ns: time_ns,
            inputs: Vec::new(),
        }
    }

    fn emit(&mut self, provider: &'static str, time_ns: i64, payload: Payload) {
        self.pending.push_back(ImportedMessage {
            time_ns,
            channel: data_channel(provider, payload.interface()),
            payload,
        });
    }

    /// The heartbeats of every source due at or before `time_ns`, from the first record's
    /// time on, every heartbeat period.
    fn heartbeats_until(&mut self, time_ns: i64) {
        let period = self.import.report.heartbeat_period_ns.max(1);
        let mut next = *self.next_heartbeat_ns.get_or_insert(time_ns);
        while next <= time_ns {
            for provider in self.sources.clone() {
                let message = Health {
                    header: self.header(provider, Health::NAME, next),
                    state: HealthState::Ok.into(),
                    reason: String::new(),
                };
                self.pending.push_back(ImportedMessage {
                    time_ns: next,
                    channel: health_channel(provider),
                    payload: Payload::Health(message),
                });
            }
            next = next.saturating_add(period);
        }
        self.next_heartbeat_ns = Some(next);
    }

    fn next_time(&mut self) -> Result<i64, ImportError> {
        let t = self
            .import
            .times_ns
            .get(self.next_time)
            .copied()
            .ok_or_else(|| ImportError::Changed {
                path: self.import.path.clone(),
            })?;
        self.next_time += 1;
        Ok(t)
    }

    fn egomotion(&mut self, time_ns: i64, pose: Pose2D, tv: f64, rv: f64) {
        self.heartbeats_until(time_ns);
        if let Some(last) = &self.last_pose {
            self.distance_travelled_m += (pose.x - last.x).hypot(pose.y - last.y);
        }
        self.last_pose = Some(pose.clone());
        let message = Egomotion {
            header: self.header(BASE, Egomotion::NAME, time_ns),
            pose,
            translation_velocity: tv,
            rotation_velocity: rv,
            distance_travelled: self.distance_travelled_m,
        };
        self.emit(BASE, time_ns, Payload::Egomotion(message));
    }

    fn scan(&mut self, time_ns: i64, scan: LaserScan) {
        self.heartbeats_until(time_ns);
        let geometry = beam_geometry(&scan);
        let mut setup = self.setup;
        if let (Some(g), None) = (scan.geometry, self.import.report.laser.max_range_line)
            && g.max_range_m > 0.0
        {
            setup.max_range_m = g.max_range_m;
        }
        let mut laser = range_finder(&scan.ranges_m, geometry, &setup, &mut self.readings);
        laser.header = self.header(LASER, RangeFinder::NAME, time_ns);
        // What the `distance` service publishes when this reading reaches it.
        let mut distance = self.distance.distance(&laser);
        distance.header = self.header(DISTANCE, Distance::NAME, time_ns);
        distance.header.inputs = vec![InputRef {
            channel: data_channel(LASER, RangeFinder::NAME),
            seq: laser.header.seq,
        }];
        let sonar = self.import.options.sonar.filter(|s| {
            self.scans
                .is_multiple_of(u64::from(s.every_nth_scan.max(1)))
        });
        let sonar_reading = sonar.map(|options| derived_sonar(&laser, &options));
        self.scans += 1;
        self.emit(LASER, time_ns, Payload::RangeFinder(laser));
        self.emit(DISTANCE, time_ns, Payload::Distance(distance));
        if let Some(mut reading) = sonar_reading {
            reading.header = self.header(SONAR, RangeFinder::NAME, time_ns);
            self.emit(SONAR, time_ns, Payload::RangeFinder(reading));
        }
        if self.import.report.odometry == OdometrySource::ScanPoses {
            self.egomotion(time_ns, scan.odometry_pose, 0.0, 0.0);
        }
    }

    fn fill(&mut self) -> Result<(), ImportError> {
        let wanted = self.import.report.laser.source.id();
        while self.pending.is_empty() {
            // A log cut short (`max_scans`) ends with its last timed record.
            if self.import.report.cut_short && self.next_time == self.import.times_ns.len() {
                return Ok(());
            }
            let Some(entry) = self.reader.next_record()? else {
                if self.next_time != self.import.times_ns.len() {
                    return Err(ImportError::Changed {
                        path: self.import.path.clone(),
                    });
                }
                return Ok(());
            };
            match entry.value {
                Record::Odometry(o) => {
                    let t = self.next_time()?;
                    self.egomotion(
                        t,
                        o.pose,
                        o.translation_velocity_mps,
                        o.rotation_velocity_radps,
                    );
                }
                Record::Laser(scan) if scan.laser == wanted => {
                    let t = self.next_time()?;
                    self.scan(t, scan);
                }
                Record::Param(_) | Record::Laser(_) => {}
            }
        }
        Ok(())
    }
}

impl Iterator for Messages<'_> {
    type Item = Result<ImportedMessage, ImportError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.pending.is_empty()
            && !self.done
            && let Err(e) = self.fill()
        {
            self.done = true;
            return Some(Err(e));
        }
        let next = self.pending.pop_front();
        if next.is_none() {
            self.done = true;
        }
        next.map(Ok)
    }
}
