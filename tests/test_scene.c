/* tests/test_scene.c: every shipped scene imports with the expected contents; animation, light
 * schedules and cameras evaluate to the authored values; the stress generator; the light pick
 * against a linear scan; and every kind of bad input gets a message naming the file and the
 * element. Label: unit. */
#include "core/core.h"
#include "tests/tnd_test.h"

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include <cjson/cJSON.h>
#include <unistd.h>

#define SCENES TND_SOURCE_DIR "/data/scenes/"

typedef struct expect {
    const char *name;
    uint64_t triangles;
    uint32_t instances, opaque, mirror, thin_glass, glass, textures;
    uint32_t point, spot, directional, area_triangles, cameras;
    float duration;
    uint32_t features;
} expect;

static uint32_t kind_count(const tnd_scene *s, tnd_material_kind k)
{
    uint32_t n = 0;
    for (uint32_t m = 0; m < s->material_count; m++) {
        bool used = false;
        for (uint32_t i = 0; i < s->instance_count; i++)
            used |= s->meshes[s->instances[i].mesh].material == m;
        n += used && s->materials[m].kind == k;
    }
    return n;
}

static uint32_t light_count(const tnd_scene *s, tnd_light_type t)
{
    uint32_t n = 0;
    for (uint32_t l = 0; l < s->light_count; l++)
        n += s->lights[l].type == t;
    return n;
}

static void test_shipped_scenes(void)
{
    /* Counts follow from scripts/make_scenes.py: a quad is 2 triangles, a box 12, a 32x16 sphere
     * 960, a 24x12 sphere 528. */
    const expect ex[] = {
        {"cornell", 36, 8, 4, 0, 0, 0, 0, 0, 0, 0, 2, 1, 4.0f,
         TND_FEATURE(LIGHT_AREA) | TND_FEATURE(ANIMATED_CAMERA)},
        {"materials", 2 + 2 + 2 + 5 * 960 + 2 + 12 + 2, 11, 7, 2, 1, 1, 3, 1, 1, 0, 2, 1, 6.0f,
         TND_FEATURE(LIGHT_POINT) | TND_FEATURE(LIGHT_SPOT) | TND_FEATURE(LIGHT_AREA) |
             TND_FEATURE(TEXTURES) | TND_FEATURE(NORMAL_MAPS) | TND_FEATURE(MIRROR) |
             TND_FEATURE(GLASS) | TND_FEATURE(THIN_GLASS) | TND_FEATURE(SPLIT) |
             TND_FEATURE(ANIMATED_CAMERA)},
        {"dynamic", 2 * 4 + 12 * 2, 6, 5, 0, 0, 0, 0, 1, 0, 0, 2, 1, 4.0f,
         TND_FEATURE(LIGHT_POINT) | TND_FEATURE(LIGHT_AREA) | TND_FEATURE(ANIMATED_CAMERA) |
             TND_FEATURE(ANIMATED_OBJECTS) | TND_FEATURE(LIGHT_SCHEDULE)},
        {"sun", 2 + 6 * 12 + 12 + 12, 9, 3, 0, 0, 0, 0, 0, 0, 1, 0, 1, 6.0f,
         TND_FEATURE(LIGHT_DIRECTIONAL) | TND_FEATURE(SKY) | TND_FEATURE(ANIMATED_CAMERA)},
        {"extremes", 2 + 4 * 528 + 2 + 2, 7, 6, 1, 0, 0, 0, 2, 0, 0, 4, 1, 2.0f,
         TND_FEATURE(LIGHT_POINT) | TND_FEATURE(LIGHT_AREA) | TND_FEATURE(MIRROR) |
             TND_FEATURE(ANIMATED_CAMERA)},
        {"cutout", 2 + 12 + 12 + 2 + 2 * 2, 6, 5, 0, 0, 0, 2, 0, 0, 1, 0, 1, 0.0f,
         TND_FEATURE(LIGHT_DIRECTIONAL) | TND_FEATURE(SKY) | TND_FEATURE(TEXTURES) |
             TND_FEATURE(ALPHA)},
    };
    for (size_t k = 0; k < sizeof ex / sizeof *ex; k++) {
        const expect *e = &ex[k];
        char path[512];
        snprintf(path, sizeof path, SCENES "%s.gltf", e->name);
        tnd_scene *s = NULL;
        tnd_result r = tnd_scene_load(path, &s);
        CHECK(r == TND_OK, "%s: %s", e->name, tnd_error_detail());
        if (r != TND_OK)
            continue;
        CHECK(tnd_scene_triangles(s) == e->triangles, "%s: %llu triangles, expected %llu", e->name,
              (unsigned long long)tnd_scene_triangles(s), (unsigned long long)e->triangles);
        CHECK(s->instance_count == e->instances, "%s: %u instances", e->name, s->instance_count);
        CHECK(kind_count(s, TND_MAT_OPAQUE) == e->opaque &&
                  kind_count(s, TND_MAT_MIRROR) == e->mirror &&
                  kind_count(s, TND_MAT_THIN_GLASS) == e->thin_glass &&
                  kind_count(s, TND_MAT_GLASS) == e->glass,
              "%s: materials by kind %u/%u/%u/%u", e->name, kind_count(s, TND_MAT_OPAQUE),
              kind_count(s, TND_MAT_MIRROR), kind_count(s, TND_MAT_THIN_GLASS),
              kind_count(s, TND_MAT_GLASS));
        CHECK(s->texture_count == e->textures, "%s: %u textures", e->name, s->texture_count);
        CHECK(light_count(s, TND_LIGHT_POINT) == e->point &&
                  light_count(s, TND_LIGHT_SPOT) == e->spot &&
                  light_count(s, TND_LIGHT_DIRECTIONAL) == e->directional,
              "%s: lights by type", e->name);
        CHECK(s->emitter_count == e->area_triangles, "%s: %u emissive triangles", e->name,
              s->emitter_count);
        CHECK(s->camera_count == e->cameras, "%s: cameras", e->name);
        CHECK_NEAR(s->duration, e->duration, 1e-6, "duration");
        CHECK(s->features == e->features, "%s: features 0x%x, expected 0x%x", e->name, s->features,
              e->features);
        for (uint32_t t = 0; t < s->texture_count; t++)
            CHECK(s->textures[t].rgba8 && s->textures[t].width > 0, "%s: texture %u decoded",
                  e->name, t);
        tnd_scene_destroy(s);
    }
}

static const tnd_material *material(const tnd_scene *s, const char *name)
{
    for (uint32_t m = 0; m < s->material_count; m++)
        if (strcmp(s->materials[m].name, name) == 0)
            return &s->materials[m];
    return NULL;
}

static const tnd_light *light(const tnd_scene *s, const char *name)
{
    for (uint32_t l = 0; l < s->light_count; l++)
        if (strcmp(s->lights[l].name, name) == 0)
            return &s->lights[l];
    return NULL;
}

/* KHR_texture_transform and texCoord on Khronos' models in Debian's assimp-testmodels:
 * TextureTransformTest's offsets, rotation and scale as the affine map T R S; boxTexcoords'
 * metal-rough texture on TEXCOORD_1, loaded beside TEXCOORD_0. */
static void test_texture_coordinates(void)
{
    const char *tt = "/usr/share/assimp/models/glTF2/textureTransform/TextureTransformTest.gltf";
    const char *bt = "/usr/share/assimp/models/glTF2/BoxTexcoords-glTF/boxTexcoords.gltf";
    if (access(tt, R_OK) != 0 || access(bt, R_OK) != 0) {
        printf("     skip: assimp-testmodels absent\n");
        return;
    }
    tnd_scene *s = NULL;
    REQUIRE_OK(tnd_scene_load(tt, &s));
    const tnd_material *ou = material(s, "Offset UV"), *ro = material(s, "Rotation"),
                       *al = material(s, "All"), *co = material(s, "Correct");
    REQUIRE(ou && ro && al && co, "materials");
    const float *m = ou->uvx[TND_TEX_BASE].m;
    CHECK(m[0] == 1 && m[1] == 0 && m[2] == 0.5f && m[3] == 0 && m[4] == 1 && m[5] == 0.5f,
          "Offset UV: %g %g %g / %g %g %g", m[0], m[1], m[2], m[3], m[4], m[5]);
    double c = cos(0.39269908169872414), sn = sin(0.39269908169872414);
    m = ro->uvx[TND_TEX_BASE].m;
    CHECK(fabs(m[0] - c) < 1e-6 && fabs(m[1] - sn) < 1e-6 && fabs(m[3] + sn) < 1e-6 &&
              fabs(m[4] - c) < 1e-6 && m[2] == 0 && m[5] == 0,
          "Rotation: %g %g %g / %g %g %g", m[0], m[1], m[2], m[3], m[4], m[5]);
    /* All: offset (-0.2, -0.1), rotation 0.3, scale 1.5: T R S */
    m = al->uvx[TND_TEX_BASE].m;
    c = cos(0.3), sn = sin(0.3);
    CHECK(fabs(m[0] - 1.5 * c) < 1e-6 && fabs(m[1] - 1.5 * sn) < 1e-6 &&
              fabs(m[2] + 0.2) < 1e-6 && fabs(m[3] + 1.5 * sn) < 1e-6 &&
              fabs(m[4] - 1.5 * c) < 1e-6 && fabs(m[5] + 0.1) < 1e-6 &&
              fabs(al->uvx[TND_TEX_BASE].lod_shift - 0.5 * log2(2.25)) < 1e-6,
          "All: %g %g %g / %g %g %g", m[0], m[1], m[2], m[3], m[4], m[5]);
    m = co->uvx[TND_TEX_BASE].m;
    CHECK(m[0] == 1 && m[4] == 1 && m[1] == 0 && m[2] == 0 && co->uvx[0].lod_shift == 0,
          "Correct: the identity");
    tnd_scene_destroy(s);
    s = NULL;
    REQUIRE_OK(tnd_scene_load(bt, &s));
    const tnd_material *bm = &s->materials[s->meshes[0].material];
    CHECK(s->uvs1 != NULL && bm->uvx[TND_TEX_BASE].set == 0 &&
              bm->uvx[TND_TEX_METAL_ROUGH].set == 1,
          "boxTexcoords: TEXCOORD_1 %s, sets %u %u", s->uvs1 ? "loaded" : "missing",
          bm->uvx[TND_TEX_BASE].set, bm->uvx[TND_TEX_METAL_ROUGH].set);
    int differ = 0;
    for (uint32_t v = 0; s->uvs1 && v < 2 * s->vertex_count; v++)
        differ += s->uvs1[v] != s->uvs[v];
    CHECK(differ > 0, "the two sets are the same");
cleanup:
    tnd_scene_destroy(s);
}

