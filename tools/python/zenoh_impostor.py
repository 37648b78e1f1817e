r"""A Zenoh peer that claims to be a host of a Lewis robot but speaks another version of the
bridge's protocol: what a host running an older or newer `lewis` looks like to the others.

It declares the host's liveliness token `lewis/ROBOT/@hosts/HOST` and beats on
`lewis/ROBOT/HOST/@beat` every 10 ms, the payload being the protocol version it claims.
With --connect it joins a robot host as another host would; with --listen it stands where
a robot host listens, for another host to connect to.

Usage:
  zenoh_impostor.py --robot sim --host workstation --connect tcp/10.0.0.1:7447 \
                    --version 99 --seconds 3

Prints `beating` once its session is open, then exits 0 after --seconds; exits 1 with one
line on stderr when the session cannot be opened.
"""

import argparse
import json
import sys
import time

import zenoh


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", required=True)
    parser.add_argument("--host", required=True)
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--connect", help="an endpoint to connect to (tcp/ADDR:PORT)")
    where.add_argument("--listen", help="an endpoint to listen on (tcp/ADDR:PORT)")
    parser.add_argument("--version", default="99", help="the protocol version it claims")
    parser.add_argument("--seconds", type=float, default=3.0)
    args = parser.parse_args()

    config = zenoh.Config()
    config.insert_json5("mode", json.dumps("peer"))
    config.insert_json5("scouting/multicast/enabled", "false")
    if args.connect:
        config.insert_json5("connect/endpoints", json.dumps([args.connect]))
        config.insert_json5("connect/timeout_ms", "10000")
        config.insert_json5("connect/exit_on_failure", "true")
        config.insert_json5("listen/endpoints", "[]")
    else:
        config.insert_json5("listen/endpoints", json.dumps([args.listen]))
    try:
        session = zenoh.open(config)
    except zenoh.ZError as e:
        print(f"cannot open a Zenoh session: {str(e).split(' at /')[0]}", file=sys.stderr)
        return 1
    token = session.liveliness().declare_token(f"lewis/{args.robot}/@hosts/{args.host}")
    beat = session.declare_publisher(f"lewis/{args.robot}/{args.host}/@beat")
    print("beating", flush=True)
    end = time.monotonic() + args.seconds
    while time.monotonic() < end:
        beat.put(args.version)
        time.sleep(0.01)
    token.undeclare()
    session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
