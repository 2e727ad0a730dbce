#!/usr/bin/python3
"""Tandem from Python, step by step, as a notebook would run it (docs/python.md):

    PYTHONPATH=build/python /usr/bin/python3 examples/python/walkthrough.py

A real asset (Khronos' 2CylinderEngine from Debian's assimp-testmodels) lit by a real HDRI
(blender-data's courtyard), orbited by a camera path; a few frames rendered with a built-in
denoiser and with the PyTorch example (temporal_denoiser.py, weights temporal_denoiser.pt or
--weights), the matched reference of the same frames, and eval's metrics of each against it,
frame by frame. Everything stays in numpy arrays; nothing is written unless --out is given.
"""
import argparse
import os
import sys
import time

import numpy as np

import tandem

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

ENGINE = "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"
HDRI = "/usr/share/blender/datafiles/studiolights/world/courtyard.exr"

ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
ap.add_argument("--frontend", default="embree", help="embree (CPU) or vk (Vulkan ray tracing)")
ap.add_argument("--frames", type=int, default=6)
ap.add_argument("--size", default="160x96")
ap.add_argument("--spp", type=int, default=256, help="the matched reference's samples")
ap.add_argument("--weights", default=os.path.join(HERE, "temporal_denoiser.pt"))
ap.add_argument("--out", help="also write the frames there as PNG strips")
a = ap.parse_args()
w, h = (int(v) for v in a.size.split("x"))

# 1. The scene, as every tandem command loads it (scene options by their command-line names).
scene = tandem.Scene(ENGINE, env=HDRI, camera_path="orbit", path_duration=8)
info = scene.info()
print("1. %s: %d triangles, %d materials (%s), environment %dx%d" % (
    os.path.basename(ENGINE), info["triangles"], sum(info["materials"].values()),
    ", ".join(k for k, v in info["materials"].items() if v), info["environment"]["width"],
    info["environment"]["height"]))

# 2. Denoised frames: a built-in by name, and the PyTorch example given as its class (it runs in
#    this process, in the same frame loop, with the same post chain).
import temporal_denoiser  # noqa: E402


class Learned(temporal_denoiser.Denoiser):
    def __init__(self, width, height):
        super().__init__(width, height, a.weights)


runs = {}
for name, dn in (("asvgf", "asvgf"), ("svgf", "svgf"), ("learned", Learned)):
    t0 = time.time()
    r = tandem.Renderer(scene, frontend=a.frontend, denoiser=dn, size=(w, h))  # (scene: loaded once)
    runs[name] = [r.frame(f, contract=(name == "asvgf")) for f in range(a.frames)]
    print("2. %-8s %d frames in %.1f s (denoiser as run: %s)" % (name, a.frames, time.time() - t0,
                                                                r.denoiser))
# the noisy input: the composite of each frame's contract (render --denoiser off without TAA)
runs["noisy"] = [{"radiance": fr["contract"].composite()} for fr in runs["asvgf"]]
c = runs["asvgf"][0]["contract"]
print("   frame 0's contract: %s; depth %.2f..%.2f m" % (
    ", ".join(c.keys()[:6]) + ", ...", float(c["depth"][c["depth"] < 1e20].min()),
    float(c["depth"][c["depth"] < 1e20].max())))

# 3. The matched reference: the real-time estimator's expectation over many samples.
t0 = time.time()
ref = tandem.Renderer(scene, reference=True, frontend=a.frontend, estimator="realtime",
                      spp=a.spp, size=(w, h))
refs = [ref.reference(f) for f in range(a.frames)]
print("3. matched reference: %d frames of %d spp in %.1f s, noise left %.2f%% (mean relative "
      "standard error)" % (a.frames, refs[0]["spp"], time.time() - t0,
                           100 * np.mean([r["rel_error"] for r in refs])))

# 4. eval's metrics on the arrays (the same C code as `tandem eval`), one exposure for all.
exposure = tandem.auto_exposure([r["radiance"] for r in refs])
print("4. against the matched reference, per frame (relMSE / FLIP):")
print("   %-8s" % "frame" + "".join("%18s" % n for n in runs))
seqs = {n: tandem.Sequence(w, h, exposure) for n in runs}
rows = {n: [] for n in runs}
for f in range(a.frames):
    cells = []
    for n in runs:
        m = seqs[n].add(runs[n][f]["radiance"], refs[f]["radiance"], frame=f,
                        variance=refs[f]["variance"])
        rows[n].append(m)
        cells.append("%9.4f / %6.4f" % (m["relmse"], m["flip"]))
    print("   %-8d" % f + "".join("%18s" % c for c in cells))
print("   %-8s" % "mean" + "".join("%18s" % ("%9.4f / %6.4f" % (
    seqs[n].summary()["relmse"], seqs[n].summary()["flip"])) for n in runs))

if a.out:
    import OpenImageIO as oiio
    os.makedirs(a.out, exist_ok=True)
    for n in ("asvgf", "learned"):
        strip = np.concatenate([fr["display"] for fr in runs[n]], axis=1)
        out = oiio.ImageOutput.create(os.path.join(a.out, n + ".png"))
        out.open(os.path.join(a.out, n + ".png"), oiio.ImageSpec(strip.shape[1], h, 3, "uint8"))
        out.write_image(strip)
        out.close()
    print("-> %s/asvgf.png, %s/learned.png" % (a.out, a.out))
