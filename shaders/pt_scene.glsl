/* pt_scene.glsl: the scene's bindings (set 0) and what every stage of the path tracer reads
 * from them: vertex fetches, texture filtering written out (the mirror of tnd_texture_sample),
 * the specialization on what a scene requires, and the alpha test (tnd_material_alpha_pass).
 * Included by pt_common.glsl (raygens, compute twins) and pt_alpha.rahit (the any-hit shader). */
#ifndef TND_PT_SCENE_GLSL
#define TND_PT_SCENE_GLSL

#include "encoding.h"
#include "lights.h"
#include "scene_gpu.h"
#include "texel_lut.h"

layout(set = 0, binding = 0) uniform accelerationStructureEXT tlas;
layout(set = 0, binding = 1, std140) uniform Frame { tnd_gpu_frame fr; };
layout(set = 0, binding = 2, std430) readonly buffer Positions { float positions[]; };
layout(set = 0, binding = 3, std430) readonly buffer Normals { float normals[]; };
layout(set = 0, binding = 4, std430) readonly buffer Uvs { float uvs[]; };
layout(set = 0, binding = 5, std430) readonly buffer Tangents { float tangents[]; };
layout(set = 0, binding = 6, std430) readonly buffer Indices { uint indices[]; };
layout(set = 0, binding = 7, std430) readonly buffer Meshes { tnd_gpu_mesh meshes[]; };
layout(set = 0, binding = 8, std430) readonly buffer Materials { tnd_gpu_material materials[]; };
layout(set = 0, binding = 9, std430) readonly buffer Instances { tnd_gpu_instance instances[]; };
layout(set = 0, binding = 10, std430) readonly buffer Lights { tnd_light_gpu lights[]; };
layout(set = 0, binding = 11, std430) buffer Gradients { tnd_gpu_gradient gradients[]; };
layout(set = 0, binding = 12) uniform usampler2D textures[]; /* RGBA8 as stored */
layout(set = 0, binding = 14, std430) readonly buffer Env { float env_data[]; };
/* TEXCOORD_1 (the scene's TEXCOORD_0 again when no mesh has a second set) */
layout(set = 0, binding = 15, std430) readonly buffer Uvs1 { float uvs1[]; };
/* shaders/texel_lut.h's table (TND_TEXEL_LUT_SIZE floats), as the CPU decodes texels */
layout(set = 0, binding = 16, std430) readonly buffer TexelLut { float texel_lut[]; };
/* the alpha test's records and UVs (alpha_pass) */
layout(set = 0, binding = 17, std430) readonly buffer Alpha { vec4 alpha_data[]; };
/* the light tree (fr.indirect.y nodes), declared by the header with its functions */
#define TND_LT_SET 0
#define TND_LT_BINDING 18
#include "light_tree.h"
/* ReSTIR DI's reservoirs and surfaces (shaders/restir.h; pt_restir.glsl) */
#include "restir.h"
layout(set = 0, binding = 19, std430) buffer Reservoirs { tnd_gpu_reservoir reservoirs[]; };
layout(set = 0, binding = 20, std430) buffer RSurfaces { tnd_gpu_rsurf rsurfs[]; };
#include "env.h"


const float PI = 3.14159265358979323846;

/* What this scene needs (TND_USES_*, scene_gpu.h); branches for anything else fold away. */
layout(constant_id = 0) const uint TND_USES = TND_USES_ALL;
#define USES(bit) ((TND_USES & (bit)) != 0u)

vec3 vpos(uint i) { return vec3(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]); }
vec3 vnrm(uint i) { return vec3(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]); }
vec2 vuv(uint i) { return vec2(uvs[2 * i], uvs[2 * i + 1]); }
vec2 vuv_set(uint set, uint i)
{
    return set == 0u ? vuv(i) : vec2(uvs1[2 * i], uvs1[2 * i + 1]);
}
/* A texture transform (tnd_uv_apply): a = (m0, m1, m2, set), b = (m3, m4, m5, lod shift). */
vec2 uv_xform(vec4 a, vec4 b, vec2 uv)
{
    return vec2(a.x * uv.x + a.y * uv.y + a.z, b.x * uv.x + b.y * uv.y + b.z);
}
vec4 vtan(uint i)
{
    return vec4(tangents[4 * i], tangents[4 * i + 1], tangents[4 * i + 2], tangents[4 * i + 3]);
}

