/* app: the `tandem` command line. Parses options, wires a front-end to the back-end, prints
 * progress. Only app/ decides exit statuses: 0 success, 1 failure, 2 usage error. */
#ifndef TND_APP_H
#define TND_APP_H

#include <math.h>
#include <stdbool.h>
#include <stdio.h>

#include "core/core.h"
#include "denoise/denoise.h"
#include "eval/eval.h"
#include "pipeline/pipeline.h"

enum { APP_EXIT_OK = 0, APP_EXIT_FAIL = 1, APP_EXIT_USAGE = 2 };

/* ---- options -------------------------------------------------------------------------------- */
typedef enum app_opt_kind {
    APP_OPT_FLAG = 0, /* bool, no argument */
    APP_OPT_STRING,   /* const char * */
    APP_OPT_INT,      /* int */
    APP_OPT_UINT,     /* unsigned */
    APP_OPT_FLOAT,    /* double */
    APP_OPT_SIZE,     /* unsigned[2], "WxH" */
    APP_OPT_LIST,     /* app_list: the option may repeat */
    APP_OPT_BOUNCES,  /* unsigned: a count, or "half" (APP_BOUNCES_HALF) */
} app_opt_kind;

/* `--bounces half`: one indirect bounce at half resolution (pl_params.half_indirect); commands
 * turn it into a count of 1 and the flag (app_bounces_split) before anything reads the count. */
#define APP_BOUNCES_HALF 0xfffffffeu
/* A --bounces word: a count (0 to max) or "half" (APP_BOUNCES_HALF); false for any other. */
bool app_bounces_parse(const char *v, unsigned max, unsigned *value);
/* A --bounces value as its count (half: 1) and *half. */
unsigned app_bounces_split(unsigned value, bool *half);

#define APP_LIST_MAX 8
typedef struct app_list {
    const char *v[APP_LIST_MAX];
    int n;
} app_list;

typedef struct app_opt {
    const char *name; /* without the leading "--" */
    app_opt_kind kind;
    void *dest;
    const char *arg; /* argument placeholder in help, e.g. "PATH" */
    const char *help;
} app_opt;

typedef struct app_cmd {
    const char *name;
    const char *summary;
    const char *usage; /* after "tandem NAME " */
    int (*run)(int argc, char **argv);
} app_cmd;

/* Parse argv[1..] against opts (NULL-name terminated). Every command also accepts --help and
 * --quiet. Returns -1 to continue, or an exit status (help printed: 0; error: 2). Positional
 * arguments are collected into pos (up to max_pos); *npos receives their count. */
int app_parse(const app_cmd *cmd, const app_opt *opts, int argc, char **argv, const char **pos,
              int max_pos, int *npos);
bool app_quiet(void);
/* Quiet or not from now on (the previous setting returned): a command called as a function by
 * another sets its own and puts the caller's back. */
bool app_set_quiet(bool quiet);

/* One run writes an output directory at a time: DIR/.tandem.lock, locked (fcntl) for as long as
 * the run lasts (the system lets go when the process ends, killed or not); a second run there
 * is refused, naming the first's process. app_unlock_dir removes it (fd < 0: nothing). */
tnd_result app_lock_dir(const char *dir, int *fd);
void app_unlock_dir(const char *dir, int fd);
/* Interrupts (SIGINT, SIGTERM): the command line catches them (app_interrupts_install, once in
 * main; a second signal ends the process); long loops ask app_interrupted() between frames or
 * batches of samples, finish what is in flight, write where they stopped and exit with
 * app_interrupt_status() (128 + the signal: 130 for SIGINT, 143 for SIGTERM). */
void app_interrupts_install(void);
int app_interrupted(void); /* the signal, or 0 */
const char *app_signal_name(int sig);
int app_interrupt_status(void);
/* The registered denoisers' parameters as options (pl_param: --NAME VALUE), after `base` (its
 * entries up to the terminator) into `out` (room for cap entries, terminated); their values land
 * in vals (PL_PARAMS_MAX doubles, NaN until given). Returns false when out is too small. */
