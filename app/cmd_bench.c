/* app/cmd_bench.c: `tandem bench`: front-end throughput on one scene (Mrays/s, ms per frame)
 * beside a raw ray-casting loop over the same rays (pl_frontend_bench); with --denoiser, the
 * real-time frame back to back, each of the chain's passes against the memory-bandwidth floor
 * (the run layer's rn_bench_backend, printed here); --overlap / --whole-frame, the whole frame
 * in up to four ways (rn_whole_frame, printed by bench_whole_frame.c); --sweep (cmd_sweep.c)
 * and --extremes (the run layer's stability report). */
#include "app/app.h"
#include "denoise/denoise.h"
#include "pipeline/pipeline.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef TND_DATA_DIR
#define TND_DATA_DIR "data"
#endif

static const app_cmd bench_cmd = {
    "bench",
    "Measure a front-end on a scene: ms per frame per pass, rays per frame, Mrays/s, and the\n"
    "rate of a raw Embree loop over the same rays (medians over --repeats after a warm-up).\n"
    "With --frontend vk --denoiser MODE: the real-time frame back to back over the camera\n"
    "path (front-end, gradient samples, back-end), GPU ms per pass, the bytes each pass must\n"
    "move and the fraction of the device's measured copy bandwidth it reaches.",
    "[--scene PATH] [--frontend NAME] [--denoiser NAME] [--size WxH] "
    "[--repeats N] [--json]",
    NULL};

/* --bounces (a count, or RN_BOUNCES_HALF: 1 at half resolution) in JSON and in words */
static void bench_bounces_json(cJSON *o, unsigned bounces)
{
    if (bounces == RN_BOUNCES_HALF)
        cJSON_AddStringToObject(o, "bounces", "half");
    else
        cJSON_AddNumberToObject(o, "bounces", bounces);
}

static const char *bounces_words(unsigned bounces, char *buf, size_t size)
{
    if (bounces == RN_BOUNCES_HALF)
        snprintf(buf, size, "1 bounce at half resolution");
    else
        snprintf(buf, size, "%u bounce%s", bounces, bounces == 1 ? "" : "s");
    return buf;
}

/* `bench --denoiser`: the run layer's rn_bench_backend (the real-time frame back to back, each
 * pass against its bandwidth floor) as a table or JSON on stdout. */
