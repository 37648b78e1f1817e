"""Checks a Lewis recording's ROS 2 companion channels against the Lewis messages they were
made from, both decoded by mcap-ros2-support (independent of Lewis): LaserScan against
RangeFinder (ranges, angles, frame), PointCloud2 against the sonar's RangeFinder (where
each beam ends), Odometry and /tf against Egomotion (pose, heading, velocities),
/tf_static against the RangeFinders' offsets and the robot file's camera mounts,
MarkerArray against Blobs3D, Signs and the broker's bindings, CompressedImage against
ImageSource (format and size). Every channel must carry `offered_qos_profiles` (MCAP's ros2
profile requires it): a YAML list of rosbag2 profile records with known policy codes,
`/tf_static` and `/robot_description` transient local.

Usage: check_companions.py FILE.mcap
Decodes every message of the file (exits 1 at one that does not decode). Prints `TOPIC TYPE
COUNT` per companion topic checked, `decoded TOPIC COUNT` per topic, then one line per
mismatch; exits 1 if there is any mismatch or no companion at all.
"""

import math
import struct
import sys
import tomllib

import yaml
from collections import Counter, defaultdict

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


DEFAULTS = {"system_default", "unknown", "best_available"}
QOS_NAMES = {
    "history": DEFAULTS | {"keep_last", "keep_all"},
    "reliability": DEFAULTS | {"reliable", "best_effort"},
    "durability": DEFAULTS | {"transient_local", "volatile"},
    "liveliness": DEFAULTS | {"automatic", "manual_by_topic"},
}


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def close(a, b, tol=1e-6):
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def same_angle(a, b):
    d = (a - b + math.pi) % (2 * math.pi) - math.pi
    return abs(d) < 1e-6


def stamp_ns(header):
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


