/* pt_reference (body): the reference mode on the GPU (mirror of femb_render.c reference_tile):
 * one full path per pixel per dispatch, per-sample random pixel jitter, accumulated into `accum`
 * (rgb sum, luminance^2 sum in alpha) from the batch's first sample on (fvk_reference_add adds
 * each batch's sums to its own in double). */
#include "pt_common.glsl"

layout(set = 0, binding = 13, rgba32f) uniform image2D accum;
layout(push_constant) uniform Push { uint sample_index, batch_first; } pc;

void pt_reference_main(uvec2 launch)
{
    ivec2 ip = ivec2(launch);
    uint q = launch.y * fr.frame.y + launch.x;
    uvec3 key = uvec3(q, fr.frame.x, tnd_reference_sample(pc.sample_index));
    float jx = tnd_rand(key.x, key.y, key.z, TND_DIM_JITTER_X);
    float jy = tnd_rand(key.x, key.y, key.z, TND_DIM_JITTER_Y);
    vec3 dir = camera_dir(vec2(launch) + vec2(jx, jy));
    /* params.x: the bounces of a matched reference (fvk_set_reference_bounces), 0: full paths */
    uint max_bounce = fr.params.x != 0u ? fr.params.x : TND_REFERENCE_MAX_BOUNCES;
    vec3 L = trace_path(key, fr.cam_pos.xyz, fr.cam_pos.xyz, dir, 0u, max_bounce, 3u, 0.0, 0.0);
    float lum = tnd_luminance(L.r, L.g, L.b);
    vec4 a = pc.sample_index == pc.batch_first ? vec4(0.0) : imageLoad(accum, ip);
    imageStore(accum, ip, a + vec4(L, lum * lum));
}
