/* tests/lambert_probe.h: direct light from polygonal Lambert emitters against Lambert's exact
 * polygon irradiance, shared by test_frontend_embree (femb) and test_frontend_vk (fvk).
 *
 * The scene (lp_scene): eight square emitters (0.5 m, radiance 1, black, specular 0), four
 * two-sided and four one-sided facing down, on a 20 m grid at height 1; each emitter k has a
 * pure-Lambert receiver quad (KHR_materials_specular 0, albedo 1e-6) at distance h_k below it
 * (facing up) and one at h_k above it (facing down), h from 1 mm to 4 m (lp_heights).
 * Everything hangs from one node translated by (T, T, T), T = 0, 1e2, 1e4, 1e5. Probe points lie
 * on the receivers under and over each emitter's centre line, from the centre to beyond the edge
 * (grazing light).
 *
 * Each point is shaded as a gradient sample (the front-ends' re-evaluation of a surface from its
 * instance, triangle and barycentrics, then the shading pass) with its own random-number keys,
 * thousands of times per point. The receiver is specular-free, so the estimate of its
 * demodulated irradiance over pi is hf + lf evaluated at the normal (NEE plus the MIS-weighted
 * emitter hits of BRDF samples), whose expectation is E / pi by Lambert's formula
 * E = L/2 sum_i beta_i n.Gamma_i, summed over all emitters (the others, 20 m away, add at most
 * 1e-3 of it; that other receivers may shadow them is ignored, and their whole share is a term
 * of the bound), plus what the facing receiver reflects (less than its albedo, 1e-6, of the
 * largest E / pi, 1: another term).
 *
 * The bound from float error, at coordinates of magnitude m (u = 2^-24): the expectation is
 * computed at the point the front-end reconstructed (its G-buffer position); BRDF samples see the
 * emitter from that point's offset origin, eps = 16 u (1 + m) nearer (shaders/offset.h), and the
 * emitter's vertices are rounded to float in world space (u m at most; the points sampled on
 * them are interpolated in float, which scatters each sample by a few u m without moving the
 * emitter). The bound moves the point by eps and every vertex by 2 u (1 + m) in the worst
 * direction (first order: the gradient of E by central differences in double), adds 16 u m / h
 * of E for the float arithmetic on q - p (h: the distance from the emitter's plane) and the
 * other terms above. A shadow ray that reaches the emitter's own plane or starts under the
 * receiver shows as a loss far beyond the bound.
 *
 * The test asserts |mean - E/pi| <= bound + 5 standard errors where the bound is under a quarter
 * of E/pi, and that the light of a one-sided emitter never reaches its back (no more than the
 * other emitters' and the reflected light) where the receiver's distance exceeds 16 u (1 + m),
 * the offset; elsewhere the coordinates cannot resolve the geometry, and it asserts only finite
 * values (and counts those points). */
#ifndef TESTS_LAMBERT_PROBE_H
#define TESTS_LAMBERT_PROBE_H

#include "core/core.h"
#include "tests/tnd_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

enum { LP_EMITTERS = 8, LP_OFFSETS = 5, LP_POINTS = LP_EMITTERS * 2 * LP_OFFSETS };
/* distances of emitter k's receivers: two-sided 0..3, one-sided 4..7 (4 m: the far end, where
 * 1e5 units from the origin the coordinates resolve the geometry to a few percent) */
static const double lp_heights[LP_EMITTERS] = {1e-3, 1e-2, 1e-1, 1.0, 1e-3, 1e-2, 1.0, 4.0};
static const double lp_offsets[LP_OFFSETS] = {0.0, 0.15, 0.24, 0.26, 0.4}; /* along x */
#define LP_HALF 0.25  /* emitter half size */
#define LP_RHALF 0.6  /* receiver half size */
#define LP_Z 0.07     /* the probe line's z (off the receivers' diagonals) */
#define LP_GRID 20.0
#define LP_ALBEDO 1e-6f /* the receivers' (not 0: a black surface samples no diffuse lobe) */

