#!/usr/bin/env python3
"""What a binary holds: its size, stripped and not, its largest sections, and its code by
crate (symbols from `nm -C -S`, each counted for the crate its path starts with; generic
code instantiated from `core` and `alloc` counts there, as in `cargo bloat`).

    scripts/binary-size.py target/release/lewis [--crates 20]
"""

import argparse
import collections
import os
import re
import subprocess
import tempfile


def mb(n):
    return f"{n / 1e6:.1f} MB"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("binary")
    parser.add_argument("--crates", type=int, default=20, help="crates listed")
    args = parser.parse_args()

    size = os.path.getsize(args.binary)
    with tempfile.TemporaryDirectory() as tmp:
        stripped = os.path.join(tmp, "stripped")
        subprocess.run(["strip", "-o", stripped, args.binary], check=True)
        stripped_size = os.path.getsize(stripped)
    print(f"{args.binary}: {mb(size)}, {mb(stripped_size)} stripped")

    sections = []
    for line in subprocess.run(
        ["size", "-A", args.binary], check=True, capture_output=True, text=True
    ).stdout.splitlines():
        fields = line.split()
        if len(fields) == 3 and fields[0].startswith(".") and fields[1].isdigit():
            sections.append((int(fields[1]), fields[0]))
    debug = sum(n for n, name in sections if name.startswith(".debug"))
    print(f"debug info: {mb(debug)}; largest sections:")
    for n, name in sorted(sections, reverse=True)[:6]:
        print(f"  {mb(n):>9}  {name}")

    by_crate = collections.Counter()
    total = 0
    nm = subprocess.run(
        ["nm", "-C", "-S", "--size-sort", args.binary],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    for line in nm.splitlines():
        parts = line.split(" ", 3)
        if len(parts) < 4 or parts[2] not in "tTwW":
            continue
        n = int(parts[1], 16)
        name = re.sub(r"^(dyn |impl |mut |const )", "", parts[3].lstrip("<&*"))
        m = re.match(r"([A-Za-z_][A-Za-z0-9_]*)::", name)
        by_crate[m.group(1) if m else "(C and unnamed)"] += n
        total += n
    print(f"code (function symbols): {mb(total)}; by crate:")
    for crate, n in by_crate.most_common(args.crates):
        print(f"  {mb(n):>9}  {n / total:5.1%}  {crate}")


if __name__ == "__main__":
    main()
