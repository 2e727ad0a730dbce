/* frontend_embree/femb_restir.c: ReSTIR DI at the primary surface (`--lights restir`).
 *
 * The direct light of each directly seen opaque surface (perceptual roughness at least
 * TND_RESTIR_MIN_ROUGHNESS; the others keep next-event estimation with MIS) is estimated by
 * resampled importance sampling with reuse (Bitterli et al. 2020), in three steps per frame:
 * 1. candidates: TND_RESTIR_CANDIDATES light samples drawn as next-event estimation draws them
 *    (the light tree's pick at the point, or the power table), each weighed by its target (the
 *    luminance of its unshadowed contribution: BRDF x cos x emitted light x the geometric term)
 *    over its source density; one kept in a reservoir by weighted reservoir sampling;
 * 2. temporal: merged with the previous frame's final reservoir at the pixel the motion vector
 *    points to, where that surface is like this one (normals, distance), the previous one's count
 *    capped at TND_RESTIR_HISTORY times the candidates;
 * 3. spatial: merged with TND_RESTIR_NEIGHBOURS neighbours' step-2 reservoirs in a disc, where
 *    their surfaces are alike.
 * Each merge weighs input i's sample y by the generalized balance heuristic m_i(y) = M_i p_i(y) /
 * sum_j M_j p_j(y), each p_j the target at input j's own surface (the previous frame's surface
 * for the temporal input), so the weights of any y sum to one over the inputs and the result's
 * contribution weight W = sum_i m_i p(y_i) W_i / p(y) stays unbiased (Lin et al. 2022); the
 * shading pass then casts one shadow ray to the final sample: f(y) V(y) W. The reservoirs keep no
 * visibility (a biased shortcut of the paper, left out), so the estimator's expectation is the
 * plain one's and the matched reference of a run with reservoirs is the same.
 * Where the primary vertex's light comes from a reservoir, the BRDF sample that continues the
 * path gives the emitters of the list zero weight (FEMB_PDF_RESERVOIR): the reservoir took their
 * whole share.
 * A light that moved between frames is evaluated where it is now for the previous surface's
 * target too (a small bias under moving emitters, none where they stand still).
 * Entry points: femb_restir_frame, femb_restir_lookup, femb_restir_shade, femb_restir_free. */
#include "frontend_embree/femb_internal.h"
#include "shaders/brdf.h"
#include "shaders/restir.h"
#include "shaders/sampling.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A light sample resolved against the current light list: the point (or direction: `far`), the
 * emitter's normal and sidedness, the emitted light, the spot's cone; `ok` false where the sample
 * names no light or the environment gives it no direction. */
typedef struct rs_point {
    v3 x, n, axis;
    float L[3], cos_in, cos_out, area, env_pdf;
    uint32_t kind;
    bool two_sided, far, ok;
} rs_point;

static rs_point resolve(const femb_context *c, uint32_t light, float u, float v)
{
    rs_point y = {0};
    if (light >= c->lights.count)
        return y;
    const tnd_light_gpu *l = &c->lights.lights[light];
    y.kind = (uint32_t)l->p0.w;
    v3 p0 = {l->p0.x, l->p0.y, l->p0.z}, p1 = {l->p1.x, l->p1.y, l->p1.z};
    v3 p2 = {l->p2.x, l->p2.y, l->p2.z};
    y.L[0] = l->radiance.x, y.L[1] = l->radiance.y, y.L[2] = l->radiance.z;
    y.ok = true;
    switch (y.kind) {
    case TND_LIGHT_KIND_TRIANGLE: { /* as next-event estimation places it */
        float su = sqrtf(u);
        y.x = add(add(mul(p0, 1.0f - su), mul(p1, su * (1.0f - v))), mul(p2, su * v));
        y.n = norm(cross(sub(p1, p0), sub(p2, p0)));
        y.two_sided = l->p1.w != 0.0f;
        y.area = l->cdf.w;
        y.ok = y.area > 0.0f;
        break;
    }
    case TND_LIGHT_KIND_POINT:
        y.x = p0;
        break;
    case TND_LIGHT_KIND_SPOT:
        y.x = p0, y.axis = p1, y.cos_in = l->p2.x, y.cos_out = l->p2.y;
        break;
    case TND_LIGHT_KIND_DIRECTIONAL:
        y.x = mul(p1, -1.0f), y.far = true;
        break;
    default: { /* the environment map */
        float d[3], rgb[3];
        y.env_pdf = tnd_env_sample(&c->scene->env, u, v, d, rgb);
        y.x = (v3){d[0], d[1], d[2]}, y.far = true;
        memcpy(y.L, rgb, sizeof rgb);
        y.ok = y.env_pdf > 0.0f;
        break;
    }
    }
    return y;
}

