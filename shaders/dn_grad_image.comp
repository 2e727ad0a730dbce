/* dn_grad_image.comp: the temporal gradient per stratum, as Q2RTX does. hf and spec are
 * normalised before filtering: g = (|l_now - l_prev| / max(l_now, l_prev))^2 at the re-shaded
 * sample pixel (0 without a sample or when both are 0). lf is too sparse for per-sample ratios:
 * the stratum's sums of the raw L0 now and of the accumulated L0 history at the reprojected
 * pixels (summed by dn_grad_select.comp into grad[1].zw) go into zw, normalised after the blur.
 * One thread per stratum. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"

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
    ivec2 s = ivec2(gl_GlobalInvocationID.xy);
    ivec2 gs = grad_size();
    if (s.x >= gs.x || s.y >= gs.y)
        return;
    vec2 sum = imageLoad(grad[1], s).zw;
    tnd_gpu_gradient smp = samples[uint(s.y * gs.x + s.x)];
    vec2 g = vec2(0.0);
    if (smp.b.w != 0u) {
        vec2 prev = imageLoad(grad[0], s).zw;
        ivec2 q = ivec2(int(smp.a.x % P.size.x), int(smp.a.x / P.size.x));
        float hf = luma(finite3(load_hf(q))), spec = luma(finite3(load_spec(q)));
        g = vec2(grad_of(hf, prev.x), grad_of(spec, prev.y));
    }
    imageStore(grad[0], s, vec4(g, max(sum, vec2(0.0))));
}
