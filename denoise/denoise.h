/* denoise: the back-end. Vulkan compute passes that read only the contract (from either
 * front-end, or from a capture uploaded with tnd_contract_upload) and produce a linear HDR image.
 *
 * Today: SVGF (Schied et al. 2017) per channel with Q2RTX's constants: temporal accumulation of
 * hf (with luminance moments), lf (SH + CoCg) and spec with per-tap disocclusion tests, then
 * edge-avoiding a-trous (hf variance-guided, spec roughness-aware, lf geometry-guided), then the
 * composite. Mode "off" is the plain composite of the noisy signals. Mode "asvgf" adds A-SVGF
 * (Schied et al. 2018): sparse gradient samples re-shaded with the previous frame's random
 * numbers, a 1/3-resolution gradient image blurred by a-trous, and an antilag factor that
 * shortens the history where the signal changed. Mode "recurrent" (after NVIDIA's ReLAX and
 * ReBLUR, docs/denoise.md): fast histories beside the slow ones, the slow clamped to the fast
 * ones' neighbourhood (dn_history.comp), history fix for young histories, cubic reprojection,
 * virtual motion for near-mirror reflections (the contract's spec_hit), the A-SVGF gradients as
 * its history's confidence where there are samples. Prefix dn_; depends on core/ and
 * shaders/. */
#ifndef DN_DENOISE_H
#define DN_DENOISE_H

#include "core/core.h"

/* the recurrent denoiser's resampling of its slow histories by default (dn_desc.resample): the
 * tested bilinear taps (the Catmull-Rom filter measured 0.3% worse over the standard suite and
 * 0.09 ms slower at 1080p on the H100: docs/denoise.md) */
#define DN_RESAMPLE_DEFAULT 2u

typedef enum dn_mode {
    DN_MODE_SVGF = 0, /* temporal + a-trous, fixed minimum alpha */
    DN_MODE_OFF,      /* composite of the noisy signals */
    DN_MODE_ASVGF,    /* SVGF whose history length follows the temporal gradients */
    DN_MODE_RECURRENT, /* fast and slow histories, the slow clamped to the fast; history fix;
                          the gradients (where there are samples) as the history's confidence */
} dn_mode;
tnd_result dn_mode_parse(const char *s, dn_mode *mode);
const char *dn_mode_name(dn_mode mode);

typedef struct dn_desc {
    dn_mode mode;
    tnd_precision precision; /* of the contract images it reads */
    uint32_t iters_hf, iters_lf, iters_spec; /* a-trous iterations: 0 means 4 / 3 / 3 (lf's at 1/3
                                                resolution, steps 3, 6, 12 pixels) */
    float min_alpha_hf, min_alpha_lf, min_alpha_spec, min_alpha_moments; /* 0: .02 .01 .01 .01 */
    /* A-SVGF: antilag = gain x filtered gradient (spec, lf; hf: gain x its square root, the
     * relative change) + motion gain x pixels of motion (spec); history length scales by (1 - antilag)^10 and alpha moves towards 1 by
     * antilag. 0 means 1 / 2 / 0.004 / 1 (Q2RTX's, but lf 1 against its 0.2: the lf gradient
     * here stops at its noise, docs/denoise.md). */
    float antilag_hf, antilag_spec, antilag_motion, antilag_lf;
    /* lf filter (1/3 res): deflicker ratio (0 means Q2RTX's 2; negative turns it off), and the
     * light-leak guard of the last iteration (on unless no_leak_guard) */
    float lf_deflicker;
    bool no_leak_guard;
    /* lf filter: its luminance weight stops at this many standard deviations of the noise left
     * in the temporal lf histories (0 means 2; docs/denoise.md) */
    float lf_sigma;
    /* hf a-trous: its luminance weight stops at this many standard deviations of the hf
     * history's mean (0 means 4, Q2RTX's) */
    float hf_sigma;
    /* recurrent: the fast history's length in frames (0 means 6), the clamp's width in standard
     * deviations of the fast histories' 5x5 neighbourhood (0 means 2), histories of at most
     * this many frames rebuilt by the history fix (0 means 3; negative: none) and its base
     * stride in pixels (0 means 14: 7, 5, 4 pixels at 1, 2, 3 frames) */
    float fast_frames, clamp_sigma, history_fix, fix_stride;
    /* recurrent: how the slow colour histories are resampled where the whole 4x4 footprint saw
     * the pixel's surface: 0 the default (DN_RESAMPLE_DEFAULT), 1 Catmull-Rom (NRD's), 2 the
     * tested bilinear taps as everywhere else */
    uint32_t resample;
    /* profiling: a timestamp around every dispatch as well (dn_dispatch_times) */
    bool dispatch_timing;
    /* the gradient blur's segment of a row or column per work group, in strata: 0 means (and
     * larger values become) DN_GRAD_SEGMENT; smaller ones let a test split small images */
    uint32_t grad_segment;
} dn_desc;

