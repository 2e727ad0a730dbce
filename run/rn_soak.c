/* run/rn_soak.c: `tandem bench --soak N`: N frames through render's frame loop (run/rn_session.c) for
 * each front-end and denoiser, sampling the process's resident memory (/proc/self/statm), its
 * open file descriptors (/proc/self/fd) and the device memory in use (VK_EXT_memory_budget) as
 * it goes; after a warm-up each must stay flat: what a run of hours would leak shows in a few
 * hundred frames as a slope (docs/reliability.md). The recorder (rn_soak_rec_*) is what
 * `tandem view --soak` samples the viewer's own loop with.
 * Entry points: rn_soak, rn_soak_rec_*. */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>
#include <dirent.h>
#include <malloc.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct soak_sample {
    uint32_t frame;
    double rss_mb, device_mb; /* device_mb < 0: not known (or a CPU device's: the host's) */
    uint32_t fds;
    uint64_t allocations;     /* Tandem's device allocations alive */
    double heap_mb;           /* malloc's bytes in use (every arena; mmapped blocks included) */
} soak_sample;

static double rss_mb(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    unsigned long size = 0, resident = 0;
    if (f) {
        if (fscanf(f, "%lu %lu", &size, &resident) != 2)
            resident = 0;
        fclose(f);
    }
    return (double)resident * (double)sysconf(_SC_PAGESIZE) / (1024.0 * 1024.0);
}

/* What the process's malloc holds in use: RSS that grows while this stays flat is the allocator's
 * arenas or a library's own mappings, not memory the program keeps. */
static double heap_mb(void)
{
    struct mallinfo2 mi = mallinfo2();
    return (double)(mi.uordblks + mi.hblkhd) / (1024.0 * 1024.0);
}

static uint32_t open_fds(void)
{
    DIR *d = opendir("/proc/self/fd");
    uint32_t n = 0;
    if (!d)
        return 0;
    for (struct dirent *e; (e = readdir(d));)
        n += e->d_name[0] != '.';
    closedir(d);
    return n ? n - 1 : 0; /* (the directory's own) */
}

/* Least-squares slope of y over x. */
static double slope(const double *x, const double *y, uint32_t n)
{
    double mx = 0, my = 0, sxx = 0, sxy = 0;
    for (uint32_t i = 0; i < n; i++)
        mx += x[i] / n, my += y[i] / n;
    for (uint32_t i = 0; i < n; i++)
        sxx += (x[i] - mx) * (x[i] - mx), sxy += (x[i] - mx) * (y[i] - my);
    return sxx > 0 ? sxy / sxx : 0.0;
}



enum { SOAK_CAP = 200 }; /* samples kept per run (every frames/CAP-th frame) */

struct rn_soak_rec {
    soak_sample sm[SOAK_CAP];
    uint32_t k, every;
    double t0;
    rn_soak_row row;
};

rn_soak_rec *rn_soak_rec_begin(uint32_t frames)
{
    rn_soak_rec *r = calloc(1, sizeof *r);
    if (!r)
        return NULL;
    r->every = frames / SOAK_CAP + 1;
    r->row.warmup = frames / 10 > 20 ? frames / 10 : 20;
    r->t0 = tnd_now();
    return r;
}

void rn_soak_rec_frame(rn_soak_rec *r, uint32_t f, bool last, const tnd_vk *vk)
{
    if (!r || (f % r->every != 0 && !last) || r->k == SOAK_CAP)
        return;
    uint64_t dev = 0;
    /* (a CPU device's heap is the host's memory, shared with everything: RSS stands) */
    bool known = vk && vk->info.type != VK_PHYSICAL_DEVICE_TYPE_CPU &&
                 tnd_vk_memory_in_use(vk, &dev);
    r->sm[r->k++] = (soak_sample){f, rss_mb(), known ? dev / 1048576.0 : -1, open_fds(),
                                  tnd_vk_live_allocations(), heap_mb()};
}