/* The unshadowed contribution of y at s, measured on the emitter (area, direction or point):
 * diffuse (demodulated: without albedo and 1 - metallic) and specular, as next-event estimation's
 * BRDF (femb_estimator.c: brdf_lane); the direction and distance to it. False where it adds
 * nothing (behind the surface or the emitter). */
static bool contribution(const rs_point *y, const femb_rsurf *s, float diff[3], float spec[3],
                         v3 *wi, float *dist)
{
    v3 p = {s->p[0], s->p[1], s->p[2]};
    float J = 1.0f;
    if (y->far) {
        *wi = y->x, *dist = 1e30f;
    } else {
        v3 d = sub(y->x, p);
        float d2 = dot(d, d);
        if (!(d2 > 0.0f))
            return false;
        *dist = sqrtf(d2);
        *wi = mul(d, 1.0f / *dist);
        J = 1.0f / d2;
        if (y->kind == TND_LIGHT_KIND_TRIANGLE) {
            float cfront = -dot(y->n, *wi);
            float cosl = y->two_sided ? fabsf(cfront) : cfront;
            if (!(cosl > 0.0f))
                return false;
            J *= cosl;
        } else if (y->kind == TND_LIGHT_KIND_SPOT) {
            float t = (-dot(*wi, y->axis) - y->cos_out) / fmx(y->cos_in - y->cos_out, 1e-6f);
            t = fmn(fmx(t, 0.0f), 1.0f);
            J *= t * t;
        }
    }
    v3 ns = {s->ns[0], s->ns[1], s->ns[2]}, ng = {s->ng[0], s->ng[1], s->ng[2]};
    v3 wo = {s->wo[0], s->wo[1], s->wo[2]};
    float nl = dot(ns, *wi);
    if (!(nl > 0.0f) || !(dot(ng, *wi) > 0.0f) || !(J > 0.0f))
        return false;
    float nv = fmx(dot(ns, wo), 1e-4f);
    float alpha = fmx(s->roughness * s->roughness, (float)TND_MIN_ALPHA), a2 = alpha * alpha;
    v3 h = norm(add(*wi, wo));
    float nh = fmx(dot(ns, h), 0.0f), vh = fmx(dot(wo, h), 0.0f);
    float g = tnd_ggx_spec_cos(nh, nv, nl, a2);
    for (int k = 0; k < 3; k++) {
        float fnv = tnd_fresnel(s->metallic, s->specular, s->base[k], nv);
        diff[k] = (1.0f - fnv) * nl * (float)TND_INV_PI * y->L[k] * J;
        spec[k] = tnd_fresnel(s->metallic, s->specular, s->base[k], vh) * g * y->L[k] * J;
    }
    return true;
}

/* The target: the luminance of the contribution to the pixel (diffuse remodulated). */
static float target(const rs_point *y, const femb_rsurf *s)
{
    float d[3], sp[3], dist;
    v3 wi;
    if (!y->ok || !contribution(y, s, d, sp, &wi, &dist))
        return 0.0f;
    float m = 1.0f - s->metallic;
    float t = tnd_luminance(d[0] * s->base[0] * m + sp[0], d[1] * s->base[1] * m + sp[1],
                            d[2] * s->base[2] * m + sp[2]);
    return t > 0.0f && t <= 3.0e38f ? t : 0.0f;
}

