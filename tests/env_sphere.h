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

static tnd_scene *es_scene(float albedo, int light)
{
    tnd_scene *s = NULL;
    if (tnd_scene_new("env sphere", &s) != TND_OK)
        return NULL;
    enum { SEG = 64, RINGS = 32 };
    static float pos[(SEG + 1) * (RINGS + 1) * 3];
    static uint32_t idx[SEG * RINGS * 6];
    uint32_t n = 0, t = 0;
    for (int j = 0; j <= RINGS; j++)
        for (int i = 0; i <= SEG; i++, n++) {
            double th = TND_PI * j / RINGS, ph = 2 * TND_PI * i / SEG;
            pos[3 * n] = (float)(sin(th) * cos(ph));
            pos[3 * n + 1] = (float)cos(th);
            pos[3 * n + 2] = (float)(sin(th) * sin(ph));
        }
    for (int j = 0; j < RINGS; j++)
        for (int i = 0; i < SEG; i++) {
            uint32_t a = j * (SEG + 1) + i, b = (j + 1) * (SEG + 1) + i;
            if (j != 0)
                idx[t++] = a, idx[t++] = a + 1, idx[t++] = b;
            if (j != RINGS - 1)
                idx[t++] = a + 1, idx[t++] = b + 1, idx[t++] = b;
        }
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

#endif
