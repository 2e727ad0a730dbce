/* core/env.c: environment maps (shaders/env.h: convention, layout): a latitude-longitude EXR read
 * into radiance texels and the 2D piecewise-constant distribution both front-ends sample it
 * with; the C side's lookup and sample (the GLSL mirror is in shaders/pt_common.glsl).
 * Entry points: tnd_env_load, tnd_env_from_pixels, tnd_env_free, tnd_env_lookup,
 * tnd_env_sample. */
#include "core/core.h"
#include "shaders/brdf.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void tnd_env_free(tnd_env *e)
{
    free(e->data);
    e->data = NULL;
    e->width = e->height = 0;
}

tnd_result tnd_env_from_pixels(const char *name, const float *rgb, uint32_t w, uint32_t h,
                               float intensity, float rotation_deg, tnd_env *e)
{
    if (w == 0 || h == 0 || w > 32768 || h > 16384)
        return tnd_fail(TND_ERR_BAD_INPUT, "environment: %s: %ux%u texels (1 to 32768 x 16384)",
                        name, w, h);
    if (!(intensity >= 0) || !isfinite(intensity) || !isfinite(rotation_deg))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "environment: %s: intensity %g and rotation %g must be finite (intensity "
                        ">= 0)",
                        name, (double)intensity, (double)rotation_deg);
    float *d = malloc(TND_ENV_FLOATS((size_t)w, (size_t)h) * sizeof *d);
    if (!d)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "environment: %s: out of memory (%ux%u)", name, w,
                        h);
    tnd_env_free(e);
    memset(e, 0, sizeof *e);
    snprintf(e->path, sizeof e->path, "%s", name);
    e->width = w, e->height = h;
    e->intensity = intensity;
    e->rotation = rotation_deg;
    double r = rotation_deg * TND_PI / 180.0;
    e->cos_rot = (float)cos(r), e->sin_rot = (float)sin(r);
    e->data = d;
    /* texels: radiance, bad values counted and set to 0 */
    size_t n = (size_t)w * h;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            float v = rgb[3 * i + k];
            if (!isfinite(v) || v < 0) {
                e->bad_texels++;
                v = 0;
            }
            d[4 * i + k] = v * intensity;
        }
    /* the texel edges (shaders/env.h: tnd_env_refine) */
    float *edges = d + TND_ENV_OFFSET_EDGES(w, h);
    for (uint32_t j = 0; j <= w; j++) {
        double b = 2 * TND_PI * ((double)j / w - 0.5);
        edges[2 * j] = (float)cos(b), edges[2 * j + 1] = (float)sin(b);
    }
    for (uint32_t i = 0; i <= h; i++)
        edges[2 * (w + 1) + i] = (float)cos(TND_PI * i / h);
    /* weights luminance x sin(theta) at the row's centre; row sums in double */
    float *marg = d + TND_ENV_OFFSET_MARGINAL(w, h), *cond = d + TND_ENV_OFFSET_CONDITIONAL(w, h);
    double *row = malloc(h * sizeof *row);
    if (!row) {
        tnd_env_free(e);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "environment: %s: out of memory", name);
    }
    double total = 0, lum_sa = 0;
    for (uint32_t y = 0; y < h; y++) {
        double st = sin(TND_PI * (y + 0.5) / h);
        double band = 2 * TND_PI / w * (cos(TND_PI * y / h) - cos(TND_PI * (y + 1.0) / h));
        double acc = 0;
        float *c = cond + (size_t)y * w;
        for (uint32_t x = 0; x < w; x++) {
            const float *t = d + 4 * ((size_t)y * w + x);
            double l = tnd_luminance(t[0], t[1], t[2]);
            acc += l * st;
            lum_sa += l * band;
            c[x] = (float)acc;
        }
        for (uint32_t x = 0; x < w; x++) /* inclusive cdf of the row; flat 1 when it is dark */
            c[x] = acc > 0 ? (x + 1 == w ? 1.0f : (float)(c[x] / acc)) : 1.0f;
        row[y] = acc;
        total += acc;
    }
    double acc = 0;
    for (uint32_t y = 0; y < h; y++) {
        acc += row[y];
        marg[y] = total > 0 ? (y + 1 == h ? 1.0f : (float)(acc / total)) : 1.0f;
    }
    for (uint32_t y = 0; y < h; y++) {
        double st = sin(TND_PI * (y + 0.5) / h);
        for (uint32_t x = 0; x < w; x++) {
            float *t = d + 4 * ((size_t)y * w + x);
            double l = tnd_luminance(t[0], t[1], t[2]);
            t[3] = total > 0 ? (float)(l * st / total * (double)w * h) : 0.0f;
        }
    }
    free(row);
    e->mean_luminance = lum_sa / (4 * TND_PI);
    return TND_OK;
}