/* Values assimp drops or alters come through exactly. */
static void test_values(void)
{
    {
        /* alphaMode: MASK with its cutoff, BLEND as a cut-out at 0.5, OPAQUE without a test */
        tnd_scene *c = NULL;
        REQUIRE_OK(tnd_scene_load(SCENES "cutout.gltf", &c));
        const tnd_material *fence = material(c, "fence"), *leaf = material(c, "leaf"),
                           *ground = material(c, "ground");
        CHECK(fence && fence->alpha_test && fence->alpha_cutoff == 0.5f, "fence: MASK 0.5");
        CHECK(leaf && leaf->alpha_test && leaf->alpha_cutoff == 0.5f, "leaf: BLEND as 0.5");
        CHECK(ground && !ground->alpha_test, "ground: opaque");
        tnd_scene_destroy(c);
    }
    tnd_scene *s = NULL;
    REQUIRE_OK(tnd_scene_load(SCENES "cornell.gltf", &s));
    const tnd_material *m = material(s, "light");
    REQUIRE(m, "light material");
    CHECK_NEAR(m->emission[0], 17.0, 1e-5, "emissive x KHR_materials_emissive_strength");
    CHECK_NEAR(m->emission[1], 0.85 * 17.0, 1e-5, "emission G");
    CHECK_NEAR(s->cameras[0].yfov, 39.0 * TND_PI / 180.0, 1e-6, "camera yfov from the JSON");
    tnd_scene_destroy(s);
    s = NULL;
    REQUIRE_OK(tnd_scene_load(SCENES "materials.gltf", &s));
    const tnd_light *l = light(s, "warm_point");
    REQUIRE(l, "warm_point");
    CHECK(l->color[0] == 60.0f && l->color[1] == 48.0f && l->color[2] == 36.0f,
          "candela x colour: %g %g %g", l->color[0], l->color[1], l->color[2]);
    l = light(s, "spot");
    REQUIRE(l, "spot");
    CHECK_NEAR(l->inner_cone, 0.2, 1e-6, "inner cone");
    CHECK_NEAR(l->outer_cone, 0.35, 1e-6, "outer cone");
    m = material(s, "glass");
    REQUIRE(m, "glass");
    CHECK(m->kind == TND_MAT_GLASS && m->ior == 1.5f && m->transmission == 1.0f,
          "glass: kind %d ior %g", m->kind, m->ior);
    CHECK_NEAR(m->thickness, 0.8, 1e-6, "volume thickness");
    CHECK_NEAR(m->attenuation_distance, 2.0, 1e-6, "attenuation distance");
    CHECK_NEAR(m->attenuation_color[1], 0.95, 1e-6, "attenuation colour");
    m = material(s, "textured_metal");
    REQUIRE(m, "textured_metal");
    CHECK(m->tex_metal_rough >= 0 && m->tex_normal >= 0 && m->tex_base_color < 0,
          "metallicRoughness and normal textures");
    CHECK(!s->textures[m->tex_normal].srgb, "normal maps are linear");
    m = material(s, "checker_floor");
    REQUIRE(m && m->tex_base_color >= 0, "checker texture");
    const tnd_texture *t = &s->textures[m->tex_base_color];
    CHECK(t->srgb && t->width == 64 && t->height == 64, "base colour texture 64x64 sRGB");
    /* texel (0,0) is dark (60,60,70), texel (8,0) light (200) */
    CHECK(t->rgba8[0] == 60 && t->rgba8[2] == 70 && t->rgba8[4 * 8] == 200, "texels decoded");
cleanup:
    tnd_scene_destroy(s);
}

static void test_animation(void)
{
    tnd_scene *s = NULL;
    tnd_scene_state st = {0};
    REQUIRE_OK(tnd_scene_load(SCENES "dynamic.gltf", &s));
    uint32_t cube = UINT32_MAX;
    for (uint32_t i = 0; i < s->instance_count; i++)
        if (strcmp(s->meshes[s->instances[i].mesh].name, "moving_cube") == 0)
            cube = i;
    REQUIRE(cube != UINT32_MAX, "moving cube");
    CHECK(s->instances[cube].animated, "cube is animated");
    REQUIRE_OK(tnd_scene_evaluate(s, 2.0, 0, 16.0f / 9.0f, &st));
    const float *x = st.instance_xform + 12 * cube;
    CHECK_NEAR(x[3], 2.0, 1e-5, "cube x at its key");
    CHECK_NEAR(x[7], 0.25, 1e-5, "cube y");
    CHECK_NEAR(x[11], -1.2, 1e-5, "cube z");
    REQUIRE_OK(tnd_scene_evaluate(s, 1.0, 0, 16.0f / 9.0f, &st));
    CHECK_NEAR(st.instance_xform[12 * cube + 3], 0.25, 1e-5, "linear halfway (-1.5 .. 2.0)");
    /* the schedule: off from frame 30, on again from frame 60 (30 fps) */
    const tnd_light *l = light(s, "switched_lamp");
    REQUIRE(l, "switched lamp");
    uint32_t li = (uint32_t)(l - s->lights);
    const int frames[] = {0, 29, 30, 45, 59, 60, 90};
    const float scales[] = {1, 1, 0, 0, 0, 1, 1};
    for (int k = 0; k < 7; k++) {
        REQUIRE_OK(tnd_scene_evaluate(s, frames[k] / 30.0, 0, 1.0f, &st));
        CHECK(st.light_scale[li] == scales[k], "frame %d: scale %g, expected %g", frames[k],
              st.light_scale[li], scales[k]);
    }
    /* camera at t = 0: authored at (-0.5, 1.5, 4.5) */
    REQUIRE_OK(tnd_scene_evaluate(s, 0.0, 0, 16.0f / 9.0f, &st));
    CHECK_NEAR(st.camera_position[0], -0.5, 1e-5, "camera x");
    CHECK_NEAR(st.camera_position[2], 4.5, 1e-5, "camera z");
    float o[3], d[3];
    tnd_camera_ray(&st.camera, 160, 90, 80.0f, 45.0f, o, d);
    CHECK_NEAR(o[1], 1.5, 1e-5, "ray origin at the camera");
    /* yaw -5, pitch -10 degrees: the centre ray looks down and slightly to the right (-yaw) */
    CHECK_NEAR(d[1], -sin(10 * TND_PI / 180), 1e-4, "centre ray pitch");
    CHECK(d[2] < -0.9f, "looks down -Z");
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
    s = NULL;
    /* geometry 1e5 from the origin stays put */
    REQUIRE_OK(tnd_scene_load(SCENES "extremes.gltf", &s));
    REQUIRE_OK(tnd_scene_evaluate(s, 0.0, 0, 1.0f, &st));
    CHECK_NEAR(st.instance_xform[3], 1.0e5, 0.01, "far instance x");
    CHECK_NEAR(st.camera_position[0], 1.0e5, 0.01, "far camera");
cleanup:
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
}

static void test_stress(void)
{
    tnd_scene *s = NULL;
    const double wants[] = {20000, 1000000};
    for (int k = 0; k < 2; k++) {
        char spec[64];
        snprintf(spec, sizeof spec, "stress:%.0f", wants[k]);
        REQUIRE_OK(tnd_scene_load(spec, &s));
        double n = (double)tnd_scene_triangles(s);
        CHECK(fabs(n - wants[k]) / wants[k] < 0.05, "%s: %.0f triangles", spec, n);
        CHECK(s->mesh_count == 18 && s->emitter_count == 2 && s->camera_count == 1,
              "16 distinct meshes + ground + panel");
        tnd_scene_destroy(s);
        s = NULL;
    }
    CHECK(tnd_scene_load("stress:abc", &s) == TND_ERR_INVALID_ARGUMENT && !s, "bad stress spec");
    CHECK(tnd_scene_load("stress:10", &s) == TND_ERR_INVALID_ARGUMENT, "too small");
cleanup:
    tnd_scene_destroy(s);
}

/* ---- bad input ------------------------------------------------------------------------------ */
static char dir[64];

static void copy_file(const char *from, const char *to)
{
    void *d;
    size_t n;
    if (tnd_file_read(from, &d, &n) == TND_OK) {
        tnd_file_write_atomic(to, d, n);
        free(d);
    }
}

