/* viewer: a window on the pipeline (tandem view). vw_view_run is the viewer: the pipeline live,
 * the camera flown, the knobs on keys, screenshots with repro states, scripted sessions
 * (vw_session.c, vw_views.c, vw_script.c). vw_window is a GLFW window with a Vulkan swapchain
 * that shows one RGBA8 image per frame (blitted, so any size and format conversion is the
 * blit's); vw_compose draws that image from the pipeline's outputs (one view, or two split by a
 * divider) with the overlay on top. Input arrives through a callback, the same one a scripted
 * session feeds. Prefix vw_; over the run layer (run/), like app/. */
#ifndef VW_VIEWER_H
#define VW_VIEWER_H

#include "core/core.h"
#include "run/run.h"

typedef struct vw_window vw_window;

/* Input: a key (GLFW key code) pressed or released, the cursor moved (pixels) with the left
 * button held or not, the framebuffer resized. */
typedef enum vw_event_kind { VW_KEY, VW_MOUSE, VW_RESIZE } vw_event_kind;
typedef struct vw_event {
    vw_event_kind kind;
    int key;
    bool down;
    double dx, dy;
    bool drag;
    uint32_t width, height;
} vw_event;
typedef void (*vw_event_fn)(const vw_event *e, void *user);

/* Open a window (GLFW; X11 or Wayland). Fails with GLFW's own words when there is no display. */
tnd_result vw_window_create(const char *title, uint32_t width, uint32_t height, vw_event_fn on_event,
                            void *user, vw_window **out);
void vw_window_destroy(vw_window *w);
/* The instance extensions its surface needs (for tnd_vk_desc). */
const char *const *vw_window_instance_extensions(uint32_t *count);
/* Make the surface and swapchain on this context (its queue must present: checked). */
tnd_result vw_window_attach(vw_window *w, tnd_vk *vk);
/* The framebuffer's size now. */
void vw_window_size(const vw_window *w, uint32_t *width, uint32_t *height);
/* Ask the window system to resize the window (a scripted session's resize). */
void vw_window_set_size(vw_window *w, uint32_t width, uint32_t height);
/* Deliver pending input to the callback; false once the window was asked to close. */
bool vw_window_poll(vw_window *w);
/* Show `img` (RGBA8, any size: blitted to the swapchain's). Recreates the swapchain when the
 * window changed; a minimised window shows nothing. */
tnd_result vw_window_present(vw_window *w, const tnd_image *img);
/* A key's GLFW code from its name ("W", "1", "F5", "SPACE", "TAB", "LEFT_SHIFT", ...); -1 when
 * unknown. And back. */
int vw_key_code(const char *name);
const char *vw_key_name(int code);

/* The composition: image a (RGBA32F, display-encoded [0,1]) left of the divider, b right of it
 * (split < 0: a alone), the overlay (RGBA8, alpha-blended at the top-left) on top, into an
 * RGBA8 image of the same size. */
typedef struct vw_compose vw_compose;
tnd_result vw_compose_create(tnd_vk *vk, vw_compose **out);
void vw_compose_destroy(vw_compose *c);
tnd_result vw_compose_run(vw_compose *c, const tnd_image *a, const tnd_image *b, int split,
                          const tnd_image *overlay, const tnd_image *out);

/* `tandem view` with these settings (the state's over them where given): until the window
 * closes, `frames` frames have run (0: no limit) or the script ends; h says its lines and asks
 * whether to stop (TND_ERR_INTERRUPTED: screenshots kept). With `soak` a soak record of the
 * viewer's loop comes back in result->soak (the caller frees it, rn_soak_rec_free). */
typedef struct vw_view_opts {
    const char *scene, *frontend, *denoiser;
    const char *state;  /* a repro state to start from (a screenshot's .json), or NULL */
    const char *script; /* timed events to play, then exit (docs/viewer.md), or NULL */
    const char *out;    /* screenshots and captures (NULL: .) */
    unsigned size[2], frames;
    bool soak;
    rn_env env;
} vw_view_opts;
typedef struct vw_view_result {
    rn_soak_rec *soak;
    char scene[1024]; /* the scene it ended with, its frames and window size */
    uint32_t steps, size[2];
} vw_view_result;
tnd_result vw_view_run(const vw_view_opts *o, const rn_host *h, vw_view_result *result);

#endif
