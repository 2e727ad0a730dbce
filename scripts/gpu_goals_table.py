#!/usr/bin/env python3
"""Summarise scripts/gpu-goals.sh's JSON files as the goal table of docs/performance.md.

    scripts/gpu_goals_table.py OUT

Whole frames: wall ms per frame, frames not waited for (the re-shading folded into the shading
pass, and in a launch of its own), their ratio, and the GPU ms of the shading pass and of the
frame's timed passes; the any-hit's share of atrium's shading pass (against --opaque). Back-ends:
GPU ms against the bandwidth floor of bench --denoiser."""
import json
import os
import sys

GOALS = {  # whole frame, wall ms not waited for (issue 44)
    "cornell": 2.0,
    "cornell_4k": 7.0,
    "materials": 4.0,
    "atrium": 5.0,
    "engine": 2.5,
    "level": 5.0,
}
FLOOR_GOAL = 0.70  # the back-end at >= 70% of its bandwidth floor
ANYHIT_GOAL = 0.15  # the any-hit under 15% of atrium's shading pass


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"gpu_goals_table: {path}: {e}")


def main(argv):
    if len(argv) != 2 or not os.path.isdir(argv[1]):
        sys.exit("usage: gpu_goals_table.py OUT (the folder scripts/gpu-goals.sh wrote)")
    out = argv[1]
    names = sorted(n for n in os.listdir(out) if n.endswith(".json"))
    if not names:
        sys.exit(f"gpu_goals_table: {out}: no JSON files")
    print("| scene | bounces | size | wall folded | wall separate | separate / folded | "
          "shade GPU | frame GPU | goal |")
    print("|---|---|---|---|---|---|---|---|---|")
    order = list(GOALS)
    frames = []
    for n in names:
        if n.startswith("frame_"):
            scene, bounces = n[len("frame_"):-len(".json")].rsplit("_", 1)
            rank = order.index(scene) if scene in order else len(order)
            frames.append((rank, scene, bounces != "1", bounces, n))
    for _, scene, _, bounces, n in sorted(frames):
        j = load(os.path.join(out, n))
        folded = j.get("gpu_contract_no_wait")
        sep = j.get("gpu_contract_no_wait_separate_reshade")
        g = j.get("gpu_ms", {})
        goal = GOALS.get(scene)
        met = "" if goal is None or folded is None else (
            f"{goal:g}: {'met' if folded <= goal else 'missed'}")
        fmt = lambda v: "" if v is None else f"{v:.3f}"
        ratio = "" if folded is None or sep is None else f"{sep / folded:.3f}"
        print(f"| {scene} | {bounces} | {j.get('width')}x{j.get('height')} | {fmt(folded)} | "
              f"{fmt(sep)} | {ratio} | {fmt(g.get('shade'))} | {fmt(g.get('frame'))} | {met} |")
    opaque = os.path.join(out, "atrium_opaque.json")
    cut = os.path.join(out, "frame_atrium_1.json")
    if os.path.exists(opaque) and os.path.exists(cut):
        a = load(cut).get("gpu_ms", {}).get("shade")
        o = load(opaque).get("gpu_ms", {}).get("shade")
        if a and o is not None:
            share = (a - o) / a
            print()
            print(f"any-hit's share of atrium's shading pass: ({a:.3f} - {o:.3f} opaque) / {a:.3f} "
                  f"= {100 * share:.0f}% (goal under {100 * ANYHIT_GOAL:.0f}%: "
                  f"{'met' if share < ANYHIT_GOAL else 'missed'})")
    print()
    print("| back-end | size | GPU ms | floor ms | of floor | goal |")
    print("|---|---|---|---|---|---|")
    for n in names:
        if not n.startswith("backend_"):
            continue
        j = load(os.path.join(out, n))
        ms, floor = j.get("backend_ms"), j.get("backend_floor_ms")
        if not ms or floor is None:
            print(f"| {j.get('denoiser')} | | no figures | | | |")
            continue
        share = floor / ms
        print(f"| {j.get('denoiser')} | {j.get('width')}x{j.get('height')} | {ms:.3f} | "
              f"{floor:.3f} | {100 * share:.0f}% | {100 * FLOOR_GOAL:.0f}%: "
              f"{'met' if share >= FLOOR_GOAL else 'missed'} |")


if __name__ == "__main__":
    main(sys.argv)
