/* frontend_embree/femb_render.c: the passes of the Embree front-end and its estimator.
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
 * Entry points: femb_trace_primary, femb_shade, femb_gradient_unpack, femb_shade_gradients,
 * femb_reference, femb_composite. */
#include "frontend_embree/femb_internal.h"
#include "shaders/brdf.h"
#include "shaders/sampling.h"
#include "shaders/specular.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SH_C0 0.282094791773878f /* Y00 */
#define SH_C1 0.488602511902920f /* Y1m / direction component */

typedef struct rng_key {
    uint32_t pixel, frame;
} rng_key;

static inline float rnd(rng_key k, uint32_t bounce, uint32_t which)
{
    return tnd_rand(k.pixel, k.frame, tnd_dim(bounce, which));
}

/* Orthonormal basis around n (Duff et al. 2017). The sign test treats -0 as +0, as the GLSL
 * mirror must (copysign would split them, and the two front-ends would sample different
 * directions for normals with z = -0). */
static void onb(v3 n, v3 *t, v3 *b)
{
    float sign = n.z >= 0.0f ? 1.0f : -1.0f;
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = (v3){1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x};
    *b = (v3){bb, sign + n.y * n.y * a, -n.y};
}

static v3 to_world(v3 l, v3 t, v3 b, v3 n)
{
    return add(add(mul(t, l.x), mul(b, l.y)), mul(n, l.z));
}

static v3 sample_cosine(v3 n, float u1, float u2)
{
    v3 t, b;
    onb(n, &t, &b);
    float r = sqrtf(u1), phi = 2.0f * (float)TND_PI * u2;
    v3 l = {r * cosf(phi), r * sinf(phi), sqrtf(fmx(0.0f, 1.0f - u1))};
    return norm(to_world(l, t, b, n));
}

/* GGX VNDF sample (Heitz 2018): microfacet normal for the view direction wo. */
static v3 sample_vndf(v3 n, v3 wo, float alpha, float u1, float u2)
{
    v3 t, b;
    onb(n, &t, &b);
    v3 v = {dot(wo, t), dot(wo, b), dot(wo, n)};
    v3 vh = norm((v3){alpha * v.x, alpha * v.y, v.z});
    float lensq = vh.x * vh.x + vh.y * vh.y;
    v3 t1 = lensq > 0 ? mul((v3){-vh.y, vh.x, 0}, 1.0f / sqrtf(lensq)) : (v3){1, 0, 0};
    v3 t2 = cross(vh, t1);
    float r = sqrtf(u1), phi = 2.0f * (float)TND_PI * u2;
    float p1 = r * cosf(phi), p2 = r * sinf(phi);
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrtf(fmx(0.0f, 1.0f - p1 * p1)) + s * p2;
    v3 nh = add(add(mul(t1, p1), mul(t2, p2)), mul(vh, sqrtf(fmx(0.0f, 1.0f - p1 * p1 - p2 * p2))));
    v3 ne = norm((v3){alpha * nh.x, alpha * nh.y, fmx(1e-6f, nh.z)});
    return norm(to_world(ne, t, b, n));
}

/* ---- materials ------------------------------------------------------------------------------ */
typedef struct lobe_info {
    float f_nv[3];  /* Fresnel at n.v */
    float alpha, a2, nv;
    float p_spec;   /* probability of the specular lobe */
} lobe_info;

static void lobes(const femb_surface *s, lobe_info *L)
{
    L->nv = fmx(dot(s->ns, s->wo), 1e-4f);
    L->alpha = fmx(s->roughness * s->roughness, (float)TND_MIN_ALPHA);
    L->a2 = L->alpha * L->alpha;
    float kd[3];
    for (int k = 0; k < 3; k++) {
        L->f_nv[k] = tnd_fresnel(s->metallic, s->specular, s->base[k], L->nv);
        kd[k] = s->base[k] * (1.0f - s->metallic) * (1.0f - L->f_nv[k]);
    }
    L->p_spec = tnd_spec_probability(tnd_luminance(L->f_nv[0], L->f_nv[1], L->f_nv[2]),
                                     tnd_luminance(kd[0], kd[1], kd[2]));
}

/* BRDF x cos for direction wi: diffuse part without albedo and (1 - metallic) ("demodulated"),
 * specular part with its Fresnel. Returns false when wi is below either normal. */
static bool eval_brdf(const femb_surface *s, const lobe_info *L, v3 wi, float diff[3],
                      float spec[3], float *pdf_brdf)
{
    float nl = dot(s->ns, wi);
    if (nl <= 0.0f || dot(s->ng, wi) <= 0.0f)
        return false;
    v3 h = norm(add(wi, s->wo));
    float nh = fmx(dot(s->ns, h), 0.0f), vh = fmx(dot(s->wo, h), 0.0f);
    float g = tnd_ggx_spec_cos(nh, L->nv, nl, L->a2);
    for (int k = 0; k < 3; k++) {
        diff[k] = (1.0f - L->f_nv[k]) * nl * (float)TND_INV_PI;
        spec[k] = tnd_fresnel(s->metallic, s->specular, s->base[k], vh) * g;
    }
    *pdf_brdf = L->p_spec * tnd_ggx_vndf_pdf(nh, L->nv, L->a2) +
                (1.0f - L->p_spec) * nl * (float)TND_INV_PI;
    return true;
}

/* Light pick probability times the solid-angle pdf of reaching emitter triangle (instance,
 * primitive) from p along a ray of length d; 0 when it is not in the list. */
static float emitter_pdf(const femb_context *c, uint32_t instance, uint32_t primitive, float d,
                         v3 wi, v3 ng_light)
{
    if (!c->lights.count || c->lights.instance_first[instance] == ~0u)
        return 0.0f;
    const tnd_light_gpu *l = &c->lights.lights[c->lights.instance_first[instance] + primitive];
    float cosl = fabsf(dot(ng_light, wi));
    return cosl > 0 ? l->radiance.w * d * d / (l->cdf.w * cosl) : 0.0f;
}

