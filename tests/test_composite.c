/* tests/test_composite.c: the post chain on lavapipe. Tone mapping: auto exposure makes a scene
 * whose light is 1000x brighter look the same; black, white and NaN inputs give defined output.
 * TAA: on a static scene whose primary rays are jittered, the accumulated image is closer to the
 * supersampled image than one frame is (edges converge); under camera and object motion, no
 * ghost trail outlives 2 frames. Temporal upscaling: edges converge towards the supersampled full
 * size better than the spatial upscalers; a newly visible surface (the depth test) takes no
 * history. Label: gpu. */
#include "composite/composite.h"
#include "frontend_embree/frontend_embree.h"
#include "tests/embree_frame.h"
#include "tests/gpu_common.h"
#include "shaders/sampling.h"

enum { W = 64, H = 36, N = W * H };

/* one frame of the rig's scene through the Embree front-end (frame index i: its jitter) */
static tnd_result render_frame(femb_context *fe, const tnd_scene_state *st, uint32_t i,
                                tnd_frame *f)
{
    return test_embree_frame(fe, st, st, i, W, H, &(femb_params){.bounces = 1}, f);
}

/* cornell through the Embree front-end, a contract for the motion vectors and an HDR input */
typedef struct rig {
    tnd_scene *s;
    femb_context *fe;
    tnd_scene_state st;
    tnd_contract_gpu ct;
    tnd_image in;
} rig;

static tnd_result rig_open_scene(tnd_vk *vk, const char *scene, rig *r)
{
    memset(r, 0, sizeof *r);
    tnd_result res = tnd_scene_load(scene, &r->s);
    if (res == TND_OK)
        res = femb_create(r->s, &(femb_desc){.threads = 2}, &r->fe);
    if (res == TND_OK)
        res = tnd_scene_evaluate(r->s, 0.0, 0, (float)W / H, &r->st);
    if (res == TND_OK)
        res = tnd_contract_gpu_create(vk, W, H, TND_PRECISION_F32, &r->ct);
    if (res == TND_OK)
        res = tnd_image_create(vk, &(tnd_image_desc){.width = W, .height = H,
                                                     .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                     .name = "test.hdr"},
                               &r->in);
    return res;
}

static tnd_result rig_open(tnd_vk *vk, rig *r)
{
    return rig_open_scene(vk, TND_SOURCE_DIR "/data/scenes/cornell.gltf", r);
}

/* The rig on `scene`, its frame 0 rendered into f, composited into rgb and uploaded. */
static tnd_result rig_first_frame(tnd_vk *vk, const char *scene, rig *r, tnd_frame *f, float *rgb)
{
    tnd_result res = rig_open_scene(vk, scene, r);
    if (res == TND_OK)
        res = render_frame(r->fe, &r->st, 0, f);
    if (res == TND_OK) {
        tnd_frame_composite(f, rgb);
        res = tnd_contract_upload(vk, &r->ct, f);
    }
    return res;
}

static void rig_close(tnd_vk *vk, rig *r)
{
    tnd_image_destroy(vk, &r->in);
    tnd_contract_gpu_destroy(vk, &r->ct);
    tnd_scene_state_free(&r->st);
    femb_destroy(r->fe);
    tnd_scene_destroy(r->s);
}

static tnd_result upload_rgb(tnd_vk *vk, const tnd_image *img, const float *rgb, float scale)
{
    static float px[N * 4];
    for (int q = 0; q < N; q++) {
        for (int k = 0; k < 3; k++)
            px[4 * q + k] = rgb[3 * q + k] * scale;
        px[4 * q + 3] = 1.0f;
    }
    return tnd_image_upload(vk, img, px, sizeof px);
}

static double mean_display(const uint8_t *d)
{
    double s = 0;
    for (int q = 0; q < N * 3; q++)
        s += d[q] / 255.0;
    return s / (N * 3);
}

