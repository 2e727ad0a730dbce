/* tandem_plugin.h: Tandem's plugin ABI, for front-ends and denoisers built outside Tandem and
 * loaded from a shared object: `tandem render --frontend plugin:PATH.so`,
 * `--denoiser plugin:PATH.so`. This header is all a plugin needs (with <vulkan/vulkan.h> for a
 * GPU denoiser); it is installed as <tandem/tandem_plugin.h>.
 *
 * A plugin exports one C function, TANDEM_PLUGIN_ENTRY_NAME:
 *     const tandem_plugin *tandem_plugin_entry(uint32_t abi_version);
 * Tandem passes the ABI version it speaks; the plugin returns its description (static storage)
 * or NULL when it cannot speak that version. Every struct starts with struct_size: the side that
 * fills a struct sets it to sizeof (its version of the struct), and the reader uses only the
 * fields that fit, so that fields can be added at the end without breaking either side. Fields
 * are never removed or reordered within a major ABI version.
 *
 * The contract is Tandem's G-buffer and noisy-signal contract (docs/contract.md): entries are
 * named by tandem_entry below, with the conventions there (world space, right-handed, depth as
 * the distance along the primary ray, motion as previous minus current in pixels, demodulated
 * signals). A plugin declares which entries it reads (denoiser) or writes (front-end) as a mask;
 * Tandem checks the declaration against what it needs and what it has, and says so by name.
 *
 * Calls return 0 on success; on failure, non-zero and a message in `err` (NUL-terminated, at
 * most err_cap bytes), which Tandem prints with the plugin's path. Tandem calls a plugin from one
 * thread. */
#ifndef TANDEM_PLUGIN_H
#define TANDEM_PLUGIN_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define TANDEM_PLUGIN_ABI_VERSION 1u
#define TANDEM_PLUGIN_ENTRY_NAME "tandem_plugin_entry"

/* The contract's entries (values equal Tandem's own table; components per pixel in brackets). */
typedef enum tandem_entry {
    TANDEM_ENTRY_ALBEDO = 0,      /* [3] base colour of the primary surface */
    TANDEM_ENTRY_NORMAL = 1,      /* [3] shading normal, world, facing the primary ray */
    TANDEM_ENTRY_GEO_NORMAL = 2,  /* [3] geometric normal (absent: the shading normal) */
    TANDEM_ENTRY_POSITION = 3,    /* [3] primary hit, world (absent: from depth and camera) */
    TANDEM_ENTRY_DEPTH = 4,       /* [1] distance along the primary ray; 1e30 on a miss */
    TANDEM_ENTRY_MOTION = 5,      /* [3] previous minus current: xy pixels, z depth */
    TANDEM_ENTRY_ROUGHNESS = 6,   /* [1] perceptual roughness (absent: 1) */
    TANDEM_ENTRY_METALLIC = 7,    /* [1] metalness (absent: 0) */
    TANDEM_ENTRY_EMISSION = 8,    /* [3] emitted radiance to the camera, sky on a miss */
    TANDEM_ENTRY_VIS_ID = 9,      /* [2] uint: instance, primitive; 0xFFFFFFFF on a miss */
    TANDEM_ENTRY_VIS_BARY = 10,   /* [2] barycentrics of the primary hit */
    TANDEM_ENTRY_THROUGHPUT = 11, /* [3] primary path throughput (absent: 1) */
    TANDEM_ENTRY_RNG = 12,        /* [2] uint: random-number key (frame, pixel) */
    TANDEM_ENTRY_HF = 13,         /* [3] direct diffuse, albedo demodulated */
    TANDEM_ENTRY_LF_SH = 14,      /* [4] indirect diffuse luma as L1 SH (L1x, L1y, L1z, L0) */
    TANDEM_ENTRY_LF_COCG = 15,    /* [2] indirect diffuse chroma (Co, Cg) */
    TANDEM_ENTRY_SPEC = 16,       /* [3] specular / max(0.01, F0) */
    TANDEM_ENTRY_PATH = 17,       /* [1] uint: path flags (checkerboard split, mirror, glass) */
    TANDEM_ENTRY_COUNT = 18
} tandem_entry;
#define TANDEM_ENTRY_BIT(e) (UINT64_C(1) << (e))
/* The entries every front-end must write (the rest have defaults or are derived). */
#define TANDEM_ENTRIES_REQUIRED                                                                    \
    (TANDEM_ENTRY_BIT(TANDEM_ENTRY_ALBEDO) | TANDEM_ENTRY_BIT(TANDEM_ENTRY_NORMAL) |               \
     TANDEM_ENTRY_BIT(TANDEM_ENTRY_DEPTH) | TANDEM_ENTRY_BIT(TANDEM_ENTRY_MOTION) |                \
     TANDEM_ENTRY_BIT(TANDEM_ENTRY_HF))
