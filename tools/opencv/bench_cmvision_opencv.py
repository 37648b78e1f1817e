#!/usr/bin/env python3
"""OpenCV's answer to CMVision, timed on the frames and colour classes of the Rust benchmark.

The Rust benchmark (`scripts/bench-cmvision.sh`, which runs `cargo bench --bench cmvision`)
writes the 640x480 RGB frames it times as PNG files into a folder and runs this script on
them with the same colour file (robots/colors/bench6.txt, Player format, YUV thresholds). It
times, per frame, inside Python around the OpenCV calls only:

    yuv = cv2.transform(rgb, M)                      # BT.601 integer approximation, as Lewis
    for each colour:
        mask = cv2.inRange(yuv, lo, hi)
        cv2.connectedComponentsWithStats(mask, connectivity=4)

M is the matrix of components/perception/src/cmvision/yuv.rs divided by 256, with the offsets
(16, 128, 128) plus 1/1024: Lewis floors (a + 128) / 256, cv2.transform rounds a / 256 to the
nearest (ties to even); the extra 1/1024 sends the ties up, and is too small to move any other
value (a / 256 is a multiple of 1/256, exact in float32), so both give the same YUV. The
script checks it: it counts the pixels whose class differs from the exact integer formula's
(computed outside the timing with numpy), expected 0.

Per colour it reports the number of 4-connected components, which CMVision's region count
(with a minimum area of 1 and no density merging) must equal.

OpenCV runs on one thread by default (as CMVision does); --threads N lets it use more.

Setup: scripts/bench-cmvision.sh makes .venv-bench (opencv-python-headless, numpy).
Alone: .venv-bench/bin/python tools/opencv/bench_cmvision_opencv.py --frames-dir DIR [--json]
"""

import argparse
import json
import re
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[2]
FRAMES = ["fruits", "stuff"]
HEIGHT, WIDTH = 480, 640


