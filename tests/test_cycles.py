#!/usr/bin/env python3
"""tests/test_cycles.py [--quick] TANDEM: Tandem's unbiased reference against Blender Cycles, an independent
renderer set up to model the same thing (tests/cycles_render.py says how), on two small closed
rooms and an open yard of pure-Lambert materials (KHR_materials_specular specularFactor 0) made
here:
  room_one_sided   lit by a one-sided emissive quad under the ceiling, facing down;
  room_two_sided   lit by a double-sided emissive panel standing in the room, facing the red
                   and the green wall (Tandem's NEE once lit only its front: -40% on the walls);
  yard_sunset      three boxes on a floor under sunset.exr (Debian's blender-data), no other
                   light, the sky in view: the environment map's orientation (Cycles' is the
                   one Tandem states), its importance sampling and MIS.
Both are rendered by `tandem reference` (Embree front-end) and by Cycles at SIZE x SIZE. The image
is cut into 4 x 4 regions; in each, the mean of the per-pixel differences Cycles - Tandem must be
within 4 standard errors of 0, the standard error measured from the spread of those differences
over the region's pixels (both renderers' noise, pixels independent), plus a systematic
allowance; so is the whole image, per channel. Directly visible emitters are left out of the
means (both show the emission exactly).

The allowance (SYSTEMATIC_*) is measured, not derived: at 4096 samples in both, Cycles reads
0.06-0.12% darker than Tandem over these rooms (4-6 standard errors), and 0.3-0.8% darker in the
band of wall that sees the emitter at grazing angles (just below its plane); Tandem before and
after the fixes of issue 30 agree within 0.02% there, and the cause is not isolated
(docs/estimator.md). The allowance covers that and nothing near the defects the comparison
exists for (a two-sided panel lighting one side: -40% on the walls).
Prints each region's difference and standard error, then "N passed, N failed".

--quick (the sanitizer build, where the reference runs some 30 times slower) renders Tandem's
reference at 512 samples instead of 4096: the standard errors, measured, grow to match.
Skipped (exit 0, says why) when `blender` is not installed: scripts/install-deps.sh installs it."""
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "scripts"))
from make_scenes import Gltf, box, quad, quat_axis  # noqa: E402

SIZE = 48
SUNSET = "/usr/share/blender/datafiles/studiolights/world/sunset.exr"
TANDEM_SPP = 4096
CYCLES_SPP = 1024
SIGMAS = 4.0
SYSTEMATIC_IMAGE = 0.003   # of the image mean
SYSTEMATIC_REGION = 0.01   # of the region mean


def room(name, two_sided):
    """A closed 2 m room (floor at y = 0), white floor, ceiling and back and front walls, red left
    and green right wall, a white box; the camera inside near the front wall, looking at -z."""
    g = Gltf(name)
    lam = dict(specular=0.0, metallic=0.0, roughness=1.0)
    white = g.material("white", (0.73, 0.73, 0.73), **lam)
    red = g.material("red", (0.63, 0.065, 0.05), **lam)
    green = g.material("green", (0.14, 0.45, 0.09), **lam)
    grey = g.material("grey", (0.5, 0.5, 0.5), **lam)
    S = 2.0
    g.node("floor", g.mesh("floor", quad(S, S), white))
    g.node("ceiling", g.mesh("ceiling", quad(S, S), white), t=(0, S, 0),
           r=quat_axis((1, 0, 0), 180))
    g.node("back", g.mesh("back", quad(S, S), white), t=(0, S / 2, -S / 2),
           r=quat_axis((1, 0, 0), 90))
    g.node("front", g.mesh("front", quad(S, S), white), t=(0, S / 2, S / 2),
           r=quat_axis((1, 0, 0), -90))
    g.node("left", g.mesh("left", quad(S, S), red), t=(-S / 2, S / 2, 0),
           r=quat_axis((0, 0, 1), -90))
    g.node("right", g.mesh("right", quad(S, S), green), t=(S / 2, S / 2, 0),
           r=quat_axis((0, 0, 1), 90))
    g.node("box", g.mesh("box", box(0.5, 0.7, 0.5), grey), t=(-0.45, 0.35, -0.4),
           r=quat_axis((0, 1, 0), 20))
    if two_sided:
        panel = g.material("panel", (0, 0, 0), emission=(1.0, 0.9, 0.7), strength=6.0,
                           double_sided=True, **lam)
        g.node("panel", g.mesh("panel", quad(0.5, 0.6), panel), t=(0.3, 1.0, -0.35),
               r=quat_axis((0, 0, 1), 90))
    else:
        light = g.material("light", (0, 0, 0), emission=(1.0, 0.85, 0.6), strength=12.0, **lam)
        g.node("light", g.mesh("light", quad(0.6, 0.6), light), t=(0, S - 0.01, 0),
               r=quat_axis((1, 0, 0), 180))
    cam = g.camera("camera", 70.0, aspect=1.0, znear=0.01)
    g.node("camera", t=(0.0, 1.0, 0.95), camera=cam)
    return g


