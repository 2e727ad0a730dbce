/* pipeline/pl_chain.c: the frame after the front-end, written once: gradient selection (for a
 * denoiser that asks for re-shaded samples), re-shading by the front-end (in its shading pass,
 * the selection between its primary and shading passes, where it can), the denoiser (through
 * its registered operations, pl_denoiser.c), the post chain, and the outputs a caller asks for
 * (the host frame, a capture with its gradient samples, the HDR and display images). render,
 * denoise (capture replay) and bench run their frames through pl_chain_run. The contract stays on
 * the GPU unless a capture or the CPU composite needs it on the host. The frame's passes (the
 * front-end's, the denoiser's, the post chain's) are listed here once for every timings writer.
 * Entry points: pl_chain_create, pl_chain_destroy, pl_chain_run, pl_chain_finish,
 * pl_chain_denoiser, pl_chain_denoiser_info, pl_chain_contract, pl_chain_plugin_name,
 * pl_chain_post, pl_chain_passes, pl_step_times, pl_chain_traffic. */
#include "pipeline/pl_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

_Static_assert(PL_GRADIENT_WORDS == DN_GRADIENT_WORDS, "the back-end's gradient list layout");

struct pl_chain {
    pl_chain_desc d;
    const pl_denoiser_ops *ops; /* the denoiser */
    void *dn;                   /* its context */
    cmp_context *post;
    tnd_contract_gpu upload;  /* host front-ends: their frame goes up here */
    uint32_t *grads;          /* the host list of gradient samples, PL_GRADIENT_WORDS words each */
    tnd_frame host, reshaded; /* (reshaded: a GPU contract after re-shading, for a capture) */
    float prev_jitter[2];
    bool in_flight; /* the last frame's back-end and post were not waited for */
    pl_frontend *fe; /* the front-end of the last frame (its times at pl_chain_finish) */
    const tnd_contract_gpu *last_ct; /* the contract of the last frame */
};

/* The front-end's and the post chain's passes (pl_timings', cmp_timings' fields in order). */
const pl_pass pl_frontend_passes[] = {
    {"primary", "primary_ms", PL_GROUP_FRONTEND, NULL},
    {"shade", "shade_ms", PL_GROUP_FRONTEND, NULL},
    {"tlas", "tlas_ms", PL_GROUP_FRONTEND, NULL},
    {"gradient_shade", "gradient_shade_ms", PL_GROUP_GRADIENTS, NULL},
};
const uint32_t pl_frontend_pass_count = sizeof pl_frontend_passes / sizeof *pl_frontend_passes;
const pl_pass pl_post_passes[] = {
    {"interleave", "interleave_ms", PL_GROUP_POST, NULL},
    {"taa", "taa_ms", PL_GROUP_POST, NULL},
    {"bloom", "bloom_ms", PL_GROUP_POST, NULL},
    {"exposure", "exposure_ms", PL_GROUP_POST, NULL},
    {"tonemap", "tonemap_ms", PL_GROUP_POST, NULL},
};
const uint32_t pl_post_pass_count = sizeof pl_post_passes / sizeof *pl_post_passes;
_Static_assert(sizeof(pl_timings) == 4 * sizeof(double), "pl_frontend_passes follow pl_timings");
_Static_assert(sizeof(cmp_timings) == 5 * sizeof(double), "pl_post_passes follow cmp_timings");

