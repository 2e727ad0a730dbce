/* dn_history.comp: the recurrent denoiser's history pass, after the temporal one (the ideas of
 * NVIDIA's ReLAX as its public documentation describes them; docs/denoise.md):
 * - history clamping: the slow hf and spec histories (up to 1 / min alpha frames) are clamped,
 *   in YCoCg, to the fast histories' (P.rc.x frames) 5x5 mean +- P.rc.y standard deviations,
 *   the box widened to hold the pixel's own fast value. A change of the signal then reaches
 *   the slow history within the fast history's few frames, without dropping the history where
 *   nothing changed (inside the box nothing moves: a still image keeps converging to its mean).
 *   The clamped slow history is what the next frame reprojects (DN_B_HIST_RC).
 * - history fix: a history of at most P.rc.z frames (a disocclusion, a reset) is rebuilt for
 *   the a-trous from its neighbours' histories on a 5x5 grid of stride P.rc.w / (1 + N) pixels
 *   (wide for a new pixel, narrowing as the history grows), each weighted by 1 + its history
 *   length (long histories are the better estimates), plane distance and normals (spec:
 *   normals by the roughness's lobe, and similar roughness); not on a geometric edge (a 3x3
 *   neighbour on another plane or field), where the jitter, not a disocclusion, keeps the
 *   history young. Not fed back: the histories stay means of the pixel's own samples.
 * Reads this frame's histories (hist_hf, hist_spec, hist_fast: slot pc.slot), the filter
 * geometry and the temporal pass's a-trous input (its variance); writes DN_B_HIST_RC and the
 * a-trous input (DN_B_AT slot 0). A pixel writes only its own texels and reads none that this
 * pass writes. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"

vec3 to_ycocg(vec3 c)
{
    return vec3(0.25 * c.r + 0.5 * c.g + 0.25 * c.b, 0.5 * c.r - 0.5 * c.b,
                -0.25 * c.r + 0.5 * c.g - 0.25 * c.b);
}
vec3 from_ycocg(vec3 y)
{
    float t = y.x - y.z;
    return vec3(t + y.y, y.x + y.z, t - y.y);
}

/* clamp `slow` to the box m +- s sigma (YCoCg moments m1, m2 over n taps), widened to hold
 * `own` (the pixel's own fast value) */
vec3 clamp_to_box(vec3 slow, vec3 m1, vec3 m2, float n, vec3 own)
{
    vec3 mean = m1 / n, sigma = sqrt(max(m2 / n - mean * mean, vec3(0.0)));
    vec3 o = to_ycocg(own);
    vec3 lo = min(mean - P.rc.y * sigma, o), hi = max(mean + P.rc.y * sigma, o);
    return max(from_ycocg(clamp(to_ycocg(slow), lo, hi)), vec3(0.0));
}

/* The work group's fast histories with a 2-texel apron, loaded once (each 5x5 window reads 25
 * of them), two 16-byte texels per tap: s_hf hf in YCoCg and the lf L0, s_sp spec in YCoCg and
 * the texel's field (NO_SURFACE where none) as a float (a whole number: exact, and no
 * denormal bit pattern a device could flush). */
const uint NO_SURFACE = 0xffu;
shared vec4 s_hf[12][12], s_sp[12][12];

