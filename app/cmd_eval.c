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
    "DIR/metrics.json and DIR/metrics.csv; with --report, an HTML page with images and plots.",
    "--out DIR --reference REFDIR [--report REPORTDIR] [--exposure auto|EV100] [--ppd P] [--json]",
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
        cJSON_AddStringToObject(s, "kind", e->series[i].noisy ? "capture composited, no denoiser"
                                                              : "linear output");
        cJSON_AddItemToArray(series, s);
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

/* Remove a directory this command created and filled with files only (the report). */
int cmd_eval(int argc, char **argv)
{
    const char *out = NULL, *refdir = NULL, *report = NULL, *exposure = "auto";
    double ppd = EV_FLIP_PPD;
    bool json = false;
    const app_opt opts[] = {
        {"out", APP_OPT_STRING, &out, "DIR", "the run to evaluate (its frame_NNNN.exr)"},
        {"reference", APP_OPT_STRING, &refdir, "REFDIR", "converged references (frame_NNNN.exr)"},
        {"report", APP_OPT_STRING, &report, "REPORTDIR", "also write an HTML report there"},
        {"exposure", APP_OPT_STRING, &exposure, "auto|EV100",
         "tone mapping of the LDR metrics: auto (the references' geometric-mean luminance to "
         "0.18, one exposure for the whole sequence) or a fixed EV100"},
        {"ppd", APP_OPT_FLOAT, &ppd, "P", "FLIP pixels per degree (default 67: 0.7 m wide 4K at 0.7 m)"},
        {"json", APP_OPT_FLAG, &json, NULL, "print the summary as JSON"},
        {0},
    };
    const char *pos[1];
    int npos;
    int rc = app_parse(&eval_cmd, opts, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;
    if (!out || !refdir) {
        fprintf(stderr, "tandem eval: --out DIR and --reference REFDIR are required (see tandem eval --help)\n");
        return APP_EXIT_USAGE;
    }
    app_eval e = {.ppd = ppd};
    if (strcmp(exposure, "auto") != 0) {
        char *end;
        double ev = strtod(exposure, &end);
        if (*end || !isfinite(ev) || ev < -20 || ev > 30) {
            fprintf(stderr, "tandem eval: --exposure %s: expected auto or an EV100 in [-20, 30]\n",
                    exposure);
            return APP_EXIT_USAGE;
        }
        e.exposure = 1.0 / (1.2 * pow(2.0, ev));
    }
    if (!(ppd > 0 && ppd < 1000)) {
        fprintf(stderr, "tandem eval: --ppd %g: expected a positive number of pixels per degree\n", ppd);
        return APP_EXIT_USAGE;
    }
    for (const char *d = out; d; d = d == out ? refdir : NULL)
        if (!is_dir(d)) {
            fprintf(stderr, "tandem: eval: %s: no such directory\n", d);
            return APP_EXIT_FAIL;
        }
    if (strlen(out) > 1000 || strlen(refdir) > 1000 || (report && strlen(report) > 1000)) {
        fprintf(stderr, "tandem eval: path too long\n");
        return APP_EXIT_USAGE;
    }
    snprintf(e.ref, sizeof e.ref, "%s", refdir);
    tnd_result res = app_eval_add(&e, "denoised", out, false);
    char cap[1200];
    snprintf(cap, sizeof cap, "%s/capture", out);
    if (res == TND_OK && is_dir(cap)) {
        res = app_eval_add(&e, "noisy (1 spp)", out, true);
        snprintf(e.regions_from, sizeof e.regions_from, "%.1000s/capture", out); /* the masks */
    }
    app_progress bar;
    uint32_t *list = NULL, nlist = 0;
    if (res == TND_OK && (res = app_list_frames(refdir, &list, &nlist)) == TND_OK) {
        app_progress_begin(&bar, "eval", nlist);
        e.progress = &bar;
        res = app_eval_run(&e);
        app_progress_end(&bar);
    }
    free(list);
    char *settings = NULL;
    if (res == TND_OK && !(settings = settings_json(&e, out, exposure)))
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    ev_series series[APP_EVAL_MAX_SERIES];
    char *regions[APP_EVAL_MAX_SERIES] = {0};
    for (uint32_t i = 0; i < e.nseries; i++) {
        regions[i] = res == TND_OK ? app_eval_regions_json(&e, i) : NULL;
        series[i] = (ev_series){e.series[i].name, e.series[i].m, e.series[i].summary, regions[i]};
    }
    if (res == TND_OK)
        res = ev_write_metrics(out, series, e.nseries, e.count, settings);
    bool made_report = report && !is_dir(report);
    if (res == TND_OK && report) {
        char title[1200];
        snprintf(title, sizeof title, "Tandem eval: %s against %s", out, refdir);
        ev_text html = {0};
        app_eval_regions_html(&e, &html);
        res = app_eval_report(&e, report, title, settings, html.s);
        ev_text_free(&html);
        if (res != TND_OK && made_report && !app_remove_flat_dir(report)) /* no partial report */
            fprintf(stderr, "tandem: eval: could not remove the partial report %s\n", report);
    }
    if (res == TND_OK) {
        if (json) {
            cJSON *j = cJSON_CreateArray();
            for (uint32_t i = 0; i < e.nseries; i++) {
                const ev_summary *s = &e.series[i].summary;
                cJSON *o = cJSON_CreateObject();
                cJSON_AddStringToObject(o, "name", e.series[i].name);
                cJSON_AddNumberToObject(o, "frames", e.count);
                cJSON_AddNumberToObject(o, "relmse", s->relmse);
                cJSON_AddNumberToObject(o, "smape", s->smape);
                cJSON_AddNumberToObject(o, "rmse", s->rmse);
                cJSON_AddNumberToObject(o, "psnr", s->psnr);
                cJSON_AddNumberToObject(o, "ssim", s->ssim);
                cJSON_AddNumberToObject(o, "flip", s->flip);
                cJSON_AddNumberToObject(o, "temporal", s->temporal);
                cJSON_AddNumberToObject(o, "lag", s->lag);
                cJSON *reg = regions[i] ? cJSON_Parse(regions[i]) : NULL;
                if (reg)
                    cJSON_AddItemToObject(o, "regions", reg);
                cJSON_AddItemToArray(j, o);
            }
            char *txt = cJSON_Print(j);
            printf("%s\n", txt ? txt : "[]");
            free(txt);
            cJSON_Delete(j);
        } else {
            printf("eval: %u frames (%u..%u, %ux%u) against %s, exposure %.4g (%s)\n", e.count,
                   e.frames[0], e.frames[e.count - 1], e.width, e.height, refdir, e.exposure,
                   e.auto_exposure ? "auto" : "EV100");
            printf("  %-28s %10s %8s %8s %8s %7s %7s %9s %6s\n", "series", "relMSE", "SMAPE",
                   "RMSE", "PSNR", "SSIM", "FLIP", "temporal", "lag");
            for (uint32_t i = 0; i < e.nseries; i++) {
                const ev_summary *s = &e.series[i].summary;
                char lag[32];
                if (s->lag >= 0)
                    snprintf(lag, sizeof lag, "%.1f", s->lag);
                else
                    snprintf(lag, sizeof lag, "-");
                printf("  %-28s %10.4g %8.4f %8.4g %8.2f %7.4f %7.4f %9.4g %6s\n",
                       e.series[i].name, s->relmse, s->smape, s->rmse, s->psnr, s->ssim, s->flip,
                       s->temporal, lag);
            }
            for (uint32_t i = 0; i < e.nseries; i++)
                for (int b = 0; b < APP_REGIONS; b++) {
                    const app_region *r = &e.series[i].regions[b];
                    app_region_stats st = app_region_summary(r);
                    if (r->pixels)
                        printf("  %-28s %s: %llu pixels, relMSE %.4g, FLIP %.4f, sharpness %.3f, "
                               "bias %+.1f%%\n",
                               e.series[i].name, app_region_name(b), (unsigned long long)r->pixels,
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
    if (res != TND_OK)
        return app_report("eval", res);
    return APP_EXIT_OK;
}
