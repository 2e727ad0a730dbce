/* app/cmd_sweep.c: `tandem bench --scene S --sweep key=v1,v2,... [--sweep ...] --out DIR`: the
 * real-time pipeline over the cartesian product of knob values. Per combination: a `tandem
 * render` run (GPU ms per pass from its timestamps, medians over the frames after the warm-up),
 * its denoiser's error against the matched reference of its estimator (bounces, resolution;
 * made once per estimator under DIR/matched) and its error against the unbiased reference; then
 * DIR/sweep.json, DIR/sweep.csv and DIR/report (the Pareto fronts of time against the denoiser's
 * relMSE and FLIP, and the table). */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { MAX_KEYS = 6, MAX_VALUES = 8, MAX_RUNS = 256 };

typedef struct knob {
    const char *key, *option, *help;
} knob;

static const knob knobs[] = {
    {"bounces", "--bounces", "indirect bounces"},
    {"atrous", "--atrous", "a-trous iterations of hf and spec"},
    {"alpha", "--min-alpha", "temporal minimum alpha (hf, lf, spec)"},
    {"gradient", "--denoiser", "A-SVGF temporal gradients: on (asvgf) or off (svgf)"},
    {"denoiser", "--denoiser", "asvgf, svgf or off"},
    {"precision", "--precision", "contract precision: float32 or packed"},
    {"taa", "--taa", "on, off or the new-frame weight"},
    {"scale", "--size", "resolution scale (the output is resampled to the reference's size)"},
    {"frontend", "--frontend", "vk or embree (embree's front-end time is CPU wall clock)"},
};
enum { KNOBS = sizeof knobs / sizeof knobs[0] };

/* timings.json keys that are GPU passes of the frame (vk); primary/shade are the CPU's with embree */
static const char *const passes[] = {"primary_ms", "shade_ms", "tlas_ms", "gradient_shade_ms",
                                     "denoise_select_ms", "denoise_gradient_ms",
                                     "denoise_temporal_ms", "denoise_lf_ms", "denoise_atrous_ms",
                                     "composite_ms", "taa_ms", "bloom_ms", "exposure_ms",
                                     "tonemap_ms"};
enum { PASSES = sizeof passes / sizeof passes[0] };

typedef struct sweep_run {
    const char *value[MAX_KEYS];
    double pass_ms[PASSES], total_ms;
    ev_summary metrics;    /* the denoiser's error: against the cell's matched reference */
    ev_summary whole;      /* against the unbiased reference: denoiser error and estimator bias */
    int estimator;         /* index into the sweep's estimators (matched references) */
    bool pareto_relmse, pareto_flip;
} sweep_run;

/* One estimator of the sweep: the knobs that change the real-time estimator's expectation (its
 * bounce count and resolution); cells with the same one share its matched reference. */
typedef struct sweep_estimator {
    char bounces[16], size[32], dir[1100];
    ev_summary bias; /* its matched reference against the unbiased one */
} sweep_estimator;

/* Metrics of `dir`'s frames after the warm-up against `ref` (resampled to its size). */
static tnd_result eval_against(const char *dir, const char *ref, unsigned warmup, ev_summary *m)
{
    app_eval e = {.min_frame = warmup, .resample = true};
    snprintf(e.ref, sizeof e.ref, "%s", ref);
    tnd_result res = app_eval_add(&e, "run", dir, false);
    if (res == TND_OK)
        res = app_eval_run(&e);
    if (res == TND_OK)
        *m = e.series[0].summary;
    app_eval_free(&e);
    return res;
}

