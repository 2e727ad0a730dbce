/* core/scene.c: the flat scene representation: evaluation of animation (glTF TRS channels,
 * linear / slerp / step), the features a scene requires, validation shared by every source, and
 * the generated stress scene ("stress:N"). glTF import is in scene_gltf.c.
 * Entry points: tnd_scene_load, tnd_scene_destroy, tnd_scene_evaluate, tnd_scene_triangles,
 * tnd_scene_bounds. */
#include "core/core.h"
#include "core/scene_internal.h"
#include "shaders/texel_lut.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

void tnd_material_sigma(const tnd_material *m, float sigma[3])
{
    for (int k = 0; k < 3; k++) {
        float c = m->attenuation_color[k];
        sigma[k] = m->kind == TND_MAT_GLASS && m->attenuation_distance > 0 && c < 1.0f
                       ? -logf(c > 1e-6f ? c : 1e-6f) / m->attenuation_distance
                       : 0.0f;
    }
}

const char *tnd_material_kind_name(tnd_material_kind k)
{
    static const char *const n[] = {"opaque", "mirror", "thin glass", "glass"};
    return (unsigned)k < TND_MAT_KIND_COUNT ? n[k] : "?";
}

const char *tnd_light_type_name(tnd_light_type t)
{
    static const char *const n[] = {"point", "spot", "directional", "area"};
    return (unsigned)t < TND_LIGHT_TYPE_COUNT ? n[t] : "?";
}

const char *tnd_feature_name(uint32_t bit)
{
    static const char *const n[] = {
#define TND_X(id, text) text,
        TND_FEATURE_LIST(TND_X)
#undef TND_X
    };
    return bit < TND_FEATURE_COUNT ? n[bit] : "?";
}

void tnd_scene_destroy(tnd_scene *s)
{
    if (!s)
        return;
    tnd_env_free(&s->env);
    free(s->missing_images);
    free(s->positions);
    free(s->normals);
    free(s->uvs);
    free(s->uvs1);
    free(s->tangents);
    free(s->indices);
    free(s->meshes);
    free(s->materials);
    for (uint32_t i = 0; s->textures && i < s->texture_count; i++) {
        free(s->textures[i].rgba8);
        for (uint32_t l = 1; l < s->textures[i].levels; l++) /* (level 0 is rgba8) */
            free(s->textures[i].level[l]);
    }
    free(s->textures);
    free(s->nodes);
    free(s->instances);
    free(s->lights);
    free(s->emitters);
    free(s->cameras);
    for (uint32_t i = 0; s->channels && i < s->channel_count; i++) {
        free(s->channels[i].times);
        free(s->channels[i].values);
    }
    free(s->channels);
    free(s);
}

uint64_t tnd_scene_triangles(const tnd_scene *s)
{
    uint64_t n = 0;
    for (uint32_t i = 0; i < s->instance_count; i++)
        n += s->meshes[s->instances[i].mesh].triangle_count;
    return n;
}

/* ---- checks and derived data shared by all sources ------------------------------------------ */
void tnd_scene_bounds(const tnd_scene *s, const tnd_scene_state *st, double lo[3], double hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = 1e300, hi[k] = -1e300;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const tnd_mesh *m = &s->meshes[s->instances[i].mesh];
        const float *x = st->instance_xform + 12 * i;
        for (uint32_t v = 0; v < m->vertex_count; v++) {
            const float *p = s->positions + 3 * (size_t)(m->first_vertex + v);
            for (int k = 0; k < 3; k++) {
                double w = (double)x[4 * k] * p[0] + (double)x[4 * k + 1] * p[1] +
                           (double)x[4 * k + 2] * p[2] + x[4 * k + 3];
                lo[k] = fmin(lo[k], w), hi[k] = fmax(hi[k], w);
            }
        }
    }
}

/* A scene modelled with +Z up (Stellarium's scenery, assimp's exports of .blend files) turned to
 * glTF's +Y up: every root node, and every channel animating one, rotated by -90 degrees about
 * +X, so (x, y, z) becomes (x, z, -y). For a root's local T R S: Rx T R S = (Rx t) (qx r) S. */
static void up_z_to_y(tnd_scene *s)
{
    const float h = (float)(0.5 * sqrt(2.0)), qx[4] = {-h, 0, 0, h};
    for (uint32_t n = 0; n < s->node_count; n++) {
        if (s->nodes[n].parent >= 0)
            continue;
        float *t = s->nodes[n].t, y = t[1];
        t[1] = t[2], t[2] = -y;
        float r[4];
        tnd_quat_mul(qx, s->nodes[n].r, r);
        memcpy(s->nodes[n].r, r, sizeof r);
        for (uint32_t c = 0; c < s->channel_count; c++) {
            tnd_anim_channel *ch = &s->channels[c];
            if (ch->node != n || (ch->path != TND_ANIM_T && ch->path != TND_ANIM_R))
                continue;
            uint32_t dim = tnd_anim_dim(ch->path), per = ch->cubic ? 3 : 1;
            for (uint32_t k = 0; k < ch->key_count * per; k++) { /* values and tangents alike */
                float *v = ch->values + (size_t)dim * k;
                if (ch->path == TND_ANIM_T) {
                    float vy = v[1];
                    v[1] = v[2], v[2] = -vy;
                } else {
                    tnd_quat_mul(qx, v, r);
                    memcpy(v, r, sizeof r);
                }
            }
        }
    }
}

/* Animation flags (propagated to children: parents come first) and the duration. */
static void anim_flags(tnd_scene *s)
{
    for (uint32_t c = 0; c < s->channel_count; c++)
        s->nodes[s->channels[c].node].animated = true;
    for (uint32_t n = 0; n < s->node_count; n++)
        if (s->nodes[n].parent >= 0 && s->nodes[s->nodes[n].parent].animated)
            s->nodes[n].animated = true;
    s->duration = 0;
    for (uint32_t c = 0; c < s->channel_count; c++)
        if (s->channels[c].key_count)
            s->duration = fmaxf(s->duration, s->channels[c].times[s->channels[c].key_count - 1]);
}