tnd_result pl_chain_create(const pl_chain_desc *d, pl_chain **out)
{
    tnd_result res = TND_OK;
    *out = NULL;
    pl_chain *c = calloc(1, sizeof *c);
    if (!c)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
    c->d = *d;
    /* (callers from before the registry name the built-in back-end's mode) */
    const char *name = d->denoiser ? d->denoiser : dn_mode_name(d->denoise.mode);
    const pl_denoiser_info *info;
    TND_TRY(pl_denoiser_find(name, &info));
    c->ops = pl_denoiser_ops_find(name);
    if ((info->caps & PL_DN_PLUGIN) && !d->backend) {
        res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: a denoiser plugin needs the back-end");
        goto fail;
    }
    for (uint32_t i = 0; i < d->params.n; i++)
        if (!pl_denoiser_has_param(info, d->params.param[i]->name)) {
            res = tnd_fail(TND_ERR_INVALID_ARGUMENT, "pipeline: denoiser %s has no parameter %s",
                           info->name, d->params.param[i]->name);
            goto fail;
        }
    if (d->backend) {
        TND_TRY(c->ops->create(&(pl_dn_desc){.vk = d->vk, .width = d->width, .height = d->height,
                                             .precision = d->precision, .params = &c->d.params,
                                             .backend = &d->denoise,
                                             .path = name + (info->caps & PL_DN_PLUGIN ? 7 : 0),
                                             .data = c->ops->data,
                                             .npasses = info->npasses},
                               &c->dn));
        if (!d->no_post)
            TND_TRY(cmp_create_scaled(d->vk, d->width, d->height,
                                      d->out_width ? d->out_width : d->width,
                                      d->out_height ? d->out_height : d->height, d->precision,
                                      &d->post, &c->post));
        if ((info->caps & (PL_DN_GRADIENTS | PL_DN_CONFIDENCE)) &&
            !(c->grads = malloc((size_t)c->ops->capacity(c->dn) * PL_GRADIENT_WORDS *
                                sizeof *c->grads))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
            goto fail;
        }
    }
    *out = c;
    return TND_OK;
fail:
    pl_chain_destroy(c);
    return res;
}

void pl_chain_destroy(pl_chain *c)
{
    if (!c)
        return;
    free(c->grads);
    tnd_frame_destroy(&c->host);
    tnd_frame_destroy(&c->reshaded);
    if (c->upload.images[0].image)
        tnd_contract_gpu_destroy(c->d.vk, &c->upload);
    cmp_destroy(c->post);
    if (c->dn)
        c->ops->destroy(c->dn);
    free(c);
}

const pl_denoiser_info *pl_chain_denoiser_info(const pl_chain *c)
{
    return &c->ops->info;
}

dn_context *pl_chain_denoiser(pl_chain *c)
{
    return c->dn && c->ops->backend ? c->ops->backend(c->dn) : NULL;
}

const tnd_contract_gpu *pl_chain_contract(const pl_chain *c)
{
    return c->last_ct;
}

const char *pl_chain_plugin_name(const pl_chain *c)
{
    return c->dn && c->ops->plugin_name ? c->ops->plugin_name(c->dn) : NULL;
}

uint32_t pl_chain_passes(const pl_chain *c, const pl_pass **p, uint32_t max)
{
    uint32_t n = 0;
    for (uint32_t i = 0; i < pl_frontend_pass_count && n < max; i++)
        p[n++] = &pl_frontend_passes[i];
    for (uint32_t i = 0; c->d.backend && i < c->ops->info.npasses && n < max; i++)
        p[n++] = &c->ops->info.passes[i];
    for (uint32_t i = 0; c->post && i < pl_post_pass_count && n < max; i++)
        p[n++] = &pl_post_passes[i];
    return n;
}

void pl_step_times(const pl_chain *c, const pl_step_result *r, double *ms)
{
    uint32_t n = 0;
    const double fe[4] = {r->fe.primary_ms, r->fe.shade_ms, r->fe.tlas_ms, r->fe.gradient_ms};
    for (uint32_t i = 0; i < pl_frontend_pass_count; i++)
        ms[n++] = fe[i];
    for (uint32_t i = 0; c->d.backend && i < c->ops->info.npasses; i++)
        ms[n++] = r->dn[i];
    const double post[5] = {r->post.interleave_ms, r->post.taa_ms, r->post.bloom_ms,
                            r->post.exposure_ms, r->post.tonemap_ms};
    for (uint32_t i = 0; c->post && i < pl_post_pass_count; i++)
        ms[n++] = post[i];
}

void pl_chain_traffic(const pl_chain *c, double *bytes)
{
    memset(bytes, 0, PL_DN_MAX_PASSES * sizeof *bytes);
    if (c->dn && c->ops->traffic)
        c->ops->traffic(c->dn, bytes);
}