bool app_opts_with_params(const app_opt *base, app_opt *out, size_t cap, double *vals);
/* The values given into a parameter set (checked against each parameter's range). */
tnd_result app_params_collect(const double *vals, pl_param_set *set);

/* Report a failure of a library call: "tandem: <what>: <detail>" on stderr. Returns 1. */
int app_report(const char *what, tnd_result r);

/* ---- progress bar on stderr (silent when stderr is not a terminal or with --quiet) ---------- */
/* The scene options of every command that loads a scene: the environment map (--env FILE,
 * --env-intensity X, --env-rotation DEG), the default light (--no-default-light) and a camera
 * path (--camera-path orbit|dolly|flythrough|FILE.json, --path-duration, --path-radius,
 * --path-height): APP_ENV_OPTS' table entries, then app_scene_load. Start from APP_ENV_INIT. */
typedef struct app_env {
    const char *path;
    double intensity, rotation;
    bool opaque; /* (bench --opaque: cut-outs made opaque) */
    bool no_default_light;
    const char *camera_path;
    double path_duration, path_radius, path_height; /* path_height NaN: from the bounds */
    const char *up; /* "y" (glTF's) or "z" */
} app_env;
#define APP_ENV_INIT {NULL, 1.0, 0.0, false, false, NULL, 0.0, 0.0, NAN, "y"}
#define APP_ENV_OPTS(e)                                                                            \
    {"env", APP_OPT_STRING, &(e)->path, "FILE",                                                    \
     "light the scene by a latitude-longitude EXR (replaces its sky; docs/scenes.md)"},            \
        {"env-intensity", APP_OPT_FLOAT, &(e)->intensity, "X",                                     \
         "--env: radiance factor (default 1)"},                                                    \
        {"env-rotation", APP_OPT_FLOAT, &(e)->rotation, "DEG",                                     \
         "--env: rotation about +Y in degrees (default 0)"},                                       \
        {"up", APP_OPT_STRING, &(e)->up, "y|z",                                                    \
         "the scene's up axis: y (glTF's, default) or z (turned to +Y up: Stellarium's OBJs, "     \
         "assimp's exports of .blend)"},                                                           \
        {"no-default-light", APP_OPT_FLAG, &(e)->no_default_light, NULL,                           \
         "a scene without punctual light, sky or environment stays unlit (its emitters alone)"},   \
        {"camera-path", APP_OPT_STRING, &(e)->camera_path, "P",                                    \
         "orbit, dolly, flythrough (from the scene's bounds) or keyframes FILE.json: camera 0 "    \
         "(docs/scenes.md)"},                                                                      \
        {"path-duration", APP_OPT_FLOAT, &(e)->path_duration, "S",                                 \
         "--camera-path: seconds once round or along (default 10)"},                               \
        {"path-radius", APP_OPT_FLOAT, &(e)->path_radius, "R",                                     \
         "--camera-path: orbit radius, dolly distance, flythrough radius (default: the bounds')"}, \
        {"path-height", APP_OPT_FLOAT, &(e)->path_height, "H",                                     \
         "--camera-path: height above the bounds' centre (default: the bounds')"}
tnd_result app_scene_load(const char *path, const app_env *env, tnd_scene **scene);

typedef struct app_progress {
    const char *label;
    unsigned total, done;
    double start, last_draw;
    bool enabled;
} app_progress;
void app_progress_begin(app_progress *p, const char *label, unsigned total);
void app_progress_step(app_progress *p, unsigned done);
void app_progress_end(app_progress *p);

/* ---- outputs ------------------------------------------------------------------------------ */
/* Linear RGB (3 floats per pixel) as a float EXR with channels R, G, B (atomic write). */
/* --dump LIST (comma-separated dn_dump names, or all) as a bit per dump; then write the chosen
 * dumps of the last frame to DIR/NAME_STEM.exr. */