/* One NEE sample at s with the dimensions of path vertex `bounce`: diffuse (demodulated) and
 * specular contributions. */
static void direct_light(const femb_context *c, rng_key key, uint32_t bounce,
                         const femb_surface *s, const lobe_info *L, float diff[3], float spec[3])
{
    for (int k = 0; k < 3; k++)
        diff[k] = spec[k] = 0.0f;
    if (!c->lights.count)
        return;
    uint32_t li = tnd_lights_pick(&c->lights, rnd(key, bounce, TND_DIM_LIGHT_PICK));
    const tnd_light_gpu *l = &c->lights.lights[li];
    uint32_t kind = (uint32_t)l->p0.w;
    float u1 = rnd(key, bounce, TND_DIM_LIGHT_U), u2 = rnd(key, bounce, TND_DIM_LIGHT_V);
    v3 wi, pos = {l->p0.x, l->p0.y, l->p0.z};
    float dist = 1e30f, pdf = l->radiance.w, Li[3] = {l->radiance.x, l->radiance.y, l->radiance.z};
    bool area = false;
    if (kind == TND_LIGHT_KIND_TRIANGLE) {
        v3 v1 = {l->p1.x, l->p1.y, l->p1.z}, v2 = {l->p2.x, l->p2.y, l->p2.z};
        float su = sqrtf(u1);
        v3 q = add(add(mul(pos, 1.0f - su), mul(v1, su * (1.0f - u2))), mul(v2, su * u2));
        v3 nl = norm(cross(sub(v1, pos), sub(v2, pos)));
        v3 d = sub(q, s->p);
        float d2 = dot(d, d);
        dist = sqrtf(d2);
        if (!(dist > 0))
            return;
        wi = mul(d, 1.0f / dist);
        float cosl = -dot(nl, wi);
        if (cosl <= 0.0f) /* the back of a one-sided emitter */
            return;
        pdf *= d2 / (l->cdf.w * cosl);
        area = true;
    } else if (kind == TND_LIGHT_KIND_DIRECTIONAL) {
        wi = (v3){-l->p1.x, -l->p1.y, -l->p1.z};
    } else {
        v3 d = sub(pos, s->p);
        float d2 = dot(d, d);
        dist = sqrtf(d2);
        if (!(dist > 0))
            return;
        wi = mul(d, 1.0f / dist);
        float fall = 1.0f / d2;
        if (kind == TND_LIGHT_KIND_SPOT) {
            float cd = -dot(wi, (v3){l->p1.x, l->p1.y, l->p1.z});
            float t = (cd - l->p2.y) / fmx(l->p2.x - l->p2.y, 1e-6f);
            t = fmn(fmx(t, 0.0f), 1.0f);
            fall *= t * t;
        }
        for (int k = 0; k < 3; k++)
            Li[k] *= fall;
    }
    float d[3], sp[3], pdf_brdf;
    if (!(pdf > 0) || !eval_brdf(s, L, wi, d, sp, &pdf_brdf))
        return;
    v3 org = femb_offset_ray(s->p, s->ng);
    if (femb_occluded(c, org, wi, area || kind != TND_LIGHT_KIND_DIRECTIONAL ? dist * 0.999f : 1e30f))
        return;
    float w = area ? tnd_mis_power(pdf, pdf_brdf) : 1.0f;
    for (int k = 0; k < 3; k++) {
        diff[k] = Li[k] * d[k] * w / pdf;
        spec[k] = Li[k] * sp[k] * w / pdf;
    }
}

/* Sample the BRDF at s (dimensions of `bounce`): direction, per-channel weight f cos / pdf
 * (diffuse demodulated when `demod`, i.e. without albedo and 1 - metallic), the pdf, and
 * whether the specular lobe was taken. False when the sample is absorbed. */
static bool sample_brdf(const femb_surface *s, const lobe_info *L, rng_key key, uint32_t bounce,
                        bool demod, v3 *wi, float w[3], float *pdf, bool *specular)
{
    float u = rnd(key, bounce, TND_DIM_LOBE);
    float u1 = rnd(key, bounce, TND_DIM_BRDF_U), u2 = rnd(key, bounce, TND_DIM_BRDF_V);
    *specular = u < L->p_spec;
    if (*specular) {
        v3 h = sample_vndf(s->ns, s->wo, L->alpha, u1, u2);
        *wi = norm(sub(mul(h, 2.0f * dot(s->wo, h)), s->wo));
    } else {
        *wi = sample_cosine(s->ns, u1, u2);
    }
    float d[3], sp[3];
    if (!eval_brdf(s, L, *wi, d, sp, pdf) || !(*pdf > 0))
        return false;
    /* one-sample MIS over the two lobes: weight = f cos / (mixture pdf) for the chosen lobe's
     * share of f; the lobe's own contribution only, so that lf and spec stay separate */
    float pl = *specular ? L->p_spec * tnd_ggx_vndf_pdf(fmx(dot(s->ns, norm(add(*wi, s->wo))), 0.0f),
                                                       L->nv, L->a2)
                         : (1.0f - L->p_spec) * dot(s->ns, *wi) * (float)TND_INV_PI;
    if (!(pl > 0))
        return false;
    for (int k = 0; k < 3; k++) {
        float f = *specular ? sp[k] : d[k] * (demod ? 1.0f : s->base[k] * (1.0f - s->metallic));
        w[k] = f / pl;
    }
    return true;
}

/* Radiance arriving along (org, dir) from path vertex `bounce` on: emission (MIS-weighted
 * against the light list when pdf_prev > 0), NEE at each hit, more vertices up to max_bounce with
 * Russian roulette from rr_start. */
