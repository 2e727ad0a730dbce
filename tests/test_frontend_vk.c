/* tests/test_frontend_vk.c: acceleration structures and a ray-tracing pipeline with an SBT on a
 * real driver. Rays are traced through BLAS/TLAS with instance transforms and the results are
 * compared with a double-precision CPU intersector (Moller-Trumbore); then an instance moves,
 * the TLAS is refitted, and the comparison is repeated. Then the Vulkan front-end against the
 * Embree one (G-buffer, noisy signals, gradient samples, references), its motion vectors and
 * depth far from the origin against double precision, and the ray-query variant against the
 * pipeline. Label: gpu. */
#include "frontend_embree/frontend_embree.h"
#include "frontend_vk/frontend_vk.h"
#include "shaders/brdf.h"
#include "shaders/shader_list.h"
#include "shaders/trace_test_shared.h"
#include "tests/embree_frame.h"
#include "tests/gpu_common.h"
#include "tests/env_sphere.h"
#include "tests/lambert_probe.h"
#include "tests/motion_reference.h"

#include <unistd.h>

/* ---- scene: a quad (2 triangles) and a closed octahedron (8), three instances ---------------- */
static const float quad_pos[] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
static const uint32_t quad_idx[] = {0, 1, 2, 0, 2, 3};
static const float octa_pos[] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
static const uint32_t octa_idx[] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4,
                                    2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};

typedef struct {
    double v[3];
} d3;
static d3 sub(d3 a, d3 b)
{
    return (d3){{a.v[0] - b.v[0], a.v[1] - b.v[1], a.v[2] - b.v[2]}};
}
static d3 cross(d3 a, d3 b)
{
    return (d3){{a.v[1] * b.v[2] - a.v[2] * b.v[1], a.v[2] * b.v[0] - a.v[0] * b.v[2],
                 a.v[0] * b.v[1] - a.v[1] * b.v[0]}};
}
static double dot(d3 a, d3 b)
{
    return a.v[0] * b.v[0] + a.v[1] * b.v[1] + a.v[2] * b.v[2];
}

static d3 xform(const float m[12], const float *p)
{
    d3 r;
    for (int i = 0; i < 3; i++)
        r.v[i] = m[4 * i] * (double)p[0] + m[4 * i + 1] * (double)p[1] +
                 m[4 * i + 2] * (double)p[2] + m[4 * i + 3];
    return r;
}

typedef struct {
    double t, b1, b2, edge; /* edge: distance of the hit to the nearest triangle edge (bary) */
    int custom, prim;
} cpu_hit;

static cpu_hit cpu_trace(const fvk_instance *inst, int ninst, const fvk_mesh_desc *meshes, d3 o,
                         d3 d, double tmin, double tmax)
{
    cpu_hit best = {.t = -1, .custom = -1, .prim = -1};
    for (int k = 0; k < ninst; k++) {
        const fvk_mesh_desc *m = &meshes[inst[k].blas];
        for (uint32_t p = 0; p < m->triangle_count; p++) {
            d3 a = xform(inst[k].transform, m->positions + 3 * m->indices[3 * p]);
            d3 b = xform(inst[k].transform, m->positions + 3 * m->indices[3 * p + 1]);
            d3 c = xform(inst[k].transform, m->positions + 3 * m->indices[3 * p + 2]);
            d3 e1 = sub(b, a), e2 = sub(c, a), pv = cross(d, e2);
            double det = dot(e1, pv);
            if (fabs(det) < 1e-18)
                continue;
            d3 tv = sub(o, a);
            double u = dot(tv, pv) / det;
            d3 qv = cross(tv, e1);
            double v = dot(d, qv) / det;
            double t = dot(e2, qv) / det;
            double edge = fmin(fmin(u, v), 1 - u - v);
            if (edge < 0 || t < tmin || t > tmax)
                continue;
            if (best.t < 0 || t < best.t)
                best = (cpu_hit){t, u, v, edge, (int)inst[k].custom_index, (int)p};
        }
    }
    return best;
}

static void set_transform(float m[12], double scale, double angle_z, double tx, double ty,
                          double tz)
{
    double c = cos(angle_z) * scale, s = sin(angle_z) * scale;
    const float r[12] = {(float)c, (float)-s, 0, (float)tx, (float)s,     (float)c,
                         0,        (float)ty, 0, 0,         (float)scale, (float)tz};
    memcpy(m, r, sizeof r);
}

/* ---- GPU side ------------------------------------------------------------------------------- */
typedef struct {
    VkDescriptorSetLayout dsl;
    VkPipelineLayout layout;
    VkPipeline pipe;
    tnd_sbt sbt;
    VkDescriptorPool pool;
    VkDescriptorSet set;
} tracer;

static tnd_result tracer_create(tnd_vk *vk, tracer *t)
{
    tnd_result res = TND_OK;
    VkDescriptorSetLayoutBinding b[3] = {
        {0, VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, 1, VK_SHADER_STAGE_RAYGEN_BIT_KHR, 0},
        {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_RAYGEN_BIT_KHR, 0},
        {2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_RAYGEN_BIT_KHR, 0}};
    VkDescriptorSetLayoutCreateInfo dci = {.sType =
                                               VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                           .bindingCount = 3,
                                           .pBindings = b};
    TND_VK_TRY(vkCreateDescriptorSetLayout(vk->device, &dci, NULL, &t->dsl));
    VkPipelineLayoutCreateInfo pci = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 1,
                                      .pSetLayouts = &t->dsl};
    TND_VK_TRY(vkCreatePipelineLayout(vk->device, &pci, NULL, &t->layout));
    tnd_rt_stage stages[3];
    const tnd_shader ids[3] = {TND_SHADER_trace_test_rgen, TND_SHADER_trace_test_rmiss,
                               TND_SHADER_trace_test_rchit};
    const VkShaderStageFlagBits kinds[3] = {VK_SHADER_STAGE_RAYGEN_BIT_KHR,
                                            VK_SHADER_STAGE_MISS_BIT_KHR,
                                            VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR};
    for (int i = 0; i < 3; i++) {
        stages[i].code = tnd_spirv_code(ids[i], &stages[i].bytes, NULL);
        stages[i].stage = kinds[i];
    }
    const uint32_t rg = 0, ms = 1;
    const tnd_rt_hit_group hg = {.closest_hit = 2, .any_hit = -1};
    TND_TRY(tnd_rt_pipeline_create(vk,
                                   &(tnd_rt_desc){.stages = stages,
                                                  .stage_count = 3,
                                                  .raygen = &rg,
                                                  .raygen_count = 1,
                                                  .miss = &ms,
                                                  .miss_count = 1,
                                                  .hit = &hg,
                                                  .hit_count = 1,
                                                  .layout = t->layout,
                                                  .name = "trace_test"},
                                   &t->pipe, &t->sbt));
    VkDescriptorPoolSize ps[2] = {{VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, 1},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2}};
    VkDescriptorPoolCreateInfo dpci = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                       .maxSets = 1,
                                       .poolSizeCount = 2,
                                       .pPoolSizes = ps};
    TND_VK_TRY(vkCreateDescriptorPool(vk->device, &dpci, NULL, &t->pool));
    VkDescriptorSetAllocateInfo ai = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                      .descriptorPool = t->pool,
                                      .descriptorSetCount = 1,
                                      .pSetLayouts = &t->dsl};
    TND_VK_TRY(vkAllocateDescriptorSets(vk->device, &ai, &t->set));
fail:
    return res;
}

static void tracer_destroy(tnd_vk *vk, tracer *t)
{
    tnd_sbt_destroy(vk, &t->sbt);
    if (t->pipe)
        vkDestroyPipeline(vk->device, t->pipe, NULL);
    if (t->pool)
        vkDestroyDescriptorPool(vk->device, t->pool, NULL);
    if (t->layout)
        vkDestroyPipelineLayout(vk->device, t->layout, NULL);
    if (t->dsl)
        vkDestroyDescriptorSetLayout(vk->device, t->dsl, NULL);
    memset(t, 0, sizeof *t);
}

static tnd_result trace(tnd_vk *vk, tracer *t, const fvk_tlas *tlas, const tnd_buffer *rays,
                        const tnd_buffer *hits, uint32_t n)
{
    VkWriteDescriptorSetAccelerationStructureKHR wa = {
        .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR,
        .accelerationStructureCount = 1,
        .pAccelerationStructures = &tlas->as};
    VkDescriptorBufferInfo bi[2] = {{rays->buffer, 0, VK_WHOLE_SIZE},
                                    {hits->buffer, 0, VK_WHOLE_SIZE}};
    VkWriteDescriptorSet w[2] = {{.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                  .pNext = &wa,
                                  .dstSet = t->set,
                                  .dstBinding = 0,
                                  .descriptorCount = 1,
                                  .descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR},
                                 {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                  .dstSet = t->set,
                                  .dstBinding = 1,
                                  .descriptorCount = 2,
                                  .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                  .pBufferInfo = bi}};
    vkUpdateDescriptorSets(vk->device, 2, w, 0, NULL);
    VkCommandBuffer cmd;
    tnd_result res = tnd_cmd_begin(vk, &cmd);
    if (res != TND_OK)
        return res;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, t->pipe);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR, t->layout, 0, 1, &t->set,
                            0, NULL);
    vk->fn.vkCmdTraceRaysKHR(cmd, &t->sbt.raygen[0], &t->sbt.miss, &t->sbt.hit, &t->sbt.callable, n,
                             1, 1);
    tnd_cmd_barrier(cmd);
    return tnd_cmd_submit_wait(vk, cmd);
}

/* Compare GPU hits with the CPU; rays within 1e-4 (barycentric) of an edge may legitimately
 * pick the neighbouring triangle or miss, and are only counted. */
