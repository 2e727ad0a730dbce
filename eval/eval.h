/* eval: image metrics against a converged reference (relMSE, SMAPE, RMSE on linear radiance;
 * PSNR, SSIM and LDR-FLIP on the tone-mapped sRGB image; temporal error and lag over a
 * sequence), and the report (metrics.json, metrics.csv, a static HTML page with PNGs and SVG
 * plots). docs/metrics.md gives every definition. Prefix ev_; depends on core/. */
#ifndef EV_EVAL_H
#define EV_EVAL_H

#include "core/core.h"

#define EV_RELMSE_EPS 0.01   /* relMSE denominator r^2 + eps */
#define EV_SMAPE_EPS 0.01    /* SMAPE denominator |o| + |r| + eps */
#define EV_FLIP_PPD 67.0206  /* 0.7 m wide 3840-pixel monitor seen from 0.7 m */

/* ---- images ---------------------------------------------------------------------------- */
typedef struct ev_image {
    uint32_t width, height;
    float *rgb; /* 3 floats per pixel, row-major, top row first */
    float *var; /* a reference's: the variance of one sample's luminance per pixel (its EXR's
                   `variance.Y`, written by tandem reference); NULL when the file has none */
} ev_image;

tnd_result ev_image_alloc(uint32_t width, uint32_t height, ev_image *img);
void ev_image_free(ev_image *img);
/* Linear RGB EXR (channels R, G, B, and `variance.Y` into var where present; A and others
 * ignored). Missing channels: an error naming the file and the channel. */
tnd_result ev_image_read_exr(const char *path, ev_image *img);
/* Bilinear resampling to w x h (pixel centres aligned): a run at a reduced resolution scale
 * compared with a full-size reference. */
tnd_result ev_image_resize(const ev_image *in, uint32_t w, uint32_t h, ev_image *out);
/* Non-finite values replaced by 0; returns how many there were. */
uint64_t ev_image_sanitize(ev_image *img);

/* ---- tone mapping (the display image the LDR metrics see) ------------------------------- */
/* Exposure that maps the geometric-mean luminance (0.2126, 0.7152, 0.0722; floor 1e-4) of the
 * given images to 0.18. */
double ev_auto_exposure(const ev_image *imgs, uint32_t count);
/* out = sRGB(ACES fit(exposure x in)), in [0, 1] (3 floats per pixel). */
void ev_tonemap(const ev_image *in, double exposure, float *out);

/* ---- per-image metrics ------------------------------------------------------------------ */
double ev_mse(const float *o, const float *r, size_t n);           /* n floats */
double ev_relmse(const float *o, const float *r, size_t n);
double ev_smape(const float *o, const float *r, size_t n);
double ev_psnr(double mse); /* peak 1; 100 dB at most (MSE floored at 1e-10) */
/* Mean SSIM over the three channels of two [0,1] images (11x11 Gaussian window, sigma 1.5, C1 =
 * 0.01^2, C2 = 0.03^2, windows that fit inside the image). Needs width, height >= 11. */
tnd_result ev_ssim(const float *o, const float *r, uint32_t w, uint32_t h, double *ssim);
/* (SSIM by the scalar double-precision code that the vectorised one is checked against) */
tnd_result ev_ssim_reference(const float *o, const float *r, uint32_t w, uint32_t h, double *ssim);
/* The metrics' scalar code (the separable filters summed in double per output, one pixel at a
 * time), kept as the reference the vectorised code is checked against (tests/test_eval.c): on
 * for every metric until turned off. Not thread-safe; a test's switch. */
void ev_metrics_reference(bool on);
/* LDR-FLIP (Andersson et al. 2020) of two sRGB [0,1] images at `ppd` pixels per degree: the
 * per-pixel error map in `map` (w x h floats, may be NULL) and its mean. */
tnd_result ev_flip(const float *ref, const float *test, uint32_t w, uint32_t h, double ppd,
                   float *map, double *mean);

/* FLIP's and SSIM's kernels for the device metrics (shaders/ev_metrics.comp's table: the 4
 * contrast-sensitivity Gaussians, their 4 weights, the edge, point and smoothing kernels, SSIM's
 * 11 taps), their radii and FLIP's c_max, into `table` (at most `cap` floats). */
tnd_result ev_flip_kernels(double ppd, float *table, size_t cap, int *rc, int *rf, double *cmax);

