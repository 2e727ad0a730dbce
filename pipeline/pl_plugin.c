/* pipeline/pl_plugin.c: plugins from shared objects (include/tandem/tandem_plugin.h): the
 * loader and its checks, the front-end adapter (a plugin that fills host buffers becomes a
 * pl_frontend_ops) and the denoiser adapter (a denoiser plugin becomes a pl_denoiser_ops: the
 * built-in back-end's composite of the noisy radiance, then the plugin's commands, timed), and
 * the host adapter (a host denoiser plugin, and Python denoisers through the Python bridge or
 * the Python package's own description: the composite, the contract and radiance to the host,
 * the plugin's run, its radiance back up). A plugin's description is checked once when it is
 * loaded: ABI version, kind, the operations it must have, the entries it declares.
 * Entry points: pl_plugin_frontend_ops, pl_plugin_denoiser_ops, pl_python_denoiser_ops,
 * pl_python_set, pl_dnp_create, pl_dnp_destroy, pl_dnp_record, pl_dnp_reads, pl_dnp_name,
 * pl_plugin_settings. */
#include "pipeline/pl_internal.h"
#include "shaders/sampling.h"

#include <dlfcn.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* The ABI's entry numbers are the contract table's. */
#define PL_SAME(ID) _Static_assert((int)TANDEM_ENTRY_##ID == (int)TND_CT_##ID, #ID);
PL_SAME(ALBEDO) PL_SAME(NORMAL) PL_SAME(GEO_NORMAL) PL_SAME(POSITION) PL_SAME(DEPTH)
PL_SAME(MOTION) PL_SAME(ROUGHNESS) PL_SAME(METALLIC) PL_SAME(EMISSION) PL_SAME(VIS_ID)
PL_SAME(VIS_BARY) PL_SAME(THROUGHPUT) PL_SAME(RNG) PL_SAME(HF) PL_SAME(LF_SH) PL_SAME(LF_COCG)
PL_SAME(SPEC) PL_SAME(PATH)
#undef PL_SAME
/* ABI 1 carries the contract's first TANDEM_ENTRY_COUNT entries (those of contract version 2):
 * spec_hit and diffuse_view, added since, are not exchanged with plugins (a plugin front-end's
 * frames leave them at their defaults: 0, denoisers reproject reflections by surface motion
 * there; 1, the histories keep the diffuse lobe's view factor as before version 4) */
_Static_assert((int)TANDEM_ENTRY_COUNT == (int)TND_CT_SPEC_HIT &&
                   (int)TND_CT_DIFFUSE_VIEW + 1 == (int)TND_CT_COUNT,
               "the contract's entries");
_Static_assert((int)TANDEM_PRECISION_FLOAT32 == (int)TND_PRECISION_F32 &&
                   (int)TANDEM_PRECISION_PACKED == (int)TND_PRECISION_PACKED,
               "precisions");

#define ALL_ENTRIES ((UINT64_C(1) << TANDEM_ENTRY_COUNT) - 1)

/* A field of a struct the plugin filled, when its struct_size covers it. */
#define HAS_FIELD(p, type, field)                                                                  \
    ((p)->struct_size >= offsetof(type, field) + sizeof(((type *)0)->field))

typedef struct pl_plugin {
    void *dl;
    const tandem_plugin *desc;
    char path[1024];
} pl_plugin;

static void plugin_close(pl_plugin *p)
{
    if (!p)
        return;
    if (p->dl)
        dlclose(p->dl);
    free(p);
}

static const char *kind_name(uint32_t k)
{
    return k == TANDEM_PLUGIN_FRONTEND ? "front-end" : k == TANDEM_PLUGIN_DENOISER ? "denoiser"
                                                                                 : "unknown kind";
}

static tnd_result plugin_check(const char *path, const tandem_plugin *d, uint32_t kind);

