/* run/rn_rank.c: `tandem rank SUITE --denoisers A,B,... --out DIR`: the denoiser leaderboard.
 *
 * A suite (a JSON file; data/suites/ ships `quick` and `standard`) lists sequences: a scene with
 * its options, size, frames, front-end, bounces and the matched reference's samples. Per sequence
 * the matched reference is made once, in a cache keyed by everything that determines it (the
 * scene's files' contents, the options, the estimator's version), and reused by later ranks; an
 * interrupted one resumes. Per sequence and denoiser a render (its own process: a denoiser that
 * crashes loses its row, not the rank), then one evaluation per sequence of every denoiser that
 * rendered against the reference (what `tandem eval --matched-reference` computes, to the last
 * digit), and the statistics: per figure a 95% interval from a moving-block bootstrap over the
 * frames (the same resampled frames for every denoiser: paired), ties where the paired
 * difference's interval holds zero, and the overall rank: the geometric mean over sequences of
 * each denoiser's mean FLIP relative to the baseline's (svgf, or the first named). Written as
 * DIR/rank.json, DIR/rank.csv and DIR/report (the table, per sequence the eval report with its
 * per-frame curves, player and the crops where the denoisers differ most). Entry points:
 * rn_rank_check, rn_rank, rn_rank_result_free. */
#define _XOPEN_SOURCE 700 /* realpath */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

/* Bump when the matched estimator's expectation changes (a new light sampler, a BRDF fix): the
 * cached references of the versions before are then not reused. */
#define RANK_REFERENCE_VERSION 2
#define RANK_DEFAULT_BOOTSTRAP 1000
#define RANK_CONFIDENCE 0.95

enum { RANK_FIGURES = 4 }; /* the figures with a per-frame series, bootstrapped */
static const char *const figure_names[RANK_FIGURES] = {"relmse", "flip", "temporal",
                                                       "mc_temporal"};
static const char *const figure_heads[RANK_FIGURES] = {"relMSE", "FLIP", "temporal",
                                                       "MC temporal"};
static double figure_of(const ev_frame_metrics *m, int f)
{
    return f == 0 ? m->relmse : f == 1 ? m->flip : f == 2 ? m->temporal : m->mc_temporal;
}

typedef struct rank_den {
    char spec[1100]; /* as given: asvgf, plugin:PATH, python:MODULE:FN, each with @KEY=VALUE */
    char name[1100]; /* the denoiser: spec up to its first '@' */
    char id[80];     /* its directory and column name */
    char taa[24];    /* @taa=: the post chain's TAA (empty: the suite's) */
    char lights[8];  /* @lights=: NEE's light pick, auto|plain|tree|restir (empty: the suite's) */
    double render_scale; /* @render-scale=: traced at the size times this (0: the suite's) */
    char upscaler[12];   /* @upscaler=: temporal|bilinear|bicubic (empty: the suite's) */
    pl_param_set params; /* @PARAM=: the denoiser's parameters (pl_param) */
} rank_den;

typedef struct rank_cell {
    bool ok;
    char reason[600];
    ev_summary sum;
    double backend_ms; /* median over the frames after the first; < 0: not timed */
    double mean[RANK_FIGURES], lo[RANK_FIGURES], hi[RANK_FIGURES];
    bool tie[RANK_FIGURES]; /* within the noise of the sequence's best */
    rn_region region[RN_REGIONS]; /* --regions: its error per region (pixels 0: none there) */
} rank_cell;

typedef struct rank_seq {
    char name[128];
    rn_render_opts o; /* a cell's render (denoiser and out per cell); strings in the suite */
    char scene[1100], env[1100], camera_path[1100];
    const char *package; /* the Debian package its scene comes from (for the message) */
    unsigned spp;        /* the matched reference's samples */
    char key[17], refdir[1200];
    bool ref_ok;
    char ref_reason[600];
    double ref_seconds;
    double ref_noise; /* the relMSE its own noise adds (< 0: unknown) */
    rank_cell cell[RN_RANK_MAX_DENOISERS];
    double *reps; /* FLIP's bootstrap replicates: [den][bootstrap] (NULL: none) */
    uint32_t frames_evaluated;
} rank_seq;

typedef struct rank_plan {
    cJSON *root;
    char suite[1100], suite_dir[1100], suite_name[128];
    rank_seq *seq;
    unsigned nseq;
    rank_den den[RN_RANK_MAX_DENOISERS];
    unsigned nden, base; /* base: the baseline's index */
    char out[1000], cache[1000];
    unsigned bootstrap;
    bool report, regions;
    /* --regions: denoiser d's FLIP in region g over the baseline's, the geometric mean over the
     * sequences that have it (region_n of them; region_r < 0: none); region_ratios() fills it */
    double region_r[RN_REGIONS][RN_RANK_MAX_DENOISERS];
    unsigned region_n[RN_REGIONS][RN_RANK_MAX_DENOISERS];
    bool any_region;
} rank_plan;

static void plan_free(rank_plan *P)
{
    for (unsigned s = 0; P->seq && s < P->nseq; s++)
        free(P->seq[s].reps);
    free(P->seq);
    cJSON_Delete(P->root);
    memset(P, 0, sizeof *P);
}

/* The failure just reported again as "WHAT: ITS MESSAGE" (the message copied first: it lives in
 * the buffer the new one is written to). */
static tnd_result refail(tnd_result code, const char *what)
{
    char msg[1024];
    snprintf(msg, sizeof msg, "%s", tnd_error_detail());
    return tnd_fail(code, "%s: %s", what, msg);
}

/* ---- the suite ----------------------------------------------------------------------------- */
static bool file_exists(const char *p)
{
    struct stat st;
    return stat(p, &st) == 0 && S_ISREG(st.st_mode);
}

/* p relative to dir (p itself when absolute); false when it does not fit */
static bool resolve(const char *dir, const char *p, char *out, size_t cap)
{
    int n = p[0] == '/' || !dir[0] ? snprintf(out, cap, "%s", p)
                                   : snprintf(out, cap, "%s/%s", dir, p);
    return n >= 0 && (size_t)n < cap;
}

/* The suite's file: a path, or a name shipped in the data's suites/ (quick, standard). */
static void suite_path(const char *suite, char *out, size_t cap)
{
    if (file_exists(suite) || strchr(suite, '/') || strstr(suite, ".json"))
        snprintf(out, cap, "%s", suite);
    else
        snprintf(out, cap, "%s/suites/%s.json", TND_DATA_DIR, suite);
}

static bool plain_name(const char *s)
{
    if (!s[0] || s[0] == '.')
        return false;
    for (; *s; s++)
        if (*s == '/' || *s == '\\' || *s == ' ')
            return false;
    return true;
}

static bool known_key(const char *k, const char *const *keys, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(k, keys[i]) == 0)
            return true;
    return false;
}

/* The settings a sequence may give and the suite may default: size, frames, fps, frontend,
 * bounces (a count or "half"), spp (the matched reference's). */
static bool read_settings(const cJSON *q, rn_render_opts *o, unsigned *spp)
{
    const cJSON *size = cJSON_GetObjectItemCaseSensitive(q, "size");
    if (size) {
        if (!(cJSON_IsArray(size) && cJSON_GetArraySize(size) == 2))
            return false;
        for (int k = 0; k < 2; k++) {
            const cJSON *v = cJSON_GetArrayItem(size, k);
            if (!cJSON_IsNumber(v) || v->valuedouble < 8 || v->valuedouble > 8192 ||
                v->valuedouble != (double)(unsigned)v->valuedouble)
                return false;
            o->size[k] = (unsigned)v->valuedouble;
        }
    }
    const cJSON *b = cJSON_GetObjectItemCaseSensitive(q, "bounces");
    if (cJSON_IsString(b)) {
        if (strcmp(b->valuestring, "half") != 0)
            return false;
        o->bounces = 1, o->half_indirect = true;
    } else if (b) {
        o->half_indirect = false;
        if (!rn_json_uint(q, "bounces", &o->bounces, 0, 64))
            return false;
    }
    return rn_json_uint(q, "frames", &o->frames, 2, 100000) && rn_json_num(q, "fps", &o->fps) &&
           o->fps > 0 && rn_json_str(q, "frontend", &o->frontend) &&
           rn_json_uint(q, "spp", spp, 1, 1u << 20);
}

#define SETTINGS_KEYS "size", "frames", "fps", "frontend", "bounces", "spp"
#define SETTINGS_TEXT                                                                              \
    "size [W, H] (8 to 8192), frames (2 or more), fps > 0, frontend (a string), bounces (a "     \
    "count or \"half\"), spp (the matched reference's samples)"

