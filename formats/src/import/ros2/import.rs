//! The import in three passes over the bag, in file order: the topics and their counts
//! (choose), then the chosen topics decoded and checked (range counts, image encodings,
//! time) with what the robot file and the report need, then the messages streamed out.
//! Every check is made before anything is streamed, so a bag refused is refused before
//! its output is begun; memory does not grow with the bag.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_interfaces::Interface;
use lewis_interfaces::dynamic::{Decoder, Value};
use lewis_interfaces::msg::{
    Blobs, Distance, Egomotion, Header, Health, HealthState, ImageSource, InputRef, Pose2D,
    RangeFinder,
};
use lewis_perception::blobfinder::{self, BlobFinder};
use lewis_perception::cmvision::ColorConfig;
use lewis_perception::range_distance::{self, RangeToDistance};
use lewis_ros2_map::from_ros2::{self, ImageError, RangeCounts, Scan};
use lewis_runtime::names::{data_channel, health_channel};

use super::bag::{self, BagMessage};
use super::topics::{self, Choice, ChoiceError, Role, TopicStats};
use crate::import::carmen::laser::{SonarOptions, derived_sonar};
use crate::import::carmen::{ImportedMessage, Payload};

/// The provider name of the imported laser.
pub const LASER: &str = "laser";
/// The provider name of a second range sensor of the bag, the laser's fallback.
pub const SECOND_LASER: &str = "laser2";
/// The provider name of the imported odometry.
pub const BASE: &str = "base";
/// The provider name of the imported camera.
pub const CAMERA: &str = "camera";
/// The provider name of the sonar-like fallback derived from the laser.
pub const SONAR: &str = crate::import::carmen::SONAR;
/// The name of the imported robot's Distance service, whose outputs the import computes.
pub const DISTANCE: &str = crate::import::carmen::DISTANCE;
/// The name of the imported robot's blob finder (with `--colors`), whose outputs the import
/// computes.
pub const BLOBFINDER: &str = "blobfinder";

/// A header stamp further than this from its log time disagrees with it.
pub const STAMP_TOLERANCE_NS: i64 = 1_000_000_000;

/// How to import a bag.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportOptions {
    /// Topics mapped by the user to an interface (`--map TOPIC=INTERFACE`).
    pub maps: Vec<(String, String)>,
    /// The avoider's goal in the odometry frame, in m (`None`: the odometry pose farthest
    /// from the first one).
    pub goal: Option<(f64, f64)>,
    /// The derived sonar, when the bag has no second range sensor (`None`: none).
    pub sonar: Option<SonarOptions>,
    /// Distance sectors over the laser's field of view.
    pub distance_sectors: usize,
    /// The period of the sources' heartbeats, in ns.
    pub heartbeat_period_ns: i64,
    /// A colour file (Player's format or TOML): with a camera, the robot gets a
    /// `blobfinder` over it, whose Blobs the import computes (`None`: no blob finder).
    pub colors: Option<PathBuf>,
}

impl Default for ImportOptions {
    /// No maps, the farthest pose, the derived sonar's defaults, 8 sectors, 100 ms.
    fn default() -> Self {
        Self {
            maps: Vec::new(),
            goal: None,
            sonar: Some(SonarOptions::default()),
            distance_sectors: 8,
            heartbeat_period_ns: 100_000_000,
            colors: None,
        }
    }
}

/// Why a bag cannot be imported. Each message names the bag; a message's problem names its
/// topic, its index on the topic (from 0) and its log time.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// Not an MCAP file, or unreadable.
    #[error("{}: cannot be read as MCAP: {reason}", path.display())]
    Unreadable {
        /// The bag.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// The topics cannot be chosen.
    #[error(transparent)]
    Choice(#[from] ChoiceError),
    /// Nothing the import makes Lewis messages of.
    #[error(
        "{}: no laser (sensor_msgs/LaserScan) and no odometry (nav_msgs/Odometry, or odom to base_link on /tf) among its topics: nothing to replay over; it has {topics}",
        path.display()
    )]
    NothingToImport {
        /// The bag.
        path: PathBuf,
        /// Its topics and types, or "no messages".
        topics: String,
    },
    /// A message of a chosen topic cannot be imported.
    #[error(
        "{}: {topic} message {index} (log time {:.6} s): {reason}",
        path.display(), *log_time_ns as f64 / 1e9
    )]
    Message {
        /// The bag.
        path: PathBuf,
        /// Its topic.
        topic: String,
        /// Its index on the topic, from 0.
        index: u64,
        /// Its log time, in ns.
        log_time_ns: u64,
        /// What is wrong.
        reason: String,
    },
    /// A chosen topic's schema does not parse.
    #[error("{}: {topic}: its schema {type_name} cannot be read: {reason}", path.display())]
    Schema {
        /// The bag.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Its type.
        type_name: String,
        /// Why.
        reason: String,
    },
    /// An option is out of range.
    #[error("{0}")]
    Option(String),
    /// The bag changed between two passes.
    #[error("{} changed while it was being imported: import it again", path.display())]
    Changed {
        /// The bag.
        path: PathBuf,
    },
}