/* The camera's position from its world-to-camera matrix (column-major): -R^T t. */
static void camera_position(const float view[16], float pos[3])
{
    for (int i = 0; i < 3; i++)
        pos[i] = -(view[i * 4 + 0] * view[12] + view[i * 4 + 1] * view[13] +
                   view[i * 4 + 2] * view[14]);
}

cmp_context *pl_chain_post(pl_chain *c)
{
    return c->post;
}

/* A-SVGF's samples of the frame beside its capture: the pixels of the back-end's selection and
 * the contract there after re-shading. */
static tnd_result write_gradients(const char *capture, const tnd_frame *reshaded,
                                  const uint32_t *words, uint32_t n)
{
    tnd_result res = TND_OK;
    tnd_gradient_samples g = {0};
    uint32_t *pixels = malloc((size_t)n * sizeof *pixels);
    if (!pixels)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
    for (uint32_t k = 0; k < n; k++)
        pixels[k] = words[(size_t)k * PL_GRADIENT_WORDS];
    char path[2200];
    tnd_capture_gradients_path(capture, path, sizeof path);
    TND_TRY(tnd_gradient_samples_gather(reshaded, pixels, n, &g));
    TND_TRY(tnd_capture_write_gradients(path, &g, reshaded->width, reshaded->height, TND_EXR_ZIP));
fail:
    tnd_gradient_samples_free(&g);
    free(pixels);
    return res;
}

/* The frame in flight: wait for it, its GPU times into r (lagged: not this call's frame). `fe`:
 * the front-end whose next frame is in the queue behind it (its times without waiting), NULL
 * when none is (pl_chain_finish). */
static tnd_result collect(pl_chain *c, pl_frontend *fe, pl_step_result *r)
{
    tnd_result res = TND_OK;
    if (fe)
        TND_TRY(pl_frontend_timings(fe, false, &r->fe));
    else if (c->fe)
        TND_TRY(pl_frontend_timings(c->fe, true, &r->fe));
    TND_TRY(c->ops->wait(c->dn, r->dn, &r->beside));
    if (c->post)
        TND_TRY(cmp_wait(c->post, &r->post));
    r->lagged = true;
fail:
    return res;
}

bool pl_chain_takes_gradients(const pl_chain *c, const pl_frontend *fe)
{
    /* a denoiser that asks for re-shaded gradient samples (A-SVGF), or takes them where the
     * front-end can give them (recurrent) */
    uint32_t dn = c->ops->info.caps, caps = pl_frontend_caps(fe);
    return c->d.backend &&
           ((dn & PL_DN_GRADIENTS) || ((dn & PL_DN_CONFIDENCE) && (caps & PL_CAP_RESHADE)));
}

bool pl_chain_can_fold(const pl_chain *c, const pl_frontend *fe)
{
    return pl_chain_takes_gradients(c, fe) && (pl_frontend_caps(fe) & PL_CAP_SHADE_SLOTS);
}