/* ---- the metrics on the device (eval/metrics_gpu.c) --------------------------------------
 * relMSE, SMAPE, RMSE, PSNR, SSIM and FLIP of one frame, as ev_sequence_add computes them on
 * the CPU (the same definitions, in float on the GPU: within 1e-4 of the CPU's,
 * tests/test_eval_gpu.c), for frames of a fixed size. */
typedef struct ev_gpu ev_gpu;
typedef struct ev_gpu_metrics {
    double relmse, smape, rmse, psnr, ssim, flip;
    double gpu_ms;     /* the four passes' GPU time */
    double pass_ms[4]; /* each pass's: prep, rows, columns, reduce */
} ev_gpu_metrics;
tnd_result ev_gpu_create(tnd_vk *vk, uint32_t width, uint32_t height, double ppd, ev_gpu **out);
void ev_gpu_destroy(ev_gpu *g);
/* The metrics of `out` against `ref` (linear RGB, sanitised, the size given), tone mapped by
 * `exposure`; flip_map (optional): the per-pixel FLIP. */
tnd_result ev_gpu_frame(ev_gpu *g, const ev_image *out, const ev_image *ref, double exposure,
                        ev_gpu_metrics *m, float *flip_map);

/* ---- sequences -------------------------------------------------------------------------- */
typedef struct ev_frame_metrics {
    uint32_t frame;
    double relmse, smape, rmse, psnr, ssim, flip;
    double temporal;    /* vs the previous frame of the sequence; < 0 for the first */
    /* with the reference's motion (ev_sequence_motion): the frame-to-frame change after warping
     * the previous frame along the motion, over pixels visible in both frames, against the
     * reference's (< 0: no motion or the first frame); the fraction of pixels disoccluded */
    double mc_temporal, disoccluded;
    uint64_t nonfinite; /* NaN/Inf values in the output (counted as 0 in the metrics) */
    /* "worth N samples" (a reference with its per-pixel variance; < 0: none): the samples per
     * pixel whose plain average would have the output's error, by luminance relMSE and by FLIP
     * (ev_worth_flip; only on the frames asked for, ev_sequence_worth_flip) */
    double worth_relmse, worth_flip;
} ev_frame_metrics;

typedef struct ev_summary {
    double relmse, smape, rmse, psnr, ssim, flip, temporal; /* means over frames */
    double lag;          /* mean lag over the lighting changes, frames; < 0: none measured */
    uint32_t changes;    /* lighting changes found in the reference */
    /* with the reference's motion: the mean motion-compensated temporal error; flicker: the mean
     * over pixels static through the sequence of the temporal standard deviation of the
     * tone-mapped luminance, the output's and the reference's (< 0: none); the mean lag after
     * a disocclusion (frames until the disoccluded pixels' error is back to the rest's) over
     * `disocclusions` events (< 0: none) */
    double mc_temporal, flicker, flicker_ref, disocclusion_lag;
    uint32_t disocclusions;
    uint64_t static_pixels;
    uint64_t nonfinite;
    /* worth N samples over the sequence (< 0: none): by relMSE, the N whose mean luminance
     * relMSE over the frames equals the output's (sum of the variance terms over the sum of the
     * errors); by FLIP, the geometric mean of the frames' */
    double worth_relmse, worth_flip;
} ev_summary;

/* A sequence evaluated frame by frame (no frame kept but the previous one): `exposure` is the
 * tone mapping's scale for PSNR/SSIM/FLIP/temporal, the same for every frame. */
typedef struct ev_sequence ev_sequence;
tnd_result ev_sequence_create(uint32_t width, uint32_t height, double exposure, double ppd,
                              ev_sequence **seq);
void ev_sequence_destroy(ev_sequence *seq);
/* The next frame (sanitised images, same size): its metrics, and its FLIP map (w x h floats)
 * when flip_map is not NULL. */
tnd_result ev_sequence_add(ev_sequence *seq, uint32_t frame, const ev_image *out,
                           const ev_image *ref, ev_frame_metrics *m, float *flip_map);
/* Per-image metrics (relMSE, SMAPE, RMSE, PSNR, SSIM, FLIP and its map) from the device from
 * the next frame on (NULL: the CPU's); `g` of the sequence's size, outliving the use. */
void ev_sequence_gpu(ev_sequence *seq, ev_gpu *g);
/* Whether the next ev_sequence_add also finds the frame's worth by FLIP (a search of about ten
 * FLIP evaluations; the relMSE worth is always found where the reference has its variance). */
