/* run/rn_spec.c: what the JSON files that list sequences share (the dataset's spec, the rank's
 * suite): a member read as a whole number in a range, a string or a number, absent members left
 * as they were; and a sequence's scene options. */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>

bool rn_json_uint(const cJSON *o, const char *k, unsigned *v, unsigned lo, unsigned hi)
{
    const cJSON *x = cJSON_GetObjectItemCaseSensitive(o, k);
    if (!x)
        return true;
    if (!cJSON_IsNumber(x) || x->valuedouble < lo || x->valuedouble > hi ||
        x->valuedouble != (double)(unsigned)x->valuedouble)
        return false;
    *v = (unsigned)x->valuedouble;
    return true;
}

bool rn_json_str(const cJSON *o, const char *k, const char **v)
{
    const cJSON *x = cJSON_GetObjectItemCaseSensitive(o, k);
    if (!x)
        return true;
    if (!cJSON_IsString(x))
        return false;
    *v = x->valuestring;
    return true;
}

bool rn_json_num(const cJSON *o, const char *k, double *v)
{
    const cJSON *x = cJSON_GetObjectItemCaseSensitive(o, k);
    if (!x)
        return true;
    if (!cJSON_IsNumber(x))
        return false;
    *v = x->valuedouble;
    return true;
}

bool rn_spec_scene_options(const cJSON *q, rn_render_opts *o)
{
    const cJSON *ndl = cJSON_GetObjectItemCaseSensitive(q, "no_default_light");
    bool ok = rn_json_str(q, "scene", &o->scene) &&
              rn_json_str(q, "camera_path", &o->env.camera_path) &&
              rn_json_num(q, "path_duration", &o->env.path_duration) &&
              rn_json_num(q, "path_radius", &o->env.path_radius) &&
              rn_json_num(q, "path_height", &o->env.path_height) &&
              rn_json_str(q, "env", &o->env.path) &&
              rn_json_num(q, "env_intensity", &o->env.intensity) &&
              rn_json_num(q, "env_rotation", &o->env.rotation) &&
              rn_json_str(q, "up", &o->env.up) &&
              rn_json_uint(q, "camera", &o->camera, 0, 1u << 20) && (!ndl || cJSON_IsBool(ndl));
    if (ok && ndl)
        o->env.no_default_light = cJSON_IsTrue(ndl);
    return ok;
}
