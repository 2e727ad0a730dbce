/* tests/test_contract.c: the contract table and its document, the packed encodings at the
 * extremes, host frames, EXR captures (bit-exact round trips, validation of bad files, the
 * files seen by exrheader and oiiotool), and the Blender Cycles mapping. Label: unit. */
#include "core/core.h"
#include "shaders/encoding.h"
#include "tests/tnd_test.h"

#include <float.h>
#include <unistd.h>

static char tmpdir[64];

static const char *tmp_path(const char *name)
{
    static char buf[4][256];
    static int k;
    k = (k + 1) % 4;
    if (!tmpdir[0]) {
        snprintf(tmpdir, sizeof tmpdir, "/tmp/tandem_contract_XXXXXX");
        if (!mkdtemp(tmpdir))
            tmpdir[0] = 0;
    }
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

static void test_table(void)
{
    CHECK(TND_CT_COUNT == 20, "entry count %d", (int)TND_CT_COUNT);
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
        REQUIRE(e != NULL, "entry %d", i);
        CHECK((int)e->id == i, "binding of '%s' is %d, expected %d (bindings are contiguous)",
              e->name, (int)e->id, i);
        CHECK(e->comps >= 1 && e->comps <= 4, "'%s' comps", e->name);
        for (uint32_t c = 0; c < e->comps; c++)
            CHECK(e->exr_channels[c] && e->exr_channels[c][0], "'%s' channel %u named", e->name, c);
        CHECK(tnd_ct_find(e->name) == e, "find '%s'", e->name);
        /* float32 formats hold all components; RGBE only for 3-component floats */
        CHECK(e->pack != TND_PACK_RGBE || (e->comps == 3 && e->vk_packed == VK_FORMAT_R32_UINT),
              "'%s' RGBE layout", e->name);
        CHECK(e->kind != TND_CT_UINT || e->pack == TND_PACK_F32, "'%s' uint never packed", e->name);
        for (int j = 0; j < i; j++) {
            const tnd_ct_info *o = tnd_ct_get((tnd_ct)j);
            CHECK(strcmp(o->name, e->name) != 0, "duplicate name %s", e->name);
            for (uint32_t a = 0; a < e->comps; a++)
                for (uint32_t b = 0; b < o->comps; b++) {
                    char na[64], nb[64];
                    tnd_ct_exr_name((tnd_ct)i, a, na, sizeof na);
                    tnd_ct_exr_name((tnd_ct)j, b, nb, sizeof nb);
                    CHECK(strcmp(na, nb) != 0, "EXR channel %s used twice", na);
                }
        }
    }
    /* The names other tools map onto (the issue's list). */
    const char *expect[] = {"albedo.R", "normal.X",    "geo_normal.Z", "position.Y", "depth.Z",
                            "motion.Z", "roughness.V", "metallic.V",   "emission.B", "hf.R",
                            "spec.B",   "lf.L0",       "vis.instance", "vis.u",      "rng.frame"};
    for (size_t k = 0; k < sizeof expect / sizeof *expect; k++) {
        bool found = false;
        for (int i = 0; i < TND_CT_COUNT; i++)
            for (uint32_t c = 0; c < tnd_ct_get((tnd_ct)i)->comps; c++) {
                char n[64];
                tnd_ct_exr_name((tnd_ct)i, c, n, sizeof n);
                found |= strcmp(n, expect[k]) == 0;
            }
        CHECK(found, "channel %s exists", expect[k]);
    }
    CHECK(tnd_ct_find("nope") == NULL, "unknown name");
}

/* docs/contract.md embeds the generated table between markers: they must be identical. */
static void test_document_matches_table(void)
{
    void *doc = NULL;
    size_t size;
    REQUIRE_OK(tnd_file_read(TND_SOURCE_DIR "/docs/contract.md", &doc, &size));
    const char *b = strstr(doc, "<!-- contract-table:begin -->\n");
    const char *e = strstr(doc, "<!-- contract-table:end -->");
    REQUIRE(b && e && e > b, "markers present");
    b += strlen("<!-- contract-table:begin -->\n");
    size_t n = tnd_ct_markdown(NULL, 0);
    char *gen = malloc(n + 1);
    tnd_ct_markdown(gen, n + 1);
    CHECK((size_t)(e - b) == n && memcmp(b, gen, n) == 0,
          "docs/contract.md is out of date: regenerate the table with `tandem contract`");
    /* every entry is also explained in prose (its name appears outside the table) */
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *ci = tnd_ct_get((tnd_ct)i);
        char key[64];
        snprintf(key, sizeof key, "`%s", ci->exr_layer);
        const char *hit = strstr(doc, key);
        CHECK(hit && hit < b, "entry layer '%s' is discussed before the table", ci->exr_layer);
    }
    free(gen);
cleanup:
    free(doc);
}

