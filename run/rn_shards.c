/* run/rn_shards.c: a reference in parts (--shard I/N: part of the work as per-pixel sums, with
 * shard.json saying what they belong to) and the merge that adds the shards' sums into the
 * frames one run of all the samples writes (docs/cluster.md). Entry points: rn_shard_parse,
 * rn_shard_plan, rn_shard_sums_write, rn_shard_sums_read, rn_shard_json_write, rn_merge. */
#include "run/rn_internal.h"
#include "shaders/specular.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* ---- shards --------------------------------------------------------------------------------- */
tnd_result rn_shard_parse(const char *text, uint32_t *shard, uint32_t *shards)
{
    char *end;
    errno = 0;
    unsigned long i = strtoul(text, &end, 10), n = 0;
    bool ok = end != text && *end == '/' && errno == 0;
    if (ok) {
        const char *t = end + 1;
        n = strtoul(t, &end, 10);
        ok = end != t && *end == 0 && errno == 0 && n >= 1 && n <= 65536 && i < n &&
             text[0] != '-' && t[0] != '-';
    }
    if (!ok)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--shard '%s': expected I/N with 0 <= I < N <= 65536 (shard I of N)", text);
    *shard = (uint32_t)i;
    *shards = (uint32_t)n;
    return TND_OK;
}

tnd_result rn_shard_plan(uint32_t frames, uint32_t spp, uint32_t shard, uint32_t shards,
                          rn_shard_part *parts, uint32_t *count)
{
    *count = 0;
    if (shards <= frames) { /* whole frames: shard i takes frames [i F / N, (i + 1) F / N) */
        uint64_t f0 = (uint64_t)shard * frames / shards, f1 = (uint64_t)(shard + 1) * frames / shards;
        for (uint64_t f = f0; f < f1; f++)
            parts[(*count)++] = (rn_shard_part){(uint32_t)f, 0, spp};
        return TND_OK;
    }
    /* fewer frames than shards: the work is frames x batches of TND_REF_CHECK_EVERY samples
     * (where the GPU's float sums restart), split into N even runs of batches */
    uint64_t b = (spp + TND_REF_CHECK_EVERY - 1) / TND_REF_CHECK_EVERY, w = b * frames;
    if (shards > w)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "--shard %u/%u: %u frame(s) of %u samples are %" PRIu64 " batches of %u "
                        "samples; no more shards than that",
                        shard, shards, frames, spp, w, TND_REF_CHECK_EVERY);
    uint64_t u0 = (uint64_t)shard * w / shards, u1 = (uint64_t)(shard + 1) * w / shards;
    for (uint64_t f = u0 / b; f < frames && f * b < u1; f++) {
        uint64_t a = u0 > f * b ? u0 - f * b : 0, e = u1 - f * b < b ? u1 - f * b : b;
        uint64_t s0 = a * TND_REF_CHECK_EVERY, s1 = e * TND_REF_CHECK_EVERY;
        if (s1 > spp)
            s1 = spp;
        parts[(*count)++] = (rn_shard_part){(uint32_t)f, (uint32_t)s0, (uint32_t)(s1 - s0)};
    }
    return TND_OK;
}

/* A part's sums: "TNDSUMS1", then width, height, frame, first sample, samples held and 0 as
 * uint32, then 3 doubles of RGB per pixel and 1 of luminance^2 per pixel (little-endian, as
 * every machine Tandem runs on). */
#define SUMS_MAGIC "TNDSUMS1"
typedef struct sums_header {
    char magic[8];
    uint32_t width, height, frame, first, samples, zero;
} sums_header;

static void sums_name(char *buf, size_t cap, const char *dir, uint32_t frame)
{
    snprintf(buf, cap, "%s/frame_%04u.sums", dir, frame);
}

tnd_result rn_shard_sums_write(const char *dir, uint32_t w, uint32_t h, uint32_t frame,
                                uint32_t first, uint32_t samples, const double *sum_rgb,
                                const double *sum_lum2)
{
    char path[1700], tmp[1800];
    sums_name(path, sizeof path, dir, frame);
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    sums_header hd = {SUMS_MAGIC, w, h, frame, first, samples, 0};
    size_t n = (size_t)w * h;
    FILE *fp = fopen(tmp, "wb");
    if (!fp)
        return tnd_fail(TND_ERR_IO, "%s: cannot create", tmp);
    bool ok = fwrite(&hd, sizeof hd, 1, fp) == 1 && fwrite(sum_rgb, sizeof(double), 3 * n, fp) ==
                                                        3 * n &&
              fwrite(sum_lum2, sizeof(double), n, fp) == n;
    ok = fclose(fp) == 0 && ok;
    if (!ok || rename(tmp, path) != 0) {
        remove(tmp);
        return tnd_fail(TND_ERR_IO, "%s: write failed", path);
    }
    return TND_OK;
}

