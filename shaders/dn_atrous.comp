/* dn_atrous.comp: one edge-avoiding a-trous iteration (Dammertz et al. 2010, as SVGF uses it),
 * step 2^i, 3x3 taps with weights 1 / 0.5 / 0.25 (Q2RTX's kernel). Edge stopping:
 * - geometry: distance of the neighbour to the centre's tangent plane, relative to the pixel
 *   footprint (depth sigma), and normals (exponent);
 * - hf: luminance against the centre's standard deviation (variance-guided; the variance is
 *   filtered with squared weights for the next iteration);
 * - spec: normals with a roughness-derived exponent, and similar roughness; none below roughness
 *   0.05 (mirror-like surfaces stay sharp).
 * lf is filtered at 1/3 resolution (dn_lf.comp).
 * Iteration 0's hf output is fed back as the hf history (SVGF). Reads ping-pong slot i & 1,
 * writes the other. */
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
    vec4 c_hf = imageLoad(at_hf[src], p), c_spec = imageLoad(at_spec[src], p);
    uint inst = imageLoad(img_vis_id, p).x;
    bool do_hf = i < P.iters.x, do_spec = i < P.iters.z;
    if (inst == TND_VIS_NONE || !(do_hf || do_spec)) {
        imageStore(at_hf[dst], p, c_hf);
        imageStore(at_spec[dst], p, c_spec);
        return;
    }
    vec3 n = imageLoad(img_normal, p).xyz, pos = imageLoad(img_position, p).xyz;
    /* the two checkerboard fields of a split surface are filtered apart */
    uint field = imageLoad(img_path, p).x & (TND_PATH_SPLIT | TND_PATH_REFRACT);
    float depth = imageLoad(img_depth, p).x, rough = imageLoad(img_roughness, p).x;
    float footprint = max(depth * P.misc.x * float(step), 1e-6);
    float l = luma(c_hf.rgb);
    float sigma_l = P.weights.z * sqrt(max(c_hf.a, 1e-8)) + 1e-6;
    float a2 = max(rough * rough, 1e-3);
    a2 *= a2;
    float spec_exp = clamp(2.0 / a2 - 2.0, 8.0, P.misc.z);
    vec4 s_hf = vec4(0.0), s_spec = vec4(0.0);
    float w_hf = 0.0, w_spec = 0.0, var_acc = 0.0;
    const float k[3] = float[3](0.25, 0.5, 1.0);
    for (int y = -1; y <= 1; y++)
        for (int x = -1; x <= 1; x++) {
            ivec2 q = p + ivec2(x, y) * step;
            if (!inside(q) || imageLoad(img_vis_id, q).x == TND_VIS_NONE ||
                (imageLoad(img_path, q).x & (TND_PATH_SPLIT | TND_PATH_REFRACT)) != field)
                continue;
            float h = k[abs(x) + abs(y) == 0 ? 2 : (abs(x) + abs(y) == 1 ? 1 : 0)];
            vec3 nq = imageLoad(img_normal, q).xyz;
            float plane = abs(dot(n, imageLoad(img_position, q).xyz - pos));
            float wz = exp(-plane / (P.weights.x * footprint));
            float nn = max(dot(n, nq), 0.0);
            vec4 q_hf = imageLoad(at_hf[src], q);
            if (do_hf) {
                float w = h * wz * pow(nn, P.weights.y) * exp(-abs(luma(q_hf.rgb) - l) / sigma_l);
                s_hf.rgb += w * q_hf.rgb;
                var_acc += w * w * q_hf.a;
                w_hf += w;
            }
            if (do_spec && rough >= 0.05) {
                float rq = imageLoad(img_roughness, q).x;
                float w = h * wz * pow(nn, spec_exp) * max(0.0, 1.0 - 10.0 * abs(rough - rq));
                s_spec += w * imageLoad(at_spec[src], q);
                w_spec += w;
            }
        }
    vec4 o_hf = do_hf && w_hf > 1e-8 ? vec4(s_hf.rgb / w_hf, var_acc / (w_hf * w_hf)) : c_hf;
    vec4 o_spec = do_spec && w_spec > 1e-8 ? s_spec / w_spec : c_spec;
    imageStore(at_hf[dst], p, o_hf);
    imageStore(at_spec[dst], p, o_spec);
    if (i == 0u) /* SVGF's feedback: the first iteration becomes the hf history */
        imageStore(hist_hf[pc.slot], p, vec4(o_hf.rgb, imageLoad(hist_hf[pc.slot], p).a));
}
