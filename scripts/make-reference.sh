#!/usr/bin/env bash
# Makes the reference recording again: the simulated B21r of robots/sim-reference.toml (the
# simulated robot without its camera) drives from the lobby into the corridor, recorded by
# `lewis up`, into tests/data/reference/sim-goal.mcap, which the replay regression tests replay
# (replay/tests/reference.rs). Then it checks that the new recording replays to itself.
#
#   scripts/make-reference.sh              # builds lewis (release) first
#   LEWIS=target/debug/lewis scripts/make-reference.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
if [[ -z ${LEWIS:-} ]]; then
    cargo build --release -q -p lewis
    LEWIS=target/release/lewis
fi
out=tests/data/reference/sim-goal.mcap
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "== lewis up robots/sim-reference.toml --goal 12,13 -o $out"
"$LEWIS" up robots/sim-reference.toml --goal 12,13 --goal-timeout 120s \
    -o "$tmp/sim-goal.mcap" --namespace "reference-$$"
echo "== lewis replay $out --check (an unchanged replay must match it)"
"$LEWIS" replay "$tmp/sim-goal.mcap" -o "$tmp/replay.mcap" --check
mkdir -p tests/data/reference
mv "$tmp/sim-goal.mcap" "$out"
echo "== wrote $out ($(stat -c %s "$out") bytes)"