struct dn_context;
tnd_result app_parse_dump(const char *list, uint32_t *mask);
/* The viewer's repro state (app/view_state.c): its settings and the camera of every frame since
 * the history last restarted; tandem render --view FILE reproduces it frame for frame. A camera
 * held still is one entry for all its frames (a viewer left running does not grow). */
typedef struct app_view_cam {
    uint32_t frame;                 /* the first frame it is the camera of */
    uint32_t frames;                /* how many (1 or more): frame .. frame + frames - 1 */
    double position[3], yaw, pitch; /* radians: yaw about +Y from -Z towards +X, pitch up */
} app_view_cam;
typedef struct app_view_state {
    char scene[1024], frontend[1100], denoiser[1100], precision[16], taa[16], tonemap[16];
    char exposure[32], env[1024], view[64], up[4]; /* up: the scene's up axis (--up), "" = y */
    double bloom, fps, env_intensity, env_rotation, exposure_bias;
    pl_param_set params; /* the denoisers' parameters (pl_param) */
    char split_mode[16];                  /* off, noisy, denoiser, frontend */
    char split_denoiser[1100], split_frontend[1100]; /* the right half's, when split */
    uint32_t bounces, camera, size[2];
    uint32_t no_default_light; /* --no-default-light: 1 */
    uint32_t half_indirect;    /* bounces "half": 1 (bounces 1, at half resolution) */
    app_view_cam *path;
    uint32_t path_len, path_cap; /* entries */
    uint32_t path_frames;        /* frames: the entries' `frames` summed */
} app_view_state;
tnd_result app_view_state_read(const char *path, app_view_state *s);
tnd_result app_view_state_write(const char *path, const app_view_state *s);
void app_view_state_free(app_view_state *s);
/* The camera of the next frame (c->frame: the frame after the path's last; c->frames unused):
 * the last entry held one frame longer when the camera is the same, else a new entry. */
tnd_result app_view_state_push(app_view_state *s, const app_view_cam *c);
/* The entry holding the path's i-th frame (0: its first), i < path_frames. */
const app_view_cam *app_view_state_at(const app_view_state *s, uint32_t i);
/* The path emptied (the history restarts). */
void app_view_state_restart(app_view_state *s);
/* The frame's camera into a scene state (its view matrix and position; the projection stays). */
void app_view_camera_apply(const app_view_cam *c, tnd_scene_state *st);
void app_view_camera_from_state(const tnd_scene_state *st, uint32_t frame, app_view_cam *c);

/* render's and reference's options (app/cmd_render.c); the viewer fills them from its
 * settings, so that both build the same pipeline (app_pipeline_open). */
typedef struct app_render_opts {
    const char *scene, *frontend, *out, *precision, *rt_api, *denoiser, *dump, *pipeline;
    const char *taa, *tonemap, *exposure;
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
    app_env env;
    const app_view_state *view; /* --view FILE: its settings and camera path */
    const char *shard;          /* reference --shard I/N */
    double checkpoint_s;        /* reference: seconds between checkpoints of a frame's sums (0:
                                   after every run of samples); a frame done is one too */
    const char *resume;         /* reference --resume DIR: the interrupted run's own options and
                                   state (DIR/reference.partial.json), continued */
    unsigned timed_frames;      /* render: frames after the written ones, back to back, timed */
    bool quiet;                 /* no progress or messages (as --quiet, for this call only) */
} app_render_opts;
/* `tandem render` (reference: `tandem reference`) with these options: what the commands run
 * after parsing, and what the sweep and compare call. Options checked as the command line's;
 * returns the exit status. */
int app_render(const app_render_opts *o, bool reference);
/* A viewer state's settings over render's options (scene, front-end, denoiser and its
 * parameters, post chain, size, camera): the one converter from the viewer's settings. */
