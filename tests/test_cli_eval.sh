#!/usr/bin/env bash
# tests/test_cli_eval.sh TANDEM: `tandem eval` and `compare` from outside: metrics checked by an
# independent numpy implementation, reports in headless Chromium, light-change lag, regions.
source "$(dirname "$0")/cli_common.sh" "$1"

# eval: metrics against references, checked by an independent numpy implementation, and the
# report opened in headless Chromium
"$T" render --frontend vk --scene "$SRC/data/scenes/dynamic.gltf" --frames 6 --size 48x27 --capture \
    --out "$tmp/ev_run" --quiet || echo "render for eval failed"
# (64 spp: at 16 whether the cube's disocclusion settles within the 6 frames, which the check
# below counts, hung on the reference's noise: 0 events at 16 spp, 1 at 32 and 64)
"$T" reference --scene "$SRC/data/scenes/dynamic.gltf" --frames 6 --size 48x27 --spp 64 \
    --out "$tmp/ev_ref" --quiet || echo "reference for eval failed"
"$T" eval --out "$tmp/ev_run" --reference "$tmp/ev_ref" --report "$tmp/ev_report" >"$tmp/ev_out" 2>&1; rc=$?
[ $rc -eq 0 ] && [ -f "$tmp/ev_run/metrics.json" ] && [ -f "$tmp/ev_run/metrics.csv" ] &&
    grep -q "^denoised,mean," "$tmp/ev_run/metrics.csv" && grep -q "^noisy (1 spp),3," "$tmp/ev_run/metrics.csv"
check "eval writes metrics.json and metrics.csv (denoised and noisy series)" $?
$PY "$SRC/tests/metrics_reference.py" "$tmp/ev_run" "$tmp/ev_ref" 0 3 5 --motion >"$tmp/ev_py.json" 2>"$tmp/err" &&
$PY - "$tmp/ev_py.json" "$tmp/ev_run/metrics.json" <<'PY'
import json, sys
py = json.load(open(sys.argv[1]))
c = json.load(open(sys.argv[2]))
assert abs(py["exposure"] - c["settings"]["exposure"]) <= 1e-6 * py["exposure"]
den = {f["frame"]: f for f in c["series"][0]["frames"]}
assert c["series"][0]["name"] == "denoised" and len(den) == 6
for p in py["frames"]:
    for k in ("relmse", "smape", "rmse", "psnr", "ssim", "flip"):
        a, b = p[k], den[p["frame"]][k]
        assert abs(a - b) <= 1e-3 * abs(a), (p["frame"], k, a, b)
s = c["series"]
assert s[0]["summary"]["relmse"] < s[1]["summary"]["relmse"], "denoised must beat noisy"
# with the reference's motion (frame_NNNN.motion.exr): per frame and over the sequence
mo = py["motion"]
for p in mo["frames"]:
    a, b = p["mc_temporal"], den[p["frame"]]["mc_temporal"]
    assert (a is None) == (b is None) and (a is None or abs(a - b) <= 1e-3 * a), (p, b)
    assert abs(p["disoccluded"] - den[p["frame"]]["disoccluded"]) < 1e-9, p
sm = s[0]["summary"]
for k in ("mc_temporal", "flicker", "flicker_reference"):
    assert abs(mo[k] - sm[k]) <= 1e-3 * abs(mo[k]), (k, mo[k], sm[k])
for k in ("static_pixels", "disocclusions", "disocclusion_lag"):
    assert mo[k] == sm[k], (k, mo[k], sm[k])
assert sm["disocclusions"] > 0 and sm["static_pixels"] > 0, sm  # (the cube moves, a wall stays)
PY
check "eval's relMSE, SMAPE, RMSE, PSNR, SSIM, FLIP and motion-compensated metrics match numpy within 1e-3" $?
chromium --headless=new --no-sandbox --disable-gpu --virtual-time-budget=5000 --dump-dom \
    "file://$tmp/ev_report/index.html" >"$tmp/dom" 2>/dev/null
n_img=$(grep -o '<img ' "$tmp/ev_report/index.html" | wc -l)
grep -q "data-images=\"$n_img\" data-broken=\"\" data-status=\"ok\"" "$tmp/dom" && [ "$n_img" -ge 20 ]
check "the eval report loads in headless Chromium with all $n_img images" $?
"$T" compare --scene "$SRC/data/scenes/cornell.gltf" --out "$tmp/cmpx" --frames 3 --size 40x24 \
    --spp 8 --json >"$tmp/cmpx.json" 2>"$tmp/err"; rc=$?
