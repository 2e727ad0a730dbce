/* pipeline: the frame, written once, and what the pipeline is, as data. A front-end is a table
 * of operations (pl_frontend_ops) that every front-end implements: the Vulkan ray tracer, the
 * Embree tracer and capture replay ("replay": a recorded sequence that re-shades only from
 * stored gradient samples) are registered here, and app/ reaches them only through
 * pl_frontend_*: it names no fvk_/femb_ function. A denoiser is the same (pl_denoiser_ops in
 * pl_denoiser.c): svgf, asvgf and off (the built-in back-end), plugins through an adapter,
 * Python denoisers (python:MODULE:CALLABLE) through the host adapter; each
 * declares its capabilities, its parameters (pl_param: the command line, run.json, the
 * viewer's keys and states, the sweep's knobs are made from them) and the passes it times
 * (pl_pass: every timings writer prints from pl_chain_passes). docs/extending.md says how to
 * add one.
 * Prefix pl_; depends on core/, frontend_vk/, frontend_embree/, denoise/, composite/. */
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
    bool half_indirect; /* the indirect paths of half the pixels, a checkerboard that alternates
                           each frame, weighted 2 (`--bounces half`; femb_params) */
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
    PL_CAP_SHADE_SLOTS = 64u, /* renders in two steps, primary then shading, and re-shades the
                                 back-end's slots inside the shading pass
                                 (pl_frontend_render_primary, pl_frontend_render_shade) */
};

/* A capability bit's name ("gpu_contract", "reshade", ...; NULL past the last), for listings. */
const char *pl_frontend_cap_name(uint32_t bit);

