#!/usr/bin/env bash
# The suite's benchmark (README, "A regression suite"): 40 jobs (31 copies of the reference
# recording and the 9 CARMEN logs of ../shared/data, imported when planned), run with
# `lewis test --jobs 1` and `--jobs 2`; prints the wall times, the speed-up, and the jobs'
# overhead (the time a job spends outside its replay) as a share of their time.
#   scripts/bench-suite.sh [LEWIS]    (default: target/debug/lewis)
set -euo pipefail
cd "$(dirname "$0")/.."
lewis=${1:-target/debug/lewis}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/runs"
for i in $(seq -w 1 31); do cp tests/data/reference/sim-goal.mcap "$work/runs/sim-goal-$i.mcap"; done
cp ../shared/data/carmen/*.log.gz "$work/runs/"
# Planned once first: the imports are the plan's, not the jobs'.
"$lewis" test "$work/runs" --plan "$work/plan/plan.json" >/dev/null
for jobs in 1 2; do
    start=$(date +%s.%N)
    "$lewis" test "$work/runs" --out "$work/j$jobs" --jobs "$jobs" >/dev/null || true
    end=$(date +%s.%N)
    echo "--jobs $jobs: $(echo "$end - $start" | bc) s wall (planning included)"
    python3 - "$work/j$jobs/timing.json" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))
print(f"  {len(t['jobs'])} jobs, {t['total_wall_ms'] / 1000:.1f} s of jobs; overhead "
      f"{100 * t['total_overhead_ms'] / t['total_wall_ms']:.3f}% of the jobs' time")
PY
done
cmp "$work/j1/report.json" "$work/j2/report.json" && echo "reports: the same bytes"
