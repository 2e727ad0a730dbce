/* eval/metrics.c: image metrics (docs/metrics.md): relMSE, SMAPE, MSE/RMSE, PSNR, SSIM, LDR-FLIP,
 * the tone mapping the LDR metrics see, sequences (temporal error) and lag.
 * Entry points: ev_image_*, ev_auto_exposure, ev_tonemap, ev_mse, ev_relmse, ev_smape, ev_psnr,
 * ev_ssim, ev_flip, ev_sequence, ev_lag. */
#include "eval/eval.h"
#include "shaders/sampling.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ev_metrics_reference: the scalar code instead of the vectorised one */
static bool reference_filters;
/* the vectorised loops' functions, cloned for AVX2 and AVX-512 */
#define EV_VEC_FN __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))

tnd_result ev_image_alloc(uint32_t w, uint32_t h, ev_image *img)
{
    img->width = w;
    img->height = h;
    img->rgb = calloc((size_t)w * h * 3, sizeof(float));
    img->var = NULL;
    return img->rgb ? TND_OK : tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
}

void ev_image_free(ev_image *img)
{
    free(img->rgb);
    free(img->var);
    img->rgb = img->var = NULL;
}

tnd_result ev_image_read_exr(const char *path, ev_image *img)
{
    tnd_exr_file f;
    memset(img, 0, sizeof *img);
    tnd_result res = tnd_exr_read(path, &f);
    if (res != TND_OK)
        return res;
    const char *names[3] = {"R", "G", "B"};
    const tnd_exr_channel *ch[3];
    for (int k = 0; k < 3; k++)
        if (!(ch[k] = tnd_exr_find(&f, names[k])) || ch[k]->type == TND_EXR_UINT) {
            tnd_exr_close(&f);
            return tnd_fail(TND_ERR_BAD_INPUT, "eval: %s: no %s channel of floats (expected linear RGB)",
                            path, names[k]);
        }
    res = ev_image_alloc(f.width, f.height, img);
    if (res == TND_OK) {
        size_t n = (size_t)f.width * f.height;
        for (size_t q = 0; q < n; q++)
            for (int k = 0; k < 3; k++)
                img->rgb[3 * q + k] = ((const float *)ch[k]->data)[q];
        const tnd_exr_channel *v = tnd_exr_find(&f, "variance.Y");
        if (v && v->type != TND_EXR_UINT && (img->var = malloc(n * sizeof(float))) != NULL)
            for (size_t q = 0; q < n; q++) { /* (a variance is finite and not negative) */
                float x = ((const float *)v->data)[q];
                img->var[q] = x >= 0 && x < INFINITY ? x : 0.0f;
            }
        else if (v)
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    }
    tnd_exr_close(&f);
    if (res != TND_OK)
        ev_image_free(img);
    return res;
}

tnd_result ev_image_resize(const ev_image *in, uint32_t w, uint32_t h, ev_image *out)
{
    tnd_result res = ev_image_alloc(w, h, out);
    if (res != TND_OK)
        return res;
    double sx = (double)in->width / w, sy = (double)in->height / h;
    for (uint32_t y = 0; y < h; y++) {
        double fy = fmin(fmax((y + 0.5) * sy - 0.5, 0.0), in->height - 1.0);
        uint32_t y0 = (uint32_t)fy, y1 = y0 + 1 < in->height ? y0 + 1 : y0;
        double ty = fy - y0;
        for (uint32_t x = 0; x < w; x++) {
            double fx = fmin(fmax((x + 0.5) * sx - 0.5, 0.0), in->width - 1.0);
            uint32_t x0 = (uint32_t)fx, x1 = x0 + 1 < in->width ? x0 + 1 : x0;
            double tx = fx - x0;
            for (int k = 0; k < 3; k++) {
#define PX(xx, yy) in->rgb[3 * ((size_t)(yy) * in->width + (xx)) + k]
                double a = PX(x0, y0) + (PX(x1, y0) - PX(x0, y0)) * tx;
                double b = PX(x0, y1) + (PX(x1, y1) - PX(x0, y1)) * tx;
#undef PX
                out->rgb[3 * ((size_t)y * w + x) + k] = (float)(a + (b - a) * ty);
            }
        }
    }
    return TND_OK;
}

uint64_t ev_image_sanitize(ev_image *img)
{
    uint64_t bad = 0;
    size_t n = (size_t)img->width * img->height * 3;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(img->rgb[i])) {
            img->rgb[i] = 0.0f;
            bad++;
        }
    return bad;
}

static double luma(const float *c)
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

double ev_auto_exposure(const ev_image *imgs, uint32_t count)
{
    double sum = 0;
    size_t n = 0;
    for (uint32_t i = 0; i < count; i++) {
        size_t px = (size_t)imgs[i].width * imgs[i].height;
        for (size_t q = 0; q < px; q++) {
            double l = luma(imgs[i].rgb + 3 * q);
            sum += log(fmax(isfinite(l) ? l : 0.0, 1e-4));
        }
        n += px;
    }
    return n ? 0.18 / exp(sum / (double)n) : 1.0;
}

/* ---- float math the per-pixel loops vectorise (the reference code calls libm's pow and cbrt):
 * log2 from the exponent and an odd series in (m - 1) / (m + 1) on the mantissa m in
 * [sqrt(1/2), sqrt(2)) (truncation 1e-9); 2^y from the rounded integer part and a degree-7
 * series of e^u, |u| <= ln 2 / 2 (truncation 5e-9): about 1 float ulp, branch-free. */
static inline float vlog2(float x) /* x > 0 and normal */
{
    uint32_t b;
    memcpy(&b, &x, 4);
    float e = (float)(int32_t)((b >> 23) & 0xffu) - 127.0f, m;
    b = (b & 0x007fffffu) | 0x3f800000u;
    memcpy(&m, &b, 4);
    float big = m > 1.41421356f ? 1.0f : 0.0f;
    m = big > 0.0f ? 0.5f * m : m;
    e += big;
    float t = (m - 1.0f) / (m + 1.0f), t2 = t * t;
    return e + t * (2.88539008f + t2 * (0.961796694f + t2 * (0.577078016f +
                                                                t2 * (0.412198583f + t2 * 0.320598898f))));
}

static inline float vexp2(float y)
{
    y = y < -126.0f ? -126.0f : y > 126.0f ? 126.0f : y;
    int32_t k = (int32_t)(y + 128.5f) - 128; /* round to nearest (y + 128.5 > 0) */
    float u = (y - (float)k) * 0.693147181f;
    float p = 1.0f + u * (1.0f + u * (0.5f + u * (1.0f / 6 + u * (1.0f / 24 + u * (1.0f / 120 +
                                                                  u * (1.0f / 720 + u * (1.0f / 5040)))))));
    uint32_t b = (uint32_t)(k + 127) << 23;
    float s;
    memcpy(&s, &b, 4);
    return p * s;
}

/* x^p for x >= 0 (0 below 1e-30) */
static inline float vpow(float x, float p)
{
    float r = vexp2(p * vlog2(x > 1e-30f ? x : 1e-30f)); /* (both sides evaluated: no branch) */
    return x > 1e-30f ? r : 0.0f;
}

static float srgb_oetf(double v)
{
    v = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
    return (float)fmin(fmax(v, 0.0), 1.0);
}

EV_VEC_FN static void tonemap_fast(const float *restrict in, size_t n, float exposure,
                                   float *restrict out)
{
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        float x = in[i] * exposure;
        x = x > 0.0f ? x : 0.0f; /* (NaN: 0) */
        float y = x <= 1e18f ? x * (2.51f * x + 0.03f) / (x * (2.43f * x + 0.59f) + 0.14f) : 1.0f;
        y = y > 0.0f ? (y < 1.0f ? y : 1.0f) : 0.0f;
        float lin = 12.92f * y, curve = 1.055f * vpow(y, 1.0f / 2.4f) - 0.055f;
        float v = y <= 0.0031308f ? lin : y >= 1.0f ? 1.0f : curve;
        out[i] = v > 0.0f ? (v < 1.0f ? v : 1.0f) : 0.0f;
    }
}

