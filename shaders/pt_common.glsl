/* pt_common.glsl: the front-end's estimator in GLSL, the mirror of frontend_embree/
 * femb_estimator.c, femb_render.c and femb_scene.c (same functions, same order of random
 * numbers, same scalar code from brdf.h),
 * so that the two front-ends agree sample for sample. Included by the pt_*.rgen passes (ray-
 * tracing pipeline) and, with TND_RAY_QUERY, by their compute twins (inline ray queries). */
#extension GL_EXT_nonuniform_qualifier : require
#extension GL_GOOGLE_include_directive : require
#ifdef TND_RAY_QUERY
#extension GL_EXT_ray_query : require
#else
#extension GL_EXT_ray_tracing : require
#endif

/* (the scene's bindings and specialization first: sampling.h draws reference samples only in
 * passes built with TND_USES_REFERENCE) */
#include "pt_scene.glsl"
#define TND_RAND_REFERENCE USES(TND_USES_REFERENCE)

#include "brdf.h"
#include "lights.h"
#include "sampling.h"
#include "scene_gpu.h"
#include "encoding.h"
#include "specular.h"
#include "offset.h"

#define TND_CONTRACT_SET 1
#include "contract.h"
TND_CONTRACT(TND_CT_DECLARE)


/* ---- rays ---------------------------------------------------------------------------------- */
struct hit_info {
    float t;
    uint inst;
    uint prim;
    vec2 bary;
};

/* Every ray is opaque (no any-hit shader or candidate test runs) unless the scene has
 * alpha-tested geometry; then the geometry without it is still marked opaque in its BLAS, and
 * pt_alpha.rahit (or alpha_candidates) tests the rest. */
const uint RAY_OPAQUE = USES(TND_USES_ALPHA) ? gl_RayFlagsNoneEXT : gl_RayFlagsOpaqueEXT;

#ifndef TND_RAY_QUERY
layout(location = 0) rayPayloadEXT hit_info payload;
layout(location = 1) rayPayloadEXT uint shadow_payload;

bool trace_closest(vec3 org, vec3 dir, float tmax, out hit_info h)
{
    payload.t = -1.0;
    traceRayEXT(tlas, RAY_OPAQUE, 0xff, 0, 0, 0, org, 0.0, dir, tmax, 0);
    h = payload;
    return payload.t >= 0.0;
}

bool trace_occluded(vec3 org, vec3 dir, float tmax)
{
    shadow_payload = 1u;
    traceRayEXT(tlas,
                RAY_OPAQUE | gl_RayFlagsTerminateOnFirstHitEXT | gl_RayFlagsSkipClosestHitShaderEXT,
                0xff, 0, 0, 1, org, 0.0, dir, tmax, 1);
    return shadow_payload != 0u;
}
#else

/* The candidate loop of a ray query: a triangle of alpha-tested geometry (not opaque in its
 * BLAS) is confirmed where alpha_pass says the surface is there. */
void alpha_candidates(rayQueryEXT q)
{
    while (rayQueryProceedEXT(q)) {
        if (USES(TND_USES_ALPHA) && rayQueryGetIntersectionTypeEXT(q, false) ==
                                        gl_RayQueryCandidateIntersectionTriangleEXT) {
            uint inst = uint(rayQueryGetIntersectionInstanceCustomIndexEXT(q, false) +
                             rayQueryGetIntersectionGeometryIndexEXT(q, false));
            uint prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(q, false));
            if (alpha_pass(inst, prim, rayQueryGetIntersectionBarycentricsEXT(q, false)))
                rayQueryConfirmIntersectionEXT(q);
        }
    }
}

bool trace_closest(vec3 org, vec3 dir, float tmax, out hit_info h)
{
    rayQueryEXT q;
    rayQueryInitializeEXT(q, tlas, RAY_OPAQUE, 0xff, org, 0.0, dir, tmax);
    alpha_candidates(q);
    if (rayQueryGetIntersectionTypeEXT(q, true) == gl_RayQueryCommittedIntersectionNoneEXT) {
        h.t = -1.0;
        return false;
    }
    h.t = rayQueryGetIntersectionTEXT(q, true);
    /* the scene's instance: a merged run's first plus the geometry (frontend_vk/fvk_scene.c) */
    h.inst = uint(rayQueryGetIntersectionInstanceCustomIndexEXT(q, true) +
                  rayQueryGetIntersectionGeometryIndexEXT(q, true));
    h.prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(q, true));
    h.bary = rayQueryGetIntersectionBarycentricsEXT(q, true);
    return true;
}

bool trace_occluded(vec3 org, vec3 dir, float tmax)
{
    rayQueryEXT q;
    rayQueryInitializeEXT(q, tlas, RAY_OPAQUE | gl_RayFlagsTerminateOnFirstHitEXT, 0xff, org, 0.0,
                          dir, tmax);
    alpha_candidates(q);
    return rayQueryGetIntersectionTypeEXT(q, true) != gl_RayQueryCommittedIntersectionNoneEXT;
}
#endif