static void test_tonemap_exposure(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    rig r;
    tnd_frame f = {0};
    cmp_context *c = NULL;
    static float rgb[N * 3];
    static uint8_t d1[N * 3], d1000[N * 3];
    REQUIRE_OK(rig_first_frame(vk, TND_SOURCE_DIR "/data/scenes/cornell.gltf", &r, &f, rgb));
    for (int curve = 0; curve < 3; curve++) {
        REQUIRE_OK(cmp_create(vk, W, H, TND_PRECISION_F32, &(cmp_desc){.curve = (cmp_curve)curve},
                              &c));
        /* adapted to the plain scene, then the light x1000: adaptation (3 stops per second up)
         * takes a few seconds of frames to catch up */
        REQUIRE_OK(upload_rgb(vk, &r.in, rgb, 1.0f));
        for (int i = 0; i < 3; i++)
            REQUIRE_OK(cmp_run(c, &r.in, &r.ct, &(cmp_frame){.dt = 1.0f / 30, .reset = i == 0}, NULL));
        REQUIRE_OK(cmp_download_display(c, d1));
        REQUIRE_OK(upload_rgb(vk, &r.in, rgb, 1000.0f));
        REQUIRE_OK(cmp_run(c, &r.in, &r.ct, &(cmp_frame){.dt = 1.0f / 30}, NULL));
        REQUIRE_OK(cmp_download_display(c, d1000));
        double first = mean_display(d1000);
        for (int i = 0; i < 300; i++)
            REQUIRE_OK(cmp_run(c, &r.in, &r.ct, &(cmp_frame){.dt = 1.0f / 30}, NULL));
        REQUIRE_OK(cmp_download_display(c, d1000));
        double m1 = mean_display(d1), m1000 = mean_display(d1000);
        printf("     %s: mean display value %.4f; light x1000: %.4f on the first frame, %.4f "
               "after 10 s (%.2f%% off)\n",
               cmp_curve_name((cmp_curve)curve), m1, first, m1000, 100.0 * fabs(m1000 / m1 - 1));
        CHECK(first > m1 + 0.05, "%s: the first frame after the change is not brighter (%.3f)",
              cmp_curve_name((cmp_curve)curve), first);
        /* exact log averaging: only the dither and 8-bit rounding differ */
        CHECK(fabs(m1000 / m1 - 1) < 0.02, "%s: adapted x1000 scene %.4f against %.4f",
              cmp_curve_name((cmp_curve)curve), m1000, m1);
        cmp_destroy(c);
        c = NULL;
    }
    /* black, white, NaN: defined output */
    REQUIRE_OK(cmp_create(vk, W, H, TND_PRECISION_F32, &(cmp_desc){0}, &c));
    static float special[N * 3];
    for (int q = 0; q < N * 3; q++)
        special[q] = 0.0f;
    REQUIRE_OK(upload_rgb(vk, &r.in, special, 1.0f));
    REQUIRE_OK(cmp_run(c, &r.in, &r.ct, &(cmp_frame){.reset = true}, NULL));
    REQUIRE_OK(cmp_download_display(c, d1));
    int nonzero = 0;
    for (int q = 0; q < N * 3; q++)
        nonzero += d1[q] != 0;
    CHECK(nonzero == 0, "a black image gives %d non-black values", nonzero);
    float e = 0, l = 0;
    REQUIRE_OK(cmp_exposure(c, &e, &l));
    CHECK(isfinite(e) && e > 0, "exposure after a black image: %g", e);
    cmp_destroy(c); /* with TAA, whose history must stay finite */
    c = NULL;
    REQUIRE_OK(cmp_create(vk, W, H, TND_PRECISION_F32, &(cmp_desc){.taa = true}, &c));
    for (int q = 0; q < N * 3; q++)
        special[q] = q % 7 == 0 ? NAN : q % 11 == 0 ? INFINITY : 1e30f;
    REQUIRE_OK(upload_rgb(vk, &r.in, special, 1.0f));
    for (int i = 0; i < 3; i++)
        REQUIRE_OK(cmp_run(c, &r.in, &r.ct, &(cmp_frame){.reset = i == 0}, NULL));
    REQUIRE_OK(cmp_download_display(c, d1));
    static float hdr[N * 3];
    REQUIRE_OK(cmp_download_hdr(c, hdr));
    REQUIRE_OK(cmp_exposure(c, &e, &l));
    int bad = 0;
    for (int q = 0; q < N * 3; q++)
        bad += !isfinite(hdr[q]);
    CHECK(isfinite(e) && isfinite(l), "exposure after NaN / huge input: %g (log2 %g)", e, l);
    CHECK(bad == 0, "%d non-finite HDR values after NaN / Inf input", bad);
    printf("     black -> all 0; NaN / Inf / 1e30 -> finite, exposure %g\n", e);
cleanup:
    cmp_destroy(c);
    tnd_frame_destroy(&f);
    rig_close(vk, &r);
    gpu_end();
}

