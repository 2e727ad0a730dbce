/* pipeline: the frame, written once. A front-end is a table of operations (pl_frontend_ops)
 * that every front-end implements: the Vulkan ray tracer, the Embree tracer and capture replay
 * ("replay": a recorded sequence that re-shades only from stored gradient samples) are
 * registered here, and app/ reaches them only through pl_frontend_*: it names no fvk_/femb_
 * function.
 * Prefix pl_; depends on core/, frontend_vk/, frontend_embree/ (and denoise/ for the gradient
 * layout). */
#ifndef PL_PIPELINE_H
#define PL_PIPELINE_H

#include "composite/composite.h"
#include "core/core.h"
#include "denoise/denoise.h"

/* One real-time frame's parameters (as femb_params / fvk_params). */
typedef struct pl_params {
    uint32_t bounces; /* indirect bounces after the primary surface */
    uint32_t sample;  /* sample word: 0 (TND_SAMPLE_REALTIME), a matched reference's s + 1 */
    bool set_jitter;  /* replace the frame's Halton jitter by `jitter` (pixels) */
    float jitter[2];
} pl_params;

/* What the last call took: GPU timestamps (Vulkan) or the CPU's wall clock (Embree, which does
 * both passes in one sweep: primary_ms, shade_ms 0). */
typedef struct pl_timings {
    double primary_ms, shade_ms, tlas_ms, gradient_ms;
} pl_timings;

enum {
    PL_CAP_GPU_CONTRACT = 1u, /* fills the contract on the GPU (pl_frontend_contract) */
    PL_CAP_RESHADE = 2u,      /* re-shades gradient samples (A-SVGF) */
    PL_CAP_REFERENCE = 4u,    /* renders unbiased references */
    PL_CAP_BENCHMARK = 8u,    /* measures its rays against the bare tracer (pl_frontend_benchmark) */
    PL_CAP_RECORDED = 16u,    /* a recorded sequence: pl_frontend_length frames, set by index */
    PL_CAP_QUEUED = 32u,      /* render and re-shade without `t` only submit to the GPU's queue;
                                 pl_frontend_timings gives their times later */
};

typedef struct pl_frontend_desc {
    tnd_vk *vk;              /* GPU front-ends: the caller's context (ray tracing on) */
    tnd_precision precision; /* of the contract */
    const char *rt_api;      /* vk: "pipeline", "query" or "auto" (NULL: auto) */
    bool full_pipeline;      /* vk: every shader variant */
    uint32_t reflect_depth;  /* mirrors/glass the primary pass follows (0: 4) */
    uint32_t threads;        /* embree: CPU threads (0: all) */
    const char *captures;    /* replay: the capture directory (or a run's output, DIR/capture) */
    const struct tnd_capture_map *map; /* replay: another renderer's mapping (NULL: Tandem's) */
    const char *scene_path;  /* plugins: what the user passed as the scene */
    const char *plugin;      /* set by pl_frontend_create from "plugin:PATH" */
} pl_frontend_desc;

/* The camera of a front-end's current frame (pl_frontend_set_frame): matrices of this and the
 * previous frame, the Halton jitter, the position and the scene time. */
typedef struct pl_camera {
    tnd_camera_state state;
    float position[3];
    double time;
} pl_camera;

typedef struct pl_frontend pl_frontend;

/* The registered front-ends' names, comma-separated ("embree, vk"); "plugin:PATH" loads a
 * front-end plugin (include/tandem/tandem_plugin.h) from a shared object. */
const char *pl_frontend_names(void);
/* Whether the named front-end needs a Vulkan context with ray tracing (false for unknown). */
bool pl_frontend_needs_gpu(const char *name);
tnd_result pl_frontend_create(const char *name, const tnd_scene *scene, const pl_frontend_desc *d,
                              pl_frontend **fe);
