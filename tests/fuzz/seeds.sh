#!/usr/bin/env bash
# tests/fuzz/seeds.sh OUT TANDEM: the seed corpora of the fuzz targets, from files nobody here
# wrote where they exist: Debian's assimp-testmodels (glTF 2 .glb and embedded .gltf, OBJ with
# their MTL), Tandem's scenes packed into .glb, captures `tandem render` writes (both
# precisions, A-SVGF gradient samples), the shipped channel mappings, Blender's HDRIs reduced to
# small EXRs (oiiotool). OUT/<target>/ for gltf, obj, capture, mapping, env.
set -euo pipefail
OUT=$1 T=$2
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$OUT"/{gltf,obj,capture,mapping,env}
MODELS=/usr/share/assimp/models
# glTF: assimp's glTF 2 models that fit in one file, and Tandem's scenes packed as .glb
if [ -d "$MODELS/glTF2" ]; then
    find "$MODELS/glTF2" \( -name '*.glb' -o -name '*Embedded*.gltf' \) -size -1M |
        while read -r f; do cp "$f" "$OUT/gltf/$(echo "$f" | md5sum | cut -c1-12)_$(basename "$f")"; done
fi
/usr/bin/python3 - "$ROOT/data/scenes" "$OUT/gltf" <<'PY'
import json, os, struct, sys
src, out = sys.argv[1:3]
for name in sorted(os.listdir(src)):
    if not name.endswith(".gltf"):
        continue
    g = json.load(open(os.path.join(src, name)))
    bins = [b for b in g.get("buffers", []) if "uri" in b]
    if len(bins) != 1 or os.path.getsize(os.path.join(src, bins[0]["uri"])) > 1 << 20:
        continue
    data = open(os.path.join(src, bins[0]["uri"]), "rb").read()
    del bins[0]["uri"]
    js = json.dumps(g, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    data += b"\0" * (-len(data) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(data), b"BIN\0") + data
    open(os.path.join(out, name[:-5] + ".glb"), "wb").write(
        struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
PY
# OBJ: the model, "#MTL", its material library (named in.mtl, as the target writes it)
if [ -d "$MODELS/OBJ" ]; then
    find "$MODELS/OBJ" -name '*.obj' -size -200k | while read -r f; do
        o="$OUT/obj/$(basename "$f")"
        mtl=$(grep -m1 '^mtllib ' "$f" | sed 's/^mtllib *//; s/\r$//' || true)
        sed 's/^mtllib .*/mtllib in.mtl/' "$f" > "$o"
        if [ -n "$mtl" ] && [ -f "$(dirname "$f")/$mtl" ]; then
            printf '\n#MTL\n' >> "$o"
            cat "$(dirname "$f")/$mtl" >> "$o"
        fi
    done
fi
# captures: tiny renders, both precisions, with A-SVGF's gradient samples
for p in float32 packed; do
    "$T" render --scene "$ROOT/data/scenes/dynamic.gltf" --frontend embree --denoiser asvgf \
        --frames 2 --size 12x8 --precision $p --capture --out "$OUT/run_$p" --quiet
    for f in "$OUT/run_$p"/capture/*.exr; do cp "$f" "$OUT/capture/${p}_$(basename "$f")"; done
    rm -rf "$OUT/run_$p"
done
cp "$ROOT"/data/mappings/*.json "$OUT/mapping/"
# environment maps: Blender's studio lights, 32x16, float and half
for f in /usr/share/blender/datafiles/studiolights/world/*.exr; do
    [ -f "$f" ] || continue
    b=$(basename "$f" .exr)
    oiiotool "$f" --resize 32x16 -d float -o "$OUT/env/${b}_f32.exr"
    oiiotool "$f" --resize 16x8 -d half --compression none -o "$OUT/env/${b}_half.exr"
done
for t in gltf obj capture mapping env; do echo "seeds: $t $(ls "$OUT/$t" | wc -l)"; done
