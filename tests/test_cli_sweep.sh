#!/usr/bin/env bash
# tests/test_cli_sweep.sh TANDEM: `tandem bench --sweep` (cells against matched references, Pareto
# fronts) and `bench --extremes` (the numerical stability report) from outside.
source "$(dirname "$0")/cli_common.sh" "$1"

# speed/accuracy sweep: 3 knobs, 8 runs, Pareto fronts; each cell against the matched reference
# of its estimator (two: bounces 1 and 2), and against the unbiased one; the report opens in
# Chromium
"$T" bench --scene "$SRC/data/scenes/cornell.gltf" --size 40x24 --frames 5 --warmup 2 --spp 32 \
    --sweep bounces=1,2 --sweep atrous=1,4 --sweep gradient=on,off --out "$tmp/sweep" --quiet \
    >"$tmp/sw_out" 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && $PY - "$tmp/sweep/sweep.json" "$tmp/sweep/sweep.csv" <<'PY'
import json, math, sys
d = json.load(open(sys.argv[1]))
runs = d["runs"]
assert d["knobs"] == ["bounces", "atrous", "gradient"] and len(runs) == 8
assert len({tuple(sorted(r["knobs"].items())) for r in runs}) == 8
# each cell timed on 24 frames back to back after its 5 (render --timed-frames)
assert d["timed_frames"] == 24, d["timed_frames"]
t = json.load(open(sys.argv[1].replace("sweep.json", "runs/000/timings.json")))
assert len(t["frames"]) == 5 and len(t["back_to_back"]["frames"]) == 24, t.keys()
assert [f["frame"] for f in t["back_to_back"]["frames"]] == list(range(5 + 4, 5 + 4 + 24))
# each timed frame's host work (the same parts as bench --whole-frame's), and their medians: a
# frame's host parts are inside its wall clock (recording and submission wait for the frame
# before, so they take most of it on lavapipe; 1.5x for the clock's jitter between frames)
parts = ("evaluate", "set_frame", "chain_run")
b2b = t["back_to_back"]
for f in b2b["frames"]:
    assert all(f["host_ms"][k] >= 0 for k in parts), f
assert 0 < sum(b2b["host_ms_median"][k] for k in parts) < 1.5 * b2b["wall_ms"], b2b
for r in runs:
    assert r["total_ms"] > 0 and r["pass_ms"]["denoise_atrous_ms"] > 0, r
    assert r["wall_ms"] > 0, r
    assert math.isfinite(r["relmse"]) and 0 < r["flip"] < 1, r
    assert math.isfinite(r["relmse_unbiased"]) and r["estimator_bias_relmse"] > 0, r
    assert (r["pass_ms"]["denoise_gradient_ms"] > 0) == (r["knobs"]["gradient"] == "on"), r
    assert r["matched_reference"].endswith("bounces%s_40x24" % r["knobs"]["bounces"]), r
matched = {r["knobs"]["bounces"]: r["matched_reference"] for r in runs}
assert len(set(matched.values())) == 2  # one per estimator, shared by its 4 cells
bias = {r["knobs"]["bounces"]: r["estimator_bias_relmse"] for r in runs}
assert bias["2"] < bias["1"], bias  # a second bounce brings the expectation nearer the truth
assert any(r["pareto_relmse"] for r in runs) and any(r["pareto_flip"] for r in runs)
assert len(open(sys.argv[2]).read().strip().split("\n")) == 9
PY
check "bench --sweep over 3 knobs: 8 runs, each against its estimator's matched reference" $?
chromium --headless=new --no-sandbox --disable-gpu --virtual-time-budget=5000 --dump-dom \
    "file://$tmp/sweep/report/index.html" >"$tmp/dom" 2>/dev/null
grep -q 'data-images="2" data-broken="" data-status="ok"' "$tmp/dom"
check "the sweep report (Pareto plots and table) loads in Chromium" $?
"$T" bench --sweep spp=1,4 --out "$tmp/sw2" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "one sample per pixel" "$tmp/err" && [ ! -e "$tmp/sw2" ]
check "bench --sweep spp explains why it is not a real-time knob (usage error, no output)" $?
"$T" bench --sweep colour=red --out "$tmp/sw3" 2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] && grep -q "atrous" "$tmp/err" && [ ! -e "$tmp/sw3" ]
check "bench --sweep with an unknown key lists the keys" $?