typedef struct dn_frame {
    float jitter[2], prev_jitter[2]; /* pixels */
    float pixel_spread;              /* radians per pixel (2 tan(yfov / 2) / height) */
    bool reset;                      /* drop the history (first frame, cut) */
    /* The camera of this frame and the last (dn_frame_set_camera), for what the motion vectors
     * do not say: where a reflection was (the recurrent denoiser's virtual motion). Without
     * it (has_camera false) reflections move with their surfaces. */
    bool has_camera;
    float view[16], proj[16], prev_view[16], prev_proj[16]; /* as tnd_camera_state's */
} dn_frame;
/* Fill f's camera from a camera state (unset when its projection is not a perspective one). */
void dn_frame_set_camera(dn_frame *f, const tnd_camera_state *c);

/* The frame parameters of frame `frame` rendered by a Tandem front-end (Halton jitter of this and
 * the previous frame, pixel spread from the projection's vertical scale proj[5]). */
dn_frame dn_frame_for_camera(const float proj[16], uint32_t height, uint32_t frame, bool reset);

typedef struct dn_timings {
    double select_ms;   /* the gradient selection of this frame (dn_select_gradients) */
    double gradient_ms; /* gradient image and its blur */
    double temporal_ms, lf_ms, atrous_ms, composite_ms; /* lf: the 1/3-res lf filter */
    double history_ms; /* recurrent: the history pass (clamp, history fix) */
    /* the lf filter ran beside the a-trous (the default; dn_desc.dispatch_timing runs them in
     * turn): atrous_ms covers both, lf_ms is 0 */
    bool lf_beside_atrous;
} dn_timings;

typedef struct dn_context dn_context;

/* The bytes each pass must move at the least (every texel it reads or writes, once), for the
 * bandwidth floor of `tandem bench`: time >= bytes / copy bandwidth. Fields as dn_timings. */
typedef struct dn_traffic {
    double select, gradient, temporal, lf, atrous, composite, history;
} dn_traffic;
void dn_traffic_of(const dn_context *ctx, dn_traffic *t);
/* With dn_desc.dispatch_timing: the last dn_run's GPU time of each dispatch, in order (names
 * such as "atrous.2"; they stay valid for the context's life); returns how many (at most max). */
uint32_t dn_dispatch_times(const dn_context *ctx, const char **names, double *ms, uint32_t max);

tnd_result dn_create(tnd_vk *vk, uint32_t width, uint32_t height, const dn_desc *desc,
                     dn_context **ctx);
void dn_destroy(dn_context *ctx);
/* Denoise one frame (blocks): the contract images of this frame in, the output image out.
 * dn_run is dn_submit then dn_wait. */
tnd_result dn_run(dn_context *ctx, const tnd_contract_gpu *contract, const dn_frame *frame,
                  dn_timings *t);