/// What the import found of a range sensor.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserStats {
    /// Its topic.
    pub topic: String,
    /// Scans.
    pub scans: u64,
    /// Beams per scan (the same in every scan: the import checks it).
    pub beams: usize,
    /// `range_max` of its first scan, in m.
    pub max_range_m: f64,
    /// Bearing of the first beam and the step, in rad, of its first scan.
    pub angle_min_rad: f64,
    /// Angle between beams, in rad.
    pub angle_increment_rad: f64,
    /// Scans per second.
    pub rate_hz: Option<f64>,
    /// Readings kept and replaced.
    pub readings: RangeCounts,
}

/// What the import found of the odometry.
#[derive(Debug, Clone, PartialEq)]
pub struct OdometryStats {
    /// Its topic.
    pub topic: String,
    /// Odometry or TF.
    pub role: Role,
    /// Egomotion readings it gives.
    pub readings: u64,
    /// Readings per second.
    pub rate_hz: Option<f64>,
}

/// What the import found of the camera.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageStats {
    /// Its topic.
    pub topic: String,
    /// Raw or compressed.
    pub role: Role,
    /// Images.
    pub images: u64,
    /// Encodings (or compressed formats) met, with counts.
    pub encodings: BTreeMap<String, u64>,
    /// Size of the first image, in px.
    pub size_px: (u32, u32),
    /// Images per second.
    pub rate_hz: Option<f64>,
}

/// Header stamps of a topic against its log times.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StampStats {
    /// Messages with a header.
    pub stamped: u64,
    /// Stamps of zero (a publisher that never set them).
    pub zero: u64,
    /// Stamps further than [`STAMP_TOLERANCE_NS`] from their log time.
    pub disagreeing: u64,
    /// Stamps earlier than the one before on the topic.
    pub backwards: u64,
    /// Smallest and largest log time minus stamp of the non-zero stamps, in ns.
    pub offset_range_ns: Option<(i64, i64)>,
}

/// What the first two passes found and decided.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportReport {
    /// The bag.
    pub path: PathBuf,
    /// Every topic of the bag.
    pub topics: Vec<TopicStats>,
    /// The topics chosen.
    pub choice: Choice,
    /// The laser, when there is one.
    pub laser: Option<LaserStats>,
    /// The second range sensor, when mapped.
    pub second_laser: Option<LaserStats>,
    /// The odometry, when there is one.
    pub odometry: Option<OdometryStats>,
    /// The camera, when there is one.
    pub image: Option<ImageStats>,
    /// Header stamps against log times, per chosen topic.
    pub stamps: BTreeMap<String, StampStats>,
    /// The derived sonar (only with a laser and no second range sensor).
    pub sonar: Option<SonarOptions>,
    /// Distance sectors and their span, from and to, in degrees.
    pub distance_sectors: usize,
    /// The span of the Distance sectors (the laser's field of view), in degrees.
    pub distance_span_deg: [f64; 2],
    /// The heartbeat period, in ns.
    pub heartbeat_period_ns: i64,
    /// The avoider's goal, in the odometry frame, in m.
    pub goal: (f64, f64),
    /// Damage that ended the reading early, as a sentence.
    pub damage: Option<String>,
    /// Topics kept as they are but not decodable (not CDR under ros2msg): not written.
    pub not_ros2: Vec<String>,
    /// The colour file of the blob finder, made absolute (only with a camera).
    pub colors: Option<PathBuf>,
}

