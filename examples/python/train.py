#!/usr/bin/python3
"""Train temporal_denoiser.py on `tandem dataset` frames, on the CPU, then rank it by `tandem
eval` against svgf and asvgf on sequences it never saw (docs/python.md has the figures).

    PYTHONPATH=build/python /usr/bin/python3 examples/python/train.py --out out/learned

Steps, each skipped when its output exists (--fresh redoes them): the training set
(OUT/data: tandem dataset, .npz), the training (OUT/temporal_denoiser.pt, --minutes of it), and
per held-out sequence the matched reference and a run of each denoiser through `tandem render`,
evaluated with `tandem eval --matched-reference` (OUT/eval/NAME/DENOISER/metrics.json); the
table goes to OUT/results.json and standard output.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import torch

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import temporal_denoiser as td  # noqa: E402

import tandem  # noqa: E402

SCENES = os.path.join(SRC, "data", "scenes")
ENGINE = "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"
TRAIN = [
    {"name": "cornell_orbit", "scene": os.path.join(SCENES, "cornell.gltf"), "camera_path": "orbit",
     "path_duration": 4},
    {"name": "closed_box_dolly", "scene": os.path.join(SCENES, "closed_box.gltf"),
     "camera_path": "dolly", "path_duration": 3},
    {"name": "materials_orbit", "scene": os.path.join(SCENES, "materials.gltf"),
     "camera_path": "orbit", "path_duration": 5},
    {"name": "sun_flythrough", "scene": os.path.join(SCENES, "sun.gltf"),
     "camera_path": "flythrough", "path_duration": 6},
    {"name": "cutout_still", "scene": os.path.join(SCENES, "cutout.gltf")},
]
# never trained on: a real asset (Khronos' 2CylinderEngine from Debian's assimp-testmodels)
# orbiting, and Tandem's animated scene on its own camera
HELD_OUT = [
    {"name": "engine_orbit", "scene": ENGINE, "camera_path": "orbit", "path_duration": 6},
    {"name": "dynamic", "scene": os.path.join(SCENES, "dynamic.gltf")},
]
DENOISERS = ["svgf", "asvgf", "python:temporal_denoiser:Denoiser"]


def tensors(frames):
    """A sequence's frames as tensors (T, C, H, W)."""
    t = lambda k: torch.from_numpy(np.stack([f[k] for f in frames]).astype(np.float32)).permute(0, 3, 1, 2)
    return {k: t(k) for k in ("noisy", "albedo", "normal", "depth", "motion", "matched")}


def loss_of(out, ref):
    # L1 of log radiance: relative error, robust to the fireflies a matched reference keeps
    return torch.mean(torch.abs(torch.log1p(out.clamp(min=0)) - torch.log1p(ref)))


def train(data_dir, minutes, seed, weights):
    frames = tandem.load_dataset(data_dir)
    seqs = {}
    for f in frames:
        seqs.setdefault(f["sequence"], []).append(f)
    seqs = [tensors(v) for _, v in sorted(seqs.items())]
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    net = td.Net()
    nparams = sum(p.numel() for p in net.parameters())
    opt = torch.optim.Adam(net.parameters(), lr=3e-3)
    T, CROP, BATCH = 6, 48, 4
    t0, it, curve = time.time(), 0, []
    while time.time() - t0 < 60 * minutes:
        batch = {k: [] for k in seqs[0]}
        for _ in range(BATCH):
            s = seqs[rng.integers(len(seqs))]
            n, _, h, w = s["noisy"].shape
            t = rng.integers(0, n - T + 1)
            y, x = rng.integers(0, h - CROP + 1), rng.integers(0, w - CROP + 1)
            for k in batch:
                batch[k].append(s[k][t:t + T, :, y:y + CROP, x:x + CROP])
        b = {k: torch.stack(v, 1) for k, v in batch.items()}  # (T, B, C, H, W)
        prev = prev_depth = None
        loss = 0
        for k in range(T):
            out = td.step(net, b["noisy"][k], b["albedo"][k], b["normal"][k], b["depth"][k],
                          b["motion"][k], prev, prev_depth)
            loss = loss + loss_of(out, b["matched"][k]) / T
            prev, prev_depth = out, b["depth"][k]
        opt.zero_grad()
        loss.backward()
        opt.step()
        it += 1
        if it % 50 == 0:
            curve.append((it, round(time.time() - t0, 1), float(loss)))
            print("train: iteration %d, %.0f s, loss %.4f" % curve[-1], flush=True)
    torch.save(net.state_dict(), weights)
    return {"parameters": nparams, "iterations": it, "seconds": round(time.time() - t0, 1),
            "curve": curve}


def run(tandem_bin, *args, env=None):
    subprocess.run([tandem_bin, *args, "--quiet"], check=True, env=env)


