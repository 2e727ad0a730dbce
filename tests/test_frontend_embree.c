/* tests/test_frontend_embree.c: the Embree front-end's estimator against analytic answers and
 * its own invariants: white furnaces (Lambert: exactly the emitter; GGX: the single-scattering
 * directional albedo, integrated independently here), the composite of the demodulated signals
 * against the radiance computed directly, determinism over thread counts, gradient samples
 * reproducing the previous frame, many-bounce convergence to the reference, motion vectors and
 * depth 1e5 units from the origin against double precision, and no NaN/Inf on the extremes
 * scene. Label: unit (CPU only). */
#include "frontend_embree/frontend_embree.h"
#include "frontend_embree/femb_internal.h" /* (test_nee_copies_agree forces the general NEE) */
#include "shaders/brdf.h"
#include "tests/embree_frame.h"
#include "tests/env_sphere.h"
#include "tests/lambert_probe.h"
#include "tests/motion_reference.h"
#include "tests/tnd_test.h"
#include "shaders/specular.h"
#include <unistd.h>

#define SCENES TND_SOURCE_DIR "/data/scenes/"

/* A sphere of radius 1 (or, with `cube`, a flat-shaded cube rotated to show three faces) at the
 * origin, seen by a camera at (0, 0, 4), inside a uniform sky of radiance 1. */
static int furnace_glass; /* 0: metal-rough; TND_MAT_GLASS / TND_MAT_THIN_GLASS: IOR 1.5, clear */

static tnd_scene *furnace_scene(float metallic, float roughness, float specular, bool cube)
{
    tnd_scene *s = NULL;
    if (tnd_scene_new("furnace", &s) != TND_OK)
        return NULL;
    static float pos[(ES_SEG + 1) * (ES_RINGS + 1) * 3], nrm[(ES_SEG + 1) * (ES_RINGS + 1) * 3];
    static uint32_t idx[ES_SEG * ES_RINGS * 6];
    uint32_t n = 0, t = 0;
    if (cube) {
        /* six faces, 4 vertices each with the face normal */
        static const float fn[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        static const float fu[6][3] = {{0, 0, -1}, {0, 0, 1}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}, {-1, 0, 0}};
        static const float fv[6][3] = {{0, 1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};
        for (int f = 0; f < 6; f++) {
            const int ab[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
            /* glass: a slab 6 x 6 x 0.6 (its rim out of view) instead of the cube */
            const float sc[3] = {furnace_glass ? 3.0f : 0.7f, furnace_glass ? 3.0f : 0.7f,
                                 furnace_glass ? 0.3f : 0.7f};
            for (int k = 0; k < 4; k++, n++)
                for (int c = 0; c < 3; c++) {
                    pos[3 * n + c] = sc[c] * (fn[f][c] + ab[k][0] * fu[f][c] + ab[k][1] * fv[f][c]);
                    nrm[3 * n + c] = fn[f][c];
                }
            const uint32_t tri[6] = {0, 1, 2, 0, 2, 3};
            for (int k = 0; k < 6; k++)
                idx[t++] = n - 4 + tri[k];
        }
    } else { /* tests/env_sphere.h's sphere: its positions are its normals */
        es_uv_sphere(pos, idx, &n, &t);
        memcpy(nrm, pos, 3 * sizeof(float) * n);
    }
    tnd_material m = tnd_material_default("furnace");
    m.metallic = metallic;
    m.roughness = roughness;
    m.specular = specular;
    if (furnace_glass) {
        m.transmission = 1.0f;
        m.ior = 1.5f;
        m.thickness = furnace_glass == TND_MAT_GLASS ? 1.0f : 0.0f;
    }
    int32_t mi = tnd_scene_add_material(s, &m);
    int32_t me = tnd_scene_add_mesh(s, "sphere", pos, nrm, NULL, n, idx, t / 3, (uint32_t)mi);
    /* the cube turned 30 degrees about y, then 25 about x: three faces face the camera */
    const float rot[4] = {0.2113f, 0.2549f, -0.0566f, 0.9418f};
    int32_t node = tnd_scene_add_node(s, "object", -1, NULL, cube ? rot : NULL, NULL);
    const float cam_t[3] = {0, 0, 4};
    int32_t cn = tnd_scene_add_node(s, "camera", -1, cam_t, NULL, NULL);
    tnd_scene_add_instance(s, (uint32_t)me, (uint32_t)node);
    tnd_scene_add_camera(s, (uint32_t)cn, 0.6f);
    s->sky[0] = s->sky[1] = s->sky[2] = 1.0f;
    if (tnd_scene_commit(s) != TND_OK) {
        tnd_scene_destroy(s);
        return NULL;
    }
    return s;
}

/* Directional albedo of the GGX specular lobe with F = 1 (single scattering), by quadrature in
 * double over the hemisphere: E(mu) = integral of D G2 / (4 mu) dl. */
static double ggx_albedo_exact(double mu, double alpha)
{
    double a2 = alpha * alpha, sum = 0;
    const int NT = 800, NP = 256;
    double v[3] = {sqrt(1 - mu * mu), 0, mu};
    for (int i = 0; i < NT; i++) {
        double th = (i + 0.5) / NT * TND_PI / 2, ct = cos(th), st = sin(th);
        for (int j = 0; j < NP; j++) {
            double ph = (j + 0.5) / NP * 2 * TND_PI;
            double l[3] = {st * cos(ph), st * sin(ph), ct};
            double h[3] = {v[0] + l[0], v[1] + l[1], v[2] + l[2]};
            double hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
            double nh = h[2] / hl;
            double d = nh * nh * (a2 - 1) + 1;
            double D = a2 / (TND_PI * d * d);
            double lv = 0.5 * (-1 + sqrt(1 + a2 * (1 - mu * mu) / (mu * mu)));
            double ll = 0.5 * (-1 + sqrt(1 + a2 * (1 - ct * ct) / (ct * ct)));
            double G2 = 1 / (1 + lv + ll);
            sum += D * G2 / (4 * mu) * st * (TND_PI / 2 / NT) * (2 * TND_PI / NP);
        }
    }
    return sum;
}

/* Tabulated over mu (the quadrature is slow): linear interpolation on 64 intervals of [0.25, 1],
 * whose error (< 1e-4 for these roughnesses) is far inside the test's tolerance. */
static double ggx_albedo(double mu, double alpha)
{
    static double table[65], table_alpha = -1;
    if (alpha != table_alpha) {
        for (int i = 0; i <= 64; i++)
            table[i] = ggx_albedo_exact(0.25 + 0.75 * i / 64.0, alpha);
        table_alpha = alpha;
    }
    double x = (fmin(fmax(mu, 0.25), 1.0) - 0.25) / 0.75 * 64.0;
    int i = (int)x;
    if (i >= 64)
        return table[64];
    return table[i] + (x - i) * (table[i + 1] - table[i]);
}

typedef struct furnace_result {
    double mean_diff, se, max_abs;
    int pixels;
    double max_pos; /* the largest value above the expectation */
    double rt_sum; /* glass: the real-time front-end's radiance over the pixels seen through it */
    int rt_pixels;
} furnace_result;

/* Render the furnace with the reference mode; compare every sphere pixel with expected(mu). */
static void furnace(float metallic, float roughness, float specular, bool cube, uint32_t spp,
                    double (*expected)(double mu, double alpha), furnace_result *fr)
{
    memset(fr, 0, sizeof *fr);
    tnd_scene *s = furnace_scene(metallic, roughness, specular, cube);
    REQUIRE(s, "furnace scene: %s", tnd_error_detail());
    femb_context *c = NULL;
    tnd_scene_state st = {0};
    tnd_frame f = {0};
    enum { W = 40, H = 40 };
    float *rgb = malloc(W * H * 3 * sizeof(float)), *rt = NULL;
    REQUIRE_OK(femb_create(s, &(femb_desc){.threads = 2}, &c));
    REQUIRE_OK(tnd_scene_evaluate(s, 0, 0, 1.0f, &st));
    REQUIRE_OK(femb_set_frame(c, &st, &st, 0, W, H));
    REQUIRE_OK(tnd_frame_create(W, H, &f));
    REQUIRE_OK(femb_trace_primary(c, &f));
    if (furnace_glass) {
        rt = malloc(W * H * 3 * sizeof(float));
        REQUIRE_OK(femb_shade(c, &(femb_params){.bounces = 1}, &f, rt));
    }
    REQUIRE_OK(femb_reference(c, spp, rgb, NULL, NULL, NULL, NULL));
    double sum = 0, sum2 = 0;
    float cam[3] = {0, 0, 4};
    for (int q = 0; q < W * H; q++) {
        /* glass: the primary pass looks through it or at its reflection (the path flags tell) */
        bool through = tnd_frame_u(&f, TND_CT_PATH)[q] != 0u;
        if (tnd_frame_u(&f, TND_CT_VIS_ID)[2 * q] == TND_VIS_NONE && !through)
            continue;
        if (through) {
            double d = rgb[3 * q + 1] - expected(1.0, 0.0);
            sum += d;
            sum2 += d * d;
            fr->max_abs = fmax(fr->max_abs, fabs(d));
            fr->max_pos = fmax(fr->max_pos, d);
            fr->pixels++;
            if (rt) { /* the real-time estimate: the sky through the chain */
                fr->rt_sum += rt[3 * q + 1];
                fr->rt_pixels++;
            }
            continue;
        }
        /* a pixel's reference averages over its footprint; the primary pass saw its centre
         * (plus jitter): skip pixels on the silhouette, where mu changes fastest */
        const float *p = tnd_frame_f(&f, TND_CT_POSITION) + 3 * q;
        const float *n = tnd_frame_f(&f, TND_CT_NORMAL) + 3 * q;
        double wo[3] = {cam[0] - p[0], cam[1] - p[1], cam[2] - p[2]};
        double l = sqrt(wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2]);
        double mu = (n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2]) / l;
        if (mu < (cube ? 0.05 : 0.3))
            continue;
        double d = rgb[3 * q + 1] - expected(mu, fmax(roughness * roughness, TND_MIN_ALPHA));
        sum += d;
        sum2 += d * d;
        fr->max_abs = fmax(fr->max_abs, fabs(d));
        fr->pixels++;
    }
    if (fr->pixels > 1) {
        fr->mean_diff = sum / fr->pixels;
        double var = (sum2 - sum * sum / fr->pixels) / (fr->pixels - 1);
        fr->se = sqrt(fmax(var, 0) / fr->pixels);
    }
cleanup:
    free(rgb);
    free(rt);
    tnd_frame_destroy(&f);
    tnd_scene_state_free(&st);
    femb_destroy(c);
    tnd_scene_destroy(s);
}