/* Byte offset in the .bin of element `elem` of the accessor for (mesh m, attribute or indices). */
static long accessor_offset(const char *gltf, int mesh, const char *attr, int elem, int elem_size)
{
    void *txt;
    size_t n;
    if (tnd_file_read(gltf, &txt, &n) != TND_OK)
        return -1;
    cJSON *j = cJSON_Parse(txt);
    free(txt);
    const cJSON *prim = cJSON_GetArrayItem(
        cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(j, "meshes"), mesh),
                            "primitives"),
        0);
    const cJSON *acc_i = attr ? cJSON_GetObjectItem(cJSON_GetObjectItem(prim, "attributes"), attr)
                              : cJSON_GetObjectItem(prim, "indices");
    const cJSON *acc = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "accessors"), acc_i->valueint);
    const cJSON *bv = cJSON_GetArrayItem(cJSON_GetObjectItem(j, "bufferViews"),
                                         cJSON_GetObjectItem(acc, "bufferView")->valueint);
    long off = cJSON_GetObjectItem(bv, "byteOffset")->valueint + (long)elem * elem_size;
    cJSON_Delete(j);
    return off;
}

static void patch_bin(const char *path, long off, const void *bytes, size_t n)
{
    void *d;
    size_t size;
    if (tnd_file_read(path, &d, &size) == TND_OK) {
        if (off >= 0 && (size_t)off + n <= size)
            memcpy((char *)d + off, bytes, n);
        tnd_file_write_atomic(path, d, size);
        free(d);
    }
}

/* Make DIR/NAME.gltf (+ .bin + textures) from a shipped scene, then let the case break it. */
static void stage(const char *scene, bool with_bin, bool with_textures)
{
    char from[512], to[512];
    snprintf(from, sizeof from, SCENES "%s.gltf", scene);
    snprintf(to, sizeof to, "%s/%s.gltf", dir, scene);
    copy_file(from, to);
    if (with_bin) {
        snprintf(from, sizeof from, SCENES "%s.bin", scene);
        snprintf(to, sizeof to, "%s/%s.bin", dir, scene);
        copy_file(from, to);
    }
    const char *tex[] = {"materials_checker.png", "materials_mr.png", "materials_normal.png"};
    for (int i = 0; with_textures && i < 3; i++) {
        snprintf(from, sizeof from, SCENES "%s", tex[i]);
        snprintf(to, sizeof to, "%s/%s", dir, tex[i]);
        copy_file(from, to);
    }
}

static void expect_error(const char *what, const char *path, const char *needle1,
                         const char *needle2)
{
    tnd_scene *s = NULL;
    tnd_result r = tnd_scene_load(path, &s);
    const char *d = tnd_error_detail();
    CHECK(r != TND_OK && s == NULL, "%s: must fail", what);
    CHECK(strstr(d, path) != NULL, "%s: message names the file: %s", what, d);
    CHECK(strstr(d, needle1) != NULL && (!needle2 || strstr(d, needle2) != NULL),
          "%s: message names the element ('%s'%s%s): %s", what, needle1, needle2 ? ", '" : "",
          needle2 ? needle2 : "", d);
    tnd_scene_destroy(s);
}

/* Load `path` with stderr captured (the warnings an import prints); returns what was printed
 * (the caller frees it; NULL when the capture failed) and the load's result in *r. */
static char *load_capturing(const char *path, tnd_result *r)
{
    char log[] = "/tmp/tandem_stderr_XXXXXX";
    int fd = mkstemp(log);
    if (fd < 0)
        return NULL;
    fflush(stderr);
    int saved = dup(2);
    dup2(fd, 2);
    tnd_scene *s = NULL;
    *r = tnd_scene_load(path, &s);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    close(fd);
    tnd_scene_destroy(s);
    void *out = NULL;
    size_t n = 0;
    char *text = NULL;
    if (tnd_file_read(log, &out, &n) == TND_OK && (text = calloc(n + 1, 1)) != NULL)
        memcpy(text, out, n);
    free(out);
    remove(log);
    return text;
}

static void write_text(const char *path, const char *text)
{
    CHECK_OK(tnd_file_write_atomic(path, text, strlen(text)));
}

static void test_bad_input(void)
{
    snprintf(dir, sizeof dir, "/tmp/tandem_scene_XXXXXX");
    REQUIRE(mkdtemp(dir), "mkdtemp");
    char p[512], bin[512];
    snprintf(p, sizeof p, "%s/cornell.gltf", dir);
    snprintf(bin, sizeof bin, "%s/cornell.bin", dir);

    /* truncated JSON */
    stage("cornell", true, false);
    void *txt;
    size_t n;
    REQUIRE_OK(tnd_file_read(p, &txt, &n));
    CHECK_OK(tnd_file_write_atomic(p, txt, n / 2));
    free(txt);
    expect_error("truncated JSON", p, "invalid glTF JSON", "truncated");

    /* missing .bin */
    remove(bin);
    stage("cornell", false, false);
    expect_error("missing .bin", p, "buffer 0", "cornell.bin");

    /* missing textures load with a named warning each and a stand-in (test_missing_images) */

    /* out-of-range index: mesh 0 ('floor'), index 1 := 999 (4 vertices) */
    stage("cornell", true, false);
    uint32_t big = 999;
    patch_bin(bin, accessor_offset(p, 0, NULL, 1, 4), &big, 4);
    expect_error("index out of range", p, "floor", "999");

    /* an index accessor's byteOffset of -1, 0.5 and 2^40 (the first read 1 byte before its
     * buffer, a heap overflow, until every such number went through one check) */
    const char *offsets[3] = {"-1", "0.5", "1099511627776"};
    for (int k = 0; k < 3; k++) {
        stage("cornell", true, false);
        void *jt = NULL;
        size_t jn = 0;
        REQUIRE_OK(tnd_file_read(p, &jt, &jn));
        cJSON *jj = cJSON_ParseWithLength(jt, jn);
        free(jt);
        REQUIRE(jj, "cornell.gltf parses");
        cJSON *prim0 = cJSON_GetArrayItem(
            cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(jj, "meshes"), 0),
                                "primitives"),
            0);
        cJSON *acc = cJSON_GetArrayItem(cJSON_GetObjectItem(jj, "accessors"),
                                        cJSON_GetObjectItem(prim0, "indices")->valueint);
        cJSON_DeleteItemFromObject(acc, "byteOffset");
        cJSON_AddItemToObject(acc, "byteOffset", cJSON_CreateRaw(offsets[k]));
        char *txt2 = cJSON_Print(jj);
        cJSON_Delete(jj);
        write_text(p, txt2);
        free(txt2);
        expect_error("byteOffset", p, "floor", "accessor");
    }

    /* NaN vertex: mesh 1 ('ceiling'), vertex 2, x */
    stage("cornell", true, false);
    float nan = NAN;
    patch_bin(bin, accessor_offset(p, 1, "POSITION", 2, 12), &nan, 4);
    expect_error("NaN vertex", p, "ceiling", "non-finite");

    /* zero-area emissive triangle: the 'light' mesh (5) with vertex 1 := vertex 0 */
    stage("cornell", true, false);
    float v0[3];
    {
        void *b;
        size_t bs;
        REQUIRE_OK(tnd_file_read(bin, &b, &bs));
        memcpy(v0, (char *)b + accessor_offset(p, 5, "POSITION", 0, 12), 12);
        free(b);
    }
    patch_bin(bin, accessor_offset(p, 5, "POSITION", 1, 12), v0, 12);
    patch_bin(bin, accessor_offset(p, 5, "POSITION", 2, 12), v0, 12);
    expect_error("zero-area emitter", p, "light", "zero area");

    /* unsupported required extension */
    stage("cornell", true, false);
    REQUIRE_OK(tnd_file_read(p, &txt, &n));
    char *patched = malloc(n + 128);
    char *brace = strchr(txt, '{');
    snprintf(patched, n + 128, "{\"extensionsRequired\": [\"KHR_draco_mesh_compression\"],%s",
             brace + 1);
    CHECK_OK(tnd_file_write_atomic(p, patched, strlen(patched)));
    free(patched);
    free(txt);
    expect_error("unsupported extension", p, "KHR_draco_mesh_compression", "not support");
    /* ... whose message lists what is supported, KHR_materials_specular among it */
    CHECK(strstr(tnd_error_detail(), "KHR_materials_specular") != NULL, "%s",
          tnd_error_detail());

    /* an alphaMode glTF does not define */
    stage("cornell", true, false);
    REQUIRE_OK(tnd_file_read(p, &txt, &n));
    patched = malloc(n + 64);
    {
        char *pbr = strstr(txt, "\"pbrMetallicRoughness\"");
        REQUIRE(pbr, "cornell has materials");
        snprintf(patched, n + 64, "%.*s\"alphaMode\": \"CUTOUT\", %s", (int)(pbr - (char *)txt),
                 (char *)txt, pbr);
    }
    CHECK_OK(tnd_file_write_atomic(p, patched, strlen(patched)));
    free(patched);
    free(txt);
    expect_error("bad alphaMode", p, "alphaMode 'CUTOUT'", "expected OPAQUE, MASK or BLEND");

    /* KHR_materials_specular, which Tandem applies, may be required, and using it draws no
     * "used but ignored" warning (stderr captured around the load) */
    stage("cornell", true, false);
    REQUIRE_OK(tnd_file_read(p, &txt, &n));
    patched = malloc(n + 160);
    brace = strchr(txt, '{');
    snprintf(patched, n + 160,
             "{\"extensionsRequired\": [\"KHR_materials_specular\"], "
             "\"extensionsUsed\": [\"KHR_materials_specular\"],%s",
             brace + 1);
    CHECK_OK(tnd_file_write_atomic(p, patched, strlen(patched)));
    free(patched);
    free(txt);
    {
        tnd_result r;
        char *text = load_capturing(p, &r);
        CHECK(r == TND_OK, "KHR_materials_specular required: %s", tnd_error_detail());
        CHECK(text && strstr(text, "KHR_materials_specular") == NULL,
              "KHR_materials_specular warned about: %s", text ? text : "(no capture)");
        free(text);
    }
