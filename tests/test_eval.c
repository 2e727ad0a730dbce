/* tests/test_eval.c: the metrics of eval/ against values worked out by hand (docs/metrics.md):
 * relMSE, SMAPE, RMSE/PSNR on small vectors; SSIM of identical and of constant images (closed
 * form); FLIP of identical images, of uniform colour pairs (no features: the colour term alone,
 * derived step by step below) and its response to edges; temporal error; lag of an exponential
 * follower after a step (closed form); the Pareto front. tests/test_cli.sh checks `tandem eval`
 * against an independent numpy implementation. Label: unit. */
#include "eval/eval.h"
#include "tests/tnd_test.h"

#include <math.h>

static void test_pointwise(void)
{
    const float o[3] = {1, 2, 3}, r[3] = {1, 1, 1};
    /* (0 + 1/1.01 + 4/1.01) / 3 */
    CHECK_NEAR(ev_relmse(o, r, 3), 5.0 / 3.03, 1e-12, "relMSE");
    /* (0 + 1/(2+1+0.01) + 2/(3+1+0.01)) / 3 */
    CHECK_NEAR(ev_smape(o, r, 3), (1 / 3.01 + 2 / 4.01) / 3, 1e-12, "SMAPE");
    CHECK_NEAR(ev_mse(o, r, 3), 5.0 / 3, 1e-12, "MSE");
    CHECK_NEAR(ev_psnr(0.01), 20.0, 1e-12, "PSNR of MSE 0.01");
    CHECK_NEAR(ev_psnr(0.0), 100.0, 1e-12, "PSNR of identical images is capped at 100 dB");
    const float z[2] = {0, 0}, one[2] = {1, 0};
    CHECK_NEAR(ev_smape(one, z, 2), 0.5 / 1.01, 1e-12, "SMAPE with a zero reference");
}

static void fill(float *img, size_t n, float v)
{
    for (size_t i = 0; i < n * 3; i++)
        img[i] = v;
}

static void test_ssim(void)
{
    enum { W = 24, H = 16, N = W * H };
    static float a[N * 3], b[N * 3];
    uint32_t s = 1;
    for (int i = 0; i < N * 3; i++) {
        s = s * 1664525u + 1013904223u;
        a[i] = (float)(s >> 8) / 16777216.0f;
    }
    double v;
    CHECK_OK(ev_ssim(a, a, W, H, &v));
    CHECK_NEAR(v, 1.0, 1e-9, "SSIM of identical images");
    /* constant images: sigma = 0, so SSIM = (2ab + C1) / (a^2 + b^2 + C1) */
    fill(a, N, 0.2f);
    fill(b, N, 0.6f);
    CHECK_OK(ev_ssim(a, b, W, H, &v));
    double e = (2 * 0.2 * 0.6 + 1e-4) / (0.04 + 0.36 + 1e-4);
    CHECK_NEAR(v, e, 1e-6, "SSIM of constants 0.2 and 0.6");
    CHECK(ev_ssim(a, b, 10, 40, &v) != TND_OK, "SSIM needs 11x11");
    tnd_error_clear();
}

/* The FLIP colour term of two uniform images, worked through the published formulas:
 * sRGB -> linear -> XYZ (D65) -> CIELAB, Hunt: a,b x 0.01 L; HyAB = |dL| + |d(a,b)|; ^0.7;
 * knee at 0.4 cmax (-> 0.95), cmax = HyAB(green, blue)^0.7. A uniform image has no features
 * (both detectors sum to zero), so FLIP = the colour term. */
static double lin(double c)
{
    return c > 0.04045 ? pow((c + 0.055) / 1.055, 2.4) : c / 12.92;
}

static void hunt_lab(double r, double g, double b, double out[3])
{
    double X = 0.4123908 * r + 0.3575843 * g + 0.1804808 * b;
    double Y = 0.2126390 * r + 0.7151687 * g + 0.0721923 * b;
    double Z = 0.0193308 * r + 0.1191948 * g + 0.9505322 * b;
    double t[3] = {X / 0.950428545, Y, Z / 1.088900371}, f[3];
    for (int k = 0; k < 3; k++)
        f[k] = t[k] > 216.0 / 24389.0 ? cbrt(t[k]) : t[k] * 841.0 / 108.0 + 4.0 / 29.0;
    double L = 116 * f[1] - 16;
    out[0] = L;
    out[1] = 0.01 * L * 500 * (f[0] - f[1]);
    out[2] = 0.01 * L * 200 * (f[1] - f[2]);
}

