/* tests/env_sphere.h: a convex pure-Lambert sphere under a uniform environment, shared by
 * test_frontend_embree (femb) and test_frontend_vk (fvk): the reference mode must return
 * albedo x radiance on every pixel of the sphere (a convex object sees the whole environment
 * over its hemisphere, and nothing else: E = pi L, reflected radiance albedo L).
 *
 * The scene (es_scene): a UV sphere of radius 1 (64 x 32 segments, smooth normals) at the
 * origin with a KHR_materials_specular 0 material (no Fresnel: pure Lambert) of albedo `albedo`,
 * seen by a camera at (0, 0, 4) with yfov 0.6; lit by radiance 1 in one of two ways:
 * - ES_SKY: the uniform sky (tandem_sky), which only BRDF samples find;
 * - ES_ENV: a constant 64 x 32 environment map (1 everywhere), importance-sampled through the
 *   light list with MIS against the BRDF.
 * Pixels are chosen analytically (the camera ray hits the sphere with cos(n, v) >= 0.3, away from
 * the silhouette, where a pixel's footprint averages over the edge); the mean of their green
 * channel must be the albedo within 0.5% (the bound). The smooth normals lose the few
 * cosine samples that fall between the interpolated normal's horizon and the flat triangle's
 * (test_furnace_lambert measures 0.2% at albedo 1 over the whole sphere), so the bound holds
 * that and the noise: 5 standard errors of the mean over those pixels are required to fit too. */
#ifndef TESTS_ENV_SPHERE_H
#define TESTS_ENV_SPHERE_H

#include "core/core.h"
#include "tests/tnd_test.h"

#include <math.h>
#include <stdlib.h>

enum { ES_SKY = 0, ES_ENV = 1 };
enum { ES_W = 40, ES_H = 40 };

/* A UV sphere of radius 1 at the origin, ES_SEG x ES_RINGS segments, its positions (which are
 * also its normals) and indices; the vertex and triangle-index counts. (Also the white furnace's
 * sphere, test_frontend_embree.c.) */
enum { ES_SEG = 64, ES_RINGS = 32 };
static void es_uv_sphere(float pos[(ES_SEG + 1) * (ES_RINGS + 1) * 3],
                         uint32_t idx[ES_SEG * ES_RINGS * 6], uint32_t *nv, uint32_t *ni)
{
    uint32_t n = 0, t = 0;
    for (int j = 0; j <= ES_RINGS; j++)
        for (int i = 0; i <= ES_SEG; i++, n++) {
            double th = TND_PI * j / ES_RINGS, ph = 2 * TND_PI * i / ES_SEG;
            pos[3 * n] = (float)(sin(th) * cos(ph));
            pos[3 * n + 1] = (float)cos(th);
            pos[3 * n + 2] = (float)(sin(th) * sin(ph));
        }
    for (int j = 0; j < ES_RINGS; j++)
        for (int i = 0; i < ES_SEG; i++) {
            uint32_t a = j * (ES_SEG + 1) + i, b = (j + 1) * (ES_SEG + 1) + i;
            if (j != 0)
                idx[t++] = a, idx[t++] = a + 1, idx[t++] = b;
            if (j != ES_RINGS - 1)
                idx[t++] = a + 1, idx[t++] = b + 1, idx[t++] = b;
        }
    *nv = n, *ni = t;
}

static tnd_scene *es_scene(float albedo, int light)
{
    tnd_scene *s = NULL;
    if (tnd_scene_new("env sphere", &s) != TND_OK)
        return NULL;
    static float pos[(ES_SEG + 1) * (ES_RINGS + 1) * 3];
    static uint32_t idx[ES_SEG * ES_RINGS * 6];
    uint32_t n, t;
    es_uv_sphere(pos, idx, &n, &t);
    tnd_material m = tnd_material_default("lambert");
    m.metallic = 0, m.roughness = 1, m.specular = 0;
    m.base_color[0] = m.base_color[1] = m.base_color[2] = albedo;
    int32_t mi = tnd_scene_add_material(s, &m);
    int32_t me = tnd_scene_add_mesh(s, "sphere", pos, pos, NULL, n, idx, t / 3, (uint32_t)mi);
    int32_t node = tnd_scene_add_node(s, "sphere", -1, NULL, NULL, NULL);
    const float cam_t[3] = {0, 0, 4};
    int32_t cn = tnd_scene_add_node(s, "camera", -1, cam_t, NULL, NULL);
    tnd_scene_add_instance(s, (uint32_t)me, (uint32_t)node);
    tnd_scene_add_camera(s, (uint32_t)cn, 0.6f);
    if (light == ES_SKY) {
        s->sky[0] = s->sky[1] = s->sky[2] = 1.0f;
    } else {
        static float ones[64 * 32 * 3];
        for (int i = 0; i < 64 * 32 * 3; i++)
            ones[i] = 1.0f;
        if (tnd_env_from_pixels("constant", ones, 64, 32, 1.0f, 0.0f, &s->env) != TND_OK) {
            tnd_scene_destroy(s);
            return NULL;
        }
    }
    if (tnd_scene_commit(s) != TND_OK) {
        tnd_scene_destroy(s);
        return NULL;
    }
    return s;
}