/* The figures of a run's samples after the warm-up. */
static void judge(const soak_sample *sm, uint32_t k, rn_soak_row *r)
{
    uint32_t b = 0;
    while (b + 1 < k && sm[b].frame < r->warmup)
        b++;
    const soak_sample *base = &sm[b], *end = &sm[k - 1];
    double x[SOAK_CAP], y[SOAK_CAP], hy[SOAK_CAP];
    uint32_t m = 0;
    r->rss_max = 0;
    for (uint32_t i = b; i < k; i++, m++) {
        x[m] = sm[i].frame, y[m] = sm[i].rss_mb * 1024.0, hy[m] = sm[i].heap_mb * 1024.0;
        r->rss_max = sm[i].rss_mb > r->rss_max ? sm[i].rss_mb : r->rss_max;
    }
    r->rss_base = base->rss_mb, r->rss_end = end->rss_mb;
    r->rss_kb_per_frame = m > 2 ? slope(x, y, m) : 0.0;
    r->heap_kb_per_frame = m > 2 ? slope(x, hy, m) : 0.0;
    r->dev_base = base->device_mb, r->dev_end = end->device_mb;
    r->heap_base = base->heap_mb, r->heap_end = end->heap_mb;
    r->fds_base = base->fds, r->fds_end = end->fds;
    r->allocs_base = base->allocations, r->allocs_end = end->allocations;
    /* flat: under 1 KB a frame and 2 MB in all after the warm-up; malloc's bytes in use growing
     * by under 32 bytes a frame (what RSS hides in its pages: the viewer's path grew by 48); the
     * same descriptors, device allocations and device memory */
    r->flat = r->rss_kb_per_frame < 1.0 && r->rss_max - r->rss_base < 2.0 &&
              r->heap_kb_per_frame < 32.0 / 1024.0 &&
              r->fds_end == r->fds_base && r->allocs_end == r->allocs_base &&
              r->dev_end == r->dev_base;
}

bool rn_soak_rec_end(rn_soak_rec *r, uint32_t frames, const char *frontend,
                     const char *denoiser)
{
    r->row.seconds = tnd_now() - r->t0;
    r->row.frames = frames;
    snprintf(r->row.frontend, sizeof r->row.frontend, "%s", frontend);
    snprintf(r->row.denoiser, sizeof r->row.denoiser, "%s", denoiser);
    if (r->k == 0)
        return false;
    judge(r->sm, r->k, &r->row);
    return r->row.flat;
}

void *rn_soak_rec_json(const rn_soak_rec *rec)
{
    const rn_soak_row *r = &rec->row;
    cJSON *e = cJSON_CreateObject();
    cJSON_AddStringToObject(e, "frontend", r->frontend);
    cJSON_AddStringToObject(e, "denoiser", r->denoiser);
    cJSON_AddNumberToObject(e, "frames", r->frames);
    cJSON_AddNumberToObject(e, "warmup", r->warmup);
    cJSON_AddNumberToObject(e, "seconds", r->seconds);
    cJSON_AddNumberToObject(e, "rss_mb_base", r->rss_base);
    cJSON_AddNumberToObject(e, "rss_mb_end", r->rss_end);
    cJSON_AddNumberToObject(e, "rss_mb_max", r->rss_max);
    cJSON_AddNumberToObject(e, "rss_kb_per_frame", r->rss_kb_per_frame);
    cJSON_AddNumberToObject(e, "heap_mb_base", r->heap_base);
    cJSON_AddNumberToObject(e, "heap_mb_end", r->heap_end);
    cJSON_AddNumberToObject(e, "heap_kb_per_frame", r->heap_kb_per_frame);
    cJSON_AddNumberToObject(e, "fds_base", r->fds_base);
    cJSON_AddNumberToObject(e, "fds_end", r->fds_end);
    cJSON_AddNumberToObject(e, "vk_allocations_base", (double)r->allocs_base);
    cJSON_AddNumberToObject(e, "vk_allocations_end", (double)r->allocs_end);
    if (r->dev_base >= 0) {
        cJSON_AddNumberToObject(e, "device_mb_base", r->dev_base);
        cJSON_AddNumberToObject(e, "device_mb_end", r->dev_end);
    }
    cJSON_AddBoolToObject(e, "flat", r->flat);
    cJSON *ss = cJSON_AddArrayToObject(e, "samples");
    for (uint32_t i = 0; i < rec->k; i++) {
        const soak_sample *q = &rec->sm[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "frame", q->frame);
        cJSON_AddNumberToObject(o, "rss_mb", q->rss_mb);
        cJSON_AddNumberToObject(o, "heap_mb", q->heap_mb);
        cJSON_AddNumberToObject(o, "fds", q->fds);
        cJSON_AddNumberToObject(o, "vk_allocations", (double)q->allocations);
        if (q->device_mb >= 0)
            cJSON_AddNumberToObject(o, "device_mb", q->device_mb);
        cJSON_AddItemToArray(ss, o);
    }
    return e;
}

