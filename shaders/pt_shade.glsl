/* pt_shade (body): the shading pass of the Vulkan front-end (mirror of femb_render.c shade_pixel):
 * direct light, one indirect bounce (or more), outputs hf, lf (SH + CoCg), spec. Mode 0 shades
 * every pixel from the G-buffer; mode 1 shades the gradient samples (one launch each): it patches
 * the G-buffer at the sample's pixel with the previous surface re-evaluated on this frame's
 * geometry and shades it with the previous frame's key. Mode 2 is mode 0 with mode 1 folded in:
 * the back-end's per-stratum list (selected from this frame's primary pass) names at most one
 * pixel per 3x3 stratum, which is shaded as mode 1 shades it instead of with its own sample (the
 * contract afterwards is that of mode 0 then mode 1, without the second launch). */
#include "pt_common.glsl"


layout(push_constant) uniform Push { uint mode; } pc;

/* The indirect bounces these passes are built for, plus one (0: the frame parameters' count):
 * fvk_pt.c need_passes specialises the real-time passes for the count the frame asks, so that
 * trace_path's code for vertices it cannot reach folds away (13% of `cornell`'s shading pass on
 * the H200, docs/performance.md). */
layout(constant_id = 1) const uint TND_BOUNCES_PLUS_ONE = 0u;
/* The indirect paths built for: every pixel's (1), half of them (2, TND_HALF_TRACED), or as the
 * frame parameters say (0): the test costs the full-resolution pass 2-3% where it is not folded
 * away (`atrium` on the H200, docs/performance.md). */
layout(constant_id = 2) const uint TND_HALF_SPEC = 0u;
bool half_rate()
{
    return TND_HALF_SPEC != 0u ? TND_HALF_SPEC == 2u : fr.indirect.x != 0u;
}

#if TND_PACKED
#define STORE_RGBE(img, p, v) imageStore(img, p, uvec4(tnd_rgbe_encode3(v), 0u, 0u, 0u))
#else
#define STORE_RGBE(img, p, v) imageStore(img, p, vec4(v, 0.0))
#endif

const float SH_C0 = 0.282094791773878;
const float SH_C1 = 0.488602511902920;

/* The pixel launch l of mode 0 shades (false: none). Each its own, or with the indirect paths at
 * half resolution (TND_HALF_TRACED) the launch is W x 2 ceil(H / 2): its first ceil(H / 2) rows
 * take the pixels that trace theirs this frame, one of each column's pair of rows, the rest the
 * other of each pair. A warp's lanes then all trace or all do not: with the two kinds side by
 * side in every warp, half the lanes would wait through each bounce (docs/performance.md). */
bool shade_pixel(uvec2 l, out ivec2 ip)
{
    uint W = fr.frame.y, H = fr.frame.z;
    if (!half_rate()) {
        ip = ivec2(l);
        return l.x < W && l.y < H;
    }
    uint half_rows = (H + 1u) / 2u;
    bool traced = l.y < half_rows;
    uint pair = traced ? l.y : l.y - half_rows;
    /* (x + y + frame even: y's parity is that of x + frame) */
    uint y = 2u * pair + (((l.x + fr.frame.x) & 1u) ^ (traced ? 0u : 1u));
    ip = ivec2(l.x, y);
    return l.x < W && pair < half_rows && y < H;
}

/* Gradient sample g at its pixel ip: the G-buffer there patched with the previous frame's
 * surface re-evaluated on this frame's geometry; the previous frame's key. */
uvec3 patch_gradient(tnd_gpu_gradient g, ivec2 ip)
{
    vec2 bary = vec2(uintBitsToFloat(g.b.y), uintBitsToFloat(g.b.z));
    uint inst = g.a.w, prim = g.b.x;
    vec3 dv = surface_from_camera(inst, prim, bary);
    surface s = surface_eval(inst, prim, bary, safe_normalize(dv), length(dv) * fr.jitter.z);
    imageStore(img_vis_id, ip, uvec4(inst, prim, 0u, 0u));
    imageStore(img_vis_bary, ip, vec4(bary, 0.0, 0.0));
    imageStore(img_rng, ip, uvec4(g.a.y, g.a.z, 0u, 0u));
    imageStore(img_albedo, ip, vec4(s.base, 0.0));
    imageStore(img_normal, ip, vec4(s.ns, 0.0));
    imageStore(img_geo_normal, ip, vec4(s.ng, 0.0));
    imageStore(img_position, ip, vec4(s.p, 0.0));
    imageStore(img_roughness, ip, vec4(s.roughness));
    imageStore(img_metallic, ip, vec4(s.metallic));
    imageStore(img_emission, ip, vec4(s.emission, 0.0));
    return uvec3(g.a.z, g.a.y, TND_SAMPLE_REALTIME);
}