typedef struct lp_point {
    uint32_t instance, primitive;
    float u, v;
    int emitter, above;   /* above: the receiver over the emitter (its back when one-sided) */
    double lateral, h;
    /* accumulated */
    double sum, sum2;
    uint64_t n;
    float p[3];           /* the surface point the front-end reconstructed */
    int p_set, p_moved, nonfinite;
} lp_point;

typedef struct lambert_probe {
    double T;
    tnd_scene *scene;
    uint32_t emitter_instance0;
    lp_point pts[LP_POINTS];
} lambert_probe;

static void lp_emitter_centre(int k, double c[3])
{
    static const int gx[LP_EMITTERS] = {-1, 0, 1, -1, 1, -1, 0, 1};
    static const int gz[LP_EMITTERS] = {-1, -1, -1, 0, 0, 1, 1, 1};
    c[0] = LP_GRID * gx[k];
    c[1] = 1.0;
    c[2] = LP_GRID * gz[k];
}
static bool lp_two_sided(int k) { return k < 4; }
static double lp_height(int k) { return lp_heights[k]; }

/* The emitter's corners (local, as floats: what the scene holds), ordered so that
 * (v1 - v0) x (v2 - v0) points down (-y): a one-sided emitter lights what is below it. */
static void lp_emitter_quad(int k, float v[4][3])
{
    double c[3];
    lp_emitter_centre(k, c);
    const double dx[4] = {-LP_HALF, LP_HALF, LP_HALF, -LP_HALF};
    const double dz[4] = {-LP_HALF, -LP_HALF, LP_HALF, LP_HALF};
    for (int i = 0; i < 4; i++) {
        v[i][0] = (float)(c[0] + dx[i]);
        v[i][1] = (float)c[1];
        v[i][2] = (float)(c[2] + dz[i]);
    }
}

/* Receiver `above` of emitter k: corners (local), facing down when above, up when below. */
static void lp_receiver_quad(int k, int above, float v[4][3])
{
    double c[3];
    lp_emitter_centre(k, c);
    double y = c[1] + (above ? lp_height(k) : -lp_height(k));
    const double dx[4] = {-LP_RHALF, LP_RHALF, LP_RHALF, -LP_RHALF};
    const double dz[4] = {-LP_RHALF, -LP_RHALF, LP_RHALF, LP_RHALF};
    for (int i = 0; i < 4; i++) {
        int j = above ? i : 3 - i; /* below: the other winding (normal up) */
        v[i][0] = (float)(c[0] + dx[j]);
        v[i][1] = (float)y;
        v[i][2] = (float)(c[2] + dz[j]);
    }
}