/* A ray origin off the surface at p along the geometric normal n (shaders/offset.h), as
 * femb_offset_ray. */
vec3 offset_ray(vec3 p, vec3 n)
{
    return p + n * tnd_offset_eps(tnd_max_abs(p));
}

/* ---- surfaces ------------------------------------------------------------------------------ */
struct surface {
    vec3 p, ng, ns, wo;
    vec3 base;
    float metallic, roughness, specular;
    vec3 emission;
    vec3 obj;
    uint inst, prim;
    uint kind;   /* TND_KIND_* */
    float ior;
    vec3 sigma;  /* glass absorption (1/m) */
    bool front;  /* arrived on the side the geometric normal points to */
};

vec3 xf_point(tnd_gpu_instance I, vec3 p)
{
    return vec3(dot(I.xform[0], vec4(p, 1.0)), dot(I.xform[1], vec4(p, 1.0)),
                dot(I.xform[2], vec4(p, 1.0)));
}
vec3 xf_dir(tnd_gpu_instance I, vec3 d)
{
    return vec3(dot(I.xform[0].xyz, d), dot(I.xform[1].xyz, d), dot(I.xform[2].xyz, d));
}
vec3 xf_normal(tnd_gpu_instance I, vec3 n)
{
    vec3 r0 = I.xform[0].xyz, r1 = I.xform[1].xyz, r2 = I.xform[2].xyz;
    vec3 c0 = cross(r1, r2), c1 = cross(r2, r0), c2 = cross(r0, r1);
    return vec3(dot(c0, n), dot(c1, n), dot(c2, n)); /* the cofactor matrix times n */
}

vec3 safe_normalize(vec3 v)
{
    float l = sqrt(dot(v, v));
    return l > 0.0 ? v / l : v;
}

vec4 sample_tex(int t, vec2 uv, float lod_base, bool srgb)
{
    vec2 size = vec2(textureSize(textures[nonuniformEXT(t)], 0));
    float lod = lod_base + 0.5 * log2(size.x * size.y);
    if (tnd_nonfinite(uv.x) || tnd_nonfinite(uv.y))
        uv = vec2(0.0);
    uv -= floor(uv);
    if (!(lod > 0.0))
        lod = 0.0;
    /* the CPU's chain halves down to 1x1 (at most TND_TEXTURE_MAX_LEVELS = 16 levels) */
    ivec2 isz = ivec2(size);
    float maxl = float(min(findMSB(max(isz.x, isz.y)) + 1, 16) - 1);
    if (lod > maxl)
        lod = maxl;
    int l0 = int(lod);
    int l1 = float(l0 + 1) <= maxl ? l0 + 1 : l0;
    float f = lod - float(l0);
    vec4 a = bilinear(t, l0, isz, uv, srgb);
    /* (no second level where it has no weight: a + 0 (b - a) is a, texels being finite and not
     * -0; magnified and clamped footprints, where lod is a whole number; the CPU skips too) */
    if (f == 0.0)
        return a;
    vec4 b = bilinear(t, l1, isz, uv, srgb);
    return a + f * (b - a);
}

/* Texture t of material slot k at the slot's coordinate set, through its transform, at that
 * set's level of detail plus the transform's shift. */
vec4 sample_slot(tnd_gpu_material mat, uint k, int t, vec2 tuv[2], float lod_set[2])
{
    vec4 a = mat.uvx[2u * k], b = mat.uvx[2u * k + 1u];
    uint set = a.w != 0.0 ? 1u : 0u;
    /* base colour and emission are sRGB-encoded (core: the texture's srgb, by its slot) */
    return sample_tex(t, uv_xform(a, b, tuv[set]), lod_set[set] + b.w,
                      k == TND_TEX_BASE || k == TND_TEX_EMISSION);
}