void pt_shade_main(uvec2 launch)
{
    ivec2 ip;
    uvec3 key;
    uint W = fr.frame.y;
    if (pc.mode == 1u) {
        tnd_gpu_gradient g = gradients[launch.x];
        if (g.a.x == TND_GRADIENT_NONE) /* a stratum without a sample */
            return;
        ip = ivec2(int(g.a.x % W), int(g.a.x / W));
        key = patch_gradient(g, ip);
    } else {
        if (!shade_pixel(launch, ip))
            return;
        /* mode 2: this pixel's stratum's slot, in rows of fr.params.z (the strata's grid) */
        uvec2 st = uvec2(ip) / TND_GRADIENT_STRATUM;
        uint pixel = uint(ip.y) * W + uint(ip.x);
        tnd_gpu_gradient g;
        if (pc.mode == 2u && (g = gradients[st.y * fr.params.z + st.x]).a.x == pixel) {
            key = patch_gradient(g, ip);
        } else {
            uvec2 r = imageLoad(img_rng, ip).xy;
            key = uvec3(r.y, r.x, fr.params.y); /* (TND_SAMPLE_REALTIME but in a matched
                                                    reference) */
        }
    }
    vec3 hf = vec3(0.0), spec = vec3(0.0);
    float spec_hit = 0.0; /* (no specular-lobe sample) */
    vec4 sh = vec4(0.0);
    vec2 cocg = vec2(0.0);
    uint inst = imageLoad(img_vis_id, ip).x;
    if (inst != TND_VIS_NONE) {
        /* the surface from the G-buffer (as femb's surface_from_gbuffer) */
        surface s;
        s.p = imageLoad(img_position, ip).xyz;
        s.ns = imageLoad(img_normal, ip).xyz;
        s.ng = imageLoad(img_geo_normal, ip).xyz;
        vec3 d = fr.cam_pos.xyz - s.p;
        float depth = sqrt(dot(d, d));
        s.wo = depth > 0.0 ? d * (1.0 / depth) : s.ns;
        if (USES(TND_USES_SPECULAR) && imageLoad(img_path, ip).x != 0u) {
            /* seen in a mirror or through glass (the path flags say the primary chain met one):
             * lit towards the chain's last segment (the primary pass's chain again: same
             * jitter, same geometry) */
            chain_result ch = specular_chain(uvec2(ip), true);
            if (ch.hit && ch.vertices > 0u && ch.inst == inst &&
                ch.prim == imageLoad(img_vis_id, ip).y) {
                s.wo = -ch.dir;
                depth = ch.len;
            }
        }
        s.base = imageLoad(img_albedo, ip).rgb;
        s.roughness = imageLoad(img_roughness, ip).x;
        s.metallic = imageLoad(img_metallic, ip).x;
        s.specular = materials[meshes[instances[inst].info.x].info.x].params.y;
        s.inst = inst;
        lobe_info L = lobes(s);
        vec3 demod;
        for (int k = 0; k < 3; k++)
            demod[k] = max(0.01, 0.04 * (1.0 - s.metallic) + s.base[k] * s.metallic);
        vec3 dd, sp;
        direct_light(key, 0u, s, L, dd, sp);
        hf = dd;
        spec = sp / demod;
        vec3 wi, w;
        float pdf;
        bool is_spec;
        uint bounces = TND_BOUNCES_PLUS_ONE != 0u ? TND_BOUNCES_PLUS_ONE - 1u : fr.params.x;
        /* (half resolution: this pixel's choice in the frame its key was drawn for) */
        bool halved = half_rate();
        if (bounces > 0u && (!halved || TND_HALF_TRACED(key.x, key.y, W)) &&
            sample_brdf(s, L, key, 0u, true, wi, w, pdf, is_spec)) {
            vec3 Li = trace_path(key, s.p, offset_ray(s.p, s.ng), wi, 1u, bounces, 2u, pdf,
                                 depth * fr.jitter.z);
            vec3 contrib = w * Li;
            if (halved)
                contrib *= 2.0;
            for (int k = 0; k < 3; k++)
                if (tnd_nonfinite(contrib[k]) || contrib[k] < 0.0)
                    contrib[k] = 0.0;
            if (is_spec) {
                spec += contrib / demod;
                spec_hit = g_first_t;
            } else {
                float co = contrib.r - contrib.b, t = contrib.b + 0.5 * co, cg = contrib.g - t;
                float Y = t + 0.5 * cg;
                float kk = 4.0 * PI / (1.0 + 2.0 * max(dot(wi, s.ns), 0.0));
                sh = vec4(kk * Y * SH_C1 * wi, kk * Y * SH_C0);
                cocg = vec2(kk * co, kk * cg);
            }
        }
    }
    STORE_RGBE(img_hf, ip, hf);
    STORE_RGBE(img_spec, ip, spec);
    imageStore(img_spec_hit, ip, vec4(spec_hit));
    imageStore(img_lf_sh, ip, sh);
    imageStore(img_lf_cocg, ip, vec4(cocg, 0.0, 0.0));
}