cleanup:;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    CHECK(system(cmd) == 0, "cleanup");
}

/* The light tree (shaders/light_tree.h) on shipped scenes: hundreds of emitters (many_lights,
 * animated), area and punctual lights (materials), a sun and an environment map beside local
 * lights (atrium: the root's two groups). At random points in the scene's box: the probabilities
 * of all lights sum to at most 1 (the rest: descents that end at a node whose children both weigh
 * 0 where the parent's looser bounds did not: no light there can light the point); a descent's
 * probability is the one tnd_lt_pmf recomputes from the light's path; every light that can light
 * the point has a probability above 0 (the bounds are conservative: the estimator stays
 * unbiased); and at one point the picks' frequencies over 200,000 descents, and the descents
 * without a light, match their probabilities within 5 standard deviations. */
static void test_light_tree(void)
{
    static const char *const names[] = {"many_lights.gltf", "materials.gltf", "atrium.gltf"};
    uint32_t state = 62u;
    for (int sc = 0; sc < 3; sc++) {
        char path[512];
        snprintf(path, sizeof path, SCENES "%s", names[sc]);
        tnd_scene *s = NULL;
        tnd_scene_state st = {0};
        tnd_light_list l = {.want_tree = true};
        double *pm = NULL;
        uint32_t *hits = NULL;
        REQUIRE_OK(tnd_scene_load(path, &s));
        REQUIRE_OK(tnd_scene_evaluate(s, 1.0, 0, 16.0f / 9.0f, &st));
        REQUIRE_OK(tnd_lights_build(s, &st, &l));
        CHECK(l.count > 0 && l.node_count >= l.count && l.node_count <= 2 * l.count + 1,
              "%s: %u lights, %u nodes", names[sc], l.count, l.node_count);
        double lo[3], hi[3];
        tnd_scene_bounds(s, &st, lo, hi);
        pm = malloc(l.count * sizeof *pm);
        hits = calloc(l.count, sizeof *hits);
        REQUIRE(pm && hits, "out of memory");
        uint32_t bad_sum = 0, bad_pmf = 0, culled = 0, points = 0;
        double worst_sum = 0;
        for (int k = 0; k < 200; k++) {
            float p[3];
            for (int j = 0; j < 3; j++) {
                state = state * 1664525u + 1013904223u;
                p[j] = (float)(lo[j] + (hi[j] - lo[j]) * ((state >> 8) / 16777216.0));
            }
            double sum = 0;
            for (uint32_t i = 0; i < l.count; i++) {
                uint32_t trail;
                memcpy(&trail, &l.lights[i].p2.w, sizeof trail);
                pm[i] = tnd_lt_pmf(l.nodes, trail, p[0], p[1], p[2]);
                sum += pm[i];
                /* can light i light p? a point or an environment always; a one-sided triangle
                 * where p is in front of its plane (a margin for the float bounds), a two-sided
                 * one off its plane, a spot inside its outer cone, a sun always */
                const tnd_light_gpu *g = &l.lights[i];
                uint32_t kind = (uint32_t)g->p0.w;
                bool can = true;
                if (kind == TND_LIGHT_KIND_TRIANGLE) {
                    double e1[3] = {g->p1.x - g->p0.x, g->p1.y - g->p0.y, g->p1.z - g->p0.z};
                    double e2[3] = {g->p2.x - g->p0.x, g->p2.y - g->p0.y, g->p2.z - g->p0.z};
                    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                                   e1[0] * e2[1] - e1[1] * e2[0]};
                    double nl = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                    double side = (n[0] * (p[0] - g->p0.x) + n[1] * (p[1] - g->p0.y) +
                                   n[2] * (p[2] - g->p0.z)) / nl;
                    can = g->p1.w != 0.0f ? fabs(side) > 1e-4 : side > 1e-4;
                } else if (kind == TND_LIGHT_KIND_SPOT) {
                    double d[3] = {p[0] - g->p0.x, p[1] - g->p0.y, p[2] - g->p0.z};
                    double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                    can = dl > 0 && (d[0] * g->p1.x + d[1] * g->p1.y + d[2] * g->p1.z) / dl >
                                        g->p2.y + 1e-4;
                }
                culled += can && !(pm[i] > 0);
            }
            worst_sum = fmax(worst_sum, 1 - sum);
            bad_sum += sum > 1 + 1e-5 || !(sum > 0.5);
            for (int t = 0; t < 64; t++) {
                state = state * 1664525u + 1013904223u;
                float u = (state >> 8) / 16777216.0f, pmf = 0;
                uint32_t i = tnd_lt_sample(l.nodes, p[0], p[1], p[2], u, &pmf);
                bad_pmf += i == TND_LT_NONE
                               ? pmf != 0
                               : i >= l.count || fabs(pmf - pm[i]) > 1e-5 * pm[i];
            }
            if (k == 0) { /* the frequencies at the first point */
                const uint32_t N = 200000;
                uint32_t none = 0;
                for (uint32_t t = 0; t < N; t++) {
                    float pmf;
                    uint32_t i = tnd_lt_sample(l.nodes, p[0], p[1], p[2],
                                               ((float)t + 0.5f) / (float)N, &pmf);
                    if (i < l.count)
                        hits[i]++;
                    else
                        none++;
                }
                uint32_t off = 0;
                for (uint32_t i = 0; i <= l.count; i++) {
                    double q = i < l.count ? pm[i] : fmax(0.0, 1 - sum);
                    double got = i < l.count ? hits[i] : none;
                    off += fabs(got - N * q) > 5 * (sqrt(N * q * (1 - q)) + 1);
                }
                CHECK(off == 0, "%s: %u lights picked off their probability", names[sc], off);
            }
            points++;
        }
        printf("     %s: %u lights, %u nodes; over %u points the probabilities sum to at least "
               "%.3g (the rest: no light); %u lights that can light a point culled\n",
               names[sc], l.count, l.node_count, points, 1 - worst_sum, culled);
        CHECK(bad_sum == 0, "%s: %u points whose probabilities sum over 1 or under 1/2",
              names[sc], bad_sum);
        CHECK(bad_pmf == 0, "%s: %u descents whose probability is not the light's", names[sc],
              bad_pmf);
        CHECK(culled == 0, "%s: %u (point, light) pairs culled that the light can reach",
              names[sc], culled);
    cleanup:
        free(pm);
        free(hits);
        tnd_lights_free(&l);
        tnd_scene_state_free(&st);
        tnd_scene_destroy(s);
    }
}

/* tnd_lights_pick against a linear scan (the first light whose cdf exceeds u, the last when none
 * does): lists of 1 to 40 lights with random steps and runs of equal cdf values (float sums do
 * repeat), u random, on every cdf value and the floats beside it, 0, 1, negative and NaN. */
static void test_light_pick(void)
{
    uint32_t state = 12345u, bad = 0, checked = 0;
    tnd_light_gpu lights[40];
    for (uint32_t count = 1; count <= 40; count++) {
        for (int trial = 0; trial < 20; trial++) {
            float acc = 0.0f;
            for (uint32_t i = 0; i < count; i++) {
                state = state * 1664525u + 1013904223u;
                acc += (state >> 30) == 0 ? 0.0f : (float)(state >> 8) * (1.0f / 16777216.0f);
                lights[i].cdf.x = acc;
            }
            for (uint32_t i = 0; i < count; i++) /* normalised as tnd_lights_build does */
                lights[i].cdf.x = i + 1 == count ? 1.0f : lights[i].cdf.x / acc;
            tnd_light_list list = {.lights = lights, .count = count};
            float us[4 * 40 + 100];
            uint32_t nu = 0;
            for (uint32_t i = 0; i < count; i++) {
                float x = lights[i].cdf.x;
                us[nu++] = x;
                us[nu++] = nextafterf(x, 0.0f);
                us[nu++] = nextafterf(x, 2.0f);
            }
            for (int k = 0; k < 90; k++) {
                state = state * 1664525u + 1013904223u;
                us[nu++] = (float)(state >> 8) * (1.0f / 16777216.0f);
            }
            us[nu++] = 0.0f, us[nu++] = 1.0f, us[nu++] = -1.0f, us[nu++] = NAN;
            uint32_t picks[sizeof us / sizeof *us];
            tnd_lights_pick_n(&list, nu, us, picks); /* (linear up to 16 lights, then binary) */
            for (uint32_t k = 0; k < nu; k++) {
                uint32_t want = count - 1;
                for (uint32_t i = 0; i < count; i++)
                    if (lights[i].cdf.x > us[k]) {
                        want = i;
                        break;
                    }
                uint32_t got = tnd_lights_pick(&list, us[k]);
                if (got != want && bad++ < 5)
                    CHECK(false, "%u lights, u %.9g: picked %u, expected %u", count, us[k], got,
                          want);
                if (picks[k] != want && bad++ < 5)
                    CHECK(false, "%u lights, u %.9g: tnd_lights_pick_n picked %u, expected %u",
                          count, us[k], picks[k], want);
                checked++;
            }
        }
    }
    CHECK(bad == 0, "%u of %u picks differ from the linear scan", bad, checked);
}

