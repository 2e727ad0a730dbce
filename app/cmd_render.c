/* app/cmd_render.c: `tandem render` (the real-time pipeline over a camera path: front-end,
 * back-end, post chain) and `tandem reference` (converged images). Writes DIR/frame_NNNN.exr
 * (linear HDR after TAA, before tone mapping), DIR/frame_NNNN.png (display), timings.json and
 * run.json. */
#include "app/app.h"
#include "shaders/specular.h"
#include "composite/composite.h"
#include "denoise/denoise.h"
#include "pipeline/pipeline.h"
#include "shaders/sampling.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/stat.h>

#ifndef TND_DATA_DIR
#define TND_DATA_DIR "data"
#endif

typedef app_render_opts render_opts;

static const app_cmd render_cmd = {
    "render",
    "Render a scene's camera path through a front-end: the contract (with --capture) and the\n"
    "composited frames (DIR/frame_NNNN.exr, linear HDR; DIR/frame_NNNN.png, a preview).",
    "--out DIR [--scene PATH] [--frontend embree] [--frames N] [--size WxH] [--capture] ...",
    NULL};
static const app_cmd reference_cmd = {
    "reference",
    "Render converged reference frames of a scene's camera path: DIR/frame_NNNN.exr (linear HDR\n"
    "radiance, and in variance.Y the variance of one sample's luminance, from which eval finds\n"
    "what a run is worth in samples) and DIR/reference.json (the samples, remaining noise,\n"
    "sampling time and paths per second of every frame). The unbiased path tracer (default), or\n"
    "with --estimator realtime the converged expectation of the real-time estimator `render`\n"
    "runs with the same --bounces and --reflect-depth (a matched reference: what a denoiser of\n"
    "that estimator can reach at best). Samples are shuffled Owen-scrambled Sobol' points\n"
    "(docs/estimator.md).",
    "--out DIR [--scene PATH] [--frontend embree] [--frames N] [--size WxH] [--spp K] "
    "[--shard I/N]", NULL};

/* render --view FILE: the viewer's settings and camera path (lives for the run) */
static app_view_state view_state;


void app_render_defaults(app_render_opts *o)
{
    *o = (render_opts){.scene = TND_DATA_DIR "/scenes/cornell.gltf",
                       .env = APP_ENV_INIT,
                       .frontend = "embree",
                       .precision = "float32",
                       .rt_api = "auto",
                       .pipeline = "scene",
                       .denoiser = pl_denoiser_default(),
                       .taa = "on",
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
                       .fps = 30.0};
}

/* ---- options back into a command line ------------------------------------------------------- */
static bool arg(app_args *a, const char *v)
{
    if (!v || a->n >= (int)(sizeof a->v / sizeof a->v[0]))
        return false;
    a->v[a->n++] = v;
    return true;
}