impl ImportReport {
    /// One sentence per thing the user should know.
    #[must_use]
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(damage) = &self.damage {
            out.push(format!(
                "the bag is damaged: {damage}; imported up to there"
            ));
        }
        if self.laser.is_none() {
            out.push(
                "no laser: no RangeFinder, no Distance and no ObstacleAvoider to replay".to_owned(),
            );
        }
        if self.odometry.is_none() {
            out.push(
                "no odometry (nav_msgs/Odometry or odom to base_link on /tf): no Egomotion, so no ObstacleAvoider or VectorMover to replay; Distance only"
                    .to_owned(),
            );
        }
        if let Some(o) = &self.odometry
            && o.role == Role::Tf
        {
            out.push(format!(
                "Egomotion from the odom to base transforms of {}, with zero velocities",
                o.topic
            ));
        }
        for laser in self.laser.iter().chain(&self.second_laser) {
            if laser.readings.out_of_limits > 0 {
                out.push(format!(
                    "{}: {} of {} readings outside [range_min, range_max] or not finite, published as max range ({:.2} m)",
                    laser.topic,
                    laser.readings.out_of_limits,
                    laser.readings.out_of_limits + laser.readings.kept,
                    laser.max_range_m
                ));
            }
        }
        for (topic, s) in &self.stamps {
            if s.zero + s.disagreeing + s.backwards > 0 {
                out.push(format!(
                    "{topic}: of {} header stamps, {} are zero, {} differ from their log time by more than {} s and {} go backwards; the recording keeps the log times",
                    s.stamped,
                    s.zero,
                    s.disagreeing,
                    STAMP_TOLERANCE_NS / 1_000_000_000,
                    s.backwards
                ));
            }
        }
        if let Some(sonar) = &self.sonar {
            out.push(format!(
                "provider `{SONAR}` is derived from the laser, not a sensor of the bag: {} transducers, {:.1} m, every {} scans",
                sonar.transducers, sonar.max_range_m, sonar.every_nth_scan
            ));
        }
        if !self.not_ros2.is_empty() {
            out.push(format!(
                "topics not ROS 2 CDR, left out: {}",
                self.not_ros2.join(", ")
            ));
        }
        out
    }

    /// The parameters of the imported robot's `range_distance` service.
    #[must_use]
    pub fn distance_params(&self) -> range_distance::Params {
        range_distance::Params {
            sector_count: self.distance_sectors,
            span_deg: Some(self.distance_span_deg),
            seed: None,
        }
    }
}

/// What the stream hands out: a Lewis message, or a message of the bag kept as it is.
#[derive(Debug)]
pub enum Out<'a> {
    /// A message made by the import (boxed: it is five times the size of the other).
    Lewis(Box<ImportedMessage>),
    /// A message of the bag, unchanged.
    Original(BagMessage<'a>),
}

/// A bag read and checked, ready to stream its messages.
#[derive(Debug, Clone)]
pub struct Ros2Import {
    report: ImportReport,
}

/// A decoded message of a chosen topic, converted.
enum Converted {
    Laser(RangeFinder, RangeCounts),
    SecondLaser(RangeFinder, RangeCounts),
    Odometry(from_ros2::Odometry),
    Image(ImageSource, String),
    Nothing,
}

/// The decoders of the chosen topics and the checks that carry from message to message.
struct Converter {
    path: PathBuf,
    choice: Choice,
    decoders: BTreeMap<String, Decoder>,
    beams: BTreeMap<String, (usize, u64)>,
    last_log_ns: BTreeMap<String, u64>,
    last_stamp_ns: BTreeMap<String, i64>,
    stamps: BTreeMap<String, StampStats>,
}

impl Converter {
    fn new(path: &Path, choice: &Choice) -> Self {
        Self {
            path: path.to_owned(),
            choice: choice.clone(),
            decoders: BTreeMap::new(),
            beams: BTreeMap::new(),
            last_log_ns: BTreeMap::new(),
            last_stamp_ns: BTreeMap::new(),
            stamps: BTreeMap::new(),
        }
    }

    fn role(&self, topic: &str) -> Option<(Role, bool)> {
        let c = &self.choice;
        if c.laser.as_deref() == Some(topic) {
            Some((Role::Laser, false))
        } else if c.second_laser.as_deref() == Some(topic) {
            Some((Role::Laser, true))
        } else if let Some((t, role)) = &c.odometry
            && t == topic
        {
            Some((*role, false))
        } else if let Some((t, role)) = &c.image
            && t == topic
        {
            Some((*role, false))
        } else {
            None
        }
    }