void scene_default_view(const double lo[3], const double hi[3], double c[3], double *rad,
                        double *dist)
{
    double r2 = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * (lo[k] + hi[k]);
        r2 += 0.25 * (hi[k] - lo[k]) * (hi[k] - lo[k]);
    }
    *rad = sqrt(r2) > 0 ? sqrt(r2) : 1.0;
    double yfov = TND_DEFAULT_CAMERA_YFOV_DEG * TND_PI / 180;
    *dist = TND_DEFAULT_CAMERA_MARGIN * *rad / sin(0.5 * yfov);
}

/* A camera framing the bounds lo..hi (docs/scenes.md's rule). */
static tnd_result default_camera(tnd_scene *s, const double lo[3], const double hi[3])
{
    double c[3], rad, dist;
    scene_default_view(lo, hi, c, &rad, &dist);
    double az = TND_DEFAULT_CAMERA_AZIMUTH_DEG * TND_PI / 180;
    double el = TND_DEFAULT_CAMERA_ELEVATION_DEG * TND_PI / 180;
    double yfov = TND_DEFAULT_CAMERA_YFOV_DEG * TND_PI / 180;
    /* the camera's +Z (it looks down -Z) points from the centre to the camera */
    double b[3] = {sin(az) * cos(el), sin(el), cos(az) * cos(el)}, eye[3];
    float t[3], q[4];
    for (int k = 0; k < 3; k++)
        t[k] = (float)(eye[k] = c[k] + dist * b[k]);
    tnd_quat_look_at(eye, c, q);
    int32_t n = tnd_scene_add_node(s, "tandem_default_camera", -1, t, q, NULL);
    if (n < 0 || tnd_scene_add_camera(s, (uint32_t)n, (float)yfov) < 0)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: %s: out of memory", s->path);
    s->cameras[s->camera_count - 1].znear = (float)(1e-3 * dist);
    snprintf(s->default_camera, sizeof s->default_camera,
             "scene has no camera: framing its bounds (centre %.4g %.4g %.4g, radius %.4g) "
             "from %.0f degrees right of +Z and %.0f above, yfov %.0f degrees, margin %.0f%%",
             c[0], c[1], c[2], rad, TND_DEFAULT_CAMERA_AZIMUTH_DEG,
             TND_DEFAULT_CAMERA_ELEVATION_DEG, TND_DEFAULT_CAMERA_YFOV_DEG,
             100 * (TND_DEFAULT_CAMERA_MARGIN - 1));
    tnd_info("scene", "%s: %s", s->path, s->default_camera);
    return TND_OK;
}

/* What a real asset may lack: a camera (one framing the scene's bounds at time 0 is added; a
 * camera path replaces it) and any light: without a punctual light, a sky (tandem_sky, even
 * black) or an environment, a uniform white sky, whatever emissive surfaces it has (lamps and
 * signs are decoration, not what lights a level), unless o->no_default_light. Each is noted in
 * the scene and announced. */
static tnd_result scene_defaults(tnd_scene *s, const tnd_scene_options *o)
{
    s->default_camera[0] = s->default_light[0] = s->camera_path[0] = '\0';
    bool path = o && o->camera_path && o->camera_path[0];
    if ((s->camera_count == 0 || path) && s->instance_count > 0) {
        tnd_scene_state st = {0};
        tnd_result r = tnd_scene_evaluate(s, 0, 0, 1.0f, &st);
        double lo[3], hi[3];
        if (r == TND_OK)
            tnd_scene_bounds(s, &st, lo, hi);
        tnd_scene_state_free(&st);
        if (r != TND_OK)
            return r;
        if (path) {
            TND_TRY_RETURN(scene_camera_path(s, o, lo, hi));
            anim_flags(s);
        } else {
            TND_TRY_RETURN(default_camera(s, lo, hi));
        }
    }
    bool lit = s->light_count > 0 || s->sky_set || s->sky[0] > 0 || s->sky[1] > 0 ||
               s->sky[2] > 0 || (s->env.width > 0 && s->env.mean_luminance > 0);
    if (!lit && o && o->no_default_light) {
        tnd_info("scene", "%s: no punctual light, sky or environment, and no default light asked "
                 "for: lit by its %u emissive triangles alone",
                 s->path, s->emitter_count);
    } else if (!lit) {
        s->sky[0] = s->sky[1] = s->sky[2] = TND_DEFAULT_SKY;
        char why[96] = "";
        if (s->emitter_count)
            snprintf(why, sizeof why, " (its %u emissive triangles do not count as lighting)",
                     s->emitter_count);
        snprintf(s->default_light, sizeof s->default_light,
                 "scene has no punctual light, sky or environment%s: lit by the default "
                 "environment, a uniform white sky of %g nits (--no-default-light: off)",
                 why, (double)TND_DEFAULT_SKY);
        tnd_info("scene", "%s: %s", s->path, s->default_light);
    }
    return TND_OK;
}