/* The density, on the emitter's measure, with which next-event estimation's pick at point p and
 * the point's two numbers draw y (light `light` picked with probability pick). */
static float source_pdf(const rs_point *y, float pick)
{
    if (y->kind == TND_LIGHT_KIND_TRIANGLE)
        return pick / y->area;
    if (y->kind >= TND_LIGHT_KIND_POINT && y->kind <= TND_LIGHT_KIND_DIRECTIONAL)
        return pick;
    return pick * y->env_pdf;
}

static inline float rnd(uint32_t pixel, uint32_t frame, uint32_t dim)
{
    return tnd_rand(pixel, frame, TND_SAMPLE_REALTIME, dim);
}

/* ---- the frame's surfaces and reservoirs ---------------------------------------------------- */
void femb_restir_free(femb_restir *rs)
{
    free(rs->prev), free(rs->mid), free(rs->cur), free(rs->sprev), free(rs->scur);
    memset(rs, 0, sizeof *rs);
}

/* The surface of pixel q from the frame's G-buffer as the shading pass reads it (gbuffer_surfaces:
 * the same direction to the eye); false where the pixel does not use reservoirs (no surface, one
 * seen in a mirror or through glass, or one too smooth). */
static bool gather_surface(const femb_context *c, const tnd_frame *f, size_t q, femb_rsurf *s)
{
    const uint32_t *vis = tnd_frame_u(f, TND_CT_VIS_ID);
    memset(s, 0, sizeof *s);
    if (vis[2 * q] == TND_VIS_NONE || vis[2 * q] >= c->scene->instance_count)
        return false;
    if (f->present[TND_CT_PATH] && tnd_frame_u(f, TND_CT_PATH)[q] != 0u)
        return false;
    const float *P = tnd_frame_f(f, TND_CT_POSITION), *NS = tnd_frame_f(f, TND_CT_NORMAL);
    const float *NG = tnd_frame_f(f, TND_CT_GEO_NORMAL), *B = tnd_frame_f(f, TND_CT_ALBEDO);
    v3 pos = {P[3 * q], P[3 * q + 1], P[3 * q + 2]};
    v3 ns = {NS[3 * q], NS[3 * q + 1], NS[3 * q + 2]};
    v3 d = sub((v3){c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]}, pos);
    float depth = sqrtf(dot(d, d));
    v3 wo = depth > 0 ? mul(d, 1.0f / depth) : ns;
    for (int k = 0; k < 3; k++) {
        s->p[k] = P[3 * q + k];
        s->ns[k] = NS[3 * q + k];
        s->ng[k] = NG[3 * q + k];
        s->base[k] = B[3 * q + k];
    }
    s->wo[0] = wo.x, s->wo[1] = wo.y, s->wo[2] = wo.z;
    s->depth = depth;
    s->roughness = tnd_frame_f(f, TND_CT_ROUGHNESS)[q];
    s->metallic = tnd_frame_f(f, TND_CT_METALLIC)[q];
    s->specular = c->inst[vis[2 * q]].specular;
    return s->roughness >= TND_RESTIR_MIN_ROUGHNESS && depth > 0;
}

/* Whether surface b may lend its reservoir to a (normals and distances alike). */
static bool alike(const femb_rsurf *a, const femb_rsurf *b, float b_depth)
{
    float nd = a->ns[0] * b->ns[0] + a->ns[1] * b->ns[1] + a->ns[2] * b->ns[2];
    return nd >= TND_RESTIR_NORMAL_DOT &&
           fabsf(b_depth - a->depth) <= TND_RESTIR_DEPTH_REL * a->depth;
}

/* Merge n reservoirs r[i] (from the domains of surfaces s[i]) into one for surface s[0] by the
 * generalized balance heuristic; u picks the sample. The counts add up, capped at `cap`. */