void pl_frontend_destroy(pl_frontend *fe);
uint32_t pl_frontend_caps(const pl_frontend *fe);
/* "Vulkan ray-tracing pipeline on NAME", "Embree, 8 threads" */
const char *pl_frontend_describe(const pl_frontend *fe, char *buf, size_t cap);
/* The shader variant in use (what the scene needs), or a fixed text for CPU front-ends. */
const char *pl_frontend_models(const pl_frontend *fe);
tnd_result pl_frontend_set_frame(pl_frontend *fe, const tnd_scene_state *cur,
                                 const tnd_scene_state *prev, uint32_t frame, uint32_t width,
                                 uint32_t height);
/* The current frame's camera (NULL before the first set_frame). */
const pl_camera *pl_frontend_camera(const pl_frontend *fe);
/* Fill the frame's contract: on the GPU for PL_CAP_GPU_CONTRACT front-ends, and into `host`
 * (quantised to the precision; with the camera) when it is not NULL (a GPU front-end downloads
 * it). */
tnd_result pl_frontend_render(pl_frontend *fe, const pl_params *p, tnd_frame *host,
                              pl_timings *t);
/* A PL_CAP_QUEUED front-end's GPU times of a render and its re-shading: with `wait`, of the last
 * submitted (waits for them); without, of the frame before the one just rendered (no wait). For
 * other front-ends t is left as their render and re-shade calls filled it. */
tnd_result pl_frontend_timings(pl_frontend *fe, bool wait, pl_timings *t);
/* The GPU contract of the last render (NULL for host front-ends). */
const tnd_contract_gpu *pl_frontend_contract(const pl_frontend *fe);
/* Re-shade gradient samples (DN_GRADIENT_WORDS words each, the back-end's host list): on the GPU
 * contract for GPU front-ends (host untouched), else into `host` (then quantised). */
tnd_result pl_frontend_reshade(pl_frontend *fe, const pl_params *p, const uint32_t *words,
                               uint32_t count, tnd_frame *host, pl_timings *t);
/* The same from the back-end's GPU slot buffer (GPU front-ends only). */
tnd_result pl_frontend_reshade_slots(pl_frontend *fe, const pl_params *p, VkBuffer slots,
                                     uint32_t count, pl_timings *t);
/* A recorded front-end's frames (0 for a live one) and frame i's name (its file). */
uint32_t pl_frontend_length(const pl_frontend *fe);
const char *pl_frontend_frame_name(const pl_frontend *fe, uint32_t i);
/* A recorded front-end's frame size, precision and whether its first frame splits pixels into
 * checkerboard fields (the post chain's interleave); false for a live one. */
bool pl_frontend_recorded(const pl_frontend *fe, uint32_t *width, uint32_t *height,
                          tnd_precision *precision, bool *split);
/* A CPU front-end's benchmark of the current frame (PL_CAP_BENCHMARK): the frame, each pass
 * alone, and the same rays replayed through the bare tracer (femb_benchmark's figures). */
typedef struct pl_bench {
    double frame_ms, primary_ms, shade_ms, raw_ms, raw_primary_ms;
    uint64_t rays, primary_rays;
} pl_bench;
tnd_result pl_frontend_benchmark(pl_frontend *fe, const pl_params *p, uint32_t repeats,
                                 pl_bench *out);
/* A CPU front-end's threads and instruction set (0 and NULL for a GPU one). */
void pl_frontend_cpu(const pl_frontend *fe, uint32_t *threads, const char **simd);
/* Samples [first, first + count) of an unbiased reference of the current frame (max_bounces 0:
 * full paths) added to per-pixel double sums of RGB (3 per pixel) and luminance^2 (1 per pixel)
 * (femb_reference_add: a range split at multiples of TND_REF_CHECK_EVERY adds up as the whole
 * range); stats->until_noise stops early, stats->spp: the samples the sums hold after. */
tnd_result pl_frontend_reference_add(pl_frontend *fe, uint32_t max_bounces, uint32_t first,
                                     uint32_t count, double *sum_rgb, double *sum_lum2,
                                     tnd_ref_stats *stats,
                                     void (*progress)(uint32_t done, uint32_t total, void *user),
                                     void *user);
