/* core/camera_path.c: camera paths for any scene (docs/scenes.md "Camera paths"): an orbit, a
 * dolly or a flythrough made from the scene's bounds, or keyframes from a JSON file. A path
 * becomes the scene's first camera, on a node animated by glTF CUBICSPLINE channels (Catmull-Rom
 * tangents; the field of view linear), so that motion vectors and references follow it exactly as they follow a camera
 * animated in the file. Entry points: scene_camera_path (scene_finish), tnd_camera_path_write. */
#include "core/core.h"
#include "core/scene_internal.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define PATH_KEYS 96 /* keys of a generated path: a Catmull-Rom circle of 96 keys is within
                        2e-6 of its radius */
#define PATH_DEFAULT_DURATION 10.0

/* Keys: time, position, rotation, yfov. */
typedef struct path_keys {
    uint32_t n;
    double *time;
    float *pos, *rot, *fov; /* 3, 4, 1 per key */
} path_keys;

static void keys_free(path_keys *k)
{
    free(k->time);
    free(k->pos);
    free(k->rot);
    free(k->fov);
    memset(k, 0, sizeof *k);
}

static tnd_result keys_alloc(path_keys *k, uint32_t n)
{
    k->n = n;
    k->time = calloc(n, sizeof *k->time);
    k->pos = calloc(3 * (size_t)n, sizeof *k->pos);
    k->rot = calloc(4 * (size_t)n, sizeof *k->rot);
    k->fov = calloc(n, sizeof *k->fov);
    if (!k->time || !k->pos || !k->rot || !k->fov) {
        keys_free(k);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    }
    return TND_OK;
}

/* The keys' times as the channels store them (float seconds); NULL when out of memory. */
static float *key_times(const path_keys *k)
{
    float *t = malloc(k->n * sizeof *t);
    for (uint32_t i = 0; t && i < k->n; i++)
        t[i] = (float)k->time[i];
    return t;
}

/* One channel of dim values per key as a CUBICSPLINE channel with Catmull-Rom tangents (one-sided
 * at the ends, or across the seam of a closed loop whose last key repeats its first). */
static tnd_result add_cubic(tnd_scene *s, uint32_t node, tnd_anim_path path, const path_keys *k,
                            const float *v, uint32_t dim, bool closed)
{
    uint32_t n = k->n;
    float *times = key_times(k), *vals = malloc(3 * (size_t)dim * n * sizeof *vals);
    if (!times || !vals) {
        free(times);
        free(vals);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    }
    /* a closed loop's last key is its first again, up to the sign of a quaternion (a turn of
     * 2 pi is -1): the neighbours across the seam are taken with that sign */
    double seam = 0;
    for (uint32_t d = 0; d < dim; d++)
        seam += (double)v[d] * v[dim * (n - 1) + d];
    double sgn = dim == 4 && seam < 0 ? -1.0 : 1.0;
    for (uint32_t i = 0; i < n; i++) {
        /* neighbours: across the seam of a closed loop (n - 1 is the key 0 again) */
        bool wa = i == 0 && closed && n > 2, wb = i == n - 1 && closed && n > 2;
        uint32_t a = i > 0 ? i - 1 : (wa ? n - 2 : 0);
        uint32_t b = i + 1 < n ? i + 1 : (wb ? 1 : n - 1);
        double ta = k->time[a] - (wa ? k->time[n - 1] - k->time[0] : 0);
        double tb = k->time[b] + (wb ? k->time[n - 1] - k->time[0] : 0);
        for (uint32_t d = 0; d < dim; d++) {
            double dt = tb - ta, va = v[dim * a + d] * (wa ? sgn : 1.0);
            double vb = v[dim * b + d] * (wb ? sgn : 1.0);
            float tan = dt > 0 ? (float)((vb - va) / dt) : 0.0f;
            vals[3 * dim * i + d] = tan;
            vals[3 * dim * i + dim + d] = v[dim * i + d];
            vals[3 * dim * i + 2 * dim + d] = tan;
        }
    }
    tnd_result r = tnd_scene_add_channel(s, node, path, n, times, vals, false, true);
    free(times);
    free(vals);
    return r;
}

static double length3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

