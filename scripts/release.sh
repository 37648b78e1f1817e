#!/usr/bin/env bash
# Makes a release archive for a robot: the lewis binary built here (release, locked), the
# robot files, missions, worlds and colour files, and the systemd unit, so nothing is built
# on the robot. Unpack it into /opt/lewis there (README, "Deploying on the robot").
#
#   scripts/release.sh [--no-viewer] [OUT_DIR]     # default OUT_DIR: target/release-archive
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
features=()
if [ "${1:-}" = "--no-viewer" ]; then
    # Without Rerun: a smaller binary that builds in half the time (no `lewis view`); with
    # the bridge, for a robot on more than one host.
    features=(--no-default-features --features hosts)
    shift
fi
out=${1:-target/release-archive}
version=$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
arch=$(uname -m)
name="lewis-$version-$arch-linux"
cargo build --release --locked -p lewis "${features[@]}"
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/$name/bin"
cp target/release/lewis "$stage/$name/bin/"
cp -r robots "$stage/$name/"
cp README.md ARCHITECTURE.md "$stage/$name/"
mkdir -p "$out"
tar -C "$stage" -czf "$out/$name.tar.gz" "$name"
(cd "$out" && sha256sum "$name.tar.gz" > "$name.tar.gz.sha256")
echo "$out/$name.tar.gz"