/* TAA on the albedo (noise-free, so only the pixel filter differs): the reference is the mean
 * of 256 jittered frames, the pixel-area average a supersampled render gives. */
static void test_taa_converges_at_edges(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    rig r;
    tnd_frame f = {0};
    cmp_context *c = NULL;
    static float ref[N * 3], one[N * 3], taa[N * 3], alb[N * 3];
    REQUIRE_OK(rig_open(vk, &r));
    REQUIRE_OK(cmp_create(vk, W, H, TND_PRECISION_F32, &(cmp_desc){.taa = true}, &c));
    const int frames = 256, taa_frames = 48;
    for (int i = 0; i < frames; i++) {
        tnd_frame_destroy(&f);
        REQUIRE_OK(render_frame(r.fe, &r.st, (uint32_t)i, &f));
        const float *a = tnd_frame_f(&f, TND_CT_ALBEDO);
        for (int q = 0; q < N * 3; q++) {
            alb[q] = a[q];
            ref[q] += a[q] / frames;
        }
        if (i == taa_frames - 1)
            memcpy(one, alb, sizeof one);
        if (i < taa_frames) {
            REQUIRE_OK(tnd_contract_upload(vk, &r.ct, &f));
            REQUIRE_OK(upload_rgb(vk, &r.in, alb, 1.0f));
            REQUIRE_OK(cmp_run(c, &r.in, &r.ct, &(cmp_frame){.reset = i == 0}, NULL));
        }
    }
    REQUIRE_OK(cmp_download_hdr(c, taa));
    /* edge pixels: where the reference is not what one frame gives (partial coverage) */
    double e_one = 0, e_taa = 0;
    int edges = 0;
    for (int q = 0; q < N; q++) {
        double d1 = 0, d2 = 0, dr = 0;
        for (int k = 0; k < 3; k++) {
            d1 += fabs(one[3 * q + k] - ref[3 * q + k]);
            d2 += fabs(taa[3 * q + k] - ref[3 * q + k]);
            dr += fabs(ref[3 * q + k]);
        }
        if (d1 > 0.02 * (dr + 0.01)) {
            e_one += d1;
            e_taa += d2;
            edges++;
        }
    }
    printf("     %d edge pixels: mean abs error against 256 jittered frames: one frame %.4f, "
           "TAA after %d frames %.4f\n",
           edges, e_one / edges, taa_frames, e_taa / edges);
    CHECK(edges > 50, "only %d edge pixels", edges);
    CHECK(e_taa < 0.5 * e_one, "TAA %.4f is not below half of one frame's %.4f", e_taa / edges,
          e_one / edges);
cleanup:
    cmp_destroy(c);
    tnd_frame_destroy(&f);
    rig_close(vk, &r);
    gpu_end();
}

/* TAA under motion on `dynamic` (camera and objects move), on the noise-free albedo with the
 * scene's motion vectors. A ghost is a pixel whose TAA output differs from this frame's input
 * by more than 0.05 where this frame is flat (its 3x3 neighbourhood spans less than 0.02): no
 * edge, so neither jitter nor anti-aliasing can explain the difference; only history from
 * another surface (a disocclusion, an object that moved on) can. The trail is the longest run of
 * consecutive frames a pixel stays a ghost. With clipping it must stay within 2 frames; the same
 * run with clipping off (history trusted as it is) must show trails, so the measure can fail. */