/* RGBE over 1e-6 .. 1e6: the bounds stated in shaders/encoding.h. */
static void test_rgbe_extremes(void)
{
    const double lo = 1.0 / 32768.0; /* 2^-BIAS */
    int bad_rel = 0, bad_abs = 0, bad_clamp = 0, bad_idem = 0, n = 0;
    double worst_rel = 0;
    for (double v = 1e-6; v <= 1e6; v *= 1.0137, n++) {
        float x = (float)v;
        uint32_t p = tnd_rgbe_encode(x, x * 0.5f, x * 0.01f);
        float r = tnd_rgbe_channel(p, 0), g = tnd_rgbe_channel(p, 1), b = tnd_rgbe_channel(p, 2);
        if (x > TND_RGBE_MAX) {
            bad_clamp += r != (float)TND_RGBE_MAX;
        } else if (x >= lo) {
            double rel = fabs(r - x) / x;
            worst_rel = fmax(worst_rel, rel);
            bad_rel += rel > 1.0 / 512.0;
            /* other channels: absolute error <= 2^-9 x the largest */
            bad_abs += fabs(g - x * 0.5f) > x / 512.0 || fabs(b - x * 0.01f) > x / 512.0;
        } else {
            bad_abs += fabs(r - x) > ldexp(1.0, -24) * 1.0000001;
        }
        /* decoding then re-encoding is the identity (captures store decoded RGBE) */
        bad_idem += tnd_rgbe_encode(r, g, b) != p;
    }
    printf("     RGBE: %d values over 1e-6..1e6, worst relative error in range %.3e (bound %.3e)\n",
           n, worst_rel, 1.0 / 512.0);
    CHECK(bad_rel == 0, "%d values beyond 2^-9 relative error", bad_rel);
    CHECK(bad_abs == 0, "%d values beyond the absolute bounds", bad_abs);
    CHECK(bad_clamp == 0, "%d large values not clamped to the maximum", bad_clamp);
    CHECK(bad_idem == 0, "%d values not stable under decode/encode", bad_idem);
    /* defined values for what is not a radiance */
    CHECK(tnd_rgbe_encode(NAN, 1.0f, 1.0f) == tnd_rgbe_encode(0.0f, 1.0f, 1.0f), "NaN -> 0");
    CHECK(tnd_rgbe_channel(tnd_rgbe_encode(INFINITY, 0, 0), 0) == (float)TND_RGBE_MAX,
          "+Inf -> max");
    CHECK(tnd_rgbe_encode(-INFINITY, -1.0f, 0.0f) == 0u, "negatives and -Inf -> 0");
    CHECK(tnd_rgbe_encode(0, 0, 0) == 0u && tnd_rgbe_channel(0u, 1) == 0.0f, "zero");
    CHECK(tnd_rgbe_channel(tnd_rgbe_encode(1e30f, 1e30f, 1e30f), 2) == (float)TND_RGBE_MAX,
          "far above the range clamps (Q2RTX decoded these too small)");
    /* rounding carry: 511.6 x 2^k must not wrap the mantissa */
    float carry = 511.75f / 256.0f;
    CHECK(fabs(tnd_rgbe_channel(tnd_rgbe_encode(carry, 0, 0), 0) - carry) <= carry / 512.0,
          "mantissa carry");
}

/* tnd_uf16 (the back-end's a-trous storage): the bounds stated in shaders/encoding.h over
 * 1e-12 .. 1e12, exhaustive decode/encode round trip, and the clamp rules. */
static void test_uf16_extremes(void)
{
    const double lo = ldexp(1.0, 1 - TND_UF16_BIAS);
    int bad_rel = 0, bad_abs = 0, bad_clamp = 0, n = 0;
    double worst = 0;
    for (double v = 1e-12; v <= 1e12; v *= 1.0137, n++) {
        float x = (float)v, d = tnd_uf16_decode(tnd_uf16_encode(x));
        if (x > TND_UF16_MAX)
            bad_clamp += d != (float)TND_UF16_MAX;
        else if (x >= lo) {
            double rel = fabs(d - x) / x;
            worst = fmax(worst, rel);
            bad_rel += rel > ldexp(1.0, -11);
        } else
            bad_abs += fabs(d - x) >= lo;
    }
    int bad_rt = 0, bad_scaled = 0;
    for (uint32_t h = 0; h < 65536; h++) /* every code decodes to a value that encodes back */
        bad_rt += (h >> 10) != 0 && tnd_uf16_encode(tnd_uf16_decode(h)) != h;
    /* the encoder from scaled values (x 2^(BIAS - 127)) gives the same codes: over the sweep,
     * every code's value and the midpoints between neighbouring codes (ties), zero, the
     * largest values, and below the smallest code */
    const float to_scaled = ldexpf(1.0f, TND_UF16_BIAS - 127);
    for (double v = 1e-12; v <= 1e12; v *= 1.0137)
        bad_scaled += tnd_uf16_encode_scaled((float)v * to_scaled) != tnd_uf16_encode((float)v);
    for (uint32_t h = 0x400; h < 0xffff; h++) {
        float a = tnd_uf16_decode(h), b = tnd_uf16_decode(h + 1), mid = 0.5f * (a + b);
        bad_scaled += tnd_uf16_encode_scaled(a * to_scaled) != h;
        bad_scaled += tnd_uf16_encode_scaled(mid * to_scaled) != tnd_uf16_encode(mid);
        bad_scaled += tnd_uf16_encode_scaled(nextafterf(mid, 0.0f) * to_scaled) !=
                      tnd_uf16_encode(nextafterf(mid, 0.0f));
    }
    const float lo_code = ldexpf(1.0f, 1 - TND_UF16_BIAS); /* the smallest code's value */
    const float edge[] = {0.0f, -0.0f, (float)TND_UF16_MAX, 1e30f, ldexpf(1.0f, -TND_UF16_BIAS),
                          lo_code, nextafterf(lo_code, 0.0f)};
    for (int k = 0; k < 7; k++)
        bad_scaled += tnd_uf16_encode_scaled(edge[k] * to_scaled) != tnd_uf16_encode(edge[k]);
    printf("     uf16: %d values over 1e-12..1e12, worst relative error in range %.3e (bound "
           "%.3e)\n", n, worst, ldexp(1.0, -11));
    CHECK(bad_rel == 0, "%d values beyond 2^-11 relative error", bad_rel);
    CHECK(bad_abs == 0, "%d small values beyond the absolute bound", bad_abs);
    CHECK(bad_clamp == 0, "%d large values not clamped to the maximum", bad_clamp);
    CHECK(bad_rt == 0, "%d codes not stable under decode/encode", bad_rt);
    CHECK(bad_scaled == 0, "%d codes from scaled values differ", bad_scaled);
    CHECK(tnd_uf16_encode(NAN) == 0u && tnd_uf16_encode(-1.0f) == 0u &&
              tnd_uf16_encode(-INFINITY) == 0u,
          "NaN and negatives -> 0");
    CHECK(tnd_uf16_decode(tnd_uf16_encode(INFINITY)) == (float)TND_UF16_MAX, "+Inf -> max");
    CHECK(tnd_uf16_decode(tnd_uf16_encode(1.0f)) == 1.0f, "1 exact");
    float carry = 1.99951171875f; /* 2 - 2^-11: rounds up into the next exponent */
    CHECK(tnd_uf16_decode(tnd_uf16_encode(carry)) == 2.0f, "mantissa carry");
}

