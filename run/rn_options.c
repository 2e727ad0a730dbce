/* run/rn_options.c: a render's and a reference's options: their defaults, their check (the
 * errors that name an option), the command line that gives them back (the sweep's Slurm jobs, a
 * reference's resume state), the post chain's settings, the pipeline they build and the frame
 * loop's steps every run shares (render, references, the session, the dataset, the viewer).
 * Entry points: rn_render_defaults, rn_render_args, rn_render_check, rn_reference_bounces,
 * rn_taa_parse, rn_pipeline_open, rn_frame_begin, rn_frame_step. */
#include "run/rn_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#ifndef TND_DATA_DIR
#define TND_DATA_DIR "data"
#endif

typedef rn_render_opts render_opts;

void rn_render_defaults(rn_render_opts *o)
{
    *o = (render_opts){.scene = TND_DATA_DIR "/scenes/cornell.gltf",
                       .env = RN_ENV_INIT,
                       .frontend = "embree",
                       .precision = "float32",
                       .rt_api = "auto",
                       .pipeline = "scene",
                       .lights = "auto",
                       .denoiser = pl_denoiser_default(),
                       .taa = NULL, /* (on; given: said where it cannot run) */
                       .tonemap = "aces",
                       .exposure = "auto",
                       .frames = 8,
                       .bounces = 1,
                       .spp = 256,
                       .ref_bounces = ~0u,
                       .estimator = "unbiased",
                       .composite_on = "device",
                       .checkpoint_s = 60.0,
                       .size = {320, 180},
                       .render_scale = 1.0,
                       .upscaler = "temporal",
                       .fps = 30.0};
}

/* ---- options back into a command line ------------------------------------------------------- */
static bool arg(rn_args *a, const char *v)
{
    if (!v || a->n >= (int)(sizeof a->v / sizeof a->v[0]))
        return false;
    a->v[a->n++] = v;
    return true;
}

