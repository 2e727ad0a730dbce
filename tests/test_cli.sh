#!/usr/bin/env bash
# tests/test_cli.sh TANDEM: the `tandem` command seen from outside: exit codes, messages, JSON
# (evaluation in test_cli_eval.sh; sweeps and the stability report in test_cli_sweep.sh).
source "$(dirname "$0")/cli_common.sh" "$1"

"$T" info >"$tmp/out" 2>"$tmp/err"; rc=$?
check "info exits 0" $rc
grep -q "ray tracing pipeline: yes" "$tmp/out"; check "info shows a device with RT pipelines" $?
grep -q "<- chosen" "$tmp/out"; check "info marks the chosen device" $?
grep -q "shader_group\|SBT: handle size" "$tmp/out"; check "info shows SBT limits" $?

"$T" info --json >"$tmp/json" 2>"$tmp/err"; rc=$?
check "info --json exits 0" $rc
python3 - "$tmp/json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
c = [x for x in d["devices"] if x["chosen"]]
assert len(c) == 1, "exactly one chosen device"
assert c[0]["ray_tracing_pipeline"] and c[0]["acceleration_structure"]
assert c[0]["limits"]["shader_group_handle_size"] > 0
assert c[0]["index"] == d["chosen"]
PY
check "info --json is valid JSON with one chosen RT device" $?

TANDEM_DEVICE=nonexistent "$T" info >"$tmp/out" 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ]; check "TANDEM_DEVICE=nonexistent exits 1 (got $rc)" $?
grep -q "nonexistent" "$tmp/err" && grep -q "devices:" "$tmp/err"
check "the message names the request and the devices" $?
[ ! -s "$tmp/out" ]; check "and nothing on stdout" $?

"$T" info --device nonexistent >/dev/null 2>&1; rc=$?
[ $rc -eq 1 ]; check "--device nonexistent exits 1" $?

"$T" frobnicate >/dev/null 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "unknown command" "$tmp/err"; check "unknown command exits 2" $?
"$T" info --bogus >/dev/null 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "unknown option '--bogus'" "$tmp/err"; check "unknown option exits 2" $?
"$T" info --help >"$tmp/out" 2>&1; rc=$?
[ $rc -eq 0 ] && grep -q -- "--json" "$tmp/out"; check "info --help lists its options" $?
"$T" --help >"$tmp/out" 2>&1; rc=$?
[ $rc -eq 0 ] && grep -q "info" "$tmp/out"; check "tandem --help lists the commands" $?

# scenes
"$T" info --scene "$SRC/data/scenes/cornell.gltf" >"$tmp/out" 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && grep -q "triangles   36" "$tmp/out" && grep -q "area lights" "$tmp/out"
check "info --scene describes cornell" $?
"$T" info --scene "$SRC/data/scenes/materials.gltf" --json >"$tmp/json" 2>/dev/null
python3 -c "import json,sys; d=json.load(open(sys.argv[1])); assert d['materials']['glass']==1 and d['lights']['spot']==1" "$tmp/json"
check "info --scene --json is valid JSON" $?
"$T" info --scene "$tmp/none.gltf" >"$tmp/out" 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] && grep -q "none.gltf" "$tmp/err" && [ ! -s "$tmp/out" ]
check "a missing scene exits 1 naming the file" $?
printf '{"asset": {"version": "2.0"}, "meshes": [' >"$tmp/trunc.gltf"
"$T" info --scene "$tmp/trunc.gltf" >/dev/null 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] && grep -q "trunc.gltf: invalid glTF JSON" "$tmp/err"
check "a truncated scene exits 1 with a clear message" $?
"$T" contract >"$tmp/out" 2>&1; rc=$?
[ $rc -eq 0 ] && grep -q '`hf.R`' "$tmp/out"; check "contract prints the table" $?

