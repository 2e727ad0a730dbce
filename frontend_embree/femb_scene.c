/* frontend_embree/femb_scene.c: Embree device and scenes (one scene per mesh, instanced in a top
 * scene whose geometry ids are the tnd_scene instance indices), per-instance and per-material
 * records, per-frame transforms, the benchmark's ray log, surface reconstruction and the
 * tile-parallel loop (the ray casts and the ray-offset rule are inline in femb_internal.h).
 * Entry points: femb_create, femb_destroy, femb_set_frame, femb_log_ray, femb_surface_eval_batch,
 * femb_surface_eval_eye, femb_surface_eval, femb_parallel_tiles. */
#include "frontend_embree/femb_internal.h"
#include "shaders/sampling.h"
#include "shaders/specular.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define FEMB_HAVE_SSE 1
#endif

static void on_embree_error(void *user, enum RTCError code, const char *str)
{
    femb_context *c = user;
    if (!c->error[0])
        snprintf(c->error, sizeof c->error, "embree error %d: %s", (int)code, str ? str : "");
}

/* The alpha test of a mesh whose material has one (tnd_material_alpha_pass), as Embree's
 * intersection and occlusion filter: a hit where the surface is cut out is rejected, and the ray
 * goes on. Meshes without it get no filter (an opaque scene runs none). */
typedef struct femb_alpha_geom {
    const tnd_scene *s;
    uint32_t mesh;
} femb_alpha_geom;

static void alpha_filter(const struct RTCFilterFunctionNArguments *a)
{
    const femb_alpha_geom *g = a->geometryUserPtr;
    const tnd_scene *s = g->s;
    const tnd_mesh *me = &s->meshes[g->mesh];
    const tnd_material *m = &s->materials[me->material];
    for (unsigned i = 0; i < a->N; i++) {
        if (a->valid[i] != -1)
            continue;
        /* RTCHitN is structure-of-arrays (Ng x, y, z, u, v, primID, ...: N each); its accessors
         * are C++ only */
        const float *hf = (const float *)a->hit;
        uint32_t prim = ((const uint32_t *)a->hit)[5 * a->N + i];
        float bu = hf[3 * a->N + i], bv = hf[4 * a->N + i];
        const uint32_t *ix = s->indices + me->first_index + 3 * (size_t)prim;
        const float *uvs = m->uvx[TND_TEX_BASE].set && s->uvs1 ? s->uvs1 : s->uvs;
        const float *t0 = uvs + 2 * (size_t)(me->first_vertex + ix[0]);
        const float *t1 = uvs + 2 * (size_t)(me->first_vertex + ix[1]);
        const float *t2 = uvs + 2 * (size_t)(me->first_vertex + ix[2]);
        float w0 = 1.0f - bu - bv;
        float u = w0 * t0[0] + bu * t1[0] + bv * t2[0];
        float v = w0 * t0[1] + bu * t1[1] + bv * t2[1];
        if (!tnd_material_alpha_pass(s, m, u, v))
            a->valid[i] = 0;
    }
}

void femb_destroy(femb_context *c)
{
    if (!c)
        return;
    femb_pool_stop(c);
    femb_restir_free(&c->rs);
    if (c->top)
        rtcReleaseScene(c->top);
    for (uint32_t m = 0; c->meshes && m < c->scene->mesh_count; m++)
        if (c->meshes[m])
            rtcReleaseScene(c->meshes[m]);
    free(c->meshes);
    free(c->alpha);
    free(c->inst);
    free(c->mats);
    free(c->inst_index0);
    free(c->inst_vertex0);
    if (c->device)
        rtcReleaseDevice(c->device);
    tnd_lights_free(&c->lights);
    free(c);
}

uint32_t femb_thread_count(const femb_context *c)
{
    return c->threads;
}

const char *femb_simd(void)
{
#if defined(FEMB_NO_CLONES)
    return "the baseline only (built without clones)";
#elif defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
    /* the test the target_clones resolver makes (FEMB_LANE_FN) */
    if (__builtin_cpu_supports("x86-64-v4"))
        return "x86-64-v4 (AVX-512), 8 lanes";
    return __builtin_cpu_supports("x86-64-v3") ? "x86-64-v3 (AVX2), 8 lanes" : "SSE2, 4 lanes";
#else
    return "the compiler's default";
#endif
}

