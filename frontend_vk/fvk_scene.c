/* frontend_vk/fvk_scene.c: the scene on the GPU: vertex and index buffers, meshes, materials,
 * instances, light list, frame parameters, textures with their mip chains (8-bit, as the CPU
 * keeps and samples them, with the table that decodes them), and the acceleration structures (one compacted BLAS per mesh; a TLAS whose
 * custom indices are Tandem's instance indices, refitted when instances move).
 * Entry points (internal): fvk_scene_upload, fvk_scene_free, fvk_scene_frame. */
#include "frontend_vk/fvk_internal.h"
#include "shaders/restir.h"
#include "shaders/texel_lut.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static tnd_result upload_array(tnd_vk *vk, const void *data, size_t bytes, const char *name,
                               tnd_buffer *b)
{
    tnd_result res = tnd_buffer_create(vk,
                                       &(tnd_buffer_desc){.size = bytes ? bytes : 16,
                                                          .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                          .name = name},
                                       b);
    if (res == TND_OK && bytes)
        res = tnd_buffer_upload(vk, b, 0, data, bytes);
    return res;
}

static void image_barrier(VkCommandBuffer cmd, VkImage img, uint32_t levels, VkImageLayout from,
                          VkImageLayout to)
{
    VkImageMemoryBarrier b = {.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER,
                              .srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT,
                              .dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT,
                              .oldLayout = from,
                              .newLayout = to,
                              .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
                              .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
                              .image = img,
                              .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, levels, 0, 1}};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                         0, 0, NULL, 0, NULL, 1, &b);
}

/* One texture: RGBA8 as stored (UINT: the shaders decode each byte through shaders/texel_lut.h
 * as the CPU does), every level of the CPU's mip chain, shader-read-only. */
static tnd_result upload_texture(tnd_vk *vk, const tnd_texture *t, fvk_texture *out)
{
    tnd_result res = TND_OK;
    tnd_buffer st = {0};
    size_t total = 0;
    for (uint32_t l = 0; l < t->levels; l++)
        total += (size_t)t->level_w[l] * t->level_h[l] * 4;
    VkImageCreateInfo ici = {.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO,
                             .imageType = VK_IMAGE_TYPE_2D,
                             .format = VK_FORMAT_R8G8B8A8_UINT,
                             .extent = {t->width, t->height, 1},
                             .mipLevels = t->levels,
                             .arrayLayers = 1,
                             .samples = VK_SAMPLE_COUNT_1_BIT,
                             .tiling = VK_IMAGE_TILING_OPTIMAL,
                             .usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                             .initialLayout = VK_IMAGE_LAYOUT_UNDEFINED};
    TND_VK_TRY(vkCreateImage(vk->device, &ici, NULL, &out->image));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_IMAGE, out->image, "texture '%s'", t->name);
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(vk->device, out->image, &req);
    VkMemoryAllocateInfo ai = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
        .allocationSize = req.size,
        .memoryTypeIndex =
            tnd_vk_memory_type(vk, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT)};
    TND_VK_TRY(tnd_vk_allocate(vk, &ai, &out->memory));
    TND_VK_TRY(vkBindImageMemory(vk->device, out->image, out->memory, 0));
    VkImageViewCreateInfo vci = {.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO,
                                 .image = out->image,
                                 .viewType = VK_IMAGE_VIEW_TYPE_2D,
                                 .format = VK_FORMAT_R8G8B8A8_UINT,
                                 .subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, t->levels, 0, 1}};
    TND_VK_TRY(vkCreateImageView(vk->device, &vci, NULL, &out->view));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = total, .mem = TND_MEM_UPLOAD,
                                                     .name = "texture.staging"},
                              &st));
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    image_barrier(cmd, out->image, t->levels, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    size_t off = 0;
    for (uint32_t l = 0; l < t->levels; l++) {
        size_t bytes = (size_t)t->level_w[l] * t->level_h[l] * 4;
        memcpy((char *)st.mapped + off, t->level[l], bytes);
        VkBufferImageCopy r = {.bufferOffset = off,
                               .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, l, 0, 1},
                               .imageExtent = {t->level_w[l], t->level_h[l], 1}};
        vkCmdCopyBufferToImage(cmd, st.buffer, out->image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                               &r);
        off += bytes;
    }
    image_barrier(cmd, out->image, t->levels, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
fail:
    tnd_buffer_destroy(vk, &st);
    return res;
}

