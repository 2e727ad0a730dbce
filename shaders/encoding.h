/* Value encodings shared by C and GLSL: sanitising, the packed-contract RGBE format, and (C only)
 * IEEE half floats.
 *
 * RGBE 9-9-9-5 ("tnd_rgbe"): bits 0-8, 9-17, 18-26 hold the R, G, B mantissas, bits 27-31 the
 * shared exponent E with bias TND_RGBE_BIAS; a channel decodes to m * 2^(E - BIAS - 8). Unlike
 * Q2RTX's packer, values are clamped to [0, TND_RGBE_MAX] *before* the exponent is chosen, so
 * nothing decodes to a wrong power of two; NaN and -Inf encode as 0, +Inf as TND_RGBE_MAX.
 * Error bounds (tests/test_contract.c checks them over 1e-6 .. 1e6):
 *   - the largest channel m in [2^-BIAS, TND_RGBE_MAX]: relative error <= 2^-9 (0.196%);
 *   - below 2^-BIAS: absolute error <= 2^-(BIAS+9) (5.96e-8 for BIAS 15);
 *   - other channels of the pixel: absolute error <= 2^-9 x the largest channel;
 *   - above TND_RGBE_MAX (130816): clamped (saturation is counted by the stability report).
 * Unsigned wide half ("tnd_uf16"; the back-end's a-trous colours and variance, whose range
 * must cover the extremes scene's lights of 1e-4 and 1e5): 16 bits per channel, a 6-bit
 * exponent E with bias TND_UF16_BIAS and a 10-bit mantissa m: (1 + m / 1024) * 2^(E - BIAS),
 * code 0 is zero (E = 0 is never produced otherwise). Rounded to nearest (ties away from zero),
 * negatives and NaN -> 0, values above TND_UF16_MAX (and +Inf) -> TND_UF16_MAX, below
 * 2^(1 - BIAS) -> 0.
 *   - in [2^(1 - BIAS), TND_UF16_MAX] (4.7e-10 .. 4.3e9): relative error <= 2^-11;
 *   - below: absolute error < 2^(1 - BIAS).
 * Half (C side; GLSL uses the image format's own conversion): round to nearest even, clamped to
 * +-65504 first (never Inf), NaN -> 0. Relative error <= 2^-11 in [6.1e-5, 65504]; below,
 * absolute error <= 2^-25.
 *
 * Both languages use only exact operations (bit manipulation, multiplication by powers of two,
 * floor(x + 0.5) on values whose sum is exact), so C and GLSL produce identical bits. */
#ifndef TND_ENCODING_H
#define TND_ENCODING_H

#define TND_RGBE_BIAS 15
#define TND_RGBE_MAX  130816.0 /* 511 * 2^(31 - BIAS - 8) */
#define TND_HALF_MAX  65504.0
#define TND_UF16_BIAS 32
#define TND_UF16_MAX  4292870144.0 /* (2 - 2^-10) * 2^(63 - BIAS) */

#ifdef TND_GLSL
#define TND_FN
#define TND_U32             uint
#define TND_I32             int
#define TND_F2U(x)          floatBitsToUint(x)
#define TND_U2F(x)          uintBitsToFloat(x)
#define TND_TOU(x)          uint(x)
#define TND_TOI(x)          int(x)
#define TND_FLOORF(x)       floor(x)
#define TND_MINF(a, b)      min(a, b)
#define TND_MAXF(a, b)      max(a, b)
#define TND_MINU(a, b)      min(a, b)
#define TND_MAXU(a, b)      max(a, b)
#define TND_CLAMPI(x, a, b) clamp(x, a, b)
#define TND_FLT(x)          float(x)
#else
#include <stdbool.h>
#include <stdint.h>
#include <string.h>
#define TND_FN              static inline
#define TND_U32             uint32_t
#define TND_I32             int32_t
static inline uint32_t tnd_f2u_(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}
static inline float tnd_u2f_(uint32_t u)
{
    float f;
    memcpy(&f, &u, 4);
    return f;
}
static inline float tnd_minf_(float a, float b)
{
    return a < b ? a : b;
}
static inline float tnd_maxf_(float a, float b)
{
    return a > b ? a : b;
}
static inline uint32_t tnd_maxu_(uint32_t a, uint32_t b)
{
    return a > b ? a : b;
}
static inline int32_t tnd_clampi_(int32_t x, int32_t a, int32_t b)
{
    return x < a ? a : x > b ? b : x;
}
#define TND_F2U(x)          tnd_f2u_(x)
#define TND_U2F(x)          tnd_u2f_(x)
#define TND_TOU(x)          ((uint32_t)(x))
#define TND_TOI(x)          ((int32_t)(x))
#define TND_FLOORF(x)       floorf(x)
#define TND_MINF(a, b)      tnd_minf_(a, b)
#define TND_MAXF(a, b)      tnd_maxf_(a, b)
#define TND_MAXU(a, b)      tnd_maxu_(a, b)
#define TND_CLAMPI(x, a, b) tnd_clampi_(x, a, b)
#define TND_FLT(x)          ((float)(x))
#include <math.h>
#endif