static void ghost_run(tnd_vk *vk, rig *r, bool clip, int frames, int *max_trail, double *ghosts)
{
    cmp_context *c = NULL;
    tnd_frame f = {0};
    tnd_scene_state prev = {0};
    static float alb[N * 3], taa[N * 3];
    static int trail[N];
    memset(trail, 0, sizeof trail);
    *max_trail = 0;
    *ghosts = 0;
    cmp_desc d = {.taa = true};
    if (!clip)
        d.taa_clip = 1e6f, d.taa_sparkle = 1e6f;
    REQUIRE_OK(cmp_create(vk, W, H, TND_PRECISION_F32, &d, &c));
    for (int i = 0; i < frames; i++) {
        double t = i / 30.0;
        REQUIRE_OK(tnd_scene_evaluate(r->s, i ? (i - 1) / 30.0 : 0.0, 0, (float)W / H, &prev));
        REQUIRE_OK(tnd_scene_evaluate(r->s, t, 0, (float)W / H, &r->st));
        tnd_frame_destroy(&f);
        REQUIRE_OK(test_embree_frame(r->fe, &r->st, &prev, (uint32_t)i, W, H, NULL, &f));
        memcpy(alb, tnd_frame_f(&f, TND_CT_ALBEDO), sizeof alb);
        REQUIRE_OK(tnd_contract_upload(vk, &r->ct, &f));
        REQUIRE_OK(upload_rgb(vk, &r->in, alb, 1.0f));
        REQUIRE_OK(cmp_run(c, &r->in, &r->ct, &(cmp_frame){.reset = i == 0}, NULL));
        REQUIRE_OK(cmp_download_hdr(c, taa));
        int n = 0;
        for (int y = 1; y < H - 1; y++)
            for (int x = 1; x < W - 1; x++) {
                int q = y * W + x;
                bool flat = true;
                for (int k = 0; k < 3 && flat; k++) {
                    float lo = alb[3 * q + k], hi = lo;
                    for (int dy = -1; dy <= 1; dy++)
                        for (int dx = -1; dx <= 1; dx++) {
                            float v = alb[3 * (q + dy * W + dx) + k];
                            lo = fminf(lo, v);
                            hi = fmaxf(hi, v);
                        }
                    flat = hi - lo < 0.02f;
                }
                float e = 0;
                for (int k = 0; k < 3; k++)
                    e = fmaxf(e, fabsf(taa[3 * q + k] - alb[3 * q + k]));
                trail[q] = flat && e > 0.05f ? trail[q] + 1 : 0;
                n += trail[q] > 0;
                if (trail[q] > *max_trail)
                    *max_trail = trail[q];
            }
        *ghosts += (double)n / ((W - 2) * (H - 2)) / frames;
    }
cleanup:
    tnd_scene_state_free(&prev);
    tnd_frame_destroy(&f);
    cmp_destroy(c);
}

static void test_taa_no_ghosting_under_motion(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    rig r;
    REQUIRE_OK(rig_open_scene(vk, TND_SOURCE_DIR "/data/scenes/dynamic.gltf", &r));
    int trail_clip = 0, trail_off = 0;
    double g_clip = 0, g_off = 0;
    const int frames = 40;
    ghost_run(vk, &r, true, frames, &trail_clip, &g_clip);
    ghost_run(vk, &r, false, frames, &trail_off, &g_off);
    printf("     dynamic, %d frames: ghost pixels %.3f%% (longest trail %d frames) with clipping, "
           "%.3f%% (%d frames) with clipping off\n",
           frames, 100 * g_clip, trail_clip, 100 * g_off, trail_off);
    CHECK(trail_off > 4, "the measure sees no ghosts even without clipping (trail %d)", trail_off);
    CHECK(trail_clip <= 2, "ghost trails of %d frames with clipping", trail_clip);
    CHECK(g_clip < 0.25 * g_off, "ghosts %.4f with clipping vs %.4f without", g_clip, g_off);
cleanup:
    rig_close(vk, &r);
    gpu_end();
}

