/* pt_primary (body): the primary pass of the Vulkan front-end (mirror of femb_render.c
 * primary_tile): camera ray, visibility buffer, G-buffer, motion vectors, rng keys. One launch
 * per pixel; writes the contract images of set 1. */
#include "pt_common.glsl"


/* Pixel position of the point at d from the camera's position (of direction d when `direction`);
 * d relative to the camera, never formed from a world point (xf_point_rel). */
bool project_px(mat4 view, mat4 proj, vec3 d, bool direction, out vec2 px)
{
    vec3 v = mat3(view) * d;
    vec4 clip = proj * vec4(v, direction ? 0.0 : 1.0);
    px = vec2(0.0);
    if (!(abs(clip.w) > 1e-30))
        return false;
    px = (clip.xy / clip.w * 0.5 + 0.5) * vec2(fr.frame.yz);
    return true;
}

void pt_primary_main(uvec2 launch)
{
    ivec2 ip = ivec2(launch);
    uint W = fr.frame.y;
    uint q = uint(ip.y) * W + uint(ip.x);
    chain_result ch = specular_chain(uvec2(ip), USES(TND_USES_SPECULAR));
    imageStore(img_path, ip, uvec4(ch.path, 0u, 0u, 0u));
    vec3 dir = ch.dir0;
    vec3 cam = fr.cam_pos.xyz;
    imageStore(img_rng, ip, uvec4(fr.frame.x, q, 0u, 0u));
    imageStore(img_throughput, ip, vec4(ch.thr, 0.0));
    hit_info h;
    h.inst = ch.inst;
    h.prim = ch.prim;
    h.bary = ch.bary;
    vec2 cur_px, prev_px;
    if (!ch.hit) {
        imageStore(img_albedo, ip, vec4(0.0));
        imageStore(img_normal, ip, vec4(0.0));
        imageStore(img_geo_normal, ip, vec4(0.0));
        imageStore(img_position, ip, vec4(0.0));
        imageStore(img_emission, ip, vec4(miss_radiance(ch.dir, 0.0) * ch.thr, 0.0));
        imageStore(img_depth, ip, vec4(TND_DEPTH_MISS));
        imageStore(img_vis_id, ip, uvec4(TND_VIS_NONE, TND_VIS_NONE, 0u, 0u));
        imageStore(img_vis_bary, ip, vec4(0.0));
        imageStore(img_roughness, ip, vec4(1.0));
        imageStore(img_metallic, ip, vec4(0.0));
        vec3 mo = vec3(0.0);
        if (project_px(fr.view, fr.proj, dir, true, cur_px) &&
            project_px(fr.prev_view, fr.prev_proj, dir, true, prev_px))
            mo.xy = prev_px - cur_px;
        imageStore(img_motion, ip, vec4(mo, 0.0));
        return;
    }
    surface s;
    float dist;
    if (ch.vertices == 0u) {
        vec3 dv = surface_from_camera(h.inst, h.prim, h.bary);
        dist = sqrt(dot(dv, dv));
        s = surface_eval(h.inst, h.prim, h.bary, safe_normalize(dv), dist * fr.jitter.z);
    } else { /* seen in a mirror or through glass: the surface at the chain's end */
        dist = ch.len;
        s = surface_eval(h.inst, h.prim, h.bary, ch.dir, dist * fr.jitter.z);
    }
    imageStore(img_albedo, ip, vec4(s.base, 0.0));
    imageStore(img_emission, ip, vec4(s.emission * ch.thr, 0.0));
    imageStore(img_normal, ip, vec4(s.ns, 0.0));
    imageStore(img_geo_normal, ip, vec4(s.ng, 0.0));
    imageStore(img_position, ip, vec4(s.p, 0.0));
    imageStore(img_depth, ip, vec4(dist));
    imageStore(img_vis_id, ip, uvec4(h.inst, h.prim, 0u, 0u));
    imageStore(img_vis_bary, ip, vec4(h.bary, 0.0, 0.0));
    imageStore(img_roughness, ip, vec4(s.roughness));
    imageStore(img_metallic, ip, vec4(s.metallic));
    vec3 mo = vec3(0.0);
    if (ch.vertices > 0u) {
        /* the virtual point along the camera ray at the chain's length (mirror, glass still) */
        vec3 dc = dir * ch.len, dp = (cam - fr.prev_cam_pos.xyz) + dc;
        if (project_px(fr.view, fr.proj, dc, false, cur_px) &&
            project_px(fr.prev_view, fr.prev_proj, dp, false, prev_px))
            mo.xy = prev_px - cur_px;
        mo.z = length(dp) - ch.len;
        imageStore(img_motion, ip, vec4(mo, 0.0));
        return;
    }
    tnd_gpu_instance I = instances[h.inst];
    vec3 dp = xf_point_rel(I.prev_xform, s.obj, fr.prev_cam_pos.xyz);
    vec3 dc = xf_point_rel(I.xform, s.obj, cam);
    if (project_px(fr.view, fr.proj, dc, false, cur_px) &&
        project_px(fr.prev_view, fr.prev_proj, dp, false, prev_px))
        mo.xy = prev_px - cur_px;
    mo.z = length(dp) - length(dc);
    imageStore(img_motion, ip, vec4(mo, 0.0));
}
