r"""Latency from a /scan to the /cmd_vel that answers it, measured from a Cyclone DDS
participant (no Lewis code): through Lewis (the laser's gateway, the avoider's reflex, the
vector mover, the base's gateway) or through a plain Cyclone participant that answers every
scan with a Twist at once (`echo`), in the same network and the same run.

  ros2_latency_bench.py echo --domain D                  # the plain answerer, until killed
  ros2_latency_bench.py measure --domain D --trials N    # against whoever answers

`measure` publishes free scans (nothing within 5 m, a centimetre of noise) at 10 Hz and /odom at 20 Hz (the robot's
pose driven by the /cmd_vel it receives), waits until the answerer drives the robot, then
publishes one scan with a wall 0.3 m ahead (120 degrees of it) and times the first twist
received after it that stops or slows the robot (a Lewis avoider stops for it; the vector
mover brakes within its deceleration limit, so its first answer is a slower twist); then free scans until the robot drives
again, N times. Against `echo`, every scan is answered with a zero twist, so each trial is
one scan and its answer. Arrivals are timestamped in Cyclone's listener, on its receive
thread, with the monotonic clock.

Prints one JSON line: {"trials": N, "p50_ms", "p90_ms", "p99_ms", "max_ms", "timeouts"}.
"""

import argparse
import json
import math
import os
import random
import statistics
import sys
import threading
import time

from cyclonedds.core import Listener
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ros2_types import (  # noqa: E402
    DEFAULT,
    SENSOR_DATA,
    Header,
    LaserScan,
    Odometry,
    Point,
    Pose,
    PoseWithCovariance,
    Quaternion,
    Time,
    Twist,
    TwistWithCovariance,
    Vector3,
)

BEAMS = 361
FOV = math.pi


def scan(obstacle):
    # A real laser's noise (a centimetre): identical scans are a frozen laser to Lewis.
    ranges = [5.0 + random.uniform(-0.01, 0.01) for _ in range(BEAMS)]
    if obstacle:
        # A wall 0.3 m ahead, over the 120 degrees in front.
        for i in range(BEAMS):
            bearing = -FOV / 2 + i * FOV / (BEAMS - 1)
            if abs(bearing) < math.radians(60):
                ranges[i] = 0.3
    return LaserScan(
        header=Header(stamp=Time.from_ns(time.time_ns()), frame_id="laser"),
        angle_min=-FOV / 2,
        angle_max=FOV / 2,
        angle_increment=FOV / (BEAMS - 1),
        scan_time=0.1,
        range_min=0.05,
        range_max=8.0,
        ranges=ranges,
    )


def echo(args):
    dp = DomainParticipant(args.domain)
    cmd_w = DataWriter(dp, Topic(dp, "rt/cmd_vel", Twist), qos=DEFAULT)

    class Answer(Listener):
        def on_data_available(self, reader):
            for _ in reader.take(N=16):
                cmd_w.write(Twist())

    # Kept: a reader no longer referred to is deleted.
    scan_r = DataReader(dp, Topic(dp, "rt/scan", LaserScan), qos=SENSOR_DATA, listener=Answer())
    print(json.dumps({"event": "ready"}), flush=True)
    deadline = time.monotonic() + args.max_seconds
    while time.monotonic() < deadline:
        time.sleep(0.5)
    del scan_r


class Twists(Listener):
    """Every twist received, with its arrival time (ns), on Cyclone's receive thread."""

    def __init__(self):
        super().__init__()
        self.lock = threading.Condition()
        self.received = []

    def on_data_available(self, reader):
        now = time.monotonic_ns()
        with self.lock:
            for t in reader.take(N=64):
                if isinstance(t, Twist):
                    self.received.append((now, t.linear.x, t.angular.z))
            self.lock.notify_all()

    def wait(self, after_index, accept, timeout_s):
        """The first twist from `after_index` on that `accept`s, or None."""
        deadline = time.monotonic() + timeout_s
        with self.lock:
            while True:
                for i in range(after_index, len(self.received)):
                    if accept(self.received[i]):
                        return self.received[i]
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self.lock.wait(left)


