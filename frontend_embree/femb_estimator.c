/* frontend_embree/femb_estimator.c: the estimator of the Embree front-end, run on batches of up
 * to FEMB_LANES paths in structure-of-arrays form.
 *
 * The estimator follows the Q2RTX reference (section 1.4) in a clean form:
 * - direct light: one-sample next-event estimation over the light list (area, point, spot,
 *   directional; shaders/lights.h), one shadow ray, GGX specular (height-correlated Smith,
 *   Schlick) and Lambert diffuse, MIS (power heuristic) with BRDF sampling for area lights;
 * - indirect: a Fresnel-weighted choice of the specular lobe (GGX VNDF sampling, Heitz 2018) or
 *   the diffuse lobe (cosine hemisphere), one bounce by default with NEE at the hit, more with
 *   Russian roulette;
 * - outputs: hf (direct diffuse, demodulated), lf (indirect diffuse as L1 SH of luma plus Co/Cg,
 *   scaled so that evaluating the SH at the shading normal returns the sample exactly:
 *   s = 4 pi Y / (1 + 2 d.n)), spec (specular / max(0.01, F0)).
 * Every random number comes from shaders/sampling.h keyed by the pixel's (frame, pixel) key.
 *
 * Why batches: between two ray casts a path does a few hundred scalar operations, and on small
 * scenes that costs several times the rays. Each step here is a loop over the batch's lanes
 * (LANES) that the compiler turns into SIMD code: the random numbers, the light and lobe samples,
 * the BRDF formulas of shaders/brdf.h. Ray casts, surface reconstruction (indexed loads,
 * textures), the light pick and the rare specular vertices run lane by lane. A lane's arithmetic
 * never depends on the other lanes, and C in ISO mode does not contract to FMA, so a pixel shaded
 * alone (a gradient sample) gets exactly the bits it gets in a full batch.
 * Entry points: femb_trace_paths, femb_shade_pixels, femb_specular_direction,
 * femb_specular_vertex. */
#include "frontend_embree/femb_internal.h"
#include "shaders/brdf.h"
#include "shaders/sampling.h"
#include "shaders/specular.h"

#include <float.h>
#include <math.h>
#include <string.h>

enum { NL = FEMB_LANES };

#define LANES   FEMB_LANES_LOOP
#define LD3     FEMB_LD3
#define ST3     FEMB_ST3
#define LANE_FN FEMB_LANE_FN

#define SH_C0 0.282094791773878f /* Y00 */
#define SH_C1 0.488602511902920f /* Y1m / direction component */

static inline __attribute__((always_inline)) float rnd(const femb_paths *P, uint32_t i, uint32_t bounce, uint32_t which)
{
    return tnd_rand(P->key_pixel[i], P->key_frame[i], P->key_sample, tnd_dim(bounce, which));
}

typedef femb_surfaces fb_surf;

/* Orthonormal basis around n (Duff et al. 2017). The sign test treats -0 as +0, as the GLSL
 * mirror must (copysign would split them, and the two front-ends would sample different
 * directions for normals with z = -0). */
static inline void onb(v3 n, v3 *t, v3 *b)
{
    float sign = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = (v3){1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x};
    *b = (v3){bb, sign + n.y * n.y * a, -n.y};
}

static inline v3 to_world(v3 l, v3 t, v3 b, v3 n)
{
    return add(add(mul(t, l.x), mul(b, l.y)), mul(n, l.z));
}

/* sin and cos of 2 pi u for u in [0, 1], in a form that vectorises (libm's are calls): the
 * nearest quarter turn q, then Taylor polynomials on a = 2 pi u - q pi/2 in [-pi/4, pi/4]
 * (truncation errors below 2e-9 for sin and 3e-8 for cos, under float rounding). */
static inline void sincos_turns(float u, float *s, float *c)
{
    float x = 4.0f * u;
    int q = (int)(x + 0.5f); /* x >= 0: truncation is floor */
    float a = (x - (float)q) * (float)(0.5 * TND_PI), a2 = a * a;
    float sa =
        a *
        (1.0f + a2 * (-1.0f / 6 + a2 * (1.0f / 120 + a2 * (-1.0f / 5040 + a2 * (1.0f / 362880)))));
    float ca = 1.0f + a2 * (-0.5f + a2 * (1.0f / 24 + a2 * (-1.0f / 720 + a2 * (1.0f / 40320))));
    /* quarter turns: odd ones swap sin and cos; sin is negative in the 3rd and 4th, cos in
     * the 2nd and 3rd */
    float s0 = q & 1 ? ca : sa, c0 = q & 1 ? sa : ca;
    *s = q & 2 ? -s0 : s0;
    *c = (q + 1) & 2 ? -c0 : c0;
}

/* ---- materials ------------------------------------------------------------------------------ */
typedef struct fb_lobes {
    FEMB_ALIGN float f_nv[3][NL]; /* Fresnel at n.v */
    float alpha[NL], a2[NL], nv[NL];
    float p_spec[NL]; /* probability of the specular lobe */
} fb_lobes;

LANE_FN static void lobes(const fb_surf *S, uint32_t n, fb_lobes *L)
{
    LANES (i, n) {
        float nv = fmx(dot(LD3(S->ns, i), LD3(S->wo, i)), 1e-4f);
        float alpha = fmx(S->roughness[i] * S->roughness[i], (float)TND_MIN_ALPHA);
        float fnv[3], kd[3];
        for (int k = 0; k < 3; k++) {
            fnv[k] = tnd_fresnel(S->metallic[i], S->specular[i], S->base[k][i], nv);
            kd[k] = S->base[k][i] * (1.0f - S->metallic[i]) * (1.0f - fnv[k]);
            L->f_nv[k][i] = fnv[k];
        }
        L->nv[i] = nv;
        L->alpha[i] = alpha;
        L->a2[i] = alpha * alpha;
        L->p_spec[i] = tnd_spec_probability(tnd_luminance(fnv[0], fnv[1], fnv[2]),
                                            tnd_luminance(kd[0], kd[1], kd[2]));
    }
}

/* BRDF x cos of lane i for direction wi: diffuse part without albedo and (1 - metallic)
 * ("demodulated"), specular part with its Fresnel, the mixture pdf of the two lobes. False when
 * wi is below either normal (the values are then meaningless). Always inline: called out of line
 * (gcc's choice once direct_light grew) it kept the general NEE copy's lane loop scalar, and
 * `materials` lost 6 points of front-end/raw. */
