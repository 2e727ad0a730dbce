/* run/rn_dataset.c: `tandem dataset SPEC.json --out DIR [--shard I/N]`: training data for
 * learned denoisers. For every frame of every sequence the spec names (a scene, its scene
 * options such as a camera path), the contract as render --capture writes it, the noisy
 * composite (render --denoiser off's radiance before the post chain), the matched reference
 * (the real-time estimator's expectation: what a denoiser should output) and, when asked, the
 * unbiased one; as EXR files or one .npz per frame, with a manifest. Each frame is rendered on
 * its own (its scene states, its front-end frame), so frames are split across shards as a
 * reference's are, and any shard's frames are those of the whole run (docs/python.md).
 * Entry point: rn_dataset. */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* ---- .npz: a zip of .npy arrays, stored (no compression) ----------------------------------- */
static uint32_t crc32_of(uint32_t crc, const void *data, size_t n)
{
    static uint32_t table[256];
    if (!table[1])
        for (uint32_t i = 0; i < 256; i++) {
            uint32_t c = i;
            for (int k = 0; k < 8; k++)
                c = c & 1 ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            table[i] = c;
        }
    const uint8_t *p = data;
    crc = ~crc;
    for (size_t i = 0; i < n; i++)
        crc = table[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
    return ~crc;
}

typedef struct npz_array {
    const char *name;
    const void *data;
    char dtype; /* 'f': float32, 'u': uint32 */
    uint32_t shape[3], dims;
} npz_array;

static void put16(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v, p[1] = (uint8_t)(v >> 8);
}

static void put32(uint8_t *p, uint32_t v)
{
    put16(p, v & 0xFFFF), put16(p + 2, v >> 16);
}

/* NAME.npy's header (version 1.0, padded to a multiple of 64 bytes) into h; its length. */
static size_t npy_header(const npz_array *a, char *h, size_t cap)
{
    char shape[64];
    if (a->dims == 1)
        snprintf(shape, sizeof shape, "(%u,)", a->shape[0]);
    else if (a->dims == 2)
        snprintf(shape, sizeof shape, "(%u, %u)", a->shape[0], a->shape[1]);
    else
        snprintf(shape, sizeof shape, "(%u, %u, %u)", a->shape[0], a->shape[1], a->shape[2]);
    char dict[160];
    int d = snprintf(dict, sizeof dict, "{'descr': '<%c4', 'fortran_order': False, 'shape': %s, }",
                     a->dtype, shape);
    size_t total = (10 + (size_t)d + 1 + 63) / 64 * 64, pad = total - 10 - (size_t)d - 1;
    if (total > cap)
        return 0;
    memcpy(h, "\x93NUMPY\x01\x00", 8);
    put16((uint8_t *)h + 8, (uint32_t)(total - 10));
    memcpy(h + 10, dict, (size_t)d);
    memset(h + 10 + d, ' ', pad);
    h[total - 1] = '\n';
    return total;
}

/* The arrays as PATH (written to PATH.tmp, then renamed: whole or not at all). */
static tnd_result npz_write(const char *path, const npz_array *a, uint32_t n)
{
    char tmp[2600];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *f = fopen(tmp, "wb");
    if (!f)
        return tnd_fail(TND_ERR_IO, "%s: cannot create", tmp);
    uint8_t central[64 * 128];
    size_t clen = 0;
    uint32_t offset = 0;
    bool ok = n <= 64;
    for (uint32_t i = 0; ok && i < n; i++) {
        char header[256], name[96];
        size_t hl = npy_header(&a[i], header, sizeof header);
        size_t bytes = 4;
        for (uint32_t k = 0; k < a[i].dims; k++)
            bytes *= a[i].shape[k];
        int nl = snprintf(name, sizeof name, "%s.npy", a[i].name);
        uint32_t crc = crc32_of(crc32_of(0, header, hl), a[i].data, bytes);
        uint32_t size = (uint32_t)(hl + bytes);
        if (!hl || hl + bytes > 0xFFFFFFF0u || (uint64_t)offset + size + 30 + nl > 0xFFFFFFF0u) {
            ok = false;
            break;
        }
        uint8_t local[30] = {0x50, 0x4B, 0x03, 0x04, 20, 0};
        put32(local + 14, crc), put32(local + 18, size), put32(local + 22, size);
        put16(local + 26, (uint32_t)nl);
        uint8_t *c = central + clen;
        memset(c, 0, 46);
        c[0] = 0x50, c[1] = 0x4B, c[2] = 0x01, c[3] = 0x02, c[4] = 20, c[6] = 20;
        put32(c + 16, crc), put32(c + 20, size), put32(c + 24, size);
        put16(c + 28, (uint32_t)nl), put32(c + 42, offset);
        memcpy(c + 46, name, (size_t)nl);
        clen += 46 + (size_t)nl;
        ok = fwrite(local, 1, 30, f) == 30 && fwrite(name, 1, (size_t)nl, f) == (size_t)nl &&
             fwrite(header, 1, hl, f) == hl && fwrite(a[i].data, 1, bytes, f) == bytes;
        offset += 30 + (uint32_t)nl + size;
    }
    uint8_t end[22] = {0x50, 0x4B, 0x05, 0x06, 0};
    put16(end + 8, n), put16(end + 10, n), put32(end + 12, (uint32_t)clen), put32(end + 16, offset);
    ok = ok && fwrite(central, 1, clen, f) == clen && fwrite(end, 1, 22, f) == 22;
    ok = fclose(f) == 0 && ok;
    if (!ok || rename(tmp, path) != 0) {
        remove(tmp);
        return tnd_fail(TND_ERR_IO, "%s: cannot write", path);
    }
    return TND_OK;
}

/* ---- the spec ------------------------------------------------------------------------------ */
typedef struct sequence {
    char name[128];
    rn_render_opts o; /* render's options for it (strings in the spec's JSON) */
} sequence;

typedef struct spec {
    cJSON *root;
    sequence *seq;
    uint32_t nseq, frames, unbiased_spp;
    bool npz;
} spec;

static tnd_result spec_fail(const char *path, const char *what)
{
    return tnd_fail(TND_ERR_BAD_INPUT, "%s: %s", path, what);
}

static void spec_free(spec *s)
{
    cJSON_Delete(s->root);
    free(s->seq);
    memset(s, 0, sizeof *s);
}

/* The spec's settings (the whole set's, then each sequence's own over them). */
static tnd_result spec_read(const char *path, spec *s)
{
    static const char *const top_keys[] = {"size",      "frames",   "fps",          "frontend",
                                           "bounces",   "spp",      "unbiased_spp", "format",
                                           "sequences", "precision"};
    static const char *const seq_keys[] = {"name", RN_SPEC_SCENE_KEYS};
    tnd_result res = TND_OK;
    memset(s, 0, sizeof *s);
    void *text = NULL;
    size_t len = 0;
    TND_TRY_RETURN(tnd_file_read(path, &text, &len));
    s->root = cJSON_Parse(text);
    free(text);
    if (!cJSON_IsObject(s->root))
        return spec_fail(path, "not a JSON object (docs/python.md gives the spec)");
    for (const cJSON *v = s->root->child; v; v = v->next) {
        bool known = false;
        for (size_t k = 0; k < sizeof top_keys / sizeof *top_keys; k++)
            known = known || strcmp(v->string, top_keys[k]) == 0;
        if (!known) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "%s: unknown key '%s'", path, v->string);
            goto fail;
        }
    }
    rn_render_opts base;
    rn_render_defaults(&base);
    base.frames = 8;
    base.spp = 64;
    base.estimator = "realtime";
    base.quiet = true;
    const cJSON *size = cJSON_GetObjectItemCaseSensitive(s->root, "size");
    const char *format = "exr";
    unsigned unbiased = 0;
    if (size && !(cJSON_IsArray(size) && cJSON_GetArraySize(size) == 2 &&
                  cJSON_IsNumber(cJSON_GetArrayItem(size, 0)) &&
                  cJSON_IsNumber(cJSON_GetArrayItem(size, 1)) &&
                  cJSON_GetArrayItem(size, 0)->valuedouble >= 8 &&
                  cJSON_GetArrayItem(size, 1)->valuedouble >= 8 &&
                  cJSON_GetArrayItem(size, 0)->valuedouble <= 8192 &&
                  cJSON_GetArrayItem(size, 1)->valuedouble <= 8192)) {
        res = spec_fail(path, "size: expected [width, height], each 8 to 8192");
        goto fail;
    }
    if (size) {
        base.size[0] = (unsigned)cJSON_GetArrayItem(size, 0)->valuedouble;
        base.size[1] = (unsigned)cJSON_GetArrayItem(size, 1)->valuedouble;
    }
    /* bounces: a count, or "half" (render --bounces half: the matched reference's is 1) */
    const cJSON *half = cJSON_GetObjectItemCaseSensitive(s->root, "bounces");
    base.half_indirect = cJSON_IsString(half) && strcmp(half->valuestring, "half") == 0;
    if (base.half_indirect)
        base.bounces = 1;
    if (!rn_json_uint(s->root, "frames", &base.frames, 1, 100000) ||
        (!base.half_indirect && !rn_json_uint(s->root, "bounces", &base.bounces, 0, 64)) ||
        !rn_json_uint(s->root, "spp", &base.spp, 1, 1u << 20) ||
        !rn_json_uint(s->root, "unbiased_spp", &unbiased, 0, 1u << 20) ||
        !rn_json_num(s->root, "fps", &base.fps) || !(base.fps > 0) ||
        !rn_json_str(s->root, "frontend", &base.frontend) ||
        !rn_json_str(s->root, "precision", &base.precision) || !rn_json_str(s->root, "format", &format)) {
        res = spec_fail(path, "frames (1..100000), bounces (or \"half\"), spp, unbiased_spp: "
                              "whole numbers; fps > 0; frontend, precision, format: strings");
        goto fail;
    }
    if (strcmp(format, "exr") != 0 && strcmp(format, "npz") != 0) {
        res = tnd_fail(TND_ERR_BAD_INPUT, "%s: format '%s': expected exr or npz", path, format);
        goto fail;
    }
    s->npz = strcmp(format, "npz") == 0;
    s->frames = base.frames;
    s->unbiased_spp = unbiased;
    base.ref_bounces = base.bounces;
    const cJSON *seqs = cJSON_GetObjectItemCaseSensitive(s->root, "sequences");
    int n = cJSON_GetArraySize(seqs);
    if (!cJSON_IsArray(seqs) || n < 1) {
        res = spec_fail(path, "sequences: expected a list of at least one {\"scene\": PATH, ...}");
        goto fail;
    }
    if (!(s->seq = calloc((size_t)n, sizeof *s->seq))) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
        goto fail;
    }
    for (const cJSON *q = seqs->child; q; q = q->next) {
        sequence *sq = &s->seq[s->nseq];
        sq->o = base;
        const char *name = NULL;
        bool ok = cJSON_IsObject(q);
        for (const cJSON *v = ok ? q->child : NULL; v; v = v->next) {
            bool known = false;
            for (size_t k = 0; k < sizeof seq_keys / sizeof *seq_keys; k++)
                known = known || strcmp(v->string, seq_keys[k]) == 0;
            if (!known) {
                res = tnd_fail(TND_ERR_BAD_INPUT, "%s: sequence %u: unknown key '%s'", path,
                               s->nseq, v->string);
                goto fail;
            }
        }
        sq->o.scene = NULL;
        ok = ok && rn_json_str(q, "name", &name) && rn_spec_scene_options(q, &sq->o) &&
             sq->o.scene;
        if (!ok) {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "%s: sequence %u: expected an object with \"scene\": PATH and "
                           "scene options (strings: name, camera_path, env, up; numbers: "
                           "path_duration, path_radius, path_height, env_intensity, "
                           "env_rotation, camera; no_default_light: true or false)",
                           path, s->nseq);
            goto fail;
        }
        if (name)
            snprintf(sq->name, sizeof sq->name, "%s", name);
        else
            snprintf(sq->name, sizeof sq->name, "seq_%03u", s->nseq);
        for (const char *c = sq->name; *c; c++)
            if (*c == '/' || *c == '\\' || (c == sq->name && *c == '.')) {
                res = tnd_fail(TND_ERR_BAD_INPUT,
                               "%s: sequence %u: name '%s' is not a "
                               "plain directory name",
                               path, s->nseq, sq->name);
                goto fail;
            }
        for (uint32_t k = 0; k < s->nseq; k++)
            if (strcmp(s->seq[k].name, sq->name) == 0) {
                res = tnd_fail(TND_ERR_BAD_INPUT, "%s: two sequences named '%s'", path, sq->name);
                goto fail;
            }
        TND_TRY(rn_render_check(&sq->o, true));
        s->nseq++;
    }
    return TND_OK;
