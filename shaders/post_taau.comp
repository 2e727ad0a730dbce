/* post_taau.comp: temporal upscaling (`--render-scale S < 1`; docs/upscaling.md), in the spirit of
 * TAAU and FSR 2 as their public descriptions give them (../shared/docs/upscaling.md): the
 * front-end traces and the back-end denoises at the input size; this pass writes the output size.
 * Per output pixel p (centre u in input pixels: (p + 0.5) x input / output):
 * - the current frame reconstructed at u from the 3x3 input pixels around it, each sample at its
 *   jittered position (pixel j's at j + 0.5 + jitter), weighted by a Gaussian of its distance in
 *   output pixels (sigma 0.42; 0.35 to 0.6 within 5% on test_taau_converges_at_edges), and
 *   the samples that fell inside p;
 * - the history (output size) found through the longest motion vector of the 3x3 input pixels
 *   (scaled to output pixels), sampled with a 4x4 Catmull-Rom kernel, clipped towards the 3x3
 *   input neighbourhood's mean onto the box mean +- k sigma in YCoCg (k: TAA's clip, P.taa.y,
 *   times the output's pixels per input pixel: the input's coarser neighbourhood mixes that many
 *   more edges; at 2x, k 1 held the edges' error at 0.65x bilinear's, k 2 at 0.54x), as far
 *   as this frame has a sample in the pixel, so a disocclusion or a change cannot leave a ghost;
 * - blended by the sample weight the pixel holds (kept in the history's alpha): where the image
 *   is still, the samples inside the output pixel, weight 1 each, up to 1 / TAA's weight
 *   (P.taa.x) samples; where it moves, the reconstruction with its weights' sum, up to
 *   HELD_MOVING; no history (first frame, off screen, non-finite): the reconstruction alone.
 * - reset on disocclusion: where the input pixel nearest u and three of its four cross
 *   neighbours saw a surface that no input pixel within one of its previous position saw in the
 *   last frame (the depth the motion's z gives, within 10%: the back-end's tap test, on the
 *   input's depths kept from the last frame), the history is dropped, as where there is none
 *   (FSR 2's depth test; the clip alone keeps a ghost whose colour lies inside the new
 *   neighbourhood's box); a thin part newly visible at one pixel keeps its history;
 * With CP_F_SPATIAL it is the spatial baseline instead: the input resampled at u - jitter
 * (bilinear, Catmull-Rom bicubic or the edge-adaptive Lanczos: P.taa.w 0, 1, 2), no history.
 * Not yet: a sharpening pass (measured worse: docs/upscaling.md), lock and reactivity masks
 * for thin and emissive pixels. */
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

layout(set = 0, binding = CP_B_DEPTH, r32f) uniform image2D in_depth[2]; /* this frame's slot */

ivec2 in_size() { return ivec2(P.up.xy); }

/* Whether the input pixel q's surface is newly visible: no input pixel within one of its previous
 * position (through its motion) held, in the last frame, the depth its motion says it had there
 * (within 10%, the back-end's tap test). Off screen there is no history to drop anyway. */
bool disoccluded(ivec2 q)
{
    float d = imageLoad(img_depth, q).x;
    vec3 mv = imageLoad(img_motion, q).xyz;
    if (!(d < 0.5 * TND_DEPTH_MISS) || tnd_nonfinite(mv.x) || tnd_nonfinite(mv.y) ||
        tnd_nonfinite(mv.z))
        return false; /* (a miss: the sky is never newly visible) */
    vec2 was = vec2(q) + 0.5 + mv.xy;
    if (any(lessThan(was, vec2(0.0))) || any(greaterThanEqual(was, vec2(in_size()))))
        return false;
    float want = d + mv.z;
    ivec2 b = ivec2(floor(was));
    uint prev = 1u - pc.slot;
    for (int j = -1; j <= 1; j++)
        for (int i = -1; i <= 1; i++) {
            float pd = imageLoad(in_depth[prev], clamp(b + ivec2(i, j), ivec2(0), in_size() - 1)).x;
            if (abs(pd - want) <= 0.1 * want)
                return false;
        }
    return true;
}

