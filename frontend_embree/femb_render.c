/* frontend_embree/femb_render.c: the passes of the Embree front-end, on batches of pixels (the
 * estimator itself is in femb_estimator.c):
 * - primary: camera rays (Halton jitter), the real-time mirror/glass chain, the G-buffer with
 *   visibility, motion vectors from the previous frame's camera and instance transforms, and the
 *   rng keys; staged per batch and written to the frame with streaming stores;
 * - shading: the estimator on the G-buffer's surfaces, sky pixels set directly;
 * - gradient samples: the previous frame's surfaces and keys patched in, then shaded;
 * - reference: full paths with Russian roulette from jittered camera rays, accumulated.
 * Entry points: femb_trace_primary, femb_shade, femb_gradient_unpack, femb_shade_gradients,
 * femb_reference, femb_specular_chain. */
#include "frontend_embree/femb_internal.h"
#include "shaders/brdf.h"
#include "shaders/sampling.h"
#include "shaders/specular.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef __SSE2__
#include <immintrin.h>
#endif

/* ---- projection ----------------------------------------------------------------------------- */
/* Pixel position, for a camera, of the point at d from the camera's position (of direction d
 * when `direction`), in float. Callers pass d relative to the camera without forming the world
 * point first (femb_xf_point_rel). Inline: lane loops vectorise it. */
static inline bool project(const tnd_camera_state *cam, v3 d, bool direction, uint32_t w,
                           uint32_t h, float out[2])
{
    const float *V = cam->view, *P = cam->proj;
    float v[3], clip[4];
    for (int r = 0; r < 3; r++)
        v[r] = V[r] * d.x + V[4 + r] * d.y + V[8 + r] * d.z;
    for (int r = 0; r < 4; r++)
        clip[r] = P[r] * v[0] + P[4 + r] * v[1] + P[8 + r] * v[2] + (direction ? 0.0f : P[12 + r]);
    out[0] = (clip[0] / clip[3] * 0.5f + 0.5f) * (float)w;
    out[1] = (clip[1] / clip[3] * 0.5f + 0.5f) * (float)h;
    return (fabsf(clip[3]) > 1e-30f) & isfinite(out[0]) & isfinite(out[1]);
}

/* ---- primary pass ---------------------------------------------------------------------------- */
/* Primary ray direction through pixel position (px, py), from the inverses computed once per
 * frame: unproject in view space, then rotate (no translation enters the direction), in float
 * as the Vulkan front-end's camera_dir; inline, so that a loop over lanes vectorises it. */
static inline v3 camera_dir(const femb_context *c, float px, float py)
{
    float ndc[3] = {2.0f * px / (float)c->width - 1.0f, 2.0f * py / (float)c->height - 1.0f, 0.5f};
    const float *m = c->inv_proj, *r = c->inv_view;
    float h[4];
    for (int k = 0; k < 4; k++)
        h[k] = m[k] * ndc[0] + m[4 + k] * ndc[1] + m[8 + k] * ndc[2] + m[12 + k];
    float w = h[3] != 0.0f ? h[3] : 1.0f, pv[3];
    for (int k = 0; k < 3; k++)
        pv[k] = h[k] / w;
    v3 d = {r[0] * pv[0] + r[4] * pv[1] + r[8] * pv[2], r[1] * pv[0] + r[5] * pv[1] + r[9] * pv[2],
            r[2] * pv[0] + r[6] * pv[1] + r[10] * pv[2]};
    return norm(d); /* (0 stays 0) */
}

static inline v3 pixel_dir(const femb_context *c, uint32_t x, uint32_t y)
{
    return camera_dir(c, (float)x + 0.5f + c->jitter[0], (float)y + 0.5f + c->jitter[1]);
}

/* A chain before its camera ray is cast: no hit, no vertex, throughput 1. */
static void chain_start(femb_chain *r, v3 dir)
{
    memset(r, 0, sizeof *r);
    r->thr[0] = r->thr[1] = r->thr[2] = 1.0f;
    r->dir0 = r->dir = dir;
}

/* The real-time reflect/refract chain (femb_internal.h) of pixel (x, y) whose camera ray has
 * direction dir (pixel_dir): mirror: reflect, x Schlick; glass: refract unless total internal
 * reflection, x (1 - F); Beer-Lambert inside. */

