/* run: what is done with frames, as a library. The layer between the pipeline (pipeline/, eval/)
 * and its two faces, the command line (app/) and Python (python/): the frame session, render and
 * references (unbiased and matched, shards, merge, checkpoints, resume, until-noise), sequence
 * evaluation, sweeps (plan, local run, resume, collect, Slurm), datasets, soak, the stability
 * report, the viewer's repro states and the outputs every run writes.
 *
 * Each entry point takes an options struct whose zero is the default where it can be, and a
 * host (rn_host) through which it says what it does: message lines, progress, and whether it
 * was asked to stop. Nothing here parses a command line, prints or exits: failures come back as
 * tnd_result with Tandem's messages (tnd_error_detail), the words the command line prints.
 * Prefix rn_. */
#ifndef TND_RUN_H
#define TND_RUN_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "core/core.h"
#include "eval/eval.h"
#include "pipeline/pipeline.h"

/* ---- the host: how a run speaks and hears ----------------------------------------------------- */
typedef enum rn_progress_phase {
    RN_PROGRESS_BEGIN = 0, /* a long step starts: label, total */
    RN_PROGRESS_STEP,      /* done of total */
    RN_PROGRESS_END,       /* it ended (done == total unless interrupted) */
} rn_progress_phase;

/* What a run calls to say what it does. Every member may be NULL (that part is silent; a host
 * pointer may be NULL too: silent, never interrupted). `message`: a line for the user (no
 * newline; info lines only when !quiet); `warning`: a line that is always said (a fallback, an
 * interruption, a noise warning); `progress`: a long step (not called when quiet);
 * `interrupted`: the signal that asks the run to stop (0: go on), asked between frames and
 * batches of samples: the run finishes what is in flight, writes where it stopped and returns
 * TND_ERR_INTERRUPTED. */
typedef struct rn_host {
    void (*message)(void *user, const char *line);
    void (*warning)(void *user, const char *line);
    void (*progress)(void *user, rn_progress_phase phase, const char *label, uint64_t done,
                     uint64_t total);
    int (*interrupted)(void *user);
    void *user;
    bool quiet; /* no info lines, no progress */
} rn_host;

