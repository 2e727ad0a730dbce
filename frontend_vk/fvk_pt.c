/* frontend_vk/fvk_pt.c: the ray-tracing pipeline of the Vulkan front-end (raygens: primary,
 * shade; misses: closest, shadow; one hit group), its descriptor sets (set 0: scene, set 1: the
 * contract images) and the passes, each bracketed by timestamps.
 * Entry points: fvk_create, fvk_destroy, fvk_set_frame, fvk_render, fvk_shade_gradients,
 * fvk_shade_gradient_slots, fvk_contract. */
#include "frontend_vk/fvk_internal.h"
#include "shaders/restir.h"
#include "shaders/sampling.h"
#include "shaders/specular.h"
#include "shaders/shader_list.h"

#include "shaders/brdf.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { SCENE_BINDINGS = 21 };

static tnd_result create_layouts(fvk_context *c)
{
    tnd_result res = TND_OK;
    tnd_vk *vk = c->vk;
    const VkShaderStageFlags rt = VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_COMPUTE_BIT |
                                  VK_SHADER_STAGE_ANY_HIT_BIT_KHR;
    VkDescriptorSetLayoutBinding b0[SCENE_BINDINGS];
    for (uint32_t i = 0; i < SCENE_BINDINGS; i++)
        b0[i] = (VkDescriptorSetLayoutBinding){i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, rt, NULL};
    b0[0].descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
    b0[1].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    b0[12].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    b0[12].descriptorCount = c->texture_count;
    b0[13].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    VkDescriptorSetLayoutCreateInfo ci0 = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
                                           .bindingCount = SCENE_BINDINGS,
                                           .pBindings = b0};
    TND_VK_TRY(vkCreateDescriptorSetLayout(vk->device, &ci0, NULL, &c->set_layout[0]));
    TND_TRY(tnd_contract_set_layout(vk, rt, &c->set_layout[1]));
    /* (8 bytes: the reference's sample and its batch's first; the passes read the first 4) */
    VkPushConstantRange pcr = {VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_COMPUTE_BIT, 0, 8};
    VkPipelineLayoutCreateInfo pci = {.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
                                      .setLayoutCount = 2,
                                      .pSetLayouts = c->set_layout,
                                      .pushConstantRangeCount = 1,
                                      .pPushConstantRanges = &pcr};
    TND_VK_TRY(vkCreatePipelineLayout(vk->device, &pci, NULL, &c->layout));
    /* two scene sets (the second for slot launches) and the contract's */
    VkDescriptorPoolSize ps[5] = {{VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, 2},
                                  {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 2},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2 * (SCENE_BINDINGS - 4)},
                                  {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2 * c->texture_count},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, TND_CT_COUNT + 2}};
    VkDescriptorPoolCreateInfo dpci = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
                                       .maxSets = 3,
                                       .poolSizeCount = 5,
                                       .pPoolSizes = ps};
    TND_VK_TRY(vkCreateDescriptorPool(vk->device, &dpci, NULL, &c->pool));
    VkDescriptorSetAllocateInfo ai = {.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
                                      .descriptorPool = c->pool,
                                      .descriptorSetCount = 2,
                                      .pSetLayouts = c->set_layout};
    TND_VK_TRY(vkAllocateDescriptorSets(vk->device, &ai, c->sets));
    ai.descriptorSetCount = 1;
    TND_VK_TRY(vkAllocateDescriptorSets(vk->device, &ai, &c->slot_set));
fail:
    return res;
}

tnd_result fvk_rt_api_parse(const char *s, fvk_rt_api *api)
{
    if (strcmp(s, "auto") == 0)
        *api = FVK_RT_AUTO;
    else if (strcmp(s, "pipeline") == 0)
        *api = FVK_RT_PIPELINE;
    else if (strcmp(s, "query") == 0)
        *api = FVK_RT_QUERY;
    else
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "frontend_vk: ray-tracing API '%s' (expected pipeline, query or auto)", s);
    return TND_OK;
}

fvk_rt_api fvk_api(const fvk_context *c)
{
    return c->api;
}

/* Stage *n of a ray-tracing pipeline's list: shader `id` as `kind`; returns its index. */
static uint32_t add_stage(tnd_rt_stage *stages, uint32_t *n, tnd_shader id,
                          VkShaderStageFlagBits kind)
{
    stages[*n].code = tnd_spirv_code(id, &stages[*n].bytes, NULL);
    stages[*n].stage = kind;
    return (*n)++;
}

/* The passes' specialization: the scene's features, with TND_USES_REFERENCE only for the passes
 * that draw reference samples (v 1). */
static uint32_t passes_uses(const fvk_context *c, int v)
{
    return v ? c->uses | TND_USES_REFERENCE : c->uses & ~TND_USES_REFERENCE;
}

/* The passes v (0: the real-time frame's, 1: references') as compute pipelines (FVK_RT_QUERY:
 * primary and shade, and pt_reference for v 1) or one ray-tracing pipeline of all three raygens
 * either way (v 0 never launches pt_reference; without it in the pipeline, the H200's primary
 * pass ran 20% slower: docs/performance.md). */