static tnd_result suite_read(const char *given, rank_plan *P)
{
    static const char *const top_keys[] = {"name", "description", "sequences", SETTINGS_KEYS};
    static const char *const seq_keys[] = {"name",          "description", "package",
                                           RN_SPEC_SCENE_KEYS, SETTINGS_KEYS};
    const char *path = P->suite;
    suite_path(given, P->suite, sizeof P->suite);
    snprintf(P->suite_dir, sizeof P->suite_dir, "%s", P->suite);
    char *slash = strrchr(P->suite_dir, '/');
    if (slash)
        *slash = 0;
    else
        P->suite_dir[0] = 0;
    void *text = NULL;
    size_t len = 0;
    tnd_result res = tnd_file_read(path, &text, &len);
    if (res != TND_OK)
        return refail(TND_ERR_IO, path);
    P->root = cJSON_ParseWithLength(text, len);
    free(text);
    if (!cJSON_IsObject(P->root))
        return tnd_fail(TND_ERR_BAD_INPUT, "%s: not a JSON object (docs/rank.md gives the suite)",
                        path);
    for (const cJSON *v = P->root->child; v; v = v->next)
        if (!known_key(v->string, top_keys, sizeof top_keys / sizeof *top_keys))
            return tnd_fail(TND_ERR_BAD_INPUT, "%s: unknown key '%s'", path, v->string);
    rn_render_opts base;
    rn_render_defaults(&base);
    base.frames = 16;
    base.size[0] = 128, base.size[1] = 72;
    base.frontend = "vk";
    base.quiet = true;
    unsigned base_spp = 64;
    const char *name = NULL;
    if (!rn_json_str(P->root, "name", &name) || !read_settings(P->root, &base, &base_spp))
        return tnd_fail(TND_ERR_BAD_INPUT, "%s: %s; name: a string", path, SETTINGS_TEXT);
    if (!name) {
        const char *b = strrchr(path, '/');
        name = b ? b + 1 : path;
    }
    snprintf(P->suite_name, sizeof P->suite_name, "%.100s", name);
    char *dot = strstr(P->suite_name, ".json");
    if (dot)
        *dot = 0;
    const cJSON *seqs = cJSON_GetObjectItemCaseSensitive(P->root, "sequences");
    int n = cJSON_GetArraySize(seqs);
    if (!cJSON_IsArray(seqs) || n < 1)
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "%s: sequences: expected a list of at least one {\"scene\": PATH, ...}",
                        path);
    if (!(P->seq = calloc((size_t)n, sizeof *P->seq)))
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "rank: out of memory");
    for (const cJSON *q = seqs->child; q; q = q->next) {
        rank_seq *sq = &P->seq[P->nseq];
        unsigned idx = P->nseq;
        sq->o = base;
        sq->spp = base_spp;
        sq->o.scene = NULL;
        if (!cJSON_IsObject(q))
            return tnd_fail(TND_ERR_BAD_INPUT, "%s: sequence %u: not an object", path, idx);
        const char *qname = NULL;
        if (!rn_json_str(q, "name", &qname) || !qname || !plain_name(qname) ||
            strlen(qname) >= sizeof sq->name)
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "%s: sequence %u: \"name\": a plain directory name is required", path,
                            idx);
        snprintf(sq->name, sizeof sq->name, "%s", qname);
        for (const cJSON *v = q->child; v; v = v->next)
            if (!known_key(v->string, seq_keys, sizeof seq_keys / sizeof *seq_keys))
                return tnd_fail(TND_ERR_BAD_INPUT, "%s: sequence %s: unknown key '%s'", path,
                                sq->name, v->string);
        for (unsigned k = 0; k < idx; k++)
            if (strcmp(P->seq[k].name, sq->name) == 0)
                return tnd_fail(TND_ERR_BAD_INPUT, "%s: two sequences named '%s'", path,
                                sq->name);
        if (!rn_spec_scene_options(q, &sq->o) || !sq->o.scene ||
            !rn_json_str(q, "package", &sq->package))
            return tnd_fail(TND_ERR_BAD_INPUT,
                            "%s: sequence %s: expected \"scene\": PATH and scene options "
                            "(strings: camera_path, env, up, package; numbers: path_duration, "
                            "path_radius, path_height, env_intensity, env_rotation, camera; "
                            "no_default_light: true or false)",
                            path, sq->name);
        if (!read_settings(q, &sq->o, &sq->spp))
            return tnd_fail(TND_ERR_BAD_INPUT, "%s: sequence %s: %s", path, sq->name,
                            SETTINGS_TEXT);
        /* paths relative to the suite's folder; every file there before anything runs */
        if (!resolve(P->suite_dir, sq->o.scene, sq->scene, sizeof sq->scene))
            return tnd_fail(TND_ERR_BAD_INPUT, "%s: sequence %s: scene path too long", path,
                            sq->name);
        sq->o.scene = sq->scene;
        if (!file_exists(sq->scene)) {
            if (sq->package)
                return tnd_fail(TND_ERR_IO,
                                "%s: sequence %s: scene %s: no such file (it comes with Debian's "
                                "package %s: scripts/install-deps.sh installs it)",
                                path, sq->name, sq->scene, sq->package);
            return tnd_fail(TND_ERR_IO, "%s: sequence %s: scene %s: no such file", path,
                            sq->name, sq->scene);
        }
        if (sq->o.env.path) {
            const char *e_given = sq->o.env.path;
            sq->o.env.path = sq->env;
            if (!resolve(P->suite_dir, e_given, sq->env, sizeof sq->env) || !file_exists(sq->env))
                return tnd_fail(TND_ERR_IO, "%s: sequence %s: env %s: no such file", path,
                                sq->name, sq->env);
        }
        const char *cp = sq->o.env.camera_path;
        if (cp && strcmp(cp, "orbit") != 0 && strcmp(cp, "dolly") != 0 &&
            strcmp(cp, "flythrough") != 0) {
            sq->o.env.camera_path = sq->camera_path;
            if (!resolve(P->suite_dir, cp, sq->camera_path, sizeof sq->camera_path) ||
                !file_exists(sq->camera_path))
                return tnd_fail(TND_ERR_IO, "%s: sequence %s: camera_path %s: no such file",
                                path, sq->name, sq->camera_path);
        }
        if (rn_render_check(&sq->o, false) != TND_OK) {
            char what[1400];
            snprintf(what, sizeof what, "%s: sequence %s", path, sq->name);
            return refail(TND_ERR_BAD_INPUT, what);
        }
        P->nseq++;
    }
    return TND_OK;
}

/* A row's settings kept as strings, each checked by its own parser. */
static bool taa_ok(const char *v)
{
    struct cmp_desc cd = {0};
    bool ok = rn_taa_parse(v, &cd) == TND_OK;
    tnd_error_clear();
    return ok;
}
static bool lights_ok(const char *v)
{
    tnd_light_sampling ls;
    return tnd_light_sampling_parse(v, &ls);
}
static bool upscaler_ok(const char *v)
{
    cmp_upscaler u;
    bool ok = cmp_upscaler_parse(v, &u) == TND_OK;
    tnd_error_clear();
    return ok;
}
typedef struct string_setting {
    const char *key;
    size_t offset, cap; /* its field in rank_den */
    bool (*ok)(const char *value);
    const char *expect; /* what the message says is expected */
} string_setting;
static const string_setting string_settings[] = {
    {"taa", offsetof(rank_den, taa), sizeof ((rank_den *)0)->taa, taa_ok,
     "on, off or a new-frame weight in (0, 1]"},
    {"lights", offsetof(rank_den, lights), sizeof ((rank_den *)0)->lights, lights_ok,
     "auto, plain, tree or restir"},
    {"upscaler", offsetof(rank_den, upscaler), sizeof ((rank_den *)0)->upscaler, upscaler_ok,
     CMP_UPSCALER_NAMES},
};

/* A row's settings after its name: @taa=on|off|W (the post chain's TAA, as render's --taa),
 * @lights=auto|plain|tree|restir (the front-end's light pick, as render's --lights: every pick has the
 * same matched reference, docs/lights.md), @render-scale=S and
 * @upscaler=temporal|bilinear|bicubic|lanczos (traced and denoised at the size times S, upscaled to it: the matched reference is the full
 * size's, so the upscaler's loss counts; docs/upscaling.md) and @PARAM=X (a parameter of that
 * denoiser, as render's --PARAM), so that one rank measures a change against the denoiser without it. Each is checked here, by name, before anything runs;
 * the row's id (its folder and column) gets the settings as given. */
static tnd_result variant_read(rank_den *d, const pl_denoiser_info *info)
{
    const char *settings = d->spec + strlen(d->name), *v = settings;
    while (*v == '@') {
        v++;
        size_t n = strcspn(v, "@");
        char kv[128], *eq;
        if (n == 0 || n >= sizeof kv)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers %s: an empty or overlong "
                                                      "setting (NAME@KEY=VALUE@...)", d->spec);
        memcpy(kv, v, n);
        kv[n] = 0;
        v += n;
        if (!(eq = strchr(kv, '=')) || eq == kv || !eq[1])
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers %s: '%s': expected KEY=VALUE",
                            d->spec, kv);
        *eq = 0;
        const char *key = kv, *val = eq + 1;
        bool taken = false;
        for (size_t k = 0; k < sizeof string_settings / sizeof *string_settings && !taken; k++) {
            const string_setting *ss = &string_settings[k];
            if (strcmp(key, ss->key) != 0)
                continue;
            if (strlen(val) >= ss->cap || !ss->ok(val))
                return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers %s: %s=%s: %s", d->spec,
                                key, val, ss->expect);
            snprintf((char *)d + ss->offset, ss->cap, "%s", val);
            taken = true;
        }
        if (taken)
            continue;
        if (strcmp(key, "render-scale") == 0) {
            char *end;
            double x = strtod(val, &end);
            if (*end || end == val || !(x >= 0.25 && x <= 1))
                return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers %s: render-scale=%s: a "
                                                          "number from 0.25 to 1", d->spec, val);
            d->render_scale = x;
            continue;
        }
        if (!pl_param_find(key) || !pl_denoiser_has_param(info, key))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers %s: %s has no parameter %s "
                                                      "(taa, lights, render-scale, upscaler, or "
                                                      "one that tandem info --pipeline lists "
                                                      "for it)",
                            d->spec, d->name, key);
        char *end;
        double x = strtod(val, &end);
        if (*end || end == val)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers %s: %s=%s: a number",
                            d->spec, key, val);
        if (pl_param_set_put(&d->params, key, x) != TND_OK) {
            char what[1300];
            snprintf(what, sizeof what, "--denoisers %s", d->spec);
            return refail(TND_ERR_INVALID_ARGUMENT, what);
        }
    }
    size_t l = strlen(d->id);
    if (strlen(settings) + l >= sizeof d->id)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers %s: its settings are too long "
                                                  "for a folder name", d->spec);
    snprintf(d->id + l, sizeof d->id - l, "%s", settings);
    return TND_OK;
}

/* --denoisers: each a registered name, plugin:PATH or python:MODULE:CALLABLE (at most
 * RN_RANK_MAX_DENOISERS, no two alike); the baseline: svgf where named, else the first. */
static tnd_result denoisers_read(const char *list, rank_plan *P)
{
    if (!list || !*list)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers A,B,...: the denoisers to rank "
                                                  "are required (%s, plugin:PATH.so, "
                                                  "python:MODULE:CALLABLE)",
                        pl_denoiser_names());
    const char *p = list;
    while (*p) {
        const char *end = strchr(p, ',');
        size_t n = end ? (size_t)(end - p) : strlen(p);
        if (P->nden >= RN_RANK_MAX_DENOISERS)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers: at most %d",
                            RN_RANK_MAX_DENOISERS);
        rank_den *d = &P->den[P->nden];
        if (n == 0 || n >= sizeof d->spec)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers %s: an empty or overlong name",
                            list);
        memcpy(d->spec, p, n);
        d->spec[n] = 0;
        size_t nl = strcspn(d->spec, "@");
        memcpy(d->name, d->spec, nl);
        d->name[nl] = 0;
        const pl_denoiser_info *info;
        if (pl_denoiser_find(d->name, &info) != TND_OK)
            return refail(TND_ERR_INVALID_ARGUMENT, "--denoisers");
        if (strncmp(d->name, "plugin:", 7) == 0) {
            if (!file_exists(d->name + 7))
                return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers: %s: no such file",
                                d->name + 7);
            const char *b = strrchr(d->name + 7, '/');
            b = b ? b + 1 : d->name + 7;
            snprintf(d->id, sizeof d->id, "plugin-%.*s", (int)strcspn(b, "."), b);
        } else if (strncmp(d->name, "python:", 7) == 0) {
            char tmp[72];
            snprintf(tmp, sizeof tmp, "%.70s", d->name + 7);
            snprintf(d->id, sizeof d->id, "python-%s", tmp);
            for (char *c = d->id; *c; c++)
                if (*c == ':' || *c == '/')
                    *c = '-';
        } else {
            size_t l = nl < sizeof d->id - 1 ? nl : sizeof d->id - 1;
            memcpy(d->id, d->name, l);
            d->id[l] = 0;
        }
        TND_TRY_RETURN(variant_read(d, info));
        for (unsigned k = 0; k < P->nden; k++)
            if (strcmp(P->den[k].id, d->id) == 0)
                return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--denoisers: %s named twice", d->id);
        P->nden++;
        p += n;
        if (*p == ',')
            p++;
    }
    P->base = 0;
    for (unsigned k = 0; k < P->nden; k++)
        if (strcmp(P->den[k].spec, "svgf") == 0)
            P->base = k;
    return TND_OK;
}

