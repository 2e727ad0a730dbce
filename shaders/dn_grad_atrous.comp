/* dn_grad_atrous.comp: densify the sparse gradients: a-trous blur at 1/3 resolution, step 2^i,
 * 3x3 weights 1 / 0.5 / 0.25, no edge stopping, taps outside count as zero (Q2RTX). hf and spec
 * gradients (xy) blur for iterations 0..2 (steps 1..4), the lf sums (zw) for all 7 (steps
 * 1..64); at the end the lf sums are normalised: z = (|now - prev| / max(now, prev))^2.
 * Iteration 0 ends dn_grad_image.comp (slot 1). Iterations 1..6 are done here, separably: each
 * 3x3 iteration is a 3-tap filter along x times one along y (weights 0.25 / 0.5 / 0.25; an
 * outside tap is zero on either axis, so the masks separate too), and filters along different
 * axes commute, so the six iterations along rows (pc.iteration 0: slot 1 -> slot 0), then the
 * six along columns (1: slot 0 -> slot 1, normalised) give the same result in two dispatches
 * instead of six (a chain of tiny, latency-bound dispatches). A work group filters a segment of
 * DN_GRAD_SEGMENT strata of a row or column in shared memory, with REACH = 2 + 4 + ... + 64
 * strata of input on either side: an error at the window's edge moves inward by one step per
 * iteration, so the segment itself is exact. */
#version 460
#extension GL_GOOGLE_include_directive : require
#define DN_OWN_LOCAL_SIZE 1
#include "dn_common.glsl"
#define GROUP 256
layout(local_size_x = GROUP) in;
#define REACH 126
#define WIN_MAX (DN_GRAD_SEGMENT + 2 * REACH)
#define PER ((WIN_MAX + GROUP - 1) / GROUP)

shared vec4 s_v[WIN_MAX]; /* 16 320 bytes: within Vulkan's guaranteed 16 KiB */

void main()
{
    bool cols = pc.iteration != 0u;
    ivec2 gs = grad_size();
    int len = cols ? gs.y : gs.x, line = int(gl_WorkGroupID.y);
    int seg = int(P.iters.w), win = seg + 2 * REACH; /* seg: DN_GRAD_SEGMENT but in tests */
    int w0 = int(gl_WorkGroupID.x) * seg - REACH; /* the window's first stratum on the axis */
    uint src = cols ? 0u : 1u;
    int lid = int(gl_LocalInvocationID.x);
    for (int k = 0; k < PER; k++) {
        int i = lid + k * GROUP, a = w0 + i;
        if (i < win)
            s_v[i] = a >= 0 && a < len ? imageLoad(grad[src], cols ? ivec2(line, a) : ivec2(a, line))
                                       : vec4(0.0);
    }
    barrier();
    vec4 r[PER];
    for (int it = 1; it < 7; it++) {
        int step = 1 << it;
        for (int k = 0; k < PER; k++) {
            int i = lid + k * GROUP, a = w0 + i;
            vec4 v = vec4(0.0);
            if (i < win && a >= 0 && a < len) { /* outside the grid stays zero */
                vec4 c = s_v[i];
                vec4 lo = i >= step ? s_v[i - step] : vec4(0.0);
                vec4 hi = i + step < win ? s_v[i + step] : vec4(0.0);
                v = 0.5 * c + 0.25 * (lo + hi);
                if (it >= 3) /* hf and spec are done after step 4 */
                    v.xy = c.xy;
            }
            r[k] = v;
        }
        barrier();
        for (int k = 0; k < PER; k++)
            if (lid + k * GROUP < win)
                s_v[lid + k * GROUP] = r[k];
        barrier();
    }
    for (int k = 0; k < PER; k++) {
        int i = lid + k * GROUP, a = w0 + i;
        if (i < REACH || i >= REACH + seg || a >= len)
            continue;
        vec4 o = s_v[i];
        if (cols) {
            float m = max(o.z, o.w);
            float q = m > 0.0 ? abs(o.z - o.w) / m : 0.0;
            o.zw = vec2(q * q, 0.0);
        }
        imageStore(grad[1u - src], cols ? ivec2(line, a) : ivec2(a, line), o);
    }
}