/* a formatted string kept in the struct (NULL when it is full) */
static const char *keep(rn_args *a, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static const char *keep(rn_args *a, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int len = vsnprintf(a->buf + a->used, sizeof a->buf - a->used, fmt, ap);
    va_end(ap);
    if (len < 0 || (size_t)len >= sizeof a->buf - a->used)
        return NULL;
    const char *v = a->buf + a->used;
    a->used += (size_t)len + 1;
    return v;
}

#define argf(a, name, ...) (arg(a, name) && arg(a, keep(a, __VA_ARGS__)))

/* a number as short as reads back the same */
static const char *keep_num(rn_args *a, double v)
{
    char t[40];
    snprintf(t, sizeof t, "%.15g", v);
    return keep(a, strtod(t, NULL) == v ? "%.15g" : "%.17g", v);
}
#define argn(a, name, v) (arg(a, name) && arg(a, keep_num(a, v)))

static bool args_str(rn_args *a, const char *name, const char *v, const char *def)
{
    return !v || (def && strcmp(v, def) == 0) || (arg(a, name) && arg(a, v));
}

tnd_result rn_render_args(const rn_render_opts *o, bool reference, rn_args *a)
{
    render_opts d;
    rn_render_defaults(&d);
    a->n = 0;
    a->used = 0;
    bool ok = arg(a, reference ? "reference" : "render");
    ok = ok && args_str(a, "--scene", o->scene, d.scene) &&
         args_str(a, "--frontend", o->frontend, d.frontend);
    if (reference)
        ok = ok && args_str(a, "--estimator", o->estimator, d.estimator);
    ok = ok && (o->frames == d.frames || argf(a, "--frames", "%u", o->frames)) &&
         (o->start == d.start || argf(a, "--start", "%u", o->start)) &&
         (o->fps == d.fps || argn(a, "--fps", o->fps)) &&
         ((o->size[0] == d.size[0] && o->size[1] == d.size[1]) ||
          argf(a, "--size", "%ux%u", o->size[0], o->size[1])) &&
         (o->camera == d.camera || argf(a, "--camera", "%u", o->camera)) &&
         (o->threads == d.threads || argf(a, "--threads", "%u", o->threads)) &&
         (o->reflect_depth == d.reflect_depth ||
          argf(a, "--reflect-depth", "%u", o->reflect_depth)) &&
         args_str(a, "--lights", o->lights, d.lights);
    if (reference)
        ok = ok && (o->ref_bounces == RN_BOUNCES_HALF ? args_str(a, "--bounces", "half", NULL)
                    : o->ref_bounces == d.ref_bounces ||
                          argf(a, "--bounces", "%u", o->ref_bounces)) &&
             (o->spp == d.spp || argf(a, "--spp", "%u", o->spp)) &&
             (o->until_noise == d.until_noise ||
              argn(a, "--until-noise", o->until_noise)) &&
             args_str(a, "--shard", o->shard, NULL) && args_str(a, "--rt-api", o->rt_api, d.rt_api) &&
             args_str(a, "--composite-on", o->composite_on, d.composite_on) &&
             (o->checkpoint_s == d.checkpoint_s || argn(a, "--checkpoint", o->checkpoint_s));
    else {
        ok = ok && (o->half_indirect ? args_str(a, "--bounces", "half", NULL)
                                     : o->bounces == d.bounces ||
                                           argf(a, "--bounces", "%u", o->bounces)) &&
             args_str(a, "--denoiser", o->denoiser, d.denoiser);
        for (uint32_t i = 0; ok && i < o->params.n; i++) /* the denoiser's parameters */
            ok = argn(a, keep(a, "--%s", o->params.param[i]->name), o->params.value[i]);
        ok = ok && args_str(a, "--precision", o->precision, d.precision) &&
             args_str(a, "--rt-api", o->rt_api, d.rt_api) &&
             args_str(a, "--pipeline", o->pipeline, d.pipeline) &&
             args_str(a, "--taa", o->taa, "on") &&
             args_str(a, "--tonemap", o->tonemap, d.tonemap) &&
             args_str(a, "--exposure", o->exposure, d.exposure) &&
             (o->bloom == d.bloom || argn(a, "--bloom", o->bloom)) &&
             (o->exposure_bias == d.exposure_bias ||
              argn(a, "--exposure-bias", o->exposure_bias)) &&
             args_str(a, "--dump", o->dump, NULL) && (!o->capture || arg(a, "--capture")) &&
             (!o->video || arg(a, "--video")) &&
             (o->timed_frames == d.timed_frames ||
              argf(a, "--timed-frames", "%u", o->timed_frames)) &&
             (o->render_scale == d.render_scale ||
              argn(a, "--render-scale", o->render_scale)) &&
             args_str(a, "--upscaler", o->upscaler, d.upscaler);
    }
    ok = ok && args_str(a, "--env", o->env.path, NULL) &&
         (!o->env.path || o->env.intensity == d.env.intensity ||
          argn(a, "--env-intensity", o->env.intensity)) &&
         (!o->env.path || o->env.rotation == d.env.rotation ||
          argn(a, "--env-rotation", o->env.rotation)) &&
         (!o->env.no_default_light || arg(a, "--no-default-light")) &&
         args_str(a, "--up", o->env.up, "y") &&
         args_str(a, "--camera-path", o->env.camera_path, NULL) &&
         (!o->env.camera_path || o->env.path_duration == d.env.path_duration ||
          argn(a, "--path-duration", o->env.path_duration)) &&
         (!o->env.camera_path || o->env.path_radius == d.env.path_radius ||
          argn(a, "--path-radius", o->env.path_radius)) &&
         (!o->env.camera_path || !isfinite(o->env.path_height) ||
          argn(a, "--path-height", o->env.path_height)) &&
         args_str(a, "--out", o->out, NULL) && (!o->quiet || arg(a, "--quiet"));
    if (!ok)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: its command line is too long",
                        reference ? "reference" : "render");
    if (o->view)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "render: a view state has no command line here");
    return TND_OK;
}

void rn_reference_bounces(rn_render_opts *o)
{
    bool rt = strcmp(o->estimator, "realtime") == 0;
    if (o->ref_bounces == RN_BOUNCES_HALF) /* (realtime: rn_render_check refuses the other) */
        o->ref_bounces = 1;
    if (rt)
        o->bounces = o->ref_bounces == ~0u ? 1 : o->ref_bounces;
    o->ref_bounces = rt || o->ref_bounces == ~0u ? 0 : o->ref_bounces;
}

/* The options' values checked (render's and reference's, parsed or filled by a caller): an error
 * names the option. */
void rn_render_size(const rn_render_opts *o, uint32_t out[2])
{
    double sc = o->render_scale > 0 && o->render_scale < 1 ? o->render_scale : 1.0;
    for (int k = 0; k < 2; k++) {
        double v = floor(o->size[k] * sc + 0.5);
        out[k] = v < 1 ? 1u : (uint32_t)v;
    }
}

tnd_light_sampling rn_lights_mode(const rn_render_opts *o)
{
    tnd_light_sampling m = TND_LIGHTS_AUTO;
    if (o->lights)
        tnd_light_sampling_parse(o->lights, &m);
    return m;
}

