/* viewer/vw_views.c: what the viewer shows besides the final image: every contract entry and the
 * back-end's dumps in false colour, a still camera's progressive reference, the error against
 * it (relative error or FLIP, on the device), and the overlay (device, GPU ms of every pass,
 * settings, frame-time graph) drawn with stb_easy_font. */
#include "viewer/vw_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <stb/stb_easy_font.h>

uint32_t vw_view_count(void)
{
    return 1 + TND_CT_COUNT + dn_dump_count();
}

void vw_view_name(uint32_t v, char *buf, size_t cap)
{
    if (v == 0)
        snprintf(buf, cap, "final");
    else if (v <= TND_CT_COUNT)
        snprintf(buf, cap, "%s", tnd_ct_get((tnd_ct)(v - 1))->name);
    else
        snprintf(buf, cap, "dump:%s", dn_dump_name(v - 1 - TND_CT_COUNT, NULL));
}

uint32_t vw_view_find(const char *name)
{
    char buf[64];
    for (uint32_t v = 0; v < vw_view_count(); v++) {
        vw_view_name(v, buf, sizeof buf);
        if (strcmp(buf, name) == 0)
            return v;
    }
    return 0;
}
/* ---- views in false colour ------------------------------------------------------------------------ */
static float enc(float x) /* linear [0, inf) to display: Reinhard, then a 2.2 gamma */
{
    x = x > 0 ? x / (1.0f + x) : 0.0f;
    return powf(x, 1.0f / 2.2f);
}

static void hue(float h, float out[3]) /* h in [0, 1) around the colour wheel, 0 red */
{
    h = (h - floorf(h)) * 6.0f;
    out[0] = fminf(1.0f, fmaxf(0.0f, fabsf(h - 3.0f) - 1.0f));
    out[1] = fminf(1.0f, fmaxf(0.0f, 2.0f - fabsf(h - 2.0f)));
    out[2] = fminf(1.0f, fmaxf(0.0f, 2.0f - fabsf(h - 4.0f)));
}

static void colour_id(uint32_t a, uint32_t b, float out[3])
{
    uint32_t h = a * 0x9E3779B9u ^ b * 0x85EBCA6Bu;
    h ^= h >> 15;
    h *= 0x2C1B3C6Du;
    h ^= h >> 12;
    hue((float)(h & 0xffff) / 65536.0f, out);
}