/* A real asset without camera or light (Khronos' BoxTextured, from Debian's assimp-testmodels)
 * gets the defaults of docs/scenes.md, noted in the scene: one camera, from the stated direction,
 * that sees every vertex of the box inside the image with the stated margin, and a uniform white
 * sky. A shipped scene with its own camera and light gets neither. */
static void test_defaults(void)
{
    const char *box = "/usr/share/assimp/models/glTF2/BoxTextured-glTF/BoxTextured.gltf";
    tnd_scene *s = NULL;
    tnd_scene_state st = {0};
    if (access(box, R_OK) != 0) {
        printf("     skip: %s absent (assimp-testmodels: scripts/install-deps.sh)\n", box);
        return;
    }
    REQUIRE_OK(tnd_scene_load(box, &s));
    CHECK(s->camera_count == 1 && strstr(s->default_camera, "no camera") != NULL,
          "default camera: %u cameras, note '%s'", s->camera_count, s->default_camera);
    CHECK(s->sky[0] == TND_DEFAULT_SKY && s->sky[2] == TND_DEFAULT_SKY &&
              (s->features & TND_FEATURE(SKY)) &&
              strstr(s->default_light, "no punctual light") != NULL,
          "default light: sky %g, note '%s'", (double)s->sky[0], s->default_light);
    /* every vertex inside the image, the farthest from the centre of the view at about
     * 1 / margin of the half height (the bounding sphere, whose silhouette is a little larger
     * than the box's, fills exactly that) */
    REQUIRE_OK(tnd_scene_evaluate(s, 0, 0, 1.0f, &st));
    double worst = 0;
    for (uint32_t v = 0; v < s->vertex_count; v++) {
        float ndc[3], vp[16];
        tnd_mat4_mul(st.camera.proj, st.camera.view, vp);
        tnd_mat4_point(vp, s->positions + 3 * v, true, ndc);
        worst = fmax(worst, fmax(fabs(ndc[0]), fabs(ndc[1])));
    }
    CHECK(worst < 1.0 / TND_DEFAULT_CAMERA_MARGIN && worst > 0.6,
          "the box fills %.3f of the half image (expected under %.3f, framed)", worst,
          1.0 / TND_DEFAULT_CAMERA_MARGIN);
    /* from the stated direction: the camera sits where the note says, right of +Z and above */
    const float *cp = st.camera_position;
    double el = atan2(cp[1], sqrt((double)cp[0] * cp[0] + (double)cp[2] * cp[2])) * 180 / TND_PI;
    double az = atan2(cp[0], cp[2]) * 180 / TND_PI;
    CHECK(fabs(el - TND_DEFAULT_CAMERA_ELEVATION_DEG) < 0.01 &&
              fabs(az - TND_DEFAULT_CAMERA_AZIMUTH_DEG) < 0.01,
          "camera at azimuth %.3f, elevation %.3f", az, el);
    printf("     BoxTextured: the default camera frames it at %.3f of the half image, from "
           "azimuth %.1f, elevation %.1f degrees\n",
           worst, az, el);
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
    s = NULL;
    REQUIRE_OK(tnd_scene_load(SCENES "cornell.gltf", &s));
    CHECK(!s->default_camera[0] && !s->default_light[0], "cornell given defaults: '%s' '%s'",
          s->default_camera, s->default_light);
cleanup:
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
}

/* What real glTF files hold and Tandem does not model is named once, and the scene still loads
 * (Debian's assimp-testmodels): an orthographic camera (left out, the perspective one kept),
 * skinning, morph targets, KHR_materials_clearcoat. */
static void test_unsupported_named(void)
{
    const char *m = "/usr/share/assimp/models/glTF2/";
    const struct {
        const char *file, *needle;
    } cases[] = {{"cameras/Cameras.gltf", "orthographic"},
                 {"simple_skin/simple_skin.gltf", "skinning"},
                 {"glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf", "morph"},
                 {"ClearCoat-glTF/ClearCoatTest.gltf", "KHR_materials_clearcoat"}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char path[512];
        snprintf(path, sizeof path, "%s%s", m, cases[i].file);
        if (access(path, R_OK) != 0) {
            printf("     skip: %s absent (assimp-testmodels)\n", path);
            continue;
        }
        tnd_result r;
        char *text = load_capturing(path, &r);
        CHECK(r == TND_OK, "%s: %s", path, tnd_error_detail());
        CHECK(text && strstr(text, cases[i].needle) && strstr(text, path),
              "%s: no warning naming '%s' and the file: %s", path, cases[i].needle,
              text ? text : "(no capture)");
        free(text);
    }
}

/* The other formats assimp reads that Tandem takes (FBX, Collada, PLY, STL, 3DS: Debian's
 * assimp-testmodels), through the MTL conversion: every file imports or is refused with a message
 * naming it, none crashes, and each format has models that import (test_assimp_walk renders the
 * OBJ ones in both front-ends). Prints the counts. */
static void test_other_formats(void)
{
    static const char *const dirs[][2] = {{"FBX", "fbx"}, {"Collada", "dae"}, {"PLY", "ply"},
                                          {"STL", "stl"}, {"3DS", "3ds"}};
    if (access("/usr/share/assimp/models/FBX", R_OK) != 0) {
        printf("     skip: assimp-testmodels absent (scripts/install-deps.sh)\n");
        return;
    }
    for (int d = 0; d < 5; d++) {
        char cmd[512], line[1024];
        snprintf(cmd, sizeof cmd,
                 "find /usr/share/assimp/models/%s -type f -iname '*.%s' | sort", dirs[d][0],
                 dirs[d][1]);
        FILE *fp = popen(cmd, "r");
        REQUIRE(fp, "find");
        int imported = 0, refused = 0, unlit = 0;
        while (fgets(line, sizeof line, fp)) {
            line[strcspn(line, "\n")] = 0;
            tnd_scene *s = NULL;
            tnd_result r = tnd_scene_load(line, &s);
            if (r != TND_OK) {
                refused++;
                CHECK(strstr(tnd_error_detail(), line) != NULL, "%s: %s", line,
                      tnd_error_detail());
                continue;
            }
            imported++;
            unlit += s->default_light[0] != 0;
            CHECK(s->camera_count >= 1 && tnd_scene_triangles(s) > 0, "%s: camera and triangles",
                  line);
            tnd_scene_destroy(s);
        }
        pclose(fp);
        printf("     %-8s %2d imported (%d lit by the default sky), %d refused naming the file\n",
               dirs[d][0], imported, unlit, refused);
        CHECK(imported > 0, "%s: none imported", dirs[d][0]);
    }
}


/* MTL to metal-rough, statement by statement (docs/scenes.md "OBJ and MTL"): a plastic (Kd, Ks,
 * Ns), a metal (no Kd, Ks), a glass (illum 7, d, Ni), a lamp (Ke: an area light), a cut-out
 * (map_d beside map_Kd), a bumped one (map_Bump: a normal map made from the height); an unused
 * statement is named with its line; an OBJ index out of range is refused naming the file. */