static tnd_scene *lp_scene(double T, uint32_t *first_emitter)
{
    tnd_scene *s = NULL;
    if (tnd_scene_new("lambert_probe", &s) != TND_OK)
        return NULL;
    s->sky_set = true; /* a black sky stated: the emitters alone light it */
    tnd_material rec = tnd_material_default("receiver");
    rec.base_color[0] = rec.base_color[1] = rec.base_color[2] = LP_ALBEDO;
    rec.metallic = 0.0f;
    rec.roughness = 1.0f;
    rec.specular = 0.0f;
    tnd_material em1 = rec, em2 = rec;
    em1.base_color[0] = em1.base_color[1] = em1.base_color[2] = 0.0f;
    em2.base_color[0] = em2.base_color[1] = em2.base_color[2] = 0.0f;
    snprintf(em1.name, sizeof em1.name, "one_sided");
    snprintf(em2.name, sizeof em2.name, "two_sided");
    em1.emission[0] = em1.emission[1] = em1.emission[2] = 1.0f;
    em2.emission[0] = em2.emission[1] = em2.emission[2] = 1.0f;
    em2.double_sided = true;
    int32_t mr = tnd_scene_add_material(s, &rec), m1 = tnd_scene_add_material(s, &em1),
            m2 = tnd_scene_add_material(s, &em2);
    const float t[3] = {(float)T, (float)T, (float)T};
    int32_t root = tnd_scene_add_node(s, "root", -1, t, NULL, NULL);
    static const uint32_t idx[6] = {0, 1, 2, 0, 2, 3};
    /* receivers first (instances 0 .. 15: emitter k's below 2k, above 2k + 1), then emitters */
    for (int k = 0; k < LP_EMITTERS; k++)
        for (int above = 0; above < 2; above++) {
            float v[4][3], n[4][3];
            lp_receiver_quad(k, above, v);
            for (int i = 0; i < 4; i++)
                n[i][0] = 0, n[i][1] = above ? -1.0f : 1.0f, n[i][2] = 0;
            int32_t me = tnd_scene_add_mesh(s, "receiver", &v[0][0], &n[0][0], NULL, 4, idx, 2,
                                            (uint32_t)mr);
            tnd_scene_add_instance(s, (uint32_t)me, (uint32_t)root);
        }
    *first_emitter = s->instance_count;
    for (int k = 0; k < LP_EMITTERS; k++) {
        float v[4][3], n[4][3];
        lp_emitter_quad(k, v);
        for (int i = 0; i < 4; i++)
            n[i][0] = 0, n[i][1] = -1.0f, n[i][2] = 0;
        int32_t me = tnd_scene_add_mesh(s, "emitter", &v[0][0], &n[0][0], NULL, 4, idx, 2,
                                        (uint32_t)(lp_two_sided(k) ? m2 : m1));
        tnd_scene_add_instance(s, (uint32_t)me, (uint32_t)root);
    }
    /* the camera at the emitters' height (between every receiver pair: each faces it) */
    const float ct[3] = {0.0f, 1.0f, 60.0f};
    int32_t cn = tnd_scene_add_node(s, "camera", root, ct, NULL, NULL);
    tnd_scene_add_camera(s, (uint32_t)cn, 0.8f);
    if (tnd_scene_commit(s) != TND_OK) {
        tnd_scene_destroy(s);
        return NULL;
    }
    return s;
}

/* Barycentrics of local point (x, z) on a receiver quad (triangles (0,1,2) and (0,2,3)). */
static void lp_bary(const float v[4][3], double x, double z, uint32_t *prim, float *u, float *w)
{
    for (uint32_t t = 0; t < 2; t++) {
        const float *a = v[0], *b = v[1 + t], *c = v[2 + t];
        double e1x = b[0] - a[0], e1z = b[2] - a[2], e2x = c[0] - a[0], e2z = c[2] - a[2];
        double px = x - a[0], pz = z - a[2], det = e1x * e2z - e2x * e1z;
        double bu = (px * e2z - e2x * pz) / det, bv = (e1x * pz - px * e1z) / det;
        if (bu >= 0 && bv >= 0 && bu + bv <= 1) {
            *prim = t;
            *u = (float)bu;
            *w = (float)bv;
            return;
        }
    }
    *prim = 0, *u = *w = 0; /* (not reached: every probe point lies on its quad) */
}

static bool lambert_probe_open(lambert_probe *lp, double T)
{
    memset(lp, 0, sizeof *lp);
    lp->T = T;
    lp->scene = lp_scene(T, &lp->emitter_instance0);
    if (!lp->scene)
        return false;
    int i = 0;
    for (int k = 0; k < LP_EMITTERS; k++)
        for (int above = 0; above < 2; above++)
            for (int o = 0; o < LP_OFFSETS; o++, i++) {
                lp_point *p = &lp->pts[i];
                float v[4][3];
                double c[3];
                lp_receiver_quad(k, above, v);
                lp_emitter_centre(k, c);
                p->instance = (uint32_t)(2 * k + above);
                lp_bary(v, c[0] + lp_offsets[o], c[2] + LP_Z, &p->primitive, &p->u, &p->v);
                p->emitter = k;
                p->above = above;
                p->lateral = lp_offsets[o];
                p->h = lp_height(k);
            }
    return true;
}

