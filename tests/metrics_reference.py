#!/usr/bin/env python3
"""tests/metrics_reference.py OUT REF FRAME... [--motion]: an independent implementation of docs/metrics.md
(numpy + OpenImageIO, written from the definitions, not from eval/'s C): prints per-frame
relMSE, SMAPE, RMSE, PSNR, SSIM and LDR-FLIP of OUT/frame_NNNN.exr against REF/frame_NNNN.exr,
with the automatic exposure of the whole sequence, as JSON; with --motion also the
motion-compensated temporal error per frame, the flicker on static pixels and the lag after a
disocclusion over the whole sequence (REF/frame_NNNN.motion.exr). tests/test_cli.sh compares it
with `tandem eval`'s metrics.json."""
import glob
import json
import os
import sys

import numpy as np
import OpenImageIO as oiio


def read(path):
    img = oiio.ImageInput.open(path)
    if img is None:
        raise SystemExit(f"cannot open {path}")
    spec = img.spec()
    names = list(spec.channelnames)
    px = img.read_image(format="float")
    img.close()
    px = np.asarray(px, dtype=np.float64).reshape(spec.height, spec.width, spec.nchannels)
    return np.stack([px[:, :, names.index(c)] for c in "RGB"], axis=-1)


def luma(x):
    return 0.2126 * x[..., 0] + 0.7152 * x[..., 1] + 0.0722 * x[..., 2]


def tonemap(x, e):
    x = np.maximum(x * e, 0.0)
    y = np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)
    return np.clip(np.where(y <= 0.0031308, 12.92 * y, 1.055 * y ** (1 / 2.4) - 0.055), 0, 1)


def correlate(img, k):
    """2-D correlation with edge-replicated borders (k square, odd)."""
    r = k.shape[0] // 2
    p = np.pad(img, r, mode="edge")
    h, w = img.shape
    out = np.zeros_like(img)
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            out += k[dy + r, dx + r] * p[r + dy:r + dy + h, r + dx:r + dx + w]
    return out


def ssim(o, r):
    g = np.exp(-np.arange(-5, 6) ** 2 / (2 * 1.5 ** 2))
    k = np.outer(g, g)
    k /= k.sum()
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    vals = []
    for c in range(3):
        a, b = o[..., c], r[..., c]
        m = [correlate(x, k)[5:-5, 5:-5] for x in (a, b, a * a, b * b, a * b)]
        va, vb, cov = m[2] - m[0] ** 2, m[3] - m[1] ** 2, m[4] - m[0] * m[1]
        s = (2 * m[0] * m[1] + c1) * (2 * cov + c2) / ((m[0] ** 2 + m[1] ** 2 + c1) * (va + vb + c2))
        vals.append(s.mean())
    return float(np.mean(vals))


M = np.array([[10135552 / 24577794, 8788810 / 24577794, 4435075 / 24577794],
              [2613072 / 12288897, 8788810 / 12288897, 887015 / 12288897],
              [1425312 / 73733382, 8788810 / 73733382, 70074185 / 73733382]])
W = np.array([0.950428545, 1.0, 1.088900371])


def hunt_lab(rgb):
    t = (rgb @ M.T) / W
    d = 6 / 29
    f = np.where(t > d ** 3, np.cbrt(t), t / (3 * d * d) + 4 / 29)
    L = 116 * f[..., 1] - 16
    return np.stack([L, 0.01 * L * 500 * (f[..., 0] - f[..., 1]), 0.01 * L * 200 * (f[..., 1] - f[..., 2])], -1)


def hyab(a, b):
    d = a - b
    return np.abs(d[..., 0]) + np.hypot(d[..., 1], d[..., 2])


