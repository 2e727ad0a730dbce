#!/usr/bin/env python3
"""tests/test_blender_capture.py TANDEM: a real Blender Cycles capture through `tandem denoise`.

Blender (Debian's 3.4) renders cornell.gltf with Cycles as a multilayer EXR sequence, the camera
dollying in by 2% of its distance per frame (tests/blender_capture.py: the passes
data/mappings/blender_cycles.json reads, 16 samples), and the same frames converged (512
samples). Then:
- `tandem denoise --denoiser off --taa off` through the mapping must return Cycles' noisy
  Combined pass on every pixel to float rounding (the mapping demodulates by the albedo and takes
  the emission off; the composite puts both back): max relative difference <= 1e-5;
- `--denoiser svgf --taa off`: the history must grow (mean length over the frame > 12 after 16
  frames: reprojection works from the capture's depth, normals and motion), and the relMSE
  against the converged frames (`tandem eval`, over the sequence) must be at most half the noisy
  input's.
- the same capture with Blender's default passes plus Denoising Data and Vector (no Emit pass:
  the mapping's emission is optional) denoises too: off is still Combined, svgf halves the error,
  and `tandem info --capture` names the fallback.
Before issue 23 this capture came out black (no visibility buffer: every pixel a miss) and, with
the motion vectors' sign wrong, never reprojected. Prints the figures, then "N passed, N failed".
Skipped (exit 0, says why) when `blender` is not installed."""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..")
FRAMES, SIZE, SPP, REF_SPP = 16, 48, 16, 512


def read(path, names=None):
    img = oiio.ImageBuf(path)
    if img.has_error:
        raise SystemExit("test_blender_capture: %s: %s" % (path, img.geterror()))
    px = np.asarray(img.get_pixels(oiio.FLOAT), dtype=np.float64)
    if names is None:
        return px[:, :, :3]
    ch = list(img.spec().channelnames)
    return px[:, :, [ch.index(n) for n in names]]


