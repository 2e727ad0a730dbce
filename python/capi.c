/* python/capi.c: the flat C API (include/tandem/tandem_api.h) over libtandem's modules and its
 * run layer (run/run.h: the frame session, sequence evaluation, datasets), for the Python
 * package. Options arrive as JSON objects keyed by the command line's option names; every
 * failure leaves its message in tnd_error_detail (tandem_error). The run layer's lines go to
 * stderr, its information lines only while not quiet (tandem_set_quiet).
 * Entry points: tandem_* (tandem_api.h). */
#include "run/run.h"
#include "include/tandem/tandem_api.h"
#include "include/tandem/tandem_plugin.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define API __attribute__((visibility("default")))

_Static_assert(sizeof(tandem_camera) == sizeof(tnd_camera_state) &&
                   offsetof(tandem_camera, jitter) == offsetof(tnd_camera_state, jitter) &&
                   offsetof(tandem_camera, frame_index) == offsetof(tnd_camera_state, frame_index),
               "tandem_camera is tnd_camera_state");

API const char *tandem_error(void)
{
    const char *d = tnd_error_detail();
    return d && *d ? d : "unknown error";
}

API void tandem_free(void *p)
{
    free(p);
}

/* ---- the run layer's host: lines on stderr ------------------------------------------------ */
static bool quiet_flag;
static tnd_log_level loud_level = TND_LOG_INFO; /* the core's log level before quiet */

static void on_line(void *user, const char *line)
{
    (void)user;
    fprintf(stderr, "%s\n", line);
}

static rn_host host(bool quiet)
{
    return (rn_host){.message = on_line, .warning = on_line, .quiet = quiet || quiet_flag};
}

/* Quiet (the core's log at WARN too) or not; the previous setting. */
static bool set_quiet(bool quiet)
{
    bool was = quiet_flag;
    if (quiet && !was)
        loud_level = tnd_log_get_level();
    quiet_flag = quiet;
    tnd_log_set_level(quiet ? TND_LOG_WARN : loud_level);
    return was;
}

API int tandem_set_quiet(int quiet)
{
    return set_quiet(quiet != 0);
}

/* A run layer's failure as `NAME: DETAIL` (the detail alone where it names NAME already). */
static void fail_as(const char *name, tnd_result r)
{
    char line[4200];
    rn_failure_line(name, r, line, sizeof line); /* ("tandem: NAME: DETAIL") */
    tnd_fail(r, "%s", line + strlen("tandem: "));
}

API const char *tandem_version(void)
{
    return TND_VERSION_STRING;
}

static char *oom(void)
{
    tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
    return NULL;
}

API char *tandem_pipeline_json(void)
{
    char *t = rn_pipeline_json();
    return t ? t : oom();
}

/* ---- the contract's table ---------------------------------------------------------------- */
API uint32_t tandem_entry_count(void)
{
    return TND_CT_COUNT;
}

API const char *tandem_entry_name(uint32_t e)
{
    return e < TND_CT_COUNT ? tnd_ct_get((tnd_ct)e)->name : NULL;
}

API uint32_t tandem_entry_components(uint32_t e)
{
    return e < TND_CT_COUNT ? tnd_ct_get((tnd_ct)e)->comps : 0;
}

API int tandem_entry_is_uint(uint32_t e)
{
    return e < TND_CT_COUNT && tnd_ct_get((tnd_ct)e)->kind == TND_CT_UINT;
}

API double tandem_entry_default(uint32_t e)
{
    return e < TND_CT_COUNT ? tnd_ct_get((tnd_ct)e)->default_value : 0.0;
}

/* ---- options as JSON ---------------------------------------------------------------------- */
typedef enum { K_STR, K_UINT, K_DOUBLE, K_BOOL, K_SIZE, K_BOUNCES } kind;
typedef struct key {
    const char *name;
    kind k;
    size_t offset;
} key;

