/* app/cmd_view.c: `tandem view`: the pipeline live in a window. The frame is render's (the same
 * front-end and chain, built by rn_pipeline_open from the same options), the camera flies
 * (WASD/QE, mouse drag), keys change the knobs (each change restarts the history), V cycles the
 * views (the final image, every contract entry, the back-end's dumps, in false colour where it
 * helps), TAB splits the window (noisy | denoised), and an overlay shows the device, the GPU time
 * of every pass, a frame-time graph and the settings. F12 writes a screenshot with its repro
 * state (app/view_state.c), which `tandem render --view` reproduces frame for frame; F11 writes
 * the next frame's contract as a capture. --script FILE plays timed key, mouse and resize events
 * and exits: the tests drive the window that way under Xvfb. */
#include "app/app.h"
#include "eval/eval.h"
#include "pipeline/pipeline.h"
#include "shaders/shader_list.h"
#include "viewer/viewer.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <stb/stb_easy_font.h>

#ifndef TND_DATA_DIR
#define TND_DATA_DIR "data"
#endif

static const app_cmd view_cmd = {
    "view",
    "The pipeline live in a window: fly the camera (WASD, Q/E down/up, drag to look; shift\n"
    "faster, control slower), change the knobs (1/2/3/4/5 the registered denoisers in order\n"
    "(asvgf/svgf/off/recurrent), then the denoiser plugin, F front-end (the registered ones,\n"
    "then the front-end plugin), [ ] bounces (0, half, 1, 2, ...), P precision, T TAA, K\n"
    "tone curve, B bloom, the\n"
    "denoiser's parameters on their keys (, . a-trous iterations, M minimum alpha, G antilag\n"
    "gain, H recurrent's fast history, C its clamp: the overlay lists them), - = exposure bias, 7 8 environment rotation, 9 0 its intensity), V cycles\n"
    "the views (final, contract entries, back-end dumps), TAB the splits (noisy | denoised,\n"
    "denoiser A | B, front-end A | B), R a progressive reference of a still camera, X the\n"
    "relative error, then FLIP, against that reference, O the\n"
    "overlay, F12 writes a screenshot (PNG, EXR and its repro state for `tandem render\n"
    "--view`), F11 the next frame's capture, F5 reloads the shaders from $TANDEM_SHADER_DIR\n"
    "(scripts/compile-shaders.sh), ESC quits.",
    "[--scene PATH] [--frontend NAME] [--denoiser NAME] [--size WxH] [--state FILE] "
    "[--script FILE] [--out DIR]",
    NULL};

enum { GRAPH = 120, OVERLAY_W = 600, OVERLAY_H = 180 };

typedef struct script_event {
    uint32_t frame;
    enum { EV_KEY, EV_TAP, EV_MOUSE, EV_RESIZE, EV_SHOT, EV_EXIT, EV_WAIT } kind;
    char path[1024]; /* EV_WAIT: the file to wait for */
    int key;
    bool down, drag;
    double dx, dy;
    uint32_t w, h;
} script_event;

/* the views: the final image, then every contract entry, then the back-end's dumps */
static uint32_t view_count(void)
{
    return 1 + TND_CT_COUNT + dn_dump_count();
}

static void view_name(uint32_t v, char *buf, size_t cap)
{
    if (v == 0)
        snprintf(buf, cap, "final");
    else if (v <= TND_CT_COUNT)
        snprintf(buf, cap, "%s", tnd_ct_get((tnd_ct)(v - 1))->name);
    else
        snprintf(buf, cap, "dump:%s", dn_dump_name(v - 1 - TND_CT_COUNT, NULL));
}

static uint32_t view_find(const char *name)
{
    char buf[64];
    for (uint32_t v = 0; v < view_count(); v++) {
        view_name(v, buf, sizeof buf);
        if (strcmp(buf, name) == 0)
            return v;
    }
    return 0;
}

typedef struct viewer {
    rn_view_state st; /* the settings and the flight since the last restart */
    tnd_vk vk;
    vw_window *win;
    vw_compose *compose;
    tnd_scene *scene;
    pl_frontend *fe[2]; /* [1]: the noisy half of a split */
    pl_chain *chain[2];
    const pl_denoiser_info *dn; /* what runs in the left half */
    tnd_image shown, debug, overlay;
    uint8_t *overlay_px;
    float *debug_px;
    tnd_frame host;
    tnd_scene_state ss[2];
    uint32_t frame, steps; /* the scene's frame index; frames shown since the start */
    bool rebuild, reload, reload_shaders, show_overlay, ref_on, quit, want_shot, want_capture;
    rn_view_cam cam;
    bool keys[512];
    uint32_t view, ref_spp; /* ref_spp: the progressive reference's samples shown */
    float *ref_rgb;
    /* X: the error views against the progressive reference (0 off, 1 relative error, 2 FLIP),
     * their metrics on the device (eval/metrics_gpu.c) and the last mean */
    uint32_t err_view;
    ev_gpu *metrics;
    float *err_rgb, *err_map;
    double err_mean;
    char plugin_fe[1100]; /* a front-end plugin given at the start (F cycles to it) */
    char plugin_dn[1100]; /* a denoiser plugin given at the start (key 4) */
    double graph[GRAPH];
    uint32_t graph_n;
    pl_step_result last;
    const char *out;
    uint32_t shots, captures;
    char note[200];
    double t_last;
    bool scripted;
    rn_env scene_opts; /* the command line's scene options (the state's environment over them) */
    bool on_path;       /* following the scene's camera path until the camera is flown */
} viewer;

