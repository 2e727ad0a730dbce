#!/usr/bin/env bash
# tests/test_slurm.sh TANDEM: Tandem's long work on a real Slurm (slurm-wlm, munge). Starts a
# one-node cluster on localhost (scripts/slurm-local.sh: its own munge key, slurm.conf, ports,
# this machine's cores as one node), then:
# - a 2-shard reference of one frame (two sample ranges) as a job array with `sbatch --wait`,
#   merged with `tandem merge`: equal to the same reference run here in one go;
# - a 4-cell sweep written by `tandem bench --sweep ... --emit slurm` (reference shards, their
#   merge, matched references, the cells as an array, collect) and submitted with its
#   submit.sh: its sweep.json has every cell, and each cell's error (against its matched
#   reference and the unbiased one) equals the same sweep run here (the times differ: they are
#   measured);
# - collect names a failed and a missing cell (exit 1);
# then stops the daemons. When they cannot start, the test fails with their own messages.
set -uo pipefail
T=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")
SRC=$(cd "$(dirname "$0")/.." && pwd)
PY=/usr/bin/python3
D=$(mktemp -d /tmp/tandem_slurm.XXXXXX)
fails=0
check() {
    if [ "$2" -eq 0 ]; then echo "ok   $1"; else echo "FAIL $1"; fails=$((fails + 1)); fi
}
cleanup() {
    "$SRC/scripts/slurm-local.sh" stop "$D/cluster"
    rm -rf "$D"
}
trap cleanup EXIT
export TANDEM_QUIET=1

if ! "$SRC/scripts/slurm-local.sh" start "$D/cluster"; then
    echo "FAIL the one-node cluster did not start (its daemons' messages above)"
    exit 1
fi
export SLURM_CONF=$D/cluster/slurm.conf
echo "ok   a one-node Slurm cluster on localhost ($(sinfo -h -o '%n, %c CPUs, %t'))"
cd "$D" || exit 1

# wait until the cluster has no job left (at most 15 minutes)
drain() {
    for _ in $(seq 900); do
        [ -z "$(squeue -h 2>/dev/null)" ] && return 0
        sleep 1
    done
    squeue
    return 1
}

# a reference in 2 shards on Slurm, merged, against one run here
scene=$SRC/data/scenes/cornell.gltf
ref=(reference --quiet --scene "$scene" --frames 1 --start 3 --size 40x24 --spp 64)
wrap="$(printf '%q ' "$T" "${ref[@]}") --threads 1 --shard \$SLURM_ARRAY_TASK_ID/2"
wrap="$wrap --out $(printf '%q' "$D/shard_")\$SLURM_ARRAY_TASK_ID"
sbatch --wait --array=0-1 --cpus-per-task=1 --output="$D/shard_%a.out" --wrap "$wrap" >/dev/null
rc=$?
[ $rc -eq 0 ] || cat "$D"/shard_*.out
check "sbatch --wait: the 2-shard reference array ran" $rc
"$T" merge --quiet "$D/shard_0" "$D/shard_1" --out "$D/merged"
check "tandem merge of the Slurm shards" $?
"$T" "${ref[@]}" --out "$D/single"
$PY - "$D/single" "$D/merged" "$D/shard_0/shard.json" "$D/shard_1/shard.json" <<'PY'
import json, os, sys
import numpy as np
import OpenImageIO as oiio
a, b = sys.argv[1], sys.argv[2]
parts = [json.load(open(p))["parts"] for p in sys.argv[3:5]]
assert [(p[0]["first"], p[0]["count"]) for p in parts] == [(0, 32), (32, 32)], parts
assert sorted(os.listdir(a)) == sorted(os.listdir(b)), (os.listdir(a), os.listdir(b))
for name in os.listdir(a):
    x, y = open(os.path.join(a, name), "rb").read(), open(os.path.join(b, name), "rb").read()
    if x == y:
        continue
    if name == "reference.json":  # the same but for the sampling times (a merge measures none)
        untimed = lambda j: ({k: untimed(v) for k, v in j.items()
                              if k not in ("seconds", "paths_per_s")} if isinstance(j, dict) else
                             [untimed(v) for v in j] if isinstance(j, list) else j)
        assert untimed(json.loads(x)) == untimed(json.loads(y)), name
        continue
    assert name.endswith(".exr") and ".motion" not in name, name  # (the frames: within 1 ulp)
    va = oiio.ImageBuf(os.path.join(a, name)).get_pixels(oiio.FLOAT)
    vb = oiio.ImageBuf(os.path.join(b, name)).get_pixels(oiio.FLOAT)
    assert np.all(np.abs(va - vb) <= np.spacing(np.maximum(abs(va), abs(vb)))), name