static tnd_result create_passes(fvk_context *c, int v, uint32_t bounces_spec, uint32_t half_spec)
{
    tnd_result res = TND_OK;
    struct fvk_passes *ps = &c->passes[v];
    bool packed = c->precision == TND_PRECISION_PACKED;
    /* constant 0: what the scene and the passes use; 1: the bounces built for, 2: the indirect
     * paths' resolution built for (pt_shade.glsl) */
    const uint32_t constants[3] = {passes_uses(c, v), bounces_spec, half_spec};
    const VkSpecializationMapEntry entries[3] = {{0, 0, sizeof(uint32_t)},
                                                 {1, sizeof(uint32_t), sizeof(uint32_t)},
                                                 {2, 2 * sizeof(uint32_t), sizeof(uint32_t)}};
    const VkSpecializationInfo spec = {3, entries, sizeof constants, constants};
    ps->bounces_spec = bounces_spec;
    ps->half_spec = half_spec;
    if (c->api == FVK_RT_QUERY) {
        const tnd_shader ids[3] = {
            packed ? TND_SHADER_pt_primary_rq_packed : TND_SHADER_pt_primary_rq_f32,
            packed ? TND_SHADER_pt_shade_rq_packed : TND_SHADER_pt_shade_rq_f32,
            TND_SHADER_pt_reference_rq};
        const char *names[2][3] = {{"frontend_vk.primary_rq", "frontend_vk.shade_rq", ""},
                                   {"frontend_vk.primary_rq.ref", "frontend_vk.shade_rq.ref",
                                    "frontend_vk.reference_rq"}};
        for (int i = 0; i < (v ? 3 : 2); i++) {
            size_t bytes;
            const uint32_t *code = tnd_spirv_code(ids[i], &bytes, NULL);
            TND_TRY(tnd_compute_pipeline_create(c->vk,
                                                &(tnd_compute_desc){.code = code,
                                                                    .bytes = bytes,
                                                                    .layout = c->layout,
                                                                    .spec = &spec,
                                                                    .name = names[v][i]},
                                                &ps->compute[i]));
        }
        return res;
    }
    /* stages: the raygens, the two miss shaders, the closest hit, the any-hit only where the
     * scene has alpha-tested geometry */
    const tnd_shader raygen_ids[3] = {
        packed ? TND_SHADER_pt_primary_packed : TND_SHADER_pt_primary_f32,
        packed ? TND_SHADER_pt_shade_packed : TND_SHADER_pt_shade_f32, TND_SHADER_pt_reference};
    tnd_rt_stage stages[7];
    uint32_t n = 0, raygen[3], miss[2];
    for (int i = 0; i < 3; i++)
        raygen[i] = add_stage(stages, &n, raygen_ids[i], VK_SHADER_STAGE_RAYGEN_BIT_KHR);
    miss[0] = add_stage(stages, &n, TND_SHADER_pt_rmiss, VK_SHADER_STAGE_MISS_BIT_KHR);
    miss[1] = add_stage(stages, &n, TND_SHADER_pt_shadow_rmiss, VK_SHADER_STAGE_MISS_BIT_KHR);
    tnd_rt_hit_group hit = {
        .closest_hit =
            (int)add_stage(stages, &n, TND_SHADER_pt_rchit, VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR),
        .any_hit = -1};
    if (c->uses & TND_USES_ALPHA)
        hit.any_hit =
            (int)add_stage(stages, &n, TND_SHADER_pt_alpha_rahit, VK_SHADER_STAGE_ANY_HIT_BIT_KHR);
    res = tnd_rt_pipeline_create(
        c->vk,
        &(tnd_rt_desc){.stages = stages, .stage_count = n, .raygen = raygen,
                       .raygen_count = 3, .miss = miss, .miss_count = 2,
                       .hit = &hit, .hit_count = 1, .max_recursion = 1, .layout = c->layout,
                       .spec = &spec, .name = v ? "frontend_vk.pt.ref" : "frontend_vk.pt"},
        &ps->pipeline, &ps->sbt);
fail:
    return res;
}

