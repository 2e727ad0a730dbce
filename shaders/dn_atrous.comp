/* dn_atrous.comp: one edge-avoiding a-trous iteration (Dammertz et al. 2010, as SVGF uses it),
 * step 2^i, 3x3 taps with weights 1 / 0.5 / 0.25 (Q2RTX's kernel). Edge stopping:
 * - geometry: distance of the centre to the neighbour's tangent plane, relative to the pixel
 *   footprint (depth sigma), and normals (exponent);
 * - hf: luminance against the centre's standard deviation (variance-guided; the variance is
 *   filtered with squared weights for the next iteration);
 * - spec: normals with a roughness-derived exponent, and similar roughness; none below roughness
 *   0.05 (mirror-like surfaces stay sharp).
 * lf is filtered at 1/3 resolution (dn_lf.comp).
 * Iteration 0's hf output is fed back as the hf history (SVGF). Reads ping-pong slot i & 1,
 * writes the other. The geometry of the taps comes packed in one texel (DN_B_FGEO: tangent-plane
 * offset, 22-bit normal, 8-bit roughness, field), and each tap's loads are issued before its tests. */
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
    /* a channel whose iterations are done is left alone: its result stays in slot
     * iterations & 1, where the composite reads it */
    bool do_hf = i < P.iters.x, do_spec = i < P.iters.z;
    vec4 c_hf = do_hf ? imageLoad(at_hf[src], p) : vec4(0.0);
    vec4 c_spec = do_spec ? imageLoad(at_spec[src], p) : vec4(0.0);
    uvec2 g = imageLoad(fgeo, p).xy;
    if (g.x == DN_FGEO_NONE) { /* no surface: carried through (for dumps) */
        if (do_hf)
            imageStore(at_hf[dst], p, c_hf);
        if (do_spec)
            imageStore(at_spec[dst], p, c_spec);
        return;
    }
    vec3 n = fgeo_normal(g.y), pos = imageLoad(img_position, p).xyz - fgeo_origin();
    /* the two checkerboard fields of a split surface are filtered apart */
    uint field = fgeo_field(g.y);
    float rough = fgeo_roughness(g.y);
    float footprint = max(imageLoad(img_depth, p).x * P.misc.x * float(step), 1e-6);
    float inv_sigma_z = 1.0 / (P.weights.x * footprint);
    float l = luma(c_hf.rgb);
    float inv_sigma_l = 1.0 / (P.weights.z * sqrt(max(c_hf.a, 1e-8)) + 1e-6);
    const float LOG2E = 1.4426950408889634;
    float a2 = max(rough * rough, 1e-3);
    a2 *= a2;
    float spec_exp = clamp(2.0 / a2 - 2.0, 8.0, P.misc.z);
    bool spec_iter = do_spec;
    do_spec = do_spec && rough >= 0.05;
    /* the centre tap: every weight is h = 1 */
    vec4 s_hf = vec4(c_hf.rgb, 0.0), s_spec = c_spec;
    float w_hf = 1.0, w_spec = 1.0, var_acc = c_hf.a;
    const float k[3] = float[3](0.25, 0.5, 1.0);
    ivec2 last = ivec2(P.size.xy) - 1;
    for (int y = -1; y <= 1; y++)
        for (int x = -1; x <= 1; x++) {
            if (x == 0 && y == 0)
                continue;
            ivec2 q = p + ivec2(x, y) * step;
            bool in_image = q == clamp(q, ivec2(0), last);
            q = clamp(q, ivec2(0), last); /* the loads are issued before the tests */
            uvec2 gq = imageLoad(fgeo, q).xy;
            vec4 q_hf = imageLoad(at_hf[src], q);
            vec4 q_spec = do_spec ? imageLoad(at_spec[src], q) : vec4(0.0);
            if (!in_image || gq.x == DN_FGEO_NONE || fgeo_field(gq.y) != field)
                continue;
            /* all factors of a weight in one exp2: exp(-a) x nn^e x exp(-b) =
             * exp2(e log2(nn) - (a + b) log2(e)), one log2 shared by hf and spec */
            float h = k[abs(x) + abs(y) == 1 ? 1 : 0];
            /* the distance of this pixel to the neighbour's tangent plane */
            vec3 nq = fgeo_normal(gq.y);
            float plane = abs(uintBitsToFloat(gq.x) - dot(nq, pos)) * inv_sigma_z;
            float log_nn = log2(max(dot(n, nq), 1e-30));
            if (do_hf) {
                float w = h * exp2(P.weights.y * log_nn -
                                   (plane + abs(luma(q_hf.rgb) - l) * inv_sigma_l) * LOG2E);
                s_hf.rgb += w * q_hf.rgb;
                var_acc += w * w * q_hf.a;
                w_hf += w;
            }
            if (do_spec) {
                float w = h * exp2(spec_exp * log_nn - plane * LOG2E) *
                          max(0.0, 1.0 - 10.0 * abs(rough - fgeo_roughness(gq.y)));
                s_spec += w * q_spec;
                w_spec += w;
            }
        }
    vec4 o_hf = vec4(s_hf.rgb / w_hf, var_acc / (w_hf * w_hf));
    if (do_hf)
        imageStore(at_hf[dst], p, o_hf);
    if (spec_iter) /* rough < 0.05: the spec carried through unfiltered */
        imageStore(at_spec[dst], p, do_spec ? s_spec / w_spec : c_spec);
    if (i == 0u && do_hf) /* SVGF's feedback: the first iteration becomes the hf history */
        imageStore(hist_hf[pc.slot], p, vec4(o_hf.rgb, imageLoad(hist_hf[pc.slot], p).a));
}