void app_view_state_options(const app_view_state *v, app_render_opts *o);
/* render's defaults (what the command line starts from). */
void app_render_defaults(app_render_opts *o);
/* The command line of those options (after "tandem", from "render" or "reference"): every option
 * that differs from the defaults, --out when set, --quiet when quiet; strings live in the struct
 * (for scripts that run tandem elsewhere: the sweep's Slurm jobs). */
typedef struct app_args {
    const char *v[96];
    int n;
    char buf[4096];
    size_t used;
} app_args;
tnd_result app_render_args(const app_render_opts *o, bool reference, app_args *a);
struct pl_frontend;
struct pl_chain;
struct cmp_desc;
/* The front-end and the chain as render builds them from its options (the post chain's settings
 * into *pd); *dn (o->denoiser's registry entry) becomes what runs: its fallback where the
 * front-end cannot re-shade (said on stderr). The parameters the denoiser has go to it. */
tnd_result app_pipeline_open(const app_render_opts *o, const tnd_scene *scene, tnd_vk *vk,
                             bool use_vk, bool use_dn, tnd_precision prec,
                             const pl_denoiser_info **dn, bool reference, struct pl_frontend **fr,
                             struct pl_chain **chain, struct cmp_desc *pd);
/* The frame loop's one frame, as render runs it (and the Python binding, the dataset): frame i
 * of the run (o->start + i): the scene's states (st[i & 1] the current; the previous evaluated
 * too when `first`), the viewer's camera, the front-end's frame. */
tnd_result app_frame_begin(const app_render_opts *o, const tnd_scene *scene,
                           struct pl_frontend *fr, tnd_scene_state st[2], unsigned i, bool first);
/* Its step through the chain (the front-end's bounces, the camera's jitter and spread, the
 * frame time; `reset`: the history restarts). */
pl_step app_frame_step(const app_render_opts *o, const tnd_scene_state *cur, unsigned i,
                       bool reset);
/* Samples [first, first + count) of the current frame's reference by o->estimator ("realtime":
 * the matched one, composited where o->composite_on says; else unbiased, o->ref_bounces) added
 * to the per-pixel sums (RGB, luminance^2); `frame`: scratch of the frame's size. */
tnd_result app_reference_add(struct pl_frontend *fr, const app_render_opts *o, unsigned f,
                             tnd_frame *frame, uint32_t first, uint32_t count, double *sum_rgb,
                             double *sum_lum2, tnd_ref_stats *rs,
                             void (*progress)(uint32_t, uint32_t, void *), void *user);
/* render's or reference's options checked (no --out needed): an error names the option. */
tnd_result app_render_check(const app_render_opts *o, bool reference);
/* A reference's --bounces (o->ref_bounces as given, ~0: none; half: realtime's 1) as its run
 * takes it: the realtime estimator's count in o->bounces (default 1), the unbiased path's cap in
 * o->ref_bounces (0: none). Once, after app_render_check. */
void app_reference_bounces(app_render_opts *o);
/* render's (or reference's) pipeline held open, frame by frame (app/session.c): what render
 * builds from the options, each frame as render's loop runs it. Frames are asked for by number
 * (o->start and o->view are not used): one that follows the frame before continues the history,
 * any other restarts it. */
typedef struct app_session app_session;
/* `scene`: one loaded already (the caller's, outliving the session; o->scene and o->env then
 * only name it), or NULL: loaded from o->scene with o->env. */
tnd_result app_session_open(const app_render_opts *o, bool reference, const tnd_scene *scene,
                            app_session **s);
void app_session_close(app_session *s);
const tnd_scene *app_session_scene(const app_session *s);
const app_render_opts *app_session_opts(const app_session *s);
/* the denoiser that runs (after a fallback; NULL for a reference session) */
const char *app_session_denoiser(const app_session *s);
/* its Vulkan context (NULL where the CPU composites) */
const tnd_vk *app_session_vk(const app_session *s);
/* Frame f: render's frame_NNNN.exr into rgb (3 floats per pixel), its PNG's pixels into display
 * (3 bytes per pixel; zeros where the CPU composites), the contract as the capture holds it into
 * `contract` (each optional). */
