#!/usr/bin/env bash
# The ROS 2 gateway's latency: from a /scan with an obstacle ahead, published by a Cyclone
# DDS participant, to the zero /cmd_vel with which Lewis's avoider stops the robot (the
# laser's gateway, the avoider's reflex, the vector mover, the base's gateway), against the
# same DDS round trip through a plain Cyclone participant that answers each scan at once,
# in the same run (tools/python/ros2_latency_bench.py says how each is measured).
#
#   scripts/bench-ros2.sh [TRIALS]        # default 100; about a second a trial
#
# Everything runs in a network namespace of its own with only a loopback device (root, or
# user namespaces), so nothing leaves the machine. Needs .venv (scripts/setup-python.sh) and
# a built lewis: $LEWIS_EXE, else target/release/lewis, else target/debug/lewis.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
trials=${1:-100}
target=${CARGO_TARGET_DIR:-${LEWIS_TARGET_DIR:-$HOME/.cache/lewis/target}}
lewis=${LEWIS_EXE:-}
if [ -z "$lewis" ]; then
    for candidate in "$target/release/lewis" "$target/debug/lewis"; do
        if [ -x "$candidate" ]; then lewis=$candidate; break; fi
    done
fi
[ -n "$lewis" ] || { echo "no lewis: build it, or set LEWIS_EXE" >&2; exit 2; }
python=$root/.venv/bin/python
[ -x "$python" ] || { echo "no .venv: run scripts/setup-python.sh" >&2; exit 2; }
work=$(mktemp -d)
[ -n "${LEWIS_BENCH_KEEP:-}" ] || trap 'rm -rf "$work"' EXIT
# The TurtleBot 4's robot file with the laser at the robot's centre looking ahead (the
# bench's scans are the robot's view), and patience for a scene that never changes.
sed -e 's/^mount = { x_m = -0.04, y_m = 0.0, heading_deg = 90.0, height_m = 0.193 }/mount = { x_m = 0.0, y_m = 0.0, heading_deg = 0.0, height_m = 0.193 }/' \
    -e 's/^robot_radius_m = 0.18$/robot_radius_m = 0.18\nno_progress_timeout_ms = 600000\nfail_after_ms = 600000/' \
    "$root/robots/turtlebot4.toml" > "$work/robot.toml"
export LEWIS_BENCH_PYTHON=$python LEWIS_BENCH_TOOL=$root/tools/python/ros2_latency_bench.py \
    LEWIS_BENCH_LEWIS=$lewis LEWIS_BENCH_WORK=$work LEWIS_BENCH_TRIALS=$trials
unshare --net -- bash -euo pipefail -c '
    ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo
    cd "$LEWIS_BENCH_WORK"
    domain=$(( ($$ % 200) + 20 ))
    # A plain participant that answers each scan.
    "$LEWIS_BENCH_PYTHON" "$LEWIS_BENCH_TOOL" echo --domain $domain --max-seconds 600 \
        > echo.out < /dev/null &
    echo_pid=$!
    plain=$("$LEWIS_BENCH_PYTHON" "$LEWIS_BENCH_TOOL" measure --plain --domain $domain \
        --trials "$LEWIS_BENCH_TRIALS" | tail -1)
    kill $echo_pid 2>/dev/null || true
    wait $echo_pid 2>/dev/null || true
    # Lewis, driving toward a goal far ahead.
    ROS_DOMAIN_ID=$domain "$LEWIS_BENCH_LEWIS" up robot.toml --no-record \
        --goal 1000,0 --goal-frame odom --goal-timeout 60m > /dev/null 2> lewis.log < /dev/null &
    lewis_pid=$!
    through=$("$LEWIS_BENCH_PYTHON" "$LEWIS_BENCH_TOOL" measure --domain $domain \
        --trials "$LEWIS_BENCH_TRIALS" | tail -1) || true
    kill -INT $lewis_pid 2>/dev/null || true
    wait $lewis_pid 2>/dev/null || true
    echo "plain Cyclone round trip: $plain"
    echo "through Lewis:            $through"
    [ -n "$through" ] || { echo "lewis up wrote:" >&2; tail -30 lewis.log >&2; exit 1; }
'
