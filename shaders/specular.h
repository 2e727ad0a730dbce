/* Perfect specular interfaces (mirror, thin glass, glass with a volume), as scalar functions
 * shared by C and GLSL so that both front-ends take the same decisions with the same numbers.
 *
 * - Dielectric Fresnel, exact for unpolarised light: with eta = n_t / n_i and cos_i the cosine
 *   on the incident side, sin_t^2 = (1 - cos_i^2) / eta^2; total internal reflection when
 *   sin_t^2 >= 1 (F = 1: all the energy goes to the reflection, once). Otherwise
 *   r_s = (cos_i - eta cos_t) / (cos_i + eta cos_t), r_p = (eta cos_i - cos_t) / (eta cos_i +
 *   cos_t), F = (r_s^2 + r_p^2) / 2.
 * - Glass with a volume: reflect with probability F, refract with 1 - F (weight F / F = 1 and
 *   (1 - F) / (1 - F) = 1); inside, Beer-Lambert: throughput x exp(-sigma_a d), sigma_a =
 *   -ln(attenuation colour) / attenuation distance (KHR_materials_volume).
 * - Thin glass (no volume): the two interfaces of a thin slab with multiple reflections,
 *   R = 2F / (1 + F), T = 1 - R, the transmitted ray not bent.
 * - Mirror (metallic, roughness below TND_MIRROR_ROUGHNESS): reflection weighted by Schlick's
 *   Fresnel with F0 = base colour.
 * Radiance is not scaled by eta^2 across an interface: the factors of entering and leaving a
 * closed object cancel, and the estimator never ends a path inside glass on a light.
 *
 * The reflect/refract choice draws TND_DIM_SPLIT of the vertex (sampling.h); the real-time
 * front-ends replace that draw by the checkerboard split where a surface both reflects and
 * refracts (docs/specular.md). */
#ifndef TND_SPECULAR_H
#define TND_SPECULAR_H

#include "brdf.h" /* TND_FN, TND_SQRTF */

#ifdef TND_GLSL
#define TND_SP_UINT uint
#define TND_SP_INOUT_BOOL out bool
#define TND_SP_SET(p, v) p = (v)
#else
#include <stdbool.h>
#include <stdint.h>
#define TND_SP_UINT uint32_t
#define TND_SP_INOUT_BOOL bool *
#define TND_SP_SET(p, v) (*(p) = (v))
#endif

/* material kinds on the GPU (tnd_material_kind's values) */
#define TND_KIND_OPAQUE 0u
#define TND_KIND_MIRROR 1u
#define TND_KIND_THIN_GLASS 2u
#define TND_KIND_GLASS 3u

/* events */
#define TND_EVENT_REFLECT 0u
#define TND_EVENT_REFRACT 1u  /* glass: into or out of the volume, bent */
#define TND_EVENT_TRANSMIT 2u /* thin glass: straight through */

/* longest chain of specular vertices a path follows (beyond it the path ends: black) */
#define TND_MAX_SPECULAR_DEPTH 16u

/* cos_t of the refracted direction, or -1 on total internal reflection */
TND_FN float tnd_refract_cos(float cos_i, float eta)
{
    float s2 = (1.0f - cos_i * cos_i) / (eta * eta);
    if (s2 >= 1.0f)
        return -1.0f;
    return TND_SQRTF(1.0f - s2);
}

TND_FN float tnd_fresnel_dielectric(float cos_i, float eta)
{
    float cos_t = tnd_refract_cos(cos_i, eta);
    if (cos_t < 0.0f)
        return 1.0f;
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5f * (rs * rs + rp * rp);
}

/* reflectance of a thin slab from the single-interface F */
TND_FN float tnd_thin_reflectance(float F)
{
    return 2.0f * F / (1.0f + F);
}

/* The event at a dielectric vertex: kind (thin or volume glass), whether the ray arrives on the
 * front side, cos_i (> 0, on the incident side), the material's IOR, and u in [0, 1). With
 * TIR, F = 1 and u < 1 always reflects: the whole energy once, never counted again. */
TND_FN TND_SP_UINT tnd_dielectric_event(TND_SP_UINT kind, bool front, float cos_i, float ior, float u)
{
    float eta = kind == TND_KIND_THIN_GLASS ? ior : (front ? ior : 1.0f / ior);
    float F = tnd_fresnel_dielectric(cos_i, eta);
    if (kind == TND_KIND_THIN_GLASS)
        return u < tnd_thin_reflectance(F) ? TND_EVENT_REFLECT : TND_EVENT_TRANSMIT;
    return u < F ? TND_EVENT_REFLECT : TND_EVENT_REFRACT;
}

/* Schlick's Fresnel of one channel of a mirror (F0 = base colour) */
TND_FN float tnd_mirror_fresnel(float f0, float cos_i)
{
    float m = 1.0f - cos_i;
    float m2 = m * m;
    return f0 + (1.0f - f0) * m2 * m2 * m;
}

/* The real-time reflect/refract chain (the primary pass): at most this many specular vertices
 * between the camera and the surface the G-buffer shows. */
#define TND_REFLECT_DEPTH 4u

/* The chain's event at a dielectric. The first surface on the chain that both reflects and
 * refracts (0 < F < 1) splits the pixels into two fields (checkerboard): `field` 0 (even x + y)
 * takes the reflection with weight 2F, field 1 the refraction with 2(1 - F); *split tells that
 * it happened (the caller passes `may_split` false afterwards). At later surfaces the chain
 * refracts with 1 - F (the reflection there is not followed: a bias of F per extra interface,
 * docs/specular.md). Total internal reflection: reflection, weight 1, in both fields. Returns
 * the weight; *is_reflect tells the event. */
TND_FN float tnd_chain_dielectric(TND_SP_UINT kind, bool front, float cos_i, float ior,
                                  bool may_split, TND_SP_UINT field,
                                  TND_SP_INOUT_BOOL is_reflect, TND_SP_INOUT_BOOL split)
{
    float eta = kind == TND_KIND_THIN_GLASS ? ior : (front ? ior : 1.0f / ior);
    float F = tnd_fresnel_dielectric(cos_i, eta);
    if (kind == TND_KIND_THIN_GLASS)
        F = tnd_thin_reflectance(F);
    bool tir = F >= 1.0f;
    bool sp = may_split && !tir && F > 0.0f;
    TND_SP_SET(split, sp);
    TND_SP_SET(is_reflect, tir || (sp && field == 0u));
    if (tir)
        return 1.0f;
    if (sp)
        return field == 0u ? 2.0f * F : 2.0f * (1.0f - F);
    return 1.0f - F;
}

#endif