def yard(name, env):
    """Three boxes (grey, red, green) on a 20 m white floor under the environment map `env` (no
    other light); the camera looks at them from above the floor, towards -z, with the map's sky
    behind them in view."""
    g = Gltf(name)
    lam = dict(specular=0.0, metallic=0.0, roughness=1.0)
    white = g.material("white", (0.6, 0.6, 0.6), **lam)
    red = g.material("red", (0.63, 0.065, 0.05), **lam)
    green = g.material("green", (0.14, 0.45, 0.09), **lam)
    grey = g.material("grey", (0.5, 0.5, 0.5), **lam)
    g.node("floor", g.mesh("floor", quad(20.0, 20.0), white))
    g.node("grey", g.mesh("grey", box(0.6, 0.9, 0.6), grey), t=(-0.9, 0.45, -0.6),
           r=quat_axis((0, 1, 0), 25))
    g.node("red", g.mesh("red", box(0.5, 0.5, 0.5), red), t=(0.3, 0.25, -0.2),
           r=quat_axis((0, 1, 0), -15))
    g.node("green", g.mesh("green", box(0.4, 1.2, 0.4), green), t=(1.0, 0.6, -1.1))
    cam = g.camera("camera", 60.0, aspect=1.0, znear=0.01)
    g.node("camera", t=(0.0, 1.3, 2.2), r=quat_axis((1, 0, 0), -18), camera=cam)
    g.doc["scenes"][0]["extras"] = {"tandem_env": {"uri": env, "intensity": 1.0}}
    return g


def read_rgb(path):
    img = oiio.ImageBuf(path)
    if img.has_error:
        raise SystemExit("test_cycles: %s: %s" % (path, img.geterror()))
    px = img.get_pixels(oiio.FLOAT)
    return np.asarray(px, dtype=np.float64)[:, :, :3]


def main():
    args = sys.argv[1:]
    quick = "--quick" in args  # the sanitizer build: fewer reference samples, same checks
    args = [a for a in args if a != "--quick"]
    if len(args) != 1:
        raise SystemExit("usage: test_cycles.py [--quick] TANDEM")
    tandem = args[0]
    tandem_spp = TANDEM_SPP // 8 if quick else TANDEM_SPP
    blender = shutil.which("blender")
    if not blender:
        print("skip: blender is not installed (scripts/install-deps.sh installs it)")
        print("0 passed, 0 failed")
        return 0
    passed = failed = 0
    tmp = tempfile.mkdtemp(prefix="tandem_cycles_")
    try:
        for name, two in (("room_one_sided", False), ("room_two_sided", True),
                          ("yard_sunset", None)):
            if two is None:
                if not os.path.exists(SUNSET):
                    print("skip yard_sunset: %s is missing (blender-data)" % SUNSET)
                    continue
                yard(name, SUNSET).write(tmp)
            else:
                room(name, two).write(tmp)
            scene = os.path.join(tmp, name + ".gltf")
            tdir = os.path.join(tmp, name + "_tandem")
            subprocess.run([tandem, "reference", "--quiet", "--scene", scene, "--out", tdir, "--frames", "1",
                            "--spp", str(tandem_spp), "--size", "%dx%d" % (SIZE, SIZE)],
                           check=True, stdout=subprocess.DEVNULL)
            cexr = os.path.join(tmp, name + "_cycles.exr")
            r = subprocess.run([blender, "-b", "--factory-startup", "-noaudio", "-P",
                                os.path.join(HERE, "cycles_render.py"), "--", scene, cexr,
                                str(CYCLES_SPP), str(SIZE), "7"],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            if r.returncode != 0 or not os.path.exists(cexr):
                print(r.stdout[-3000:])
                raise SystemExit("test_cycles: blender failed on %s" % scene)
            t = read_rgb(os.path.join(tdir, "frame_0000.exr"))
            c = read_rgb(cexr)
            if t.shape != c.shape:
                raise SystemExit("test_cycles: sizes differ: %s vs %s" % (t.shape, c.shape))
            lum = np.array([0.2126, 0.7152, 0.0722])
            tl, cl = t @ lum, c @ lum
            # pixels that see an emitter: brighter than any lit wall can be in either image
            seen = np.maximum(tl, cl) > 2.0
            print("%s: Tandem %d spp (Embree), Cycles %d spp, %dx%d, %d emitter pixels left out"
                  % (name, tandem_spp, CYCLES_SPP, SIZE, SIZE, int(seen.sum())))

            def check(what, d, ref, allowance):
                nonlocal passed, failed
                n = d.size
                mean, se = d.mean(), d.std(ddof=1) / np.sqrt(n)
                ok = abs(mean) <= SIGMAS * se + allowance * ref
                print("  %-4s %-16s Cycles - Tandem %+8.3f%% (standard error %.3f%%, %4.1f se) %s"
                      % ("ok" if ok else "FAIL", what, 100 * mean / ref, 100 * se / ref,
                         abs(mean) / se if se > 0 else 0.0, "" if ok else "<-"))
                passed += ok
                failed += not ok

            keep = ~seen
            for k, ch in enumerate("RGB"):
                check("image %s" % ch, (c[:, :, k] - t[:, :, k])[keep], t[:, :, k][keep].mean(),
                      SYSTEMATIC_IMAGE)
            b = SIZE // 4
            for ry in range(4):
                for rx in range(4):
                    sl = (slice(ry * b, ry * b + b), slice(rx * b, rx * b + b))
                    m = keep[sl]
                    if m.sum() < b * b // 2:
                        continue
                    check("region (%d, %d)" % (rx, ry), (cl[sl] - tl[sl])[m], tl[sl][m].mean(),
                          SYSTEMATIC_REGION)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("%d passed, %d failed" % (passed, failed))
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
