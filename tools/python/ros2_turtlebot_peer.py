r"""A TurtleBot 4-shaped ROS 2 session over DDS, played by Eclipse Cyclone DDS's Python
binding (the DDS behind ROS 2's rmw_cyclonedds), with no Lewis code: the independent peer
of Lewis's live ROS 2 gateway in the end-to-end test.

It plays the real laser scans of a rosbag2 MCAP file (read with `mcap-ros2-support`) live,
at the rate they were recorded, as /scan, and makes the rest of a TurtleBot 4 fit them:

- /odom (nav_msgs/Odometry, 20 Hz) and /tf (odom -> base_link): the robot's pose, driven
  by the /cmd_vel it receives (a unicycle integrated at 20 Hz), so a Lewis that drives
  sees itself move;
- /tf_static (base_link -> laser, transient local, published once);
- /ir_intensity (irobot_create_msgs/IrIntensityVector, --ir-rate-hz): the Create 3's seven
  IR sensors, each the intensity `k / d^p` of the laser's range at its bearing (d from the
  bumper, k = 1, p = 2: lewis-ros2's default model), plus noise of a few counts;
- /hazard_detection (10 Hz, empty: no bump) and /battery_state (1 Hz);
- from another participant, all along, a std_msgs/String writer on /scan (the wrong type).

/scan's writer announces LaserScan's type hash in its USER_DATA, as a Jazzy driver does.

The scans' own stamps are kept, shifted by one constant so that they read the present
time (and, when the file is played again from its start, go on increasing).

It receives /cmd_vel (geometry_msgs/Twist, reliable) and prints each one as a JSON line:
{"event": "cmd_vel", "t": SECONDS, "linear": [x, y, z], "angular": [x, y, z]}, `t` being
this process's monotonic clock. Other lines: {"event": "ready"} once every writer and the
reader exist, {"event": "scan", "mode": "off" | "on" | "garbage" | "flood"} when /scan changes,
{"event": "done", "scans": N, "cmd_vel": N} at the end.

Commands on standard input, one a line: `scan off` (stop publishing /scan: the lidar went
silent), `scan garbage` (publish, in place of each scan, a message of the same type name
that is no LaserScan, from a participant of its own), `scan flood` (each scan ten times, with noise),
`scan on`, `quit`. The `garbage` writer announces the type hash of its own definition. It ends on `quit`, at the end of its input, or after
--max-seconds.

Usage:
  ros2_turtlebot_peer.py --bag ../shared/data/ros2/hokuyo-scan-matcher-demo.mcap \
      --domain 17 [--ir-rate-hz 62] [--max-seconds 120]
"""

import argparse
import json
import math
import os
import random
import select
import sys
import time

from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ros2_types import (  # noqa: E402
    DEFAULT,
    LATCHED,
    SENSOR_DATA,
    BatteryState,
    HazardDetectionVector,
    Header,
    IrIntensity,
    IrIntensityVector,
    LASER_SCAN_HASH,
    NOT_A_LASER_SCAN_HASH,
    LaserScan,
    NotALaserScan,
    Odometry,
    Point,
    Pose,
    PoseWithCovariance,
    Quaternion,
    TFMessage,
    Time,
    Transform,
    TransformStamped,
    Twist,
    TwistWithCovariance,
    Vector3,
    WrongType,
    announcing,
)

# The Create 3's IR sensors (frame, bearing in degrees), from its /tf_static.
IR_SENSORS = [
    ("ir_intensity_side_left", 57.3),
    ("ir_intensity_left", 36.0),
    ("ir_intensity_front_left", 19.1),
    ("ir_intensity_front_center_left", 2.6),
    ("ir_intensity_front_center_right", -13.8),
    ("ir_intensity_front_right", -32.3),
    ("ir_intensity_right", -62.6),
]
BUMPER_RADIUS_M = 0.17


def say(**event):
    sys.stdout.write(json.dumps(event) + "\n")
    sys.stdout.flush()


def load_scans(path):
    """The file's LaserScans on /scan with their log times, in ns."""
    scans = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, _, message, scan in reader.iter_decoded_messages(topics=["/scan"]):
            scans.append((message.log_time, scan))
    if not scans:
        raise SystemExit(f"{path} has no /scan")
    return scans


def quaternion(yaw):
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))