/* The interleave on `materials` (its glass splits the pixels into a reflection and a refraction
 * field): the GPU pass equals the CPU reference (core's tnd_frame_interleave) to float rounding,
 * changes the split pixels only, and a split pixel becomes the mean of its own field and the
 * other field's neighbours. */
static void test_interleave(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    rig r;
    tnd_frame f = {0};
    cmp_context *c = NULL;
    static float rgb[N * 3], cpu[N * 3], gpu[N * 3];
    REQUIRE_OK(rig_first_frame(vk, TND_SOURCE_DIR "/data/scenes/materials.gltf", &r, &f, rgb));
    memcpy(cpu, rgb, sizeof cpu);
    tnd_frame_interleave(&f, cpu);
    REQUIRE_OK(upload_rgb(vk, &r.in, rgb, 1.0f));
    REQUIRE_OK(cmp_create(vk, W, H, TND_PRECISION_F32, &(cmp_desc){.interleave = true}, &c));
    REQUIRE_OK(cmp_run(c, &r.in, &r.ct, &(cmp_frame){.reset = true}, NULL));
    REQUIRE_OK(cmp_download_hdr(c, gpu));
    int split = 0, changed_outside = 0;
    double worst = 0;
    for (int q = 0; q < N; q++) {
        bool sp = (tnd_frame_u(&f, TND_CT_PATH)[q] & TND_PATH_SPLIT) != 0;
        split += sp;
        for (int k = 0; k < 3; k++) {
            worst = fmax(worst, fabs(gpu[3 * q + k] - cpu[3 * q + k]) /
                                    fmax(fabs(cpu[3 * q + k]), 1e-3));
            changed_outside += !sp && gpu[3 * q + k] != rgb[3 * q + k];
        }
    }
    printf("     materials %dx%d: %d split pixels; GPU against CPU interleave: worst relative "
           "difference %.2e\n", W, H, split, worst);
    CHECK(split > 10, "%d split pixels", split);
    CHECK(worst < 1e-5, "GPU and CPU differ by %.3g", worst);
    CHECK(changed_outside == 0, "%d values changed outside split pixels", changed_outside);
    /* one interior split pixel by hand */
    for (int y = 1; y < H - 1; y++)
        for (int x = 1; x < W - 1; x++) {
            int q = y * W + x;
            uint32_t pq = tnd_frame_u(&f, TND_CT_PATH)[q];
            if (!(pq & TND_PATH_SPLIT))
                continue;
            double sum = 0;
            int n = 0;
            const int nb[4] = {q - 1, q + 1, q - W, q + W};
            for (int k = 0; k < 4; k++) {
                uint32_t o = tnd_frame_u(&f, TND_CT_PATH)[nb[k]];
                if ((o & TND_PATH_SPLIT) && (o & TND_PATH_REFRACT) != (pq & TND_PATH_REFRACT))
                    sum += rgb[3 * nb[k] + 1], n++;
            }
            if (n == 4) {
                CHECK_NEAR(gpu[3 * q + 1], 0.5 * rgb[3 * q + 1] + 0.5 * sum / 4,
                           1e-5 * fmax(1.0, fabs(sum)), "a split pixel by hand");
                y = H; /* one is enough */
                break;
            }
        }
cleanup:
    cmp_destroy(c);
    tnd_frame_destroy(&f);
    rig_close(vk, &r);
    gpu_end();
}

/* Temporal upscaling (post_taau.comp): cornell's albedo traced at half the size (32x18, jittered
 * by the frame index), upscaled to 64x36 over 48 frames, against the full size's 256-frame
 * supersampled albedo: with TAA's new-frame weight 0.1 (a still image: the longer history) the
 * edge pixels' error under 0.55x the spatial baselines' (measured 0.46-0.47x; bilinear, bicubic
 * and lanczos of the last half-size frame), and the flat pixels' summed error within 1% of
 * their sum (nothing but the edges may differ). */
