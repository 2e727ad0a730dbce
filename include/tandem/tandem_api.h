/* tandem_api.h: Tandem's flat C API for bindings (the Python package `tandem` speaks it through
 * cffi; docs/python.md). Opaque handles, plain arrays the caller owns, JSON text for options and
 * descriptions, so that any foreign-function interface can call it. The library behind it
 * (libtandem_api.so, built into the Python package's directory) holds libtandem's modules, eval's
 * metrics and the command line's frame loop, so that a frame rendered here is `tandem render`'s.
 *
 * Conventions: calls that can fail return 0 (or a handle) on success, and non-zero (or NULL) on
 * failure with the message in tandem_error() (the calling thread's; it names the file or option
 * and the problem, as the command line prints it). Strings returned as `char *` are the caller's
 * to release with tandem_free. Images are row-major from the top-left pixel: rgb 3 floats per
 * pixel, display 3 bytes, a contract entry components(e) floats or uint32 per pixel.
 *
 * This header is read by cffi as it is: no macros, no includes beyond <stdint.h>, plain types. */
#ifndef TANDEM_API_H
#define TANDEM_API_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

const char *tandem_error(void);
void tandem_free(void *p);
const char *tandem_version(void);
/* Info messages (a scene's defaults, a camera path's figures) off (warnings stay); returns the
 * setting before. */
int tandem_set_quiet(int quiet);
/* The registries (front-ends, denoisers with their parameters and passes, metrics): what
 * `tandem info --pipeline --json` prints. */
char *tandem_pipeline_json(void);

/* ---- the contract's table ---- */
uint32_t tandem_entry_count(void);
const char *tandem_entry_name(uint32_t e);
uint32_t tandem_entry_components(uint32_t e);
int tandem_entry_is_uint(uint32_t e);
/* default value (absent entries hold it) */
double tandem_entry_default(uint32_t e);

/* ---- scenes ---- */
typedef struct tandem_scene tandem_scene;
/* options_json: NULL or an object of the scene options, by their command-line names with '_'
 * for '-': env, env_intensity, env_rotation, up, no_default_light, camera_path, path_duration,
 * path_radius, path_height. */
tandem_scene *tandem_scene_load(const char *path, const char *options_json);
/* `tandem info --scene PATH --json`'s object */
char *tandem_scene_info(const tandem_scene *s);
void tandem_scene_free(tandem_scene *s);

/* ---- captures: one frame of the contract in host memory ---- */
typedef struct tandem_capture tandem_capture;
/* The camera a capture carries (tnd_camera_state): column-major matrices, jitter in pixels. */
typedef struct tandem_camera {
    float view[16], proj[16], prev_view[16], prev_proj[16];
    float jitter[2];
    uint32_t frame_index;
} tandem_camera;
/* A frame of every entry at its default, none present. */
tandem_capture *tandem_capture_new(uint32_t width, uint32_t height);
/* A Tandem capture (map_path NULL) or another renderer's frame through a mapping (its primary
 * file; `prev`: the frame before in the sequence, for motion from positions; may be NULL). */
tandem_capture *tandem_capture_read(const char *path, const char *map_path,
                                    const tandem_capture *prev);
/* Every present entry, with the camera when it has one (zip-compressed EXR, written whole). */
int tandem_capture_write(const tandem_capture *c, const char *path);
void tandem_capture_free(tandem_capture *c);
uint32_t tandem_capture_width(const tandem_capture *c);
uint32_t tandem_capture_height(const tandem_capture *c);
/* Entry e's plane (width x height x components values; the capture owns it). */
void *tandem_capture_plane(tandem_capture *c, uint32_t e);
int tandem_capture_present(const tandem_capture *c, uint32_t e);
void tandem_capture_set_present(tandem_capture *c, uint32_t e, int present);
/* an entry the mapping marked optional that the frame's files lack (its default stands) */
int tandem_capture_fallback(const tandem_capture *c, uint32_t e);
tandem_camera *tandem_capture_camera(tandem_capture *c);
int tandem_capture_has_camera(const tandem_capture *c);
void tandem_capture_set_has_camera(tandem_capture *c, int has);
/* The noisy radiance: the composite of the demodulated signals and the checkerboard interleave,
 * as `render --denoiser off` computes it on the CPU (rgb: 3 floats per pixel). */
void tandem_capture_composite(const tandem_capture *c, float *rgb);
/* The frames of a capture directory (DIR or DIR/capture) as a JSON array of file names, in
 * order (a mapping's primary files with map_path). */
char *tandem_capture_list(const char *dir, const char *map_path);

/* ---- rendering: render's and reference's pipeline, frame by frame ---- */
typedef struct tandem_renderer tandem_renderer;
/* options_json: render's options (reference's with `reference`) by their command-line names
 * with '_' for '-': scene, frontend, denoiser, size [W, H], precision, bounces (a count or
 * "half"), fps, camera, threads, rt_api, pipeline, reflect_depth, lights, taa, tonemap, exposure,
 * exposure_bias, bloom, spp, estimator, until_noise, composite_on, the scene options
 * (tandem_scene_load's) and params (an object: the denoiser's parameters by name). */