tnd_result scene_finish(tnd_scene *s, const tnd_scene_options *o)
{
    const char *path = s->path;
    if (o && o->env) {
        TND_TRY_RETURN(tnd_env_load(o->env, o->env_intensity, o->env_rotation, &s->env));
        tnd_info("scene", "%s: lit by the environment %s (intensity %g, rotation %g degrees)",
                 path, o->env, (double)o->env_intensity, (double)o->env_rotation);
    }
    if (o && o->opaque)
        for (uint32_t m = 0; m < s->material_count; m++)
            s->materials[m].alpha_test = false;
    if (o && o->up_z)
        up_z_to_y(s);
    if (s->env.width && (s->sky[0] > 0 || s->sky[1] > 0 || s->sky[2] > 0)) {
        tnd_info("scene", "%s: the environment map replaces the uniform sky", path);
        s->sky[0] = s->sky[1] = s->sky[2] = 0;
    }
    for (uint32_t t = 0; t < s->texture_count; t++)
        if (!s->textures[t].levels) {
            tnd_result r = tnd_texture_build_mips(&s->textures[t]);
            if (r != TND_OK)
                return r;
        }
    /* indices in range, finite vertices */
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const tnd_mesh *me = &s->meshes[m];
        for (uint32_t k = 0; k < 3 * me->triangle_count; k++) {
            uint32_t i = s->indices[me->first_index + k];
            if (i >= me->vertex_count)
                return tnd_fail(TND_ERR_BAD_INPUT,
                                "scene: %s: mesh %u '%s': index %u out of range (%u vertices)",
                                path, m, me->name, i, me->vertex_count);
        }
        for (uint32_t v = 0; v < me->vertex_count; v++) {
            const float *p = s->positions + 3 * (size_t)(me->first_vertex + v);
            const float *n = s->normals + 3 * (size_t)(me->first_vertex + v);
            const float *uv = s->uvs + 2 * (size_t)(me->first_vertex + v);
            bool ok = true;
            for (int c = 0; c < 3; c++)
                ok &= isfinite(p[c]) && isfinite(n[c]);
            ok &= isfinite(uv[0]) && isfinite(uv[1]);
            if (s->uvs1)
                ok &= isfinite(s->uvs1[2 * (size_t)(me->first_vertex + v)]) &&
                      isfinite(s->uvs1[2 * (size_t)(me->first_vertex + v) + 1]);
            if (!ok)
                return tnd_fail(TND_ERR_BAD_INPUT,
                                "scene: %s: mesh %u '%s': vertex %u has a non-finite position, "
                                "normal or texture coordinate (%g, %g, %g)",
                                path, m, me->name, v, (double)p[0], (double)p[1], (double)p[2]);
        }
        if (me->material >= s->material_count)
            return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: mesh %u '%s': material %u of %u", path,
                            m, me->name, me->material, s->material_count);
    }
    /* emissive triangles become area lights; a degenerate one is an error (its pdf would be
     * infinite) */
    uint32_t cap = 0;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const tnd_mesh *me = &s->meshes[s->instances[i].mesh];
        const float *e = s->materials[me->material].emission;
        if (e[0] > 0 || e[1] > 0 || e[2] > 0)
            cap += me->triangle_count;
    }
    free(s->emitters);
    s->emitters = calloc(cap ? cap : 1, sizeof *s->emitters);
    if (!s->emitters)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: %s: out of memory", path);
    s->emitter_count = 0;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const tnd_mesh *me = &s->meshes[s->instances[i].mesh];
        const tnd_material *mat = &s->materials[me->material];
        if (!(mat->emission[0] > 0 || mat->emission[1] > 0 || mat->emission[2] > 0))
            continue;
        for (uint32_t t = 0; t < me->triangle_count; t++) {
            const uint32_t *ix = s->indices + me->first_index + 3 * t;
            const float *a = s->positions + 3 * (size_t)(me->first_vertex + ix[0]);
            const float *b = s->positions + 3 * (size_t)(me->first_vertex + ix[1]);
            const float *c = s->positions + 3 * (size_t)(me->first_vertex + ix[2]);
            double e1[3], e2[3], cr[3];
            for (int k = 0; k < 3; k++)
                e1[k] = (double)b[k] - a[k], e2[k] = (double)c[k] - a[k];
            cr[0] = e1[1] * e2[2] - e1[2] * e2[1];
            cr[1] = e1[2] * e2[0] - e1[0] * e2[2];
            cr[2] = e1[0] * e2[1] - e1[1] * e2[0];
            double area2 = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
            double l1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
            double l2 = sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
            if (!(area2 > 1e-9 * l1 * l2) || area2 == 0.0)
                return tnd_fail(TND_ERR_BAD_INPUT,
                                "scene: %s: mesh '%s' (emissive material '%s'): triangle %u has "
                                "zero area",
                                path, me->name, mat->name, t);
            s->emitters[s->emitter_count++] = (tnd_emitter){i, t};
        }
    }
    anim_flags(s);
    tnd_result dr = scene_defaults(s, o);
    if (dr != TND_OK)
        return dr;
    /* features */
    uint32_t f = 0;
    for (uint32_t l = 0; l < s->light_count; l++) {
        f |= s->lights[l].type == TND_LIGHT_POINT         ? TND_FEATURE(LIGHT_POINT)
             : s->lights[l].type == TND_LIGHT_SPOT        ? TND_FEATURE(LIGHT_SPOT)
             : s->lights[l].type == TND_LIGHT_DIRECTIONAL ? TND_FEATURE(LIGHT_DIRECTIONAL)
                                                          : 0;
        if (s->lights[l].schedule_count > 1)
            f |= TND_FEATURE(LIGHT_SCHEDULE);
    }
    if (s->emitter_count)
        f |= TND_FEATURE(LIGHT_AREA);
    if (s->sky[0] > 0 || s->sky[1] > 0 || s->sky[2] > 0)
        f |= TND_FEATURE(SKY);
    if (s->env.width)
        f |= TND_FEATURE(ENV_MAP);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        s->instances[i].animated = s->nodes[s->instances[i].node].animated;
        if (s->instances[i].animated)
            f |= TND_FEATURE(ANIMATED_OBJECTS);
        const tnd_material *m = &s->materials[s->meshes[s->instances[i].mesh].material];
        if (m->tex_base_color >= 0 || m->tex_metal_rough >= 0 || m->tex_emission >= 0 ||
            m->tex_normal >= 0)
            f |= TND_FEATURE(TEXTURES);
        if (m->tex_normal >= 0)
            f |= TND_FEATURE(NORMAL_MAPS);
        if (m->alpha_test)
            f |= TND_FEATURE(ALPHA);
        if (m->kind == TND_MAT_MIRROR)
            f |= TND_FEATURE(MIRROR);
        if (m->kind == TND_MAT_GLASS)
            f |= TND_FEATURE(GLASS) | TND_FEATURE(SPLIT);
        if (m->kind == TND_MAT_THIN_GLASS)
            f |= TND_FEATURE(THIN_GLASS) | TND_FEATURE(SPLIT);
    }
    for (uint32_t c = 0; c < s->camera_count; c++)
        if (s->nodes[s->cameras[c].node].animated)
            f |= TND_FEATURE(ANIMATED_CAMERA);
    s->features = f;
    if (s->instance_count == 0)
        return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: no geometry", path);
    return TND_OK;
}

