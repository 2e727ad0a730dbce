#!/bin/bash
# tests/test_view.sh TANDEM: `tandem view` under Xvfb on the Vulkan device (lavapipe in CI),
# driven by scripts (--script: timed key, mouse and resize events):
#  - no display: a clear message and exit 1;
#  - a session opens the window, flies (W, mouse drag), resizes it, switches the denoiser, the
#    front-end, the views and the split, takes screenshots and exits 0;
#  - every final-image screenshot equals `tandem render --view` of its repro state bit for bit
#    (PNG bytes and EXR pixels): the viewer's frame is render's, the camera path and settings
#    the state's;
#  - a repro state round-trips (--state, then a screenshot at once: the same settings, the path
#    one frame longer at the same camera);
#  - F5 reloads the shaders from $TANDEM_SHADER_DIR (an edited compositor inverts the window);
#  - --camera-path: the viewer plays the orbit, F12 writes it as a camera path file, render takes it;
#  - a bad script is refused by name.
# The validation layer is on (the test's environment): an error fails the session.
set -uo pipefail
T=$1
SRC=$(cd "$(dirname "$0")/.." && pwd)
TMP=$(mktemp -d /tmp/tandem_view.XXXXXX)
trap 'rm -rf "$TMP"' EXIT
pass=0 failn=0
ok() { echo "ok   $1"; pass=$((pass + 1)); }
bad() { echo "FAIL $1"; failn=$((failn + 1)); }
check() { if eval "$2"; then ok "$1"; else bad "$1"; fi; }
XVFB=(xvfb-run -a -s "-screen 0 1024x768x24")
PY=/usr/bin/python3
# a repro state's last frame (a camera held still is one path entry with "frames")
last_frame() {
    $PY -c "import json, sys; e = json.load(open(sys.argv[1]))['path'][-1]; print(e['frame'] + e.get('frames', 1) - 1)" "$1"
}

# no display
DISPLAY= WAYLAND_DISPLAY= "$T" view --frames 1 --out "$TMP/none" > "$TMP/none.log" 2>&1
rc=$?
check "no display: exit 1 with a message" \
    "[ $rc -eq 1 ] && grep -q 'cannot open a window' '$TMP/none.log'"

cat > "$TMP/session.json" <<'JSON'
{"events": [
  {"frame": 2, "key": "W", "down": true},
  {"frame": 6, "key": "W", "down": false},
  {"frame": 7, "mouse": [40, -12]},
  {"frame": 9, "screenshot": true},
  {"frame": 10, "resize": [200, 120]},
  {"frame": 11, "key": "2"},
  {"frame": 11, "key": "LEFT_BRACKET"},
  {"frame": 12, "key": "A", "down": true},
  {"frame": 14, "key": "A", "down": false},
  {"frame": 17, "screenshot": true},
  {"frame": 18, "key": "V"},
  {"frame": 18, "key": "V"},
  {"frame": 19, "key": "TAB"},
  {"frame": 21, "screenshot": true},
  {"frame": 22, "key": "TAB"},
  {"frame": 22, "key": "F"},
  {"frame": 22, "key": "3"},
  {"frame": 22, "key": "M"},
  {"frame": 22, "key": "G"},
  {"frame": 22, "key": "EQUAL"},
  {"frame": 23, "key": "R"},
  {"frame": 24, "key": "TAB"},
  {"frame": 26, "screenshot": true},
  {"frame": 27, "exit": true}
]}
JSON
"${XVFB[@]}" "$T" view --scene "$SRC/data/scenes/cornell.gltf" --size 160x90 \
    --script "$TMP/session.json" --out "$TMP/shots" > "$TMP/session.log" 2>&1
rc=$?
check "scripted session: exit 0" "[ $rc -eq 0 ]" || cat "$TMP/session.log"
check "scripted session: 4 screenshots (final, HDR, as shown, state)" \
    "[ \$(ls '$TMP/shots' | grep -c '^shot_000[0-3]\.\(png\|exr\|view\.png\|json\)$') -eq 16 ]"
