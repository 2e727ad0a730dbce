/* core/capture.c: the contract as one multi-channel EXR per frame (docs/captures.md), and
 * A-SVGF's gradient samples beside it. Other renderers' EXRs: capture_map.c.
 *
 * Camera attributes: tandem.view, tandem.proj, tandem.prevView, tandem.prevProj (m44f: the
 * column-major array verbatim, which is Imath's row-vector convention), tandem.jitter (v2f,
 * pixels), tandem.frame (int), tandem.contractVersion (int), tandem.precision (string).
 * Entry points: tnd_capture_write, tnd_capture_read, tnd_gradient_samples_*,
 * tnd_capture_gradients_path, tnd_capture_write_gradients, tnd_capture_read_gradients. */
#include "core/capture_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void cap_problem_add(cap_problems *p, const char *fmt, ...)
{
    size_t l = strlen(p->text);
    if (l + 8 < sizeof p->text) {
        p->text[l++] = '\n';
        p->text[l++] = ' ';
        p->text[l++] = ' ';
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(p->text + l, sizeof p->text - l, fmt, ap);
        va_end(ap);
    }
    p->count++;
}

/* The frame's present entries as channels, the camera and `extra` (channels and attributes of
 * the caller's) beside them. */
static tnd_result write_frame(const char *path, const tnd_frame *f, const tnd_exr_channel_desc *xc,
                              uint32_t nxc, const tnd_exr_attr *xa, uint32_t nxa,
                              tnd_exr_compression c)
{
    tnd_exr_channel_desc ch[TND_CT_COUNT * 4 + 4];
    char names[TND_CT_COUNT * 4][64];
    uint32_t n = 0;
    for (int i = 0; i < TND_CT_COUNT; i++) {
        if (!f->present[i])
            continue;
        const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
        tnd_exr_type t = e->kind == TND_CT_UINT ? TND_EXR_UINT
                         : (f->precision == TND_PRECISION_PACKED && e->pack == TND_PACK_HALF)
                             ? TND_EXR_HALF
                             : TND_EXR_FLOAT;
        for (uint32_t k = 0; k < e->comps; k++) {
            tnd_ct_exr_name((tnd_ct)i, k, names[n], sizeof names[n]);
            ch[n] = (tnd_exr_channel_desc){names[n], t, (const uint32_t *)f->data[i] + k, e->comps};
            n++;
        }
    }
    if (n == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "capture: %s: frame has no entries", path);
    for (uint32_t k = 0; k < nxc && k < 4; k++)
        ch[n++] = xc[k];
    tnd_exr_attr at[12] = {
        {.name = "tandem.contractVersion", .type = TND_ATTR_INT, .i = TND_CONTRACT_VERSION},
        {.name = "tandem.precision",
         .type = TND_ATTR_STRING,
         .s = tnd_precision_name(f->precision)},
    };
    uint32_t na = 2;
    if (f->has_camera) {
        at[na++] = (tnd_exr_attr){
            .name = "tandem.frame", .type = TND_ATTR_INT, .i = (int32_t)f->camera.frame_index};
        at[na] = (tnd_exr_attr){.name = "tandem.jitter", .type = TND_ATTR_V2F};
        memcpy(at[na++].f, f->camera.jitter, sizeof f->camera.jitter);
        const char *mn[4] = {"tandem.view", "tandem.proj", "tandem.prevView", "tandem.prevProj"};
        const float *mv[4] = {f->camera.view, f->camera.proj, f->camera.prev_view,
                              f->camera.prev_proj};
        for (int m = 0; m < 4; m++) {
            at[na] = (tnd_exr_attr){.name = mn[m], .type = TND_ATTR_M44F};
            memcpy(at[na++].f, mv[m], 16 * sizeof(float));
        }
    }
    if (f->gradients)
        at[na++] = (tnd_exr_attr){.name = "tandem.gradients", .type = TND_ATTR_INT, .i = 1};
    for (uint32_t k = 0; k < nxa && na < 12; k++)
        at[na++] = xa[k];
    return tnd_exr_write(path, f->width, f->height, ch, n, at, na, c);
}