static void test_obj_mtl(void)
{
    char d[] = "/tmp/tandem_obj_XXXXXX", p[600], cmd[700];
    REQUIRE(mkdtemp(d), "mkdtemp");
    snprintf(p, sizeof p, "%s/m.mtl", d);
    write_text(p, "newmtl plastic\nKd 0.8 0.2 0.1\nKs 0.5 0.5 0.5\nNs 98\n"
                  "newmtl metal\nKd 0 0 0\nKs 0.9 0.6 0.3\nNs 400\n"
                  "newmtl glass\nKd 0 0 0\nKs 1 1 1\nillum 7\nd 0.2\nNi 1.45\n"
                  "newmtl lamp\nKd 0 0 0\nKe 5 4 3\n"
                  "newmtl leaf\nKd 1 1 1\nmap_Kd c.png\nmap_d mask.png\nTf 1 1 1\n"
                  "newmtl bumpy\nKd 0.5 0.5 0.5\nKs 0 0 0\nmap_Bump h.png\n");
    /* textures: 2x2 colour, 4x4 mask (left half opaque), 4x4 height ramp along x */
    {
        static const uint8_t px[16] = {255, 0, 0,   255, 0, 255, 0, 255,
                                       0,   0, 255, 255, 9, 9,   9, 255};
        uint8_t mask[4 * 4 * 4], h[4 * 4 * 4];
        for (int i = 0; i < 16; i++) {
            uint8_t m = (i % 4) < 2 ? 255 : 0, v = (uint8_t)(60 * (i % 4));
            for (int k = 0; k < 4; k++) {
                mask[4 * i + k] = k == 3 ? 255 : m;
                h[4 * i + k] = k == 3 ? 255 : v;
            }
        }
        const char *names[3] = {"c.png", "mask.png", "h.png"};
        const uint8_t *data[3] = {px, mask, h};
        const int sz[3] = {2, 4, 4};
        for (int t = 0; t < 3; t++) {
            snprintf(p, sizeof p, "%s/%s", d, names[t]);
            CHECK(stbi_write_png(p, sz[t], sz[t], 4, data[t], 4 * sz[t]) != 0, "write %s", p);
        }
    }
    /* six quads, one per material */
    char obj[4096];
    size_t n = (size_t)snprintf(obj, sizeof obj, "mtllib m.mtl\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n");
    const char *mats[6] = {"plastic", "metal", "glass", "lamp", "leaf", "bumpy"};
    for (int q = 0; q < 6; q++) {
        n += (size_t)snprintf(obj + n, sizeof obj - n,
                              "v %d 0 0\nv %d 0 0\nv %d 1 0\nv %d 1 0\nusemtl %s\n"
                              "f %d/1 %d/2 %d/3 %d/4\n",
                              2 * q, 2 * q + 1, 2 * q + 1, 2 * q, mats[q], 4 * q + 1, 4 * q + 2,
                              4 * q + 3, 4 * q + 4);
    }
    snprintf(p, sizeof p, "%s/scene.obj", d);
    write_text(p, obj);
    tnd_result r;
    char *log = load_capturing(p, &r);
    CHECK(r == TND_OK, "scene.obj: %s", tnd_error_detail());
    CHECK(log && strstr(log, "m.mtl:22: MTL statement 'Tf' is not used"),
          "the unused statement named with its line: %s", log ? log : "(no capture)");
    free(log);
    tnd_scene *s = NULL;
    REQUIRE_OK(tnd_scene_load(p, &s));
    const tnd_material *pl = material(s, "plastic"), *me = material(s, "metal"),
                       *gl = material(s, "glass"), *la = material(s, "lamp"),
                       *le = material(s, "leaf"), *bu = material(s, "bumpy");
    REQUIRE(pl && me && gl && la && le && bu, "the six materials");
    CHECK(pl->metallic == 0 && pl->base_color[0] == 0.8f && pl->specular == 1.0f &&
              fabsf(pl->roughness - powf(2.0f / 100.0f, 0.25f)) < 1e-6f,
          "plastic: metallic %g, base %g, specular %g, roughness %g", (double)pl->metallic,
          (double)pl->base_color[0], (double)pl->specular, (double)pl->roughness);
    CHECK(me->metallic == 1 && me->base_color[1] == 0.6f, "metal: metallic %g, base %g",
          (double)me->metallic, (double)me->base_color[1]);
    CHECK(gl->kind == TND_MAT_THIN_GLASS && fabsf(gl->ior - 1.45f) < 1e-6f && !gl->alpha_test,
          "glass: kind %d, ior %g", (int)gl->kind, (double)gl->ior);
    CHECK(la->emission[0] == 5 && s->emitter_count == 2, "lamp: emission %g, %u emitters",
          (double)la->emission[0], s->emitter_count);
    CHECK(le->alpha_test && le->tex_base_color >= 0, "leaf: alpha-tested with a texture");
    if (le->tex_base_color >= 0) { /* the mask's left half in the alpha, over the colour */
        const tnd_texture *t = &s->textures[le->tex_base_color];
        CHECK(t->width == 2 && t->rgba8[3] == 255 && t->rgba8[7] == 0 && t->rgba8[0] == 255,
              "merged texture: %ux%u, alpha %d %d", t->width, t->height, t->rgba8[3], t->rgba8[7]);
    }
    CHECK(bu->specular == 0 && bu->tex_normal >= 0, "bumpy: Lambert with a normal map");
    if (bu->tex_normal >= 0) { /* a ramp rising along +x: normals lean towards -x */
        const tnd_texture *t = &s->textures[bu->tex_normal];
        CHECK(t->rgba8[4 * 1] < 128 && t->rgba8[4 * 1 + 2] > 128 && !t->srgb,
              "normal from height: %d %d %d", t->rgba8[4], t->rgba8[5], t->rgba8[6]);
    }
    CHECK(s->features & TND_FEATURE(ALPHA), "features %#x", s->features);
    tnd_scene_destroy(s);
    s = NULL;
    /* a face index out of range */
    snprintf(p, sizeof p, "%s/bad.obj", d);
    write_text(p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
    r = tnd_scene_load(p, &s);
    CHECK(r != TND_OK && !s && strstr(tnd_error_detail(), p), "index out of range: %s",
          tnd_error_detail());
cleanup:
    tnd_scene_destroy(s);
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", d);
    CHECK(system(cmd) == 0, "cleanup");
}

/* ---- real-content defaults, camera paths, CUBICSPLINE ---------------------------------------- */

/* A box (inward faces) with one emissive quad and no other light, as a game level comes: the
 * quad is decoration, so the default sky lights it (and says why); --no-default-light keeps it
 * dark; a stated black sky (tandem_sky [0, 0, 0]) is no request for light. */
static tnd_scene *lamp_level(const tnd_scene_options *o, bool sky_set)
{
    tnd_scene *s = NULL;
    if (tnd_scene_new("lamp level", &s) != TND_OK)
        return NULL;
    s->sky_set = sky_set;
    tnd_material wall = tnd_material_default("wall"), lamp = tnd_material_default("lamp");
    lamp.emission[0] = lamp.emission[1] = lamp.emission[2] = 5;
    int32_t mw = tnd_scene_add_material(s, &wall), ml = tnd_scene_add_material(s, &lamp);
    const float fv[4][3] = {{-4, 0, -2}, {4, 0, -2}, {4, 0, 2}, {-4, 0, 2}};
    const float lv[4][3] = {{-0.1f, 0.5f, 0}, {0.1f, 0.5f, 0}, {0.1f, 0.7f, 0}, {-0.1f, 0.7f, 0}};
    const float up[4][3] = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
    const float fw[4][3] = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    const uint32_t fi[6] = {0, 2, 1, 0, 3, 2}, li[6] = {0, 1, 2, 0, 2, 3};
    int32_t root = tnd_scene_add_node(s, "root", -1, NULL, NULL, NULL);
    int32_t m0 = tnd_scene_add_mesh(s, "floor", &fv[0][0], &up[0][0], NULL, 4, fi, 2,
                                    (uint32_t)mw);
    int32_t m1 = tnd_scene_add_mesh(s, "sign", &lv[0][0], &fw[0][0], NULL, 4, li, 2,
                                    (uint32_t)ml);
    if (root < 0 || m0 < 0 || m1 < 0 || tnd_scene_add_instance(s, (uint32_t)m0, (uint32_t)root) < 0 ||
        tnd_scene_add_instance(s, (uint32_t)m1, (uint32_t)root) < 0 ||
        tnd_scene_commit_with(s, o) != TND_OK) {
        tnd_scene_destroy(s);
        return NULL;
    }
    return s;
}

static void test_default_light_levels(void)
{
    tnd_scene_options o = {0};
    tnd_scene *s = lamp_level(&o, false);
    REQUIRE(s, "lamp level: %s", tnd_error_detail());
    CHECK(s->emitter_count == 2 && s->sky[0] == TND_DEFAULT_SKY && (s->features & TND_FEATURE(SKY)) &&
              strstr(s->default_light, "2 emissive triangles do not count"),
          "emitters and no light: sky %g, note '%s'", (double)s->sky[0], s->default_light);
    tnd_scene_destroy(s);
    o.no_default_light = true;
    s = lamp_level(&o, false);
    REQUIRE(s, "lamp level: %s", tnd_error_detail());
    CHECK(s->sky[0] == 0 && !(s->features & TND_FEATURE(SKY)) && !s->default_light[0] &&
              (s->features & TND_FEATURE(LIGHT_AREA)),
          "--no-default-light: sky %g, features %#x", (double)s->sky[0], s->features);
    tnd_scene_destroy(s);
    o.no_default_light = false;
    s = lamp_level(&o, true);
    REQUIRE(s, "lamp level: %s", tnd_error_detail());
    CHECK(s->sky[0] == 0 && !s->default_light[0], "a stated black sky: sky %g, note '%s'",
          (double)s->sky[0], s->default_light);
    tnd_scene_destroy(s);
    s = NULL;
    /* the shipped rooms lit by their panels state their black sky */
    REQUIRE_OK(tnd_scene_load(SCENES "closed_box.gltf", &s));
    CHECK(s->sky_set && s->sky[0] == 0 && !s->default_light[0], "closed_box: '%s'",
          s->default_light);
cleanup:
    tnd_scene_destroy(s);
}

/* The camera's position and its view direction (-Z of the camera) at time t. */
static void camera_at(const tnd_scene *s, double t, tnd_scene_state *st, double p[3], double d[3])
{
    CHECK_OK(tnd_scene_evaluate(s, t, 0, 1.0f, st));
    float inv[16];
    tnd_mat4_inverse(st->camera.view, inv);
    for (int k = 0; k < 3; k++) {
        p[k] = st->camera_position[k];
        d[k] = -inv[8 + k];
    }
}

static double distance(const double p[3], const double q[3])
{
    return sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                (p[2] - q[2]) * (p[2] - q[2]));
}

