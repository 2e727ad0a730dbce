/* pipeline/pl_dn_backend.c: the built-in back-end (denoise/: SVGF, A-SVGF, the recurrent
 * denoiser, the plain composite) as four registered denoisers: their parameters (one pl_param
 * table; dn_desc fields they set), their passes (dn_timings' fields), and the operations over
 * dn_context.
 * Entry points: pl_asvgf_ops, pl_recurrent_ops, pl_svgf_ops, pl_off_ops (also the plugin adapter's composite of
 * the noisy radiance). */
#include "pipeline/pl_internal.h"

#include <stdlib.h>
#include <string.h>

/* ---- the built-in back-end (denoise/): SVGF, A-SVGF, the plain composite ------------------- */
/* clang-format off */
static const pl_param p_atrous = {
    .name = "atrous", .kind = PL_PARAM_UINT, .min = 1, .max = 5, .arg = "N",
    .help = "a-trous iterations of hf and spec (default 4 and 3; 1 to 5)",
    .keys = ",."};
static const pl_param p_min_alpha = {
    .name = "min-alpha", .kind = PL_PARAM_FLOAT, .min = 0, .max = 1, .min_open = true,
    .arg = "A",
    .help = "temporal accumulation: the smallest weight of the new frame, hf/lf/spec (default "
            ".02/.01/.01)",
    .keys = "M", .steps = {0, 0.05, 0.1, 0.2}, .nsteps = 4};
static const pl_param p_antilag = {
    .name = "antilag", .kind = PL_PARAM_FLOAT, .min = 0, .max = 100, .min_open = true,
    .arg = "G",
    .help = "asvgf, recurrent: the hf antilag gain (how fast history drops where the "
            "gradients say the signal changed; default 1)",
    .keys = "G", .steps = {0, 2.0, 0.5}, .nsteps = 3};
static const pl_param p_antilag_lf = {
    .name = "antilag-lf", .kind = PL_PARAM_FLOAT, .min = 0, .max = 100, .min_open = true,
    .arg = "G",
    .help = "asvgf, recurrent: the lf (indirect light) antilag gain (default 1; docs/denoise.md)"};
static const pl_param p_lf_sigma = {
    .name = "lf-sigma", .kind = PL_PARAM_FLOAT, .min = 0, .max = 100, .min_open = true,
    .arg = "S",
    .help = "the lf filter's luminance weight: standard deviations of the noise left in its "
            "histories (default 2; docs/denoise.md)"};
static const pl_param p_hf_sigma = {
    .name = "hf-sigma", .kind = PL_PARAM_FLOAT, .min = 0, .max = 100, .min_open = true,
    .arg = "S",
    .help = "the hf a-trous luminance weight: standard deviations of the hf history's mean "
            "(default 4, Q2RTX's; docs/denoise.md)"};
static const pl_param p_fast = {
    .name = "fast", .kind = PL_PARAM_UINT, .min = 1, .max = 30, .arg = "N",
    .help = "recurrent: the fast history's length in frames, whose statistics clamp the slow "
            "history (default 6)",
    .keys = "H", .steps = {0, 3, 12}, .nsteps = 3};
static const pl_param p_clamp_sigma = {
    .name = "clamp-sigma", .kind = PL_PARAM_FLOAT, .min = 0, .max = 10, .min_open = true,
    .arg = "S",
    .help = "recurrent: the clamp's half-width in standard deviations of the fast histories' "
            "5x5 neighbourhood (default 2)",
    .keys = "C", .steps = {0, 1, 4}, .nsteps = 3};
static const pl_param p_history_fix = {
    .name = "history-fix", .kind = PL_PARAM_UINT, .min = 1, .max = 8, .arg = "N",
    .help = "recurrent: histories of at most N frames are rebuilt from their neighbours' "
            "(default 3)"};
static const pl_param p_resample = {
    .name = "resample", .kind = PL_PARAM_UINT, .min = 1, .max = 2, .arg = "1|2",
    .help = "recurrent: the slow histories' resampling where the 4x4 footprint saw the "
            "surface: 1 Catmull-Rom, 2 the tested bilinear taps (default 2)"};
/* clang-format on */

static const pl_param *const svgf_params[] = {&p_atrous, &p_min_alpha, &p_lf_sigma, &p_hf_sigma};
static const pl_param *const recurrent_params[] = {
    &p_atrous,      &p_min_alpha,   &p_antilag,  &p_antilag_lf, &p_fast,
    &p_clamp_sigma, &p_history_fix, &p_lf_sigma, &p_hf_sigma,   &p_resample};
static const pl_param *const asvgf_params[] = {&p_atrous,     &p_min_alpha, &p_antilag,
                                               &p_antilag_lf, &p_lf_sigma,  &p_hf_sigma};

