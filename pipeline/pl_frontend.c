/* pipeline/pl_frontend.c: the front-end interface and its registry. Each front-end is one table
 * of operations (pl_frontend_ops); the Vulkan and Embree front-ends are adapted to it here, the
 * only place outside their folders that names their functions.
 * Entry points: pl_frontend_names, pl_frontend_live_names, pl_frontend_known, pl_frontend_live,
 * pl_frontend_caps_of, pl_frontend_cap_name, pl_frontend_name_at, pl_frontend_needs_gpu, pl_frontend_create and the
 * pl_frontend_* operations. */
#include "pipeline/pl_internal.h"
#include "frontend_embree/frontend_embree.h"
#include "frontend_vk/frontend_vk.h"
#include "shaders/sampling.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct pl_frontend {
    const pl_frontend_ops *ops;
    void *ctx;
    pl_camera cam;
    bool have_cam;
    uint32_t width, height; /* the frame's, as set */
};

void pl_camera_from_states(const tnd_scene_state *cur, const tnd_scene_state *prev,
                           uint32_t frame, pl_camera *cam)
{
    if (!prev)
        prev = cur;
    memset(cam, 0, sizeof *cam);
    memcpy(cam->state.view, cur->camera.view, sizeof cam->state.view);
    memcpy(cam->state.proj, cur->camera.proj, sizeof cam->state.proj);
    memcpy(cam->state.prev_view, prev->camera.view, sizeof cam->state.prev_view);
    memcpy(cam->state.prev_proj, prev->camera.proj, sizeof cam->state.prev_proj);
    tnd_jitter(frame, cam->state.jitter);
    cam->state.frame_index = frame;
    memcpy(cam->position, cur->camera_position, sizeof cam->position);
    cam->time = cur->time;
}

/* ---- Vulkan ------------------------------------------------------------------------------------ */
typedef struct vk_fe {
    fvk_context *gv;
    tnd_vk *vk;
    tnd_camera_state cam; /* of the current frame, for the host copy */
} vk_fe;

static fvk_params vk_params(const pl_params *p)
{
    return p ? (fvk_params){p->bounces, p->sample, p->set_jitter, {p->jitter[0], p->jitter[1]},
                           p->half_indirect}
             : (fvk_params){.bounces = 1};
}

static tnd_result vk_create(const tnd_scene *scene, const pl_frontend_desc *d, void **out)
{
    tnd_result res = TND_OK;
    fvk_rt_api api;
    if (!d->vk)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: the vk front-end needs a Vulkan context");
    TND_TRY(fvk_rt_api_parse(d->rt_api ? d->rt_api : "auto", &api));
    vk_fe *v = calloc(1, sizeof *v);
    if (!v)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
    v->vk = d->vk;
    res = fvk_create(d->vk, scene,
                     &(fvk_desc){.precision = d->precision, .rt_api = api,
                                 .full_pipeline = d->full_pipeline,
                                 .reflect_depth = d->reflect_depth,
                                 .references = d->references,
                                 .bounces = d->bounces,
                                 .half_indirect = d->half_indirect,
                                 .lights = d->lights,
                                 .footprint_scale = d->footprint_scale},
                     &v->gv);
    if (res != TND_OK) {
        free(v);
        return res;
    }
    *out = v;
fail:
    return res;
}

static void vk_destroy(void *ctx)
{
    vk_fe *v = ctx;
    if (v)
        fvk_destroy(v->gv);
    free(v);
}

static void vk_describe(const void *ctx, char *buf, size_t cap)
{
    const vk_fe *v = ctx;
    snprintf(buf, cap, "Vulkan %s on %s",
             fvk_api(v->gv) == FVK_RT_QUERY ? "ray query" : "ray-tracing pipeline",
             v->vk->info.name);
}

static const char *vk_models(const void *ctx)
{
    return fvk_variant(((const vk_fe *)ctx)->gv);
}

static tnd_result vk_set_frame(void *ctx, const tnd_scene_state *cur, const tnd_scene_state *prev,
                               uint32_t frame, uint32_t w, uint32_t h)
{
    vk_fe *v = ctx;
    pl_camera cam;
    pl_camera_from_states(cur, prev, frame, &cam);
    v->cam = cam.state;
    if (!prev)
        prev = cur;
    return fvk_set_frame(v->gv, cur, prev, frame, w, h);
}