static double angle_to(const double p[3], const double d[3], const double at[3])
{
    double v[3] = {at[0] - p[0], at[1] - p[1], at[2] - p[2]};
    double c = (v[0] * d[0] + v[1] * d[1] + v[2] * d[2]) /
               sqrt((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
    return acos(fmin(1.0, fmax(-1.0, c)));
}

/* --camera-path orbit|dolly|flythrough from the bounds (docs/scenes.md): the orbit starts where
 * the default camera stands, keeps its radius and height and looks at the centre, once round in
 * the duration; the dolly runs its distance straight towards the centre; the flythrough stays
 * inside the bounds looking level along its way. A keyframe file passes through its keys, looks
 * at its targets, and blends its field of view; bad files are named. */
static void test_camera_paths(void)
{
    tnd_scene_options o = {0};
    tnd_scene_state st = {0};
    tnd_scene *plain = lamp_level(&o, true), *s = NULL;
    REQUIRE(plain, "lamp level: %s", tnd_error_detail());
    double p0[3], d0[3], p[3], d[3], lo[3], hi[3], c[3];
    camera_at(plain, 0, &st, p0, d0);
    tnd_scene_bounds(plain, &st, lo, hi);
    for (int k = 0; k < 3; k++)
        c[k] = 0.5 * (lo[k] + hi[k]);
    double ring = hypot(p0[0] - c[0], p0[2] - c[2]), height = p0[1] - c[1];
    tnd_scene_state_free(&st);

    o.camera_path = "orbit";
    o.path_duration = 8;
    s = lamp_level(&o, true);
    REQUIRE(s, "orbit: %s", tnd_error_detail());
    CHECK(s->duration == 8.0f && strcmp(s->cameras[0].name, "camera path") == 0 &&
              (s->features & TND_FEATURE(ANIMATED_CAMERA)) && strstr(s->camera_path, "orbit"),
          "orbit: duration %g, camera '%s', note '%s'", (double)s->duration, s->cameras[0].name,
          s->camera_path);
    camera_at(s, 0, &st, p, d);
    CHECK(distance(p, p0) < 1e-4 * ring,
          "orbit starts at the default camera: (%g %g %g) vs (%g %g %g)", p[0], p[1], p[2], p0[0],
          p0[1], p0[2]);
    double worst_r = 0, worst_h = 0, worst_a = 0;
    for (int i = 0; i <= 160; i++) {
        double t = 8.0 * i / 160;
        camera_at(s, t, &st, p, d);
        worst_r = fmax(worst_r, fabs(hypot(p[0] - c[0], p[2] - c[2]) - ring) / ring);
        worst_h = fmax(worst_h, fabs(p[1] - c[1] - height) / ring);
        worst_a = fmax(worst_a, angle_to(p, d, c));
    }
    CHECK(worst_r < 2e-5 && worst_h < 1e-6 && worst_a < 1e-4,
          "orbit: radius off by %.2g, height by %.2g, aim by %.2g rad", worst_r, worst_h, worst_a);
    /* a quarter of the way round: the azimuth has turned 90 degrees (counter-clockwise from
     * above, as the azimuth grows from +Z towards +X) */
    camera_at(s, 2.0, &st, p, d);
    double az0 = atan2(p0[0] - c[0], p0[2] - c[2]), az = atan2(p[0] - c[0], p[2] - c[2]);
    double turn = fmod(az - az0 + 4 * TND_PI, 2 * TND_PI);
    CHECK_NEAR(turn, TND_PI / 2, 1e-4, "orbit: a quarter turn in a quarter of the time");
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);

    o.camera_path = "dolly";
    o.path_radius = 3;
    s = lamp_level(&o, true);
    REQUIRE(s, "dolly: %s", tnd_error_detail());
    camera_at(s, 0, &st, p, d);
    double e0 = distance(p, c), worst = 0;
    for (int i = 0; i <= 16; i++) {
        camera_at(s, 8.0 * i / 16, &st, p, d);
        worst = fmax(worst, fabs(distance(p, c) - (e0 - 3.0 * i / 16)) + angle_to(p, d, c));
    }
    CHECK(worst < 1e-4, "dolly: off its line by %.2g", worst);
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);

    o.camera_path = "flythrough";
    o.path_radius = 0;
    s = lamp_level(&o, true);
    REQUIRE(s, "flythrough: %s", tnd_error_detail());
    bool inside = true;
    worst = 0;
    for (int i = 0; i <= 64; i++) {
        camera_at(s, 8.0 * i / 64, &st, p, d);
        for (int k = 0; k < 3; k += 2)
            inside &= p[k] > lo[k] && p[k] < hi[k];
        worst = fmax(worst, fabs(d[1]));
    }
    CHECK(inside && worst < 1e-4, "flythrough: inside %d, looks off level by %.2g", inside, worst);
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
    s = NULL;

    /* a keyframe file: the keys themselves, their targets, the field of view blended */
    char dir_[] = "/tmp/tandem_path_XXXXXX", path[64];
    REQUIRE(mkdtemp(dir_), "temporary folder");
    snprintf(path, sizeof path, "%s/path.json", dir_);
    write_text(path, "{\"keyframes\": ["
                     "{\"time\": 0, \"position\": [0, 1, 5], \"target\": [0, 0.5, 0], \"yfov\": 40},"
                     "{\"time\": 1, \"position\": [3, 1, 4], \"target\": [0, 0.5, 0], \"yfov\": 40},"
                     "{\"time\": 3, \"position\": [3, 2, -1], \"rotation\": [0, 0.70710678, 0, "
                     "0.70710678], \"yfov\": 60}]}");
    o.camera_path = path;
    s = lamp_level(&o, true);
    REQUIRE(s, "keyframes: %s", tnd_error_detail());
    const double at[3] = {0, 0.5, 0}, keys[3][3] = {{0, 1, 5}, {3, 1, 4}, {3, 2, -1}};
    for (int i = 0; i < 3; i++) {
        camera_at(s, i == 2 ? 3.0 : i, &st, p, d);
        CHECK(distance(p, keys[i]) < 1e-5,
              "key %d: at (%g %g %g)", i, p[0], p[1], p[2]);
        if (i < 2)
            CHECK(angle_to(p, d, at) < 1e-5, "key %d looks at its target (off by %.2g)", i,
                  angle_to(p, d, at));
        else /* a quarter turn about +Y: looks down -X */
            CHECK(fabs(d[0] + 1) < 1e-5, "key 2 looks down -X: (%g %g %g)", d[0], d[1], d[2]);
    }
    /* the field of view, linear: 40 degrees up to the second key, halfway (50) at t = 2 */
    camera_at(s, 0.5, &st, p, d);
    CHECK_NEAR(2 * atan(1.0 / fabs(st.camera.proj[5])) * 180 / TND_PI, 40.0, 1e-3, "yfov before");
    camera_at(s, 2.0, &st, p, d);
    double fov_mid = 2 * atan(1.0 / fabs(st.camera.proj[5])) * 180 / TND_PI;
    CHECK_NEAR(fov_mid, 50.0, 1e-3, "yfov linear from 40 to 60");
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
    s = NULL;
    /* written back from the evaluated path: the same camera */
    tnd_camera_key wk[2] = {{0, {0, 1, 5}, {0, 0, 0, 1}, 0.7f}, {2, {1, 1, 5}, {0, 0, 0, 1}, 0.7f}};
    CHECK_OK(tnd_camera_path_write(path, wk, 2));
    s = lamp_level(&o, true);
    REQUIRE(s, "written path: %s", tnd_error_detail());
    camera_at(s, 1.0, &st, p, d);
    CHECK(fabs(p[0] - 0.5) < 1e-5 && fabs(d[2] + 1) < 1e-6, "written path at 1 s: x %g", p[0]);
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
    s = NULL;
    /* bad files: named, with the keyframe and the problem */
    const struct {
        const char *text, *needle;
    } bad[] = {{"{\"keyframes\": [{\"time\": 0, \"target\": [0, 0, 0]}]}", "\"position\""},
               {"{\"keyframes\": [{\"time\": 1, \"position\": [0, 0, 1], \"target\": [0, 0, 0]},"
                "{\"time\": 1, \"position\": [0, 0, 2], \"target\": [0, 0, 0]}]}",
                "keyframe 1: times must increase"},
               {"{\"keyframes\": [{\"time\": 0, \"position\": [0, 0, 1], \"target\": [0, 5, 1]}]}",
                "straight above"},
               {"[1, 2", "not JSON"}};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        write_text(path, bad[i].text);
        s = lamp_level(&o, true);
        CHECK(!s && strstr(tnd_error_detail(), path) && strstr(tnd_error_detail(), bad[i].needle),
              "bad path %zu: '%s'", i, tnd_error_detail());
        tnd_scene_destroy(s);
        s = NULL;
    }
    o.camera_path = "spiral";
    s = lamp_level(&o, true);
    CHECK(!s && strstr(tnd_error_detail(), "orbit, dolly, flythrough"), "unknown path: '%s'",
          tnd_error_detail());
    unlink(path);
    rmdir(dir_);
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
    tnd_scene_destroy(plain);
}

/* --up z (Stellarium's scenery, assimp's exports of .blend files): (x, y, z) becomes (x, z, -y)
 * for geometry, and the default camera frames the turned bounds. The lamp level's floor spans
 * x in [-4, 4], z in [-2, 2] at y = 0; turned, it spans y in [-2, 2] at z = 0 (its +Z side at
 * y = +2). */