/* Half: exhaustive over every finite half, plus the clamp rules. */
static void test_half_extremes(void)
{
    int bad_rt = 0;
    for (uint32_t h = 0; h < 65536; h++) {
        if (((h >> 10) & 0x1f) == 31)
            continue; /* Inf/NaN are never produced */
        float f = tnd_half_to_float((uint16_t)h);
        uint16_t back = tnd_half_from_float(f);
        bad_rt += back != h && !(f == 0.0f && (back & 0x7fff) == 0);
    }
    CHECK(bad_rt == 0, "%d halves do not survive float and back", bad_rt);
    int bad = 0;
    double worst = 0;
    for (double v = 1e-6; v <= 1e6; v *= 1.0137) {
        float x = (float)v, r = tnd_half_to_float(tnd_half_from_float(x));
        if (x > 65504.0f)
            bad += r != 65504.0f;
        else if (x >= 6.103515625e-5f) {
            worst = fmax(worst, fabs(r - x) / x);
            bad += fabs(r - x) / x > 1.0 / 2048.0;
        } else
            bad += fabs(r - x) > ldexp(1.0, -25) * 1.0000001;
    }
    printf("     half: worst relative error in range %.3e (bound %.3e)\n", worst, 1.0 / 2048.0);
    CHECK(bad == 0, "%d values outside the stated half bounds", bad);
    CHECK(tnd_half_to_float(tnd_half_from_float(NAN)) == 0.0f, "NaN -> 0");
    CHECK(tnd_half_to_float(tnd_half_from_float(INFINITY)) == 65504.0f, "Inf -> 65504");
    CHECK(tnd_half_to_float(tnd_half_from_float(-1e9f)) == -65504.0f, "-big -> -65504");
    CHECK(tnd_half_from_float(1.0f) == 0x3c00 && tnd_half_from_float(-2.0f) == 0xc000, "bits");
    /* ties to even: 1 + 2^-11 is halfway between 1 and 1 + 2^-10 */
    CHECK(tnd_half_from_float(1.0f + 1.0f / 2048.0f) == 0x3c00, "tie to even (down)");
    CHECK(tnd_half_from_float(1.0f + 3.0f / 2048.0f) == 0x3c02, "tie to even (up)");
}

static uint32_t rng_state = 1;
static uint32_t next_u(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 17;
    rng_state ^= rng_state << 5;
    return rng_state;
}
static float next_f(float lo, float hi)
{
    return lo + (hi - lo) * (float)(next_u() >> 8) / 16777216.0f;
}