static tnd_result vk_render(void *ctx, const pl_params *p, tnd_frame *host, pl_timings *t)
{
    tnd_result res = TND_OK;
    vk_fe *v = ctx;
    fvk_params fp = vk_params(p);
    fvk_timings tm = {0};
    TND_TRY(fvk_render(v->gv, &fp, t ? &tm : NULL));
    if (t)
        *t = (pl_timings){tm.primary_ms, tm.shade_ms, tm.tlas_ms, 0.0};
    if (host) {
        TND_TRY(tnd_contract_download(v->vk, fvk_contract(v->gv), host));
        host->has_camera = true;
        host->camera = v->cam;
    }
fail:
    return res;
}

static const tnd_contract_gpu *vk_contract(const void *ctx)
{
    return fvk_contract(((const vk_fe *)ctx)->gv);
}

static tnd_result vk_reshade(void *ctx, const pl_params *p, const uint32_t *words, uint32_t n,
                             tnd_frame *host, pl_timings *t)
{
    (void)host; /* (the GPU contract is patched; a caller that wants it on the host downloads) */
    vk_fe *v = ctx;
    fvk_params fp = vk_params(p);
    fvk_timings tm = {0};
    tnd_result res = fvk_shade_gradients(v->gv, &fp, words, n, t ? &tm : NULL);
    if (t)
        t->gradient_ms = tm.gradient_ms;
    return res;
}

static tnd_result vk_reshade_slots(void *ctx, const pl_params *p, VkBuffer slots, uint32_t n,
                                   uint32_t row, pl_timings *t)
{
    vk_fe *v = ctx;
    fvk_params fp = vk_params(p);
    fvk_timings tm = {0};
    tnd_result res = fvk_shade_gradient_slots(v->gv, &fp, slots, n, row, t ? &tm : NULL);
    if (t)
        t->gradient_ms = tm.gradient_ms;
    return res;
}

static tnd_result vk_render_primary(void *ctx, const pl_params *p)
{
    vk_fe *v = ctx;
    fvk_params fp = vk_params(p);
    return fvk_render_primary(v->gv, &fp);
}

static tnd_result vk_render_shade(void *ctx, const pl_params *p, VkBuffer slots, uint32_t row,
                                  pl_timings *t)
{
    vk_fe *v = ctx;
    fvk_params fp = vk_params(p);
    fvk_timings tm = {0};
    tnd_result res = fvk_render_shade(v->gv, &fp, slots, row, t ? &tm : NULL);
    if (t)
        *t = (pl_timings){tm.primary_ms, tm.shade_ms, tm.tlas_ms, 0.0};
    return res;
}

static tnd_result vk_reference(void *ctx, uint32_t max_bounces, uint32_t first, uint32_t count,
                               double *sum_rgb, double *sum_lum2, tnd_ref_stats *stats,
                               void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    vk_fe *v = ctx;
    fvk_set_reference_bounces(v->gv, max_bounces);
    return fvk_reference_add(v->gv, first, count, sum_rgb, sum_lum2, stats, progress, user);
}

static tnd_result vk_matched(void *ctx, uint32_t bounces, uint32_t first, uint32_t count,
                             double *sum_rgb, double *sum_lum2, tnd_ref_stats *stats,
                             void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    return fvk_matched_add(((vk_fe *)ctx)->gv, bounces, first, count, sum_rgb, sum_lum2, stats,
                           progress, user);
}

static tnd_result vk_timings(void *ctx, bool wait, pl_timings *t)
{
    fvk_timings tm;
    tnd_result res = fvk_last_timings(((vk_fe *)ctx)->gv, wait, &tm);
    *t = (pl_timings){tm.primary_ms, tm.shade_ms, tm.tlas_ms, tm.gradient_ms};
    return res;
}

