"""The Python package against the tandem command: the same frames, captures, metrics and
datasets, bit for bit where the same C code runs; Python denoisers in both; errors as
exceptions with Tandem's message. Run by `make test` (tests/CMakeLists.txt: test_python) with
PYTHONPATH at the build's python/ and TANDEM the command."""
import json
import os
import subprocess

import numpy as np
import OpenImageIO as oiio
import pytest

import tandem

TANDEM = os.environ["TANDEM"]
SRC = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CORNELL = os.path.join(SRC, "data", "scenes", "cornell.gltf")
BOX = "/usr/share/assimp/models/glTF2/BoxTextured-glTF/BoxTextured.gltf"
HERE = os.path.dirname(os.path.abspath(__file__))


def run(*args, env=None):
    e = dict(os.environ, **(env or {}))
    return subprocess.run([TANDEM, *args, "--quiet"], check=True, env=e)


def read_rgb(path):
    img = oiio.ImageInput.open(path)
    px = img.read_image("float")
    names = img.spec().channelnames
    img.close()
    return px, names


@pytest.mark.parametrize("frontend,denoiser,bounces", [("embree", "svgf", 1), ("embree", "off", 1),
                                                       ("vk", "asvgf", 1), ("vk", "asvgf", "half"),
                                                       ("embree", "svgf", "half")])
def test_render_equals_command(tmp_path, frontend, denoiser, bounces):
    """Renderer frames are render's frame_NNNN.exr and its captures, bit for bit (the Vulkan
    front-end on lavapipe with A-SVGF's re-shading and the post chain; bounces "half" as
    --bounces half)."""
    out = tmp_path / "run"
    run("render", "--scene", CORNELL, "--frontend", frontend, "--denoiser", denoiser, "--size",
        "48x32", "--frames", "3", "--capture", "--bounces", str(bounces), "--out", str(out))
    r = tandem.Renderer(CORNELL, frontend=frontend, denoiser=denoiser, size=(48, 32),
                        bounces=bounces)
    for f in range(3):
        fr = r.frame(f)
        px, _ = read_rgb(str(out / ("frame_%04d.exr" % f)))
        assert np.array_equal(px[..., :3], fr["radiance"]), f
        cap = tandem.read_capture(str(out / "capture" / ("frame_%04d.exr" % f)))
        assert cap.keys() == fr["contract"].keys()
        for k in cap.keys():
            assert np.array_equal(cap[k], fr["contract"][k]), (f, k)


def test_capture_round_trip(tmp_path):
    """A capture read, written and read again is the same; one made from arrays reads back."""
    out = tmp_path / "run"
    run("render", "--scene", BOX, "--frames", "1", "--size", "40x30", "--capture", "--out",
        str(out))
    a = tandem.read_capture(str(out / "capture" / "frame_0000.exr"))
    assert a.has_camera and {"albedo", "normal", "depth", "motion", "hf"} <= set(a.keys())
    a.write(str(tmp_path / "again.exr"))
    b = tandem.read_capture(str(tmp_path / "again.exr"))
    assert a.keys() == b.keys()
    for k in a.keys():
        assert np.array_equal(a[k], b[k]), k
    assert np.array_equal(a.camera["view"], b.camera["view"])
    # a view outlives the expression that read its capture (the view holds the capture)
    import gc
    albedo = tandem.read_capture(str(out / "capture" / "frame_0000.exr"))["albedo"][2:5]
    gc.collect()
    junk = [tandem.Capture(40, 30) for _ in range(4)]  # (memory a freed plane would go to)
    assert np.array_equal(albedo, a["albedo"][2:5]) and len(junk) == 4
    # made from arrays: the required entries, a camera left out
    c = tandem.Capture(8, 6)
    rng = np.random.default_rng(1)
    for name in ("albedo", "normal", "depth", "motion", "hf"):
        c[name] = rng.random(c[name].shape, dtype=np.float32)
    c.write(str(tmp_path / "made.exr"))
    d = tandem.read_capture(str(tmp_path / "made.exr"))
    # (the reader derives geo_normal and fills the defaults it reads)
    assert set(c.keys()) <= set(d.keys())
    for k in c.keys():
        assert np.array_equal(c[k], d[k]), k
    # the composite is render --denoiser off's on the CPU
    off = tmp_path / "off"
    run("render", "--scene", BOX, "--frontend", "embree", "--denoiser", "off", "--taa", "off",
        "--frames", "1", "--size", "40x30", "--out", str(off))
    px, _ = read_rgb(str(off / "frame_0000.exr"))
    assert np.array_equal(px[..., :3], a.composite())