tnd_result femb_create(const tnd_scene *s, const femb_desc *d, femb_context **out)
{
    *out = NULL;
    femb_context *c = calloc(1, sizeof *c);
    if (!c)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "embree: out of memory");
    c->scene = s;
    c->specular = (s->features & (TND_FEATURE(MIRROR) | TND_FEATURE(GLASS) |
                                      TND_FEATURE(THIN_GLASS))) != 0;
    long ncpu = sysconf(_SC_NPROCESSORS_ONLN);
    c->threads = d && d->threads ? d->threads : (uint32_t)(ncpu > 0 ? ncpu : 1);
    c->reflect_depth = d && d->reflect_depth ? d->reflect_depth : TND_REFLECT_DEPTH;
    c->footprint_scale = d && d->footprint_scale > 0 ? d->footprint_scale : 1.0f;
    tnd_light_sampling pick = tnd_light_sampling_for(s, d ? d->lights : TND_LIGHTS_AUTO);
    c->restir = pick == TND_LIGHTS_RESTIR; /* (its candidates by the tree) */
    c->lights.want_tree = pick == TND_LIGHTS_TREE || pick == TND_LIGHTS_RESTIR;
    if (c->reflect_depth > TND_MAX_SPECULAR_DEPTH)
        c->reflect_depth = TND_MAX_SPECULAR_DEPTH;
    char cfg[64];
    snprintf(cfg, sizeof cfg, "threads=%u", c->threads);
    c->device = rtcNewDevice(cfg);
    if (!c->device) {
        femb_destroy(c);
        return tnd_fail(TND_ERR_UNSUPPORTED, "embree: cannot create a device (error %d)",
                        (int)rtcGetDeviceError(NULL));
    }
    rtcSetDeviceErrorFunction(c->device, on_embree_error, c);
    c->meshes = calloc(s->mesh_count + 1, sizeof *c->meshes);
    c->inst = calloc(s->instance_count + 1, sizeof *c->inst);
    c->mats = calloc(s->material_count + 1, sizeof *c->mats);
    c->inst_index0 = calloc(s->instance_count + 1, sizeof *c->inst_index0);
    c->inst_vertex0 = calloc(s->instance_count + 1, sizeof *c->inst_vertex0);
    c->alpha = calloc(s->mesh_count + 1, sizeof *c->alpha);
    if (!c->meshes || !c->inst || !c->mats || !c->inst_index0 || !c->inst_vertex0 || !c->alpha) {
        femb_destroy(c);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "embree: out of memory");
    }
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const tnd_mesh *me = &s->meshes[m];
        if (!me->triangle_count)
            continue;
        RTCGeometry g = rtcNewGeometry(c->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        /* new buffers carry Embree's padding after the last vertex */
        float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                            3 * sizeof(float), me->vertex_count);
        uint32_t *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                               3 * sizeof(uint32_t), me->triangle_count);
        if (!vb || !ib) {
            rtcReleaseGeometry(g);
            femb_destroy(c);
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "embree: mesh '%s': out of memory", me->name);
        }
        memcpy(vb, s->positions + 3 * (size_t)me->first_vertex,
               (size_t)me->vertex_count * 3 * sizeof(float));
        memcpy(ib, s->indices + me->first_index, (size_t)me->triangle_count * 3 * sizeof(uint32_t));
        if (s->materials[me->material].alpha_test) {
            c->alpha[m] = (femb_alpha_geom){s, m};
            rtcSetGeometryUserData(g, &c->alpha[m]);
            rtcSetGeometryIntersectFilterFunction(g, alpha_filter);
            rtcSetGeometryOccludedFilterFunction(g, alpha_filter);
        }
        rtcCommitGeometry(g);
        c->meshes[m] = rtcNewScene(c->device);
        rtcSetSceneBuildQuality(c->meshes[m], RTC_BUILD_QUALITY_HIGH);
        rtcAttachGeometryByID(c->meshes[m], g, 0);
        rtcReleaseGeometry(g);
        rtcCommitScene(c->meshes[m]);
    }
    /* the geometry loop's offsets are signed 32-bit (gathers): 3 x vertices, the index count and
     * 12 x instances must fit */
    if ((uint64_t)s->vertex_count * 3 > INT32_MAX || s->index_count > INT32_MAX - 3 ||
        (uint64_t)s->instance_count * 12 > INT32_MAX) {
        tnd_result r = tnd_fail(TND_ERR_UNSUPPORTED,
                                "embree: %s: %u vertices, %u indices, %u instances: more than the "
                                "front-end addresses (715,827,882 vertices, 2^31 indices, "
                                "178,956,970 instances)",
                                s->path, s->vertex_count, s->index_count, s->instance_count);
        femb_destroy(c);
        return r;
    }
    static const int32_t zero_indices[3] = {0, 0, 0};
    static const float zero_vertex[3] = {0, 0, 0};
    bool geometry = s->index_count >= 3 && s->vertex_count > 0;
    c->g_indices = geometry ? (const int32_t *)s->indices : zero_indices;
    c->g_positions = geometry ? s->positions : zero_vertex;
    c->g_normals = geometry ? s->normals : zero_vertex;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const tnd_mesh *me = &s->meshes[s->instances[i].mesh];
        c->inst_index0[i] = (int32_t)me->first_index;
        c->inst_vertex0[i] = (int32_t)me->first_vertex;
        c->inst[i] = (femb_inst){me->material, s->materials[me->material].specular, false};
    }
    for (uint32_t m = 0; m < s->material_count; m++) {
        const tnd_material *mat = &s->materials[m];
        femb_mat *r = &c->mats[m];
        tnd_material_sigma(mat, r->sigma);
        for (int k = 0; k < 3; k++) {
            r->base[k] = mat->base_color[k];
            r->emission[k] = mat->emission[k];
        }
        r->metallic = mat->metallic;
        r->roughness = mat->roughness;
        r->specular = mat->specular;
        r->ior = mat->ior > 0 ? mat->ior : 1.5f;
        r->kind = (uint32_t)mat->kind;
        r->textured = mat->tex_base_color >= 0 || mat->tex_metal_rough >= 0 ||
                      mat->tex_emission >= 0 || mat->tex_normal >= 0;
        r->two_sided = mat->double_sided;
    }
    c->top = rtcNewScene(c->device);
    rtcSetSceneFlags(c->top, RTC_SCENE_FLAG_DYNAMIC);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        RTCGeometry g = rtcNewGeometry(c->device, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(g, c->meshes[s->instances[i].mesh]);
        rtcAttachGeometryByID(c->top, g, i);
        rtcReleaseGeometry(g);
    }
    if (c->error[0]) {
        tnd_result r = tnd_fail(TND_ERR_UNSUPPORTED, "embree: %s: %s", s->path, c->error);
        femb_destroy(c);
        return r;
    }
    tnd_result res = femb_pool_start(c);
    if (res != TND_OK) {
        femb_destroy(c);
        return res;
    }
    *out = c;
    return TND_OK;
}