def load_player_thresholds(path):
    """(name, (ylo, yhi), (ulo, uhi), (vlo, vhi)) per colour of a Player colour file."""
    names, thresholds, section = [], [], None
    for number, raw in enumerate(path.read_text().splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if line.startswith("["):
            section = line.strip("[] ").lower()
            continue
        if section in ("colors", "colours"):
            match = re.match(r"\(\s*\d+\s*,\s*\d+\s*,\s*\d+\s*\)\s*\S+\s*(?:\d+\s+)?(.*)$", line)
            if not match:
                sys.exit(f"{path}:{number}: not a colour line: {raw}")
            names.append(match.group(1).strip() or f"color{len(names)}")
        elif section == "thresholds":
            values = [int(v) for v in re.findall(r"-?\d+", line)]
            if len(values) != 6:
                sys.exit(f"{path}:{number}: not a threshold line: {raw}")
            clamped = [min(max(v, 0), 255) for v in values]
            thresholds.append(tuple(zip(clamped[0::2], clamped[1::2])))
    if len(names) != len(thresholds):
        sys.exit(f"{path}: {len(names)} colours but {len(thresholds)} thresholds")
    return [(n, *t) for n, t in zip(names, thresholds)]


def exact_yuv(rgb):
    """The integer formula of components/perception/src/cmvision/yuv.rs."""
    r, g, b = (rgb[..., k].astype(np.int32) for k in range(3))
    y = ((66 * r + 129 * g + 25 * b + 128) >> 8) + 16
    u = ((-38 * r - 74 * g + 112 * b + 128) >> 8) + 128
    v = ((112 * r - 94 * g - 18 * b + 128) >> 8) + 128
    return np.stack([y, u, v], axis=-1).astype(np.uint8)


def class_codes(yuv, classes):
    """Per pixel the lowest colour whose box contains it, len(classes) for none."""
    codes = np.full(yuv.shape[:2], len(classes), np.uint8)
    for k in reversed(range(len(classes))):
        _, (ylo, yhi), (ulo, uhi), (vlo, vhi) = classes[k]
        lo = np.array([ylo, ulo, vlo], np.uint8)
        hi = np.array([yhi, uhi, vhi], np.uint8)
        codes[np.all((yuv >= lo) & (yuv <= hi), axis=-1)] = k
    return codes


def boxes_overlap(a, b):
    return all(max(a[i][0], b[i][0]) <= min(a[i][1], b[i][1]) for i in (1, 2, 3))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames-dir", type=Path, default=Path(tempfile.gettempdir()) / "lewis-cmvision-bench")
    parser.add_argument("--frames", nargs="+", default=FRAMES, help="frame names (NAME.png in --frames-dir)")
    parser.add_argument("--colors", type=Path, default=REPO / "robots/colors/bench6.txt")
    parser.add_argument("--repetitions", type=int, default=300, help="timed runs per frame")
    parser.add_argument("--threads", type=int, default=1, help="OpenCV threads (default 1, as CMVision)")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    args = parser.parse_args()

    cv2.setNumThreads(args.threads)
    classes = load_player_thresholds(args.colors)
    overlapping = [
        (a[0], b[0]) for i, a in enumerate(classes) for b in classes[i + 1:] if boxes_overlap(a, b)
    ]
    if overlapping:
        print(f"warning: overlapping classes {overlapping}: OpenCV counts their pixels twice", file=sys.stderr)
    bounds = [
        (np.array([y[0], u[0], v[0]], np.uint8), np.array([y[1], u[1], v[1]], np.uint8))
        for _, y, u, v in classes
    ]
    # Lewis computes floor((a + 128) / 256) + offset; cv2.transform rounds a / 256 + offset to
    # nearest with ties to even: 1/1024 more sends every tie up, as the floor does.
    matrix = np.array(
        [[66, 129, 25, 16 * 256], [-38, -74, 112, 128 * 256], [112, -94, -18, 128 * 256]], np.float32
    ) / 256.0
    matrix[:, 3] += 1.0 / 1024.0

    results = {"opencv_version": cv2.__version__, "threads": args.threads, "frames": {}}
    for name in args.frames:
        path = args.frames_dir / f"{name}.png"
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            sys.exit(f"{path} is missing: run `cargo bench -p lewis-perception --bench cmvision` first, it writes the frames")
        rgb = np.ascontiguousarray(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        if rgb.shape != (HEIGHT, WIDTH, 3):
            sys.exit(f"{path}: expected {WIDTH}x{HEIGHT}, found {rgb.shape[1]}x{rgb.shape[0]}")

        def segment():
            yuv = cv2.transform(rgb, matrix)
            return yuv, [cv2.connectedComponentsWithStats(cv2.inRange(yuv, lo, hi), connectivity=4) for lo, hi in bounds]

        for _ in range(10):
            segment()
        times_ns = []
        for _ in range(args.repetitions):
            start = time.perf_counter_ns()
            segment()
            times_ns.append(time.perf_counter_ns() - start)
        times_ns.sort()

        yuv, components = segment()
        per_colour = {classes[k][0]: count - 1 for k, (count, _, _, _) in enumerate(components)}
        regions = sum(per_colour.values())
        differing = int(np.count_nonzero(class_codes(yuv, classes) != class_codes(exact_yuv(rgb), classes)))
        median_s = times_ns[len(times_ns) // 2] / 1e9
        results["frames"][name] = {
            "regions": regions,
            "regions_per_colour": per_colour,
            "median_ms": median_s * 1e3,
            "min_ms": times_ns[0] / 1e6,
            "fps_median": 1.0 / median_s,
            "pixels_classified_differently_from_exact_formula": differing,
        }

    if args.json:
        print(json.dumps(results, indent=2))
        return
    print(f"OpenCV {results['opencv_version']}, {args.threads} thread(s), {len(classes)} colours, 640x480")
    for name, r in results["frames"].items():
        print(
            f"{name:7} {r['fps_median']:8.1f} frames/s (median {r['median_ms']:.3f} ms, min {r['min_ms']:.3f} ms), "
            f"{r['regions']} regions, {r['pixels_classified_differently_from_exact_formula']} pixels off the exact formula"
        )


if __name__ == "__main__":
    main()
