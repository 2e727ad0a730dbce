#!/usr/bin/env bash
# scripts/fuzz.sh FUZZ_BUILD TANDEM SECONDS [TARGET...]: run each fuzz target (default: all) for
# SECONDS on its corpus (FUZZ_BUILD/corpus/<target>, seeded from tests/fuzz/seeds.sh the first
# time) with its dictionary; crashes, leaks, timeouts and out-of-memory inputs go to
# FUZZ_BUILD/artifacts/<target>/ and fail the run. One line per target: executions, coverage
# (edges), features, corpus size, crashes. Leaks inside C++ libraries (assimp) are suppressed:
# tests/fuzz/lsan.supp says why. FUZZ_JOBS=N runs N targets at once (each one process), so a long
# run keeps every core busy; the lines come in the order of the targets either way.
set -uo pipefail
B=$1 T=$2 SECONDS_EACH=$3
shift 3
ROOT=$(cd "$(dirname "$0")/.." && pwd)
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(gltf obj capture mapping env)
if [ ! -d "$B/corpus" ]; then
    "$ROOT/tests/fuzz/seeds.sh" "$B/seeds" "$T" || exit 1
    mkdir -p "$B/corpus"
    for t in gltf obj capture mapping env; do cp -r "$B/seeds/$t" "$B/corpus/$t"; done
fi
export LSAN_OPTIONS="suppressions=$ROOT/tests/fuzz/lsan.supp"
status=0
summary="$B/fuzz-summary.txt"
: > "$summary"
jobs_max=${FUZZ_JOBS:-1}
run_target() { # target: writes $B/fuzz-<target>.line, returns non-zero on any finding
    local t=$1 dict art log extra rc execs last cov ft corp found line
    dict="$ROOT/tests/fuzz/$t.dict"
    [ -f "$dict" ] || dict="$ROOT/tests/fuzz/exr.dict"
    art="$B/artifacts/$t"
    mkdir -p "$art" "$B/corpus/$t"
    log="$B/fuzz-$t.log"
    touch "$art/.start" # (artifacts of earlier runs stay; this run's are counted)
    extra=()
    # assimp's OBJ importer leaks on nearly every malformed input: a leak check each time takes
    # the target from hundreds of executions a second to one (docs/reliability.md)
    [ "$t" = obj ] && extra+=(-detect_leaks=0)
    "$B/tests/fuzz/fuzz_$t" "$B/corpus/$t" "${extra[@]}" -dict="$dict" \
        -max_total_time="$SECONDS_EACH" \
        -artifact_prefix="$art/" -print_final_stats=1 -rss_limit_mb=2048 -timeout=25 \
        -report_slow_units=1000000 > "$log" 2>&1
    rc=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")
    last=$(grep -E '^#[0-9]+' "$log" | tail -1)
    cov=$(echo "$last" | sed -n 's/.*cov: \([0-9]*\).*/\1/p')
    ft=$(echo "$last" | sed -n 's/.*ft: \([0-9]*\).*/\1/p')
    corp=$(echo "$last" | sed -n 's/.*corp: \([0-9]*\)\/.*/\1/p')
    found=$(find "$art" -newer "$art/.start" -type f \( -name 'crash-*' -o -name 'leak-*' \
        -o -name 'timeout-*' -o -name 'oom-*' \) | wc -l)
    line="fuzz $t: ${SECONDS_EACH} s, ${execs:-0} executions, cov ${cov:-?}, ft ${ft:-?}"
    line="$line, corpus ${corp:-?}, crashes $found"
    if [ $rc -ne 0 ] || [ "$found" -ne 0 ]; then
        line="$line"$'\n'"$(grep -E 'ERROR|SUMMARY|Test unit written' "$log" | head -5)"
        echo "$line" > "$B/fuzz-$t.line"
        return 1
    fi
    echo "$line" > "$B/fuzz-$t.line"
}
running=0
for t in "${targets[@]}"; do
    rm -f "$B/fuzz-$t.line"
    if [ "$jobs_max" -le 1 ]; then
        run_target "$t" || status=1
        cat "$B/fuzz-$t.line"
        continue
    fi
    if [ $running -ge "$jobs_max" ]; then wait -n || status=1; running=$((running - 1)); fi
    run_target "$t" &
    running=$((running + 1))
done
while [ $running -gt 0 ]; do wait -n || status=1; running=$((running - 1)); done
for t in "${targets[@]}"; do
    [ "$jobs_max" -le 1 ] || cat "$B/fuzz-$t.line"
    head -1 "$B/fuzz-$t.line" >> "$summary"
done
exit $status
