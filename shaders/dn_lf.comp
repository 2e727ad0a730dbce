/* dn_lf.comp: the indirect diffuse (lf) spatial filter at 1/3 resolution, in SH form (Q2RTX's
 * choice: lf is smooth and sparse, so a 3x3 stratum loses nothing a full-resolution filter would
 * keep, and every pass touches 1/9 of the pixels). One thread per stratum; push constant
 * iteration k:
 * - k = 0, the downsample onto the strata's anchors (writes slot 0 and lf_geo): a shader of its
 *   own, dn_lf_down.comp, which says how;
 * - k = 1, deflicker: where L0 exceeds 2x (P.lf.x; 0 turns it off) the mean L0 of the 8
 *   low-res pixels at distance 2 (a firefly that the temporal pass could not average away), SH
 *   and chroma are scaled down to that limit. Q2RTX compares with the 8 adjacent pixels; a
 *   moving camera's bilinear reprojection spreads a firefly kept in the history into adjacent
 *   strata, which then hide it (test_lf_firefly_is_deflickered: brightest pixel 1.11x the
 *   clean run, energy added -0.07%, against 7.3x and 5.9% without deflicker).
 * - k = 2 .. iters + 1: a-trous, step 2^(k-2) low-res pixels (3, 6, 12 full-res pixels), 3x3 taps
 *   1 / 0.5 / 0.25, geometry weights (the centre's distance to the tap's tangent plane against
 *   the footprint, normals^8) and a luminance weight exp(-|L0_q - L0_p| / (sigma sqrt(var_p +
 *   var_q))), sigma = P.lf.z, the variances those of the anchors' noise (dn_lf_down.comp),
 *   filtered with squared weights from one iteration to the next; the last iteration adds the
 *   light-leak guard
 *   w *= clamp(1.5 - 0.25 l_q / l_p, 0, 1) (a neighbour more than 2x brighter than the centre
 *   is attenuated, more than 6x is dropped).
 * Pass k >= 1 reads slot (k - 1) & 1 and writes slot k & 1; the result lands in slot
 * (iters + 1) & 1, which dn_composite.comp upsamples. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"

/* the lf texel at s, invalid outside the grid */
uvec4 lf_texel(ivec2 s, uint slot) { return in_grid(s) ? imageLoad(at_lf[slot], s) : uvec4(0u); }

void main()
{
    ivec2 s = ivec2(gl_GlobalInvocationID.xy);
    if (!in_grid(s))
        return;
    uint k = pc.iteration; /* k = 0, the downsample, is dn_lf_down.comp */
    uint src = (k - 1u) & 1u, dst = k & 1u;
    uvec4 c = imageLoad(at_lf[src], s);
    vec4 c_sh = imageLoad(at_lf_sh[src], s);
    if (!lf_valid_texel(c) || (k == 1u && P.lf.x <= 0.0)) { /* sky, or deflicker off */
        imageStore(at_lf[dst], s, c);
        imageStore(at_lf_sh[dst], s, c_sh);
        return;
    }
    if (k == 1u) { /* deflicker */
        float sum = 0.0, cnt = 0.0;
        for (int y = -1; y <= 1; y++)
            for (int x = -1; x <= 1; x++) {
                ivec2 q = s + 2 * ivec2(x, y);
                if ((x == 0 && y == 0) || !lf_valid_texel(lf_texel(q, src)))
                    continue;
                sum += max(imageLoad(at_lf_sh[src], q).w, 0.0);
                cnt += 1.0;
            }
        float limit = P.lf.x * sum / max(cnt, 1.0);
        if (cnt > 0.0 && c_sh.w > limit) {
            float f = limit / c_sh.w;
            c_sh *= f;
            /* (CoCg is stored relative to L0, which the scale keeps) */
            c = uvec4(c.xyz, floatBitsToUint(lf_variance(c) * f * f));
        }
        imageStore(at_lf[dst], s, c);
        imageStore(at_lf_sh[dst], s, c_sh);
        return;
    }
    uint i = k - 2u;
    int step = 1 << int(i);
    bool last = i + 1u == P.iters.y && P.lf.y != 0.0;
    vec4 g = imageLoad(lf_geo, s);
    vec3 pos = g.xyz; /* relative to fgeo_origin() */
    float footprint = max(g.w * P.misc.x * float(DN_STRATUM * step), 1e-6);
    float inv_sigma = 1.0 / (P.weights.x * footprint);
    vec3 n = lf_normal(c);
    float lp = max(c_sh.w, 1e-6);
    /* the luminance weight: the L0 difference against P.lf.z standard deviations of the noise
     * left in the two anchors (SVGF's variance guide, on the temporal lf histories: it narrows
     * as they converge, so that a still image ends at its accumulated mean, not at a blur of
     * it; both anchors' variances, as for the difference of two estimates: an anchor whose
     * samples were all 0 so far has none of its own, and would refuse every neighbour) */
    float c_var = lf_variance(c);
    vec4 s_sh = vec4(0.0);
    vec2 s_cocg = vec2(0.0);
    float wsum = 0.0, var_acc = 0.0;
    const float kw[3] = float[3](0.25, 0.5, 1.0);
    for (int y = -1; y <= 1; y++)
        for (int x = -1; x <= 1; x++) {
            ivec2 q = s + ivec2(x, y) * step;
            /* (symmetric at the grid's border, as the full-res a-trous) */
            uvec4 t = in_grid(s - ivec2(x, y) * step) ? lf_texel(q, src) : uvec4(0u);
            if (!lf_valid_texel(t))
                continue;
            float h = kw[abs(x) + abs(y) == 0 ? 2 : (abs(x) + abs(y) == 1 ? 1 : 0)];
            vec4 q_sh = imageLoad(at_lf_sh[src], q);
            /* the distance of this anchor to the tap's tangent plane */
            float sigma_l = P.lf.z * sqrt(max(c_var + lf_variance(t), 0.0)) + 1e-6 * lp;
            float w = h * exp(-lf_plane_distance(t, pos) * inv_sigma -
                              abs(q_sh.w - c_sh.w) / sigma_l) *
                      pow(max(dot(n, lf_normal(t)), 0.0), P.weights.w);
            if (last)
                w *= clamp(1.5 - 0.25 * max(q_sh.w, 0.0) / lp, 0.0, 1.0);
            s_sh += w * q_sh;
            s_cocg += w * lf_cocg(t, q_sh.w);
            var_acc += w * w * lf_variance(t);
            wsum += w;
        }
    bool ok = wsum > 1e-8;
    vec4 o_sh = ok ? s_sh / wsum : c_sh;
    imageStore(at_lf[dst], s,
               ok ? lf_with(c, s_cocg / wsum, o_sh.w, var_acc / (wsum * wsum)) : c);
    imageStore(at_lf_sh[dst], s, o_sh);
}