static inline __attribute__((always_inline)) bool
brdf_lane(const fb_surf *S, const fb_lobes *L, uint32_t i, v3 wi, float diff[3], float spec[3],
          float *pdf)
{
    v3 ns = LD3(S->ns, i), wo = LD3(S->wo, i);
    float nl = dot(ns, wi);
    v3 h = norm(add(wi, wo));
    float nh = fmx(dot(ns, h), 0.0f), vh = fmx(dot(wo, h), 0.0f);
    float g = tnd_ggx_spec_cos(nh, L->nv[i], nl, L->a2[i]);
    for (int k = 0; k < 3; k++) {
        diff[k] = (1.0f - L->f_nv[k][i]) * nl * (float)TND_INV_PI;
        spec[k] = tnd_fresnel(S->metallic[i], S->specular[i], S->base[k][i], vh) * g;
    }
    *pdf = L->p_spec[i] * tnd_ggx_vndf_pdf(nh, L->nv[i], L->a2[i]) +
           (1.0f - L->p_spec[i]) * nl * (float)TND_INV_PI;
    return (nl > 0.0f) & (dot(LD3(S->ng, i), wi) > 0.0f);
}

/* Light pick probability times the solid-angle pdf of reaching emitter triangle (instance,
 * primitive) from a point at distance d along wi; 0 when it is not in the list. d is measured
 * from the surface point the ray left, not from its offset origin (which may be 16 u (1 + m)
 * nearer: at 1e4 from the origin, 1 cm, and MIS weights that no longer sum to one). */
static float emitter_pdf(const femb_context *c, uint32_t instance, uint32_t primitive, float d,
                         v3 wi, v3 ng_light, v3 from)
{
    if (!c->lights.count || c->lights.instance_first[instance] == ~0u)
        return 0.0f;
    const tnd_light_gpu *l = &c->lights.lights[c->lights.instance_first[instance] + primitive];
    float cosl = fabsf(dot(ng_light, wi));
    float pick = l->radiance.w;
    if (c->lights.node_count) { /* the tree's probability of it, from the point the ray left */
        uint32_t trail;
        memcpy(&trail, &l->p2.w, sizeof trail);
        pick = tnd_lt_pmf(c->lights.nodes, trail, from.x, from.y, from.z);
    }
    return cosl > 0 ? pick * d * d / (l->cdf.w * cosl) : 0.0f;
}

/* The weight of emission found by a path whose previous vertex left `from` with a BRDF sample of
 * density pdf_prev: MIS against the light list's pick, 0 where a reservoir took the list's whole
 * share at that vertex (FEMB_PDF_RESERVOIR) and the emitter is in the list, 1 after a delta lobe
 * or the camera (pdf_prev 0). */
static inline float emission_weight(const femb_context *c, float pdf_prev, uint32_t instance,
                                    uint32_t primitive, v3 p, v3 from, v3 dir, v3 ng)
{
    if (pdf_prev == FEMB_PDF_RESERVOIR)
        return c->lights.count && c->lights.instance_first[instance] != ~0u ? 0.0f : 1.0f;
    if (!(pdf_prev > 0))
        return 1.0f;
    v3 dd = sub(p, from);
    return tnd_mis_power(pdf_prev,
                         emitter_pdf(c, instance, primitive, sqrtf(dot(dd, dd)), dir, ng, from));
}

/* Radiance a path finds where its ray in direction dir leaves the scene: the uniform sky, or the
 * environment map MIS-weighted against its own sampling when the ray is a BRDF sample (pdf_prev
 * > 0; a camera ray or a delta lobe's gets it whole). */
static inline void miss_radiance(const femb_context *c, v3 dir, float pdf_prev, float out[3])
{
    const tnd_scene *s = c->scene;
    if (!s->env.width) {
        out[0] = s->sky[0], out[1] = s->sky[1], out[2] = s->sky[2];
        return;
    }
    float d[3] = {dir.x, dir.y, dir.z};
    float pdf = tnd_env_lookup(&s->env, d, out);
    float w = pdf_prev > 0 ? tnd_mis_power(pdf_prev, c->lights.env_pick * pdf) : 1.0f;
    w = pdf_prev == FEMB_PDF_RESERVOIR && c->lights.env_pick > 0 ? 0.0f : w;
    for (int k = 0; k < 3; k++)
        out[k] *= w;
}

void femb_miss_radiance(const femb_context *c, v3 dir, float out[3])
{
    miss_radiance(c, dir, 0.0f, out);
}

/* (lanes below n of upick and the records are written before use; gcc 12 cannot always see it
 * through the lane loops) */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

/* One NEE sample per active lane with the dimensions of path vertex `bounce`, the shadow ray
 * from `org` (the surface point offset along the geometric normal: femb_offset_ray): diffuse
 * (demodulated) and specular contributions, 0 where inactive (direct_light; `triangles_only`:
 * every light is an emissive triangle). MIS-weighted against the BRDF sample that continues the
 * path where mis[i] (NULL: every lane); where the path ends at this vertex no BRDF sample can
 * find the emitter, so NEE takes its whole share (weight 1): the estimator's expectation is
 * then the capped path tracer's whatever the light pick (plain, tree). */