static tnd_result bench_pipeline(const rn_bench_backend_opts *o, const char *scene_path, bool json)
{
    rn_bench_backend_result *r = malloc(sizeof *r);
    if (!r)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
    tnd_result res = rn_bench_backend(o, r);
    if (res != TND_OK) {
        free(r);
        return res;
    }
    const uint32_t np = r->npasses, nfe = r->nfrontend;
    if (json) {
        cJSON *j = cJSON_CreateObject();
        cJSON_AddStringToObject(j, "frontend", o->frontend);
        cJSON_AddStringToObject(j, "denoiser", r->denoiser);
        cJSON_AddStringToObject(j, "precision", tnd_precision_name(o->precision));
        cJSON_AddStringToObject(j, "scene", scene_path);
        cJSON_AddStringToObject(j, "frontend_models", r->models);
        cJSON_AddStringToObject(j, "device", r->device);
        cJSON_AddNumberToObject(j, "width", o->size[0]);
        cJSON_AddNumberToObject(j, "height", o->size[1]);
        bench_bounces_json(j, o->bounces);
        cJSON_AddNumberToObject(j, "frames", r->frames);
        cJSON_AddNumberToObject(j, "copy_bandwidth_gb_per_s", r->bandwidth_gb_s);
        cJSON_AddNumberToObject(j, "transfer_copy_gb_per_s", r->transfer_gb_s);
        cJSON_AddNumberToObject(j, "compute_copy_gb_per_s", r->compute_gb_s);
        cJSON_AddNumberToObject(j, "copy_mib", r->copy_mib);
        for (uint32_t k = nfe; k < np; k++)
            if (r->pass[k].beside[0]) { /* e.g. "lf_beside_atrous" */
                char key[128];
                snprintf(key, sizeof key, "%s_beside_%s", r->pass[k].id, r->pass[k].beside);
                cJSON_AddBoolToObject(j, key, r->beside);
            }
        cJSON *passes = cJSON_AddObjectToObject(j, "passes");
        for (uint32_t k = 0; k < np; k++) {
            const rn_bench_pass *q = &r->pass[k];
            if (q->timed_beside)
                continue; /* in the pass it ran beside */
            cJSON *x = cJSON_AddObjectToObject(passes, q->name);
            cJSON_AddNumberToObject(x, "median_ms", q->ms);
            if (q->bytes > 0) {
                cJSON_AddNumberToObject(x, "bytes", q->bytes);
                cJSON_AddNumberToObject(x, "floor_ms", rn_bench_floor_ms(r, q->bytes));
            }
        }
        cJSON_AddNumberToObject(cJSON_AddObjectToObject(passes, "frame_wall"), "median_ms",
                                r->wall_ms);
        if (r->ndispatches) {
            cJSON *dd = cJSON_AddArrayToObject(j, "dispatches");
            for (uint32_t k = 0; k < r->ndispatches; k++) {
                cJSON *x = cJSON_CreateObject();
                cJSON_AddStringToObject(x, "name", r->dispatch[k].name);
                cJSON_AddNumberToObject(x, "median_ms", r->dispatch[k].ms);
                cJSON_AddItemToArray(dd, x);
            }
        }
        cJSON_AddNumberToObject(j, "backend_ms", r->backend_ms);
        cJSON_AddNumberToObject(j, "backend_bytes", r->backend_bytes);
        cJSON_AddNumberToObject(j, "backend_floor_ms", rn_bench_floor_ms(r, r->backend_bytes));
        char *txt = cJSON_Print(j);
        printf("%s\n", txt);
        free(txt);
        cJSON_Delete(j);
        free(r);
        return TND_OK;
    }
    char bw[48];
    printf("bench %s + %s (%s contract): %s, %ux%u, 1 spp, %s, %u frames back to back\n",
           o->frontend, r->denoiser, tnd_precision_name(o->precision), scene_path, o->size[0],
           o->size[1], bounces_words(o->bounces, bw, sizeof bw), r->frames);
    printf("  device %s; copy bandwidth (%.0f MiB, bytes read + written): compute copy %.0f "
           "GB/s, vkCmdCopyBuffer %.0f GB/s\n",
           r->device, r->copy_mib, r->compute_gb_s, r->transfer_gb_s);
    printf("  front-end shaders model: %s\n", r->models);
    printf("  %-18s %9s %10s %9s %8s\n", "pass", "GPU ms", "MB moved", "floor ms", "of floor");
    for (uint32_t k = 0; k < np; k++) {
        const rn_bench_pass *q = &r->pass[k];
        double fl = rn_bench_floor_ms(r, q->bytes);
        if (q->timed_beside)
            printf("  %-18s %9s   (runs beside the %s, timed with it)\n", q->name, "-",
                   q->beside);
        else if (q->bytes > 0)
            printf("  %-18s %9.3f %10.1f %9.3f %7.0f%%\n", q->label, q->ms, q->bytes / 1e6, fl,
                   q->ms > 0 ? 100.0 * fl / q->ms : 0.0);
        else
            printf("  %-18s %9.3f\n", q->name, q->ms);
    }
    printf("  %-18s %9.3f   (wall clock per frame, host work and the gradient round trip "
           "included)\n", "frame", r->wall_ms);
    double bfl = rn_bench_floor_ms(r, r->backend_bytes);
    printf("  %-18s %9.3f %10.1f %9.3f %7.0f%%\n", "back-end total", r->backend_ms,
           r->backend_bytes / 1e6, bfl, r->backend_ms > 0 ? 100.0 * bfl / r->backend_ms : 0.0);
    printf("  (GPU timestamps; medians of %u frames after 3 warm-up frames; \"of floor\" = "
           "floor / measured)\n", r->frames);
    if (r->dispatches_differed)
        printf("  per dispatch: the dispatches differed between frames; not shown\n");
    else if (r->ndispatches) {
        printf("  per dispatch (back-end, each with its own timestamps; the select pass is "
               "above):\n");
        for (uint32_t k = 0; k < r->ndispatches; k++)
            printf("    %-18s %9.3f\n", r->dispatch[k].name, r->dispatch[k].ms);
    }
    free(r);
    return TND_OK;
}

