"""Tandem from Python: scenes, rendering and references through either front-end, captures,
the denoisers, eval's metrics and training data, over libtandem's C code (docs/python.md).

Arrays are numpy arrays: images ``(height, width, 3)`` float32 (linear radiance), display images
``(height, width, 3)`` uint8, contract entries ``(height, width, components)`` float32 (uint32
for vis_id, rng and path). Tandem writes into arrays the package allocates, and a capture's
entries are views of its own planes: nothing is copied on the way. A failure raises
:class:`TandemError` with Tandem's own message.
"""
import json
import os

import numpy as np

from . import _ffi, _host
from ._host import DenoiserFrame

__all__ = ["TandemError", "version", "set_quiet", "pipeline", "denoisers", "entries", "Scene", "Capture",
           "read_capture", "list_captures", "Renderer", "render", "reference", "metrics",
           "Sequence", "auto_exposure", "evaluate", "dataset", "load_dataset", "DenoiserFrame", "rank"]


class TandemError(RuntimeError):
    """A failure in Tandem; its text is Tandem's message (the file or option and the problem)."""


def _lib():
    return _ffi.get()


def _check(rc):
    if rc:
        raise TandemError(_ffi.get()[0].string(_ffi.get()[1].tandem_error()).decode())


def _handle(h):
    if h == _ffi.get()[0].NULL:
        raise TandemError(_ffi.get()[0].string(_ffi.get()[1].tandem_error()).decode())
    return h


def _take_string(p):
    ffi, lib = _lib()
    _handle(p)
    try:
        return ffi.string(p).decode()
    finally:
        lib.tandem_free(p)


def _str(s):
    return None if s is None else os.fspath(s).encode()


def _ptr(a, ctype):
    ffi, _ = _lib()
    if a is None:
        return ffi.NULL
    return ffi.cast(ctype, ffi.from_buffer(a, require_writable=False))


def version():
    _, lib = _lib()
    return _lib()[0].string(lib.tandem_version()).decode()


def set_quiet(quiet=True):
    """Tandem's info messages on standard error (a scene's defaults, a camera path's figures)
    off or on again; warnings always show. Returns the setting before."""
    return bool(_lib()[1].tandem_set_quiet(int(quiet)))


def pipeline():
    """The registries (front-ends, denoisers with their parameters and passes, metrics): what
    ``tandem info --pipeline --json`` prints."""
    return json.loads(_take_string(_lib()[1].tandem_pipeline_json()))


def denoisers():
    """The registered denoisers by name: their summary, capabilities, parameters and passes."""
    return {d["name"]: d for d in pipeline()["denoisers"]}


def entries():
    """The contract's entries in order: (name, components, dtype)."""
    ffi, lib = _lib()
    return [(ffi.string(lib.tandem_entry_name(e)).decode(), lib.tandem_entry_components(e),
             np.uint32 if lib.tandem_entry_is_uint(e) else np.float32)
            for e in range(lib.tandem_entry_count())]


# ---- scenes ---------------------------------------------------------------------------------
class Scene:
    """A scene as every command loads it: ``Scene(path, env=..., camera_path="orbit", ...)``
    with the scene options by their command-line names ('_' for '-')."""

    def __init__(self, path, **options):
        ffi, lib = _lib()
        self.path = os.fspath(path)
        self.options = options
        self._h = ffi.gc(_handle(lib.tandem_scene_load(_str(path), json.dumps(options).encode())),
                         lib.tandem_scene_free)

    def info(self):
        """``tandem info --scene PATH --json``'s dict."""
        return json.loads(_take_string(_lib()[1].tandem_scene_info(self._h)))


# ---- captures -------------------------------------------------------------------------------
class _View(np.ndarray):
    """A view of memory another object owns, holding that object (a capture's plane stays valid
    as long as any array made from it lives)."""


def _owned(arr, owner):
    v = arr.view(_View)
    v._owner = owner
    return v


