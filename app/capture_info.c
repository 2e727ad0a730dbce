/* app/capture_info.c: `tandem info --capture DIR [--map M]`: what the files hold, which contract entries come from
 * which channels or defaults, value ranges and non-finite counts, and a motion check (each frame
 * reprojected onto the previous one through its motion vectors, as the back-end does, also with
 * either axis negated, so that a wrong sign shows at once).
 * Entry point: app_capture_info. */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* The motion check of frame b against a (the previous), for the four sign variants of the
 * motion's x and y (signs[s]) in one pass: agree[s] counts frame b's surface pixels whose moved
 * position lands on a surface of frame a with the same albedo (within 0.1 of the larger value,
 * + 0.02) and depth (within 5%, after the motion's depth change): what the back-end's
 * reprojection needs. Returns the surface pixels tested. */
static uint64_t motion_agreement(const tnd_frame *a, const tnd_frame *b, const float signs[4][2],
                                 double agree[4])
{
    uint32_t W = b->width, H = b->height;
    const float *da = tnd_frame_f(a, TND_CT_DEPTH), *db = tnd_frame_f(b, TND_CT_DEPTH);
    const float *aa = tnd_frame_f(a, TND_CT_ALBEDO), *ab = tnd_frame_f(b, TND_CT_ALBEDO);
    const float *mo = tnd_frame_f(b, TND_CT_MOTION);
    uint64_t n = 0;
    for (uint32_t y = 0; y < H; y++)
        for (uint32_t x = 0; x < W; x++) {
            size_t p = (size_t)y * W + x;
            if (!(db[p] < (float)TND_DEPTH_MISS))
                continue;
            n++;
            for (int s = 0; s < 4; s++) {
                float qx = (float)x + signs[s][0] * mo[3 * p];
                float qy = (float)y + signs[s][1] * mo[3 * p + 1];
                long ix = lroundf(qx), iy = lroundf(qy);
                if (!isfinite(qx) || !isfinite(qy) || ix < 0 || iy < 0 || ix >= (long)W ||
                    iy >= (long)H)
                    continue;
                size_t q = (size_t)iy * W + (size_t)ix;
                if (!(da[q] < (float)TND_DEPTH_MISS))
                    continue;
                bool same = fabsf(da[q] - (db[p] + mo[3 * p + 2])) <= 0.05f * db[p];
                for (int k = 0; k < 3; k++)
                    same &= fabsf(aa[3 * q + k] - ab[3 * p + k]) <=
                            0.1f * fmaxf(aa[3 * q + k], ab[3 * p + k]) + 0.02f;
                agree[s] += same;
            }
        }
    return n;
}

int app_capture_info(const char *captures, const char *map_path, bool json)
{
    char dir[1100], path[2300];
    char **names = NULL;
    size_t n = 0;
    tnd_capture_map *map = NULL;
    tnd_frame cur = {0}, prev = {0};
    tnd_exr_file x = {0};
    cJSON *o = NULL;
    int status = APP_EXIT_FAIL;
    tnd_result res = TND_OK;
    if (map_path && (res = tnd_capture_map_load(map_path, &map)) != TND_OK)
        return app_report("info", res);
    if ((res = (tnd_capture_dir(captures, dir, sizeof dir), tnd_capture_map_list(map, dir, &names, &n))) != TND_OK)
        goto fail;
    snprintf(path, sizeof path, "%s/%s", dir, names[0]);
    TND_TRY(tnd_exr_read(path, &x));
    /* every frame: value ranges, non-finite counts (the reader refuses those, naming them), the
     * motion check against the previous frame */
    double lo[TND_CT_COUNT], hi[TND_CT_COUNT];
    for (int e = 0; e < TND_CT_COUNT; e++)
        lo[e] = INFINITY, hi[e] = -INFINITY;
    const float signs[4][2] = {{1, 1}, {-1, 1}, {1, -1}, {-1, -1}};
    double agree[4] = {0, 0, 0, 0};
    uint64_t tested = 0;
    bool present[TND_CT_COUNT] = {false};
    size_t fell_back[TND_CT_COUNT] = {0}; /* frames where an optional entry was absent */
    uint64_t nonfinite[TND_CT_COUNT] = {0};
    size_t grad_frames = 0, grad_files = 0; /* rendered with A-SVGF; with a samples file */
    for (size_t i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        tnd_frame_destroy(&prev);
        prev = cur;
        memset(&cur, 0, sizeof cur);
        TND_TRY(map ? tnd_capture_read_mapped(path, map, i ? &prev.camera : NULL, &cur)
                    : tnd_capture_read(path, &cur));
        if (i > 0 && (cur.width != prev.width || cur.height != prev.height)) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "capture: %s: %ux%u, frame 0 is %ux%u", path,
                           cur.width, cur.height, prev.width, prev.height);
            goto fail;
        }
        if (i > 0)
            TND_TRY(tnd_capture_check_entries(&prev, &cur, path));
        if (cur.gradients) {
            char gp[2400];
            struct stat gst;
            tnd_capture_gradients_path(path, gp, sizeof gp);
            grad_frames++;
            grad_files += stat(gp, &gst) == 0;
        }
        size_t npx = (size_t)cur.width * cur.height;
        for (int e = 0; e < TND_CT_COUNT; e++) {
            present[e] |= cur.present[e];
            fell_back[e] += cur.fallback[e];
            nonfinite[e] += cur.nonfinite[e];
            const tnd_ct_info *ci = tnd_ct_get((tnd_ct)e);
            if (!cur.present[e] || ci->kind != TND_CT_FLOAT)
                continue;
            const float *v = cur.data[e];
            for (size_t q = 0; q < npx * ci->comps; q++) {
                if (e == TND_CT_DEPTH && !(v[q] < (float)TND_DEPTH_MISS))
                    continue; /* (misses) */
                lo[e] = fmin(lo[e], v[q]), hi[e] = fmax(hi[e], v[q]);
            }
        }
        if (i > 0)
            tested += motion_agreement(&prev, &cur, signs, agree);
    }
    int best = 0;
    for (int s = 1; s < 4; s++)
        best = agree[s] > agree[best] ? s : best;
    const char *sign_names[4] = {"as given", "x negated", "y negated", "x and y negated"};
    if (json)
        o = cJSON_CreateObject();
    if (o) {
        cJSON_AddStringToObject(o, "capture", dir);
        cJSON_AddNumberToObject(o, "frames", (double)n);
        cJSON_AddNumberToObject(o, "width", cur.width);
        cJSON_AddNumberToObject(o, "height", cur.height);
        cJSON_AddStringToObject(o, "mapping", map ? tnd_capture_map_name(map) : "");
        cJSON_AddNumberToObject(o, "asvgf_frames", (double)grad_frames);
        cJSON_AddNumberToObject(o, "gradient_sample_files", (double)grad_files);
    } else {
        printf("capture %s: %zu frames (%s .. %s), %ux%u\n", dir, n, names[0], names[n - 1],
               cur.width, cur.height);
        printf("  %u channels in %s:", x.channel_count, names[0]);
        for (uint32_t c = 0; c < x.channel_count; c++)
            printf("%s %s", c ? "," : "", x.channels[c].name);
        printf("\n  read %s\n", map ? tnd_capture_map_name(map) : "as a Tandem capture");
        if (grad_frames)
            printf("  rendered with A-SVGF: %zu frames, %zu with gradient samples beside them "
                   "(FRAME.gradients.exr; the first has no history): denoise replays asvgf\n",
                   grad_frames, grad_files);
        else
            printf("  no gradient samples: denoise runs asvgf as svgf\n");
        printf("  %-11s %-8s %-12s %-12s %-10s %s\n", "entry", "how", "min", "max", "non-finite",
               "from");
    }
    cJSON *entries = o ? cJSON_AddObjectToObject(o, "entries") : NULL;
    for (int e = 0; e < TND_CT_COUNT; e++) {
        const tnd_ct_info *ci = tnd_ct_get((tnd_ct)e);
        char src[512] = "";
        const char *how;
        if (map && fell_back[e]) { /* an optional entry the files lack: what the mapping says */
            how = "fallback";
            snprintf(src, sizeof src, "absent from %zu of %zu frames: %s", fell_back[e], n,
                     tnd_capture_map_fallback(map, (tnd_ct)e));
        } else if (map) {
            how = tnd_capture_map_source(map, (tnd_ct)e, src, sizeof src) ? "fed"
                  : present[e]                                              ? "derived"
                                                                            : "default";
        } else {
            char ch[300];
            tnd_ct_exr_name((tnd_ct)e, 0, ch, sizeof ch);
            how = tnd_exr_find(&x, ch) ? "read" : present[e] ? "derived" : "default";
            if (tnd_exr_find(&x, ch))
                snprintf(src, sizeof src, "%s.*", ci->exr_layer);
        }
        if (!strcmp(how, "derived"))
            snprintf(src, sizeof src, "%s",
                     e == TND_CT_VIS_ID       ? "from depth: surfaces where it is a hit"
                     : e == TND_CT_GEO_NORMAL ? "the shading normal"
                     : e == TND_CT_POSITION   ? "depth along the camera's rays"
                                              : "");
        else if (!strcmp(how, "default"))
            snprintf(src, sizeof src, "%s%s",
                     ci->default_value == 4294967295.0 ? "0xFFFFFFFF" : "",
                     e == TND_CT_RNG ? " (no random-number keys)" : "");
        bool ranged = present[e] && ci->kind == TND_CT_FLOAT && lo[e] <= hi[e];
        if (entries) {
            cJSON *je = cJSON_AddObjectToObject(entries, ci->name);
            cJSON_AddStringToObject(je, "how", how);
            cJSON_AddStringToObject(je, "from", src);
            if (ranged) {
                cJSON_AddNumberToObject(je, "min", lo[e]);
                cJSON_AddNumberToObject(je, "max", hi[e]);
            }
            cJSON_AddNumberToObject(je, "nonfinite_replaced", (double)nonfinite[e]);
        } else {
            char a[32] = "-", b[32] = "-";
            if (ranged)
                snprintf(a, sizeof a, "%.4g", lo[e]), snprintf(b, sizeof b, "%.4g", hi[e]);
            printf("  %-11s %-8s %-12s %-12s %-10llu %s\n", ci->name, how, a, b,
                   (unsigned long long)nonfinite[e], src);
        }
    }
    double frac[4];
    for (int s = 0; s < 4; s++)
        frac[s] = tested ? agree[s] / (double)tested : 0.0;
    if (o) {
        cJSON *mc = cJSON_AddObjectToObject(o, "motion_check");
        cJSON_AddNumberToObject(mc, "pixels", (double)tested);
        for (int s = 0; s < 4; s++)
            cJSON_AddNumberToObject(mc, sign_names[s], frac[s]);
        cJSON_AddStringToObject(mc, "best", sign_names[best]);
        char *txt = cJSON_Print(o);
        printf("%s\n", txt);
        free(txt);
    } else if (n > 1) {
        printf("  motion check (%llu surface pixels of frames 1..%zu reprojected onto the frame "
               "before: the same albedo and depth): %.1f%% as given; %.1f%% with x negated, "
               "%.1f%% with y negated, %.1f%% with both\n",
               (unsigned long long)tested, n - 1, 100 * frac[0], 100 * frac[1], 100 * frac[2],
               100 * frac[3]);
    } else {
        printf("  motion check: needs two frames\n");
    }
    if (n > 1 && best != 0 && frac[best] > frac[0] + 0.05)
        fprintf(stderr,
                "tandem: info: warning: %s: the motion vectors agree with the depth and albedo of "
                "the frame before far better %s (%.1f%% against %.1f%%): check the mapping's "
                "motion scale\n",
                dir, sign_names[best], 100 * frac[best], 100 * frac[0]);
    status = APP_EXIT_OK;
fail:
    if (res != TND_OK)
        status = app_report("info", res);
    cJSON_Delete(o);
    tnd_exr_close(&x);
    tnd_frame_destroy(&cur);
    tnd_frame_destroy(&prev);
    tnd_capture_map_destroy(map);
    tnd_capture_list_free(names, n);
    return status;
}