static inline __attribute__((always_inline)) void
direct_light_kinds(const femb_context *c, const femb_paths *P, uint32_t bounce, const fb_surf *S,
                   const fb_lobes *L, const float org[3][NL], const uint8_t *active,
                   const uint8_t *mis_on, uint32_t n, float diff[3][NL], float spec[3][NL],
                   bool triangles_only)
{
    /* the picked lights' records */
    float lp0[3][NL], lp1[3][NL], lp2[3][NL], lrad[4][NL], lcdf[NL], ltwo[NL];
    uint32_t kind[NL], pick[NL];
    float upick[NL];
    LANES (i, n)
        upick[i] = rnd(P, i, bounce, TND_DIM_LIGHT_PICK);
    float tree_pmf[NL];
    if (c->lights.node_count) { /* the light tree, by importance for each lane's point */
        for (uint32_t i = 0; i < n; i++) {
            pick[i] = tnd_lt_sample(c->lights.nodes, S->p[0][i], S->p[1][i], S->p[2][i],
                                    upick[i], &tree_pmf[i]);
            if (pick[i] == TND_LT_NONE) /* no light reaches the point */
                pick[i] = 0, tree_pmf[i] = 0.0f;
        }
    } else {
        tnd_lights_pick_n(&c->lights, n, upick, pick);
    }
    if (c->select_lights) {
        /* few lights: each one's record selected into the lanes that picked it, in lane loops
         * (cheaper than a copy lane by lane up to about 8 lights) */
        for (uint32_t j = 0; j < c->lights.count; j++) {
            const tnd_light_gpu *l = &c->lights.lights[j];
            float rec[15] = {l->p0.x,       l->p0.y,       l->p0.z,       l->p1.x,
                             l->p1.y,       l->p1.z,       l->p2.x,       l->p2.y,
                             l->p2.z,       l->radiance.x, l->radiance.y, l->radiance.z,
                             l->radiance.w, l->cdf.w,      l->p1.w};
            uint32_t lk = (uint32_t)l->p0.w;
            LANES (i, n) {
                bool mine = (pick[i] == j) | (j == 0); /* (light 0 first fills every lane) */
                for (int k = 0; k < 3; k++) {
                    lp0[k][i] = mine ? rec[k] : lp0[k][i];
                    lp1[k][i] = mine ? rec[3 + k] : lp1[k][i];
                    lp2[k][i] = mine ? rec[6 + k] : lp2[k][i];
                }
                for (int k = 0; k < 4; k++)
                    lrad[k][i] = mine ? rec[9 + k] : lrad[k][i];
                lcdf[i] = mine ? rec[13] : lcdf[i];
                ltwo[i] = mine ? rec[14] : ltwo[i];
                kind[i] = mine ? lk : kind[i];
            }
        }
    } else {
        for (uint32_t i = 0; i < n; i++) {
            const tnd_light_gpu *l = &c->lights.lights[pick[i]];
            kind[i] = (uint32_t)l->p0.w;
            ST3(lp0, i, ((v3){l->p0.x, l->p0.y, l->p0.z}));
            ST3(lp1, i, ((v3){l->p1.x, l->p1.y, l->p1.z}));
            ST3(lp2, i, ((v3){l->p2.x, l->p2.y, l->p2.z}));
            lrad[0][i] = l->radiance.x, lrad[1][i] = l->radiance.y, lrad[2][i] = l->radiance.z;
            lrad[3][i] = c->lights.node_count ? tree_pmf[i] : l->radiance.w;
            lcdf[i] = l->cdf.w;
            ltwo[i] = l->p1.w;
        }
    }
    float wi[3][NL], tmax[NL], dc[3][NL], sc[3][NL], lu[NL], lv[NL];
    uint8_t ok[NL], cast[NL];
    LANES (i, n) {
        lu[i] = rnd(P, i, bounce, TND_DIM_LIGHT_U);
        lv[i] = rnd(P, i, bounce, TND_DIM_LIGHT_V);
    }
    /* the environment map's samples, lane by lane (two searches in its distribution) for the
     * lanes that picked it: direction, radiance, solid-angle density (0: no sample) */
    float ed[3][NL], erad[3][NL], epdf[NL];
    if (!triangles_only && c->lights.env_pick > 0)
        for (uint32_t i = 0; i < n; i++) {
            float d[3] = {0, 1, 0}, rgb[3] = {0, 0, 0};
            epdf[i] = kind[i] == TND_LIGHT_KIND_ENV
                          ? tnd_env_sample(&c->scene->env, lu[i], lv[i], d, rgb)
                          : 0.0f;
            for (int k = 0; k < 3; k++)
                ed[k][i] = d[k], erad[k][i] = rgb[k];
        }
    LANES (i, n) {
        float u1 = lu[i], u2 = lv[i];
        v3 p = LD3(S->p, i), pos = LD3(lp0, i), v1 = LD3(lp1, i), v2 = LD3(lp2, i);
        bool tri = triangles_only | (kind[i] == TND_LIGHT_KIND_TRIANGLE);
        bool dirl = !triangles_only & (kind[i] == TND_LIGHT_KIND_DIRECTIONAL);
        bool spot = !triangles_only & (kind[i] == TND_LIGHT_KIND_SPOT);
        bool envl = !triangles_only & (kind[i] == TND_LIGHT_KIND_ENV);
        bool far = dirl | envl; /* no end point: the shadow ray goes to infinity */
        /* area: a uniform point on the triangle, the pdf turned to solid angle; a two-sided
         * emitter from either side */
        float su = sqrtf(u1);
        v3 q = add(add(mul(pos, 1.0f - su), mul(v1, su * (1.0f - u2))), mul(v2, su * u2));
        v3 nlt = norm(cross(sub(v1, pos), sub(v2, pos)));
        v3 d = sub(sel3(tri, q, pos), p);
        float d2 = dot(d, d), dist = sqrtf(d2);
        v3 wp = mul(d, 1.0f / dist);
        float cfront = -dot(nlt, wp); /* > 0: p is in front of the triangle */
        float cosl = ltwo[i] != 0.0f ? fabsf(cfront) : cfront;
        float pdf_tri = lrad[3][i] * (d2 / (lcdf[i] * cosl));
        /* point and spot: inverse square, the spot's smooth cone */
        float cd = -dot(wp, v1);
        float t = (cd - v2.y) / fmx(v2.x - v2.y, 1e-6f);
        t = fmn(fmx(t, 0.0f), 1.0f);
        float fall = spot ? (1.0f / d2) * (t * t) : 1.0f / d2;
        fall = tri | dirl ? 1.0f : fall;
        /* directional: along -p1; the environment: its sample */
        v3 w = sel3(dirl, mul(v1, -1.0f), wp);
        w = envl ? LD3(ed, i) : w;
        float pdf = tri ? pdf_tri : envl ? lrad[3][i] * epdf[i] : lrad[3][i];
        bool valid = dirl | (envl & (epdf[i] > 0.0f)) |
                     (!envl & (dist > 0) & (!tri | (cosl > 0.0f)));
        float d3[3], s3[3], pdf_brdf;
        bool up = brdf_lane(S, L, i, w, d3, s3, &pdf_brdf);
        ok[i] = active[i] & valid & (pdf > 0) & up;
        /* the shadow ray from the receiver's offset origin to the emitter's point offset off
         * its plane towards the receiver (shaders/offset.h), direction and length from those
         * two points; a point light's position is its end. When the two offset points have
         * crossed (the receiver closer to the emitter than the coordinates resolve), no
         * occluder fits between them: no ray. */
        v3 o = LD3(org, i);
        float eq = tnd_offset_eps(fmx(tnd_max_abs3(q.x, q.y, q.z), tnd_max_abs3(p.x, p.y, p.z)));
        v3 end = sel3(tri, add(q, mul(sel3(cfront >= 0.0f, nlt, mul(nlt, -1.0f)), eq)), pos);
        v3 sd = sub(end, o);
        float sl = sqrtf(dot(sd, sd));
        cast[i] = far | (dot(sd, d) > 0.0f);
        tmax[i] = far ? 1e30f : sl;
        bool weigh = (tri | envl) & (!mis_on || mis_on[i] != 0);
        float mis = weigh ? tnd_mis_power(pdf, pdf_brdf) : 1.0f;
        for (int k = 0; k < 3; k++) {
            float Li = envl ? erad[k][i] : lrad[k][i] * fall;
            dc[k][i] = Li * d3[k] * mis / pdf;
            sc[k][i] = Li * s3[k] * mis / pdf;
        }
        ST3(wi, i, sel3(far, w, mul(sd, 1.0f / sl)));
    }
    /* the lanes with a shadow ray first, without a branch per lane (which lanes have one
     * follows the light samples: a branch on it mispredicts) */
    uint32_t todo[NL], m = 0;
    for (uint32_t i = 0; i < n; i++) {
        todo[m] = i;
        m += ok[i] & cast[i];
    }
    for (uint32_t j = 0; j < m; j++) {
        uint32_t i = todo[j];
        ok[i] = !femb_occluded(c, LD3(org, i), LD3(wi, i), tmax[i]);
    }
    LANES (i, n)
        for (int k = 0; k < 3; k++) {
            diff[k][i] = ok[i] ? dc[k][i] : 0.0f;
            spec[k][i] = ok[i] ? sc[k][i] : 0.0f;
        }
}

