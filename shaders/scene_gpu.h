/* GPU scene layout shared by frontend_vk (C) and its shaders (GLSL): std430 structs of vec4/uvec4
 * members only, and the frame parameters (a uniform buffer, std140-compatible). */
#ifndef TND_SCENE_GPU_H
#define TND_SCENE_GPU_H

#ifndef TND_GLSL
#include <stdint.h>
typedef struct { float x, y, z, w; } tnd_gvec4;
typedef struct { uint32_t x, y, z, w; } tnd_guvec4;
typedef struct { int32_t x, y, z, w; } tnd_givec4;
typedef struct { float m[16]; } tnd_gmat4;
#define vec4 tnd_gvec4
#define uvec4 tnd_guvec4
#define ivec4 tnd_givec4
#define mat4 tnd_gmat4
#endif

struct tnd_gpu_mesh {
    uvec4 range; /* first vertex, vertex count, first index, triangle count */
    uvec4 info;  /* x: material */
};

struct tnd_gpu_material {
    vec4 base_color;     /* rgb, a */
    vec4 emission;       /* rgb (nits, strength applied), w: metallic */
    vec4 params;         /* roughness, specular factor, normal scale, double-sided (0/1) */
    ivec4 tex;           /* base colour, metal-rough, normal, emission texture index; -1 none */
    vec4 vol;            /* glass: Beer-Lambert sigma_a rgb (1/m), w: index of refraction */
    uvec4 info;          /* x: kind (TND_KIND_*, specular.h), y: 1 alpha-tested, z: alpha cutoff
                            (float bits) */
    vec4 uvx[8];         /* texture slot k (TND_TEX_*): [2k] = (m0, m1, m2, coordinate set),
                            [2k + 1] = (m3, m4, m5, level-of-detail shift): tnd_uv_xform */
};
#ifdef TND_GLSL /* (C: core.h's enum, the same values) */
#define TND_TEX_BASE 0u
#define TND_TEX_METAL_ROUGH 1u
#define TND_TEX_NORMAL 2u
#define TND_TEX_EMISSION 3u
#endif

struct tnd_gpu_instance {
    vec4 xform[3];      /* object to world, 3x4 row-major, this frame */
    vec4 prev_xform[3]; /* the previous frame's */
    uvec4 info;         /* x: mesh, y: first light index of its emissive triangles or ~0 */
};

struct tnd_gpu_frame {
    mat4 inv_view, inv_proj;
    mat4 view, proj, prev_view, prev_proj;
    vec4 cam_pos;        /* xyz */
    vec4 prev_cam_pos;   /* xyz */
    vec4 jitter;         /* xy: this frame's jitter (pixels), z: pixel spread angle */
    vec4 sky;            /* rgb uniform sky radiance; w: the environment map's pick probability */
    vec4 env;            /* environment map (shaders/env.h): cos, sin of its rotation, width,
                            height (0: none) */
    uvec4 frame;         /* x: frame index, y: width, z: height, w: light count */
    uvec4 params;        /* x: bounces, y: the real-time pass's sample word (0; a matched
                            reference's samples: s + 1), z: gradient count, w: specular
                            vertices the primary chain follows */
    uvec4 indirect;      /* x: 1: the indirect paths of half the pixels (TND_HALF_TRACED,
                            shaders/sampling.h), 0: of every pixel; y: the light tree's nodes
                            (0: NEE picks from the power table) */
    uvec4 restir;        /* ReSTIR DI (shaders/restir.h, pt_restir.glsl): x: 1 where this
                            frame's shading takes reservoirs; y: bit 0 this frame's slot of the
                            final reservoirs and surfaces (the previous frame's is the other),
                            bit 1 the previous frame's are there; z: the previous frame's index;
                            w: the spatial disc's radius in pixels (float bits) */
};

