#!/usr/bin/env bash
# Runs every fuzz target of the repository (the cargo-fuzz packages in */fuzz/ and
# components/*/fuzz/) for N seconds
# each, and prints how many inputs each ran. By hand, not in CI:
#
#   scripts/fuzz.sh [SECONDS]        (default 60)
#
# cargo-fuzz needs nightly features: RUSTC_BOOTSTRAP=1 lets the stable toolchain build them.
# It needs `cargo fuzz` (cargo install cargo-fuzz --locked). A crash stops the run of its
# target and leaves the input in PACKAGE/fuzz/artifacts/TARGET/; turn it into a regression
# test next to the code it broke, then fix the code. The corpus grows in PACKAGE/fuzz/corpus/
# (not committed).
set -euo pipefail
seconds=${1:-60}
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "cargo fuzz is missing: cargo install cargo-fuzz --locked" >&2
    exit 2
fi
export RUSTC_BOOTSTRAP=1
summary=()
failed=0
for manifest in */fuzz/Cargo.toml components/*/fuzz/Cargo.toml; do
    package=$(dirname "$(dirname "$manifest")")
    for target in $(cd "$package" && cargo fuzz list); do
        log=$(mktemp)
        echo "== $package: $target, ${seconds} s" >&2
        if (cd "$package" && cargo fuzz run "$target" -- -max_total_time="$seconds" -print_final_stats=1) >"$log" 2>&1; then
            result=ok
        else
            result=FAILED
            failed=1
            tail -n 40 "$log" >&2
        fi
        runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n 1)
        summary+=("$(printf '%-22s %-20s %-7s %10s runs in %s s' "$package" "$target" "$result" "${runs:-?}" "$seconds")")
        rm -f "$log"
    done
done
printf '%s\n' "${summary[@]}"
exit $failed