[ $rc -eq 0 ] && $PY - "$tmp/cmpx.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
assert d["pass"] and d["compared"] == 3
e = {x["name"]: x for x in d["eval"]}
assert set(e) == {"embree", "vk"}
for k in ("relmse", "flip", "ssim"):   # the same paths: the same denoised pictures, nearly
    assert abs(e["embree"][k] - e["vk"][k]) <= 0.02 * abs(e["embree"][k]) + 1e-4, (k, e)
PY
check "compare --scene: both front-ends through one back-end agree, and score alike against one reference" $?
chromium --headless=new --no-sandbox --disable-gpu --virtual-time-budget=5000 --dump-dom \
    "file://$tmp/cmpx/report/index.html" >"$tmp/dom" 2>/dev/null
grep -q 'data-status="ok"' "$tmp/dom" && grep -q "Contract agreement" "$tmp/cmpx/report/index.html"
check "the compare report (agreement table, both series) loads in Chromium" $?

# lag after the scripted light switch of `dynamic` (its lamp goes off at frame 30)
for d in asvgf svgf; do
    "$T" render --frontend vk --scene "$SRC/data/scenes/dynamic.gltf" --start 24 --frames 14 \
        --size 48x27 --denoiser $d --out "$tmp/lag_$d" --quiet || echo "render lag $d failed"
done
"$T" reference --scene "$SRC/data/scenes/dynamic.gltf" --start 24 --frames 14 --size 48x27 \
    --spp 32 --out "$tmp/lag_ref" --quiet
for d in asvgf svgf; do
    "$T" eval --out "$tmp/lag_$d" --reference "$tmp/lag_ref" --json --quiet >"$tmp/lag_$d.json"
done
$PY - "$tmp/lag_asvgf.json" "$tmp/lag_svgf.json" "$tmp/lag_asvgf/metrics.json" <<'PY'
import json, sys
a, s = (json.load(open(f))[0] for f in sys.argv[1:3])
m = json.load(open(sys.argv[3]))["series"][0]["summary"]
assert m["lighting_changes"] == 1, m
assert 0 <= a["lag"] <= 2 and s["lag"] >= 4, (a["lag"], s["lag"])
print("     lag after the light switch: asvgf %g frames, svgf %g" % (a["lag"], s["lag"]))
PY
check "eval finds dynamic's light switch and measures the lag: A-SVGF <= 2 frames, SVGF >= 4" $?

# materials: the mirror and glass regions (from the path flags) are measured per region
"$T" render --frontend vk --scene "$SRC/data/scenes/materials.gltf" --frames 6 --size 64x36 \
    --capture --out "$tmp/mat_run" --quiet || echo "render materials failed"
"$T" reference --frontend vk --scene "$SRC/data/scenes/materials.gltf" --frames 6 --size 64x36 \
    --spp 64 --out "$tmp/mat_ref" --quiet || echo "reference materials failed"
"$T" eval --out "$tmp/mat_run" --reference "$tmp/mat_ref" --json --quiet >"$tmp/mat.json"; rc=$?
[ $rc -eq 0 ] && $PY - "$tmp/mat.json" "$tmp/mat_run/metrics.json" "$tmp/mat_run/run.json" <<'PY'
import json, sys
den, noisy = json.load(open(sys.argv[1]))[:2]
m = json.load(open(sys.argv[2]))
run = json.load(open(sys.argv[3]))
assert "interleave" in run["post"]["passes"], run["post"]["passes"]   # materials has split glass
for region in ("mirror", "glass"):
    d, n = den["regions"][region], noisy["regions"][region]
    assert d["pixels"] > 100 and d["pixels"] == n["pixels"], (region, d, n)
    # denoising helps there, and does not blur below 70% of the reference's detail
    assert d["flip"] < n["flip"], (region, d, n)
    assert d["sharpness"] > 0.7, (region, d)
    print("     %s: denoised FLIP %.3f (noisy %.3f), sharpness %.2f" % (region, d["flip"], n["flip"], d["sharpness"]))
assert "regions" in m["series"][0]
PY
check "eval on materials: mirror and glass regions, denoised better than noisy and not over-blurred; interleave ran" $?

"$T" eval --out "$tmp/ev_run" --reference "$tmp/nowhere" 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] && grep -q "nowhere" "$tmp/err"
check "eval with a missing reference directory exits 1 naming it" $?
"$T" eval --out "$tmp/ev_run" --reference "$tmp/mat_ref" --report "$tmp/ev_bad" 2>"$tmp/err"; rc=$?
[ $rc -eq 1 ] && grep -q "64x36" "$tmp/err" && grep -q "48x27" "$tmp/err" && [ ! -e "$tmp/ev_bad" ]
check "eval of frames of another size exits 1 with both sizes, no report" $?

echo "$pass passed, $fail failed"
[ $fail -eq 0 ]