surface surface_eval(uint inst, uint prim, vec2 bary, vec3 dir, float cone_width)
{
    surface s;
    tnd_gpu_instance I = instances[inst];
    tnd_gpu_mesh M = meshes[I.info.x];
    tnd_gpu_material mat = materials[M.info.x];
    uint fi = M.range.z + 3u * prim;
    uint i0 = M.range.x + indices[fi], i1 = M.range.x + indices[fi + 1u],
         i2 = M.range.x + indices[fi + 2u];
    float u = bary.x, v = bary.y, w0 = 1.0 - u - v;
    vec3 p0 = vpos(i0), p1 = vpos(i1), p2 = vpos(i2);
    s.obj = w0 * p0 + u * p1 + v * p2;
    s.p = xf_point(I, s.obj);
    vec3 e1 = p1 - p0, e2 = p2 - p0;
    vec3 ng = safe_normalize(xf_normal(I, cross(e1, e2)));
    vec3 ns = w0 * vnrm(i0) + u * vnrm(i1) + v * vnrm(i2);
    ns = dot(ns, ns) > 1e-20 ? safe_normalize(xf_normal(I, ns)) : ng;
    s.wo = -dir;
    bool front = dot(ng, s.wo) >= 0.0;
    s.front = front;
    if (!front) {
        ng = -ng;
        ns = -ns;
    }
    /* both coordinate sets and their level of detail before a texture's transform
     * (femb_scene.c's surface_textures) */
    vec2 tuv[2];
    float lod_set[2];
    bool textured = USES(TND_USES_TEXTURES) &&
                    (mat.tex.x >= 0 || mat.tex.y >= 0 || mat.tex.z >= 0 || mat.tex.w >= 0);
    if (textured) {
        vec3 we1 = xf_dir(I, e1), we2 = xf_dir(I, e2);
        float world_area = length(cross(we1, we2));
        float cosv = abs(dot(ng, dir));
        for (uint set = 0u; set < 2u; set++) {
            vec2 t0 = vuv_set(set, i0), t1 = vuv_set(set, i1), t2 = vuv_set(set, i2);
            tuv[set] = w0 * t0 + u * t1 + v * t2;
            float uv_area = abs((t1.x - t0.x) * (t2.y - t0.y) - (t2.x - t0.x) * (t1.y - t0.y));
            lod_set[set] = 0.0;
            if (uv_area > 0.0 && world_area > 0.0)
                lod_set[set] =
                    log2(cone_width / max(cosv, 1e-3)) + 0.5 * log2(uv_area / world_area);
        }
    }
    s.base = mat.base_color.rgb;
    s.metallic = mat.emission.w;
    s.roughness = mat.params.x;
    s.specular = mat.params.y;
    s.emission = mat.emission.rgb;
    s.kind = mat.info.x;
    s.ior = mat.vol.w;
    s.sigma = mat.vol.xyz;
    if (textured && mat.tex.x >= 0)
        s.base *= sample_slot(mat, TND_TEX_BASE, mat.tex.x, tuv, lod_set).rgb;
    if (textured && mat.tex.y >= 0) {
        vec4 mr = sample_slot(mat, TND_TEX_METAL_ROUGH, mat.tex.y, tuv, lod_set);
        s.roughness *= mr.g;
        s.metallic *= mr.b;
    }
    if (textured && mat.tex.w >= 0)
        s.emission *= sample_slot(mat, TND_TEX_EMISSION, mat.tex.w, tuv, lod_set).rgb;
    if (USES(TND_USES_NORMAL_MAPS) && mat.tex.z >= 0) {
        vec4 texel = sample_slot(mat, TND_TEX_NORMAL, mat.tex.z, tuv, lod_set);
        vec4 tg0 = vtan(i0);
        vec3 T = w0 * tg0.xyz + u * vtan(i1).xyz + v * vtan(i2).xyz;
        T = xf_dir(I, T);
        T = safe_normalize(T - ns * dot(ns, T));
        vec3 B = cross(ns, T) * (tg0.w < 0.0 ? -1.0 : 1.0);
        float mx = (2.0 * texel.x - 1.0) * mat.params.z, my = (2.0 * texel.y - 1.0) * mat.params.z;
        float mz = 2.0 * texel.z - 1.0;
        vec3 nm = safe_normalize(T * mx + B * my + ns * mz);
        if (dot(T, T) > 0.5 && dot(nm, nm) > 0.5)
            ns = nm;
    }
    if (dot(ns, s.wo) <= 1e-4)
        ns = ng;
    s.ng = ng;
    s.ns = ns;
    if (!front && mat.params.w == 0.0)
        s.emission = vec3(0.0);
    s.base = clamp(s.base, 0.0, 1.0);
    s.metallic = clamp(s.metallic, 0.0, 1.0);
    s.roughness = clamp(s.roughness, 0.0, 1.0);
    s.inst = inst;
    s.prim = prim;
    return s;
}

/* Object-space point p through the 3x4 transform x, relative to the world point org (a camera):
 * the translation's difference first (femb_xf_point_rel). `precise`: no reassociation that would
 * form the world point, rounded to its magnitude (1/128 at 1e5 from the origin). */
vec3 xf_point_rel(vec4 x[3], vec3 p, vec3 org)
{
    precise vec3 r = vec3(dot(x[0].xyz, p) + (x[0].w - org.x), dot(x[1].xyz, p) + (x[1].w - org.y),
                          dot(x[2].xyz, p) + (x[2].w - org.z));
    return r;
}

/* The point of a triangle from this frame's camera position (depth and eye direction of a
 * surface seen directly). */