static void texture_destroy(tnd_vk *vk, fvk_texture *t)
{
    if (t->view)
        vkDestroyImageView(vk->device, t->view, NULL);
    if (t->image)
        vkDestroyImage(vk->device, t->image, NULL);
    if (t->memory)
        tnd_vk_free(vk, t->memory);
    memset(t, 0, sizeof *t);
}

void fvk_scene_free(fvk_context *c)
{
    tnd_vk *vk = c->vk;
    tnd_buffer *bufs[] = {&c->positions, &c->normals, &c->uvs,      &c->tangents,
                          &c->indices,   &c->meshes,  &c->materials, &c->instances,
                          &c->lights,    &c->frame_ubo, &c->gradients, &c->env, &c->uvs1,
                          &c->texel_lut, &c->alpha, &c->light_nodes, &c->rs_reservoirs,
                          &c->rs_surfaces};
    for (size_t i = 0; i < sizeof bufs / sizeof *bufs; i++)
        tnd_buffer_destroy(vk, bufs[i]);
    for (uint32_t i = 0; c->textures && i < c->texture_count; i++)
        texture_destroy(vk, &c->textures[i]);
    free(c->textures);
    c->textures = NULL;
    if (c->sampler)
        vkDestroySampler(vk->device, c->sampler, NULL);
    c->sampler = VK_NULL_HANDLE;
    fvk_tlas_destroy(vk, &c->tlas);
    for (uint32_t i = 0; c->blas && i < c->scene->mesh_count + c->run_count; i++)
        fvk_blas_destroy(vk, &c->blas[i]);
    free(c->blas);
    c->blas = NULL;
    free(c->run_of);
    free(c->run_first);
    free(c->last_xf);
    c->run_of = c->run_first = NULL;
    c->last_xf = NULL;
    c->run_count = 0;
    c->merge_tried = c->unmerged = false;
    free(c->inst);
    c->inst = NULL;
    free(c->alpha_at);
    c->alpha_at = NULL;
    tnd_lights_free(&c->light_list);
}

/* The alpha test's data (fvk_internal.h): for each mesh of an alpha-tested material, three vec4
 * (its base colour texture's UV transform, the transform's second row with the base alpha in w;
 * the texture, its size and the cutoff's bits as uints), then two vec4 per triangle: its three
 * UVs in the texture's set, as stored. The any-hit does tnd_material_alpha_pass's arithmetic on
 * them, the same as when it read the instance, mesh, material, indices and UVs in turn. */
