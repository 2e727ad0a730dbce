/* core/contract.c: the C side of the buffer contract: entry metadata generated from the table in
 * shaders/contract.h, host frames, quantisation to the packed precision (the exact C mirror of
 * shaders/encoding.h), and derived entries.
 * Entry points: tnd_ct_get, tnd_ct_find, tnd_frame_create/destroy/copy/quantize/derive. */
#include "core/core.h"
#include "shaders/encoding.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CT_KIND_FLOAT    TND_CT_FLOAT
#define CT_KIND_UINT     TND_CT_UINT
#define CT_PACK_F32      TND_PACK_F32
#define CT_PACK_HALF     TND_PACK_HALF
#define CT_PACK_RGBE     TND_PACK_RGBE
#define CT_NEED_REQUIRED TND_NEED_REQUIRED
#define CT_NEED_DEFAULT  TND_NEED_DEFAULT
#define CT_NEED_DERIVED  TND_NEED_DERIVED

#define CT_CHANNELS(...)                                                                           \
    {                                                                                              \
        __VA_ARGS__                                                                                \
    }

static const tnd_ct_info rows[TND_CT_COUNT] = {
#define ROW(ID, bind, nm, comps, kind, pack, vk32, vkp, g32, gp, layer, chans, need, def, sem,     \
            unit, space)                                                                           \
    [bind] = {TND_CT_##ID,                                                                         \
              #nm,                                                                                 \
              comps,                                                                               \
              CT_KIND_##kind,                                                                      \
              CT_PACK_##pack,                                                                      \
              VK_FORMAT_##vk32,                                                                    \
              VK_FORMAT_##vkp,                                                                     \
              #g32,                                                                                \
              #gp,                                                                                 \
              layer,                                                                               \
              CT_CHANNELS chans,                                                                   \
              CT_NEED_##need,                                                                      \
              def,                                                                                 \
              sem,                                                                                 \
              unit,                                                                                \
              space},
    TND_CONTRACT(ROW)
#undef ROW
};

const tnd_ct_info *tnd_ct_get(tnd_ct id)
{
    return (unsigned)id < TND_CT_COUNT ? &rows[id] : NULL;
}

const tnd_ct_info *tnd_ct_find(const char *name)
{
    for (int i = 0; i < TND_CT_COUNT; i++)
        if (strcmp(rows[i].name, name) == 0)
            return &rows[i];
    return NULL;
}

void tnd_ct_exr_name(tnd_ct id, uint32_t c, char *out, size_t cap)
{
    const tnd_ct_info *e = tnd_ct_get(id);
    snprintf(out, cap, "%s.%s", e->exr_layer, c < e->comps ? e->exr_channels[c] : "?");
}

const char *tnd_precision_name(tnd_precision p)
{
    return p == TND_PRECISION_PACKED ? "packed" : "float32";
}

tnd_result tnd_precision_parse(const char *s, tnd_precision *p)
{
    if (strcmp(s, "float32") == 0 || strcmp(s, "f32") == 0)
        *p = TND_PRECISION_F32;
    else if (strcmp(s, "packed") == 0)
        *p = TND_PRECISION_PACKED;
    else
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "contract: precision '%s' (expected float32 or packed)", s);
    return TND_OK;
}

tnd_result tnd_frame_create(uint32_t width, uint32_t height, tnd_frame *f)
{
    memset(f, 0, sizeof *f);
    if (width == 0 || height == 0 || width > 32768 || height > 32768)
        return tnd_fail(TND_ERR_LIMIT, "contract: frame size %ux%u (1..32768 per side)", width,
                        height);
    f->width = width;
    f->height = height;
    size_t n = (size_t)width * height;
    /* One block; each plane starts 5 cache lines further past a 64-byte boundary than the one
     * before, so that the same pixel of different planes falls in different L1 sets: planes
     * at equal offsets modulo 4 KiB (separate page-aligned allocations) make a pass that writes
     * a pixel's G-buffer entries together thrash one set (4x slower stores in a micro-benchmark). */
    size_t offset[TND_CT_COUNT], total = 0;
    for (int i = 0; i < TND_CT_COUNT; i++) {
        offset[i] = total;
        total += (n * tnd_ct_get((tnd_ct)i)->comps * 4 + 63) / 64 * 64 + 5 * 64;
    }
    f->block = aligned_alloc(64, total);
    if (!f->block)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "contract: out of memory for %ux%u frame", width,
                        height);
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
        f->data[i] = (char *)f->block + offset[i];
        if (e->kind == TND_CT_UINT) {
            uint32_t v = (uint32_t)e->default_value, *d = f->data[i];
            for (size_t k = 0; k < n * e->comps; k++)
                d[k] = v;
        } else {
            float v = (float)e->default_value, *d = f->data[i];
            for (size_t k = 0; k < n * e->comps; k++)
                d[k] = v;
        }
    }
    tnd_mat4_identity(f->camera.view);
    tnd_mat4_identity(f->camera.proj);
    tnd_mat4_identity(f->camera.prev_view);
    tnd_mat4_identity(f->camera.prev_proj);
    return TND_OK;
}