tnd_result app_session_frame(app_session *s, unsigned f, float *rgb, uint8_t *display,
                             tnd_frame *contract);
/* Frame f's reference (o->estimator, o->spp, o->until_noise): the mean into rgb and the variance
 * of one sample's luminance into variance (optional), as reference's EXR holds them. */
tnd_result app_session_reference(app_session *s, unsigned f, float *rgb, float *variance,
                                 tnd_ref_stats *stats);
/* "The other denoiser" of a comparison (the viewer's split): a denoiser's fallback, or the one
 * whose fallback it is, or the first that filters without gradient samples. */
const pl_denoiser_info *app_denoiser_other(const pl_denoiser_info *d);
/* One frame's times as timings.json entry members (", \"KEY\": MS" for each of the chain's
 * passes, and the `beside` flag after the pass that has it). */
void app_timings_members(FILE *f, const struct pl_chain *chain, const pl_step_result *r);
/* Remove a directory and the files in it (no subdirectories): an output left by a failed run. */
bool app_remove_flat_dir(const char *dir);
/* `tandem info --scene PATH --json`'s object, and `tandem info --pipeline --json`'s (malloc'd
 * text; NULL when out of memory) (app/cmd_info.c). */
char *app_scene_info_json(const char *path, const tnd_scene *s);
char *app_pipeline_json(void);
/* tandem info --capture DIR [--map M] [--json] (app/capture_info.c). */
int app_capture_info(const char *captures, const char *map_path, bool json);
/* --taa on|off|W (a new-frame weight in (0, 1]) into the post chain's description. */
struct cmp_desc;
tnd_result app_taa_parse(const char *taa, struct cmp_desc *d);
tnd_result app_write_dumps(struct dn_context *dn, uint32_t mask, const char *dir, const char *stem);
/* A frame's dumps as a pl_step's after_backend hook: user is an app_dump_ctx. */
typedef struct app_dump_ctx {
    uint32_t mask;
    const char *dir;
    char stem[1024];
} app_dump_ctx;
tnd_result app_dump_after_backend(struct dn_context *dn, void *user);
/* The median of v[0..n) (sorts v in place; 0 when n is 0). */
double app_median(double *v, unsigned n);
/* Device bandwidth (GB/s, bytes read + written) of a vkCmdCopyBuffer and of a compute copy of
 * `bytes` between device-local buffers: medians of `repeats` after a warm-up (app/bandwidth.c). */
tnd_result app_bandwidth(tnd_vk *vk, VkDeviceSize bytes, unsigned repeats, double *transfer_gbs,
                         double *compute_gbs);
/* A JSON document (cJSON *) as PATH, indented, ending in a newline, whole or not at all
 * (tnd_file_write_atomic); the caller keeps `json`. */
tnd_result app_json_write(const char *path, const void *json);
/* 8-bit sRGB RGB as PNG (written to PATH.tmp, then renamed: no partial file). */
tnd_result app_write_png(const char *path, const uint8_t *rgb8, uint32_t w, uint32_t h);
bool app_have_program(const char *prog);
/* DIR/video.mp4 from DIR/frame_NNNN.png, frames first .. first+count-1 (needs ffmpeg). */
tnd_result app_write_video(const char *dir, unsigned first, unsigned count, double fps);
tnd_result app_write_rgb_exr(const char *path, const float *rgb, uint32_t w, uint32_t h);
/* A preview PNG: exposure from the log-average luminance (key 0.18), Reinhard, sRGB. The
 * composite stage's tone mapping replaces it. */
tnd_result app_write_preview(const char *path, const float *rgb, uint32_t w, uint32_t h);

/* ---- evaluation (app/evaluate.c) ------------------------------------------------------------ */
#define APP_EVAL_MAX_SERIES 5
/* Error inside a region of the image (pixels the run's path flags mark: seen in a mirror, at
 * glass), over all frames: relMSE, mean FLIP, and sharpness = the sum of the tone-mapped image's
 * absolute forward differences inside the region over the reference's (below 1: blurrier than
 * the reference; noise makes it larger than 1), and bias = the region's mean linear luminance
 * over the reference's, minus 1 (what the estimator leaves out or adds). */
