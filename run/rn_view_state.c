/* run/rn_view_state.c: the viewer's repro state: the settings `tandem view` ran with and the camera
 * of every frame since its history last restarted (the flight), as a small JSON file that
 * `tandem render --view FILE` reproduces frame for frame. The camera of a frame is a position,
 * a yaw about +Y and a pitch (no roll), turned into the view matrix the same way by both.
 * Entry points: rn_view_state_read, rn_view_state_write, rn_view_state_free,
 * rn_view_state_push, rn_view_camera_apply, rn_view_camera_from_state, rn_view_state_options
 * (its settings as render's options), rn_view_render_size. */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void rn_view_state_free(rn_view_state *s)
{
    free(s->path);
    s->path = NULL;
    s->path_len = s->path_cap = s->path_frames = 0;
}

void rn_view_state_restart(rn_view_state *s)
{
    s->path_len = s->path_frames = 0;
}

static bool same_pose(const rn_view_cam *a, const rn_view_cam *b)
{
    return !memcmp(a->position, b->position, sizeof a->position) && a->yaw == b->yaw &&
           a->pitch == b->pitch;
}

/* An entry as it is (its frames included). */
static tnd_result append(rn_view_state *s, const rn_view_cam *c)
{
    if (s->path_len == s->path_cap) {
        uint32_t cap = s->path_cap ? 2 * s->path_cap : 64;
        rn_view_cam *p = realloc(s->path, cap * sizeof *p);
        if (!p)
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
        s->path = p;
        s->path_cap = cap;
    }
    s->path[s->path_len++] = *c;
    s->path_frames += c->frames;
    return TND_OK;
}

tnd_result rn_view_state_push(rn_view_state *s, const rn_view_cam *c)
{
    rn_view_cam *last = s->path_len ? &s->path[s->path_len - 1] : NULL;
    if (last && same_pose(last, c) && last->frames < UINT32_MAX / 2 &&
        c->frame == last->frame + last->frames) {
        last->frames++;
        s->path_frames++;
        return TND_OK;
    }
    rn_view_cam e = *c;
    e.frames = 1;
    return append(s, &e);
}

const rn_view_cam *rn_view_state_at(const rn_view_state *s, uint32_t i)
{
    uint32_t f = s->path[0].frame + i, lo = 0, hi = s->path_len - 1;
    while (lo < hi) { /* the last entry starting at or before f */
        uint32_t mid = lo + (hi - lo + 1) / 2;
        if (s->path[mid].frame <= f)
            lo = mid;
        else
            hi = mid - 1;
    }
    return &s->path[lo];
}

void rn_view_camera_apply(const rn_view_cam *c, tnd_scene_state *st)
{
    double cy = cos(c->yaw), sy = sin(c->yaw), cp = cos(c->pitch), sp = sin(c->pitch);
    double f[3] = {sy * cp, sp, -cy * cp}; /* forward */
    double r[3] = {cy, 0.0, sy};           /* right: forward x +Y, normalised */
    double u[3] = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
    const double *p = c->position;
    float *m = st->camera.view; /* column-major, rows right, up, -forward */
    for (int k = 0; k < 3; k++) {
        m[k * 4 + 0] = (float)r[k];
        m[k * 4 + 1] = (float)u[k];
        m[k * 4 + 2] = (float)-f[k];
        m[k * 4 + 3] = 0.0f;
    }
    m[12] = (float)-(r[0] * p[0] + r[1] * p[1] + r[2] * p[2]);
    m[13] = (float)-(u[0] * p[0] + u[1] * p[1] + u[2] * p[2]);
    m[14] = (float)(f[0] * p[0] + f[1] * p[1] + f[2] * p[2]);
    m[15] = 1.0f;
    for (int k = 0; k < 3; k++)
        st->camera_position[k] = (float)p[k];
}