vec3 surface_from_camera(uint inst, uint prim, vec2 bary)
{
    tnd_gpu_instance I = instances[inst];
    tnd_gpu_mesh M = meshes[I.info.x];
    uint fi = M.range.z + 3u * prim;
    vec3 o = (1.0 - bary.x - bary.y) * vpos(M.range.x + indices[fi]) +
             bary.x * vpos(M.range.x + indices[fi + 1u]) + bary.y * vpos(M.range.x + indices[fi + 2u]);
    return xf_point_rel(I.xform, o, fr.cam_pos.xyz);
}

/* ---- the estimator ------------------------------------------------------------------------- */
struct lobe_info {
    vec3 f_nv;
    float alpha, a2, nv, p_spec;
};

lobe_info lobes(surface s)
{
    lobe_info L;
    L.nv = max(dot(s.ns, s.wo), 1e-4);
    L.alpha = max(s.roughness * s.roughness, TND_MIN_ALPHA);
    L.a2 = L.alpha * L.alpha;
    vec3 kd;
    for (int k = 0; k < 3; k++) {
        L.f_nv[k] = tnd_fresnel(s.metallic, s.specular, s.base[k], L.nv);
        kd[k] = s.base[k] * (1.0 - s.metallic) * (1.0 - L.f_nv[k]);
    }
    L.p_spec = tnd_spec_probability(tnd_luminance(L.f_nv.x, L.f_nv.y, L.f_nv.z),
                                    tnd_luminance(kd.x, kd.y, kd.z));
    return L;
}

bool eval_brdf(surface s, lobe_info L, vec3 wi, out vec3 diff, out vec3 spec, out float pdf_brdf)
{
    diff = vec3(0.0);
    spec = vec3(0.0);
    pdf_brdf = 0.0;
    float nl = dot(s.ns, wi);
    if (nl <= 0.0 || dot(s.ng, wi) <= 0.0)
        return false;
    vec3 h = safe_normalize(wi + s.wo);
    float nh = max(dot(s.ns, h), 0.0), vh = max(dot(s.wo, h), 0.0);
    float g = tnd_ggx_spec_cos(nh, L.nv, nl, L.a2);
    for (int k = 0; k < 3; k++) {
        diff[k] = (1.0 - L.f_nv[k]) * nl * TND_INV_PI;
        spec[k] = tnd_fresnel(s.metallic, s.specular, s.base[k], vh) * g;
    }
    pdf_brdf = L.p_spec * tnd_ggx_vndf_pdf(nh, L.nv, L.a2) + (1.0 - L.p_spec) * nl * TND_INV_PI;
    return true;
}

void onb(vec3 n, out vec3 t, out vec3 b)
{
    float sgn = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + n.z);
    float bb = n.x * n.y * a;
    t = vec3(1.0 + sgn * n.x * n.x * a, sgn * bb, -sgn * n.x);
    b = vec3(bb, sgn + n.y * n.y * a, -n.y);
}

vec3 sample_cosine(vec3 n, float u1, float u2)
{
    vec3 t, b;
    onb(n, t, b);
    float r = sqrt(u1), phi = 2.0 * PI * u2;
    vec3 l = vec3(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u1)));
    return safe_normalize(t * l.x + b * l.y + n * l.z);
}

vec3 sample_vndf(vec3 n, vec3 wo, float alpha, float u1, float u2)
{
    vec3 t, b;
    onb(n, t, b);
    vec3 v = vec3(dot(wo, t), dot(wo, b), dot(wo, n));
    vec3 vh = safe_normalize(vec3(alpha * v.x, alpha * v.y, v.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = lensq > 0.0 ? vec3(-vh.y, vh.x, 0.0) * (1.0 / sqrt(lensq)) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u1), phi = 2.0 * PI * u2;
    float p1 = r * cos(phi), p2 = r * sin(phi);
    float sv = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - sv) * sqrt(max(0.0, 1.0 - p1 * p1)) + sv * p2;
    vec3 nh = t1 * p1 + t2 * p2 + vh * sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2));
    vec3 ne = safe_normalize(vec3(alpha * nh.x, alpha * nh.y, max(1e-6, nh.z)));
    return safe_normalize(t * ne.x + b * ne.y + n * ne.z);
}

/* key: (pixel, frame, sample word: shaders/sampling.h) */
float rnd(uvec3 key, uint bounce, uint which)
{
    return tnd_rand(key.x, key.y, key.z, tnd_dim(bounce, which));
}

uint pick_light(float u)
{
    uint lo = 0u, hi = fr.frame.w - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (lights[mid].cdf.x > u)
            hi = mid;
        else
            lo = mid + 1u;
    }
    return lo;
}

/* NEE's density of reaching emitter triangle (inst, prim) at distance d along wi from surface
 * point `from` (femb's emitter_pdf) */
