/* The buffer contract: every buffer a front-end fills and the back-end reads, written once.
 *
 * Compiles as C11 and as GLSL (TND_GLSL). docs/contract.md documents every entry and the
 * conventions; tests/test_contract.c checks that document against this table.
 *
 * Conventions (docs/contract.md says more):
 * - flat layout, W x H, pixel (0,0) at the top left, pixel centres at +0.5;
 * - world space, right-handed, glTF units (metres by convention);
 * - depth: distance from the camera position to the primary hit along the primary ray (not
 *   planar z); TND_DEPTH_MISS where the primary ray escapes;
 * - motion: previous minus current: xy = previous pixel position - current pixel position, in
 *   pixels; z = previous depth - current depth;
 * - normals: world space, unit length, facing the incoming primary ray;
 * - hf: direct diffuse irradiance times (1 - F) / pi, albedo demodulated (radiance units);
 * - lf: indirect diffuse as L1 spherical harmonics of luma Y (L1x, L1y, L1z, L0 in that order)
 *   plus raw chroma Co/Cg (YCoCg), albedo demodulated;
 * - spec: specular radiance / max(0.01, F0) per channel, F0 = mix(0.04, albedo, metallic).
 *
 * X(ID, binding, name, comps, kind, pack, vk_f32, vk_packed, glsl_f32, glsl_packed, exr_layer,
 *   (exr_channels...), need, default_value, semantic, unit, space)
 *  kind: FLOAT or UINT; pack: how the packed precision stores it (F32 keeps float32);
 *  need: REQUIRED (a capture must feed it), DEFAULT (absent = default_value), DERIVED
 *  (absent = computed from other entries, see docs/contract.md). */
#ifndef TND_CONTRACT_H
#define TND_CONTRACT_H