/* A frame with every entry present and varied values, including extremes. */
static tnd_result make_frame(uint32_t w, uint32_t h, tnd_frame *f)
{
    tnd_result r = tnd_frame_create(w, h, f);
    if (r != TND_OK)
        return r;
    for (int i = 0; i < TND_CT_COUNT; i++) {
        const tnd_ct_info *e = tnd_ct_get((tnd_ct)i);
        size_t n = (size_t)w * h * e->comps;
        if (e->kind == TND_CT_UINT) {
            for (size_t k = 0; k < n; k++)
                tnd_frame_u(f, (tnd_ct)i)[k] = next_u();
        } else {
            for (size_t k = 0; k < n; k++) {
                float v = next_f(-2.0f, 2.0f);
                if (k % 17 == 3)
                    v = 1e5f * next_f(0.5f, 1.5f);
                if (k % 19 == 5)
                    v = 1e-5f * next_f(0.0f, 1.0f);
                tnd_frame_f(f, (tnd_ct)i)[k] = v;
            }
        }
        f->present[i] = true;
    }
    f->has_camera = true;
    for (int k = 0; k < 16; k++) {
        f->camera.view[k] = next_f(-3, 3);
        f->camera.proj[k] = next_f(-3, 3);
        f->camera.prev_view[k] = next_f(-3, 3);
        f->camera.prev_proj[k] = next_f(-3, 3);
    }
    f->camera.jitter[0] = 0.25f;
    f->camera.jitter[1] = -0.125f;
    f->camera.frame_index = 41;
    return TND_OK;
}

static bool frames_equal(const tnd_frame *a, const tnd_frame *b, char *why, size_t cap)
{
    if (a->width != b->width || a->height != b->height) {
        snprintf(why, cap, "size");
        return false;
    }
    for (int i = 0; i < TND_CT_COUNT; i++) {
        if (a->present[i] != b->present[i]) {
            snprintf(why, cap, "presence of %s", tnd_ct_get((tnd_ct)i)->name);
            return false;
        }
        size_t n = (size_t)a->width * a->height * tnd_ct_get((tnd_ct)i)->comps * 4;
        if (a->present[i] && memcmp(a->data[i], b->data[i], n) != 0) {
            snprintf(why, cap, "bits of %s", tnd_ct_get((tnd_ct)i)->name);
            return false;
        }
    }
    if (memcmp(&a->camera, &b->camera, sizeof a->camera) != 0 || a->has_camera != b->has_camera) {
        snprintf(why, cap, "camera");
        return false;
    }
    return true;
}

static void test_capture_round_trip(void)
{
    const tnd_exr_compression comp[] = {TND_EXR_ZIP, TND_EXR_PIZ, TND_EXR_NONE};
    const char *cname[] = {"zip", "piz", "none"};
    for (int prec = 0; prec < 2; prec++)
        for (int c = 0; c < 3; c++) {
            tnd_frame f = {0}, g = {0};
            CHECK_OK(make_frame(67, 41, &f)); /* odd sizes: the last chunk is short */
            tnd_frame_quantize(&f, (tnd_precision)prec);
            const char *path = tmp_path("rt.exr");
            CHECK_OK(tnd_capture_write(path, &f, comp[c]));
            CHECK_OK(tnd_capture_read(path, &g));
            char why[128] = "";
            CHECK(frames_equal(&f, &g, why, sizeof why), "%s/%s round trip differs: %s",
                  tnd_precision_name((tnd_precision)prec), cname[c], why);
            CHECK(g.precision == (tnd_precision)prec, "precision attribute");
            tnd_frame_destroy(&f);
            tnd_frame_destroy(&g);
        }
}

static void test_quantize(void)
{
    tnd_frame f = {0};
    REQUIRE_OK(tnd_frame_create(4, 1, &f));
    float *hf = tnd_frame_f(&f, TND_CT_HF), *alb = tnd_frame_f(&f, TND_CT_ALBEDO);
    float *depth = tnd_frame_f(&f, TND_CT_DEPTH);
    hf[0] = NAN, hf[1] = 1e9f, hf[2] = 0.3f;
    alb[0] = INFINITY, alb[1] = 0.3f;
    depth[0] = 123456.789f;
    tnd_frame_quantize(&f, TND_PRECISION_PACKED);
    CHECK(hf[0] == 0.0f && hf[1] == (float)TND_RGBE_MAX, "RGBE sanitised: %g %g", hf[0], hf[1]);
    CHECK(fabs(hf[2] - 0.3f) <= 1e9f / 512.0f, "RGBE shares the exponent");
    CHECK(alb[0] == 65504.0f, "half clamps Inf");
    CHECK(alb[1] == tnd_half_to_float(tnd_half_from_float(0.3f)) && alb[1] != 0.3f, "half");
    CHECK(depth[0] == 123456.789f, "depth stays float32 when packed");
    tnd_frame_destroy(&f);
    REQUIRE_OK(tnd_frame_create(2, 1, &f));
    tnd_frame_f(&f, TND_CT_SPEC)[0] = NAN;
    tnd_frame_f(&f, TND_CT_SPEC)[1] = -INFINITY;
    tnd_frame_quantize(&f, TND_PRECISION_F32);
    CHECK(tnd_frame_f(&f, TND_CT_SPEC)[0] == 0.0f && tnd_frame_f(&f, TND_CT_SPEC)[1] == -FLT_MAX,
          "float32 maps NaN/Inf to defined values");
cleanup:
    tnd_frame_destroy(&f);
}