    fn error(&self, m: &BagMessage<'_>, reason: impl Into<String>) -> ImportError {
        ImportError::Message {
            path: self.path.clone(),
            topic: m.topic.name.clone(),
            index: m.index,
            log_time_ns: m.log_time_ns,
            reason: reason.into(),
        }
    }

    fn decode(&mut self, m: &BagMessage<'_>) -> Result<Value, ImportError> {
        let topic = m.topic;
        if !self.decoders.contains_key(&topic.name) {
            let decoder = Decoder::new(&topic.type_name, &topic.schema_text).map_err(|e| {
                ImportError::Schema {
                    path: self.path.clone(),
                    topic: topic.name.clone(),
                    type_name: topic.type_name.clone(),
                    reason: e.to_string(),
                }
            })?;
            self.decoders.insert(topic.name.clone(), decoder);
        }
        let decoded = self
            .decoders
            .get(&topic.name)
            .map(|d| d.decode(m.data).map_err(|e| e.to_string()));
        match decoded {
            Some(Ok(value)) => Ok(value),
            Some(Err(reason)) => Err(self.error(
                m,
                format!("does not decode as {}: {reason}", topic.type_name),
            )),
            None => Err(self.error(m, "no decoder")),
        }
    }

    /// Checks time, decodes and converts a message of a chosen topic.
    fn convert(&mut self, m: &BagMessage<'_>) -> Result<Converted, ImportError> {
        let Some((role, second)) = self.role(&m.topic.name) else {
            return Ok(Converted::Nothing);
        };
        if i64::try_from(m.log_time_ns).is_err() {
            return Err(self.error(m, "its log time is beyond the year 2262"));
        }
        if let Some(&before) = self.last_log_ns.get(&m.topic.name)
            && m.log_time_ns < before
        {
            return Err(self.error(
                m,
                format!(
                    "time goes backwards: its log time is {:.6} s before the previous message's on the topic ({:.6} s); fix the bag's order (for instance `ros2 bag convert`) and import it again",
                    (before - m.log_time_ns) as f64 / 1e9,
                    before as f64 / 1e9
                ),
            ));
        }
        self.last_log_ns.insert(m.topic.name.clone(), m.log_time_ns);
        let value = self.decode(m)?;
        let stamp = if role == Role::Tf {
            None
        } else {
            from_ros2::stamp_ns(&value)
        };
        self.stamp(m, stamp);
        match role {
            Role::Laser => {
                let scan = from_ros2::laser_scan(&value).map_err(|r| self.error(m, r))?;
                self.check_beams(m, &scan)?;
                let mut counts = RangeCounts::default();
                let reading = from_ros2::range_finder(&scan, &mut counts);
                Ok(if second {
                    Converted::SecondLaser(reading, counts)
                } else {
                    Converted::Laser(reading, counts)
                })
            }
            Role::Odometry => from_ros2::odometry(&value)
                .map(Converted::Odometry)
                .map_err(|r| self.error(m, r)),
            Role::Tf => match from_ros2::tf_odometry(&value).map_err(|r| self.error(m, r))? {
                Some((pose, stamp)) => {
                    self.stamp(m, stamp);
                    Ok(Converted::Odometry(from_ros2::Odometry {
                        pose,
                        translation_mps: 0.0,
                        rotation_radps: 0.0,
                    }))
                }
                None => Ok(Converted::Nothing),
            },
            Role::Image | Role::CompressedImage => {
                let kind = value
                    .get("encoding")
                    .or_else(|| value.get("format"))
                    .and_then(Value::as_str)
                    .unwrap_or_default()
                    .to_owned();
                let pixels = if role == Role::Image {
                    from_ros2::image(&value)
                } else {
                    from_ros2::compressed_image(&value)
                };
                match pixels {
                    Ok((w, h, rgb)) => Ok(Converted::Image(from_ros2::image_source(w, h, rgb), kind)),
                    Err(e @ ImageError::UnknownEncoding(_)) => Err(self.error(
                        m,
                        format!("{e}; map another image topic with --map TOPIC=ImageSource, if the bag has one"),
                    )),
                    Err(e) => Err(self.error(m, e.to_string())),
                }
            }
        }
    }