def write_exr(path, rgb):
    out = oiio.ImageOutput.create(path)
    out.open(path, oiio.ImageSpec(rgb.shape[1], rgb.shape[0], 3, "float"))
    out.write_image(np.ascontiguousarray(rgb, np.float32))
    out.close()


def test_mapped_capture(tmp_path):
    """Another renderer's frames through a mapping (Open Image Denoise's training layout: one
    EXR per feature) read as `tandem convert` converts them, entry for entry."""
    rng = np.random.default_rng(7)
    src = tmp_path / "oidn"
    src.mkdir()
    for name in ("a", "b"):
        write_exr(str(src / (name + ".hdr.exr")), rng.random((12, 16, 3)) * 4)
        write_exr(str(src / (name + ".alb.exr")), 0.1 + 0.8 * rng.random((12, 16, 3)))
        write_exr(str(src / (name + ".nrm.exr")), rng.random((12, 16, 3)) * 2 - 1)
    mapping = os.path.join(SRC, "data", "mappings", "oidn_training.json")
    names = tandem.list_captures(str(src), map=mapping)
    assert [os.path.basename(n) for n in names] == ["a.hdr.exr", "b.hdr.exr"]
    conv = tmp_path / "conv"
    run("convert", "--captures", str(src), "--map", mapping, "--out", str(conv))
    prev = None
    for i, n in enumerate(names):
        got = tandem.read_capture(n, map=mapping, prev=prev)
        want = tandem.read_capture(str(conv / ("frame_%04d.exr" % i)))
        assert set(want.keys()) <= set(got.keys() + ["motion", "depth", "emission"])
        for k in want.keys():
            assert np.array_equal(got[k], want[k]), (n, k)
        assert np.allclose(np.linalg.norm(got["normal"], axis=2), 1, atol=1e-5)
        prev = got
    # Tandem's own sequence lists its frames
    out = tmp_path / "run"
    run("render", "--scene", CORNELL, "--frames", "2", "--size", "32x24", "--capture", "--out",
        str(out))
    names = tandem.list_captures(str(out))
    assert [os.path.basename(n) for n in names] == ["frame_0000.exr", "frame_0001.exr"]


def test_metrics_equal_eval(tmp_path):
    """Sequence's metrics are tandem eval's (--metrics-on cpu: the same C code), frame by
    frame; evaluate() returns its metrics.json."""
    out, ref = tmp_path / "run", tmp_path / "ref"
    run("render", "--scene", CORNELL, "--frontend", "embree", "--denoiser", "svgf", "--size",
        "48x32", "--frames", "4", "--out", str(out))
    run("reference", "--scene", CORNELL, "--frontend", "embree", "--estimator", "realtime",
        "--spp", "32", "--size", "48x32", "--frames", "4", "--out", str(ref))
    m = tandem.evaluate(str(out), matched_reference=str(ref), metrics_on="cpu")
    frames = m["series"][0]["frames"]
    refs = [read_rgb(str(ref / ("frame_%04d.exr" % f)))[0] for f in range(4)]
    exposure = tandem.auto_exposure([r[..., :3] for r in refs])
    seq = tandem.Sequence(48, 32, exposure)
    for f in range(4):
        o, _ = read_rgb(str(out / ("frame_%04d.exr" % f)))
        got = seq.add(o[..., :3], refs[f][..., :3], frame=f, variance=refs[f][..., 3])
        for k in ("relmse", "smape", "rmse", "psnr", "ssim", "flip", "worth_relmse"):
            # (metrics.json prints doubles with %.17g or 6 significant digits)
            assert got[k] == pytest.approx(frames[f][k], rel=1e-5), (f, k)
        if f:
            assert got["temporal"] == pytest.approx(frames[f]["temporal"], rel=1e-5)


