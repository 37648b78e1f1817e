"""Writes a ROS 2 bag (MCAP, rosbag2's layout) with Python's independent writer,
`mcap-ros2-support`, for `lewis import ros2`'s tests: LaserScan on /scan, Odometry on
/odom, TF on /tf and an Image on /camera/image_raw, each with the message definitions as
ROS 2 ships them (the ros2msg text rosbag2 stores: the .msg file, then each dependency
after a line of '=' and `MSG: pkg/msg/Name`).

Usage: write_ros2_bag.py OUT.mcap [VARIANT]

VARIANT (default `good`): `no-laser-no-odom` (only the image), `bad-encoding` (an image
in `bayer_rggb16`), `beams-change` (scan 3 has fewer ranges), `time-backwards` (the log
time of /scan message 4 is earlier than message 3's), `two-lasers` (a second LaserScan on
/scan_rear), `stamps-off` (the scans' header stamps 5 s behind their log times, the
first one zero), `compressed` (the images as sensor_msgs/CompressedImage PNG on
/camera/image_raw/compressed, encoded here with zlib).

The values written are a function of the message index, so the test computes the same.
/scan carries the offered QoS of a sensor driver (best effort), as rosbag2 records it.
"""

import math
import struct
import sys
import zlib

from mcap_ros2.writer import Writer

SEP = "=" * 80 + "\n"

TIME = """# This message communicates ROS Time defined here:
# https://design.ros2.org/articles/clock_and_time.html

# The seconds component, valid over all int32 values.
int32 sec

# The nanoseconds component, valid in the range [0, 1e9), to be added to the seconds component.
# e.g.
# The time -1.7 seconds is represented as {sec: -2, nanosec: 3e8}
# The time 1.7 seconds is represented as {sec: 1, nanosec: 7e8}
uint32 nanosec
"""

HEADER = """# Standard metadata for higher-level stamped data types.
# This is generally used to communicate timestamped data
# in a particular coordinate frame.

# Two-integer timestamp that is expressed as seconds and nanoseconds.
builtin_interfaces/Time stamp

# Transform frame with which this data is associated.
string frame_id
"""

LASER_SCAN = """# Single scan from a planar laser range-finder
#
# If you have another ranging device with different behavior (e.g. a sonar
# array), please find or create a different message, since applications
# will make fairly laser-specific assumptions about this data

std_msgs/Header header # timestamp in the header is the acquisition time of
                             # the first ray in the scan.
                             #
                             # in frame frame_id, angles are measured around
                             # the positive Z axis (counterclockwise, if Z is up)
                             # with zero angle being forward along the x axis

float32 angle_min            # start angle of the scan [rad]
float32 angle_max            # end angle of the scan [rad]
float32 angle_increment      # angular distance between measurements [rad]

float32 time_increment       # time between measurements [seconds] - if your scanner
                             # is moving, this will be used in interpolating position
                             # of 3d points
float32 scan_time            # time between scans [seconds]

float32 range_min            # minimum range value [m]
float32 range_max            # maximum range value [m]

float32[] ranges             # range data [m]
                             # (Note: values < range_min or > range_max should be discarded)
float32[] intensities        # intensity data [device-specific units].  If your
                             # device does not provide intensities, please leave
                             # the array empty.
"""

ODOMETRY = """# This represents an estimate of a position and velocity in free space.
# The pose in this message should be specified in the coordinate frame given by header.frame_id
# The twist in this message should be specified in the coordinate frame given by the child_frame_id

# Includes the frame id of the pose parent.
std_msgs/Header header

# Frame id the pose points to. The twist is in this coordinate frame.
string child_frame_id

# Estimated pose that is typically relative to a fixed world frame.
geometry_msgs/PoseWithCovariance pose

# Estimated linear and angular velocity relative to child_frame_id.
geometry_msgs/TwistWithCovariance twist
"""

POSE_WITH_COVARIANCE = """# This represents a pose in free space with uncertainty.

Pose pose

# Row-major representation of the 6x6 covariance matrix
# The orientation parameters use a fixed-axis representation.
# In order, the parameters are:
# (x, y, z, rotation about X axis, rotation about Y axis, rotation about Z axis)
float64[36] covariance
"""