static void lambert_probe_close(lambert_probe *lp)
{
    tnd_scene_destroy(lp->scene);
    lp->scene = NULL;
}

/* The gradient-sample words (7 per pixel: pixel, rng frame, rng pixel, instance, primitive, u,
 * v) of dispatch d over a w x h frame: pixel q shades point q mod LP_POINTS with keys
 * (q, 1000 + d), distinct for every (q, d). */
static void lambert_probe_samples(const lambert_probe *lp, uint32_t d, uint32_t count,
                                  uint32_t *words)
{
    for (uint32_t q = 0; q < count; q++) {
        const lp_point *p = &lp->pts[q % LP_POINTS];
        uint32_t *g = words + 7 * q;
        g[0] = q;
        g[1] = 1000u + d;
        g[2] = q;
        g[3] = p->instance;
        g[4] = p->primitive;
        memcpy(&g[5], &p->u, 4);
        memcpy(&g[6], &p->v, 4);
    }
}

/* Accumulate the estimates of one shaded dispatch: hf (green) + lf's luma at the normal. */
static void lambert_probe_add(lambert_probe *lp, const tnd_frame *f, uint32_t count)
{
    const float *hf = tnd_frame_f(f, TND_CT_HF), *sh = tnd_frame_f(f, TND_CT_LF_SH);
    const float *nrm = tnd_frame_f(f, TND_CT_NORMAL), *pos = tnd_frame_f(f, TND_CT_POSITION);
    for (uint32_t q = 0; q < count; q++) {
        lp_point *p = &lp->pts[q % LP_POINTS];
        const float *n = nrm + 3 * q, *l = sh + 4 * q;
        double y = 0.282094791773878 * l[3] +
                   (2.0 / 3.0) * 0.488602511902920 * (n[0] * l[0] + n[1] * l[1] + n[2] * l[2]);
        double x = hf[3 * q + 1] + y;

        if (!isfinite(x)) {
            p->nonfinite++;
            continue;
        }
        p->sum += x;
        p->sum2 += x * x;
        p->n++;
        if (!p->p_set) {
            memcpy(p->p, pos + 3 * q, sizeof p->p);
            p->p_set = 1;
        } else {
            p->p_moved |= memcmp(p->p, pos + 3 * q, sizeof p->p) != 0;
        }
    }
}

/* Lambert's irradiance at p (normal n) from a polygon of radiance 1, both sides lit; `front`
 * receives whether p is on the side its winding's normal faces. */
static double lp_polygon_irradiance(const double p[3], const double n[3], const double v[][3],
                                    int count, bool *front)
{
    double sum = 0;
    for (int i = 0; i < count; i++) {
        const double *a0 = v[i], *b0 = v[(i + 1) % count];
        double a[3], b[3];
        for (int k = 0; k < 3; k++)
            a[k] = a0[k] - p[k], b[k] = b0[k] - p[k];
        double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        double lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
        for (int k = 0; k < 3; k++)
            a[k] /= la, b[k] /= lb;
        double g[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                       a[0] * b[1] - a[1] * b[0]};
        double lg = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        double beta = atan2(lg, c);
        if (lg > 0)
            sum += beta * (n[0] * g[0] + n[1] * g[1] + n[2] * g[2]) / lg;
    }
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++)
        e1[k] = v[1][k] - v[0][k], e2[k] = v[2][k] - v[0][k];
    double nl[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0]};
    *front = nl[0] * (p[0] - v[0][0]) + nl[1] * (p[1] - v[0][1]) + nl[2] * (p[2] - v[0][2]) > 0;
    return 0.5 * fabs(sum);
}

/* E / pi at p from emitter k (exact geometry: T + the scene's local floats) on the receiver of
 * point pt, with vertex j (0..3) moved by dv when j >= 0. */
