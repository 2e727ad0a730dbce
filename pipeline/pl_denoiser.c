/* pipeline/pl_denoiser.c: the denoisers' registry and the built-in back-end's adapter. Each
 * entry says what the denoiser is: its name, its capabilities (PL_DN_*: re-shaded gradient
 * samples, filtering, the back-end's dumps), its parameters (one pl_param table: the command
 * line, run.json, the viewer's keys and states and the sweep's knobs are made from it) and the
 * passes it times. A new built-in denoiser is one more line in `registry[]` (docs/extending.md).
 * Entry points: pl_denoiser_names, pl_denoiser_count, pl_denoiser_at, pl_denoiser_find,
 * pl_denoiser_has_param, pl_denoiser_for, pl_pass_all, pl_pass_owner_of, pl_pass_group_name, pl_param_count,
 * pl_param_at, pl_param_find, pl_param_set_put, pl_param_set_get, pl_param_key,
 * pl_denoiser_ops_find, pl_backend_off_ops. */
#include "pipeline/pl_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
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

static const pl_denoiser_ops asvgf_ops = {
    .info = {"asvgf",
             "A-SVGF (Schied et al. 2018): SVGF whose history length follows temporal gradients "
             "of re-shaded samples",
             PL_DN_GRADIENTS | PL_DN_FILTERS | PL_DN_DUMPS, "svgf", asvgf_params,
             sizeof asvgf_params / sizeof *asvgf_params, backend_passes, BACKEND_PASSES},
    BACKEND_OPS(mode_asvgf)};
static const pl_denoiser_ops svgf_ops = {
    .info = {"svgf",
             "SVGF (Schied et al. 2017): temporal accumulation and variance-guided a-trous",
             PL_DN_FILTERS | PL_DN_DUMPS, NULL, svgf_params,
             sizeof svgf_params / sizeof *svgf_params, backend_passes, BACKEND_PASSES},
    BACKEND_OPS(mode_svgf)};
static const pl_denoiser_ops off_ops = {
    .info = {"off", "the noisy signals composited (no denoising)", PL_DN_DUMPS, NULL, NULL, 0,
             backend_passes, BACKEND_PASSES},
    BACKEND_OPS(mode_off)};
const pl_denoiser_ops pl_backend_off_ops = {
    .info = {"off", "", PL_DN_DUMPS, NULL, NULL, 0, backend_passes, BACKEND_PASSES},
    BACKEND_OPS(mode_off)};

/* ---- the registry ----------------------------------------------------------------------------- */
static const pl_denoiser_ops *const registry[] = {&asvgf_ops, &svgf_ops, &off_ops};
enum { REGISTERED = sizeof registry / sizeof registry[0] };

const char *pl_denoiser_names(void)
{
    static char names[256];
    if (!names[0])
        for (int i = 0; i < REGISTERED; i++)
            snprintf(names + strlen(names), sizeof names - strlen(names), "%s%s", i ? ", " : "",
                     registry[i]->info.name);
    return names;
}

uint32_t pl_denoiser_count(void)
{
    return REGISTERED;
}

const pl_denoiser_info *pl_denoiser_at(uint32_t i)
{
    return i < REGISTERED ? &registry[i]->info : NULL;
}

const pl_denoiser_ops *pl_denoiser_ops_find(const char *name)
{
    if (strncmp(name, "plugin:", 7) == 0)
        return name[7] ? &pl_plugin_denoiser_ops : NULL;
    for (int i = 0; i < REGISTERED; i++)
        if (strcmp(registry[i]->info.name, name) == 0)
            return registry[i];
    return NULL;
}

tnd_result pl_denoiser_find(const char *name, const pl_denoiser_info **info)
{
    const pl_denoiser_ops *ops = pl_denoiser_ops_find(name);
    *info = ops ? &ops->info : NULL;
    if (!ops)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "denoiser '%s' (expected %s or plugin:PATH.so)",
                        name, pl_denoiser_names());
    return TND_OK;
}

bool pl_denoiser_has_param(const pl_denoiser_info *d, const char *name)
{
    for (uint32_t i = 0; i < d->nparams; i++)
        if (strcmp(d->params[i]->name, name) == 0)
            return true;
    return false;
}

const pl_denoiser_info *pl_denoiser_for(const pl_denoiser_info *d, uint32_t fe_caps)
{
    const pl_denoiser_ops *fb;
    if ((d->caps & PL_DN_GRADIENTS) && !(fe_caps & PL_CAP_RESHADE) && d->fallback &&
        (fb = pl_denoiser_ops_find(d->fallback)))
        return &fb->info;
    return d;
}

/* ---- passes ------------------------------------------------------------------------------------ */
const char *pl_pass_group_name(pl_pass_group g)
{
    static const char *const names[PL_GROUPS] = {"front-end", "gradients", "back-end", "post"};
    return g < PL_GROUPS ? names[g] : "?";
}