/* The scene set `set` (its gradient binding, 11, at our list). */
static void write_scene_set_to(fvk_context *c, VkDescriptorSet set)
{
    VkWriteDescriptorSetAccelerationStructureKHR as = {
        .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR,
        .accelerationStructureCount = 1,
        .pAccelerationStructures = &c->tlas.as};
    const tnd_buffer *bufs[SCENE_BINDINGS] = {NULL,          &c->frame_ubo, &c->positions,
                                              &c->normals,   &c->uvs,       &c->tangents,
                                              &c->indices,   &c->meshes,    &c->materials,
                                              &c->instances, &c->lights,    &c->gradients,
                                              NULL,          NULL,          &c->env,
                                              &c->uvs1,      &c->texel_lut, &c->alpha,
                                              &c->light_nodes, &c->rs_reservoirs,
                                              &c->rs_surfaces};
    VkDescriptorImageInfo acc = {VK_NULL_HANDLE, c->accum.view, VK_IMAGE_LAYOUT_GENERAL};
    VkDescriptorBufferInfo bi[SCENE_BINDINGS];
    VkWriteDescriptorSet w[SCENE_BINDINGS];
    VkDescriptorImageInfo *ii = calloc(c->texture_count, sizeof *ii);
    for (uint32_t i = 0; i < c->texture_count && ii; i++)
        ii[i] = (VkDescriptorImageInfo){c->sampler, c->textures[i].view,
                                        VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    for (uint32_t i = 0; i < SCENE_BINDINGS; i++) {
        w[i] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                                      .dstSet = set,
                                      .dstBinding = i,
                                      .descriptorCount = 1,
                                      .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
        if (bufs[i]) {
            bi[i] = (VkDescriptorBufferInfo){bufs[i]->buffer, 0, VK_WHOLE_SIZE};
            w[i].pBufferInfo = &bi[i];
        }
    }
    w[0].pNext = &as;
    w[0].descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR;
    w[1].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    w[12].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    w[12].descriptorCount = c->texture_count;
    w[12].pImageInfo = ii;
    w[13].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    w[13].pImageInfo = &acc;
    if (!ii) /* (out of memory: the textures' binding left out) */
        w[12] = w[SCENE_BINDINGS - 1];
    vkUpdateDescriptorSets(c->vk->device, ii ? SCENE_BINDINGS : SCENE_BINDINGS - 1, w, 0, NULL);
    free(ii);
}

/* Both scene sets (nothing in flight may use them), the slot set's list back at ours: the
 * back-end's list may be gone by the next slot launch, which points it there again. */
static void write_scene_set(fvk_context *c)
{
    write_scene_set_to(c, c->sets[0]);
    write_scene_set_to(c, c->slot_set);
    c->slot_buffer = VK_NULL_HANDLE;
}

enum { FVK_RENDER = 1u, FVK_GRADIENTS = 2u, FVK_ALL = 3u };

/* Wait for the submissions in `mask` (FVK_*) and read their timestamps into c->last: a render's
 * first, then its gradient launch's (a launch waited for waits for the render before it, which
 * the queue runs first). */
static tnd_result settle(fvk_context *c, unsigned mask)
{
    tnd_result res = TND_OK;
    if ((mask & FVK_GRADIENTS) && c->due[1])
        mask |= FVK_RENDER;
    for (int i = 0; i < 2; i++) {
        if (!(mask & (1u << i)))
            continue;
        if (i == 0) /* (the primary pass of a render in two; done when run[0] is) */
            TND_TRY(tnd_pending_wait(c->vk, &c->primary_run));
        TND_TRY(tnd_pending_wait(c->vk, &c->run[i]));
        if (!c->due[i])
            continue;
        c->due[i] = false;
        double ms[2] = {0, 0};
        TND_TRY(tnd_timer_read(c->vk, &c->timer[i], ms));
        if (i == 0)
            c->last = (fvk_timings){.primary_ms = ms[0], .shade_ms = ms[1],
                                    .tlas_ms = c->due_tlas_ms};
        else
            c->last.gradient_ms = ms[0];
    }
    if ((mask & FVK_ALL) == FVK_ALL)
        c->slot_set_queued = false;
fail:
    return res;
}

tnd_result fvk_last_timings(fvk_context *c, bool wait, fvk_timings *t)
{
    tnd_result res = wait ? settle(c, FVK_ALL) : TND_OK;
    *t = c->last;
    return res;
}

static void destroy_passes(fvk_context *c, int v)
{
    struct fvk_passes *ps = &c->passes[v];
    tnd_sbt_destroy(c->vk, &ps->sbt);
    if (ps->pipeline)
        vkDestroyPipeline(c->vk->device, ps->pipeline, NULL);
    for (int i = 0; i < 3; i++)
        if (ps->compute[i])
            vkDestroyPipeline(c->vk->device, ps->compute[i], NULL);
    *ps = (struct fvk_passes){0};
}

/* The passes v for frames of `bounces` indirect bounces (`half`: at half resolution): made the
 * first time they are needed. The real-time passes are built for the count and the resolution
 * (and made again when a frame asks others, after what was submitted with them is done); the
 * reference passes take both from the frame parameters, whatever they are (a reference's
 * context also writes each frame's motion with a frame of none: one build serves both, as
 * before the real-time passes were specialised). */
static tnd_result need_passes(fvk_context *c, int v, uint32_t bounces, bool half)
{
    tnd_result res = TND_OK;
    struct fvk_passes *ps = &c->passes[v];
    uint32_t bounces_spec = v || !c->specialise ? 0u : bounces + 1u;
    uint32_t half_spec = v || !c->specialise ? 0u : half ? 2u : 1u;
    bool made = c->api == FVK_RT_QUERY ? ps->compute[0] != VK_NULL_HANDLE
                                       : ps->pipeline != VK_NULL_HANDLE;
    if (made && ps->bounces_spec == bounces_spec && ps->half_spec == half_spec)
        return TND_OK;
    if (made) {
        TND_TRY(settle(c, FVK_ALL));
        destroy_passes(c, v);
    }
    TND_TRY(create_passes(c, v, bounces_spec, half_spec));
fail:
    return res;
}

void fvk_destroy(fvk_context *c)
{
    if (!c)
        return;
    tnd_vk *vk = c->vk;
    if (vk->device)
        vkDeviceWaitIdle(vk->device);
    for (int i = 0; i < 2; i++) {
        tnd_pending_destroy(vk, &c->run[i]);
        tnd_timer_destroy(vk, &c->timer[i]);
    }
    tnd_pending_destroy(vk, &c->primary_run);
    tnd_contract_gpu_destroy(vk, &c->contract);
    for (int v = 0; v < 2; v++)
        destroy_passes(c, v);
    if (c->matched)
        vkDestroyPipeline(vk->device, c->matched, NULL);
    tnd_image_destroy(vk, &c->accum);
    if (c->pool)
        vkDestroyDescriptorPool(vk->device, c->pool, NULL);
    if (c->layout)
        vkDestroyPipelineLayout(vk->device, c->layout, NULL);
    for (int i = 0; i < 2; i++)
        if (c->set_layout[i])
            vkDestroyDescriptorSetLayout(vk->device, c->set_layout[i], NULL);
    fvk_scene_free(c);
    free(c);
}

/* The shaders' specialization from the scene's features (or everything when forced). */
static void choose_variant(fvk_context *c, bool full)
{
    static const struct {
        uint32_t feature, use;
        const char *name;
    } map[] = {{TND_FEATURE(LIGHT_AREA), TND_USES_AREA, "area lights"},
               {TND_FEATURE(LIGHT_POINT), TND_USES_POINT, "point lights"},
               {TND_FEATURE(LIGHT_SPOT), TND_USES_SPOT, "spot lights"},
               {TND_FEATURE(LIGHT_DIRECTIONAL), TND_USES_DIRECTIONAL, "directional lights"},
               {TND_FEATURE(TEXTURES), TND_USES_TEXTURES, "textures"},
               {TND_FEATURE(NORMAL_MAPS), TND_USES_NORMAL_MAPS, "normal maps"},
               {TND_FEATURE(SKY), TND_USES_SKY, "sky"},
               {TND_FEATURE(ENV_MAP), TND_USES_ENV, "environment map"},
               {TND_FEATURE(ALPHA), TND_USES_ALPHA, "alpha-tested geometry"},
               {TND_FEATURE(MIRROR) | TND_FEATURE(GLASS) | TND_FEATURE(THIN_GLASS),
                TND_USES_SPECULAR, "mirrors and glass"}};
    c->uses = full ? TND_USES_ALL : 0u;
    c->variant[0] = 0;
    size_t n = 0;
    for (size_t i = 0; i < sizeof map / sizeof map[0]; i++) {
        if (!full && !(c->scene->features & map[i].feature))
            continue;
        c->uses |= map[i].use;
        n += (size_t)snprintf(c->variant + n, sizeof c->variant - n, "%s%s", n ? ", " : "",
                              map[i].name);
    }
    if (c->light_list.want_tree) { /* the light tree's descent (shaders/light_tree.h) */
        c->uses |= TND_USES_LIGHT_TREE;
        n += (size_t)snprintf(c->variant + n, sizeof c->variant - n, "%slight tree",
                              n ? ", " : "");
    }
    if (c->restir) { /* ReSTIR DI's passes and shading (shaders/pt_restir.glsl) */
        c->uses |= TND_USES_RESTIR;
        n += (size_t)snprintf(c->variant + n, sizeof c->variant - n, "%sreservoirs",
                              n ? ", " : "");
    }
    if (full)
        snprintf(c->variant + n, sizeof c->variant - n, " (--pipeline full)");
    else if (!n)
        snprintf(c->variant, sizeof c->variant, "no lights, no textures");
}

uint32_t fvk_uses(const fvk_context *c)
{
    return c->uses;
}

const char *fvk_variant(const fvk_context *c)
{
    return c->variant;
}

tnd_result fvk_create(tnd_vk *vk, const tnd_scene *scene, const fvk_desc *desc, fvk_context **out)
{
    tnd_result res = TND_OK;
    *out = NULL;
    if (!vk->ray_tracing)
        return tnd_fail(TND_ERR_UNSUPPORTED,
                        "frontend_vk: device '%s' has no ray-tracing pipelines", vk->info.name);
    fvk_context *c = calloc(1, sizeof *c);
    if (!c)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "frontend_vk: out of memory");
    c->vk = vk;
    c->scene = scene;
    c->precision = desc ? desc->precision : TND_PRECISION_F32;
    c->api = desc ? desc->rt_api : FVK_RT_AUTO;
    if (c->api == FVK_RT_AUTO)
        c->api = vk->ray_query ? FVK_RT_QUERY : FVK_RT_PIPELINE;
    if (c->api == FVK_RT_QUERY && !vk->ray_query) {
        res = tnd_fail(TND_ERR_UNSUPPORTED,
                       "frontend_vk: --rt-api query: device '%s' has no VK_KHR_ray_query (use "
                       "pipeline or auto)",
                       vk->info.name);
        goto fail;
    }
    tnd_light_sampling pick = tnd_light_sampling_for(scene, desc ? desc->lights : TND_LIGHTS_AUTO);
    c->restir = pick == TND_LIGHTS_RESTIR; /* (its candidates by the tree) */
    c->light_list.want_tree = pick == TND_LIGHTS_TREE || pick == TND_LIGHTS_RESTIR;
    choose_variant(c, desc && desc->full_pipeline);
    c->reflect_depth = desc && desc->reflect_depth ? desc->reflect_depth : TND_REFLECT_DEPTH;
    c->footprint_scale = desc && desc->footprint_scale > 0 ? desc->footprint_scale : 1.0f;
    if (c->reflect_depth > TND_MAX_SPECULAR_DEPTH)
        c->reflect_depth = TND_MAX_SPECULAR_DEPTH;
    TND_TRY(fvk_scene_upload(c));
    TND_TRY(create_layouts(c));
    c->references = desc && desc->references;
    fvk_specialise sp = desc ? desc->specialise : FVK_SPECIALISE_AUTO;
    c->specialise = sp == FVK_SPECIALISE_ON ||
                    (sp == FVK_SPECIALISE_AUTO && vk->info.type != VK_PHYSICAL_DEVICE_TYPE_CPU);
    TND_TRY(need_passes(c, c->references || !c->specialise,
                        desc && desc->bounces ? desc->bounces : 1u, desc && desc->half_indirect));
    {
        size_t bytes;
        tnd_shader id = c->precision == TND_PRECISION_PACKED ? TND_SHADER_pt_matched_packed
                                                             : TND_SHADER_pt_matched_f32;
        const uint32_t *code = tnd_spirv_code(id, &bytes, NULL);
        TND_TRY(tnd_compute_pipeline_create(vk,
                                            &(tnd_compute_desc){.code = code, .bytes = bytes,
                                                                .layout = c->layout,
                                                                .name = "frontend_vk.matched"},
                                            &c->matched));
    }
    for (int i = 0; i < 2; i++) {
        TND_TRY(tnd_timer_create(vk, &c->timer[i]));
        TND_TRY(tnd_pending_create(vk, &c->run[i]));
    }
    TND_TRY(tnd_pending_create(vk, &c->primary_run));
    *out = c;
    return TND_OK;
fail:
    fvk_destroy(c);
    return res;
}

