/* run/rn_reference.c: a reference's work besides its frame loop (run/rn_render.c): its samples
 * (unbiased through the front-end, matched composited on the device or the host) in runs
 * between checkpoints, the motion it writes for eval, what it writes (frames, reference.json,
 * the noise a reference adds) and its state when interrupted (reference.partial.json, from
 * which it resumes). Entry points: rn_reference_add, rn_ref_noise_relmse, rn_ref_paths_per_s,
 * rn_ref_json_write, rn_ref_frame_finish, rn_ref_partial_write, rn_ref_partial_read; inside
 * the layer: rn_ref_sample_frame, rn_ref_write_motion, rn_ref_on_progress. */
#include "run/rn_internal.h"
#include "shaders/brdf.h"
#include "shaders/sampling.h"
#include "shaders/specular.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* ---- what a single run and a merge both write --------------------------------------------- */
static bool access_ok(const char *dir)
{
    char path[1700];
    struct stat st;
    snprintf(path, sizeof path, "%s/reference.json", dir);
    return stat(path, &st) == 0;
}

double rn_ref_noise_relmse(const float *rgb, const float *lum_se, size_t n)
{
    double s = 0;
    for (size_t q = 0; q < n; q++) {
        double l = tnd_luminance(rgb[3 * q], rgb[3 * q + 1], rgb[3 * q + 2]);
        s += (double)lum_se[q] * lum_se[q] / (l * l + EV_RELMSE_EPS);
    }
    return n ? s / (double)n : 0.0;
}

double rn_ref_paths_per_s(const rn_render_opts *o, const tnd_ref_stats *rs)
{
    return rs->seconds > 0 ? (double)o->size[0] * o->size[1] * rs->spp / rs->seconds : 0.0;
}

tnd_result rn_ref_json_write(const rn_render_opts *o, const char *device,
                              const tnd_ref_stats *rs, const double *noise)
{
    char path[1600];
    snprintf(path, sizeof path, "%s/reference.json", o->out);
    FILE *fp = fopen(path, "w");
    if (!fp)
        return tnd_fail(TND_ERR_IO, "%s: cannot create", path);
    bool rt = strcmp(o->estimator, "realtime") == 0;
    fprintf(fp, "{\n  \"estimator\": \"%s\",\n  \"frontend\": \"%s\",\n  \"device\": \"%s\",\n",
            o->estimator, o->frontend, device);
    if (rt)
        fprintf(fp, "  \"bounces\": %u,\n  \"reflect_depth\": %u,\n", o->bounces,
                o->reflect_depth ? o->reflect_depth : 4);
    else
        fprintf(fp, "  \"max_bounces\": %u,\n", o->ref_bounces);
    /* (sampling time and paths per second: 0 where not measured, as in a merge) */
    double secs = 0, paths = 0;
    for (unsigned i = 0; i < o->frames; i++)
        secs += rs[i].seconds, paths += (double)o->size[0] * o->size[1] * rs[i].spp;
    fprintf(fp, "  \"sampler\": \"owen-scrambled sobol\",\n");
    fprintf(fp, "  \"spp_max\": %u,\n  \"until_noise\": %g,\n  \"seconds\": %.6g,\n"
                "  \"paths_per_s\": %.6g,\n  \"frames\": [", o->spp, o->until_noise, secs,
            secs > 0 ? paths / secs : 0.0);
    for (unsigned i = 0; i < o->frames; i++)
        fprintf(fp,
                "%s\n    {\"frame\": %u, \"spp\": %u, \"rel_error\": %.6g, "
                "\"noise_relmse\": %.6g, \"seconds\": %.6g, \"paths_per_s\": %.6g}",
                i ? "," : "", o->start + i, rs[i].spp, rs[i].rel_error, noise[i], rs[i].seconds,
                rn_ref_paths_per_s(o, &rs[i]));
    fprintf(fp, "\n  ]\n}\n");
    if (fclose(fp) != 0)
        return tnd_fail(TND_ERR_IO, "%s: write failed", path);
    return TND_OK;
}

