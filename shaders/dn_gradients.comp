/* dn_gradients.comp: the temporal gradient per stratum and its blur at 1/3 resolution, as Q2RTX
 * does. hf and spec are normalised before filtering: g = (|l_now - l_prev| / max(l_now,
 * l_prev))^2, l_now the re-shaded sample's luminance (the stratum's slot, c and d, as the
 * front-end wrote it; the contract holds the pixel's fresh sample), l_prev the pixel's raw
 * luminance last frame (0 without a sample or when both are 0). lf is too sparse for per-sample
 * ratios: the stratum's sums of the raw L0 now (summed here; at the sample pixel the re-shaded
 * L0, this frame's light on the previous frame's random numbers) and of the accumulated L0
 * history at the reprojected pixels (dn_grad_select.comp's, grad[0].y) go into zw, with the sum
 * of the raw L0's squares beside them (a bound on the variance of the sum now, blurred through
 * the squared weights), normalised after the blur: z = (max(|now - prev| - k sqrt(var), 0) /
 * max(now, prev))^2, k = DN_LF_NOISE_K (Q2RTX's has no noise term). The
 * blur: a-trous, step 2^i, 3x3 weights 1 / 0.5 / 0.25, no edge stopping, taps outside count as
 * zero (Q2RTX); hf and spec (xy) for iterations 0..2 (steps 1..4), lf (zw) for all 7 (steps
 * 1..64).
 * It runs separably: each 3x3 iteration is a 3-tap filter along x times one along y (weights
 * 0.25 / 0.5 / 0.25; an outside tap is zero on either axis, so the masks separate too), and
 * filters along different axes commute, so the seven iterations along rows (pc.iteration 0:
 * the gradients computed from grad[0] and the samples, filtered into grad[1]), then the seven
 * along columns (1: grad[1] -> grad[0], normalised) give the same result in two dispatches
 * instead of eight (a chain of tiny, latency-bound dispatches). A work group filters a segment
 * of DN_GRAD_SEGMENT strata of a row or column in shared memory, with REACH = 1 + 2 + ... + 64
 * strata of input on either side: an error at the window's edge moves inward by one step per
 * iteration, so the segment itself is exact. */
#version 460
#extension GL_GOOGLE_include_directive : require
#define DN_OWN_LOCAL_SIZE 1
#include "dn_common.glsl"
#define GROUP 512
layout(local_size_x = GROUP) in;
#define REACH 127
#define WIN_MAX (DN_GRAD_SEGMENT + 2 * REACH)
#define PER ((WIN_MAX + GROUP - 1) / GROUP)

shared vec4 s_v[WIN_MAX]; /* with s_var: 20 bytes a stratum, 15 320 bytes (512 + 254 strata):
                            within Vulkan's guaranteed 16 KiB */
shared float s_var[WIN_MAX];

/* Between the row and the column pass the hf and spec gradients (both in [0, 1]) share one
 * channel as two 12-bit fractions, a whole number under 2^24 (exact in a float), so that the
 * fifth value, the lf sum's variance, fits the rgba32f texel; the rounding (1.2e-4) is far under
 * anything the antilag acts on. */
float pack_hs(vec2 v)
{
    vec2 q = round(clamp(v, 0.0, 1.0) * 4095.0);
    return q.x * 4096.0 + q.y;
}
vec2 unpack_hs(float f)
{
    float hi = floor(f / 4096.0);
    return vec2(hi, f - hi * 4096.0) / 4095.0;
}

float grad_of(float now, float prev)
{
    float m = max(now, prev);
    if (!(m > 0.0))
        return 0.0;
    float r = abs(now - prev) / m;
    return r * r;
}

