/* run/rn_internal.h: what the run layer's files share and nobody else sees. */
#ifndef TND_RN_INTERNAL_H
#define TND_RN_INTERNAL_H

#include "run/run.h"
#include "composite/composite.h"
#include "denoise/denoise.h"

/* A quiet run keeps the core's information lines quiet too (its log level at least WARN) for as
 * long as it lasts: rn_quiet_begin returns the level to put back with rn_quiet_end. */
tnd_log_level rn_quiet_begin(bool quiet);
void rn_quiet_end(tnd_log_level was);

/* ---- a reference's samples (run/rn_reference.c), for its frame loop (run/rn_render.c) ---- */
/* A reference's progress in samples: the bar and the samples taken before the current part. */
typedef struct rn_ref_progress {
    rn_progress *bar;
    uint64_t base;
} rn_ref_progress;
/* rn_reference_add's progress callback: user is an rn_ref_progress. */
void rn_ref_on_progress(uint32_t done, uint32_t total, void *user);
/* A reference frame's checkpoints: its sums (DIR/frame_NNNN.sums) and the run's state
 * (reference.partial.json) when o->checkpoint_s have passed since the last, or when
 * interrupted. */
typedef struct rn_ref_checkpoint {
    bool on;                     /* (not for shards, which write their sums as their output) */
    const rn_render_opts *given; /* the options as given (its command line, to resume with) */
    const bool *finished;        /* the frames done */
    const double *noise;
    const tnd_ref_stats *all;
    unsigned index;     /* the frame's */
    double before;      /* its sampling seconds in runs before this one */
    double start, last; /* when its sampling began here; the last checkpoint */
} rn_ref_checkpoint;
/* Samples [from, end) of frame f (a part of a reference) into the sums (RGB, then luminance^2)
 * in runs of whole batches of TND_REF_CHECK_EVERY samples, each run about a second (the sums are
 * those of one call: the front-ends add ranges split at multiples of TND_REF_CHECK_EVERY as the
 * whole), and between runs: the noise target (--until-noise, as inside a run), an interrupt (h),
 * a checkpoint due. rs->spp: the samples the sums hold; *stopped: interrupted before `end`. */
tnd_result rn_ref_sample_frame(pl_frontend *fr, const rn_render_opts *o, unsigned f,
                               tnd_frame *frame, uint32_t from, uint32_t end, double *sums,
                               tnd_ref_stats *rs, rn_ref_progress *rp, rn_ref_checkpoint *cp,
                               const rn_host *h, bool *stopped);
/* REFDIR/frame_NNNN.motion.exr: the frame's motion and depth at the pixel centres (the primary
 * pass without jitter), for eval's motion-compensated metrics. */
tnd_result rn_ref_write_motion(pl_frontend *fr, const rn_render_opts *o, unsigned f,
                               tnd_frame *frame);

/* ---- JSON files that list sequences (run/rn_spec.c): the dataset's spec, the rank's suite ---- */
struct cJSON;
/* A member of o as a whole number in [lo, hi], a string, a number: true when absent (v kept) or
 * of that kind, false otherwise. */
bool rn_json_uint(const struct cJSON *o, const char *k, unsigned *v, unsigned lo, unsigned hi);
bool rn_json_str(const struct cJSON *o, const char *k, const char **v);
bool rn_json_num(const struct cJSON *o, const char *k, double *v);
/* A sequence's scene options (RN_SPEC_SCENE_KEYS: strings scene, camera_path, env, up; numbers
 * path_duration, path_radius, path_height, env_intensity, env_rotation, camera; no_default_light
 * true or false) from q into o (strings point into q); false when one is of another kind. */
#define RN_SPEC_SCENE_KEYS                                                                         \
    "scene", "camera_path", "path_duration", "path_radius", "path_height", "env",                 \
        "env_intensity", "env_rotation", "up", "camera", "no_default_light"
bool rn_spec_scene_options(const struct cJSON *q, rn_render_opts *o);

/* ---- Slurm jobs (run/rn_slurm.c): the sweep's and the rank's ---------------------------------- */
/* One shell word: 'text' with each ' written as '\'' */
void rn_sh_word(FILE *f, const char *s);
/* TANDEM and the words of a, each a shell word, then `extra` as it is */
void rn_sh_command(FILE *f, const char *tandem, const rn_args *a, const char *extra);
/* The environment every task starts with (`by`: "tandem bench", "tandem rank"): its GPU (the
 * first Slurm gave it, by index: Vulkan does not read CUDA_VISIBLE_DEVICES; docs/cluster.md)
 * and its CPUs. */
void rn_sh_preamble(FILE *f, const char *by, const char *what, const char *name, int array);
/* the running tandem's path (/proc/self/exe) */
tnd_result rn_tandem_binary(char *out, size_t cap);

/* ---- a reference's own noise (run/rn_evaluate.c) ------------------------------------------------ */
/* The mean over e's frames of REFDIR/reference.json's noise_relmse (the relMSE its noise adds to
 * one measured against it); < 0 when unknown. */
double rn_reference_noise(const char *refdir, const rn_eval *e);
/* The rule for a reference good enough to judge by: its noise under a tenth of the relMSE
 * measured against it; a warning (through h) with both figures otherwise. */
void rn_warn_noise(const char *refdir, double noise, double measured, const char *what,
                   const rn_host *h);

#endif