tnd_result tnd_env_load(const char *path, float intensity, float rotation_deg, tnd_env *e)
{
    tnd_exr_file f = {0};
    TND_TRY_RETURN(tnd_exr_read(path, &f));
    tnd_result res = TND_OK;
    const tnd_exr_channel *ch[3] = {tnd_exr_find(&f, "R"), tnd_exr_find(&f, "G"),
                                    tnd_exr_find(&f, "B")};
    float *rgb = NULL;
    if (!ch[0] || !ch[1] || !ch[2] || !ch[0]->data || !ch[1]->data || !ch[2]->data ||
        ch[0]->type == TND_EXR_UINT || ch[1]->type == TND_EXR_UINT ||
        ch[2]->type == TND_EXR_UINT) {
        res = tnd_fail(TND_ERR_BAD_INPUT,
                       "environment: %s: not an RGB image (needs full-resolution half or float "
                       "channels R, G and B; it has %u channel%s%s%s)",
                       path, f.channel_count, f.channel_count == 1 ? "" : "s",
                       f.channel_count ? ", the first " : "",
                       f.channel_count ? f.channels[0].name : "");
        goto done;
    }
    if (f.width != 2 * f.height) {
        res = tnd_fail(TND_ERR_BAD_INPUT,
                       "environment: %s: %ux%u is not a latitude-longitude image (width must be "
                       "twice the height)",
                       path, f.width, f.height);
        goto done;
    }
    size_t n = (size_t)f.width * f.height;
    rgb = malloc(3 * n * sizeof *rgb);
    if (!rgb) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "environment: %s: out of memory", path);
        goto done;
    }
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            rgb[3 * i + k] = ((const float *)ch[k]->data)[i];
    res = tnd_env_from_pixels(path, rgb, f.width, f.height, intensity, rotation_deg, e);
    if (res == TND_OK && e->bad_texels)
        tnd_warn("scene", "environment %s: %u texel value%s NaN, infinite or negative: set to 0",
                 path, e->bad_texels, e->bad_texels == 1 ? " was" : "s were");
done:
    free(rgb);
    tnd_exr_close(&f);
    return res;
}

/* texel index of a world direction, and its sin theta */
static size_t env_texel(const tnd_env *e, const float dir[3], float *st)
{
    float x = e->cos_rot * dir[0] - e->sin_rot * dir[2];
    float z = e->sin_rot * dir[0] + e->cos_rot * dir[2];
    float y = fminf(fmaxf(dir[1], -1.0f), 1.0f);
    float u = atan2f(z, x) * (float)(0.5 * TND_INV_PI) + 0.5f;
    float v = acosf(y) * (float)TND_INV_PI;
    uint32_t cx = (uint32_t)fmaxf(u * (float)e->width, 0.0f);
    uint32_t cy = (uint32_t)fmaxf(v * (float)e->height, 0.0f);
    cx = cx < e->width ? cx : e->width - 1;
    cy = cy < e->height ? cy : e->height - 1;
    tnd_env_refine(e->data, e->width, e->height, x, y, z, &cx, &cy);
    *st = sqrtf(fmaxf(0.0f, 1.0f - y * y));
    return (size_t)cy * e->width + cx;
}

float tnd_env_lookup(const tnd_env *e, const float dir[3], float rgb[3])
{
    float st;
    const float *t = e->data + 4 * env_texel(e, dir, &st);
    rgb[0] = t[0], rgb[1] = t[1], rgb[2] = t[2];
    return tnd_env_pdf(t[3], st);
}

float tnd_env_sample(const tnd_env *e, float u1, float u2, float dir[3], float rgb[3])
{
    uint32_t w = e->width, h = e->height;
    const float *env_data = e->data;
    uint32_t mo = TND_ENV_OFFSET_MARGINAL(w, h);
    uint32_t y = tnd_env_find(env_data, mo, h, u1);
    float fv = tnd_env_remap(env_data, mo, y, u1);
    uint32_t co = TND_ENV_OFFSET_CONDITIONAL(w, h) + y * w;
    uint32_t x = tnd_env_find(env_data, co, w, u2);
    float fu = tnd_env_remap(env_data, co, x, u2);
    float u = ((float)x + fu) / (float)w, v = ((float)y + fv) / (float)h;
    float th = (float)TND_PI * v, ph = 2.0f * (float)TND_PI * (u - 0.5f);
    float st = sinf(th), ct = cosf(th);
    float lx = cosf(ph) * st, lz = sinf(ph) * st;
    dir[0] = e->cos_rot * lx + e->sin_rot * lz;
    dir[1] = ct;
    dir[2] = -e->sin_rot * lx + e->cos_rot * lz;
    const float *t = env_data + 4 * ((size_t)y * w + x);
    rgb[0] = t[0], rgb[1] = t[1], rgb[2] = t[2];
    return tnd_env_pdf(t[3], st);
}