# render and reference, small
"$T" render --scene "$SRC/data/scenes/cornell.gltf" --frames 2 --size 32x18 --capture --out "$tmp/r" --quiet
rc=$?
[ $rc -eq 0 ] && [ -f "$tmp/r/frame_0001.exr" ] && [ -f "$tmp/r/frame_0001.png" ] && [ -f "$tmp/r/capture/frame_0001.exr" ]
check "render writes frames, previews and captures" $?
"$T" reference --scene "$SRC/data/scenes/cornell.gltf" --frames 1 --size 16x9 --spp 4 --out "$tmp/ref" >/dev/null 2>"$tmp/err"
rc=$?
[ $rc -eq 0 ] && [ -f "$tmp/ref/frame_0000.exr" ] && grep -q "remaining noise" "$tmp/err"
check "reference writes a frame and reports the remaining noise" $?
"$T" render --scene "$tmp/trunc.gltf" --out "$tmp/bad" --quiet 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] && grep -q "trunc.gltf" "$tmp/err" && [ ! -e "$tmp/bad/frame_0000.exr" ]
check "render of a bad scene exits 1 with no output" $?
"$T" render --out "$tmp/x" --size 0x5 2>/dev/null; rc=$?
[ $rc -eq 2 ]; check "render --size 0x5 is a usage error" $?
"$T" bench --size 32x32 --repeats 2 --json >"$tmp/bench.json" 2>/dev/null
python3 -c "import json,sys; d=json.load(open(sys.argv[1])); assert d['rays_per_frame'] > 1024 and d['frontend_mrays_per_s'] > 0 and d['bounces'] == 1" "$tmp/bench.json"
check "bench --json reports rays and rates" $?
# --bounces half: the indirect paths of half the pixels, so fewer rays than one bounce's
"$T" bench --size 32x32 --repeats 2 --bounces half --json >"$tmp/bench_half.json" 2>/dev/null
python3 -c "import json,sys; a, h = (json.load(open(p)) for p in sys.argv[1:3]); assert h['bounces'] == 'half' and a['rays_per_frame'] * 0.95 > h['rays_per_frame'] > a['rays_per_frame'] * 0.6, (a['rays_per_frame'], h['rays_per_frame'])" "$tmp/bench.json" "$tmp/bench_half.json"
check "bench --bounces half traces fewer rays and says half" $?
# a bounce count no command takes: a usage error naming the value, from the one parse they share
"$T" bench --size 32x32 --bounces quarter 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "'quarter'" "$tmp/err"; check "bench --bounces quarter is a usage error" $?
# no repetitions: no medians to print (it printed "medians of 0 repetitions" before)
"$T" bench --size 32x32 --repeats 0 >"$tmp/out" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q -- "--repeats 0: expected at least 1" "$tmp/err" && [ ! -s "$tmp/out" ]
check "bench --repeats 0 is a usage error with nothing on stdout (got $rc)" $?
"$T" bench --sweep bounces=half,65 --out "$tmp/sweep_bad" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "bounces=65: a count (0 to 64) or half" "$tmp/err" && [ ! -e "$tmp/sweep_bad" ]
check "bench --sweep bounces=65 is a usage error with no output" $?
"$T" reference --estimator unbiased --bounces half --out "$tmp/ref_half" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "half: only with the realtime estimator" "$tmp/err" && [ ! -e "$tmp/ref_half" ]
check "reference --estimator unbiased --bounces half is a usage error" $?
"$T" bench --frontend vk --denoiser asvgf --scene "$SRC/data/scenes/dynamic.gltf" --size 48x27 --repeats 3 --json >"$tmp/bench_dn.json" 2>/dev/null
python3 - "$tmp/bench_dn.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
p = d["passes"]
assert d["compute_copy_gb_per_s"] > 0 and d["transfer_copy_gb_per_s"] > 0, d
# the lf filter runs beside the a-trous: one pass (and timer) covers both
assert d["lf_beside_atrous"] is True and "denoise_lf" not in p, d
for k in ("denoise_select", "denoise_gradient", "denoise_temporal", "denoise_atrous", "composite"):
    assert p[k]["bytes"] > 0 and p[k]["floor_ms"] > 0, k
# the floor of the whole back-end is the sum of its passes'
assert abs(sum(p[k]["bytes"] for k in p if "bytes" in p[k]) - d["backend_bytes"]) < 1, d
PY
check "bench --denoiser times every pass against the bandwidth floor" $?
"$T" bench --frontend vk --denoiser asvgf --scene "$SRC/data/scenes/dynamic.gltf" --size 48x27 --repeats 3 --per-dispatch --json >"$tmp/bench_pd.json" 2>/dev/null
python3 - "$tmp/bench_pd.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
names = [x["name"] for x in d["dispatches"]]
# every dispatch of the frame, in order, each timed (the lf chain then runs apart from the a-trous)
assert d["lf_beside_atrous"] is False and d["passes"]["denoise_lf"]["median_ms"] > 0, d
# (the gradients and their blur: along rows, then along columns)
assert names[0:2] == ["gradient.rows", "gradient.columns"], names
assert names[2:] == ["temporal", "lf.downsample", "lf.deflicker", "lf.atrous0", "lf.atrous1",
                     "lf.atrous2", "atrous.0", "atrous.1", "atrous.2", "atrous.3", "composite"], names
assert all(x["median_ms"] > 0 for x in d["dispatches"]), d["dispatches"]
PY
check "bench --per-dispatch times each back-end dispatch" $?
"$T" bench --frontend embree --denoiser asvgf >/dev/null 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "needs --frontend vk" "$tmp/err"
check "bench --denoiser without the Vulkan front-end is a usage error" $?

# both front-ends, one capture each, compared
for fe in embree vk; do
    "$T" render --frontend $fe --scene "$SRC/data/scenes/cornell.gltf" --frames 2 --size 40x24 \
        --capture --denoiser svgf --out "$tmp/$fe" --quiet || echo "render $fe failed"
done
"$T" compare "$tmp/embree" "$tmp/vk" >"$tmp/cmp" 2>&1; rc=$?
[ $rc -eq 0 ] && grep -q "2 frames compared: agree" "$tmp/cmp"
check "compare: the two front-ends' captures agree" $?
"$T" render --frontend embree --scene "$SRC/data/scenes/dynamic.gltf" --frames 2 --size 40x24 \
    --capture --out "$tmp/other" --quiet