PY
check "the merged Slurm reference (samples [0,32) and [32,64)) equals one run here" $?

# a sweep as Slurm jobs against the same sweep run here
sweep=(bench --quiet --scene "$scene" --size 40x24 --frames 4 --warmup 1 --spp 32
       --sweep bounces=1,2 --sweep atrous=1,4)
"$T" "${sweep[@]}" --emit slurm "$D/sweep" --ref-shards 2 >/dev/null &&
    [ -x "$D/sweep/slurm/submit.sh" ] && [ ! -e "$D/sweep/runs" ]
check "bench --sweep --emit slurm writes the jobs and runs nothing" $?
"$D/sweep/slurm/submit.sh" --cpus-per-task=1 >"$D/submit.out"
rc=$?
cat "$D/submit.out"
check "submit.sh submitted the reference shards, merge, matched references, cells, collect" $rc
drain
check "every job of the sweep left the queue" $?
"$T" "${sweep[@]}" --out "$D/local" >/dev/null
check "the same sweep run here" $?
$PY - "$D/sweep/sweep.json" "$D/local/sweep.json" <<'PY'
import json, math, sys
s, l = (json.load(open(p)) for p in sys.argv[1:3])
assert s["cells"] == 4 and len(s["runs"]) == 4 and not s["failed"] and not s["missing"], s
for a, b in zip(s["runs"], l["runs"]):
    assert a["knobs"] == b["knobs"], (a["knobs"], b["knobs"])
    for k in ("relmse", "smape", "psnr", "ssim", "flip", "temporal", "relmse_unbiased",
              "flip_unbiased", "estimator_bias_relmse"):
        assert math.isclose(a[k], b[k], rel_tol=1e-6, abs_tol=1e-12), (a["knobs"], k, a[k], b[k])
    assert a["total_ms"] > 0
PY
rc=$?
[ $rc -eq 0 ] || tail -n 5 "$D"/sweep/slurm/logs/*
check "the Slurm sweep's sweep.json: all 4 cells, each with the local sweep's errors" $rc
[ -f "$D/sweep/report/index.html" ] && [ -f "$D/sweep/sweep.csv" ] &&
    [ "$(wc -l <"$D/sweep/sweep.csv")" -eq 5 ]
check "the Slurm sweep's CSV and report" $?

# collect names what did not finish
rm -rf "$D/sweep/runs/002"
echo "exit 1" >"$D/sweep/runs/001.failed"
"$T" sweep collect "$D/sweep" 2>"$D/err"
rc=$?
[ $rc -eq 1 ] && grep -q "cell 1 (bounces=2 atrous=1): failed, exit 1" "$D/err" &&
    grep -q "cell 2 (bounces=1 atrous=4): missing" "$D/err" &&
    $PY -c "import json,sys; d=json.load(open(sys.argv[1])); \
assert len(d['runs']) == 2 and [c['cell'] for c in d['failed']] == [1] \
and [c['cell'] for c in d['missing']] == [2]" "$D/sweep/sweep.json"
check "sweep collect lists a failed and a missing cell (exit 1) and gathers the others" $?

"$SRC/scripts/slurm-local.sh" stop "$D/cluster"
! pgrep -f "$D/cluster/slurm.conf" >/dev/null
check "the daemons are stopped" $?
[ $fails -eq 0 ] && echo "all passed" || echo "$fails failed"
exit $((fails > 0))
