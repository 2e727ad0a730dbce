/* run/rn_sweep.c: `tandem bench --scene S --sweep key=v1,v2,... [--sweep ...] --out DIR`: the
 * real-time pipeline over the cartesian product of knob values. Per combination: a `tandem
 * render` run (GPU ms per pass from its timestamps: medians over --timed-frames frames it runs
 * back to back after those it writes, as bench does; wall clock per frame beside),
 * its denoiser's error against the matched reference of its estimator (bounces, resolution;
 * made once per estimator under DIR/matched) and its error against the unbiased reference; then
 * DIR/sweep.json, DIR/sweep.csv and DIR/report (the Pareto fronts of time against the denoiser's
 * relMSE and FLIP, and the table). The plan (DIR/sweep-plan.json) runs here, or with --emit
 * slurm becomes Slurm jobs (DIR/slurm/submit.sh); `tandem sweep collect DIR` gathers either.
 * Entry points: rn_sweep_check, rn_sweep, rn_sweep_resume, rn_sweep_collect,
 * rn_sweep_result_free. */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

enum { MAX_KEYS = 6, MAX_VALUES = 8, MAX_RUNS = 256 };
enum { SWEEP_MAX_BOUNCES = 64 }; /* a sweep cell's --bounces: a count up to this, or half */

typedef struct knob {
    const char *key, *option, *help;
} knob;

/* The knobs: render's settings, then every denoiser parameter of the registry (pl_param: a cell
 * gives its value to the denoisers that have it). */
static const knob fixed_knobs[] = {
    {"bounces", "--bounces", "indirect bounces (a count, or half)"},
    {"gradient", "--denoiser", "A-SVGF temporal gradients: on (asvgf) or off (svgf)"},
    {"denoiser", "--denoiser", "a registered denoiser (tandem render --help lists them)"},
    {"precision", "--precision", "contract precision: float32 or packed"},
    {"taa", "--taa", "on, off or the new-frame weight"},
    {"scale", "--size", "resolution scale (the output is resampled to the reference's size)"},
    {"render-scale", "--render-scale", "traced and denoised at this scale of the size (0.25 to "
                                       "1), upscaled to it by the post chain (--upscaler)"},
    {"upscaler", "--upscaler", CMP_UPSCALER_NAMES " (with render-scale below 1)"},
    {"frontend", "--frontend", "vk or embree (embree's front-end time is CPU wall clock)"},
};
enum { FIXED = sizeof fixed_knobs / sizeof fixed_knobs[0], MAX_KNOBS = FIXED + PL_PARAMS_MAX };
static knob knobs[MAX_KNOBS];
static char knob_option[PL_PARAMS_MAX][72];
static int n_knobs;

static void knobs_init(void)
{
    if (n_knobs)
        return;
    knobs[n_knobs++] = fixed_knobs[0];
    for (uint32_t i = 0; i < pl_param_count() && i < PL_PARAMS_MAX; i++) {
        const pl_param *p = pl_param_at(i);
        snprintf(knob_option[i], sizeof knob_option[i], "--%s", p->name);
        knobs[n_knobs++] = (knob){p->name, knob_option[i], p->help};
    }
    for (int i = 1; i < FIXED; i++)
        knobs[n_knobs++] = fixed_knobs[i];
}

/* timings.json's keys of every pass a frame may time (pl_pass_all); the front-end's are the CPU's
 * wall clock with embree */
enum { PASSES_MAX = 48 };
static const pl_pass *passes[PASSES_MAX];
static int n_passes;

static void passes_init(void)
{
    if (!n_passes)
        n_passes = (int)pl_pass_all(passes, PASSES_MAX);
}

typedef struct sweep_run {
    const char *value[MAX_KEYS];
    double pass_ms[PASSES_MAX], total_ms, wall_ms; /* wall_ms: per frame back to back (0: none) */
    ev_summary metrics;    /* the denoiser's error: against the cell's matched reference */
    ev_summary whole;      /* against the unbiased reference: denoiser error and estimator bias */
    int estimator;         /* index into the sweep's estimators (matched references) */
    bool pareto_relmse, pareto_flip;
} sweep_run;

/* One estimator of the sweep: the knobs that change the real-time estimator's expectation (its
 * bounce count and resolution); cells with the same one share its matched reference. */
typedef struct sweep_estimator {
    char bounces[16], size[32], dir[1100];
    ev_summary bias; /* its matched reference against the unbiased one */
} sweep_estimator;

/* Metrics of `dir`'s frames after the warm-up against `ref` (resampled to its size). */
static tnd_result eval_against(const char *dir, const char *ref, unsigned warmup, ev_summary *m)
{
    rn_eval e = {.min_frame = warmup, .resample = true};
    snprintf(e.ref, sizeof e.ref, "%s", ref);
    tnd_result res = rn_eval_add(&e, "run", dir, RN_SERIES_OUTPUT);
    if (res == TND_OK)
        res = rn_eval_run(&e);
    if (res == TND_OK)
        *m = e.series[0].summary;
    rn_eval_free(&e);
    return res;
}

/* A cell's times: per pass, the median over its back-to-back frames (render --timed-frames), or
 * over its written frames after the warm-up (each waited for: the GPU idles between them, and
 * its clocks drop) where it ran none; and the wall clock per back-to-back frame (0 without). */
static tnd_result read_timings(const char *dir, unsigned warmup, sweep_run *r)
{
    passes_init();
    char path[1400];
    snprintf(path, sizeof path, "%s/timings.json", dir);
    void *txt = NULL;
    size_t len = 0;
    tnd_result res = tnd_file_read(path, &txt, &len);
    if (res != TND_OK)
        return res;
    cJSON *j = cJSON_Parse(txt);
    free(txt);
    const cJSON *b2b = cJSON_GetObjectItem(j, "back_to_back");
    const cJSON *frames = cJSON_GetObjectItem(b2b ? b2b : j, "frames");
    const cJSON *wall = cJSON_GetObjectItem(b2b, "wall_ms");
    int n = cJSON_GetArraySize(frames), first = b2b ? 0 : (int)warmup;
    if (!j || n <= first || (b2b && !cJSON_IsNumber(wall))) {
        cJSON_Delete(j);
        return tnd_fail(TND_ERR_BAD_INPUT, "bench: %s: %d %sframes, need more than %d", path, n,
                        b2b ? "back-to-back " : "", first);
    }
    r->wall_ms = b2b ? wall->valuedouble : 0.0;
    double *v = malloc((size_t)n * sizeof *v);
    r->total_ms = 0;
    for (int p = 0; v && p < n_passes; p++) {
        unsigned m = 0;
        for (int i = first; i < n; i++) {
            const cJSON *x = cJSON_GetObjectItem(cJSON_GetArrayItem(frames, i), passes[p]->key);
            v[m++] = cJSON_IsNumber(x) ? x->valuedouble : 0.0;
        }
        r->pass_ms[p] = rn_median(v, m);
        r->total_ms += r->pass_ms[p];
    }
    free(v);
    cJSON_Delete(j);
    return v ? TND_OK : tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
}

static const knob *find_knob(const char *key)
{
    knobs_init();
    if (strcmp(key, "alpha") == 0) /* (its name before the parameter table) */
        key = "min-alpha";
    for (int k = 0; k < n_knobs; k++)
        if (strcmp(knobs[k].key, key) == 0)
            return &knobs[k];
    return NULL;
}

/* ---- the plan: cells and estimators, DIR/sweep-plan.json ----------------------------------- */
/* A sweep's plan. Local and Slurm sweeps write it; `tandem sweep collect` reads it back, so a
 * sweep run anywhere is gathered by the same code. */
typedef struct sweep_plan {
    char scene[1100], out[1000], refdir[1000];
    char env_path[1000], camera_path[1000]; /* the scene options' strings (env points here) */
    rn_env env;                             /* the scene options every job loads with */
    unsigned size[2], frames, warmup, spp;
    unsigned timed; /* frames each cell runs back to back for its times (0: its written frames) */
    bool own_reference; /* the unbiased reference is rendered into DIR/reference */
    int nkeys, total, nests;
    const knob *keys[MAX_KEYS];
    char value[MAX_RUNS][MAX_KEYS][48];
    char cell_size[MAX_RUNS][32], cell_bounces[MAX_RUNS][16];
    int cell_est[MAX_RUNS];
    sweep_estimator ests[MAX_RUNS];
} sweep_plan;

