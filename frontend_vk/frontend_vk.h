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
    bool alpha_tested; /* not opaque: the any-hit shader (or candidate loop) tests its hits */
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
/* A BLAS of several geometries: meshes[parts[k].mesh], in order (gl_GeometryIndexEXT k), each
 * with its vertices through a 3x4 row-major transform as the BLAS is built (NULL: as they are). */
typedef struct fvk_blas_part {
    uint32_t mesh;
    const float *transform;
} fvk_blas_part;
typedef struct fvk_blas_desc {
    const fvk_blas_part *parts;
    uint32_t part_count;
    const char *name;
} fvk_blas_desc;
/* `count` BLASes, out[b] from desc[b] (compacted, fast trace; the meshes validated first). */
tnd_result fvk_blas_build_parts(tnd_vk *vk, const fvk_mesh_desc *meshes, uint32_t mesh_count,
                                const fvk_blas_desc *desc, uint32_t count, fvk_blas *out);
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

/* ---- the path-tracing front-end ------------------------------------------------------------ */
typedef enum fvk_rt_api {
    FVK_RT_AUTO = 0,  /* ray query where the device has it, else the ray-tracing pipeline */
    FVK_RT_PIPELINE,  /* ray-tracing pipeline with a shader binding table */
    FVK_RT_QUERY,     /* compute shaders with inline ray queries (VK_KHR_ray_query) */
} fvk_rt_api;
tnd_result fvk_rt_api_parse(const char *s, fvk_rt_api *api);

/* The passes' own specialisation (fvk_desc.specialise): the real-time passes built for the
 * real-time sample word and the frame's bounce count. On (the default) for GPUs; off for CPU
 * devices (lavapipe), where every build costs a compile of up to a minute (`materials`) and one
 * build that draws every sample word and bounce count serves all frames, as before it existed. */
typedef enum fvk_specialise {
    FVK_SPECIALISE_AUTO = 0, /* on unless the device is a CPU */
    FVK_SPECIALISE_ON,
    FVK_SPECIALISE_OFF
} fvk_specialise;

typedef struct fvk_desc {
    tnd_precision precision; /* contract storage the passes write */
    fvk_rt_api rt_api;
    bool full_pipeline;      /* compile every light type, textures, normal maps and sky in, whatever
                                the scene holds (default: only what the scene requires) */
    uint32_t reflect_depth;  /* as femb_desc */
    bool references;         /* renders references: their passes (every sample word, any bounce
                                count) are made here and draw its real-time frames too (the
                                motion a reference writes); otherwise they are made when a
                                reference first needs them */
    uint32_t bounces;        /* the indirect bounces the real-time passes are first built for (0:
                                1, the default): the shading pass is specialised for the count a
                                frame asks, and built again when a frame asks another */
    bool half_indirect;      /* the real-time passes are first built for --bounces half */
    fvk_specialise specialise; /* the passes' own specialisation (above) */
    tnd_light_sampling lights; /* as femb_desc */
    float footprint_scale;     /* as femb_desc */
} fvk_desc;

typedef struct fvk_params {
    uint32_t bounces; /* as femb_params */
    uint32_t sample;  /* as femb_params: 0 (TND_SAMPLE_REALTIME), or a matched reference's */
    bool set_jitter;  /* as femb_params */
    float jitter[2];
    bool half_indirect; /* as femb_params */
} fvk_params;

/* GPU times of a fvk_render and the gradient launch after it, per pass; tlas_ms: the wall clock of
 * this frame's TLAS build or refit (submitted and waited for in fvk_set_frame; 0 when nothing
 * moved). */
typedef struct fvk_timings { /* (in pl_timings' order) */
    double primary_ms, shade_ms, tlas_ms, gradient_ms;
} fvk_timings;

typedef struct fvk_context fvk_context;

/* Upload a scene (vertex data, materials, textures with mips), build its acceleration
 * structures and the ray-tracing pipeline with its shader binding table. */
tnd_result fvk_create(tnd_vk *vk, const tnd_scene *scene, const fvk_desc *desc,
                      fvk_context **ctx);
void fvk_destroy(fvk_context *ctx);
/* The shader variant in use: TND_USES_* bits (shaders/scene_gpu.h), and its description
 * ("area lights, textures" or "everything (--pipeline full)"). */
uint32_t fvk_uses(const fvk_context *ctx);
const char *fvk_variant(const fvk_context *ctx);

/* The frame: scene states (current, previous), frame index, size. Refits the TLAS when instances
 * move, uploads the light list and the frame parameters. (Re)creates the contract images when
 * the size changes. */
tnd_result fvk_set_frame(fvk_context *ctx, const tnd_scene_state *cur, const tnd_scene_state *prev,
                         uint32_t frame_index, uint32_t width, uint32_t height);
/* Primary pass then shading pass into the contract images, submitted to the queue; with `t`, waits
 * for them and gives their times, else returns at once (whatever the queue runs next, downloads
 * and the back-end's passes included, sees the contract written: the passes end with a full
 * barrier). The gradient launches below do the same. */
