/* post_histogram.comp: the luminance histogram for auto exposure: CP_BINS bins over log2
 * luminance [CP_LOG_MIN, CP_LOG_MAX) (0.25 stop each); per bin the pixel count and the sum of
 * the pixels' positions inside the bin (fixed point), so that the exposure pass averages exact
 * log luminances, not bin centres (a 0.25-stop bin would otherwise move the exposure by up to
 * 9%). Black and non-finite pixels are left out; the group accumulates in shared memory first. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "post_common.glsl"

shared uint s_count[CP_BINS];
shared uint s_frac[CP_BINS];

void main()
{
    uint t = gl_LocalInvocationIndex;
    for (uint b = t; b < CP_BINS; b += 64u)
        s_count[b] = 0u, s_frac[b] = 0u;
    barrier();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (inside(p)) {
        float l = luma(load_hdr(p));
        if (l > 0.0 && !tnd_nonfinite(l)) {
            float x = (clamp(log2(l), CP_LOG_MIN, CP_LOG_MAX - 1e-3) - CP_LOG_MIN) *
                      (float(CP_BINS) / (CP_LOG_MAX - CP_LOG_MIN));
            uint b = min(uint(x), uint(CP_BINS - 1));
            atomicAdd(s_count[b], 1u);
            atomicAdd(s_frac[b], uint((x - float(b)) * CP_FRAC_SCALE));
        }
    }
    barrier();
    for (uint b = t; b < CP_BINS; b += 64u)
        if (s_count[b] != 0u) {
            atomicAdd(H.count[b], s_count[b]);
            atomicAdd(H.frac[b], s_frac[b]);
        }
}