/* The specular vertex of surface s (mirror, thin glass, glass) hit by a ray along `dir`: the
 * new direction, the throughput factor, and whether the ray is inside a glass volume after it.
 * The event comes from tnd_dielectric_event with u (TND_DIM_SPLIT of the vertex); shaders/
 * specular.h says why the weights are 1. */
static v3 specular_direction(const femb_surface *s, v3 n, v3 dir, float u, float f[3],
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

/* The specular vertex of surface s hit along `dir`: the new direction, the throughput factor,
 * the event (u: TND_DIM_SPLIT of the vertex) and whether the ray enters a glass volume. With
 * the shading normal a reflection can point below the geometric surface or a refraction above
 * it (near the silhouette of a smooth-shaded mesh); that vertex then uses the geometric normal,
 * so the ray always leaves on the side its event says. */
static v3 specular_vertex(const femb_surface *s, v3 dir, float u, float f[3], uint32_t *event,
                          bool *enter)
{
    v3 wi = specular_direction(s, s->ns, dir, u, f, event, enter);
    float side = dot(wi, s->ng); /* ng faces the incoming ray */
    if (*event == TND_EVENT_REFLECT ? side <= 0.0f : side >= 0.0f)
        wi = specular_direction(s, s->ng, dir, u, f, event, enter);
    return wi;
}

static void trace_path(const femb_context *c, rng_key key, v3 org, v3 dir, uint32_t bounce,
                       uint32_t max_bounce, uint32_t rr_start, float pdf_prev, float cone,
                       float L_out[3])
{
    float beta[3] = {1, 1, 1}, sigma[3] = {0, 0, 0};
    bool inside = false;
    uint32_t specular = 0; /* specular vertices so far: they do not count as bounces */
    L_out[0] = L_out[1] = L_out[2] = 0.0f;
    for (uint32_t b = bounce;; b++) {
        uint32_t inst, prim;
        float hu, hv, t;
        if (!femb_intersect(c, org, dir, 1e30f, &inst, &prim, &hu, &hv, &t)) {
            for (int k = 0; k < 3; k++)
                L_out[k] += beta[k] * c->scene->sky[k];
            return;
        }
        if (inside) /* Beer-Lambert over the segment inside the glass */
            for (int k = 0; k < 3; k++)
                beta[k] *= expf(-sigma[k] * t);
        femb_surface s;
        cone += t * c->pixel_spread;
        femb_surface_eval(c, inst, prim, hu, hv, dir, cone, &s);
        if (s.emission[0] > 0 || s.emission[1] > 0 || s.emission[2] > 0) {
            float w = 1.0f;
            if (pdf_prev > 0) {
                float pl = emitter_pdf(c, inst, prim, t, dir, s.ng);
                w = tnd_mis_power(pdf_prev, pl);
            }
            for (int k = 0; k < 3; k++)
                L_out[k] += beta[k] * w * s.emission[k];
        }
        if (s.kind != TND_KIND_OPAQUE) {
            if (++specular > TND_MAX_SPECULAR_DEPTH)
                return;
            float f[3];
            uint32_t ev;
            bool enter;
            v3 wi = specular_vertex(&s, dir, rnd(key, b, TND_DIM_SPLIT), f, &ev, &enter);
            if (ev == TND_EVENT_REFRACT) { /* into the volume, or out of it */
                inside = enter;
                memcpy(sigma, s.sigma, sizeof sigma);
            }
            for (int k = 0; k < 3; k++)
                beta[k] *= f[k];
            org = femb_offset_ray(s.p, dot(wi, s.ng) >= 0 ? s.ng : mul(s.ng, -1.0f));
            dir = wi;
            pdf_prev = 0.0f; /* a delta lobe: an emitter seen through it gets the full weight */
            continue;
        }
        uint32_t nb = b - specular; /* bounces that count */
        lobe_info L;
        lobes(&s, &L);
        float d[3], sp[3];
        direct_light(c, key, b, &s, &L, d, sp);
        for (int k = 0; k < 3; k++)
            L_out[k] += beta[k] * (d[k] * s.base[k] * (1.0f - s.metallic) + sp[k]);
        if (nb >= max_bounce)
            return;
        v3 wi;
        float w[3], pdf;
        bool spec;
        if (!sample_brdf(&s, &L, key, b, false, &wi, w, &pdf, &spec))
            return;
        for (int k = 0; k < 3; k++)
            beta[k] *= w[k];
        if (nb + 1 >= rr_start) {
            float q = fmn(fmx(fmx(beta[0], fmx(beta[1], beta[2])), 0.05f), 1.0f);
            if (rnd(key, b, TND_DIM_RR) >= q)
                return;
            for (int k = 0; k < 3; k++)
                beta[k] /= q;
        }
        org = femb_offset_ray(s.p, s.ng);
        dir = wi;
        pdf_prev = pdf;
    }
}

/* ---- projection ----------------------------------------------------------------------------- */
/* Pixel position of world point p (or of direction p when `direction`) for a camera. */
static bool project(const tnd_camera_state *cam, const float *cam_pos, const double p[3],
                    bool direction, uint32_t w, uint32_t h, double out[2])
{
    double d[3];
    for (int k = 0; k < 3; k++)
        d[k] = direction ? p[k] : p[k] - cam_pos[k];
    const float *V = cam->view, *P = cam->proj;
    double v[3];
    for (int r = 0; r < 3; r++)
        v[r] = V[r] * d[0] + V[4 + r] * d[1] + V[8 + r] * d[2];
    double clip[4];
    for (int r = 0; r < 4; r++)
        clip[r] = P[r] * v[0] + P[4 + r] * v[1] + P[8 + r] * v[2] + (direction ? 0.0 : P[12 + r]);
    if (!(fabs(clip[3]) > 1e-30))
        return false;
    out[0] = (clip[0] / clip[3] * 0.5 + 0.5) * w;
    out[1] = (clip[1] / clip[3] * 0.5 + 0.5) * h;
    return isfinite(out[0]) && isfinite(out[1]);
}

/* ---- primary pass ---------------------------------------------------------------------------- */
/* Primary ray direction through pixel position (px, py), from the inverses computed once per
 * frame (the same arithmetic as tnd_camera_ray: unproject in view space, then rotate). */
static void camera_dir(const femb_context *c, float px, float py, float out[3])
{
    float ndc[3] = {2.0f * px / (float)c->width - 1.0f, 2.0f * py / (float)c->height - 1.0f, 0.5f};
    float pv[3], d[3];
    tnd_mat4_point(c->inv_proj, ndc, true, pv);
    tnd_mat4_dir(c->inv_view, pv, d);
    double n = sqrt((double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2]);
    for (int i = 0; i < 3; i++)
        out[i] = n > 0 ? (float)(d[i] / n) : 0.0f;
}

static v3 surface_position(const femb_context *c, uint32_t inst, uint32_t prim, float u, float v)
{
    const tnd_scene *sc = c->scene;
    const tnd_mesh *m = &sc->meshes[sc->instances[inst].mesh];
    const uint32_t *ix = sc->indices + m->first_index + 3 * prim;
    const float *X = c->cur->instance_xform + 12 * inst;
    float o[3];
    for (int k = 0; k < 3; k++)
        o[k] = (1.0f - u - v) * sc->positions[3 * (size_t)(m->first_vertex + ix[0]) + k] +
               u * sc->positions[3 * (size_t)(m->first_vertex + ix[1]) + k] +
               v * sc->positions[3 * (size_t)(m->first_vertex + ix[2]) + k];
    return (v3){X[0] * o[0] + X[1] * o[1] + X[2] * o[2] + X[3],
                X[4] * o[0] + X[5] * o[1] + X[6] * o[2] + X[7],
                X[8] * o[0] + X[9] * o[1] + X[10] * o[2] + X[11]};
}

/* Reconstruct the surface of a visibility-buffer entry as seen from the camera. */
static void surface_from_vis(const femb_context *c, uint32_t inst, uint32_t prim, float u,
                             float v, femb_surface *s, float *depth)
{
    v3 p = surface_position(c, inst, prim, u, v);
    v3 cam = {c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]};
    v3 d = sub(p, cam);
    *depth = sqrtf(dot(d, d));
    femb_surface_eval(c, inst, prim, u, v, norm(d), *depth * c->pixel_spread, s);
}

