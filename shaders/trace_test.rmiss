/* trace_test.rmiss: a miss is reported as t = -1. */
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "trace_test_shared.h"

layout(location = 0) rayPayloadInEXT tt_hit payload;

void main()
{
    payload.t = -1.0;
    payload.custom_index = -1;
    payload.primitive = -1;
    payload.bary = vec2(0.0);
    payload.pad0 = 0.0;
    payload.pad = uvec2(0);
}
