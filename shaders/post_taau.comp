/* post_taau.comp: temporal upscaling (`--render-scale S < 1`; docs/upscaling.md), in the spirit of
 * TAAU and FSR 2 as their public descriptions give them (../shared/docs/upscaling.md): the
 * front-end traces and the back-end denoises at the input size; this pass writes the output size.
 * Per output pixel p (centre u in input pixels: (p + 0.5) x input / output):
 * - the current frame reconstructed at u from the 3x3 input pixels around it, each sample at its
 *   jittered position (pixel j's at j + 0.5 + jitter), weighted by a Gaussian of its distance in
 *   output pixels (sigma 0.42; 0.35 to 0.6 within 5% on test_taau_converges_at_edges); the largest weight is the frame's confidence at p: a sample that
 *   lands on p counts fully, one between pixels little;
 * - the history (output size) found through the longest motion vector of the 3x3 input pixels
 *   (scaled to output pixels), sampled with a 4x4 Catmull-Rom kernel, clipped towards the 3x3
 *   input neighbourhood's mean onto the box mean +- k sigma in YCoCg (k: TAA's clip, P.taa.y,
 *   times the output's pixels per input pixel: the input's coarser neighbourhood mixes that many
 *   more edges; at 2x, k 1 held the edges' error at 0.65x bilinear's, k 2 at 0.54x), so a
 *   disocclusion or a change cannot leave a ghost;
 * - blended with the new frame's weight P.taa.x x confidence / its mean over the jitter
 *   sequence (2 pi sigma^2 x (input / output)^2 for a Gaussian of sigma output pixels), so that
 *   over the frames a pixel takes new samples at TAA's rate; no history (first frame, off
 *   screen, non-finite): the reconstruction alone.
 * With CP_F_SPATIAL it is the spatial baseline instead: the input resampled at u - jitter
 * (bilinear, or Catmull-Rom bicubic: P.taa.w), no history.
 * Not yet: a sharpening pass, lock and reactivity masks for thin and emissive pixels. */
#version 460
#extension GL_GOOGLE_include_directive : require
#define CP_NEEDS_CONTRACT
#include "post_common.glsl"

vec3 rgb_to_ycocg(vec3 c)
{
    return vec3(0.25 * c.r + 0.5 * c.g + 0.25 * c.b, 0.5 * c.r - 0.5 * c.b,
                -0.25 * c.r + 0.5 * c.g - 0.25 * c.b);
}
vec3 ycocg_to_rgb(vec3 y)
{
    return vec3(y.x + y.y - y.z, y.x + y.z, y.x - y.y - y.z);
}

ivec2 in_size() { return ivec2(P.up.xy); }

vec3 fetch_in(ivec2 q)
{
    return max(finite_or_zero(imageLoad(in_hdr, clamp(q, ivec2(0), in_size() - 1)).rgb), vec3(0.0));
}

vec4 catmull_rom(float t)
{
    float t2 = t * t, t3 = t2 * t;
    return vec4(-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t,
                0.5 * t3 - 0.5 * t2);
}

/* the history (output size) at continuous output position x */
vec3 sample_history(vec2 x, out bool ok)
{
    uint prev = 1u - pc.slot;
    vec2 c = x - 0.5;
    ivec2 b = ivec2(floor(c));
    vec2 f = c - vec2(b);
    vec4 wx = catmull_rom(f.x), wy = catmull_rom(f.y);
    vec3 sum = vec3(0.0);
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            ivec2 q = clamp(b + ivec2(i - 1, j - 1), ivec2(0), img_size() - 1);
            sum += wx[i] * wy[j] * imageLoad(taa[prev], q).rgb;
        }
    ok = !(tnd_nonfinite(sum.x) || tnd_nonfinite(sum.y) || tnd_nonfinite(sum.z));
    return max(sum, vec3(0.0));
}

/* the input at continuous input position x (pixel centres at + 0.5): bilinear or Catmull-Rom */
vec3 resample_in(vec2 x, bool cubic)
{
    vec2 c = x - 0.5;
    ivec2 b = ivec2(floor(c));
    vec2 f = c - vec2(b);
    if (!cubic)
        return mix(mix(fetch_in(b), fetch_in(b + ivec2(1, 0)), f.x),
                   mix(fetch_in(b + ivec2(0, 1)), fetch_in(b + ivec2(1, 1)), f.x), f.y);
    vec4 wx = catmull_rom(f.x), wy = catmull_rom(f.y);
    vec3 sum = vec3(0.0);
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++)
            sum += wx[i] * wy[j] * fetch_in(b + ivec2(i - 1, j - 1));
    return max(sum, vec3(0.0));
}

