/* dn_grad_atrous.comp: densify the sparse gradients: a-trous blur at 1/3 resolution, step 2^i,
 * 3x3 weights 1 / 0.5 / 0.25, no edge stopping, taps outside count as zero (Q2RTX). Iteration i
 * (1..6; 0 ends dn_grad_image.comp) reads slot i & 1, so the result lands in slot 1. hf and
 * spec gradients (xy) blur for iterations 0..2 (steps 1..4), the lf sums (zw) for all 7 (steps
 * 1..64), and the last one normalises them: z = (|now - prev| / max(now, prev))^2. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"

void main()
{
    ivec2 s = ivec2(gl_GlobalInvocationID.xy);
    if (!in_grid(s))
        return;
    uint src = pc.iteration & 1u;
    int step = 1 << int(pc.iteration);
    vec4 sum = vec4(0.0);
    float wsum = 0.0;
    for (int y = -1; y <= 1; y++)
        for (int x = -1; x <= 1; x++) {
            ivec2 q = s + ivec2(x, y) * step;
            float w = (x == 0 ? 1.0 : 0.5) * (y == 0 ? 1.0 : 0.5);
            wsum += w;
            if (!in_grid(q))
                continue;
            sum += w * imageLoad(grad[src], q);
        }
    sum /= wsum;
    vec4 c = imageLoad(grad[src], s);
    vec4 o = vec4(pc.iteration < 3u ? sum.xy : c.xy, sum.zw);
    if (pc.iteration == 6u) {
        float m = max(o.z, o.w);
        float r = m > 0.0 ? abs(o.z - o.w) / m : 0.0;
        o.zw = vec2(r * r, 0.0);
    }
    imageStore(grad[1u - src], s, o);
}
