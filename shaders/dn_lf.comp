/* dn_lf.comp: the indirect diffuse (lf) spatial filter at 1/3 resolution, in SH form (Q2RTX's
 * choice: lf is smooth and sparse, so a 3x3 stratum loses nothing a full-resolution filter would
 * keep, and every pass touches 1/9 of the pixels). One thread per stratum; push constant
 * iteration k:
 * - k = 0, the downsample onto the strata's anchors (writes slot 0 and lf_geo): a shader of its
 *   own, dn_lf_down.comp, which says how;
 * - k = 1, deflicker: where L0 exceeds 2x (P.lf.x; 0 turns it off) the mean L0 of the 8
 *   low-res pixels at distance 2 (a firefly that the temporal pass could not average away), SH
 *   and chroma are scaled down to that limit. Q2RTX compares with the 8 adjacent pixels; the
 *   jittered bilinear reprojection spreads a firefly kept in the history into adjacent strata,
 *   which then hide it (test_lf_firefly_is_deflickered: brightest pixel 6.7x -> 5.9x, energy
 *   added 3.7% -> 2.2%, against 13x and 8.5% without deflicker).
 * - k = 2 .. iters + 1: a-trous, step 2^(k-2) low-res pixels (3, 6, 12 full-res pixels), 3x3 taps
 *   1 / 0.5 / 0.25, geometry weights only (tangent plane against the footprint, normals^8); the
 *   last iteration adds the light-leak guard w *= clamp(1.5 - 0.25 l_q / l_p, 0, 1) (a neighbour
 *   more than 2x brighter than the centre is attenuated, more than 6x is dropped).
 * Pass k >= 1 reads slot (k - 1) & 1 and writes slot k & 1; the result lands in slot
 * (iters + 1) & 1, which dn_composite.comp upsamples. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"

bool in_grid(ivec2 s)
{
    ivec2 gs = grad_size();
    return s.x >= 0 && s.y >= 0 && s.x < gs.x && s.y < gs.y;
}
bool lf_valid(ivec2 s) { return in_grid(s) && imageLoad(lf_geo[0], s).w != 0.0; }

void main()
{
    ivec2 s = ivec2(gl_GlobalInvocationID.xy);
    ivec2 gs = grad_size();
    if (s.x >= gs.x || s.y >= gs.y)
        return;
    uint k = pc.iteration; /* k = 0, the downsample, is dn_lf_down.comp */
    uint src = (k - 1u) & 1u, dst = k & 1u;
    vec4 c_sh = imageLoad(at_lf_sh[src], s), c_cocg = imageLoad(at_lf_cocg[src], s);
    if (!lf_valid(s)) {
        imageStore(at_lf_sh[dst], s, c_sh);
        imageStore(at_lf_cocg[dst], s, c_cocg);
        return;
    }
    if (k == 1u && P.lf.x <= 0.0) { /* deflicker off */
        imageStore(at_lf_sh[dst], s, c_sh);
        imageStore(at_lf_cocg[dst], s, c_cocg);
        return;
    }
    if (k == 1u) { /* deflicker */
        float sum = 0.0, cnt = 0.0;
        for (int y = -1; y <= 1; y++)
            for (int x = -1; x <= 1; x++) {
                ivec2 q = s + 2 * ivec2(x, y);
                if ((x == 0 && y == 0) || !lf_valid(q))
                    continue;
                sum += max(imageLoad(at_lf_sh[src], q).w, 0.0);
                cnt += 1.0;
            }
        float limit = P.lf.x * sum / max(cnt, 1.0);
        if (cnt > 0.0 && c_sh.w > limit) {
            float f = limit / c_sh.w;
            c_sh *= f;
            c_cocg *= f;
        }
        imageStore(at_lf_sh[dst], s, c_sh);
        imageStore(at_lf_cocg[dst], s, c_cocg);
        return;
    }
    uint i = k - 2u;
    int step = 1 << int(i);
    bool last = i + 1u == P.iters.y && P.lf.y != 0.0;
    vec4 g0 = imageLoad(lf_geo[0], s), g1 = imageLoad(lf_geo[1], s);
    vec3 pos = g0.xyz, n = g1.xyz;
    float footprint = max(g1.w * P.misc.x * float(DN_STRATUM * step), 1e-6);
    float lp = max(c_sh.w, 1e-6);
    vec4 s_sh = vec4(0.0), s_cocg = vec4(0.0);
    float wsum = 0.0;
    const float kw[3] = float[3](0.25, 0.5, 1.0);
    for (int y = -1; y <= 1; y++)
        for (int x = -1; x <= 1; x++) {
            ivec2 q = s + ivec2(x, y) * step;
            if (!in_grid(q))
                continue;
            vec4 q0 = imageLoad(lf_geo[0], q);
            if (q0.w == 0.0)
                continue;
            float h = kw[abs(x) + abs(y) == 0 ? 2 : (abs(x) + abs(y) == 1 ? 1 : 0)];
            float plane = abs(dot(n, q0.xyz - pos));
            float nn = max(dot(n, imageLoad(lf_geo[1], q).xyz), 0.0);
            float w = h * exp(-plane / (P.weights.x * footprint)) * pow(nn, P.weights.w);
            vec4 q_sh = imageLoad(at_lf_sh[src], q);
            if (last)
                w *= clamp(1.5 - 0.25 * max(q_sh.w, 0.0) / lp, 0.0, 1.0);
            s_sh += w * q_sh;
            s_cocg += w * imageLoad(at_lf_cocg[src], q);
            wsum += w;
        }
    imageStore(at_lf_sh[dst], s, wsum > 1e-8 ? s_sh / wsum : c_sh);
    imageStore(at_lf_cocg[dst], s, wsum > 1e-8 ? s_cocg / wsum : c_cocg);
}
