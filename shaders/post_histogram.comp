/* post_histogram.comp: the luminance histogram for auto exposure: CP_BINS bins over log2
 * luminance [CP_LOG_MIN, CP_LOG_MAX) (0.25 stop each); per bin the pixel count and the sum of
 * the pixels' positions inside the bin (fixed point), so that the exposure pass averages exact
 * log luminances, not bin centres (a 0.25-stop bin would otherwise move the exposure by up to
 * 9%). Black and non-finite pixels are left out. A group takes a tile of CP_HIST_TILE^2 pixels
 * (each invocation one pixel in every 8x8 block of it, so that neighbours load together) and
 * accumulates in shared memory first: one flush to the global bins per tile, not per 64 pixels
 * (at 3840x2160 the flushes' atomics on the few bins an image fills held the pass at 0.17 ms on
 * the H200). The sums are integers: the histogram is the same whatever the tile. */
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
    ivec2 origin = ivec2(gl_WorkGroupID.xy) * CP_HIST_TILE + ivec2(gl_LocalInvocationID.xy);
    for (int j = 0; j < CP_HIST_TILE; j += 8)
        for (int i = 0; i < CP_HIST_TILE; i += 8) {
            ivec2 p = origin + ivec2(i, j);
            if (!inside(p))
                continue;
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