/* one contract entry of the host frame, or a dump (4 floats per texel), as display colours */
static void false_colour(viewer *v, uint32_t view, const float *dump, uint32_t dw, uint32_t dh)
{
    uint32_t w = v->st.size[0], h = v->st.size[1];
    float *o = v->debug_px;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t q = (size_t)y * w + x;
            float c[3] = {0, 0, 0};
            if (view > TND_CT_COUNT) { /* a dump: 1/3-res ones stretched */
                uint32_t dx = x * dw / w, dy = y * dh / h;
                const float *d = dump + 4 * ((size_t)dy * dw + dx);
                const char *nm = dn_dump_name(view - 1 - TND_CT_COUNT, NULL);
                if (strcmp(nm, "temporal.hf") == 0) { /* history length: 0 red .. 32+ green */
                    hue(0.33f * fminf(d[3], 32.0f) / 32.0f, c);
                } else if (strcmp(nm, "gradients") == 0) { /* |gradient| x 4, per signal */
                    for (int k = 0; k < 3; k++)
                        c[k] = fminf(1.0f, 4.0f * fabsf(d[k]));
                } else {
                    for (int k = 0; k < 3; k++)
                        c[k] = enc(d[k]);
                }
            } else {
                tnd_ct id = (tnd_ct)(view - 1);
                const tnd_ct_info *e = tnd_ct_get(id);
                const float *f = tnd_frame_f(&v->host, id) + (size_t)e->comps * q;
                const uint32_t *u = tnd_frame_u(&v->host, id) + (size_t)e->comps * q;
                switch (id) {
                case TND_CT_NORMAL: case TND_CT_GEO_NORMAL:
                    for (int k = 0; k < 3; k++)
                        c[k] = 0.5f + 0.5f * f[k];
                    break;
                case TND_CT_POSITION:
                    for (int k = 0; k < 3; k++)
                        c[k] = f[k] - floorf(f[k]);
                    break;
                case TND_CT_DEPTH:
                    c[0] = c[1] = c[2] = f[0] >= (float)TND_DEPTH_MISS ? 0.0f : 1.0f / (1.0f + f[0]);
                    if (f[0] >= (float)TND_DEPTH_MISS)
                        c[2] = 0.25f;
                    break;
                case TND_CT_SPEC_HIT: /* the reflection's distance as depth's; none: black */
                    c[0] = c[1] = c[2] =
                        f[0] > 0.0f && f[0] < (float)TND_DEPTH_MISS ? 1.0f / (1.0f + f[0]) : 0.0f;
                    if (f[0] >= (float)TND_DEPTH_MISS) /* escaped: as the sky in depth */
                        c[2] = 0.25f;
                    break;
                case TND_CT_MOTION: { /* direction as hue, length as value (4 pixels: full) */
                    float len = sqrtf(f[0] * f[0] + f[1] * f[1]);
                    hue(atan2f(f[1], f[0]) / (2.0f * (float)TND_PI) + 0.5f, c);
                    for (int k = 0; k < 3; k++)
                        c[k] *= fminf(1.0f, len / 4.0f);
                    break;
                }
                case TND_CT_VIS_ID: case TND_CT_RNG:
                    if (u[0] != TND_VIS_NONE)
                        colour_id(u[0], id == TND_CT_VIS_ID ? u[1] : 0, c);
                    break;
                case TND_CT_PATH:
                    c[0] = (u[0] & TND_PATH_SPLIT) ? 1.0f : 0.0f;
                    c[1] = (u[0] & TND_PATH_MIRROR) ? 1.0f : 0.0f;
                    c[2] = (u[0] & (TND_PATH_GLASS | TND_PATH_REFRACT)) ? 1.0f : 0.0f;
                    break;
                case TND_CT_LF_SH:
                    c[0] = c[1] = c[2] = enc(f[3]);
                    break;
                case TND_CT_LF_COCG:
                    c[0] = 0.5f + f[0];
                    c[1] = 0.5f + f[1];
                    c[2] = 0.5f;
                    break;
                case TND_CT_ROUGHNESS: case TND_CT_METALLIC: case TND_CT_DIFFUSE_VIEW:
                    c[0] = c[1] = c[2] = f[0];
                    break;
                case TND_CT_VIS_BARY:
                    c[0] = f[0];
                    c[1] = f[1];
                    break;
                case TND_CT_ALBEDO: case TND_CT_THROUGHPUT:
                    for (int k = 0; k < 3; k++)
                        c[k] = powf(fminf(1.0f, fmaxf(0.0f, f[k])), 1.0f / 2.2f);
                    break;
                default: /* radiance: hf, spec, emission */
                    for (int k = 0; k < 3; k++)
                        c[k] = enc(f[k]);
                }
            }
            for (int k = 0; k < 3; k++)
                o[4 * q + k] = c[k];
            o[4 * q + 3] = 1.0f;
        }
}

tnd_result vw_debug_view(viewer *v)
{
    tnd_result res = TND_OK;
    uint32_t w = v->st.size[0], h = v->st.size[1];
    float *dump = NULL;
    uint32_t dw = 0, dh = 0;
    if (v->view <= TND_CT_COUNT) {
        TND_TRY(tnd_contract_download(&v->vk, pl_chain_contract(v->chain[0]), &v->host));
    } else {
        uint32_t i = v->view - 1 - TND_CT_COUNT;
        dn_context *dn = pl_chain_denoiser(v->chain[0]);
        TND_TRY(dn_dump_size(dn, i, &dw, &dh));
        if (!(dump = malloc((size_t)dw * dh * 16))) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
            goto fail;
        }
        TND_TRY(dn_dump(dn, i, dump));
    }
    false_colour(v, v->view, dump, dw, dh);
    TND_TRY(tnd_image_upload(&v->vk, &v->debug, v->debug_px, (size_t)w * h * 16));