static double one(double mu, double alpha)
{
    (void)mu, (void)alpha;
    return 1.0;
}

static void test_furnace_lambert(void)
{
    /* albedo 1, metallic 0, specular 0: a flat-shaded convex Lambertian object in a sky of 1
     * returns exactly 1 on every path (cosine sampling makes each weight 1), so the bound is
     * float rounding. (A smooth-shaded sphere loses the few cosine samples that fall between
     * its interpolated normal's horizon and the flat triangle's: that loss is measured below.) */
    furnace_result fr;
    furnace(0.0f, 1.0f, 0.0f, true, 16, one, &fr);
    printf("     Lambert furnace (cube): %d pixels, mean error %.2e, max %.2e\n", fr.pixels,
           fr.mean_diff, fr.max_abs);
    CHECK(fr.pixels > 300, "the cube covers the image (%d pixels)", fr.pixels);
    CHECK(fr.max_abs < 1e-5, "every pixel returns the emitter's radiance: max error %.3g",
          fr.max_abs);
    furnace(0.0f, 1.0f, 0.0f, false, 16, one, &fr);
    printf("     Lambert furnace (smooth sphere): mean error %.2e (normal-interpolation loss)\n",
           fr.mean_diff);
    CHECK(fr.mean_diff <= 0 && fr.mean_diff > -2e-3, "sphere loss %.3g stays below 0.2%%",
          fr.mean_diff);
}

static void test_furnace_ggx(void)
{
    /* metallic 1 with base 1 (F = 1): the sphere returns the GGX single-scattering albedo
     * E(mu, alpha) < 1; the loss grows with roughness. Bound: 5 standard errors of the mean over
     * the sphere's pixels, plus 0.3% for the quadrature and the pixel-footprint average. */
    const float rough[] = {0.2f, 0.5f, 0.8f, 1.0f};
    for (int i = 0; i < 4; i++) {
        furnace_result fr;
        furnace(1.0f, rough[i], 1.0f, false, 64, ggx_albedo, &fr);
        double e_half = ggx_albedo(0.7, fmax(rough[i] * rough[i], TND_MIN_ALPHA));
        printf("     GGX furnace r=%.1f: E(0.7)=%.4f, %d pixels, mean error %.2e (se %.1e)\n",
               rough[i], e_half, fr.pixels, fr.mean_diff, fr.se);
        CHECK(fabs(fr.mean_diff) < 5 * fr.se + 3e-3,
              "roughness %.1f: mean deviation from E(mu) %.4g (se %.2g)", rough[i], fr.mean_diff,
              fr.se);
        if (rough[i] >= 0.8f)
            CHECK(e_half < 0.97, "rough GGX loses energy (E = %.3f)", e_half);
    }
}

/* Glass in the furnace: clear glass (no absorption) only redirects light, so every path that
 * leaves returns the sky's radiance 1 exactly, whatever its chain of reflections and
 * refractions: in the reference mode the mean over the object must be 1 (less only for the rare
 * paths that exceed TND_MAX_SPECULAR_DEPTH vertices), and no pixel may exceed 1 (total internal
 * reflection counted twice would). Slab and sphere, volume and thin glass. The real-time chain
 * follows refraction only (1 - F per interface): its bias is measured and printed. */
static void test_furnace_glass(void)
{
    const int kinds[2] = {TND_MAT_GLASS, TND_MAT_THIN_GLASS};
    for (int k = 0; k < 2; k++)
        for (int cube = 0; cube < 2; cube++) {
            furnace_glass = kinds[k];
            furnace_result fr;
            furnace(0.0f, 0.0f, 1.0f, cube, 16, one, &fr);
            furnace_glass = 0;
            double rt_mean = fr.rt_pixels ? fr.rt_sum / fr.rt_pixels : 0;
            printf("     %s %s furnace: %d pixels, reference mean %.6f (largest deviation %.2e); "
                   "real time %.4f (bias %.1f%%: the reflections it does not follow)\n",
                   kinds[k] == TND_MAT_GLASS ? "glass" : "thin glass", cube ? "slab" : "sphere",
                   fr.pixels, 1.0 + fr.mean_diff, fr.max_abs, rt_mean, 100.0 * (rt_mean - 1.0));
            /* the real-time chain keeps 1 - F per interface: darker than the truth, by a few
             * percent (F = 4% at normal incidence, more towards the silhouette) */
            CHECK(rt_mean < 1.0 && rt_mean > 0.6, "real-time glass furnace %.4f", rt_mean);
            CHECK(fr.pixels > 100, "%d pixels", fr.pixels);
            CHECK(fabs(fr.mean_diff) < 5 * fr.se + 1e-3, "mean %.6f (se %.2g)", 1 + fr.mean_diff,
                  fr.se);
            /* never brighter than the sky (TIR counted twice would be); a silhouette pixel may
             * lose a sample to TND_MAX_SPECULAR_DEPTH (grazing chains of reflections) */
            CHECK(fr.max_pos <= 1e-5, "a pixel brighter than the sky by %.3g", fr.max_pos);
            CHECK(fr.max_abs <= 2.0 / 16 + 1e-6, "a pixel lost %.3g", fr.max_abs);
        }
}

/* The normals of a rotated instance: every pixel of the rotated cube must carry one of its
 * faces' normals turned by the node's rotation, R e (the normal transform once applied R^T:
 * invisible to the Lambert furnace and to the cross-check, both front-ends sharing it; the glass
 * slab furnace found it). */
