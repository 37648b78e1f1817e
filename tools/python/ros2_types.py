"""ROS 2 message types as ROS 2 generates them for DDS, declared with Cyclone DDS's Python
IDL (`cyclonedds.idl`), written from the ROS 2 (Humble) .msg definitions, not from Lewis's
code: the `rosidl` DDS names (`sensor_msgs::msg::dds_::LaserScan_`), fields in .msg order,
`@final` structs, plain CDR (XCDR1) as `rmw_cyclonedds` sends it. Only the types of a
TurtleBot 4-shaped session.
"""

import hashlib
import json
from dataclasses import dataclass, field

import cyclonedds.idl.annotations as annotate
from cyclonedds.core import Policy, Qos
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float32, float64, int16, int32, sequence, uint8, uint32
from cyclonedds.util import duration


@dataclass
@annotate.final
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0

    @staticmethod
    def from_ns(ns):
        return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


@dataclass
@annotate.final
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
@annotate.final
class LaserScan(IdlStruct, typename="sensor_msgs::msg::dds_::LaserScan_"):
    header: Header = field(default_factory=Header)
    angle_min: float32 = 0.0
    angle_max: float32 = 0.0
    angle_increment: float32 = 0.0
    time_increment: float32 = 0.0
    scan_time: float32 = 0.0
    range_min: float32 = 0.0
    range_max: float32 = 0.0
    ranges: sequence[float32] = field(default_factory=list)
    intensities: sequence[float32] = field(default_factory=list)


@dataclass
@annotate.final
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
@annotate.final
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
@annotate.final
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
@annotate.final
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
@annotate.final
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose = field(default_factory=Pose)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
@annotate.final
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
@annotate.final
class TwistStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TwistStamped_"):
    header: Header = field(default_factory=Header)
    twist: Twist = field(default_factory=Twist)


@dataclass
@annotate.final
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist = field(default_factory=Twist)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@dataclass
@annotate.final
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass
@annotate.final
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
@annotate.final
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
@annotate.final
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped] = field(default_factory=list)


@dataclass
@annotate.final
class IrIntensity(IdlStruct, typename="irobot_create_msgs::msg::dds_::IrIntensity_"):
    header: Header = field(default_factory=Header)
    value: int16 = 0


@dataclass
@annotate.final
class IrIntensityVector(IdlStruct, typename="irobot_create_msgs::msg::dds_::IrIntensityVector_"):
    header: Header = field(default_factory=Header)
    readings: sequence[IrIntensity] = field(default_factory=list)


@dataclass
@annotate.final
class HazardDetection(IdlStruct, typename="irobot_create_msgs::msg::dds_::HazardDetection_"):
    header: Header = field(default_factory=Header)
    type: uint8 = 0


@dataclass
@annotate.final
class HazardDetectionVector(
    IdlStruct, typename="irobot_create_msgs::msg::dds_::HazardDetectionVector_"
):
    header: Header = field(default_factory=Header)
    detections: sequence[HazardDetection] = field(default_factory=list)


@dataclass
@annotate.final
class BatteryState(IdlStruct, typename="sensor_msgs::msg::dds_::BatteryState_"):
    header: Header = field(default_factory=Header)
    voltage: float32 = 0.0
    temperature: float32 = 0.0
    current: float32 = 0.0
    charge: float32 = 0.0
    capacity: float32 = 0.0
    design_capacity: float32 = 0.0
    percentage: float32 = 0.0
    power_supply_status: uint8 = 0
    power_supply_health: uint8 = 0
    power_supply_technology: uint8 = 0
    present: bool = True
    cell_voltage: sequence[float32] = field(default_factory=list)
    cell_temperature: sequence[float32] = field(default_factory=list)
    location: str = ""
    serial_number: str = ""