/* The references' cache: o->cache, else $TANDEM_CACHE/references, else
 * $XDG_CACHE_HOME/tandem/references, else ~/.cache/tandem/references. */
static void cache_dir(const char *given, char *out, size_t cap)
{
    const char *e;
    if (given)
        snprintf(out, cap, "%s", given);
    else if ((e = getenv("TANDEM_CACHE")) && *e)
        snprintf(out, cap, "%s/references", e);
    else if ((e = getenv("XDG_CACHE_HOME")) && *e)
        snprintf(out, cap, "%s/tandem/references", e);
    else
        snprintf(out, cap, "%s/.cache/tandem/references", getenv("HOME") ? getenv("HOME") : ".");
}

static tnd_result plan_make(const rn_rank_opts *o, rank_plan *P)
{
    memset(P, 0, sizeof *P);
    if (!o->suite || !o->out)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "SUITE and --out DIR are required (see tandem "
                                                  "rank --help)");
    if (strlen(o->out) >= sizeof P->out || strlen(o->suite) >= 1000 ||
        (o->cache && strlen(o->cache) >= sizeof P->cache))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "rank: path too long");
    if (o->emit && strcmp(o->emit, "slurm") != 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--emit %s: expected slurm", o->emit);
    if (o->bootstrap && (o->bootstrap < 100 || o->bootstrap > 100000))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--bootstrap %u: expected 100 to 100000",
                        o->bootstrap);
    snprintf(P->out, sizeof P->out, "%s", o->out);
    cache_dir(o->cache, P->cache, sizeof P->cache);
    P->bootstrap = o->bootstrap ? o->bootstrap : RANK_DEFAULT_BOOTSTRAP;
    P->report = !o->no_report;
    P->regions = o->regions;
    TND_TRY_RETURN(denoisers_read(o->denoisers, P));
    return suite_read(o->suite, P);
}

tnd_result rn_rank_check(const rn_rank_opts *o)
{
    rank_plan P;
    tnd_result r = plan_make(o, &P);
    plan_free(&P);
    return r;
}

/* ---- the references' key ------------------------------------------------------------------- */
static uint64_t fnv(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

static uint64_t fnv_str(uint64_t h, const char *s)
{
    return fnv(h, s, strlen(s) + 1);
}

static uint64_t fnv_file(uint64_t h, const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return fnv_str(h, "(missing)");
    unsigned char buf[1 << 16];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0)
        h = fnv(h, buf, n);
    fclose(f);
    return h;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Every file beside the scene (its buffers, textures, materials), by name and contents: a change
 * to any of them makes another reference. */
static uint64_t fnv_scene_dir(uint64_t h, const char *scene)
{
    char dir[1100];
    snprintf(dir, sizeof dir, "%s", scene);
    char *slash = strrchr(dir, '/');
    if (slash)
        *slash = 0;
    else
        snprintf(dir, sizeof dir, ".");
    DIR *d = opendir(dir);
    if (!d)
        return fnv_file(h, scene);
    char **names = NULL;
    size_t n = 0, cap = 0;
    for (struct dirent *e; (e = readdir(d));) {
        char p[1400];
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        if (e->d_name[0] == '.' || !file_exists(p))
            continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            char **g = realloc(names, cap * sizeof *names);
            if (!g)
                break;
            names = g;
        }
        names[n] = strdup(e->d_name);
        if (names[n])
            n++;
    }
    closedir(d);
    qsort(names, n, sizeof *names, cmp_str);
    for (size_t i = 0; i < n; i++) {
        char p[1400];
        snprintf(p, sizeof p, "%s/%s", dir, names[i]);
        h = fnv_file(fnv_str(h, names[i]), p);
        free(names[i]);
    }
    free(names);
    return h;
}

/* The matched reference's options for a sequence: the real-time estimator's expectation, by
 * the Embree front-end (the same samples as Vulkan's: the sweep's choice too). */
static void reference_opts(const rank_seq *sq, rn_render_opts *r)
{
    rn_render_defaults(r);
    r->scene = sq->o.scene;
    r->env = sq->o.env;
    r->camera = sq->o.camera;
    r->frames = sq->o.frames;
    r->fps = sq->o.fps;
    r->size[0] = sq->o.size[0], r->size[1] = sq->o.size[1];
    r->spp = sq->spp;
    r->estimator = "realtime";
    r->frontend = strncmp(sq->o.frontend, "plugin:", 7) == 0 ? sq->o.frontend : "embree";
    r->bounces = sq->o.bounces;
    r->ref_bounces = sq->o.bounces;
    r->half_indirect = sq->o.half_indirect;
    r->out = sq->refdir;
    r->quiet = true;
}

static void reference_key(rank_plan *P, rank_seq *sq)
{
    uint64_t h = 0xcbf29ce484222325ull;
    char v[64];
    snprintf(v, sizeof v, "tandem rank reference %d %s", RANK_REFERENCE_VERSION,
             TND_VERSION_STRING);
    h = fnv_str(h, v);
    rn_render_opts r;
    reference_opts(sq, &r);
    r.out = NULL;
    r.quiet = false;
    rn_args a;
    /* a file's path by its canonical name: the same suite ranked from its absolute path and
     * from a relative one makes its references once (a scene such as stress:N is no file) */
    if (rn_render_args(&r, true, &a) == TND_OK)
        for (int k = 0; k < a.n; k++) {
            char *canon = NULL;
            if (k > 0 && (strcmp(a.v[k - 1], "--scene") == 0 || strcmp(a.v[k - 1], "--env") == 0 ||
                          strcmp(a.v[k - 1], "--camera-path") == 0))
                canon = realpath(a.v[k], NULL);
            h = fnv_str(h, canon ? canon : a.v[k]);
            free(canon);
        }
    tnd_error_clear();
    h = fnv_scene_dir(h, sq->scene);
    if (sq->o.env.path)
        h = fnv_file(h, sq->o.env.path);
    if (sq->camera_path[0])
        h = fnv_file(h, sq->camera_path);
    snprintf(sq->key, sizeof sq->key, "%016llx", (unsigned long long)h);
    snprintf(sq->refdir, sizeof sq->refdir, "%s/%s-%s", P->cache, sq->name, sq->key);
}

/* ---- one job in its own process ------------------------------------------------------------ */
static volatile sig_atomic_t child_stop;
static void child_on_signal(int sig)
{
    child_stop = sig;
}
static int child_interrupted(void *user)
{
    (void)user;
    return child_stop;
}
static void child_warning(void *user, const char *line)
{
    int fd = *(int *)user;
    char buf[2048];
    int n = snprintf(buf, sizeof buf, "W%s\n", line);
    if (n > 0 && write(fd, buf, (size_t)(n < (int)sizeof buf ? n : (int)sizeof buf - 1)) < 0)
        return;
}

/* A render or a reference in a child process, so that a denoiser that crashes (a plugin's
 * segfault, an abort) costs its row only. Its warnings come back through a pipe and are said
 * here; its failure comes back as its line (reason). An interrupt here is passed on to it (it
 * stops between frames and keeps what it finished); *stopped then. */
static tnd_result run_isolated(const rn_render_opts *o, bool reference, const rn_host *h,
                               char *reason, size_t cap, bool *stopped)
{
    int fds[2];
    reason[0] = 0;
    *stopped = false;
    if (pipe(fds) != 0)
        return tnd_fail(TND_ERR_IO, "rank: cannot make a pipe: %s", strerror(errno));
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0) {
        close(fds[0]), close(fds[1]);
        return tnd_fail(TND_ERR_IO, "rank: cannot start a process: %s", strerror(errno));
    }
    if (pid == 0) { /* the child: its own signals, a silent host but for warnings */
        close(fds[0]);
        struct sigaction sa = {.sa_handler = child_on_signal};
        sigemptyset(&sa.sa_mask);
        sigaction(SIGINT, &sa, NULL);
        sigaction(SIGTERM, &sa, NULL);
        int fd = fds[1];
        rn_host q = {.warning = child_warning, .interrupted = child_interrupted, .user = &fd,
                     .quiet = true};
        tnd_result r = rn_render(o, reference, &q);
        if (r != TND_OK && r != TND_ERR_INTERRUPTED) {
            char line[1600];
            rn_failure_line(reference ? "reference" : "render", r, line, sizeof line);
            char buf[1700];
            int n = snprintf(buf, sizeof buf, "E%s\n", line);
            if (n > 0 && write(fd, buf, (size_t)(n < (int)sizeof buf ? n : (int)sizeof buf - 1)))
                (void)0;
        }
        close(fd);
        _exit(r == TND_OK ? 0 : r == TND_ERR_INTERRUPTED ? 3 : 1);
    }
    close(fds[1]);
    ev_text got = {0};
    char buf[4096];
    int status = 0;
    bool passed_on = false;
    for (;;) { /* read what it says until it ends; pass an interrupt on once */
        if (rn_interrupted(h) && !passed_on) {
            kill(pid, SIGINT);
            passed_on = true;
        }
        struct pollfd pf = {.fd = fds[0], .events = POLLIN};
        int ready = poll(&pf, 1, 100);
        if (ready < 0 && errno != EINTR)
            break;
        if (ready <= 0)
            continue;
        ssize_t n = read(fds[0], buf, sizeof buf - 1);
        if (n > 0) {
            buf[n] = 0;
            ev_text_add(&got, "%s", buf);
            continue;
        }
        if (n < 0 && errno == EINTR)
            continue;
        break; /* end of the pipe: it ended */
    }
    close(fds[0]);
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
        ;
    for (char *line = got.s; line && *line;) { /* its lines */
        char *nl = strchr(line, '\n');
        if (nl)
            *nl = 0;
        if (line[0] == 'W')
            rn_warn(h, "%s", line + 1);
        else if (line[0] == 'E')
            snprintf(reason, cap, "%s", line + 1 + (strncmp(line + 1, "tandem: ", 8) ? 0 : 8));
        line = nl ? nl + 1 : NULL;
    }
    ev_text_free(&got);
    if (WIFSIGNALED(status)) {
        snprintf(reason, cap, "crashed (%s)", strsignal(WTERMSIG(status)));
        return tnd_fail(TND_ERR_IO, "%s", reason);
    }
    int code = WIFEXITED(status) ? WEXITSTATUS(status) : 1;
    if (code == 3 || (rn_interrupted(h) && code != 0)) {
        *stopped = true;
        return TND_ERR_INTERRUPTED;
    }
    if (code != 0) {
        if (!reason[0])
            snprintf(reason, cap, "exited with status %d without a message", code);
        return tnd_fail(TND_ERR_IO, "%s", reason);
    }
    return TND_OK;
}