/* True for NaN and +-Inf, by the bits (immune to fast-math assumptions). */
TND_FN bool tnd_nonfinite(float x)
{
    return (TND_F2U(x) & 0x7f800000u) == 0x7f800000u;
}

/* NaN -> 0, +-Inf -> +-lim, and clamp to [-lim, lim]. */
TND_FN float tnd_sanitize(float x, float lim)
{
    TND_U32 u = TND_F2U(x);
    if ((u & 0x7f800000u) == 0x7f800000u)
        return (u & 0x007fffffu) != 0u ? 0.0f : ((u >> 31) != 0u ? -lim : lim);
    return TND_MAXF(-lim, TND_MINF(x, lim));
}

/* 2^k as a float, exact for k in [-126, 127]. */
TND_FN float tnd_exp2i(TND_I32 k)
{
    return TND_U2F(TND_TOU(k + 127) << 23);
}

TND_FN TND_U32 tnd_rgbe_encode(float r, float g, float b)
{
    const float lim = TND_FLT(TND_RGBE_MAX);
    r = TND_MAXF(tnd_sanitize(r, lim), 0.0f);
    g = TND_MAXF(tnd_sanitize(g, lim), 0.0f);
    b = TND_MAXF(tnd_sanitize(b, lim), 0.0f);
    float m = TND_MAXF(r, TND_MAXF(g, b));
    if (m <= 0.0f)
        return 0u;
    /* floor(log2(m)) from the exponent bits; denormal m gives -127 and clamps to E = 0. */
    TND_I32 e = TND_TOI((TND_F2U(m) >> 23) & 0xffu) - 127;
    TND_I32 E = TND_CLAMPI(e + TND_RGBE_BIAS, 0, 31);
    float s = tnd_exp2i(8 - (E - TND_RGBE_BIAS));
    TND_U32 mr = TND_TOU(TND_FLOORF(r * s + 0.5f));
    TND_U32 mg = TND_TOU(TND_FLOORF(g * s + 0.5f));
    TND_U32 mb = TND_TOU(TND_FLOORF(b * s + 0.5f));
    if (TND_MAXU(mr, TND_MAXU(mg, mb)) > 511u) { /* rounding carried into the next exponent */
        E += 1;
        s = tnd_exp2i(8 - (E - TND_RGBE_BIAS));
        mr = TND_TOU(TND_FLOORF(r * s + 0.5f));
        mg = TND_TOU(TND_FLOORF(g * s + 0.5f));
        mb = TND_TOU(TND_FLOORF(b * s + 0.5f));
    }
    return mr | (mg << 9) | (mb << 18) | (TND_TOU(E) << 27);
}

/* Channel c (0 R, 1 G, 2 B) of a packed value. */
TND_FN float tnd_rgbe_channel(TND_U32 p, TND_I32 c)
{
    TND_I32 E = TND_TOI(p >> 27);
    TND_U32 m = (p >> TND_TOU(9 * c)) & 511u;
    return TND_FLT(m) * tnd_exp2i(E - TND_RGBE_BIAS - 8);
}

TND_FN TND_U32 tnd_uf16_encode(float x)
{
    TND_U32 u = TND_F2U(TND_MAXF(tnd_sanitize(x, TND_FLT(TND_UF16_MAX)), 0.0f)) + 0x1000u;
    TND_I32 e = TND_TOI(u >> 23) - 127 + TND_UF16_BIAS; /* the rounding may carry into it */
    if (e <= 0)
        return 0u;
    if (e > 63)
        return 0xffffu;
    return (TND_TOU(e) << 10) | ((u >> 13) & 1023u);
}

