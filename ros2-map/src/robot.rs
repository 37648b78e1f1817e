//! The messages a live ROS 2 robot sends or takes that neither the import nor the
//! companions use: `sensor_msgs/msg/Range`, `sensor_msgs/msg/BatteryState`, the Create 3's
//! `irobot_create_msgs/msg/IrIntensityVector` and `HazardDetectionVector`,
//! `sensor_msgs/msg/Image` (live; the import reads a bag's own text), and
//! `geometry_msgs/msg/TwistStamped` (Jazzy's `/cmd_vel`). Their ros2msg texts (for the
//! schema-driven decoder, [`lewis_interfaces::dynamic`]), the DDS type names ROS 2 gives
//! them on the wire, and what each means to Lewis.
//!
//! The texts are the field lists of the ROS 2 definitions, comments left out. Where a
//! distribution changed a type (`sensor_msgs/msg/Range` gained `variance` in Jazzy), both
//! texts are given ([`schema_texts`]) and a reader takes the one the bytes fit.

use lewis_interfaces::cdr::{Encode, Sink};
use lewis_interfaces::dynamic::Value;
use lewis_interfaces::ros2::{Header, Twist};

use crate::from_ros2::number;

/// `sensor_msgs/msg/Range`.
pub const RANGE: &str = "sensor_msgs/msg/Range";
/// `sensor_msgs/msg/BatteryState`.
pub const BATTERY_STATE: &str = "sensor_msgs/msg/BatteryState";
/// `irobot_create_msgs/msg/IrIntensityVector`: the Create 3's seven IR proximity sensors.
pub const IR_INTENSITY_VECTOR: &str = "irobot_create_msgs/msg/IrIntensityVector";
/// `irobot_create_msgs/msg/HazardDetectionVector`: the Create 3's bumps, cliffs, stalls.
pub const HAZARD_DETECTION_VECTOR: &str = "irobot_create_msgs/msg/HazardDetectionVector";
/// `geometry_msgs/msg/TwistStamped`.
pub const TWIST_STAMPED: &str = "geometry_msgs/msg/TwistStamped";
/// `sensor_msgs/msg/Image`.
pub const IMAGE: &str = "sensor_msgs/msg/Image";

const TIME: &str = "int32 sec\nuint32 nanosec\n";
const HEADER: &str = "builtin_interfaces/Time stamp\nstring frame_id\n";
const VECTOR3: &str = "float64 x\nfloat64 y\nfloat64 z\n";
const TWIST: &str = "Vector3  linear\nVector3  angular\n";
const RANGE_HUMBLE: &str = "uint8 ULTRASOUND=0\nuint8 INFRARED=1\nstd_msgs/Header header\n\
    uint8 radiation_type\nfloat32 field_of_view\nfloat32 min_range\nfloat32 max_range\n\
    float32 range\n";
const BATTERY: &str = "uint8 POWER_SUPPLY_STATUS_UNKNOWN = 0\n\
    uint8 POWER_SUPPLY_STATUS_CHARGING = 1\nuint8 POWER_SUPPLY_STATUS_DISCHARGING = 2\n\
    uint8 POWER_SUPPLY_STATUS_NOT_CHARGING = 3\nuint8 POWER_SUPPLY_STATUS_FULL = 4\n\
    std_msgs/Header header\nfloat32 voltage\nfloat32 temperature\nfloat32 current\n\
    float32 charge\nfloat32 capacity\nfloat32 design_capacity\nfloat32 percentage\n\
    uint8 power_supply_status\nuint8 power_supply_health\nuint8 power_supply_technology\n\
    bool present\nfloat32[] cell_voltage\nfloat32[] cell_temperature\nstring location\n\
    string serial_number\n";
const HAZARD: &str = "uint8 BACKUP_LIMIT=0\nuint8 BUMP=1\nuint8 CLIFF=2\nuint8 STALL=3\n\
    uint8 WHEEL_DROP=4\nuint8 OBJECT_PROXIMITY=5\nstd_msgs/Header header\nuint8 type\n";

