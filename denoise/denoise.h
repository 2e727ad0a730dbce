/* denoise: the back-end. Vulkan compute passes that read only the contract (from either
 * front-end, or from a capture uploaded with tnd_contract_upload) and produce a linear HDR image.
 *
 * Today: SVGF (Schied et al. 2017) per channel with Q2RTX's constants: temporal accumulation of
 * hf (with luminance moments), lf (SH + CoCg) and spec with per-tap disocclusion tests, then
 * edge-avoiding a-trous (hf variance-guided, spec roughness-aware, lf geometry-guided), then the
 * composite. Mode "off" is the plain composite of the noisy signals. A-SVGF's gradients come next
 * (issue "denoise"). Prefix dn_; depends on core/ and shaders/ only. */
#ifndef DN_DENOISE_H
#define DN_DENOISE_H

#include "core/core.h"

typedef enum dn_mode {
    DN_MODE_SVGF = 0, /* temporal + a-trous, fixed minimum alpha (no gradients yet) */
    DN_MODE_OFF,      /* composite of the noisy signals */
} dn_mode;
tnd_result dn_mode_parse(const char *s, dn_mode *mode);
const char *dn_mode_name(dn_mode mode);

typedef struct dn_desc {
    dn_mode mode;
    tnd_precision precision; /* of the contract images it reads */
    uint32_t iters_hf, iters_lf, iters_spec; /* a-trous iterations: 0 means 4 / 4 / 3 */
    float min_alpha_hf, min_alpha_lf, min_alpha_spec, min_alpha_moments; /* 0: .02 .01 .01 .01 */
} dn_desc;

typedef struct dn_frame {
    float jitter[2], prev_jitter[2]; /* pixels */
    float pixel_spread;              /* radians per pixel (2 tan(yfov / 2) / height) */
    bool reset;                      /* drop the history (first frame, cut) */
} dn_frame;

typedef struct dn_timings {
    double temporal_ms, atrous_ms, composite_ms;
} dn_timings;

typedef struct dn_context dn_context;

tnd_result dn_create(tnd_vk *vk, uint32_t width, uint32_t height, const dn_desc *desc,
                     dn_context **ctx);
void dn_destroy(dn_context *ctx);
/* Denoise one frame (blocks): the contract images of this frame in, the output image out. */
tnd_result dn_run(dn_context *ctx, const tnd_contract_gpu *contract, const dn_frame *frame,
                  dn_timings *t);
/* The output as linear RGB floats (3 per pixel). */
tnd_result dn_download(dn_context *ctx, float *rgb);

#endif