/* 8-bit texels as linear values (shaders/texel_lut.h; pt_scene.glsl's texel_decode): sRGB
 * through the table, linear data (and alpha) as c x (1 / 255) */
static const float srgb_lut[TND_TEXEL_LUT_SIZE] = {TND_TEXEL_LUT_VALUES};
static const float unorm = (float)TND_TEXEL_UNORM;
static inline float texel_value(uint8_t c, bool srgb)
{
    return srgb ? srgb_lut[c] : (float)c * unorm;
}

/* linear to the nearest 8-bit code (sRGB-encoded where srgb): the inverse of texel_value */
static uint8_t encode8(float x, bool srgb)
{
    if (!srgb) {
        float c = roundf(x * 255.0f);
        return (uint8_t)(c < 0 ? 0 : c > 255 ? 255 : c);
    }
    const float *lut = srgb_lut;
    int lo = 0, hi = 255;
    while (lo < hi) { /* the first code whose value is >= x */
        int mid = (lo + hi) / 2;
        if (lut[mid] < x)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo > 0 && x - lut[lo - 1] <= lut[lo] - x)
        lo--;
    return (uint8_t)lo;
}

tnd_result tnd_texture_build_mips(tnd_texture *t)
{
    uint32_t w = t->width, h = t->height;
    /* level 0 is the image as stored; each further level a 2x2 box filter of the one above, in
     * linear values, stored again in 8 bits (sRGB-encoded where the texture is) */
    t->level[0] = t->rgba8;
    t->level_w[0] = w;
    t->level_h[0] = h;
    t->levels = 1;
    while ((w > 1 || h > 1) && t->levels < TND_TEXTURE_MAX_LEVELS) {
        uint32_t nw = w > 1 ? w / 2 : 1, nh = h > 1 ? h / 2 : 1;
        const uint8_t *src = t->level[t->levels - 1];
        uint8_t *dst = malloc((size_t)nw * nh * 4);
        if (!dst)
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: texture '%s': out of memory", t->name);
        for (uint32_t y = 0; y < nh; y++)
            for (uint32_t x = 0; x < nw; x++) {
                uint32_t x0 = 2 * x < w ? 2 * x : w - 1, x1 = 2 * x + 1 < w ? 2 * x + 1 : x0;
                uint32_t y0 = 2 * y < h ? 2 * y : h - 1, y1 = 2 * y + 1 < h ? 2 * y + 1 : y0;
                const uint8_t *a = src + 4 * ((size_t)y0 * w + x0), *b = src + 4 * ((size_t)y0 * w + x1);
                const uint8_t *c = src + 4 * ((size_t)y1 * w + x0), *d = src + 4 * ((size_t)y1 * w + x1);
                for (int k = 0; k < 4; k++) {
                    bool sr = k < 3 && t->srgb;
                    float m = 0.25f * (texel_value(a[k], sr) + texel_value(b[k], sr) +
                                       texel_value(c[k], sr) + texel_value(d[k], sr));
                    dst[4 * ((size_t)y * nw + x) + k] = encode8(m, sr);
                }
            }
        t->level[t->levels] = dst;
        t->level_w[t->levels] = nw;
        t->level_h[t->levels] = nh;
        t->levels++;
        w = nw, h = nh;
    }
    return TND_OK;
}

static void bilinear(const tnd_texture *t, uint32_t l, float u, float v, float out[4])
{
    uint32_t w = t->level_w[l], h = t->level_h[l];
    float x = u * (float)w - 0.5f, y = v * (float)h - 0.5f;
    float fx = floorf(x), fy = floorf(y);
    float ax = x - fx, ay = y - fy;
    long ix = (long)fx, iy = (long)fy;
    const uint8_t *d = t->level[l];
    for (int c = 0; c < 4; c++)
        out[c] = 0;
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            long xx = ((ix + i) % (long)w + (long)w) % (long)w;
            long yy = ((iy + j) % (long)h + (long)h) % (long)h;
            float wgt = (i ? ax : 1 - ax) * (j ? ay : 1 - ay);
            const uint8_t *p = d + 4 * ((size_t)yy * w + (size_t)xx);
            for (int c = 0; c < 4; c++)
                out[c] += wgt * texel_value(p[c], c < 3 && t->srgb);
        }
}

void tnd_texture_sample(const tnd_texture *t, float u, float v, float lod, float out[4])
{
    if (!isfinite(u) || !isfinite(v))
        u = v = 0;
    u -= floorf(u);
    v -= floorf(v);
    if (!(lod > 0))
        lod = 0;
    float maxl = (float)(t->levels - 1);
    if (lod > maxl)
        lod = maxl;
    uint32_t l0 = (uint32_t)lod, l1 = l0 + 1 < t->levels ? l0 + 1 : l0;
    float f = lod - (float)l0, a[4], b[4];
    bilinear(t, l0, u, v, a);
    /* (no second level where it has no weight: a + 0 (b - a) is a, texels being finite and not
     * -0; the GPU's skip too) */
    if (f == 0.0f) { /* (also where l1 is l0: lod is then the last level, a whole number) */
        memcpy(out, a, sizeof a);
        return;
    }
    bilinear(t, l1, u, v, b);
    for (int c = 0; c < 4; c++)
        out[c] = a[c] + f * (b[c] - a[c]);
}

