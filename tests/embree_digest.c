/* tests/embree_digest.c: renders with the Embree front-end and prints a digest of every bit it
 * produced: two real-time frames of `materials` (textures, glass, a mirror; primary and shading
 * with two bounces, motion between the frames; the first as two passes, the second in one sweep)
 * and a 4-spp reference. Built twice, against the
 * front-end with its clones (x86-64-v4 or v3) and against the baseline-only build (FEMB_NO_CLONES);
 * tests/test_simd.sh runs both and requires the same digest: the lane loops give the same bits
 * whatever instruction set the CPU picks (frontend_embree/README.md says why they should). */
#include "frontend_embree/frontend_embree.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>

static uint64_t fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

int main(void)
{
    const char *path = TND_SOURCE_DIR "/data/scenes/materials.gltf";
    enum { W = 96, H = 54 };
    tnd_scene *s = NULL;
    femb_context *c = NULL;
    tnd_scene_state st[2] = {{0}};
    tnd_frame f = {0};
    float *rgb = NULL;
    uint64_t h = 1469598103934665603ull;
    int rc = 1;
    if (tnd_scene_load(path, &s) != TND_OK || femb_create(s, &(femb_desc){.threads = 2}, &c) != TND_OK)
        goto done;
    for (uint32_t frame = 4; frame < 6; frame++) {
        if (tnd_scene_evaluate(s, frame / 30.0, 0, (float)W / H, &st[frame & 1]) != TND_OK ||
            femb_set_frame(c, &st[frame & 1], frame == 4 ? NULL : &st[(frame + 1) & 1], frame, W,
                           H) != TND_OK ||
            tnd_frame_create(W, H, &f) != TND_OK)
            goto done;
        /* frame 4 as two passes, frame 5 in one sweep (femb_render): the same bits either way */
        const femb_params p = {.bounces = 2};
        if (frame == 4 ? femb_trace_primary(c, &f) != TND_OK || femb_shade(c, &p, &f, NULL) != TND_OK
                       : femb_render(c, &p, &f, NULL) != TND_OK)
            goto done;
        for (int e = 0; e < TND_CT_COUNT; e++)
            if (f.present[e])
                h = fnv1a(h, f.data[e], (size_t)W * H * tnd_ct_get((tnd_ct)e)->comps * 4);
        tnd_frame_destroy(&f);
    }
    if (!(rgb = malloc((size_t)W * H * 3 * sizeof *rgb)) ||
        femb_reference(c, 4, rgb, NULL, NULL, NULL, NULL) != TND_OK)
        goto done;
    h = fnv1a(h, rgb, (size_t)W * H * 3 * sizeof *rgb);
    printf("%016" PRIx64 " (lane loops: %s)\n", h, femb_simd());
    rc = 0;
done:
    if (rc)
        fprintf(stderr, "embree_digest: %s: %s\n", path, tnd_error_detail());
    free(rgb);
    tnd_frame_destroy(&f);
    tnd_scene_state_free(&st[0]);
    tnd_scene_state_free(&st[1]);
    femb_destroy(c);
    tnd_scene_destroy(s);
    return rc;
}
