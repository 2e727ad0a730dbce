/* pipeline/pl_internal.h: the tables of operations a front-end and a denoiser implement
 * (pl_frontend.c holds the front-ends' registry and the Vulkan and Embree adapters, pl_replay.c
 * the capture replay; pl_denoiser.c the denoisers' registry and the built-in back-end's
 * adapter; pl_plugin.c the plugins' adapters). */
#ifndef PL_INTERNAL_H
#define PL_INTERNAL_H

#include "pipeline/pipeline.h"

/* words per gradient sample in the back-end's host list (denoise.h's DN_GRADIENT_WORDS) */
#define PL_GRADIENT_WORDS 7u

typedef struct pl_frontend_ops {
    const char *name;
    uint32_t caps;
    tnd_result (*create)(const tnd_scene *scene, const pl_frontend_desc *d, void **ctx);
    void (*destroy)(void *ctx);
    void (*describe)(const void *ctx, char *buf, size_t cap);
    const char *(*models)(const void *ctx);
    tnd_result (*set_frame)(void *ctx, const tnd_scene_state *cur, const tnd_scene_state *prev,
                            uint32_t frame, uint32_t w, uint32_t h);
    tnd_result (*render)(void *ctx, const pl_params *p, tnd_frame *host, pl_timings *t);
    const tnd_contract_gpu *(*contract)(const void *ctx);
    tnd_result (*reshade)(void *ctx, const pl_params *p, const uint32_t *words, uint32_t n,
                          tnd_frame *host, pl_timings *t);
    tnd_result (*reshade_slots)(void *ctx, const pl_params *p, VkBuffer slots, uint32_t n,
                                uint32_t row, pl_timings *t);
    /* PL_CAP_SHADE_SLOTS: render in two steps, the slots re-shaded in the second */
    tnd_result (*render_primary)(void *ctx, const pl_params *p);
    tnd_result (*render_shade)(void *ctx, const pl_params *p, VkBuffer slots, uint32_t row,
                               pl_timings *t);
    tnd_result (*reference)(void *ctx, uint32_t max_bounces, uint32_t first, uint32_t count,
                            double *sum_rgb, double *sum_lum2, tnd_ref_stats *stats,
                            void (*progress)(uint32_t, uint32_t, void *), void *user);
    /* a matched reference's samples composited and summed where the contract is (NULL: the
     * caller renders each sample and composites it on the host) */
    tnd_result (*matched)(void *ctx, uint32_t bounces, uint32_t first, uint32_t count,
                          double *sum_rgb, double *sum_lum2, tnd_ref_stats *stats,
                          void (*progress)(uint32_t, uint32_t, void *), void *user);
    tnd_result (*benchmark)(void *ctx, const pl_params *p, uint32_t repeats, pl_bench *out);
    tnd_result (*timings)(void *ctx, bool wait, pl_timings *t); /* PL_CAP_QUEUED */
    void (*cpu)(const void *ctx, uint32_t *threads, const char **simd);
    /* recorded front-ends (PL_CAP_RECORDED) */
    uint32_t (*length)(const void *ctx);
    const char *(*frame_name)(const void *ctx, uint32_t i);
    bool (*can_reshade)(const void *ctx); /* NULL: as caps says */
    bool (*recorded)(const void *ctx, uint32_t *w, uint32_t *h, tnd_precision *p, bool *split);
    bool (*has_entry)(const void *ctx, tnd_ct e); /* its frames carry entry e */
} pl_frontend_ops;


extern const pl_frontend_ops pl_replay_ops;

/* ---- plugins (pl_plugin.c) --------------------------------------------------------------------- */
#include "include/tandem/tandem_plugin.h"

extern const pl_frontend_ops pl_plugin_frontend_ops;
/* The camera of frame `frame` from the scene's states (prev NULL: cur). */
void pl_camera_from_states(const tnd_scene_state *cur, const tnd_scene_state *prev,
                           uint32_t frame, pl_camera *cam);
/* The ABI's per-frame settings; df NULL: no jitter history, spread or reset; p NULL: one
 * bounce, the real-time sample word. */
void pl_plugin_settings(const pl_camera *cam, uint32_t w, uint32_t h, const pl_params *p,
                        const dn_frame *df, float dt, tnd_precision precision,
                        tandem_frame_settings *s);