#define O(field) offsetof(rn_render_opts, field)
#define E(field) (offsetof(rn_render_opts, env) + offsetof(rn_env, field))
static const key scene_keys[] = {
    {"env", K_STR, E(path)},
    {"env_intensity", K_DOUBLE, E(intensity)},
    {"env_rotation", K_DOUBLE, E(rotation)},
    {"up", K_STR, E(up)},
    {"no_default_light", K_BOOL, E(no_default_light)},
    {"camera_path", K_STR, E(camera_path)},
    {"path_duration", K_DOUBLE, E(path_duration)},
    {"path_radius", K_DOUBLE, E(path_radius)},
    {"path_height", K_DOUBLE, E(path_height)},
    {NULL, K_STR, 0},
};
static const key render_keys[] = {
    {"scene", K_STR, O(scene)},
    {"frontend", K_STR, O(frontend)},
    {"denoiser", K_STR, O(denoiser)},
    {"size", K_SIZE, O(size)},
    {"precision", K_STR, O(precision)},
    {"bounces", K_BOUNCES, O(bounces)}, /* a count or "half" */
    {"fps", K_DOUBLE, O(fps)},
    {"camera", K_UINT, O(camera)},
    {"threads", K_UINT, O(threads)},
    {"rt_api", K_STR, O(rt_api)},
    {"pipeline", K_STR, O(pipeline)},
    {"reflect_depth", K_UINT, O(reflect_depth)},
    {"lights", K_STR, O(lights)},
    {"render_scale", K_DOUBLE, O(render_scale)},
    {"upscaler", K_STR, O(upscaler)},
    {"taa", K_STR, O(taa)},
    {"tonemap", K_STR, O(tonemap)},
    {"exposure", K_STR, O(exposure)},
    {"exposure_bias", K_DOUBLE, O(exposure_bias)},
    {"bloom", K_DOUBLE, O(bloom)},
    {"spp", K_UINT, O(spp)},
    {"estimator", K_STR, O(estimator)},
    {"until_noise", K_DOUBLE, O(until_noise)},
    {"composite_on", K_STR, O(composite_on)},
    {NULL, K_STR, 0},
};
#undef O
#undef E

static const key *find_key(const key *t, const char *name)
{
    for (; t->name; t++)
        if (strcmp(t->name, name) == 0)
            return t;
    return NULL;
}

static tnd_result put(const key *k, const cJSON *v, void *base, const char *what)
{
    char *at = (char *)base + k->offset;
    switch (k->k) {
    case K_STR:
        if (!cJSON_IsString(v))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: %s: expected a string", what, k->name);
        *(const char **)at = v->valuestring;
        return TND_OK;
    case K_BOOL:
        if (!cJSON_IsBool(v))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: %s: expected true or false", what,
                            k->name);
        *(bool *)at = cJSON_IsTrue(v);
        return TND_OK;
    case K_DOUBLE:
        if (!cJSON_IsNumber(v))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: %s: expected a number", what, k->name);
        *(double *)at = v->valuedouble;
        return TND_OK;
    case K_BOUNCES: /* (render --bounces: a count, or "half") */
        if (cJSON_IsString(v) && strcmp(v->valuestring, "half") == 0) {
            *(unsigned *)at = RN_BOUNCES_HALF;
            return TND_OK;
        }
        if (cJSON_IsString(v))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: %s: expected a count or \"half\"",
                            what, k->name);
        /* fall through */
    case K_UINT:
        if (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble > 4294967295.0 ||
            v->valuedouble != floor(v->valuedouble))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: %s: expected a whole number >= 0", what,
                            k->name);
        *(unsigned *)at = (unsigned)v->valuedouble;
        return TND_OK;
    case K_SIZE: {
        const cJSON *w = cJSON_GetArrayItem(v, 0), *h = cJSON_GetArrayItem(v, 1);
        if (!cJSON_IsArray(v) || cJSON_GetArraySize(v) != 2 || !cJSON_IsNumber(w) ||
            !cJSON_IsNumber(h) || w->valuedouble < 1 || h->valuedouble < 1 ||
            w->valuedouble > 32768 || h->valuedouble > 32768)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                            "%s: %s: expected [width, height], each 1 to 32768", what, k->name);
        ((unsigned *)at)[0] = (unsigned)w->valuedouble;
        ((unsigned *)at)[1] = (unsigned)h->valuedouble;
        return TND_OK;
    }
    }
    return TND_OK;
}

/* reference's --bounces (a key of its own: a compound literal in the loop would not outlive
 * the statement that made it) */
static const key ref_bounces_key = {"bounces", K_BOUNCES, offsetof(rn_render_opts, ref_bounces)};