"$T" compare "$tmp/embree" "$tmp/other" >"$tmp/cmp" 2>&1; rc=$?
[ $rc -eq 1 ] && grep -q "below the floor" "$tmp/cmp"
check "compare: different scenes disagree and exit 1" $?
grep -q '"primary_ms"' "$tmp/vk/timings.json"; check "render writes timings.json" $?

# the outputs open in independent tools with the expected sizes and channels
oiiotool --info "$tmp/vk/frame_0001.png" "$tmp/vk/frame_0001.exr" >"$tmp/oiio" 2>&1
grep -q "frame_0001.png *: *40 x *24, 3 channel, uint8 png" "$tmp/oiio" &&
    grep -q "frame_0001.exr *: *40 x *24, 3 channel, float openexr" "$tmp/oiio"
check "oiiotool reads render's PNG (40x24 RGB8) and EXR (40x24 RGB float)" $?
exrheader "$tmp/vk/frame_0001.exr" >"$tmp/hdr" 2>&1 &&
    grep -q "dataWindow (type box2i): (0 0) - (39 23)" "$tmp/hdr" &&
    [ "$(grep -c ', 32-bit floating-point' "$tmp/hdr")" -eq 3 ]
check "exrheader: the linear EXR is 40x24 with three float channels" $?
exrheader "$tmp/vk/capture/frame_0001.exr" >"$tmp/hdr" 2>&1
"$T" contract --json >"$tmp/contract.json"
python3 - "$tmp/hdr" "$tmp/contract.json" <<'PY'
import json, re, sys
txt = open(sys.argv[1]).read()
have = set(re.findall(r"^    (\S+), (?:32|16)-bit", txt, re.M))
want = {c for e in json.load(open(sys.argv[2]))["entries"] for c in e["exr_channels"]}
assert have == want, (sorted(have ^ want))
assert "dataWindow (type box2i): (0 0) - (39 23)" in txt
PY
check "exrheader: a capture holds exactly the contract's channels (tandem contract --json)" $?

# model only what the scene requires: the forced full pipeline gives the same pictures
for p in scene full; do
    "$T" render --frontend vk --scene "$SRC/data/scenes/cornell.gltf" --frames 2 --size 32x18 \
        --pipeline $p --out "$tmp/pipe_$p" --quiet || echo "render --pipeline $p failed"
done
cmp -s "$tmp/pipe_scene/frame_0001.exr" "$tmp/pipe_full/frame_0001.exr" &&
    cmp -s "$tmp/pipe_scene/frame_0001.png" "$tmp/pipe_full/frame_0001.png"
check "--pipeline full and scene-driven shaders give identical frames on cornell" $?
python3 - "$tmp" <<'PY'
import json, sys
s = json.load(open(f"{sys.argv[1]}/pipe_scene/run.json"))
f = json.load(open(f"{sys.argv[1]}/pipe_full/run.json"))
assert s["pipeline"] == "scene" and f["pipeline"] == "full"
assert s["frontend_models"] == "area lights", s["frontend_models"]
assert f["frontend_models"].count(",") == 9 and "textures" in f["frontend_models"], f["frontend_models"]
assert "area lights (emissive triangles)" in s["scene_features"]
assert "reflect_refract" in s["post"]["not_run"] and "interleave" in s["post"]["not_run"]
PY
check "run.json: cornell models area lights only; --pipeline full everything; no reflect/refract, no interleave" $?
"$T" render --frames 1 --size 24x12 --pipeline most --out "$tmp/pipe_bad" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "most" "$tmp/err" && [ ! -e "$tmp/pipe_bad" ]
check "--pipeline with an unknown value is a usage error, no output" $?

# --video: the PNGs as an MP4 (ffmpeg, installed by the set-up)
"$T" render --frames 4 --start 2 --size 41x23 --video --out "$tmp/video" --quiet; rc=$?
[ $rc -eq 0 ] && ffprobe -v error -show_entries stream=codec_name,width,height,nb_frames \
    -of compact=p=0 "$tmp/video/video.mp4" >"$tmp/probe" 2>&1 &&
    grep -q "codec_name=h264|width=42|height=24|nb_frames=4" "$tmp/probe"
check "render --video writes a 4-frame H.264 MP4 (odd size padded to 42x24)" $?
PATH=/nonexistent "$T" render --frames 1 --size 24x12 --video --out "$tmp/video2" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "ffmpeg" "$tmp/err" && [ ! -e "$tmp/video2" ]
check "render --video without ffmpeg is a usage error naming it, no output" $?

# captures back through the denoiser: the same pictures as render's own back-end
"$T" denoise --captures "$tmp/embree" --out "$tmp/den" --denoiser svgf --quiet; rc=$?
[ $rc -eq 0 ] && cmp -s "$tmp/den/frame_0001.exr" "$tmp/embree/frame_0001.exr"
check "denoise --captures reproduces render's denoised frames exactly" $?
"$T" denoise --captures "$tmp/nowhere" --out "$tmp/den2" 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] && grep -q "nowhere" "$tmp/err" && [ ! -e "$tmp/den2" ]
check "denoise of a missing directory exits 1 with no output" $?
"$T" denoise --captures "$tmp/embree" --out "$tmp/den3" 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && grep -q "running as svgf: the capture carries no gradient samples" "$tmp/err" &&
    grep -q '"denoiser": "svgf"' "$tmp/den3/timings.json"
