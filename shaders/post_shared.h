/* Parameters of the post chain (composite/: TAA, bloom, exposure, tone mapping), shared by C and
 * GLSL (TND_GLSL). */
#ifndef TND_POST_SHARED_H
#define TND_POST_SHARED_H

#ifndef TND_GLSL
#include <stdint.h>
typedef struct { float x, y, z, w; } cp_vec4;
typedef struct { uint32_t x, y, z, w; } cp_uvec4;
#define vec4 cp_vec4
#define uvec4 cp_uvec4
#define CP_U32 uint32_t
#else
#define CP_U32 uint
#endif

struct cp_params {
    uvec4 size;   /* x: width, y: height, z: frame index, w: flags (CP_F_*) */
    vec4 taa;     /* x: weight of the new frame, y: clip width (standard deviations), z: anti-sparkle
                     ratio, w: unused */
    vec4 bloom;   /* x: intensity, y: sigma (quarter-res pixels), z: tap radius, w: unused */
    vec4 tm;      /* x: curve (CP_CURVE_*), y: fixed EV100, z: low percentile, w: high percentile */
    vec4 adapt;   /* x: frame time (s), y: speed up, z: speed down (1/s), w: exposure bias (stops) */
    vec4 up;      /* upscaling (CP_F_UPSCALE): x, y: the input's size (smaller than size.xy), z, w:
                     this frame's jitter (input pixels: pixel j's sample lies at j + 0.5 + jitter) */
};

#define CP_F_TAA 1u         /* TAA on */
#define CP_F_HISTORY 2u     /* the TAA history is valid */
#define CP_F_BLOOM 4u       /* bloom on */
#define CP_F_AUTO 8u        /* auto exposure (else fixed EV100) */
#define CP_F_DITHER 16u     /* dither the display output */
#define CP_F_UPSCALE 32u    /* the input is smaller than the output: post_taau.comp upscales it */
#define CP_F_SPATIAL 64u    /* ... from this frame alone (the spatial baselines; taa.w: 0 bilinear,
                               1 Catmull-Rom bicubic, 2 edge-adaptive Lanczos) */

#define CP_CURVE_ACES 0u
#define CP_CURVE_AGX 1u
#define CP_CURVE_REINHARD 2u
#define CP_CURVE_LINEAR 3u  /* clamp only */

/* Luminance histogram: CP_BINS bins over log2 luminance [CP_LOG_MIN, CP_LOG_MAX). */
#define CP_BINS 128
#define CP_LOG_MIN (-16.0)
#define CP_LOG_MAX 16.0
#define CP_FRAC_SCALE 256.0 /* fixed point of the in-bin position sums */
#define CP_HIST_TILE 32     /* the histogram pass: pixels per side of a group's tile (8 | it) */

/* Storage buffer: counts and in-bin position sums per bin, then the exposure state. */
struct cp_histogram {
    CP_U32 count[CP_BINS];
    CP_U32 frac[CP_BINS];
    float adapted_log_lum; /* adapted log2 average luminance */
    float exposure;        /* scale applied before the curve */
    float target_log_lum;  /* this frame's measurement */
    CP_U32 valid; /* 1 once adapted_log_lum holds a value */
};

#ifndef TND_GLSL
#undef vec4
#undef uvec4
typedef struct cp_params cp_params;
typedef struct cp_histogram cp_histogram;
_Static_assert(sizeof(cp_params) == 96, "cp_params layout");
#endif

/* Bindings of set 0 (set 1 is the contract). */
#define CP_B_PARAMS 0
#define CP_B_IN 1       /* the back-end's linear HDR output */
#define CP_B_TAA 2      /* [2] TAA history (linear RGB): this frame's slot is the output */
#define CP_B_BLOOM 3    /* [2] 1/4 res */
#define CP_B_DISPLAY 4  /* display-referred sRGB-encoded [0,1], dithered */
#define CP_B_HIST 5     /* cp_histogram */
#define CP_B_FLAT 6     /* the interleave's output: the later passes' input when it runs */
#define CP_B_DEPTH 7    /* [2] the input's depth, this frame's slot and the last's (the temporal
                           upscaler's disocclusion test; input size; only where it upscales) */
#define CP_BINDINGS 8

#endif
