/* composite: everything after the denoiser, on the GPU: the checkerboard interleave (where the
 * primary paths split at glass), TAA, bloom, auto exposure from a luminance histogram, tone
 * mapping to a dithered sRGB display image. Reads the back-end's linear HDR image and the
 * contract's motion vectors and path flags. Prefix cmp_; depends on core/ and shaders/. */
#ifndef CMP_COMPOSITE_H
#define CMP_COMPOSITE_H

#include "core/core.h"

typedef enum cmp_curve { CMP_ACES = 0, CMP_AGX, CMP_REINHARD, CMP_LINEAR } cmp_curve;
tnd_result cmp_curve_parse(const char *s, cmp_curve *c);
const char *cmp_curve_name(cmp_curve c);

typedef enum cmp_upscaler {
    CMP_UPSCALE_TEMPORAL = 0, /* post_taau.comp: jittered samples accumulated at the output size */
    CMP_UPSCALE_BILINEAR,     /* spatial baselines: this frame alone */
    CMP_UPSCALE_BICUBIC,
    CMP_UPSCALE_LANCZOS,      /* edge-adaptive Lanczos-2 (FSR 1's EASU's idea) */
    CMP_UPSCALE_COUNT
} cmp_upscaler;
/* the names, for messages: what cmp_upscaler_parse takes */
#define CMP_UPSCALER_NAMES "temporal, bilinear, bicubic or lanczos"
#define CMP_UPSCALER_LIST "temporal|bilinear|bicubic|lanczos"
tnd_result cmp_upscaler_parse(const char *s, cmp_upscaler *u);
const char *cmp_upscaler_name(cmp_upscaler u);
/* the upscaler that runs: the temporal one needs TAA's history (without it: bilinear) */
cmp_upscaler cmp_upscaler_used(cmp_upscaler u, bool taa);

typedef struct cmp_desc {
    bool interleave;      /* merge the checkerboard fields (the scene has split surfaces) */
    bool taa;             /* temporal anti-aliasing */
    float taa_weight;     /* weight of the new frame (0 means 0.1; upscaling: 0.2) */
    float taa_clip;       /* clip box half-width in standard deviations (0 means 1) */
    float taa_sparkle;    /* anti-sparkle: centre luma at most this x the neighbours' (0 means 4) */
    float bloom;          /* bloom intensity, 0 = off (the default: evaluation runs want none) */
    float bloom_sigma;    /* blur sigma as a fraction of the image height (0 means 0.037) */
    cmp_curve curve;
    bool fixed_exposure;  /* use ev100 instead of auto exposure */
    float ev100;
    float low, high;      /* auto exposure's percentile window (0, 0 means 0.5 .. 0.95) */
    float speed_up, speed_down; /* adaptation rates, 1/s (0 means 3 and 1) */
    float bias;           /* exposure bias in stops */
    bool no_dither;
    /* upscaling, where the input is smaller than the output (cmp_create_scaled): temporal (the
     * default; with TAA off: bilinear) or one of the spatial baselines */
    cmp_upscaler upscaler;
} cmp_desc;

typedef struct cmp_frame {
    float dt;   /* seconds since the previous frame (adaptation) */
    bool reset; /* drop the TAA history and adapt at once */
    float jitter[2]; /* the frame's jitter in input pixels (upscaling places the samples by it) */
} cmp_frame;

typedef struct cmp_timings {
    double interleave_ms, taa_ms, bloom_ms, exposure_ms, tonemap_ms;
} cmp_timings;

typedef struct cmp_context cmp_context;

tnd_result cmp_create(tnd_vk *vk, uint32_t width, uint32_t height, tnd_precision contract_precision,
                      const cmp_desc *desc, cmp_context **ctx);
/* The same for an input (the back-end's image and the contract) of in_width x in_height, at most
 * the output's: the TAA pass upscales it (desc->upscaler); the later passes run at the output
 * size. */
tnd_result cmp_create_scaled(tnd_vk *vk, uint32_t in_width, uint32_t in_height, uint32_t width,
                             uint32_t height, tnd_precision contract_precision,
                             const cmp_desc *desc, cmp_context **ctx);
void cmp_destroy(cmp_context *ctx);
/* One frame (blocks): `hdr` is the back-end's output (RGBA32F, the input size). */
tnd_result cmp_run(cmp_context *ctx, const tnd_image *hdr, const tnd_contract_gpu *contract,
                   const cmp_frame *frame, cmp_timings *t);
/* cmp_run in two halves: record and submit without waiting (the next call into the context
 * waits first; downloads run after it on the device), and wait for it with its GPU times. */
tnd_result cmp_submit(cmp_context *ctx, const tnd_image *hdr, const tnd_contract_gpu *contract,
                      const cmp_frame *frame);
tnd_result cmp_wait(cmp_context *ctx, cmp_timings *t);
/* After cmp_run: the linear HDR image after TAA (3 floats per pixel), and the display image
 * (3 bytes per pixel, sRGB). */
tnd_result cmp_download_hdr(cmp_context *ctx, float *rgb);
tnd_result cmp_download_display(cmp_context *ctx, uint8_t *rgb8);
/* The display image of the last frame on the device (RGBA32F, display-encoded in [0, 1]): what
 * cmp_download_display reads, for a window to show without a round trip. */
const tnd_image *cmp_display_image(const cmp_context *ctx);
/* The exposure applied to the last frame (scale before the curve) and its adapted log2 mean. */
tnd_result cmp_exposure(cmp_context *ctx, float *exposure, float *log2_luminance);
/* The settings in force (defaults filled in). */
const cmp_desc *cmp_settings(const cmp_context *ctx);
/* The passes each frame dispatches with these settings, comma-separated (for run.json). */
const char *cmp_passes(const cmp_context *ctx);

#endif