tnd_result rn_render_check(const rn_render_opts *o, bool reference)
{
    if (strcmp(o->pipeline, "scene") != 0 && strcmp(o->pipeline, "full") != 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--pipeline %s: expected scene or full",
                        o->pipeline);
    if (!pl_frontend_live(o->frontend))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--frontend '%s': expected %s", o->frontend,
                        pl_frontend_live_names());
    if (o->reflect_depth > 16)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--reflect-depth is 1 to 16");
    tnd_light_sampling ls;
    if (!tnd_light_sampling_parse(o->lights ? o->lights : "auto", &ls))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--lights %s: expected auto, plain, tree or restir",
                        o->lights);
    if (!(o->render_scale >= 0.25 && o->render_scale <= 1))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--render-scale %g: expected 0.25 to 1",
                        o->render_scale);
    cmp_upscaler up;
    if (o->upscaler && cmp_upscaler_parse(o->upscaler, &up) != TND_OK) {
        tnd_error_clear();
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--upscaler %s: expected " CMP_UPSCALER_NAMES, o->upscaler);
    }
    if (reference && o->render_scale != 1)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--render-scale: render only (the matched "
                                                  "reference of a scaled run is the full "
                                                  "size's: docs/upscaling.md)");
    if (o->timed_frames && o->view) /* (its camera path ends with the frames written) */
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--timed-frames runs the scene's path on after the frames; "
                        "not with --view");
    if (o->video && !rn_have_program("ffmpeg"))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--video needs ffmpeg on PATH (Debian package ffmpeg)");
    if (reference && strcmp(o->estimator, "unbiased") != 0 && strcmp(o->estimator, "realtime"))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--estimator %s: expected unbiased or realtime",
                        o->estimator);
    if (reference && strcmp(o->composite_on, "device") != 0 && strcmp(o->composite_on, "host"))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--composite-on %s: expected device or host",
                        o->composite_on);
    if (reference && o->ref_bounces == RN_BOUNCES_HALF && strcmp(o->estimator, "realtime") != 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--bounces half: only with the realtime "
                                                  "estimator (unbiased: a cap on the path length)");
    if (reference && (o->until_noise < 0 || o->until_noise >= 1))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--until-noise is a fraction in (0, 1)");
    if (o->frames == 0 || !(o->fps > 0) || (reference && o->spp == 0))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--frames, --fps and --spp must be positive");
    return TND_OK;
}

tnd_result rn_frame_begin(const rn_render_opts *o, const tnd_scene *scene, pl_frontend *fr,
                           tnd_scene_state st[2], unsigned i, bool first, rn_frame_host *host)
{
    tnd_result res = TND_OK;
    double t0 = host ? tnd_now() : 0;
    unsigned f = o->start + i;
    float aspect = (float)o->size[0] / (float)o->size[1];
    tnd_scene_state *cur = &st[i & 1], *prev = &st[(i + 1) & 1];
    TND_TRY(tnd_scene_evaluate(scene, f / o->fps, o->camera, aspect, cur));
    if (first)
        TND_TRY(tnd_scene_evaluate(scene, f > 0 ? (f - 1) / o->fps : 0.0, o->camera, aspect, prev));
    if (o->view) { /* the viewer's camera (its first frame: no camera motion before it) */
        rn_view_camera_apply(rn_view_state_at(o->view, i), cur);
        if (first)
            rn_view_camera_apply(rn_view_state_at(o->view, i > 0 ? i - 1 : 0), prev);
    }
    uint32_t rs[2];
    rn_render_size(o, rs);
    double t1 = host ? tnd_now() : 0;
    TND_TRY(pl_frontend_set_frame(fr, cur, prev, f, rs[0], rs[1]));
    if (host)
        *host = (rn_frame_host){1e3 * (t1 - t0), 1e3 * (tnd_now() - t1)};
fail:
    return res;
}

pl_step rn_frame_step(const rn_render_opts *o, const tnd_scene_state *cur, unsigned i,
                       bool reset)
{
    uint32_t rs[2];
    rn_render_size(o, rs);
    return (pl_step){.params = {.bounces = o->bounces, .half_indirect = o->half_indirect},
                     .frame = dn_frame_for_camera(cur->camera.proj, rs[1], o->start + i,
                                                  reset),
                     .dt = (float)(1.0 / o->fps)};
}

