#!/usr/bin/env bash
# The byte-for-byte set: every command's outputs on small inputs (images, captures, dumps,
# references and their shards, merges, metrics, reports, sweeps, datasets, conversions, the
# JSON that info and contract print), digested by scripts/golden_digest.py into one manifest
# with timings and host facts left out. Run it before and after a change that must not change
# behaviour and compare the two manifests (`diff`): only what the change meant to change may
# differ.
#
#   scripts/golden.sh TANDEM OUT          -> OUT/manifest.txt (and OUT/runs, the outputs)
# About 6 minutes on the 2-core machine (lavapipe).
set -euo pipefail
T=$(realpath "$1")
OUT=$2
SRC=$(cd "$(dirname "$0")/.." && pwd)
S=$SRC/data/scenes
rm -rf "$OUT"
mkdir -p "$OUT/runs"
R=$OUT/runs
LOG=$OUT/log.txt
: >"$LOG"
step() { # name, then tandem's arguments: stdout to R/name.out, stderr kept in the log
    local name=$1
    shift
    echo "golden: $name" >&2
    local rc=0
    "$T" "$@" >"$R/$name.out" 2>>"$LOG" || rc=$?
    echo "$rc" >"$R/$name.rc"
}
# info, contract: what they print
step info_scene info --scene "$S/materials.gltf" --json
step info_pipeline info --pipeline --json
step contract contract --json
# renders: both front-ends, every built-in denoiser, captures, dumps, packed, half
for fe in embree vk; do
    for dn in asvgf svgf recurrent off; do
        step "render_${fe}_$dn" render --frontend $fe --denoiser $dn --scene "$S/dynamic.gltf" \
            --frames 4 --size 40x24 --capture --out "$R/render_${fe}_$dn" --quiet
    done
done
step render_dump render --frontend vk --scene "$S/materials.gltf" --frames 3 --size 32x18 \
    --dump all --precision packed --out "$R/render_dump" --quiet
step render_half render --frontend vk --scene "$S/cornell.gltf" --frames 3 --size 32x18 \
    --bounces half --taa off --tonemap agx --out "$R/render_half" --quiet
step render_env render --frontend embree --scene "$S/cutout.gltf" --frames 2 --size 32x18 \
    --camera-path orbit --out "$R/render_env" --quiet
# references: unbiased, matched (device and host composite), shards and their merge, until-noise
step ref_unbiased reference --scene "$S/dynamic.gltf" --frames 4 --size 40x24 --spp 16 \
    --out "$R/ref_unbiased" --quiet
step ref_matched reference --estimator realtime --scene "$S/dynamic.gltf" --frames 4 \
    --size 40x24 --spp 16 --out "$R/ref_matched" --quiet
step ref_matched_vk reference --frontend vk --estimator realtime --scene "$S/dynamic.gltf" \
    --frames 2 --size 40x24 --spp 8 --out "$R/ref_matched_vk" --quiet
step ref_until reference --scene "$S/cornell.gltf" --frames 1 --size 24x16 --spp 256 \
    --until-noise 0.2 --out "$R/ref_until" --quiet
for i in 0 1; do
    step "ref_shard$i" reference --scene "$S/cornell.gltf" --frames 1 --size 24x16 --spp 64 \
        --shard $i/2 --out "$R/ref_shard$i" --quiet
done
step merge merge "$R/ref_shard0" "$R/ref_shard1" --out "$R/merge" --quiet
# denoise replays, eval against both references (report), compare
step denoise denoise --captures "$R/render_vk_asvgf" --denoiser recurrent --out "$R/denoise" \
    --quiet
step eval eval --out "$R/render_vk_asvgf" --metrics-on cpu \
    --matched-reference "$R/ref_matched" --reference "$R/ref_unbiased" --report "$R/eval_report" \
    --json
step eval_device eval --out "$R/render_embree_recurrent" --metrics-on device \
    --reference "$R/ref_unbiased" --json --quiet
step compare compare "$R/render_embree_asvgf" "$R/render_vk_asvgf" --json \
    --reference "$R/ref_unbiased" --report "$R/compare_report"
step compare_scene compare --scene "$S/cornell.gltf" --frames 2 --size 32x18 --spp 8 \
    --out "$R/compare_scene" --json
# a sweep (matched references per estimator), its Slurm plan, extremes
step sweep bench --scene "$S/cornell.gltf" --size 24x16 --frames 3 --warmup 1 --spp 8 \
    --timed-frames 2 --sweep bounces=1,half --sweep denoiser=asvgf,recurrent \
    --out "$R/sweep" --quiet
step sweep_slurm bench --scene "$S/dynamic.gltf" --size 24x16 --frames 3 --spp 8 \
    --warmup 1 --sweep atrous=1,4 --emit slurm "$R/sweep_slurm" --quiet
step extremes bench --extremes --size 24x16 --frames 2 --out "$R/extremes" --quiet
# a dataset, what info says of a capture
cat >"$OUT/dataset.json" <<EOF
{"size": [32, 18], "frames": 2, "spp": 8, "unbiased_spp": 8, "format": "npz",
 "sequences": [{"name": "c", "scene": "$S/cornell.gltf", "camera_path": "orbit"}]}
EOF
step dataset dataset "$OUT/dataset.json" --out "$R/dataset" --quiet
step capture_info info --capture "$R/render_vk_asvgf/capture" --json
/usr/bin/python3 "$SRC/scripts/golden_digest.py" "$OUT" "$T" >"$OUT/manifest.txt"
echo "golden: $(wc -l <"$OUT/manifest.txt") entries in $OUT/manifest.txt" >&2
