#!/usr/bin/env python3
"""Sharded references: `tandem reference --shard I/N` on parts of the work, `tandem merge` back.

The random numbers of a reference sample are keyed by (pixel, frame, sample index), so shards
draw exactly the samples one run draws. A shard keeps per-pixel sums in double; merge adds the
shards' sums in the order of their samples. One run adds sample after sample (Embree, the
matched reference) or 16-sample float batches from the GPU (Vulkan), also in double: the two
differ only in how the double additions associate, a relative 2 (N - 1) 2^-53 at most for N
samples, far below float32's 2^-24, so a merged frame equals one run's within 1 ulp of float32
per channel (and bit for bit unless a mean falls that close to a rounding boundary: here every
file is identical, which the test reports). Checks:
- both front-ends and both estimators: 2 frames in 3 shards (one frame split between two
  shards) merge to what one run writes: frames within 1 ulp, motion, PNG and reference.json
  (but for its sampling times: a merge measures none);
- one frame split into 4 sample ranges; 4 frames in 2 shards with --until-noise; the order the
  shards are given in does not matter; --env takes part in the scene digest;
- merge refuses a missing shard (a gap), a shard given twice (an overlap), shards of another
  scene, size or sample count, a truncated sums file and a directory that is no shard, each
  with a message naming it, exit 1, and no output directory left behind; reference refuses
  --shard N/N, more shards than 16-sample batches, and --until-noise on split frames (exit 2).

usage: test_shards.py TANDEM
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
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
SCENES = os.path.join(ROOT, "data", "scenes")
ENV = "/usr/share/blender/datafiles/studiolights/world/forest.exr"
C = Checks(TANDEM)
check, run = C.check, C.run
TMP = tempfile.mkdtemp(prefix="tandem_shards_")


def img(path):
    return oiio.ImageBuf(path).get_pixels(oiio.FLOAT)


def untimed(j):
    """reference.json without its sampling times (seconds, paths_per_s)"""
    if isinstance(j, dict):
        return {k: untimed(v) for k, v in j.items() if k not in ("seconds", "paths_per_s")}
    if isinstance(j, list):
        return [untimed(v) for v in j]
    return j


def compare_dirs(a, b):
    """(same file names, frames within 1 ulp, other files identical, values that differ)"""
    fa, fb = sorted(os.listdir(a)), sorted(os.listdir(b))
    if fa != fb:
        return False, False, False, f"files {fa} vs {fb}"
    within, identical, differing = True, True, 0
    for name in fa:
        pa, pb = os.path.join(a, name), os.path.join(b, name)
        with open(pa, "rb") as x, open(pb, "rb") as y:
            same = x.read() == y.read()
        if same:
            continue
        if name == "reference.json":  # the same but for the times (a merge measures none)
            ja, jb = (untimed(json.load(open(p))) for p in (pa, pb))
            identical = identical and ja == jb
        elif name.endswith(".exr") and not name.endswith(".motion.exr"):
            va, vb = img(pa), img(pb)
            ulp = np.spacing(np.maximum(np.abs(va), np.abs(vb)).astype(np.float32))
            within = within and bool(np.all(np.abs(va - vb) <= ulp))
            differing += int(np.count_nonzero(va != vb))
        else:
            identical = False
    return True, within, identical, differing


def reference(out, *args, expect=0):
    return run("reference", "--quiet", "--size", "40x24", "--out", out, *args, expect=expect)


def shards_and_merge(name, n, args, order=None):
    dirs = [os.path.join(TMP, f"{name}_s{i}") for i in range(n)]
    for i, d in enumerate(dirs):
        reference(d, *args, "--shard", f"{i}/{n}")
    merged = os.path.join(TMP, f"{name}_merged")
    run("merge", "--quiet", *[dirs[i] for i in (order or range(n))], "--out", merged)
    return dirs, merged


def equal_to_single(name, n, args, order=None):
    single = os.path.join(TMP, f"{name}_single")
    reference(single, *args)
    dirs, merged = shards_and_merge(name, n, args, order)
    same_names, within, identical, differing = compare_dirs(single, merged)
    check(f"{name}: {n} shards merged = one run (frames within 1 ulp, other files identical)",
          same_names and within and identical, f"{differing} float values differ by 1 ulp")
    return dirs


try:
    cornell = os.path.join(SCENES, "cornell.gltf")
    dynamic = os.path.join(SCENES, "dynamic.gltf")
    for fe in ("embree", "vk"):
        for est in ("unbiased", "realtime"):
            equal_to_single(f"{fe}_{est}", 3, ["--scene", dynamic, "--frontend", fe,
                                               "--estimator", est, "--frames", "2",
                                               "--spp", "40"])
    one = ["--scene", cornell, "--frames", "1", "--start", "5", "--spp", "64"]
    dirs = equal_to_single("one_frame", 4, one)
    parts = [json.load(open(os.path.join(d, "shard.json")))["parts"] for d in dirs]
    check("one frame in 4 shards: sample ranges [0,16) [16,32) [32,48) [48,64)",
          [(p[0]["first"], p[0]["count"]) for p in parts] == [(0, 16), (16, 16), (32, 16),
                                                              (48, 16)], str(parts))
    equal_to_single("until_noise", 2, ["--scene", cornell, "--frames", "4", "--spp", "256",
                                       "--until-noise", "0.2"])
    equal_to_single("order", 3, ["--scene", dynamic, "--frames", "2", "--spp", "32"],
                    order=[2, 0, 1])
    if os.path.exists(ENV):
        equal_to_single("env", 2, ["--scene", cornell, "--frames", "2", "--spp", "16",
                                   "--env", ENV])

    # refusals: merge
    base = ["--scene", dynamic, "--frames", "2", "--spp", "40"]
    s = [os.path.join(TMP, f"bad_s{i}") for i in range(3)]
    for i, d in enumerate(s):
        reference(d, *base, "--shard", f"{i}/3")

    def refused(name, dirs, needle):
        out = os.path.join(TMP, "refused_out")
        p = run("merge", *dirs, "--out", out, expect=None)
        check(f"merge refuses {name}", p.returncode == 1 and needle in p.stderr and
              not os.path.exists(out), p.stderr.strip())

    refused("a missing shard (a gap)", [s[0], s[2]], "samples [32, 40) are in no shard")
    refused("a shard given twice (an overlap)", [s[0], s[1], s[1], s[2]], "are in two shards")
    other = os.path.join(TMP, "other_scene")
    reference(other, "--scene", cornell, "--frames", "2", "--spp", "40", "--shard", "1/3")
    refused("another scene's shard", [s[0], other, s[2]], "scene_digest")
    other_env = os.path.join(TMP, "other_env")
    if os.path.exists(ENV):
        reference(other_env, *base, "--env", ENV, "--shard", "1/3")
        refused("a shard under another environment", [s[0], other_env, s[2]], "scene_digest")
    other_size = os.path.join(TMP, "other_size")
    run("reference", "--quiet", "--size", "32x24", "--out", other_size, *base, "--shard", "1/3")
    refused("another size's shard", [s[0], other_size, s[2]], "width")
    other_spp = os.path.join(TMP, "other_spp")
    reference(other_spp, "--scene", dynamic, "--frames", "2", "--spp", "48", "--shard", "1/3")
    refused("another sample count's shard", [s[0], other_spp, s[2]], "spp")
    cut = os.path.join(TMP, "cut")
    shutil.copytree(s[1], cut)
    with open(os.path.join(cut, "frame_0001.sums"), "r+b") as f:
        f.truncate(1000)
    refused("a truncated sums file", [s[0], cut, s[2]], "frame_0001.sums: truncated")
    refused("a directory that is no shard", [s[0], SCENES, s[2]], "not a reference shard")
    # refusals: reference
    for name, args, needle in (
            ("--shard 3/3", ["--shard", "3/3"], "0 <= I < N"),
            ("more shards than batches", ["--frames", "1", "--spp", "32", "--shard", "0/3"],
             "no more shards than that"),
            ("--until-noise on split frames", ["--frames", "1", "--spp", "32", "--shard", "0/2",
                                               "--until-noise", "0.1"], "samples are split")):
        out = os.path.join(TMP, "refused_ref")
        p = reference(out, *args, expect=None)
        check(f"reference refuses {name}", p.returncode == 2 and needle in p.stderr and
              not os.path.exists(out), p.stderr.strip())
finally:
    shutil.rmtree(TMP, ignore_errors=True)
C.finish()