/* Mean and standard error of the green channel of `rgb` (ES_W x ES_H, from the scene's camera)
 * over the sphere's pixels with cos(n, v) >= 0.3 (found by intersecting each pixel's centre
 * ray with the exact sphere). */
static int es_measure(const float *rgb, double *mean, double *se)
{
    double sum = 0, sum2 = 0;
    int n = 0;
    double th = tan(0.3);
    for (int y = 0; y < ES_H; y++)
        for (int x = 0; x < ES_W; x++) {
            double d[3] = {(2 * (x + 0.5) / ES_W - 1) * th, (1 - 2 * (y + 0.5) / ES_H) * th, -1};
            double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            for (int k = 0; k < 3; k++)
                d[k] /= l;
            /* |o + t d| = 1 with o = (0, 0, 4): t^2 + 2 (o.d) t + 15 = 0 */
            double b = 4 * d[2], disc = b * b - 15;
            if (disc <= 0)
                continue;
            double t = -b - sqrt(disc);
            double p[3] = {t * d[0], t * d[1], 4 + t * d[2]};
            double mu = -(p[0] * d[0] + p[1] * d[1] + p[2] * d[2]);
            if (mu < 0.3)
                continue;
            double v = rgb[3 * (y * ES_W + x) + 1];
            sum += v, sum2 += v * v, n++;
        }
    *mean = n ? sum / n : 0;
    *se = n > 1 ? sqrt(fmax(0, (sum2 - sum * sum / n) / (n - 1)) / n) : 0;
    return n;
}

/* Check one rendering: the sphere's mean within 0.5% of the albedo (and 5 standard errors). */
static void es_check(const char *who, int light, float albedo, const float *rgb)
{
    double mean, se;
    int n = es_measure(rgb, &mean, &se);
    double rel = mean / albedo - 1;
    printf("     %s, %s, albedo %.1f: sphere mean %.5f (%+.3f%%, se %.3f%%, %d pixels)\n", who,
           light == ES_SKY ? "uniform sky" : "constant environment map", (double)albedo, mean,
           100 * rel, 100 * se / albedo, n);
    CHECK(n > 500, "%s: %d sphere pixels", who, n);
    CHECK(fabs(rel) <= 0.005, "%s: the sphere returns %.5f, not %.2f within 0.5%%", who, mean,
          (double)albedo);
    CHECK(fabs(mean - albedo) <= 5 * se + 2e-3 * albedo, "%s: %.5f vs %.2f beyond 5 se (%.2g)",
          who, mean, (double)albedo, se);
}

/* A front-end's reference of scene s in state st: ES_W x ES_H, 64 samples per pixel, into rgb. */
typedef tnd_result (*es_render_fn)(tnd_scene *s, const tnd_scene_state *st, float *rgb,
                                   void *user);

/* The four cases (the uniform sky and the constant map, albedo 0.5 and 1) rendered by `render`
 * and checked. */
static void es_run(const char *who, es_render_fn render, void *user)
{
    float *rgb = malloc(ES_W * ES_H * 3 * sizeof(float));
    for (int light = ES_SKY; light <= ES_ENV && rgb; light++)
        for (int a = 0; a < 2; a++) {
            float albedo = a ? 1.0f : 0.5f;
            tnd_scene *s = es_scene(albedo, light);
            CHECK(s, "sphere scene: %s", tnd_error_detail());
            if (!s)
                continue;
            CHECK(light == ES_SKY ? (s->features & TND_FEATURE(SKY)) != 0
                                  : (s->features & TND_FEATURE(ENV_MAP)) != 0,
                  "features %#x", s->features);
            tnd_scene_state st = {0};
            tnd_result r = tnd_scene_evaluate(s, 0, 0, 1.0f, &st);
            if (r == TND_OK)
                r = render(s, &st, rgb, user);
            CHECK(r == TND_OK, "%s: %s", who, tnd_error_detail());
            if (r == TND_OK)
                es_check(who, light, albedo, rgb);
            tnd_scene_state_free(&st);
            tnd_scene_destroy(s);
        }
    CHECK(rgb, "out of memory");
    free(rgb);
}

#endif