def test_python_denoiser_in_render(tmp_path):
    """A Python denoiser through `tandem render --denoiser python:MODULE:CALLABLE` (the bridge)
    and through the package (in this process): the same frames; a failing one names its
    exception and leaves no output."""
    out = tmp_path / "py"
    env = {"PYTHONPATH": HERE + os.pathsep + os.environ.get("PYTHONPATH", "")}
    run("render", "--scene", CORNELL, "--frontend", "embree", "--denoiser",
        "python:denoisers:Ema", "--size", "48x32", "--frames", "3", "--out", str(out), env=env)
    import sys
    sys.path.insert(0, HERE)
    import denoisers
    r = tandem.Renderer(CORNELL, frontend="embree", denoiser=denoisers.Ema, size=(48, 32))
    named = tandem.Renderer(CORNELL, frontend="embree", denoiser="python:denoisers:Ema",
                            size=(48, 32))
    for f in range(3):
        px, _ = read_rgb(str(out / ("frame_%04d.exr" % f)))
        a, b = r.frame(f)["radiance"], named.frame(f)["radiance"]
        assert np.array_equal(px[..., :3], a) and np.array_equal(a, b), f
    # the denoiser saw the history restart once, and the frames in order
    timings = json.load(open(out / "timings.json"))
    assert "denoiser_host_ms" in timings["frames"][0]
    bad = tmp_path / "bad"
    p = subprocess.run([TANDEM, "render", "--scene", CORNELL, "--frontend", "embree",
                        "--denoiser", "python:denoisers:broken", "--size", "48x32", "--frames",
                        "2", "--out", str(bad)], env=dict(os.environ, **env),
                       capture_output=True, text=True)
    assert p.returncode == 1 and "ValueError: no luck at frame 0" in p.stderr
    assert not bad.exists()


def test_python_denoiser_in_sweep(tmp_path):
    """A sweep over denoisers takes a Python one beside a built-in: both cells timed and judged
    against the same references (the Python one's time as denoiser_host_ms)."""
    out = tmp_path / "sweep"
    env = {"PYTHONPATH": HERE + os.pathsep + os.environ.get("PYTHONPATH", "")}
    run("bench", "--scene", CORNELL, "--sweep", "denoiser=svgf,python:denoisers:Ema", "--size",
        "48x32", "--frames", "6", "--warmup", "2", "--spp", "16", "--out", str(out), env=env)
    sweep = json.load(open(out / "sweep.json"))
    runs = {r["knobs"]["denoiser"]: r for r in sweep["runs"]}
    assert set(runs) == {"svgf", "python:denoisers:Ema"} and not sweep["failed"]
    ema = runs["python:denoisers:Ema"]
    assert ema["pass_ms"]["denoiser_host_ms"] > 0 and 0 < ema["relmse"] < 1
    assert ema["matched_reference"] == runs["svgf"]["matched_reference"]


def test_python_identity_is_off(tmp_path):
    """A Python denoiser that returns the noisy radiance it gets renders --denoiser off's frames
    bit for bit (Vulkan front-end on lavapipe: the radiance to Python and back unchanged)."""
    out = tmp_path / "off"
    run("render", "--scene", CORNELL, "--frontend", "vk", "--denoiser", "off", "--size", "40x24",
        "--frames", "2", "--out", str(out))
    import sys
    sys.path.insert(0, HERE)
    import denoisers
    r = tandem.Renderer(CORNELL, frontend="vk", denoiser=denoisers.Identity, size=(40, 24))
    for f in range(2):
        px, _ = read_rgb(str(out / ("frame_%04d.exr" % f)))
        assert np.array_equal(px[..., :3], r.frame(f, contract=False)["radiance"]), f


def test_lights_option_equals_command(tmp_path):
    """lights="tree" is render's --lights tree, bit for bit (the light tree on many_lights)."""
    scene = os.path.join(os.path.dirname(CORNELL), "many_lights.gltf")
    out = tmp_path / "run"
    run("render", "--scene", scene, "--frontend", "embree", "--denoiser", "off", "--size",
        "32x18", "--frames", "1", "--lights", "tree", "--out", str(out))
    fr = tandem.Renderer(scene, frontend="embree", denoiser="off", size=(32, 18),
                         lights="tree").frame(0)
    px, _ = read_rgb(str(out / "frame_0000.exr"))
    assert np.array_equal(px[..., :3], fr["radiance"])
    plain = tandem.Renderer(scene, frontend="embree", denoiser="off", size=(32, 18),
                            lights="plain").frame(0)
    assert not np.array_equal(plain["radiance"], fr["radiance"])