/* Load PATH and check that it is a plugin of `kind` that Tandem can use. */
static tnd_result plugin_open(const char *path, uint32_t kind, pl_plugin **out)
{
    tnd_result res = TND_OK;
    *out = NULL;
    pl_plugin *p = calloc(1, sizeof *p);
    if (!p)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "plugin: out of memory");
    snprintf(p->path, sizeof p->path, "%s", path);
    /* dlopen searches the library path for a bare name: a plugin is a file */
    char full[1100];
    snprintf(full, sizeof full, "%s%s", strchr(path, '/') ? "" : "./", path);
    dlerror();
    if (!(p->dl = dlopen(full, RTLD_NOW | RTLD_LOCAL))) {
        const char *e = dlerror();
        res = tnd_fail(TND_ERR_IO, "plugin %s: cannot load: %s", path, e ? e : "unknown error");
        goto fail;
    }
    tandem_plugin_entry_fn entry;
    void *sym = dlsym(p->dl, TANDEM_PLUGIN_ENTRY_NAME);
    memcpy(&entry, &sym, sizeof entry); /* (object to function pointer, as POSIX allows) */
    if (!sym) {
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "plugin %s: no function %s: not a Tandem plugin",
                       path, TANDEM_PLUGIN_ENTRY_NAME);
        goto fail;
    }
    const tandem_plugin *d = entry(TANDEM_PLUGIN_ABI_VERSION);
    if (!d) {
        res = tnd_fail(TND_ERR_UNSUPPORTED, "plugin %s: does not speak plugin ABI version %u",
                       path, TANDEM_PLUGIN_ABI_VERSION);
        goto fail;
    }
    TND_TRY(plugin_check(path, d, kind));
    p->desc = d;
    *out = p;
    return TND_OK;
fail:
    plugin_close(p);
    return res;
}

/* A plugin's description checked: ABI, kind (a denoiser: either kind of denoiser), the
 * operations it must have, the entries it declares. */
static tnd_result plugin_check(const char *path, const tandem_plugin *d, uint32_t kind)
{
    tnd_result res = TND_OK;
    if (!HAS_FIELD(d, tandem_plugin, denoiser)) {
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                       "plugin %s: its description has struct_size %u, at least %zu expected",
                       path, d->struct_size, offsetof(tandem_plugin, denoiser) + sizeof(void *));
        goto fail;
    }
    if (d->abi_version != TANDEM_PLUGIN_ABI_VERSION) {
        res = tnd_fail(TND_ERR_UNSUPPORTED, "plugin %s: built for ABI version %u, Tandem speaks %u",
                       path, d->abi_version, TANDEM_PLUGIN_ABI_VERSION);
        goto fail;
    }
    const char *name = d->name ? d->name : "(unnamed)";
    bool denoiser = d->kind == TANDEM_PLUGIN_DENOISER || d->kind == TANDEM_PLUGIN_HOST_DENOISER;
    if (d->kind != kind && !(kind == TANDEM_PLUGIN_DENOISER && denoiser)) {
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "plugin %s (%s): a %s, not a %s", path, name,
                       kind_name(d->kind), kind_name(kind));
        goto fail;
    }
    if (kind == TANDEM_PLUGIN_FRONTEND) {
        const tandem_frontend_plugin *f = d->frontend;
        if (!f || !HAS_FIELD(f, tandem_frontend_plugin, render) || !f->create || !f->destroy ||
            !f->render) {
            res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                           "plugin %s (%s): its front-end lacks create, destroy or render", path,
                           name);
            goto fail;
        }
        if (f->writes & ~ALL_ENTRIES) {
            res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                           "plugin %s (%s): writes entries Tandem does not know (mask %#llx)",
                           path, name, (unsigned long long)(f->writes & ~ALL_ENTRIES));
            goto fail;
        }
        for (int e = 0; e < TANDEM_ENTRY_COUNT; e++)
            if ((TANDEM_ENTRIES_REQUIRED & TANDEM_ENTRY_BIT(e)) && !(f->writes & TANDEM_ENTRY_BIT(e))) {
                res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                               "plugin %s (%s): does not write the required entry '%s'", path,
                               name, tnd_ct_get((tnd_ct)e)->name);
                goto fail;
            }
    } else if (d->kind == TANDEM_PLUGIN_HOST_DENOISER) {
        const tandem_host_denoiser_plugin *n =
            HAS_FIELD(d, tandem_plugin, host_denoiser) ? d->host_denoiser : NULL;
        if (!n || !HAS_FIELD(n, tandem_host_denoiser_plugin, run) || !n->create || !n->destroy ||
            !n->run) {
            res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                           "plugin %s (%s): its host denoiser lacks create, destroy or run", path,
                           name);
            goto fail;
        }
        if (n->reads & ~(ALL_ENTRIES | TANDEM_INPUT_RADIANCE)) {
            res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                           "plugin %s (%s): reads entries Tandem does not know (mask %#llx)",
                           path, name,
                           (unsigned long long)(n->reads & ~(ALL_ENTRIES | TANDEM_INPUT_RADIANCE)));
            goto fail;
        }
    } else {
        const tandem_denoiser_plugin *n = d->denoiser;
        if (!n || !HAS_FIELD(n, tandem_denoiser_plugin, record) || !n->create || !n->destroy ||
            !n->record) {
            res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                           "plugin %s (%s): its denoiser lacks create, destroy or record", path,
                           name);
            goto fail;
        }
        if (n->reads & ~(ALL_ENTRIES | TANDEM_INPUT_RADIANCE)) {
            res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                           "plugin %s (%s): reads entries Tandem does not know (mask %#llx)",
                           path, name,
                           (unsigned long long)(n->reads & ~(ALL_ENTRIES | TANDEM_INPUT_RADIANCE)));
            goto fail;
        }
    }
