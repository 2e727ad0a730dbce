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
 * writes the other. The last iteration runs in dn_composite.comp (both use dn_atrous.glsl).
 * Each tap is two loads: the ping-pong texel (DN_B_AT: hf, spec and the variance as 16-bit
 * wide-range floats) and the filter geometry (DN_B_FGEO: tangent-plane offset, packed normal,
 * roughness and field); they are issued before the tap's tests. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"
#include "dn_atrous.glsl"

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    uint i = pc.iteration;
    dn_atrous_out r = atrous_at(p, i);
    imageStore(at[1u - (i & 1u)], p, r.surface ? at_pack(r.hf, r.spec, r.variance) : r.texel);
    atrous_feedback(p, i, r);
}
