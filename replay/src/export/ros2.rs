//! `lewis export ros2 RUN.mcap -o OUT.mcap`: a Lewis recording copied, every channel and
//! message unchanged, with companion channels of ROS 2's standard types beside them, so
//! that Foxglove's 3D panel (or RViz, through a bag) draws the scans and the robot:
//!
//! - each uniform RangeFinder (a laser) as `sensor_msgs/msg/LaserScan` on `/<service>/scan`;
//! - each non-uniform one (the sonar ring, whose transducers sit at their own poses) as
//!   one `sensor_msgs/msg/PointCloud2` per reading on `/<service>/points`: one message
//!   holds the whole ring, in one frame, as the laser's scan does (48 `Range` topics with
//!   48 frames would be drawn as cones but said nothing more);
//! - each Egomotion as `nav_msgs/msg/Odometry` on `/<service>/odom` and its pose as the
//!   `odom` to `base_link` transform on `/tf`;
//! - the sensors' frames on `/tf_static` (`base_link` to `<service>`), from the mount of
//!   the service in the robot file where it gives one (`mount = { x_m, y_m, heading_deg,
//!   height_m }`), otherwise from the offsets the RangeFinder carries (its driver's mount);
//! - with `images`, each ImageSource (rgb8 or mono8) as `sensor_msgs/msg/CompressedImage`
//!   (PNG or JPEG) on `/<service>/image/compressed`.
//!
//! Header stamps are the Lewis messages' publish times; the companion's log time is its
//! source's. The file is written through the recorder to a temporary file beside the
//! output and renamed once complete.

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use image::{DynamicImage, ImageFormat, RgbImage};
use lewis_interfaces::cdr::{self, Encode};
use lewis_interfaces::msg::{Egomotion, ImageSource, RangeFinder};
use lewis_recorder::{ChannelId, ChannelSpec, RecordError, Recorder, RecorderOptions, Sample};
use lewis_runtime::robot::Robot;

use crate::import::record::temporary_path;
use crate::recording::{Recording, RecordingError, Topic};
use crate::ros2msg::{
    self, CompressedImage, Header, LaserScan, Odometry, PointCloud, Pose, TfMessage,
    TransformStamped,
};

/// The odometry frame.
pub const ODOM_FRAME: &str = "odom";
/// The robot's frame.
pub const BASE_FRAME: &str = "base_link";
/// The topic of moving transforms.
pub const TF_TOPIC: &str = "/tf";
/// The topic of fixed transforms.
pub const TF_STATIC_TOPIC: &str = "/tf_static";
/// The provider of the companion channels (their metadata).
pub const EXPORT_PROVIDER: &str = "lewis-export";

/// How images are compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageCodec {
    /// Lossless.
    Png,
    /// Lossy, smaller.
    Jpeg,
}

impl ImageCodec {
    fn name(self) -> &'static str {
        match self {
            Self::Png => "png",
            Self::Jpeg => "jpeg",
        }
    }
}

/// What to export.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExportOptions {
    /// Images as CompressedImage in this format; `None` leaves them out.
    pub images: Option<ImageCodec>,
}

/// Why an export failed.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The input is not a readable Lewis recording.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// The recorder refused.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// The output exists.
    #[error("{} exists: give another -o, or remove it first", path.display())]
    Exists {
        /// The output.
        path: PathBuf,
    },
    /// A message of the recording does not decode as its interface says.
    #[error("{topic}: message {index} does not decode as {interface}: {reason}")]
    Decode {
        /// Its topic.
        topic: String,
        /// Its index on the topic, from 0.
        index: u64,
        /// Its interface.
        interface: String,
        /// What is wrong.
        reason: String,
    },
    /// An image could not be compressed.
    #[error("{topic}: image {index}: {reason}")]
    Image {
        /// Its topic.
        topic: String,
        /// Its index on the topic, from 0.
        index: u64,
        /// What is wrong.
        reason: String,
    },
    /// The finished file could not be moved to its name.
    #[error("cannot rename {} to {}: {source}", from.display(), to.display())]
    Rename {
        /// The temporary file.
        from: PathBuf,
        /// The output.
        to: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// What was written.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ExportReport {
    /// Messages copied from the recording.
    pub copied: u64,
    /// Channels copied.
    pub copied_channels: usize,
    /// Messages written per companion topic, with its type.
    pub companions: BTreeMap<String, (String, u64)>,
    /// Images left out (no `images` option), per topic.
    pub images_skipped: BTreeMap<String, u64>,
    /// ImageSource messages of an encoding that is not exported, per topic.
    pub images_unsupported: BTreeMap<String, u64>,
}