static double upscale_error(tnd_vk *vk, rig *half, cmp_upscaler up, bool taa, const float *ref,
                            const uint8_t *edge, double *flat)
{
    enum { HW = W / 2, HH = H / 2 };
    cmp_context *c = NULL;
    tnd_frame f = {0};
    static float alb[HW * HH * 4], out[N * 3];
    double e = 0, fr = 0;
    int n = 0;
    *flat = 0;
    REQUIRE_OK(cmp_create_scaled(vk, HW, HH, W, H, TND_PRECISION_F32,
                                 &(cmp_desc){.taa = taa, .upscaler = up, .taa_weight = 0.1f},
                                 &c));
    for (int i = 0; i < 48; i++) {
        tnd_frame_destroy(&f);
        REQUIRE_OK(test_embree_frame(half->fe, &half->st, &half->st, (uint32_t)i, HW, HH,
                                     &(femb_params){.bounces = 1}, &f));
        const float *a = tnd_frame_f(&f, TND_CT_ALBEDO);
        for (int q = 0; q < HW * HH; q++) {
            for (int k = 0; k < 3; k++)
                alb[4 * q + k] = a[3 * q + k];
            alb[4 * q + 3] = 1.0f;
        }
        REQUIRE_OK(tnd_contract_upload(vk, &half->ct, &f));
        REQUIRE_OK(tnd_image_upload(vk, &half->in, alb, sizeof alb));
        float jit[2];
        tnd_jitter((uint32_t)i, jit);
        REQUIRE_OK(cmp_run(c, &half->in, &half->ct,
                           &(cmp_frame){.reset = i == 0, .jitter = {jit[0], jit[1]}}, NULL));
    }
    REQUIRE_OK(cmp_download_hdr(c, out));
    for (int q = 0; q < N; q++) {
        double d = 0, r = 0;
        for (int k = 0; k < 3; k++)
            d += fabs(out[3 * q + k] - ref[3 * q + k]), r += ref[3 * q + k];
        if (edge[q])
            e += d, n++;
        else
            *flat += d, fr += r;
    }
    *flat /= fr > 0 ? fr : 1;
cleanup:
    cmp_destroy(c);
    tnd_frame_destroy(&f);
    return n ? e / n : 1e9;
}

