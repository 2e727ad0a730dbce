/* dn_temporal.comp: temporal accumulation (SVGF, Schied et al. 2017; constants as Q2RTX's A-SVGF):
 * each pixel's surface is found in the previous frame through its motion vector (the pixel's own
 * footprint moved, no jitter: a history is its pixel's mean), the history is resampled with a 2x2
 * bilinear footprint whose taps are tested one by one (tap(): same instance in the visibility
 * buffer, depth within 10% after the motion's depth delta, geometric normals within 25 degrees),
 * then blended with alpha = max(min alpha, 1 / history length). Channels: hf (colour and luminance
 * moments), lf (SH + CoCg), spec. Specular-aware weights: a spec tap also weighs max(n . n_prev,
 * 0)^s with the shading normals and s = clamp(2 / r^4 - 2, 0, 32) (r the roughness; Q2RTX's lobe-
 * width proxy), so that a glossy reflection does not take history from a texel whose normal, hence
 * whose reflected direction, differs; with no such tap the spec history restarts. A-SVGF: the
 * filtered gradients shorten the histories (antilag); the contract holds every pixel's fresh sample
 * (the re-shaded gradient samples go to the gradient pass beside it), so each counts as one. Writes this frame's history slot (the temporal means themselves: nothing
 * spatially filtered is fed back, unlike SVGF) and the first a-trous input: colours and the
 * variance of the hf history's mean (from the moments, or from a 3x3 spatial estimate where the
 * history is shorter than 4 frames), and the filter geometry (DN_B_AT, DN_B_FGEO, DN_B_CENTRE). */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"

/* The history gathered from the previous frame's taps (tap()), and what the taps test: the
 * pixel's surface. */
vec4 h_hf = vec4(0.0), h_mom = vec4(0.0), h_sh = vec4(0.0), h_spec = vec4(0.0);
vec2 h_cocg = vec2(0.0);
vec3 h_fast_hf = vec3(0.0), h_fast_spec = vec3(0.0); /* recurrent */
float h_fast_l0 = 0.0, h_hit = 0.0;
float wsum = 0.0, wsum_spec = 0.0;
uint t_inst, t_field;
float t_depth, t_shininess;
vec3 t_gn, t_n;

/* Whether g, the previous frame's surface at a texel, is this pixel's: the same instance and
 * field, geometric normals within 25 degrees and (with_depth) the depth within 10% after the
 * motion's depth delta. */
bool saw_surface(uvec4 g, bool with_depth)
{
    return g.x == t_inst && ((g.z >> 24u) & 3u) == t_field &&
           (!with_depth || abs(uintBitsToFloat(g.y) - t_depth) <= 0.1 * t_depth) &&
           dot(oct_unpack12(g.z), t_gn) >= 0.9;
}

/* a spec tap's weight: w times the shading normals' agreement (tap()) */
float spec_weight(uvec4 g, float w)
{
    return t_shininess > 0.0 ? w * pow(max(dot(t_n, oct_unpack12(g.w)), 0.0), t_shininess) : w;
}

/* Adds the previous frame's texel q with weight w where it saw this pixel's surface: the same
 * instance and field, the depth within 10% after the motion's depth delta (t_depth), geometric
 * normals within 25 degrees; spec weighs the shading normals' agreement too. Whether it was
 * tested and passed. */
bool tap(ivec2 q, float w)
{
    if (!inside(q) || w <= 0.0)
        return false;
    uint prev = 1u - pc.slot;
    uvec4 g = imageLoad(prev_geo, q); /* the previous surface in one texel */
    if (!saw_surface(g, true))
        return false;
    uvec4 hf_q = imageLoad(hist_hf[prev], q); /* hf, its length, moments */
    uvec4 lf_q = imageLoad(hist_lf[prev], q); /* SH, CoCg, length */
    uvec2 sp_q = imageLoad(hist_spec[prev], q).xy; /* spec, its length */
    vec3 hf_rgb = hist_rgb(hf_q.xy), spec_rgb = hist_rgb(sp_q);
    float ws = spec_weight(g, w);
    if (P.size.w == DN_RUN_RECURRENT) { /* the slow histories as the clamp left them, and the
                                           fast ones */
        uvec4 rc_q = imageLoad(hist_rc[prev], q), fast_q = imageLoad(hist_fast[prev], q);
        hf_rgb = at_hf(rc_q), spec_rgb = at_spec(rc_q);
        h_fast_hf += w * at_hf(fast_q);
        h_fast_l0 += w * at_variance(fast_q); /* (w: the fast lf L0) */
        h_hit += w * at_variance(rc_q);       /* (w: the reflection's distance) */
        h_fast_spec += ws * at_spec(fast_q);
    }
    h_hf += w * vec4(hf_rgb, hist_len(hf_q.xy));
    h_mom += w * vec4(uintBitsToFloat(hf_q.zw), hist_lf_len(lf_q), hist_len(sp_q));
    h_sh += w * hist_lf_sh(lf_q);
    h_cocg += w * hist_lf_cocg(lf_q);
    h_spec += ws * vec4(spec_rgb, 0.0);
    wsum += w;
    wsum_spec += ws;
    return true;
}

