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
#include "run/run.h"

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
    APP_OPT_BOUNCES,  /* unsigned: a count, or "half" (RN_BOUNCES_HALF) */
} app_opt_kind;

/* `--bounces half`: one indirect bounce at half resolution (pl_params.half_indirect); commands
 * turn it into a count of 1 and the flag (rn_bounces_split) before anything reads the count. */
#define RN_BOUNCES_HALF 0xfffffffeu
/* A --bounces word: a count (0 to max) or "half" (RN_BOUNCES_HALF); false for any other. */
bool rn_bounces_parse(const char *v, unsigned max, unsigned *value);
/* A --bounces value as its count (half: 1) and *half. */
unsigned rn_bounces_split(unsigned value, bool *half);

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

/* Interrupts (SIGINT, SIGTERM): the command line catches them (app_interrupts_install, once in
 * main; a second signal ends the process); long loops ask app_interrupted() between frames or
 * batches of samples, finish what is in flight, write where they stopped and exit with
 * app_interrupt_status() (128 + the signal: 130 for SIGINT, 143 for SIGTERM). */
void app_interrupts_install(void);
int app_interrupted(void); /* the signal, or 0 */
int app_interrupt_status(void);
/* The registered denoisers' parameters as options (pl_param: --NAME VALUE), after `base` (its
 * entries up to the terminator) into `out` (room for cap entries, terminated); their values land
 * in vals (PL_PARAMS_MAX doubles, NaN until given). Returns false when out is too small. */
bool app_opts_with_params(const app_opt *base, app_opt *out, size_t cap, double *vals);
/* The values given into a parameter set (checked against each parameter's range). */
tnd_result app_params_collect(const double *vals, pl_param_set *set);

/* Report a failure of a library call: "tandem: <what>: <detail>" on stderr. Returns 1. */
int app_report(const char *what, tnd_result r);
/* The command line as the run layer's host (app/host.c): lines on stderr, the progress bar,
 * SIGINT and SIGTERM; quiet as --quiet is. */
rn_host app_host(void);
/* A run's result as the exit status: 0, the interrupt's (128 + the signal; the run said where it
 * stopped), or 1 with the failure reported as app_report does. */
int app_finish(const char *what, tnd_result r);

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

/* ---- progress bar on stderr (silent when stderr is not a terminal or with --quiet) ---------- */
typedef struct app_progress {
    const char *label;
    unsigned total, done;
    double start, last_draw;
    bool enabled;
} app_progress;
void app_progress_begin(app_progress *p, const char *label, unsigned total);
void app_progress_step(app_progress *p, unsigned done);
void app_progress_end(app_progress *p);

/* tandem info --capture DIR [--map M] [--json] (app/capture_info.c). */
int app_capture_info(const char *captures, const char *map_path, bool json);

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
int cmd_rank(int argc, char **argv);
/* `tandem bench --sweep` (app/cmd_sweep.c): usage errors said as bench's, then run; the exit
 * status. */
int app_sweep(const rn_sweep_opts *o);
int cmd_sweep(int argc, char **argv);
/* tandem bench --metrics (app/bench_metrics.c) */
tnd_result app_bench_metrics(const unsigned size[2], unsigned repeats, unsigned threads, bool json);
/* tandem bench --whole-frame and --overlap (o->with_host; app/bench_whole_frame.c): the run
 * layer's rn_whole_frame as a table or JSON on stdout. */
tnd_result app_bench_whole_frame(const rn_whole_frame_opts *o, bool json);
/* A soak run's figures as a table row on stdout (with its header when `title`). */
void app_soak_print(const rn_soak_rec *rec, const char *title, const char *scene,
                    const unsigned size[2]);
/* A summary's metrics as a text table's cells (" VALUE" each, in the table's formats) and their
 * headers (eval/table.c). */
void app_metrics_text(FILE *f, const ev_summary *s);
void app_metrics_header(FILE *f);

#endif
