/* pipeline/pl_replay.c: capture replay as a front-end. A sequence of EXR captures (Tandem's, or
 * another renderer's through a mapping) fills the contract frame by frame in host memory; it
 * cannot trace, but when the captures keep A-SVGF's gradient samples its "re-shading" patches
 * the stored samples in, after checking that the back-end selected the same pixels. Frame i of
 * the sequence is set with pl_frontend_set_frame(fe, NULL, NULL, i, 0, 0).
 * Entry point: pl_replay_ops (registered by pl_frontend.c). */
#include "pipeline/pl_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

typedef struct replay {
    const tnd_capture_map *map;
    char dir[1100];
    char **names;
    size_t count;
    uint32_t index;       /* the frame set_frame chose */
    tnd_frame first;      /* frame 0, read at creation (its size, entries and gradients) */
    uint32_t width, height;
    tnd_precision precision;
    bool split;           /* frame 0 splits pixels into checkerboard fields */
    bool present[TND_CT_COUNT]; /* frame 0's entries: every frame must carry them */
    bool first_used;      /* (handed to the first render) */
    bool gradients;       /* frame 0 keeps gradient samples: the replay re-shades */
    tnd_camera_state prev_cam;
    bool have_prev;
    char path[2300];      /* the current frame's file */
    tnd_gradient_samples gs;
} replay;

static tnd_result read_frame(replay *r, uint32_t i, tnd_frame *f)
{
    snprintf(r->path, sizeof r->path, "%s/%s", r->dir, r->names[i]);
    return r->map ? tnd_capture_read_mapped(r->path, r->map, i && r->have_prev ? &r->prev_cam : NULL,
                                            f)
                  : tnd_capture_read(r->path, f);
}

static tnd_result rp_create(const tnd_scene *scene, const pl_frontend_desc *d, void **out)
{
    (void)scene;
    if (!d->captures)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: replay needs a capture directory");
    replay *r = calloc(1, sizeof *r);
    if (!r)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
    r->map = d->map;
    tnd_capture_dir(d->captures, r->dir, sizeof r->dir);
    tnd_result res = tnd_capture_map_list(r->map, r->dir, &r->names, &r->count);
    if (res == TND_OK)
        res = read_frame(r, 0, &r->first);
    r->gradients = res == TND_OK && r->first.gradients;
    if (res == TND_OK) {
        const tnd_frame *f = &r->first;
        r->width = f->width, r->height = f->height, r->precision = f->precision;
        memcpy(r->present, f->present, sizeof r->present);
        for (size_t q = 0; f->present[TND_CT_PATH] && q < (size_t)f->width * f->height; q++)
            r->split |= (tnd_frame_u(f, TND_CT_PATH)[q] & TND_PATH_SPLIT) != 0;
    }
    if (res != TND_OK) {
        tnd_capture_list_free(r->names, r->count);
        free(r);
        return res;
    }
    *out = r;
    return TND_OK;
}

static void rp_destroy(void *ctx)
{
    replay *r = ctx;
    if (!r)
        return;
    tnd_frame_destroy(&r->first);
    tnd_gradient_samples_free(&r->gs);
    tnd_capture_list_free(r->names, r->count);
    free(r);
}

static void rp_describe(const void *ctx, char *buf, size_t cap)
{
    const replay *r = ctx;
    snprintf(buf, cap, "capture replay of %s (%zu frames%s%s)", r->dir, r->count,
             r->map ? ", mapping " : "", r->map ? tnd_capture_map_name(r->map) : "");
}

static const char *rp_models(const void *ctx)
{
    (void)ctx;
    return "a recorded contract";
}

static tnd_result rp_set_frame(void *ctx, const tnd_scene_state *cur, const tnd_scene_state *prev,
                               uint32_t frame, uint32_t w, uint32_t h)
{
    (void)cur, (void)prev, (void)w, (void)h;
    replay *r = ctx;
    if (frame >= r->count)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: %s holds %zu frames, not %u", r->dir,
                        r->count, frame + 1);
    r->index = frame;
    return TND_OK;
}

