/* timestamp_test.comp: out[i] = in[i] * scale + offset; a tiny pass for the Vulkan context tests
 * (compute pipeline from SPIR-V, push constants, specialisation constants, timestamps). */
#version 460
layout(local_size_x_id = 0) in;
layout(set = 0, binding = 0, std430) readonly buffer In { float src[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Out { float dst[]; };
layout(push_constant) uniform Push { float scale; float offset; uint count; } pc;

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i < pc.count)
        dst[i] = src[i] * pc.scale + pc.offset;
}