static void test_rotated_instance_normals(void)
{
    tnd_scene *s = furnace_scene(0.0f, 0.5f, 1.0f, true);
    REQUIRE(s, "scene: %s", tnd_error_detail());
    femb_context *c = NULL;
    tnd_scene_state st = {0};
    tnd_frame f = {0};
    enum { W = 32, H = 32 };
    REQUIRE_OK(femb_create(s, &(femb_desc){.threads = 2}, &c));
    REQUIRE_OK(tnd_scene_evaluate(s, 0, 0, 1.0f, &st));
    REQUIRE_OK(femb_set_frame(c, &st, &st, 0, W, H));
    REQUIRE_OK(tnd_frame_create(W, H, &f));
    REQUIRE_OK(femb_trace_primary(c, &f));
    /* R from the node's quaternion (x, y, z, w), normalised */
    double q[4] = {0.2113, 0.2549, -0.0566, 0.9418}, l = 0;
    for (int i = 0; i < 4; i++)
        l += q[i] * q[i];
    for (int i = 0; i < 4; i++)
        q[i] /= sqrt(l);
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                      {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                      {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    int hits = 0, good = 0;
    for (int p = 0; p < W * H; p++) {
        if (tnd_frame_u(&f, TND_CT_VIS_ID)[2 * p] == TND_VIS_NONE)
            continue;
        hits++;
        const float *n = tnd_frame_f(&f, TND_CT_GEO_NORMAL) + 3 * p;
        double best = 0;
        for (int a = 0; a < 3; a++) /* the rotated axes, either sign */
            best = fmax(best, fabs(R[0][a] * n[0] + R[1][a] * n[1] + R[2][a] * n[2]));
        good += best > 1 - 1e-5;
    }
    CHECK(hits > 200 && good == hits, "%d of %d pixels carry a rotated face normal", good, hits);
cleanup:
    tnd_frame_destroy(&f);
    tnd_scene_state_free(&st);
    femb_destroy(c);
    tnd_scene_destroy(s);
}

/* Total internal reflection: beyond the critical angle (inside glass of IOR 1.5: 41.8 degrees)
 * F = 1 and every draw reflects; at normal incidence F = ((1 - n) / (1 + n))^2 = 0.04. */
static void test_total_internal_reflection(void)
{
    float crit = sqrtf(1.0f - 1.0f / (1.5f * 1.5f)); /* cos of the critical angle */
    for (float c = 0.01f; c < crit - 1e-3f; c += 0.05f) {
        CHECK(tnd_fresnel_dielectric(c, 1.0f / 1.5f) == 1.0f, "F(cos %.2f) inside", c);
        CHECK(tnd_refract_cos(c, 1.0f / 1.5f) < 0.0f, "no refraction at cos %.2f", c);
        for (float u = 0.0f; u < 1.0f; u += 0.125f)
            CHECK(tnd_dielectric_event(TND_KIND_GLASS, false, c, 1.5f, u) == TND_EVENT_REFLECT,
                  "TIR reflects (cos %.2f, u %.3f)", c, u);
    }
    CHECK(tnd_dielectric_event(TND_KIND_GLASS, false, 0.9f, 1.5f, 0.999f) == TND_EVENT_REFRACT,
          "below the critical angle light leaves");
    CHECK_NEAR(tnd_fresnel_dielectric(1.0f, 1.5f), 0.04, 1e-6, "normal incidence, entering");
    CHECK_NEAR(tnd_fresnel_dielectric(1.0f, 1.0f / 1.5f), 0.04, 1e-6, "normal incidence, leaving");
    /* entering and leaving at the matching angles see the same F (reciprocity) */
    float ci = 0.6f, ct = tnd_refract_cos(ci, 1.5f);
    CHECK_NEAR(tnd_fresnel_dielectric(ci, 1.5f), tnd_fresnel_dielectric(ct, 1.0f / 1.5f), 1e-6,
               "reciprocity");
    CHECK_NEAR(tnd_thin_reflectance(0.04f), 0.08 / 1.04, 1e-7, "thin slab");
}


/* Render frame `frame` of a scene; the caller destroys everything. */
typedef struct rig {
    tnd_scene *s;
    femb_context *c;
    tnd_scene_state cur, prev;
} rig;

static tnd_result rig_open_lights(rig *r, const char *path, uint32_t threads,
                                  tnd_light_sampling lights)
{
    memset(r, 0, sizeof *r);
    tnd_result res = tnd_scene_load(path, &r->s);
    if (res == TND_OK)
        res = femb_create(r->s, &(femb_desc){.threads = threads, .lights = lights}, &r->c);
    return res;
}

static tnd_result rig_open(rig *r, const char *path, uint32_t threads)
{
    return rig_open_lights(r, path, threads, TND_LIGHTS_AUTO);
}

static tnd_result rig_frame(rig *r, uint32_t frame, double t, double t_prev, uint32_t w,
                            uint32_t h, tnd_frame *f)
{
    tnd_result res = tnd_scene_evaluate(r->s, t, 0, (float)w / h, &r->cur);
    if (res == TND_OK)
        res = tnd_scene_evaluate(r->s, t_prev, 0, (float)w / h, &r->prev);
    if (res == TND_OK)
        res = test_embree_frame(r->c, &r->cur, &r->prev, frame, w, h, NULL, f);
    return res;
}

static void rig_close(rig *r)
{
    tnd_scene_state_free(&r->cur);
    tnd_scene_state_free(&r->prev);
    femb_destroy(r->c);
    tnd_scene_destroy(r->s);
}

/* Reference frames are independent of each other: the luminance difference of a pixel between
 * two frames of a still scene, over a per-pixel scale (the frames' standard errors from their
 * sample variance), has the same mean square for every pair of frames. Frames that share samples
 * are positively correlated and give less: the keys frame x 4096 + s once made consecutive frames
 * share half their samples above 4096 (mean square 0.5 of the others'). The pixel's standard
 * error is only a scale here: the reference's samples are a low-discrepancy sequence
 * (shaders/sampling.h), whose mean converges faster than the sample variance says (measured:
 * 0.62 of it on this scene), so an absolute test against 1 would fail on independent frames.
 * Four frames: the mean square of the consecutive pairs (0-1, 1-2, 2-3) over that of the others
 * (0-2, 1-3, 0-3) is 1 +- about 1.3 sqrt(2 / P) over P pixels (0.077 at 24 x 24; 0.15 at 12 x 12
 * and 1024 spp under the sanitizers, where 4096 took 107 s), one-sided at 4 standard deviations:
 * above 0.69 (0.39). The ratio does not depend on the sample count. */
static void test_reference_frames_independent(void)
{
    enum { W = TND_TEST_SAMPLES_DIV > 1 ? 12 : 24, H = W };
    enum { SPP = 4096 / TND_TEST_SAMPLES_DIV, F = 4 };
    rig r;
    float *rgb[F], *se[F];
    for (int f = 0; f < F; f++)
        rgb[f] = malloc(W * H * 3 * sizeof(float)), se[f] = malloc(W * H * sizeof(float));
    REQUIRE_OK(rig_open(&r, SCENES "cornell.gltf", 2));
    REQUIRE_OK(tnd_scene_evaluate(r.s, 0, 0, 1.0f, &r.cur));
    for (uint32_t f = 0; f < F; f++) {
        REQUIRE_OK(femb_set_frame(r.c, &r.cur, &r.cur, f, W, H));
        REQUIRE_OK(femb_reference(r.c, SPP, rgb[f], se[f], NULL, NULL, NULL));
    }
    double z[F][F] = {{0}};
    int n = 0;
    for (int q = 0; q < W * H; q++) {
        double v = 0, l[F];
        for (int f = 0; f < F; f++) {
            v += (double)se[f][q] * se[f][q] / (F / 2);
            l[f] = tnd_luminance(rgb[f][3 * q], rgb[f][3 * q + 1], rgb[f][3 * q + 2]);
        }
        if (!(v > 0)) /* (a pixel without variance: the sky, or the light seen directly) */
            continue;
        for (int a = 0; a < F; a++)
            for (int b = a + 1; b < F; b++)
                z[a][b] += (l[a] - l[b]) * (l[a] - l[b]) / v;
        n++;
    }
    REQUIRE(n > W * H / 2, "only %d pixels with variance", n);
    double near = (z[0][1] + z[1][2] + z[2][3]) / 3, far = (z[0][2] + z[1][3] + z[0][3]) / 3;
    double ratio = near / far, sd = 1.3 * sqrt(2.0 / n);
    printf("     %d frames at %d spp: consecutive frames' mean squared difference %.3f of the "
           "others' (%d pixels; 1 +- %.3f expected; %.3f of the sample variance's)\n",
           F, SPP, ratio, n, sd, far / n);
    CHECK(ratio > 1 - 4 * sd, "consecutive reference frames correlated: %.3f", ratio);
    CHECK(ratio < 1 + 8 * sd, "consecutive reference frames: %.3f, far above the others' 1", ratio);
cleanup:
    for (int f = 0; f < F; f++)
        free(rgb[f]), free(se[f]);
    rig_close(&r);
}

/* Direct light from one- and two-sided polygonal emitters at receivers 1 mm to 1 m from them,
 * at the origin and 1e2, 1e4, 1e5 units from it, against Lambert's polygon irradiance within
 * the float-error bound and the noise (tests/lambert_probe.h says how both are derived). */
static void test_lambert_emitters(void)
{
    lambert_probe_self_test();
    const double Ts[4] = {0, 1e2, 1e4, 1e5};
    enum { W = 128, H = 128, DISPATCHES = 48 / TND_TEST_SAMPLES_DIV };
    uint32_t *words = malloc(7 * W * H * sizeof *words);
    femb_gradient_sample *g = malloc(W * H * sizeof *g);
    for (int t = 0; t < 4; t++) {
        lambert_probe lp;
        femb_context *c = NULL;
        tnd_scene_state st = {0};
        tnd_frame f = {0};
        REQUIRE(lambert_probe_open(&lp, Ts[t]), "probe scene: %s", tnd_error_detail());
        REQUIRE_OK(femb_create(lp.scene, &(femb_desc){.threads = 2}, &c));
        REQUIRE_OK(tnd_scene_evaluate(lp.scene, 0, 0, (float)W / H, &st));
        for (uint32_t d = 0; d < DISPATCHES; d++) {
            tnd_frame_destroy(&f);
            REQUIRE_OK(test_embree_frame(c, &st, &st, d, W, H, NULL, &f));
            lambert_probe_samples(&lp, d, W * H, words);
            femb_gradient_unpack(words, W * H, g);
            REQUIRE_OK(femb_shade_gradients(c, &(femb_params){.bounces = 1}, g, W * H, &f));
            lambert_probe_add(&lp, &f, W * H);
        }
        lp_summary sm;
        lambert_probe_check(&lp, "embree", &sm, getenv("LP_VERBOSE") != NULL);
        lambert_probe_print("embree", &lp, &sm);
    cleanup:
        tnd_frame_destroy(&f);
        tnd_scene_state_free(&st);
        femb_destroy(c);
        lambert_probe_close(&lp);
    }
    free(words);
    free(g);
}

static void test_composite_equals_radiance(void)
{
    const char *scenes[] = {SCENES "cornell.gltf", SCENES "materials.gltf", SCENES "sun.gltf"};
    for (int k = 0; k < 3; k++) {
        rig r;
        tnd_frame f = {0};
        enum { W = 64, H = 36 };
        float rad[W * H * 3], comp[W * H * 3];
        REQUIRE_OK(rig_open(&r, scenes[k], 2));
        REQUIRE_OK(rig_frame(&r, 3, 0.1, 0.1, W, H, &f));
        REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = 2}, &f, rad));
        tnd_frame_composite(&f, comp);
        int bad = 0;
        double worst = 0;
        for (int q = 0; q < W * H * 3; q++) {
            /* float rounding of the YCoCg round trip, the SH evaluation and the F0 division */
            double tol = 1e-4 * fabs(rad[q]) + 1e-6;
            worst = fmax(worst, fabs(comp[q] - rad[q]) / (fabs(rad[q]) + 1e-6));
            bad += !(fabs(comp[q] - rad[q]) <= tol);
        }
        printf("     %s: composite vs direct radiance, worst relative difference %.2e\n",
               strrchr(scenes[k], '/') + 1, worst);
        CHECK(bad == 0, "%s: %d channels differ", scenes[k], bad);
    cleanup:
        tnd_frame_destroy(&f);
        rig_close(&r);
    }
}