/// The ROS 2 type name as DDS carries it: `sensor_msgs/msg/LaserScan` is
/// `sensor_msgs::msg::dds_::LaserScan_` (rosidl's DDS naming). `None` when `type_name` is
/// not `package/msg/Type`.
#[must_use]
pub fn dds_type_name(type_name: &str) -> Option<String> {
    let mut parts = type_name.split('/');
    let (Some(package), Some(kind), Some(name), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return None;
    };
    let word = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    (word(package) && word(kind) && word(name)).then(|| format!("{package}::{kind}::dds_::{name}_"))
}

/// The ROS 2 name of a DDS type name (`sensor_msgs::msg::dds_::LaserScan_` is
/// `sensor_msgs/msg/LaserScan`), for messages; `None` for a type ROS 2 did not name.
#[must_use]
pub fn ros_type_name(dds_type: &str) -> Option<String> {
    let mut parts = dds_type.split("::");
    let (Some(package), Some(kind), Some("dds_"), Some(name), None) = (
        parts.next(),
        parts.next(),
        parts.next(),
        parts.next(),
        parts.next(),
    ) else {
        return None;
    };
    let name = name.strip_suffix('_')?;
    let ros = format!("{package}/{kind}/{name}");
    (dds_type_name(&ros).as_deref() == Some(dds_type)).then_some(ros)
}

fn with_dependencies(main: &str, dependencies: &[(&str, &str)]) -> String {
    let mut text = main.to_owned();
    for (name, body) in dependencies {
        text.push_str(&"=".repeat(80));
        text.push_str("\nMSG: ");
        text.push_str(name);
        text.push('\n');
        text.push_str(body);
    }
    text
}

/// The ros2msg texts of `type_name`, newest distribution first: every type this module or
/// [`lewis_interfaces::ros2`] knows. Empty for another type.
#[must_use]
pub fn schema_texts(type_name: &str) -> Vec<String> {
    let header: [(&str, &str); 2] = [
        ("std_msgs/Header", HEADER),
        ("builtin_interfaces/Time", TIME),
    ];
    match type_name {
        RANGE => vec![
            with_dependencies(&format!("{RANGE_HUMBLE}float32 variance\n"), &header),
            with_dependencies(RANGE_HUMBLE, &header),
        ],
        BATTERY_STATE => vec![with_dependencies(BATTERY, &header)],
        IMAGE => vec![with_dependencies(
            "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n\
             uint8 is_bigendian\nuint32 step\nuint8[] data\n",
            &header,
        )],
        IR_INTENSITY_VECTOR => vec![with_dependencies(
            "std_msgs/Header header\nirobot_create_msgs/IrIntensity[] readings\n",
            &[
                ("std_msgs/Header", HEADER),
                ("builtin_interfaces/Time", TIME),
                (
                    "irobot_create_msgs/IrIntensity",
                    "std_msgs/Header header\nint16 value\n",
                ),
            ],
        )],
        HAZARD_DETECTION_VECTOR => vec![with_dependencies(
            "std_msgs/Header header\nirobot_create_msgs/HazardDetection[] detections\n",
            &[
                ("std_msgs/Header", HEADER),
                ("builtin_interfaces/Time", TIME),
                ("irobot_create_msgs/HazardDetection", HAZARD),
            ],
        )],
        TWIST_STAMPED => vec![with_dependencies(
            "std_msgs/Header header\nTwist twist\n",
            &[
                ("std_msgs/Header", HEADER),
                ("builtin_interfaces/Time", TIME),
                ("geometry_msgs/Twist", TWIST),
                ("geometry_msgs/Vector3", VECTOR3),
            ],
        )],
        other => lewis_interfaces::ros2::schema_text(other)
            .into_iter()
            .collect(),
    }
}

/// A `sensor_msgs/msg/Range` reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeReading {
    /// The distance measured, in m (REP 117: `-inf` too close, `+inf` nothing in range).
    pub range_m: f64,
    /// The shortest distance the sensor measures, in m.
    pub min_range_m: f64,
    /// The longest, in m.
    pub max_range_m: f64,
    /// The cone's full width, in rad.
    pub field_of_view_rad: f64,
}