$PY - "$TMP/shots" > "$TMP/states.txt" <<'PYEOF'
import json, sys
d = sys.argv[1]
for i in range(4):
    j = json.load(open(f"{d}/shot_{i:04d}.json"))
    print(i, j["size"][0], j["size"][1], j["denoiser"], j["frontend"], j["view"], j["split"],
          sum(e.get("frames", 1) for e in j["path"]), j["min_alpha"], j["antilag"],
          j["exposure_bias"], j["bounces"], j["half_indirect"])
PYEOF
cat "$TMP/states.txt"
check "the states follow the session (resize, denoiser, view, split, front-end, knobs, half)" \
    "grep -q '^0 160 90 asvgf vk final off 10 0 0 0 1 0$' '$TMP/states.txt' &&
     grep -q '^1 200 120 svgf vk final off 7 .* 1 1$' '$TMP/states.txt' &&
     grep -q '^2 200 120 svgf vk normal noisy 3 .* 1 1$' '$TMP/states.txt' &&
     grep -q '^3 200 120 off embree normal frontend 3 0.05 2 0.5 1 1$' '$TMP/states.txt'"

# each screenshot's final image = render --view of its state
for i in 0 1 2 3; do
    st="$TMP/shots/shot_000$i.json"
    last=$(last_frame "$st")
    "$T" render --view "$st" --out "$TMP/render$i" --quiet > "$TMP/render$i.log" 2>&1 ||
        cat "$TMP/render$i.log"
    f=$(printf 'frame_%04d' "$last")
    check "shot $i: render --view gives the same PNG, byte for byte" \
        "cmp -s '$TMP/render$i/$f.png' '$TMP/shots/shot_000$i.png'"
    check "shot $i: and the same HDR pixels" \
        "idiff -q -fail 0 -failpercent 0 -warn 0 '$TMP/render$i/$f.exr' \
             '$TMP/shots/shot_000$i.exr' > /dev/null"
done
check "the split and the view show in the window (shot 2 as shown differs from its final)" \
    "! cmp -s '$TMP/shots/shot_0002.view.png' '$TMP/shots/shot_0002.png'"

# the repro state round-trips
echo '{"events": [{"frame": 0, "screenshot": true}, {"frame": 1, "exit": true}]}' \
    > "$TMP/once.json"
"${XVFB[@]}" "$T" view --state "$TMP/shots/shot_0001.json" --script "$TMP/once.json" \
    --out "$TMP/again" > "$TMP/again.log" 2>&1
check "--state: exit 0" "[ $? -eq 0 ]" || cat "$TMP/again.log"
$PY - "$TMP/shots/shot_0001.json" "$TMP/again/shot_0000.json" <<'PYEOF'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
pa, pb = a.pop("path"), b.pop("path")
assert a == b, (a, b)
# a new flight from the state's last camera: one frame, the next frame index
assert len(pb) == 1 and pb[0].get("frames", 1) == 1, pb
assert pb[0]["frame"] == pa[-1]["frame"] + pa[-1].get("frames", 1), (pa[-1], pb)
for k in ("position", "yaw", "pitch"):
    assert pb[0][k] == pa[-1][k], (k, pb[0][k], pa[-1][k])
PYEOF
check "the repro state round-trips (settings equal, camera kept)" "[ $? -eq 0 ]"

# U: the render scale (1, 0.67, 0.5): traced at 80x45 and upscaled to the window's 160x90; the
# views refuse (they read the contract at the window's size); the state keeps the scale and
# render --view takes it back, pixel for pixel
cat > "$TMP/scaled.json" <<'JSON'
{"events": [{"frame": 0, "key": "U"}, {"frame": 0, "key": "U"}, {"frame": 1, "key": "V"},
  {"frame": 5, "screenshot": true}, {"frame": 6, "exit": true}]}
