"""Reads a recording written by Lewis (`lewis import`, `lewis bench long-recording`) with the
independent readers (`mcap`, and `mcap-ros2-support` to decode CDR from the schema stored in
the file) and prints a JSON summary for the tests (tests/tests/import_carmen.rs,
tests/tests/bench_long.rs): messages per topic, whether log time ever goes
backwards (over the file, and per topic strictly), the robot description's metadata, and the
first laser reading decoded.

Usage: python check_recording.py RUN.mcap
"""

import json
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def main(path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        factory = DecoderFactory()
        counts = {}
        last_per_topic = {}
        last = None
        backwards = 0
        not_increasing_per_topic = []
        negative = 0
        first_laser = None
        first_egomotion = None
        # File order, as a streaming player would read it.
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            topic = channel.topic
            counts[topic] = counts.get(topic, 0) + 1
            t = message.log_time
            if t < 0:
                negative += 1
            if last is not None and t < last:
                backwards += 1
            last = t
            if topic in last_per_topic and t <= last_per_topic[topic]:
                not_increasing_per_topic.append(topic)
            last_per_topic[topic] = t
            if topic == "/laser/RangeFinder" and first_laser is None:
                decoded = factory.decoder_for(channel.message_encoding, schema)(
                    message.data
                )
                first_laser = {
                    "provider": decoded.header.provider,
                    "seq": decoded.header.seq,
                    "publish_time_ns": decoded.header.publish_time_ns,
                    "log_time_ns": t,
                    "range_count": decoded.range_count,
                    "ranges": len(decoded.ranges),
                    "first_range": decoded.ranges[0],
                    "max_range": decoded.max_range,
                }
            if topic == "/base/Egomotion" and first_egomotion is None:
                decoded = factory.decoder_for(channel.message_encoding, schema)(
                    message.data
                )
                first_egomotion = {"provider": decoded.header.provider}
        f.seek(0)
        robot = {}
        for record in make_reader(f).iter_metadata():
            if record.name == "lewis.robot":
                robot = {name: len(text) for name, text in record.metadata.items()}
                robot_text = "".join(record.metadata.values())
        print(
            json.dumps(
                {
                    "counts": counts,
                    "backwards": backwards,
                    "not_increasing_per_topic": not_increasing_per_topic,
                    "negative": negative,
                    "robot_files": sorted(robot),
                    "robot_text": robot_text if robot else "",
                    "first_laser": first_laser,
                    "first_egomotion": first_egomotion,
                }
            )
        )


if __name__ == "__main__":
    main(sys.argv[1])