tnd_result femb_set_frame(femb_context *c, const tnd_scene_state *cur,
                          const tnd_scene_state *prev, uint32_t frame, uint32_t width,
                          uint32_t height)
{
    const tnd_scene *s = c->scene;
    c->cur = cur;
    c->prev = prev ? prev : cur;
    c->frame = frame;
    c->width = width;
    c->height = height;
    tnd_jitter(frame, c->jitter);
    c->any_moved = false;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        RTCGeometry g = rtcGetGeometry(c->top, i);
        rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, cur->instance_xform + 12 * i);
        rtcCommitGeometry(g);
        c->inst[i].moved = memcmp(cur->instance_xform + 12 * i,
                                  c->prev->instance_xform + 12 * i, 12 * sizeof(float)) != 0;
        c->any_moved |= c->inst[i].moved;
    }
    rtcCommitScene(c->top);
    if (c->error[0])
        return tnd_fail(TND_ERR_UNSUPPORTED, "embree: %s: %s", s->path, c->error);
    tnd_mat4_inverse(cur->camera.proj, c->inv_proj);
    tnd_mat4_inverse(cur->camera.view, c->inv_view);
    float ipv[16];
    tnd_mat4_inverse(c->prev->camera.view, ipv);
    for (int k = 0; k < 3; k++) {
        c->cam_pos[k] = c->inv_view[12 + k];
        c->prev_cam_pos[k] = ipv[12 + k];
    }
    /* vertical field of view from the projection: proj[5] = -1 / tan(yfov / 2) */
    double tan_half = 1.0 / fabs((double)cur->camera.proj[5]);
    /* (the ray cones' spread: the pixel's angle, or the shown pixel's where upscaled) */
    c->pixel_spread = (float)(2.0 * tan_half / height * c->footprint_scale);
    tnd_result res = tnd_lights_build(s, cur, &c->lights);
    c->select_lights = c->lights.count <= FEMB_SELECT_LIGHTS && !c->lights.node_count;
    c->triangle_lights_only = true;
    for (uint32_t i = 0; i < c->lights.count; i++)
        c->triangle_lights_only &= (uint32_t)c->lights.lights[i].p0.w == TND_LIGHT_KIND_TRIANGLE;
    return res;
}