vec3 clip_box(vec3 h, vec3 m, vec3 e)
{
    vec3 d = h - m;
    vec3 r = abs(d) / max(e, vec3(1e-7));
    float k = max(r.x, max(r.y, r.z));
    return k > 1.0 ? m + d / k : h;
}

const float SIGMA = 0.42; /* the reconstruction's Gaussian, output pixels */

/* The reconstruction, the box and the blend work on c / (1 + luma c) (Karis's reversible tone
 * map): an emitter 100x brighter than its surround would otherwise spread over it through the
 * Gaussian, the history's cubic and the blend (cornell at 0.67: relMSE 2.2 in linear, where the
 * panel's edge bled into the ceiling). */
vec3 tm(vec3 c) { return c / (1.0 + luma(c)); }
vec3 tm_inv(vec3 c) { return c / max(1.0 - luma(c), 1e-4); }

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    vec2 scale = P.up.xy / vec2(img_size()); /* input pixels per output pixel */
    vec2 u = (vec2(p) + 0.5) * scale;
    vec2 jit = P.up.zw;
    if ((P.size.w & CP_F_SPATIAL) != 0u) {
        vec3 c = resample_in(u - jit, P.taa.w != 0.0);
        imageStore(taa[pc.slot], p, vec4(max(finite_or_zero(c), vec3(0.0)), 1.0));
        return;
    }
    /* the 3x3 input pixels around the one whose sample is nearest u */
    ivec2 c0 = ivec2(floor(u - jit));
    vec3 m1 = vec3(0.0), m2 = vec3(0.0), sum = vec3(0.0);
    float wsum = 0.0, conf = 0.0, longest = -1.0;
    vec2 motion = vec2(0.0);
    ivec2 last = in_size() - 1;
    for (int j = -1; j <= 1; j++)
        for (int i = -1; i <= 1; i++) {
            ivec2 q = clamp(c0 + ivec2(i, j), ivec2(0), last);
            vec3 c = tm(fetch_in(q));
            vec3 y = rgb_to_ycocg(c);
            m1 += y, m2 += y * y;
            vec2 d = (vec2(q) + 0.5 + jit - u) / scale; /* output pixels */
            float w = exp(-0.5 * dot(d, d) / (SIGMA * SIGMA));
            sum += w * c, wsum += w, conf = max(conf, w);
            vec2 mv = imageLoad(img_motion, q).xy;
            if (!(tnd_nonfinite(mv.x) || tnd_nonfinite(mv.y)) && dot(mv, mv) > longest) {
                longest = dot(mv, mv);
                motion = mv;
            }
        }
    m1 /= 9.0;
    vec3 sigma = sqrt(max(m2 / 9.0 - m1 * m1, vec3(0.0)));
    /* the reconstruction; far from every sample (wsum tiny) the nearest's neighbourhood mean */
    vec3 current = wsum > 1e-6 ? sum / wsum : ycocg_to_rgb(m1);
    vec3 result = current;
    if ((P.size.w & CP_F_HISTORY) != 0u) {
        vec2 x = vec2(p) + 0.5 + motion / scale;
        bool ok = all(greaterThanEqual(x, vec2(0.0))) && all(lessThan(x, vec2(img_size())));
        vec3 h = ok ? tm(sample_history(x, ok)) : vec3(0.0);
        if (ok) {
            /* (the box from input pixels: wider by the output's pixels per input pixel, as
             * each holds that many more of the edges an output pixel resolves) */
            vec3 hy = clip_box(rgb_to_ycocg(h), m1, P.taa.y / min(scale.x, scale.y) * sigma);
            float mean_conf = min(1.0, 2.0 * 3.14159265 * SIGMA * SIGMA * scale.x * scale.y);
            float a = clamp(P.taa.x * conf / mean_conf, 0.0, 1.0);
            result = mix(max(ycocg_to_rgb(hy), vec3(0.0)), current, a);
        }
    }
    imageStore(taa[pc.slot], p, vec4(max(finite_or_zero(tm_inv(result)), vec3(0.0)), 1.0));
}
