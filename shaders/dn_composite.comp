/* dn_composite.comp: remodulation and composite into linear HDR (docs/contract.md):
 * ((hf + E_n(lf)) x albedo x (1 - metallic) + spec x max(0.01, F0)) x throughput + emission,
 * E_n the SH at the shading normal, chroma rescaled with it. Inputs: the a-trous results (the
 * last slot written), or the raw contract in mode "off". lf comes from the
 * 1/3-resolution filter (dn_lf.comp), upsampled with geometry-aware weights: the 4 bilinear
 * taps on the low-res grid (anchors at full-res pixel 3i + 1) weighted by the pixel's distance
 * to the anchor's tangent plane against the footprint and max(n . n_anchor, 0)^8 (geometric
 * normals); where no tap passes (a thin object between anchors), the pixel's own temporal lf
 * history. Also saves this
 * frame's depth, geometric and shading normals and visibility for the next frame's
 * reprojection. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "dn_common.glsl"

const float SH_C0 = 0.282094791773878;
const float SH_C1 = 0.488602511902920;

/* The filtered lf at full-res pixel p (surface position pos relative to fgeo_origin(),
 * geometric normal gn, depth). */
void upsample_lf(ivec2 p, vec3 pos, vec3 gn, float depth, out vec4 sh, out vec2 cocg)
{
    uint slot = (P.iters.y + 1u) & 1u;
    ivec2 gs = grad_size();
    vec2 x = (vec2(p) - 1.0) / float(DN_STRATUM); /* low-res coordinates of the pixel */
    ivec2 s0 = ivec2(floor(x));
    vec2 f = x - vec2(s0);
    float footprint = max(depth * P.misc.x * float(DN_STRATUM), 1e-6);
    sh = vec4(0.0);
    cocg = vec2(0.0);
    float wsum = 0.0;
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            ivec2 s = clamp(s0 + ivec2(i, j), ivec2(0), gs - 1);
            uvec4 t = imageLoad(at_lf[slot], s);
            if (!lf_valid_texel(t))
                continue;
            float w = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y);
            w *= exp(-lf_plane_distance(t, pos) / (P.weights.x * footprint)) *
                 pow(max(dot(gn, lf_normal(t)), 0.0), P.weights.w);
            vec4 sh_s = imageLoad(at_lf_sh[slot], s);
            sh += w * sh_s;
            cocg += w * lf_cocg(t, sh_s.w);
            wsum += w;
        }
    if (wsum > 1e-6) {
        sh /= wsum;
        cocg /= wsum;
    } else {
        uvec4 h = imageLoad(hist_lf[pc.slot], p);
        sh = hist_lf_sh(h);
        cocg = hist_lf_cocg(h);
    }
}

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    uvec2 vis = imageLoad(img_vis_id, p).xy;
    vec3 gn = imageLoad(img_geo_normal, p).xyz;
    /* the temporal pass's copy of position (relative) and depth where it ran */
    vec4 ce = P.size.w == DN_RUN_OFF ? vec4(vec3(0.0), imageLoad(img_depth, p).x) : imageLoad(centre, p);
    float depth = ce.w;
    bool was_sample = false;
    if ((P.size.w == DN_RUN_ASVGF || P.size.w == DN_RUN_RECURRENT) && P.misc.w != 0.0) { /* this stratum's sample (one buffer read per
                                                   stratum, cached: no per-pixel mask) */
        ivec2 s = p / DN_STRATUM;
        uint pixel = uint(p.y) * P.size.x + uint(p.x);
        was_sample = samples[uint(s.y * grad_size().x + s.x)].a.x == pixel;
    }
    /* the shading normal and the field: from the filter geometry (8 bytes, the normal
     * octahedral 11 + 11 bits) where the temporal pass ran, else from the contract */
    vec3 n;
    uint field;
    if (P.size.w == DN_RUN_OFF) {
        n = imageLoad(img_normal, p).xyz;
        field = imageLoad(img_path, p).x & (TND_PATH_SPLIT | TND_PATH_REFRACT);
    } else {
        uint w = imageLoad(fgeo, p).y;
        n = fgeo_normal(w);
        field = fgeo_field(w);
    }
    bool sky = vis.x == TND_VIS_NONE;
    imageStore(prev_geo, p, uvec4(vis.x, floatBitsToUint(depth),
                                  (sky ? 0u : oct_pack12(gn)) | field << 24u |
                                      (was_sample ? 1u : 0u) << 26u,
                                  sky ? 0u : oct_pack12(n)));
    /* what the next frame's gradient samples need: barycentrics, and whether this pixel was a
     * gradient sample (not reused twice in a row); its luminances and rng key: dn_temporal.comp */
    imageStore(prev_surf, p, uvec4(vis.y, floatBitsToUint(imageLoad(img_vis_bary, p).xy), 0u));
    vec3 em = imageLoad(img_emission, p).rgb;
    if (vis.x == TND_VIS_NONE) {
        imageStore(out_img, p, vec4(finite3(em), 1.0));
        return;
    }
    vec3 hf, spec;
    vec4 sh;
    vec2 cocg;
    if (P.size.w == DN_RUN_OFF) {
        hf = load_hf(p);
        spec = load_spec(p);
        sh = imageLoad(img_lf_sh, p);
        cocg = imageLoad(img_lf_cocg, p).xy;
    } else {
        uvec4 a = imageLoad(at[max(P.iters.x, P.iters.z) & 1u], p); /* the last a-trous slot */
        hf = at_hf(a);
        spec = at_spec(a);
        upsample_lf(p, ce.xyz, gn, depth, sh, cocg);
        /* the diffuse lobe's view factor back (the histories are without it) */
        float fv = diffuse_view(p);
        hf *= fv, sh *= fv, cocg *= fv;
    }
    vec3 alb = imageLoad(img_albedo, p).rgb;
    float m = imageLoad(img_metallic, p).x;
    float Y = max(SH_C0 * sh.w + (2.0 / 3.0) * SH_C1 * dot(n, sh.xyz), 0.0);
    float s0 = sh.w / SH_C0;
    float r = s0 > 0.0 ? Y / s0 : 0.0;
    float co = cocg.x * r, cg = cocg.y * r;
    float t = Y - 0.5 * cg, g = cg + t, b = t - 0.5 * co, rr = b + co;
    vec3 lf = max(vec3(rr, g, b), vec3(0.0));
    vec3 demod = max(vec3(0.01), 0.04 * (1.0 - m) + alb * m);
    vec3 c = ((hf + lf) * alb * (1.0 - m) + spec * demod) * imageLoad(img_throughput, p).rgb + em;
    imageStore(out_img, p, vec4(finite3(c), 1.0));
}