/* (out of line and cold: the inline casts stay lean when no log is attached) */
__attribute__((noinline, cold)) void femb_log_ray(femb_ray_log *log, v3 org, v3 dir, float tmax,
                                                 uint32_t occlusion)
{
    pthread_mutex_lock(&log->lock);
    if (log->count == log->cap) {
        size_t cap = log->cap ? log->cap * 2 : 1 << 16;
        femb_ray *n = realloc(log->rays, cap * sizeof *n);
        if (!n) {
            pthread_mutex_unlock(&log->lock);
            return; /* the benchmark notices the short log */
        }
        log->rays = n;
        log->cap = cap;
    }
    log->rays[log->count++] = (femb_ray){{org.x, org.y, org.z}, {dir.x, dir.y, dir.z}, tmax,
                                         occlusion};
    pthread_mutex_unlock(&log->lock);
}

/* 3x4 row-major transform */
static inline v3 xf_point(const float *x, const float *p)
{
    return (v3){x[0] * p[0] + x[1] * p[1] + x[2] * p[2] + x[3],
                x[4] * p[0] + x[5] * p[1] + x[6] * p[2] + x[7],
                x[8] * p[0] + x[9] * p[1] + x[10] * p[2] + x[11]};
}
static inline v3 xf_dir(const float *x, v3 d)
{
    return (v3){x[0] * d.x + x[1] * d.y + x[2] * d.z, x[4] * d.x + x[5] * d.y + x[6] * d.z,
                x[8] * d.x + x[9] * d.y + x[10] * d.z};
}
/* normal transform: inverse transpose of the 3x3 = its cofactor matrix C / det; C's rows are
 * r1 x r2, r2 x r0, r0 x r1 (r_i the rows), and n' = C n (up to a positive scale when the
 * determinant is positive; the sign is fixed by facing the viewer anyway). For a rotation C = R. */
static inline v3 xf_normal(const float *x, v3 n)
{
    v3 r0 = {x[0], x[1], x[2]}, r1 = {x[4], x[5], x[6]}, r2 = {x[8], x[9], x[10]};
    v3 c0 = cross(r1, r2), c1 = cross(r2, r0), c2 = cross(r0, r1);
    return (v3){dot(c0, n), dot(c1, n), dot(c2, n)};
}

enum { NL = FEMB_LANES };

/* Texture coordinates, level of detail (ray cones, Akenine-Moller et al. 2019) and the
 * material's textures for lane i of a batch whose geometry is evaluated (ng and ns facing the
 * ray); X is the instance transform, e1 and e2 the triangle's object-space edges. */
