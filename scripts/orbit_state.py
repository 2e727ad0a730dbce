#!/usr/bin/env python3
"""Write a `tandem view` repro state whose camera orbits a scene: for real models that come
without a camera path (OBJ, most glTF), so that `tandem render --view` and `tandem reference
--view` render the same moving camera (docs/denoise.md's real scenes use it).

usage: orbit_state.py SCENE OUT.json --centre X Y Z --distance D [--frames N] [--degrees A]
                      [--height H] [--size WxH] [--denoiser NAME] [--env FILE] [--frontend vk]

The camera starts 30 degrees right of +Z (the default camera's side), H x D above the centre,
and turns A degrees about +Y over N frames, always looking at the centre.
"""
import argparse
import json
import math

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("out")
ap.add_argument("--centre", type=float, nargs=3, required=True)
ap.add_argument("--distance", type=float, required=True)
ap.add_argument("--frames", type=int, default=48)
ap.add_argument("--degrees", type=float, default=20.0)
ap.add_argument("--height", type=float, default=0.35)
ap.add_argument("--size", default="192x108")
ap.add_argument("--denoiser", default="asvgf")
ap.add_argument("--frontend", default="vk")
ap.add_argument("--env", default="")
a = ap.parse_args()
w, h = (int(v) for v in a.size.split("x"))
path = []
for i in range(a.frames):
    ang = math.radians(30.0 + a.degrees * i / max(a.frames - 1, 1))
    c = a.centre
    p = [c[0] + a.distance * math.sin(ang), c[1] + a.height * a.distance,
         c[2] + a.distance * math.cos(ang)]
    f = [c[k] - p[k] for k in range(3)]
    n = math.sqrt(sum(v * v for v in f))
    f = [v / n for v in f]
    path.append({"frame": i, "position": p, "yaw": math.atan2(f[0], -f[2]),
                 "pitch": math.asin(max(-1.0, min(1.0, f[1])))})
state = {"tandem_view_state": 1, "scene": a.scene, "frontend": a.frontend, "denoiser": a.denoiser,
         "precision": "float32", "taa": "on", "tonemap": "aces", "exposure": "auto",
         "env": a.env, "view": "final", "split": "off", "split_denoiser": "",
         "split_frontend": "", "bloom": 0, "fps": 30, "env_intensity": 1, "env_rotation": 0,
         "exposure_bias": 0, "bounces": 1, "camera": 0, "size": [w, h], "path": path}
json.dump(state, open(a.out, "w"), indent=1)