def laser_scan(scan, stamp_ns):
    return LaserScan(
        header=Header(stamp=Time.from_ns(stamp_ns), frame_id=scan.header.frame_id or "laser"),
        angle_min=scan.angle_min,
        angle_max=scan.angle_max,
        angle_increment=scan.angle_increment,
        time_increment=scan.time_increment,
        scan_time=scan.scan_time,
        range_min=scan.range_min,
        range_max=scan.range_max,
        ranges=list(scan.ranges),
        intensities=list(scan.intensities),
    )


def range_at(scan, bearing_rad):
    """The scan's reading nearest to `bearing_rad` (max range when it saw nothing)."""
    if scan.angle_increment == 0:
        return scan.range_max
    i = round((bearing_rad - scan.angle_min) / scan.angle_increment)
    i = max(0, min(len(scan.ranges) - 1, i))
    r = scan.ranges[i]
    if not (scan.range_min <= r <= scan.range_max) or math.isnan(r):
        return scan.range_max
    return r


def ir_vector(scan, stamp_ns, rng):
    readings = []
    for frame, bearing_deg in IR_SENSORS:
        d = max(range_at(scan, math.radians(bearing_deg)) - BUMPER_RADIUS_M, 0.005)
        value = 1.0 / (d * d) + rng.uniform(0.0, 6.0)
        readings.append(
            IrIntensity(
                header=Header(stamp=Time.from_ns(stamp_ns), frame_id=frame),
                value=int(min(value, 32767)),
            )
        )
    return IrIntensityVector(
        header=Header(stamp=Time.from_ns(stamp_ns), frame_id="base_link"), readings=readings
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--bag", required=True)
    parser.add_argument("--domain", type=int, required=True)
    parser.add_argument("--ir-rate-hz", type=float, default=62.0)
    parser.add_argument("--max-seconds", type=float, default=120.0)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    scans = load_scans(args.bag)

    dp = DomainParticipant(args.domain)

    def writer(name, kind, qos):
        return DataWriter(dp, Topic(dp, "rt" + name, kind), qos=qos)

    # /scan announces its type hash as a Jazzy driver's does (the other topics announce
    # none, as Humble's do).
    scan_w = writer("/scan", LaserScan, announcing(SENSOR_DATA, LASER_SCAN_HASH))
    odom_w = writer("/odom", Odometry, SENSOR_DATA)
    tf_w = writer("/tf", TFMessage, DEFAULT)
    tf_static_w = writer("/tf_static", TFMessage, LATCHED)
    ir_w = writer("/ir_intensity", IrIntensityVector, SENSOR_DATA)
    hazard_w = writer("/hazard_detection", HazardDetectionVector, SENSOR_DATA)
    battery_w = writer("/battery_state", BatteryState, SENSOR_DATA)
    cmd_r = DataReader(dp, Topic(dp, "rt/cmd_vel", Twist), qos=DEFAULT)
    # Another participant: one may not have one topic name with two types. It announces
    # the hash of its own definition, as a Jazzy publisher would.
    liar = DomainParticipant(args.domain)
    garbage_w = DataWriter(
        liar,
        Topic(liar, "rt/scan", NotALaserScan),
        qos=announcing(SENSOR_DATA, NOT_A_LASER_SCAN_HASH),
    )
    # And one more: a std_msgs/String writer on /scan for the whole session.
    stranger = DomainParticipant(args.domain)
    wrong_w = DataWriter(stranger, Topic(stranger, "rt/scan", WrongType), qos=SENSOR_DATA)
    wrong_w.write(WrongType(data="not a scan"))

    start = time.monotonic()
    wall_ns = time.time_ns
    # The scans' stamps read the present time: one shift for the whole session.
    first_log = scans[0][0]
    shift = wall_ns() - first_log
    tf_static_w.write(
        TFMessage(
            transforms=[
                TransformStamped(
                    header=Header(stamp=Time.from_ns(wall_ns()), frame_id="base_link"),
                    child_frame_id=scans[0][1].header.frame_id or "laser",
                    transform=Transform(translation=Vector3(x=0.0, y=0.0, z=0.2)),
                )
            ]
        )
    )
    say(event="ready", scans=len(scans))

    x = y = theta = 0.0
    v = w = 0.0
    scan_mode = "on"
    scan_index = 0
    loop_offset = 0
    play_start = time.monotonic()
    next_scan = play_start
    next_odom = play_start
    next_ir = play_start
    next_hazard = play_start
    next_battery = play_start
    last_scan = scans[0][1]
    published_scans = 0
    received = 0
    odom_dt = 0.05
    commands = ""

    while time.monotonic() - start < args.max_seconds:
        now = time.monotonic()
        for sample in cmd_r.take(N=100):
            if not isinstance(sample, Twist):
                continue
            received += 1
            v, w = sample.linear.x, sample.angular.z
            say(
                event="cmd_vel",
                t=time.monotonic(),
                linear=[sample.linear.x, sample.linear.y, sample.linear.z],
                angular=[sample.angular.x, sample.angular.y, sample.angular.z],
            )
        if now >= next_scan:
            log_time, scan = scans[scan_index]
            last_scan = scan
            if scan_mode in ("on", "flood"):
                # Flooding: each scan ten times (ten times the rate), each copy with its
                # own noise as a laser's scans have (identical ones would be frozen).
                for copy in range(10 if scan_mode == "flood" else 1):
                    message = laser_scan(scan, log_time + loop_offset + shift)
                    if copy:
                        message.ranges = [r + rng.uniform(-0.005, 0.005) for r in message.ranges]
                    scan_w.write(message)
                    published_scans += 1
            elif scan_mode == "garbage":
                garbage_w.write(
                    NotALaserScan(
                        header=Header(stamp=Time.from_ns(wall_ns()), frame_id="laser"),
                        value=published_scans,
                    )
                )
            if scan_index + 1 == len(scans):
                # Played again from the start, 100 ms on.
                gap = 0.1
                scan_index = 0
                loop_offset += scans[-1][0] - first_log + 100_000_000
            else:
                gap = (scans[scan_index + 1][0] - log_time) / 1e9
                scan_index += 1
            next_scan += max(gap, 0.0)
        if now >= next_odom:
            x += v * math.cos(theta) * odom_dt
            y += v * math.sin(theta) * odom_dt
            theta = math.atan2(math.sin(theta + w * odom_dt), math.cos(theta + w * odom_dt))
            stamp = Time.from_ns(wall_ns())
            pose = Pose(position=Point(x=x, y=y), orientation=quaternion(theta))
            odom_w.write(
                Odometry(
                    header=Header(stamp=stamp, frame_id="odom"),
                    child_frame_id="base_link",
                    pose=PoseWithCovariance(pose=pose),
                    twist=TwistWithCovariance(
                        twist=Twist(linear=Vector3(x=v), angular=Vector3(z=w))
                    ),
                )
            )
            tf_w.write(
                TFMessage(
                    transforms=[
                        TransformStamped(
                            header=Header(stamp=stamp, frame_id="odom"),
                            child_frame_id="base_link",
                            transform=Transform(
                                translation=Vector3(x=x, y=y), rotation=quaternion(theta)
                            ),
                        )
                    ]
                )
            )
            next_odom += odom_dt
        if now >= next_ir:
            ir_w.write(ir_vector(last_scan, wall_ns(), rng))
            next_ir += 1.0 / args.ir_rate_hz
        if now >= next_hazard:
            hazard_w.write(
                HazardDetectionVector(
                    header=Header(stamp=Time.from_ns(wall_ns()), frame_id="base_link")
                )
            )
            next_hazard += 0.1
        if now >= next_battery:
            battery_w.write(
                BatteryState(
                    header=Header(stamp=Time.from_ns(wall_ns()), frame_id="base_link"),
                    voltage=15.6,
                    percentage=0.8,
                    power_supply_status=2,
                )
            )
            next_battery += 1.0
        # Commands, without blocking the schedule.
        wait = max(0.0, min(next_scan, next_odom, next_ir, next_hazard, next_battery) - time.monotonic())
        wait = min(wait, 0.005)
        ready, _, _ = select.select([sys.stdin], [], [], wait)
        if ready:
            chunk = os.read(sys.stdin.fileno(), 4096).decode()
            if not chunk:
                break
            commands += chunk
            while "\n" in commands:
                line, commands = commands.split("\n", 1)
                line = line.strip()
                if line == "quit":
                    say(event="done", scans=published_scans, cmd_vel=received)
                    return
                if line in ("scan off", "scan on", "scan garbage", "scan flood"):
                    scan_mode = line.split()[1]
                    say(event="scan", mode=scan_mode)
    say(event="done", scans=published_scans, cmd_vel=received)


if __name__ == "__main__":
    main()