static void compare(const tt_ray *rays, const tt_hit *gpu, uint32_t n, const fvk_instance *inst,
                    int ninst, const fvk_mesh_desc *meshes, const char *what)
{
    int edge = 0, hits = 0, bad_hit = 0, bad_t = 0, bad_id = 0, bad_bary = 0;
    double max_rel = 0;
    for (uint32_t i = 0; i < n; i++) {
        d3 o = {{rays[i].origin_tmin.x, rays[i].origin_tmin.y, rays[i].origin_tmin.z}};
        d3 d = {{rays[i].dir_tmax.x, rays[i].dir_tmax.y, rays[i].dir_tmax.z}};
        cpu_hit c = cpu_trace(inst, ninst, meshes, o, d, rays[i].origin_tmin.w, rays[i].dir_tmax.w);
        if (c.t >= 0 && c.edge < 1e-4) {
            edge++;
            continue;
        }
        bool gh = gpu[i].t >= 0, ch = c.t >= 0;
        if (gh != ch) {
            bad_hit++;
            continue;
        }
        if (!ch)
            continue;
        hits++;
        /* Float traversal vs double reference: a few ulps of the ray's extent. */
        double rel = fabs(gpu[i].t - c.t) / c.t;
        max_rel = fmax(max_rel, rel);
        bad_t += rel > 1e-5;
        bad_id += gpu[i].custom_index != c.custom || gpu[i].primitive != c.prim;
        bad_bary += fabs(gpu[i].bary.x - c.b1) > 1e-4 || fabs(gpu[i].bary.y - c.b2) > 1e-4;
    }
    printf("     %s: %u rays, %d hits compared, %d near edges, max relative t error %.2e\n", what,
           n, hits, edge, max_rel);
    CHECK(hits > (int)n / 4, "%s: enough hits to mean something (%d)", what, hits);
    CHECK(edge < (int)n / 100, "%s: edge cases are rare (%d)", what, edge);
    CHECK(bad_hit == 0, "%s: %d hit/miss disagreements", what, bad_hit);
    CHECK(bad_t == 0, "%s: %d distances off by > 1e-5 relative", what, bad_t);
    CHECK(bad_id == 0, "%s: %d instance/primitive mismatches", what, bad_id);
    CHECK(bad_bary == 0, "%s: %d barycentric mismatches", what, bad_bary);
}

static uint32_t lcg(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return *s >> 8;
}
static float frand(uint32_t *s)
{
    return (float)lcg(s) / 16777216.0f;
}

static void test_trace_against_cpu(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    fvk_mesh_desc meshes[2] = {
        {quad_pos, 4, quad_idx, 2, "quad", false},
        {octa_pos, 6, octa_idx, 8, "octahedron", false},
    };
    fvk_blas blas[2] = {0};
    fvk_tlas tlas = {0};
    tracer tr = {0};
    tnd_buffer rays = {0}, hits = {0};
    enum { N = 64 * 64 };
    tt_ray *r = calloc(N, sizeof *r);
    tt_hit *h = calloc(N, sizeof *h);
    fvk_instance inst[3] = {{.blas = 0, .custom_index = 7},
                            {.blas = 0, .custom_index = 9},
                            {.blas = 1, .custom_index = 3}};
    set_transform(inst[0].transform, 3.0, 0.0, 0, 0, -2);
    set_transform(inst[1].transform, 0.7, 0.6, 1.2, 0.4, 0.5);
    set_transform(inst[2].transform, 0.8, 0.3, -1.0, -0.8, 0.8);

    REQUIRE_OK(fvk_blas_build(vk, meshes, 2, blas));
    for (int i = 0; i < 2; i++)
        CHECK(blas[i].compacted_bytes > 0 && blas[i].compacted_bytes <= blas[i].built_bytes,
              "BLAS %d compacted %llu <= built %llu", i,
              (unsigned long long)blas[i].compacted_bytes, (unsigned long long)blas[i].built_bytes);
    REQUIRE_OK(fvk_tlas_build(vk, blas, 2, inst, 3, false, &tlas));
    REQUIRE_OK(tracer_create(vk, &tr));

    /* A pinhole grid from (0,0,6) over [-3,3]^2 at z = -2, directions not normalised (t is in
     * units of the direction's length), plus tmin/tmax windows on some rays. */
    uint32_t seed = 12345;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            int i = y * 64 + x;
            float px = -3.0f + 6.0f * ((float)x + frand(&seed)) / 64.0f;
            float py = -3.0f + 6.0f * ((float)y + frand(&seed)) / 64.0f;
            float tmax = (i % 7 == 0) ? 0.9f : 1e30f;
            r[i] = (tt_ray){{0, 0, 6, 0.0f}, {px, py, -8.0f, tmax}};
        }
    REQUIRE_OK(tnd_buffer_create(vk,
                                 &(tnd_buffer_desc){.size = N * sizeof *r,
                                                    .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                    .name = "test.rays"},
                                 &rays));
    REQUIRE_OK(tnd_buffer_create(vk,
                                 &(tnd_buffer_desc){.size = N * sizeof *h,
                                                    .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                    .mem = TND_MEM_READBACK,
                                                    .name = "test.hits"},
                                 &hits));
    REQUIRE_OK(tnd_buffer_upload(vk, &rays, 0, r, N * sizeof *r));
    REQUIRE_OK(trace(vk, &tr, &tlas, &rays, &hits, N));
    REQUIRE_OK(tnd_buffer_download(vk, &hits, 0, h, N * sizeof *h));
    compare(r, h, N, inst, 3, meshes, "static");

    /* Move the octahedron and the small quad; refit; trace again. */
    set_transform(inst[1].transform, 0.7, 1.1, 0.2, 1.4, 1.5);
    set_transform(inst[2].transform, 0.8, 0.9, 1.0, -0.5, 0.2);
    REQUIRE_OK(fvk_tlas_build(vk, blas, 2, inst, 3, true, &tlas));
    REQUIRE_OK(trace(vk, &tr, &tlas, &rays, &hits, N));
    REQUIRE_OK(tnd_buffer_download(vk, &hits, 0, h, N * sizeof *h));
    compare(r, h, N, inst, 3, meshes, "refit");
cleanup:
    tracer_destroy(vk, &tr);
    tnd_buffer_destroy(vk, &rays);
    tnd_buffer_destroy(vk, &hits);
    fvk_tlas_destroy(vk, &tlas);
    for (int i = 0; i < 2; i++)
        fvk_blas_destroy(vk, &blas[i]);
    free(r);
    free(h);
    gpu_end();
}

static void test_blas_bad_input(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    const uint32_t bad_idx[] = {0, 1, 7};
    fvk_mesh_desc m = {quad_pos, 4, bad_idx, 1, "broken", false};
    fvk_blas b = {0};
    tnd_result r = fvk_blas_build(vk, &m, 1, &b);
    CHECK(r == TND_ERR_BAD_INPUT, "out-of-range index rejected: %s", tnd_result_name(r));
    CHECK(strstr(tnd_error_detail(), "broken") && strstr(tnd_error_detail(), "index 7"),
          "message names the mesh and the index: %s", tnd_error_detail());
    CHECK(b.as == VK_NULL_HANDLE, "nothing built");
    fvk_tlas t = {0};
    fvk_instance in = {.blas = 3};
    CHECK(fvk_tlas_build(vk, &b, 1, &in, 1, false, &t) == TND_ERR_INVALID_ARGUMENT,
          "instance of a missing BLAS");
    gpu_end();
}

/* ---- cross-check against the Embree front-end ------------------------------------------------ */
typedef struct pair {
    tnd_vk *vk;
    tnd_scene *s;
    femb_context *fe;
    fvk_context *gv;
    tnd_scene_state cur, prev;
    tnd_frame cpu, gpu;
} pair;

static tnd_result pair_open_with(tnd_vk *vk, pair *p, const char *path, fvk_rt_api api,
                                 const tnd_scene_options *o)
{
    memset(p, 0, sizeof *p);
    p->vk = vk;
    tnd_result r = tnd_scene_load_with(path, o, &p->s);
    if (r == TND_OK)
        r = femb_create(p->s, &(femb_desc){.threads = 2}, &p->fe);
    if (r == TND_OK)
        r = fvk_create(vk, p->s, &(fvk_desc){.precision = TND_PRECISION_F32, .rt_api = api},
                       &p->gv);
    return r;
}

static tnd_result pair_open_api(tnd_vk *vk, pair *p, const char *path, fvk_rt_api api)
{
    return pair_open_with(vk, p, path, api, NULL);
}

/* sun.gltf (a sun and a sky) lit by a real HDRI instead of its sky: the environment map's
 * importance sampling in both front-ends. */
static const tnd_scene_options env_forest = {
    .env = "/usr/share/blender/datafiles/studiolights/world/forest.exr", .env_intensity = 1.5f,
    .env_rotation = 70.0f};

/* The cross-checks use the ray-tracing pipeline, the API every target device has. */
static tnd_result pair_open(tnd_vk *vk, pair *p, const char *path)
{
    return pair_open_api(vk, p, path, FVK_RT_PIPELINE);
}

static void pair_close(pair *p)
{
    tnd_frame_destroy(&p->cpu);
    tnd_frame_destroy(&p->gpu);
    tnd_scene_state_free(&p->cur);
    tnd_scene_state_free(&p->prev);
    fvk_destroy(p->gv);
    femb_destroy(p->fe);
    tnd_scene_destroy(p->s);
    memset(p, 0, sizeof *p);
}

/* Render frame `frame` (time t, previous time tp) on both front-ends into p->cpu and p->gpu
 * (half: the indirect paths at half resolution). */
static tnd_result pair_frame_half(pair *p, uint32_t frame, double t, double tp, uint32_t w,
                                  uint32_t h, uint32_t bounces, bool half)
{
    tnd_frame_destroy(&p->cpu);
    tnd_frame_destroy(&p->gpu);
    tnd_result r = tnd_scene_evaluate(p->s, t, 0, (float)w / h, &p->cur);
    if (r == TND_OK)
        r = tnd_scene_evaluate(p->s, tp, 0, (float)w / h, &p->prev);
    if (r == TND_OK)
        r = test_embree_frame(p->fe, &p->cur, &p->prev, frame, w, h,
                              &(femb_params){.bounces = bounces, .half_indirect = half},
                              &p->cpu);
    if (r == TND_OK)
        r = fvk_set_frame(p->gv, &p->cur, &p->prev, frame, w, h);
    if (r == TND_OK)
        r = fvk_render(p->gv, &(fvk_params){.bounces = bounces, .half_indirect = half}, NULL);
    if (r == TND_OK)
        r = tnd_frame_create(w, h, &p->gpu);
    if (r == TND_OK)
        r = tnd_contract_download(p->vk, fvk_contract(p->gv), &p->gpu);
    return r;
}

static tnd_result pair_frame(pair *p, uint32_t frame, double t, double tp, uint32_t w, uint32_t h,
                             uint32_t bounces)
{
    return pair_frame_half(p, frame, t, tp, w, h, bounces, false);
}

static bool near3(const float *a, const float *b, float tol)
{
    return fabsf(a[0] - b[0]) <= tol && fabsf(a[1] - b[1]) <= tol && fabsf(a[2] - b[2]) <= tol;
}

/* tests/lambert_probe.h on the Vulkan front-end (test_lambert_emitters in test_frontend_embree
 * runs the same points on the Embree one): direct light from one- and two-sided emitters 1 mm to
 * 4 m away, at the origin and 1e2, 1e4, 1e5 from it, against Lambert's polygon irradiance. */
