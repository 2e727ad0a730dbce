/* tests/motion_reference.h: a frame's motion vectors and depth against the same computed in
 * double precision from its visibility buffer (shared by the Embree and Vulkan front-end tests).
 * For each pixel that sees a surface directly: the object-space point interpolated from the
 * visibility buffer's barycentrics, through both frames' instance transforms relative to both
 * cameras (their positions as the front-ends take them from the view matrices), projected.
 *
 * Each pixel gets a bound from float arithmetic done right: the interpolated point is off by a
 * few ulps of its vertices' size (FMA contraction or not: mag * 2^-20 units), the translation
 * relative to the camera by an ulp of the distance (d * 2^-20); depth may be off by that sum,
 * the depth change by twice it, the motion by twice it in pixels at that distance plus 1e-4 px
 * of projection rounding. A world point formed in float first is off by an ulp of its distance
 * from the origin (1/256 at 1e5), hundreds of times more. */
#ifndef TND_MOTION_REFERENCE_H
#define TND_MOTION_REFERENCE_H

#include "core/core.h"
#include "tests/tnd_test.h"

#include <math.h>

typedef struct motion_error {
    long pixels, outside; /* pixels compared; those with a value outside its bound */
    double worst_px, worst_z, worst_depth; /* largest errors: pixels, units, relative */
    double worst_ratio;                    /* largest error / bound over all values */
} motion_error;

static inline void motion_reference_add(const tnd_scene *s, const tnd_scene_state *cur,
                                        const tnd_scene_state *prev, const tnd_frame *f,
                                        motion_error *e)
{
    uint32_t W = f->width, H = f->height;
    float icv[16], ipv[16];
    tnd_mat4_inverse(cur->camera.view, icv);
    tnd_mat4_inverse(prev->camera.view, ipv);
    for (size_t q = 0; q < (size_t)W * H; q++) {
        uint32_t inst = tnd_frame_u(f, TND_CT_VIS_ID)[2 * q];
        if (inst == TND_VIS_NONE || tnd_frame_u(f, TND_CT_PATH)[q] != 0)
            continue;
        uint32_t prim = tnd_frame_u(f, TND_CT_VIS_ID)[2 * q + 1];
        float u = tnd_frame_f(f, TND_CT_VIS_BARY)[2 * q];
        float v = tnd_frame_f(f, TND_CT_VIS_BARY)[2 * q + 1], w0 = 1.0f - u - v;
        const tnd_mesh *m = &s->meshes[s->instances[inst].mesh];
        const uint32_t *ix = s->indices + m->first_index + 3 * prim;
        const float *P = s->positions + 3 * (size_t)m->first_vertex;
        float obj[3];
        double mag = 0;
        for (int k = 0; k < 3; k++) {
            obj[k] = P[3 * ix[0] + k] * w0 + P[3 * ix[1] + k] * u + P[3 * ix[2] + k] * v;
            for (int j = 0; j < 3; j++)
                mag = fmax(mag, fabs(P[3 * ix[j] + k]));
        }
        double px[2][2], dist[2];
        for (int t = 0; t < 2; t++) { /* 0: this frame, 1: the previous one */
            const tnd_scene_state *st = t ? prev : cur;
            const float *X = st->instance_xform + 12 * (size_t)inst, *cam = t ? ipv : icv;
            const float *V = st->camera.view, *Pr = st->camera.proj;
            double d[3], vv[3], clip[4];
            for (int k = 0; k < 3; k++)
                d[k] = (double)X[4 * k] * obj[0] + (double)X[4 * k + 1] * obj[1] +
                       (double)X[4 * k + 2] * obj[2] + X[4 * k + 3] - cam[12 + k];
            for (int k = 0; k < 3; k++)
                vv[k] = V[k] * d[0] + V[4 + k] * d[1] + V[8 + k] * d[2];
            for (int k = 0; k < 4; k++)
                clip[k] = Pr[k] * vv[0] + Pr[4 + k] * vv[1] + Pr[8 + k] * vv[2] + Pr[12 + k];
            px[t][0] = (clip[0] / clip[3] * 0.5 + 0.5) * W;
            px[t][1] = (clip[1] / clip[3] * 0.5 + 0.5) * H;
            dist[t] = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        }
        const float *mo = tnd_frame_f(f, TND_CT_MOTION) + 3 * q;
        double near = fmin(dist[0], dist[1]);
        double tol = (mag + fmax(dist[0], dist[1])) * 0x1p-20; /* scene units */
        const float *Pr = cur->camera.proj;
        double ppu = fmax(fabs(Pr[0]) * W, fabs(Pr[5]) * H) / (2.0 * near); /* px per unit */
        double err[4] = {fabs(mo[0] - (px[1][0] - px[0][0])), fabs(mo[1] - (px[1][1] - px[0][1])),
                         fabs(mo[2] - (dist[1] - dist[0])),
                         fabs(tnd_frame_f(f, TND_CT_DEPTH)[q] - dist[0])};
        double bound[4] = {2 * tol * ppu + 1e-4, 2 * tol * ppu + 1e-4, 2 * tol, tol};
        bool out = false;
        for (int k = 0; k < 4; k++) {
            out |= !(err[k] <= bound[k]);
            e->worst_ratio = fmax(e->worst_ratio, err[k] / bound[k]);
        }
        e->outside += out;
        e->worst_px = fmax(e->worst_px, fmax(err[0], err[1]));
        e->worst_z = fmax(e->worst_z, err[2]);
        e->worst_depth = fmax(e->worst_depth, err[3] / dist[0]);
        e->pixels++;
    }
}

/* Print the figures; check that enough pixels were compared and none is outside its bound. */
static inline void motion_reference_check(const motion_error *e, long min_pixels)
{
    printf("     %ld pixels: motion within %.3g px of double precision, depth change within "
           "%.3g, depth within %.3g relative; largest error %.3g of its bound, %ld pixels "
           "outside\n",
           e->pixels, e->worst_px, e->worst_z, e->worst_depth, e->worst_ratio, e->outside);
    CHECK(e->pixels > min_pixels, "pixels seen directly: %ld", e->pixels);
    CHECK(e->outside == 0, "%ld pixels with motion or depth outside the bound (worst %.3g of it)",
          e->outside, e->worst_ratio);
}

#endif