/* Not a contract entry: the noisy radiance, Tandem's composite of the contract (the back-end's
 * `off` mode: remodulated signals, emission, throughput), RGBA32F. A denoiser that works on
 * radiance (temporal accumulation, an image denoiser) reads it instead of the signals. */
#define TANDEM_INPUT_RADIANCE (UINT64_C(1) << 63)

/* How the contract's images are stored: float32 everywhere, or packed (half floats, RGBE for
 * hf and spec; docs/contract.md lists each entry's format). Masks of TANDEM_PRECISION_BIT. */
typedef enum tandem_precision {
    TANDEM_PRECISION_FLOAT32 = 0,
    TANDEM_PRECISION_PACKED = 1
} tandem_precision;
#define TANDEM_PRECISION_BIT(p) (1u << (p))

/* Per-frame settings common to every plugin (what NRD calls its common settings). Matrices are
 * column-major (m[col * 4 + row]), right-handed, the camera looking down -Z; proj maps to Vulkan
 * clip space (y down, depth [0, 1]) and includes no jitter. */
typedef struct tandem_frame_settings {
    uint32_t struct_size;
    uint32_t width, height;
    uint32_t frame_index;       /* of the sequence (the front-end's random numbers key on it) */
    uint32_t reset;             /* non-zero: the history is invalid (first frame, camera cut) */
    float view[16], proj[16];   /* this frame's world-to-camera and projection */
    float prev_view[16], prev_proj[16];
    float jitter[2], prev_jitter[2]; /* sub-pixel offsets of the primary rays, pixels */
    float camera_position[3];
    float pixel_spread;         /* radians per pixel: 2 tan(yfov / 2) / height */
    float time_s, dt_s;         /* scene time and seconds since the previous frame */
    uint32_t bounces;           /* front-ends: indirect bounces asked for */
    uint32_t sample;            /* front-ends: 0 for a real-time frame; s + 1 for the s-th frame
                                   of a matched reference (key the random numbers on it, and on
                                   frame_index and the pixel, so that samples differ) */
    uint32_t precision;         /* tandem_precision of the contract */
    /* front-ends (appended: read it only where struct_size covers it): non-zero for `--bounces
     * half`, one bounce (bounces 1) traced only at the pixels (x, y) where x + y + frame_index
     * is even, weighted 2, the others without an indirect sample (docs/estimator.md); a
     * front-end that ignores it traces every pixel's, which has the same expectation */
    uint32_t half_indirect;
} tandem_frame_settings;

/* ---- front-ends ------------------------------------------------------------------------------ */
typedef struct tandem_frontend_create_info {
    uint32_t struct_size;
    const char *scene_path; /* what the user passed to --scene (the plugin may ignore it) */
    uint32_t threads;       /* CPU threads the user allows (0: all) */
} tandem_frontend_create_info;

/* Host buffers of one frame: for each entry in the plugin's `writes` mask, `entries[e]` points
 * at width x height pixels of components(e) values each (float, or uint32_t for VIS_ID, RNG and
 * PATH), row-major from the top-left pixel, pre-filled with the entry's default. Entries not
 * written are NULL. Tandem quantises to the precision, fills defaults and derived entries. */
typedef struct tandem_host_frame {
    uint32_t struct_size;
    uint32_t width, height;
    void *entries[TANDEM_ENTRY_COUNT];
} tandem_host_frame;

typedef struct tandem_frontend_plugin {
    uint32_t struct_size;
    uint64_t writes; /* entries it fills (must include TANDEM_ENTRIES_REQUIRED) */
    int (*create)(const tandem_frontend_create_info *info, void **state, char *err,
                  uint32_t err_cap);
    void (*destroy)(void *state);
    /* Fill the frame the settings describe. */
    int (*render)(void *state, const tandem_frame_settings *settings, tandem_host_frame *out,
                  char *err, uint32_t err_cap);
} tandem_frontend_plugin;

/* ---- denoisers (Vulkan) ---------------------------------------------------------------------- */
#ifdef VK_VERSION_1_0
typedef struct tandem_vulkan {
    uint32_t struct_size;
    VkInstance instance;
    VkPhysicalDevice physical_device;
    VkDevice device;
    VkQueue queue; /* Tandem's one queue: submit to it only in create and destroy */
    uint32_t queue_family;
    PFN_vkGetInstanceProcAddr get_instance_proc_addr;
    PFN_vkGetDeviceProcAddr get_device_proc_addr;
    uint32_t api_version; /* the device's (VK_MAKE_API_VERSION) */
} tandem_vulkan;

typedef struct tandem_image {
    VkImage image;
    VkImageView view; /* 2D, one mip, one layer, layout GENERAL, usable as a storage image */
    VkFormat format;
} tandem_image;

