/* run/rn_session.c: render's and reference's pipeline held open between calls, frame by frame, for
 * callers that take the pixels instead of files: the Python binding (python/) and the dataset
 * (run/rn_dataset.c). It builds what render builds (rn_scene_load, rn_pipeline_open) and runs
 * each frame as render's loop does (rn_frame_begin, rn_frame_step, pl_chain_run), so that a
 * frame here is the frame render writes, bit for bit.
 * Entry points: rn_session_open, rn_session_close, rn_session_frame, rn_session_reference,
 * rn_session_scene, rn_session_opts, rn_session_denoiser, rn_session_vk. */
#include "run/rn_internal.h"

#include <stdlib.h>
#include <string.h>

struct rn_session {
    rn_render_opts o;
    bool reference;
    tnd_scene *own;          /* the scene it loaded (NULL: the caller's) */
    const tnd_scene *scene;
    tnd_vk vk;
    bool have_vk, use_dn;
    pl_frontend *fr;
    pl_chain *chain;
    const pl_denoiser_info *dn;
    cmp_desc pd;
    tnd_scene_state st[2];
    bool started;      /* a frame was run: `last` is the previous one */
    unsigned last;     /* the frame run last */
    tnd_frame scratch; /* (references: the frame's contract) */
    double *sums;      /* (references: RGB and luminance^2 per pixel) */
};

void rn_session_close(rn_session *s)
{
    if (!s)
        return;
    tnd_frame_destroy(&s->scratch);
    free(s->sums);
    tnd_scene_state_free(&s->st[0]);
    tnd_scene_state_free(&s->st[1]);
    pl_chain_destroy(s->chain);
    pl_frontend_destroy(s->fr);
    if (s->have_vk) {
        if (s->vk.device)
            vkDeviceWaitIdle(s->vk.device);
        tnd_vk_destroy(&s->vk);
    }
    tnd_scene_destroy(s->own);
    free(s);
}

tnd_result rn_session_open(const rn_render_opts *o, bool reference, const tnd_scene *scene,
                           const rn_host *h, rn_session **out)
{
    *out = NULL;
    tnd_result res = rn_render_check(o, reference);
    if (res != TND_OK)
        return res;
    rn_session *s = calloc(1, sizeof *s);
    if (!s)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "out of memory");
    s->o = *o;
    s->o.start = 0; /* (frames are asked for by number) */
    s->o.view = NULL;
    s->reference = reference;
    if (reference) /* --bounces as reference takes it (run_opts) */
        rn_reference_bounces(&s->o);
    tnd_precision prec;
    if ((res = tnd_precision_parse(s->o.precision, &prec)) != TND_OK)
        goto fail;
    bool use_vk = pl_frontend_needs_gpu(s->o.frontend);
    if (!reference && (res = pl_denoiser_find(s->o.denoiser, &s->dn)) != TND_OK)
        goto fail;
    /* the back-end on Vulkan unless a host front-end runs a denoiser that does not filter */
    s->use_dn = !reference && ((s->dn->caps & PL_DN_FILTERS) || use_vk);
    if (scene) {
        s->scene = scene;
    } else {
        TND_TRY(rn_scene_load(s->o.scene, &s->o.env, &s->own));
        s->scene = s->own;
    }
    if (use_vk || s->use_dn) {
        TND_TRY(tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = !use_vk}, &s->vk));
        s->have_vk = true;
    }
    TND_TRY(rn_pipeline_open(&s->o, s->scene, &s->vk, use_vk, s->use_dn, prec, &s->dn, reference,
                             &s->fr, &s->chain, &s->pd, h));
    if (reference && strcmp(s->o.estimator, "realtime") != 0 &&
        !(pl_frontend_caps(s->fr) & PL_CAP_REFERENCE)) {
        res = tnd_fail(TND_ERR_UNSUPPORTED,
                       "--frontend %s renders no unbiased reference (--estimator realtime "
                       "renders the matched one)",
                       s->o.frontend);
        goto fail;
    }
    *out = s;
    return TND_OK;
fail:
    rn_session_close(s);
    return res;
}

const tnd_scene *rn_session_scene(const rn_session *s)
{
    return s->scene;
}

const rn_render_opts *rn_session_opts(const rn_session *s)
{
    return &s->o;
}

const tnd_vk *rn_session_vk(const rn_session *s)
{
    return s->have_vk ? &s->vk : NULL;
}

const char *rn_session_denoiser(const rn_session *s)
{
    return s->dn ? s->dn->name : NULL;
}

/* Frame f's states and the front-end's frame: the history goes on from the frame before when f
 * follows it, else restarts (the first frame of a render). */
static tnd_result begin(rn_session *s, unsigned f, bool *first)
{
    *first = !s->started || f != s->last + 1;
    tnd_result res = rn_frame_begin(&s->o, s->scene, s->fr, s->st, f, *first, NULL);
    s->started = res == TND_OK;
    s->last = f;
    return res;
}

tnd_result rn_session_frame(rn_session *s, unsigned f, float *rgb, uint8_t *display,
                            tnd_frame *contract)
{
    tnd_result res = TND_OK;
    if (s->reference)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "a reference session renders references");
    bool first;
    TND_TRY(begin(s, f, &first));
    pl_step step = rn_frame_step(&s->o, &s->st[f & 1], f, first);
    step.host_out = contract;
    TND_TRY(pl_chain_run(s->chain, s->fr, &step, rgb, s->use_dn ? display : NULL, NULL));
    if (display && !s->use_dn) { /* (the CPU composite has no display image: render's preview) */
        size_t n = (size_t)s->o.size[0] * s->o.size[1];
        memset(display, 0, n * 3);
    }
fail:
    return res;
}

tnd_result rn_session_reference(rn_session *s, unsigned f, float *rgb, float *variance,
                                tnd_ref_stats *stats)
{
    tnd_result res = TND_OK;
    float *se = NULL;
    if (!s->reference)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "a render session renders no references");
    size_t n = (size_t)s->o.size[0] * s->o.size[1];
    if (!s->sums && !(s->sums = malloc(4 * n * sizeof *s->sums)))
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "reference: out of memory");
    if (!s->scratch.block)
        TND_TRY(tnd_frame_create(s->o.size[0], s->o.size[1], &s->scratch));
    if (!(se = malloc(n * sizeof *se)))
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "reference: out of memory");
    bool first;
    TND_TRY(begin(s, f, &first));
    memset(s->sums, 0, 4 * n * sizeof *s->sums);
    tnd_ref_stats rs = {.until_noise = s->o.until_noise};
    TND_TRY(rn_reference_add(s->fr, &s->o, f, &s->scratch, 0, s->o.spp, s->sums, s->sums + 3 * n,
                             &rs, NULL, NULL));
    /* the mean and the variance of one sample's luminance, as reference's EXR holds them
     * (rn_ref_frame_finish) */
    rs.rel_error = tnd_ref_finish(s->sums, s->sums + 3 * n, n, rs.spp, rgb, se);
    for (size_t q = 0; variance && q < n; q++)
        variance[q] = se[q] * se[q] * (float)rs.spp;
    if (stats)
        *stats = rs;
fail:
    free(se);
    return res;
}