static void test_taau_converges_at_edges(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    rig full, half = {0};
    tnd_frame f = {0};
    static float ref[N * 3];
    static uint8_t edge[N];
    REQUIRE_OK(rig_open(vk, &full));
    memset(ref, 0, sizeof ref);
    for (int i = 0; i < 256; i++) { /* the supersampled albedo at the full size */
        tnd_frame_destroy(&f);
        REQUIRE_OK(render_frame(full.fe, &full.st, (uint32_t)i, &f));
        const float *a = tnd_frame_f(&f, TND_CT_ALBEDO);
        for (int q = 0; q < N * 3; q++)
            ref[q] += a[q] / 256;
    }
    int edges = 0;
    for (int y = 0; y < H; y++) /* edge pixels: where the supersampled albedo varies */
        for (int x = 0; x < W; x++) {
            float lo = 1e9f, hi = -1e9f;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int xx = x + dx < 0 ? 0 : x + dx >= W ? W - 1 : x + dx;
                    int yy = y + dy < 0 ? 0 : y + dy >= H ? H - 1 : y + dy;
                    float v = ref[3 * (yy * W + xx) + 1];
                    lo = fminf(lo, v), hi = fmaxf(hi, v);
                }
            edge[y * W + x] = hi - lo > 0.05f;
            edges += edge[y * W + x];
        }
    /* the half size's rig: its own contract and input image */
    REQUIRE_OK(tnd_scene_load(TND_SOURCE_DIR "/data/scenes/cornell.gltf", &half.s));
    REQUIRE_OK(femb_create(half.s, &(femb_desc){.threads = 2}, &half.fe));
    REQUIRE_OK(tnd_scene_evaluate(half.s, 0.0, 0, (float)W / H, &half.st));
    REQUIRE_OK(tnd_contract_gpu_create(vk, W / 2, H / 2, TND_PRECISION_F32, &half.ct));
    REQUIRE_OK(tnd_image_create(vk, &(tnd_image_desc){.width = W / 2, .height = H / 2,
                                                      .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                      .name = "test.hdr_half"},
                                &half.in));
    double flat_t, flat_l, flat_c, flat_z;
    double et = upscale_error(vk, &half, CMP_UPSCALE_TEMPORAL, true, ref, edge, &flat_t);
    double el = upscale_error(vk, &half, CMP_UPSCALE_BILINEAR, true, ref, edge, &flat_l);
    double ec = upscale_error(vk, &half, CMP_UPSCALE_BICUBIC, true, ref, edge, &flat_c);
    double ez = upscale_error(vk, &half, CMP_UPSCALE_LANCZOS, true, ref, edge, &flat_z);
    printf("     %d edge pixels of 64x36 from 32x18, mean abs error against the supersampled "
           "full size: temporal %.4f, bilinear %.4f, bicubic %.4f, lanczos %.4f; flat pixels' "
           "relative error %.4f / %.4f / %.4f / %.4f\n", edges, et, el, ec, ez, flat_t, flat_l,
           flat_c, flat_z);
    CHECK(edges > 50, "only %d edge pixels", edges);
    /* (measured 0.46x: the samples inside each output pixel accumulated where nothing moves;
     * 0.55x before that, with the reconstruction's Gaussian accumulated) */
    CHECK(et < 0.55 * el && et < 0.55 * ec, "the temporal upscaler's edge error %.4f is not "
          "under 0.55x bilinear's %.4f and bicubic's %.4f", et, el, ec);
    CHECK(flat_t < 0.01, "flat pixels off by %.4f", flat_t);
    /* the edge-adaptive Lanczos: its weights sum to one and it is clamped to the nearest 2x2
     * pixels' range, so a flat region stays flat (within 1%, as the temporal one; measured
     * 0.36%); on the edges it is under bilinear (measured 0.2758 against 0.2829: a deterministic
     * input, so the 2.5% are no noise), and the temporal upscaler's accumulated samples beat it
     * as they beat the others (measured 0.47x) */
    CHECK(flat_z < 0.01, "lanczos: flat pixels off by %.4f", flat_z);
    CHECK(ez < el, "lanczos's edge error %.4f is not under bilinear's %.4f", ez, el);
    CHECK(et < 0.55 * ez, "the temporal upscaler's edge error %.4f is not under 0.55x the "
          "edge-adaptive Lanczos's %.4f", et, ez);
cleanup:
    tnd_frame_destroy(&f);
    rig_close(vk, &full);
    rig_close(vk, &half);
    gpu_end();
}

/* The temporal upscaler drops the history where the depth test says a surface is newly visible
 * (post_taau.comp's disocclusion reset): a synthetic contract at 32x18 upscaled to 64x36, a still
 * noisy pattern (depth 1) for 8 frames, then in its right half a new surface (depth 4, no motion:
 * nothing there was at depth 4) with the pattern shifted by a pixel, whose colours lie inside the
 * neighbourhood's clip box, so that the clip alone keeps the old history there. The right half's
 * output away from the edge must equal what a context without history makes of that frame (the
 * reconstruction alone), and the left half's must not (its history kept). */