static void test_lambert_emitters_vk(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    lambert_probe_self_test();
    const double Ts[4] = {0, 1e2, 1e4, 1e5};
    enum { W = 128, H = 128, DISPATCHES = 48 / TND_TEST_SAMPLES_DIV };
    uint32_t *words = malloc(7 * W * H * sizeof *words);
    for (int t = 0; t < 4; t++) {
        lambert_probe lp;
        fvk_context *gv = NULL;
        tnd_scene_state st = {0};
        tnd_frame f = {0};
        REQUIRE(lambert_probe_open(&lp, Ts[t]), "probe scene: %s", tnd_error_detail());
        REQUIRE_OK(fvk_create(vk, lp.scene,
                              &(fvk_desc){.precision = TND_PRECISION_F32,
                                          .rt_api = FVK_RT_PIPELINE},
                              &gv));
        REQUIRE_OK(tnd_scene_evaluate(lp.scene, 0, 0, (float)W / H, &st));
        REQUIRE_OK(tnd_frame_create(W, H, &f));
        for (uint32_t d = 0; d < DISPATCHES; d++) {
            REQUIRE_OK(fvk_set_frame(gv, &st, &st, d, W, H));
            REQUIRE_OK(fvk_render(gv, &(fvk_params){.bounces = 1}, NULL));
            lambert_probe_samples(&lp, d, W * H, words);
            REQUIRE_OK(fvk_shade_gradients(gv, &(fvk_params){.bounces = 1}, words, W * H, NULL));
            REQUIRE_OK(tnd_contract_download(vk, fvk_contract(gv), &f));
            lambert_probe_add(&lp, &f, W * H);
        }
        lp_summary sm;
        lambert_probe_check(&lp, "vulkan", &sm, getenv("LP_VERBOSE") != NULL);
        lambert_probe_print("vulkan", &lp, &sm);
    cleanup:
        tnd_frame_destroy(&f);
        tnd_scene_state_free(&st);
        fvk_destroy(gv);
        lambert_probe_close(&lp);
    }
    free(words);
    gpu_end();
}

/* Every file of Debian's assimp-testmodels under glTF2/, OBJ/ and invalid/ (models and broken
 * files nobody here wrote): each imports and renders a frame in both front-ends, or fails with a
 * message that names the file; an imported one renders finite signals, and the two front-ends
 * see the same surface (visibility) on at least 99% of its pixels (the rest: triangle edges). No
 * crash (this runs under ASan and UBSan too). Prints the counts. */
