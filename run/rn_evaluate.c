/* run/rn_evaluate.c: what `tandem eval` computes over run folders: a run's frames against its
 * matched or unbiased reference (with its noisy input and accumulation alone when it kept its
 * captures), the estimator's bias where both references are given, the references' own noise
 * against what is measured (a warning past the rule), DIR/metrics.json and metrics.csv, and the
 * report. Entry points: rn_eval_sequence, rn_eval_result_free. */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static bool is_dir(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

/* settings as JSON text: what was compared and how, plus the run's own run.json */
static char *settings_json(const rn_eval *e, const char *out, const char *exposure_arg)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "output", out);
    cJSON_AddStringToObject(j, "reference", e->ref);
    cJSON_AddNumberToObject(j, "frames", e->count);
    cJSON_AddNumberToObject(j, "first_frame", e->frames[0]);
    cJSON_AddNumberToObject(j, "last_frame", e->frames[e->count - 1]);
    cJSON_AddNumberToObject(j, "width", e->width);
    cJSON_AddNumberToObject(j, "height", e->height);
    cJSON_AddStringToObject(j, "exposure_mode", e->auto_exposure ? "auto" : exposure_arg);
    cJSON_AddNumberToObject(j, "exposure", e->exposure);
    cJSON_AddStringToObject(j, "tone_mapping", "exposure x linear, ACES fit (Narkowicz 2015), sRGB");
    cJSON_AddNumberToObject(j, "relmse_epsilon", EV_RELMSE_EPS);
    cJSON_AddNumberToObject(j, "smape_epsilon", EV_SMAPE_EPS);
    cJSON_AddNumberToObject(j, "flip_ppd", e->ppd);
    cJSON *series = cJSON_AddArrayToObject(j, "series");
    for (uint32_t i = 0; i < e->nseries; i++) {
        cJSON *s = cJSON_CreateObject();
        cJSON_AddStringToObject(s, "name", e->series[i].name);
        cJSON_AddStringToObject(s, "frames_from", e->series[i].dir);
        static const char *const kinds[] = {
            [RN_SERIES_OUTPUT] = "linear output",
            [RN_SERIES_NOISY] = "capture composited, no denoiser",
            [RN_SERIES_ACCUMULATED] = "running mean of the capture composited, restarted "
                                       "wherever anything moves"};
        cJSON_AddStringToObject(s, "kind", kinds[e->series[i].kind]);
        cJSON_AddItemToArray(series, s);
    }
    rn_convergence c = rn_eval_convergence(e);
    if (c.have) {
        cJSON *cj = cJSON_AddObjectToObject(j, "convergence");
        cJSON_AddStringToObject(cj, "series", e->series[c.output].name);
        cJSON_AddBoolToObject(cj, "still", c.still);
        cJSON_AddNumberToObject(cj, "accumulation_restarts", c.restarts);
        cJSON_AddNumberToObject(cj, "last_quarter_relmse", c.last_output);
        cJSON_AddNumberToObject(cj, "accumulation_last_quarter_relmse", c.last_accumulated);
        cJSON_AddBoolToObject(cj, "at_or_below_accumulation", c.converges);
    }
    char path[1200];
    snprintf(path, sizeof path, "%s/run.json", out);
    void *buf = NULL;
    size_t n = 0;
    if (tnd_file_read(path, &buf, &n) == TND_OK) { /* no run.json: settings without it */
        cJSON *run = cJSON_Parse(buf);
        if (run)
            cJSON_AddItemToObject(j, "run", run);
    }
    free(buf);
    tnd_error_clear();
    char *txt = cJSON_Print(j);
    cJSON_Delete(j);
    return txt;
}

/* Whether run.json says the run traced at a smaller size than its output (--render-scale). */
static bool scaled_run(const char *out)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/run.json", out);
    void *buf = NULL;
    size_t n = 0;
    bool scaled = false;
    if (tnd_file_read(path, &buf, &n) == TND_OK) {
        cJSON *run = cJSON_ParseWithLength(buf, n);
        const cJSON *sc = cJSON_GetObjectItemCaseSensitive(run, "render_scale");
        scaled = cJSON_IsNumber(sc) && sc->valuedouble != 1.0;
        cJSON_Delete(run);
    }
    free(buf);
    tnd_error_clear();
    return scaled;
}