static const pl_frontend_ops vk_ops = {
    .name = "vk",
    .caps = PL_CAP_GPU_CONTRACT | PL_CAP_RESHADE | PL_CAP_REFERENCE | PL_CAP_QUEUED |
            PL_CAP_SHADE_SLOTS,
    .create = vk_create,
    .destroy = vk_destroy,
    .describe = vk_describe,
    .models = vk_models,
    .set_frame = vk_set_frame,
    .render = vk_render,
    .contract = vk_contract,
    .reshade = vk_reshade,
    .reshade_slots = vk_reshade_slots,
    .render_primary = vk_render_primary,
    .render_shade = vk_render_shade,
    .reference = vk_reference,
    .matched = vk_matched,
    .timings = vk_timings,
};

/* ---- Embree ------------------------------------------------------------------------------------ */
typedef struct emb_fe {
    femb_context *fe;
    tnd_precision precision;
} emb_fe;

static femb_params emb_params(const pl_params *p)
{
    return p ? (femb_params){p->bounces, p->sample, p->set_jitter, {p->jitter[0], p->jitter[1]},
                           p->half_indirect}
             : (femb_params){.bounces = 1};
}

static tnd_result emb_create(const tnd_scene *scene, const pl_frontend_desc *d, void **out)
{
    emb_fe *e = calloc(1, sizeof *e);
    if (!e)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
    e->precision = d->precision;
    tnd_result res = femb_create(
        scene,
        &(femb_desc){.threads = d->threads, .reflect_depth = d->reflect_depth, .lights = d->lights,
                     .footprint_scale = d->footprint_scale},
        &e->fe);
    if (res != TND_OK) {
        free(e);
        return res;
    }
    *out = e;
    return TND_OK;
}

static void emb_destroy(void *ctx)
{
    emb_fe *e = ctx;
    if (e)
        femb_destroy(e->fe);
    free(e);
}

static void emb_describe(const void *ctx, char *buf, size_t cap)
{
    snprintf(buf, cap, "Embree, %u threads", femb_thread_count(((const emb_fe *)ctx)->fe));
}

static const char *emb_models(const void *ctx)
{
    (void)ctx;
    return "everything (CPU code, no variants)";
}

static tnd_result emb_set_frame(void *ctx, const tnd_scene_state *cur,
                                const tnd_scene_state *prev, uint32_t frame, uint32_t w,
                                uint32_t h)
{
    return femb_set_frame(((emb_fe *)ctx)->fe, cur, prev, frame, w, h);
}

static tnd_result emb_render(void *ctx, const pl_params *p, tnd_frame *host, pl_timings *t)
{
    emb_fe *e = ctx;
    if (!host)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: the embree front-end fills a host frame");
    femb_params fp = emb_params(p);
    double t0 = tnd_now();
    tnd_result res = femb_render(e->fe, &fp, host, NULL);
    if (t) /* both passes in one sweep: one time for the two */
        *t = (pl_timings){1e3 * (tnd_now() - t0), 0.0, 0.0, 0.0};
    if (res == TND_OK)
        tnd_frame_quantize(host, e->precision);
    return res;
}

static const tnd_contract_gpu *emb_contract(const void *ctx)
{
    (void)ctx;
    return NULL;
}

static tnd_result emb_reshade(void *ctx, const pl_params *p, const uint32_t *words, uint32_t n,
                              tnd_frame *host, pl_timings *t)
{
    emb_fe *e = ctx;
    if (n == 0)
        return TND_OK;
    if (!host)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: the embree front-end re-shades a host frame");
    femb_gradient_sample *g = malloc((size_t)n * sizeof *g);
    if (!g)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
    femb_params fp = emb_params(p);
    double t0 = tnd_now();
    femb_gradient_unpack(words, n, g);
    tnd_result res = femb_shade_gradients(e->fe, &fp, g, n, host);
    if (t)
        t->gradient_ms = 1e3 * (tnd_now() - t0);
    free(g);
    if (res == TND_OK)
        tnd_frame_quantize(host, e->precision);
    return res;
}

static tnd_result emb_reference(void *ctx, uint32_t max_bounces, uint32_t first, uint32_t count,
                               double *sum_rgb, double *sum_lum2, tnd_ref_stats *stats,
                               void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    emb_fe *e = ctx;
    femb_set_reference_bounces(e->fe, max_bounces);
    return femb_reference_add(e->fe, first, count, sum_rgb, sum_lum2, stats, progress, user);
}