typedef struct tandem_denoiser_create_info {
    uint32_t struct_size;
    const tandem_vulkan *vulkan;
    uint32_t width, height;
    uint32_t precision; /* tandem_precision of the contract images it will receive */
} tandem_denoiser_create_info;

/* One frame's images: the entries in `reads` (others zeroed), the noisy radiance when asked
 * (TANDEM_INPUT_RADIANCE), and the output to write: linear HDR radiance, RGBA32F, width x
 * height. Every image is in layout GENERAL and stays there. */
typedef struct tandem_denoiser_io {
    uint32_t struct_size;
    tandem_image entries[TANDEM_ENTRY_COUNT];
    tandem_image radiance;
    tandem_image output;
} tandem_denoiser_io;

typedef struct tandem_denoiser_plugin {
    uint32_t struct_size;
    uint64_t reads;      /* entries (and TANDEM_INPUT_RADIANCE) it reads */
    uint32_t precisions; /* TANDEM_PRECISION_BIT of the contract precisions it accepts */
    /* Create the state that persists across frames (its history, pipelines): it owns it. */
    int (*create)(const tandem_denoiser_create_info *info, void **state, char *err,
                  uint32_t err_cap);
    void (*destroy)(void *state); /* Tandem waits for the device to be idle first */
    /* Record the frame's work into `cmd` (recording; Tandem submits it). Tandem puts a full
     * memory barrier before and after what the plugin records. */
    int (*record)(void *state, VkCommandBuffer cmd, const tandem_frame_settings *settings,
                  const tandem_denoiser_io *io, char *err, uint32_t err_cap);
} tandem_denoiser_plugin;
#else
typedef struct tandem_denoiser_plugin tandem_denoiser_plugin;
#endif

/* ---- host denoisers (the CPU) ---------------------------------------------------------------- */
/* A denoiser that runs on the host: Tandem brings each frame's contract and noisy radiance to
 * host memory, calls `run`, and takes the radiance it writes back into the frame (the post chain
 * follows). Python denoisers (`--denoiser python:MODULE:CALLABLE`) are one: Tandem's Python
 * bridge is a host denoiser plugin (docs/python.md). */
typedef struct tandem_host_denoiser_create_info {
    uint32_t struct_size;
    uint32_t width, height;
    uint32_t precision; /* tandem_precision of the contract (the host copies are float32 either
                           way, holding the values as quantised) */
    const char *options; /* what the user named the denoiser by after its kind (python: the
                            MODULE:CALLABLE; plugins: "") */
} tandem_host_denoiser_create_info;

/* One frame in host memory: the entries in `reads` (width x height pixels of components(e)
 * values each, float or uint32_t as tandem_host_frame; NULL for the others), the noisy radiance
 * (RGBA, float) when asked (TANDEM_INPUT_RADIANCE), and the output to write: linear HDR
 * radiance, RGBA float (alpha ignored), width x height, row-major from the top-left pixel. */
typedef struct tandem_host_denoiser_io {
    uint32_t struct_size;
    uint32_t width, height;
    const void *entries[TANDEM_ENTRY_COUNT];
    const float *radiance;
    float *output;
} tandem_host_denoiser_io;

typedef struct tandem_host_denoiser_plugin {
    uint32_t struct_size;
    uint64_t reads; /* entries (and TANDEM_INPUT_RADIANCE) it reads */
    int (*create)(const tandem_host_denoiser_create_info *info, void **state, char *err,
                  uint32_t err_cap);
    void (*destroy)(void *state);
    int (*run)(void *state, const tandem_frame_settings *settings,
               const tandem_host_denoiser_io *io, char *err, uint32_t err_cap);
} tandem_host_denoiser_plugin;

/* ---- the description a plugin returns -------------------------------------------------------- */
typedef enum tandem_plugin_kind {
    TANDEM_PLUGIN_FRONTEND = 1,
    TANDEM_PLUGIN_DENOISER = 2,
    TANDEM_PLUGIN_HOST_DENOISER = 3
} tandem_plugin_kind;

typedef struct tandem_plugin {
    uint32_t struct_size;
    uint32_t abi_version;       /* TANDEM_PLUGIN_ABI_VERSION the plugin was built against */
    uint32_t kind;              /* tandem_plugin_kind */
    const char *name;           /* short, for run.json and messages */
    const char *description;    /* one line */
    const tandem_frontend_plugin *frontend; /* kind FRONTEND */
    const tandem_denoiser_plugin *denoiser; /* kind DENOISER */
    const tandem_host_denoiser_plugin *host_denoiser; /* kind HOST_DENOISER */
} tandem_plugin;

typedef const tandem_plugin *(*tandem_plugin_entry_fn)(uint32_t abi_version);

#ifdef __cplusplus
}
#endif
#endif