static tnd_result alpha_upload(fvk_context *c)
{
    const tnd_scene *s = c->scene;
    size_t n = 1; /* (vec4s; one unused, so that the buffer is never empty) */
    c->alpha_at = calloc(s->mesh_count + 1, sizeof *c->alpha_at);
    if (!c->alpha_at)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "frontend_vk: out of memory");
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const tnd_mesh *me = &s->meshes[m];
        if (me->triangle_count && s->materials[me->material].alpha_test) {
            c->alpha_at[m] = (uint32_t)n + 1;
            n += 3 + 2 * (size_t)me->triangle_count;
        }
    }
    if (n >= UINT32_MAX / 2)
        return tnd_fail(TND_ERR_LIMIT, "frontend_vk: too many alpha-tested triangles");
    float *a = calloc(4 * n, sizeof *a);
    if (!a)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "frontend_vk: out of memory");
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        if (!c->alpha_at[m])
            continue;
        const tnd_mesh *me = &s->meshes[m];
        const tnd_material *mt = &s->materials[me->material];
        const tnd_uv_xform *x = &mt->uvx[TND_TEX_BASE];
        float *r = a + 4 * (size_t)(c->alpha_at[m] - 1);
        int32_t tex = mt->tex_base_color;
        uint32_t w = 0, h = 0;
        if (tex >= 0 && (uint32_t)tex < s->texture_count)
            w = s->textures[tex].width, h = s->textures[tex].height;
        else
            tex = -1;
        const float row[8] = {x->m[0], x->m[1], x->m[2], (float)x->set,
                              x->m[3], x->m[4], x->m[5], mt->base_color[3]};
        memcpy(r, row, sizeof row);
        uint32_t info[4] = {(uint32_t)tex, w, h, 0};
        memcpy(&info[3], &mt->alpha_cutoff, sizeof(float));
        memcpy(r + 8, info, sizeof info);
        const float *uv = x->set != 0 && s->uvs1 ? s->uvs1 : s->uvs; /* (vuv_set) */
        for (uint32_t t = 0; t < me->triangle_count; t++) {
            float *q = r + 12 + 8 * (size_t)t;
            for (int k = 0; k < 3; k++) {
                uint32_t v = me->first_vertex + s->indices[me->first_index + 3 * t + k];
                q[2 * k] = uv[2 * (size_t)v], q[2 * k + 1] = uv[2 * (size_t)v + 1];
            }
        }
    }
    tnd_result res = upload_array(c->vk, a, 4 * n * sizeof *a, "scene.alpha", &c->alpha);
    free(a);
    return res;
}

/* Mesh m as a BLAS takes it (fvk_scene_upload's per-mesh BLASes, merge_static's runs). */
static fvk_mesh_desc mesh_desc(const tnd_scene *s, uint32_t m)
{
    const tnd_mesh *me = &s->meshes[m];
    return (fvk_mesh_desc){s->positions + 3 * (size_t)me->first_vertex, me->vertex_count,
                           s->indices + me->first_index, me->triangle_count, me->name,
                           s->materials[me->material].alpha_test};
}