// clang-format off
#define TND_CONTRACT(X) \
    X(ALBEDO,     0, albedo,     3, FLOAT, HALF, R32G32B32A32_SFLOAT, R16G16B16A16_SFLOAT, rgba32f, rgba16f, "albedo",     ("R", "G", "B"),          REQUIRED, 0.0, "base colour of the primary surface (glTF baseColor x texture), before metallic", "reflectance [0,1]", "linear sRGB primaries") \
    X(NORMAL,     1, normal,     3, FLOAT, HALF, R32G32B32A32_SFLOAT, R16G16B16A16_SFLOAT, rgba32f, rgba16f, "normal",     ("X", "Y", "Z"),          REQUIRED, 0.0, "shading normal (normal-mapped), facing the primary ray", "unit vector", "world") \
    X(GEO_NORMAL, 2, geo_normal, 3, FLOAT, HALF, R32G32B32A32_SFLOAT, R16G16B16A16_SFLOAT, rgba32f, rgba16f, "geo_normal", ("X", "Y", "Z"),          DERIVED,  0.0, "geometric (flat triangle) normal, facing the primary ray", "unit vector", "world") \
    X(POSITION,   3, position,   3, FLOAT, F32,  R32G32B32A32_SFLOAT, R32G32B32A32_SFLOAT, rgba32f, rgba32f, "position",   ("X", "Y", "Z"),          DERIVED,  0.0, "primary hit position", "scene units", "world") \
    X(DEPTH,      4, depth,      1, FLOAT, F32,  R32_SFLOAT,          R32_SFLOAT,          r32f,    r32f,    "depth",      ("Z"),              REQUIRED, 0.0, "distance from the camera to the primary hit along the ray; TND_DEPTH_MISS on a miss", "scene units", "camera") \
    X(MOTION,     5, motion,     3, FLOAT, HALF, R32G32B32A32_SFLOAT, R16G16B16A16_SFLOAT, rgba32f, rgba16f, "motion",     ("X", "Y", "Z"),          REQUIRED, 0.0, "previous minus current: xy pixel position, z depth", "pixels (xy), scene units (z)", "screen") \
    X(ROUGHNESS,  6, roughness,  1, FLOAT, HALF, R32_SFLOAT,          R16_SFLOAT,          r32f,    r16f,    "roughness",  ("V"),              DEFAULT,  1.0, "perceptual roughness (glTF), GGX alpha = roughness^2", "[0,1]", "-") \
    X(METALLIC,   7, metallic,   1, FLOAT, HALF, R32_SFLOAT,          R16_SFLOAT,          r32f,    r16f,    "metallic",   ("V"),              DEFAULT,  0.0, "metalness (glTF)", "[0,1]", "-") \
    X(EMISSION,   8, emission,   3, FLOAT, HALF, R32G32B32A32_SFLOAT, R16G16B16A16_SFLOAT, rgba32f, rgba16f, "emission",   ("R", "G", "B"),          DEFAULT,  0.0, "radiance emitted by the primary surface towards the camera (sky radiance on a miss)", "radiance", "linear sRGB primaries") \
    X(VIS_ID,     9, vis_id,     2, UINT,  F32,  R32G32_UINT,         R32G32_UINT,         rg32ui,  rg32ui,  "vis",        ("instance", "primitive"), DERIVED, 4294967295.0, "visibility buffer: instance index and triangle index in its mesh; TND_VIS_NONE on a miss (absent: (0, 0) where depth is a hit)", "index", "scene") \
    X(VIS_BARY,  10, vis_bary,   2, FLOAT, F32,  R32G32_SFLOAT,       R32G32_SFLOAT,       rg32f,   rg32f,   "vis",        ("u", "v"),            DEFAULT,  0.0, "barycentrics (b1, b2) of the primary hit; b0 = 1 - u - v", "[0,1]", "triangle") \
    X(THROUGHPUT,11, throughput, 3, FLOAT, HALF, R32G32B32A32_SFLOAT, R16G16B16A16_SFLOAT, rgba32f, rgba16f, "throughput", ("R", "G", "B"),          DEFAULT,  1.0, "primary path throughput from the camera to the G-buffer surface", "[0,1] per channel", "-") \
    X(RNG,       12, rng,        2, UINT,  F32,  R32G32_UINT,         R32G32_UINT,         rg32ui,  rg32ui,  "rng",        ("frame", "pixel"),    DEFAULT,  4294967295.0, "random-number key of the pixel's samples: frame index and pixel index y*W+x (a gradient sample carries the previous frame's key)", "index", "-") \
    X(HF,        13, hf,         3, FLOAT, RGBE, R32G32B32A32_SFLOAT, R32_UINT,            rgba32f, r32ui,   "hf",         ("R", "G", "B"),          REQUIRED, 0.0, "direct diffuse: irradiance x (1 - F) / pi, albedo demodulated", "radiance", "linear sRGB primaries") \
    X(LF_SH,     14, lf_sh,      4, FLOAT, HALF, R32G32B32A32_SFLOAT, R16G16B16A16_SFLOAT, rgba32f, rgba16f, "lf",         ("L1x", "L1y", "L1z", "L0"), DEFAULT,  0.0, "indirect diffuse luma Y as L1 spherical harmonics (L1 band xyz, L0), albedo demodulated", "radiance", "world (SH directions)") \
    X(LF_COCG,   15, lf_cocg,    2, FLOAT, HALF, R32G32_SFLOAT,       R16G16_SFLOAT,       rg32f,   rg16f,   "lf",         ("Co", "Cg"),          DEFAULT,  0.0, "indirect diffuse chroma (YCoCg), albedo demodulated", "radiance", "linear sRGB primaries") \
    X(SPEC,      16, spec,       3, FLOAT, RGBE, R32G32B32A32_SFLOAT, R32_UINT,            rgba32f, r32ui,   "spec",       ("R", "G", "B"),          DEFAULT,  0.0, "specular radiance divided by max(0.01, F0) per channel", "radiance", "linear sRGB primaries") \
    X(PATH,      17, path,       1, UINT,  F32,  R32_UINT,            R32_UINT,            r32ui,   r32ui,   "path",       ("flags"),             DEFAULT,  0.0, "how the primary ray reached the surface: bit 0 a surface that reflects and refracts split the pixels (checkerboard), bit 1 this pixel took the refraction (odd field), bit 2 a mirror reflected it, bit 3 it went through glass", "bits", "-") \
    X(SPEC_HIT,  18, spec_hit,   1, FLOAT, F32,  R32_SFLOAT,          R32_SFLOAT,          r32f,    r32f,    "spec",       ("hitT"),              DEFAULT,  0.0, "distance from the primary hit to the first hit of this frame's specular-lobe sample (the reflection's depth; denoisers reproject reflections by it); 0 where the sample took the diffuse lobe or none was traced, TND_DEPTH_MISS where it escaped", "scene units", "-") \
    X(DIFFUSE_VIEW, 19, diffuse_view, 1, FLOAT, HALF, R32_SFLOAT,       R16_SFLOAT,          r32f,    r16f,    "diffuse",    ("view"),              DEFAULT,  1.0, "the diffuse lobe's view factor at the primary hit, 1 - F(n.v) (the luminance of its per-channel value), which hf and lf carry: the back-end divides it out of its histories and multiplies it back; 1 where no surface", "[0,1]", "-")