/// A sensor frame: where `base_link` to it comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Mount {
    x: f64,
    y: f64,
    z: f64,
    yaw: f64,
}

/// The mount the robot file gives service `name`, if any.
fn robot_mount(robot: &Robot, name: &str) -> Option<Mount> {
    let mount = robot.service(name)?.parameters.get("mount")?;
    let get = |key: &str| {
        mount
            .get(key)
            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
    };
    Some(Mount {
        x: get("x_m").unwrap_or(0.0),
        y: get("y_m").unwrap_or(0.0),
        z: get("height_m").unwrap_or(0.0),
        yaw: get("heading_deg").unwrap_or(0.0).to_radians(),
    })
}

/// The sensor's frame: the provider (its service's name) or the topic's first segment.
fn frame_of(topic: &Topic) -> String {
    topic.provider.clone().unwrap_or_else(|| {
        topic
            .name
            .trim_start_matches('/')
            .split('/')
            .next()
            .unwrap_or("sensor")
            .to_owned()
    })
}

/// `/laser/RangeFinder` to `/laser/<leaf>`.
fn companion_topic(topic: &str, leaf: &str) -> String {
    match topic.rsplit_once('/') {
        Some((prefix, _)) if !prefix.is_empty() => format!("{prefix}/{leaf}"),
        _ => format!("/{leaf}"),
    }
}

struct Writer {
    recorder: Recorder,
    channels: BTreeMap<String, ChannelId>,
    seqs: BTreeMap<String, u64>,
    buffer: Vec<u8>,
    report: ExportReport,
}

impl Writer {
    fn write_companion<T: Encode>(
        &mut self,
        topic: &str,
        type_name: &str,
        message: &T,
        time_ns: i64,
    ) -> Result<(), ExportError> {
        let channel = match self.channels.get(topic) {
            Some(id) => *id,
            None => {
                let mut extra = BTreeMap::new();
                extra.insert("kind".to_owned(), "ros2-companion".to_owned());
                let id = self.recorder.add_channel(ChannelSpec {
                    topic: topic.to_owned(),
                    schema_name: type_name.to_owned(),
                    // The types are this module's constants, each with a text.
                    schema_text: ros2msg::schema_text(type_name).unwrap_or_default(),
                    provider: EXPORT_PROVIDER.to_owned(),
                    interface: type_name.to_owned(),
                    interface_version: String::new(),
                    extra_metadata: extra,
                })?;
                self.channels.insert(topic.to_owned(), id);
                id
            }
        };
        cdr::encode_to_vec(message, &mut self.buffer);
        let seq = self.seqs.entry(topic.to_owned()).or_default();
        *seq += 1;
        self.recorder.write(&Sample {
            channel,
            seq: *seq,
            publish_time_ns: time_ns,
            log_time_ns: time_ns,
            data: &self.buffer,
        })?;
        self.report
            .companions
            .entry(topic.to_owned())
            .or_insert_with(|| (type_name.to_owned(), 0))
            .1 += 1;
        Ok(())
    }
}