static void test_deterministic_threads(void)
{
    tnd_frame f[3] = {{0}};
    const uint32_t threads[3] = {1, 2, 5};
    for (int i = 0; i < 3; i++) {
        rig r;
        REQUIRE_OK(rig_open(&r, SCENES "materials.gltf", threads[i]));
        REQUIRE_OK(rig_frame(&r, 7, 0.5, 0.45, 48, 30, &f[i]));
        REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = 1}, &f[i], NULL));
        rig_close(&r);
    }
    for (int i = 1; i < 3; i++)
        for (int e = 0; e < TND_CT_COUNT; e++) {
            size_t n = (size_t)48 * 30 * tnd_ct_get((tnd_ct)e)->comps * 4;
            CHECK(memcmp(f[0].data[e], f[i].data[e], n) == 0, "%u threads: '%s' differs from 1 thread",
                  threads[i], tnd_ct_get((tnd_ct)e)->name);
        }
cleanup:
    for (int i = 0; i < 3; i++)
        tnd_frame_destroy(&f[i]);
}

/* An unchanged scene rendered as frame 5 and frame 6: gradient samples in frame 6 that carry
 * frame 5's keys and surfaces reproduce frame 5's shading exactly. */
static void gradient_samples_reproduce(const char *scene, tnd_light_sampling lights)
{
    rig r;
    tnd_frame a = {0}, b = {0};
    enum { W = 60, H = 34 };
    femb_gradient_sample g[64];
    uint32_t n = 0;
    printf("     %s, --lights %s\n", scene, tnd_light_sampling_name(lights));
    REQUIRE_OK(rig_open_lights(&r, scene, 2, lights));
    REQUIRE_OK(rig_frame(&r, 5, 1.0, 1.0, W, H, &a));
    REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = 1}, &a, NULL));
    REQUIRE_OK(rig_frame(&r, 6, 1.0, 1.0, W, H, &b));
    REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = 1}, &b, NULL));
    int differ = 0, hits = 0;
    for (uint32_t q = 0; q < W * H; q++) {
        if (tnd_frame_u(&a, TND_CT_VIS_ID)[2 * q] == TND_VIS_NONE)
            continue;
        hits++;
        differ += memcmp(tnd_frame_f(&a, TND_CT_HF) + 3 * q, tnd_frame_f(&b, TND_CT_HF) + 3 * q, 12) != 0;
        if (q % 37 == 0 && n < 64) /* one sample every 37 pixels, like a sparse stratum choice */
            g[n++] = (femb_gradient_sample){q, tnd_frame_u(&a, TND_CT_RNG)[2 * q],
                                            tnd_frame_u(&a, TND_CT_RNG)[2 * q + 1],
                                            tnd_frame_u(&a, TND_CT_VIS_ID)[2 * q],
                                            tnd_frame_u(&a, TND_CT_VIS_ID)[2 * q + 1],
                                            tnd_frame_f(&a, TND_CT_VIS_BARY)[2 * q],
                                            tnd_frame_f(&a, TND_CT_VIS_BARY)[2 * q + 1]};
    }
    CHECK(differ > hits / 2, "new random numbers change most pixels (%d of %d)", differ, hits);
    REQUIRE(n > 10, "enough samples");
    REQUIRE_OK(femb_shade_gradients(r.c, &(femb_params){.bounces = 1}, g, n, &b));
    int bad = 0;
    for (uint32_t i = 0; i < n; i++) {
        size_t q = g[i].pixel;
        bad += memcmp(tnd_frame_f(&a, TND_CT_HF) + 3 * q, tnd_frame_f(&b, TND_CT_HF) + 3 * q, 12) ||
               memcmp(tnd_frame_f(&a, TND_CT_LF_SH) + 4 * q, tnd_frame_f(&b, TND_CT_LF_SH) + 4 * q, 16) ||
               memcmp(tnd_frame_f(&a, TND_CT_LF_COCG) + 2 * q, tnd_frame_f(&b, TND_CT_LF_COCG) + 2 * q, 8) ||
               memcmp(tnd_frame_f(&a, TND_CT_SPEC) + 3 * q, tnd_frame_f(&b, TND_CT_SPEC) + 3 * q, 12);
        bad += tnd_frame_u(&b, TND_CT_RNG)[2 * q] != 5u;
    }
    CHECK(bad == 0, "%d of %u gradient samples differ from the previous frame", bad, n);
    femb_gradient_sample wrong = g[0];
    wrong.primitive = 1u << 30;
    CHECK(femb_shade_gradients(r.c, NULL, &wrong, 1, &b) == TND_ERR_INVALID_ARGUMENT,
          "bad sample rejected");
cleanup:
    tnd_frame_destroy(&a);
    tnd_frame_destroy(&b);
    rig_close(&r);
}

/* (with reservoirs, a gradient sample shades the previous frame's reservoir of its pixel at the
 * surface found again: the same light sample and weight, the same value where nothing moved) */
static void test_gradient_samples_reproduce(void)
{
    gradient_samples_reproduce(SCENES "cornell.gltf", TND_LIGHTS_AUTO);
    gradient_samples_reproduce(SCENES "many_lights.gltf", TND_LIGHTS_RESTIR);
}

/* ReSTIR DI (femb_restir.c) is unbiased: on many_lights (348 emitters) seen still, the mean of
 * its frames equals that of next-event estimation's frames with the light tree (whose expectation
 * is the capped path tracer's, test_light_tree_unbiased): direct light alone over the image and in
 * each quarter of it (the reservoirs are then the whole estimator), and with one bounce over the
 * image (the bounce's BRDF sample then gives the list's emitters no weight: the reservoir took
 * their share). Real-time frames are compared with real-time frames: both go through the same 16
 * jitter offsets. The reservoirs' frames are correlated (each reuses the last), so the standard
 * error of their mean is taken from the measured variance of the frames' means times their
 * integrated autocorrelation time (1 + 2 x the autocorrelations up to the first lag where it falls
 * under 0.05). With one bounce a quarter of this scene is no test: two 8192-sample references of
 * next-event estimation, by the table and by the tree, differ there by 1.4% (its 40x lamps seen by
 * BRDF samples: heavy tails), as much as the reservoirs' mean does from either. And it is what it is
 * for: the frames' relMSE against a 512-sample reference, after the reservoirs' first 8 frames,
 * with one bounce, under 0.7x next-event estimation's with the tree and 0.3x with the table
 * (measured 1.38, 2.80 and 8.49: the bounce's own noise, alike for all three, dominates; direct
 * light alone at 160x90 gains 8x and 41x, docs/lights.md). */
enum { RS_W = 48, RS_H = 27, RS_FRAMES = 256 / TND_TEST_SAMPLES_DIV };
typedef struct rs_series {
    double lum[RS_FRAMES][5]; /* per frame: the image's mean luminance and its quarters' */
    double mean[5], se[5], tau[5];
    double relmse; /* of a frame against the reference, after the first 8 */
} rs_series;

static void restir_series(femb_context *c, const tnd_scene_state *st, uint32_t frames,
                          uint32_t bounces, const float *ref, rs_series *S)
{
    enum { W = RS_W, H = RS_H };
    static float rad[W * H * 3];
    tnd_frame f = {0};
    memset(S, 0, sizeof *S);
    for (uint32_t i = 0; i < frames; i++) {
        REQUIRE_OK(femb_set_frame(c, st, st, i, W, H));
        REQUIRE_OK(tnd_frame_create(W, H, &f));
        REQUIRE_OK(femb_render(c, &(femb_params){.bounces = bounces}, &f, rad));
        double e = 0;
        for (uint32_t q = 0; q < W * H; q++) {
            uint32_t x = q % W, y = q / W, quarter = 1 + (x >= W / 2) + 2 * (y >= H / 2);
            double l = tnd_luminance(rad[3 * q], rad[3 * q + 1], rad[3 * q + 2]);
            double lr = tnd_luminance(ref[3 * q], ref[3 * q + 1], ref[3 * q + 2]);
            S->lum[i][0] += l / (W * H);
            S->lum[i][quarter] += 4 * l / (W * H);
            e += (l - lr) * (l - lr) / (lr * lr + 1e-2) / (W * H);
        }
        if (i >= 8)
            S->relmse += e / (frames - 8);
        tnd_frame_destroy(&f);
    }
    for (int k = 0; k < 5; k++) {
        double mean = 0, var = 0, tau = 1;
        for (uint32_t i = 0; i < frames; i++)
            mean += S->lum[i][k] / frames;
        for (uint32_t i = 0; i < frames; i++)
            var += (S->lum[i][k] - mean) * (S->lum[i][k] - mean) / (frames - 1);
        for (uint32_t lag = 1; lag < frames / 4 && var > 0; lag++) {
            double r = 0;
            for (uint32_t i = 0; i + lag < frames; i++)
                r += (S->lum[i][k] - mean) * (S->lum[i + lag][k] - mean) / (frames - lag);
            if (r / var < 0.05)
                break;
            tau += 2 * r / var;
        }
        S->mean[k] = mean, S->tau[k] = tau, S->se[k] = sqrt(var * tau / frames);
    }
cleanup:
    tnd_frame_destroy(&f);
}