void ev_tonemap(const ev_image *in, double exposure, float *out)
{
    size_t n = (size_t)in->width * in->height * 3;
    if (!reference_filters && exposure < 3e38) {
        tonemap_fast(in->rgb, n, (float)exposure, out);
        return;
    }
    for (size_t i = 0; i < n; i++) {
        double x = fmax(in->rgb[i] * exposure, 0.0);
        double y = isfinite(x) ? x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14) : 1.0;
        out[i] = srgb_oetf(fmin(fmax(y, 0.0), 1.0));
    }
}

/* ---- per-image metrics ------------------------------------------------------------------ */
double ev_mse(const float *o, const float *r, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)o[i] - r[i];
        s += d * d;
    }
    return n ? s / (double)n : 0.0;
}

double ev_relmse(const float *o, const float *r, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)o[i] - r[i];
        s += d * d / ((double)r[i] * r[i] + EV_RELMSE_EPS);
    }
    return n ? s / (double)n : 0.0;
}

double ev_smape(const float *o, const float *r, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += fabs((double)o[i] - r[i]) / (fabs((double)o[i]) + fabs((double)r[i]) + EV_SMAPE_EPS);
    return n ? s / (double)n : 0.0;
}

double ev_psnr(double mse)
{
    return 10.0 * log10(1.0 / fmax(mse, 1e-10)); /* at most 100 dB (identical images) */
}

/* Separable correlation of `src` (w x h) with the 1-D kernels kx (horizontal) and ky
 * (vertical), radius r each, clamped borders; `tmp` and `dst` hold w x h values. One version per
 * storage type: float for FLIP's planes, double for SSIM's moments (whose differences
 * E[x^2] - E[x]^2 cancel). */
#define EV_SEP_FILTER(NAME, T)                                                                   \
    static void NAME(const T *src, uint32_t w, uint32_t h, const double *kx, const double *ky,   \
                     int r, T *tmp, T *dst)                                                      \
    {                                                                                            \
        _Pragma("omp parallel for schedule(static)")                                             \
        for (uint32_t y = 0; y < h; y++)                                                         \
            for (uint32_t x = 0; x < w; x++) {                                                   \
                double s = 0;                                                                    \
                for (int i = -r; i <= r; i++) {                                                  \
                    int xx = (int)x + i;                                                         \
                    xx = xx < 0 ? 0 : xx >= (int)w ? (int)w - 1 : xx;                            \
                    s += kx[i + r] * src[(size_t)y * w + (size_t)xx];                            \
                }                                                                                \
                tmp[(size_t)y * w + x] = (T)s;                                                   \
            }                                                                                    \
        _Pragma("omp parallel for schedule(static)")                                             \
        for (uint32_t y = 0; y < h; y++)                                                         \
            for (uint32_t x = 0; x < w; x++) {                                                   \
                double s = 0;                                                                    \
                for (int i = -r; i <= r; i++) {                                                  \
                    int yy = (int)y + i;                                                         \
                    yy = yy < 0 ? 0 : yy >= (int)h ? (int)h - 1 : yy;                            \
                    s += ky[i + r] * tmp[(size_t)yy * w + x];                                    \
                }                                                                                \
                dst[(size_t)y * w + x] = (T)s;                                                   \
            }                                                                                    \
    }
EV_SEP_FILTER(sep_filter_ref, float)
EV_SEP_FILTER(sep_filter_d, double)

void ev_metrics_reference(bool on)
{
    reference_filters = on;
}

/* The vectorised separable filter (the same sums in float, in another order): each row as a sum
 * of shifted rows scaled by the kernel's taps (contiguous multiply-adds the compiler vectorises,
 * in clones for AVX2 and AVX-512), the clamped borders apart; rows over the threads. */
EV_VEC_FN static void filter_h(const float *restrict src, float *restrict dst, uint32_t w,
                               uint32_t h, const float *restrict k, int r)
{
#pragma omp parallel for schedule(static)
    for (uint32_t y = 0; y < h; y++) {
        const float *restrict s = src + (size_t)y * w;
        float *restrict d = dst + (size_t)y * w;
        int x0 = r < (int)w ? r : (int)w, x1 = (int)w - r > x0 ? (int)w - r : x0;
        for (int x = x0; x < x1; x++)
            d[x] = 0.0f;
        for (int i = -r; i <= r; i++) {
            float kk = k[i + r];
            for (int x = x0; x < x1; x++)
                d[x] += kk * s[x + i];
        }
        for (int x = 0; x < (int)w; x++) {
            if (x == x0)
                x = x1;
            if (x >= (int)w)
                break;
            float a = 0.0f;
            for (int i = -r; i <= r; i++) {
                int xx = x + i < 0 ? 0 : x + i >= (int)w ? (int)w - 1 : x + i;
                a += k[i + r] * s[xx];
            }
            d[x] = a;
        }
    }
}

EV_VEC_FN static void filter_v(const float *restrict src, float *restrict dst, uint32_t w,
                               uint32_t h, const float *restrict k, int r)
{
#pragma omp parallel for schedule(static)
    for (uint32_t y = 0; y < h; y++) {
        float *restrict d = dst + (size_t)y * w;
        for (uint32_t x = 0; x < w; x++)
            d[x] = 0.0f;
        for (int i = -r; i <= r; i++) {
            int yy = (int)y + i < 0 ? 0 : (int)y + i >= (int)h ? (int)h - 1 : (int)y + i;
            const float *restrict s = src + (size_t)yy * w;
            float kk = k[i + r];
            for (uint32_t x = 0; x < w; x++)
                d[x] += kk * s[x];
        }
    }
}

/* sep_filter: kernels of at most EV_MAX_TAPS taps */
#define EV_MAX_TAPS 129
static void sep_filter(const float *src, uint32_t w, uint32_t h, const double *kx,
                       const double *ky, int r, float *tmp, float *dst)
{
    if (reference_filters || 2 * r + 1 > EV_MAX_TAPS) {
        sep_filter_ref(src, w, h, kx, ky, r, tmp, dst);
        return;
    }
    float fx[EV_MAX_TAPS], fy[EV_MAX_TAPS];
    for (int i = 0; i < 2 * r + 1; i++)
        fx[i] = (float)kx[i], fy[i] = (float)ky[i];
    filter_h(src, tmp, w, h, fx, r);
    filter_v(tmp, dst, w, h, fy, r);
}

/* ---- SSIM ----------------------------------------------------------------------------------- */
/* SSIM's window: 11 taps of a Gaussian of sigma 1.5, normalised */
static void ssim_window(double g[11])
{
    double gs = 0;
    for (int i = -5; i <= 5; i++)
        gs += g[i + 5] = exp(-(double)(i * i) / (2.0 * 1.5 * 1.5));
    for (int i = 0; i < 11; i++)
        g[i] /= gs;
}

/* SSIM's vectorised way: each thread takes a band of output rows and keeps the last 2R + 1 input
 * rows' five moments, filtered horizontally over the windows that fit (no borders), in a ring;
 * per output row the vertical sums and the index. In double, as the scalar code: in float the
 * cancellation in E[x^2] - E[x]^2 leaves about 1e-7, 1e-4 of C2 = 9e-4 on flat regions. */
EV_VEC_FN static void ssim_hrow(const float *restrict o, const float *restrict r, uint32_t w,
                                uint32_t y, int k, const double *restrict g, int R,
                                double *restrict ab, double *restrict m)
{
    uint32_t iw = w - 2 * (uint32_t)R;
    double *restrict a = ab, *restrict b = ab + w;
    for (uint32_t x = 0; x < w; x++)
        a[x] = o[3 * ((size_t)y * w + x) + k], b[x] = r[3 * ((size_t)y * w + x) + k];
    for (uint32_t x = 0; x < 5 * iw; x++)
        m[x] = 0.0;
    double *restrict m0 = m, *restrict m1 = m + iw, *restrict m2 = m + 2 * iw;
    double *restrict m3 = m + 3 * iw, *restrict m4 = m + 4 * iw;
    for (int i = 0; i <= 2 * R; i++) {
        double kk = g[i];
        const double *restrict ai = a + i, *restrict bi = b + i;
        for (uint32_t x = 0; x < iw; x++) {
            double u = ai[x], v = bi[x];
            m0[x] += kk * u;
            m1[x] += kk * v;
            m2[x] += kk * u * u;
            m3[x] += kk * v * v;
            m4[x] += kk * u * v;
        }
    }
}

