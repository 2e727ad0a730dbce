/* dn_lf_down.comp: the first step of the lf filter (dn_lf.comp, k = 0): the downsample onto the
 * stratum anchors. The anchor is the stratum's centre pixel (the first surface pixel in row
 * order when the centre sees the sky); this frame's lf history of the 9 pixels is averaged with
 * weights max(n . n_anchor, 0)^8 (geometric normals) times the tangent-plane test of the a-trous
 * passes, and the variance of the average's L0 estimated from the stratum's samples (for the lf
 * a-trous's luminance weight); the anchor's tangent plane goes with the CoCg into the lf texel
 * (lf_pack), its position and depth to lf_geo (read by the lf a-trous at its centre). Writes
 * slot 0. One thread per pixel (tiles of strata; the anchor is found and the weighted values
 * summed in row order through shared memory). */
#version 460
#extension GL_GOOGLE_include_directive : require
#define DN_STRATUM_TILES 1
#include "dn_common.glsl"

shared bool s_valid[DN_TILE_N];
shared vec4 s_sh[DN_TILE_N]; /* w x lf SH of the pixel */
shared vec3 s_cw[DN_TILE_N]; /* w x CoCg, w */
shared vec4 s_mom[DN_TILE_N]; /* w x raw L0^2, w x raw L0, w^2, w x history length */
shared vec4 s_geo[DN_TILE_STRATA][2]; /* the anchor's lf_geo texels */

/* tile-local index of stratum k's anchor, ~0u when the stratum sees only sky */
uint find_anchor(uint k)
{
    if (s_valid[tile_pixel_index(k, 1, 1)])
        return tile_pixel_index(k, 1, 1);
    for (int j = 0; j < DN_STRATUM; j++)
        for (int i = 0; i < DN_STRATUM; i++)
            if (s_valid[tile_pixel_index(k, i, j)])
                return tile_pixel_index(k, i, j);
    return ~0u;
}

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    uint li = gl_LocalInvocationIndex, k = tile_stratum_index();
    bool valid = inside(p) && imageLoad(img_vis_id, p).x != TND_VIS_NONE;
    s_valid[li] = valid;
    barrier();
    uint anchor = find_anchor(k);
    vec4 sh = vec4(0.0);
    vec3 cw = vec3(0.0);
    vec4 mom = vec4(0.0);
    if (valid) {
        ivec2 a = tile_pixel(anchor);
        vec4 ca = imageLoad(centre, a); /* position relative to fgeo_origin(), depth */
        vec3 n = imageLoad(img_geo_normal, a).xyz, pos = ca.xyz;
        float depth = ca.w;
        float w = 1.0;
        if (anchor != li) {
            float footprint = max(depth * P.misc.x, 1e-6);
            float plane = abs(dot(n, imageLoad(centre, p).xyz - pos));
            float nn = max(dot(n, imageLoad(img_geo_normal, p).xyz), 0.0);
            w = exp(-plane / (P.weights.x * footprint)) * pow(nn, P.weights.w);
        } else {
            s_geo[k][0] = vec4(pos, 1.0);
            s_geo[k][1] = vec4(n, depth);
        }
        uvec4 h = imageLoad(hist_lf[pc.slot], p);
        vec4 hs = hist_lf_sh(h);
        sh = w * hs;
        cw = vec3(w * hist_lf_cocg(h), w);
        float raw = finite4(imageLoad(img_lf_sh, p)).w / diffuse_view(p); /* this frame's sample */
        mom = vec4(w * raw * raw, w * raw, w * w, w * hist_lf_len(h));
    }
    s_sh[li] = sh;
    s_cw[li] = cw;
    s_mom[li] = mom;
    barrier();
    if (li >= DN_TILE_STRATA)
        return;
    ivec2 s = tile_stratum(li);
    if (!in_grid(s))
        return;
    vec4 sum_sh = vec4(0.0);
    vec3 sum_cw = vec3(0.0);
    vec4 sum_mom = vec4(0.0);
    for (int j = 0; j < DN_STRATUM; j++)
        for (int i = 0; i < DN_STRATUM; i++) {
            sum_sh += s_sh[tile_pixel_index(li, i, j)];
            sum_cw += s_cw[tile_pixel_index(li, i, j)];
            sum_mom += s_mom[tile_pixel_index(li, i, j)];
        }
    if (find_anchor(li) != ~0u) {
        vec3 pos = s_geo[li][0].xyz;
        vec4 m_sh = sum_sh / sum_cw.z;
        /* The noise left in the anchor's L0: the variance of one frame's samples (their
         * spread over the stratum, unbiased: n_eff - 1; at least the mean's square, since 1
         * spp indirect light deviates by about its mean or more, and nine zeros tell nothing)
         * over the samples behind the anchor: its pixels' mean history length times the
         * effective count of pixels averaged. (The spread of the histories themselves shrinks
         * as they grow too, but a moving camera's bilinear reprojection makes neighbours'
         * histories alike, and that spread then hid the noise left: blotches on atrium.) */
        float n_eff = sum_cw.z * sum_cw.z / max(sum_mom.z, 1e-30);
        float len = max(sum_mom.w / sum_cw.z, 1.0), mr = sum_mom.y / sum_cw.z;
        float spread = max(sum_mom.x / sum_cw.z - mr * mr, 0.0);
        float var = max(n_eff > 1.5 ? spread * n_eff / (n_eff - 1.0) : 0.0, m_sh.w * m_sh.w) /
                    (len * max(n_eff, 1.0));
        imageStore(lf_geo, s, vec4(pos, s_geo[li][1].w));
        imageStore(at_lf[0], s, lf_pack(true, pos, s_geo[li][1].xyz, sum_cw.xy / sum_cw.z,
                                        m_sh.w, tnd_nonfinite(var) ? 0.0 : var));
        imageStore(at_lf_sh[0], s, m_sh);
    } else { /* the whole stratum sees the sky */
        imageStore(lf_geo, s, vec4(0.0));
        imageStore(at_lf[0], s, uvec4(0u));
        imageStore(at_lf_sh[0], s, vec4(0.0));
    }
}