/* The real-time reflect/refract chain of pixel position (px, py): from the camera through up to
 * TND_REFLECT_DEPTH specular vertices (mirror: reflect, x Schlick; glass: refract unless total
 * internal reflection, x (1 - F); Beer-Lambert inside) to the surface the G-buffer shows. */
typedef struct chain_result {
    bool hit;
    uint32_t inst, prim, vertices; /* vertices: specular vertices followed */
    uint32_t path;                 /* TND_PATH_* (the contract's path flags) */
    float u, v, length;            /* length: from the camera along the whole chain */
    float thr[3];
    v3 dir, dir0;                  /* the last segment's direction, the camera ray's */
} chain_result;

static void specular_chain(const femb_context *c, uint32_t x, uint32_t y, bool follow,
                           chain_result *r)
{
    float px = (float)x + 0.5f + c->jitter[0], py = (float)y + 0.5f + c->jitter[1];
    uint32_t field = (x + y) & 1u;
    float dd[3];
    camera_dir(c, px, py, dd);
    v3 org = {c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]}, dir = {dd[0], dd[1], dd[2]};
    float sigma[3] = {0, 0, 0};
    bool inside = false;
    memset(r, 0, sizeof *r);
    r->thr[0] = r->thr[1] = r->thr[2] = 1.0f;
    r->dir0 = dir;
    for (;;) {
        float t;
        r->dir = dir;
        if (!femb_intersect(c, org, dir, 1e30f, &r->inst, &r->prim, &r->u, &r->v, &t)) {
            r->hit = false;
            return;
        }
        r->hit = true;
        r->length += t;
        if (inside)
            for (int k = 0; k < 3; k++)
                r->thr[k] *= expf(-sigma[k] * t);
        if (!follow || r->vertices >= c->reflect_depth)
            return;
        const tnd_scene *sc = c->scene;
        const tnd_material *m =
            &sc->materials[sc->meshes[sc->instances[r->inst].mesh].material];
        if (m->kind == TND_MAT_OPAQUE)
            return;
        femb_surface s;
        femb_surface_eval(c, r->inst, r->prim, r->u, r->v, dir, r->length * c->pixel_spread, &s);
        float cos_i = fmx(-dot(s.ns, dir), 1e-6f), f[3];
        v3 wi;
        if (s.kind == TND_KIND_MIRROR) { /* reflect about the shading normal, x Schlick */
            uint32_t ev;
            bool enter;
            wi = specular_direction(&s, s.ns, dir, 0.0f, f, &ev, &enter);
            r->path |= TND_PATH_MIRROR;
        } else {
            bool refl, split;
            f[0] = f[1] = f[2] = tnd_chain_dielectric(s.kind, s.front, cos_i, s.ior,
                                                      !(r->path & TND_PATH_SPLIT), field, &refl,
                                                      &split);
            if (split)
                r->path |= TND_PATH_SPLIT | (field ? TND_PATH_REFRACT : 0u);
            if (!refl)
                r->path |= TND_PATH_GLASS;
            uint32_t ev = refl ? TND_EVENT_REFLECT
                               : (s.kind == TND_KIND_THIN_GLASS ? TND_EVENT_TRANSMIT : TND_EVENT_REFRACT);
            float uu = ev == TND_EVENT_REFLECT ? 0.0f : 0.99999994f;
            float f2[3];
            bool enter;
            uint32_t ev2;
            /* the direction as the path tracer computes it (the same geometric-normal rule) */
            wi = specular_vertex(&s, dir, uu, f2, &ev2, &enter);
            if (ev2 == TND_EVENT_REFRACT) {
                inside = enter;
                memcpy(sigma, s.sigma, sizeof sigma);
            }
        }
        for (int k = 0; k < 3; k++)
            r->thr[k] *= f[k];
        r->vertices++;
        org = femb_offset_ray(s.p, dot(wi, s.ng) >= 0 ? s.ng : mul(s.ng, -1.0f));
        dir = wi;
    }
}

