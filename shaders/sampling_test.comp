/* sampling_test.comp: draws tnd_rand for (pixel, frame, sample, dim) keys, so that a test can
 * compare the GLSL generator with its C mirror bit for bit. */
#version 460
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
#include "sampling.h"

layout(set = 0, binding = 0, std430) readonly buffer In { uvec4 src[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Out { uvec4 dst[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count)
        return;
    uvec4 k = src[i];
    float r = tnd_rand(k.x, k.y, k.z, k.w);
    dst[i] = uvec4(floatBitsToUint(r), tnd_pcg4d(k).yzw);
}