/* The options object onto render's options (the denoiser's parameters from "params"). */
static tnd_result parse_opts(const cJSON *root, bool render, bool reference, rn_render_opts *o,
                             const char *what)
{
    tnd_result res = TND_OK;
    if (root && !cJSON_IsObject(root))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: options: expected a JSON object", what);
    for (const cJSON *v = root ? root->child : NULL; v; v = v->next) {
        const key *k = find_key(scene_keys, v->string);
        if (!k && render)
            k = find_key(render_keys, v->string);
        if (k && reference && strcmp(k->name, "bounces") == 0) /* (reference's --bounces) */
            k = &ref_bounces_key;
        if (k) {
            TND_TRY(put(k, v, o, what));
            continue;
        }
        if (render && strcmp(v->string, "params") == 0 && cJSON_IsObject(v)) {
            for (const cJSON *p = v->child; p; p = p->next) {
                char name[64];
                snprintf(name, sizeof name, "%s", p->string);
                for (char *c = name; *c; c++)
                    *c = *c == '_' ? '-' : *c;
                if (!cJSON_IsNumber(p))
                    return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: params: %s: expected a number",
                                    what, p->string);
                if (!pl_param_find(name))
                    return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                                    "%s: params: no denoiser has a parameter '%s' (tandem info "
                                    "--pipeline lists them)",
                                    what, p->string);
                TND_TRY(pl_param_set_put(&o->params, name, p->valuedouble));
            }
            continue;
        }
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: unknown option '%s'", what, v->string);
    }
fail:
    return res;
}

static tnd_result parse_json(const char *text, cJSON **out, const char *what)
{
    *out = NULL;
    if (!text || !*text)
        return TND_OK;
    if (!(*out = cJSON_Parse(text)))
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "%s: options are not JSON (near '%.20s')", what,
                        cJSON_GetErrorPtr() ? cJSON_GetErrorPtr() : "");
    return TND_OK;
}

/* ---- scenes ------------------------------------------------------------------------------- */
struct tandem_scene {
    tnd_scene *s;
    char *path;
};

API tandem_scene *tandem_scene_load(const char *path, const char *options_json)
{
    cJSON *root = NULL;
    tandem_scene *ts = NULL;
    rn_render_opts o;
    rn_render_defaults(&o);
    if (!path) {
        tnd_fail(TND_ERR_INVALID_ARGUMENT, "scene: no path");
        return NULL;
    }
    if (parse_json(options_json, &root, "scene") != TND_OK ||
        parse_opts(root, false, false, &o, "scene") != TND_OK)
        goto fail;
    if (!(ts = calloc(1, sizeof *ts)) || !(ts->path = strdup(path))) {
        oom();
        goto fail;
    }
    if (rn_scene_load(path, &o.env, &ts->s) != TND_OK)
        goto fail;
    cJSON_Delete(root);
    return ts;
fail:
    cJSON_Delete(root);
    tandem_scene_free(ts);
    return NULL;
}

API char *tandem_scene_info(const tandem_scene *s)
{
    char *t = rn_scene_info_json(s->path, s->s);
    return t ? t : oom();
}

API void tandem_scene_free(tandem_scene *s)
{
    if (!s)
        return;
    tnd_scene_destroy(s->s);
    free(s->path);
    free(s);
}

/* ---- captures ----------------------------------------------------------------------------- */
struct tandem_capture {
    tnd_frame f;
};

API tandem_capture *tandem_capture_new(uint32_t width, uint32_t height)
{
    tandem_capture *c = calloc(1, sizeof *c);
    if (!c)
        return (void *)oom();
    if (tnd_frame_create(width, height, &c->f) != TND_OK) {
        free(c);
        return NULL;
    }
    return c;
}

API tandem_capture *tandem_capture_read(const char *path, const char *map_path,
                                        const tandem_capture *prev)
{
    tandem_capture *c = calloc(1, sizeof *c);
    tnd_capture_map *map = NULL;
    if (!c)
        return (void *)oom();
    tnd_result r = TND_OK;
    if (map_path && (r = tnd_capture_map_load(map_path, &map)) == TND_OK)
        r = tnd_capture_read_mapped(path, map, prev ? &prev->f.camera : NULL, &c->f);
    else if (!map_path)
        r = tnd_capture_read(path, &c->f);
    tnd_capture_map_destroy(map);
    if (r != TND_OK) {
        tnd_frame_destroy(&c->f);
        free(c);
        return NULL;
    }
    return c;
}

API int tandem_capture_write(const tandem_capture *c, const char *path)
{
    return tnd_capture_write(path, &c->f, TND_EXR_ZIP) != TND_OK;
}

API void tandem_capture_free(tandem_capture *c)
{
    if (!c)
        return;
    tnd_frame_destroy(&c->f);
    free(c);
}

API uint32_t tandem_capture_width(const tandem_capture *c)
{
    return c->f.width;
}

