/* core/capture.c: the contract as one multi-channel EXR per frame, and foreign EXRs read through
 * a JSON channel mapping (docs/captures.md).
 *
 * Camera attributes: tandem.view, tandem.proj, tandem.prevView, tandem.prevProj (m44f: the
 * column-major array verbatim, which is Imath's row-vector convention), tandem.jitter (v2f,
 * pixels), tandem.frame (int), tandem.contractVersion (int), tandem.precision (string).
 * Entry points: tnd_capture_write, tnd_capture_read, tnd_capture_map_load/destroy,
 * tnd_capture_read_mapped. */
#include "core/core.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* Problems found while validating, reported together. */
typedef struct problems {
    char text[3500];
    int count;
} problems;

static void add_problem(problems *p, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void add_problem(problems *p, const char *fmt, ...)
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

/* Count non-finite values of a float channel; report the first one's pixel. */
static void check_finite(problems *p, const char *name, const float *d, uint32_t w, uint32_t h)
{
    size_t bad = 0, first = 0;
    for (size_t k = 0; k < (size_t)w * h; k++)
        if (!isfinite(d[k]) && bad++ == 0)
            first = k;
    if (bad)
        add_problem(p, "channel '%s': %zu non-finite value%s (first at pixel %zu,%zu: %g)", name,
                    bad, bad == 1 ? "" : "s", first % w, first / w, (double)d[first]);
}

static void read_camera(const tnd_exr_file *x, tnd_frame *f)
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
    problems p = {{0}, 0};
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
        add_problem(&p, "attribute 'tandem.precision': '%s'", prec);
    read_camera(&x, f);
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
                add_problem(&p, "entry '%s': missing (channels %s%s%s%s%s%s%s)", e->name, nm[0],
                            e->comps > 1 ? ", " : "", e->comps > 1 ? nm[1] : "",
                            e->comps > 2 ? ", " : "", e->comps > 2 ? nm[2] : "",
                            e->comps > 3 ? ", " : "", e->comps > 3 ? nm[3] : "");
            continue;
        }
        bool ok = true;
        for (uint32_t k = 0; k < e->comps; k++) {
            const tnd_exr_channel *c = chs[k];
            if (!c) {
                add_problem(&p, "channel '%s': missing (entry '%s' is partly present)", nm[k],
                            e->name);
                ok = false;
                continue;
            }
            bool want_uint = e->kind == TND_CT_UINT;
            if (want_uint != (c->type == TND_EXR_UINT)) {
                add_problem(&p, "channel '%s': wrong type %s (expected %s)", nm[k],
                            c->type == TND_EXR_UINT   ? "UINT"
                            : c->type == TND_EXR_HALF ? "HALF"
                                                      : "FLOAT",
                            want_uint ? "UINT" : "HALF or FLOAT");
                ok = false;
                continue;
            }
            if (!c->data) {
                add_problem(&p, "channel '%s': wrong size (subsampled %dx%d; expected %ux%u)",
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

/* ---- mappings ------------------------------------------------------------------------------- */
#define MAP_ALTS 4
typedef struct map_entry {
    bool fed;
    /* per component: up to MAP_ALTS candidate channel names (first found wins); none = constant */
    char chan[4][MAP_ALTS][128];
    int alts[4];
    float scale[4], offset[4];
    bool normalize;
    bool planar_to_distance;
    float miss_at; /* depth: values >= this (and <= 0) mean "no hit"; 0 = only non-positive */
    int divide_by; /* contract entry or -1 */
    int subtract;  /* contract entry or -1: taken off before divide_by (emission out of radiance) */
    bool on_miss;  /* where depth is a miss the entry reads miss_chan instead (the background) */
    char miss_chan[4][MAP_ALTS][128];
    int miss_alts[4];
} map_entry;

struct tnd_capture_map {
    char path[1024];
    char name[256];
    char prefix[128];
    float xfov, yfov; /* radians, 0 = unknown */
    map_entry e[TND_CT_COUNT];
};

static tnd_result map_error(const char *path, const char *what)
{
    return tnd_fail(TND_ERR_BAD_INPUT, "mapping: %s: %s", path, what);
}

/* One component's channel: a name, or a list of alternatives (the first present wins), into
 * names[0..*alts); false for anything else (null: a constant, for the caller to allow). */
static bool parse_alts(const cJSON *c, char names[MAP_ALTS][128], int *alts)
{
    *alts = 0;
    if (cJSON_IsString(c)) {
        snprintf(names[0], 128, "%s", c->valuestring);
        *alts = 1;
        return true;
    }
    if (!cJSON_IsArray(c))
        return false;
    const cJSON *a;
    cJSON_ArrayForEach(a, c)
    {
        if (cJSON_IsString(a) && *alts < MAP_ALTS)
            snprintf(names[(*alts)++], 128, "%s", a->valuestring);
    }
    return true;
}

/* The first of a component's alternatives present in the file (its full name into full), or
 * NULL. */
static const tnd_exr_channel *find_alt(const tnd_exr_file *x, const char *prefix,
                                       const char names[MAP_ALTS][128], int alts, char *full,
                                       size_t cap)
{
    const tnd_exr_channel *c = NULL;
    for (int a = 0; a < alts && !c; a++) {
        snprintf(full, cap, "%s%s", prefix, names[a]);
        c = tnd_exr_find(x, full);
    }
    return c;
}

tnd_result tnd_capture_map_load(const char *path, tnd_capture_map **out)
{
    tnd_result res = TND_OK;
    void *text = NULL;
    size_t size;
    cJSON *root = NULL;
    char msg[512];
    *out = NULL;
    tnd_capture_map *m = calloc(1, sizeof *m);
    if (!m)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "mapping: out of memory");
    snprintf(m->path, sizeof m->path, "%s", path);
    TND_TRY(tnd_file_read(path, &text, &size));
    root = cJSON_ParseWithLength(text, size);
    if (!root) {
        res = map_error(path, "not valid JSON");
        goto fail;
    }
    const cJSON *ver = cJSON_GetObjectItemCaseSensitive(root, "tandem_mapping");
    if (!cJSON_IsNumber(ver) || ver->valueint != 1) {
        res = map_error(path, "\"tandem_mapping\": 1 expected (the mapping format version)");
        goto fail;
    }
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(root, "name");
    snprintf(m->name, sizeof m->name, "%s", cJSON_IsString(s) ? s->valuestring : path);
    s = cJSON_GetObjectItemCaseSensitive(root, "prefix");
    if (s && !cJSON_IsString(s)) {
        res = map_error(path, "\"prefix\" must be a string");
        goto fail;
    }
    snprintf(m->prefix, sizeof m->prefix, "%s", s ? s->valuestring : "");
    const cJSON *cam = cJSON_GetObjectItemCaseSensitive(root, "camera");
    if (cam) {
        const cJSON *xf = cJSON_GetObjectItemCaseSensitive(cam, "xfov_degrees");
        const cJSON *yf = cJSON_GetObjectItemCaseSensitive(cam, "yfov_degrees");
        if (cJSON_IsNumber(xf))
            m->xfov = (float)(xf->valuedouble * TND_PI / 180.0);
        if (cJSON_IsNumber(yf))
            m->yfov = (float)(yf->valuedouble * TND_PI / 180.0);
    }
    const cJSON *entries = cJSON_GetObjectItemCaseSensitive(root, "entries");
    if (!cJSON_IsObject(entries)) {
        res = map_error(path, "\"entries\" object expected");
        goto fail;
    }
    for (int i = 0; i < TND_CT_COUNT; i++)
        m->e[i].divide_by = m->e[i].subtract = -1;
    const cJSON *it;
    cJSON_ArrayForEach(it, entries)
    {
        const tnd_ct_info *ci = tnd_ct_find(it->string);
        if (!ci) {
            snprintf(msg, sizeof msg, "entry '%s' is not a contract entry", it->string);
            res = map_error(path, msg);
            goto fail;
        }
        map_entry *me = &m->e[ci->id];
        const cJSON *chans = cJSON_GetObjectItemCaseSensitive(it, "channels");
        if (!cJSON_IsArray(chans) || cJSON_GetArraySize(chans) != (int)ci->comps) {
            snprintf(msg, sizeof msg, "entry '%s': \"channels\" must list %u channel(s)", ci->name,
                     ci->comps);
            res = map_error(path, msg);
            goto fail;
        }
        for (uint32_t k = 0; k < ci->comps; k++) {
            const cJSON *c = cJSON_GetArrayItem(chans, (int)k);
            me->scale[k] = 1.0f;
            if (!parse_alts(c, me->chan[k], &me->alts[k]) && !cJSON_IsNull(c)) {
                snprintf(msg, sizeof msg,
                         "entry '%s': channel %u must be a name, a list of names or null", ci->name,
                         k);
                res = map_error(path, msg);
                goto fail;
            }
        }
        const char *vec_keys[2] = {"scale", "offset"};
        float *vec_dst[2] = {me->scale, me->offset};
        for (int v = 0; v < 2; v++) {
            const cJSON *a = cJSON_GetObjectItemCaseSensitive(it, vec_keys[v]);
            if (!a)
                continue;
            if (cJSON_IsNumber(a)) {
                for (uint32_t k = 0; k < ci->comps; k++)
                    vec_dst[v][k] = (float)a->valuedouble;
            } else if (cJSON_IsArray(a) && cJSON_GetArraySize(a) == (int)ci->comps) {
                for (uint32_t k = 0; k < ci->comps; k++)
                    vec_dst[v][k] = (float)cJSON_GetArrayItem(a, (int)k)->valuedouble;
            } else {
                snprintf(msg, sizeof msg, "entry '%s': \"%s\" must be a number or %u numbers",
                         ci->name, vec_keys[v], ci->comps);
                res = map_error(path, msg);
                goto fail;
            }
        }
        me->normalize = cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(it, "normalize"));
        const cJSON *conv = cJSON_GetObjectItemCaseSensitive(it, "convert");
        if (conv) {
            if (!cJSON_IsString(conv) || strcmp(conv->valuestring, "planar_to_distance") != 0 ||
                ci->id != TND_CT_DEPTH) {
                res = map_error(path, "\"convert\": only \"planar_to_distance\" on depth");
                goto fail;
            }
            if (m->xfov <= 0 && m->yfov <= 0) {
                res = map_error(path, "\"planar_to_distance\" needs camera.xfov_degrees or "
                                      "camera.yfov_degrees");
                goto fail;
            }
            me->planar_to_distance = true;
        }
        const cJSON *miss = cJSON_GetObjectItemCaseSensitive(it, "miss_at_or_above");
        if (miss) {
            if (!cJSON_IsNumber(miss) || ci->id != TND_CT_DEPTH || !(miss->valuedouble > 0)) {
                res = map_error(path, "\"miss_at_or_above\": a positive number, on depth only");
                goto fail;
            }
            me->miss_at = (float)miss->valuedouble;
        }
        const cJSON *div = cJSON_GetObjectItemCaseSensitive(it, "divide_by");
        if (div) {
            const tnd_ct_info *d = cJSON_IsString(div) ? tnd_ct_find(div->valuestring) : NULL;
            if (!d || d->comps != ci->comps || d->id == ci->id) {
                snprintf(msg, sizeof msg,
                         "entry '%s': \"divide_by\" must name another entry with %u components",
                         ci->name, ci->comps);
                res = map_error(path, msg);
                goto fail;
            }
            me->divide_by = (int)d->id;
        }
        const cJSON *mc = cJSON_GetObjectItemCaseSensitive(it, "miss_channels");
        if (mc) {
            bool good = cJSON_IsArray(mc) && cJSON_GetArraySize(mc) == (int)ci->comps &&
                        ci->kind == TND_CT_FLOAT && ci->id != TND_CT_DEPTH;
            for (uint32_t k = 0; good && k < ci->comps; k++)
                good = parse_alts(cJSON_GetArrayItem(mc, (int)k), me->miss_chan[k],
                                  &me->miss_alts[k]) &&
                       me->miss_alts[k] > 0;
            if (!good) {
                snprintf(msg, sizeof msg,
                         "entry '%s': \"miss_channels\" must list %u channel name(s) (float "
                         "entries but depth)",
                         ci->name, ci->comps);
                res = map_error(path, msg);
                goto fail;
            }
            me->on_miss = true;
        }
        const cJSON *sub = cJSON_GetObjectItemCaseSensitive(it, "subtract");
        if (sub) {
            const tnd_ct_info *d = cJSON_IsString(sub) ? tnd_ct_find(sub->valuestring) : NULL;
            if (!d || d->comps != ci->comps || d->id == ci->id ||
                (me->divide_by >= 0 && d->id == (tnd_ct)me->divide_by)) {
                snprintf(msg, sizeof msg,
                         "entry '%s': \"subtract\" must name another entry with %u components "
                         "(not its divide_by)",
                         ci->name, ci->comps);
                res = map_error(path, msg);
                goto fail;
            }
            me->subtract = (int)d->id;
        }
        me->fed = true;
    }
    *out = m;
    m = NULL;
fail:
    cJSON_Delete(root);
    free(text);
    free(m);
    return res;
}

const char *tnd_capture_map_name(const tnd_capture_map *map)
{
    return map->name;
}

bool tnd_capture_map_source(const tnd_capture_map *map, tnd_ct e, char *buf, size_t cap)
{
    const map_entry *me = &map->e[e];
    if (!me->fed)
        return false;
    size_t n = 0;
#define PUT(...)                                                                                   \
    do {                                                                                           \
        int w_ = snprintf(buf + n, n < cap ? cap - n : 0, __VA_ARGS__);                            \
        n += w_ > 0 && (size_t)w_ < cap - n ? (size_t)w_ : 0;                                      \
    } while (0)
    buf[0] = '\0';
    for (uint32_t k = 0; k < tnd_ct_get(e)->comps; k++) {
        if (me->alts[k] == 0)
            PUT("%s%g", k ? ", " : "", (double)me->offset[k]);
        else
            PUT("%s%s%s%s", k ? ", " : "", map->prefix, me->chan[k][0],
                me->alts[k] > 1 ? " (or alternatives)" : "");
        if (me->alts[k] && (me->scale[k] != 1.0f || me->offset[k] != 0.0f))
            PUT(" x %g + %g", (double)me->scale[k], (double)me->offset[k]);
    }
    if (me->planar_to_distance)
        PUT("; planar depth to distance");
    if (me->normalize)
        PUT("; normalised");
    if (me->subtract >= 0)
        PUT("; minus %s", tnd_ct_get((tnd_ct)me->subtract)->name);
    if (me->divide_by >= 0)
        PUT("; divided by %s", tnd_ct_get((tnd_ct)me->divide_by)->name);
    if (me->on_miss)
        PUT("; on a miss: %s%s...", map->prefix, me->miss_chan[0][0]);
#undef PUT
    return true;
}

void tnd_capture_map_destroy(tnd_capture_map *map)
{
    free(map);
}

tnd_result tnd_capture_read_mapped(const char *path, const tnd_capture_map *map, tnd_frame *f)
{
    tnd_exr_file x;
    memset(f, 0, sizeof *f);
    problems p = {{0}, 0};
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
        if (e->need == TND_NEED_REQUIRED && !map->e[i].fed)
            add_problem(&p, "required entry '%s' is not fed by the mapping", e->name);
    }
    if (p.count)
        return tnd_fail(TND_ERR_BAD_INPUT, "mapping: %s: %d problem%s:%s", map->path, p.count,
                        p.count == 1 ? "" : "s", p.text);
    tnd_result res = tnd_exr_read(path, &x);
    if (res != TND_OK)
        return res;
    TND_TRY(tnd_frame_create(x.width, x.height, f));
    read_camera(&x, f);
    size_t npx = (size_t)x.width * x.height;
    /* Two passes so that divide_by and subtract see their entries already converted. */
    for (int pass = 0; pass < 2; pass++)
        for (int i = 0; i < TND_CT_COUNT; i++) {
            const map_entry *me = &map->e[i];
            if (!me->fed || (me->divide_by >= 0 || me->subtract >= 0) != (pass == 1))
                continue;
            const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
            const float *src[4] = {0};
            bool ok = true;
            for (uint32_t k = 0; k < e->comps; k++) {
                if (me->alts[k] == 0)
                    continue; /* constant: offset */
                char full[300] = "";
                const tnd_exr_channel *c =
                    find_alt(&x, map->prefix, me->chan[k], me->alts[k], full, sizeof full);
                if (!c) {
                    add_problem(&p, "entry '%s': channel '%s%s' not in the file", e->name,
                                map->prefix, me->chan[k][0]);
                    ok = false;
                } else if (!c->data || c->type == TND_EXR_UINT) {
                    add_problem(&p, "channel '%s': %s", full,
                                c->data ? "wrong type UINT (expected HALF or FLOAT)"
                                        : "wrong size (subsampled)");
                    ok = false;
                } else {
                    src[k] = c->data; /* (non-finite values: counted and replaced below) */
                }
            }
            if (!ok || e->kind != TND_CT_FLOAT)
                continue;
            float *dst = f->data[i];
            for (size_t q = 0; q < npx; q++)
                for (uint32_t k = 0; k < e->comps; k++)
                    dst[q * e->comps + k] =
                        (src[k] ? src[k][q] : 0.0f) * me->scale[k] + me->offset[k];
            /* Another renderer's NaN and infinities (a division by zero, a firefly past half's
             * range) never enter the back-end: counted, said once per file and entry, and
             * replaced by a miss (depth) or 0 (anything else: no light, no motion), before any
             * conversion could hide them */
            size_t bad = 0, first = 0;
            for (size_t q = 0; q < npx * e->comps; q++)
                if (!isfinite(dst[q])) {
                    if (bad++ == 0)
                        first = q / e->comps;
                    dst[q] = i == TND_CT_DEPTH ? (float)TND_DEPTH_MISS : 0.0f;
                }
            if (bad)
                tnd_warn("capture",
                         "%s: entry '%s': %zu non-finite value%s (first at pixel %zu,%zu) set to %s",
                         path, e->name, bad, bad == 1 ? "" : "s", first % x.width,
                         first / x.width, i == TND_CT_DEPTH ? "a miss" : "0");
            f->nonfinite[i] = (uint32_t)(bad < UINT32_MAX ? bad : UINT32_MAX);
            if (me->normalize)
                for (size_t q = 0; q < npx; q++) {
                    float *v = dst + q * e->comps;
                    double l = 0;
                    for (uint32_t k = 0; k < e->comps; k++)
                        l += (double)v[k] * v[k];
                    l = l > 0 ? 1.0 / sqrt(l) : 0.0;
                    for (uint32_t k = 0; k < e->comps; k++)
                        v[k] = (float)(v[k] * l);
                }
            if (i == TND_CT_DEPTH) { /* a foreign "no hit" marker becomes TND_DEPTH_MISS */
                for (size_t q = 0; q < npx; q++)
                    if (!(dst[q] > 0.0f) || (me->miss_at > 0 && dst[q] >= me->miss_at))
                        dst[q] = (float)TND_DEPTH_MISS;
            }
            if (me->planar_to_distance) {
                /* distance = planar depth x |(u, v, 1)| for the pinhole ray through the pixel */
                double W = x.width, H = x.height;
                double fx = map->xfov > 0 ? 0.5 * W / tan(0.5 * map->xfov) : 0;
                double fy = map->yfov > 0 ? 0.5 * H / tan(0.5 * map->yfov) : fx;
                if (fx == 0)
                    fx = fy;
                for (uint32_t yy = 0; yy < x.height; yy++)
                    for (uint32_t xx = 0; xx < x.width; xx++) {
                        double u = (xx + 0.5 - 0.5 * W) / fx, v = (yy + 0.5 - 0.5 * H) / fy;
                        float *d = dst + (size_t)yy * x.width + xx;
                        if (*d < (float)TND_DEPTH_MISS)
                            *d = (float)(*d * sqrt(1.0 + u * u + v * v));
                    }
            }
            if (me->subtract >= 0) {
                const float *sb = f->data[me->subtract];
                for (size_t q = 0; q < npx * e->comps; q++)
                    dst[q] = fmaxf(dst[q] - sb[q], 0.0f);
            }
            if (me->divide_by >= 0) {
                const float *div = f->data[me->divide_by];
                for (size_t q = 0; q < npx * e->comps; q++)
                    dst[q] /= fmaxf(div[q], 0.01f);
            }
            if (me->on_miss) { /* (depth, entry 4, is converted before any later entry) */
                const float *depth = f->data[TND_CT_DEPTH];
                for (uint32_t k = 0; k < e->comps; k++) {
                    char full[300] = "";
                    const tnd_exr_channel *c = find_alt(&x, map->prefix, me->miss_chan[k],
                                                        me->miss_alts[k], full, sizeof full);
                    if (!c || !c->data || c->type == TND_EXR_UINT) {
                        add_problem(&p, "entry '%s': miss channel '%s%s' not in the file as float",
                                    e->name, map->prefix, me->miss_chan[k][0]);
                        break;
                    }
                    for (size_t q = 0; q < npx; q++)
                        if (depth[q] >= (float)TND_DEPTH_MISS)
                            dst[q * e->comps + k] = ((const float *)c->data)[q];
                }
            }
            /* (what the conversions could still make non-finite, and the miss channels) */
            for (size_t q = 0; q < npx * e->comps; q++)
                if (!isfinite(dst[q])) {
                    dst[q] = i == TND_CT_DEPTH ? (float)TND_DEPTH_MISS : 0.0f;
                    f->nonfinite[i] += f->nonfinite[i] < UINT32_MAX;
                }
            f->present[i] = true;
        }
    if (p.count) {
        res = tnd_fail(TND_ERR_BAD_INPUT, "capture: %s (mapping %s): %d problem%s:%s", path,
                       map->name, p.count, p.count == 1 ? "" : "s", p.text);
        goto fail;
    }
    TND_TRY(tnd_frame_derive(f, path));
    tnd_exr_close(&x);
    return TND_OK;
fail:
    tnd_exr_close(&x);
    tnd_frame_destroy(f);
    return res;
}