typedef struct primary_job {
    tnd_frame *f;
} primary_job;

static void primary_tile(femb_context *c, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                         void *user)
{
    tnd_frame *f = ((primary_job *)user)->f;
    const tnd_scene *sc = c->scene;
    uint32_t W = c->width, H = c->height;
    tnd_camera_state cam = c->cur->camera;
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = x0; x < x1; x++) {
            size_t q = (size_t)y * W + x;
            chain_result ch;
            specular_chain(c, x, y, c->specular, &ch);
            tnd_frame_u(f, TND_CT_PATH)[q] = ch.path;
            float dd[3] = {ch.dir0.x, ch.dir0.y, ch.dir0.z};
            uint32_t inst = ch.inst, prim = ch.prim;
            float u = ch.u, v = ch.v;
            float *alb = tnd_frame_f(f, TND_CT_ALBEDO) + 3 * q, *n = tnd_frame_f(f, TND_CT_NORMAL) + 3 * q;
            float *gn = tnd_frame_f(f, TND_CT_GEO_NORMAL) + 3 * q;
            float *pos = tnd_frame_f(f, TND_CT_POSITION) + 3 * q, *depth = tnd_frame_f(f, TND_CT_DEPTH) + q;
            float *mo = tnd_frame_f(f, TND_CT_MOTION) + 3 * q;
            float *em = tnd_frame_f(f, TND_CT_EMISSION) + 3 * q;
            uint32_t *vis = tnd_frame_u(f, TND_CT_VIS_ID) + 2 * q;
            float *bary = tnd_frame_f(f, TND_CT_VIS_BARY) + 2 * q;
            float *thr = tnd_frame_f(f, TND_CT_THROUGHPUT) + 3 * q;
            uint32_t *rng = tnd_frame_u(f, TND_CT_RNG) + 2 * q;
            rng[0] = c->frame;
            rng[1] = (uint32_t)q;
            memcpy(thr, ch.thr, 3 * sizeof(float));
            double cur_px[2], prev_px[2];
            if (!ch.hit) {
                for (int k = 0; k < 3; k++) {
                    alb[k] = n[k] = gn[k] = pos[k] = 0.0f;
                    em[k] = sc->sky[k] * ch.thr[k];
                }
                n[2] = gn[2] = 0.0f;
                *depth = (float)TND_DEPTH_MISS;
                vis[0] = vis[1] = TND_VIS_NONE;
                bary[0] = bary[1] = 0.0f;
                tnd_frame_f(f, TND_CT_ROUGHNESS)[q] = 1.0f;
                tnd_frame_f(f, TND_CT_METALLIC)[q] = 0.0f;
                double dir_d[3] = {dd[0], dd[1], dd[2]};
                mo[0] = mo[1] = mo[2] = 0.0f;
                if (project(&cam, c->cam_pos, dir_d, true, W, H, cur_px) &&
                    project(&c->prev->camera, c->prev_cam_pos, dir_d, true, W, H, prev_px)) {
                    mo[0] = (float)(prev_px[0] - cur_px[0]);
                    mo[1] = (float)(prev_px[1] - cur_px[1]);
                }
                continue;
            }
            femb_surface s;
            float dist;
            if (ch.vertices == 0) {
                surface_from_vis(c, inst, prim, u, v, &s, &dist);
            } else { /* seen in a mirror or through glass: the surface at the chain's end */
                dist = ch.length;
                femb_surface_eval(c, inst, prim, u, v, ch.dir, dist * c->pixel_spread, &s);
            }
            for (int k = 0; k < 3; k++) {
                alb[k] = s.base[k];
                em[k] = s.emission[k] * ch.thr[k];
            }
            n[0] = s.ns.x, n[1] = s.ns.y, n[2] = s.ns.z;
            gn[0] = s.ng.x, gn[1] = s.ng.y, gn[2] = s.ng.z;
            pos[0] = s.p.x, pos[1] = s.p.y, pos[2] = s.p.z;
            *depth = dist;
            vis[0] = inst;
            vis[1] = prim;
            bary[0] = u;
            bary[1] = v;
            tnd_frame_f(f, TND_CT_ROUGHNESS)[q] = s.roughness;
            tnd_frame_f(f, TND_CT_METALLIC)[q] = s.metallic;
            mo[0] = mo[1] = mo[2] = 0.0f;
            if (ch.vertices > 0) {
                /* the virtual point (what a planar mirror shows: along the camera ray at the
                 * chain's length), the mirror and the glass assumed still */
                double vp[3];
                for (int r = 0; r < 3; r++)
                    vp[r] = c->cam_pos[r] + (double)dd[r] * ch.length;
                if (project(&cam, c->cam_pos, vp, false, W, H, cur_px) &&
                    project(&c->prev->camera, c->prev_cam_pos, vp, false, W, H, prev_px)) {
                    mo[0] = (float)(prev_px[0] - cur_px[0]);
                    mo[1] = (float)(prev_px[1] - cur_px[1]);
                }
                double dp = 0;
                for (int r = 0; r < 3; r++)
                    dp += (vp[r] - c->prev_cam_pos[r]) * (vp[r] - c->prev_cam_pos[r]);
                mo[2] = (float)(sqrt(dp) - ch.length);
                continue;
            }
            /* motion: the same object-space point through this and the previous frame's
             * instance transform and camera (both unjittered) */
            const float *PX = c->prev->instance_xform + 12 * inst, *X = c->cur->instance_xform + 12 * inst;
            double pw[3], cw[3];
            for (int r = 0; r < 3; r++) {
                pw[r] = (double)PX[4 * r] * s.obj[0] + (double)PX[4 * r + 1] * s.obj[1] +
                        (double)PX[4 * r + 2] * s.obj[2] + PX[4 * r + 3];
                cw[r] = (double)X[4 * r] * s.obj[0] + (double)X[4 * r + 1] * s.obj[1] +
                        (double)X[4 * r + 2] * s.obj[2] + X[4 * r + 3];
            }
            if (project(&cam, c->cam_pos, cw, false, W, H, cur_px) &&
                project(&c->prev->camera, c->prev_cam_pos, pw, false, W, H, prev_px)) {
                mo[0] = (float)(prev_px[0] - cur_px[0]);
                mo[1] = (float)(prev_px[1] - cur_px[1]);
            }
            double dp = 0, dc = 0;
            for (int r = 0; r < 3; r++) {
                dp += (pw[r] - c->prev_cam_pos[r]) * (pw[r] - c->prev_cam_pos[r]);
                dc += (cw[r] - c->cam_pos[r]) * (cw[r] - c->cam_pos[r]);
            }
            mo[2] = (float)(sqrt(dp) - sqrt(dc));
        }
}