static double expected_uniform_flip(const double c0[3], const double c1[3])
{
    double a[3], b[3], g[3], bl[3];
    hunt_lab(lin(c0[0]), lin(c0[1]), lin(c0[2]), a);
    hunt_lab(lin(c1[0]), lin(c1[1]), lin(c1[2]), b);
    hunt_lab(0, 1, 0, g);
    hunt_lab(0, 0, 1, bl);
    double cmax = pow(fabs(g[0] - bl[0]) + hypot(g[1] - bl[1], g[2] - bl[2]), 0.7);
    double e = pow(fabs(a[0] - b[0]) + hypot(a[1] - b[1], a[2] - b[2]), 0.7);
    return e < 0.4 * cmax ? 0.95 / (0.4 * cmax) * e : 0.95 + (e - 0.4 * cmax) / (0.6 * cmax) * 0.05;
}

static void test_flip(void)
{
    enum { W = 48, H = 40, N = W * H };
    static float a[N * 3], b[N * 3], map[N];
    double mean;
    const double pairs[4][2][3] = {{{0, 0, 0}, {1, 1, 1}},
                                   {{0.5, 0.5, 0.5}, {0.55, 0.5, 0.45}},
                                   {{0.2, 0.4, 0.8}, {0.2, 0.4, 0.8}},
                                   {{0, 1, 0}, {0, 0, 1}}};
    for (int p = 0; p < 4; p++) {
        for (int q = 0; q < N; q++)
            for (int k = 0; k < 3; k++) {
                a[3 * q + k] = (float)pairs[p][0][k];
                b[3 * q + k] = (float)pairs[p][1][k];
            }
        double e = expected_uniform_flip(pairs[p][0], pairs[p][1]);
        /* the scalar reference code in double: 2e-5; the vectorised code in float: 2e-4 of
         * it (the Lab differences of nearly equal colours cancel: 3 float ulps of the cube
         * roots, times 5 L, are 1e-4 of pair 1's) */
        for (int fast = 0; fast < 2; fast++) {
            ev_metrics_reference(!fast);
            CHECK_OK(ev_flip(a, b, W, H, EV_FLIP_PPD, map, &mean));
            double tol = fast ? 2e-4 * e + 1e-6 : 2e-5;
            CHECK_NEAR(mean, e, tol, "uniform pair FLIP (colour term only)");
            CHECK_NEAR(map[N / 2 + W / 2], e, tol, "uniform pair FLIP, centre pixel");
            printf("     uniform pair %d: FLIP %.6f (expected %.6f; %s)\n", p, mean, e,
                   fast ? "vectorised" : "reference");
        }
        ev_metrics_reference(false);
    }
    /* green vs blue is the largest colour difference: FLIP = 1 exactly */
    CHECK_NEAR(expected_uniform_flip(pairs[3][0], pairs[3][1]), 1.0, 1e-12, "green/blue = 1");
    /* an edge present in one image only: the feature term raises the error at the edge above
     * the colour term alone (which the blur of the CSF spreads and lowers) */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int k = 0; k < 3; k++) {
                a[3 * (y * W + x) + k] = x < W / 2 ? 0.2f : 0.8f;
                b[3 * (y * W + x) + k] = 0.5f;
            }
    CHECK_OK(ev_flip(a, b, W, H, EV_FLIP_PPD, map, &mean));
    float edge = map[(H / 2) * W + W / 2], flat = map[(H / 2) * W + 2];
    printf("     step edge vs flat grey: FLIP %.4f at the edge, %.4f away from it\n", edge, flat);
    CHECK(edge > 0.5f && edge <= 1.0f, "edge error %.4f", edge);
    CHECK(flat > 0.0f && flat < 1.0f, "flat error %.4f", flat);
    CHECK_OK(ev_flip(a, a, W, H, EV_FLIP_PPD, map, &mean));
    CHECK(mean == 0.0, "identical images: FLIP %g", mean);
}

/* frames numbered from 100, exposure 1 */
static tnd_result run_sequence(const ev_image *out, const ev_image *ref, uint32_t count,
                               ev_frame_metrics *m, ev_summary *s)
{
    ev_sequence *seq = NULL;
    tnd_result res = ev_sequence_create(ref[0].width, ref[0].height, 1.0, EV_FLIP_PPD, &seq);
    for (uint32_t t = 0; res == TND_OK && t < count; t++)
        res = ev_sequence_add(seq, 100 + t, &out[t], &ref[t], &m[t], NULL);
    if (res == TND_OK)
        ev_sequence_summary(seq, s);
    ev_sequence_destroy(seq);
    return res;
}