static void chain_from(const femb_context *c, uint32_t x, uint32_t y, v3 dir, bool follow,
                       femb_chain *r)
{
    uint32_t field = (x + y) & 1u;
    v3 org = {c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]};
    float sigma[3] = {0, 0, 0};
    bool inside = false;
    chain_start(r, dir);
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
            wi = femb_specular_direction(&s, s.ns, dir, 0.0f, f, &ev, &enter);
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
            wi = femb_specular_vertex(&s, dir, uu, f2, &ev2, &enter);
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

void femb_specular_chain(const femb_context *c, uint32_t x, uint32_t y, bool follow,
                         femb_chain *r)
{
    chain_from(c, x, y, pixel_dir(c, x, y), follow, r);
}

typedef struct primary_job {
    tnd_frame *f;
    const femb_params *shade; /* femb_render: each batch shaded at once with these; else NULL */
    float *radiance;          /* femb_render's */
} primary_job;

/* The channels the primary pass writes. */
static const tnd_ct primary_cts[] = {
    TND_CT_ALBEDO,   TND_CT_NORMAL, TND_CT_GEO_NORMAL, TND_CT_POSITION,  TND_CT_DEPTH,
    TND_CT_MOTION,   TND_CT_ROUGHNESS, TND_CT_METALLIC, TND_CT_EMISSION, TND_CT_VIS_ID,
    TND_CT_VIS_BARY, TND_CT_THROUGHPUT, TND_CT_RNG,   TND_CT_PATH};
enum { PRIMARY_CTS = sizeof primary_cts / sizeof *primary_cts };

/* A batch's G-buffer, staged as planes of FEMB_LANES entries (a frame of FEMB_LANES x 1 whose
 * planes live in `mem`), then copied to the frame's planes with streaming stores: the passes
 * write each entry once and the frame (megabytes) would only push the BVH out of the caches. */
typedef struct gbuf_stage {
    tnd_frame f;
    float mem[4 * PRIMARY_CTS * FEMB_LANES]; /* (at most 4 components per entry) */
} gbuf_stage;