tnd_result fvk_render(fvk_context *ctx, const fvk_params *p, fvk_timings *t);
/* fvk_render in two submissions, for a denoiser whose gradient selection reads this frame's
 * G-buffer between them: the primary pass, then the shading pass. With the back-end's
 * per-stratum list (dn_select_gradients_gpu's buffer, rows of `row`), the shading pass also
 * re-shades the listed samples into the list, as fvk_shade_gradient_slots would after it,
 * without a launch of their own: the contract and the list afterwards are the same
 * (shaders/pt_shade.glsl, mode 2). Without a list (VK_NULL_HANDLE) it is fvk_render's. A render
 * or set_frame between the two is refused. */
tnd_result fvk_render_primary(fvk_context *ctx, const fvk_params *p);
tnd_result fvk_render_shade(fvk_context *ctx, const fvk_params *p, VkBuffer slots_buffer,
                            uint32_t row, fvk_timings *t);
/* The times of the last render and gradient launch read: with `wait`, of the last submitted
 * (waits for them); without, of those that had finished when this frame's render was submitted
 * (the frame before), without waiting. */
tnd_result fvk_last_timings(fvk_context *ctx, bool wait, fvk_timings *t);
/* Shade gradient samples (layout of femb_gradient_sample: pixel, rng frame, rng pixel,
 * instance, primitive, u, v) after fvk_render into the contract, patching the G-buffer at their
 * pixels (the re-shaded contract, for captures and tests; the back-end takes the values through
 * dn_set_gradient_values and the frame as rendered). */
tnd_result fvk_shade_gradients(fvk_context *ctx, const fvk_params *p, const uint32_t *samples,
                               uint32_t count, fvk_timings *t);
/* The same samples, reading the back-end's per-stratum list where it lies on the GPU
 * (dn_select_gradients_gpu: `slots` tnd_gpu_gradient entries in rows of `row`, the strata's
 * grid; TND_GRADIENT_NONE skipped): no read-back and no upload; the re-shaded values go into
 * the list's entries (tnd_gpu_gradient c, d), the contract keeps the frame as rendered. The
 * entries come from the back-end's own pass over the contract, so they are trusted (no range
 * check). */
tnd_result fvk_shade_gradient_slots(fvk_context *ctx, const fvk_params *p, VkBuffer slots_buffer,
                                    uint32_t slots, uint32_t row, fvk_timings *t);
/* Reference: unbiased progressive path tracing on the GPU, as femb_reference (same paths for
 * the same keys): spp samples per pixel, radiance in rgb (3 floats per pixel), the standard error
 * of each pixel's luminance mean in lum_se (optional), the samples taken and the mean relative
 * standard error in stats (optional; its until_noise stops early), progress after each batch of
 * samples. */
/* As femb_set_reference_bounces: 0 full paths (the default), n > 0 a matched reference. */
void fvk_set_reference_bounces(fvk_context *ctx, uint32_t bounces);
tnd_result fvk_reference(fvk_context *ctx, uint32_t spp, float *rgb, float *lum_se,
                         tnd_ref_stats *stats,
                         void (*progress)(uint32_t done, uint32_t total, void *user), void *user);
/* As femb_reference_add: samples [first, first + count) added to per-pixel double sums (RGB,
 * luminance^2). The GPU sums each batch (the samples between multiples of TND_REF_CHECK_EVERY)
 * in float, from zero, and the host adds the batches in double: a range split at multiples of
 * TND_REF_CHECK_EVERY sums every batch as the whole range does. */
tnd_result fvk_reference_add(fvk_context *ctx, uint32_t first, uint32_t count, double *sum_rgb,
                             double *sum_lum2, tnd_ref_stats *stats,
                             void (*progress)(uint32_t done, uint32_t total, void *user),
                             void *user);
/* A matched reference's samples [first, first + count) on the device: sample s runs the
 * real-time estimator (primary and shading passes, `bounces` indirect bounces) with the sample
 * word tnd_reference_sample(s) and the whole image's pixel offset tnd_rand(0, frame, word,
 * TND_DIM_JITTER_*) - 1/2, then pt_matched.comp composites and interleaves it as the host's
 * tnd_frame_composite and tnd_frame_interleave do and adds it to the batch's float sums; the
 * host adds each batch (as fvk_reference_add) into sum_rgb and sum_lum2 in double. Nothing of a
 * sample leaves the device. */
tnd_result fvk_matched_add(fvk_context *ctx, uint32_t bounces, uint32_t first, uint32_t count,
                           double *sum_rgb, double *sum_lum2, tnd_ref_stats *stats,
                           void (*progress)(uint32_t done, uint32_t total, void *user),
                           void *user);
/* The API the passes use (after AUTO was resolved). */
fvk_rt_api fvk_api(const fvk_context *ctx);
/* The BLASes that hold runs of static instances (fvk_scene.c merge_static), and the instances
 * in them; 0 before the first frame, where nothing was merged, or once one of them moved. */
uint32_t fvk_static_runs(const fvk_context *ctx, uint32_t *instances);
/* The contract images of the last render. */
const tnd_contract_gpu *fvk_contract(const fvk_context *ctx);

#endif
