/* app/cmd_eval.c: `tandem eval --out DIR --reference REFDIR [--report REPORTDIR]`: the metrics of
 * a run's frames (DIR/frame_NNNN.exr, linear HDR) against converged references
 * (REFDIR/frame_NNNN.exr from `tandem reference`), and of its noisy input when the run kept its
 * captures; DIR/metrics.json and DIR/metrics.csv, and the HTML report. */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const app_cmd eval_cmd = {
    "eval",
    "Evaluate a run's frames against converged references: relMSE, SMAPE, RMSE (linear), PSNR,\n"
    "SSIM, LDR-FLIP (tone-mapped), temporal error and lag (docs/metrics.md). Writes\n"
    "DIR/metrics.json and DIR/metrics.csv; with --report, an HTML page with images and plots.\n"
    "Against a matched reference the figures are the denoiser's own error; with both references\n"
    "the estimator's bias (matched against unbiased) is reported beside it.",
    "--out DIR --reference REFDIR | --matched-reference DIR (or both) [--report REPORTDIR] ...",
    NULL};

static bool is_dir(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISDIR(st.st_mode);
}

/* settings as JSON text: what was compared and how, plus the run's own run.json */
static char *settings_json(const app_eval *e, const char *out, const char *exposure_arg)
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
            [APP_SERIES_OUTPUT] = "linear output",
            [APP_SERIES_NOISY] = "capture composited, no denoiser",
            [APP_SERIES_ACCUMULATED] = "running mean of the capture composited, restarted "
                                       "wherever anything moves"};
        cJSON_AddStringToObject(s, "kind", kinds[e->series[i].kind]);
        cJSON_AddItemToArray(series, s);
    }
    app_convergence c = app_eval_convergence(e);
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

/* The reference's own noise over the evaluated frames: the mean of reference.json's
 * noise_relmse (what its noise adds to a relMSE measured against it); < 0 when unknown. */
static double reference_noise(const char *refdir, const app_eval *e)
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
static void warn_noise(const char *refdir, double noise, double measured, const char *what)
{
    if (noise >= 0 && measured > 0 && noise > EVAL_NOISE_RULE * measured)
        fprintf(stderr,
                "tandem: eval: warning: %s's own noise (relMSE %.4g) is %.0f%% of the %s measured "
                "against it (relMSE %.4g); the rule: under %.0f%% (more --spp, or tandem "
                "reference --until-noise)\n",
                refdir, noise, 100.0 * noise / measured, what, measured, 100.0 * EVAL_NOISE_RULE);
}

static cJSON *summary_json(const app_eval_series *se, uint32_t count, const char *role,
                           const char *against, const char *regions)
{
    const ev_summary *s = &se->summary;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", se->name);
    cJSON_AddStringToObject(o, "role", role);
    cJSON_AddStringToObject(o, "against", against);
    cJSON_AddNumberToObject(o, "frames", count);
    app_metrics_json(o, s);
    cJSON_AddNumberToObject(o, "lag", s->lag);
    cJSON *reg = regions ? cJSON_Parse(regions) : NULL;
    if (reg)
        cJSON_AddItemToObject(o, "regions", reg);
    return o;
}

static void print_row(const app_eval_series *se)
{
    const ev_summary *s = &se->summary;
    char lag[32] = "-";
    if (s->lag >= 0)
        snprintf(lag, sizeof lag, "%.1f", s->lag);
    printf("  %-40s", se->name);
    app_metrics_text(stdout, s);
    printf(" %6s\n", lag);
}

/* Run one evaluation with a progress bar over the reference's frames. */
static tnd_result run_eval(app_eval *e, const char *label)
{
    app_progress bar;
    uint32_t *list = NULL, nlist = 0;
    tnd_result res = app_list_frames(e->ref, &list, &nlist);
    if (res == TND_OK) {
        app_progress_begin(&bar, label, nlist);
        e->progress = &bar;
        res = app_eval_run(e);
        app_progress_end(&bar);
        e->progress = NULL;
    }
    free(list);
    return res;
}

