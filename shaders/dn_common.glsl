/* dn_common.glsl: declarations shared by the back-end's compute passes. Push constant: x = the
 * history slot written this frame (0 or 1; the other holds the previous frame), y = a-trous
 * iteration. */
#extension GL_GOOGLE_include_directive : require
#include "denoise_shared.h"
#include "scene_gpu.h"
#include "encoding.h"
#include "sampling.h"
#define TND_CONTRACT_SET 1
#include "contract.h"
TND_CONTRACT(TND_CT_DECLARE)

#ifdef DN_STRATUM_TILES
/* one thread per pixel; the work group is one tile of DN_TILE_SX x DN_TILE_SY strata, whose
 * pixels share their values through shared memory (tile_* below) */
layout(local_size_x = DN_TILE_W, local_size_y = DN_TILE_H) in;
#define DN_TILE_N (DN_TILE_W * DN_TILE_H)
#define DN_TILE_SX (DN_TILE_W / DN_STRATUM)
#define DN_TILE_STRATA (DN_TILE_SX * (DN_TILE_H / DN_STRATUM))
/* the tile-local index of pixel (i, j) of tile-local stratum k */
uint tile_pixel_index(uint k, int i, int j)
{
    return (k / DN_TILE_SX * DN_STRATUM + j) * DN_TILE_W + k % DN_TILE_SX * DN_STRATUM + i;
}
/* the tile-local stratum of this invocation's pixel */
uint tile_stratum_index()
{
    uvec2 l = gl_LocalInvocationID.xy / DN_STRATUM;
    return l.y * DN_TILE_SX + l.x;
}
/* the image coordinates of tile-local stratum k and tile-local pixel index k */
ivec2 tile_stratum(uint k)
{
    return ivec2(gl_WorkGroupID.xy) * ivec2(DN_TILE_SX, DN_TILE_H / DN_STRATUM) +
           ivec2(k % DN_TILE_SX, k / DN_TILE_SX);
}
ivec2 tile_pixel(uint k)
{
    return ivec2(gl_WorkGroupID.xy) * ivec2(DN_TILE_W, DN_TILE_H) + ivec2(k % DN_TILE_W, k / DN_TILE_W);
}
#elif !defined(DN_OWN_LOCAL_SIZE)
layout(local_size_x = 8, local_size_y = 8) in;
#endif
layout(set = 0, binding = DN_B_PARAMS, std140) uniform Params { dn_params P; };
layout(set = 0, binding = DN_B_HIST_HF, rgba32ui) uniform uimage2D hist_hf[2];
layout(set = 0, binding = DN_B_HIST_LF, rgba32ui) uniform uimage2D hist_lf[2];
layout(set = 0, binding = DN_B_HIST_SPEC, rg32ui) uniform uimage2D hist_spec[2];
layout(set = 0, binding = DN_B_PREV_GEO, rgba32ui) uniform uimage2D prev_geo;
layout(set = 0, binding = DN_B_PREV_SURF, rgba32ui) uniform uimage2D prev_surf;
layout(set = 0, binding = DN_B_AT, rgba32ui) uniform uimage2D at[2];
layout(set = 0, binding = DN_B_AT_LF, rgba32ui) uniform uimage2D at_lf[2];
layout(set = 0, binding = DN_B_AT_LF_SH, rgba32f) uniform image2D at_lf_sh[2];
layout(set = 0, binding = DN_B_OUT, rgba32f) uniform image2D out_img;
layout(set = 0, binding = DN_B_PREV_LUM, r32ui) uniform uimage2D prev_lum;
layout(set = 0, binding = DN_B_PREV_KEY, rg32ui) uniform uimage2D prev_key;
layout(set = 0, binding = DN_B_GRAD, rgba32f) uniform image2D grad[2];
layout(set = 0, binding = DN_B_LF_GEO, rgba32f) uniform image2D lf_geo;
layout(set = 0, binding = DN_B_FGEO, rg32ui) uniform uimage2D fgeo;
layout(set = 0, binding = DN_B_CENTRE, rgba32f) uniform image2D centre;
layout(set = 0, binding = DN_B_HIST_FAST, rgba32ui) uniform uimage2D hist_fast[2];
layout(set = 0, binding = DN_B_HIST_RC, rgba32ui) uniform uimage2D hist_rc[2];
layout(set = 0, binding = DN_B_SAMPLES, std430) buffer Samples { tnd_gpu_gradient samples[]; };
ivec2 grad_size() { return (ivec2(P.size.xy) + DN_STRATUM - 1) / DN_STRATUM; }
/* whether stratum s lies in the 1/3-resolution grid */
bool in_grid(ivec2 s) { return all(greaterThanEqual(s, ivec2(0))) && all(lessThan(s, grad_size())); }
layout(push_constant) uniform Push { uint slot; uint iteration; } pc;