enum { APP_REGION_MIRROR, APP_REGION_GLASS, APP_REGIONS };
typedef struct app_region {
    uint64_t pixels, values, pairs;
    double rel_sq, flip, grad_out, grad_ref;
    double lum_out, lum_ref; /* bias = lum_out / lum_ref - 1 (linear luminance) */
} app_region;
/* A region's figures from its sums, and its name ("mirror", "glass"). */
typedef struct app_region_stats {
    double relmse, flip, sharpness, bias;
} app_region_stats;
app_region_stats app_region_summary(const app_region *r);
const char *app_region_name(int region);

/* What a series' frames are: a run's linear output, or its capture composited without
 * denoising (the noisy input), or the running mean of those composites, restarted wherever
 * anything moves on screen (a capture's motion not all zero) or a frame is missing: what
 * accumulation alone gives, the curve a denoiser must end at or below on a still camera. */
typedef enum app_series_kind {
    APP_SERIES_OUTPUT = 0,
    APP_SERIES_NOISY,
    APP_SERIES_ACCUMULATED,
} app_series_kind;

typedef struct app_eval_series {
    char name[64];
    char dir[1100];      /* where its frame_NNNN.exr are */
    app_series_kind kind; /* not OUTPUT: dir is a capture directory */
    ev_frame_metrics *m; /* per frame (app_eval_run) */
    ev_summary summary;
    app_region regions[APP_REGIONS];
    /* APP_SERIES_ACCUMULATED: the running sum (rgb per pixel), its frame count, the last frame
     * added (app_eval_run) */
    double *acc;
    size_t acc_len; /* doubles in acc */
    uint32_t acc_n, acc_frame, acc_starts; /* acc_starts: how often it (re)started */
    uint32_t restarts; /* APP_SERIES_ACCUMULATED: its restarts after the first frame in the run */
} app_eval_series;

typedef struct app_eval {
    char ref[1100];          /* the reference's frame_NNNN.exr */
    double exposure;         /* <= 0: from the reference (geometric mean luminance -> 0.18) */
    double ppd;              /* FLIP pixels per degree (<= 0: 67) */
    struct app_progress *progress; /* optional: stepped once per frame */
    uint32_t min_frame;      /* frames before it are left out (a warm-up) */
    char regions_from[1100]; /* captures whose path flags define the regions ("" : none) */
    bool resample;           /* series of another size are resampled to the reference's */
    const char *metrics_on;  /* "cpu", "device" (a Vulkan device), or NULL / "auto": the device
                                where one that is not a CPU implementation is present */
    /* filled by app_eval_run */
    bool auto_exposure;
    uint32_t *frames, count, width, height;
    app_eval_series series[APP_EVAL_MAX_SERIES];
    uint32_t nseries;
} app_eval;

/* frame numbers of DIR/frame_NNNN.exr, sorted */
tnd_result app_list_frames(const char *dir, uint32_t **frames, uint32_t *count);
/* A series: DIR's frames (the other kinds: DIR/capture's, composited). */
tnd_result app_eval_add(app_eval *e, const char *name, const char *dir, app_series_kind kind);
/* tandem bench --metrics (app/bench_metrics.c) */
tnd_result app_bench_metrics(const unsigned size[2], unsigned repeats, unsigned threads, bool json);
/* the frames of a sequence whose worth N by FLIP eval finds (evenly spread) */
#define APP_WORTH_FLIP_FRAMES 8
/* Metrics of every series on the frames they all share with the reference. */
tnd_result app_eval_run(app_eval *e);
/* DIR/metrics.json, metrics.csv, plots, images of the first, worst and last frames with crops,
 * and index.html. `settings`: JSON object text; `html`: extra section (may be NULL). */