fail:
    spec_free(s);
    return res;
}

/* ---- one frame ------------------------------------------------------------------------------ */
typedef struct frame_out {
    tnd_frame contract;
    float *noisy, *matched, *matched_var, *unbiased, *unbiased_var, *se;
    double *sums;
} frame_out;

static tnd_result reference_of(pl_frontend *fr, const rn_render_opts *o, unsigned f, frame_out *w,
                               float *rgb, float *var)
{
    tnd_result res = TND_OK;
    size_t n = (size_t)o->size[0] * o->size[1];
    tnd_frame scratch = {0};
    TND_TRY(tnd_frame_create(o->size[0], o->size[1], &scratch));
    memset(w->sums, 0, 4 * n * sizeof *w->sums);
    tnd_ref_stats rs = {0};
    TND_TRY(rn_reference_add(fr, o, f, &scratch, 0, o->spp, w->sums, w->sums + 3 * n, &rs, NULL,
                              NULL));
    tnd_ref_finish(w->sums, w->sums + 3 * n, n, rs.spp, rgb, w->se);
    for (size_t q = 0; q < n; q++)
        var[q] = w->se[q] * w->se[q] * (float)rs.spp;
fail:
    tnd_frame_destroy(&scratch);
    return res;
}

static tnd_result write_rgb(const char *path, const float *rgb, const float *var, uint32_t w,
                            uint32_t h)
{
    const tnd_exr_channel_desc ch[4] = {{"R", TND_EXR_FLOAT, rgb, 3},
                                        {"G", TND_EXR_FLOAT, rgb + 1, 3},
                                        {"B", TND_EXR_FLOAT, rgb + 2, 3},
                                        {"variance.Y", TND_EXR_FLOAT, var, 1}};
    return tnd_exr_write(path, w, h, ch, var ? 4 : 3, NULL, 0, TND_EXR_ZIP);
}

