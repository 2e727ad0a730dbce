#!/usr/bin/env bash
# Run ctest in each build directory given, then print one closing line for all of them:
# "tests: N passed, N failed" (counting ctest tests; each test executable prints its own cases).
# Each build's tests run TEST_JOBS at a time (default: the cores).
set -u
pass=0
fail=0
status=0
# as many tests at once as there are cores (TEST_JOBS=1: one at a time); tests/CMakeLists.txt
# says why and in what order
jobs=${TEST_JOBS:-$(nproc 2>/dev/null || echo 2)}
for dir in "$@"; do
    log=$(mktemp)
    (cd "$dir" && ctest --output-on-failure -j "$jobs") 2>&1 | tee "$log"
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
    # every test's time against its limit, slowest first (ctest's own figures, kept in the CI
    # log; a test past half its limit is marked: the margin a slower machine needs)
    (cd "$dir" && ctest --show-only=json-v1) 2>/dev/null | /usr/bin/python3 -c '
import json, re, sys
limits = {t["name"]: next((p["value"] for p in t.get("properties", [])
                          if p["name"] == "TIMEOUT"), 1500)
          for t in json.load(sys.stdin).get("tests", [])}
rows = []
for line in open(sys.argv[1], errors="replace"):
    m = re.match(r"^ *[0-9]+/[0-9]+ Test +#[0-9]+: (\S+) .*?([0-9.]+) sec$", line)
    if m:
        rows.append((float(m.group(2)), m.group(1)))
print("run-tests: %s: per-test times, slowest first (seconds, limit, share)" % sys.argv[2])
for t, name in sorted(rows, reverse=True):
    lim = float(limits.get(name, 1500))
    print("  %8.1f  %5.0f  %4.0f%%  %s%s" % (t, lim, 100 * t / lim, name,
                                           "  (over half its limit)" if t > lim / 2 else ""))
' "$log" "$dir"
    rm -f "$log"
done
echo "tests: $pass passed, $fail failed"
exit $status
