//! ROS 2's standard messages as Rust values that encode to ROS 2 CDR ([`Twist`] decodes
//! too).

use crate::cdr::{Decode, DecodeError, Encode, Reader, Sink};

use super::quaternion_from_yaw;

/// `std_msgs/Header`.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// The stamp, in ns since the epoch (negative times are written as ROS 2 does: a
    /// negative `sec` and a positive `nanosec`).
    pub stamp_ns: i64,
    /// The tf frame.
    pub frame_id: String,
}

impl Encode for Header {
    fn encode<S: Sink>(&self, sink: &mut S) {
        let sec = self.stamp_ns.div_euclid(1_000_000_000);
        let nanosec = self.stamp_ns.rem_euclid(1_000_000_000);
        // Stamps past 2038 do not fit ROS 2's int32 seconds: saturated, not wrapped.
        i32::try_from(sec)
            .unwrap_or(if sec < 0 { i32::MIN } else { i32::MAX })
            .encode(sink);
        // In [0, 1e9): fits.
        (nanosec as u32).encode(sink);
        self.frame_id.encode(sink);
    }
}

/// `sensor_msgs/msg/LaserScan`.
#[derive(Debug, Clone, PartialEq)]
pub struct LaserScan {
    /// Stamp and frame.
    pub header: Header,
    /// Bearing of the first beam, in rad.
    pub angle_min: f32,
    /// Bearing of the last beam, in rad.
    pub angle_max: f32,
    /// Angle between beams, in rad.
    pub angle_increment: f32,
    /// Time between beams, in s.
    pub time_increment: f32,
    /// Time between scans, in s.
    pub scan_time: f32,
    /// Shortest valid reading, in m.
    pub range_min: f32,
    /// Longest valid reading, in m.
    pub range_max: f32,
    /// The readings, in m.
    pub ranges: Vec<f32>,
    /// Intensities (none).
    pub intensities: Vec<f32>,
}

impl Encode for LaserScan {
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.header.encode(sink);
        for x in [
            self.angle_min,
            self.angle_max,
            self.angle_increment,
            self.time_increment,
            self.scan_time,
            self.range_min,
            self.range_max,
        ] {
            x.encode(sink);
        }
        self.ranges.encode(sink);
        self.intensities.encode(sink);
    }
}

/// A planar pose as `geometry_msgs/Pose` (or a `Transform`: the same bytes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Position (or translation), in m.
    pub position: [f64; 3],
    /// Orientation `(x, y, z, w)`.
    pub orientation: [f64; 4],
}

impl Pose {
    /// At `(x, y, z)`, turned `yaw` rad about z.
    #[must_use]
    pub fn planar(x: f64, y: f64, z: f64, yaw: f64) -> Self {
        Self {
            position: [x, y, z],
            orientation: quaternion_from_yaw(yaw),
        }
    }
}

impl Encode for Pose {
    fn encode<S: Sink>(&self, sink: &mut S) {
        for x in self.position.iter().chain(&self.orientation) {
            x.encode(sink);
        }
    }
}

/// `nav_msgs/msg/Odometry`.
#[derive(Debug, Clone, PartialEq)]
pub struct Odometry {
    /// Stamp and the odometry frame.
    pub header: Header,
    /// The robot's frame.
    pub child_frame_id: String,
    /// The pose in the odometry frame (covariance unknown: zeros).
    pub pose: Pose,
    /// Linear velocity in the robot's frame, in m/s.
    pub linear: [f64; 3],
    /// Angular velocity, in rad/s.
    pub angular: [f64; 3],
}

impl Encode for Odometry {
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.header.encode(sink);
        self.child_frame_id.encode(sink);
        self.pose.encode(sink);
        for _ in 0..36 {
            0.0f64.encode(sink);
        }
        for x in self.linear.iter().chain(&self.angular) {
            x.encode(sink);
        }
        for _ in 0..36 {
            0.0f64.encode(sink);
        }
    }
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Debug, Clone, PartialEq)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child frame's pose in the parent's.
    pub transform: Pose,
}

impl Encode for TransformStamped {
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.header.encode(sink);
        self.child_frame_id.encode(sink);
        self.transform.encode(sink);
    }
}

/// `tf2_msgs/msg/TFMessage`.
#[derive(Debug, Clone, PartialEq)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

impl Encode for TfMessage {
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.transforms.encode(sink);
    }
}

/// `sensor_msgs/msg/PointCloud2` of points with float32 fields (`x`, `y`, `z`, ...),
/// little-endian, one row.
#[derive(Debug, Clone, PartialEq)]
pub struct PointCloud {
    /// Stamp and frame.
    pub header: Header,
    /// The field names, each a float32, in this order in every point.
    pub fields: Vec<&'static str>,
    /// The points, `fields.len()` values each.
    pub values: Vec<f32>,
}