class Capture:
    """One frame of the contract. ``cap["albedo"]`` is a view of the entry's plane (writable:
    set present for entries you fill), ``cap.present(name)``, ``cap.camera`` (a dict of views:
    view, proj, prev_view, prev_proj as stored, column-major 16 floats; jitter)."""

    def __init__(self, width=None, height=None, _handle_=None):
        ffi, lib = _lib()
        if _handle_ is None:
            _handle_ = _handle(lib.tandem_capture_new(width, height))
        self._h = ffi.gc(_handle_, lib.tandem_capture_free)
        self.width = lib.tandem_capture_width(self._h)
        self.height = lib.tandem_capture_height(self._h)
        self._names = {n: (i, c, t) for i, (n, c, t) in enumerate(entries())}

    def _index(self, name):
        if name not in self._names:
            raise KeyError("%s: not a contract entry (%s)" % (name, ", ".join(self._names)))
        return self._names[name]

    def __getitem__(self, name):
        ffi, lib = _lib()
        e, comps, dtype = self._index(name)
        p = lib.tandem_capture_plane(self._h, e)
        buf = ffi.buffer(p, self.width * self.height * comps * 4)
        return _owned(np.frombuffer(buf, dtype=dtype).reshape(self.height, self.width, comps),
                      self)

    def __setitem__(self, name, value):
        self[name][...] = value
        self.set_present(name, True)

    def keys(self):
        return [n for n in self._names if self.present(n)]

    def present(self, name):
        return bool(_lib()[1].tandem_capture_present(self._h, self._index(name)[0]))

    def set_present(self, name, present=True):
        _lib()[1].tandem_capture_set_present(self._h, self._index(name)[0], int(present))

    def fallback(self, name):
        """An entry the mapping marks optional that this frame's files lack."""
        return bool(_lib()[1].tandem_capture_fallback(self._h, self._index(name)[0]))

    @property
    def has_camera(self):
        return bool(_lib()[1].tandem_capture_has_camera(self._h))

    @property
    def camera(self):
        ffi, lib = _lib()
        c = lib.tandem_capture_camera(self._h)
        f = lambda field, n: _owned(np.frombuffer(ffi.buffer(getattr(c, field), 4 * n),
                                                  np.float32), self)
        return {"view": f("view", 16), "proj": f("proj", 16), "prev_view": f("prev_view", 16),
                "prev_proj": f("prev_proj", 16), "jitter": f("jitter", 2),
                "frame_index": c.frame_index}

    def to_dict(self):
        """The present entries as a dict of arrays (views)."""
        return {n: self[n] for n in self.keys()}

    def composite(self):
        """The noisy radiance: ``render --denoiser off``'s composite and interleave, (h, w, 3)."""
        ffi, lib = _lib()
        out = np.empty((self.height, self.width, 3), np.float32)
        lib.tandem_capture_composite(self._h, _ptr(out, "float *"))
        return out

    def write(self, path):
        """A Tandem capture EXR (every present entry, the camera)."""
        _check(_lib()[1].tandem_capture_write(self._h, _str(path)))


def read_capture(path, map=None, prev=None):
    """A Tandem capture, or another renderer's frame through a mapping (``map``: a JSON file
    from data/mappings/ or yours; ``prev``: the frame before, for motion from positions)."""
    ffi, lib = _lib()
    h = lib.tandem_capture_read(_str(path), _str(map) if map else ffi.NULL,
                                prev._h if prev is not None else ffi.NULL)
    return Capture(_handle_=_handle(h))


def list_captures(directory, map=None):
    """The frames of a capture directory (DIR or DIR/capture), in order."""
    ffi, lib = _lib()
    return json.loads(_take_string(lib.tandem_capture_list(_str(directory),
                                                           _str(map) if map else ffi.NULL)))


# ---- rendering ------------------------------------------------------------------------------
_python_plugin = None


