#!/usr/bin/env python3
"""A generated scene of millions of triangles from real models: Sweet Home 3D's furniture (Debian's
`sweethome3d-furniture`, CC-BY / CC0 OBJ models inside .sh3f zip files), each model converted once
to glTF meshes and instanced many times on a grid, as a showroom (docs/scenes.md "Bigger still").

usage: make_furniture_scene.py OUT_DIR [--furniture DIR] [--models N] [--copies K] [--spacing M]

Reads the first N models (by name, those under 300k triangles; default 60) of every .sh3f in DIR
(default /usr/share/sweethome3d/furniture), converts each OBJ (v, vt, vn, f with polygons fanned,
usemtl; MTL Kd, map_Kd, d) to one glTF mesh with a primitive per material (Lambert-like: metallic 0,
roughness 0.6; map_Kd as the base colour texture, copied next to the scene), and places K copies of
every model (default 8) on a grid of M metres (default 2.5) on a grey floor, turned at random (seed
1). Writes OUT_DIR/furniture.gltf, furniture.bin and the images. Prints the triangle count.
No light: Tandem's default sky lights it (or --env)."""
import argparse
import json
import math
import os
import random
import struct
import sys
import zipfile


def parse_mtl(text):
    mats, cur = {}, None
    for line in text.splitlines():
        p = line.split()
        if not p or p[0].startswith("#"):
            continue
        if p[0] == "newmtl":
            cur = mats.setdefault(" ".join(p[1:]), {"Kd": (0.8, 0.8, 0.8), "map": None, "d": 1.0})
        elif cur is None:
            continue
        elif p[0] == "Kd" and len(p) >= 4:
            cur["Kd"] = tuple(float(x) for x in p[1:4])
        elif p[0] == "map_Kd" and len(p) >= 2:
            cur["map"] = p[-1]
        elif p[0] == "d" and len(p) >= 2:
            cur["d"] = float(p[1])
    return mats


def parse_obj(text):
    """Positions, uvs, normals and, per material, triangles of (v, vt, vn) index triples."""
    v, vt, vn, groups, mat = [], [], [], {}, ""
    for line in text.splitlines():
        if not line or line[0] == "#":
            continue
        p = line.split()
        if not p:
            continue
        if p[0] == "v":
            v.append(tuple(float(x) for x in p[1:4]))
        elif p[0] == "vt":
            vt.append((float(p[1]), float(p[2]) if len(p) > 2 else 0.0))
        elif p[0] == "vn":
            vn.append(tuple(float(x) for x in p[1:4]))
        elif p[0] == "usemtl":
            mat = " ".join(p[1:])
        elif p[0] == "f":
            corners = []
            for c in p[1:]:
                ids = c.split("/")
                res = []
                for k, n in enumerate((len(v), len(vt), len(vn))):
                    if k < len(ids) and ids[k]:
                        i = int(ids[k])
                        res.append(i - 1 if i > 0 else n + i)
                    else:
                        res.append(-1)
                corners.append(tuple(res))
            tris = groups.setdefault(mat, [])
            for k in range(1, len(corners) - 1):
                tris.append((corners[0], corners[k], corners[k + 1]))
    return v, vt, vn, groups