/* The reconstruction, the box and the blend work on c / (1 + luma c) (Karis's reversible tone
 * map): an emitter 100x brighter than its surround would otherwise spread over it through the
 * Gaussian, the history's cubic and the blend (cornell at 0.67: relMSE 2.2 in linear, where the
 * panel's edge bled into the ceiling). */
vec3 tm(vec3 c) { return c / (1.0 + luma(c)); }
vec3 tm_inv(vec3 c) { return c / max(1.0 - luma(c), 1e-4); }

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

/* the history (output size) at continuous output position x: colour, and in w the sample weight
 * it holds */
vec4 sample_history(vec2 x, out bool ok)
{
    uint prev = 1u - pc.slot;
    vec2 c = x - 0.5;
    ivec2 b = ivec2(floor(c));
    vec2 f = c - vec2(b);
    vec4 wx = catmull_rom(f.x), wy = catmull_rom(f.y);
    vec4 sum = vec4(0.0);
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            ivec2 q = clamp(b + ivec2(i - 1, j - 1), ivec2(0), img_size() - 1);
            sum += wx[i] * wy[j] * imageLoad(taa[prev], q);
        }
    ok = !(tnd_nonfinite(sum.x) || tnd_nonfinite(sum.y) || tnd_nonfinite(sum.z) || tnd_nonfinite(sum.w));
    return max(sum, vec4(0.0));
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

/* Lanczos-2 of a distance in input pixels (0 from 2 on) */
float lanczos2(float r)
{
    if (r < 1e-4)
        return 1.0;
    if (r >= 2.0)
        return 0.0;
    float a = 3.14159265 * r;
    return 2.0 * sin(a) * sin(0.5 * a) / (a * a);
}

/* The edge-adaptive Lanczos baseline (`--upscaler lanczos`), in the spirit of FSR 1's EASU as
 * its public description gives it: the input's 4x4 pixels around x (continuous input position)
 * weighted by a radial Lanczos-2 whose footprint is stretched along the local edge, so that an
 * edge is interpolated along itself and kept sharp across; then clamped to the nearest 2x2
 * pixels' range (no ringing). The edge: the luma gradients of the 2x2 nearest pixels (central
 * differences over the 12 pixels of the 4x4 without its corners), weighted bilinearly by x's
 * position among them; its strength is the gradient's length over the 2x2's local contrast
 * (1 for a clean step), and the footprint along it is (1 + strength) pixels wide per pixel.
 * Works on c / (1 + luma c), as the temporal upscaler does, so that an emitter's edge does not
 * spread its light. */
vec3 lanczos_in(vec2 x)
{
    vec2 c = x - 0.5;
    ivec2 b = ivec2(floor(c));
    vec2 f = c - vec2(b);
    vec3 t[16];
    float l[16];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            t[j * 4 + i] = tm(fetch_in(b + ivec2(i - 1, j - 1)));
            l[j * 4 + i] = luma(t[j * 4 + i]);
        }
    /* the gradients of the inner 2x2 (indices 5, 6, 9, 10), bilinearly weighted */
    vec2 g = vec2(0.0);
    float lo = 1e30, hi = -1e30;
    for (int j = 1; j <= 2; j++)
        for (int i = 1; i <= 2; i++) {
            int k = j * 4 + i;
            float w = (i == 1 ? 1.0 - f.x : f.x) * (j == 1 ? 1.0 - f.y : f.y);
            g += w * vec2(l[k + 1] - l[k - 1], l[k + 4] - l[k - 4]);
            lo = min(lo, min(min(l[k - 1], l[k + 1]), min(l[k - 4], l[k + 4])));
            hi = max(hi, max(max(l[k - 1], l[k + 1]), max(l[k - 4], l[k + 4])));
        }
    float glen = length(g);
    float strength = hi - lo > 1e-6 ? clamp(glen / (hi - lo), 0.0, 1.0) : 0.0;
    vec2 across = glen > 1e-8 ? g / glen : vec2(1.0, 0.0);
    vec2 along = vec2(-across.y, across.x);
    float stretch = 1.0 / (1.0 + strength);
    vec3 sum = vec3(0.0), mn = vec3(1e30), mx = vec3(-1e30);
    float wsum = 0.0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            vec2 d = vec2(i - 1, j - 1) - f; /* the tap from x, input pixels */
            float r = length(vec2(dot(d, across), dot(d, along) * stretch));
            float w = lanczos2(r);
            sum += w * t[j * 4 + i], wsum += w;
            if (i >= 1 && i <= 2 && j >= 1 && j <= 2)
                mn = min(mn, t[j * 4 + i]), mx = max(mx, t[j * 4 + i]);
        }
    vec3 r = wsum > 1e-6 ? sum / wsum : t[5];
    return tm_inv(clamp(r, mn, mx));
}