/* Frame f of a sequence into DIR/NAME/: its files named in `files` (a JSON object). */
static tnd_result frame_write(const spec *sp, const sequence *sq, pl_frontend *fr, tnd_scene *scene,
                              tnd_scene_state st[2], unsigned f, const char *dir, frame_out *w,
                              cJSON *files)
{
    tnd_result res = TND_OK;
    const rn_render_opts *o = &sq->o;
    uint32_t W = o->size[0], H = o->size[1];
    char path[2400];
    TND_TRY(rn_frame_begin(o, scene, fr, st, f, true, NULL));
    /* the contract as render --capture writes it, and its composite */
    TND_TRY(pl_frontend_render(fr,
                               &(pl_params){.bounces = o->bounces,
                                            .half_indirect = o->half_indirect},
                               &w->contract, NULL));
    tnd_frame_composite(&w->contract, w->noisy);
    tnd_frame_interleave(&w->contract, w->noisy);
    rn_render_opts ro = *o;
    ro.estimator = "realtime";
    TND_TRY(reference_of(fr, &ro, f, w, w->matched, w->matched_var));
    if (sp->unbiased_spp) {
        ro.estimator = "unbiased";
        ro.spp = sp->unbiased_spp;
        ro.ref_bounces = 0; /* full paths */
        TND_TRY(reference_of(fr, &ro, f, w, w->unbiased, w->unbiased_var));
    }
    if (sp->npz) {
        npz_array a[TND_CT_COUNT + 12];
        uint32_t n = 0;
        for (int e = 0; e < TND_CT_COUNT; e++) {
            const tnd_ct_info *ci = tnd_ct_get((tnd_ct)e);
            a[n++] = (npz_array){ci->name,
                                 w->contract.data[e],
                                 ci->kind == TND_CT_UINT ? 'u' : 'f',
                                 {H, W, ci->comps},
                                 3};
        }
        const tnd_camera_state *c = &w->contract.camera;
        a[n++] = (npz_array){"noisy", w->noisy, 'f', {H, W, 3}, 3};
        a[n++] = (npz_array){"matched", w->matched, 'f', {H, W, 3}, 3};
        a[n++] = (npz_array){"matched_variance", w->matched_var, 'f', {H, W}, 2};
        if (sp->unbiased_spp) {
            a[n++] = (npz_array){"unbiased", w->unbiased, 'f', {H, W, 3}, 3};
            a[n++] = (npz_array){"unbiased_variance", w->unbiased_var, 'f', {H, W}, 2};
        }
        /* the matrices row by row (numpy's m[row, col]; the camera stores them by column) */
        float mats[4][16];
        const float *from[4] = {c->view, c->proj, c->prev_view, c->prev_proj};
        static const char *const mat_names[4] = {"view", "proj", "prev_view", "prev_proj"};
        for (int m = 0; m < 4; m++) {
            for (int r = 0; r < 4; r++)
                for (int col = 0; col < 4; col++)
                    mats[m][r * 4 + col] = from[m][col * 4 + r];
            a[n++] = (npz_array){mat_names[m], mats[m], 'f', {4, 4}, 2};
        }
        a[n++] = (npz_array){"jitter", c->jitter, 'f', {2}, 1};
        snprintf(path, sizeof path, "%s/frame_%04u.npz", dir, f);
        TND_TRY(npz_write(path, a, n));
        cJSON_AddStringToObject(files, "npz", strrchr(path, '/') + 1);
        return TND_OK;
    }
    static const char *const kinds[] = {"capture", "noisy", "matched", "unbiased"};
    for (int k = 0; k < (sp->unbiased_spp ? 4 : 3); k++) {
        snprintf(path, sizeof path, "%s/frame_%04u.%s.exr", dir, f, kinds[k]);
        if (k == 0)
            TND_TRY(tnd_capture_write(path, &w->contract, TND_EXR_ZIP));
        else
            TND_TRY(write_rgb(path,
                              k == 1   ? w->noisy
                              : k == 2 ? w->matched
                                       : w->unbiased,
                              k == 1   ? NULL
                              : k == 2 ? w->matched_var
                                       : w->unbiased_var,
                              W, H));
        cJSON_AddStringToObject(files, kinds[k], strrchr(path, '/') + 1);
    }
fail:
    return res;
}