JSON
"${XVFB[@]}" "$T" view --scene "$SRC/data/scenes/cornell.gltf" --size 160x90 \
    --script "$TMP/scaled.json" --out "$TMP/scaled" > "$TMP/scaled.log" 2>&1
check "U: exit 0" "[ $? -eq 0 ]" || cat "$TMP/scaled.log"
$PY - "$TMP/scaled/shot_0000.json" <<'PYEOF'
import json, sys
j = json.load(open(sys.argv[1]))
assert j["render_scale"] == 0.5 and j["view"] == "final" and j["size"] == [160, 90], j
PYEOF
check "U twice: the state holds render scale 0.5, the final view (V refused while scaled)" "[ $? -eq 0 ]"
last=$(last_frame "$TMP/scaled/shot_0000.json")
"$T" render --view "$TMP/scaled/shot_0000.json" --out "$TMP/rscaled" --quiet \
    > "$TMP/rscaled.log" 2>&1 || cat "$TMP/rscaled.log"
f=$(printf 'frame_%04d' "$last")
check "the scaled shot: render --view traces 80x45 and gives the same PNG, byte for byte" \
    "grep -q '\"render_width\":[[:space:]]*80' '$TMP/rscaled/run.json' &&
     cmp -s '$TMP/rscaled/$f.png' '$TMP/scaled/shot_0000.png'"
$PY -c "import json, sys; j = json.load(open(sys.argv[1])); j['render_scale'] = 5; json.dump(j, open(sys.argv[2], 'w'))" \
    "$TMP/scaled/shot_0000.json" "$TMP/scale_bad.json"
"$T" render --view "$TMP/scale_bad.json" --out "$TMP/scale_bad" > "$TMP/scale_bad.log" 2>&1
check "a state with render_scale 5: exit 1, named, nothing written" \
    "[ $? -eq 1 ] && grep -q 'scale_bad.json: \"render_scale\": 5: 0.25 to 1' '$TMP/scale_bad.log' &&
     [ ! -e '$TMP/scale_bad' ]"

# X: the error views against the progressive reference (relative error, then FLIP from the
# device metrics), the overlay off so that the window shows the view itself; a screenshot in
# each: what the window shows is no longer the final image, and the two views differ
cat > "$TMP/errv.json" <<JSON
{"events": [{"frame": 0, "key": "O"}, {"frame": 1, "key": "X"}, {"frame": 4, "screenshot": true},
  {"frame": 5, "key": "X"}, {"frame": 8, "screenshot": true}, {"frame": 9, "key": "X"},
  {"frame": 10, "screenshot": true}, {"frame": 11, "exit": true}]}
JSON
"${XVFB[@]}" "$T" view --scene "$SRC/data/scenes/cornell.gltf" --size 96x64 \
    --script "$TMP/errv.json" --out "$TMP/errv" > "$TMP/errv.log" 2>&1
check "X: the error views, exit 0" "[ $? -eq 0 ]" || cat "$TMP/errv.log"
$PY - "$TMP/errv" <<'PYEOF'
import sys
import numpy as np, OpenImageIO as oiio
d = sys.argv[1]
def rd(p):
    i = oiio.ImageInput.open(p); a = i.read_image(format="uint8"); i.close(); return np.asarray(a, int)
rel, flip, off = (rd(f"{d}/shot_{k:04d}.view.png") for k in range(3))
assert np.abs(rel - rd(f"{d}/shot_0000.png")).max() > 32, "relative error view: the final image"
assert np.abs(flip - rel).max() > 32, "FLIP view: the same as the relative error's"
assert (off == rd(f"{d}/shot_0002.png")).all(), "X a third time: the final image again"
PYEOF
check "X: relative error and FLIP views against the reference, then the final image again" "[ $? -eq 0 ]"