void ev_sequence_worth_flip(ev_sequence *seq, bool on);
/* The model of a plain average of n samples of the reference's estimator behind worth N by
 * FLIP: one sample is Y_r / p with probability p = Y_r^2 / (Y_r^2 + var), else 0 (mean Y_r,
 * variance var: the spikiest distribution of them, as a path tracer's rare bright paths are),
 * so n of them average to Y_r K / (n p), K binomial (n, p), drawn by its inverse CDF at one
 * uniform per pixel and frame (the same for every n, so the error falls with n); the pixel's
 * colour is the reference's. Into rgb (3 floats per pixel). */
void ev_worth_model(const ev_image *ref, double n, uint32_t frame, float *rgb);
/* Worth N samples by FLIP: the N for which ev_worth_model's average of N samples has `flip`
 * against the reference (tr: the reference tone-mapped by `exposure`; scratch: 6 floats per
 * pixel). Searched over N in [1/16, 2^24] (log scale, 10 halvings); returns the bound where it
 * lies beyond. A model: a real 1-spp frame of `cornell` measures 2 samples by it (its samples
 * are less spiky), a 16-sample plain average 23 where relMSE says 29 (docs/metrics.md). */
tnd_result ev_worth_flip(const ev_image *ref, const float *tr, double exposure, double ppd,
                         double flip, uint32_t frame, float *scratch, double *n);
/* The reference's motion (3 floats per pixel: previous minus current position in pixels, depth
 * change) and depth (1 float per pixel, TND_DEPTH_MISS on a miss) of the frame ev_sequence_add
 * takes next: the motion-compensated metrics (docs/metrics.md). Copied. */
void ev_sequence_motion(ev_sequence *seq, const float *motion, const float *depth);
/* The disocclusion lag's settings: an event is a frame with disoccluded pixels; it settles at the
 * first frame k (0 ..) where their mean |Y_o - Y_r| is at most EV_DISOCC_RATIO x the other
 * visible pixels' + EV_DISOCC_ABS, or counts EV_DISOCC_FRAMES. */
#define EV_DISOCC_FRAMES 16
#define EV_DISOCC_RATIO 1.25
#define EV_DISOCC_ABS 0.002
/* The last frame's tone-mapped output and reference (3 floats per pixel, valid until the next
 * ev_sequence_add). */
void ev_sequence_display(const ev_sequence *seq, const float **out, const float **ref);
/* Means over the frames so far, and the lag (nonfinite is left 0 for the caller). */
void ev_sequence_summary(const ev_sequence *seq, ev_summary *s);
/* Lighting changes: frames t whose reference mean luminance differs from frame t-1's by more
 * than 20%. The lag of a change is the number of frames from t until the output's mean
 * absolute luminance error is back within 10% of the change's size above the error before the
 * change (docs/metrics.md). */
uint32_t ev_lag(const ev_image *out, const ev_image *ref, uint32_t count, double *mean_lag);

/* ---- the metrics, one table (eval/table.c) --------------------------------------------------
 * metrics.json and metrics.csv, the report's table and plots, the viewer's curves, and the
 * summaries of tandem eval, compare and the sweep are all made from it; a new metric is a row
 * there and its field in ev_frame_metrics / ev_summary. */
typedef struct ev_metric {
    const char *name;  /* the key in metrics.json, metrics.csv, sweep.json; plot_NAME.svg */
    const char *head;  /* the report's table header and text tables: "relMSE" */
    const char *title; /* its plot's title (with which way is better) */
    const char *fmt;   /* the text tables' printf format, with its width */
    size_t frame;      /* the offset of its double in ev_frame_metrics */
    long summary;      /* in ev_summary; -1: per frame only */
    bool optional;     /* a value < 0 means none (the first frame's temporal; no motion): null */
    bool plotted;      /* a plot per frame in the report */
    bool summarised;   /* in the commands' summaries (eval, compare, the sweep) */
    bool watched;      /* a curve in the report you can watch (viewer.html) */
} ev_metric;
uint32_t ev_metric_count(void);
const ev_metric *ev_metric_at(uint32_t i);
const ev_metric *ev_metric_find(const char *name);
/* A metric's value in a frame's metrics, or in a summary (-1 where it has no mean). */
double ev_metric_frame(const ev_metric *m, const ev_frame_metrics *f);
double ev_metric_summary(const ev_metric *m, const ev_summary *s);
/* none for this value: an optional metric's negative */
bool ev_metric_none(const ev_metric *m, double v);