/* ---- jobs ------------------------------------------------------------------------------------ */
static bool read_json(const char *path, cJSON **j)
{
    void *txt = NULL;
    size_t len = 0;
    *j = NULL;
    if (tnd_file_read(path, &txt, &len) != TND_OK) {
        tnd_error_clear();
        return false;
    }
    *j = cJSON_ParseWithLength(txt, len);
    free(txt);
    return *j != NULL;
}

static bool reference_done(const rank_seq *sq, double *seconds)
{
    char path[1400];
    snprintf(path, sizeof path, "%s/reference.json", sq->refdir);
    cJSON *j;
    if (!read_json(path, &j))
        return false;
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(j, "seconds");
    *seconds = cJSON_IsNumber(s) ? s->valuedouble : -1;
    cJSON_Delete(j);
    return true;
}

static void cell_dir(const rank_plan *P, unsigned s, unsigned d, char *buf, size_t cap)
{
    snprintf(buf, cap, "%s/runs/%s/%s", P->out, P->seq[s].name, P->den[d].id);
}

/* a cell rendered whole before (resuming): its run.json, not interrupted */
static bool cell_done(const char *dir)
{
    char path[1400];
    if ((size_t)snprintf(path, sizeof path, "%s/run.json", dir) >= sizeof path)
        return false;
    void *txt = NULL;
    size_t len = 0;
    if (tnd_file_read(path, &txt, &len) != TND_OK) {
        tnd_error_clear();
        return false;
    }
    bool done = !strstr(txt, "\"interrupted\"");
    free(txt);
    return done;
}

static void cell_opts(const rank_plan *P, unsigned s, unsigned d, char *dir, size_t cap,
                      rn_render_opts *o)
{
    *o = P->seq[s].o;
    cell_dir(P, s, d, dir, cap);
    o->out = dir;
    const rank_den *dn = &P->den[d];
    o->denoiser = dn->name;
    if (dn->taa[0])
        o->taa = dn->taa;
    if (dn->lights[0])
        o->lights = dn->lights;
    if (dn->render_scale > 0)
        o->render_scale = dn->render_scale;
    if (dn->upscaler[0])
        o->upscaler = dn->upscaler;
    for (uint32_t i = 0; i < dn->params.n; i++) /* (over the suite's, where it gives any) */
        (void)pl_param_set_put(&o->params, dn->params.param[i]->name, dn->params.value[i]);
    o->quiet = true;
    o->capture = P->regions && d == 0; /* (the masks of every row: the noisy input is theirs) */
}

/* A cell rendered whole, with its capture where the plan wants one. */
static bool cell_complete(const rn_render_opts *o, const char *dir)
{
    char cap[1500];
    snprintf(cap, sizeof cap, "%s/capture/frame_0000.exr", dir);
    return cell_done(dir) && (!o->capture || file_exists(cap));
}

/* The references, then the cells, here (each in its own process). */
static tnd_result run_local(rank_plan *P, const rn_host *h, bool *stopped)
{
    *stopped = false;
    rn_progress bar;
    unsigned total = P->nseq * (1 + P->nden), done = 0;
    rn_progress_begin(&bar, h, "rank", total);
    for (unsigned s = 0; s < P->nseq && !*stopped; s++) {
        rank_seq *sq = &P->seq[s];
        if ((*stopped = rn_interrupted(h) != 0))
            break;
        if (reference_done(sq, &sq->ref_seconds)) {
            sq->ref_ok = true;
            rn_say(h, "rank: %s: the matched reference from the cache (%s)", sq->name,
                   sq->refdir);
        } else {
            rn_render_opts r;
            reference_opts(sq, &r);
            char partial[1400];
            snprintf(partial, sizeof partial, "%s/reference.partial.json", sq->refdir);
            if (file_exists(partial))
                r.resume = sq->refdir;
            rn_say(h, "rank: %s: the matched reference (%u spp, %u frames) into %s%s", sq->name,
                   sq->spp, sq->o.frames, sq->refdir, r.resume ? ", resumed" : "");
            TND_TRY_RETURN(tnd_mkdirs(P->cache));
            tnd_result res = run_isolated(&r, true, h, sq->ref_reason, sizeof sq->ref_reason,
                                          stopped);
            tnd_error_clear();
            if (*stopped)
                break;
            sq->ref_ok = res == TND_OK && reference_done(sq, &sq->ref_seconds);
            if (!sq->ref_ok)
                rn_warn(h, "tandem: rank: %s: its reference failed: %s; the sequence is left out",
                        sq->name, sq->ref_reason[0] ? sq->ref_reason : "no reference.json");
        }
        rn_progress_step(&bar, ++done);
    }
    for (unsigned s = 0; s < P->nseq && !*stopped; s++) {
        rank_seq *sq = &P->seq[s];
        for (unsigned d = 0; d < P->nden && !*stopped; d++) {
            rank_cell *c = &sq->cell[d];
            if (!sq->ref_ok) {
                snprintf(c->reason, sizeof c->reason, "no reference");
                continue;
            }
            char dir[1400];
            rn_render_opts o;
            cell_opts(P, s, d, dir, sizeof dir, &o);
            if (cell_complete(&o, dir)) {
                c->ok = true;
            } else if ((*stopped = rn_interrupted(h) != 0)) {
                break;
            } else {
                tnd_result res = run_isolated(&o, false, h, c->reason, sizeof c->reason, stopped);
                tnd_error_clear();
                c->ok = res == TND_OK;
                if (!c->ok && !*stopped)
                    rn_warn(h, "tandem: rank: %s with %s: %s; its row is left out", sq->name,
                            P->den[d].spec, c->reason);
            }
            rn_progress_step(&bar, ++done);
        }
    }
    if (!*stopped)
        *stopped = rn_interrupted(h) != 0;
    rn_progress_end(&bar);
    return TND_OK;
}

/* ---- times ------------------------------------------------------------------------------------ */
/* The back-end's time per frame: its passes summed (timings.json), the median over the frames
 * after the first (this machine's device; < 0 where nothing was timed). */
static double backend_ms(const char *dir)
{
    enum { PASSES_MAX = 48 };
    const pl_pass *passes[PASSES_MAX];
    uint32_t np = pl_pass_all(passes, PASSES_MAX);
    char path[1400];
    if ((size_t)snprintf(path, sizeof path, "%s/timings.json", dir) >= sizeof path)
        return -1;
    cJSON *j;
    if (!read_json(path, &j))
        return -1;
    const cJSON *frames = cJSON_GetObjectItemCaseSensitive(j, "frames");
    int n = cJSON_GetArraySize(frames);
    double *v = n > 1 ? malloc((size_t)n * sizeof *v) : NULL, r = -1;
    unsigned m = 0;
    bool any = false;
    for (int i = 1; v && i < n; i++) {
        const cJSON *f = cJSON_GetArrayItem(frames, i);
        double sum = 0;
        for (uint32_t p = 0; p < np; p++) {
            const cJSON *x = cJSON_GetObjectItemCaseSensitive(f, passes[p]->key);
            if (passes[p]->group == PL_GROUP_BACKEND && cJSON_IsNumber(x))
                sum += x->valuedouble, any = true;
        }
        v[m++] = sum;
    }
    if (v && any)
        r = rn_median(v, m);
    free(v);
    cJSON_Delete(j);
    return r;
}

/* ---- statistics ------------------------------------------------------------------------------- */
static uint64_t splitmix(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The interval's ends: the (1 - c)/2 and (1 + c)/2 quantiles of v[0..n) (sorted here, a copy
 * in tmp), linear between order statistics. */
static void interval(const double *v, unsigned n, double *tmp, double *lo, double *hi)
{
    memcpy(tmp, v, n * sizeof *v);
    qsort(tmp, n, sizeof *tmp, cmp_double);
    double q[2] = {0.5 * (1 - RANK_CONFIDENCE), 0.5 * (1 + RANK_CONFIDENCE)}, *out[2] = {lo, hi};
    for (int k = 0; k < 2; k++) {
        double x = q[k] * (n - 1);
        unsigned i = (unsigned)x;
        double f = x - i;
        *out[k] = i + 1 < n ? tmp[i] * (1 - f) + tmp[i + 1] * f : tmp[n - 1];
    }
}

/* The block length of the moving-block bootstrap over n frames: the frames' errors are
 * correlated in time (history), so blocks of consecutive frames are drawn; n^(1/3) (Hall,
 * Horowitz and Jing 1995's order for intervals), at least 1. */
static unsigned block_length(unsigned n)
{
    unsigned b = (unsigned)lround(cbrt((double)n));
    return b < 1 ? 1 : b > n ? n : b;
}

/* Replicate r of the means of val[d][0..n) for every denoiser d in `on`: the same blocks of
 * frames for all (paired). */
static void replicate(uint64_t *rng, double *const *val, const bool *on, unsigned nden, unsigned n,
                      double *means)
{
    unsigned L = block_length(n), taken = 0;
    for (unsigned d = 0; d < nden; d++)
        means[d] = 0;
    while (taken < n) {
        unsigned start = (unsigned)(splitmix(rng) % (uint64_t)(n - L + 1));
        for (unsigned k = 0; k < L && taken < n; k++, taken++)
            for (unsigned d = 0; d < nden; d++)
                if (on[d])
                    means[d] += val[d][start + k];
    }
    for (unsigned d = 0; d < nden; d++)
        means[d] /= n;
}

/* A sequence's figures with their intervals and ties; FLIP's replicates kept for the overall
 * rank. `series[d]`: the eval series of denoiser d (-1: no row). */