/* The back-end's passes (timings.json's keys as they always were) and, for each, its field of
 * dn_timings / dn_traffic (0 select, 1 gradient, 2 temporal, 3 lf, 4 atrous, 5 composite): A-SVGF
 * runs all of them, SVGF no gradient work, "off" the composite alone; recurrent adds its history
 * pass (6). */
/* clang-format off */
#define PASS_SELECT {"select", "denoise_select_ms", PL_GROUP_GRADIENTS, NULL}
#define PASS_GRADIENT {"gradient", "denoise_gradient_ms", PL_GROUP_GRADIENTS, NULL}
#define PASS_TEMPORAL {"temporal", "denoise_temporal_ms", PL_GROUP_BACKEND, NULL}
#define PASS_LF {"lf", "denoise_lf_ms", PL_GROUP_BACKEND, "atrous"}
#define PASS_ATROUS {"atrous", "denoise_atrous_ms", PL_GROUP_BACKEND, NULL}
#define PASS_COMPOSITE {"composite", "composite_ms", PL_GROUP_BACKEND, NULL}
#define PASS_HISTORY {"history", "denoise_history_ms", PL_GROUP_BACKEND, NULL}
/* clang-format on */
static const pl_pass asvgf_passes[] = {PASS_SELECT, PASS_GRADIENT, PASS_TEMPORAL,
                                       PASS_LF,     PASS_ATROUS,   PASS_COMPOSITE};
static const pl_pass recurrent_passes[] = {PASS_SELECT, PASS_GRADIENT, PASS_TEMPORAL,
                                           PASS_HISTORY, PASS_LF,       PASS_ATROUS,
                                           PASS_COMPOSITE};
static const pl_pass svgf_passes[] = {PASS_TEMPORAL, PASS_LF, PASS_ATROUS, PASS_COMPOSITE};
static const pl_pass off_passes[] = {PASS_COMPOSITE};

typedef struct variant {
    dn_mode mode;
    uint8_t field[7]; /* each pass's field of dn_timings / dn_traffic */
} variant;
static const variant v_recurrent = {DN_MODE_RECURRENT, {0, 1, 2, 6, 3, 4, 5}},
                     v_asvgf = {DN_MODE_ASVGF, {0, 1, 2, 3, 4, 5}},
                     v_svgf = {DN_MODE_SVGF, {2, 3, 4, 5}}, v_off = {DN_MODE_OFF, {5}};

/* the context: the back-end's, and which variant runs (its passes) */
typedef struct backend {
    dn_context *dn;
    const variant *v;
    uint32_t npasses;
} backend;

static void backend_param(dn_desc *d, const char *name, double v)
{
    if (strcmp(name, "atrous") == 0)
        d->iters_hf = d->iters_spec = (uint32_t)v;
    else if (strcmp(name, "min-alpha") == 0)
        d->min_alpha_hf = d->min_alpha_lf = d->min_alpha_spec = (float)v;
    else if (strcmp(name, "antilag") == 0)
        d->antilag_hf = (float)v;
    else if (strcmp(name, "antilag-lf") == 0)
        d->antilag_lf = (float)v;
    else if (strcmp(name, "lf-sigma") == 0)
        d->lf_sigma = (float)v;
    else if (strcmp(name, "hf-sigma") == 0)
        d->hf_sigma = (float)v;
    else if (strcmp(name, "fast") == 0)
        d->fast_frames = (float)v;
    else if (strcmp(name, "clamp-sigma") == 0)
        d->clamp_sigma = (float)v;
    else if (strcmp(name, "history-fix") == 0)
        d->history_fix = (float)v;
    else if (strcmp(name, "resample") == 0)
        d->resample = (uint32_t)v;
}

static void backend_destroy(void *ctx)
{
    backend *b = ctx;
    if (b)
        dn_destroy(b->dn);
    free(b);
}

static tnd_result backend_create(const pl_dn_desc *d, void **out)
{
    backend *b = calloc(1, sizeof *b);
    if (!b)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
    b->v = d->data;
    b->npasses = d->npasses;
    dn_desc dd = d->backend ? *d->backend : (dn_desc){0};
    dd.mode = b->v->mode;
    dd.precision = d->precision;
    for (uint32_t i = 0; d->params && i < d->params->n; i++)
        backend_param(&dd, d->params->param[i]->name, d->params->value[i]);
    tnd_result res = dn_create(d->vk, d->width, d->height, &dd, &b->dn);
    if (res != TND_OK) {
        backend_destroy(b);
        return res;
    }
    *out = b;
    return TND_OK;
}

static uint32_t backend_capacity(const void *ctx)
{
    return dn_gradient_capacity(((const backend *)ctx)->dn);
}