enum { MAX_INPUTS = 2 + TND_RESTIR_NEIGHBOURS };
static femb_reservoir merge(const femb_context *c, uint32_t n, const femb_reservoir *const *r,
                            const femb_rsurf *const *s, float u, float cap)
{
    float w[MAX_INPUTS], pc[MAX_INPUTS], sum = 0.0f, M = 0.0f;
    for (uint32_t i = 0; i < n; i++) {
        M += r[i]->M;
        w[i] = pc[i] = 0.0f;
        if (!(r[i]->W > 0.0f))
            continue;
        rs_point y = resolve(c, r[i]->light, r[i]->u, r[i]->v);
        if (!y.ok)
            continue;
        pc[i] = target(&y, s[0]);
        if (pc[i] == 0.0f)
            continue;
        float own = 0.0f, all = 0.0f;
        for (uint32_t j = 0; j < n; j++) {
            float pj = j == 0 ? pc[i] : target(&y, s[j]);
            all += r[j]->M * pj;
            own = j == i ? r[j]->M * pj : own;
        }
        w[i] = all > 0.0f ? own / all * pc[i] * r[i]->W : 0.0f;
        sum += w[i];
    }
    femb_reservoir out = {TND_LT_NONE, 0.0f, 0.0f, 0.0f, fmn(M, cap)};
    if (!(sum > 0.0f) || !(sum <= 3.0e38f))
        return out;
    float pick = u * sum, acc = 0.0f;
    for (uint32_t i = 0; i < n; i++) {
        if (w[i] == 0.0f)
            continue;
        acc += w[i];
        if (pick < acc || out.light == TND_LT_NONE) {
            out.light = r[i]->light, out.u = r[i]->u, out.v = r[i]->v;
            out.W = sum / pc[i];
            if (pick < acc)
                break;
        }
    }
    return out;
}

typedef struct rs_job {
    const tnd_frame *f;
    float radius; /* the spatial disc's, in pixels */
} rs_job;

/* Steps 1 and 2 for a tile: the surfaces, the candidates, the temporal merge. */
static void candidates_tile(femb_context *c, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                            void *user)
{
    const rs_job *j = user;
    const tnd_frame *f = j->f;
    femb_restir *rs = &c->rs;
    const uint32_t *rng = tnd_frame_u(f, TND_CT_RNG);
    const float *mot = tnd_frame_f(f, TND_CT_MOTION);
    const float cap = (float)(TND_RESTIR_HISTORY * TND_RESTIR_CANDIDATES);
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = x0; x < x1; x++) {
            size_t q = (size_t)y * c->width + x;
            femb_rsurf *s = &rs->scur[q];
            femb_reservoir *out = &rs->mid[q];
            *out = (femb_reservoir){TND_LT_NONE, 0.0f, 0.0f, 0.0f, 0.0f};
            if (!gather_surface(c, f, q, s))
                continue;
            uint32_t kp = rng[2 * q + 1], kf = rng[2 * q];
            /* 1. candidates by weighted reservoir sampling */
            femb_reservoir r = {TND_LT_NONE, 0.0f, 0.0f, 0.0f, (float)TND_RESTIR_CANDIDATES};
            float sum = 0.0f, p_kept = 0.0f;
            for (uint32_t k = 0; k < TND_RESTIR_CANDIDATES; k++) {
                uint32_t dim = TND_DIM_RESTIR_CANDIDATE + 4u * k;
                float up = rnd(kp, kf, dim), u = rnd(kp, kf, dim + 1), v = rnd(kp, kf, dim + 2);
                uint32_t light;
                float pick;
                if (c->lights.node_count) {
                    light = tnd_lt_sample(c->lights.nodes, s->p[0], s->p[1], s->p[2], up, &pick);
                } else {
                    light = tnd_lights_pick(&c->lights, up);
                    pick = light < c->lights.count ? c->lights.lights[light].radiance.w : 0.0f;
                }
                if (light == TND_LT_NONE || !(pick > 0.0f))
                    continue;
                rs_point yp = resolve(c, light, u, v);
                float src = yp.ok ? source_pdf(&yp, pick) : 0.0f;
                float t = src > 0.0f ? target(&yp, s) : 0.0f;
                float w = t > 0.0f ? t / src : 0.0f;
                if (!(w > 0.0f) || !(w <= 3.0e38f))
                    continue;
                sum += w;
                if (rnd(kp, kf, dim + 3) * sum < w)
                    r.light = light, r.u = u, r.v = v, p_kept = t;
            }
            r.W = p_kept > 0.0f ? sum / ((float)TND_RESTIR_CANDIDATES * p_kept) : 0.0f;
            /* 2. the previous frame's reservoir where the motion vector points, if alike */
            *out = r;
            if (!rs->have_prev)
                continue;
            float px = (float)x + 0.5f + mot[3 * q], py = (float)y + 0.5f + mot[3 * q + 1];
            if (!(px >= 0.0f && py >= 0.0f && px < (float)c->width && py < (float)c->height))
                continue;
            size_t pq = (size_t)(uint32_t)py * c->width + (uint32_t)px;
            femb_reservoir prev = rs->prev[pq];
            const femb_rsurf *ps = &rs->sprev[pq];
            if (!(prev.M > 0.0f) || !alike(s, ps, ps->depth - mot[3 * q + 2]))
                continue;
            prev.M = fmn(prev.M, cap);
            const femb_reservoir *in[2] = {&r, &prev};
            const femb_rsurf *sf[2] = {s, ps};
            *out = merge(c, 2, in, sf, rnd(kp, kf, TND_DIM_RESTIR_TEMPORAL), cap + r.M);
        }
}