/* ---- bench --soak N ---------------------------------------------------------------------- */
void app_soak_print(const rn_soak_rec *rec, const char *title, const char *scene,
                    const unsigned size[2])
{
    const rn_soak_row *r = rn_soak_rec_row(rec);
    if (title)
        printf("soak: %u frames of %s at %ux%u %s; after a warm-up of %u frames:\n%-8s %-10s "
               "%8s %8s %8s %10s %9s %7s %9s %14s %6s\n",
               r->frames, scene, size[0], size[1], title, r->warmup, "frontend", "denoiser", "fps",
               "RSS MB", "+MB", "KB/frame", "heap +KB", "fds", "vk allocs", "device MB", "");
    char dev[40] = "-";
    if (r->dev_base >= 0)
        snprintf(dev, sizeof dev, "%.1f -> %.1f", r->dev_base, r->dev_end);
    printf("%-8s %-10s %8.1f %8.1f %+8.2f %10.3f %+9.1f %3u->%-3u %4llu->%-4llu %14s %6s\n",
           r->frontend, r->denoiser, r->frames / r->seconds, r->rss_end, r->rss_end - r->rss_base,
           r->rss_kb_per_frame, 1024.0 * (r->heap_end - r->heap_base), r->fds_base, r->fds_end,
           (unsigned long long)r->allocs_base, (unsigned long long)r->allocs_end, dev,
           r->flat ? "flat" : "GROWS");
}

typedef struct soak_out {
    cJSON *runs; /* --json: the runs' objects; else rows printed as they end */
    const char *scene;
    const unsigned *size;
    bool first;
} soak_out;

static void on_soak_run(const rn_soak_rec *rec, void *user)
{
    soak_out *so = user;
    if (so->runs)
        cJSON_AddItemToArray(so->runs, rn_soak_rec_json(rec));
    else
        app_soak_print(rec, so->first ? "per front-end and denoiser" : NULL, so->scene, so->size);
    so->first = false;
}

static int bench_soak(const char *scene, const rn_env *env, const unsigned size[2],
                      unsigned frames, const char *frontend, const char *denoiser, bool json)
{
    cJSON *root = json ? cJSON_CreateObject() : NULL;
    soak_out so = {.scene = scene, .size = size, .first = true};
    if (root) {
        cJSON_AddStringToObject(root, "scene", scene);
        cJSON_AddNumberToObject(root, "frames", frames);
        cJSON_AddNumberToObject(root, "width", size[0]);
        cJSON_AddNumberToObject(root, "height", size[1]);
        so.runs = cJSON_AddArrayToObject(root, "runs");
    }
    rn_soak_opts o = {.scene = scene, .env = *env, .size = {size[0], size[1]}, .frames = frames,
                      .frontend = frontend, .denoiser = denoiser, .on_run = on_soak_run,
                      .user = &so};
    rn_host h = app_host();
    bool flat = false;
    tnd_result res = rn_soak(&o, &h, &flat);
    if (root && (res == TND_OK || res == TND_ERR_INTERRUPTED)) {
        cJSON_AddBoolToObject(root, "flat", flat);
        char *t = cJSON_Print(root);
        printf("%s\n", t ? t : "{}");
        free(t);
    }
    cJSON_Delete(root);
    return app_finish("bench", res);
}

/* ---- bench --extremes --------------------------------------------------------------------- */
/* exit 1 when any output or buffer holds a NaN or an Inf */
static int bench_extremes(const char *scene, const char *out, const unsigned size[2],
                          unsigned frames)
{
    if (!out || strlen(out) > 900) {
        fprintf(stderr, "tandem bench: --extremes needs --out DIR (a short path)\n");
        return APP_EXIT_USAGE;
    }
    rn_host h = app_host();
    ev_text summary = {0};
    uint64_t bad = 0;
    tnd_result res = rn_extremes(scene, out, size, frames, &h, &summary, &bad);
    if (res == TND_OK && summary.s)
        fputs(summary.s, stdout);
    ev_text_free(&summary);
    if (res != TND_OK)
        return app_finish("bench", res);
    return bad ? APP_EXIT_FAIL : APP_EXIT_OK;
}

