/* app/cmd_compare.c: `tandem compare A B`: the agreement of two captures (the same frames from
 * two front-ends, or any two Tandem capture directories), per contract entry. G-buffer entries
 * must agree to float precision on --min-gbuffer of the pixels (the rest lie on triangle edges);
 * the noisy signals on --min-signal of the pixels that see the same surface (same path traced).
 * Exit 1 past those floors. With --scene: renders both front-ends (--frontends, registered names)
 * and the reference first through the run layer (rn_render_nested), then evaluates both. */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const app_cmd compare_cmd = {
    "compare",
    "Compare two capture directories (DIR or DIR/capture with frame_NNNN.exr) entry by entry:\n"
    "the fraction of pixels that agree, per frame and channel; exit 1 below the floors. With\n"
    "--reference, also the metrics of both runs' denoised frames against it (and --report).\n"
    "With --scene, first render the scene with both front-ends through one back-end.",
    "A B [--min-gbuffer F] [--min-signal F] [--json] [--reference REFDIR [--report DIR]]\n"
    "       tandem compare --scene PATH --out DIR [--frames N] [--size WxH] [--reference REFDIR]",
    NULL};

/* The directory that holds the frames: DIR/capture when it exists, else DIR. */
static void frames_dir(const char *d, char *out, size_t cap)
{
    struct stat st;
    snprintf(out, cap, "%s/capture", d);
    if (stat(out, &st) != 0 || !S_ISDIR(st.st_mode))
        snprintf(out, cap, "%s", d);
}

static bool is_signal(tnd_ct e)
{
    return e == TND_CT_HF || e == TND_CT_LF_SH || e == TND_CT_LF_COCG || e == TND_CT_SPEC;
}

/* The agreement of the captures in da and db, frame by frame: per entry, the fraction of
 * (same-surface, for the signals) pixels that agree; printed unless json; into root ("frames",
 * "worst", "pass"). Returns APP_EXIT_OK, APP_EXIT_FAIL (below a floor, or an error: *res). */
