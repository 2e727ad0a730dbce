#!/usr/bin/env python3
"""Round trips through the mappings of other renderers (data/mappings/).

Tandem's own frames (sun.gltf: a sky, a sun and a moving camera, 3 frames at 48x32, Embree) are
written in each renderer's documented convention (pbrt-v4's GBufferFilm, Mitsuba 3's aov
integrator, Falcor's frame capture, the OIDN training layout), read back with `tandem convert`
through the shipped mapping, and compared entry by entry with the originals, within what that
convention's format keeps. The writers below follow each renderer's documentation, not
Tandem's reader: pbrt's matrices are built from its Perspective() and screen window, Mitsuba's
camera from its sensor's to_world and fov. Then the bad input: a missing file of a frame, a
header without the camera, a feature file of another size.

usage: test_capture_conventions.py TANDEM
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np
import OpenImageIO as oiio

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tandem_cli import Checks  # noqa: E402

TANDEM = os.path.abspath(sys.argv[1])
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
MAPS = os.path.join(ROOT, "data", "mappings")
W, H, FRAMES = 48, 32, 3
MISS = 1e29
C = Checks(TANDEM)
check, run = C.check, C.run


def read_exr(path):
    buf = oiio.ImageBuf(path)
    spec = buf.spec()
    px = buf.get_pixels(oiio.FLOAT)
    return {n: px[:, :, i].astype(np.float64) for i, n in enumerate(spec.channelnames)}, spec


def write_exr(path, chans, half=False, attrs=()):
    names = list(chans)
    spec = oiio.ImageSpec(W, H, len(names), oiio.HALF if half else oiio.FLOAT)
    spec.channelnames = names
    spec.attribute("compression", "zip")
    for name, value in attrs:
        spec.attribute(name, oiio.TypeDesc("matrix"), tuple(float(v) for v in value))
    out = oiio.ImageOutput.create(path)
    assert out and out.open(path, spec), oiio.geterror()
    out.write_image(np.stack([np.asarray(chans[n], np.float32) for n in names], -1))
    out.close()


def vec(ch, layer, comps="XYZ"):
    return np.stack([ch[f"{layer}.{c}"] for c in comps], -1)


def column_major(spec, name):
    return np.array(spec.getattribute(name), np.float64).reshape(4, 4).T


def xform(m, v, w):
    """m (4x4) applied to H x W x 3 points (w=1) or directions (w=0)."""
    return v @ m[:3, :3].T + (m[:3, 3] if w else 0.0)


# ---- the originals ----------------------------------------------------------------------------
tmp = tempfile.mkdtemp(prefix="tandem_conv_")
try:
    run("render", "--frontend", "embree", "--scene", os.path.join(ROOT, "data/scenes/sun.gltf"),
        "--frames", str(FRAMES), "--size", f"{W}x{H}", "--capture", "--denoiser", "off",
        "--out", f"{tmp}/orig", "--quiet")
    run("denoise", "--captures", f"{tmp}/orig", "--denoiser", "off", "--taa", "off",
        "--out", f"{tmp}/orig_off", "--quiet")
    frames = []
    for k in range(FRAMES):
        ch, spec = read_exr(f"{tmp}/orig/capture/frame_{k:04d}.exr")
        rgb, _ = read_exr(f"{tmp}/orig_off/frame_{k:04d}.exr")
        fr = {
            "albedo": vec(ch, "albedo", "RGB"), "normal": vec(ch, "normal"),
            "geo_normal": vec(ch, "geo_normal"), "position": vec(ch, "position"),
            "depth": ch["depth.Z"], "motion": vec(ch, "motion"), "rough": ch["roughness.V"],
            "emission": vec(ch, "emission", "RGB"), "rgb": vec(rgb, "", "RGB") if ".R" in rgb
            else np.stack([rgb["R"], rgb["G"], rgb["B"]], -1),
            "view": column_major(spec, "tandem.view"), "proj": column_major(spec, "tandem.proj"),
        }
        fr["hit"] = fr["depth"] < MISS
        frames.append(fr)
    hit_all = np.stack([f["hit"] for f in frames])
    assert 0.1 < hit_all.mean() < 0.95, "the scene must show both surfaces and sky"
    P0 = frames[0]["proj"]
    yfov = 2 * np.arctan(1 / abs(P0[1, 1]))
    xfov = 2 * np.arctan(1 / P0[0, 0])
    aspect = W / H

    def compare(name, conv_dir, tol, skip=()):
        """Every entry of the converted frames against the originals; tol: entry -> bound."""
        run("denoise", "--captures", conv_dir, "--denoiser", "off", "--taa", "off",
            "--out", f"{conv_dir}_off", "--quiet")
        worst = {}
        for k, fr in enumerate(frames):
            ch, _ = read_exr(f"{conv_dir}/frame_{k:04d}.exr")
            rgb, _ = read_exr(f"{conv_dir}_off/frame_{k:04d}.exr")
            got = {"albedo": vec(ch, "albedo", "RGB"), "depth": ch["depth.Z"],
                   "rgb": np.stack([rgb["R"], rgb["G"], rgb["B"]], -1)}
            for e in ("normal", "geo_normal", "position", "motion"):
                if e not in skip:
                    got[e] = vec(ch, e)
            hit = fr["hit"]
            assert np.array_equal(got["depth"] < MISS, hit), f"{name}: misses moved, frame {k}"
            for e, g in got.items():
                if e in skip:
                    continue
                ref = fr[e]
                if e in ("rgb",):  # the composite: relative to the pixel's value
                    d = np.abs(g - ref) / np.maximum(np.abs(ref), 1e-3)
                elif e == "depth":
                    d = np.where(hit, np.abs(g - ref) / np.maximum(ref, 1e-6), 0)
                elif e == "motion" and k == 0:  # (no frame before: the reconstruction gives 0)
                    continue
                elif e == "motion" and "motion.z" in skip:  # (a convention without the depth's)
                    d = np.where(hit[..., None], np.abs(g - ref)[..., :2], 0)
                else:
                    d = np.where(hit[..., None] if g.ndim == 3 else hit, np.abs(g - ref), 0)
                    if e == "position":
                        d = d / np.maximum(fr["depth"], 1e-6)[..., None]
                worst[e] = max(worst.get(e, 0.0), float(np.max(d)))
        ok = all(worst[e] <= tol[e] for e in worst)
        check(f"{name}: the same contract within the format's precision", ok,
              ", ".join(f"{e} {worst[e]:.2g} (<= {tol[e]:g})" for e in worst))
        return worst

    # ---- pbrt-v4 GBufferFilm -------------------------------------------------------------------
    # pbrt's camera looks down +z (x right, y up): cameraFromWorld = diag(1,1,-1) view. Its
    # Perspective(fov) scales by 1/tan(fov/2) for the shorter image axis (y here) and maps z in
    # [near, far] to [0, 1]; NDCFromWorld = Translate(.5) Scale(.5) screenFromCamera
    # cameraFromWorld; header matrices row-major (M[i][j] at 4i + j). Half floats (its default).
    def pbrt_write(dirname, old_names=False):
        os.makedirs(dirname)
        n, f = 1e-2, 1000.0
        inv_tan = 1 / np.tan(0.5 * (yfov if W >= H else xfov))
        persp = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, f / (f - n), -f * n / (f - n)],
                          [0, 0, 1, 0]])
        screen_from_camera = np.diag([inv_tan, inv_tan, 1, 1]) @ persp
        ndc_from_screen = np.array([[.5, 0, 0, .5], [0, .5, 0, .5], [0, 0, .5, .5], [0, 0, 0, 1]])
        for k, fr in enumerate(frames):
            C = np.diag([1.0, 1.0, -1.0, 1.0]) @ fr["view"]
            N = ndc_from_screen @ screen_from_camera @ C
            hit = fr["hit"][..., None]
            P = np.where(hit, xform(C, fr["position"], 1), 0)
            Ng = np.where(hit, xform(C, fr["geo_normal"], 0), 0)
            Ns = np.where(hit, xform(C, fr["normal"], 0), 0)
            c = {}
            for i, a in enumerate("RGB"):
                c[a] = fr["rgb"][..., i]
                c[f"Albedo.{a}"] = fr["albedo"][..., i]
                c[f"Variance.{a}"] = c[f"RelativeVariance.{a}"] = np.zeros((H, W))
            for i, a in enumerate("XYZ"):
                sep = "" if old_names else "."
                c[f"P{sep}{a.lower() if old_names else a}"] = P[..., i]
                c[f"N{sep}{a.lower() if old_names else a}"] = Ng[..., i]
                c[f"Ns{sep}{a.lower() if old_names else a}"] = Ns[..., i]
            c["dzdx"] = c["dzdy"] = c["u"] = c["v"] = np.zeros((H, W))
            write_exr(f"{dirname}/sun_{k:04d}.exr", c, half=True,
                      attrs=[("worldToCamera", C.flatten()), ("worldToNDC", N.flatten())])

    # half floats keep 2^-11 of a value: albedo 1e-3 absolute; camera-space P and N per component
    # (position and depth 2e-3 of the depth, normals 2e-3); the motion, reprojected from that P
    # through two cameras, a few hundredths of a pixel; the composite 2e-3 of the pixel
    half_tol = {"albedo": 1e-3, "normal": 2e-3, "geo_normal": 2e-3, "position": 2e-3,
                "depth": 2e-3, "motion": 0.05, "rgb": 2e-3}
    pbrt_write(f"{tmp}/pbrt")
    run("convert", "--captures", f"{tmp}/pbrt", "--map", f"{MAPS}/pbrt_v4_gbuffer.json",
        "--out", f"{tmp}/pbrt_conv", "--quiet")
    compare("pbrt-v4 GBufferFilm", f"{tmp}/pbrt_conv", half_tol)
    pbrt_write(f"{tmp}/pbrt_old", old_names=True)
    run("convert", "--captures", f"{tmp}/pbrt_old", "--map", f"{MAPS}/pbrt_v4_gbuffer.json",
        "--out", f"{tmp}/pbrt_old_conv", "--quiet")
    compare("pbrt-v4, older files (Px, Nx, Nsx)", f"{tmp}/pbrt_old_conv", half_tol)

    # ---- Mitsuba 3 aov ---------------------------------------------------------------------------
    # Mitsuba's sensor frame: +x left, +y up, looking down +z (look_at: left = up x dir), so
    # to_world = inverse(diag(-1,1,-1) view); fov along x. World space AOVs, depth = distance
    # along the ray (0 on a miss). This scene is written with +Z up (as Blender exports), the
    # mapping told so.
    def mitsuba_write(dirname):
        os.makedirs(dirname)
        R = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1.0]])  # y-up -> z-up
        cams = {"frames": {}}
        for k, fr in enumerate(frames):
            to_world = R @ np.linalg.inv(np.diag([-1.0, 1.0, -1.0, 1.0]) @ fr["view"])
            cams["frames"][f"frame_{k:04d}"] = {"to_world": to_world.flatten().tolist(),
                                                "fov": float(np.degrees(xfov)), "fov_axis": "x"}
            hit = fr["hit"][..., None]
            c = {}
            pos = np.where(hit, xform(R, fr["position"], 1), 0)
            nn = np.where(hit, xform(R, fr["normal"], 0), 0)
            ng = np.where(hit, xform(R, fr["geo_normal"], 0), 0)
            for i, a in enumerate("RGB"):
                c[a] = fr["rgb"][..., i]
                c[f"albedo.{a}"] = fr["albedo"][..., i]
            for i, a in enumerate("XYZ"):
                c[f"pos.{a}"], c[f"nn.{a}"], c[f"ng.{a}"] = pos[..., i], nn[..., i], ng[..., i]
            c["dd.T"] = np.where(fr["hit"], fr["depth"], 0)
            write_exr(f"{dirname}/frame_{k:04d}.exr", c)
        json.dump(cams, open(f"{dirname}/cameras.json", "w"), indent=1)

    mitsuba_write(f"{tmp}/mitsuba")
    m = json.load(open(f"{MAPS}/mitsuba3_aov.json"))
    m["world"]["up"] = "+z"
    json.dump(m, open(f"{tmp}/mitsuba_zup.json", "w"))
    run("convert", "--captures", f"{tmp}/mitsuba", "--map", f"{tmp}/mitsuba_zup.json",
        "--out", f"{tmp}/mitsuba_conv", "--quiet")
    # float32 throughout: rounding in the camera and world turns (1e-5), the reprojection 1e-3 px
    float_tol = {"albedo": 1e-6, "normal": 1e-5, "geo_normal": 1e-5, "position": 1e-5,
                 "depth": 1e-5, "motion": 2e-3, "rgb": 1e-5}
    compare("Mitsuba 3 aov (world +Z up)", f"{tmp}/mitsuba_conv", float_tol)

    # ---- Falcor frame capture --------------------------------------------------------------------
    # One file per output: <base>.<pass.output>.<frame>.exr. posW (w = 1 on geometry, cleared to
    # 0), normW, faceNormalW, diffuseOpacity, specRough (roughness in A), emissive, linearZ
    # (view-space z, 0 where cleared) and mvec = previous UV - current UV, y down, jitter removed.
    def falcor_write(dirname):
        os.makedirs(dirname)
        for k, fr in enumerate(frames):
            fid = 1000 + 7 * k  # Falcor's frame numbers: not padded, not from 0
            hit = fr["hit"]
            one, zero = np.ones((H, W)), np.zeros((H, W))
            vz = -xform(fr["view"], fr["position"], 1)[..., 2]
            outs = {
                "AccumulatePass.output": list(np.moveaxis(fr["rgb"], -1, 0)) + [one],
                "GBufferRaster.posW": list(np.moveaxis(fr["position"], -1, 0)) + [one],
                "GBufferRaster.normW": list(np.moveaxis(fr["normal"], -1, 0)) + [zero],
                "GBufferRaster.faceNormalW": list(np.moveaxis(fr["geo_normal"], -1, 0)) + [zero],
                "GBufferRaster.diffuseOpacity": list(np.moveaxis(fr["albedo"], -1, 0)) + [one],
                "GBufferRaster.specRough": [zero, zero, zero, fr["rough"]],
                "GBufferRaster.emissive": list(np.moveaxis(fr["emission"], -1, 0)) + [zero],
                "GBufferRaster.linearZ": [np.where(hit, vz, 0), zero],
                "GBufferRaster.mvec": [fr["motion"][..., 0] / W, fr["motion"][..., 1] / H],
            }
            for out, planes in outs.items():
                planes = [np.where(hit, p, 0) if out.startswith("GBufferRaster.") and
                          out != "GBufferRaster.mvec" else p for p in planes]
                write_exr(f"{dirname}/Tandem.{out}.{fid}.exr", dict(zip("RGBA", planes)))

    falcor_write(f"{tmp}/falcor")
    m = json.load(open(f"{MAPS}/falcor_capture.json"))
    m["camera"]["yfov_degrees"] = float(np.degrees(yfov))  # (Falcor's default is 59.49)
    json.dump(m, open(f"{tmp}/falcor.json", "w"))
    run("convert", "--captures", f"{tmp}/falcor", "--map", f"{tmp}/falcor.json",
        "--out", f"{tmp}/falcor_conv", "--quiet")
    # linearZ is planar: the mapping turns it into a distance along the pixel centre's ray, while
    # Tandem's rays carry the frame's jitter (up to half a pixel): checked against the centre's
    # ray below, and against Tandem's depth within that half pixel's effect on the ray's length,
    # 0.5 px x (|u| + |v|) / focal length in pixels. mvec has no depth change: the
    # converted motion.z is 0 (the back-end's depth test then allows its 10%), compared in x, y
    f_px = 0.5 * H / np.tan(0.5 * yfov)
    jitter_bound = 0.5 / f_px * (0.5 * W + 0.5 * H) / f_px
    falcor_tol = dict(float_tol, depth=jitter_bound)
    compare("Falcor frame capture (9 files per frame)", f"{tmp}/falcor_conv", falcor_tol,
            skip=("motion.z",))
    ch, _ = read_exr(f"{tmp}/falcor_conv/frame_0001.exr")
    fr = frames[1]
    xs, ys = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    want = -xform(fr["view"], fr["position"], 1)[..., 2] * np.sqrt(
        1 + ((xs - W / 2) / f_px) ** 2 + ((ys - H / 2) / f_px) ** 2)
    err = np.max(np.abs(ch["depth.Z"] - want)[fr["hit"]] / want[fr["hit"]])
    check("Falcor: linearZ to distance along the pixel centre's ray", err < 1e-5, f"{err:.2g}")
    info = run("info", "--capture", f"{tmp}/falcor", "--map", f"{tmp}/falcor.json", "--json")
    mc = json.loads(info.stdout)["motion_check"]
    # (without motion.z the check's 5% depth test fails where the dolly changes depth more)
    check("Falcor: info's motion check agrees best as given (mvec's convention mapped)",
          mc["best"] == "as given" and mc["as given"] > 0.5,
          ", ".join(f"{k} {mc[k]:.3f}" for k in ("as given", "x negated", "y negated")))

    # ---- OIDN training layout --------------------------------------------------------------------
    # NAME.hdr.exr (noisy radiance), NAME.alb.exr, NAME.nrm.exr ([-1,1], 0 where nothing was
    # hit); single images: every hit is a surface at depth 1 and nothing moves
    def oidn_write(dirname):
        os.makedirs(dirname)
        for k, fr in enumerate(frames):
            hit = fr["hit"][..., None]
            for feat, img in (("hdr", fr["rgb"]), ("alb", np.where(hit, fr["albedo"], 0)),
                              ("nrm", np.where(hit, fr["normal"], 0))):
                write_exr(f"{dirname}/sun_{k:04d}.{feat}.exr",
                          dict(zip("RGB", np.moveaxis(img, -1, 0))))

    oidn_write(f"{tmp}/oidn")
    run("convert", "--captures", f"{tmp}/oidn", "--map", f"{MAPS}/oidn_training.json",
        "--out", f"{tmp}/oidn_conv", "--quiet")
    compare("OIDN training layout", f"{tmp}/oidn_conv", float_tol,
            skip=("geo_normal", "position", "depth", "motion"))
    ch, _ = read_exr(f"{tmp}/oidn_conv/frame_0001.exr")
    d = ch["depth.Z"]
    check("OIDN: depth 1 on surfaces (zero normal: a miss), no motion",
          np.all(d[frames[1]["hit"]] == 1) and np.all(vec(ch, "motion") == 0))

    # ---- bad input ---------------------------------------------------------------------------------
    shutil.copytree(f"{tmp}/falcor", f"{tmp}/falcor_gap")
    os.remove(f"{tmp}/falcor_gap/Tandem.GBufferRaster.mvec.1007.exr")
    p = run("convert", "--captures", f"{tmp}/falcor_gap", "--map", f"{tmp}/falcor.json",
            "--out", f"{tmp}/gap_conv", expect=None)
    check("a frame without one of its files exits 1 naming the frame and the file",
          p.returncode == 1 and "Tandem.AccumulatePass.output.1007.exr" in p.stderr and
          "'mvec'" in p.stderr and not os.path.exists(f"{tmp}/gap_conv"), p.stderr.strip())
    os.makedirs(f"{tmp}/pbrt_nocam")
    ch, _ = read_exr(f"{tmp}/pbrt/sun_0000.exr")
    write_exr(f"{tmp}/pbrt_nocam/sun_0000.exr", ch, half=True)
    p = run("convert", "--captures", f"{tmp}/pbrt_nocam", "--map",
            f"{MAPS}/pbrt_v4_gbuffer.json", "--out", f"{tmp}/nocam_conv", expect=None)
    check("a pbrt file without the header matrices exits 1 naming them",
          p.returncode == 1 and "sun_0000.exr" in p.stderr and "worldToNDC" in p.stderr,
          p.stderr.strip())
    shutil.copytree(f"{tmp}/oidn", f"{tmp}/oidn_size")
    w0 = W
    W = 40
    write_exr(f"{tmp}/oidn_size/sun_0002.alb.exr", dict(zip("RGB", np.zeros((3, H, W)))))
    W = w0
    p = run("convert", "--captures", f"{tmp}/oidn_size", "--map", f"{MAPS}/oidn_training.json",
            "--out", f"{tmp}/size_conv", expect=None)
    check("a feature file of another size exits 1 naming it and both sizes",
          p.returncode == 1 and "sun_0002.alb.exr: 40x32" in p.stderr and "48x32" in p.stderr
          and not os.path.exists(f"{tmp}/size_conv"), p.stderr.strip())
    # a Tandem capture whose second frame lost an entry (roughness): the sequence is refused
    os.makedirs(f"{tmp}/dropped")
    for k in range(FRAMES):
        src = f"{tmp}/orig/capture/frame_{k:04d}.exr"
        if k != 1:
            shutil.copy(src, f"{tmp}/dropped/")
            continue
        keep = [n for n in oiio.ImageBuf(src).spec().channelnames if n != "roughness.V"]
        subprocess.run(["oiiotool", src, "--ch", ",".join(keep), "-o",  # (keeps UINT channels)
                        f"{tmp}/dropped/frame_0001.exr"], check=True)
    p = run("denoise", "--captures", f"{tmp}/dropped", "--out", f"{tmp}/dropped_den", expect=None)
    check("a frame without an entry its first frame has exits 1 naming the file and the entry",
          p.returncode == 1 and "frame_0001.exr: entry 'roughness' is absent here" in p.stderr
          and not os.path.exists(f"{tmp}/dropped_den"), p.stderr.strip())
finally:
    shutil.rmtree(tmp, ignore_errors=True)

C.finish()