static void stage_init(gbuf_stage *st)
{
    memset(&st->f, 0, sizeof st->f);
    size_t off = 0;
    for (int k = 0; k < PRIMARY_CTS; k++) {
        st->f.data[primary_cts[k]] = st->mem + off;
        off += (size_t)tnd_ct_get(primary_cts[k])->comps * FEMB_LANES;
    }
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(FEMB_NO_CLONES)
/* words [i, n) with 32-byte non-temporal stores from a 32-byte aligned dst + i, for CPUs with
 * AVX (picked at run time): half the instructions of the 16-byte copy; returns where it
 * stopped */
__attribute__((target("avx"))) static size_t stream_avx(float *dst, const float *src, size_t i,
                                                        size_t n)
{
#pragma GCC unroll 4
    for (; i + 8 <= n; i += 8)
        _mm256_stream_ps(dst + i, _mm256_loadu_ps(src + i));
    return i;
}
#define FEMB_STREAM_AVX 1
#endif

void femb_stream_words(float *dst, const float *src, size_t n)
{
#ifdef __SSE2__
    bool avx = false;
#ifdef FEMB_STREAM_AVX
    avx = __builtin_cpu_supports("avx");
#endif
    uintptr_t align = avx ? 31u : 15u;
    size_t i = 0;
    for (; i < n && ((uintptr_t)(dst + i) & align); i++)
        dst[i] = src[i];
#ifdef FEMB_STREAM_AVX
    if (avx)
        i = stream_avx(dst, src, i, n);
#endif
    for (; i + 4 <= n; i += 4)
        _mm_stream_ps(dst + i, _mm_loadu_ps(src + i));
    for (; i < n; i++)
        dst[i] = src[i];
#else
    memcpy(dst, src, n * sizeof *dst);
#endif
}

/* The staged entries of pixels [q0, q0 + n) to the frame, plane by plane. */
static void stage_flush(const gbuf_stage *st, tnd_frame *f, size_t q0, uint32_t n)
{
    for (int k = 0; k < PRIMARY_CTS; k++) {
        uint32_t comps = tnd_ct_get(primary_cts[k])->comps;
        femb_stream_words((float *)f->data[primary_cts[k]] + q0 * comps,
                          st->f.data[primary_cts[k]], (size_t)n * comps);
    }
}

void femb_stream_fence(void)
{
#ifdef __SSE2__
    _mm_sfence();
#endif
}

/* The G-buffer entries of surface s at entry q: visibility (instance, primitive, barycentrics),
 * albedo, both normals, position, roughness and metallic (the primary pass and the gradient
 * samples' patches). */
static void store_surface(tnd_frame *f, size_t q, const femb_surface *s, uint32_t inst,
                          uint32_t prim, float u, float v)
{
    const v3 *vec[3] = {&s->ns, &s->ng, &s->p};
    const tnd_ct ct[3] = {TND_CT_NORMAL, TND_CT_GEO_NORMAL, TND_CT_POSITION};
    for (int k = 0; k < 3; k++) {
        float *d = tnd_frame_f(f, ct[k]) + 3 * q;
        d[0] = vec[k]->x, d[1] = vec[k]->y, d[2] = vec[k]->z;
    }
    memcpy(tnd_frame_f(f, TND_CT_ALBEDO) + 3 * q, s->base, 3 * sizeof(float));
    tnd_frame_u(f, TND_CT_VIS_ID)[2 * q] = inst;
    tnd_frame_u(f, TND_CT_VIS_ID)[2 * q + 1] = prim;
    tnd_frame_f(f, TND_CT_VIS_BARY)[2 * q] = u;
    tnd_frame_f(f, TND_CT_VIS_BARY)[2 * q + 1] = v;
    tnd_frame_f(f, TND_CT_ROUGHNESS)[q] = s->roughness;
    tnd_frame_f(f, TND_CT_METALLIC)[q] = s->metallic;
}

/* G-buffer and motion of pixel `pixel` whose chain misses or meets a mirror or glass (surfaces
 * seen directly are written by primary_batch's lane loop): from the chain and, when it sees
 * one, the surface s at distance `dist` along it, written at entry q of f. */
static void primary_store(femb_context *c, tnd_frame *f, size_t q, uint32_t pixel,
                          const femb_chain *ch, const femb_surface *s, float dist)
{
    uint32_t W = c->width, H = c->height;
    const tnd_camera_state *cam = &c->cur->camera;
    tnd_frame_u(f, TND_CT_PATH)[q] = ch->path;
    uint32_t inst = ch->inst, prim = ch->prim;
    float u = ch->u, v = ch->v;
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
    rng[1] = pixel;
    memcpy(thr, ch->thr, 3 * sizeof(float));
    float cur_px[2], prev_px[2];
    if (!ch->hit) {
        float Le[3];
        femb_miss_radiance(c, ch->dir, Le);
        for (int k = 0; k < 3; k++) {
            alb[k] = n[k] = gn[k] = pos[k] = 0.0f;
            em[k] = Le[k] * ch->thr[k];
        }
        n[2] = gn[2] = 0.0f;
        *depth = (float)TND_DEPTH_MISS;
        vis[0] = vis[1] = TND_VIS_NONE;
        bary[0] = bary[1] = 0.0f;
        tnd_frame_f(f, TND_CT_ROUGHNESS)[q] = 1.0f;
        tnd_frame_f(f, TND_CT_METALLIC)[q] = 0.0f;
        mo[0] = mo[1] = mo[2] = 0.0f;
        if (project(cam, ch->dir0, true, W, H, cur_px) &&
            project(&c->prev->camera, ch->dir0, true, W, H, prev_px)) {
            mo[0] = prev_px[0] - cur_px[0];
            mo[1] = prev_px[1] - cur_px[1];
        }
        return;
    }
    store_surface(f, q, s, inst, prim, u, v);
    for (int k = 0; k < 3; k++)
        em[k] = s->emission[k] * ch->thr[k];
    *depth = dist;
    mo[0] = mo[1] = mo[2] = 0.0f;
    /* the virtual point (what a planar mirror shows: along the camera ray at the chain's
     * length), the mirror and the glass assumed still */
    v3 dc = mul(ch->dir0, ch->length); /* from this frame's camera, and the previous one's */
    v3 dp = add(sub((v3){c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]},
                    (v3){c->prev_cam_pos[0], c->prev_cam_pos[1], c->prev_cam_pos[2]}),
                dc);
    if (project(cam, dc, false, W, H, cur_px) &&
        project(&c->prev->camera, dp, false, W, H, prev_px)) {
        mo[0] = prev_px[0] - cur_px[0];
        mo[1] = prev_px[1] - cur_px[1];
    }
    mo[2] = sqrtf(dot(dp, dp)) - ch->length;
}

