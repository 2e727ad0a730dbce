/* Structs shared by the trace test shaders (GLSL) and tests/test_frontend_vk.c (C). */
#ifndef TRACE_TEST_SHARED_H
#define TRACE_TEST_SHARED_H
#ifndef TND_GLSL
#include <stdint.h>
typedef struct {
    float x, y, z, w;
} tt_vec4;
typedef struct {
    float x, y;
} tt_vec2;
typedef struct {
    uint32_t x, y;
} tt_uvec2;
#define vec4  tt_vec4
#define vec2  tt_vec2
#define uvec2 tt_uvec2
#define int int32_t
#endif

struct tt_ray {
    vec4 origin_tmin; /* xyz origin, w tmin */
    vec4 dir_tmax;    /* xyz direction (need not be unit), w tmax */
};

struct tt_hit {
    float t; /* hit distance in units of the direction's length; -1 miss */
    int custom_index;
    int primitive;
    float pad0;
    vec2 bary;
    uvec2 pad;
};

#ifndef TND_GLSL
#undef vec4
#undef vec2
#undef uvec2
#undef int
typedef struct tt_ray tt_ray;
typedef struct tt_hit tt_hit;
_Static_assert(sizeof(tt_ray) == 32, "tt_ray layout");
_Static_assert(sizeof(tt_hit) == 32, "tt_hit layout");
#endif
#endif