/* (one copy for scenes whose lights are all emissive triangles, without the point, spot and
 * directional arithmetic, as the Vulkan front-end compiles only what a scene requires; one for
 * any list) */
LANE_FN static void direct_light(const femb_context *c, const femb_paths *P, uint32_t bounce,
                                 const fb_surf *S, const fb_lobes *L, const float org[3][NL],
                                 const uint8_t *active, const uint8_t *mis_on, uint32_t n,
                                 float diff[3][NL], float spec[3][NL])
{
    if (!c->lights.count) {
        LANES (i, n)
            for (int k = 0; k < 3; k++)
                diff[k][i] = spec[k][i] = 0.0f;
    } else if (c->triangle_lights_only) {
        direct_light_kinds(c, P, bounce, S, L, org, active, mis_on, n, diff, spec, true);
    } else {
        direct_light_kinds(c, P, bounce, S, L, org, active, mis_on, n, diff, spec, false);
    }
}
#pragma GCC diagnostic pop

/* Sample the BRDF of every lane (dimensions of `bounce`): direction, per-channel weight
 * f cos / pdf (the diffuse lobe's demodulated, i.e. without albedo and 1 - metallic), the
 * mixture pdf, whether the specular lobe was taken, and whether the sample lives (ok). */
LANE_FN static void sample_brdf(const fb_surf *S, const fb_lobes *L, const femb_paths *P,
                                uint32_t bounce, uint32_t n, float wi[3][NL], float w[3][NL],
                                float pdf[NL], uint8_t specular[NL], uint8_t ok[NL])
{
    LANES (i, n) {
        float u = rnd(P, i, bounce, TND_DIM_LOBE);
        float u1 = rnd(P, i, bounce, TND_DIM_BRDF_U), u2 = rnd(P, i, bounce, TND_DIM_BRDF_V);
        v3 ns = LD3(S->ns, i), wo = LD3(S->wo, i), t, b;
        onb(ns, &t, &b);
        float sn, cs, r = sqrtf(u1);
        sincos_turns(u2, &sn, &cs);
        /* diffuse: cosine-weighted hemisphere */
        v3 wd = norm(to_world((v3){r * cs, r * sn, sqrtf(fmx(0.0f, 1.0f - u1))}, t, b, ns));
        /* specular: a GGX VNDF microfacet normal for wo (Heitz 2018), wo reflected about it */
        float alpha = L->alpha[i];
        v3 v = {dot(wo, t), dot(wo, b), dot(wo, ns)};
        v3 vh = norm((v3){alpha * v.x, alpha * v.y, v.z});
        float lensq = vh.x * vh.x + vh.y * vh.y, il = 1.0f / sqrtf(lensq);
        v3 t1 = sel3(lensq > 0, (v3){-vh.y * il, vh.x * il, 0.0f}, (v3){1.0f, 0.0f, 0.0f});
        v3 t2 = cross(vh, t1);
        float p1 = r * cs, p2 = r * sn, s = 0.5f * (1.0f + vh.z);
        p2 = (1.0f - s) * sqrtf(fmx(0.0f, 1.0f - p1 * p1)) + s * p2;
        v3 nh =
            add(add(mul(t1, p1), mul(t2, p2)), mul(vh, sqrtf(fmx(0.0f, 1.0f - p1 * p1 - p2 * p2))));
        v3 ne = norm((v3){alpha * nh.x, alpha * nh.y, fmx(1e-6f, nh.z)});
        v3 h = norm(to_world(ne, t, b, ns));
        v3 ws = norm(sub(mul(h, 2.0f * dot(wo, h)), wo));
        bool sp = u < L->p_spec[i];
        v3 dir = sel3(sp, ws, wd);
        float d3[3], s3[3], pb;
        bool up = brdf_lane(S, L, i, dir, d3, s3, &pb);
        /* one-sample MIS over the two lobes: weight = f cos / (mixture pdf) for the chosen
         * lobe's share of f; the lobe's own contribution only, so that lf and spec stay apart */
        float pl_s = L->p_spec[i] *
                     tnd_ggx_vndf_pdf(fmx(dot(ns, norm(add(dir, wo))), 0.0f), L->nv[i], L->a2[i]);
        float pl_d = (1.0f - L->p_spec[i]) * dot(ns, dir) * (float)TND_INV_PI;
        float pl = sp ? pl_s : pl_d;
        ok[i] = up & (pb > 0) & (pl > 0);
        for (int k = 0; k < 3; k++)
            w[k][i] = (sp ? s3[k] : d3[k]) / pl;
        ST3(wi, i, dir);
        pdf[i] = pb;
        specular[i] = sp;
    }
}

/* ---- specular vertices ---------------------------------------------------------------------- */
v3 femb_specular_direction(const femb_surface *s, v3 n, v3 dir, float u, float f[3],
                           uint32_t *event, bool *enter)
{
    float cos_i = fmx(-dot(n, dir), 1e-6f);
    v3 refl = sub(dir, mul(n, 2.0f * dot(dir, n)));
    f[0] = f[1] = f[2] = 1.0f;
    *enter = false;
    if (s->kind == TND_KIND_MIRROR) {
        for (int k = 0; k < 3; k++)
            f[k] = tnd_mirror_fresnel(s->base[k], cos_i);
        *event = TND_EVENT_REFLECT;
        return refl;
    }
    *event = tnd_dielectric_event(s->kind, s->front, cos_i, s->ior, u);
    if (*event == TND_EVENT_REFLECT)
        return refl;
    if (*event == TND_EVENT_TRANSMIT)
        return dir;
    float eta = s->front ? s->ior : 1.0f / s->ior;
    float cos_t = tnd_refract_cos(cos_i, eta);
    *enter = s->front;
    return norm(add(mul(dir, 1.0f / eta), mul(n, cos_i / eta - cos_t)));
}

v3 femb_specular_vertex(const femb_surface *s, v3 dir, float u, float f[3], uint32_t *event,
                        bool *enter)
{
    v3 wi = femb_specular_direction(s, s->ns, dir, u, f, event, enter);
    float side = dot(wi, s->ng); /* ng faces the incoming ray */
    if (*event == TND_EVENT_REFLECT ? side <= 0.0f : side >= 0.0f)
        wi = femb_specular_direction(s, s->ng, dir, u, f, event, enter);
    return wi;
}

/* ---- paths ---------------------------------------------------------------------------------- */
/* The state of a batch of paths between vertices. */
typedef struct fb_state {
    FEMB_ALIGN float from[3][NL], org[3][NL], dir[3][NL], beta[3][NL], sigma[3][NL];
    float pdf_prev[NL], cone[NL];
    uint32_t specular[NL]; /* specular vertices so far: they do not count as bounces */
    uint8_t alive[NL], inside[NL];
} fb_state;

/* The closest hits of the rays of the `live` lanes among [0, n): hit[i], and where (a lane that
 * is not live or misses gets instance, primitive, barycentrics and distance 0); whether any
 * lane hit. */
