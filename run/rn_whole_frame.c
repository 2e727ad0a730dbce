/* run/rn_whole_frame.c: the whole frame (front-end, gradients, back-end, post) back to back, in
 * up to four ways in one run: the contract brought to the host and every pass waited for (what
 * the chain did before it kept the contract on the GPU), the contract on the GPU with every frame
 * waited for (its timestamps are the frame's own: the per-pass table), frames recorded without
 * waiting for the one before (the host's share of each timed), and, where the front-end can fold
 * the denoiser's gradient re-shading into its shading pass, the same re-shaded in a launch of its
 * own (pl_chain_desc.separate_reshade). Blocks of frames take turns (noise on these machines
 * drifts in minutes); each way has its own front-end, chain and scene states, so histories do not
 * mix. Each frame is render's (rn_frame_begin, rn_frame_step, pl_chain_run), as render
 * --timed-frames times it. What `tandem bench --whole-frame` and `--overlap` print.
 * Entry point: rn_whole_frame. */
#include "run/rn_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *rn_whole_frame_way_name(int way)
{
    static const char *const name[RN_WF_WAYS] = {"host_contract_blocking", "gpu_contract_blocking",
                                                 "gpu_contract_no_wait",
                                                 "gpu_contract_no_wait_separate_reshade"};
    return way >= 0 && way < RN_WF_WAYS ? name[way] : "?";
}

const char *rn_whole_frame_host_name(int part)
{
    static const char *const name[3] = {"evaluate", "set_frame", "chain_run"};
    return part >= 0 && part < 3 ? name[part] : "?";
}