tnd_result fvk_scene_upload(fvk_context *c)
{
    tnd_result res = TND_OK;
    tnd_vk *vk = c->vk;
    const tnd_scene *s = c->scene;
    fvk_mesh_desc *md = NULL;
    tnd_gpu_mesh *gm = NULL;
    tnd_gpu_material *gmat = NULL;
    TND_TRY(upload_array(vk, s->positions, (size_t)s->vertex_count * 12, "scene.positions",
                         &c->positions));
    TND_TRY(upload_array(vk, s->normals, (size_t)s->vertex_count * 12, "scene.normals",
                         &c->normals));
    TND_TRY(upload_array(vk, s->uvs, (size_t)s->vertex_count * 8, "scene.uvs", &c->uvs));
    TND_TRY(upload_array(vk, s->uvs1 ? s->uvs1 : s->uvs, (size_t)s->vertex_count * 8,
                         "scene.uvs1", &c->uvs1));
    TND_TRY(upload_array(vk, s->tangents, (size_t)s->vertex_count * 16, "scene.tangents",
                         &c->tangents));
    /* the sRGB decoding table (a storage buffer: lavapipe takes minutes to compile a constant
     * array indexed per texel) */
    static const float lut[TND_TEXEL_LUT_SIZE] = {TND_TEXEL_LUT_VALUES};
    TND_TRY(upload_array(vk, lut, sizeof lut, "scene.texel_lut", &c->texel_lut));
    TND_TRY(upload_array(vk, s->indices, (size_t)s->index_count * 4, "scene.indices", &c->indices));
    TND_TRY(alpha_upload(c));
    gm = calloc(s->mesh_count + 1, sizeof *gm);
    gmat = calloc(s->material_count + 1, sizeof *gmat);
    md = calloc(s->mesh_count + 1, sizeof *md);
    c->blas = calloc(s->mesh_count + s->instance_count + 1, sizeof *c->blas);
    c->inst = calloc(s->instance_count + 1, sizeof *c->inst);
    c->last_xf = calloc(12 * (size_t)s->instance_count + 1, sizeof *c->last_xf);
    if (!gm || !gmat || !md || !c->blas || !c->inst || !c->last_xf) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "frontend_vk: out of memory");
        goto fail;
    }
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const tnd_mesh *me = &s->meshes[m];
        gm[m] = (tnd_gpu_mesh){{me->first_vertex, me->vertex_count, me->first_index,
                                me->triangle_count},
                               {me->material, 0, 0, 0}};
        md[m] = mesh_desc(s, m);
    }
    for (uint32_t m = 0; m < s->material_count; m++) {
        const tnd_material *mt = &s->materials[m];
        float sigma[3];
        tnd_material_sigma(mt, sigma);
        gmat[m] = (tnd_gpu_material){
            {mt->base_color[0], mt->base_color[1], mt->base_color[2], mt->base_color[3]},
            {mt->emission[0], mt->emission[1], mt->emission[2], mt->metallic},
            {mt->roughness, mt->specular, mt->normal_scale, mt->double_sided ? 1.0f : 0.0f},
            {mt->tex_base_color, mt->tex_metal_rough, mt->tex_normal, mt->tex_emission},
            {sigma[0], sigma[1], sigma[2], mt->ior > 0 ? mt->ior : 1.5f},
            {(uint32_t)mt->kind, mt->alpha_test ? 1u : 0u, 0, 0},
            .uvx = {{0, 0, 0, 0}}};
        memcpy(&gmat[m].info.z, &mt->alpha_cutoff, sizeof(float));
        for (int k = 0; k < TND_TEX_SLOTS; k++) {
            const tnd_uv_xform *x = &mt->uvx[k];
            gmat[m].uvx[2 * k] = (tnd_gvec4){x->m[0], x->m[1], x->m[2], (float)x->set};
            gmat[m].uvx[2 * k + 1] = (tnd_gvec4){x->m[3], x->m[4], x->m[5], x->lod_shift};
        }
    }
    TND_TRY(upload_array(vk, gm, s->mesh_count * sizeof *gm, "scene.meshes", &c->meshes));
    TND_TRY(upload_array(vk, gmat, s->material_count * sizeof *gmat, "scene.materials",
                         &c->materials));
    {
        /* one BLAS per mesh that has triangles (a mesh of points or lines has none, and no
         * instance: its entry stays empty); built together, then put at their meshes' places */
        uint32_t nz = 0;
        for (uint32_t m = 0; m < s->mesh_count; m++)
            if (s->meshes[m].triangle_count)
                md[nz++] = md[m];
        fvk_blas *built = calloc(nz + 1, sizeof *built);
        if (!built) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "frontend_vk: out of memory");
            goto fail;
        }
        res = nz ? fvk_blas_build(vk, md, nz, built) : TND_OK;
        for (uint32_t m = 0, k = 0; m < s->mesh_count && res == TND_OK; m++)
            if (s->meshes[m].triangle_count)
                c->blas[m] = built[k++];
        free(built);
        if (res != TND_OK)
            goto fail;
    }
    TND_TRY(tnd_buffer_create(
        vk, &(tnd_buffer_desc){.size = (s->instance_count + 1) * sizeof(tnd_gpu_instance),
                               .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                               .mem = TND_MEM_UPLOAD, .name = "scene.instances"},
        &c->instances));
    TND_TRY(tnd_buffer_create(
        vk, &(tnd_buffer_desc){.size = (s->emitter_count + s->light_count + 1) * sizeof(tnd_light_gpu),
                               .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                               .mem = TND_MEM_UPLOAD, .name = "scene.lights"},
        &c->lights));
    /* the light tree's nodes (at most 2 lights + 1; one unused where there is no tree) */
    TND_TRY(tnd_buffer_create(
        vk, &(tnd_buffer_desc){.size = (c->light_list.want_tree
                                            ? 2 * (s->emitter_count + s->light_count + 1) + 1
                                            : 1) * sizeof(tnd_light_node),
                               .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                               .mem = TND_MEM_UPLOAD, .name = "scene.light_nodes"},
        &c->light_nodes));
    /* ReSTIR DI's reservoirs and surfaces: a record each until fvk_set_frame makes them at the
     * frame's size (the bindings are never empty) */
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = TND_GPU_RESERVOIR_BYTES,
                                                     .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                     .mem = TND_MEM_DEVICE,
                                                     .name = "restir.reservoirs"},
                              &c->rs_reservoirs));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = TND_GPU_RSURF_BYTES,
                                                     .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                     .mem = TND_MEM_DEVICE,
                                                     .name = "restir.surfaces"},
                              &c->rs_surfaces));
    /* the environment map's texels and distributions as one float array (shaders/env.h); a
     * vec4 when there is none (the binding is never empty) */
    size_t env_bytes = s->env.width ? TND_ENV_FLOATS((size_t)s->env.width, s->env.height) * 4 : 16;
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = env_bytes,
                                                     .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                     .mem = TND_MEM_UPLOAD, .name = "scene.env"},
                              &c->env));
    if (s->env.width)
        memcpy(c->env.mapped, s->env.data, env_bytes);
    else
        memset(c->env.mapped, 0, env_bytes);
    /* (filled by each submission from the host's copy: vkCmdUpdateBuffer) */
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = sizeof(tnd_gpu_frame),
                                                     .usage = VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT |
                                                              VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                                     .mem = TND_MEM_DEVICE, .name = "frame"},
                              &c->frame_ubo));
    TND_TRY(tnd_buffer_create(vk, &(tnd_buffer_desc){.size = 64 * sizeof(tnd_gpu_gradient),
                                                     .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                     .mem = TND_MEM_UPLOAD, .name = "gradients"},
                              &c->gradients));
    c->gradient_capacity = 64;
    /* textures (a 1x1 white one when the scene has none: the binding is never empty) */
    c->texture_count = s->texture_count ? s->texture_count : 1;
    c->textures = calloc(c->texture_count, sizeof *c->textures);
    if (!c->textures) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "frontend_vk: out of memory");
        goto fail;
    }
    if (s->texture_count) {
        for (uint32_t t = 0; t < s->texture_count; t++)
            TND_TRY(upload_texture(vk, &s->textures[t], &c->textures[t]));
    } else {
        uint8_t white[4] = {255, 255, 255, 255};
        tnd_texture w = {.name = "white", .width = 1, .height = 1, .levels = 1,
                         .level_w = {1}, .level_h = {1}, .level = {white}};
        TND_TRY(upload_texture(vk, &w, &c->textures[0]));
    }
    VkSamplerCreateInfo sci = {.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO,
                               .magFilter = VK_FILTER_NEAREST, /* (texelFetch only) */
                               .minFilter = VK_FILTER_NEAREST,
                               .mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST,
                               .addressModeU = VK_SAMPLER_ADDRESS_MODE_REPEAT,
                               .addressModeV = VK_SAMPLER_ADDRESS_MODE_REPEAT,
                               .addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT,
                               .maxLod = VK_LOD_CLAMP_NONE};
    TND_VK_TRY(vkCreateSampler(vk->device, &sci, NULL, &c->sampler));