/* Trilinear filtering written out with texelFetch, the exact mirror of tnd_texture_sample (repeat
 * wrap, texel centres at +0.5, linear blend of two levels): the hardware's fixed-point filter
 * weights would make the two front-ends disagree on textured surfaces. */

/* A texel's four bytes as linear values, core/scene.c's texel_value bit for bit: RGB through
 * the sRGB table where srgb, linear data and alpha as c x (1 / 255). */
vec4 texel_decode(uvec4 c, bool srgb)
{
    vec4 v = vec4(c) * float(TND_TEXEL_UNORM);
    return srgb ? vec4(texel_lut[c.x], texel_lut[c.y], texel_lut[c.z], v.w) : v;
}

vec4 bilinear(int t, int level, ivec2 size0, vec2 uv, bool srgb)
{
    /* level sizes as the CPU builds them (halving down to 1), not textureSize(level): lavapipe
     * answered that wrongly for a non-uniformly indexed sampler in this shader */
    ivec2 size = max(size0 >> level, ivec2(1));
    vec2 x = uv * vec2(size) - 0.5;
    vec2 fl = floor(x);
    vec2 a = x - fl;
    /* uv is in [0, 1), so the taps lie in [-1, size]: wrap without % (GLSL leaves % of negative
     * operands undefined) */
    ivec2 p0 = ivec2(fl), p1 = p0 + 1;
    p0 = ivec2(p0.x < 0 ? p0.x + size.x : p0.x, p0.y < 0 ? p0.y + size.y : p0.y);
    p1 = ivec2(p1.x >= size.x ? p1.x - size.x : p1.x, p1.y >= size.y ? p1.y - size.y : p1.y);
    vec4 t00 = texel_decode(texelFetch(textures[nonuniformEXT(t)], ivec2(p0.x, p0.y), level), srgb);
    vec4 t10 = texel_decode(texelFetch(textures[nonuniformEXT(t)], ivec2(p1.x, p0.y), level), srgb);
    vec4 t01 = texel_decode(texelFetch(textures[nonuniformEXT(t)], ivec2(p0.x, p1.y), level), srgb);
    vec4 t11 = texel_decode(texelFetch(textures[nonuniformEXT(t)], ivec2(p1.x, p1.y), level), srgb);
    /* the CPU's order of summation: (0,0), (1,0), (0,1), (1,1) */
    vec4 r = ((1.0 - a.x) * (1.0 - a.y)) * t00;
    r += (a.x * (1.0 - a.y)) * t10;
    r += ((1.0 - a.x) * a.y) * t01;
    r += (a.x * a.y) * t11;
    return r;
}

/* Whether a ray meets the surface of instance inst's triangle prim at barycentrics bary: always,
 * or for an alpha-tested material, where base colour alpha x its texture's alpha at level 0
 * reaches the cutoff: tnd_material_alpha_pass's arithmetic. The data come from the alpha buffer
 * (frontend_vk/fvk_scene.c alpha_upload) in two steps, the instance's record index, then the
 * record and the triangle's UVs together: a chain of the instance, its mesh, its material, three
 * indices and their UVs cost the H200 about 1 ms a frame on atrium (docs/performance.md). */
bool alpha_pass(uint inst, uint prim, vec2 bary)
{
    uint at = instances[inst].info.z;
    if (at == 0u)
        return true;
    at -= 1u;
    vec4 xa = alpha_data[at], xb = alpha_data[at + 1u];
    uvec4 info = floatBitsToUint(alpha_data[at + 2u]); /* texture, width, height, cutoff */
    float a = xb.w;
    if (USES(TND_USES_TEXTURES) && int(info.x) >= 0) {
        vec4 p = alpha_data[at + 3u + 2u * prim], q = alpha_data[at + 4u + 2u * prim];
        vec2 t0 = p.xy, t1 = p.zw, t2 = q.xy;
        float w0 = 1.0 - bary.x - bary.y;
        vec2 uv = uv_xform(xa, xb, w0 * t0 + bary.x * t1 + bary.y * t2);
        if (tnd_nonfinite(uv.x) || tnd_nonfinite(uv.y))
            uv = vec2(0.0);
        uv -= floor(uv);
        a *= bilinear(int(info.x), 0, ivec2(info.yz), uv, true).a;
    }
    return a >= uintBitsToFloat(info.w);
}

#endif