class Checker:
    def __init__(self, path):
        self.path = path
        self.problems = []
        self.counts = Counter()
        self.types = {}
        self.decoded = Counter()
        # (topic, log_time) -> (decoded Lewis message, its channel's metadata)
        self.sources = {}
        self.offsets = defaultdict(set)
        self.bindings = {}
        self.binding_texts = {}
        self.mounts = {}
        self.static_frames = {}
        self.qos_channels = 0

    def problem(self, where, text):
        if len(self.problems) < 50:
            self.problems.append(f"{where}: {text}")

    def run(self):
        with open(self.path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for record in reader.iter_metadata():
                if record.name == "lewis.robot":
                    for text in record.metadata.values():
                        robot = tomllib.loads(text)
                        for service in robot.get("services", []):
                            mount = service.get("parameters", {}).get("mount")
                            if mount is not None:
                                self.mounts[service["name"]] = mount
            for channel in reader.get_summary().channels.values():
                self.check_qos(channel)
            f.seek(0)
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            pending = []
            for schema, channel, message, decoded in reader.iter_decoded_messages():
                self.decoded[channel.topic] += 1
                meta = channel.metadata
                if meta.get("kind") == "ros2-companion":
                    pending.append((schema.name, channel.topic, meta, message.log_time, decoded))
                else:
                    self.sources[(channel.topic, message.log_time)] = (decoded, meta, message)
                    if schema.name == "lewis_interfaces/msg/Broker":
                        self.track_binding(decoded, message.log_time)
                    if schema.name == "lewis_interfaces/msg/RangeFinder":
                        self.offsets[meta.get("provider")].add(
                            (decoded.x_offset, decoded.y_offset, decoded.z_offset)
                        )
        for type_name, topic, meta, log_time, decoded in pending:
            self.counts[topic] += 1
            self.types[topic] = type_name
            if topic == "/tf_static":
                self.check_tf_static(decoded)
                continue
            source = self.sources.get((meta.get("source"), log_time))
            if source is None:
                self.problem(topic, f"no {meta.get('source')} message at log time {log_time}")
                continue
            lewis, lewis_meta, lewis_message = source
            expected_stamp = lewis_message.publish_time or lewis_message.log_time
            where = f"{topic} @{log_time}"
            check = {
                "sensor_msgs/msg/LaserScan": self.check_scan,
                "sensor_msgs/msg/PointCloud2": self.check_cloud,
                "nav_msgs/msg/Odometry": self.check_odometry,
                "tf2_msgs/msg/TFMessage": self.check_tf,
                "visualization_msgs/msg/MarkerArray": self.check_markers,
                "sensor_msgs/msg/CompressedImage": self.check_image,
            }.get(type_name)
            if check is None:
                self.problem(where, f"unexpected companion type {type_name}")
                continue
            check(where, decoded, lewis, lewis_meta, log_time)
            header = getattr(decoded, "header", None)
            if header is not None and stamp_ns(header) != expected_stamp:
                self.problem(where, f"stamp {stamp_ns(header)} != {expected_stamp}")
        for frame, transform in self.static_frames.items():
            t = transform.translation
            got = (t.x, t.y, t.z)
            if frame in self.offsets:
                if got not in self.offsets[frame]:
                    self.problem("/tf_static", f"{frame} at {got}, its RangeFinder says {self.offsets[frame]}")
            elif frame in self.mounts:
                m = self.mounts[frame]
                want = (m.get("x_m", 0.0), m.get("y_m", 0.0), m.get("height_m", 0.0))
                if not all(close(a, b) for a, b in zip(got, want)):
                    self.problem("/tf_static", f"{frame} at {got}, the robot file mounts it at {want}")
                if not same_angle(yaw_of(transform.rotation), math.radians(m.get("heading_deg", 0.0))):
                    self.problem("/tf_static", f"{frame} heading differs from the robot file")
            else:
                self.problem("/tf_static", f"frame {frame} is neither a range finder nor a mounted camera")

    def check_qos(self, channel):
        where = f"{channel.topic} offered_qos_profiles"
        text = channel.metadata.get("offered_qos_profiles")
        if text is None:
            self.problem(where, "missing")
            return
        profiles = yaml.safe_load(text)
        if not isinstance(profiles, list) or not profiles:
            self.problem(where, f"not a non-empty YAML list: {text!r}")
            return
        self.qos_channels += 1
        for profile in profiles:
            # rmw's codes (Humble writes numbers, Jazzy names): 0 system default, the
            # policy's values, 3 unknown, 4 best available.
            for key, names in QOS_NAMES.items():
                value = profile.get(key)
                if value not in (0, 1, 2, 3, 4) and str(value).lower() not in names:
                    self.problem(where, f"{key} = {value!r}")
            for key in ("deadline", "lifespan", "liveliness_lease_duration"):
                value = profile.get(key)
                if not isinstance(value, dict) or set(value) != {"sec", "nsec"}:
                    self.problem(where, f"{key} = {value!r}")
            latched = channel.topic.rsplit("/", 1)[-1] in ("tf_static", "robot_description")
            if latched and profile.get("durability") not in (1, "transient_local"):
                self.problem(where, f"durability {profile.get('durability')}, transient local (1) expected")

    def track_binding(self, broker, log_time):
        key = (broker.client, broker.interface)
        if broker.action == "bind":
            self.bindings[key] = broker.service
        elif broker.action == "rebind":
            self.bindings[key] = broker.to_service
        elif broker.action == "unbind":
            self.bindings.pop(key, None)
        else:
            return
        self.binding_texts[log_time] = "\n".join(
            f"{c}: {i} <- {p}" for (c, i), p in sorted(self.bindings.items())
        )

    def check_scan(self, where, scan, rf, meta, _):
        if scan.header.frame_id != meta.get("provider"):
            self.problem(where, f"frame {scan.header.frame_id} != provider {meta.get('provider')}")
        if not rf.uniform:
            self.problem(where, "a LaserScan of a non-uniform RangeFinder")
        if len(scan.ranges) != len(rf.ranges):
            self.problem(where, f"{len(scan.ranges)} ranges != {len(rf.ranges)}")
        for i, (got, want) in enumerate(zip(scan.ranges, rf.ranges)):
            if got != f32(want) and not (math.isnan(got) and math.isnan(want)):
                self.problem(where, f"range {i}: {got} != {want}")
                break
        for name, got, want in [
            ("angle_min", scan.angle_min, rf.theta_offset),
            ("angle_increment", scan.angle_increment, rf.theta_separation),
            ("angle_max", scan.angle_max, rf.theta_offset + rf.theta_separation * (len(rf.ranges) - 1)),
            ("range_max", scan.range_max, rf.max_range),
        ]:
            if got != f32(want):
                self.problem(where, f"{name} {got} != {want}")

    def check_cloud(self, where, cloud, rf, meta, _):
        names = [f.name for f in cloud.fields]
        if names != ["x", "y", "z", "range"] or cloud.point_step != 16:
            self.problem(where, f"fields {names}, step {cloud.point_step}")
            return
        if cloud.width != len(rf.ranges) or len(cloud.data) != 16 * cloud.width:
            self.problem(where, f"{cloud.width} points for {len(rf.ranges)} readings")
            return
        for i, (r, at) in enumerate(zip(rf.ranges, rf.sensor_positions)):
            x, y, z, rng = struct.unpack_from("<4f", bytes(cloud.data), 16 * i)
            want = (
                at.x + r * math.cos(at.theta) - rf.x_offset,
                at.y + r * math.sin(at.theta) - rf.y_offset,
                at.z - rf.z_offset,
                r,
            )
            if not all(close(g, f32(w), 1e-5) for g, w in zip((x, y, z, rng), want)):
                self.problem(where, f"point {i}: {(x, y, z, rng)} != {want}")
                break

    def check_odometry(self, where, odom, ego, meta, _):
        p = odom.pose.pose
        if (odom.header.frame_id, odom.child_frame_id) != ("odom", "base_link"):
            self.problem(where, f"frames {odom.header.frame_id} -> {odom.child_frame_id}")
        if (p.position.x, p.position.y) != (ego.pose.x, ego.pose.y) or not same_angle(yaw_of(p.orientation), ego.pose.theta):
            self.problem(where, f"pose {p} != {ego.pose}")
        if (odom.twist.twist.linear.x, odom.twist.twist.angular.z) != (ego.translation_velocity, ego.rotation_velocity):
            self.problem(where, "velocities differ")

    def check_tf(self, where, tf, ego, meta, _):
        if len(tf.transforms) != 1:
            self.problem(where, f"{len(tf.transforms)} transforms")
            return
        t = tf.transforms[0]
        if (t.header.frame_id, t.child_frame_id) != ("odom", "base_link"):
            self.problem(where, f"frames {t.header.frame_id} -> {t.child_frame_id}")
        tr = t.transform
        if (tr.translation.x, tr.translation.y) != (ego.pose.x, ego.pose.y) or not same_angle(yaw_of(tr.rotation), ego.pose.theta):
            self.problem(where, f"transform {tr} != {ego.pose}")

    def check_tf_static(self, tf):
        for t in tf.transforms:
            if t.header.frame_id != "base_link":
                self.problem("/tf_static", f"parent {t.header.frame_id}")
            self.static_frames[t.child_frame_id] = t.transform

    def check_markers(self, where, array, lewis, meta, log_time):
        markers = array.markers
        if not markers or markers[0].action != 3:
            self.problem(where, "the first marker does not clear the earlier ones")
            return
        shapes = markers[1:]
        if hasattr(lewis, "blobs"):
            placed = [b for b in lewis.blobs if b.range_valid]
            boxes = shapes[0::2]
            if len(boxes) != len(placed):
                self.problem(where, f"{len(boxes)} boxes for {len(placed)} placed blobs")
            for box, blob in zip(boxes, placed):
                at = box.pose.position
                if (at.x, at.y, at.z) != (blob.position.x, blob.position.y, blob.position.z):
                    self.problem(where, f"box at {at} != blob at {blob.position}")
        elif hasattr(lewis, "signs"):
            boards = shapes[0::2]
            texts = shapes[1::2]
            if len(boards) != len(lewis.signs):
                self.problem(where, f"{len(boards)} boards for {len(lewis.signs)} signs")
            for board, text, sign in zip(boards, texts, lewis.signs):
                at = board.pose.position
                if (at.x, at.y, at.z) != (sign.position.x, sign.position.y, sign.position.z):
                    self.problem(where, f"board at {at} != sign at {sign.position}")
                if not text.text.startswith(sign.arrow):
                    self.problem(where, f"text {text.text!r} for sign {sign.arrow!r}")
        else:
            want = self.binding_texts.get(log_time)
            if want is None or len(shapes) != 1 or shapes[0].text != want:
                got = shapes[0].text if shapes else None
                self.problem(where, f"bindings {got!r} != {want!r}")

    def check_image(self, where, image, source, meta, _):
        data = bytes(image.data)
        if image.format == "png":
            if data[:8] != b"\x89PNG\r\n\x1a\n":
                self.problem(where, "not a PNG")
                return
            width, height = struct.unpack(">II", data[16:24])
            if (width, height) != (source.width, source.height):
                self.problem(where, f"{width}x{height} != {source.width}x{source.height}")
        elif image.format == "jpeg":
            if data[:2] != b"\xff\xd8":
                self.problem(where, "not a JPEG")
        else:
            self.problem(where, f"format {image.format}")


def main(path):
    checker = Checker(path)
    checker.run()
    for topic, count in sorted(checker.counts.items()):
        print(f"{topic} {checker.types[topic]} {count}")
    for topic, count in sorted(checker.decoded.items()):
        print(f"decoded {topic} {count}")
    print(f"offered_qos_profiles on {checker.qos_channels} channels")
    for problem in checker.problems:
        print(f"MISMATCH {problem}")
    if not checker.counts:
        print(f"{path}: no companion channel")
        return 1
    return 1 if checker.problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