static void cell_dir(const sweep_plan *P, int i, char *buf, size_t cap)
{
    snprintf(buf, cap, "%s/runs/%03d", P->out, i);
}

/* The knobs' values into cells (the first key varies fastest), their sizes, estimators and
 * matched reference directories. A usage error: TND_ERR_INVALID_ARGUMENT naming the option. */
static tnd_result plan_make(const char *const *sweeps, int nkeys, const char *scene,
                            const char *out, const char *reference, unsigned spp,
                            const unsigned size[2], unsigned frames, unsigned warmup,
                            unsigned timed, sweep_plan *P)
{
    const char *values[MAX_KEYS][MAX_VALUES];
    int nvalues[MAX_KEYS];
    tnd_result res = TND_ERR_INVALID_ARGUMENT;
    char *values_buf[MAX_KEYS] = {0};
    if (nkeys > MAX_KEYS)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "at most %d --sweep keys", MAX_KEYS);
    if (!out)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--sweep needs --out DIR");
    if (strlen(out) > 900 || (reference && strlen(reference) > 900) || strlen(scene) > 1000)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "path too long");
    if (warmup >= frames)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--warmup %u must be below --frames %u", warmup,
                        frames);
    int total = 1;
    for (int k = 0; k < nkeys; k++) {
        const char *eq = strchr(sweeps[k], '=');
        char key[32];
        snprintf(key, sizeof key, "%.*s", eq ? (int)(eq - sweeps[k]) : 0, sweeps[k]);
        if (strcmp(key, "spp") == 0) {
            tnd_fail(TND_ERR_INVALID_ARGUMENT,
                     "--sweep spp: the real-time front-ends trace one sample per pixel (the "
                     "A-SVGF gradient samples re-shade that one sample); samples per pixel are "
                     "the references' knob (tandem reference --spp)");
            goto done;
        }
        if (!eq || !(P->keys[k] = find_knob(key))) {
            char list[1024] = "";
            size_t n = 0;
            for (int i = 0; i < n_knobs && n < sizeof list; i++)
                n += (size_t)snprintf(list + n, sizeof list - n, " %s", knobs[i].key);
            tnd_fail(TND_ERR_INVALID_ARGUMENT, "--sweep %s: expected KEY=V1,V2,... with KEY one "
                                               "of:%s", sweeps[k], list);
            goto done;
        }
        for (int j = 0; j < k; j++)
            if (P->keys[j] == P->keys[k]) {
                tnd_fail(TND_ERR_INVALID_ARGUMENT, "--sweep %s given twice", key);
                goto done;
            }
        values_buf[k] = strdup(eq + 1);
        nvalues[k] = 0;
        for (char *save = NULL, *t = strtok_r(values_buf[k], ",", &save);
             t && nvalues[k] < MAX_VALUES; t = strtok_r(NULL, ",", &save)) {
            if (strlen(t) >= sizeof P->value[0][0]) {
                tnd_fail(TND_ERR_INVALID_ARGUMENT, "--sweep %s: value too long", key);
                goto done;
            }
            values[k][nvalues[k]++] = t;
        }
        if (nvalues[k] == 0) {
            tnd_fail(TND_ERR_INVALID_ARGUMENT, "--sweep %s: no values", sweeps[k]);
            goto done;
        }
        if (strcmp(key, "scale") == 0)
            for (int i = 0; i < nvalues[k]; i++) {
                char *end;
                double s = strtod(values[k][i], &end);
                if (*end || !(s >= 0.1 && s <= 1.0)) {
                    tnd_fail(TND_ERR_INVALID_ARGUMENT, "--sweep scale=%s: a scale in [0.1, 1]",
                             values[k][i]);
                    goto done;
                }
            }
        if (strcmp(key, "bounces") == 0)
            for (int i = 0; i < nvalues[k]; i++) {
                unsigned b;
                if (!rn_bounces_parse(values[k][i], SWEEP_MAX_BOUNCES, &b)) {
                    tnd_fail(TND_ERR_INVALID_ARGUMENT,
                             "--sweep bounces=%s: a count (0 to %u) or half", values[k][i],
                             SWEEP_MAX_BOUNCES);
                    goto done;
                }
            }
        if (strcmp(key, "gradient") == 0)
            for (int i = 0; i < nvalues[k]; i++)
                if (strcmp(values[k][i], "on") != 0 && strcmp(values[k][i], "off") != 0) {
                    tnd_fail(TND_ERR_INVALID_ARGUMENT, "--sweep gradient=%s: on or off",
                             values[k][i]);
                    goto done;
                }
        total *= nvalues[k];
        if (total > MAX_RUNS)
            break;
    }
    if (total > MAX_RUNS) {
        tnd_fail(TND_ERR_INVALID_ARGUMENT, "more than %d combinations", MAX_RUNS);
        goto done;
    }
    const char *too_long = NULL; /* (refused by name rather than cut short) */
    if ((size_t)snprintf(P->scene, sizeof P->scene, "%s", scene) >= sizeof P->scene)
        too_long = scene;
    else if ((size_t)snprintf(P->out, sizeof P->out, "%s", out) >= sizeof P->out)
        too_long = out;
    else if ((size_t)snprintf(P->refdir, sizeof P->refdir, reference ? "%s" : "%s/reference",
                              reference ? reference : out) >= sizeof P->refdir)
        too_long = reference ? reference : out;
    if (too_long) {
        tnd_fail(TND_ERR_INVALID_ARGUMENT, "sweep: %s: path too long", too_long);
        goto done;
    }
    P->own_reference = !reference;
    P->size[0] = size[0];
    P->size[1] = size[1];
    P->frames = frames;
    P->warmup = warmup;
    P->timed = timed;
    P->spp = spp;
    P->nkeys = nkeys;
    P->total = total;
    P->nests = 0;
    for (int i = 0; i < total; i++) {
        snprintf(P->cell_size[i], sizeof P->cell_size[i], "%ux%u", size[0], size[1]);
        snprintf(P->cell_bounces[i], sizeof P->cell_bounces[i], "1");
        for (int k = 0, rest = i; k < nkeys; k++) {
            const char *v = values[k][rest % nvalues[k]];
            rest /= nvalues[k];
            snprintf(P->value[i][k], sizeof P->value[i][k], "%s", v);
            if (strcmp(P->keys[k]->key, "scale") == 0) {
                double s = strtod(v, NULL);
                snprintf(P->cell_size[i], sizeof P->cell_size[i], "%ux%u",
                         (unsigned)fmax(1, lround(size[0] * s)),
                         (unsigned)fmax(1, lround(size[1] * s)));
            }
            /* (half: the matched reference of 1, whose expectation it has) */
            if (strcmp(P->keys[k]->key, "bounces") == 0)
                snprintf(P->cell_bounces[i], sizeof P->cell_bounces[i], "%s",
                         strcmp(v, "half") == 0 ? "1" : v);
        }
        /* the cell's estimator (its bounces and resolution) and its matched reference */
        P->cell_est[i] = -1;
        for (int e = 0; e < P->nests; e++)
            if (!strcmp(P->ests[e].bounces, P->cell_bounces[i]) &&
                !strcmp(P->ests[e].size, P->cell_size[i]))
                P->cell_est[i] = e;
        if (P->cell_est[i] < 0) {
            sweep_estimator *es = &P->ests[P->nests];
            _Static_assert(sizeof es->bounces == sizeof P->cell_bounces[0] &&
                               sizeof es->size == sizeof P->cell_size[0], "the same strings");
            memcpy(es->bounces, P->cell_bounces[i], sizeof es->bounces);
            memcpy(es->size, P->cell_size[i], sizeof es->size);
            char b[16], sz[32]; /* (copies: es->dir is in *P as well) */
            memcpy(b, es->bounces, sizeof b);
            memcpy(sz, es->size, sizeof sz);
            snprintf(es->dir, sizeof es->dir, "%s/matched/bounces%s_%s", out, b, sz);
            P->cell_est[i] = P->nests++;
        }
    }
    res = TND_OK;
