/* post_taa.comp: temporal anti-aliasing of the back-end's linear HDR output. The front-ends
 * jitter primary rays by the Halton(2,3) sequence (tnd_jitter), so accumulating frames converges
 * to the pixel-area average, the supersampled image. Per pixel: the 3x3 neighbourhood's mean
 * and standard deviation in YCoCg (luma and chroma separate, so clipping keeps hue); the centre
 * is clamped to 1 / anti-sparkle x the neighbours' mean luma (a lone firefly cannot flash); the
 * history is found through the longest motion vector of the 3x3 neighbourhood (edges of moving
 * objects keep their history), sampled with a 4x4 Catmull-Rom kernel, NaN-checked, and clipped
 * towards the mean onto the box mean +- k sigma; out = mix(history, centre, weight).
 * Without a valid history (first frame, off screen, non-finite) the centre is taken as is.
 * The group's 10x10 neighbourhood (colour and motion) is loaded once into shared memory: each
 * pixel's 3x3 reads come from there, not 18 image loads per pixel (H200, 3840x2160: ...). */
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
vec3 fetch_in(ivec2 p)
{
    return max(finite_or_zero(imageLoad(in_hdr, clamp(p, ivec2(0), img_size() - 1)).rgb), vec3(0.0));
}

/* Catmull-Rom weights for fractional position t (taps at -1, 0, 1, 2) */
vec4 catmull_rom(float t)
{
    float t2 = t * t, t3 = t2 * t;
    return vec4(-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t,
                0.5 * t3 - 0.5 * t2);
}

/* history at continuous pixel position x (pixel centres at +0.5) */
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
    return max(sum, vec3(0.0)); /* the kernel's negative lobes can undershoot */
}

/* clip h towards the box centre m onto the box m +- e (YCoCg) */
vec3 clip_box(vec3 h, vec3 m, vec3 e)
{
    vec3 d = h - m;
    vec3 r = abs(d) / max(e, vec3(1e-7));
    float k = max(r.x, max(r.y, r.z));
    return k > 1.0 ? m + d / k : h;
}

/* the group's 8x8 pixels and a ring of one: colour as fetch_in gives it, motion (NaN outside
 * the image, where the 3x3 search skips it) */
shared vec3 s_c[10][10];
shared vec2 s_mv[10][10];

void main()
{
    ivec2 corner = ivec2(gl_WorkGroupID.xy) * 8 - 1;
    for (uint k = gl_LocalInvocationIndex; k < 100u; k += 64u) {
        ivec2 t = ivec2(k % 10u, k / 10u), q = corner + t;
        s_c[t.y][t.x] = fetch_in(q);
        s_mv[t.y][t.x] = inside(q) ? imageLoad(img_motion, q).xy : vec2(uintBitsToFloat(0x7fc00000u));
    }
    barrier();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    ivec2 l = ivec2(gl_LocalInvocationID.xy) + 1;
    vec3 m1 = vec3(0.0), m2 = vec3(0.0);
    float nb_luma = 0.0;
    vec2 motion = vec2(0.0);
    float longest = -1.0;
    vec3 centre = vec3(0.0);
    for (int j = -1; j <= 1; j++)
        for (int i = -1; i <= 1; i++) {
            vec3 c = s_c[l.y + j][l.x + i];
            vec3 y = rgb_to_ycocg(c);
            m1 += y;
            m2 += y * y;
            if (i != 0 || j != 0)
                nb_luma += y.x;
            else
                centre = c;
            vec2 mv = s_mv[l.y + j][l.x + i];
            if (!(tnd_nonfinite(mv.x) || tnd_nonfinite(mv.y)) && dot(mv, mv) > longest) {
                longest = dot(mv, mv);
                motion = mv;
            }
        }
    m1 /= 9.0;
    vec3 sigma = sqrt(max(m2 / 9.0 - m1 * m1, vec3(0.0)));
    /* anti-sparkle: the centre's luma at most ratio x the mean of its 8 neighbours */
    /* both in YCoCg's Y (0.25, 0.5, 0.25): a Rec.709 luma here would compare unlike things */
    float cap = P.taa.z * nb_luma / 8.0, lc = rgb_to_ycocg(centre).x;
    if (lc > cap && lc > 0.0)
        centre *= cap / lc;
    vec3 result = centre;
    if ((P.size.w & CP_F_HISTORY) != 0u) {
        vec2 x = vec2(p) + 0.5 + motion;
        bool ok = all(greaterThanEqual(x, vec2(0.0))) && all(lessThan(x, vec2(img_size())));
        vec3 h = ok ? sample_history(x, ok) : vec3(0.0);
        if (ok) {
            vec3 hy = clip_box(rgb_to_ycocg(h), m1, P.taa.y * sigma);
            result = mix(max(ycocg_to_rgb(hy), vec3(0.0)), centre, P.taa.x);
        }
    }
    /* whatever the inputs held, the output is finite (the history stays NaN-safe) */
    imageStore(taa[pc.slot], p, vec4(max(finite_or_zero(result), vec3(0.0)), 1.0));
}