POSE = """# A representation of pose in free space, composed of position and orientation.

Point position
Quaternion orientation
"""

POINT = """# This contains the position of a point in free space
float64 x
float64 y
float64 z
"""

QUATERNION = """# This represents an orientation in free space in quaternion form.

float64 x 0
float64 y 0
float64 z 0
float64 w 1
"""

TWIST_WITH_COVARIANCE = """# This expresses velocity in free space with uncertainty.

Twist twist

# Row-major representation of the 6x6 covariance matrix
# The orientation parameters use a fixed-axis representation.
# In order, the parameters are:
# (x, y, z, rotation about X axis, rotation about Y axis, rotation about Z axis)
float64[36] covariance
"""

TWIST = """# This expresses velocity in free space broken into its linear and angular parts.

Vector3  linear
Vector3  angular
"""

VECTOR3 = """# This represents a vector in free space.

# This is semantically different than a point.
# A vector is always anchored at the origin.
# When a transform is applied to a vector, only the rotational component is applied.

float64 x
float64 y
float64 z
"""

TF_MESSAGE = """geometry_msgs/TransformStamped[] transforms
"""

TRANSFORM_STAMPED = """# This expresses a transform from coordinate frame header.frame_id
# to the coordinate frame child_frame_id at the time of header.stamp
#
# This message is mostly used by the
# <a href="https://index.ros.org/p/tf2/">tf2</a> package.
# See its documentation for more information.
#
# The child_frame_id is necessary in addition to the frame_id
# in the Header to communicate the full reference for the transform
# in a self contained message.

# The frame id in the header is used as the reference frame of this transform.
std_msgs/Header header

# The frame id of the child frame to which this transform points.
string child_frame_id

# Translation and rotation in 3-dimensions of child_frame_id from header.frame_id.
Transform transform
"""

TRANSFORM = """# This represents the transform between two coordinate frames in free space.

Vector3 translation
Quaternion rotation
"""

IMAGE = """# This message contains an uncompressed image
# (0, 0) is at top-left corner of image

std_msgs/Header header # Header timestamp should be acquisition time of image
                             # Header frame_id should be optical frame of camera
                             # origin of frame should be optical center of cameara
                             # +x should point to the right in the image
                             # +y should point down in the image
                             # +z should point into to plane of the image
                             # If the frame_id here and the frame_id of the CameraInfo
                             # message associated with the image conflict
                             # the behavior is undefined

uint32 height                # image height, that is, number of rows
uint32 width                 # image width, that is, number of columns

# The legal values for encoding are in file include/sensor_msgs/image_encodings.hpp
# If you want to standardize a new string format, join
# ros-users@lists.ros.org and send an email proposing a new encoding.

string encoding       # Encoding of pixels -- channel meaning, ordering, size
                      # taken from the list of strings in include/sensor_msgs/image_encodings.hpp

uint8 is_bigendian    # is this data bigendian?
uint32 step           # Full row length in bytes
uint8[] data          # actual matrix data, size is (step * rows)
"""


COMPRESSED_IMAGE = """# This message contains a compressed image.

std_msgs/Header header # Header timestamp should be acquisition time of image
                             # Header frame_id should be optical frame of camera
                             # origin of frame should be optical center of cameara
                             # +x should point to the right in the image
                             # +y should point down in the image
                             # +z should point into to plane of the image

string format                # Specifies the format of the data
                             #   Acceptable values differ by the image transport used:
                             #   - compressed_image_transport:
                             #       ORIG_PIXFMT; CODEC compressed [COMPRESSED_PIXFMT]
                             #     where:
                             #     - ORIG_PIXFMT is pixel format of the raw image, i.e.
                             #       the content of sensor_msgs/Image/encoding with
                             #       values from include/sensor_msgs/image_encodings.h
                             #     - CODEC is one of [jpeg, png, tiff, webp]
                             #     - COMPRESSED_PIXFMT is only appended for color images
                             #       and is the pixel format used by the compression
                             #       algorithm. Valid values for jpeg encoding are:
                             #       [bgr8, rgb8]. Valid values for png encoding are:
                             #       [bgr8, rgb8, bgr16, rgb16].
                             #     If the field is empty or does not correspond to the
                             #     above pattern, the image is treated as bgr8 or mono8
                             #     jpeg image (depending on the number of channels).
                             #   - compressed_depth_image_transport:
                             #       ORIG_PIXFMT; compressedDepth CODEC
                             #     where:
                             #     - ORIG_PIXFMT is pixel format of the raw image, i.e.
                             #       the content of sensor_msgs/Image/encoding with
                             #       values from include/sensor_msgs/image_encodings.h
                             #       It is usually one of [16UC1, 32FC1].
                             #     - CODEC is one of [png, rvl]
                             #     If the field is empty or does not correspond to the
                             #     above pattern, the image is treated as png image.
                             #   - Other image transports can store whatever values they
                             #     need for successful decoding of the image. Refer to
                             #     documentation of the other transports for details.

uint8[] data                 # Compressed image buffer
"""