/* Whether the previous frame's texel q saw this pixel's surface (tap()'s tests). */
bool same_surface(ivec2 q)
{
    if (!inside(q))
        return false;
    return saw_surface(imageLoad(prev_geo, q), true);
}

/* Catmull-Rom weights (sharpness 0.5) of the taps at -1, 0, 1, 2 for a position t in [0, 1) */
vec4 catmull_rom(float t)
{
    float t2 = t * t, t3 = t2 * t;
    return vec4(-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0, -1.5 * t3 + 2.0 * t2 + 0.5 * t,
                0.5 * t3 - 0.5 * t2);
}

/* Recurrent: the slow colour histories (as clamped) resampled by a Catmull-Rom filter on the
 * 4x4 footprint without its corners (12 taps, renormalised: NRD's reprojection) where every tap
 * saw this surface: a bilinear resampling every frame blurs a history a little more each time
 * the camera moves; the cubic keeps it sharp. False where a tap failed (the bilinear taps
 * stay). The fast histories keep the bilinear taps (they only bound the slow ones). `passed`:
 * the bilinear taps (bit j * 2 + i of tap (i, j)) that tap() tested and passed, the 4x4's inner
 * 2x2: they are not tested again. */
bool resample_cubic(vec2 pp, bool with_spec, uint passed, out vec3 hf, out vec3 spec)
{
    ivec2 b = ivec2(floor(pp)) - 1;
    vec2 f = pp - floor(pp);
    vec4 wx = catmull_rom(f.x), wy = catmull_rom(f.y);
    hf = spec = vec3(0.0);
    float wsum = 0.0;
    uint prev = 1u - pc.slot;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 4; i++) {
            if ((i == 0 || i == 3) && (j == 0 || j == 3))
                continue; /* (the corners) */
            ivec2 q = b + ivec2(i, j);
            bool inner = i >= 1 && i <= 2 && j >= 1 && j <= 2;
            if (!(inner && (passed & 1u << ((j - 1) * 2 + i - 1)) != 0u) && !same_surface(q))
                return false;
            float w = wx[i] * wy[j];
            uvec4 rc_q = imageLoad(hist_rc[prev], q);
            hf += w * at_hf(rc_q);
            if (with_spec)
                spec += w * at_spec(rc_q);
            wsum += w;
        }
    hf = max(hf / wsum, vec3(0.0)), spec = max(spec / wsum, vec3(0.0));
    return true;
}

/* Recurrent, virtual motion: the spec history gathered again where the reflection was. Taps
 * are tested as tap() tests them but for the depth (the reflection's history lies on the same
 * surface, not at this pixel's depth). */
vec3 v_spec = vec3(0.0), v_fast = vec3(0.0);
float v_len = 0.0, v_wsum = 0.0;
void tap_spec(ivec2 q, float w)
{
    if (!inside(q) || w <= 0.0)
        return;
    uint prev = 1u - pc.slot;
    uvec4 g = imageLoad(prev_geo, q);
    if (!saw_surface(g, false))
        return;
    float ws = spec_weight(g, w);
    uvec4 rc_q = imageLoad(hist_rc[prev], q), fast_q = imageLoad(hist_fast[prev], q);
    v_spec += ws * at_spec(rc_q);
    v_fast += ws * at_spec(fast_q);
    v_len += ws * hist_len(imageLoad(hist_spec[prev], q).xy);
    v_wsum += ws;
}

/* The largest reflection distance kept (farther: the sky, seen at infinity) */
const float HIT_FAR = 1.0e6;