typedef struct pl_frontend_desc {
    tnd_vk *vk;              /* GPU front-ends: the caller's context (ray tracing on) */
    tnd_precision precision; /* of the contract */
    const char *rt_api;      /* vk: "pipeline", "query" or "auto" (NULL: auto) */
    bool full_pipeline;      /* vk: every shader variant */
    uint32_t reflect_depth;  /* mirrors/glass the primary pass follows (0: 4) */
    /* vk, embree: the pixel footprint that filters textures (ray cones), over the traced pixel's:
     * the traced size over the shown size where the frame is upscaled (--render-scale), so that
     * textures are filtered for the shown pixels, as the full size's and its matched reference
     * are (FSR 2's and DLSS's mip bias, log2 of it); 0: 1 */
    float footprint_scale;
    tnd_light_sampling lights; /* embree, vk: how NEE picks its light (auto: by the scene) */
    bool references;         /* vk: for references (their shader variant made at creation) */
    uint32_t bounces;        /* vk: the bounces its real-time shaders are first built for (0: 1) */
    bool half_indirect;      /* vk: ... and for --bounces half */
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
 * contract for GPU front-ends (host untouched), else into `host` (then quantised), in place
 * (pl_chain_run takes the values to the back-end and gives it the frame as rendered). */
tnd_result pl_frontend_reshade(pl_frontend *fe, const pl_params *p, const uint32_t *words,
                               uint32_t count, tnd_frame *host, pl_timings *t);
/* The same from the back-end's GPU slot buffer (GPU front-ends only): `count` slots in rows of
 * `row` (the strata's grid), into the slots themselves (the contract stays as rendered). */
tnd_result pl_frontend_reshade_slots(pl_frontend *fe, const pl_params *p, VkBuffer slots,
                                     uint32_t count, uint32_t row, pl_timings *t);
/* pl_frontend_render in two steps (PL_CAP_SHADE_SLOTS, GPU front-ends), so that the back-end's
 * gradient selection, which reads the primary pass's G-buffer, runs between them: the primary
 * pass, then the shading pass, which also re-shades the samples the slots name (`row` per row
 * of the strata's grid; VK_NULL_HANDLE: none) as pl_frontend_reshade_slots would after it,
 * without a launch of their own. No host copy: a caller that wants the frame on the host (a
 * capture) renders in one step. */
tnd_result pl_frontend_render_primary(pl_frontend *fe, const pl_params *p);
tnd_result pl_frontend_render_shade(pl_frontend *fe, const pl_params *p, VkBuffer slots,
                                    uint32_t row, pl_timings *t);
/* A recorded front-end's frames (0 for a live one) and frame i's name (its file). */
uint32_t pl_frontend_length(const pl_frontend *fe);
const char *pl_frontend_frame_name(const pl_frontend *fe, uint32_t i);
/* A recorded front-end's frame size, precision and whether its first frame splits pixels into
 * checkerboard fields (the post chain's interleave); false for a live one. */
bool pl_frontend_recorded(const pl_frontend *fe, uint32_t *width, uint32_t *height,
                          tnd_precision *precision, bool *split);
/* Whether a recorded front-end's frames carry contract entry e (absent: its default); true for
 * a live one. */
bool pl_frontend_recorded_has(const pl_frontend *fe, tnd_ct e);
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
/* A matched reference's samples [first, first + count) of the current frame, composited,
 * interleaved and summed where the front-end keeps its contract (the Vulkan one: on the device,
 * float per batch of TND_REF_CHECK_EVERY, double across), the same sums as rendering each
 * sample (pl_params: bounces, sample word tnd_reference_sample(s), the image's offset
 * tnd_rand(0, frame, word, TND_DIM_JITTER_*) - 1/2) and tnd_frame_composite + interleave on the
 * host; pl_frontend_has_matched says whether it can. */
bool pl_frontend_has_matched(const pl_frontend *fe);
tnd_result pl_frontend_matched_add(pl_frontend *fe, uint32_t bounces, uint32_t first,
                                   uint32_t count, double *sum_rgb, double *sum_lum2,
                                   tnd_ref_stats *stats,
                                   void (*progress)(uint32_t done, uint32_t total, void *user),
                                   void *user);
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

/* The named front-end is registered, or "plugin:PATH" with a path; live: one that renders a
 * scene (not a recorded sequence: what render's --frontend takes), and their names
 * ("embree, vk, plugin:PATH"); a registered front-end's capabilities without creating it (0 for
 * an unknown name and for plugins, whose adapter declares none). */
bool pl_frontend_known(const char *name);
bool pl_frontend_live(const char *name);
const char *pl_frontend_live_names(void);
uint32_t pl_frontend_caps_of(const char *name);
/* The i-th registered front-end's name (NULL past the last). */
const char *pl_frontend_name_at(uint32_t i);

/* ---- denoisers (pl_denoiser.c): the registry beside the front-ends' -------------------------- */
/* A denoiser's parameter. Its value 0 always means the denoiser's own default (said in help),
 * as in the *_desc structs; other values must lie in [min, max] (min itself excluded when
 * min_open) and be whole for PL_PARAM_UINT. */
typedef enum pl_param_kind { PL_PARAM_FLOAT = 0, PL_PARAM_UINT } pl_param_kind;
typedef struct pl_param {
    const char *name; /* --NAME on the command line and the sweep's knob; run.json and the
                         viewer's states: NAME with '_' for '-' */
    pl_param_kind kind;
    double min, max;
    bool min_open;
    const char *arg, *help; /* the help's placeholder and text (with the default) */
    /* tandem view: one key cycles through steps[0..nsteps) (steps[0] is 0: the default); two
     * keys step down and up */
    const char *keys;
    double steps[6];
    uint32_t nsteps;
} pl_param;

/* Values given for parameters (by name; the others keep their defaults). */
#define PL_PARAMS_MAX 16
typedef struct pl_param_set {
    uint32_t n;
    const pl_param *param[PL_PARAMS_MAX];
    double value[PL_PARAMS_MAX];
} pl_param_set;
/* Every parameter of every registered denoiser, each name once (the command line's options). */
uint32_t pl_param_count(void);
const pl_param *pl_param_at(uint32_t i);
const pl_param *pl_param_find(const char *name);
/* Set a value (0: back to the default), checked against the parameter's range: an error names
 * the parameter and the range. */
tnd_result pl_param_set_put(pl_param_set *s, const char *name, double v);
/* The value given for `name`, or 0 (the default). */
double pl_param_set_get(const pl_param_set *s, const char *name);
/* The key of a parameter in run.json and view states ("min-alpha" -> "min_alpha"). */
const char *pl_param_key(const pl_param *p, char *buf, size_t cap);

enum {
    PL_DN_GRADIENTS = 1u, /* needs re-shaded gradient samples (A-SVGF): the chain selects them,
                             the front-end re-shades them */
    PL_DN_FILTERS = 2u,   /* filters (not only composites): runs on the Vulkan back-end even
                             behind a host front-end */
    PL_DN_DUMPS = 4u,     /* the built-in back-end's buffers (--dump, the viewer's views) are its */
    PL_DN_PLUGIN = 8u,    /* loaded from a shared object (include/tandem/tandem_plugin.h) */
    PL_DN_CONFIDENCE = 16u, /* uses re-shaded gradient samples where the front-end gives them
                               (as a confidence in its history) and runs without them elsewhere */
    PL_DN_SPEC_HIT = 32u, /* follows reflections by the contract's spec_hit where it is given */
    PL_DN_DIFFUSE_VIEW = 64u, /* keeps the contract's diffuse_view out of its histories where it
                                 is given (docs/denoise.md, "The diffuse lobe's view factor") */
};

/* A capability bit's name ("gradients", "filters", ...; NULL past the last). */
const char *pl_denoiser_cap_name(uint32_t bit);

/* A pass the frame times. Groups as bench --whole-frame reports them. */
typedef enum pl_pass_group {
    PL_GROUP_FRONTEND = 0,
    PL_GROUP_GRADIENTS,
    PL_GROUP_BACKEND,
    PL_GROUP_POST,
    PL_GROUPS
} pl_pass_group;
typedef struct pl_pass {
    const char *name;    /* "temporal" */
    const char *key;     /* timings.json's: "denoise_temporal_ms" */
    pl_pass_group group;
    const char *beside;  /* when the step says `beside`, this pass ran beside the named one, whose
                            time covers both (its own reads 0) */
} pl_pass;
const char *pl_pass_group_name(pl_pass_group g); /* "front-end", "gradients", "back-end", "post" */

#define PL_DN_MAX_PASSES 8
typedef struct pl_denoiser_info {
    const char *name;     /* --denoiser NAME ("plugin" for plugins) */
    const char *summary;  /* one line for help texts */
    uint32_t caps;        /* PL_DN_* */
    const char *fallback; /* run instead behind a front-end that cannot re-shade (PL_DN_GRADIENTS) */
    const pl_param *const *params;
    uint32_t nparams;
    const pl_pass *passes; /* its passes in order, each frame */
    uint32_t npasses;
} pl_denoiser_info;
/* The registered denoisers' names, comma-separated ("asvgf, svgf, off"). */
const char *pl_denoiser_names(void);
/* The default denoiser (the first registered: "asvgf"), and the first with all of `caps`. */
const char *pl_denoiser_default(void);
const pl_denoiser_info *pl_denoiser_with(uint32_t caps);
uint32_t pl_denoiser_count(void);
const pl_denoiser_info *pl_denoiser_at(uint32_t i);
/* A denoiser by its name, or "plugin:PATH" (the plugin adapter's description); an error lists
 * the names. */
tnd_result pl_denoiser_find(const char *name, const pl_denoiser_info **info);
bool pl_denoiser_has_param(const pl_denoiser_info *d, const char *name);
/* Python denoisers (--denoiser python:MODULE:CALLABLE) run through a host denoiser plugin
 * (include/tandem/tandem_plugin.h): the Python bridge PL_PYTHON_BRIDGE, which starts an
 * interpreter in the process, or, in a process that is Python already (the tandem package),
 * the description it sets here (NULL: the bridge again). */
#define PL_PYTHON_BRIDGE "libtandem_pybridge.so"
struct tandem_plugin;
void pl_python_set(const struct tandem_plugin *d);
/* What runs behind a front-end with capabilities fe_caps: d, or its fallback where d needs
 * re-shaded gradient samples the front-end cannot give. */
const pl_denoiser_info *pl_denoiser_for(const pl_denoiser_info *d, uint32_t fe_caps);
/* "The other denoiser" of a comparison (the viewer's split): a denoiser's fallback, or the one
 * whose fallback it is, or the first that filters without gradient samples. */
const pl_denoiser_info *pl_denoiser_other(const pl_denoiser_info *d);
/* Every pass any frame may time, each key once, in frame order: the front-end's, every
 * registered denoiser's (and the plugin adapter's), the post chain's (readers of timings.json). */
uint32_t pl_pass_all(const pl_pass **passes, uint32_t max);
/* Whose pass it is: the front-end's, the denoiser's or the post chain's. */
typedef enum pl_pass_owner { PL_OWNER_FRONTEND = 0, PL_OWNER_DENOISER, PL_OWNER_POST } pl_pass_owner;
pl_pass_owner pl_pass_owner_of(const pl_pass *p);

/* ---- the frame after the front-end (pl_chain.c) -------------------------------------------- */
typedef struct pl_chain_desc {
    tnd_vk *vk;              /* the back-end's and post chain's context (backend) */
    uint32_t width, height;  /* what the front-end traces and the back-end denoises */
    /* the post chain's output, larger where the frames are rendered at a smaller scale and
     * upscaled (post.upscaler; 0: width x height) */
    uint32_t out_width, out_height;
    tnd_precision precision; /* of the contract */
    bool backend;            /* the Vulkan back-end (false: the CPU composite, no Vulkan) */
    /* the denoiser by its registered name or "plugin:PATH" (NULL: the built-in back-end's
     * denoise.mode, for callers from before the registry), and the parameters given */
    const char *denoiser;
    pl_param_set params;
    dn_desc denoise;         /* the built-in back-end's settings beyond the parameters (profiling,
                                tests; the precision is the chain's) */
    cmp_desc post;
    bool no_post;            /* the back-end alone (bench) */
    bool host_contract;      /* bring a GPU front-end's contract to the host every frame (what
                                the chain did before it kept it on the GPU; for measurements) */
    bool separate_reshade;   /* re-shade gradient samples in a launch of their own after the
                                shading pass, also where the front-end can fold them into it
                                (PL_CAP_SHADE_SLOTS; the same contract; for measurements) */
} pl_chain_desc;

typedef struct pl_step {
    pl_params params;       /* the front-end's */
    dn_frame frame;         /* jitter, spread, reset */
    bool frame_from_host;   /* recorded frames: jitter and spread from the frame's camera (yfov
                               when it has none), the previous jitter kept by the chain */
    double yfov;            /* degrees */
    float dt;               /* seconds since the previous frame (post) */
    const char *capture;    /* write the frame's capture there (and its gradient samples beside) */
    tnd_frame *host_out;    /* a copy of the frame's contract as the front-end gave it (what the
                               capture holds), into this frame (tnd_frame_copy) */
    /* called after the back-end ran, before the post chain (dumps) */
    tnd_result (*after_backend)(dn_context *dn, void *user);
    void *user;
    /* do not wait for this frame's back-end and post: the host goes on to the next frame while
     * the device works (ignored when the caller takes its pixels: hdr, display, after_backend) */
    bool no_wait;
} pl_step;

typedef struct pl_step_result {
    pl_timings fe;
    double dn[PL_DN_MAX_PASSES]; /* the denoiser's passes' GPU times (pl_denoiser_info.passes) */
    bool beside;                 /* passes with `beside` ran beside another (pl_pass) */
    cmp_timings post;
    /* dn and post, and fe for a PL_CAP_QUEUED front-end, hold the previous frame's GPU times
     * (that frame was not waited for; a frame not waited for leaves them 0 for the next call or
     * pl_chain_finish) */
    bool lagged;
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
/* The denoiser that runs (after pl_denoiser_for) and the built-in back-end's context when it is
 * the built-in's (PL_DN_DUMPS: dumps, traffic, per-dispatch times; NULL otherwise). */
const pl_denoiser_info *pl_chain_denoiser_info(const pl_chain *chain);
/* Whether the chain's denoiser takes re-shaded gradient samples behind this front-end (it asks
 * for them, or takes them where the front-end can re-shade), and whether the re-shading can be
 * folded into the front-end's shading pass (the front-end shades slots; a frame that goes to the
 * host as rendered, or pl_chain_desc.separate_reshade, keeps the separate re-shading). */
bool pl_chain_takes_gradients(const pl_chain *chain, const pl_frontend *fe);
bool pl_chain_can_fold(const pl_chain *chain, const pl_frontend *fe);
dn_context *pl_chain_denoiser(pl_chain *chain);
/* The frame's passes in order (the front-end's, the denoiser's, the post chain's; the post
 * chain's only with it) and a step's times in the same order: what every timings writer prints. */
uint32_t pl_chain_passes(const pl_chain *chain, const pl_pass **passes, uint32_t max);
void pl_step_times(const pl_chain *chain, const pl_step_result *r, double *ms);
/* The bytes each of the denoiser's passes must move at the least (its bandwidth floor; 0 where
 * it does not say), in the order of its passes. */
void pl_chain_traffic(const pl_chain *chain, double *bytes);
/* The contract the last frame ran on, on the GPU (the front-end's, or the chain's upload of a
 * host front-end's); NULL before the first frame or without the back-end. */
const tnd_contract_gpu *pl_chain_contract(const pl_chain *chain);
/* A denoiser plugin's own name (NULL without one). */
const char *pl_chain_plugin_name(const pl_chain *chain);
cmp_context *pl_chain_post(pl_chain *chain);

#endif