static int walk_cmp(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static void test_assimp_testmodels(void)
{
    const char *root = "/usr/share/assimp/models";
    char dir_probe[256];
    snprintf(dir_probe, sizeof dir_probe, "%s/glTF2", root);
    if (access(dir_probe, R_OK) != 0) {
        printf("     skip: %s absent (assimp-testmodels: scripts/install-deps.sh)\n", dir_probe);
        return;
    }
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    char cmd[512];
    snprintf(cmd, sizeof cmd,
             "find %s/glTF2 %s/OBJ %s/invalid -type f \\( -name '*.gltf' -o -name '*.glb' -o "
             "-name '*.obj' -o -path '*/invalid/*' \\)",
             root, root, root);
    FILE *fp = popen(cmd, "r");
    REQUIRE(fp, "find");
    char line[1024], *files[512];
    int nf = 0;
    while (nf < 512 && fgets(line, sizeof line, fp)) {
        line[strcspn(line, "\n")] = 0;
        files[nf++] = strdup(line);
    }
    pclose(fp);
    qsort(files, (size_t)nf, sizeof *files, walk_cmp);
    int imported = 0, refused = 0, rendered = 0;
    enum { W = 48, H = 36 };
    for (int i = 0; i < nf; i++) {
        const char *path = files[i];
        tnd_scene *s = NULL;
        tnd_result r = tnd_scene_load(path, &s);
        if (r != TND_OK) {
            refused++;
            CHECK(strstr(tnd_error_detail(), path) != NULL, "%s: message without the file: %s",
                  path, tnd_error_detail());
            continue;
        }
        imported++;
        /* a fresh device per model (tests/gpu_common.h): on one shared device every model's
         * pipelines missed lavapipe's shader cache, its four variants compiled anew 40 times
         * (7-8 s a model cold, 472 s in all; 0.6 s a model warm) */
        if (imported > 1)
            REQUIRE((vk = gpu_fresh()) != NULL, "no context");
        femb_context *fe = NULL;
        fvk_context *gv = NULL;
        tnd_scene_state st = {0};
        tnd_frame a = {0}, b = {0};
        r = tnd_scene_evaluate(s, 0, 0, (float)W / H, &st);
        if (r == TND_OK)
            r = femb_create(s, &(femb_desc){.threads = 2}, &fe);
        if (r == TND_OK)
            r = test_embree_frame(fe, &st, &st, 0, W, H, &(femb_params){.bounces = 1}, &a);
        if (r == TND_OK)
            r = fvk_create(vk, s, &(fvk_desc){.precision = TND_PRECISION_F32,
                                              .rt_api = FVK_RT_PIPELINE}, &gv);
        if (r == TND_OK)
            r = fvk_set_frame(gv, &st, &st, 0, W, H);
        if (r == TND_OK)
            r = fvk_render(gv, &(fvk_params){.bounces = 1}, NULL);
        if (r == TND_OK)
            r = tnd_frame_create(W, H, &b);
        if (r == TND_OK)
            r = tnd_contract_download(vk, fvk_contract(gv), &b);
        CHECK(r == TND_OK, "%s: imported but not rendered: %s", path, tnd_error_detail());
        if (r == TND_OK) {
            rendered++;
            int same = 0, finite = 1;
            for (int q = 0; q < W * H; q++) {
                const uint32_t *va = tnd_frame_u(&a, TND_CT_VIS_ID) + 2 * q;
                const uint32_t *vb = tnd_frame_u(&b, TND_CT_VIS_ID) + 2 * q;
                same += va[0] == vb[0] && (va[0] == TND_VIS_NONE || va[1] == vb[1]);
                const tnd_ct chs[3] = {TND_CT_HF, TND_CT_LF_SH, TND_CT_SPEC};
                for (int k = 0; k < 3; k++) {
                    uint32_t m = tnd_ct_get(chs[k])->comps;
                    for (uint32_t j = 0; j < m; j++)
                        finite &= isfinite(tnd_frame_f(&a, chs[k])[m * q + j]) &&
                                  isfinite(tnd_frame_f(&b, chs[k])[m * q + j]);
                }
            }
            CHECK(finite, "%s: non-finite signals", path);
            CHECK(same >= 0.99 * W * H, "%s: front-ends see the same surface on %d of %d pixels",
                  path, same, W * H);
        }
        tnd_frame_destroy(&a);
        tnd_frame_destroy(&b);
        fvk_destroy(gv);
        femb_destroy(fe);
        tnd_scene_state_free(&st);
        tnd_scene_destroy(s);
    }
    printf("     assimp-testmodels: %d files: %d imported (%d rendered in both front-ends), %d "
           "refused with a message naming the file, 0 crashed\n",
           nf, imported, rendered, refused);
    CHECK(nf > 50 && imported > 10, "%d files, %d imported", nf, imported);
    for (int i = 0; i < nf; i++)
        free(files[i]);
    gpu_end();
}

/* G-buffer channels agree to float precision on at least 99% of the pixels (the rest are on
 * triangle edges, where the two traversals may report the neighbour). */
static void test_gbuffer_matches_embree(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    const char *scenes[] = {TND_SOURCE_DIR "/data/scenes/cornell.gltf",
                            TND_SOURCE_DIR "/data/scenes/materials.gltf",
                            TND_SOURCE_DIR "/data/scenes/dynamic.gltf",
                            TND_SOURCE_DIR "/data/scenes/cutout.gltf",
                            "/usr/share/assimp/models/glTF2/textureTransform/"
                            "TextureTransformTest.gltf"};
    for (int k = 0; k < 5; k++) {
        pair p;
        enum { W = 96, H = 54 };
        if (access(scenes[k], R_OK) != 0) { /* (assimp-testmodels: scripts/install-deps.sh) */
            printf("     skip: %s absent\n", scenes[k]);
            continue;
        }
        /* (each scene on a fresh device, so that its pipelines hit the shader cache that the
         * other tests and the command line fill: gpu_common.h) */
        if (k > 0)
            REQUIRE((vk = gpu_fresh()) != NULL, "no context");
        REQUIRE_OK(pair_open(vk, &p, scenes[k]));
        REQUIRE_OK(pair_frame(&p, 20, 20 / 30.0, 19 / 30.0, W, H, 1));
        int agree = 0, vis_diff = 0, n = W * H;
        double worst_depth = 0;
        for (int q = 0; q < n; q++) {
            const uint32_t *va = tnd_frame_u(&p.cpu, TND_CT_VIS_ID) + 2 * q;
            const uint32_t *vb = tnd_frame_u(&p.gpu, TND_CT_VIS_ID) + 2 * q;
            if (va[0] != vb[0] || va[1] != vb[1]) {
                vis_diff++;
                continue;
            }
            float da = tnd_frame_f(&p.cpu, TND_CT_DEPTH)[q], db = tnd_frame_f(&p.gpu, TND_CT_DEPTH)[q];
            bool ok = fabsf(da - db) <= 1e-4f * fabsf(da) + 1e-6f;
            if (va[0] != TND_VIS_NONE)
                worst_depth = fmax(worst_depth, fabs(da - db) / da);
            /* textures: the GPU's filtering weights are fixed point, hence 2e-3 on albedo */
            ok &= near3(tnd_frame_f(&p.cpu, TND_CT_ALBEDO) + 3 * q,
                        tnd_frame_f(&p.gpu, TND_CT_ALBEDO) + 3 * q, 2e-3f);
            ok &= near3(tnd_frame_f(&p.cpu, TND_CT_NORMAL) + 3 * q,
                        tnd_frame_f(&p.gpu, TND_CT_NORMAL) + 3 * q, 2e-3f);
            ok &= near3(tnd_frame_f(&p.cpu, TND_CT_GEO_NORMAL) + 3 * q,
                        tnd_frame_f(&p.gpu, TND_CT_GEO_NORMAL) + 3 * q, 1e-4f);
            ok &= near3(tnd_frame_f(&p.cpu, TND_CT_MOTION) + 3 * q,
                        tnd_frame_f(&p.gpu, TND_CT_MOTION) + 3 * q, 2e-3f);
            ok &= fabsf(tnd_frame_f(&p.cpu, TND_CT_VIS_BARY)[2 * q] -
                        tnd_frame_f(&p.gpu, TND_CT_VIS_BARY)[2 * q]) <= 1e-4f;
            ok &= memcmp(tnd_frame_u(&p.cpu, TND_CT_RNG) + 2 * q,
                         tnd_frame_u(&p.gpu, TND_CT_RNG) + 2 * q, 8) == 0;
            agree += ok;
        }
        printf("     %s: G-buffer agrees on %.2f%% of pixels (%d differ in visibility: triangle "
               "edges), worst relative depth difference %.1e\n",
               strrchr(scenes[k], '/') + 1, 100.0 * agree / n, vis_diff, worst_depth);
        CHECK(agree >= 0.99 * n, "%s: %d of %d pixels agree", scenes[k], agree, n);
    cleanup:
        pair_close(&p);
    }
    gpu_end();
}

/* The Vulkan front-end's motion vectors and depth on the extremes scene (everything 1e5 units
 * from the origin, the camera moving down to 0.07 units above the plane) against the same in
 * double precision from its own visibility buffer, each value within the bound of float
 * arithmetic done relative to the cameras (tests/motion_reference.h), as test_frontend_embree
 * checks the CPU front-end. Measured at most 0.11 of the bound on lavapipe (3e-5 px), 0.12 on
 * an H200 (3e-3 px, 8.7e-5 relative depth: its interpolated points differ by ulps); the shaders
 * that formed float world points were off by 2.6 px and 7% of the depth, 790 times the bound. */
static void test_motion_far_from_origin_vk(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    pair p;
    enum { W = 128, H = 72 };
    motion_error e = {0};
    REQUIRE_OK(pair_open(vk, &p, TND_SOURCE_DIR "/data/scenes/extremes.gltf"));
    for (uint32_t fr = 1; fr < 6; fr++) {
        tnd_frame_destroy(&p.gpu);
        REQUIRE_OK(tnd_scene_evaluate(p.s, fr / 30.0, 0, (float)W / H, &p.cur));
        REQUIRE_OK(tnd_scene_evaluate(p.s, (fr - 1) / 30.0, 0, (float)W / H, &p.prev));
        REQUIRE_OK(fvk_set_frame(p.gv, &p.cur, &p.prev, fr, W, H));
        REQUIRE_OK(fvk_render(p.gv, &(fvk_params){.bounces = 0}, NULL));
        REQUIRE_OK(tnd_frame_create(W, H, &p.gpu));
        REQUIRE_OK(tnd_contract_download(p.vk, fvk_contract(p.gv), &p.gpu));
        motion_reference_add(p.s, &p.cur, &p.prev, &p.gpu, &e);
    }
    motion_reference_check(&e, 5000);
cleanup:
    pair_close(&p);
    gpu_end();
}

/* The same path is traced: hf, lf and spec agree per pixel. Where they could not, a random
 * decision fell on the other side of a threshold through float rounding (lobe choice, light
 * pick, Russian roulette) or a ray grazed an edge. Measured: 100% on these scenes with one and
 * with three bounces (after the two front-ends' orthonormal bases were made to agree on normals
 * with z = -0, a divergence this test found); the floor is 99%. Relative tolerance 1e-3: float
 * rounding and the GPU's transcendentals. */
static void test_shading_matches_embree(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    const char *scenes[] = {TND_SOURCE_DIR "/data/scenes/cornell.gltf",
                            TND_SOURCE_DIR "/data/scenes/materials.gltf",
                            TND_SOURCE_DIR "/data/scenes/sun.gltf",
                            TND_SOURCE_DIR "/data/scenes/cutout.gltf"};
    for (int k = 0; k < 8; k++) {
        pair p;
        enum { W = 64, H = 36 };
#ifdef TND_SANITIZED
        /* (the sanitizers check the host's code, which the other cases run the same: there
         * materials, the environment and the cut-outs through both APIs) */
        if (k == 0 || k == 2 || k == 3 || k == 5)
            continue;
#endif
        uint32_t bounces = k == 3 || k == 5 || k == 7 ? 3 : 1;
        /* 4, 5: sun.gltf under forest.exr; 6, 7: the alpha cut-outs, through the pipeline's
         * any-hit shader and the ray query's candidate loop */
        const char *scene = scenes[k < 4 ? k % 3 : k < 6 ? 2 : 3];
        /* (7: ray queries where the device has them; the NVIDIA datacenter driver has none,
         * and auto then takes the pipeline) */
        /* (each case on a fresh device: its pipelines' keys in the shader cache are then the
         * same in both builds, which skip different cases: gpu_common.h) */
        REQUIRE((vk = gpu_fresh()) != NULL, "no context");
        REQUIRE_OK(pair_open_with(vk, &p, scene, k == 7 ? FVK_RT_AUTO : FVK_RT_PIPELINE,
                                  k == 4 || k == 5 ? &env_forest : NULL));
        REQUIRE_OK(pair_frame(&p, 11, 0.3, 0.3, W, H, bounces));
        const tnd_ct ch[4] = {TND_CT_HF, TND_CT_LF_SH, TND_CT_LF_COCG, TND_CT_SPEC};
        int agree[4] = {0}, n = 0;
        for (int q = 0; q < W * H; q++) {
            if (tnd_frame_u(&p.cpu, TND_CT_VIS_ID)[2 * q] != tnd_frame_u(&p.gpu, TND_CT_VIS_ID)[2 * q])
                continue;
            n++;
            for (int c = 0; c < 4; c++) {
                uint32_t comps = tnd_ct_get(ch[c])->comps;
                const float *a = tnd_frame_f(&p.cpu, ch[c]) + comps * q;
                const float *b = tnd_frame_f(&p.gpu, ch[c]) + comps * q;
                bool ok = true;
                for (uint32_t i = 0; i < comps; i++)
                    ok &= fabsf(a[i] - b[i]) <= 1e-3f * fmaxf(fabsf(a[i]), fabsf(b[i])) + 1e-6f;
                agree[c] += ok;
            }
        }
        printf("     %s%s, %u bounce%s: same-path agreement hf %.1f%%, lf %.1f%% / %.1f%%, "
               "spec %.1f%%\n",
               strrchr(scene, '/') + 1,
               k == 4 || k == 5                                   ? " under forest.exr"
               : k == 7 && fvk_api(p.gv) == FVK_RT_QUERY ? " (ray query)"
                                                          : "",
               bounces,
               bounces > 1 ? "s" : "",
               100.0 * agree[0] / n, 100.0 * agree[1] / n, 100.0 * agree[2] / n,
               100.0 * agree[3] / n);
        for (int c = 0; c < 4; c++)
            CHECK(agree[c] >= 0.99 * n, "%s: %s agrees on %d of %d pixels", scene,
                  tnd_ct_get(ch[c])->name, agree[c], n);
    cleanup:
        pair_close(&p);
    }
    gpu_end();
}

/* The shading pass is built for the bounces a frame asks, and for --bounces half or not
 * (fvk_pt.c need_passes; forced on here: lavapipe, a CPU device, builds one set of passes for
 * every count by default): a context built for one bounce and asked for three builds its passes
 * again, and shades exactly as one built for three from the start and as the unspecialised
 * passes; the counts give different signals, so a stale build could not pass. The same for a
 * frame of --bounces half after them. */
static void test_bounces_rebuilt(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    enum { W = 48, H = 27 };
    tnd_scene *s = NULL;
    fvk_context *a = NULL, *b = NULL, *g = NULL;
    tnd_scene_state st = {0};
    tnd_frame f1 = {0}, f3 = {0}, b3 = {0}, g3 = {0}, half[2] = {{0}};
    tnd_frame *out[4] = {&f1, &f3, &b3, &g3};
    REQUIRE_OK(tnd_scene_load(TND_SOURCE_DIR "/data/scenes/cornell.gltf", &s));
    REQUIRE_OK(tnd_scene_evaluate(s, 0.0, 0, (float)W / H, &st));
    REQUIRE_OK(fvk_create(vk, s,
                          &(fvk_desc){.precision = TND_PRECISION_F32,
                                      .specialise = FVK_SPECIALISE_ON},
                          &a));
    REQUIRE_OK(fvk_create(vk, s,
                          &(fvk_desc){.precision = TND_PRECISION_F32, .bounces = 3,
                                      .specialise = FVK_SPECIALISE_ON},
                          &b));
    REQUIRE_OK(fvk_create(vk, s,
                          &(fvk_desc){.precision = TND_PRECISION_F32,
                                      .specialise = FVK_SPECIALISE_OFF},
                          &g));
    const uint32_t bounces[4] = {1, 3, 3, 3};
    for (int i = 0; i < 4; i++) {
        fvk_context *c = i < 2 ? a : i == 2 ? b : g;
        REQUIRE_OK(fvk_set_frame(c, &st, &st, 5, W, H));
        REQUIRE_OK(fvk_render(c, &(fvk_params){.bounces = bounces[i]}, NULL));
        REQUIRE_OK(tnd_frame_create(W, H, out[i]));
        REQUIRE_OK(tnd_contract_download(vk, fvk_contract(c), out[i]));
    }
    const tnd_ct ch[4] = {TND_CT_HF, TND_CT_LF_SH, TND_CT_LF_COCG, TND_CT_SPEC};
    for (int k = 0; k < 4; k++) {
        size_t bytes = (size_t)W * H * tnd_ct_get(ch[k])->comps * sizeof(float);
        CHECK(memcmp(tnd_frame_f(&f3, ch[k]), tnd_frame_f(&b3, ch[k]), bytes) == 0,
              "%s: rebuilt for 3 bounces differs from built for 3", tnd_ct_get(ch[k])->name);
        CHECK(memcmp(tnd_frame_f(&g3, ch[k]), tnd_frame_f(&b3, ch[k]), bytes) == 0,
              "%s: the unspecialised passes differ from those built for 3 bounces",
              tnd_ct_get(ch[k])->name);
    }
    size_t lf = (size_t)W * H * tnd_ct_get(TND_CT_LF_SH)->comps * sizeof(float);
    CHECK(memcmp(tnd_frame_f(&f1, TND_CT_LF_SH), tnd_frame_f(&f3, TND_CT_LF_SH), lf) != 0,
          "1 and 3 bounces give the same indirect light");
    /* --bounces half: the passes built for it again (constant 2), as the unspecialised ones */
    for (int i = 0; i < 2; i++) {
        fvk_context *c = i ? g : a;
        REQUIRE_OK(fvk_render(c, &(fvk_params){.bounces = 1, .half_indirect = true}, NULL));
        REQUIRE_OK(tnd_frame_create(W, H, &half[i]));
        REQUIRE_OK(tnd_contract_download(vk, fvk_contract(c), &half[i]));
    }
    for (int k = 0; k < 4; k++) {
        size_t bytes = (size_t)W * H * tnd_ct_get(ch[k])->comps * sizeof(float);
        CHECK(memcmp(tnd_frame_f(&half[0], ch[k]), tnd_frame_f(&half[1], ch[k]), bytes) == 0,
              "%s: built for --bounces half differs from the unspecialised passes",
              tnd_ct_get(ch[k])->name);
    }
    CHECK(memcmp(tnd_frame_f(&f1, TND_CT_LF_SH), tnd_frame_f(&half[0], TND_CT_LF_SH), lf) != 0,
          "--bounces half gives the indirect light of 1");
cleanup:
    for (int i = 0; i < 4; i++)
        tnd_frame_destroy(out[i]);
    tnd_frame_destroy(&half[0]);
    tnd_frame_destroy(&half[1]);
    tnd_scene_state_free(&st);
    fvk_destroy(a);
    fvk_destroy(b);
    fvk_destroy(g);
    tnd_scene_destroy(s);
    gpu_end();
}

/* The indirect paths at half resolution (`--bounces half`), on both front-ends: in frame f the
 * pixels where x + y + f is even trace theirs, weighted 2 (their lf exactly twice that of
 * `--bounces 1`, their spec_hit the same), the others trace none (lf 0, spec that of NEE
 * alone, spec_hit 0); direct light (hf) is the same everywhere. An odd height (27) tests the launch's
 * pairs of rows. Each half frame is rendered after frames of other random numbers, so a pixel
 * the pass missed would keep values that fail. Then the two front-ends agree as in
 * test_shading_matches_embree, and gradient samples of a half frame, re-shaded in the next with
 * its own choice, give back its values. */
static void check_half(const tnd_frame *h, const tnd_frame *one,
                       uint32_t frame, int W, int H, const char *who)
{
    int wrong = 0, traced = 0, lit = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t q = (size_t)y * W + x;
            bool t = ((x + y + frame) & 1) == 0, ok = true;
            for (int k = 0; k < 3; k++)
                ok &= tnd_frame_f(h, TND_CT_HF)[3 * q + k] ==
                      tnd_frame_f(one, TND_CT_HF)[3 * q + k];
            for (int k = 0; k < 4; k++) {
                float a = tnd_frame_f(h, TND_CT_LF_SH)[4 * q + k];
                ok &= a == (t ? 2.0f * tnd_frame_f(one, TND_CT_LF_SH)[4 * q + k] : 0.0f);
                lit += t && k == 3 && a != 0.0f;
            }
            for (int k = 0; k < 2; k++)
                ok &= tnd_frame_f(h, TND_CT_LF_COCG)[2 * q + k] ==
                      (t ? 2.0f * tnd_frame_f(one, TND_CT_LF_COCG)[2 * q + k] : 0.0f);
            float hit = tnd_frame_f(h, TND_CT_SPEC_HIT)[q];
            ok &= hit == (t ? tnd_frame_f(one, TND_CT_SPEC_HIT)[q] : 0.0f);
            /* an untraced pixel's spec is its NEE alone, MIS-weighted as with a path after it
             * (the traced half carries the BRDF's share, twice): `--bounces 1`'s where that
             * one's sample took the diffuse lobe (spec_hit 0: no specular bounce added) */
            for (int k = 0; k < 3 && !t && tnd_frame_f(one, TND_CT_SPEC_HIT)[q] == 0.0f; k++)
                ok &= tnd_frame_f(h, TND_CT_SPEC)[3 * q + k] ==
                      tnd_frame_f(one, TND_CT_SPEC)[3 * q + k];
            traced += t;
            wrong += !ok;
        }
    printf("     %s, frame %u: %d of %d pixels traced, %d of them lit indirectly; %d wrong\n", who,
           frame, traced, W * H, lit, wrong);
    CHECK(wrong == 0, "%s, frame %u: %d pixels not as --bounces half shades them", who, frame,
          wrong);
    /* (not an empty test: cornell's one bounce reaches a lit surface from 17-19% of them) */
    CHECK(lit >= traced / 8, "%s, frame %u: %d of %d traced pixels lit indirectly", who, frame,
          lit, traced);
}

