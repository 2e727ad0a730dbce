/* encoding_test.comp: RGBE-encodes (and tnd_uf16-encodes, also from scaled values) vec3 inputs
 * with shaders/encoding.h, so that a test can compare
 * the bits with the C mirror; also declares the whole contract (both precisions are compiled) to
 * keep the GLSL side of shaders/contract.h honest. */
#version 460
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;
#include "encoding.h"
#define TND_CONTRACT_SET 1
#include "contract.h"
TND_CONTRACT(TND_CT_DECLARE)

layout(set = 0, binding = 0, std430) readonly buffer In { vec4 src[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Out { uvec4 dst[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count)
        return;
    vec4 v = src[i];
    uint p = tnd_rgbe_encode(v.x, v.y, v.z);
    vec3 d = tnd_rgbe_decode(p);
    dst[i] = uvec4(p, floatBitsToUint(d.x), floatBitsToUint(d.y), tnd_nonfinite(v.w) ? 1u : 0u);
    uvec3 h = uvec3(tnd_uf16_encode(v.x), tnd_uf16_encode(v.y), tnd_uf16_encode(v.z));
    dst[i + pc.count] = uvec4(h.x | h.y << 16u, floatBitsToUint(tnd_uf16_decode(h.x)),
                              floatBitsToUint(tnd_uf16_decode(h.y)), floatBitsToUint(tnd_uf16_decode(h.z)));
    const float s = 1.0 / 39614081257132168796771975168.0; /* 2^(BIAS - 127) */
    dst[i + 2u * pc.count] = uvec4(tnd_uf16_encode_scaled(v.x * s), tnd_uf16_encode_scaled(v.y * s),
                                   tnd_uf16_encode_scaled(v.z * s), 0u);
}
