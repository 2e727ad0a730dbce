/* tests/embree_frame.h: one frame through the Embree front-end as the tests render it, shared by
 * the front-end, denoiser and post-chain tests: the front-end set to (cur, prev, frame) at w x h,
 * f created (the caller destroys it, also on failure), then with *p both passes in one sweep
 * (femb_render, as `tandem render` runs them), or with p NULL the primary pass alone. */
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
    if (res == TND_OK)
        res = p ? femb_render(fe, p, f, NULL) : femb_trace_primary(fe, f);
    return res;
}

#endif