tnd_result tnd_capture_write(const char *path, const tnd_frame *f, tnd_exr_compression c)
{
    return write_frame(path, f, NULL, 0, NULL, 0, c);
}

/* Count non-finite values of a float channel; report the first one's pixel. */
static void check_finite(cap_problems *p, const char *name, const float *d, uint32_t w, uint32_t h)
{
    size_t bad = 0, first = 0;
    for (size_t k = 0; k < (size_t)w * h; k++)
        if (!isfinite(d[k]) && bad++ == 0)
            first = k;
    if (bad)
        cap_problem_add(p, "channel '%s': %zu non-finite value%s (first at pixel %zu,%zu: %g)",
                        name, bad, bad == 1 ? "" : "s", first % w, first / w, (double)d[first]);
}

void cap_read_tandem_camera(const tnd_exr_file *x, tnd_frame *f)
{
    int32_t frame = 0;
    f->has_camera = tnd_exr_attr_m44f(x, "tandem.view", f->camera.view) &&
                    tnd_exr_attr_m44f(x, "tandem.proj", f->camera.proj) &&
                    tnd_exr_attr_m44f(x, "tandem.prevView", f->camera.prev_view) &&
                    tnd_exr_attr_m44f(x, "tandem.prevProj", f->camera.prev_proj);
    if (tnd_exr_attr_int(x, "tandem.frame", &frame))
        f->camera.frame_index = (uint32_t)frame;
    tnd_exr_attr_v2f(x, "tandem.jitter", f->camera.jitter);
}

/* The contract of an open Tandem EXR (a capture or its gradient samples) into f, validated;
 * `derive`: fill the derived entries it lacks (not for samples: their pixels are not a grid). */
static tnd_result read_frame(const tnd_exr_file *xp, const char *path, bool derive, tnd_frame *f)
{
    const tnd_exr_file x = *xp;
    tnd_result res = TND_OK;
    memset(f, 0, sizeof *f);
    cap_problems p = {{0}, 0};
    int32_t version = 0, grad = 0;
    if (!tnd_exr_attr_int(&x, "tandem.contractVersion", &version)) {
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "capture: %s: not a Tandem capture (no tandem.contractVersion; other "
                        "renderers' files need a mapping: --map)",
                        path);
    }
    /* version 1 lacks only the path flags (a DEFAULT entry: 0, no specular chain) */
    if (version < 1 || version > TND_CONTRACT_VERSION) {
        return tnd_fail(TND_ERR_UNSUPPORTED,
                        "capture: %s: contract version %d (this Tandem reads 1 to %d)", path,
                        version, TND_CONTRACT_VERSION);
    }
    TND_TRY(tnd_frame_create(x.width, x.height, f));
    char prec[32] = "float32";
    tnd_exr_attr_string(&x, "tandem.precision", prec, sizeof prec);
    if (tnd_precision_parse(prec, &f->precision) != TND_OK)
        cap_problem_add(&p, "attribute 'tandem.precision': '%s'", prec);
    cap_read_tandem_camera(&x, f);
    f->gradients = tnd_exr_attr_int(&x, "tandem.gradients", &grad) && grad == 1;
    size_t npx = (size_t)x.width * x.height;
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
        const tnd_exr_channel *chs[4] = {0};
        uint32_t found = 0;
        char nm[4][64];
        for (uint32_t k = 0; k < e->comps; k++) {
            tnd_ct_exr_name((tnd_ct)i, k, nm[k], sizeof nm[k]);
            chs[k] = tnd_exr_find(&x, nm[k]);
            found += chs[k] != NULL;
        }
        if (found == 0) {
            if (e->need == TND_NEED_REQUIRED)
                cap_problem_add(&p, "entry '%s': missing (channels %s%s%s%s%s%s%s)", e->name, nm[0],
                            e->comps > 1 ? ", " : "", e->comps > 1 ? nm[1] : "",
                            e->comps > 2 ? ", " : "", e->comps > 2 ? nm[2] : "",
                            e->comps > 3 ? ", " : "", e->comps > 3 ? nm[3] : "");
            continue;
        }
        bool ok = true;
        for (uint32_t k = 0; k < e->comps; k++) {
            const tnd_exr_channel *c = chs[k];
            if (!c) {
                cap_problem_add(&p, "channel '%s': missing (entry '%s' is partly present)", nm[k],
                            e->name);
                ok = false;
                continue;
            }
            bool want_uint = e->kind == TND_CT_UINT;
            if (want_uint != (c->type == TND_EXR_UINT)) {
                cap_problem_add(&p, "channel '%s': wrong type %s (expected %s)", nm[k],
                            c->type == TND_EXR_UINT   ? "UINT"
                            : c->type == TND_EXR_HALF ? "HALF"
                                                      : "FLOAT",
                            want_uint ? "UINT" : "HALF or FLOAT");
                ok = false;
                continue;
            }
            if (!c->data) {
                cap_problem_add(&p, "channel '%s': wrong size (subsampled %dx%d; expected %ux%u)",
                            nm[k], c->x_sampling, c->y_sampling, x.width, x.height);
                ok = false;
                continue;
            }
            if (!want_uint) {
                size_t before = (size_t)p.count;
                check_finite(&p, nm[k], c->data, x.width, x.height);
                ok &= (size_t)p.count == before;
            }
        }
        if (!ok)
            continue;
        uint32_t *dst = f->data[i];
        for (uint32_t k = 0; k < e->comps; k++) {
            const uint32_t *src = chs[k]->data;
            for (size_t q = 0; q < npx; q++)
                dst[q * e->comps + k] = src[q];
        }
        f->present[i] = true;
    }
    if (p.count) {
        res = tnd_fail(TND_ERR_BAD_INPUT, "capture: %s: %d problem%s:%s", path, p.count,
                       p.count == 1 ? "" : "s", p.text);
        goto fail;
    }
    if (derive)
        TND_TRY(tnd_frame_derive(f, path));
    return TND_OK;
