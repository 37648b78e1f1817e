#!/usr/bin/env bash
# Renders the Rerun viewer with a recording of the paper's failover loaded, and saves a
# screenshot: the simulated B21r drives to (12, 13) while its laser is killed three times
# (the broker restarts it twice, then moves the obstacle avoider to the sonar), `lewis view`
# turns the recording into an .rrd file, and the PyPI Rerun viewer (.venv, from
# scripts/setup-python.sh) draws it under Xvfb with Mesa's software Vulkan (lavapipe; its
# software OpenGL lacks a texture format Rerun needs) and saves its own screenshot.
#
#   scripts/screenshot-viewer.sh [OUT_DIR]      # default: /tmp/lewis-viewer-shot
#   SKIP_DRIVE=1 scripts/screenshot-viewer.sh   # reuse OUT_DIR/run.mcap
#
# Needs: target/debug/lewis (cargo build --workspace), .venv with rerun-sdk, Xvfb and
# lavapipe (apt-get install -y xvfb mesa-vulkan-drivers). Not run in CI: it drives the
# robot for about a minute. Writes OUT_DIR/run.mcap, OUT_DIR/run.rrd, OUT_DIR/viewer.png.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
out=${1:-/tmp/lewis-viewer-shot}
lewis=${LEWIS:-$root/target/debug/lewis}
rerun="$root/.venv/bin/rerun"
size=${SIZE:-1600x1000}
namespace="shot-$$"
mkdir -p "$out"

for tool in "$lewis" "$rerun"; do
    [ -x "$tool" ] || { echo "missing $tool (cargo build --workspace; scripts/setup-python.sh)" >&2; exit 2; }
done
command -v Xvfb > /dev/null || { echo "missing Xvfb: apt-get install -y xvfb" >&2; exit 2; }
lavapipe=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json
[ -f "$lavapipe" ] || { echo "missing lavapipe: apt-get install -y mesa-vulkan-drivers" >&2; exit 2; }

pids=()
cleanup() {
    for pid in "${pids[@]}"; do
        kill "$pid" 2> /dev/null || true
    done
}
trap cleanup EXIT

# 1. The drive, recorded, with the laser killed until the broker gives it up.
if [ -z "${SKIP_DRIVE:-}" ]; then
rm -f "$out/run.mcap"
"$lewis" up robots/sim.toml --goal 12,13 --goal-timeout 120s --namespace "$namespace" \
    -o "$out/run.mcap" > "$out/up.log" 2>&1 &
up=$!
pids+=("$up")
until grep -q "goal 1 sent" "$out/up.log"; do
    kill -0 "$up" 2> /dev/null || { cat "$out/up.log" >&2; exit 1; }
    sleep 0.5
done
sleep 3
for kill in 1 2 3; do
    # The broker restarts the laser with a backoff: wait until it runs again.
    for _ in $(seq 1 40); do
        if "$lewis" fault laser --kill --namespace "$namespace" > /dev/null 2>&1; then
            echo "laser killed ($kill)"
            break
        fi
        sleep 0.25
    done
    sleep 2
done
wait "$up" || echo "lewis up ended with $? (see $out/up.log)"
fi

# 2. The Rerun file.
"$lewis" view "$out/run.mcap" --save "$out/run.rrd"
"$rerun" rrd verify "$out/run.rrd"

# 3. The viewer under Xvfb, which saves its own screenshot. The window is drawn at twice
# its size in points; the screen is five times as wide, so that the pointer (at the
# screen's centre) hovers over nothing. Rerun
# 0.36 may panic while quitting after the screenshot is saved: the file is what counts.
display=":$((90 + $$ % 100))"
width=${size%x*}
height=${size#*x}
Xvfb "$display" -screen 0 "$((5 * width))x$((2 * height))x24" -nolisten tcp > "$out/xvfb.log" 2>&1 &
pids+=("$!")
sleep 1
rm -f "$out/viewer.png"
DISPLAY="$display" VK_ICD_FILENAMES="$lavapipe" timeout 300 "$rerun" "$out/run.rrd" \
    --port "$((20000 + $$ % 10000))" --renderer vulkan --window-size "$size" \
    --screenshot-to "$out/viewer.png" > "$out/rerun.log" 2>&1 || true
[ -s "$out/viewer.png" ] || { tail -20 "$out/rerun.log" >&2; exit 1; }
echo "wrote $out/viewer.png"