def flip(ref, test, ppd=0.7 * 3840 / 0.7 * np.pi / 180):
    def ycxcz(srgb):
        lin = np.where(srgb > 0.04045, ((srgb + 0.055) / 1.055) ** 2.4, srgb / 12.92)
        x = (lin @ M.T) / W
        return np.stack([116 * x[..., 1] - 16, 500 * (x[..., 0] - x[..., 1]), 200 * (x[..., 1] - x[..., 2])], -1)

    r = int(np.ceil(3 * np.sqrt(0.04 / (2 * np.pi ** 2)) * ppd))
    xx, yy = np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1))
    z = (xx ** 2 + yy ** 2) / ppd ** 2

    def csf(a1, b1, a2, b2):
        s = a1 * np.sqrt(np.pi / b1) * np.exp(-np.pi ** 2 * z / b1)
        if a2:
            s = s + a2 * np.sqrt(np.pi / b2) * np.exp(-np.pi ** 2 * z / b2)
        return s / s.sum()

    ks = [csf(1, 0.0047, 0, 1e-5), csf(1, 0.0053, 0, 1e-5), csf(34.1, 0.04, 13.5, 0.025)]
    labs, ys = [], []
    for img in (ref, test):
        o = ycxcz(img)
        ys.append((o[..., 0] + 16) / 116)
        f = np.stack([correlate(o[..., c], ks[c]) for c in range(3)], -1)
        y = (f[..., 0] + 16) / 116
        xyz = np.stack([y + f[..., 1] / 500, y, y - f[..., 2] / 200], -1) * W
        lin = np.clip(xyz @ np.linalg.inv(M).T, 0, 1)
        labs.append(hunt_lab(lin))
    cmax = hyab(hunt_lab(np.array([0.0, 1, 0])), hunt_lab(np.array([0.0, 0, 1]))) ** 0.7
    e = hyab(labs[0], labs[1]) ** 0.7
    pc, pt = 0.4, 0.95
    color = np.where(e < pc * cmax, pt / (pc * cmax) * e, pt + (e - pc * cmax) / (cmax - pc * cmax) * (1 - pt))
    sd = 0.5 * 0.082 * ppd
    rf = int(np.ceil(3 * sd))
    fx, fy = np.meshgrid(np.arange(-rf, rf + 1), np.arange(-rf, rf + 1))
    g = np.exp(-(fx ** 2 + fy ** 2) / (2 * sd * sd))
    feats = []
    for kern in (-fx * g, (fx ** 2 / sd ** 2 - 1) * g):
        kern = np.where(kern < 0, kern / -kern[kern < 0].sum(), kern / kern[kern > 0].sum())
        feats.append([np.hypot(correlate(y, kern), correlate(y, kern.T)) for y in ys])
    df = np.maximum(np.abs(feats[0][0] - feats[0][1]), np.abs(feats[1][0] - feats[1][1]))
    df = (df / np.sqrt(2)) ** 0.5
    return float(np.mean(color ** (1 - df)))


def read_motion(path):
    img = oiio.ImageInput.open(path)
    if img is None:
        raise SystemExit(f"cannot open {path}")
    spec = img.spec()
    names = list(spec.channelnames)
    px = np.asarray(img.read_image(format="float"), np.float64).reshape(
        spec.height, spec.width, spec.nchannels)
    img.close()
    m = np.stack([px[:, :, names.index(f"motion.{c}")] for c in "XYZ"], -1)
    return m, px[:, :, names.index("depth.Z")]


def bilinear(img, x, y):
    """img at pixel-centre coordinates (x, y) (pixel i's centre at i), edge-clamped."""
    h, w = img.shape[:2]
    x0, y0 = np.floor(x), np.floor(y)
    ax, ay = (x - x0)[..., None], (y - y0)[..., None]
    xi = [np.clip(x0 + k, 0, w - 1).astype(int) for k in (0, 1)]
    yi = [np.clip(y0 + k, 0, h - 1).astype(int) for k in (0, 1)]
    top = (1 - ax) * img[yi[0], xi[0]] + ax * img[yi[0], xi[1]]
    bot = (1 - ax) * img[yi[1], xi[0]] + ax * img[yi[1], xi[1]]
    return (1 - ay) * top + ay * bot