tnd_result femb_trace_primary(femb_context *c, tnd_frame *f)
{
    if (f->width != c->width || f->height != c->height)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "embree: frame %ux%u, expected %ux%u", f->width,
                        f->height, c->width, c->height);
    primary_job j = {f};
    femb_parallel_tiles(c, primary_tile, &j);
    const tnd_ct gbuf[] = {TND_CT_ALBEDO,    TND_CT_NORMAL,   TND_CT_GEO_NORMAL, TND_CT_POSITION,
                           TND_CT_DEPTH,     TND_CT_MOTION,   TND_CT_ROUGHNESS,  TND_CT_METALLIC,
                           TND_CT_EMISSION,  TND_CT_VIS_ID,   TND_CT_VIS_BARY,   TND_CT_THROUGHPUT,
                           TND_CT_RNG,       TND_CT_PATH};
    for (size_t i = 0; i < sizeof gbuf / sizeof *gbuf; i++)
        f->present[gbuf[i]] = true;
    f->has_camera = true;
    memcpy(f->camera.view, c->cur->camera.view, sizeof f->camera.view);
    memcpy(f->camera.proj, c->cur->camera.proj, sizeof f->camera.proj);
    memcpy(f->camera.prev_view, c->prev->camera.view, sizeof f->camera.prev_view);
    memcpy(f->camera.prev_proj, c->prev->camera.proj, sizeof f->camera.prev_proj);
    memcpy(f->camera.jitter, c->jitter, sizeof c->jitter);
    f->camera.frame_index = c->frame;
    f->precision = TND_PRECISION_F32;
    return TND_OK;
}

/* ---- shading pass ---------------------------------------------------------------------------- */
/* The shading pass reads the surface from the G-buffer, as the GPU passes do (the primary pass
 * and the gradient patches wrote it), plus the material's specular factor and emission. */
static void surface_from_gbuffer(const femb_context *c, const tnd_frame *f, size_t q,
                                 femb_surface *s, float *depth)
{
    const tnd_scene *sc = c->scene;
    const float *p = tnd_frame_f(f, TND_CT_POSITION) + 3 * q;
    const float *ns = tnd_frame_f(f, TND_CT_NORMAL) + 3 * q;
    const float *ng = tnd_frame_f(f, TND_CT_GEO_NORMAL) + 3 * q;
    uint32_t inst = tnd_frame_u(f, TND_CT_VIS_ID)[2 * q];
    const tnd_material *m = &sc->materials[sc->meshes[sc->instances[inst].mesh].material];
    s->p = (v3){p[0], p[1], p[2]};
    s->ns = (v3){ns[0], ns[1], ns[2]};
    s->ng = (v3){ng[0], ng[1], ng[2]};
    v3 d = sub((v3){c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]}, s->p);
    *depth = sqrtf(dot(d, d));
    s->wo = *depth > 0 ? mul(d, 1.0f / *depth) : s->ns;
    memcpy(s->base, tnd_frame_f(f, TND_CT_ALBEDO) + 3 * q, 3 * sizeof(float));
    memcpy(s->emission, tnd_frame_f(f, TND_CT_EMISSION) + 3 * q, 3 * sizeof(float));
    s->roughness = tnd_frame_f(f, TND_CT_ROUGHNESS)[q];
    s->metallic = tnd_frame_f(f, TND_CT_METALLIC)[q];
    s->specular = m->specular;
    s->instance = inst;
    s->primitive = tnd_frame_u(f, TND_CT_VIS_ID)[2 * q + 1];
}