/* (pl_chain.c's tables of the front-end's and the post chain's passes) */
extern const pl_pass pl_frontend_passes[], pl_post_passes[];
extern const uint32_t pl_frontend_pass_count, pl_post_pass_count;

static void add_passes(const pl_pass *p, uint32_t n, const pl_pass **out, uint32_t max,
                       uint32_t *count)
{
    for (uint32_t i = 0; i < n; i++) {
        bool seen = false;
        for (uint32_t k = 0; k < *count && k < max; k++)
            seen = seen || strcmp(out[k]->key, p[i].key) == 0;
        if (!seen && *count < max)
            out[(*count)++] = &p[i];
    }
}

uint32_t pl_pass_all(const pl_pass **out, uint32_t max)
{
    uint32_t n = 0;
    add_passes(pl_frontend_passes, pl_frontend_pass_count, out, max, &n);
    for (int i = 0; i < REGISTERED; i++)
        add_passes(registry[i]->info.passes, registry[i]->info.npasses, out, max, &n);
    add_passes(pl_plugin_denoiser_ops.info.passes, pl_plugin_denoiser_ops.info.npasses, out, max,
               &n);
    add_passes(pl_post_passes, pl_post_pass_count, out, max, &n);
    return n;
}

pl_pass_owner pl_pass_owner_of(const pl_pass *p)
{
    if (p >= pl_frontend_passes && p < pl_frontend_passes + pl_frontend_pass_count)
        return PL_OWNER_FRONTEND;
    if (p >= pl_post_passes && p < pl_post_passes + pl_post_pass_count)
        return PL_OWNER_POST;
    return PL_OWNER_DENOISER;
}

/* ---- parameters -------------------------------------------------------------------------------- */
static uint32_t params_all(const pl_param **out)
{
    uint32_t n = 0;
    for (int i = 0; i < REGISTERED; i++)
        for (uint32_t k = 0; k < registry[i]->info.nparams; k++) {
            const pl_param *p = registry[i]->info.params[k];
            bool seen = false;
            for (uint32_t j = 0; j < n; j++)
                seen = seen || strcmp(out[j]->name, p->name) == 0;
            if (!seen && n < PL_PARAMS_MAX)
                out[n++] = p;
        }
    return n;
}

uint32_t pl_param_count(void)
{
    const pl_param *all[PL_PARAMS_MAX];
    return params_all(all);
}

const pl_param *pl_param_at(uint32_t i)
{
    const pl_param *all[PL_PARAMS_MAX];
    return i < params_all(all) ? all[i] : NULL;
}

const pl_param *pl_param_find(const char *name)
{
    const pl_param *all[PL_PARAMS_MAX];
    uint32_t n = params_all(all);
    for (uint32_t i = 0; i < n; i++)
        if (strcmp(all[i]->name, name) == 0)
            return all[i];
    return NULL;
}

const char *pl_param_key(const pl_param *p, char *buf, size_t cap)
{
    snprintf(buf, cap, "%s", p->name);
    for (char *c = buf; *c; c++)
        if (*c == '-')
            *c = '_';
    return buf;
}

tnd_result pl_param_set_put(pl_param_set *s, const char *name, double v)
{
    const pl_param *p = pl_param_find(name);
    if (!p)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "no denoiser has a parameter '%s'", name);
    bool ok = isfinite(v) && (v == 0 || ((p->min_open ? v > p->min : v >= p->min) && v <= p->max &&
                                         (p->kind != PL_PARAM_UINT || v == floor(v))));
    if (!ok)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--%s %g: expected %s in %c%g, %g]", p->name, v,
                        p->kind == PL_PARAM_UINT ? "a whole number" : "a value",
                        p->min_open ? '(' : '[', p->min, p->max);
    uint32_t i = 0;
    while (i < s->n && s->param[i] != p)
        i++;
    if (v == 0) { /* the default again */
        if (i < s->n) {
            memmove(&s->param[i], &s->param[i + 1], (s->n - i - 1) * sizeof *s->param);
            memmove(&s->value[i], &s->value[i + 1], (s->n - i - 1) * sizeof *s->value);
            s->n--;
        }
        return TND_OK;
    }
    if (i == s->n) {
        if (s->n == PL_PARAMS_MAX)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "more than %d parameters", PL_PARAMS_MAX);
        s->param[s->n++] = p;
    }
    s->value[i] = v;
    return TND_OK;
}

double pl_param_set_get(const pl_param_set *s, const char *name)
{
    for (uint32_t i = 0; i < s->n; i++)
        if (strcmp(s->param[i]->name, name) == 0)
            return s->value[i];
    return 0.0;
}