/* The reference's own noise over the evaluated frames: the mean of reference.json's
 * noise_relmse (what its noise adds to a relMSE measured against it); < 0 when unknown. */
double rn_reference_noise(const char *refdir, const rn_eval *e)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/reference.json", refdir);
    void *buf = NULL;
    size_t n = 0;
    double sum = 0;
    uint32_t found = 0;
    if (tnd_file_read(path, &buf, &n) == TND_OK) {
        cJSON *j = cJSON_ParseWithLength(buf, n), *fr;
        const cJSON *frames = j ? cJSON_GetObjectItemCaseSensitive(j, "frames") : NULL;
        cJSON_ArrayForEach(fr, frames)
        {
            const cJSON *f = cJSON_GetObjectItemCaseSensitive(fr, "frame");
            const cJSON *v = cJSON_GetObjectItemCaseSensitive(fr, "noise_relmse");
            for (uint32_t k = 0; cJSON_IsNumber(f) && cJSON_IsNumber(v) && k < e->count; k++)
                if (e->frames[k] == (uint32_t)f->valuedouble) {
                    sum += v->valuedouble;
                    found++;
                }
        }
        cJSON_Delete(j);
    }
    free(buf);
    tnd_error_clear();
    return found == e->count && found ? sum / found : -1.0;
}

/* The rule for a reference good enough to judge by: its own noise (the relMSE it adds) below a
 * tenth of the relMSE measured against it. A warning with both figures otherwise. */
#define EVAL_NOISE_RULE 0.1
void rn_warn_noise(const char *refdir, double noise, double measured, const char *what,
                       const rn_host *h)
{
    if (noise >= 0 && measured > 0 && noise > EVAL_NOISE_RULE * measured)
        rn_warn(h,
                "tandem: eval: warning: %s's own noise (relMSE %.4g) is %.0f%% of the %s measured "
                "against it (relMSE %.4g); the rule: under %.0f%% (more --spp, or tandem "
                "reference --until-noise)",
                refdir, noise, 100.0 * noise / measured, what, measured, 100.0 * EVAL_NOISE_RULE);
}

/* Run one evaluation with a progress over the reference's frames. */
static tnd_result run_eval(rn_eval *e, const char *label, const rn_host *h)
{
    rn_progress bar;
    uint32_t *list = NULL, nlist = 0;
    tnd_result res = rn_list_frames(e->ref, &list, &nlist);
    if (res == TND_OK) {
        rn_progress_begin(&bar, h, label, nlist);
        e->progress = &bar;
        res = rn_eval_run(e);
        rn_progress_end(&bar);
        e->progress = NULL;
    }
    free(list);
    return res;
}

/* --exposure as the metrics take it: 0 for auto, else the factor of an EV100 */
static bool exposure_of(const char *exposure, double *factor)
{
    *factor = 0;
    if (!exposure || strcmp(exposure, "auto") == 0)
        return true;
    char *end;
    double ev = strtod(exposure, &end);
    if (*end || end == exposure || !isfinite(ev) || ev < -20 || ev > 30)
        return false;
    *factor = 1.0 / (1.2 * pow(2.0, ev));
    return true;
}

tnd_result rn_eval_check(const rn_eval_opts *o)
{
    double x;
    if (!o->out || (!o->reference && !o->matched))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--out DIR and --reference REFDIR or "
                                                  "--matched-reference DIR are required (see "
                                                  "tandem eval --help)");
    if (o->metrics_on && strcmp(o->metrics_on, "auto") != 0 &&
        strcmp(o->metrics_on, "cpu") != 0 && strcmp(o->metrics_on, "device") != 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--metrics-on %s: expected auto, cpu or device",
                        o->metrics_on);
    if (!exposure_of(o->exposure, &x))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--exposure %s: expected auto or an EV100 in [-20, 30]", o->exposure);
    if (!(o->ppd >= 0 && o->ppd < 1000))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--ppd %g: expected a positive number of pixels per degree", o->ppd);
    const char *paths[4] = {o->out, o->reference, o->matched, o->report};
    for (int k = 0; k < 4; k++)
        if (paths[k] && strlen(paths[k]) > 1000)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "path too long");
    return TND_OK;
}

