/* app/cmd_compare.c: `tandem compare A B`: the agreement of two captures (the same frames from
 * two front-ends, or any two Tandem capture directories), per contract entry. G-buffer entries
 * must agree to float precision on --min-gbuffer of the pixels (the rest lie on triangle edges);
 * the noisy signals on --min-signal of the pixels that see the same surface (same path traced).
 * Exit 1 past those floors. */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static const app_cmd compare_cmd = {
    "compare",
    "Compare two capture directories (DIR or DIR/capture with frame_NNNN.exr) entry by entry:\n"
    "the fraction of pixels that agree, per frame and channel; exit 1 below the floors.",
    "A B [--min-gbuffer F] [--min-signal F] [--json]", NULL};

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

int cmd_compare(int argc, char **argv)
{
    double min_gbuffer = 0.99, min_signal = 0.9;
    bool json = false;
    const app_opt opts[] = {
        {"min-gbuffer", APP_OPT_FLOAT, &min_gbuffer, "F",
         "G-buffer entries: fraction of pixels that must agree (default 0.99)"},
        {"min-signal", APP_OPT_FLOAT, &min_signal, "F",
         "hf, lf, spec: fraction of same-surface pixels that must agree (default 0.9)"},
        {"json", APP_OPT_FLAG, &json, NULL, "print the figures as JSON"},
        {0},
    };
    const char *pos[2];
    int npos;
    int rc = app_parse(&compare_cmd, opts, argc, argv, pos, 2, &npos);
    if (rc >= 0)
        return rc;
    if (npos != 2) {
        fprintf(stderr, "tandem compare: two directories expected (see tandem compare --help)\n");
        return APP_EXIT_USAGE;
    }
    char da[1100], db[1100];
    frames_dir(pos[0], da, sizeof da);
    frames_dir(pos[1], db, sizeof db);
    DIR *d = opendir(da);
    if (!d) {
        fprintf(stderr, "tandem: compare: %s: cannot open directory\n", da);
        return APP_EXIT_FAIL;
    }
    char names[4096][32];
    int nf = 0;
    for (struct dirent *e; (e = readdir(d)) && nf < 4096;) {
        unsigned f;
        char tail[8];
        if (sscanf(e->d_name, "frame_%u.ex%1s", &f, tail) == 2 && strlen(e->d_name) < 32)
            snprintf(names[nf++], sizeof names[0], "%.31s", e->d_name);
    }
    closedir(d);
    qsort(names, (size_t)nf, sizeof names[0], (int (*)(const void *, const void *))strcmp);
    int status = APP_EXIT_OK, compared = 0;
    double worst[TND_CT_COUNT];
    for (int i = 0; i < TND_CT_COUNT; i++)
        worst[i] = 1.0;
    cJSON *root = cJSON_CreateObject(), *frames = cJSON_AddArrayToObject(root, "frames");
    for (int k = 0; k < nf; k++) {
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
            cJSON_Delete(root);
            return app_report("compare", r);
        }
        size_t n = (size_t)a.width * a.height;
        cJSON *fo = cJSON_CreateObject();
        cJSON_AddStringToObject(fo, "frame", names[k]);
        if (!json)
            printf("%s (%ux%u):\n", names[k], a.width, a.height);
        size_t same_surface = 0;
        for (size_t q = 0; q < n; q++)
            same_surface += memcmp(tnd_frame_u(&a, TND_CT_VIS_ID) + 2 * q,
                                   tnd_frame_u(&b, TND_CT_VIS_ID) + 2 * q, 8) == 0;
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
                printf("  %-11s %7.2f%% of %s%s\n", ci->name, 100.0 * frac,
                       sig ? "same-surface pixels" : "pixels", pass ? "" : "  <- below the floor");
            cJSON_AddNumberToObject(fo, ci->name, frac);
        }
        if (!json)
            printf("  (%.2f%% of the pixels see the same surface)\n", 100.0 * same_surface / n);
        cJSON_AddNumberToObject(fo, "same_surface", (double)same_surface / n);
        cJSON_AddItemToArray(frames, fo);
        compared++;
        tnd_frame_destroy(&a);
        tnd_frame_destroy(&b);
    }
    if (compared == 0) {
        cJSON_Delete(root);
        fprintf(stderr, "tandem: compare: no frame_NNNN.exr in both %s and %s\n", da, db);
        return APP_EXIT_FAIL;
    }
    cJSON *w = cJSON_AddObjectToObject(root, "worst");
    for (int e = 0; e < TND_CT_COUNT; e++)
        if (worst[e] < 1.0 || 1)
            cJSON_AddNumberToObject(w, tnd_ct_get((tnd_ct)e)->name, worst[e]);
    cJSON_AddBoolToObject(root, "pass", status == APP_EXIT_OK);
    if (json) {
        char *t = cJSON_Print(root);
        printf("%s\n", t);
        free(t);
    } else {
        printf("%d frame%s compared: %s\n", compared, compared == 1 ? "" : "s",
               status == APP_EXIT_OK ? "agree" : "DISAGREE");
    }
    cJSON_Delete(root);
    return status;
}
