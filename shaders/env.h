/* The environment map both front-ends sample, shared by C and GLSL: its convention, its buffer
 * layout and the search in its distributions (core/env.c builds it; frontend_embree reads the
 * arrays, frontend_vk uploads them as one storage buffer).
 *
 * Convention (Cycles', in glTF's +Y-up world): a latitude-longitude image, row 0 at the top.
 * Texel column u in [0, 1) is the azimuth phi = 2 pi (u - 1/2), row v in [0, 1) the angle theta
 * = pi v from +Y; the direction is (cos phi sin theta, cos theta, sin phi sin theta), so the
 * image's centre (u = 1/2) faces +X, u = 1/4 faces -Z, u = 3/4 faces +Z and the left and right
 * edges face -X (Cycles' Environment Texture: u = 1/2 - atan2(y, x) / 2 pi with Blender's +Z up,
 * and glTF's export maps Blender's (x, y, z) to (x, z, -y)). A rotation r (degrees) turns the
 * environment about +Y by the right-hand rule: world = R_y(r) local, x' = cos r x + sin r z,
 * z' = -sin r x + cos r z (r = 90 turns +X to -Z).
 *
 * Radiance is the texel's (nearest, no filtering: the radiance is piecewise constant exactly as
 * the sampling density is, so an importance-sampled texel contributes L / pdf = its share of the
 * integral, and both front-ends find the same texel to the last bit of the direction).
 *
 * Sampling: a 2D piecewise-constant distribution over the texels with weights luminance x sin
 * (theta at the row's centre): a row from the marginal cdf, a column from the row's conditional
 * cdf, a uniform point inside the texel (the two uniforms remapped into the chosen intervals).
 * Density in (u, v): pdf_uv = weight / (sum of weights) x W H (stored per texel); in solid angle
 * pdf = pdf_uv / (2 pi^2 sin theta), with theta of the direction itself.
 *
 * Layout of the float array (W x H texels):
 *   [0, 4WH)            texel (row-major): r, g, b radiance (nits, intensity applied), pdf_uv
 *   [4WH, 4WH + H)      marginal cdf over rows (inclusive: entry i = P(row <= i), last = 1)
 *   [4WH + H, 5WH + H)  per row, the conditional cdf over its columns (inclusive, last = 1)
 * A row of zero weight has a flat cdf of 1 (never chosen). */
#ifndef TND_ENV_H
#define TND_ENV_H

#define TND_LIGHT_KIND_ENV 4u

#ifdef TND_GLSL
#define TND_ENV_U32 uint
#define TND_ENV_ARG
#define TND_ENV_AT(i) env_data[i]
#else
#include <stdint.h>
#define TND_ENV_U32 uint32_t
#define TND_ENV_ARG const float *env_data,
#define TND_ENV_AT(i) env_data[i]
#endif

#define TND_ENV_OFFSET_MARGINAL(w, h) (4u * (w) * (h))
#define TND_ENV_OFFSET_CONDITIONAL(w, h) (4u * (w) * (h) + (h))
#define TND_ENV_FLOATS(w, h) (5u * (w) * (h) + (h))

/* The first index i of [0, n) whose inclusive cdf entry env[first + i] exceeds u (the last one
 * when none does): the interval u falls in. */
#ifdef TND_GLSL
TND_ENV_U32 tnd_env_find(TND_ENV_ARG TND_ENV_U32 first, TND_ENV_U32 n, float u)
#else
static inline TND_ENV_U32 tnd_env_find(TND_ENV_ARG TND_ENV_U32 first, TND_ENV_U32 n, float u)
#endif
{
    TND_ENV_U32 lo = 0u, hi = n - 1u;
    while (lo < hi) {
        TND_ENV_U32 mid = (lo + hi) / 2u;
        if (TND_ENV_AT(first + mid) > u)
            hi = mid;
        else
            lo = mid + 1u;
    }
    return lo;
}

/* Where u falls inside interval i of that cdf, in [0, 1): the uniform remapped, so that one
 * number picks the interval and the point inside it. */
#ifdef TND_GLSL
float tnd_env_remap(TND_ENV_ARG TND_ENV_U32 first, TND_ENV_U32 i, float u)
#else
static inline float tnd_env_remap(TND_ENV_ARG TND_ENV_U32 first, TND_ENV_U32 i, float u)
#endif
{
    float lo = i > 0u ? TND_ENV_AT(first + i - 1u) : 0.0f;
    float hi = TND_ENV_AT(first + i);
    float f = hi > lo ? (u - lo) / (hi - lo) : 0.5f;
    f = f > 0.0f ? f : 0.0f;
    return f < 0.99999994f ? f : 0.99999994f;
}

/* Solid-angle density of a direction whose texel has density pdf_uv and whose sin theta is st
 * (0 at the poles, where no density is defined: the direction is not sampled there). */
#ifdef TND_GLSL
float tnd_env_pdf(float pdf_uv, float st)
#else
static inline float tnd_env_pdf(float pdf_uv, float st)
#endif
{
    return st > 0.0f ? pdf_uv / (19.739208802178716f * st) : 0.0f; /* 2 pi^2 */
}

#endif