def _install_python_plugin():
    """The package's own host denoiser plugin: python:MODULE:CALLABLE denoisers run in this
    process through tandem._host (as the tandem command's bridge runs them)."""
    global _python_plugin
    if _python_plugin is not None:
        return
    ffi, lib = _lib()
    states = {}

    @ffi.callback("int(const tandem_host_denoiser_create_info *, void **, char *, uint32_t)")
    def create(ci, state, err, cap):
        try:
            runner = _host.create(ffi.string(ci.options).decode(), ci.width, ci.height,
                                  ci.precision)
        except BaseException as e:  # (the message goes back to Tandem)
            _error(ffi, err, cap, e)
            return 1
        h = ffi.new_handle(runner)
        states[h] = runner
        state[0] = h
        return 0

    @ffi.callback("void(void *)")
    def destroy(state):
        for k in list(states):
            if k == state:
                del states[k]

    @ffi.callback("int(void *, const tandem_frame_settings *, const tandem_host_denoiser_io *, "
                  "char *, uint32_t)")
    def run(state, settings, io, err, cap):
        try:
            runner = ffi.from_handle(state)
            px = io.width * io.height
            ents = [ffi.buffer(io.entries[e], px * c * 4) if io.entries[e] != ffi.NULL else None
                    for e, (_, c) in enumerate(_host.ENTRIES)]
            rad = ffi.buffer(io.radiance, px * 16) if io.radiance != ffi.NULL else None
            runner.run(ffi.buffer(settings, settings.struct_size), ents, rad,
                       ffi.buffer(io.output, px * 16))
        except BaseException as e:
            _error(ffi, err, cap, e)
            return 1
        return 0

    host = ffi.new("tandem_host_denoiser_plugin *")
    host.struct_size = ffi.sizeof("tandem_host_denoiser_plugin")
    host.reads = ((1 << 18) - 1) | (1 << 63)
    host.create, host.destroy, host.run = create, destroy, run
    desc = ffi.new("tandem_plugin *")
    name = ffi.new("char[]", b"python")
    text = ffi.new("char[]", b"Python denoisers in the tandem package's process")
    desc.struct_size = ffi.sizeof("tandem_plugin")
    desc.abi_version, desc.kind = 1, 3
    desc.name, desc.description, desc.host_denoiser = name, text, host
    _python_plugin = (desc, host, name, text, create, destroy, run, states)
    lib.tandem_set_python_denoiser(desc)


def _error(ffi, err, cap, e):
    import traceback
    msg = "".join(traceback.format_exception(type(e), e, e.__traceback__)).rstrip()
    data = msg.encode(errors="replace")[:max(0, cap - 1)]
    ffi.memmove(err, data + b"\0", len(data) + 1)


def _denoiser_name(denoiser):
    if denoiser is None or isinstance(denoiser, str):
        return denoiser
    return _host.register(denoiser)  # a factory or class: run in this process


