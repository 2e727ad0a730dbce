#!/usr/bin/env python3
"""Generate Tandem's built-in glTF 2.0 scenes under data/scenes/ (standard library only).

Each scene is NAME.gltf + NAME.bin (+ PNG textures), small, with an animated camera. The files are
committed; run this script only to change them:  python3 scripts/make_scenes.py [OUTDIR]

Units are metres; light intensities are glTF's photometric units (candela for point and spot
lights, lux for directional lights, nits for emission x KHR_materials_emissive_strength).
Tandem-specific data lives in glTF `extras`:
  scene.extras.tandem_sky = [r, g, b]                   uniform sky radiance (nits); [0, 0, 0]
                                                        states a black sky (no default light)
  node.extras.tandem_light_schedule = {"fps": F, "keys": [[frame, scale], ...]}
                                                        step-wise intensity scale of a light node
"""
import base64, json, math, os, random, struct, sys, zlib


class Gltf:
    def __init__(self, name):
        self.name = name
        self.bin = bytearray()
        self.doc = {"asset": {"version": "2.0", "generator": "tandem scripts/make_scenes.py"},
                    "scene": 0, "scenes": [{"name": name, "nodes": []}], "nodes": [],
                    "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
                    "buffers": []}
        self.images = {}
        self.extensions = set()

    def _view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            v["target"] = target
        self.bin += data
        self.doc["bufferViews"].append(v)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, values, kind, ctype=5126, target=None, minmax=False):
        n = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[kind]
        flat = [x for v in values for x in (v if n > 1 else [v])]
        fmt = {5126: "f", 5125: "I"}[ctype]
        view = self._view(struct.pack("<%d%s" % (len(flat), fmt), *flat), target)
        a = {"bufferView": view, "componentType": ctype, "count": len(values), "type": kind}
        if minmax:
            a["min"] = [min(v[i] for v in values) for i in range(n)]
            a["max"] = [max(v[i] for v in values) for i in range(n)]
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1

    def material(self, name, base=(0.8, 0.8, 0.8), metallic=0.0, roughness=1.0, emission=None,
                 strength=1.0, transmission=None, ior=None, base_tex=None, mr_tex=None,
                 normal_tex=None, double_sided=False, volume=None, specular=None, alpha=None):
        m = {"name": name, "pbrMetallicRoughness": {"baseColorFactor": list(base) + [1.0],
                                                    "metallicFactor": metallic,
                                                    "roughnessFactor": roughness}}
        if alpha:  # ("MASK", cutoff) or ("BLEND", None)
            m["alphaMode"] = alpha[0]
            if alpha[1] is not None:
                m["alphaCutoff"] = alpha[1]
        if double_sided:
            m["doubleSided"] = True
        if emission:
            m["emissiveFactor"] = list(emission)
            if strength != 1.0:
                m.setdefault("extensions", {})["KHR_materials_emissive_strength"] = {
                    "emissiveStrength": strength}
                self.extensions.add("KHR_materials_emissive_strength")
        if transmission is not None:
            m.setdefault("extensions", {})["KHR_materials_transmission"] = {
                "transmissionFactor": transmission}
            self.extensions.add("KHR_materials_transmission")
        if ior is not None:
            m.setdefault("extensions", {})["KHR_materials_ior"] = {"ior": ior}
            self.extensions.add("KHR_materials_ior")
        if specular is not None:  # KHR_materials_specular factor (0: pure Lambert)
            m.setdefault("extensions", {})["KHR_materials_specular"] = {
                "specularFactor": specular}
            self.extensions.add("KHR_materials_specular")
        if volume is not None:  # (thickness, attenuation colour, attenuation distance)
            m.setdefault("extensions", {})["KHR_materials_volume"] = {
                "thicknessFactor": volume[0], "attenuationColor": list(volume[1]),
                "attenuationDistance": volume[2]}
            self.extensions.add("KHR_materials_volume")
        if base_tex:
            m["pbrMetallicRoughness"]["baseColorTexture"] = {"index": self.texture(base_tex)}
        if mr_tex:
            m["pbrMetallicRoughness"]["metallicRoughnessTexture"] = {"index": self.texture(mr_tex)}
        if normal_tex:
            m["normalTexture"] = {"index": self.texture(normal_tex)}
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def texture(self, png):
        name, data = png
        if name not in self.images:
            self.doc.setdefault("images", []).append({"uri": name})
            self.doc.setdefault("textures", []).append({"source": len(self.doc["images"]) - 1,
                                                        "sampler": 0})
            self.doc.setdefault("samplers", [{"magFilter": 9729, "minFilter": 9987,
                                              "wrapS": 10497, "wrapT": 10497}])
            self.images[name] = (len(self.doc["textures"]) - 1, data)
        return self.images[name][0]

    def primitive(self, geo, material):
        pos, nrm, uv, idx = geo
        return {"attributes": {"POSITION": self.accessor(pos, "VEC3", target=34962, minmax=True),
                               "NORMAL": self.accessor(nrm, "VEC3", target=34962),
                               "TEXCOORD_0": self.accessor(uv, "VEC2", target=34962)},
                "indices": self.accessor(idx, "SCALAR", 5125, target=34963),
                "material": material}

    def mesh(self, name, geo, material, more=()):
        """A mesh of one primitive (geo, material), and more (geo, material) pairs after it."""
        prims = [self.primitive(g, m) for g, m in [(geo, material)] + list(more)]
        self.doc["meshes"].append({"name": name, "primitives": prims})
        return len(self.doc["meshes"]) - 1

    def node(self, name, mesh=None, t=None, r=None, s=None, parent=None, **kw):
        n = {"name": name}
        if mesh is not None:
            n["mesh"] = mesh
        if t:
            n["translation"] = list(t)
        if r:
            n["rotation"] = list(r)
        if s:
            n["scale"] = list(s)
        n.update(kw)
        self.doc["nodes"].append(n)
        i = len(self.doc["nodes"]) - 1
        if parent is None:
            self.doc["scenes"][0]["nodes"].append(i)
        else:
            self.doc["nodes"][parent].setdefault("children", []).append(i)
        return i

    def camera(self, name, yfov_deg, aspect=16 / 9, znear=0.05, zfar=None):
        p = {"yfov": math.radians(yfov_deg), "znear": znear, "aspectRatio": aspect}
        if zfar:
            p["zfar"] = zfar
        self.doc.setdefault("cameras", []).append({"name": name, "type": "perspective",
                                                   "perspective": p})
        return len(self.doc["cameras"]) - 1

    def light(self, name, kind, color, intensity, spot=None, rng=None):
        l = {"name": name, "type": kind, "color": list(color), "intensity": intensity}
        if spot:
            l["spot"] = {"innerConeAngle": spot[0], "outerConeAngle": spot[1]}
        if rng:
            l["range"] = rng
        ext = self.doc.setdefault("extensions", {}).setdefault("KHR_lights_punctual",
                                                               {"lights": []})
        ext["lights"].append(l)
        self.extensions.add("KHR_lights_punctual")
        return len(ext["lights"]) - 1

    def light_node(self, name, light, t=None, r=None, parent=None, **kw):
        return self.node(name, t=t, r=r, parent=parent,
                         extensions={"KHR_lights_punctual": {"light": light}}, **kw)

    def animate(self, node, path, times, values, interp="LINEAR"):
        anims = self.doc.setdefault("animations", [{"name": "main", "channels": [],
                                                    "samplers": []}])
        a = anims[0]
        kind = {"translation": "VEC3", "rotation": "VEC4", "scale": "VEC3"}[path]
        s = {"input": self.accessor(times, "SCALAR", minmax=False),
             "output": self.accessor(values, kind), "interpolation": interp}
        self.doc["accessors"][s["input"]]["min"] = [min(times)]
        self.doc["accessors"][s["input"]]["max"] = [max(times)]
        a["samplers"].append(s)
        a["channels"].append({"sampler": len(a["samplers"]) - 1,
                              "target": {"node": node, "path": path}})

    def write(self, outdir):
        self.doc["buffers"] = [{"uri": self.name + ".bin", "byteLength": len(self.bin)}]
        if self.extensions:
            self.doc["extensionsUsed"] = sorted(self.extensions)
        with open(os.path.join(outdir, self.name + ".bin"), "wb") as f:
            f.write(self.bin)
        for name, (_, data) in self.images.items():
            with open(os.path.join(outdir, name), "wb") as f:
                f.write(data)
        with open(os.path.join(outdir, self.name + ".gltf"), "w") as f:
            json.dump(self.doc, f, indent=1)
            f.write("\n")