static void test_sequence_and_lag(void)
{
    enum { W = 16, H = 12, N = W * H, T = 20 };
    ev_image out[T] = {{0}}, ref[T] = {{0}};
    const float alpha = 0.2f;
    float o = 0.1f;
    for (int t = 0; t < T; t++) {
        REQUIRE_OK(ev_image_alloc(W, H, &out[t]));
        REQUIRE_OK(ev_image_alloc(W, H, &ref[t]));
        float r = t < 5 ? 0.1f : 0.5f; /* the light switches on at frame 5 */
        o = t < 5 ? 0.1f : o + alpha * (r - o);
        fill(ref[t].rgb, N, r);
        fill(out[t].rgb, N, o);
    }
    double lag;
    uint32_t changes = ev_lag(out, ref, T, &lag);
    /* error after the step: 0.4 x 0.8^(k+1) at frame 5 + k; it counts while > 0.1 x 0.4 */
    int expect = 0;
    while (pow(0.8, expect + 1) > 0.1)
        expect++;
    CHECK(changes == 1, "%u changes", changes);
    CHECK_NEAR(lag, expect, 1e-12, "lag of an exponential follower (alpha 0.2)");
    printf("     step at frame 5, exponential follower alpha 0.2: lag %.0f frames (expected %d)\n",
           lag, expect);
    /* temporal error: output = reference gives 0; a static output against a changing reference
     * gives the reference's own change */
    ev_frame_metrics m[T];
    ev_summary s;
    REQUIRE_OK(run_sequence(ref, ref, T, m, &s));
    CHECK(m[0].temporal < 0 && m[3].frame == 103, "first frame has no temporal error");
    CHECK_NEAR(s.temporal, 0.0, 1e-12, "temporal error of the reference itself");
    CHECK_NEAR(s.relmse, 0.0, 1e-12, "relMSE of the reference itself");
    CHECK_NEAR(s.ssim, 1.0, 1e-9, "SSIM of the reference itself");
    CHECK(s.flip == 0.0, "FLIP of the reference itself");
    for (int t = 0; t < T; t++)
        fill(out[t].rgb, N, 0.1f);
    REQUIRE_OK(run_sequence(out, ref, T, m, &s));
    CHECK(s.changes == 1 && s.lag == 15, "a static output never catches up: lag %g (to the end, 15)", s.lag);
    float a[3], b[3];
    ev_image pa = {1, 1, (float[3]){0.1f, 0.1f, 0.1f}, NULL},
             pb = {1, 1, (float[3]){0.5f, 0.5f, 0.5f}, NULL};
    ev_tonemap(&pa, 1.0, a);
    ev_tonemap(&pb, 1.0, b);
    CHECK_NEAR(m[5].temporal, fabs(b[0] - a[0]), 1e-6, "temporal error at the step");
    CHECK_NEAR(m[6].temporal, 0.0, 1e-12, "temporal error after the step");
cleanup:
    for (int t = 0; t < T; t++) {
        ev_image_free(&out[t]);
        ev_image_free(&ref[t]);
    }
}

static void test_tonemap_and_exposure(void)
{
    ev_image img = {2, 1, (float[6]){0.18f, 0.18f, 0.18f, 0.72f, 0.72f, 0.72f}, NULL};
    /* geometric mean of 0.18 and 0.72 is 0.36: exposure 0.5 */
    CHECK_NEAR(ev_auto_exposure(&img, 1), 0.5, 1e-6, "auto exposure");
    float out[6];
    ev_image in = {2, 1, (float[6]){0, 0, 0, 1e30f, NAN, -1}, NULL};
    ev_tonemap(&in, 1.0, out);
    CHECK(out[0] == 0 && out[3] == 1.0f && out[4] == 0 && out[5] == 0, "black 0, huge 1, NaN 0, negative 0");
}

static void test_pareto(void)
{
    const double x[5] = {1, 2, 3, 2, 4}, y[5] = {5, 3, 1, 4, 1};
    bool p[5];
    ev_pareto(x, y, 5, p);
    CHECK(p[0] && p[1] && p[2] && !p[3] && !p[4], "front %d%d%d%d%d", p[0], p[1], p[2], p[3], p[4]);
}

/* Worth N samples. By relMSE: a reference with a known per-pixel variance and an output off by a
 * known error is worth exactly sum var w / sum err^2 w. By FLIP: the model of an N-sample
 * average (ev_worth_model) has the mean and the variance of one (checked over 9216 pixels at
 * N = 1, 4 and 1000, the last through the normal approximation), and an output that is that
 * model at N = 8 is found worth 8 (within the search's 10 halvings of [2^-4, 2^24]: +- 1%, and
 * the mean FLIP's wiggle between neighbouring N: 15%). */
