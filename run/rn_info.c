/* run/rn_info.c: what a scene holds and what the pipeline is, as JSON: `tandem info --scene
 * --json`'s object (and Python's Scene.info()), `tandem info --pipeline --json`'s (and
 * tandem.pipeline()). Entry points: rn_scene_count, rn_scene_info_json, rn_pipeline_json. */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>
#include <stdlib.h>
#include <string.h>

/* Materials used by at least one instance, by kind. */
static void material_kinds(const tnd_scene *s, uint32_t counts[TND_MAT_KIND_COUNT])
{
    memset(counts, 0, sizeof(uint32_t) * TND_MAT_KIND_COUNT);
    for (uint32_t m = 0; m < s->material_count; m++) {
        bool used = false;
        for (uint32_t i = 0; i < s->instance_count && !used; i++)
            used = s->meshes[s->instances[i].mesh].material == m;
        if (used)
            counts[s->materials[m].kind]++;
    }
}

rn_scene_counts rn_scene_count(const tnd_scene *s)
{
    rn_scene_counts c = {0};
    material_kinds(s, c.kinds);
    for (uint32_t l = 0; l < s->light_count; l++)
        c.lights[s->lights[l].type]++;
    c.lights[TND_LIGHT_AREA] = s->emitter_count;
    for (uint32_t m = 0; m < s->mesh_count; m++)
        c.unique += s->meshes[m].triangle_count;
    /* what the content takes on the host (and again on the GPU): the vertex arrays and indices,
     * the textures as decoded (8-bit RGBA) and their mip chains */
    c.geo_mb = ((double)s->vertex_count * (12 + 12 + 8 + 16 + (s->uvs1 ? 8 : 0)) +
                4.0 * s->index_count) / 1e6;
    for (uint32_t t = 0; t < s->texture_count; t++)
        for (uint32_t l = 0; l < s->textures[t].levels; l++)
            *(l ? &c.mip_mb : &c.tex_mb) +=
                4.0 * s->textures[t].level_w[l] * s->textures[t].level_h[l] / 1e6;
    return c;
}

char *rn_scene_info_json(const char *path, const tnd_scene *s)
{
    rn_scene_counts c = rn_scene_count(s);
    const uint32_t *kinds = c.kinds, *lights = c.lights;
    uint64_t unique = c.unique;
    double geo_mb = c.geo_mb, tex_mb = c.tex_mb, mip_mb = c.mip_mb;
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "scene", path);
    cJSON_AddNumberToObject(o, "triangles", (double)tnd_scene_triangles(s));
    cJSON_AddNumberToObject(o, "unique_triangles", (double)unique);
    cJSON_AddNumberToObject(o, "vertices", s->vertex_count);
    cJSON *mem = cJSON_AddObjectToObject(o, "memory_mb");
    cJSON_AddNumberToObject(mem, "geometry", geo_mb);
    cJSON_AddNumberToObject(mem, "textures", tex_mb);
    cJSON_AddNumberToObject(mem, "texture_mips", mip_mb);
    cJSON_AddNumberToObject(o, "meshes", s->mesh_count);
    cJSON_AddNumberToObject(o, "instances", s->instance_count);
    cJSON_AddNumberToObject(o, "nodes", s->node_count);
    cJSON_AddNumberToObject(o, "textures", s->texture_count);
    cJSON *mk = cJSON_AddObjectToObject(o, "materials");
    for (int k = 0; k < TND_MAT_KIND_COUNT; k++)
        cJSON_AddNumberToObject(mk, tnd_material_kind_name((tnd_material_kind)k), kinds[k]);
    cJSON *lk = cJSON_AddObjectToObject(o, "lights");
    for (int k = 0; k < TND_LIGHT_TYPE_COUNT; k++)
        cJSON_AddNumberToObject(lk, tnd_light_type_name((tnd_light_type)k), lights[k]);
    cJSON_AddStringToObject(o, "light_pick",
                            tnd_light_sampling_name(tnd_light_sampling_for(s, TND_LIGHTS_AUTO)));
    cJSON_AddNumberToObject(o, "cameras", s->camera_count);
    cJSON_AddNumberToObject(o, "animation_seconds", s->duration);
    cJSON *sky = cJSON_AddArrayToObject(o, "sky");
    for (int k = 0; k < 3; k++)
        cJSON_AddItemToArray(sky, cJSON_CreateNumber(s->sky[k]));
    if (s->env.width) {
        cJSON *e = cJSON_AddObjectToObject(o, "environment");
        cJSON_AddStringToObject(e, "path", s->env.path);
        cJSON_AddNumberToObject(e, "width", s->env.width);
        cJSON_AddNumberToObject(e, "height", s->env.height);
        cJSON_AddNumberToObject(e, "intensity", s->env.intensity);
        cJSON_AddNumberToObject(e, "rotation_degrees", s->env.rotation);
        cJSON_AddNumberToObject(e, "mean_luminance", s->env.mean_luminance);
        cJSON_AddNumberToObject(e, "bad_texels", s->env.bad_texels);
    }
    cJSON *def = cJSON_AddObjectToObject(o, "defaults");
    if (s->default_camera[0])
        cJSON_AddStringToObject(def, "camera", s->default_camera);
    if (s->default_light[0])
        cJSON_AddStringToObject(def, "light", s->default_light);
    if (s->camera_path[0])
        cJSON_AddStringToObject(o, "camera_path", s->camera_path);
    cJSON *miss = cJSON_AddArrayToObject(o, "missing_images");
    for (uint32_t i = 0; i < s->missing_image_count; i++) {
        const struct tnd_missing_image *mi = &s->missing_images[i];
        cJSON *e = cJSON_CreateObject();
        cJSON_AddItemToArray(miss, e);
        cJSON_AddStringToObject(e, "image", mi->name);
        cJSON_AddStringToObject(e, "material", mi->material);
        cJSON_AddStringToObject(e, "reason", mi->reason);
        cJSON_AddNumberToObject(e, "uses", mi->uses);
    }
    cJSON *f = cJSON_AddArrayToObject(o, "features");
    for (uint32_t b = 0; b < TND_FEATURE_COUNT; b++)
        if (s->features & (1u << b))
            cJSON_AddItemToArray(f, cJSON_CreateString(tnd_feature_name(b)));
    char *txt = cJSON_Print(o);
    cJSON_Delete(o);
    return txt;
}

