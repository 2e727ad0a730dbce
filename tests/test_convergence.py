#!/usr/bin/env python3
"""Denoisers that converge: judged against the matched reference frame by frame, as a user of
`tandem eval` judges them (docs/denoise.md, "Convergence").

On closed_box.gltf (a closed box lit by one ceiling panel; the camera stands still), 64x64:
- every built-in denoiser's error falls and never climbs back: no frame from frame 6 on is
  worse than the mean of frames 2..5 (the old back-end's error tripled between frame 3 and
  frame 47: SVGF's feedback and the jittered history resampling blurred the histories a little
  more every frame);
- it ends at or below TAA alone's (`--denoiser off`, whose error levels off where TAA's
  history weight 0.1 leaves it) and at or below accumulation alone's (the running mean of the
  noisy frames, eval's own verdict), on both front-ends;
- the band under the lamp (the image's top eighth, where the ceiling meets the wall and the
  light changes fastest) stays within 5% of the matched reference at every frame (measured on
  lavapipe: 4.6% under at frame 0, where one sample per pixel meets the variance-guided
  filter, whose weights favour neighbours darker than a bright centre in heavy-tailed noise,
  2.2% under over the whole image; within 2.5% from frame 2 on; the old back-end was 14% over
  at frame 3 and 34% at frame 47, TAA alone 4-8% under);
on cornell.gltf, whose camera moves over static light (64x36, 16 frames), A-SVGF's error is
within 5% of SVGF's (relMSE and FLIP): the gradients are small there and must not cost history
(the lag after a light switch, where A-SVGF must stay far ahead, is test_denoise's
test_asvgf_follows_light_switch).

Matched references: the still camera's frames all have one expectation, so one frame of 4096
spp stands for every frame (its noise, a relMSE near 0.13 / 4096 = 3e-5, is under 3% of the
smallest error measured here; --quick: 1024 spp, 1.3e-4, under 10% of the errors of its 16
frames); the moving camera's are rendered per frame at 512 spp (--quick: 256; noise under
5e-4, some 2-3% of the errors compared; both denoisers are measured against the same frames,
so it cancels in their ratio). Both are the Embree front-end's; --quick renders them with the
Vulkan one (the same expectation, test_matched_reference cross-checks the two): lavapipe is not
built with the sanitizers, so under them it takes 42 s instead of 230 (in the release build
Embree is the faster, 7 s against 17 for the box).

usage: test_convergence.py TANDEM [--quick]   (--quick: fewer frames, for the sanitizer build)
"""
import json
import os
import shutil
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tandem_cli import Checks  # noqa: E402

TANDEM = os.path.abspath(sys.argv[1])
QUICK = "--quick" in sys.argv[2:]
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
BOX = os.path.join(ROOT, "data", "scenes", "closed_box.gltf")
CORNELL = os.path.join(ROOT, "data", "scenes", "cornell.gltf")
C = Checks(TANDEM)
check, run = C.check, C.run
FRAMES = 16 if QUICK else 32
REF_FRONTEND = ["--frontend", "vk" if QUICK else "embree"]


def lum(path):
    a = oiio.ImageBuf(path).get_pixels(oiio.FLOAT)[:, :, :3].astype(np.float64)
    return a @ np.array([0.2126, 0.7152, 0.0722])


def curve(d, series=0):
    m = json.load(open(f"{d}/metrics.json"))
    return np.array([f["relmse"] for f in m["series"][series]["frames"]]), m