// clang-format on

/* path flags (the PATH entry) */
#define TND_PATH_SPLIT 1u   /* the chain met a surface that both reflects and refracts: split */
#define TND_PATH_REFRACT 2u /* this pixel's field took the refraction (odd (x + y)) */
#define TND_PATH_MIRROR 4u  /* reflected by a mirror */
#define TND_PATH_GLASS 8u   /* went through glass */

/* Sentinels. TND_DEPTH_MISS is finite so that every stored value is finite. */
#define TND_DEPTH_MISS       1.0e30
#define TND_VIS_NONE         0xFFFFFFFFu
#define TND_CONTRACT_VERSION 4

#ifdef TND_GLSL
/* GLSL: one storage image per entry, binding = entry index, in set TND_CONTRACT_SET (which the
 * including shader defines), format chosen by TND_PACKED (0: float32, 1: packed). */
#define TND_CT_IMGTYPE_FLOAT_F32  image2D
#define TND_CT_IMGTYPE_FLOAT_HALF image2D
#define TND_CT_IMGTYPE_FLOAT_RGBE uimage2D
#define TND_CT_IMGTYPE_UINT_F32   uimage2D
#if TND_PACKED
#define TND_CT_DECLARE(ID, bind, name, comps, kind, pack, vk32, vkp, g32, gp, layer, chans, need,  \
                       def, sem, unit, space)                                                      \
    layout(set = TND_CONTRACT_SET, binding = bind, gp)                                             \
        uniform TND_CT_IMGTYPE_##kind##_##pack img_##name;
#else
#define TND_CT_DECLARE(ID, bind, name, comps, kind, pack, vk32, vkp, g32, gp, layer, chans, need,  \
                       def, sem, unit, space)                                                      \
    layout(set = TND_CONTRACT_SET, binding = bind, g32)                                            \
        uniform TND_CT_IMGTYPE_##kind##_F32 img_##name;
#endif
#else
/* C: the enum; the rest of the table's uses live in core/contract.c. */
typedef enum tnd_ct {
#define TND_CT_ENUM(ID, bind, ...) TND_CT_##ID = bind,
    TND_CONTRACT(TND_CT_ENUM)
#undef TND_CT_ENUM
} tnd_ct;
#define TND_CT_COUNT_(ID, bind, ...) +1
enum { TND_CT_COUNT = 0 TND_CONTRACT(TND_CT_COUNT_) };
#undef TND_CT_COUNT_
#endif

#endif