API uint32_t tandem_capture_height(const tandem_capture *c)
{
    return c->f.height;
}

API void *tandem_capture_plane(tandem_capture *c, uint32_t e)
{
    return e < TND_CT_COUNT ? c->f.data[e] : NULL;
}

API int tandem_capture_present(const tandem_capture *c, uint32_t e)
{
    return e < TND_CT_COUNT && c->f.present[e];
}

API void tandem_capture_set_present(tandem_capture *c, uint32_t e, int present)
{
    if (e < TND_CT_COUNT)
        c->f.present[e] = present != 0;
}

API int tandem_capture_fallback(const tandem_capture *c, uint32_t e)
{
    return e < TND_CT_COUNT && c->f.fallback[e];
}

API tandem_camera *tandem_capture_camera(tandem_capture *c)
{
    return (tandem_camera *)&c->f.camera;
}

API int tandem_capture_has_camera(const tandem_capture *c)
{
    return c->f.has_camera;
}

API void tandem_capture_set_has_camera(tandem_capture *c, int has)
{
    c->f.has_camera = has != 0;
}

API void tandem_capture_composite(const tandem_capture *c, float *rgb)
{
    tnd_frame_composite(&c->f, rgb);
    tnd_frame_interleave(&c->f, rgb);
}

API char *tandem_capture_list(const char *dir, const char *map_path)
{
    tnd_capture_map *map = NULL;
    char **names = NULL, d[2048];
    size_t count = 0;
    char *out = NULL;
    if (map_path && tnd_capture_map_load(map_path, &map) != TND_OK)
        return NULL;
    tnd_capture_dir(dir, d, sizeof d);
    if (tnd_capture_map_list(map, d, &names, &count) == TND_OK) {
        cJSON *a = cJSON_CreateArray();
        for (size_t i = 0; i < count; i++) {
            char full[4200];
            snprintf(full, sizeof full, "%s/%s", d, names[i]);
            cJSON_AddItemToArray(a, cJSON_CreateString(full));
        }
        out = cJSON_PrintUnformatted(a);
        cJSON_Delete(a);
        if (!out)
            oom();
    }
    tnd_capture_list_free(names, count);
    tnd_capture_map_destroy(map);
    return out;
}

/* ---- rendering ---------------------------------------------------------------------------- */
struct tandem_renderer {
    cJSON *options; /* (the strings the options point into) */
    rn_session *s;
};

API tandem_renderer *tandem_renderer_open(const char *options_json, int reference)
{
    return tandem_renderer_open_scene(NULL, options_json, reference);
}

API tandem_renderer *tandem_renderer_open_scene(const tandem_scene *scene,
                                                const char *options_json, int reference)
{
    const char *what = reference ? "reference" : "render";
    tandem_renderer *r = calloc(1, sizeof *r);
    if (!r)
        return (void *)oom();
    rn_render_opts o;
    rn_render_defaults(&o);
    o.quiet = true;
    if (parse_json(options_json, &r->options, what) != TND_OK ||
        parse_opts(r->options, true, reference != 0, &o, what) != TND_OK)
        goto fail;
    /* bounces "half": render's 1 at half resolution; a reference's as the command line's
     * (rn_reference_bounces, through rn_session_open) */
    if (!reference)
        o.bounces = rn_bounces_split(o.bounces, &o.half_indirect);
    bool was = set_quiet(true);
    if (scene) { /* (the scene's own path and options: run.json's record of them) */
        o.scene = scene->path;
        for (const cJSON *v = r->options ? r->options->child : NULL; v; v = v->next)
            if (find_key(scene_keys, v->string) || strcmp(v->string, "scene") == 0) {
                tnd_fail(TND_ERR_INVALID_ARGUMENT,
                         "%s: %s: the scene and its options come with the loaded scene "
                         "(tandem.Scene(...)), not with the renderer", what, v->string);
                goto fail;
            }
    }
    rn_host h = host(true);
    tnd_result res = rn_session_open(&o, reference != 0, scene ? scene->s : NULL, &h, &r->s);
    set_quiet(was);
    if (res != TND_OK)
        goto fail;
    return r;
fail:
    tandem_renderer_free(r);
    return NULL;
}

API void tandem_renderer_free(tandem_renderer *r)
{
    if (!r)
        return;
    rn_session_close(r->s);
    cJSON_Delete(r->options);
    free(r);
}

API void tandem_renderer_size(const tandem_renderer *r, uint32_t *width, uint32_t *height)
{
    const rn_render_opts *o = rn_session_opts(r->s);
    *width = o->size[0];
    *height = o->size[1];
}