/* ---- outputs ---------------------------------------------------------------------------- */
typedef struct ev_series {
    const char *name;          /* "denoised", "noisy", "embree", ... */
    const ev_frame_metrics *m; /* `count` frames (ev_report's / ev_write_metrics' count) */
    ev_summary summary;
    const char *regions;       /* JSON object text for metrics.json's "regions" (may be NULL) */
} ev_series;

/* DIR/metrics.json ({"settings": ..., "series": [{"name", "summary", "frames": [...]}]}) and
 * DIR/metrics.csv (one row per series and frame, then one "mean" row per series). `settings`:
 * JSON object text (may be NULL). Written under temporary names, then renamed. */
tnd_result ev_write_metrics(const char *dir, const ev_series *s, uint32_t nseries, uint32_t count,
                            const char *settings);

/* Images for the report. */
tnd_result ev_write_png(const char *path, const float *rgb01, uint32_t w, uint32_t h);
/* The FLIP map in a perceptually ordered colour map (black - purple - orange - pale yellow). */
void ev_colormap(const float *err, size_t n, float *rgb01);

/* Line plot of one metric per frame, one line per series (SVG, self-contained). metric:
 * "relmse", "smape", "rmse", "psnr", "ssim", "flip" or "temporal". */
tnd_result ev_plot_metric(const char *path, const char *metric, const ev_series *s,
                          uint32_t nseries, uint32_t count);
/* Scatter plot of (x, y) points with labels; points on the lower-left Pareto front joined and
 * highlighted (pareto[i] true). Log-scaled axes when log_x / log_y. */
tnd_result ev_plot_pareto(const char *path, const char *title, const char *xlabel,
                          const char *ylabel, const double *x, const double *y,
                          const char *const *labels, const bool *pareto, uint32_t n, bool log_x,
                          bool log_y);
/* pareto[i] = no other point is at least as good on both axes and better on one (lower is
 * better on both). */
void ev_pareto(const double *x, const double *y, uint32_t n, bool *pareto);

typedef struct ev_panel {
    const char *caption;
    char file[128];         /* relative to the report directory */
    uint32_t display_width; /* CSS pixels (small images are shown enlarged); 0: natural */
} ev_panel;

/* A report row's panels at most: the reference and three per series (the image, its difference
 * and its FLIP map) for up to 10 series. */
#define EV_ROW_PANELS 31
typedef struct ev_row {
    char title[160];
    ev_panel panels[EV_ROW_PANELS];
    uint32_t count;
} ev_row;

typedef struct ev_report {
    const char *dir, *title;
    const char *settings;       /* JSON text shown as it is (may be NULL) */
    const ev_series *series;    /* summary table (may be NULL) */
    uint32_t nseries;
    const char *const *plots;   /* SVG files in dir */
    uint32_t nplots;
    const ev_row *rows;         /* image rows (side by side, crops) */
    uint32_t nrows;
    const char *html;           /* extra HTML inserted after the summary (may be NULL) */
} ev_report;

/* DIR/index.html: works offline from the file system; its script marks <body data-status="ok">
 * once every image has loaded (data-images: how many), "error" otherwise (headless checks). */
tnd_result ev_report_write(const ev_report *r);
/* The report you can watch (REPORT/viewer.html, eval/viewer.c): its page and script; one frame's
 * images (n linear RGB images of w x h, downscaled by ev_viewer_scale to at most
 * EV_VIEWER_MAX_SIZE a side) as RGBE PNG data URIs in a script calling TND_FRAME(index, [...]). */
#define EV_VIEWER_MAX_SIZE 640
tnd_result ev_viewer_assets(const char *dir);
uint32_t ev_viewer_scale(uint32_t w, uint32_t h);
tnd_result ev_viewer_frame(const char *path, uint32_t index, const float *const *hdr, uint32_t n,
                           uint32_t w, uint32_t h);
/* Text with <, >, & and quotes escaped, appended to a growing buffer. */
typedef struct ev_text {
    char *s;
    size_t len, cap;
    bool failed;
} ev_text;
void ev_text_add(ev_text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
void ev_text_escaped(ev_text *t, const char *raw);
void ev_text_free(ev_text *t);

#endif