float emitter_pdf(uint inst, uint prim, float d, vec3 wi, vec3 ng_light, vec3 from)
{
    uint first = instances[inst].info.y;
    if (!USES(TND_USES_AREA) || fr.frame.w == 0u || first == 0xffffffffu)
        return 0.0;
    tnd_light_gpu l = lights[first + prim];
    float cosl = abs(dot(ng_light, wi));
    float pick = l.radiance.w;
    if (USES(TND_USES_LIGHT_TREE) && fr.indirect.y != 0u) /* the tree's, from that point */
        pick = tnd_lt_pmf(floatBitsToUint(l.p2.w), from.x, from.y, from.z);
    return cosl > 0.0 ? pick * d * d / (l.cdf.w * cosl) : 0.0;
}

/* ---- the environment map (shaders/env.h; core/env.c's tnd_env_lookup and tnd_env_sample) -- */
/* Radiance along world direction dir (nearest texel) and the solid-angle density of sampling it. */
float env_lookup(vec3 dir, out vec3 rgb)
{
    float cr = fr.env.x, sr = fr.env.y;
    uint w = uint(fr.env.z), h = uint(fr.env.w);
    float x = cr * dir.x - sr * dir.z;
    float z = sr * dir.x + cr * dir.z;
    float y = clamp(dir.y, -1.0, 1.0);
    float u = atan(z, x) * (0.5 * TND_INV_PI) + 0.5;
    float v = acos(y) * TND_INV_PI;
    uint cx = min(uint(max(u * float(w), 0.0)), w - 1u);
    uint cy = min(uint(max(v * float(h), 0.0)), h - 1u);
    tnd_env_refine(w, h, x, y, z, cx, cy);
    uint t = 4u * (cy * w + cx);
    rgb = vec3(env_data[t], env_data[t + 1u], env_data[t + 2u]);
    return tnd_env_pdf(env_data[t + 3u], sqrt(max(0.0, 1.0 - y * y)));
}

/* A direction by importance: u1 picks the row, u2 the column; its radiance and density. */
float env_sample(float u1, float u2, out vec3 dir, out vec3 rgb)
{
    uint w = uint(fr.env.z), h = uint(fr.env.w);
    uint mo = TND_ENV_OFFSET_MARGINAL(w, h);
    uint y = tnd_env_find(mo, h, u1);
    float fv = tnd_env_remap(mo, y, u1);
    uint co = TND_ENV_OFFSET_CONDITIONAL(w, h) + y * w;
    uint x = tnd_env_find(co, w, u2);
    float fu = tnd_env_remap(co, x, u2);
    float u = (float(x) + fu) / float(w), v = (float(y) + fv) / float(h);
    float th = PI * v, ph = 2.0 * PI * (u - 0.5);
    float st = sin(th), ct = cos(th);
    float lx = cos(ph) * st, lz = sin(ph) * st;
    float cr = fr.env.x, sr = fr.env.y;
    dir = vec3(cr * lx + sr * lz, ct, -sr * lx + cr * lz);
    uint t = 4u * (y * w + x);
    rgb = vec3(env_data[t], env_data[t + 1u], env_data[t + 2u]);
    return tnd_env_pdf(env_data[t + 3u], st);
}

/* What a ray that leaves the scene in direction dir brings back: the uniform sky, or the
 * environment map MIS-weighted against its own sampling when the ray is a BRDF sample
 * (pdf_prev > 0). */
vec3 miss_radiance(vec3 dir, float pdf_prev)
{
    if (USES(TND_USES_ENV) && fr.env.z > 0.0) {
        vec3 rgb;
        float pdf = env_lookup(dir, rgb);
        float w = pdf_prev > 0.0 ? tnd_mis_power(pdf_prev, fr.sky.w * pdf) : 1.0;
        if (USES(TND_USES_RESTIR) && pdf_prev == TND_PDF_RESERVOIR && fr.sky.w > 0.0)
            w = 0.0; /* (a reservoir took the environment's share) */
        return rgb * w;
    }
    return USES(TND_USES_SKY) ? fr.sky.rgb : vec3(0.0);
}

/* MIS-weighted against the BRDF sample that continues the path where `mis`; where the path ends
 * at this vertex no BRDF sample can find the emitter, and NEE takes its whole share (femb's
 * direct_light_kinds) */