# ---- geometry ------------------------------------------------------------------------------
def quad(w, h):
    """A w x h quad in the XZ plane facing +Y, centred at the origin."""
    x, z = w / 2, h / 2
    pos = [(-x, 0, -z), (x, 0, -z), (x, 0, z), (-x, 0, z)]
    return pos, [(0, 1, 0)] * 4, [(0, 0), (w, 0), (w, h), (0, h)], [0, 2, 1, 0, 3, 2]


def box(sx, sy, sz, inward=False):
    pos, nrm, uv, idx = [], [], [], []
    faces = [((1, 0, 0), (0, 0, -1), (0, 1, 0)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
             ((0, 1, 0), (1, 0, 0), (0, 0, -1)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
             ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (-1, 0, 0), (0, 1, 0))]
    h = (sx / 2, sy / 2, sz / 2)
    for n, u, v in faces:
        base = len(pos)
        for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = tuple(h[i] * (n[i] + a * u[i] + b * v[i]) for i in range(3))
            pos.append(p)
            nrm.append(tuple(-c for c in n) if inward else n)
            uv.append(((a + 1) / 2, (b + 1) / 2))
        tri = [0, 1, 2, 0, 2, 3] if not inward else [0, 2, 1, 0, 3, 2]
        idx += [base + t for t in tri]
    return pos, nrm, uv, idx


def sphere(r, seg=32, rings=16):
    pos, nrm, uv, idx = [], [], [], []
    for j in range(rings + 1):
        th = math.pi * j / rings
        for i in range(seg + 1):
            ph = 2 * math.pi * i / seg
            n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            pos.append(tuple(r * c for c in n))
            nrm.append(n)
            uv.append((i / seg, j / rings))
    for j in range(rings):
        for i in range(seg):
            a, b = j * (seg + 1) + i, (j + 1) * (seg + 1) + i
            if j != 0:
                idx += [a, a + 1, b]
            if j != rings - 1:
                idx += [a + 1, b + 1, b]
    return pos, nrm, uv, idx


def png(name, w, h, pixel):
    """An 8-bit RGBA PNG from pixel(x, y) -> (r, g, b, a) in 0..255."""
    raw = b"".join(b"\0" + bytes(c for x in range(w) for c in pixel(x, y)) for y in range(h))

    def chunk(t, d):
        c = struct.pack(">I", len(d)) + t + d
        return c + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    return name, data


def quat_axis(axis, deg):
    a = math.radians(deg) / 2
    n = math.sqrt(sum(c * c for c in axis))
    return tuple(c / n * math.sin(a) for c in axis) + (math.cos(a),)


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def look_rot(yaw_deg, pitch_deg):
    """Camera rotation: yaw about +Y, then pitch about the camera's X (glTF cameras look -Z)."""
    return quat_mul(quat_axis((0, 1, 0), yaw_deg), quat_axis((1, 0, 0), pitch_deg))


def camera_path(g, name, keys, yfov=39.0, aspect=16 / 9, zfar=None):
    """keys: [(time, (x, y, z), yaw, pitch)]; linear translation, slerped rotation."""
    cam = g.camera(name, yfov, aspect, zfar=zfar)
    t0 = keys[0]
    n = g.node(name, t=t0[1], r=look_rot(t0[2], t0[3]), camera=cam)
    g.animate(n, "translation", [k[0] for k in keys], [k[1] for k in keys])
    g.animate(n, "rotation", [k[0] for k in keys], [look_rot(k[2], k[3]) for k in keys])
    return n


# ---- scenes --------------------------------------------------------------------------------

def write_exr_rgb(path, w, h, pixel):
    """A latitude-longitude RGB EXR (float channels, ZIPS compression: per scanline, the bytes
    split into even and odd halves, delta-coded, deflated) written with the standard library
    alone; pixel(u, v) gives (r, g, b) at the texel centre (u, v) in [0, 1)."""
    def attr(name, typ, data):
        return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(data)) + data
    chans = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in "BGR") + b"\0"
    header = (struct.pack("<ii", 20000630, 2) +
              attr("channels", "chlist", chans) +
              attr("compression", "compression", bytes([2])) +
              attr("dataWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1)) +
              attr("displayWindow", "box2i", struct.pack("<iiii", 0, 0, w - 1, h - 1)) +
              attr("lineOrder", "lineOrder", bytes([0])) +
              attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)) +
              attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)) +
              attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    blocks = []
    for y in range(h):
        rows = [[], [], []]
        for x in range(w):
            rgb = pixel((x + 0.5) / w, (y + 0.5) / h)
            for k in range(3):
                rows[k].append(rgb[k])
        raw = b"".join(struct.pack("<%df" % w, *rows[k]) for k in (2, 1, 0))  # B, G, R
        split = raw[0::2] + raw[1::2]
        pred = bytearray(split)
        for i in range(len(split) - 1, 0, -1):
            pred[i] = (split[i] - split[i - 1] + 128 + 256) & 0xFF
        data = zlib.compress(bytes(pred), 9)
        if len(data) >= len(raw):
            data = raw
        blocks.append(struct.pack("<ii", y, len(data)) + data)
    offset = len(header) + 8 * h
    table = b""
    for b in blocks:
        table += struct.pack("<Q", offset)
        offset += len(b)
    with open(path, "wb") as f:
        f.write(header + table + b"".join(blocks))