tnd_result rn_ref_frame_finish(const rn_render_opts *o, unsigned i, const double *sum_rgb,
                                const double *sum_lum2, float *rgb, float *lum_se,
                                tnd_ref_stats *rs, double *noise)
{
    size_t n = (size_t)o->size[0] * o->size[1];
    char path[1700];
    rs->rel_error = tnd_ref_finish(sum_rgb, sum_lum2, n, rs->spp, rgb, lum_se);
    *noise = rn_ref_noise_relmse(rgb, lum_se, n);
    /* beside the mean, the variance of one sample's luminance (eval's "worth N samples"): the
     * standard error squared times the samples, written over lum_se (it is not used after) */
    for (size_t q = 0; q < n; q++)
        lum_se[q] = lum_se[q] * lum_se[q] * (float)rs->spp;
    snprintf(path, sizeof path, "%s/frame_%04u.exr", o->out, o->start + i);
    const tnd_exr_channel_desc ch[4] = {{"R", TND_EXR_FLOAT, rgb, 3},
                                        {"G", TND_EXR_FLOAT, rgb + 1, 3},
                                        {"B", TND_EXR_FLOAT, rgb + 2, 3},
                                        {"variance.Y", TND_EXR_FLOAT, lum_se, 1}};
    tnd_result res = tnd_exr_write(path, o->size[0], o->size[1], ch, 4, NULL, 0, TND_EXR_ZIP);
    snprintf(path, sizeof path, "%s/frame_%04u.png", o->out, o->start + i);
    return res == TND_OK ? rn_write_preview(path, rgb, o->size[0], o->size[1]) : res;
}

/* ---- an interrupted reference: its state, to resume ------------------------------------------ */
tnd_result rn_ref_partial_write(const rn_render_opts *o, const bool *done,
                                 const tnd_ref_stats *rs, const double *noise, int at,
                                 double at_seconds, int signal)
{
    tnd_result res = TND_OK;
    rn_render_opts own = *o; /* (its command line: every option but where it goes) */
    own.out = NULL;
    own.quiet = false;
    own.resume = NULL;
    rn_args a;
    TND_TRY(rn_render_args(&own, true, &a));
    cJSON *j = cJSON_CreateObject(), *args = cJSON_AddArrayToObject(j, "args");
    for (int k = 1; k < a.n; k++) /* (after "reference") */
        cJSON_AddItemToArray(args, cJSON_CreateString(a.v[k]));
    cJSON *d = cJSON_AddArrayToObject(j, "done");
    for (unsigned i = 0; i < o->frames; i++) {
        if (!done[i])
            continue;
        cJSON *e = cJSON_CreateObject();
        cJSON_AddNumberToObject(e, "index", i);
        cJSON_AddNumberToObject(e, "frame", o->start + i);
        cJSON_AddNumberToObject(e, "spp", rs[i].spp);
        cJSON_AddNumberToObject(e, "rel_error", rs[i].rel_error);
        cJSON_AddNumberToObject(e, "noise_relmse", noise[i]);
        cJSON_AddNumberToObject(e, "seconds", rs[i].seconds);
        cJSON_AddItemToArray(d, e);
    }
    if (at >= 0) { /* (its samples: the checkpoint's, DIR/frame_NNNN.sums) */
        cJSON *e = cJSON_AddObjectToObject(j, "at");
        cJSON_AddNumberToObject(e, "index", at);
        cJSON_AddNumberToObject(e, "frame", o->start + (unsigned)at);
        cJSON_AddNumberToObject(e, "seconds", at_seconds);
    }
    if (signal)
        cJSON_AddStringToObject(j, "interrupted", rn_signal_name(signal));
    char path[1700];
    snprintf(path, sizeof path, "%s/reference.partial.json", o->out);
    res = rn_json_write(path, j);
    cJSON_Delete(j);
fail:
    return res;
}