static inline bool closest_hits(const femb_context *c, uint32_t n, const uint8_t *live,
                                const float org[3][NL], const float dir[3][NL], uint32_t *inst,
                                uint32_t *prim, float *hu, float *hv, float *t, uint8_t *hit)
{
    bool any = false;
    for (uint32_t i = 0; i < n; i++) {
        hit[i] = live[i] && femb_intersect(c, LD3(org, i), LD3(dir, i), 1e30f, &inst[i],
                                           &prim[i], &hu[i], &hv[i], &t[i]);
        if (!hit[i]) {
            inst[i] = prim[i] = 0;
            hu[i] = hv[i] = t[i] = 0.0f;
        }
        any |= hit[i];
    }
    return any;
}

/* Vertex `b` of the live lanes: the closest hits (a miss adds the sky and ends the path), the
 * surfaces, their emission (MIS-weighted against the light list when the previous vertex sampled
 * a BRDF), and specular vertices followed at once. shade[i] is set for the lanes that stand on
 * an opaque surface (in S) and need shading. */
static void path_vertex(const femb_context *c, const femb_paths *P, uint32_t b, uint32_t n,
                        fb_state *st, fb_surf *S, uint8_t shade[NL], float L_out[3][NL],
                        float *t_out)
{
    uint32_t inst[NL] = {0}, prim[NL] = {0}; /* (initialised: gcc cannot see that lanes < n are) */
    float hu[NL] = {0}, hv[NL] = {0}, t[NL];
    uint8_t hit[NL] = {0};
    closest_hits(c, n, st->alive, st->org, st->dir, inst, prim, hu, hv, t, hit);
    for (uint32_t i = 0; t_out && i < n; i++) /* the segment's length (femb_trace_paths) */
        if (st->alive[i])
            t_out[i] = hit[i] ? t[i] : (float)TND_DEPTH_MISS;
    for (uint32_t i = 0; i < n; i++) {
        if (!hit[i]) {
            if (st->alive[i]) {
                float Le[3];
                miss_radiance(c, LD3(st->dir, i), st->pdf_prev[i], Le);
                for (int k = 0; k < 3; k++)
                    L_out[k][i] += st->beta[k][i] * Le[k];
            }
            st->alive[i] = 0;
            continue;
        }
        if (st->inside[i]) /* Beer-Lambert over the segment inside the glass */
            for (int k = 0; k < 3; k++)
                st->beta[k][i] *= expf(-st->sigma[k][i] * t[i]);
        st->cone[i] += t[i] * c->pixel_spread;
    }
    femb_surface_eval_batch(c, n, hit, inst, prim, hu, hv, st->dir, st->cone, S);
    for (uint32_t i = 0; i < n; i++) {
        shade[i] = 0;
        if (!hit[i])
            continue;
        v3 dir = LD3(st->dir, i);
        if (S->emission[0][i] > 0 || S->emission[1][i] > 0 || S->emission[2][i] > 0) {
            float w = emission_weight(c, st->pdf_prev[i], inst[i], prim[i], LD3(S->p, i),
                                      LD3(st->from, i), dir, LD3(S->ng, i));
            for (int k = 0; k < 3; k++)
                L_out[k][i] += st->beta[k][i] * w * S->emission[k][i];
        }
        if (S->kind[i] == TND_KIND_OPAQUE) {
            shade[i] = 1;
            continue;
        }
        if (++st->specular[i] > TND_MAX_SPECULAR_DEPTH) {
            st->alive[i] = 0;
            continue;
        }
        femb_surface s;
        femb_surface_get(S, i, &s);
        float f[3];
        uint32_t ev;
        bool enter;
        v3 wi = femb_specular_vertex(&s, dir, rnd(P, i, b, TND_DIM_SPLIT), f, &ev, &enter);
        if (ev == TND_EVENT_REFRACT) { /* into the volume, or out of it */
            st->inside[i] = enter;
            for (int k = 0; k < 3; k++)
                st->sigma[k][i] = s.sigma[k];
        }
        for (int k = 0; k < 3; k++)
            st->beta[k][i] *= f[k];
        ST3(st->from, i, s.p);
        ST3(st->org, i, femb_offset_ray(s.p, dot(wi, s.ng) >= 0 ? s.ng : mul(s.ng, -1.0f)));
        ST3(st->dir, i, wi);
        st->pdf_prev[i] = 0.0f; /* a delta lobe: an emitter seen through it gets the full weight */
    }
}

LANE_FN void femb_trace_paths(const femb_context *c, const femb_paths *P, uint32_t bounce,
                              uint32_t max_bounce, uint32_t rr_start, float L_out[3][FEMB_LANES],
                              float *first_t)
{
    uint32_t n = P->n;
    fb_state st;
    fb_surf S;
    fb_lobes L;
    for (uint32_t i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++) {
            st.from[k][i] = P->from[k][i];
            st.org[k][i] = P->org[k][i];
            st.dir[k][i] = P->dir[k][i];
            st.beta[k][i] = 1.0f;
            st.sigma[k][i] = 0.0f;
            L_out[k][i] = 0.0f;
        }
        st.pdf_prev[i] = P->pdf_prev[i];
        st.cone[i] = P->cone[i];
        st.specular[i] = 0;
        st.alive[i] = P->active[i];
        st.inside[i] = 0;
    }
    for (uint32_t b = bounce;; b++) {
        bool alive = false;
        for (uint32_t i = 0; i < n; i++)
            alive |= st.alive[i];
        if (!alive)
            return;
        uint8_t shade[NL], goes_on[NL];
        bool any = false, more = false; /* any lane to shade; any to continue after it */
        path_vertex(c, P, b, n, &st, &S, shade, L_out, b == bounce ? first_t : NULL);
        for (uint32_t i = 0; i < n; i++) {
            any |= shade[i];
            goes_on[i] = shade[i] && b - st.specular[i] < max_bounce;
            more |= goes_on[i];
        }
        if (!any)
            continue;
        float d[3][NL], sp[3][NL], org[3][NL];
        lobes(&S, n, &L);
        LANES (i, n) /* the next rays' origin */
            ST3(org, i, femb_offset_ray(LD3(S.p, i), LD3(S.ng, i)));
        direct_light(c, P, b, &S, &L, org, shade, goes_on, n, d, sp);
        LANES (i, n)
            for (int k = 0; k < 3; k++) {
                float add =
                    st.beta[k][i] * (d[k][i] * S.base[k][i] * (1.0f - S.metallic[i]) + sp[k][i]);
                L_out[k][i] +=
                    shade[i] ? add : 0.0f; /* (no conditional store: it would not vectorise) */
            }
        float wi[3][NL], w[3][NL], pdf[NL];
        uint8_t spec[NL], ok[NL];
        if (more)
            sample_brdf(&S, &L, P, b, n, wi, w, pdf, spec, ok);
        for (uint32_t i = 0; i < n; i++) {
            if (!shade[i])
                continue;
            uint32_t nb = b - st.specular[i]; /* bounces that count */
            if (nb >= max_bounce || !ok[i]) {
                st.alive[i] = 0;
                continue;
            }
            for (int k = 0; k < 3; k++) /* the diffuse lobe remodulated */
                st.beta[k][i] *=
                    spec[i] ? w[k][i] : w[k][i] * (S.base[k][i] * (1.0f - S.metallic[i]));
            if (nb + 1 >= rr_start) {
                float q =
                    fmn(fmx(fmx(st.beta[0][i], fmx(st.beta[1][i], st.beta[2][i])), 0.05f), 1.0f);
                if (rnd(P, i, b, TND_DIM_RR) >= q) {
                    st.alive[i] = 0;
                    continue;
                }
                for (int k = 0; k < 3; k++)
                    st.beta[k][i] /= q;
            }
            for (int k = 0; k < 3; k++) {
                st.from[k][i] = S.p[k][i];
                st.org[k][i] = org[k][i];
                st.dir[k][i] = wi[k][i];
            }
            st.pdf_prev[i] = pdf[i];
        }
    }
}