/* Keys of a generated path over the bounds lo..hi. */
static tnd_result generate(const char *kind, const tnd_scene_options *o, const double lo[3],
                           const double hi[3], path_keys *k, bool *closed, char *note, size_t cap)
{
    double c[3], rad, dist;
    scene_default_view(lo, hi, c, &rad, &dist);
    double yfov = TND_DEFAULT_CAMERA_YFOV_DEG * TND_PI / 180;
    double el = TND_DEFAULT_CAMERA_ELEVATION_DEG * TND_PI / 180;
    double az0 = TND_DEFAULT_CAMERA_AZIMUTH_DEG * TND_PI / 180;
    double dur = o->path_duration > 0 ? o->path_duration : PATH_DEFAULT_DURATION;
    bool orbit = strcasecmp(kind, "orbit") == 0, dolly = strcasecmp(kind, "dolly") == 0;
    bool fly = strcasecmp(kind, "flythrough") == 0;
    if (!orbit && !dolly && !fly)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "camera path '%s': expected orbit, dolly, flythrough or a keyframe file "
                        "(.json)",
                        kind);
    /* the default camera's place (docs/scenes.md) is where an orbit and a dolly start */
    double ring = o->path_radius > 0 && orbit ? o->path_radius : dist * cos(el);
    double height = o->path_height_given ? o->path_height
                    : fly               ? -0.25 * (hi[1] - lo[1])
                                        : dist * sin(el);
    double travel = o->path_radius > 0 && dolly ? o->path_radius : 0.5 * hypot(ring, height);
    double ax = fly ? (o->path_radius > 0 ? o->path_radius : 0.3 * (hi[0] - lo[0])) : 0;
    double az = fly ? (o->path_radius > 0 ? o->path_radius : 0.3 * (hi[2] - lo[2])) : 0;
    *closed = orbit || fly;
    TND_TRY_RETURN(keys_alloc(k, PATH_KEYS + 1));
    for (uint32_t i = 0; i <= PATH_KEYS; i++) {
        double u = (double)i / PATH_KEYS, eye[3], at[3];
        k->time[i] = u * dur;
        k->fov[i] = (float)yfov;
        if (orbit) {
            double a = az0 + 2 * TND_PI * u;
            eye[0] = c[0] + ring * sin(a), eye[1] = c[1] + height, eye[2] = c[2] + ring * cos(a);
            memcpy(at, c, sizeof at);
        } else if (dolly) {
            double e0[3] = {c[0] + ring * sin(az0), c[1] + height, c[2] + ring * cos(az0)};
            double d[3] = {c[0] - e0[0], c[1] - e0[1], c[2] - e0[2]}, l = length3(d);
            for (int j = 0; j < 3; j++)
                eye[j] = e0[j] + (l > 0 ? d[j] / l : 0) * travel * u;
            memcpy(at, c, sizeof at);
        } else { /* an ellipse through the bounds, looking a sixteenth of the loop ahead */
            double a = 2 * TND_PI * u, b = a + 2 * TND_PI / 16;
            eye[0] = c[0] + ax * sin(a), eye[1] = c[1] + height, eye[2] = c[2] + az * cos(a);
            at[0] = c[0] + ax * sin(b), at[1] = eye[1], at[2] = c[2] + az * cos(b);
        }
        for (int j = 0; j < 3; j++)
            k->pos[3 * i + j] = (float)eye[j];
        if (!tnd_quat_look_at(eye, at, k->rot + 4 * i)) {
            keys_free(k);
            return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                            "camera path '%s': the camera would look straight up or down (a "
                            "radius or distance of 0?)",
                            kind);
        }
    }
    if (orbit)
        snprintf(note, cap,
                 "camera path: orbit of radius %.4g at %.4g above the centre (%.4g %.4g %.4g) "
                 "of the bounds, once round in %g s",
                 ring, height, c[0], c[1], c[2], dur);
    else if (dolly)
        snprintf(note, cap,
                 "camera path: dolly of %.4g towards the centre (%.4g %.4g %.4g) of the bounds in "
                 "%g s",
                 travel, c[0], c[1], c[2], dur);
    else
        snprintf(note, cap,
                 "camera path: flythrough on an ellipse of radii %.4g x %.4g at %.4g above the "
                 "centre of the bounds, once round in %g s",
                 ax, az, height, dur);
    return TND_OK;
}

