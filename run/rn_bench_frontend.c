/* run/rn_bench_frontend.c: a front-end's throughput on one scene (`tandem bench` without a
 * denoiser): the Embree front-end counts the frame's rays and times its sweep beside a raw
 * ray-casting loop over the same rays (pl_frontend_benchmark); a GPU front-end traces exactly
 * those rays (same random numbers, same decisions) and its two passes are timed with timestamps,
 * medians after a warm-up. Entry point: rn_bench_frontend. */
#include "run/rn_internal.h"

#include <stdio.h>
#include <stdlib.h>

/* The GPU front-end's passes over `repeats` frames after 3 of warm-up: their medians into b,
 * its build time into *t_build, its description into who. */
static tnd_result bench_gpu(const rn_bench_frontend_opts *o, const tnd_scene *s,
                            const tnd_scene_state *st, const pl_params *p, pl_bench *b,
                            double *t_build, char *who, size_t who_size)
{
    tnd_result res = TND_OK;
    tnd_vk vk = {0};
    pl_frontend *gv = NULL;
    double *tp = calloc(o->repeats, sizeof *tp), *ts = calloc(o->repeats, sizeof *ts);
    if (!tp || !ts) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        goto fail;
    }
    TND_TRY(tnd_vk_create(&(tnd_vk_desc){0}, &vk));
    double t0 = tnd_now();
    TND_TRY(pl_frontend_create(o->frontend, s,
                               &(pl_frontend_desc){.vk = &vk, .rt_api = o->rt_api,
                                                   .full_pipeline = o->full_pipeline},
                               &gv));
    TND_TRY(pl_frontend_set_frame(gv, st, st, o->frame, o->size[0], o->size[1]));
    *t_build = tnd_now() - t0;
    for (int w = 0; w < 3; w++)
        TND_TRY(pl_frontend_render(gv, p, NULL, NULL));
    for (unsigned r = 0; r < o->repeats; r++) {
        pl_timings tm;
        TND_TRY(pl_frontend_render(gv, p, NULL, &tm));
        tp[r] = tm.primary_ms;
        ts[r] = tm.shade_ms;
    }
    b->primary_ms = rn_median(tp, o->repeats);
    b->shade_ms = rn_median(ts, o->repeats);
    b->raw_ms = 0;
    pl_frontend_describe(gv, who, who_size);
fail:
    free(tp);
    free(ts);
    pl_frontend_destroy(gv);
    tnd_vk_destroy(&vk);
    return res;
}

tnd_result rn_bench_frontend(const rn_bench_frontend_opts *o, rn_bench_frontend_result *r)
{
    tnd_result res = TND_OK;
    tnd_scene *s = NULL;
    pl_frontend *c = NULL;
    tnd_scene_state st = {0};
    *r = (rn_bench_frontend_result){0};
    if (o->repeats == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "bench: --repeats must be positive");
    r->gpu = (pl_frontend_caps_of(o->frontend) & PL_CAP_GPU_CONTRACT) != 0;
    bool half;
    pl_params p = {.bounces = rn_bounces_split(o->bounces, &half)};
    p.half_indirect = half;
    r->load_s = tnd_now();
    TND_TRY(tnd_scene_load(o->scene, &s));
    r->load_s = tnd_now() - r->load_s;
    r->triangles = tnd_scene_triangles(s);
    r->build_s = tnd_now();
    /* the CPU front-end counts the rays (both front-ends trace the same ones) */
    TND_TRY(pl_frontend_create("embree", s, &(pl_frontend_desc){.threads = o->threads}, &c));
    pl_frontend_cpu(c, &r->threads, &r->simd);
    TND_TRY(tnd_scene_evaluate(s, o->frame / 30.0, 0, (float)o->size[0] / o->size[1], &st));
    TND_TRY(pl_frontend_set_frame(c, &st, &st, o->frame, o->size[0], o->size[1]));
    r->build_s = tnd_now() - r->build_s;
    TND_TRY(pl_frontend_benchmark(c, &p, r->gpu ? 1 : o->repeats, &r->b));
    if (r->gpu)
        TND_TRY(bench_gpu(o, s, &st, &p, &r->b, &r->build_s, r->device, sizeof r->device));
    /* Embree: the frame as its render sweeps it (both passes batch by batch); the GPU: its two
     * passes' timestamps */
    r->frame_ms = r->gpu ? r->b.primary_ms + r->b.shade_ms : r->b.frame_ms;
fail:
    tnd_scene_state_free(&st);
    pl_frontend_destroy(c);
    tnd_scene_destroy(s);
    return res;
}