static tnd_result sequence_stats(rank_plan *P, unsigned s, const rn_eval *e, const int *series)
{
    rank_seq *sq = &P->seq[s];
    unsigned B = P->bootstrap, nd = P->nden, n = e->count;
    double *val[RN_RANK_MAX_DENOISERS] = {0};
    bool on[RN_RANK_MAX_DENOISERS];
    double *reps = calloc((size_t)nd * B, sizeof *reps), *tmp = malloc(B * sizeof *tmp);
    double *diff = malloc(B * sizeof *diff), means[RN_RANK_MAX_DENOISERS];
    uint32_t *keep = malloc((n ? n : 1) * sizeof *keep);
    bool fail = !reps || !tmp || !diff || !keep;
    for (unsigned d = 0; d < nd && !fail; d++)
        fail = !(val[d] = malloc((n ? n : 1) * sizeof **val));
    if (fail) {
        for (unsigned d = 0; d < nd; d++)
            free(val[d]);
        free(reps), free(tmp), free(diff), free(keep);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "rank: out of memory");
    }
    for (unsigned d = 0; d < nd; d++)
        on[d] = series[d] >= 0;
    for (int f = 0; f < RANK_FIGURES; f++) {
        /* the frames where every row has the figure (temporal: not the first; motion) */
        unsigned m = 0;
        for (uint32_t k = 0; k < n; k++) {
            bool all = true;
            for (unsigned d = 0; d < nd; d++)
                all &= !on[d] || figure_of(&e->series[series[d]].m[k], f) >= 0;
            if (all)
                keep[m++] = k;
        }
        for (unsigned d = 0; d < nd; d++) {
            rank_cell *c = &sq->cell[d];
            c->mean[f] = c->lo[f] = c->hi[f] = -1;
            c->tie[f] = false;
            if (!on[d])
                continue;
            double sum = 0;
            for (unsigned k = 0; k < m; k++)
                sum += val[d][k] = figure_of(&e->series[series[d]].m[keep[k]], f);
            if (m)
                c->mean[f] = sum / m;
        }
        if (!m)
            continue;
        uint64_t rng = 0x7a6e6b5eedull ^ ((uint64_t)s << 32) ^ (uint64_t)f;
        for (unsigned r = 0; r < B; r++) {
            replicate(&rng, val, on, nd, m, means);
            for (unsigned d = 0; d < nd; d++)
                reps[(size_t)d * B + r] = means[d];
        }
        int best = -1;
        for (unsigned d = 0; d < nd; d++)
            if (on[d]) {
                interval(reps + (size_t)d * B, B, tmp, &sq->cell[d].lo[f], &sq->cell[d].hi[f]);
                if (best < 0 || sq->cell[d].mean[f] < sq->cell[best].mean[f])
                    best = (int)d;
            }
        for (unsigned d = 0; d < nd; d++) { /* within the noise of the best: the paired
                                              difference's interval holds zero */
            if (!on[d] || (int)d == best)
                continue;
            for (unsigned r = 0; r < B; r++)
                diff[r] = reps[(size_t)d * B + r] - reps[(size_t)best * B + r];
            double lo, hi;
            interval(diff, B, tmp, &lo, &hi);
            sq->cell[d].tie[f] = lo <= 0 && hi >= 0;
        }
        if (f == 1) { /* FLIP's replicates for the overall rank */
            free(sq->reps);
            sq->reps = reps;
            reps = calloc((size_t)nd * B, sizeof *reps);
            if (!reps)
                fail = true;
        }
        if (fail)
            break;
    }
    sq->frames_evaluated = n;
    for (unsigned d = 0; d < nd; d++)
        free(val[d]);
    free(reps), free(tmp), free(diff), free(keep);
    return fail ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "rank: out of memory") : TND_OK;
}

/* The paired FLIP difference a - b on sequence s: its mean and interval. */
static void flip_pair(const rank_plan *P, const rank_seq *sq, unsigned a, unsigned b, double *mean,
                      double *lo, double *hi, double *tmp, double *diff)
{
    unsigned B = P->bootstrap;
    for (unsigned r = 0; r < B; r++)
        diff[r] = sq->reps[(size_t)a * B + r] - sq->reps[(size_t)b * B + r];
    *mean = sq->cell[a].mean[1] - sq->cell[b].mean[1];
    interval(diff, B, tmp, lo, hi);
}

typedef struct rank_overall {
    unsigned den, sequences;
    double ratio, lo, hi; /* the geometric mean of FLIP over the baseline's; < 0: none */
    bool tie_next;        /* within the noise of the next in the rank */
} rank_overall;

static bool usable(const rank_seq *sq, unsigned d)
{
    return sq->reps && sq->cell[d].ok && sq->cell[d].mean[1] > 0;
}

/* Over the sequences where a, b (and c) all have rows: per replicate the mean of log(a / b). */
static unsigned log_ratio(const rank_plan *P, unsigned a, unsigned b, int c, double *point,
                          double *reps)
{
    unsigned B = P->bootstrap, n = 0;
    *point = 0;
    for (unsigned r = 0; r < B; r++)
        reps[r] = 0;
    for (unsigned s = 0; s < P->nseq; s++) {
        const rank_seq *sq = &P->seq[s];
        if (!usable(sq, a) || !usable(sq, b) || (c >= 0 && !usable(sq, (unsigned)c)))
            continue;
        n++;
        *point += log(sq->cell[a].mean[1] / sq->cell[b].mean[1]);
        for (unsigned r = 0; r < B; r++) {
            double x = sq->reps[(size_t)a * B + r], y = sq->reps[(size_t)b * B + r];
            reps[r] += x > 0 && y > 0 ? log(x / y) : 0;
        }
    }
    if (n) {
        *point /= n;
        for (unsigned r = 0; r < B; r++)
            reps[r] /= n;
    }
    return n;
}

static int cmp_overall(const void *a, const void *b)
{
    const rank_overall *x = a, *y = b;
    if ((x->ratio < 0) != (y->ratio < 0))
        return x->ratio < 0 ? 1 : -1;
    return x->ratio < y->ratio ? -1 : x->ratio > y->ratio ? 1 : (int)x->den - (int)y->den;
}

static tnd_result overall(const rank_plan *P, rank_overall *ov)
{
    unsigned B = P->bootstrap;
    double *reps = malloc(B * sizeof *reps), *tmp = malloc(B * sizeof *tmp);
    if (!reps || !tmp) {
        free(reps), free(tmp);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "rank: out of memory");
    }
    for (unsigned d = 0; d < P->nden; d++) {
        rank_overall *o = &ov[d];
        *o = (rank_overall){.den = d, .ratio = -1, .lo = -1, .hi = -1};
        double point;
        o->sequences = log_ratio(P, d, P->base, -1, &point, reps);
        if (!o->sequences)
            continue;
        double lo, hi;
        interval(reps, B, tmp, &lo, &hi);
        o->ratio = exp(point), o->lo = exp(lo), o->hi = exp(hi);
    }
    qsort(ov, P->nden, sizeof *ov, cmp_overall);
    for (unsigned k = 0; k + 1 < P->nden; k++) {
        if (ov[k].ratio < 0 || ov[k + 1].ratio < 0)
            continue;
        double point, lo, hi;
        if (!log_ratio(P, ov[k].den, ov[k + 1].den, (int)P->base, &point, reps))
            continue;
        interval(reps, B, tmp, &lo, &hi);
        ov[k].tie_next = lo <= 0 && hi >= 0;
    }
    free(reps), free(tmp);
    return TND_OK;
}

/* ---- evaluation of a sequence ----------------------------------------------------------------- */
static tnd_result evaluate(rank_plan *P, unsigned s, const rn_host *h)
{
    rank_seq *sq = &P->seq[s];
    int series[RN_RANK_MAX_DENOISERS];
    tnd_result res = TND_OK;
    for (int pass = 0; pass < 2; pass++) { /* again without the rows whose output is not finite */
        rn_eval e = {.ppd = EV_FLIP_PPD, .metrics_on = "auto"};
        snprintf(e.ref, sizeof e.ref, "%.1090s", sq->refdir);
        bool again = false;
        for (unsigned d = 0; d < P->nden && res == TND_OK; d++) {
            series[d] = -1;
            if (!sq->cell[d].ok)
                continue;
            char dir[1400];
            cell_dir(P, s, d, dir, sizeof dir);
            series[d] = (int)e.nseries;
            res = rn_eval_add(&e, P->den[d].id, dir, RN_SERIES_OUTPUT);
        }
        if (P->regions && sq->cell[0].ok) { /* the masks: the first row's capture */
            char dir[1400];
            cell_dir(P, s, 0, dir, sizeof dir);
            snprintf(e.regions_from, sizeof e.regions_from, "%.1000s/capture", dir);
        }
        if (res == TND_OK && e.nseries)
            res = rn_eval_run(&e);
        for (unsigned d = 0; d < P->nden && res == TND_OK; d++) {
            rank_cell *c = &sq->cell[d];
            if (series[d] < 0)
                continue;
            c->sum = e.series[series[d]].summary;
            memcpy(c->region, e.series[series[d]].regions, sizeof c->region);
            if (c->sum.nonfinite) {
                c->ok = false;
                snprintf(c->reason, sizeof c->reason, "NaN or Inf in its output (%llu values)",
                         (unsigned long long)c->sum.nonfinite);
                rn_warn(h, "tandem: rank: %s with %s: %s; its row is left out", sq->name,
                        P->den[d].spec, c->reason);
                again = true;
            }
        }
        if (res == TND_OK && !again && e.nseries) {
            /* the reference's own noise against the best row's error: a figure below it is
             * the reference's, not the denoiser's (more spp in the suite) */
            double best = -1;
            for (unsigned d = 0; d < P->nden; d++)
                if (series[d] >= 0 && (best < 0 || sq->cell[d].sum.relmse < best))
                    best = sq->cell[d].sum.relmse;
            sq->ref_noise = rn_reference_noise(sq->refdir, &e);
            rn_warn_noise(sq->refdir, sq->ref_noise, best, "best denoiser's error", h);
            res = sequence_stats(P, s, &e, series);
            if (res == TND_OK && P->report) {
                char dir[1400], title[300];
                snprintf(dir, sizeof dir, "%s/report/%s", P->out, sq->name);
                snprintf(title, sizeof title, "tandem rank: %s (%s)", sq->name, P->suite_name);
                e.crop_spread = true;
                char settings[1600];
                snprintf(settings, sizeof settings,
                         "{\"reference\": \"%s\", \"sequence\": \"%s\"}", sq->refdir, sq->name);
                res = rn_eval_report(&e, dir, title, settings, NULL);
            }
        }
        if (res != TND_OK) {
            char what[300];
            snprintf(what, sizeof what, "rank: %s: evaluation", sq->name);
            res = refail(res, what);
        }
        rn_eval_free(&e);
        if (res != TND_OK || !again)
            break;
    }
    return res;
}

/* ---- outputs ----------------------------------------------------------------------------------- */
static cJSON *num_or_null(double v)
{
    return v < 0 || !isfinite(v) ? cJSON_CreateNull() : cJSON_CreateNumber(v);
}

/* --regions: each denoiser's mean FLIP inside each region over the baseline's, the geometric
 * mean over the sequences where both rows have pixels there (the same pixels for both: the
 * masks are the sequence's, not the row's), into P->region_r and region_n. */
static void region_ratios(rank_plan *P)
{
    P->any_region = false;
    for (int g = 0; g < RN_REGIONS; g++)
        for (unsigned d = 0; d < P->nden; d++) {
            double logsum = 0;
            unsigned n = 0;
            for (unsigned s = 0; P->regions && s < P->nseq; s++) {
                const rank_cell *c = &P->seq[s].cell[d], *b = &P->seq[s].cell[P->base];
                if (!c->ok || !b->ok || !c->region[g].pixels || !b->region[g].pixels)
                    continue;
                double fc = rn_region_summary(&c->region[g]).flip;
                double fb = rn_region_summary(&b->region[g]).flip;
                if (!(fc > 0) || !(fb > 0))
                    continue;
                logsum += log(fc / fb);
                n++;
            }
            P->region_n[g][d] = n;
            P->region_r[g][d] = n ? exp(logsum / n) : -1.0;
            P->any_region |= n > 0;
        }
}