@dataclass
@annotate.final
class NotALaserScan(IdlStruct, typename="sensor_msgs::msg::dds_::LaserScan_"):
    """Bad input from the network: a publisher that calls its messages LaserScans but sends
    something else (a header and one number), so that a reader of real LaserScans gets
    samples that do not decode."""

    header: Header = field(default_factory=Header)
    value: int16 = 0


@dataclass
@annotate.final
class WrongType(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    """Bad input from the network: a std_msgs/String published under a topic name that
    carries LaserScans elsewhere (DDS never matches it with a LaserScan reader)."""

    data: str = ""


def type_hash(type_name, fields, referenced=()):
    """ROS 2's type hash (REP 2011) of a message, as rosidl computes it on Iron and later:
    SHA-256 over the JSON of its type description (each field a name, a type id, capacity,
    string capacity and nested type name), the referenced types sorted by name.
    `fields` and each referenced `(name, fields)` are `(field name, type id, nested)`."""

    def describe(name, fields):
        return {
            "type_name": name,
            "fields": [
                {
                    "name": field_name,
                    "type": {
                        "type_id": type_id,
                        "capacity": 0,
                        "string_capacity": 0,
                        "nested_type_name": nested,
                    },
                }
                for field_name, type_id, nested in fields
            ],
        }

    description = {
        "type_description": describe(type_name, fields),
        "referenced_type_descriptions": [
            describe(name, f) for name, f in sorted(referenced, key=lambda r: r[0])
        ],
    }
    text = json.dumps(description, separators=(", ", ": "))
    return "RIHS01_" + hashlib.sha256(text.encode()).hexdigest()


# rosidl's field type ids.
NESTED, INT16, INT32, UINT32, FLOAT32, STRING, FLOAT32_SEQUENCE = 1, 4, 6, 7, 10, 17, 154
HEADER_TYPES = [
    ("builtin_interfaces/msg/Time", [("sec", INT32, ""), ("nanosec", UINT32, "")]),
    (
        "std_msgs/msg/Header",
        [("stamp", NESTED, "builtin_interfaces/msg/Time"), ("frame_id", STRING, "")],
    ),
]
HEADER_FIELD = ("header", NESTED, "std_msgs/msg/Header")
# sensor_msgs/msg/LaserScan's hash, which a Jazzy publisher of /scan announces.
LASER_SCAN_HASH = type_hash(
    "sensor_msgs/msg/LaserScan",
    [HEADER_FIELD]
    + [
        (name, FLOAT32, "")
        for name in (
            "angle_min",
            "angle_max",
            "angle_increment",
            "time_increment",
            "scan_time",
            "range_min",
            "range_max",
        )
    ]
    + [("ranges", FLOAT32_SEQUENCE, ""), ("intensities", FLOAT32_SEQUENCE, "")],
    HEADER_TYPES,
)
# NotALaserScan's hash: what a Jazzy publisher of that other definition announces.
NOT_A_LASER_SCAN_HASH = type_hash(
    "sensor_msgs/msg/LaserScan", [HEADER_FIELD, ("value", INT16, "")], HEADER_TYPES
)


def announcing(qos, hash_):
    """`qos` with the type hash in USER_DATA, as rmw_dds_common puts it there."""
    return Qos(*qos, Policy.Userdata(data=f"typehash={hash_};".encode()))


# The QoS profiles of rclcpp, as rmw_cyclonedds sets them, with plain CDR (XCDR1).
XCDR1 = Policy.DataRepresentation(use_cdrv0_representation=True)

SENSOR_DATA = Qos(
    Policy.Reliability.BestEffort,
    Policy.Durability.Volatile,
    Policy.History.KeepLast(5),
    XCDR1,
)
DEFAULT = Qos(
    Policy.Reliability.Reliable(duration(milliseconds=100)),
    Policy.Durability.Volatile,
    Policy.History.KeepLast(10),
    XCDR1,
)
LATCHED = Qos(
    Policy.Reliability.Reliable(duration(milliseconds=100)),
    Policy.Durability.TransientLocal,
    Policy.History.KeepLast(1),
    XCDR1,
)