    fn stamp(&mut self, m: &BagMessage<'_>, stamp: Option<i64>) {
        let Some(stamp) = stamp else { return };
        let s = self.stamps.entry(m.topic.name.clone()).or_default();
        s.stamped += 1;
        if stamp == 0 {
            s.zero += 1;
            return;
        }
        let log = i64::try_from(m.log_time_ns).unwrap_or(i64::MAX);
        let offset = log.saturating_sub(stamp);
        if offset.saturating_abs() > STAMP_TOLERANCE_NS {
            s.disagreeing += 1;
        }
        s.offset_range_ns = Some(s.offset_range_ns.map_or((offset, offset), |(lo, hi)| {
            (lo.min(offset), hi.max(offset))
        }));
        if let Some(&before) = self.last_stamp_ns.get(&m.topic.name)
            && stamp < before
        {
            s.backwards += 1;
        }
        self.last_stamp_ns.insert(m.topic.name.clone(), stamp);
    }

    fn check_beams(&mut self, m: &BagMessage<'_>, scan: &Scan) -> Result<(), ImportError> {
        let n = scan.ranges_m.len();
        if n == 0 {
            return Err(self.error(m, "the scan has no ranges"));
        }
        match self.beams.get(&m.topic.name) {
            Some(&(before, first)) if before != n => Err(self.error(
                m,
                format!(
                    "the scan has {n} ranges, the scans before it {before} (since message {first}): a RangeFinder keeps its beam count; import the part before it (or after) as a bag of its own"
                ),
            )),
            Some(_) => Ok(()),
            None => {
                self.beams.insert(m.topic.name.clone(), (n, m.index));
                Ok(())
            }
        }
    }
}

fn check_options(options: &ImportOptions) -> Result<(), ImportError> {
    crate::import::check_shared_options(
        options.heartbeat_period_ns,
        options.goal,
        options.distance_sectors,
    )
    .map_err(ImportError::Option)
}

fn laser_stats(
    topic: &str,
    first: &RangeFinder,
    scans: u64,
    span: Option<(u64, u64)>,
    readings: RangeCounts,
) -> LaserStats {
    LaserStats {
        topic: topic.to_owned(),
        scans,
        beams: first.ranges.len(),
        max_range_m: first.max_range,
        angle_min_rad: first.theta_offset,
        angle_increment_rad: first.theta_separation,
        rate_hz: topics::rate_hz(scans, span),
        readings,
    }
}

#[derive(Default)]
struct Seen {
    count: u64,
    span: Option<(u64, u64)>,
}

impl Seen {
    fn see(&mut self, t: u64) {
        self.count += 1;
        self.span = Some(self.span.map_or((t, t), |(a, _)| (a, t)));
    }
}