fail:
    return res;
}

static const char *plugin_name(const pl_plugin *p)
{
    return p->desc->name ? p->desc->name : "(unnamed)";
}

void pl_plugin_settings(const pl_camera *cam, uint32_t w, uint32_t h, const pl_params *p,
                        const dn_frame *df, float dt, tnd_precision precision,
                        tandem_frame_settings *s)
{
    *s = (tandem_frame_settings){.struct_size = sizeof *s,
                                 .width = w,
                                 .height = h,
                                 .frame_index = cam->state.frame_index,
                                 .reset = df && df->reset,
                                 .pixel_spread = df ? df->pixel_spread : 0.0f,
                                 .time_s = (float)cam->time,
                                 .dt_s = dt,
                                 .bounces = p ? p->bounces : 1,
                                 .sample = p ? p->sample : 0,
                                 .precision = (uint32_t)precision,
                                 .half_indirect = p && p->half_indirect};
    memcpy(s->view, cam->state.view, sizeof s->view);
    memcpy(s->proj, cam->state.proj, sizeof s->proj);
    memcpy(s->prev_view, cam->state.prev_view, sizeof s->prev_view);
    memcpy(s->prev_proj, cam->state.prev_proj, sizeof s->prev_proj);
    memcpy(s->jitter, df ? df->jitter : cam->state.jitter, sizeof s->jitter);
    if (df)
        memcpy(s->prev_jitter, df->prev_jitter, sizeof s->prev_jitter);
    memcpy(s->camera_position, cam->position, sizeof s->camera_position);
}

/* ---- front-ends -------------------------------------------------------------------------------- */
typedef struct plugin_fe {
    pl_plugin *p;
    void *state;
    bool have_state;
    tnd_precision precision;
    pl_camera cam;
    uint32_t width, height;
    float dt;
} plugin_fe;

static void pfe_destroy(void *ctx)
{
    plugin_fe *f = ctx;
    if (!f)
        return;
    if (f->have_state)
        f->p->desc->frontend->destroy(f->state);
    plugin_close(f->p);
    free(f);
}

static tnd_result pfe_create(const tnd_scene *scene, const pl_frontend_desc *d, void **out)
{
    (void)scene; /* (the plugin traces its own scene; it gets the path) */
    tnd_result res = TND_OK;
    *out = NULL;
    plugin_fe *f = calloc(1, sizeof *f);
    if (!f)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "plugin: out of memory");
    f->precision = d->precision;
    TND_TRY(plugin_open(d->plugin, TANDEM_PLUGIN_FRONTEND, &f->p));
    char err[512] = "";
    tandem_frontend_create_info ci = {.struct_size = sizeof ci,
                                      .scene_path = d->scene_path ? d->scene_path : "",
                                      .threads = d->threads};
    if (f->p->desc->frontend->create(&ci, &f->state, err, sizeof err) != 0) {
        err[sizeof err - 1] = 0;
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "plugin %s (%s): create failed: %s", d->plugin,
                       plugin_name(f->p), err[0] ? err : "no message");
        goto fail;
    }
    f->have_state = true;
    *out = f;
    return TND_OK;
fail:
    pfe_destroy(f);
    return res;
}

static void pfe_describe(const void *ctx, char *buf, size_t cap)
{
    const plugin_fe *f = ctx;
    snprintf(buf, cap, "plugin %s (%s)%s%s", plugin_name(f->p), f->p->path,
             f->p->desc->description ? ": " : "",
             f->p->desc->description ? f->p->desc->description : "");
}

static const char *pfe_models(const void *ctx)
{
    (void)ctx;
    return "plugin (its own)";
}

static tnd_result pfe_set_frame(void *ctx, const tnd_scene_state *cur, const tnd_scene_state *prev,
                                uint32_t frame, uint32_t w, uint32_t h)
{
    plugin_fe *f = ctx;
    pl_camera_from_states(cur, prev, frame, &f->cam);
    f->width = w;
    f->height = h;
    f->dt = prev && cur->time > prev->time ? (float)(cur->time - prev->time) : 0.0f;
    return TND_OK;
}

