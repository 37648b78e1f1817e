#!/usr/bin/env python3
"""CPU time of a whole `lewis up` run, per process, from /proc: what the robot really costs.

    scripts/sim-cpu.py [--lewis target/release/lewis] [--robot robots/sim.toml]
                       [--duration 30] [--warmup 5] [--record]
                       [--goal X,Y | --script robots/missions/challenge.seq]

Starts `lewis up ROBOT --duration D` (with `--no-record` unless --record, then into a
temporary file), and every 100 ms reads utime + stime of `lewis up` and of every process
below it (the services, `lewis service NAME`, the mission's programs, `lewis app NAME`,
and the recorder, `lewis record`) from /proc/PID/stat. With `--script`, the run is a whole
mission (the sequencer inside `lewis up`), which ends the run; `--duration` is then only
an upper bound. Prints, per service or program (a program's restarts added up):

- `steady %`: CPU time between the end of the warm-up and the last sample before the
  robot was stopped, over that wall time, as a percentage of one core (what the robot
  costs while it runs at real time);
- `whole run s`: CPU seconds over the whole run, start-up (world loading, IPC set-up,
  process start) included;

and the total of both. The total of the whole run is also taken exactly from the kernel
(wait4's rusage of `lewis up`, which includes every descendant it reaped), as a check on
the sampling. With `--record`, the messages the recorder lost (`lewis info --json`), and
for a mission its wall time and `lewis up`'s exit code (0: the mission succeeded).
Standard library only; Linux only.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import defaultdict

TICK = os.sysconf("SC_CLK_TCK")


def proc_stat(pid: int) -> tuple[int, int] | None:
    """(parent pid, utime + stime in ticks) of a process, None when it is gone."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            text = f.read().decode(errors="replace")
    except OSError:
        return None
    # The command name is in parentheses and may hold spaces: split after the last ')'.
    fields = text[text.rfind(")") + 2 :].split()
    # fields[0] is the state (field 3); ppid is field 4, utime 14, stime 15.
    return int(fields[1]), int(fields[11]) + int(fields[12])


def label(pid: int, root: int, mission: bool) -> str:
    """What a process is: the service's name, `recorder`, a program, or `lewis up`."""
    if pid == root:
        return "lewis up (broker, sequencer)" if mission else "lewis up (broker, goal thread)"
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            argv = [a.decode(errors="replace") for a in f.read().split(b"\0") if a]
    except OSError:
        return f"pid {pid}"
    if len(argv) >= 3 and argv[1] == "service":
        return argv[2]
    if len(argv) >= 2 and argv[1] == "record":
        return "recorder (lewis record)"
    if len(argv) >= 3 and argv[1] == "app":
        return f"program {argv[2]}"
    return " ".join(argv[:3]) or f"pid {pid}"