/* Write a raw EXR with the given channels (all of a frame but with changes) for bad-input tests */
static tnd_result write_raw(const char *path, uint32_t w, uint32_t h, const char **names,
                            const tnd_exr_type *types, const float *data, int n, bool tagged)
{
    tnd_exr_channel_desc ch[64];
    for (int i = 0; i < n; i++)
        ch[i] = (tnd_exr_channel_desc){names[i], types[i], data, 1};
    tnd_exr_attr at = {
        .name = "tandem.contractVersion", .type = TND_ATTR_INT, .i = TND_CONTRACT_VERSION};
    return tnd_exr_write(path, w, h, ch, (uint32_t)n, &at, tagged ? 1 : 0, TND_EXR_ZIP);
}

static void test_capture_validation(void)
{
    enum { W = 8, H = 4 };
    float data[W * H];
    for (int i = 0; i < W * H; i++)
        data[i] = 0.5f;
    const char *req[] = {"albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y",
                         "normal.Z", "depth.Z",  "motion.X", "motion.Y", "motion.Z",
                         "hf.R",     "hf.G",     "hf.B"};
    tnd_exr_type types[20];
    for (int i = 0; i < 20; i++)
        types[i] = TND_EXR_FLOAT;
    tnd_frame f = {0};
    const char *p = tmp_path("v.exr");

    /* minimal valid capture: defaults and derivations fill the rest */
    REQUIRE_OK(write_raw(p, W, H, req, types, data, 13, true));
    CHECK_OK(tnd_capture_read(p, &f));
    CHECK(f.present[TND_CT_GEO_NORMAL] && !f.present[TND_CT_RNG], "derived geo_normal, no rng");
    CHECK(tnd_frame_f(&f, TND_CT_ROUGHNESS)[5] == 1.0f, "default roughness 1");
    /* no visibility buffer: derived from depth, a surface (0, 0) where it is a hit */
    for (int q = 0; q < W * H; q++) {
        bool hit = tnd_frame_f(&f, TND_CT_DEPTH)[q] < (float)TND_DEPTH_MISS;
        const uint32_t *v = tnd_frame_u(&f, TND_CT_VIS_ID) + 2 * q;
        CHECK(f.present[TND_CT_VIS_ID] && v[0] == (hit ? 0u : TND_VIS_NONE) &&
                  v[1] == (hit ? 0u : TND_VIS_NONE),
              "derived visibility at %d: %u %u", q, v[0], v[1]);
    }
    tnd_frame_destroy(&f);

    /* missing required entry, named */
    REQUIRE_OK(write_raw(p, W, H, req, types, data, 10, true));
    tnd_result r = tnd_capture_read(p, &f);
    CHECK(r == TND_ERR_BAD_INPUT && strstr(tnd_error_detail(), "entry 'hf': missing") &&
              strstr(tnd_error_detail(), "v.exr"),
          "missing hf: %s", tnd_error_detail());
    CHECK(f.data[0] == NULL, "no frame left allocated");

    /* partly present entry, wrong type, non-finite: all reported at once */
    const char *mixed[] = {"albedo.R", "albedo.G", "normal.X",     "normal.Y",     "normal.Z",
                           "depth.Z",  "motion.X", "motion.Y",     "motion.Z",     "hf.R",
                           "hf.G",     "hf.B",     "vis.instance", "vis.primitive"};
    float bad[W * H];
    memcpy(bad, data, sizeof bad);
    bad[W + 3] = NAN;
    bad[2] = INFINITY;
    REQUIRE_OK(write_raw(p, W, H, mixed, types, bad, 14, true));
    r = tnd_capture_read(p, &f);
    const char *d = tnd_error_detail();
    CHECK(r == TND_ERR_BAD_INPUT, "bad capture rejected");
    CHECK(strstr(d, "channel 'albedo.B': missing"), "partial entry: %s", d);
    CHECK(strstr(d, "channel 'vis.instance': wrong type FLOAT (expected UINT)"), "type: %s", d);
    CHECK(strstr(d, "channel 'normal.X': 2 non-finite values (first at pixel 2,0"),
          "non-finite with count and pixel: %s", d);

    /* not a Tandem capture, not an EXR, truncated, missing */
    REQUIRE_OK(write_raw(p, W, H, req, types, data, 13, false));
    CHECK(tnd_capture_read(p, &f) == TND_ERR_BAD_INPUT && strstr(tnd_error_detail(), "--map"),
          "untagged EXR: %s", tnd_error_detail());
    const char *txt = tmp_path("x.exr");
    CHECK_OK(tnd_file_write_atomic(txt, "hello world, not an exr", 23));
    CHECK(tnd_capture_read(txt, &f) != TND_OK && strstr(tnd_error_detail(), "x.exr"),
          "text file: %s", tnd_error_detail());
    REQUIRE_OK(write_raw(p, W, H, req, types, data, 13, true));
    void *bytes;
    size_t size;
    REQUIRE_OK(tnd_file_read(p, &bytes, &size));
    const char *tr = tmp_path("truncated.exr");
    CHECK_OK(tnd_file_write_atomic(tr, bytes, size * 2 / 3));
    free(bytes);
    r = tnd_capture_read(tr, &f);
    CHECK(r != TND_OK && strstr(tnd_error_detail(), "truncated.exr"), "truncated: %s",
          tnd_error_detail());
    CHECK(tnd_capture_read(tmp_path("nope.exr"), &f) == TND_ERR_IO, "missing file");

    /* a failing write leaves nothing behind: duplicate channel names are refused mid-header */
    const char *dup[] = {"albedo.R", "albedo.R"};
    const char *dp = tmp_path("dup.exr");
    CHECK(write_raw(dp, W, H, dup, types, data, 2, true) != TND_OK, "duplicate channels refused");
    CHECK(access(dp, F_OK) != 0, "no partial output file");
    char cmd[300], out[256] = "";
    snprintf(cmd, sizeof cmd, "ls '%s' | grep -c '\\.tmp\\.' || true", tmpdir);
    FILE *pp = popen(cmd, "r");
    if (pp) {
        if (!fgets(out, sizeof out, pp))
            out[0] = 0;
        pclose(pp);
    }
    CHECK(atoi(out) == 0, "no temporary files left (%s)", out);
    CHECK(tnd_capture_write(tmp_path("missing_dir/x.exr"), &(tnd_frame){0}, TND_EXR_ZIP) != TND_OK,
          "empty frame refused");
cleanup:
    tnd_frame_destroy(&f);
}