/* a formatted string kept in the struct (NULL when it is full) */
static const char *keep(app_args *a, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static const char *keep(app_args *a, const char *fmt, ...)
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
static const char *keep_num(app_args *a, double v)
{
    char t[40];
    snprintf(t, sizeof t, "%.15g", v);
    return keep(a, strtod(t, NULL) == v ? "%.15g" : "%.17g", v);
}
#define argn(a, name, v) (arg(a, name) && arg(a, keep_num(a, v)))

static bool args_str(app_args *a, const char *name, const char *v, const char *def)
{
    return !v || (def && strcmp(v, def) == 0) || (arg(a, name) && arg(a, v));
}

tnd_result app_render_args(const app_render_opts *o, bool reference, app_args *a)
{
    render_opts d;
    app_render_defaults(&d);
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
          argf(a, "--reflect-depth", "%u", o->reflect_depth));
    if (reference)
        ok = ok && (o->ref_bounces == APP_BOUNCES_HALF ? args_str(a, "--bounces", "half", NULL)
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
             args_str(a, "--taa", o->taa, d.taa) &&
             args_str(a, "--tonemap", o->tonemap, d.tonemap) &&
             args_str(a, "--exposure", o->exposure, d.exposure) &&
             (o->bloom == d.bloom || argn(a, "--bloom", o->bloom)) &&
             (o->exposure_bias == d.exposure_bias ||
              argn(a, "--exposure-bias", o->exposure_bias)) &&
             args_str(a, "--dump", o->dump, NULL) && (!o->capture || arg(a, "--capture")) &&
             (!o->video || arg(a, "--video")) &&
             (o->timed_frames == d.timed_frames ||
              argf(a, "--timed-frames", "%u", o->timed_frames));
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

static int parse_common(const app_cmd *cmd, render_opts *o, bool reference, int argc, char **argv)
{
    const char *view_path = NULL;
    app_render_defaults(o);
    char fe_help[200], dn_help[300];
    snprintf(fe_help, sizeof fe_help, "the front-end: %s (default embree)",
             pl_frontend_live_names());
    snprintf(dn_help, sizeof dn_help,
             "the denoiser: %s, plugin:PATH.so or python:MODULE:CALLABLE (default asvgf; "
             "docs/denoise.md)",
             pl_denoiser_names());
    /* what render and reference share: where, what, the path (one entry each) */
#define COMMON_OPTS \
    {"out", APP_OPT_STRING, &o->out, "DIR", "output directory (created)"}, \
    {"scene", APP_OPT_STRING, &o->scene, "PATH", "glTF scene or stress:N (default: cornell)"}, \
    {"frontend", APP_OPT_STRING, &o->frontend, "NAME", fe_help}
#define PATH_OPTS \
    {"frames", APP_OPT_UINT, &o->frames, "N", "frames of the camera path (default 8)"}, \
    {"start", APP_OPT_UINT, &o->start, "F", "first frame (default 0)"}, \
    {"fps", APP_OPT_FLOAT, &o->fps, "R", "frames per second of the path (default 30)"}, \
    {"size", APP_OPT_SIZE, o->size, "WxH", "image size (default 320x180)"}, \
    {"camera", APP_OPT_UINT, &o->camera, "I", "scene camera (default 0)"}, \
    {"threads", APP_OPT_UINT, &o->threads, "N", "CPU threads (default: all cores)"}
    const app_opt render_opts_tbl[] = {
        COMMON_OPTS,
        PATH_OPTS,
        {"bounces", APP_OPT_BOUNCES, &o->bounces, "N|half",
         "indirect bounces (default 1); half: one, traced for half the pixels each frame (a "
         "checkerboard that alternates, weighted 2: Q2RTX's GI low)"},
        {"reflect-depth", APP_OPT_UINT, &o->reflect_depth, "N",
         "mirrors and glass the primary pass looks through (default 4, 1 to 16)"},
        {"precision", APP_OPT_STRING, &o->precision, "P", "contract precision: float32 or packed"},
        {"capture", APP_OPT_FLAG, &o->capture, NULL, "also write DIR/capture/frame_NNNN.exr"},
        {"dump", APP_OPT_STRING, &o->dump, "LIST",
         "also write back-end buffers to DIR/dump/NAME_NNNN.exr: comma-separated names, or all "
         "(temporal.hf, temporal.moments, temporal.lf_sh, temporal.lf_cocg, temporal.spec, "
         "atrous.hf, atrous.spec, lf.sh, lf.cocg (1/3 res), gradients (1/3 res), output)"},
        {"denoiser", APP_OPT_STRING, &o->denoiser, "NAME", dn_help},
        {"rt-api", APP_OPT_STRING, &o->rt_api, "API",
         "vk: pipeline, query, or auto (query where the device has it)"},
        {"pipeline", APP_OPT_STRING, &o->pipeline, "scene|full",
         "vk: compile only what the scene requires (default), or every light type, textures, "
         "normal maps and sky (same images; for comparison)"},
        {"taa", APP_OPT_STRING, &o->taa, "on|off|W", "temporal anti-aliasing (on: new-frame weight 0.1)"},
        {"tonemap", APP_OPT_STRING, &o->tonemap, "CURVE", "aces (default), agx, reinhard or linear"},
        {"exposure", APP_OPT_STRING, &o->exposure, "auto|EV100",
         "auto exposure from the luminance histogram (default), or a fixed EV100"},
        {"bloom", APP_OPT_FLOAT, &o->bloom, "I", "bloom intensity (default 0: off)"},
        {"exposure-bias", APP_OPT_FLOAT, &o->exposure_bias, "STOPS",
         "added to the exposure, auto or fixed (default 0)"},
        {"video", APP_OPT_FLAG, &o->video, NULL, "also write DIR/video.mp4 from the PNGs (needs ffmpeg)"},
        {"timed-frames", APP_OPT_UINT, &o->timed_frames, "N",
         "after the frames written, N more of the path back to back (nothing waited for, nothing "
         "written, after 4 of warm-up): their GPU times per pass and wall clock per frame into "
         "timings.json's back_to_back (how bench --sweep times its cells)"},
        {"view", APP_OPT_STRING, &view_path, "FILE",
         "a repro state of tandem view: its scene, settings and camera path, frame for frame "
         "(over the options that set the same)"},
        APP_ENV_OPTS(&o->env),
        {0},
    };
    const app_opt ref_opts_tbl[] = {
        COMMON_OPTS,
        {"rt-api", APP_OPT_STRING, &o->rt_api, "API", "vk: pipeline, query or auto"},
        {"view", APP_OPT_STRING, &view_path, "FILE",
         "the camera path of a repro state of tandem view (render --view FILE renders the same "
         "frames): its scene, size, bounces and path, frame for frame"},
        PATH_OPTS,
        {"spp", APP_OPT_UINT, &o->spp, "K", "samples per pixel (default 256)"},
        {"estimator", APP_OPT_STRING, &o->estimator, "E",
         "unbiased (full paths, Russian roulette; the default) or realtime (the expectation of "
         "render's estimator: samples of it with fresh random numbers and pixel offsets, "
         "composited and averaged)"},
        {"bounces", APP_OPT_BOUNCES, &o->ref_bounces, "N",
         "realtime: the estimator's indirect bounces (as render --bounces, default 1; half: the "
         "expectation of render --bounces half, that of 1); "
         "unbiased: a cap on the path length (default none)"},
        {"reflect-depth", APP_OPT_UINT, &o->reflect_depth, "N",
         "realtime: mirrors and glass the primary pass looks through (as render; default 4)"},
        {"composite-on", APP_OPT_STRING, &o->composite_on, "WHERE",
         "realtime: where each sample is composited and summed: device (the default where the "
         "front-end keeps its contract on the GPU: nothing of a sample leaves it) or host (each "
         "sample brought to the host and composited there, as every front-end can)"},
        {"until-noise", APP_OPT_FLOAT, &o->until_noise, "P",
         "stop each frame once its mean relative standard error is below P (checked every 16 "
         "samples; --spp stays the most)"},
        {"checkpoint", APP_OPT_FLOAT, &o->checkpoint_s, "S",
         "keep the frame in progress's sums and the run's state in DIR every S seconds (default "
         "60; 0: after every run of samples), so that an interrupted or killed run goes on with "
         "--resume"},
        {"resume", APP_OPT_STRING, &o->resume, "DIR",
         "go on with the interrupted reference in DIR (its own options, from "
         "DIR/reference.partial.json): the frames equal a run never interrupted"},
        {"shard", APP_OPT_STRING, &o->shard, "I/N",
         "render part I of N of the work (whole frames, or sample ranges when there are fewer "
         "frames than shards) as per-pixel sums and shard.json in DIR; tandem merge adds the "
         "shards up to the frames one run writes (docs/cluster.md)"},
        APP_ENV_OPTS(&o->env),
        {0},
    };
    /* render's options and the denoisers' parameters (pl_param) */
    app_opt with_params[64];
    double param_vals[PL_PARAMS_MAX];
    if (!app_opts_with_params(render_opts_tbl, with_params, 64, param_vals))
        return APP_EXIT_FAIL;
#undef COMMON_OPTS
#undef PATH_OPTS
    const char *pos[1];
    int npos;
    int rc = app_parse(cmd, reference ? ref_opts_tbl : with_params, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;
    if (!reference)
        o->bounces = app_bounces_split(o->bounces, &o->half_indirect);
    tnd_result pr = reference ? TND_OK : app_params_collect(param_vals, &o->params);
    if (pr != TND_OK) {
        app_report(cmd->name, pr);
        return APP_EXIT_USAGE;
    }
    if (view_path) {
        tnd_result vr = app_view_state_read(view_path, &view_state);
        if (vr == TND_OK && view_state.path_len == 0)
            vr = tnd_fail(TND_ERR_BAD_INPUT, "view state %s: no camera path", view_path);
        if (vr != TND_OK) {
            app_report(cmd->name, vr);
            return APP_EXIT_FAIL;
        }
        const char *fe = o->frontend;
        app_view_state_options(&view_state, o); /* what the viewer ran with, frame for frame */
        if (reference) { /* the reference's own front-end; a matched one the state's bounces */
            o->frontend = fe;
            if (o->ref_bounces == ~0u && o->estimator && strcmp(o->estimator, "realtime") == 0)
                o->ref_bounces = o->bounces;
        }
        o->start = view_state.path[0].frame;
        o->frames = view_state.path_frames;
        o->view = &view_state;
    }
    return -1;
}

void app_reference_bounces(app_render_opts *o)
{
    bool rt = strcmp(o->estimator, "realtime") == 0;
    if (o->ref_bounces == APP_BOUNCES_HALF) /* (realtime: app_render_check refuses the other) */
        o->ref_bounces = 1;
    if (rt)
        o->bounces = o->ref_bounces == ~0u ? 1 : o->ref_bounces;
    o->ref_bounces = rt || o->ref_bounces == ~0u ? 0 : o->ref_bounces;
}

/* The options' values checked (render's and reference's, parsed or filled by a caller): an error
 * names the option. */
tnd_result app_render_check(const app_render_opts *o, bool reference)
{
    if (strcmp(o->pipeline, "scene") != 0 && strcmp(o->pipeline, "full") != 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--pipeline %s: expected scene or full",
                        o->pipeline);
    if (!pl_frontend_live(o->frontend))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--frontend '%s': expected %s", o->frontend,
                        pl_frontend_live_names());
    if (o->reflect_depth > 16)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--reflect-depth is 1 to 16");
    if (o->timed_frames && o->view) /* (its camera path ends with the frames written) */
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--timed-frames runs the scene's path on after the frames; "
                        "not with --view");
    if (o->video && !app_have_program("ffmpeg"))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--video needs ffmpeg on PATH (Debian package ffmpeg)");
    if (reference && strcmp(o->estimator, "unbiased") != 0 && strcmp(o->estimator, "realtime"))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--estimator %s: expected unbiased or realtime",
                        o->estimator);
    if (reference && strcmp(o->composite_on, "device") != 0 && strcmp(o->composite_on, "host"))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--composite-on %s: expected device or host",
                        o->composite_on);
    if (reference && o->ref_bounces == APP_BOUNCES_HALF && strcmp(o->estimator, "realtime") != 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--bounces half: only with the realtime "
                                                  "estimator (unbiased: a cap on the path length)");
    if (reference && (o->until_noise < 0 || o->until_noise >= 1))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--until-noise is a fraction in (0, 1)");
    if (o->frames == 0 || !(o->fps > 0) || (reference && o->spp == 0))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--frames, --fps and --spp must be positive");
    return TND_OK;
}

