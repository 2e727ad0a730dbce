/* viewer/vw_internal.h: what the viewer's files share (the viewer's state, its views, overlay and
 * script) and nobody else sees. */
#ifndef VW_INTERNAL_H
#define VW_INTERNAL_H

#include "viewer/viewer.h"
#include "composite/composite.h"
#include "denoise/denoise.h"
#include "eval/eval.h"

enum { GRAPH = 120, OVERLAY_W = 600, OVERLAY_H = 180 };

typedef struct vw_script_event {
    uint32_t frame;
    enum { EV_KEY, EV_TAP, EV_MOUSE, EV_RESIZE, EV_SHOT, EV_EXIT, EV_WAIT } kind;
    char path[1024]; /* EV_WAIT: the file to wait for */
    int key;
    bool down, drag;
    double dx, dy;
    uint32_t w, h;
} vw_script_event;
/* The viewer: its settings and flight, its window, pipeline, views and overlay. */
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
    const rn_host *run_host; /* its lines and interrupts */
} viewer;

/* the views: the final image, then every contract entry, then the back-end's dumps
 * (vw_views.c) */
uint32_t vw_view_count(void);
void vw_view_name(uint32_t v, char *buf, size_t cap);
uint32_t vw_view_find(const char *name);
/* the view chosen in false colour, the error against the progressive reference, that
 * reference: into v->debug */
tnd_result vw_debug_view(viewer *v);
tnd_result vw_error_view(viewer *v);
tnd_result vw_progressive_reference(viewer *v);
/* the overlay's text and frame-time graph into v->overlay_px */
void vw_draw_overlay(viewer *v, const char *device, double fps);
/* a scripted session (vw_script.c): its events read, and this frame's played */
tnd_result vw_load_script(const char *path, vw_script_event **out, uint32_t *count);
tnd_result vw_play(viewer *v, const vw_script_event *ev, uint32_t n, uint32_t *next);
/* input (vw_session.c): a key, an event of the window or the script */
void vw_on_key(viewer *v, int key, bool down);
void vw_on_event(const vw_event *e, void *user);
/* the window split in two halves */
bool vw_split(const rn_view_state *s);

#endif