static void test_restir_unbiased(void)
{
    tnd_scene *s = NULL;
    tnd_scene_state st = {0};
    femb_context *fe[3] = {NULL, NULL, NULL};
    static float ref[RS_W * RS_H * 3], se[RS_W * RS_H];
    static rs_series S[3], D[2];
    REQUIRE_OK(tnd_scene_load(SCENES "many_lights.gltf", &s));
    REQUIRE_OK(tnd_scene_evaluate(s, 1.0, 0, (float)RS_W / RS_H, &st));
    const tnd_light_sampling mode[3] = {TND_LIGHTS_RESTIR, TND_LIGHTS_TREE, TND_LIGHTS_PLAIN};
    for (int m = 0; m < 3; m++)
        REQUIRE_OK(femb_create(s, &(femb_desc){.threads = 2, .lights = mode[m]}, &fe[m]));
    REQUIRE_OK(femb_set_frame(fe[1], &st, &st, 0, RS_W, RS_H));
    femb_set_reference_bounces(fe[1], 1);
    REQUIRE_OK(femb_reference(fe[1], 512, ref, se, NULL, NULL, NULL));
    restir_series(fe[0], &st, RS_FRAMES, 1, ref, &S[0]);
    restir_series(fe[1], &st, RS_FRAMES, 1, ref, &S[1]);
    restir_series(fe[2], &st, 24, 1, ref, &S[2]); /* (its relMSE only) */
    restir_series(fe[0], &st, RS_FRAMES, 0, ref, &D[0]);
    restir_series(fe[1], &st, RS_FRAMES, 0, ref, &D[1]);
    printf("     many_lights %dx%d, 1 bounce, %d frames: relMSE of a frame %.4f (reservoirs), "
           "%.4f (tree), %.4f (table)\n", RS_W, RS_H, RS_FRAMES, S[0].relmse, S[1].relmse,
           S[2].relmse);
    CHECK(S[0].relmse < 0.7 * S[1].relmse && S[0].relmse < 0.3 * S[2].relmse,
          "the reservoirs' relMSE %.4f is not under 0.7x the tree's %.4f and 0.3x the table's "
          "%.4f", S[0].relmse, S[1].relmse, S[2].relmse);
    const char *where[5] = {"image", "top left", "top right", "bottom left", "bottom right"};
    for (int b = 0; b < 2; b++)
        for (int k = 0; k < (b ? 1 : 5); k++) {
            const rs_series *r = b ? &S[0] : &D[0], *t = b ? &S[1] : &D[1];
            double d = r->mean[k] - t->mean[k];
            double err = sqrt(r->se[k] * r->se[k] + t->se[k] * t->se[k]);
            printf("       %s, %-12s reservoirs %.5f (tau %.1f), tree %.5f (tau %.1f): %+.2f se\n",
                   b ? "1 bounce" : "direct", where[k], r->mean[k], r->tau[k], t->mean[k],
                   t->tau[k], d / err);
            CHECK(fabs(d) <= 4 * err, "%s, %s: the reservoirs' mean %.5f is %.2g from next-event "
                  "estimation's %.5f (4 se %.2g)", b ? "1 bounce" : "direct", where[k],
                  r->mean[k], fabs(d), t->mean[k], 4 * err);
        }
cleanup:
    for (int m = 0; m < 3; m++)
        femb_destroy(fe[m]);
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
}

/* The estimator shades batches of pixels in SIMD lanes: a pixel shaded alone (a batch of one,
 * through the gradient path with its own key and surface) gets exactly the bits it got among
 * its batch, on a scene with textures, normal maps, glass and a mirror at the bounce; so do the
 * same pixels shaded together as one list of scattered pixels (femb_shade_pixels has a copy
 * for runs of pixels, the shading pass's batches, and one for any list). Pixels seen through a
 * mirror or glass are left out: their G-buffer holds the surface seen along the chain, which a
 * gradient sample (a surface seen directly) does not reproduce. */
static void test_batch_independent(void)
{
    rig r;
    tnd_frame f = {0}, g = {0};
    enum { W = 64, H = 36 };
    REQUIRE_OK(rig_open(&r, SCENES "materials.gltf", 2));
    REQUIRE_OK(rig_frame(&r, 3, 0.5, 0.45, W, H, &f));
    REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = 2}, &f, NULL));
    REQUIRE_OK(rig_frame(&r, 3, 0.5, 0.45, W, H, &g));
    REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = 2}, &g, NULL));
    int tested = 0, bad = 0, textured = 0, bad_list = 0;
    static femb_gradient_sample list[W * H];
    const tnd_ct ct[] = {TND_CT_HF, TND_CT_LF_SH, TND_CT_LF_COCG, TND_CT_SPEC,
                         TND_CT_NORMAL, TND_CT_ALBEDO, TND_CT_POSITION};
    for (uint32_t q = 0; q < W * H; q += 7) {
        if (tnd_frame_u(&f, TND_CT_VIS_ID)[2 * q] == TND_VIS_NONE ||
            tnd_frame_u(&f, TND_CT_PATH)[q] != 0)
            continue;
        uint32_t inst = tnd_frame_u(&f, TND_CT_VIS_ID)[2 * q];
        const tnd_material *m = &r.s->materials[r.s->meshes[r.s->instances[inst].mesh].material];
        textured += m->tex_base_color >= 0 || m->tex_normal >= 0;
        femb_gradient_sample one = {q, tnd_frame_u(&f, TND_CT_RNG)[2 * q],
                                    tnd_frame_u(&f, TND_CT_RNG)[2 * q + 1], inst,
                                    tnd_frame_u(&f, TND_CT_VIS_ID)[2 * q + 1],
                                    tnd_frame_f(&f, TND_CT_VIS_BARY)[2 * q],
                                    tnd_frame_f(&f, TND_CT_VIS_BARY)[2 * q + 1]};
        /* perturb g's outputs first, so that a pass that did not write them fails */
        tnd_frame_f(&g, TND_CT_HF)[3 * q] = -1.0f;
        REQUIRE_OK(femb_shade_gradients(r.c, &(femb_params){.bounces = 2}, &one, 1, &g));
        list[tested] = one;
        for (size_t k = 0; k < sizeof ct / sizeof *ct; k++) {
            uint32_t comps = tnd_ct_get(ct[k])->comps;
            bad += memcmp(tnd_frame_f(&f, ct[k]) + comps * q, tnd_frame_f(&g, ct[k]) + comps * q,
                          4 * comps) != 0;
        }
        tested++;
    }
    /* all of them again as one list (every 7th pixel: never a run) */
    for (int t = 0; t < tested; t++)
        tnd_frame_f(&g, TND_CT_HF)[3 * (size_t)list[t].pixel] = -1.0f;
    REQUIRE_OK(femb_shade_gradients(r.c, &(femb_params){.bounces = 2}, list, (uint32_t)tested, &g));
    for (int t = 0; t < tested; t++) {
        size_t q = list[t].pixel;
        for (size_t k = 0; k < sizeof ct / sizeof *ct; k++) {
            uint32_t comps = tnd_ct_get(ct[k])->comps;
            bad_list += memcmp(tnd_frame_f(&f, ct[k]) + comps * q,
                               tnd_frame_f(&g, ct[k]) + comps * q, 4 * comps) != 0;
        }
    }
    printf("     %d pixels shaded alone (%d textured), %d entries differ from the batched pass; "
           "as one list, %d differ\n",
           tested, textured, bad, bad_list);
    CHECK(tested > 100 && textured > 10, "%d pixels, %d textured", tested, textured);
    CHECK(bad == 0, "%d entries differ", bad);
    CHECK(bad_list == 0, "shaded as one list: %d entries differ", bad_list);
cleanup:
    tnd_frame_destroy(&f);
    tnd_frame_destroy(&g);
    rig_close(&r);
}

/* The real-time estimator with many bounces, averaged over frames, converges to the reference.
 * Compared on interior pixels (not within one pixel of an emitter or of the background): there
 * the pixel filters differ (16 Halton jitter positions against the reference's uniform jitter)
 * and the bright emitter's edge pixels would dominate the difference. */
/* Shade cornell's frame twice, the second time after `force` changed the context, and compare
 * hf, lf and spec bit for bit; `what` names the two code paths. */