# --camera-path: the viewer plays the orbit (nothing flown), and F12 writes the flight as a
# camera path file: a key per frame on the orbit's circle, which render takes back
echo '{"events": [{"frame": 5, "screenshot": true}, {"frame": 6, "exit": true}]}' > "$TMP/orbit.json"
"${XVFB[@]}" "$T" view --scene "$SRC/data/scenes/cornell.gltf" --size 96x64 --camera-path orbit \
    --path-duration 2 --script "$TMP/orbit.json" --out "$TMP/orbit" > "$TMP/orbit.log" 2>&1
check "--camera-path orbit: exit 0" "[ $? -eq 0 ]" || cat "$TMP/orbit.log"
$PY - "$TMP/orbit/shot_0000.path.json" <<'PYEOF'
import json, math, sys
k = json.load(open(sys.argv[1]))["keyframes"]
assert len(k) == 6, len(k)
assert all(b["time"] > a["time"] for a, b in zip(k, k[1:])), "times increase"
# on a circle about a vertical axis: the same height, the same distance from the centre of the
# circle through the first, third and fifth keys (x, z)
assert max(abs(e["position"][1] - k[0]["position"][1]) for e in k) < 1e-4, "one height"
(x1, z1), (x2, z2), (x3, z3) = ((k[i]["position"][0], k[i]["position"][2]) for i in (0, 2, 4))
d = 2 * (x1 * (z2 - z3) + x2 * (z3 - z1) + x3 * (z1 - z2))
cx = ((x1 * x1 + z1 * z1) * (z2 - z3) + (x2 * x2 + z2 * z2) * (z3 - z1) + (x3 * x3 + z3 * z3) * (z1 - z2)) / d
cz = ((x1 * x1 + z1 * z1) * (x3 - x2) + (x2 * x2 + z2 * z2) * (x1 - x3) + (x3 * x3 + z3 * z3) * (x2 - x1)) / d
r = [math.hypot(e["position"][0] - cx, e["position"][2] - cz) for e in k]
assert max(r) - min(r) < 1e-3 * max(r), r
assert math.hypot(k[5]["position"][0] - k[0]["position"][0], k[5]["position"][2] - k[0]["position"][2]) > 0.1, "it moved"
PYEOF
check "F12 writes the orbit as a camera path (a key per frame, on its circle)" "[ $? -eq 0 ]"
"$T" render --scene "$SRC/data/scenes/cornell.gltf" --size 96x64 --frames 6 \
    --camera-path "$TMP/orbit/shot_0000.path.json" --out "$TMP/orbit_render" --quiet
check "render --camera-path FILE.json takes the viewer's path" "[ $? -eq 0 ] && [ -e '$TMP/orbit_render/frame_0005.exr' ]"

# F5: the shaders again from $TANDEM_SHADER_DIR (scripts/compile-shaders.sh). The session
# starts with the directory empty (the embedded code), takes a screenshot, waits until the test
# compiled an inverting view_compose.comp into it, reloads, takes another. The overlay is off, so
# that what the window shows is the final image itself, then its inverse.
mkdir -p "$TMP/spv"
cp -r "$SRC/shaders" "$TMP/src"
sed -i 's/imageStore(result, p, vec4(clamp(c, 0.0, 1.0), 1.0));/imageStore(result, p, vec4(1.0 - clamp(c, 0.0, 1.0), 1.0));/' \
    "$TMP/src/view_compose.comp"
grep -q '1.0 - clamp' "$TMP/src/view_compose.comp" || bad "the test could not edit view_compose.comp"
cat > "$TMP/reload.json" <<JSON
{"events": [{"frame": 0, "key": "O"}, {"frame": 3, "screenshot": true},
  {"frame": 4, "wait_for": "$TMP/spv/ready"}, {"frame": 4, "key": "F5"},
  {"frame": 7, "screenshot": true}, {"frame": 8, "exit": true}]}
JSON
TANDEM_SHADER_DIR="$TMP/spv" "${XVFB[@]}" "$T" view --scene "$SRC/data/scenes/cornell.gltf" \
    --size 96x64 --script "$TMP/reload.json" --out "$TMP/reload" > "$TMP/reload.log" 2>&1 &
