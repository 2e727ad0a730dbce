/* run/rn_bench_backend.c: the real-time frame back to back (`tandem bench --denoiser`): no file is
 * written between frames, so the GPU stays busy (and its clocks up) as in an application. Each
 * frame is render's (rn_frame_begin, rn_frame_step, pl_chain_run) without the post chain; every
 * pass of the chain (pl_chain_passes: the front-end's and the denoiser's) is timed, and the
 * wall clock per frame; the denoiser's passes are set against their bandwidth floor (the bytes
 * each must move at the copy bandwidth measured after the frames). Entry point: rn_bench_backend. */
#include "run/rn_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

tnd_result rn_bench_backend(const rn_bench_backend_opts *b, rn_bench_backend_result *r)
{
    enum { WARM = 3 };
    tnd_result res = TND_OK;
    tnd_vk vk = {0};
    pl_frontend *fe = NULL;
    pl_chain *chain = NULL;
    tnd_scene_state st[2] = {{0}};
    const unsigned repeats = b->repeats;
    double *v[RN_WF_MAX_PASSES + 1] = {0}, *dv = NULL; /* v[np]: the wall clock */
    const pl_pass *pass[RN_WF_MAX_PASSES];
    *r = (rn_bench_backend_result){.frames = repeats};
    if (repeats == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "bench: --repeats must be positive");
    rn_render_opts o;
    rn_render_defaults(&o);
    o.start = b->frame;
    o.size[0] = b->size[0], o.size[1] = b->size[1];
    o.bounces = rn_bounces_split(b->bounces, &o.half_indirect);
    TND_TRY(tnd_vk_create(&(tnd_vk_desc){0}, &vk));
    TND_TRY(pl_frontend_create(b->frontend, b->scene,
                               &(pl_frontend_desc){.vk = &vk, .precision = b->precision,
                                                   .rt_api = b->rt_api,
                                                   .full_pipeline = b->full_pipeline,
                                                   .bounces = o.bounces,
                                                   .half_indirect = o.half_indirect},
                               &fe));
    TND_TRY(pl_chain_create(&(pl_chain_desc){.vk = &vk, .width = o.size[0], .height = o.size[1],
                                             .precision = b->precision, .backend = true,
                                             .denoiser = b->denoiser,
                                             .denoise = {.dispatch_timing = b->per_dispatch},
                                             .no_post = true},
                            &chain));
    dn_context *dn = pl_chain_denoiser(chain); /* (the built-in back-end's: per dispatch) */
    /* (no post chain: the denoiser's passes come last) */
    const uint32_t np = pl_chain_passes(chain, pass, RN_WF_MAX_PASSES);
    const uint32_t nfe = np - pl_chain_denoiser_info(chain)->npasses;
    r->npasses = np, r->nfrontend = nfe;
    for (uint32_t k = 0; k <= np; k++)
        if (!(v[k] = calloc(repeats, sizeof(double)))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
            goto fail;
        }
    /* per dispatch: each dispatch's times over the timed frames, when the sequence of
     * dispatches is the same every frame (it is after the first) */
    enum { MAXD = TND_TIMER_MAX_PASSES };
    const char *dnames[MAXD] = {0};
    uint32_t nd = 0;
    bool d_same = true, per_dispatch = b->per_dispatch && dn;
    if (per_dispatch && !(dv = calloc((size_t)MAXD * repeats, sizeof(double)))) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        goto fail;
    }
    for (unsigned i = 0; i < WARM + repeats; i++) {
        double t0 = tnd_now();
        TND_TRY(rn_frame_begin(&o, b->scene, fe, st, i, i == 0, NULL));
        pl_step step = rn_frame_step(&o, &st[i & 1], i, i == 0);
        pl_step_result pr;
        TND_TRY(pl_chain_run(chain, fe, &step, NULL, NULL, &pr));
        double wall = 1e3 * (tnd_now() - t0), ms[RN_WF_MAX_PASSES];
        r->beside = pr.beside;
        if (i < WARM)
            continue;
        pl_step_times(chain, &pr, ms);
        for (uint32_t k = 0; k < np; k++)
            v[k][i - WARM] = ms[k];
        v[np][i - WARM] = wall;
        if (per_dispatch) {
            const char *nm[MAXD];
            double dms[MAXD];
            uint32_t n_now = dn_dispatch_times(dn, nm, dms, MAXD);
            if (i == WARM) {
                nd = n_now;
                memcpy(dnames, nm, n_now * sizeof *nm);
            }
            d_same = d_same && n_now == nd && memcmp(nm, dnames, nd * sizeof *nm) == 0;
            for (uint32_t k = 0; k < nd && d_same; k++)
                dv[(size_t)k * repeats + (i - WARM)] = dms[k];
        }
    }
    /* the bytes the denoiser's passes move at the least; a pass run beside another is timed
     * with it, and its bytes go there */
    double dbytes[PL_DN_MAX_PASSES];
    pl_chain_traffic(chain, dbytes);
    for (uint32_t k = 0; k < np; k++) {
        rn_bench_pass *q = &r->pass[k];
        snprintf(q->id, sizeof q->id, "%s", pass[k]->name);
        snprintf(q->name, sizeof q->name, "%.*s", (int)strlen(pass[k]->key) - 3, pass[k]->key);
        snprintf(q->label, sizeof q->label, "%s", q->name);
        snprintf(q->beside, sizeof q->beside, "%s", pass[k]->beside ? pass[k]->beside : "");
        q->timed_beside = r->beside && pass[k]->beside && k >= nfe;
        q->bytes = k >= nfe ? dbytes[k - nfe] : 0;
        q->ms = rn_median(v[k], repeats);
    }
    for (uint32_t k = nfe; r->beside && k < np; k++)
        for (uint32_t j = nfe; pass[k]->beside && j < np; j++)
            if (strcmp(pass[j]->name, pass[k]->beside) == 0) {
                r->pass[j].bytes += r->pass[k].bytes;
                r->pass[k].bytes = 0;
                size_t used = strlen(r->pass[j].label);
                snprintf(r->pass[j].label + used, sizeof r->pass[j].label - used, "+%s",
                         pass[k]->name);
            }
    r->wall_ms = rn_median(v[np], repeats);
    for (uint32_t k = nfe; k < np; k++)
        r->backend_ms += r->pass[k].ms, r->backend_bytes += r->pass[k].bytes;
    /* the copy bandwidth, measured now that the GPU is warm: 8x the back-end's traffic per
     * frame, between 64 MiB and 1 GiB (larger than any cache) */
    r->copy_mib = fmin(1024.0, fmax(64.0, 8.0 * r->backend_bytes / (1 << 20)));
    TND_TRY(rn_bandwidth(&vk, (VkDeviceSize)r->copy_mib << 20, 9, &r->transfer_gb_s,
                         &r->compute_gb_s));
    r->bandwidth_gb_s = fmax(r->transfer_gb_s, r->compute_gb_s); /* the floor: the faster */
    if (per_dispatch && d_same) {
        r->ndispatches = nd;
        for (uint32_t k = 0; k < nd; k++) {
            snprintf(r->dispatch[k].name, sizeof r->dispatch[k].name, "%s", dnames[k]);
            r->dispatch[k].ms = rn_median(dv + (size_t)k * repeats, repeats);
        }
    }
    r->dispatches_differed = per_dispatch && !d_same;
    snprintf(r->device, sizeof r->device, "%s", vk.info.name);
    snprintf(r->models, sizeof r->models, "%s", pl_frontend_models(fe));
    snprintf(r->denoiser, sizeof r->denoiser, "%s", pl_chain_denoiser_info(chain)->name);
fail:
    free(dv);
    for (uint32_t k = 0; k <= RN_WF_MAX_PASSES; k++)
        free(v[k]);
    tnd_scene_state_free(&st[0]);
    tnd_scene_state_free(&st[1]);
    pl_chain_destroy(chain);
    pl_frontend_destroy(fe);
    tnd_vk_destroy(&vk);
    return res;
}

double rn_bench_floor_ms(const rn_bench_backend_result *r, double bytes)
{
    return r->bandwidth_gb_s > 0 ? bytes / (r->bandwidth_gb_s * 1e9) * 1e3 : 0.0;
}