static void test_half_indirect(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    enum { W = 48, H = 27 };
    pair p;
    /* [frame][cpu, gpu]; `zero` (0 bounces) are the frames of other random numbers rendered
     * between */
    tnd_frame one[2][2] = {{{0}}}, zero[2][2] = {{{0}}}, half[2][2] = {{{0}}};
    uint32_t samples[7 * 60], n = 0;
    REQUIRE_OK(pair_open(vk, &p, TND_SOURCE_DIR "/data/scenes/cornell.gltf"));
    for (int f = 0; f < 2; f++) {
        for (int b = 0; b < 2; b++) {
            REQUIRE_OK(pair_frame(&p, 5 + f, 1.0, 1.0, W, H, 1 - b));
            tnd_frame *o = b ? zero[f] : one[f];
            o[0] = p.cpu, o[1] = p.gpu; /* (the pair's frames kept: new ones next) */
            memset(&p.cpu, 0, sizeof p.cpu);
            memset(&p.gpu, 0, sizeof p.gpu);
        }
    }
    for (int f = 0; f < 2; f++) {
        REQUIRE_OK(pair_frame_half(&p, 5 + f, 1.0, 1.0, W, H, 1, true));
        half[f][0] = p.cpu, half[f][1] = p.gpu;
        memset(&p.cpu, 0, sizeof p.cpu);
        memset(&p.gpu, 0, sizeof p.gpu);
        for (int k = 0; k < 2; k++)
            check_half(&half[f][k], &one[f][k], 5 + f, W, H,
                       k ? "Vulkan" : "Embree");
        int agree = 0, same = 0;
        for (int q = 0; q < W * H; q++) {
            if (tnd_frame_u(&half[f][0], TND_CT_VIS_ID)[2 * q] !=
                tnd_frame_u(&half[f][1], TND_CT_VIS_ID)[2 * q])
                continue;
            same++;
            const float *a = tnd_frame_f(&half[f][0], TND_CT_LF_SH) + 4 * q;
            const float *b = tnd_frame_f(&half[f][1], TND_CT_LF_SH) + 4 * q;
            bool ok = true;
            for (int i = 0; i < 4; i++)
                ok &= fabsf(a[i] - b[i]) <= 1e-3f * fmaxf(fabsf(a[i]), fabsf(b[i])) + 1e-6f;
            agree += ok;
        }
        CHECK(agree >= 0.99 * same, "frame %d: lf of the two front-ends agrees on %d of %d", 5 + f,
              agree, same);
    }
    /* gradient samples of frame 5 (half), both parities, re-shaded in frame 6 */
    for (uint32_t q = 0; q < W * H && n < 60; q += 13) {
        if (tnd_frame_u(&half[0][1], TND_CT_VIS_ID)[2 * q] == TND_VIS_NONE)
            continue;
        uint32_t *g = samples + 7 * n++;
        g[0] = q;
        g[1] = tnd_frame_u(&half[0][1], TND_CT_RNG)[2 * q];
        g[2] = tnd_frame_u(&half[0][1], TND_CT_RNG)[2 * q + 1];
        g[3] = tnd_frame_u(&half[0][1], TND_CT_VIS_ID)[2 * q];
        g[4] = tnd_frame_u(&half[0][1], TND_CT_VIS_ID)[2 * q + 1];
        memcpy(&g[5], tnd_frame_f(&half[0][1], TND_CT_VIS_BARY) + 2 * q, 8);
    }
    REQUIRE_OK(pair_frame_half(&p, 6, 1.0, 1.0, W, H, 1, true));
    REQUIRE_OK(fvk_shade_gradients(p.gv, &(fvk_params){.bounces = 1, .half_indirect = true},
                                   samples, n, NULL));
    REQUIRE_OK(tnd_contract_download(vk, fvk_contract(p.gv), &p.gpu));
    femb_gradient_sample fg[60];
    femb_gradient_unpack(samples, n, fg);
    REQUIRE_OK(femb_shade_gradients(p.fe, &(femb_params){.bounces = 1, .half_indirect = true}, fg,
                                    n, &p.cpu));
    int bad[2] = {0, 0};
    for (uint32_t i = 0; i < n; i++) {
        size_t q = samples[7 * i];
        for (int k = 0; k < 2; k++) {
            const tnd_frame *now = k ? &p.gpu : &p.cpu, *was = &half[0][k];
            bool close = true;
            const tnd_ct chs[3] = {TND_CT_HF, TND_CT_LF_SH, TND_CT_SPEC};
            for (int c = 0; c < 3; c++) {
                uint32_t m = tnd_ct_get(chs[c])->comps;
                for (uint32_t j = 0; j < m; j++) {
                    float a = tnd_frame_f(was, chs[c])[m * q + j],
                          b = tnd_frame_f(now, chs[c])[m * q + j];
                    close &= fabsf(a - b) <= 1e-4f * fmaxf(fabsf(a), 1e-6f);
                }
            }
            bad[k] += !close;
        }
    }
    printf("     %u gradient samples of a half frame: %d (Embree), %d (Vulkan) differ\n", n,
           bad[0], bad[1]);
    CHECK(n > 30, "samples taken (%u)", n);
    CHECK(bad[0] == 0 && bad[1] == 0, "gradient samples of a half frame differ: %d, %d", bad[0],
          bad[1]);
cleanup:
    for (int f = 0; f < 2; f++)
        for (int k = 0; k < 2; k++) {
            tnd_frame_destroy(&one[f][k]);
            tnd_frame_destroy(&zero[f][k]);
            tnd_frame_destroy(&half[f][k]);
        }
    pair_close(&p);
    gpu_end();
}