fail:
    free(dump);
    return res;
}

/* The progressive reference's next step: 1, 2, 4, ... 4096 samples per pixel (each rendered
 * afresh: the front-ends key their samples by index). */
static tnd_result reference_step(viewer *v)
{
    uint32_t spp = v->ref_spp ? (v->ref_spp < 4096 ? 2 * v->ref_spp : 4096) : 1;
    if (spp == v->ref_spp)
        return TND_OK;
    tnd_result res = pl_frontend_reference(v->fe[0], 0, spp, v->ref_rgb, NULL, NULL, NULL, NULL);
    if (res == TND_OK)
        v->ref_spp = spp;
    return res;
}

/* X: the final image (linear, after TAA) against the progressive reference, tone mapped as eval
 * does (the reference's auto exposure): the relative error |o - r| / (r + 0.01) (mean over the
 * channels, 1 and above at the top of the colour map), or FLIP's map from the device metrics
 * (eval/metrics_gpu.c); the mean into err_mean (relMSE or FLIP). */
tnd_result vw_error_view(viewer *v)
{
    tnd_result res = TND_OK;
    uint32_t w = v->st.size[0], h = v->st.size[1];
    size_t n = (size_t)w * h;
    TND_TRY(reference_step(v));
    TND_TRY(cmp_download_hdr(pl_chain_post(v->chain[0]), v->err_rgb));
    ev_image out = {w, h, v->err_rgb, NULL}, ref = {w, h, v->ref_rgb, NULL};
    ev_image_sanitize(&out);
    if (v->err_view == 2) {
        if (!v->metrics)
            TND_TRY(ev_gpu_create(&v->vk, w, h, EV_FLIP_PPD, &v->metrics));
        ev_gpu_metrics m;
        TND_TRY(ev_gpu_frame(v->metrics, &out, &ref, ev_auto_exposure(&ref, 1), &m, v->err_map));
        v->err_mean = m.flip;
    } else {
        for (size_t q = 0; q < n; q++) {
            float e = 0;
            for (int k = 0; k < 3; k++) {
                float d = out.rgb[3 * q + k] - ref.rgb[3 * q + k];
                e += fabsf(d) / (fabsf(ref.rgb[3 * q + k]) + 0.01f) / 3.0f;
            }
            v->err_map[q] = fminf(e, 1.0f);
        }
        v->err_mean = ev_relmse(out.rgb, ref.rgb, 3 * n);
    }
    ev_colormap(v->err_map, n, v->err_rgb);
    for (size_t q = 0; q < n; q++) {
        for (int k = 0; k < 3; k++)
            v->debug_px[4 * q + k] = v->err_rgb[3 * q + k];
        v->debug_px[4 * q + 3] = 1.0f;
    }
    TND_TRY(tnd_image_upload(&v->vk, &v->debug, v->debug_px, n * 16));
fail:
    return res;
}

/* A still camera's unbiased reference, shown with the current exposure and Reinhard. */
tnd_result vw_progressive_reference(viewer *v)
{
    tnd_result res = TND_OK;
    uint32_t w = v->st.size[0], h = v->st.size[1];
    TND_TRY(reference_step(v));
    float exposure = 1.0f, log2_lum = 0.0f;
    TND_TRY(cmp_exposure(pl_chain_post(v->chain[0]), &exposure, &log2_lum));
    for (size_t q = 0; q < (size_t)w * h; q++) {
        for (int k = 0; k < 3; k++)
            v->debug_px[4 * q + k] = enc(exposure * v->ref_rgb[3 * q + k]);
        v->debug_px[4 * q + 3] = 1.0f;
    }
    TND_TRY(tnd_image_upload(&v->vk, &v->debug, v->debug_px, (size_t)w * h * 16));
fail:
    return res;
}

