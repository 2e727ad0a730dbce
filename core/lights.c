/* core/lights.c: the per-frame light list for next-event estimation (shaders/lights.h), shared
 * by both front-ends: world-space emissive triangles, punctual lights and the environment map,
 * with power-proportional pick probabilities and their cdf; and the light tree over them
 * (shaders/light_tree.h) where the front-end asks for it.
 * Entry points: tnd_lights_build, tnd_lights_free, tnd_light_sampling_name / _parse / _for
 * (tnd_lights_pick is inline in core.h). */
#include "core/core.h"
#include "shaders/brdf.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void tnd_lights_free(tnd_light_list *l)
{
    free(l->lights);
    free(l->instance_first);
    free(l->nodes);
    memset(l, 0, sizeof *l);
}

static const char *const sampling_names[] = {"auto", "plain", "tree", "restir"};
enum { SAMPLING_NAMES = sizeof sampling_names / sizeof sampling_names[0] };

const char *tnd_light_sampling_name(tnd_light_sampling m)
{
    return (unsigned)m < SAMPLING_NAMES ? sampling_names[m] : "?";
}

bool tnd_light_sampling_parse(const char *name, tnd_light_sampling *m)
{
    for (int i = 0; i < SAMPLING_NAMES; i++)
        if (strcmp(name, sampling_names[i]) == 0) {
            *m = (tnd_light_sampling)i;
            return true;
        }
    return false;
}

tnd_light_sampling tnd_light_sampling_for(const tnd_scene *s, tnd_light_sampling m)
{
    if (m != TND_LIGHTS_AUTO)
        return m;
    uint32_t local = s->emitter_count;
    for (uint32_t i = 0; i < s->light_count; i++)
        local += s->lights[i].type == TND_LIGHT_POINT || s->lights[i].type == TND_LIGHT_SPOT;
    return local >= TND_LIGHTS_RESTIR_FROM ? TND_LIGHTS_RESTIR
           : local >= TND_LIGHTS_TREE_FROM ? TND_LIGHTS_TREE
                                           : TND_LIGHTS_PLAIN;
}

/* ---- the light tree (shaders/light_tree.h) ---------------------------------------------------- */
typedef struct lt_item {
    uint32_t light;    /* index in the list */
    double lo[3], hi[3], power;
    double axis[3], cos_o, cos_e;
    bool two_sided;
    double centre[3];
} lt_item;

static double clampd(double x, double lo, double hi)
{
    return x < lo ? lo : x > hi ? hi : x;
}

/* A light's bounds: its box, power and normal cone (axis, theta_o) with the spread theta_e. */
static void lt_light(const tnd_light_gpu *g, uint32_t index, double total, lt_item *it)
{
    memset(it, 0, sizeof *it);
    it->light = index;
    it->power = (double)g->radiance.w * total;
    const float *pts[3] = {&g->p0.x, &g->p1.x, &g->p2.x};
    uint32_t kind = (uint32_t)g->p0.w;
    int np = kind == TND_LIGHT_KIND_TRIANGLE ? 3 : 1;
    for (int k = 0; k < 3; k++) {
        it->lo[k] = it->hi[k] = pts[0][k];
        for (int j = 1; j < np; j++) {
            it->lo[k] = fmin(it->lo[k], pts[j][k]);
            it->hi[k] = fmax(it->hi[k], pts[j][k]);
        }
        it->centre[k] = 0.5 * (it->lo[k] + it->hi[k]);
    }
    it->cos_e = 0.0; /* Lambertian emission: pi/2 about the normal */
    if (kind == TND_LIGHT_KIND_TRIANGLE) {
        double e1[3], e2[3];
        for (int k = 0; k < 3; k++)
            e1[k] = (double)pts[1][k] - pts[0][k], e2[k] = (double)pts[2][k] - pts[0][k];
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int k = 0; k < 3; k++)
            it->axis[k] = l > 0 ? n[k] / l : (k == 2);
        it->cos_o = l > 0 ? 1.0 : -1.0;
        it->two_sided = g->p1.w != 0.0f;
    } else if (kind == TND_LIGHT_KIND_SPOT) {
        for (int k = 0; k < 3; k++)
            it->axis[k] = (&g->p1.x)[k];
        it->cos_o = 1.0;
        it->cos_e = g->p2.y; /* the outer cone */
    } else { /* a point light: every direction */
        it->axis[2] = 1.0;
        it->cos_o = -1.0;
    }
}