static int check_opts(const app_cmd *cmd, const render_opts *o, bool reference)
{
    if (!o->out) {
        fprintf(stderr, "tandem %s: --out DIR is required (see tandem %s --help)\n", cmd->name,
                cmd->name);
        return APP_EXIT_USAGE;
    }
    if (app_render_check(o, reference) != TND_OK) {
        fprintf(stderr, "tandem %s: %s\n", cmd->name, tnd_error_detail());
        return APP_EXIT_USAGE;
    }
    return -1;
}

typedef struct ref_progress {
    app_progress *bar;
    uint64_t base; /* samples taken before this part */
} ref_progress;

static void on_ref_progress(uint32_t done, uint32_t total, void *user)
{
    ref_progress *p = user;
    app_progress_step(p->bar, (unsigned)(p->base + done));
    (void)total;
}

/* Samples [first, first + count) of a matched reference of the current frame, added to the
 * per-pixel sums (RGB, luminance^2): sample s draws the sample word tnd_reference_sample(s) and
 * one pixel offset for the whole image (uniform in the pixel, so that over the samples each
 * pixel's area is integrated as the unbiased reference does), composited as `render --denoiser
 * off` does (composite and interleave); stops early as stats->until_noise says (stats->spp: the
 * samples the sums hold after). */
static tnd_result matched_reference_add(pl_frontend *fr, const render_opts *o, unsigned f,
                                        tnd_frame *frame, uint32_t first, uint32_t count,
                                        double *sum, double *sum2, tnd_ref_stats *stats,
                                        void (*progress)(uint32_t, uint32_t, void *), void *rp)
{
    tnd_result res = TND_OK;
    size_t n = (size_t)o->size[0] * o->size[1];
    float *one = malloc(3 * n * sizeof *one);
    uint32_t end = first + count, done = end;
    if (!one)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "reference: out of memory");
    for (uint32_t s = first; s < end; s++) {
        uint32_t key = tnd_reference_sample(s);
        float jit[2] = {tnd_rand(0, f, key, TND_DIM_JITTER_X) - 0.5f,
                        tnd_rand(0, f, key, TND_DIM_JITTER_Y) - 0.5f};
        pl_params p = {.bounces = o->bounces, .sample = key, .set_jitter = true,
                       .jitter = {jit[0], jit[1]}};
        TND_TRY(pl_frontend_render(fr, &p, frame, NULL));
        tnd_frame_composite(frame, one);
        tnd_frame_interleave(frame, one);
        for (size_t q = 0; q < n; q++) {
            for (int k = 0; k < 3; k++)
                sum[3 * q + k] += one[3 * q + k];
            double l = tnd_luminance(one[3 * q], one[3 * q + 1], one[3 * q + 2]);
            sum2[q] += l * l;
        }
        if (progress)
            progress(s + 1 - first, count, rp);
        if (stats->until_noise > 0 && (s + 1) % TND_REF_CHECK_EVERY == 0 && s + 1 < end &&
            tnd_ref_finish(sum, sum2, n, s + 1, NULL, NULL) < stats->until_noise) {
            done = s + 1;
            break;
        }
    }
    stats->spp = done;
fail:
    free(one);
    return res;
}

tnd_result app_reference_add(pl_frontend *fr, const app_render_opts *o, unsigned f,
                             tnd_frame *frame, uint32_t first, uint32_t count, double *sum_rgb,
                             double *sum_lum2, tnd_ref_stats *rs,
                             void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    if (strcmp(o->estimator, "realtime") != 0)
        return pl_frontend_reference_add(fr, o->ref_bounces, first, count, sum_rgb, sum_lum2, rs,
                                         progress, user);
    if (strcmp(o->composite_on, "device") == 0 && pl_frontend_has_matched(fr))
        return pl_frontend_matched_add(fr, o->bounces, first, count, sum_rgb, sum_lum2, rs,
                                       progress, user);
    return matched_reference_add(fr, o, f, frame, first, count, sum_rgb, sum_lum2, rs, progress,
                                 user);
}

tnd_result app_frame_begin(const app_render_opts *o, const tnd_scene *scene, pl_frontend *fr,
                           tnd_scene_state st[2], unsigned i, bool first)
{
    tnd_result res = TND_OK;
    unsigned f = o->start + i;
    float aspect = (float)o->size[0] / (float)o->size[1];
    tnd_scene_state *cur = &st[i & 1], *prev = &st[(i + 1) & 1];
    TND_TRY(tnd_scene_evaluate(scene, f / o->fps, o->camera, aspect, cur));
    if (first)
        TND_TRY(tnd_scene_evaluate(scene, f > 0 ? (f - 1) / o->fps : 0.0, o->camera, aspect, prev));
    if (o->view) { /* the viewer's camera (its first frame: no camera motion before it) */
        app_view_camera_apply(app_view_state_at(o->view, i), cur);
        if (first)
            app_view_camera_apply(app_view_state_at(o->view, i > 0 ? i - 1 : 0), prev);
    }
    TND_TRY(pl_frontend_set_frame(fr, cur, prev, f, o->size[0], o->size[1]));
fail:
    return res;
}

pl_step app_frame_step(const app_render_opts *o, const tnd_scene_state *cur, unsigned i,
                       bool reset)
{
    return (pl_step){.params = {.bounces = o->bounces, .half_indirect = o->half_indirect},
                     .frame = dn_frame_for_camera(cur->camera.proj, o->size[1], o->start + i,
                                                  reset),
                     .dt = (float)(1.0 / o->fps)};
}

/* REFDIR/frame_NNNN.motion.exr: the frame's motion and depth at the pixel centres (the primary
 * pass without jitter), for eval's motion-compensated metrics. */
static tnd_result write_reference_motion(pl_frontend *fr, const render_opts *o, unsigned f,
                                         tnd_frame *frame)
{
    tnd_result res = TND_OK;
    TND_TRY(pl_frontend_render(fr, &(pl_params){.bounces = 0, .set_jitter = true}, frame, NULL));
    const float *m = tnd_frame_f(frame, TND_CT_MOTION), *d = tnd_frame_f(frame, TND_CT_DEPTH);
    tnd_exr_channel_desc ch[4] = {{"motion.X", TND_EXR_FLOAT, (const uint32_t *)m, 3},
                                  {"motion.Y", TND_EXR_FLOAT, (const uint32_t *)m + 1, 3},
                                  {"motion.Z", TND_EXR_FLOAT, (const uint32_t *)m + 2, 3},
                                  {"depth.Z", TND_EXR_FLOAT, (const uint32_t *)d, 1}};
    char path[1600];
    snprintf(path, sizeof path, "%s/frame_%04u.motion.exr", o->out, f);
    TND_TRY(tnd_exr_write(path, o->size[0], o->size[1], ch, 4, NULL, 0, TND_EXR_ZIP));
fail:
    return res;
}