def measure(args):
    dp = DomainParticipant(args.domain)
    scan_w = DataWriter(dp, Topic(dp, "rt/scan", LaserScan), qos=SENSOR_DATA)
    odom_w = DataWriter(dp, Topic(dp, "rt/odom", Odometry), qos=SENSOR_DATA)
    twists = Twists()
    cmd_r = DataReader(dp, Topic(dp, "rt/cmd_vel", Twist), qos=DEFAULT, listener=twists)

    state = {"x": 0.0, "y": 0.0, "theta": 0.0, "stop": False}

    def odometry():
        # The robot's pose from the last twist, at 20 Hz, on a thread of its own.
        while not state["stop"]:
            with twists.lock:
                v, w = (twists.received[-1][1:]) if twists.received else (0.0, 0.0)
            state["x"] += v * math.cos(state["theta"]) * 0.05
            state["y"] += v * math.sin(state["theta"]) * 0.05
            state["theta"] += w * 0.05
            half = state["theta"] / 2
            odom_w.write(
                Odometry(
                    header=Header(stamp=Time.from_ns(time.time_ns()), frame_id="odom"),
                    child_frame_id="base_link",
                    pose=PoseWithCovariance(
                        pose=Pose(
                            position=Point(x=state["x"], y=state["y"]),
                            orientation=Quaternion(z=math.sin(half), w=math.cos(half)),
                        )
                    ),
                    twist=TwistWithCovariance(twist=Twist(linear=Vector3(x=v), angular=Vector3(z=w))),
                )
            )
            time.sleep(0.05)

    threading.Thread(target=odometry, daemon=True).start()

    def free_scans_until(accept, timeout_s):
        """Free scans at 10 Hz until a twist `accept`s; whether one did."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with twists.lock:
                start = len(twists.received)
            scan_w.write(scan(False))
            if twists.wait(start, accept, 0.1):
                return True
        return False

    latencies = []
    timeouts = 0
    moving = lambda t: t[1] != 0.0 or t[2] != 0.0  # noqa: E731
    zero = lambda t: t[1] == 0.0 and t[2] == 0.0  # noqa: E731
    deadline = time.monotonic() + args.max_seconds
    print(json.dumps({"event": "ready"}), flush=True)
    while len(latencies) < args.trials and time.monotonic() < deadline:
        if not args.plain and not free_scans_until(moving, 30.0):
            timeouts += 1
            break
        if args.plain:
            time.sleep(0.1)
        with twists.lock:
            start = len(twists.received)
            before = twists.received[-1][1] if twists.received else 0.0
        obstacle = scan(True)
        sent = time.monotonic_ns()
        scan_w.write(obstacle)
        # The answer: a stop, or the first slower forward velocity (the mover brakes within
        # its deceleration limit, so a stop is a ramp to zero).
        answer = twists.wait(start, lambda t: zero(t) or t[1] < before - 1e-9, 2.0)
        if answer is None:
            timeouts += 1
            continue
        latencies.append((answer[0] - sent) / 1e6)
        if not args.plain:
            # Let the obstacle be forgotten: free scans for a while.
            free_scans_until(lambda t: False, args.clear_s)
    state["stop"] = True
    del cmd_r
    if not latencies:
        print(json.dumps({"trials": 0, "timeouts": timeouts}), flush=True)
        sys.exit(1)
    q = statistics.quantiles(latencies, n=100, method="inclusive") if len(latencies) > 1 else latencies * 99
    print(
        json.dumps(
            {
                "trials": len(latencies),
                "p50_ms": round(statistics.median(latencies), 3),
                "p90_ms": round(q[89], 3),
                "p99_ms": round(q[98], 3),
                "max_ms": round(max(latencies), 3),
                "timeouts": timeouts,
            }
        ),
        flush=True,
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="mode", required=True)
    e = sub.add_parser("echo")
    e.add_argument("--domain", type=int, required=True)
    e.add_argument("--max-seconds", type=float, default=600.0)
    m = sub.add_parser("measure")
    m.add_argument("--domain", type=int, required=True)
    m.add_argument("--trials", type=int, default=100)
    m.add_argument("--plain", action="store_true", help="the answerer is `echo`")
    m.add_argument("--clear-s", type=float, default=1.0, help="free scans after each trial")
    m.add_argument("--max-seconds", type=float, default=600.0)
    args = parser.parse_args()
    echo(args) if args.mode == "echo" else measure(args)


if __name__ == "__main__":
    main()