/* ---- input ----------------------------------------------------------------------------------- */
static const char *const split_modes[] = {"off", "noisy", "denoiser", "frontend"};
static const char *const curves[] = {"aces", "agx", "reinhard", "linear"};

static void set_note(viewer *v, const char *fmt, const char *arg)
{
    char a[120];
    size_t n = strlen(arg) < sizeof a - 1 ? strlen(arg) : sizeof a - 1;
    memcpy(a, arg, n);
    a[n] = 0;
    snprintf(v->note, sizeof v->note, fmt, a);
}

/* The live front-end registered after `name` (NULL: the first; NULL after the last). */
static const char *next_frontend(const char *name)
{
    bool after = name == NULL;
    for (uint32_t i = 0; pl_frontend_name_at(i); i++) {
        const char *n = pl_frontend_name_at(i);
        if (after && pl_frontend_live(n))
            return n;
        after = after || strcmp(n, name) == 0;
    }
    return NULL;
}

/* The split's other front-end: the next live one, wrapping. */
static const char *other_frontend(const char *name)
{
    const char *n = next_frontend(name);
    return n ? n : next_frontend(NULL);
}

static void on_key(viewer *v, int key, bool down)
{
    if (key >= 0 && key < 512)
        v->keys[key] = down;
    if (!down)
        return;
    rn_view_state *s = &v->st;
    const char *dn = NULL;
    /* 1, 2, ...: the registered denoisers in order, then the plugin given at the start */
    if (key >= '1' && key < '1' + (int)pl_denoiser_count())
        dn = pl_denoiser_at((uint32_t)(key - '1'))->name;
    else if (key == '1' + (int)pl_denoiser_count() && v->plugin_dn[0])
        dn = v->plugin_dn;
    /* the denoisers' parameters on their keys (pl_param: one key cycles, two step) */
    for (uint32_t i = 0; i < pl_param_count(); i++) {
        const pl_param *p = pl_param_at(i);
        const char *k = p->keys && key > 0 && key < 128 ? strchr(p->keys, key) : NULL;
        if (!k)
            continue;
        double x = pl_param_set_get(&s->params, p->name), next = 0;
        if (strlen(p->keys) == 1) { /* the next step after the current value */
            uint32_t j = 0;
            while (j < p->nsteps && p->steps[j] != x)
                j++;
            next = p->nsteps ? p->steps[(j + 1) % p->nsteps] : 0;
        } else if (k == p->keys) { /* down: from the default to the least */
            next = x == 0 ? p->min : fmax(p->min, x - 1);
        } else { /* up: from the default to the most */
            next = x == 0 ? p->max : fmin(p->max, x + 1);
        }
        if (pl_param_set_put(&s->params, p->name, next) == TND_OK)
            v->rebuild = true;
    }
    switch (key) {
    case 'F': { /* the next live front-end of the registry (then the plugin given) */
        const char *next = next_frontend(s->frontend);
        if (!next && v->plugin_fe[0] && strcmp(s->frontend, v->plugin_fe) != 0)
            next = v->plugin_fe;
        snprintf(s->frontend, sizeof s->frontend, "%s", next ? next : next_frontend(NULL));
        v->rebuild = true;
        set_note(v, "front-end %s", s->frontend);
        break;
    }
    case '-': case '=':
        s->exposure_bias += key == '-' ? -0.5 : 0.5;
        v->rebuild = true;
        break;
    case '7': case '8':
        s->env_rotation = fmod(s->env_rotation + (key == '7' ? -15.0 : 15.0) + 360.0, 360.0);
        v->reload = true;
        break;
    case '9': case '0':
        s->env_intensity *= key == '9' ? 0.5 : 2.0;
        v->reload = true;
        break;
    case 'R':
        v->ref_on = !v->ref_on;
        v->ref_spp = 0;
        break;
    case 'X':
        v->err_view = (v->err_view + 1) % 3;
        v->ref_spp = 0;
        break;
    case '[': case ']': /* 0, half (one at half resolution), 1, 2, ... 16 */
        if (key == '[' && s->half_indirect)
            s->half_indirect = 0, s->bounces = 0;
        else if (key == '[' && s->bounces == 1)
            s->half_indirect = 1;
        else if (key == '[' && s->bounces > 0)
            s->bounces--;
        else if (key == ']' && s->bounces == 0)
            s->half_indirect = 1, s->bounces = 1;
        else if (key == ']' && s->half_indirect)
            s->half_indirect = 0;
        else if (key == ']' && s->bounces < 16)
            s->bounces++;
        v->rebuild = true;
        break;
    case 'P':
        snprintf(s->precision, sizeof s->precision, "%s",
                 strcmp(s->precision, "float32") == 0 ? "packed" : "float32");
        v->rebuild = true;
        set_note(v, "precision %s", s->precision);
        break;
    case 'T':
        snprintf(s->taa, sizeof s->taa, "%s", strcmp(s->taa, "off") == 0 ? "on" : "off");
        v->rebuild = true;
        break;
    case 'K': {
        int k = 0;
        while (k < 4 && strcmp(curves[k], s->tonemap) != 0)
            k++;
        snprintf(s->tonemap, sizeof s->tonemap, "%s", curves[(k + 1) % 4]);
        v->rebuild = true;
        break;
    }
    case 'B':
        s->bloom = s->bloom > 0 ? 0.0 : 0.05;
        v->rebuild = true;
        break;
    case 'V': {
        v->view = (v->view + 1) % view_count();
        char nm[64];
        view_name(v->view, nm, sizeof nm);
        snprintf(s->view, sizeof s->view, "%s", nm);
        break;
    }
    case 258: { /* TAB: off, noisy | denoised, denoiser A | B, front-end A | B */
        int k = 0;
        while (k < 4 && strcmp(split_modes[k], s->split_mode) != 0)
            k++;
        snprintf(s->split_mode, sizeof s->split_mode, "%s", split_modes[(k + 1) % 4]);
        /* the other denoiser: its ablation (or what it ablates); the other front-end */
        const pl_denoiser_info *d = NULL;
        if (pl_denoiser_find(s->denoiser, &d) != TND_OK)
            d = pl_denoiser_at(0);
        snprintf(s->split_denoiser, sizeof s->split_denoiser, "%s", pl_denoiser_other(d)->name);
        snprintf(s->split_frontend, sizeof s->split_frontend, "%s", other_frontend(s->frontend));
        v->rebuild = true;
        set_note(v, "split %s", s->split_mode);
        break;
    }
    case 'O': v->show_overlay = !v->show_overlay; break;
    case 301: v->want_shot = true; break;    /* F12 */
    case 300: v->want_capture = true; break; /* F11 */
    case 294: /* F5: the shaders again from $TANDEM_SHADER_DIR */
        v->reload_shaders = true;
        v->rebuild = true;
        break;
    case 256: v->quit = true; break;         /* ESC */
    default: break;
    }
    if (dn) {
        snprintf(s->denoiser, sizeof s->denoiser, "%s", dn);
        v->rebuild = true;
        set_note(v, "denoiser %s", dn);
    }
}

