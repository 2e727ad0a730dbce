/* app/cmd_bench.c: `tandem bench`: front-end throughput on one scene (Mrays/s, ms per frame)
 * beside a raw ray-casting loop over the same rays. Later it grows into the speed/accuracy
 * sweeps of the eval issue. */
#include "app/app.h"
#include "frontend_embree/frontend_embree.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

#ifndef TND_DATA_DIR
#define TND_DATA_DIR "data"
#endif

static const app_cmd bench_cmd = {
    "bench",
    "Measure a front-end on a scene: ms per frame per pass, rays per frame, Mrays/s, and the\n"
    "rate of a raw Embree loop over the same rays (medians over --repeats after a warm-up).",
    "[--scene PATH] [--frontend embree] [--size WxH] [--repeats N] [--json]", NULL};

int cmd_bench(int argc, char **argv)
{
    const char *scene_path = TND_DATA_DIR "/scenes/cornell.gltf", *frontend = "embree";
    unsigned size[2] = {256, 256}, repeats = 10, threads = 0, bounces = 1, frame = 0;
    bool json = false;
    const app_opt opts[] = {
        {"scene", APP_OPT_STRING, &scene_path, "PATH", "glTF scene or stress:N (default: cornell)"},
        {"frontend", APP_OPT_STRING, &frontend, "NAME", "embree"},
        {"size", APP_OPT_SIZE, size, "WxH", "image size (default 256x256)"},
        {"repeats", APP_OPT_UINT, &repeats, "N", "timed repetitions (default 10)"},
        {"threads", APP_OPT_UINT, &threads, "N", "CPU threads (default: all cores)"},
        {"bounces", APP_OPT_UINT, &bounces, "N", "indirect bounces (default 1)"},
        {"frame", APP_OPT_UINT, &frame, "F", "frame of the camera path (default 0)"},
        {"json", APP_OPT_FLAG, &json, NULL, "print the results as JSON"},
        {0},
    };
    const char *pos[1];
    int npos;
    int rc = app_parse(&bench_cmd, opts, argc, argv, pos, 0, &npos);
    if (rc >= 0)
        return rc;
    if (strcmp(frontend, "embree") != 0) {
        fprintf(stderr, "tandem bench: --frontend '%s': only 'embree' is benchmarked so far\n",
                frontend);
        return APP_EXIT_USAGE;
    }
    tnd_result res = TND_OK;
    tnd_scene *s = NULL;
    femb_context *c = NULL;
    tnd_scene_state st = {0};
    femb_bench b;
    int status = APP_EXIT_FAIL;
    double t_load = tnd_now();
    TND_TRY(tnd_scene_load(scene_path, &s));
    t_load = tnd_now() - t_load;
    double t_build = tnd_now();
    TND_TRY(femb_create(s, &(femb_desc){.threads = threads}, &c));
    TND_TRY(tnd_scene_evaluate(s, frame / 30.0, 0, (float)size[0] / size[1], &st));
    TND_TRY(femb_set_frame(c, &st, &st, frame, size[0], size[1]));
    t_build = tnd_now() - t_build;
    TND_TRY(femb_benchmark(c, &(femb_params){.bounces = bounces}, repeats, &b));
    double frame_ms = b.primary_ms + b.shade_ms;
    double fe_rate = b.rays / (frame_ms * 1e3), raw_rate = b.rays / (b.raw_ms * 1e3);
    if (json) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "frontend", "embree");
        cJSON_AddStringToObject(o, "scene", scene_path);
        cJSON_AddNumberToObject(o, "triangles", (double)tnd_scene_triangles(s));
        cJSON_AddNumberToObject(o, "width", size[0]);
        cJSON_AddNumberToObject(o, "height", size[1]);
        cJSON_AddNumberToObject(o, "threads", femb_thread_count(c));
        cJSON_AddNumberToObject(o, "bounces", bounces);
        cJSON_AddNumberToObject(o, "rays_per_frame", (double)b.rays);
        cJSON_AddNumberToObject(o, "primary_ms", b.primary_ms);
        cJSON_AddNumberToObject(o, "shade_ms", b.shade_ms);
        cJSON_AddNumberToObject(o, "frame_ms", frame_ms);
        cJSON_AddNumberToObject(o, "frontend_mrays_per_s", fe_rate);
        cJSON_AddNumberToObject(o, "raw_ms", b.raw_ms);
        cJSON_AddNumberToObject(o, "raw_mrays_per_s", raw_rate);
        cJSON_AddNumberToObject(o, "frontend_over_raw", fe_rate / raw_rate);
        cJSON_AddNumberToObject(o, "build_s", t_build);
        char *txt = cJSON_Print(o);
        printf("%s\n", txt);
        free(txt);
        cJSON_Delete(o);
    } else {
        printf("bench embree: %s, %llu triangles, %ux%u, 1 spp, %u bounce%s, %u threads\n",
               scene_path, (unsigned long long)tnd_scene_triangles(s), size[0], size[1], bounces,
               bounces == 1 ? "" : "s", femb_thread_count(c));
        printf("  scene load %.2f s, BVH build %.2f s\n", t_load, t_build);
        printf("  rays per frame    %llu (primary, shadow and bounce rays)\n",
               (unsigned long long)b.rays);
        printf("  primary pass      %8.2f ms\n  shading pass      %8.2f ms\n", b.primary_ms,
               b.shade_ms);
        printf("  front-end frame   %8.2f ms  %7.2f Mrays/s\n", frame_ms, fe_rate);
        printf("  raw Embree loop   %8.2f ms  %7.2f Mrays/s (same rays, rtcIntersect1/rtcOccluded1)\n",
               b.raw_ms, raw_rate);
        printf("  front-end / raw   %7.1f%%  (goal: above 60%%)\n", 100.0 * fe_rate / raw_rate);
        printf("  (medians of %u repetitions after a warm-up)\n", repeats);
    }
    status = APP_EXIT_OK;
fail:
    if (status != APP_EXIT_OK)
        app_report("bench", res);
    tnd_scene_state_free(&st);
    femb_destroy(c);
    tnd_scene_destroy(s);
    return status;
}