const rn_soak_row *rn_soak_rec_row(const rn_soak_rec *r)
{
    return &r->row;
}

void rn_soak_rec_free(rn_soak_rec *r)
{
    free(r);
}

/* One front-end and denoiser: n frames of render's loop into `rec`. */
static tnd_result soak_one(const rn_render_opts *o, uint32_t n, rn_soak_rec *rec,
                           const rn_host *h)
{
    tnd_result res = TND_OK;
    rn_session *s = NULL;
    float *rgb = malloc((size_t)o->size[0] * o->size[1] * 3 * sizeof *rgb);
    if (!rgb)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "soak: out of memory");
    TND_TRY(rn_session_open(o, false, NULL, h, &s));
    uint32_t f = 0;
    for (; f < n && !rn_interrupted(h); f++) {
        TND_TRY(rn_session_frame(s, f, rgb, NULL, NULL));
        rn_soak_rec_frame(rec, f, f + 1 == n, rn_session_vk(s));
    }
    rn_soak_rec_end(rec, f, o->frontend, rn_session_denoiser(s));
fail:
    rn_session_close(s);
    free(rgb);
    return res;
}

tnd_result rn_soak(const rn_soak_opts *so, const rn_host *h, bool *flat)
{
    tnd_result res = TND_OK;
    const char *fes[2] = {"embree", "vk"};
    uint32_t nfe = 2, ndn = pl_denoiser_count();
    if (so->frontend)
        fes[0] = so->frontend, nfe = 1;
    if (so->denoiser)
        ndn = 1;
    bool all_flat = true;
    rn_host quiet = rn_host_quiet(h);
    for (uint32_t a = 0; a < nfe && res == TND_OK && !rn_interrupted(h); a++)
        for (uint32_t d = 0; d < ndn && res == TND_OK && !rn_interrupted(h); d++) {
            rn_render_opts o;
            rn_render_defaults(&o);
            o.scene = so->scene;
            o.env = so->env;
            o.size[0] = so->size[0], o.size[1] = so->size[1];
            o.frontend = fes[a];
            o.denoiser = so->denoiser ? so->denoiser : pl_denoiser_at(d)->name;
            o.quiet = true;
            rn_soak_rec *rec = rn_soak_rec_begin(so->frames);
            if (!rec) {
                res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "soak: out of memory");
                break;
            }
            tnd_log_level was = rn_quiet_begin(true);
            res = soak_one(&o, so->frames, rec, &quiet);
            rn_quiet_end(was);
            if (res == TND_OK && rec->k > 0) {
                all_flat = all_flat && rec->row.flat;
                if (so->on_run)
                    so->on_run(rec, so->user);
            }
            rn_soak_rec_free(rec);
        }
    if (flat)
        *flat = all_flat;
    int sig = rn_interrupted(h);
    if (res == TND_OK && sig) {
        rn_warn(h, "tandem: bench: soak interrupted (%s)", rn_signal_name(sig));
        res = tnd_fail(TND_ERR_INTERRUPTED, "bench: soak interrupted (%s)", rn_signal_name(sig));
    }
    return res;
}
