/* Random numbers and the sample-dimension table, shared by both front-ends (C and GLSL).
 *
 * The generator is counter-based: every number is a pure function of (pixel key, frame, sample,
 * sample dimension), so the Vulkan and Embree front-ends draw the same numbers for the same pixel
 * and the same use, and a gradient sample re-draws the previous frame's numbers from its stored
 * key. Hash: pcg4d (Jarzynski and Olano, "Hash Functions for GPU Rendering", JCGT 2020), a
 * bijection of 128 bits, applied to (pixel, frame, sample, dimension); the float is the top 24
 * bits of its first word times 2^-24, in [0, 1). Only 32-bit integer arithmetic, which wraps
 * identically in C and GLSL. tests/test_core_gpu.c checks bit equality on the GPU.
 *
 * Keys never collide: each of the four words is a full 32-bit input. The sample word is
 * TND_SAMPLE_REALTIME (0) for the real-time estimator's one sample per pixel and frame, and
 * s + 1 for sample s of a reference frame (tnd_reference_sample), so any frame count and up to
 * 2^32 - 1 samples per pixel give independent streams, and a reference never reuses the numbers
 * of the real-time frame it is compared with. (Before, the reference keyed sample s of frame f
 * as frame f x 4096 + s, and with more than 4096 samples consecutive frames shared samples.)
 *
 * Dimensions: TND_DIM_JITTER_* for the reference mode's per-sample pixel jitter (the real-time
 * jitter is one Halton offset per frame, in the frame parameters), then TND_DIMS_PER_BOUNCE per
 * path vertex b (b = 0 is the primary surface). */
#ifndef TND_SAMPLING_H
#define TND_SAMPLING_H

// clang-format off
#define TND_DIM_LIST(X) \
    X(LIGHT_PICK, 0, "which light NEE samples") \
    X(LIGHT_U,    1, "first coordinate of the point on the light") \
    X(LIGHT_V,    2, "second coordinate of the point on the light") \
    X(LOBE,       3, "specular or diffuse lobe of the bounce") \
    X(BRDF_U,     4, "first coordinate of the BRDF sample") \
    X(BRDF_V,     5, "second coordinate of the BRDF sample") \
    X(RR,         6, "Russian roulette") \
    X(SPLIT,      7, "reflect or refract at a dielectric")
// clang-format on
#define TND_DIM_JITTER_X 0u
#define TND_DIM_JITTER_Y 1u
#define TND_DIMS_BASE 2u
#define TND_DIMS_PER_BOUNCE 8u
#define TND_SAMPLE_REALTIME 0u

/* A full path of the reference mode: at most this many bounces (Russian roulette, from the third,
 * ends them long before); a matched reference traces the real-time estimator's count instead. */
#define TND_REFERENCE_MAX_BOUNCES 64u

#ifdef TND_GLSL
#define TND_DIM_ENUM(name, off, text) const uint TND_DIM_##name = uint(off);
TND_DIM_LIST(TND_DIM_ENUM)
#undef TND_DIM_ENUM
/* (pcg3d: the back-end's per-pixel hashes, GLSL only) */
uvec3 tnd_pcg3d(uvec3 v)
{
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.z;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v ^= v >> 16u;
    v.x += v.y * v.z;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    return v;
}
uvec4 tnd_pcg4d(uvec4 v)
{
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v ^= v >> 16u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}
/* dimension of path vertex `bounce` */
uint tnd_dim(uint bounce, uint which)
{
    return TND_DIMS_BASE + TND_DIMS_PER_BOUNCE * bounce + which;
}
/* the sample word of reference sample s */
uint tnd_reference_sample(uint s)
{
    return s + 1u;
}
float tnd_rand(uint pixel, uint frame, uint smp, uint dim)
{
    return float(tnd_pcg4d(uvec4(pixel, frame, smp, dim)).x >> 8) * (1.0 / 16777216.0);
}
#else
#include <stdint.h>
enum {
#define TND_DIM_ENUM(name, off, text) TND_DIM_##name = off,
    TND_DIM_LIST(TND_DIM_ENUM)
#undef TND_DIM_ENUM
};
static inline void tnd_pcg4d(uint32_t v[4])
{
    for (int i = 0; i < 4; i++)
        v[i] = v[i] * 1664525u + 1013904223u;
    v[0] += v[1] * v[3];
    v[1] += v[2] * v[0];
    v[2] += v[0] * v[1];
    v[3] += v[1] * v[2];
    for (int i = 0; i < 4; i++)
        v[i] ^= v[i] >> 16u;
    v[0] += v[1] * v[3];
    v[1] += v[2] * v[0];
    v[2] += v[0] * v[1];
    v[3] += v[1] * v[2];
}
static inline uint32_t tnd_dim(uint32_t bounce, uint32_t which)
{
    return TND_DIMS_BASE + TND_DIMS_PER_BOUNCE * bounce + which;
}
static inline uint32_t tnd_reference_sample(uint32_t s)
{
    return s + 1u;
}
static inline float tnd_rand(uint32_t pixel, uint32_t frame, uint32_t sample, uint32_t dim)
{
    uint32_t v[4] = {pixel, frame, sample, dim};
    tnd_pcg4d(v);
    return (float)(int32_t)(v[0] >> 8) * (1.0f / 16777216.0f); /* (signed: converts in SIMD) */
}
#endif

/* Halton radical inverse in base 2 and 3: the real-time per-frame jitter, shared with TAA.
 * Frame f uses index (f mod 16) + 1; the offset is in pixels, in [-0.5, 0.5). */
#ifdef TND_GLSL
float tnd_halton(uint i, uint base)
{
    float f = 1.0, r = 0.0;
    while (i > 0u) {
        f /= float(base);
        r += f * float(i % base);
        i /= base;
    }
    return r;
}
#else
static inline float tnd_halton(uint32_t i, uint32_t base)
{
    float f = 1.0f, r = 0.0f;
    while (i > 0u) {
        f /= (float)base;
        r += f * (float)(i % base);
        i /= base;
    }
    return r;
}
static inline void tnd_jitter(uint32_t frame, float out[2])
{
    uint32_t i = frame % 16u + 1u;
    out[0] = tnd_halton(i, 2) - 0.5f;
    out[1] = tnd_halton(i, 3) - 0.5f;
}
#endif

#endif
