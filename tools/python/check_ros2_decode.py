"""Decodes every message of an MCAP file with mcap-ros2-support (its own CDR parser and
ros2msg reader, independent of Lewis) and compares each one field by field with the
expected values given as JSON: {topic: value}.

Usage: check_ros2_decode.py FILE.mcap EXPECTED.json
Prints one line per mismatch and exits 1 if there is any.
"""

import json
import math
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def to_plain(value):
    """A decoded ROS message as plain Python data."""
    if isinstance(value, (bytes, bytearray)):
        return list(value)
    if isinstance(value, (list, tuple)):
        return [to_plain(v) for v in value]
    if hasattr(value, "__slots__"):
        return {name: to_plain(getattr(value, name)) for name in value.__slots__}
    return value


def compare(path, got, want, problems):
    if isinstance(want, dict):
        if not isinstance(got, dict):
            problems.append(f"{path}: expected a message, got {got!r}")
            return
        if set(got) != set(want):
            problems.append(f"{path}: fields {sorted(got)} != expected {sorted(want)}")
        for key in want:
            if key in got:
                compare(f"{path}.{key}", got[key], want[key], problems)
    elif isinstance(want, list):
        if not isinstance(got, list) or len(got) != len(want):
            problems.append(f"{path}: expected {len(want)} elements, got {got!r:.80}")
            return
        for i, (g, w) in enumerate(zip(got, want)):
            compare(f"{path}[{i}]", g, w, problems)
    elif isinstance(want, bool):
        if got is not want:
            problems.append(f"{path}: {got!r} != {want!r}")
    elif isinstance(want, float):
        # float32 fields come back as the nearest double of the float32 value.
        if not (isinstance(got, float) and math.isclose(got, want, rel_tol=1e-6, abs_tol=1e-30)):
            problems.append(f"{path}: {got!r} != {want!r}")
    elif got != want:
        problems.append(f"{path}: {got!r} != {want!r}")


def main():
    mcap_path, expected_path = sys.argv[1], sys.argv[2]
    with open(expected_path, encoding="utf-8") as f:
        expected = json.load(f)
    seen = set()
    problems = []
    with open(mcap_path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            topic = channel.topic
            seen.add(topic)
            if topic not in expected:
                problems.append(f"{topic}: not expected")
                continue
            compare(topic, to_plain(decoded), expected[topic], problems)
    for topic in sorted(set(expected) - seen):
        problems.append(f"{topic}: missing from the file")
    for p in problems:
        print(p)
    print(f"{len(seen)} messages decoded, {len(problems)} mismatches")
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