/* The scene options: the command line's, with the state's environment. */
static rn_env scene_options(const viewer *v)
{
    rn_env e = v->scene_opts;
    e.path = v->st.env[0] ? v->st.env : NULL;
    e.intensity = v->st.env_intensity;
    e.rotation = v->st.env_rotation;
    e.up = v->st.up[0] ? v->st.up : "y";
    e.no_default_light = v->st.no_default_light != 0;
    return e;
}

static void on_event(const vw_event *e, void *user)
{
    viewer *v = user;
    if (e->kind == VW_KEY)
        on_key(v, e->key, e->down);
    else if (e->kind == VW_MOUSE && e->drag) {
        v->ref_spp = 0; /* (the reference starts again) */
        v->on_path = false;
        v->cam.yaw += 0.004 * e->dx;
        v->cam.pitch = fmax(-1.5, fmin(1.5, v->cam.pitch - 0.004 * e->dy));
    } else if (e->kind == VW_RESIZE) {
        v->rebuild = true;
    }
}

/* the camera moves by the keys held: `dt` seconds at 1.5 scene units per second (shift x4,
 * control x0.25) */
static void fly(viewer *v, double dt)
{
    double speed = 1.5 * dt * (v->keys[340] ? 4.0 : 1.0) * (v->keys[341] ? 0.25 : 1.0);
    double cy = cos(v->cam.yaw), sy = sin(v->cam.yaw), cp = cos(v->cam.pitch);
    double f[3] = {sy * cp, sin(v->cam.pitch), -cy * cp}, r[3] = {cy, 0, sy};
    double m[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) {
        m[k] += (v->keys['W'] - v->keys['S']) * f[k] + (v->keys['D'] - v->keys['A']) * r[k];
        if (k == 1)
            m[k] += v->keys['E'] - v->keys['Q'];
    }
    for (int k = 0; k < 3; k++)
        v->cam.position[k] += speed * m[k];
    if (m[0] != 0 || m[1] != 0 || m[2] != 0)
        v->ref_spp = 0, v->on_path = false;
}

static bool split(const rn_view_state *s)
{
    return s->split_mode[0] && strcmp(s->split_mode, "off") != 0;
}

/* ---- the pipeline ------------------------------------------------------------------------------ */
static void close_pipeline(viewer *v)
{
    for (int i = 0; i < 2; i++) {
        pl_chain_destroy(v->chain[i]);
        pl_frontend_destroy(v->fe[i]);
        v->chain[i] = NULL;
        v->fe[i] = NULL;
    }
    tnd_image_destroy(&v->vk, &v->shown);
    tnd_image_destroy(&v->vk, &v->debug);
    tnd_frame_destroy(&v->host);
    free(v->debug_px);
    v->debug_px = NULL;
    free(v->ref_rgb);
    v->ref_rgb = NULL;
    ev_gpu_destroy(v->metrics);
    v->metrics = NULL;
    free(v->err_rgb);
    free(v->err_map);
    v->err_rgb = v->err_map = NULL;
}