impl Ros2Import {
    /// Reads the bag at `path`: its topics, the choice, and every message of the chosen
    /// topics decoded and checked.
    ///
    /// # Errors
    /// See [`ImportError`].
    pub fn open(path: &Path, options: &ImportOptions) -> Result<Self, ImportError> {
        check_options(options)?;
        // Pass 1: the topics.
        let mut stats: BTreeMap<u16, TopicStats> = BTreeMap::new();
        let end = bag::read::<_, ImportError>(path, |m| {
            let s = stats.entry(m.topic.id).or_insert_with(|| TopicStats {
                topic: m.topic.clone(),
                count: 0,
                span_ns: None,
            });
            s.count += 1;
            s.span_ns = Some(s.span_ns.map_or((m.log_time_ns, m.log_time_ns), |(a, b)| {
                (a.min(m.log_time_ns), b.max(m.log_time_ns))
            }));
            Ok(())
        })?;
        let topics: Vec<TopicStats> = stats.into_values().collect();
        let choice = topics::choose(path, &topics, &options.maps)?;
        if choice.laser.is_none() && choice.odometry.is_none() {
            let list: Vec<String> = topics
                .iter()
                .map(|t| format!("{} ({})", t.topic.name, t.topic.type_name))
                .collect();
            let mut topics = if list.is_empty() {
                "no messages".to_owned()
            } else {
                list.join(", ")
            };
            if let Some(damage) = &end.damage {
                topics.push_str(&format!(" (it is damaged: {damage}; read up to there)"));
            }
            return Err(ImportError::NothingToImport {
                path: path.to_owned(),
                topics,
            });
        }
        // Pass 2: decode and check the chosen topics.
        let mut converter = Converter::new(path, &choice);
        let (mut laser, mut second) = (Seen::default(), Seen::default());
        let (mut odometry, mut images) = (Seen::default(), Seen::default());
        let (mut first_laser, mut first_second): (Option<RangeFinder>, Option<RangeFinder>) =
            (None, None);
        let (mut laser_counts, mut second_counts) =
            (RangeCounts::default(), RangeCounts::default());
        let mut first_pose: Option<Pose2D> = None;
        let mut farthest: Option<(f64, Pose2D)> = None;
        let mut encodings: BTreeMap<String, u64> = BTreeMap::new();
        let mut size_px = (0, 0);
        bag::read::<_, ImportError>(path, |m| {
            match converter.convert(&m)? {
                Converted::Laser(r, counts) => {
                    laser_counts.kept += counts.kept;
                    laser_counts.out_of_limits += counts.out_of_limits;
                    laser.see(m.log_time_ns);
                    first_laser.get_or_insert(r);
                }
                Converted::SecondLaser(r, counts) => {
                    second_counts.kept += counts.kept;
                    second_counts.out_of_limits += counts.out_of_limits;
                    second.see(m.log_time_ns);
                    first_second.get_or_insert(r);
                }
                Converted::Odometry(o) => {
                    odometry.see(m.log_time_ns);
                    let p = &o.pose;
                    if p.x.is_finite() && p.y.is_finite() {
                        let first = first_pose.get_or_insert_with(|| p.clone());
                        let d = (p.x - first.x).hypot(p.y - first.y);
                        if farthest.as_ref().is_none_or(|(best, _)| d > *best) {
                            farthest = Some((d, p.clone()));
                        }
                    }
                }
                Converted::Image(i, kind) => {
                    if images.count == 0 {
                        size_px = (
                            u32::try_from(i.width).unwrap_or(0),
                            u32::try_from(i.height).unwrap_or(0),
                        );
                    }
                    images.see(m.log_time_ns);
                    *encodings.entry(kind).or_default() += 1;
                }
                Converted::Nothing => {}
            }
            Ok(())
        })?;
        let laser_stats_v = first_laser
            .as_ref()
            .zip(choice.laser.as_deref())
            .map(|(f, t)| laser_stats(t, f, laser.count, laser.span, laser_counts));
        let second_stats = first_second
            .as_ref()
            .zip(choice.second_laser.as_deref())
            .map(|(f, t)| laser_stats(t, f, second.count, second.span, second_counts));
        let odometry_stats =
            choice
                .odometry
                .as_ref()
                .filter(|_| odometry.count > 0)
                .map(|(t, role)| OdometryStats {
                    topic: t.clone(),
                    role: *role,
                    readings: odometry.count,
                    rate_hz: topics::rate_hz(odometry.count, odometry.span),
                });
        if laser_stats_v.is_none() && odometry_stats.is_none() {
            let topics_text = topics
                .iter()
                .map(|t| {
                    format!(
                        "{} ({}, {} messages)",
                        t.topic.name, t.topic.type_name, t.count
                    )
                })
                .collect::<Vec<_>>()
                .join(", ");
            return Err(ImportError::NothingToImport {
                path: path.to_owned(),
                topics: topics_text,
            });
        }
        let image_stats = choice.image.as_ref().map(|(t, role)| ImageStats {
            topic: t.clone(),
            role: *role,
            images: images.count,
            encodings,
            size_px,
            rate_hz: topics::rate_hz(images.count, images.span),
        });
        let colors = match (&options.colors, &image_stats) {
            (Some(file), Some(_)) => {
                let file = std::path::absolute(file).unwrap_or_else(|_| file.clone());
                blob_finder(&file)?;
                Some(file)
            }
            (Some(file), None) => {
                return Err(ImportError::Option(format!(
                    "{}: --colors {}: the bag has no camera (sensor_msgs/Image or CompressedImage) to find blobs in",
                    path.display(),
                    file.display()
                )));
            }
            (None, _) => None,
        };
        let goal = options
            .goal
            .unwrap_or_else(|| farthest.as_ref().map_or((0.0, 0.0), |(_, p)| (p.x, p.y)));
        let sonar = options
            .sonar
            .filter(|_| laser_stats_v.is_some() && second_stats.is_none());
        let distance_span_deg = first_laser
            .as_ref()
            .map_or([-180.0, 180.0], crate::import::span_deg);
        let not_ros2 = topics
            .iter()
            .filter(|t| !t.topic.is_ros2())
            .map(|t| format!("{} ({})", t.topic.name, t.topic.message_encoding))
            .collect();
        let report = ImportReport {
            path: path.to_owned(),
            topics,
            choice,
            laser: laser_stats_v,
            second_laser: second_stats,
            odometry: odometry_stats,
            image: image_stats,
            stamps: converter.stamps,
            sonar,
            distance_sectors: options.distance_sectors,
            distance_span_deg,
            heartbeat_period_ns: options.heartbeat_period_ns,
            goal,
            damage: end.damage,
            not_ros2,
            colors,
        };
        Ok(Self { report })
    }

