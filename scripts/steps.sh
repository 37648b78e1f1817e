# Sourced by .ci/run and scripts/test.sh: `step NAME COMMAND...` runs COMMAND and notes how
# long it took; the script that sourced this first prints the table of every step when it
# exits, also when a step failed (the failed step marked), so CI says what each step cost.
# Scripts it runs that source this too add their steps to the same table.
if [ -z "${LEWIS_STEPS_FILE:-}" ]; then
    LEWIS_STEPS_FILE=$(mktemp)
    export LEWIS_STEPS_FILE
    steps_started=$SECONDS
    steps_table() {
        local status=$? name seconds result
        echo
        echo "time per step:"
        while IFS=$'\t' read -r name seconds result; do
            printf '  %3d:%02d  %-6s %s\n' $((seconds / 60)) $((seconds % 60)) "$result" "$name"
        done < "$LEWIS_STEPS_FILE"
        seconds=$((SECONDS - steps_started))
        printf '  %3d:%02d  %-6s %s\n' $((seconds / 60)) $((seconds % 60)) \
            "$([ "$status" = 0 ] && echo ok || echo FAILED)" "total"
        rm -f "$LEWIS_STEPS_FILE"
    }
    trap steps_table EXIT
fi

step() {
    local name=$1 start=$SECONDS status=0
    shift
    printf '\n== %s\n' "$name"
    "$@" || status=$?
    printf '%s\t%d\t%s\n' "$name" $((SECONDS - start)) \
        "$([ "$status" = 0 ] && echo ok || echo FAILED)" >> "$LEWIS_STEPS_FILE"
    return "$status"
}