check "denoise runs asvgf (the default) as svgf on captures and says so" $?
# a sequence whose third frame is broken: exit 1 naming it, and no output left behind (neither a
# new directory nor, in an existing one, the frames written before the failure)
mkdir -p "$tmp/broken_cap" "$tmp/den_existing"
cp "$tmp/embree/capture/frame_0000.exr" "$tmp/embree/capture/frame_0001.exr" "$tmp/broken_cap/"
head -c 300 "$tmp/embree/capture/frame_0001.exr" >"$tmp/broken_cap/frame_0002.exr"
touch "$tmp/den_existing/notes.txt"
"$T" denoise --captures "$tmp/broken_cap" --out "$tmp/den_broken" --denoiser off 2>"$tmp/err"; rc1=$?
"$T" denoise --captures "$tmp/broken_cap" --out "$tmp/den_existing" --denoiser off 2>/dev/null; rc2=$?
[ $rc1 -eq 1 ] && [ $rc2 -eq 1 ] && grep -q "frame_0002.exr" "$tmp/err" && [ ! -e "$tmp/den_broken" ] &&
    [ "$(ls "$tmp/den_existing")" = "notes.txt" ]
check "denoise of a sequence with a broken frame exits 1 naming it, no partial output" $?
# a frame of another size
"$T" render --frontend embree --scene "$SRC/data/scenes/cornell.gltf" --frames 1 --size 32x24 \
    --capture --denoiser off --out "$tmp/small" --quiet
cp "$tmp/small/capture/frame_0000.exr" "$tmp/broken_cap/frame_0002.exr"
"$T" denoise --captures "$tmp/broken_cap" --out "$tmp/den_sized" --denoiser off 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] && grep -q "frame_0002.exr: 32x24, the sequence's first frame is 40x24" "$tmp/err" &&
    [ ! -e "$tmp/den_sized" ]
check "denoise of a sequence whose frames differ in size exits 1 naming the file and both sizes" $?

# A-SVGF: the back-end picks gradient samples, either front-end re-shades them
for fe in embree vk; do
    "$T" render --frontend $fe --scene "$SRC/data/scenes/dynamic.gltf" --frames 3 --size 40x24 \
        --out "$tmp/as_$fe" --quiet || echo "render asvgf $fe failed"
done
python3 - "$tmp" <<'PY'
import json, sys
for fe in ("embree", "vk"):
    d = json.load(open(f"{sys.argv[1]}/as_{fe}/timings.json"))
    assert d["denoiser"] == "asvgf", d["denoiser"]
    f = d["frames"]
    assert len(f) == 3 and f[0]["denoise_gradient_ms"] == 0, f[0]   # no history yet
    assert all(x["denoise_gradient_ms"] > 0 and x["denoise_select_ms"] > 0 for x in f[1:]), f
PY
check "render's default denoiser, asvgf, runs the gradient passes with both front-ends" $?
# replays: a capture rendered with each denoiser, denoised again from its files, gives render's
# frames bit for bit (asvgf: the capture keeps the gradient samples beside each frame). Embree's
# `off` composites on the CPU in render and on the GPU in denoise: equal to float rounding.
ok=0
for fe in embree vk; do
    for d in asvgf svgf off; do
        "$T" render --frontend $fe --scene "$SRC/data/scenes/dynamic.gltf" --frames 4 \
            --size 40x24 --capture --denoiser $d --out "$tmp/rp_${fe}_$d" --quiet || ok=1
        taa=on; [ $fe$d = embreeoff ] && taa=off
        "$T" denoise --captures "$tmp/rp_${fe}_$d" --out "$tmp/rd_${fe}_$d" --denoiser $d \
            --taa $taa 2>"$tmp/err_rp_${fe}_$d" || ok=1
        [ $d = asvgf ] && { grep -q "running as svgf" "$tmp/err_rp_${fe}_$d" && ok=1; }
        [ $fe$d = embreeoff ] && continue
        for k in 0 1 2 3; do
            cmp -s "$tmp/rp_${fe}_$d/frame_000$k.exr" "$tmp/rd_${fe}_$d/frame_000$k.exr" ||
                { echo "     replay $fe $d frame $k differs"; ok=1; }
        done
    done
done
[ -f "$tmp/rp_vk_asvgf/capture/frame_0003.gradients.exr" ] &&
    [ ! -e "$tmp/rp_vk_asvgf/capture/frame_0000.gradients.exr" ] || ok=1
$PY - "$tmp" <<'PY' || ok=1
import sys, numpy as np, OpenImageIO as oiio
for k in range(4):
    a = oiio.ImageBuf(f"{sys.argv[1]}/rp_embree_off/frame_000{k}.exr").get_pixels(oiio.FLOAT)
    b = oiio.ImageBuf(f"{sys.argv[1]}/rd_embree_off/frame_000{k}.exr").get_pixels(oiio.FLOAT)
    assert np.abs(a - b).max() <= 1e-6 * max(1.0, np.abs(a).max()), (k, np.abs(a - b).max())
