/* tests/test_env.c: environment maps (core/env.c, shaders/env.h): the orientation convention and
 * rotation, the sampling density against the lookup and against 1 over the sphere, importance
 * sampling against uniform sphere sampling on real HDRIs (Debian's blender-data: HDRI Haven,
 * CC0), and bad input (missing, not 2:1, not RGB, NaN/Inf/negative texels, the scene's
 * tandem_env). Label: unit (CPU only). */
#include "core/core.h"
#include "shaders/brdf.h"
#include "tests/tnd_test.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define HDRIS "/usr/share/blender/datafiles/studiolights/world/"

static uint32_t lcg_state = 12345u;
static float frand(void)
{
    lcg_state = lcg_state * 1664525u + 1013904223u;
    return (float)(lcg_state >> 8) * (1.0f / 16777216.0f);
}

static double dot3(const float *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* One bright texel: every sample lands in its solid angle, centred where the convention says
 * (the image's centre faces +X; a rotation of 90 degrees about +Y turns +X to -Z), and each
 * sampled direction looks up the texel it came from with the density it was drawn with. */
static void test_convention(void)
{
    enum { W = 16, H = 8 };
    static float px[W * H * 3];
    tnd_env e = {0};
    /* texel (8, 4): u in [1/2, 9/16), v in [1/2, 5/8): phi in [0, 22.5] degrees, theta in [90,
     * 112.5] degrees: about (0.96, -0.2, 0.19) */
    for (int k = 0; k < 3; k++)
        px[3 * (4 * W + 8) + k] = 5.0f;
    px[3 * (1 * W + 3) + 1] = 1e-3f; /* a faint second texel, for the lookup test */
    const double ph = 11.25 * TND_PI / 180, th = 101.25 * TND_PI / 180;
    const double centre[3] = {cos(ph) * sin(th), cos(th), sin(ph) * sin(th)};
    for (int r = 0; r < 2; r++) {
        double rot = r ? 90.0 : 0.0;
        REQUIRE_OK(tnd_env_from_pixels("one texel", px, W, H, 1.0f, (float)rot, &e));
        double c = cos(rot * TND_PI / 180), s = sin(rot * TND_PI / 180);
        double want[3] = {c * centre[0] + s * centre[2], centre[1],
                          -s * centre[0] + c * centre[2]};
        double mean[3] = {0, 0, 0}, worst_cos = 1;
        int mismatched = 0, bright = 0;
        const int N = 20000;
        for (int i = 0; i < N; i++) {
            float d[3], rgb[3], look[3];
            float pdf = tnd_env_sample(&e, frand(), frand(), d, rgb);
            float lpdf = tnd_env_lookup(&e, d, look);
            bool in_bright = rgb[0] == 5.0f;
            bright += in_bright;
            /* the same texel and density (a direction on a texel's edge may round into the
             * neighbour: rare) */
            mismatched += !(look[0] == rgb[0] && look[1] == rgb[1] &&
                            fabsf(lpdf - pdf) <= 1e-4f * pdf);
            for (int k = 0; k < 3; k++)
                mean[k] += d[k] / N;
            worst_cos = in_bright ? fmin(worst_cos, dot3(d, want)) : worst_cos;
        }
        double ml = sqrt(dot3((float[3]){(float)mean[0], (float)mean[1], (float)mean[2]}, mean));
        double cos_mean = (mean[0] * want[0] + mean[1] * want[1] + mean[2] * want[2]) / ml;
        printf("     rotation %3.0f: mean sample direction (%.3f %.3f %.3f), cos to the texel's "
               "centre %.5f, widest sample %.1f degrees off; %d of %d lookups elsewhere\n",
               rot, mean[0] / ml, mean[1] / ml, mean[2] / ml, cos_mean,
               acos(worst_cos) * 180 / TND_PI, mismatched, N);
        /* the faint texel takes 1e-3/5 x its smaller sin of the weight: almost every sample is
         * in the bright one, all within its half-diagonal (~16 degrees) of its centre */
        CHECK(bright > N * 99 / 100, "%d of %d samples in the bright texel", bright, N);
        CHECK(cos_mean > 0.999, "the samples' mean direction is the texel's (cos %.5f)",
              cos_mean);
        CHECK(worst_cos > cos(17 * TND_PI / 180), "a sample %.1f degrees away",
              acos(worst_cos) * 180 / TND_PI);
        CHECK(mismatched <= N / 1000, "%d samples look up another texel or density", mismatched);
    }
cleanup:
    tnd_env_free(&e);
}

/* The density integrates to 1 over the sphere and the stored mean luminance is the radiance's
 * (both by quadrature over a grid four times finer than the texels), on a real HDRI. */
static void test_density_normalised(void)
{
    tnd_env e = {0};
    REQUIRE_OK(tnd_env_load(HDRIS "forest.exr", 2.0f, 30.0f, &e));
    CHECK(e.width == 1024 && e.height == 512, "forest.exr is %ux%u", e.width, e.height);
    const int NX = 4 * 1024, NY = 4 * 512;
    double pint = 0, lint = 0;
    for (int y = 0; y < NY; y++) {
        double th0 = TND_PI * y / NY, th1 = TND_PI * (y + 1) / NY, th = 0.5 * (th0 + th1);
        double dw = 2 * TND_PI / NX * (cos(th0) - cos(th1));
        for (int x = 0; x < NX; x++) {
            double ph = 2 * TND_PI * ((x + 0.5) / NX - 0.5);
            float d[3] = {(float)(cos(ph) * sin(th)), (float)cos(th), (float)(sin(ph) * sin(th))};
            /* (the world direction of this local one under the 30-degree rotation) */
            double c = cos(30 * TND_PI / 180), s = sin(30 * TND_PI / 180);
            float w[3] = {(float)(c * d[0] + s * d[2]), d[1], (float)(-s * d[0] + c * d[2])};
            float rgb[3];
            pint += tnd_env_lookup(&e, w, rgb) * dw;
            lint += tnd_luminance(rgb[0], rgb[1], rgb[2]) * dw;
        }
    }
    printf("     forest.exr x2, rotated 30 degrees: density integrates to %.6f; mean luminance "
           "%.5f (stored %.5f); %u bad texels\n",
           pint, lint / (4 * TND_PI), e.mean_luminance, e.bad_texels);
    /* the quadrature's error: the density varies with 1/sin(theta) inside a texel row */
    CHECK(fabs(pint - 1) < 2e-3, "the density integrates to %.6f", pint);
    CHECK(fabs(lint / (4 * TND_PI) / e.mean_luminance - 1) < 2e-3, "mean luminance %.6g vs %.6g",
          lint / (4 * TND_PI), e.mean_luminance);
cleanup:
    tnd_env_free(&e);
}

/* Must show: on forest.exr and sunset.exr, the irradiance of a surface (facing up, and facing
 * the map's brightest texel). Uniform sphere sampling's expectation and both estimators' variances
 * are computed exactly, by quadrature over the texels (4 x 4 points each): the uniform estimator
 * is heavy-tailed (a few samples hit the sun), so its sample mean and variance from a feasible
 * count mislead (run under ASan with a quarter of the samples, it once missed the sun: a 6% low
 * mean "within" an underestimated error). The importance-sampled mean must agree with that
 * expectation within 4.5 of its exact standard errors; the variance ratio is printed and must be
 * at least 10 on sunset facing its sun. */
static void test_importance_vs_uniform(void)
{
    const char *maps[2] = {"forest.exr", "sunset.exr"};
    tnd_env e = {0};
    for (int m = 0; m < 2; m++) {
        char path[256];
        snprintf(path, sizeof path, HDRIS "%s", maps[m]);
        REQUIRE_OK(tnd_env_load(path, 1.0f, 0.0f, &e));
        /* the brightest texel's direction */
        size_t best = 0;
        for (size_t i = 0; i < (size_t)e.width * e.height; i++)
            if (tnd_luminance(e.data[4 * i], e.data[4 * i + 1], e.data[4 * i + 2]) >
                tnd_luminance(e.data[4 * best], e.data[4 * best + 1], e.data[4 * best + 2]))
                best = i;
        double bu = (best % e.width + 0.5) / e.width, bv = (best / e.width + 0.5) / e.height;
        double bph = 2 * TND_PI * (bu - 0.5), bth = TND_PI * bv;
        double normals[2][3] = {{0, 1, 0},
                                {cos(bph) * sin(bth), cos(bth), sin(bph) * sin(bth)}};
        for (int k = 0; k < 2; k++) {
            const double *n = normals[k];
            /* exact: E = sum L cos dw; second moments sum (L cos)^2 / p dw, p the importance
             * density or 1 / 4 pi */
            double exact = 0, m2_imp = 0, m2_uni = 0;
            for (uint32_t y = 0; y < 4 * e.height; y++) {
                double th0 = TND_PI * y / (4.0 * e.height);
                double th1 = TND_PI * (y + 1) / (4.0 * e.height), th = 0.5 * (th0 + th1);
                double dw = 2 * TND_PI / (4.0 * e.width) * (cos(th0) - cos(th1));
                for (uint32_t x = 0; x < 4 * e.width; x++) {
                    double ph = 2 * TND_PI * ((x + 0.5) / (4.0 * e.width) - 0.5);
                    double d[3] = {cos(ph) * sin(th), cos(th), sin(ph) * sin(th)};
                    double c = d[0] * n[0] + d[1] * n[1] + d[2] * n[2];
                    if (c <= 0)
                        continue;
                    const float *t = e.data + 4 * ((size_t)(y / 4) * e.width + x / 4);
                    double f = tnd_luminance(t[0], t[1], t[2]) * c;
                    double p = tnd_env_pdf(t[3], (float)sin(th));
                    exact += f * dw;
                    m2_imp += p > 0 ? f * f / p * dw : 0;
                    m2_uni += f * f * 4 * TND_PI * dw;
                }
            }
            double var_imp = m2_imp - exact * exact, var_uni = m2_uni - exact * exact;
            const int N = 200000 / TND_TEST_SAMPLES_DIV;
            double si = 0;
            for (int i = 0; i < N; i++) {
                float d[3], rgb[3];
                float pdf = tnd_env_sample(&e, frand(), frand(), d, rgb);
                double c = dot3(d, n);
                si += pdf > 0 && c > 0 ? tnd_luminance(rgb[0], rgb[1], rgb[2]) * c / pdf : 0;
            }
            double mi = si / N, sei = sqrt(var_imp / N);
            printf("     %s, facing %s: irradiance (uniform sampling's expectation) %.5g, "
                   "importance %.5g (se %.2g); variance %.3g uniform, %.3g importance: %.1fx "
                   "lower\n",
                   maps[m], k ? "its brightest texel" : "up", exact, mi, sei, var_uni, var_imp,
                   var_uni / var_imp);
            CHECK(fabs(mi - exact) < 4.5 * sei + 1e-4 * exact,
                  "%s: importance %.6g vs uniform's expectation %.6g", maps[m], mi, exact);
            CHECK(var_imp < var_uni, "%s: importance sampling has more variance", maps[m]);
            if (m == 1 && k == 1)
                CHECK(var_uni >= 10 * var_imp, "sunset facing the sun: variance lower by only "
                      "%.1fx", var_uni / var_imp);
        }
    }
cleanup:
    tnd_env_free(&e);
}

/* Write an EXR of w x h with the given channels (all float, values from `fill`). */
static void write_exr(const char *path, uint32_t w, uint32_t h, const char *const *names, int nc,
                      const float *data)
{
    tnd_exr_channel_desc ch[4];
    for (int c = 0; c < nc; c++)
        ch[c] = (tnd_exr_channel_desc){names[c], TND_EXR_FLOAT, data + c, (uint32_t)nc};
    CHECK_OK(tnd_exr_write(path, w, h, ch, (uint32_t)nc, NULL, 0, TND_EXR_ZIP));
}

/* Copy data/scenes/sun.gltf and its buffer into dir with scenes[0].extras.tandem_env naming
 * `uri` (intensity 2, rotation 45); the glTF's path in out. */
static bool scene_with_env(const char *dir, const char *uri, char *out, size_t cap)
{
    void *text = NULL, *bin = NULL;
    size_t n = 0, nb = 0;
    if (tnd_file_read(TND_SOURCE_DIR "/data/scenes/sun.gltf", &text, &n) != TND_OK ||
        tnd_file_read(TND_SOURCE_DIR "/data/scenes/sun.bin", &bin, &nb) != TND_OK)
        return false;
    cJSON *j = cJSON_ParseWithLength(text, n);
    cJSON *ex = cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(j, "scenes"), 0),
                                    "extras");
    cJSON *env = cJSON_AddObjectToObject(ex, "tandem_env");
    cJSON_AddStringToObject(env, "uri", uri);
    cJSON_AddNumberToObject(env, "intensity", 2);
    cJSON_AddNumberToObject(env, "rotation", 45);
    char *txt = cJSON_Print(j), path[512];
    snprintf(path, sizeof path, "%s/sun.bin", dir);
    FILE *f = fopen(path, "wb");
    bool ok = f && fwrite(bin, 1, nb, f) == nb;
    if (f)
        fclose(f);
    snprintf(out, cap, "%s/scene.gltf", dir);
    f = fopen(out, "w");
    ok = ok && f && txt && fputs(txt, f) >= 0;
    if (f)
        fclose(f);
    free(txt);
    cJSON_Delete(j);
    free(text);
    free(bin);
    return ok;
}