static void test_worth_samples(void)
{
    enum { W = 96, H = 96, N = W * H };
    ev_image ref = {0}, out = {0};
    float *scratch = malloc(6 * N * sizeof(float)), *tr = malloc(3 * N * sizeof(float));
    REQUIRE(scratch && tr, "out of memory");
    REQUIRE_OK(ev_image_alloc(W, H, &ref));
    REQUIRE_OK(ev_image_alloc(W, H, &out));
    ref.var = malloc(N * sizeof(float));
    REQUIRE(ref.var, "out of memory");
    for (int q = 0; q < N; q++) {
        float y = 0.2f + 0.6f * (float)((q / 7) % 5) / 4.0f; /* (grey: luminance y) */
        for (int k = 0; k < 3; k++)
            ref.rgb[3 * q + k] = y;
        ref.var[q] = 0.5f * y * y;
    }
    /* the model's moments: one grey level (y 0.2, relative variance 0.5: p = 2/3) */
    for (int i = 0; i < N; i++)
        out.rgb[3 * i] = out.rgb[3 * i + 1] = out.rgb[3 * i + 2] = 0.2f;
    float *v = out.var = malloc(N * sizeof(float));
    REQUIRE(v, "out of memory");
    for (int i = 0; i < N; i++)
        v[i] = 0.5f * 0.04f;
    const double ns[3] = {1, 4, 1000};
    for (int t = 0; t < 3; t++) {
        ev_worth_model(&out, ns[t], 3, scratch);
        double m = 0, m2 = 0;
        for (int q = 0; q < N; q++)
            m += scratch[3 * q], m2 += (double)scratch[3 * q] * scratch[3 * q];
        m /= N;
        double var = m2 / N - m * m, want = 0.02 / ns[t];
        /* standard errors: of the mean sqrt(want / N), of the variance about want sqrt(2 / N)
         * (the binomial's excess kurtosis is small here): 5 of each */
        printf("     model at N = %g: mean %.5f (0.2), variance %.4g (%.4g)\n", ns[t], m, var, want);
        CHECK(fabs(m - 0.2) < 5 * sqrt(want / N), "model mean at N = %g: %g", ns[t], m);
        CHECK(fabs(var - want) < 5 * want * sqrt(2.0 / N) + 1e-12, "model variance at N = %g: %g",
              ns[t], var);
    }
    free(out.var);
    out.var = NULL;
    /* relMSE: the output 10% off everywhere */
    double sv = 0, se = 0;
    for (int q = 0; q < N; q++) {
        double y = ref.rgb[3 * q], w = 1.0 / (y * y + EV_RELMSE_EPS);
        for (int k = 0; k < 3; k++)
            out.rgb[3 * q + k] = (float)(y * 1.1);
        double d = (double)(float)(y * 1.1) - y;
        sv += ref.var[q] * w, se += d * d * w;
    }
    ev_sequence *seq = NULL;
    ev_frame_metrics m;
    ev_summary sum;
    REQUIRE_OK(ev_sequence_create(W, H, 1.0, EV_FLIP_PPD, &seq));
    REQUIRE_OK(ev_sequence_add(seq, 0, &out, &ref, &m, NULL));
    ev_sequence_summary(seq, &sum);
    CHECK_NEAR(m.worth_relmse, sv / se, 1e-6 * sv / se, "worth by relMSE");
    CHECK_NEAR(sum.worth_relmse, sv / se, 1e-6 * sv / se, "its mean over the sequence");
    CHECK(m.worth_flip < 0, "worth by FLIP found without being asked: %g", m.worth_flip);
    /* FLIP: an output that is the model's 8-sample average */
    ev_worth_model(&ref, 8, 5, out.rgb);
    ev_tonemap(&ref, 1.0, tr);
    double flip, n8;
    {
        float *to = malloc(3 * N * sizeof(float));
        REQUIRE(to, "out of memory");
        ev_tonemap(&out, 1.0, to);
        tnd_result r = ev_flip(tr, to, W, H, EV_FLIP_PPD, NULL, &flip);
        free(to);
        REQUIRE_OK(r);
    }
    REQUIRE_OK(ev_worth_flip(&ref, tr, 1.0, EV_FLIP_PPD, flip, 5, scratch, &n8));
    printf("     the model's 8-sample average: FLIP %.4f, worth %.3f samples by FLIP\n", flip, n8);
    CHECK(fabs(n8 / 8 - 1) < 0.15, "worth by FLIP %g, expected 8", n8);
    double lo, hi;
    REQUIRE_OK(ev_worth_flip(&ref, tr, 1.0, EV_FLIP_PPD, 0.9, 5, scratch, &lo));
    REQUIRE_OK(ev_worth_flip(&ref, tr, 1.0, EV_FLIP_PPD, 0.0, 5, scratch, &hi));
    CHECK(lo == 1.0 / 16 && hi == 16777216.0, "the bounds: %g and %g", lo, hi);
    /* through the sequence, asked for */
    ev_sequence_worth_flip(seq, true);
    REQUIRE_OK(ev_sequence_add(seq, 5, &out, &ref, &m, NULL));
    CHECK_NEAR(m.worth_flip, n8, 1e-9, "the sequence's worth by FLIP");
cleanup:
    ev_sequence_destroy(seq);
    ev_image_free(&ref);
    ev_image_free(&out);
    free(scratch);
    free(tr);
}