/* Shade pixel q of the frame (its surface in the G-buffer) with random key `key`. */
static void shade_pixel(const femb_context *c, const femb_params *p, rng_key key,
                        const tnd_frame *f, size_t q, float hf[3], float sh[4], float cocg[2],
                        float spec[3], float radiance[3])
{
    femb_surface s;
    float depth;
    surface_from_gbuffer(c, f, q, &s, &depth);
    if (c->specular && tnd_frame_u(f, TND_CT_PATH)[q] != 0u) {
        /* a surface seen in a mirror or through glass (the path flags say the primary chain met
         * one) is lit towards the chain's last segment, not towards the camera: the primary
         * pass's chain again (same jitter, same geometry) */
        chain_result ch;
        specular_chain(c, (uint32_t)(q % c->width), (uint32_t)(q / c->width), true, &ch);
        if (ch.hit && ch.vertices > 0 && ch.inst == s.instance && ch.prim == s.primitive) {
            s.wo = mul(ch.dir, -1.0f);
            depth = ch.length;
        }
    }
    const float *thr = tnd_frame_f(f, TND_CT_THROUGHPUT) + 3 * q;
    lobe_info L;
    lobes(&s, &L);
    float demod[3];
    for (int k = 0; k < 3; k++)
        demod[k] = fmx(0.01f, 0.04f * (1.0f - s.metallic) + s.base[k] * s.metallic);
    float d[3], sp[3];
    direct_light(c, key, 0, &s, &L, d, sp);
    for (int k = 0; k < 3; k++) {
        hf[k] = d[k];
        spec[k] = sp[k] / demod[k];
        radiance[k] = s.emission[k] + thr[k] * (d[k] * s.base[k] * (1.0f - s.metallic) + sp[k]);
    }
    sh[0] = sh[1] = sh[2] = sh[3] = cocg[0] = cocg[1] = 0.0f;
    if (p->bounces == 0)
        return;
    v3 wi;
    float w[3], pdf;
    bool is_spec;
    if (!sample_brdf(&s, &L, key, 0, true, &wi, w, &pdf, &is_spec))
        return;
    float Li[3];
    trace_path(c, key, femb_offset_ray(s.p, s.ng), wi, 1, p->bounces, 2, pdf,
               depth * c->pixel_spread, Li);
    float contrib[3];
    for (int k = 0; k < 3; k++) {
        contrib[k] = w[k] * Li[k];
        if (!isfinite(contrib[k]) || contrib[k] < 0)
            contrib[k] = 0.0f; /* a broken sample must not poison the history */
    }
    if (is_spec) {
        for (int k = 0; k < 3; k++) {
            spec[k] += contrib[k] / demod[k];
            radiance[k] += thr[k] * contrib[k];
        }
        return;
    }
    for (int k = 0; k < 3; k++)
        radiance[k] += thr[k] * contrib[k] * s.base[k] * (1.0f - s.metallic);
    /* YCoCg, then the SH lobe scaled so that its value at the shading normal is exactly Y */
    float co = contrib[0] - contrib[2], t = contrib[2] + 0.5f * co, cg = contrib[1] - t;
    float Y = t + 0.5f * cg;
    float k = 4.0f * (float)TND_PI / (1.0f + 2.0f * fmx(dot(wi, s.ns), 0.0f));
    sh[0] = k * Y * SH_C1 * wi.x;
    sh[1] = k * Y * SH_C1 * wi.y;
    sh[2] = k * Y * SH_C1 * wi.z;
    sh[3] = k * Y * SH_C0;
    cocg[0] = k * co;
    cocg[1] = k * cg;
}

typedef struct shade_job {
    const femb_params *p;
    tnd_frame *f;
    float *radiance;
    const femb_gradient_sample *grad;
    uint32_t grad_count;
} shade_job;

static void write_shading(tnd_frame *f, size_t q, const float hf[3], const float sh[4],
                          const float cocg[2], const float spec[3])
{
    memcpy(tnd_frame_f(f, TND_CT_HF) + 3 * q, hf, 3 * sizeof(float));
    memcpy(tnd_frame_f(f, TND_CT_LF_SH) + 4 * q, sh, 4 * sizeof(float));
    memcpy(tnd_frame_f(f, TND_CT_LF_COCG) + 2 * q, cocg, 2 * sizeof(float));
    memcpy(tnd_frame_f(f, TND_CT_SPEC) + 3 * q, spec, 3 * sizeof(float));
}

static void shade_tile(femb_context *c, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                       void *user)
{
    shade_job *j = user;
    tnd_frame *f = j->f;
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = x0; x < x1; x++) {
            size_t q = (size_t)y * c->width + x;
            const uint32_t *vis = tnd_frame_u(f, TND_CT_VIS_ID) + 2 * q;
            const uint32_t *rng = tnd_frame_u(f, TND_CT_RNG) + 2 * q;
            float hf[3] = {0}, sh[4] = {0}, cocg[2] = {0}, spec[3] = {0}, rad[3];
            if (vis[0] == TND_VIS_NONE) {
                memcpy(rad, tnd_frame_f(f, TND_CT_EMISSION) + 3 * q, sizeof rad);
            } else {
                rng_key key = {rng[1], rng[0]};
                shade_pixel(c, j->p, key, f, q, hf, sh, cocg, spec, rad);
            }
            write_shading(f, q, hf, sh, cocg, spec);
            if (j->radiance)
                memcpy(j->radiance + 3 * q, rad, sizeof rad);
        }
}

static void mark_shading(tnd_frame *f)
{
    f->present[TND_CT_HF] = f->present[TND_CT_LF_SH] = true;
    f->present[TND_CT_LF_COCG] = f->present[TND_CT_SPEC] = true;
}

tnd_result femb_shade(femb_context *c, const femb_params *p, tnd_frame *f, float *radiance)
{
    if (f->width != c->width || f->height != c->height || !f->present[TND_CT_VIS_ID])
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "embree: shade needs the primary pass's frame");
    femb_params def = {.bounces = 1};
    shade_job j = {p ? p : &def, f, radiance, NULL, 0};
    femb_parallel_tiles(c, shade_tile, &j);
    mark_shading(f);
    return TND_OK;
}

_Static_assert(sizeof(femb_gradient_sample) == 7 * sizeof(uint32_t), "7 words per sample");

void femb_gradient_unpack(const uint32_t *w, uint32_t n, femb_gradient_sample *g)
{
    for (uint32_t k = 0; k < n; k++, w += 7) {
        g[k] = (femb_gradient_sample){w[0], w[1], w[2], w[3], w[4], 0.0f, 0.0f};
        memcpy(&g[k].u, &w[5], sizeof g[k].u);
        memcpy(&g[k].v, &w[6], sizeof g[k].v);
    }
}