# numerical stability report: extremes through every mode
"$T" bench --extremes --size 64x36 --frames 4 --out "$tmp/ext" --quiet >"$tmp/ext_out" 2>"$tmp/err"; rc=$?
"$T" info --pipeline --json >"$tmp/ext_info.json"
$PY - "$tmp/ext/extremes.json" $rc "$tmp/ext_info.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
rc = int(sys.argv[2])
info = json.load(open(sys.argv[3]))
runs = d["runs"]
# every live front-end (those render takes) x every registered denoiser x both precisions
live = [f for f in info["frontends"] if "recorded" not in f["capabilities"]]
want = len(live) * len(info["denoisers"]) * 2
assert want == 16, want  # embree, vk x asvgf, svgf, off, recurrent x float32, packed
assert len(runs) == want and len({(r["frontend"], r["denoiser"], r["precision"]) for r in runs}) == want
assert rc == (1 if d["nonfinite"] else 0), (rc, d["nonfinite"])   # exit status says it
for r in runs:
    b = r["buffers"]
    # what users get is finite in every mode: the frames, and every contract entry
    assert b["output"]["nonfinite"] == 0, r
    assert all(v["nonfinite"] == 0 for k, v in b.items() if k.startswith("contract.")), r
    # the scene's 1e5 emitter is above half's range: the report sees the packed clamp coming
    if r["precision"] == "float32":
        assert b["contract.emission"]["over_half_max"] > 0 and b["contract.emission"]["max_abs"] >= 1e5
    if r["denoiser"] != "off" or r["frontend"] == "vk":
        assert any(k.startswith("denoise.") for k in b), r
for p in d["packed_vs_float32"]:
    e = p["entries"]
    assert e["albedo"]["max_relative"] < 1e-3 and e["normal"]["max_relative"] < 1e-3, p  # half: 2^-11
    assert e["emission"]["max_relative"] > 0.3, p   # 1e5 clamped to 65504: the cost, measured
print("     extremes: %d NaN/Inf inside the back-end's buffers" % d["nonfinite"])
PY
check "bench --extremes: every mode (16), finite frames and contracts, packed clamps found and measured" $?
chromium --headless=new --no-sandbox --disable-gpu --virtual-time-budget=5000 --dump-dom \
    "file://$tmp/ext/report/index.html" >"$tmp/dom" 2>/dev/null
grep -q 'data-status="ok"' "$tmp/dom" && grep -q "Packed against float32" "$tmp/ext/report/index.html"
check "the stability report loads in Chromium" $?

# render at a smaller scale, upscaled (docs/upscaling.md): the output at --size, run.json says
# the render size and the upscaler; captures at the render size, which eval leaves out; a
# sweep over render-scale and upscaler; the CPU composite and references refuse it by name
"$T" render --frontend vk --denoiser asvgf --size 40x24 --render-scale 0.5 --frames 3 --capture \
    --out "$tmp/up" --quiet 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && $PY - "$tmp/up" <<'PY'
import json, sys, OpenImageIO as oiio
d = sys.argv[1]
r = json.load(open(d + "/run.json"))
assert (r["width"], r["height"], r["render_width"], r["render_height"]) == (40, 24, 20, 12), r
assert r["render_scale"] == 0.5 and r["upscaler"] == "temporal", r
assert "taau" in r["post"]["passes"], r["post"]
assert oiio.ImageInput.open(d + "/frame_0002.exr").spec().width == 40
assert oiio.ImageInput.open(d + "/capture/frame_0002.exr").spec().width == 20
PY
check "render --render-scale 0.5: output at --size, traced at half, run.json says so" $?
"$T" reference --size 40x24 --frames 3 --spp 16 --estimator realtime --out "$tmp/upref" --quiet &&
    "$T" eval --out "$tmp/up" --matched-reference "$tmp/upref" --quiet >/dev/null 2>"$tmp/err"
check "eval of a scaled run: the output against the full size's matched reference" $?
# the traced pixels filter textures for the shown ones (the ray cones' spread scaled by the render
# size over the output's: a mip bias of log2(0.5)), on a model nobody here wrote (Khronos'
# BoxTextured, assimp-testmodels): the half-size run's albedo sharper than a run traced at that
# size for itself (measured +30% neighbour differences; its mean the same texture's within 1%),
# and the two front-ends equal on it (measured 5e-8 mean, 3e-6 largest)
BOX=/usr/share/assimp/models/glTF2/BoxTextured-glTF/BoxTextured.gltf
for fe in vk embree; do
    "$T" render --frontend $fe --denoiser asvgf --scene "$BOX" --size 64x36 --render-scale 0.5 \
        --frames 2 --capture --out "$tmp/fp_$fe" --quiet 2>>"$tmp/err" || echo "render $fe failed"
