/* run/rn_extremes.c: `tandem bench --extremes --out DIR`: the numerical stability report. The
 * `extremes` scene (or --scene) through every mode (every live front-end and every denoiser of
 * the registries, contract float32 / packed); per run and per buffer (the contract's entries from the
 * captures, the back-end's buffers from --dump all, the output): NaN/Inf counts, values the
 * packed formats clamp (half above 65504, RGBE 9-9-9-5 above 130816) and flush (non-zero below
 * half's 2^-24 or RGBE's 2^-24 step), and the largest magnitude; then the error of the packed
 * contract against float32 (entries and final frames). DIR/extremes.json, DIR/report/index.html;
 * the count of NaN and Inf found (the command line's exit 1 when any). Entry point: rn_extremes. */
#include "run/rn_internal.h"
#include "shaders/encoding.h"

#include <cjson/cJSON.h>
#include <dirent.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct buf_stats {
    char name[64];
    uint64_t values, nonfinite, over_half, over_rgbe, tiny;
    double max_abs;
} buf_stats;

typedef struct run_stats {
    const char *frontend, *denoiser, *precision;
    char dir[1100];
    buf_stats *bufs;
    uint32_t nbufs, cap;
    uint64_t nonfinite; /* all buffers and outputs */
} run_stats;

static buf_stats *stats_for(run_stats *r, const char *name)
{
    for (uint32_t i = 0; i < r->nbufs; i++)
        if (strcmp(r->bufs[i].name, name) == 0)
            return &r->bufs[i];
    if (r->nbufs == r->cap) {
        uint32_t cap = r->cap ? 2 * r->cap : 32;
        buf_stats *b = realloc(r->bufs, cap * sizeof *b);
        if (!b)
            return NULL;
        r->bufs = b;
        r->cap = cap;
    }
    buf_stats *b = &r->bufs[r->nbufs++];
    memset(b, 0, sizeof *b);
    snprintf(b->name, sizeof b->name, "%s", name);
    return b;
}

/* every float channel of an EXR, grouped by layer ("albedo" of "albedo.R"; "output" for R, G, B),
 * under `prefix` */
static tnd_result scan_exr(run_stats *r, const char *path, const char *prefix)
{
    tnd_exr_file f;
    tnd_result res = tnd_exr_read(path, &f);
    if (res != TND_OK)
        return res;
    size_t n = (size_t)f.width * f.height;
    const double tiny = ldexp(1.0, -24); /* half's smallest subnormal; RGBE's step at 2^-BIAS */
    for (uint32_t c = 0; c < f.channel_count; c++) {
        const tnd_exr_channel *ch = &f.channels[c];
        if (ch->type == TND_EXR_UINT)
            continue;
        char name[64];
        const char *dot = strrchr(ch->name, '.');
        if (dot)
            snprintf(name, sizeof name, "%s%.*s", prefix, (int)(dot - ch->name), ch->name);
        else
            snprintf(name, sizeof name, "%s", prefix[0] ? prefix : "output");
        size_t len = strlen(name);
        if (len && name[len - 1] == '.')
            name[len - 1] = 0;
        /* contract entries: only what their packed format would clamp or flush counts (a float32
         * entry such as depth or position is never packed) */
        const tnd_ct_info *ci = strncmp(name, "contract.", 9) == 0 ? tnd_ct_find(name + 9) : NULL;
        bool can_half = !ci || ci->pack == TND_PACK_HALF, can_rgbe = !ci || ci->pack == TND_PACK_RGBE;
        bool can_flush = !ci || ci->pack != TND_PACK_F32;
        buf_stats *b = stats_for(r, name);
        if (!b) {
            tnd_exr_close(&f);
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        }
        const float *v = ch->data;
        for (size_t q = 0; q < n; q++) {
            double x = v[q];
            b->values++;
            if (!isfinite(x)) {
                b->nonfinite++;
                r->nonfinite++;
                continue;
            }
            double a = fabs(x);
            b->max_abs = fmax(b->max_abs, a);
            b->over_half += can_half && a > TND_HALF_MAX;
            b->over_rgbe += can_rgbe && a > TND_RGBE_MAX;
            b->tiny += can_flush && a > 0 && a < tiny;
        }
    }
    tnd_exr_close(&f);
    return TND_OK;
}

