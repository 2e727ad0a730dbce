/* trace_test.rchit: reports distance, custom index, primitive and barycentrics of the hit. */
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "trace_test_shared.h"

layout(location = 0) rayPayloadInEXT tt_hit payload;
hitAttributeEXT vec2 bary;

void main()
{
    payload.t = gl_HitTEXT;
    payload.custom_index = gl_InstanceCustomIndexEXT;
    payload.primitive = gl_PrimitiveID;
    payload.bary = bary;
    payload.pad0 = 0.0;
    payload.pad = uvec2(0);
}
