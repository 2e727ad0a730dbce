/* core/scene_build.c: building a tnd_scene in code (tests and generators). Arrays grow by
 * realloc; tnd_scene_commit runs the same validation as a glTF load.
 * Entry points: tnd_scene_new, tnd_scene_add_*, tnd_scene_commit, tnd_material_default. */
#include "core/core.h"
#include "core/scene_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static bool grow(void **p, uint32_t count, size_t elem)
{
    void *n = realloc(*p, (size_t)(count + 1) * elem);
    if (!n) {
        tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        return false;
    }
    *p = n;
    return true;
}

tnd_result tnd_scene_new(const char *name, tnd_scene **out)
{
    *out = calloc(1, sizeof **out);
    if (!*out)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    snprintf((*out)->path, sizeof (*out)->path, "%s", name);
    return TND_OK;
}

tnd_material tnd_material_default(const char *name)
{
    tnd_material m = {.base_color = {1, 1, 1, 1},
                      .metallic = 1,
                      .roughness = 1,
                      .ior = 1.5f,
                      .specular = 1,
                      .normal_scale = 1,
                      .attenuation_color = {1, 1, 1},
                      .tex_base_color = -1,
                      .tex_metal_rough = -1,
                      .tex_normal = -1,
                      .tex_emission = -1,
                      .uvx = {TND_UV_IDENTITY, TND_UV_IDENTITY, TND_UV_IDENTITY, TND_UV_IDENTITY}};
    snprintf(m.name, sizeof m.name, "%s", name);
    return m;
}

int32_t tnd_scene_add_material(tnd_scene *s, const tnd_material *m)
{
    if (!grow((void **)&s->materials, s->material_count, sizeof *m))
        return -1;
    s->materials[s->material_count] = *m;
    s->materials[s->material_count].kind = scene_classify(m);
    return (int32_t)s->material_count++;
}

int32_t tnd_scene_add_mesh(tnd_scene *s, const char *name, const float *pos, const float *nrm,
                           const float *uv, uint32_t nv, const uint32_t *idx, uint32_t ntri,
                           uint32_t material)
{
    uint32_t v0 = s->vertex_count;
    float *p = realloc(s->positions, (size_t)(v0 + nv) * 3 * sizeof(float));
    if (p)
        s->positions = p;
    float *n = realloc(s->normals, (size_t)(v0 + nv) * 3 * sizeof(float));
    if (n)
        s->normals = n;
    float *u = realloc(s->uvs, (size_t)(v0 + nv) * 2 * sizeof(float));
    if (u)
        s->uvs = u;
    float *t = realloc(s->tangents, (size_t)(v0 + nv) * 4 * sizeof(float));
    if (t)
        s->tangents = t;
    uint32_t *ix = realloc(s->indices, (size_t)(s->index_count + 3 * ntri) * sizeof(uint32_t));
    if (ix)
        s->indices = ix;
    if (!p || !n || !u || !t || !ix || !grow((void **)&s->meshes, s->mesh_count, sizeof(tnd_mesh))) {
        tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        return -1;
    }
    memcpy(s->positions + 3 * (size_t)v0, pos, (size_t)nv * 3 * sizeof(float));
    memcpy(s->normals + 3 * (size_t)v0, nrm, (size_t)nv * 3 * sizeof(float));
    for (uint32_t k = 0; k < nv; k++) {
        s->uvs[2 * (size_t)(v0 + k)] = uv ? uv[2 * k] : 0.0f;
        s->uvs[2 * (size_t)(v0 + k) + 1] = uv ? uv[2 * k + 1] : 0.0f;
        float *tg = s->tangents + 4 * (size_t)(v0 + k);
        tg[0] = 1, tg[1] = 0, tg[2] = 0, tg[3] = 1;
    }
    memcpy(s->indices + s->index_count, idx, (size_t)ntri * 3 * sizeof(uint32_t));
    tnd_mesh *m = &s->meshes[s->mesh_count];
    memset(m, 0, sizeof *m);
    snprintf(m->name, sizeof m->name, "%s", name);
    m->first_vertex = v0;
    m->vertex_count = nv;
    m->first_index = s->index_count;
    m->triangle_count = ntri;
    m->material = material;
    s->vertex_count += nv;
    s->index_count += 3 * ntri;
    return (int32_t)s->mesh_count++;
}

int32_t tnd_scene_add_node(tnd_scene *s, const char *name, int32_t parent, const float t[3],
                           const float r[4], const float sc[3])
{
    if (!grow((void **)&s->nodes, s->node_count, sizeof(tnd_node)))
        return -1;
    tnd_node *n = &s->nodes[s->node_count];
    memset(n, 0, sizeof *n);
    snprintf(n->name, sizeof n->name, "%s", name);
    n->parent = parent;
    const float zero[3] = {0, 0, 0}, one[3] = {1, 1, 1}, id[4] = {0, 0, 0, 1};
    memcpy(n->t, t ? t : zero, sizeof n->t);
    memcpy(n->r, r ? r : id, sizeof n->r);
    memcpy(n->s, sc ? sc : one, sizeof n->s);
    return (int32_t)s->node_count++;
}

int32_t tnd_scene_add_instance(tnd_scene *s, uint32_t mesh, uint32_t node)
{
    if (!grow((void **)&s->instances, s->instance_count, sizeof(tnd_instance)))
        return -1;
    s->instances[s->instance_count] = (tnd_instance){mesh, node, false};
    return (int32_t)s->instance_count++;
}

int32_t tnd_scene_add_camera(tnd_scene *s, uint32_t node, float yfov)
{
    if (!grow((void **)&s->cameras, s->camera_count, sizeof(tnd_camera_def)))
        return -1;
    s->cameras[s->camera_count] = (tnd_camera_def){"camera", node, yfov, 0.0f, 0.01f, 0.0f};
    return (int32_t)s->camera_count++;
}

int32_t tnd_scene_add_light(tnd_scene *s, const tnd_light *l)
{
    if (!grow((void **)&s->lights, s->light_count, sizeof(tnd_light)))
        return -1;
    s->lights[s->light_count] = *l;
    return (int32_t)s->light_count++;
}

tnd_result tnd_scene_add_channel(tnd_scene *s, uint32_t node, tnd_anim_path path,
                                 uint32_t key_count, const float *times, const float *values,
                                 bool step, bool cubic)
{
    if (node >= s->node_count || (unsigned)path > TND_ANIM_YFOV || key_count == 0)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "scene: %s: channel of node %u: bad arguments",
                        s->path, node);
    if (!grow((void **)&s->channels, s->channel_count, sizeof(tnd_anim_channel)))
        return TND_ERR_OUT_OF_MEMORY;
    size_t nv = (size_t)key_count * tnd_anim_dim(path) * (cubic ? 3 : 1);
    tnd_anim_channel *c = &s->channels[s->channel_count];
    *c = (tnd_anim_channel){node, path, key_count, malloc(key_count * sizeof(float)),
                            malloc(nv * sizeof(float)), step, cubic};
    if (!c->times || !c->values) {
        free(c->times);
        free(c->values);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    }
    memcpy(c->times, times, key_count * sizeof(float));
    memcpy(c->values, values, nv * sizeof(float));
    s->channel_count++;
    return TND_OK;
}

tnd_result tnd_scene_commit(tnd_scene *s)
{
    return scene_finish(s, NULL);
}

tnd_result tnd_scene_commit_with(tnd_scene *s, const tnd_scene_options *o)
{
    return scene_finish(s, o);
}