const tnd_contract_gpu *fvk_contract(const fvk_context *c)
{
    return &c->contract;
}

tnd_result fvk_set_frame(fvk_context *c, const tnd_scene_state *cur, const tnd_scene_state *prev,
                         uint32_t frame, uint32_t width, uint32_t height)
{
    tnd_result res = TND_OK;
    if (!prev)
        prev = cur;
    bool first = !c->have_frame;
    if (c->primary_open)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "frontend_vk: set_frame before the last primary pass's shading pass");
    /* the buffers, sets and images below are what the frame before read: its passes first (the
     * queue ran them before the back-end's passes of that frame, so this rarely waits) */
    TND_TRY(settle(c, FVK_ALL));
    if (!c->contract.images[0].image || c->width != width || c->height != height) {
        vkDeviceWaitIdle(c->vk->device);
        tnd_contract_gpu_destroy(c->vk, &c->contract);
        TND_TRY(tnd_contract_gpu_create(c->vk, width, height, c->precision, &c->contract));
        /* the reference's accumulation image: the pipeline's reference raygen uses it, so the
         * descriptor must always be valid */
        tnd_image_destroy(c->vk, &c->accum);
        TND_TRY(tnd_image_create(c->vk,
                                 &(tnd_image_desc){.width = width, .height = height,
                                                   .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                   .name = "frontend_vk.accum"},
                                 &c->accum));
        c->width = width;
        c->height = height;
        tnd_contract_write_set(c->vk, c->sets[1], &c->contract);
    }
    if (c->restir && (c->rs_width != width || c->rs_height != height)) {
        /* ReSTIR DI's records at the frame's size (nothing of the previous size carries over) */
        vkDeviceWaitIdle(c->vk->device);
        size_t n = (size_t)width * height;
        tnd_buffer_destroy(c->vk, &c->rs_reservoirs);
        tnd_buffer_destroy(c->vk, &c->rs_surfaces);
        TND_TRY(tnd_buffer_create(c->vk, &(tnd_buffer_desc){.size = 3 * n * TND_GPU_RESERVOIR_BYTES,
                                                            .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                            .mem = TND_MEM_DEVICE,
                                                            .name = "restir.reservoirs"},
                                  &c->rs_reservoirs));
        TND_TRY(tnd_buffer_create(c->vk, &(tnd_buffer_desc){.size = 2 * n * TND_GPU_RSURF_BYTES,
                                                            .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                            .mem = TND_MEM_DEVICE,
                                                            .name = "restir.surfaces"},
                                  &c->rs_surfaces));
        c->rs_width = width, c->rs_height = height;
        c->rs_have_cur = c->rs_have_prev = false;
    }
    TND_TRY(fvk_scene_frame(c, cur, prev, first));
    tnd_gpu_frame f;
    memset(&f, 0, sizeof f);
    float iv[16], ip[16], ipv[16], jit[2];
    tnd_mat4_inverse(cur->camera.view, iv);
    tnd_mat4_inverse(cur->camera.proj, ip);
    tnd_mat4_inverse(prev->camera.view, ipv);
    memcpy(f.inv_view.m, iv, sizeof iv);
    memcpy(f.inv_proj.m, ip, sizeof ip);
    memcpy(f.view.m, cur->camera.view, sizeof iv);
    memcpy(f.proj.m, cur->camera.proj, sizeof iv);
    memcpy(f.prev_view.m, prev->camera.view, sizeof iv);
    memcpy(f.prev_proj.m, prev->camera.proj, sizeof iv);
    f.cam_pos = (tnd_gvec4){iv[12], iv[13], iv[14], 0};
    f.prev_cam_pos = (tnd_gvec4){ipv[12], ipv[13], ipv[14], 0};
    tnd_jitter(frame, jit);
    double tan_half = 1.0 / (cur->camera.proj[5] < 0 ? -cur->camera.proj[5] : cur->camera.proj[5]);
    /* (the ray cones' spread: the pixel's angle, or the shown pixel's where upscaled) */
    f.jitter = (tnd_gvec4){jit[0], jit[1], (float)(2.0 * tan_half / height * c->footprint_scale),
                           0};
    const tnd_env *env = &c->scene->env;
    f.sky = (tnd_gvec4){c->scene->sky[0], c->scene->sky[1], c->scene->sky[2],
                        c->light_list.env_pick};
    f.env = (tnd_gvec4){env->cos_rot, env->sin_rot, (float)env->width, (float)env->height};
    f.frame = (tnd_guvec4){frame, width, height, c->light_list.count};
    f.indirect.y = c->light_list.node_count; /* (every pass of the frame: references too) */
    c->ubo = f;
    write_scene_set(c); /* the TLAS handle may be new */
    c->frame = frame;
    c->have_frame = true;
