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
    /* the scene's instance: a merged run's first plus the geometry (frontend_vk/fvk_scene.c) */
    payload.inst = uint(gl_InstanceCustomIndexEXT + gl_GeometryIndexEXT);
    payload.prim = uint(gl_PrimitiveID);
    payload.bary = bary;
}