static tnd_result emb_benchmark(void *ctx, const pl_params *p, uint32_t repeats, pl_bench *out)
{
    femb_params fp = emb_params(p);
    femb_bench b;
    tnd_result res = femb_benchmark(((emb_fe *)ctx)->fe, &fp, repeats, &b);
    if (res == TND_OK)
        *out = (pl_bench){b.frame_ms, b.primary_ms,   b.shade_ms,       b.raw_ms,
                          b.raw_primary_ms, b.rays, b.primary_rays};
    return res;
}

static void emb_cpu(const void *ctx, uint32_t *threads, const char **simd)
{
    *threads = femb_thread_count(((const emb_fe *)ctx)->fe);
    *simd = femb_simd();
}

static const pl_frontend_ops embree_ops = {
    .name = "embree",
    .caps = PL_CAP_RESHADE | PL_CAP_REFERENCE | PL_CAP_BENCHMARK,
    .create = emb_create,
    .destroy = emb_destroy,
    .describe = emb_describe,
    .models = emb_models,
    .set_frame = emb_set_frame,
    .render = emb_render,
    .contract = emb_contract,
    .reshade = emb_reshade,
    .reference = emb_reference,
    .benchmark = emb_benchmark,
    .cpu = emb_cpu,
};

/* ---- the registry -------------------------------------------------------------------------------- */
static const pl_frontend_ops *const registry[] = {&embree_ops, &vk_ops, &pl_replay_ops};
enum { REGISTERED = sizeof registry / sizeof registry[0] };

static const pl_frontend_ops *find(const char *name)
{
    for (int i = 0; name && i < REGISTERED; i++)
        if (strcmp(registry[i]->name, name) == 0)
            return registry[i];
    return NULL;
}

/* the registered names (live ones only: without PL_CAP_RECORDED), then "plugin:PATH" */
static const char *names_of(bool live, char *buf, size_t cap)
{
    if (buf[0])
        return buf;
    for (int i = 0; i < REGISTERED; i++)
        if (!live || !(registry[i]->caps & PL_CAP_RECORDED))
            snprintf(buf + strlen(buf), cap - strlen(buf), "%s, ", registry[i]->name);
    snprintf(buf + strlen(buf), cap - strlen(buf), "plugin:PATH");
    return buf;
}

const char *pl_frontend_names(void)
{
    static char buf[256];
    return names_of(false, buf, sizeof buf);
}

const char *pl_frontend_live_names(void)
{
    static char buf[256];
    return names_of(true, buf, sizeof buf);
}

/* "plugin:PATH": the path, else NULL */
static const char *plugin_path(const char *name)
{
    return name && strncmp(name, "plugin:", 7) == 0 ? name + 7 : NULL;
}

uint32_t pl_frontend_caps_of(const char *name)
{
    const char *plugin = plugin_path(name);
    const pl_frontend_ops *o = plugin ? (*plugin ? &pl_plugin_frontend_ops : NULL) : find(name);
    return o ? o->caps : 0;
}

const char *pl_frontend_cap_name(uint32_t bit)
{
    /* in PL_CAP_* order */
    static const char *const names[] = {"gpu_contract", "reshade", "reference",  "benchmark",
                                        "recorded",     "queued",  "shade_slots"};
    _Static_assert(1u << (sizeof names / sizeof *names - 1) == PL_CAP_SHADE_SLOTS,
                   "one name a bit");
    return bit < sizeof names / sizeof *names ? names[bit] : NULL;
}

const char *pl_frontend_name_at(uint32_t i)
{
    return i < REGISTERED ? registry[i]->name : NULL;
}

bool pl_frontend_known(const char *name)
{
    const char *plugin = plugin_path(name);
    return plugin ? *plugin != 0 : find(name) != NULL;
}

bool pl_frontend_live(const char *name)
{
    return pl_frontend_known(name) && !(pl_frontend_caps_of(name) & PL_CAP_RECORDED);
}

bool pl_frontend_needs_gpu(const char *name)
{
    return (pl_frontend_caps_of(name) & PL_CAP_GPU_CONTRACT) != 0;
}