done:
    for (int k = 0; k < MAX_KEYS; k++)
        free(values_buf[k]);
    return res;
}

/* The sweep's work as render's and reference's options (rn_render runs them here; their
 * command lines, rn_render_args, go into the Slurm jobs). Strings live in the job. */
typedef struct sweep_job {
    rn_render_opts o;
    bool reference;
    char dir[1300];
} sweep_job;

/* the unbiased reference (on the GPU) */
static void job_reference(const sweep_plan *P, sweep_job *j)
{
    rn_render_defaults(&j->o);
    j->reference = true;
    j->o.frontend = "vk";
    j->o.scene = P->scene;
    j->o.env = P->env;
    j->o.frames = P->frames;
    j->o.size[0] = P->size[0];
    j->o.size[1] = P->size[1];
    j->o.spp = P->spp;
    j->o.out = P->refdir;
    j->o.quiet = true;
}

/* an estimator's matched reference (Embree: the same samples as Vulkan's, without a contract
 * read back per sample) */
static tnd_result job_matched(const sweep_plan *P, int e, sweep_job *j)
{
    const sweep_estimator *es = &P->ests[e];
    rn_render_defaults(&j->o);
    j->reference = true;
    j->o.estimator = "realtime";
    j->o.frontend = "embree";
    j->o.scene = P->scene;
    j->o.env = P->env;
    j->o.frames = P->frames;
    j->o.spp = P->spp;
    j->o.out = es->dir;
    j->o.quiet = true;
    char *end;
    unsigned long b = strtoul(es->bounces, &end, 10);
    if (*end || end == es->bounces || b > SWEEP_MAX_BOUNCES ||
        sscanf(es->size, "%ux%u", &j->o.size[0], &j->o.size[1]) != 2)
        return tnd_fail(TND_ERR_BAD_INPUT, "bench: estimator %d: bounces '%s', size '%s'", e,
                        es->bounces, es->size);
    j->o.ref_bounces = (unsigned)b;
    return TND_OK;
}

/* cell i: render on the GPU with the cell's knob values */
static tnd_result job_cell(const sweep_plan *P, int i, sweep_job *j)
{
    rn_render_defaults(&j->o);
    cell_dir(P, i, j->dir, sizeof j->dir);
    j->reference = false;
    j->o.scene = P->scene;
    j->o.env = P->env;
    j->o.frames = P->frames;
    j->o.out = j->dir;
    j->o.quiet = true;
    j->o.frontend = "vk";
    j->o.timed_frames = P->timed; /* its times: frames back to back after those written */
    if (sscanf(P->cell_size[i], "%ux%u", &j->o.size[0], &j->o.size[1]) != 2)
        return tnd_fail(TND_ERR_BAD_INPUT, "bench: cell %d: size '%s'", i, P->cell_size[i]);
    for (int k = 0; k < P->nkeys; k++) {
        const char *key = P->keys[k]->key, *val = P->value[i][k];
        char *end;
        if (strcmp(key, "scale") == 0) {
            continue; /* (in the cell's size) */
        } else if (strcmp(key, "bounces") == 0) {
            unsigned b;
            if (!rn_bounces_parse(val, SWEEP_MAX_BOUNCES, &b))
                return tnd_fail(TND_ERR_BAD_INPUT, "bench: --sweep bounces=%s: a count (0 to %u) "
                                                   "or half", val, SWEEP_MAX_BOUNCES);
            j->o.bounces = rn_bounces_split(b, &j->o.half_indirect);
        } else if (strcmp(key, "gradient") == 0) {
            /* on: the denoiser of re-shaded gradient samples; off: its fallback */
            const pl_denoiser_info *g = pl_denoiser_with(PL_DN_GRADIENTS);
            if (!g)
                return tnd_fail(TND_ERR_UNSUPPORTED, "bench: --sweep gradient: no denoiser "
                                                     "takes gradient samples");
            j->o.denoiser = strcmp(val, "on") == 0 || !g->fallback ? g->name : g->fallback;
        } else if (strcmp(key, "denoiser") == 0) {
            j->o.denoiser = val;
        } else if (strcmp(key, "precision") == 0) {
            j->o.precision = val;
        } else if (strcmp(key, "taa") == 0) {
            j->o.taa = val;
        } else if (strcmp(key, "render-scale") == 0) {
            double x = strtod(val, &end);
            if (*end || !(x >= 0.25 && x <= 1))
                return tnd_fail(TND_ERR_BAD_INPUT, "bench: --sweep render-scale=%s: 0.25 to 1",
                                val);
            j->o.render_scale = x;
        } else if (strcmp(key, "upscaler") == 0) {
            j->o.upscaler = val;
        } else if (strcmp(key, "frontend") == 0) {
            j->o.frontend = val;
        } else { /* a denoiser parameter (pl_param) */
            double x = strtod(val, &end);
            if (*end || end == val)
                return tnd_fail(TND_ERR_BAD_INPUT, "bench: --sweep %s=%s: a number", key, val);
            TND_TRY_RETURN(pl_param_set_put(&j->o.params, key, x));
        }
    }
    return TND_OK;
}

static tnd_result plan_write(const sweep_plan *P)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "tandem_sweep_plan", 1);
    cJSON_AddStringToObject(j, "scene", P->scene);
    cJSON_AddStringToObject(j, "reference", P->refdir);
    cJSON_AddBoolToObject(j, "own_reference", P->own_reference);
    cJSON_AddNumberToObject(j, "width", P->size[0]);
    cJSON_AddNumberToObject(j, "height", P->size[1]);
    cJSON_AddNumberToObject(j, "frames", P->frames);
    cJSON_AddNumberToObject(j, "warmup", P->warmup);
    cJSON_AddNumberToObject(j, "timed_frames", P->timed);
    cJSON_AddNumberToObject(j, "spp", P->spp);
    cJSON *so = cJSON_AddObjectToObject(j, "scene_options");
    cJSON_AddStringToObject(so, "env", P->env_path);
    cJSON_AddNumberToObject(so, "env_intensity", P->env.intensity);
    cJSON_AddNumberToObject(so, "env_rotation", P->env.rotation);
    cJSON_AddBoolToObject(so, "no_default_light", P->env.no_default_light);
    cJSON_AddBoolToObject(so, "up_z", P->env.up && strcmp(P->env.up, "z") == 0);
    cJSON_AddStringToObject(so, "camera_path", P->camera_path);
    cJSON_AddNumberToObject(so, "path_duration", P->env.path_duration);
    cJSON_AddNumberToObject(so, "path_radius", P->env.path_radius);
    if (isfinite(P->env.path_height))
        cJSON_AddNumberToObject(so, "path_height", P->env.path_height);
    cJSON *ka = cJSON_AddArrayToObject(j, "knobs");
    for (int k = 0; k < P->nkeys; k++)
        cJSON_AddItemToArray(ka, cJSON_CreateString(P->keys[k]->key));
    cJSON *ea = cJSON_AddArrayToObject(j, "estimators");
    for (int e = 0; e < P->nests; e++) {
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "bounces", P->ests[e].bounces);
        cJSON_AddStringToObject(o, "size", P->ests[e].size);
        cJSON_AddStringToObject(o, "dir", P->ests[e].dir);
        cJSON_AddItemToArray(ea, o);
    }
    cJSON *ca = cJSON_AddArrayToObject(j, "cells");
    for (int i = 0; i < P->total; i++) {
        cJSON *o = cJSON_CreateObject();
        cJSON *v = cJSON_AddArrayToObject(o, "values");
        for (int k = 0; k < P->nkeys; k++)
            cJSON_AddItemToArray(v, cJSON_CreateString(P->value[i][k]));
        cJSON_AddStringToObject(o, "size", P->cell_size[i]);
        cJSON_AddNumberToObject(o, "estimator", P->cell_est[i]);
        char dir[1300];
        cell_dir(P, i, dir, sizeof dir);
        cJSON_AddStringToObject(o, "dir", dir);
        cJSON_AddItemToArray(ca, o);
    }
    char path[1100];
    snprintf(path, sizeof path, "%s/sweep-plan.json", P->out);
    tnd_result res = rn_json_write(path, j);
    cJSON_Delete(j);
    return res;
}

