#!/usr/bin/env bash
# The GPU-performance goals (docs/performance.md, issue 44) measured in one go on the GPU machine:
# the whole frame of each goal scene at 1080p (and `cornell` at 4K), every pixel's indirect path
# and half of them, A-SVGF, frames not waited for, with the re-shading folded into the shading
# pass and in a launch of its own (bench --whole-frame's fourth way), `atrium` with its cut-outs
# opaque (the any-hit's share of its shading pass), then each built-in denoiser's back-end
# against its bandwidth floor. One JSON file per case in OUT; summarise them
# with scripts/gpu_goals_table.py OUT (on any machine with Python).
#
#   . .gpu/env.sh; scripts/gpu-goals.sh OUT [SIZE]
# SIZE (default 1920x1080) scales every case down for a trial run (4K becomes twice SIZE).
# Optional scenes, skipped when their files are absent (the GPU machine has no Debian packages:
# carry them): ENGINE (Khronos' 2CylinderEngine.glb) lit by ENV_MAP (blender-data's
# sunset.exr), LEVEL (a real level of 400k+ triangles, e.g. morse-simulator-data's
# buildings_2.blend converted to glTF; docs/performance.md says how) with LEVEL_ARGS (its scene
# options, e.g. "--up z --camera-path inside.json").
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:?usage: scripts/gpu-goals.sh OUT [SIZE]}
SIZE=${2:-1920x1080}
W=${SIZE%x*} H=${SIZE#*x}
BIG=$((2 * W))x$((2 * H))
REPEATS=${REPEATS:-10}
mkdir -p "$OUT"
S=data/scenes
run() { # name, then bench's arguments
    local name=$1
    shift
    echo "gpu-goals: $name" >&2
    if ! tandem bench "$@" --repeats "$REPEATS" --json >"$OUT/$name.json" 2>"$OUT/$name.err"; then
        echo "gpu-goals: $name failed (see $OUT/$name.err)" >&2
        rm -f "$OUT/$name.json"
    fi
}
whole() { # name, scene arguments...
    local name=$1
    shift
    for b in 1 half; do
        run "frame_${name}_${b}" --whole-frame --frontend vk --denoiser asvgf --bounces "$b" "$@"
    done
}
whole cornell --scene $S/cornell.gltf --size "$SIZE"
whole cornell_4k --scene $S/cornell.gltf --size "$BIG"
whole materials --scene $S/materials.gltf --size "$SIZE"
whole atrium --scene $S/atrium.gltf --size "$SIZE"
# the any-hit's share of atrium's shading pass: against its cut-outs made opaque
run atrium_opaque --whole-frame --frontend vk --denoiser asvgf --opaque --scene $S/atrium.gltf \
    --size "$SIZE"
if [ -n "${ENGINE:-}" ] && [ -f "$ENGINE" ] && [ -f "${ENV_MAP:-}" ]; then
    whole engine --scene "$ENGINE" --env "$ENV_MAP" --size "$SIZE"
fi
if [ -n "${LEVEL:-}" ] && [ -f "$LEVEL" ]; then
    # shellcheck disable=SC2086 # LEVEL_ARGS is a list of options
    whole level --scene "$LEVEL" ${LEVEL_ARGS:-} --size "$SIZE"
fi
for d in asvgf svgf recurrent; do
    run "backend_$d" --frontend vk --denoiser "$d" --scene $S/cornell.gltf --size "$SIZE"
done
echo "gpu-goals: done; scripts/gpu_goals_table.py $OUT" >&2