tnd_result pl_chain_run(pl_chain *c, pl_frontend *fe, const pl_step *s, float *hdr,
                        uint8_t *display, pl_step_result *r)
{
    tnd_result res = TND_OK;
    pl_step_result own = {0};
    if (!r)
        r = &own;
    memset(r, 0, sizeof *r);
    uint32_t caps = pl_frontend_caps(fe);
    bool gpu = (caps & PL_CAP_GPU_CONTRACT) != 0, recorded = (caps & PL_CAP_RECORDED) != 0;
    /* a queued front-end's passes are not waited for here (the back-end's follow them in the
     * queue): their times come once the frame is waited for, or lagged with the back-end's */
    pl_timings *ft = (caps & PL_CAP_QUEUED) ? NULL : &r->fe;
    c->fe = fe;
    bool gradients = pl_chain_takes_gradients(c, fe);
    bool need_host = !gpu || s->capture || s->host_out || !c->d.backend || c->d.host_contract;
    /* the selection between the front-end's primary and shading passes, which re-shades the
     * samples in place: no re-shading launch (it cost `cornell` 0.17 ms of 2.18 at 1080p on the
     * H200, docs/performance.md); where the frame goes to the host, it goes as rendered */
    bool fold = pl_chain_can_fold(c, fe) && !need_host && !s->frame_from_host &&
                !c->d.separate_reshade;
    if (recorded)
        tnd_frame_destroy(&c->host); /* (a recorded front-end reads into a fresh frame) */
    else if (need_host && !c->host.block)
        TND_TRY(tnd_frame_create(c->d.width, c->d.height, &c->host));
    if (fold) {
        TND_TRY(pl_frontend_render_primary(fe, &s->params));
        VkBuffer slots = VK_NULL_HANDLE;
        uint32_t n = 0, row = 0;
        tnd_result sel = c->ops->select(c->dn, pl_frontend_contract(fe), &s->frame, NULL, &slots,
                                        &n, &row);
        /* (the shading pass either way: the front-end's frame is not left half-made) */
        TND_TRY(pl_frontend_render_shade(fe, &s->params, n ? slots : VK_NULL_HANDLE, row, ft));
        TND_TRY(sel);
    } else {
        TND_TRY(pl_frontend_render(fe, &s->params, need_host ? &c->host : NULL, ft));
    }
    dn_frame df = s->frame;
    if (s->frame_from_host) { /* a recorded frame: its own jitter and projection */
        const tnd_frame *f = &c->host;
        double tan_half = f->has_camera && f->camera.proj[5] != 0.0f
                              ? 1.0 / fabs((double)f->camera.proj[5])
                              : tan(0.5 * s->yfov * TND_PI / 180.0);
        memcpy(df.jitter, f->camera.jitter, sizeof df.jitter);
        memcpy(df.prev_jitter, c->prev_jitter, sizeof df.prev_jitter);
        df.pixel_spread = (float)(2.0 * tan_half / c->d.height);
        memcpy(c->prev_jitter, f->camera.jitter, sizeof c->prev_jitter);
    }
    if (s->host_out)
        TND_TRY(tnd_frame_copy(&c->host, s->host_out));
    if (s->capture) {
        c->host.gradients = gradients; /* the samples come beside it */
        TND_TRY(tnd_capture_write(s->capture, &c->host, TND_EXR_ZIP));
    }
    if (!c->d.backend) { /* the composite on the CPU */
        if (!ft)
            TND_TRY(pl_frontend_timings(fe, true, &r->fe));
        tnd_frame_composite(&c->host, hdr);
        tnd_frame_interleave(&c->host, hdr);
        return TND_OK;
    }
    const tnd_contract_gpu *ct = gpu ? pl_frontend_contract(fe) : &c->upload;
    c->last_ct = ct;
    if (!gpu) {
        if (!c->upload.images[0].image)
            TND_TRY(tnd_contract_gpu_create(c->d.vk, c->d.width, c->d.height, c->d.precision,
                                            &c->upload));
        TND_TRY(tnd_contract_upload(c->d.vk, &c->upload, &c->host));
    }
    if (gradients && !fold) {
        /* A-SVGF: the denoiser picks pixels, the front-end re-shades them with the previous
         * frame's random numbers on the surface seen there; the re-shaded values go beside the
         * contract (the gradients read them), the contract keeps every pixel's fresh sample */
        uint32_t n = 0;
        if (gpu && s->capture) { /* the list comes to the host, for the capture */
            TND_TRY(c->ops->select(c->dn, ct, &df, c->grads, NULL, &n, NULL));
            TND_TRY(pl_frontend_reshade(fe, &s->params, c->grads, n, NULL, ft));
            if (n) { /* the contract as re-shaded, at the samples */
                if (!c->reshaded.block)
                    TND_TRY(tnd_frame_create(c->d.width, c->d.height, &c->reshaded));
                TND_TRY(tnd_contract_download(c->d.vk, ct, &c->reshaded));
                TND_TRY(write_gradients(s->capture, &c->reshaded, c->grads, n));
                TND_TRY(c->ops->gradient_values(c->dn, c->grads, n, &c->reshaded));
                /* the front-end re-shaded its contract in place: the back-end reads the frame
                 * as rendered, the host's copy */
                if (!c->upload.images[0].image)
                    TND_TRY(tnd_contract_gpu_create(c->d.vk, c->d.width, c->d.height,
                                                    c->d.precision, &c->upload));
                TND_TRY(tnd_contract_upload(c->d.vk, &c->upload, &c->host));
                ct = c->last_ct = &c->upload;
            }
        } else if (gpu) { /* the sample list stays on the GPU, the values go into it */
            VkBuffer slots;
            uint32_t row = 0;
            TND_TRY(c->ops->select(c->dn, ct, &df, NULL, &slots, &n, &row));
            TND_TRY(pl_frontend_reshade_slots(fe, &s->params, slots, n, row, ft));
        } else {
            TND_TRY(c->ops->select(c->dn, ct, &df, c->grads, NULL, &n, NULL));
            /* the host frame as rendered (uploaded above) at the samples, to put back after the
             * front-end re-shaded them in place */
            tnd_gradient_samples kept = {0};
            if (n) {
                uint32_t *pixels = malloc((size_t)n * sizeof *pixels);
                if (!pixels)
                    return tnd_fail(TND_ERR_OUT_OF_MEMORY, "pipeline: out of memory");
                for (uint32_t k = 0; k < n; k++)
                    pixels[k] = c->grads[(size_t)k * PL_GRADIENT_WORDS];
                res = tnd_gradient_samples_gather(&c->host, pixels, n, &kept);
                free(pixels);
                TND_TRY(res);
            }
            /* (a recorded front-end checks the selection even when it is empty) */
            if (n || recorded)
                res = pl_frontend_reshade(fe, &s->params, c->grads, n, &c->host, ft);
            if (res == TND_OK && n) {
                res = c->ops->gradient_values(c->dn, c->grads, n, &c->host);
                if (res == TND_OK && s->capture)
                    res = write_gradients(s->capture, &c->host, c->grads, n);
                tnd_gradient_samples_apply(&kept, &c->host);
            }
            tnd_gradient_samples_free(&kept);
            TND_TRY(res);
        }
    }
    /* the times of the frame in flight before this one, when it was not waited for */
    bool wait = !s->no_wait || hdr || display || s->after_backend;
    if (c->in_flight && !wait)
        TND_TRY(collect(c, fe, r));
    c->in_flight = false;
    /* the frame's camera: the recorded frame's, or the front-end's */
    pl_camera cam = {0};
    if (recorded) {
        cam.state = c->host.camera;
        camera_position(c->host.camera.view, cam.position);
    } else if (pl_frontend_camera(fe)) {
        cam = *pl_frontend_camera(fe);
    }
    TND_TRY(c->ops->submit(c->dn, &(pl_dn_input){.contract = ct, .frame = &df, .camera = &cam,
                                                 .params = &s->params, .dt = s->dt}));
    if (wait)
        TND_TRY(c->ops->wait(c->dn, r->dn, &r->beside));
    if (s->after_backend)
        TND_TRY(s->after_backend(pl_chain_denoiser(c), s->user));
    if (c->post) {
        const tnd_image *out = c->ops->output(c->dn);
        TND_TRY(cmp_submit(c->post, out, ct,
                           &(cmp_frame){.dt = s->dt, .reset = df.reset,
                                        .jitter = {df.jitter[0], df.jitter[1]}}));
        if (wait)
            TND_TRY(cmp_wait(c->post, &r->post));
        if (hdr)
            TND_TRY(cmp_download_hdr(c->post, hdr));
        if (display)
            TND_TRY(cmp_download_display(c->post, display));
    }
    if (wait && !ft)
        TND_TRY(pl_frontend_timings(fe, true, &r->fe));
    c->in_flight = !wait;
fail:
    return res;
}

tnd_result pl_chain_finish(pl_chain *c, pl_step_result *r)
{
    tnd_result res = TND_OK;
    pl_step_result own;
    if (!r)
        r = &own;
    memset(r, 0, sizeof *r);
    if (c->in_flight)
        TND_TRY(collect(c, NULL, r));
    c->in_flight = false;
fail:
    return res;
}
