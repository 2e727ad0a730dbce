/* core/vk_pipeline.c: shader modules, compute and ray-tracing pipelines, shader binding tables,
 * and timestamp queries.
 *
 * SBT layout follows the Vulkan spec's rules (VK_KHR_ray_tracing_pipeline): each region starts
 * at a multiple of shaderGroupBaseAlignment, its stride is a multiple of
 * shaderGroupHandleAlignment, and a raygen region's size equals its stride. The numbers come from
 * the device; lavapipe and NVIDIA differ (docs: platform.md).
 * Entry points: tnd_shader_module_create, tnd_compute_pipeline_create, tnd_rt_pipeline_create,
 * tnd_sbt_compute_layout, tnd_sbt_destroy, tnd_timer_*. */
#include "core/core.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static VkDeviceSize align_up(VkDeviceSize v, VkDeviceSize a)
{
    return (v + a - 1) / a * a;
}

static bool is_pow2(uint32_t v)
{
    return v && !(v & (v - 1));
}

tnd_result tnd_shader_module_create(tnd_vk *vk, const uint32_t *code, size_t bytes,
                                    const char *name, VkShaderModule *mod)
{
    tnd_result res = TND_OK;
    *mod = VK_NULL_HANDLE;
    if (!code || bytes < 20 || bytes % 4 || code[0] != 0x07230203u)
        return tnd_fail(TND_ERR_BAD_INPUT, "vulkan: shader '%s': not SPIR-V (%zu bytes)",
                        name ? name : "?", bytes);
    VkShaderModuleCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO, .codeSize = bytes, .pCode = code};
    TND_VK_TRY(vkCreateShaderModule(vk->device, &ci, NULL, mod));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_SHADER_MODULE, *mod, "%s", name ? name : "shader");
fail:
    return res;
}

/* The compiler's statistics of each executable of a pipeline (VK_KHR_pipeline_executable_
 * properties; NVIDIA reports registers and code size), one line per executable on stderr. */
static void print_statistics(tnd_vk *vk, VkPipeline pipe, const char *name)
{
    PFN_vkGetPipelineExecutablePropertiesKHR props_fn =
        (PFN_vkGetPipelineExecutablePropertiesKHR)vkGetDeviceProcAddr(
            vk->device, "vkGetPipelineExecutablePropertiesKHR");
    PFN_vkGetPipelineExecutableStatisticsKHR stats_fn =
        (PFN_vkGetPipelineExecutableStatisticsKHR)vkGetDeviceProcAddr(
            vk->device, "vkGetPipelineExecutableStatisticsKHR");
    if (!props_fn || !stats_fn)
        return;
    VkPipelineInfoKHR pi = {.sType = VK_STRUCTURE_TYPE_PIPELINE_INFO_KHR, .pipeline = pipe};
    VkPipelineExecutablePropertiesKHR props[16]; /* (a ray-tracing pipeline: one per shader) */
    uint32_t n = 16;
    for (uint32_t k = 0; k < n; k++)
        props[k] = (VkPipelineExecutablePropertiesKHR){
            .sType = VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_PROPERTIES_KHR};
    if (props_fn(vk->device, &pi, &n, props) < 0)
        return;
    for (uint32_t k = 0; k < n; k++) {
        VkPipelineExecutableInfoKHR ei = {.sType = VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INFO_KHR,
                                          .pipeline = pipe,
                                          .executableIndex = k};
        VkPipelineExecutableStatisticKHR st[32];
        uint32_t m = 32;
        for (uint32_t j = 0; j < m; j++)
            st[j] = (VkPipelineExecutableStatisticKHR){
                .sType = VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_STATISTIC_KHR};
        if (stats_fn(vk->device, &ei, &m, st) < 0)
            continue;
        char line[1024];
        int len = snprintf(line, sizeof line, "pipeline stats: %s [%s]", name, props[k].name);
        for (uint32_t j = 0; j < m && len > 0 && (size_t)len < sizeof line; j++) {
            const VkPipelineExecutableStatisticKHR *s = &st[j];
            char v[64];
            switch (s->format) {
            case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_BOOL32_KHR:
                snprintf(v, sizeof v, "%s", s->value.b32 ? "yes" : "no");
                break;
            case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_INT64_KHR:
                snprintf(v, sizeof v, "%lld", (long long)s->value.i64);
                break;
            case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_UINT64_KHR:
                snprintf(v, sizeof v, "%llu", (unsigned long long)s->value.u64);
                break;
            default:
                snprintf(v, sizeof v, "%g", s->value.f64);
            }
            len += snprintf(line + len, sizeof line - (size_t)len, "; %s %s", s->name, v);
        }
        fprintf(stderr, "%s\n", line);
    }
}

