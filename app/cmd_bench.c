/* app/cmd_bench.c: `tandem bench`: front-end throughput on one scene (Mrays/s, ms per frame)
 * beside a raw ray-casting loop over the same rays; with --denoiser, the real-time frame (GPU
 * front-end, gradient round trip, the denoiser) back to back, each of the chain's passes
 * (pl_chain_passes) against the memory-bandwidth floor; --overlap / --whole-frame, the whole
 * frame three ways; --sweep (cmd_sweep.c) and --extremes (cmd_extremes.c). */
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

/* --bounces as the frame parameters (a count, or RN_BOUNCES_HALF: 1 at half resolution), in
 * JSON and in words */
static pl_params bench_params(unsigned bounces)
{
    bool half;
    unsigned n = rn_bounces_split(bounces, &half);
    return (pl_params){.bounces = n, .half_indirect = half};
}

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

static tnd_result bench_vk(const tnd_scene *s, const char *fe_name, const tnd_scene_state *st,
                           unsigned frame,
                           const unsigned size[2], unsigned bounces, unsigned repeats,
                           const char *rt_api, bool full, pl_bench *b, double *t_build)
{
    tnd_result res = TND_OK;
    tnd_vk vk = {0};
    pl_frontend *gv = NULL;
    double *tp = calloc(repeats + 1, sizeof *tp), *ts = calloc(repeats + 1, sizeof *ts);
    if (!tp || !ts) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        goto fail;
    }
    TND_TRY(tnd_vk_create(&(tnd_vk_desc){0}, &vk));
    double t0 = tnd_now();
    TND_TRY(pl_frontend_create(fe_name, s,
                               &(pl_frontend_desc){.vk = &vk, .rt_api = rt_api,
                                                   .full_pipeline = full},
                               &gv));
    TND_TRY(pl_frontend_set_frame(gv, st, st, frame, size[0], size[1]));
    *t_build = tnd_now() - t0;
    for (int w = 0; w < 3; w++)
        TND_TRY(pl_frontend_render(gv, (pl_params[]){bench_params(bounces)}, NULL, NULL));
    for (unsigned r = 0; r < repeats; r++) {
        pl_timings tm;
        TND_TRY(pl_frontend_render(gv, (pl_params[]){bench_params(bounces)}, NULL, &tm));
        tp[r] = tm.primary_ms;
        ts[r] = tm.shade_ms;
    }
    b->primary_ms = rn_median(tp, repeats);
    b->shade_ms = rn_median(ts, repeats);
    b->raw_ms = 0;
    char who[300];
    printf("device: %s\n", pl_frontend_describe(gv, who, sizeof who));
fail:
    free(tp);
    free(ts);
    pl_frontend_destroy(gv);
    tnd_vk_destroy(&vk);
    return res;
}

/* The real-time frame back to back: no file is written between frames, so the GPU stays busy
 * (and its clocks up) as in an application. Every pass of the chain (pl_chain_passes: the
 * front-end's and the denoiser's) and the wall clock per frame; the denoiser's passes against
 * their bandwidth floor. */
