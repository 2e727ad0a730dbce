/* viewer/vw_session.c: `tandem view`: the pipeline live in a window. The frame is render's (the same
 * front-end and chain, built by rn_pipeline_open from the same options), the camera flies
 * (WASD/QE, mouse drag), keys change the knobs (each change restarts the history), V cycles the
 * views (the final image, every contract entry, the back-end's dumps, in false colour where it
 * helps), TAB splits the window (noisy | denoised), and an overlay shows the device, the GPU time
 * of every pass, a frame-time graph and the settings. F12 writes a screenshot with its repro
 * state (run/rn_view_state.c), which `tandem render --view` reproduces frame for frame; F11 writes
 * the next frame's contract as a capture. --script FILE plays timed key, mouse and resize events
 * and exits: the tests drive the window that way under Xvfb. Entry point: vw_view_run. */
#include "viewer/vw_internal.h"
#include "shaders/shader_list.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* Whether the front-end traces fewer pixels than the window shows (U). */
static bool scaled(const rn_view_state *s)
{
    return s->render_scale > 0 && s->render_scale < 1;
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

void vw_on_key(viewer *v, int key, bool down)
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
        if (scaled(s)) {
            set_note(v, "%s", "the reference needs render scale 1 (U)");
            break;
        }
        v->ref_on = !v->ref_on;
        v->ref_spp = 0;
        break;
    case 'X':
        if (scaled(s)) {
            set_note(v, "%s", "the error views need render scale 1 (U)");
            break;
        }
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
    case 'U': { /* the render scale: 1, 2/3, 1/2 (traced smaller, upscaled to the window) */
        double sc = s->render_scale > 0 ? s->render_scale : 1.0;
        s->render_scale = sc > 0.9 ? 0.67 : sc > 0.6 ? 0.5 : 1.0;
        if (s->render_scale < 1) /* (the views read the contract and the dumps at the window's size) */
            v->view = 0, v->ref_on = false, v->err_view = 0, snprintf(s->view, sizeof s->view, "final");
        v->rebuild = true;
        char sc_text[16];
        snprintf(sc_text, sizeof sc_text, "%.2f", s->render_scale);
        set_note(v, "render scale %s", sc_text);
        break;
    }
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
        if (scaled(s)) {
            set_note(v, "%s", "the views need render scale 1 (U)");
            break;
        }
        v->view = (v->view + 1) % vw_view_count();
        char nm[64];
        vw_view_name(v->view, nm, sizeof nm);
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

void vw_on_event(const vw_event *e, void *user)
{
    viewer *v = user;
    if (e->kind == VW_KEY)
        vw_on_key(v, e->key, e->down);
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

bool vw_split(const rn_view_state *s)
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
    for (int i = 0; i < (vw_split(s) ? 2 : 1); i++) {
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
        TND_TRY(rn_pipeline_open(&o, v->scene, &v->vk, pl_frontend_needs_gpu(o.frontend), true,
                                 prec, &info, false, &v->fe[i], &v->chain[i], &pd,
                                 v->run_host));
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
    rn_say(v->run_host, "tandem: view: %s/shot_%04u.{png,exr,view.png,json,path.json} (frame %u)",
           v->out, v->shots, v->frame - 1);
    v->shots++;
fail:
    free(rgb8);
    free(shown);
    free(rgb);
    return res;
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
    uint32_t rs[2]; /* (the size traced: the window's, or less with a render scale) */
    rn_view_render_size(s, rs);
    for (int i = 0; i < (vw_split(s) ? 2 : 1); i++) {
        TND_TRY(pl_frontend_set_frame(v->fe[i], cur, prev, f, rs[0], rs[1]));
        pl_step step = {.params = {.bounces = s->bounces, .half_indirect = s->half_indirect != 0},
                        .frame = dn_frame_for_camera(cur->camera.proj, rs[1], f, first),
                        .dt = (float)(1.0 / s->fps),
                        .capture = i == 0 && v->want_capture ? cap : NULL,
                        .no_wait = true};
        pl_step_result r;
        TND_TRY(pl_chain_run(v->chain[i], v->fe[i], &step, NULL, NULL, &r));
        if (i == 0 && r.lagged)
            v->last = r;
    }
    if (v->want_capture) {
        rn_say(v->run_host, "tandem: view: %s", cap);
        v->captures++;
        v->want_capture = false;
    }
    bool can_ref = (pl_frontend_caps(v->fe[0]) & PL_CAP_REFERENCE) != 0;
    bool shown_debug = v->view || v->ref_on || (v->err_view && can_ref);
    if (v->err_view && can_ref)
        TND_TRY(vw_error_view(v));
    else if (v->ref_on && can_ref)
        TND_TRY(vw_progressive_reference(v));
    else if (v->view)
        TND_TRY(vw_debug_view(v));
    /* A (the main pipeline, or its view) on the left, B on the right */
    const tnd_image *a = shown_debug ? &v->debug : cmp_display_image(pl_chain_post(v->chain[0]));
    const tnd_image *b = vw_split(s) ? cmp_display_image(pl_chain_post(v->chain[1])) : NULL;
    TND_TRY(tnd_image_upload(&v->vk, &v->overlay, v->overlay_px,
                             (size_t)OVERLAY_W * OVERLAY_H * 4));
    TND_TRY(vw_compose_run(v->compose, a, b, (int)w / 2, &v->overlay, &v->shown));
    TND_TRY(vw_window_present(v->win, &v->shown));
    v->frame++; /* (scene time follows the frame: render --view replays it)*/
fail:
    return res;
}

tnd_result vw_view_run(const vw_view_opts *o, const rn_host *h, vw_view_result *result)
{
    *result = (vw_view_result){0};
    viewer *v = calloc(1, sizeof *v);
    if (!v)
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
    v->run_host = h;
    const char *scene = o->scene, *frontend = o->frontend, *denoiser = o->denoiser;
    const char *state = o->state, *script = o->script, *out = o->out ? o->out : ".";
    const unsigned *size = o->size;
    unsigned frames = o->frames;
    rn_env env = o->env;
    rn_soak_rec *rec = NULL;
    tnd_result res = TND_OK;
    vw_script_event *events = NULL;
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
        v->view = vw_view_find(s->view);
    }
    v->out = out;
    if (strncmp(s->frontend, "plugin:", 7) == 0)
        memcpy(v->plugin_fe, s->frontend, sizeof v->plugin_fe);
    if (strncmp(s->denoiser, "plugin:", 7) == 0)
        memcpy(v->plugin_dn, s->denoiser, sizeof v->plugin_dn);
    v->show_overlay = true;
    if (script) {
        TND_TRY(vw_load_script(script, &events, &n_events));
        v->scripted = true;
    }
    TND_TRY(tnd_mkdirs(out));
    TND_TRY(vw_window_create("tandem view", s->size[0], s->size[1], vw_on_event, v, &v->win));
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
    if (o->soak && !(rec = rn_soak_rec_begin(frames))) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "view: out of memory");
        goto fail;
    }
    v->t_last = tnd_now();
    double avg_dt = 0, t_start = tnd_now();
    while (!v->quit && !rn_interrupted(h) && vw_window_poll(v->win)) {
        if (v->scripted)
            TND_TRY(vw_play(v, events, n_events, &next_event));
        uint32_t ww, wh;
        vw_window_size(v->win, &ww, &wh);
        if (ww == 0 || wh == 0) /* minimised */
            continue;
        if (ww != s->size[0] || wh != s->size[1]) {
            s->size[0] = ww;
            s->size[1] = wh;
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
            rn_say(h, "tandem: view: %s", v->note);
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
            vw_draw_overlay(v, device, fps);
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
    rn_say(h, "tandem: view: %u frames in %.2f s (%.1f fps) at %ux%u on %s, %u screenshot%s",
           v->steps, tnd_now() - t_start, v->steps / fmax(1e-9, tnd_now() - t_start),
           s->size[0], s->size[1], device, v->shots, v->shots == 1 ? "" : "s");
    if (rec) { /* (the front-end and denoiser the loop ended with) */
        rn_soak_rec_end(rec, v->steps, s->frontend, s->denoiser);
        result->soak = rec;
        rec = NULL;
    }
    snprintf(result->scene, sizeof result->scene, "%s", s->scene);
    result->steps = v->steps;
    result->size[0] = s->size[0];
    result->size[1] = s->size[1];
    int sig = rn_interrupted(h);
    if (sig) { /* (the window closed as by its close button: screenshots kept) */
        rn_warn(h, "tandem: view: interrupted (%s)", rn_signal_name(sig));
        res = tnd_fail(TND_ERR_INTERRUPTED, "view: interrupted (%s)", rn_signal_name(sig));
    }
fail:
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
    return res;
}
