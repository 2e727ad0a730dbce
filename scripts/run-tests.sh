#!/usr/bin/env bash
# Run ctest in each build directory given, then print one closing line for all of them:
# "tests: N passed, N failed" (counting ctest tests; each test executable prints its own cases).
set -u
pass=0
fail=0
status=0
for dir in "$@"; do
    log=$(mktemp)
    (cd "$dir" && ctest --output-on-failure) 2>&1 | tee "$log"
    rc=${PIPESTATUS[0]}
    [ "$rc" -ne 0 ] && status=1
    line=$(grep -E '[0-9]+% tests passed, [0-9]+ tests failed out of [0-9]+' "$log" | tail -1)
    if [ -n "$line" ]; then
        f=$(echo "$line" | sed -E 's/.* ([0-9]+) tests failed out of ([0-9]+).*/\1/')
        t=$(echo "$line" | sed -E 's/.* tests failed out of ([0-9]+).*/\1/')
        pass=$((pass + t - f))
        fail=$((fail + f))
    else
        echo "run-tests: $dir: ctest printed no summary" >&2
        status=1
    fi
    rm -f "$log"
done
echo "tests: $pass passed, $fail failed"
exit $status