class Writer:
    def __init__(self):
        self.bin = bytearray()
        self.doc = {"asset": {"version": "2.0", "generator": "tandem scripts/make_furniture_scene.py"},
                    "scene": 0, "scenes": [{"name": "furniture", "nodes": []}], "nodes": [],
                    "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
                    "buffers": [], "textures": [], "images": [], "samplers": [{}]}

    def view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        bv = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            bv["target"] = target
        self.bin += data
        self.doc["bufferViews"].append(bv)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, values, comps, ctype=5126, target=34962):
        fmt = "<%d%s" % (len(values) * comps, "f" if ctype == 5126 else "I")
        flat = [x for t in values for x in t] if comps > 1 else list(values)
        a = {"bufferView": self.view(struct.pack(fmt, *flat), target), "componentType": ctype,
             "count": len(values), "type": {1: "SCALAR", 2: "VEC2", 3: "VEC3"}[comps]}
        if comps == 3 and ctype == 5126:
            a["min"] = [min(t[k] for t in values) for k in range(3)]
            a["max"] = [max(t[k] for t in values) for k in range(3)]
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--furniture", default="/usr/share/sweethome3d/furniture")
    ap.add_argument("--models", type=int, default=60)
    ap.add_argument("--copies", type=int, default=8)
    ap.add_argument("--spacing", type=float, default=2.5)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    w = Writer()
    rng = random.Random(1)
    meshes = []  # (mesh index, footprint radius, triangles)
    for sh3f in sorted(f for f in os.listdir(a.furniture) if f.endswith(".sh3f")):
        z = zipfile.ZipFile(os.path.join(a.furniture, sh3f))
        objs = sorted(n for n in z.namelist() if n.endswith(".obj"))
        taken = 0
        for name in objs:
            if taken >= a.models:
                break
            text = z.read(name).decode("utf-8", "replace")
            v, vt, vn, groups = parse_obj(text)
            ntri = sum(len(t) for t in groups.values())
            if not v or ntri == 0 or ntri > 300000:
                continue
            folder = os.path.dirname(name)
            mats = {}
            for line in text.splitlines():
                if line.startswith("mtllib"):
                    mp = os.path.join(folder, line.split(None, 1)[1].strip())
                    if mp in z.namelist():
                        mats.update(parse_mtl(z.read(mp).decode("utf-8", "replace")))
            lo = [min(p[k] for p in v) for k in range(3)]
            hi = [max(p[k] for p in v) for k in range(3)]
            # Sweet Home 3D models are in centimetres or arbitrary units: scaled to fit 2 m
            size = max(hi[k] - lo[k] for k in range(3))
            s = 1.8 / size if size > 0 else 1.0
            centre = [(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2]
            prims = []
            for mname, tris in groups.items():
                pos, uv, nrm, idx, seen = [], [], [], [], {}
                for tri in tris:
                    for c in tri:
                        if c not in seen:
                            seen[c] = len(pos)
                            p = v[c[0]]
                            pos.append(tuple((p[k] - centre[k]) * s for k in range(3)))
                            uv.append((vt[c[1]][0], 1.0 - vt[c[1]][1]) if 0 <= c[1] < len(vt)
                                      else (0.0, 0.0))
                            nrm.append(vn[c[2]] if 0 <= c[2] < len(vn) else (0.0, 1.0, 0.0))
                        idx.append(seen[c])
                nrm = [(x / (math.sqrt(x * x + y * y + zz * zz) or 1), y / (math.sqrt(x * x + y * y + zz * zz) or 1),
                        zz / (math.sqrt(x * x + y * y + zz * zz) or 1)) for x, y, zz in nrm]
                m = mats.get(mname, {"Kd": (0.8, 0.8, 0.8), "map": None, "d": 1.0})
                mat = {"name": "%s/%s" % (os.path.basename(folder), mname),
                       "pbrMetallicRoughness": {"baseColorFactor": list(m["Kd"]) + [1.0],
                                                "metallicFactor": 0.0, "roughnessFactor": 0.6}}
                tex = os.path.join(folder, m["map"]) if m["map"] else None
                if tex and tex in z.namelist():
                    img = "%s_%s" % (os.path.basename(folder), os.path.basename(tex))
                    with open(os.path.join(a.out, img), "wb") as f:
                        f.write(z.read(tex))
                    w.doc["images"].append({"uri": img})
                    w.doc["textures"].append({"source": len(w.doc["images"]) - 1, "sampler": 0})
                    mat["pbrMetallicRoughness"]["baseColorTexture"] = {
                        "index": len(w.doc["textures"]) - 1}
                    mat["pbrMetallicRoughness"]["baseColorFactor"] = [1.0, 1.0, 1.0, 1.0]
                w.doc["materials"].append(mat)
                prims.append({"attributes": {"POSITION": w.accessor(pos, 3),
                                             "NORMAL": w.accessor(nrm, 3),
                                             "TEXCOORD_0": w.accessor(uv, 2)},
                              "indices": w.accessor(idx, 1, 5125, 34963),
                              "material": len(w.doc["materials"]) - 1})
            w.doc["meshes"].append({"name": os.path.basename(folder), "primitives": prims})
            foot = 0.5 * s * max(hi[0] - lo[0], hi[2] - lo[2])
            meshes.append((len(w.doc["meshes"]) - 1, foot, ntri))
            taken += 1
    if not meshes:
        sys.exit("make_furniture_scene: no models under %s" % a.furniture)
    # the showroom: copies x models on a square grid, each turned at random
    n = len(meshes) * a.copies
    side = math.ceil(math.sqrt(n))
    total = 0
    for i in range(n):
        mesh, foot, ntri = meshes[i % len(meshes)]
        gx, gz = i % side, i // side
        yaw = rng.uniform(0, 2 * math.pi)
        w.doc["nodes"].append({"name": "item_%d" % i, "mesh": mesh,
                               "translation": [(gx - side / 2) * a.spacing, 0.0,
                                               (gz - side / 2) * a.spacing],
                               "rotation": [0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2)]})
        w.doc["scenes"][0]["nodes"].append(len(w.doc["nodes"]) - 1)
        total += ntri
    half = side * a.spacing / 2 + a.spacing
    floor = [(-half, 0, -half), (half, 0, -half), (half, 0, half), (-half, 0, half)]
    w.doc["materials"].append({"name": "floor", "pbrMetallicRoughness": {
        "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8}})
    w.doc["meshes"].append({"name": "floor", "primitives": [{
        "attributes": {"POSITION": w.accessor(floor, 3),
                       "NORMAL": w.accessor([(0.0, 1.0, 0.0)] * 4, 3)},
        "indices": w.accessor([0, 2, 1, 0, 3, 2], 1, 5125, 34963),
        "material": len(w.doc["materials"]) - 1}]})
    w.doc["nodes"].append({"name": "floor", "mesh": len(w.doc["meshes"]) - 1})
    w.doc["scenes"][0]["nodes"].append(len(w.doc["nodes"]) - 1)
    for k in ("images", "textures"):
        if not w.doc[k]:
            del w.doc[k]
    w.doc["buffers"].append({"uri": "furniture.bin", "byteLength": len(w.bin)})
    with open(os.path.join(a.out, "furniture.bin"), "wb") as f:
        f.write(w.bin)
    with open(os.path.join(a.out, "furniture.gltf"), "w") as f:
        json.dump(w.doc, f)
    print("%s/furniture.gltf: %d models, %d instances, %d triangles traced (%d unique)"
          % (a.out, len(meshes), n, total + 2, sum(m[2] for m in meshes) + 2))


if __name__ == "__main__":
    main()