static cJSON *rank_json(const rank_plan *P, const rank_overall *ov)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "suite", P->suite);
    cJSON_AddStringToObject(j, "suite_name", P->suite_name);
    cJSON *dl = cJSON_AddArrayToObject(j, "denoisers");
    for (unsigned d = 0; d < P->nden; d++)
        cJSON_AddItemToArray(dl, cJSON_CreateString(P->den[d].spec));
    cJSON_AddStringToObject(j, "baseline", P->den[P->base].spec);
    cJSON *bs = cJSON_AddObjectToObject(j, "statistics");
    cJSON_AddStringToObject(bs, "method", "moving-block bootstrap over the evaluated frames, "
                                          "the same resampled frames for every denoiser "
                                          "(paired); percentile intervals");
    cJSON_AddNumberToObject(bs, "replicates", P->bootstrap);
    cJSON_AddNumberToObject(bs, "confidence", RANK_CONFIDENCE);
    cJSON_AddStringToObject(bs, "block_length", "round(frames^(1/3))");
    cJSON_AddStringToObject(bs, "tie", "the paired difference's interval holds zero");
    cJSON_AddStringToObject(bs, "overall", "geometric mean over sequences of mean FLIP over the "
                                           "baseline's, on the sequences where both have rows");
    cJSON *oa = cJSON_AddArrayToObject(j, "overall");
    for (unsigned k = 0; k < P->nden; k++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddNumberToObject(o, "rank", k + 1);
        cJSON_AddStringToObject(o, "denoiser", P->den[ov[k].den].spec);
        cJSON_AddItemToObject(o, "flip_vs_baseline", num_or_null(ov[k].ratio));
        cJSON_AddItemToObject(o, "lo", num_or_null(ov[k].lo));
        cJSON_AddItemToObject(o, "hi", num_or_null(ov[k].hi));
        cJSON_AddNumberToObject(o, "sequences", ov[k].sequences);
        cJSON_AddBoolToObject(o, "tie_with_next", ov[k].tie_next);
        cJSON_AddItemToArray(oa, o);
    }
    if (P->regions) {
        cJSON *ra = cJSON_AddObjectToObject(j, "regions");
        for (int g = 0; g < RN_REGIONS; g++) {
            cJSON *gj = NULL;
            for (unsigned d = 0; d < P->nden; d++) {
                if (P->region_r[g][d] < 0)
                    continue;
                if (!gj)
                    gj = cJSON_AddObjectToObject(ra, rn_region_name(g));
                cJSON *dj = cJSON_AddObjectToObject(gj, P->den[d].id);
                cJSON_AddNumberToObject(dj, "flip_vs_baseline", P->region_r[g][d]);
                cJSON_AddNumberToObject(dj, "sequences", P->region_n[g][d]);
            }
        }
    }
    cJSON *sa = cJSON_AddArrayToObject(j, "sequences");
    double *tmp = malloc(P->bootstrap * sizeof *tmp), *diff = malloc(P->bootstrap * sizeof *diff);
    for (unsigned s = 0; s < P->nseq; s++) {
        const rank_seq *sq = &P->seq[s];
        cJSON *q = cJSON_CreateObject();
        cJSON_AddStringToObject(q, "name", sq->name);
        cJSON_AddStringToObject(q, "scene", sq->scene);
        cJSON *size = cJSON_AddArrayToObject(q, "size");
        cJSON_AddItemToArray(size, cJSON_CreateNumber(sq->o.size[0]));
        cJSON_AddItemToArray(size, cJSON_CreateNumber(sq->o.size[1]));
        cJSON_AddNumberToObject(q, "frames", sq->o.frames);
        cJSON_AddNumberToObject(q, "frames_evaluated", sq->frames_evaluated);
        cJSON_AddStringToObject(q, "frontend", sq->o.frontend);
        cJSON *ref = cJSON_AddObjectToObject(q, "reference");
        cJSON_AddStringToObject(ref, "dir", sq->refdir);
        cJSON_AddStringToObject(ref, "key", sq->key);
        cJSON_AddNumberToObject(ref, "spp", sq->spp);
        cJSON_AddItemToObject(ref, "seconds", num_or_null(sq->ref_ok ? sq->ref_seconds : -1));
        cJSON_AddItemToObject(ref, "noise_relmse", num_or_null(sq->ref_ok ? sq->ref_noise : -1));
        if (!sq->ref_ok)
            cJSON_AddStringToObject(ref, "failed", sq->ref_reason);
        cJSON *cells = cJSON_AddArrayToObject(q, "cells");
        for (unsigned d = 0; d < P->nden; d++) {
            const rank_cell *c = &sq->cell[d];
            cJSON *cj = cJSON_CreateObject();
            cJSON_AddStringToObject(cj, "denoiser", P->den[d].spec);
            cJSON_AddStringToObject(cj, "id", P->den[d].id);
            cJSON_AddStringToObject(cj, "status", c->ok ? "ok" : "failed");
            if (!c->ok) {
                cJSON_AddStringToObject(cj, "reason", c->reason);
                cJSON_AddItemToArray(cells, cj);
                continue;
            }
            for (int f = 0; f < RANK_FIGURES; f++) {
                cJSON *fj = cJSON_AddObjectToObject(cj, figure_names[f]);
                cJSON_AddItemToObject(fj, "mean", num_or_null(c->mean[f]));
                cJSON_AddItemToObject(fj, "lo", num_or_null(c->lo[f]));
                cJSON_AddItemToObject(fj, "hi", num_or_null(c->hi[f]));
                cJSON_AddBoolToObject(fj, "tie_with_best", c->tie[f]);
            }
            cJSON_AddItemToObject(cj, "flicker", num_or_null(c->sum.flicker));
            cJSON_AddItemToObject(cj, "flicker_reference", num_or_null(c->sum.flicker_ref));
            cJSON_AddItemToObject(cj, "disocclusion_lag", num_or_null(c->sum.disocclusion_lag));
            cJSON_AddItemToObject(cj, "light_change_lag", num_or_null(c->sum.lag));
            cJSON_AddItemToObject(cj, "worth_relmse", num_or_null(c->sum.worth_relmse));
            cJSON_AddItemToObject(cj, "worth_flip", num_or_null(c->sum.worth_flip));
            cJSON_AddItemToObject(cj, "backend_ms", num_or_null(c->backend_ms));
            cJSON *sum = cJSON_AddObjectToObject(cj, "summary"); /* = tandem eval's */
            rn_metrics_json(sum, &c->sum);
            if (P->regions) { /* (as tandem eval's metrics.json has them) */
                cJSON *rj = cJSON_AddObjectToObject(cj, "regions");
                for (int g = 0; g < RN_REGIONS; g++) {
                    if (!c->region[g].pixels)
                        continue;
                    rn_region_stats st = rn_region_summary(&c->region[g]);
                    cJSON *gj = cJSON_AddObjectToObject(rj, rn_region_name(g));
                    cJSON_AddNumberToObject(gj, "pixels", (double)c->region[g].pixels);
                    cJSON_AddNumberToObject(gj, "relmse", st.relmse);
                    cJSON_AddNumberToObject(gj, "flip", st.flip);
                    cJSON_AddNumberToObject(gj, "sharpness", st.sharpness);
                    cJSON_AddNumberToObject(gj, "bias", st.bias);
                }
            }
            cJSON_AddItemToArray(cells, cj);
        }
        cJSON *pairs = cJSON_AddArrayToObject(q, "flip_pairs");
        for (unsigned a = 0; tmp && diff && a < P->nden; a++)
            for (unsigned b = a + 1; b < P->nden; b++) {
                if (!usable(sq, a) || !usable(sq, b))
                    continue;
                double mean, lo, hi;
                flip_pair(P, sq, a, b, &mean, &lo, &hi, tmp, diff);
                cJSON *pj = cJSON_CreateObject();
                cJSON_AddStringToObject(pj, "a", P->den[a].spec);
                cJSON_AddStringToObject(pj, "b", P->den[b].spec);
                cJSON_AddNumberToObject(pj, "difference", mean);
                cJSON_AddNumberToObject(pj, "lo", lo);
                cJSON_AddNumberToObject(pj, "hi", hi);
                cJSON_AddBoolToObject(pj, "tie", lo <= 0 && hi >= 0);
                cJSON_AddItemToArray(pairs, pj);
            }
        cJSON_AddItemToArray(sa, q);
    }
    free(tmp), free(diff);
    return j;
}

static void csv_num(ev_text *t, double v)
{
    if (v < 0 || !isfinite(v))
        ev_text_add(t, ",");
    else
        ev_text_add(t, ",%.9g", v);
}

static ev_text rank_csv(const rank_plan *P)
{
    ev_text t = {0};
    ev_text_add(&t, "sequence,denoiser,status");
    for (int f = 0; f < RANK_FIGURES; f++)
        ev_text_add(&t, ",%s,%s_lo,%s_hi,%s_tie", figure_names[f], figure_names[f],
                    figure_names[f], figure_names[f]);
    ev_text_add(&t, ",flicker,disocclusion_lag,light_change_lag,worth_relmse,worth_flip,"
                    "backend_ms,reason\n");
    for (unsigned s = 0; s < P->nseq; s++)
        for (unsigned d = 0; d < P->nden; d++) {
            const rank_cell *c = &P->seq[s].cell[d];
            ev_text_add(&t, "%s,%s,%s", P->seq[s].name, P->den[d].spec, c->ok ? "ok" : "failed");
            for (int f = 0; f < RANK_FIGURES; f++) {
                csv_num(&t, c->ok ? c->mean[f] : -1);
                csv_num(&t, c->ok ? c->lo[f] : -1);
                csv_num(&t, c->ok ? c->hi[f] : -1);
                ev_text_add(&t, ",%d", c->ok && c->tie[f]);
            }
            double lag[6] = {c->sum.flicker, c->sum.disocclusion_lag, c->sum.lag,
                             c->sum.worth_relmse, c->sum.worth_flip, c->backend_ms};
            for (int k = 0; k < 6; k++)
                csv_num(&t, c->ok ? lag[k] : -1);
            ev_text_add(&t, ",");
            if (!c->ok) { /* (quoted: a reason may hold commas) */
                ev_text_add(&t, "\"");
                for (const char *p = c->reason; *p; p++)
                    ev_text_add(&t, *p == '"' ? "\"\"" : "%c", *p);
                ev_text_add(&t, "\"");
            }
            ev_text_add(&t, "\n");
        }
    return t;
}

static void fmt_ci(char *buf, size_t cap, double mean, double lo, double hi)
{
    if (mean < 0)
        snprintf(buf, cap, "-");
    else
        snprintf(buf, cap, "%.4g [%.4g, %.4g]", mean, lo, hi);
}

/* --regions: per region, each denoiser's FLIP there over the baseline's (geometric mean over
 * the sequences that have the region), as text or as an HTML table. */