static void test_up_z(void)
{
    tnd_scene_options o = {.up_z = true};
    tnd_scene_state st = {0};
    tnd_scene *s = lamp_level(&o, true);
    REQUIRE(s, "lamp level: %s", tnd_error_detail());
    double lo[3], hi[3];
    CHECK_OK(tnd_scene_evaluate(s, 0, 0, 1.0f, &st));
    tnd_scene_bounds(s, &st, lo, hi);
    CHECK(fabs(lo[0] + 4) < 1e-5 && fabs(hi[0] - 4) < 1e-5 && fabs(lo[1] + 2) < 1e-5 &&
              fabs(hi[1] - 2) < 1e-5 && fabs(lo[2] + 0.7) < 1e-5 && fabs(hi[2]) < 1e-5,
          "turned bounds (%g %g %g) .. (%g %g %g)", lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    /* the floor's corner (4, 0, 2) is now at (4, 2, 0) */
    const float *x = st.instance_xform;
    float p[3] = {x[0] * 4 + x[2] * 2 + x[3], x[4] * 4 + x[6] * 2 + x[7], x[8] * 4 + x[10] * 2 + x[11]};
    CHECK(fabsf(p[0] - 4) < 1e-5f && fabsf(p[1] - 2) < 1e-5f && fabsf(p[2]) < 1e-5f,
          "corner at (%g %g %g)", p[0], p[1], p[2]);
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
}

/* glTF CUBICSPLINE (spec 3.11): keys 0 s and 2 s, x from 0 (out-tangent 1/s) to 2 (in-tangent
 * 0), y from 0 (out-tangent 0) to 0 (in-tangent 3/s). By hand, with d = 2 and s = t / 2:
 * x = (s^3 - 2s^2 + s) d 1 + (-2s^3 + 3s^2) 2, y = (s^3 - s^2) d 3: at t = 0.5, x = 0.28125 +
 * 0.3125 = 0.59375 and y = -0.28125; at t = 1, x = 0.25 + 1 = 1.25 and y = -0.75 (linear
 * between the values would give 0.5 and 1, y 0). */
static void test_cubicspline(void)
{
    char d[] = "/tmp/tandem_cubic_XXXXXX", p[600];
    REQUIRE(mkdtemp(d), "temporary folder");
    float bin[29] = {0, 0, 0, 1, 0, 0, 0, 1, 0, /* a triangle */
                     0, 2,                      /* times */
                     0, 0, 0, 0, 0, 0, 1, 0, 0, /* key 0: in-tangent, value, out-tangent */
                     0, 3, 0, 2, 0, 0, 0, 0, 0}; /* key 1 */
    snprintf(p, sizeof p, "%s/cubic.bin", d);
    CHECK_OK(tnd_file_write_atomic(p, bin, sizeof bin));
    snprintf(p, sizeof p, "%s/cubic.gltf", d);
    write_text(p, "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],"
                  "\"nodes\": [{\"name\": \"mover\", \"mesh\": 0}],"
                  "\"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}}]}],"
                  "\"buffers\": [{\"uri\": \"cubic.bin\", \"byteLength\": 116}],"
                  "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36},"
                  "{\"buffer\": 0, \"byteOffset\": 36, \"byteLength\": 8},"
                  "{\"buffer\": 0, \"byteOffset\": 44, \"byteLength\": 72}],"
                  "\"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, "
                  "\"type\": \"VEC3\", \"min\": [0, 0, 0], \"max\": [1, 1, 0]},"
                  "{\"bufferView\": 1, \"componentType\": 5126, \"count\": 2, \"type\": "
                  "\"SCALAR\", \"min\": [0], \"max\": [2]},"
                  "{\"bufferView\": 2, \"componentType\": 5126, \"count\": 6, \"type\": "
                  "\"VEC3\"}],"
                  "\"animations\": [{\"samplers\": [{\"input\": 1, \"output\": 2, "
                  "\"interpolation\": \"CUBICSPLINE\"}], \"channels\": [{\"sampler\": 0, "
                  "\"target\": {\"node\": 0, \"path\": \"translation\"}}]}]}");
    tnd_scene *s = NULL;
    tnd_scene_state st = {0};
    REQUIRE_OK(tnd_scene_load(p, &s));
    REQUIRE(s->channel_count == 1 && s->channels[0].cubic && s->channels[0].key_count == 2,
            "one CUBICSPLINE channel of 2 keys (%u channels)", s->channel_count);
    const double t[4] = {0.5, 1.0, 0.0, 2.0}, x[4] = {0.59375, 1.25, 0, 2},
                 y[4] = {-0.28125, -0.75, 0, 0};
    for (int i = 0; i < 4; i++) {
        REQUIRE_OK(tnd_scene_evaluate(s, t[i], 0, 1.0f, &st));
        const float *w = st.node_world;
        CHECK(fabs(w[12] - x[i]) < 1e-6 && fabs(w[13] - y[i]) < 1e-6,
              "t %g: translation (%.7g, %.7g), by hand (%g, %g)", t[i], w[12], w[13], x[i], y[i]);
    }
cleanup:
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
    snprintf(p, sizeof p, "rm -rf '%s'", d);
    CHECK(system(p) == 0, "cleanup");
}

/* Images that did not ship (docs/scenes.md "Missing images"): the scene loads, each image is
 * named once on stderr with the reason and listed in the scene (tandem info), and its materials
 * keep their factors (no texture: white base colour, a flat normal). On a real file (Khronos'
 * BoxTextured from assimp-testmodels, copied without its PNG) and on the shipped materials scene
 * with one image a Blender procedural pseudo-URI (what Blender's exporters write). */
static void test_missing_images(void)
{
    char d[] = "/tmp/tandem_missing_XXXXXX", p[600], cmd[1400];
    REQUIRE(mkdtemp(d), "temporary folder");
    tnd_scene *s = NULL;
    tnd_result r;
    char *log = NULL;
    const char *box = "/usr/share/assimp/models/glTF2/BoxTextured-glTF/BoxTextured.gltf";
    if (access(box, R_OK) == 0) {
        snprintf(cmd, sizeof cmd, "cp '%s' '%s/BoxTextured0.bin' '%s/'", box,
                 "/usr/share/assimp/models/glTF2/BoxTextured-glTF", d);
        CHECK(system(cmd) == 0, "copy BoxTextured");
        snprintf(p, sizeof p, "%s/BoxTextured.gltf", d);
        log = load_capturing(p, &r);
        CHECK(r == TND_OK, "BoxTextured without its PNG loads: %s", tnd_error_detail());
        CHECK(log && strstr(log, "CesiumLogoFlat.png") && strstr(log, "no such file"),
              "the missing image named with its material and reason: %s", log ? log : "");
        free(log);
        log = NULL;
        REQUIRE_OK(tnd_scene_load(p, &s));
        CHECK(s->missing_image_count == 1 && s->texture_count == 0 &&
                  s->materials[0].tex_base_color == -1 &&
                  strcmp(s->missing_images[0].name, "CesiumLogoFlat.png") == 0,
              "missing %u, textures %u", s->missing_image_count, s->texture_count);
        tnd_scene_destroy(s);
        s = NULL;
    } else {
        printf("     skip: %s absent (assimp-testmodels)\n", box);
    }
    /* a procedural pseudo-URI and a missing normal map on the shipped materials scene */
    snprintf(cmd, sizeof cmd, "cp '%smaterials.gltf' '%smaterials.bin' '%smaterials_mr.png' '%s/'",
             SCENES, SCENES, SCENES, d);
    CHECK(system(cmd) == 0, "copy materials");
    snprintf(p, sizeof p, "%s/materials.gltf", d);
    void *txt = NULL;
    size_t n = 0;
    REQUIRE_OK(tnd_file_read(p, &txt, &n));
    cJSON *j = cJSON_ParseWithLength(txt, n);
    free(txt);
    REQUIRE(j, "materials.gltf parses");
    cJSON *img;
    cJSON_ArrayForEach(img, cJSON_GetObjectItem(j, "images"))
    {
        cJSON *uri = cJSON_GetObjectItem(img, "uri");
        if (uri && strcmp(uri->valuestring, "materials_checker.png") == 0)
            cJSON_SetValuestring(uri, "Procedural,num=0,type=Clouds");
    }
    char *out = cJSON_Print(j);
    cJSON_Delete(j);
    write_text(p, out);
    free(out);
    log = load_capturing(p, &r);
    CHECK(r == TND_OK, "materials with two images missing loads: %s", tnd_error_detail());
    CHECK(log && strstr(log, "Procedural,num=0,type=Clouds") &&
              strstr(log, "a Blender procedural texture") && strstr(log, "materials_normal.png") &&
              strstr(log, "a flat normal"),
          "both named: %s", log ? log : "");
    REQUIRE_OK(tnd_scene_load(p, &s));
    CHECK(s->missing_image_count == 2 && s->texture_count >= 1, "missing %u, textures %u",
          s->missing_image_count, s->texture_count);
    for (uint32_t m = 0; m < s->material_count; m++)
        CHECK(s->materials[m].tex_normal == -1, "material '%s' keeps no normal map",
              s->materials[m].name);
    /* undecodable: a PNG that is not one */
    snprintf(p, sizeof p, "%s/materials_mr.png", d);
    write_text(p, "not a PNG");
    tnd_scene_destroy(s);
    s = NULL;
    snprintf(p, sizeof p, "%s/materials.gltf", d);
    REQUIRE_OK(tnd_scene_load(p, &s));
    CHECK(s->missing_image_count == 3, "an undecodable image is missing too: %u",
          s->missing_image_count);
    /* geometry stays an error: the .bin gone */
    tnd_scene_destroy(s);
    s = NULL;
    snprintf(cmd, sizeof cmd, "%s/materials.bin", d);
    remove(cmd);
    expect_error("missing .bin", p, "buffer 0", "materials.bin");
cleanup:
    free(log);
    tnd_scene_destroy(s);
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", d);
    CHECK(system(cmd) == 0, "cleanup");
}

TND_TEST_MAIN(T(test_shipped_scenes), T(test_values), T(test_animation), T(test_stress),
              T(test_light_pick), T(test_light_tree), T(test_bad_input), T(test_defaults),
              T(test_unsupported_named), T(test_other_formats), T(test_obj_mtl),
              T(test_texture_coordinates), T(test_default_light_levels), T(test_camera_paths),
              T(test_cubicspline), T(test_missing_images), T(test_up_z))