/* Step 3 for a tile: the merge with neighbours in a disc. */
static void spatial_tile(femb_context *c, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                         void *user)
{
    const rs_job *j = user;
    femb_restir *rs = &c->rs;
    const uint32_t *rng = tnd_frame_u(j->f, TND_CT_RNG);
    const float cap = (float)(TND_RESTIR_HISTORY * TND_RESTIR_CANDIDATES);
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = x0; x < x1; x++) {
            size_t q = (size_t)y * c->width + x;
            const femb_reservoir *in[MAX_INPUTS] = {&rs->mid[q]};
            const femb_rsurf *sf[MAX_INPUTS] = {&rs->scur[q]};
            if (!(rs->mid[q].M > 0.0f)) {
                rs->cur[q] = rs->mid[q];
                continue;
            }
            uint32_t kp = rng[2 * q + 1], kf = rng[2 * q], n = 1;
            for (uint32_t k = 0; k < TND_RESTIR_NEIGHBOURS; k++) {
                uint32_t dim = TND_DIM_RESTIR_SPATIAL + 2u * k;
                float s_, c_, a = 2.0f * (float)TND_PI * rnd(kp, kf, dim);
                float rad = j->radius * sqrtf(rnd(kp, kf, dim + 1));
                s_ = sinf(a), c_ = cosf(a);
                float nx = (float)x + 0.5f + rad * c_, ny = (float)y + 0.5f + rad * s_;
                if (!(nx >= 0.0f && ny >= 0.0f && nx < (float)c->width && ny < (float)c->height))
                    continue;
                size_t nq = (size_t)(uint32_t)ny * c->width + (uint32_t)nx;
                if (nq == q || !(rs->mid[nq].M > 0.0f) ||
                    !alike(&rs->scur[q], &rs->scur[nq], rs->scur[nq].depth))
                    continue;
                in[n] = &rs->mid[nq], sf[n] = &rs->scur[nq], n++;
            }
            rs->cur[q] = merge(c, n, in, sf, rnd(kp, kf, TND_DIM_RESTIR_SPATIAL_KEEP), cap);
        }
}