tmp = tempfile.mkdtemp(prefix="tandem_convergence_")
try:
    box = ["--scene", BOX, "--size", "64x64", "--quiet"]
    run("reference", *REF_FRONTEND, "--estimator", "realtime", "--frames", "1", "--spp",
        "1024" if QUICK else "4096", "--out", f"{tmp}/ref1", *box)
    os.makedirs(f"{tmp}/ref")
    for k in range(FRAMES):  # the still camera: one expectation for every frame
        shutil.copy(f"{tmp}/ref1/frame_0000.exr", f"{tmp}/ref/frame_{k:04d}.exr")
    ref_band = lum(f"{tmp}/ref/frame_0000.exr")[:8].mean()

    # every registered denoiser that filters (tandem info --pipeline), the one that does not
    # (TAA alone: "off"), and the one with gradient samples on the Embree front-end as well
    reg = json.loads(run("info", "--pipeline", "--json").stdout)["denoisers"]
    filtering = [d["name"] for d in reg if "filters" in d["capabilities"]]
    plain = next(d["name"] for d in reg if "filters" not in d["capabilities"])
    grad = next(d["name"] for d in reg if "gradients" in d["capabilities"])
    runs = {}
    for fe, dn in [("vk", d) for d in filtering] + [("vk", plain), ("embree", grad)]:
        d = f"{tmp}/{fe}_{dn}"
        run("render", "--frontend", fe, "--denoiser", dn, "--frames", str(FRAMES), "--capture",
            "--out", d, *box)
        run("eval", "--out", d, "--matched-reference", f"{tmp}/ref", "--quiet")
        runs[(fe, dn)] = curve(d)
    last = max(FRAMES // 4, 1)  # the last quarter of the frames
    taa_only = runs[("vk", plain)][0][-last:].mean()
    for (fe, dn), (r, m) in runs.items():
        if dn == plain:
            continue
        early = r[2:6].mean()
        worst_late = r[6:].max()
        end = r[-last:].mean()
        acc = m["settings"].get("convergence", {"still": False, "at_or_below_accumulation": False,
                                                "accumulation_last_quarter_relmse": float("nan")})
        check(f"{fe} {dn}: the error falls and stays down on a still camera",
              worst_late <= early,
              f"relMSE frames 2..5 {early:.4g}, worst from frame 6 {worst_late:.4g}, "
              "per frame " + " ".join(f"{x:.4f}" for x in r))
        check(f"{fe} {dn}: ends at or below TAA alone's and accumulation alone's",
              end <= taa_only and acc["still"] and acc["at_or_below_accumulation"],
              f"last quarter relMSE {end:.4g}, TAA alone {taa_only:.4g}, accumulation alone "
              f"{acc['accumulation_last_quarter_relmse']:.4g}")
        band = np.array([lum(f"{tmp}/{fe}_{dn}/frame_{k:04d}.exr")[:8].mean() / ref_band
                         for k in range(FRAMES)])
        check(f"{fe} {dn}: the band under the lamp within 5% of the matched reference at every "
              "frame", np.all(np.abs(band - 1) < 0.05),
              "band / reference " + " ".join(f"{x:.3f}" for x in band))

    # the moving camera over static light: A-SVGF's gradients must not cost it against SVGF
    cam = ["--scene", CORNELL, "--size", "64x36", "--frames", "16", "--quiet"]
    run("reference", *REF_FRONTEND, "--estimator", "realtime", "--spp",
        "256" if QUICK else "512",
        "--out", f"{tmp}/cref", *cam)
    got = {}
    for dn in ("asvgf", "svgf"):
        d = f"{tmp}/cornell_{dn}"
        run("render", "--frontend", "vk", "--denoiser", dn, "--out", d, *cam)
        p = run("eval", "--out", d, "--matched-reference", f"{tmp}/cref", "--json")
        got[dn] = json.loads(p.stdout)[0]
    a, s = got["asvgf"], got["svgf"]
    check("moving camera, static light: A-SVGF within 5% of SVGF (relMSE, FLIP)",
          a["relmse"] <= 1.05 * s["relmse"] and a["flip"] <= 1.05 * s["flip"],
          f"relMSE {a['relmse']:.4g} / {s['relmse']:.4g}, FLIP {a['flip']:.4f} / {s['flip']:.4f}")
finally:
    shutil.rmtree(tmp, ignore_errors=True)
C.finish()
