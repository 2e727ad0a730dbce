/* frontend_embree/femb_bench.c: the front-end's throughput beside a raw Embree loop over the
 * very rays it traced (issue: "the front-end should stay above 60% of the raw rate").
 * Entry point: femb_benchmark. */
#include "frontend_embree/femb_internal.h"

#include <stdlib.h>
#include <string.h>

static void replay(femb_context *c, size_t b, size_t e, void *user)
{
    const femb_ray *rays = user;
    struct RTCIntersectContext ictx;
    for (size_t i = b; i < e; i++) {
        const femb_ray *r = &rays[i];
        rtcInitIntersectContext(&ictx);
        if (r->occlusion) {
            struct RTCRay ray = {.org_x = r->org[0], .org_y = r->org[1], .org_z = r->org[2],
                                 .dir_x = r->dir[0], .dir_y = r->dir[1], .dir_z = r->dir[2],
                                 .tnear = 0.0f, .tfar = r->tmax, .mask = 0xffffffffu};
            rtcOccluded1(c->top, &ictx, &ray);
        } else {
            struct RTCRayHit rh;
            memset(&rh, 0, sizeof rh);
            rh.ray.org_x = r->org[0], rh.ray.org_y = r->org[1], rh.ray.org_z = r->org[2];
            rh.ray.dir_x = r->dir[0], rh.ray.dir_y = r->dir[1], rh.ray.dir_z = r->dir[2];
            rh.ray.tfar = r->tmax;
            rh.ray.mask = 0xffffffffu;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(c->top, &ictx, &rh);
        }
    }
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, uint32_t n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

tnd_result femb_benchmark(femb_context *c, const femb_params *p, uint32_t repeats,
                          femb_bench *out)
{
    tnd_result res = TND_OK;
    tnd_frame f = {0};
    femb_ray_log log = {.lock = PTHREAD_MUTEX_INITIALIZER};
    double *tf = NULL, *tp = NULL, *ts = NULL, *tr = NULL, *trp = NULL;
    memset(out, 0, sizeof *out);
    if (repeats == 0)
        repeats = 1;
    tf = calloc(repeats, sizeof *tf);
    tp = calloc(repeats, sizeof *tp);
    ts = calloc(repeats, sizeof *ts);
    tr = calloc(repeats, sizeof *tr);
    trp = calloc(repeats, sizeof *trp);
    if (!tf || !tp || !ts || !tr || !trp) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        goto fail;
    }
    TND_TRY(tnd_frame_create(c->width, c->height, &f));
    /* record (and warm up) the rays of the two passes in their order: all camera rays, then the
     * shading's (femb_render casts the same rays batch by batch) */
    c->log = &log;
    res = femb_trace_primary(c, &f);
    size_t primary_rays = log.count;
    if (res == TND_OK)
        res = femb_shade(c, p, &f, NULL);
    c->log = NULL;
    if (res != TND_OK)
        goto fail;
    out->rays = log.count;
    out->primary_rays = primary_rays;
    TND_TRY(femb_render(c, p, &f, NULL)); /* (its warm-up) */
    for (uint32_t r = 0; r < repeats; r++) {
        double tr0 = tnd_now();
        TND_TRY(femb_render(c, p, &f, NULL)); /* the frame as `tandem render` renders it */
        double t0 = tnd_now();
        TND_TRY(femb_trace_primary(c, &f)); /* each pass alone, for the per-pass figures */
        double t1 = tnd_now();
        TND_TRY(femb_shade(c, p, &f, NULL));
        double t2 = tnd_now();
        /* chunks of 1024 rays: with 4096 the last chunks left cores idle and the raw loop
         * looked 10-15% slower on 16 cores (docs/performance.md); smaller gain nothing */
        femb_parallel_range(c, log.count, 1024, replay, log.rays);
        double t3 = tnd_now();
        /* (the primary pass's rays again, alone: the whole replay stays one parallel loop, as
         * the front-end's passes are, so that it pays the same start-up) */
        femb_parallel_range(c, primary_rays, 1024, replay, log.rays);
        double t4 = tnd_now();
        tf[r] = 1e3 * (t0 - tr0);
        tp[r] = 1e3 * (t1 - t0);
        ts[r] = 1e3 * (t2 - t1);
        tr[r] = 1e3 * (t3 - t2);
        trp[r] = 1e3 * (t4 - t3);
    }
    out->frame_ms = median(tf, repeats);
    out->primary_ms = median(tp, repeats);
    out->shade_ms = median(ts, repeats);
    out->raw_ms = median(tr, repeats);
    out->raw_primary_ms = median(trp, repeats);
fail:
    free(tf);
    free(tp);
    free(ts);
    free(tr);
    free(trp);
    free(log.rays);
    tnd_frame_destroy(&f);
    return res;
}
