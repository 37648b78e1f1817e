#!/usr/bin/env bash
# The main job, as far as it is built: see README.md ("State of the main job").
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
cargo build --release -q -p lewis
lewis=target/release/lewis
echo "== lewis idl check interfaces/idl"
$lewis idl check interfaces/idl
echo "== lewis idl show RangeFinder (the paper's Figure 2, as ROS 2 sees it)"
$lewis idl show RangeFinder | head -25
echo "== lewis info ../shared/data/mcap/talker.mcap --messages 3 (a recording written by ROS 2)"
$lewis info ../shared/data/mcap/talker.mcap --messages 3
echo "== lewis seq check robots/missions/extensions.seq (its programs are not installed here: the checker says so)"
$lewis seq check robots/missions/extensions.seq || true
