#!/usr/bin/env bash
# The test command: formatting, lints, and every test of the workspace (unit, property,
# end-to-end with real processes, and interop with independent Python MCAP readers).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
scripts/setup-python.sh
# The browser test drives Debian's chromium with playwright-core (no browser download).
npm ci --silent --no-audit --no-fund --prefix tools/node
cargo fmt --all --check
cargo clippy --workspace --all-targets --locked -- -D warnings
# What the layout promises, checked (cargo check only: no second full build). The docs
# build without a warning; the workspace builds without default features (no V4L2, no
# viewer); the fuzz targets, packages of their own, still compile (one shared target
# folder, so their common dependencies are checked once).
RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --workspace --locked --quiet
cargo check --workspace --all-targets --no-default-features --locked --quiet
for manifest in */fuzz/Cargo.toml components/*/fuzz/Cargo.toml; do
    [ -f "$manifest" ] || continue
    CARGO_TARGET_DIR="$root/target/fuzz-check" cargo check --manifest-path "$manifest" --locked --quiet
done
# `cargo test --workspace` builds target/debug/lewis with the features of this build; the
# end-to-end tests run that one rather than building `lewis` again with other features.
LEWIS_EXE="$root/target/debug/lewis" cargo test --workspace --locked