/* a := the union of a and b (box, power, cones) */
static void lt_union(lt_item *a, const lt_item *b)
{
    for (int k = 0; k < 3; k++) {
        a->lo[k] = fmin(a->lo[k], b->lo[k]);
        a->hi[k] = fmax(a->hi[k], b->hi[k]);
    }
    a->power += b->power;
    a->cos_e = fmin(a->cos_e, b->cos_e);
    a->two_sided |= b->two_sided;
    if (a->cos_o <= -1.0)
        return;
    if (b->cos_o <= -1.0) {
        a->cos_o = -1.0;
        return;
    }
    /* the smallest cone holding both (each cone: the directions within theta of its axis) */
    double ta = acos(clampd(a->cos_o, -1, 1)), tb = acos(clampd(b->cos_o, -1, 1));
    double dot = a->axis[0] * b->axis[0] + a->axis[1] * b->axis[1] + a->axis[2] * b->axis[2];
    double td = acos(clampd(dot, -1, 1));
    if (fmin(td + tb, TND_PI) <= ta)
        return; /* a holds b */
    if (fmin(td + ta, TND_PI) <= tb) {
        memcpy(a->axis, b->axis, sizeof a->axis);
        a->cos_o = b->cos_o;
        return;
    }
    double to = 0.5 * (ta + td + tb);
    double k[3] = {a->axis[1] * b->axis[2] - a->axis[2] * b->axis[1],
                   a->axis[2] * b->axis[0] - a->axis[0] * b->axis[2],
                   a->axis[0] * b->axis[1] - a->axis[1] * b->axis[0]};
    double kl = sqrt(k[0] * k[0] + k[1] * k[1] + k[2] * k[2]);
    if (to >= TND_PI || !(kl > 1e-12)) {
        a->cos_o = -1.0;
        return;
    }
    /* the axis turned from a's towards b's by to - ta, about k (Rodrigues; k is normal to a) */
    double r = to - ta, c = cos(r), sn = sin(r), ka[3];
    for (int j = 0; j < 3; j++)
        k[j] /= kl;
    ka[0] = k[1] * a->axis[2] - k[2] * a->axis[1];
    ka[1] = k[2] * a->axis[0] - k[0] * a->axis[2];
    ka[2] = k[0] * a->axis[1] - k[1] * a->axis[0];
    double al = 0;
    for (int j = 0; j < 3; j++) {
        a->axis[j] = a->axis[j] * c + ka[j] * sn;
        al += a->axis[j] * a->axis[j];
    }
    al = sqrt(al);
    for (int j = 0; j < 3; j++)
        a->axis[j] /= al;
    /* (a little wider than exact: the float cosine must not cut an emitter off) */
    a->cos_o = fmax(-1.0, cos(to) - 1e-6);
}

static int lt_axis; /* (qsort's comparison: the axis being split) */
static int lt_cmp(const void *x, const void *y)
{
    double a = ((const lt_item *)x)->centre[lt_axis], b = ((const lt_item *)y)->centre[lt_axis];
    return a < b ? -1 : a > b;
}

typedef struct lt_builder {
    tnd_light_list *l;
    bool power_only; /* the infinite lights' subtree */
    bool failed;
} lt_builder;

static void lt_store(tnd_light_node *n, const lt_item *b, uint32_t flags)
{
    double c[3], r2 = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * (b->lo[k] + b->hi[k]);
        r2 += (b->hi[k] - c[k]) * (b->hi[k] - c[k]);
    }
    /* (the float radius rounded up: the box's angle from p must not come out smaller) */
    float r = (float)sqrt(r2);
    r = nextafterf(r, INFINITY);
    double cos_o = clampd(b->cos_o, -1, 1);
    n->centre = (tnd_ltvec4){(float)c[0], (float)c[1], (float)c[2], (float)b->power};
    n->axis = (tnd_ltvec4){(float)b->axis[0], (float)b->axis[1], (float)b->axis[2],
                           (float)cos_o};
    n->cone = (tnd_ltvec4){(float)sqrt(1.0 - cos_o * cos_o), (float)b->cos_e, r * r, r};
    n->link.z = flags | (b->two_sided ? TND_LT_TWO_SIDED : 0u);
}