/* shard.json: what the shard belongs to (every setting that changes a pixel), then its parts. */
tnd_result rn_shard_json_write(const rn_render_opts *o, const char *device, uint64_t digest,
                                uint32_t shard, uint32_t shards, const rn_shard_part *parts,
                                const uint32_t *taken, uint32_t count)
{
    char path[1600];
    snprintf(path, sizeof path, "%s/shard.json", o->out);
    cJSON *j = cJSON_CreateObject();
    char hex[20];
    snprintf(hex, sizeof hex, "%016" PRIx64, digest);
    cJSON_AddNumberToObject(j, "tandem_reference_shard", 1);
    cJSON_AddNumberToObject(j, "shard", shard);
    cJSON_AddNumberToObject(j, "shards", shards);
    cJSON_AddStringToObject(j, "scene", o->scene);
    cJSON_AddStringToObject(j, "scene_digest", hex);
    cJSON_AddStringToObject(j, "env", o->env.path ? o->env.path : "");
    cJSON_AddStringToObject(j, "estimator", o->estimator);
    cJSON_AddStringToObject(j, "frontend", o->frontend);
    cJSON_AddStringToObject(j, "device", device);
    cJSON_AddNumberToObject(j, "camera", o->camera);
    cJSON_AddNumberToObject(j, "width", o->size[0]);
    cJSON_AddNumberToObject(j, "height", o->size[1]);
    cJSON_AddNumberToObject(j, "fps", o->fps);
    cJSON_AddNumberToObject(j, "start", o->start);
    cJSON_AddNumberToObject(j, "frames", o->frames);
    cJSON_AddNumberToObject(j, "spp", o->spp);
    cJSON_AddNumberToObject(j, "until_noise", o->until_noise);
    cJSON_AddNumberToObject(j, "bounces", o->bounces);
    cJSON_AddNumberToObject(j, "max_bounces", o->ref_bounces);
    cJSON_AddNumberToObject(j, "reflect_depth",
                            o->reflect_depth ? o->reflect_depth : TND_REFLECT_DEPTH);
    cJSON *arr = cJSON_AddArrayToObject(j, "parts");
    for (uint32_t k = 0; k < count; k++) {
        cJSON *p = cJSON_CreateObject();
        cJSON_AddNumberToObject(p, "frame", o->start + parts[k].index);
        cJSON_AddNumberToObject(p, "first", parts[k].first);
        cJSON_AddNumberToObject(p, "count", parts[k].count);
        cJSON_AddNumberToObject(p, "samples", taken[k]);
        cJSON_AddItemToArray(arr, p);
    }
    tnd_result res = rn_json_write(path, j);
    cJSON_Delete(j);
    return res;
}

/* ---- merging shards ------------------------------------------------------------------------- */
#define MERGE_MAX 4096
typedef struct merge_part {
    uint32_t frame, first, count, samples, shard; /* shard: index into the given dirs */
} merge_part;

typedef struct merge_shard {
    const char *dir;
    cJSON *json;
} merge_shard;

/* The settings that must agree between shards (every one that changes a pixel). */
static const char *const merge_keys[] = {"scene_digest", "estimator", "frontend", "camera",
                                         "width", "height", "fps", "start", "frames", "spp",
                                         "until_noise", "bounces", "max_bounces",
                                         "reflect_depth"};

static tnd_result read_shard(const char *dir, merge_shard *s)
{
    char path[1600];
    snprintf(path, sizeof path, "%s/shard.json", dir);
    void *text = NULL;
    size_t len = 0;
    struct stat st;
    if (stat(path, &st) != 0)
        return tnd_fail(TND_ERR_IO, "%s: no shard.json: not a reference shard (tandem reference "
                        "--shard I/N writes one)", dir);
    if (st.st_size > (64 << 20))
        return tnd_fail(TND_ERR_BAD_INPUT, "%s: too large for a shard.json", path);
    TND_TRY_RETURN(tnd_file_read(path, &text, &len));
    s->dir = dir;
    s->json = cJSON_ParseWithLength(text, len);
    free(text);
    if (!s->json || !cJSON_IsObject(s->json) ||
        !cJSON_IsNumber(cJSON_GetObjectItem(s->json, "tandem_reference_shard")))
        return tnd_fail(TND_ERR_BAD_INPUT, "%s: not a reference shard's shard.json", path);
    for (size_t k = 0; k < sizeof merge_keys / sizeof *merge_keys; k++)
        if (!cJSON_GetObjectItem(s->json, merge_keys[k]))
            return tnd_fail(TND_ERR_BAD_INPUT, "%s: no \"%s\"", path, merge_keys[k]);
    if (!cJSON_IsArray(cJSON_GetObjectItem(s->json, "parts")))
        return tnd_fail(TND_ERR_BAD_INPUT, "%s: no \"parts\"", path);
    return TND_OK;
}