static tnd_result taau_synthetic_frame(tnd_vk *vk, rig *r, tnd_frame *f, int i, float *px)
{
    enum { HW = W / 2, HH = H / 2 };
    float *depth = tnd_frame_f(f, TND_CT_DEPTH), *motion = tnd_frame_f(f, TND_CT_MOTION);
    for (int y = 0; y < HH; y++)
        for (int x = 0; x < HW; x++) {
            int q = y * HW + x;
            bool changed = i >= 8 && x >= HW / 2;
            uint32_t h = ((uint32_t)(x + (changed ? 1 : 0)) * 73856093u) ^ ((uint32_t)y * 19349663u);
            float v = (h % 4u == 0u) ? 0.8f : 0.2f; /* (a pattern whose 3x3 box spans both) */
            for (int k = 0; k < 3; k++)
                px[4 * q + k] = v;
            px[4 * q + 3] = 1.0f;
            depth[q] = changed ? 4.0f : 1.0f;
            motion[3 * q] = motion[3 * q + 1] = motion[3 * q + 2] = 0.0f;
        }
    tnd_result res = tnd_contract_upload(vk, &r->ct, f);
    if (res == TND_OK)
        res = tnd_image_upload(vk, &r->in, px, (size_t)HW * HH * 4 * sizeof(float));
    return res;
}

static void test_taau_resets_on_disocclusion(void)
{
    enum { HW = W / 2, HH = H / 2 };
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    rig r = {0};
    tnd_frame f = {0};
    cmp_context *c = NULL, *fresh = NULL;
    static float px[HW * HH * 4], out[N * 3], ref[N * 3];
    REQUIRE_OK(tnd_contract_gpu_create(vk, HW, HH, TND_PRECISION_F32, &r.ct));
    REQUIRE_OK(tnd_image_create(vk, &(tnd_image_desc){.width = HW, .height = HH,
                                                      .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                      .name = "test.hdr"},
                                &r.in));
    REQUIRE_OK(tnd_frame_create(HW, HH, &f));
    REQUIRE_OK(cmp_create_scaled(vk, HW, HH, W, H, TND_PRECISION_F32, &(cmp_desc){.taa = true}, &c));
    REQUIRE_OK(cmp_create_scaled(vk, HW, HH, W, H, TND_PRECISION_F32, &(cmp_desc){.taa = true},
                                 &fresh));
    float jit[2];
    for (int i = 0; i <= 8; i++) {
        REQUIRE_OK(taau_synthetic_frame(vk, &r, &f, i, px));
        tnd_jitter((uint32_t)i, jit);
        REQUIRE_OK(cmp_run(c, &r.in, &r.ct, &(cmp_frame){.reset = i == 0, .jitter = {jit[0], jit[1]}},
                           NULL));
    }
    REQUIRE_OK(cmp_download_hdr(c, out));
    REQUIRE_OK(cmp_run(fresh, &r.in, &r.ct, &(cmp_frame){.reset = true, .jitter = {jit[0], jit[1]}},
                       NULL));
    REQUIRE_OK(cmp_download_hdr(fresh, ref));
    double right = 0, left = 0;
    for (int y = 2; y < H - 2; y++)
        for (int x = 2; x < W - 2; x++) {
            if (x >= W / 2 - 3 && x <= W / 2 + 3)
                continue; /* (the new surface's edge: both sides in the box) */
            double d = 0;
            for (int k = 0; k < 3; k++)
                d = fmax(d, fabs(out[3 * (y * W + x) + k] - ref[3 * (y * W + x) + k]));
            if (x > W / 2)
                right = fmax(right, d);
            else
                left = fmax(left, d);
        }
    printf("     disocclusion at half size: newly visible half against no history: largest "
           "difference %.2e; the unchanged half %.3f (its history kept)\n", right, left);
    CHECK(right < 1e-5, "the newly visible half keeps %.3g of its old history", right);
    CHECK(left > 0.05, "the unchanged half equals a frame without history (%.3g)", left);
cleanup:
    cmp_destroy(c);
    cmp_destroy(fresh);
    tnd_frame_destroy(&f);
    tnd_image_destroy(vk, &r.in);
    tnd_contract_gpu_destroy(vk, &r.ct);
    gpu_end();
}

static void test_shutdown(void)
{
    gpu_shutdown();
}

TND_TEST_MAIN(T(test_tonemap_exposure), T(test_taa_converges_at_edges), T(test_taau_converges_at_edges), T(test_taau_resets_on_disocclusion),
              T(test_taa_no_ghosting_under_motion), T(test_interleave), T(test_shutdown))