static const char *jstr(const cJSON *j, const char *key, size_t max, bool *ok)
{
    const cJSON *v = cJSON_GetObjectItem(j, key);
    if (!cJSON_IsString(v) || strlen(v->valuestring) >= max) {
        *ok = false;
        return "";
    }
    return v->valuestring;
}

static unsigned jnum(const cJSON *j, const char *key, unsigned max, bool *ok)
{
    const cJSON *v = cJSON_GetObjectItem(j, key);
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0 && v->valuedouble <= max)) {
        *ok = false;
        return 0;
    }
    return (unsigned)v->valuedouble;
}

/* DIR/sweep-plan.json back into a plan; every field checked. */
static tnd_result plan_read(const char *dir, sweep_plan *P)
{
    char path[1100];
    if (strlen(dir) > 900)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: path too long", dir);
    snprintf(path, sizeof path, "%s/sweep-plan.json", dir);
    void *txt = NULL;
    size_t len = 0;
    tnd_result res = tnd_file_read(path, &txt, &len);
    if (res != TND_OK)
        return tnd_fail(TND_ERR_IO, "%s: no sweep plan (tandem bench --sweep ... writes "
                        "one)", path);
    cJSON *j = cJSON_ParseWithLength(txt, len);
    free(txt);
    bool ok = j && cJSON_IsNumber(cJSON_GetObjectItem(j, "tandem_sweep_plan"));
    const cJSON *ka = cJSON_GetObjectItem(j, "knobs"), *ea = cJSON_GetObjectItem(j, "estimators"),
                *ca = cJSON_GetObjectItem(j, "cells");
    ok = ok && cJSON_IsArray(ka) && cJSON_IsArray(ea) && cJSON_IsArray(ca);
    if (ok) {
        snprintf(P->out, sizeof P->out, "%s", dir);
        snprintf(P->scene, sizeof P->scene, "%s", jstr(j, "scene", sizeof P->scene, &ok));
        snprintf(P->refdir, sizeof P->refdir, "%s", jstr(j, "reference", sizeof P->refdir, &ok));
        P->own_reference = cJSON_IsTrue(cJSON_GetObjectItem(j, "own_reference"));
        P->size[0] = jnum(j, "width", 1u << 16, &ok);
        P->size[1] = jnum(j, "height", 1u << 16, &ok);
        P->frames = jnum(j, "frames", 1u << 20, &ok);
        P->warmup = jnum(j, "warmup", 1u << 20, &ok);
        P->timed = cJSON_GetObjectItem(j, "timed_frames") /* (a plan from before it: none) */
                       ? jnum(j, "timed_frames", 1u << 20, &ok)
                       : 0;
        P->spp = jnum(j, "spp", ~0u, &ok);
        P->env = (rn_env)RN_ENV_INIT;
        const cJSON *so = cJSON_GetObjectItem(j, "scene_options"); /* (older plans: none) */
        if (so) {
            snprintf(P->env_path, sizeof P->env_path, "%s",
                     jstr(so, "env", sizeof P->env_path, &ok));
            snprintf(P->camera_path, sizeof P->camera_path, "%s",
                     jstr(so, "camera_path", sizeof P->camera_path, &ok));
            const char *nums[] = {"env_intensity", "env_rotation", "path_duration", "path_radius",
                                  "path_height"};
            double *dst[] = {&P->env.intensity, &P->env.rotation, &P->env.path_duration,
                             &P->env.path_radius, &P->env.path_height};
            for (int k = 0; k < 5; k++) {
                const cJSON *v = cJSON_GetObjectItem(so, nums[k]);
                if (v && !(cJSON_IsNumber(v) && isfinite(v->valuedouble)))
                    ok = false;
                else if (v)
                    *dst[k] = v->valuedouble;
            }
            P->env.no_default_light = cJSON_IsTrue(cJSON_GetObjectItem(so, "no_default_light"));
            P->env.up = cJSON_IsTrue(cJSON_GetObjectItem(so, "up_z")) ? "z" : "y";
            P->env.path = P->env_path[0] ? P->env_path : NULL;
            P->env.camera_path = P->camera_path[0] ? P->camera_path : NULL;
        }
        P->nkeys = cJSON_GetArraySize(ka);
        P->nests = cJSON_GetArraySize(ea);
        P->total = cJSON_GetArraySize(ca);
        ok = ok && P->nkeys <= MAX_KEYS && P->nests <= MAX_RUNS && P->total <= MAX_RUNS &&
             P->total > 0 && P->warmup < P->frames;
    }
    for (int k = 0; ok && k < P->nkeys; k++) {
        const cJSON *v = cJSON_GetArrayItem(ka, k);
        ok = cJSON_IsString(v) && (P->keys[k] = find_knob(v->valuestring)) != NULL;
    }
    for (int e = 0; ok && e < P->nests; e++) {
        const cJSON *o = cJSON_GetArrayItem(ea, e);
        sweep_estimator *es = &P->ests[e];
        snprintf(es->bounces, sizeof es->bounces, "%s", jstr(o, "bounces", sizeof es->bounces, &ok));
        snprintf(es->size, sizeof es->size, "%s", jstr(o, "size", sizeof es->size, &ok));
        snprintf(es->dir, sizeof es->dir, "%s", jstr(o, "dir", sizeof es->dir, &ok));
    }
    for (int i = 0; ok && i < P->total; i++) {
        const cJSON *o = cJSON_GetArrayItem(ca, i), *v = cJSON_GetObjectItem(o, "values");
        ok = cJSON_IsArray(v) && cJSON_GetArraySize(v) == P->nkeys;
        for (int k = 0; ok && k < P->nkeys; k++) {
            const cJSON *s = cJSON_GetArrayItem(v, k);
            ok = cJSON_IsString(s) && strlen(s->valuestring) < sizeof P->value[i][k];
            if (ok)
                snprintf(P->value[i][k], sizeof P->value[i][k], "%s", s->valuestring);
        }
        snprintf(P->cell_size[i], sizeof P->cell_size[i], "%s",
                 jstr(o, "size", sizeof P->cell_size[i], &ok));
        P->cell_est[i] = (int)jnum(o, "estimator", MAX_RUNS, &ok);
        ok = ok && P->cell_est[i] < P->nests;
    }
    cJSON_Delete(j);
    return ok ? TND_OK : tnd_fail(TND_ERR_BAD_INPUT, "%s: not a valid sweep plan", path);
}

/* ---- running a sweep here, or writing it out for Slurm -------------------------------------- */
static bool exists(const char *path);
static tnd_result sweep_collect(const char *dir, bool *complete, const rn_host *h,
                                ev_text *table);

/* A job already done (resuming): a reference with its reference.json, a run whose run.json does
 * not say it was interrupted. */
static bool job_done(const sweep_job *j, bool reference)
{
    char path[1400];
    snprintf(path, sizeof path, "%s/%s", j->o.out, reference ? "reference.json" : "run.json");
    if (!exists(path))
        return false;
    if (reference)
        return true;
    void *txt = NULL;
    size_t len = 0;
    bool done = tnd_file_read(path, &txt, &len) == TND_OK && !strstr(txt, "\"interrupted\"");
    free(txt);
    return done;
}

/* One job of the plan (resuming: not when done; a reference interrupted goes on). A failure is
 * said as the render's own (the sweep says which job after). */
static tnd_result run_job(sweep_job *j, bool reference, bool resume, const rn_host *h)
{
    if (resume && job_done(j, reference))
        return TND_OK;
    char path[1400];
    snprintf(path, sizeof path, "%s/reference.partial.json", j->o.out);
    if (resume && reference && exists(path))
        j->o.resume = j->o.out;
    return rn_render_nested(&j->o, reference, h);
}

/* The plan's jobs here, in order (resume: those not done yet); *stopped: interrupted (the job
 * in flight kept what it finished; tandem sweep resume DIR goes on). */