/* output row y from the ring (input row y + j in slot (y + j) mod (2R + 1)) */
EV_VEC_FN static double ssim_vrow(const double *restrict ring, uint32_t y, uint32_t iw,
                                  const double *restrict g, int R, double *restrict v)
{
    const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
    for (uint32_t x = 0; x < 5 * iw; x++)
        v[x] = 0.0;
    for (int j = -R; j <= R; j++) {
        double kk = g[j + R];
        const double *restrict s = ring + (size_t)((y + (uint32_t)(j + 2 * R + 1)) % (uint32_t)(2 * R + 1)) * 5 * iw;
        for (uint32_t x = 0; x < 5 * iw; x++)
            v[x] += kk * s[x];
    }
    const double *restrict v0 = v, *restrict v1 = v + iw, *restrict v2 = v + 2 * iw;
    const double *restrict v3 = v + 3 * iw, *restrict v4 = v + 4 * iw;
    double *restrict idx = v + 5 * iw; /* (one more row: the index) */
    for (uint32_t x = 0; x < iw; x++) {
        double mo = v0[x], mr = v1[x];
        double vo = v2[x] - mo * mo, vr = v3[x] - mr * mr, cov = v4[x] - mo * mr;
        idx[x] = (2 * mo * mr + c1) * (2 * cov + c2) / ((mo * mo + mr * mr + c1) * (vo + vr + c2));
    }
    double row = 0;
    for (uint32_t x = 0; x < iw; x++)
        row += idx[x];
    return row;
}

tnd_result ev_ssim(const float *o, const float *r, uint32_t w, uint32_t h, double *ssim)
{
    enum { R = 5, T = 2 * R + 1 };
    if (reference_filters || w < T || h < T)
        return ev_ssim_reference(o, r, w, h, ssim);
    double g[T];
    ssim_window(g);
    uint32_t iw = w - 2 * R, rows = h - 2 * R;
    int threads = omp_get_max_threads();
    /* per thread: the ring (T rows x 5 moments), the vertical sums and the index, the input
     * rows */
    size_t per = (size_t)(T + 1) * 5 * iw + iw + 2 * (size_t)w;
    double *buf = malloc((size_t)threads * per * sizeof(double));
    if (!buf)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    double total = 0;
#pragma omp parallel reduction(+ : total)
    {
        int t = omp_get_thread_num(), nt = omp_get_num_threads();
        double *ring = buf + (size_t)t * per, *v = ring + (size_t)T * 5 * iw, *ab = v + 6 * iw;
        uint32_t y0 = R + (uint32_t)((uint64_t)rows * t / nt);
        uint32_t y1 = R + (uint32_t)((uint64_t)rows * (t + 1) / nt);
        for (int k = 0; k < 3 && y0 < y1; k++) {
            for (uint32_t y = y0 - R; y < y0 + R; y++) /* (rows y0 - R .. y0 + R - 1) */
                ssim_hrow(o, r, w, y, k, g, R, ab, ring + (size_t)(y % T) * 5 * iw);
            for (uint32_t y = y0; y < y1; y++) {
                ssim_hrow(o, r, w, y + R, k, g, R, ab, ring + (size_t)((y + R) % T) * 5 * iw);
                total += ssim_vrow(ring, y, iw, g, R, v);
            }
        }
    }
    free(buf);
    *ssim = total / (3.0 * (double)iw * (double)rows);
    return TND_OK;
}

tnd_result ev_ssim_reference(const float *o, const float *r, uint32_t w, uint32_t h, double *ssim)
{
    enum { R = 5 };
    if (w < 2 * R + 1 || h < 2 * R + 1)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "eval: SSIM needs at least 11x11 pixels (got %ux%u)",
                        w, h);
    double g[2 * R + 1];
    ssim_window(g);
    const double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
    size_t n = (size_t)w * h;
    double *buf = malloc(n * 7 * sizeof(double));
    if (!buf)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    double *in[5] = {buf, buf + n, buf + 2 * n, buf + 3 * n, buf + 4 * n};
    double *tmp = buf + 5 * n, *mo = buf + 6 * n;
    double total = 0;
    uint64_t count = 0;
    for (int k = 0; k < 3; k++) {
        for (size_t q = 0; q < n; q++) {
            double a = o[3 * q + k], b = r[3 * q + k];
            in[0][q] = a, in[1][q] = b, in[2][q] = a * a, in[3][q] = b * b, in[4][q] = a * b;
        }
        /* filter each moment in place (the windows that fit are the only ones read) */
        for (int m = 0; m < 5; m++) {
            sep_filter_d(in[m], w, h, g, g, R, tmp, mo);
            memcpy(in[m], mo, n * sizeof(double));
        }
        for (uint32_t y = R; y < h - R; y++)
            for (uint32_t x = R; x < w - R; x++) {
                size_t q = (size_t)y * w + x;
                double mu_o = in[0][q], mu_r = in[1][q];
                double vo = in[2][q] - mu_o * mu_o, vr = in[3][q] - mu_r * mu_r;
                double cov = in[4][q] - mu_o * mu_r;
                total += (2 * mu_o * mu_r + c1) * (2 * cov + c2) /
                         ((mu_o * mu_o + mu_r * mu_r + c1) * (vo + vr + c2));
                count++;
            }
    }
    free(buf);
    *ssim = total / (double)count;
    return TND_OK;
}

/* ---- FLIP ------------------------------------------------------------------------------------
 * Colour: sRGB -> linear -> XYZ -> YCxCz; CSF filters per channel (sums of Gaussians, applied as
 * separable passes); back to linear RGB clamped to [0,1]; CIELAB with the Hunt adjustment; HyAB
 * distance^0.7 remapped with the knee (0.4 cmax -> 0.95). Features: edge and point detectors
 * (first and second Gaussian derivatives, sd = 0.5 x 0.082 x ppd) on the luminance; the larger
 * difference of their magnitudes, /sqrt(2), ^0.5. Error = colour^(1 - feature). */
static const double D65[3] = {0.950428545, 1.0, 1.088900371};

static void srgb_to_xyz(const float *c, double xyz[3])
{
    double l[3];
    for (int k = 0; k < 3; k++)
        l[k] = c[k] > 0.04045 ? pow((c[k] + 0.055) / 1.055, 2.4) : c[k] / 12.92;
    xyz[0] = (10135552.0 * l[0] + 8788810.0 * l[1] + 4435075.0 * l[2]) / 24577794.0;
    xyz[1] = (2613072.0 * l[0] + 8788810.0 * l[1] + 887015.0 * l[2]) / 12288897.0;
    xyz[2] = (1425312.0 * l[0] + 8788810.0 * l[1] + 70074185.0 * l[2]) / 73733382.0;
}

static void xyz_to_linrgb(const double xyz[3], double rgb[3])
{
    rgb[0] = 3.241003275 * xyz[0] - 1.537398934 * xyz[1] - 0.498615861 * xyz[2];
    rgb[1] = -0.969224334 * xyz[0] + 1.875930071 * xyz[1] + 0.041554224 * xyz[2];
    rgb[2] = 0.055639423 * xyz[0] - 0.204011202 * xyz[1] + 1.057148933 * xyz[2];
}

/* Hunt-adjusted CIELAB of a linear RGB colour */
static void linrgb_to_hunt_lab(const double rgb[3], double lab[3])
{
    double xyz[3], f[3];
    xyz[0] = (10135552.0 * rgb[0] + 8788810.0 * rgb[1] + 4435075.0 * rgb[2]) / 24577794.0;
    xyz[1] = (2613072.0 * rgb[0] + 8788810.0 * rgb[1] + 887015.0 * rgb[2]) / 12288897.0;
    xyz[2] = (1425312.0 * rgb[0] + 8788810.0 * rgb[1] + 70074185.0 * rgb[2]) / 73733382.0;
    const double d = 6.0 / 29.0;
    for (int k = 0; k < 3; k++) {
        double t = xyz[k] / D65[k];
        f[k] = t > d * d * d ? cbrt(t) : t / (3 * d * d) + 4.0 / 29.0;
    }
    double L = 116 * f[1] - 16;
    lab[0] = L;
    lab[1] = 0.01 * L * 500 * (f[0] - f[1]);
    lab[2] = 0.01 * L * 200 * (f[1] - f[2]);
}

