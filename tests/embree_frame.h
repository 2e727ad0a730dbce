/* tests/embree_frame.h: one frame through the Embree front-end as the tests render it, shared by
 * the front-end, denoiser and post-chain tests: the front-end set to (cur, prev, frame) at w x h,
 * f created (the caller destroys it, also on failure), the primary pass, and the shading pass with
 * *p unless p is NULL (then femb_render: both in one sweep). */
#ifndef TESTS_EMBREE_FRAME_H
#define TESTS_EMBREE_FRAME_H

#include "frontend_embree/frontend_embree.h"

static inline tnd_result test_embree_frame(femb_context *fe, const tnd_scene_state *cur,
                                           const tnd_scene_state *prev, uint32_t frame,
                                           uint32_t w, uint32_t h, const femb_params *p,
                                           tnd_frame *f)
{
    tnd_result res = femb_set_frame(fe, cur, prev, frame, w, h);
    if (res == TND_OK)
        res = tnd_frame_create(w, h, f);
    if (res == TND_OK) /* (both passes in one sweep, as `tandem render` runs them) */
        res = p ? femb_render(fe, p, f, NULL) : femb_trace_primary(fe, f);
    return res;
}

#endif