/* the post chain's settings from the options */
tnd_result app_taa_parse(const char *taa, struct cmp_desc *d)
{
    char *end;
    if (strcmp(taa, "on") == 0) {
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
    TND_TRY_RETURN(app_taa_parse(o->taa, d));
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

/* One frame's times in timings.json: every pass of the chain (pl_chain_passes): front-end GPU
 * timestamps (vk) or CPU wall clock (embree); the denoiser's and the post chain's: GPU. */
static void timings_entry(FILE *f, const char *sep, unsigned frame, const pl_chain *chain,
                          const pl_step_result *pr)
{
    fprintf(f, "%s\n    {\"frame\": %u", sep, frame);
    app_timings_members(f, chain, pr);
    fputc('}', f);
}

/* --timed-frames: the path's next frames after `done`, back to back as bench runs them (each
 * frame submitted without waiting for the one before; the GPU's times come a frame late), into
 * timings.json's back_to_back: per frame after the warm-up, and the wall clock per frame. */
static tnd_result time_back_to_back(const app_render_opts *o, const tnd_scene *scene,
                                    pl_frontend *fr, pl_chain *chain, tnd_scene_state st[2],
                                    unsigned done, bool lags, float *rgb, FILE *timings)
{
    enum { WARM = 4 };
    tnd_result res = TND_OK;
    unsigned total = WARM + o->timed_frames, recorded = 0;
    float aspect = (float)o->size[0] / (float)o->size[1];
    double t0 = tnd_now();
    /* a front-end that is not queued gives its own frame's times at once: kept a frame, so that
     * each entry is one frame's */
    bool queued = (pl_frontend_caps(fr) & PL_CAP_QUEUED) != 0;
    pl_timings own_before = {0};
    fprintf(timings, "\n  ],\n  \"back_to_back\": {\"warmup\": %u, \"frames\": [", WARM);
    for (unsigned k = 0; k <= total; k++) {
        pl_step_result pr = {0};
        unsigned i = done + k, f = o->start + i;
        if (k == WARM)
            t0 = tnd_now();
        if (k < total) {
            tnd_scene_state *cur = &st[i & 1], *prev = &st[(i + 1) & 1];
            TND_TRY(tnd_scene_evaluate(scene, f / o->fps, o->camera, aspect, cur));
            TND_TRY(pl_frontend_set_frame(fr, cur, prev, f, o->size[0], o->size[1]));
            pl_step step = app_frame_step(o, cur, i, false);
            step.no_wait = true;
            /* (without the GPU chain the CPU composite has to go somewhere) */
            TND_TRY(pl_chain_run(chain, fr, &step, lags ? NULL : rgb, NULL, &pr));
        } else {
            TND_TRY(pl_chain_finish(chain, &pr));
        }
        pl_timings own = pr.fe;
        if (lags && !queued)
            pr.fe = own_before;
        own_before = own;
        /* the frame these times are of: the one before (lagged), or this one (no GPU chain) */
        unsigned of = lags ? k - 1 : k;
        if ((lags ? k > WARM : k >= WARM && k < total) && (pr.lagged || !lags)) {
            timings_entry(timings, recorded ? "," : "", o->start + done + of, chain, &pr);
            recorded++;
        }
    }
    fprintf(timings, "\n  ], \"wall_ms\": %.4f}", 1e3 * (tnd_now() - t0) / o->timed_frames);
fail:
    return res;
}

/* DIR/run.json: what reproduces the run (scene, front-end, device, every parameter) and which
 * post passes ran, and why the others did not. */
static tnd_result write_run_json(const render_opts *o, const char *device, const char *dn_name,
                                 const pl_denoiser_info *dn, const cmp_desc *pd,
                                 const char *passes, const tnd_scene *scene,
                                 const pl_frontend *fr, int interrupted, unsigned written)
{
    cJSON *j = cJSON_CreateObject();
    if (interrupted) { /* (where the run stopped: the frames before are written) */
        cJSON *in = cJSON_AddObjectToObject(j, "interrupted");
        cJSON_AddStringToObject(in, "signal", app_signal_name(interrupted));
        cJSON_AddNumberToObject(in, "frames_written", written);
        cJSON_AddNumberToObject(in, "next_frame", o->start + written);
    }
    cJSON_AddNumberToObject(j, "contract_version", TND_CONTRACT_VERSION);
    cJSON_AddStringToObject(j, "scene", o->scene);
    cJSON_AddStringToObject(j, "frontend", o->frontend);
    cJSON_AddStringToObject(j, "device", device);
    cJSON_AddStringToObject(j, "rt_api", o->rt_api);
    cJSON_AddStringToObject(j, "pipeline", o->pipeline);
    cJSON_AddBoolToObject(j, "video", o->video);
    cJSON *def = cJSON_AddObjectToObject(j, "scene_defaults"); /* what the scene lacked */
    if (scene->default_camera[0])
        cJSON_AddStringToObject(def, "camera", scene->default_camera);
    if (scene->default_light[0])
        cJSON_AddStringToObject(def, "light", scene->default_light);
    if (scene->camera_path[0])
        cJSON_AddStringToObject(j, "camera_path", scene->camera_path);
    if (scene->env.width) { /* the environment map, from --env or the scene */
        cJSON *env = cJSON_AddObjectToObject(j, "environment");
        cJSON_AddStringToObject(env, "path", scene->env.path);
        cJSON_AddNumberToObject(env, "intensity", scene->env.intensity);
        cJSON_AddNumberToObject(env, "rotation_degrees", scene->env.rotation);
        cJSON_AddBoolToObject(env, "from_command_line", o->env.path != NULL);
    }
    cJSON *feat = cJSON_AddArrayToObject(j, "scene_features");
    for (uint32_t b = 0; b < TND_FEATURE_COUNT; b++)
        if (scene->features & (1u << b))
            cJSON_AddItemToArray(feat, cJSON_CreateString(tnd_feature_name(b)));
    /* what the front-end's shaders model (Embree's CPU code has no variants) */
    cJSON_AddStringToObject(j, "frontend_models", pl_frontend_models(fr));
    cJSON_AddNumberToObject(j, "width", o->size[0]);
    cJSON_AddNumberToObject(j, "height", o->size[1]);
    cJSON_AddNumberToObject(j, "frames", o->frames);
    cJSON_AddNumberToObject(j, "start", o->start);
    cJSON_AddNumberToObject(j, "fps", o->fps);
    cJSON_AddNumberToObject(j, "camera", o->camera);
    if (o->half_indirect)
        cJSON_AddStringToObject(j, "bounces", "half");
    else
        cJSON_AddNumberToObject(j, "bounces", o->bounces);
    cJSON_AddNumberToObject(j, "reflect_depth", o->reflect_depth ? o->reflect_depth : TND_REFLECT_DEPTH);
    cJSON_AddStringToObject(j, "precision", o->precision);
    cJSON_AddStringToObject(j, "denoiser", dn_name);
    /* the parameters given that the denoiser has, in its table's order */
    for (uint32_t i = 0; dn && i < dn->nparams; i++) {
        double v = pl_param_set_get(&o->params, dn->params[i]->name);
        char key[64];
        if (v != 0)
            cJSON_AddNumberToObject(j, pl_param_key(dn->params[i], key, sizeof key), v);
    }
    cJSON *post = cJSON_AddObjectToObject(j, "post");
    if (passes) {
        cJSON_AddBoolToObject(post, "taa", pd->taa);
        cJSON_AddNumberToObject(post, "taa_weight", pd->taa_weight);
        cJSON_AddNumberToObject(post, "taa_clip_sigma", pd->taa_clip);
        cJSON_AddNumberToObject(post, "taa_anti_sparkle", pd->taa_sparkle);
        cJSON_AddNumberToObject(post, "bloom", pd->bloom);
        cJSON_AddNumberToObject(post, "bloom_sigma", pd->bloom_sigma);
        cJSON_AddStringToObject(post, "tonemap", cmp_curve_name(pd->curve));
        cJSON_AddStringToObject(post, "exposure", pd->fixed_exposure ? "fixed" : "auto");
        if (pd->fixed_exposure)
            cJSON_AddNumberToObject(post, "ev100", pd->ev100);
        else {
            cJSON_AddNumberToObject(post, "percentile_low", pd->low);
            cJSON_AddNumberToObject(post, "percentile_high", pd->high);
            cJSON_AddNumberToObject(post, "speed_up", pd->speed_up);
            cJSON_AddNumberToObject(post, "speed_down", pd->speed_down);
        }
        cJSON_AddStringToObject(post, "passes", passes);
        cJSON *why = cJSON_AddObjectToObject(post, "not_run");
        if (!pd->interleave)
            cJSON_AddStringToObject(why, "interleave",
                                    "the scene has no surface that both reflects and refracts");
        if (!(scene->features & (TND_FEATURE(MIRROR) | TND_FEATURE(GLASS) | TND_FEATURE(THIN_GLASS))))
            cJSON_AddStringToObject(why, "reflect_refract", "the scene has no mirror or glass");
        if (!pd->taa)
            cJSON_AddStringToObject(why, "taa", "--taa off");
        if (!(pd->bloom > 0))
            cJSON_AddStringToObject(why, "bloom", "off by default (--bloom I turns it on)");
        if (pd->fixed_exposure)
            cJSON_AddStringToObject(why, "histogram", "fixed exposure");
    } else {
        cJSON_AddStringToObject(post, "passes", "none: CPU composite and preview (embree + --denoiser off)");
    }
    char path[2048];
    snprintf(path, sizeof path, "%s/run.json", o->out);
    tnd_result res = app_json_write(path, j);
    cJSON_Delete(j);
    return res;
}

/* The front-end and the chain as render builds them (tandem view builds its own with it). */
tnd_result app_pipeline_open(const app_render_opts *o, const tnd_scene *scene, tnd_vk *vk,
                             bool use_vk, bool use_dn, tnd_precision prec,
                             const pl_denoiser_info **dn, bool reference, pl_frontend **fr,
                             pl_chain **chain, cmp_desc *pd)
{
    tnd_result res = TND_OK;
    /* the interleave where the scene has surfaces that both reflect and refract (or forced) */
    *pd = (cmp_desc){.bloom = (float)o->bloom,
                   .interleave = (scene->features & TND_FEATURE(SPLIT)) != 0 ||
                                 strcmp(o->pipeline, "full") == 0};
    if (use_dn && (res = post_desc(o, pd)) != TND_OK)
        goto fail;
    TND_TRY(pl_frontend_create(o->frontend, scene,
                               &(pl_frontend_desc){.vk = use_vk ? vk : NULL, .precision = prec,
                                                   .rt_api = o->rt_api,
                                                   .full_pipeline =
                                                       strcmp(o->pipeline, "full") == 0,
                                                   .reflect_depth = o->reflect_depth,
                                                   .references = reference,
                                                   .bounces = o->bounces,
                                                   .half_indirect = o->half_indirect,
                                                   .threads = o->threads,
                                                   .scene_path = o->scene},
                               fr));
    if (reference)
        return TND_OK; /* (no chain) */
    /* a denoiser that needs re-shaded gradient samples runs its fallback behind a front-end
     * that cannot re-shade them */
    const pl_denoiser_info *asked = *dn;
    *dn = pl_denoiser_for(asked, pl_frontend_caps(*fr));
    if (*dn != asked && !app_quiet())
        fprintf(stderr, "tandem: render: --frontend %s cannot re-shade gradient samples: "
                        "running %s instead of %s\n", o->frontend, (*dn)->name, asked->name);
    pl_chain_desc cd = {.vk = vk, .width = o->size[0], .height = o->size[1], .precision = prec,
                        .backend = use_dn,
                        .denoiser = (*dn)->caps & PL_DN_PLUGIN ? o->denoiser : (*dn)->name,
                        .post = *pd};
    for (uint32_t i = 0; i < o->params.n; i++) { /* (the others' are not its) */
        const char *pn = o->params.param[i]->name;
        if (pl_denoiser_has_param(*dn, pn))
            TND_TRY(pl_param_set_put(&cd.params, pn, o->params.value[i]));
        else if (!o->view && !o->quiet && !app_quiet()) /* (a viewer state keeps them all) */
            fprintf(stderr, "tandem: %s: --%s: %s has no such parameter (left out; tandem info "
                            "--pipeline lists each denoiser's)\n",
                    reference ? "reference" : "render", pn, (*dn)->name);
    }
    TND_TRY(pl_chain_create(&cd, chain));
fail:
    return res;
}

/* A run that failed leaves nothing of itself: the output directory when it made it, else the
 * files of the frames it began (images, captures with their gradient samples, motion, dumps'
 * directory when it made it) and its timings. */
static void remove_partial(const render_opts *o, bool out_existed, bool dumps_made,
                           unsigned begun, const bool *keep)
{
    char path[2400];
    snprintf(path, sizeof path, "%s/dump", o->out);
    if (dumps_made || !out_existed)
        app_remove_flat_dir(path);
    if (!out_existed) {
        snprintf(path, sizeof path, "%s/capture", o->out);
        app_remove_flat_dir(path);
        app_remove_flat_dir(o->out);
        return;
    }
    static const char *const names[] = {"%s/frame_%04u.exr", "%s/frame_%04u.png",
                                        "%s/frame_%04u.motion.exr", "%s/capture/frame_%04u.exr",
                                        "%s/frame_%04u.sums"};
    for (unsigned i = 0; i < begun; i++) {
        if (keep && keep[i]) /* (a resumed reference's frames done before) */
            continue;
        for (int k = 0; k < 5; k++) {
            snprintf(path, sizeof path, names[k], o->out, o->start + i);
            remove(path);
        }
        char cap[2400];
        snprintf(cap, sizeof cap, "%s/capture/frame_%04u.exr", o->out, o->start + i);
        tnd_capture_gradients_path(cap, path, sizeof path);
        remove(path);
    }
    snprintf(path, sizeof path, "%s/timings.json", o->out);
    remove(path);
    if (o->shard) { /* (an earlier shard's list would name the sums just removed) */
        snprintf(path, sizeof path, "%s/shard.json", o->out);
        remove(path);
    }
}

/* A reference frame's checkpoints: its sums (DIR/frame_NNNN.sums) and the run's state
 * (reference.partial.json) when `every` seconds have passed since the last, or when interrupted. */
typedef struct ref_checkpoint {
    bool on;              /* (not for shards, which write their sums as their output) */
    const render_opts *given; /* the options as given (its command line, to resume with) */
    const bool *finished; /* the frames done */
    const double *noise;
    const tnd_ref_stats *all;
    unsigned index;       /* the frame's */
    double before;        /* its sampling seconds in runs before this one */
    double start, last;   /* when its sampling began here; the last checkpoint */
} ref_checkpoint;

/* Samples [from, end) of frame f (a part of a reference) into the sums (RGB, then luminance^2)
 * in runs of whole batches of TND_REF_CHECK_EVERY samples, each run about a second (the sums are
 * those of one call: the front-ends add ranges split at multiples of TND_REF_CHECK_EVERY as the
 * whole), and between runs: the noise target (--until-noise, as inside a run), an interrupt, a
 * checkpoint due. rs->spp: the samples the sums hold; *stopped: interrupted before `end`. */
static tnd_result sample_frame(pl_frontend *fr, const render_opts *o, unsigned f,
                               tnd_frame *frame, uint32_t from, uint32_t end, double *sums,
                               tnd_ref_stats *rs, ref_progress *rp, ref_checkpoint *cp,
                               bool *stopped)
{
    tnd_result res = TND_OK;
    size_t n = (size_t)o->size[0] * o->size[1];
    uint32_t run = TND_REF_CHECK_EVERY;
    *stopped = false;
    rs->spp = from;
    while (rs->spp < end) {
        uint32_t at = rs->spp, count = end - at < run ? end - at : run;
        double t0 = tnd_now();
        TND_TRY(app_reference_add(fr, o, f, frame, at, count, sums, sums + 3 * n, rs,
                                  on_ref_progress, rp));
        rp->base += rs->spp - at;
        if (rs->spp < at + count || rs->spp == end)
            break; /* (the noise target inside the run, or all taken) */
        if (o->until_noise > 0 &&
            tnd_ref_finish(sums, sums + 3 * n, n, rs->spp, NULL, NULL) < o->until_noise)
            break;
        if (tnd_now() - t0 < 0.5 && run < (1u << 20))
            run *= 2;
        int sig = app_interrupted();
        if (cp->on && (sig || tnd_now() - cp->last >= o->checkpoint_s)) {
            TND_TRY(app_shard_sums_write(o->out, o->size[0], o->size[1], f, 0, rs->spp, sums,
                                         sums + 3 * n));
            TND_TRY(app_ref_partial_write(cp->given, cp->finished, cp->all, cp->noise, (int)cp->index,
                                          cp->before + tnd_now() - cp->start, sig));
            cp->last = tnd_now();
        }
        if (sig) {
            *stopped = true;
            break;
        }
    }
fail:
    return res;
}

/* render or reference with its options (parsed, or filled by a caller such as the sweep) */
static int run_opts(const render_opts *opts, bool reference)
{
    render_opts o = *opts;
    const char *what = reference ? "reference" : "render";
    /* (render's --bounces half was split into a count of 1 and half_indirect by the parse) */
    if (reference)
        app_reference_bounces(&o);

    tnd_precision prec = TND_PRECISION_F32;
    tnd_result res = tnd_precision_parse(o.precision, &prec);
    if (res != TND_OK)
        return app_report(what, res);
    tnd_scene *scene = NULL;
    tnd_vk vk = {0};
    pl_frontend *fr = NULL;
    pl_chain *chain = NULL; /* selection, re-shading, back-end, post */
    uint8_t *display = NULL;
    bool use_vk = pl_frontend_needs_gpu(o.frontend); /* (the contract on the GPU) */
    const pl_denoiser_info *dn = NULL; /* (what runs, after app_pipeline_open) */
    if (!reference && (res = pl_denoiser_find(o.denoiser, &dn)) != TND_OK)
        return app_report(what, res);
    bool dn_plugin = dn && (dn->caps & PL_DN_PLUGIN);
    /* the back-end runs on Vulkan; only a host front-end with a denoiser that does not filter
     * ("off") stays on the CPU (a viewer's state: its back-end, always on the GPU) */
    bool use_dn = !reference && ((dn->caps & PL_DN_FILTERS) || use_vk || o.view);
    if (o.dump && dn && !(dn->caps & PL_DN_DUMPS))
        return app_report(what, tnd_fail(TND_ERR_INVALID_ARGUMENT,
                                         "--dump shows the back-end's buffers: with a denoiser "
                                         "plugin they are not the denoiser's"));
    uint32_t dump_mask = 0;
    if ((res = app_parse_dump(o.dump, &dump_mask)) != TND_OK)
        return app_report(what, res);
    if (dump_mask && !use_dn)
        return app_report(what, tnd_fail(TND_ERR_INVALID_ARGUMENT,
                                         "--dump needs the Vulkan back-end (embree with "
                                         "--denoiser off composites on the CPU)"));
    FILE *timings = NULL;
    tnd_scene_state st[2] = {{0}};
    tnd_frame frame = {0}; /* (reference: the frame's contract) */
    float *rgb = NULL;
    bool matched = reference && strcmp(o.estimator, "realtime") == 0;
    tnd_ref_stats *ref_stats = NULL; /* reference: per frame */
    double *ref_noise = NULL, *ref_sum = NULL; /* (sums: RGB, then luminance^2) */
    float *lum_se = NULL;
    app_shard_part *parts = NULL; /* reference: the work, all of it or this shard's */
    uint32_t *part_taken = NULL, nparts = 0, shard = 0, shards = 0;
    char path[2048], dir[1600];
    if (strlen(o.out) > 1500)
        return app_report(what, tnd_fail(TND_ERR_INVALID_ARGUMENT, "--out: path too long"));
    int status = APP_EXIT_FAIL;
    int lock_fd = -1;      /* the output directory's lock */
    bool *finished = NULL; /* reference (not a shard): the frames done (resumed: before too) */
    int resume_at = -1, stopped = 0; /* the frame a resumed run's checkpoint holds; the signal */
    double resume_seconds = 0;
    cJSON *partial = NULL;
    if (reference) {
        parts = calloc(o.frames, sizeof *parts);
        part_taken = calloc(o.frames, sizeof *part_taken);
        if (!parts || !part_taken) {
            free(parts);
            free(part_taken);
            return app_report(what, tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory"));
        }
        if (o.shard && (res = app_shard_parse(o.shard, &shard, &shards)) == TND_OK)
            res = app_shard_plan(o.frames, o.spp, shard, shards, parts, &nparts);
        for (uint32_t i = 0; !o.shard && i < o.frames; i++)
            parts[nparts++] = (app_shard_part){i, 0, o.spp};
        for (uint32_t k = 0; res == TND_OK && k < nparts; k++)
            if (o.until_noise > 0 && parts[k].count != o.spp)
                res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                               "--until-noise stops a frame by its own noise: with --shard %s a "
                               "frame's samples are split (fewer frames than shards)", o.shard);
        if (res != TND_OK) {
            free(parts);
            free(part_taken);
            app_report(what, res);
            return APP_EXIT_USAGE;
        }
    }
    bool out_existed = false, dumps_made = false, begun_output = false;
    unsigned frames_begun = 0;
    TND_TRY(app_scene_load(o.scene, &o.env, &scene));
    if (use_vk || use_dn) {
        TND_TRY(tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = !use_vk}, &vk));
    }
    cmp_desc pd = {0};
    TND_TRY(app_pipeline_open(&o, scene, &vk, use_vk, use_dn, prec, &dn, reference, &fr, &chain,
                              &pd));
    if (reference && !matched && !(pl_frontend_caps(fr) & PL_CAP_REFERENCE)) {
        res = tnd_fail(TND_ERR_UNSUPPORTED,
                       "--frontend %s renders no unbiased reference (--estimator realtime "
                       "renders the matched one)", o.frontend);
        goto fail;
    }
    /* the denoiser as run.json and timings.json name it */
    const char *dn_name = reference ? NULL
                          : dn_plugin ? o.denoiser
                          : use_dn    ? dn->name
                                      : "off (CPU composite)";
    struct stat out_st, dump_st;
    out_existed = stat(o.out, &out_st) == 0;
    snprintf(path, sizeof path, "%s/dump", o.out);
    dumps_made = dump_mask && stat(path, &dump_st) != 0;
    TND_TRY(tnd_mkdirs(o.out));
    TND_TRY(app_lock_dir(o.out, &lock_fd)); /* (before anything is written or removed there) */
    begun_output = true;
    if (!reference) {
        snprintf(path, sizeof path, "%s/timings.json", o.out);
        timings = fopen(path, "w");
        if (!timings) {
            res = tnd_fail(TND_ERR_IO, "render: %s: cannot create", path);
            goto fail;
        }
        fprintf(timings,
                "{\n  \"frontend\": \"%s\",\n  \"denoiser\": \"%s\",\n  \"device\": \"%s\",\n"
                "  \"frames\": [",
                o.frontend, dn_name,
                use_vk || use_dn ? vk.info.name : "CPU (Embree)");
    }
    snprintf(dir, sizeof dir, "%s/capture", o.out);
    if (o.capture)
        TND_TRY(tnd_mkdirs(dir));
    char dump_dir[1700];
    snprintf(dump_dir, sizeof dump_dir, "%s/dump", o.out);
    if (dump_mask)
        TND_TRY(tnd_mkdirs(dump_dir));
    rgb = malloc((size_t)o.size[0] * o.size[1] * 3 * sizeof(float));
    display = malloc((size_t)o.size[0] * o.size[1] * 3);
    if (reference) {
        ref_stats = calloc(o.frames, sizeof *ref_stats);
        ref_noise = calloc(o.frames, sizeof *ref_noise);
        lum_se = malloc((size_t)o.size[0] * o.size[1] * sizeof *lum_se);
        ref_sum = malloc((size_t)o.size[0] * o.size[1] * 4 * sizeof *ref_sum);
    }
    /* (a reference of a viewer's flight has no command line to resume with) */
    bool resumable = reference && !o.shard && !o.view;
    if (resumable)
        finished = calloc(o.frames, sizeof *finished);
    if (!rgb || !display || (reference && (!ref_stats || !ref_noise || !lum_se || !ref_sum)) ||
        (resumable && !finished)) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "%s: out of memory", what);
        goto fail;
    }
    if (o.resume) { /* the frames done and their figures, the frame in progress */
        TND_TRY(app_ref_partial_read(o.resume, &partial));
        const cJSON *e;
        cJSON_ArrayForEach(e, cJSON_GetObjectItemCaseSensitive(partial, "done"))
        {
            double idx = cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(e, "index"));
            if (!(idx >= 0 && idx < o.frames))
                continue;
            unsigned k = (unsigned)idx;
            finished[k] = true;
            ref_stats[k].spp = (uint32_t)cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(e, "spp"));
            ref_stats[k].rel_error = cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(e, "rel_error"));
            ref_stats[k].seconds = cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(e, "seconds"));
            ref_noise[k] = cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(e, "noise_relmse"));
        }
        const cJSON *at = cJSON_GetObjectItemCaseSensitive(partial, "at");
        double idx = cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(at, "index"));
        if (at && idx >= 0 && idx < o.frames) {
            resume_at = (int)idx;
            resume_seconds = cJSON_GetNumberValue(cJSON_GetObjectItemCaseSensitive(at, "seconds"));
        }
    }
    if (finished) /* (a run killed from now on can be resumed) */
        TND_TRY(app_ref_partial_write(opts, finished, ref_stats, ref_noise, resume_at,
                                      resume_seconds, 0));
    app_progress bar;
    uint64_t ref_total = 0, ref_done = 0; /* samples of the work, taken */
    for (uint32_t k = 0; k < nparts; k++)
        ref_total += parts[k].count;
    app_progress_begin(&bar, what, reference ? (unsigned)ref_total : o.frames);
    double t0 = tnd_now();
    uint32_t part = 0; /* reference: the next part of the work */
    bool any_begun = false, mid_frame = false;
    for (unsigned i = 0; i < o.frames; i++) {
        unsigned f = o.start + i;
        if (reference && (part == nparts || parts[part].index != i))
            continue; /* (another shard's frame) */
        if (finished && finished[i]) { /* (done before the run was resumed) */
            ref_done += parts[part].count;
            part++;
            continue;
        }
        if ((stopped = app_interrupted()) != 0)
            break; /* (between frames: the ones written stay) */
        bool first_frame = !any_begun; /* (its previous state evaluated) */
        any_begun = true;
        frames_begun = i + 1;
        tnd_scene_state *cur = &st[i & 1];
        TND_TRY(app_frame_begin(&o, scene, fr, st, i, first_frame));
        if (reference) {
            const app_shard_part *pp = &parts[part];
            size_t n = (size_t)o.size[0] * o.size[1];
            tnd_ref_stats *rs = &ref_stats[i];
            rs->until_noise = o.until_noise;
            ref_progress rp = {&bar, ref_done};
            memset(ref_sum, 0, 4 * n * sizeof *ref_sum);
            TND_TRY(tnd_frame_create(o.size[0], o.size[1], &frame));
            if (pp->first == 0) /* (the shard that has the frame's first sample) */
                TND_TRY(write_reference_motion(fr, &o, f, &frame));
            double t_sample = tnd_now();
            uint32_t from = pp->first;
            ref_checkpoint cp = {.on = finished != NULL, .given = opts, .finished = finished,
                                 .noise = ref_noise,
                                 .all = ref_stats, .index = i, .start = t_sample,
                                 .last = t_sample};
            if ((int)i == resume_at) { /* its checkpoint's samples (none written yet: from 0) */
                uint32_t cf = 0, cs = 0;
                tnd_result rr = app_shard_sums_read(o.out, o.size[0], o.size[1], f, &cf, &cs,
                                                    ref_sum);
                if (rr == TND_OK && cf == 0 && cs <= o.spp && cs % TND_REF_CHECK_EVERY == 0) {
                    from = cs;
                    cp.before = resume_seconds;
                    rp.base += cs;
                } else if (rr != TND_ERR_IO) {
                    res = rr != TND_OK ? rr
                                       : tnd_fail(TND_ERR_BAD_INPUT,
                                                  "--resume: %s/frame_%04u.sums holds samples "
                                                  "[%u, +%u), not a checkpoint of this run",
                                                  o.out, f, cf, cs);
                    goto fail;
                } else {
                    memset(ref_sum, 0, 4 * n * sizeof *ref_sum);
                }
            }
            bool cut = false;
            TND_TRY(sample_frame(fr, &o, f, &frame, from, pp->first + pp->count, ref_sum, rs, &rp,
                                 &cp, &cut));
            tnd_frame_destroy(&frame);
            rs->seconds = cp.before + tnd_now() - t_sample;
            if (cut) {
                stopped = app_interrupted();
                mid_frame = true;
                break;
            }
            ref_done += pp->count;
            part_taken[part] = rs->spp - pp->first;
            part++;
            if (o.shard) {
                TND_TRY(app_shard_sums_write(o.out, o.size[0], o.size[1], f, pp->first,
                                             rs->spp - pp->first, ref_sum, ref_sum + 3 * n));
                if (!app_quiet())
                    fprintf(stderr, "%sreference: frame %u: samples [%u, %u) of %u, shard %u/%u\n",
                            bar.enabled ? "\n" : "", f, pp->first, rs->spp, o.spp, shard, shards);
                continue;
            }
            TND_TRY(app_ref_frame_finish(&o, i, ref_sum, ref_sum + 3 * n, rgb, lum_se, rs,
                                         &ref_noise[i]));
            if (finished) { /* (the frame's files, the state saying so, then no checkpoint) */
                finished[i] = true;
                TND_TRY(app_ref_partial_write(opts, finished, ref_stats, ref_noise, -1, 0, 0));
                snprintf(path, sizeof path, "%s/frame_%04u.sums", o.out, f);
                remove(path);
            }
            if (!app_quiet())
                fprintf(stderr, "%sreference: frame %u: %u spp, remaining noise %.2f%% (mean "
                                "relative standard error), %.3g Mpaths/s\n",
                        bar.enabled ? "\n" : "", f, rs->spp, 100.0 * rs->rel_error,
                        app_ref_paths_per_s(&o, rs) * 1e-6);
            continue;
        }
        pl_step_result pr = {0};
        char cap_path[1800];
        snprintf(cap_path, sizeof cap_path, "%s/frame_%04u.exr", dir, f);
        app_dump_ctx dc = {.mask = dump_mask, .dir = dump_dir};
        snprintf(dc.stem, sizeof dc.stem, "%04u", f);
        pl_step step = app_frame_step(&o, cur, i, i == 0);
        step.capture = o.capture ? cap_path : NULL;
        step.after_backend = dump_mask ? app_dump_after_backend : NULL;
        step.user = &dc;
        TND_TRY(pl_chain_run(chain, fr, &step, rgb, use_dn ? display : NULL, &pr));
        timings_entry(timings, i ? "," : "", f, chain, &pr);
        snprintf(path, sizeof path, "%s/frame_%04u.exr", o.out, f);
        TND_TRY(app_write_rgb_exr(path, rgb, o.size[0], o.size[1]));
        snprintf(path, sizeof path, "%s/frame_%04u.png", o.out, f);
        if (use_dn)
            TND_TRY(app_write_png(path, display, o.size[0], o.size[1]));
        else
            TND_TRY(app_write_preview(path, rgb, o.size[0], o.size[1]));
        app_progress_step(&bar, i + 1);
    }
    app_progress_end(&bar);
    if (stopped) { /* interrupted: what is written stays, and says where the run stopped */
        unsigned written = 0;
        for (unsigned k = 0; k < o.frames; k++)
            written += reference ? finished && finished[k] : k < frames_begun;
        if (timings) {
            fprintf(timings, "\n  ]\n}\n");
            bool ok = fclose(timings) == 0;
            timings = NULL;
            if (!ok) {
                res = tnd_fail(TND_ERR_IO, "render: %s/timings.json: write failed", o.out);
                goto fail;
            }
        }
        if (!reference)
            TND_TRY(write_run_json(&o, use_vk || use_dn ? vk.info.name : "CPU (Embree)",
                                   dn_name, dn,
                                   pl_chain_post(chain) ? cmp_settings(pl_chain_post(chain))
                                                        : &pd,
                                   pl_chain_post(chain) ? cmp_passes(pl_chain_post(chain)) : NULL,
                                   scene, fr, stopped, written));
        else if (finished && !mid_frame) /* (mid-frame: its checkpoint wrote the state) */
            TND_TRY(app_ref_partial_write(opts, finished, ref_stats, ref_noise, -1, 0, stopped));
        fprintf(stderr, "%standem: %s: interrupted (%s): %u of %u frame%s written in %s/%s\n",
                bar.enabled ? "\n" : "", what, app_signal_name(stopped), written, o.frames,
                o.frames == 1 ? "" : "s", o.out,
                finished ? "; tandem reference --resume DIR goes on from there"
                : o.shard ? "; run the shard again" : "");
        status = app_interrupt_status();
        goto fail;
    }
    if (timings && o.timed_frames)
        TND_TRY(time_back_to_back(&o, scene, fr, chain, st, o.frames, use_dn, rgb, timings));
    else if (timings)
        fprintf(timings, "\n  ]");
    if (timings) {
        fprintf(timings, "\n}\n");
        if (fclose(timings) != 0) {
            timings = NULL;
            res = tnd_fail(TND_ERR_IO, "render: %s/timings.json: write failed", o.out);
            goto fail;
        }
        timings = NULL;
    }
    if (reference && o.shard)
        TND_TRY(app_shard_json_write(&o, use_vk ? vk.info.name : "CPU (Embree)",
                                     tnd_scene_digest(scene), shard, shards, parts, part_taken,
                                     nparts));
    else if (reference) {
        TND_TRY(app_ref_json_write(&o, use_vk ? vk.info.name : "CPU (Embree)", ref_stats,
                                   ref_noise));
        snprintf(path, sizeof path, "%s/reference.partial.json", o.out);
        remove(path); /* (finished) */
    }
    if (!reference)
        TND_TRY(write_run_json(&o, use_vk || use_dn ? vk.info.name : "CPU (Embree)",
                               dn_name, dn,
                               pl_chain_post(chain) ? cmp_settings(pl_chain_post(chain)) : &pd,
                               pl_chain_post(chain) ? cmp_passes(pl_chain_post(chain)) : NULL,
                               scene, fr, 0, o.frames));
    if (o.video)
        TND_TRY(app_write_video(o.out, o.start, o.frames, o.fps));
    if ((use_vk || use_dn) && vk.validation && tnd_vk_validation_errors(&vk)) {
        res = tnd_fail(TND_ERR_VULKAN, "%u Vulkan validation error(s)", tnd_vk_validation_errors(&vk));
        goto fail;
    }
    if (!app_quiet()) {
        char who[300];
        pl_frontend_describe(fr, who, sizeof who);
        fprintf(stderr, "tandem: %s: %u frame%s of %s at %ux%u in %.1f s (%s) -> %s/\n", what,
                o.frames, o.frames == 1 ? "" : "s", o.scene, o.size[0], o.size[1],
                tnd_now() - t0, who, o.out);
    }
    status = APP_EXIT_OK;