static void shade_twice_agree(void (*force)(femb_context *c), uint32_t bounces, const char *what)
{
    rig r;
    tnd_frame f = {0};
    float *first = NULL;
    enum { W = 64, H = 36 };
    const tnd_ct ct[] = {TND_CT_HF, TND_CT_LF_SH, TND_CT_LF_COCG, TND_CT_SPEC};
    size_t words = 0, off = 0;
    for (size_t k = 0; k < sizeof ct / sizeof *ct; k++)
        words += (size_t)tnd_ct_get(ct[k])->comps * W * H;
    REQUIRE_OK(rig_open(&r, SCENES "cornell.gltf", 2));
    REQUIRE_OK(rig_frame(&r, 3, 0.5, 0.45, W, H, &f));
    REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = bounces}, &f, NULL));
    first = malloc(words * sizeof *first);
    CHECK(first != NULL, "out of memory");
    if (!first)
        goto cleanup;
    for (size_t k = 0; k < sizeof ct / sizeof *ct; k++) {
        size_t m = (size_t)tnd_ct_get(ct[k])->comps * W * H;
        memcpy(first + off, tnd_frame_f(&f, ct[k]), m * sizeof *first);
        memset(tnd_frame_f(&f, ct[k]), 0xff, m * sizeof *first); /* NaN: a pass that skips fails */
        off += m;
    }
    force(r.c);
    REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = bounces}, &f, NULL));
    size_t differ = 0, lit = 0, lf = 0;
    off = 0;
    for (size_t k = 0; k < sizeof ct / sizeof *ct; k++) {
        size_t m = (size_t)tnd_ct_get(ct[k])->comps * W * H;
        for (size_t i = 0; i < m; i++) {
            differ += memcmp(first + off + i, tnd_frame_f(&f, ct[k]) + i, 4) != 0;
            lit += ct[k] == TND_CT_HF && first[off + i] > 0.0f;
            lf += ct[k] == TND_CT_LF_SH && first[off + i] != 0.0f;
        }
        off += m;
    }
    printf("     %s: %zu of %zu words differ (%zu hf words lit, %zu lf words set)\n", what,
           differ, words, lit, lf);
    /* (most pixels see the light directly; a bounce that finds light sets an lf entry: about
     * a fifth of cornell's lf words) */
    CHECK(lit > W * H && lf > W * H / 2, "%zu hf words lit, %zu lf words set", lit, lf);
    CHECK(differ == 0, "%zu words differ", differ);
cleanup:
    free(first);
    tnd_frame_destroy(&f);
    rig_close(&r);
}

static void force_general_nee(femb_context *c) { c->triangle_lights_only = false; }
static void force_copied_lights(femb_context *c) { c->select_lights = false; }
/* (the flag of scenes with mirrors or glass: the shading pass then takes the general path loop;
 * on a scene without them it changes nothing else) */
static void force_general_paths(femb_context *c) { c->specular = true; }

/* The NEE sampling has a copy for scenes whose lights are all emissive triangles (no point,
 * spot or directional arithmetic) beside the general one; on `cornell` (two emitter triangles)
 * both must give the same bits. */
static void test_nee_copies_agree(void)
{
    shade_twice_agree(force_general_nee, 2, "triangle-only vs general NEE");
}

/* With few lights the NEE selects each light's record into the lanes that picked it; with more it
 * copies them lane by lane (no shipped scene has more than 8 lights): both, bit for bit. */
static void test_light_records_agree(void)
{
    shade_twice_agree(force_copied_lights, 2, "light records selected vs copied");
}

/* One bounce in a scene without mirrors or glass (the real-time default) has its own loop beside
 * the general path loop; on `cornell` both must give the same bits. */
static void test_one_bounce_agrees(void)
{
    shade_twice_agree(force_general_paths, 1, "one-bounce loop vs general path loop");
}

/* femb_render shades each batch from its staged G-buffer right after its primary pass; it must
 * give every plane of the contract and the radiance bit for bit as femb_trace_primary followed by
 * femb_shade, on each shipped scene (one bounce without mirrors or glass, the general path loop
 * with them; sky lanes inside batches; a width that is not a multiple of the 64-lane batch). */
static void test_render_agrees(void)
{
    const char *scenes[] = {SCENES "cornell.gltf", SCENES "materials.gltf", SCENES "sun.gltf",
                            SCENES "dynamic.gltf", SCENES "extremes.gltf"};
    enum { W = 100, H = 37 };
    static float rad_a[W * H * 3], rad_b[W * H * 3];
    for (int k = 0; k < 5; k++) {
        for (uint32_t bounces = 1; bounces <= 2; bounces++) {
            rig r;
            tnd_frame a = {0}, b = {0};
            const femb_params p = {.bounces = bounces};
            REQUIRE_OK(rig_open(&r, scenes[k], 2));
            REQUIRE_OK(tnd_scene_evaluate(r.s, 0.5, 0, (float)W / H, &r.cur));
            REQUIRE_OK(tnd_scene_evaluate(r.s, 0.45, 0, (float)W / H, &r.prev));
            REQUIRE_OK(test_embree_frame(r.c, &r.cur, &r.prev, 3, W, H, NULL, &a));
            REQUIRE_OK(femb_shade(r.c, &p, &a, rad_a));
            REQUIRE_OK(tnd_frame_create(W, H, &b));
            for (int e = 0; e < TND_CT_COUNT; e++) /* NaN: a plane the sweep skips fails */
                memset(b.data[e], 0xff, (size_t)W * H * tnd_ct_get((tnd_ct)e)->comps * 4);
            memset(rad_b, 0xff, sizeof rad_b);
            REQUIRE_OK(femb_render(r.c, &p, &b, rad_b));
            size_t differ = 0, words = 0, sky = 0, lit = 0;
            for (int e = 0; e < TND_CT_COUNT; e++) {
                size_t m = (size_t)W * H * tnd_ct_get((tnd_ct)e)->comps;
                CHECK(a.present[e] == b.present[e], "%s: '%s' present %d vs %d", scenes[k],
                      tnd_ct_get((tnd_ct)e)->name, a.present[e], b.present[e]);
                if (!a.present[e])
                    continue;
                for (size_t i = 0; i < m; i++)
                    differ += memcmp((const float *)a.data[e] + i, (const float *)b.data[e] + i,
                                     4) != 0;
                words += m;
            }
            for (size_t i = 0; i < (size_t)W * H * 3; i++)
                differ += memcmp(rad_a + i, rad_b + i, 4) != 0;
            for (size_t q = 0; q < (size_t)W * H; q++) {
                sky += tnd_frame_u(&a, TND_CT_VIS_ID)[2 * q] == TND_VIS_NONE;
                lit += tnd_frame_f(&a, TND_CT_HF)[3 * q] > 0.0f;
            }
            printf("     %s, %u bounce%s: %zu of %zu words differ (%zu sky pixels, %zu lit)\n",
                   strrchr(scenes[k], '/') + 1, bounces, bounces > 1 ? "s" : "", differ,
                   words + (size_t)W * H * 3, sky, lit);
            CHECK(differ == 0, "%s: %zu words differ", scenes[k], differ);
            /* (enough signal to compare: cornell, the least lit at this wide aspect, has its
             * box in the middle third and 854 of its 3700 pixels lit directly) */
            CHECK(lit > W * H / 5, "%s: %zu pixels lit", scenes[k], lit);
        cleanup:
            tnd_frame_destroy(&a);
            tnd_frame_destroy(&b);
            rig_close(&r);
        }
    }
}

static void test_many_bounces_converge(void)
{
    rig r;
    tnd_frame f = {0};
    /* (128 frames under the sanitizers, where 512 took 56 s: the bounds are the measured
     * variance's, so they widen with fewer frames) */
    enum { W = 48, H = 32, N = 512 / TND_TEST_SAMPLES_DIV };
    static double acc[W * H], acc2[W * H];
    static float ref[W * H * 3], tmp[W * H * 3];
    static unsigned char edge[W * H];
    memset(acc, 0, sizeof acc);
    memset(acc2, 0, sizeof acc2);
    memset(edge, 0, sizeof edge);
    REQUIRE_OK(rig_open(&r, SCENES "cornell.gltf", 2));
    for (uint32_t i = 0; i < N; i++) {
        REQUIRE_OK(rig_frame(&r, i, 0.0, 0.0, W, H, &f));
        REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = 64}, &f, NULL));
        tnd_frame_composite(&f, tmp);
        for (int q = 0; q < W * H; q++) {
            double l = tnd_luminance(tmp[3 * q], tmp[3 * q + 1], tmp[3 * q + 2]);
            acc[q] += l;
            acc2[q] += l * l;
            const float *e = tnd_frame_f(&f, TND_CT_EMISSION) + 3 * q;
            if (e[0] > 0 || tnd_frame_u(&f, TND_CT_VIS_ID)[2 * q] == TND_VIS_NONE)
                edge[q] = 1;
        }
        tnd_frame_destroy(&f);
    }
    REQUIRE_OK(femb_reference(r.c, N, ref, NULL, NULL, NULL, NULL));
    double mt = 0, mr = 0, var = 0;
    int n = 0, outliers = 0;
    for (int y = 1; y < H - 1; y++)
        for (int x = 1; x < W - 1; x++) {
            bool skip = false;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++)
                    skip |= edge[(y + dy) * W + x + dx];
            if (skip)
                continue;
            int q = y * W + x;
            double m = acc[q] / N, v = fmax(acc2[q] / N - m * m, 0) / N;
            double rl = tnd_luminance(ref[3 * q], ref[3 * q + 1], ref[3 * q + 2]);
            mt += m, mr += rl, var += v, n++;
            /* each estimator's pixel mean has variance about v: the difference 2v */
            outliers += fabs(m - rl) > 5 * sqrt(2 * v) + 1e-6;
        }
    mt /= n, mr /= n;
    double se = sqrt(2 * var) / n;
    printf("     %d interior pixels: real-time (64 bounces) %.5f, reference %.5f: %.2f%%, %.1f "
           "standard errors; %d pixels beyond 5 sigma\n",
           n, mt, mr, 100 * (mt - mr) / mr, fabs(mt - mr) / se, outliers);
    CHECK(n > W * H / 3, "enough interior pixels (%d)", n);
    CHECK(fabs(mt - mr) < 5 * se, "means differ by %.1f standard errors", fabs(mt - mr) / se);
    CHECK(outliers <= n / 100, "%d pixels differ beyond 5 sigma", outliers);
