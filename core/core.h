/* core: what every part of Tandem shares, in sections:
 *
 * - results and error messages (one catalogue of codes; a per-thread detail message), logging,
 *   files;
 * - Vulkan: devices, the context (headless instance, device choice), memory, buffers and images,
 *   commands and synchronisation, pipelines from SPIR-V and shader binding tables, timestamp
 *   queries (per-pass GPU times), debug names;
 * - the buffer contract on the C side and on the GPU (the table itself is shaders/contract.h),
 *   OpenEXR files and captures (one EXR per frame holding the whole contract);
 * - math (matrices, quaternions), scenes (glTF 2.0 and what assimp reads, flat and GPU-friendly;
 *   building scenes in code), the light list for next-event estimation.
 *
 * Conventions: fallible functions return tnd_result (TND_OK is 0). Every *_destroy accepts a
 * zeroed or half-built object and may be called twice. Descriptor structs: zero means default. */
#ifndef TND_CORE_H
#define TND_CORE_H

#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <vulkan/vulkan.h>

#define TND_VERSION_STRING "0.1.0"
#define TND_PI             3.14159265358979323846

/* ---------------------------------------------------------------------------------------------
 * Results and errors
 * ------------------------------------------------------------------------------------------- */

// clang-format off
#define TND_RESULT_LIST(X) \
    X(TND_OK,                   "success") \
    X(TND_ERR_INVALID_ARGUMENT, "invalid argument") \
    X(TND_ERR_OUT_OF_MEMORY,    "out of host memory") \
    X(TND_ERR_IO,               "file input/output error") \
    X(TND_ERR_BAD_INPUT,        "malformed input") \
    X(TND_ERR_UNSUPPORTED,      "unsupported feature") \
    X(TND_ERR_NO_DEVICE,        "no suitable Vulkan device") \
    X(TND_ERR_VULKAN,           "Vulkan call failed") \
    X(TND_ERR_LIMIT,            "beyond a device or format limit") \
    X(TND_ERR_INTERRUPTED,      "interrupted")
// clang-format on

typedef enum tnd_result {
#define TND_X(code, msg) code,
    TND_RESULT_LIST(TND_X)
#undef TND_X
        TND_RESULT_COUNT
} tnd_result;

/* Name ("TND_ERR_IO") and generic message ("file input/output error") of a code. */
const char *tnd_result_name(tnd_result r);
const char *tnd_result_message(tnd_result r);

/* Record a detailed message for the calling thread and return `code`, so that a failure reads
 * `return tnd_fail(TND_ERR_BAD_INPUT, "scene: %s: mesh %u: ...", ...)`. The message should name
 * the module, the file or object, and what was expected. */