tnd_result femb_restir_frame(femb_context *c, const tnd_frame *f)
{
    femb_restir *rs = &c->rs;
    size_t n = (size_t)c->width * c->height;
    if (rs->width != c->width || rs->height != c->height || !rs->cur) {
        femb_restir_free(rs);
        rs->prev = calloc(n, sizeof *rs->prev), rs->mid = calloc(n, sizeof *rs->mid);
        rs->cur = calloc(n, sizeof *rs->cur);
        rs->sprev = calloc(n, sizeof *rs->sprev), rs->scur = calloc(n, sizeof *rs->scur);
        if (!rs->prev || !rs->mid || !rs->cur || !rs->sprev || !rs->scur) {
            femb_restir_free(rs);
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "embree: out of memory (reservoirs)");
        }
        rs->width = c->width, rs->height = c->height;
    }
    if (rs->have_cur && rs->frame != c->frame) { /* a new frame: this one's become the previous */
        femb_reservoir *t = rs->prev;
        rs->prev = rs->cur, rs->cur = t;
        femb_rsurf *ts = rs->sprev;
        rs->sprev = rs->scur, rs->scur = ts;
        rs->prev_frame = rs->frame;
        rs->have_prev = true;
    }
    /* (the same frame again, e.g. shaded twice: merged with the same previous one) */
    float radius = (float)c->width / 40.0f;
    rs_job j = {f, radius < 3.0f ? 3.0f : radius > 30.0f ? 30.0f : radius};
    femb_parallel_tiles(c, candidates_tile, &j);
    femb_parallel_tiles(c, spatial_tile, &j);
    rs->frame = c->frame;
    rs->have_cur = true;
    return TND_OK;
}

const femb_reservoir *femb_restir_lookup(const femb_context *c, uint32_t key_frame,
                                         uint32_t key_pixel)
{
    const femb_restir *rs = &c->rs;
    const femb_reservoir *r = NULL;
    if (!c->restir || key_pixel >= (size_t)rs->width * rs->height)
        return NULL;
    if (rs->have_cur && key_frame == rs->frame)
        r = &rs->cur[key_pixel];
    else if (rs->have_prev && key_frame == rs->prev_frame)
        r = &rs->prev[key_pixel];
    return r && r->M > 0.0f ? r : NULL;
}

void femb_restir_shade(const femb_context *c, const femb_reservoir *r, const femb_rsurf *s,
                       v3 org, float diff[3], float spec[3])
{
    for (int k = 0; k < 3; k++)
        diff[k] = spec[k] = 0.0f;
    if (!(r->W > 0.0f))
        return;
    rs_point y = resolve(c, r->light, r->u, r->v);
    float d[3], sp[3], dist;
    v3 wi;
    if (!y.ok || !contribution(&y, s, d, sp, &wi, &dist))
        return;
    /* the shadow ray as next-event estimation casts it: to the emitter's point offset off its
     * plane towards the receiver (shaders/offset.h); none where the two offset points crossed
     * (the receiver nearer the emitter than the coordinates resolve: no occluder fits) */
    float tmax = 1e30f;
    v3 dir = wi;
    bool cast = true;
    if (!y.far) {
        v3 p = {s->p[0], s->p[1], s->p[2]}, end = y.x;
        if (y.kind == TND_LIGHT_KIND_TRIANGLE) {
            float eq = tnd_offset_eps(
                fmx(tnd_max_abs3(y.x.x, y.x.y, y.x.z), tnd_max_abs3(p.x, p.y, p.z)));
            v3 nt = -dot(y.n, wi) >= 0.0f ? y.n : mul(y.n, -1.0f);
            end = add(y.x, mul(nt, eq));
        }
        v3 sd = sub(end, org);
        cast = dot(sd, sub(y.x, p)) > 0.0f;
        tmax = sqrtf(dot(sd, sd));
        dir = mul(sd, 1.0f / tmax);
    }
    if (cast && femb_occluded(c, org, dir, tmax))
        return;
    for (int k = 0; k < 3; k++) {
        diff[k] = d[k] * r->W;
        spec[k] = sp[k] * r->W;
    }
}