/* A denoiser plugin: its state, its output image (RGBA32F). */
typedef struct pl_dnp pl_dnp;
tnd_result pl_dnp_create(tnd_vk *vk, const char *path, uint32_t w, uint32_t h,
                         tnd_precision precision, pl_dnp **out);
void pl_dnp_destroy(pl_dnp *d);
uint64_t pl_dnp_reads(const pl_dnp *d);
const char *pl_dnp_name(const pl_dnp *d);
const tnd_image *pl_dnp_output(const pl_dnp *d);
/* Record the plugin's frame into cmd, between full barriers. */
tnd_result pl_dnp_record(pl_dnp *d, VkCommandBuffer cmd, const tandem_frame_settings *s,
                         const tnd_contract_gpu *ct, const tnd_image *radiance);

/* ---- the frame's passes (pl_chain.c): the front-end's and the post chain's ------------------ */
extern const pl_pass pl_frontend_passes[], pl_post_passes[];
extern const uint32_t pl_frontend_pass_count, pl_post_pass_count;

/* ---- denoisers ---------------------------------------------------------------------------- */
typedef struct pl_dn_desc {
    tnd_vk *vk;
    uint32_t width, height;
    tnd_precision precision;
    const pl_param_set *params; /* values given for its parameters */
    const dn_desc *backend;     /* the built-in back-end's other settings (may be NULL) */
    const char *path;           /* plugins: the shared object */
    const void *data;           /* the ops table's `data` */
    uint32_t npasses;           /* its info.npasses */
} pl_dn_desc;

/* One frame's input: the contract, the frame's parameters, and what a plugin's settings are made
 * of (the camera, the front-end's parameters, seconds since the last frame). */
typedef struct pl_dn_input {
    const tnd_contract_gpu *contract;
    const dn_frame *frame;
    const pl_camera *camera;
    const pl_params *params;
    float dt;
} pl_dn_input;

typedef struct pl_denoiser_ops {
    pl_denoiser_info info;
    const void *data; /* handed to create (pl_dn_desc.data) */
    tnd_result (*create)(const pl_dn_desc *d, void **ctx);
    void (*destroy)(void *ctx);
    /* PL_DN_GRADIENTS: this frame's gradient samples, to the host (words, PL_GRADIENT_WORDS
     * each, room for capacity()) or left on the GPU (slots: the buffer, *n its slots in rows
     * of *row) */
    uint32_t (*capacity)(const void *ctx);
    tnd_result (*select)(void *ctx, const tnd_contract_gpu *ct, const dn_frame *f,
                         uint32_t *words, VkBuffer *slots, uint32_t *n, uint32_t *row);
    /* the host's re-shaded samples of the host list: `reshaded` at those pixels (the frame
     * submitted next stays as rendered) */
    tnd_result (*gradient_values)(void *ctx, const uint32_t *words, uint32_t n,
                                  const tnd_frame *reshaded);
    /* record and submit the frame (not waited for); wait for it: its passes' times */
    tnd_result (*submit)(void *ctx, const pl_dn_input *in);
    tnd_result (*wait)(void *ctx, double *ms, bool *beside);
    const tnd_image *(*output)(const void *ctx);
    /* optional: the built-in back-end's context (PL_DN_DUMPS), the bytes per pass, the plugin's
     * own name */
    dn_context *(*backend)(void *ctx);
    void (*traffic)(const void *ctx, double *bytes);
    const char *(*plugin_name)(const void *ctx);
} pl_denoiser_ops;

/* A registered denoiser's operations by name ("plugin:PATH": the plugin adapter's); NULL for
 * an unknown name. */
const pl_denoiser_ops *pl_denoiser_ops_find(const char *name);
/* The plugin adapter (pl_plugin.c): "plugin:PATH". */
extern const pl_denoiser_ops pl_plugin_denoiser_ops;
/* The host adapter for Python (pl_plugin.c): "python:MODULE:CALLABLE". */
extern const pl_denoiser_ops pl_python_denoiser_ops;
/* The built-in back-end in mode off (pl_dn_backend.c): what the plugin adapter composites the
 * noisy radiance with. */
extern const pl_denoiser_ops pl_off_ops;

#endif