#ifndef TND_GLSL
#undef vec4
#undef uvec4
#undef ivec4
#undef mat4
typedef struct tnd_gpu_mesh tnd_gpu_mesh;
typedef struct tnd_gpu_material tnd_gpu_material;
typedef struct tnd_gpu_instance tnd_gpu_instance;
typedef struct tnd_gpu_frame tnd_gpu_frame;
_Static_assert(sizeof(tnd_gpu_mesh) == 32, "mesh layout");
_Static_assert(sizeof(tnd_gpu_material) == 224, "material layout");
_Static_assert(sizeof(tnd_gpu_instance) == 112, "instance layout");
_Static_assert(sizeof(tnd_gpu_frame) == 6 * 64 + 9 * 16, "frame layout");
#endif

/* What the front-end's shaders model (specialization constant 0 of every pass, a bit mask):
 * fvk_create derives it from the scene's features so that code for light types, textures,
 * normal maps and sky the scene lacks is not compiled in ("model only what a scene requires");
 * TND_USES_ALL forces every branch in (`--pipeline full`). Either way the images are identical:
 * a branch left out is one no pixel of that scene can take. */
#define TND_USES_AREA 1u        /* emissive triangles */
#define TND_USES_POINT 2u
#define TND_USES_SPOT 4u
#define TND_USES_DIRECTIONAL 8u
#define TND_USES_TEXTURES 16u
#define TND_USES_NORMAL_MAPS 32u
#define TND_USES_SKY 64u
#define TND_USES_SPECULAR 128u  /* mirrors and glass */
#define TND_USES_ENV 256u       /* an environment map */
#define TND_USES_ALPHA 512u     /* alpha-tested geometry (any-hit, candidate loop) */
/* Not a feature of the scene but of the passes: they may draw reference samples (shuffled Owen-
 * scrambled Sobol' points, sampling.h). The real-time passes are built without it, so that
 * tnd_rand's Sobol' branch folds away from them (it cost `materials`' shading pass 7% on the
 * H200, docs/performance.md); references and matched references run passes built with it. */
#define TND_USES_REFERENCE 1024u
/* The light tree's descent for NEE's pick (--lights tree: shaders/light_tree.h), not the power
 * table's search. */
#define TND_USES_LIGHT_TREE 2048u
/* ReSTIR DI at the primary surface (--lights restir: shaders/restir.h, pt_restir.glsl) */
#define TND_USES_RESTIR 4096u
#define TND_USES_ALL 8191u

/* Gradient sample for the shading pass (its first 7 words match femb_gradient_sample). In the
 * back-end's per-stratum list (handed to the Vulkan front-end on the GPU), a stratum without a
 * sample has pixel TND_GRADIENT_NONE and is skipped; the list is the grid of
 * TND_GRADIENT_STRATUM^2-pixel strata in rows (pixel (x, y)'s stratum: (y / 3) x row + x / 3),
 * at most one sample each. The re-shaded sample (the previous surface and key in this frame's
 * scene) goes into c and d, not into the contract: the contract keeps the pixel's own fresh
 * sample, so that a history gets one new sample a frame everywhere (dn_gradients.comp reads c
 * and d; the host's re-shading reaches them through dn_set_gradient_values). */
#define TND_GRADIENT_NONE 0xFFFFFFFFu
#define TND_GRADIENT_STRATUM 3u
struct tnd_gpu_gradient {
#ifdef TND_GLSL
    uvec4 a; /* pixel, rng frame, rng pixel, instance */
    uvec4 b; /* primitive, u bits, v bits, 0 */
    vec4 c;  /* the re-shaded sample: hf rgb, lf L0 */
    vec4 d;  /* spec rgb, 1 once the front-end wrote c and d (0 from the selection) */
#else
    uint32_t pixel, rng_frame, rng_pixel, instance;
    uint32_t primitive, u_bits, v_bits, pad; /* pad: 1 = valid in the back-end's selection */
    float hf[3], l0, spec[3], reshaded;
#endif
};
#ifndef TND_GLSL
typedef struct tnd_gpu_gradient tnd_gpu_gradient;
#endif

#endif