static bool vec_of(const cJSON *a, int n, double *out)
{
    if (!cJSON_IsArray(a) || cJSON_GetArraySize(a) != n)
        return false;
    for (int i = 0; i < n; i++) {
        const cJSON *e = cJSON_GetArrayItem(a, i);
        if (!cJSON_IsNumber(e) || !isfinite(e->valuedouble))
            return false;
        out[i] = e->valuedouble;
    }
    return true;
}

/* Keys from a keyframe file: {"keyframes": [{"time": s, "position": [x, y, z], "target":
 * [x, y, z] or "rotation": [x, y, z, w], "yfov": degrees}, ...]} (docs/scenes.md). */
static tnd_result read_file(const char *path, path_keys *k, char *note, size_t cap)
{
    void *bytes = NULL;
    size_t size = 0;
    TND_TRY_RETURN(tnd_file_read(path, &bytes, &size));
    cJSON *j = cJSON_ParseWithLength(bytes, size);
    free(bytes);
    tnd_result res = TND_OK;
    const cJSON *kf = cJSON_GetObjectItemCaseSensitive(j, "keyframes"), *e;
    int n = cJSON_GetArraySize(kf);
    if (!j || !cJSON_IsArray(kf) || n < 1) {
        res = tnd_fail(TND_ERR_BAD_INPUT,
                       "camera path %s: %s", path,
                       !j ? "not JSON" : "expected {\"keyframes\": [{\"time\", \"position\", "
                                         "\"target\" or \"rotation\", \"yfov\"}, ...]}");
        goto done;
    }
    TND_TRY(keys_alloc(k, (uint32_t)n));
    int i = 0;
    cJSON_ArrayForEach(e, kf)
    {
        double t, p[3], at[3], q[4], fov = TND_DEFAULT_CAMERA_YFOV_DEG;
        const cJSON *jt = cJSON_GetObjectItemCaseSensitive(e, "time");
        const cJSON *jf = cJSON_GetObjectItemCaseSensitive(e, "yfov");
        const cJSON *jat = cJSON_GetObjectItemCaseSensitive(e, "target");
        const cJSON *jq = cJSON_GetObjectItemCaseSensitive(e, "rotation");
        const char *why = NULL;
        if (!cJSON_IsNumber(jt) || !isfinite(t = jt->valuedouble) || t < 0)
            why = "\"time\" must be a number of seconds >= 0";
        else if (i > 0 && !(t > k->time[i - 1]))
            why = "times must increase";
        else if (!vec_of(cJSON_GetObjectItemCaseSensitive(e, "position"), 3, p))
            why = "\"position\" must be [x, y, z]";
        else if (!jat == !jq)
            why = "give one of \"target\" [x, y, z] and \"rotation\" [x, y, z, w]";
        else if (jat && !vec_of(jat, 3, at))
            why = "\"target\" must be [x, y, z]";
        else if (jq && (!vec_of(jq, 4, q) || !(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] +
                                                   q[3] * q[3] > 1e-12)))
            why = "\"rotation\" must be a quaternion [x, y, z, w]";
        else if (jf && (!cJSON_IsNumber(jf) || !(jf->valuedouble > 0 && jf->valuedouble < 180)))
            why = "\"yfov\" must be in (0, 180) degrees";
        if (!why && jat && !tnd_quat_look_at(p, at, k->rot + 4 * i))
            why = "its target coincides with its position or lies straight above or below it";
        if (why) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "camera path %s: keyframe %d: %s", path, i, why);
            goto done;
        }
        if (jf)
            fov = jf->valuedouble;
        k->time[i] = t;
        for (int d = 0; d < 3; d++)
            k->pos[3 * i + d] = (float)p[d];
        if (jq) {
            double l = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
            for (int d = 0; d < 4; d++)
                k->rot[4 * i + d] = (float)(q[d] / l);
        }
        k->fov[i] = (float)(fov * TND_PI / 180);
        i++;
    }
    snprintf(note, cap, "camera path: %d keyframes from %s over %g s", n, path, k->time[n - 1]);