class Renderer:
    """``tandem render``'s pipeline (``tandem reference``'s with reference=True), frame by frame,
    on a scene path or a loaded :class:`Scene` (loaded once, shared by renderers):

        r = Renderer("data/scenes/cornell.gltf", frontend="vk", denoiser="svgf", size=(320, 180))
        f = r.frame(0)            # dict: radiance, display, contract (a Capture)

    Options are render's by their command-line names ('_' for '-'): frontend, denoiser (a name,
    "python:MODULE:CALLABLE", or a factory such as a class: run in this process), size,
    precision, bounces, fps, camera, threads, lights, taa, tonemap, exposure, bloom, spp,
    render_scale and upscaler (traced at size x render_scale and upscaled: ``radiance`` and
    ``display`` at size, the contract at ``render_width`` x ``render_height``),
    estimator, the scene options (env, camera_path, ...), params (the denoiser's parameters). A frame that
    follows the one before continues the history; any other restarts it.
    """

    def __init__(self, scene, reference=False, **options):
        ffi, lib = _lib()
        options = dict(options)
        self.scene = scene  # (a Scene: loaded once, kept as long as the renderer)
        if not isinstance(scene, Scene):
            options["scene"] = os.fspath(scene)
        if "size" in options:
            options["size"] = list(options["size"])
        if "denoiser" in options:
            options["denoiser"] = _denoiser_name(options["denoiser"])
            if options["denoiser"] and options["denoiser"].startswith("python:"):
                _install_python_plugin()
        self.reference_mode = bool(reference)
        text = json.dumps(options).encode()
        h = (lib.tandem_renderer_open_scene(scene._h, text, int(reference))
             if isinstance(scene, Scene) else lib.tandem_renderer_open(text, int(reference)))
        self._h = ffi.gc(_handle(h), lib.tandem_renderer_free)
        w, h = ffi.new("uint32_t *"), ffi.new("uint32_t *")
        lib.tandem_renderer_size(self._h, w, h)
        self.width, self.height = w[0], h[0]
        lib.tandem_renderer_render_size(self._h, w, h)  # (the contract's: render_scale < 1)
        self.render_width, self.render_height = w[0], h[0]
        self.denoiser = ffi.string(lib.tandem_renderer_denoiser(self._h)).decode() or None

    def frame(self, f, contract=True, display=True):
        """Frame f: ``radiance`` (render's frame_NNNN.exr), ``display`` (its PNG's pixels) and
        ``contract`` (a Capture: what render --capture writes)."""
        ffi, lib = _lib()
        rgb = np.empty((self.height, self.width, 3), np.float32)
        disp = np.empty((self.height, self.width, 3), np.uint8) if display else None
        cap = Capture(self.render_width, self.render_height) if contract else None
        _check(lib.tandem_renderer_frame(self._h, f, _ptr(rgb, "float *"),
                                         _ptr(disp, "uint8_t *"),
                                         cap._h if cap is not None else ffi.NULL))
        return {"frame": f, "radiance": rgb, "display": disp, "contract": cap}

    def reference(self, f):
        """Frame f's reference: ``radiance`` (the mean), ``variance`` (of one sample's
        luminance), ``spp`` and ``rel_error`` (the mean relative standard error left)."""
        ffi, lib = _lib()
        rgb = np.empty((self.height, self.width, 3), np.float32)
        var = np.empty((self.height, self.width), np.float32)
        spp, err = ffi.new("uint32_t *"), ffi.new("double *")
        _check(lib.tandem_renderer_reference(self._h, f, _ptr(rgb, "float *"),
                                             _ptr(var, "float *"), spp, err))
        return {"frame": f, "radiance": rgb, "variance": var, "spp": spp[0],
                "rel_error": err[0]}


def render(scene, frames=8, start=0, **options):
    """Frames [start, start + frames) as render runs them: a list of frame dicts."""
    r = Renderer(scene, **options)
    return [r.frame(f) for f in range(start, start + frames)]


def reference(scene, frames=8, start=0, **options):
    """References of frames [start, start + frames): estimator "unbiased" (default) or
    "realtime" (the matched reference), spp, bounces, until_noise, ..."""
    r = Renderer(scene, reference=True, **options)
    return [r.reference(f) for f in range(start, start + frames)]


# ---- metrics --------------------------------------------------------------------------------
_METRICS = ("relmse", "smape", "rmse", "psnr", "ssim", "flip", "temporal", "mc_temporal",
            "disoccluded", "worth_relmse", "worth_flip", "nonfinite")
_SUMMARY = ("relmse", "smape", "rmse", "psnr", "ssim", "flip", "temporal", "lag", "mc_temporal",
            "flicker", "flicker_ref", "disocclusion_lag", "worth_relmse", "worth_flip", "changes",
            "disocclusions", "nonfinite")