def png(width, height, rgb):
    """An 8-bit RGB PNG of `rgb`, each row filtered with filter 0."""

    def chunk(kind, body):
        return (
            struct.pack(">I", len(body))
            + kind
            + body
            + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
        )

    rows = b"".join(
        b"\x00" + rgb[r * width * 3 : (r + 1) * width * 3] for r in range(height)
    )
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(rows))
        + chunk(b"IEND", b"")
    )


def definition(main, *deps):
    text = main
    for name, body in deps:
        text += SEP + "MSG: " + name + "\n" + body
    return text


HEADER_DEPS = [("std_msgs/Header", HEADER), ("builtin_interfaces/Time", TIME)]

BEAMS = 181
START_NS = 1_700_000_000_000_000_000


def stamp(ns):
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def header(ns, frame):
    return {"stamp": stamp(ns), "frame_id": frame}


def ranges(i, beams=BEAMS):
    """Readings of scan i: within [0.1, 10] m except beam 7, beyond range_max (30 m)."""
    out = [0.5 + ((i * 31 + b * 7) % 900) / 100.0 for b in range(beams)]
    out[7] = 30.0 + i
    return out


def pose(i):
    """Odometry pose i: a drive along x, turning slowly."""
    return (0.1 * i, 0.02 * i, 0.05 * i)


def quaternion(yaw):
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def pixels(i, width, height):
    return bytes((i * 17 + k * 5) % 256 for k in range(width * height * 3))


INFINITE = "    sec: 9223372036\n    nsec: 854775807\n"
SCAN_QOS = (
    "- history: 3\n  depth: 0\n  reliability: 2\n  durability: 2\n"
    f"  deadline:\n{INFINITE}  lifespan:\n{INFINITE}  liveliness: 1\n"
    f"  liveliness_lease_duration:\n{INFINITE}  avoid_ros_namespace_conventions: false"
)