bool tnd_material_alpha_pass(const tnd_scene *s, const tnd_material *m, float u, float v)
{
    if (!m->alpha_test)
        return true;
    float a = m->base_color[3];
    if (m->tex_base_color >= 0) {
        float t[4], tu, tv;
        tnd_uv_apply(&m->uvx[TND_TEX_BASE], u, v, &tu, &tv);
        tnd_texture_sample(&s->textures[m->tex_base_color], tu, tv, 0.0f, t);
        a *= t[3];
    }
    return a >= m->alpha_cutoff;
}

tnd_material_kind scene_classify(const tnd_material *m)
{
    if (m->transmission > 0.0f)
        return m->thickness > 0.0f ? TND_MAT_GLASS : TND_MAT_THIN_GLASS;
    if (m->metallic >= 0.5f && m->roughness < TND_MIRROR_ROUGHNESS)
        return TND_MAT_MIRROR;
    return TND_MAT_OPAQUE;
}

/* ---- evaluation ------------------------------------------------------------------------------ */
static uint32_t find_key(const tnd_anim_channel *c, float t)
{
    /* last key with time <= t (binary search); keys are few, but cameras can have many */
    uint32_t lo = 0, hi = c->key_count;
    while (hi - lo > 1) {
        uint32_t mid = (lo + hi) / 2;
        if (c->times[mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

uint32_t tnd_anim_dim(tnd_anim_path p)
{
    return p == TND_ANIM_R ? 4 : p == TND_ANIM_YFOV ? 1 : 3;
}

/* A channel's value at time t (clamped to its keys) into out (its dim floats): linear (slerp for
 * rotations), STEP, or CUBICSPLINE as the glTF spec defines it: with s = (t - t_k) / d and
 * d = t_k+1 - t_k, p = (2s^3 - 3s^2 + 1) v_k + (s^3 - 2s^2 + s) d b_k + (-2s^3 + 3s^2) v_k+1
 * + (s^3 - s^2) d a_k+1 (b: out-tangent, a: in-tangent), a rotation then normalised. */
static void anim_sample(const tnd_anim_channel *ch, double t, float *out)
{
    if (ch->key_count == 0)
        return;
    uint32_t dim = tnd_anim_dim(ch->path), k = find_key(ch, (float)t);
    uint32_t k1 = k + 1 < ch->key_count ? k + 1 : k;
    double d = ch->times[k1] - ch->times[k];
    float u = 0;
    if (k1 != k && !ch->step && (float)t > ch->times[k])
        u = (float)((t - ch->times[k]) / d);
    if (u > 1)
        u = 1;
    if (ch->cubic) {
        const float *a = ch->values + 3 * dim * k, *b = ch->values + 3 * dim * k1;
        double u2 = (double)u * u, u3 = u2 * u;
        double h00 = 2 * u3 - 3 * u2 + 1, h10 = (u3 - 2 * u2 + u) * d, h01 = -2 * u3 + 3 * u2,
               h11 = (u3 - u2) * d, n = 0;
        for (uint32_t i = 0; i < dim; i++) {
            out[i] = (float)(h00 * a[dim + i] + h10 * a[2 * dim + i] + h01 * b[dim + i] +
                             h11 * b[i]);
            n += (double)out[i] * out[i];
        }
        if (ch->path == TND_ANIM_R && n > 0)
            for (uint32_t i = 0; i < 4; i++)
                out[i] = (float)(out[i] / sqrt(n));
    } else if (ch->path == TND_ANIM_R) {
        tnd_quat_slerp(ch->values + 4 * k, ch->values + 4 * k1, u, out);
    } else {
        for (uint32_t i = 0; i < dim; i++)
            out[i] = ch->values[dim * k + i] * (1 - u) + ch->values[dim * k1 + i] * u;
    }
}

tnd_result tnd_scene_evaluate(const tnd_scene *s, double time, uint32_t camera, float aspect,
                              tnd_scene_state *st)
{
    if (!st->node_world) {
        st->node_world = calloc((size_t)s->node_count * 16 + 16, sizeof(float));
        st->instance_xform = calloc((size_t)s->instance_count * 12 + 12, sizeof(float));
        st->light_scale = calloc((size_t)s->light_count + 1, sizeof(float));
        if (!st->node_world || !st->instance_xform || !st->light_scale) {
            tnd_scene_state_free(st);
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
        }
    }
    double t = time < 0 ? 0 : time > s->duration ? s->duration : time;
    st->time = t;
    for (uint32_t n = 0; n < s->node_count; n++) {
        const tnd_node *nd = &s->nodes[n];
        float tr[3], rot[4], sc[3];
        memcpy(tr, nd->t, sizeof tr);
        memcpy(rot, nd->r, sizeof rot);
        memcpy(sc, nd->s, sizeof sc);
        if (nd->animated)
            for (uint32_t c = 0; c < s->channel_count; c++) {
                const tnd_anim_channel *ch = &s->channels[c];
                if (ch->node == n && ch->path != TND_ANIM_YFOV)
                    anim_sample(ch, t, ch->path == TND_ANIM_T ? tr : ch->path == TND_ANIM_R ? rot : sc);
            }
        float local[16];
        tnd_mat4_trs(tr, rot, sc, local);
        float *w = st->node_world + 16 * n;
        if (nd->parent >= 0)
            tnd_mat4_mul(st->node_world + 16 * nd->parent, local, w);
        else
            memcpy(w, local, sizeof local);
    }
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const float *w = st->node_world + 16 * s->instances[i].node;
        float *x = st->instance_xform + 12 * i;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++)
                x[4 * r + c] = w[c * 4 + r];
    }
    for (uint32_t l = 0; l < s->light_count; l++) {
        const tnd_light *li = &s->lights[l];
        float scale = 1.0f;
        if (li->schedule_count) {
            double frame = t * li->schedule_fps + 1e-6;
            for (uint32_t k = 0; k < li->schedule_count; k++)
                if (frame >= li->schedule_frame[k])
                    scale = li->schedule_scale[k];
        }
        st->light_scale[l] = scale;
    }
    /* camera: view = inverse of the camera node's rigid world transform */
    tnd_mat4_identity(st->camera.view);
    tnd_mat4_perspective(0.8f, aspect > 0 ? aspect : 1.0f, 0.05f, 0.0f, st->camera.proj);
    st->camera_position[0] = st->camera_position[1] = st->camera_position[2] = 0;
    if (camera < s->camera_count) {
        const tnd_camera_def *cd = &s->cameras[camera];
        const float *w = st->node_world + 16 * cd->node;
        float rigid[16];
        memcpy(rigid, w, sizeof rigid);
        for (int c = 0; c < 3; c++) { /* drop scale: glTF cameras must not be scaled */
            double n = sqrt((double)w[c * 4] * w[c * 4] + (double)w[c * 4 + 1] * w[c * 4 + 1] +
                            (double)w[c * 4 + 2] * w[c * 4 + 2]);
            for (int r = 0; r < 3; r++)
                rigid[c * 4 + r] = n > 0 ? (float)(w[c * 4 + r] / n) : (c == r);
        }
        tnd_mat4_inverse(rigid, st->camera.view);
        float yfov = cd->yfov;
        for (uint32_t c = 0; c < s->channel_count; c++)
            if (s->channels[c].node == cd->node && s->channels[c].path == TND_ANIM_YFOV)
                anim_sample(&s->channels[c], t, &yfov);
        tnd_mat4_perspective(yfov, aspect > 0 ? aspect : (cd->aspect > 0 ? cd->aspect : 1.0f),
                             cd->znear, cd->zfar, st->camera.proj);
        memcpy(st->camera_position, w + 12, 3 * sizeof(float));
    } else if (s->camera_count) {
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "scene: %s: camera %u of %u", s->path, camera,
                        s->camera_count);
    }
    return TND_OK;
}

void tnd_scene_state_free(tnd_scene_state *st)
{
    free(st->node_world);
    free(st->instance_xform);
    free(st->light_scale);
    memset(st, 0, sizeof *st);
}

/* ---- the generated stress scene ---------------------------------------------------------------
 */
static tnd_result stress_scene(const char *spec, const tnd_scene_options *o, tnd_scene **out)
{
    char *end = NULL;
    double want = strtod(spec + 7, &end);
    if (end == spec + 7 || *end || !(want >= 1000) || want > 2e8)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "scene: '%s': expected stress:N with 1000 <= N <= 2e8 triangles", spec);
    tnd_scene *s = calloc(1, sizeof *s);
    if (!s)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: out of memory");
    snprintf(s->path, sizeof s->path, "%s", spec);
    /* 16 displaced spheres of seg x seg/2 quads (about seg^2 triangles each), a ground quad, an
     * emissive panel, a camera. */
    const uint32_t nb = 16;
    uint32_t seg = (uint32_t)ceil(sqrt(want / nb));
    if (seg < 8)
        seg = 8;
    seg += seg & 1;
    uint32_t rings = seg / 2;
    uint32_t sv = (seg + 1) * (rings + 1), st = 2 * seg * (rings - 1);
    s->vertex_count = nb * sv + 8;
    s->index_count = 3 * (nb * st + 4);
    s->positions = calloc((size_t)s->vertex_count * 3, sizeof(float));
    s->normals = calloc((size_t)s->vertex_count * 3, sizeof(float));
    s->uvs = calloc((size_t)s->vertex_count * 2, sizeof(float));
    s->tangents = calloc((size_t)s->vertex_count * 4, sizeof(float));
    s->indices = calloc(s->index_count, sizeof(uint32_t));
    s->mesh_count = nb + 2;
    s->meshes = calloc(s->mesh_count, sizeof *s->meshes);
    s->material_count = 3;
    s->materials = calloc(3, sizeof *s->materials);
    s->node_count = s->mesh_count + 1;
    s->nodes = calloc(s->node_count, sizeof *s->nodes);
    s->instance_count = s->mesh_count;
    s->instances = calloc(s->instance_count, sizeof *s->instances);
    s->camera_count = 1;
    s->sky_set = true; /* lit by its panel: a black sky, no default light */
    s->cameras = calloc(1, sizeof *s->cameras);
    if (!s->positions || !s->normals || !s->uvs || !s->tangents || !s->indices || !s->meshes ||
        !s->materials || !s->nodes || !s->instances || !s->cameras) {
        tnd_scene_destroy(s);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "scene: '%s': out of memory", spec);
    }
    const float cols[3][3] = {{0.7f, 0.7f, 0.7f}, {0.6f, 0.3f, 0.2f}, {0.8f, 0.8f, 0.8f}};
    for (int m = 0; m < 3; m++) {
        tnd_material *mt = &s->materials[m];
        snprintf(mt->name, sizeof mt->name, "%s", m == 0 ? "ground" : m == 1 ? "blob" : "panel");
        memcpy(mt->base_color, cols[m], sizeof cols[m]);
        mt->base_color[3] = 1;
        mt->roughness = m == 1 ? 0.4f : 0.9f;
        mt->ior = 1.5f;
        mt->specular = 1.0f;
        mt->normal_scale = 1;
        mt->tex_base_color = mt->tex_metal_rough = mt->tex_normal = mt->tex_emission = -1;
        for (int k = 0; k < TND_TEX_SLOTS; k++)
            mt->uvx[k] = (tnd_uv_xform)TND_UV_IDENTITY;
        if (m == 2)
            mt->emission[0] = mt->emission[1] = mt->emission[2] = 20.0f;
    }
    uint32_t v = 0, ix = 0;
    for (uint32_t b = 0; b < nb; b++) {
        tnd_mesh *me = &s->meshes[b];
        snprintf(me->name, sizeof me->name, "blob_%u", b);
        me->first_vertex = v;
        me->first_index = ix;
        me->material = 1;
        for (uint32_t j = 0; j <= rings; j++)
            for (uint32_t i = 0; i <= seg; i++, v++) {
                double th = TND_PI * j / rings, ph = 2 * TND_PI * i / seg;
                double n[3] = {sin(th) * cos(ph), cos(th), sin(th) * sin(ph)};
                double r = 0.45 * (1.0 + 0.08 * sin(5 * ph + b) * sin(4 * th + 0.5 * b));
                for (int c = 0; c < 3; c++) {
                    s->positions[3 * v + c] = (float)(r * n[c]);
                    s->normals[3 * v + c] = (float)n[c];
                }
                s->uvs[2 * v] = (float)i / seg;
                s->uvs[2 * v + 1] = (float)j / rings;
                s->tangents[4 * v] = 1, s->tangents[4 * v + 3] = 1;
            }
        for (uint32_t j = 0; j < rings; j++)
            for (uint32_t i = 0; i < seg; i++) {
                uint32_t a = j * (seg + 1) + i, c = (j + 1) * (seg + 1) + i;
                if (j != 0) {
                    s->indices[ix++] = a, s->indices[ix++] = c, s->indices[ix++] = a + 1;
                }
                if (j != rings - 1) {
                    s->indices[ix++] = a + 1, s->indices[ix++] = c, s->indices[ix++] = c + 1;
                }
            }
        me->vertex_count = v - me->first_vertex;
        me->triangle_count = (ix - me->first_index) / 3;
    }
    for (uint32_t q = 0; q < 2; q++) { /* ground (up) and panel (down) */
        tnd_mesh *me = &s->meshes[nb + q];
        snprintf(me->name, sizeof me->name, "%s", q ? "panel" : "ground");
        me->first_vertex = v;
        me->first_index = ix;
        me->vertex_count = 4;
        me->triangle_count = 2;
        me->material = q ? 2 : 0;
        float h = q ? 0.5f : 5.0f, y = q ? 3.0f : 0.0f, ny = q ? -1.0f : 1.0f;
        const float xz[4][2] = {{-h, -h}, {h, -h}, {h, h}, {-h, h}};
        for (int k = 0; k < 4; k++, v++) {
            s->positions[3 * v] = xz[k][0], s->positions[3 * v + 1] = y;
            s->positions[3 * v + 2] = xz[k][1];
            s->normals[3 * v + 1] = ny;
            s->tangents[4 * v] = 1, s->tangents[4 * v + 3] = 1;
        }
        const uint32_t up[6] = {0, 2, 1, 0, 3, 2}, down[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++)
            s->indices[ix++] = q ? down[k] : up[k];
    }
    s->vertex_count = v;
    s->index_count = ix;
    for (uint32_t n = 0; n < s->mesh_count; n++) {
        tnd_node *nd = &s->nodes[n];
        snprintf(nd->name, sizeof nd->name, "%s", s->meshes[n].name);
        nd->parent = -1;
        nd->r[3] = 1;
        nd->s[0] = nd->s[1] = nd->s[2] = 1;
        if (n < nb) {
            nd->t[0] = -1.8f + 1.2f * (float)(n % 4);
            nd->t[1] = 0.5f;
            nd->t[2] = -1.8f + 1.2f * (float)(n / 4);
        }
        s->instances[n] = (tnd_instance){n, n, false};
    }
    tnd_node *cn = &s->nodes[s->mesh_count];
    snprintf(cn->name, sizeof cn->name, "camera");
    cn->parent = -1;
    /* look from (0, 3, 6) towards the grid: pitch down about 24 degrees */
    double a = -0.42 / 2;
    cn->t[1] = 3.0f, cn->t[2] = 6.0f;
    cn->r[0] = (float)sin(a), cn->r[3] = (float)cos(a);
    cn->s[0] = cn->s[1] = cn->s[2] = 1;
    s->cameras[0] = (tnd_camera_def){"camera", s->mesh_count, 0.8f, 0.0f, 0.05f, 0.0f};
    tnd_result r = scene_finish(s, o);
    if (r != TND_OK) {
        tnd_scene_destroy(s);
        return r;
    }
    *out = s;
    return TND_OK;
}