static tnd_result open_pipeline(viewer *v)
{
    tnd_result res = TND_OK;
    close_pipeline(v);
    rn_view_state *s = &v->st;
    tnd_precision prec;
    TND_TRY(tnd_precision_parse(s->precision, &prec));
    for (int i = 0; i < (split(s) ? 2 : 1); i++) {
        /* the right half: the noisy input, the other denoiser, or the other front-end */
        const char *dn = i == 0                                     ? s->denoiser
                         : strcmp(s->split_mode, "noisy") == 0    ? "off"
                         : strcmp(s->split_mode, "denoiser") == 0 ? s->split_denoiser
                                                                    : s->denoiser;
        const pl_denoiser_info *info;
        TND_TRY(pl_denoiser_find(dn, &info));
        rn_render_opts o;
        rn_render_defaults(&o); /* (the viewer's frame is render's) */
        rn_view_state_options(s, &o);
        o.denoiser = dn;
        o.quiet = true; /* (its state keeps every parameter; a denoiser takes its own) */
        if (i == 1 && strcmp(s->split_mode, "frontend") == 0)
            o.frontend = s->split_frontend;
        cmp_desc pd;
        rn_host h = app_host();
        TND_TRY(rn_pipeline_open(&o, v->scene, &v->vk, pl_frontend_needs_gpu(o.frontend), true,
                                 prec, &info, false, &v->fe[i], &v->chain[i], &pd, &h));
        if (i == 0)
            v->dn = info;
    }
    uint32_t w = s->size[0], h = s->size[1];
    TND_TRY(tnd_image_create(&v->vk, &(tnd_image_desc){.width = w, .height = h,
                                                      .format = VK_FORMAT_R8G8B8A8_UNORM,
                                                      .name = "view.shown"},
                             &v->shown));
    TND_TRY(tnd_image_create(&v->vk, &(tnd_image_desc){.width = w, .height = h,
                                                      .format = VK_FORMAT_R32G32B32A32_SFLOAT,
                                                      .name = "view.debug"},
                             &v->debug));
    if (!(v->debug_px = malloc((size_t)w * h * 16)) ||
        !(v->ref_rgb = malloc((size_t)w * h * 3 * sizeof(float))) ||
        !(v->err_rgb = malloc((size_t)w * h * 3 * sizeof(float))) ||
        !(v->err_map = malloc((size_t)w * h * sizeof(float)))) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
        goto fail;
    }
    TND_TRY(tnd_frame_create(w, h, &v->host));
    /* the history restarts: a new flight */
    rn_view_state_restart(s);
    v->ref_spp = 0;
    v->rebuild = false;
fail:
    return res;
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
                case TND_CT_ROUGHNESS: case TND_CT_METALLIC:
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

static tnd_result debug_view(viewer *v)
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
static tnd_result error_view(viewer *v)
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
static tnd_result progressive_reference(viewer *v)
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

static void draw_overlay(viewer *v, const char *device, double fps)
{
    uint8_t *px = v->overlay_px;
    const uint8_t bg[4] = {0, 0, 0, 150}, fg[4] = {235, 235, 235, 255},
                  bar[4] = {80, 200, 120, 230}, hot[4] = {240, 120, 60, 230};
    fill(px, 0, 0, OVERLAY_W, OVERLAY_H, bg);
    const rn_view_state *s = &v->st;
    char line[400], who[300], vn[64];
    view_name(v->view, vn, sizeof vn);
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
    snprintf(line, sizeof line, "denoiser %.60s  bounces %s  %s  TAA %s  %s  bloom %.2f",
             v->chain[0] && pl_chain_plugin_name(v->chain[0]) ? s->denoiser : v->dn->name, nb,
             s->precision, s->taa, s->tonemap, s->bloom);
    text(px, 4, y, line, fg);
    y += 10;
    char sp[200] = "";
    if (split(s))
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

/* ---- screenshots ----------------------------------------------------------------------------- */
/* The flight since the last restart as a camera path file (--camera-path FILE.json): a key per
 * frame at its scene time, looking where the camera looked, with the camera's field of view. */
static tnd_result write_camera_path(const viewer *v, const char *path)
{
    const rn_view_state *s = &v->st;
    tnd_camera_key *keys = calloc(s->path_len ? 2 * s->path_len : 1, sizeof *keys);
    if (!keys)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
    float yfov = s->camera < v->scene->camera_count ? v->scene->cameras[s->camera].yfov : 0.8f;
    uint32_t n = 0;
    for (uint32_t i = 0; i < 2 * s->path_len; i++) { /* (a held camera: its first and last) */
        const rn_view_cam *c = &s->path[i / 2];
        if (i % 2 && c->frames == 1)
            continue;
        double cp = cos(c->pitch), at[3] = {c->position[0] + sin(c->yaw) * cp,
                                            c->position[1] + sin(c->pitch),
                                            c->position[2] - cos(c->yaw) * cp};
        tnd_camera_key *k = &keys[n];
        k->time = (c->frame + (i % 2 ? c->frames - 1 : 0)) / s->fps;
        if (n > 0 && !(k->time > keys[n - 1].time))
            continue;
        for (int j = 0; j < 3; j++)
            k->position[j] = (float)c->position[j];
        k->yfov = yfov;
        if (tnd_quat_look_at(c->position, at, k->rotation))
            n++;
    }
    tnd_result r = tnd_camera_path_write(path, keys, n);
    free(keys);
    return r;
}

static tnd_result screenshot(viewer *v)
{
    tnd_result res = TND_OK;
    uint32_t w = v->st.size[0], h = v->st.size[1];
    size_t n = (size_t)w * h;
    uint8_t *rgb8 = malloc(n * 3), *shown = malloc(n * 4);
    float *rgb = malloc(n * 3 * sizeof *rgb);
    char path[2200];
    if (!rgb8 || !shown || !rgb) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
        goto fail;
    }
    cmp_context *post = pl_chain_post(v->chain[0]);
    TND_TRY(pl_chain_finish(v->chain[0], NULL));
    TND_TRY(cmp_download_display(post, rgb8));
    snprintf(path, sizeof path, "%s/shot_%04u.png", v->out, v->shots);
    TND_TRY(rn_write_png(path, rgb8, w, h));
    TND_TRY(cmp_download_hdr(post, rgb));
    snprintf(path, sizeof path, "%s/shot_%04u.exr", v->out, v->shots);
    TND_TRY(rn_write_rgb_exr(path, rgb, w, h));
    TND_TRY(tnd_image_download(&v->vk, &v->shown, shown, n * 4)); /* as shown */
    for (size_t q = 0; q < n; q++)
        memcpy(rgb8 + 3 * q, shown + 4 * q, 3);
    snprintf(path, sizeof path, "%s/shot_%04u.view.png", v->out, v->shots);
    TND_TRY(rn_write_png(path, rgb8, w, h));
    snprintf(path, sizeof path, "%s/shot_%04u.json", v->out, v->shots);
    TND_TRY(rn_view_state_write(path, &v->st));
    snprintf(path, sizeof path, "%s/shot_%04u.path.json", v->out, v->shots);
    TND_TRY(write_camera_path(v, path));
    if (!app_quiet())
        fprintf(stderr, "tandem: view: %s/shot_%04u.{png,exr,view.png,json,path.json} (frame %u)\n",
                v->out, v->shots, v->frame - 1);
    v->shots++;
fail:
    free(rgb8);
    free(shown);
    free(rgb);
    return res;
}