/* Gradient samples on the GPU reproduce the previous frame's shading exactly. */
static void test_gpu_gradient_samples(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    pair p;
    tnd_frame prev = {0};
    enum { W = 48, H = 27 };
    uint32_t samples[7 * 40];
    uint32_t n = 0;
    REQUIRE_OK(pair_open(vk, &p, TND_SOURCE_DIR "/data/scenes/cornell.gltf"));
    REQUIRE_OK(pair_frame(&p, 5, 1.0, 1.0, W, H, 1));
    REQUIRE_OK(tnd_frame_create(W, H, &prev));
    REQUIRE_OK(tnd_contract_download(vk, fvk_contract(p.gv), &prev));
    for (uint32_t q = 0; q < W * H && n < 40; q += 31) {
        if (tnd_frame_u(&prev, TND_CT_VIS_ID)[2 * q] == TND_VIS_NONE)
            continue;
        uint32_t *g = samples + 7 * n++;
        g[0] = q;
        g[1] = tnd_frame_u(&prev, TND_CT_RNG)[2 * q];
        g[2] = tnd_frame_u(&prev, TND_CT_RNG)[2 * q + 1];
        g[3] = tnd_frame_u(&prev, TND_CT_VIS_ID)[2 * q];
        g[4] = tnd_frame_u(&prev, TND_CT_VIS_ID)[2 * q + 1];
        memcpy(&g[5], tnd_frame_f(&prev, TND_CT_VIS_BARY) + 2 * q, 8);
    }
    REQUIRE_OK(pair_frame(&p, 6, 1.0, 1.0, W, H, 1));
    REQUIRE_OK(fvk_shade_gradients(p.gv, &(fvk_params){.bounces = 1}, samples, n, NULL));
    REQUIRE_OK(tnd_contract_download(vk, fvk_contract(p.gv), &p.gpu));
    /* the same numbers up to float rounding: the primary and shading passes evaluate the surface
     * in two shaders, and a driver may contract (fuse) their arithmetic differently (NVIDIA
     * does; lavapipe gives identical bits). A wrong surface or key differs by far more. */
    int bad = 0, exact = 0;
    double worst = 0;
    const tnd_ct chs[3] = {TND_CT_HF, TND_CT_LF_SH, TND_CT_SPEC};
    for (uint32_t i = 0; i < n; i++) {
        size_t q = samples[7 * i];
        bool same = true, close = true;
        for (int k = 0; k < 3; k++) {
            uint32_t m = tnd_ct_get(chs[k])->comps;
            const float *a = tnd_frame_f(&prev, chs[k]) + m * q, *b = tnd_frame_f(&p.gpu, chs[k]) + m * q;
            for (uint32_t j = 0; j < m; j++) {
                double d = fabs((double)a[j] - b[j]) / fmax(fabs((double)a[j]), 1e-6);
                worst = fmax(worst, d);
                same &= a[j] == b[j];
                close &= d <= 1e-4;
            }
        }
        exact += same;
        bad += !close;
    }
    printf("     %u gradient samples: %d bit-exact, worst relative difference %.2e\n", n, exact,
           worst);
    CHECK(n > 10, "samples taken (%u)", n);
    CHECK(bad == 0, "%d of %u GPU gradient samples differ from the previous frame", bad, n);
cleanup:
    tnd_frame_destroy(&prev);
    pair_close(&p);
    gpu_end();
}

/* Over many frames the per-pixel means of both front-ends agree within their confidence bounds,
 * and both reference modes converge to the same image. */
static void means_and_references(tnd_vk *vk, const char *path, const tnd_scene_options *o,
                                 const char *name)
{
    pair p;
    enum { W = 32, H = 18, N = 24, SPP = 32 };
    static double sa[W * H], sb[W * H], qa[W * H], qb[W * H];
    static float ca[W * H * 3], cb[W * H * 3], ra[W * H * 3], rb[W * H * 3];
    memset(sa, 0, sizeof sa), memset(sb, 0, sizeof sb), memset(qa, 0, sizeof qa), memset(qb, 0, sizeof qb);
    REQUIRE_OK(pair_open_with(vk, &p, path, FVK_RT_PIPELINE, o));
    for (uint32_t i = 0; i < N; i++) {
        REQUIRE_OK(pair_frame(&p, i, 0.0, 0.0, W, H, 2));
        tnd_frame_composite(&p.cpu, ca);
        tnd_frame_composite(&p.gpu, cb);
        for (int q = 0; q < W * H; q++) {
            double a = tnd_luminance(ca[3 * q], ca[3 * q + 1], ca[3 * q + 2]);
            double b = tnd_luminance(cb[3 * q], cb[3 * q + 1], cb[3 * q + 2]);
            sa[q] += a, qa[q] += a * a, sb[q] += b, qb[q] += b * b;
        }
    }
    int outside = 0;
    for (int q = 0; q < W * H; q++) {
        double ma = sa[q] / N, mb = sb[q] / N;
        double se = sqrt(fmax(qa[q] / N - ma * ma, 0) / N + fmax(qb[q] / N - mb * mb, 0) / N);
        outside += fabs(ma - mb) > 4 * se + 1e-5 * fmax(ma, mb) + 1e-7;
    }
    CHECK(outside == 0, "%s: %d pixel means differ beyond 4 standard errors", name, outside);
    static float sea[W * H], seb[W * H];
    if (!o) {
        /* a matched reference (2 bounces, as the frames above) is the real-time estimator's
         * expectation: the image means agree within 4 standard errors (the frames' spread, the
         * reference's own) */
        femb_set_reference_bounces(p.fe, 2);
        fvk_set_reference_bounces(p.gv, 2);
        REQUIRE_OK(femb_reference(p.fe, SPP, ra, sea, NULL, NULL, NULL));
        REQUIRE_OK(fvk_reference(p.gv, SPP, rb, seb, NULL, NULL, NULL));
        double mr = 0, mrb = 0, mt = 0, vr = 0, vt = 0;
        for (int q = 0; q < W * H; q++) {
            mr += tnd_luminance(ra[3 * q], ra[3 * q + 1], ra[3 * q + 2]) / (W * H);
            mrb += tnd_luminance(rb[3 * q], rb[3 * q + 1], rb[3 * q + 2]) / (W * H);
            vr += (double)sea[q] * sea[q] / ((double)W * H * W * H);
            double m = sa[q] / N;
            mt += m / (W * H);
            vt += fmax(qa[q] / N - m * m, 0) / N / ((double)W * H * W * H);
        }
        double se = sqrt(vr + vt);
        printf("     %s: real-time mean %.5f, matched reference (2 bounces) %.5f / %.5f "
               "(se %.2g)\n",
               name, mt, mr, mrb, se);
        CHECK(fabs(mt - mr) < 4 * se, "%s: the real-time mean %.5f is not the matched "
              "reference's %.5f", name, mt, mr);
        CHECK(fabs(mr - mrb) < 1e-4 * mr, "%s: matched references differ", name);
        femb_set_reference_bounces(p.fe, 0);
        fvk_set_reference_bounces(p.gv, 0);
    }
    REQUIRE_OK(femb_reference(p.fe, SPP, ra, sea, NULL, NULL, NULL));
    REQUIRE_OK(fvk_reference(p.gv, SPP, rb, seb, NULL, NULL, NULL));
    double worst = 0;
    int apart = 0, beyond = 0;
    for (int k = 0; k < W * H * 3; k++) {
        double d = fabs(ra[k] - rb[k]) / (fabs(ra[k]) + 1e-3);
        worst = fmax(worst, d);
        apart += d > 1e-3;
    }
    for (int q = 0; q < W * H; q++) {
        double la = tnd_luminance(ra[3 * q], ra[3 * q + 1], ra[3 * q + 2]);
        double lb = tnd_luminance(rb[3 * q], rb[3 * q + 1], rb[3 * q + 2]);
        beyond += fabs(la - lb) > 4 * sqrt((double)sea[q] * sea[q] + (double)seb[q] * seb[q]) +
                                      1e-5 * fmax(la, lb);
    }
    printf("     %s: references (%d spp): worst relative difference %.2e (same paths), %d of %d "
           "values beyond 1e-3, %d pixels beyond 4 se\n",
           name, SPP, worst, apart, W * H * 3, beyond);
    if (!o || !o->env) {
        /* the two references trace the same paths: only float rounding separates them */
        CHECK(worst < 1e-3, "%s: references differ by %.3g", name, worst);
    } else {
        /* an environment map's texel is found from the direction by atan2 and acos, which a
         * GPU computes to a few ulps: a direction within those of a texel's edge finds the
         * neighbour on one side (sample_cosine's cos and sin move directions by as much), so
         * some samples see another texel; the paths stay the same, and the pixels agree in
         * distribution */
        CHECK(apart < W * H * 3 / 3, "%s: %d values apart", name, apart);
        CHECK(beyond == 0, "%s: %d pixels differ beyond 4 standard errors", name, beyond);
    }
cleanup:
    pair_close(&p);
}

/* The light tree (--lights tree) against the power table on many_lights.gltf (348 emitters),
 * matched references of the real-time estimator (1 bounce) on both front-ends: the two picks
 * are two unbiased estimators of one expectation, so the image means agree within 4 standard
 * errors (from the references' per-pixel errors); the tree's per-pixel variance is lower (the
 * point of it: measured 0.62x the table's here, 0.44x at 96x54 with 1024 samples); and the two
 * front-ends' tree references,
 * which trace the same paths but for the float rounding of the importances, agree pixel by pixel
 * within 4 standard errors. */