/* ---- the overlay ------------------------------------------------------------------------------- */
static void fill(uint8_t *px, int x0, int y0, int x1, int y1, const uint8_t c[4])
{
    for (int y = y0 < 0 ? 0 : y0; y < y1 && y < OVERLAY_H; y++)
        for (int x = x0 < 0 ? 0 : x0; x < x1 && x < OVERLAY_W; x++)
            memcpy(px + 4 * ((size_t)y * OVERLAY_W + x), c, 4);
}

static void text(uint8_t *px, int x, int y, const char *s, const uint8_t c[4])
{
    static char buf[60000];
    char t[400];
    snprintf(t, sizeof t, "%s", s);
    int quads = stb_easy_font_print((float)x, (float)y, t, NULL, buf, sizeof buf);
    for (int i = 0; i < quads; i++) { /* each quad: 4 vertices of x, y, z, colour */
        const float *q = (const float *)(buf + (size_t)i * 64);
        fill(px, (int)q[0], (int)q[1], (int)q[8], (int)q[9], c);
    }
}

void vw_draw_overlay(viewer *v, const char *device, double fps)
{
    uint8_t *px = v->overlay_px;
    const uint8_t bg[4] = {0, 0, 0, 150}, fg[4] = {235, 235, 235, 255},
                  bar[4] = {80, 200, 120, 230}, hot[4] = {240, 120, 60, 230};
    fill(px, 0, 0, OVERLAY_W, OVERLAY_H, bg);
    const rn_view_state *s = &v->st;
    char line[400], who[300], vn[64];
    vw_view_name(v->view, vn, sizeof vn);
    int y = 4;
    snprintf(line, sizeof line, "tandem view   %.1f fps   %.1f ms   %s", fps,
             fps > 0 ? 1e3 / fps : 0.0, device);
    text(px, 4, y, line, fg);
    y += 10;
    snprintf(line, sizeof line, "front-end %s  [%s]",
             pl_frontend_describe(v->fe[0], who, sizeof who), pl_frontend_models(v->fe[0]));
    text(px, 4, y, line, fg);
    y += 10;
    char nb[16];
    snprintf(nb, sizeof nb, s->half_indirect ? "half" : "%u", s->bounces);
    char sc[32] = "";
    if (s->render_scale > 0 && s->render_scale < 1)
        snprintf(sc, sizeof sc, "  scale %.2f", s->render_scale);
    snprintf(line, sizeof line, "denoiser %.60s  bounces %s  %s  TAA %s  %s  bloom %.2f%s",
             v->chain[0] && pl_chain_plugin_name(v->chain[0]) ? s->denoiser : v->dn->name, nb,
             s->precision, s->taa, s->tonemap, s->bloom, sc);
    text(px, 4, y, line, fg);
    y += 10;
    char sp[200] = "";
    if (vw_split(s))
        snprintf(sp, sizeof sp, "  split %.16s: %.40s | %.40s", s->split_mode,
                 strcmp(s->split_mode, "frontend") == 0 ? s->frontend : s->denoiser,
                 strcmp(s->split_mode, "frontend") == 0 ? s->split_frontend
                 : strcmp(s->split_mode, "noisy") == 0  ? "off"
                                                        : s->split_denoiser);
    if (v->ref_on)
        snprintf(sp, sizeof sp, "  reference %u spp (unbiased, Reinhard)", v->ref_spp);
    if (v->err_view)
        snprintf(sp, sizeof sp, "  %s %.4f against the reference at %u spp",
                 v->err_view == 2 ? "FLIP" : "relative error; relMSE", v->err_mean, v->ref_spp);
    snprintf(line, sizeof line, "view %s%s   frame %u   history %u frames", vn, sp, v->frame,
             s->path_frames);
    text(px, 4, y, line, fg);
    y += 10;
    /* GPU ms of every pass of the frame (pl_chain_passes), groups apart, on two lines */
    const pl_pass *pass[48];
    double ms[48];
    uint32_t np = v->chain[0] ? pl_chain_passes(v->chain[0], pass, 48) : 0;
    if (np)
        pl_step_times(v->chain[0], &v->last, ms);
    size_t n = (size_t)snprintf(line, sizeof line, "GPU ms:");
    for (uint32_t k = 0; k < np && n < sizeof line; k++) {
        if (n > 84) { /* the second line */
            text(px, 4, y, line, fg);
            y += 10;
            n = (size_t)snprintf(line, sizeof line, "       ");
        }
        n += (size_t)snprintf(line + n, sizeof line - n, "%s %s %.2f",
                              k && pass[k]->group != pass[k - 1]->group ? " |" : "",
                              pass[k]->name, ms[k]);
    }
    text(px, 4, y, line, fg);
    y += 10;
    snprintf(line, sizeof line, "camera (%.2f, %.2f, %.2f) yaw %.1f pitch %.1f   %s",
             v->cam.position[0], v->cam.position[1], v->cam.position[2],
             v->cam.yaw * 180.0 / TND_PI, v->cam.pitch * 180.0 / TND_PI, v->note);
    text(px, 4, y, line, fg);
    y += 10;
    char feat[160] = "";
    for (uint32_t b = 0, fn = 0; b < TND_FEATURE_COUNT; b++)
        if (v->scene->features & (1u << b))
            fn += (uint32_t)snprintf(feat + fn, fn < sizeof feat ? sizeof feat - fn : 0, "%s%s",
                                     fn ? " " : "", tnd_feature_name(b));
    /* the denoiser's parameters (pl_param) with their keys */
    n = 0;
    line[0] = 0;
    for (uint32_t k = 0; v->dn && k < v->dn->nparams && n < sizeof line; k++) {
        const pl_param *pp = v->dn->params[k];
        double x = pl_param_set_get(&s->params, pp->name);
        char val[32] = "default";
        if (x != 0)
            snprintf(val, sizeof val, "%g", x);
        n += (size_t)snprintf(line + n, sizeof line - n, "%s (%s) %s  ", pp->name,
                              pp->keys ? pp->keys : "-", val);
    }
    if (n < sizeof line)
        snprintf(line + n, sizeof line - n, "exposure bias %+.1f  env x%.2f %.0f deg  scene: %s",
                 s->exposure_bias, s->env_intensity, s->env_rotation, feat);
    text(px, 4, y, line, fg);
    y += 10;
    y += 10;
    text(px, 4, y, "WASD QE drag | 1 2 3 4 F [ ] P T K B , . M G - = 7 8 9 0 | V TAB R O | F12 F11 F5 ESC",
         fg);
    /* the frame-time graph: the last frames' wall clock, full height a multiple of 50 ms */
    int gy = OVERLAY_H - 4, gh = 50;
    double top = 50.0;
    for (uint32_t i = 0; i < v->graph_n && i < GRAPH; i++)
        top = fmax(top, 50.0 * ceil(v->graph[(v->graph_n - 1 - i) % GRAPH] / 50.0));
    snprintf(line, sizeof line, "frame time, last %d frames: 0 - %.0f ms", GRAPH, top);
    text(px, OVERLAY_W - 8 - 3 * GRAPH, gy - gh - 12, line, fg);
    for (uint32_t i = 0; i < v->graph_n && i < GRAPH; i++) {
        double fms = v->graph[(v->graph_n - 1 - i) % GRAPH];
        int hgt = (int)fmin(gh, fms / top * gh);
        int x = OVERLAY_W - 8 - 3 * (int)i;
        fill(px, x, gy - hgt, x + 2, gy, fms > 33.4 ? hot : bar);
    }
}