fail:
    free(gm);
    free(gmat);
    free(md);
    return res;
}

/* Static instances in BLASes of their own (c->run_of): on the H200, whose driver traverses in
 * software, two levels of many overlapping instance boxes cost more per ray than one BVH over
 * the placed triangles: whole frame at 1080p, 129 instances of Debian's morse `buildings_2`
 * 6.26 -> 4.79 ms, 115 of the 2CylinderEngine 3.30 -> 3.08, 382 of `atrium` 9.43 -> 9.25; but
 * 8 of `cornell` 2.22 -> 2.25 and 11 of `materials` 6.34 -> 6.43 (docs/performance.md). So a
 * run is a maximal sequence of FVK_MERGE_MIN or more consecutive instances whose nodes are
 * not animated, within FVK_MERGE_TRIANGLES placed triangles over all runs (the BVH's memory:
 * the instances' triangles are copied into it). Their transforms are this frame's (fixed:
 * nothing animates them). TANDEM_MERGE_STATIC (a developer switch, for timing the two against
 * each other): 0 keeps every instance on its own, N >= 2 merges runs of N or more. */
enum { FVK_MERGE_MIN = 32, FVK_MERGE_TRIANGLES = 8u << 20 };
static uint32_t vk_geometry_limit(const tnd_vk *vk)
{
    return vk->info.max_geometry_count > 0xffffffu ? 0xffffffu : (uint32_t)vk->info.max_geometry_count;
}

