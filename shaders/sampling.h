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
 * Reference samples (sample word s + 1) draw from a low-discrepancy sequence instead: shuffled,
 * Owen-scrambled Sobol' points, padded in pairs of dimensions (Burley, "Practical Hash-based Owen
 * Scrambling", JCGT 2020). Each pair of dimensions that belong together (the pixel jitter, the
 * point on the light, the BRDF sample, the lobe and light choices, Russian roulette and the
 * dielectric split) takes the first two Sobol' dimensions of the sample index, the index shuffled
 * and each coordinate scrambled by seeds hashed from (pixel, frame, pair): the first 2^m samples
 * of a pair stratify the unit square into 2^m cells of every shape (a (0, m, 2)-net), while
 * pixels, frames and pairs stay independent. Still a pure function of the four words: shards,
 * `merge`, any frame and the whole 2^32-sample range work as before; the real-time estimator's
 * one sample (word 0) keeps the hash (the A-SVGF gradients re-draw it).
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
/* ReSTIR DI's numbers (`--lights restir`, the real-time sample word only, whose hash makes any
 * 32-bit dimension a stream of its own): candidate j of the primary surface draws
 * TND_DIM_RESTIR_CANDIDATE + 4 j + (0 the light, 1 and 2 the point on it, 3 keep or not); the
 * temporal merge's choice TND_DIM_RESTIR_TEMPORAL; spatial neighbour s TND_DIM_RESTIR_SPATIAL
 * + 2 s + (0 the angle, 1 the radius) and the spatial merge's choice TND_DIM_RESTIR_SPATIAL_KEEP. */
#define TND_DIM_RESTIR_CANDIDATE 0x52000000u
#define TND_DIM_RESTIR_TEMPORAL 0x52001000u
#define TND_DIM_RESTIR_SPATIAL 0x52002000u
#define TND_DIM_RESTIR_SPATIAL_KEEP 0x52002fffu
#define TND_DIM_JITTER_X 0u
#define TND_DIM_JITTER_Y 1u
#define TND_DIMS_BASE 2u
#define TND_DIMS_PER_BOUNCE 8u
#define TND_SAMPLE_REALTIME 0u
/* The reference's pairs of a path vertex's dimensions, 3 bits per dimension of TND_DIM_LIST
 * (pair in bits 0-1, coordinate in bit 2): the point on the light (LIGHT_U, LIGHT_V) is pair 0,
 * the BRDF sample (BRDF_U, BRDF_V) pair 1, the light and lobe choices (LIGHT_PICK, LOBE) pair 2,
 * Russian roulette and the dielectric split (RR, SPLIT) pair 3. */
#define TND_DIM_PAIRS                                                                              \
    ((2u << 0) | (0u << 3) | (4u << 6) | (6u << 9) | (1u << 12) | (5u << 15) | (3u << 18) |       \
     (7u << 21))
#define TND_QMC_SALT 0x5eed50b1u

/* A full path of the reference mode: at most this many bounces (Russian roulette, from the third,
 * ends them long before); a matched reference traces the real-time estimator's count instead. */
#define TND_REFERENCE_MAX_BOUNCES 64u

/* The indirect paths at half resolution (`--bounces half`; Q2RTX's global illumination "low",
 * whose bounce pass covers half the rows): the real-time estimator traces the indirect path of
 * pixel (x, y) of frame f only where x + y + f is even, a checkerboard that alternates each
 * frame, and weights what it brings back by 2. Each pixel's estimate stays unbiased over any two
 * consecutive frames (and over any two neighbours of a frame); direct light is as before. From
 * the sample key's words (pixel y W + x, frame), so a gradient sample re-draws its own frame's
 * choice. */
#define TND_HALF_TRACED(key_pixel, key_frame, width)                                               \
    (((((key_pixel) % (width)) + ((key_pixel) / (width)) + (key_frame)) & 1u) == 0u)

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
/* which pair of dimensions `dim` belongs to (0: the jitter; 1 + 4 b + k for pair k of path
 * vertex b), and its coordinate in the pair, as (pair << 1) | coordinate */
uint tnd_dim_pair(uint dim)
{
    if (dim < TND_DIMS_BASE)
        return dim;
    uint d = dim - TND_DIMS_BASE, w = d % TND_DIMS_PER_BOUNCE;
    return ((1u + 4u * (d / TND_DIMS_PER_BOUNCE) + ((TND_DIM_PAIRS >> (3u * w)) & 3u)) << 1) |
           ((TND_DIM_PAIRS >> (3u * w + 2u)) & 1u);
}
/* Owen scrambling (each bit flipped by a hash of the bits above it: the Laine-Karras
 * permutation with Burley's constants) of the number whose bits reversed are y; returns the
 * scrambled number. (Sobol' points are computed here bit-reversed, which saves two reversals.) */
uint tnd_owen_rev(uint y, uint seed)
{
    y += seed;
    y ^= y * 0x6c50b47cu;
    y ^= y * 0xb82f1e52u;
    y ^= y * 0xc7afe638u;
    y ^= y * 0x8d22f6e6u;
    return bitfieldReverse(y);
}
/* The first two Sobol' dimensions of index i, bit-reversed: the first is i itself (van der
 * Corput); the second's generator is Pascal's triangle mod 2 (direction numbers v_k = v_(k-1) ^
 * v_(k-1) >> 1), so by Lucas' theorem its bit j is the XOR of the index bits k whose set bits
 * hold j's: a superset transform in five shifts. */
