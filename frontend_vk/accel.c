/* frontend_vk/accel.c: bottom- and top-level acceleration structures.
 *
 * BLAS: built with ALLOW_COMPACTION | PREFER_FAST_TRACE, then copied into a buffer of the
 * compacted size (typically about half). TLAS: ALLOW_UPDATE so that moving instances refit
 * rather than rebuild. Scratch addresses honour minAccelerationStructureScratchOffsetAlignment.
 * A BLAS may hold several meshes, each with the transform its vertices take as it is built
 * (fvk_blas_build_parts: the static instances of a scene in one BLAS, fvk_scene.c).
 * Entry points: fvk_blas_build, fvk_blas_build_parts, fvk_blas_destroy, fvk_tlas_build,
 * fvk_tlas_destroy. */
#include "frontend_vk/frontend_vk.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static VkDeviceSize align_up(VkDeviceSize v, VkDeviceSize a)
{
    return a ? (v + a - 1) / a * a : v;
}

static tnd_result create_as(tnd_vk *vk, VkAccelerationStructureTypeKHR type, VkDeviceSize size,
                            const char *name, tnd_buffer *storage, VkAccelerationStructureKHR *as)
{
    tnd_result res = TND_OK;
    TND_TRY(tnd_buffer_create(
        vk,
        &(tnd_buffer_desc){.size = size,
                           .usage = VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR,
                           .device_address = true,
                           .name = name},
        storage));
    VkAccelerationStructureCreateInfoKHR ci = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_KHR,
        .buffer = storage->buffer,
        .size = size,
        .type = type};
    TND_VK_TRY(vk->fn.vkCreateAccelerationStructureKHR(vk->device, &ci, NULL, as));
    TND_VK_NAME(vk, VK_OBJECT_TYPE_ACCELERATION_STRUCTURE_KHR, *as, "%s", name);
fail:
    return res;
}

static VkDeviceAddress as_address(tnd_vk *vk, VkAccelerationStructureKHR as)
{
    VkAccelerationStructureDeviceAddressInfoKHR ai = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_DEVICE_ADDRESS_INFO_KHR,
        .accelerationStructure = as};
    return vk->fn.vkGetAccelerationStructureDeviceAddressKHR(vk->device, &ai);
}

static tnd_result scratch_buffer(tnd_vk *vk, VkDeviceSize size, const char *name, tnd_buffer *b)
{
    VkDeviceSize a = vk->info.min_scratch_offset_alignment;
    return tnd_buffer_create(vk,
                             &(tnd_buffer_desc){.size = size + a,
                                                .usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                .device_address = true,
                                                .name = name},
                             b);
}

void fvk_blas_destroy(tnd_vk *vk, fvk_blas *blas)
{
    if (blas->as)
        vk->fn.vkDestroyAccelerationStructureKHR(vk->device, blas->as, NULL);
    tnd_buffer_destroy(vk, &blas->storage);
    memset(blas, 0, sizeof *blas);
}

tnd_result fvk_blas_build(tnd_vk *vk, const fvk_mesh_desc *meshes, uint32_t count, fvk_blas *out)
{
    fvk_blas_part *parts = calloc(count ? count : 1, sizeof *parts);
    fvk_blas_desc *desc = calloc(count ? count : 1, sizeof *desc);
    tnd_result res = TND_OK;
    if (!parts || !desc) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "accel: out of memory");
        goto fail;
    }
    for (uint32_t m = 0; m < count; m++) {
        parts[m] = (fvk_blas_part){.mesh = m};
        desc[m] = (fvk_blas_desc){.parts = &parts[m], .part_count = 1, .name = meshes[m].name};
    }
    res = fvk_blas_build_parts(vk, meshes, count, desc, count, out);
fail:
    free(parts);
    free(desc);
    return res;
}

