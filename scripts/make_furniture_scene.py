#!/usr/bin/env python3
"""A generated scene of millions of triangles from real models: Sweet Home 3D's furniture (Debian's
`sweethome3d-furniture`, CC-BY / CC0 OBJ models inside .sh3f zip files), each model converted once
to glTF meshes and instanced many times on a grid, as a showroom (docs/scenes.md "Real levels and interiors").

usage: make_furniture_scene.py OUT_DIR [--furniture DIR] [--models N] [--copies K] [--spacing M]

Reads the first N models (by name, those under 300k triangles; default 60) of every .sh3f in DIR
(default /usr/share/sweethome3d/furniture), converts each OBJ (v, vt, vn, f with polygons fanned,
usemtl; MTL Kd and map_Kd) to one glTF mesh with a primitive per material (Lambert-like: metallic 0,
roughness 0.6; map_Kd as the base colour texture, copied next to the scene), and places K copies of
every model (default 8) on a grid of M metres (default 2.5) on a grey floor, turned at random (seed
1). Writes OUT_DIR/furniture.gltf, furniture.bin and the images. Prints the triangle count.
No light: Tandem's default sky lights it (or --env)."""
import argparse
import math
import os
import random
import sys
import zipfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_scenes import Gltf, quad  # noqa: E402  (the one glTF writer of scripts/)


def parse_mtl(text):
    mats, cur = {}, None
    for line in text.splitlines():
        p = line.split()
        if not p or p[0].startswith("#"):
            continue
        if p[0] == "newmtl":
            cur = mats.setdefault(" ".join(p[1:]), {"Kd": (0.8, 0.8, 0.8), "map": None})
        elif cur is None:
            continue
        elif p[0] == "Kd" and len(p) >= 4:
            cur["Kd"] = tuple(float(x) for x in p[1:4])
        elif p[0] == "map_Kd" and len(p) >= 2:
            cur["map"] = p[-1]
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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--furniture", default="/usr/share/sweethome3d/furniture")
    ap.add_argument("--models", type=int, default=60)
    ap.add_argument("--copies", type=int, default=8)
    ap.add_argument("--spacing", type=float, default=2.5)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    g = Gltf("furniture")
    rng = random.Random(1)
    meshes = []  # (mesh index, triangles)
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
            # Sweet Home 3D models are in centimetres or arbitrary units: scaled to fit 1.8 m,
            # standing on the floor at the origin
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
                            n = vn[c[2]] if 0 <= c[2] < len(vn) else (0.0, 1.0, 0.0)
                            ln = math.sqrt(sum(x * x for x in n)) or 1.0
                            nrm.append(tuple(x / ln for x in n))
                        idx.append(seen[c])
                m = mats.get(mname, {"Kd": (0.8, 0.8, 0.8), "map": None})
                tex = os.path.join(folder, m["map"]) if m["map"] else None
                base_tex = None
                if tex and tex in z.namelist():
                    base_tex = ("%s_%s" % (os.path.basename(folder), os.path.basename(tex)),
                                z.read(tex))
                mat = g.material("%s/%s" % (os.path.basename(folder), mname),
                                 base=(1.0, 1.0, 1.0) if base_tex else m["Kd"], metallic=0.0,
                                 roughness=0.6, base_tex=base_tex)
                prims.append(((pos, nrm, uv, idx), mat))
            meshes.append((g.mesh(os.path.basename(folder), *prims[0], more=prims[1:]), ntri))
            taken += 1
    if not meshes:
        sys.exit("make_furniture_scene: no models under %s" % a.furniture)
    # the showroom: copies x models on a square grid, each turned at random
    n = len(meshes) * a.copies
    side = math.ceil(math.sqrt(n))
    total = 0
    for i in range(n):
        mesh, ntri = meshes[i % len(meshes)]
        yaw = rng.uniform(0, 2 * math.pi)
        g.node("item_%d" % i, mesh, t=((i % side - side / 2) * a.spacing, 0.0,
                                       (i // side - side / 2) * a.spacing),
               r=(0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2)))
        total += ntri
    half = side * a.spacing / 2 + a.spacing
    g.node("floor", g.mesh("floor", quad(2 * half, 2 * half),
                           g.material("floor", (0.5, 0.5, 0.5), roughness=0.8)))
    g.write(a.out)
    print("%s/furniture.gltf: %d models, %d instances, %d triangles traced (%d unique)"
          % (a.out, len(meshes), n, total + 2, sum(m[1] for m in meshes) + 2))


if __name__ == "__main__":
    main()