static double num(const cJSON *j, const char *key)
{
    const cJSON *v = cJSON_GetObjectItem(j, key);
    return cJSON_IsNumber(v) ? v->valuedouble : -1;
}

static const char *str(const cJSON *j, const char *key)
{
    const cJSON *v = cJSON_GetObjectItem(j, key);
    return cJSON_IsString(v) ? v->valuestring : "";
}

static int part_order(const void *a, const void *b)
{
    const merge_part *x = a, *y = b;
    if (x->frame != y->frame)
        return x->frame < y->frame ? -1 : 1;
    return x->first < y->first ? -1 : x->first > y->first;
}

tnd_result rn_shard_sums_read(const char *dir, uint32_t w, uint32_t h, uint32_t frame,
                               uint32_t *first, uint32_t *samples, double *sums)
{
    char path[1700];
    sums_name(path, sizeof path, dir, frame);
    size_t n = (size_t)w * h;
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return tnd_fail(TND_ERR_IO, "%s: cannot open", path);
    sums_header hd;
    tnd_result res = TND_OK;
    if (fread(&hd, sizeof hd, 1, fp) != 1 || memcmp(hd.magic, SUMS_MAGIC, 8) != 0)
        res = tnd_fail(TND_ERR_BAD_INPUT, "%s: not a Tandem sums file", path);
    else if (hd.width != w || hd.height != h || hd.frame != frame)
        res = tnd_fail(TND_ERR_BAD_INPUT, "%s: holds %ux%u frame %u, expected %ux%u frame %u",
                       path, hd.width, hd.height, hd.frame, w, h, frame);
    else if (fread(sums, sizeof(double), 4 * n, fp) != 4 * n || fgetc(fp) != EOF)
        res = tnd_fail(TND_ERR_BAD_INPUT, "%s: truncated or too long (%zu sums expected)", path,
                       4 * n);
    fclose(fp);
    *first = hd.first;
    *samples = hd.samples;
    return res;
}

/* Add one part's sums file to the frame's sums, after checking its header against the part. */
static tnd_result add_sums(const char *dir, const merge_part *p, uint32_t w, uint32_t h,
                           double *sum_rgb, double *sum_lum2, double *buf)
{
    size_t n = (size_t)w * h;
    uint32_t first = 0, samples = 0;
    tnd_result res = rn_shard_sums_read(dir, w, h, p->frame, &first, &samples, buf);
    if (res == TND_ERR_IO) {
        char msg[2000];
        snprintf(msg, sizeof msg, "%s", tnd_error_detail());
        return tnd_fail(TND_ERR_IO, "%s (shard.json lists frame %u)", msg, p->frame);
    }
    if (res == TND_OK && (first != p->first || samples != p->samples)) {
        char path[1700];
        sums_name(path, sizeof path, dir, p->frame);
        res = tnd_fail(TND_ERR_BAD_INPUT,
                       "%s: holds samples [%u, +%u), shard.json says samples [%u, +%u)", path,
                       first, samples, p->first, p->samples);
    }
    if (res != TND_OK)
        return res;
    for (size_t q = 0; q < 3 * n; q++)
        sum_rgb[q] += buf[q];
    for (size_t q = 0; q < n; q++)
        sum_lum2[q] += buf[3 * n + q];
    return TND_OK;
}

static tnd_result copy_file(const char *from, const char *to)
{
    FILE *a = fopen(from, "rb");
    if (!a)
        return tnd_fail(TND_ERR_IO, "%s: cannot open", from);
    FILE *b = fopen(to, "wb");
    if (!b) {
        fclose(a);
        return tnd_fail(TND_ERR_IO, "%s: cannot create", to);
    }
    char buf[65536];
    size_t got;
    bool ok = true;
    while ((got = fread(buf, 1, sizeof buf, a)) > 0)
        ok = ok && fwrite(buf, 1, got, b) == got;
    ok = !ferror(a) && ok;
    fclose(a);
    ok = fclose(b) == 0 && ok;
    return ok ? TND_OK : tnd_fail(TND_ERR_IO, "%s: write failed", to);
}

/* Every check before anything is written: the shards agree, and each frame's parts tile its
 * samples [0, spp) without gap or overlap. */
