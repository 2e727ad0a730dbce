/* core/lights.c: the per-frame light list for next-event estimation (shaders/lights.h), shared
 * by both front-ends: world-space emissive triangles, punctual lights and the environment map,
 * with power-proportional pick probabilities and their cdf.
 * Entry points: tnd_lights_build, tnd_lights_free (tnd_lights_pick is inline in core.h). */
#include "core/core.h"
#include "shaders/brdf.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void tnd_lights_free(tnd_light_list *l)
{
    free(l->lights);
    free(l->instance_first);
    memset(l, 0, sizeof *l);
}

static void xform_point(const float *x, const float *p, double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = (double)x[4 * r] * p[0] + (double)x[4 * r + 1] * p[1] +
                 (double)x[4 * r + 2] * p[2] + x[4 * r + 3];
}

tnd_result tnd_lights_build(const tnd_scene *s, const tnd_scene_state *st, tnd_light_list *l)
{
    uint32_t cap = s->emitter_count + s->light_count + 1; /* + the environment map */
    tnd_light_gpu *nl = realloc(l->lights, (cap ? cap : 1) * sizeof *nl);
    uint32_t *nf = realloc(l->instance_first, (s->instance_count ? s->instance_count : 1) *
                                                  sizeof *nf);
    if (nl)
        l->lights = nl;
    if (nf)
        l->instance_first = nf;
    if (!nl || !nf)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "lights: out of memory");
    for (uint32_t i = 0; i < s->instance_count; i++)
        l->instance_first[i] = ~0u;
    /* scene bounding radius, for directional lights' and the environment's notional power: a
     * walk over every vertex (atrium: 13 ms a frame on lavapipe's host), so only where such a
     * light is and again only when instances move */
    if ((s->features & (TND_FEATURE(LIGHT_DIRECTIONAL) | TND_FEATURE(ENV_MAP))) &&
        (!l->radius_known || (s->features & TND_FEATURE(ANIMATED_OBJECTS)))) {
        double lo[3], hi[3];
        tnd_scene_bounds(s, st, lo, hi);
        l->radius = 0.5 * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) +
                               (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                               (hi[2] - lo[2]) * (hi[2] - lo[2]));
        l->radius_known = true;
    }
    double radius = l->radius;
    uint32_t n = 0;
    double total = 0;
    double *power = malloc((cap ? cap : 1) * sizeof *power);
    if (!power)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "lights: out of memory");
    for (uint32_t e = 0; e < s->emitter_count; e++) {
        const tnd_emitter *em = &s->emitters[e];
        const tnd_mesh *m = &s->meshes[s->instances[em->instance].mesh];
        const tnd_material *mat = &s->materials[m->material];
        const uint32_t *ix = s->indices + m->first_index + 3 * em->primitive;
        const float *x = st->instance_xform + 12 * em->instance;
        double v[3][3];
        for (int k = 0; k < 3; k++)
            xform_point(x, s->positions + 3 * (size_t)(m->first_vertex + ix[k]), v[k]);
        double e1[3], e2[3];
        for (int k = 0; k < 3; k++)
            e1[k] = v[1][k] - v[0][k], e2[k] = v[2][k] - v[0][k];
        double c[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        double area = 0.5 * sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        double lum = tnd_luminance(mat->emission[0], mat->emission[1], mat->emission[2]);
        double p = TND_PI * lum * area * (mat->double_sided ? 2.0 : 1.0);
        if (!(p > 0))
            continue;
        if (l->instance_first[em->instance] == ~0u)
            l->instance_first[em->instance] = n - em->primitive; /* first + prim = index */
        tnd_light_gpu *g = &l->lights[n];
        memset(g, 0, sizeof *g);
        g->p0 = (tnd_lvec4){(float)v[0][0], (float)v[0][1], (float)v[0][2], TND_LIGHT_KIND_TRIANGLE};
        g->p1 = (tnd_lvec4){(float)v[1][0], (float)v[1][1], (float)v[1][2],
                            mat->double_sided ? 1.0f : 0.0f};
        g->p2 = (tnd_lvec4){(float)v[2][0], (float)v[2][1], (float)v[2][2], 0};
        g->radiance = (tnd_lvec4){mat->emission[0], mat->emission[1], mat->emission[2], 0};
        g->cdf = (tnd_lvec4){0, (float)em->instance, (float)em->primitive, (float)area};
        power[n++] = p;
        total += p;
    }
    for (uint32_t i = 0; i < s->light_count; i++) {
        const tnd_light *li = &s->lights[i];
        const float *w = st->node_world + 16 * li->node;
        float sc = st->light_scale[i];
        double lum = tnd_luminance(li->color[0], li->color[1], li->color[2]) * sc;
        /* the light shines along its node's -Z */
        double d[3] = {-w[8], -w[9], -w[10]};
        double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int k = 0; k < 3; k++)
            d[k] = dl > 0 ? d[k] / dl : (k == 2 ? -1 : 0);
        double p = 0;
        tnd_light_gpu *g = &l->lights[n];
        memset(g, 0, sizeof *g);
        switch (li->type) {
        case TND_LIGHT_POINT:
            p = 4 * TND_PI * lum;
            g->p0.w = TND_LIGHT_KIND_POINT;
            break;
        case TND_LIGHT_SPOT:
            p = 2 * TND_PI * (1 - cos(li->outer_cone)) * lum;
            g->p0.w = TND_LIGHT_KIND_SPOT;
            g->p2 = (tnd_lvec4){cosf(li->inner_cone), cosf(li->outer_cone), 0, 0};
            break;
        default:
            p = TND_PI * radius * radius * lum;
            g->p0.w = TND_LIGHT_KIND_DIRECTIONAL;
            break;
        }
        if (!(p > 0))
            continue;
        g->p0.x = w[12], g->p0.y = w[13], g->p0.z = w[14];
        g->p1 = (tnd_lvec4){(float)d[0], (float)d[1], (float)d[2], 0};
        g->radiance = (tnd_lvec4){li->color[0] * sc, li->color[1] * sc, li->color[2] * sc, 0};
        power[n++] = p;
        total += p;
    }
    /* the environment map: the flux its radiance sends through the scene's cross-section,
     * pi R^2 x the integral of luminance over the sphere (4 pi x the mean) */
    uint32_t env_index = ~0u;
    if (s->env.width) {
        double p = TND_PI * radius * radius * 4 * TND_PI * s->env.mean_luminance;
        if (p > 0) {
            tnd_light_gpu *g = &l->lights[n];
            memset(g, 0, sizeof *g);
            g->p0.w = (float)TND_LIGHT_KIND_ENV;
            env_index = n;
            power[n++] = p;
            total += p;
        }
    }
    double acc = 0;
    for (uint32_t i = 0; i < n; i++) {
        acc += power[i];
        l->lights[i].radiance.w = (float)(power[i] / total);
        l->lights[i].cdf.x = i + 1 == n ? 1.0f : (float)(acc / total);
    }
    free(power);
    l->env_pick = env_index != ~0u ? l->lights[env_index].radiance.w : 0.0f;
    l->count = n;
    l->total_power = (float)total;
    return TND_OK;
}