def atrium_sky(u, v):
    """A clear sky for the atrium (its sun is the directional light): blue at the zenith, pale at
    the horizon, a dim warm ground; about 0.77 nits of mean luminance, as courtyard.exr had."""
    y = math.cos(math.pi * v)
    if y >= 0:
        t = (1.0 - y) ** 3
        zen, hor = (0.16, 0.30, 0.75), (0.95, 0.97, 1.0)
        return tuple(2.15 * (zen[k] * (1 - t) + hor[k] * t) for k in range(3))
    t = min(1.0, -y * 6.0)
    hor, gnd = (0.95, 0.97, 1.0), (0.20, 0.18, 0.16)
    return tuple(2.15 * (hor[k] * (1 - t) + gnd[k] * t) for k in range(3))

def cornell(out):
    g = Gltf("cornell")
    white = g.material("white", (0.73, 0.73, 0.73))
    red = g.material("red", (0.65, 0.05, 0.05))
    green = g.material("green", (0.12, 0.45, 0.15))
    light = g.material("light", (0.78, 0.78, 0.78), emission=(1.0, 0.85, 0.6), strength=17.0)
    S = 2.0  # box of 2 m, floor at y = 0
    g.node("floor", g.mesh("floor", quad(S, S), white))
    g.node("ceiling", g.mesh("ceiling", quad(S, S), white), t=(0, S, 0),
           r=quat_axis((1, 0, 0), 180))
    g.node("back", g.mesh("back", quad(S, S), white), t=(0, S / 2, -S / 2),
           r=quat_axis((1, 0, 0), 90))
    g.node("left", g.mesh("left", quad(S, S), red), t=(-S / 2, S / 2, 0),
           r=quat_axis((0, 0, 1), -90))
    g.node("right", g.mesh("right", quad(S, S), green), t=(S / 2, S / 2, 0),
           r=quat_axis((0, 0, 1), 90))
    g.node("light", g.mesh("light", quad(0.5, 0.4), light), t=(0, S - 0.001, 0),
           r=quat_axis((1, 0, 0), 180))
    g.node("tall_box", g.mesh("tall_box", box(0.6, 1.2, 0.6), white), t=(-0.35, 0.6, -0.3),
           r=quat_axis((0, 1, 0), 17))
    g.node("short_box", g.mesh("short_box", box(0.6, 0.6, 0.6), white), t=(0.4, 0.3, 0.35),
           r=quat_axis((0, 1, 0), -17))
    camera_path(g, "camera", [(0.0, (0.0, 1.0, 3.9), 0, 0), (2.0, (0.25, 1.05, 3.7), 3, -1),
                              (4.0, (0.0, 1.0, 3.9), 0, 0)])
    # lit by its panel alone: a black sky stated, so that no default light is added
    g.doc["scenes"][0]["extras"] = {"tandem_sky": [0, 0, 0]}
    g.write(out)


def closed_box(out):
    """A closed Lambert box (albedo 0.7 everywhere, one emitting ceiling panel) seen from a static
    camera inside it: light bounces many times, so the 1-bounce real-time estimator's expectation
    lies far below the unbiased reference (docs/metrics.md: estimator bias against denoiser
    error)."""
    g = Gltf("closed_box")
    wall = g.material("wall", (0.7, 0.7, 0.7))
    light = g.material("light", (0.7, 0.7, 0.7), emission=(1.0, 1.0, 1.0), strength=10.0)
    S = 2.0  # inside a cube of 2 m, floor at y = 0; every face points inwards
    g.node("box", g.mesh("box", box(S, S, S, inward=True), wall), t=(0, S / 2, 0))
    g.node("light", g.mesh("light", quad(0.6, 0.6), light), t=(0, S - 0.001, 0),
           r=quat_axis((1, 0, 0), 180))
    g.node("block", g.mesh("block", box(0.5, 0.8, 0.5), wall), t=(0.3, 0.4, -0.2),
           r=quat_axis((0, 1, 0), 25))
    cam = g.camera("camera", 70.0, 1.0)
    g.node("camera", t=(-0.2, 1.0, 0.9), r=look_rot(-12, -8), camera=cam)
    g.doc["scenes"][0]["extras"] = {"tandem_sky": [0, 0, 0]}  # closed: no default light
    g.write(out)


