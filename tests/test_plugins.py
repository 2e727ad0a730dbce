#!/usr/bin/env python3
"""tests/test_plugins.py TANDEM SPHERES.so ACCUMULATE.so BROKEN.so: plugins from shared objects
(include/tandem/tandem_plugin.h) through the command line.

- The accumulate denoiser plugin on a still camera is the running mean of the noisy radiance:
  render --frontend vk --denoiser plugin:accumulate.so --taa off against the mean of the frames
  of --denoiser off --taa off (the radiance it reads), pixel by pixel.
- The spheres front-end plugin through render (svgf, and the accumulate plugin), compare (the
  two runs' captures agree everywhere: one front-end), reference --estimator realtime and eval
  (both denoisers well below the noisy input's error against the matched reference).
- compare --scene with the denoiser plugin: Embree and Vulkan through it, evaluated.
- denoise of a capture with the denoiser plugin equals render with it (the same radiance).
- Bad plugins: a missing file, a file that is no shared object, a library that is no plugin, a
  plugin that refuses the ABI, another ABI version, a truncated description, the wrong kind, a
  front-end without a required entry, a failing create and a failing frame: exit 1, the path
  and the problem in the message, no output directory.
Checked with the validation layer on (the test's environment): any error fails a run.
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

from tandem_cli import Checks

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(os.path.dirname(HERE), "data", "scenes")


def read_rgb(path):
    img = oiio.ImageInput.open(path)
    if img is None:
        sys.exit(f"cannot read {path}: {oiio.geterror()}")
    px = img.read_image(format="float")
    img.close()
    return np.asarray(px, dtype=np.float64)[:, :, :3]


def main():
    tandem, spheres, accumulate, broken, host_copy = sys.argv[1:6]
    c = Checks(tandem)
    tmp = tempfile.mkdtemp(prefix="tandem_plugins_")
    try:
        run_checks(c, tmp, spheres, accumulate, broken)
        host_checks(c, tmp, host_copy)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    c.finish()


def run_checks(c, tmp, spheres, accumulate, broken):
    cornell = os.path.join(SCENES, "cornell.gltf")
    dynamic = os.path.join(SCENES, "dynamic.gltf")

    # 1. accumulate = the running mean of the noisy radiance on a still camera. Nothing moves in
    # closed_box.gltf and the jitter does not enter the motion vectors (0 there, exactly), so
    # the reprojection is the identity: every pixel is the mean of the frames since its history
    # last restarted. It restarts where the depth at this frame's jittered position differs by
    # more than the plugin's 2% from the last one (the walls seen at grazing angles, at 48x48);
    # elsewhere the mean is over every frame.
    n = 6
    common = ["--scene", os.path.join(SCENES, "closed_box.gltf"), "--frontend", "vk", "--frames",
              str(n), "--size", "48x48", "--taa", "off", "--quiet"]
    noisy, acc = os.path.join(tmp, "noisy"), os.path.join(tmp, "acc")
    c.run("render", *common, "--denoiser", "off", "--out", noisy)
    c.run("render", *common, "--denoiser", f"plugin:{accumulate}", "--out", acc)
    frames = np.array([read_rgb(os.path.join(noisy, f"frame_{i:04d}.exr")) for i in range(n)])
    got = read_rgb(os.path.join(acc, f"frame_{n - 1:04d}.exr"))
    some, every = np.zeros(got.shape[:2], bool), None
    for k in range(1, n + 1):  # the mean of the last k frames
        mean = frames[n - k:].mean(axis=0)
        # float32 running mean against a float64 mean: a few ulps per step
        close = np.all(np.abs(got - mean) <= 1e-5 * np.maximum(np.abs(mean), 1e-3), axis=2)
        some |= close
        every = close
    c.check("accumulate: every pixel the running mean of the noisy radiance since a restart",
            some.all(), f"{100 * some.mean():.1f}% of pixels within 1e-5")
    c.check("accumulate: most pixels the mean over every frame (measured 71%)",
            every.mean() >= 0.6, f"{100 * every.mean():.1f}%")
    with open(os.path.join(acc, "timings.json")) as fp:
        t = json.load(fp)
    c.check("timings.json: the plugin's GPU time per frame",
            all(f.get("denoiser_plugin_ms", -1) >= 0 for f in t["frames"]) and
            t["denoiser"] == f"plugin:{accumulate}")

    # 2. the spheres front-end: two runs (svgf; the accumulate plugin) with captures
    f = 8
    sp = ["--scene", dynamic, "--frontend", f"plugin:{spheres}", "--frames", str(f), "--size",
          "64x40", "--quiet"]
    run_a, run_b = os.path.join(tmp, "sph_svgf"), os.path.join(tmp, "sph_acc")
    pa = c.run("render", *sp, "--denoiser", "asvgf", "--capture", "--out", run_a, "--quiet")
    c.check("asvgf on a front-end that cannot re-shade runs svgf",
            json.load(open(os.path.join(run_a, "run.json")))["denoiser"] == "svgf")
    c.run("render", *sp, "--denoiser", f"plugin:{accumulate}", "--capture", "--out", run_b)
    run = json.load(open(os.path.join(run_b, "run.json")))
    c.check("run.json names both plugins", run["frontend"] == f"plugin:{spheres}" and
            run["denoiser"] == f"plugin:{accumulate}")
    img = read_rgb(os.path.join(run_b, f"frame_{f - 1:04d}.exr"))
    c.check("the spheres are lit (mean radiance above the sky's floor)",
            np.isfinite(img).all() and img.mean() > 0.05, f"mean {img.mean():.4f}")
    p = c.run("compare", run_a, run_b, "--json")
    cmp = json.loads(p.stdout)
    # (every agreement fraction; edge_ties is the share of pixels that hit two triangles of one
    # object at the same point, 0 for one front-end against itself)
    fractions = [v for fr in cmp["frames"] for k, v in fr.items() if k not in ("frame", "edge_ties")]
    fractions += [1.0 - fr["edge_ties"] for fr in cmp["frames"]]
    c.check("compare: the two runs' captures agree everywhere (one front-end)",
            len(cmp["frames"]) == f and min(fractions) == 1.0, f"min {min(fractions)}")
    matched = os.path.join(tmp, "sph_matched")
    c.run("reference", "--estimator", "realtime", *sp, "--spp", "128", "--out", matched)
    errs = {}
    for name, d in (("svgf", run_a), ("accumulate", run_b)):
        p = c.run("eval", "--out", d, "--matched-reference", matched, "--json", "--quiet")
        s = {e["role"]: e for e in json.loads(p.stdout)}
        errs[name] = (s["denoiser error"]["relmse"], s["noisy input"]["relmse"])
    # measured on lavapipe: svgf 0.031, accumulate 0.065, noisy 0.248 (8 frames; the moving
    # camera keeps accumulate's windows short): half the input's error is a loose floor
    for name, (dn, noisy_err) in errs.items():
        c.check(f"eval: {name} on the spheres plugin below half the noisy input's relMSE",
                dn < 0.5 * noisy_err, f"{dn:.4f} vs {noisy_err:.4f}")

    # 3. denoise with the plugin = render with it (the capture holds the radiance's inputs)
    den = os.path.join(tmp, "sph_denoise")
    c.run("denoise", "--captures", run_b, "--denoiser", f"plugin:{accumulate}", "--out", den,
          "--quiet")
    same = all(np.array_equal(read_rgb(os.path.join(den, f"frame_{i:04d}.exr")),
                              read_rgb(os.path.join(run_b, f"frame_{i:04d}.exr")))
               for i in range(f))
    c.check("denoise --denoiser plugin: equals render with it, bit for bit", same)

    # 4. compare --scene: both of Tandem's front-ends through the denoiser plugin, against one
    # reference (the two front-ends trace the same paths: their figures agree to float noise)
    cdir = os.path.join(tmp, "compare")
    p = c.run("compare", "--scene", cornell, "--out", cdir, "--frames", "3", "--size", "48x32",
              "--spp", "16", "--denoiser", f"plugin:{accumulate}", "--json", "--quiet")
    cj = json.loads(p.stdout)
    ev = {e["name"]: e["relmse"] for e in cj["eval"]}
    c.check("compare --scene --denoiser plugin: both front-ends agree and are evaluated",
            cj["pass"] and set(ev) == {"embree", "vk"} and
            abs(ev["embree"] - ev["vk"]) <= 1e-3 * ev["vk"], str(ev))

    # 5. bad plugins: exit 1, the problem named, nothing written
    notes = os.path.join(tmp, "notes.txt")
    with open(notes, "w") as fp:
        fp.write("not a shared object\n")
    libm = "/usr/lib/x86_64-linux-gnu/libm.so.6"
    cases = [
        ("missing file", "frontend", os.path.join(tmp, "none.so"), None, "cannot load"),
        ("not a shared object", "frontend", notes, None, "cannot load"),
        ("a library that is no plugin", "denoiser", libm, None, "not a Tandem plugin"),
        ("refuses the ABI", "frontend", broken, "refuse", "does not speak plugin ABI version 1"),
        ("another ABI version", "frontend", broken, "abi", "built for ABI version 99"),
        ("truncated description", "frontend", broken, "small", "struct_size 8"),
        ("wrong kind", "frontend", broken, "kind", "a denoiser, not a front-end"),
        ("front-end for a denoiser", "denoiser", spheres, None, "a front-end, not a denoiser"),
        ("no required entry", "frontend", broken, "no_hf", "required entry 'hf'"),
        ("create fails", "frontend", broken, "create", "asked to fail"),
        ("a frame fails", "frontend", broken, "render", "frame 2 is where"),
    ]
    for name, role, path, mode, expect in cases:
        out = os.path.join(tmp, "bad")
        env = dict(os.environ)
        env.pop("TANDEM_TEST_BROKEN", None)
        if mode:
            env["TANDEM_TEST_BROKEN"] = mode
        args = ["render", "--scene", cornell, "--frames", "4", "--size", "32x32", "--out", out]
        args += (["--frontend", f"plugin:{path}", "--denoiser", "svgf"] if role == "frontend"
                 else ["--frontend", "vk", "--denoiser", f"plugin:{path}"])
        p = subprocess.run([c.tandem, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           text=True, env=env)
        c.check(f"bad plugin, {name}: exit 1, message, no output",
                p.returncode == 1 and expect in p.stderr and path in p.stderr and
                not os.path.exists(out),
                f"exit {p.returncode}: {p.stderr.strip()[-200:]}")
        shutil.rmtree(out, ignore_errors=True)
    # working plugins load fine through the same path (the broken one unbroken)
    env_ok = os.path.join(tmp, "broken_ok")
    c.run("render", "--scene", cornell, "--frontend", f"plugin:{broken}", "--denoiser", "off",
          "--frames", "2", "--size", "16x16", "--out", env_ok, "--quiet")
    c.check("the broken plugin with nothing broken renders", os.path.exists(
        os.path.join(env_ok, "frame_0001.exr")))


def host_checks(c, tmp, host_copy):
    """A host denoiser plugin that returns the noisy radiance: the frames of `--denoiser off`,
    bit for bit, behind both front-ends (the contract and radiance to the host and back); a
    failing frame: exit 1, its message, no output."""
    cornell = os.path.join(SCENES, "cornell.gltf")
    # (behind Embree, --denoiser off composites on the CPU and runs no post chain: TAA off on
    # both, the GPU's composite against the CPU's within float rounding)
    for fe, taa in (("vk", "on"), ("embree", "off")):
        outs = {}
        for dn in ("off", f"plugin:{host_copy}"):
            outs[dn] = os.path.join(tmp, f"host_{fe}_{'off' if dn == 'off' else 'copy'}")
            c.run("render", "--scene", cornell, "--frontend", fe, "--denoiser", dn, "--taa", taa,
                  "--frames", "3", "--size", "40x24", "--out", outs[dn], "--quiet")
        a, b = outs.values()
        diff = max(float(np.max(np.abs(read_rgb(os.path.join(a, f"frame_{i:04d}.exr")) -
                                       read_rgb(os.path.join(b, f"frame_{i:04d}.exr"))) /
                                (np.abs(read_rgb(os.path.join(a, f"frame_{i:04d}.exr"))) + 1e-3)))
                   for i in range(3))
        c.check(f"host denoiser plugin behind {fe}: the noisy radiance through the host equals "
                f"--denoiser off {'bit for bit' if fe == 'vk' else 'within 1e-5'}",
                diff == 0 if fe == "vk" else diff <= 1e-5, f"largest relative difference {diff:.3g}")
    out = os.path.join(tmp, "host_fail")
    p = subprocess.run([c.tandem, "render", "--scene", cornell, "--frontend", "embree",
                        "--denoiser", f"plugin:{host_copy}", "--frames", "3", "--size", "16x16",
                        "--out", out], capture_output=True, text=True,
                       env=dict(os.environ, TANDEM_TEST_HOST="fail"))
    c.check("host denoiser plugin: a failing frame exits 1 with its message, no output",
            p.returncode == 1 and "host_copy fails at frame 1" in p.stderr and
            not os.path.exists(out), p.stderr[-300:])


if __name__ == "__main__":
    main()