tandem_renderer *tandem_renderer_open(const char *options_json, int reference);
/* The same on a scene loaded already (it must outlive the renderer; the options then hold no
 * scene options). */
tandem_renderer *tandem_renderer_open_scene(const tandem_scene *scene, const char *options_json,
                                            int reference);
void tandem_renderer_free(tandem_renderer *r);
void tandem_renderer_size(const tandem_renderer *r, uint32_t *width, uint32_t *height);
/* The size its front-end traces and its contract has: the size times render_scale (rounded). */
void tandem_renderer_render_size(const tandem_renderer *r, uint32_t *width, uint32_t *height);
/* the denoiser that runs (after a fallback); "" for a reference renderer */
const char *tandem_renderer_denoiser(const tandem_renderer *r);
/* Frame f: rgb (render's frame_NNNN.exr: linear HDR after the post chain), display (its PNG's
 * pixels; zeros where the CPU composites), the contract as render --capture writes it (a
 * capture of the renderer's size); each may be NULL. A frame that follows the one before goes
 * on with its history; any other restarts it. */
int tandem_renderer_frame(tandem_renderer *r, uint32_t f, float *rgb, uint8_t *display,
                          tandem_capture *contract);
/* Frame f's reference (reference's frame_NNNN.exr): the mean into rgb, the variance of one
 * sample's luminance into variance (may be NULL), the samples taken and the mean relative
 * standard error left. */
int tandem_renderer_reference(tandem_renderer *r, uint32_t f, float *rgb, float *variance,
                              uint32_t *spp, double *rel_error);

/* ---- metrics: tandem eval's, on arrays ---- */
typedef struct tandem_metrics {
    double relmse, smape, rmse, psnr, ssim, flip;
    double temporal, mc_temporal, disoccluded;
    double worth_relmse, worth_flip;
    uint64_t nonfinite;
} tandem_metrics;
typedef struct tandem_summary {
    double relmse, smape, rmse, psnr, ssim, flip, temporal;
    double lag, mc_temporal, flicker, flicker_ref, disocclusion_lag;
    double worth_relmse, worth_flip;
    uint32_t changes, disocclusions;
    uint64_t nonfinite;
} tandem_summary;
/* eval's exposure for a sequence of references (count images of w x h, one after another):
 * their geometric-mean luminance to 0.18. */
double tandem_auto_exposure(const float *rgb, uint32_t width, uint32_t height, uint32_t count);
typedef struct tandem_sequence tandem_sequence;
/* A sequence evaluated frame by frame as tandem eval does (--metrics-on cpu); ppd <= 0: 67. */
tandem_sequence *tandem_sequence_new(uint32_t width, uint32_t height, double exposure, double ppd);
void tandem_sequence_free(tandem_sequence *s);
/* The next frame: out and ref (3 floats per pixel; non-finite values counted and taken as 0),
 * the reference's variance (1 per pixel; NULL: none), its motion (3 per pixel) and depth (1 per
 * pixel) for the motion-compensated metrics (NULL: none), `worth_flip`: also find its worth by
 * FLIP; flip_map (optional): the per-pixel FLIP. */
int tandem_sequence_add(tandem_sequence *s, uint32_t frame, const float *out, const float *ref,
                        const float *variance, const float *motion, const float *depth,
                        int worth_flip, tandem_metrics *m, float *flip_map);
void tandem_sequence_summary(const tandem_sequence *s, tandem_summary *out);
/* `tandem eval` of a run folder: options_json {out, reference, matched_reference, report,
 * exposure, ppd, metrics_on}; returns what DIR/metrics.json holds. */
char *tandem_eval(const char *options_json);

/* ---- commands ---- */
/* `tandem dataset SPEC --out DIR [--shard I/N]` (docs/python.md): the training set's manifest
 * (DIR/manifest.json's text, or the shard's). */
char *tandem_dataset(const char *spec_path, const char *out, const char *shard);
/* `tandem rank SUITE --denoisers LIST --out DIR [--cache DIR] [--bootstrap N] [--no-report]
 * [--regions]` (docs/rank.md): DIR/rank.json's text. cache NULL: the default; bootstrap 0: 1000. */
char *tandem_rank(const char *suite, const char *denoisers, const char *out, const char *cache,
                  unsigned bootstrap, int report, int regions);

/* ---- Python denoisers in this process (the package's own host denoiser plugin) ---- */
/* desc: a `const tandem_plugin *` of kind HOST_DENOISER (tandem_plugin.h) that runs
 * python:MODULE:CALLABLE denoisers, or NULL (the bridge). */
void tandem_set_python_denoiser(const void *desc);

#ifdef __cplusplus
}
#endif
#endif
