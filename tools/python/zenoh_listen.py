r"""Listens to a Lewis channel over Zenoh, without Lewis: what any other tool would do.

Lewis's Zenoh bridge puts each channel CHANNEL of robot ROBOT on host HOST on the key
`lewis/ROBOT/HOST/CHANNEL` (the channel without its leading slash), with the message's
ROS 2 CDR bytes as the payload, exactly as Lewis writes them into MCAP. The schema is
answered by a query on `lewis/ROBOT/HOST/@schema/CHANNEL` as JSON
{"name", "encoding": "ros2msg", "data"}. This program uses only `eclipse-zenoh` and
`mcap-ros2-support`'s CDR decoder, so it checks the bridge with readers independent of Lewis.

Usage:
  zenoh_listen.py --connect tcp/ADDR:PORT --key lewis/sim/robot/laser/RangeFinder \
                  --count 3 [--timeout 20]

Prints one JSON line per message: {"key", "schema", "msg"}, where msg holds the message's
fields (numbers and strings as they are, nested messages such as the header as objects,
arrays as their length under "<field>_len"). Exits 0 after --count messages; exits 1 with
one line on stderr if it cannot connect, gets no schema or no message within --timeout
seconds (for each of these steps), or a payload does not decode.
"""

import argparse
import json
import math
import queue
import sys
import time

import zenoh
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory


class Failure(Exception):
    """A one-line reason to exit 1."""


def schema_key(key):
    """lewis/ROBOT/HOST/CHANNEL... -> lewis/ROBOT/HOST/@schema/CHANNEL..."""
    parts = key.split("/")
    if len(parts) < 4 or parts[0] != "lewis" or "" in parts:
        raise Failure(f"{key}: not a Lewis key (lewis/ROBOT/HOST/CHANNEL)")
    return "/".join(parts[:3] + ["@schema"] + parts[3:])


def open_session(endpoint, timeout):
    """A client session connected to `endpoint` only: no scouting, no listening."""
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps("client"))
    config.insert_json5("connect/endpoints", json.dumps([endpoint]))
    # Retry connecting until the timeout, then fail open() instead of running unconnected.
    config.insert_json5("connect/timeout_ms", json.dumps(int(timeout * 1000)))
    config.insert_json5("connect/exit_on_failure", "true")
    config.insert_json5("listen/endpoints", "[]")
    config.insert_json5("scouting/multicast/enabled", "false")
    try:
        return zenoh.open(config)
    except zenoh.ZError as e:
        reason = str(e).split(" at /")[0]  # without zenoh's source location
        raise Failure(f"cannot connect to {endpoint} within {timeout:g} s: {reason}") from None


def fetch_schema(session, key, timeout):
    """The {"name", "encoding", "data"} answered on the schema key, asked until it comes."""
    deadline = time.monotonic() + timeout
    while True:
        left = deadline - time.monotonic()
        for reply in session.get(key, timeout=max(0.1, min(left, 2.0))):
            if reply.ok is None:
                raise Failure(f"{key}: query answered an error: {reply.err.payload.to_string()}")
            try:
                return json.loads(reply.ok.payload.to_string())
            except ValueError as e:
                raise Failure(f"{key}: schema reply is not JSON: {e}") from None
        if time.monotonic() >= deadline:
            raise Failure(f"{key}: no schema reply within {timeout:g} s")
        time.sleep(0.2)


def make_decoder(schema, key):
    if schema.get("encoding") != "ros2msg":
        raise Failure(f"{key}: schema encoding {schema.get('encoding')!r}, expected 'ros2msg'")
    try:
        record = Schema(id=1, name=schema["name"], encoding="ros2msg", data=schema["data"].encode())
        return DecoderFactory().decoder_for("cdr", record)
    except Exception as e:  # a schema that does not parse, or lacks a field
        raise Failure(f"{key}: schema {schema.get('name')!r} does not parse: {e!r}") from None


def plain(message):
    """A decoded message's fields as JSON values; arrays only by their length."""
    fields = {}
    for name in message.__slots__:
        value = getattr(message, name)
        if hasattr(value, "__slots__"):
            fields[name] = plain(value)
        elif isinstance(value, (list, tuple, bytes, bytearray)) or hasattr(value, "typecode"):
            fields[f"{name}_len"] = len(value)
        elif isinstance(value, float) and not math.isfinite(value):
            fields[name] = str(value)  # JSON has no inf or nan
        else:
            fields[name] = value
    return fields


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--connect", required=True, help="Zenoh endpoint, e.g. tcp/10.77.0.1:7447")
    parser.add_argument("--key", required=True, help="e.g. lewis/sim/robot/laser/RangeFinder")
    parser.add_argument("--count", type=int, default=1, help="messages to print, then exit 0")
    parser.add_argument("--timeout", type=float, default=20.0, help="seconds for each wait")
    args = parser.parse_args()

    try:
        schema_at = schema_key(args.key)
        session = open_session(args.connect, args.timeout)
        try:
            schema = fetch_schema(session, schema_at, args.timeout)
            decode = make_decoder(schema, args.key)
            samples = queue.Queue()
            session.declare_subscriber(args.key, samples.put)
            for _ in range(args.count):
                try:
                    sample = samples.get(timeout=args.timeout)
                except queue.Empty:
                    raise Failure(f"{args.key}: no message within {args.timeout:g} s") from None
                key = str(sample.key_expr)
                try:
                    message = decode(sample.payload.to_bytes())
                except Exception as e:
                    raise Failure(f"{key}: payload of {len(sample.payload)} bytes does not decode "
                                  f"as {schema['name']}: {e}") from None
                print(json.dumps({"key": key, "schema": schema["name"], "msg": plain(message)}),
                      flush=True)
        finally:
            session.close()
    except Failure as e:
        print(f"zenoh_listen: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
