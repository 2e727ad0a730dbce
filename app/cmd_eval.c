/* app/cmd_eval.c: `tandem eval --out DIR --reference REFDIR [--report REPORTDIR]`: the metrics of
 * a run's frames (DIR/frame_NNNN.exr, linear HDR) against converged references
 * (REFDIR/frame_NNNN.exr from `tandem reference`), and of its noisy input when the run kept its
 * captures (rn_eval_sequence, run/rn_evaluate.c); the summary as a table or JSON. */
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

void app_metrics_text(FILE *f, const ev_summary *s)
{
    for (uint32_t k = 0; k < ev_metric_count(); k++)
        if (ev_metric_at(k)->summarised) {
            fputc(' ', f);
            fprintf(f, ev_metric_at(k)->fmt, ev_metric_summary(ev_metric_at(k), s));
        }
}

void app_metrics_header(FILE *f)
{
    for (uint32_t k = 0; k < ev_metric_count(); k++)
        if (ev_metric_at(k)->summarised) /* (as wide as its values) */
            fprintf(f, " %*s", atoi(ev_metric_at(k)->fmt + 1), ev_metric_at(k)->head);
}

static cJSON *summary_json(const rn_eval_series *se, uint32_t count, const char *role,
                           const char *against, const char *regions)
{
    const ev_summary *s = &se->summary;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "name", se->name);
    cJSON_AddStringToObject(o, "role", role);
    cJSON_AddStringToObject(o, "against", against);
    cJSON_AddNumberToObject(o, "frames", count);
    rn_metrics_json(o, s);
    cJSON_AddNumberToObject(o, "lag", s->lag);
    cJSON *reg = regions ? cJSON_Parse(regions) : NULL;
    if (reg)
        cJSON_AddItemToObject(o, "regions", reg);
    return o;
}

static void print_row(const rn_eval_series *se)
{
    const ev_summary *s = &se->summary;
    char lag[32] = "-";
    if (s->lag >= 0)
        snprintf(lag, sizeof lag, "%.1f", s->lag);
    printf("  %-40s", se->name);
    app_metrics_text(stdout, s);
    printf(" %6s\n", lag);
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
    rn_eval_opts eo = {.out = out, .reference = unbiased, .matched = matched,
                       .report = report, .exposure = exposure, .ppd = ppd,
                       .metrics_on = metrics_on};
    if (!(ppd > 0)) /* (0 is the run layer's default; on the command line, a mistake) */
        tnd_fail(TND_ERR_INVALID_ARGUMENT,
                 "--ppd %g: expected a positive number of pixels per degree", ppd);
    if (!(ppd > 0) || rn_eval_check(&eo) != TND_OK) {
        fprintf(stderr, "tandem eval: %s\n", tnd_error_detail());
        return APP_EXIT_USAGE;
    }
    rn_host h = app_host();
    rn_eval_result r;
    tnd_result res = rn_eval_sequence(&eo, &h, &r);
    if (res != TND_OK)
        return app_report("eval", res);
    const rn_eval *e = &r.e, *b = &r.b;
    bool both = r.both;
    char **regions = r.regions;
    /* (--quiet: the files alone; --json is the output asked for) */
    if (json || !app_quiet()) {
        if (json) {
            cJSON *j = cJSON_CreateArray();
            for (uint32_t i = 0; i < e->nseries; i++)
                cJSON_AddItemToArray(
                    j, summary_json(&e->series[i], e->count,
                                    e->series[i].kind == RN_SERIES_NOISY         ? "noisy input"
                                    : e->series[i].kind == RN_SERIES_ACCUMULATED ? "accumulation alone"
                                    : matched                                    ? "denoiser error"
                                                                                 : "error",
                                    r.primary, regions[i]));
            if (both)
                cJSON_AddItemToArray(j, summary_json(&b->series[0], b->count, "estimator bias",
                                                     unbiased, NULL));
            char *txt = cJSON_Print(j);
            printf("%s\n", txt ? txt : "[]");
            free(txt);
            cJSON_Delete(j);
        } else {
            printf("eval: %u frames (%u..%u, %ux%u) against %s (%s), exposure %.4g (%s)\n",
                   e->count, e->frames[0], e->frames[e->count - 1], e->width, e->height, r.primary,
                   matched ? "matched: the same estimator's expectation" : "unbiased",
                   e->exposure, e->auto_exposure ? "auto" : "EV100");
            printf("  %-40s", "series");
            app_metrics_header(stdout);
            printf(" %6s\n", "lag");
            for (uint32_t i = 0; i < e->nseries; i++)
                print_row(&e->series[i]);
            if (both) {
                printf("  estimator bias: %s against %s (unbiased): what no denoiser of this "
                       "estimator can recover\n",
                       matched, unbiased);
                print_row(&b->series[0]);
            }
            ev_text conv = {0};
            rn_eval_convergence_text(e, "  ", &conv);
            if (conv.s)
                fputs(conv.s, stdout);
            ev_text_free(&conv);
            for (uint32_t i = 0; i < e->nseries; i++)
                for (int k = 0; k < RN_REGIONS; k++) {
                    const rn_region *g = &e->series[i].regions[k];
                    rn_region_stats st = rn_region_summary(g);
                    if (g->pixels)
                        printf("  %-28s %s: %llu pixels, relMSE %.4g, FLIP %.4f, sharpness %.3f, "
                               "bias %+.1f%%\n",
                               e->series[i].name, rn_region_name(k), (unsigned long long)g->pixels,
                               st.relmse, st.flip, st.sharpness, 100.0 * st.bias);
                }
            printf("  -> %s/metrics.json, %s/metrics.csv%s%s%s\n", out, out,
                   report ? ", " : "", report ? report : "", report ? "/index.html" : "");
        }
    }
    rn_eval_result_free(&r);
    return APP_EXIT_OK;
}
