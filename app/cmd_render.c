/* app/cmd_render.c: `tandem render` (the real-time pipeline over a camera path: front-end,
 * back-end, post chain) and `tandem reference` (converged images): their options, parsed into
 * rn_render_opts and run by rn_render (run/rn_render.c), and a reference's --resume DIR. */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

typedef rn_render_opts render_opts;

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
static rn_view_state view_state;


static int parse_common(const app_cmd *cmd, render_opts *o, bool reference, int argc, char **argv)
{
    const char *view_path = NULL;
    rn_render_defaults(o);
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
    {"frontend", APP_OPT_STRING, &o->frontend, "NAME", fe_help}, \
    {"lights", APP_OPT_STRING, &o->lights, "auto|plain|tree|restir", \
     "how next-event estimation picks a light: from the power table (plain), by the light " \
     "tree's importance for the shading point (tree), or by reservoirs reused over pixels and " \
     "frames (restir: ReSTIR DI); auto: the tree from 16 emitters, point and spot lights, " \
     "reservoirs from 64 (docs/lights.md)"}
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
        {"render-scale", APP_OPT_FLOAT, &o->render_scale, "S",
         "trace and denoise at --size x S (0.25 to 1, default 1) and upscale to --size in the "
         "post chain (docs/upscaling.md)"},
        {"upscaler", APP_OPT_STRING, &o->upscaler, CMP_UPSCALER_LIST,
         "--render-scale below 1: the temporal upscaler (jittered samples accumulated at the "
         "output size; the default; bilinear with --taa off) or a spatial baseline"},
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
        o->bounces = rn_bounces_split(o->bounces, &o->half_indirect);
    tnd_result pr = reference ? TND_OK : app_params_collect(param_vals, &o->params);
    if (pr != TND_OK) {
        app_report(cmd->name, pr);
        return APP_EXIT_USAGE;
    }
    if (view_path) {
        tnd_result vr = rn_view_state_read(view_path, &view_state);
        if (vr == TND_OK && view_state.path_len == 0)
            vr = tnd_fail(TND_ERR_BAD_INPUT, "view state %s: no camera path", view_path);
        if (vr != TND_OK) {
            app_report(cmd->name, vr);
            return APP_EXIT_FAIL;
        }
        const char *fe = o->frontend;
        rn_view_state_options(&view_state, o); /* what the viewer ran with, frame for frame */
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

static int check_opts(const app_cmd *cmd, const render_opts *o, bool reference)
{
    if (!o->out) {
        fprintf(stderr, "tandem %s: --out DIR is required (see tandem %s --help)\n", cmd->name,
                cmd->name);
        return APP_EXIT_USAGE;
    }
    if (rn_render_check(o, reference) != TND_OK) {
        fprintf(stderr, "tandem %s: %s\n", cmd->name, tnd_error_detail());
        return APP_EXIT_USAGE;
    }
    tnd_result r;
    if (reference && (r = rn_reference_check(o)) != TND_OK) {
        app_report(cmd->name, r);
        return APP_EXIT_USAGE;
    }
    return -1;
}

static int render(const render_opts *o, bool reference)
{
    const app_cmd *cmd = reference ? &reference_cmd : &render_cmd;
    int rc = check_opts(cmd, o, reference);
    if (rc >= 0)
        return rc;
    rn_host h = app_host();
    return app_finish(cmd->name, rn_render(o, reference, &h));
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
    tnd_result r = rn_ref_partial_read(given->resume, &state);
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
            rc = render(&o, true);
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
        rc = render(&o, reference);
    rn_view_state_free(&view_state);
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