static tnd_result pfe_render(void *ctx, const pl_params *p, tnd_frame *host, pl_timings *t)
{
    plugin_fe *f = ctx;
    const tandem_frontend_plugin *fp = f->p->desc->frontend;
    if (!host)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: a plugin front-end fills a host frame");
    if (host->width != f->width || host->height != f->height)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: host frame %ux%u, frame %ux%u",
                        host->width, host->height, f->width, f->height);
    pl_camera cam = f->cam;
    if (p && p->set_jitter)
        memcpy(cam.state.jitter, p->jitter, sizeof cam.state.jitter);
    float spread = 2.0f / (fabsf(cam.state.proj[5]) > 0 ? fabsf(cam.state.proj[5]) : 1.0f) /
                   (float)f->height;
    dn_frame df = {.pixel_spread = spread};
    memcpy(df.jitter, cam.state.jitter, sizeof df.jitter);
    tnd_jitter(cam.state.frame_index ? cam.state.frame_index - 1 : 0, df.prev_jitter);
    tandem_frame_settings s;
    pl_plugin_settings(&cam, f->width, f->height, p, &df, f->dt, f->precision, &s);
    tandem_host_frame hf = {.struct_size = sizeof hf, .width = f->width, .height = f->height};
    for (int e = 0; e < TANDEM_ENTRY_COUNT; e++)
        hf.entries[e] = (fp->writes & TANDEM_ENTRY_BIT(e)) ? host->data[e] : NULL;
    char err[512] = "";
    double t0 = tnd_now();
    if (fp->render(f->state, &s, &hf, err, sizeof err) != 0) {
        err[sizeof err - 1] = 0;
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "plugin %s (%s): frame %u: %s", f->p->path,
                        plugin_name(f->p), s.frame_index, err[0] ? err : "render failed");
    }
    if (t)
        *t = (pl_timings){1e3 * (tnd_now() - t0), 0.0, 0.0, 0.0};
    /* what it wrote is present; the derived entries follow from it every frame */
    for (int e = 0; e < TANDEM_ENTRY_COUNT; e++)
        host->present[e] = (fp->writes & TANDEM_ENTRY_BIT(e)) != 0;
    host->camera = cam.state;
    host->has_camera = true;
    tnd_result res = tnd_frame_derive(host, f->p->path);
    if (res == TND_OK)
        tnd_frame_quantize(host, f->precision);
    return res;
}

static const tnd_contract_gpu *pfe_contract(const void *ctx)
{
    (void)ctx;
    return NULL;
}

const pl_frontend_ops pl_plugin_frontend_ops = {
    .name = "plugin",
    .caps = 0, /* a host contract; no re-shading, reference or ray benchmark in ABI 1 */
    .create = pfe_create,
    .destroy = pfe_destroy,
    .describe = pfe_describe,
    .models = pfe_models,
    .set_frame = pfe_set_frame,
    .render = pfe_render,
    .contract = pfe_contract,
};

/* ---- denoisers --------------------------------------------------------------------------------- */
struct pl_dnp {
    pl_plugin *p;
    tnd_vk *vk;
    void *state;
    bool have_state;
    tnd_image out;
    tandem_vulkan vulkan;
};

void pl_dnp_destroy(pl_dnp *d)
{
    if (!d)
        return;
    if (d->vk && d->vk->device)
        vkDeviceWaitIdle(d->vk->device);
    if (d->have_state)
        d->p->desc->denoiser->destroy(d->state);
    if (d->out.image)
        tnd_image_destroy(d->vk, &d->out);
    plugin_close(d->p);
    free(d);
}