static tnd_result backend_select(void *ctx, const tnd_contract_gpu *ct, const dn_frame *f,
                                 uint32_t *words, VkBuffer *slots, uint32_t *n, uint32_t *row)
{
    dn_context *dn = ((backend *)ctx)->dn;
    return words ? dn_select_gradients(dn, ct, f, words, n)
                 : dn_select_gradients_gpu(dn, ct, f, slots, n, row);
}

static tnd_result backend_gradient_values(void *ctx, const uint32_t *words, uint32_t n,
                                          const tnd_frame *reshaded)
{
    return dn_set_gradient_values(((backend *)ctx)->dn, words, n, reshaded);
}

static tnd_result backend_submit(void *ctx, const pl_dn_input *in)
{
    dn_frame f = *in->frame;
    dn_frame_set_camera(&f, in->camera ? &in->camera->state : NULL);
    return dn_submit(((backend *)ctx)->dn, in->contract, &f);
}

static tnd_result backend_wait(void *ctx, double *ms, bool *beside)
{
    backend *b = ctx;
    dn_timings t;
    tnd_result res = dn_wait(b->dn, &t);
    if (res != TND_OK)
        return res;
    const double v[7] = {t.select_ms, t.gradient_ms,  t.temporal_ms, t.lf_ms,
                         t.atrous_ms, t.composite_ms, t.history_ms};
    for (uint32_t k = 0; k < b->npasses; k++)
        ms[k] = v[b->v->field[k]];
    *beside = t.lf_beside_atrous;
    return TND_OK;
}

static const tnd_image *backend_output(const void *ctx)
{
    return dn_output(((const backend *)ctx)->dn);
}

static dn_context *backend_context(void *ctx)
{
    return ((backend *)ctx)->dn;
}

static void backend_traffic(const void *ctx, double *bytes)
{
    const backend *b = ctx;
    dn_traffic t;
    dn_traffic_of(b->dn, &t);
    const double v[7] = {t.select, t.gradient,  t.temporal, t.lf,
                         t.atrous, t.composite, t.history};
    for (uint32_t k = 0; k < b->npasses; k++)
        bytes[k] = v[b->v->field[k]];
}

#define BACKEND_OPS(mode_var)                                                                      \
    .data = &mode_var, .create = backend_create, .destroy = backend_destroy,                       \
    .capacity = backend_capacity, .select = backend_select,                                        \
    .gradient_values = backend_gradient_values, .submit = backend_submit,                          \
    .wait = backend_wait, .output = backend_output, .backend = backend_context,                    \
    .traffic = backend_traffic

const pl_denoiser_ops pl_asvgf_ops = {
    .info = {"asvgf",
             "A-SVGF (Schied et al. 2018): SVGF whose history length follows temporal gradients "
             "of re-shaded samples",
             PL_DN_GRADIENTS | PL_DN_FILTERS | PL_DN_DUMPS | PL_DN_DIFFUSE_VIEW, "svgf",
             asvgf_params,
             sizeof asvgf_params / sizeof *asvgf_params, asvgf_passes,
             sizeof asvgf_passes / sizeof *asvgf_passes},
    BACKEND_OPS(v_asvgf)};
const pl_denoiser_ops pl_recurrent_ops = {
    .info = {"recurrent",
             "recurrent (after NVIDIA's ReLAX): slow histories clamped to fast ones, history fix, "
             "gradients as the history's confidence where samples are re-shaded",
             PL_DN_CONFIDENCE | PL_DN_SPEC_HIT | PL_DN_FILTERS | PL_DN_DUMPS | PL_DN_DIFFUSE_VIEW,
             NULL,
             recurrent_params,
             sizeof recurrent_params / sizeof *recurrent_params, recurrent_passes,
             sizeof recurrent_passes / sizeof *recurrent_passes},
    BACKEND_OPS(v_recurrent)};
const pl_denoiser_ops pl_svgf_ops = {
    .info = {"svgf", "SVGF (Schied et al. 2017): temporal accumulation and variance-guided a-trous",
             PL_DN_FILTERS | PL_DN_DUMPS | PL_DN_DIFFUSE_VIEW, NULL, svgf_params,
             sizeof svgf_params / sizeof *svgf_params, svgf_passes,
             sizeof svgf_passes / sizeof *svgf_passes},
    BACKEND_OPS(v_svgf)};
const pl_denoiser_ops pl_off_ops = {.info = {"off", "the noisy signals composited (no denoising)",
                                             PL_DN_DUMPS, NULL, NULL, 0, off_passes,
                                             sizeof off_passes / sizeof *off_passes},
                                    BACKEND_OPS(v_off)};
