#!/usr/bin/env python3
"""tests/bench_cycles_noise.py [--spp K] [--size N] [--threads T] TANDEM: a benchmark, run by hand
(not a test: its figure is a speed): how long Tandem's unbiased reference needs to reach the noise
of Blender Cycles, on the same cores, as a ratio measured in one run.

The scene is test_cycles.py's `room_one_sided`: a closed pure-Lambert room lit by a one-sided
emissive quad under the ceiling, which both renderers model exactly alike (tests/cycles_render.py:
Diffuse BSDF, Cycles' light sampling on, adaptive sampling off, box filter one pixel wide, 128
bounces). Each renderer makes two independent images at K samples (Tandem: frames 0 and 1 of the
still camera, whose samples are independent; Cycles: seeds 1 and 2). The noise of one image is
its relative variance, mean over pixels of (a - b)^2 / 2 / m^2 (m the two images' mean
luminance, pixels that see the emitter left out); its time is the time spent sampling
(Tandem: reference.json's `seconds` per frame; Cycles: the render time its log prints, scene
sync included, start-up excluded). Time to equal noise scales as time x variance, so

    ratio = (T_tandem x V_tandem) / (T_cycles x V_cycles)

is how many times Cycles' time Tandem needs for the same noise (below 1: Tandem is sooner).
Prints both renderers' figures and the ratio; exit 0, or 1 when something failed to run."""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from test_cycles import room  # noqa: E402

LUM = np.array([0.2126, 0.7152, 0.0722])


def lum(path):
    img = oiio.ImageBuf(path)
    if img.has_error:
        raise SystemExit("bench_cycles_noise: %s: %s" % (path, img.geterror()))
    return np.asarray(img.get_pixels(oiio.FLOAT), np.float64)[:, :, :3] @ LUM


def rel_variance(a, b):
    """one image's relative variance from two independent ones, and its standard error"""
    m = 0.5 * (a + b)
    keep = (m < 2.0) & (m > 1e-4)  # not the emitter (its radiance is 12), not black
    r = 0.5 * (a - b)[keep] ** 2 / m[keep] ** 2
    return r.mean(), r.std(ddof=1) / np.sqrt(r.size)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("tandem")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--keep", help="keep the images in this directory")
    a = ap.parse_args()
    blender = shutil.which("blender")
    if not blender:
        print("bench_cycles_noise: blender is not installed (scripts/install-deps.sh installs it)")
        return 1
    tmp = a.keep or tempfile.mkdtemp(prefix="tandem_cycles_noise_")
    os.makedirs(tmp, exist_ok=True)
    try:
        room("room_one_sided", False).write(tmp)
        scene = os.path.join(tmp, "room_one_sided.gltf")
        tdir = os.path.join(tmp, "tandem")
        subprocess.run([a.tandem, "reference", "--quiet", "--scene", scene, "--out", tdir,
                        "--frames", "2", "--spp", str(a.spp), "--size", "%dx%d" % (a.size, a.size),
                        "--threads", str(a.threads)], check=True)
        ref = json.load(open(os.path.join(tdir, "reference.json")))
        t_tandem = sum(f["seconds"] for f in ref["frames"]) / 2
        paths = ref["paths_per_s"]
        t_cycles = 0.0
        for seed in (1, 2):
            out = os.path.join(tmp, "cycles_%d.exr" % seed)
            r = subprocess.run([blender, "-b", "--factory-startup", "-noaudio", "-t",
                                str(a.threads), "-P", os.path.join(HERE, "cycles_render.py"),
                                "--", scene, out, str(a.spp), str(a.size), str(seed)],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            times = re.findall(r"\| Time:(\d+):(\d+\.\d+) \|", r.stdout)
            if r.returncode != 0 or not os.path.exists(out) or not times:
                print(r.stdout[-3000:])
                print("bench_cycles_noise: blender failed")
                return 1
            mm, ss = times[-1]
            t_cycles += (int(mm) * 60 + float(ss)) / 2
        vt, vt_se = rel_variance(lum(os.path.join(tdir, "frame_0000.exr")),
                                 lum(os.path.join(tdir, "frame_0001.exr")))
        vc, vc_se = rel_variance(lum(os.path.join(tmp, "cycles_1.exr")),
                                 lum(os.path.join(tmp, "cycles_2.exr")))
        ratio = t_tandem * vt / (t_cycles * vc)
        rel = np.hypot(vt_se / vt, vc_se / vc)
        print("room_one_sided %dx%d, %d spp, %d threads" % (a.size, a.size, a.spp, a.threads))
        print("  Tandem (Embree, %s): %.2f s a frame, %.3g Mpaths/s, relative variance %.3g"
              % (ref.get("sampler", "hash"), t_tandem, paths * 1e-6, vt))
        print("  Cycles:                  %.2f s a frame, %.3g Mpaths/s, relative variance %.3g"
              % (t_cycles, a.size * a.size * a.spp / t_cycles * 1e-6, vc))
        print("  variance at equal samples: Tandem %.2fx Cycles'" % (vt / vc))
        print("  time to equal noise: Tandem %.2fx Cycles' (+- %.2f)" % (ratio, ratio * rel))
    finally:
        if not a.keep:
            shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