fail:
    return res;
}

static void set_params(fvk_context *c, const fvk_params *p)
{
    tnd_gpu_frame *f = &c->ubo;
    f->params.x = p ? p->bounces : 1;
    f->params.y = p ? p->sample : TND_SAMPLE_REALTIME;
    f->params.w = c->reflect_depth;
    f->indirect.x = p && p->half_indirect && f->params.x > 0 ? 1u : 0u;
    /* ReSTIR DI: the frame's own numbers only (a matched reference's samples keep next-event
     * estimation, whose expectation is the same); a new frame takes the other slot, the last
     * frame's final reservoirs becoming the previous ones */
    f->restir = (tnd_guvec4){0, 0, 0, 0};
    if (c->restir && f->params.y == TND_SAMPLE_REALTIME) {
        if (c->rs_have_cur && c->rs_frame != c->frame) {
            c->rs_slot ^= 1u;
            c->rs_prev_frame = c->rs_frame;
            c->rs_have_prev = true;
        }
        c->rs_frame = c->frame;
        c->rs_have_cur = true;
        float radius = (float)c->width / 40.0f;
        radius = radius < 3.0f ? 3.0f : radius > 30.0f ? 30.0f : radius;
        uint32_t rbits;
        memcpy(&rbits, &radius, sizeof rbits);
        f->restir = (tnd_guvec4){1u, c->rs_slot | (c->rs_have_prev ? 2u : 0u), c->rs_prev_frame,
                                 rbits};
    }
    float jit[2];
    if (p && p->set_jitter)
        memcpy(jit, p->jitter, sizeof jit);
    else
        tnd_jitter(c->frame, jit);
    f->jitter.x = jit[0], f->jitter.y = jit[1];
}

/* Bind the passes v's pipeline (need_passes made them) and the sets (the scene set, or the slot
 * set for slot launches), push the mode. */
static void bind_all(fvk_context *c, VkCommandBuffer cmd, uint32_t mode, bool slots, int v)
{
    VkPipelineBindPoint bp = c->api == FVK_RT_QUERY ? VK_PIPELINE_BIND_POINT_COMPUTE
                                                    : VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR;
    c->bound = v;
    if (c->api != FVK_RT_QUERY)
        vkCmdBindPipeline(cmd, bp, c->passes[c->bound].pipeline);
    VkDescriptorSet sets[2] = {slots ? c->slot_set : c->sets[0], c->sets[1]};
    vkCmdBindDescriptorSets(cmd, bp, c->layout, 0, 2, sets, 0, NULL);
    vkCmdPushConstants(cmd, c->layout, VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_COMPUTE_BIT,
                       0, 4, &mode);
}

/* A command buffer for passes: run `run`'s timer reset (run < 0: none), the frame parameters as
 * they are now (the command buffer keeps its copy), the bindings (the passes the frame
 * parameters ask for, or with `reference` the reference passes), a barrier. */