uint tnd_sobol1_rev(uint i)
{
    i ^= (i >> 1) & 0x55555555u;
    i ^= (i >> 2) & 0x33333333u;
    i ^= (i >> 4) & 0x0f0f0f0fu;
    i ^= (i >> 8) & 0x00ff00ffu;
    return i ^ (i >> 16);
}
/* A pass that never draws reference samples defines TND_RAND_REFERENCE false before including
 * this file (the path tracer's real-time passes: TND_USES_REFERENCE, scene_gpu.h), and the
 * Sobol' branch folds away from every draw. */
#ifndef TND_RAND_REFERENCE
#define TND_RAND_REFERENCE true
#endif
float tnd_rand(uint pixel, uint frame, uint smp, uint dim)
{
    if (!(TND_RAND_REFERENCE) || smp == TND_SAMPLE_REALTIME)
        return float(tnd_pcg4d(uvec4(pixel, frame, smp, dim)).x >> 8) * (1.0 / 16777216.0);
    uint pc = tnd_dim_pair(dim);
    uvec4 seed = tnd_pcg4d(uvec4(pixel, frame, pc >> 1, TND_QMC_SALT));
    uint i = tnd_owen_rev(bitfieldReverse(smp - 1u), seed.x); /* the shuffled index */
    uint x = (pc & 1u) == 0u ? tnd_owen_rev(i, seed.y) : tnd_owen_rev(tnd_sobol1_rev(i), seed.z);
    return float(x >> 8) * (1.0 / 16777216.0);
}
#else
#include <stdint.h>
/* (always inlined: the Embree front-end's lane loops vectorise the draws only then) */
#if defined(__GNUC__)
#define TND_RAND_INLINE static inline __attribute__((always_inline))
#else
#define TND_RAND_INLINE static inline
#endif
enum {
#define TND_DIM_ENUM(name, off, text) TND_DIM_##name = off,
    TND_DIM_LIST(TND_DIM_ENUM)
#undef TND_DIM_ENUM
};
TND_RAND_INLINE void tnd_pcg4d(uint32_t v[4])
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
TND_RAND_INLINE uint32_t tnd_dim(uint32_t bounce, uint32_t which)
{
    return TND_DIMS_BASE + TND_DIMS_PER_BOUNCE * bounce + which;
}
TND_RAND_INLINE uint32_t tnd_reference_sample(uint32_t s)
{
    return s + 1u;
}
TND_RAND_INLINE uint32_t tnd_dim_pair(uint32_t dim)
{
    if (dim < TND_DIMS_BASE)
        return dim;
    uint32_t d = dim - TND_DIMS_BASE, w = d % TND_DIMS_PER_BOUNCE;
    return ((1u + 4u * (d / TND_DIMS_PER_BOUNCE) + ((TND_DIM_PAIRS >> (3u * w)) & 3u)) << 1) |
           ((TND_DIM_PAIRS >> (3u * w + 2u)) & 1u);
}
TND_RAND_INLINE uint32_t tnd_reverse_bits(uint32_t x)
{
    x = (x >> 16) | (x << 16);
    x = ((x & 0xff00ff00u) >> 8) | ((x & 0x00ff00ffu) << 8);
    x = ((x & 0xf0f0f0f0u) >> 4) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x & 0xccccccccu) >> 2) | ((x & 0x33333333u) << 2);
    return ((x & 0xaaaaaaaau) >> 1) | ((x & 0x55555555u) << 1);
}
TND_RAND_INLINE uint32_t tnd_owen_rev(uint32_t y, uint32_t seed)
{
    y += seed;
    y ^= y * 0x6c50b47cu;
    y ^= y * 0xb82f1e52u;
    y ^= y * 0xc7afe638u;
    y ^= y * 0x8d22f6e6u;
    return tnd_reverse_bits(y);
}
TND_RAND_INLINE uint32_t tnd_sobol1_rev(uint32_t i)
{
    i ^= (i >> 1) & 0x55555555u;
    i ^= (i >> 2) & 0x33333333u;
    i ^= (i >> 4) & 0x0f0f0f0fu;
    i ^= (i >> 8) & 0x00ff00ffu;
    return i ^ (i >> 16);
}
TND_RAND_INLINE float tnd_rand(uint32_t pixel, uint32_t frame, uint32_t sample, uint32_t dim)
{
    uint32_t v[4] = {pixel, frame, sample, dim};
    if (sample == TND_SAMPLE_REALTIME) {
        tnd_pcg4d(v);
        return (float)(int32_t)(v[0] >> 8) * (1.0f / 16777216.0f); /* (signed: converts in SIMD) */
    }
    uint32_t pc = tnd_dim_pair(dim);
    v[2] = pc >> 1;
    v[3] = TND_QMC_SALT;
    tnd_pcg4d(v);
    uint32_t i = tnd_owen_rev(tnd_reverse_bits(sample - 1u), v[0]); /* the shuffled index */
    uint32_t x = (pc & 1u) == 0u ? tnd_owen_rev(i, v[1]) : tnd_owen_rev(tnd_sobol1_rev(i), v[2]);
    return (float)(int32_t)(x >> 8) * (1.0f / 16777216.0f);
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
TND_RAND_INLINE float tnd_halton(uint32_t i, uint32_t base)
{
    float f = 1.0f, r = 0.0f;
    while (i > 0u) {
        f /= (float)base;
        r += f * (float)(i % base);
        i /= base;
    }
    return r;
}
TND_RAND_INLINE void tnd_jitter(uint32_t frame, float out[2])
{
    uint32_t i = frame % 16u + 1u;
    out[0] = tnd_halton(i, 2) - 0.5f;
    out[1] = tnd_halton(i, 3) - 0.5f;
}
#endif

#endif