static tnd_result bench_pipeline(const tnd_scene *s, const char *scene_path, const char *fe_name,
                                 unsigned frame,
                                 const unsigned size[2], unsigned bounces, unsigned repeats,
                                 const char *rt_api, bool full, const char *denoiser,
                                 tnd_precision prec, bool json, bool per_dispatch)
{
    tnd_result res = TND_OK;
    tnd_vk vk = {0};
    pl_frontend *gv = NULL;
    pl_chain *chain = NULL;
    dn_context *dn = NULL; /* (the chain's, for the built-in back-end's per-dispatch times) */
    tnd_scene_state st[2] = {{0}};
    enum { WARM = 3, MAXP = 32 };
    const pl_pass *pass[MAXP];
    uint32_t np = 0, nfe = 0; /* passes; the front-end's come first */
    double *v[MAXP + 1] = {0}, *dv = NULL; /* v[np]: the wall clock; dv: per dispatch */
    bool beside = false; /* the denoiser ran a pass beside another (timed with it) */
    TND_TRY(tnd_vk_create(&(tnd_vk_desc){0}, &vk));
    TND_TRY(pl_frontend_create(fe_name, s,
                               &(pl_frontend_desc){.vk = &vk, .precision = prec, .rt_api = rt_api,
                                                   .full_pipeline = full},
                               &gv));
    TND_TRY(pl_chain_create(&(pl_chain_desc){.vk = &vk, .width = size[0], .height = size[1],
                                             .precision = prec, .backend = true,
                                             .denoiser = denoiser,
                                             .denoise = {.dispatch_timing = per_dispatch},
                                             .no_post = true},
                            &chain));
    dn = pl_chain_denoiser(chain);
    np = pl_chain_passes(chain, pass, MAXP); /* (no post chain: the denoiser's come last) */
    nfe = np - pl_chain_denoiser_info(chain)->npasses;
    for (uint32_t k = 0; k <= np; k++)
        if (!(v[k] = calloc(repeats, sizeof(double)))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
            goto fail;
        }
    /* per dispatch (--per-dispatch): times of each dispatch over the timed frames, when the
     * sequence of dispatches is the same every frame (it is after the first) */
    enum { MAXD = TND_TIMER_MAX_PASSES };
    const char *dnames[MAXD] = {0};
    uint32_t nd = 0;
    bool d_same = true;
    per_dispatch = per_dispatch && dn;
    if (per_dispatch && !(dv = calloc((size_t)MAXD * repeats, sizeof(double)))) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        goto fail;
    }
    float aspect = (float)size[0] / size[1];
    pl_params fp = bench_params(bounces);
    for (unsigned i = 0; i < WARM + repeats; i++) {
        unsigned f = frame + i;
        tnd_scene_state *cur = &st[i & 1], *prev = &st[(i + 1) & 1];
        TND_TRY(tnd_scene_evaluate(s, f / 30.0, 0, aspect, cur));
        if (i == 0)
            TND_TRY(tnd_scene_evaluate(s, f ? (f - 1) / 30.0 : 0.0, 0, aspect, prev));
        double t0 = tnd_now();
        TND_TRY(pl_frontend_set_frame(gv, cur, prev, f, size[0], size[1]));
        pl_step step = {.params = fp,
                        .frame = dn_frame_for_camera(cur->camera.proj, size[1], f, i == 0)};
        pl_step_result pr;
        TND_TRY(pl_chain_run(chain, gv, &step, NULL, NULL, &pr));
        double wall = 1e3 * (tnd_now() - t0), ms[MAXP];
        beside = pr.beside;
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
    double bytes[MAXP] = {0}, dbytes[PL_DN_MAX_PASSES];
    pl_chain_traffic(chain, dbytes);
    char name[MAXP][64], label[MAXP][96]; /* timings.json's key without _ms; the table's */
    for (uint32_t k = 0; k < np; k++) {
        snprintf(name[k], sizeof name[k], "%.*s", (int)strlen(pass[k]->key) - 3, pass[k]->key);
        snprintf(label[k], sizeof label[k], "%s", name[k]);
        if (k >= nfe)
            bytes[k] = dbytes[k - nfe];
    }
    for (uint32_t k = nfe; beside && k < np; k++)
        for (uint32_t j = nfe; pass[k]->beside && j < np; j++)
            if (strcmp(pass[j]->name, pass[k]->beside) == 0) {
                bytes[j] += bytes[k];
                bytes[k] = 0;
                snprintf(label[j] + strlen(label[j]), sizeof label[j] - strlen(label[j]), "+%s",
                         pass[k]->name);
            }
    double traffic = 0;
    for (uint32_t k = nfe; k < np; k++)
        traffic += bytes[k];
    /* the copy bandwidth, measured now that the GPU is warm: 8x the back-end's traffic per
     * frame, between 64 MiB and 1 GiB (larger than any cache) */
    double copy_mib = fmin(1024.0, fmax(64.0, 8.0 * traffic / (1 << 20)));
    double transfer_bw = 0, compute_bw = 0;
    TND_TRY(rn_bandwidth(&vk, (VkDeviceSize)copy_mib << 20, 9, &transfer_bw, &compute_bw));
    double bandwidth = fmax(transfer_bw, compute_bw); /* the floor: the faster of the two */
    double med[MAXP + 1];
    for (uint32_t k = 0; k <= np; k++)
        med[k] = rn_median(v[k], repeats);
    double backend = 0, backend_bytes = 0;
    for (uint32_t k = nfe; k < np; k++)
        backend += med[k], backend_bytes += bytes[k];
    /* beside: the pass ran beside another and is timed with it */
#define IS_BESIDE(k) (beside && pass[k]->beside && (k) >= nfe)
    /* floor: bytes / bandwidth, in ms */
#define FLOOR(b) (bandwidth > 0 ? (b) / (bandwidth * 1e9) * 1e3 : 0.0)
    const char *dn_name = pl_chain_denoiser_info(chain)->name;
    if (json) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "frontend", fe_name);
        cJSON_AddStringToObject(o, "denoiser", dn_name);
        cJSON_AddStringToObject(o, "precision", tnd_precision_name(prec));
        cJSON_AddStringToObject(o, "scene", scene_path);
        cJSON_AddStringToObject(o, "frontend_models", pl_frontend_models(gv));
        cJSON_AddStringToObject(o, "device", vk.info.name);
        cJSON_AddNumberToObject(o, "width", size[0]);
        cJSON_AddNumberToObject(o, "height", size[1]);
        bench_bounces_json(o, bounces);
        cJSON_AddNumberToObject(o, "frames", repeats);
        cJSON_AddNumberToObject(o, "copy_bandwidth_gb_per_s", bandwidth);
        cJSON_AddNumberToObject(o, "transfer_copy_gb_per_s", transfer_bw);
        cJSON_AddNumberToObject(o, "compute_copy_gb_per_s", compute_bw);
        cJSON_AddNumberToObject(o, "copy_mib", copy_mib);
        for (uint32_t k = nfe; k < np; k++)
            if (pass[k]->beside) { /* e.g. "lf_beside_atrous" */
                char key[128];
                snprintf(key, sizeof key, "%s_beside_%s", pass[k]->name, pass[k]->beside);
                cJSON_AddBoolToObject(o, key, beside);
            }
        cJSON *passes = cJSON_AddObjectToObject(o, "passes");
        for (uint32_t k = 0; k <= np; k++) {
            if (k < np && IS_BESIDE(k))
                continue; /* in the pass it ran beside */
            cJSON *q = cJSON_AddObjectToObject(passes, k < np ? name[k] : "frame_wall");
            cJSON_AddNumberToObject(q, "median_ms", med[k]);
            if (k < np && bytes[k] > 0) {
                cJSON_AddNumberToObject(q, "bytes", bytes[k]);
                cJSON_AddNumberToObject(q, "floor_ms", FLOOR(bytes[k]));
            }
        }
        if (per_dispatch && d_same) {
            cJSON *dd = cJSON_AddArrayToObject(o, "dispatches");
            for (uint32_t k = 0; k < nd; k++) {
                cJSON *q = cJSON_CreateObject();
                cJSON_AddStringToObject(q, "name", dnames[k]);
                cJSON_AddNumberToObject(q, "median_ms", rn_median(dv + (size_t)k * repeats, repeats));
                cJSON_AddItemToArray(dd, q);
            }
        }
        cJSON_AddNumberToObject(o, "backend_ms", backend);
        cJSON_AddNumberToObject(o, "backend_bytes", backend_bytes);
        cJSON_AddNumberToObject(o, "backend_floor_ms", FLOOR(backend_bytes));
        char *txt = cJSON_Print(o);
        printf("%s\n", txt);
        free(txt);
        cJSON_Delete(o);
    } else {
        char bw[48];
        printf("bench %s + %s (%s contract): %s, %ux%u, 1 spp, %s, %u frames back to "
               "back\n", fe_name, dn_name, tnd_precision_name(prec), scene_path, size[0],
               size[1], bounces_words(bounces, bw, sizeof bw), repeats);
        printf("  device %s; copy bandwidth (%.0f MiB, bytes read + written): compute copy %.0f "
               "GB/s, vkCmdCopyBuffer %.0f GB/s\n",
               vk.info.name, copy_mib, compute_bw, transfer_bw);
        printf("  front-end shaders model: %s\n", pl_frontend_models(gv));
        printf("  %-18s %9s %10s %9s %8s\n", "pass", "GPU ms", "MB moved", "floor ms",
               "of floor");
        for (uint32_t k = 0; k <= np; k++) {
            if (k == np)
                printf("  %-18s %9.3f   (wall clock per frame, host work and the gradient "
                       "round trip included)\n", "frame", med[k]);
            else if (IS_BESIDE(k))
                printf("  %-18s %9s   (runs beside the %s, timed with it)\n", name[k], "-",
                       pass[k]->beside);
            else if (bytes[k] > 0)
                printf("  %-18s %9.3f %10.1f %9.3f %7.0f%%\n", label[k], med[k],
                       bytes[k] / 1e6, FLOOR(bytes[k]),
                       med[k] > 0 ? 100.0 * FLOOR(bytes[k]) / med[k] : 0.0);
            else
                printf("  %-18s %9.3f\n", name[k], med[k]);
        }
        printf("  %-18s %9.3f %10.1f %9.3f %7.0f%%\n", "back-end total", backend,
               backend_bytes / 1e6, FLOOR(backend_bytes),
               backend > 0 ? 100.0 * FLOOR(backend_bytes) / backend : 0.0);
        printf("  (GPU timestamps; medians of %u frames after %d warm-up frames; \"of floor\" = "
               "floor / measured)\n", repeats, WARM);
        if (per_dispatch && !d_same)
            printf("  per dispatch: the dispatches differed between frames; not shown\n");
        else if (per_dispatch) {
            printf("  per dispatch (back-end, each with its own timestamps; the select pass is "
                   "above):\n");
            for (uint32_t k = 0; k < nd; k++)
                printf("    %-18s %9.3f\n", dnames[k], rn_median(dv + (size_t)k * repeats, repeats));
        }
    }
