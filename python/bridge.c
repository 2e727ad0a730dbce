/* python/bridge.c: the Python bridge, a host denoiser plugin (include/tandem/tandem_plugin.h)
 * that runs `--denoiser python:MODULE:CALLABLE` inside the tandem command: it starts Debian's
 * Python 3 in the process (once), puts the package's parent directory (this file's directory's
 * parent) first on sys.path, and hands each frame to tandem._host, the same runner the package
 * uses in a Python process, as memoryviews over Tandem's host buffers (no copy). A Python
 * exception fails the frame with its traceback as the message.
 * Entry point: tandem_plugin_entry. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "tandem/tandem_plugin.h"

#include <dlfcn.h>
#include <stdio.h>
#include <string.h>

#define EXPORT __attribute__((visibility("default")))

/* The pending Python exception as text (its traceback) into err; clears it. */
static void exception_text(char *err, uint32_t cap)
{
    PyObject *type, *value, *tb;
    PyErr_Fetch(&type, &value, &tb);
    PyErr_NormalizeException(&type, &value, &tb);
    snprintf(err, cap, "Python raised an exception");
    PyObject *mod = PyImport_ImportModule("traceback");
    PyObject *lines = mod && value
                          ? PyObject_CallMethod(mod, "format_exception", "OOO",
                                                type ? type : Py_None, value, tb ? tb : Py_None)
                          : NULL;
    PyObject *empty = PyUnicode_FromString("");
    PyObject *joined = lines && empty ? PyUnicode_Join(empty, lines) : NULL;
    const char *text = joined ? PyUnicode_AsUTF8(joined) : NULL;
    if (text)
        snprintf(err, cap, "%s", text);
    size_t n = strlen(err);
    while (n && err[n - 1] == '\n') /* (the message ends where Tandem's line does) */
        err[--n] = 0;
    Py_XDECREF(joined);
    Py_XDECREF(empty);
    Py_XDECREF(lines);
    Py_XDECREF(mod);
    Py_XDECREF(type);
    Py_XDECREF(value);
    Py_XDECREF(tb);
    PyErr_Clear();
}

/* The package's parent directory (this shared object lies in .../tandem/) first on sys.path. */
static int add_package_path(void)
{
    Dl_info info;
    if (!dladdr((void *)add_package_path, &info) || !info.dli_fname)
        return 0;
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", info.dli_fname);
    for (int up = 0; up < 2; up++) {
        char *slash = strrchr(dir, '/');
        if (!slash)
            return 0;
        *slash = 0;
    }
    PyObject *path = PySys_GetObject("path"); /* (borrowed) */
    PyObject *d = PyUnicode_FromString(dir);
    int rc = path && d ? PyList_Insert(path, 0, d) : -1;
    Py_XDECREF(d);
    return rc;
}

static int bridge_create(const tandem_host_denoiser_create_info *ci, void **state, char *err,
                         uint32_t cap)
{
    if (!Py_IsInitialized()) {
        /* Tandem loads this plugin with its symbols local: libpython's go global again, so
         * that extension modules (numpy's, torch's) find them */
        Dl_info li;
        if (dladdr((void *)Py_InitializeEx, &li) && li.dli_fname)
            dlopen(li.dli_fname, RTLD_NOW | RTLD_GLOBAL | RTLD_NOLOAD);
        Py_InitializeEx(0);
        add_package_path();
        PyEval_SaveThread(); /* (every call takes the interpreter with PyGILState_Ensure) */
    }
    PyGILState_STATE g = PyGILState_Ensure();
    int rc = 0;
    PyObject *mod = PyImport_ImportModule("tandem._host");
    PyObject *obj = mod ? PyObject_CallMethod(mod, "create", "sIII", ci->options, ci->width,
                                              ci->height, ci->precision)
                        : NULL;
    if (!obj) {
        exception_text(err, cap);
        rc = 1;
    }
    *state = obj;
    Py_XDECREF(mod);
    PyGILState_Release(g);
    return rc;
}

static void bridge_destroy(void *state)
{
    if (!state)
        return;
    PyGILState_STATE g = PyGILState_Ensure();
    Py_DECREF((PyObject *)state);
    PyGILState_Release(g);
}

static PyObject *view(const void *p, size_t bytes, int flags)
{
    if (!p)
        Py_RETURN_NONE;
    return PyMemoryView_FromMemory((char *)p, (Py_ssize_t)bytes, flags);
}

/* components of each entry, in tandem_entry order */
static const uint32_t comps[TANDEM_ENTRY_COUNT] = {3, 3, 3, 3, 1, 3, 1, 1, 3,
                                                   2, 2, 3, 2, 3, 4, 2, 3, 1};

static int bridge_run(void *state, const tandem_frame_settings *s,
                      const tandem_host_denoiser_io *io, char *err, uint32_t cap)
{
    PyGILState_STATE g = PyGILState_Ensure();
    int rc = 0;
    size_t px = (size_t)io->width * io->height;
    PyObject *entries = PyList_New(TANDEM_ENTRY_COUNT);
    for (int e = 0; entries && e < TANDEM_ENTRY_COUNT; e++)
        PyList_SET_ITEM(entries, e, view(io->entries[e], px * comps[e] * 4, PyBUF_READ));
    PyObject *settings = view(s, s->struct_size, PyBUF_READ);
    PyObject *radiance = view(io->radiance, px * 16, PyBUF_READ);
    PyObject *output = view(io->output, px * 16, PyBUF_WRITE);
    PyObject *r = entries && settings && radiance && output
                      ? PyObject_CallMethod((PyObject *)state, "run", "OOOO", settings, entries,
                                            radiance, output)
                      : NULL;
    if (!r) {
        exception_text(err, cap);
        rc = 1;
    }
    Py_XDECREF(r);
    Py_XDECREF(entries);
    Py_XDECREF(settings);
    Py_XDECREF(radiance);
    Py_XDECREF(output);
    PyGILState_Release(g);
    return rc;
}

static const tandem_host_denoiser_plugin host = {
    .struct_size = sizeof host,
    .reads = ((UINT64_C(1) << TANDEM_ENTRY_COUNT) - 1) | TANDEM_INPUT_RADIANCE,
    .create = bridge_create,
    .destroy = bridge_destroy,
    .run = bridge_run,
};

static const tandem_plugin desc = {
    .struct_size = sizeof desc,
    .abi_version = TANDEM_PLUGIN_ABI_VERSION,
    .kind = TANDEM_PLUGIN_HOST_DENOISER,
    .name = "python",
    .description = "Python denoisers (python:MODULE:CALLABLE) through Debian's Python 3",
    .host_denoiser = &host,
};

EXPORT const tandem_plugin *tandem_plugin_entry(uint32_t abi_version)
{
    return abi_version == TANDEM_PLUGIN_ABI_VERSION ? &desc : NULL;
}