/* Motion of a surface point at dc from this frame's camera (femb_xf_point_rel) and dp from the
 * previous frame's: the same point through the two unjittered cameras; inline, so that a loop
 * over lanes vectorises it. */
static inline void point_motion(const femb_context *c, v3 dc, v3 dp, float mo[3])
{
    float cur_px[2], prev_px[2];
    bool ok = project(&c->cur->camera, dc, false, c->width, c->height, cur_px) &
              project(&c->prev->camera, dp, false, c->width, c->height, prev_px);
    mo[0] = ok ? prev_px[0] - cur_px[0] : 0.0f;
    mo[1] = ok ? prev_px[1] - cur_px[1] : 0.0f;
    mo[2] = sqrtf(dot(dp, dp)) - sqrtf(dot(dc, dc));
}

/* The motion vectors mo of a batch's lanes (dc: from this frame's camera; the previous transform
 * PX of the lanes on instances that moved); `any_moved` (a constant in each call) false: no
 * instance moved, every point is where it was. */
static inline __attribute__((always_inline)) void
batch_motion(const femb_context *c, bool any_moved, uint32_t n, const uint8_t *moved,
             const float PX[12][FEMB_LANES], const femb_surfaces *S,
             const float rel[3][FEMB_LANES], float mo[3][FEMB_LANES])
{
    v3 cam = {c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]};
    v3 dcam = sub(cam, (v3){c->prev_cam_pos[0], c->prev_cam_pos[1], c->prev_cam_pos[2]});
    FEMB_LANES_LOOP(i, n) {
        v3 dc = FEMB_LD3(rel, i), dp = add(dcam, dc);
        if (any_moved) {
            float a[12], obj[3] = {S->obj[0][i], S->obj[1][i], S->obj[2][i]};
            for (int r = 0; r < 12; r++)
                a[r] = PX[r][i];
            dp = sel3(moved[i], femb_xf_point_rel(a, obj, c->prev_cam_pos), dp);
        }
        float m[3];
        point_motion(c, dc, dp, m);
        for (int k = 0; k < 3; k++)
            mo[k][i] = m[k];
    }
}

/* The primary pass on the n pixels from q0 on, a run within a row (primary_tile), then when
 * `shade` is given the shading pass on them from the staged G-buffer (femb_render). */
