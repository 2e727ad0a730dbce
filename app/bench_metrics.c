/* app/bench_metrics.c: `tandem bench --metrics`: what eval's metrics of one frame cost, per
 * metric, in wall time and in CPU time (core-seconds: the process's CPU clock over all threads),
 * medians over the repeats after a warm-up. The images are made here (a reference of smooth
 * shading, hard edges and fine texture; an output off it by a per-pixel factor of about 30%), so
 * the figure does not depend on a scene: the metrics' cost depends on the size alone. */
#include "app/app.h"
#include "eval/eval.h"
#include "shaders/sampling.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double cpu_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static float hash01(uint32_t a, uint32_t b)
{
    uint32_t v[4] = {a, b, 0xbe7cu, 0x51u};
    tnd_pcg4d(v);
    return (float)(v[0] >> 8) / 16777216.0f;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

enum { PART_POINTWISE, PART_TONEMAP, PART_SSIM, PART_FLIP, PART_FRAME, PART_WORTH, PARTS };
static const char *const part_name[PARTS] = {
    "relMSE, SMAPE, RMSE", "tone mapping (2 images)", "SSIM", "FLIP",
    "the whole frame (ev_sequence_add)", "worth N by FLIP (a search)"};

tnd_result app_bench_metrics(const unsigned size[2], unsigned repeats, unsigned threads, bool json)
{
    tnd_result res = TND_OK;
    uint32_t w = size[0], h = size[1];
    size_t n = (size_t)w * h;
    ev_image ref = {0}, out = {0};
    ev_sequence *seq = NULL;
    float *to = malloc(3 * n * sizeof(float)), *tr = malloc(3 * n * sizeof(float));
    float *scratch = malloc(6 * n * sizeof(float)), *motion = calloc(3 * n, sizeof(float));
    float *depth = malloc(n * sizeof(float));
    double *wall = calloc((size_t)2 * PARTS * repeats, sizeof(double));
    double *cpu = calloc((size_t)2 * PARTS * repeats, sizeof(double));
    if (threads)
        omp_set_num_threads((int)threads);
    if (!to || !tr || !scratch || !motion || !depth || !wall || !cpu) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        goto fail;
    }
    TND_TRY(ev_image_alloc(w, h, &ref));
    TND_TRY(ev_image_alloc(w, h, &out));
    if (!(ref.var = malloc(n * sizeof(float)))) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        goto fail;
    }
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t q = (size_t)y * w + x;
            float u = (float)x / w, v = (float)y / h;
            float shade = 0.2f + 0.8f * u * v, edge = ((x / 64 + y / 48) & 1) ? 1.0f : 0.35f;
            float tex = 0.8f + 0.2f * hash01((uint32_t)(x / 3), (uint32_t)(y / 3));
            float c[3] = {shade * edge * tex, 0.7f * shade * tex, (0.3f + 0.7f * v) * edge};
            float f = 1.0f + 0.6f * (hash01((uint32_t)q, 1) - 0.5f);
            for (int k = 0; k < 3; k++)
                ref.rgb[3 * q + k] = c[k], out.rgb[3 * q + k] = c[k] * f;
            ref.var[q] = 0.3f * c[1] * c[1];
            depth[q] = 5.0f;
        }
    double exposure = ev_auto_exposure(&ref, 1);
    TND_TRY(ev_sequence_create(w, h, exposure, EV_FLIP_PPD, &seq));
    ev_tonemap(&ref, exposure, tr);
    ev_tonemap(&out, exposure, to);
    /* the scalar reference code (ev_metrics_reference) and the vectorised code, one after the
     * other in this run: [mode][part][repeat] */
    for (int mode = 0; mode < 2; mode++)
    for (unsigned it = 0; it <= repeats; it++) { /* (iteration 0: the warm-up) */
        ev_metrics_reference(mode == 0);
        for (int p = 0; p < PARTS; p++) {
            double t0 = tnd_now(), c0 = cpu_now(), v;
            ev_frame_metrics m;
            switch (p) {
            case PART_POINTWISE:
                v = ev_relmse(out.rgb, ref.rgb, 3 * n) + ev_smape(out.rgb, ref.rgb, 3 * n) +
                    ev_mse(out.rgb, ref.rgb, 3 * n);
                (void)v;
                break;
            case PART_TONEMAP:
                ev_tonemap(&ref, exposure, tr);
                ev_tonemap(&out, exposure, to);
                break;
            case PART_SSIM:
                TND_TRY(ev_ssim(to, tr, w, h, &v));
                break;
            case PART_FLIP:
                TND_TRY(ev_flip(tr, to, w, h, EV_FLIP_PPD, NULL, &v));
                break;
            case PART_FRAME: /* (with motion: the motion-compensated metrics too) */
                ev_sequence_motion(seq, motion, depth);
                TND_TRY(ev_sequence_add(seq, it, &out, &ref, &m, NULL));
                break;
            case PART_WORTH:
                TND_TRY(ev_worth_flip(&ref, tr, exposure, EV_FLIP_PPD, 0.1, it, scratch, &v));
                break;
            }
            if (it > 0) {
                wall[((size_t)mode * PARTS + p) * repeats + it - 1] = tnd_now() - t0;
                cpu[((size_t)mode * PARTS + p) * repeats + it - 1] = cpu_now() - c0;
            }
        }
    }
    ev_metrics_reference(false);
    if (json)
        printf("{\"width\": %u, \"height\": %u, \"threads\": %d, \"parts\": [", w, h,
               omp_get_max_threads());
    else
        printf("metrics of one %ux%u frame, %d threads, medians of %u: wall and CPU ms of the "
               "scalar reference code, of the vectorised code, and the CPU ratio\n",
               w, h, omp_get_max_threads(), repeats);
    for (int p = 0; p < PARTS; p++) {
        double mw[2], mc[2];
        for (int mode = 0; mode < 2; mode++) {
            double *pw = wall + ((size_t)mode * PARTS + p) * repeats;
            double *pc = cpu + ((size_t)mode * PARTS + p) * repeats;
            qsort(pw, repeats, sizeof(double), cmp_double);
            qsort(pc, repeats, sizeof(double), cmp_double);
            mw[mode] = 1e3 * pw[repeats / 2], mc[mode] = 1e3 * pc[repeats / 2];
        }
        if (json)
            printf("%s{\"part\": \"%s\", \"reference_wall_ms\": %.4g, \"reference_cpu_ms\": "
                   "%.4g, \"wall_ms\": %.4g, \"cpu_ms\": %.4g}",
                   p ? ", " : "", part_name[p], mw[0], mc[0], mw[1], mc[1]);
        else
            printf("  %-36s %9.2f %9.2f  %9.2f %9.2f  %6.2fx\n", part_name[p], mw[0], mc[0], mw[1],
                   mc[1], mc[1] > 0 ? mc[0] / mc[1] : 0.0);
    }
    if (json)
        printf("]");
    else
        printf("\n");
    /* on the device (eval/metrics_gpu.c), where there is one: the passes' GPU time, and the
     * wall time of a frame with its upload and read-back */
    tnd_vk vk = {0};
    ev_gpu *g = NULL;
    tnd_result vr = tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = true}, &vk);
    if (vr == TND_OK)
        vr = ev_gpu_create(&vk, w, h, EV_FLIP_PPD, &g);
    if (vr == TND_OK) {
        double *gw = wall, *gg = cpu, pass[4][64] = {{0}};
        ev_gpu_metrics gm;
        for (unsigned it = 0; it <= repeats && vr == TND_OK; it++) {
            double t0 = tnd_now();
            vr = ev_gpu_frame(g, &out, &ref, exposure, &gm, NULL);
            if (it > 0) {
                gw[it - 1] = tnd_now() - t0, gg[it - 1] = 1e-3 * gm.gpu_ms;
                for (int k = 0; k < 4 && it - 1 < 64; k++)
                    pass[k][it - 1] = gm.pass_ms[k];
            }
        }
        if (vr == TND_OK) {
            unsigned np = repeats < 64 ? repeats : 64;
            qsort(gw, repeats, sizeof(double), cmp_double);
            qsort(gg, repeats, sizeof(double), cmp_double);
            for (int k = 0; k < 4; k++)
                qsort(pass[k], np, sizeof(double), cmp_double);
            if (json)
                printf(", \"device\": \"%s\", \"device_ms\": %.4g, \"device_wall_ms\": %.4g",
                       vk.info.name, 1e3 * gg[repeats / 2], 1e3 * gw[repeats / 2]);
            else
                printf("on the device (%s): the metrics but the temporal ones and worth N, "
                       "%.3f ms of GPU (prep %.3f, rows %.3f, columns %.3f, reduce %.3f), "
                       "%.2f ms a frame with its upload and read-back\n",
                       vk.info.name, 1e3 * gg[repeats / 2], pass[0][np / 2], pass[1][np / 2],
                       pass[2][np / 2], pass[3][np / 2], 1e3 * gw[repeats / 2]);
        }
    }
    if (vr != TND_OK && !json)
        printf("on the device: not measured (%s)\n", tnd_error_detail());
    tnd_error_clear();
    ev_gpu_destroy(g);
    if (vk.device)
        tnd_vk_destroy(&vk);
    if (json)
        printf("}\n");
fail:
    ev_sequence_destroy(seq);
    ev_image_free(&ref);
    ev_image_free(&out);
    free(to);
    free(tr);
    free(scratch);
    free(motion);
    free(depth);
    free(wall);
    free(cpu);
    return res;
}