cleanup:
    tnd_frame_destroy(&f);
    rig_close(&r);
}

/* Motion vectors point to where the surface was: in the `dynamic` scene (moving camera and a
 * moving cube), following a pixel's motion into the previous frame's render lands on the same
 * instance, and the previous depth matches depth + motion.z. */
static void test_motion_vectors(void)
{
    rig r;
    tnd_frame a = {0}, b = {0};
    enum { W = 96, H = 54 };
    const double fps = 30.0;
    REQUIRE_OK(rig_open(&r, SCENES "dynamic.gltf", 2));
    uint32_t cube = UINT32_MAX;
    for (uint32_t i = 0; i < r.s->instance_count; i++)
        if (strcmp(r.s->meshes[r.s->instances[i].mesh].name, "moving_cube") == 0)
            cube = i;
    /* "previous" is 4 frames back, so that the camera moves by several pixels */
    REQUIRE_OK(rig_frame(&r, 40, 40 / fps, 36 / fps, W, H, &b)); /* current */
    REQUIRE_OK(rig_frame(&r, 36, 36 / fps, 35 / fps, W, H, &a)); /* previous */
    int valid = 0, same = 0, cube_valid = 0, cube_same = 0, depth_ok = 0, moving = 0;
    int cube_static = 0; /* control: cube pixels that land on the cube when motion is ignored */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t q = (size_t)y * W + x;
            uint32_t inst = tnd_frame_u(&b, TND_CT_VIS_ID)[2 * q];
            if (inst == TND_VIS_NONE)
                continue;
            const float *m = tnd_frame_f(&b, TND_CT_MOTION) + 3 * q;
            moving += fabsf(m[0]) + fabsf(m[1]) > 0.5f;
            double px = x + 0.5 + b.camera.jitter[0] + m[0];
            double py = y + 0.5 + b.camera.jitter[1] + m[1];
            long ix = lround(px - 0.5 - a.camera.jitter[0]), iy = lround(py - 0.5 - a.camera.jitter[1]);
            if (ix < 1 || iy < 1 || ix >= W - 1 || iy >= H - 1)
                continue;
            size_t pq = (size_t)iy * W + (size_t)ix;
            uint32_t pinst = tnd_frame_u(&a, TND_CT_VIS_ID)[2 * pq];
            bool hit = pinst == inst;
            valid++, same += hit;
            if (inst == cube) {
                cube_valid++, cube_same += hit;
                cube_static += tnd_frame_u(&a, TND_CT_VIS_ID)[2 * q] == cube;
            }
            if (hit) {
                float dprev = tnd_frame_f(&a, TND_CT_DEPTH)[pq];
                float dcur = tnd_frame_f(&b, TND_CT_DEPTH)[q];
                /* within a pixel's depth footprint: half a pixel of slope at grazing 80 deg */
                depth_ok += fabsf(dprev - (dcur + m[2])) < 0.02f * dcur;
            }
        }
    printf("     motion: %d of %d pixels land on the same instance (cube %d of %d; %d without "
           "motion vectors), depth consistent for %d; %d pixels move by > 0.5 px\n",
           same, valid, cube_same, cube_valid, cube_static, depth_ok, moving);
    CHECK(moving > valid / 4, "the camera moves: many pixels have motion (%d)", moving);
    CHECK(cube_static < 0.8 * cube_valid, "control: ignoring motion loses the cube (%d of %d)",
          cube_static, cube_valid);
    CHECK(same >= 0.97 * valid, "%d of %d reprojected pixels hit the same instance", same, valid);
    CHECK(cube_valid > 20 && cube_same >= 0.9 * cube_valid,
          "moving cube: %d of %d reproject onto it", cube_same, cube_valid);
    CHECK(depth_ok >= 0.95 * same, "depth + motion.z matches the previous depth (%d of %d)",
          depth_ok, same);
cleanup:
    tnd_frame_destroy(&a);
    tnd_frame_destroy(&b);
    rig_close(&r);
}

static void test_extremes_finite(void)
{
    rig r;
    tnd_frame f = {0};
    enum { W = 64, H = 36 };
    static float rgb[W * H * 3];
    REQUIRE_OK(rig_open(&r, SCENES "extremes.gltf", 2));
    for (int fr = 0; fr < 3; fr++) {
        REQUIRE_OK(rig_frame(&r, (uint32_t)fr, fr * 0.7, fr ? (fr - 1) * 0.7 : 0, W, H, &f));
        REQUIRE_OK(femb_shade(r.c, &(femb_params){.bounces = 3}, &f, NULL));
        int bad = 0;
        for (int e = 0; e < TND_CT_COUNT; e++) {
            const tnd_ct_info *ci = tnd_ct_get((tnd_ct)e);
            if (ci->kind != TND_CT_FLOAT || e == TND_CT_DEPTH)
                continue; /* depth holds the finite TND_DEPTH_MISS */
            for (size_t k = 0; k < (size_t)W * H * ci->comps; k++)
                bad += !isfinite(tnd_frame_f(&f, (tnd_ct)e)[k]);
        }
        for (size_t k = 0; k < (size_t)W * H; k++)
            bad += !isfinite(tnd_frame_f(&f, TND_CT_DEPTH)[k]);
        CHECK(bad == 0, "frame %d: %d non-finite values in the contract", fr, bad);
        tnd_frame_destroy(&f);
    }
    REQUIRE_OK(femb_reference(r.c, 8, rgb, NULL, NULL, NULL, NULL));
    int bad = 0;
    for (int k = 0; k < W * H * 3; k++)
        bad += !isfinite(rgb[k]) || rgb[k] < 0;
    CHECK(bad == 0, "%d non-finite reference values", bad);
cleanup:
    tnd_frame_destroy(&f);
    rig_close(&r);
}

/* Motion vectors and depth of the extremes scene, whose whole content (camera included) stands
 * 1e5 units from the origin, against the same in double precision, each value within the bound
 * of float arithmetic done relative to the cameras (tests/motion_reference.h). The plane is seen
 * down to 0.07 units from the camera (motion up to 60 px). Measured: 6e-5 px, 3e-6 units of
 * depth change, 1.4e-7 relative depth, at most 0.12 of the bound; forming the world point in
 * float first (rounded to 1/128 there) is off by up to 6 px and 7% of the depth, 800 times the
 * bound. */
static void test_motion_far_from_origin(void)
{
    rig r;
    tnd_frame f = {0};
    enum { W = 256, H = 144 };
    motion_error e = {0};
    REQUIRE_OK(rig_open(&r, SCENES "extremes.gltf", 2));
    for (int fr = 1; fr < 6; fr++) {
        REQUIRE_OK(rig_frame(&r, (uint32_t)fr, fr / 30.0, (fr - 1) / 30.0, W, H, &f));
        motion_reference_add(r.s, &r.cur, &r.prev, &f, &e);
        tnd_frame_destroy(&f);
    }
    motion_reference_check(&e, 10000);
cleanup:
    tnd_frame_destroy(&f);
    rig_close(&r);
}

/* The reflect/refract chain of the primary pass on `materials` (a mirror, glass): the pixels
 * that look into the mirror or through the glass (throughput below 1) show in the G-buffer the
 * opaque surface at the chain's end (its material, not the mirror's or the glass's), at a depth
 * (the chain's length) never shorter than the straight distance to it, longer for the mirror's
 * detour; motion vectors stay finite.
 * tests/test_frontend_vk.c compares the same G-buffer with the Vulkan front-end's. */