static tnd_result merge_check(merge_shard *sh, uint32_t ns, merge_part **parts_out,
                              uint32_t *np_out)
{
    const cJSON *a = sh[0].json;
    for (uint32_t i = 1; i < ns; i++)
        for (size_t k = 0; k < sizeof merge_keys / sizeof *merge_keys; k++) {
            const cJSON *x = cJSON_GetObjectItem(a, merge_keys[k]),
                        *y = cJSON_GetObjectItem(sh[i].json, merge_keys[k]);
            if (!cJSON_Compare(x, y, true)) {
                char *tx = cJSON_PrintUnformatted(x), *ty = cJSON_PrintUnformatted(y);
                tnd_result r = tnd_fail(TND_ERR_BAD_INPUT,
                                        "%s and %s do not belong together: %s %s and %s",
                                        sh[0].dir, sh[i].dir, merge_keys[k], tx ? tx : "?",
                                        ty ? ty : "?");
                free(tx);
                free(ty);
                return r;
            }
        }
    uint32_t frames = (uint32_t)num(a, "frames"), start = (uint32_t)num(a, "start"),
             spp = (uint32_t)num(a, "spp");
    uint32_t np = 0, cap = 0;
    merge_part *parts = NULL;
    for (uint32_t i = 0; i < ns; i++) {
        const cJSON *p;
        cJSON_ArrayForEach(p, cJSON_GetObjectItem(sh[i].json, "parts"))
        {
            double f = num(p, "frame"), s0 = num(p, "first"), c = num(p, "count"),
                   t = num(p, "samples");
            if (!(f >= start && f < (double)start + frames && s0 >= 0 && c >= 1 &&
                  s0 + c <= spp && t >= 1 && t <= c)) {
                free(parts);
                return tnd_fail(TND_ERR_BAD_INPUT, "%s/shard.json: a part out of the path's "
                                "frames [%u, %u) or samples [0, %u)", sh[i].dir, start,
                                start + frames, spp);
            }
            if (np == cap) {
                cap = cap ? 2 * cap : 64;
                merge_part *q = realloc(parts, cap * sizeof *q);
                if (!q) {
                    free(parts);
                    return tnd_fail(TND_ERR_OUT_OF_MEMORY, "merge: out of memory");
                }
                parts = q;
            }
            parts[np++] = (merge_part){(uint32_t)f, (uint32_t)s0, (uint32_t)c, (uint32_t)t, i};
        }
    }
    qsort(parts, np, sizeof *parts, part_order);
    uint32_t k = 0;
    tnd_result res = TND_OK;
    for (uint32_t f = start; f < start + frames && res == TND_OK; f++) {
        uint32_t next = 0; /* the first sample of the frame no part has covered yet */
        for (; k < np && parts[k].frame == f; k++) {
            const merge_part *p = &parts[k];
            if (p->first > next)
                res = tnd_fail(TND_ERR_BAD_INPUT, "frame %u: samples [%u, %u) are in no shard "
                               "given (a shard missing?)", f, next, p->first);
            else if (p->first < next)
                res = tnd_fail(TND_ERR_BAD_INPUT, "frame %u: samples [%u, %u) are in two shards "
                               "(%s and %s)", f, p->first, next, sh[parts[k - 1].shard].dir,
                               sh[p->shard].dir);
            else if (p->samples < p->count && (p->first != 0 || p->count != spp))
                res = tnd_fail(TND_ERR_BAD_INPUT, "%s: frame %u stopped early in a part of its "
                               "samples", sh[p->shard].dir, f);
            if (res != TND_OK)
                break;
            next = p->first + p->count;
        }
        if (res == TND_OK && next < spp)
            res = tnd_fail(TND_ERR_BAD_INPUT, "frame %u: samples [%u, %u) are in no shard given "
                           "(a shard missing?)", f, next, spp);
    }
    if (res != TND_OK) {
        free(parts);
        return res;
    }
    *parts_out = parts;
    *np_out = np;
    return TND_OK;
}