PY
check "denoise replays render's frames bit for bit: asvgf, svgf, off, both front-ends" $ok
# A-SVGF's replay must start where the render did: a sequence without its first frame selects
# other samples (no history on the first frame replayed); a missing samples file is named
mkdir -p "$tmp/rp_late" "$tmp/rp_nograd"
cp "$tmp/rp_vk_asvgf/capture/frame_0002"* "$tmp/rp_vk_asvgf/capture/frame_0003"* "$tmp/rp_late/"
"$T" denoise --captures "$tmp/rp_late" --out "$tmp/rd_late" 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] && grep -q "frame_0002.gradients.exr: .* gradient samples, but the back-end selected" \
    "$tmp/err" && [ ! -e "$tmp/rd_late" ]
check "an A-SVGF replay that does not start at the first frame exits 1 naming the samples file" $?
cp "$tmp/rp_vk_asvgf/capture/frame_000"[0-3].exr "$tmp/rp_nograd/"
"$T" denoise --captures "$tmp/rp_nograd" --out "$tmp/rd_nograd" 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] && grep -q "frame_0001.gradients.exr: missing" "$tmp/err" && [ ! -e "$tmp/rd_nograd" ]
"$T" denoise --captures "$tmp/rp_nograd" --out "$tmp/rd_nograd2" --denoiser svgf --quiet; rc2=$?
[ $rc -eq 1 ] && [ $rc2 -eq 0 ]
check "an A-SVGF capture without its samples files exits 1 naming one; svgf still runs" $?
"$T" render --frames 2 --size 24x12 --dump temporal.hf,gradients --out "$tmp/dump" --quiet; rc=$?
[ $rc -eq 0 ] && [ -f "$tmp/dump/dump/temporal.hf_0001.exr" ] && [ -f "$tmp/dump/dump/gradients_0001.exr" ] &&
    [ ! -e "$tmp/dump/dump/output_0001.exr" ]
check "render --dump writes the named back-end buffers per frame" $?
"$T" render --frames 1 --size 24x12 --dump temporal.hf,bogus --out "$tmp/dump2" 2>"$tmp/err"; rc=$?
[ $rc -ne 0 ] && grep -q "bogus" "$tmp/err" && [ ! -e "$tmp/dump2" ]
check "render --dump with an unknown buffer fails naming it, with no output" $?
"$T" denoise --captures "$tmp/embree" --out "$tmp/den4" --dump atrous.spec --quiet; rc=$?
[ $rc -eq 0 ] && [ -f "$tmp/den4/dump/atrous.spec_frame_0001.exr" ]
check "denoise --dump names the dumps after the input frames" $?

# developers' compiler statistics: printed per compute pipeline where the driver has
# VK_KHR_pipeline_executable_properties (NVIDIA), else one line saying it has not (lavapipe)
TANDEM_PIPELINE_STATS=1 "$T" render --frames 1 --size 24x12 --out "$tmp/ps" --quiet 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && { grep -q "pipeline stats: denoise.temporal" "$tmp/err" ||
    grep -q "has no VK_KHR_pipeline_executable_properties" "$tmp/err"; }
check "TANDEM_PIPELINE_STATS=1 prints the compiler's statistics or says the driver has none" $?

# developers' shader override: $TANDEM_SHADER_DIR/<name>.spv replaces the embedded code
mkdir -p "$tmp/sv_bad" "$tmp/sv_same"
printf 'abcde' >"$tmp/sv_bad/dn_composite_f32.spv"
"$T" render --frames 2 --size 24x12 --out "$tmp/sv0" --quiet 2>/dev/null
TANDEM_SHADER_DIR="$tmp/sv_bad" "$T" render --frames 2 --size 24x12 --out "$tmp/sv1" --quiet \
    2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && grep -q "sv_bad/dn_composite_f32.spv: unreadable" "$tmp/err" &&
    cmp -s "$tmp/sv0/frame_0001.exr" "$tmp/sv1/frame_0001.exr"