FEMB_LANE_FN static void primary_batch(femb_context *c, tnd_frame *f, uint32_t q0, uint32_t n,
                                       const femb_params *shade, float *radiance)
{
    gbuf_stage st;
    stage_init(&st);
    femb_chain ch[FEMB_LANES];
    femb_surfaces S;
    uint32_t inst[FEMB_LANES] = {0}, prim[FEMB_LANES] = {0}; /* (zeroed: quiets gcc) */
    float u[FEMB_LANES] = {0}, v[FEMB_LANES] = {0}, depth[FEMB_LANES], dir[3][FEMB_LANES];
    float PX[12][FEMB_LANES], rel[3][FEMB_LANES], mo[3][FEMB_LANES];
    uint8_t plain[FEMB_LANES] = {0}, chain[FEMB_LANES], moved[FEMB_LANES];
    float fx[FEMB_LANES], fy[FEMB_LANES]; /* (pixel_dir split, without a division per lane) */
    uint32_t x0 = q0 % c->width, y0 = q0 / c->width;
    FEMB_LANES_LOOP(i, n) {
        fx[i] = (float)(x0 + i) + 0.5f + c->jitter[0];
        fy[i] = (float)y0 + 0.5f + c->jitter[1];
    }
    FEMB_LANES_LOOP(i, n) FEMB_ST3(dir, i, camera_dir(c, fx[i], fy[i]));
    v3 cam = {c->cam_pos[0], c->cam_pos[1], c->cam_pos[2]};
    if (c->any_moved) /* (lanes that did not move read zeros, whose result is not selected) */
        memset(PX, 0, sizeof PX);
    for (uint32_t i = 0; i < n; i++) {
        if (!c->specular) { /* no mirror or glass: the chain is the camera ray (chain_from's) */
            float t;
            v3 d = FEMB_LD3(dir, i);
            plain[i] = femb_intersect(c, cam, d, 1e30f, &inst[i], &prim[i], &u[i], &v[i], &t);
            chain[i] = 0;
            if (!plain[i]) { /* what chain_from returns for a miss (primary_store reads it) */
                chain_start(&ch[i], d);
                inst[i] = prim[i] = 0, u[i] = v[i] = 0.0f;
            }
        } else {
            chain_from(c, x0 + i, y0, FEMB_LD3(dir, i), true, &ch[i]);
            inst[i] = ch[i].inst, prim[i] = ch[i].prim, u[i] = ch[i].u, v[i] = ch[i].v;
            plain[i] = ch[i].hit && ch[i].vertices == 0;
            chain[i] = ch[i].hit && ch[i].vertices > 0;
        }
        /* the previous transform of instances that moved (the others' points are where they
         * were: from the previous camera, the camera's displacement plus the vector from this
         * one) */
        moved[i] = c->any_moved && plain[i] && c->inst[inst[i]].moved;
        if (moved[i]) {
            const float *px = c->prev->instance_xform + 12 * (size_t)inst[i];
            for (int r = 0; r < 12; r++)
                PX[r][i] = px[r];
        }
    }
    femb_surface_eval_eye(c, n, plain, inst, prim, u, v, &S, depth, rel);
    if (c->any_moved)
        batch_motion(c, true, n, moved, PX, &S, rel, mo);
    else
        batch_motion(c, false, n, moved, PX, &S, rel, mo);
    /* the G-buffer of the lanes that see a surface directly, from the batch's surfaces (what
     * primary_store writes with a chain of no vertex: throughput 1, no path flags); the other
     * lanes are written after, one by one */
    tnd_frame *g = &st.f;
    float *alb = tnd_frame_f(g, TND_CT_ALBEDO), *nrm = tnd_frame_f(g, TND_CT_NORMAL);
    float *gn = tnd_frame_f(g, TND_CT_GEO_NORMAL), *pos = tnd_frame_f(g, TND_CT_POSITION);
    float *dep = tnd_frame_f(g, TND_CT_DEPTH), *mot = tnd_frame_f(g, TND_CT_MOTION);
    float *rough = tnd_frame_f(g, TND_CT_ROUGHNESS), *metal = tnd_frame_f(g, TND_CT_METALLIC);
    float *em = tnd_frame_f(g, TND_CT_EMISSION), *bary = tnd_frame_f(g, TND_CT_VIS_BARY);
    float *thr = tnd_frame_f(g, TND_CT_THROUGHPUT);
    uint32_t *vis = tnd_frame_u(g, TND_CT_VIS_ID), *rng = tnd_frame_u(g, TND_CT_RNG);
    uint32_t *path = tnd_frame_u(g, TND_CT_PATH);
    FEMB_LANES_LOOP(i, n) {
        for (int k = 0; k < 3; k++) {
            alb[3 * i + k] = S.base[k][i];
            nrm[3 * i + k] = S.ns[k][i];
            gn[3 * i + k] = S.ng[k][i];
            pos[3 * i + k] = S.p[k][i];
            mot[3 * i + k] = mo[k][i];
            em[3 * i + k] = S.emission[k][i];
            thr[3 * i + k] = 1.0f;
        }
        dep[i] = depth[i];
        rough[i] = S.roughness[i];
        metal[i] = S.metallic[i];
        vis[2 * i] = inst[i], vis[2 * i + 1] = prim[i];
        bary[2 * i] = u[i], bary[2 * i + 1] = v[i];
        rng[2 * i] = c->frame, rng[2 * i + 1] = q0 + i;
        path[i] = 0u;
    }
    for (uint32_t i = 0; i < n; i++) {
        femb_surface s;
        if (plain[i]) {
            continue;
        } else if (chain[i]) { /* seen in a mirror or through glass: the surface at its end */
            depth[i] = ch[i].length;
            femb_surface_eval(c, inst[i], prim[i], u[i], v[i], ch[i].dir,
                              depth[i] * c->pixel_spread, &s);
        }
        primary_store(c, &st.f, i, q0 + i, &ch[i], &s, depth[i]);
    }
    stage_flush(&st, f, q0, n);
    if (shade) /* (S holds every lane's surface when no chain met a mirror or glass) */
        femb_shade_staged(c, shade, f, &st.f, c->specular ? NULL : &S, q0, n, radiance);
}

