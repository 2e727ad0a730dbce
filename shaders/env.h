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
 * integral). Both front-ends find the same texel to the last bits of the direction: atan2 and
 * acos give a first guess (a GPU computes them less exactly than the C library: lavapipe's
 * differ by up to about 1e-5 rad, enough to cross a texel's edge on 1% of a frame's sky), then
 * tnd_env_refine moves it across an edge where the direction lies on the edge's other side, by
 * sign tests against tables of the edges (exact but for the last bits).
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
 *   [5WH + H, 5WH + H + 2(W + 1))  the column edges: cos b, sin b of b_j = 2 pi (j / W - 1/2)
 *   [.., + H + 1)       the row edges: cos theta_i of theta_i = pi i / H
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
#define TND_ENV_OFFSET_EDGES(w, h) (5u * (w) * (h) + (h))
#define TND_ENV_FLOATS(w, h) (5u * (w) * (h) + (h) + 2u * ((w) + 1u) + (h) + 1u)

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

/* The texel (column, row: *cx, *cy) of a direction (x, y, z) in the map's frame, from a first
 * guess one texel off at most: moved across the edge whose plane the direction lies beyond
 * (columns wrap, rows clamp). Column edge j's plane holds +Y and (cos b_j, 0, sin b_j): the
 * azimuth phi is past b_j where sin(phi - b_j), whose sign z cos b_j - x sin b_j has, is >= 0;
 * row edge i: theta is past theta_i where y <= cos theta_i. */
#ifdef TND_GLSL
void tnd_env_refine(TND_ENV_U32 w, TND_ENV_U32 h, float x, float y, float z, inout TND_ENV_U32 cx,
                    inout TND_ENV_U32 cy)
#else
static inline void tnd_env_refine(TND_ENV_ARG TND_ENV_U32 w, TND_ENV_U32 h, float x, float y,
                                  float z, TND_ENV_U32 *pcx, TND_ENV_U32 *pcy)
#endif
{
#ifndef TND_GLSL
    TND_ENV_U32 cx = *pcx, cy = *pcy;
#endif
    TND_ENV_U32 e = TND_ENV_OFFSET_EDGES(w, h), r = e + 2u * (w + 1u);
    if (z * TND_ENV_AT(e + 2u * cx) - x * TND_ENV_AT(e + 2u * cx + 1u) < 0.0f)
        cx = cx > 0u ? cx - 1u : w - 1u;
    else if (z * TND_ENV_AT(e + 2u * cx + 2u) - x * TND_ENV_AT(e + 2u * cx + 3u) >= 0.0f)
        cx = cx + 1u < w ? cx + 1u : 0u;
    if (y > TND_ENV_AT(r + cy))
        cy = cy > 0u ? cy - 1u : 0u;
    else if (y <= TND_ENV_AT(r + cy + 1u))
        cy = cy + 1u < h ? cy + 1u : h - 1u;
#ifndef TND_GLSL
    *pcx = cx, *pcy = cy;
#endif
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