tnd_result femb_shade_gradients(femb_context *c, const femb_params *p,
                                const femb_gradient_sample *g, uint32_t n, tnd_frame *f)
{
    femb_params def = {.bounces = 1};
    if (!p)
        p = &def;
    for (uint32_t i = 0; i < n; i++) {
        if (g[i].pixel >= c->width * c->height || g[i].instance >= c->scene->instance_count ||
            g[i].primitive >=
                c->scene->meshes[c->scene->instances[g[i].instance].mesh].triangle_count)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                            "embree: gradient sample %u: pixel %u, instance %u, primitive %u out "
                            "of range",
                            i, g[i].pixel, g[i].instance, g[i].primitive);
    }
    for (uint32_t i = 0; i < n; i++) {
        size_t q = g[i].pixel;
        femb_surface s;
        float depth;
        surface_from_vis(c, g[i].instance, g[i].primitive, g[i].u, g[i].v, &s, &depth);
        /* patch the G-buffer with the re-evaluated surface */
        tnd_frame_u(f, TND_CT_VIS_ID)[2 * q] = g[i].instance;
        tnd_frame_u(f, TND_CT_VIS_ID)[2 * q + 1] = g[i].primitive;
        tnd_frame_f(f, TND_CT_VIS_BARY)[2 * q] = g[i].u;
        tnd_frame_f(f, TND_CT_VIS_BARY)[2 * q + 1] = g[i].v;
        tnd_frame_u(f, TND_CT_RNG)[2 * q] = g[i].rng_frame;
        tnd_frame_u(f, TND_CT_RNG)[2 * q + 1] = g[i].rng_pixel;
        memcpy(tnd_frame_f(f, TND_CT_ALBEDO) + 3 * q, s.base, 3 * sizeof(float));
        float n3[3] = {s.ns.x, s.ns.y, s.ns.z}, g3[3] = {s.ng.x, s.ng.y, s.ng.z};
        float p3[3] = {s.p.x, s.p.y, s.p.z};
        memcpy(tnd_frame_f(f, TND_CT_NORMAL) + 3 * q, n3, sizeof n3);
        memcpy(tnd_frame_f(f, TND_CT_GEO_NORMAL) + 3 * q, g3, sizeof g3);
        memcpy(tnd_frame_f(f, TND_CT_POSITION) + 3 * q, p3, sizeof p3);
        tnd_frame_f(f, TND_CT_ROUGHNESS)[q] = s.roughness;
        tnd_frame_f(f, TND_CT_METALLIC)[q] = s.metallic;
        float hf[3], sh[4], cocg[2], spec[3], rad[3];
        rng_key key = {g[i].rng_pixel, g[i].rng_frame};
        memcpy(tnd_frame_f(f, TND_CT_EMISSION) + 3 * q, s.emission, 3 * sizeof(float));
        shade_pixel(c, p, key, f, q, hf, sh, cocg, spec, rad);
        write_shading(f, q, hf, sh, cocg, spec);
    }
    mark_shading(f);
    return TND_OK;
}

/* ---- reference ------------------------------------------------------------------------------- */
typedef struct ref_job {
    uint32_t sample;
    double *sum, *sum2; /* rgb and luminance^2 per pixel */
} ref_job;

static void reference_tile(femb_context *c, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                           void *user)
{
    ref_job *j = user;
    uint32_t W = c->width;
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = x0; x < x1; x++) {
            size_t q = (size_t)y * W + x;
            rng_key key = {(uint32_t)q, c->frame * 4096u + j->sample};
            float jx = tnd_rand(key.pixel, key.frame, TND_DIM_JITTER_X);
            float jy = tnd_rand(key.pixel, key.frame, TND_DIM_JITTER_Y);
            float d[3];
            camera_dir(c, (float)x + jx, (float)y + jy, d);
            v3 org = {c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]};
            float L[3];
            trace_path(c, key, org, (v3){d[0], d[1], d[2]}, 0, 64, 3, 0.0f, 0.0f, L);
            double lum = 0;
            for (int k = 0; k < 3; k++) {
                j->sum[3 * q + k] += L[k];
            }
            lum = tnd_luminance(L[0], L[1], L[2]);
            j->sum2[q] += lum * lum;
        }
}

tnd_result femb_reference(femb_context *c, uint32_t spp, float *rgb, double *rel_error,
                          void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    size_t n = (size_t)c->width * c->height;
    if (spp == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "embree: reference with 0 samples per pixel");
    ref_job j = {0, calloc(3 * n, sizeof(double)), calloc(n, sizeof(double))};
    if (!j.sum || !j.sum2) {
        free(j.sum);
        free(j.sum2);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "embree: out of memory");
    }
    for (uint32_t s = 0; s < spp; s++) {
        j.sample = s;
        femb_parallel_tiles(c, reference_tile, &j);
        if (progress)
            progress(s + 1, spp, user);
    }
    double err = 0;
    uint32_t counted = 0;
    for (size_t q = 0; q < n; q++) {
        double m[3];
        for (int k = 0; k < 3; k++) {
            m[k] = j.sum[3 * q + k] / spp;
            rgb[3 * q + k] = (float)m[k];
        }
        double ml = tnd_luminance((float)m[0], (float)m[1], (float)m[2]);
        double var = spp > 1 ? (j.sum2[q] / spp - ml * ml) * spp / (spp - 1) : 0;
        if (ml > 1e-6 && spp > 1) {
            err += sqrt(fmax(var, 0) / spp) / ml;
            counted++;
        }
    }
    if (rel_error)
        *rel_error = counted ? err / counted : 0;
    free(j.sum);
    free(j.sum2);
    return TND_OK;
}