/* An unbiased reference of the current frame (max_bounces 0: full paths), finished: the mean in
 * rgb, each pixel's standard error in lum_se (optional), stats (optional) as tnd_ref_finish. */
tnd_result pl_frontend_reference(pl_frontend *fe, uint32_t max_bounces, uint32_t spp, float *rgb,
                                 float *lum_se, tnd_ref_stats *stats,
                                 void (*progress)(uint32_t done, uint32_t total, void *user),
                                 void *user);

/* ---- the frame after the front-end (pl_chain.c) -------------------------------------------- */
typedef struct pl_chain_desc {
    tnd_vk *vk;              /* the back-end's and post chain's context (backend) */
    uint32_t width, height;
    tnd_precision precision; /* of the contract */
    bool backend;            /* the Vulkan back-end (false: the CPU composite, no Vulkan) */
    dn_desc denoise;         /* its mode and knobs (the precision is the chain's) */
    cmp_desc post;
    bool no_post;            /* the back-end alone (bench) */
    /* a denoiser plugin (include/tandem/tandem_plugin.h) in place of the back-end's filters:
     * the back-end runs in mode off (the noisy radiance the plugin may read), the plugin's
     * output goes to the post chain */
    const char *denoiser_plugin;
    bool host_contract;      /* bring a GPU front-end's contract to the host every frame (what
                                the chain did before it kept it on the GPU; for measurements) */
} pl_chain_desc;

typedef struct pl_step {
    pl_params params;       /* the front-end's */
    dn_frame frame;         /* jitter, spread, reset */
    bool frame_from_host;   /* recorded frames: jitter and spread from the frame's camera (yfov
                               when it has none), the previous jitter kept by the chain */
    double yfov;            /* degrees */
    float dt;               /* seconds since the previous frame (post) */
    const char *capture;    /* write the frame's capture there (and its gradient samples beside) */
    /* called after the back-end ran, before the post chain (dumps) */
    tnd_result (*after_backend)(dn_context *dn, void *user);
    void *user;
    /* do not wait for this frame's back-end and post: the host goes on to the next frame while
     * the device works (ignored when the caller takes its pixels: hdr, display, after_backend) */
    bool no_wait;
} pl_step;

typedef struct pl_step_result {
    pl_timings fe;
    dn_timings dn;
    cmp_timings post;
    /* dn and post, and fe for a PL_CAP_QUEUED front-end, hold the previous frame's GPU times
     * (that frame was not waited for; a frame not waited for leaves them 0 for the next call or
     * pl_chain_finish) */
    bool lagged;
    double plugin_ms; /* a denoiser plugin's GPU time (lagged as dn) */
} pl_step_result;

typedef struct pl_chain pl_chain;
tnd_result pl_chain_create(const pl_chain_desc *d, pl_chain **chain);
void pl_chain_destroy(pl_chain *chain);
/* One frame: the front-end's (set by the caller with pl_frontend_set_frame), then selection,
 * re-shading, back-end and post; the linear HDR output (3 floats per pixel) and the display
 * image (3 bytes) when asked (not NULL). Without the back-end, hdr receives the CPU composite. */
tnd_result pl_chain_run(pl_chain *chain, pl_frontend *fe, const pl_step *step, float *hdr,
                        uint8_t *display, pl_step_result *result);
/* Wait for a frame run with no_wait; its back-end and post times (lagged; zero when none). */
tnd_result pl_chain_finish(pl_chain *chain, pl_step_result *result);
dn_context *pl_chain_denoiser(pl_chain *chain);
/* The contract the last frame ran on, on the GPU (the front-end's, or the chain's upload of a
 * host front-end's); NULL before the first frame or without the back-end. */
const tnd_contract_gpu *pl_chain_contract(const pl_chain *chain);
/* A denoiser plugin's name (NULL without one). */
const char *pl_chain_plugin_name(const pl_chain *chain);
cmp_context *pl_chain_post(pl_chain *chain);

#endif
