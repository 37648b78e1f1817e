"""Decodes every message of an MCAP file with mcap-ros2-support (its own CDR parser,
independent of Lewis) and prints `TOPIC COUNT` per topic.

Usage: decode_all.py FILE.mcap
Exits 1, naming the topic and the message's log time, at the first message that does not
decode.
"""

import sys
from collections import Counter

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def main(path):
    counts = Counter()
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        try:
            for _schema, channel, message, _decoded in reader.iter_decoded_messages():
                counts[channel.topic] += 1
        except Exception as e:  # noqa: BLE001 - any failure is the finding
            print(f"{path}: a message does not decode after {sum(counts.values())}: {e}")
            return 1
    for topic, count in sorted(counts.items()):
        print(f"{topic} {count}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