static tnd_result scan_dir(run_stats *r, const char *dir, const char *prefix, bool strip_frame)
{
    DIR *d = opendir(dir);
    if (!d)
        return tnd_fail(TND_ERR_IO, "bench: %s: cannot open directory", dir);
    tnd_result res = TND_OK;
    for (struct dirent *e; res == TND_OK && (e = readdir(d));) {
        size_t len = strlen(e->d_name);
        if (len < 5 || strcmp(e->d_name + len - 4, ".exr") != 0)
            continue;
        char path[1400], pre[64];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (strip_frame) { /* dump files: NAME_NNNN.exr -> "NAME" */
            const char *us = strrchr(e->d_name, '_');
            snprintf(pre, sizeof pre, "%s%.*s.", prefix, us ? (int)(us - e->d_name) : (int)len - 4,
                     e->d_name);
        } else {
            snprintf(pre, sizeof pre, "%s", prefix);
        }
        res = scan_exr(r, path, pre);
    }
    closedir(d);
    return res;
}

/* packed vs float32: per contract entry, the largest and mean relative error |p - f| / max(|f|,
 * 1e-3) over the captures; and relMSE of the final frames */
static tnd_result packed_error(const char *f32, const char *packed, cJSON *out, ev_text *html)
{
    tnd_result res = TND_OK;
    uint32_t *frames = NULL, n = 0;
    char a[1200], b[1200];
    snprintf(a, sizeof a, "%s/capture", f32);
    TND_TRY(rn_list_frames(a, &frames, &n));
    double max_rel[TND_CT_COUNT] = {0}, sum_rel[TND_CT_COUNT] = {0};
    uint64_t cnt[TND_CT_COUNT] = {0};
    double relmse = 0;
    for (uint32_t k = 0; k < n; k++) {
        tnd_frame fa = {0}, fb = {0};
        snprintf(a, sizeof a, "%s/capture/frame_%04u.exr", f32, frames[k]);
        snprintf(b, sizeof b, "%s/capture/frame_%04u.exr", packed, frames[k]);
        res = tnd_capture_read(a, &fa);
        if (res == TND_OK)
            res = tnd_capture_read(b, &fb);
        for (int e = 0; res == TND_OK && e < TND_CT_COUNT; e++) {
            const tnd_ct_info *ci = tnd_ct_get((tnd_ct)e);
            if (ci->kind != TND_CT_FLOAT || !fa.present[e] || !fb.present[e])
                continue;
            size_t m = (size_t)fa.width * fa.height * ci->comps;
            const float *x = tnd_frame_f(&fa, (tnd_ct)e), *y = tnd_frame_f(&fb, (tnd_ct)e);
            for (size_t i = 0; i < m; i++) {
                double rel = fabs((double)y[i] - x[i]) / fmax(fabs((double)x[i]), 1e-3);
                if (!isfinite(rel))
                    continue;
                max_rel[e] = fmax(max_rel[e], rel);
                sum_rel[e] += rel;
                cnt[e]++;
            }
        }
        tnd_frame_destroy(&fa);
        tnd_frame_destroy(&fb);
        ev_image ia = {0}, ib = {0};
        snprintf(a, sizeof a, "%s/frame_%04u.exr", f32, frames[k]);
        snprintf(b, sizeof b, "%s/frame_%04u.exr", packed, frames[k]);
        if (res == TND_OK)
            res = ev_image_read_exr(a, &ia);
        if (res == TND_OK)
            res = ev_image_read_exr(b, &ib);
        if (res == TND_OK) {
            ev_image_sanitize(&ia);
            ev_image_sanitize(&ib);
            relmse += ev_relmse(ib.rgb, ia.rgb, (size_t)ia.width * ia.height * 3) / n;
        }
        ev_image_free(&ia);
        ev_image_free(&ib);
        if (res != TND_OK)
            goto fail;
    }
    cJSON *ent = cJSON_AddObjectToObject(out, "entries");
    ev_text_add(html, "<table><tr><th>entry</th><th>largest relative error</th><th>mean</th></tr>\n");
    for (int e = 0; e < TND_CT_COUNT; e++) {
        if (!cnt[e])
            continue;
        const char *name = tnd_ct_get((tnd_ct)e)->name;
        cJSON *o = cJSON_AddObjectToObject(ent, name);
        cJSON_AddNumberToObject(o, "max_relative", max_rel[e]);
        cJSON_AddNumberToObject(o, "mean_relative", sum_rel[e] / cnt[e]);
        ev_text_add(html, "<tr><td>%s</td><td>%.3g</td><td>%.3g</td></tr>\n", name, max_rel[e],
                    sum_rel[e] / cnt[e]);
    }
    ev_text_add(html, "</table>\n<p>Final frames, packed against float32: relMSE %.3g.</p>\n", relmse);
    cJSON_AddNumberToObject(out, "frames_relmse", relmse);
fail:
    free(frames);
    return res;
}