#if TND_PACKED
vec3 load_hf(ivec2 p) { return tnd_rgbe_decode(imageLoad(img_hf, p).x); }
vec3 load_spec(ivec2 p) { return tnd_rgbe_decode(imageLoad(img_spec, p).x); }
#else
vec3 load_hf(ivec2 p) { return imageLoad(img_hf, p).rgb; }
vec3 load_spec(ivec2 p) { return imageLoad(img_spec, p).rgb; }
#endif

/* Octahedral unit vectors (Cigolle et al. 2014), `bits` per axis in the low 2 x bits. */
uint oct_pack(vec3 n, uint bits)
{
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    vec2 e = n.z >= 0.0 ? n.xy : (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    uvec2 q = uvec2(round(clamp(e * 0.5 + 0.5, 0.0, 1.0) * float((1u << bits) - 1u)));
    return q.x | q.y << bits;
}
vec3 oct_unpack(uint v, uint bits)
{
    uint m = (1u << bits) - 1u;
    vec2 e = vec2(v & m, (v >> bits) & m) * (2.0 / float(m)) - 1.0;
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return normalize(n);
}
uint oct_pack12(vec3 n) { return oct_pack(n, 12u); }
vec3 oct_unpack12(uint v) { return oct_unpack(v, 12u); }

/* The a-trous passes' filter geometry (DN_B_FGEO): 8 bytes per pixel instead of five contract
 * images per tap. x: the offset of the pixel's tangent plane, dot(n, pos - origin) with the
 * stored (quantised) normal n and origin fgeo_origin() (a point of this frame's scene, so that
 * the offsets stay small and exact far from the world origin); y: the normal (octahedral,
 * 11 + 11 bits), roughness (8 bits) and checkerboard field (2 bits). */
vec3 fgeo_normal(uint w) { return oct_unpack(w, 11u); }
vec3 fgeo_origin()
{
    return P.origin_vis.x != TND_VIS_NONE ? P.origin_position.xyz : vec3(0.0);
}
/* pos: relative to fgeo_origin() */
uvec2 fgeo_pack(bool surface, vec3 pos, vec3 n, float rough, uint field)
{
    if (!surface)
        return uvec2(DN_FGEO_NONE, 0u);
    uint r = uint(round(clamp(rough, 0.0, 1.0) * 255.0));
    uint w = oct_pack(n, 11u) | r << 22u | (field & 3u) << 30u;
    float d = dot(fgeo_normal(w), pos);
    return uvec2(tnd_nonfinite(d) ? DN_FGEO_NONE : floatBitsToUint(d), w);
}
float fgeo_roughness(uint w) { return float((w >> 22u) & 255u) * (1.0 / 255.0); }
uint fgeo_field(uint w) { return w >> 30u; }

/* The histories' 16-bit values are rounded stochastically: a history blends in alpha (0.01
 * to 0.02) of each new value, and with rounding to nearest an update below half a step (2^-11
 * of the value) would be lost, so a history that sees a noiseless signal stops up to 2^-11 /
 * alpha (2.4% to 4.9%) short of it (test_noiseless_history_converges). With a random offset
 * in [0, 1) step before truncation the stored value is right in expectation and the history
 * converges as a float one does, give or take 2^-11 of noise. The offsets: 13 random bits per
 * word, from the pixel and the frame (P.frame.x), three words per texel. */
uvec3 history_dither(ivec2 p)
{
    return tnd_pcg3d(uvec3(uvec2(p), P.frame.x)) & 0x1fffu;
}
/* A half float (unpackHalf2x16 reads it) rounded the same way; values below half's normal range
 * (6.1e-5) become 0, above it the largest half */
uint half_dither(float v, uint r)
{
    uint b = floatBitsToUint(v), s = (b >> 16u) & 0x8000u;
    uint m = (b & 0x7fffffffu) + r;
    int e = int(m >> 23u) - 112; /* 127 - 15 */
    if (e <= 0)
        return s;
    return e >= 31 ? s | 0x7bffu : s | uint(e) << 10u | ((m >> 13u) & 0x3ffu);
}
/* Two values relative to L0 as half floats: chroma and the L1 coefficients are bounded by
 * luminance (|L1| <= sqrt(3) L0 for a non-negative signal), small ratios that half floats keep
 * to 2^-11, clamped so that a degenerate L0 cannot make them infinite (L0 <= 0 keeps none);
 * rounded with offset r (history_dither) */
uint rel_pack(vec2 v, float l0, uint r)
{
    vec2 q = clamp(v * (l0 > 0.0 ? 1.0 / l0 : 0.0), -60000.0, 60000.0);
    return half_dither(q.x, r) | half_dither(q.y, r ^ 0x0aaau) << 16u;
}
vec2 rel_unpack(uint w, float l0) { return unpackHalf2x16(w) * l0; }
/* the same rounded to nearest */
uint rel_pack_nearest(vec2 v, float l0)
{
    return packHalf2x16(clamp(v * (l0 > 0.0 ? 1.0 / l0 : 0.0), -60000.0, 60000.0));
}

/* The lf history (DN_B_HIST_LF), one texel with all the lf reprojection and downsample need:
 * x L0 (float bits), y L1x, L1y and z L1z, the lf history length (half), w CoCg; L1 and CoCg
 * relative to L0 (rel_pack). The SH is (L1x, L1y, L1z, L0) as in the contract. */
uvec4 hist_lf_pack(vec4 sh, vec2 cocg, float len, uvec3 r)
{
    uint z = (rel_pack(vec2(sh.z, 0.0), sh.w, r.z) & 0xffffu) | packHalf2x16(vec2(0.0, len));
    return uvec4(floatBitsToUint(sh.w), rel_pack(sh.xy, sh.w, r.y), z, rel_pack(cocg, sh.w, r.x));
}
float hist_lf_l0(uvec4 t) { return uintBitsToFloat(t.x); }
vec4 hist_lf_sh(uvec4 t)
{
    float l0 = uintBitsToFloat(t.x);
    return vec4(rel_unpack(t.y, l0), rel_unpack(t.z, l0).x, l0);
}
vec2 hist_lf_cocg(uvec4 t) { return rel_unpack(t.w, uintBitsToFloat(t.x)); }
float hist_lf_len(uvec4 t) { return unpackHalf2x16(t.z).y; }

/* The lf filter's ping-pong is two texels per anchor: the SH (DN_B_AT_LF_SH) and this one
 * (DN_B_AT_LF): x the offset of the anchor's tangent plane from fgeo_origin() (float bits), y
 * its geometric normal (octahedral 12 + 12 bits) | 1 << 24 (0 where the stratum sees only
 * sky), z CoCg relative to L0 (rel_pack_nearest), w the variance of the anchor's
 * L0 (float bits: the noise left in the stratum's temporal histories, which the lf a-trous
 * stops its luminance weight at). A tap of the lf passes and of the upsample loads both and
 * nothing else (these passes are bound by their load count); each pass carries the geometry
 * words through. */
/* pos: relative to fgeo_origin() */
uvec4 lf_pack(bool valid, vec3 pos, vec3 n, vec2 cocg, float l0, float variance)
{
    if (!valid)
        return uvec4(0u);
    uint w = oct_pack12(n);
    return uvec4(floatBitsToUint(dot(oct_unpack12(w), pos)), w | 1u << 24u,
                 rel_pack_nearest(cocg, l0), floatBitsToUint(variance));
}
bool lf_valid_texel(uvec4 t) { return (t.y >> 24u) != 0u; }
vec3 lf_normal(uvec4 t) { return oct_unpack12(t.y); }
/* the distance of `pos` (relative to fgeo_origin()) to the anchor's tangent plane */
float lf_plane_distance(uvec4 t, vec3 pos)
{
    return abs(uintBitsToFloat(t.x) - dot(lf_normal(t), pos));
}
/* l0: the L0 of the same anchor's SH texel */
vec2 lf_cocg(uvec4 t, float l0) { return rel_unpack(t.z, l0); }
float lf_variance(uvec4 t) { return uintBitsToFloat(t.w); }
uvec4 lf_with(uvec4 t, vec2 cocg, float l0, float variance)
{
    return uvec4(t.xy, rel_pack_nearest(cocg, l0), floatBitsToUint(variance));
}

/* The a-trous ping-pong texel (DN_B_AT): hf, spec and the hf variance as tnd_uf16. */
/* tnd_uf16_decode of both halves of a word: the high half shifts right by 3 into place */
vec2 at_decode2(uint w)
{
    const float rebias = 39614081257132168796771975168.0; /* 2^(127 - TND_UF16_BIAS) = 2^95 */
    return uintBitsToFloat(uvec2((w & 0xffffu) << 13u, (w >> 3u) & 0x1fffe000u)) * rebias;
}
/* the rgb of a ping-pong or history texel (both keep it in words x, y) */
vec3 hist_rgb(uvec2 t) { return vec3(at_decode2(t.x), at_decode2(t.y).x); }
vec3 at_hf(uvec4 t) { return hist_rgb(t.xy); }
vec3 at_spec(uvec4 t) { return vec3(at_decode2(t.y).y, at_decode2(t.z)); }
float at_variance(uvec4 t) { return tnd_uf16_decode(t.w); }
/* the same times 2^-95 (no rebias): the a-trous taps work on these */
vec2 at_decode2_scaled(uint w)
{
    return uintBitsToFloat(uvec2((w & 0xffffu) << 13u, (w >> 3u) & 0x1fffe000u));
}
vec3 at_hf_scaled(uvec4 t) { return vec3(at_decode2_scaled(t.x), at_decode2_scaled(t.y).x); }
vec3 at_spec_scaled(uvec4 t) { return vec3(at_decode2_scaled(t.y).y, at_decode2_scaled(t.z)); }
float at_variance_scaled(uvec4 t) { return uintBitsToFloat((t.w & 0xffffu) << 13u); }
/* The packing side works on values so scaled, finite and >= 0 (tnd_uf16_encode_scaled: 6
 * operations per value instead of 14): UF16_SCALE * max(x, 0) for a finite x. */
const float UF16_SCALE = 1.0 / 39614081257132168796771975168.0; /* 2^(TND_UF16_BIAS - 127) */
/* r: rounding offsets (history_dither; uvec3(0x1000) rounds to nearest, as
 * tnd_uf16_encode_scaled) */
uvec4 at_pack_scaled(vec3 hf, vec3 spec, float variance, uvec3 r)
{
    uvec3 h = uvec3(tnd_uf16_encode_offset(hf.r, r.x), tnd_uf16_encode_offset(hf.g, r.y),
                    tnd_uf16_encode_offset(hf.b, r.z));
    uvec3 s = uvec3(tnd_uf16_encode_offset(spec.r, r.x), tnd_uf16_encode_offset(spec.g, r.y),
                    tnd_uf16_encode_offset(spec.b, r.z));
    return uvec4(h.x | h.y << 16u, h.z | s.x << 16u, s.y | s.z << 16u,
                 tnd_uf16_encode_offset(variance, r.x));
}
/* The histories of hf (DN_B_HIST_HF) and spec (DN_B_HIST_SPEC), one texel each, so that a
 * reprojection tap loads four texels (with the previous surface and the lf history), not five:
 * hf: x, y hf rgb as tnd_uf16 and the hf history length as a half float, zw the luminance
 * moments E[l], E[l^2] (float bits); spec (RG32UI): x, y spec rgb as tnd_uf16 and the spec
 * history length as a half float. tnd_uf16 keeps 2^-11 relative, as RGBA16F would (Q2RTX keeps
 * its hf history in RGBE); the rgb is scaled (UF16_SCALE) and rounded with the offsets r. */
uvec2 hist_rgb_pack_scaled(vec3 c, float len, uvec3 r)
{
    return uvec2(tnd_uf16_encode_offset(c.r, r.x) | tnd_uf16_encode_offset(c.g, r.y) << 16u,
                 tnd_uf16_encode_offset(c.b, r.z) | packHalf2x16(vec2(len, 0.0)) << 16u);
}
uvec4 hist_hf_pack_scaled(vec3 hf, float len, vec2 mom, uvec3 r)
{
    return uvec4(hist_rgb_pack_scaled(hf, len, r), floatBitsToUint(mom));
}
/* a history texel's length (its rgb: hist_rgb) */
float hist_len(uvec2 t) { return unpackHalf2x16(t.y >> 16u).x; }
float luma(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }
/* The raw luminances kept for the next frame's gradients (DN_B_PREV_LUM), and their values as
 * the selection and the gradient read them: tnd_uf16, 2^-11 relative, both sides of a gradient
 * rounded alike (an unchanged sample gives 0 exactly). */
uint prev_lum_pack(float hf, float spec)
{
    return tnd_uf16_encode(hf) | tnd_uf16_encode(spec) << 16u;
}
vec2 prev_lum_unpack(uint w) { return at_decode2(w); }
float lum_rounded(float l) { return tnd_uf16_decode(tnd_uf16_encode(l)); }

bool inside(ivec2 p) { return all(greaterThanEqual(p, ivec2(0))) && p.x < int(P.size.x) && p.y < int(P.size.y); }

/* Sanitise what enters a history: NaN/Inf never do (they would spread forever). */
vec3 finite3(vec3 v)
{
    return vec3(tnd_nonfinite(v.x) ? 0.0 : v.x, tnd_nonfinite(v.y) ? 0.0 : v.y,
                tnd_nonfinite(v.z) ? 0.0 : v.z);
}
vec4 finite4(vec4 v) { return vec4(finite3(v.xyz), tnd_nonfinite(v.w) ? 0.0 : v.w); }
/* The diffuse lobe's view factor, 1 - F(n.v), that the contract's hf and lf carry (its
 * diffuse_view entry): the back-end divides it out where it reads them and the composite
 * multiplies it back, so that the histories hold what does not change with the view and a
 * moving camera's view of a surface does not lag (docs/denoise.md, "The diffuse lobe's view
 * factor"). 1 where absent (captures from before contract version 4) or not finite. */
float diffuse_view(ivec2 p)
{
    float v = imageLoad(img_diffuse_view, p).x;
    return v >= 0.0 ? clamp(v, 1e-3, 1.0) : 1.0;
}