tnd_result pl_frontend_create(const char *name, const tnd_scene *scene, const pl_frontend_desc *d,
                              pl_frontend **out)
{
    *out = NULL;
    const char *plugin = plugin_path(name);
    pl_frontend_desc dp;
    if (plugin) {
        if (!*plugin)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: front-end 'plugin:': no path");
        dp = *d;
        dp.plugin = plugin;
        d = &dp;
    }
    const pl_frontend_ops *o = plugin ? &pl_plugin_frontend_ops : find(name);
    if (!o)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: front-end '%s': expected one of %s",
                        name ? name : "(none)", pl_frontend_names());
    pl_frontend *fe = calloc(1, sizeof *fe);
    if (!fe)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
    fe->ops = o;
    tnd_result res = o->create(scene, d, &fe->ctx);
    if (res != TND_OK) {
        free(fe);
        return res;
    }
    *out = fe;
    return TND_OK;
}

void pl_frontend_destroy(pl_frontend *fe)
{
    if (!fe)
        return;
    fe->ops->destroy(fe->ctx);
    free(fe);
}

uint32_t pl_frontend_caps(const pl_frontend *fe)
{
    uint32_t c = fe->ops->caps;
    if (fe->ops->can_reshade && !fe->ops->can_reshade(fe->ctx))
        c &= ~(uint32_t)PL_CAP_RESHADE;
    return c;
}

uint32_t pl_frontend_length(const pl_frontend *fe)
{
    return fe->ops->length ? fe->ops->length(fe->ctx) : 0;
}

const char *pl_frontend_frame_name(const pl_frontend *fe, uint32_t i)
{
    return fe->ops->frame_name ? fe->ops->frame_name(fe->ctx, i) : NULL;
}

const char *pl_frontend_describe(const pl_frontend *fe, char *buf, size_t cap)
{
    fe->ops->describe(fe->ctx, buf, cap);
    return buf;
}

const char *pl_frontend_models(const pl_frontend *fe)
{
    return fe->ops->models(fe->ctx);
}

tnd_result pl_frontend_set_frame(pl_frontend *fe, const tnd_scene_state *cur,
                                 const tnd_scene_state *prev, uint32_t frame, uint32_t width,
                                 uint32_t height)
{
    fe->have_cam = cur != NULL; /* (a recorded front-end's frames carry their cameras) */
    fe->width = width;
    fe->height = height;
    if (cur)
        pl_camera_from_states(cur, prev, frame, &fe->cam);
    return fe->ops->set_frame(fe->ctx, cur, prev, frame, width, height);
}

const pl_camera *pl_frontend_camera(const pl_frontend *fe)
{
    return fe->have_cam ? &fe->cam : NULL;
}

tnd_result pl_frontend_render(pl_frontend *fe, const pl_params *p, tnd_frame *host, pl_timings *t)
{
    return fe->ops->render(fe->ctx, p, host, t);
}

tnd_result pl_frontend_timings(pl_frontend *fe, bool wait, pl_timings *t)
{
    if (!(pl_frontend_caps(fe) & PL_CAP_QUEUED) || !fe->ops->timings)
        return TND_OK; /* (t as render and re-shade gave it) */
    return fe->ops->timings(fe->ctx, wait, t);
}

const tnd_contract_gpu *pl_frontend_contract(const pl_frontend *fe)
{
    return fe->ops->contract(fe->ctx);
}

tnd_result pl_frontend_reshade(pl_frontend *fe, const pl_params *p, const uint32_t *words,
                               uint32_t count, tnd_frame *host, pl_timings *t)
{
    if (!(pl_frontend_caps(fe) & PL_CAP_RESHADE))
        return tnd_fail(TND_ERR_UNSUPPORTED, "pipeline: front-end '%s' cannot re-shade",
                        fe->ops->name);
    return fe->ops->reshade(fe->ctx, p, words, count, host, t);
}

tnd_result pl_frontend_reshade_slots(pl_frontend *fe, const pl_params *p, VkBuffer slots,
                                     uint32_t count, uint32_t row, pl_timings *t)
{
    if (!fe->ops->reshade_slots)
        return tnd_fail(TND_ERR_UNSUPPORTED, "pipeline: front-end '%s' re-shades host lists only",
                        fe->ops->name);
    return fe->ops->reshade_slots(fe->ctx, p, slots, count, row, t);
}

