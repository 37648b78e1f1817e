#!/usr/bin/env bash
# The fuzzing campaign: runs every fuzz target of the repository (the cargo-fuzz packages in
# */fuzz/ and components/*/fuzz/) for SECONDS each and reports, per target, the inputs it
# ran, the coverage it reached (libFuzzer's final `cov:` edges and `ft:` features), the
# corpus it ended with, and any crash with the path of its input. A benchmark run by hand,
# not CI (CI only checks that the targets compile: scripts/test.sh).
#
#   scripts/fuzz.sh [SECONDS] [--update-corpus] [TARGET...]   (default 60 s, every target)
#
# The corpus is kept in the repository, minimized, in PACKAGE/fuzz/corpus/TARGET/: each run
# starts from it and writes what it finds to a scratch folder, so the repository does not
# change. With --update-corpus, what was found is merged in and the corpus minimized again
# (`cargo fuzz cmin`): commit the result when it grew coverage, keeping it small.
#
# cargo-fuzz needs nightly features: RUSTC_BOOTSTRAP=1 lets the stable toolchain build them.
# It needs `cargo fuzz` (cargo install cargo-fuzz --locked). A crash (a panic, an overflow,
# an allocation beyond libFuzzer's limit, an input slower than 10 s) stops its target, leaves
# the input in PACKAGE/fuzz/artifacts/TARGET/ and makes the script exit 1: turn it into a
# regression test next to the code it broke, then fix the code (docs/src/how-to/tests.md).
# The machine is often shared: run it under `nice -n 10`.
set -euo pipefail
seconds=60
update=0
only=()
for arg in "$@"; do
    case $arg in
        --update-corpus) update=1 ;;
        [0-9]*) seconds=$arg ;;
        *) only+=("$arg") ;;
    esac
done
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "cargo fuzz is missing: cargo install cargo-fuzz --locked" >&2
    exit 2
fi
export RUSTC_BOOTSTRAP=1
# Debug assertions on, so that an arithmetic overflow is a crash; one target folder for
# every package, so that libFuzzer and the common dependencies are built once.
flags=(--debug-assertions --target-dir "${CARGO_TARGET_DIR:-$root/target}/fuzz")
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
rows=()
failed=0
for manifest in */fuzz/Cargo.toml components/*/fuzz/Cargo.toml; do
    package=$(dirname "$(dirname "$manifest")")
    built=0
    for target in $(cd "$package" && cargo fuzz list); do
        if ((${#only[@]})) && [[ ! " ${only[*]} " == *" $target "* ]]; then
            continue
        fi
        corpus=$package/fuzz/corpus/$target
        found=$scratch/$target
        log=$scratch/$target.log
        mkdir -p "$corpus" "$found"
        if ((!built)); then
            echo "== $package: building" >&2
            (cd "$package" && cargo fuzz build "${flags[@]}") >"$log" 2>&1 || {
                tail -n 40 "$log" >&2
                exit 2
            }
            built=1
        fi
        echo "== $package: $target, ${seconds} s" >&2
        # New inputs go to the first folder (scratch); the committed corpus is only read.
        result=ok
        if ! (cd "$package" && cargo fuzz run "${flags[@]}" "$target" "$found" "$root/$corpus" -- \
            -max_total_time="$seconds" -timeout=10 -print_final_stats=1) >"$log" 2>&1; then
            result=CRASH
            failed=1
            tail -n 40 "$log" >&2
        fi
        # A figure missing from the log (a crash before the end) stays empty: `|| true`.
        runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n 1) || true
        # The last status line (`#N DONE cov: C ft: F corp: U/S ...`) has the final figures.
        status=$(grep -E '^#[0-9]+.*cov: ' "$log" | tail -n 1) || true
        cov=$(grep -o 'cov: [0-9]*' <<<"$status" | grep -o '[0-9]*') || true
        ft=$(grep -o 'ft: [0-9]*' <<<"$status" | grep -o '[0-9]*') || true
        units=$(grep -o 'corp: [0-9]*' <<<"$status" | grep -o '[0-9]*') || true
        artifact=$(grep -o 'Test unit written to [^ ]*' "$log" | tail -n 1 | sed 's/Test unit written to //') || true
        if ((update)) && [[ $result == ok ]]; then
            cp -n "$found"/* "$corpus"/ 2>/dev/null || true
            (cd "$package" && cargo fuzz cmin "${flags[@]}" "$target") >"$log" 2>&1 || tail -n 20 "$log" >&2
        fi
        files=$(find "$corpus" -type f | wc -l)
        rows+=("$(printf '%-22s %-18s %12s %6s %7s %7s %8s  %s' "$package" "$target" \
            "${runs:-?}" "${cov:-?}" "${ft:-?}" "${units:-?}" "$files" \
            "$result${artifact:+ ${artifact#"$root"/}}")")
    done
done
printf '%-22s %-18s %12s %6s %7s %7s %8s  %s\n' package target executions cov ft corpus committed result
printf '%s\n' "${rows[@]}"
echo "(${seconds} s per target, $(nproc) cores; cov: edges, ft: features, corpus: inputs libFuzzer kept, committed: files in PACKAGE/fuzz/corpus/TARGET/)"
exit $failed