    /// What the first passes found and decided.
    #[must_use]
    pub fn report(&self) -> &ImportReport {
        &self.report
    }

    /// The sources the import writes heartbeats for.
    fn sources(&self) -> Vec<&'static str> {
        let r = &self.report;
        let mut sources = Vec::new();
        if r.odometry.is_some() {
            sources.push(BASE);
        }
        if r.image.is_some() {
            sources.push(CAMERA);
        }
        if r.laser.is_some() {
            sources.push(LASER);
        }
        if r.second_laser.is_some() {
            sources.push(SECOND_LASER);
        }
        if r.sonar.is_some() {
            sources.push(SONAR);
        }
        sources
    }

    /// Streams the import to `out`, in the bag's file order: each message of the bag kept
    /// as it is, then what the import makes of it (the heartbeats due before it first).
    ///
    /// # Errors
    /// The bag cannot be read again or changed, or `out` failed.
    pub fn stream<E, F>(&self, mut out: F) -> Result<(), E>
    where
        E: From<ImportError>,
        F: FnMut(Out<'_>) -> Result<(), E>,
    {
        let report = &self.report;
        let path = report.path.clone();
        let mut converter = Converter::new(&path, &report.choice);
        let distance = RangeToDistance::from_params(&report.distance_params())
            .map_err(|e| E::from(ImportError::Option(e)))?;
        let mut state = StreamState {
            seq: BTreeMap::new(),
            sources: self.sources(),
            period_ns: report.heartbeat_period_ns.max(1),
            next_heartbeat_ns: None,
            last_pose: None,
            travelled_m: 0.0,
            scans: 0,
        };
        let sonar = report.sonar;
        let mut finder = match &report.colors {
            Some(file) => Some(blob_finder(file).map_err(E::from)?),
            None => None,
        };
        bag::read::<_, E>(&path, |m| {
            if !m.topic.is_ros2() {
                return Ok(());
            }
            let converted = converter.convert(&m).map_err(E::from)?;
            // Checked by the pass before; a bag that now fails changed in between.
            let time_ns = i64::try_from(m.log_time_ns)
                .map_err(|_| E::from(ImportError::Changed { path: path.clone() }))?;
            out(Out::Original(m))?;
            if matches!(converted, Converted::Nothing) {
                return Ok(());
            }
            for heartbeat in state.heartbeats_until(time_ns) {
                out(Out::Lewis(Box::new(heartbeat)))?;
            }
            match converted {
                Converted::Laser(mut laser, _) => {
                    laser.header = state.header(LASER, RangeFinder::NAME, time_ns);
                    let mut d: Distance = distance.distance(&laser);
                    d.header = state.header(DISTANCE, Distance::NAME, time_ns);
                    d.header.inputs = vec![InputRef {
                        channel: data_channel(LASER, RangeFinder::NAME),
                        seq: laser.header.seq,
                    }];
                    let sonar_reading = sonar
                        .filter(|s| {
                            state
                                .scans
                                .is_multiple_of(u64::from(s.every_nth_scan.max(1)))
                        })
                        .map(|s| derived_sonar(&laser, &s));
                    state.scans += 1;
                    out(Out::Lewis(message(
                        LASER,
                        time_ns,
                        Payload::RangeFinder(laser),
                    )))?;
                    out(Out::Lewis(message(DISTANCE, time_ns, Payload::Distance(d))))?;
                    if let Some(mut s) = sonar_reading {
                        s.header = state.header(SONAR, RangeFinder::NAME, time_ns);
                        out(Out::Lewis(message(SONAR, time_ns, Payload::RangeFinder(s))))?;
                    }
                }
                Converted::SecondLaser(mut r, _) => {
                    r.header = state.header(SECOND_LASER, RangeFinder::NAME, time_ns);
                    out(Out::Lewis(message(
                        SECOND_LASER,
                        time_ns,
                        Payload::RangeFinder(r),
                    )))?;
                }
                Converted::Odometry(o) => {
                    if let Some(last) = &state.last_pose {
                        let step = (o.pose.x - last.x).hypot(o.pose.y - last.y);
                        if step.is_finite() {
                            state.travelled_m += step;
                        }
                    }
                    state.last_pose = Some(o.pose.clone());
                    let e = Egomotion {
                        header: state.header(BASE, Egomotion::NAME, time_ns),
                        pose: o.pose,
                        translation_velocity: o.translation_mps,
                        rotation_velocity: o.rotation_radps,
                        distance_travelled: state.travelled_m,
                    };
                    out(Out::Lewis(message(BASE, time_ns, Payload::Egomotion(e))))?;
                }
                Converted::Image(mut i, _) => {
                    i.header = state.header(CAMERA, ImageSource::NAME, time_ns);
                    // What the `blobfinder` service publishes when this image reaches it
                    // (an image it cannot read gives none, as live).
                    let blobs = finder.as_mut().and_then(|f| f.find(&i).ok());
                    let camera_seq = i.header.seq;
                    out(Out::Lewis(message(
                        CAMERA,
                        time_ns,
                        Payload::ImageSource(i),
                    )))?;
                    if let Some(mut blobs) = blobs {
                        blobs.header = state.header(BLOBFINDER, Blobs::NAME, time_ns);
                        blobs.header.inputs = vec![InputRef {
                            channel: data_channel(CAMERA, ImageSource::NAME),
                            seq: camera_seq,
                        }];
                        out(Out::Lewis(message(
                            BLOBFINDER,
                            time_ns,
                            Payload::Blobs(blobs),
                        )))?;
                    }
                }
                Converted::Nothing => {}
            }
            Ok(())
        })?;
        Ok(())
    }
}

