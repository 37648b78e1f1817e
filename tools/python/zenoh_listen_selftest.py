"""Self-test of zenoh_listen.py without Lewis: a Python Zenoh node stands in for the bridge.

It listens on tcp/127.0.0.1:<free port> (multicast scouting off), answers the schema query
of /laser/RangeFinder with the schema from a Lewis MCAP recording, and publishes that
channel's CDR bytes straight from the recording, as the bridge does. It then checks that
zenoh_listen.py prints them decoded, and that it fails with one line when it should.

Usage: zenoh_listen_selftest.py FILE.mcap   (made by e.g. `lewis up robots/sim.toml
--duration 5s -o FILE.mcap`). Prints 'N passed, N failed'; exits 1 on any failure.
"""

import json
import os
import socket
import subprocess
import sys
import threading

import zenoh
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from zenoh_listen import plain  # noqa: E402

CHANNEL = "/laser/RangeFinder"
KEY = "lewis/sim/robot" + CHANNEL
LISTEN = os.path.join(os.path.dirname(os.path.abspath(__file__)), "zenoh_listen.py")


def read_channel(path):
    """(schema record, [CDR bytes], {expected JSON line of msg}) of CHANNEL in the MCAP."""
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        schema, payloads, expected = None, [], set()
        for schema, _channel, message, decoded in reader.iter_decoded_messages(topics=[CHANNEL]):
            payloads.append(message.data)
            expected.add(json.dumps(plain(decoded), sort_keys=True))
    if not payloads:
        sys.exit(f"{path}: no message on {CHANNEL}")
    return schema, payloads, expected


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def bridge(mode, endpoint, schema, payloads, stop):
    """A stand-in for the Rust bridge: schema queryable plus a publisher, until `stop`."""
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("listen/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(config)
    answer = json.dumps({"name": schema.name, "encoding": schema.encoding,
                         "data": schema.data.decode()})
    prefix = "lewis/sim/robot/"
    # Schemas for the real channel, for one whose payloads are cut short, and for one
    # that never publishes; other channels get no reply.
    answered = {prefix + "@schema/" + c for c in (CHANNEL.lstrip("/"), "bad/Range", "quiet/Range")}

    def on_query(query):
        if str(query.key_expr) in answered:
            query.reply(query.key_expr, answer, encoding="application/json")

    queryable = session.declare_queryable(prefix + "@schema/**", on_query)
    encoding = zenoh.Encoding("application/cdr").with_schema(schema.name)
    publisher = session.declare_publisher(KEY, encoding=encoding)
    bad = session.declare_publisher(prefix + "bad/Range", encoding=encoding)
    i = 0
    while not stop.wait(0.05):
        publisher.put(payloads[i % len(payloads)])
        bad.put(payloads[i % len(payloads)][:12])
        i += 1
    queryable.undeclare()
    session.close()


def listen(*args):
    return subprocess.run([sys.executable, LISTEN, *args], capture_output=True, text=True,
                          timeout=60)


def main():
    schema, payloads, expected = read_channel(sys.argv[1])
    passed, failed = 0, 0

    def check(name, ok, detail):
        nonlocal passed, failed
        print(f"{'ok  ' if ok else 'FAIL'} {name}" + ("" if ok else f": {detail}"))
        passed, failed = passed + ok, failed + (not ok)

    for mode in ("peer", "router"):
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        stop = threading.Event()
        thread = threading.Thread(target=bridge, args=(mode, endpoint, schema, payloads, stop))
        # The listener starts first: it must keep trying to connect until the bridge is up.
        first = subprocess.Popen([sys.executable, LISTEN, "--connect", endpoint, "--key", KEY,
                                  "--count", "3", "--timeout", "20"],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        stop.wait(1.5)
        thread.start()
        try:
            stdout, stderr = first.communicate(timeout=60)
            run = subprocess.CompletedProcess(first.args, first.returncode, stdout, stderr)
            lines = run.stdout.splitlines()
            good = run.returncode == 0 and len(lines) == 3
            for line in lines:
                got = json.loads(line)
                good = good and got["key"] == KEY and got["schema"] == schema.name
                good = good and json.dumps(got["msg"], sort_keys=True) in expected
            check(f"{mode}: started before the bridge, 3 messages decoded as in the MCAP", good,
                  f"exit {run.returncode}, stdout {run.stdout!r}, stderr {run.stderr!r}")
            if lines:
                print("     " + lines[0])

            run = listen("--connect", endpoint, "--key", "lewis/sim/robot/bad/Range",
                         "--count", "1", "--timeout", "10")
            err = run.stderr.strip().splitlines()
            check(f"{mode}: a payload that does not decode fails naming the key",
                  run.returncode == 1 and len(err) == 1 and "bad/Range" in err[0]
                  and "does not decode" in err[0], f"exit {run.returncode}, stderr {run.stderr!r}")
            if err:
                print("     " + err[0])

            run = listen("--connect", endpoint, "--key", "lewis/sim/robot/quiet/Range",
                         "--count", "1", "--timeout", "2")
            check(f"{mode}: no message fails in one line", run.returncode == 1
                  and "no message within 2 s" in run.stderr and len(run.stderr.splitlines()) == 1,
                  f"exit {run.returncode}, stderr {run.stderr!r}")

            run = listen("--connect", endpoint, "--key", "lewis/sim/robot/no/Such",
                         "--count", "1", "--timeout", "2")
            check(f"{mode}: no schema reply fails in one line", run.returncode == 1
                  and "no schema reply" in run.stderr and len(run.stderr.splitlines()) == 1,
                  f"exit {run.returncode}, stderr {run.stderr!r}")
        finally:
            stop.set()
            thread.join()

    run = listen("--connect", f"tcp/127.0.0.1:{free_port()}", "--key", KEY, "--timeout", "2")
    check("nothing listening fails in one line", run.returncode == 1
          and "cannot connect" in run.stderr and len(run.stderr.splitlines()) == 1,
          f"exit {run.returncode}, stderr {run.stderr!r}")

    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