/* Bad input: each refused with a message naming the file and the problem, the environment left
 * as it was; bad texels counted and set to 0; a scene naming a missing map fails naming both. */
static void test_bad_input(void)
{
    char dir[] = "/tmp/tandem_env_XXXXXX", path[512], gltf[512];
    REQUIRE(mkdtemp(dir), "mkdtemp");
    static float px[64 * 32 * 4];
    const char *rgb[3] = {"R", "G", "B"}, *y[1] = {"Y"};
    tnd_env e = {0};
    /* missing */
    snprintf(path, sizeof path, "%s/missing.exr", dir);
    tnd_result r = tnd_env_load(path, 1, 0, &e);
    CHECK(r != TND_OK && strstr(tnd_error_detail(), path), "missing file: %s", tnd_error_detail());
    /* not 2:1 */
    snprintf(path, sizeof path, "%s/square.exr", dir);
    write_exr(path, 32, 32, rgb, 3, px);
    r = tnd_env_load(path, 1, 0, &e);
    CHECK(r == TND_ERR_BAD_INPUT && strstr(tnd_error_detail(), path) &&
              strstr(tnd_error_detail(), "latitude-longitude"),
          "square: %s", tnd_error_detail());
    /* not RGB */
    snprintf(path, sizeof path, "%s/gray.exr", dir);
    write_exr(path, 64, 32, y, 1, px);
    r = tnd_env_load(path, 1, 0, &e);
    CHECK(r == TND_ERR_BAD_INPUT && strstr(tnd_error_detail(), path) &&
              strstr(tnd_error_detail(), "not an RGB image"),
          "luminance only: %s", tnd_error_detail());
    CHECK(e.width == 0 && e.data == NULL, "a failed load leaves the environment as it was");
    /* DWAB headers the C++ reader would misread (fuzzing's finds): an attribute of a fixed-size
     * type declaring another size, a string longer than the file; refused by name before it
     * reads them (it allocated 1.85 and 1.9 GB) */
    const struct {
        const char *file, *says;
    } dwab[2] = {{"oom-float-attribute-declares-1074-bytes.exr",
                  "'dwaCompressionLevel' (float) declares 1074 bytes; the type has 4"},
                 {"oom-dwab-software-string-1.9GB.exr", "more than the file holds"}};
    for (int i = 0; i < 2; i++) {
        char fz[512];
        snprintf(fz, sizeof fz, "%s/tests/fuzz/regressions/env/%s", TND_SOURCE_DIR, dwab[i].file);
        r = tnd_env_load(fz, 1, 0, &e);
        CHECK(r == TND_ERR_BAD_INPUT && strstr(tnd_error_detail(), fz) &&
                  strstr(tnd_error_detail(), dwab[i].says),
              "%s: %s", dwab[i].file, tnd_error_detail());
    }
    /* NaN, Inf and negative texels: counted, set to 0 */
    for (int i = 0; i < 64 * 32 * 3; i++)
        px[i] = 0.5f;
    px[0] = NAN, px[4] = INFINITY, px[8] = -1.0f, px[100] = -INFINITY;
    snprintf(path, sizeof path, "%s/bad.exr", dir);
    write_exr(path, 64, 32, rgb, 3, px);
    REQUIRE_OK(tnd_env_load(path, 1, 0, &e));
    CHECK(e.bad_texels == 4, "%u bad texel values counted (4 written)", e.bad_texels);
    for (size_t i = 0; i < TND_ENV_OFFSET_EDGES(64u, 32u); i++) /* (the edges: cosines, sines) */
        CHECK(isfinite(e.data[i]) && e.data[i] >= 0, "value %zu of the environment: %g", i,
              (double)e.data[i]);
    /* sun.gltf (a sky and a sun) with a tandem_env naming bad.exr, then a missing file */
    tnd_scene *s = NULL;
    for (int missing = 0; missing < 2; missing++) {
        REQUIRE(scene_with_env(dir, missing ? "nowhere.exr" : "bad.exr", gltf, sizeof gltf),
                "scene copy");
        r = tnd_scene_load(gltf, &s);
        if (!missing) {
            CHECK(r == TND_OK && s, "scene with an environment: %s", tnd_error_detail());
            if (s)
                CHECK(s->env.width == 64 && s->env.intensity == 2 && s->env.rotation == 45 &&
                          (s->features & TND_FEATURE(ENV_MAP)) &&
                          !(s->features & TND_FEATURE(SKY)) && s->sky[0] == 0,
                      "tandem_env: %ux%u, intensity %g, rotation %g, features %#x",
                      s->env.width, s->env.height, (double)s->env.intensity,
                      (double)s->env.rotation, s->features);
        } else {
            CHECK(r != TND_OK && !s && strstr(tnd_error_detail(), gltf) &&
                      strstr(tnd_error_detail(), "nowhere.exr"),
                  "scene with a missing environment: %s", tnd_error_detail());
        }
        tnd_scene_destroy(s);
        s = NULL;
    }
cleanup:
    tnd_env_free(&e);
    const char *files[] = {"square.exr", "gray.exr", "bad.exr", "scene.gltf", "sun.bin"};
    for (int i = 0; i < 5; i++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[i]);
        remove(path);
    }
    rmdir(dir);
}