def main():
    out = sys.argv[1]
    variant = sys.argv[2] if len(sys.argv) > 2 else "good"
    with open(out, "wb") as f:
        writer = Writer(f)
        scan_schema = writer.register_msgdef(
            "sensor_msgs/msg/LaserScan", definition(LASER_SCAN, *HEADER_DEPS)
        )
        odom_schema = writer.register_msgdef(
            "nav_msgs/msg/Odometry",
            definition(
                ODOMETRY,
                ("geometry_msgs/PoseWithCovariance", POSE_WITH_COVARIANCE),
                ("geometry_msgs/Pose", POSE),
                ("geometry_msgs/Point", POINT),
                ("geometry_msgs/Quaternion", QUATERNION),
                ("geometry_msgs/TwistWithCovariance", TWIST_WITH_COVARIANCE),
                ("geometry_msgs/Twist", TWIST),
                ("geometry_msgs/Vector3", VECTOR3),
                *HEADER_DEPS,
            ),
        )
        tf_schema = writer.register_msgdef(
            "tf2_msgs/msg/TFMessage",
            definition(
                TF_MESSAGE,
                ("geometry_msgs/TransformStamped", TRANSFORM_STAMPED),
                ("geometry_msgs/Transform", TRANSFORM),
                ("geometry_msgs/Quaternion", QUATERNION),
                ("geometry_msgs/Vector3", VECTOR3),
                *HEADER_DEPS,
            ),
        )
        image_schema = writer.register_msgdef(
            "sensor_msgs/msg/Image", definition(IMAGE, *HEADER_DEPS)
        )
        compressed_schema = writer.register_msgdef(
            "sensor_msgs/msg/CompressedImage", definition(COMPRESSED_IMAGE, *HEADER_DEPS)
        )
        # /scan as rosbag2 records a sensor driver's topic: its offered QoS (best effort,
        # volatile; history unknown from discovery) on the channel, which an import keeps.
        # The Writer has no argument for a channel's metadata: the channel is registered
        # here, through the MCAP writer it wraps, before its first message.
        if variant != "no-laser-no-odom":
            writer._channel_ids["/scan"] = writer._writer.register_channel(
                topic="/scan",
                message_encoding="cdr",
                schema_id=scan_schema.id,
                metadata={"offered_qos_profiles": SCAN_QOS},
            )
        seq = 0
        for i in range(30):
            t = START_NS + i * 100_000_000
            if variant != "no-laser-no-odom":
                beams = BEAMS - 10 if (variant == "beams-change" and i == 3) else BEAMS
                log = t - 150_000_000 if (variant == "time-backwards" and i == 4) else t
                for topic in ["/scan", "/scan_rear"] if variant == "two-lasers" else ["/scan"]:
                    writer.write_message(
                        topic,
                        scan_schema,
                        {
                            "header": header(
                                (0 if i == 0 else t - 5_000_000_000)
                                if variant == "stamps-off"
                                else t,
                                "laser",
                            ),
                            "angle_min": -math.pi / 2,
                            "angle_max": math.pi / 2,
                            "angle_increment": math.pi / (BEAMS - 1),
                            "time_increment": 0.0,
                            "scan_time": 0.1,
                            "range_min": 0.1,
                            "range_max": 30.0,
                            "ranges": ranges(i, beams),
                            "intensities": [],
                        },
                        log_time=log,
                        publish_time=log,
                        sequence=seq,
                    )
                    seq += 1
                x, y, yaw = pose(i)
                writer.write_message(
                    "/odom",
                    odom_schema,
                    {
                        "header": header(t + 1_000, "odom"),
                        "child_frame_id": "base_link",
                        "pose": {
                            "pose": {
                                "position": {"x": x, "y": y, "z": 0.0},
                                "orientation": quaternion(yaw),
                            },
                            "covariance": [0.0] * 36,
                        },
                        "twist": {
                            "twist": {
                                "linear": {"x": 1.0, "y": 0.0, "z": 0.0},
                                "angular": {"x": 0.0, "y": 0.0, "z": 0.5},
                            },
                            "covariance": [0.0] * 36,
                        },
                    },
                    log_time=t + 1_000,
                    publish_time=t + 1_000,
                    sequence=seq,
                )
                seq += 1
                writer.write_message(
                    "/tf",
                    tf_schema,
                    {
                        "transforms": [
                            {
                                "header": header(t + 2_000, "odom"),
                                "child_frame_id": "base_link",
                                "transform": {
                                    "translation": {"x": x, "y": y, "z": 0.0},
                                    "rotation": quaternion(yaw),
                                },
                            }
                        ]
                    },
                    log_time=t + 2_000,
                    publish_time=t + 2_000,
                    sequence=seq,
                )
                seq += 1
            if i % 5 == 0 and variant == "compressed":
                writer.write_message(
                    "/camera/image_raw/compressed",
                    compressed_schema,
                    {
                        "header": header(t + 3_000, "camera"),
                        "format": "rgb8; png compressed rgb8",
                        "data": png(6, 4, pixels(i, 6, 4)),
                    },
                    log_time=t + 3_000,
                    publish_time=t + 3_000,
                    sequence=seq,
                )
                seq += 1
            elif i % 5 == 0:
                encoding = "bayer_rggb16" if (variant == "bad-encoding" and i == 10) else "rgb8"
                writer.write_message(
                    "/camera/image_raw",
                    image_schema,
                    {
                        "header": header(t + 3_000, "camera"),
                        "height": 4,
                        "width": 6,
                        "encoding": encoding,
                        "is_bigendian": 0,
                        "step": 18,
                        "data": pixels(i, 6, 4),
                    },
                    log_time=t + 3_000,
                    publish_time=t + 3_000,
                    sequence=seq,
                )
                seq += 1
        writer.finish()


if __name__ == "__main__":
    main()
