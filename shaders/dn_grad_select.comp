/* dn_grad_select.comp: A-SVGF's gradient samples (Schied et al. 2018; Q2RTX's choice rules): one
 * per 3x3 stratum, among the stratum's pixels whose surface was visible in the previous frame at
 * the motion's target (same instance, depth within 10%, geometric normal within 25 degrees),
 * that were not last frame's gradient sample (reusing a random sequence twice biases), picking
 * the brightest previous hf + spec (a random pick in a moving penumbra often misses the change).
 * Writes the sample (pixel, the previous frame's rng key and surface) for the front-end to
 * re-shade, the previous luminances, and this frame's sample mask. One thread per stratum. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"

void main()
{
    ivec2 s = ivec2(gl_GlobalInvocationID.xy);
    ivec2 gs = grad_size();
    if (s.x >= gs.x || s.y >= gs.y)
        return;
    uint index = uint(s.y * gs.x + s.x);
    float best = 0.0;
    ivec2 best_p = ivec2(-1), best_pp = ivec2(-1);
    for (int j = 0; j < DN_STRATUM; j++)
        for (int i = 0; i < DN_STRATUM; i++) {
            ivec2 p = s * DN_STRATUM + ivec2(i, j);
            if (!inside(p))
                continue;
            imageStore(grad_flag, p, uvec4(0u));
            if (P.size.z == 0u)
                continue;
            uvec2 vis = imageLoad(img_vis_id, p).xy;
            if (vis.x == TND_VIS_NONE)
                continue;
            vec3 m = imageLoad(img_motion, p).xyz;
            ivec2 pp = ivec2(floor(vec2(p) + P.jitter.xy + m.xy - P.jitter.zw + 0.5));
            if (!inside(pp) || imageLoad(prev_vis, pp).x != vis.x)
                continue;
            uint pz = uint(imageLoad(prev_bary, pp).z); /* bit 0 was a sample, bits 1-2 field */
            if ((pz & 1u) != 0u ||
                (pz >> 1u) != (imageLoad(img_path, p).x & (TND_PATH_SPLIT | TND_PATH_REFRACT)))
                continue;
            vec4 g = imageLoad(prev_gb, pp);
            float depth = imageLoad(img_depth, p).x;
            if (abs(g.x - (depth + m.z)) > 0.1 * depth ||
                dot(g.yzw, imageLoad(img_geo_normal, p).xyz) < 0.9)
                continue;
            vec4 pl = imageLoad(prev_lum, pp);
            float l = pl.x + pl.y;
            if (l > best) {
                best = l;
                best_p = p;
                best_pp = pp;
            }
        }
    tnd_gpu_gradient smp;
    smp.a = uvec4(TND_GRADIENT_NONE, 0u, 0u, 0u);
    smp.b = uvec4(0u);
    vec4 gout = vec4(0.0);
    if (best > 0.0) {
        vec4 pl = imageLoad(prev_lum, best_pp);
        uvec2 pv = imageLoad(prev_vis, best_pp).xy;
        vec2 pb = imageLoad(prev_bary, best_pp).xy;
        smp.a = uvec4(uint(best_p.y) * P.size.x + uint(best_p.x), floatBitsToUint(pl.z),
                      floatBitsToUint(pl.w), pv.x);
        smp.b = uvec4(pv.y, floatBitsToUint(pb.x), floatBitsToUint(pb.y), 1u);
        imageStore(grad_flag, best_p, uvec4(1u));
        gout = vec4(0.0, 0.0, pl.x, pl.y);
    }
    samples[index] = smp;
    imageStore(grad[0], s, gout);
}