tnd_result pl_dnp_create(tnd_vk *vk, const char *path, uint32_t w, uint32_t h,
                         tnd_precision precision, pl_dnp **out)
{
    tnd_result res = TND_OK;
    *out = NULL;
    pl_dnp *d = calloc(1, sizeof *d);
    if (!d)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "plugin: out of memory");
    d->vk = vk;
    TND_TRY(plugin_open(path, TANDEM_PLUGIN_DENOISER, &d->p));
    const tandem_denoiser_plugin *n = d->p->desc->denoiser;
    if (!(n->precisions & TANDEM_PRECISION_BIT(precision))) {
        res = tnd_fail(TND_ERR_UNSUPPORTED,
                       "plugin %s (%s): does not accept the %s contract precision", path,
                       plugin_name(d->p), tnd_precision_name(precision));
        goto fail;
    }
    TND_TRY(tnd_image_create(vk,
                             &(tnd_image_desc){.width = w, .height = h,
                                               .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                               .name = "plugin.output"},
                             &d->out));
    d->vulkan = (tandem_vulkan){.struct_size = sizeof d->vulkan,
                                .instance = vk->instance,
                                .physical_device = vk->phys,
                                .device = vk->device,
                                .queue = vk->queue,
                                .queue_family = vk->queue_family,
                                .get_instance_proc_addr = vkGetInstanceProcAddr,
                                .get_device_proc_addr = vkGetDeviceProcAddr,
                                .api_version = vk->info.api_version};
    tandem_denoiser_create_info ci = {.struct_size = sizeof ci,
                                      .vulkan = &d->vulkan,
                                      .width = w,
                                      .height = h,
                                      .precision = (uint32_t)precision};
    char err[512] = "";
    TND_VK_TRY(vkDeviceWaitIdle(vk->device)); /* (it may submit to the queue) */
    if (n->create(&ci, &d->state, err, sizeof err) != 0) {
        err[sizeof err - 1] = 0;
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "plugin %s (%s): create failed: %s", path,
                       plugin_name(d->p), err[0] ? err : "no message");
        goto fail;
    }
    d->have_state = true;
    *out = d;
    return TND_OK;
fail:
    pl_dnp_destroy(d);
    return res;
}

uint64_t pl_dnp_reads(const pl_dnp *d)
{
    return d->p->desc->denoiser->reads;
}

const char *pl_dnp_name(const pl_dnp *d)
{
    return plugin_name(d->p);
}

const tnd_image *pl_dnp_output(const pl_dnp *d)
{
    return &d->out;
}

static tandem_image image_of(const tnd_image *i)
{
    return (tandem_image){i->image, i->view, i->format};
}

tnd_result pl_dnp_record(pl_dnp *d, VkCommandBuffer cmd, const tandem_frame_settings *s,
                         const tnd_contract_gpu *ct, const tnd_image *radiance)
{
    uint64_t reads = d->p->desc->denoiser->reads;
    tandem_denoiser_io io = {.struct_size = sizeof io, .output = image_of(&d->out)};
    for (int e = 0; e < TANDEM_ENTRY_COUNT; e++)
        if (reads & TANDEM_ENTRY_BIT(e))
            io.entries[e] = image_of(&ct->images[e]);
    if (reads & TANDEM_INPUT_RADIANCE)
        io.radiance = image_of(radiance);
    char err[512] = "";
    tnd_cmd_barrier(cmd);
    if (d->p->desc->denoiser->record(d->state, cmd, s, &io, err, sizeof err) != 0) {
        err[sizeof err - 1] = 0;
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "plugin %s (%s): frame %u: %s", d->p->path,
                        plugin_name(d->p), s->frame_index, err[0] ? err : "record failed");
    }
    tnd_cmd_barrier(cmd);
    return TND_OK;
}

/* ---- host denoisers: "python:MODULE:CALLABLE", and plugins of kind HOST_DENOISER ------------ */
/* The built-in back-end composites the noisy radiance; the contract and that radiance come to
 * the host, the plugin runs there (timed by the wall clock), its radiance goes up into the
 * output image the post chain reads. */
static const tandem_plugin *python_in_process; /* the Python package's own (pl_python_set) */

void pl_python_set(const tandem_plugin *d)
{
    python_in_process = d;
}

/* The Python bridge: TANDEM_PYTHON_BRIDGE, else beside the running program, in the build tree
 * (python/tandem/) or the installed package (../lib/python3/dist-packages/tandem/). */
static tnd_result python_bridge(char *out, size_t cap)
{
    static const char *const near[] = {"/python/tandem/", "/../lib/python3/dist-packages/tandem/"};
    const char *env = getenv("TANDEM_PYTHON_BRIDGE");
    if (env && *env) {
        snprintf(out, cap, "%s", env);
        return TND_OK;
    }
    char exe[1024];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n > 0) {
        exe[n] = 0;
        char *slash = strrchr(exe, '/');
        if (slash)
            *slash = 0;
        for (size_t i = 0; i < sizeof near / sizeof *near; i++) {
            snprintf(out, cap, "%s%s%s", exe, near[i], PL_PYTHON_BRIDGE);
            if (access(out, R_OK) == 0)
                return TND_OK;
        }
    }
    return tnd_fail(TND_ERR_IO,
                    "python: the bridge %s is not beside %s (build the project with Debian's "
                    "python3-dev, or set TANDEM_PYTHON_BRIDGE)", PL_PYTHON_BRIDGE,
                    n > 0 ? exe : "the program");
}