tnd_result tnd_scene_load(const char *path, tnd_scene **scene)
{
    return tnd_scene_load_with(path, NULL, scene);
}

tnd_result tnd_scene_load_with(const char *path, const tnd_scene_options *o, tnd_scene **scene)
{
    *scene = NULL;
    if (strncmp(path, "stress:", 7) == 0)
        return stress_scene(path, o, scene);
    /* glTF by its extension; OBJ and the formats assimp reads that the MTL conversion fits;
     * any other is refused by name (a file without an extension is tried as glTF, whose parser
     * says what is wrong) */
    static const char *const others[] = {".obj", ".fbx", ".dae", ".ply", ".stl", ".3ds"};
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    if (dot && (!slash || dot > slash) && strcasecmp(dot, ".gltf") != 0 &&
        strcasecmp(dot, ".glb") != 0) {
        for (size_t i = 0; i < sizeof others / sizeof *others; i++)
            if (strcasecmp(dot, others[i]) == 0)
                return scene_load_assimp(path, o, scene);
        return tnd_fail(TND_ERR_UNSUPPORTED,
                        "scene: %s: '%s' files are not supported (Tandem reads glTF 2.0 .gltf and "
                        ".glb, and through assimp .obj with .mtl, .fbx, .dae, .ply, .stl, .3ds)",
                        path, dot + 1);
    }
    return scene_load_gltf(path, o, scene);
}