/* ---- the script -------------------------------------------------------------------------------- */
static tnd_result load_script(const char *path, script_event **out, uint32_t *count)
{
    tnd_result res = TND_OK;
    void *buf = NULL;
    size_t n = 0;
    *out = NULL;
    *count = 0;
    TND_TRY_RETURN(tnd_file_read(path, &buf, &n));
    cJSON *j = cJSON_ParseWithLength(buf, n), *e;
    free(buf);
    const cJSON *evs = cJSON_GetObjectItem(j, "events");
    if (!j || !cJSON_IsArray(evs)) {
        cJSON_Delete(j);
        return tnd_fail(TND_ERR_BAD_INPUT, "view script %s: {\"events\": [...]} expected", path);
    }
    script_event *ev = calloc((size_t)cJSON_GetArraySize(evs) + 1, sizeof *ev);
    if (!ev) {
        cJSON_Delete(j);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
    }
    uint32_t k = 0;
    cJSON_ArrayForEach(e, evs)
    {
        script_event s = {0};
        const cJSON *f = cJSON_GetObjectItem(e, "frame"), *key = cJSON_GetObjectItem(e, "key");
        const cJSON *mouse = cJSON_GetObjectItem(e, "mouse"), *rs = cJSON_GetObjectItem(e, "resize");
        if (!cJSON_IsNumber(f) || f->valuedouble < 0 || (k && f->valuedouble < ev[k - 1].frame)) {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "view script %s: event %u: \"frame\" (frames shown so far, in order) "
                           "expected", path, k);
            goto fail;
        }
        s.frame = (uint32_t)f->valuedouble;
        if (cJSON_IsString(key)) {
            s.key = vw_key_code(key->valuestring);
            if (s.key < 0) {
                res = tnd_fail(TND_ERR_BAD_INPUT, "view script %s: event %u: key \"%s\" unknown",
                               path, k, key->valuestring);
                goto fail;
            }
            const cJSON *down = cJSON_GetObjectItem(e, "down");
            s.kind = down ? EV_KEY : EV_TAP;
            s.down = cJSON_IsTrue(down);
        } else if (cJSON_GetArraySize(mouse) == 2) {
            s.kind = EV_MOUSE;
            s.dx = cJSON_GetArrayItem(mouse, 0)->valuedouble;
            s.dy = cJSON_GetArrayItem(mouse, 1)->valuedouble;
            s.drag = !cJSON_IsFalse(cJSON_GetObjectItem(e, "drag"));
        } else if (cJSON_GetArraySize(rs) == 2 && cJSON_GetArrayItem(rs, 0)->valuedouble >= 16 &&
                   cJSON_GetArrayItem(rs, 1)->valuedouble >= 16) {
            s.kind = EV_RESIZE;
            s.w = (uint32_t)cJSON_GetArrayItem(rs, 0)->valuedouble;
            s.h = (uint32_t)cJSON_GetArrayItem(rs, 1)->valuedouble;
        } else if (cJSON_IsTrue(cJSON_GetObjectItem(e, "screenshot"))) {
            s.kind = EV_SHOT;
        } else if (cJSON_IsTrue(cJSON_GetObjectItem(e, "exit"))) {
            s.kind = EV_EXIT;
        } else if (cJSON_IsString(cJSON_GetObjectItem(e, "wait_for")) &&
                   strlen(cJSON_GetObjectItem(e, "wait_for")->valuestring) < sizeof s.path) {
            s.kind = EV_WAIT;
            strcpy(s.path, cJSON_GetObjectItem(e, "wait_for")->valuestring);
        } else {
            res = tnd_fail(TND_ERR_BAD_INPUT,
                           "view script %s: event %u: one of key, mouse [dx, dy], resize [w, h] "
                           "(16 or more), screenshot, wait_for (a file) or exit expected", path,
                           k);
            goto fail;
        }
        ev[k++] = s;
    }
    *out = ev;
    *count = k;
    ev = NULL;
fail:
    free(ev);
    cJSON_Delete(j);
    return res;
}