static double hyab(const double a[3], const double b[3])
{
    return fabs(a[0] - b[0]) + sqrt((a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

/* CSF: a1 sqrt(pi/b1) exp(-pi^2 d^2/b1) + a2 sqrt(pi/b2) exp(-pi^2 d^2/b2), d in degrees,
 * normalised to unit sum over the (2r+1)^2 grid. As separable terms: weights[i] x (g_i (x) g_i). */
typedef struct csf {
    int terms, r;
    double weight[2];
    double *g[2];
} csf;

static tnd_result csf_make(double ppd, double a1, double b1, double a2, double b2, csf *c)
{
    c->r = (int)ceil(3.0 * sqrt(0.04 / (2.0 * M_PI * M_PI)) * ppd); /* widest CSF (b = 0.04) */
    c->terms = a2 > 0 ? 2 : 1;
    double a[2] = {a1, a2}, b[2] = {b1, b2}, total = 0;
    for (int t = 0; t < c->terms; t++) {
        c->g[t] = malloc((size_t)(2 * c->r + 1) * sizeof(double));
        if (!c->g[t])
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
        double s1 = 0;
        for (int i = -c->r; i <= c->r; i++) {
            double d = i / ppd;
            s1 += c->g[t][i + c->r] = exp(-M_PI * M_PI * d * d / b[t]);
        }
        c->weight[t] = a[t] * sqrt(M_PI / b[t]);
        total += c->weight[t] * s1 * s1;
    }
    for (int t = 0; t < c->terms; t++)
        c->weight[t] /= total;
    return TND_OK;
}

static void csf_free(csf *c)
{
    for (int t = 0; t < c->terms; t++)
        free(c->g[t]);
}

/* Gaussian-derivative detector pair (edge: -x g; point: (x^2/sd^2 - 1) g), normalised so that
 * positive weights sum to 1 and negative ones to -1 (as 2-D kernels), as separable factors:
 * d (along the derivative) and s (across, unit sum). */
static void feature_kernels(double ppd, int *radius, double **edge, double **point, double **s)
{
    double sd = 0.5 * 0.082 * ppd;
    int r = (int)ceil(3 * sd);
    *radius = r;
    *edge = malloc((size_t)(2 * r + 1) * sizeof(double));
    *point = malloc((size_t)(2 * r + 1) * sizeof(double));
    *s = malloc((size_t)(2 * r + 1) * sizeof(double));
    if (!*edge || !*point || !*s)
        return;
    double gs = 0, ep = 0, en = 0, pp = 0, pn = 0;
    for (int i = -r; i <= r; i++) {
        double g = exp(-(double)(i * i) / (2 * sd * sd));
        (*s)[i + r] = g;
        gs += g;
        double e = -i * g, p = ((double)(i * i) / (sd * sd) - 1) * g;
        (*edge)[i + r] = e;
        (*point)[i + r] = p;
        if (e > 0) ep += e; else en -= e;
        if (p > 0) pp += p; else pn -= p;
    }
    for (int i = 0; i < 2 * r + 1; i++) {
        (*s)[i] /= gs;
        (*edge)[i] /= (*edge)[i] > 0 ? ep : en;
        (*point)[i] /= (*point)[i] > 0 ? pp : pn;
    }
}

/* FLIP's per-pixel steps in float (the reference: the double code in ev_flip) */
EV_VEC_FN static void flip_ycxcz_fast(const float *restrict c, size_t n, float *restrict py,
                                      float *restrict pcx, float *restrict pcz)
{
#pragma omp parallel for schedule(static)
    for (size_t q = 0; q < n; q++) {
        float l[3];
        for (int k = 0; k < 3; k++) {
            float v = c[3 * q + k];
            float curve = vpow((v + 0.055f) * (1.0f / 1.055f), 2.4f), lin = v * (1.0f / 12.92f);
            l[k] = v > 0.04045f ? curve : lin;
        }
        float x = (10135552.0f * l[0] + 8788810.0f * l[1] + 4435075.0f * l[2]) *
                  (float)(1.0 / (24577794.0 * 0.950428545));
        float y = (2613072.0f * l[0] + 8788810.0f * l[1] + 887015.0f * l[2]) * (1.0f / 12288897.0f);
        float z = (1425312.0f * l[0] + 8788810.0f * l[1] + 70074185.0f * l[2]) *
                  (float)(1.0 / (73733382.0 * 1.088900371));
        py[q] = 116.0f * y - 16.0f;
        pcx[q] = 500.0f * (x - y);
        pcz[q] = 200.0f * (y - z);
    }
}

static inline void hunt_lab_fast(float y0, float cx, float cz, float lab[3])
{
    float y = (y0 + 16.0f) * (1.0f / 116.0f);
    float X = (y + cx * (1.0f / 500.0f)) * 0.950428545f, Y = y, Z = (y - cz * (1.0f / 200.0f)) *
                                                                      1.088900371f;
    float rgb[3] = {3.241003275f * X - 1.537398934f * Y - 0.498615861f * Z,
                    -0.969224334f * X + 1.875930071f * Y + 0.041554224f * Z,
                    0.055639423f * X - 0.204011202f * Y + 1.057148933f * Z};
    for (int k = 0; k < 3; k++)
        rgb[k] = rgb[k] > 0.0f ? (rgb[k] < 1.0f ? rgb[k] : 1.0f) : 0.0f;
    float t[3] = {(10135552.0f * rgb[0] + 8788810.0f * rgb[1] + 4435075.0f * rgb[2]) *
                      (float)(1.0 / (24577794.0 * 0.950428545)),
                  (2613072.0f * rgb[0] + 8788810.0f * rgb[1] + 887015.0f * rgb[2]) *
                      (1.0f / 12288897.0f),
                  (1425312.0f * rgb[0] + 8788810.0f * rgb[1] + 70074185.0f * rgb[2]) *
                      (float)(1.0 / (73733382.0 * 1.088900371))};
    const float d3 = (6.0f / 29.0f) * (6.0f / 29.0f) * (6.0f / 29.0f);
    float f[3];
    for (int k = 0; k < 3; k++) {
        float cube = vpow(t[k], 1.0f / 3.0f);
        float lin = t[k] * (1.0f / (3.0f * (6.0f / 29.0f) * (6.0f / 29.0f))) + 4.0f / 29.0f;
        f[k] = t[k] > d3 ? cube : lin;
    }
    float L = 116.0f * f[1] - 16.0f;
    lab[0] = L;
    lab[1] = 5.0f * L * (f[0] - f[1]);
    lab[2] = 2.0f * L * (f[1] - f[2]);
}

EV_VEC_FN static void flip_color_fast(const float *const *P, size_t n, float cmax,
                                      float *restrict color)
{
    const float qc = 0.7f, pc = 0.4f, pt = 0.95f;
#pragma omp parallel for schedule(static)
    for (size_t q = 0; q < n; q++) {
        float a[3], b[3];
        hunt_lab_fast(P[0][q], P[1][q], P[2][q], a);
        hunt_lab_fast(P[3][q], P[4][q], P[5][q], b);
        float d = fabsf(a[0] - b[0]) + sqrtf((a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
        float e = vpow(d, qc);
        float lo = pt / (pc * cmax) * e, hi = pt + (e - pc * cmax) / (cmax - pc * cmax) * (1.0f - pt);
        color[q] = e < pc * cmax ? lo : hi;
    }
}

EV_VEC_FN static void flip_error_fast(const float *restrict e0, const float *restrict p0,
                                      const float *restrict e1, const float *restrict p1,
                                      const float *restrict color, size_t n, float *restrict err)
{
#pragma omp parallel for schedule(static)
    for (size_t q = 0; q < n; q++) {
        float de = fabsf(e0[q] - e1[q]), dp = fabsf(p0[q] - p1[q]);
        float f = sqrtf((de > dp ? de : dp) * 0.70710678f); /* (^0.5) */
        float pw = vpow(color[q], 1.0f - f), zero = f >= 1.0f ? 1.0f : 0.0f;
        err[q] = color[q] > 0.0f ? pw : zero;
    }
}

/* FLIP's filters at ppd pixels per degree: the contrast-sensitivity functions of the three
 * channels, the feature detectors (radius r), and c_max, the largest colour difference */
typedef struct flip_set {
    csf c[3];
    int r;
    double *ke, *kp, *ks;
    double cmax;
} flip_set;

static void flip_set_free(flip_set *f)
{
    for (int k = 0; k < 3; k++)
        csf_free(&f->c[k]);
    free(f->ke);
    free(f->kp);
    free(f->ks);
    *f = (flip_set){0};
}

static tnd_result flip_set_make(double ppd, flip_set *f)
{
    tnd_result res = TND_OK;
    *f = (flip_set){0};
    TND_TRY(csf_make(ppd, 1, 0.0047, 0, 1e-5, &f->c[0]));
    TND_TRY(csf_make(ppd, 1, 0.0053, 0, 1e-5, &f->c[1]));
    TND_TRY(csf_make(ppd, 34.1, 0.04, 13.5, 0.025, &f->c[2]));
    feature_kernels(ppd, &f->r, &f->ke, &f->kp, &f->ks);
    if (!f->ke || !f->kp || !f->ks) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
        goto fail;
    }
    double lab_g[3], lab_b[3];
    linrgb_to_hunt_lab((const double[3]){0, 1, 0}, lab_g);
    linrgb_to_hunt_lab((const double[3]){0, 0, 1}, lab_b);
    f->cmax = pow(hyab(lab_g, lab_b), 0.7);
fail:
    if (res != TND_OK)
        flip_set_free(f);
    return res;
}

tnd_result ev_flip_kernels(double ppd, float *table, size_t cap, int *rc, int *rf, double *cmax)
{
    tnd_result res = TND_OK;
    flip_set fs;
    TND_TRY(flip_set_make(ppd, &fs));
    size_t tc = (size_t)(2 * fs.c[0].r + 1), tf = (size_t)(2 * fs.r + 1);
    if (4 * tc + 4 + 3 * tf + 11 > cap) {
        res = tnd_fail(TND_ERR_LIMIT, "eval: FLIP's kernels at %g pixels per degree are too wide "
                       "for the device metrics", ppd);
        goto fail;
    }
    const double *g[4] = {fs.c[0].g[0], fs.c[1].g[0], fs.c[2].g[0], fs.c[2].g[1]};
    const double wt[4] = {fs.c[0].weight[0], fs.c[1].weight[0], fs.c[2].weight[0],
                          fs.c[2].weight[1]};
    for (int t = 0; t < 4; t++) {
        for (size_t i = 0; i < tc; i++)
            table[(size_t)t * tc + i] = (float)g[t][i];
        table[4 * tc + (size_t)t] = (float)wt[t];
    }
    const double *f[3] = {fs.ke, fs.kp, fs.ks};
    for (int t = 0; t < 3; t++)
        for (size_t i = 0; i < tf; i++)
            table[4 * tc + 4 + (size_t)t * tf + i] = (float)f[t][i];
    double gg[11];
    ssim_window(gg);
    for (int i = 0; i < 11; i++)
        table[4 * tc + 4 + 3 * tf + (size_t)i] = (float)gg[i];
    *cmax = fs.cmax;
    *rc = fs.c[0].r;
    *rf = fs.r;
fail:
    flip_set_free(&fs);
    return res;
}

tnd_result ev_flip(const float *ref, const float *test, uint32_t w, uint32_t h, double ppd,
                   float *map, double *mean)
{
    tnd_result res = TND_OK;
    size_t n = (size_t)w * h;
    flip_set fs = {0};
    float *buf = malloc(n * 16 * sizeof(float));
    if (!buf)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    /* [0..5] YCxCz of ref and test (plane per channel), [6..11] filtered, [12] tmp, [13] acc,
     * [14] luminance, [15] scratch */
    float *P[16];
    for (int i = 0; i < 16; i++)
        P[i] = buf + (size_t)i * n;
    TND_TRY(flip_set_make(ppd, &fs));
    const csf *c = fs.c;
    const float *img[2] = {ref, test};
    if (!reference_filters)
        for (int m = 0; m < 2; m++)
            flip_ycxcz_fast(img[m], n, P[3 * m], P[3 * m + 1], P[3 * m + 2]);
    for (int m = 0; m < 2 && reference_filters; m++)
        for (size_t q = 0; q < n; q++) {
            double xyz[3];
            srgb_to_xyz(img[m] + 3 * q, xyz);
            double x = xyz[0] / D65[0], y = xyz[1] / D65[1], z = xyz[2] / D65[2];
            P[3 * m + 0][q] = (float)(116 * y - 16);
            P[3 * m + 1][q] = (float)(500 * (x - y));
            P[3 * m + 2][q] = (float)(200 * (y - z));
        }
    for (int m = 0; m < 2; m++)
        for (int k = 0; k < 3; k++) {
            float *dst = P[6 + 3 * m + k];
            memset(dst, 0, n * sizeof(float));
            for (int t = 0; t < c[k].terms; t++) {
                sep_filter(P[3 * m + k], w, h, c[k].g[t], c[k].g[t], c[k].r, P[12], P[13]);
                for (size_t q = 0; q < n; q++)
                    dst[q] += (float)(c[k].weight[t] * P[13][q]);
            }
        }
    /* colour difference */
    const double qc = 0.7, qf = 0.5, pc = 0.4, pt = 0.95, cmax = fs.cmax;
    float *color = P[15];
    if (!reference_filters)
        flip_color_fast((const float *const *)P + 6, n, (float)cmax, color);
#pragma omp parallel for schedule(static) if (reference_filters)
    for (size_t q = 0; q < n * reference_filters; q++) {
        double lab[2][3];
        for (int m = 0; m < 2; m++) {
            double yc[3] = {P[6 + 3 * m][q], P[7 + 3 * m][q], P[8 + 3 * m][q]}, xyz[3], rgb[3];
            double y = (yc[0] + 16) / 116;
            xyz[0] = (y + yc[1] / 500) * D65[0];
            xyz[1] = y * D65[1];
            xyz[2] = (y - yc[2] / 200) * D65[2];
            xyz_to_linrgb(xyz, rgb);
            for (int k = 0; k < 3; k++)
                rgb[k] = fmin(fmax(rgb[k], 0.0), 1.0);
            linrgb_to_hunt_lab(rgb, lab[m]);
        }
        double e = pow(hyab(lab[0], lab[1]), qc);
        color[q] = (float)(e < pc * cmax ? pt / (pc * cmax) * e
                                         : pt + (e - pc * cmax) / (cmax - pc * cmax) * (1 - pt));
    }
    /* features on the normalised luminance, (Y' + 16) / 116 of the unfiltered images */
    int r = fs.r;
    const double *ke = fs.ke, *kp = fs.kp, *ks = fs.ks;
    /* P[6..11] are free now: [6+2m] edge magnitude, [7+2m] point magnitude of image m */
    for (int m = 0; m < 2; m++) {
        for (size_t q = 0; q < n; q++)
            P[14][q] = (P[3 * m][q] + 16) / 116;
        const double *kd[2] = {ke, kp};
        for (int f = 0; f < 2; f++) {
            float *mag = P[6 + 2 * m + f];
            sep_filter(P[14], w, h, kd[f], ks, r, P[12], P[13]); /* d/dx */
            sep_filter(P[14], w, h, ks, kd[f], r, P[12], P[10 + f]); /* d/dy (P[10..11] scratch) */
            for (size_t q = 0; q < n; q++)
                mag[q] = reference_filters ? hypotf(P[13][q], P[10 + f][q])
                                           : sqrtf(P[13][q] * P[13][q] + P[10 + f][q] * P[10 + f][q]);
        }
        if (m == 0) { /* keep image 0's magnitudes out of the scratch planes used for image 1 */
            memcpy(P[4], P[6], n * sizeof(float));
            memcpy(P[5], P[7], n * sizeof(float));
        }
    }
    double sum = 0;
    if (!reference_filters) { /* (the error into the map, or over the colour plane) */
        float *err = map ? map : color;
        flip_error_fast(P[4], P[5], P[8], P[9], color, n, err);
        for (size_t q = 0; q < n; q++)
            sum += err[q];
    }
    for (size_t q = 0; q < n * reference_filters; q++) {
        double de = fabs((double)P[4][q] - P[8][q]), dp = fabs((double)P[5][q] - P[9][q]);
        double f = pow(fmax(de, dp) / sqrt(2.0), qf);
        double e = pow(color[q], 1.0 - f);
        if (map)
            map[q] = (float)e;
        sum += e;
    }
    *mean = sum / (double)n;
fail:
    flip_set_free(&fs);
    free(buf);
    return res;
}

/* ---- sequences ------------------------------------------------------------------------------ */
static double mean_luma(const ev_image *img)
{
    double s = 0;
    size_t n = (size_t)img->width * img->height;
    for (size_t q = 0; q < n; q++)
        s += luma(img->rgb + 3 * q);
    return n ? s / (double)n : 0.0;
}

static double mean_abs_luma_diff(const ev_image *a, const ev_image *b)
{
    double s = 0;
    size_t n = (size_t)a->width * a->height;
    for (size_t q = 0; q < n; q++)
        s += fabs(luma(a->rgb + 3 * q) - luma(b->rgb + 3 * q));
    return n ? s / (double)n : 0.0;
}

/* per frame: the reference's mean luminance, its change from the previous frame (mean absolute
 * luminance difference), and the output's mean absolute luminance error */
typedef struct lag_stats {
    double mean, step, err;
} lag_stats;

static uint32_t lag_of(const lag_stats *st, uint32_t count, double *mean_lag)
{
    uint32_t changes = 0;
    double total = 0;
    for (uint32_t t = 1; t < count; t++) {
        double m0 = st[t - 1].mean, m1 = st[t].mean;
        if (!(fabs(m1 - m0) > 0.2 * fmax(m0, 1e-6)))
            continue;
        double limit = st[t - 1].err + 0.1 * st[t].step;
        uint32_t k = t;
        while (k < count && st[k].err > limit)
            k++;
        total += k - t; /* a change that never settles counts until the end of the sequence */
        changes++;
    }
    *mean_lag = changes ? total / changes : -1.0;
    return changes;
}

uint32_t ev_lag(const ev_image *out, const ev_image *ref, uint32_t count, double *mean_lag)
{
    lag_stats *st = calloc(count + 1, sizeof *st);
    if (!st) {
        *mean_lag = -1;
        return 0;
    }
    for (uint32_t t = 0; t < count; t++) {
        st[t].mean = mean_luma(&ref[t]);
        st[t].step = t ? mean_abs_luma_diff(&ref[t], &ref[t - 1]) : 0.0;
        st[t].err = mean_abs_luma_diff(&out[t], &ref[t]);
    }
    uint32_t n = lag_of(st, count, mean_lag);
    free(st);
    return n;
}

/* A disocclusion event: the pixels a frame disoccluded, followed until they settle. */
typedef struct disocc_event {
    uint8_t *mask;
    uint32_t age; /* frames since the event */
    bool active;
} disocc_event;

struct ev_sequence {
    uint32_t w, h, count, cap;
    double exposure, ppd;
    float *to, *tr, *po, *pr; /* tone-mapped output and reference, this and the previous frame */
    ev_image prev_ref;        /* linear, for the lag's reference change */
    lag_stats *lag;
    ev_summary sum;
    uint32_t temporal_count;
    /* motion-compensated metrics (ev_sequence_motion) */
    float *motion, *depth, *prev_depth; /* this frame's (set before add), the last one's depth */
    bool have_motion, have_prev_depth;
    uint8_t *valid, *still;  /* this frame's visibility in the last; static so far */
    float *yerr;             /* this frame's |Y_o - Y_r| per pixel (tone-mapped) */
    double *ysum;            /* per pixel: sum Y_o, Y_o^2, Y_r, Y_r^2 over frames with motion */
    uint32_t yframes, mc_count;
    double mc_sum;
    disocc_event ev[EV_DISOCC_FRAMES];
    double lag_sum;
    uint32_t lag_events;
    /* worth N samples: the relMSE's sums of variance terms and errors; FLIP's log sum */
    double worth_v, worth_e, worth_log;
    uint32_t worth_flips;
    bool worth_flip_next;
    float *worth_scratch;
    ev_gpu *gpu; /* ev_sequence_gpu: the per-image metrics on the device */
};

void ev_sequence_destroy(ev_sequence *s)
{
    if (!s)
        return;
    free(s->to);
    free(s->tr);
    free(s->po);
    free(s->pr);
    ev_image_free(&s->prev_ref);
    free(s->lag);
    free(s->motion);
    free(s->depth);
    free(s->prev_depth);
    free(s->valid);
    free(s->still);
    free(s->ysum);
    free(s->yerr);
    free(s->worth_scratch);
    for (int k = 0; k < EV_DISOCC_FRAMES; k++)
        free(s->ev[k].mask);
    free(s);
}

void ev_sequence_motion(ev_sequence *s, const float *motion, const float *depth)
{
    size_t n = (size_t)s->w * s->h;
    if (!s->motion) {
        s->motion = malloc(n * 3 * sizeof(float));
        s->depth = malloc(n * sizeof(float));
        s->prev_depth = malloc(n * sizeof(float));
        s->valid = malloc(n);
        s->still = malloc(n);
        s->ysum = calloc(n * 4, sizeof(double));
        s->yerr = malloc(n * sizeof(float));
        for (int k = 0; k < EV_DISOCC_FRAMES; k++)
            s->ev[k].mask = malloc(n);
        bool ok = s->motion && s->depth && s->prev_depth && s->valid && s->still && s->ysum &&
                  s->yerr;
        for (int k = 0; k < EV_DISOCC_FRAMES; k++)
            ok &= s->ev[k].mask != NULL;
        if (!ok) { /* (ev_sequence_add then measures without motion) */
            free(s->motion), free(s->depth), free(s->prev_depth), free(s->valid), free(s->still);
            free(s->ysum), free(s->yerr);
            s->motion = s->depth = s->prev_depth = s->yerr = NULL;
            s->valid = s->still = NULL;
            s->ysum = NULL;
            for (int k = 0; k < EV_DISOCC_FRAMES; k++) {
                free(s->ev[k].mask);
                s->ev[k].mask = NULL;
            }
            return;
        }
        memset(s->still, 1, n);
    }
    memcpy(s->motion, motion, n * 3 * sizeof(float));
    memcpy(s->depth, depth, n * sizeof(float));
    s->have_motion = true;
}

/* Bilinear lookup of a 3-channel image at pixel-centre coordinates (x, y) (pixel i's centre at
 * i), clamped to the edge. */
static void bilinear3(const float *img, uint32_t w, uint32_t h, double x, double y, double out[3])
{
    double fx = floor(x), fy = floor(y), ax = x - fx, ay = y - fy;
    long x0 = (long)fx, y0 = (long)fy;
    long xs[2] = {x0 < 0 ? 0 : x0 >= (long)w ? (long)w - 1 : x0,
                  x0 + 1 < 0 ? 0 : x0 + 1 >= (long)w ? (long)w - 1 : x0 + 1};
    long ys[2] = {y0 < 0 ? 0 : y0 >= (long)h ? (long)h - 1 : y0,
                  y0 + 1 < 0 ? 0 : y0 + 1 >= (long)h ? (long)h - 1 : y0 + 1};
    for (int c = 0; c < 3; c++) {
        double a = img[3 * ((size_t)ys[0] * w + xs[0]) + c], b = img[3 * ((size_t)ys[0] * w + xs[1]) + c];
        double d = img[3 * ((size_t)ys[1] * w + xs[0]) + c], e = img[3 * ((size_t)ys[1] * w + xs[1]) + c];
        out[c] = (1 - ay) * ((1 - ax) * a + ax * b) + ay * ((1 - ax) * d + ax * e);
    }
}

/* The motion-compensated metrics of the frame just tone-mapped into s->to / s->tr (the last
 * frame's in s->po / s->pr). */
static void motion_metrics(ev_sequence *s, ev_frame_metrics *f)
{
    uint32_t w = s->w, h = s->h;
    size_t n = (size_t)w * h;
    const float miss = 1e29f;
    double acc = 0;
    uint64_t nvalid = 0, ndis = 0;
    bool prev = s->count > 0 && s->have_prev_depth;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            const float *m = s->motion + 3 * p;
            double xp = x + (double)m[0], yp = y + (double)m[1], d = s->depth[p];
            bool hit = d < miss, valid = false;
            if (prev && isfinite(xp) && isfinite(yp) && xp >= -0.5 && yp >= -0.5 &&
                xp < w - 0.5 && yp < h - 0.5) {
                long ix = lround(xp), iy = lround(yp); /* (the nearest pixel, inside) */
                ix = ix < 0 ? 0 : ix >= (long)w ? (long)w - 1 : ix;
                iy = iy < 0 ? 0 : iy >= (long)h ? (long)h - 1 : iy;
                double dp = s->prev_depth[(size_t)iy * w + ix];
                valid = hit ? dp < miss && fabs(dp - (d + m[2])) <= 0.05 * d : !(dp < miss);
            }
            s->valid[p] = valid;
            ndis += prev && hit && !valid;
            if (valid) {
                double wo[3], wr[3];
                bilinear3(s->po, w, h, xp, yp, wo);
                bilinear3(s->pr, w, h, xp, yp, wr);
                for (int c = 0; c < 3; c++)
                    acc += fabs((s->to[3 * p + c] - wo[c]) - (s->tr[3 * p + c] - wr[c]));
                nvalid++;
            }
            /* static through the sequence: visible in the last frame and unmoved */
            if (prev)
                s->still[p] &= valid && fabsf(m[0]) < 0.01f && fabsf(m[1]) < 0.01f &&
                               (!hit || fabs(m[2]) <= 1e-3 * d);
            double yo = luma(s->to + 3 * p), yr = luma(s->tr + 3 * p);
            double *ys = s->ysum + 4 * p;
            ys[0] += yo, ys[1] += yo * yo, ys[2] += yr, ys[3] += yr * yr;
            s->yerr[p] = (float)fabs(yo - yr);
        }
    s->yframes++;
    f->mc_temporal = prev && nvalid ? acc / (3.0 * (double)nvalid) : -1.0;
    f->disoccluded = prev ? (double)ndis / (double)n : 0.0;
    if (f->mc_temporal >= 0) {
        s->mc_sum += f->mc_temporal;
        s->mc_count++;
    }
    /* disocclusions: this frame's is a new event; every event settles when its pixels' error is
     * back to the other visible pixels' */
    if (prev && ndis) {
        disocc_event *e = NULL;
        for (int k = 0; k < EV_DISOCC_FRAMES && !e; k++)
            if (!s->ev[k].active)
                e = &s->ev[k];
        if (e) { /* (at most one a frame, each settled within EV_DISOCC_FRAMES: always free) */
            for (size_t p = 0; p < n; p++)
                e->mask[p] = s->depth[p] < miss && !s->valid[p];
            e->age = 0;
            e->active = true;
        }
    }
    double base = 0;
    uint64_t nb = 0;
    for (size_t p = 0; p < n; p++)
        if (s->valid[p]) {
            base += s->yerr[p];
            nb++;
        }
    base = nb ? base / (double)nb : 0.0;
    for (int k = 0; k < EV_DISOCC_FRAMES; k++) {
        disocc_event *e = &s->ev[k];
        if (!e->active)
            continue;
        double err = 0;
        uint64_t ne = 0;
        for (size_t p = 0; p < n; p++)
            if (e->mask[p]) {
                err += s->yerr[p];
                ne++;
            }
        err = ne ? err / (double)ne : 0.0;
        bool settled = err <= EV_DISOCC_RATIO * base + EV_DISOCC_ABS;
        if (settled || e->age + 1 >= EV_DISOCC_FRAMES) {
            s->lag_sum += settled ? e->age : EV_DISOCC_FRAMES;
            s->lag_events++;
            e->active = false;
        } else {
            e->age++;
        }
    }
    memcpy(s->prev_depth, s->depth, n * sizeof(float));
    s->have_prev_depth = true;
    s->have_motion = false;
}

tnd_result ev_sequence_create(uint32_t w, uint32_t h, double exposure, double ppd, ev_sequence **out)
{
    *out = NULL;
    ev_sequence *s = calloc(1, sizeof *s);
    size_t n = (size_t)w * h * 3;
    if (!s || !(s->to = malloc(n * sizeof(float))) || !(s->tr = malloc(n * sizeof(float))) ||
        !(s->po = malloc(n * sizeof(float))) || !(s->pr = malloc(n * sizeof(float))) ||
        ev_image_alloc(w, h, &s->prev_ref) != TND_OK) {
        ev_sequence_destroy(s);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    }
    s->w = w;
    s->h = h;
    s->exposure = exposure;
    s->ppd = ppd;
    *out = s;
    return TND_OK;
}

void ev_sequence_gpu(ev_sequence *s, ev_gpu *g)
{
    s->gpu = g;
}

void ev_sequence_worth_flip(ev_sequence *s, bool on)
{
    s->worth_flip_next = on;
}

/* The luminance relMSE terms of worth N: the variance of one sample and the output's squared
 * error, each over Y_r^2 + eps, summed over the pixels. */
static void worth_relmse_terms(const ev_image *out, const ev_image *ref, double *v, double *e)
{
    size_t n = (size_t)ref->width * ref->height;
    double sv = 0, se = 0;
    for (size_t q = 0; q < n; q++) {
        const float *o = out->rgb + 3 * q, *r = ref->rgb + 3 * q;
        double yr = luma(r), d = luma(o) - yr;
        double w = 1.0 / (yr * yr + EV_RELMSE_EPS);
        sv += ref->var[q] * w;
        se += d * d * w;
    }
    *v = sv, *e = se;
}

/* a uniform draw in (0, 1) per pixel and frame, on the shared hash */
static double uniform_draw(uint32_t q, uint32_t frame)
{
    uint32_t h[4] = {q, frame, 0x3017u, 0x9e3779b9u};
    tnd_pcg4d(h);
    return ((h[0] >> 8) + 0.5) / 16777216.0;
}

/* The standard normal quantile (Acklam's rational approximations, relative error 1.2e-9). */
static double normal_quantile(double u)
{
    static const double a[6] = {-3.969683028665376e+01, 2.209460984245205e+02,
                                -2.759285104469687e+02, 1.383577518672690e+02,
                                -3.066479806614716e+01, 2.506628277459239e+00};
    static const double b[5] = {-5.447609879822406e+01, 1.615858368580409e+02,
                                -1.556989798598866e+02, 6.680131188771972e+01,
                                -1.328068155288572e+01};
    static const double c[6] = {-7.784894002430293e-03, -3.223964580411365e-01,
                                -2.400758277161838e+00, -2.549732539343734e+00,
                                4.374664141464968e+00, 2.938163982698783e+00};
    static const double d[4] = {7.784695709041462e-03, 3.224671290700398e-01,
                                2.445134137142996e+00, 3.754408661907416e+00};
    if (u < 0.02425 || u > 1 - 0.02425) {
        double t = sqrt(-2 * log(u < 0.5 ? u : 1 - u));
        double x = (((((c[0] * t + c[1]) * t + c[2]) * t + c[3]) * t + c[4]) * t + c[5]) /
                   ((((d[0] * t + d[1]) * t + d[2]) * t + d[3]) * t + 1);
        return u < 0.5 ? x : -x;
    }
    double t = u - 0.5, r = t * t;
    return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * t /
           (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1);
}

/* The inverse CDF at u of the number of hits in n trials of probability p: the normal
 * approximation with continuity correction where the variance is large, else exact by
 * summation over the rarer outcome (at most about 50 terms). */
static double binomial_icdf(double n, double p, double u)
{
    double mean = n * p, var = mean * (1.0 - p);
    if (var > 25.0) {
        double k = floor(mean + sqrt(var) * normal_quantile(u) + 0.5);
        return k < 0 ? 0 : k > n ? n : k;
    }
    if (p > 0.5) /* (the misses: K = n - F, F of probability 1 - p, at 1 - u) */
        return n - binomial_icdf(n, 1.0 - p, 1.0 - u);
    double pk = pow(1.0 - p, n), cdf = pk; /* P(0) */
    double k = 0;
    while (cdf < u && k < n) {
        pk *= (n - k) / (k + 1) * p / (1.0 - p);
        k += 1;
        cdf += pk;
    }
    return k;
}

void ev_worth_model(const ev_image *ref, double n, uint32_t frame, float *rgb)
{
    size_t px = (size_t)ref->width * ref->height;
    /* (fewer than one sample: one sample of n times the variance, a continuous extension) */
    double scale = n < 1.0 ? 1.0 / n : 1.0;
    n = n < 1.0 ? 1.0 : n;
#pragma omp parallel for schedule(static)
    for (size_t q = 0; q < px; q++) {
        const float *r = ref->rgb + 3 * q;
        double y = luma(r), v = ref->var[q] * scale;
        /* one sample: y / p with probability p, else 0 (mean y, variance v) */
        double p = y > 0 ? y * y / (y * y + v) : 1.0;
        double f = p < 1.0 ? binomial_icdf(n, p, uniform_draw((uint32_t)q, frame)) / (n * p) : 1.0;
        for (int k = 0; k < 3; k++)
            rgb[3 * q + k] = (float)(r[k] * f);
    }
}

tnd_result ev_worth_flip(const ev_image *ref, const float *tr, double exposure, double ppd,
                         double flip, uint32_t frame, float *scratch, double *n_out)
{
    tnd_result res = TND_OK;
    uint32_t w = ref->width, h = ref->height;
    size_t n = (size_t)w * h;
    ev_image avg = {w, h, scratch, NULL};
    float *ta = scratch + 3 * n;
    double lo = -4.0, hi = 24.0; /* log2 N */
    for (int it = 0; it < 12; it++) { /* (the bounds first, then 10 halvings) */
        double l2 = it == 0 ? lo : it == 1 ? hi : 0.5 * (lo + hi), nn = exp2(l2);
        ev_worth_model(ref, nn, frame, avg.rgb);
        ev_tonemap(&avg, exposure, ta);
        double m;
        TND_TRY(ev_flip(tr, ta, w, h, ppd, NULL, &m));
        if (it == 0 && m <= flip) { /* worse than a sixteenth of a sample */
            *n_out = exp2(lo);
            return TND_OK;
        }
        if (it == 1 && m >= flip) { /* better than 2^24 samples */
            *n_out = exp2(hi);
            return TND_OK;
        }
        if (it >= 2)
            *(m > flip ? &lo : &hi) = l2;
    }
    *n_out = exp2(0.5 * (lo + hi));
fail:
    return res;
}

tnd_result ev_sequence_add(ev_sequence *s, uint32_t frame, const ev_image *out, const ev_image *ref,
                           ev_frame_metrics *f, float *flip_map)
{
    tnd_result res = TND_OK;
    if (out->width != s->w || out->height != s->h || ref->width != s->w || ref->height != s->h)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "eval: frame %u is %ux%u against %ux%u, expected %ux%u",
                        frame, out->width, out->height, ref->width, ref->height, s->w, s->h);
    if (s->count == s->cap) {
        uint32_t cap = s->cap ? 2 * s->cap : 64;
        lag_stats *l = realloc(s->lag, cap * sizeof *l);
        if (!l)
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
        s->lag = l;
        s->cap = cap;
    }
    size_t n = (size_t)s->w * s->h;
    memset(f, 0, sizeof *f);
    f->frame = frame;
    const float *o = out->rgb, *r = ref->rgb;
    ev_tonemap(out, s->exposure, s->to);
    ev_tonemap(ref, s->exposure, s->tr);
    if (s->gpu) { /* (the tone-mapped images on the CPU too: the temporal metrics read them) */
        ev_gpu_metrics gm;
        TND_TRY(ev_gpu_frame(s->gpu, out, ref, s->exposure, &gm, flip_map));
        f->relmse = gm.relmse, f->smape = gm.smape, f->rmse = gm.rmse, f->psnr = gm.psnr;
        f->ssim = gm.ssim, f->flip = gm.flip;
    } else {
        f->relmse = ev_relmse(o, r, n * 3);
        f->smape = ev_smape(o, r, n * 3);
        f->rmse = sqrt(ev_mse(o, r, n * 3));
        f->psnr = ev_psnr(ev_mse(s->to, s->tr, n * 3));
        TND_TRY(ev_ssim(s->to, s->tr, s->w, s->h, &f->ssim));
        TND_TRY(ev_flip(s->tr, s->to, s->w, s->h, s->ppd, flip_map, &f->flip));
    }
    f->temporal = -1.0;
    f->mc_temporal = -1.0;
    f->worth_relmse = f->worth_flip = -1.0;
    if (ref->var) {
        double v, e;
        worth_relmse_terms(out, ref, &v, &e);
        f->worth_relmse = e > 0 ? v / e : -1.0;
        s->worth_v += v, s->worth_e += e;
        if (s->worth_flip_next) {
            if (!s->worth_scratch && !(s->worth_scratch = malloc(6 * n * sizeof(float))))
                return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
            TND_TRY(ev_worth_flip(ref, s->tr, s->exposure, s->ppd, f->flip, frame,
                                  s->worth_scratch, &f->worth_flip));
            s->worth_log += log(f->worth_flip);
            s->worth_flips++;
        }
    }
    if (s->have_motion)
        motion_metrics(s, f);
    else
        s->have_prev_depth = false; /* (motion must be given for consecutive frames) */
    if (s->count > 0) {
        double t = 0;
        for (size_t k = 0; k < n * 3; k++)
            t += fabs(((double)s->to[k] - s->po[k]) - ((double)s->tr[k] - s->pr[k]));
        f->temporal = t / (double)(n * 3);
        s->sum.temporal += f->temporal;
        s->temporal_count++;
    }
    lag_stats *l = &s->lag[s->count];
    l->mean = mean_luma(ref);
    l->step = s->count ? mean_abs_luma_diff(ref, &s->prev_ref) : 0.0;
    l->err = mean_abs_luma_diff(out, ref);
    memcpy(s->prev_ref.rgb, ref->rgb, n * 3 * sizeof(float));
    float *swap = s->po;
    s->po = s->to, s->to = swap;
    swap = s->pr;
    s->pr = s->tr, s->tr = swap;
    s->sum.relmse += f->relmse;
    s->sum.smape += f->smape;
    s->sum.rmse += f->rmse;
    s->sum.psnr += f->psnr;
    s->sum.ssim += f->ssim;
    s->sum.flip += f->flip;
    s->count++;
fail:
    return res;
}

void ev_sequence_display(const ev_sequence *s, const float **out, const float **ref)
{
    /* ev_sequence_add swapped them into the previous-frame slots */
    *out = s->po;
    *ref = s->pr;
}

void ev_sequence_summary(const ev_sequence *s, ev_summary *out)
{
    *out = s->sum;
    double k = s->count ? 1.0 / s->count : 0.0;
    out->relmse *= k;
    out->smape *= k;
    out->rmse *= k;
    out->psnr *= k;
    out->ssim *= k;
    out->flip *= k;
    out->temporal = s->temporal_count ? s->sum.temporal / s->temporal_count : -1.0;
    out->changes = lag_of(s->lag, s->count, &out->lag);
    out->mc_temporal = s->mc_count ? s->mc_sum / s->mc_count : -1.0;
    out->worth_relmse = s->worth_e > 0 ? s->worth_v / s->worth_e : -1.0;
    out->worth_flip = s->worth_flips ? exp(s->worth_log / s->worth_flips) : -1.0;
    out->disocclusions = s->lag_events;
    out->disocclusion_lag = s->lag_events ? s->lag_sum / s->lag_events : -1.0;
    out->flicker = out->flicker_ref = -1.0;
    out->static_pixels = 0;
    if (s->ysum && s->yframes >= 3) { /* population standard deviations over the frames */
        double fo = 0, fr = 0, inv = 1.0 / s->yframes;
        for (size_t p = 0; p < (size_t)s->w * s->h; p++) {
            if (!s->still[p])
                continue;
            const double *y = s->ysum + 4 * p;
            fo += sqrt(fmax(0.0, y[1] * inv - (y[0] * inv) * (y[0] * inv)));
            fr += sqrt(fmax(0.0, y[3] * inv - (y[2] * inv) * (y[2] * inv)));
            out->static_pixels++;
        }
        if (out->static_pixels) {
            out->flicker = fo / (double)out->static_pixels;
            out->flicker_ref = fr / (double)out->static_pixels;
        }
    }
}
