#!/usr/bin/env bash
# The main job: `lewis demo`. The simulated B21r runs the Robot Challenge mission, recorded;
# the laser dies on the way and the broker moves its clients to the sonar; the mission is
# lived again from the recording with another fault and turned into a Rerun file. No
# hardware. Arguments go to `lewis demo` (`--seed N`, `--no-gui`, `--out DIR`, `--fault
# SPEC`); files in logs/demo/.
#
# The mission comes first: `lewis` is built in the `demo` profile (Cargo.toml) without the
# viewer (Rerun) and the bridge between hosts (Zenoh), and runs it; then the viewer is built
# and writes the picture and the Rerun file (`lewis demo --pictures-only`).
# docs/src/first-run.md says where the time goes.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
lewis=${CARGO_TARGET_DIR:-$root/target}/demo/lewis
# A progress bar on a terminal; elsewhere no line per crate.
quiet=(-q)
[ -t 2 ] && quiet=()
say() { printf '%s: %s\n' "$(date +%T)" "$1" >&2; }
say "building lewis for the mission (without the viewer: a few minutes)"
cargo build --profile demo "${quiet[@]}" --locked -p lewis --no-default-features
status=0
"$lewis" demo "$@" || status=$?
say "building the viewer (Rerun) for the picture and the Rerun file"
if cargo build --profile demo "${quiet[@]}" --locked -p lewis --no-default-features --features viewer; then
    "$lewis" demo "$@" --pictures-only || true
else
    say "the viewer did not build: no picture, no Rerun file"
fi
exit "$status"