void load_tile(uint cur)
{
    ivec2 origin = ivec2(gl_WorkGroupID.xy) * 8 - 2, last = ivec2(P.size.xy) - 1;
    for (uint k = gl_LocalInvocationIndex; k < 144u; k += 64u) {
        ivec2 t = ivec2(k % 12u, k / 12u);
        ivec2 q = clamp(origin + t, ivec2(0), last); /* (the image's edge texels repeat) */
        uvec2 gq = imageLoad(fgeo, q).xy;
        uvec4 f = imageLoad(hist_fast[cur], q);
        s_hf[t.y][t.x] = vec4(to_ycocg(at_hf(f)), at_variance(f)); /* (w: the fast lf L0) */
        s_sp[t.y][t.x] = vec4(to_ycocg(at_spec(f)),
                              float(gq.x == DN_FGEO_NONE ? NO_SURFACE : fgeo_field(gq.y)));
    }
}

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    uint cur = pc.slot;
    load_tile(cur);
    barrier();
    if (!inside(p))
        return;
    uvec2 g = imageLoad(fgeo, p).xy;
    uvec4 hf_t = imageLoad(hist_hf[cur], p);
    uvec2 sp_t = imageLoad(hist_spec[cur], p).xy;
    uvec4 fast_t = imageLoad(hist_fast[cur], p);
    uint hit = imageLoad(hist_rc[cur], p).w; /* the reflection's distance (dn_temporal.comp) */
    vec3 slow_hf = hist_rgb(hf_t.xy), slow_spec = hist_rgb(sp_t);
    if (g.x == DN_FGEO_NONE) { /* no surface: nothing to clamp (the a-trous carries it) */
        imageStore(hist_rc[cur], p, uvec4(at_pack_scaled(slow_hf * UF16_SCALE,
                                                         slow_spec * UF16_SCALE, 0.0,
                                                         uvec3(0x1000u)).xyz, hit));
        return;
    }
    float len_hf = hist_len(hf_t.xy), len_spec = hist_len(sp_t);
    uint field = fgeo_field(g.y);
    ivec2 last = ivec2(P.size.xy) - 1;

    /* history clamping: the fast histories' 5x5 moments (same field, surfaces only) */
    vec3 m1_hf = vec3(0.0), m2_hf = vec3(0.0), m1_sp = vec3(0.0), m2_sp = vec3(0.0);
    float n = 0.0, m1_l0 = 0.0, m2_l0 = 0.0;
    ivec2 lp = ivec2(gl_LocalInvocationID.xy) + 2; /* the pixel in the tile */
    for (int j = -2; j <= 2; j++)
        for (int i = -2; i <= 2; i++) {
            ivec2 t = lp + ivec2(i, j);
            vec4 sp = s_sp[t.y][t.x];
            if (sp.w != float(field))
                continue;
            vec4 hf = s_hf[t.y][t.x];
            vec3 a = hf.xyz, b = sp.xyz;
            float c = hf.w;
            m1_hf += a, m2_hf += a * a, m1_sp += b, m2_sp += b * b, m1_l0 += c, m2_l0 += c * c;
            n += 1.0;
        }
    vec3 fast_hf = at_hf(fast_t), fast_spec = at_spec(fast_t);
    /* (a history no longer than the fast one is the fast one) */
    vec3 out_hf = len_hf > P.rc.x ? clamp_to_box(slow_hf, m1_hf, m2_hf, n, fast_hf) : slow_hf;
    vec3 out_spec =
        len_spec > P.rc.x ? clamp_to_box(slow_spec, m1_sp, m2_sp, n, fast_spec) : slow_spec;
    /* lf: its L0 clamped the same way (L1 and CoCg are kept relative to L0: they follow) */
    uvec4 lf_t = imageLoad(hist_lf[cur], p);
    float l0 = hist_lf_l0(lf_t);
    if (hist_lf_len(lf_t) > P.rc.x) {
        float mean = m1_l0 / n, sigma = sqrt(max(m2_l0 / n - mean * mean, 0.0));
        float own = at_variance(fast_t);
        float c = clamp(l0, min(mean - P.rc.y * sigma, own), max(mean + P.rc.y * sigma, own));
        if (c != l0 && l0 > 0.0)
            imageStore(hist_lf[cur], p, uvec4(floatBitsToUint(c), lf_t.yzw));
    }
    uvec3 dither = history_dither(p);
    imageStore(hist_rc[cur], p, uvec4(at_pack_scaled(out_hf * UF16_SCALE, out_spec * UF16_SCALE,
                                                     0.0, dither).xyz, hit));

    /* history fix: young histories rebuilt from their neighbours', where the surface goes on
     * around the pixel: a disocclusion's. A pixel on a geometric edge (a 3x3 neighbour on
     * another plane or field, or none) is young because the jitter moves its sample from one
     * surface to the other, not because its surface was hidden; the neighbours' histories
     * there are not its own (on a still camera the fix took 2% of the pixels, every one on an
     * edge, and cost 2% of FLIP: docs/denoise.md). */
    vec3 fix_hf = out_hf, fix_spec = out_spec;
    bool fix_hf_on = len_hf <= P.rc.z, fix_spec_on = len_spec <= P.rc.z;
    vec4 ce = vec4(0.0);
    vec3 nrm = vec3(0.0);
    if (fix_hf_on || fix_spec_on) {
        ce = imageLoad(centre, p); /* position (relative to the origin), depth */
        nrm = fgeo_normal(g.y);
        bool edge = false;
        for (int j = -1; j <= 1; j++)
            for (int i = -1; i <= 1; i++) {
                if (i == 0 && j == 0)
                    continue;
                ivec2 q = clamp(p + ivec2(i, j), ivec2(0), last);
                uvec2 gq = imageLoad(fgeo, q).xy;
                vec4 cq = imageLoad(centre, q);
                edge = edge || gq.x == DN_FGEO_NONE || fgeo_field(gq.y) != field ||
                       abs(dot(nrm, cq.xyz - ce.xyz)) > 0.01 * ce.w ||
                       dot(nrm, fgeo_normal(gq.y)) < 0.9;
            }
        fix_hf_on = fix_hf_on && !edge, fix_spec_on = fix_spec_on && !edge;
    }
    if (fix_hf_on || fix_spec_on) {
        float rough = fgeo_roughness(g.y);
        float a2 = max(rough * rough, 1e-3);
        a2 *= a2;
        float spec_exp = clamp(2.0 / a2 - 2.0, 8.0, P.misc.z);
        /* (the base stride is for 1080 lines, as NRD's radii: scaled to this image's height) */
        float base = P.rc.w * min(float(P.size.y) / 1080.0, 1.0);
        float stride_hf = base / (1.0 + len_hf), stride_spec = base / (1.0 + len_spec);
        /* the centre counts as its own history's length */
        vec3 s_hf = (1.0 + len_hf) * out_hf, s_spec = (1.0 + len_spec) * out_spec;
        float w_hf = 1.0 + len_hf, w_spec = 1.0 + len_spec;
        for (int j = -2; j <= 2; j++)
            for (int i = -2; i <= 2; i++) {
                if (i == 0 && j == 0)
                    continue;
                for (int k = 0; k < 2; k++) { /* 0: hf, 1: spec */
                    if (k == 0 ? !fix_hf_on : !fix_spec_on)
                        continue;
                    float stride = k == 0 ? stride_hf : stride_spec;
                    ivec2 q = p + ivec2(round(vec2(i, j) * stride));
                    if (q != clamp(q, ivec2(0), last))
                        continue;
                    uvec2 gq = imageLoad(fgeo, q).xy;
                    if (gq.x == DN_FGEO_NONE || fgeo_field(gq.y) != field)
                        continue;
                    /* plane distance: the neighbour's tangent plane within 1% of the depth
                     * per pixel of stride x 5 (binary, as ReLAX's), normals */
                    vec3 nq = fgeo_normal(gq.y);
                    vec4 cq = imageLoad(centre, q);
                    if (abs(dot(nrm, cq.xyz - ce.xyz)) > 0.01 * ce.w * max(stride, 1.0))
                        continue;
                    float nn = max(dot(nrm, nq), 0.0);
                    if (k == 0) {
                        uvec4 t = imageLoad(hist_hf[cur], q);
                        float w = pow(max(nn, 0.01), 8.0) * (1.0 + hist_len(t.xy));
                        s_hf += w * hist_rgb(t.xy);
                        w_hf += w;
                    } else {
                        uvec2 t = imageLoad(hist_spec[cur], q).xy;
                        float w = pow(nn, spec_exp) * (1.0 + hist_len(t)) *
                                  max(0.0, 1.0 - 10.0 * abs(rough - fgeo_roughness(gq.y)));
                        s_spec += w * hist_rgb(t);
                        w_spec += w;
                    }
                }
            }
        fix_hf = s_hf / w_hf;
        /* mirror-like surfaces stay sharp (as in the a-trous) */
        fix_spec = rough >= 0.05 ? s_spec / w_spec : out_spec;
    }
    /* the a-trous input: the temporal pass's variance kept */
    float variance = at_variance(imageLoad(at[0], p));
    imageStore(at[0], p, at_pack_scaled(max(fix_hf, 0.0) * UF16_SCALE,
                                        max(fix_spec, 0.0) * UF16_SCALE, variance * UF16_SCALE,
                                        uvec3(0x1000u)));
}