static tnd_result read_timings(const char *dir, unsigned warmup, sweep_run *r)
{
    char path[1400];
    snprintf(path, sizeof path, "%s/timings.json", dir);
    void *txt = NULL;
    size_t len = 0;
    tnd_result res = tnd_file_read(path, &txt, &len);
    if (res != TND_OK)
        return res;
    cJSON *j = cJSON_Parse(txt);
    free(txt);
    const cJSON *frames = cJSON_GetObjectItem(j, "frames");
    int n = cJSON_GetArraySize(frames);
    if (!j || n <= (int)warmup) {
        cJSON_Delete(j);
        return tnd_fail(TND_ERR_BAD_INPUT, "bench: %s: %d frames, need more than the %u of warm-up",
                        path, n, warmup);
    }
    double *v = malloc((size_t)n * sizeof *v);
    r->total_ms = 0;
    for (int p = 0; v && p < PASSES; p++) {
        unsigned m = 0;
        for (int i = (int)warmup; i < n; i++) {
            const cJSON *x = cJSON_GetObjectItem(cJSON_GetArrayItem(frames, i), passes[p]);
            v[m++] = cJSON_IsNumber(x) ? x->valuedouble : 0.0;
        }
        r->pass_ms[p] = app_median(v, m);
        r->total_ms += r->pass_ms[p];
    }
    free(v);
    cJSON_Delete(j);
    return TND_OK;
}

static const knob *find_knob(const char *key)
{
    for (int k = 0; k < KNOBS; k++)
        if (strcmp(knobs[k].key, key) == 0)
            return &knobs[k];
    return NULL;
}