def materials(out):
    g = Gltf("materials")
    checker = png("materials_checker.png", 64, 64,
                  lambda x, y: (200, 200, 200, 255) if (x // 8 + y // 8) % 2 else (60, 60, 70, 255))
    # metallicRoughness: G = roughness, B = metallic (glTF); stripes of rough/smooth metal
    mr = png("materials_mr.png", 32, 32,
             lambda x, y: (0, 40 if (x // 4) % 2 else 220, 255 if (y // 16) else 0, 255))
    # normal map: gentle bumps (tangent space, +Z up)
    def bump(x, y):
        nx = 0.35 * math.sin(2 * math.pi * x / 16)
        ny = 0.35 * math.sin(2 * math.pi * y / 16)
        nz = math.sqrt(max(0.0, 1 - nx * nx - ny * ny))
        return (int(127.5 + 127.5 * nx), int(127.5 + 127.5 * ny), int(127.5 + 127.5 * nz), 255)
    nmap = png("materials_normal.png", 32, 32, bump)
    floor = g.material("checker_floor", (1, 1, 1), roughness=0.8, base_tex=checker)
    wall = g.material("wall", (0.7, 0.7, 0.72), roughness=0.9)
    gold = g.material("rough_gold", (1.0, 0.78, 0.34), metallic=1.0, roughness=0.35)
    chrome = g.material("chrome", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.02)
    plastic = g.material("smooth_plastic", (0.1, 0.25, 0.8), metallic=0.0, roughness=0.15)
    rubber = g.material("rough_rubber", (0.8, 0.3, 0.1), metallic=0.0, roughness=0.95)
    glass = g.material("glass", (1, 1, 1), metallic=0.0, roughness=0.0, transmission=1.0, ior=1.5,
                       volume=(0.8, (0.85, 0.95, 0.9), 2.0))
    pane = g.material("thin_glass", (1, 1, 1), metallic=0.0, roughness=0.0, transmission=1.0,
                      ior=1.5, double_sided=True)
    textured = g.material("textured_metal", (0.9, 0.9, 0.9), metallic=1.0, roughness=1.0,
                          mr_tex=mr, normal_tex=nmap)
    mirror = g.material("mirror", (0.98, 0.98, 0.98), metallic=1.0, roughness=0.0)
    lamp = g.material("lamp", (0.8, 0.8, 0.8), emission=(1, 1, 1), strength=30.0)
    g.node("floor", g.mesh("floor", quad(8, 8), floor))
    g.node("back_wall", g.mesh("back_wall", quad(8, 4), wall), t=(0, 2, -3),
           r=quat_axis((1, 0, 0), 90))
    g.node("mirror", g.mesh("mirror", quad(1.6, 1.2), mirror), t=(2.2, 1.0, -2.95),
           r=quat_axis((1, 0, 0), 90))
    ball = lambda n, m, x, z: g.node(n, g.mesh(n, sphere(0.4), m), t=(x, 0.4, z))
    ball("gold_sphere", gold, -1.8, -0.8)
    ball("chrome_sphere", chrome, -0.9, 0.2)
    ball("plastic_sphere", plastic, 0.0, -0.8)
    ball("rubber_sphere", rubber, 0.9, 0.2)
    ball("glass_sphere", glass, 1.8, -0.8)
    g.node("glass_pane", g.mesh("glass_pane", quad(1.0, 1.4), pane), t=(1.0, 0.7, 1.4),
           r=quat_axis((1, 0, 0), 90))
    g.node("textured_box", g.mesh("textured_box", box(0.7, 0.7, 0.7), textured),
           t=(-2.2, 0.35, 1.0), r=quat_axis((0, 1, 0), 30))
    g.node("ceiling_lamp", g.mesh("ceiling_lamp", quad(1.5, 0.6), lamp), t=(0, 3.2, -1),
           r=quat_axis((1, 0, 0), 180))
    pl = g.light("warm_point", "point", (1.0, 0.8, 0.6), 60.0)
    g.light_node("warm_point", pl, t=(-2.5, 2.0, 1.5))
    sl = g.light("spot", "spot", (0.7, 0.8, 1.0), 400.0, spot=(0.2, 0.35))
    g.light_node("spot", sl, t=(2.0, 3.0, 1.0), r=quat_axis((1, 0, 0), -70))
    camera_path(g, "camera", [(0.0, (0.0, 1.6, 5.0), 0, -12), (3.0, (1.2, 1.4, 4.6), 12, -10),
                              (6.0, (-1.2, 1.5, 4.7), -12, -11)], yfov=45.0)
    g.write(out)


def dynamic(out):
    g = Gltf("dynamic")
    floor = g.material("floor", (0.6, 0.6, 0.6), roughness=0.7)
    wall = g.material("wall", (0.75, 0.72, 0.68), roughness=0.9)
    cube_m = g.material("cube", (0.8, 0.15, 0.1), roughness=0.4)
    pillar_m = g.material("pillar", (0.2, 0.4, 0.7), roughness=0.5)
    panel = g.material("ceiling_panel", (0.8, 0.8, 0.8), emission=(0.9, 0.95, 1.0), strength=4.0)
    g.node("floor", g.mesh("floor", quad(8, 8), floor))
    g.node("back_wall", g.mesh("back_wall", quad(8, 3), wall), t=(0, 1.5, -3),
           r=quat_axis((1, 0, 0), 90))
    g.node("left_wall", g.mesh("left_wall", quad(6, 3), wall), t=(-3, 1.5, 0),
           r=quat_axis((0, 0, 1), -90))
    g.node("ceiling_panel", g.mesh("ceiling_panel", quad(1.0, 1.0), panel), t=(0, 3.0, -1.5),
           r=quat_axis((1, 0, 0), 180))
    g.node("pillar", g.mesh("pillar", box(0.4, 2.0, 0.4), pillar_m), t=(0.8, 1.0, -0.8))
    cube = g.node("moving_cube", g.mesh("moving_cube", box(0.5, 0.5, 0.5), cube_m),
                  t=(-1.5, 0.25, 0.0))
    # the cube slides behind the pillar and back (disocclusions on both sides)
    g.animate(cube, "translation", [0.0, 2.0, 4.0], [(-1.5, 0.25, 0.0), (2.0, 0.25, -1.2),
                                                       (-1.5, 0.25, 0.0)])
    g.animate(cube, "rotation", [0.0, 2.0, 4.0], [quat_axis((0, 1, 0), 0),
                                                    quat_axis((0, 1, 0), 179),
                                                    quat_axis((0, 1, 0), 358)])
    lamp = g.light("switched_lamp", "point", (1.0, 0.9, 0.75), 25.0)
    # switched off at frame 30 and on again at frame 60 (30 frames per second)
    g.light_node("switched_lamp", lamp, t=(-1.0, 2.2, 0.5),
                 extras={"tandem_light_schedule": {"fps": 30, "keys": [[0, 1.0], [30, 0.0],
                                                                        [60, 1.0]]}})
    camera_path(g, "camera", [(0.0, (-0.5, 1.5, 4.5), -5, -10), (2.0, (0.8, 1.4, 4.2), 8, -9),
                              (4.0, (-0.5, 1.5, 4.5), -5, -10)])
    g.write(out)


def sun(out):
    g = Gltf("sun")
    ground = g.material("ground", (0.45, 0.42, 0.38), roughness=0.95)
    stone = g.material("stone", (0.7, 0.68, 0.62), roughness=0.8)
    roof = g.material("roof", (0.55, 0.2, 0.15), roughness=0.6)
    g.node("ground", g.mesh("ground", quad(60, 60), ground))
    for i, (x, z) in enumerate([(-3, -2), (-1, -2), (1, -2), (3, -2), (-3, 2), (3, 2)]):
        g.node("pillar_%d" % i, g.mesh("pillar_%d" % i, box(0.5, 3.0, 0.5), stone),
               t=(x, 1.5, z))
    g.node("roof", g.mesh("roof", box(7.5, 0.3, 5.0), roof), t=(0, 3.15, 0))
    g.node("block", g.mesh("block", box(1.2, 1.2, 1.2), stone), t=(0.5, 0.6, 0.4),
           r=quat_axis((0, 1, 0), 25))
    sl = g.light("sun", "directional", (1.0, 0.95, 0.85), 8.0)
    g.light_node("sun", sl, r=quat_mul(quat_axis((0, 1, 0), 35), quat_axis((1, 0, 0), -50)))
    g.doc["scenes"][0]["extras"] = {"tandem_sky": [0.35, 0.5, 0.8]}
    camera_path(g, "camera", [(0.0, (-7.0, 2.0, 8.0), -40, -8), (3.0, (0.0, 2.5, 10.0), 0, -9),
                              (6.0, (7.0, 2.0, 8.0), 40, -8)], yfov=50.0)
    g.write(out)


def cutout(out):
    """Alpha: a wire fence (alphaMode MASK, cutoff 0.5: a grid of bars, 3/4 holes) and two leaf
    cards (BLEND, cut at 0.5: an ellipse with soft edges) in front of boxes on a ground, lit by a
    low sun whose light falls through the fence's holes, and a sky."""
    g = Gltf("cutout")

    def wire(x, y):
        bar = (x % 16) < 4 or (y % 16) < 4
        return (150, 150, 140, 255 if bar else 0)

    def leaf(x, y):
        r = math.hypot((x - 31.5) / 30.0, (y - 31.5) / 18.0)
        a = max(0.0, min(1.0, (1.1 - r) / 0.2))
        return (60, 120 + (x * 2) % 40, 40, int(round(255 * a)))
    fence_tex = png("cutout_fence.png", 32, 32, wire)
    leaf_tex = png("cutout_leaf.png", 64, 64, leaf)
    ground = g.material("ground", (0.5, 0.48, 0.44), roughness=0.9)
    stone = g.material("stone", (0.7, 0.68, 0.62), roughness=0.8)
    red = g.material("red", (0.6, 0.12, 0.08), roughness=0.7)
    fence = g.material("fence", (1, 1, 1), metallic=0.0, roughness=0.5, base_tex=fence_tex,
                       double_sided=True, alpha=("MASK", 0.5))
    foliage = g.material("leaf", (1, 1, 1), roughness=0.7, base_tex=leaf_tex,
                         double_sided=True, alpha=("BLEND", None))
    g.node("ground", g.mesh("ground", quad(40, 40), ground))
    g.node("block", g.mesh("block", box(1.0, 1.0, 1.0), stone), t=(-0.8, 0.5, -1.6),
           r=quat_axis((0, 1, 0), 30))
    g.node("pillar", g.mesh("pillar", box(0.5, 2.0, 0.5), red), t=(1.2, 1.0, -1.4))
    # the fence: 4 m x 1.5 m, standing in the XY plane at z = 0 (the quad's UVs repeat the
    # 32-texel tile once per metre)
    g.node("fence", g.mesh("fence", quad(4.0, 1.5), fence), t=(0, 0.75, 0),
           r=quat_axis((1, 0, 0), 90))
    for i, (x, y, z, yaw) in enumerate([(-1.2, 1.9, 0.6, 20), (0.9, 2.1, 0.9, -35)]):
        g.node("leaf_%d" % i, g.mesh("leaf_%d" % i, quad(1.0, 1.0), foliage), t=(x, y, z),
               r=quat_mul(quat_axis((0, 1, 0), yaw), quat_axis((1, 0, 0), 80)))
    sl = g.light("sun", "directional", (1.0, 0.95, 0.85), 6.0)
    g.light_node("sun", sl, r=quat_mul(quat_axis((0, 1, 0), 20), quat_axis((1, 0, 0), -35)))
    g.doc["scenes"][0]["extras"] = {"tandem_sky": [0.35, 0.5, 0.8]}
    cam = g.camera("camera", 50.0)
    g.node("camera", t=(0.3, 1.6, 4.5), r=look_rot(4, -12), camera=cam)
    g.write(out)


def cylinder(r, h, seg, rings):
    """A cylinder of radius r from y = 0 to h, seg x rings quads, smooth normals, no caps."""
    pos, nrm, uv, idx = [], [], [], []
    for j in range(rings + 1):
        y = h * j / rings
        for i in range(seg + 1):
            a = 2 * math.pi * i / seg
            n = (math.cos(a), 0.0, math.sin(a))
            pos.append((r * n[0], y, r * n[2]))
            nrm.append(n)
            uv.append((i / seg * 2 * math.pi * r, y))
    for j in range(rings):
        for i in range(seg):
            a, b = j * (seg + 1) + i, (j + 1) * (seg + 1) + i
            idx += [a, b, a + 1, a + 1, b, b + 1]
    return pos, nrm, uv, idx


def grid(w, d, nx, nz, tile):
    """A w x d floor in the XZ plane facing +Y, nx x nz quads, UVs in units of `tile` metres."""
    pos, nrm, uv, idx = [], [], [], []
    for j in range(nz + 1):
        for i in range(nx + 1):
            x, z = -w / 2 + w * i / nx, -d / 2 + d * j / nz
            pos.append((x, 0.0, z))
            nrm.append((0.0, 1.0, 0.0))
            uv.append((x / tile, z / tile))
    for j in range(nz):
        for i in range(nx):
            a, b = j * (nx + 1) + i, (j + 1) * (nx + 1) + i
            idx += [a, b, a + 1, a + 1, b, b + 1]
    return pos, nrm, uv, idx


def atrium(out):
    """What real scenes stress, at a size benchmarks feel: a 16 x 24 m courtyard open to the sky
    (a generated clear sky, atrium_sky.exr, through the roof's opening) and a low sun; stone
    floor tiles and columns (over 500k triangles traced: 16 columns of 30k, instanced), wooden
    beams and benches, a stone fountain, galleries behind a cut-out railing (MASK) and planters of
    alpha-tested leaf cards (BLEND); a camera path through the colonnade (8 s)."""
    g = Gltf("atrium")
    rng = random.Random(7)

    def stone_px(x, y):
        grout = (x % 64) < 2 or (y % 64) < 2
        n = rng.randint(-12, 12)
        v = 90 if grout else 178 + n + ((x // 64 + y // 64) % 3) * 6
        return (v, v - 6, v - 16, 255)

    def wood_px(x, y):
        r = 0.5 + 0.5 * math.sin(0.35 * x + 2.5 * math.sin(0.05 * y) + 0.2 * math.sin(0.9 * x))
        return (int(110 + 60 * r), int(70 + 40 * r), int(35 + 20 * r), 255)

    def leaf_px(x, y):
        rr = math.hypot((x - 31.5) / 14.0, (y - 31.5) / 30.0)
        a = max(0.0, min(1.0, (1.08 - rr) / 0.16))
        return (50 + (y % 7) * 4, 105 + (x * 3) % 50, 35, int(round(255 * a)))

    def rail_px(x, y):
        bar = (x % 16) < 3 or y < 4 or y > 59 or (y % 32) < 2
        return (40, 38, 36, 255 if bar else 0)
    stone_t = png("atrium_stone.png", 256, 256, stone_px)
    wood_t = png("atrium_wood.png", 256, 256, wood_px)
    leaf_t = png("atrium_leaf.png", 64, 64, leaf_px)
    rail_t = png("atrium_rail.png", 64, 64, rail_px)
    stone = g.material("stone", (1, 1, 1), roughness=0.85, base_tex=stone_t)
    column_m = g.material("column", (0.92, 0.9, 0.86), roughness=0.7, base_tex=stone_t)
    plaster = g.material("plaster", (0.78, 0.74, 0.66), roughness=0.9)
    wood = g.material("wood", (1, 1, 1), roughness=0.55, base_tex=wood_t)
    leaf = g.material("leaf", (1, 1, 1), roughness=0.6, base_tex=leaf_t, double_sided=True,
                      alpha=("BLEND", None))
    rail = g.material("railing", (1, 1, 1), metallic=0.0, roughness=0.4, base_tex=rail_t,
                      double_sided=True, alpha=("MASK", 0.5))
    W, D, H = 16.0, 24.0, 9.0
    g.node("floor", g.mesh("floor", grid(W, D, 80, 120, 1.0), stone))
    # walls (facing inwards) and a roof with an 8 x 14 m opening
    wall_ns = g.mesh("wall_ns", quad(W, H), plaster)
    wall_ew = g.mesh("wall_ew", quad(D, H), plaster)
    g.node("wall_n", wall_ns, t=(0, H / 2, -D / 2), r=quat_axis((1, 0, 0), 90))
    g.node("wall_s", wall_ns, t=(0, H / 2, D / 2),
           r=quat_mul(quat_axis((0, 1, 0), 180), quat_axis((1, 0, 0), 90)))
    g.node("wall_w", wall_ew, t=(-W / 2, H / 2, 0),
           r=quat_mul(quat_axis((0, 1, 0), 90), quat_axis((1, 0, 0), 90)))
    g.node("wall_e", wall_ew, t=(W / 2, H / 2, 0),
           r=quat_mul(quat_axis((0, 1, 0), -90), quat_axis((1, 0, 0), 90)))
    roof_side = g.mesh("roof_side", box(4.0, 0.4, D), plaster)
    roof_end = g.mesh("roof_end", box(8.0, 0.4, 5.0), plaster)
    for x in (-6.0, 6.0):
        g.node("roof_%+d" % x, roof_side, t=(x, H + 0.2, 0))
    for z in (-9.5, 9.5):
        g.node("roof_end_%+d" % z, roof_end, t=(0, H + 0.2, z))
    # colonnades on both sides, galleries above them behind a railing
    column = g.mesh("column", cylinder(0.3, 4.0, 64, 240), column_m)
    capital = g.mesh("capital", box(0.8, 0.25, 0.8), stone)
    for k, z in enumerate([-9.8 + 2.8 * i for i in range(8)]):
        for x in (-4.5, 4.5):
            g.node("column_%d_%+d" % (k, x), column, t=(x, 0, z))
            g.node("capital_%d_%+d" % (k, x), capital, t=(x, 4.125, z))
    gallery = g.mesh("gallery", box(3.5, 0.3, D), stone)
    railing = g.mesh("railing", quad(D, 1.0), rail)
    for x in (-1, 1):
        g.node("gallery_%+d" % x, gallery, t=(x * 6.25, 4.4, 0))
        g.node("railing_%+d" % x, railing, t=(x * 4.55, 5.05, 0),
               r=quat_mul(quat_axis((0, 1, 0), 90), quat_axis((1, 0, 0), 90)))
    # beams across the opening, benches, the fountain, planters with leaf cards
    beam = g.mesh("beam", box(8.0, 0.3, 0.3), wood)
    for z in (-5.0, -1.7, 1.7, 5.0):
        g.node("beam_%+.1f" % z, beam, t=(0, H - 0.6, z))
    bench = g.mesh("bench", box(1.8, 0.45, 0.5), wood)
    for k, (x, z, yaw) in enumerate([(-2.5, -6, 0), (2.5, -6, 0), (-2.5, 6, 0), (2.5, 6, 0)]):
        g.node("bench_%d" % k, bench, t=(x, 0.225, z), r=quat_axis((0, 1, 0), yaw))
    bowl = g.mesh("fountain", sphere(1.0, 128, 64), column_m)
    g.node("fountain", bowl, t=(0, 0.35, 0), s=(1.6, 0.5, 1.6))
    planter = g.mesh("planter", box(1.0, 0.6, 1.0), plaster)
    card = g.mesh("leaf_card", quad(0.45, 0.9), leaf)
    for k, (x, z) in enumerate([(-6.5, -9), (6.5, -9), (-6.5, 9), (6.5, 9), (-2.8, 0),
                                (2.8, 0), (-6.5, 0), (6.5, 0)]):
        g.node("planter_%d" % k, planter, t=(x, 0.3, z))
        for c in range(40):
            yaw, tilt = rng.uniform(0, 360), rng.uniform(20, 75)
            t = (x + rng.uniform(-0.3, 0.3), 0.9 + rng.uniform(0, 0.9),
                 z + rng.uniform(-0.3, 0.3))
            g.node("leaf_%d_%d" % (k, c), card, t=t,
                   r=quat_mul(quat_axis((0, 1, 0), yaw), quat_axis((1, 0, 0), tilt)))
    sl = g.light("sun", "directional", (1.0, 0.93, 0.8), 4.0)
    g.light_node("sun", sl, r=quat_mul(quat_axis((0, 1, 0), 35), quat_axis((1, 0, 0), -62)))
    write_exr_rgb(os.path.join(out, "atrium_sky.exr"), 256, 128, atrium_sky)
    g.doc["scenes"][0]["extras"] = {"tandem_env": {"uri": "atrium_sky.exr", "intensity": 1.0}}
    camera_path(g, "camera", [(0.0, (-2.0, 1.7, 10.5), -15, 2), (4.0, (-1.5, 1.7, 2.5), 10, 8),
                              (8.0, (1.5, 1.8, -6.0), 35, 14)], yfov=60.0)
    g.write(out)


def extremes(out):
    """Numerical extremes: a tiny very bright light beside a large dim one, geometry 1e5 units
    from the origin, roughness 0 and 1, metallic 0 and 1, grazing views."""
    g = Gltf("extremes")
    far = g.node("far_away", t=(1.0e5, 0.0, -1.0e5))  # everything below lives here
    plane = g.material("plane", (0.5, 0.5, 0.5), roughness=1.0)
    mirror = g.material("rough0_metal1", (0.9, 0.9, 0.9), metallic=1.0, roughness=0.0)
    rough1 = g.material("rough1_metal0", (0.9, 0.9, 0.9), metallic=0.0, roughness=1.0)
    smooth_d = g.material("rough0_metal0", (0.2, 0.7, 0.3), metallic=0.0, roughness=0.0)
    rough_m = g.material("rough1_metal1", (0.9, 0.6, 0.3), metallic=1.0, roughness=1.0)
    tiny = g.material("tiny_bright", (0, 0, 0), emission=(1, 1, 1), strength=1.0e5)
    dim = g.material("large_dim", (0, 0, 0), emission=(1, 1, 1), strength=1.0e-4)
    g.node("plane", g.mesh("plane", quad(200, 200), plane), parent=far)
    for i, (m, x) in enumerate([(mirror, -1.5), (rough1, -0.5), (smooth_d, 0.5), (rough_m, 1.5)]):
        g.node("sphere_%d" % i, g.mesh("sphere_%d" % i, sphere(0.4, 24, 12), m),
               t=(x, 0.4, 0), parent=far)
    g.node("tiny_bright_light", g.mesh("tiny_bright_light", quad(0.01, 0.01), tiny),
           t=(0.0, 1.2, 0.3), r=quat_axis((1, 0, 0), 180), parent=far)
    g.node("large_dim_light", g.mesh("large_dim_light", quad(20, 20), dim),
           t=(0.0, 6.0, 0.0), r=quat_axis((1, 0, 0), 180), parent=far)
    pl = g.light("faint_point", "point", (1, 1, 1), 1.0e-4)
    g.light_node("faint_point", pl, t=(2.0, 0.5, 1.0), parent=far)
    bl = g.light("blazing_point", "point", (1, 1, 1), 1.0e5)
    g.light_node("blazing_point", bl, t=(-2.5, 0.3, -1.0), parent=far)
    # grazing: the camera skims the plane at 2 cm and looks almost along it
    cam = g.camera("camera", 40.0, zfar=None)
    c = g.node("camera", t=(0.0, 0.02, 6.0), r=look_rot(0, -0.3), camera=cam, parent=far)
    g.animate(c, "translation", [0.0, 2.0], [(0.0, 0.02, 6.0), (0.3, 0.05, 5.5)])
    g.animate(c, "rotation", [0.0, 2.0], [look_rot(0, -0.3), look_rot(4, -0.5)])
    g.write(out)


def many_lights(out):
    """A level of rooms off a corridor lit only by its own small emitters (issue 62): 12 rooms of
    3 x 4 m, each with 8 to 14 ceiling lamps (0.25 m squares) of varied colour and power (1 to
    40 nits over a range of 40x), a row of 24 strip lights down the corridor and 4 small glowing
    cubes that move: 450 emissive triangles, no sky. From any point most of them are behind
    walls or across the level, which is what a power table cannot know. The camera walks down
    the corridor looking into the rooms."""
    g = Gltf("many_lights")
    rnd = random.Random(62)
    wall = g.material("wall", (0.7, 0.68, 0.64), roughness=0.9)
    floor_m = g.material("floor", (0.45, 0.42, 0.4), roughness=0.6)
    H, RW, RD, CW = 3.0, 3.0, 4.0, 2.0  # height, room width (x), room depth (z), corridor width
    L = 6 * RW  # the corridor's length: 6 rooms on each side
    # floor and ceiling over the whole level; the ceiling faces down
    g.node("floor", g.mesh("floor", quad(L, 2 * RD + CW), floor_m))
    g.node("ceiling", g.mesh("ceiling", quad(L, 2 * RD + CW), wall), t=(0, H, 0),
           r=quat_axis((1, 0, 0), 180))
    # outer walls, facing in
    g.node("end_w", g.mesh("end_w", quad(2 * RD + CW, H), wall), t=(-L / 2, H / 2, 0),
           r=quat_mul(quat_axis((0, 0, 1), -90), quat_axis((0, 1, 0), 90)))
    g.node("end_e", g.mesh("end_e", quad(2 * RD + CW, H), wall), t=(L / 2, H / 2, 0),
           r=quat_mul(quat_axis((0, 0, 1), 90), quat_axis((0, 1, 0), 90)))
    for side in ("n", "s"):
        sg = -1 if side == "n" else 1
        zo = sg * (CW / 2 + RD)  # the outer wall
        zw = sg * CW / 2  # the rooms' front wall, along the corridor
        g.node("outer_" + side, g.mesh("outer_" + side, box(L, H, 0.1), wall),
               t=(0, H / 2, zo + sg * 0.05))
        for r in range(6):  # each room's front wall has a doorway of 1 m; walls between rooms
            x0 = -L / 2 + r * RW
            seg = (RW - 1.0) / 2
            for k, xc in enumerate((x0 + seg / 2, x0 + RW - seg / 2)):
                g.node("front_%s%d_%d" % (side, r, k),
                       g.mesh("front_%s%d_%d" % (side, r, k), box(seg, H, 0.1), wall),
                       t=(xc, H / 2, zw))
            g.node("lintel_%s%d" % (side, r), g.mesh("lintel_%s%d" % (side, r),
                                                      box(1.0, 0.8, 0.1), wall),
                   t=(x0 + RW / 2, H - 0.4, zw))
            if r:
                g.node("party_%s%d" % (side, r), g.mesh("party_%s%d" % (side, r),
                                                        box(0.1, H, RD), wall),
                       t=(x0, H / 2, (zw + zo) / 2))
    # lamps: a few materials of varied colour and strength, instanced
    lamp_geo = quad(0.25, 0.25)
    mats = []
    for k in range(8):
        col = [(1.0, 0.95, 0.85), (0.85, 0.9, 1.0), (1.0, 0.8, 0.6), (0.9, 1.0, 0.9)][k % 4]
        strength = [1.0, 2.5, 5.0, 10.0, 20.0, 40.0, 3.0, 8.0][k]
        mats.append(g.mesh("lamp_%d" % k, lamp_geo,
                           g.material("lamp_%d" % k, (0.8, 0.8, 0.8), emission=col,
                                      strength=strength)))
    down = quat_axis((1, 0, 0), 180)
    for side, zc in (("n", -(CW / 2 + RD / 2)), ("s", CW / 2 + RD / 2)):
        for r in range(6):
            x0 = -L / 2 + r * RW
            for j in range(rnd.randint(8, 14)):
                x = x0 + 0.3 + rnd.random() * (RW - 0.6)
                z = zc + (rnd.random() - 0.5) * (RD - 0.6)
                g.node("lamp_%s%d_%d" % (side, r, j), mats[rnd.randrange(8)],
                       t=(x, H - 0.002, z), r=down)
    strip = g.mesh("strip", quad(0.6, 0.1), g.material("strip", (0.8, 0.8, 0.8),
                                                        emission=(1.0, 1.0, 1.0), strength=6.0))
    for k in range(24):
        g.node("strip_%d" % k, strip, t=(-L / 2 + (k + 0.5) * L / 24, H - 0.002, 0), r=down)
    glow = g.material("glow", (0.8, 0.8, 0.8), emission=(1.0, 0.5, 0.2), strength=15.0)
    cube = g.mesh("glow_cube", box(0.15, 0.15, 0.15), glow)
    for k in range(4):  # moving emitters: back and forth in the corridor and two rooms
        x = -L / 2 + (k + 1) * L / 5
        n = g.node("glow_%d" % k, cube, t=(x, 0.5, 0))
        g.animate(n, "translation", [0.0, 2.0, 4.0],
                  [(x, 0.5, -0.6), (x + 1.5, 0.9, 0.6), (x, 0.5, -0.6)])
    camera_path(g, "camera", [(0.0, (-L / 2 + 1.0, 1.6, 0.3), -80, -6),
                              (2.0, (-L / 2 + 5.0, 1.6, -0.3), -60, -4),
                              (4.0, (-L / 2 + 9.0, 1.6, 0.3), -100, -6)], yfov=60.0)
    g.doc["scenes"][0]["extras"] = {"tandem_sky": [0, 0, 0]}  # closed: no default light
    g.write(out)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "data", "scenes")
    os.makedirs(out, exist_ok=True)
    only = sys.argv[2:]  # [OUTDIR NAME...]: those scenes alone
    for f in (cornell, materials, dynamic, sun, extremes, cutout, atrium, closed_box,
              many_lights):
        if not only or f.__name__ in only:
            f(out)


if __name__ == "__main__":
    main()
