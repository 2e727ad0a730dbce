/* post_tonemap.comp: linear HDR (after TAA, with bloom mixed in) to display: x exposure (the
 * exposure pass), a curve (ACES fit of Narkowicz 2015, an AgX-style sigmoid in log2 space with
 * its inset / outset matrices, Reinhard on luminance, or a plain clamp), the sRGB transfer
 * function, and a triangular dither of +-1 8-bit step (no banding in smooth gradients; 0 and 1
 * are left exact). NaN or
 * Inf input gives black; output in [0, 1]. */
#version 460
#extension GL_GOOGLE_include_directive : require
#include "post_common.glsl"
#include "sampling.h"

vec3 aces_fit(vec3 x)
{
    return clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

/* AgX-style: inset matrix, log2 encoding over [-12.47, 4.03] stops around 0.18, a polynomial
 * sigmoid (the community fit of AgX's default contrast), outset matrix, back to linear */
vec3 agx(vec3 c)
{
    const mat3 inset = mat3(0.842479062253094, 0.0423282422610123, 0.0423756549057051,
                            0.0784335999999992, 0.878468636469772, 0.0784336,
                            0.0792237451477643, 0.0791661274605434, 0.879142973793104);
    const mat3 outset = mat3(1.19687900512017, -0.0528968517574562, -0.0529716355144438,
                             -0.0980208811401368, 1.15190312990417, -0.0980434501171241,
                             -0.0990297440797205, -0.0989611768448433, 1.15107367264116);
    const float lo = -12.47393, hi = 4.026069;
    vec3 x = inset * c;
    x = clamp((log2(max(x, vec3(1e-10))) - lo) / (hi - lo), 0.0, 1.0);
    vec3 x2 = x * x, x4 = x2 * x2;
    x = 15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x -
        0.00232;
    x = outset * x;
    return clamp(pow(max(x, vec3(0.0)), vec3(2.2)), 0.0, 1.0);
}

vec3 reinhard(vec3 c)
{
    float l = luma(c);
    return l > 0.0 ? clamp(c * (1.0 / (1.0 + l)), 0.0, 1.0) : vec3(0.0);
}

float srgb_oetf(float v)
{
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

vec3 bloom_at(ivec2 p)
{
    /* bilinear from the 1/4-res blur (texel centres at 4i + 2) */
    ivec2 qs = (img_size() + 3) / 4;
    vec2 x = (vec2(p) + 0.5) / 4.0 - 0.5;
    ivec2 b = ivec2(floor(x));
    vec2 f = x - vec2(b);
    vec3 s = vec3(0.0);
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            ivec2 q = clamp(b + ivec2(i, j), ivec2(0), qs - 1);
            s += (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y) * imageLoad(bloom[0], q).rgb;
        }
    return finite_or_zero(s);
}

void main()
{
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (!inside(p))
        return;
    vec3 c = load_hdr(p);
    if ((P.size.w & CP_F_BLOOM) != 0u)
        c = mix(c, bloom_at(p), P.bloom.x);
    c *= H.exposure;
    uint curve = uint(P.tm.x);
    c = curve == CP_CURVE_ACES ? aces_fit(c)
      : curve == CP_CURVE_AGX ? agx(c)
      : curve == CP_CURVE_REINHARD ? reinhard(c) : clamp(c, 0.0, 1.0);
    c = finite_or_zero(c);
    vec3 o = vec3(srgb_oetf(c.r), srgb_oetf(c.g), srgb_oetf(c.b));
    if ((P.size.w & CP_F_DITHER) != 0u) {
        uvec3 h = tnd_pcg3d(uvec3(uint(p.x), uint(p.y), P.size.z));
        vec2 u = vec2(h.xy >> 8u) * (1.0 / 16777216.0);
        float d = (u.x + u.y - 1.0) / 255.0; /* triangular, +-1 step */
        /* pure black and white stay exact */
        o = mix(o, o + d, vec3(greaterThan(o, vec3(0.0))) * vec3(lessThan(o, vec3(1.0))));
    }
    imageStore(display, p, vec4(clamp(o, 0.0, 1.0), 1.0));
}
