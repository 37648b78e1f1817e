//! ROS 2's standard messages that Lewis writes (`lewis export ros2`): their type names,
//! their ros2msg schema texts as rosbag2 stores them (the message's .msg fields, then each
//! type it uses, depth-first in order of first use, after a line of 80 `=` and a
//! `MSG: package/Type` line), and their CDR encoding through `lewis_interfaces::cdr`.
//!
//! The texts are the ROS 2 (Humble to Jazzy) definitions with their comments left out:
//! the fields, types and order are what decoders read. Reading bags goes through the
//! schema-driven decoder (`lewis_interfaces::dynamic`) with the bag's own texts, so the
//! import side needs no text of its own; both sides share the type names and the
//! quaternion conventions here.

use lewis_interfaces::cdr::{Encode, Sink};

/// `sensor_msgs/msg/LaserScan`.
pub const LASER_SCAN: &str = "sensor_msgs/msg/LaserScan";
/// `nav_msgs/msg/Odometry`.
pub const ODOMETRY: &str = "nav_msgs/msg/Odometry";
/// `tf2_msgs/msg/TFMessage`.
pub const TF_MESSAGE: &str = "tf2_msgs/msg/TFMessage";
/// `sensor_msgs/msg/PointCloud2`.
pub const POINT_CLOUD2: &str = "sensor_msgs/msg/PointCloud2";
/// `sensor_msgs/msg/CompressedImage`.
pub const COMPRESSED_IMAGE: &str = "sensor_msgs/msg/CompressedImage";

const TIME: &str = "int32 sec\nuint32 nanosec\n";
const HEADER: &str = "builtin_interfaces/Time stamp\nstring frame_id\n";
const POINT: &str = "float64 x\nfloat64 y\nfloat64 z\n";
const QUATERNION: &str = "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const VECTOR3: &str = "float64 x\nfloat64 y\nfloat64 z\n";
const POSE: &str = "Point position\nQuaternion orientation\n";
const POSE_WITH_COVARIANCE: &str = "Pose pose\nfloat64[36] covariance\n";
const TWIST: &str = "Vector3  linear\nVector3  angular\n";
const TWIST_WITH_COVARIANCE: &str = "Twist twist\nfloat64[36] covariance\n";
const TRANSFORM: &str = "Vector3 translation\nQuaternion rotation\n";
const TRANSFORM_STAMPED: &str =
    "std_msgs/Header header\nstring child_frame_id\nTransform transform\n";
const POINT_FIELD: &str = "uint8 INT8    = 1\nuint8 UINT8   = 2\nuint8 INT16   = 3\n\
    uint8 UINT16  = 4\nuint8 INT32   = 5\nuint8 UINT32  = 6\nuint8 FLOAT32 = 7\n\
    uint8 FLOAT64 = 8\nstring name\nuint32 offset\nuint8  datatype\nuint32 count\n";

/// The main text and the `(package/Type, text)` of each dependency, in rosbag2's order.
fn parts(type_name: &str) -> Option<(&'static str, Vec<(&'static str, &'static str)>)> {
    let header = [
        ("std_msgs/Header", HEADER),
        ("builtin_interfaces/Time", TIME),
    ];
    Some(match type_name {
        LASER_SCAN => (
            "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\n\
             float32 angle_increment\nfloat32 time_increment\nfloat32 scan_time\n\
             float32 range_min\nfloat32 range_max\nfloat32[] ranges\nfloat32[] intensities\n",
            header.to_vec(),
        ),
        ODOMETRY => (
            "std_msgs/Header header\nstring child_frame_id\n\
             geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
            [
                &header[..],
                &[
                    ("geometry_msgs/PoseWithCovariance", POSE_WITH_COVARIANCE),
                    ("geometry_msgs/Pose", POSE),
                    ("geometry_msgs/Point", POINT),
                    ("geometry_msgs/Quaternion", QUATERNION),
                    ("geometry_msgs/TwistWithCovariance", TWIST_WITH_COVARIANCE),
                    ("geometry_msgs/Twist", TWIST),
                    ("geometry_msgs/Vector3", VECTOR3),
                ],
            ]
            .concat(),
        ),
        TF_MESSAGE => (
            "geometry_msgs/TransformStamped[] transforms\n",
            vec![
                ("geometry_msgs/TransformStamped", TRANSFORM_STAMPED),
                ("std_msgs/Header", HEADER),
                ("builtin_interfaces/Time", TIME),
                ("geometry_msgs/Transform", TRANSFORM),
                ("geometry_msgs/Vector3", VECTOR3),
                ("geometry_msgs/Quaternion", QUATERNION),
            ],
        ),
        POINT_CLOUD2 => (
            "std_msgs/Header header\nuint32 height\nuint32 width\nPointField[] fields\n\
             bool    is_bigendian\nuint32  point_step\nuint32  row_step\nuint8[] data\n\
             bool is_dense\n",
            [&header[..], &[("sensor_msgs/PointField", POINT_FIELD)]].concat(),
        ),
        COMPRESSED_IMAGE => (
            "std_msgs/Header header\nstring format\nuint8[] data\n",
            header.to_vec(),
        ),
        _ => return None,
    })
}