def test_restir_option_equals_command(tmp_path):
    """lights="restir" is render's --lights restir, bit for bit over frames that reuse the last
    frame's reservoirs, on both front-ends."""
    scene = os.path.join(os.path.dirname(CORNELL), "many_lights.gltf")
    for fe in ("embree", "vk"):
        out = tmp_path / fe
        run("render", "--scene", scene, "--frontend", fe, "--denoiser", "off", "--size",
            "32x18", "--frames", "3", "--lights", "restir", "--out", str(out))
        r = tandem.Renderer(scene, frontend=fe, denoiser="off", size=(32, 18), lights="restir")
        for f in range(3):
            px, _ = read_rgb(str(out / ("frame_%04d.exr" % f)))
            assert np.array_equal(px[..., :3], r.frame(f)["radiance"]), (fe, f)


def test_render_scale_equals_command(tmp_path):
    """render_scale=0.5 is render's --render-scale 0.5, bit for bit: radiance at the size, the
    contract at the render size (what render --capture writes)."""
    out = tmp_path / "half"
    run("render", "--scene", CORNELL, "--frontend", "vk", "--denoiser", "asvgf", "--size",
        "64x36", "--frames", "3", "--render-scale", "0.5", "--capture", "--out", str(out))
    r = tandem.Renderer(CORNELL, frontend="vk", denoiser="asvgf", size=(64, 36), render_scale=0.5)
    assert (r.width, r.height, r.render_width, r.render_height) == (64, 36, 32, 18)
    for f in range(3):
        got = r.frame(f)
        px, _ = read_rgb(str(out / ("frame_%04d.exr" % f)))
        assert np.array_equal(px[..., :3], got["radiance"]), f
        cap = tandem.read_capture(str(out / "capture" / ("frame_%04d.exr" % f)))
        assert got["contract"].width == cap.width == 32 and got["contract"].height == 18
        assert np.array_equal(got["contract"]["albedo"], cap["albedo"]), f
    with pytest.raises(tandem.TandemError, match="--render-scale 2: expected 0.25 to 1"):
        tandem.Renderer(CORNELL, frontend="vk", size=(64, 36), render_scale=2)


def test_errors_raise_with_message(tmp_path):
    with pytest.raises(tandem.TandemError, match="nope.gltf: cannot open"):
        tandem.Scene(str(tmp_path / "nope.gltf"))
    with pytest.raises(tandem.TandemError, match="unknown option 'framez'"):
        tandem.Renderer(CORNELL, framez=3)
    with pytest.raises(tandem.TandemError, match="up: the scene and its options come with"):
        tandem.Renderer(tandem.Scene(CORNELL), up="z")
    with pytest.raises(tandem.TandemError, match='bounces: expected a count or "half"'):
        tandem.Renderer(CORNELL, bounces="quarter")
    with pytest.raises(tandem.TandemError, match='--bounces half: only with the realtime'):
        tandem.Renderer(CORNELL, reference=True, bounces="half")
    with pytest.raises(tandem.TandemError, match="--frontend 'rays'"):
        tandem.Renderer(CORNELL, frontend="rays")
    with pytest.raises(tandem.TandemError, match="denoiser 'bm3d'"):
        tandem.Renderer(CORNELL, frontend="embree", denoiser="bm3d")
    with pytest.raises(tandem.TandemError, match="--lights x: expected auto, plain, tree or restir"):
        tandem.Renderer(CORNELL, frontend="embree", lights="x")
    bad = tmp_path / "bad.exr"
    bad.write_bytes(b"not an exr")
    with pytest.raises(tandem.TandemError, match="bad.exr"):
        tandem.read_capture(str(bad))
    with pytest.raises(tandem.TandemError, match="metrics: out has shape"):
        tandem.Sequence(8, 8, 1.0).add(np.zeros((4, 4, 3)), np.zeros((8, 8, 3)))


def test_dataset_half(tmp_path):
    """A dataset of bounces "half": the contract as render --bounces half makes it, and the
    matched reference of one bounce (its expectation)."""
    spec = {"size": [40, 24], "frames": 2, "spp": 8, "format": "npz", "bounces": "half",
            "sequences": [{"scene": CORNELL, "name": "c"}]}
    tandem.dataset(spec, str(tmp_path / "d"))
    data = tandem.load_dataset(str(tmp_path / "d"))
    r = tandem.Renderer(CORNELL, frontend="embree", denoiser="off", size=(40, 24), bounces="half")
    ref = tandem.Renderer(CORNELL, reference=True, frontend="embree", estimator="realtime",
                          spp=8, size=(40, 24), bounces=1)
    assert len(data) == 2
    for d in data:
        c = r.frame(d["frame"])["contract"]
        assert np.array_equal(d["lf_sh"], c["lf_sh"]) and np.array_equal(d["noisy"], c.composite())
        assert np.array_equal(d["matched"], ref.reference(d["frame"])["radiance"])