tnd_result rn_merge(const char *const *pos, int npos, const char *out, const rn_host *h)
{
    if (strlen(out) > 1500)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--out: path too long");
    if (npos < 1 || npos > MERGE_MAX)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "merge: 1 to %d shard directories", MERGE_MAX);
    merge_shard *sh = calloc((size_t)npos, sizeof *sh);
    merge_part *parts = NULL;
    uint32_t np = 0;
    double *sum = NULL, *buf = NULL, *noise = NULL;
    float *rgb = NULL, *lum_se = NULL;
    tnd_ref_stats *rs = NULL;
    tnd_result res = TND_OK;
    bool begun = false, out_existed = false;
    struct stat st;
    rn_render_opts o = {0};
    if (!sh)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "merge: out of memory");
    for (int i = 0; i < npos; i++)
        TND_TRY(read_shard(pos[i], &sh[i]));
    TND_TRY(merge_check(sh, (uint32_t)npos, &parts, &np));
    const cJSON *a = sh[0].json;
    o = (rn_render_opts){.out = out,
                         .estimator = str(a, "estimator"),
                         .frontend = str(a, "frontend"),
                         .frames = (unsigned)num(a, "frames"),
                         .start = (unsigned)num(a, "start"),
                         .spp = (unsigned)num(a, "spp"),
                         .until_noise = num(a, "until_noise"),
                         .bounces = (unsigned)num(a, "bounces"),
                         .ref_bounces = (unsigned)num(a, "max_bounces"),
                         .reflect_depth = (unsigned)num(a, "reflect_depth"),
                         .size = {(unsigned)num(a, "width"), (unsigned)num(a, "height")}};
    size_t n = (size_t)o.size[0] * o.size[1];
    if (n == 0 || n > (1u << 28)) {
        res = tnd_fail(TND_ERR_BAD_INPUT, "%s/shard.json: size %ux%u", sh[0].dir, o.size[0],
                       o.size[1]);
        goto fail;
    }
    /* the device: the shards' own, or each one named where they differ */
    char device[1024] = "";
    for (int i = 0; i < npos; i++) {
        const char *d = str(sh[i].json, "device");
        if (d[0] && !strstr(device, d)) {
            size_t l = strlen(device);
            snprintf(device + l, sizeof device - l, "%s%s", l ? " + " : "", d);
        }
    }
    sum = malloc(4 * n * sizeof *sum);
    buf = malloc(4 * n * sizeof *buf);
    rgb = malloc(3 * n * sizeof *rgb);
    lum_se = malloc(n * sizeof *lum_se);
    rs = calloc(o.frames, sizeof *rs);
    noise = calloc(o.frames, sizeof *noise);
    if (!sum || !buf || !rgb || !lum_se || !rs || !noise) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "merge: out of memory");
        goto fail;
    }
    out_existed = stat(out, &st) == 0;
    begun = true;
    TND_TRY(tnd_mkdirs(out));
    rn_progress bar;
    rn_progress_begin(&bar, h, "merge", o.frames);
    uint32_t k = 0;
    for (uint32_t i = 0; i < o.frames; i++) {
        uint32_t f = o.start + i;
        memset(sum, 0, 4 * n * sizeof *sum);
        for (; k < np && parts[k].frame == f; k++) {
            const merge_part *p = &parts[k];
            TND_TRY(add_sums(sh[p->shard].dir, p, o.size[0], o.size[1], sum, sum + 3 * n, buf));
            rs[i].spp += p->samples;
            if (p->first == 0) { /* the motion the shard of the frame's first sample wrote */
                char from[1700], to[1700];
                snprintf(from, sizeof from, "%s/frame_%04u.motion.exr", sh[p->shard].dir, f);
                snprintf(to, sizeof to, "%s/frame_%04u.motion.exr", out, f);
                TND_TRY(copy_file(from, to));
            }
        }
        TND_TRY(rn_ref_frame_finish(&o, i, sum, sum + 3 * n, rgb, lum_se, &rs[i], &noise[i]));
        rn_progress_step(&bar, i + 1);
    }
    rn_progress_end(&bar);
    TND_TRY(rn_ref_json_write(&o, device, rs, noise));
    rn_say(h, "tandem: merge: %d shard%s, %u frame%s of %u samples -> %s/", npos,
           npos == 1 ? "" : "s", o.frames, o.frames == 1 ? "" : "s", o.spp, out);
fail:
    if (res != TND_OK) {
        if (begun) { /* no partial output */
            char path[1700];
            for (uint32_t i = 0; i < o.frames; i++)
                for (int e = 0; e < 3; e++) {
                    static const char *const names[] = {"%s/frame_%04u.exr", "%s/frame_%04u.png",
                                                        "%s/frame_%04u.motion.exr"};
                    snprintf(path, sizeof path, names[e], out, o.start + i);
                    remove(path);
                }
            snprintf(path, sizeof path, "%s/reference.json", out);
            remove(path);
            if (!out_existed)
                rn_remove_flat_dir(out);
        }
    }
    for (int i = 0; i < npos; i++)
        cJSON_Delete(sh[i].json);
    free(sh);
    free(parts);
    free(sum);
    free(buf);
    free(rgb);
    free(lum_se);
    free(rs);
    free(noise);
    return res;
}