fail:
    tnd_frame_destroy(f);
    return res;
}

tnd_result tnd_capture_read(const char *path, tnd_frame *f)
{
    tnd_exr_file x;
    memset(f, 0, sizeof *f);
    tnd_result res = tnd_exr_read(path, &x);
    if (res == TND_OK)
        res = read_frame(&x, path, true, f);
    tnd_exr_close(&x);
    return res;
}

/* ---- gradient samples ------------------------------------------------------------------------ */
void tnd_gradient_samples_free(tnd_gradient_samples *g)
{
    free(g->pixel);
    tnd_frame_destroy(&g->values);
    memset(g, 0, sizeof *g);
}

tnd_result tnd_gradient_samples_gather(const tnd_frame *f, const uint32_t *pixels, uint32_t count,
                                       tnd_gradient_samples *g)
{
    tnd_result res = TND_OK;
    memset(g, 0, sizeof *g);
    if (count == 0)
        return TND_OK;
    g->pixel = malloc((size_t)count * sizeof *g->pixel);
    if (!g->pixel)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "capture: out of memory for %u gradient samples",
                        count);
    TND_TRY(tnd_frame_create(count, 1, &g->values));
    g->count = count;
    g->values.precision = f->precision;
    for (int i = 0; i < TND_CT_COUNT; i++) {
        g->values.present[i] = f->present[i];
        size_t sz = tnd_ct_get((tnd_ct)i)->comps * sizeof(uint32_t);
        for (uint32_t k = 0; k < count; k++) {
            if (pixels[k] >= f->width * f->height) {
                res = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                               "capture: gradient sample %u: pixel %u outside the %ux%u frame", k,
                               pixels[k], f->width, f->height);
                goto fail;
            }
            memcpy((char *)g->values.data[i] + k * sz, (const char *)f->data[i] + pixels[k] * sz,
                   sz);
        }
    }
    memcpy(g->pixel, pixels, (size_t)count * sizeof *pixels);
    return TND_OK;
fail:
    tnd_gradient_samples_free(g);
    return res;
}