static tnd_result merge_static(fvk_context *c, const tnd_scene_state *cur)
{
    tnd_result res = TND_OK;
    const tnd_scene *s = c->scene;
    const char *env = getenv("TANDEM_MERGE_STATIC");
    uint32_t min_run = FVK_MERGE_MIN;
    if (env && *env) {
        char *end;
        unsigned long v = strtoul(env, &end, 10);
        min_run = *end || v == 1 ? FVK_MERGE_MIN : v > 0xffffffu ? 0xffffffu : (uint32_t)v;
    }
    fvk_mesh_desc *md = NULL;
    uint32_t *mesh_at = NULL;
    fvk_blas_part *parts = NULL;
    fvk_blas_desc *desc = NULL;
    uint32_t nruns = 0;
    if (min_run == 0 || s->instance_count < min_run)
        return TND_OK;
    c->run_of = calloc(s->instance_count, sizeof *c->run_of);
    c->run_first = calloc(s->instance_count, sizeof *c->run_first);
    md = calloc(s->mesh_count + 1, sizeof *md);
    mesh_at = calloc(s->mesh_count + 1, sizeof *mesh_at);
    parts = calloc(s->instance_count, sizeof *parts);
    desc = calloc(s->instance_count, sizeof *desc);
    if (!c->run_of || !c->run_first || !md || !mesh_at || !parts || !desc) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "frontend_vk: out of memory");
        goto fail;
    }
    /* the meshes with triangles, as fvk_scene_upload built them */
    uint32_t nz = 0;
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        const tnd_mesh *me = &s->meshes[m];
        if (!me->triangle_count)
            continue;
        mesh_at[m] = nz;
        md[nz++] = mesh_desc(s, m);
    }
    uint64_t budget = FVK_MERGE_TRIANGLES;
    uint32_t nparts = 0;
    for (uint32_t i = 0; i < s->instance_count;) {
        uint32_t j = i;
        uint64_t tris = 0;
        while (j < s->instance_count && !s->instances[j].animated &&
               s->meshes[s->instances[j].mesh].triangle_count &&
               j - i < vk_geometry_limit(c->vk) &&
               tris + s->meshes[s->instances[j].mesh].triangle_count <= budget)
            tris += s->meshes[s->instances[j++].mesh].triangle_count;
        if (j - i >= min_run) {
            desc[nruns] = (fvk_blas_desc){.parts = &parts[nparts], .part_count = j - i,
                                          .name = "static instances"};
            c->run_first[nruns] = i;
            for (uint32_t k = i; k < j; k++) {
                c->run_of[k] = nruns + 1;
                parts[nparts++] = (fvk_blas_part){mesh_at[s->instances[k].mesh],
                                                  cur->instance_xform + 12 * (size_t)k};
            }
            nruns++;
            budget -= tris;
        }
        i = j > i ? j : i + 1;
    }
    if (nruns) {
        res = fvk_blas_build_parts(c->vk, md, nz, desc, nruns, c->blas + s->mesh_count);
        if (res != TND_OK && !tnd_vk_device_lost()) {
            /* (the merge is an optimisation: out of device memory for the copies, the
             * instances stay apart and the frame goes on) */
            tnd_warn("frontend_vk", "static instances left apart: %s", tnd_error_detail());
            tnd_error_clear();
            res = TND_OK;
            nruns = 0;
        }
        if (res == TND_OK)
            c->run_count = nruns;
    }