/// The reading of a `sensor_msgs/msg/Range`.
///
/// # Errors
/// A field is missing, or the limits are not usable (`max_range` not positive and finite).
pub fn range(value: &Value) -> Result<RangeReading, String> {
    let reading = RangeReading {
        range_m: number(value, "range")?,
        min_range_m: number(value, "min_range")?,
        max_range_m: number(value, "max_range")?,
        field_of_view_rad: number(value, "field_of_view")?,
    };
    if !(reading.max_range_m.is_finite() && reading.max_range_m > 0.0) {
        return Err(format!(
            "max_range is {}: a range sensor needs a positive finite maximum",
            reading.max_range_m
        ));
    }
    Ok(reading)
}

impl RangeReading {
    /// The distance as a RangeFinder reading: kept within `[min_range, max_range]`; a
    /// reading too close (REP 117's `-inf`, or below the minimum) is the minimum, anything
    /// else (no return, NaN, beyond the maximum) is the maximum, "free up to there".
    #[must_use]
    pub fn distance_m(&self) -> f64 {
        let r = self.range_m;
        if r.is_finite() && r >= self.min_range_m && r <= self.max_range_m {
            r
        } else if r == f64::NEG_INFINITY || (r.is_finite() && r < self.min_range_m) {
            self.min_range_m.max(0.0)
        } else {
            self.max_range_m
        }
    }
}

/// One IR sensor's reading of an `IrIntensityVector`: its frame and its raw intensity.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IrIntensity {
    /// The sensor's tf frame (`ir_intensity_front_left`, ...).
    pub frame_id: String,
    /// The raw intensity (higher is nearer).
    pub value: i64,
}

/// The readings of an `irobot_create_msgs/msg/IrIntensityVector`.
///
/// # Errors
/// A field is missing or of another type.
pub fn ir_intensities(value: &Value) -> Result<Vec<IrIntensity>, String> {
    let readings = value
        .get("readings")
        .and_then(Value::as_array)
        .ok_or("`readings` is missing or not an array")?;
    readings
        .iter()
        .map(|r| {
            Ok(IrIntensity {
                frame_id: r
                    .get("header.frame_id")
                    .and_then(Value::as_str)
                    .ok_or("a reading has no `header.frame_id`")?
                    .to_owned(),
                value: r
                    .get("value")
                    .and_then(Value::as_i64)
                    .ok_or("a reading's `value` is missing or not an integer")?,
            })
        })
        .collect()
}

/// `HazardDetection.type` of a bump.
pub const HAZARD_BUMP: u64 = 1;

/// The frames of the bumps of an `irobot_create_msgs/msg/HazardDetectionVector` (only its
/// `BUMP` detections: `bump_left`, `bump_front_center`, ...).
///
/// # Errors
/// A field is missing or of another type.
pub fn bumps(value: &Value) -> Result<Vec<String>, String> {
    let detections = value
        .get("detections")
        .and_then(Value::as_array)
        .ok_or("`detections` is missing or not an array")?;
    let mut frames = Vec::new();
    for d in detections {
        let kind = d
            .get("type")
            .and_then(Value::as_u64)
            .ok_or("a detection's `type` is missing")?;
        if kind == HAZARD_BUMP {
            frames.push(
                d.get("header.frame_id")
                    .and_then(Value::as_str)
                    .ok_or("a detection has no `header.frame_id`")?
                    .to_owned(),
            );
        }
    }
    Ok(frames)
}

/// What Lewis's Power reads of a `sensor_msgs/msg/BatteryState`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Battery {
    /// Volts.
    pub voltage_v: f64,
    /// Charge from 0 to 1 (`NaN` when the battery does not say).
    pub charge_fraction: f64,
    /// Whether it is charging (`POWER_SUPPLY_STATUS_CHARGING`).
    pub charging: bool,
}