def _image(a, name, shape=None):
    a = np.ascontiguousarray(a, dtype=np.float32)
    if shape is not None and a.shape != shape:
        raise TandemError("metrics: %s has shape %s, expected %s" % (name, a.shape, shape))
    return a


def auto_exposure(references):
    """eval's exposure: the references' geometric-mean luminance to 0.18 (a list of images or
    one)."""
    refs = np.ascontiguousarray(np.asarray(references, np.float32))
    if refs.ndim == 3:
        refs = refs[None]
    _, lib = _lib()
    return lib.tandem_auto_exposure(_ptr(refs, "float *"), refs.shape[2], refs.shape[1],
                                    refs.shape[0])


class Sequence:
    """A sequence evaluated frame by frame as ``tandem eval --metrics-on cpu`` does (the same C
    code): ``add(out, ref, ...)`` returns the frame's metrics, ``summary()`` the means (and the
    lag, flicker, ...)."""

    def __init__(self, width, height, exposure, ppd=0.0):
        ffi, lib = _lib()
        self.width, self.height = width, height
        self._h = ffi.gc(_handle(lib.tandem_sequence_new(width, height, exposure, ppd)),
                         lib.tandem_sequence_free)

    def add(self, out, ref, frame=None, variance=None, motion=None, depth=None, worth_flip=False,
            flip_map=False):
        ffi, lib = _lib()
        shape = (self.height, self.width, 3)
        out, ref = _image(out, "out", shape), _image(ref, "ref", shape)
        var = None if variance is None else _image(variance, "variance", shape[:2])
        mot = None if motion is None else _image(motion, "motion", shape)
        dep = None if depth is None else _image(np.reshape(depth, shape[:2]), "depth", shape[:2])
        fmap = np.empty(shape[:2], np.float32) if flip_map else None
        m = ffi.new("tandem_metrics *")
        self._n = getattr(self, "_n", 0)
        _check(lib.tandem_sequence_add(self._h, self._n if frame is None else frame,
                                       _ptr(out, "float *"), _ptr(ref, "float *"),
                                       _ptr(var, "float *"), _ptr(mot, "float *"),
                                       _ptr(dep, "float *"), int(worth_flip), m,
                                       _ptr(fmap, "float *")))
        self._n += 1
        d = {k: getattr(m, k) for k in _METRICS}
        if flip_map:
            d["flip_map"] = fmap
        return d

    def summary(self):
        ffi, lib = _lib()
        s = ffi.new("tandem_summary *")
        lib.tandem_sequence_summary(self._h, s)
        return {k: getattr(s, k) for k in _SUMMARY}


def metrics(out, ref, exposure=None, ppd=0.0, variance=None):
    """One image's metrics against a reference (exposure: eval's auto from the reference)."""
    ref = _image(ref, "ref")
    if exposure is None:
        exposure = auto_exposure(ref)
    seq = Sequence(ref.shape[1], ref.shape[0], exposure, ppd)
    return seq.add(out, ref, variance=variance)


def evaluate(out, reference=None, matched_reference=None, report=None, exposure=None, ppd=None,
             metrics_on="cpu"):
    """``tandem eval`` of a run folder (written by render or denoise): what its metrics.json
    holds."""
    opts = {"out": os.fspath(out), "metrics_on": metrics_on}
    for k, v in (("reference", reference), ("matched_reference", matched_reference),
                 ("report", report)):
        if v is not None:
            opts[k] = os.fspath(v)
    if exposure is not None:  # (eval's --exposure: "auto" or an EV100)
        opts["exposure"] = str(exposure)
    if ppd is not None:
        opts["ppd"] = float(ppd)
    return json.loads(_take_string(_lib()[1].tandem_eval(json.dumps(opts).encode())))