static void surface_textures(const femb_context *c, femb_surfaces *S, uint32_t i, const float *X,
                             v3 e1, v3 e2, v3 dir, float cone_width)
{
    const tnd_scene *sc = c->scene;
    const tnd_mesh *m = &sc->meshes[sc->instances[S->instance[i]].mesh];
    const tnd_material *mat = &sc->materials[m->material];
    const uint32_t *ix = sc->indices + m->first_index + 3 * S->primitive[i];
    uint32_t i0 = m->first_vertex + ix[0], i1 = m->first_vertex + ix[1], i2 = m->first_vertex + ix[2];
    float u = S->u[i], v = S->v[i], w0 = 1.0f - u - v;
    v3 ng = FEMB_LD3(S->ng, i), ns = FEMB_LD3(S->ns, i);
    /* both coordinate sets (set 1 reads set 0 where the scene has none) and their level of
     * detail before a texture's transform */
    float tuv[2][2], lod_set[2] = {0.0f, 0.0f};
    v3 we1 = xf_dir(X, e1), we2 = xf_dir(X, e2);
    float world_area = sqrtf(dot(cross(we1, we2), cross(we1, we2)));
    float cosv = fabsf(dot(ng, dir));
    for (int set = 0; set < 2; set++) {
        const float *uvs = set && sc->uvs1 ? sc->uvs1 : sc->uvs;
        const float *t0 = uvs + 2 * (size_t)i0, *t1 = uvs + 2 * (size_t)i1,
                    *t2 = uvs + 2 * (size_t)i2;
        tuv[set][0] = w0 * t0[0] + u * t1[0] + v * t2[0];
        tuv[set][1] = w0 * t0[1] + u * t1[1] + v * t2[1];
        float uv_area =
            fabsf((t1[0] - t0[0]) * (t2[1] - t0[1]) - (t2[0] - t0[0]) * (t1[1] - t0[1]));
        if (uv_area > 0 && world_area > 0)
            lod_set[set] =
                log2f(cone_width / fmx(cosv, 1e-3f)) + 0.5f * log2f(uv_area / world_area);
    }
    float texel[4];
    /* texture slot k's coordinates (its set, its transform) and level of detail */
    float tu, tv, lod;
#define TEX_AT(k, t)                                                                               \
    do {                                                                                           \
        const tnd_uv_xform *x_ = &mat->uvx[k];                                                     \
        uint32_t s_ = x_->set ? 1 : 0;                                                             \
        tnd_uv_apply(x_, tuv[s_][0], tuv[s_][1], &tu, &tv);                                        \
        lod = lod_set[s_] + x_->lod_shift +                                                 \
              0.5f * log2f((float)(t)->width * (float)(t)->height);                                \
    } while (0)
    if (mat->tex_base_color >= 0) {
        const tnd_texture *t = &sc->textures[mat->tex_base_color];
        TEX_AT(TND_TEX_BASE, t);
        tnd_texture_sample(t, tu, tv, lod, texel);
        for (int k = 0; k < 3; k++)
            S->base[k][i] *= texel[k];
    }
    if (mat->tex_metal_rough >= 0) {
        const tnd_texture *t = &sc->textures[mat->tex_metal_rough];
        TEX_AT(TND_TEX_METAL_ROUGH, t);
        tnd_texture_sample(t, tu, tv, lod, texel);
        S->roughness[i] *= texel[1];
        S->metallic[i] *= texel[2];
    }
    if (mat->tex_emission >= 0) {
        const tnd_texture *t = &sc->textures[mat->tex_emission];
        TEX_AT(TND_TEX_EMISSION, t);
        tnd_texture_sample(t, tu, tv, lod, texel);
        for (int k = 0; k < 3; k++)
            S->emission[k][i] *= texel[k];
    }
    if (mat->tex_normal >= 0) {
        const tnd_texture *t = &sc->textures[mat->tex_normal];
        TEX_AT(TND_TEX_NORMAL, t);
        tnd_texture_sample(t, tu, tv, lod, texel);
        const float *tg0 = sc->tangents + 4 * (size_t)i0;
        v3 T = {w0 * tg0[0] + u * sc->tangents[4 * (size_t)i1] + v * sc->tangents[4 * (size_t)i2],
                w0 * tg0[1] + u * sc->tangents[4 * (size_t)i1 + 1] + v * sc->tangents[4 * (size_t)i2 + 1],
                w0 * tg0[2] + u * sc->tangents[4 * (size_t)i1 + 2] + v * sc->tangents[4 * (size_t)i2 + 2]};
        T = xf_dir(X, T);
        T = norm(sub(T, mul(ns, dot(ns, T)))); /* Gram-Schmidt against the shading normal */
        v3 B = mul(cross(ns, T), tg0[3] < 0 ? -1.0f : 1.0f);
        float mx = (2 * texel[0] - 1) * mat->normal_scale, my = (2 * texel[1] - 1) * mat->normal_scale;
        float mz = 2 * texel[2] - 1;
        v3 nm = norm(add(add(mul(T, mx), mul(B, my)), mul(ns, mz)));
        if (dot(T, T) > 0.5f && dot(nm, nm) > 0.5f)
            FEMB_ST3(S->ns, i, nm);
    }
#undef TEX_AT
}

/* femb_surface_eval_batch and femb_surface_eval_eye: `eye` (a constant in each) tells whether
 * the directions and cone widths are given or follow from the camera to each point. */
