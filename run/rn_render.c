/* run/rn_render.c: a render (the real-time pipeline over a camera path: front-end, back-end,
 * post chain) and a reference (converged images), written into a directory: frame_NNNN.exr
 * (linear HDR after TAA, before tone mapping), frame_NNNN.png (display), captures, dumps,
 * timings.json and run.json; a reference's frames, reference.json, its checkpoints or a shard's
 * sums. What `tandem render` and `tandem reference` run, and the sweep's, compare's and the
 * stability report's runs. Entry point: rn_render. */
#include "run/rn_internal.h"
#include "shaders/specular.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/stat.h>

typedef rn_render_opts render_opts;

/* One frame's times in timings.json: every pass of the chain (pl_chain_passes): front-end GPU
 * timestamps (vk) or CPU wall clock (embree); the denoiser's and the post chain's: GPU; and,
 * where given, the host's parts of the frame (rn_whole_frame_host_name's three). */
static void timings_entry(FILE *f, const char *sep, unsigned frame, const pl_chain *chain,
                          const pl_step_result *pr, const double *host)
{
    fprintf(f, "%s\n    {\"frame\": %u", sep, frame);
    rn_timings_members(f, chain, pr);
    if (host) {
        fprintf(f, ", \"host_ms\": {");
        for (int q = 0; q < 3; q++)
            fprintf(f, "%s\"%s\": %.4f", q ? ", " : "", rn_whole_frame_host_name(q), host[q]);
        fputc('}', f);
    }
    fputc('}', f);
}

/* --timed-frames: the path's next frames after `done`, back to back as bench --whole-frame runs
 * them (each frame submitted without waiting for the one before; the GPU's times come a frame
 * late), into timings.json's back_to_back: per frame after the warm-up, with its host work
 * (host_ms: the scene evaluated, the front-end's frame set, pl_chain_run's recording and
 * submission and any wait for the frame before), their medians, and the wall clock per frame. */
static tnd_result time_back_to_back(const rn_render_opts *o, const tnd_scene *scene,
                                    pl_frontend *fr, pl_chain *chain, tnd_scene_state st[2],
                                    unsigned done, bool lags, float *rgb, FILE *timings)
{
    enum { WARM = 4 };
    tnd_result res = TND_OK;
    unsigned total = WARM + o->timed_frames, recorded = 0;
    double t0 = tnd_now();
    /* the host's parts per frame (evaluate, set_frame, chain_run), and the timed frames' */
    double(*host)[3] = calloc(total, sizeof *host);
    double *part = calloc((size_t)3 * o->timed_frames, sizeof *part);
    if (!host || !part) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "render: out of memory");
        goto fail;
    }
    /* a front-end that is not queued gives its own frame's times at once: kept a frame, so that
     * each entry is one frame's */
    bool queued = (pl_frontend_caps(fr) & PL_CAP_QUEUED) != 0;
    pl_timings own_before = {0};
    fprintf(timings, "\n  ],\n  \"back_to_back\": {\"warmup\": %u, \"frames\": [", WARM);
    for (unsigned k = 0; k <= total; k++) {
        pl_step_result pr = {0};
        unsigned i = done + k;
        if (k == WARM)
            t0 = tnd_now();
        if (k < total) {
            rn_frame_host fh;
            TND_TRY(rn_frame_begin(o, scene, fr, st, i, false, &fh));
            pl_step step = rn_frame_step(o, &st[i & 1], i, false);
            step.no_wait = true;
            double c0 = tnd_now();
            /* (without the GPU chain the CPU composite has to go somewhere) */
            TND_TRY(pl_chain_run(chain, fr, &step, lags ? NULL : rgb, NULL, &pr));
            host[k][0] = fh.evaluate_ms, host[k][1] = fh.set_frame_ms;
            host[k][2] = 1e3 * (tnd_now() - c0);
            if (k >= WARM)
                for (int q = 0; q < 3; q++)
                    part[(size_t)q * o->timed_frames + (k - WARM)] = host[k][q];
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
            timings_entry(timings, recorded ? "," : "", o->start + done + of, chain, &pr, host[of]);
            recorded++;
        }
    }
    fprintf(timings, "\n  ], \"wall_ms\": %.4f", 1e3 * (tnd_now() - t0) / o->timed_frames);
    fprintf(timings, ", \"host_ms_median\": {");
    for (int q = 0; q < 3; q++)
        fprintf(timings, "%s\"%s\": %.4f", q ? ", " : "", rn_whole_frame_host_name(q),
                rn_median(part + (size_t)q * o->timed_frames, o->timed_frames));
    fprintf(timings, "}}");