tnd_result rn_eval_sequence(const rn_eval_opts *o, const rn_host *h, rn_eval_result *r)
{
    double ppd = o->ppd > 0 ? o->ppd : EV_FLIP_PPD, exposure_factor = 0;
    const char *metrics_on = o->metrics_on ? o->metrics_on : "auto";
    *r = (rn_eval_result){.e = {.ppd = ppd, .metrics_on = metrics_on},
                          .b = {.ppd = ppd, .metrics_on = metrics_on}};
    TND_TRY_RETURN(rn_eval_check(o));
    exposure_of(o->exposure, &exposure_factor);
    r->e.exposure = r->b.exposure = exposure_factor;
    rn_eval *e = &r->e, *b = &r->b;
    const char *out = o->out, *unbiased = o->reference, *matched = o->matched;
    const char *report = o->report, *exposure = o->exposure ? o->exposure : "auto";
    const char *dirs[3] = {out, unbiased, matched};
    for (int k = 0; k < 3; k++)
        if (dirs[k] && !is_dir(dirs[k]))
            return tnd_fail(TND_ERR_IO, "%s: no such directory", dirs[k]);
    /* the run against `primary`; with both references the matched one against the unbiased */
    const char *primary = matched ? matched : unbiased;
    r->primary = primary;
    bool both = r->both = matched && unbiased;
    snprintf(e->ref, sizeof e->ref, "%s", primary);
    tnd_result res = rn_eval_add(e, "denoised", out, RN_SERIES_OUTPUT);
    char cap[1200];
    snprintf(cap, sizeof cap, "%s/capture", out);
    if (res == TND_OK && is_dir(cap) && scaled_run(out)) /* (captures at the render size) */
        rn_say(h, "eval: %s was rendered at a smaller scale (--render-scale): its captures "
                  "(the render size) are left out, the output alone is evaluated", out);
    else if (res == TND_OK && is_dir(cap)) {
        res = rn_eval_add(e, "noisy (1 spp)", out, RN_SERIES_NOISY);
        if (res == TND_OK)
            res = rn_eval_add(e, "accumulation alone", out, RN_SERIES_ACCUMULATED);
        snprintf(e->regions_from, sizeof e->regions_from, "%.1000s/capture", out); /* the masks */
    }
    if (res == TND_OK)
        res = run_eval(e, "eval", h);
    if (res == TND_OK && both) { /* the estimator's bias: its expectation against the truth */
        snprintf(b->ref, sizeof b->ref, "%s", unbiased);
        b->exposure = e->exposure; /* (one tone mapping for both comparisons) */
        if ((res = rn_eval_add(b, "estimator bias (matched vs unbiased)", matched,
                               RN_SERIES_OUTPUT)) == TND_OK)
            res = run_eval(b, "eval: bias", h);
        if (res == TND_OK && (b->count != e->count ||
                              memcmp(b->frames, e->frames, e->count * sizeof *e->frames) != 0))
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "%s and %s hold other frames (%u and %u in common with the run)",
                           matched, unbiased, e->count, b->count);
    }
    if (res == TND_OK && matched)
        snprintf(e->series[0].name, sizeof e->series[0].name,
                 "denoiser error (denoised vs matched)");
    char *settings = NULL;
    if (res == TND_OK && !(settings = settings_json(e, out, exposure)))
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    if (res == TND_OK) { /* what each comparison measures, and the references' own noise */
        cJSON *sj = cJSON_Parse(settings);
        cJSON_AddStringToObject(sj, "denoiser_error_against",
                                matched ? matched : "(no matched reference)");
        cJSON_AddStringToObject(sj, "estimator_bias_against",
                                both ? unbiased : "(needs both references)");
        double nm = rn_reference_noise(primary, e), nu = both ? rn_reference_noise(unbiased, b) : -1;
        cJSON_AddNumberToObject(sj, "reference_noise_relmse", nm);
        if (both)
            cJSON_AddNumberToObject(sj, "unbiased_reference_noise_relmse", nu);
        cJSON_AddNumberToObject(sj, "noise_rule", EVAL_NOISE_RULE);
        char *txt = cJSON_PrintUnformatted(sj);
        cJSON_Delete(sj);
        free(settings);
        settings = txt;
        rn_warn_noise(primary, nm, e->series[0].summary.relmse, matched ? "denoiser error" : "error",
                   h);
        if (both)
            rn_warn_noise(unbiased, nu, b->series[0].summary.relmse, "estimator bias", h);
    }
    ev_series series[RN_EVAL_MAX_SERIES + 1];
    char **regions = r->regions;
    uint32_t ns = 0;
    for (uint32_t i = 0; res == TND_OK && i < e->nseries; i++) {
        regions[i] = rn_eval_regions_json(e, i);
        series[ns++] =
            (ev_series){e->series[i].name, e->series[i].m, e->series[i].summary, regions[i]};
    }
    if (res == TND_OK && both)
        series[ns++] = (ev_series){b->series[0].name, b->series[0].m, b->series[0].summary, NULL};
    if (res == TND_OK)
        res = ev_write_metrics(out, series, ns, e->count, settings);
    bool made_report = report && !is_dir(report);
    if (res == TND_OK && report) {
        char title[1200];
        snprintf(title, sizeof title, "Tandem eval: %s against %s", out, primary);
        ev_text html = {0};
        ev_text_add(
            &html,
            "<h2>What is measured</h2><p>%s</p>",
            matched ? "The run is compared with the <b>matched reference</b>: the converged "
                      "expectation of the same real-time estimator (its bounces, light model, "
                      "spherical-harmonic indirect light, checkerboard fields), so the figures "
                      "above are the <b>denoiser's own error</b>: what it adds (blur, lag, "
                      "ghosting) or leaves (noise)."
                    : "The run is compared with the <b>unbiased reference</b> (every bounce): the "
                      "figures above mix the denoiser's error with the real-time estimator's "
                      "bias (what its one bounce and its models leave out). Give "
                      "--matched-reference to tell them apart.");
        if (both) {
            const ev_summary *bs = &b->series[0].summary;
            ev_text_add(&html,
                        "<h2>Estimator bias</h2><p>The matched reference against the unbiased "
                        "one: what this estimator cannot reach however well it is denoised (no "
                        "denoiser of it can do better). relMSE %.4g, SMAPE %.4f, FLIP %.4f over "
                        "%u frames.</p>",
                        bs->relmse, bs->smape, bs->flip, b->count);
        }
        rn_convergence cv = rn_eval_convergence(e);
        if (cv.have) {
            ev_text conv = {0};
            rn_eval_convergence_text(e, "", &conv);
            ev_text_add(&html,
                        "<h2>Convergence</h2><p>A denoiser owes its matched reference this: "
                        "where nothing moves, its error falls frame by frame and ends at or "
                        "below that of <b>accumulation alone</b> (the running mean of the noisy "
                        "frames, restarted wherever anything moves), the curve beside it in the "
                        "relMSE plot.</p><pre style=\"white-space: pre-wrap\">");
            ev_text_escaped(&html, conv.s ? conv.s : "");
            ev_text_add(&html, "</pre><p><img src=\"plot_relmse.svg\" alt=\"relMSE per "
                               "frame\"></p>\n");
            ev_text_free(&conv);
        }
        rn_eval_regions_html(e, &html);
        res = rn_eval_report(e, report, title, settings, html.s);
        ev_text_free(&html);
        if (res != TND_OK && made_report && !rn_remove_flat_dir(report)) /* no partial report */
            rn_warn(h, "tandem: eval: could not remove the partial report %s", report);
    }
    free(settings);
    if (res != TND_OK)
        rn_eval_result_free(r);
    return res;
}

void rn_eval_result_free(rn_eval_result *r)
{
    for (uint32_t i = 0; i < RN_EVAL_MAX_SERIES; i++) {
        free(r->regions[i]);
        r->regions[i] = NULL;
    }
    rn_eval_free(&r->e);
    rn_eval_free(&r->b);
}
