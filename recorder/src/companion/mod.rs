//! Companion channels: ROS 2's standard messages written beside Lewis's own, so that
//! Foxglove's 3D panel (or RViz, through a bag) draws a Lewis recording with no extension.
//! The recorder writes them as it records when [`RecorderOptions::companions`] asks (the
//! live recorder's default), and `lewis export ros2` writes them into a copy of a finished
//! recording; both through [`Companions`], so both write the same messages.
//!
//! The messages are made by `lewis_ros2_map::to_ros2` (the mappings a live ROS 2 gateway
//! shares); this module decides which channels they go on, keeps the state they need (the
//! sensor frames, the broker's bindings) and counts what could not be converted.
//!
//! From each publication of a Lewis interface:
//!
//! - a uniform `RangeFinder` (a laser): `sensor_msgs/msg/LaserScan` on `/<service>/scan`;
//! - a non-uniform one (the sonar ring, each transducer at its own pose):
//!   `sensor_msgs/msg/PointCloud2` on `/<service>/points`, one point per reading where its
//!   beam ends (fields x, y, z, range), the whole ring in one message as a scan is;
//! - `Egomotion`: `nav_msgs/msg/Odometry` on `/<service>/odom`, and its pose as the `odom`
//!   to `base_link` transform on `/tf`;
//! - the sensors' frames (each named after its service) on `/tf_static`, all of them in
//!   every message there (as ROS 2's latched static broadcaster does), written again when a
//!   new sensor appears and at the start of every part: a RangeFinder's frame from the
//!   offsets its messages carry (its driver's mount), a camera's from the `mount` the
//!   robot file gives it (`mount = { x_m, y_m, heading_deg, height_m }`);
//! - `Blobs3D` and `Signs`: `visualization_msgs/msg/MarkerArray` on `/<service>/markers`
//!   (a box per blob in its colour, a board and its word per sign, in `base_link`);
//! - `/lewis/broker`'s bind, rebind and unbind decisions: a MarkerArray on
//!   `/lewis/broker/markers`, the bindings as text above the robot;
//! - with images asked for, `ImageSource` (rgb8, bgr8, mono8) as
//!   `sensor_msgs/msg/CompressedImage` (PNG or JPEG) on `/<service>/image/compressed`.
//!
//! Header stamps are the Lewis messages' publish times (their log times where a publisher
//! left it 0, as the broker did before it stamped its decisions); a companion's publish
//! and log times are its source's. A message that does not decode, or an image of another encoding, gets
//! no companion and is counted ([`Companions::skipped`]); the recording itself never fails
//! for a companion.
//!
//! [`RecorderOptions::companions`]: crate::RecorderOptions::companions

mod mounts;

use std::collections::BTreeMap;

use lewis_interfaces::Struct;
use lewis_interfaces::cdr::{self, Decode, Encode};
use lewis_interfaces::msg::{
    Blobs3D, Broker, BrokerAction, Egomotion, ImageSource, RangeFinder, Signs,
};
use lewis_interfaces::ros2;
use lewis_ros2_map::to_ros2::{self, RangeMessage};

use crate::channel::ChannelSpec;
pub use lewis_ros2_map::to_ros2::{BASE_FRAME, ImageCodec, Mount, ODOM_FRAME};

/// The topic of moving transforms.
pub const TF_TOPIC: &str = "/tf";
/// The topic of fixed transforms.
pub const TF_STATIC_TOPIC: &str = "/tf_static";
/// The topic of the broker's bindings as markers.
pub const BINDINGS_TOPIC: &str = "/lewis/broker/markers";
/// Channel metadata key `kind`'s value on a companion channel.
pub const COMPANION_KIND: &str = "ros2-companion";
/// Channel metadata key naming the Lewis topic a companion channel is made from (absent
/// for `/tf_static`, made from several).
pub const META_SOURCE: &str = "source";
/// The provider named on companion channels.
pub const COMPANION_PROVIDER: &str = "lewis-companion";

/// Which companions to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CompanionOptions {
    /// Images as CompressedImage in this format; `None` leaves them out (a second copy of
    /// every frame would be most of the file).
    pub images: Option<ImageCodec>,
}

/// Whether messages of `schema_name` have a ROS 2 view (ImageSource's only when images
/// are asked for): the schemas [`Companions::convert`] makes companions of.
#[must_use]
pub fn has_view(schema_name: &str) -> bool {
    [
        RangeFinder::SCHEMA_NAME,
        Egomotion::SCHEMA_NAME,
        ImageSource::SCHEMA_NAME,
        Blobs3D::SCHEMA_NAME,
        Signs::SCHEMA_NAME,
        Broker::SCHEMA_NAME,
    ]
    .contains(&schema_name)
}

