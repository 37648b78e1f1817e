#!/usr/bin/env bash
# CMVision against OpenCV in one run (components/perception/benches/cmvision.rs): the same
# frames and colour classes, both timed, the region counts compared. Makes .venv-bench with OpenCV
# (opencv-python-headless and numpy from PyPI) the first time.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
python=${PYTHON:-python3}
if [ ! -x .venv-bench/bin/python ]; then
    "$python" -m venv .venv-bench
fi
.venv-bench/bin/pip install --quiet --disable-pip-version-check -r tools/opencv/requirements.txt
LEWIS_OPENCV_PYTHON="$root/.venv-bench/bin/python" cargo bench --workspace --locked --bench cmvision