tnd_result rn_ref_partial_read(const char *dir, cJSON **out)
{
    char path[1700];
    snprintf(path, sizeof path, "%s/reference.partial.json", dir);
    *out = NULL;
    void *text = NULL;
    size_t len = 0;
    if (tnd_file_read(path, &text, &len) != TND_OK)
        return tnd_fail(TND_ERR_IO, "--resume %s: no %s (not an interrupted reference%s)", dir,
                        path, access_ok(dir) ? "; a finished one has reference.json" : "");
    cJSON *j = cJSON_Parse(text);
    free(text);
    const cJSON *args = cJSON_GetObjectItemCaseSensitive(j, "args");
    bool ok = cJSON_IsArray(args) && cJSON_IsArray(cJSON_GetObjectItemCaseSensitive(j, "done"));
    for (const cJSON *a = ok ? args->child : NULL; a; a = a->next)
        ok = ok && cJSON_IsString(a);
    if (!ok) {
        cJSON_Delete(j);
        return tnd_fail(TND_ERR_BAD_INPUT, "--resume: %s: not a reference's state (args, done)",
                        path);
    }
    *out = j;
    return TND_OK;
}


/* ---- sampling a reference frame ----------------------------------------------------------- */
void rn_ref_on_progress(uint32_t done, uint32_t total, void *user)
{
    rn_ref_progress *p = user;
    rn_progress_step(p->bar, p->base + done);
    (void)total;
}

/* Samples [first, first + count) of a matched reference of the current frame, added to the
 * per-pixel sums (RGB, luminance^2): sample s draws the sample word tnd_reference_sample(s) and
 * one pixel offset for the whole image (uniform in the pixel, so that over the samples each
 * pixel's area is integrated as the unbiased reference does), composited as `render --denoiser
 * off` does (composite and interleave); stops early as stats->until_noise says (stats->spp: the
 * samples the sums hold after). */
static tnd_result matched_reference_add(pl_frontend *fr, const rn_render_opts *o, unsigned f,
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

tnd_result rn_reference_add(pl_frontend *fr, const rn_render_opts *o, unsigned f,
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

/* REFDIR/frame_NNNN.motion.exr: the frame's motion and depth at the pixel centres (the primary
 * pass without jitter), for eval's motion-compensated metrics. */
tnd_result rn_ref_write_motion(pl_frontend *fr, const rn_render_opts *o, unsigned f,
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

tnd_result rn_ref_sample_frame(pl_frontend *fr, const rn_render_opts *o, unsigned f,
                               tnd_frame *frame, uint32_t from, uint32_t end, double *sums,
                               tnd_ref_stats *rs, rn_ref_progress *rp, rn_ref_checkpoint *cp,
                               const rn_host *h, bool *stopped)
{
    tnd_result res = TND_OK;
    size_t n = (size_t)o->size[0] * o->size[1];
    uint32_t run = TND_REF_CHECK_EVERY;
    *stopped = false;
    rs->spp = from;
    while (rs->spp < end) {
        uint32_t at = rs->spp, count = end - at < run ? end - at : run;
        double t0 = tnd_now();
        TND_TRY(rn_reference_add(fr, o, f, frame, at, count, sums, sums + 3 * n, rs,
                                 rn_ref_on_progress, rp));
        rp->base += rs->spp - at;
        if (rs->spp < at + count || rs->spp == end)
            break; /* (the noise target inside the run, or all taken) */
        if (o->until_noise > 0 &&
            tnd_ref_finish(sums, sums + 3 * n, n, rs->spp, NULL, NULL) < o->until_noise)
            break;
        if (tnd_now() - t0 < 0.5 && run < (1u << 20))
            run *= 2;
        int sig = rn_interrupted(h);
        if (cp->on && (sig || tnd_now() - cp->last >= o->checkpoint_s)) {
            TND_TRY(rn_shard_sums_write(o->out, o->size[0], o->size[1], f, 0, rs->spp, sums,
                                        sums + 3 * n));
            TND_TRY(rn_ref_partial_write(cp->given, cp->finished, cp->all, cp->noise,
                                         (int)cp->index, cp->before + tnd_now() - cp->start, sig));
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
