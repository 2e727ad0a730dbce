"""Python denoisers inside Tandem's frame loop (docs/python.md).

`--denoiser python:MODULE:CALLABLE` names a factory: Tandem calls ``CALLABLE(width, height)``
once per run (a class is such a factory) and the object it returns once per frame with a
:class:`DenoiserFrame`; that call returns the denoised linear radiance, an array of
``(height, width, 3)`` floats. The object keeps whatever state it needs between frames (its
previous output, for a recurrent denoiser). The tandem command runs this module through its
Python bridge; the package runs it in the Python process itself. Only numpy is imported here.
"""
import importlib

import numpy as np

# tandem_entry order and components (include/tandem/tandem_plugin.h)
ENTRIES = (("albedo", 3), ("normal", 3), ("geo_normal", 3), ("position", 3), ("depth", 1),
           ("motion", 3), ("roughness", 1), ("metallic", 1), ("emission", 3), ("vis_id", 2),
           ("vis_bary", 2), ("throughput", 3), ("rng", 2), ("hf", 3), ("lf_sh", 4),
           ("lf_cocg", 2), ("spec", 3), ("path", 1))
_UINT = {"vis_id", "rng", "path"}

# tandem_frame_settings: 5 uint32, 64 + 10 floats, 3 uint32 (then half_indirect, where the
# struct's size has it)
_SETTINGS_BYTES = 4 * (5 + 74 + 3)

# denoisers the package registered by object (python:__tandem__:ID)
_REGISTERED = {}


def register(factory):
    """A factory (or class) under a name Tandem can be given: returns "python:__tandem__:ID"."""
    key = str(len(_REGISTERED))
    _REGISTERED[key] = factory
    return "python:__tandem__:" + key


def resolve(spec):
    module, sep, name = spec.partition(":")
    if not sep or not module or not name:
        raise ValueError("python:%s: expected python:MODULE:CALLABLE" % spec)
    if module == "__tandem__":
        return _REGISTERED[name]
    obj = importlib.import_module(module)
    for part in name.split("."):
        obj = getattr(obj, part)
    if not callable(obj):
        raise TypeError("python:%s: %s.%s is not callable" % (spec, module, name))
    return obj


class DenoiserFrame:
    """One frame as a Python denoiser receives it: views of Tandem's buffers (no copy).

    ``radiance``: the noisy composite, (h, w, 3); ``frame[name]`` or ``entries[name]``: a
    contract entry, (h, w, components) float32 (uint32 for vis_id, rng, path); ``index``,
    ``reset`` (the history is invalid: first frame or a cut), the camera: ``view``, ``proj``,
    ``prev_view``, ``prev_proj`` (4 x 4, numpy's m[row, col]), ``jitter``, ``prev_jitter``
    (pixels), ``position``, ``pixel_spread`` (radians per pixel), ``time``, ``dt`` (seconds),
    ``bounces``, ``sample``, ``half_indirect`` (``--bounces half``).
    """

    def __init__(self, width, height, settings, entries, radiance):
        self.width, self.height = width, height
        u = np.frombuffer(settings, dtype=np.uint32, count=_SETTINGS_BYTES // 4)
        f = np.frombuffer(settings, dtype=np.float32, count=_SETTINGS_BYTES // 4)
        self.index, self.reset = int(u[3]), bool(u[4])
        mats = f[5:69].reshape(4, 4, 4)  # four column-major matrices
        self.view, self.proj, self.prev_view, self.prev_proj = (m.T for m in mats)
        self.jitter, self.prev_jitter = f[69:71], f[71:73]
        self.position = f[73:76]
        self.pixel_spread, self.time, self.dt = float(f[76]), float(f[77]), float(f[78])
        self.bounces, self.sample = int(u[79]), int(u[80])
        self.half_indirect = len(settings) >= _SETTINGS_BYTES + 4 and bool(
            np.frombuffer(settings, dtype=np.uint32, count=1, offset=_SETTINGS_BYTES)[0])
        self.entries = {}
        for (name, comps), buf in zip(ENTRIES, entries):
            if buf is not None:
                dt = np.uint32 if name in _UINT else np.float32
                self.entries[name] = np.frombuffer(buf, dtype=dt).reshape(height, width, comps)
        self.radiance = None
        if radiance is not None:
            self.radiance = np.frombuffer(radiance, dtype=np.float32).reshape(height, width, 4)[..., :3]

    def __getitem__(self, name):
        return self.entries[name]


class Runner:
    """What the bridge (or the package's own host plugin) holds for a run."""

    def __init__(self, factory, width, height):
        self.width, self.height = width, height
        self.denoise = factory(width, height)

    def run(self, settings, entries, radiance, output):
        frame = DenoiserFrame(self.width, self.height, settings, entries, radiance)
        out = np.asarray(self.denoise(frame))
        if out.shape[:2] != (self.height, self.width) or out.ndim != 3 or out.shape[2] < 3:
            raise ValueError("the denoiser returned an array of shape %s; expected (%d, %d, 3)"
                             % (out.shape, self.height, self.width))
        dst = np.frombuffer(output, dtype=np.float32).reshape(self.height, self.width, 4)
        dst[..., :3] = out[..., :3]
        dst[..., 3] = 1.0


def create(options, width, height, precision):
    return Runner(resolve(options), width, height)