/* Written files open in tools nobody here wrote. */
static void test_independent_tools(void)
{
    tnd_frame f = {0};
    REQUIRE_OK(make_frame(32, 16, &f));
    tnd_frame_quantize(&f, TND_PRECISION_PACKED);
    const char *p = tmp_path("tools.exr");
    REQUIRE_OK(tnd_capture_write(p, &f, TND_EXR_PIZ));
    char cmd[512], out[65536];
    snprintf(cmd, sizeof cmd, "exrheader '%s' 2>&1", p);
    FILE *pp = popen(cmd, "r");
    size_t n = pp ? fread(out, 1, sizeof out - 1, pp) : 0;
    out[n] = 0;
    CHECK(pp && pclose(pp) == 0, "exrheader runs: %s", out);
    CHECK(strstr(out, "albedo.R, 16-bit floating-point") &&
              strstr(out, "vis.instance, 32-bit unsigned int") &&
              strstr(out, "hf.G, 32-bit floating-point") && strstr(out, "piz"),
          "exrheader shows the channels, types and compression");
    CHECK(strstr(out, "tandem.view") && strstr(out, "tandem.jitter"), "camera attributes");
    snprintf(cmd, sizeof cmd, "oiiotool --info -v '%s' 2>&1", p);
    pp = popen(cmd, "r");
    n = pp ? fread(out, 1, sizeof out - 1, pp) : 0;
    out[n] = 0;
    CHECK(pp && pclose(pp) == 0, "oiiotool runs");
    unsigned ow = 0, oh = 0;
    const char *colon = strstr(out, "tools.exr :");
    CHECK(colon && sscanf(colon + 11, " %u x %u", &ow, &oh) == 2 && ow == 32 && oh == 16,
          "oiiotool sees 32 x 16: %s", out);
    CHECK(strstr(out, "albedo.R") && strstr(out, "spec.B") && strstr(out, "lf.L0"),
          "oiiotool lists the channel names");
cleanup:
    tnd_frame_destroy(&f);
}

