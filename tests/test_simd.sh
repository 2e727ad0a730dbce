#!/usr/bin/env bash
# tests/test_simd.sh A B: the Embree front-end built with its clones (A: x86-64-v4 or v3, as the
# CPU has) and baseline-only (B) render the same bits (tests/embree_digest.c). On a CPU without
# AVX2 both run the baseline and the check is trivially true; it says so.
set -u
a=$("$1") || { echo "FAIL $1 did not run"; exit 1; }
b=$("$2") || { echo "FAIL $2 did not run"; exit 1; }
echo "     clones:   $a"
echo "     baseline: $b"
case "$a" in *SSE2*) echo "     (this CPU has no AVX2: both ran the baseline)" ;; esac
if [ "${a%% *}" = "${b%% *}" ]; then
    echo "ok   the lane loops give the same bits with either instruction set"
    echo "1 passed, 0 failed"
    exit 0
fi
echo "FAIL the digests differ"
echo "0 passed, 1 failed"
exit 1