def main():
    if len(sys.argv) != 2:
        raise SystemExit("usage: test_blender_capture.py TANDEM")
    tandem = sys.argv[1]
    blender = shutil.which("blender")
    if not blender:
        print("skip: blender is not installed (scripts/install-deps.sh installs it)")
        print("0 passed, 0 failed")
        return 0
    passed = failed = 0

    def check(ok, what):
        nonlocal passed, failed
        print("  %-4s %s" % ("ok" if ok else "FAIL", what))
        passed += ok
        failed += not ok

    tmp = tempfile.mkdtemp(prefix="tandem_blender_")
    try:
        r = subprocess.run([blender, "-b", "--factory-startup", "-noaudio", "-P",
                            os.path.join(HERE, "blender_capture.py"), "--",
                            os.path.join(ROOT, "data", "scenes", "cornell.gltf"), tmp,
                            str(FRAMES), str(SIZE), str(SPP), str(REF_SPP)],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if r.returncode != 0:
            print(r.stdout[-3000:])
            raise SystemExit("test_blender_capture: blender failed")
        mapping = os.path.join(ROOT, "data", "mappings", "blender_cycles.json")
        runs = {}
        for mode in ("off", "svgf"):
            out = os.path.join(tmp, "denoised_" + mode)
            args = [tandem, "denoise", "--quiet", "--captures", os.path.join(tmp, "capture"),
                    "--map", mapping, "--denoiser", mode, "--taa", "off", "--out", out]
            if mode == "svgf":
                args += ["--dump", "temporal.hf"]
            subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
            e = subprocess.run([tandem, "eval", "--quiet", "--out", out, "--reference",
                                os.path.join(tmp, "converged"), "--json"], check=True,
                               stdout=subprocess.PIPE, text=True)
            runs[mode] = (out, json.loads(e.stdout)[0])
        # the off composite is Cycles' noisy image
        worst = 0.0
        rgb = ["ViewLayer.Combined." + c for c in "RGB"]
        for f in range(FRAMES):
            noisy = read(os.path.join(tmp, "capture", "frame_%04d.exr" % f), rgb)
            off = read(os.path.join(runs["off"][0], "frame_%04d.exr" % f))
            worst = max(worst, float((np.abs(off - noisy) / np.maximum(np.abs(noisy), 1e-3)).max()))
        check(worst <= 1e-5, "off equals Cycles' noisy Combined: max relative difference %.2e over "
              "%d frames" % (worst, FRAMES))
        hist = read(os.path.join(runs["svgf"][0], "dump", "temporal.hf_frame_%04d.exr"
                                 % (FRAMES - 1)), ["history"])
        check(hist.mean() > 12, "svgf history after %d frames: mean length %.2f"
              % (FRAMES, hist.mean()))
        # tandem info --capture: the motion check agrees best with the mapping as it is, and a
        # mapping with the motion signs flipped (the old one) is flagged
        flipped = os.path.join(tmp, "flipped.json")
        with open(mapping) as f:
            m = json.load(f)
        m["entries"]["motion"]["scale"] = [-1, 1, 0]
        with open(flipped, "w") as f:
            json.dump(m, f)
        infos = {}
        for name, mp in (("mapping", mapping), ("flipped", flipped)):
            r = subprocess.run([tandem, "info", "--capture", os.path.join(tmp, "capture"),
                                "--map", mp, "--json"], check=True, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
            infos[name] = (json.loads(r.stdout)["motion_check"], r.stderr)
            mc = infos[name][0]
            print("  info --capture (%s): motion check %.1f%% as given, %.1f%% x negated, %.1f%% "
                  "y negated, %.1f%% both" % (name, 100 * mc["as given"], 100 * mc["x negated"],
                                              100 * mc["y negated"],
                                              100 * mc["x and y negated"]))
        check(infos["mapping"][0]["best"] == "as given" and "warning" not in infos["mapping"][1],
              "the motion check agrees with the mapping")
        check(infos["flipped"][0]["best"] != "as given" and "warning" in infos["flipped"][1],
              "a flipped motion sign is flagged")
        rn, rd = runs["off"][1]["relmse"], runs["svgf"][1]["relmse"]
        check(rd <= 0.5 * rn, "relMSE against converged Cycles (%d spp): noisy %.4f, svgf %.4f "
              "(%.1fx lower)" % (REF_SPP, rn, rd, rn / rd if rd > 0 else float("inf")))
        # Blender's default passes + Denoising Data + Vector (no Emit pass): the mapping's
        # emission is optional, so the capture denoises; off is still the Combined pass (the
        # emitters filtered with their surroundings, the background from Combined where nothing
        # is hit), svgf still halves the error, and info --capture names the fallback
        cap = os.path.join(tmp, "capture_default")
        chans = oiio.ImageBuf(os.path.join(cap, "frame_0000.exr")).spec().channelnames
        check(not any(".Emit." in c for c in chans), "the default-pass capture has no Emit pass")
        dflt = {}
        for mode in ("off", "svgf"):
            out = os.path.join(tmp, "default_" + mode)
            subprocess.run([tandem, "denoise", "--quiet", "--captures", cap, "--map", mapping,
                            "--denoiser", mode, "--taa", "off", "--out", out], check=True,
                           stdout=subprocess.DEVNULL)
            e = subprocess.run([tandem, "eval", "--quiet", "--out", out, "--reference",
                                os.path.join(tmp, "converged"), "--json"], check=True,
                               stdout=subprocess.PIPE, text=True)
            dflt[mode] = (out, json.loads(e.stdout)[0])
        worst = 0.0
        for f in range(FRAMES):
            noisy = read(os.path.join(cap, "frame_%04d.exr" % f), rgb)
            off = read(os.path.join(dflt["off"][0], "frame_%04d.exr" % f))
            worst = max(worst, float((np.abs(off - noisy) / np.maximum(np.abs(noisy), 1e-3)).max()))
        check(worst <= 1e-5, "default passes: off equals Cycles' noisy Combined (max relative "
              "difference %.2e)" % worst)
        rn, rd = dflt["off"][1]["relmse"], dflt["svgf"][1]["relmse"]
        check(rd <= 0.5 * rn, "default passes: relMSE noisy %.4f, svgf %.4f (%.1fx lower)"
              % (rn, rd, rn / rd if rd > 0 else float("inf")))
        r = subprocess.run([tandem, "info", "--capture", cap, "--map", mapping, "--json"],
                           check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        em = json.loads(r.stdout)["entries"]["emission"]
        check(em["how"] == "fallback" and "filtered with their surroundings" in em["from"],
              "info --capture names the fallback: %s: %s" % (em["how"], em["from"][:60]))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("%d passed, %d failed" % (passed, failed))
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