int cmd_bench(int argc, char **argv)
{
    const char *scene_path = TND_DATA_DIR "/scenes/cornell.gltf", *frontend = NULL;
    unsigned size[2] = {0, 0}, repeats = 10, threads = 0, bounces = 1, frame = 0, soak = 0;
    bool json = false, extremes = false, scene_given = false, per_dispatch = false;
    bool overlap = false, whole_frame = false, metrics = false;
    const char *rt_api = "auto", *denoiser = NULL, *precision = "float32", *pipeline = "scene";
    const char *out = NULL, *reference = NULL, *lights = "auto";
    app_list sweeps = {0};
    unsigned frames = 12, warmup = 4, spp = 64, ref_shards = 0, timed = 24;
    const char *emit = NULL;
    rn_env env = RN_ENV_INIT; /* (--overlap and --denoiser: the whole frame or the back-end) */
    char dn_help[300];
    snprintf(dn_help, sizeof dn_help,
             "with --frontend vk: time the whole frame with this denoiser (%s, plugin:PATH.so or "
             "python:MODULE:CALLABLE)",
             pl_denoiser_names());
    const app_opt opts[] = {
        {"denoiser", APP_OPT_STRING, &denoiser, "NAME", dn_help},
        {"precision", APP_OPT_STRING, &precision, "P", "contract precision: float32 or packed"},
        {"overlap", APP_OPT_FLAG, &overlap, NULL,
         "the whole frame (front-end, back-end, post) back to back with the contract brought to "
         "the host, kept on the GPU, and with frames not waited for: wall ms and ratios"},
        {"whole-frame", APP_OPT_FLAG, &whole_frame, NULL,
         "the whole frame back to back (front-end, gradients, back-end, post): GPU timestamps "
         "per pass and wall clock, medians after warm-up; --overlap without its host-contract "
         "way"},
        {"metrics", APP_OPT_FLAG, &metrics, NULL,
         "what eval's metrics of one frame of --size cost (wall and CPU ms per metric, medians "
         "of --repeats; --threads)"},
        {"per-dispatch", APP_OPT_FLAG, &per_dispatch, NULL,
         "with --denoiser: also time every back-end dispatch (each a-trous iteration, ...)"},
        {"rt-api", APP_OPT_STRING, &rt_api, "API", "vk: pipeline, query or auto"},
        {"lights", APP_OPT_STRING, &lights, "auto|plain|tree|restir",
         "--whole-frame, --overlap: how next-event estimation picks its light (as render's; "
         "default auto: by the scene)"},
        {"pipeline", APP_OPT_STRING, &pipeline, "scene|full",
         "vk: shaders model only what the scene requires (default) or everything"},
        {"scene", APP_OPT_STRING, &scene_path, "PATH", "glTF scene or stress:N (default: cornell)"},
        {"frontend", APP_OPT_STRING, &frontend, "NAME",
         "a registered front-end that benchmarks its rays or fills the contract on the GPU "
         "(embree, vk; the rays are counted with Embree)"},
        {"size", APP_OPT_SIZE, size, "WxH", "image size (default 256x256)"},
        {"repeats", APP_OPT_UINT, &repeats, "N", "timed repetitions (default 10)"},
        {"threads", APP_OPT_UINT, &threads, "N", "CPU threads (default: all cores)"},
        {"bounces", APP_OPT_BOUNCES, &bounces, "N|half",
         "indirect bounces (default 1; half: as render --bounces half)"},
        {"frame", APP_OPT_UINT, &frame, "F", "frame of the camera path (default 0)"},
        {"json", APP_OPT_FLAG, &json, NULL, "print the results as JSON"},
        {"sweep", APP_OPT_LIST, &sweeps, "KEY=V1,V2,...",
         "run the pipeline over every combination of knob values (repeatable; keys: bounces, "
         "every denoiser parameter (atrous, min-alpha or alpha, antilag, lf-sigma: tandem info "
         "--pipeline), gradient, denoiser, precision, taa, scale, render-scale, upscaler, frontend); needs --out"},
        {"out", APP_OPT_STRING, &out, "DIR",
         "--sweep, --extremes: where runs, tables and the report go"},
        {"reference", APP_OPT_STRING, &reference, "REFDIR",
         "--sweep: references (default: rendered into DIR/reference with --spp)"},
        {"spp", APP_OPT_UINT, &spp, "K",
         "--sweep: samples per pixel of the reference (default 64)"},
        {"frames", APP_OPT_UINT, &frames, "N", "--sweep: frames per run (default 12)"},
        {"soak", APP_OPT_UINT, &soak, "N",
         "N frames through render's loop per front-end and denoiser (--frontend, --denoiser: one "
         "of each), sampling host memory, open descriptors and device memory: flat after a "
         "warm-up? (--json: every sample)"},
        {"extremes", APP_OPT_FLAG, &extremes, NULL,
         "numerical stability report: the extremes scene (or --scene) through every mode; needs "
         "--out"},
        {"warmup", APP_OPT_UINT, &warmup, "W",
         "--sweep: frames left out of times and metrics (default 4)"},
        {"timed-frames", APP_OPT_UINT, &timed, "N",
         "--sweep: each cell's times from N frames back to back after its frames (render "
         "--timed-frames; default 24; 0: from its frames, each waited for)"},
        APP_ENV_OPTS(&env),
        {"opaque", APP_OPT_FLAG, &env.opaque, NULL,
         "alpha-tested (cut-out) materials made opaque: against a run without it, what the "
         "any-hit tests cost (the image differs: leaves become solid)"},
        {"emit", APP_OPT_STRING, &emit, "slurm",
         "--sweep: write the sweep as Slurm jobs (DIR/slurm/submit.sh: reference shards, their "
         "merge, matched references, one array task per cell, collect) instead of running it; "
         "DIR: --out, or given after --emit slurm"},
        {"ref-shards", APP_OPT_UINT, &ref_shards, "N",
         "--emit slurm: the unbiased reference in N shards (default: one per frame, at most 64)"},
        {0},
    };
    const char *pos[1];
    int npos;
    int rc = app_parse(&bench_cmd, opts, argc, argv, pos, 1, &npos);
    if (rc >= 0)
        return rc;
    /* (--soak: every front-end unless one is named, its own default size) */
    const char *soak_frontend = frontend;
    const unsigned soak_size[2] = {size[0] ? size[0] : 160, size[1] ? size[1] : 90};
    if (!frontend)
        frontend = "embree";
    if (!size[0])
        size[0] = size[1] = 256;
    if (npos && (!emit || out)) { /* (--emit slurm DIR) */
        fprintf(stderr, "tandem bench: unexpected argument '%s' (see tandem bench --help)\n",
                pos[0]);
        return APP_EXIT_USAGE;
    }
    if (npos)
        out = pos[0];
    if (repeats == 0) { /* (a median of nothing is no measurement) */
        fprintf(stderr, "tandem bench: --repeats 0: expected at least 1\n");
        return APP_EXIT_USAGE;
    }
    /* a GPU front-end is timed on the rays the CPU one counts; a CPU one benchmarks itself */
    uint32_t fe_caps = pl_frontend_caps_of(frontend);
    bool use_vk = (fe_caps & PL_CAP_GPU_CONTRACT) != 0;
    if (!use_vk && !(fe_caps & PL_CAP_BENCHMARK)) {
        fprintf(stderr, "tandem bench: --frontend '%s': expected a registered front-end that "
                        "fills the contract on the GPU or benchmarks its rays (%s)\n",
                frontend, pl_frontend_live_names());
        return APP_EXIT_USAGE;
    }
    if (strcmp(pipeline, "scene") != 0 && strcmp(pipeline, "full") != 0) {
        fprintf(stderr, "tandem bench: --pipeline %s: expected scene or full\n", pipeline);
        return APP_EXIT_USAGE;
    }
    bool full = strcmp(pipeline, "full") == 0;
    tnd_result res = TND_OK;
    scene_given = strcmp(scene_path, TND_DATA_DIR "/scenes/cornell.gltf") != 0;
    if (metrics) {
        if ((res = app_bench_metrics(size, repeats ? repeats : 1, threads, json)) != TND_OK) {
            app_report("bench", res);
            return APP_EXIT_FAIL;
        }
        return APP_EXIT_OK;
    }
    if (soak) /* (every front-end and denoiser unless named; 160x90 unless given) */
        return bench_soak(scene_path, &env, soak_size, soak, soak_frontend, denoiser, json);
    if (extremes)
        return bench_extremes(scene_given ? scene_path : TND_DATA_DIR "/scenes/extremes.gltf",
                              out, size, frames);
    if (sweeps.n)
        return app_sweep(&(rn_sweep_opts){.sweeps = sweeps.v, .nsweeps = sweeps.n,
                                           .scene = scene_path, .env = env, .out = out,
                                           .reference = reference, .spp = spp,
                                           .size = {size[0], size[1]}, .frames = frames,
                                           .warmup = warmup, .timed = timed, .emit = emit,
                                           .shards = ref_shards ? ref_shards
                                                     : frames < 64 ? frames : 64});
    const pl_denoiser_info *dn = NULL;
    if (overlap || whole_frame) {
        tnd_precision prec;
        tnd_light_sampling pick;
        if ((res = pl_denoiser_find(denoiser ? denoiser : "svgf", &dn)) != TND_OK ||
            (res = tnd_precision_parse(precision, &prec)) != TND_OK) {
            app_report("bench", res);
            return APP_EXIT_USAGE;
        }
        if (!tnd_light_sampling_parse(lights, &pick)) {
            fprintf(stderr, "tandem bench: --lights %s: expected auto, plain, tree or restir\n",
                    lights);
            return APP_EXIT_USAGE;
        }
        tnd_scene *sc = NULL;
        res = rn_scene_load(scene_path, &env, &sc);
        if (res == TND_OK)
            res = app_bench_whole_frame(
                &(rn_whole_frame_opts){.scene = sc, .frontend = frontend,
                                       .size = {size[0], size[1]}, .bounces = bounces,
                                       .blocks = repeats, .denoiser = denoiser ? denoiser : "svgf",
                                       .precision = prec, .lights = pick, .with_host = overlap},
                json);
        tnd_scene_destroy(sc);
        if (res != TND_OK) {
            app_report("bench", res);
            return APP_EXIT_FAIL;
        }
        return APP_EXIT_OK;
    }
    if (denoiser) {
        tnd_precision prec;
        if (!use_vk) {
            fprintf(stderr, "tandem bench: --denoiser needs --frontend vk (the back-end runs on the "
                            "GPU; back-to-back timings of the CPU front-end are `tandem bench`'s)\n");
            return APP_EXIT_USAGE;
        }
        if ((res = pl_denoiser_find(denoiser, &dn)) != TND_OK ||
            (res = tnd_precision_parse(precision, &prec)) != TND_OK) {
            app_report("bench", res);
            return APP_EXIT_USAGE;
        }
        tnd_scene *sc = NULL;
        res = rn_scene_load(scene_path, &env, &sc);
        if (res == TND_OK)
            res = bench_pipeline(
                &(rn_bench_backend_opts){.scene = sc, .frontend = frontend,
                                         .size = {size[0], size[1]}, .frame = frame,
                                         .bounces = bounces, .repeats = repeats, .rt_api = rt_api,
                                         .full_pipeline = full, .denoiser = denoiser,
                                         .precision = prec, .per_dispatch = per_dispatch},
                scene_path, json);
        tnd_scene_destroy(sc);
        if (res != TND_OK) {
            app_report("bench", res);
            return APP_EXIT_FAIL;
        }
        return APP_EXIT_OK;
    }
    rn_bench_frontend_result r;
    res = rn_bench_frontend(&(rn_bench_frontend_opts){.scene = scene_path, .frontend = frontend,
                                                      .size = {size[0], size[1]}, .frame = frame,
                                                      .bounces = bounces, .repeats = repeats,
                                                      .rt_api = rt_api, .full_pipeline = full,
                                                      .threads = threads},
                            &r);
    if (res != TND_OK) {
        app_report("bench", res);
        return APP_EXIT_FAIL;
    }
    const pl_bench b = r.b;
    double frame_ms = r.frame_ms;
    double fe_rate = b.rays / (frame_ms * 1e3);
    double raw_rate = b.raw_ms > 0 ? b.rays / (b.raw_ms * 1e3) : 0;
    if (json) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "frontend", frontend);
        cJSON_AddStringToObject(o, "scene", scene_path);
        cJSON_AddNumberToObject(o, "triangles", (double)r.triangles);
        if (use_vk)
            cJSON_AddStringToObject(o, "device", r.device);
        cJSON_AddNumberToObject(o, "width", size[0]);
        cJSON_AddNumberToObject(o, "height", size[1]);
        cJSON_AddNumberToObject(o, "threads", r.threads);
        if (!use_vk)
            cJSON_AddStringToObject(o, "simd", r.simd);
        bench_bounces_json(o, bounces);
        cJSON_AddNumberToObject(o, "rays_per_frame", (double)b.rays);
        cJSON_AddNumberToObject(o, "primary_ms", b.primary_ms);
        cJSON_AddNumberToObject(o, "shade_ms", b.shade_ms);
        cJSON_AddNumberToObject(o, "frame_ms", frame_ms);
        cJSON_AddNumberToObject(o, "frontend_mrays_per_s", fe_rate);
        cJSON_AddNumberToObject(o, "raw_ms", b.raw_ms);
        cJSON_AddNumberToObject(o, "raw_mrays_per_s", raw_rate);
        if (!use_vk) {
            cJSON_AddNumberToObject(o, "primary_rays_per_frame", (double)b.primary_rays);
            cJSON_AddNumberToObject(o, "raw_primary_ms", b.raw_primary_ms);
        }
        if (raw_rate > 0)
            cJSON_AddNumberToObject(o, "frontend_over_raw", fe_rate / raw_rate);
        cJSON_AddNumberToObject(o, "build_s", r.build_s);
        char *txt = cJSON_Print(o);
        printf("%s\n", txt);
        free(txt);
        cJSON_Delete(o);
    } else {
        char bw[48];
        if (use_vk)
            printf("device: %s\n", r.device);
        printf("bench %s: %s, %llu triangles, %ux%u, 1 spp, %s%s\n", frontend, scene_path,
               (unsigned long long)r.triangles, size[0], size[1],
               bounces_words(bounces, bw, sizeof bw), use_vk ? " (GPU timestamps)" : "");
        printf("  scene load %.2f s, BVH build %.2f s\n", r.load_s, r.build_s);
        if (!use_vk)
            printf("  %u threads, estimator lanes in %s\n", r.threads, r.simd);
        printf("  rays per frame    %llu (primary, shadow and bounce rays)\n",
               (unsigned long long)b.rays);
        printf("  primary pass      %8.2f ms%s\n  shading pass      %8.2f ms%s\n", b.primary_ms,
               use_vk ? "" : " (alone)", b.shade_ms, use_vk ? "" : " (alone)");
        printf("  front-end frame   %8.2f ms  %7.2f Mrays/s%s\n", frame_ms, fe_rate,
               use_vk ? "" : " (both passes in one sweep)");
        if (!use_vk) {
            printf("  raw Embree loop   %8.2f ms  %7.2f Mrays/s (same rays, rtcIntersect1/rtcOccluded1)\n",
                   b.raw_ms, raw_rate);
            printf("    of which        %8.2f ms for the primary pass's %llu rays "
                   "(replayed alone)\n",
                   b.raw_primary_ms, (unsigned long long)b.primary_rays);
            printf("  front-end / raw   %7.1f%%  (goal: above 60%%; primary pass %.1f%%, "
                   "shading pass %.1f%%)\n",
                   100.0 * fe_rate / raw_rate, 100.0 * b.raw_primary_ms / b.primary_ms,
                   100.0 * (b.raw_ms - b.raw_primary_ms) / b.shade_ms);
        }
        printf("  (medians of %u repetitions after a warm-up)\n", repeats);
    }
    return APP_EXIT_OK;
}