/* host: destroyed or zeroed; it receives the frame (the caller destroys it) */
static tnd_result rp_render(void *ctx, const pl_params *p, tnd_frame *host, pl_timings *t)
{
    (void)p;
    replay *r = ctx;
    if (!host)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: replay fills a host frame");
    double t0 = tnd_now();
    tnd_result res = TND_OK;
    if (r->index == 0 && !r->first_used) { /* (read at creation) */
        *host = r->first;
        memset(&r->first, 0, sizeof r->first);
        r->first_used = true;
        snprintf(r->path, sizeof r->path, "%s/%s", r->dir, r->names[0]);
    } else {
        TND_TRY(read_frame(r, r->index, host));
        if (host->width != r->width || host->height != r->height) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "capture: %s: %ux%u, the sequence's first frame "
                           "is %ux%u", r->path, host->width, host->height, r->width, r->height);
            goto fail;
        }
        tnd_frame first = {.width = r->width, .height = r->height};
        memcpy(first.present, r->present, sizeof first.present);
        TND_TRY(tnd_capture_check_entries(&first, host, r->path));
    }
    if (t)
        *t = (pl_timings){1e3 * (tnd_now() - t0), 0.0, 0.0, 0.0};
    r->prev_cam = host->camera;
    r->have_prev = true;
fail:
    return res;
}

static const tnd_contract_gpu *rp_contract(const void *ctx)
{
    (void)ctx;
    return NULL;
}

/* The stored samples of this frame, patched in where the back-end selected the same pixels. */
static tnd_result rp_reshade(void *ctx, const pl_params *p, const uint32_t *words, uint32_t n,
                             tnd_frame *host, pl_timings *t)
{
    (void)p, (void)t;
    replay *r = ctx;
    char gpath[2400];
    tnd_gradient_samples_free(&r->gs);
    if (r->gradients && !host->gradients)
        return tnd_fail(TND_ERR_BAD_INPUT, "capture: %s: no gradient samples, but the "
                        "sequence's first frame has them (run --denoiser svgf)", r->path);
    tnd_capture_gradients_path(r->path, gpath, sizeof gpath);
    struct stat st;
    if (stat(gpath, &st) != 0) {
        if (n == 0)
            return TND_OK; /* (a frame without history: no samples, no file) */
        return tnd_fail(TND_ERR_BAD_INPUT, "capture: %s: missing (the back-end selected %u "
                        "gradient samples for %s)", gpath, n, r->path);
    }

    tnd_result res = tnd_capture_read_gradients(gpath, host->width, host->height, &r->gs);
    if (res != TND_OK)
        return res;
    bool same = r->gs.count == n;
    for (uint32_t k = 0; same && k < n; k++)
        same = r->gs.pixel[k] == words[(size_t)k * PL_GRADIENT_WORDS];
    if (!same)
        return tnd_fail(TND_ERR_BAD_INPUT,
                        "capture: %s: %u gradient samples, but the back-end selected %u%s (a "
                        "replay must start at the sequence's first frame, as rendered; or run "
                        "--denoiser svgf)",
                        gpath, r->gs.count, n, r->gs.count == n ? " at other pixels" : "");
    tnd_gradient_samples_apply(&r->gs, host);
    return TND_OK;
}

static uint32_t rp_length(const void *ctx)
{
    return (uint32_t)((const replay *)ctx)->count;
}

static const char *rp_frame_name(const void *ctx, uint32_t i)
{
    const replay *r = ctx;
    return i < r->count ? r->names[i] : NULL;
}

static bool rp_recorded(const void *ctx, uint32_t *w, uint32_t *h, tnd_precision *p, bool *split)
{
    const replay *r = ctx;
    *w = r->width, *h = r->height, *p = r->precision, *split = r->split;
    return true;
}

static bool rp_has_entry(const void *ctx, tnd_ct e)
{
    return ((const replay *)ctx)->present[e];
}

static bool rp_can_reshade(const void *ctx)
{
    return ((const replay *)ctx)->gradients;
}

const pl_frontend_ops pl_replay_ops = {
    .name = "replay",
    .caps = PL_CAP_RESHADE | PL_CAP_RECORDED,
    .create = rp_create,
    .destroy = rp_destroy,
    .describe = rp_describe,
    .models = rp_models,
    .set_frame = rp_set_frame,
    .render = rp_render,
    .contract = rp_contract,
    .reshade = rp_reshade,
    .has_entry = rp_has_entry,
    .length = rp_length,
    .frame_name = rp_frame_name,
    .can_reshade = rp_can_reshade,
    .recorded = rp_recorded,
};