fail:
    free(host);
    free(part);
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
        cJSON_AddStringToObject(in, "signal", rn_signal_name(interrupted));
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
    uint32_t rs[2];
    rn_render_size(o, rs);
    cJSON_AddNumberToObject(j, "render_scale", o->render_scale);
    cJSON_AddNumberToObject(j, "render_width", rs[0]);
    cJSON_AddNumberToObject(j, "render_height", rs[1]);
    if (o->render_scale != 1) /* (without TAA the temporal one has no history: bilinear) */
        cJSON_AddStringToObject(j, "upscaler",
                                cmp_upscaler_name(cmp_upscaler_used(pd->upscaler, pd->taa)));
    cJSON_AddNumberToObject(j, "frames", o->frames);
    cJSON_AddNumberToObject(j, "start", o->start);
    cJSON_AddNumberToObject(j, "fps", o->fps);
    cJSON_AddNumberToObject(j, "camera", o->camera);
    if (o->half_indirect)
        cJSON_AddStringToObject(j, "bounces", "half");
    else
        cJSON_AddNumberToObject(j, "bounces", o->bounces);
    cJSON_AddNumberToObject(j, "reflect_depth", o->reflect_depth ? o->reflect_depth : TND_REFLECT_DEPTH);
    cJSON_AddStringToObject(j, "lights",
                            tnd_light_sampling_name(tnd_light_sampling_for(scene, rn_lights_mode(o))));
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
    tnd_result res = rn_json_write(path, j);
    cJSON_Delete(j);
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
        rn_remove_flat_dir(path);
    if (!out_existed) {
        snprintf(path, sizeof path, "%s/capture", o->out);
        rn_remove_flat_dir(path);
        rn_remove_flat_dir(o->out);
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


/* render or reference with its options (parsed, or filled by a caller such as the sweep) */
/* The work of a reference (o->frames entries in parts): every frame's samples, or this shard's. */
static tnd_result reference_plan(const render_opts *o, rn_shard_part *parts, uint32_t *nparts,
                                 uint32_t *shard, uint32_t *shards)
{
    tnd_result res = TND_OK;
    *nparts = 0;
    if (o->shard && (res = rn_shard_parse(o->shard, shard, shards)) == TND_OK)
        res = rn_shard_plan(o->frames, o->spp, *shard, *shards, parts, nparts);
    for (uint32_t i = 0; !o->shard && i < o->frames; i++)
        parts[(*nparts)++] = (rn_shard_part){i, 0, o->spp};
    for (uint32_t k = 0; res == TND_OK && k < *nparts; k++)
        if (o->until_noise > 0 && parts[k].count != o->spp)
            res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                           "--until-noise stops a frame by its own noise: with --shard %s a "
                           "frame's samples are split (fewer frames than shards)", o->shard);
    return res;
}

tnd_result rn_reference_check(const rn_render_opts *o)
{
    if (!o->frames)
        return TND_OK; /* (rn_render_check refuses it) */
    rn_shard_part *parts = calloc(o->frames, sizeof *parts);
    uint32_t n, shard = 0, shards = 0;
    if (!parts)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
    tnd_result res = reference_plan(o, parts, &n, &shard, &shards);
    free(parts);
    return res;
}

