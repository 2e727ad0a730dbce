"""cffi (ABI mode) over libtandem_api.so, read from tandem_api.h beside this file; loaded on
first use so that importing the package (as the tandem command's Python bridge does) costs
nothing."""
import os
import re

import cffi

_HERE = os.path.dirname(os.path.abspath(__file__))
_ffi = None
_lib = None

# The host denoiser plugin ABI, as tandem_plugin.h declares it (the part the package's own
# Python denoiser plugin fills); its sizes are checked against the library's.
_PLUGIN_CDEF = """
typedef struct tandem_frame_settings {
    uint32_t struct_size, width, height, frame_index, reset;
    float view[16], proj[16], prev_view[16], prev_proj[16];
    float jitter[2], prev_jitter[2], camera_position[3];
    float pixel_spread, time_s, dt_s;
    uint32_t bounces, sample, precision, half_indirect;
} tandem_frame_settings;
typedef struct tandem_host_denoiser_create_info {
    uint32_t struct_size, width, height, precision;
    const char *options;
} tandem_host_denoiser_create_info;
typedef struct tandem_host_denoiser_io {
    uint32_t struct_size, width, height;
    const void *entries[18];
    const float *radiance;
    float *output;
} tandem_host_denoiser_io;
typedef struct tandem_host_denoiser_plugin {
    uint32_t struct_size;
    uint64_t reads;
    int (*create)(const tandem_host_denoiser_create_info *, void **, char *, uint32_t);
    void (*destroy)(void *);
    int (*run)(void *, const tandem_frame_settings *, const tandem_host_denoiser_io *, char *,
               uint32_t);
} tandem_host_denoiser_plugin;
typedef struct tandem_plugin {
    uint32_t struct_size, abi_version, kind;
    const char *name, *description;
    const void *frontend, *denoiser;
    const tandem_host_denoiser_plugin *host_denoiser;
} tandem_plugin;
"""


def _cdef_of(header):
    text = open(header).read()
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    lines = [l for l in text.splitlines()
             if not l.lstrip().startswith("#") and 'extern "C"' not in l]
    body = "\n".join(lines)
    # (the closing brace of extern "C")
    return re.sub(r"\n}\s*$", "\n", body.rstrip() + "\n")


def get():
    """(ffi, lib), loaded once."""
    global _ffi, _lib
    if _lib is None:
        ffi = cffi.FFI()
        ffi.cdef(_cdef_of(os.path.join(_HERE, "tandem_api.h")))
        ffi.cdef(_PLUGIN_CDEF)
        # (never unloaded: at the interpreter's exit the threads its libraries started, OpenMP's
        # pool among them, outlive the module that holds the library)
        lib = ffi.dlopen(os.path.join(_HERE, "libtandem_api.so"),
                         ffi.RTLD_NOW | ffi.RTLD_NODELETE)
        _ffi, _lib = ffi, lib
    return _ffi, _lib
