/* pt_shade (body): the shading pass of the Vulkan front-end (mirror of femb_render.c shade_pixel):
 * direct light, one indirect bounce (or more), outputs hf, lf (SH + CoCg), spec. Mode 0 shades
 * every pixel from the G-buffer. The gradient samples (the previous frame's surface, re-evaluated
 * on this frame's geometry, shaded with the previous frame's key): mode 1 shades a host list of
 * them (one launch each) into the contract, patching the G-buffer at the sample's pixel (for
 * captures and tests, which read the re-shaded contract); mode 3 shades the back-end's
 * per-stratum slots (one launch each) into the slots themselves (tnd_gpu_gradient.c, .d),
 * leaving the G-buffer and the contract with the pixel's own sample; mode 2 is mode 0 with mode
 * 3 folded in: the launch has rows past the pixels' own, one slot per launch, so that a warp
 * shades pixels or slots, never both (a slot shaded beside its pixel would hold its warp for a
 * second shading). Modes 4 and 5 run before mode 0 where the frame takes reservoirs (ReSTIR DI,
 * pt_restir.glsl): the candidates and the temporal merge, then the spatial merge. */
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

/* What a pixel's shading gives: the contract's noisy signals. */
struct shaded {
    vec3 hf, spec;
    float spec_hit; /* 0: no specular-lobe sample */
    float dview;    /* the contract's diffuse_view: 1 - F(n.v) (luminance) */
    vec4 sh;
    vec2 cocg;
};

/* The G-buffer's surface at ip as the shading reads it (as femb's surface_from_gbuffer): the
 * position, both normals and the material's values; wo and the instance come in shade(). */
surface gbuffer_surface(ivec2 ip)
{
    surface s;
    s.p = imageLoad(img_position, ip).xyz;
    s.ns = imageLoad(img_normal, ip).xyz;
    s.ng = imageLoad(img_geo_normal, ip).xyz;
    s.base = imageLoad(img_albedo, ip).rgb;
    s.roughness = imageLoad(img_roughness, ip).x;
    s.metallic = imageLoad(img_metallic, ip).x;
    return s;
}

#include "pt_restir.glsl"

/* no light: what a pixel that sees nothing holds */
shaded shaded_none()
{
    return shaded(vec3(0.0), vec3(0.0), 0.0, 1.0, vec4(0.0), vec2(0.0));
}

/* Shade surface s (instance inst, primitive prim) seen at pixel ip with key `key`. */
shaded shade(ivec2 ip, surface s, uint inst, uint prim, uvec3 key)
{
    shaded o = shaded_none();
    uint W = fr.frame.y;
    vec3 d = fr.cam_pos.xyz - s.p;
    float depth = sqrt(dot(d, d));
    s.wo = depth > 0.0 ? d * (1.0 / depth) : s.ns;
    if (USES(TND_USES_SPECULAR) && imageLoad(img_path, ip).x != 0u) {
        /* seen in a mirror or through glass (the path flags say the primary chain met one):
         * lit towards the chain's last segment (the primary pass's chain again: same
         * jitter, same geometry) */
        chain_result ch = specular_chain(uvec2(ip), true);
        if (ch.hit && ch.vertices > 0u && ch.inst == inst && ch.prim == prim) {
            s.wo = -ch.dir;
            depth = ch.len;
        }
    }
    s.specular = materials[meshes[instances[inst].info.x].info.x].params.y;
    s.inst = inst;
    lobe_info L = lobes(s);
    o.dview = tnd_luminance(1.0 - L.f_nv.x, 1.0 - L.f_nv.y, 1.0 - L.f_nv.z);
    vec3 demod;
    for (int k = 0; k < 3; k++)
        demod[k] = max(0.01, 0.04 * (1.0 - s.metallic) + s.base[k] * s.metallic);
    vec3 dd, sp;
    uint bounces = TND_BOUNCES_PLUS_ONE != 0u ? TND_BOUNCES_PLUS_ONE - 1u : fr.params.x;
    /* (an indirect path follows; with half of them traced, in expectation) */
    /* the direct light of a reservoir (--lights restir: pt_restir.glsl), or next-event
     * estimation's */
    int ri = USES(TND_USES_RESTIR) && key.z == TND_SAMPLE_REALTIME ? rs_lookup(key.x, key.y) : -1;
    if (ri >= 0)
        restir_shade(rs_load(uint(ri)), s, dd, sp);
    else
        direct_light(key, 0u, s, L, bounces > 0u, dd, sp);
    o.hf = dd;
    o.spec = sp / demod;
    vec3 wi, w;
    float pdf;
    bool is_spec;
    /* (half resolution: this pixel's choice in the frame its key was drawn for) */
    bool halved = half_rate();
    if (bounces > 0u && (!halved || TND_HALF_TRACED(key.x, key.y, W)) &&
        sample_brdf(s, L, key, 0u, true, wi, w, pdf, is_spec)) {
        vec3 Li = trace_path(key, s.p, offset_ray(s.p, s.ng), wi, 1u, bounces, 2u,
                             ri >= 0 ? TND_PDF_RESERVOIR : pdf, depth * fr.jitter.z);
        vec3 contrib = w * Li;
        if (halved)
            contrib *= 2.0;
        for (int k = 0; k < 3; k++)
            if (tnd_nonfinite(contrib[k]) || contrib[k] < 0.0)
                contrib[k] = 0.0;
        if (is_spec) {
            o.spec += contrib / demod;
            o.spec_hit = g_first_t;
        } else {
            float co = contrib.r - contrib.b, t = contrib.b + 0.5 * co, cg = contrib.g - t;
            float Y = t + 0.5 * cg;
            float kk = 4.0 * PI / (1.0 + 2.0 * max(dot(wi, s.ns), 0.0));
            o.sh = vec4(kk * Y * SH_C1 * wi, kk * Y * SH_C0);
            o.cocg = vec2(kk * co, kk * cg);
        }
    }
    return o;
}

