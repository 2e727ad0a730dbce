/* Parameters of the denoising back-end, shared by denoise/ (C) and its shaders (GLSL). */
#ifndef TND_DENOISE_SHARED_H
#define TND_DENOISE_SHARED_H

#ifndef TND_GLSL
#include <stdint.h>
typedef struct { float x, y, z, w; } dn_vec4;
typedef struct { uint32_t x, y, z, w; } dn_uvec4;
#define vec4 dn_vec4
#define uvec4 dn_uvec4
#endif

/* what the back-end runs (dn_params.size.w) */
#define DN_RUN_SVGF 0u
#define DN_RUN_OFF 1u
#define DN_RUN_ASVGF 2u
#define DN_RUN_RECURRENT 3u /* the recurrent denoiser (fast history, clamp, history fix) */

struct dn_params {
    uvec4 size;    /* x: width, y: height, z: history valid (0 after a reset), w: what runs
                      (DN_RUN_*) */
    uvec4 iters;   /* a-trous iterations: x hf, y lf (at 1/3 resolution), z spec; w the gradient
                      blur's segment (dn_gradients.comp) */
    vec4 alpha;    /* minimum temporal alpha: x hf colour, y lf, z spec, w hf moments */
    vec4 jitter;   /* xy: this frame's jitter, zw: the previous frame's (pixels) */
    vec4 weights;  /* x: depth sigma, y: hf normal exponent, z: hf luminance sigma, w: lf normal exponent */
    vec4 misc;     /* x: pixel spread angle (radians), y: history cap, z: spec normal exponent cap,
                      w: 1 when this frame has gradient samples */
    vec4 antilag;  /* x: hf gain, y: spec gain, z: spec motion gain (per pixel of motion), w: lf gain */
    vec4 lf;       /* x: deflicker ratio (0: off), y: 1 when the light-leak guard is on, z: the
                      luminance weight's sigma (standard deviations of the anchor's noise) */
    /* The filter geometry's origin (fgeo_origin in dn_common.glsl): the contract's position and
     * visibility at the image's centre pixel, copied here on the GPU at the start of each
     * frame (the host fills the rest), so that a shader reads them from the uniform buffer
     * instead of loading two image texels per thread */
    vec4 origin_position;
    uvec4 origin_vis;
    uvec4 frame; /* x: frames run so far (seeds the histories' stochastic rounding); y:
                    recurrent: 1 where the slow histories are resampled by the cubic */
    vec4 rc;     /* recurrent: x the fast history's length in frames, y the clamp's width in
                    standard deviations, z the history fix's reach (histories of at most this
                    many frames are rebuilt from neighbours; 0: none), w its base stride (px) */
    /* The camera for the recurrent denoiser's virtual motion: clip = cur_vp * (x - cam) for a
     * world point x (the projection times the view's rotation), prev_vp likewise with the
     * previous camera at cam - cam_delta.xyz; cam_delta.w: 1 when they are set */
    vec4 cur_vp[4], prev_vp[4];
    vec4 cam_pos, cam_delta;
};

#ifndef TND_GLSL
#undef vec4
#undef uvec4
typedef struct dn_params dn_params;
_Static_assert(sizeof(dn_params) == 352, "dn_params layout");
#endif

/* Bindings of set 0 (the back-end's own images; set 1 is the contract). */
#define DN_B_PARAMS 0
#define DN_B_HIST_HF 1     /* [2] RGBA32UI: hf rgb (tnd_uf16), history length (half), moments
                              E[l], E[l^2] (hist_hf_pack in dn_common.glsl) */
#define DN_B_PREV_KEY 2    /* RG32UI, previous frame: the rng key, read at the chosen samples */
#define DN_B_HIST_LF 3     /* [2] RGBA32UI: the lf history's SH, CoCg and length (hist_lf_pack in
                              dn_common.glsl) */
#define DN_B_HIST_SPEC 4   /* [2] RG32UI: spec rgb (tnd_uf16), spec history length (half) */
#define DN_B_PREV_GEO 5    /* RGBA32UI, the previous frame's surface as the reprojection tests
                              it: x instance, y depth (float bits), z geometric normal
                              (octahedral 12 + 12 bits) | field << 24 | was a gradient sample
                              << 26, w shading normal (octahedral 12 + 12 bits) */