tnd_result rn_whole_frame(const rn_whole_frame_opts *w, rn_whole_frame_result *r)
{
    enum { BLOCK = 8, WARM = 2 };
    tnd_result res = TND_OK;
    tnd_vk vk = {0};
    pl_frontend *fe[RN_WF_WAYS] = {0};
    pl_chain *chain[RN_WF_WAYS] = {0};
    tnd_scene_state st[RN_WF_WAYS][2] = {{{0}}};
    double *ms[RN_WF_WAYS] = {0};
    double *pass[RN_WF_MAX_PASSES] = {0};
    double *host[3] = {0};
    const unsigned blocks = w->blocks, frames = blocks * BLOCK;
    const int m0 = w->with_host ? RN_WF_HOST : RN_WF_GPU; /* the first way run */
    *r = (rn_whole_frame_result){.frames_per_block = BLOCK, .blocks = blocks};
    if (blocks == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "bench: --repeats must be positive");
    for (int m = 0; m < RN_WF_WAYS; m++)
        if (!(ms[m] = calloc(blocks, sizeof(double)))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
            goto fail;
        }
    for (int k = 0; k < 3; k++)
        if (!(host[k] = calloc(frames, sizeof(double)))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
            goto fail;
        }
    /* render's frame: its options with what bench sets (30 frames a second from frame 0, the
     * scene's camera, no upscaling) */
    rn_render_opts o;
    rn_render_defaults(&o);
    o.size[0] = w->size[0], o.size[1] = w->size[1];
    o.bounces = rn_bounces_split(w->bounces, &o.half_indirect);
    TND_TRY(tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = !pl_frontend_needs_gpu(w->frontend)},
                          &vk));
    cmp_desc pd = {.taa = true, .interleave = (w->scene->features & TND_FEATURE(SPLIT)) != 0};
    for (int m = m0; m < RN_WF_WAYS; m++) {
        if (m == RN_WF_SEPARATE && !pl_chain_can_fold(chain[RN_WF_GPU], fe[RN_WF_GPU]))
            break; /* (a separate re-shading is another way only where it can be folded in) */
        r->ran[m] = true;
        TND_TRY(pl_frontend_create(w->frontend, w->scene,
                                   &(pl_frontend_desc){.vk = &vk, .precision = w->precision,
                                                       .lights = w->lights,
                                                       .bounces = o.bounces,
                                                       .half_indirect = o.half_indirect},
                                   &fe[m]));
        TND_TRY(pl_chain_create(&(pl_chain_desc){.vk = &vk, .width = o.size[0],
                                                 .height = o.size[1], .precision = w->precision,
                                                 .backend = true, .denoiser = w->denoiser,
                                                 .post = pd, .host_contract = m == RN_WF_HOST,
                                                 .separate_reshade = m == RN_WF_SEPARATE},
                                &chain[m]));
    }
    const pl_pass *wf[RN_WF_MAX_PASSES];
    r->npasses = pl_chain_passes(chain[RN_WF_GPU], wf, RN_WF_MAX_PASSES);
    for (uint32_t k = 0; k < r->npasses; k++) {
        snprintf(r->pass[k].name, sizeof r->pass[k].name, "%s", wf[k]->name);
        r->pass[k].group = wf[k]->group;
        if (!(pass[k] = calloc(frames, sizeof(double)))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
            goto fail;
        }
    }
    for (unsigned b = 0; b < WARM + blocks; b++)
        for (int m = m0; m < RN_WF_WAYS && r->ran[m]; m++) {
            double t0 = tnd_now();
            for (unsigned i = 0; i < BLOCK; i++) {
                unsigned f = b * BLOCK + i; /* the same frames for every way */
                size_t at = (size_t)(b - WARM) * BLOCK + i; /* (b >= WARM) */
                rn_frame_host fh;
                TND_TRY(rn_frame_begin(&o, w->scene, fe[m], st[m], f, f == 0, &fh));
                pl_step step = rn_frame_step(&o, &st[m][f & 1], f, f == 0);
                step.no_wait = m >= RN_WF_NO_WAIT;
                pl_step_result pr = {0};
                double c0 = tnd_now();
                TND_TRY(pl_chain_run(chain[m], fe[m], &step, NULL, NULL, &pr));
                if (m == RN_WF_GPU && b >= WARM) {
                    double t[RN_WF_MAX_PASSES];
                    pl_step_times(chain[m], &pr, t);
                    for (uint32_t k = 0; k < r->npasses; k++)
                        pass[k][at] = t[k];
                }
                if (m == RN_WF_NO_WAIT && b >= WARM) { /* the host's share of a frame */
                    host[0][at] = fh.evaluate_ms;
                    host[1][at] = fh.set_frame_ms;
                    host[2][at] = 1e3 * (tnd_now() - c0);
                }
            }
            TND_TRY(pl_chain_finish(chain[m], NULL));
            if (b >= WARM)
                ms[m][b - WARM] = 1e3 * (tnd_now() - t0) / BLOCK;
        }
    for (int m = m0; m < RN_WF_WAYS && r->ran[m]; m++)
        r->wall_ms[m] = rn_median(ms[m], blocks);
    for (uint32_t k = 0; k < r->npasses; k++) {
        r->pass[k].ms = rn_median(pass[k], frames);
        r->group_ms[r->pass[k].group] += r->pass[k].ms;
        r->gpu_ms += r->pass[k].ms;
    }
    for (int k = 0; k < 3; k++)
        r->host_ms[k] = rn_median(host[k], frames);
    pl_frontend_describe(fe[m0], r->device, sizeof r->device);
    snprintf(r->denoiser, sizeof r->denoiser, "%s", pl_chain_denoiser_info(chain[RN_WF_GPU])->name);
    r->lights = tnd_light_sampling_for(w->scene, w->lights);
fail:
    for (int m = 0; m < RN_WF_WAYS; m++) {
        pl_chain_destroy(chain[m]);
        pl_frontend_destroy(fe[m]);
        free(ms[m]);
        tnd_scene_state_free(&st[m][0]);
        tnd_scene_state_free(&st[m][1]);
    }
    for (int k = 0; k < RN_WF_MAX_PASSES; k++)
        free(pass[k]);
    for (int k = 0; k < 3; k++)
        free(host[k]);
    tnd_vk_destroy(&vk);
    return res;
}