done
"$T" render --frontend vk --denoiser asvgf --scene "$BOX" --size 32x18 --frames 2 --capture \
    --out "$tmp/fp_own" --quiet 2>>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && $PY - "$tmp" <<'PY'
import sys, numpy as np, OpenImageIO as oiio
def albedo(run):
    i = oiio.ImageInput.open(sys.argv[1] + "/" + run + "/capture/frame_0001.exr")
    names, px = list(i.spec().channelnames), i.read_image(oiio.FLOAT)
    i.close()
    return px[..., [names.index("albedo." + c) for c in "RGB"]]
def detail(a):
    y = a.mean(-1)
    return np.abs(np.diff(y, axis=0)).mean() + np.abs(np.diff(y, axis=1)).mean()
half, own, emb = albedo("fp_vk"), albedo("fp_own"), albedo("fp_embree")
assert half.shape == own.shape == (18, 32, 3), half.shape
assert detail(half) > 1.15 * detail(own), (detail(half), detail(own))
assert abs(half.mean() / own.mean() - 1) < 0.02, (half.mean(), own.mean())
assert np.abs(half - emb).max() < 1e-4, np.abs(half - emb).max()
PY
check "a scaled run's textures filtered for the shown pixels, on both front-ends alike" $?
"$T" bench --scene "$SRC/data/scenes/cornell.gltf" --size 40x24 --frames 4 --warmup 2 --spp 16 \
    --sweep render-scale=0.5,1 --sweep upscaler=temporal,bilinear --out "$tmp/upsw" --quiet \
    >/dev/null 2>"$tmp/err" && $PY - "$tmp/upsw/sweep.json" <<'PY'
import json, math, sys
d = json.load(open(sys.argv[1]))
assert d["knobs"] == ["render-scale", "upscaler"] and len(d["runs"]) == 4, d["knobs"]
for r in d["runs"]:
    assert math.isfinite(r["relmse"]) and 0 < r["flip"] < 1, r
PY
check "bench --sweep render-scale=0.5,1 --sweep upscaler=...: 4 cells" $?
"$T" render --frontend embree --denoiser off --render-scale 0.5 --frames 1 --out "$tmp/upbad" \
    2>"$tmp/err"; rc=$?
[ $rc -eq 2 ] || [ $rc -eq 1 ]; [ $? -eq 0 ] && grep -q -- "--render-scale: the post chain upscales on the GPU" "$tmp/err" &&
    [ ! -e "$tmp/upbad" ] &&
    ! "$T" render --render-scale 0.1 --out "$tmp/upbad" 2>"$tmp/err" &&
    grep -q -- "--render-scale 0.1: expected 0.25 to 1" "$tmp/err" &&
    ! "$T" reference --render-scale 0.5 --out "$tmp/upbad" 2>"$tmp/err"
check "--render-scale refused by name: the CPU composite, out of range, references" $?

# bench --whole-frame: the whole frame back to back through render's frame (rn_frame_begin and
# rn_frame_step in the run layer); its passes sum to their groups and the frame, and the host's
# parts of a frame not waited for lie inside that way's wall clock
"$T" bench --whole-frame --frontend vk --denoiser recurrent --lights tree \
    --scene "$SRC/data/scenes/many_lights.gltf" --size 32x18 --repeats 1 --json \
    >"$tmp/wf.json" 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && $PY - "$tmp/wf.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
assert d["denoiser"] == "recurrent" and d["lights"] == "tree" and d["blocks"] == 1, d
g = d["gpu_ms"]
groups = ("front-end", "gradients", "back-end", "post")
assert g["shade"] > 0 and g["history"] > 0 and g["taa"] > 0, g
assert abs(sum(g[k] for k in groups) - g["frame"]) < 1e-6 * max(1, g["frame"]), g
passes = [k for k in g if k not in groups and k != "frame"]
assert abs(sum(g[k] for k in passes) - g["frame"]) < 1e-6 * max(1, g["frame"]), g
h = d["host_ms_not_waited"]
assert set(h) == {"evaluate", "set_frame", "chain_run"} and min(h.values()) >= 0, h
assert 0 < sum(h.values()) < 1.5 * d["gpu_contract_no_wait"], (h, d)
assert d["gpu_contract_blocking"] > 0, d
PY
check "bench --whole-frame: the passes sum to the frame; the host's parts inside the wall clock" $?


echo "$pass passed, $fail failed"
[ $fail -eq 0 ]