#define DN_B_PREV_SURF 6   /* RGBA32UI, the rest of the previous surface, read at the chosen
                              gradient samples: x primitive, yz barycentrics (float bits) */
#define DN_B_AT 7          /* [2] a-trous ping-pong, RGBA32UI: hf rgb, spec rgb, hf variance as
                              16-bit tnd_uf16 (at_pack in dn_common.glsl) */
#define DN_B_AT_LF 8       /* [2] 1/3 res, the lf filter's ping-pong (dn_lf.comp), RGBA32UI: the
                              anchor's tangent plane and CoCg (lf_pack in dn_common.glsl) */
#define DN_B_AT_LF_SH 9    /* [2] 1/3 res, the lf filter's ping-pong: the SH (RGBA32F) */
#define DN_B_FGEO 10       /* RG32UI, the a-trous filter geometry, written by the temporal pass:
                              x the offset of the pixel's tangent plane (float bits; DN_FGEO_NONE
                              where no surface), y the shading normal (octahedral 11 + 11 bits),
                              roughness (8 bits) and checkerboard field (2 bits) */
#define DN_B_OUT 11        /* linear HDR output */
#define DN_B_PREV_LUM 12   /* R32UI, previous frame: luminances of the raw hf (without the
                              contract's diffuse_view) and spec as tnd_uf16 (low, high half),
                              read by the gradient selection at every candidate (4 bytes
                              instead of 16 with the key) */
#define DN_B_GRAD 13       /* [2] 1/3 res: after the selection [0] holds xy the lf sums (now /
                              before), zw the sample's previous lum hf / spec; after the blur
                              (dn_gradients.comp) x g hf, y g spec, z g lf */
#define DN_B_SAMPLES 14    /* buffer: one tnd_gpu_gradient per 3x3 stratum (b.w = 1: valid) */
#define DN_B_LF_GEO 15     /* 1/3 res: the lf anchor's xyz position (relative to fgeo_origin())
                              and w depth, read by the lf a-trous at its centre (the taps read
                              DN_B_AT_LF) */
#define DN_B_CENTRE 16     /* RGBA32F, written by the temporal pass: xyz the pixel's position
                              relative to fgeo_origin(), w its depth (what the a-trous's
                              centre, the lf downsample and the composite need of the geometry
                              in one texel, instead of two contract images each) */
#define DN_B_HIST_FAST 17  /* [2] recurrent: the fast histories, RGBA32UI: hf rgb, spec rgb as
                              tnd_uf16 (at_pack's layout), w the fast lf history's L0 */
#define DN_B_HIST_RC 18    /* [2] recurrent: the slow histories after the clamp (what the next
                              frame reprojects), RGBA32UI: hf rgb, spec rgb (at_pack's layout),
                              w the reflection's distance (tnd_uf16; 0: unknown), from the
                              contract's spec_hit (dn_temporal.comp's virtual motion) */
#define DN_BINDINGS 19
#define DN_STRATUM 3
/* dn_gradients.comp filters rows and columns of strata in segments of at most this many per
 * work group (with its reach of 127 on either side, 20 bytes a stratum: 15 320 bytes of shared
 * memory) */
#define DN_GRAD_SEGMENT 512
#define DN_FGEO_NONE 0xffffffffu
/* dn_gradients.comp's lf gradient counts only the part of the sums' difference beyond this many
 * standard deviations of this frame's sum (docs/denoise.md, "The lf antilag"): 8, since one sample
 * of indirect light a pixel is heavy-tailed and the bound from its squares is loose */
#define DN_LF_NOISE_K 8.0
/* The passes that reduce each 3x3 stratum run one thread per pixel in tiles of DN_TILE_W x
 * DN_TILE_H pixels (8 x 4 strata); the others 8 x 8 threads. */
#define DN_TILE_W 24
#define DN_TILE_H 12

#endif