check "TANDEM_SHADER_DIR: a file that is not SPIR-V words is named and ignored" $?
if command -v glslangValidator >/dev/null; then
    glslangValidator --target-env vulkan1.2 -DTND_GLSL=1 -DTND_PACKED=0 -I"$SRC/shaders" \
        -o "$tmp/sv_same/dn_composite_f32.spv" "$SRC/shaders/dn_composite.comp" >/dev/null
    sed 's/vec4(finite3(c), 1.0)/vec4(finite3(c) * 2.0, 1.0)/' "$SRC/shaders/dn_composite.comp" \
        >"$tmp/sv_bad/twice.comp"
    glslangValidator --target-env vulkan1.2 -DTND_GLSL=1 -DTND_PACKED=0 -I"$SRC/shaders" \
        -o "$tmp/sv_bad/dn_composite_f32.spv" "$tmp/sv_bad/twice.comp" >/dev/null
    TANDEM_SHADER_DIR="$tmp/sv_same" "$T" render --frames 2 --size 24x12 --out "$tmp/sv2" \
        --quiet 2>"$tmp/err"; rc=$?
    [ $rc -eq 0 ] && grep -q "shader dn_composite_f32 from" "$tmp/err" &&
        cmp -s "$tmp/sv0/frame_0001.exr" "$tmp/sv2/frame_0001.exr"
    check "TANDEM_SHADER_DIR: the same shader compiled apart gives the same frame" $?
    TANDEM_SHADER_DIR="$tmp/sv_bad" "$T" render --frames 2 --size 24x12 --out "$tmp/sv3" \
        --quiet 2>/dev/null; rc=$?
    [ $rc -eq 0 ] && ! cmp -s "$tmp/sv0/frame_0001.exr" "$tmp/sv3/frame_0001.exr"
    check "TANDEM_SHADER_DIR: a changed shader changes the frame" $?
fi

# ---- the pipeline describes itself (the registries' tables) ----------------------------------
# every denoiser parameter of the registry is an option of render and denoise, with its help
"$T" render --help >"$tmp/rh" 2>&1; "$T" denoise --help >"$tmp/dh" 2>&1
for o in atrous min-alpha antilag antilag-lf lf-sigma hf-sigma; do
    grep -q -- "--$o " "$tmp/rh" && grep -q -- "--$o " "$tmp/dh" || echo "missing --$o" >>"$tmp/params_missing"
done
[ ! -s "$tmp/params_missing" ] && grep -q "asvgf, svgf, off" "$tmp/rh"
check "render and denoise take every denoiser parameter of the table, help names the registry" $?
"$T" render --atrous 9 --out "$tmp/bad_param" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q -- "--atrous 9" "$tmp/err" && grep -q "1, 5" "$tmp/err" && [ ! -e "$tmp/bad_param" ]
check "a parameter out of its range: exit 2, the range said, nothing written (got $rc)" $?
"$T" render --atrous nan --out "$tmp/bad_param" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "bad value 'nan'" "$tmp/err" && [ ! -e "$tmp/bad_param" ]
check "no option takes nan (a parameter would have read it as not given) (got $rc)" $?
"$T" render --atrous 2.5 --out "$tmp/bad_param" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "whole number" "$tmp/err"
check "a count parameter takes whole numbers (got $rc)" $?
"$T" render --frontend replay --out "$tmp/bad_fe" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "embree, vk, plugin:PATH" "$tmp/err"
check "render's front-ends are the registry's live ones (replay is not) (got $rc)" $?
# run.json holds the parameters given that the denoiser has; the parameter reaches it
"$T" render --frames 2 --size 32x20 --antilag 2 --lf-sigma 0.5 --out "$tmp/p_a" --quiet &&
    "$T" render --frames 2 --size 32x20 --antilag 2 --out "$tmp/p_b" --quiet &&
    "$T" render --frames 2 --size 32x20 --denoiser svgf --antilag 2 --atrous 3 --out "$tmp/p_c" --quiet &&
    "$T" render --frames 2 --size 32x20 --antilag 2 --hf-sigma 1 --antilag-lf 0.2 --out "$tmp/p_e" --quiet
rc=$?
[ $rc -eq 0 ] && python3 - "$tmp" <<'PY'
import json, sys
t = sys.argv[1]
a = json.load(open(t + "/p_a/run.json"))
b = json.load(open(t + "/p_b/run.json"))
c = json.load(open(t + "/p_c/run.json"))
assert a["antilag"] == 2 and a["lf_sigma"] == 0.5 and "atrous" not in a, a
assert "lf_sigma" not in b, b
assert c["denoiser"] == "svgf" and c["atrous"] == 3 and "antilag" not in c, c  # svgf has none
e = json.load(open(t + "/p_e/run.json"))
assert e["hf_sigma"] == 1 and e["antilag_lf"] == 0.2 and "lf_sigma" not in e, e
PY
[ $? -eq 0 ] && ! cmp -s "$tmp/p_a/frame_0001.exr" "$tmp/p_b/frame_0001.exr" &&
    ! cmp -s "$tmp/p_e/frame_0001.exr" "$tmp/p_b/frame_0001.exr"
check "run.json: the denoiser's parameters given; --lf-sigma and --hf-sigma reach the filters" $?
"$T" render --frames 1 --size 16x12 --denoiser svgf --antilag 2 --out "$tmp/p_d" 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && grep -q -- "--antilag: svgf has no such parameter" "$tmp/err"
check "a parameter the denoiser lacks is left out, and said (got $rc)" $?
# tandem denoise's timings.json carries every pass of the chain (the denoiser's, gradient
# selection included, and the post chain's), as render's does
"$T" render --frames 3 --size 32x20 --capture --out "$tmp/tp" --quiet &&
    "$T" denoise --captures "$tmp/tp/capture" --out "$tmp/tp_dn" --quiet