/* the capability bits set, by name (names: the registry's) */
static cJSON *caps_json(uint32_t caps, const char *(*name)(uint32_t))
{
    cJSON *a = cJSON_CreateArray();
    for (uint32_t b = 0; name(b); b++)
        if (caps & (1u << b))
            cJSON_AddItemToArray(a, cJSON_CreateString(name(b)));
    return a;
}

char *rn_pipeline_json(void)
{
    cJSON *root = cJSON_CreateObject(), *fa = cJSON_AddArrayToObject(root, "frontends"),
          *da = cJSON_AddArrayToObject(root, "denoisers"),
          *ma = cJSON_AddArrayToObject(root, "metrics");
    for (uint32_t i = 0; pl_frontend_name_at(i); i++) {
        const char *n = pl_frontend_name_at(i);
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", n);
        cJSON_AddBoolToObject(o, "live", pl_frontend_live(n));
        cJSON_AddItemToObject(o, "capabilities",
                              caps_json(pl_frontend_caps_of(n), pl_frontend_cap_name));
        cJSON_AddItemToArray(fa, o);
    }
    for (uint32_t i = 0; i < pl_denoiser_count(); i++) {
        const pl_denoiser_info *d = pl_denoiser_at(i);
        cJSON *o = cJSON_CreateObject(), *pa, *sa;
        cJSON_AddStringToObject(o, "name", d->name);
        cJSON_AddStringToObject(o, "summary", d->summary);
        cJSON_AddItemToObject(o, "capabilities", caps_json(d->caps, pl_denoiser_cap_name));
        if (d->fallback)
            cJSON_AddStringToObject(o, "fallback", d->fallback);
        pa = cJSON_AddArrayToObject(o, "parameters");
        sa = cJSON_AddArrayToObject(o, "passes");
        for (uint32_t k = 0; k < d->nparams; k++) {
            const pl_param *p = d->params[k];
            cJSON *q = cJSON_CreateObject();
            cJSON_AddStringToObject(q, "name", p->name);
            cJSON_AddStringToObject(q, "kind", p->kind == PL_PARAM_UINT ? "count" : "number");
            cJSON_AddNumberToObject(q, "min", p->min);
            cJSON_AddNumberToObject(q, "max", p->max);
            cJSON_AddBoolToObject(q, "min_excluded", p->min_open);
            cJSON_AddStringToObject(q, "help", p->help);
            if (p->keys)
                cJSON_AddStringToObject(q, "view_keys", p->keys);
            cJSON_AddItemToArray(pa, q);
        }
        for (uint32_t k = 0; k < d->npasses; k++) {
            cJSON *q = cJSON_CreateObject();
            cJSON_AddStringToObject(q, "name", d->passes[k].name);
            cJSON_AddStringToObject(q, "key", d->passes[k].key);
            cJSON_AddStringToObject(q, "group", pl_pass_group_name(d->passes[k].group));
            cJSON_AddItemToArray(sa, q);
        }
        cJSON_AddItemToArray(da, o);
    }
    for (uint32_t k = 0; k < ev_metric_count(); k++) {
        const ev_metric *m = ev_metric_at(k);
        cJSON *o = cJSON_CreateObject();
        cJSON_AddStringToObject(o, "name", m->name);
        cJSON_AddStringToObject(o, "title", m->title);
        cJSON_AddItemToArray(ma, o);
    }
    char *t = cJSON_Print(root);
    cJSON_Delete(root);
    return t;
}
