/* frontend_embree/femb_internal.h: the context and the shared pieces of the Embree front-end. */
#ifndef FEMB_INTERNAL_H
#define FEMB_INTERNAL_H

#include "frontend_embree/frontend_embree.h"
#include "shaders/offset.h"
#include "shaders/restir.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <pthread.h>
#include <string.h>

typedef struct v3 {
    float x, y, z;
} v3;

/* Small vector helpers (min/max written out: libm's fminf/fmaxf are calls without
 * -ffinite-math-only). */
static inline float fmx(float a, float b) { return a > b ? a : b; }
static inline float fmn(float a, float b) { return a < b ? a : b; }
static inline v3 add(v3 a, v3 b) { return (v3){a.x + b.x, a.y + b.y, a.z + b.z}; }
static inline v3 sub(v3 a, v3 b) { return (v3){a.x - b.x, a.y - b.y, a.z - b.z}; }
static inline v3 mul(v3 a, float s) { return (v3){a.x * s, a.y * s, a.z * s}; }
static inline float dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline v3 cross(v3 a, v3 b)
{
    return (v3){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static inline v3 norm(v3 a)
{
    float l = sqrtf(dot(a, a));
    return mul(a, l > 0 ? 1.0f / l : 1.0f); /* selects on floats, not on structs: SIMD-friendly */
}
/* c ? a : b, per component (the estimator's lane loops vectorise selects of floats) */
static inline v3 sel3(bool c, v3 a, v3 b)
{
    return (v3){c ? a.x : b.x, c ? a.y : b.y, c ? a.z : b.z};
}

/* Object-space point p through a 3x4 row-major transform x (object to world), relative to the
 * world point `org` (a camera): the translation's difference first, exact or rounded to its own
 * size. Forming the world point first would round it to its magnitude (1/128 at 1e5 from the
 * origin), which near a camera far from the origin moves it by whole pixels: the `extremes`
 * scene seen from 0.07 units had its motion vectors off by up to 6 px that way. */
static inline v3 femb_xf_point_rel(const float *x, const float *p, const float *org)
{
    return (v3){x[0] * p[0] + x[1] * p[1] + x[2] * p[2] + (x[3] - org[0]),
                x[4] * p[0] + x[5] * p[1] + x[6] * p[2] + (x[7] - org[1]),
                x[8] * p[0] + x[9] * p[1] + x[10] * p[2] + (x[11] - org[2])};
}

/* Rays traced while a log is attached (benchmarks replay them in a raw loop). */
typedef struct femb_ray {
    float org[3], dir[3], tmax;
    uint32_t occlusion; /* 1: rtcOccluded1, 0: rtcIntersect1 */
} femb_ray;

typedef struct femb_ray_log {
    pthread_mutex_t lock;
    femb_ray *rays;
    size_t count, cap;
} femb_ray_log;

/* What a surface evaluation reads per instance and per material, gathered once at creation
 * (the scene's structs spread it over several cache lines and a function call); the mesh's
 * vertex and index offsets are femb_context.inst_vertex0 / inst_index0 (loaded by lane). */
typedef struct femb_inst {
    uint32_t material;
    float specular; /* the material's specular factor (what the shading pass reads from it) */
    bool moved; /* this frame's transform differs from the previous frame's (femb_set_frame) */
} femb_inst;
typedef struct femb_mat {
    float base[3], emission[3], sigma[3];
    float metallic, roughness, specular, ior;
    uint32_t kind;
    uint8_t textured, two_sided;
} femb_mat;

typedef struct femb_pool femb_pool;

/* ReSTIR DI's per-pixel state (femb_restir.c). A reservoir holds one light sample: the light's
 * index in the list and the two numbers that place the point on it, its unbiased contribution
 * weight W for the pixel's target, and M, the candidates it stands for (0: the pixel does not use
 * reservoirs, and shades with next-event estimation). */
typedef struct femb_reservoir {
    uint32_t light;
    float u, v, W, M;
} femb_reservoir;
/* What a target is evaluated on: the primary surface of a pixel (depth: from the camera). */
typedef struct femb_rsurf {
    float p[3], ns[3], ng[3], wo[3], base[3];
    float metallic, roughness, specular, depth;
} femb_rsurf;
typedef struct femb_restir {
    uint32_t width, height;
    uint32_t frame, prev_frame; /* the frames of cur and prev */
    bool have_cur, have_prev;
    femb_reservoir *prev, *mid, *cur; /* the previous frame's final, this one's after the
                                       * temporal merge, this one's final */
    femb_rsurf *sprev, *scur;
} femb_restir;

struct femb_context {
    const tnd_scene *scene;
    femb_inst *inst; /* per instance */
    /* What the surface evaluation's geometry loop loads by lane (as gathers where the CPU has
     * them: signed 32-bit offsets, checked at creation): per instance its mesh's first index and
     * first vertex, and the scene's index, position and normal arrays (a zero triangle for a
     * scene without geometry, so that inactive lanes always read something). */
    int32_t *inst_index0, *inst_vertex0;
    const int32_t *g_indices;
    const float *g_positions, *g_normals;
    femb_mat *mats;  /* per material */
    RTCDevice device;
    RTCScene top;
    RTCScene *meshes; /* one per tnd_mesh (NULL for meshes without triangles) */
    struct femb_alpha_geom *alpha; /* per mesh: what its alpha-test filter reads */
    uint32_t threads;
    femb_pool *pool; /* threads - 1 workers (femb_parallel_range) */
    char error[256];
    /* the frame */
    uint32_t width, height, frame;
    float jitter[2];
    const tnd_scene_state *cur, *prev;
    float cam_pos[3], prev_cam_pos[3];
    float inv_proj[16], inv_view[16];
    float pixel_spread; /* ray-cone spread angle per pixel (radians) */
    bool specular;      /* the scene has mirrors or glass: the primary pass follows them */
    uint32_t reflect_depth; /* at most this many specular vertices in the primary chain */
    float footprint_scale;  /* the ray cones' spread over the traced pixel's (femb_desc) */
    uint32_t ref_bounces;   /* femb_set_reference_bounces (0: full paths) */
    tnd_light_list lights;
    bool triangle_lights_only; /* every light of the list is an emissive triangle */
    bool select_lights; /* at most FEMB_SELECT_LIGHTS lights: NEE selects their records into
                         * lanes instead of copying them lane by lane (femb_estimator.c) */
    bool any_moved;            /* some instance's transform differs from the previous frame's */
    femb_ray_log *log; /* NULL except while recording */
    bool restir;       /* --lights restir: reservoirs at the primary surface (femb_restir.c) */
    femb_restir rs;
};

/* A surface point, reconstructed from (instance, primitive, barycentrics). */
typedef struct femb_surface {
    v3 p, ng, ns;  /* world position, geometric and shading normals (facing wo) */
    v3 wo;         /* towards the viewer */
    float base[3], metallic, roughness, specular;
    float emission[3]; /* towards wo (0 for a back face of a one-sided emitter) */
    uint32_t instance, primitive;
    float u, v;
    uint32_t kind; /* TND_KIND_* (shaders/specular.h) */
    float ior, sigma[3]; /* glass: index of refraction, absorption inside (1/m) */
    bool front;    /* the ray arrived on the side the geometric normal points to */
} femb_surface;

/* A loop over a batch's lanes: iterations are independent (no array of a batch overlaps
 * another), which the pragma tells the vectoriser. */
#define FEMB_LANES_LOOP(i, n) _Pragma("GCC ivdep") for (uint32_t i = 0; i < (n); i++)
#define FEMB_LD3(a, i) ((v3){(a)[0][i], (a)[1][i], (a)[2][i]})
#define FEMB_ST3(a, i, v) ((a)[0][i] = (v).x, (a)[1][i] = (v).y, (a)[2][i] = (v).z)
/* Functions with lane loops, compiled three times: for the baseline (SSE2: 4 lanes per
 * instruction), for x86-64-v3 (AVX2: 8) and for x86-64-v4 (AVX-512; gcc still uses 256-bit
 * vectors there, with mask registers for the selects and compares: 2-3 points of front-end/raw
 * on `cornell` over the AVX2 code), picked at load time by the CPU's features. All give the same
 * bits: no contraction to FMA in ISO C mode, and the operations used are IEEE-exact either way
 * (test_simd checks the clone this CPU runs against a build with FEMB_NO_CLONES, which compiles
 * the baseline only). */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(FEMB_NO_CLONES)
#define FEMB_LANE_FN __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define FEMB_LANE_FN
#endif

enum { FEMB_LANES = 64 }; /* paths per batch (femb_estimator.c) */
enum { FEMB_SELECT_LIGHTS = 8 }; /* see femb_context.select_lights */
/* A batch's arrays start on a cache line: a SIMD load of lanes never straddles two (the
 * vectoriser cannot tell through a pointer, and a misaligned struct makes every load split). */
#define FEMB_ALIGN _Alignas(64)

/* The surfaces of a batch, one lane per path (structure of arrays: the lane loops vectorise).
 * sigma and ior are set only in scenes with mirrors or glass (context `specular`); read them
 * through femb_surface_get, which gives opaque surfaces 0 and 1. obj (the object-space position,
 * for motion vectors) is set by femb_surface_eval_eye only. */
typedef struct femb_surfaces {
    FEMB_ALIGN float p[3][FEMB_LANES], ng[3][FEMB_LANES], ns[3][FEMB_LANES], wo[3][FEMB_LANES];
    float obj[3][FEMB_LANES], base[3][FEMB_LANES], emission[3][FEMB_LANES], sigma[3][FEMB_LANES];
    float metallic[FEMB_LANES], roughness[FEMB_LANES], specular[FEMB_LANES], ior[FEMB_LANES];
    float u[FEMB_LANES], v[FEMB_LANES];
    uint32_t instance[FEMB_LANES], primitive[FEMB_LANES], kind[FEMB_LANES];
    uint8_t front[FEMB_LANES];
} femb_surfaces;

/* Evaluate the surfaces hit by rays of directions dir (unit) at (instance, primitive, u, v) for
 * the active lanes of [0, n) (the others get unspecified values); `cone` (world width of the ray
 * cone at the hit) chooses the texture level of detail. femb_surface_eval does one. */
void femb_surface_eval_batch(const femb_context *c, uint32_t n, const uint8_t *active,
                             const uint32_t *instance, const uint32_t *primitive, const float *u,
                             const float *v, const float dir[3][FEMB_LANES], const float *cone,
                             femb_surfaces *S);
/* The same for surfaces seen from the camera: each direction runs from the camera position to
 * the surface point, `depth` receives the distance and `rel` the vector from the camera
 * (computed relative to it: femb_xf_point_rel); what the primary pass and the gradient samples
 * need, bit for bit alike. */
void femb_surface_eval_eye(const femb_context *c, uint32_t n, const uint8_t *active,
                           const uint32_t *instance, const uint32_t *primitive, const float *u,
                           const float *v, femb_surfaces *S, float *depth,
                           float rel[3][FEMB_LANES]);
void femb_surface_eval(const femb_context *c, uint32_t instance, uint32_t primitive, float u,
                       float v, v3 dir, float cone_width, femb_surface *s);
/* Lane i of a batch as one surface. */
void femb_surface_get(const femb_surfaces *S, uint32_t i, femb_surface *s);

/* Append a ray to the benchmark's log. */
void femb_log_ray(femb_ray_log *log, v3 org, v3 dir, float tmax, uint32_t occlusion);

/* Closest hit (false on a miss) and occlusion; inline, the rays built in the callers' loops. */
static inline bool femb_intersect(const femb_context *c, v3 org, v3 dir, float tmax,
                                  uint32_t *instance, uint32_t *primitive, float *u, float *v,
                                  float *t)
{
    if (c->log)
        femb_log_ray(c->log, org, dir, tmax, 0);
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    /* (the fields Embree reads, and the hit's ids it tests; the rest it writes) */
    struct RTCRayHit rh;
    rh.ray = (struct RTCRay){.org_x = org.x, .org_y = org.y, .org_z = org.z, .tnear = 0.0f,
                             .dir_x = dir.x, .dir_y = dir.y, .dir_z = dir.z, .time = 0.0f,
                             .tfar = tmax, .mask = 0xffffffffu};
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(c->top, &ictx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return false;
    *instance = rh.hit.instID[0];
    *primitive = rh.hit.primID;
    *u = rh.hit.u;
    *v = rh.hit.v;
    *t = rh.ray.tfar;
    return true;
}

static inline bool femb_occluded(const femb_context *c, v3 org, v3 dir, float tmax)
{
    if (c->log)
        femb_log_ray(c->log, org, dir, tmax, 1);
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRay r = {.org_x = org.x, .org_y = org.y, .org_z = org.z, .tnear = 0.0f,
                       .dir_x = dir.x, .dir_y = dir.y, .dir_z = dir.z, .time = 0.0f,
                       .tfar = tmax, .mask = 0xffffffffu};
    rtcOccluded1(c->top, &ictx, &r);
    return r.tfar < 0.0f;
}

/* Copy n floats (4-byte words) to dst, with non-temporal stores from where dst is aligned for
 * them (32 bytes with AVX, else 16): for output that the pass writes once and does not read
 * (megabytes of it would only push the BVH out of the caches). femb_stream_fence makes such
 * stores visible to other threads: femb_parallel_range runs it on each thread when its chunks are
 * done (one fence per thread and pass, not one per batch); code that streams outside a parallel
 * range calls it itself. */
void femb_stream_words(float *dst, const float *src, size_t n);
void femb_stream_fence(void);

/* Parallel for over tiles of the image: fn(ctx, x0, y0, x1, y1, user) per 64x4 tile, FTZ/DAZ on
 * in every worker, deterministic results whatever the thread count. */
void femb_parallel_tiles(femb_context *c, void (*fn)(femb_context *c, uint32_t x0, uint32_t y0,
                                                     uint32_t x1, uint32_t y1, void *user),
                         void *user);

/* The context's worker threads: started by femb_create, stopped by femb_destroy. */
tnd_result femb_pool_start(femb_context *c);
void femb_pool_stop(femb_context *c);

/* Parallel for over [0, count) in chunks, on the context's threads (FTZ/DAZ on): the pool's
 * workers and the calling thread; returns when every chunk is done. */
void femb_parallel_range(femb_context *c, size_t count, size_t chunk,
                         void (*fn)(femb_context *c, size_t begin, size_t end, void *user),
                         void *user);

/* A ray origin off the surface at p along the geometric normal n, by an offset that scales with
 * the coordinates' magnitude (shaders/offset.h; the GLSL mirror is offset_ray). Inline: lane
 * loops vectorise it. */
static inline v3 femb_offset_ray(v3 p, v3 n)
{
    return add(p, mul(n, tnd_offset_eps(tnd_max_abs3(p.x, p.y, p.z))));
}

/* ---- the estimator (femb_estimator.c), on batches of paths ---------------------------------- */

/* A batch of paths to trace: random-number keys (pixel and frame per lane; the sample word for
 * the batch: TND_SAMPLE_REALTIME, or tnd_reference_sample(s) in the reference mode), start rays
 * (from: the surface point a ray leaves, org its offset origin; an emitter's MIS pdf measures
 * the distance from `from`, as next-event estimation at that point does), the pdf of the BRDF
 * sample that chose each direction (0: none, an emitter hit gets the full weight), the ray
 * cone's width at the origin; inactive lanes are skipped and return 0. */
typedef struct femb_paths {
    FEMB_ALIGN uint32_t key_pixel[FEMB_LANES];
    uint32_t key_frame[FEMB_LANES];
    uint32_t key_sample;
    float from[3][FEMB_LANES], org[3][FEMB_LANES], dir[3][FEMB_LANES];
    float pdf_prev[FEMB_LANES], cone[FEMB_LANES];
    uint8_t active[FEMB_LANES];
    uint32_t n;
} femb_paths;
/* pdf_prev of a path whose previous vertex took every light of the list's share by itself (a
 * reservoir's sample, femb_restir.c): an emitter of the list or the environment map it finds gets
 * weight 0; emitters outside the list and the uniform sky keep theirs */
#define FEMB_PDF_RESERVOIR TND_PDF_RESERVOIR

/* Radiance arriving along each path from path vertex `bounce` on: emission (MIS-weighted against
 * the light list where pdf_prev > 0), NEE at each hit, more vertices up to max_bounce with
 * Russian roulette from rr_start; specular vertices do not count as bounces. first_t (NULL: not
 * wanted): each active lane's first segment length, TND_DEPTH_MISS where it escaped (the
 * contract's spec_hit; the GPU's trace_path keeps it in g_first_t). */
void femb_trace_paths(const femb_context *c, const femb_paths *paths, uint32_t bounce,
                      uint32_t max_bounce, uint32_t rr_start, float radiance[3][FEMB_LANES],
                      float *first_t);

/* The shading pass on n <= FEMB_LANES pixels of the frame's G-buffer (their rng keys too):
 * writes hf, lf_sh, lf_cocg and spec, and the undemodulated estimate to `radiance` when given. */
void femb_shade_pixels(const femb_context *c, const femb_params *p, tnd_frame *f,
                       const uint32_t *pixels, uint32_t n, float *radiance);
/* The same for the run of n pixels from q0 on, read from `stage`, the primary pass's G-buffer of
 * that run staged as a frame of n x 1 (femb_render: the batch shaded while its G-buffer is in the
 * cache): the same bits as femb_shade_pixels on those pixels of f, and for those that see no
 * surface what femb_shade writes (no signal; radiance: the emission). With S (a batch in which
 * every pixel sees its surface directly or the sky: no mirror or glass on the way), the
 * surfaces are taken from the primary pass's S instead of the stage; S's wo is overwritten. */
void femb_shade_staged(const femb_context *c, const femb_params *p, tnd_frame *f,
                       const tnd_frame *stage, femb_surfaces *S, uint32_t q0, uint32_t n,
                       float *radiance);

/* The specular vertex of surface s hit along `dir`: the new direction, the throughput factor,
 * the event (u: TND_DIM_SPLIT of the vertex) and whether the ray enters a glass volume.
 * femb_specular_direction does it about normal n; femb_specular_vertex uses the shading normal
 * unless the ray would then leave on the wrong side of the geometric surface (near the
 * silhouette of a smooth-shaded mesh), and the geometric normal there. */
v3 femb_specular_direction(const femb_surface *s, v3 n, v3 dir, float u, float f[3],
                           uint32_t *event, bool *enter);
v3 femb_specular_vertex(const femb_surface *s, v3 dir, float u, float f[3], uint32_t *event,
                        bool *enter);

/* The real-time reflect/refract chain of pixel (x, y) (femb_render.c): from the camera through up
 * to reflect_depth specular vertices to the surface the G-buffer shows. */
typedef struct femb_chain {
    bool hit;
    uint32_t inst, prim, vertices; /* vertices: specular vertices followed */
    uint32_t path;                 /* TND_PATH_* (the contract's path flags) */
    float u, v, length;            /* length: from the camera along the whole chain */
    float thr[3];
    v3 dir, dir0;                  /* the last segment's direction, the camera ray's */
} femb_chain;
/* Radiance seen along a camera ray (or one through a specular chain) that leaves the scene in
 * direction dir: the sky, or the environment map. */
void femb_miss_radiance(const femb_context *c, v3 dir, float out[3]);
void femb_specular_chain(const femb_context *c, uint32_t x, uint32_t y, bool follow,
                         femb_chain *r);

/* ReSTIR DI (femb_restir.c). femb_restir_frame: the reservoirs of frame f's pixels from its
 * G-buffer (candidates, the merge with the previous frame's along the motion vectors, the merge
 * with neighbours), before the shading pass. femb_restir_lookup: the reservoir the pixel with
 * random-number key (key_frame, key_pixel) shades with (this frame's, or the previous frame's for
 * a gradient sample), NULL where it has none. femb_restir_shade: its sample's light at surface s
 * (one shadow ray from org), diffuse (demodulated) and specular, times W. */
tnd_result femb_restir_frame(femb_context *c, const tnd_frame *f);
const femb_reservoir *femb_restir_lookup(const femb_context *c, uint32_t key_frame,
                                         uint32_t key_pixel);
void femb_restir_shade(const femb_context *c, const femb_reservoir *r, const femb_rsurf *s,
                       v3 org, float diff[3], float spec[3]);
void femb_restir_free(femb_restir *rs);

#endif