/// Exports the recording `input` to `output` with companion channels (see the module).
///
/// # Errors
/// The input is not a complete Lewis recording, a message does not decode, the output
/// exists, or the recorder refuses. Nothing is left under `output` on failure.
pub fn export(
    input: &Path,
    output: &Path,
    options: &ExportOptions,
) -> Result<ExportReport, ExportError> {
    if output.exists() {
        return Err(ExportError::Exists {
            path: output.to_owned(),
        });
    }
    let recording = Recording::open(&[input.to_owned()])?;
    let temporary = temporary_path(output);
    // A temporary file left by an export that was killed is ours to replace.
    let _ = std::fs::remove_file(&temporary);
    let result = export_to(&recording, &temporary, options);
    let report = match result {
        Ok(report) => report,
        Err(e) => {
            let _ = std::fs::remove_file(&temporary);
            return Err(e);
        }
    };
    if let Err(source) = std::fs::rename(&temporary, output) {
        let _ = std::fs::remove_file(&temporary);
        return Err(ExportError::Rename {
            from: temporary,
            to: output.to_owned(),
            source,
        });
    }
    Ok(report)
}

fn decode<T: cdr::Decode>(
    topic: &str,
    index: u64,
    interface: &str,
    data: &[u8],
) -> Result<T, ExportError> {
    cdr::from_bytes(data).map_err(|e| ExportError::Decode {
        topic: topic.to_owned(),
        index,
        interface: interface.to_owned(),
        reason: e.to_string(),
    })
}