#undef FLOOR
#undef IS_BESIDE
fail:
    free(dv);
    for (uint32_t k = 0; k <= MAXP; k++)
        free(v[k]);
    tnd_scene_state_free(&st[0]);
    tnd_scene_state_free(&st[1]);
    pl_chain_destroy(chain);
    pl_frontend_destroy(gv);
    tnd_vk_destroy(&vk);
    return res;
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
            res = bench_pipeline(sc, scene_path, frontend, frame, size, bounces, repeats, rt_api,
                                 full, denoiser, prec, json, per_dispatch);
        tnd_scene_destroy(sc);
        if (res != TND_OK) {
            app_report("bench", res);
            return APP_EXIT_FAIL;
        }
        return APP_EXIT_OK;
    }
    tnd_scene *s = NULL;
    pl_frontend *c = NULL;
    tnd_scene_state st = {0};
    pl_bench b;
    uint32_t threads_used = 0;
    const char *simd = NULL;
    int status = APP_EXIT_FAIL;
    double t_load = tnd_now();
    TND_TRY(tnd_scene_load(scene_path, &s));
    t_load = tnd_now() - t_load;
    double t_build = tnd_now();
    /* the CPU front-end counts the rays (both front-ends trace the same ones) */
    TND_TRY(pl_frontend_create("embree", s, &(pl_frontend_desc){.threads = threads}, &c));
    pl_frontend_cpu(c, &threads_used, &simd);
    TND_TRY(tnd_scene_evaluate(s, frame / 30.0, 0, (float)size[0] / size[1], &st));
    TND_TRY(pl_frontend_set_frame(c, &st, &st, frame, size[0], size[1]));
    t_build = tnd_now() - t_build;
    TND_TRY(pl_frontend_benchmark(c, (pl_params[]){bench_params(bounces)}, use_vk ? 1 : repeats,
                                  &b));
    if (use_vk) {
        /* the GPU traces exactly the rays the Embree front-end counted (same random numbers,
         * same decisions): time its passes with timestamps, medians after a warm-up */
        TND_TRY(bench_vk(s, frontend, &st, frame, size, bounces, repeats, rt_api, full, &b, &t_build));
    }
    /* Embree: the frame as its render sweeps it (both passes batch by batch); the GPU: its two
     * passes' timestamps */
    double frame_ms = use_vk ? b.primary_ms + b.shade_ms : b.frame_ms;
    double fe_rate = b.rays / (frame_ms * 1e3);
    double raw_rate = b.raw_ms > 0 ? b.rays / (b.raw_ms * 1e3) : 0;
    if (json) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "frontend", frontend);
        cJSON_AddStringToObject(o, "scene", scene_path);
        cJSON_AddNumberToObject(o, "triangles", (double)tnd_scene_triangles(s));
        cJSON_AddNumberToObject(o, "width", size[0]);
        cJSON_AddNumberToObject(o, "height", size[1]);
        cJSON_AddNumberToObject(o, "threads", threads_used);
        if (!use_vk)
            cJSON_AddStringToObject(o, "simd", simd);
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
        cJSON_AddNumberToObject(o, "build_s", t_build);
        char *txt = cJSON_Print(o);
        printf("%s\n", txt);
        free(txt);
        cJSON_Delete(o);
    } else {
        char bw[48];
        printf("bench %s: %s, %llu triangles, %ux%u, 1 spp, %s%s\n", frontend, scene_path,
               (unsigned long long)tnd_scene_triangles(s), size[0], size[1],
               bounces_words(bounces, bw, sizeof bw), use_vk ? " (GPU timestamps)" : "");
        printf("  scene load %.2f s, BVH build %.2f s\n", t_load, t_build);
        if (!use_vk)
            printf("  %u threads, estimator lanes in %s\n", threads_used, simd);
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
    status = APP_EXIT_OK;
fail:
    if (status != APP_EXIT_OK)
        app_report("bench", res);
    tnd_scene_state_free(&st);
    pl_frontend_destroy(c);
    tnd_scene_destroy(s);
    return status;
}