/// `sensor_msgs/PointField`'s FLOAT32.
const FLOAT32: u8 = 7;

impl Encode for PointCloud {
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.header.encode(sink);
        let step = 4 * self.fields.len();
        let width = self
            .values
            .len()
            .checked_div(self.fields.len())
            .unwrap_or(0);
        let as_u32 = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
        1u32.encode(sink);
        as_u32(width).encode(sink);
        as_u32(self.fields.len()).encode(sink);
        for (i, name) in self.fields.iter().enumerate() {
            name.encode(sink);
            as_u32(4 * i).encode(sink);
            FLOAT32.encode(sink);
            1u32.encode(sink);
        }
        false.encode(sink);
        as_u32(step).encode(sink);
        as_u32(step * width).encode(sink);
        let data: Vec<u8> = self.values.iter().flat_map(|v| v.to_le_bytes()).collect();
        data.encode(sink);
        true.encode(sink);
    }
}

/// `sensor_msgs/msg/CompressedImage`.
#[derive(Debug, Clone, PartialEq)]
pub struct CompressedImage {
    /// Stamp and the camera's frame.
    pub header: Header,
    /// `png` or `jpeg`.
    pub format: String,
    /// The compressed image.
    pub data: Vec<u8>,
}

impl Encode for CompressedImage {
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.header.encode(sink);
        self.format.encode(sink);
        self.data.encode(sink);
    }
}

/// `std_msgs/ColorRGBA`, each in `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Color {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

impl Encode for Color {
    fn encode<S: Sink>(&self, sink: &mut S) {
        for x in [self.r, self.g, self.b, self.a] {
            x.encode(sink);
        }
    }
}

/// The shape of a [`Marker`] (`visualization_msgs/msg/Marker`'s `type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MarkerKind {
    /// A box.
    Cube = 1,
    /// A ball.
    Sphere = 2,
    /// Text that always faces the viewer.
    Text = 9,
}

/// `visualization_msgs/msg/Marker`, the parts Lewis uses: a shape added (or, with
/// `delete_all`, every marker of the topic removed), lasting until replaced.
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// Stamp and the frame the pose is in.
    pub header: Header,
    /// The namespace (with `id`, what a later marker replaces).
    pub ns: String,
    /// The marker's number in its namespace.
    pub id: i32,
    /// Its shape.
    pub kind: MarkerKind,
    /// Whether this marker removes every earlier one instead (`DELETEALL`).
    pub delete_all: bool,
    /// Where it is.
    pub pose: Pose,
    /// Its size in m (for text, `z` is the letters' height).
    pub scale: [f64; 3],
    /// Its colour.
    pub color: Color,
    /// The text of a [`MarkerKind::Text`].
    pub text: String,
}

/// `Marker`'s `action`: ADD and DELETEALL.
const ADD: i32 = 0;
const DELETE_ALL: i32 = 3;

impl Encode for Marker {
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.header.encode(sink);
        self.ns.encode(sink);
        self.id.encode(sink);
        (self.kind as i32).encode(sink);
        (if self.delete_all { DELETE_ALL } else { ADD }).encode(sink);
        self.pose.encode(sink);
        for x in self.scale {
            x.encode(sink);
        }
        self.color.encode(sink);
        // lifetime 0: until replaced.
        0i32.encode(sink);
        0u32.encode(sink);
        // frame_locked, points, colors.
        false.encode(sink);
        0u32.encode(sink);
        0u32.encode(sink);
        self.text.encode(sink);
        // mesh_resource, mesh_use_embedded_materials.
        "".encode(sink);
        false.encode(sink);
    }
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Debug, Clone, PartialEq)]
pub struct MarkerArray {
    /// The markers, in order.
    pub markers: Vec<Marker>,
}

impl Encode for MarkerArray {
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.markers.encode(sink);
    }
}

/// `geometry_msgs/msg/Twist`: a velocity, as a ROS 2 base takes it on `/cmd_vel`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Twist {
    /// Linear velocity `(x, y, z)` in the robot's frame (x forward), in m/s.
    pub linear: [f64; 3],
    /// Angular velocity about `(x, y, z)`, in rad/s (z: turning left).
    pub angular: [f64; 3],
}

impl Encode for Twist {
    fn encode<S: Sink>(&self, sink: &mut S) {
        for x in self.linear.iter().chain(&self.angular) {
            x.encode(sink);
        }
    }
}

impl Decode for Twist {
    const MIN_LEN: usize = 6 * size_of::<f64>();

    fn decode(reader: &mut Reader<'_>) -> Result<Self, DecodeError> {
        let mut vector = |name: &'static str| -> Result<[f64; 3], DecodeError> {
            let mut xyz = [0.0; 3];
            for x in &mut xyz {
                *x = reader.field(name)?;
            }
            Ok(xyz)
        };
        Ok(Self {
            linear: vector("linear")?,
            angular: vector("angular")?,
        })
    }
}