fail:
    if (status == APP_EXIT_FAIL)
        app_report(what, res);
    if (timings)
        fclose(timings);
    timings = NULL;
    /* A reference that lost its device keeps its checkpoints (nothing in it is wrong: the machine
     * failed), so that it goes on where it stopped; any other failure leaves no partial output. */
    bool keep_state = status == APP_EXIT_FAIL && finished && tnd_vk_device_lost();
    if (keep_state) {
        snprintf(path, sizeof path, "%s/reference.partial.json", o.out);
        keep_state = access(path, F_OK) == 0;
    }
    if (keep_state)
        fprintf(stderr, "tandem: %s: its checkpoints are kept: tandem reference --resume %s goes "
                        "on from the last one\n", what, o.out);
    else if (status == APP_EXIT_FAIL && begun_output)
        remove_partial(&o, out_existed, dumps_made, frames_begun, finished);
    if (lock_fd >= 0 && (status != APP_EXIT_FAIL || out_existed || keep_state))
        app_unlock_dir(o.out, lock_fd);
    else if (lock_fd >= 0) /* (the directory itself is gone) */
        close(lock_fd);
    free(finished);
    cJSON_Delete(partial);
    tnd_frame_destroy(&frame);
    free(ref_stats);
    free(ref_noise);
    free(ref_sum);
    free(parts);
    free(part_taken);
    free(lum_se);
    free(rgb);
    tnd_scene_state_free(&st[0]);
    tnd_scene_state_free(&st[1]);
    if (timings)
        fclose(timings);
    free(display);
    pl_chain_destroy(chain);
    pl_frontend_destroy(fr);
    tnd_vk_destroy(&vk);
    tnd_scene_destroy(scene);
    return status;
}