def evaluate(tandem_bin, out, size, frames, spp, weights):
    env = dict(os.environ, TANDEM_EXAMPLE_WEIGHTS=weights,
               PYTHONPATH=HERE + os.pathsep + os.environ.get("PYTHONPATH", ""))
    results = {}
    for seq in HELD_OUT:
        opts = ["--scene", seq["scene"], "--size", "%dx%d" % size, "--frames", str(frames),
                "--frontend", "embree"]
        for k in ("camera_path", "path_duration"):
            if k in seq:
                opts += ["--" + k.replace("_", "-"), str(seq[k])]
        ref = os.path.join(out, "eval", seq["name"], "reference")
        if not os.path.exists(os.path.join(ref, "reference.json")):
            run(tandem_bin, "reference", *opts, "--estimator", "realtime", "--spp", str(spp),
                "--out", ref)
        results[seq["name"]] = {}
        for dn in DENOISERS:
            name = dn.split(":")[-1] if dn.startswith("python:") else dn
            d = os.path.join(out, "eval", seq["name"], name)
            t0 = time.time()
            run(tandem_bin, "render", *opts, "--denoiser", dn, "--out", d, env=env)
            wall = time.time() - t0
            m = tandem.evaluate(d, matched_reference=ref, metrics_on="cpu")
            s = m["series"][0]["summary"]
            timings = json.load(open(os.path.join(d, "timings.json")))
            # the denoiser's own passes (the front-end's and the post chain's are the same for all)
            keys = (["composite_ms", "denoiser_host_ms"] if dn.startswith("python:") else
                    [p["key"] for p in tandem.denoisers()[dn]["passes"]])
            ms = [sum(f.get(k, 0) for k in keys) for f in timings["frames"][1:]]
            results[seq["name"]][name] = {
                "relmse": s["relmse"], "flip": s["flip"], "ssim": s["ssim"],
                "temporal": s.get("temporal"), "frame_ms": float(np.median(ms)) if ms else None,
                "render_s": round(wall, 1)}
    return results


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(SRC, "out", "learned"))
    ap.add_argument("--tandem", default=os.path.join(SRC, "build", "tandem"))
    ap.add_argument("--minutes", type=float, default=4.0, help="training time (default 4)")
    ap.add_argument("--size", default="128x72", help="training frames (default 128x72)")
    ap.add_argument("--frames", type=int, default=24, help="frames per training sequence")
    ap.add_argument("--spp", type=int, default=256, help="matched reference samples")
    ap.add_argument("--eval-size", default="160x96")
    ap.add_argument("--eval-frames", type=int, default=32)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--fresh", action="store_true", help="redo every step")
    a = ap.parse_args()
    if a.fresh and os.path.isdir(a.out):
        shutil.rmtree(a.out)
    os.makedirs(a.out, exist_ok=True)
    data = os.path.join(a.out, "data")
    report = {}
    if not os.path.exists(os.path.join(data, "manifest.json")):
        w, h = (int(v) for v in a.size.split("x"))
        t0 = time.time()
        tandem.dataset({"size": [w, h], "frames": a.frames, "spp": a.spp, "format": "npz",
                        "frontend": "embree", "sequences": TRAIN}, data)
        report["dataset_s"] = round(time.time() - t0, 1)
        print("dataset: %d sequences x %d frames in %.0f s" % (len(TRAIN), a.frames,
                                                              report["dataset_s"]))
    weights = os.path.join(a.out, "temporal_denoiser.pt")
    if not os.path.exists(weights):
        report["training"] = train(data, a.minutes, a.seed, weights)
        print("training: %(parameters)d parameters, %(iterations)d iterations in %(seconds).0f s"
              % report["training"])
    ew, eh = (int(v) for v in a.eval_size.split("x"))
    report["held_out"] = evaluate(a.tandem, a.out, (ew, eh), a.eval_frames, a.spp, weights)
    old = os.path.join(a.out, "results.json")
    if os.path.exists(old):
        report = {**json.load(open(old)), **report}
    json.dump(report, open(old, "w"), indent=1)
    print("\nheld-out sequences, against the matched reference (%d spp), %s, %d frames:"
          % (a.spp, a.eval_size, a.eval_frames))
    print("%-16s %-18s %9s %7s %7s %9s %9s" % ("sequence", "denoiser", "relMSE", "FLIP", "SSIM",
                                               "temporal", "ms/frame"))
    for seq, r in report["held_out"].items():
        for dn, m in r.items():
            print("%-16s %-18s %9.5f %7.4f %7.4f %9.5f %9.2f" % (
                seq, dn, m["relmse"], m["flip"], m["ssim"], m["temporal"] or 0, m["frame_ms"] or 0))


if __name__ == "__main__":
    main()
