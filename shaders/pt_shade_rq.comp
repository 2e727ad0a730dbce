/* pt_shade_rq.comp: the ray-query twin of pt_shade.rgen (same body, inline ray queries), for
 * devices with VK_KHR_ray_query (--rt-api query). 8x8 groups over the image (modes 0 and 2;
 * mode 2's slot rows below it); gradient samples (shade modes 1 and 3) are numbered linearly
 * over groups of 64. */
#version 460
#extension GL_GOOGLE_include_directive : require
#define TND_RAY_QUERY 1
#define TND_SHADE_PASS 1
layout(local_size_x = 8, local_size_y = 8) in;
#include "pt_shade.glsl"

void main()
{
    uvec2 launch = gl_GlobalInvocationID.xy;
#ifdef TND_SHADE_PASS
    if (pc.mode == 1u || pc.mode == 3u) {
        uint i = gl_WorkGroupID.x * 64u + gl_LocalInvocationIndex;
        if (i >= fr.params.z)
            return;
        launch = uvec2(i, 0u);
    } /* (mode 0: pt_shade_main tests the launch's bounds) */
#else
    if (launch.x >= fr.frame.y || launch.y >= fr.frame.z)
        return;
#endif
    pt_shade_main(launch);
}