/// The voltage, charge and charging state of a `sensor_msgs/msg/BatteryState`.
///
/// # Errors
/// A field is missing or of another type.
pub fn battery(value: &Value) -> Result<Battery, String> {
    Ok(Battery {
        voltage_v: number(value, "voltage")?,
        charge_fraction: number(value, "percentage")?,
        charging: number(value, "power_supply_status")? == 1.0,
    })
}

/// One transform of a `tf2_msgs/msg/TFMessage`, planar: the child frame's place in its
/// parent's.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarTransform {
    /// The parent frame (leading `/` removed).
    pub parent: String,
    /// The child frame (leading `/` removed).
    pub child: String,
    /// Forward, in m.
    pub x: f64,
    /// Left, in m.
    pub y: f64,
    /// Up, in m.
    pub z: f64,
    /// About z, in rad.
    pub yaw: f64,
}

/// The transforms of a `tf2_msgs/msg/TFMessage`, planar.
///
/// # Errors
/// A field is missing or of another type.
pub fn transforms(value: &Value) -> Result<Vec<PlanarTransform>, String> {
    let list = value
        .get("transforms")
        .and_then(Value::as_array)
        .ok_or("`transforms` is missing or not an array")?;
    list.iter()
        .map(|t| {
            let frame = |path: &str| {
                t.get(path)
                    .and_then(Value::as_str)
                    .map(|f| f.trim_start_matches('/').to_owned())
                    .ok_or_else(|| format!("`{path}` is missing"))
            };
            Ok(PlanarTransform {
                parent: frame("header.frame_id")?,
                child: frame("child_frame_id")?,
                x: number(t, "transform.translation.x")?,
                y: number(t, "transform.translation.y")?,
                z: number(t, "transform.translation.z")?,
                yaw: crate::from_ros2::yaw(t, "transform.rotation")?,
            })
        })
        .collect()
}

/// Where `frame` is in `base` by a chain of `transforms` (composed in the plane, heights
/// added), or `None` when no chain joins them.
#[must_use]
pub fn frame_in(
    transforms: &[PlanarTransform],
    base: &str,
    frame: &str,
) -> Option<PlanarTransform> {
    let mut at = PlanarTransform {
        parent: frame.to_owned(),
        child: frame.to_owned(),
        x: 0.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.0,
    };
    // At most one step per transform: a cycle ends the walk.
    for _ in 0..=transforms.len() {
        if at.parent == base {
            at.parent = base.to_owned();
            return Some(at);
        }
        let step = transforms.iter().find(|t| t.child == at.parent)?;
        let (s, c) = step.yaw.sin_cos();
        at = PlanarTransform {
            parent: step.parent.clone(),
            child: at.child,
            x: step.x + c * at.x - s * at.y,
            y: step.y + s * at.x + c * at.y,
            z: step.z + at.z,
            yaw: step.yaw + at.yaw,
        };
    }
    None
}

/// `geometry_msgs/msg/TwistStamped`.
#[derive(Debug, Clone, PartialEq)]
pub struct TwistStamped {
    /// Stamp and frame (the robot's).
    pub header: Header,
    /// The velocity.
    pub twist: Twist,
}

impl Encode for TwistStamped {
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.header.encode(sink);
        self.twist.encode(sink);
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use lewis_interfaces::cdr;
    use lewis_interfaces::dynamic::Decoder;

    use super::*;

    #[test]
    fn ros2_types_get_their_dds_names() {
        assert_eq!(
            dds_type_name("sensor_msgs/msg/LaserScan").as_deref(),
            Some("sensor_msgs::msg::dds_::LaserScan_")
        );
        assert_eq!(
            dds_type_name(IR_INTENSITY_VECTOR).as_deref(),
            Some("irobot_create_msgs::msg::dds_::IrIntensityVector_")
        );
        assert_eq!(dds_type_name("sensor_msgs/LaserScan"), None);
        assert_eq!(dds_type_name("a/msg/B/c"), None);
        assert_eq!(dds_type_name("a/msg/B c"), None);
        assert_eq!(
            ros_type_name("std_msgs::msg::dds_::String_").as_deref(),
            Some("std_msgs/msg/String")
        );
        assert_eq!(ros_type_name("std_msgs::msg::String_"), None);
        assert_eq!(ros_type_name("std_msgs::msg::dds_::String"), None);
        assert_eq!(ros_type_name("DDS::String"), None);
    }