/// The ros2msg schema text of `type_name` (one of the constants of this module), as
/// rosbag2 writes it into MCAP; `None` for another type.
#[must_use]
pub fn schema_text(type_name: &str) -> Option<String> {
    let (main, dependencies) = parts(type_name)?;
    let mut text = main.to_owned();
    for (name, body) in dependencies {
        text.push_str(&"=".repeat(80));
        text.push('\n');
        text.push_str("MSG: ");
        text.push_str(name);
        text.push('\n');
        text.push_str(body);
    }
    Some(text)
}

/// The quaternion `(x, y, z, w)` of a turn of `yaw` rad about z (the inverse of the
/// import's heading of a quaternion).
#[must_use]
pub fn quaternion_from_yaw(yaw: f64) -> [f64; 4] {
    let half = yaw / 2.0;
    [0.0, 0.0, half.sin(), half.cos()]
}

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
        let width = self.values.len().checked_div(self.fields.len()).unwrap_or(0);
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

#[cfg(test)]
mod tests {
    use lewis_interfaces::cdr;
    use lewis_interfaces::dynamic::{Decoder, Value};

    use super::*;

    /// Each text parses with the schema-driven decoder and decodes what was encoded.
    #[test]
    fn texts_decode_what_is_encoded() {
        let header = Header {
            stamp_ns: 1_500_000_001,
            frame_id: "laser".into(),
        };
        let scan = LaserScan {
            header: header.clone(),
            angle_min: -1.5,
            angle_max: 1.5,
            angle_increment: 0.5,
            time_increment: 0.0,
            scan_time: 0.1,
            range_min: 0.0,
            range_max: 8.0,
            ranges: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0],
            intensities: vec![],
        };
        let text = schema_text(LASER_SCAN).unwrap();
        let value = Decoder::new(LASER_SCAN, &text)
            .unwrap()
            .decode(&cdr::to_vec(&scan))
            .unwrap();
        assert_eq!(value.get("header.stamp.sec"), Some(&Value::Int(1)));
        assert_eq!(value.get("header.stamp.nanosec"), Some(&Value::UInt(500_000_001)));
        assert_eq!(value.get("ranges").and_then(Value::as_array).map(<[_]>::len), Some(7));
        let tf = TfMessage {
            transforms: vec![TransformStamped {
                header,
                child_frame_id: "base_link".into(),
                transform: Pose::planar(1.0, 2.0, 0.0, 0.5),
            }],
        };
        let text = schema_text(TF_MESSAGE).unwrap();
        let value = Decoder::new(TF_MESSAGE, &text)
            .unwrap()
            .decode(&cdr::to_vec(&tf))
            .unwrap();
        let z = value.get("transforms").and_then(Value::as_array).unwrap()[0]
            .get("transform.rotation.z")
            .and_then(Value::as_f64)
            .unwrap();
        assert!((z - 0.25f64.sin()).abs() < 1e-12);
        for name in [ODOMETRY, POINT_CLOUD2, COMPRESSED_IMAGE] {
            Decoder::new(name, &schema_text(name).unwrap()).unwrap();
        }
    }
}