static tnd_result begin_passes(fvk_context *c, int run, uint32_t mode, bool slots, bool reference,
                               VkCommandBuffer *cmd)
{
    tnd_result res = TND_OK;
    /* the passes for the frame parameters (a reference's sample word or the real-time one, and
     * the bounces); a context for references, or without the passes' own specialisation, draws
     * every frame with the reference passes */
    int v = reference || c->references || !c->specialise ||
            c->ubo.params.y != TND_SAMPLE_REALTIME;
    TND_TRY(need_passes(c, v, c->ubo.params.x, c->ubo.indirect.x != 0));
    TND_TRY(tnd_cmd_begin(c->vk, cmd));
    if (run >= 0)
        tnd_timer_reset(*cmd, &c->timer[run]);
    vkCmdUpdateBuffer(*cmd, c->frame_ubo.buffer, 0, sizeof c->ubo, &c->ubo);
    bind_all(c, *cmd, mode, slots, v);
    tnd_cmd_barrier(*cmd);
fail:
    return res;
}

/* Pass `which` (0 primary, 1 shade) over w x h launches (or `w` linear ones for gradients). */
static void launch(fvk_context *c, VkCommandBuffer cmd, int which, uint32_t w, uint32_t h,
                   bool linear)
{
    if (c->api == FVK_RT_QUERY) {
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE,
                          c->passes[c->bound].compute[which]);
        if (linear)
            vkCmdDispatch(cmd, (w + 63) / 64, 1, 1);
        else
            vkCmdDispatch(cmd, (w + 7) / 8, (h + 7) / 8, 1);
    } else {
        const tnd_sbt *sbt = &c->passes[c->bound].sbt;
        c->vk->fn.vkCmdTraceRaysKHR(cmd, &sbt->raygen[which], &sbt->miss, &sbt->hit,
                                    &sbt->callable, w, h, 1);
    }
}

/* A render's first command buffer: the frame parameters, timer[0] reset, the primary pass. */
static tnd_result begin_render(fvk_context *c, const fvk_params *p, VkCommandBuffer *cmd)
{
    tnd_result res = TND_OK;
    if (!c->have_frame)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "frontend_vk: render before set_frame");
    if (c->primary_open)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "frontend_vk: render before the last primary pass's shading pass");
    TND_TRY(settle(c, FVK_ALL)); /* (the timers; the times of the frame before into c->last) */
    set_params(c, p);
    TND_TRY(begin_passes(c, 0, 0, false, false, cmd));
    int s0 = tnd_timer_begin(*cmd, &c->timer[0], "frontend_vk.primary");
    launch(c, *cmd, 0, c->width, c->height, false);
    tnd_timer_end(*cmd, &c->timer[0], s0);
    tnd_cmd_barrier(*cmd);
fail:
    return res;
}

/* A render's last command buffer: the shading pass, submitted as run[0]. */
static tnd_result end_render(fvk_context *c, VkCommandBuffer cmd, uint32_t mode, fvk_timings *t)
{
    tnd_result res = TND_OK;
    int s1 = tnd_timer_begin(cmd, &c->timer[0], "frontend_vk.shade");
    if (c->ubo.restir.x) {
        /* ReSTIR DI's passes (pt_shade.glsl modes 4 and 5), then the shading pass's own mode */
        const VkShaderStageFlags st = VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_COMPUTE_BIT;
        for (uint32_t m = 4; m <= 5; m++) {
            vkCmdPushConstants(cmd, c->layout, st, 0, 4, &m);
            launch(c, cmd, 1, c->width, c->height, false);
            tnd_cmd_barrier(cmd);
        }
        vkCmdPushConstants(cmd, c->layout, st, 0, 4, &mode);
    }
    /* (half resolution: pt_shade.glsl's shade_pixel takes rows in pairs; mode 2: the slots' rows
     * below the pixels') */
    launch(c, cmd, 1, c->width,
           c->height + (c->ubo.indirect.x ? c->height & 1 : 0) + c->shade_slot_rows, false);
    c->shade_slot_rows = 0;
    tnd_timer_end(cmd, &c->timer[0], s1);
    tnd_cmd_barrier(cmd); /* (whatever the queue runs next reads the contract) */
    TND_TRY(tnd_cmd_submit_pending(c->vk, cmd, &c->run[0]));
    c->due[0] = true;
    c->due_tlas_ms = c->tlas_ms;
    if (t) {
        TND_TRY(settle(c, FVK_RENDER));
        *t = c->last;
    }
fail:
    return res;
}

tnd_result fvk_render(fvk_context *c, const fvk_params *p, fvk_timings *t)
{
    tnd_result res = TND_OK;
    VkCommandBuffer cmd;
    TND_TRY(begin_render(c, p, &cmd));
    TND_TRY(end_render(c, cmd, 0u, t));
fail:
    return res;
}

tnd_result fvk_render_primary(fvk_context *c, const fvk_params *p)
{
    tnd_result res = TND_OK;
    VkCommandBuffer cmd;
    TND_TRY(begin_render(c, p, &cmd));
    TND_TRY(tnd_cmd_submit_pending(c->vk, cmd, &c->primary_run));
    c->primary_open = true;
fail:
    return res;
}

/* Point the slot set's gradient binding (11) at `buffer`: only slot launches and shading passes
 * with slots (fvk_render_shade) read that set. Each frame's set_frame points it back at ours
 * (write_scene_set) once nothing is in flight; a wait here only where a submission since reads
 * it (not the frame's primary pass: the host waiting for it would leave the GPU idle while it
 * wakes). */