/* The built-in back-end in mode off (its composite of the noisy radiance, which a plugin may
 * read), with the plugin's frame size and precision: both adapters run their plugin after it. */
static tnd_result off_create(const pl_dn_desc *d, void **off)
{
    pl_dn_desc od = *d;
    od.params = NULL;
    od.data = pl_off_ops.data;
    od.npasses = pl_off_ops.info.npasses;
    return pl_off_ops.create(&od, off);
}

typedef struct hdn {
    void *off;          /* the built-in adapter's context (pl_off_ops) */
    pl_plugin *p;       /* the shared object (NULL: the Python package's own description) */
    const tandem_host_denoiser_plugin *h;
    void *state;
    bool have_state;
    tnd_vk *vk;
    tnd_image out;
    tnd_frame host;
    float *radiance, *output;
    uint32_t width, height;
    tnd_precision precision;
    double ms, ms_composite;
    char label[1100];
} hdn;

static void hdn_destroy(void *ctx)
{
    hdn *p = ctx;
    if (!p)
        return;
    if (p->have_state)
        p->h->destroy(p->state);
    if (p->out.image)
        tnd_image_destroy(p->vk, &p->out);
    tnd_frame_destroy(&p->host);
    free(p->radiance);
    free(p->output);
    plugin_close(p->p);
    pl_off_ops.destroy(p->off);
    free(p);
}

/* `path`: the plugin (python: NULL, `options` its MODULE:CALLABLE) */
static tnd_result hdn_open(const pl_dn_desc *d, const char *path, const char *options, hdn **out)
{
    tnd_result res = TND_OK;
    *out = NULL;
    hdn *p = calloc(1, sizeof *p);
    if (!p)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "host denoiser: out of memory");
    p->vk = d->vk;
    p->width = d->width, p->height = d->height, p->precision = d->precision;
    const tandem_plugin *desc = NULL;
    if (path) {
        snprintf(p->label, sizeof p->label, "plugin %s", path);
        TND_TRY(plugin_open(path, TANDEM_PLUGIN_HOST_DENOISER, &p->p));
        desc = p->p->desc;
    } else if (!*options || !strchr(options, ':')) {
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                       "--denoiser python:%s: expected python:MODULE:CALLABLE", options);
        goto fail;
    } else if (python_in_process) {
        snprintf(p->label, sizeof p->label, "python:%s", options);
        TND_TRY(plugin_check(p->label, python_in_process, TANDEM_PLUGIN_HOST_DENOISER));
        desc = python_in_process;
    } else {
        char bridge[1200];
        snprintf(p->label, sizeof p->label, "python:%s", options);
        TND_TRY(python_bridge(bridge, sizeof bridge));
        TND_TRY(plugin_open(bridge, TANDEM_PLUGIN_HOST_DENOISER, &p->p));
        desc = p->p->desc;
    }
    if (desc->kind != TANDEM_PLUGIN_HOST_DENOISER) {
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: a %s, not a host denoiser", p->label,
                       kind_name(desc->kind));
        goto fail;
    }
    p->h = desc->host_denoiser;
    size_t n = (size_t)d->width * d->height;
    p->radiance = malloc(n * 4 * sizeof(float));
    p->output = calloc(n * 4, sizeof(float));
    if (!p->radiance || !p->output) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "%s: out of memory", p->label);
        goto fail;
    }
    TND_TRY(tnd_frame_create(d->width, d->height, &p->host));
    TND_TRY(tnd_image_create(d->vk,
                             &(tnd_image_desc){.width = d->width, .height = d->height,
                                               .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                               .name = "host_denoiser.output"},
                             &p->out));
    TND_TRY(off_create(d, &p->off));
    tandem_host_denoiser_create_info ci = {.struct_size = sizeof ci,
                                           .width = d->width,
                                           .height = d->height,
                                           .precision = (uint32_t)d->precision,
                                           .options = path ? "" : options};
    char err[4096] = "";
    if (p->h->create(&ci, &p->state, err, sizeof err) != 0) {
        err[sizeof err - 1] = 0;
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: create failed: %s", p->label,
                       err[0] ? err : "no message");
        goto fail;
    }
    p->have_state = true;
    *out = p;
    return TND_OK;
fail:
    hdn_destroy(p);
    return res;
}