/* Apply the script's events of this frame; a resize waits (2 s at most) for the window. */
static tnd_result play(viewer *v, const script_event *ev, uint32_t n, uint32_t *next)
{
    while (*next < n && ev[*next].frame <= v->steps) {
        const script_event *e = &ev[(*next)++];
        switch (e->kind) {
        case EV_KEY: on_key(v, e->key, e->down); break;
        case EV_TAP:
            on_key(v, e->key, true);
            on_key(v, e->key, false);
            break;
        case EV_MOUSE:
            on_event(&(vw_event){.kind = VW_MOUSE, .dx = e->dx, .dy = e->dy, .drag = e->drag}, v);
            break;
        case EV_RESIZE: {
            vw_window_set_size(v->win, e->w, e->h);
            double t0 = tnd_now();
            uint32_t w = 0, h = 0;
            while (tnd_now() - t0 < 2.0) {
                vw_window_poll(v->win);
                vw_window_size(v->win, &w, &h);
                if (w == e->w && h == e->h)
                    break;
            }
            if (w != e->w || h != e->h)
                return tnd_fail(TND_ERR_UNSUPPORTED,
                                "view: the window system kept the window at %ux%u (asked %ux%u)",
                                w, h, e->w, e->h);
            v->rebuild = true;
            break;
        }
        case EV_SHOT: v->want_shot = true; break;
        case EV_WAIT: { /* until another process made the file (30 s at most) */
            double t0 = tnd_now();
            FILE *fp = NULL;
            while (!(fp = fopen(e->path, "rb")) && tnd_now() - t0 < 30.0) {
                vw_window_poll(v->win);
                struct timespec ts = {0, 20 * 1000 * 1000};
                nanosleep(&ts, NULL);
            }
            if (!fp)
                return tnd_fail(TND_ERR_IO, "view: script: %s did not appear in 30 s", e->path);
            fclose(fp);
            break;
        }
        case EV_EXIT: v->quit = true; break;
        }
    }
    return TND_OK;
}

/* ---- the loop ---------------------------------------------------------------------------------- */
static tnd_result frame(viewer *v)
{
    tnd_result res = TND_OK;
    rn_view_state *s = &v->st;
    uint32_t w = s->size[0], h = s->size[1];
    float aspect = (float)w / (float)h;
    uint32_t f = v->frame;
    bool first = s->path_len == 0;
    tnd_scene_state *cur = &v->ss[f & 1], *prev = &v->ss[(f + 1) & 1];
    TND_TRY(tnd_scene_evaluate(v->scene, f / s->fps, s->camera, aspect, cur));
    if (v->on_path) /* --camera-path: the path's camera until the camera is flown */
        rn_view_camera_from_state(cur, f, &v->cam), v->ref_spp = 0;
    v->cam.frame = f;
    rn_view_camera_apply(&v->cam, cur);
    if (first) { /* as render --view: the previous frame at the same camera */
        TND_TRY(tnd_scene_evaluate(v->scene, f > 0 ? (f - 1) / s->fps : 0.0, s->camera, aspect,
                                   prev));
        rn_view_camera_apply(&v->cam, prev);
    }
    TND_TRY(rn_view_state_push(s, &v->cam));
    char cap[2200];
    snprintf(cap, sizeof cap, "%s/capture_%04u.exr", v->out, v->captures);
    for (int i = 0; i < (split(s) ? 2 : 1); i++) {
        TND_TRY(pl_frontend_set_frame(v->fe[i], cur, prev, f, w, h));
        pl_step step = {.params = {.bounces = s->bounces, .half_indirect = s->half_indirect != 0},
                        .frame = dn_frame_for_camera(cur->camera.proj, h, f, first),
                        .dt = (float)(1.0 / s->fps),
                        .capture = i == 0 && v->want_capture ? cap : NULL,
                        .no_wait = true};
        pl_step_result r;
        TND_TRY(pl_chain_run(v->chain[i], v->fe[i], &step, NULL, NULL, &r));
        if (i == 0 && r.lagged)
            v->last = r;
    }
    if (v->want_capture) {
        if (!app_quiet())
            fprintf(stderr, "tandem: view: %s\n", cap);
        v->captures++;
        v->want_capture = false;
    }
    bool can_ref = (pl_frontend_caps(v->fe[0]) & PL_CAP_REFERENCE) != 0;
    bool shown_debug = v->view || v->ref_on || (v->err_view && can_ref);
    if (v->err_view && can_ref)
        TND_TRY(error_view(v));
    else if (v->ref_on && can_ref)
        TND_TRY(progressive_reference(v));
    else if (v->view)
        TND_TRY(debug_view(v));
    /* A (the main pipeline, or its view) on the left, B on the right */
    const tnd_image *a = shown_debug ? &v->debug : cmp_display_image(pl_chain_post(v->chain[0]));
    const tnd_image *b = split(s) ? cmp_display_image(pl_chain_post(v->chain[1])) : NULL;
    TND_TRY(tnd_image_upload(&v->vk, &v->overlay, v->overlay_px,
                             (size_t)OVERLAY_W * OVERLAY_H * 4));
    TND_TRY(vw_compose_run(v->compose, a, b, (int)w / 2, &v->overlay, &v->shown));
    TND_TRY(vw_window_present(v->win, &v->shown));
    v->frame++; /* (scene time follows the frame: render --view replays it)*/
fail:
    return res;
}