def descendants(root: int) -> list[int]:
    """`root` and every process below it."""
    children = defaultdict(list)
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        stat = proc_stat(int(name))
        if stat is not None:
            children[stat[0]].append(int(name))
    found, todo = [], [root]
    while todo:
        pid = todo.pop()
        found.append(pid)
        todo.extend(children.get(pid, []))
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--lewis", default="target/release/lewis")
    parser.add_argument("--robot", default="robots/sim.toml")
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--warmup", type=float, default=5.0)
    parser.add_argument("--record", action="store_true", help="record the run (default --no-record)")
    what = parser.add_mutually_exclusive_group()
    what.add_argument("--goal", help="also drive to X,Y (the run still ends at --duration, or on arrival)")
    what.add_argument("--script", help="run this mission (it ends the run; --duration bounds it)")
    args = parser.parse_args()

    out_dir = tempfile.mkdtemp(prefix="lewis-cpu-")
    command = [args.lewis, "up", args.robot, "--duration", f"{args.duration}s"]
    command += ["--namespace", f"cpu-{os.getpid()}"]
    command += ["-o", os.path.join(out_dir, "run.mcap")] if args.record else ["--no-record"]
    if args.goal:
        command += ["--goal", args.goal, "--goal-timeout", f"{args.duration}s"]
    if args.script:
        command += ["--script", args.script]
    started = time.monotonic()
    child = subprocess.Popen(command, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)

    names: dict[int, str] = {}
    first: dict[int, int] = {}  # ticks at the first sample after the warm-up (0 if born later)
    last: dict[int, int] = {}  # ticks at the latest sample
    window_start = window_end = None
    window_last: dict[int, int] = {}
    while True:
        # wait4 rather than poll(): its rusage is the exact total of the whole tree.
        pid, status, usage = os.wait4(child.pid, os.WNOHANG)
        if pid == child.pid:
            child.returncode = os.waitstatus_to_exitcode(status)
            break
        now = time.monotonic() - started
        in_window = now >= args.warmup
        if in_window and window_start is None:
            window_start = now
        for pid in descendants(child.pid):
            stat = proc_stat(pid)
            if stat is None:
                continue
            # Labelled again until it has exec'd: a child caught between fork and exec still
            # has the cmdline of `lewis up`.
            # (Or the `/bin/sh` of a mission's program wrapper, which execs `lewis app`.)
            if pid not in names or names[pid].startswith(("lewis up", "pid ", args.lewis, "/bin/sh")):
                names[pid] = label(pid, child.pid, bool(args.script))
            last[pid] = stat[1]
            if in_window and pid not in first:
                # A process seen for the first time inside the window started inside it.
                first[pid] = stat[1] if now - window_start < 0.15 else 0
        # The robot is stopped at --duration: the window ends just before. A mission ends
        # the run itself, so its window ends at the last sample taken while it ran.
        if args.script or now < args.duration - 0.3:
            window_end = now
            window_last = dict(last)
        time.sleep(0.1)
    exact = usage.ru_utime + usage.ru_stime
    wall = time.monotonic() - started

    steady = defaultdict(float)
    whole = defaultdict(float)
    for pid, name in names.items():
        whole[name] += last[pid] / TICK
        if window_start is not None and pid in window_last:
            steady[name] += (window_last[pid] - first.get(pid, 0)) / TICK
    span = (window_end or 0) - (window_start or 0)
    record = "recording to a temporary file" if args.record else "--no-record"
    print(f"# {' '.join(command)}")
    print(f"# {record}; steady window {window_start or 0:.1f}-{window_end or 0:.1f} s; {os.cpu_count()} cores")
    print(f"{'process':34} {'steady % of a core':>19} {'whole run s':>12}")
    for name in sorted(whole, key=lambda n: -whole[n]):
        if whole[name] == 0 and steady[name] == 0:
            continue  # a child seen only between fork and exec
        pct = 100 * steady[name] / span if span > 0 else 0.0
        print(f"{name:34} {pct:19.1f} {whole[name]:12.2f}")
    total_pct = 100 * sum(steady.values()) / span if span > 0 else 0.0
    print(f"{'total (sampled)':34} {total_pct:19.1f} {sum(whole.values()):12.2f}")
    print(f"{'total (kernel, wait4 rusage)':34} {'':19} {exact:12.2f}")
    code = os.waitstatus_to_exitcode(status)
    if args.script:
        verdict = "succeeded" if code == 0 else f"failed (lewis up exited with {code})"
        print(f"# mission {verdict}: {wall:.1f} s of wall time")
    if args.record:
        path = os.path.join(out_dir, "run.mcap")
        if os.path.exists(path):
            print(f"# recording: {os.path.getsize(path) / 1e6:.1f} MB in {wall:.0f} s ({path})")
            info = subprocess.run([args.lewis, "info", "--json", path], capture_output=True, text=True)
            if info.returncode == 0:
                lost = json.loads(info.stdout).get("lost_messages", {})
                print(f"# recorder lost {sum(lost.values())} messages on {len(lost)} channels")
    if code != 0:
        print(f"lewis up exited with {code}", file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main())
