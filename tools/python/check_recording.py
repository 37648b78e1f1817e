"""Reads MCAP files with the independent Python readers and prints what they hold as JSON.

Every message is decoded with mcap-ros2-support (its own ros2msg parser and CDR decoder);
per topic the output gives the count, a CRC-32 of the raw message bytes in order (each
preceded by its length as 4 little-endian bytes), the decoded header sequence numbers as
runs, and whether every decoded header publish time equals the MCAP publish_time. In file
order (as a streaming player reads it), per file how often log time goes backwards and per
topic whether its log times strictly increase. Companion channels (ROS 2's own types,
`kind = ros2-companion`) are left out of the topics. Each channel's `offered_qos_profiles`
is given parsed as YAML (`qos`), or null when it has none.

Usage: check_recording.py FILE.mcap [FILE.mcap ...]   (the files are read as one run)
"""

import json
import struct
import sys
import zlib

import yaml

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def main():
    out = {"files": [], "topics": {}}
    for path in sys.argv[1:]:
        with open(path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            header = reader.get_header()
            summary = reader.get_summary()
            info = {
                "profile": header.profile,
                "library": header.library,
                "metadata": {},
                "channels": {},
                "chunks": len(summary.chunk_indexes) if summary else 0,
                "compressions": sorted({c.compression for c in summary.chunk_indexes}) if summary else [],
            }
            for record in reader.iter_metadata():
                info["metadata"][record.name] = dict(record.metadata)
            if summary:
                for channel in summary.channels.values():
                    schema = summary.schemas.get(channel.schema_id)
                    info["channels"][channel.topic] = {
                        "message_encoding": channel.message_encoding,
                        "schema_name": schema.name if schema else None,
                        "schema_encoding": schema.encoding if schema else None,
                        "metadata": {k: v for k, v in channel.metadata.items() if k != "offered_qos_profiles"},
                        "qos": yaml.safe_load(channel.metadata["offered_qos_profiles"])
                        if "offered_qos_profiles" in channel.metadata
                        else None,
                    }
            out["files"].append(info)
            info["log_time_backwards"] = 0
            last_log_time = None
            for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
                if channel.metadata.get("kind") == "ros2-companion":
                    # ROS 2's own types, without a Lewis header: tools/python/check_companions.py
                    # checks them against the messages they were made from.
                    continue
                t = out["topics"].setdefault(
                    channel.topic,
                    {"count": 0, "crc32": 0, "seq_runs": [], "publish_time_matches": True, "last_decoded": None,
                     "log_time_increasing": True, "last_log_time": None},
                )
                if last_log_time is not None and message.log_time < last_log_time:
                    info["log_time_backwards"] += 1
                last_log_time = message.log_time
                if t["last_log_time"] is not None and message.log_time <= t["last_log_time"]:
                    t["log_time_increasing"] = False
                t["last_log_time"] = message.log_time
                t["count"] += 1
                t["crc32"] = zlib.crc32(struct.pack("<I", len(message.data)), t["crc32"])
                t["crc32"] = zlib.crc32(message.data, t["crc32"])
                seq = decoded.header.seq
                runs = t["seq_runs"]
                if runs and runs[-1][1] + 1 == seq:
                    runs[-1][1] = seq
                else:
                    runs.append([seq, seq])
                if max(decoded.header.publish_time_ns, 0) != message.publish_time:
                    t["publish_time_matches"] = False
                if channel.topic == "/lewis/recorder/stats":
                    t["last_decoded"] = {
                        "topics": list(decoded.topics),
                        "written": list(decoded.written),
                        "lost": list(decoded.lost),
                        "dropped": list(decoded.dropped),
                    }
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