/* The surface's convex curvature at p (1 / radius; 0 for a plane or a concave surface): the
 * normals' change against the positions' to the neighbours on the same instance, n' - n =
 * (x' - x) / R on a sphere. */
float convex_curvature(ivec2 p, vec3 n, vec3 x, uint inst)
{
    float c = 0.0, k = 0.0;
    const ivec2 d[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
    for (int i = 0; i < 4; i++) {
        ivec2 q = p + d[i];
        if (!inside(q) || imageLoad(img_vis_id, q).x != inst)
            continue;
        vec3 dx = imageLoad(img_position, q).xyz - x;
        float l2 = dot(dx, dx);
        if (l2 > 0.0) {
            c += dot(imageLoad(img_normal, q).xyz - n, dx) / l2;
            k += 1.0;
        }
    }
    return k > 0.0 ? max(c / k, 0.0) : 0.0;
}

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    uint cur = pc.slot;
    uvec2 vis = imageLoad(img_vis_id, p).xy;
    /* hf and lf without the diffuse lobe's view factor (the composite puts it back) */
    float fv = 1.0 / diffuse_view(p);
    vec3 hf = finite3(load_hf(p)) * fv, spec = finite3(load_spec(p));
    vec4 sh = finite4(imageLoad(img_lf_sh, p)) * fv;
    vec2 cocg = finite3(vec3(imageLoad(img_lf_cocg, p).xy, 0.0)).xy * fv;
    float depth = imageLoad(img_depth, p).x;
    uint field = imageLoad(img_path, p).x & (TND_PATH_SPLIT | TND_PATH_REFRACT);
    vec3 gn = imageLoad(img_geo_normal, p).xyz;
    vec3 motion = imageLoad(img_motion, p).xyz;
    vec3 n = imageLoad(img_normal, p).xyz;
    float rough = imageLoad(img_roughness, p).x, r2 = rough * rough;
    float shininess = clamp(2.0 / max(r2 * r2, 1e-6) - 2.0, 0.0, 32.0);
    if (tnd_nonfinite(motion.x) || tnd_nonfinite(motion.y) || tnd_nonfinite(motion.z))
        motion = vec3(0.0);

    /* history: the pixel's own footprint moved by the motion (the motion has no jitter, and a
     * history is the mean over its pixel's footprint, so a still camera reads each pixel's own
     * history: reading it at this frame's jitter minus the last, as a point sample would be,
     * resampled it bilinearly every frame, a blur that compounds over the history's length and
     * brightened the closed box's ceiling band); bilinear taps tested one by one. (SVGF's
     * fallback to the 3x3 around it where none passes was tried: at a disocclusion it hands the
     * pixel a neighbour's stale history, relMSE 0.12 -> 0.14 on the pixels `dynamic`'s cube
     * uncovers, for no gain a still camera can measure.) */
    uint passed = 0u; /* the bilinear taps that saw this surface (resample_cubic) */
    if (P.size.z != 0u && vis.x != TND_VIS_NONE) {
        t_inst = vis.x, t_field = field, t_depth = depth + motion.z, t_gn = gn, t_n = n;
        t_shininess = shininess;
        vec2 pp = vec2(p) + motion.xy;
        ivec2 p0 = ivec2(floor(pp));
        vec2 f = pp - vec2(p0);
        for (int j = 0; j < 2; j++)
            for (int i = 0; i < 2; i++)
                if (tap(p0 + ivec2(i, j), (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y)))
                    passed |= 1u << (j * 2 + i);
    }
    /* Recurrent: the reflection's distance (this frame's specular sample's, blended into the
     * history's; 0 where none is known) and, from it, where the reflection was in the previous
     * frame (virtual motion, after NRD: the reflected point seen through a flat reflector lies
     * hit distance x f_D behind the surface along the view ray, f_D the GGX dominant-direction
     * factor, 1 for a mirror and 0 for a rough lobe, whose reflection moves with its surface).
     * The spec history is gathered there instead when any tap holds it. */
    float hit = 0.0;
    if (P.size.w == DN_RUN_RECURRENT && vis.x != TND_VIS_NONE) {
        float hit_prev = wsum > 1e-4 ? h_hit / wsum : 0.0;
        float hit_now = min(imageLoad(img_spec_hit, p).x, HIT_FAR);
        /* (a hit and the sky are not averaged: the newer one is kept) */
        bool mixable = hit_prev > 0.0 && (hit_prev < HIT_FAR) == (hit_now < HIT_FAR);
        hit = hit_now > 0.0 ? (mixable ? mix(hit_prev, hit_now, 0.25) : hit_now) : hit_prev;
        /* only near-mirror lobes follow the virtual point: on glossier ones the flat /
         * thin-lens image without NRD's confidence tests measured worse than the surface's
         * motion (materials: FLIP 0.1036-0.1047 against 0.1025) */
        float near_mirror = 1.0 - smoothstep(0.05, 0.2, rough);
        if (P.cam_delta.w != 0.0 && hit > 0.0 && wsum > 1e-4 && near_mirror > 0.01) {
            vec3 x = imageLoad(img_position, p).xyz, dc = x - P.cam_pos.xyz;
            vec3 v = normalize(dc);
            float nv = clamp(-dot(n, v), 0.0, 1.0);
            float a = 0.298475 * log(39.4115 - 39.0029 * clamp(rough, 0.0, 1.0));
            float f_d = clamp(a + (1.0 - a) * pow(1.0 - nv, 10.8649), 0.0, 1.0);
            float amount = f_d * near_mirror;
            /* the image behind a convex reflector of curvature C lies hit / (1 + 2 C hit)
             * behind it (the mirror equation; a flat one: hit); concave ones are taken as
             * flat (their image can come in front, or at infinity) */
            float image = hit / (1.0 + 2.0 * convex_curvature(p, n, x, vis.x) * hit);
            vec3 dv = dc + v * image * f_d;
            mat4 cur_vp = mat4(P.cur_vp[0], P.cur_vp[1], P.cur_vp[2], P.cur_vp[3]);
            mat4 prev_vp = mat4(P.prev_vp[0], P.prev_vp[1], P.prev_vp[2], P.prev_vp[3]);
            vec4 c0 = cur_vp * vec4(dv, 1.0), c1 = prev_vp * vec4(P.cam_delta.xyz + dv, 1.0);
            vec4 s0 = cur_vp * vec4(dc, 1.0), s1 = prev_vp * vec4(P.cam_delta.xyz + dc, 1.0);
            if (amount > 0.01 && c0.w > 1e-6 && c1.w > 1e-6 && s0.w > 1e-6 && s1.w > 1e-6) {
                vec2 size = vec2(P.size.xy);
                /* virtual motion, px: the surface's own (moving objects too) plus what the
                 * camera's motion moves the image point more than the surface point (the
                 * reflected scene taken as still) */
                vec2 vm = motion.xy + (c1.xy / c1.w - c0.xy / c0.w - s1.xy / s1.w + s0.xy / s0.w) *
                                          0.5 * size;
                vec2 pv = vec2(p) + mix(motion.xy, vm, amount);
                ivec2 v0 = ivec2(floor(pv));
                vec2 fv = pv - vec2(v0);
                for (int j = 0; j < 2; j++)
                    for (int i = 0; i < 2; i++)
                        tap_spec(v0 + ivec2(i, j),
                                 (i == 1 ? fv.x : 1.0 - fv.x) * (j == 1 ? fv.y : 1.0 - fv.y));
                if (v_wsum > 1e-4) { /* the reflection's history replaces the surface's */
                    h_spec = vec4(v_spec, 0.0);
                    h_fast_spec = v_fast;
                    wsum_spec = v_wsum;
                }
            }
        }
    }
    /* recurrent: the cubic resampling where the whole footprint is this surface (spec too where
     * its taps all count fully and it was not gathered at the reflection) */
    bool cubic = false;
    vec3 cr_hf, cr_spec;
    bool cr_with_spec = v_wsum <= 1e-4 && wsum_spec > 0.999;
    if (P.size.w == DN_RUN_RECURRENT && P.frame.y != 0u && wsum > 0.999 && vis.x != TND_VIS_NONE)
        cubic = resample_cubic(vec2(p) + motion.xy, cr_with_spec, passed, cr_hf, cr_spec);
    float l = luma(hf);
    vec4 out_hf, out_mom, out_sh, out_spec;
    vec3 fast_hf = hf, fast_spec = spec; /* recurrent: the fast histories */
    float fast_l0 = sh.w;
    vec2 out_cocg;
    if (wsum > 1e-4) {
        h_hf /= wsum, h_mom /= wsum, h_sh /= wsum, h_cocg /= wsum;
        bool spec_ok = wsum_spec > 1e-4;
        h_spec = spec_ok ? h_spec / wsum_spec : vec4(0.0);
        h_mom.w = spec_ok ? h_mom.w : 0.0; /* no spec history: alpha 1 below */
        if (v_wsum > 1e-4) /* (gathered at the reflection's previous position) */
            h_mom.w = v_len / v_wsum;
        if (cubic) {
            h_hf.rgb = cr_hf;
            if (cr_with_spec)
                h_spec.rgb = cr_spec;
        }
        float cap = P.misc.y;
        float len_hf = min(h_hf.a + 1.0, cap), len_lf = min(h_mom.z + 1.0, cap);
        float len_spec = min(h_mom.w + 1.0, cap);
        float anti_hf = 0.0, anti_lf = 0.0, anti_spec = 0.0;
        bool recurrent = P.size.w == DN_RUN_RECURRENT;
        if ((P.size.w == DN_RUN_ASVGF || recurrent) && P.misc.w != 0.0) {
            /* A-SVGF: the filtered gradients (slot 0 after the blur) shorten the history */
            vec3 g = clamp(imageLoad(grad[0], min(p / DN_STRATUM, grad_size() - 1)).xyz, 0.0, 1.0);
            /* hf by the relative change itself, A-SVGF's lambda (the gradient is its square,
             * Q2RTX's normalisation: a shadow that moved by half its contrast dropped a quarter
             * of the history a frame; docs/denoise.md, "The hf antilag") */
            anti_hf = clamp(P.antilag.x * sqrt(g.x), 0.0, 1.0);
            /* (A-SVGF shortens glossy histories with the motion, a stand-in for following
             * reflections; the recurrent denoiser follows them by virtual motion and the clamp) */
            anti_spec = clamp(P.antilag.y * g.y + (recurrent ? 0.0 : P.antilag.z * length(motion.xy)),
                              0.0, 1.0);
            anti_lf = clamp(P.antilag.w * g.z, 0.0, 1.0);
            /* (recurrent: the gradients are its confidence input, used as A-SVGF uses them) */
            len_hf = min(h_hf.a * pow(1.0 - anti_hf, 10.0) + 1.0, cap);
            len_lf = min(h_mom.z * pow(1.0 - anti_lf, 10.0) + 1.0, cap);
            len_spec = min(h_mom.w * pow(1.0 - anti_spec, 10.0) + 1.0, cap);
        }
        if (recurrent) {
            /* The gradients are its history's confidence input (NRD's recipe computes that
             * input from A-SVGF-style gradients), applied as A-SVGF applies them above and
             * below: they shorten the slow and the fast histories alike. The fast histories:
             * the same samples, at most P.rc.x frames long. */
            float af_hf = mix(min(1.0 / min(len_hf, P.rc.x), 1.0), 1.0, anti_hf);
            float af_spec = mix(min(1.0 / min(len_spec, P.rc.x), 1.0), 1.0, anti_spec);
            float af_lf = mix(min(1.0 / min(len_lf, P.rc.x), 1.0), 1.0, anti_lf);
            h_fast_hf /= wsum;
            fast_l0 = mix(h_fast_l0 / wsum, sh.w, af_lf);
            h_fast_spec = spec_ok ? h_fast_spec / wsum_spec : spec;
            fast_hf = mix(h_fast_hf, hf, af_hf);
            fast_spec = mix(h_fast_spec, spec, af_spec);
        }
        float a_hf = min(max(P.alpha.x, 1.0 / len_hf), 1.0);
        float a_m = min(max(P.alpha.w, 1.0 / len_hf), 1.0);
        float a_lf = min(max(P.alpha.y, 1.0 / len_lf), 1.0);
        float a_spec = min(max(P.alpha.z, 1.0 / len_spec), 1.0);
        a_hf = mix(a_hf, 1.0, anti_hf);
        a_m = mix(a_m, 1.0, anti_hf);
        a_spec = mix(a_spec, 1.0, anti_spec);
        a_lf = mix(a_lf, 1.0, anti_lf);
        out_hf = vec4(mix(h_hf.rgb, hf, a_hf), len_hf);
        out_mom = vec4(mix(h_mom.xy, vec2(l, l * l), a_m), len_lf, len_spec);
        out_sh = mix(h_sh, sh, a_lf);
        out_cocg = mix(h_cocg, cocg, a_lf);
        out_spec = vec4(mix(h_spec.rgb, spec, a_spec), 0.0);
    } else {
        out_hf = vec4(hf, 1.0);
        out_mom = vec4(l, l * l, 1.0, 1.0);
        out_sh = sh;
        out_cocg = cocg;
        out_spec = vec4(spec, 0.0);
    }
    /* variance: temporal moments, or a 3x3 spatial estimate on young histories */
    float m1 = out_mom.x, m2 = out_mom.y;
    if (out_hf.a < 4.0) {
        float s1 = 0.0, s2 = 0.0, n = 0.0;
        for (int j = -1; j <= 1; j++)
            for (int i = -1; i <= 1; i++) {
                ivec2 q = p + ivec2(i, j);
                if (!inside(q) || imageLoad(img_vis_id, q).x != vis.x)
                    continue;
                float lq = luma(finite3(load_hf(q))) * fv; /* (the centre's factor) */
                s1 += lq, s2 += lq * lq, n += 1.0;
            }
        m1 = s1 / max(n, 1.0), m2 = s2 / max(n, 1.0);
    }
    /* The a-trous's luminance weight stops at a few standard deviations of the noise left in
     * the hf history, the variance of its mean: the moments' variance of one frame's sample
     * times the variance factor of the weights (1 / n for the first n frames' mean; alpha /
     * (2 - alpha) for the exponential mean at the minimum alpha). SVGF used the variance of
     * one sample, which keeps the spatial filter as wide after a hundred frames as after one:
     * a still image never converged to its mean, but to a blur of it. */
    float a_eff = min(max(P.alpha.x, 1.0 / out_hf.a), 1.0);
    float variance = max(m2 - m1 * m1, 0.0) *
                     min(max(1.0 / out_hf.a, a_eff / (2.0 - a_eff)), 1.0);
    uvec3 dither = history_dither(p);
    imageStore(hist_hf[cur], p,
               hist_hf_pack_scaled(max(out_hf.rgb, 0.0) * UF16_SCALE, out_hf.a, out_mom.xy, dither));
    imageStore(hist_lf[cur], p, hist_lf_pack(out_sh, out_cocg, out_mom.z, dither));
    vec3 spec_s = max(out_spec.rgb, 0.0) * UF16_SCALE; /* finite: the inputs are sanitised */
    imageStore(hist_spec[cur], p, uvec4(hist_rgb_pack_scaled(spec_s, out_mom.w, dither), 0u, 0u));
    if (P.size.w == DN_RUN_RECURRENT)
        imageStore(hist_fast[cur], p,
                   at_pack_scaled(max(fast_hf, 0.0) * UF16_SCALE, max(fast_spec, 0.0) * UF16_SCALE,
                                  max(fast_l0, 0.0) * UF16_SCALE, dither));
    if (P.size.w == DN_RUN_RECURRENT) /* the reflection's distance (the history pass clamps the
                                         colours of this texel) */
        imageStore(hist_rc[cur], p, uvec4(0u, 0u, 0u, tnd_uf16_encode_offset(hit * UF16_SCALE,
                                                                              dither.x)));
    if (P.size.w == DN_RUN_ASVGF || P.size.w == DN_RUN_RECURRENT) {
        /* the next frame's gradient samples need the raw luminances and the rng key (the
           selection, which reads them, runs earlier) */
        imageStore(prev_lum, p, uvec4(prev_lum_pack(luma(hf), luma(spec))));
        imageStore(prev_key, p, imageLoad(img_rng, p));
    }
    vec3 pos = imageLoad(img_position, p).xyz - fgeo_origin();
    uvec2 g = fgeo_pack(vis.x != TND_VIS_NONE, pos, n, rough, field);
    imageStore(centre, p, vec4(pos, depth));
    /* the a-trous input (the histories are not fed back from the a-trous: they stay this
     * frame's temporal means, so a still image converges to its own mean) */
    imageStore(at[0], p, at_pack_scaled(max(out_hf.rgb, 0.0) * UF16_SCALE, spec_s,
                                        (tnd_nonfinite(variance) ? 0.0 : variance) * UF16_SCALE,
                                        uvec3(0x1000u)));
    imageStore(fgeo, p, uvec4(g, 0u, 0u));
}
