/* frontend_embree: the CPU front-end on Embree 3. It fills the contract in host memory with the
 * same estimator as frontend_vk (shared scalar code in shaders/brdf.h, shared random numbers in
 * shaders/sampling.h, shared light list in shaders/lights.h), and renders references.
 *
 * Use: femb_create once per scene; per frame femb_set_frame (current and previous scene state),
 * then femb_render (G-buffer, visibility, motion, rng keys, hf, lf, spec), which is
 * femb_trace_primary and femb_shade in one sweep, or femb_shade_gradients for the back-end's gradient samples; femb_reference for converged
 * images. Depends on core/ only. */
#ifndef FEMB_FRONTEND_EMBREE_H
#define FEMB_FRONTEND_EMBREE_H

#include "core/core.h"

typedef struct femb_desc {
    uint32_t threads;       /* 0: one per core */
    uint32_t reflect_depth; /* specular vertices the primary pass follows (0: TND_REFLECT_DEPTH,
                               4; at most TND_MAX_SPECULAR_DEPTH) */
    tnd_light_sampling lights; /* how NEE picks its light (auto: tnd_light_sampling_for) */
    /* the pixel footprint that filters textures (the ray cones' spread) over the traced pixel's
     * (pl_frontend_desc.footprint_scale; 0: 1) */
    float footprint_scale;
} femb_desc;

typedef struct femb_params {
    uint32_t bounces; /* indirect bounces after the primary surface: 0 direct only, 1 (Q2RTX's
                         default), more with Russian roulette from the second on */
    /* the sample word of the random numbers: TND_SAMPLE_REALTIME (0) for the frame's own; a
     * matched reference's sample s draws tnd_reference_sample(s) (shaders/sampling.h) */
    uint32_t sample;
    /* replace the frame's Halton jitter by `jitter` (pixels; a matched reference's per-sample
     * offset) */
    bool set_jitter;
    float jitter[2];
    /* the indirect paths at half resolution (`--bounces half`): only pixels where
     * TND_HALF_TRACED (shaders/sampling.h) holds trace theirs, weighted 2 */
    bool half_indirect;
} femb_params;

typedef struct femb_context femb_context;

tnd_result femb_create(const tnd_scene *scene, const femb_desc *desc, femb_context **ctx);
void femb_destroy(femb_context *ctx);
uint32_t femb_thread_count(const femb_context *ctx);
/* The instruction set the estimator's lane loops run with on this CPU ("x86-64-v4 (AVX-512), 8
 * lanes", "x86-64-v3 (AVX2), 8 lanes" or "SSE2, 4 lanes"; the same results in every case):
 * benchmarks print it. */
const char *femb_simd(void);

/* Set the frame: the scene at this frame and the previous one (for motion vectors; pass the
 * same state twice for the first frame), the frame index (random-number key, jitter) and the
 * image size. Refits instance transforms and rebuilds the light list. */
tnd_result femb_set_frame(femb_context *ctx, const tnd_scene_state *cur,
                          const tnd_scene_state *prev, uint32_t frame_index, uint32_t width,
                          uint32_t height);

/* Primary pass: fills albedo, normal, geo_normal, position, depth, motion, roughness, metallic,
 * emission, vis_id, vis_bary, throughput and rng of `out` (created at the frame's size). */
tnd_result femb_trace_primary(femb_context *ctx, tnd_frame *out);

/* Shading pass: hf, lf_sh, lf_cocg, spec for every pixel, from the surface in the frame's
 * visibility buffer and its rng key. `radiance` (optional, 3 floats per pixel) receives the
 * same estimate computed without demodulation, for checking the composite. */
tnd_result femb_shade(femb_context *ctx, const femb_params *p, tnd_frame *io, float *radiance);

/* Both passes in one sweep over the image, what a frame is rendered with: each batch of pixels is
 * shaded as soon as its G-buffer is staged, from the stage while it is in the cache, instead of
 * from the frame read back after the whole primary pass. The same bits as femb_trace_primary
 * followed by femb_shade (test_render_agrees). */