/* stratum s before the blur: xy the hf and spec gradients of its sample, zw the lf sums */
vec4 gradient(ivec2 s, out float var)
{
    vec4 g0 = imageLoad(grad[0], s); /* y: the lf history's sum, zw: the sample's previous lums */
    tnd_gpu_gradient smp = samples[uint(s.y * grad_size().x + s.x)];
    bool reshaded = smp.b.w != 0u && smp.d.w != 0.0;
    float now = 0.0; /* the raw lf L0 of the stratum's visible pixels, in row order */
    var = 0.0; /* and the sum of their squares: a bound on the variance of that sum (one
                  sample a pixel: E[x^2] >= Var x) */
    for (int j = 0; j < DN_STRATUM; j++)
        for (int i = 0; i < DN_STRATUM; i++) {
            ivec2 p = s * DN_STRATUM + ivec2(i, j);
            if (inside(p) && imageLoad(img_vis_id, p).x != TND_VIS_NONE) {
                float x = (reshaded && uint(p.y) * P.size.x + uint(p.x) == smp.a.x
                               ? (tnd_nonfinite(smp.c.w) ? 0.0 : smp.c.w)
                               : finite4(imageLoad(img_lf_sh, p)).w) /
                          diffuse_view(p); /* (as the histories hold it) */
                now += x;
                var += x * x;
            }
        }
    vec2 g = vec2(0.0);
    if (reshaded) {
        /* (without the view factor, as the previous luminance was stored: the pixel's, where
         * the re-shaded surface is) */
        ivec2 sp = ivec2(int(smp.a.x % P.size.x), int(smp.a.x / P.size.x));
        float hf = lum_rounded(luma(finite3(smp.c.rgb)) / diffuse_view(sp));
        float spec = lum_rounded(luma(finite3(smp.d.rgb)));
        g = vec2(grad_of(hf, g0.z), grad_of(spec, g0.w));
    }
    return vec4(g, max(vec2(now, g0.y), vec2(0.0)));
}

void main()
{
    bool cols = pc.iteration != 0u;
    ivec2 gs = grad_size();
    int len = cols ? gs.y : gs.x, line = int(gl_WorkGroupID.y);
    int seg = int(P.iters.w), win = seg + 2 * REACH; /* seg: DN_GRAD_SEGMENT but in tests */
    int w0 = int(gl_WorkGroupID.x) * seg - REACH; /* the window's first stratum on the axis */
    int lid = int(gl_LocalInvocationID.x);
    for (int k = 0; k < PER; k++) {
        int i = lid + k * GROUP, a = w0 + i;
        if (i < win) {
            vec4 v = vec4(0.0);
            float var = 0.0;
            if (a >= 0 && a < len) {
                if (cols) { /* the row pass's texel: hf and spec packed, the variance in w */
                    vec4 t = imageLoad(grad[1], ivec2(line, a));
                    v = vec4(unpack_hs(t.x), t.zy);
                    var = t.w;
                } else {
                    v = gradient(ivec2(a, line), var);
                }
            }
            s_v[i] = v;
            s_var[i] = var;
        }
    }
    barrier();
    vec4 r[PER];
    float rv[PER];
    for (int it = 0; it < 7; it++) {
        int step = 1 << it;
        for (int k = 0; k < PER; k++) {
            int i = lid + k * GROUP, a = w0 + i;
            vec4 v = vec4(0.0);
            float var = 0.0;
            if (i < win && a >= 0 && a < len) { /* outside the grid stays zero */
                vec4 c = s_v[i];
                vec4 lo = i >= step ? s_v[i - step] : vec4(0.0);
                vec4 hi = i + step < win ? s_v[i + step] : vec4(0.0);
                v = 0.5 * c + 0.25 * (lo + hi);
                if (it >= 3) /* hf and spec are done after step 4 */
                    v.xy = c.xy;
                /* the variance through the same weights, squared (the strata's sums taken as
                 * independent) */
                var = 0.25 * s_var[i] + 0.0625 * ((i >= step ? s_var[i - step] : 0.0) +
                                                  (i + step < win ? s_var[i + step] : 0.0));
            }
            r[k] = v;
            rv[k] = var;
        }
        barrier();
        for (int k = 0; k < PER; k++)
            if (lid + k * GROUP < win) {
                s_v[lid + k * GROUP] = r[k];
                s_var[lid + k * GROUP] = rv[k];
            }
        barrier();
    }
    for (int k = 0; k < PER; k++) {
        int i = lid + k * GROUP, a = w0 + i;
        if (i < REACH || i >= REACH + seg || a >= len)
            continue;
        vec4 o = s_v[i];
        if (cols) {
            /* the lf gradient: the difference of the sums beyond DN_LF_NOISE_K standard deviations
             * of this frame's sum (its noise, which a 1-spp indirect signal's bright samples
             * make large: without this the antilag shortens still and thin parts' histories on
             * noise alone, and its gain had to stay low enough that a light switched off took
             * five frames to leave the indirect light), over the larger sum */
            float m = max(o.z, o.w);
            float d = max(abs(o.z - o.w) - DN_LF_NOISE_K * sqrt(max(s_var[i], 0.0)), 0.0);
            float q = m > 0.0 ? d / m : 0.0;
            o.zw = vec2(q * q, 0.0);
            imageStore(grad[0], ivec2(line, a), o);
        } else {
            imageStore(grad[1], ivec2(a, line), vec4(pack_hs(o.xy), o.w, o.z, s_var[i]));
        }
    }
}