static void test_light_tree_unbiased(void)
{
    enum { W = 48, H = 27, SPP = 64 };
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    tnd_scene *s = NULL;
    tnd_scene_state cur = {0}, prev = {0};
    femb_context *fe[2] = {NULL, NULL};
    fvk_context *gv[2] = {NULL, NULL};
    static float rgb[4][W * H * 3], se[4][W * H];
    REQUIRE_OK(tnd_scene_load(TND_SOURCE_DIR "/data/scenes/many_lights.gltf", &s));
    REQUIRE_OK(tnd_scene_evaluate(s, 1.0, 0, (float)W / H, &cur));
    REQUIRE_OK(tnd_scene_evaluate(s, 1.0 - 1.0 / 30, 0, (float)W / H, &prev));
    const tnd_light_sampling mode[2] = {TND_LIGHTS_PLAIN, TND_LIGHTS_TREE};
    for (int m = 0; m < 2; m++) {
        REQUIRE_OK(femb_create(s, &(femb_desc){.threads = 2, .lights = mode[m]}, &fe[m]));
        REQUIRE_OK(fvk_create(vk, s,
                              &(fvk_desc){.precision = TND_PRECISION_F32,
                                          .rt_api = FVK_RT_PIPELINE, .lights = mode[m]},
                              &gv[m]));
        REQUIRE_OK(femb_set_frame(fe[m], &cur, &prev, 30, W, H));
        REQUIRE_OK(fvk_set_frame(gv[m], &cur, &prev, 30, W, H));
        femb_set_reference_bounces(fe[m], 1);
        fvk_set_reference_bounces(gv[m], 1);
        REQUIRE_OK(femb_reference(fe[m], SPP, rgb[2 * m], se[2 * m], NULL, NULL, NULL));
        REQUIRE_OK(fvk_reference(gv[m], SPP, rgb[2 * m + 1], se[2 * m + 1], NULL, NULL, NULL));
    }
    double mean[4] = {0}, var[4] = {0}; /* image mean luminance, its variance; pixel variance */
    double pv[4] = {0};
    for (int k = 0; k < 4; k++)
        for (int q = 0; q < W * H; q++) {
            const float *c = rgb[k] + 3 * q;
            mean[k] += tnd_luminance(c[0], c[1], c[2]) / (W * H);
            var[k] += (double)se[k][q] * se[k][q] / ((double)W * H * W * H);
            pv[k] += (double)se[k][q] * se[k][q] * SPP / (W * H);
        }
    const char *name[4] = {"embree plain", "vk plain", "embree tree", "vk tree"};
    printf("     many_lights %dx%d, %d spp: image mean (standard error), mean pixel variance:\n",
           W, H, SPP);
    for (int k = 0; k < 4; k++)
        printf("       %-12s %.5f (%.5f) %.4f\n", name[k], mean[k], sqrt(var[k]), pv[k]);
    for (int f = 0; f < 2; f++) { /* tree against plain on each front-end */
        double d = fabs(mean[2 + f] - mean[f]), lim = 4 * sqrt(var[2 + f] + var[f]);
        CHECK(d <= lim, "%s: the tree's mean %.5f is %.2g from the table's %.5f (4 se %.2g)",
              f ? "vk" : "embree", mean[2 + f], d, mean[f], lim);
        CHECK(pv[2 + f] < 0.7 * pv[f], "%s: the tree's pixel variance %.4f is not under 0.7x "
              "the table's %.4f", f ? "vk" : "embree", pv[2 + f], pv[f]);
    }
    int beyond = 0;
    for (int q = 0; q < W * H; q++) {
        const float *a = rgb[2] + 3 * q, *b = rgb[3] + 3 * q;
        double la = tnd_luminance(a[0], a[1], a[2]), lb = tnd_luminance(b[0], b[1], b[2]);
        beyond += fabs(la - lb) > 4 * sqrt((double)se[2][q] * se[2][q] +
                                           (double)se[3][q] * se[3][q]) + 1e-5 * fmax(la, lb);
    }
    printf("     the two front-ends' tree references: %d of %d pixels beyond 4 standard errors\n",
           beyond, W * H);
    CHECK(beyond <= W * H / 200, "the front-ends' tree references differ at %d pixels", beyond);
cleanup:
    for (int m = 0; m < 2; m++) {
        femb_destroy(fe[m]);
        fvk_destroy(gv[m]);
    }
    tnd_scene_state_free(&cur);
    tnd_scene_state_free(&prev);
    tnd_scene_destroy(s);
    gpu_end();
}

/* ReSTIR DI runs the same algorithm on the same random numbers in both front-ends
 * (femb_restir.c, pt_restir.glsl): on many_lights seen still, with one bounce (the reservoirs at
 * the primary surface, the bounce's BRDF sample giving the list's emitters no weight), the means
 * of their frames agree over the image and in each quarter within 4 standard errors (from the
 * frames' variance times the integrated autocorrelation time, as test_restir_unbiased: the frames
 * reuse each other's reservoirs). The Embree side is tested against next-event estimation there;
 * so the Vulkan side is unbiased too. Per frame the two are not equal: float rounding (the GPU's
 * FMA, its own sqrt) tips a choice between two candidates now and then, and the reuse carries the
 * difference on; how close they are is printed. */
enum { RQ_W = 48, RQ_H = 27, RQ_FRAMES = 128 / TND_TEST_SAMPLES_DIV };
static void rq_stats(double lum[][5], uint32_t n, int k, double *mean, double *se)
{
    double m = 0, var = 0, tau = 1;
    for (uint32_t i = 0; i < n; i++)
        m += lum[i][k] / n;
    for (uint32_t i = 0; i < n; i++)
        var += (lum[i][k] - m) * (lum[i][k] - m) / (n - 1);
    for (uint32_t lag = 1; lag < n / 4 && var > 0; lag++) {
        double r = 0;
        for (uint32_t i = 0; i + lag < n; i++)
            r += (lum[i][k] - m) * (lum[i + lag][k] - m) / (n - lag);
        if (r / var < 0.05)
            break;
        tau += 2 * r / var;
    }
    *mean = m, *se = sqrt(var * tau / n);
}

static void test_restir_agrees(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    tnd_scene *s = NULL;
    tnd_scene_state st = {0};
    femb_context *fe = NULL;
    fvk_context *gv = NULL;
    tnd_frame a = {0}, b = {0};
    static double lum[2][RQ_FRAMES][5];
    static float ca[RQ_W * RQ_H * 3], cb[RQ_W * RQ_H * 3];
    REQUIRE_OK(tnd_scene_load(TND_SOURCE_DIR "/data/scenes/many_lights.gltf", &s));
    REQUIRE_OK(tnd_scene_evaluate(s, 1.0, 0, (float)RQ_W / RQ_H, &st));
    REQUIRE_OK(femb_create(s, &(femb_desc){.threads = 2, .lights = TND_LIGHTS_RESTIR}, &fe));
    REQUIRE_OK(fvk_create(vk, s,
                          &(fvk_desc){.precision = TND_PRECISION_F32, .rt_api = FVK_RT_PIPELINE,
                                      .lights = TND_LIGHTS_RESTIR},
                          &gv));
    CHECK(strstr(fvk_variant(gv), "reservoirs") != NULL, "the variant names the reservoirs: %s",
          fvk_variant(gv));
    double diff = 0, mean_a = 0;
    memset(lum, 0, sizeof lum);
    for (uint32_t i = 0; i < RQ_FRAMES; i++) {
        tnd_frame_destroy(&a);
        tnd_frame_destroy(&b);
        REQUIRE_OK(test_embree_frame(fe, &st, &st, i, RQ_W, RQ_H, &(femb_params){.bounces = 1},
                                     &a));
        REQUIRE_OK(fvk_set_frame(gv, &st, &st, i, RQ_W, RQ_H));
        REQUIRE_OK(fvk_render(gv, &(fvk_params){.bounces = 1}, NULL));
        REQUIRE_OK(tnd_frame_create(RQ_W, RQ_H, &b));
        REQUIRE_OK(tnd_contract_download(vk, fvk_contract(gv), &b));
        tnd_frame_composite(&a, ca);
        tnd_frame_composite(&b, cb);
        for (uint32_t q = 0; q < RQ_W * RQ_H; q++) {
            uint32_t x = q % RQ_W, y = q / RQ_W, quarter = 1 + (x >= RQ_W / 2) + 2 * (y >= RQ_H / 2);
            double la = tnd_luminance(ca[3 * q], ca[3 * q + 1], ca[3 * q + 2]);
            double lb = tnd_luminance(cb[3 * q], cb[3 * q + 1], cb[3 * q + 2]);
            lum[0][i][0] += la / (RQ_W * RQ_H), lum[1][i][0] += lb / (RQ_W * RQ_H);
            lum[0][i][quarter] += 4 * la / (RQ_W * RQ_H);
            lum[1][i][quarter] += 4 * lb / (RQ_W * RQ_H);
            diff += fabs(la - lb) / ((double)RQ_W * RQ_H * RQ_FRAMES);
            mean_a += la / ((double)RQ_W * RQ_H * RQ_FRAMES);
        }
    }
    printf("     many_lights %dx%d, 1 bounce, %d frames: per pixel and frame the two differ by "
           "%.3g%% of the mean on average\n", RQ_W, RQ_H, RQ_FRAMES, 100 * diff / mean_a);
    const char *where[5] = {"image", "top left", "top right", "bottom left", "bottom right"};
    for (int k = 0; k < 5; k++) {
        double ma, sa, mb, sb;
        rq_stats(lum[0], RQ_FRAMES, k, &ma, &sa);
        rq_stats(lum[1], RQ_FRAMES, k, &mb, &sb);
        double err = sqrt(sa * sa + sb * sb);
        printf("       %-12s embree %.5f, vk %.5f: %+.2f se\n", where[k], ma, mb, (mb - ma) / err);
        CHECK(fabs(mb - ma) <= 4 * err, "%s: the Vulkan reservoirs' mean %.5f is %.2g from "
              "Embree's %.5f (4 se %.2g)", where[k], mb, fabs(mb - ma), ma, 4 * err);
    }
cleanup:
    tnd_frame_destroy(&a);
    tnd_frame_destroy(&b);
    femb_destroy(fe);
    fvk_destroy(gv);
    tnd_scene_state_free(&st);
    tnd_scene_destroy(s);
    gpu_end();
}

static void test_means_and_references_agree(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    means_and_references(vk, TND_SOURCE_DIR "/data/scenes/cornell.gltf", NULL, "cornell");
    means_and_references(vk, TND_SOURCE_DIR "/data/scenes/sun.gltf", &env_forest,
                         "sun under forest.exr");
    gpu_end();
}

/* The ray-query compute twins give the same contract as the ray-tracing pipeline (lavapipe has
 * both; the NVIDIA datacenter driver has no ray query, so there auto picks the pipeline). */
static void test_query_matches_pipeline(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    if (!vk->ray_query) {
        printf("     device has no ray query: nothing to compare\n");
        gpu_end();
        return;
    }
    pair a, b;
    enum { W = 64, H = 36 };
    REQUIRE_OK(pair_open_api(vk, &a, TND_SOURCE_DIR "/data/scenes/materials.gltf", FVK_RT_PIPELINE));
    REQUIRE_OK(pair_open_api(vk, &b, TND_SOURCE_DIR "/data/scenes/materials.gltf", FVK_RT_QUERY));
    CHECK(fvk_api(a.gv) == FVK_RT_PIPELINE && fvk_api(b.gv) == FVK_RT_QUERY, "APIs as asked");
    REQUIRE_OK(pair_frame(&a, 9, 0.5, 0.45, W, H, 2));
    REQUIRE_OK(pair_frame(&b, 9, 0.5, 0.45, W, H, 2));
    for (int e = 0; e < TND_CT_COUNT; e++) {
        size_t n = (size_t)W * H * tnd_ct_get((tnd_ct)e)->comps;
        size_t diff = 0;
        for (size_t k = 0; k < n; k++)
            diff += memcmp((const uint32_t *)a.gpu.data[e] + k, (const uint32_t *)b.gpu.data[e] + k, 4) != 0;
        CHECK(diff == 0, "'%s': %zu of %zu values differ between pipeline and query",
              tnd_ct_get((tnd_ct)e)->name, diff, n);
    }
cleanup:
    pair_close(&a);
    pair_close(&b);
    gpu_end();
}

/* The Lambert sphere under a uniform sky and a constant environment map, as in the Embree
 * front-end's test (tests/env_sphere.h): the albedo within 0.5% in the reference mode. */
