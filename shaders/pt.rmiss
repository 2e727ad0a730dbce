/* pt.rmiss: a closest-hit query that escapes. */
#version 460
#extension GL_EXT_ray_tracing : require

struct hit_info {
    float t;
    uint inst;
    uint prim;
    vec2 bary;
};
layout(location = 0) rayPayloadInEXT hit_info payload;

void main()
{
    payload.t = -1.0;
}