rc=$?
[ $rc -eq 0 ] && python3 - "$tmp/tp/timings.json" "$tmp/tp_dn/timings.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))["frames"]
d = json.load(open(sys.argv[2]))["frames"]
keys = ["denoise_select_ms", "denoise_gradient_ms", "denoise_temporal_ms", "denoise_lf_ms",
        "denoise_atrous_ms", "composite_ms", "interleave_ms", "taa_ms", "bloom_ms", "exposure_ms",
        "tonemap_ms"]
for f in r + d:
    assert all(k in f for k in keys), (sorted(set(keys) - set(f)), f)
assert "denoise_lf_beside_atrous" in d[0]
assert all(f["denoise_select_ms"] > 0 and f["denoise_gradient_ms"] > 0 for f in d[1:]), d
PY
check "denoise's timings.json carries every pass (selection and gradients too)" $?
# the recurrent denoiser: its own parameters and pass; a capture rendered with it keeps its
# gradient samples (its confidence input) and replays with them; on a capture without them it
# runs itself, without them (no fallback), and says nothing of the kind
"$T" render --frames 3 --size 32x20 --denoiser recurrent --fast 3 --capture --out "$tmp/rc" --quiet &&
    "$T" denoise --captures "$tmp/rc/capture" --denoiser recurrent --out "$tmp/rc_dn" --quiet &&
    "$T" render --frames 3 --size 32x20 --denoiser svgf --capture --out "$tmp/rc_sv" --quiet &&
    "$T" denoise --captures "$tmp/rc_sv/capture" --denoiser recurrent --out "$tmp/rc_sv_dn" 2>"$tmp/rc_err"
rc=$?
[ $rc -eq 0 ] && ! grep -q "instead" "$tmp/rc_err" && ls "$tmp/rc/capture" | grep -q gradients &&
    python3 - "$tmp" <<'PY'
import json, sys
t = sys.argv[1]
r = json.load(open(t + "/rc/run.json"))
assert r["denoiser"] == "recurrent" and r["fast"] == 3, r
for d in ("rc", "rc_dn", "rc_sv_dn"):
    f = json.load(open(t + "/" + d + "/timings.json"))["frames"]
    assert all(x["denoise_history_ms"] > 0 for x in f), (d, f)
    g = [x["denoise_gradient_ms"] for x in f]
    assert (max(g) > 0) == (d != "rc_sv_dn"), (d, g)  # the confidence input where there is one
PY
check "recurrent: its parameters and history pass; gradients as its confidence where kept (got $rc)" $?
"$T" render --denoiser recurrent --fast 0.5 --out "$tmp/bad_param" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q -- "--fast" "$tmp/err" && [ ! -e "$tmp/bad_param" ]
check "recurrent: --fast out of its range refused (got $rc)" $?
# --resample: the cubic (1) and the tested bilinear taps (2, the default) differ where the
# camera moves and agree bit for bit where nothing does (the cubic's weights are the pixel's own)
for m in 1 2; do
    "$T" render --frames 4 --size 48x27 --denoiser recurrent --resample $m \
        --scene "$SRC/data/scenes/materials.gltf" --camera-path orbit --out "$tmp/rs_o$m" --quiet &&
        "$T" render --frames 4 --size 48x27 --denoiser recurrent --resample $m \
            --scene "$SRC/data/scenes/cornell.gltf" \
            --camera-path "$SRC/data/suites/cornell_still.json" --out "$tmp/rs_s$m" --quiet || break
done
rc=$?
[ $rc -eq 0 ] && ! cmp -s "$tmp/rs_o1/frame_0003.exr" "$tmp/rs_o2/frame_0003.exr" &&
    cmp -s "$tmp/rs_s1/frame_0003.exr" "$tmp/rs_s2/frame_0003.exr" &&
    python3 -c 'import json, sys; assert json.load(open(sys.argv[1]))["resample"] == 1' \
        "$tmp/rs_o1/run.json"
check "recurrent --resample: 1 and 2 differ under motion, agree on a still camera (got $rc)" $?
# the contract's spec_hit and diffuse_view: a capture carries them; one without them (an older
# capture, another renderer's) is denoised with surface motion for reflections and the view
# factor in the histories, and the denoiser says so (diffuse_view on svgf: this capture's
# gradient samples were picked by luminances without the view factor, so recurrent's replay
# of them needs it)
exrheader "$tmp/rc/capture/frame_0001.exr" 2>/dev/null | grep -q "spec.hitT" &&
    exrheader "$tmp/rc/capture/frame_0001.exr" 2>/dev/null | grep -q "diffuse.view"