/* the post chain's settings from the options */
tnd_result rn_taa_parse(const char *taa, struct cmp_desc *d)
{
    char *end;
    if (!taa || strcmp(taa, "on") == 0) {
        d->taa = true;
    } else if (strcmp(taa, "off") == 0) {
        d->taa = false;
    } else {
        double w = strtod(taa, &end);
        if (*end || !(w > 0 && w <= 1))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                            "--taa '%s': expected on, off or a new-frame weight in (0, 1]", taa);
        d->taa = true;
        d->taa_weight = (float)w;
    }
    return TND_OK;
}

static tnd_result post_desc(const render_opts *o, cmp_desc *d)
{
    tnd_result res = cmp_curve_parse(o->tonemap, &d->curve);
    if (res != TND_OK)
        return res;
    char *end;
    TND_TRY_RETURN(rn_taa_parse(o->taa, d));
    if (strcmp(o->exposure, "auto") != 0) {
        double ev = strtod(o->exposure, &end);
        if (*end || !isfinite(ev))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--exposure '%s': expected auto or an EV100",
                            o->exposure);
        d->fixed_exposure = true;
        d->ev100 = (float)ev;
    }
    d->bias = (float)o->exposure_bias;
    if (!(o->bloom >= 0 && o->bloom <= 1))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--bloom %g: expected an intensity in [0, 1]",
                        o->bloom);
    return TND_OK;
}


tnd_result rn_pipeline_open(const rn_render_opts *o, const tnd_scene *scene, tnd_vk *vk,
                            bool use_vk, bool use_dn, tnd_precision prec,
                            const pl_denoiser_info **dn, bool reference, pl_frontend **fr,
                            pl_chain **chain, cmp_desc *pd, const rn_host *h)
{
    tnd_result res = TND_OK;
    /* the interleave where the scene has surfaces that both reflect and refract (or forced) */
    *pd = (cmp_desc){.bloom = (float)o->bloom,
                   .interleave = (scene->features & TND_FEATURE(SPLIT)) != 0 ||
                                 strcmp(o->pipeline, "full") == 0};
    if (use_dn && (res = post_desc(o, pd)) != TND_OK)
        goto fail;
    uint32_t rs[2];
    rn_render_size(o, rs);
    TND_TRY(pl_frontend_create(o->frontend, scene,
                               &(pl_frontend_desc){.vk = use_vk ? vk : NULL, .precision = prec,
                                                   .rt_api = o->rt_api,
                                                   .full_pipeline =
                                                       strcmp(o->pipeline, "full") == 0,
                                                   .reflect_depth = o->reflect_depth,
                                                   .lights = rn_lights_mode(o),
                                                   .references = reference,
                                                   .bounces = o->bounces,
                                                   .half_indirect = o->half_indirect,
                                                   .threads = o->threads,
                                                   .scene_path = o->scene,
                                                   /* (textures filtered for the shown pixels) */
                                                   .footprint_scale =
                                                       (float)rs[1] / (float)o->size[1]},
                               fr));
    if (reference)
        return TND_OK; /* (no chain) */
    /* a denoiser that needs re-shaded gradient samples runs its fallback behind a front-end
     * that cannot re-shade them */
    const pl_denoiser_info *asked = *dn;
    *dn = pl_denoiser_for(asked, pl_frontend_caps(*fr));
    if (*dn != asked)
        rn_say(h, "tandem: render: --frontend %s cannot re-shade gradient samples: running %s "
                  "instead of %s", o->frontend, (*dn)->name, asked->name);
    if (o->upscaler)
        TND_TRY(cmp_upscaler_parse(o->upscaler, &pd->upscaler));
    pl_chain_desc cd = {.vk = vk, .width = rs[0], .height = rs[1], .out_width = o->size[0],
                        .out_height = o->size[1], .precision = prec,
                        .backend = use_dn,
                        .denoiser = (*dn)->caps & PL_DN_PLUGIN ? o->denoiser : (*dn)->name,
                        .post = *pd};
    for (uint32_t i = 0; i < o->params.n; i++) { /* (the others' are not its) */
        const char *pn = o->params.param[i]->name;
        if (pl_denoiser_has_param(*dn, pn))
            TND_TRY(pl_param_set_put(&cd.params, pn, o->params.value[i]));
        else if (!o->view && !o->quiet) /* (a viewer state keeps them all) */
            rn_say(h, "tandem: %s: --%s: %s has no such parameter (left out; tandem info "
                      "--pipeline lists each denoiser's)",
                   reference ? "reference" : "render", pn, (*dn)->name);
    }
    TND_TRY(pl_chain_create(&cd, chain));
fail:
    return res;
}