API void tandem_renderer_render_size(const tandem_renderer *r, uint32_t *width, uint32_t *height)
{
    uint32_t rs[2];
    rn_render_size(rn_session_opts(r->s), rs);
    *width = rs[0];
    *height = rs[1];
}

API const char *tandem_renderer_denoiser(const tandem_renderer *r)
{
    const char *d = rn_session_denoiser(r->s);
    return d ? d : "";
}

API int tandem_renderer_frame(tandem_renderer *r, uint32_t f, float *rgb, uint8_t *display,
                              tandem_capture *contract)
{
    return rn_session_frame(r->s, f, rgb, display, contract ? &contract->f : NULL) != TND_OK;
}

API int tandem_renderer_reference(tandem_renderer *r, uint32_t f, float *rgb, float *variance,
                                  uint32_t *spp, double *rel_error)
{
    tnd_ref_stats rs = {0};
    if (rn_session_reference(r->s, f, rgb, variance, &rs) != TND_OK)
        return 1;
    if (spp)
        *spp = rs.spp;
    if (rel_error)
        *rel_error = rs.rel_error;
    return 0;
}

/* ---- metrics ------------------------------------------------------------------------------ */
API double tandem_auto_exposure(const float *rgb, uint32_t width, uint32_t height, uint32_t count)
{
    /* as eval: each reference's geometric-mean luminance, weighted by its pixels */
    double logsum = 0;
    size_t px = (size_t)width * height;
    for (uint32_t k = 0; k < count; k++) {
        ev_image img = {width, height, (float *)rgb + 3 * px * k, NULL};
        logsum += log(0.18 / ev_auto_exposure(&img, 1)) * (double)px;
    }
    return count ? 0.18 / exp(logsum / ((double)px * count)) : 1.0;
}

struct tandem_sequence {
    ev_sequence *seq;
    ev_image out, ref;
    uint64_t nonfinite;
};

API tandem_sequence *tandem_sequence_new(uint32_t width, uint32_t height, double exposure,
                                         double ppd)
{
    tandem_sequence *s = calloc(1, sizeof *s);
    if (!s)
        return (void *)oom();
    if (!(exposure > 0)) {
        tnd_fail(TND_ERR_INVALID_ARGUMENT, "metrics: exposure %g: expected a positive scale",
                 exposure);
        goto fail;
    }
    if (ev_sequence_create(width, height, exposure, ppd > 0 ? ppd : EV_FLIP_PPD, &s->seq) !=
            TND_OK ||
        ev_image_alloc(width, height, &s->out) != TND_OK ||
        ev_image_alloc(width, height, &s->ref) != TND_OK)
        goto fail;
    return s;
fail:
    tandem_sequence_free(s);
    return NULL;
}

API void tandem_sequence_free(tandem_sequence *s)
{
    if (!s)
        return;
    ev_sequence_destroy(s->seq);
    ev_image_free(&s->out);
    ev_image_free(&s->ref);
    free(s);
}

API int tandem_sequence_add(tandem_sequence *s, uint32_t frame, const float *out, const float *ref,
                            const float *variance, const float *motion, const float *depth,
                            int worth_flip, tandem_metrics *m, float *flip_map)
{
    size_t n = (size_t)s->out.width * s->out.height;
    /* (eval's images: copied, non-finite values to 0 and counted in the output) */
    memcpy(s->out.rgb, out, 3 * n * sizeof(float));
    memcpy(s->ref.rgb, ref, 3 * n * sizeof(float));
    uint64_t bad = ev_image_sanitize(&s->out);
    ev_image_sanitize(&s->ref);
    s->ref.var = (float *)variance;
    if (motion && depth)
        ev_sequence_motion(s->seq, motion, depth);
    ev_sequence_worth_flip(s->seq, worth_flip != 0);
    ev_frame_metrics fm = {0};
    tnd_result r = ev_sequence_add(s->seq, frame, &s->out, &s->ref, &fm, flip_map);
    s->ref.var = NULL;
    if (r != TND_OK)
        return 1;
    s->nonfinite += bad;
    *m = (tandem_metrics){fm.relmse,      fm.smape,        fm.rmse,       fm.psnr,
                          fm.ssim,        fm.flip,         fm.temporal,   fm.mc_temporal,
                          fm.disoccluded, fm.worth_relmse, fm.worth_flip, bad};
    return 0;
}