tnd_result tnd_compute_pipeline_create(tnd_vk *vk, const tnd_compute_desc *desc, VkPipeline *pipe)
{
    tnd_result res = TND_OK;
    VkShaderModule mod = VK_NULL_HANDLE;
    *pipe = VK_NULL_HANDLE;
    TND_TRY(tnd_shader_module_create(vk, desc->code, desc->bytes, desc->name, &mod));
    VkComputePipelineCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
        .stage = {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                  .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                  .module = mod,
                  .pName = "main",
                  .pSpecializationInfo = desc->spec},
        .layout = desc->layout,
        .flags = vk->pipeline_stats ? VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR : 0,
    };
    TND_VK_TRY(vkCreateComputePipelines(vk->device, VK_NULL_HANDLE, 1, &ci, NULL, pipe));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_PIPELINE, *pipe, "%s", desc->name ? desc->name : "compute");
    if (vk->pipeline_stats)
        print_statistics(vk, *pipe, desc->name ? desc->name : "compute");
fail:
    if (mod)
        vkDestroyShaderModule(vk->device, mod, NULL);
    return res;
}

tnd_result tnd_sbt_compute_layout(uint32_t handle_size, uint32_t handle_alignment,
                                  uint32_t base_alignment, uint32_t raygen_count,
                                  uint32_t miss_count, uint32_t hit_count, tnd_sbt_layout *out)
{
    memset(out, 0, sizeof *out);
    if (!handle_size || !is_pow2(handle_alignment) || !is_pow2(base_alignment) ||
        raygen_count == 0 || raygen_count > TND_RT_MAX_GROUPS ||
        raygen_count + miss_count + hit_count > TND_RT_MAX_GROUPS)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                        "sbt: bad layout request (handle %u, alignments %u/%u, groups %u/%u/%u)",
                        handle_size, handle_alignment, base_alignment, raygen_count, miss_count,
                        hit_count);
    VkDeviceSize stride = align_up(handle_size, handle_alignment);
    out->handle_stride = (uint32_t)stride;
    /* Each raygen group gets its own region, so that one pipeline serves several passes. */
    VkDeviceSize rg = align_up(stride, base_alignment);
    out->raygen_size = stride;
    VkDeviceSize off = 0;
    for (uint32_t i = 0; i < raygen_count; i++) {
        out->raygen_offset[i] = off;
        off += rg;
    }
    out->miss_offset = off;
    out->miss_size = align_up(miss_count * stride, base_alignment);
    off += out->miss_size;
    out->hit_offset = off;
    out->hit_size = align_up(hit_count * stride, base_alignment);
    off += out->hit_size;
    out->total = off ? off : base_alignment;
    return TND_OK;
}

