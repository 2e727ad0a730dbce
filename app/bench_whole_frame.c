/* app/bench_whole_frame.c: `tandem bench --whole-frame` and `--overlap`: the run layer's
 * rn_whole_frame (the whole frame back to back, its ways taking turns in blocks) printed as a
 * table or JSON on stdout. Entry point: app_bench_whole_frame. */
#include "app/app.h"

#include <cjson/cJSON.h>
#include <stdlib.h>

tnd_result app_bench_whole_frame(const rn_whole_frame_opts *o, bool json)
{
    rn_whole_frame_result r;
    tnd_result res = rn_whole_frame(o, &r);
    if (res != TND_OK)
        return res;
    const int m0 = o->with_host ? RN_WF_HOST : RN_WF_GPU;
    const unsigned frames = r.blocks * r.frames_per_block;
    if (json) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddStringToObject(j, "frontend", o->frontend);
        cJSON_AddStringToObject(j, "device", r.device);
        cJSON_AddStringToObject(j, "denoiser", r.denoiser);
        cJSON_AddStringToObject(j, "lights", tnd_light_sampling_name(r.lights));
        cJSON_AddNumberToObject(j, "width", o->size[0]);
        cJSON_AddNumberToObject(j, "height", o->size[1]);
        cJSON_AddNumberToObject(j, "frames_per_block", r.frames_per_block);
        cJSON_AddNumberToObject(j, "blocks", r.blocks);
        for (int m = m0; m < RN_WF_WAYS && r.ran[m]; m++)
            cJSON_AddNumberToObject(j, rn_whole_frame_way_name(m), r.wall_ms[m]);
        if (o->with_host) {
            cJSON_AddNumberToObject(j, "gpu_over_host", r.wall_ms[RN_WF_GPU] / r.wall_ms[RN_WF_HOST]);
            cJSON_AddNumberToObject(j, "no_wait_over_host",
                                    r.wall_ms[RN_WF_NO_WAIT] / r.wall_ms[RN_WF_HOST]);
        }
        if (r.ran[RN_WF_SEPARATE])
            cJSON_AddNumberToObject(j, "separate_over_folded",
                                    r.wall_ms[RN_WF_SEPARATE] / r.wall_ms[RN_WF_NO_WAIT]);
        cJSON *g = cJSON_AddObjectToObject(j, "gpu_ms"); /* medians per pass, and their sums */
        for (uint32_t k = 0; k < r.npasses; k++)
            cJSON_AddNumberToObject(g, r.pass[k].name, r.pass[k].ms);
        for (int k = 0; k < PL_GROUPS; k++)
            cJSON_AddNumberToObject(g, pl_pass_group_name(k), r.group_ms[k]);
        cJSON_AddNumberToObject(g, "frame", r.gpu_ms);
        cJSON *h = cJSON_AddObjectToObject(j, "host_ms_not_waited");
        for (int k = 0; k < 3; k++)
            cJSON_AddNumberToObject(h, rn_whole_frame_host_name(k), r.host_ms[k]);
        char *txt = cJSON_Print(j);
        printf("%s\n", txt);
        free(txt);
        cJSON_Delete(j);
        return TND_OK;
    }
    printf("bench %s: %s, %ux%u, %s, %s, lights %s (wall ms per frame, medians of %u blocks of %u "
           "frames taking turns)\n",
           o->with_host ? "--overlap" : "--whole-frame", r.device, o->size[0], o->size[1],
           r.denoiser, tnd_precision_name(o->precision), tnd_light_sampling_name(r.lights),
           r.blocks, r.frames_per_block);
    for (int m = m0; m < RN_WF_WAYS && r.ran[m]; m++)
        printf("  %-37s %9.3f ms  %5.3fx\n", rn_whole_frame_way_name(m), r.wall_ms[m],
               r.wall_ms[m] / r.wall_ms[m0]);
    printf("  GPU ms per pass (medians of %u frames, contract on the GPU, each frame waited "
           "for; the front-end's are CPU wall clock with embree):\n", frames);
    for (int k = 0; k < PL_GROUPS; k++) {
        printf("    %-10s %8.3f  (", pl_pass_group_name(k), r.group_ms[k]);
        for (uint32_t q = 0, n = 0; q < r.npasses; q++)
            if (r.pass[q].group == (pl_pass_group)k)
                printf("%s%s %.3f", n++ ? ", " : "", r.pass[q].name, r.pass[q].ms);
        printf(")\n");
    }
    printf("    %-10s %8.3f\n", "frame", r.gpu_ms);
    printf("  host ms per frame not waited for (medians): ");
    for (int k = 0; k < 3; k++)
        printf("%s%s %.3f", k ? ", " : "", rn_whole_frame_host_name(k), r.host_ms[k]);
    printf(" (chain_run: recording, submission, any wait for the frame before)\n");
    return TND_OK;
}