void rn_view_camera_from_state(const tnd_scene_state *st, uint32_t frame, rn_view_cam *c)
{
    const float *m = st->camera.view;
    double f[3] = {-m[2], -m[6], -m[10]};
    double l = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    for (int k = 0; k < 3; k++)
        f[k] = l > 0 ? f[k] / l : (k == 2 ? -1.0 : 0.0);
    *c = (rn_view_cam){.frame = frame, .yaw = atan2(f[0], -f[2]),
                        .pitch = asin(fmax(-1.0, fmin(1.0, f[1])))};
    for (int k = 0; k < 3; k++)
        c->position[k] = st->camera_position[k];
}

static const struct {
    const char *key;
    size_t offset, cap; /* a string field */
} text_fields[] = {
#define F(k, field) {k, offsetof(rn_view_state, field), sizeof(((rn_view_state *)0)->field)}
    F("scene", scene),         F("frontend", frontend), F("denoiser", denoiser),
    F("precision", precision), F("taa", taa),           F("tonemap", tonemap),
    F("exposure", exposure),   F("env", env),           F("view", view),
    F("split", split_mode),    F("split_denoiser", split_denoiser),
    F("split_frontend", split_frontend), F("up", up),
#undef F
};
static const struct {
    const char *key;
    size_t offset;
} number_fields[] = {
#define F(k, field) {k, offsetof(rn_view_state, field)}
    F("bloom", bloom), F("fps", fps), F("env_intensity", env_intensity),
    F("env_rotation", env_rotation), F("exposure_bias", exposure_bias),
    F("render_scale", render_scale),
#undef F
};
static const struct {
    const char *key;
    size_t offset;
} uint_fields[] = {
#define F(k, field) {k, offsetof(rn_view_state, field)}
    F("bounces", bounces), F("camera", camera), F("no_default_light", no_default_light),
    F("half_indirect", half_indirect),
#undef F
};

void rn_view_state_options(const rn_view_state *v, rn_render_opts *o)
{
    o->scene = v->scene;
    o->frontend = v->frontend;
    o->denoiser = v->denoiser;
    o->precision = v->precision;
    o->taa = v->taa;
    o->tonemap = v->tonemap;
    o->exposure = v->exposure;
    o->env = (rn_env)RN_ENV_INIT;
    o->env.path = v->env[0] ? v->env : NULL;
    o->env.intensity = v->env_intensity;
    o->env.rotation = v->env_rotation;
    o->env.up = v->up[0] ? v->up : "y";
    o->env.no_default_light = v->no_default_light != 0;
    o->params = v->params;
    o->exposure_bias = v->exposure_bias;
    o->bloom = v->bloom;
    o->render_scale = v->render_scale > 0 ? v->render_scale : 1.0;
    o->fps = v->fps;
    o->bounces = v->bounces;
    o->half_indirect = v->half_indirect != 0 && v->bounces == 1;
    o->camera = v->camera;
    o->size[0] = v->size[0];
    o->size[1] = v->size[1];
}

tnd_result rn_view_state_write(const char *path, const rn_view_state *s)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "tandem_view_state", 1);
    for (size_t i = 0; i < sizeof text_fields / sizeof text_fields[0]; i++)
        cJSON_AddStringToObject(j, text_fields[i].key, (const char *)s + text_fields[i].offset);
    for (size_t i = 0; i < sizeof number_fields / sizeof number_fields[0]; i++)
        cJSON_AddNumberToObject(j, number_fields[i].key,
                                *(const double *)((const char *)s + number_fields[i].offset));
    for (size_t i = 0; i < sizeof uint_fields / sizeof uint_fields[0]; i++)
        cJSON_AddNumberToObject(j, uint_fields[i].key,
                                *(const uint32_t *)((const char *)s + uint_fields[i].offset));
    /* every denoiser parameter (pl_param; 0: the default) */
    for (uint32_t i = 0; i < pl_param_count(); i++) {
        char key[64];
        const pl_param *pp = pl_param_at(i);
        cJSON_AddNumberToObject(j, pl_param_key(pp, key, sizeof key),
                                pl_param_set_get(&s->params, pp->name));
    }
    cJSON *size = cJSON_AddArrayToObject(j, "size");
    cJSON_AddItemToArray(size, cJSON_CreateNumber(s->size[0]));
    cJSON_AddItemToArray(size, cJSON_CreateNumber(s->size[1]));
    cJSON *p = cJSON_AddArrayToObject(j, "path");
    for (uint32_t i = 0; i < s->path_len; i++) {
        const rn_view_cam *c = &s->path[i];
        cJSON *e = cJSON_CreateObject();
        cJSON_AddNumberToObject(e, "frame", c->frame);
        if (c->frames > 1)
            cJSON_AddNumberToObject(e, "frames", c->frames);
        cJSON *pos = cJSON_AddArrayToObject(e, "position");
        for (int k = 0; k < 3; k++)
            cJSON_AddItemToArray(pos, cJSON_CreateNumber(c->position[k]));
        cJSON_AddNumberToObject(e, "yaw", c->yaw);
        cJSON_AddNumberToObject(e, "pitch", c->pitch);
        cJSON_AddItemToArray(p, e);
    }
    tnd_result res = rn_json_write(path, j);
    cJSON_Delete(j);
    return res;
}