/* Record and submit the frame without waiting for it: the host goes on (the next frame's
 * front-end) while the device denoises. Later passes on the device (post chain, downloads, the
 * next front-end) run after it in submission order; the contract must not change on the host's
 * side until then (GPU front-ends write it in later submissions, which is fine). The next call
 * into the context waits first. */
tnd_result dn_submit(dn_context *ctx, const tnd_contract_gpu *contract, const dn_frame *frame);
/* Wait for the frame submitted last; its GPU times (t may be NULL). */
tnd_result dn_wait(dn_context *ctx, dn_timings *t);
/* A-SVGF and recurrent (count 0 in other modes): pick this frame's gradient samples, at most one per
 * 3x3 stratum (dn_gradient_capacity), as DN_GRADIENT_WORDS words each: pixel, previous rng frame,
 * previous rng pixel, previous instance, previous primitive, u and v bits (the layout of
 * femb_gradient_sample and fvk_shade_gradients). Call after the front-end rendered the frame
 * and before dn_run; the front-end re-shades the samples in between, and their values reach the
 * back-end through dn_set_gradient_values. */
enum { DN_GRADIENT_WORDS = 7 };
uint32_t dn_gradient_capacity(const dn_context *ctx);
/* The same selection handed over on the GPU: `buffer` (owned by the back-end, valid until the
 * next selection) holds one tnd_gpu_gradient per stratum, `slots` of them in rows of `row`
 * (the strata's grid, row by row), pixel TND_GRADIENT_NONE where a stratum has no sample;
 * fvk_shade_gradient_slots reads it directly. Saves the read-back and the host's copy of the
 * list each frame. */
tnd_result dn_select_gradients_gpu(dn_context *ctx, const tnd_contract_gpu *contract,
                                   const dn_frame *frame, VkBuffer *buffer, uint32_t *slots,
                                   uint32_t *row);
tnd_result dn_select_gradients(dn_context *ctx, const tnd_contract_gpu *contract,
                               const dn_frame *frame, uint32_t *samples, uint32_t *count);
/* The host's re-shading of dn_select_gradients' samples (`samples`, `count` of them as it gave
 * them): `reshaded` is the frame with those pixels re-shaded (femb_shade_gradients,
 * fvk_shade_gradients then a download, a replay's stored samples); its hf, spec and lf L0 there
 * go to the gradient pass beside the contract, which dn_run then reads as rendered (every
 * pixel's fresh sample). On the GPU the front-end writes them into the list itself
 * (fvk_shade_gradient_slots, fvk_render_shade). A sample without its value gives no gradient. */
tnd_result dn_set_gradient_values(dn_context *ctx, const uint32_t *samples, uint32_t count,
                                  const tnd_frame *reshaded);
/* Debug dumps of the back-end's buffers after the last dn_run (tandem render --dump): dump i
 * (0 .. dn_dump_count() - 1) has a name such as "temporal.hf" and 4 channel names; dn_dump
 * writes its 4 floats per texel (dn_dump_size: full or, for "gradients" and "lf.*", 1/3
 * resolution). The a-trous dumps hold the last iteration, "lf.*" the 1/3-res lf filter's result;
 * "gradients" (the filtered hf / spec / lf gradients) is only meaningful on asvgf frames with
 * history. A buffer the last frame did not write is zeros (every one but "output" in off mode;
 * "gradients" without gradient samples). */
uint32_t dn_dump_count(void);
const char *dn_dump_name(uint32_t i, const char **channels);
tnd_result dn_dump_size(const dn_context *ctx, uint32_t i, uint32_t *w, uint32_t *h);
tnd_result dn_dump(dn_context *ctx, uint32_t i, float *rgba);
/* The output image (RGBA32F linear HDR) of the last dn_run, for the post chain (composite/). */
const tnd_image *dn_output(const dn_context *ctx);
/* The output as linear RGB floats (3 per pixel). */
tnd_result dn_download(dn_context *ctx, float *rgb);

#endif
