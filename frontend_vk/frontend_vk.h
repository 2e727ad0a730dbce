/* frontend_vk: the Vulkan ray-tracing front-end.
 *
 * This header grows with the front-end; today it holds the acceleration structures: one
 * compacted BLAS per mesh and a TLAS over instances with 3x4 row-major transforms (the layout of
 * VkTransformMatrixKHR and of Embree's RTC_FORMAT_FLOAT3X4_ROW_MAJOR), rebuilt or refitted per
 * frame. Depends on core/ only. */
#ifndef FVK_FRONTEND_VK_H
#define FVK_FRONTEND_VK_H

#include "core/core.h"

typedef struct fvk_mesh_desc {
    const float *positions; /* xyz per vertex, tightly packed */
    uint32_t vertex_count;
    const uint32_t *indices; /* 3 per triangle */
    uint32_t triangle_count;
    const char *name;
} fvk_mesh_desc;

typedef struct fvk_blas {
    VkAccelerationStructureKHR as;
    tnd_buffer storage;
    VkDeviceAddress address;
    uint32_t triangle_count;
    VkDeviceSize compacted_bytes, built_bytes; /* sizes after and before compaction */
} fvk_blas;

/* Build one BLAS per mesh (opaque triangles, fast trace, compacted). `out` holds `count`
 * entries. Indices are validated against vertex_count before anything is uploaded. */
tnd_result fvk_blas_build(tnd_vk *vk, const fvk_mesh_desc *meshes, uint32_t count, fvk_blas *out);
void fvk_blas_destroy(tnd_vk *vk, fvk_blas *blas);

typedef struct fvk_instance {
    float transform[12];   /* object to world, 3x4 row-major */
    uint32_t blas;         /* index into the BLAS array */
    uint32_t custom_index; /* 24 bits: gl_InstanceCustomIndexEXT */
    uint8_t mask;          /* 0 means 0xff */
} fvk_instance;

typedef struct fvk_tlas {
    VkAccelerationStructureKHR as;
    tnd_buffer storage, instances, scratch;
    VkDeviceAddress address;
    uint32_t capacity; /* instances the buffers were sized for */
    uint32_t count;
} fvk_tlas;

/* Build the TLAS, or refit it in place when `refit` is set and the instance count and BLAS
 * assignment are unchanged (only transforms moved). */
tnd_result fvk_tlas_build(tnd_vk *vk, const fvk_blas *blas, uint32_t blas_count,
                          const fvk_instance *inst, uint32_t count, bool refit, fvk_tlas *tlas);
void fvk_tlas_destroy(tnd_vk *vk, fvk_tlas *tlas);

#endif