static inline __attribute__((always_inline)) void
surface_eval(const femb_context *c, bool eye, uint32_t n, const uint8_t *active,
             const uint32_t *instance, const uint32_t *primitive, const float *u, const float *v,
             const float dir_in[3][FEMB_LANES], const float *cone_in, femb_surfaces *S,
             float *depth, float rel[3][FEMB_LANES])
{
    float dir_eye[3][NL], cone_eye[NL];
    const float(*dir)[NL] = eye ? (const float(*)[NL])dir_eye : dir_in;
    const float *cone = eye ? cone_eye : cone_in;
    uint8_t textured[NL], two_sided[NL];
    bool any_textured = false;
    /* the lanes' materials (lane by lane); an inactive lane is black and opaque (its S is
     * unspecified, but defined: the lane loops after this one compute on it and discard it) */
    for (uint32_t i = 0; i < n; i++) {
        if (!active[i]) {
            textured[i] = two_sided[i] = 0;
            S->kind[i] = TND_KIND_OPAQUE;
            for (int k = 0; k < 3; k++)
                S->base[k][i] = S->emission[k][i] = 0.0f;
            S->metallic[i] = S->roughness[i] = S->specular[i] = 0.0f;
            continue;
        }
        const femb_mat *mat = &c->mats[c->inst[instance[i]].material];
        for (int k = 0; k < 3; k++) {
            S->base[k][i] = mat->base[k];
            S->emission[k][i] = mat->emission[k];
        }
        if (c->specular) { /* (glass only: femb_surface_get reads them for other kinds) */
            for (int k = 0; k < 3; k++)
                S->sigma[k][i] = mat->sigma[k];
            S->ior[i] = mat->ior;
        }
        S->metallic[i] = mat->metallic;
        S->roughness[i] = mat->roughness;
        S->specular[i] = mat->specular;
        S->kind[i] = mat->kind;
        textured[i] = mat->textured;
        two_sided[i] = mat->two_sided;
        any_textured |= mat->textured;
    }
    FEMB_LANES_LOOP(i, n) {
        S->instance[i] = instance[i];
        S->primitive[i] = primitive[i];
    }
    /* the offsets of each lane's vertices and transform; an inactive lane reads the scene's
     * first index (a triangle whatever its vertices, or the zero triangle) and transform */
    int32_t vo[3][NL], xo[NL];
    const int32_t *gi = c->g_indices, *i0 = c->inst_index0, *v0 = c->inst_vertex0;
    FEMB_LANES_LOOP(i, n) {
        int32_t in = active[i] ? (int32_t)instance[i] : 0;
        int32_t ib = active[i] ? i0[in] + 3 * (int32_t)primitive[i] : 0;
        int32_t vb = active[i] ? v0[in] : 0;
        for (int a = 0; a < 3; a++)
            vo[a][i] = 3 * (vb + gi[ib + a]);
        xo[i] = 12 * in;
    }
    /* geometry: position, normals facing the ray (vertices, normals and transforms loaded by
     * lane: gathers) */
    const float *gp = c->g_positions, *gn = c->g_normals;
    static const float no_xform[12];
    const float *xf = c->scene->instance_count ? c->cur->instance_xform : no_xform;
    FEMB_LANES_LOOP(i, n) {
        float x[12];
        for (int r = 0; r < 12; r++)
            x[r] = xf[xo[i] + r];
        float uu = u[i], vv = v[i], w0 = 1.0f - uu - vv;
        v3 p0 = {gp[vo[0][i]], gp[vo[0][i] + 1], gp[vo[0][i] + 2]};
        v3 p1 = {gp[vo[1][i]], gp[vo[1][i] + 1], gp[vo[1][i] + 2]};
        v3 p2 = {gp[vo[2][i]], gp[vo[2][i] + 1], gp[vo[2][i] + 2]};
        v3 n0 = {gn[vo[0][i]], gn[vo[0][i] + 1], gn[vo[0][i] + 2]};
        v3 n1 = {gn[vo[1][i]], gn[vo[1][i] + 1], gn[vo[1][i] + 2]};
        v3 n2 = {gn[vo[2][i]], gn[vo[2][i] + 1], gn[vo[2][i] + 2]};
        v3 obj = add(add(mul(p0, w0), mul(p1, uu)), mul(p2, vv));
        float o[3] = {obj.x, obj.y, obj.z};
        v3 e1 = sub(p1, p0), e2 = sub(p2, p0);
        v3 ng = norm(xf_normal(x, cross(e1, e2)));
        v3 ns = add(add(mul(n0, w0), mul(n1, uu)), mul(n2, vv));
        ns = sel3(dot(ns, ns) > 1e-20f, norm(xf_normal(x, ns)), ng);
        v3 p = xf_point(x, o);
        if (eye) { /* the direction from the eye and the distance (femb_xf_point_rel) */
            v3 d = femb_xf_point_rel(x, o, c->cam_pos);
            FEMB_ST3(rel, i, d);
            depth[i] = sqrtf(dot(d, d));
            FEMB_ST3(dir_eye, i, norm(d));
            cone_eye[i] = depth[i] * c->pixel_spread;
        }
        v3 wo = mul(FEMB_LD3(dir, i), -1.0f);
        bool front = dot(ng, wo) >= 0.0f;
        if (eye) /* (motion vectors: the primary pass's only) */
            FEMB_ST3(S->obj, i, obj);
        FEMB_ST3(S->p, i, p);
        FEMB_ST3(S->ng, i, sel3(front, ng, mul(ng, -1.0f)));
        FEMB_ST3(S->ns, i, sel3(front, ns, mul(ns, -1.0f)));
        FEMB_ST3(S->wo, i, wo);
        S->front[i] = front;
        S->u[i] = uu;
        S->v[i] = vv;
    }
    for (uint32_t i = 0; i < n && any_textured; i++)
        if (active[i] && textured[i]) { /* (the triangle's vertices loaded again) */
            const float *q0 = gp + vo[0][i], *q1 = gp + vo[1][i], *q2 = gp + vo[2][i];
            v3 p0 = {q0[0], q0[1], q0[2]};
            surface_textures(c, S, i, xf + xo[i], sub((v3){q1[0], q1[1], q1[2]}, p0),
                             sub((v3){q2[0], q2[1], q2[2]}, p0), FEMB_LD3(dir, i), cone[i]);
        }
    FEMB_LANES_LOOP(i, n) {
        /* a normal-mapped or interpolated normal facing away: the geometric one */
        v3 ns = FEMB_LD3(S->ns, i);
        FEMB_ST3(S->ns, i, sel3(dot(ns, FEMB_LD3(S->wo, i)) <= 1e-4f, FEMB_LD3(S->ng, i), ns));
        bool lit = S->front[i] | two_sided[i]; /* a one-sided emitter is dark from behind */
        for (int k = 0; k < 3; k++) {
            S->emission[k][i] = lit ? S->emission[k][i] : 0.0f;
            S->base[k][i] = fmn(fmx(S->base[k][i], 0.0f), 1.0f);
        }
        S->metallic[i] = fmn(fmx(S->metallic[i], 0.0f), 1.0f);
        S->roughness[i] = fmn(fmx(S->roughness[i], 0.0f), 1.0f);
    }
}