tnd_result app_eval_report(app_eval *e, const char *dir, const char *title, const char *settings,
                           const char *html);
void app_eval_free(app_eval *e);
/* Convergence on a still camera: the first output series against the accumulated one (the
 * running mean of the noisy composites), by relMSE. `have`: both series exist; `still`: the
 * accumulation never restarted after the first frame (nothing moved); the means over the last
 * quarter of the frames (at least one); `converges`: the output's at or below accumulation
 * alone's. */
typedef struct app_convergence {
    bool have, still, converges;
    uint32_t output, accumulated; /* series indices */
    uint32_t restarts;
    double last_output, last_accumulated;
} app_convergence;
app_convergence app_eval_convergence(const app_eval *e);
/* The convergence as text lines (per-frame relMSE at frames 0, 1, 3, 7, ... and the last, the
 * verdict), each starting with `indent`; nothing without both series. */
void app_eval_convergence_text(const app_eval *e, const char *indent, ev_text *t);

/* A summary's metrics (the table's summarised ones, eval/table.c) as members of a JSON object,
 * as a text table's cells (" VALUE" each, in the table's formats) and their headers. */
struct cJSON;
void app_metrics_json(struct cJSON *o, const ev_summary *s);
void app_metrics_text(FILE *f, const ev_summary *s);
void app_metrics_header(FILE *f);

/* The regions of series i as JSON object text (malloc'd; NULL when none was measured), and as
 * an HTML table for the report (appended to t). */
char *app_eval_regions_json(const app_eval *e, uint32_t i);
void app_eval_regions_html(const app_eval *e, ev_text *t);

/* ---- references, their shards and merging them (app/reference.c) ------------------------- */
/* What a reference's own noise adds to a relMSE measured against it: the mean over pixels of
 * se^2 / (mean^2 + eps), from the luminance's standard error (eval's relMSE denominator). */
double app_ref_noise_relmse(const float *rgb, const float *lum_se, size_t n);
/* DIR/reference.json: the estimator and, per frame, the samples taken and the remaining noise. */
/* a reference frame's paths (pixels x samples) per second of sampling; 0 where not measured */
double app_ref_paths_per_s(const app_render_opts *o, const tnd_ref_stats *rs);
tnd_result app_ref_json_write(const app_render_opts *o, const char *device,
                              const tnd_ref_stats *rs, const double *noise);
/* Frame i of the path from its sums over rs->spp samples: the mean into rgb, rs->rel_error,
 * *noise, and DIR/frame_NNNN.exr (R, G, B and variance.Y, the variance of one sample's
 * luminance, which lum_se holds after) and .png. */
tnd_result app_ref_frame_finish(const app_render_opts *o, unsigned i, const double *sum_rgb,
                                const double *sum_lum2, float *rgb, float *lum_se,
                                tnd_ref_stats *rs, double *noise);
/* DIR/reference.partial.json, an unfinished reference's state (written whole, at its start, at
 * each checkpoint and frame, and when interrupted): its command line ("args"), the frames done
 * with their figures ("done": index, frame, spp, rel_error, noise_relmse, seconds), the frame
 * in progress ("at": index, seconds so far; its samples: DIR/frame_NNNN.sums) and the signal
 * that stopped it. tandem reference --resume DIR reads it back (the parsed JSON; its "args"
 * checked to be strings). */
tnd_result app_ref_partial_write(const app_render_opts *o, const bool *done,
                                 const tnd_ref_stats *rs, const double *noise, int at,
                                 double at_seconds, int signal);
struct cJSON;
tnd_result app_ref_partial_read(const char *dir, struct cJSON **out);
/* Part of a reference's work: samples [first, first + count) of frame `index` of the path. */
typedef struct app_shard_part {
    uint32_t index, first, count;
} app_shard_part;
/* --shard I/N */
tnd_result app_shard_parse(const char *text, uint32_t *shard, uint32_t *shards);
/* Shard `shard` of `shards` over frames x spp samples (parts: room for `frames`): whole frames
 * while there are at least as many frames as shards, otherwise even runs of batches of
 * TND_REF_CHECK_EVERY samples (frame by frame), so that shards add up as one run does. */
