#!/usr/bin/env bash
# The main job: `lewis demo`. The simulated B21r runs the Robot Challenge mission, recorded;
# the laser dies on the way and the broker moves its clients to the sonar; the mission is
# lived again from the recording with another fault and turned into a Rerun file. No hardware. Arguments go to
# `lewis demo` (`--seed N`, `--no-gui`, `--out DIR`, `--fault SPEC`); files in logs/demo/.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
cargo build --release -q -p lewis --locked
exec target/release/lewis demo "$@"
