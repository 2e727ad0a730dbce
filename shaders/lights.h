/* The light list both front-ends sample for next-event estimation, built on the CPU each frame
 * (core: tnd_lights_build) and uploaded as is to the GPU. std430 layout, vec4 members only.
 *
 * Selection: light i is picked with probability pick = power_i / sum of powers (flux: pi L A for
 * an emissive triangle, 4 pi I for point lights, 2 pi (1 - cos outer) I for spots, pi R^2 E for
 * directional lights with R the scene's bounding radius, pi R^2 x 4 pi x mean luminance for the
 * environment map: kind TND_LIGHT_KIND_ENV, shaders/env.h, sampled by its own distribution), by
 * binary search for the first cdf > u.
 * Area lights are sampled uniformly by area; pdf in solid angle = pick d^2 / (A |cos theta_l|).
 * A one-sided emitter lights only the side its triangle's normal (v1 - v0) x (v2 - v0) faces; a
 * two-sided one (a double-sided emissive material: p1.w = 1) both sides, with twice the power
 * in the pick, and NEE samples it from either side (|cos theta_l|), as a BRDF sample that hits
 * either face sees it. */
#ifndef TND_LIGHTS_H
#define TND_LIGHTS_H

#define TND_LIGHT_KIND_TRIANGLE 0u
#define TND_LIGHT_KIND_POINT 1u
#define TND_LIGHT_KIND_SPOT 2u
#define TND_LIGHT_KIND_DIRECTIONAL 3u

#ifndef TND_GLSL
#include <stdint.h>
typedef struct { float x, y, z, w; } tnd_lvec4;
#define vec4 tnd_lvec4
#endif

struct tnd_light_gpu {
    vec4 p0;       /* triangle: v0 (world); point/spot: position; w: kind (as float) */
    vec4 p1;       /* triangle: v1, w: 1 two-sided, 0 one-sided; spot/directional: unit direction
                      the light travels */
    vec4 p2;       /* triangle: v2; spot: x = cos(inner), y = cos(outer) */
    vec4 radiance; /* rgb: radiance (triangle, nits), intensity (cd), illuminance (lux),
                      schedule scale applied; w: pick probability */
    vec4 cdf;      /* x: cumulative pick probability (inclusive); y: instance; z: primitive
                      (uint values stored exactly as floats < 2^24); w: area (triangle) */
};

#ifndef TND_GLSL
#undef vec4
typedef struct tnd_light_gpu tnd_light_gpu;
_Static_assert(sizeof(tnd_light_gpu) == 80, "tnd_light_gpu is 5 vec4");
#endif

#endif
