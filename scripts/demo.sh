#!/usr/bin/env bash
# The main job: the simulated B21r drives to a goal, recorded; the recording is described,
# re-simulated with the laser failing half-way, and turned into a Rerun file. No hardware.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
cargo build --release -q --workspace --locked
lewis=target/release/lewis
mkdir -p logs
# The demo's own outputs from an earlier run: the recorder never overwrites a recording
# (it would run the robot without recording), so they go first.
rm -f logs/demo.mcap logs/demo-replay.mcap logs/demo-replay.json logs/demo.rrd
echo "== lewis up robots/sim.toml --goal 12,13 -o logs/demo.mcap (drive from the lobby into the corridor)"
$lewis up robots/sim.toml --goal 12,13 -o logs/demo.mcap --namespace "demo-$$"
echo "== lewis info logs/demo.mcap"
$lewis info logs/demo.mcap
echo "== lewis replay logs/demo.mcap --inject-fault laser (what if the laser had died half-way?)"
$lewis replay logs/demo.mcap -o logs/demo-replay.mcap --inject-fault laser --report logs/demo-replay.json
echo "== lewis view logs/demo.mcap --save logs/demo.rrd"
$lewis view logs/demo.mcap --save logs/demo.rrd
echo "open it with: rerun logs/demo.rrd   (pip install rerun-sdk==0.36.3)"