FEMB_LANE_FN void femb_surface_eval_batch(const femb_context *c, uint32_t n, const uint8_t *active,
                                          const uint32_t *instance, const uint32_t *primitive,
                                          const float *u, const float *v,
                                          const float dir[3][FEMB_LANES], const float *cone,
                                          femb_surfaces *S)
{
    surface_eval(c, false, n, active, instance, primitive, u, v, dir, cone, S, NULL, NULL);
}

FEMB_LANE_FN void femb_surface_eval_eye(const femb_context *c, uint32_t n, const uint8_t *active,
                                        const uint32_t *instance, const uint32_t *primitive,
                                        const float *u, const float *v, femb_surfaces *S,
                                        float *depth, float rel[3][FEMB_LANES])
{
    surface_eval(c, true, n, active, instance, primitive, u, v, NULL, NULL, S, depth, rel);
}

void femb_surface_get(const femb_surfaces *S, uint32_t i, femb_surface *s)
{
    s->p = FEMB_LD3(S->p, i);
    s->ng = FEMB_LD3(S->ng, i);
    s->ns = FEMB_LD3(S->ns, i);
    s->wo = FEMB_LD3(S->wo, i);
    bool opaque = S->kind[i] == TND_KIND_OPAQUE; /* (sigma and ior are set for glass only) */
    for (int k = 0; k < 3; k++) {
        s->base[k] = S->base[k][i];
        s->emission[k] = S->emission[k][i];
        s->sigma[k] = opaque ? 0.0f : S->sigma[k][i];
    }
    s->metallic = S->metallic[i];
    s->roughness = S->roughness[i];
    s->specular = S->specular[i];
    s->instance = S->instance[i];
    s->primitive = S->primitive[i];
    s->u = S->u[i];
    s->v = S->v[i];
    s->kind = S->kind[i];
    s->ior = opaque ? 1.0f : S->ior[i];
    s->front = S->front[i];
}

void femb_surface_eval(const femb_context *c, uint32_t instance, uint32_t primitive, float u,
                       float v, v3 dir, float cone_width, femb_surface *s)
{
    static const uint8_t one = 1;
    femb_surfaces S;
    float d[3][FEMB_LANES];
    FEMB_ST3(d, 0, dir);
    femb_surface_eval_batch(c, 1, &one, &instance, &primitive, &u, &v, d, &cone_width, &S);
    femb_surface_get(&S, 0, s);
}

/* ---- tiles over threads: a range over tile indices ------------------------------------------ */
enum { TILE_W = 64, TILE_H = 4 }; /* rows of 64: a batch; the G-buffer planes written in runs */

typedef struct tile_job {
    void (*fn)(femb_context *, uint32_t, uint32_t, uint32_t, uint32_t, void *);
    void *user;
    uint32_t tiles_x;
} tile_job;

static void run_tiles(femb_context *c, size_t begin, size_t end, void *user)
{
    const tile_job *j = user;
    for (size_t t = begin; t < end; t++) {
        uint32_t x0 = (uint32_t)(t % j->tiles_x) * TILE_W, y0 = (uint32_t)(t / j->tiles_x) * TILE_H;
        uint32_t x1 = x0 + TILE_W < c->width ? x0 + TILE_W : c->width;
        uint32_t y1 = y0 + TILE_H < c->height ? y0 + TILE_H : c->height;
        j->fn(c, x0, y0, x1, y1, j->user);
    }
}