fn export_to(
    recording: &Recording,
    path: &Path,
    options: &ExportOptions,
) -> Result<ExportReport, ExportError> {
    let (file_name, toml) = recording.robot_toml();
    let mut recorder_options = RecorderOptions::new(path);
    recorder_options.sync_on_flush = false;
    recorder_options.robot_description = Some(lewis_recorder::RobotDescription {
        file_name: file_name.to_owned(),
        toml: toml.to_owned(),
    });
    EXPORT_PROVIDER.clone_into(&mut recorder_options.recorder_name);
    let recorder = Recorder::create(recorder_options)?;
    let mut writer = Writer {
        recorder,
        channels: BTreeMap::new(),
        seqs: BTreeMap::new(),
        buffer: Vec::new(),
        report: ExportReport::default(),
    };
    let robot = recording.robot();
    let interface_of = |topic: &Topic| topic.interface.clone().unwrap_or_default();
    // The sensors' frames: from the robot file's mounts, else from each RangeFinder's first
    // message (its offsets), else at the robot's centre.
    let mut mounts: BTreeMap<Arc<str>, (String, Mount)> = BTreeMap::new();
    for topic in recording.topics().values() {
        let interface = interface_of(topic);
        if interface != "RangeFinder" && interface != "ImageSource" {
            continue;
        }
        let frame = frame_of(topic);
        let mount = match robot_mount(robot, &frame) {
            Some(mount) => mount,
            None if interface == "RangeFinder" => {
                let first = recording.messages_on(&[&topic.name])?.next().transpose()?;
                match first {
                    Some(m) => {
                        let rf: RangeFinder = decode(&topic.name, 0, &interface, &m.data)?;
                        Mount {
                            x: rf.x_offset,
                            y: rf.y_offset,
                            z: rf.z_offset,
                            yaw: 0.0,
                        }
                    }
                    None => continue,
                }
            }
            None => Mount {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                yaw: 0.0,
            },
        };
        mounts.insert(topic.name.clone(), (frame, mount));
    }
    let start_ns = recording.start_ns();
    let mut frames: Vec<(&String, &Mount)> = mounts.values().map(|(f, m)| (f, m)).collect();
    frames.sort_by(|a, b| a.0.cmp(b.0));
    frames.dedup_by(|a, b| a.0 == b.0);
    if !frames.is_empty() {
        let tf = TfMessage {
            transforms: frames
                .iter()
                .map(|(frame, m)| TransformStamped {
                    header: Header {
                        stamp_ns: start_ns,
                        frame_id: BASE_FRAME.to_owned(),
                    },
                    child_frame_id: (*frame).clone(),
                    transform: Pose::planar(m.x, m.y, m.z, m.yaw),
                })
                .collect(),
        };
        writer.write_companion(TF_STATIC_TOPIC, ros2msg::TF_MESSAGE, &tf, start_ns)?;
    }
    let mut copied: BTreeMap<Arc<str>, (ChannelId, u64)> = BTreeMap::new();
    for message in recording.messages()? {
        let message = message?;
        let Some(topic) = recording.topics().get(&message.topic) else {
            continue;
        };
        let (channel, index) = match copied.get_mut(&message.topic) {
            Some(entry) => {
                entry.1 += 1;
                *entry
            }
            None => {
                let id = writer.recorder.add_channel(original_spec(topic))?;
                copied.insert(message.topic.clone(), (id, 0));
                (id, 0)
            }
        };
        writer.recorder.write(&Sample {
            channel,
            seq: message.seq,
            publish_time_ns: message.publish_time_ns,
            log_time_ns: message.log_time_ns,
            data: &message.data,
        })?;
        writer.report.copied += 1;
        let interface = interface_of(topic);
        let time = message.log_time_ns;
        match interface.as_str() {
            "RangeFinder" => {
                let rf: RangeFinder = decode(&topic.name, index, &interface, &message.data)?;
                let (frame, mount) = mounts
                    .get(&message.topic)
                    .cloned()
                    .unwrap_or_else(|| (frame_of(topic), Mount { x: 0.0, y: 0.0, z: 0.0, yaw: 0.0 }));
                let header = Header {
                    stamp_ns: rf.header.publish_time_ns,
                    frame_id: frame,
                };
                if rf.uniform {
                    let scan = laser_scan(&rf, &mount, header);
                    let name = companion_topic(&topic.name, "scan");
                    writer.write_companion(&name, ros2msg::LASER_SCAN, &scan, time)?;
                } else {
                    let cloud = point_cloud(&rf, &mount, header);
                    let name = companion_topic(&topic.name, "points");
                    writer.write_companion(&name, ros2msg::POINT_CLOUD2, &cloud, time)?;
                }
            }
            "Egomotion" => {
                let ego: Egomotion = decode(&topic.name, index, &interface, &message.data)?;
                let stamp = ego.header.publish_time_ns;
                let pose = Pose::planar(ego.pose.x, ego.pose.y, 0.0, ego.pose.theta);
                let odometry = Odometry {
                    header: Header {
                        stamp_ns: stamp,
                        frame_id: ODOM_FRAME.to_owned(),
                    },
                    child_frame_id: BASE_FRAME.to_owned(),
                    pose,
                    linear: [ego.translation_velocity, 0.0, 0.0],
                    angular: [0.0, 0.0, ego.rotation_velocity],
                };
                let name = companion_topic(&topic.name, "odom");
                writer.write_companion(&name, ros2msg::ODOMETRY, &odometry, time)?;
                let tf = TfMessage {
                    transforms: vec![TransformStamped {
                        header: odometry.header.clone(),
                        child_frame_id: BASE_FRAME.to_owned(),
                        transform: pose,
                    }],
                };
                writer.write_companion(TF_TOPIC, ros2msg::TF_MESSAGE, &tf, time)?;
            }
            "ImageSource" => {
                let Some(codec) = options.images else {
                    *writer
                        .report
                        .images_skipped
                        .entry(topic.name.to_string())
                        .or_default() += 1;
                    continue;
                };
                let image: ImageSource = decode(&topic.name, index, &interface, &message.data)?;
                let Some(data) = compress(&image, codec).map_err(|reason| ExportError::Image {
                    topic: topic.name.to_string(),
                    index,
                    reason,
                })?
                else {
                    *writer
                        .report
                        .images_unsupported
                        .entry(topic.name.to_string())
                        .or_default() += 1;
                    continue;
                };
                let frame = mounts
                    .get(&message.topic)
                    .map_or_else(|| frame_of(topic), |(f, _)| f.clone());
                let compressed = CompressedImage {
                    header: Header {
                        stamp_ns: image.header.publish_time_ns,
                        frame_id: frame,
                    },
                    format: codec.name().to_owned(),
                    data,
                };
                let name = companion_topic(&topic.name, "image/compressed");
                writer.write_companion(&name, ros2msg::COMPRESSED_IMAGE, &compressed, time)?;
            }
            _ => {}
        }
    }
    writer.report.copied_channels = copied.len();
    writer.recorder.close()?;
    Ok(writer.report)
}