static double lp_emitter_expected(const lambert_probe *lp, const lp_point *pt, int k,
                                  const double p[3], int j, const double dv[3])
{
    float vf[4][3];
    double v[4][3], n[3] = {0, pt->above ? -1.0 : 1.0, 0};
    lp_emitter_quad(k, vf);
    for (int i = 0; i < 4; i++)
        for (int c = 0; c < 3; c++)
            v[i][c] = lp->T + (double)vf[i][c] + (i == j ? dv[c] : 0.0);
    bool front;
    double e = lp_polygon_irradiance(p, n, (const double(*)[3])v, 4, &front);
    /* (the others: only where the whole emitter is above the receiver's horizon, as
     * Lambert's formula needs; every one is, the own one by construction) */
    return (front || lp_two_sided(k) ? e : 0.0) / TND_PI;
}
static double lp_expected(const lambert_probe *lp, const lp_point *pt, const double p[3], int j,
                          const double dv[3])
{
    return lp_emitter_expected(lp, pt, pt->emitter, p, j, dv);
}
/* The other emitters' share at p: those on the receiver's lit side (y above a receiver below,
 * below one above). */
static double lp_others_expected(const lambert_probe *lp, const lp_point *pt, const double p[3])
{
    double e = 0;
    for (int k = 0; k < LP_EMITTERS; k++) {
        double c[3];
        lp_emitter_centre(k, c);
        double dy = lp->T + c[1] - p[1];
        if (k != pt->emitter && (pt->above ? dy < 0 : dy > 0))
            e += lp_emitter_expected(lp, pt, k, p, -1, NULL);
    }
    return e;
}

typedef struct lp_summary {
    int asserted, failed, unresolved, dark_checked, dark_failed;
    int tight;             /* asserted lit points whose bound is under 1% of E/pi */
    double worst_z;        /* largest |mean - E/pi| in standard errors over those */
    double worst_of_bound; /* largest |mean - E/pi| / (bound + 5 se) */
    double worst_dark;     /* largest mean on the back of a one-sided emitter */
} lp_summary;