static tnd_result run_local(const sweep_plan *P, bool resume, int *stopped, const rn_host *h)
{
    tnd_result res = TND_OK;
    sweep_job j;
    *stopped = 0;
    if (P->own_reference) {
        job_reference(P, &j);
        if (run_job(&j, true, resume, h) != TND_OK && !(*stopped = rn_interrupted(h)))
            return tnd_fail(TND_ERR_IO, "bench: the reference (%s) failed", P->refdir);
    }
    rn_progress bar;
    rn_progress_begin(&bar, h, "sweep", (uint64_t)(P->nests + P->total));
    for (int e = 0; e < P->nests && res == TND_OK && !*stopped; e++) {
        if ((res = job_matched(P, e, &j)) == TND_OK && run_job(&j, true, resume, h) != TND_OK &&
            !(*stopped = rn_interrupted(h)))
            res = tnd_fail(TND_ERR_IO, "bench: the matched reference %s failed", P->ests[e].dir);
        rn_progress_step(&bar, (uint64_t)e + 1);
    }
    for (int i = 0; res == TND_OK && !*stopped && i < P->total; i++) {
        if ((res = job_cell(P, i, &j)) == TND_OK && run_job(&j, false, resume, h) != TND_OK &&
            !(*stopped = rn_interrupted(h)))
            res = tnd_fail(TND_ERR_IO, "bench: sweep run %d (%s) failed", i, j.dir);
        rn_progress_step(&bar, (uint64_t)(P->nests + i + 1));
    }
    if (res == TND_OK && !*stopped)
        *stopped = rn_interrupted(h);
    rn_progress_end(&bar);
    return res;
}

static tnd_result emit_slurm(const sweep_plan *P, unsigned shards, const rn_host *h,
                             char *submit, size_t cap)
{
    char tandem[4096], sdir[1100], logs[1200], path[1300];
    ssize_t l = readlink("/proc/self/exe", tandem, sizeof tandem - 1);
    if (l <= 0)
        return tnd_fail(TND_ERR_IO, "bench: cannot find the tandem binary (/proc/self/exe)");
    tandem[l] = 0;
    snprintf(sdir, sizeof sdir, "%s/slurm", P->out);
    snprintf(logs, sizeof logs, "%s/logs", sdir);
    TND_TRY_RETURN(tnd_mkdirs(logs));
    sweep_job j;
    rn_args a;
    FILE *f;
    /* the unbiased reference: one task per shard, then their merge */
    if (P->own_reference) {
        snprintf(path, sizeof path, "%s/reference.sbatch", sdir);
        if (!(f = fopen(path, "w")))
            return tnd_fail(TND_ERR_IO, "bench: %s: cannot create", path);
        rn_sh_preamble(f, "tandem bench", "the unbiased reference, one shard per task", "reference", (int)shards);
        job_reference(P, &j);
        j.o.out = NULL; /* (its --out and --quiet are the shard's) */
        j.o.quiet = false;
        TND_TRY_RETURN(rn_render_args(&j.o, true, &a));
        rn_sh_command(f, tandem, &a, "--threads \"$threads\" --quiet \\\n    --shard "
                                  "\"$SLURM_ARRAY_TASK_ID/");
        fprintf(f, "%u\" --out ", shards);
        rn_sh_word(f, sdir);
        fprintf(f, "/shards/reference_$SLURM_ARRAY_TASK_ID\n");
        if (fclose(f) != 0)
            return tnd_fail(TND_ERR_IO, "bench: %s: write failed", path);
        snprintf(path, sizeof path, "%s/merge.sbatch", sdir);
        if (!(f = fopen(path, "w")))
            return tnd_fail(TND_ERR_IO, "bench: %s: cannot create", path);
        rn_sh_preamble(f, "tandem bench", "the reference's shards merged", "merge", 0);
        rn_sh_word(f, tandem);
        fprintf(f, " merge --quiet");
        for (unsigned s = 0; s < shards; s++) {
            fprintf(f, " \\\n    ");
            rn_sh_word(f, sdir);
            fprintf(f, "/shards/reference_%u", s);
        }
        fprintf(f, " \\\n    --out ");
        rn_sh_word(f, P->refdir);
        fprintf(f, "\n");
        if (fclose(f) != 0)
            return tnd_fail(TND_ERR_IO, "bench: %s: write failed", path);
    }
    /* the matched references, one task per estimator; the cells, one task per cell (a failed
     * cell leaves DIR/runs/NNN.failed with its exit status for collect) */
    for (int w = 0; w < 2; w++) {
        snprintf(path, sizeof path, "%s/%s.sbatch", sdir, w ? "cells" : "matched");
        if (!(f = fopen(path, "w")))
            return tnd_fail(TND_ERR_IO, "bench: %s: cannot create", path);
        rn_sh_preamble(f, "tandem bench", w ? "the sweep's cells, one per task"
                         : "the matched references, one estimator per task",
                    w ? "cells" : "matched", w ? P->total : P->nests);
        fprintf(f, "case $SLURM_ARRAY_TASK_ID in\n");
        for (int i = 0; i < (w ? P->total : P->nests); i++) {
            fprintf(f, "%d)\n    ", i);
            if (w) {
                TND_TRY_RETURN(job_cell(P, i, &j));
                TND_TRY_RETURN(rn_render_args(&j.o, false, &a));
                fprintf(f, "rm -f ");
                rn_sh_word(f, j.dir);
                fprintf(f, ".failed\n    ");
                rn_sh_command(f, tandem, &a, "--threads \"$threads\"");
                fprintf(f, "\n    rc=$?\n    [ $rc -eq 0 ] || echo \"exit $rc\" > ");
                rn_sh_word(f, j.dir);
                fprintf(f, ".failed\n    exit $rc ;;\n");
            } else {
                TND_TRY_RETURN(job_matched(P, i, &j));
                TND_TRY_RETURN(rn_render_args(&j.o, true, &a));
                rn_sh_command(f, tandem, &a, "--threads \"$threads\"");
                fprintf(f, " ;;\n");
            }
        }
        fprintf(f, "*) echo \"no task $SLURM_ARRAY_TASK_ID\" >&2; exit 2 ;;\nesac\n");
        if (fclose(f) != 0)
            return tnd_fail(TND_ERR_IO, "bench: %s: write failed", path);
    }
    snprintf(path, sizeof path, "%s/collect.sbatch", sdir);
    if (!(f = fopen(path, "w")))
        return tnd_fail(TND_ERR_IO, "bench: %s: cannot create", path);
    rn_sh_preamble(f, "tandem bench", "the finished cells gathered into sweep.json, sweep.csv and the report",
                "collect", 0);
    rn_sh_word(f, tandem);
    fprintf(f, " sweep collect --quiet ");
    rn_sh_word(f, P->out);
    fprintf(f, "\n");
    if (fclose(f) != 0)
        return tnd_fail(TND_ERR_IO, "bench: %s: write failed", path);
    /* submit.sh: every job with its dependencies; its arguments go to every sbatch (partition,
     * account, CPUs per task), $TANDEM_SBATCH_GPU to those of Vulkan work (--gres=gpu:1) */
    snprintf(path, sizeof path, "%s/submit.sh", sdir);
    if (!(f = fopen(path, "w")))
        return tnd_fail(TND_ERR_IO, "bench: %s: cannot create", path);
    fprintf(f, "#!/bin/bash\n"
               "# Submits the sweep to Slurm: submit.sh [SBATCH_OPTION...] (given to every job, e.g.\n"
               "# --partition=P --cpus-per-task=N); TANDEM_SBATCH_GPU adds options to the jobs on\n"
               "# Vulkan (the reference shards and the cells), e.g. TANDEM_SBATCH_GPU=--gres=gpu:1.\n"
               "# Prints the job ids; the last one gathers the results (tandem sweep collect).\n"
               "set -euo pipefail\n"
               "cd \"$(dirname \"$0\")\"\n"
               "gpu=(${TANDEM_SBATCH_GPU:-})\n"
               "after=\"\"\n");
    if (P->own_reference)
        fprintf(f, "ref=$(sbatch --parsable \"$@\" \"${gpu[@]}\" --output=logs/reference_%%a.out "
                   "reference.sbatch)\n"
                   "merge=$(sbatch --parsable \"$@\" --output=logs/merge_%%j.out "
                   "--dependency=afterok:$ref --kill-on-invalid-dep=yes merge.sbatch)\n"
                   "echo \"reference shards: $ref, merge: $merge\"\n"
                   "after=\":$merge\"\n");
    fprintf(f, "matched=$(sbatch --parsable \"$@\" --output=logs/matched_%%a.out matched.sbatch)\n"
               "cells=$(sbatch --parsable \"$@\" \"${gpu[@]}\" --output=logs/cells_%%a.out "
               "--dependency=afterok:$matched$after --kill-on-invalid-dep=yes cells.sbatch)\n"
               "collect=$(sbatch --parsable \"$@\" --output=logs/collect_%%j.out "
               "--dependency=afterany:$cells collect.sbatch)\n"
               "echo \"matched references: $matched, cells: $cells, collect: $collect\"\n");
    if (fclose(f) != 0 || chmod(path, 0755) != 0)
        return tnd_fail(TND_ERR_IO, "bench: %s: write failed", path);
    rn_say(h, "tandem: bench: %d cells, %d matched references%s -> %s/submit.sh", P->total,
           P->nests, P->own_reference ? ", the reference in shards" : "", sdir);
    snprintf(submit, cap, "%s/submit.sh", sdir);
    return TND_OK;
}

