/* Ray origins off a surface, shared by both front-ends (C and GLSL).
 *
 * A ray leaving a surface point p starts at p + eps n (n: the geometric normal on the side the
 * ray leaves), and a shadow ray towards a point q on an emitter ends at q + eps_q n_l (n_l: the
 * emitter's normal on the receiver's side), with its direction and length computed from those
 * two offset points (so that the ray can neither start under its own surface nor reach the
 * emitter's plane, whatever the distance between them).
 *
 * eps scales with the magnitude of the coordinates, as their rounding errors do: the point is
 * interpolated from a triangle's vertices and moved by an instance transform in float (a few
 * u m of error, u = 2^-24 the unit roundoff, m the largest coordinate magnitude), and the
 * intersector moves the ray into the instance's space and forms vertex - origin at the same
 * magnitude (a few u m more); eps = 16 u (1 + m) (8 to 16 ulps of m) leaves a margin over their
 * sum. The 1 + m floor keeps 16 u (1e-6 units) at the origin. The offset is along the normal, so
 * a ray at a grazing angle leaves the surface as surely as a perpendicular one.
 *
 * No larger than that: a ray sees the scene from its offset origin, so a BRDF sample taken h
 * from an emitter sees it as from h - eps (tests/lambert_probe.h measures it: 32 u moved the
 * irradiance 10 cm under an emitter 1e4 units from the origin by +8%). Mitsuba 3 uses the same
 * form with 89 u; Waechter and Binder's integer offset of 256 ulps per coordinate, which Tandem
 * used before, moved points 2 units at 1e5 from the origin.
 *
 * The same formula on both sides gives the same origins to the last bit in C; a GPU may fuse
 * p + eps n into one FMA (within one rounding of it). */
#ifndef TND_OFFSET_H
#define TND_OFFSET_H

#define TND_OFFSET_EPS (16.0 / 16777216.0) /* 16 u */

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