int app_render(const app_render_opts *o, bool reference)
{
    bool was = app_set_quiet(app_quiet() || o->quiet);
    int rc = check_opts(reference ? &reference_cmd : &render_cmd, o, reference);
    if (rc < 0)
        rc = run_opts(o, reference);
    app_set_quiet(was);
    return rc;
}

/* reference --resume DIR: the run's own command line from DIR/reference.partial.json, parsed as
 * it was, then run on in DIR (nothing else may be given but --quiet). */
static int resume(const render_opts *given, int argc, char **argv)
{
    for (int k = 1; k < argc; k++)
        if (strcmp(argv[k], "--quiet") != 0 && strcmp(argv[k], "--resume") != 0 &&
            !(k > 1 && strcmp(argv[k - 1], "--resume") == 0)) {
            fprintf(stderr, "tandem reference: --resume DIR takes the run's own options from "
                            "DIR/reference.partial.json (%s given)\n", argv[k]);
            return APP_EXIT_USAGE;
        }
    cJSON *state = NULL;
    tnd_result r = app_ref_partial_read(given->resume, &state);
    if (r != TND_OK)
        return app_report("reference", r);
    const cJSON *args = cJSON_GetObjectItemCaseSensitive(state, "args");
    int n = cJSON_GetArraySize(args);
    char **v = calloc((size_t)n + 7, sizeof *v);
    int rc = APP_EXIT_FAIL;
    if (v) {
        int c = 0;
        v[c++] = "reference";
        for (const cJSON *a = args->child; a; a = a->next)
            v[c++] = a->valuestring;
        v[c++] = "--out";
        v[c++] = (char *)given->resume;
        v[c++] = "--resume";
        v[c++] = (char *)given->resume;
        if (app_quiet())
            v[c++] = "--quiet";
        render_opts o;
        rc = parse_common(&reference_cmd, &o, true, c, v);
        if (rc < 0)
            rc = app_render(&o, true);
        free(v);
    }
    cJSON_Delete(state);
    return rc;
}

static int run(bool reference, int argc, char **argv)
{
    render_opts o;
    int rc = parse_common(reference ? &reference_cmd : &render_cmd, &o, reference, argc, argv);
    if (rc < 0 && reference && o.resume && !o.out)
        rc = resume(&o, argc, argv);
    else if (rc < 0 && o.resume && o.out && strcmp(o.resume, o.out) != 0) {
        fprintf(stderr, "tandem reference: --resume DIR goes on in DIR: no --out\n");
        rc = APP_EXIT_USAGE;
    } else if (rc < 0)
        rc = app_render(&o, reference);
    app_view_state_free(&view_state);
    return rc;
}

int cmd_render(int argc, char **argv)
{
    return run(false, argc, argv);
}

int cmd_reference(int argc, char **argv)
{
    return run(true, argc, argv);
}