/* ---- digest ------------------------------------------------------------------------------ */
static void fnv(uint64_t *h, const void *p, size_t n)
{
    const uint8_t *b = p;
    for (size_t i = 0; i < n; i++)
        *h = (*h ^ b[i]) * 0x100000001b3ull;
}
#define FNV_ARR(h, p, n) ((p) ? fnv(h, p, (size_t)(n) * sizeof *(p)) : (void)0)

uint64_t tnd_scene_digest(const tnd_scene *s)
{
    uint64_t h = 0xcbf29ce484222325ull;
    fnv(&h, &s->vertex_count, sizeof s->vertex_count);
    fnv(&h, &s->index_count, sizeof s->index_count);
    FNV_ARR(&h, s->positions, 3ull * s->vertex_count);
    FNV_ARR(&h, s->normals, 3ull * s->vertex_count);
    FNV_ARR(&h, s->uvs, 2ull * s->vertex_count);
    FNV_ARR(&h, s->uvs1, 2ull * s->vertex_count);
    FNV_ARR(&h, s->tangents, 4ull * s->vertex_count);
    FNV_ARR(&h, s->indices, s->index_count);
    for (uint32_t i = 0; i < s->mesh_count; i++) { /* (field by field: no padding bytes) */
        const tnd_mesh *m = &s->meshes[i];
        uint32_t v[5] = {m->first_vertex, m->vertex_count, m->first_index, m->triangle_count,
                         m->material};
        fnv(&h, v, sizeof v);
    }
    for (uint32_t i = 0; i < s->material_count; i++) {
        const tnd_material *m = &s->materials[i];
        float f[] = {m->base_color[0], m->base_color[1], m->base_color[2], m->base_color[3],
                     m->metallic, m->roughness, m->emission[0], m->emission[1], m->emission[2],
                     m->transmission, m->ior, m->specular, m->attenuation_color[0],
                     m->attenuation_color[1], m->attenuation_color[2], m->attenuation_distance,
                     m->thickness, m->normal_scale, m->alpha_cutoff};
        int32_t k[] = {(int32_t)m->kind, m->tex_base_color, m->tex_metal_rough, m->tex_normal,
                       m->tex_emission, m->double_sided, m->alpha_test};
        fnv(&h, f, sizeof f);
        fnv(&h, k, sizeof k);
        for (int t = 0; t < TND_TEX_SLOTS; t++) {
            fnv(&h, m->uvx[t].m, sizeof m->uvx[t].m);
            fnv(&h, &m->uvx[t].set, sizeof m->uvx[t].set);
        }
    }
    for (uint32_t i = 0; i < s->texture_count; i++) {
        const tnd_texture *t = &s->textures[i];
        uint32_t v[3] = {t->width, t->height, t->srgb};
        fnv(&h, v, sizeof v);
        FNV_ARR(&h, t->rgba8, 4ull * t->width * t->height);
    }
    for (uint32_t i = 0; i < s->node_count; i++) {
        const tnd_node *n = &s->nodes[i];
        fnv(&h, &n->parent, sizeof n->parent);
        fnv(&h, n->t, sizeof n->t);
        fnv(&h, n->r, sizeof n->r);
        fnv(&h, n->s, sizeof n->s);
    }
    for (uint32_t i = 0; i < s->instance_count; i++) {
        uint32_t v[2] = {s->instances[i].mesh, s->instances[i].node};
        fnv(&h, v, sizeof v);
    }
    for (uint32_t i = 0; i < s->light_count; i++) {
        const tnd_light *l = &s->lights[i];
        uint32_t v[3] = {l->type, l->node, l->schedule_count};
        float f[] = {l->color[0], l->color[1], l->color[2], l->inner_cone, l->outer_cone,
                     l->schedule_fps};
        fnv(&h, v, sizeof v);
        fnv(&h, f, sizeof f);
        fnv(&h, l->schedule_frame, l->schedule_count * sizeof(float));
        fnv(&h, l->schedule_scale, l->schedule_count * sizeof(float));
    }
    for (uint32_t i = 0; i < s->camera_count; i++) {
        const tnd_camera_def *c = &s->cameras[i];
        float f[4] = {c->yfov, c->aspect, c->znear, c->zfar};
        fnv(&h, &c->node, sizeof c->node);
        fnv(&h, f, sizeof f);
    }
    for (uint32_t i = 0; i < s->channel_count; i++) {
        const tnd_anim_channel *c = &s->channels[i];
        uint32_t v[4] = {c->node, c->path, c->key_count, c->step};
        fnv(&h, v, sizeof v);
        if (c->cubic)
            fnv(&h, "cubic", 5);
        FNV_ARR(&h, c->times, c->key_count);
        FNV_ARR(&h, c->values, (size_t)c->key_count * tnd_anim_dim(c->path) * (c->cubic ? 3 : 1));
    }
    fnv(&h, s->sky, sizeof s->sky);
    uint32_t ev[2] = {s->env.width, s->env.height};
    float ef[2] = {s->env.intensity, s->env.rotation};
    fnv(&h, ev, sizeof ev);
    fnv(&h, ef, sizeof ef);
    if (s->env.width)
        FNV_ARR(&h, s->env.data, TND_ENV_FLOATS(s->env.width, s->env.height));
    return h;
}