void femb_parallel_tiles(femb_context *c,
                         void (*fn)(femb_context *, uint32_t, uint32_t, uint32_t, uint32_t, void *),
                         void *user)
{
    tile_job j = {fn, user, (c->width + TILE_W - 1) / TILE_W};
    femb_parallel_range(c, (size_t)j.tiles_x * ((c->height + TILE_H - 1) / TILE_H), 1, run_tiles,
                        &j);
}

/* ---- ranges over threads: a pool started with the context ------------------------------------ */
/* The workers wait on `wake` for a new generation, take chunks of the posted job until it is
 * exhausted, and the last one out signals `done`; the calling thread takes chunks too. */
typedef struct range_job {
    femb_context *c;
    void (*fn)(femb_context *, size_t, size_t, void *);
    void *user;
    atomic_size_t next;
    size_t count, chunk;
} range_job;

struct femb_pool {
    pthread_mutex_t lock;
    pthread_cond_t wake, done;
    pthread_t *threads;
    uint32_t started;
    uint64_t generation; /* of the posted job */
    uint32_t busy;       /* workers still on it */
    bool quit;
    range_job *job;
};

static void run_chunks(range_job *j)
{
    for (;;) {
        size_t b = atomic_fetch_add(&j->next, j->chunk);
        if (b >= j->count)
            break;
        j->fn(j->c, b, b + j->chunk < j->count ? b + j->chunk : j->count, j->user);
    }
    femb_stream_fence(); /* this thread's streaming stores visible before the job counts done */
}

static void *pool_worker(void *arg)
{
    femb_pool *p = arg;
#ifdef FEMB_HAVE_SSE
    _mm_setcsr(_mm_getcsr() | 0x8040); /* FTZ and DAZ, for the worker's life */
#endif
    uint64_t seen = 0;
    pthread_mutex_lock(&p->lock);
    for (;;) {
        while (p->generation == seen && !p->quit)
            pthread_cond_wait(&p->wake, &p->lock);
        if (p->quit)
            break;
        seen = p->generation;
        range_job *j = p->job;
        pthread_mutex_unlock(&p->lock);
        run_chunks(j);
        pthread_mutex_lock(&p->lock);
        if (--p->busy == 0)
            pthread_cond_signal(&p->done);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

tnd_result femb_pool_start(femb_context *c)
{
    femb_pool *p = calloc(1, sizeof *p);
    uint32_t n = c->threads > 1 ? c->threads - 1 : 0;
    if (n > 255)
        n = 255; /* (as many as the old per-call loop started) */
    if (!p || !(p->threads = calloc(n + 1, sizeof *p->threads))) {
        free(p);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "embree: out of memory");
    }
    pthread_mutex_init(&p->lock, NULL);
    pthread_cond_init(&p->wake, NULL);
    pthread_cond_init(&p->done, NULL);
    c->pool = p;
    for (uint32_t i = 0; i < n; i++)
        if (pthread_create(&p->threads[p->started], NULL, pool_worker, p) == 0)
            p->started++; /* (fewer workers only slow it down: the caller takes chunks too) */
    return TND_OK;
}

void femb_pool_stop(femb_context *c)
{
    femb_pool *p = c->pool;
    if (!p)
        return;
    pthread_mutex_lock(&p->lock);
    p->quit = true;
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->lock);
    for (uint32_t i = 0; i < p->started; i++)
        pthread_join(p->threads[i], NULL);
    pthread_cond_destroy(&p->wake);
    pthread_cond_destroy(&p->done);
    pthread_mutex_destroy(&p->lock);
    free(p->threads);
    free(p);
    c->pool = NULL;
}

void femb_parallel_range(femb_context *c, size_t count, size_t chunk,
                         void (*fn)(femb_context *, size_t, size_t, void *), void *user)
{
    range_job j = {.c = c, .fn = fn, .user = user, .count = count, .chunk = chunk ? chunk : 1};
    atomic_init(&j.next, 0);
    femb_pool *p = c->pool;
#ifdef FEMB_HAVE_SSE
    unsigned csr = _mm_getcsr();
    _mm_setcsr(csr | 0x8040);
#endif
    if (p && p->started) {
        pthread_mutex_lock(&p->lock);
        p->job = &j;
        p->busy = p->started;
        p->generation++;
        pthread_cond_broadcast(&p->wake);
        pthread_mutex_unlock(&p->lock);
    }
    run_chunks(&j);
    if (p && p->started) { /* the job lives on this stack: wait until no worker holds it */
        pthread_mutex_lock(&p->lock);
        while (p->busy)
            pthread_cond_wait(&p->done, &p->lock);
        pthread_mutex_unlock(&p->lock);
    }
#ifdef FEMB_HAVE_SSE
    _mm_setcsr(csr);
#endif
}