static void test_mirror_gbuffer(void)
{
    rig r;
    tnd_frame f = {0};
    REQUIRE_OK(rig_open(&r, SCENES "materials.gltf", 2));
    enum { W = 96, H = 54 };
    REQUIRE_OK(rig_frame(&r, 0, 0.0, 0.0, W, H, &f));
    const tnd_scene *s = r.s;
    int chained = 0, opaque_end = 0, longer = 0, shorter = 0, mirror_seen = 0, split = 0,
        refract_field = 0;
    const float *cam = r.cur.camera_position;
    for (int q = 0; q < W * H; q++) {
        uint32_t inst = tnd_frame_u(&f, TND_CT_VIS_ID)[2 * q];
        uint32_t path = tnd_frame_u(&f, TND_CT_PATH)[q];
        if (path == 0u || inst == TND_VIS_NONE)
            continue;
        split += (path & TND_PATH_SPLIT) != 0u;
        refract_field += (path & TND_PATH_REFRACT) != 0u;
        chained++;
        const tnd_material *m = &s->materials[s->meshes[s->instances[inst].mesh].material];
        opaque_end += m->kind == TND_MAT_OPAQUE;
        const float *p = tnd_frame_f(&f, TND_CT_POSITION) + 3 * q;
        double d = sqrt((p[0] - cam[0]) * (p[0] - cam[0]) + (p[1] - cam[1]) * (p[1] - cam[1]) +
                        (p[2] - cam[2]) * (p[2] - cam[2]));
        /* never shorter than the straight line; a mirror's detour is longer (through thin glass
         * the path is straight) */
        longer += tnd_frame_f(&f, TND_CT_DEPTH)[q] > d * (1 + 1e-3);
        shorter += tnd_frame_f(&f, TND_CT_DEPTH)[q] < d * (1 - 1e-5);
        const float *alb = tnd_frame_f(&f, TND_CT_ALBEDO) + 3 * q;
        mirror_seen += m->kind == TND_MAT_OPAQUE && fabsf(alb[0] - m->base_color[0]) < 1e-6f;
        const float *mo = tnd_frame_f(&f, TND_CT_MOTION) + 3 * q;
        CHECK(isfinite(mo[0]) && isfinite(mo[1]) && isfinite(mo[2]), "motion at %d", q);
    }
    printf("     materials: %d pixels look into the mirror or through glass; %d end on an opaque "
           "surface, %d at a depth beyond the straight distance\n", chained, opaque_end, longer);
    CHECK(chained > 100, "%d pixels", chained);
    CHECK(opaque_end > chained * 9 / 10, "%d of %d end on an opaque surface", opaque_end, chained);
    CHECK(shorter == 0, "%d pixels nearer than the straight line", shorter);
    CHECK(longer > 50, "only %d pixels seen by a detour (the mirror)", longer);
    CHECK(mirror_seen > 0, "the albedo is the reflected material's");
    /* the glass splits its pixels: both fields present, about half each */
    printf("     %d split pixels, %d of them in the refraction field\n", split, refract_field);
    CHECK(split > 20 && refract_field > split / 4 && refract_field < split * 3 / 4,
          "%d split pixels, %d refracting", split, refract_field);
cleanup:
    tnd_frame_destroy(&f);
    rig_close(&r);
}

/* A pure-Lambert sphere under a uniform environment of radiance 1 returns its albedo (0.5 and
 * the white furnace's 1) within 0.5% in the reference mode, lit by the uniform sky and by a
 * constant environment map sampled by importance (tests/env_sphere.h). */
static tnd_result env_sphere_render(tnd_scene *s, const tnd_scene_state *st, float *rgb,
                                    void *user)
{
    (void)user;
    femb_context *c = NULL;
    tnd_result r = femb_create(s, &(femb_desc){.threads = 2}, &c);
    if (r == TND_OK)
        r = femb_set_frame(c, st, st, 0, ES_W, ES_H);
    if (r == TND_OK)
        r = femb_reference(c, 64, rgb, NULL, NULL, NULL, NULL);
    femb_destroy(c);
    return r;
}

static void test_env_sphere(void)
{
    es_run("embree", env_sphere_render, NULL);
}

/* The cutout scene's wire fence (alphaMode MASK, cutoff 0.5; 4 m x 1.5 m in the plane z = 0, its
 * 32-texel tile repeated per metre, bars of 4 texels every 16 in both directions): rays straight
 * through it meet it where the texture has its bars, 1 - (12/16)^2 = 43.75% of its area (the
 * bilinear alpha crosses the cutoff at the texel edges), and shadow rays are stopped by the same
 * part; a ray meets nothing else of the fence. (The Vulkan front-end's any-hit shader and
 * candidate loop: test_shading_matches_embree on the same scene.) */
static void test_alpha_cutout(void)
{
    tnd_scene *s = NULL;
    femb_context *c = NULL;
    tnd_scene_state st = {0};
    REQUIRE_OK(tnd_scene_load(SCENES "cutout.gltf", &s));
    REQUIRE_OK(femb_create(s, &(femb_desc){.threads = 1}, &c));
    REQUIRE_OK(tnd_scene_evaluate(s, 0, 0, 1.0f, &st));
    REQUIRE_OK(femb_set_frame(c, &st, &st, 0, 16, 16));
    uint32_t fence = ~0u;
    for (uint32_t i = 0; i < s->instance_count; i++)
        if (strcmp(s->nodes[s->instances[i].node].name, "fence") == 0)
            fence = i;
    REQUIRE(fence != ~0u, "the fence instance");
    enum { NX = 800, NY = 300 };
    int hits = 0, occluded = 0, disagree = 0, n = 0;
    for (int y = 0; y < NY; y++)
        for (int x = 0; x < NX; x++) {
            v3 o = {-2.0f + 4.0f * (x + 0.5f) / NX, 1.5f * (y + 0.5f) / NY, 0.5f};
            v3 d = {0, 0, -1};
            uint32_t inst, prim;
            float u, v, t;
            bool h = femb_intersect(c, o, d, 1.0f, &inst, &prim, &u, &v, &t) && inst == fence;
            bool occ = femb_occluded(c, o, d, 1.0f); /* (only the fence lies within 1 m) */
            hits += h;
            occluded += occ;
            disagree += h != occ;
            n++;
        }
    double frac = (double)hits / n;
    printf("     fence: %.2f%% of %d rays meet it (43.75%% expected), %d shadow rays stopped, %d "
           "disagree\n",
           100 * frac, n, occluded, disagree);
    CHECK(fabs(frac - 0.4375) < 0.005, "the fence's coverage %.4f", frac);
    CHECK(disagree == 0, "%d closest-hit and shadow rays disagree", disagree);
cleanup:
    tnd_scene_state_free(&st);
    femb_destroy(c);
    tnd_scene_destroy(s);
}

/* KHR_texture_transform on Khronos' TextureTransformTest (Debian's assimp-testmodels): its top
 * row offsets the UV texture by (0.5, 0), (0, 0.5) and (0.5, 0.5) so that each quad shows a
 * green, a blue and a cyan square with a tick (yellow where the offset is not applied). The
 * G-buffer's albedo over each quad's pixels must have that colour. (The rotation and scale quads'
 * arrows: docs/scenes.md shows them; the two front-ends' albedo: test_gbuffer_matches_embree.) */
static void test_texture_transform(void)
{
    const char *path = "/usr/share/assimp/models/glTF2/textureTransform/TextureTransformTest.gltf";
    if (access(path, R_OK) != 0) {
        printf("     skip: %s absent (assimp-testmodels)\n", path);
        return;
    }
    rig r;
    enum { W = 160, H = 120 };
    tnd_frame f = {0};
    REQUIRE_OK(rig_open(&r, path, 2));
    REQUIRE_OK(rig_frame(&r, 0, 0, 0, W, H, &f));
    const char *names[3] = {"Offset U", "Offset V", "Offset UV"};
    for (int k = 0; k < 3; k++) {
        double sum[3] = {0, 0, 0};
        int n = 0;
        for (int q = 0; q < W * H; q++) {
            uint32_t inst = tnd_frame_u(&f, TND_CT_VIS_ID)[2 * q];
            if (inst == TND_VIS_NONE)
                continue;
            const tnd_scene *sc = r.s;
            const tnd_material *m = &sc->materials[sc->meshes[sc->instances[inst].mesh].material];
            if (strcmp(m->name, names[k]) != 0)
                continue;
            for (int c = 0; c < 3; c++)
                sum[c] += tnd_frame_f(&f, TND_CT_ALBEDO)[3 * q + c];
            n++;
        }
        for (int c = 0; c < 3; c++)
            sum[c] /= n > 0 ? n : 1;
        printf("     %s: %d pixels, mean albedo %.2f %.2f %.2f\n", names[k], n, sum[0], sum[1],
               sum[2]);
        CHECK(n > 100, "%s: %d pixels", names[k], n);
        /* green: G over R and B; blue: B over R and G; cyan: G and B over R (yellow: R and G
         * over B) */
        bool ok = k == 0   ? sum[1] > 1.5 * sum[0] && sum[1] > 1.5 * sum[2]
                  : k == 1 ? sum[2] > 1.5 * sum[0] && sum[2] > 1.5 * sum[1]
                           : sum[1] > 1.5 * sum[0] && sum[2] > 1.5 * sum[0];
        CHECK(ok, "%s shows the wrong part of its texture (%.2f %.2f %.2f)", names[k], sum[0],
              sum[1], sum[2]);
    }
cleanup:
    tnd_frame_destroy(&f);
    rig_close(&r);
}

TND_TEST_MAIN(T(test_furnace_lambert), T(test_env_sphere), T(test_alpha_cutout),
              T(test_texture_transform), T(test_furnace_ggx), T(test_furnace_glass),
              T(test_total_internal_reflection), T(test_rotated_instance_normals),
              T(test_mirror_gbuffer), T(test_composite_equals_radiance),
              T(test_deterministic_threads), T(test_gradient_samples_reproduce), T(test_batch_independent),
              T(test_nee_copies_agree), T(test_one_bounce_agrees),
              T(test_light_records_agree), T(test_render_agrees),
              T(test_many_bounces_converge), T(test_motion_vectors),
              T(test_motion_far_from_origin), T(test_extremes_finite), T(test_lambert_emitters),
              T(test_reference_frames_independent), T(test_restir_unbiased))