/* femb_trace_paths from vertex 1 with max_bounce 1 in a scene without mirrors or glass (every
 * surface opaque): the real-time default, and the shading pass's usual call. The same
 * arithmetic on the same values (a path's throughput is 1 at its first vertex, and products
 * by 1 are exact), without the general loop's path state and bookkeeping: test_one_bounce_agrees
 * compares the two bit for bit. (The lanes of S, d and sp below n are all written before use;
 * gcc cannot see it through the lane loops.) */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
LANE_FN static void one_bounce(const femb_context *c, const femb_paths *P, float L_out[3][NL],
                               float first_t[NL])
{
    uint32_t n = P->n;
    uint32_t inst[NL], prim[NL];
    float hu[NL], hv[NL], t[NL], cone[NL];
    uint8_t hit[NL];
    fb_surf S;
    fb_lobes L;
    bool any = closest_hits(c, n, P->active, P->org, P->dir, inst, prim, hu, hv, t, hit);
    const float *sky = c->scene->sky;
    LANES (i, n) { /* a miss sees the sky */
        bool miss = P->active[i] & !hit[i];
        first_t[i] = hit[i] ? t[i] : (float)TND_DEPTH_MISS;
        for (int k = 0; k < 3; k++)
            L_out[k][i] = miss ? sky[k] : 0.0f;
        cone[i] = P->cone[i] + t[i] * c->pixel_spread;
    }
    for (uint32_t i = 0; i < n && c->scene->env.width; i++) /* or the environment map */
        if (P->active[i] && !hit[i]) {
            float Le[3];
            miss_radiance(c, LD3(P->dir, i), P->pdf_prev[i], Le);
            ST3(L_out, i, ((v3){Le[0], Le[1], Le[2]}));
        }
    if (!any)
        return;
    femb_surface_eval_batch(c, n, hit, inst, prim, hu, hv, P->dir, cone, &S);
    for (uint32_t i = 0; i < n; i++) /* emitters hit, MIS-weighted when a BRDF sample found them */
        if (hit[i] && (S.emission[0][i] > 0 || S.emission[1][i] > 0 || S.emission[2][i] > 0)) {
            float w = emission_weight(c, P->pdf_prev[i], inst[i], prim[i], LD3(S.p, i),
                                      LD3(P->from, i), LD3(P->dir, i), LD3(S.ng, i));
            for (int k = 0; k < 3; k++)
                L_out[k][i] += w * S.emission[k][i];
        }
    float d[3][NL], sp[3][NL], org[3][NL];
    lobes(&S, n, &L);
    LANES (i, n)
        ST3(org, i, femb_offset_ray(LD3(S.p, i), LD3(S.ng, i)));
    uint8_t none[NL] = {0}; /* (max_bounce 1: the paths end here) */
    direct_light(c, P, 1, &S, &L, org, hit, none, n, d, sp);
    LANES (i, n)
        for (int k = 0; k < 3; k++) {
            float add = d[k][i] * S.base[k][i] * (1.0f - S.metallic[i]) + sp[k][i];
            L_out[k][i] += hit[i] ? add : 0.0f;
        }
}
#pragma GCC diagnostic pop

/* ---- the shading pass ----------------------------------------------------------------------- */
/* Entry q of lane i: pixels[i], or pixels[0] + i when `run` (a constant in each caller: the
 * pixels are one run, and the lane loops read and write the contract's planes with vector loads
 * and shuffles instead of one lane at a time). */
static inline size_t lane_entry(const uint32_t *pixels, bool run, uint32_t i)
{
    return run ? (size_t)pixels[0] + i : pixels[i];
}

/* The entry that lane i reads: lane_entry in the frame, or i in a staged batch (whose pixels are
 * one run). */
static inline size_t read_entry(const uint32_t *pixels, bool run, bool staged, uint32_t i)
{
    return staged ? i : lane_entry(pixels, run, i);
}

/* The lanes' surfaces from the G-buffer of pixels[0..n), as the GPU passes read it (the primary
 * pass and the gradient patches wrote it), plus the material's specular factor; the distance from
 * the eye along the primary chain. f holds the G-buffer: the frame, or when `staged` (a constant
 * in each caller) the primary pass's staged batch of the run pixels[0].., whose lanes that see no
 * surface (active 0) get values that are not used. */
static inline __attribute__((always_inline)) void
gbuffer_surfaces(const femb_context *c, const tnd_frame *f, const uint32_t *pixels, bool run,
                 bool staged, const uint8_t *active, uint32_t n, fb_surf *S, float *depth)
{
    const float *P = tnd_frame_f(f, TND_CT_POSITION), *NS = tnd_frame_f(f, TND_CT_NORMAL);
    const float *NG = tnd_frame_f(f, TND_CT_GEO_NORMAL), *B = tnd_frame_f(f, TND_CT_ALBEDO);
    const float *R = tnd_frame_f(f, TND_CT_ROUGHNESS), *M = tnd_frame_f(f, TND_CT_METALLIC);
    const uint32_t *vis = tnd_frame_u(f, TND_CT_VIS_ID);
    v3 cam = {c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]};
    LANES (i, n) {
        size_t q = read_entry(pixels, run, staged, i);
        v3 pos = {P[3 * q], P[3 * q + 1], P[3 * q + 2]};
        v3 ns = {NS[3 * q], NS[3 * q + 1], NS[3 * q + 2]};
        v3 d = sub(cam, pos);
        depth[i] = sqrtf(dot(d, d));
        v3 wo = sel3(depth[i] > 0, mul(d, 1.0f / depth[i]), ns);
        ST3(S->p, i, pos);
        ST3(S->ns, i, ns);
        ST3(S->ng, i, ((v3){NG[3 * q], NG[3 * q + 1], NG[3 * q + 2]}));
        ST3(S->wo, i, wo);
        for (int k = 0; k < 3; k++)
            S->base[k][i] = B[3 * q + k];
        S->roughness[i] = R[q];
        S->metallic[i] = M[q];
    }
    LANES (i, n) { /* (a lane without a surface reads instance 0's) */
        uint32_t inst = vis[2 * read_entry(pixels, run, staged, i)];
        S->specular[i] = c->inst[active[i] ? inst : 0].specular;
    }
    for (uint32_t i = 0; i < n && c->specular; i++) {
        size_t r = read_entry(pixels, run, staged, i), q = lane_entry(pixels, run, i);
        uint32_t inst = vis[2 * r];
        if (!active[i] || tnd_frame_u(f, TND_CT_PATH)[r] == 0u)
            continue;
        /* a surface seen in a mirror or through glass (the path flags say the primary chain met
         * one) is lit towards the chain's last segment, not towards the camera: the primary
         * pass's chain again (same jitter, same geometry) */
        femb_chain ch;
        femb_specular_chain(c, (uint32_t)(q % c->width), (uint32_t)(q / c->width), true, &ch);
        if (ch.hit && ch.vertices > 0 && ch.inst == inst && ch.prim == vis[2 * r + 1]) {
            ST3(S->wo, i, mul(ch.dir, -1.0f));
            depth[i] = ch.length;
        }
    }
}