void direct_light(uvec3 key, uint bounce, surface s, lobe_info L, bool mis, out vec3 diff,
                  out vec3 spec)
{
    diff = vec3(0.0);
    spec = vec3(0.0);
    if (fr.frame.w == 0u)
        return;
    float u_pick = rnd(key, bounce, TND_DIM_LIGHT_PICK), pick;
    uint li;
    if (USES(TND_USES_LIGHT_TREE) && fr.indirect.y != 0u) { /* by importance for this point */
        li = tnd_lt_sample(s.p.x, s.p.y, s.p.z, u_pick, pick);
        if (li == TND_LT_NONE) /* no light reaches it */
            return;
    } else {
        li = pick_light(u_pick);
        pick = lights[li].radiance.w;
    }
    tnd_light_gpu l = lights[li];
    uint kind = uint(l.p0.w);
    float u1 = rnd(key, bounce, TND_DIM_LIGHT_U), u2 = rnd(key, bounce, TND_DIM_LIGHT_V);
    vec3 wi, pos = l.p0.xyz;
    float dist = 1e30, pdf = pick;
    vec3 Li = l.radiance.rgb;
    bool area = false, env = false;
    vec3 end = pos; /* where the shadow ray ends: a point light's position */
    if (USES(TND_USES_AREA) && kind == TND_LIGHT_KIND_TRIANGLE) {
        /* a uniform point on the triangle, the pdf turned to solid angle; a two-sided emitter
         * from either side */
        float su = sqrt(u1);
        vec3 q = pos * (1.0 - su) + l.p1.xyz * (su * (1.0 - u2)) + l.p2.xyz * (su * u2);
        vec3 nl = safe_normalize(cross(l.p1.xyz - pos, l.p2.xyz - pos));
        vec3 d = q - s.p;
        float d2 = dot(d, d);
        dist = sqrt(d2);
        if (!(dist > 0.0))
            return;
        wi = d * (1.0 / dist);
        float cfront = -dot(nl, wi); /* > 0: s.p is in front of the triangle */
        float cosl = l.p1.w != 0.0 ? abs(cfront) : cfront;
        if (cosl <= 0.0)
            return;
        pdf *= d2 / (l.cdf.w * cosl);
        area = true;
        /* the emitter's end of the shadow ray: off its plane towards the receiver */
        end = q + (cfront >= 0.0 ? nl : -nl) *
                      tnd_offset_eps(max(tnd_max_abs(q), tnd_max_abs(s.p)));
    } else if (USES(TND_USES_DIRECTIONAL) && kind == TND_LIGHT_KIND_DIRECTIONAL) {
        wi = -l.p1.xyz;
    } else if (USES(TND_USES_ENV) && kind == TND_LIGHT_KIND_ENV) {
        float pe = env_sample(u1, u2, wi, Li);
        if (!(pe > 0.0))
            return;
        pdf *= pe;
        env = true;
    } else if (USES(TND_USES_POINT | TND_USES_SPOT)) {
        vec3 d = pos - s.p;
        float d2 = dot(d, d);
        dist = sqrt(d2);
        if (!(dist > 0.0))
            return;
        wi = d * (1.0 / dist);
        float fall = 1.0 / d2;
        if (USES(TND_USES_SPOT) && kind == TND_LIGHT_KIND_SPOT) {
            float cd = -dot(wi, l.p1.xyz);
            float t = (cd - l.p2.y) / max(l.p2.x - l.p2.y, 1e-6);
            t = clamp(t, 0.0, 1.0);
            fall *= t * t;
        }
        Li *= fall;
    } else {
        return; /* a light kind this scene has not got (cannot be picked) */
    }
    vec3 dd, sp;
    float pdf_brdf;
    if (!(pdf > 0.0) || !eval_brdf(s, L, wi, dd, sp, pdf_brdf))
        return;
    /* the shadow ray from the offset origin to the offset end, direction and length from those
     * two points (femb's direct_light_kinds); none when they have crossed (the receiver closer
     * to the emitter than the coordinates resolve: no occluder fits between them) */
    vec3 org = offset_ray(s.p, s.ng);
    if (area || (kind != TND_LIGHT_KIND_DIRECTIONAL && !env)) {
        vec3 sd = end - org;
        float sl = sqrt(dot(sd, sd));
        if (dot(sd, wi) > 0.0 && trace_occluded(org, sd * (1.0 / sl), sl))
            return;
    } else if (trace_occluded(org, wi, 1e30)) {
        return;
    }
    float w = (area || env) && mis ? tnd_mis_power(pdf, pdf_brdf) : 1.0;
    diff = Li * dd * w / pdf;
    spec = Li * sp * w / pdf;
}

bool sample_brdf(surface s, lobe_info L, uvec3 key, uint bounce, bool demod, out vec3 wi,
                 out vec3 w, out float pdf, out bool is_spec)
{
    float u = rnd(key, bounce, TND_DIM_LOBE);
    float u1 = rnd(key, bounce, TND_DIM_BRDF_U), u2 = rnd(key, bounce, TND_DIM_BRDF_V);
    is_spec = u < L.p_spec;
    w = vec3(0.0);
    if (is_spec) {
        vec3 h = sample_vndf(s.ns, s.wo, L.alpha, u1, u2);
        wi = safe_normalize(h * (2.0 * dot(s.wo, h)) - s.wo);
    } else {
        wi = sample_cosine(s.ns, u1, u2);
    }
    vec3 d, sp;
    if (!eval_brdf(s, L, wi, d, sp, pdf) || !(pdf > 0.0))
        return false;
    float pl = is_spec ? L.p_spec * tnd_ggx_vndf_pdf(max(dot(s.ns, safe_normalize(wi + s.wo)), 0.0),
                                                     L.nv, L.a2)
                       : (1.0 - L.p_spec) * dot(s.ns, wi) * TND_INV_PI;
    if (!(pl > 0.0))
        return false;
    w = (is_spec ? sp : d * (demod ? vec3(1.0) : s.base * (1.0 - s.metallic))) / pl;
    return true;
}