static void primary_tile(femb_context *c, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                         void *user)
{
    const primary_job *j = user;
    for (uint32_t y = y0; y < y1; y++) /* one batch per row of the tile: a run of pixels */
        for (uint32_t x = x0; x < x1; x += FEMB_LANES)
            primary_batch(c, j->f, y * c->width + x, x1 - x < FEMB_LANES ? x1 - x : FEMB_LANES,
                          j->shade, j->radiance);
}

/* The primary pass over the frame, each batch shaded at once when j->shade is given. */
static tnd_result primary_frame(femb_context *c, tnd_frame *f, const primary_job *j)
{
    if (f->width != c->width || f->height != c->height)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "embree: frame %ux%u, expected %ux%u", f->width,
                        f->height, c->width, c->height);
    femb_parallel_tiles(c, primary_tile, (void *)j);
    for (int k = 0; k < PRIMARY_CTS; k++)
        f->present[primary_cts[k]] = true;
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

tnd_result femb_trace_primary(femb_context *c, tnd_frame *f)
{
    return primary_frame(c, f, &(primary_job){f, NULL, NULL});
}

/* ---- shading pass ---------------------------------------------------------------------------- */
typedef struct shade_job {
    const femb_params *p;
    tnd_frame *f;
    float *radiance;
} shade_job;

void femb_set_reference_bounces(femb_context *c, uint32_t bounces)
{
    c->ref_bounces = bounces;
}

/* A tile's pixels that see a surface go to the estimator in batches; the others show the sky
 * (its radiance is the primary pass's emission) and carry no shading. */
static void shade_tile(femb_context *c, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                       void *user)
{
    shade_job *j = user;
    tnd_frame *f = j->f;
    uint32_t batch[FEMB_LANES], n = 0;
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = x0; x < x1; x++) {
            uint32_t q = y * c->width + x;
            if (tnd_frame_u(f, TND_CT_VIS_ID)[2 * (size_t)q] != TND_VIS_NONE) {
                batch[n++] = q;
                if (n == FEMB_LANES) {
                    femb_shade_pixels(c, j->p, f, batch, n, j->radiance);
                    n = 0;
                }
                continue;
            }
            memset(tnd_frame_f(f, TND_CT_HF) + 3 * (size_t)q, 0, 3 * sizeof(float));
            memset(tnd_frame_f(f, TND_CT_LF_SH) + 4 * (size_t)q, 0, 4 * sizeof(float));
            memset(tnd_frame_f(f, TND_CT_LF_COCG) + 2 * (size_t)q, 0, 2 * sizeof(float));
            memset(tnd_frame_f(f, TND_CT_SPEC) + 3 * (size_t)q, 0, 3 * sizeof(float));
            tnd_frame_f(f, TND_CT_SPEC_HIT)[q] = 0.0f;
            tnd_frame_f(f, TND_CT_DIFFUSE_VIEW)[q] = 1.0f;
            if (j->radiance)
                memcpy(j->radiance + 3 * (size_t)q, tnd_frame_f(f, TND_CT_EMISSION) + 3 * (size_t)q,
                       3 * sizeof(float));
        }
    if (n)
        femb_shade_pixels(c, j->p, f, batch, n, j->radiance);
}

static void mark_shading(tnd_frame *f)
{
    f->present[TND_CT_HF] = f->present[TND_CT_LF_SH] = true;
    f->present[TND_CT_LF_COCG] = f->present[TND_CT_SPEC] = true;
    f->present[TND_CT_SPEC_HIT] = f->present[TND_CT_DIFFUSE_VIEW] = true;
}

static const femb_params default_params = {.bounces = 1};