/* Both front-ends find the same texel (shaders/env.h, tnd_env_refine): from a first guess one
 * texel off either way, as a GPU's less exact atan2 and acos can give near an edge, the sign
 * tests against the edge tables land on the texel exact (double) arithmetic finds, for
 * directions up to 1e-5 rad from an edge (closer ones: the last bits decide either way). */
static void test_texel_refine(void)
{
    const uint32_t w = 64, h = 32;
    static float px[64 * 32 * 3];
    for (size_t i = 0; i < sizeof px / sizeof *px; i++)
        px[i] = 1.0f;
    tnd_env e = {0};
    REQUIRE_OK(tnd_env_from_pixels("refine", px, w, h, 1, 0, &e));
    uint32_t state = 12345, checked = 0, bad = 0;
    for (int k = 0; k < 20000; k++) {
        /* a direction near a column edge and a row edge, on either side */
        state = state * 1664525u + 1013904223u;
        uint32_t j = state % (w + 1), i = 1 + (state >> 16) % (h - 1);
        state = state * 1664525u + 1013904223u;
        double dphi = ((double)(state >> 8) / 16777216.0 - 0.5) * 4e-3;
        double dth = ((double)(state & 0xff) / 256.0 - 0.5) * 4e-3;
        if (fabs(dphi) < 1e-5 || fabs(dth) < 1e-5)
            continue;
        double phi = 2 * TND_PI * ((double)j / w - 0.5) + dphi, th = TND_PI * i / h + dth;
        if (th <= 0 || th >= TND_PI)
            continue;
        float x = (float)(cos(phi) * sin(th)), y = (float)cos(th), z = (float)(sin(phi) * sin(th));
        double u = atan2((double)z, (double)x) / (2 * TND_PI) + 0.5, v = acos((double)y) / TND_PI;
        uint32_t ex = (uint32_t)floor(u * w) % w, ey = (uint32_t)floor(v * h);
        for (int gx = -1; gx <= 1; gx++)
            for (int gy = -1; gy <= 1; gy++) {
                uint32_t cx = (ex + w + (uint32_t)gx) % w, cy = ey;
                if ((int)ey + gy < 0 || (int)ey + gy >= (int)h)
                    continue;
                cy = (uint32_t)((int)ey + gy);
                tnd_env_refine(e.data, w, h, x, y, z, &cx, &cy);
                checked++;
                if ((cx != ex || cy != ey) && bad++ < 5)
                    CHECK(false, "phi %.6f theta %.6f: guess off by (%d, %d): texel (%u, %u), "
                                 "exact (%u, %u)",
                          phi, th, gx, gy, cx, cy, ex, ey);
            }
    }
    CHECK(bad == 0 && checked > 100000, "%u of %u refined guesses off the exact texel", bad,
          checked);
    /* and the lookup itself (atan2f and acosf, then refined) agrees with the exact texel */
    float rgb[3], dir[3];
    for (uint32_t t = 0; t < w * h; t++) /* each texel's colour: its index */
        px[3 * t] = (float)t;
    REQUIRE_OK(tnd_env_from_pixels("refine", px, w, h, 1, 0, &e));
    dir[0] = (float)(cos(0.3) * sin(1.0)), dir[1] = (float)cos(1.0),
    dir[2] = (float)(sin(0.3) * sin(1.0));
    tnd_env_lookup(&e, dir, rgb);
    uint32_t want = (uint32_t)floor(1.0 / TND_PI * h) * w +
                    (uint32_t)floor((0.3 / (2 * TND_PI) + 0.5) * w);
    CHECK(rgb[0] == (float)want, "lookup: texel %g, expected %u", (double)rgb[0], want);
cleanup:
    tnd_env_free(&e);
}

TND_TEST_MAIN(T(test_texel_refine), T(test_convention), T(test_density_normalised), T(test_importance_vs_uniform),
              T(test_bad_input))
