/* pipeline/pl_dn_backend.c: the built-in back-end (denoise/: SVGF, A-SVGF, the plain composite)
 * as three registered denoisers: their parameters (one pl_param table; dn_desc fields they set),
 * their passes (dn_timings' fields), and the operations over dn_context.
 * Entry points: pl_asvgf_ops, pl_svgf_ops, pl_off_ops (also the plugin adapter's composite of
 * the noisy radiance). */
#include "pipeline/pl_internal.h"

#include <string.h>

/* ---- the built-in back-end (denoise/): SVGF, A-SVGF, the plain composite ------------------- */
static const pl_param p_atrous = {
    "atrous", PL_PARAM_UINT, 1, 5, false, "N",
    "a-trous iterations of hf and spec (default 4 and 3; 1 to 5)", ",.", {0}, 0};
static const pl_param p_min_alpha = {
    "min-alpha", PL_PARAM_FLOAT, 0, 1, true, "A",
    "temporal accumulation: the smallest weight of the new frame, hf/lf/spec (default "
    ".02/.01/.01)",
    "M", {0, 0.05, 0.1, 0.2}, 4};
static const pl_param p_antilag = {
    "antilag", PL_PARAM_FLOAT, 0, 100, true, "G",
    "asvgf: the hf antilag gain (how fast history drops where the signal changed; default 1)",
    "G", {0, 2.0, 0.5}, 3};
static const pl_param p_lf_sigma = {
    "lf-sigma", PL_PARAM_FLOAT, 0, 100, true, "S",
    "the lf filter's luminance weight: standard deviations of the noise left in its histories "
    "(default 2; docs/denoise.md)",
    NULL, {0}, 0};

static const pl_param *const svgf_params[] = {&p_atrous, &p_min_alpha, &p_lf_sigma};
static const pl_param *const asvgf_params[] = {&p_atrous, &p_min_alpha, &p_antilag, &p_lf_sigma};

/* The back-end's passes, in dn_timings' order (timings.json's keys as they always were). */
static const pl_pass backend_passes[] = {
    {"select", "denoise_select_ms", PL_GROUP_GRADIENTS, NULL},
    {"gradient", "denoise_gradient_ms", PL_GROUP_GRADIENTS, NULL},
    {"temporal", "denoise_temporal_ms", PL_GROUP_BACKEND, NULL},
    {"lf", "denoise_lf_ms", PL_GROUP_BACKEND, "atrous"},
    {"atrous", "denoise_atrous_ms", PL_GROUP_BACKEND, NULL},
    {"composite", "composite_ms", PL_GROUP_BACKEND, NULL},
};
enum { BACKEND_PASSES = sizeof backend_passes / sizeof backend_passes[0] };

static void backend_param(dn_desc *d, const char *name, double v)
{
    if (strcmp(name, "atrous") == 0)
        d->iters_hf = d->iters_spec = (uint32_t)v;
    else if (strcmp(name, "min-alpha") == 0)
        d->min_alpha_hf = d->min_alpha_lf = d->min_alpha_spec = (float)v;
    else if (strcmp(name, "antilag") == 0)
        d->antilag_hf = (float)v;
    else if (strcmp(name, "lf-sigma") == 0)
        d->lf_sigma = (float)v;
}

static tnd_result backend_create(const pl_dn_desc *d, void **out)
{
    dn_desc dd = d->backend ? *d->backend : (dn_desc){0};
    dd.mode = *(const dn_mode *)d->data;
    dd.precision = d->precision;
    for (uint32_t i = 0; d->params && i < d->params->n; i++)
        backend_param(&dd, d->params->param[i]->name, d->params->value[i]);
    return dn_create(d->vk, d->width, d->height, &dd, (dn_context **)out);
}

static void backend_destroy(void *ctx)
{
    dn_destroy(ctx);
}

static uint32_t backend_capacity(const void *ctx)
{
    return dn_gradient_capacity(ctx);
}

static tnd_result backend_select(void *ctx, const tnd_contract_gpu *ct, const dn_frame *f,
                                 uint32_t *words, VkBuffer *slots, uint32_t *n)
{
    return words ? dn_select_gradients(ctx, ct, f, words, n)
                 : dn_select_gradients_gpu(ctx, ct, f, slots, n);
}

static tnd_result backend_submit(void *ctx, const pl_dn_input *in)
{
    return dn_submit(ctx, in->contract, in->frame);
}

static void backend_times(const dn_timings *t, double *ms, bool *beside)
{
    const double v[BACKEND_PASSES] = {t->select_ms, t->gradient_ms, t->temporal_ms,
                                      t->lf_ms,     t->atrous_ms,   t->composite_ms};
    memcpy(ms, v, sizeof v);
    *beside = t->lf_beside_atrous;
}

static tnd_result backend_wait(void *ctx, double *ms, bool *beside)
{
    dn_timings t;
    tnd_result res = dn_wait(ctx, &t);
    if (res == TND_OK)
        backend_times(&t, ms, beside);
    return res;
}

static const tnd_image *backend_output(const void *ctx)
{
    return dn_output(ctx);
}

static dn_context *backend_context(void *ctx)
{
    return ctx;
}

static void backend_traffic(const void *ctx, double *bytes)
{
    dn_traffic t;
    dn_traffic_of(ctx, &t);
    const double v[BACKEND_PASSES] = {t.select, t.gradient, t.temporal, t.lf, t.atrous,
                                      t.composite};
    memcpy(bytes, v, sizeof v);
}

static const dn_mode mode_svgf = DN_MODE_SVGF, mode_asvgf = DN_MODE_ASVGF, mode_off = DN_MODE_OFF;

#define BACKEND_OPS(mode_var)                                                                      \
    .data = &mode_var, .create = backend_create, .destroy = backend_destroy,                       \
    .capacity = backend_capacity, .select = backend_select, .submit = backend_submit,              \
    .wait = backend_wait, .output = backend_output, .backend = backend_context,                    \
    .traffic = backend_traffic

const pl_denoiser_ops pl_asvgf_ops = {
    .info = {"asvgf",
             "A-SVGF (Schied et al. 2018): SVGF whose history length follows temporal gradients "
             "of re-shaded samples",
             PL_DN_GRADIENTS | PL_DN_FILTERS | PL_DN_DUMPS, "svgf", asvgf_params,
             sizeof asvgf_params / sizeof *asvgf_params, backend_passes, BACKEND_PASSES},
    BACKEND_OPS(mode_asvgf)};
const pl_denoiser_ops pl_svgf_ops = {
    .info = {"svgf",
             "SVGF (Schied et al. 2017): temporal accumulation and variance-guided a-trous",
             PL_DN_FILTERS | PL_DN_DUMPS, NULL, svgf_params,
             sizeof svgf_params / sizeof *svgf_params, backend_passes, BACKEND_PASSES},
    BACKEND_OPS(mode_svgf)};
const pl_denoiser_ops pl_off_ops = {
    .info = {"off", "the noisy signals composited (no denoising)", PL_DN_DUMPS, NULL, NULL, 0,
             backend_passes, BACKEND_PASSES},
    BACKEND_OPS(mode_off)};