tnd_result fvk_blas_build_parts(tnd_vk *vk, const fvk_mesh_desc *meshes, uint32_t mesh_count,
                                const fvk_blas_desc *desc, uint32_t count, fvk_blas *out)
{
    tnd_result res = TND_OK;
    tnd_buffer geo = {0}, scratch = {0}, xform = {0};
    VkQueryPool query = VK_NULL_HANDLE;
    uint32_t nparts = 0;
    bool transforms = false;
    for (uint32_t b = 0; b < count; b++) {
        nparts += desc[b].part_count;
        for (uint32_t p = 0; p < desc[b].part_count; p++)
            transforms |= desc[b].parts[p].transform != NULL;
    }
    fvk_blas *tmp = calloc(count ? count : 1, sizeof *tmp);
    VkDeviceSize *vtx_off = calloc(mesh_count ? mesh_count : 1, sizeof *vtx_off);
    VkDeviceSize *idx_off = calloc(mesh_count ? mesh_count : 1, sizeof *idx_off);
    VkAccelerationStructureGeometryKHR *geoms = calloc(nparts ? nparts : 1, sizeof *geoms);
    VkAccelerationStructureBuildRangeInfoKHR *ranges = calloc(nparts ? nparts : 1, sizeof *ranges);
    uint32_t *prims = calloc(nparts ? nparts : 1, sizeof *prims);
    VkAccelerationStructureBuildGeometryInfoKHR *infos = calloc(count ? count : 1, sizeof *infos);
    VkDeviceSize *scratch_off = calloc(count ? count : 1, sizeof *scratch_off);
    uint64_t *compact = calloc(count ? count : 1, sizeof *compact);
    memset(out, 0, sizeof *out * count);
    if (!tmp || !vtx_off || !idx_off || !geoms || !ranges || !prims || !infos || !scratch_off ||
        !compact) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "accel: out of memory");
        goto fail;
    }
    /* Validate and lay out all meshes in one geometry buffer. */
    VkDeviceSize total = 0;
    for (uint32_t m = 0; m < mesh_count; m++) {
        const fvk_mesh_desc *d = &meshes[m];
        const char *nm = d->name ? d->name : "";
        if (d->triangle_count == 0 || d->vertex_count == 0) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "accel: mesh %u '%s': empty", m, nm);
            goto fail;
        }
        if (d->triangle_count > vk->info.max_primitive_count) {
            res =
                tnd_fail(TND_ERR_LIMIT, "accel: mesh %u '%s': %u triangles > device limit %llu", m,
                         nm, d->triangle_count, (unsigned long long)vk->info.max_primitive_count);
            goto fail;
        }
        for (uint64_t i = 0; i < 3ull * d->triangle_count; i++) {
            if (d->indices[i] >= d->vertex_count) {
                res = tnd_fail(TND_ERR_BAD_INPUT,
                               "accel: mesh %u '%s': index %u out of range (%u vertices)", m, nm,
                               d->indices[i], d->vertex_count);
                goto fail;
            }
        }
        vtx_off[m] = total;
        total = align_up(total + 12ull * d->vertex_count, 16);
        idx_off[m] = total;
        total = align_up(total + 12ull * d->triangle_count, 16);
    }
    /* ... and each BLAS's geometries: within the device's limits, meshes that exist */
    for (uint32_t b = 0; b < count; b++) {
        uint64_t tris = 0;
        for (uint32_t p = 0; p < desc[b].part_count; p++) {
            if (desc[b].parts[p].mesh >= mesh_count) {
                res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "accel: BLAS %u: mesh %u of %u", b,
                               desc[b].parts[p].mesh, mesh_count);
                goto fail;
            }
            tris += meshes[desc[b].parts[p].mesh].triangle_count;
        }
        if (desc[b].part_count == 0 || tris > vk->info.max_primitive_count ||
            (desc[b].part_count > 1 && desc[b].part_count > vk->info.max_geometry_count)) {
            res = tnd_fail(TND_ERR_LIMIT,
                           "accel: BLAS %u '%s': %u geometries, %llu triangles (device limits "
                           "%llu, %llu)",
                           b, desc[b].name ? desc[b].name : "", desc[b].part_count,
                           (unsigned long long)tris,
                           (unsigned long long)vk->info.max_geometry_count,
                           (unsigned long long)vk->info.max_primitive_count);
            goto fail;
        }
    }
    if (count == 0 || mesh_count == 0)
        goto fail; /* nothing to build; res is TND_OK */
    TND_TRY(tnd_buffer_create(
        vk,
        &(tnd_buffer_desc){
            .size = total,
            .usage = VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR |
                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
            .device_address = true,
            .name = "accel.blas_input"},
        &geo));
    {
        uint8_t *staging = malloc(total);
        if (!staging) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "accel: out of memory");
            goto fail;
        }
        for (uint32_t m = 0; m < mesh_count; m++) {
            memcpy(staging + vtx_off[m], meshes[m].positions, 12ull * meshes[m].vertex_count);
            memcpy(staging + idx_off[m], meshes[m].indices, 12ull * meshes[m].triangle_count);
        }
        res = tnd_buffer_upload(vk, &geo, 0, staging, total);
        free(staging);
        if (res != TND_OK)
            goto fail;
    }
    /* the parts' transforms (VkTransformMatrixKHR: 3x4 row-major, 48 bytes, 16-byte aligned),
     * applied to the vertices as the BLAS is built; identity for a part without one */
    if (transforms) {
        TND_TRY(tnd_buffer_create(
            vk,
            &(tnd_buffer_desc){
                .size = 48ull * nparts,
                .usage = VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR |
                         VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                .device_address = true,
                .name = "accel.blas_transforms"},
            &xform));
        float *x = malloc(48ull * nparts);
        if (!x) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "accel: out of memory");
            goto fail;
        }
        static const float identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
        for (uint32_t b = 0, k = 0; b < count; b++)
            for (uint32_t p = 0; p < desc[b].part_count; p++, k++)
                memcpy(x + 12 * (size_t)k,
                       desc[b].parts[p].transform ? desc[b].parts[p].transform : identity, 48);
        res = tnd_buffer_upload(vk, &xform, 0, x, 48ull * nparts);
        free(x);
        if (res != TND_OK)
            goto fail;
    }

    VkDeviceSize scratch_total = 0, sa = vk->info.min_scratch_offset_alignment;
    for (uint32_t b = 0, k = 0; b < count; b++) {
        uint32_t first = k;
        for (uint32_t p = 0; p < desc[b].part_count; p++, k++) {
            const fvk_mesh_desc *d = &meshes[desc[b].parts[p].mesh];
            uint32_t m = desc[b].parts[p].mesh;
            geoms[k] = (VkAccelerationStructureGeometryKHR){
                .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR,
                .geometryType = VK_GEOMETRY_TYPE_TRIANGLES_KHR,
                /* alpha-tested geometry: any-hit once per triangle (the test has no side
                 * effects, but a second call would be wasted) */
                .flags = d->alpha_tested ? VK_GEOMETRY_NO_DUPLICATE_ANY_HIT_INVOCATION_BIT_KHR
                                         : VK_GEOMETRY_OPAQUE_BIT_KHR,
                .geometry.triangles = {
                    .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR,
                    .vertexFormat = VK_FORMAT_R32G32B32_SFLOAT,
                    .vertexData.deviceAddress = geo.address + vtx_off[m],
                    .vertexStride = 12,
                    .maxVertex = d->vertex_count - 1,
                    .indexType = VK_INDEX_TYPE_UINT32,
                    .indexData.deviceAddress = geo.address + idx_off[m],
                    .transformData.deviceAddress = transforms ? xform.address + 48ull * k : 0,
                }};
            ranges[k] = (VkAccelerationStructureBuildRangeInfoKHR){.primitiveCount =
                                                                       d->triangle_count};
            prims[k] = d->triangle_count;
        }
        infos[b] = (VkAccelerationStructureBuildGeometryInfoKHR){
            .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR,
            .type = VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR,
            .flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR |
                     VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_COMPACTION_BIT_KHR,
            .mode = VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR,
            .geometryCount = desc[b].part_count,
            .pGeometries = &geoms[first]};
        VkAccelerationStructureBuildSizesInfoKHR sz = {
            .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
        vk->fn.vkGetAccelerationStructureBuildSizesKHR(
            vk->device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &infos[b], &prims[first],
            &sz);
        char name[96];
        snprintf(name, sizeof name, "accel.blas[%u].build", b);
        TND_TRY(create_as(vk, VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR,
                          sz.accelerationStructureSize, name, &tmp[b].storage, &tmp[b].as));
        tmp[b].built_bytes = sz.accelerationStructureSize;
        infos[b].dstAccelerationStructure = tmp[b].as;
        scratch_off[b] = scratch_total;
        scratch_total = align_up(scratch_total + sz.buildScratchSize, sa);
    }
    TND_TRY(scratch_buffer(vk, scratch_total, "accel.blas_scratch", &scratch));
    VkDeviceAddress sbase = align_up(scratch.address, sa);
    for (uint32_t b = 0; b < count; b++)
        infos[b].scratchData.deviceAddress = sbase + scratch_off[b];

    VkQueryPoolCreateInfo qci = {.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
                                 .queryType =
                                     VK_QUERY_TYPE_ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
                                 .queryCount = count};
    TND_VK_TRY(vkCreateQueryPool(vk->device, &qci, NULL, &query));
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    vkCmdResetQueryPool(cmd, query, 0, count);
    /* One build call per BLAS keeps the pointer arrays simple; builds run back to back. */
    for (uint32_t b = 0, k = 0; b < count; k += desc[b].part_count, b++) {
        const VkAccelerationStructureBuildRangeInfoKHR *r = &ranges[k];
        vk->fn.vkCmdBuildAccelerationStructuresKHR(cmd, 1, &infos[b], &r);
    }
    tnd_cmd_barrier(cmd);
    VkAccelerationStructureKHR *handles = malloc(count * sizeof *handles);
    if (!handles) {
        vkEndCommandBuffer(cmd);
        vkFreeCommandBuffers(vk->device, vk->cmd_pool, 1, &cmd);
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "accel: out of memory");
        goto fail;
    }
    for (uint32_t b = 0; b < count; b++)
        handles[b] = tmp[b].as;
    vk->fn.vkCmdWriteAccelerationStructuresPropertiesKHR(
        cmd, count, handles, VK_QUERY_TYPE_ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR, query, 0);
    free(handles);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
    TND_VK_TRY(vkGetQueryPoolResults(vk->device, query, 0, count, count * sizeof(uint64_t), compact,
                                     sizeof(uint64_t),
                                     VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));

    /* Compact: copy each BLAS into a right-sized one. */
    for (uint32_t b = 0, k = 0; b < count; b++) {
        char name[96];
        snprintf(name, sizeof name, "accel.blas[%u] %s", b, desc[b].name ? desc[b].name : "");
        TND_TRY(create_as(vk, VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR, compact[b], name,
                          &out[b].storage, &out[b].as));
        out[b].compacted_bytes = compact[b];
        out[b].built_bytes = tmp[b].built_bytes;
        for (uint32_t p = 0; p < desc[b].part_count; p++, k++)
            out[b].triangle_count += prims[k];
    }
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    for (uint32_t b = 0; b < count; b++) {
        VkCopyAccelerationStructureInfoKHR ci = {
            .sType = VK_STRUCTURE_TYPE_COPY_ACCELERATION_STRUCTURE_INFO_KHR,
            .src = tmp[b].as,
            .dst = out[b].as,
            .mode = VK_COPY_ACCELERATION_STRUCTURE_MODE_COMPACT_KHR};
        vk->fn.vkCmdCopyAccelerationStructureKHR(cmd, &ci);
    }
    tnd_cmd_barrier(cmd);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
    for (uint32_t b = 0; b < count; b++)
        out[b].address = as_address(vk, out[b].as);