/* The vectorised metrics against the scalar reference code they replaced (ev_metrics_reference):
 * tone mapping, SSIM and FLIP of a smooth image with edges and texture against a noisy copy, at
 * a size whose rows are not a multiple of any vector width. Tolerances: tone mapping 4 float
 * ulps of 1 (the fast pow's 2e-6 relative at worst, on values near 0); SSIM 1e-9 (both sum in
 * double, in another order); FLIP 1e-4 relative (float colour conversions, as in test_flip). */
static void test_vectorised_metrics_match_reference(void)
{
    enum { W = 203, H = 117, N = W * H };
    ev_image ref = {0}, out = {0};
    float *tr[2] = {malloc(3 * N * sizeof(float)), malloc(3 * N * sizeof(float))};
    float *to[2] = {malloc(3 * N * sizeof(float)), malloc(3 * N * sizeof(float))};
    REQUIRE(tr[0] && tr[1] && to[0] && to[1], "out of memory");
    REQUIRE_OK(ev_image_alloc(W, H, &ref));
    REQUIRE_OK(ev_image_alloc(W, H, &out));
    uint32_t st = 17;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int k = 0; k < 3; k++) {
                size_t i = 3 * ((size_t)y * W + x) + k;
                st = st * 1664525u + 1013904223u;
                float base = (0.05f + 0.9f * x / W) * ((x / 23 + y / 19) % 2 ? 1.0f : 0.3f) *
                             (k == 1 ? 0.8f : 1.0f);
                ref.rgb[i] = 2.0f * base;
                out.rgb[i] = ref.rgb[i] * (0.6f + 0.8f * (float)(st >> 8) / 16777216.0f);
            }
    double ssim[2], flip[2];
    float tm_diff = 0;
    for (int fast = 0; fast < 2; fast++) {
        ev_metrics_reference(!fast);
        ev_tonemap(&ref, 0.9, tr[fast]);
        ev_tonemap(&out, 0.9, to[fast]);
    }
    for (int fast = 0; fast < 2; fast++) { /* (on the same tone-mapped images) */
        ev_metrics_reference(!fast);
        CHECK_OK(ev_ssim(to[0], tr[0], W, H, &ssim[fast]));
        CHECK_OK(ev_flip(tr[0], to[0], W, H, EV_FLIP_PPD, NULL, &flip[fast]));
    }
    ev_metrics_reference(false);
    for (size_t i = 0; i < 3 * (size_t)N; i++)
        tm_diff = fmaxf(tm_diff, fmaxf(fabsf(tr[0][i] - tr[1][i]), fabsf(to[0][i] - to[1][i])));
    printf("     reference / vectorised: tone map max diff %.3g, SSIM %.9f / %.9f, FLIP %.7f / "
           "%.7f\n", tm_diff, ssim[0], ssim[1], flip[0], flip[1]);
    CHECK(tm_diff <= 4.8e-7f, "tone mapping differs by %g", tm_diff);
    CHECK_NEAR(ssim[1], ssim[0], 1e-9, "SSIM");
    CHECK_NEAR(flip[1], flip[0], 1e-4 * flip[0], "FLIP");
cleanup:
    ev_image_free(&ref);
    ev_image_free(&out);
    for (int i = 0; i < 2; i++)
        free(tr[i]), free(to[i]);
}

TND_TEST_MAIN(T(test_vectorised_metrics_match_reference), T(test_worth_samples), T(test_pointwise), T(test_ssim), T(test_flip), T(test_sequence_and_lag),
              T(test_tonemap_and_exposure), T(test_pareto))