tnd_result tnd_frame_copy(const tnd_frame *src, tnd_frame *dst)
{
    if (!dst->block || dst->width != src->width || dst->height != src->height) {
        tnd_frame_destroy(dst);
        tnd_result res = tnd_frame_create(src->width, src->height, dst);
        if (res != TND_OK)
            return res;
    }
    void *block = dst->block, *data[TND_CT_COUNT];
    memcpy(data, dst->data, sizeof data);
    size_t n = (size_t)src->width * src->height;
    for (int i = 0; i < TND_CT_COUNT; i++)
        memcpy(data[i], src->data[i], n * tnd_ct_get((tnd_ct)i)->comps * 4);
    *dst = *src;
    dst->block = block;
    memcpy(dst->data, data, sizeof data);
    return TND_OK;
}

void tnd_frame_destroy(tnd_frame *f)
{
    free(f->block);
    memset(f, 0, sizeof *f);
}

void tnd_frame_quantize(tnd_frame *f, tnd_precision p)
{
    size_t n = (size_t)f->width * f->height;
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
        if (e->kind != TND_CT_FLOAT)
            continue;
        float *d = f->data[i];
        tnd_ct_pack pack = p == TND_PRECISION_PACKED ? e->pack : TND_PACK_F32;
        switch (pack) {
        case TND_PACK_F32:
            for (size_t k = 0; k < n * e->comps; k++)
                d[k] = tnd_sanitize(d[k], 3.4028234663852886e38f);
            break;
        case TND_PACK_HALF:
            for (size_t k = 0; k < n * e->comps; k++)
                d[k] = tnd_half_to_float(tnd_half_from_float(d[k]));
            break;
        case TND_PACK_RGBE:
            for (size_t k = 0; k < n; k++) {
                float *px = d + k * e->comps;
                uint32_t v = tnd_rgbe_encode(px[0], px[1], px[2]);
                for (int c = 0; c < 3; c++)
                    px[c] = tnd_rgbe_channel(v, c);
            }
            break;
        }
    }
    f->precision = p;
}

tnd_result tnd_frame_derive(tnd_frame *f, const char *source)
{
    size_t n = (size_t)f->width * f->height;
    /* A capture without a visibility buffer (another renderer's) still shows surfaces: every
     * pixel whose depth is a hit is surface (instance 0, triangle 0: one "object", so that the
     * back-end's same-instance tests pass and its depth, normal and motion tests alone decide
     * reprojection), the others are misses. Left at its default (all misses) the composite
     * showed only emission, black, and no history was ever kept. */
    if (!f->present[TND_CT_VIS_ID] && f->present[TND_CT_DEPTH]) {
        tnd_debug("contract", "%s: visibility derived from depth (one object)", source);
        uint32_t *vis = tnd_frame_u(f, TND_CT_VIS_ID);
        const float *depth = tnd_frame_f(f, TND_CT_DEPTH);
        for (size_t k = 0; k < n; k++) {
            bool hit = depth[k] < (float)TND_DEPTH_MISS;
            vis[2 * k] = hit ? 0u : TND_VIS_NONE;
            vis[2 * k + 1] = hit ? 0u : TND_VIS_NONE;
        }
        f->present[TND_CT_VIS_ID] = true;
    }
    if (!f->present[TND_CT_GEO_NORMAL] && f->present[TND_CT_NORMAL]) {
        memcpy(f->data[TND_CT_GEO_NORMAL], f->data[TND_CT_NORMAL], n * 3 * sizeof(float));
        f->present[TND_CT_GEO_NORMAL] = true;
    }
    if (!f->present[TND_CT_POSITION] && f->present[TND_CT_DEPTH] && f->has_camera) {
        tnd_debug("contract", "%s: position derived from depth and the camera", source);
        float *pos = tnd_frame_f(f, TND_CT_POSITION), *depth = tnd_frame_f(f, TND_CT_DEPTH);
        for (uint32_t y = 0; y < f->height; y++)
            for (uint32_t x = 0; x < f->width; x++) {
                size_t k = (size_t)y * f->width + x;
                float o[3], d[3];
                tnd_camera_ray(&f->camera, f->width, f->height,
                               (float)x + 0.5f + f->camera.jitter[0],
                               (float)y + 0.5f + f->camera.jitter[1], o, d);
                float t = depth[k] >= (float)TND_DEPTH_MISS ? 0.0f : depth[k];
                for (int c = 0; c < 3; c++)
                    pos[k * 3 + c] = o[c] + t * d[c];
            }
        f->present[TND_CT_POSITION] = true;
    }
    return TND_OK;
}