static tnd_result env_sphere_render(tnd_scene *s, const tnd_scene_state *st, float *rgb,
                                    void *user)
{
    fvk_context *gv = NULL;
    tnd_result r = fvk_create(user, s,
                              &(fvk_desc){.precision = TND_PRECISION_F32,
                                          .rt_api = FVK_RT_PIPELINE},
                              &gv);
    if (r == TND_OK)
        r = fvk_set_frame(gv, st, st, 0, ES_W, ES_H);
    if (r == TND_OK)
        r = fvk_reference(gv, 64, rgb, NULL, NULL, NULL, NULL);
    fvk_destroy(gv);
    return r;
}

static void test_env_sphere_vk(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    es_run("vulkan", env_sphere_render, vk);
    gpu_end();
}

/* The atrium (scripts/make_scenes.py: 528k triangles traced, a real HDRI through the roof's
 * opening, the sun, MASK and BLEND cut-outs) at 256 x 256 halfway along its camera path: the two
 * front-ends see the same surface on at least 99.5% of the pixels (the rest: triangle edges),
 * and their shading agrees sample for sample on 99% of those. */
static void test_atrium_agrees(void)
{
    tnd_vk *vk = gpu_begin();
    REQUIRE(vk, "no context");
    pair p;
    enum { W = 256, H = 256 };
    REQUIRE_OK(pair_open(vk, &p, TND_SOURCE_DIR "/data/scenes/atrium.gltf"));
    REQUIRE_OK(pair_frame(&p, 60, 2.0, 2.0 - 1 / 30.0, W, H, 1));
    int same = 0, agree = 0, n = W * H;
    for (int q = 0; q < n; q++) {
        const uint32_t *va = tnd_frame_u(&p.cpu, TND_CT_VIS_ID) + 2 * q;
        const uint32_t *vb = tnd_frame_u(&p.gpu, TND_CT_VIS_ID) + 2 * q;
        if (va[0] != vb[0] || (va[0] != TND_VIS_NONE && va[1] != vb[1]))
            continue;
        same++;
        bool ok = true;
        const tnd_ct ch[3] = {TND_CT_HF, TND_CT_LF_SH, TND_CT_SPEC};
        for (int c = 0; c < 3; c++) {
            uint32_t comps = tnd_ct_get(ch[c])->comps;
            const float *a = tnd_frame_f(&p.cpu, ch[c]) + comps * q;
            const float *b = tnd_frame_f(&p.gpu, ch[c]) + comps * q;
            for (uint32_t i = 0; i < comps; i++)
                ok &= fabsf(a[i] - b[i]) <= 1e-3f * fmaxf(fabsf(a[i]), fabsf(b[i])) + 1e-6f;
        }
        agree += ok;
    }
    printf("     atrium at %dx%d: the same surface on %.2f%% of pixels, shading agrees on %.2f%% "
           "of those\n",
           W, H, 100.0 * same / n, 100.0 * agree / (same ? same : 1));
    CHECK(same >= 0.995 * n, "atrium: %d of %d pixels see the same surface", same, n);
    CHECK(agree >= 0.99 * same, "atrium: shading agrees on %d of %d", agree, same);
cleanup:
    pair_close(&p);
    gpu_end();
}

/* Static instances merged into one BLAS (fvk_scene.c merge_static) against every instance on
 * its own (TANDEM_MERGE_STATIC=0), on `dynamic` (five static instances, the emissive panel among
 * them, then the animated cube: with runs of 2 or more merged, one run and one instance of its
 * own, refitted as it moves) and on `atrium` (382 instances, MASK cut-outs among them; the
 * default: runs of 32 or more): the hits name the same instance and
 * triangle; where the traversal's float rounding differs (triangles placed before the BVH is
 * built, against the ray taken into object space) a pixel on a triangle edge may see its
 * neighbour, and depth and shading agree within rounding elsewhere. A static instance moved
 * after all (a state nobody's animation made) leaves the merge: the frames agree still. */
static tnd_result merge_frame(fvk_context *gv, tnd_vk *vk, tnd_scene_state *cur,
                              tnd_scene_state *prev, uint32_t frame, uint32_t w, uint32_t h,
                              tnd_frame *out)
{
    tnd_frame_destroy(out);
    tnd_result r = fvk_set_frame(gv, cur, prev, frame, w, h);
    if (r == TND_OK)
        r = fvk_render(gv, &(fvk_params){.bounces = 1}, NULL);
    if (r == TND_OK)
        r = tnd_frame_create(w, h, out);
    if (r == TND_OK)
        r = tnd_contract_download(vk, fvk_contract(gv), out);
    return r;
}

static void merge_compare(const tnd_frame *a, const tnd_frame *b, int w, int h, const char *what)
{
    int n = w * h, same = 0, near = 0;
    for (int q = 0; q < n; q++) {
        const uint32_t *va = tnd_frame_u(a, TND_CT_VIS_ID) + 2 * q;
        const uint32_t *vb = tnd_frame_u(b, TND_CT_VIS_ID) + 2 * q;
        if (va[0] != vb[0] || va[1] != vb[1])
            continue;
        same++;
        float da = tnd_frame_f(a, TND_CT_DEPTH)[q], db = tnd_frame_f(b, TND_CT_DEPTH)[q];
        bool ok = fabsf(da - db) <= 1e-4f * fabsf(db) + 1e-6f;
        const float *ha = tnd_frame_f(a, TND_CT_HF) + 3 * q, *hb = tnd_frame_f(b, TND_CT_HF) + 3 * q;
        for (int c = 0; c < 3; c++)
            ok &= fabsf(ha[c] - hb[c]) <= 1e-3f * fmaxf(fabsf(ha[c]), fabsf(hb[c])) + 1e-6f;
        near += ok;
    }
    printf("     %s: the same instance and triangle on %.3f%% of pixels, depth and direct light "
           "within rounding on %.3f%% of those\n",
           what, 100.0 * same / n, 100.0 * near / (same ? same : 1));
    CHECK(same >= 0.995 * n, "%s: %d of %d pixels see the same triangle", what, same, n);
    CHECK(near >= 0.99 * same, "%s: %d of %d agree", what, near, same);
}

static void test_static_instances_merged(void)
{
    tnd_vk *vk = gpu_begin();
    if (!vk) {
        CHECK(vk, "no context");
        return;
    }
    static const struct {
        const char *scene;
        double t;
        const char *merge; /* TANDEM_MERGE_STATIC: runs of 2 or more, or the default (32) */
        uint32_t runs, merged; /* what merge_static makes of it */
    } cases[] = {{"dynamic", 0.5, "2", 1, 5}, {"atrium", 2.0, "", 1, 382}};
#ifdef TND_SANITIZED
    const size_t ncases = 1; /* (`atrium` takes 90 s there; its frames are the release build's) */
#else
    const size_t ncases = sizeof cases / sizeof *cases;
#endif
    enum { W = 96, H = 64 };
    for (size_t k = 0; k < ncases; k++) {
        char path[512], what[96];
        snprintf(path, sizeof path, TND_SOURCE_DIR "/data/scenes/%s.gltf", cases[k].scene);
        tnd_scene *s = NULL;
        fvk_context *gv[2] = {NULL, NULL}; /* merged, each on its own */
        tnd_scene_state cur = {0}, prev = {0};
        tnd_frame f[2] = {{0}};
        REQUIRE_OK(tnd_scene_load(path, &s));
        for (int m = 0; m < 2; m++) {
            setenv("TANDEM_MERGE_STATIC", m ? "0" : cases[k].merge, 1);
            REQUIRE_OK(fvk_create(vk, s, &(fvk_desc){.precision = TND_PRECISION_F32,
                                                     .rt_api = FVK_RT_PIPELINE},
                                  &gv[m]));
        }
        /* three frames: the cube moves in `dynamic` (a refit beside the run) */
        for (uint32_t fr = 0; fr < 3; fr++) {
            double t = cases[k].t + fr / 30.0;
            REQUIRE_OK(tnd_scene_evaluate(s, t, 0, (float)W / H, &cur));
            REQUIRE_OK(tnd_scene_evaluate(s, t - 1 / 30.0, 0, (float)W / H, &prev));
            for (int m = 0; m < 2; m++) {
                setenv("TANDEM_MERGE_STATIC", m ? "0" : cases[k].merge, 1);
                REQUIRE_OK(merge_frame(gv[m], vk, &cur, &prev, fr, W, H, &f[m]));
            }
            snprintf(what, sizeof what, "%s frame %u", cases[k].scene, fr);
            merge_compare(&f[0], &f[1], W, H, what);
        }
        uint32_t inst = 0, runs = fvk_static_runs(gv[0], &inst);
        CHECK(runs == cases[k].runs && inst == cases[k].merged,
              "%s: %u runs of %u instances merged (want %u of %u)", cases[k].scene, runs, inst,
              cases[k].runs, cases[k].merged);
        CHECK(fvk_static_runs(gv[1], NULL) == 0, "%s: TANDEM_MERGE_STATIC=0 merged", cases[k].scene);
        /* instance 0 (static: the floor, in the run) moved by hand */
        cur.instance_xform[3] += 0.25f;
        for (int m = 0; m < 2; m++)
            REQUIRE_OK(merge_frame(gv[m], vk, &cur, &prev, 3, W, H, &f[m]));
        snprintf(what, sizeof what, "%s, a merged instance moved", cases[k].scene);
        merge_compare(&f[0], &f[1], W, H, what);
        CHECK(fvk_static_runs(gv[0], NULL) == 0, "%s: still merged after a merged instance moved",
              cases[k].scene);
    cleanup:
        unsetenv("TANDEM_MERGE_STATIC");
        tnd_frame_destroy(&f[0]);
        tnd_frame_destroy(&f[1]);
        tnd_scene_state_free(&cur);
        tnd_scene_state_free(&prev);
        fvk_destroy(gv[0]);
        fvk_destroy(gv[1]);
        tnd_scene_destroy(s);
    }
    gpu_end();
}

static void test_shutdown(void)
{
    gpu_shutdown();
}

TND_TEST_MAIN(T(test_trace_against_cpu), T(test_light_tree_unbiased), T(test_restir_agrees), T(test_blas_bad_input), T(test_gbuffer_matches_embree),
              T(test_motion_far_from_origin_vk), T(test_lambert_emitters_vk),
              T(test_assimp_testmodels),
              T(test_shading_matches_embree), T(test_bounces_rebuilt), T(test_half_indirect),
              T(test_gpu_gradient_samples),
              T(test_query_matches_pipeline), T(test_means_and_references_agree),
              T(test_env_sphere_vk), T(test_atrium_agrees), T(test_static_instances_merged),
              T(test_shutdown))