/* h clipped onto the box m +- e; k: how far outside it was (1: inside) */
vec3 clip_box(vec3 h, vec3 m, vec3 e, out float k)
{
    vec3 d = h - m;
    vec3 r = abs(d) / max(e, vec3(1e-7));
    k = max(1.0, max(r.x, max(r.y, r.z)));
    return m + d / k;
}

const float SIGMA = 0.42; /* the reconstruction's Gaussian, output pixels */
/* The sample weight a history holds at most where the image moves (where it is still: 1 / TAA's
 * new-frame weight, 5 at the upscaler's 0.2), and what a frame's reconstruction counts for where
 * there is no history. Where the image moves, the history is resampled every frame and lags:
 * on the standard suite's moving sequences at half size (docs/upscaling.md) 1.5 held FLIP at
 * 1.33x bilinear's on materials-orbit, 0.6 at 1.21x (0.25: 1.03x, with temporal error 1.25x
 * bilinear's; cut-outs, the engine and the walk lose 5-12% at 0.25). HELD_FIRST: cornell's still
 * camera's frame 47 and dolly at half size, FLIP 0.0663 / 0.1183 against 0.0689 / 0.1187 (1.0). */
const float HELD_MOVING = 0.6;
const float HELD_FIRST = 0.5;

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    vec2 scale = P.up.xy / vec2(img_size()); /* input pixels per output pixel */
    vec2 u = (vec2(p) + 0.5) * scale;
    vec2 jit = P.up.zw;
    if ((P.size.w & CP_F_SPATIAL) != 0u) {
        vec3 c = P.taa.w == 2.0 ? lanczos_in(u - jit) : resample_in(u - jit, P.taa.w != 0.0);
        imageStore(taa[pc.slot], p, vec4(max(finite_or_zero(c), vec3(0.0)), 1.0));
        return;
    }
    /* the 3x3 input pixels around the one whose sample is nearest u */
    ivec2 c0 = ivec2(floor(u - jit));
    /* the input's depth kept for the next frame's test (every input pixel is some output
     * pixel's c0, as the output is at least the input's size; the writers of one agree) */
    ivec2 cq = clamp(c0, ivec2(0), in_size() - 1);
    imageStore(in_depth[pc.slot], cq, vec4(imageLoad(img_depth, cq).x));
    vec3 m1 = vec3(0.0), m2 = vec3(0.0), sum = vec3(0.0), own = vec3(0.0);
    float wsum = 0.0, n_own = 0.0, longest = -1.0;
    vec2 motion = vec2(0.0);
    ivec2 last = in_size() - 1;
    for (int j = -1; j <= 1; j++)
        for (int i = -1; i <= 1; i++) {
            ivec2 q0 = c0 + ivec2(i, j), q = clamp(q0, ivec2(0), last);
            vec3 c = tm(fetch_in(q));
            vec3 y = rgb_to_ycocg(c);
            m1 += y, m2 += y * y;
            vec2 mv = imageLoad(img_motion, q).xy;
            if (!(tnd_nonfinite(mv.x) || tnd_nonfinite(mv.y)) && dot(mv, mv) > longest) {
                longest = dot(mv, mv);
                motion = mv;
            }
            if (q != q0) /* (a pixel beyond the border: its sample is not there) */
                continue;
            vec2 d = (vec2(q) + 0.5 + jit - u) / scale; /* output pixels */
            float w = exp(-0.5 * dot(d, d) / (SIGMA * SIGMA));
            sum += w * c, wsum += w;
            if (all(lessThan(abs(d), vec2(0.5))))
                own += c, n_own += 1.0;
        }
    m1 /= 9.0;
    vec3 sigma = sqrt(max(m2 / 9.0 - m1 * m1, vec3(0.0)));
    /* the frame's own estimate: the reconstruction; far from every sample (wsum tiny) the
     * neighbourhood's mean */
    vec3 current = wsum > 1e-6 ? sum / wsum : ycocg_to_rgb(m1);
    /* What this frame adds to the pixel's history, and with what weight. Where the image is
     * still (no motion over a thousandth of an output pixel), the samples inside the output
     * pixel, each with weight 1: over the jitter sequence they cover the pixel evenly, so the
     * history converges to the pixel's mean, the full size's and its matched reference's (a
     * Gaussian's wider footprint converges to a blur of it: cornell's still camera at half
     * size, frame 47, FLIP 0.0753 with sigma 0.3, 0.0617 inside the pixel). Where it moves, the
     * history is resampled every frame anyway: the reconstruction, with the sum of its weights. */
    bool moving = length(motion / scale) >= 1e-3;
    vec3 mine = moving || n_own == 0.0 ? current : own / n_own;
    float w_new = moving ? wsum : n_own;
    vec3 result = current;
    float held = max(w_new, HELD_FIRST); /* the sample weight the pixel holds after this frame */
    /* A disocclusion is a region: the centre newly visible and at least three of its four
     * cross neighbours too. A thin part (a railing, a leaf card) whose samples come and go with
     * the jitter is newly visible at one pixel and not beside it: it keeps its history (on the
     * standard suite's walk through the planetarium's railings and trees, a test of the centre
     * alone cost 1.5% of FLIP and temporal error, docs/upscaling.md). */
    bool fresh = false;
    if ((P.size.w & CP_F_HISTORY) != 0u && disoccluded(cq)) {
        int n = 0;
        for (int k = 0; k < 4; k++) {
            ivec2 o = k == 0 ? ivec2(1, 0) : k == 1 ? ivec2(-1, 0) : k == 2 ? ivec2(0, 1) : ivec2(0, -1);
            n += disoccluded(clamp(cq + o, ivec2(0), in_size() - 1)) ? 1 : 0;
        }
        fresh = n >= 3;
    }
    if ((P.size.w & CP_F_HISTORY) != 0u && !fresh) {
        vec2 x = vec2(p) + 0.5 + motion / scale;
        bool ok = all(greaterThanEqual(x, vec2(0.0))) && all(lessThan(x, vec2(img_size())));
        vec4 hw = ok ? sample_history(x, ok) : vec4(0.0);
        if (ok) {
            /* The history clipped towards the 3x3 input neighbourhood's mean, onto mean +- k
             * sigma in YCoCg (the box from input pixels: wider by the output's pixels per input
             * pixel, as each holds that many more of the edges an output pixel resolves), as
             * far as this frame has a sample in the pixel where the image is still (fully where
             * it moves): a still pixel whose samples all fell elsewhere this frame (a thin part,
             * the image's border row) is not in that neighbourhood, and clipping it there would
             * pull it to its neighbours (the still camera's frame 47: FLIP 0.091 clipped every
             * frame, 0.0617 so); where the image moves, the full clip (the standard suite's
             * dynamic: 0.0777 against 0.0899 gated). A clipped history holds less: its weight
             * is divided by how far it was outside the box. */
            float k;
            vec3 h0 = rgb_to_ycocg(tm(hw.rgb));
            vec3 hy = clip_box(h0, m1, P.taa.y / min(scale.x, scale.y) * sigma, k);
            float s_clip = moving ? 1.0 : clamp(w_new, 0.0, 1.0);
            hy = mix(h0, hy, s_clip);
            k = mix(1.0, k, s_clip);
            float w_max = moving ? HELD_MOVING : 1.0 / max(P.taa.x, 1e-3);
            held = min(min(hw.w, w_max) / k + w_new, w_max);
            if (held > 1e-6)
                result = mix(max(ycocg_to_rgb(hy), vec3(0.0)), mine, clamp(w_new / held, 0.0, 1.0));
        }
    }
    /* (w: the sample weight held, for the next frame) */
    imageStore(taa[pc.slot], p, vec4(max(finite_or_zero(tm_inv(result)), vec3(0.0)), held));
}