void tnd_gradient_samples_apply(const tnd_gradient_samples *g, tnd_frame *f)
{
    for (int i = 0; i < TND_CT_COUNT; i++) {
        if (!g->values.present[i] || !f->present[i])
            continue;
        size_t sz = tnd_ct_get((tnd_ct)i)->comps * sizeof(uint32_t);
        for (uint32_t k = 0; k < g->count; k++)
            memcpy((char *)f->data[i] + (size_t)g->pixel[k] * sz,
                   (const char *)g->values.data[i] + k * sz, sz);
    }
}

static const char gradients_suffix[] = ".gradients.exr";

void tnd_capture_gradients_path(const char *capture, char *out, size_t cap)
{
    size_t l = strlen(capture);
    if (l > 4 && strcmp(capture + l - 4, ".exr") == 0)
        l -= 4;
    snprintf(out, cap, "%.*s%s", (int)l, capture, gradients_suffix);
}

bool tnd_capture_is_gradients_file(const char *name)
{
    size_t l = strlen(name), s = sizeof gradients_suffix - 1;
    return l >= s && strcmp(name + l - s, gradients_suffix) == 0;
}

tnd_result tnd_capture_write_gradients(const char *path, const tnd_gradient_samples *g,
                                       uint32_t frame_width, uint32_t frame_height,
                                       tnd_exr_compression c)
{
    if (g->count == 0)
        return TND_OK;
    tnd_exr_channel_desc pc = {"gradient.pixel", TND_EXR_UINT, g->pixel, 1};
    tnd_exr_attr at[2] = {
        {.name = "tandem.frameWidth", .type = TND_ATTR_INT, .i = (int32_t)frame_width},
        {.name = "tandem.frameHeight", .type = TND_ATTR_INT, .i = (int32_t)frame_height},
    };
    return write_frame(path, &g->values, &pc, 1, at, 2, c);
}

tnd_result tnd_capture_read_gradients(const char *path, uint32_t frame_width,
                                      uint32_t frame_height, tnd_gradient_samples *g)
{
    tnd_exr_file x;
    memset(g, 0, sizeof *g);
    tnd_result res = tnd_exr_read(path, &x);
    if (res != TND_OK)
        return res;
    int32_t fw = 0, fh = 0;
    const tnd_exr_channel *pc = tnd_exr_find(&x, "gradient.pixel");
    if (!pc || pc->type != TND_EXR_UINT || !pc->data || x.height != 1 ||
        !tnd_exr_attr_int(&x, "tandem.frameWidth", &fw) ||
        !tnd_exr_attr_int(&x, "tandem.frameHeight", &fh)) {
        res = tnd_fail(TND_ERR_BAD_INPUT,
                       "capture: %s: not a Tandem capture's gradient samples (a single row with a "
                       "UINT channel 'gradient.pixel' and tandem.frameWidth/Height expected)",
                       path);
        goto fail;
    }
    if ((uint32_t)fw != frame_width || (uint32_t)fh != frame_height) {
        res = tnd_fail(TND_ERR_BAD_INPUT, "capture: %s: gradient samples of a %dx%d frame, the "
                       "frame is %ux%u", path, fw, fh, frame_width, frame_height);
        goto fail;
    }
    TND_TRY(read_frame(&x, path, false, &g->values));
    g->count = x.width;
    g->pixel = malloc((size_t)g->count * sizeof *g->pixel);
    if (!g->pixel) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "capture: %s: out of memory", path);
        goto fail;
    }
    memcpy(g->pixel, pc->data, (size_t)g->count * sizeof *g->pixel);
    for (uint32_t k = 0; k < g->count; k++)
        if (g->pixel[k] >= frame_width * frame_height) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "capture: %s: sample %u: pixel %u outside the "
                           "%ux%u frame", path, k, g->pixel[k], frame_width, frame_height);
            goto fail;
        }
    tnd_exr_close(&x);
    return TND_OK;
fail:
    tnd_exr_close(&x);
    tnd_gradient_samples_free(g);
    return res;
}