tnd_result rn_extremes(const char *scene, const char *out, const unsigned size[2],
                       unsigned frames, const rn_host *h, ev_text *summary, uint64_t *nonfinite)
{
    /* every live front-end of the registry, every registered denoiser, both precisions */
    static const char *const precs[2] = {"float32", "packed"};
    enum { MAX_RUNS = 128 };
    const char *fes[16];
    uint32_t nfe = 0, ndn = pl_denoiser_count();
    for (uint32_t i = 0; pl_frontend_name_at(i) && nfe < 16; i++)
        if (pl_frontend_live(pl_frontend_name_at(i)))
            fes[nfe++] = pl_frontend_name_at(i);
    const int nruns = (int)(nfe * ndn * 2 < MAX_RUNS ? nfe * ndn * 2 : MAX_RUNS);
    run_stats runs[MAX_RUNS];
    memset(runs, 0, sizeof runs);
    tnd_result res = TND_OK;
    cJSON *root = cJSON_CreateObject();
    ev_text html = {0};
    uint64_t total_bad = 0;
    *nonfinite = 0;
    if (!out || strlen(out) > 900) {
        cJSON_Delete(root);
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--extremes needs --out DIR (a short path)");
    }
    TND_TRY(tnd_mkdirs(out));
    rn_progress bar;
    rn_progress_begin(&bar, h, "extremes", (uint64_t)nruns);
    for (int i = 0; i < nruns; i++) {
        run_stats *r = &runs[i];
        const pl_denoiser_info *dn = pl_denoiser_at((uint32_t)(i / 2) % ndn);
        r->frontend = fes[(uint32_t)i / (2 * ndn)];
        r->denoiser = dn->name;
        r->precision = precs[i % 2];
        snprintf(r->dir, sizeof r->dir, "%s/runs/%s_%s_%s", out, r->frontend, r->denoiser,
                 r->precision);
        /* the back-end's buffers where it runs on the GPU (a host front-end with a denoiser that
         * does not filter composites on the CPU) */
        bool gpu_backend = ((pl_frontend_caps_of(r->frontend) & PL_CAP_GPU_CONTRACT) ||
                            (dn->caps & PL_DN_FILTERS)) && (dn->caps & PL_DN_DUMPS);
        rn_render_opts ro;
        rn_render_defaults(&ro);
        ro.scene = scene;
        ro.frames = frames;
        ro.size[0] = size[0];
        ro.size[1] = size[1];
        ro.frontend = r->frontend;
        ro.denoiser = r->denoiser;
        ro.precision = r->precision;
        ro.capture = true;
        ro.quiet = true;
        ro.out = r->dir;
        ro.dump = gpu_backend ? "all" : NULL;
        if (rn_render_nested(&ro, false, h) != TND_OK) {
            res = tnd_fail(TND_ERR_IO, "bench: extremes run %s failed", r->dir);
            rn_progress_end(&bar);
            goto fail;
        }
        char d[1300];
        snprintf(d, sizeof d, "%s/capture", r->dir);
        TND_TRY(scan_dir(r, d, "contract.", false));
        if (gpu_backend) {
            snprintf(d, sizeof d, "%s/dump", r->dir);
            TND_TRY(scan_dir(r, d, "denoise.", true));
        }
        /* the frames: linear output after TAA */
        uint32_t *list = NULL, nl = 0;
        TND_TRY(rn_list_frames(r->dir, &list, &nl));
        for (uint32_t k = 0; k < nl && res == TND_OK; k++) {
            snprintf(d, sizeof d, "%s/frame_%04u.exr", r->dir, list[k]);
            res = scan_exr(r, d, "");
        }
        free(list);
        if (res != TND_OK)
            goto fail;
        rn_progress_step(&bar, (uint64_t)i + 1);
    }
    rn_progress_end(&bar);
    /* report */
    cJSON_AddStringToObject(root, "scene", scene);
    cJSON_AddNumberToObject(root, "width", size[0]);
    cJSON_AddNumberToObject(root, "height", size[1]);
    cJSON_AddNumberToObject(root, "frames", frames);
    cJSON *ra = cJSON_AddArrayToObject(root, "runs");
    ev_text_add(&html, "<p>Per buffer, over all frames: values, NaN/Inf, values the packed formats "
                       "would clamp (half above 65504, RGBE above 130816) or flush (non-zero below "
                       "2^-24), and the largest magnitude. For contract entries only the entry's own "
                       "packed format counts (float32 entries are never packed); for the back-end's "
                       "buffers and the output both are shown, as what storing them packed would do. <code>contract.*</code>: the captures; "
                       "<code>denoise.*</code>: the back-end's buffers (<code>--dump all</code>); "
                       "<code>output</code>: the frames after TAA.</p>\n");
    for (int i = 0; i < nruns; i++) {
        run_stats *r = &runs[i];
        total_bad += r->nonfinite;
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToArray(ra, o);
        cJSON_AddStringToObject(o, "frontend", r->frontend);
        cJSON_AddStringToObject(o, "denoiser", r->denoiser);
        cJSON_AddStringToObject(o, "precision", r->precision);
        cJSON_AddNumberToObject(o, "nonfinite", (double)r->nonfinite);
        cJSON *bo = cJSON_AddObjectToObject(o, "buffers");
        ev_text_add(&html, "<h2>%s + %s, %s contract: %llu NaN/Inf</h2>\n<table><tr><th>buffer</th>"
                           "<th>values</th><th>NaN/Inf</th><th>&gt; half max</th><th>&gt; RGBE max"
                           "</th><th>flushed</th><th>max |v|</th></tr>\n",
                    r->frontend, r->denoiser, r->precision, (unsigned long long)r->nonfinite);
        for (uint32_t b = 0; b < r->nbufs; b++) {
            const buf_stats *s = &r->bufs[b];
            cJSON *x = cJSON_AddObjectToObject(bo, s->name);
            cJSON_AddNumberToObject(x, "values", (double)s->values);
            cJSON_AddNumberToObject(x, "nonfinite", (double)s->nonfinite);
            cJSON_AddNumberToObject(x, "over_half_max", (double)s->over_half);
            cJSON_AddNumberToObject(x, "over_rgbe_max", (double)s->over_rgbe);
            cJSON_AddNumberToObject(x, "flushed", (double)s->tiny);
            cJSON_AddNumberToObject(x, "max_abs", s->max_abs);
            ev_text_add(&html, "<tr><td>%s</td><td>%llu</td><td>%llu</td><td>%llu</td><td>%llu</td>"
                               "<td>%llu</td><td>%.4g</td></tr>\n",
                        s->name, (unsigned long long)s->values, (unsigned long long)s->nonfinite,
                        (unsigned long long)s->over_half, (unsigned long long)s->over_rgbe,
                        (unsigned long long)s->tiny, s->max_abs);
        }
        ev_text_add(&html, "</table>\n");
    }
    cJSON *pe = cJSON_AddArrayToObject(root, "packed_vs_float32");
    ev_text_add(&html, "<h2>Packed against float32 contracts</h2>\n");
    for (int i = 0; i < nruns && res == TND_OK; i += 2) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToArray(pe, o);
        cJSON_AddStringToObject(o, "frontend", runs[i].frontend);
        cJSON_AddStringToObject(o, "denoiser", runs[i].denoiser);
        ev_text_add(&html, "<h3>%s + %s</h3>\n", runs[i].frontend, runs[i].denoiser);
        res = packed_error(runs[i].dir, runs[i + 1].dir, o, &html);
    }
    if (res != TND_OK)
        goto fail;
    cJSON_AddNumberToObject(root, "nonfinite", (double)total_bad);
    char *txt = cJSON_Print(root);
    char path[1000], rdir[1000];
    snprintf(path, sizeof path, "%s/extremes.json", out);
    res = txt ? tnd_file_write_atomic(path, txt, strlen(txt))
              : tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
    snprintf(rdir, sizeof rdir, "%s/report", out);
    if (res == TND_OK)
        res = tnd_mkdirs(rdir);
    if (res == TND_OK) {
        char title[1100];
        snprintf(title, sizeof title, "Tandem numerical stability: %s", scene);
        res = html.failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory")
                          : ev_report_write(&(ev_report){.dir = rdir, .title = title, .html = html.s});
    }
    free(txt);
    if (res == TND_OK) {
        ev_text_add(summary, "extremes: %s at %ux%u, %u frames, 12 modes: %llu NaN/Inf%s\n",
                    scene, size[0], size[1], frames, (unsigned long long)total_bad,
                    total_bad ? " (see the report)" : "");
        for (int i = 0; i < nruns; i++) {
            uint64_t oh = 0, orgbe = 0;
            for (uint32_t b = 0; b < runs[i].nbufs; b++) {
                oh += runs[i].bufs[b].over_half;
                orgbe += runs[i].bufs[b].over_rgbe;
            }
            ev_text_add(summary,
                        "  %-6s %-5s %-7s NaN/Inf %llu, above half max %llu, above RGBE max "
                        "%llu\n",
                        runs[i].frontend, runs[i].denoiser, runs[i].precision,
                        (unsigned long long)runs[i].nonfinite, (unsigned long long)oh,
                        (unsigned long long)orgbe);
        }
        ev_text_add(summary, "  -> %s, %s/index.html\n", path, rdir);
        *nonfinite = total_bad;
    }
fail:
    for (int i = 0; i < nruns; i++)
        free(runs[i].bufs);
    cJSON_Delete(root);
    ev_text_free(&html);
    return res;
}