fail:
    if (res != TND_OK)
        for (uint32_t b = 0; b < count; b++)
            fvk_blas_destroy(vk, &out[b]);
    for (uint32_t b = 0; tmp && b < count; b++)
        fvk_blas_destroy(vk, &tmp[b]);
    if (query)
        vkDestroyQueryPool(vk->device, query, NULL);
    tnd_buffer_destroy(vk, &scratch);
    tnd_buffer_destroy(vk, &xform);
    tnd_buffer_destroy(vk, &geo);
    free(tmp);
    free(vtx_off);
    free(idx_off);
    free(geoms);
    free(ranges);
    free(prims);
    free(infos);
    free(scratch_off);
    free(compact);
    return res;
}

void fvk_tlas_destroy(tnd_vk *vk, fvk_tlas *tlas)
{
    if (tlas->as)
        vk->fn.vkDestroyAccelerationStructureKHR(vk->device, tlas->as, NULL);
    tnd_buffer_destroy(vk, &tlas->storage);
    tnd_buffer_destroy(vk, &tlas->instances);
    tnd_buffer_destroy(vk, &tlas->scratch);
    memset(tlas, 0, sizeof *tlas);
}

tnd_result fvk_tlas_build(tnd_vk *vk, const fvk_blas *blas, uint32_t blas_count,
                          const fvk_instance *inst, uint32_t count, bool refit, fvk_tlas *tlas)
{
    tnd_result res = TND_OK;
    if (count == 0 || count > vk->info.max_instance_count)
        return tnd_fail(TND_ERR_LIMIT, "accel: %u instances (device limit %llu)", count,
                        (unsigned long long)vk->info.max_instance_count);
    for (uint32_t i = 0; i < count; i++)
        if (inst[i].blas >= blas_count || inst[i].custom_index >= (1u << 24))
            return tnd_fail(TND_ERR_INVALID_ARGUMENT,
                            "accel: instance %u: BLAS %u of %u, custom index %u (24 bits)", i,
                            inst[i].blas, blas_count, inst[i].custom_index);
    bool can_refit = refit && tlas->as && tlas->count == count;
    if (!can_refit && tlas->as && tlas->capacity < count)
        fvk_tlas_destroy(vk, tlas);
    if (!tlas->instances.buffer) {
        TND_TRY(tnd_buffer_create(
            vk,
            &(tnd_buffer_desc){
                .size = count * sizeof(VkAccelerationStructureInstanceKHR),
                .usage = VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR,
                .mem = TND_MEM_UPLOAD,
                .device_address = true,
                .name = "accel.tlas_instances"},
            &tlas->instances));
        tlas->capacity = count;
    }
    VkAccelerationStructureInstanceKHR *vi = tlas->instances.mapped;
    for (uint32_t i = 0; i < count; i++) {
        vi[i] = (VkAccelerationStructureInstanceKHR){
            .instanceCustomIndex = inst[i].custom_index,
            .mask = inst[i].mask ? inst[i].mask : 0xff,
            .instanceShaderBindingTableRecordOffset = 0,
            .flags = VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR,
            .accelerationStructureReference = blas[inst[i].blas].address};
        memcpy(&vi[i].transform, inst[i].transform, sizeof vi[i].transform);
    }
    VkAccelerationStructureGeometryKHR geom = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_KHR,
        .geometryType = VK_GEOMETRY_TYPE_INSTANCES_KHR,
        .geometry.instances = {
            .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_INSTANCES_DATA_KHR,
            .data.deviceAddress = tlas->instances.address}};
    VkAccelerationStructureBuildGeometryInfoKHR info = {
        .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR,
        .type = VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR,
        .flags = VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR |
                 VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_UPDATE_BIT_KHR,
        .mode = can_refit ? VK_BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE_KHR
                          : VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR,
        .geometryCount = 1,
        .pGeometries = &geom};
    uint32_t cap = tlas->capacity;
    if (!tlas->as) {
        VkAccelerationStructureBuildSizesInfoKHR sz = {
            .sType = VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_BUILD_SIZES_INFO_KHR};
        vk->fn.vkGetAccelerationStructureBuildSizesKHR(
            vk->device, VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR, &info, &cap, &sz);
        TND_TRY(create_as(vk, VK_ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL_KHR,
                          sz.accelerationStructureSize, "accel.tlas", &tlas->storage, &tlas->as));
        VkDeviceSize s =
            sz.buildScratchSize > sz.updateScratchSize ? sz.buildScratchSize : sz.updateScratchSize;
        TND_TRY(scratch_buffer(vk, s, "accel.tlas_scratch", &tlas->scratch));
        tlas->address = as_address(vk, tlas->as);
    }
    info.srcAccelerationStructure = can_refit ? tlas->as : VK_NULL_HANDLE;
    info.dstAccelerationStructure = tlas->as;
    info.scratchData.deviceAddress =
        align_up(tlas->scratch.address, vk->info.min_scratch_offset_alignment);
    VkAccelerationStructureBuildRangeInfoKHR range = {.primitiveCount = count};
    const VkAccelerationStructureBuildRangeInfoKHR *pr = &range;
    VkCommandBuffer cmd;
    TND_TRY(tnd_cmd_begin(vk, &cmd));
    tnd_cmd_barrier(cmd);
    vk->fn.vkCmdBuildAccelerationStructuresKHR(cmd, 1, &info, &pr);
    tnd_cmd_barrier(cmd);
    TND_TRY(tnd_cmd_submit_wait(vk, cmd));
    tlas->count = count;
    return TND_OK;
fail:
    fvk_tlas_destroy(vk, tlas);
    return res;
}