def test_dataset(tmp_path):
    """tandem dataset's frames: the contract as render --capture writes it, the noisy composite
    of it, the matched reference as `reference --estimator realtime` renders it; two shards
    make the whole set."""
    spec = {"size": [40, 24], "frames": 3, "spp": 8, "format": "npz",
            "sequences": [{"scene": CORNELL, "camera_path": "orbit", "name": "orbit"},
                          {"scene": BOX, "name": "box"}]}
    whole = tmp_path / "whole"
    man = tandem.dataset(spec, str(whole))
    assert len(man["frames"]) == 6
    data = tandem.load_dataset(str(whole))
    ref = tandem.Renderer(CORNELL, reference=True, frontend="embree", estimator="realtime",
                          spp=8, size=(40, 24), camera_path="orbit")
    r = tandem.Renderer(CORNELL, frontend="embree", denoiser="off", size=(40, 24),
                        camera_path="orbit")
    for d in data[3:]:  # (box first, then orbit: sorted by name)
        assert d["sequence"] == "orbit"
        m = ref.reference(d["frame"])
        assert np.array_equal(d["matched"], m["radiance"])
        c = r.frame(d["frame"])["contract"]
        assert np.array_equal(d["albedo"], c["albedo"]) and np.array_equal(d["hf"], c["hf"])
        assert np.array_equal(d["noisy"], c.composite())
    for i in range(2):
        tandem.dataset(str(whole / "spec.json"), str(tmp_path / "shards"), shard="%d/2" % i)
    parts = tandem.load_dataset(str(tmp_path / "shards"))
    assert len(parts) == 6
    for a, b in zip(data, parts):
        assert (a["sequence"], a["frame"]) == (b["sequence"], b["frame"])
        assert np.array_equal(a["matched"], b["matched"]) and np.array_equal(a["noisy"], b["noisy"])
    # the same frames as EXR files
    spec["format"] = "exr"
    tandem.dataset(spec, str(tmp_path / "exr"))
    exr = tandem.load_dataset(str(tmp_path / "exr"))
    for a, b in zip(data, exr):
        for k in ("noisy", "matched", "matched_variance", "albedo", "normal", "depth", "motion",
                  "view", "proj", "jitter"):
            assert np.array_equal(a[k], b[k]), k
    with pytest.raises(tandem.TandemError, match="unknown key 'fames'"):
        tandem.dataset({"fames": 2, "sequences": [{"scene": CORNELL}]}, str(tmp_path / "x"))


def test_rank(tmp_path, monkeypatch):
    """tandem.rank: a suite given as a dict (its relative paths from here), the leaderboard
    back as rank.json; a row per denoiser, the noisy input (off) behind svgf on this still box."""
    monkeypatch.chdir(os.path.dirname(CORNELL))
    suite = {"size": [32, 18], "frames": 4, "spp": 8, "frontend": "embree",
             "sequences": [{"name": "box", "scene": os.path.basename(CORNELL)}]}
    r = tandem.rank(suite, ["svgf", "off"], str(tmp_path / "r"), cache=str(tmp_path / "c"),
                    report=False, regions=True)
    cells = r["sequences"][0]["cells"]
    assert [c["status"] for c in cells] == ["ok", "ok"]
    assert r["overall"][0]["denoiser"] == "svgf" and r["overall"][1]["flip_vs_baseline"] > 1
    # regions=True: the box's lamp and the pixels round it, measured for both rows
    assert {"emitter", "emitter_edge"} <= set(cells[1]["regions"]) and "emitter" in r["regions"]
    with pytest.raises(tandem.TandemError, match="unknown key 'sise'"):
        tandem.rank({"sequences": [{"name": "a", "scene": CORNELL, "sise": 1}]}, "svgf",
                    str(tmp_path / "bad"), cache=str(tmp_path / "c"))