static tnd_result run_opts(const render_opts *opts, bool reference, const rn_host *h)
{
    render_opts o = *opts;
    const char *what = reference ? "reference" : "render";
    /* (render's --bounces half was split into a count of 1 and half_indirect by the parse) */
    if (reference)
        rn_reference_bounces(&o);

    tnd_precision prec = TND_PRECISION_F32;
    tnd_result res = tnd_precision_parse(o.precision, &prec);
    if (res != TND_OK)
        return res;
    tnd_scene *scene = NULL;
    tnd_vk vk = {0};
    pl_frontend *fr = NULL;
    pl_chain *chain = NULL; /* selection, re-shading, back-end, post */
    uint8_t *display = NULL;
    bool use_vk = pl_frontend_needs_gpu(o.frontend); /* (the contract on the GPU) */
    const pl_denoiser_info *dn = NULL; /* (what runs, after rn_pipeline_open) */
    if (!reference && (res = pl_denoiser_find(o.denoiser, &dn)) != TND_OK)
        return res;
    bool dn_plugin = dn && (dn->caps & PL_DN_PLUGIN);
    /* the back-end runs on Vulkan; only a host front-end with a denoiser that does not filter
     * ("off") stays on the CPU (a viewer's state: its back-end, always on the GPU) */
    bool use_dn = !reference && ((dn->caps & PL_DN_FILTERS) || use_vk || o.view);
    bool taa_asked = o.taa && strcmp(o.taa, "off") != 0;
    if (!reference && !use_dn && (taa_asked || o.bloom > 0)) { /* (asked for, not run) */
        char asked[160];
        snprintf(asked, sizeof asked, "%s%.60s%s%s", taa_asked ? "--taa " : "",
                 taa_asked ? o.taa : "", taa_asked && o.bloom > 0 ? " and " : "",
                 o.bloom > 0 ? "--bloom" : "");
        rn_warn(h, "tandem: render: %s not run: --frontend %s with --denoiser %s composites on "
                   "the CPU (no post chain; its PNGs are previews)", asked, o.frontend,
                o.denoiser);
    }
    if (!reference && !use_dn && o.render_scale != 1)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--render-scale: the post chain upscales on the GPU; --frontend %s with "
                        "--denoiser %s composites on the CPU (take --frontend vk or a denoiser)",
                        o.frontend, o.denoiser);
    if (o.dump && dn && !(dn->caps & PL_DN_DUMPS))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--dump shows the back-end's buffers: with a denoiser plugin they are not "
                        "the denoiser's");
    uint32_t dump_mask = 0;
    if ((res = rn_dump_parse(o.dump, &dump_mask)) != TND_OK)
        return res;
    if (dump_mask && !use_dn)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--dump needs the Vulkan back-end (embree "
                                                  "with --denoiser off composites on the CPU)");
    FILE *timings = NULL;
    tnd_scene_state st[2] = {{0}};
    tnd_frame frame = {0}; /* (reference: the frame's contract) */
    float *rgb = NULL;
    bool matched = reference && strcmp(o.estimator, "realtime") == 0;
    tnd_ref_stats *ref_stats = NULL; /* reference: per frame */
    double *ref_noise = NULL, *ref_sum = NULL; /* (sums: RGB, then luminance^2) */
    float *lum_se = NULL;
    rn_shard_part *parts = NULL; /* reference: the work, all of it or this shard's */
    uint32_t *part_taken = NULL, nparts = 0, shard = 0, shards = 0;
    char path[2048], dir[1600];
    if (strlen(o.out) > 1500)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--out: path too long");
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
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
        }
        if ((res = reference_plan(&o, parts, &nparts, &shard, &shards)) != TND_OK) {
            free(parts);
            free(part_taken);
            return res;
        }
    }
    bool out_existed = false, dumps_made = false, begun_output = false;
    unsigned frames_begun = 0;
    TND_TRY(rn_scene_load(o.scene, &o.env, &scene));
    if (use_vk || use_dn) {
        TND_TRY(tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = !use_vk}, &vk));
    }
    cmp_desc pd = {0};
    TND_TRY(rn_pipeline_open(&o, scene, &vk, use_vk, use_dn, prec, &dn, reference, &fr, &chain,
                             &pd, h));
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
    TND_TRY(rn_lock_dir(o.out, &lock_fd)); /* (before anything is written or removed there) */
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
        TND_TRY(rn_ref_partial_read(o.resume, &partial));
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
        TND_TRY(rn_ref_partial_write(opts, finished, ref_stats, ref_noise, resume_at,
                                     resume_seconds, 0));
    rn_progress bar;
    uint64_t ref_total = 0, ref_done = 0; /* samples of the work, taken */
    for (uint32_t k = 0; k < nparts; k++)
        ref_total += parts[k].count;
    rn_progress_begin(&bar, h, what, reference ? ref_total : o.frames);
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
        if ((stopped = rn_interrupted(h)) != 0)
            break; /* (between frames: the ones written stay) */
        bool first_frame = !any_begun; /* (its previous state evaluated) */
        any_begun = true;
        frames_begun = i + 1;
        tnd_scene_state *cur = &st[i & 1];
        TND_TRY(rn_frame_begin(&o, scene, fr, st, i, first_frame, NULL));
        if (reference) {
            const rn_shard_part *pp = &parts[part];
            size_t n = (size_t)o.size[0] * o.size[1];
            tnd_ref_stats *rs = &ref_stats[i];
            rs->until_noise = o.until_noise;
            rn_ref_progress rp = {&bar, ref_done};
            memset(ref_sum, 0, 4 * n * sizeof *ref_sum);
            TND_TRY(tnd_frame_create(o.size[0], o.size[1], &frame));
            if (pp->first == 0) /* (the shard that has the frame's first sample) */
                TND_TRY(rn_ref_write_motion(fr, &o, f, &frame));
            double t_sample = tnd_now();
            uint32_t from = pp->first;
            rn_ref_checkpoint cp = {.on = finished != NULL, .given = opts, .finished = finished,
                                 .noise = ref_noise,
                                 .all = ref_stats, .index = i, .start = t_sample,
                                 .last = t_sample};
            if ((int)i == resume_at) { /* its checkpoint's samples (none written yet: from 0) */
                uint32_t cf = 0, cs = 0;
                tnd_result rr = rn_shard_sums_read(o.out, o.size[0], o.size[1], f, &cf, &cs,
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
            TND_TRY(rn_ref_sample_frame(fr, &o, f, &frame, from, pp->first + pp->count, ref_sum,
                                        rs, &rp, &cp, h, &cut));
            tnd_frame_destroy(&frame);
            rs->seconds = cp.before + tnd_now() - t_sample;
            if (cut) {
                stopped = rn_interrupted(h);
                mid_frame = true;
                break;
            }
            ref_done += pp->count;
            part_taken[part] = rs->spp - pp->first;
            part++;
            if (o.shard) {
                TND_TRY(rn_shard_sums_write(o.out, o.size[0], o.size[1], f, pp->first,
                                             rs->spp - pp->first, ref_sum, ref_sum + 3 * n));
                rn_say(h, "reference: frame %u: samples [%u, %u) of %u, shard %u/%u", f, pp->first,
                       rs->spp, o.spp, shard, shards);
                continue;
            }
            TND_TRY(rn_ref_frame_finish(&o, i, ref_sum, ref_sum + 3 * n, rgb, lum_se, rs,
                                         &ref_noise[i]));
            if (finished) { /* (the frame's files, the state saying so, then no checkpoint) */
                finished[i] = true;
                TND_TRY(rn_ref_partial_write(opts, finished, ref_stats, ref_noise, -1, 0, 0));
                snprintf(path, sizeof path, "%s/frame_%04u.sums", o.out, f);
                remove(path);
            }
            rn_say(h, "reference: frame %u: %u spp, remaining noise %.2f%% (mean relative "
                      "standard error), %.3g Mpaths/s",
                   f, rs->spp, 100.0 * rs->rel_error, rn_ref_paths_per_s(&o, rs) * 1e-6);
            continue;
        }
        pl_step_result pr = {0};
        char cap_path[1800];
        snprintf(cap_path, sizeof cap_path, "%s/frame_%04u.exr", dir, f);
        rn_dump_ctx dc = {.mask = dump_mask, .dir = dump_dir};
        snprintf(dc.stem, sizeof dc.stem, "%04u", f);
        pl_step step = rn_frame_step(&o, cur, i, i == 0);
        step.capture = o.capture ? cap_path : NULL;
        step.after_backend = dump_mask ? rn_dump_after_backend : NULL;
        step.user = &dc;
        TND_TRY(pl_chain_run(chain, fr, &step, rgb, use_dn ? display : NULL, &pr));
        timings_entry(timings, i ? "," : "", f, chain, &pr, NULL);
        snprintf(path, sizeof path, "%s/frame_%04u.exr", o.out, f);
        TND_TRY(rn_write_rgb_exr(path, rgb, o.size[0], o.size[1]));
        snprintf(path, sizeof path, "%s/frame_%04u.png", o.out, f);
        if (use_dn)
            TND_TRY(rn_write_png(path, display, o.size[0], o.size[1]));
        else
            TND_TRY(rn_write_preview(path, rgb, o.size[0], o.size[1]));
        rn_progress_step(&bar, i + 1);
    }
    rn_progress_end(&bar);
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
            TND_TRY(rn_ref_partial_write(opts, finished, ref_stats, ref_noise, -1, 0, stopped));
        rn_warn(h, "tandem: %s: interrupted (%s): %u of %u frame%s written in %s/%s", what,
                rn_signal_name(stopped), written, o.frames, o.frames == 1 ? "" : "s", o.out,
                finished ? "; tandem reference --resume DIR goes on from there"
                : o.shard ? "; run the shard again" : "");
        tnd_fail(TND_ERR_INTERRUPTED, "%s: interrupted (%s)", what, rn_signal_name(stopped));
        res = TND_ERR_INTERRUPTED;
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
        TND_TRY(rn_shard_json_write(&o, use_vk ? vk.info.name : "CPU (Embree)",
                                    tnd_scene_digest(scene), shard, shards, parts, part_taken,
                                    nparts));
    else if (reference) {
        TND_TRY(rn_ref_json_write(&o, use_vk ? vk.info.name : "CPU (Embree)", ref_stats,
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
        TND_TRY(rn_write_video(o.out, o.start, o.frames, o.fps));
    if ((use_vk || use_dn) && vk.validation && tnd_vk_validation_errors(&vk)) {
        res = tnd_fail(TND_ERR_VULKAN, "%u Vulkan validation error(s)", tnd_vk_validation_errors(&vk));
        goto fail;
    }
    char who[300];
    pl_frontend_describe(fr, who, sizeof who);
    rn_say(h, "tandem: %s: %u frame%s of %s at %ux%u in %.1f s (%s) -> %s/", what, o.frames,
           o.frames == 1 ? "" : "s", o.scene, o.size[0], o.size[1], tnd_now() - t0, who, o.out);
fail:;
    bool failed = res != TND_OK && res != TND_ERR_INTERRUPTED;
    if (timings)
        fclose(timings);
    timings = NULL;
    /* A reference that lost its device keeps its checkpoints (nothing in it is wrong: the machine
     * failed), so that it goes on where it stopped; any other failure leaves no partial output. */
    bool keep_state = failed && finished && tnd_vk_device_lost();
    if (keep_state) {
        snprintf(path, sizeof path, "%s/reference.partial.json", o.out);
        keep_state = access(path, F_OK) == 0;
    }
    if (keep_state)
        rn_warn(h, "tandem: %s: its checkpoints are kept: tandem reference --resume %s goes on "
                   "from the last one", what, o.out);
    else if (failed && begun_output)
        remove_partial(&o, out_existed, dumps_made, frames_begun, finished);
    if (lock_fd >= 0 && (!failed || out_existed || keep_state))
        rn_unlock_dir(o.out, lock_fd);
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
    return res;
}

tnd_result rn_render(const rn_render_opts *o, bool reference, const rn_host *host)
{
    if (!o->out)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: --out DIR is required",
                        reference ? "reference" : "render");
    tnd_result res = rn_render_check(o, reference);
    if (res == TND_OK && reference)
        res = rn_reference_check(o);
    if (res != TND_OK)
        return res;
    /* a quiet run (a sweep's cell, compare's halves) keeps the core's lines quiet too */
    rn_host h = o->quiet ? rn_host_quiet(host) : host ? *host : (rn_host){0};
    tnd_log_level was = rn_quiet_begin(h.quiet);
    res = run_opts(o, reference, &h);
    rn_quiet_end(was);
    return res;
}

tnd_result rn_render_nested(const rn_render_opts *o, bool reference, const rn_host *h)
{
    tnd_result res = rn_render(o, reference, h);
    if (res != TND_OK && res != TND_ERR_INTERRUPTED) {
        char line[4200];
        rn_failure_line(reference ? "reference" : "render", res, line, sizeof line);
        rn_warn(h, "%s", line);
    }
    return res;
}