API void tandem_sequence_summary(const tandem_sequence *s, tandem_summary *out)
{
    ev_summary e = {0};
    ev_sequence_summary(s->seq, &e);
    *out = (tandem_summary){e.relmse,       e.smape,      e.rmse,        e.psnr,
                            e.ssim,         e.flip,       e.temporal,    e.lag,
                            e.mc_temporal,  e.flicker,    e.flicker_ref, e.disocclusion_lag,
                            e.worth_relmse, e.worth_flip, e.changes,     e.disocclusions,
                            s->nonfinite};
}

static char *read_text(const char *path)
{
    void *t = NULL;
    size_t n = 0;
    return tnd_file_read(path, &t, &n) == TND_OK ? t : NULL;
}

API char *tandem_eval(const char *options_json)
{
    static const char *const keys[] = {"out",      "reference", "matched_reference", "report",
                                       "exposure", "ppd",       "metrics_on"};
    cJSON *root = NULL;
    const char *str[7] = {0};
    char exposure[32];
    double ppd = 0;
    char *result = NULL;
    tnd_error_clear();
    if (parse_json(options_json, &root, "eval") != TND_OK)
        return NULL;
    for (const cJSON *v = root ? root->child : NULL; v; v = v->next) {
        size_t k = 0;
        while (k < 7 && strcmp(keys[k], v->string) != 0)
            k++;
        if (k == 7 || !(cJSON_IsString(v) || (cJSON_IsNumber(v) && k >= 4 && k <= 5))) {
            tnd_fail(TND_ERR_INVALID_ARGUMENT, "eval: option '%s': %s", v->string,
                     k == 7 ? "unknown" : "expected a string");
            goto done;
        }
        if (k == 4 && cJSON_IsNumber(v)) { /* (an EV100 as a number) */
            snprintf(exposure, sizeof exposure, "%.17g", v->valuedouble);
            str[k] = exposure;
        } else if (k == 5) {
            char *end = NULL;
            ppd = cJSON_IsNumber(v) ? v->valuedouble : strtod(v->valuestring, &end);
            if (!(ppd > 0) || (end && *end)) {
                tnd_fail(TND_ERR_INVALID_ARGUMENT, "eval: --ppd %s: expected a positive number "
                                                   "of pixels per degree",
                         cJSON_IsNumber(v) ? "(not positive)" : v->valuestring);
                goto done;
            }
        } else {
            str[k] = v->valuestring;
        }
    }
    rn_eval_opts o = {.out = str[0], .reference = str[1], .matched = str[2], .report = str[3],
                      .exposure = str[4], .ppd = ppd, .metrics_on = str[6]};
    rn_eval_result r;
    rn_host h = host(true);
    tnd_result res = rn_eval_sequence(&o, &h, &r);
    if (res != TND_OK) {
        fail_as("eval", res);
        goto done;
    }
    rn_eval_result_free(&r);
    char path[2100];
    snprintf(path, sizeof path, "%s/metrics.json", o.out);
    result = read_text(path);
done:
    cJSON_Delete(root);
    return result;
}

API char *tandem_dataset(const char *spec_path, const char *out, const char *shard)
{
    tnd_error_clear();
    rn_host h = host(true);
    tnd_result res = rn_dataset(spec_path, out, shard, &h);
    if (res != TND_OK) {
        fail_as("dataset", res);
        return NULL;
    }
    char path[2100];
    uint32_t i = 0, n = 0;
    if (shard && rn_shard_parse(shard, &i, &n) == TND_OK)
        snprintf(path, sizeof path, "%s/manifest-%u-of-%u.json", out, i, n);
    else
        snprintf(path, sizeof path, "%s/manifest.json", out);
    return read_text(path);
}

API char *tandem_rank(const char *suite, const char *denoisers, const char *out, const char *cache,
                      unsigned bootstrap, int report, int regions)
{
    tnd_error_clear();
    rn_rank_opts o = {.suite = suite, .denoisers = denoisers, .out = out, .cache = cache,
                      .bootstrap = bootstrap, .no_report = !report, .regions = regions != 0};
    rn_host h = host(true);
    rn_rank_result r;
    tnd_result res = rn_rank(&o, &h, &r);
    rn_rank_result_free(&r);
    if (res != TND_OK) {
        fail_as("rank", res);
        return NULL;
    }
    char path[2100];
    snprintf(path, sizeof path, "%s/rank.json", out);
    return read_text(path);
}

API void tandem_set_python_denoiser(const void *desc)
{
    pl_python_set(desc);
}