/* The subtree over items [0, n): its node's index; the lights' paths (bits, depth) below it. */
static uint32_t lt_build(lt_builder *B, lt_item *items, uint32_t n, uint32_t bits,
                         uint32_t depth, uint32_t flags)
{
    tnd_light_list *l = B->l;
    uint32_t at = l->node_count++;
    tnd_light_node *nodes = l->nodes;
    if (depth > TND_LT_MAX_DEPTH || (n > 1 && depth >= TND_LT_MAX_DEPTH)) {
        B->failed = true; /* (an inner node's children need a bit of the 32) */
        return at;
    }
    if (B->power_only)
        flags |= TND_LT_POWER_ONLY;
    if (n == 1) {
        lt_store(&nodes[at], &items[0], flags | TND_LT_LEAF);
        nodes[at].link.x = items[0].light;
        nodes[at].link.y = 0;
        memcpy(&l->lights[items[0].light].p2.w, &bits, sizeof bits);
        return at;
    }
    lt_item all = items[0];
    double clo[3], chi[3];
    for (int k = 0; k < 3; k++)
        clo[k] = chi[k] = items[0].centre[k];
    for (uint32_t i = 1; i < n; i++) {
        lt_union(&all, &items[i]);
        for (int k = 0; k < 3; k++) {
            clo[k] = fmin(clo[k], items[i].centre[k]);
            chi[k] = fmax(chi[k], items[i].centre[k]);
        }
    }
    lt_store(&nodes[at], &all, flags);
    /* split at the median of the centres along their widest axis: a balanced tree, so a
     * light's path fits TND_LT_MAX_DEPTH bits */
    lt_axis = 0;
    for (int k = 1; k < 3; k++)
        if (chi[k] - clo[k] > chi[lt_axis] - clo[lt_axis])
            lt_axis = k;
    qsort(items, n, sizeof *items, lt_cmp);
    uint32_t half = n / 2;
    uint32_t a = lt_build(B, items, half, bits, depth + 1, 0);
    uint32_t b = lt_build(B, items + half, n - half, bits | (1u << depth), depth + 1, 0);
    l->nodes[at].link.x = a;
    l->nodes[at].link.y = b;
    return at;
}

static tnd_result lt_build_tree(tnd_light_list *l)
{
    l->node_count = 0;
    if (!l->count)
        return TND_OK;
    uint32_t need = 2 * l->count + 1;
    if (need > l->node_capacity) {
        tnd_light_node *nn = realloc(l->nodes, need * sizeof *nn);
        if (!nn)
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "lights: out of memory for the light tree");
        l->nodes = nn;
        l->node_capacity = need;
    }
    memset(l->nodes, 0, need * sizeof *l->nodes);
    lt_item *items = malloc(l->count * sizeof *items);
    if (!items)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "lights: out of memory for the light tree");
    uint32_t nl = 0, ni = l->count; /* local lights first, the infinite ones from the end */
    for (uint32_t i = 0; i < l->count; i++) {
        uint32_t kind = (uint32_t)l->lights[i].p0.w;
        bool infinite = kind == TND_LIGHT_KIND_DIRECTIONAL || kind == TND_LIGHT_KIND_ENV;
        lt_light(&l->lights[i], i, l->total_power, &items[infinite ? --ni : nl++]);
    }
    uint32_t n_inf = l->count - ni;
    lt_builder B = {.l = l};
    if (nl && n_inf) { /* the root: the two groups by power */
        l->node_count = 1;
        uint32_t a = lt_build(&B, items, nl, 0u, 1, TND_LT_POWER_ONLY);
        B.power_only = true;
        uint32_t b = lt_build(&B, items + nl, n_inf, 1u, 1, 0);
        double p = 0;
        for (uint32_t i = 0; i < l->count; i++)
            p += items[i].power;
        l->nodes[0].centre.w = (float)p;
        l->nodes[0].link = (tnd_ltuvec4){a, b, TND_LT_POWER_ONLY, 0};
    } else {
        B.power_only = nl == 0;
        lt_build(&B, items, nl ? nl : n_inf, 0u, 0, 0);
    }
    free(items);
    if (B.failed)
        return tnd_fail(TND_ERR_LIMIT, "lights: the light tree is deeper than %u levels",
                        TND_LT_MAX_DEPTH);
    return TND_OK;
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
    l->node_count = 0;
    return l->want_tree ? lt_build_tree(l) : TND_OK;
}