/* Check every point (CHECKs name the front-end `who`), fill the summary. */
static void lambert_probe_check(const lambert_probe *lp, const char *who, lp_summary *sm,
                                bool verbose)
{
    memset(sm, 0, sizeof *sm);
    const double u = 1.0 / 16777216.0;
    for (int i = 0; i < LP_POINTS; i++) {
        const lp_point *pt = &lp->pts[i];
        CHECK(pt->nonfinite == 0, "%s T=%g: %d non-finite estimates at point %d", who, lp->T,
              pt->nonfinite, i);
        CHECK(!pt->p_moved, "%s T=%g: point %d reconstructed at different places", who, lp->T,
              i);
        if (pt->n < 2)
            continue;
        double p[3] = {pt->p[0], pt->p[1], pt->p[2]};
        double m = fmax(fabs(p[0]), fmax(fabs(p[1]), fabs(p[2])));
        double Dp = 16 * u * (1 + m), Dv = 2 * u * (1 + m);
        double e = lp_expected(lp, pt, p, -1, NULL);
        /* first-order change of E/pi under moves of the point and of every vertex */
        double grad_p = 0, grad_v = 0, zero[3] = {0, 0, 0};
        for (int j = -1; j < 4; j++)
            for (int k = 0; k < 3; k++) {
                double step = fmax(1e-9, 1e-3 * pt->h), dv[3] = {0, 0, 0}, pa[3], pb[3];
                memcpy(pa, p, sizeof pa);
                memcpy(pb, p, sizeof pb);
                double ea, eb;
                if (j < 0) {
                    pa[k] += step, pb[k] -= step;
                    ea = lp_expected(lp, pt, pa, -1, zero);
                    eb = lp_expected(lp, pt, pb, -1, zero);
                } else {
                    dv[k] = step;
                    ea = lp_expected(lp, pt, p, j, dv);
                    dv[k] = -step;
                    eb = lp_expected(lp, pt, p, j, dv);
                }
                *(j < 0 ? &grad_p : &grad_v) += fabs(ea - eb) / (2 * step);
            }
        double others = lp_others_expected(lp, pt, p);
        double bound = Dp * grad_p + Dv * grad_v + e * 16 * u * m / pt->h + LP_ALBEDO + others;
        double mean = pt->sum / pt->n - others;
        double var = (pt->sum2 - pt->sum * mean) / (pt->n - 1);
        double se = sqrt(fmax(var, 0) / pt->n);
        bool dark = e == 0;
        if (dark) {
            if (pt->h <= Dp) {
                sm->unresolved++;
                continue;
            }
            sm->dark_checked++;
            sm->dark_failed += !(fabs(mean) <= others + LP_ALBEDO + 5 * se);
            sm->worst_dark = fmax(sm->worst_dark, fabs(mean));
            CHECK(fabs(mean) <= others + LP_ALBEDO + 5 * se,
                  "%s T=%g: the back of one-sided emitter %d gets light %.3g at h %g (other "
                  "emitters: %.2g)",
                  who, lp->T, pt->emitter, mean, pt->h, others);
            continue;
        }
        if (bound > 0.25 * e) {
            sm->unresolved++;
            continue;
        }
        sm->asserted++;
        double err = mean - e;
        sm->failed += !(fabs(err) <= bound + 5 * se);
        if (bound < 0.01 * e) {
            sm->tight++;
            sm->worst_z = fmax(sm->worst_z, fabs(err) / se);
        }
        sm->worst_of_bound = fmax(sm->worst_of_bound, fabs(err) / (bound + 5 * se));
        if (verbose || fabs(err) > bound + 5 * se)
            printf("     %s T=%g emitter %d (%s) %s h=%g x=%.2f: %.6f vs %.6f (%+.3f%%, "
                   "se %.2g, bound %.2g)\n",
                   who, lp->T, pt->emitter, lp_two_sided(pt->emitter) ? "two-sided" : "one-sided",
                   pt->above ? "above" : "below", pt->h, pt->lateral, mean, e,
                   100 * err / e, se, bound);
        CHECK(fabs(err) <= bound + 5 * se,
              "%s T=%g: emitter %d %s h=%g x=%.2f: %.6f vs %.6f (bound %.2g, se %.2g)", who,
              lp->T, pt->emitter, pt->above ? "above" : "below", pt->h, pt->lateral, mean, e,
              bound, se);
    }
}

static void lambert_probe_print(const char *who, const lambert_probe *lp, const lp_summary *sm)
{
    printf("     %s T=%-6g lit: %2d of %2d within bound + 5 se (worst |error| %.2f of that; %2d "
           "with bounds under 1%%: worst %.1f standard errors); one-sided backs dark: %2d of %2d "
           "(worst %.2g); %2d points beyond float resolution\n",
           who, lp->T, sm->asserted - sm->failed, sm->asserted, sm->worst_of_bound, sm->tight,
           sm->worst_z, sm->dark_checked - sm->dark_failed, sm->dark_checked, sm->worst_dark,
           sm->unresolved);
}

/* Lambert's formula against the closed form for a rectangle seen from a point under its corner
 * (the form factor of a parallel rectangle, Howell's catalogue C-11): a check of the reference
 * itself. */
static void lambert_probe_self_test(void)
{
    const double a = 0.3, b = 0.7, h = 0.2;
    double v[4][3] = {{0, h, 0}, {0, h, b}, {a, h, b}, {a, h, 0}}, p[3] = {0, 0, 0},
           n[3] = {0, 1, 0};
    bool front;
    double e = lp_polygon_irradiance(p, n, (const double(*)[3])v, 4, &front);
    double X = a / h, Y = b / h;
    double F = (X / sqrt(1 + X * X) * atan(Y / sqrt(1 + X * X)) +
                Y / sqrt(1 + Y * Y) * atan(X / sqrt(1 + Y * Y))) /
               (2 * TND_PI);
    CHECK(fabs(e - TND_PI * F) < 1e-12, "Lambert's formula %.12f vs closed form %.12f", e,
          TND_PI * F);
}

#endif