int cmd_eval(int argc, char **argv)
{
    const char *out = NULL, *unbiased = NULL, *matched = NULL, *report = NULL;
    const char *exposure = "auto";
    double ppd = EV_FLIP_PPD;
    const char *metrics_on = "auto";
    bool json = false;
    const app_opt opts[] = {
        {"out", APP_OPT_STRING, &out, "DIR", "the run to evaluate (its frame_NNNN.exr)"},
        {"reference", APP_OPT_STRING, &unbiased, "REFDIR",
         "unbiased references (tandem reference): the whole error, or with --matched-reference "
         "the estimator's bias"},
        {"matched-reference", APP_OPT_STRING, &matched, "DIR",
         "matched references (tandem reference --estimator realtime, the run's estimator): the "
         "denoiser's own error"},
        {"report", APP_OPT_STRING, &report, "REPORTDIR", "also write an HTML report there"},
        {"exposure", APP_OPT_STRING, &exposure, "auto|EV100",
         "tone mapping of the LDR metrics: auto (the references' geometric-mean luminance to "
         "0.18, one exposure for the whole sequence) or a fixed EV100"},
        {"ppd", APP_OPT_FLOAT, &ppd, "P", "FLIP pixels per degree (default 67: 0.7 m wide 4K at 0.7 m)"},
        {"metrics-on", APP_OPT_STRING, &metrics_on, "WHERE",
         "where relMSE, SMAPE, RMSE, PSNR, SSIM and FLIP are computed: auto (a GPU where one is "
         "present, else the CPU; the default), cpu, or device (any Vulkan device, lavapipe too)"},
        {"json", APP_OPT_FLAG, &json, NULL, "print the summary as JSON"},
        {0},
    };
    const char *pos[1];
    int npos;
    int rc = app_parse(&eval_cmd, opts, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;
    if (!out || (!unbiased && !matched)) {
        fprintf(stderr, "tandem eval: --out DIR and --reference REFDIR or --matched-reference DIR "
                        "are required (see tandem eval --help)\n");
        return APP_EXIT_USAGE;
    }
    /* the run against `primary`; with both references the matched one against the unbiased */
    const char *primary = matched ? matched : unbiased;
    if (strcmp(metrics_on, "auto") != 0 && strcmp(metrics_on, "cpu") != 0 &&
        strcmp(metrics_on, "device") != 0) {
        fprintf(stderr, "tandem eval: --metrics-on %s: expected auto, cpu or device\n", metrics_on);
        return APP_EXIT_USAGE;
    }
    app_eval e = {.ppd = ppd, .metrics_on = metrics_on}, b = {.ppd = ppd, .metrics_on = metrics_on};
    if (strcmp(exposure, "auto") != 0) {
        char *end;
        double ev = strtod(exposure, &end);
        if (*end || !isfinite(ev) || ev < -20 || ev > 30) {
            fprintf(stderr, "tandem eval: --exposure %s: expected auto or an EV100 in [-20, 30]\n",
                    exposure);
            return APP_EXIT_USAGE;
        }
        e.exposure = b.exposure = 1.0 / (1.2 * pow(2.0, ev));
    }
    if (!(ppd > 0 && ppd < 1000)) {
        fprintf(stderr, "tandem eval: --ppd %g: expected a positive number of pixels per degree\n", ppd);
        return APP_EXIT_USAGE;
    }
    const char *dirs[3] = {out, unbiased, matched};
    for (int k = 0; k < 3; k++) {
        if (dirs[k] && !is_dir(dirs[k])) {
            fprintf(stderr, "tandem: eval: %s: no such directory\n", dirs[k]);
            return APP_EXIT_FAIL;
        }
        if (dirs[k] && strlen(dirs[k]) > 1000) {
            fprintf(stderr, "tandem eval: path too long\n");
            return APP_EXIT_USAGE;
        }
    }
    if (report && strlen(report) > 1000) {
        fprintf(stderr, "tandem eval: path too long\n");
        return APP_EXIT_USAGE;
    }
    bool both = matched && unbiased;
    snprintf(e.ref, sizeof e.ref, "%s", primary);
    tnd_result res = app_eval_add(&e, "denoised", out, APP_SERIES_OUTPUT);
    char cap[1200];
    snprintf(cap, sizeof cap, "%s/capture", out);
    if (res == TND_OK && is_dir(cap)) {
        res = app_eval_add(&e, "noisy (1 spp)", out, APP_SERIES_NOISY);
        if (res == TND_OK)
            res = app_eval_add(&e, "accumulation alone", out, APP_SERIES_ACCUMULATED);
        snprintf(e.regions_from, sizeof e.regions_from, "%.1000s/capture", out); /* the masks */
    }
    if (res == TND_OK)
        res = run_eval(&e, "eval");
    if (res == TND_OK && both) { /* the estimator's bias: its expectation against the truth */
        snprintf(b.ref, sizeof b.ref, "%s", unbiased);
        b.exposure = e.exposure; /* (one tone mapping for both comparisons) */
        if ((res = app_eval_add(&b, "estimator bias (matched vs unbiased)", matched,
                                APP_SERIES_OUTPUT)) == TND_OK)
            res = run_eval(&b, "eval: bias");
        if (res == TND_OK && (b.count != e.count ||
                              memcmp(b.frames, e.frames, e.count * sizeof *e.frames) != 0))
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "%s and %s hold other frames (%u and %u in common with the run)",
                           matched, unbiased, e.count, b.count);
    }
    if (res == TND_OK && matched)
        snprintf(e.series[0].name, sizeof e.series[0].name, "denoiser error (denoised vs matched)");
    char *settings = NULL;
    if (res == TND_OK && !(settings = settings_json(&e, out, exposure)))
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    if (res == TND_OK) { /* what each comparison measures, and the references' own noise */
        cJSON *sj = cJSON_Parse(settings);
        cJSON_AddStringToObject(sj, "denoiser_error_against",
                                matched ? matched : "(no matched reference)");
        cJSON_AddStringToObject(sj, "estimator_bias_against",
                                both ? unbiased : "(needs both references)");
        double nm = reference_noise(primary, &e), nu = both ? reference_noise(unbiased, &b) : -1;
        cJSON_AddNumberToObject(sj, "reference_noise_relmse", nm);
        if (both)
            cJSON_AddNumberToObject(sj, "unbiased_reference_noise_relmse", nu);
        cJSON_AddNumberToObject(sj, "noise_rule", EVAL_NOISE_RULE);
        char *txt = cJSON_PrintUnformatted(sj);
        cJSON_Delete(sj);
        free(settings);
        settings = txt;
        warn_noise(primary, nm, e.series[0].summary.relmse, matched ? "denoiser error" : "error");
        if (both)
            warn_noise(unbiased, nu, b.series[0].summary.relmse, "estimator bias");
    }
    ev_series series[APP_EVAL_MAX_SERIES + 1];
    char *regions[APP_EVAL_MAX_SERIES] = {0};
    uint32_t ns = 0;
    for (uint32_t i = 0; res == TND_OK && i < e.nseries; i++) {
        regions[i] = app_eval_regions_json(&e, i);
        series[ns++] = (ev_series){e.series[i].name, e.series[i].m, e.series[i].summary, regions[i]};
    }
    if (res == TND_OK && both)
        series[ns++] = (ev_series){b.series[0].name, b.series[0].m, b.series[0].summary, NULL};
    if (res == TND_OK)
        res = ev_write_metrics(out, series, ns, e.count, settings);
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
            const ev_summary *bs = &b.series[0].summary;
            ev_text_add(&html,
                           "<h2>Estimator bias</h2><p>The matched reference against the "
                           "unbiased one: what this estimator cannot reach however well it "
                           "is denoised (no denoiser of it can do better). relMSE %.4g, "
                           "SMAPE %.4f, FLIP %.4f over %u frames.</p>",
                           bs->relmse, bs->smape, bs->flip, b.count);
        }
        app_convergence cv = app_eval_convergence(&e);
        if (cv.have) {
            ev_text conv = {0};
            app_eval_convergence_text(&e, "", &conv);
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
        app_eval_regions_html(&e, &html);
        res = app_eval_report(&e, report, title, settings, html.s);
        ev_text_free(&html);
        if (res != TND_OK && made_report && !app_remove_flat_dir(report)) /* no partial report */
            fprintf(stderr, "tandem: eval: could not remove the partial report %s\n", report);
    }
    if (res == TND_OK) {
        if (json) {
            cJSON *j = cJSON_CreateArray();
            for (uint32_t i = 0; i < e.nseries; i++)
                cJSON_AddItemToArray(
                    j, summary_json(&e.series[i], e.count,
                                    e.series[i].kind == APP_SERIES_NOISY         ? "noisy input"
                                    : e.series[i].kind == APP_SERIES_ACCUMULATED ? "accumulation alone"
                                    : matched                                    ? "denoiser error"
                                                                                 : "error",
                                    primary, regions[i]));
            if (both)
                cJSON_AddItemToArray(j, summary_json(&b.series[0], b.count, "estimator bias",
                                                     unbiased, NULL));
            char *txt = cJSON_Print(j);
            printf("%s\n", txt ? txt : "[]");
            free(txt);
            cJSON_Delete(j);
        } else {
            printf("eval: %u frames (%u..%u, %ux%u) against %s (%s), exposure %.4g (%s)\n",
                   e.count, e.frames[0], e.frames[e.count - 1], e.width, e.height, primary,
                   matched ? "matched: the same estimator's expectation" : "unbiased",
                   e.exposure, e.auto_exposure ? "auto" : "EV100");
            printf("  %-40s", "series");
            app_metrics_header(stdout);
            printf(" %6s\n", "lag");
            for (uint32_t i = 0; i < e.nseries; i++)
                print_row(&e.series[i]);
            if (both) {
                printf("  estimator bias: %s against %s (unbiased): what no denoiser of this "
                       "estimator can recover\n",
                       matched, unbiased);
                print_row(&b.series[0]);
            }
            ev_text conv = {0};
            app_eval_convergence_text(&e, "  ", &conv);
            if (conv.s)
                fputs(conv.s, stdout);
            ev_text_free(&conv);
            for (uint32_t i = 0; i < e.nseries; i++)
                for (int r = 0; r < APP_REGIONS; r++) {
                    const app_region *g = &e.series[i].regions[r];
                    app_region_stats st = app_region_summary(g);
                    if (g->pixels)
                        printf("  %-28s %s: %llu pixels, relMSE %.4g, FLIP %.4f, sharpness %.3f, "
                               "bias %+.1f%%\n",
                               e.series[i].name, app_region_name(r), (unsigned long long)g->pixels,
                               st.relmse, st.flip, st.sharpness, 100.0 * st.bias);
                }
            printf("  -> %s/metrics.json, %s/metrics.csv%s%s%s\n", out, out,
                   report ? ", " : "", report ? report : "", report ? "/index.html" : "");
        }
    }
    free(settings);
    for (uint32_t i = 0; i < APP_EVAL_MAX_SERIES; i++)
        free(regions[i]);
    app_eval_free(&e);
    app_eval_free(&b);
    if (res != TND_OK)
        return app_report("eval", res);
    return APP_EXIT_OK;
}