/// The blob finder of a colour file, as the `blobfinder` service builds it with its
/// default parameters.
fn blob_finder(file: &Path) -> Result<BlobFinder, ImportError> {
    let bad =
        |reason: String| ImportError::Option(format!("--colors {}: {reason}", file.display()));
    let colors = ColorConfig::load(file).map_err(|e| bad(e.to_string()))?;
    BlobFinder::new(&colors, blobfinder::DEFAULT_MAX_BLOBS_PER_COLOR)
        .map_err(|e| bad(e.to_string()))
}

fn message(provider: &str, time_ns: i64, payload: Payload) -> Box<ImportedMessage> {
    Box::new(ImportedMessage {
        time_ns,
        channel: data_channel(provider, payload.interface()),
        payload,
    })
}

struct StreamState {
    seq: BTreeMap<(&'static str, &'static str), u64>,
    sources: Vec<&'static str>,
    period_ns: i64,
    next_heartbeat_ns: Option<i64>,
    last_pose: Option<Pose2D>,
    travelled_m: f64,
    scans: u64,
}

impl StreamState {
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

    /// The heartbeats of every source due at or before `time_ns`, from the first converted
    /// message on, every period. Times of different topics may interleave out of order by
    /// a little: a heartbeat is never earlier than one before it.
    fn heartbeats_until(&mut self, time_ns: i64) -> Vec<ImportedMessage> {
        let mut out = Vec::new();
        let mut next = *self.next_heartbeat_ns.get_or_insert(time_ns);
        while next <= time_ns {
            for provider in self.sources.clone() {
                let health = Health {
                    header: self.header(provider, Health::NAME, next),
                    state: HealthState::Ok.into(),
                    reason: String::new(),
                };
                out.push(ImportedMessage {
                    time_ns: next,
                    channel: health_channel(provider),
                    payload: Payload::Health(health),
                });
            }
            next = next.saturating_add(self.period_ns);
        }
        self.next_heartbeat_ns = Some(next);
        out
    }
}