static tnd_result hdn_create(const pl_dn_desc *d, void **out)
{
    return hdn_open(d, NULL, d->path, (hdn **)out);
}

static tnd_result hdn_submit(void *ctx, const pl_dn_input *in)
{
    hdn *p = ctx;
    tnd_result res = TND_OK;
    double off[PL_DN_MAX_PASSES] = {0};
    bool beside;
    TND_TRY(pl_off_ops.submit(p->off, in));
    TND_TRY(pl_off_ops.wait(p->off, off, &beside));
    p->ms = 0;
    double t0 = tnd_now();
    size_t n = (size_t)p->width * p->height;
    uint64_t reads = p->h->reads;
    if (reads & ALL_ENTRIES)
        TND_TRY(tnd_contract_download(p->vk, in->contract, &p->host));
    if (reads & TANDEM_INPUT_RADIANCE)
        TND_TRY(tnd_image_download(p->vk, pl_off_ops.output(p->off), p->radiance,
                                   n * 4 * sizeof(float)));
    tandem_frame_settings fs;
    pl_plugin_settings(in->camera, p->width, p->height, in->params, in->frame, in->dt,
                       p->precision, &fs);
    tandem_host_denoiser_io io = {.struct_size = sizeof io,
                                  .width = p->width,
                                  .height = p->height,
                                  .radiance = reads & TANDEM_INPUT_RADIANCE ? p->radiance : NULL,
                                  .output = p->output};
    for (int e = 0; e < TANDEM_ENTRY_COUNT; e++)
        if (reads & TANDEM_ENTRY_BIT(e))
            io.entries[e] = p->host.data[e];
    char err[4096] = "";
    if (p->h->run(p->state, &fs, &io, err, sizeof err) != 0) {
        err[sizeof err - 1] = 0;
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: frame %u: %s", p->label, fs.frame_index,
                        err[0] ? err : "run failed");
    }
    TND_TRY(tnd_image_upload(p->vk, &p->out, p->output, n * 4 * sizeof(float)));
    p->ms = 1e3 * (tnd_now() - t0);
    p->ms_composite = off[0];
fail:
    return res;
}

static tnd_result hdn_wait(void *ctx, double *ms, bool *beside)
{
    hdn *p = ctx;
    ms[0] = p->ms_composite;
    ms[1] = p->ms;
    *beside = false;
    return TND_OK;
}

static const tnd_image *hdn_output(const void *ctx)
{
    return &((const hdn *)ctx)->out;
}

static const char *hdn_name(const void *ctx)
{
    return ((const hdn *)ctx)->label;
}

/* its passes: the noisy radiance's composite, the host's frame (to the host, the run, back) */
static const pl_pass hdn_passes[] = {
    {"composite", "composite_ms", PL_GROUP_BACKEND, NULL},
    {"host", "denoiser_host_ms", PL_GROUP_BACKEND, NULL},
};

const pl_denoiser_ops pl_python_denoiser_ops = {
    .info = {"python", "a denoiser in Python, on the host (python:MODULE:CALLABLE; docs/python.md)",
             PL_DN_FILTERS | PL_DN_PLUGIN, NULL, NULL, 0, hdn_passes,
             sizeof hdn_passes / sizeof *hdn_passes},
    .create = hdn_create,
    .destroy = hdn_destroy,
    .submit = hdn_submit,
    .wait = hdn_wait,
    .output = hdn_output,
    .plugin_name = hdn_name,
};

/* ---- the denoiser adapter: "plugin:PATH" as a registered denoiser ------------------------------ */
/* The built-in back-end composites the noisy radiance (mode off) that the plugin may read; the
 * plugin's commands follow in their own submission, between full barriers, timed. */
typedef struct pdn {
    hdn *host; /* a plugin of kind HOST_DENOISER: the host adapter runs it (and the rest is
                  unused) */
    void *off; /* the built-in adapter's context (pl_off_ops) */
    pl_dnp *dnp;
    tnd_vk *vk;
    tnd_pending pending;
    tnd_timer timer;
    bool due;
    double ms;
    uint32_t width, height;
    tnd_precision precision;
} pdn;

static void pdn_destroy(void *ctx)
{
    pdn *p = ctx;
    if (!p)
        return;
    hdn_destroy(p->host);
    if (p->dnp) {
        tnd_pending_destroy(p->vk, &p->pending);
        tnd_timer_destroy(p->vk, &p->timer);
        pl_dnp_destroy(p->dnp);
    }
    pl_off_ops.destroy(p->off);
    free(p);
}