/* The specular vertex (mirror, thin glass, glass): femb_render.c's specular_direction and
 * specular_vertex, the same decisions with the same numbers. */
vec3 specular_direction(surface s, vec3 n, vec3 dir, float u, out vec3 f, out uint event,
                        out bool enter)
{
    float cos_i = max(-dot(n, dir), 1e-6);
    vec3 refl = dir - n * (2.0 * dot(dir, n));
    f = vec3(1.0);
    enter = false;
    if (s.kind == TND_KIND_MIRROR) {
        f = vec3(tnd_mirror_fresnel(s.base.r, cos_i), tnd_mirror_fresnel(s.base.g, cos_i),
                 tnd_mirror_fresnel(s.base.b, cos_i));
        event = TND_EVENT_REFLECT;
        return refl;
    }
    event = tnd_dielectric_event(s.kind, s.front, cos_i, s.ior, u);
    if (event == TND_EVENT_REFLECT)
        return refl;
    if (event == TND_EVENT_TRANSMIT)
        return dir;
    float eta = s.front ? s.ior : 1.0 / s.ior;
    float cos_t = tnd_refract_cos(cos_i, eta);
    enter = s.front;
    return safe_normalize(dir * (1.0 / eta) + n * (cos_i / eta - cos_t));
}

vec3 specular_vertex(surface s, vec3 dir, float u, out vec3 f, out uint event, out bool enter)
{
    vec3 wi = specular_direction(s, s.ns, dir, u, f, event, enter);
    float side = dot(wi, s.ng);
    if (event == TND_EVENT_REFLECT ? side <= 0.0 : side >= 0.0)
        wi = specular_direction(s, s.ng, dir, u, f, event, enter);
    return wi;
}

/* The length of trace_path's first segment (TND_DEPTH_MISS where it escaped): the contract's
 * spec_hit for the specular-lobe sample (femb_trace_paths' first_t). */
float g_first_t = TND_DEPTH_MISS;

/* Radiance along the ray from org (the offset origin of surface point `from`, whence an emitter's
 * MIS distance is measured: femb's femb_paths) in direction dir. */
vec3 trace_path(uvec3 key, vec3 from, vec3 org, vec3 dir, uint bounce, uint max_bounce,
                uint rr_start, float pdf_prev, float cone)
{
    vec3 beta = vec3(1.0), L_out = vec3(0.0), sigma = vec3(0.0);
    bool inside = false;
    uint specular = 0u; /* specular vertices so far: they do not count as bounces */
    g_first_t = TND_DEPTH_MISS;
    for (uint b = bounce;; b++) {
        hit_info h;
        if (!trace_closest(org, dir, 1e30, h))
            return L_out + beta * miss_radiance(dir, pdf_prev);
        if (b == bounce)
            g_first_t = h.t;
        if (inside) /* Beer-Lambert over the segment inside the glass */
            beta *= vec3(exp(-sigma.x * h.t), exp(-sigma.y * h.t), exp(-sigma.z * h.t));
        cone += h.t * fr.jitter.z;
        surface s = surface_eval(h.inst, h.prim, h.bary, dir, cone);
        if (s.emission.r > 0.0 || s.emission.g > 0.0 || s.emission.b > 0.0) {
            float w = 1.0;
            if (pdf_prev > 0.0)
                w = tnd_mis_power(pdf_prev, emitter_pdf(h.inst, h.prim, length(s.p - from), dir,
                                                        s.ng, from));
            else if (USES(TND_USES_RESTIR) && pdf_prev == TND_PDF_RESERVOIR &&
                     fr.frame.w != 0u && instances[h.inst].info.y != 0xffffffffu)
                w = 0.0; /* an emitter of the list: the reservoir took its share */
            L_out += beta * w * s.emission;
        }
        if (USES(TND_USES_SPECULAR) && s.kind != TND_KIND_OPAQUE) {
            if (++specular > TND_MAX_SPECULAR_DEPTH)
                return L_out;
            vec3 f;
            uint ev;
            bool enter;
            vec3 wi = specular_vertex(s, dir, rnd(key, b, TND_DIM_SPLIT), f, ev, enter);
            if (ev == TND_EVENT_REFRACT) { /* into the volume, or out of it */
                inside = enter;
                sigma = s.sigma;
            }
            beta *= f;
            from = s.p;
            org = offset_ray(s.p, dot(wi, s.ng) >= 0.0 ? s.ng : -s.ng);
            dir = wi;
            pdf_prev = 0.0; /* a delta lobe: an emitter seen through it gets the full weight */
            continue;
        }
        uint nb = b - specular; /* bounces that count */
        lobe_info L = lobes(s);
        vec3 d, sp;
        direct_light(key, b, s, L, nb < max_bounce, d, sp);
        L_out += beta * (d * s.base * (1.0 - s.metallic) + sp);
        if (nb >= max_bounce)
            return L_out;
        vec3 wi, w;
        float pdf;
        bool is_spec;
        if (!sample_brdf(s, L, key, b, false, wi, w, pdf, is_spec))
            return L_out;
        beta *= w;
        if (nb + 1u >= rr_start) {
            float q = clamp(max(beta.x, max(beta.y, beta.z)), 0.05, 1.0);
            if (rnd(key, b, TND_DIM_RR) >= q)
                return L_out;
            beta /= q;
        }
        from = s.p;
        org = offset_ray(s.p, s.ng);
        dir = wi;
        pdf_prev = pdf;
    }
    return L_out;
}