static tnd_result bind_slot_buffer(fvk_context *c, VkBuffer buffer)
{
    tnd_result res = TND_OK;
    if (buffer == c->slot_buffer)
        return TND_OK;
    if (c->slot_set_queued)
        TND_TRY(settle(c, FVK_ALL));
    VkDescriptorBufferInfo bi = {buffer, 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet w = {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                              .dstSet = c->slot_set,
                              .dstBinding = 11,
                              .descriptorCount = 1,
                              .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                              .pBufferInfo = &bi};
    vkUpdateDescriptorSets(c->vk->device, 1, &w, 0, NULL);
    c->slot_buffer = buffer;
fail:
    return res;
}

/* One launch per entry of the gradient list (ours, or the slot set's: `count` entries). The
 * slot set's is the strata's grid, rows of `row` entries: the ray-tracing pipeline launches it
 * as a grid, so that a warp re-shades neighbouring strata in two dimensions rather than a run of
 * one row (H200, 1080p: 0.202 -> 0.174 ms on `cornell`, 0.76 -> 0.65 on `materials`;
 * docs/performance.md); a list, and the ray-query compute pass, run linear. */
static tnd_result launch_gradients(fvk_context *c, const fvk_params *p, uint32_t count,
                                   uint32_t row, bool slots, fvk_timings *t)
{
    tnd_result res = TND_OK;
    if (c->primary_open)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "frontend_vk: gradient samples before the frame's shading pass");
    TND_TRY(settle(c, FVK_GRADIENTS)); /* (the launch before: its timer) */
    set_params(c, p);
    c->ubo.params.z = count;
    VkCommandBuffer cmd;
    /* (mode 1: a host list, into the contract; 3: the back-end's slots, into the slots) */
    TND_TRY(begin_passes(c, 1, slots ? 3u : 1u, slots, false, &cmd));
    int s0 = tnd_timer_begin(cmd, &c->timer[1], "frontend_vk.gradients");
    if (slots && row && count % row == 0 && c->api != FVK_RT_QUERY)
        launch(c, cmd, 1, row, count / row, false); /* (pt_shade.rgen: y x width + x) */
    else
        launch(c, cmd, 1, count, 1, true);
    tnd_timer_end(cmd, &c->timer[1], s0);
    tnd_cmd_barrier(cmd);
    TND_TRY(tnd_cmd_submit_pending(c->vk, cmd, &c->run[1]));
    c->due[1] = true;
    c->slot_set_queued |= slots;
    if (t) {
        TND_TRY(settle(c, FVK_GRADIENTS));
        t->gradient_ms = c->last.gradient_ms;
    }
fail:
    return res;
}

tnd_result fvk_shade_gradients(fvk_context *c, const fvk_params *p, const uint32_t *samples,
                               uint32_t count, fvk_timings *t)
{
    tnd_result res = TND_OK;
    if (count == 0)
        return TND_OK;
    for (uint32_t i = 0; i < count; i++) {
        const uint32_t *g = samples + 7 * i;
        if (g[0] >= c->width * c->height || g[3] >= c->scene->instance_count ||
            g[4] >= c->scene->meshes[c->scene->instances[g[3]].mesh].triangle_count)
            return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                            "frontend_vk: gradient sample %u: pixel %u, instance %u, primitive %u "
                            "out of range",
                            i, g[0], g[3], g[4]);
    }
    TND_TRY(settle(c, FVK_GRADIENTS)); /* (the launch before read our list) */
    if (count > c->gradient_capacity) {
        TND_TRY(settle(c, FVK_ALL)); /* (only our launches read the list and the sets) */
        tnd_buffer_destroy(c->vk, &c->gradients);
        TND_TRY(tnd_buffer_create(c->vk, &(tnd_buffer_desc){.size = count * sizeof(tnd_gpu_gradient),
                                                            .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                            .mem = TND_MEM_UPLOAD, .name = "gradients"},
                                  &c->gradients));
        c->gradient_capacity = count;
        write_scene_set(c);
    }
    tnd_gpu_gradient *g = c->gradients.mapped;
    for (uint32_t i = 0; i < count; i++) {
        const uint32_t *s = samples + 7 * i;
        g[i] = (tnd_gpu_gradient){.pixel = s[0], .rng_frame = s[1], .rng_pixel = s[2],
                                  .instance = s[3], .primitive = s[4], .u_bits = s[5],
                                  .v_bits = s[6]};
    }
    return launch_gradients(c, p, count, 0, false, t);
fail:
    return res;
}

tnd_result fvk_shade_gradient_slots(fvk_context *c, const fvk_params *p, VkBuffer slots_buffer,
                                    uint32_t slots, uint32_t row, fvk_timings *t)
{
    if (slots == 0 || slots_buffer == VK_NULL_HANDLE)
        return TND_OK;
    tnd_result res = bind_slot_buffer(c, slots_buffer);
    return res == TND_OK ? launch_gradients(c, p, slots, row, true, t) : res;
}

tnd_result fvk_render_shade(fvk_context *c, const fvk_params *p, VkBuffer slots_buffer,
                            uint32_t row, fvk_timings *t)
{
    tnd_result res = TND_OK;
    if (!c->primary_open)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "frontend_vk: a shading pass without its primary pass");
    c->primary_open = false;
    bool slots = slots_buffer != VK_NULL_HANDLE && row > 0;
    if (slots)
        TND_TRY(bind_slot_buffer(c, slots_buffer));
    set_params(c, p); /* (as the primary pass had them) */
    c->ubo.params.z = slots ? row : 0u;
    /* the slots (row x the strata's rows of them) re-shaded in launch rows of their own, W
     * slots a row (pt_shade.glsl, mode 2) */
    uint32_t strata_rows = (c->height + TND_GRADIENT_STRATUM - 1) / TND_GRADIENT_STRATUM;
    c->shade_slot_rows = slots ? (row * strata_rows + c->width - 1) / c->width : 0u;
    VkCommandBuffer cmd;
    TND_TRY(begin_passes(c, -1, slots ? 2u : 0u, slots, false, &cmd));
    c->slot_set_queued |= slots; /* (end_render submits it) */
    TND_TRY(end_render(c, cmd, slots ? 2u : 0u, t));
fail:
    return res;
}

void fvk_set_reference_bounces(fvk_context *c, uint32_t bounces)
{
    c->ref_bounces = bounces;
}

/* Record the samples [b0, b1) of a batch: the unbiased reference's (one pt_reference launch
 * each), or a matched reference's (the real-time passes, then pt_matched.comp). */
