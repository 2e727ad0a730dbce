/* dn_grad_image.comp: the temporal gradient per stratum, as Q2RTX does. hf and spec are
 * normalised before filtering: g = (|l_now - l_prev| / max(l_now, l_prev))^2 at the re-shaded
 * sample pixel (0 without a sample or when both are 0). lf is too sparse for per-sample ratios:
 * the stratum's sums of the raw L0 now and of the accumulated L0 history at the reprojected
 * pixels go into zw, normalised after the blur. One thread per pixel for the sums (tiles of
 * strata, summed in row order through shared memory), one per stratum for the rest. */
#version 460
#extension GL_GOOGLE_include_directive : require
#define DN_STRATUM_TILES 1
#include "dn_common.glsl"

shared vec2 s_lf[DN_TILE_N];

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
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    uint li = gl_LocalInvocationIndex;
    vec2 lf = vec2(0.0); /* raw lf L0 now, accumulated lf L0 at the reprojection */
    if (inside(p) && imageLoad(img_vis_id, p).x != TND_VIS_NONE) {
        vec3 m = imageLoad(img_motion, p).xyz;
        if (tnd_nonfinite(m.x) || tnd_nonfinite(m.y))
            m = vec3(0.0);
        lf.x = finite4(imageLoad(img_lf_sh, p)).w;
        ivec2 pp = ivec2(floor(vec2(p) + P.jitter.xy + m.xy - P.jitter.zw + 0.5));
        if (inside(pp))
            lf.y = finite4(imageLoad(hist_lf_sh[1u - pc.slot], pp)).w;
    }
    s_lf[li] = lf;
    barrier();
    if (li >= DN_TILE_STRATA)
        return;
    ivec2 s = tile_stratum(li);
    ivec2 gs = grad_size();
    if (s.x >= gs.x || s.y >= gs.y)
        return;
    vec2 sum = vec2(0.0);
    for (int j = 0; j < DN_STRATUM; j++)
        for (int i = 0; i < DN_STRATUM; i++)
            sum += s_lf[tile_pixel_index(li, i, j)];
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