vpid=$!
for _ in $(seq 600); do [ -e "$TMP/reload/shot_0000.json" ] && break; sleep 0.1; done
"$SRC/scripts/compile-shaders.sh" "$TMP/spv" "$TMP/src" view_compose > /dev/null && touch "$TMP/spv/ready"
wait $vpid
check "F5: exit 0, one shader reloaded" \
    "grep -q '1 shaders from TANDEM_SHADER_DIR' '$TMP/reload.log'" || cat "$TMP/reload.log"
$PY - "$TMP/reload" <<'PYEOF'
import sys
import numpy as np, OpenImageIO as oiio
d = sys.argv[1]
def rd(p):
    i = oiio.ImageInput.open(p); a = i.read_image(format="uint8"); i.close(); return np.asarray(a, int)
f0, v0 = rd(f"{d}/shot_0000.png"), rd(f"{d}/shot_0000.view.png")
f1, v1 = rd(f"{d}/shot_0001.png"), rd(f"{d}/shot_0001.view.png")
assert (v0 == f0).all(), "before: the window shows the final image"
assert np.abs(v1 - (255 - f1)).max() <= 1, "after F5: its inverse"
PYEOF
check "F5: the window shows the final image, then (the edited shader) its inverse" "[ $? -eq 0 ]"
"$T" render --view "$TMP/reload/shot_0001.json" --out "$TMP/reload_r" --quiet
last=$(last_frame "$TMP/reload/shot_0001.json")
check "F5: the final image still equals render --view (only the compositor changed)" \
    "cmp -s '$TMP/reload_r/$(printf frame_%04d "$last").png' '$TMP/reload/shot_0001.png'"

# a camera held still is one path entry however long it is held (a viewer left running does
# not grow: docs/reliability.md, "Soak"); a state whose entries do not follow each other, or
# with "frames": 0, is refused by name
$PY - "$TMP/reload/shot_0001.json" "$TMP/held_bad.json" "$TMP/held_zero.json" <<'PYEOF'
import json, sys
j = json.load(open(sys.argv[1]))
# (F5 restarted the history at frame 4: frames 4 to 7 at one camera)
assert len(j["path"]) == 1 and j["path"][0]["frames"] == 4, j["path"]
bad = dict(j, path=[dict(j["path"][0]), dict(j["path"][0], frame=j["path"][0]["frame"] + 7)])
json.dump(bad, open(sys.argv[2], "w"))
json.dump(dict(j, path=[dict(j["path"][0], frames=0)]), open(sys.argv[3], "w"))
PYEOF
check "a still camera is one path entry with its 4 frames" "[ $? -eq 0 ]"
"$T" render --view "$TMP/held_bad.json" --out "$TMP/held_bad" > "$TMP/held_bad.log" 2>&1
check "a path whose entries leave a gap: exit 1, named" \
    "[ $? -eq 1 ] && grep -q 'held_bad.json: path entry 1: frame 11 after 4 frames from 4' '$TMP/held_bad.log'"
"$T" render --view "$TMP/held_zero.json" --out "$TMP/held_zero" > "$TMP/held_zero.log" 2>&1
check "a path entry of 0 frames: exit 1, named" \
    "[ $? -eq 1 ] && grep -q 'held_zero.json: path entry 0:' '$TMP/held_zero.log'"

# a bad script
echo '{"events": [{"frame": 0, "key": "NOPE"}]}' > "$TMP/bad.json"
"${XVFB[@]}" "$T" view --script "$TMP/bad.json" --out "$TMP/bad" > "$TMP/bad.log" 2>&1
rc=$?
check "bad script: exit 1 naming the key" "[ $rc -eq 1 ] && grep -q 'key \"NOPE\" unknown' '$TMP/bad.log'"

echo "$pass passed, $failn failed"
[ "$failn" -eq 0 ]