/* Primary ray direction through pixel position px (as femb's camera_dir). */
vec3 camera_dir(vec2 px)
{
    vec2 ndc = 2.0 * px / vec2(fr.frame.yz) - 1.0;
    vec4 pv = fr.inv_proj * vec4(ndc, 0.5, 1.0);
    vec3 d = mat3(fr.inv_view) * (pv.xyz / pv.w);
    return safe_normalize(d);
}

/* The real-time reflect/refract chain (femb_render.c specular_chain): from the camera through up
 * to TND_REFLECT_DEPTH specular vertices to the surface the G-buffer shows. */
struct chain_result {
    bool hit;
    uint inst, prim, vertices, path;
    vec2 bary;
    float len;
    vec3 thr, dir, dir0;
};

chain_result specular_chain(uvec2 ipx, bool follow)
{
    chain_result r;
    vec2 px = vec2(ipx) + 0.5 + fr.jitter.xy;
    uint field = (ipx.x + ipx.y) & 1u;
    r.path = 0u;
    vec3 org = fr.cam_pos.xyz, dir = camera_dir(px);
    vec3 sigma = vec3(0.0);
    bool inside = false;
    r.hit = false;
    r.inst = TND_VIS_NONE;
    r.prim = 0u;
    r.vertices = 0u;
    r.bary = vec2(0.0);
    r.len = 0.0;
    r.thr = vec3(1.0);
    r.dir0 = dir;
    for (;;) {
        r.dir = dir;
        hit_info h;
        if (!trace_closest(org, dir, 1e30, h)) {
            r.hit = false;
            return r;
        }
        r.hit = true;
        r.inst = h.inst;
        r.prim = h.prim;
        r.bary = h.bary;
        r.len += h.t;
        if (inside)
            r.thr *= vec3(exp(-sigma.x * h.t), exp(-sigma.y * h.t), exp(-sigma.z * h.t));
        if (!follow || r.vertices >= fr.params.w)
            return r;
        if (materials[meshes[instances[h.inst].info.x].info.x].info.x == TND_KIND_OPAQUE)
            return r;
        surface s = surface_eval(h.inst, h.prim, h.bary, dir, r.len * fr.jitter.z);
        float cos_i = max(-dot(s.ns, dir), 1e-6);
        vec3 f, wi;
        if (s.kind == TND_KIND_MIRROR) { /* reflect about the shading normal, x Schlick */
            uint ev;
            bool enter;
            wi = specular_direction(s, s.ns, dir, 0.0, f, ev, enter);
            r.path |= TND_PATH_MIRROR;
        } else {
            bool refl, split;
            f = vec3(tnd_chain_dielectric(s.kind, s.front, cos_i, s.ior,
                                          (r.path & TND_PATH_SPLIT) == 0u, field, refl, split));
            if (split)
                r.path |= TND_PATH_SPLIT | (field != 0u ? TND_PATH_REFRACT : 0u);
            if (!refl)
                r.path |= TND_PATH_GLASS;
            float uu = refl ? 0.0 : 0.99999994;
            vec3 f2;
            bool enter;
            uint ev2;
            wi = specular_vertex(s, dir, uu, f2, ev2, enter);
            if (ev2 == TND_EVENT_REFRACT) {
                inside = enter;
                sigma = s.sigma;
            }
        }
        r.thr *= f;
        r.vertices++;
        org = offset_ray(s.p, dot(wi, s.ng) >= 0.0 ? s.ng : -s.ng);
        dir = wi;
    }
    return r;
}

