/* post_exposure.comp: auto exposure from the histogram (one invocation). The pixels between the
 * low and high percentiles of luminance (the extremes dropped: sky, lamps, deep shadow) give
 * the mean log2 luminance; bins cut by a percentile count in part. The adapted value follows
 * it exponentially, log L = target + (old - target) exp(-dt speed), faster when the image gets
 * brighter (speed up) than darker. Exposure = 1 / (9.6 L_avg) x 2^bias: the physically based
 * camera's EV100 = log2(L_avg 100 / 12.5), exposure = 1 / (1.2 x 2^EV100). With auto exposure
 * off, EV100 is the fixed value. Clears the histogram for the next frame. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "post_common.glsl"

void main()
{
    if (gl_LocalInvocationIndex != 0u) /* one group; the loop over 128 bins is cheap */
        return;
    float total = 0.0;
    for (int b = 0; b < CP_BINS; b++)
        total += float(H.count[b]);
    float bin_w = (CP_LOG_MAX - CP_LOG_MIN) / float(CP_BINS);
    float lo = P.tm.z * total, hi = P.tm.w * total;
    float acc = 0.0, wsum = 0.0, lsum = 0.0;
    for (int b = 0; b < CP_BINS; b++) {
        float n = float(H.count[b]);
        if (n > 0.0) {
            float mean = CP_LOG_MIN + (float(b) + float(H.frac[b]) / (CP_FRAC_SCALE * n)) * bin_w;
            float w = max(0.0, min(acc + n, hi) - max(acc, lo)); /* the part inside the window */
            lsum += w * mean;
            wsum += w;
        }
        acc += n;
        H.count[b] = 0u;
        H.frac[b] = 0u;
    }
    bool auto_exp = (P.size.w & CP_F_AUTO) != 0u;
    float ev100;
    if (auto_exp) {
        float target = wsum > 0.0 ? lsum / wsum : (H.valid != 0u ? H.adapted_log_lum : -3.0);
        H.target_log_lum = target;
        if (H.valid == 0u || (P.size.w & CP_F_HISTORY) == 0u) {
            H.adapted_log_lum = target;
        } else {
            float speed = target > H.adapted_log_lum ? P.adapt.y : P.adapt.z;
            H.adapted_log_lum = target + (H.adapted_log_lum - target) * exp(-P.adapt.x * speed);
        }
        H.valid = 1u;
        ev100 = H.adapted_log_lum + log2(100.0 / 12.5);
    } else {
        ev100 = P.tm.y;
    }
    H.exposure = exp2(P.adapt.w) / (1.2 * exp2(ev100));
}