static int agreement(const char *da, const char *db, double min_gbuffer, double min_signal,
                     bool json, cJSON *root, tnd_result *res)
{
    *res = TND_OK;
    uint32_t *list = NULL, nf = 0;
    if ((*res = rn_list_frames(da, &list, &nf)) != TND_OK)
        return APP_EXIT_FAIL;
    char(*names)[32] = calloc(nf + 1, sizeof *names);
    if (!names) {
        free(list);
        *res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "compare: out of memory");
        return APP_EXIT_FAIL;
    }
    for (uint32_t k = 0; k < nf; k++)
        snprintf(names[k], sizeof names[0], "frame_%04u.exr", list[k]);
    free(list);
    int status = APP_EXIT_OK, compared = 0;
    double worst[TND_CT_COUNT];
    for (int i = 0; i < TND_CT_COUNT; i++)
        worst[i] = 1.0;
    cJSON *frames = cJSON_AddArrayToObject(root, "frames");
    for (uint32_t k = 0; k < nf; k++) {
        char pa[1200], pb[1200];
        snprintf(pa, sizeof pa, "%.1000s/%.31s", da, names[k]);
        snprintf(pb, sizeof pb, "%.1000s/%.31s", db, names[k]);
        struct stat st;
        if (stat(pb, &st) != 0)
            continue;
        tnd_frame a = {0}, b = {0};
        tnd_result r = tnd_capture_read(pa, &a);
        if (r == TND_OK)
            r = tnd_capture_read(pb, &b);
        if (r == TND_OK && (a.width != b.width || a.height != b.height))
            r = tnd_fail(TND_ERR_BAD_INPUT, "compare: %s: %ux%u against %ux%u", names[k], a.width,
                         a.height, b.width, b.height);
        if (r != TND_OK) {
            tnd_frame_destroy(&a);
            tnd_frame_destroy(&b);
            free(names);
            *res = r;
            return APP_EXIT_FAIL;
        }
        size_t n = (size_t)a.width * a.height;
        cJSON *fo = cJSON_CreateObject();
        cJSON_AddStringToObject(fo, "frame", names[k]);
        if (!json)
            printf("%s (%ux%u):\n", names[k], a.width, a.height);
        size_t same_surface = 0, ties = 0;
        /* a tie: the two front-ends hit two triangles of one instance at the same point (depth
         * within 1e-4): triangles that meet there (an edge within float rounding of the pixel's
         * ray: dense real geometry has many) or coincide there (real models carry duplicated
         * faces). Both answers are right: such pixels are left out of the per-triangle entries
         * (depth and position still compared) and counted. A front-end that hit a wrong
         * triangle would hit it at another depth. */
        uint8_t *tie = calloc(n ? n : 1, 1);
        if (!tie) {
            tnd_frame_destroy(&a);
            tnd_frame_destroy(&b);
            free(names);
            *res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "compare: out of memory");
            return APP_EXIT_FAIL;
        }
        for (size_t q = 0; q < n; q++) {
            const uint32_t *va = tnd_frame_u(&a, TND_CT_VIS_ID) + 2 * q,
                           *vb = tnd_frame_u(&b, TND_CT_VIS_ID) + 2 * q;
            bool same = memcmp(va, vb, 8) == 0;
            same_surface += same;
            if (same || va[0] != vb[0] || va[0] == UINT32_MAX)
                continue;
            double za = tnd_frame_f(&a, TND_CT_DEPTH)[q], zb = tnd_frame_f(&b, TND_CT_DEPTH)[q];
            if (fabs(za - zb) <= 1e-4 * fmax(za, zb) + 1e-6)
                tie[q] = 1, ties++;
        }
        for (int e = 0; e < TND_CT_COUNT; e++) {
            const tnd_ct_info *ci = tnd_ct_get((tnd_ct)e);
            if (!a.present[e] || !b.present[e])
                continue;
            bool sig = is_signal((tnd_ct)e);
            size_t agree = 0, counted = 0;
            for (size_t q = 0; q < n; q++) {
                if (sig && memcmp(tnd_frame_u(&a, TND_CT_VIS_ID) + 2 * q,
                                  tnd_frame_u(&b, TND_CT_VIS_ID) + 2 * q, 8) != 0)
                    continue;
                if (tie[q] && e != TND_CT_DEPTH && e != TND_CT_POSITION)
                    continue;
                counted++;
                bool ok = true;
                for (uint32_t c = 0; c < ci->comps; c++) {
                    size_t i = q * ci->comps + c;
                    if (ci->kind == TND_CT_UINT) {
                        ok &= tnd_frame_u(&a, (tnd_ct)e)[i] == tnd_frame_u(&b, (tnd_ct)e)[i];
                    } else {
                        double x = tnd_frame_f(&a, (tnd_ct)e)[i], y = tnd_frame_f(&b, (tnd_ct)e)[i];
                        /* float precision: relative 1e-4 (G-buffer) or 1e-3 (signals: GPU
                         * transcendentals along a path), absolute 2e-3 for unit-scale G-buffer
                         * quantities (texture filtering weights are fixed point on GPUs) */
                        double tol = sig ? 1e-3 * fmax(fabs(x), fabs(y)) + 1e-6
                                         : (e == TND_CT_DEPTH || e == TND_CT_POSITION
                                                ? 1e-4 * fmax(fabs(x), fabs(y)) + 1e-6
                                                : 1e-4 * fmax(fabs(x), fabs(y)) + 2e-3);
                        ok &= fabs(x - y) <= tol;
                    }
                }
                agree += ok;
            }
            double frac = counted ? (double)agree / counted : 1.0;
            worst[e] = fmin(worst[e], frac);
            bool pass = frac >= (sig ? min_signal : min_gbuffer);
            if (!pass)
                status = APP_EXIT_FAIL;
            if (!json)
                printf("  %-12s %7.2f%% of %s%s\n", ci->name, 100.0 * frac,
                       sig ? "same-surface pixels" : "pixels", pass ? "" : "  <- below the floor");
            cJSON_AddNumberToObject(fo, ci->name, frac);
        }
        if (!json)
            printf("  (%.2f%% of the pixels see the same triangle; %.2f%% two triangles of one "
                   "object at the same point, left out of the per-triangle entries)\n",
                   100.0 * same_surface / n, 100.0 * ties / n);
        cJSON_AddNumberToObject(fo, "same_surface", (double)same_surface / n);
        cJSON_AddNumberToObject(fo, "edge_ties", (double)ties / n);
        free(tie);
        cJSON_AddItemToArray(frames, fo);
        compared++;
        tnd_frame_destroy(&a);
        tnd_frame_destroy(&b);
    }
    free(names);
    if (compared == 0) {
        *res = tnd_fail(TND_ERR_BAD_INPUT, "compare: no frame_NNNN.exr in both %s and %s", da, db);
        return APP_EXIT_FAIL;
    }
    cJSON *w = cJSON_AddObjectToObject(root, "worst");
    for (int e = 0; e < TND_CT_COUNT; e++)
        cJSON_AddNumberToObject(w, tnd_ct_get((tnd_ct)e)->name, worst[e]);
    cJSON_AddBoolToObject(root, "pass", status == APP_EXIT_OK);
    cJSON_AddNumberToObject(root, "compared", compared);
    if (!json)
        printf("%d frame%s compared: %s\n", compared, compared == 1 ? "" : "s",
               status == APP_EXIT_OK ? "agree" : "DISAGREE");
    return status;
}