/// One companion message, ready to write.
#[derive(Debug, Clone, PartialEq)]
pub struct Companion {
    /// Its topic.
    pub topic: String,
    /// Its ROS 2 type (one of [`ros2`]'s constants).
    pub type_name: &'static str,
    /// The Lewis topic it is made from; `None` for `/tf_static`.
    pub source: Option<String>,
    /// Its CDR bytes.
    pub data: Vec<u8>,
}

impl Companion {
    /// The channel it is written on.
    #[must_use]
    pub fn channel_spec(&self) -> ChannelSpec {
        let mut extra = BTreeMap::new();
        extra.insert("kind".to_owned(), COMPANION_KIND.to_owned());
        if let Some(source) = &self.source {
            extra.insert(META_SOURCE.to_owned(), source.clone());
        }
        ChannelSpec {
            topic: self.topic.clone(),
            schema_name: self.type_name.to_owned(),
            // Every type of `ros2` has its text.
            schema_text: ros2::schema_text(self.type_name).unwrap_or_default(),
            provider: COMPANION_PROVIDER.to_owned(),
            interface: self.type_name.to_owned(),
            interface_version: String::new(),
            extra_metadata: extra,
        }
    }
}

/// Why messages of a topic got no companion.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Skipped {
    /// How many.
    pub count: u64,
    /// The first reason.
    pub reason: String,
}

/// Makes the companions of each message (see the module).
#[derive(Debug, Clone)]
pub struct Companions {
    options: CompanionOptions,
    /// The robot file's mounts, by service.
    mounts: BTreeMap<String, Mount>,
    /// The sensor frames written on `/tf_static`, by frame.
    frames: BTreeMap<String, Mount>,
    static_due: bool,
    /// The broker's bindings: (client, interface) to provider.
    bindings: BTreeMap<(String, String), String>,
    skipped: BTreeMap<String, Skipped>,
}

impl Companions {
    /// Companions for a robot whose description is `robot_toml` (its mounts; `None` when
    /// not known yet).
    #[must_use]
    pub fn new(options: CompanionOptions, robot_toml: Option<&str>) -> Self {
        Self {
            options,
            mounts: robot_toml.map(mounts::of_robot).unwrap_or_default(),
            frames: BTreeMap::new(),
            static_due: false,
            bindings: BTreeMap::new(),
            skipped: BTreeMap::new(),
        }
    }

    /// The robot became known (a recording that found its robot later).
    pub fn set_robot(&mut self, robot_toml: &str) {
        self.mounts = mounts::of_robot(robot_toml);
    }

    /// A new part starts: the fixed frames are written again in it.
    pub fn part_started(&mut self) {
        self.static_due = !self.frames.is_empty();
    }

    /// Messages that got no companion, by topic.
    #[must_use]
    pub fn skipped(&self) -> &BTreeMap<String, Skipped> {
        &self.skipped
    }

