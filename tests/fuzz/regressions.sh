#!/usr/bin/env bash
# tests/fuzz/regressions.sh BUILD_TESTS_DIR TANDEM: every reader's fuzz target, without
# libFuzzer, over the inputs that once crashed or hung it (tests/fuzz/regressions/<target>/)
# and over its seed corpus (tests/fuzz/seeds.sh: Debian's models, Tandem's scenes and
# captures, the mappings, Blender's HDRIs). In the sanitizer build that catches a memory error
# or a leak of Tandem's on any of them; leaks inside C++ libraries are suppressed
# (tests/fuzz/lsan.supp says why).
set -uo pipefail
B=$1 T=$2
HERE=$(cd "$(dirname "$0")" && pwd)
TMP=$(mktemp -d /tmp/tandem_fuzz_seeds.XXXXXX)
trap 'rm -rf "$TMP"' EXIT
"$HERE/seeds.sh" "$TMP" "$T" > "$TMP/seeds.log" 2>&1 || { cat "$TMP/seeds.log"; exit 1; }
export LSAN_OPTIONS="suppressions=$HERE/lsan.supp"
status=0
for t in gltf obj capture mapping env; do
    dirs=("$TMP/$t")
    [ -d "$HERE/regressions/$t" ] && dirs+=("$HERE/regressions/$t")
    if out=$("$B/fuzz_replay_$t" "${dirs[@]}" 2>&1); then
        echo "ok   $t: ${out##*replay: }"
    else
        echo "FAIL $t"
        echo "$out" | tail -20
        status=1
    fi
done
exit $status