static void frame_out_free(frame_out *w)
{
    tnd_frame_destroy(&w->contract);
    free(w->noisy), free(w->matched), free(w->matched_var), free(w->unbiased),
        free(w->unbiased_var), free(w->se), free(w->sums);
    memset(w, 0, sizeof *w);
}

static tnd_result frame_out_alloc(uint32_t W, uint32_t H, frame_out *w)
{
    size_t n = (size_t)W * H;
    memset(w, 0, sizeof *w);
    tnd_result res = tnd_frame_create(W, H, &w->contract);
    if (res != TND_OK)
        return res;
    w->noisy = malloc(3 * n * sizeof(float)), w->matched = malloc(3 * n * sizeof(float));
    w->unbiased = malloc(3 * n * sizeof(float)), w->matched_var = malloc(n * sizeof(float));
    w->unbiased_var = malloc(n * sizeof(float)), w->se = malloc(n * sizeof(float));
    w->sums = malloc(4 * n * sizeof(double));
    if (!w->noisy || !w->matched || !w->unbiased || !w->matched_var || !w->unbiased_var || !w->se ||
        !w->sums) {
        frame_out_free(w);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
    }
    return TND_OK;
}

/* ---- the command ----------------------------------------------------------------------------- */
tnd_result rn_dataset(const char *spec_path, const char *out, const char *shard_text,
                      const rn_host *h)
{
    tnd_result res = TND_OK;
    spec sp = {0};
    cJSON *manifest = NULL, *list = NULL;
    bool out_existed = true, *made_dir = NULL;
    int lock_fd = -1; /* the output directory's lock */
    uint32_t shard = 0, shards = 1;
    if (shard_text)
        TND_TRY(rn_shard_parse(shard_text, &shard, &shards));
    TND_TRY(spec_read(spec_path, &sp));
    manifest = cJSON_CreateObject();
    cJSON_AddNumberToObject(manifest, "version", 1);
    cJSON_AddStringToObject(manifest, "spec", spec_path);
    cJSON_AddItemToObject(manifest, "settings", cJSON_Duplicate(sp.root, true));
    cJSON_AddStringToObject(manifest, "format", sp.npz ? "npz" : "exr");
    cJSON_AddNumberToObject(manifest, "shard", shard);
    cJSON_AddNumberToObject(manifest, "shards", shards);
    list = cJSON_AddArrayToObject(manifest, "frames");
    struct stat st_out;
    out_existed = stat(out, &st_out) == 0;
    TND_TRY(tnd_mkdirs(out));
    TND_TRY(rn_lock_dir(out, &lock_fd));
    if (!(made_dir = calloc(sp.nseq, sizeof *made_dir))) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
        goto fail;
    }
    uint64_t item = 0, done = 0;
    rn_progress bar;
    rn_progress_begin(&bar, h, "dataset",
                      (sp.nseq * (uint64_t)sp.frames + shards - 1 - shard) / shards);
    for (uint32_t q = 0; q < sp.nseq; q++) {
        const sequence *sq = &sp.seq[q];
        /* this shard's frames of the sequence: items k with k mod shards = shard */
        uint64_t first = item;
        item += sp.frames;
        bool any = false;
        for (uint64_t k = first; k < item && !any; k++)
            any = k % shards == shard;
        if (!any)
            continue;
        char dir[2100];
        snprintf(dir, sizeof dir, "%s/%s", out, sq->name);
        struct stat st_dir;
        made_dir[q] = stat(dir, &st_dir) != 0;
        TND_TRY(tnd_mkdirs(dir));
        tnd_scene *scene = NULL;
        tnd_vk vk = {0};
        pl_frontend *fr = NULL;
        pl_chain *chain = NULL;
        tnd_scene_state st[2] = {{0}};
        frame_out w = {0};
        const pl_denoiser_info *dn = NULL;
        cmp_desc pd;
        tnd_precision prec;
        bool use_vk = pl_frontend_needs_gpu(sq->o.frontend);
        res = tnd_precision_parse(sq->o.precision, &prec);
        if (res == TND_OK)
            res = rn_scene_load(sq->o.scene, &sq->o.env, &scene);
        if (res == TND_OK && use_vk)
            res = tnd_vk_create(&(tnd_vk_desc){0}, &vk);
        if (res == TND_OK)
            res = rn_pipeline_open(&sq->o, scene, &vk, use_vk, false, prec, &dn, true, &fr, &chain,
                                   &pd, h);
        if (res == TND_OK)
            res = frame_out_alloc(sq->o.size[0], sq->o.size[1], &w);
        for (uint64_t k = first; res == TND_OK && k < item; k++) {
            if (k % shards != shard)
                continue;
            unsigned f = (unsigned)(k - first);
            cJSON *e = cJSON_CreateObject(), *files = cJSON_CreateObject();
            cJSON_AddItemToArray(list, e);
            cJSON_AddStringToObject(e, "sequence", sq->name);
            cJSON_AddStringToObject(e, "scene", sq->o.scene);
            cJSON_AddNumberToObject(e, "frame", f);
            cJSON_AddItemToObject(e, "files", files);
            res = frame_write(&sp, sq, fr, scene, st, f, dir, &w, files);
            rn_progress_step(&bar, ++done);
        }
        frame_out_free(&w);
        tnd_scene_state_free(&st[0]);
        tnd_scene_state_free(&st[1]);
        pl_frontend_destroy(fr);
        if (use_vk)
            tnd_vk_destroy(&vk);
        tnd_scene_destroy(scene);
        if (res != TND_OK)
            goto fail;
    }
    rn_progress_end(&bar);
    char path[2200];
    if (shard_text)
        snprintf(path, sizeof path, "%s/manifest-%u-of-%u.json", out, shard, shards);
    else
        snprintf(path, sizeof path, "%s/manifest.json", out);
    TND_TRY(rn_json_write(path, manifest));
    rn_say(h, "tandem: dataset: %llu frame%s of %u sequence%s -> %s/", (unsigned long long)done,
           done == 1 ? "" : "s", sp.nseq, sp.nseq == 1 ? "" : "s", out);
fail:
    if (res != TND_OK && list) { /* a failed run leaves nothing of itself */
        for (const cJSON *e = list->child; e; e = e->next) {
            const cJSON *seq = cJSON_GetObjectItemCaseSensitive(e, "sequence");
            for (const cJSON *fl = cJSON_GetObjectItemCaseSensitive(e, "files")->child; fl;
                 fl = fl->next) {
                char p[2400];
                snprintf(p, sizeof p, "%s/%s/%s", out, seq->valuestring, fl->valuestring);
                remove(p);
            }
        }
        for (uint32_t q = 0; made_dir && q < sp.nseq; q++)
            if (made_dir[q]) {
                char p[2200];
                snprintf(p, sizeof p, "%s/%s", out, sp.seq[q].name);
                remove(p);
            }
        if (!out_existed) {
            rn_unlock_dir(out, lock_fd);
            lock_fd = -1;
            remove(out);
        }
    }
    rn_unlock_dir(out, lock_fd);
    free(made_dir);
    cJSON_Delete(manifest);
    spec_free(&sp);
    return res;
}