def motion_metrics(tos, trs, motions, depths):
    """docs/metrics.md's motion-compensated temporal error, flicker on static pixels and lag after
    a disocclusion, from the tone-mapped frames and the reference's motion and depth."""
    h, w = depths[0].shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    miss = 1e29
    still = np.ones((h, w), bool)
    yo_all, yr_all, frames, events, lags = [], [], [], [], []
    for t, (to, tr, m, d) in enumerate(zip(tos, trs, motions, depths)):
        hit = d < miss
        valid = np.zeros((h, w), bool)
        rec = {"mc_temporal": None, "disoccluded": 0.0}
        if t > 0:
            xp, yp = xx + m[..., 0], yy + m[..., 1]
            inside = np.isfinite(xp) & np.isfinite(yp) & (xp >= -0.5) & (yp >= -0.5) & \
                (xp < w - 0.5) & (yp < h - 0.5)
            rnd = lambda v: np.where(v >= 0, np.floor(v + 0.5), -np.floor(-v + 0.5))
            ix = np.clip(rnd(np.nan_to_num(xp)), 0, w - 1).astype(int)
            iy = np.clip(rnd(np.nan_to_num(yp)), 0, h - 1).astype(int)
            dp = depths[t - 1][iy, ix]
            same = np.where(hit, (dp < miss) & (np.abs(dp - (d + m[..., 2])) <= 0.05 * d),
                            dp >= miss)
            valid = inside & same
            wo = bilinear(tos[t - 1], np.nan_to_num(xp), np.nan_to_num(yp))
            wr = bilinear(trs[t - 1], np.nan_to_num(xp), np.nan_to_num(yp))
            diff = np.abs((to - wo) - (tr - wr))[valid]
            rec["mc_temporal"] = float(diff.mean()) if valid.any() else None
            dis = hit & ~valid
            rec["disoccluded"] = float(dis.mean())
            still &= valid & (np.abs(m[..., 0]) < 0.01) & (np.abs(m[..., 1]) < 0.01) & \
                (~hit | (np.abs(m[..., 2]) <= 1e-3 * d))
            if dis.any():
                events.append({"mask": dis, "age": 0})
        frames.append(rec)
        yo, yr = luma(to), luma(tr)
        yo_all.append(yo)
        yr_all.append(yr)
        err = np.abs(yo - yr)
        base = err[valid].mean() if valid.any() else 0.0
        left = []
        for ev in events:
            e = err[ev["mask"]].mean()
            if e <= 1.25 * base + 0.002 or ev["age"] + 1 >= 16:
                lags.append(ev["age"] if e <= 1.25 * base + 0.002 else 16)
            else:
                ev["age"] += 1
                left.append(ev)
        events = left
    mc = [f["mc_temporal"] for f in frames if f["mc_temporal"] is not None]
    out = {"frames": frames, "mc_temporal": float(np.mean(mc)) if mc else None,
           "static_pixels": int(still.sum()), "disocclusions": len(lags),
           "disocclusion_lag": float(np.mean(lags)) if lags else -1.0}
    if len(tos) >= 3 and still.any():
        out["flicker"] = float(np.std(np.stack(yo_all), axis=0)[still].mean())
        out["flicker_reference"] = float(np.std(np.stack(yr_all), axis=0)[still].mean())
    return out


def main():
    motion = "--motion" in sys.argv
    args = [a for a in sys.argv[1:] if a != "--motion"]
    out_dir, ref_dir, frames = args[0], args[1], [int(f) for f in args[2:]]
    outs = [np.nan_to_num(read(f"{out_dir}/frame_{f:04d}.exr"), nan=0, posinf=0, neginf=0) for f in frames]
    refs = [read(f"{ref_dir}/frame_{f:04d}.exr") for f in frames]
    # the exposure comes from every reference frame the run also has (as `tandem eval` does)
    every = sorted(p for p in glob.glob(f"{ref_dir}/frame_*.exr")
                   if os.path.exists(f"{out_dir}/{os.path.basename(p)}"))
    logs = np.concatenate([np.log(np.maximum(luma(read(p)), 1e-4)).ravel() for p in every])
    e = 0.18 / np.exp(logs.mean())
    res = []
    for f, o, r in zip(frames, outs, refs):
        d = o - r
        to, tr = tonemap(o, e), tonemap(r, e)
        mse = np.mean((to - tr) ** 2)
        res.append({"frame": f,
                    "relmse": float(np.mean(d * d / (r * r + 0.01))),
                    "smape": float(np.mean(np.abs(d) / (np.abs(o) + np.abs(r) + 0.01))),
                    "rmse": float(np.sqrt(np.mean(d * d))),
                    "psnr": float(10 * np.log10(1 / max(mse, 1e-10))),
                    "ssim": ssim(to, tr),
                    "flip": flip(tr, to)})
    result = {"exposure": e, "frames": res}
    if motion:  # over every frame the run shares with the reference, in order
        seq = [int(os.path.basename(p)[6:10]) for p in every]
        tos = [tonemap(np.nan_to_num(read(f"{out_dir}/frame_{f:04d}.exr"), nan=0, posinf=0,
                                     neginf=0), e) for f in seq]
        trs = [tonemap(read(f"{ref_dir}/frame_{f:04d}.exr"), e) for f in seq]
        mo = [read_motion(f"{ref_dir}/frame_{f:04d}.motion.exr") for f in seq]
        result["motion"] = motion_metrics(tos, trs, [m for m, _ in mo], [d for _, d in mo])
        for f, r in zip(seq, result["motion"]["frames"]):
            r["frame"] = f
    print(json.dumps(result))


if __name__ == "__main__":
    main()
