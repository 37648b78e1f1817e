#!/usr/bin/env bash
# Creates .venv with the independent MCAP readers the interop tests use
# (Python `mcap`, `mcap-ros2-support`, `pymcap-cli`). Safe to run again.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
python=${PYTHON:-python3}
if [ ! -x "$root/.venv/bin/python" ]; then
    "$python" -m venv "$root/.venv"
fi
"$root/.venv/bin/pip" install --quiet --disable-pip-version-check -r "$root/tools/python/requirements.txt"
echo "Python readers installed in $root/.venv"