static void record_unbiased(fvk_context *c, VkCommandBuffer cmd, uint32_t b0, uint32_t b1)
{
    bind_all(c, cmd, 0, false, 1);
    for (uint32_t s = b0; s < b1; s++) {
        uint32_t pc[2] = {s, b0};
        vkCmdPushConstants(cmd, c->layout,
                           VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_COMPUTE_BIT, 0, 8, pc);
        launch(c, cmd, 2, c->width, c->height, false);
        tnd_cmd_barrier(cmd);
    }
}

static void record_matched(fvk_context *c, VkCommandBuffer cmd, uint32_t b0, uint32_t b1)
{
    for (uint32_t s = b0; s < b1; s++) {
        uint32_t key = tnd_reference_sample(s);
        fvk_params p = {.bounces = c->ref_bounces, .sample = key, .set_jitter = true,
                        .jitter = {tnd_rand(0, c->frame, key, TND_DIM_JITTER_X) - 0.5f,
                                   tnd_rand(0, c->frame, key, TND_DIM_JITTER_Y) - 0.5f}};
        set_params(c, &p);
        /* (each sample's parameters: the command buffer keeps its copy; the barrier orders
         * the update after the last sample's reads and before this one's) */
        vkCmdUpdateBuffer(cmd, c->frame_ubo.buffer, 0, sizeof c->ubo, &c->ubo);
        tnd_cmd_barrier(cmd);
        bind_all(c, cmd, 0, false, 1);
        launch(c, cmd, 0, c->width, c->height, false);
        tnd_cmd_barrier(cmd);
        launch(c, cmd, 1, c->width, c->height, false);
        tnd_cmd_barrier(cmd);
        uint32_t pc[2] = {s, b0};
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->matched);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c->layout, 0, 2, c->sets, 0,
                                NULL);
        vkCmdPushConstants(cmd, c->layout,
                           VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_COMPUTE_BIT, 0, 8, pc);
        vkCmdDispatch(cmd, (c->width + 7) / 8, (c->height + 7) / 8, 1);
        tnd_cmd_barrier(cmd);
    }
}

/* Samples [first, first + count) in batches: each batch (up to the next multiple of
 * TND_REF_CHECK_EVERY, wherever a range starts, so that sample s falls in the same batch) summed
 * in float on the GPU, then added to the double sums. */
static tnd_result add_batches(fvk_context *c, bool matched, uint32_t first, uint32_t count,
                              double *sum_rgb, double *sum_lum2, tnd_ref_stats *stats,
                              void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    tnd_result res = TND_OK;
    if (!c->have_frame || count == 0 || first > UINT32_MAX - count)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "frontend_vk: reference needs a frame and "
                        "samples [%u, +%u) below 2^32", first, count);
    size_t n = (size_t)c->width * c->height;
    float *acc = malloc(n * 16);
    if (!acc)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "frontend_vk: out of memory");
    tnd_gpu_frame saved = c->ubo; /* (restored at the end, failed or not) */
    TND_TRY(settle(c, FVK_ALL));  /* (the accumulation image, the frame parameters) */
    TND_TRY(need_passes(c, 1, c->ref_bounces, false));
    const uint32_t batch = TND_REF_CHECK_EVERY;
    double until = stats ? stats->until_noise : 0.0;
    uint32_t end = first + count, done = end;
    for (uint32_t b0 = first; b0 < end;) {
        uint32_t b1 = (b0 / batch + 1) * batch < end ? (b0 / batch + 1) * batch : end;
        VkCommandBuffer cmd;
        c->ubo.params.x = c->ref_bounces; /* (the unbiased passes: 0, full paths) */
        TND_TRY(begin_passes(c, -1, 0, false, true, &cmd));
        if (matched)
            record_matched(c, cmd, b0, b1);
        else
            record_unbiased(c, cmd, b0, b1);
        TND_TRY(tnd_cmd_submit_wait(c->vk, cmd));
        TND_TRY(tnd_image_download(c->vk, &c->accum, acc, n * 16));
        for (size_t q = 0; q < n; q++) {
            for (int k = 0; k < 3; k++)
                sum_rgb[3 * q + k] += acc[4 * q + k];
            sum_lum2[q] += acc[4 * q + 3];
        }
        if (progress)
            progress(b1 - first, count, user);
        b0 = b1;
        if (until > 0 && b1 % batch == 0 && b1 < end &&
            tnd_ref_finish(sum_rgb, sum_lum2, n, b1, NULL, NULL) < until) {
            done = b1;
            break;
        }
    }
    if (stats)
        stats->spp = done;
fail:
    c->ubo = saved;
    free(acc);
    return res;
}

tnd_result fvk_reference_add(fvk_context *c, uint32_t first, uint32_t count, double *sum_rgb,
                             double *sum_lum2, tnd_ref_stats *stats,
                             void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    return add_batches(c, false, first, count, sum_rgb, sum_lum2, stats, progress, user);
}

tnd_result fvk_matched_add(fvk_context *c, uint32_t bounces, uint32_t first, uint32_t count,
                           double *sum_rgb, double *sum_lum2, tnd_ref_stats *stats,
                           void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    uint32_t saved = c->ref_bounces;
    c->ref_bounces = bounces;
    tnd_result res = add_batches(c, true, first, count, sum_rgb, sum_lum2, stats, progress, user);
    c->ref_bounces = saved;
    return res;
}

static tnd_result reference_add(void *c, uint32_t first, uint32_t count, double *sum_rgb,
                                double *sum_lum2, tnd_ref_stats *stats,
                                void (*progress)(uint32_t, uint32_t, void *), void *user)
{
    return fvk_reference_add(c, first, count, sum_rgb, sum_lum2, stats, progress, user);
}

tnd_result fvk_reference(fvk_context *c, uint32_t spp, float *rgb, float *lum_se,
                         tnd_ref_stats *stats, void (*progress)(uint32_t, uint32_t, void *),
                         void *user)
{
    return tnd_ref_run((size_t)c->width * c->height, spp, reference_add, c, rgb, lum_se, stats,
                       progress, user);
}