/* A path made absolute (the cluster's nodes start elsewhere); `p` need not exist. False when
 * it does not fit. */
static bool absolute(const char *p, char *out, size_t cap)
{
    char cwd[900];
    size_t lp = strlen(p), lc;
    if (p[0] == '/' || strncmp(p, "stress:", 7) == 0) {
        if (lp >= cap)
            return false;
        memcpy(out, p, lp + 1);
        return true;
    }
    if (!getcwd(cwd, sizeof cwd) || (lc = strlen(cwd)) + 1 + lp >= cap)
        return false;
    memcpy(out, cwd, lc);
    out[lc] = '/';
    memcpy(out + lc + 1, p, lp + 1);
    return true;
}

/* After a local sweep's jobs: interrupted (said, with how to go on), or collected. */
static tnd_result finish_local(tnd_result res, int stopped, const char *out, const char *what,
                               const rn_host *h, ev_text *table)
{
    if (res == TND_OK && stopped) {
        rn_warn(h, "tandem: %s: interrupted (%s): the jobs done are kept; tandem sweep resume %s "
                   "goes on", what, rn_signal_name(stopped), out);
        return tnd_fail(TND_ERR_INTERRUPTED, "%s: interrupted (%s)", what, rn_signal_name(stopped));
    }
    bool complete = false;
    if (res == TND_OK)
        res = sweep_collect(out, &complete, h, table);
    return res;
}

/* The sweep's plan from its options (paths made absolute for Slurm, whose jobs start elsewhere)
 * and every job's options made once: a bad value is said before any work. *in_job: the error is
 * a job's (a knob's value), not the sweep's own options. */
static tnd_result prepare(const rn_sweep_opts *so, sweep_plan *P, bool *in_job)
{
    char scene_abs[1100], out_abs[1000], ref_abs[1000], env_abs[1000], path_abs[1000];
    const char *scene = so->scene, *out = so->out, *reference = so->reference;
    const char *env_path = so->env.path, *cam_path = so->env.camera_path;
    *in_job = false;
    if (so->emit && strcmp(so->emit, "slurm") != 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--emit %s: slurm is the one scheduler written "
                                                  "for", so->emit);
    if (so->emit && out) {
        if (!absolute(scene, scene_abs, sizeof scene_abs) ||
            !absolute(out, out_abs, sizeof out_abs) ||
            (reference && !absolute(reference, ref_abs, sizeof ref_abs)) ||
            (env_path && !absolute(env_path, env_abs, sizeof env_abs)) ||
            (cam_path && strchr(cam_path, '.') && !absolute(cam_path, path_abs, sizeof path_abs)))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "path too long");
        env_path = env_path ? env_abs : NULL; /* (the jobs run elsewhere) */
        cam_path = cam_path && strchr(cam_path, '.') ? path_abs : cam_path;
        scene = scene_abs;
        out = out_abs;
        reference = reference ? ref_abs : NULL;
    }
    if ((env_path && strlen(env_path) >= sizeof P->env_path) ||
        (cam_path && strlen(cam_path) >= sizeof P->camera_path))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "path too long");
    P->env = so->env;
    snprintf(P->env_path, sizeof P->env_path, "%s", env_path ? env_path : "");
    snprintf(P->camera_path, sizeof P->camera_path, "%s", cam_path ? cam_path : "");
    P->env.path = env_path ? P->env_path : NULL;
    P->env.camera_path = cam_path ? P->camera_path : NULL;
    TND_TRY_RETURN(plan_make(so->sweeps, so->nsweeps, scene, out, reference, so->spp, so->size,
                             so->frames, so->warmup, so->timed, P));
    sweep_job *j = malloc(sizeof *j);
    tnd_result jr = j ? TND_OK : tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
    for (int e = 0; jr == TND_OK && e < P->nests; e++)
        jr = job_matched(P, e, j);
    for (int i = 0; jr == TND_OK && i < P->total; i++)
        jr = job_cell(P, i, j);
    free(j);
    if (jr != TND_OK) {
        *in_job = true;
        return jr;
    }
    if (so->emit && (so->shards == 0 || so->shards > so->frames * ((so->spp + TND_REF_CHECK_EVERY -
                                                                      1) / TND_REF_CHECK_EVERY)))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "--ref-shards %u: 1 to the reference's batches "
                                                  "of %u samples (%u frames x %u samples)",
                        so->shards, TND_REF_CHECK_EVERY, so->frames, so->spp);
    return TND_OK;
}

tnd_result rn_sweep_check(const rn_sweep_opts *o, bool *in_job)
{
    sweep_plan *P = calloc(1, sizeof *P);
    if (!P)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
    tnd_result res = prepare(o, P, in_job);
    free(P);
    return res;
}

tnd_result rn_sweep(const rn_sweep_opts *o, const rn_host *h, rn_sweep_result *r)
{
    *r = (rn_sweep_result){0};
    sweep_plan *P = calloc(1, sizeof *P);
    bool in_job;
    if (!P)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
    tnd_result res = prepare(o, P, &in_job);
    if (res == TND_OK)
        res = tnd_mkdirs(P->out);
    if (res == TND_OK)
        res = plan_write(P);
    if (o->emit) { /* (written for Slurm: nothing runs here) */
        if (res == TND_OK)
            res = emit_slurm(P, o->shards, h, r->submit, sizeof r->submit);
        free(P);
        return res;
    }
    int stopped = 0, lock_fd = -1;
    if (res == TND_OK && (res = rn_lock_dir(P->out, &lock_fd)) == TND_OK)
        res = run_local(P, false, &stopped, h);
    char out[1000];
    snprintf(out, sizeof out, "%s", P->out);
    free(P);
    res = finish_local(res, stopped, out, "bench", h, &r->table);
    rn_unlock_dir(out, lock_fd);
    return res;
}

tnd_result rn_sweep_resume(const char *dir, const rn_host *h, rn_sweep_result *r)
{
    *r = (rn_sweep_result){0};
    sweep_plan *P = calloc(1, sizeof *P);
    if (!P)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
    int stopped = 0, lock_fd = -1;
    tnd_result res = plan_read(dir, P);
    if (res == TND_OK && (res = rn_lock_dir(dir, &lock_fd)) == TND_OK)
        res = run_local(P, true, &stopped, h);
    free(P);
    res = finish_local(res, stopped, dir, "sweep", h, &r->table);
    rn_unlock_dir(dir, lock_fd);
    return res;
}

tnd_result rn_sweep_collect(const char *dir, const rn_host *h, rn_sweep_result *r)
{
    *r = (rn_sweep_result){0};
    bool complete = false;
    return sweep_collect(dir, &complete, h, &r->table);
}

void rn_sweep_result_free(rn_sweep_result *r)
{
    ev_text_free(&r->table);
}

/* ---- gathering: evaluate what finished, write sweep.json, sweep.csv and the report ---------- */
static bool exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Read the plan, evaluate each finished cell (timings, against its matched reference and the
 * unbiased one), name the failed and missing ones, and write the outputs over the finished. */