/* A synthetic Blender Cycles multilayer EXR read through the shipped mapping. */
static void test_cycles_mapping(void)
{
    enum { W = 16, H = 8 };
    static float noisy[3][W * H], albedo[3][W * H], normal[3][W * H], depth[W * H], vec[4][W * H],
        emit[3][W * H];
    for (int i = 0; i < W * H; i++) {
        for (int c = 0; c < 3; c++) {
            albedo[c][i] = 0.2f + 0.2f * (float)c;
            noisy[c][i] = albedo[c][i] * (1.0f + (float)i / 10.0f);
            normal[c][i] = c == 2 ? 2.0f : 0.0f; /* unnormalised +Z */
            emit[c][i] = i == 40 ? 0.25f : 0.0f;    /* an emitter at pixel 40 */
        }
        depth[i] = 5.0f;
        vec[0][i] = 1.5f, vec[1][i] = -2.0f, vec[2][i] = 0, vec[3][i] = 0;
    }
    depth[0] = 1e10f; /* Cycles' background */
    const char *names[] = {"ViewLayer.Noisy Image.R",      "ViewLayer.Noisy Image.G",
                           "ViewLayer.Noisy Image.B",      "ViewLayer.Denoising Albedo.R",
                           "ViewLayer.Denoising Albedo.G", "ViewLayer.Denoising Albedo.B",
                           "ViewLayer.Denoising Normal.X", "ViewLayer.Denoising Normal.Y",
                           "ViewLayer.Denoising Normal.Z", "ViewLayer.Depth.Z",
                           "ViewLayer.Vector.X",           "ViewLayer.Vector.Y",
                           "ViewLayer.Vector.Z",           "ViewLayer.Vector.W",
                           "ViewLayer.Emit.R",             "ViewLayer.Emit.G",
                           "ViewLayer.Emit.B"};
    const float *srcs[] = {noisy[0],  noisy[1],  noisy[2],  albedo[0], albedo[1],
                           albedo[2], normal[0], normal[1], normal[2], depth,
                           vec[0],    vec[1],    vec[2],    vec[3],    emit[0],
                           emit[1],   emit[2]};
    tnd_exr_channel_desc ch[17];
    for (int i = 0; i < 17; i++)
        ch[i] = (tnd_exr_channel_desc){names[i], i < 9 ? TND_EXR_HALF : TND_EXR_FLOAT, srcs[i], 1};
    const char *p = tmp_path("cycles.exr");
    tnd_capture_map *map = NULL;
    tnd_frame f = {0};
    REQUIRE_OK(tnd_exr_write(p, W, H, ch, 17, NULL, 0, TND_EXR_ZIP));
    REQUIRE_OK(tnd_capture_map_load(TND_SOURCE_DIR "/data/mappings/blender_cycles.json", &map));
    REQUIRE_OK(tnd_capture_read_mapped(p, map, NULL, &f));
    const float *hf = tnd_frame_f(&f, TND_CT_HF), *n = tnd_frame_f(&f, TND_CT_NORMAL);
    const float *m = tnd_frame_f(&f, TND_CT_MOTION), *dd = tnd_frame_f(&f, TND_CT_DEPTH);
    int i = 37;
    float half_noisy = tnd_half_to_float(tnd_half_from_float(noisy[1][i]));
    float half_alb = tnd_half_to_float(tnd_half_from_float(albedo[1][i]));
    CHECK_NEAR(hf[3 * i + 1], half_noisy / half_alb, 1e-6, "hf = noisy / albedo");
    CHECK_NEAR(n[3 * i + 2], 1.0, 1e-6, "normal normalised");
    /* Cycles' Vector.X/Y is previous minus current, y up (measured on a real capture:
     * tests/test_blender_capture.py): x kept, y flipped to Tandem's y down */
    CHECK_NEAR(m[3 * i], 1.5, 0, "motion x: Cycles' previous-minus-current");
    CHECK_NEAR(m[3 * i + 1], 2.0, 0, "motion y: y up flipped to y down");
    /* the emitter: its emission apart, the rest demodulated; the background pixel's noisy
     * radiance is its emission (the composite shows a miss's emission) */
    const float *em = tnd_frame_f(&f, TND_CT_EMISSION);
    float h40 = tnd_half_to_float(tnd_half_from_float(noisy[1][40]));
    float a40 = tnd_half_to_float(tnd_half_from_float(albedo[1][40]));
    CHECK_NEAR(em[3 * 40 + 1], 0.25, 0, "emission from the Emit pass");
    CHECK_NEAR(hf[3 * 40 + 1], (h40 - 0.25f) / a40, 1e-6, "hf = (noisy - emission) / albedo");
    CHECK_NEAR(em[1], tnd_half_to_float(tnd_half_from_float(noisy[1][0])), 0,
               "a miss's emission is its noisy radiance");
    /* planar depth 5 at pixel (5,2) through the mapping's 39.6 degree horizontal field of view */
    double fx = 0.5 * W / tan(0.5 * 39.6 * TND_PI / 180.0);
    double u = (5 + 0.5 - 8) / fx, v = (2 + 0.5 - 4) / fx;
    CHECK_NEAR(dd[2 * W + 5], 5.0 * sqrt(1 + u * u + v * v), 1e-5, "planar depth -> distance");
    CHECK(dd[0] == (float)TND_DEPTH_MISS, "background depth becomes TND_DEPTH_MISS");
    CHECK(!f.present[TND_CT_RNG], "no rng: the back-end will run as SVGF");
    tnd_frame_destroy(&f);
    /* another renderer's NaN and infinities: counted per entry and replaced (a miss for depth,
     * 0 otherwise), never refused and never passed on */
    noisy[1][50] = NAN;
    depth[51] = NAN;
    vec[0][52] = -INFINITY;
    REQUIRE_OK(tnd_exr_write(p, W, H, ch, 17, NULL, 0, TND_EXR_ZIP));
    REQUIRE_OK(tnd_capture_read_mapped(p, map, NULL, &f));
    CHECK(f.nonfinite[TND_CT_HF] == 1 && f.nonfinite[TND_CT_DEPTH] == 1 &&
              f.nonfinite[TND_CT_MOTION] == 1 && f.nonfinite[TND_CT_ALBEDO] == 0,
          "non-finite counted: hf %u, depth %u, motion %u", f.nonfinite[TND_CT_HF],
          f.nonfinite[TND_CT_DEPTH], f.nonfinite[TND_CT_MOTION]);
    CHECK(tnd_frame_f(&f, TND_CT_HF)[3 * 50 + 1] == 0.0f &&
              tnd_frame_f(&f, TND_CT_DEPTH)[51] == (float)TND_DEPTH_MISS &&
              tnd_frame_f(&f, TND_CT_MOTION)[3 * 52] == 0.0f,
          "non-finite replaced");
    for (int e = 0; e < TND_CT_COUNT; e++) {
        const tnd_ct_info *ci = tnd_ct_get((tnd_ct)e);
        for (size_t q = 0; ci->kind == TND_CT_FLOAT && q < (size_t)W * H * ci->comps; q++)
            CHECK(isfinite(tnd_frame_f(&f, (tnd_ct)e)[q]), "%s[%zu] finite", ci->name, q);
    }
    tnd_frame_destroy(&f);
    tnd_capture_map_destroy(map);
    map = NULL;

    /* a mapping that leaves a required entry unfed is rejected, naming it */
    const char *mp = tmp_path("partial.json");
    const char *json = "{\"tandem_mapping\": 1, \"entries\": {"
                       "\"albedo\": {\"channels\": [\"A.R\", \"A.G\", \"A.B\"]},"
                       "\"normal\": {\"channels\": [\"N.X\", \"N.Y\", \"N.Z\"]},"
                       "\"depth\": {\"channels\": [\"Z\"]},"
                       "\"motion\": {\"channels\": [null, null, null]}}}";
    REQUIRE_OK(tnd_file_write_atomic(mp, json, strlen(json)));
    REQUIRE_OK(tnd_capture_map_load(mp, &map));
    tnd_result r = tnd_capture_read_mapped(p, map, NULL, &f);
    CHECK(r == TND_ERR_BAD_INPUT && strstr(tnd_error_detail(), "required entry 'hf' is not fed"),
          "unfed hf: %s", tnd_error_detail());
    tnd_capture_map_destroy(map);
    map = NULL;
    REQUIRE_OK(
        tnd_file_write_atomic(mp, "{\"tandem_mapping\": 1, \"entries\": {\"albedo\": {", 44));
    CHECK(tnd_capture_map_load(mp, &map) == TND_ERR_BAD_INPUT &&
              strstr(tnd_error_detail(), "partial.json"),
          "broken JSON named: %s", tnd_error_detail());
    json = "{\"tandem_mapping\": 1, \"entries\": {\"colour\": {\"channels\": [\"R\"]}}}";
    REQUIRE_OK(tnd_file_write_atomic(mp, json, strlen(json)));
    CHECK(tnd_capture_map_load(mp, &map) == TND_ERR_BAD_INPUT &&
              strstr(tnd_error_detail(), "'colour' is not a contract entry"),
          "unknown entry: %s", tnd_error_detail());

    /* every number that becomes a float or an angle is range-checked: extremes are refused with
     * the key named, never read as inf/NaN or a string's 0 (cJSON reads 1e999 as inf) */
    static const struct {
        const char *json, *expect;
    } extremes[] = {
        {"{\"tandem_mapping\": 1.5, \"entries\": {}}", "\"tandem_mapping\": 1 expected"},
        {"{\"tandem_mapping\": 1, \"camera\": {\"xfov_degrees\": 180}, \"entries\": {}}",
         "camera.xfov_degrees: degrees in (0, 180)"},
        {"{\"tandem_mapping\": 1, \"camera\": {\"yfov_degrees\": -1}, \"entries\": {}}",
         "camera.yfov_degrees: degrees in (0, 180)"},
        {"{\"tandem_mapping\": 1, \"camera\": {\"xfov_degrees\": \"40\"}, \"entries\": {}}",
         "camera.xfov_degrees: degrees in (0, 180)"},
        {"{\"tandem_mapping\": 1, \"entries\": {\"albedo\": {\"channels\": [\"R\", \"G\", "
         "\"B\"], \"scale\": 1e999}}}",
         "\"scale\" must be a finite number"},
        {"{\"tandem_mapping\": 1, \"entries\": {\"albedo\": {\"channels\": [\"R\", \"G\", "
         "\"B\"], \"offset\": [0, 1e39, 0]}}}",
         "\"offset\" must be a finite number"},
        {"{\"tandem_mapping\": 1, \"entries\": {\"albedo\": {\"channels\": [\"R\", \"G\", "
         "\"B\"], \"scale\": [1, \"2\", 1]}}}",
         "\"scale\" must be a finite number"},
        {"{\"tandem_mapping\": 1, \"entries\": {\"depth\": {\"channels\": [\"Z\"], "
         "\"miss_at_or_above\": 1e999}}}",
         "\"miss_at_or_above\": a positive finite number"},
    };
    for (size_t x = 0; x < sizeof extremes / sizeof extremes[0]; x++) {
        REQUIRE_OK(tnd_file_write_atomic(mp, extremes[x].json, strlen(extremes[x].json)));
        r = tnd_capture_map_load(mp, &map);
        CHECK(r == TND_ERR_BAD_INPUT && strstr(tnd_error_detail(), "partial.json") &&
                  strstr(tnd_error_detail(), extremes[x].expect),
              "extreme %zu refused (%s): %s", x, extremes[x].expect, tnd_error_detail());
        tnd_capture_map_destroy(map);
        map = NULL;
    }
cleanup:
    tnd_capture_map_destroy(map);
    tnd_frame_destroy(&f);
}

static void test_cleanup(void)
{
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    CHECK(!tmpdir[0] || system(cmd) == 0, "cleanup");
}

TND_TEST_MAIN(T(test_table), T(test_document_matches_table), T(test_rgbe_extremes), T(test_uf16_extremes),
              T(test_half_extremes), T(test_quantize), T(test_capture_round_trip),
              T(test_capture_validation), T(test_independent_tools), T(test_cycles_mapping),
              T(test_cleanup))
