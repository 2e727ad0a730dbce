/* pt.rchit: closest hit of the path-tracing passes: reports what the raygen reconstructs from. */
#version 460
#extension GL_EXT_ray_tracing : require

struct hit_info {
    float t;
    uint inst;
    uint prim;
    vec2 bary;
};
layout(location = 0) rayPayloadInEXT hit_info payload;
hitAttributeEXT vec2 bary;

void main()
{
    payload.t = gl_HitTEXT;
    payload.inst = uint(gl_InstanceCustomIndexEXT);
    payload.prim = uint(gl_PrimitiveID);
    payload.bary = bary;
}
