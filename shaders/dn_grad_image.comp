/* dn_grad_image.comp: the temporal gradient per stratum, as Q2RTX does, and the first iteration
 * of its blur (dn_grad_atrous.comp does the other six). hf and spec are normalised before
 * filtering: g = (|l_now - l_prev| / max(l_now, l_prev))^2 at the re-shaded sample pixel (0
 * without a sample or when both are 0). lf is too sparse for per-sample ratios: the stratum's
 * sums of the raw L0 now and of the accumulated L0 history at the reprojected pixels (summed by
 * dn_grad_select.comp into grad[0].xy) go into zw, normalised after the blur. A work group of
 * 10 x 10 threads computes the gradients of 8 x 8 strata and their one-stratum border into
 * shared memory, then the inner 64 blur them (step 1; the same sums as dn_grad_atrous.comp's
 * iteration 0) into grad[1]: one dispatch less in a chain of latency-bound ones. */
#version 460
#extension GL_GOOGLE_include_directive : require
#define DN_OWN_LOCAL_SIZE 1
#include "dn_common.glsl"
layout(local_size_x = 10, local_size_y = 10) in;

shared vec4 s_g[10][10]; /* the gradients of the tile and its border (0 outside the grid) */

float grad_of(float now, float prev)
{
    float m = max(now, prev);
    if (!(m > 0.0))
        return 0.0;
    float r = abs(now - prev) / m;
    return r * r;
}

void main()
{
    ivec2 l = ivec2(gl_LocalInvocationID.xy);
    ivec2 s = ivec2(gl_WorkGroupID.xy) * 8 + l - 1;
    vec4 v = vec4(0.0);
    if (in_grid(s)) {
        ivec2 gs = grad_size();
        vec4 g0 = imageLoad(grad[0], s); /* xy: lf sums, zw: the sample's previous lums */
        tnd_gpu_gradient smp = samples[uint(s.y * gs.x + s.x)];
        vec2 g = vec2(0.0);
        if (smp.b.w != 0u) {
            ivec2 q = ivec2(int(smp.a.x % P.size.x), int(smp.a.x / P.size.x));
            float hf = lum_rounded(luma(finite3(load_hf(q))));
            float spec = lum_rounded(luma(finite3(load_spec(q))));
            g = vec2(grad_of(hf, g0.z), grad_of(spec, g0.w));
        }
        v = vec4(g, max(g0.xy, vec2(0.0)));
    }
    s_g[l.y][l.x] = v;
    barrier();
    if (any(lessThan(l, ivec2(1))) || any(greaterThan(l, ivec2(8))) || !in_grid(s))
        return;
    vec4 sum = vec4(0.0);
    float wsum = 0.0;
    for (int y = -1; y <= 1; y++)
        for (int x = -1; x <= 1; x++) {
            float w = (x == 0 ? 1.0 : 0.5) * (y == 0 ? 1.0 : 0.5);
            wsum += w;
            if (!in_grid(s + ivec2(x, y)))
                continue;
            sum += w * s_g[l.y + y][l.x + x];
        }
    imageStore(grad[1], s, sum / wsum);
}