tnd_result pl_frontend_render_primary(pl_frontend *fe, const pl_params *p)
{
    if (!(pl_frontend_caps(fe) & PL_CAP_SHADE_SLOTS))
        return tnd_fail(TND_ERR_UNSUPPORTED, "pipeline: front-end '%s' renders in one step",
                        fe->ops->name);
    return fe->ops->render_primary(fe->ctx, p);
}

tnd_result pl_frontend_render_shade(pl_frontend *fe, const pl_params *p, VkBuffer slots,
                                    uint32_t row, pl_timings *t)
{
    if (!(pl_frontend_caps(fe) & PL_CAP_SHADE_SLOTS))
        return tnd_fail(TND_ERR_UNSUPPORTED, "pipeline: front-end '%s' renders in one step",
                        fe->ops->name);
    return fe->ops->render_shade(fe->ctx, p, slots, row, t);
}

tnd_result pl_frontend_reference_add(pl_frontend *fe, uint32_t max_bounces, uint32_t first,
                                     uint32_t count, double *sum_rgb, double *sum_lum2,
                                     tnd_ref_stats *stats,
                                     void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    if (!(fe->ops->caps & PL_CAP_REFERENCE))
        return tnd_fail(TND_ERR_UNSUPPORTED, "pipeline: front-end '%s' renders no reference",
                        fe->ops->name);
    return fe->ops->reference(fe->ctx, max_bounces, first, count, sum_rgb, sum_lum2, stats,
                              progress, user);
}

bool pl_frontend_has_matched(const pl_frontend *fe)
{
    return fe->ops->matched != NULL;
}

tnd_result pl_frontend_matched_add(pl_frontend *fe, uint32_t bounces, uint32_t first,
                                   uint32_t count, double *sum_rgb, double *sum_lum2,
                                   tnd_ref_stats *stats,
                                   void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    if (!fe->ops->matched)
        return tnd_fail(TND_ERR_UNSUPPORTED, "pipeline: front-end '%s' sums no matched "
                        "reference where its contract is (the host composites its samples)",
                        fe->ops->name);
    return fe->ops->matched(fe->ctx, bounces, first, count, sum_rgb, sum_lum2, stats, progress,
                            user);
}

typedef struct ref_call {
    pl_frontend *fe;
    uint32_t max_bounces;
} ref_call;

static tnd_result reference_add(void *ctx, uint32_t first, uint32_t count, double *sum_rgb,
                                double *sum_lum2, tnd_ref_stats *stats,
                                void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    ref_call *r = ctx;
    return pl_frontend_reference_add(r->fe, r->max_bounces, first, count, sum_rgb, sum_lum2, stats,
                                     progress, user);
}

tnd_result pl_frontend_reference(pl_frontend *fe, uint32_t max_bounces, uint32_t spp, float *rgb,
                                 float *lum_se, tnd_ref_stats *stats,
                                 void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    ref_call r = {fe, max_bounces};
    return tnd_ref_run((size_t)fe->width * fe->height, spp, reference_add, &r, rgb, lum_se, stats,
                       progress, user);
}

tnd_result pl_frontend_benchmark(pl_frontend *fe, const pl_params *p, uint32_t repeats,
                                 pl_bench *out)
{
    if (!fe->ops->benchmark)
        return tnd_fail(TND_ERR_UNSUPPORTED, "pipeline: front-end '%s' has no ray benchmark",
                        fe->ops->name);
    return fe->ops->benchmark(fe->ctx, p, repeats, out);
}

void pl_frontend_cpu(const pl_frontend *fe, uint32_t *threads, const char **simd)
{
    *threads = 0;
    *simd = NULL;
    if (fe->ops->cpu)
        fe->ops->cpu(fe->ctx, threads, simd);
}

bool pl_frontend_recorded(const pl_frontend *fe, uint32_t *width, uint32_t *height,
                          tnd_precision *precision, bool *split)
{
    return fe->ops->recorded && fe->ops->recorded(fe->ctx, width, height, precision, split);
}

bool pl_frontend_recorded_has(const pl_frontend *fe, tnd_ct e)
{
    return !fe->ops->has_entry || fe->ops->has_entry(fe->ctx, e);
}
