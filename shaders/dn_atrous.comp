/* dn_atrous.comp: one edge-avoiding a-trous iteration (Dammertz et al. 2010, as SVGF uses it),
 * step 2^i, 3x3 taps with weights 1 / 0.5 / 0.25 (Q2RTX's kernel). Edge stopping:
 * - geometry: distance of the centre to the neighbour's tangent plane, relative to the pixel
 *   footprint (depth sigma), and normals (exponent);
 * - hf: luminance against the centre's standard deviation (variance-guided; the variance is
 *   that of the history's mean, so the filter narrows as the history grows, and it is filtered
 *   with squared weights for the next iteration);
 * - spec: normals with a roughness-derived exponent, and similar roughness; none below roughness
 *   0.05 (mirror-like surfaces stay sharp).
 * lf is filtered at 1/3 resolution (dn_lf.comp).
 * Nothing is fed back into the histories (SVGF fed iteration 0's hf output back: a blur that
 * compounded every frame, docs/denoise.md). Reads ping-pong slot i & 1, writes the other. Each
 * tap is two loads: the ping-pong texel (DN_B_AT: hf, spec and the variance as 16-bit
 * wide-range floats) and the filter geometry (DN_B_FGEO: tangent-plane offset, packed normal,
 * roughness and field); they are issued before the tap's tests. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    uint i = pc.iteration, src = i & 1u, dst = 1u - src;
    int step = 1 << int(i);
    /* a channel whose iterations are done is carried through unchanged */
    bool do_hf = i < P.iters.x, do_spec = i < P.iters.z;
    uvec4 c = imageLoad(at[src], p);
    uvec2 g = imageLoad(fgeo, p).xy;
    if (g.x == DN_FGEO_NONE) { /* no surface: carried through (for dumps) */
        imageStore(at[dst], p, c);
        return;
    }
    vec3 c_hf = at_hf(c), c_spec = at_spec(c);
    float c_var = at_variance(c);
    vec4 ce = imageLoad(centre, p); /* position relative to fgeo_origin(), depth */
    vec3 n = fgeo_normal(g.y), pos = ce.xyz;
    /* the two checkerboard fields of a split surface are filtered apart */
    uint field = fgeo_field(g.y);
    float rough = fgeo_roughness(g.y);
    float footprint = max(ce.w * P.misc.x * float(step), 1e-6);
    const float LOG2E = 1.4426950408889634;
    /* the taps' colours and variance stay scaled by 2^-95 (UF16_SCALE) as they decode
     * (at_decode2_scaled: a multiplication fewer per value; tnd_uf16's smallest value scales to
     * FLT_MIN, a normal float); the luminance scale and the sums follow, and the results are
     * encoded from them (at_pack_scaled). The edge-stopping terms are in units of log2 (one
     * exp2 per weight). */
    float inv_sigma_z = LOG2E / (P.weights.x * footprint);
    float l = luma(c_hf) * UF16_SCALE;
    float inv_sigma_l = LOG2E / UF16_SCALE / (P.weights.z * sqrt(max(c_var, 1e-8)) + 1e-6);
    float a2 = max(rough * rough, 1e-3);
    a2 *= a2;
    float spec_exp = clamp(2.0 / a2 - 2.0, 8.0, P.misc.z);
    bool filter_spec = do_spec && rough >= 0.05; /* mirror-like surfaces stay sharp */
    /* the centre tap: every weight is h = 1 */
    vec3 s_hf = c_hf * UF16_SCALE, s_spec = c_spec * UF16_SCALE;
    float w_hf = 1.0, w_spec = 1.0, var_acc = c_var * UF16_SCALE;
    const float log2_k[2] = float[2](1.0, 2.0); /* -log2 h: edge 0.5, corner 0.25 */
    ivec2 last = ivec2(P.size.xy) - 1;
    for (int y = -1; y <= 1; y++)
        for (int x = -1; x <= 1; x++) {
            if (x == 0 && y == 0)
                continue;
            ivec2 q = p + ivec2(x, y) * step;
            /* a tap counts only if its mirror image about the centre lies in the image too:
             * the kernel stays symmetric at the image's border (a one-sided kernel there
             * averages a gradient's pixels with brighter or darker ones on one side only: the
             * closed box's top row came out 5-16% too bright) */
            ivec2 qm = p - ivec2(x, y) * step;
            bool in_image = q == clamp(q, ivec2(0), last) && qm == clamp(qm, ivec2(0), last);
            q = clamp(q, ivec2(0), last); /* the loads are issued before the tests */
            uvec4 t = imageLoad(at[src], q);
            uvec2 gq = imageLoad(fgeo, q).xy;
            if (!in_image || gq.x == DN_FGEO_NONE || fgeo_field(gq.y) != field)
                continue;
            /* the distance of this pixel to the neighbour's tangent plane, and all factors of
             * a weight in one exp2: h x exp(-a) x nn^e x exp(-b) = exp2(e log2(nn) - (a + b)
             * log2(e) + log2(h)), one log2 shared by hf and spec */
            vec3 nq = fgeo_normal(gq.y);
            float plane = abs(uintBitsToFloat(gq.x) - dot(nq, pos)) * inv_sigma_z +
                          log2_k[abs(x) + abs(y) - 1];
            float log_nn = log2(max(dot(n, nq), 1e-30));
            if (do_hf) {
                vec3 q_hf = at_hf_scaled(t);
                float w = exp2(P.weights.y * log_nn - (plane + abs(luma(q_hf) - l) * inv_sigma_l));
                s_hf += w * q_hf;
                var_acc += w * w * at_variance_scaled(t);
                w_hf += w;
            }
            if (filter_spec) {
                float w = exp2(spec_exp * log_nn - plane) *
                          max(0.0, 1.0 - 10.0 * abs(rough - fgeo_roughness(gq.y)));
                s_spec += w * at_spec_scaled(t);
                w_spec += w;
            }
        }
    /* encoded from the scaled values (a channel carried through re-encodes to its own code) */
    vec3 o_hf = s_hf / w_hf;
    imageStore(at[dst], p, at_pack_scaled(do_hf ? o_hf : at_hf_scaled(c),
                                          filter_spec ? s_spec / w_spec : at_spec_scaled(c),
                                          do_hf ? var_acc / (w_hf * w_hf) : at_variance_scaled(c),
                                          uvec3(0x1000u)));
}