static tnd_result bad(const char *path, const char *what)
{
    return tnd_fail(TND_ERR_BAD_INPUT, "view state %s: %s", path, what);
}

tnd_result rn_view_state_read(const char *path, rn_view_state *s)
{
    tnd_result res = TND_OK;
    void *buf = NULL;
    size_t n = 0;
    TND_TRY_RETURN(tnd_file_read(path, &buf, &n));
    cJSON *j = cJSON_ParseWithLength(buf, n);
    free(buf);
    rn_view_state_free(s);
    if (!j)
        return bad(path, "not JSON");
    if (!cJSON_IsNumber(cJSON_GetObjectItem(j, "tandem_view_state"))) {
        res = bad(path, "no \"tandem_view_state\": not a view state");
        goto fail;
    }
    for (size_t i = 0; i < sizeof text_fields / sizeof text_fields[0]; i++) {
        const cJSON *v = cJSON_GetObjectItem(j, text_fields[i].key);
        if (!v)
            continue;
        if (!cJSON_IsString(v) || strlen(v->valuestring) >= text_fields[i].cap) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "view state %s: \"%s\": a string expected", path,
                           text_fields[i].key);
            goto fail;
        }
        strcpy((char *)s + text_fields[i].offset, v->valuestring);
    }
    for (size_t i = 0; i < sizeof number_fields / sizeof number_fields[0]; i++) {
        const cJSON *v = cJSON_GetObjectItem(j, number_fields[i].key);
        if (v && (!cJSON_IsNumber(v) || !isfinite(v->valuedouble))) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "view state %s: \"%s\": a number expected", path,
                           number_fields[i].key);
            goto fail;
        }
        if (v)
            *(double *)((char *)s + number_fields[i].offset) = v->valuedouble;
    }
    if (s->render_scale != 0 && !(s->render_scale >= 0.25 && s->render_scale <= 1)) {
        res = tnd_fail(TND_ERR_BAD_INPUT, "view state %s: \"render_scale\": %g: 0.25 to 1",
                       path, s->render_scale);
        goto fail;
    }
    for (size_t i = 0; i < sizeof uint_fields / sizeof uint_fields[0]; i++) {
        const cJSON *v = cJSON_GetObjectItem(j, uint_fields[i].key);
        if (v && (!cJSON_IsNumber(v) || v->valuedouble < 0 || v->valuedouble > 1e6)) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "view state %s: \"%s\": a count expected", path,
                           uint_fields[i].key);
            goto fail;
        }
        if (v)
            *(uint32_t *)((char *)s + uint_fields[i].offset) = (uint32_t)v->valuedouble;
    }
    for (uint32_t i = 0; i < pl_param_count(); i++) {
        char key[64];
        const pl_param *pp = pl_param_at(i);
        const cJSON *v = cJSON_GetObjectItem(j, pl_param_key(pp, key, sizeof key));
        if (v && !cJSON_IsNumber(v)) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "view state %s: \"%s\": a number expected", path,
                           key);
            goto fail;
        }
        if (v && pl_param_set_put(&s->params, pp->name, v->valuedouble) != TND_OK) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "view state %s: \"%s\": %s", path, key,
                           tnd_error_detail());
            goto fail;
        }
    }
    const cJSON *size = cJSON_GetObjectItem(j, "size");
    if (size) {
        const cJSON *w = cJSON_GetArrayItem(size, 0), *h = cJSON_GetArrayItem(size, 1);
        if (!cJSON_IsNumber(w) || !cJSON_IsNumber(h) || w->valuedouble < 1 ||
            h->valuedouble < 1 || w->valuedouble > 16384 || h->valuedouble > 16384) {
            res = bad(path, "\"size\": [width, height] expected");
            goto fail;
        }
        s->size[0] = (uint32_t)w->valuedouble;
        s->size[1] = (uint32_t)h->valuedouble;
    }
    const cJSON *p = cJSON_GetObjectItem(j, "path"), *e;
    if (p && !cJSON_IsArray(p)) {
        res = bad(path, "\"path\": an array expected");
        goto fail;
    }
    cJSON_ArrayForEach(e, p)
    {
        rn_view_cam c = {0};
        const cJSON *f = cJSON_GetObjectItem(e, "frame"), *pos = cJSON_GetObjectItem(e, "position");
        const cJSON *yaw = cJSON_GetObjectItem(e, "yaw"), *pitch = cJSON_GetObjectItem(e, "pitch");
        const cJSON *nf = cJSON_GetObjectItem(e, "frames"); /* (absent: 1) */
        bool ok = cJSON_IsNumber(f) && f->valuedouble >= 0 && f->valuedouble < 2147483648.0 &&
                  f->valuedouble == floor(f->valuedouble) && cJSON_IsNumber(yaw) &&
                  cJSON_IsNumber(pitch) && cJSON_GetArraySize(pos) == 3 &&
                  (!nf || (cJSON_IsNumber(nf) && nf->valuedouble >= 1 &&
                           nf->valuedouble < 2147483648.0 &&
                           nf->valuedouble == floor(nf->valuedouble)));
        for (int k = 0; ok && k < 3; k++) {
            const cJSON *v = cJSON_GetArrayItem(pos, k);
            ok = cJSON_IsNumber(v) && isfinite(v->valuedouble);
            if (ok)
                c.position[k] = v->valuedouble;
        }
        if (!ok || !isfinite(yaw->valuedouble) || !isfinite(pitch->valuedouble)) {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "view state %s: path entry %u: frame, position [x, y, z], yaw and "
                           "pitch expected (and frames, a whole number from 1)", path,
                           s->path_len);
            goto fail;
        }
        c.frame = (uint32_t)f->valuedouble;
        c.frames = nf ? (uint32_t)nf->valuedouble : 1;
        c.yaw = yaw->valuedouble;
        c.pitch = pitch->valuedouble;
        const rn_view_cam *last = s->path_len ? &s->path[s->path_len - 1] : NULL;
        if (last && (uint64_t)c.frame != (uint64_t)last->frame + last->frames) {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "view state %s: path entry %u: frame %u after %u frame%s from %u "
                           "(frames follow each other)", path, s->path_len, c.frame,
                           last->frames, last->frames == 1 ? "" : "s", last->frame);
            goto fail;
        }
        if ((uint64_t)s->path_frames + c.frames > 2147483647u) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "view state %s: over 2^31 frames", path);
            goto fail;
        }
        TND_TRY(append(s, &c));
    }
fail:
    cJSON_Delete(j);
    if (res != TND_OK)
        rn_view_state_free(s);
    return res;
}

void rn_view_render_size(const rn_view_state *s, uint32_t out[2])
{
    rn_render_opts o;
    rn_render_defaults(&o);
    rn_view_state_options(s, &o);
    rn_render_size(&o, out);
}