tnd_result tnd_fail(tnd_result code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* The calling thread's last detail message ("" when none since tnd_error_clear). */
const char *tnd_error_detail(void);
void tnd_error_clear(void);

/* VkResult as its enum name ("VK_ERROR_DEVICE_LOST"). */
const char *tnd_vk_result_name(VkResult r);
/* Records `file:line: call -> VK_ERROR_...` and returns TND_ERR_VULKAN. */
tnd_result tnd_fail_vk(const char *file, int line, const char *call, VkResult r);
/* Has a Vulkan call in this process returned VK_ERROR_DEVICE_LOST (through tnd_fail_vk)? A run
 * that stops on it failed through no fault of its own: what it can resume from is kept. */
bool tnd_vk_device_lost(void);

/* Check a Vulkan call in every build; on failure record the message, set `res` and jump to the
 * function's `fail:` cleanup label. The enclosing function declares `tnd_result res`. */
#define TND_VK_TRY(call)                                                                           \
    do {                                                                                           \
        VkResult tnd_vr_ = (call);                                                                 \
        if (tnd_vr_ < 0) {                                                                         \
            res = tnd_fail_vk(__FILE__, __LINE__, #call, tnd_vr_);                                 \
            goto fail;                                                                             \
        }                                                                                          \
    } while (0)
/* Same for calls returning tnd_result. */
#define TND_TRY(expr)                                                                              \
    do {                                                                                           \
        res = (expr);                                                                              \
        if (res != TND_OK)                                                                         \
            goto fail;                                                                             \
    } while (0)
/* Return a failure at once (where there is nothing to clean up). */
#define TND_TRY_RETURN(expr)                                                                       \
    do {                                                                                           \
        tnd_result r_ = (expr);                                                                    \
        if (r_ != TND_OK)                                                                          \
            return r_;                                                                             \
    } while (0)

/* ---------------------------------------------------------------------------------------------
 * Logging (stderr). The level is process-wide and set once by the application.
 * ------------------------------------------------------------------------------------------- */
typedef enum tnd_log_level {
    TND_LOG_INFO = 0, /* default */
    TND_LOG_DEBUG,
    TND_LOG_WARN,
    TND_LOG_ERROR,
    TND_LOG_QUIET,
} tnd_log_level;

void tnd_log_set_level(tnd_log_level level);
tnd_log_level tnd_log_get_level(void);
void tnd_log(tnd_log_level level, const char *module, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
#define tnd_info(mod, ...)  tnd_log(TND_LOG_INFO, mod, __VA_ARGS__)
#define tnd_warn(mod, ...)  tnd_log(TND_LOG_WARN, mod, __VA_ARGS__)
#define tnd_debug(mod, ...) tnd_log(TND_LOG_DEBUG, mod, __VA_ARGS__)

/* Monotonic wall clock in seconds. */
double tnd_now(void);

/* ---------------------------------------------------------------------------------------------
 * Files
 * ------------------------------------------------------------------------------------------- */

/* Read a whole file into a malloc'ed buffer (NUL-terminated, the terminator not counted in
 * *size). The caller frees it. Errors name the path. */
tnd_result tnd_file_read(const char *path, void **data, size_t *size);
/* Write a file atomically: to `path.tmp.<pid>`, then rename. No partial file on failure. */
tnd_result tnd_file_write_atomic(const char *path, const void *data, size_t size);
/* mkdir -p. */
tnd_result tnd_mkdirs(const char *path);

/* ---------------------------------------------------------------------------------------------
 * Vulkan: devices
 * ------------------------------------------------------------------------------------------- */

#define TND_DEVICE_NAME_MAX 256
typedef struct tnd_vk_device_info {
    uint32_t index; /* in vkEnumeratePhysicalDevices order */
    char name[TND_DEVICE_NAME_MAX];
    char driver_name[TND_DEVICE_NAME_MAX];
    char driver_info[TND_DEVICE_NAME_MAX];
    VkPhysicalDeviceType type;
    uint32_t api_version;
    uint32_t vendor_id, device_id;
    char uuid[48]; /* deviceUUID as "GPU-xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx" (nvidia-smi -L's
                      form: on NVIDIA the same as CUDA's), "" before Vulkan 1.2 */
    bool rt_pipeline;    /* VK_KHR_ray_tracing_pipeline + its feature */
    bool accel_struct;   /* VK_KHR_acceleration_structure + its feature */
    bool ray_query;      /* VK_KHR_ray_query + its feature */
    bool pipeline_executable_info; /* VK_KHR_pipeline_executable_properties */
    bool swapchain;      /* VK_KHR_swapchain (a window can present) */
    bool memory_budget;  /* VK_EXT_memory_budget (tnd_vk_memory_in_use) */
    bool buffer_address; /* bufferDeviceAddress */
    bool timestamps;     /* compute queue has timestampValidBits > 0 */
    bool compute_ok;     /* Vulkan >= 1.2, buffer device address, a compute queue */
    bool suitable;       /* compute_ok and ray-tracing pipelines + acceleration structures */
    char why_not[128];   /* why not suitable, "" when suitable */
    /* ray-tracing limits (0 when absent) */
    uint32_t shader_group_handle_size;
    uint32_t shader_group_handle_alignment;
    uint32_t shader_group_base_alignment;
    uint32_t max_ray_recursion_depth;
    uint32_t min_scratch_offset_alignment;
    uint64_t max_primitive_count;
    uint64_t max_instance_count;
    uint64_t max_geometry_count; /* geometries in one BLAS */
    /* general limits */
    uint32_t max_image_dimension_2d;
    uint32_t max_compute_workgroup_invocations;
    float timestamp_period_ns;
    uint64_t device_local_bytes;
} tnd_vk_device_info;

/* List the physical devices (creates and destroys a temporary instance). `out` holds `cap`
 * entries; *count receives the number of devices (which may exceed cap). */
tnd_result tnd_vk_list_devices(tnd_vk_device_info *out, uint32_t cap, uint32_t *count);

/* Choose a device: a case-insensitive substring of the name when `want` is non-empty (an error
 * naming the devices when none matches or the match is unsuitable); otherwise the first suitable
 * discrete GPU, then integrated, virtual, and finally CPU (lavapipe). `need_rt`: require ray
 * tracing (else compute_ok suffices). Pure function. */
tnd_result tnd_vk_choose_device(const tnd_vk_device_info *devs, uint32_t count, const char *want,
                                bool need_rt, uint32_t *chosen);

/* ---------------------------------------------------------------------------------------------
 * Vulkan: context
 * ------------------------------------------------------------------------------------------- */

/* Ray-tracing device functions, loaded with vkGetDeviceProcAddr. */
// clang-format off
#define TND_VK_DEVICE_FNS(X) \
    X(vkCreateAccelerationStructureKHR) \
    X(vkDestroyAccelerationStructureKHR) \
    X(vkGetAccelerationStructureBuildSizesKHR) \
    X(vkGetAccelerationStructureDeviceAddressKHR) \
    X(vkCmdBuildAccelerationStructuresKHR) \
    X(vkCmdWriteAccelerationStructuresPropertiesKHR) \
    X(vkCmdCopyAccelerationStructureKHR) \
    X(vkCreateRayTracingPipelinesKHR) \
    X(vkGetRayTracingShaderGroupHandlesKHR) \
    X(vkCmdTraceRaysKHR)
// clang-format on

typedef struct tnd_vk_fns {
#define TND_X(fn) PFN_##fn fn;
    TND_VK_DEVICE_FNS(TND_X)
#undef TND_X
    PFN_vkSetDebugUtilsObjectNameEXT vkSetDebugUtilsObjectNameEXT; /* may be NULL */
} tnd_vk_fns;

typedef struct tnd_vk_desc {
    const char *device;  /* an index (as tnd_vk_list_devices orders them) or a substring of the
                            device's name; NULL: $TANDEM_DEVICE, then the default */
    bool validation;     /* enable VK_LAYER_KHRONOS_validation (also $TANDEM_VALIDATION=1) */
    bool no_ray_tracing; /* accept devices without ray tracing (compute-only back-end) */
    /* a window: the instance extensions its surfaces need, and VK_KHR_swapchain on the device */
    const char *const *instance_extensions;
    uint32_t instance_extension_count; /* at most TND_VK_MAX_INSTANCE_EXTENSIONS */
    bool swapchain;
} tnd_vk_desc;
#define TND_VK_MAX_INSTANCE_EXTENSIONS 8

typedef struct tnd_vk_messages tnd_vk_messages; /* validation message counters (internal) */

typedef struct tnd_vk {
    VkInstance instance;
    VkDebugUtilsMessengerEXT messenger;
    VkPhysicalDevice phys;
    VkDevice device;
    VkQueue queue; /* one queue: graphics/compute, used for everything */
    uint32_t queue_family;
    VkCommandPool cmd_pool;
    VkFence fence;
    tnd_vk_device_info info;
    VkPhysicalDeviceMemoryProperties mem;
    tnd_vk_fns fn;
    bool validation;
    bool ray_tracing; /* RT pipeline + acceleration structures enabled */
    bool ray_query;   /* ray query enabled */
    /* $TANDEM_PIPELINE_STATS=1 and VK_KHR_pipeline_executable_properties: every compute and RT
     * pipeline's compiler statistics (registers, code size, ...) go to stderr when created */
    bool pipeline_stats;
    bool memory_budget; /* VK_EXT_memory_budget enabled */
    tnd_vk_messages *messages;
} tnd_vk;

tnd_result tnd_vk_create(const tnd_vk_desc *desc, tnd_vk *vk);
void tnd_vk_destroy(tnd_vk *vk);
/* Validation-layer messages seen so far (errors and warnings). The layer's text goes to stderr. */
uint32_t tnd_vk_validation_errors(const tnd_vk *vk);
uint32_t tnd_vk_validation_warnings(const tnd_vk *vk);

/* Give any Vulkan object a debug name (no-op without VK_EXT_debug_utils). */
void tnd_vk_name(const tnd_vk *vk, VkObjectType type, uint64_t handle, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
#define TND_VK_NAME(vk, type, obj, ...)                                                            \
    tnd_vk_name(vk, type, (uint64_t)(uintptr_t)(obj), __VA_ARGS__)

/* ---------------------------------------------------------------------------------------------
 * Vulkan: memory, buffers, images
 * ------------------------------------------------------------------------------------------- */
typedef enum tnd_mem_kind {
    TND_MEM_DEVICE = 0, /* device-local */
    TND_MEM_UPLOAD,     /* host-visible, coherent, mapped: CPU writes, GPU reads */
    TND_MEM_READBACK,   /* host-visible, cached if possible, mapped: GPU writes, CPU reads */
} tnd_mem_kind;

typedef struct tnd_buffer_desc {
    VkDeviceSize size;
    VkBufferUsageFlags usage; /* TRANSFER_SRC/DST are always added */
    tnd_mem_kind mem;
    bool device_address; /* allocate with VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT */
    const char *name;
} tnd_buffer_desc;

typedef struct tnd_buffer {
    VkBuffer buffer;
    VkDeviceMemory memory;
    VkDeviceSize size;
    VkDeviceAddress address; /* 0 unless desc.device_address */
    void *mapped;            /* non-NULL for UPLOAD / READBACK */
} tnd_buffer;

tnd_result tnd_buffer_create(tnd_vk *vk, const tnd_buffer_desc *desc, tnd_buffer *buf);
void tnd_buffer_destroy(tnd_vk *vk, tnd_buffer *buf);
/* Copy host data into a buffer (through a staging buffer for device memory); blocks. */
tnd_result tnd_buffer_upload(tnd_vk *vk, tnd_buffer *dst, VkDeviceSize offset, const void *data,
                             VkDeviceSize size);
/* Copy a buffer's bytes to host memory; blocks. */
tnd_result tnd_buffer_download(tnd_vk *vk, const tnd_buffer *src, VkDeviceSize offset, void *data,
                               VkDeviceSize size);

typedef struct tnd_image_desc {
    uint32_t width, height;
    VkFormat format;
    VkImageUsageFlags usage; /* STORAGE | SAMPLED | TRANSFER_SRC | TRANSFER_DST when 0 */
    const char *name;
} tnd_image_desc;

typedef struct tnd_image {
    VkImage image;
    VkDeviceMemory memory;
    VkImageView view;
    VkFormat format;
    uint32_t width, height;
} tnd_image;

/* A 2D device-local image with one mip, left in VK_IMAGE_LAYOUT_GENERAL. Fails with
 * TND_ERR_LIMIT when the size is 0 or beyond the device's maxImageDimension2D. */
tnd_result tnd_image_create(tnd_vk *vk, const tnd_image_desc *desc, tnd_image *img);
void tnd_image_destroy(tnd_vk *vk, tnd_image *img);
/* Copy a whole image (layout GENERAL) to host memory, texels tightly packed row by row;
 * `bytes` must be width x height x the format's texel size. Blocks. */
tnd_result tnd_image_download(tnd_vk *vk, const tnd_image *img, void *data, size_t bytes);
/* The whole image from `data` (tightly packed texels, `bytes` of them); blocks. */
tnd_result tnd_image_upload(tnd_vk *vk, const tnd_image *img, const void *data, size_t bytes);

/* Pick a memory type with `bits` allowed and all of `props`; UINT32_MAX when none. */
uint32_t tnd_vk_memory_type(const tnd_vk *vk, uint32_t bits, VkMemoryPropertyFlags props);
/* Device memory in use by this process, all heaps together (VK_EXT_memory_budget's heap usage:
 * what the driver counts, its own allocations included); false where the device lacks the
 * extension. */
bool tnd_vk_memory_in_use(const tnd_vk *vk, uint64_t *bytes);
/* Every device allocation goes through these (vkAllocateMemory, vkFreeMemory), which count the
 * allocations alive in the process: tnd_vk_live_allocations. */
VkResult tnd_vk_allocate(const tnd_vk *vk, const VkMemoryAllocateInfo *ai, VkDeviceMemory *out);
void tnd_vk_free(const tnd_vk *vk, VkDeviceMemory m);
/* Every wait for the device's work goes through here (one fence, no timeout: a lost device
 * returns VK_ERROR_DEVICE_LOST rather than hang). $TANDEM_FAULT makes this and tnd_vk_allocate
 * fail as a driver would (docs/reliability.md, "Faults"). */
VkResult tnd_vk_wait(const tnd_vk *vk, VkFence fence);
/* With $TANDEM_FAULT set: the waits and allocations counted so far, to stderr (tnd_vk_destroy). */
void tnd_vk_fault_report(void);
uint64_t tnd_vk_live_allocations(void);

/* ---------------------------------------------------------------------------------------------
 * Vulkan: commands and synchronisation
 * ------------------------------------------------------------------------------------------- */

/* One-shot command buffer: begin, record, then submit-and-wait (which frees it). */
tnd_result tnd_cmd_begin(tnd_vk *vk, VkCommandBuffer *cmd);
tnd_result tnd_cmd_submit_wait(tnd_vk *vk, VkCommandBuffer cmd);

/* A submission the host does not wait for: the commands run while the host goes on (the next
 * frame's CPU work, another pass's recording). Every Tandem command buffer starts with a full
 * barrier, so a later submission on the one queue runs after it on the device; the host must
 * wait (tnd_pending_wait) before it writes what the commands read from host memory (uniform
 * buffers, descriptor sets) or reads what they wrote (timestamps, read-back buffers). A blocking
 * tnd_cmd_submit_wait also finishes every earlier submission (a fence covers all of them). */
typedef struct tnd_pending {
    VkFence fence;
    VkCommandBuffer cmd; /* VK_NULL_HANDLE when nothing is in flight */
} tnd_pending;
tnd_result tnd_pending_create(tnd_vk *vk, tnd_pending *p);
/* Waits for what is in flight first. */
void tnd_pending_destroy(tnd_vk *vk, tnd_pending *p);
/* End and submit `cmd` (freed once waited for); `p` must have nothing in flight. */
tnd_result tnd_cmd_submit_pending(tnd_vk *vk, VkCommandBuffer cmd, tnd_pending *p);
/* Wait for what `p` has in flight (nothing: returns at once). */
tnd_result tnd_pending_wait(tnd_vk *vk, tnd_pending *p);

/* Full memory barrier between passes (compute, ray tracing, transfer, AS build). Coarse on
 * purpose: passes are separated by one call, which is cheap next to a pass. */
void tnd_cmd_barrier(VkCommandBuffer cmd);
/* Compute-to-compute barrier (shader writes before shader reads and writes): between the
 * back-to-back dispatches of one chain, where a full barrier's extra cache work shows (the
 * back-end records about 20 dispatches of a few microseconds each). */
void tnd_cmd_compute_barrier(VkCommandBuffer cmd);

/* ---------------------------------------------------------------------------------------------
 * Vulkan: pipelines
 * ------------------------------------------------------------------------------------------- */
tnd_result tnd_shader_module_create(tnd_vk *vk, const uint32_t *code, size_t bytes,
                                    const char *name, VkShaderModule *mod);

typedef struct tnd_compute_desc {
    const uint32_t *code; /* SPIR-V */
    size_t bytes;
    VkPipelineLayout layout;
    const VkSpecializationInfo *spec; /* optional */
    const char *name;
} tnd_compute_desc;
tnd_result tnd_compute_pipeline_create(tnd_vk *vk, const tnd_compute_desc *desc, VkPipeline *pipe);

typedef struct tnd_rt_stage {
    const uint32_t *code;
    size_t bytes;
    VkShaderStageFlagBits stage;
} tnd_rt_stage;

/* Ray-tracing pipeline with the groups in SBT order: raygen groups, then miss groups, then hit
 * groups. Each raygen/miss group is one stage; a hit group is a closest-hit stage (and optionally
 * an any-hit stage; -1 for none). */
#define TND_RT_MAX_GROUPS 32
typedef struct tnd_rt_hit_group {
    int closest_hit; /* index into stages, -1 none */
    int any_hit;     /* index into stages, -1 none */
} tnd_rt_hit_group;

typedef struct tnd_rt_desc {
    const tnd_rt_stage *stages;
    uint32_t stage_count;
    const uint32_t *raygen; /* stage indices */
    uint32_t raygen_count;
    const uint32_t *miss; /* stage indices */
    uint32_t miss_count;
    const tnd_rt_hit_group *hit;
    uint32_t hit_count;
    uint32_t max_recursion; /* 1 when 0 */
    VkPipelineLayout layout;
    const VkSpecializationInfo *spec; /* applied to every stage; optional */
    const char *name;
} tnd_rt_desc;

/* The shader binding table of one RT pipeline: one buffer, regions laid out from the device's
 * handle size, handle alignment and base alignment (never hard-coded). */
typedef struct tnd_sbt {
    tnd_buffer buffer;
    VkStridedDeviceAddressRegionKHR raygen[TND_RT_MAX_GROUPS]; /* one region per raygen group */
    VkStridedDeviceAddressRegionKHR miss;
    VkStridedDeviceAddressRegionKHR hit;
    VkStridedDeviceAddressRegionKHR callable;
    uint32_t raygen_count;
} tnd_sbt;

/* SBT layout arithmetic, separate so that it can be tested against any device's numbers. */
typedef struct tnd_sbt_layout {
    uint32_t handle_stride; /* handle size rounded up to the handle alignment */
    VkDeviceSize raygen_offset[TND_RT_MAX_GROUPS], raygen_size;
    VkDeviceSize miss_offset, miss_size;
    VkDeviceSize hit_offset, hit_size;
    VkDeviceSize total;
} tnd_sbt_layout;
tnd_result tnd_sbt_compute_layout(uint32_t handle_size, uint32_t handle_alignment,
                                  uint32_t base_alignment, uint32_t raygen_count,
                                  uint32_t miss_count, uint32_t hit_count, tnd_sbt_layout *out);

tnd_result tnd_rt_pipeline_create(tnd_vk *vk, const tnd_rt_desc *desc, VkPipeline *pipe,
                                  tnd_sbt *sbt);
void tnd_sbt_destroy(tnd_vk *vk, tnd_sbt *sbt);

/* ---------------------------------------------------------------------------------------------
 * Vulkan: timestamps (per-pass GPU times)
 * ------------------------------------------------------------------------------------------- */
#define TND_TIMER_MAX_PASSES 64
typedef struct tnd_timer {
    VkQueryPool pool;
    uint32_t count; /* passes recorded since the last reset */
    const char *names[TND_TIMER_MAX_PASSES];
    float period_ns;
    uint64_t valid_mask; /* from timestampValidBits */
} tnd_timer;

tnd_result tnd_timer_create(tnd_vk *vk, tnd_timer *t);
void tnd_timer_destroy(tnd_vk *vk, tnd_timer *t);
/* Record a reset of all queries; call before the first pass of a frame. */
void tnd_timer_reset(VkCommandBuffer cmd, tnd_timer *t);
/* Bracket a pass; returns its slot (or -1 when full; then nothing is written). `name` must
 * outlive the read. */
int tnd_timer_begin(VkCommandBuffer cmd, tnd_timer *t, const char *name);
void tnd_timer_end(VkCommandBuffer cmd, tnd_timer *t, int slot);
/* After the command buffer completed: ms[i] for each recorded pass i < t->count. */
tnd_result tnd_timer_read(tnd_vk *vk, const tnd_timer *t, double *ms);

/* ---------------------------------------------------------------------------------------------
 * The buffer contract, C side (the table itself is shaders/contract.h)
 * ------------------------------------------------------------------------------------------- */
#include "shaders/contract.h"

typedef enum tnd_precision {
    TND_PRECISION_F32 = 0, /* every entry float32 (uint32 for indices) */
    TND_PRECISION_PACKED,  /* RGBE for HF/SPEC, half floats elsewhere (see the table) */
} tnd_precision;

typedef enum tnd_ct_kind { TND_CT_FLOAT = 0, TND_CT_UINT } tnd_ct_kind;
typedef enum tnd_ct_pack { TND_PACK_F32 = 0, TND_PACK_HALF, TND_PACK_RGBE } tnd_ct_pack;
typedef enum tnd_ct_need { TND_NEED_REQUIRED = 0, TND_NEED_DEFAULT, TND_NEED_DERIVED } tnd_ct_need;

typedef struct tnd_ct_info {
    tnd_ct id;
    const char *name; /* "albedo" */
    uint32_t comps;
    tnd_ct_kind kind;
    tnd_ct_pack pack;
    VkFormat vk_f32, vk_packed;
    const char *glsl_f32, *glsl_packed;
    const char *exr_layer;       /* "albedo" */
    const char *exr_channels[4]; /* "R", "G", "B" */
    tnd_ct_need need;
    double default_value;
    const char *semantic, *unit, *space;
} tnd_ct_info;

const tnd_ct_info *tnd_ct_get(tnd_ct id);
/* Entry by name ("albedo"), NULL when unknown. */
const tnd_ct_info *tnd_ct_find(const char *name);
/* "albedo.R": full EXR channel name of component c. */
void tnd_ct_exr_name(tnd_ct id, uint32_t c, char *out, size_t cap);
/* The table as a Markdown table (what docs/contract.md embeds). Returns the length; writes at
 * most cap bytes (NUL-terminated) when buf is not NULL. */
size_t tnd_ct_markdown(char *buf, size_t cap);
const char *tnd_precision_name(tnd_precision p);
tnd_result tnd_precision_parse(const char *s, tnd_precision *p);

/* Camera state of one frame: what a capture needs to reproduce the frame. Matrices are column-
 * major (m[col * 4 + row]), right-handed, the camera looking down -Z (glTF); proj maps to
 * Vulkan clip space (y down, depth [0,1]). Jitter is the sub-pixel offset of the primary rays in
 * pixels, in [-0.5, 0.5]. */
typedef struct tnd_camera_state {
    float view[16], proj[16];
    float prev_view[16], prev_proj[16];
    float jitter[2];
    uint32_t frame_index;
} tnd_camera_state;

/* One frame of the contract in host memory: every entry W x H x comps, float or uint32,
 * row-major from the top-left pixel. Entries a source did not provide hold their default (or
 * derived) values and present[id] is false. */
typedef struct tnd_frame {
    uint32_t width, height;
    tnd_precision precision; /* values already quantised to this precision */
    tnd_camera_state camera;
    bool has_camera;
    bool present[TND_CT_COUNT];
    void *data[TND_CT_COUNT]; /* planes inside `block` */
    void *block;
    uint32_t nonfinite[TND_CT_COUNT]; /* values a mapped capture's reader replaced (NaN, Inf) */
    /* rendered with A-SVGF: the frame's gradient samples are stored beside it
     * (tnd_capture_gradients_path; none on a frame without history) */
    bool gradients;
    /* entries a mapping marks optional that this frame's files lack: their defaults stand, as
     * the mapping states (tnd_capture_map_fallback) */
    bool fallback[TND_CT_COUNT];
} tnd_frame;

/* Allocate every entry, filled with defaults (position/geo_normal zero until derived). */
tnd_result tnd_frame_create(uint32_t width, uint32_t height, tnd_frame *f);
void tnd_frame_destroy(tnd_frame *f);
/* dst becomes a copy of src: every plane and flag (dst: a frame, or zeroed; reallocated when its
 * size differs). */
tnd_result tnd_frame_copy(const tnd_frame *src, tnd_frame *dst);
static inline float *tnd_frame_f(const tnd_frame *f, tnd_ct id)
{
    return (float *)f->data[id];
}
static inline uint32_t *tnd_frame_u(const tnd_frame *f, tnd_ct id)
{
    return (uint32_t *)f->data[id];
}
/* Quantise every float entry in place as the given precision stores it (the exact C mirror of the
 * GPU's packed formats), after mapping NaN/Inf to defined values. */
void tnd_frame_quantize(tnd_frame *f, tnd_precision p);
/* Composite of the demodulated signals into linear RGB (3 floats per pixel), the back-end's
 * "off" mode on the CPU: ((hf + E_n(lf)) x albedo x (1 - metallic) + spec x max(0.01, F0))
 * x throughput + emission, with E_n the SH evaluated at the shading normal (docs/contract.md). */
void tnd_frame_composite(const tnd_frame *f, float *rgb);
/* The checkerboard interleave on the CPU (composite/'s post_interleave.comp): where the path
 * flags say the pixels split at a surface that reflects and refracts, each becomes 0.5 x its own
 * + 0.5 x the mean of its cross neighbours of the other field. */
void tnd_frame_interleave(const tnd_frame *f, float *rgb);
/* Fill DERIVED entries that are not present: geo_normal = normal; position from depth and the
 * camera when the frame has one (else position stays absent). */
tnd_result tnd_frame_derive(tnd_frame *f, const char *source);

/* ---------------------------------------------------------------------------------------------
 * OpenEXR (OpenEXRCore C API): generic multi-channel scanline files
 * ------------------------------------------------------------------------------------------- */
typedef enum tnd_exr_type { TND_EXR_HALF = 0, TND_EXR_FLOAT, TND_EXR_UINT } tnd_exr_type;
typedef enum tnd_exr_compression {
    TND_EXR_ZIP = 0,
    TND_EXR_PIZ,
    TND_EXR_NONE,
    TND_EXR_RLE,
    TND_EXR_ZIPS,
} tnd_exr_compression;

typedef struct tnd_exr_channel_desc {
    const char *name;
    tnd_exr_type type; /* type in the file; memory is float for HALF/FLOAT, uint32 for UINT */
    const void *data;  /* first element of pixel (0,0) */
    uint32_t stride;   /* elements between neighbouring pixels (1 for planar data) */
} tnd_exr_channel_desc;

typedef enum tnd_exr_attr_type {
    TND_ATTR_INT = 0,
    TND_ATTR_FLOAT,
    TND_ATTR_V2F,
    TND_ATTR_M44F,
    TND_ATTR_STRING,
} tnd_exr_attr_type;

typedef struct tnd_exr_attr {
    const char *name;
    tnd_exr_attr_type type;
    int32_t i;
    float f[16]; /* FLOAT: f[0]; V2F: f[0..1]; M44F: row-major as OpenEXR stores it */
    const char *s;
} tnd_exr_attr;

/* Write a scanline EXR atomically (temporary file, then rename; nothing left on failure). */
tnd_result tnd_exr_write(const char *path, uint32_t width, uint32_t height,
                         const tnd_exr_channel_desc *channels, uint32_t channel_count,
                         const tnd_exr_attr *attrs, uint32_t attr_count,
                         tnd_exr_compression compression);

typedef struct tnd_exr_channel {
    char name[256];
    tnd_exr_type type;
    int32_t x_sampling, y_sampling;
    void *data; /* width*height floats (HALF/FLOAT) or uint32 (UINT); NULL if subsampled */
} tnd_exr_channel;

typedef struct tnd_exr_file {
    char path[1024];
    uint32_t width, height;
    uint32_t channel_count;
    tnd_exr_channel *channels;
    void *ctx; /* exr_context_t, kept open for attribute queries */
} tnd_exr_file;

/* Read the first part of a scanline or tiled-less EXR: header and every channel, converted to
 * float or uint32. Errors name the file. */
tnd_result tnd_exr_read(const char *path, tnd_exr_file *f);
/* How many files tnd_exr_write wrote uncompressed because the library would have corrupted a
 * ZIP chunk (exr.c says when). */
uint32_t tnd_exr_uncompressed_fallbacks(void);
void tnd_exr_close(tnd_exr_file *f);
const tnd_exr_channel *tnd_exr_find(const tnd_exr_file *f, const char *name);
/* Attribute lookup; false when absent or of another type. */
bool tnd_exr_attr_int(const tnd_exr_file *f, const char *name, int32_t *v);
bool tnd_exr_attr_v2f(const tnd_exr_file *f, const char *name, float v[2]);
bool tnd_exr_attr_m44f(const tnd_exr_file *f, const char *name, float m[16]);
bool tnd_exr_attr_string(const tnd_exr_file *f, const char *name, char *out, size_t cap);

/* A progressive reference's statistics (both front-ends' references, the matched reference). */
typedef struct tnd_ref_stats {
    double until_noise; /* in: stop once rel_error is below it, checked every
                           TND_REF_CHECK_EVERY samples (0: take every sample asked for) */
    uint32_t spp;       /* out: samples taken */
    double rel_error;   /* out: mean relative standard error of the pixels' luminance means (over
                           pixels whose mean is above 1e-6) */
    double seconds;     /* out (the caller's): time spent sampling the frame, for paths per
                           second (0: not measured, as in a merge) */
} tnd_ref_stats;
#define TND_REF_CHECK_EVERY 16u
/* The standard error of a pixel's luminance mean after spp samples, from the means of its
 * luminance and of the luminance squared (the sample variance with Bessel's correction). */
static inline double tnd_ref_pixel_se(double mean, double mean_sq, uint32_t spp)
{
    if (spp < 2)
        return 0.0;
    double var = (mean_sq - mean * mean) * spp / (spp - 1);
    return var > 0 ? sqrt(var / spp) : 0.0;
}

/* A reference's result after spp samples from per-pixel sums of the samples' RGB (3 per
 * pixel) and of their luminance squared: the mean into rgb, each pixel's standard error of its
 * luminance mean into lum_se (both optional); returns the mean relative standard error. */
double tnd_ref_finish(const double *sum_rgb, const double *sum_lum2, size_t n, uint32_t spp,
                      float *rgb, float *lum_se);
/* A reference's samples [first, first + count) added to per-pixel sums (the front-ends' *_add
 * calls): stats->until_noise in, stats->spp (samples the sums hold) out. */
typedef tnd_result (*tnd_ref_add_fn)(void *ctx, uint32_t first, uint32_t count, double *sum_rgb,
                                     double *sum_lum2, tnd_ref_stats *stats,
                                     void (*progress)(uint32_t, uint32_t, void *), void *user);
/* A finished reference of n pixels from an accumulating one: zeroed sums, samples [0, spp)
 * through `add`, then tnd_ref_finish into rgb and lum_se (optional) and stats (optional). */
tnd_result tnd_ref_run(size_t n, uint32_t spp, tnd_ref_add_fn add, void *ctx, float *rgb,
                       float *lum_se, tnd_ref_stats *stats,
                       void (*progress)(uint32_t, uint32_t, void *), void *user);

/* ---------------------------------------------------------------------------------------------
 * Captures: one EXR per frame holding the whole contract
 * ------------------------------------------------------------------------------------------- */
/* Write every present entry of `f` (channels named as the table says; FLOAT/UINT at float32
 * precision, HALF for half-packed entries at packed precision) with the camera as attributes. */
tnd_result tnd_capture_write(const char *path, const tnd_frame *f, tnd_exr_compression c);
/* Read and validate a Tandem capture: every channel of every entry is checked (missing, wrong
 * type, non-finite values), and all problems are reported at once, per channel. */
tnd_result tnd_capture_read(const char *path, tnd_frame *f);

/* A-SVGF's gradient samples of a frame: the back-end's selection (the sample pixels, y*W+x, in
 * its order) and the contract at those pixels after the front-end re-shaded them with the
 * previous frame's random numbers (`values`: count x 1 pixels, sample i at pixel i). A capture
 * rendered with asvgf keeps them beside each frame, so that a replay re-runs the selection on
 * the frame as rendered and then patches these values in, as the live render did. */
typedef struct tnd_gradient_samples {
    uint32_t count;
    uint32_t *pixel;
    tnd_frame values;
} tnd_gradient_samples;
/* The samples at `pixels` (count of them, each < W*H) of the re-shaded frame. count 0: empty. */
tnd_result tnd_gradient_samples_gather(const tnd_frame *reshaded, const uint32_t *pixels,
                                       uint32_t count, tnd_gradient_samples *g);
/* Patch the samples into f (every entry present in both). */
void tnd_gradient_samples_apply(const tnd_gradient_samples *g, tnd_frame *f);
void tnd_gradient_samples_free(tnd_gradient_samples *g);
/* "DIR/frame_0003.gradients.exr" for "DIR/frame_0003.exr". */
void tnd_capture_gradients_path(const char *capture, char *out, size_t cap);
bool tnd_capture_is_gradients_file(const char *name);
/* The samples as an EXR of count x 1 pixels: the contract's channels plus `gradient.pixel`
 * (UINT), with the frame's size as attributes; count 0 writes nothing. */
tnd_result tnd_capture_write_gradients(const char *path, const tnd_gradient_samples *g,
                                       uint32_t frame_width, uint32_t frame_height,
                                       tnd_exr_compression c);
/* Read them back, checking that they belong to a frame of this size (pixels inside it). */
tnd_result tnd_capture_read_gradients(const char *path, uint32_t frame_width,
                                      uint32_t frame_height, tnd_gradient_samples *g);

/* A mapping from another renderer's EXR channels onto the contract (docs/captures.md). */
typedef struct tnd_capture_map tnd_capture_map;
tnd_result tnd_capture_map_load(const char *path, tnd_capture_map **map);
void tnd_capture_map_destroy(tnd_capture_map *map);
/* The frames of a directory: the names of a mapping's primary files (its first "files"
 * pattern; frame_{frame}.exr without one), or with map NULL Tandem's frame_NNNN.exr, in natural
 * order (free with tnd_capture_list_free); none is an error naming the directory. */
tnd_result tnd_capture_map_list(const tnd_capture_map *map, const char *dir, char ***names,
                                size_t *count);
void tnd_capture_list_free(char **names, size_t count);
/* The directory a capture's frames are in: DIR/capture where it exists (a render's output),
 * else DIR. */
void tnd_capture_dir(const char *captures, char *dir, size_t cap);
/* Every frame of a sequence carries the entries of its first: an error naming the file and the
 * entry otherwise. */
tnd_result tnd_capture_check_entries(const tnd_frame *first, const tnd_frame *f, const char *path);
/* Read a foreign frame through a mapping (`path`: its primary file; the others are found beside
 * it); an unfed REQUIRED entry is an error naming it. `prev`: the camera of the frame before in
 * the sequence (NULL for the first), for motion reconstructed from positions. */
tnd_result tnd_capture_read_mapped(const char *path, const tnd_capture_map *map,
                                   const tnd_camera_state *prev, tnd_frame *f);
/* The mapping's name, and what feeds entry e in words ("ViewLayer.Depth.Z (planar to
 * distance)"); false when the mapping does not feed it. */
const char *tnd_capture_map_name(const tnd_capture_map *map);
bool tnd_capture_map_source(const tnd_capture_map *map, tnd_ct e, char *buf, size_t cap);
/* What happens where a file lacks entry e, in the mapping's words; NULL: e is not optional. */
const char *tnd_capture_map_fallback(const tnd_capture_map *map, tnd_ct e);

/* ---------------------------------------------------------------------------------------------
 * Math: column-major 4x4 matrices (m[col * 4 + row]), quaternions (x, y, z, w)
 * ------------------------------------------------------------------------------------------- */
void tnd_mat4_identity(float m[16]);
void tnd_mat4_mul(const float a[16], const float b[16], float out[16]); /* out = a * b */
/* General inverse; false (and out = identity) when singular. */
bool tnd_mat4_inverse(const float m[16], float out[16]);
/* m * (p, 1), divided by w when `project`. */
void tnd_mat4_point(const float m[16], const float p[3], bool project, float out[3]);
void tnd_mat4_dir(const float m[16], const float d[3], float out[3]);
/* Translation * rotation * scale, as glTF composes node transforms. */
void tnd_mat4_trs(const float t[3], const float q[4], const float s[3], float out[16]);
/* Right-handed perspective for Vulkan: clip y down, depth [0, 1]; zfar <= 0 means infinite. */
void tnd_mat4_perspective(float yfov, float aspect, float znear, float zfar, float out[16]);
/* Normalised quaternion slerp (shortest path). */
void tnd_quat_slerp(const float a[4], const float b[4], float t, float out[4]);
/* out = a b (the rotation b, then a; out may alias either). */
void tnd_quat_mul(const float a[4], const float b[4], float out[4]);
/* The rotation (x, y, z, w) of a camera at eye looking at target with +Y up (glTF cameras look
 * down their -Z); false where the two coincide or the view is vertical. */
bool tnd_quat_look_at(const double eye[3], const double target[3], float q[4]);
/* World-space primary ray direction (unit) and origin through pixel position (px, py) (pixel
 * units, top-left origin, centres at +0.5) for the camera state's current view/proj. */
void tnd_camera_ray(const tnd_camera_state *c, uint32_t width, uint32_t height, float px, float py,
                    float origin[3], float dir[3]);

/* ---------------------------------------------------------------------------------------------
 * Scenes: glTF 2.0 through assimp (+ cJSON for what assimp drops), flat and GPU-friendly
 * ------------------------------------------------------------------------------------------- */
typedef enum tnd_material_kind {
    TND_MAT_OPAQUE = 0, /* metal-rough */
    TND_MAT_MIRROR,     /* metallic >= 0.5 and roughness < TND_MIRROR_ROUGHNESS */
    TND_MAT_THIN_GLASS, /* transmission without KHR_materials_volume (thin-walled) */
    TND_MAT_GLASS,      /* transmission with a volume: IOR and Beer-Lambert absorption */
    TND_MAT_KIND_COUNT,
} tnd_material_kind;
#define TND_MIRROR_ROUGHNESS 0.05f
const char *tnd_material_kind_name(tnd_material_kind k);
struct tnd_material;
/* Beer-Lambert absorption coefficient per channel (1/m) of a glass volume:
 * -ln(attenuation colour) / attenuation distance (0 without a distance or a colour below 1). */
void tnd_material_sigma(const struct tnd_material *m, float sigma[3]);

/* A texture's coordinates (glTF textureInfo.texCoord and KHR_texture_transform): from set
 * `set` (TEXCOORD_0 or _1), u' = m0 u + m1 v + m2, v' = m3 u + m4 v + m5 (offset x rotation x
 * scale, glTF's order). */
typedef struct tnd_uv_xform {
    float m[6];
    uint32_t set;
    float lod_shift; /* 0.5 log2 |det|: the transformed coordinates cover |det| times the area */
} tnd_uv_xform;
enum { TND_TEX_BASE = 0, TND_TEX_METAL_ROUGH, TND_TEX_NORMAL, TND_TEX_EMISSION, TND_TEX_SLOTS };
#define TND_UV_IDENTITY {{1, 0, 0, 0, 1, 0}, 0, 0.0f}
/* Apply a transform to (u, v). */
static inline void tnd_uv_apply(const tnd_uv_xform *x, float u, float v, float *ou, float *ov)
{
    *ou = x->m[0] * u + x->m[1] * v + x->m[2];
    *ov = x->m[3] * u + x->m[4] * v + x->m[5];
}


typedef struct tnd_material {
    char name[64];
    tnd_material_kind kind;
    float base_color[4];
    float metallic, roughness;
    float emission[3]; /* emissiveFactor x KHR_materials_emissive_strength, nits */
    float transmission, ior;
    float specular; /* KHR_materials_specular factor (1 by default) */
    float attenuation_color[3], attenuation_distance, thickness; /* KHR_materials_volume */
    float normal_scale;
    int32_t tex_base_color, tex_metal_rough, tex_normal, tex_emission; /* -1: none */
    tnd_uv_xform uvx[TND_TEX_SLOTS]; /* per texture above (TND_TEX_*) */
    bool double_sided;
    /* glTF alphaMode MASK, and BLEND taken as a cut-out (docs/scenes.md): the surface is there
     * for every ray where base colour alpha x the texture's alpha (level 0) >= alpha_cutoff */
    bool alpha_test;
    float alpha_cutoff;
} tnd_material;


#define TND_TEXTURE_MAX_LEVELS 16
typedef struct tnd_texture {
    char name[256];
    uint32_t width, height;
    uint8_t *rgba8; /* width x height x 4, top row first, as decoded */
    bool srgb;      /* base colour and emission textures: RGB sRGB-encoded (alpha linear) */
    /* The mip chain in the image's own 8 bits (level 0 = rgba8 itself; each further level a 2x2
     * box filter of the one above in linear values, encoded again), what both front-ends
     * sample, decoding through the one table of shaders/texel_lut.h. */
    uint32_t levels;
    uint32_t level_w[TND_TEXTURE_MAX_LEVELS], level_h[TND_TEXTURE_MAX_LEVELS];
    uint8_t *level[TND_TEXTURE_MAX_LEVELS];
} tnd_texture;

/* Build the mip chain of a decoded texture. */
tnd_result tnd_texture_build_mips(tnd_texture *t);
/* Trilinear sample (repeat wrap, texel centres at +0.5) at level of detail lod >= 0. */
void tnd_texture_sample(const tnd_texture *t, float u, float v, float lod, float out[4]);

typedef struct tnd_mesh {
    char name[64];
    uint32_t first_vertex, vertex_count;  /* into the scene's vertex arrays */
    uint32_t first_index, triangle_count; /* indices are relative to first_vertex */
    uint32_t material;
} tnd_mesh;

typedef enum tnd_light_type {
    TND_LIGHT_POINT = 0,
    TND_LIGHT_SPOT,
    TND_LIGHT_DIRECTIONAL,
    TND_LIGHT_AREA, /* emissive triangles; not in tnd_scene.lights */
    TND_LIGHT_TYPE_COUNT,
} tnd_light_type;
const char *tnd_light_type_name(tnd_light_type t);

#define TND_SCHEDULE_MAX 16
typedef struct tnd_light {
    char name[64];
    tnd_light_type type;
    uint32_t node;
    float color[3]; /* colour x intensity: candela (point, spot) or lux (directional) */
    float inner_cone, outer_cone; /* spot, radians */
    uint32_t schedule_count;      /* step-wise intensity scale: from frame[k] on, scale[k] */
    float schedule_fps;
    float schedule_frame[TND_SCHEDULE_MAX], schedule_scale[TND_SCHEDULE_MAX];
} tnd_light;

typedef struct tnd_instance {
    uint32_t mesh, node;
    bool animated; /* its node (or an ancestor) is animated */
} tnd_instance;

typedef struct tnd_node {
    char name[64];
    int32_t parent;         /* -1 for roots; parents come before children */
    float t[3], r[4], s[3]; /* rest pose */
    bool animated;          /* this node or an ancestor has animation channels */
} tnd_node;

typedef struct tnd_camera_def {
    char name[64];
    uint32_t node;
    float yfov, aspect, znear, zfar; /* aspect 0: the image's; zfar 0: infinite */
} tnd_camera_def;

/* What a channel animates: a node's translation, rotation or scale (glTF's paths), or the
 * vertical field of view (radians) of the camera on that node (camera paths: docs/scenes.md). */
typedef enum tnd_anim_path { TND_ANIM_T = 0, TND_ANIM_R, TND_ANIM_S, TND_ANIM_YFOV } tnd_anim_path;
/* Values per key of a path: 3 (T, S), 4 (R: quaternion xyzw) or 1 (YFOV). */
uint32_t tnd_anim_dim(tnd_anim_path p);
typedef struct tnd_anim_channel {
    uint32_t node;
    tnd_anim_path path;
    uint32_t key_count;
    float *times;  /* seconds, increasing */
    /* per key: its value (dim floats, tnd_anim_dim); cubic: in-tangent, value, out-tangent
     * (3 dim floats, glTF's CUBICSPLINE layout, tangents per second) */
    float *values;
    bool step;  /* glTF STEP: a key's value holds until the next */
    bool cubic; /* glTF CUBICSPLINE: cubic Hermite between keys (rotations then normalised) */
} tnd_anim_channel;

/* Emissive triangle: an area light. */
typedef struct tnd_emitter {
    uint32_t instance, primitive;
} tnd_emitter;

/* An environment map (shaders/env.h: convention and layout), as both front-ends sample it. */
#include "shaders/env.h"
typedef struct tnd_env {
    char path[1024];
    uint32_t width, height; /* 0: none */
    float intensity, rotation; /* rotation: degrees about +Y */
    float cos_rot, sin_rot;
    float *data;            /* TND_ENV_FLOATS(width, height) floats, shaders/env.h's layout */
    double mean_luminance;  /* over the sphere of directions, intensity applied */
    uint32_t bad_texels;    /* NaN, infinite or negative values read (set to 0) */
} tnd_env;

/* Read a latitude-longitude RGB EXR (half or float, width = 2 height) as an environment of the
 * given intensity (a factor) and rotation about +Y (degrees). Bad texels are counted, set to 0
 * and said once on stderr. Errors name the file and the problem; e is left as it was. */
tnd_result tnd_env_load(const char *path, float intensity, float rotation_deg, tnd_env *e);
/* The same from w x h RGB floats in memory (any size: tests, generated skies); `name` for
 * messages. */
tnd_result tnd_env_from_pixels(const char *name, const float *rgb, uint32_t w, uint32_t h,
                               float intensity, float rotation_deg, tnd_env *e);
void tnd_env_free(tnd_env *e);
/* Radiance seen along unit direction dir (nearest texel) and the solid-angle density with which
 * tnd_env_sample picks that direction. */
float tnd_env_lookup(const tnd_env *e, const float dir[3], float rgb[3]);
/* A direction by importance (u1 picks the row, u2 the column), its texel's radiance, and its
 * solid-angle density (0: not a usable sample). */
float tnd_env_sample(const tnd_env *e, float u1, float u2, float dir[3], float rgb[3]);

/* What a scene requires of the pipeline (docs: model only what a scene requires). */
// clang-format off
#define TND_FEATURE_LIST(X) \
    X(LIGHT_POINT,       "point lights") \
    X(LIGHT_SPOT,        "spot lights") \
    X(LIGHT_DIRECTIONAL, "directional lights") \
    X(LIGHT_AREA,        "area lights (emissive triangles)") \
    X(SKY,               "uniform sky radiance") \
    X(ENV_MAP,           "environment map (importance-sampled)") \
    X(ALPHA,             "alpha-tested geometry (glTF MASK, BLEND as a cut-out)") \
    X(TEXTURES,          "textures") \
    X(NORMAL_MAPS,       "normal maps") \
    X(MIRROR,            "mirrors (reflect pass)") \
    X(GLASS,             "glass with volume (refract pass, absorption)") \
    X(THIN_GLASS,        "thin glass (refract pass)") \
    X(SPLIT,             "surfaces that both reflect and refract (checkerboard split)") \
    X(ANIMATED_CAMERA,   "animated camera") \
    X(ANIMATED_OBJECTS,  "animated objects (TLAS refit, object motion)") \
    X(LIGHT_SCHEDULE,    "lights switching over time")
// clang-format on
enum {
#define TND_X(id, text) TND_FEATURE_BIT_##id,
    TND_FEATURE_LIST(TND_X)
#undef TND_X
        TND_FEATURE_COUNT
};
#define TND_FEATURE(id) (1u << TND_FEATURE_BIT_##id)
const char *tnd_feature_name(uint32_t bit);

typedef struct tnd_scene {
    char path[1024];
    float *positions, *normals, *uvs, *tangents; /* 3, 3, 2, 4 floats per vertex */
    float *uvs1; /* TEXCOORD_1, 2 floats per vertex; NULL when no mesh has one (set 1 then
                    reads set 0) */
    uint32_t vertex_count;
    uint32_t *indices;
    uint32_t index_count;
    tnd_mesh *meshes;
    uint32_t mesh_count;
    tnd_material *materials;
    uint32_t material_count;
    tnd_texture *textures;
    uint32_t texture_count;
    tnd_node *nodes;
    uint32_t node_count;
    tnd_instance *instances;
    uint32_t instance_count;
    tnd_light *lights;
    uint32_t light_count;
    tnd_emitter *emitters;
    uint32_t emitter_count;
    tnd_camera_def *cameras;
    uint32_t camera_count;
    tnd_anim_channel *channels;
    uint32_t channel_count;
    float duration; /* seconds; 0 for a still scene */
    float sky[3];   /* uniform sky radiance, nits (unused where env is set) */
    bool sky_set;   /* the scene states its sky (tandem_sky, even black): no default light */
    tnd_env env;    /* environment map (width 0: none); replaces the sky */
    uint32_t features;
    /* What the scene lacked and was given (empty when it had its own): a camera framing its
     * bounds, a default environment; each note says the rule, as announced on stderr. */
    char default_camera[256], default_light[256];
    char camera_path[256]; /* the camera path given (camera 0), in words; empty: none */
    /* Images a material names that could not be read (absent, a Blender procedural pseudo-URI,
     * undecodable): each warned about once; the material keeps its factors alone (white base
     * colour, a flat normal). */
    struct tnd_missing_image {
        char name[256], material[64], reason[96]; /* the first material that names it */
        uint32_t uses;                            /* materials' slots naming it */
    } *missing_images;
    uint32_t missing_image_count;
} tnd_scene;

/* The defaults a scene without a camera or without any light gets (docs/scenes.md). */
#define TND_DEFAULT_CAMERA_YFOV_DEG 45.0
#define TND_DEFAULT_CAMERA_AZIMUTH_DEG 30.0   /* to the right of +Z, about +Y */
#define TND_DEFAULT_CAMERA_ELEVATION_DEG 20.0 /* above the horizontal */
#define TND_DEFAULT_CAMERA_MARGIN 1.1         /* the bounding sphere fills 1/1.1 of the height */
#define TND_DEFAULT_SKY 1.0f                  /* nits, white, uniform */

/* Load a scene: a .gltf/.glb path, or a generated one: "stress:N" (about N triangles in 16
 * distinct meshes, for benchmarks). Bad input gets a message naming the file and the element. */
tnd_result tnd_scene_load(const char *path, tnd_scene **scene);
/* What a user may change in a scene as it loads (the command line's --env). */
typedef struct tnd_scene_options {
    const char *env;         /* an environment map (EXR) replacing the scene's sky or tandem_env */
    float env_intensity;     /* its factor */
    float env_rotation;      /* degrees about +Y */
    bool opaque;             /* alpha-tested materials made opaque (what cut-outs cost: bench) */
    bool up_z;               /* the scene was modelled with +Z up: turned to +Y up (root nodes
                                and their channels rotated -90 degrees about +X) */
    bool no_default_light;   /* a scene without punctual lights, sky or environment stays unlit
                                (its emitters alone) instead of getting the default sky */
    /* A camera path (core/camera_path.c, docs/scenes.md): orbit, dolly, flythrough or a keyframe
     * file (*.json); it becomes camera 0. NULL: none. */
    const char *camera_path;
    double path_duration;    /* seconds (<= 0: 10) */
    double path_radius;      /* orbit radius, dolly distance, flythrough radius (<= 0: bounds') */
    double path_height;      /* camera height above the bounds' centre, where path_height_given */
    bool path_height_given;
} tnd_scene_options;
/* One keyframe of a camera path file: time (s), position, rotation (x, y, z, w), yfov (rad). */
typedef struct tnd_camera_key {
    double time;
    float position[3], rotation[4], yfov;
} tnd_camera_key;
/* Write keyframes as a camera path file (what --camera-path FILE.json reads). */
tnd_result tnd_camera_path_write(const char *path, const tnd_camera_key *keys, uint32_t n);
tnd_result tnd_scene_load_with(const char *path, const tnd_scene_options *o, tnd_scene **scene);
void tnd_scene_destroy(tnd_scene *scene);
/* A 64-bit digest (FNV-1a) of everything a scene renders from once loaded: geometry, materials,
 * textures, nodes, lights, cameras, animation, sky and environment (not names or paths): two
 * loads of the same files on two machines agree; a changed buffer, texture or --env does not. */
uint64_t tnd_scene_digest(const tnd_scene *s);
/* Triangles over all instances (what the tracer sees). */
uint64_t tnd_scene_triangles(const tnd_scene *s);
/* Whether a ray meets material m's surface at (u, v), the coordinates of the set its base
 * colour texture reads (m->uvx[TND_TEX_BASE].set), before that texture's transform: always, or
 * for an alpha-tested material, where its alpha (factor x base colour texture at level 0,
 * bilinear) reaches the cutoff. The GLSL mirror is pt_scene.glsl's alpha_pass. */
bool tnd_material_alpha_pass(const tnd_scene *s, const tnd_material *m, float u, float v);

/* The scene at one moment. */
typedef struct tnd_scene_state {
    double time;
    float *node_world;       /* 16 floats per node, column-major */
    float *instance_xform;   /* 12 floats per instance, 3x4 row-major (TLAS/Embree layout) */
    float *light_scale;      /* schedule factor per light */
    tnd_camera_state camera; /* view/proj of this moment; prev_* left for the caller */
    float camera_position[3];
} tnd_scene_state;

/* Evaluate animation at `time` seconds (clamped to [0, duration]) for an image of the given
 * aspect ratio, with camera `camera` (0: the first). The state's arrays are allocated on first
 * use and reused; free them with tnd_scene_state_free. */
tnd_result tnd_scene_evaluate(const tnd_scene *s, double time, uint32_t camera, float aspect,
                              tnd_scene_state *st);
void tnd_scene_state_free(tnd_scene_state *st);
/* The world-space bounding box of every instance's vertices in state st (in double). */
void tnd_scene_bounds(const tnd_scene *s, const tnd_scene_state *st, double lo[3], double hi[3]);

/* ---------------------------------------------------------------------------------------------
 * The contract on the GPU: one storage image per entry, formats from the table
 * ------------------------------------------------------------------------------------------- */
typedef struct tnd_contract_gpu {
    tnd_image images[TND_CT_COUNT]; /* binding i = entry i (shaders/contract.h) */
    tnd_precision precision;
    uint32_t width, height;
    /* unique to this creation in the process (never 0): what a cache of descriptor writes
     * compares, as a destroyed image's handles may be handed out again */
    uint64_t serial;
} tnd_contract_gpu;

VkFormat tnd_ct_format(tnd_ct id, tnd_precision p);
/* Bytes per texel of an entry's image at a precision. */
uint32_t tnd_ct_texel_bytes(tnd_ct id, tnd_precision p);
tnd_result tnd_contract_gpu_create(tnd_vk *vk, uint32_t width, uint32_t height, tnd_precision p,
                                   tnd_contract_gpu *c);
void tnd_contract_gpu_destroy(tnd_vk *vk, tnd_contract_gpu *c);
/* The descriptor set every contract reader and writer binds: one storage image per entry,
 * binding = entry index (shaders/contract.h, TND_CT_DECLARE). */
tnd_result tnd_contract_set_layout(tnd_vk *vk, VkShaderStageFlags stages,
                                   VkDescriptorSetLayout *layout);
void tnd_contract_write_set(tnd_vk *vk, VkDescriptorSet set, const tnd_contract_gpu *c);
/* Host frame -> images (packed on the CPU with shaders/encoding.h, so the GPU holds exactly
 * what tnd_frame_quantize computes). Sizes must match. Blocks. */
tnd_result tnd_contract_upload(tnd_vk *vk, tnd_contract_gpu *c, const tnd_frame *f);
/* Images -> host frame (created by the caller at the same size); marks every entry present. */
tnd_result tnd_contract_download(tnd_vk *vk, const tnd_contract_gpu *c, tnd_frame *f);


/* ---------------------------------------------------------------------------------------------
 * Light list for next-event estimation (layout in shaders/lights.h), per frame
 * ------------------------------------------------------------------------------------------- */
#include "shaders/lights.h"
#include "shaders/light_tree.h"

/* How next-event estimation picks its light: from the power table (`plain`), or by descending
 * the light tree (shaders/light_tree.h) by importance for the shading point. */
typedef enum tnd_light_sampling {
    TND_LIGHTS_AUTO = 0, /* the scene decides: the tree from TND_LIGHTS_TREE_FROM local lights,
                          * reservoirs from TND_LIGHTS_RESTIR_FROM */
    TND_LIGHTS_PLAIN,
    TND_LIGHTS_TREE,
    /* ReSTIR DI at the primary surface (candidates from the tree; docs/lights.md) */
    TND_LIGHTS_RESTIR,
} tnd_light_sampling;
/* The local lights (emissive triangles, point and spot lights) from which `auto` takes the
 * tree: with a few, the power table picks as well and costs less (docs/lights.md). */
enum { TND_LIGHTS_TREE_FROM = 16 };
/* ... and reservoirs from this many (their candidates by the tree; on many_lights, 348 emitters,
 * the denoised FLIP 18% under the tree's, at 3.2x the tree's CPU frame: docs/lights.md). */
enum { TND_LIGHTS_RESTIR_FROM = 64 };
const char *tnd_light_sampling_name(tnd_light_sampling m);
/* "auto", "plain", "tree", "restir" -> the mode; false for anything else */
bool tnd_light_sampling_parse(const char *name, tnd_light_sampling *m);
/* What `m` comes to for a scene (auto resolved; never TND_LIGHTS_AUTO). */
tnd_light_sampling tnd_light_sampling_for(const tnd_scene *s, tnd_light_sampling m);

typedef struct tnd_light_list {
    tnd_light_gpu *lights;
    uint32_t count;
    uint32_t *instance_first; /* per instance: index of its first emissive triangle, or ~0u */
    float total_power;
    float env_pick;           /* pick probability of the environment map (0: not in the list) */
    /* the scene's bounding radius (directional lights' and the environment's notional power):
     * kept from the first build while no instance moves, walked again each build otherwise */
    double radius;
    bool radius_known;
    /* set before building: also build the light tree (nodes; each light's path from the root
     * in its record's p2.w), which the front-ends then sample instead of the power table */
    bool want_tree;
    tnd_light_node *nodes;
    uint32_t node_count; /* 0: no tree (plain sampling, or no light) */
    uint32_t node_capacity;
} tnd_light_list;

/* Build the list for a scene state (world-space emitters, schedule scales applied). Lights of
 * zero power are left out; count 0 means no light to sample. Reuses the arrays of `list`.
 * With list->want_tree, also the light tree over them (at most 2 count + 1 nodes). */
tnd_result tnd_lights_build(const tnd_scene *s, const tnd_scene_state *st, tnd_light_list *list);
void tnd_lights_free(tnd_light_list *list);
/* Index of the light picked by u in [0,1): the first light whose cdf exceeds u (the last one if
 * none does, NaN included). A binary search of fixed length whose halves are chosen by an
 * addition of 0 or `half`, without a branch: the CPU front-end picks for every path vertex, and
 * a branch there mispredicts half the time. The range always holds the answer because the cdf
 * never decreases. */
static inline uint32_t tnd_lights_pick(const tnd_light_list *list, float u)
{
    uint32_t base = 0, len = list->count;
    while (len > 1) {
        uint32_t half = len / 2;
        uint32_t right = !(list->lights[base + half - 1].cdf.x > u); /* (NaN: right) */
        base += half & (0u - right); /* (a mask: gcc compiles `right ? half : 0` to a branch) */
        len -= half;
    }
    return base;
}
/* tnd_lights_pick for n values of u at once (out[i] for u[i]). Up to TND_LIGHTS_PICK_LINEAR
 * lights, a count of the cdf values at or below u over all but the last light: the same index,
 * since the cdf never decreases (a NaN counts every one: the last light), in loops over i that
 * the compiler turns into SIMD code; longer lists take the binary search per value. */
enum { TND_LIGHTS_PICK_LINEAR = 16 };
static inline void tnd_lights_pick_n(const tnd_light_list *list, uint32_t n, const float *u,
                                     uint32_t *out)
{
    if (list->count > TND_LIGHTS_PICK_LINEAR) {
        for (uint32_t i = 0; i < n; i++)
            out[i] = tnd_lights_pick(list, u[i]);
        return;
    }
    for (uint32_t i = 0; i < n; i++)
        out[i] = 0;
    for (uint32_t j = 0; j + 1 < list->count; j++) {
        float cdf = list->lights[j].cdf.x;
        _Pragma("GCC ivdep") for (uint32_t i = 0; i < n; i++) out[i] += !(cdf > u[i]);
    }
}


/* ---------------------------------------------------------------------------------------------
 * Building scenes in code (tests, generators): add parts, then commit (validates like a load)
 * ------------------------------------------------------------------------------------------- */
tnd_result tnd_scene_new(const char *name, tnd_scene **s);
/* Each returns the new element's index, or -1 (out of memory; the detail says so). */
int32_t tnd_scene_add_material(tnd_scene *s, const tnd_material *m);
/* tnd_material with glTF's defaults (white, metallic 1, roughness 1, IOR 1.5, no textures). */
tnd_material tnd_material_default(const char *name);
int32_t tnd_scene_add_mesh(tnd_scene *s, const char *name, const float *pos, const float *nrm,
                           const float *uv, uint32_t vertex_count, const uint32_t *idx,
                           uint32_t triangle_count, uint32_t material);
int32_t tnd_scene_add_node(tnd_scene *s, const char *name, int32_t parent, const float t[3],
                           const float r[4], const float sc[3]);
int32_t tnd_scene_add_instance(tnd_scene *s, uint32_t mesh, uint32_t node);
int32_t tnd_scene_add_camera(tnd_scene *s, uint32_t node, float yfov);
int32_t tnd_scene_add_light(tnd_scene *s, const tnd_light *l);
/* An animation channel (copies of the key_count times and their values, tnd_anim_channel's
 * layout). */
tnd_result tnd_scene_add_channel(tnd_scene *s, uint32_t node, tnd_anim_path path,
                                 uint32_t key_count, const float *times, const float *values,
                                 bool step, bool cubic);
tnd_result tnd_scene_commit(tnd_scene *s);
/* The same with load options (a camera path, no default light; env and opaque as a load's). */
tnd_result tnd_scene_commit_with(tnd_scene *s, const tnd_scene_options *o);

#endif