done:
fail:
    cJSON_Delete(j);
    if (res != TND_OK)
        keys_free(k);
    return res;
}

tnd_result scene_camera_path(tnd_scene *s, const tnd_scene_options *o, const double lo[3],
                             const double hi[3])
{
    path_keys k = {0};
    bool closed = false;
    const char *dot = strrchr(o->camera_path, '.');
    tnd_result res = dot && strcasecmp(dot, ".json") == 0
                         ? read_file(o->camera_path, &k, s->camera_path, sizeof s->camera_path)
                         : generate(o->camera_path, o, lo, hi, &k, &closed, s->camera_path,
                                    sizeof s->camera_path);
    if (res != TND_OK)
        return res;
    /* a continuous rotation: each quaternion on the side of its predecessor */
    for (uint32_t i = 1; i < k.n; i++) {
        float *q = k.rot + 4 * i, *p = q - 4;
        if (q[0] * p[0] + q[1] * p[1] + q[2] * p[2] + q[3] * p[3] < 0)
            for (int d = 0; d < 4; d++)
                q[d] = -q[d];
    }
    bool fov_moves = false;
    for (uint32_t i = 1; i < k.n; i++)
        fov_moves |= k.fov[i] != k.fov[0];
    int32_t node = tnd_scene_add_node(s, "tandem_camera_path", -1, k.pos, k.rot, NULL);
    if (node < 0 || tnd_scene_add_camera(s, (uint32_t)node, k.fov[0]) < 0)
        TND_TRY(tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory"));
    if (k.n > 1) {
        TND_TRY(add_cubic(s, (uint32_t)node, TND_ANIM_T, &k, k.pos, 3, closed));
        TND_TRY(add_cubic(s, (uint32_t)node, TND_ANIM_R, &k, k.rot, 4, closed));
        if (fov_moves) { /* linear: a zoom holds between equal keys, no overshoot */
            float *times = key_times(&k);
            if (!times)
                TND_TRY(tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory"));
            res = tnd_scene_add_channel(s, (uint32_t)node, TND_ANIM_YFOV, k.n, times, k.fov,
                                        false, false);
            free(times);
            if (res != TND_OK)
                goto fail;
        }
    }
    /* the path's camera comes first: what every command uses unless --camera says otherwise */
    tnd_camera_def cam = s->cameras[s->camera_count - 1];
    snprintf(cam.name, sizeof cam.name, "camera path");
    double ext = 0;
    for (int d = 0; d < 3; d++)
        ext = fmax(ext, hi[d] - lo[d]);
    cam.znear = (float)fmax(1e-4, 1e-4 * ext);
    memmove(s->cameras + 1, s->cameras, (s->camera_count - 1) * sizeof *s->cameras);
    s->cameras[0] = cam;
    tnd_info("scene", "%s: %s", s->path, s->camera_path);
fail:
    keys_free(&k);
    return res;
}

tnd_result tnd_camera_path_write(const char *path, const tnd_camera_key *keys, uint32_t n)
{
    cJSON *j = cJSON_CreateObject(), *arr = cJSON_AddArrayToObject(j, "keyframes");
    for (uint32_t i = 0; arr && i < n; i++) {
        cJSON *e = cJSON_CreateObject();
        cJSON_AddItemToArray(arr, e);
        cJSON_AddNumberToObject(e, "time", keys[i].time);
        double p[3] = {keys[i].position[0], keys[i].position[1], keys[i].position[2]};
        double q[4] = {keys[i].rotation[0], keys[i].rotation[1], keys[i].rotation[2],
                       keys[i].rotation[3]};
        cJSON_AddItemToObject(e, "position", cJSON_CreateDoubleArray(p, 3));
        cJSON_AddItemToObject(e, "rotation", cJSON_CreateDoubleArray(q, 4));
        cJSON_AddNumberToObject(e, "yfov", keys[i].yfov * 180.0 / TND_PI);
    }
    char *text = cJSON_Print(j);
    cJSON_Delete(j);
    if (!text)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "camera path %s: out of memory", path);
    tnd_result r = tnd_file_write_atomic(path, text, strlen(text));
    free(text);
    return r;
}