/* The frame's jitter, or the one the parameters set (a matched reference's sample). */
static void params_jitter(femb_context *c, const femb_params *p)
{
    if (p && p->set_jitter)
        memcpy(c->jitter, p->jitter, sizeof c->jitter);
    else
        tnd_jitter(c->frame, c->jitter);
}

/* Whether this frame's shading takes reservoirs (--lights restir, the frame's own numbers: a
 * matched reference's samples keep next-event estimation, whose expectation is the same). */
static bool uses_reservoirs(const femb_context *c, const femb_params *p)
{
    return c->restir && (p ? p->sample : TND_SAMPLE_REALTIME) == TND_SAMPLE_REALTIME;
}

tnd_result femb_shade(femb_context *c, const femb_params *p, tnd_frame *f, float *radiance)
{
    if (f->width != c->width || f->height != c->height || !f->present[TND_CT_VIS_ID])
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "embree: shade needs the primary pass's frame");
    if (uses_reservoirs(c, p))
        TND_TRY_RETURN(femb_restir_frame(c, f));
    shade_job j = {p ? p : &default_params, f, radiance};
    femb_parallel_tiles(c, shade_tile, &j);
    mark_shading(f);
    return TND_OK;
}

tnd_result femb_render(femb_context *c, const femb_params *p, tnd_frame *f, float *radiance)
{
    params_jitter(c, p);
    if (uses_reservoirs(c, p)) { /* the reservoirs need the whole G-buffer before shading */
        tnd_result res = primary_frame(c, f, &(primary_job){f, NULL, NULL});
        return res == TND_OK ? femb_shade(c, p, f, radiance) : res;
    }
    tnd_result res = primary_frame(c, f, &(primary_job){f, p ? p : &default_params, radiance});
    if (res == TND_OK)
        mark_shading(f);
    return res;
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

tnd_result femb_shade_gradients(femb_context *c, const femb_params *pp,
                                const femb_gradient_sample *g, uint32_t n, tnd_frame *f)
{
    /* (the previous frame's own numbers: the real-time sample word whatever pp says) */
    femb_params own = pp ? *pp : default_params;
    own.sample = TND_SAMPLE_REALTIME;
    const femb_params *p = &own;
    for (uint32_t i = 0; i < n; i++) {
        if (g[i].pixel >= c->width * c->height || g[i].instance >= c->scene->instance_count ||
            g[i].primitive >=
                c->scene->meshes[c->scene->instances[g[i].instance].mesh].triangle_count)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                            "embree: gradient sample %u: pixel %u, instance %u, primitive %u out "
                            "of range",
                            i, g[i].pixel, g[i].instance, g[i].primitive);
    }
    /* in batches: the surfaces re-evaluated on the current geometry patch the G-buffer, then
     * the pixels are shaded */
    for (uint32_t i0 = 0; i0 < n; i0 += FEMB_LANES) {
        uint32_t m = n - i0 < FEMB_LANES ? n - i0 : FEMB_LANES;
        uint32_t inst[FEMB_LANES] = {0}, prim[FEMB_LANES] = {0}, pixels[FEMB_LANES];
        float u[FEMB_LANES] = {0}, v[FEMB_LANES] = {0}, depth[FEMB_LANES];
        uint8_t active[FEMB_LANES];
        for (uint32_t k = 0; k < m; k++) {
            const femb_gradient_sample *gs = &g[i0 + k];
            inst[k] = gs->instance, prim[k] = gs->primitive, u[k] = gs->u, v[k] = gs->v;
            pixels[k] = gs->pixel;
            active[k] = 1;
        }
        femb_surfaces S;
        float rel[3][FEMB_LANES];
        femb_surface_eval_eye(c, m, active, inst, prim, u, v, &S, depth, rel);
        for (uint32_t k = 0; k < m; k++) {
            const femb_gradient_sample *gs = &g[i0 + k];
            size_t q = gs->pixel;
            femb_surface s;
            femb_surface_get(&S, k, &s);
            store_surface(f, q, &s, gs->instance, gs->primitive, gs->u, gs->v);
            tnd_frame_u(f, TND_CT_RNG)[2 * q] = gs->rng_frame;
            tnd_frame_u(f, TND_CT_RNG)[2 * q + 1] = gs->rng_pixel;
            memcpy(tnd_frame_f(f, TND_CT_EMISSION) + 3 * q, s.emission, 3 * sizeof(float));
        }
        femb_shade_pixels(c, p, f, pixels, m, NULL);
    }
    femb_stream_fence(); /* (a run among the samples is streamed: femb_shade_pixels) */
    mark_shading(f);
    return TND_OK;
}

