/* bandwidth_copy.comp: a STREAM-style copy (16 bytes per invocation, grid-stride) between two
 * storage buffers, for tnd_copy_bandwidth: the memory-bandwidth floor that compute passes can
 * reach, which vkCmdCopyBuffer (a DMA engine on some devices) does not show. */
#version 460
layout(local_size_x = 256) in;
layout(set = 0, binding = 0, std430) readonly buffer Src { uvec4 src[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Dst { uvec4 dst[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main()
{
    uint stride = gl_NumWorkGroups.x * 256u;
    for (uint i = gl_GlobalInvocationID.x; i < pc.count; i += stride)
        dst[i] = src[i];
}
