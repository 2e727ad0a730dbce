/* The material model, as scalar functions shared by C and GLSL so that both front-ends evaluate
 * the same estimator (vector code around them is written once per language).
 *
 * glTF metal-rough: F0 = mix(0.04 x specular, base colour, metallic); GGX distribution with
 * alpha = roughness^2 (clamped to TND_MIN_ALPHA, so roughness 0 stays finite); height-correlated
 * Smith masking-shadowing (Heitz 2014, "Understanding the masking-shadowing function");
 * Schlick's Fresnel. Diffuse: Lambert x (1 - F(n.v)) x (1 - metallic), albedo demodulated in the
 * contract. References: Walter et al. 2007 (GGX), Heitz 2018 (VNDF sampling, in each front-end). */
#ifndef TND_BRDF_H
#define TND_BRDF_H

#ifndef TND_FN
#ifdef TND_GLSL
#define TND_FN
#else
#define TND_FN static inline
#endif
#endif
#ifdef TND_GLSL
#define TND_SQRTF(x) sqrt(x)
#define TND_F(x) float(x)
#else
#include <math.h>
#define TND_SQRTF(x) sqrtf(x)
#define TND_F(x) ((float)(x))
#endif

#define TND_MIN_ALPHA 1.0e-3
#define TND_INV_PI 0.31830988618379067

/* GGX normal distribution D(h) for cos(n, h) = nh and alpha^2 = a2. */
TND_FN float tnd_ggx_d(float nh, float a2)
{
    float d = nh * nh * (a2 - 1.0f) + 1.0f;
    return a2 * TND_F(TND_INV_PI) / (d * d);
}

/* Smith Lambda for GGX, from cos(n, w). */
TND_FN float tnd_smith_lambda(float nw, float a2)
{
    float c2 = nw * nw;
    float t2 = (1.0f - c2) / (c2 > 1e-12f ? c2 : 1e-12f);
    return 0.5f * (-1.0f + TND_SQRTF(1.0f + a2 * t2));
}

/* Height-correlated G2(v, l) and the separable G1(v). */
TND_FN float tnd_smith_g2(float nv, float nl, float a2)
{
    return 1.0f / (1.0f + tnd_smith_lambda(nv, a2) + tnd_smith_lambda(nl, a2));
}
TND_FN float tnd_smith_g1(float nv, float a2)
{
    return 1.0f / (1.0f + tnd_smith_lambda(nv, a2));
}

/* Schlick Fresnel for one channel. */
TND_FN float tnd_schlick(float f0, float c)
{
    float m = 1.0f - c;
    m = m < 0.0f ? 0.0f : m; /* one select per statement: the C front-end's lane loops */
    m = m > 1.0f ? 1.0f : m; /* vectorise only two-way choices */
    float m2 = m * m;
    return f0 + (1.0f - f0) * m2 * m2 * m;
}

/* Fresnel of the glTF material for one channel at cos c: the dielectric part scaled by
 * KHR_materials_specular's factor (which scales the whole Fresnel term, so specular 0 is pure
 * Lambert), the metallic part with F0 = base colour. */
TND_FN float tnd_fresnel(float metallic, float specular, float base, float c)
{
    return (1.0f - metallic) * specular * tnd_schlick(0.04f, c) + metallic * tnd_schlick(base, c);
}

/* Specular BRDF x cos(n, l) without F: D G2 / (4 nv) (one of the cosines cancels). */
TND_FN float tnd_ggx_spec_cos(float nh, float nv, float nl, float a2)
{
    return tnd_ggx_d(nh, a2) * tnd_smith_g2(nv, nl, a2) / (4.0f * nv);
}

/* pdf of a VNDF-sampled direction l (solid angle): D_v(h) / (4 v.h) = G1(v) D(h) / (4 nv). */
TND_FN float tnd_ggx_vndf_pdf(float nh, float nv, float a2)
{
    return tnd_smith_g1(nv, a2) * tnd_ggx_d(nh, a2) / (4.0f * nv);
}

/* Power heuristic (beta = 2) weight of technique a against b. */
TND_FN float tnd_mis_power(float pa, float pb)
{
    float a2 = pa * pa, b2 = pb * pb;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* Luminance of linear sRGB (Rec. 709 weights). */
TND_FN float tnd_luminance(float r, float g, float b)
{
    return 0.2126f * r + 0.7152f * g + 0.0722f * b;
}

/* Lobe choice: probability of the specular lobe from the luminances of the Fresnel-weighted
 * specular and diffuse weights; 1 when there is no diffuse, kept within [0.1, 0.9] otherwise so
 * that neither lobe starves. */
TND_FN float tnd_spec_probability(float lum_f, float lum_diffuse)
{
    float p = lum_f / (lum_f + lum_diffuse); /* (unused when it divides by 0) */
    p = p < 0.1f ? 0.1f : p;
    p = p > 0.9f ? 0.9f : p;
    p = lum_f <= 0.0f ? 0.0f : p;
    return lum_diffuse <= 0.0f ? 1.0f : p;
}

#endif
