/* pt_reference_rq.comp: the ray-query twin of pt_reference.rgen. */
#version 460
#extension GL_GOOGLE_include_directive : require
#define TND_RAY_QUERY 1
layout(local_size_x = 8, local_size_y = 8) in;
#include "pt_reference.glsl"

void main()
{
    uvec2 launch = gl_GlobalInvocationID.xy;
    if (launch.x >= fr.frame.y || launch.y >= fr.frame.z)
        return;
    pt_reference_main(launch);
}