/* The launch rows of mode 0's pixels (with half-rate indirect paths, pt_shade_main's pairs) */
uint pixel_rows()
{
    uint H = fr.frame.z;
    return half_rate() ? 2u * ((H + 1u) / 2u) : H;
}

/* One call of shade() and of surface_eval() in the whole pass: each is inlined where it is
 * called, and a second copy of the shading doubled the pass's code (lavapipe's compile of the
 * ray-tracing pipelines took 2.5x as long). */
void pt_shade_main(uvec2 launch)
{
    uint W = fr.frame.y;
    /* what to shade: a pixel of the G-buffer, or a gradient sample (the list's entry `entry`),
     * into the contract (mode 1, patching the G-buffer) or into its slot (modes 2 and 3) */
    int entry = -1;
    bool into_slot = false;
    if (USES(TND_USES_RESTIR) && pc.mode >= 4u) { /* the reservoirs' passes, before mode 0 */
        if (launch.x < W && launch.y < fr.frame.z) {
            if (pc.mode == 4u)
                restir_candidates(ivec2(launch));
            else
                restir_spatial(ivec2(launch));
        }
        return;
    }
    if (pc.mode == 3u) { /* the slots re-shaded after the shading pass (launch.x: the slot) */
        if (launch.x >= fr.params.z)
            return;
        entry = int(launch.x), into_slot = true;
    } else if (pc.mode == 2u && launch.y >= pixel_rows()) {
        /* mode 2's rows past the pixels' own: one slot each, a row of W slots per launch row
         * (slots in rows of fr.params.z, the strata's grid: H / 3 rows of them) */
        uint k = (launch.y - pixel_rows()) * W + launch.x;
        uint strata_rows = (fr.frame.z + TND_GRADIENT_STRATUM - 1u) / TND_GRADIENT_STRATUM;
        if (launch.x >= W || k >= fr.params.z * strata_rows)
            return;
        entry = int(k), into_slot = true;
    } else if (pc.mode == 1u) {
        entry = int(launch.x);
    }
    ivec2 ip;
    uvec3 key;
    surface s;
    uint inst, prim;
    if (entry >= 0) {
        /* the previous frame's surface re-evaluated on this frame's geometry, the previous
         * frame's key */
        tnd_gpu_gradient g = gradients[entry];
        if (g.a.x == TND_GRADIENT_NONE) /* a stratum without a sample */
            return;
        ip = ivec2(int(g.a.x % W), int(g.a.x / W));
        vec2 bary = vec2(uintBitsToFloat(g.b.y), uintBitsToFloat(g.b.z));
        inst = g.a.w, prim = g.b.x;
        vec3 dv = surface_from_camera(inst, prim, bary);
        s = surface_eval(inst, prim, bary, safe_normalize(dv), length(dv) * fr.jitter.z);
        key = uvec3(g.a.z, g.a.y, TND_SAMPLE_REALTIME);
        if (!into_slot) { /* mode 1: the G-buffer patched at the sample's pixel */
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
        }
    } else {
        if (!shade_pixel(launch, ip))
            return;
        uvec2 r = imageLoad(img_rng, ip).xy;
        key = uvec3(r.y, r.x, fr.params.y); /* (TND_SAMPLE_REALTIME but in a matched
                                                reference) */
        uvec2 vis = imageLoad(img_vis_id, ip).xy;
        inst = vis.x, prim = vis.y;
        if (inst != TND_VIS_NONE)
            s = gbuffer_surface(ip);
    }
    shaded o = shaded_none();
    if (inst != TND_VIS_NONE)
        o = shade(ip, s, inst, prim, key);
    if (into_slot) {
        gradients[entry].c = vec4(o.hf, o.sh.w);
        gradients[entry].d = vec4(o.spec, 1.0);
        return;
    }
    STORE_RGBE(img_hf, ip, o.hf);
    STORE_RGBE(img_spec, ip, o.spec);
    imageStore(img_spec_hit, ip, vec4(o.spec_hit));
    imageStore(img_diffuse_view, ip, vec4(o.dview));
    imageStore(img_lf_sh, ip, o.sh);
    imageStore(img_lf_cocg, ip, vec4(o.cocg, 0.0, 0.0));
}