/* The direction to the eye and its distance for the surfaces S of the primary pass, computed
 * from their position as gbuffer_surfaces computes them from the G-buffer's (the same bits). */
static inline __attribute__((always_inline)) void eye_from_position(const femb_context *c,
                                                                    uint32_t n, fb_surf *S,
                                                                    float *depth)
{
    v3 cam = {c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]};
    LANES (i, n) {
        v3 d = sub(cam, LD3(S->p, i));
        depth[i] = sqrtf(dot(d, d));
        ST3(S->wo, i, sel3(depth[i] > 0, mul(d, 1.0f / depth[i]), LD3(S->ns, i)));
    }
}

/* (S's lanes below n are all written before use; gcc cannot see it through the lane loops, and
 * clearing 8 KB per batch to quiet it is not free) */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
/* The shading pass on pixels[0..n) of f: from f's G-buffer, or when `staged` (a constant in each
 * caller, as `run`: then the pixels are one run) from `in`, the primary pass's staged G-buffer of
 * that run, in which a lane that sees no surface gets what the pass writes for the sky (no
 * signal; radiance: the emission). `given` (staged batches without mirrors or glass): the
 * surfaces are the primary pass's, not read from `in`; only their eye direction is recomputed. */
static inline __attribute__((always_inline)) void
shade_pixels(const femb_context *c, const femb_params *p, tnd_frame *f, const uint32_t *pixels,
             bool run, uint32_t n, float *radiance, bool staged, const tnd_frame *in,
             fb_surf *given)
{
    fb_surf own, *S = given ? given : &own;
    fb_lobes L;
    femb_paths P;
    float depth[NL], thr[3][NL], em[3][NL], demod[3][NL];
    uint8_t live[NL]; /* the lane sees a surface */
    const tnd_frame *g = staged ? in : f; /* the G-buffer read */
    P.n = n;
    P.key_sample = p->sample; /* (TND_SAMPLE_REALTIME but in a matched reference) */
    const uint32_t *rng = tnd_frame_u(g, TND_CT_RNG), *vis = tnd_frame_u(g, TND_CT_VIS_ID);
    const float *T = tnd_frame_f(g, TND_CT_THROUGHPUT), *E = tnd_frame_f(g, TND_CT_EMISSION);
    LANES (i, n) {
        size_t q = read_entry(pixels, run, staged, i);
        P.key_pixel[i] = rng[2 * q + 1];
        P.key_frame[i] = rng[2 * q];
        live[i] = staged ? vis[2 * q] != TND_VIS_NONE : 1;
        P.active[i] = live[i];
        for (int k = 0; k < 3; k++) {
            thr[k][i] = T[3 * q + k];
            em[k][i] = E[3 * q + k];
        }
    }
    if (given) /* the primary pass's surfaces; towards the eye as gbuffer_surfaces has it */
        eye_from_position(c, n, S, depth);
    else
        gbuffer_surfaces(c, g, pixels, run, staged, live, n, S, depth);
    lobes(S, n, &L);
    float d[3][NL], sp[3][NL], hf[3][NL], spec[3][NL], rad[3][NL], sh[4][NL], cocg[2][NL];
    float hit_t[NL]; /* spec_hit: the specular-lobe sample's first segment, else 0 */
    float dview[NL]; /* diffuse_view: 1 - F(n.v), the luminance of the per-channel factor */
    LANES (i, n) { /* the origin of the next rays */
        ST3(P.from, i, LD3(S->p, i));
        ST3(P.org, i, femb_offset_ray(LD3(S->p, i), LD3(S->ng, i)));
    }
    uint8_t goes_on[NL]; /* an indirect path follows (--bounces half: in expectation) */
    LANES (i, n)
        goes_on[i] = p->bounces > 0;
    /* the lanes whose direct light is a reservoir's (--lights restir; femb_restir.c): the rest
     * take next-event estimation */
    const femb_reservoir *res[NL] = {NULL};
    uint8_t nee[NL];
    bool any_res = false;
    if (c->restir && P.key_sample == TND_SAMPLE_REALTIME) {
        memcpy(nee, P.active, sizeof nee);
        for (uint32_t i = 0; i < n; i++)
            if (live[i] && (res[i] = femb_restir_lookup(c, P.key_frame[i], P.key_pixel[i]))) {
                nee[i] = 0;
                any_res = true;
            }
    }
    direct_light(c, &P, 0, S, &L, P.org, any_res ? nee : P.active, goes_on, n, d, sp);
    for (uint32_t i = 0; any_res && i < n; i++) {
        if (!res[i])
            continue;
        femb_rsurf rsf;
        for (int k = 0; k < 3; k++) {
            rsf.p[k] = S->p[k][i], rsf.ns[k] = S->ns[k][i], rsf.ng[k] = S->ng[k][i];
            rsf.wo[k] = S->wo[k][i], rsf.base[k] = S->base[k][i];
        }
        rsf.metallic = S->metallic[i], rsf.roughness = S->roughness[i];
        rsf.specular = S->specular[i], rsf.depth = depth[i];
        float dr[3], sr[3];
        femb_restir_shade(c, res[i], &rsf, LD3(P.org, i), dr, sr);
        for (int k = 0; k < 3; k++)
            d[k][i] = dr[k], sp[k][i] = sr[k];
    }
    LANES (i, n) {
        for (int k = 0; k < 3; k++) {
            float m = S->metallic[i];
            demod[k][i] = fmx(0.01f, 0.04f * (1.0f - m) + S->base[k][i] * m);
            hf[k][i] = d[k][i];
            spec[k][i] = sp[k][i] / demod[k][i];
            rad[k][i] = em[k][i] + thr[k][i] * (d[k][i] * S->base[k][i] * (1.0f - m) + sp[k][i]);
        }
        sh[0][i] = sh[1][i] = sh[2][i] = sh[3][i] = cocg[0][i] = cocg[1][i] = 0.0f;
        hit_t[i] = 0.0f;
        dview[i] = tnd_luminance(1.0f - L.f_nv[0][i], 1.0f - L.f_nv[1][i], 1.0f - L.f_nv[2][i]);
    }
    if (p->bounces > 0) {
        float wi[3][NL], w[3][NL], pdf[NL], Li[3][NL], first_t[NL] = {0};
        uint8_t is_spec[NL], ok[NL];
        sample_brdf(S, &L, &P, 0, n, wi, w, pdf, is_spec, ok);
        /* (half resolution: the lane's choice in the frame its key was drawn for) */
        float weight = p->half_indirect ? 2.0f : 1.0f;
        for (uint32_t i = 0; i < n; i++) {
            P.active[i] = live[i] & ok[i] &
                          (!p->half_indirect ||
                           TND_HALF_TRACED(P.key_pixel[i], P.key_frame[i], c->width));
            for (int k = 0; k < 3; k++)
                P.dir[k][i] = wi[k][i];
            P.pdf_prev[i] = res[i] ? FEMB_PDF_RESERVOIR : pdf[i];
            P.cone[i] = depth[i] * c->pixel_spread;
        }
        if (p->bounces == 1 && !c->specular)
            one_bounce(c, &P, Li, first_t);
        else
            femb_trace_paths(c, &P, 1, p->bounces, 2, Li, first_t);
        LANES (i, n) {
            float ct[3];
            for (int k = 0; k < 3; k++) {
                ct[k] = w[k][i] * Li[k][i] * weight;
                /* a broken sample must not poison the history */
                ct[k] = (ct[k] >= 0.0f) & (ct[k] <= FLT_MAX) ? ct[k] : 0.0f;
            }
            bool s_lobe = P.active[i] & is_spec[i], d_lobe = P.active[i] & !is_spec[i];
            hit_t[i] = s_lobe ? first_t[i] : 0.0f;
            float m = S->metallic[i];
            for (int k = 0; k < 3; k++) { /* (no conditional stores: they do not vectorise) */
                spec[k][i] += s_lobe ? ct[k] / demod[k][i] : 0.0f;
                float albedo = S->base[k][i] * (1.0f - m);
                albedo = s_lobe ? 1.0f : albedo;
                albedo = P.active[i] ? albedo : 0.0f;
                rad[k][i] += thr[k][i] * ct[k] * albedo;
            }
            /* YCoCg, then the SH lobe scaled so that its value at the shading normal is Y */
            float co = ct[0] - ct[2], t = ct[2] + 0.5f * co, cg = ct[1] - t, Y = t + 0.5f * cg;
            v3 dir = LD3(wi, i);
            float kk = 4.0f * (float)TND_PI / (1.0f + 2.0f * fmx(dot(dir, LD3(S->ns, i)), 0.0f));
            sh[0][i] = d_lobe ? kk * Y * SH_C1 * dir.x : 0.0f;
            sh[1][i] = d_lobe ? kk * Y * SH_C1 * dir.y : 0.0f;
            sh[2][i] = d_lobe ? kk * Y * SH_C1 * dir.z : 0.0f;
            sh[3][i] = d_lobe ? kk * Y * SH_C0 : 0.0f;
            cocg[0][i] = d_lobe ? kk * co : 0.0f;
            cocg[1][i] = d_lobe ? kk * cg : 0.0f;
        }
    }
    /* a run is staged in the order of the contract's planes and streamed to them */
    FEMB_ALIGN float stage[14 * NL];
    float *s_hf = stage, *s_sp = stage + 3 * n, *s_sh = stage + 6 * n, *s_cc = stage + 10 * n;
    float *s_ht = stage + 12 * n, *s_dv = stage + 13 * n;
    LANES (i, n) {
        size_t q = lane_entry(pixels, run, i);
        size_t e = run ? i : q; /* the entry written: in the stage or in the frame */
        float *o_hf = run ? s_hf : tnd_frame_f(f, TND_CT_HF),
              *o_sp = run ? s_sp : tnd_frame_f(f, TND_CT_SPEC);
        float *o_sh = run ? s_sh : tnd_frame_f(f, TND_CT_LF_SH),
              *o_cc = run ? s_cc : tnd_frame_f(f, TND_CT_LF_COCG);
        bool l = live[i]; /* (a lane without a surface: what shade_tile writes for the sky) */
        for (int k = 0; k < 3; k++) {
            o_hf[3 * e + k] = l ? hf[k][i] : 0.0f;
            o_sp[3 * e + k] = l ? spec[k][i] : 0.0f;
            if (radiance)
                radiance[3 * q + k] = l ? rad[k][i] : em[k][i];
        }
        for (int k = 0; k < 4; k++)
            o_sh[4 * e + k] = l ? sh[k][i] : 0.0f;
        o_cc[2 * e] = l ? cocg[0][i] : 0.0f;
        o_cc[2 * e + 1] = l ? cocg[1][i] : 0.0f;
        (run ? s_ht : tnd_frame_f(f, TND_CT_SPEC_HIT))[e] = l ? hit_t[i] : 0.0f;
        (run ? s_dv : tnd_frame_f(f, TND_CT_DIFFUSE_VIEW))[e] = l ? dview[i] : 1.0f;
    }
    if (run) {
        size_t q0 = pixels[0];
        femb_stream_words(tnd_frame_f(f, TND_CT_HF) + 3 * q0, s_hf, 3 * (size_t)n);
        femb_stream_words(tnd_frame_f(f, TND_CT_SPEC) + 3 * q0, s_sp, 3 * (size_t)n);
        femb_stream_words(tnd_frame_f(f, TND_CT_LF_SH) + 4 * q0, s_sh, 4 * (size_t)n);
        femb_stream_words(tnd_frame_f(f, TND_CT_LF_COCG) + 2 * q0, s_cc, 2 * (size_t)n);
        femb_stream_words(tnd_frame_f(f, TND_CT_SPEC_HIT) + q0, s_ht, (size_t)n);
        femb_stream_words(tnd_frame_f(f, TND_CT_DIFFUSE_VIEW) + q0, s_dv, (size_t)n);
    }
}

/* (one copy for pixels that are one run, the shading pass's usual batch, one for any list:
 * gradient samples come in any order) */
LANE_FN void femb_shade_pixels(const femb_context *c, const femb_params *p, tnd_frame *f,
                               const uint32_t *pixels, uint32_t n, float *radiance)
{
    bool run = true;
    for (uint32_t i = 1; i < n; i++)
        run &= pixels[i] == pixels[0] + i;
    if (run)
        shade_pixels(c, p, f, pixels, true, n, radiance, false, NULL, NULL);
    else
        shade_pixels(c, p, f, pixels, false, n, radiance, false, NULL, NULL);
}

LANE_FN void femb_shade_staged(const femb_context *c, const femb_params *p, tnd_frame *f,
                               const tnd_frame *stage, femb_surfaces *S, uint32_t q0, uint32_t n,
                               float *radiance)
{
    if (S)
        shade_pixels(c, p, f, &q0, true, n, radiance, true, stage, S);
    else
        shade_pixels(c, p, f, &q0, true, n, radiance, true, stage, NULL);
}
#pragma GCC diagnostic pop