    #[test]
    fn every_text_parses() {
        for name in [
            RANGE,
            BATTERY_STATE,
            IR_INTENSITY_VECTOR,
            HAZARD_DETECTION_VECTOR,
            TWIST_STAMPED,
            IMAGE,
            lewis_interfaces::ros2::COMPRESSED_IMAGE,
            lewis_interfaces::ros2::LASER_SCAN,
            lewis_interfaces::ros2::ODOMETRY,
        ] {
            let texts = schema_texts(name);
            assert!(!texts.is_empty(), "{name}");
            for text in texts {
                Decoder::new(name, &text).unwrap();
            }
        }
        assert!(schema_texts("a/msg/Unknown").is_empty());
    }

    #[test]
    fn a_twist_stamped_decodes_with_its_text() {
        let message = TwistStamped {
            header: Header {
                stamp_ns: 2_000_000_003,
                frame_id: "base_link".into(),
            },
            twist: Twist {
                linear: [0.25, 0.0, 0.0],
                angular: [0.0, 0.0, -0.5],
            },
        };
        let text = &schema_texts(TWIST_STAMPED)[0];
        let value = Decoder::new(TWIST_STAMPED, text)
            .unwrap()
            .decode(&cdr::to_vec(&message))
            .unwrap();
        assert_eq!(
            value.get("twist.linear.x").and_then(Value::as_f64),
            Some(0.25)
        );
        assert_eq!(
            value.get("twist.angular.z").and_then(Value::as_f64),
            Some(-0.5)
        );
        assert_eq!(
            value.get("header.frame_id").and_then(Value::as_str),
            Some("base_link")
        );
    }

    #[test]
    fn a_frame_is_found_through_a_chain_of_transforms() {
        let t = |parent: &str, child: &str, x, y, z, yaw| PlanarTransform {
            parent: parent.into(),
            child: child.into(),
            x,
            y,
            z,
            yaw,
        };
        let tree = [
            t(
                "base_link",
                "shell_link",
                0.0,
                0.0,
                0.1,
                std::f64::consts::FRAC_PI_2,
            ),
            t("shell_link", "rplidar_link", 0.1, 0.0, 0.09, 0.0),
            t("base_link", "imu", 0.05, 0.03, 0.07, 0.0),
        ];
        let lidar = frame_in(&tree, "base_link", "rplidar_link").unwrap();
        assert!(
            lidar.x.abs() < 1e-12 && (lidar.y - 0.1).abs() < 1e-12,
            "{lidar:?}"
        );
        assert!((lidar.z - 0.19).abs() < 1e-12);
        assert!((lidar.yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert_eq!(
            frame_in(&tree, "base_link", "base_link").map(|f| f.x),
            Some(0.0)
        );
        assert_eq!(frame_in(&tree, "base_link", "camera"), None);
        let cycle = [
            t("a", "b", 0.0, 0.0, 0.0, 0.0),
            t("b", "a", 0.0, 0.0, 0.0, 0.0),
        ];
        assert_eq!(frame_in(&cycle, "base_link", "a"), None);
    }

    #[test]
    fn range_readings_follow_rep_117() {
        let reading = |range_m| RangeReading {
            range_m,
            min_range_m: 0.02,
            max_range_m: 4.0,
            field_of_view_rad: 0.5,
        };
        assert_eq!(reading(1.5).distance_m(), 1.5);
        assert_eq!(reading(f64::INFINITY).distance_m(), 4.0);
        assert_eq!(reading(f64::NAN).distance_m(), 4.0);
        assert_eq!(reading(9.0).distance_m(), 4.0);
        assert_eq!(reading(f64::NEG_INFINITY).distance_m(), 0.02);
        assert_eq!(reading(0.01).distance_m(), 0.02);
    }
}