static tnd_result pdn_create(const pl_dn_desc *d, void **out)
{
    tnd_result res = TND_OK;
    pdn *p = calloc(1, sizeof *p);
    if (!p)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "plugin: out of memory");
    p->vk = d->vk;
    p->width = d->width, p->height = d->height, p->precision = d->precision;
    pl_plugin *probe; /* (which kind of denoiser it is) */
    TND_TRY(plugin_open(d->path, TANDEM_PLUGIN_DENOISER, &probe));
    bool host = probe->desc->kind == TANDEM_PLUGIN_HOST_DENOISER;
    plugin_close(probe);
    if (host) {
        TND_TRY(hdn_open(d, d->path, "", &p->host));
        *out = p;
        return TND_OK;
    }
    TND_TRY(pl_dnp_create(d->vk, d->path, d->width, d->height, d->precision, &p->dnp));
    TND_TRY(tnd_pending_create(d->vk, &p->pending));
    TND_TRY(tnd_timer_create(d->vk, &p->timer));
    TND_TRY(off_create(d, &p->off));
    *out = p;
    return TND_OK;
fail:
    pdn_destroy(p);
    return res;
}

/* Wait for the plugin's frame in flight and read its time. */
static tnd_result pdn_settle(pdn *p)
{
    tnd_result res = TND_OK;
    TND_TRY(tnd_pending_wait(p->vk, &p->pending));
    if (p->due) {
        p->due = false;
        TND_TRY(tnd_timer_read(p->vk, &p->timer, &p->ms));
    }
fail:
    return res;
}

static tnd_result pdn_submit(void *ctx, const pl_dn_input *in)
{
    pdn *p = ctx;
    if (p->host)
        return hdn_submit(p->host, in);
    tnd_result res = TND_OK;
    TND_TRY(pl_off_ops.submit(p->off, in));
    TND_TRY(pdn_settle(p));
    tandem_frame_settings fs; /* the ABI's settings of the frame */
    pl_plugin_settings(in->camera, p->width, p->height, in->params, in->frame, in->dt,
                       p->precision, &fs);
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(p->vk, &cmd));
    tnd_timer_reset(cmd, &p->timer);
    int slot = tnd_timer_begin(cmd, &p->timer, "plugin");
    res = pl_dnp_record(p->dnp, cmd, &fs, in->contract, pl_off_ops.output(p->off));
    tnd_timer_end(cmd, &p->timer, slot);
    if (res != TND_OK) {
        vkEndCommandBuffer(cmd);
        vkFreeCommandBuffers(p->vk->device, p->vk->cmd_pool, 1, &cmd);
        return res;
    }
    TND_TRY(tnd_cmd_submit_pending(p->vk, cmd, &p->pending));
    p->due = true;
fail:
    return res;
}

static tnd_result pdn_wait(void *ctx, double *ms, bool *beside)
{
    pdn *p = ctx;
    if (p->host)
        return hdn_wait(p->host, ms, beside);
    tnd_result res = TND_OK;
    double off[PL_DN_MAX_PASSES] = {0};
    TND_TRY(pl_off_ops.wait(p->off, off, beside));
    TND_TRY(pdn_settle(p));
    ms[0] = off[0]; /* its composite */
    ms[1] = p->ms;
    *beside = false;
fail:
    return res;
}

static const tnd_image *pdn_output(const void *ctx)
{
    const pdn *p = ctx;
    return p->host ? hdn_output(p->host) : pl_dnp_output(p->dnp);
}

static const char *pdn_name(const void *ctx)
{
    const pdn *p = ctx;
    return p->host ? p->host->p->desc->name : pl_dnp_name(p->dnp);
}

/* its passes: the noisy radiance's composite, the plugin's frame */
static const pl_pass pdn_passes[] = {
    {"composite", "composite_ms", PL_GROUP_BACKEND, NULL},
    {"plugin", "denoiser_plugin_ms", PL_GROUP_BACKEND, NULL},
};

const pl_denoiser_ops pl_plugin_denoiser_ops = {
    .info = {"plugin", "a denoiser plugin (plugin:PATH.so; include/tandem/tandem_plugin.h)",
             PL_DN_FILTERS | PL_DN_PLUGIN, NULL, NULL, 0, pdn_passes,
             sizeof pdn_passes / sizeof *pdn_passes},
    .create = pdn_create,
    .destroy = pdn_destroy,
    .submit = pdn_submit,
    .wait = pdn_wait,
    .output = pdn_output,
    .plugin_name = pdn_name,
};