    /// Appends the companions of the message `data` of `channel` to `out`, their headers
    /// stamped `stamp_ns`.
    pub fn convert(
        &mut self,
        channel: &ChannelSpec,
        data: &[u8],
        stamp_ns: i64,
        out: &mut Vec<Companion>,
    ) {
        let topic = channel.topic.as_str();
        let frame = channel.provider.as_str();
        let source = Some(topic);
        let result = match channel.schema_name.as_str() {
            RangeFinder::SCHEMA_NAME => decode(data).map(|rf: RangeFinder| {
                let mount = Mount::of_range_finder(&rf);
                self.add_frame(frame, mount);
                let header = to_ros2::header(stamp_ns, frame);
                out.push(match to_ros2::range_finder(&rf, &mount, header) {
                    RangeMessage::Scan(scan) => companion(
                        &sibling_topic(topic, "scan"),
                        ros2::LASER_SCAN,
                        source,
                        &scan,
                    ),
                    RangeMessage::Cloud(cloud) => companion(
                        &sibling_topic(topic, "points"),
                        ros2::POINT_CLOUD2,
                        source,
                        &cloud,
                    ),
                });
            }),
            Egomotion::SCHEMA_NAME => decode(data).map(|ego: Egomotion| {
                let (odometry, tf) = to_ros2::egomotion(&ego, stamp_ns);
                out.push(companion(
                    &sibling_topic(topic, "odom"),
                    ros2::ODOMETRY,
                    source,
                    &odometry,
                ));
                out.push(companion(TF_TOPIC, ros2::TF_MESSAGE, source, &tf));
            }),
            ImageSource::SCHEMA_NAME => match self.options.images {
                None => Ok(()),
                Some(codec) => decode(data).and_then(|image: ImageSource| {
                    let header = to_ros2::header(stamp_ns, frame);
                    let compressed = to_ros2::compressed_image(&image, header, codec)?;
                    self.add_frame(frame, self.mounts.get(frame).copied().unwrap_or_default());
                    out.push(companion(
                        &sibling_topic(topic, "image/compressed"),
                        ros2::COMPRESSED_IMAGE,
                        source,
                        &compressed,
                    ));
                    Ok(())
                }),
            },
            Blobs3D::SCHEMA_NAME => decode(data).map(|blobs: Blobs3D| {
                let markers = to_ros2::blob_markers(&blobs, stamp_ns);
                out.push(markers_companion(topic, &markers));
            }),
            Signs::SCHEMA_NAME => decode(data).map(|signs: Signs| {
                let markers = to_ros2::sign_markers(&signs, stamp_ns);
                out.push(markers_companion(topic, &markers));
            }),
            Broker::SCHEMA_NAME => decode(data).map(|decision: Broker| {
                if self.track_binding(&decision) {
                    let markers = to_ros2::binding_markers(&self.bindings, stamp_ns);
                    out.push(companion(
                        &format!("{topic}/markers"),
                        ros2::MARKER_ARRAY,
                        source,
                        &markers,
                    ));
                }
            }),
            _ => Ok(()),
        };
        if let Err(reason) = result {
            let skipped = self.skipped.entry(topic.to_owned()).or_default();
            if skipped.count == 0 {
                skipped.reason = reason;
            }
            skipped.count += 1;
        }
        if self.static_due {
            self.static_due = false;
            // The fixed frames go before the message that needs them.
            out.insert(0, self.tf_static());
        }
    }

    /// Adds a sensor frame; `/tf_static` is written again when it is new or moved.
    fn add_frame(&mut self, frame: &str, mount: Mount) {
        if self.frames.get(frame) != Some(&mount) {
            self.frames.insert(frame.to_owned(), mount);
            self.static_due = true;
        }
    }

    /// Every sensor frame, in `base_link`.
    fn tf_static(&self) -> Companion {
        let frames = self.frames.iter().map(|(frame, m)| (frame.as_str(), m));
        let transforms = to_ros2::static_transforms(frames);
        companion(TF_STATIC_TOPIC, ros2::TF_MESSAGE, None, &transforms)
    }

    /// Follows the bindings; whether they changed.
    fn track_binding(&mut self, decision: &Broker) -> bool {
        let key = (decision.client.clone(), decision.interface.clone());
        match BrokerAction::parse(&decision.action) {
            Some(BrokerAction::Bind) => {
                self.bindings.insert(key, decision.service.clone());
            }
            Some(BrokerAction::Rebind) => {
                self.bindings.insert(key, decision.to_service.clone());
            }
            Some(BrokerAction::Unbind) => {
                self.bindings.remove(&key);
            }
            _ => return false,
        }
        true
    }
}

fn decode<T: Decode>(data: &[u8]) -> Result<T, String> {
    cdr::from_bytes(data).map_err(|e| format!("does not decode: {e}"))
}

/// A companion of `message` on `topic`.
fn companion<T: Encode>(
    topic: &str,
    type_name: &'static str,
    source: Option<&str>,
    message: &T,
) -> Companion {
    Companion {
        topic: topic.to_owned(),
        type_name,
        source: source.map(str::to_owned),
        data: cdr::to_vec(message),
    }
}

/// A MarkerArray made from `topic`, on its sibling `markers`.
fn markers_companion(topic: &str, markers: &ros2::MarkerArray) -> Companion {
    companion(
        &sibling_topic(topic, "markers"),
        ros2::MARKER_ARRAY,
        Some(topic),
        markers,
    )
}

/// `/laser/RangeFinder` to `/laser/<leaf>`.
fn sibling_topic(topic: &str, leaf: &str) -> String {
    match topic.rsplit_once('/') {
        Some((prefix, _)) if !prefix.is_empty() => format!("{prefix}/{leaf}"),
        _ => format!("/{leaf}"),
    }
}

#[cfg(test)]
mod tests;