/* ---- reference ------------------------------------------------------------------------------- */
typedef struct ref_job {
    uint32_t sample;
    double *sum, *sum2; /* rgb and luminance^2 per pixel */
} ref_job;

static void reference_batch(femb_context *c, ref_job *j, femb_paths *P, const uint32_t *pixels)
{
    float L[3][FEMB_LANES];
    femb_trace_paths(c, P, 0, c->ref_bounces ? c->ref_bounces : TND_REFERENCE_MAX_BOUNCES, 3, L,
                     NULL);
    for (uint32_t i = 0; i < P->n; i++) {
        size_t q = pixels[i];
        for (int k = 0; k < 3; k++)
            j->sum[3 * q + k] += L[k][i];
        double lum = tnd_luminance(L[0][i], L[1][i], L[2][i]);
        j->sum2[q] += lum * lum;
    }
    P->n = 0;
}

static void reference_tile(femb_context *c, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                           void *user)
{
    ref_job *j = user;
    femb_paths P = {.n = 0, .key_sample = tnd_reference_sample(j->sample)};
    uint32_t pixels[FEMB_LANES];
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = x0; x < x1; x++) {
            uint32_t q = y * c->width + x, i = P.n++;
            float jx = tnd_rand(q, c->frame, P.key_sample, TND_DIM_JITTER_X);
            float jy = tnd_rand(q, c->frame, P.key_sample, TND_DIM_JITTER_Y);
            v3 dv = camera_dir(c, (float)x + jx, (float)y + jy);
            float d[3] = {dv.x, dv.y, dv.z};
            pixels[i] = q;
            P.key_pixel[i] = q;
            P.key_frame[i] = c->frame;
            for (int k = 0; k < 3; k++) {
                P.from[k][i] = P.org[k][i] = c->cam_pos[k];
                P.dir[k][i] = d[k];
            }
            P.pdf_prev[i] = 0.0f;
            P.cone[i] = 0.0f;
            P.active[i] = 1;
            if (P.n == FEMB_LANES)
                reference_batch(c, j, &P, pixels);
        }
    if (P.n)
        reference_batch(c, j, &P, pixels);
}

tnd_result femb_reference_add(femb_context *c, uint32_t first, uint32_t count, double *sum_rgb,
                              double *sum_lum2, tnd_ref_stats *stats,
                              void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    size_t n = (size_t)c->width * c->height;
    if (count == 0 || first > UINT32_MAX - count)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "embree: reference samples [%u, +%u): empty or "
                        "past 2^32", first, count);
    ref_job j = {0, sum_rgb, sum_lum2};
    double until = stats ? stats->until_noise : 0.0;
    uint32_t end = first + count, done = end;
    for (uint32_t s = first; s < end; s++) {
        j.sample = s;
        femb_parallel_tiles(c, reference_tile, &j);
        if (progress)
            progress(s + 1 - first, count, user);
        if (until > 0 && (s + 1) % TND_REF_CHECK_EVERY == 0 && s + 1 < end &&
            tnd_ref_finish(j.sum, j.sum2, n, s + 1, NULL, NULL) < until) {
            done = s + 1;
            break;
        }
    }
    if (stats)
        stats->spp = done;
    return TND_OK;
}

static tnd_result reference_add(void *c, uint32_t first, uint32_t count, double *sum_rgb,
                                double *sum_lum2, tnd_ref_stats *stats,
                                void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    return femb_reference_add(c, first, count, sum_rgb, sum_lum2, stats, progress, user);
}

tnd_result femb_reference(femb_context *c, uint32_t spp, float *rgb, float *lum_se,
                          tnd_ref_stats *stats, void (*progress)(uint32_t, uint32_t, void *),
                          void *user)
{
    return tnd_ref_run((size_t)c->width * c->height, spp, reference_add, c, rgb, lum_se, stats,
                       progress, user);
}

