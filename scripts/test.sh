#!/usr/bin/env bash
# The test command: formatting, lints, and every test of the workspace (unit, property,
# end-to-end with real processes, and interop with independent Python MCAP readers). Prints
# what each step cost at the end.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
source scripts/steps.sh
# One target directory outside the clone, kept from run to run: a fresh clone (CI's) builds
# only what changed. The tests find `lewis` through LEWIS_EXE (below) or beside themselves.
export CARGO_TARGET_DIR=${CARGO_TARGET_DIR:-${LEWIS_TARGET_DIR:-$HOME/.cache/lewis/target}}
step "python readers (.venv)" scripts/setup-python.sh
# The browser test drives Debian's chromium with playwright-core (no browser download).
step "npm ci (gui-test)" npm ci --silent --no-audit --no-fund --prefix tools/node
step "cargo fmt --check" cargo fmt --all --check
step "clippy (workspace, all targets)" cargo clippy --workspace --all-targets --locked -- -D warnings
# What the layout promises, checked without a second full build. The crates whose features
# differ, linted again without their defaults (the rest of the workspace is reused from the
# step above): `lewis` without the viewer and the bridge (the demo's first build), the
# drivers without V4L2.
step "clippy (no default features: lewis, drivers)" bash -c '
    cargo clippy -p lewis --all-targets --no-default-features --locked -- -D warnings &&
    cargo clippy -p lewis-drivers --all-targets --no-default-features --locked -- -D warnings'
# The docs build without a warning (they reuse the dependencies checked by clippy).
step "cargo doc" env RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --workspace --locked --quiet
# The fuzz targets, packages of their own, still compile (their own target folder, shared by
# all of them, so their common dependencies are checked once).
fuzz_check() {
    local manifest
    for manifest in */fuzz/Cargo.toml components/*/fuzz/Cargo.toml; do
        [ -f "$manifest" ] || continue
        CARGO_TARGET_DIR="$CARGO_TARGET_DIR/fuzz-check" cargo check --manifest-path "$manifest" --locked --quiet || return
    done
}
step "fuzz targets (cargo check)" fuzz_check
# DOCS: the user guide (docs/), built and link-checked, once scripts/docs.sh is there.
if [ -f scripts/docs.sh ]; then
    step "user guide (scripts/docs.sh)" bash scripts/docs.sh
fi
# `cargo test --workspace` builds $CARGO_TARGET_DIR/debug/lewis with the features of this
# build; the end-to-end tests run that one rather than building `lewis` again with other
# features.
step "cargo test --workspace" env LEWIS_EXE="$CARGO_TARGET_DIR/debug/lewis" cargo test --workspace --locked