int cmd_view(int argc, char **argv)
{
    viewer *v = calloc(1, sizeof *v);
    if (!v)
        return app_report("view", tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory"));
    const char *scene = TND_DATA_DIR "/scenes/cornell.gltf", *frontend = "vk",
               *denoiser = pl_denoiser_default(), *state = NULL, *script = NULL, *out = ".";
    unsigned size[2] = {640, 360}, frames = 0;
    bool soak = false, json = false;
    rn_soak_rec *rec = NULL;
    rn_env env = RN_ENV_INIT;
    char fe_help[200], dn_help[300];
    snprintf(fe_help, sizeof fe_help, "the front-end: %s (default vk)", pl_frontend_live_names());
    snprintf(dn_help, sizeof dn_help,
             "the denoiser: %s, plugin:PATH.so or python:MODULE:CALLABLE (default %s)",
             pl_denoiser_names(), pl_denoiser_default());
    const app_opt opts[] = {
        {"scene", APP_OPT_STRING, &scene, "PATH", "glTF scene (default: cornell)"},
        {"frontend", APP_OPT_STRING, &frontend, "NAME", fe_help},
        {"denoiser", APP_OPT_STRING, &denoiser, "NAME", dn_help},
        {"size", APP_OPT_SIZE, size, "WxH", "window size (default 640x360)"},
        {"state", APP_OPT_STRING, &state, "FILE",
         "start from a repro state (a screenshot's .json)"},
        {"script", APP_OPT_STRING, &script, "FILE",
         "play timed key, mouse and resize events, then exit (docs/viewer.md)"},
        {"frames", APP_OPT_UINT, &frames, "N", "exit after N frames (default: when closed)"},
        {"soak", APP_OPT_FLAG, &soak, NULL,
         "with --frames N: sample memory, descriptors and device allocations over the viewer's "
         "loop and print whether they stay flat, as bench --soak does (docs/reliability.md)"},
        {"json", APP_OPT_FLAG, &json, NULL, "--soak's figures as JSON, with every sample"},
        {"out", APP_OPT_STRING, &out, "DIR", "where screenshots and captures go (default .)"},
        APP_ENV_OPTS(&env),
        {0},
    };
    const char *pos[1];
    int npos, status = APP_EXIT_FAIL;
    int rc = app_parse(&view_cmd, opts, argc, argv, pos, 0, &npos);
    if (rc >= 0) {
        free(v);
        return rc;
    }
    if (soak && !frames) {
        free(v);
        fprintf(stderr, "tandem view: --soak needs --frames N (the frames it judges)\n");
        return APP_EXIT_USAGE;
    }
    tnd_result res = TND_OK;
    script_event *events = NULL;
    uint32_t n_events = 0, next_event = 0;
    rn_view_state *s = &v->st;
    *s = (rn_view_state){.bounces = 1, .fps = 30.0, .env_intensity = env.intensity,
                          .env_rotation = env.rotation, .size = {size[0], size[1]}};
    snprintf(s->scene, sizeof s->scene, "%s", scene);
    snprintf(s->frontend, sizeof s->frontend, "%s", frontend);
    snprintf(s->denoiser, sizeof s->denoiser, "%s", denoiser);
    snprintf(s->precision, sizeof s->precision, "float32");
    snprintf(s->taa, sizeof s->taa, "on");
    snprintf(s->tonemap, sizeof s->tonemap, "aces");
    snprintf(s->exposure, sizeof s->exposure, "auto");
    snprintf(s->env, sizeof s->env, "%s", env.path ? env.path : "");
    snprintf(s->up, sizeof s->up, "%s", env.up ? env.up : "y"); /* (checked as the scene loads) */
    s->no_default_light = env.no_default_light;
    snprintf(s->view, sizeof s->view, "final");
    snprintf(s->split_mode, sizeof s->split_mode, "off");
    bool from_state = false;
    if (state) { /* its settings, and its last camera */
        TND_TRY(rn_view_state_read(state, s));
        from_state = s->path_len > 0;
        if (from_state)
            v->cam = s->path[s->path_len - 1];
        v->view = view_find(s->view);
    }
    v->out = out;
    if (strncmp(s->frontend, "plugin:", 7) == 0)
        memcpy(v->plugin_fe, s->frontend, sizeof v->plugin_fe);
    if (strncmp(s->denoiser, "plugin:", 7) == 0)
        memcpy(v->plugin_dn, s->denoiser, sizeof v->plugin_dn);
    v->show_overlay = true;
    if (script) {
        TND_TRY(load_script(script, &events, &n_events));
        v->scripted = true;
    }
    TND_TRY(tnd_mkdirs(out));
    TND_TRY(vw_window_create("tandem view", s->size[0], s->size[1], on_event, v, &v->win));
    uint32_t n_ext = 0;
    const char *const *ext = vw_window_instance_extensions(&n_ext);
    TND_TRY(tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = !pl_frontend_needs_gpu(s->frontend),
                                         .instance_extensions = ext,
                                         .instance_extension_count = n_ext,
                                         .swapchain = true},
                          &v->vk));
    TND_TRY(vw_window_attach(v->win, &v->vk));
    TND_TRY(vw_compose_create(&v->vk, &v->compose));
    TND_TRY(tnd_image_create(&v->vk, &(tnd_image_desc){.width = OVERLAY_W, .height = OVERLAY_H,
                                                      .format = VK_FORMAT_R8G8B8A8_UNORM,
                                                      .name = "view.overlay"},
                             &v->overlay));
    if (!(v->overlay_px = calloc((size_t)OVERLAY_W * OVERLAY_H, 4))) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
        goto fail;
    }
    v->scene_opts = env;
    rn_env scene_env = scene_options(v);
    TND_TRY(rn_scene_load(s->scene, &scene_env, &v->scene));
    v->on_path = v->scene->camera_path[0] && s->camera == 0 && !from_state;
    if (!from_state) { /* the scene's camera at the first frame */
        tnd_scene_state st0 = {0};
        res = tnd_scene_evaluate(v->scene, 0.0, s->camera, (float)s->size[0] / s->size[1], &st0);
        if (res == TND_OK)
            rn_view_camera_from_state(&st0, 0, &v->cam);
        tnd_scene_state_free(&st0);
        TND_TRY(res);
    } else {
        v->frame = s->path[s->path_len - 1].frame + s->path[s->path_len - 1].frames;
    }
    TND_TRY(open_pipeline(v));
    char device[300];
    snprintf(device, sizeof device, "%s", v->vk.info.name);
    if (soak && !(rec = rn_soak_rec_begin(frames))) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
        goto fail;
    }
    v->t_last = tnd_now();
    double avg_dt = 0, t_start = tnd_now();
    while (!v->quit && !app_interrupted() && vw_window_poll(v->win)) {
        if (v->scripted)
            TND_TRY(play(v, events, n_events, &next_event));
        uint32_t w, h;
        vw_window_size(v->win, &w, &h);
        if (w == 0 || h == 0) /* minimised */
            continue;
        if (w != s->size[0] || h != s->size[1]) {
            s->size[0] = w;
            s->size[1] = h;
            v->rebuild = true;
        }
        if (v->reload) { /* the environment changed: the scene again */
            close_pipeline(v);
            tnd_scene_destroy(v->scene);
            v->scene = NULL;
            rn_env e = scene_options(v);
            TND_TRY(rn_scene_load(s->scene, &e, &v->scene));
            v->reload = false;
            v->rebuild = true;
        }
        if (v->reload_shaders) { /* every pipeline again, the compositor's too */
            close_pipeline(v);
            vw_compose_destroy(v->compose);
            v->compose = NULL;
            uint32_t n = tnd_spirv_reload();
            char msg[64];
            snprintf(msg, sizeof msg, "%u", n);
            set_note(v, "%s shaders from TANDEM_SHADER_DIR", msg);
            if (!app_quiet())
                fprintf(stderr, "tandem: view: %s\n", v->note);
            TND_TRY(vw_compose_create(&v->vk, &v->compose));
            v->reload_shaders = false;
        }
        if (v->rebuild)
            TND_TRY(open_pipeline(v));
        double now = tnd_now(), dt = now - v->t_last;
        v->t_last = now;
        fly(v, v->scripted ? 1.0 / s->fps : fmin(dt, 0.1));
        v->graph[v->graph_n++ % GRAPH] = 1e3 * dt;
        avg_dt = avg_dt > 0 ? 0.9 * avg_dt + 0.1 * dt : dt;
        double fps = avg_dt > 0 ? 1.0 / avg_dt : 0.0;
        if (v->show_overlay)
            draw_overlay(v, device, fps);
        else
            memset(v->overlay_px, 0, (size_t)OVERLAY_W * OVERLAY_H * 4);
        TND_TRY(frame(v));
        v->steps++;
        rn_soak_rec_frame(rec, v->steps - 1, frames && v->steps >= frames, &v->vk);
        if (v->want_shot) {
            v->want_shot = false;
            TND_TRY(screenshot(v));
        }
        if (frames && v->steps >= frames)
            break;
        if (v->scripted && next_event >= n_events && !v->want_shot)
            break; /* the script ran out */
    }
    if (v->vk.validation && tnd_vk_validation_errors(&v->vk)) {
        res = tnd_fail(TND_ERR_VULKAN, "%u Vulkan validation error(s)",
                       tnd_vk_validation_errors(&v->vk));
        goto fail;
    }
    if (!app_quiet())
        fprintf(stderr, "tandem: view: %u frames in %.2f s (%.1f fps) at %ux%u on %s, %u "
                "screenshot%s\n", v->steps, tnd_now() - t_start,
                v->steps / fmax(1e-9, tnd_now() - t_start), s->size[0], s->size[1], device,
                v->shots, v->shots == 1 ? "" : "s");
    if (rec) { /* (the front-end and denoiser the loop ended with) */
        rn_soak_rec_end(rec, v->steps, s->frontend, s->denoiser);
        if (json) {
            cJSON *root = cJSON_CreateObject(), *runs = cJSON_AddArrayToObject(root, "runs");
            cJSON_AddStringToObject(root, "scene", s->scene);
            cJSON_AddNumberToObject(root, "frames", v->steps);
            cJSON_AddNumberToObject(root, "width", s->size[0]);
            cJSON_AddNumberToObject(root, "height", s->size[1]);
            cJSON *row = rn_soak_rec_json(rec);
            cJSON_AddBoolToObject(root, "flat", cJSON_IsTrue(cJSON_GetObjectItem(row, "flat")));
            cJSON_AddItemToArray(runs, row);
            char *t = cJSON_Print(root);
            printf("%s\n", t ? t : "{}");
            free(t);
            cJSON_Delete(root);
        } else {
            app_soak_print(rec, "in the viewer's loop", s->scene, s->size);
        }
    }
    status = APP_EXIT_OK;
    if (app_interrupted()) { /* (the window closed as by its close button: screenshots kept) */
        fprintf(stderr, "tandem: view: interrupted (%s)\n", rn_signal_name(app_interrupted()));
        status = app_interrupt_status();
    }
fail:
    if (status == APP_EXIT_FAIL)
        app_report("view", res);
    if (v->vk.device) {
        vkDeviceWaitIdle(v->vk.device);
        close_pipeline(v);
        tnd_image_destroy(&v->vk, &v->overlay);
        vw_compose_destroy(v->compose);
    }
    vw_window_destroy(v->win);
    tnd_scene_state_free(&v->ss[0]);
    tnd_scene_state_free(&v->ss[1]);
    tnd_scene_destroy(v->scene);
    if (v->vk.device || v->vk.instance)
        tnd_vk_destroy(&v->vk);
    rn_view_state_free(s);
    free(v->overlay_px);
    free(events);
    rn_soak_rec_free(rec);
    free(v);
    return status;
}
