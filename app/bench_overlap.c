/* app/bench_overlap.c: `tandem bench --overlap` and `--whole-frame`: the whole frame (front-end,
 * back-end, post) back to back, three ways in one run: the contract brought to the host and
 * every pass waited for (what the chain did before it kept the contract on the GPU), the contract
 * on the GPU with every frame waited for, and frames recorded without waiting for the previous
 * one; a fourth where the denoiser's gradient samples are re-shaded inside the front-end's
 * shading pass: frames not waited for, re-shaded in a launch of their own
 * (pl_chain_desc.separate_reshade), where the front-end can fold it (pl_chain_can_fold). Blocks
 * of frames take turns (noise on these machines drifts in minutes); each way has its own
 * front-end and chain, so histories do not mix. Entry point: app_bench_overlap. */
#include "app/app.h"
#include "composite/composite.h"

#include <cjson/cJSON.h>
#include <stdlib.h>

enum { OV_HOST, OV_GPU, OV_NO_WAIT, OV_SEPARATE, OV_COUNT };
enum { WF_MAX = 32 }; /* the whole frame's passes (pl_chain_passes), in their groups */
tnd_result app_bench_overlap(const tnd_scene *s, const char *fe_name, const unsigned size[2],
                                unsigned bounces, unsigned blocks, const char *denoiser,
                                tnd_precision prec, tnd_light_sampling lights, bool json,
                                bool with_host)
{
    static const char *const ov_name[OV_COUNT] = {"host_contract_blocking", "gpu_contract_blocking",
                                                  "gpu_contract_no_wait",
                                                  "gpu_contract_no_wait_separate_reshade"};
    enum { BLOCK = 8, WARM = 2 };
    tnd_result res = TND_OK;
    tnd_vk vk = {0};
    pl_frontend *fe[OV_COUNT] = {0};
    pl_chain *chain[OV_COUNT] = {0};
    tnd_scene_state st[2] = {{0}};
    double *ms[OV_COUNT] = {0};
    const int m0 = with_host ? OV_HOST : OV_GPU; /* the ways run (OV_SEPARATE: see below) */
    bool way[OV_COUNT] = {false};
    /* the GPU-contract way's passes, frame by frame (its frames are waited for: their
     * timestamps are the frame's own) */
    double *pass[WF_MAX] = {0};
    const pl_pass *wf[WF_MAX];
    uint32_t nwf = 0;
    /* the frames not waited for: host ms in scene evaluation, the front-end's set_frame, and
     * pl_chain_run (recording, submission, and any wait for the frame before) */
    static const char *const host_name[3] = {"evaluate", "set_frame", "chain_run"};
    double *host[3] = {0};
    for (int m = 0; m < OV_COUNT; m++)
        if (!(ms[m] = calloc(blocks, sizeof(double)))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
            goto fail;
        }
    for (int k = 0; k < 3; k++)
        if (!(host[k] = calloc((size_t)blocks * BLOCK, sizeof(double)))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
            goto fail;
        }
    TND_TRY(tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = !pl_frontend_needs_gpu(fe_name)}, &vk));
    cmp_desc pd = {.taa = true, .interleave = (s->features & TND_FEATURE(SPLIT)) != 0};
    for (int m = m0; m < OV_COUNT; m++) {
        if (m == OV_SEPARATE && !pl_chain_can_fold(chain[OV_GPU], fe[OV_GPU]))
            break; /* (a separate re-shading is another way only where it can be folded in) */
        way[m] = true;
        TND_TRY(pl_frontend_create(
            fe_name, s, &(pl_frontend_desc){.vk = &vk, .precision = prec, .lights = lights},
            &fe[m]));
        TND_TRY(pl_chain_create(&(pl_chain_desc){.vk = &vk, .width = size[0], .height = size[1],
                                                 .precision = prec, .backend = true,
                                                 .denoiser = denoiser, .post = pd,
                                                 .host_contract = m == OV_HOST,
                                                 .separate_reshade = m == OV_SEPARATE},
                                &chain[m]));
    }
    nwf = pl_chain_passes(chain[OV_GPU], wf, WF_MAX);
    for (uint32_t k = 0; k < nwf; k++)
        if (!(pass[k] = calloc((size_t)blocks * BLOCK, sizeof(double)))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
            goto fail;
        }
    float aspect = (float)size[0] / size[1];
    bool half;
    pl_params params = {.bounces = rn_bounces_split(bounces, &half)};
    params.half_indirect = half;
    for (unsigned b = 0; b < WARM + blocks; b++)
        for (int m = m0; m < OV_COUNT && way[m]; m++) {
            double t0 = tnd_now();
            for (unsigned i = 0; i < BLOCK; i++) {
                unsigned f = b * BLOCK + i; /* the same frames for every way */
                tnd_scene_state *cur = &st[f & 1], *prev = &st[(f + 1) & 1];
                double h0 = tnd_now();
                TND_TRY(tnd_scene_evaluate(s, f / 30.0, 0, aspect, cur));
                TND_TRY(tnd_scene_evaluate(s, f ? (f - 1) / 30.0 : 0.0, 0, aspect, prev));
                double h1 = tnd_now();
                TND_TRY(pl_frontend_set_frame(fe[m], cur, prev, f, size[0], size[1]));
                double h2 = tnd_now();
                pl_step step = {.params = params,
                                .frame = dn_frame_for_camera(cur->camera.proj, size[1], f, f == 0),
                                .dt = 1.0f / 30.0f,
                                .no_wait = m >= OV_NO_WAIT};
                pl_step_result pr = {0};
                TND_TRY(pl_chain_run(chain[m], fe[m], &step, NULL, NULL, &pr));
                if (m == OV_GPU && b >= WARM) {
                    double t[WF_MAX];
                    pl_step_times(chain[m], &pr, t);
                    for (uint32_t k = 0; k < nwf; k++)
                        pass[k][(size_t)(b - WARM) * BLOCK + i] = t[k];
                }
                if (m == OV_NO_WAIT && b >= WARM) { /* the host's share of a frame */
                    size_t at = (size_t)(b - WARM) * BLOCK + i;
                    host[0][at] = 1e3 * (h1 - h0);
                    host[1][at] = 1e3 * (h2 - h1);
                    host[2][at] = 1e3 * (tnd_now() - h2);
                }
            }
            TND_TRY(pl_chain_finish(chain[m], NULL));
            if (b >= WARM)
                ms[m][b - WARM] = 1e3 * (tnd_now() - t0) / BLOCK;
        }
    double med[OV_COUNT], pmed[WF_MAX], group[PL_GROUPS] = {0}, gpu = 0;
    for (int m = m0; m < OV_COUNT && way[m]; m++)
        med[m] = rn_median(ms[m], blocks);
    for (uint32_t k = 0; k < nwf; k++) {
        pmed[k] = rn_median(pass[k], blocks * BLOCK);
        group[wf[k]->group] += pmed[k];
        gpu += pmed[k];
    }
    char who[300];
    pl_frontend_describe(fe[m0], who, sizeof who);
    if (json) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "frontend", fe_name);
        cJSON_AddStringToObject(o, "device", who);
        cJSON_AddStringToObject(o, "denoiser", pl_chain_denoiser_info(chain[OV_GPU])->name);
        cJSON_AddStringToObject(o, "lights",
                                tnd_light_sampling_name(tnd_light_sampling_for(s, lights)));
        cJSON_AddNumberToObject(o, "width", size[0]);
        cJSON_AddNumberToObject(o, "height", size[1]);
        cJSON_AddNumberToObject(o, "frames_per_block", BLOCK);
        cJSON_AddNumberToObject(o, "blocks", blocks);
        for (int m = m0; m < OV_COUNT && way[m]; m++)
            cJSON_AddNumberToObject(o, ov_name[m], med[m]);
        if (with_host) {
            cJSON_AddNumberToObject(o, "gpu_over_host", med[OV_GPU] / med[OV_HOST]);
            cJSON_AddNumberToObject(o, "no_wait_over_host", med[OV_NO_WAIT] / med[OV_HOST]);
        }
        if (way[OV_SEPARATE])
            cJSON_AddNumberToObject(o, "separate_over_folded", med[OV_SEPARATE] / med[OV_NO_WAIT]);
        cJSON *g = cJSON_AddObjectToObject(o, "gpu_ms"); /* medians per pass, and their sums */
        for (uint32_t k = 0; k < nwf; k++)
            cJSON_AddNumberToObject(g, wf[k]->name, pmed[k]);
        for (int k = 0; k < PL_GROUPS; k++)
            cJSON_AddNumberToObject(g, pl_pass_group_name(k), group[k]);
        cJSON_AddNumberToObject(g, "frame", gpu);
        cJSON *h = cJSON_AddObjectToObject(o, "host_ms_not_waited");
        for (int k = 0; k < 3; k++)
            cJSON_AddNumberToObject(h, host_name[k], rn_median(host[k], blocks * BLOCK));
        char *txt = cJSON_Print(o);
        printf("%s\n", txt);
        free(txt);
        cJSON_Delete(o);
    } else {
        printf("bench %s: %s, %ux%u, %s, %s, lights %s (wall ms per frame, medians of %u "
               "blocks of %d frames taking turns)\n",
               with_host ? "--overlap" : "--whole-frame", who, size[0], size[1],
               pl_chain_denoiser_info(chain[OV_GPU])->name, tnd_precision_name(prec),
               tnd_light_sampling_name(tnd_light_sampling_for(s, lights)), blocks, BLOCK);
        for (int m = m0; m < OV_COUNT && way[m]; m++)
            printf("  %-37s %9.3f ms  %5.3fx\n", ov_name[m], med[m], med[m] / med[m0]);
        printf("  GPU ms per pass (medians of %u frames, contract on the GPU, each frame waited "
               "for; the front-end's are CPU wall clock with embree):\n", blocks * BLOCK);
        for (int k = 0; k < PL_GROUPS; k++) {
            printf("    %-10s %8.3f  (", pl_pass_group_name(k), group[k]);
            for (uint32_t j = 0, n = 0; j < nwf; j++)
                if (wf[j]->group == (pl_pass_group)k)
                    printf("%s%s %.3f", n++ ? ", " : "", wf[j]->name, pmed[j]);
            printf(")\n");
        }
        printf("    %-10s %8.3f\n", "frame", gpu);
        printf("  host ms per frame not waited for (medians): ");
        for (int k = 0; k < 3; k++)
            printf("%s%s %.3f", k ? ", " : "", host_name[k], rn_median(host[k], blocks * BLOCK));
        printf(" (chain_run: recording, submission, any wait for the frame before)\n");
    }
fail:
    for (int m = 0; m < OV_COUNT; m++) {
        pl_chain_destroy(chain[m]);
        pl_frontend_destroy(fe[m]);
        free(ms[m]);
    }
    for (int k = 0; k < WF_MAX; k++)
        free(pass[k]);
    for (int k = 0; k < 3; k++)
        free(host[k]);
    tnd_scene_state_free(&st[0]);
    tnd_scene_state_free(&st[1]);
    tnd_vk_destroy(&vk);
    return res;
}