tnd_result tnd_rt_pipeline_create(tnd_vk *vk, const tnd_rt_desc *desc, VkPipeline *pipe,
                                  tnd_sbt *sbt)
{
    tnd_result res = TND_OK;
    const char *name = desc->name ? desc->name : "rt";
    VkShaderModule mods[TND_RT_MAX_GROUPS * 2] = {0};
    VkPipelineShaderStageCreateInfo stages[TND_RT_MAX_GROUPS * 2];
    VkRayTracingShaderGroupCreateInfoKHR groups[TND_RT_MAX_GROUPS];
    uint8_t *handles = NULL;
    *pipe = VK_NULL_HANDLE;
    memset(sbt, 0, sizeof *sbt);
    if (!vk->ray_tracing)
        return tnd_fail(TND_ERR_UNSUPPORTED, "vulkan: %s: device '%s' has no ray tracing", name,
                        vk->info.name);
    uint32_t ngroups = desc->raygen_count + desc->miss_count + desc->hit_count;
    if (desc->stage_count > TND_RT_MAX_GROUPS * 2 || ngroups > TND_RT_MAX_GROUPS)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "vulkan: %s: too many stages or groups", name);
    uint32_t recursion = desc->max_recursion ? desc->max_recursion : 1;
    if (recursion > vk->info.max_ray_recursion_depth)
        return tnd_fail(TND_ERR_LIMIT, "vulkan: %s: recursion %u > device maximum %u", name,
                        recursion, vk->info.max_ray_recursion_depth);

    tnd_sbt_layout lay;
    TND_TRY(tnd_sbt_compute_layout(vk->info.shader_group_handle_size,
                                   vk->info.shader_group_handle_alignment,
                                   vk->info.shader_group_base_alignment, desc->raygen_count,
                                   desc->miss_count, desc->hit_count, &lay));

    for (uint32_t i = 0; i < desc->stage_count; i++) {
        TND_TRY(tnd_shader_module_create(vk, desc->stages[i].code, desc->stages[i].bytes, name,
                                         &mods[i]));
        stages[i] = (VkPipelineShaderStageCreateInfo){
            .sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
            .stage = desc->stages[i].stage,
            .module = mods[i],
            .pName = "main",
            .pSpecializationInfo = desc->spec,
        };
    }
    uint32_t g = 0;
    for (uint32_t i = 0; i < desc->raygen_count + desc->miss_count; i++, g++) {
        uint32_t s = i < desc->raygen_count ? desc->raygen[i] : desc->miss[i - desc->raygen_count];
        if (s >= desc->stage_count) {
            res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "vulkan: %s: stage index %u", name, s);
            goto fail;
        }
        groups[g] = (VkRayTracingShaderGroupCreateInfoKHR){
            .sType = VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR,
            .type = VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR,
            .generalShader = s,
            .closestHitShader = VK_SHADER_UNUSED_KHR,
            .anyHitShader = VK_SHADER_UNUSED_KHR,
            .intersectionShader = VK_SHADER_UNUSED_KHR,
        };
    }
    for (uint32_t i = 0; i < desc->hit_count; i++, g++) {
        int ch = desc->hit[i].closest_hit, ah = desc->hit[i].any_hit;
        groups[g] = (VkRayTracingShaderGroupCreateInfoKHR){
            .sType = VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR,
            .type = VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR,
            .generalShader = VK_SHADER_UNUSED_KHR,
            .closestHitShader = ch >= 0 ? (uint32_t)ch : VK_SHADER_UNUSED_KHR,
            .anyHitShader = ah >= 0 ? (uint32_t)ah : VK_SHADER_UNUSED_KHR,
            .intersectionShader = VK_SHADER_UNUSED_KHR,
        };
    }
    VkRayTracingPipelineCreateInfoKHR ci = {
        .sType = VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR,
        .stageCount = desc->stage_count,
        .pStages = stages,
        .groupCount = ngroups,
        .pGroups = groups,
        .maxPipelineRayRecursionDepth = recursion,
        .layout = desc->layout,
        .flags = vk->pipeline_stats ? VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR : 0,
    };
    TND_VK_TRY(vk->fn.vkCreateRayTracingPipelinesKHR(vk->device, VK_NULL_HANDLE, VK_NULL_HANDLE, 1,
                                                     &ci, NULL, pipe));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_PIPELINE, *pipe, "%s", name);
    if (vk->pipeline_stats)
        print_statistics(vk, *pipe, name);

    /* Fetch the handles and write them at their aligned places. */
    uint32_t hs = vk->info.shader_group_handle_size;
    handles = malloc((size_t)ngroups * hs);
    if (!handles) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "vulkan: %s: out of memory", name);
        goto fail;
    }
    TND_VK_TRY(vk->fn.vkGetRayTracingShaderGroupHandlesKHR(vk->device, *pipe, 0, ngroups,
                                                           (size_t)ngroups * hs, handles));
    char bname[128];
    snprintf(bname, sizeof bname, "%s.sbt", name);
    /* The buffer's own address must honour the base alignment: allocate slack and offset. */
    VkDeviceSize slack = vk->info.shader_group_base_alignment;
    TND_TRY(
        tnd_buffer_create(vk,
                          &(tnd_buffer_desc){.size = lay.total + slack,
                                             .usage = VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR,
                                             .mem = TND_MEM_UPLOAD,
                                             .device_address = true,
                                             .name = bname},
                          &sbt->buffer));
    VkDeviceAddress base = align_up(sbt->buffer.address, slack);
    uint8_t *dst = (uint8_t *)sbt->buffer.mapped + (base - sbt->buffer.address);
    memset(sbt->buffer.mapped, 0, lay.total + slack);
    g = 0;
    for (uint32_t i = 0; i < desc->raygen_count; i++, g++) {
        memcpy(dst + lay.raygen_offset[i], handles + (size_t)g * hs, hs);
        sbt->raygen[i] = (VkStridedDeviceAddressRegionKHR){base + lay.raygen_offset[i],
                                                           lay.raygen_size, lay.raygen_size};
    }
    for (uint32_t i = 0; i < desc->miss_count; i++, g++)
        memcpy(dst + lay.miss_offset + i * lay.handle_stride, handles + (size_t)g * hs, hs);
    for (uint32_t i = 0; i < desc->hit_count; i++, g++)
        memcpy(dst + lay.hit_offset + i * lay.handle_stride, handles + (size_t)g * hs, hs);
    if (desc->miss_count)
        sbt->miss = (VkStridedDeviceAddressRegionKHR){base + lay.miss_offset, lay.handle_stride,
                                                      desc->miss_count * lay.handle_stride};
    if (desc->hit_count)
        sbt->hit = (VkStridedDeviceAddressRegionKHR){base + lay.hit_offset, lay.handle_stride,
                                                     desc->hit_count * lay.handle_stride};
    sbt->raygen_count = desc->raygen_count;