size_t tnd_ct_markdown(char *buf, size_t cap)
{
    size_t n = 0;
#define PUT(...)                                                                                   \
    do {                                                                                           \
        int w_ = snprintf(buf ? buf + n : NULL, buf && n < cap ? cap - n : 0, __VA_ARGS__);        \
        n += w_ > 0 ? (size_t)w_ : 0;                                                              \
    } while (0)
    PUT("| entry | EXR channels | float32 | packed | need | semantic | unit | space |\n");
    PUT("|---|---|---|---|---|---|---|---|\n");
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *e = &rows[i];
        PUT("| `%s` | ", e->name);
        for (uint32_t c = 0; c < e->comps; c++)
            PUT("%s`%s.%s`", c ? ", " : "", e->exr_layer, e->exr_channels[c]);
        const char *packed = e->kind == TND_CT_UINT     ? "uint32"
                             : e->pack == TND_PACK_HALF ? "half"
                             : e->pack == TND_PACK_RGBE ? "RGBE 9-9-9-5"
                                                        : "float32";
        char need[64];
        if (e->need == TND_NEED_REQUIRED)
            snprintf(need, sizeof need, "required");
        else if (e->need == TND_NEED_DERIVED)
            snprintf(need, sizeof need, "derived");
        else if (e->default_value == 4294967295.0)
            snprintf(need, sizeof need, "default 0xFFFFFFFF");
        else
            snprintf(need, sizeof need, "default %g", e->default_value);
        PUT(" | %s | %s | %s | %s | %s | %s |\n", e->kind == TND_CT_UINT ? "uint32" : "float32",
            packed, need, e->semantic, e->unit, e->space);
    }
#undef PUT
    return n;
}

#define SH_C0 0.282094791773878f
#define SH_C1 0.488602511902920f

/* ---- composite (the back-end's "off" mode, on the CPU) ------------------------------------------------------------------------------- */
void tnd_frame_interleave(const tnd_frame *f, float *rgb)
{
    if (!f->present[TND_CT_PATH])
        return;
    uint32_t w = f->width, h = f->height;
    const uint32_t *path = tnd_frame_u(f, TND_CT_PATH);
    float *src = malloc((size_t)w * h * 3 * sizeof(float));
    if (!src)
        return; /* left as it is: each pixel its own field */
    memcpy(src, rgb, (size_t)w * h * 3 * sizeof(float));
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t q = (size_t)y * w + x;
            if (!(path[q] & TND_PATH_SPLIT))
                continue;
            uint32_t field = path[q] & TND_PATH_REFRACT;
            const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
            float sum[3] = {0, 0, 0}, n = 0;
            for (int k = 0; k < 4; k++) {
                int xx = (int)x + dx[k], yy = (int)y + dy[k];
                if (xx < 0 || yy < 0 || xx >= (int)w || yy >= (int)h)
                    continue;
                size_t r = (size_t)yy * w + (size_t)xx;
                if ((path[r] & TND_PATH_SPLIT) && (path[r] & TND_PATH_REFRACT) != field) {
                    for (int c = 0; c < 3; c++)
                        sum[c] += src[3 * r + c];
                    n += 1;
                }
            }
            if (n > 0)
                for (int c = 0; c < 3; c++)
                    rgb[3 * q + c] = 0.5f * src[3 * q + c] + 0.5f * (sum[c] / n);
        }
    free(src);
}

void tnd_frame_composite(const tnd_frame *f, float *rgb)
{
    size_t n = (size_t)f->width * f->height;
    for (size_t q = 0; q < n; q++) {
        const float *alb = tnd_frame_f(f, TND_CT_ALBEDO) + 3 * q;
        const float *nrm = tnd_frame_f(f, TND_CT_NORMAL) + 3 * q;
        const float *hf = tnd_frame_f(f, TND_CT_HF) + 3 * q;
        const float *sh = tnd_frame_f(f, TND_CT_LF_SH) + 4 * q;
        const float *cc = tnd_frame_f(f, TND_CT_LF_COCG) + 2 * q;
        const float *sp = tnd_frame_f(f, TND_CT_SPEC) + 3 * q;
        const float *thr = tnd_frame_f(f, TND_CT_THROUGHPUT) + 3 * q;
        const float *em = tnd_frame_f(f, TND_CT_EMISSION) + 3 * q;
        float m = tnd_frame_f(f, TND_CT_METALLIC)[q];
        /* SH evaluated at the shading normal: Y = C0 L0 + (2/3) C1 (n . L1) */
        float Y = SH_C0 * sh[3] + (2.0f / 3.0f) * SH_C1 * (nrm[0] * sh[0] + nrm[1] * sh[1] + nrm[2] * sh[2]);
        Y = fmaxf(Y, 0.0f);
        float s = sh[3] / SH_C0; /* the luma the chroma was scaled with */
        float r = s > 0 ? Y / s : 0.0f;
        float co = cc[0] * r, cg = cc[1] * r;
        float t = Y - 0.5f * cg, g = cg + t, b = t - 0.5f * co, rr = b + co;
        float lf[3] = {fmaxf(rr, 0.0f), fmaxf(g, 0.0f), fmaxf(b, 0.0f)};
        for (int k = 0; k < 3; k++) {
            float demod = fmaxf(0.01f, 0.04f * (1.0f - m) + alb[k] * m);
            rgb[3 * q + k] = ((hf[k] + lf[k]) * alb[k] * (1.0f - m) + sp[k] * demod) * thr[k] + em[k];
        }
    }
}