/* The agreement table for the report. */
static void agreement_html(const cJSON *root, double min_gbuffer, double min_signal, ev_text *t)
{
    const cJSON *w = cJSON_GetObjectItem(root, "worst");
    const cJSON *n = cJSON_GetObjectItem(root, "compared");
    ev_text_add(t,
                "<h2>Contract agreement (embree vs vk captures)</h2>\n<p>%d frames; the worst "
                "frame's fraction of agreeing pixels per entry (signals: of the pixels that see "
                "the same surface). Floors: G-buffer %.3g, signals %.3g.</p>\n<table><tr><th>entry"
                "</th><th>agree (worst frame)</th><th>floor</th><th>verdict</th></tr>\n",
                n ? n->valueint : 0, min_gbuffer, min_signal);
    for (int e = 0; e < TND_CT_COUNT; e++) {
        const char *name = tnd_ct_get((tnd_ct)e)->name;
        const cJSON *v = cJSON_GetObjectItem(w, name);
        if (!v)
            continue;
        double floor = is_signal((tnd_ct)e) ? min_signal : min_gbuffer;
        ev_text_add(t, "<tr><td>%s</td><td>%.2f%%</td><td>%.1f%%</td><td>%s</td></tr>\n", name,
                    100.0 * v->valuedouble, 100.0 * floor, v->valuedouble >= floor ? "agree" : "DISAGREE");
    }
    ev_text_add(t, "</table>\n");
}