/* The host's lines (printf-style), progress and interrupt, NULL host allowed. */
void rn_say(const rn_host *h, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void rn_warn(const rn_host *h, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
int rn_interrupted(const rn_host *h);
/* The same host, quiet (for a run called by another: its cells, its references). */
rn_host rn_host_quiet(const rn_host *h);
/* A progress in steps: begin, step (done so far), end. */
typedef struct rn_progress {
    const rn_host *host;
    const char *label;
    uint64_t total, done;
} rn_progress;
void rn_progress_begin(rn_progress *p, const rn_host *h, const char *label, uint64_t total);
void rn_progress_step(rn_progress *p, uint64_t done);
void rn_progress_end(rn_progress *p);
/* "tandem: WHAT: DETAIL" of a failure (tnd_error_detail, or the code's message), as the command
 * line reports it; the detail alone after "tandem: " where it names WHAT already. */
void rn_failure_line(const char *what, tnd_result r, char *buf, size_t cap);
/* "SIGINT", "SIGTERM" or "a signal" */
const char *rn_signal_name(int sig);

/* ---- directories and files every run writes ---------------------------------------------------- */
/* One run writes an output directory at a time: DIR/.tandem.lock, locked (fcntl) for as long as
 * the run lasts (the system lets go when the process ends, killed or not); a second run there
 * is refused, naming the first's process. rn_unlock_dir removes it (fd < 0: nothing). */
tnd_result rn_lock_dir(const char *dir, int *fd);
void rn_unlock_dir(const char *dir, int fd);
/* Remove a directory and the files in it (no subdirectories): an output left by a failed run. */
bool rn_remove_flat_dir(const char *dir);
/* A JSON document (cJSON *) as PATH, indented, ending in a newline, whole or not at all
 * (tnd_file_write_atomic); the caller keeps `json`. */
tnd_result rn_json_write(const char *path, const void *json);
/* 8-bit sRGB RGB as PNG (written to PATH.tmp, then renamed: no partial file). */
tnd_result rn_write_png(const char *path, const uint8_t *rgb8, uint32_t w, uint32_t h);
bool rn_have_program(const char *prog);
/* DIR/video.mp4 from DIR/frame_NNNN.png, frames first .. first+count-1 (needs ffmpeg). */
tnd_result rn_write_video(const char *dir, unsigned first, unsigned count, double fps);
/* Linear RGB (3 floats per pixel) as a float EXR with channels R, G, B (atomic write). */
tnd_result rn_write_rgb_exr(const char *path, const float *rgb, uint32_t w, uint32_t h);
/* A preview PNG: exposure from the log-average luminance (key 0.18), Reinhard, sRGB. The
 * composite stage's tone mapping replaces it. */
tnd_result rn_write_preview(const char *path, const float *rgb, uint32_t w, uint32_t h);
/* The median of v[0..n) (sorts v in place; 0 when n is 0). */
double rn_median(double *v, unsigned n);
/* frame numbers of DIR/frame_NNNN.exr, sorted */
tnd_result rn_list_frames(const char *dir, uint32_t **frames, uint32_t *count);

/* ---- scenes ------------------------------------------------------------------------------------- */
/* The scene options of every run that loads a scene: the environment map (path, intensity,
 * rotation in degrees), the default light, a camera path (orbit|dolly|flythrough|FILE.json, its
 * duration, radius, height) and the up axis. Start from RN_ENV_INIT. */
typedef struct rn_env {
    const char *path;
    double intensity, rotation;
    bool opaque; /* (bench --opaque: cut-outs made opaque) */
    bool no_default_light;
    const char *camera_path;
    double path_duration, path_radius, path_height; /* path_height NaN: from the bounds */
    const char *up; /* "y" (glTF's) or "z" */
} rn_env;
#define RN_ENV_INIT {NULL, 1.0, 0.0, false, false, NULL, 0.0, 0.0, NAN, "y"}
tnd_result rn_scene_load(const char *path, const rn_env *env, tnd_scene **scene);

/* `--bounces half`: one indirect bounce at half resolution (pl_params.half_indirect); runs turn
 * it into a count of 1 and the flag (rn_bounces_split) before anything reads the count. */
#define RN_BOUNCES_HALF 0xfffffffeu
/* A bounces word: a count (0 to max) or "half" (RN_BOUNCES_HALF); false for any other. */
bool rn_bounces_parse(const char *v, unsigned max, unsigned *value);
/* A bounces value as its count (half: 1) and *half. */
unsigned rn_bounces_split(unsigned value, bool *half);

/* ---- the back-end's dumps ------------------------------------------------------------------------ */
/* LIST (comma-separated dn_dump names, or all) as a bit per dump; then write the chosen dumps of
 * the last frame to DIR/NAME_STEM.exr. */
struct dn_context;
tnd_result rn_dump_parse(const char *list, uint32_t *mask);
tnd_result rn_dumps_write(struct dn_context *dn, uint32_t mask, const char *dir, const char *stem);
/* A frame's dumps as a pl_step's after_backend hook: user is an rn_dump_ctx. */
typedef struct rn_dump_ctx {
    uint32_t mask;
    const char *dir;
    char stem[1024];
} rn_dump_ctx;
tnd_result rn_dump_after_backend(struct dn_context *dn, void *user);

/* ---- the viewer's repro state (run/rn_view_state.c) ----------------------------------------------- */
/* Its settings and the camera of every frame since the history last restarted; a render with
 * it reproduces the viewer's flight frame for frame. A camera held still is one entry for all
 * its frames (a viewer left running does not grow). */
typedef struct rn_view_cam {
    uint32_t frame;                 /* the first frame it is the camera of */
    uint32_t frames;                /* how many (1 or more): frame .. frame + frames - 1 */
    double position[3], yaw, pitch; /* radians: yaw about +Y from -Z towards +X, pitch up */
} rn_view_cam;
typedef struct rn_view_state {
    char scene[1024], frontend[1100], denoiser[1100], precision[16], taa[16], tonemap[16];
    char exposure[32], env[1024], view[64], up[4]; /* up: the scene's up axis (--up), "" = y */
    double bloom, fps, env_intensity, env_rotation, exposure_bias;
    double render_scale; /* traced at the size times this, upscaled (0 or 1: the size) */
    pl_param_set params; /* the denoisers' parameters (pl_param) */
    char split_mode[16];                  /* off, noisy, denoiser, frontend */
    char split_denoiser[1100], split_frontend[1100]; /* the right half's, when split */
    uint32_t bounces, camera, size[2];
    uint32_t no_default_light; /* --no-default-light: 1 */
    uint32_t half_indirect;    /* bounces "half": 1 (bounces 1, at half resolution) */
    rn_view_cam *path;
    uint32_t path_len, path_cap; /* entries */
    uint32_t path_frames;        /* frames: the entries' `frames` summed */
} rn_view_state;
tnd_result rn_view_state_read(const char *path, rn_view_state *s);
tnd_result rn_view_state_write(const char *path, const rn_view_state *s);
void rn_view_state_free(rn_view_state *s);
/* The camera of the next frame (c->frame: the frame after the path's last; c->frames unused):
 * the last entry held one frame longer when the camera is the same, else a new entry. */
tnd_result rn_view_state_push(rn_view_state *s, const rn_view_cam *c);
/* The entry holding the path's i-th frame (0: its first), i < path_frames. */
const rn_view_cam *rn_view_state_at(const rn_view_state *s, uint32_t i);
/* The path emptied (the history restarts). */
void rn_view_state_restart(rn_view_state *s);
/* The frame's camera into a scene state (its view matrix and position; the projection stays). */
void rn_view_camera_apply(const rn_view_cam *c, tnd_scene_state *st);
void rn_view_camera_from_state(const tnd_scene_state *st, uint32_t frame, rn_view_cam *c);
/* The size its front-end traces (render's rn_render_size for its options). */
void rn_view_render_size(const rn_view_state *s, uint32_t out[2]);

/* ---- render and reference (run/rn_render.c, run/rn_reference.c) ---------------------------------- */
/* A render's or a reference's options: what `tandem render` and `tandem reference` take, and
 * what the viewer, the sweep, compare, the dataset and Python fill. Start from
 * rn_render_defaults. */
typedef struct rn_render_opts {
    const char *scene, *frontend, *out, *precision, *rt_api, *denoiser, *dump, *pipeline;
    const char *lights; /* next-event estimation's light pick: auto, plain, tree or restir */
    const char *taa, *tonemap, *exposure; /* taa NULL: on, not asked for */
    double bloom, exposure_bias;
    pl_param_set params; /* the denoiser's parameters given (pl_param) */
    unsigned frames, start, threads, bounces, spp, camera, reflect_depth;
    bool half_indirect; /* render --bounces half: bounces 1, its paths at half resolution */
    unsigned ref_bounces; /* reference: --bounces as given (~0: not given): the realtime
                             estimator's bounces (default 1), or the unbiased path's cap (default
                             none) */
    const char *estimator; /* reference: "unbiased" or "realtime" (a matched reference) */
    const char *composite_on; /* realtime: "device" (where the front-end can) or "host" */
    double until_noise;    /* reference: stop a frame once its mean relative error is below */
    unsigned size[2];
    double fps;
    bool capture, video;
    rn_env env;
    const rn_view_state *view; /* a viewer's state: its settings and camera path */
    const char *shard;          /* reference --shard I/N */
    double checkpoint_s;        /* reference: seconds between checkpoints of a frame's sums (0:
                                   after every run of samples); a frame done is one too */
    const char *resume;         /* reference: go on with the interrupted run in this directory
                                   (its state: DIR/reference.partial.json) */
    unsigned timed_frames;      /* render: frames after the written ones, back to back, timed */
    /* render: the front-end traces and the back-end denoises at size x render_scale (0.25..1),
     * the post chain upscales to size by `upscaler` (temporal, bilinear, bicubic) */
    double render_scale;
    const char *upscaler;
    bool quiet;                 /* no progress or information lines (for this call only) */
} rn_render_opts;
/* render's defaults (the command line's starting point). */
void rn_render_defaults(rn_render_opts *o);
/* render's or reference's options checked (no out needed): an error names the option (the
 * command line's usage errors). */
tnd_result rn_render_check(const rn_render_opts *o, bool reference);
/* The size the front-end traces and the back-end denoises: size x render_scale, rounded, at
 * least 1 (the output is size). */
void rn_render_size(const rn_render_opts *o, uint32_t out[2]);
/* --lights as given (checked by rn_render_check; auto where not given) */
tnd_light_sampling rn_lights_mode(const rn_render_opts *o);
/* A reference's work checked: its --shard I/N planned over the frames and samples, and
 * --until-noise kept to whole frames (the command line's usage errors). */
tnd_result rn_reference_check(const rn_render_opts *o);
/* Render (reference: false) or a reference (true) into o->out: frame_NNNN.exr and .png,
 * captures, dumps, timings.json and run.json; a reference's frames, reference.json, its
 * checkpoints (reference.partial.json) or a shard's sums and shard.json. Options checked as
 * rn_render_check does. A failure leaves no partial output (a reference that lost its device
 * keeps its checkpoints); an interrupt (h->interrupted) ends it between frames or batches of
 * samples with what it finished written and TND_ERR_INTERRUPTED. */
tnd_result rn_render(const rn_render_opts *o, bool reference, const rn_host *h);
/* A render or reference another run makes (a sweep's cell, the stability report's modes,
 * compare's runs): rn_render, its failure said as the command line says a render's (the
 * caller's own failure comes after). */
tnd_result rn_render_nested(const rn_render_opts *o, bool reference, const rn_host *h);

/* A viewer state's settings over render's options (scene, front-end, denoiser and its
 * parameters, post chain, size, camera): the one converter from the viewer's settings. */
void rn_view_state_options(const rn_view_state *v, rn_render_opts *o);
/* The command line of those options (after "tandem", from "render" or "reference"): every option
 * that differs from the defaults, --out when set, --quiet when quiet; strings live in the struct
 * (for scripts that run tandem elsewhere: the sweep's Slurm jobs; a reference's resume state). */
typedef struct rn_args {
    const char *v[96];
    int n;
    char buf[4096];
    size_t used;
} rn_args;
tnd_result rn_render_args(const rn_render_opts *o, bool reference, rn_args *a);
struct cmp_desc;
/* The front-end and the chain as render builds them from its options (the post chain's settings
 * into *pd); *dn (o->denoiser's registry entry) becomes what runs: its fallback where the
 * front-end cannot re-shade (said through h). The parameters the denoiser has go to it. */
tnd_result rn_pipeline_open(const rn_render_opts *o, const tnd_scene *scene, tnd_vk *vk,
                            bool use_vk, bool use_dn, tnd_precision prec,
                            const pl_denoiser_info **dn, bool reference, pl_frontend **fr,
                            pl_chain **chain, struct cmp_desc *pd, const rn_host *h);
/* A frame's host work before the chain runs, ms (rn_frame_begin): the scene's states evaluated,
 * and the front-end's frame set (instances, the light tree's refit, uploads). */
typedef struct rn_frame_host {
    double evaluate_ms, set_frame_ms;
} rn_frame_host;
/* The frame loop's one frame, as render runs it (and the session, the dataset, the timed frames,
 * bench --whole-frame): frame i of the run (o->start + i): the scene's states (st[i & 1] the
 * current; the previous evaluated too when `first`), the viewer's camera, the front-end's frame;
 * its host time into *host where not NULL. */
tnd_result rn_frame_begin(const rn_render_opts *o, const tnd_scene *scene, pl_frontend *fr,
                          tnd_scene_state st[2], unsigned i, bool first, rn_frame_host *host);
/* Its step through the chain (the front-end's bounces, the camera's jitter and spread, the
 * frame time; `reset`: the history restarts). */
pl_step rn_frame_step(const rn_render_opts *o, const tnd_scene_state *cur, unsigned i,
                      bool reset);
/* Samples [first, first + count) of the current frame's reference by o->estimator ("realtime":
 * the matched one, composited where o->composite_on says; else unbiased, o->ref_bounces) added
 * to the per-pixel sums (RGB, luminance^2); `frame`: scratch of the frame's size. */
tnd_result rn_reference_add(pl_frontend *fr, const rn_render_opts *o, unsigned f,
                            tnd_frame *frame, uint32_t first, uint32_t count, double *sum_rgb,
                            double *sum_lum2, tnd_ref_stats *rs,
                            void (*progress)(uint32_t, uint32_t, void *), void *user);
/* A reference's bounces (o->ref_bounces as given, ~0: none; half: realtime's 1) as its run
 * takes it: the realtime estimator's count in o->bounces (default 1), the unbiased path's cap in
 * o->ref_bounces (0: none). Once, after rn_render_check. */
void rn_reference_bounces(rn_render_opts *o);
/* --taa on|off|W (a new-frame weight in (0, 1]; NULL: on) into the post chain's description. */
tnd_result rn_taa_parse(const char *taa, struct cmp_desc *d);
/* One frame's times as timings.json entry members (", \"KEY\": MS" for each of the chain's
 * passes, and the `beside` flag after the pass that has it). */
void rn_timings_members(FILE *f, const pl_chain *chain, const pl_step_result *r);

/* ---- the frame session (run/rn_session.c) ------------------------------------------------------- */
/* render's (or reference's) pipeline held open, frame by frame: what render builds from the
 * options, each frame as render's loop runs it, the pixels to the caller instead of files.
 * Frames are asked for by number (o->start and o->view are not used): one that follows the
 * frame before continues the history, any other restarts it. */
typedef struct rn_session rn_session;
/* `scene`: one loaded already (the caller's, outliving the session; o->scene and o->env then
 * only name it), or NULL: loaded from o->scene with o->env. */
tnd_result rn_session_open(const rn_render_opts *o, bool reference, const tnd_scene *scene,
                           const rn_host *h, rn_session **s);
void rn_session_close(rn_session *s);
const tnd_scene *rn_session_scene(const rn_session *s);
const rn_render_opts *rn_session_opts(const rn_session *s);
/* the denoiser that runs (after a fallback; NULL for a reference session) */
const char *rn_session_denoiser(const rn_session *s);
/* its Vulkan context (NULL where the CPU composites) */
const tnd_vk *rn_session_vk(const rn_session *s);
/* Frame f: render's frame_NNNN.exr into rgb (3 floats per pixel), its PNG's pixels into display
 * (3 bytes per pixel; zeros where the CPU composites), the contract as the capture holds it into
 * `contract` (each optional). */
tnd_result rn_session_frame(rn_session *s, unsigned f, float *rgb, uint8_t *display,
                            tnd_frame *contract);
/* Frame f's reference (o->estimator, o->spp, o->until_noise): the mean into rgb and the variance
 * of one sample's luminance into variance (optional), as reference's EXR holds them. */
tnd_result rn_session_reference(rn_session *s, unsigned f, float *rgb, float *variance,
                                tnd_ref_stats *stats);

/* ---- references' files, shards and merging them (run/rn_reference.c) ----------------------------- */
/* What a reference's own noise adds to a relMSE measured against it: the mean over pixels of
 * se^2 / (mean^2 + eps), from the luminance's standard error (eval's relMSE denominator). */
double rn_ref_noise_relmse(const float *rgb, const float *lum_se, size_t n);
/* a reference frame's paths (pixels x samples) per second of sampling; 0 where not measured */
double rn_ref_paths_per_s(const rn_render_opts *o, const tnd_ref_stats *rs);
/* DIR/reference.json: the estimator and, per frame, the samples taken and the remaining noise. */
tnd_result rn_ref_json_write(const rn_render_opts *o, const char *device,
                             const tnd_ref_stats *rs, const double *noise);
/* Frame i of the path from its sums over rs->spp samples: the mean into rgb, rs->rel_error,
 * *noise, and DIR/frame_NNNN.exr (R, G, B and variance.Y, the variance of one sample's
 * luminance, which lum_se holds after) and .png. */
tnd_result rn_ref_frame_finish(const rn_render_opts *o, unsigned i, const double *sum_rgb,
                               const double *sum_lum2, float *rgb, float *lum_se,
                               tnd_ref_stats *rs, double *noise);
/* DIR/reference.partial.json, an unfinished reference's state (written whole, at its start, at
 * each checkpoint and frame, and when interrupted): its command line ("args"), the frames done
 * with their figures ("done": index, frame, spp, rel_error, noise_relmse, seconds), the frame
 * in progress ("at": index, seconds so far; its samples: DIR/frame_NNNN.sums) and the signal
 * that stopped it. rn_ref_partial_read reads it back (the parsed JSON; its "args" checked to be
 * strings): the command line resumes a run from its args. */
tnd_result rn_ref_partial_write(const rn_render_opts *o, const bool *done,
                                const tnd_ref_stats *rs, const double *noise, int at,
                                double at_seconds, int signal);
struct cJSON;
tnd_result rn_ref_partial_read(const char *dir, struct cJSON **out);
/* Part of a reference's work: samples [first, first + count) of frame `index` of the path. */
typedef struct rn_shard_part {
    uint32_t index, first, count;
} rn_shard_part;
/* "I/N" */
tnd_result rn_shard_parse(const char *text, uint32_t *shard, uint32_t *shards);
/* Shard `shard` of `shards` over frames x spp samples (parts: room for `frames`): whole frames
 * while there are at least as many frames as shards, otherwise even runs of batches of
 * TND_REF_CHECK_EVERY samples (frame by frame), so that shards add up as one run does. */
tnd_result rn_shard_plan(uint32_t frames, uint32_t spp, uint32_t shard, uint32_t shards,
                         rn_shard_part *parts, uint32_t *count);
/* DIR/frame_NNNN.sums read back: its header checked against the size and frame, its first
 * sample and count out, the sums (RGB per pixel, then luminance^2) into sums (4 per pixel). */
tnd_result rn_shard_sums_read(const char *dir, uint32_t w, uint32_t h, uint32_t frame,
                              uint32_t *first, uint32_t *samples, double *sums);
/* DIR/frame_NNNN.sums: one part's per-pixel sums (written whole or not at all). */
tnd_result rn_shard_sums_write(const char *dir, uint32_t w, uint32_t h, uint32_t frame,
                               uint32_t first, uint32_t samples, const double *sum_rgb,
                               const double *sum_lum2);
/* DIR/shard.json: the settings the shard belongs to and its parts (samples taken: taken[k]). */
tnd_result rn_shard_json_write(const rn_render_opts *o, const char *device, uint64_t digest,
                               uint32_t shard, uint32_t shards, const rn_shard_part *parts,
                               const uint32_t *taken, uint32_t count);
/* The shards in dirs[0..n) added up into out: what one run of their settings writes (frames,
 * reference.json), within a float ulp; shards of another scene or setting, gaps and overlaps
 * refused by name. */
tnd_result rn_merge(const char *const *dirs, int n, const char *out, const rn_host *h);

/* ---- device measurements (run/rn_bandwidth.c) -------------------------------------------------- */
/* Device bandwidth (GB/s, bytes read + written) of a vkCmdCopyBuffer and of a compute copy of
 * `bytes` between device-local buffers: medians of `repeats` after a warm-up. */
tnd_result rn_bandwidth(tnd_vk *vk, VkDeviceSize bytes, unsigned repeats, double *transfer_gbs,
                        double *compute_gbs);

/* ---- sequence evaluation (run/rn_eval.c) ------------------------------------------------------- */
#define RN_EVAL_MAX_SERIES 8
/* Error inside a region of the image (pixels the run's capture marks: seen in a mirror, at
 * glass, an emitter, beside one, glossy, newly visible, moving, thin: rn_eval.c's region_masks and
 * docs/metrics.md say how each is found), over all frames: relMSE, mean FLIP, and sharpness = the
 * sum of the tone-mapped image's absolute forward differences inside the region over the
 * reference's (below 1: blurrier than the reference; noise makes it larger than 1), and bias =
 * the region's mean linear luminance over the reference's, minus 1 (what the estimator leaves
 * out or adds). A pixel may lie in several regions. */
enum {
    RN_REGION_MIRROR,
    RN_REGION_GLASS,
    RN_REGION_EMITTER,
    RN_REGION_EMITTER_EDGE,
    RN_REGION_GLOSSY,
    RN_REGION_DISOCCLUDED,
    RN_REGION_MOVING,
    RN_REGION_THIN,
    RN_REGIONS /* (at most 8: a pixel's regions are the bits of a byte) */
};
typedef struct rn_region {
    uint64_t pixels, values, pairs;
    double rel_sq, flip, grad_out, grad_ref;
    double lum_out, lum_ref; /* bias = lum_out / lum_ref - 1 (linear luminance) */
} rn_region;
/* A region's figures from its sums, and its name ("mirror", "glass", "emitter", "emitter_edge",
 * "glossy", "disoccluded", "moving", "thin"). */
typedef struct rn_region_stats {
    double relmse, flip, sharpness, bias;
} rn_region_stats;
rn_region_stats rn_region_summary(const rn_region *r);
const char *rn_region_name(int region);

/* What a series' frames are: a run's linear output, or its capture composited without
 * denoising (the noisy input), or the running mean of those composites, restarted wherever
 * anything moves on screen (a capture's motion not all zero) or a frame is missing: what
 * accumulation alone gives, the curve a denoiser must end at or below on a still camera. */
typedef enum rn_series_kind {
    RN_SERIES_OUTPUT = 0,
    RN_SERIES_NOISY,
    RN_SERIES_ACCUMULATED,
} rn_series_kind;

typedef struct rn_eval_series {
    char name[64];
    char dir[1100];      /* where its frame_NNNN.exr are */
    rn_series_kind kind; /* not OUTPUT: dir is a capture directory */
    ev_frame_metrics *m; /* per frame (rn_eval_run) */
    ev_summary summary;
    rn_region regions[RN_REGIONS];
    /* RN_SERIES_ACCUMULATED: the running sum (rgb per pixel), its frame count, the last frame
     * added (rn_eval_run) */
    double *acc;
    size_t acc_len; /* doubles in acc */
    uint32_t acc_n, acc_frame, acc_starts; /* acc_starts: how often it (re)started */
    uint32_t restarts; /* RN_SERIES_ACCUMULATED: its restarts after the first frame in the run */
} rn_eval_series;

typedef struct rn_eval {
    char ref[1100];          /* the reference's frame_NNNN.exr */
    double exposure;         /* <= 0: from the reference (geometric mean luminance -> 0.18) */
    double ppd;              /* FLIP pixels per degree (<= 0: 67) */
    rn_progress *progress;  /* optional: stepped once per frame */
    uint32_t min_frame;      /* frames before it are left out (a warm-up) */
    char regions_from[1100]; /* captures whose path flags define the regions ("" : none) */
    bool resample;           /* series of another size are resampled to the reference's */
    const char *metrics_on;  /* "cpu", "device" (a Vulkan device), or NULL / "auto": the device
                                where one that is not a CPU implementation is present */
    bool crop_spread;        /* the report's frames and crops where the series differ most (the
                                largest spread of FLIP between them: the rank's), not where the
                                first series is worst */
    /* filled by rn_eval_run */
    bool auto_exposure;
    uint32_t *frames, count, width, height;
    rn_eval_series series[RN_EVAL_MAX_SERIES];
    uint32_t nseries;
} rn_eval;

/* A series: DIR's frames (the other kinds: DIR/capture's, composited). */
tnd_result rn_eval_add(rn_eval *e, const char *name, const char *dir, rn_series_kind kind);
/* the frames of a sequence whose worth N by FLIP eval finds (evenly spread) */
#define RN_WORTH_FLIP_FRAMES 8
/* Metrics of every series on the frames they all share with the reference. */
tnd_result rn_eval_run(rn_eval *e);
/* DIR/metrics.json, metrics.csv, plots, images of the first, worst and last frames with crops,
 * and index.html. `settings`: JSON object text; `html`: extra section (may be NULL). */
tnd_result rn_eval_report(rn_eval *e, const char *dir, const char *title, const char *settings,
                           const char *html);
void rn_eval_free(rn_eval *e);
/* Convergence on a still camera: the first output series against the accumulated one (the
 * running mean of the noisy composites), by relMSE. `have`: both series exist; `still`: the
 * accumulation never restarted after the first frame (nothing moved); the means over the last
 * quarter of the frames (at least one); `converges`: the output's at or below accumulation
 * alone's. */
typedef struct rn_convergence {
    bool have, still, converges;
    uint32_t output, accumulated; /* series indices */
    uint32_t restarts;
    double last_output, last_accumulated;
} rn_convergence;
rn_convergence rn_eval_convergence(const rn_eval *e);
/* The convergence as text lines (per-frame relMSE at frames 0, 1, 3, 7, ... and the last, the
 * verdict), each starting with `indent`; nothing without both series. */
void rn_eval_convergence_text(const rn_eval *e, const char *indent, ev_text *t);

/* A summary's metrics (the table's summarised ones, eval/table.c) as members of a JSON object. */
struct cJSON;
void rn_metrics_json(struct cJSON *o, const ev_summary *s);

/* The regions of series i as JSON object text (malloc'd; NULL when none was measured), and as
 * an HTML table for the report (appended to t). */
char *rn_eval_regions_json(const rn_eval *e, uint32_t i);
void rn_eval_regions_html(const rn_eval *e, ev_text *t);


/* ---- the whole frame timed back to back (run/rn_whole_frame.c): bench --whole-frame, --overlap -- */
enum {
    RN_WF_HOST = 0,   /* the contract brought to the host, every pass waited for (with_host) */
    RN_WF_GPU,        /* the contract on the GPU, every frame waited for: the per-pass times */
    RN_WF_NO_WAIT,    /* frames recorded without waiting for the one before: the host's share */
    RN_WF_SEPARATE,   /* as RN_WF_NO_WAIT, the gradient re-shading in a launch of its own (only
                         where the front-end can fold it into its shading pass) */
    RN_WF_WAYS,
    RN_WF_MAX_PASSES = 32
};
typedef struct rn_whole_frame_opts {
    const tnd_scene *scene;
    const char *frontend;         /* a front-end's registry name */
    uint32_t size[2];
    unsigned bounces;             /* a count, or RN_BOUNCES_HALF */
    unsigned blocks;              /* blocks of 8 frames per way, after 2 of warm-up */
    const char *denoiser;         /* a denoiser's registry name (or plugin:PATH.so) */
    tnd_precision precision;
    tnd_light_sampling lights;
    bool with_host;               /* the host-contract way too */
} rn_whole_frame_opts;
typedef struct rn_whole_frame_result {
    char device[300], denoiser[64];
    tnd_light_sampling lights;    /* the pick the scene's auto resolved to */
    unsigned frames_per_block, blocks;
    bool ran[RN_WF_WAYS];
    double wall_ms[RN_WF_WAYS];   /* per frame, medians over the blocks */
    uint32_t npasses;             /* the chain's passes (pl_chain_passes), in RN_WF_GPU: */
    struct {
        char name[32];
        pl_pass_group group;
        double ms;                /* the GPU's (Embree's: CPU wall clock), median over frames */
    } pass[RN_WF_MAX_PASSES];
    double group_ms[PL_GROUPS], gpu_ms;
    double host_ms[3];            /* in RN_WF_NO_WAIT, medians: rn_whole_frame_host_name's parts */
} rn_whole_frame_result;
/* The way's name in the table and JSON ("gpu_contract_no_wait") */
const char *rn_whole_frame_way_name(int way);
/* the host's parts of a frame: "evaluate", "set_frame" (rn_frame_host), "chain_run" (recording,
 * submission, any wait for the frame before) */
const char *rn_whole_frame_host_name(int part);
tnd_result rn_whole_frame(const rn_whole_frame_opts *o, rn_whole_frame_result *r);

/* ---- a front-end's throughput on one scene (run/rn_bench_frontend.c): bench ------------------ */
typedef struct rn_bench_frontend_opts {
    const char *scene;      /* the scene's path */
    const char *frontend;   /* a registry name: Embree benchmarks itself, a GPU one its passes */
    uint32_t size[2];
    unsigned frame;         /* the camera path's frame */
    unsigned bounces;       /* a count, or RN_BOUNCES_HALF */
    unsigned repeats;       /* timed repetitions (medians), after a warm-up */
    const char *rt_api;     /* GPU: "pipeline", "query", "auto" (NULL: auto) */
    bool full_pipeline;     /* GPU: every shader variant */
    uint32_t threads;       /* Embree: CPU threads (0: all) */
} rn_bench_frontend_opts;
typedef struct rn_bench_frontend_result {
    bool gpu;               /* the front-end fills the contract on the GPU */
    pl_bench b;             /* rays, passes, the raw loop (Embree) */
    double frame_ms;        /* Embree: its sweep of both passes; GPU: primary + shading */
    double load_s, build_s; /* scene load; BVH / acceleration structures and the frame set */
    uint64_t triangles;
    uint32_t threads;       /* Embree's threads and SIMD width (pl_frontend_cpu) */
    const char *simd;
    char device[300];       /* GPU: the front-end's description */
} rn_bench_frontend_result;
tnd_result rn_bench_frontend(const rn_bench_frontend_opts *o, rn_bench_frontend_result *r);

/* ---- the real-time frame back to back against the bandwidth floor (run/rn_bench_backend.c):
 * bench --denoiser ---------------------------------------------------------------------------- */
typedef struct rn_bench_backend_opts {
    const tnd_scene *scene;
    const char *frontend;   /* a GPU front-end's registry name */
    uint32_t size[2];
    unsigned frame;         /* the camera path's first frame */
    unsigned bounces;       /* a count, or RN_BOUNCES_HALF */
    unsigned repeats;       /* frames timed, after 3 of warm-up */
    const char *rt_api;     /* "pipeline", "query", "auto" (NULL: auto) */
    bool full_pipeline;     /* every shader variant */
    const char *denoiser;   /* a registry name or plugin:PATH.so */
    tnd_precision precision;
    bool per_dispatch;      /* each of the built-in back-end's dispatches timed too */
} rn_bench_backend_opts;
typedef struct rn_bench_pass {
    char id[32];            /* the pass's name in its registry ("temporal") */
    char name[48];          /* timings.json's key without _ms ("denoise_temporal") */
    char label[96];         /* the name, "+" what ran beside it */
    char beside[32];        /* the pass this one runs beside where the step says so ("" none) */
    bool timed_beside;      /* it ran beside that one, which is timed for both (its ms 0) */
    double ms;              /* GPU timestamps' median */
    double bytes;           /* the least it moves (the denoiser's; with what ran beside it) */
} rn_bench_pass;
typedef struct rn_bench_backend_result {
    char device[256], models[512], denoiser[64];
    unsigned frames;
    uint32_t npasses, nfrontend; /* the chain's passes, the front-end's first */
    rn_bench_pass pass[RN_WF_MAX_PASSES];
    bool beside;                 /* a pass ran beside another */
    double wall_ms;              /* per frame (host work and the gradient round trip in it) */
    double backend_ms, backend_bytes;
    double copy_mib, transfer_gb_s, compute_gb_s, bandwidth_gb_s;
    uint32_t ndispatches;        /* per dispatch, where asked and the same every frame */
    bool dispatches_differed;
    struct {
        char name[48];
        double ms;
    } dispatch[TND_TIMER_MAX_PASSES];
} rn_bench_backend_result;
tnd_result rn_bench_backend(const rn_bench_backend_opts *o, rn_bench_backend_result *r);
/* bytes moved at the measured bandwidth, in ms (0 where none was measured) */
double rn_bench_floor_ms(const rn_bench_backend_result *r, double bytes);

/* ---- soak: memory, descriptors and device allocations over long runs (run/rn_soak.c) ---------- */
/* The soak recorder, for any frame loop (render's, the viewer's): begin with the frames planned,
 * call _frame after each (it samples every frames/200-th and the last), _end judges (true: flat
 * after the warm-up), _row its figures, _json a cJSON object of the figures and samples. */
typedef struct rn_soak_row {
    char frontend[64], denoiser[64];
    uint32_t frames, warmup;
    double seconds;
    double rss_base, rss_end, rss_max, rss_kb_per_frame; /* MB, KB a frame */
    double dev_base, dev_end;                            /* MB (< 0: not known) */
    double heap_base, heap_end, heap_kb_per_frame;
    uint32_t fds_base, fds_end;
    uint64_t allocs_base, allocs_end;
    bool flat;
} rn_soak_row;
typedef struct rn_soak_rec rn_soak_rec;
rn_soak_rec *rn_soak_rec_begin(uint32_t frames);
void rn_soak_rec_frame(rn_soak_rec *r, uint32_t f, bool last, const tnd_vk *vk);
bool rn_soak_rec_end(rn_soak_rec *r, uint32_t frames, const char *frontend,
                     const char *denoiser);
const rn_soak_row *rn_soak_rec_row(const rn_soak_rec *r);
void *rn_soak_rec_json(const rn_soak_rec *r);
void rn_soak_rec_free(rn_soak_rec *r);
/* `bench --soak N`: N frames through render's frame loop per front-end and denoiser (each of
 * them where NULL), host RSS, open descriptors and device memory sampled; on_run is called with
 * each run's recorder as it ends; *flat: every run flat. */
typedef struct rn_soak_opts {
    const char *scene;
    rn_env env;
    unsigned size[2], frames;
    const char *frontend, *denoiser;
    void (*on_run)(const rn_soak_rec *rec, void *user);
    void *user;
} rn_soak_opts;
tnd_result rn_soak(const rn_soak_opts *o, const rn_host *h, bool *flat);

/* ---- sweeps: the pipeline over a cartesian product of knobs (run/rn_sweep.c) -------------------- */
/* `bench --sweep`: per cell a render (GPU ms per pass from frames run back to back), its error
 * against its estimator's matched reference (made once per estimator under out/matched) and
 * against the unbiased reference; then out/sweep.json, sweep.csv and out/report. The plan
 * (out/sweep-plan.json) runs here, or with emit "slurm" becomes Slurm jobs
 * (out/slurm/submit.sh); rn_sweep_collect gathers either. */
typedef struct rn_sweep_opts {
    const char *const *sweeps; /* "KEY=V1,V2,..." each */
    int nsweeps;
    const char *scene;
    rn_env env;
    const char *out, *reference; /* reference: an unbiased one to use (NULL: rendered) */
    unsigned spp, size[2], frames, warmup;
    unsigned timed;   /* frames each cell runs back to back for its times (0: its own) */
    const char *emit; /* NULL (run here) or "slurm" */
    unsigned shards;  /* emit: the unbiased reference in this many shards */
} rn_sweep_opts;
typedef struct rn_sweep_result {
    char submit[1200]; /* emit: the script that submits the jobs */
    ev_text table;     /* collected: a line per cell (time, error, Pareto) */
} rn_sweep_result;
/* The options checked and every cell's made (nothing written): TND_ERR_INVALID_ARGUMENT for the
 * sweep's own options; *in_job when a cell's knob value is what fails. */
tnd_result rn_sweep_check(const rn_sweep_opts *o, bool *in_job);
tnd_result rn_sweep(const rn_sweep_opts *o, const rn_host *h, rn_sweep_result *r);
/* A local sweep interrupted (TND_ERR_INTERRUPTED), gone on with: the jobs done are kept, an
 * interrupted reference resumes, the rest run; then collected. */
tnd_result rn_sweep_resume(const char *dir, const rn_host *h, rn_sweep_result *r);
/* A sweep's finished cells gathered (run here or on a cluster); cells that failed or have not run
 * are named in the outputs and in the error. */
tnd_result rn_sweep_collect(const char *dir, const rn_host *h, rn_sweep_result *r);
void rn_sweep_result_free(rn_sweep_result *r);

/* ---- the denoiser leaderboard (run/rn_rank.c) ---------------------------------------------------- */
/* `tandem rank SUITE --denoisers A,B,... --out DIR`: per sequence of the suite (a JSON file,
 * docs/rank.md; or a name of the shipped suites: quick, standard) its matched reference, made
 * once into the cache under a key of everything that determines it; per sequence and denoiser a
 * render (each in its own process: one that fails or crashes loses its row with the reason, the
 * rest are ranked); their evaluation against the reference (tandem eval's figures), intervals by
 * a paired moving-block bootstrap over frames, ties, and the overall rank (the geometric mean of
 * FLIP over the baseline's: svgf where named). DIR/rank.json, rank.csv, report/. The same
 * command again goes on where an interrupted one stopped; another rank in DIR is refused. */
#define RN_RANK_MAX_DENOISERS 8
typedef struct rn_rank_opts {
    const char *suite;     /* a JSON file, or a shipped suite's name */
    const char *denoisers; /* comma-separated: registered names, plugin:PATH, python:MODULE:FN */
    const char *out;
    const char *cache;     /* the references' cache (NULL: $TANDEM_CACHE/references, else
                              $XDG_CACHE_HOME/tandem/references, else ~/.cache/tandem/...) */
    const char *emit;      /* NULL (run here) or "slurm" (DIR/slurm/submit.sh) */
    unsigned bootstrap;    /* replicates (0: 1000) */
    bool no_report;        /* no DIR/report (rank.json and rank.csv only) */
    bool regions;          /* the first denoiser's cells keep their captures, from which every
                              row's error is measured per region (rn_region): per cell and, over
                              the sequences, against the baseline's */
} rn_rank_opts;
typedef struct rn_rank_result {
    ev_text table;      /* the leaderboard as text */
    char submit[1200];  /* emit: the script that submits the jobs */
} rn_rank_result;
/* The options and the suite checked (every file it names, every denoiser), nothing run. */
tnd_result rn_rank_check(const rn_rank_opts *o);
tnd_result rn_rank(const rn_rank_opts *o, const rn_host *h, rn_rank_result *r);
void rn_rank_result_free(rn_rank_result *r);

/* ---- the numerical stability report (run/rn_extremes.c) -------------------------------------- */
/* `bench --extremes`: the scene through every live front-end, denoiser and contract precision;
 * per run and buffer the NaN/Inf, what the packed formats clamp and flush, the largest
 * magnitude; the packed contract's error against float32. out/extremes.json, out/report; a
 * summary's lines appended to *summary; *nonfinite: the NaN and Inf found. */
tnd_result rn_extremes(const char *scene, const char *out, const unsigned size[2],
                       unsigned frames, const rn_host *h, ev_text *summary, uint64_t *nonfinite);

/* ---- training data (run/rn_dataset.c) ---------------------------------------------------------- */
/* `tandem dataset`: per frame of every sequence of the spec (a JSON file, docs/python.md) the
 * contract, the noisy composite, the matched reference and optionally the unbiased one, as EXR
 * or .npz, with out/manifest.json (a shard "I/N": the frames k with k mod N = I, and
 * manifest-I-of-N.json). A failed run leaves nothing of itself. */
tnd_result rn_dataset(const char *spec_path, const char *out, const char *shard,
                      const rn_host *h);

/* ---- what `tandem eval` computes over run folders (run/rn_evaluate.c) ------------------------- */
/* A run's frames (out/frame_NNNN.exr; its noisy input and accumulation alone where it kept its
 * captures) against the matched reference (the denoiser's error) or the unbiased one, the
 * matched against the unbiased (the estimator's bias) where both are given; out/metrics.json,
 * metrics.csv, the report where asked. Warns (through h) where a reference's own noise is over
 * a tenth of what is measured against it. */
typedef struct rn_eval_opts {
    const char *out;          /* the run */
    const char *reference;    /* unbiased references (or NULL) */
    const char *matched;      /* matched references (or NULL; one of the two is needed) */
    const char *report;       /* the HTML report's directory (NULL: none) */
    const char *exposure;     /* the LDR metrics' exposure: "auto" (NULL: the references'
                                 geometric-mean luminance to 0.18) or an EV100 in [-20, 30] */
    double ppd;               /* FLIP pixels per degree (0: 67) */
    const char *metrics_on;   /* "auto" (NULL), "cpu" or "device" */
} rn_eval_opts;
typedef struct rn_eval_result {
    rn_eval e;       /* the run against its primary reference (matched, else unbiased) */
    rn_eval b;       /* both given: the matched reference against the unbiased one */
    bool both;
    const char *primary;
    char *regions[RN_EVAL_MAX_SERIES]; /* e's series' regions as JSON text (or NULL) */
} rn_eval_result;
/* The options checked (the command line's usage errors): TND_ERR_INVALID_ARGUMENT naming the
 * option. rn_eval_sequence checks them too. */
tnd_result rn_eval_check(const rn_eval_opts *o);
tnd_result rn_eval_sequence(const rn_eval_opts *o, const rn_host *h, rn_eval_result *r);
void rn_eval_result_free(rn_eval_result *r);

/* ---- what a scene holds and what the pipeline is (run/rn_info.c) ------------------------------- */
/* A scene's contents: materials used, by kind; lights, by type (area: its emitters); unique
 * triangles; the host memory of its geometry, textures and their mip chains (MB). */
typedef struct rn_scene_counts {
    uint32_t kinds[TND_MAT_KIND_COUNT], lights[TND_LIGHT_TYPE_COUNT];
    uint64_t unique;
    double geo_mb, tex_mb, mip_mb;
} rn_scene_counts;
rn_scene_counts rn_scene_count(const tnd_scene *s);
/* `tandem info --scene PATH --json`'s object, and `tandem info --pipeline --json`'s (malloc'd
 * text; NULL when out of memory). */
char *rn_scene_info_json(const char *path, const tnd_scene *s);
char *rn_pipeline_json(void);

#endif