static tnd_result sweep_collect(const char *dir, bool *complete, const rn_host *h,
                                ev_text *table)
{
    sweep_plan *P = calloc(1, sizeof *P);
    sweep_run *runs = NULL;
    int *cell_of = NULL;
    tnd_result res = TND_OK;
    ev_text html = {0}, problems = {0};
    cJSON *root = NULL, *failed = NULL, *missing = NULL;
    *complete = false;
    if (!P)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
    TND_TRY(plan_read(dir, P));
    passes_init();
    runs = calloc((size_t)P->total, sizeof *runs);
    cell_of = calloc((size_t)P->total, sizeof *cell_of);
    if (!runs || !cell_of) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
        goto fail;
    }
    char path[1400];
    snprintf(path, sizeof path, "%s/reference.json", P->refdir);
    if (!exists(path)) {
        res = tnd_fail(TND_ERR_IO, "%s: the unbiased reference is not there (its job "
                       "failed or has not run)", P->refdir);
        goto fail;
    }
    bool est_ok[MAX_RUNS];
    for (int e = 0; e < P->nests; e++) {
        snprintf(path, sizeof path, "%s/reference.json", P->ests[e].dir);
        est_ok[e] = exists(path);
        if (est_ok[e])
            TND_TRY(eval_against(P->ests[e].dir, P->refdir, P->warmup, &P->ests[e].bias));
    }
    failed = cJSON_CreateArray();
    missing = cJSON_CreateArray();
    int total = 0;
    rn_progress bar;
    rn_progress_begin(&bar, h, "collect", (uint64_t)P->total);
    for (int i = 0; i < P->total; i++) {
        char cdir[1300], why[1200] = "";
        cell_dir(P, i, cdir, sizeof cdir);
        snprintf(path, sizeof path, "%s.failed", cdir);
        void *txt = NULL;
        size_t len = 0;
        bool is_failed = exists(path) && tnd_file_read(path, &txt, &len) == TND_OK;
        if (is_failed) /* (its first line: "exit N") */
            snprintf(why, sizeof why, "%.*s", (int)strcspn(txt, "\n"), (char *)txt);
        free(txt);
        snprintf(path, sizeof path, "%s/run.json", cdir);
        bool done = !is_failed && exists(path);
        if (done && !est_ok[P->cell_est[i]])
            snprintf(why, sizeof why, "its matched reference %s is not there",
                     P->ests[P->cell_est[i]].dir);
        if (!done || !est_ok[P->cell_est[i]]) {
            cJSON *o = cJSON_CreateObject();
            cJSON_AddNumberToObject(o, "cell", i);
            cJSON *kv = cJSON_AddObjectToObject(o, "knobs");
            ev_text_add(&problems, "  cell %d (", i);
            for (int k = 0; k < P->nkeys; k++) {
                cJSON_AddStringToObject(kv, P->keys[k]->key, P->value[i][k]);
                ev_text_add(&problems, "%s%s=%s", k ? " " : "", P->keys[k]->key, P->value[i][k]);
            }
            ev_text_add(&problems, "): %s%s%s\n", is_failed ? "failed" : "missing",
                        why[0] ? ", " : "", why);
            cJSON_AddStringToObject(o, "dir", cdir);
            if (why[0])
                cJSON_AddStringToObject(o, "why", why);
            cJSON_AddItemToArray(is_failed ? failed : missing, o);
            rn_progress_step(&bar, (uint64_t)i + 1);
            continue;
        }
        sweep_run *r = &runs[total];
        for (int k = 0; k < P->nkeys; k++)
            r->value[k] = P->value[i][k];
        r->estimator = P->cell_est[i];
        TND_TRY(read_timings(cdir, P->warmup, r));
        TND_TRY(eval_against(cdir, P->ests[r->estimator].dir, P->warmup, &r->metrics));
        TND_TRY(eval_against(cdir, P->refdir, P->warmup, &r->whole));
        cell_of[total++] = i;
        rn_progress_step(&bar, (uint64_t)i + 1);
    }
    rn_progress_end(&bar);
    if (total == 0) {
        res = tnd_fail(TND_ERR_IO, "%s: no cell has finished:\n%s", dir,
                       problems.s ? problems.s : "");
        goto fail;
    }
    const char *scene = P->scene, *refdir = P->refdir, *out = P->out;
    const unsigned *size = P->size;
    unsigned frames = P->frames, warmup = P->warmup;
    int nkeys = P->nkeys, nests = P->nests;
    const knob *const *keys = P->keys;
    const sweep_estimator *ests = P->ests;
    /* Pareto fronts and the outputs */
    double *tx = malloc((size_t)total * sizeof *tx), *ya = malloc((size_t)total * sizeof *ya),
           *yb = malloc((size_t)total * sizeof *yb);
    bool *pa = malloc((size_t)total), *pb = malloc((size_t)total);
    char (*label)[160] = malloc((size_t)total * sizeof *label);
    const char **labels = malloc((size_t)total * sizeof *labels);
    if (!tx || !ya || !yb || !pa || !pb || !label || !labels) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory");
        free(tx), free(ya), free(yb), free(pa), free(pb), free(label), free(labels);
        goto fail;
    }
    for (int i = 0; i < total; i++) {
        tx[i] = runs[i].total_ms;
        ya[i] = runs[i].metrics.relmse;
        yb[i] = runs[i].metrics.flip;
        size_t n = 0;
        label[i][0] = 0;
        for (int k = 0; k < nkeys; k++)
            n += (size_t)snprintf(label[i] + n, sizeof label[i] - n, "%s%s=%s", k ? " " : "",
                                  keys[k]->key, runs[i].value[k]);
        labels[i] = label[i];
    }
    ev_pareto(tx, ya, (uint32_t)total, pa);
    ev_pareto(tx, yb, (uint32_t)total, pb);
    char rdir[1300];
    snprintf(rdir, sizeof rdir, "%s/report", out);
    res = tnd_mkdirs(rdir);
    const char *xlabel = P->timed ? "GPU ms per frame (medians, frames back to back)"
                                  : "GPU ms per frame (median after warm-up)";
    if (res == TND_OK) {
        snprintf(path, sizeof path, "%s/pareto_relmse.svg", rdir);
        res = ev_plot_pareto(path, "time vs relMSE (Pareto front in red)", xlabel, "relMSE", tx,
                             ya, labels, pa, (uint32_t)total, false, true);
    }
    if (res == TND_OK) {
        snprintf(path, sizeof path, "%s/pareto_flip.svg", rdir);
        res = ev_plot_pareto(path, "time vs FLIP (Pareto front in red)", xlabel, "FLIP", tx, yb,
                             labels, pb, (uint32_t)total, false, false);
    }
    /* JSON, CSV, the table */
    root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "scene", scene);
    cJSON_AddStringToObject(root, "reference", refdir);
    cJSON_AddNumberToObject(root, "width", size[0]);
    cJSON_AddNumberToObject(root, "height", size[1]);
    cJSON_AddNumberToObject(root, "frames", frames);
    cJSON_AddNumberToObject(root, "warmup", warmup);
    cJSON_AddNumberToObject(root, "timed_frames", P->timed);
    cJSON_AddNumberToObject(root, "cells", P->total);
    cJSON_AddItemToObject(root, "failed", failed);
    cJSON_AddItemToObject(root, "missing", missing);
    failed = missing = NULL; /* (root holds them) */
    cJSON *ka = cJSON_AddArrayToObject(root, "knobs");
    for (int k = 0; k < nkeys; k++)
        cJSON_AddItemToArray(ka, cJSON_CreateString(keys[k]->key));
    cJSON *ra = cJSON_AddArrayToObject(root, "runs");
    ev_text csv = {0};
    for (int k = 0; k < nkeys; k++)
        ev_text_add(&csv, "%s,", keys[k]->key);
    ev_text_add(&csv, "total_ms");
    for (int p = 0; p < n_passes; p++)
        ev_text_add(&csv, ",%s", passes[p]->key);
    for (uint32_t k = 0; k < ev_metric_count(); k++) /* the metrics of the table (eval/table.c) */
        if (ev_metric_at(k)->summarised)
            ev_text_add(&csv, ",%s", ev_metric_at(k)->name);
    ev_text_add(&csv, ",pareto_relmse,pareto_flip,"
                      "relmse_unbiased,flip_unbiased,estimator_bias_relmse,wall_ms\n");
    ev_text_add(&html, "<h2>Runs</h2>\n<p>%d combinations of %s at %ux%u, %u frames, medians after "
                       "%u warm-up frames. ", total, scene, size[0], size[1], frames, warmup);
    if (P->timed)
        ev_text_add(&html, "Times: medians of %u frames each cell ran back to back after its "
                           "frames (GPU timestamps per pass; wall: the clock per frame). ",
                    P->timed);
    ev_text_add(&html, "relMSE, FLIP, SSIM, PSNR and temporal: the "
                       "denoiser's error, against each cell's <b>matched reference</b> (the "
                       "converged expectation of its real-time estimator: its bounces and "
                       "resolution; %d of them); \"vs unbiased\": against <code>",
                nests);
    ev_text_escaped(&html, refdir);
    ev_text_add(&html, "</code>, the denoiser's error and the estimator's bias together; "
                       "\"bias\": the matched reference against the unbiased one. Bold: on a "
                       "Pareto front.</p>\n<img src=\"pareto_relmse.svg\" "
                       "width=\"680\" height=\"320\" alt=\"pareto relMSE\"> <img "
                       "src=\"pareto_flip.svg\" width=\"680\" height=\"320\" alt=\"pareto FLIP\">\n"
                       "<table><tr>");
    for (int k = 0; k < nkeys; k++)
        ev_text_add(&html, "<th>%s</th>", keys[k]->key);
    ev_text_add(&html, "<th>GPU ms</th><th>wall ms</th><th>front-end ms</th><th>denoise ms</th>"
                       "<th>post ms</th><th>relMSE</th><th>FLIP</th><th>SSIM</th><th>PSNR</th><th>temporal</th>"
                       "<th>relMSE vs unbiased</th><th>bias relMSE</th></tr>\n");
    for (int i = 0; i < total; i++) {
        sweep_run *r = &runs[i];
        r->pareto_relmse = pa[i];
        r->pareto_flip = pb[i];
        cJSON *o = cJSON_CreateObject();
        cJSON_AddItemToArray(ra, o);
        cJSON_AddNumberToObject(o, "cell", cell_of[i]);
        cJSON *kv = cJSON_AddObjectToObject(o, "knobs");
        for (int k = 0; k < nkeys; k++) {
            cJSON_AddStringToObject(kv, keys[k]->key, r->value[k]);
            ev_text_add(&csv, "%s,", r->value[k]);
        }
        cJSON_AddNumberToObject(o, "total_ms", r->total_ms);
        cJSON_AddNumberToObject(o, "wall_ms", r->wall_ms);
        ev_text_add(&csv, "%.6g", r->total_ms);
        cJSON *pm = cJSON_AddObjectToObject(o, "pass_ms");
        double fe = 0, dn = 0, post = 0;
        for (int p = 0; p < n_passes; p++) {
            cJSON_AddNumberToObject(pm, passes[p]->key, r->pass_ms[p]);
            ev_text_add(&csv, ",%.6g", r->pass_ms[p]);
            pl_pass_owner ow = pl_pass_owner_of(passes[p]);
            if (ow == PL_OWNER_FRONTEND)
                fe += r->pass_ms[p];
            else if (ow == PL_OWNER_DENOISER)
                dn += r->pass_ms[p];
            else
                post += r->pass_ms[p];
        }
        const ev_summary *m = &r->metrics;
        rn_metrics_json(o, m);
        cJSON_AddBoolToObject(o, "pareto_relmse", pa[i]);
        cJSON_AddBoolToObject(o, "pareto_flip", pb[i]);
        const sweep_estimator *es = &ests[r->estimator];
        cJSON_AddStringToObject(o, "matched_reference", es->dir);
        cJSON_AddNumberToObject(o, "relmse_unbiased", r->whole.relmse);
        cJSON_AddNumberToObject(o, "flip_unbiased", r->whole.flip);
        cJSON_AddNumberToObject(o, "estimator_bias_relmse", es->bias.relmse);
        cJSON_AddNumberToObject(o, "estimator_bias_flip", es->bias.flip);
        for (uint32_t k = 0; k < ev_metric_count(); k++)
            if (ev_metric_at(k)->summarised)
                ev_text_add(&csv, ",%.9g", ev_metric_summary(ev_metric_at(k), m));
        ev_text_add(&csv, ",%d,%d,%.9g,%.9g,%.9g,%.6g\n", pa[i], pb[i], r->whole.relmse,
                    r->whole.flip, es->bias.relmse, r->wall_ms);
        ev_text_add(&html, "<tr%s>", pa[i] || pb[i] ? " style=\"font-weight:bold\"" : "");
        for (int k = 0; k < nkeys; k++) {
            ev_text_add(&html, "<td>");
            ev_text_escaped(&html, r->value[k]);
            ev_text_add(&html, "</td>");
        }
        ev_text_add(&html, "<td>%.3f</td><td>%.3f</td><td>%.3f</td><td>%.3f</td><td>%.3f</td>"
                           "<td>%.5g</td><td>%.4f</td><td>%.4f</td><td>%.2f</td><td>%.4g</td>"
                           "<td>%.5g</td><td>%.5g</td></tr>\n",
                    r->total_ms, r->wall_ms, fe, dn, post, m->relmse, m->flip, m->ssim, m->psnr, m->temporal,
                    r->whole.relmse, es->bias.relmse);
    }
    ev_text_add(&html, "</table>\n");
    if (problems.s) { /* (a sweep gathered before every cell finished) */
        ev_text_add(&html, "<h2>Cells not in the table</h2>\n<pre>");
        ev_text_escaped(&html, problems.s);
        ev_text_add(&html, "</pre>\n");
    }
    free(tx), free(ya), free(yb), free(pa), free(pb), free(label), free(labels);
    char *json = cJSON_Print(root);
    ev_text jt = {0};
    if (json)
        ev_text_add(&jt, "%s\n", json);
    else
        jt.failed = true;
    char p2[1400];
    for (int w = 0; res == TND_OK && w < 2; w++) {
        const ev_text *t = w ? &csv : &jt;
        snprintf(p2, sizeof p2, "%s/sweep.%s", out, w ? "csv" : "json");
        res = t->failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory")
                        : tnd_file_write_atomic(p2, t->s, t->len);
    }
    if (res == TND_OK) {
        char title[1300];
        snprintf(title, sizeof title, "Tandem sweep: %s", scene);
        res = html.failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "bench: out of memory")
                          : ev_report_write(&(ev_report){.dir = rdir, .title = title,
                                                         .settings = json, .html = html.s});
    }
    free(json);
    ev_text_free(&jt);
    ev_text_free(&csv);
    if (res == TND_OK && problems.s) {
        res = tnd_fail(TND_ERR_IO, "%d of %d cells gathered into %s/sweep.json; the "
                       "others:\n%s", total, P->total, out, problems.s);
    } else if (res == TND_OK) {
        *complete = true;
        rn_say(h, "tandem: bench: %d runs -> %s/sweep.json, %s/sweep.csv, %s/index.html", total,
               out, out, rdir);
        ev_text_add(table, "sweep: %d runs of %s at %ux%u\n", total, scene, size[0], size[1]);
        for (int i = 0; i < total; i++) {
            ev_text_add(table, " ");
            for (int k = 0; k < nkeys; k++)
                ev_text_add(table, " %s=%s", keys[k]->key, runs[i].value[k]);
            ev_text_add(table, ": %.3f ms, relMSE %.4g, FLIP %.4f (vs unbiased %.4g, estimator "
                               "bias %.4g)%s\n",
                        runs[i].total_ms, runs[i].metrics.relmse, runs[i].metrics.flip,
                        runs[i].whole.relmse, ests[runs[i].estimator].bias.relmse,
                        runs[i].pareto_relmse || runs[i].pareto_flip ? "  (Pareto)" : "");
        }
    }
fail:
    cJSON_Delete(root);
    cJSON_Delete(failed);
    cJSON_Delete(missing);
    ev_text_free(&html);
    ev_text_free(&problems);
    free(runs);
    free(cell_of);
    free(P);
    return res;
}

