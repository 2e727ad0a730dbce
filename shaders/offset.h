/* Ray origins off a surface, shared by both front-ends (C and GLSL).
 *
 * A ray leaving a surface point p starts at p + eps n (n: the geometric normal on the side the
 * ray leaves), and a shadow ray towards a point q on an emitter ends at q + eps_q n_l (n_l: the
 * emitter's normal on the receiver's side), with its direction and length computed from those
 * two offset points (so that the ray can neither start under its own surface nor reach the
 * emitter's plane, whatever the distance between them).
 *
 * eps scales with the magnitude of the coordinates, as their rounding errors do: the point is
 * interpolated from a triangle's vertices and moved by an instance transform in float (about
 * 8 u m of error, u = 2^-24 the unit roundoff, m the largest coordinate magnitude), and the
 * intersector forms vertex - origin and its edge functions at the same magnitude (a few u m);
 * eps = 32 u (1 + m) leaves a factor of about 2 over their sum (16 to 32 ulps of m). The 1 + m
 * floor keeps 32 u (1.9e-6 units) at the origin. The offset is along the normal, so a ray at a
 * grazing angle leaves the surface as surely as a perpendicular one. (Mitsuba 3 uses the same
 * form with 89 u; Waechter and Binder's integer offset of 256 ulps per coordinate, which Tandem
 * used before, moved points 2 units at 1e5 from the origin.)
 *
 * The same formula on both sides gives the same origins to the last bit in C; a GPU may fuse
 * p + eps n into one FMA (within one rounding of it). */
#ifndef TND_OFFSET_H
#define TND_OFFSET_H

#define TND_OFFSET_EPS (32.0 / 16777216.0) /* 32 u */

#ifdef TND_GLSL
float tnd_offset_eps(float m)
{
    return float(TND_OFFSET_EPS) * (1.0 + m);
}
float tnd_max_abs(vec3 p)
{
    return max(abs(p.x), max(abs(p.y), abs(p.z)));
}
#else
#include <math.h>
static inline float tnd_offset_eps(float m)
{
    return (float)TND_OFFSET_EPS * (1.0f + m);
}
static inline float tnd_max_abs3(float x, float y, float z)
{
    float a = fabsf(x), b = fabsf(y), c = fabsf(z);
    float ab = a > b ? a : b;
    return ab > c ? ab : c;
}
#endif

#endif