static void region_text(const rank_plan *P, ev_text *t)
{
    bool head = false;
    for (int g = 0; P->regions && g < RN_REGIONS; g++) {
        bool any = false;
        for (unsigned d = 0; d < P->nden; d++) {
            double r = P->region_r[g][d];
            unsigned n = P->region_n[g][d];
            if (r < 0)
                continue;
            if (!head)
                ev_text_add(t, "per region, FLIP over %s's (geometric mean over the sequences "
                               "that have it):\n",
                            P->den[P->base].id);
            if (!any)
                ev_text_add(t, "  %-13s", rn_region_name(g));
            head = any = true;
            ev_text_add(t, "  %s %.4f (%u)", P->den[d].id, r, n);
        }
        if (any)
            ev_text_add(t, "\n");
    }
}

static void region_html(const rank_plan *P, ev_text *t)
{
    if (!P->regions || !P->any_region)
        return;
    ev_text_add(t, "<h2>Per region</h2>\n<p>Each denoiser's mean FLIP inside a region over the "
                   "baseline's, the geometric mean over the sequences that have the region "
                   "(their number in brackets). The masks come from the first row's capture "
                   "(docs/metrics.md, \"Regions\"): mirror, glass, emitters, pixels within 2 of "
                   "an emitter, glossy surfaces, surfaces in their first 4 frames, moving pixels, "
                   "thin parts.</p>\n<table id=\"regions\"><tr><th>region</th>");
    for (unsigned d = 0; d < P->nden; d++) {
        ev_text_add(t, "<th>");
        ev_text_escaped(t, P->den[d].spec);
        ev_text_add(t, "</th>");
    }
    ev_text_add(t, "</tr>\n");
    for (int g = 0; g < RN_REGIONS; g++) {
        ev_text row = {0};
        bool have = false;
        ev_text_add(&row, "<tr><td>%s</td>", rn_region_name(g));
        for (unsigned d = 0; d < P->nden; d++) {
            if (P->region_r[g][d] < 0) {
                ev_text_add(&row, "<td>-</td>");
                continue;
            }
            have = true;
            ev_text_add(&row, "<td>%.4f (%u)</td>", P->region_r[g][d], P->region_n[g][d]);
        }
        ev_text_add(&row, "</tr>\n");
        if (have && row.s)
            ev_text_add(t, "%s", row.s);
        ev_text_free(&row);
    }
    ev_text_add(t, "</table>\n");
}

/* The table as text (stdout) and the report's index.html. */
static void rank_text(const rank_plan *P, const rank_overall *ov, ev_text *t)
{
    ev_text_add(t, "rank  %-24s %-32s %s\n", "denoiser",
                "FLIP vs baseline [95% interval]", "sequences");
    for (unsigned k = 0; k < P->nden; k++) {
        char ci[96];
        if (ov[k].ratio < 0)
            snprintf(ci, sizeof ci, "- (no rows)");
        else
            snprintf(ci, sizeof ci, "%.4f [%.4f, %.4f]", ov[k].ratio, ov[k].lo, ov[k].hi);
        ev_text_add(t, "%-5u %-24s %-32s %u%s\n", k + 1, P->den[ov[k].den].id, ci,
                    ov[k].sequences, ov[k].tie_next ? "  (tie with the next)" : "");
    }
    ev_text_add(t, "baseline: %s; per sequence, mean FLIP (= : within the noise of the best):\n",
                P->den[P->base].id);
    for (unsigned s = 0; s < P->nseq; s++) {
        const rank_seq *sq = &P->seq[s];
        ev_text_add(t, "  %s:", sq->name);
        for (unsigned d = 0; d < P->nden; d++) {
            const rank_cell *c = &sq->cell[d];
            if (c->ok)
                ev_text_add(t, "  %s %.4f%s", P->den[d].id, c->mean[1], c->tie[1] ? "=" : "");
            else
                ev_text_add(t, "  %s failed", P->den[d].id);
        }
        ev_text_add(t, "\n");
    }
    region_text(P, t);
}

static void html_cell(ev_text *t, const rank_cell *c, int f, bool best)
{
    char buf[96];
    fmt_ci(buf, sizeof buf, c->mean[f], c->lo[f], c->hi[f]);
    ev_text_add(t, "<td%s>%s%s</td>", best ? " class=\"best\"" : c->tie[f] ? " class=\"tie\"" : "",
                buf, c->tie[f] ? " =" : "");
}

static tnd_result rank_html(const rank_plan *P, const rank_overall *ov)
{
    char dir[1100], path[1300];
    snprintf(dir, sizeof dir, "%s/report", P->out);
    TND_TRY_RETURN(tnd_mkdirs(dir));
    ev_text t = {0};
    ev_text_add(&t, "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>tandem rank: ");
    ev_text_escaped(&t, P->suite_name);
    ev_text_add(&t, "</title>\n<style>body{font-family:sans-serif;margin:2em;max-width:1400px}"
                    "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;"
                    "padding:3px 8px;text-align:right}th{background:#eee}td:first-child{text-"
                    "align:left}.best{background:#cfc}.tie{background:#efe}.failed{color:#a00}"
                    "img.plot{max-width:640px}</style></head><body>\n<h1>tandem rank: ");
    ev_text_escaped(&t, P->suite_name);
    ev_text_add(&t, "</h1>\n<p>Suite <code>");
    ev_text_escaped(&t, P->suite);
    ev_text_add(&t, "</code>; %u sequences; the baseline: <b>", P->nseq);
    ev_text_escaped(&t, P->den[P->base].spec);
    ev_text_add(&t, "</b>. Each figure's 95%% interval is a moving-block bootstrap over the "
                    "frames (%u replicates, the same frames for every denoiser); <i>=</i> marks a "
                    "figure within the noise of the sequence's best (the paired difference's "
                    "interval holds zero). The overall rank: the geometric mean over sequences "
                    "of each denoiser's mean FLIP over the baseline's.</p>\n",
                P->bootstrap);
    ev_text_add(&t, "<h2>Overall</h2>\n<table id=\"overall\"><tr><th>rank</th><th>denoiser</th>"
                    "<th>FLIP vs baseline</th><th>95%% interval</th><th>sequences</th>"
                    "<th>tie with the next</th></tr>\n");
    for (unsigned k = 0; k < P->nden; k++) {
        ev_text_add(&t, "<tr><td>%u</td><td>", k + 1);
        ev_text_escaped(&t, P->den[ov[k].den].spec);
        if (ov[k].ratio < 0)
            ev_text_add(&t, "</td><td>-</td><td>-</td><td>0</td><td></td></tr>\n");
        else
            ev_text_add(&t, "</td><td>%.4f</td><td>[%.4f, %.4f]</td><td>%u</td><td>%s</td></tr>\n",
                        ov[k].ratio, ov[k].lo, ov[k].hi, ov[k].sequences,
                        ov[k].tie_next ? "tie" : "");
    }
    ev_text_add(&t, "</table>\n");
    region_html(P, &t);
    for (unsigned s = 0; s < P->nseq; s++) {
        const rank_seq *sq = &P->seq[s];
        ev_text_add(&t, "<h2 id=\"seq-");
        ev_text_escaped(&t, sq->name);
        ev_text_add(&t, "\">");
        ev_text_escaped(&t, sq->name);
        ev_text_add(&t, "</h2>\n<p>%ux%u, %u frames, front-end %s; matched reference %u spp",
                    sq->o.size[0], sq->o.size[1], sq->o.frames, sq->o.frontend, sq->spp);
        if (sq->ref_ok && sq->ref_seconds >= 0)
            ev_text_add(&t, " (%.1f s to make)", sq->ref_seconds);
        if (!sq->ref_ok) {
            ev_text_add(&t, ": <span class=\"failed\">failed: ");
            ev_text_escaped(&t, sq->ref_reason);
            ev_text_add(&t, "</span></p>\n");
            continue;
        }
        ev_text_add(&t, ". <a href=\"");
        ev_text_escaped(&t, sq->name);
        ev_text_add(&t, "/index.html\">Its report</a> (per-frame curves, the crops where the "
                        "denoisers differ most) and <a href=\"");
        ev_text_escaped(&t, sq->name);
        ev_text_add(&t, "/viewer.html\">player</a>.</p>\n<table class=\"sequence\"><tr>"
                        "<th>denoiser</th>");
        for (int f = 0; f < RANK_FIGURES; f++)
            ev_text_add(&t, "<th>%s</th>", figure_heads[f]);
        ev_text_add(&t, "<th>flicker</th><th>disocclusion lag</th><th>light-change lag</th>"
                        "<th>worth N (relMSE)</th><th>worth N (FLIP)</th><th>back-end ms</th>"
                        "</tr>\n");
        int best[RANK_FIGURES];
        for (int f = 0; f < RANK_FIGURES; f++) {
            best[f] = -1;
            for (unsigned d = 0; d < P->nden; d++)
                if (sq->cell[d].ok && sq->cell[d].mean[f] >= 0 &&
                    (best[f] < 0 || sq->cell[d].mean[f] < sq->cell[best[f]].mean[f]))
                    best[f] = (int)d;
        }
        for (unsigned d = 0; d < P->nden; d++) {
            const rank_cell *c = &sq->cell[d];
            ev_text_add(&t, "<tr><td>");
            ev_text_escaped(&t, P->den[d].spec);
            ev_text_add(&t, "</td>");
            if (!c->ok) {
                ev_text_add(&t, "<td colspan=\"10\" class=\"failed\">failed: ");
                ev_text_escaped(&t, c->reason);
                ev_text_add(&t, "</td></tr>\n");
                continue;
            }
            for (int f = 0; f < RANK_FIGURES; f++)
                html_cell(&t, c, f, best[f] == (int)d);
            double v[6] = {c->sum.flicker, c->sum.disocclusion_lag, c->sum.lag,
                           c->sum.worth_relmse, c->sum.worth_flip, c->backend_ms};
            for (int k = 0; k < 6; k++)
                if (v[k] < 0 || !isfinite(v[k]))
                    ev_text_add(&t, "<td>-</td>");
                else
                    ev_text_add(&t, "<td>%.4g</td>", v[k]);
            ev_text_add(&t, "</tr>\n");
        }
        ev_text_add(&t, "</table>\n");
        if (P->report) {
            ev_text_add(&t, "<img class=\"plot\" alt=\"FLIP per frame\" src=\"");
            ev_text_escaped(&t, sq->name);
            ev_text_add(&t, "/plot_flip.svg\">\n");
        }
    }
    ev_text_add(&t, "</body></html>\n");
    snprintf(path, sizeof path, "%s/index.html", dir);
    tnd_result r = t.failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "rank: out of memory")
                            : tnd_file_write_atomic(path, t.s, t.len);
    ev_text_free(&t);
    return r;
}