int app_sweep(const app_list *sweeps, const char *scene, const char *out, const char *reference,
              unsigned spp, const unsigned size[2], unsigned frames, unsigned warmup)
{
    const knob *keys[MAX_KEYS];
    char *values_buf[MAX_KEYS] = {0};
    const char *values[MAX_KEYS][MAX_VALUES];
    int nvalues[MAX_KEYS], nkeys = sweeps->n;
    sweep_run *runs = NULL;
    sweep_estimator *ests = NULL;
    int nests = 0;
    tnd_result res = TND_OK;
    int status = APP_EXIT_USAGE;
    ev_text html = {0};
    cJSON *root = NULL;
    if (nkeys > MAX_KEYS) {
        fprintf(stderr, "tandem bench: at most %d --sweep keys\n", MAX_KEYS);
        return APP_EXIT_USAGE;
    }
    if (!out) {
        fprintf(stderr, "tandem bench: --sweep needs --out DIR\n");
        return APP_EXIT_USAGE;
    }
    if (strlen(out) > 900 || (reference && strlen(reference) > 900)) {
        fprintf(stderr, "tandem bench: path too long\n");
        return APP_EXIT_USAGE;
    }
    if (warmup >= frames) {
        fprintf(stderr, "tandem bench: --warmup %u must be below --frames %u\n", warmup, frames);
        return APP_EXIT_USAGE;
    }
    int total = 1;
    for (int k = 0; k < nkeys; k++) {
        const char *eq = strchr(sweeps->v[k], '=');
        char key[32];
        snprintf(key, sizeof key, "%.*s", eq ? (int)(eq - sweeps->v[k]) : 0, sweeps->v[k]);
        if (strcmp(key, "spp") == 0) {
            fprintf(stderr, "tandem bench: --sweep spp: the real-time front-ends trace one sample per "
                            "pixel (the A-SVGF gradient samples re-shade that one sample); samples per "
                            "pixel are the references' knob (tandem reference --spp)\n");
            goto fail;
        }
        if (!eq || !(keys[k] = find_knob(key))) {
            fprintf(stderr, "tandem bench: --sweep %s: expected KEY=V1,V2,... with KEY one of:",
                    sweeps->v[k]);
            for (int i = 0; i < KNOBS; i++)
                fprintf(stderr, " %s", knobs[i].key);
            fprintf(stderr, "\n");
            goto fail;
        }
        for (int j = 0; j < k; j++)
            if (keys[j] == keys[k]) {
                fprintf(stderr, "tandem bench: --sweep %s given twice\n", key);
                goto fail;
            }
        values_buf[k] = strdup(eq + 1);
        nvalues[k] = 0;
        for (char *save = NULL, *t = strtok_r(values_buf[k], ",", &save); t && nvalues[k] < MAX_VALUES;
             t = strtok_r(NULL, ",", &save))
            values[k][nvalues[k]++] = t;
        if (nvalues[k] == 0) {
            fprintf(stderr, "tandem bench: --sweep %s: no values\n", sweeps->v[k]);
            goto fail;
        }
        if (strcmp(key, "scale") == 0)
            for (int i = 0; i < nvalues[k]; i++) {
                char *end;
                double s = strtod(values[k][i], &end);
                if (*end || !(s >= 0.1 && s <= 1.0)) {
                    fprintf(stderr, "tandem bench: --sweep scale=%s: a scale in [0.1, 1]\n", values[k][i]);
                    goto fail;
                }
            }
        if (strcmp(key, "gradient") == 0)
            for (int i = 0; i < nvalues[k]; i++)
                if (strcmp(values[k][i], "on") != 0 && strcmp(values[k][i], "off") != 0) {
                    fprintf(stderr, "tandem bench: --sweep gradient=%s: on or off\n", values[k][i]);
                    goto fail;
                }
        total *= nvalues[k];
    }
    if (total > MAX_RUNS) {
        fprintf(stderr, "tandem bench: %d combinations (at most %d)\n", total, MAX_RUNS);
        goto fail;
    }
    status = APP_EXIT_FAIL;
    runs = calloc((size_t)total, sizeof *runs);
    if (!runs) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        goto fail;
    }
    TND_TRY(tnd_mkdirs(out));
    char refdir[1000], fr[16], sz[32], sp[16];
    snprintf(fr, sizeof fr, "%u", frames);
    snprintf(sz, sizeof sz, "%ux%u", size[0], size[1]);
    snprintf(sp, sizeof sp, "%u", spp);
    if (reference) {
        snprintf(refdir, sizeof refdir, "%s", reference);
    } else {
        snprintf(refdir, sizeof refdir, "%s/reference", out);
        char *args[] = {"reference", "--frontend", "vk", "--scene", (char *)scene, "--frames", fr,
                        "--size", sz, "--spp", sp, "--out", refdir, "--quiet"};
        if (cmd_reference((int)(sizeof args / sizeof args[0]), args) != APP_EXIT_OK) {
            res = tnd_fail(TND_ERR_IO, "bench: the reference (%s) failed", refdir);
            goto fail;
        }
    }
    ests = calloc((size_t)total, sizeof *ests);
    if (!ests) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        goto fail;
    }
    app_progress bar;
    app_progress_begin(&bar, "sweep", (unsigned)total);
    for (int i = 0; i < total; i++) {
        sweep_run *r = &runs[i];
        char dir[1300], run_size[32];
        const char *bounces = "1";
        snprintf(dir, sizeof dir, "%s/runs/%03d", out, i);
        snprintf(run_size, sizeof run_size, "%s", sz);
        char *args[64] = {"render", "--scene", (char *)scene, "--frames", fr, "--out", dir,
                          "--quiet", "--frontend", "vk"};
        int na = 10;
        for (int k = 0, rest = i; k < nkeys; k++) {
            const char *v = values[k][rest % nvalues[k]];
            rest /= nvalues[k];
            r->value[k] = v;
            const char *key = keys[k]->key;
            if (strcmp(key, "scale") == 0) {
                double s = strtod(v, NULL);
                snprintf(run_size, sizeof run_size, "%ux%u", (unsigned)fmax(1, lround(size[0] * s)),
                         (unsigned)fmax(1, lround(size[1] * s)));
                continue;
            }
            if (strcmp(key, "bounces") == 0)
                bounces = v;
            args[na++] = (char *)keys[k]->option;
            args[na++] = strcmp(key, "gradient") == 0 ? (strcmp(v, "on") == 0 ? "asvgf" : "svgf")
                                                       : (char *)v;
        }
        args[na++] = "--size";
        args[na++] = run_size;
        /* the cell's estimator and its matched reference (made once per estimator) */
        r->estimator = -1;
        for (int k = 0; k < nests; k++)
            if (!strcmp(ests[k].bounces, bounces) && !strcmp(ests[k].size, run_size))
                r->estimator = k;
        if (r->estimator < 0) {
            sweep_estimator *es = &ests[nests];
            snprintf(es->bounces, sizeof es->bounces, "%s", bounces);
            snprintf(es->size, sizeof es->size, "%s", run_size);
            snprintf(es->dir, sizeof es->dir, "%s/matched/bounces%s_%s", out, bounces, run_size);
            /* (Embree: the same samples as Vulkan's, without a contract read back per sample) */
            char *margs[] = {"reference", "--estimator", "realtime", "--frontend", "embree",
                             "--scene", (char *)scene, "--frames", fr, "--size", run_size,
                             "--bounces", (char *)bounces, "--spp", sp, "--out", es->dir,
                             "--quiet"};
            if (cmd_reference((int)(sizeof margs / sizeof margs[0]), margs) != APP_EXIT_OK) {
                app_progress_end(&bar);
                res = tnd_fail(TND_ERR_IO, "bench: the matched reference %s failed", es->dir);
                goto fail;
            }
            TND_TRY(eval_against(es->dir, refdir, warmup, &es->bias));
            r->estimator = nests++;
        }
        if (cmd_render(na, args) != APP_EXIT_OK) {
            app_progress_end(&bar);
            res = tnd_fail(TND_ERR_IO, "bench: sweep run %d (%s) failed", i, dir);
            goto fail;
        }
        TND_TRY(read_timings(dir, warmup, r));
        TND_TRY(eval_against(dir, ests[r->estimator].dir, warmup, &r->metrics));
        TND_TRY(eval_against(dir, refdir, warmup, &r->whole));
        app_progress_step(&bar, (unsigned)i + 1);
    }
    app_progress_end(&bar);
    /* Pareto fronts and the outputs */
    double *tx = malloc((size_t)total * sizeof *tx), *ya = malloc((size_t)total * sizeof *ya),
           *yb = malloc((size_t)total * sizeof *yb);
    bool *pa = malloc((size_t)total), *pb = malloc((size_t)total);
    char (*label)[160] = malloc((size_t)total * sizeof *label);
    const char **labels = malloc((size_t)total * sizeof *labels);
    if (!tx || !ya || !yb || !pa || !pb || !label || !labels) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        free(tx), free(ya), free(yb), free(pa), free(pb), free(label), free(labels);
        goto fail;
    }
    for (int i = 0; i < total; i++) {
        tx[i] = runs[i].total_ms;
        ya[i] = runs[i].metrics.relmse;
        yb[i] = runs[i].metrics.flip;
        size_t n = 0;
        label[i][0] = 0;
        for (int k = 0; k < nkeys; k++)
            n += (size_t)snprintf(label[i] + n, sizeof label[i] - n, "%s%s=%s", k ? " " : "",
                                  keys[k]->key, runs[i].value[k]);
        labels[i] = label[i];
    }
    ev_pareto(tx, ya, (uint32_t)total, pa);
    ev_pareto(tx, yb, (uint32_t)total, pb);
    char rdir[1300], path[1400];
    snprintf(rdir, sizeof rdir, "%s/report", out);
    res = tnd_mkdirs(rdir);
    const char *xlabel = "GPU ms per frame (median after warm-up)";
    if (res == TND_OK) {
        snprintf(path, sizeof path, "%s/pareto_relmse.svg", rdir);
        res = ev_plot_pareto(path, "time vs relMSE (Pareto front in red)", xlabel, "relMSE", tx,
                             ya, labels, pa, (uint32_t)total, false, true);
    }
    if (res == TND_OK) {
        snprintf(path, sizeof path, "%s/pareto_flip.svg", rdir);
        res = ev_plot_pareto(path, "time vs FLIP (Pareto front in red)", xlabel, "FLIP", tx, yb,
                             labels, pb, (uint32_t)total, false, false);
    }
    /* JSON, CSV, the table */
    root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "scene", scene);
    cJSON_AddStringToObject(root, "reference", refdir);
    cJSON_AddNumberToObject(root, "width", size[0]);
    cJSON_AddNumberToObject(root, "height", size[1]);
    cJSON_AddNumberToObject(root, "frames", frames);
    cJSON_AddNumberToObject(root, "warmup", warmup);
    cJSON *ka = cJSON_AddArrayToObject(root, "knobs");
    for (int k = 0; k < nkeys; k++)
        cJSON_AddItemToArray(ka, cJSON_CreateString(keys[k]->key));
    cJSON *ra = cJSON_AddArrayToObject(root, "runs");
    ev_text csv = {0};
    for (int k = 0; k < nkeys; k++)
        ev_text_add(&csv, "%s,", keys[k]->key);
    ev_text_add(&csv, "total_ms");
    for (int p = 0; p < PASSES; p++)
        ev_text_add(&csv, ",%s", passes[p]);
    ev_text_add(&csv, ",relmse,smape,psnr,ssim,flip,temporal,pareto_relmse,pareto_flip,"
                      "relmse_unbiased,flip_unbiased,estimator_bias_relmse\n");
    ev_text_add(&html, "<h2>Runs</h2>\n<p>%d combinations of %s at %ux%u, %u frames, medians after "
                       "%u warm-up frames. relMSE, FLIP, SSIM, PSNR and temporal: the "
                       "denoiser's error, against each cell's <b>matched reference</b> (the "
                       "converged expectation of its real-time estimator: its bounces and "
                       "resolution; %d of them); \"vs unbiased\": against <code>",
                total, scene, size[0], size[1], frames, warmup, nests);
    ev_text_escaped(&html, refdir);
    ev_text_add(&html, "</code>, the denoiser's error and the estimator's bias together; "
                       "\"bias\": the matched reference against the unbiased one. Bold: on a "
                       "Pareto front.</p>\n<img src=\"pareto_relmse.svg\" "
                       "width=\"680\" height=\"320\" alt=\"pareto relMSE\"> <img "
                       "src=\"pareto_flip.svg\" width=\"680\" height=\"320\" alt=\"pareto FLIP\">\n"
                       "<table><tr>");
    for (int k = 0; k < nkeys; k++)
        ev_text_add(&html, "<th>%s</th>", keys[k]->key);
    ev_text_add(&html, "<th>GPU ms</th><th>front-end ms</th><th>denoise ms</th><th>post ms</th>"
                       "<th>relMSE</th><th>FLIP</th><th>SSIM</th><th>PSNR</th><th>temporal</th>"
                       "<th>relMSE vs unbiased</th><th>bias relMSE</th></tr>\n");
    for (int i = 0; i < total; i++) {
        sweep_run *r = &runs[i];
        r->pareto_relmse = pa[i];
        r->pareto_flip = pb[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToArray(ra, o);
        cJSON *kv = cJSON_AddObjectToObject(o, "knobs");
        for (int k = 0; k < nkeys; k++) {
            cJSON_AddStringToObject(kv, keys[k]->key, r->value[k]);
            ev_text_add(&csv, "%s,", r->value[k]);
        }
        cJSON_AddNumberToObject(o, "total_ms", r->total_ms);
        ev_text_add(&csv, "%.6g", r->total_ms);
        cJSON *pm = cJSON_AddObjectToObject(o, "pass_ms");
        double fe = 0, dn = 0, post = 0;
        for (int p = 0; p < PASSES; p++) {
            cJSON_AddNumberToObject(pm, passes[p], r->pass_ms[p]);
            ev_text_add(&csv, ",%.6g", r->pass_ms[p]);
            if (p < 4)
                fe += r->pass_ms[p];
            else if (p < 10)
                dn += r->pass_ms[p];
            else
                post += r->pass_ms[p];
        }
        const ev_summary *m = &r->metrics;
        cJSON_AddNumberToObject(o, "relmse", m->relmse);
        cJSON_AddNumberToObject(o, "smape", m->smape);
        cJSON_AddNumberToObject(o, "psnr", m->psnr);
        cJSON_AddNumberToObject(o, "ssim", m->ssim);
        cJSON_AddNumberToObject(o, "flip", m->flip);
        cJSON_AddNumberToObject(o, "temporal", m->temporal);
        cJSON_AddBoolToObject(o, "pareto_relmse", pa[i]);
        cJSON_AddBoolToObject(o, "pareto_flip", pb[i]);
        const sweep_estimator *es = &ests[r->estimator];
        cJSON_AddStringToObject(o, "matched_reference", es->dir);
        cJSON_AddNumberToObject(o, "relmse_unbiased", r->whole.relmse);
        cJSON_AddNumberToObject(o, "flip_unbiased", r->whole.flip);
        cJSON_AddNumberToObject(o, "estimator_bias_relmse", es->bias.relmse);
        cJSON_AddNumberToObject(o, "estimator_bias_flip", es->bias.flip);
        ev_text_add(&csv, ",%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%d,%d,%.9g,%.9g,%.9g\n", m->relmse,
                    m->smape, m->psnr, m->ssim, m->flip, m->temporal, pa[i], pb[i],
                    r->whole.relmse, r->whole.flip, es->bias.relmse);
        ev_text_add(&html, "<tr%s>", pa[i] || pb[i] ? " style=\"font-weight:bold\"" : "");
        for (int k = 0; k < nkeys; k++) {
            ev_text_add(&html, "<td>");
            ev_text_escaped(&html, r->value[k]);
            ev_text_add(&html, "</td>");
        }
        ev_text_add(&html, "<td>%.3f</td><td>%.3f</td><td>%.3f</td><td>%.3f</td><td>%.5g</td>"
                           "<td>%.4f</td><td>%.4f</td><td>%.2f</td><td>%.4g</td><td>%.5g</td>"
                           "<td>%.5g</td></tr>\n",
                    r->total_ms, fe, dn, post, m->relmse, m->flip, m->ssim, m->psnr, m->temporal,
                    r->whole.relmse, es->bias.relmse);
    }
    ev_text_add(&html, "</table>\n");
    free(tx), free(ya), free(yb), free(pa), free(pb), free(label), free(labels);
    char *json = cJSON_Print(root);
    ev_text jt = {0};
    if (json)
        ev_text_add(&jt, "%s\n", json);
    else
        jt.failed = true;
    char p2[1400];
    for (int w = 0; res == TND_OK && w < 2; w++) {
        const ev_text *t = w ? &csv : &jt;
        snprintf(p2, sizeof p2, "%s/sweep.%s", out, w ? "csv" : "json");
        res = t->failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory")
                        : tnd_file_write_atomic(p2, t->s, t->len);
    }
    if (res == TND_OK) {
        char title[1300];
        snprintf(title, sizeof title, "Tandem sweep: %s", scene);
        res = html.failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory")
                          : ev_report_write(&(ev_report){.dir = rdir, .title = title,
                                                         .settings = json, .html = html.s});
    }
    free(json);
    ev_text_free(&jt);
    ev_text_free(&csv);
    if (res == TND_OK) {
        status = APP_EXIT_OK;
        if (!app_quiet())
            fprintf(stderr, "tandem: bench: %d runs -> %s/sweep.json, %s/sweep.csv, %s/index.html\n",
                    total, out, out, rdir);
        printf("sweep: %d runs of %s at %ux%u\n", total, scene, size[0], size[1]);
        for (int i = 0; i < total; i++) {
            printf(" ");
            for (int k = 0; k < nkeys; k++)
                printf(" %s=%s", keys[k]->key, runs[i].value[k]);
            printf(": %.3f ms, relMSE %.4g, FLIP %.4f (vs unbiased %.4g, estimator bias "
                   "%.4g)%s\n",
                   runs[i].total_ms, runs[i].metrics.relmse, runs[i].metrics.flip,
                   runs[i].whole.relmse, ests[runs[i].estimator].bias.relmse,
                   runs[i].pareto_relmse || runs[i].pareto_flip ? "  (Pareto)" : "");
        }
    }
fail:
    if (res != TND_OK)
        status = app_report("bench", res);
    cJSON_Delete(root);
    ev_text_free(&html);
    for (int k = 0; k < MAX_KEYS; k++)
        free(values_buf[k]);
    free(runs);
    free(ests);
    return status;
}