int cmd_compare(int argc, char **argv)
{
    double min_gbuffer = 0.99, min_signal = 0.9;
    bool json = false;
    const char *reference = NULL, *report = NULL, *scene = NULL, *out = NULL, *denoiser = pl_denoiser_default();
    const char *frontends = "embree,vk";
    unsigned frames = 8, spp = 64, size[2] = {160, 90}, camera = 0;
    double fps = 30;
    rn_env env = RN_ENV_INIT; /* --scene: the scene options render takes */
    const app_opt opts[] = {
        {"min-gbuffer", APP_OPT_FLOAT, &min_gbuffer, "F",
         "G-buffer entries: fraction of pixels that must agree (default 0.99)"},
        {"min-signal", APP_OPT_FLOAT, &min_signal, "F",
         "hf, lf, spec: fraction of same-surface pixels that must agree (default 0.9)"},
        {"json", APP_OPT_FLAG, &json, NULL, "print the figures as JSON"},
        {"reference", APP_OPT_STRING, &reference, "REFDIR",
         "also evaluate both runs' denoised frames against these references"},
        {"report", APP_OPT_STRING, &report, "DIR", "with two runs and --reference: the HTML report"},
        {"scene", APP_OPT_STRING, &scene, "PATH",
         "render the scene with both front-ends through one back-end, then compare (needs --out)"},
        {"out", APP_OPT_STRING, &out, "DIR",
         "with --scene: DIR/embree, DIR/vk, DIR/reference (unless --reference), DIR/report"},
        {"frames", APP_OPT_UINT, &frames, "N", "with --scene: frames (default 8)"},
        {"size", APP_OPT_SIZE, size, "WxH", "with --scene: image size (default 160x90)"},
        {"denoiser", APP_OPT_STRING, &denoiser, "NAME",
         "with --scene: the denoiser both run through (default asvgf)"},
        {"frontends", APP_OPT_STRING, &frontends, "A,B",
         "with --scene: the two front-ends (default embree,vk: the cross-check)"},
        {"spp", APP_OPT_UINT, &spp, "K", "with --scene and no --reference: reference samples (default 64)"},
        {"camera", APP_OPT_UINT, &camera, "N", "with --scene: the scene's camera (default 0)"},
        {"fps", APP_OPT_FLOAT, &fps, "F", "with --scene: frames per second of scene time (default 30)"},
        APP_ENV_OPTS(&env),
        {0},
    };
    const char *pos[2];
    int npos;
    int rc = app_parse(&compare_cmd, opts, argc, argv, pos, 2, &npos);
    if (rc >= 0)
        return rc;
    if (scene ? (npos != 0 || !out) : npos != 2) {
        fprintf(stderr, "tandem compare: two directories, or --scene PATH --out DIR, expected (see "
                        "tandem compare --help)\n");
        return APP_EXIT_USAGE;
    }
    if (!scene && report && !reference) {
        fprintf(stderr, "tandem compare: --report needs --reference REFDIR\n");
        return APP_EXIT_USAGE;
    }
    if ((out && strlen(out) > 900) || (reference && strlen(reference) > 900)) {
        fprintf(stderr, "tandem compare: path too long\n");
        return APP_EXIT_USAGE;
    }
    tnd_result res = TND_OK;
    char run_a[1000], run_b[1000], refdir[1000], report_dir[1000];
    char fe[2][256] = {"", ""}; /* --scene: the two front-ends (registered names) */
    if (scene) {
        const char *comma = strchr(frontends, ',');
        if (comma && comma - frontends < 256 && strlen(comma + 1) < 256) {
            snprintf(fe[0], sizeof fe[0], "%.*s", (int)(comma - frontends), frontends);
            snprintf(fe[1], sizeof fe[1], "%s", comma + 1);
        }
        for (int i = 0; i < 2; i++)
            if (!pl_frontend_live(fe[i]) || strncmp(fe[i], "plugin:", 7) == 0 ||
                strcmp(fe[0], fe[1]) == 0) {
                fprintf(stderr, "tandem compare: --frontends %s: two different front-ends of %s "
                                "expected\n", frontends, pl_frontend_live_names());
                return APP_EXIT_USAGE;
            }
    }
    if (scene) {
        /* both front-ends through one denoiser, then the reference: render as functions */
        snprintf(run_a, sizeof run_a, "%s/%s", out, fe[0]);
        snprintf(run_b, sizeof run_b, "%s/%s", out, fe[1]);
        const char *dirs[2] = {run_a, run_b};
        rn_render_opts base, o; /* the scene and path all three runs share */
        rn_host h = app_host();
        rn_render_defaults(&base);
        base.scene = scene;
        base.env = env;
        base.camera = camera;
        base.fps = fps;
        base.frames = frames;
        base.size[0] = size[0];
        base.size[1] = size[1];
        for (int i = 0; i < 2 && res == TND_OK; i++) {
            o = base;
            o.frontend = fe[i];
            o.capture = true;
            o.denoiser = denoiser;
            o.out = dirs[i];
            if (rn_render_nested(&o, false, &h) != TND_OK)
                res = tnd_fail(TND_ERR_IO, "compare: tandem render --out %s failed", dirs[i]);
        }
        if (reference) {
            snprintf(refdir, sizeof refdir, "%s", reference);
        } else if (res == TND_OK) {
            snprintf(refdir, sizeof refdir, "%s/reference", out);
            o = base;
            o.spp = spp;
            o.out = refdir;
            if (rn_render_nested(&o, true, &h) != TND_OK)
                res = tnd_fail(TND_ERR_IO, "compare: tandem reference --out %s failed", refdir);
        }
        snprintf(report_dir, sizeof report_dir, "%s/report", out);
        reference = refdir;
        report = report_dir;
        if (res != TND_OK)
            return app_report("compare", res);
    } else {
        snprintf(run_a, sizeof run_a, "%s", pos[0]);
        snprintf(run_b, sizeof run_b, "%s", pos[1]);
    }
    char da[1100], db[1100];
    frames_dir(run_a, da, sizeof da);
    frames_dir(run_b, db, sizeof db);
    cJSON *root = cJSON_CreateObject();
    int status = agreement(da, db, min_gbuffer, min_signal, json, root, &res);
    if (res != TND_OK) {
        cJSON_Delete(root);
        return app_report("compare", res);
    }
    if (reference) {
        rn_eval e = {0};
        snprintf(e.ref, sizeof e.ref, "%s", reference);
        res = rn_eval_add(&e, scene ? fe[0] : run_a, run_a, RN_SERIES_OUTPUT);
        if (res == TND_OK)
            res = rn_eval_add(&e, scene ? fe[1] : run_b, run_b, RN_SERIES_OUTPUT);
        if (res == TND_OK)
            res = rn_eval_run(&e);
        cJSON *ev = cJSON_AddArrayToObject(root, "eval");
        for (uint32_t i = 0; res == TND_OK && i < e.nseries; i++) {
            const ev_summary *s = &e.series[i].summary;
            cJSON *o = cJSON_CreateObject();
            cJSON_AddStringToObject(o, "name", e.series[i].name);
            rn_metrics_json(o, s);
            cJSON_AddItemToArray(ev, o);
            if (!json) {
                printf("  %s against %s:", e.series[i].name, reference);
                for (uint32_t k = 0; k < ev_metric_count(); k++) {
                    const ev_metric *em = ev_metric_at(k);
                    if (em->summarised)
                        printf("%s %s %.4g", k ? "," : "", em->head, ev_metric_summary(em, s));
                }
                printf("\n");
            }
        }
        if (res == TND_OK && report) {
            ev_text html = {0};
            agreement_html(root, min_gbuffer, min_signal, &html);
            char *settings = cJSON_Print(root);
            char title[3200];
            snprintf(title, sizeof title, "Tandem compare: %s and %s against %s", run_a, run_b,
                     reference);
            res = html.failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "compare: out of memory")
                              : rn_eval_report(&e, report, title, settings, html.s);
            free(settings);
            ev_text_free(&html);
            if (res == TND_OK && !json)
                printf("  report: %s/index.html\n", report);
        }
        rn_eval_free(&e);
        if (res != TND_OK) {
            cJSON_Delete(root);
            return app_report("compare", res);
        }
    }
    if (json) {
        char *t = cJSON_Print(root);
        printf("%s\n", t);
        free(t);
    }
    cJSON_Delete(root);
    return status;
}