/* ---- the plan's record: a second rank in the folder must be the same rank ------------------- */
static tnd_result plan_record(const rank_plan *P, const rn_rank_opts *o)
{
    char path[1200];
    snprintf(path, sizeof path, "%s/rank-plan.json", P->out);
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "suite", P->suite);
    char *suite_text = cJSON_PrintUnformatted(P->root);
    cJSON_AddStringToObject(j, "suite_digest", "");
    if (suite_text) {
        char hex[17];
        snprintf(hex, sizeof hex, "%016llx",
                 (unsigned long long)fnv_str(0xcbf29ce484222325ull, suite_text));
        cJSON_ReplaceItemInObject(j, "suite_digest", cJSON_CreateString(hex));
    }
    free(suite_text);
    cJSON_AddStringToObject(j, "denoisers", o->denoisers);
    cJSON *old;
    tnd_result r = TND_OK;
    if (read_json(path, &old)) {
        const cJSON *a = cJSON_GetObjectItemCaseSensitive(old, "suite_digest");
        const cJSON *b = cJSON_GetObjectItemCaseSensitive(old, "denoisers");
        const cJSON *c = cJSON_GetObjectItemCaseSensitive(j, "suite_digest");
        if (!cJSON_IsString(a) || !cJSON_IsString(b) ||
            strcmp(a->valuestring, c->valuestring) != 0 ||
            strcmp(b->valuestring, o->denoisers) != 0)
            r = tnd_fail(TND_ERR_INVALID_ARGUMENT,
                         "%s holds a rank of another suite or other denoisers (%s); give "
                         "another --out",
                         P->out, cJSON_IsString(b) ? b->valuestring : "?");
        cJSON_Delete(old);
    }
    if (r == TND_OK)
        r = rn_json_write(path, j);
    cJSON_Delete(j);
    return r;
}

/* ---- Slurm: the references, the cells, then the rank itself as the collecting job ------------- */
static tnd_result sbatch_open(const char *sdir, const char *name, FILE **f, char *path, size_t cap)
{
    snprintf(path, cap, "%s/%s.sbatch", sdir, name);
    if (!(*f = fopen(path, "w")))
        return tnd_fail(TND_ERR_IO, "rank: %s: cannot create", path);
    return TND_OK;
}

static tnd_result sbatch_close(FILE *f, const char *path)
{
    return fclose(f) == 0 ? TND_OK : tnd_fail(TND_ERR_IO, "rank: %s: write failed", path);
}

/* The jobs as DIR/slurm/{references,cells,collect}.sbatch and submit.sh: one task per reference
 * not made yet, one per cell (each in the folder this was run from), then this same rank again,
 * which finds them done, runs what failed here (its reason said) and writes the outputs. */
static tnd_result emit_slurm(const rank_plan *P, const rn_rank_opts *o, const rn_host *h,
                             char *submit, size_t cap)
{
    char tandem[4096], sdir[1100], path[1300], cwd[1024];
    TND_TRY_RETURN(rn_tandem_binary(tandem, sizeof tandem));
    if (!getcwd(cwd, sizeof cwd))
        return tnd_fail(TND_ERR_IO, "rank: cannot read the working directory");
    snprintf(sdir, sizeof sdir, "%s/slurm", P->out);
    snprintf(path, sizeof path, "%s/logs", sdir);
    TND_TRY_RETURN(tnd_mkdirs(path));
    TND_TRY_RETURN(tnd_mkdirs(P->cache));
    FILE *f;
    rn_args a;
    unsigned nref = 0, ncell = 0;
    TND_TRY_RETURN(sbatch_open(sdir, "references", &f, path, sizeof path));
    rn_sh_preamble(f, "tandem rank", "the matched references, one per task", "references", 0);
    fprintf(f, "cd ");
    rn_sh_word(f, cwd);
    fprintf(f, " || exit 1\ncase ${SLURM_ARRAY_TASK_ID:-0} in\n");
    for (unsigned s = 0; s < P->nseq; s++) {
        double sec;
        if (reference_done(&P->seq[s], &sec))
            continue;
        rn_render_opts r;
        reference_opts(&P->seq[s], &r);
        r.quiet = false;
        TND_TRY_RETURN(rn_render_args(&r, true, &a));
        fprintf(f, "%u)\n    ", nref++);
        rn_sh_command(f, tandem, &a, "--threads \"$threads\" --quiet ;;\n");
    }
    fprintf(f, "*) echo \"no task $SLURM_ARRAY_TASK_ID\" >&2; exit 2 ;;\nesac\n");
    TND_TRY_RETURN(sbatch_close(f, path));
    TND_TRY_RETURN(sbatch_open(sdir, "cells", &f, path, sizeof path));
    rn_sh_preamble(f, "tandem rank", "the renders, one sequence and denoiser per task", "cells",
                   0);
    fprintf(f, "cd ");
    rn_sh_word(f, cwd);
    fprintf(f, " || exit 1\ncase ${SLURM_ARRAY_TASK_ID:-0} in\n");
    for (unsigned s = 0; s < P->nseq; s++)
        for (unsigned d = 0; d < P->nden; d++) {
            char dir[1400];
            rn_render_opts c;
            cell_opts(P, s, d, dir, sizeof dir, &c);
            if (cell_complete(&c, dir))
                continue;
            c.quiet = false;
            TND_TRY_RETURN(rn_render_args(&c, false, &a));
            fprintf(f, "%u)\n    ", ncell++);
            rn_sh_command(f, tandem, &a, "--threads \"$threads\" --quiet ;;\n");
        }
    fprintf(f, "*) echo \"no task $SLURM_ARRAY_TASK_ID\" >&2; exit 2 ;;\nesac\n");
    TND_TRY_RETURN(sbatch_close(f, path));
    TND_TRY_RETURN(sbatch_open(sdir, "collect", &f, path, sizeof path));
    rn_sh_preamble(f, "tandem rank", "the rank: what failed run again here, then the outputs",
                   "rank", 0);
    fprintf(f, "cd ");
    rn_sh_word(f, cwd);
    fprintf(f, " || exit 1\n");
    rn_sh_word(f, tandem);
    fprintf(f, " rank ");
    rn_sh_word(f, P->suite);
    fprintf(f, " --denoisers ");
    rn_sh_word(f, o->denoisers);
    fprintf(f, " --out ");
    rn_sh_word(f, P->out);
    fprintf(f, " --cache ");
    rn_sh_word(f, P->cache);
    fprintf(f, " --bootstrap %u%s%s --quiet\n", P->bootstrap, P->report ? "" : " --no-report",
            P->regions ? " --regions" : "");
    TND_TRY_RETURN(sbatch_close(f, path));
    /* submit.sh: the arrays sized to their tasks, each after the one before */
    snprintf(path, sizeof path, "%s/submit.sh", sdir);
    if (!(f = fopen(path, "w")))
        return tnd_fail(TND_ERR_IO, "rank: %s: cannot create", path);
    fprintf(f, "#!/bin/bash\n"
               "# Submits the rank to Slurm: submit.sh [SBATCH_OPTION...] (given to every job);\n"
               "# TANDEM_SBATCH_GPU adds options to the jobs on Vulkan (the cells), e.g.\n"
               "# TANDEM_SBATCH_GPU=--gres=gpu:1. Prints the job ids; the last one is the rank.\n"
               "set -euo pipefail\n"
               "cd \"$(dirname \"$0\")\"\n"
               "gpu=(${TANDEM_SBATCH_GPU:-})\n"
               "after=\"\"\n");
    if (nref)
        fprintf(f, "refs=$(sbatch --parsable \"$@\" --array=0-%u --output=logs/references_%%a.out "
                   "references.sbatch)\nafter=\"--dependency=afterany:$refs\"\n"
                   "echo \"references: $refs\"\n",
                nref - 1);
    if (ncell)
        fprintf(f, "cells=$(sbatch --parsable \"$@\" \"${gpu[@]}\" --array=0-%u $after "
                   "--output=logs/cells_%%a.out cells.sbatch)\nafter=\"--dependency=afterany:"
                   "$cells\"\necho \"cells: $cells\"\n",
                ncell - 1);
    fprintf(f, "rank=$(sbatch --parsable \"$@\" \"${gpu[@]}\" $after --output=logs/rank_%%j.out "
               "collect.sbatch)\necho \"rank: $rank\"\n");
    if (fclose(f) != 0 || chmod(path, 0755) != 0)
        return tnd_fail(TND_ERR_IO, "rank: %s: write failed", path);
    rn_say(h, "tandem: rank: %u references and %u cells to make -> %s", nref, ncell, path);
    if ((size_t)snprintf(submit, cap, "%s", path) >= cap)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "rank: %s: path too long", path);
    return TND_OK;
}

tnd_result rn_rank(const rn_rank_opts *o, const rn_host *h, rn_rank_result *result)
{
    memset(result, 0, sizeof *result);
    rank_plan P;
    tnd_result res = plan_make(o, &P);
    int lock = -1;
    rank_overall ov[RN_RANK_MAX_DENOISERS];
    if (res == TND_OK)
        res = tnd_mkdirs(P.out);
    if (res == TND_OK)
        res = rn_lock_dir(P.out, &lock);
    if (res == TND_OK)
        res = plan_record(&P, o);
    for (unsigned s = 0; res == TND_OK && s < P.nseq; s++)
        reference_key(&P, &P.seq[s]);
    if (res == TND_OK && o->emit) {
        res = emit_slurm(&P, o, h, result->submit, sizeof result->submit);
        goto done;
    }
    bool stopped = false;
    if (res == TND_OK)
        res = run_local(&P, h, &stopped);
    if (res == TND_OK && stopped) {
        rn_warn(h, "tandem: rank: interrupted; the same command goes on where it stopped (the "
                   "references and the cells done are kept)");
        res = TND_ERR_INTERRUPTED;
        goto done;
    }
    for (unsigned s = 0; res == TND_OK && s < P.nseq; s++) {
        rank_seq *sq = &P.seq[s];
        if (!sq->ref_ok)
            continue;
        for (unsigned d = 0; d < P.nden; d++) {
            char dir[1400];
            cell_dir(&P, s, d, dir, sizeof dir);
            sq->cell[d].backend_ms = sq->cell[d].ok ? backend_ms(dir) : -1;
        }
        rn_say(h, "rank: %s: evaluating %u denoisers", sq->name, P.nden);
        res = evaluate(&P, s, h);
    }
    if (res == TND_OK)
        res = overall(&P, ov);
    if (res == TND_OK)
        region_ratios(&P);
    if (res == TND_OK) {
        cJSON *j = rank_json(&P, ov);
        char path[1200];
        snprintf(path, sizeof path, "%s/rank.json", P.out);
        res = j ? rn_json_write(path, j) : tnd_fail(TND_ERR_OUT_OF_MEMORY, "rank: out of memory");
        cJSON_Delete(j);
        ev_text csv = rank_csv(&P);
        snprintf(path, sizeof path, "%s/rank.csv", P.out);
        if (res == TND_OK)
            res = csv.failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "rank: out of memory")
                             : tnd_file_write_atomic(path, csv.s, csv.len);
        ev_text_free(&csv);
    }
    if (res == TND_OK && P.report)
        res = rank_html(&P, ov);
    if (res == TND_OK)
        rank_text(&P, ov, &result->table);
done:
    if (lock >= 0)
        rn_unlock_dir(P.out, lock);
    plan_free(&P);
    return res;
}

void rn_rank_result_free(rn_rank_result *r)
{
    ev_text_free(&r->table);
}