/// The channel of a recording's topic, as it was (schema, provider, interface, metadata).
fn original_spec(topic: &Topic) -> ChannelSpec {
    ChannelSpec {
        topic: topic.name.to_string(),
        schema_name: topic.schema_name.clone(),
        schema_text: topic.schema_text.clone(),
        provider: topic.provider.clone().unwrap_or_default(),
        interface: topic.interface.clone().unwrap_or_default(),
        interface_version: topic.interface_version.clone().unwrap_or_default(),
        extra_metadata: topic.metadata.clone(),
    }
}

/// A uniform RangeFinder as a LaserScan in its sensor's frame: the bearings are the
/// robot's (`theta_offset`) less the frame's heading.
fn laser_scan(rf: &RangeFinder, mount: &Mount, header: Header) -> LaserScan {
    let count = rf.ranges.len();
    let angle_min = rf.theta_offset - mount.yaw;
    let angle_max = angle_min + rf.theta_separation * count.saturating_sub(1) as f64;
    LaserScan {
        header,
        angle_min: angle_min as f32,
        angle_max: angle_max as f32,
        angle_increment: rf.theta_separation as f32,
        time_increment: 0.0,
        scan_time: 0.0,
        range_min: 0.0,
        range_max: rf.max_range as f32,
        ranges: rf.ranges.iter().map(|&r| r as f32).collect(),
        intensities: Vec::new(),
    }
}

/// A non-uniform RangeFinder as one point per reading, where its beam ends, in the
/// sensor's frame: fields x, y, z and the reading itself (`range`).
fn point_cloud(rf: &RangeFinder, mount: &Mount, header: Header) -> PointCloud {
    let (sin, cos) = (-mount.yaw).sin_cos();
    let mut values = Vec::with_capacity(rf.ranges.len() * 4);
    for (range, at) in rf.ranges.iter().zip(&rf.sensor_positions) {
        // In the robot's frame, then moved into the sensor's.
        let bx = at.x + range * at.theta.cos() - mount.x;
        let by = at.y + range * at.theta.sin() - mount.y;
        let x = cos * bx - sin * by;
        let y = sin * bx + cos * by;
        values.extend([x as f32, y as f32, (at.z - mount.z) as f32, *range as f32]);
    }
    PointCloud {
        header,
        fields: vec!["x", "y", "z", "range"],
        values,
    }
}

/// An rgb8 or mono8 image compressed; `None` for another encoding.
fn compress(image: &ImageSource, codec: ImageCodec) -> Result<Option<Vec<u8>>, String> {
    let (width, height) = (
        u32::try_from(image.width).map_err(|_| format!("width {}", image.width))?,
        u32::try_from(image.height).map_err(|_| format!("height {}", image.height))?,
    );
    let step = usize::try_from(image.step).map_err(|_| format!("step {}", image.step))?;
    let channels = match image.encoding.as_str() {
        "rgb8" => 3,
        "mono8" => 1,
        _ => return Ok(None),
    };
    let row = width as usize * channels;
    if step < row || image.data.len() < step * height as usize {
        return Err(format!(
            "{}x{} {} with step {} needs {} bytes, it has {}",
            width,
            height,
            image.encoding,
            step,
            step * height as usize,
            image.data.len()
        ));
    }
    let mut pixels = Vec::with_capacity(row * height as usize);
    for y in 0..height as usize {
        pixels.extend_from_slice(&image.data[y * step..y * step + row]);
    }
    let picture = if channels == 3 {
        DynamicImage::ImageRgb8(
            RgbImage::from_raw(width, height, pixels).ok_or("pixels do not fit the size")?,
        )
    } else {
        DynamicImage::ImageLuma8(
            image::GrayImage::from_raw(width, height, pixels)
                .ok_or("pixels do not fit the size")?,
        )
    };
    let format = match codec {
        ImageCodec::Png => ImageFormat::Png,
        ImageCodec::Jpeg => ImageFormat::Jpeg,
    };
    let mut out = Cursor::new(Vec::new());
    picture
        .write_to(&mut out, format)
        .map_err(|e| e.to_string())?;
    Ok(Some(out.into_inner()))
}
