#!/usr/bin/env python3
"""Matched references and the denoiser's error told from the estimator's bias.

On closed_box.gltf (a closed box of albedo 0.7 lit by one ceiling panel, static camera): light
bounces many times there, so the real-time estimator (one indirect bounce by default) converges
far below the unbiased reference. Checks:
- `tandem reference --estimator realtime` is the estimator's expectation: the mean of 64 frames
  that `tandem render --denoiser off` makes (each with its own random numbers and jitter) agrees
  with it within their noise; Embree and Vulkan give the same image (the same random numbers);
- its distance to the unbiased reference is what the bounce count predicts for a closed box of
  albedo a: after the emitter, n bounces keep 1 - a^(n+1) of the light (0.51 at one bounce,
  0.96 at eight), within the box's openness to the directly seen emitter;
- --until-noise stops a frame early, below the target;
- `tandem eval --matched-reference M --reference U` reports the denoiser's error and the
  estimator's bias apart, and warns, with both figures, when a reference's own noise is not
  well below the error it measures.

usage: test_matched_reference.py TANDEM [--quick]   (--quick: the sanitizer build, where the
Embree references run some 30 times slower: the 16-frame references with 128 (matched) and 32
(unbiased: only the estimator's bias, over 0.05 relMSE, is read from it) samples instead of
256, the single-frame unbiased one with 256 instead of 512; the checks and their bounds are
the same, their margins stated where they use those counts)
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
SCENE = os.path.join(ROOT, "data", "scenes", "closed_box.gltf")
C = Checks(TANDEM)
check, run = C.check, C.run


def img(path):
    return oiio.ImageBuf(path).get_pixels(oiio.FLOAT)[:, :, :3].astype(np.float64)


tmp = tempfile.mkdtemp(prefix="tandem_matched_")
try:
    size = ["--size", "32x32", "--scene", SCENE, "--quiet"]
    run("reference", "--estimator", "realtime", "--frames", "1", "--spp", "512",
        "--out", f"{tmp}/m", *size)
    run("reference", "--estimator", "realtime", "--frontend", "vk", "--frames", "1",
        "--spp", "512", "--out", f"{tmp}/mv", *size)
    run("reference", "--frames", "1", "--spp", "256" if QUICK else "512", "--out", f"{tmp}/u",
        *size)
    m, mv, u = img(f"{tmp}/m/frame_0000.exr"), img(f"{tmp}/mv/frame_0000.exr"), \
        img(f"{tmp}/u/frame_0000.exr")
    d = np.max(np.abs(m - mv) / np.maximum(m, 1e-3))
    check("matched reference: Embree and Vulkan draw the same samples (float rounding apart)",
          d < 1e-5, f"largest relative difference {d:.2g}")

    # where the samples are composited: on the device (the Vulkan default: nothing of a sample
    # leaves the GPU; float sums per batch of 16) or on the host (every sample brought back and
    # composited by core/contract.c), on a scene with glass (its split fields interleaved) and
    # one whose cube moves, 2 frames each: the same sums within float rounding (the variance
    # E[Y^2] - E[Y]^2 relative to E[Y^2]: it cancels where the variance is small)
    worst = worst_var = 0.0
    lum = np.array([0.2126, 0.7152, 0.0722])
    for sc in ("materials", "dynamic"):
        for on in ("device", "host"):
            run("reference", "--estimator", "realtime", "--frontend", "vk", "--frames", "2",
                "--spp", "24", "--size", "40x24", "--composite-on", on, "--quiet", "--scene",
                os.path.join(ROOT, "data", "scenes", sc + ".gltf"), "--out", f"{tmp}/{sc}_{on}")
        for f in range(2):
            a, b = (oiio.ImageBuf(f"{tmp}/{sc}_{on}/frame_{f:04d}.exr").get_pixels(oiio.FLOAT)
                    .astype(np.float64) for on in ("device", "host"))
            worst = max(worst, np.max(np.abs(a - b)[..., :3] / np.maximum(np.abs(b[..., :3]), 1e-3)))
            m2 = b[..., 3] + (b[..., :3] @ lum) ** 2
            worst_var = max(worst_var, np.max(np.abs(a - b)[..., 3] / np.maximum(m2, 1e-6)))
    check("matched reference: composited on the device = on the host (RGB and variance, float "
          "rounding apart)", worst < 1e-5 and worst_var < 1e-5,
          f"largest relative difference {worst:.2g}, of the variance {worst_var:.2g} of E[Y^2]")

    # worth N samples: a plain average of one sample (a 1-spp matched reference: its first sample
    # is uniformly random) is worth 1 by relMSE, within the spread of a mean over 1024 pixels
    run("reference", "--estimator", "realtime", "--frames", "1", "--spp", "1",
        "--out", f"{tmp}/m1", *size)
    p = run("eval", "--out", f"{tmp}/m1", "--matched-reference", f"{tmp}/m", "--json")
    w = json.loads(p.stdout)[0]
    check("eval: a 1-sample average is worth 1 sample by relMSE (0.75 .. 1.33)",
          0.75 < w["worth_relmse"] < 1.33, f"worth {w['worth_relmse']:.3f} by relMSE, "
          f"{w['worth_flip']:.3f} by FLIP (modelled)")

    # the per-image metrics on the device (eval/metrics_gpu.c; lavapipe here) = the CPU's
    ms = {on: json.loads(run("eval", "--out", f"{tmp}/m1", "--matched-reference", f"{tmp}/m",
                             "--json", "--metrics-on", on).stdout)[0] for on in ("cpu", "device")}
    keys = ("relmse", "smape", "rmse", "psnr", "ssim", "flip", "worth_relmse")
    bad = [k for k in keys if abs(ms["cpu"][k] - ms["device"][k]) > 2e-4 * abs(ms["cpu"][k])]
    check("eval --metrics-on device = the CPU's (relMSE, SMAPE, RMSE, PSNR, SSIM, FLIP; 2e-4)",
          not bad, ", ".join(f"{k} {ms['cpu'][k]:.6g} / {ms['device'][k]:.6g}" for k in keys))

    # the estimator's own frames, averaged: frames differ in random numbers and Halton jitter
    run("render", "--denoiser", "off", "--frames", "64", "--out", f"{tmp}/rt", *size)
    frames = np.stack([img(f"{tmp}/rt/frame_{k:04d}.exr") for k in range(64)])
    avg = frames.mean(0)
    means = frames.mean(axis=(1, 2, 3))
    sigma = np.std(means, ddof=1) / np.sqrt(len(means))  # of the average's mean
    rs = json.load(open(f"{tmp}/m/reference.json"))["frames"][0]
    sigma_m = rs["rel_error"] * m.mean() / np.sqrt(m.size / 3)  # (pixels independent)
    diff = abs(avg.mean() - m.mean())
    check("matched reference = the mean of the estimator's own frames (within 4 sigma)",
          diff < 4 * np.hypot(sigma, sigma_m),
          f"means {avg.mean():.5f} and {m.mean():.5f}, sigma {np.hypot(sigma, sigma_m):.2g}")
    rel_m = np.mean((avg - m) ** 2 / (m ** 2 + 0.01))
    rel_u = np.mean((avg - u) ** 2 / (u ** 2 + 0.01))
    check("the frames' mean is far nearer the matched reference than the unbiased one",
          rel_m < rel_u / 10, f"relMSE {rel_m:.3g} against {rel_u:.3g}")

    ratio1 = m.mean() / u.mean()
    run("reference", "--estimator", "realtime", "--bounces", "8", "--frames", "1", "--spp",
        "256", "--out", f"{tmp}/m8", *size)
    ratio8 = img(f"{tmp}/m8/frame_0000.exr").mean() / u.mean()
    # 1 - a^2 = 0.51 and 1 - a^9 = 0.96 of the bounced light; the emitter seen directly and
    # the block's shadowing move it a little: bands around those
    check("estimator bias as the bounce count predicts: 1 bounce ~0.51, 8 bounces ~0.96",
          0.45 < ratio1 < 0.70 and 0.90 < ratio8 < 1.02, f"{ratio1:.3f}, {ratio8:.3f}")

    run("reference", "--estimator", "realtime", "--frames", "2", "--spp", "1024",
        "--until-noise", "0.05", "--out", f"{tmp}/mu", *size)
    fr = json.load(open(f"{tmp}/mu/reference.json"))["frames"]
    check("--until-noise stops each frame early, below the target, at a multiple of 16",
          all(f["spp"] < 1024 and f["spp"] % 16 == 0 and f["rel_error"] < 0.05 for f in fr),
          ", ".join(f"frame {f['frame']}: {f['spp']} spp, {f['rel_error']:.4f}" for f in fr))

    # eval: 16 frames of svgf against both references
    size16 = ["--size", "32x32", "--scene", SCENE, "--quiet", "--frames", "16"]
    run("render", "--denoiser", "svgf", "--capture", "--out", f"{tmp}/run", *size16)
    run("reference", "--estimator", "realtime", "--spp", "128" if QUICK else "256", "--out",
        f"{tmp}/m16", *size16)
    run("reference", "--spp", "32" if QUICK else "256", "--out", f"{tmp}/u16", *size16)
    p = run("eval", "--out", f"{tmp}/run", "--matched-reference", f"{tmp}/m16", "--reference",
            f"{tmp}/u16", "--json")
    s = {x["role"]: x for x in json.loads(p.stdout)}
    ok = set(s) == {"denoiser error", "noisy input", "accumulation alone", "estimator bias"}
    ok = ok and s["denoiser error"]["relmse"] < s["noisy input"]["relmse"] / 4
    ok = ok and s["estimator bias"]["relmse"] > 0.05 and s["estimator bias"]["against"].endswith("u16")
    check("eval: the denoiser's error (against matched) apart from the estimator's bias",
          ok, ", ".join(f"{k} relMSE {v['relmse']:.4g}" for k, v in s.items()))
    mj = json.load(open(f"{tmp}/run/metrics.json"))
    names = [x["name"] for x in mj["series"]]
    check("metrics.json holds the four series and says which reference each is against",
          len(names) == 4 and mj["settings"]["denoiser_error_against"].endswith("m16") and
          mj["settings"]["estimator_bias_against"].endswith("u16"), str(names))
    # accumulation alone: the running mean of the noisy composites on this still camera. Its
    # error falls as 1/n (frame n averages n + 1 independent frames), so frame 15's relMSE is
    # 1/16 of frame 0's, within the frames' noise (a relMSE over 1024 pixels of 1 spp: +-30%
    # seen between single frames; bounds 1/32 .. 1/8) and the reference's own noise (1/256 of
    # a noisy frame's at 256 spp, under 2% of frame 15's; 1/128 under --quick, which adds 12%
    # to frame 15's and moves the expected ratio to 1/14.3); the verdict in metrics.json.
    acc = next(x for x in mj["series"] if x["name"] == "accumulation alone")["frames"]
    r0, r15 = acc[0]["relmse"], acc[15]["relmse"]
    conv = mj["settings"]["convergence"]
    check("eval: accumulation alone falls as 1/n on a still camera; the convergence verdict",
          1 / 32 < r15 / r0 < 1 / 8 and conv["still"] and conv["accumulation_restarts"] == 0 and
          conv["at_or_below_accumulation"] and "nothing moves" in
          run("eval", "--out", f"{tmp}/run", "--matched-reference", f"{tmp}/m16").stdout,
          f"relMSE frame 0 {r0:.4g}, frame 15 {r15:.4g} (ratio 1/{r0 / r15:.1f}); {conv}")
    run("reference", "--estimator", "realtime", "--spp", "2", "--out", f"{tmp}/m2", *size16)
    p = run("eval", "--out", f"{tmp}/run", "--matched-reference", f"{tmp}/m2")
    check("eval warns when the reference's own noise is not well below the error (both figures)",
          "own noise (relMSE" in p.stderr and "the rule: under 10%" in p.stderr, p.stderr.strip())
    p = run("eval", "--out", f"{tmp}/run", "--matched-reference", f"{tmp}/m16", "--reference",
            f"{tmp}/u", expect=None)
    check("eval with references of other frames exits 1 naming both",
          p.returncode == 1 and "m16" in p.stderr and f"{tmp}/u " in p.stderr + " ",
          p.stderr.strip())
finally:
    shutil.rmtree(tmp, ignore_errors=True)

C.finish()
