//! ROS 2's standard messages that Lewis writes beside its own (the recorder's companion
//! channels, `lewis export ros2`) or sends to a ROS 2 robot (a velocity command as
//! [`Twist`]): their type names, their ros2msg schema texts as rosbag2
//! stores them (the message's .msg fields, then each type it uses, depth-first in order
//! of first use, after a line of 80 `=` and a `MSG: package/Type` line), and their values
//! ([`LaserScan`], [`Odometry`], ...) that encode to ROS 2 CDR through [`crate::cdr`].
//!
//! The texts are the ROS 2 Humble definitions with their comments left out: the fields,
//! types and order are what decoders read (later distributions added texture fields to
//! `Marker`; a reader decodes with the text stored beside the data). Reading bags goes
//! through the schema-driven decoder ([`crate::dynamic`]) with the bag's own texts, so the
//! import side needs no text of its own.

mod msg;

pub use msg::*;

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
/// `visualization_msgs/msg/MarkerArray`.
pub const MARKER_ARRAY: &str = "visualization_msgs/msg/MarkerArray";
/// `geometry_msgs/msg/Twist`.
pub const TWIST: &str = "geometry_msgs/msg/Twist";

const TIME: &str = "int32 sec\nuint32 nanosec\n";
const HEADER: &str = "builtin_interfaces/Time stamp\nstring frame_id\n";
const POINT: &str = "float64 x\nfloat64 y\nfloat64 z\n";
const QUATERNION: &str = "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const VECTOR3: &str = "float64 x\nfloat64 y\nfloat64 z\n";
const POSE: &str = "Point position\nQuaternion orientation\n";
const POSE_WITH_COVARIANCE: &str = "Pose pose\nfloat64[36] covariance\n";
const TWIST_TEXT: &str = "Vector3  linear\nVector3  angular\n";
const TWIST_WITH_COVARIANCE: &str = "Twist twist\nfloat64[36] covariance\n";
const TRANSFORM: &str = "Vector3 translation\nQuaternion rotation\n";
const TRANSFORM_STAMPED: &str =
    "std_msgs/Header header\nstring child_frame_id\nTransform transform\n";
const COLOR_RGBA: &str = "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n";
const DURATION: &str = "int32 sec\nuint32 nanosec\n";
const MARKER: &str = "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\n\
    int32 LINE_STRIP=4\nint32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\n\
    int32 POINTS=8\nint32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\n\
    int32 ADD=0\nint32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\n\
    std_msgs/Header header\nstring ns\nint32 id\nint32 type\nint32 action\n\
    geometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n\
    builtin_interfaces/Duration lifetime\nbool frame_locked\ngeometry_msgs/Point[] points\n\
    std_msgs/ColorRGBA[] colors\nstring text\nstring mesh_resource\n\
    bool mesh_use_embedded_materials\n";
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
                    ("geometry_msgs/Twist", TWIST_TEXT),
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
        MARKER_ARRAY => (
            "Marker[] markers\n",
            vec![
                ("visualization_msgs/Marker", MARKER),
                ("std_msgs/Header", HEADER),
                ("builtin_interfaces/Time", TIME),
                ("geometry_msgs/Pose", POSE),
                ("geometry_msgs/Point", POINT),
                ("geometry_msgs/Quaternion", QUATERNION),
                ("geometry_msgs/Vector3", VECTOR3),
                ("std_msgs/ColorRGBA", COLOR_RGBA),
                ("builtin_interfaces/Duration", DURATION),
            ],
        ),
        TWIST => (TWIST_TEXT, vec![("geometry_msgs/Vector3", VECTOR3)]),
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

#[cfg(test)]
mod tests {
    use crate::cdr;
    use crate::dynamic::{Decoder, Value};

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
        assert_eq!(
            value.get("header.stamp.nanosec"),
            Some(&Value::UInt(500_000_001))
        );
        assert_eq!(
            value
                .get("ranges")
                .and_then(Value::as_array)
                .map(<[_]>::len),
            Some(7)
        );
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
        for name in [
            ODOMETRY,
            POINT_CLOUD2,
            COMPRESSED_IMAGE,
            MARKER_ARRAY,
            TWIST,
        ] {
            Decoder::new(name, &schema_text(name).unwrap()).unwrap();
        }
    }

    /// A Twist decodes to itself, and its text reads the same fields from its bytes.
    #[test]
    fn a_twist_round_trips() {
        let twist = Twist {
            linear: [0.5, -0.25, 0.0],
            angular: [0.0, 0.0, -1.5],
        };
        let bytes = cdr::to_vec(&twist);
        assert_eq!(cdr::from_bytes::<Twist>(&bytes).unwrap(), twist);
        assert_eq!(bytes.len(), 4 + 6 * 8);
        let value = Decoder::new(TWIST, &schema_text(TWIST).unwrap())
            .unwrap()
            .decode(&bytes)
            .unwrap();
        for (path, want) in [
            ("linear.x", 0.5),
            ("linear.y", -0.25),
            ("linear.z", 0.0),
            ("angular.x", 0.0),
            ("angular.y", 0.0),
            ("angular.z", -1.5),
        ] {
            assert_eq!(
                value.get(path).and_then(Value::as_f64),
                Some(want),
                "{path}"
            );
        }
        assert!(cdr::from_bytes::<Twist>(&bytes[..bytes.len() - 8]).is_err());
    }
}