fail:
    if (res != TND_OK || !nruns) {
        free(c->run_of);
        c->run_of = NULL;
    }
    free(md);
    free(mesh_at);
    free(parts);
    free(desc);
    return res;
}

uint32_t fvk_static_runs(const fvk_context *c, uint32_t *instances)
{
    uint32_t n = 0;
    bool on = c->run_of && !c->unmerged;
    for (uint32_t i = 0; on && instances && i < c->scene->instance_count; i++)
        n += c->run_of[i] != 0;
    if (instances)
        *instances = n;
    return on ? c->run_count : 0;
}

tnd_result fvk_scene_frame(fvk_context *c, const tnd_scene_state *cur, const tnd_scene_state *prev,
                           bool first)
{
    tnd_result res = TND_OK;
    const tnd_scene *s = c->scene;
    c->tlas_ms = 0; /* (this frame's build or refit only: a still scene's frames have none) */
    TND_TRY(tnd_lights_build(s, cur, &c->light_list));
    if (c->light_list.count)
        memcpy(c->lights.mapped, c->light_list.lights,
               c->light_list.count * sizeof(tnd_light_gpu));
    if (c->light_list.node_count)
        memcpy(c->light_nodes.mapped, c->light_list.nodes,
               c->light_list.node_count * sizeof(tnd_light_node));
    if (!c->merge_tried) {
        c->merge_tried = true;
        TND_TRY(merge_static(c, cur));
    }
    tnd_gpu_instance *gi = c->instances.mapped;
    bool moved = first, unmerge = false;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        const float *x = cur->instance_xform + 12 * i, *px = prev->instance_xform + 12 * i;
        bool m = memcmp(c->last_xf + 12 * (size_t)i, x, 12 * sizeof(float)) != 0;
        moved |= m;
        /* (a merged instance that moved since the last TLAS build: first frames too) */
        unmerge |= m && c->tlas.as && c->run_of && c->run_of[i] && !c->unmerged;
        memcpy(c->last_xf + 12 * (size_t)i, x, 12 * sizeof(float));
        memcpy(gi[i].xform, x, 12 * sizeof(float));
        memcpy(gi[i].prev_xform, px, 12 * sizeof(float));
        gi[i].info = (tnd_guvec4){s->instances[i].mesh, c->light_list.instance_first[i],
                                  c->alpha_at[s->instances[i].mesh], 0};
    }
    c->unmerged |= unmerge; /* (from here on every instance is its own; the BLASes stay) */
    if (moved) {
        static const float identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
        uint32_t n = 0;
        for (uint32_t i = 0; i < s->instance_count; i++) {
            uint32_t r = c->run_of && !c->unmerged ? c->run_of[i] : 0;
            if (r && c->run_first[r - 1] != i)
                continue; /* (in its run's BLAS) */
            c->inst[n] = (fvk_instance){.blas = r ? s->mesh_count + r - 1 : s->instances[i].mesh,
                                        .custom_index = i};
            memcpy(c->inst[n++].transform, r ? identity : c->last_xf + 12 * (size_t)i,
                   12 * sizeof(float));
        }
        double t0 = tnd_now();
        TND_TRY(fvk_tlas_build(c->vk, c->blas, s->mesh_count + c->run_count, c->inst, n,
                               !first && !unmerge, &c->tlas));
        c->tlas_ms = 1e3 * (tnd_now() - t0);
    }
fail:
    return res;
}