tnd_result femb_render(femb_context *ctx, const femb_params *p, tnd_frame *out, float *radiance);

/* One gradient sample: re-shade pixel `pixel` on the surface (instance, primitive, u, v) seen
 * there in the previous frame, with that frame's random-number key. */
typedef struct femb_gradient_sample {
    uint32_t pixel;
    uint32_t rng_frame, rng_pixel;
    uint32_t instance, primitive;
    float u, v;
} femb_gradient_sample;

/* Samples from 7 words each (pixel, rng frame, rng pixel, instance, primitive, u bits, v bits:
 * the back-end's dn_select_gradients and fvk_shade_gradients layout). */
void femb_gradient_unpack(const uint32_t *words, uint32_t count, femb_gradient_sample *samples);

/* Patch the frame's visibility and rng at the samples' pixels (the surface is re-evaluated on
 * the current geometry) and shade those pixels; other pixels are untouched. */
tnd_result femb_shade_gradients(femb_context *ctx, const femb_params *p,
                                const femb_gradient_sample *samples, uint32_t count,
                                tnd_frame *io);

/* Reference: unbiased progressive path tracing, spp samples per pixel (full paths with Russian
 * roulette, next-event estimation with MIS, no clamping), radiance in rgb (3 floats per pixel).
 * `lum_se` (optional, 1 float per pixel) receives the standard error of each pixel's luminance
 * mean, sqrt(sample variance / spp) (0 with one sample); `stats` (optional) the samples taken
 * and the mean relative standard error of the pixel means, and with until_noise set, stops
 * early once that error is below it. Sample s of frame f draws the random-number stream
 * (pixel, f, tnd_reference_sample(s)): frames never share samples. Calls
 * `progress(done, total, user)` after each sample pass when given. */
/* The reference's path length: 0 (the default) full paths, Russian roulette from the third
 * bounce, unbiased; n > 0: n bounces after the primary vertex, as femb_params.bounces traces them
 * (a reference matched to the real-time estimator, for evaluating denoisers). */
void femb_set_reference_bounces(femb_context *ctx, uint32_t bounces);
tnd_result femb_reference(femb_context *ctx, uint32_t spp, float *rgb, float *lum_se,
                          tnd_ref_stats *stats, void (*progress)(uint32_t, uint32_t, void *),
                          void *user);
/* The same samples one range at a time (shards of a reference): samples [first, first + count)
 * added to per-pixel sums of their RGB (3 doubles per pixel) and luminance^2 (1 per pixel),
 * one sample after another, in the order femb_reference adds them. With stats->until_noise,
 * stops early as femb_reference does (the sums hold samples [0, first) before); stats->spp:
 * the samples the sums hold after. */
tnd_result femb_reference_add(femb_context *ctx, uint32_t first, uint32_t count,
                              double *sum_rgb, double *sum_lum2, tnd_ref_stats *stats,
                              void (*progress)(uint32_t done, uint32_t total, void *user),
                              void *user);

/* Benchmark: the front-end's rays per frame and their raw rate. Records every ray of one
 * primary + shading pass (untimed), then times, `repeats` times in turn: a frame through
 * femb_render, the primary pass and the shading pass alone, a replay of the recorded rays through
 * bare rtcIntersect1/rtcOccluded1 on the same threads, and a replay of the primary pass's rays
 * alone (not part of raw_ms; for the per-pass figures). */
typedef struct femb_bench {
    double frame_ms;             /* femb_render: the front-end's frame (median over the repeats) */
    double primary_ms, shade_ms; /* each pass alone (medians) */
    double raw_ms;               /* median replay time of the same rays */
    double raw_primary_ms;       /* the primary pass's rays (the first) replayed alone */
    uint64_t rays;               /* per frame: primary, shadow and bounce rays */
    uint64_t primary_rays;       /* of them, the primary pass's (camera rays, specular chains) */
} femb_bench;
tnd_result femb_benchmark(femb_context *ctx, const femb_params *p, uint32_t repeats,
                          femb_bench *out);

#endif