tnd_result app_shard_plan(uint32_t frames, uint32_t spp, uint32_t shard, uint32_t shards,
                          app_shard_part *parts, uint32_t *count);
/* DIR/frame_NNNN.sums read back: its header checked against the size and frame, its first
 * sample and count out, the sums (RGB per pixel, then luminance^2) into sums (4 per pixel). */
tnd_result app_shard_sums_read(const char *dir, uint32_t w, uint32_t h, uint32_t frame,
                               uint32_t *first, uint32_t *samples, double *sums);
/* DIR/frame_NNNN.sums: one part's per-pixel sums (written whole or not at all). */
tnd_result app_shard_sums_write(const char *dir, uint32_t w, uint32_t h, uint32_t frame,
                                uint32_t first, uint32_t samples, const double *sum_rgb,
                                const double *sum_lum2);
/* DIR/shard.json: the settings the shard belongs to and its parts (samples taken: taken[k]). */
tnd_result app_shard_json_write(const app_render_opts *o, const char *device, uint64_t digest,
                                uint32_t shard, uint32_t shards, const app_shard_part *parts,
                                const uint32_t *taken, uint32_t count);

/* ---- commands ------------------------------------------------------------------------------- */
int cmd_info(int argc, char **argv);
int cmd_contract(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_view(int argc, char **argv);
int cmd_reference(int argc, char **argv);
int cmd_bench(int argc, char **argv);
int cmd_compare(int argc, char **argv);
int cmd_denoise(int argc, char **argv);
int cmd_convert(int argc, char **argv);
int cmd_eval(int argc, char **argv);
int cmd_merge(int argc, char **argv);
int cmd_dataset(int argc, char **argv);
/* `tandem bench --sweep` and `tandem sweep collect` (app/cmd_sweep.c) */
/* emit: NULL (run here) or "slurm" (write DIR/slurm/ with the unbiased reference in `shards`
 * shards); DIR/sweep-plan.json either way. */
/* env: the scene options every job loads the scene with (bench's --env, --camera-path, ...). */
int app_sweep(const app_list *sweeps, const char *scene, const app_env *env, const char *out,
              const char *reference, unsigned spp, const unsigned size[2], unsigned frames,
              unsigned warmup, unsigned timed, const char *emit, unsigned shards);
int cmd_sweep(int argc, char **argv);
/* `tandem bench --soak N` (app/soak.c): N frames through render's frame loop per front-end and
 * denoiser (one of each when named), host RSS, open descriptors and device memory sampled; a
 * table, or JSON with every sample. */
int app_soak(const char *scene, const app_env *env, const unsigned size[2], unsigned frames,
             const char *frontend, const char *denoiser, bool json);
/* The soak recorder (app/soak.c), for any frame loop (bench's, the viewer's): begin with the
 * frames planned, call _frame after each (it samples every frames/200-th and the last), _end
 * judges (true: flat after the warm-up), _json is a cJSON object of the figures and samples,
 * _print a table row (with its header when `title`). */
typedef struct app_soak_rec app_soak_rec;
app_soak_rec *app_soak_rec_begin(uint32_t frames);
void app_soak_rec_frame(app_soak_rec *r, uint32_t f, bool last, const tnd_vk *vk);
bool app_soak_rec_end(app_soak_rec *r, uint32_t frames, const char *frontend,
                      const char *denoiser);
void *app_soak_rec_json(const app_soak_rec *r);
void app_soak_rec_print(const app_soak_rec *r, const char *title, const char *scene,
                        const unsigned size[2]);
void app_soak_rec_free(app_soak_rec *r);
/* `tandem bench --extremes` (app/cmd_extremes.c) */
int app_extremes(const char *scene, const char *out, const unsigned size[2], unsigned frames);

#endif