/* The 16 bits shifted into a float's exponent and mantissa give (1 + m / 1024) * 2^(E - 127);
 * one exact multiplication by 2^(127 - BIAS) rebiases it (3 operations: the a-trous decodes 7
 * channels per tap). Code 0 decodes to 0; codes with E = 0 and m != 0 are never produced (they
 * would decode to a denormal, which a GPU may flush). */
TND_FN float tnd_uf16_decode(TND_U32 h)
{
    return TND_U2F((h & 0xffffu) << 13) * tnd_exp2i(127 - TND_UF16_BIAS);
}

/* tnd_uf16_encode(x) given xs = x * 2^(BIAS - 127), finite and >= 0 (-0 included; the a-trous
 * keeps its sums at that scale, decoding without the rebias): xs's float bits are the code's,
 * shifted by 13; 0 below the smallest code (xs below FLT_MIN), the largest code above it. 6
 * operations instead of 14. Rounding: `offset` in [0, 2^13) is added before the truncation;
 * 2^12 rounds as tnd_uf16_encode rounds (tnd_uf16_encode_scaled), a uniformly random one rounds
 * stochastically (up with the probability of the value's fraction of a step: within a binade
 * the codes are linear in the float's bits). */
TND_FN TND_U32 tnd_uf16_encode_offset(float xs, TND_U32 offset)
{
    TND_U32 c = ((TND_F2U(xs) & 0x7fffffffu) + offset) >> 13;
    return c < 0x400u ? 0u : c > 0xffffu ? 0xffffu : c;
}
TND_FN TND_U32 tnd_uf16_encode_scaled(float xs)
{
    return tnd_uf16_encode_offset(xs, 0x1000u);
}

#ifdef TND_GLSL
vec3 tnd_rgbe_decode(uint p)
{
    return vec3(tnd_rgbe_channel(p, 0), tnd_rgbe_channel(p, 1), tnd_rgbe_channel(p, 2));
}
uint tnd_rgbe_encode3(vec3 c)
{
    return tnd_rgbe_encode(c.x, c.y, c.z);
}
#else
/* IEEE binary16 from float, round to nearest even, after clamping to +-65504 (NaN -> 0). */
static inline uint16_t tnd_half_from_float(float f)
{
    f = tnd_sanitize(f, (float)TND_HALF_MAX);
    uint32_t x = tnd_f2u_(f);
    uint32_t sign = (x >> 16) & 0x8000u;
    uint32_t ax = x & 0x7fffffffu;
    if (ax < 0x38800000u) {   /* below the smallest normal half (2^-14): subnormal or zero */
        if (ax < 0x33000000u) /* < 2^-25: rounds to zero (2^-25 itself ties to even 0) */
            return (uint16_t)sign;
        uint32_t e = ax >> 23, mant = (ax & 0x7fffffu) | 0x800000u;
        uint32_t shift = 126 - e; /* 14..24 */
        uint32_t h = mant >> shift, rem = mant & ((1u << shift) - 1), half = 1u << (shift - 1);
        if (rem > half || (rem == half && (h & 1u)))
            h++;
        return (uint16_t)(sign | h);
    }
    uint32_t h = ((ax >> 13) - (112u << 10)); /* rebias exponent 127 -> 15 */
    uint32_t rem = ax & 0x1fffu;
    if (rem > 0x1000u || (rem == 0x1000u && (h & 1u)))
        h++; /* may carry into the exponent: still correct; clamped input cannot reach Inf */
    return (uint16_t)(sign | h);
}

static inline float tnd_half_to_float(uint16_t h)
{
    uint32_t sign = (uint32_t)(h & 0x8000u) << 16, e = (h >> 10) & 0x1fu, m = h & 0x3ffu;
    if (e == 0) { /* zero or subnormal: m * 2^-24 */
        float v = (float)m * 5.9604644775390625e-8f;
        return sign ? -v : v;
    }
    if (e == 31)
        return tnd_u2f_(sign | 0x7f800000u | (m << 13));
    return tnd_u2f_(sign | ((e + 112u) << 23) | (m << 13));
}
#endif

#endif