check "a capture carries spec.hitT and diffuse.view" $?
# strip_channel DIR CHANNEL: the capture frames in DIR without CHANNEL (as an older capture)
strip_channel() {
    local f chans
    for f in "$1/"frame_000?.exr; do
        chans=$(oiiotool --info -v "$f" | grep "channel list" | sed "s/.*channel list: //; s/ ([a-z]*)//g; s/, /,/g; s/$2,//")
        oiiotool "$f" --ch "$chans" -o "$f.tmp.exr" && mv "$f.tmp.exr" "$f"
    done
}
mkdir -p "$tmp/nohit" && cp "$tmp/rc/capture/"* "$tmp/nohit/"
strip_channel "$tmp/nohit" spec.hitT
"$T" denoise --captures "$tmp/nohit" --denoiser recurrent --out "$tmp/nohit_dn" 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && grep -q "no spec.hitT: recurrent moves reflections with their surfaces" "$tmp/err" &&
    ! grep -q "diffuse.view" "$tmp/err" &&
    ! exrheader "$tmp/nohit/frame_0001.exr" 2>/dev/null | grep -q "spec.hitT" &&
    "$T" denoise --captures "$tmp/rc/capture" --denoiser recurrent --out "$tmp/hit_dn" 2>"$tmp/err2" &&
    ! grep -q "spec.hitT\|diffuse.view" "$tmp/err2"
check "captures without spec.hitT: recurrent runs with surface motion and says so (got $rc)" $?
mkdir -p "$tmp/noview" && cp "$tmp/rc/capture/"frame_000?.exr "$tmp/noview/"
strip_channel "$tmp/noview" diffuse.view
"$T" denoise --captures "$tmp/noview" --denoiser svgf --out "$tmp/noview_dn" 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && grep -q "no diffuse.view: svgf keeps the diffuse lobe's view factor" "$tmp/err" &&
    ! exrheader "$tmp/noview/frame_0001.exr" 2>/dev/null | grep -q "diffuse.view" &&
    "$T" denoise --captures "$tmp/rc/capture" --denoiser svgf --out "$tmp/view_dn" 2>"$tmp/err2" &&
    ! grep -q "diffuse.view" "$tmp/err2" &&
    ! cmp -s "$tmp/noview_dn/frame_0002.exr" "$tmp/view_dn/frame_0002.exr"
check "captures without diffuse.view: svgf keeps the view factor in its histories, and says so (got $rc)" $?
# a sweep run here says its summary: the cells it runs quietly leave it loud
"$T" bench --scene "$SRC/data/scenes/cornell.gltf" --size 24x16 --frames 2 --warmup 1 --spp 8 \
    --sweep antilag=2 --out "$tmp/loud" >"$tmp/loud_out" 2>"$tmp/loud_err"; rc=$?
[ $rc -eq 0 ] && grep -q "tandem: bench: 1 runs ->" "$tmp/loud_err" &&
    grep -q "antilag=2" "$tmp/loud_out" && python3 - "$tmp/loud/runs/000/run.json" <<'PY'
import json, sys
assert json.load(open(sys.argv[1]))["antilag"] == 2
PY
check "a local sweep keeps its own messages (no --quiet left behind); a parameter is a knob" $?

# mended with the run layer: eval --quiet writes its files and prints nothing; a one-frame
# report has its player; the CPU composite says what it does not run; off's dumps are zeros
"$T" render --frames 1 --size 24x16 --out "$tmp/one" --quiet &&
    "$T" reference --frames 1 --size 24x16 --spp 8 --out "$tmp/one_ref" --quiet &&
    "$T" eval --out "$tmp/one" --reference "$tmp/one_ref" --report "$tmp/one_rep" --quiet \
        >"$tmp/one_out" 2>/dev/null; rc=$?
[ $rc -eq 0 ] && [ ! -s "$tmp/one_out" ] && [ -s "$tmp/one/metrics.json" ] &&
    grep -q 'href="viewer.html"' "$tmp/one_rep/index.html" && [ -s "$tmp/one_rep/viewer.html" ] &&
    [ -s "$tmp/one_rep/frames/f0000.js" ]
check "eval --quiet prints nothing; a one-frame report writes the player it links to (got $rc)" $?
"$T" render --frontend embree --denoiser off --taa on --frames 1 --size 24x16 --out "$tmp/cpu_taa" \
    --quiet 2>"$tmp/err"; rc=$?
"$T" render --frontend embree --denoiser off --frames 1 --size 24x16 --out "$tmp/cpu_none" \
    --quiet 2>"$tmp/err2"
[ $rc -eq 0 ] && grep -q -- "--taa on not run: --frontend embree with --denoiser off composites on the CPU" \
    "$tmp/err" && [ ! -s "$tmp/err2" ]
check "embree with --denoiser off: --taa on said not to run (and nothing said without it)" $?
"$T" render --frontend vk --denoiser off --dump all --frames 2 --size 24x16 --out "$tmp/off_dump" \
    --quiet && $PY - "$tmp/off_dump/dump" <<'PY'
import glob, sys
import OpenImageIO as oiio
import numpy as np
files = sorted(glob.glob(sys.argv[1] + "/*_0001.exr"))
assert len(files) > 10, files
for f in files:
    px = oiio.ImageBuf(f).get_pixels(oiio.FLOAT)
    if "/output_" in f:
        assert np.isfinite(px).all() and px.max() > 0, f
    else:  # (nothing of off's: zeros, not the memory's leftovers)
        assert not px.any(), (f, float(np.nanmax(np.abs(px))))
PY
check "--denoiser off: every dump but the output is zeros" $?

echo "$pass passed, $fail failed"
[ $fail -eq 0 ]