fail:
    free(handles);
    for (uint32_t i = 0; i < TND_RT_MAX_GROUPS * 2; i++)
        if (mods[i])
            vkDestroyShaderModule(vk->device, mods[i], NULL);
    if (res != TND_OK) {
        if (*pipe)
            vkDestroyPipeline(vk->device, *pipe, NULL);
        *pipe = VK_NULL_HANDLE;
        tnd_sbt_destroy(vk, sbt);
    }
    return res;
}

void tnd_sbt_destroy(tnd_vk *vk, tnd_sbt *sbt)
{
    tnd_buffer_destroy(vk, &sbt->buffer);
    memset(sbt, 0, sizeof *sbt);
}

tnd_result tnd_timer_create(tnd_vk *vk, tnd_timer *t)
{
    tnd_result res = TND_OK;
    memset(t, 0, sizeof *t);
    if (!vk->info.timestamps)
        return TND_OK; /* no timestamps: every read reports 0 ms */
    VkQueryPoolCreateInfo ci = {.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
                                .queryType = VK_QUERY_TYPE_TIMESTAMP,
                                .queryCount = 2 * TND_TIMER_MAX_PASSES};
    TND_VK_TRY(vkCreateQueryPool(vk->device, &ci, NULL, &t->pool));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_QUERY_POOL, t->pool, "tandem.timestamps");
    t->period_ns = vk->info.timestamp_period_ns;
    uint32_t nq = 32;
    VkQueueFamilyProperties qf[32];
    vkGetPhysicalDeviceQueueFamilyProperties(vk->phys, &nq, qf);
    uint32_t bits = qf[vk->queue_family].timestampValidBits;
    t->valid_mask = bits >= 64 ? UINT64_MAX : ((1ull << bits) - 1);
fail:
    return res;
}

void tnd_timer_destroy(tnd_vk *vk, tnd_timer *t)
{
    if (t->pool)
        vkDestroyQueryPool(vk->device, t->pool, NULL);
    memset(t, 0, sizeof *t);
}

void tnd_timer_reset(VkCommandBuffer cmd, tnd_timer *t)
{
    t->count = 0;
    if (t->pool)
        vkCmdResetQueryPool(cmd, t->pool, 0, 2 * TND_TIMER_MAX_PASSES);
}

int tnd_timer_begin(VkCommandBuffer cmd, tnd_timer *t, const char *name)
{
    if (t->count >= TND_TIMER_MAX_PASSES)
        return -1;
    int slot = (int)t->count++;
    t->names[slot] = name;
    if (t->pool)
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, t->pool, 2 * (uint32_t)slot);
    return slot;
}

void tnd_timer_end(VkCommandBuffer cmd, tnd_timer *t, int slot)
{
    if (slot >= 0 && t->pool)
        vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, t->pool,
                            2 * (uint32_t)slot + 1);
}

tnd_result tnd_timer_read(tnd_vk *vk, const tnd_timer *t, double *ms)
{
    tnd_result res = TND_OK;
    if (!t->pool || t->count == 0) {
        for (uint32_t i = 0; i < t->count; i++)
            ms[i] = 0.0;
        return TND_OK;
    }
    uint64_t q[2 * TND_TIMER_MAX_PASSES];
    TND_VK_TRY(vkGetQueryPoolResults(vk->device, t->pool, 0, 2 * t->count, sizeof q, q,
                                     sizeof(uint64_t),
                                     VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    for (uint32_t i = 0; i < t->count; i++) {
        uint64_t a = q[2 * i] & t->valid_mask, b = q[2 * i + 1] & t->valid_mask;
        uint64_t d = (b - a) & t->valid_mask; /* wraps correctly within the valid bits */
        ms[i] = (double)d * (double)t->period_ns * 1e-6;
    }
fail:
    return res;
}