# ---- training data --------------------------------------------------------------------------
def dataset(spec, out, shard=None):
    """``tandem dataset``: spec (a JSON file, or a dict written beside the output as
    spec.json) rendered into out; returns the manifest."""
    if isinstance(spec, dict):
        os.makedirs(out, exist_ok=True)
        path = os.path.join(out, "spec.json")
        with open(path, "w") as f:
            json.dump(spec, f, indent=1)
        spec = path
    _, lib = _lib()
    ffi = _lib()[0]
    return json.loads(_take_string(lib.tandem_dataset(_str(spec), _str(out),
                                                      _str(shard) if shard else ffi.NULL)))


# ---- the denoiser leaderboard ----------------------------------------------------------------
def rank(suite, denoisers, out, cache=None, bootstrap=None, report=True, regions=False):
    """``tandem rank``: denoisers (a list, or "a,b,c"; each may carry settings,
    "recurrent@taa=0.2@atrous=5") over a suite (a JSON file, a shipped
    suite's name: "quick", "standard", or a dict: written as out/suite.json, its relative paths
    taken from the current directory) into out; returns rank.json (docs/rank.md). regions: the
    error per region too (``--regions``)."""
    if isinstance(suite, dict):
        os.makedirs(out, exist_ok=True)
        suite = json.loads(json.dumps(suite))
        for seq in suite.get("sequences", []):
            for k in ("scene", "env", "camera_path"):
                v = seq.get(k) if isinstance(seq, dict) else None
                if isinstance(v, str) and v not in ("orbit", "dolly", "flythrough"):
                    seq[k] = os.path.abspath(v)
        path = os.path.join(out, "suite.json")
        with open(path, "w") as f:
            json.dump(suite, f, indent=1)
        suite = path
    if not isinstance(denoisers, str):
        denoisers = ",".join(denoisers)
    ffi, lib = _lib()
    return json.loads(_take_string(lib.tandem_rank(
        _str(suite), _str(denoisers), _str(out), _str(cache) if cache else ffi.NULL,
        int(bootstrap or 0), 1 if report else 0, 1 if regions else 0)))


def load_dataset(directory):
    """The frames of a dataset (every manifest in it: the whole run's or its shards'), each a
    dict of arrays: the contract's entries, noisy, matched (and unbiased) with their variance,
    the camera; with "sequence" and "frame"."""
    import glob
    frames = []
    for m in sorted(glob.glob(os.path.join(directory, "manifest*.json"))):
        man = json.load(open(m))
        for e in man["frames"]:
            seq_dir = os.path.join(directory, e["sequence"])
            files = e["files"]
            if "npz" in files:
                with np.load(os.path.join(seq_dir, files["npz"])) as z:
                    d = {k: z[k] for k in z.files}
            else:
                cap = read_capture(os.path.join(seq_dir, files["capture"]))
                d = {k: np.array(v) for k, v in cap.to_dict().items()}
                cam = cap.camera  # (as the .npz holds them: m[row, col])
                for k in ("view", "proj", "prev_view", "prev_proj"):
                    d[k] = cam[k].reshape(4, 4).T.copy()
                d["jitter"] = cam["jitter"].copy()
                d.update(_read_rgb_exr(seq_dir, files))
            d["sequence"], d["frame"] = e["sequence"], e["frame"]
            frames.append(d)
    frames.sort(key=lambda d: (d["sequence"], d["frame"]))
    return frames


def _read_rgb_exr(seq_dir, files):
    """noisy, matched, unbiased of an EXR dataset through the capture reader's mapping-free path:
    read with OpenImageIO where present (Debian's python3-openimageio)."""
    import OpenImageIO as oiio
    d = {}
    for k in ("noisy", "matched", "unbiased"):
        if k in files:
            img = oiio.ImageInput.open(os.path.join(seq_dir, files[k]))
            px = img.read_image("float")
            img.close()
            d[k] = np.ascontiguousarray(px[..., :3])
            if px.shape[2] > 3:
                d[k + "_variance"] = np.ascontiguousarray(px[..., 3])
    return d
