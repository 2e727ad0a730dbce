/* run/rn_eval.c: sequences of frames on disk against a reference directory, and the report
 * (shared by `tandem eval`, `tandem compare --reference` and `tandem bench --sweep`).
 * A series is a directory's frame_NNNN.exr (a run's linear output) or its capture/frame_NNNN.exr
 * composited without denoising (the noisy input), or those composites' running mean while
 * nothing moves (accumulation alone). Entry points: rn_eval_add, rn_eval_run,
 * rn_eval_report, rn_eval_free, rn_list_frames. */
#include "run/rn_internal.h"

#include <cjson/cJSON.h>
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* (rn_eval_report's frame rows: the reference and three panels per series; with 16 panels a
 * row, six series or more wrote past the row: `tandem rank` of 8 denoisers crashed) */
_Static_assert(1 + 3 * RN_EVAL_MAX_SERIES <= EV_ROW_PANELS, "a report row's panels");

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

tnd_result rn_eval_add(rn_eval *e, const char *name, const char *dir, rn_series_kind kind)
{
    if (e->nseries >= RN_EVAL_MAX_SERIES)
        return tnd_fail(TND_ERR_INVALID_ARGUMENT, "eval: at most %d series", RN_EVAL_MAX_SERIES);
    rn_eval_series *s = &e->series[e->nseries++];
    memset(s, 0, sizeof *s);
    snprintf(s->name, sizeof s->name, "%s", name);
    if (kind != RN_SERIES_OUTPUT)
        snprintf(s->dir, sizeof s->dir, "%s/capture", dir);
    else
        snprintf(s->dir, sizeof s->dir, "%s", dir);
    s->kind = kind;
    return TND_OK;
}

/* Whether anything moves on screen in a capture (its motion, jitter-free, not all zero). */
static bool capture_moves(const tnd_frame *f)
{
    if (!f->present[TND_CT_MOTION])
        return true;
    const float *m = tnd_frame_f(f, TND_CT_MOTION);
    for (size_t q = 0; q < (size_t)f->width * f->height; q++)
        if (m[3 * q] != 0.0f || m[3 * q + 1] != 0.0f)
            return true;
    return false;
}

/* The accumulated series: frame `frame`'s composite (img) added to the running mean, which
 * restarts where the frames are not consecutive or the capture moves; img becomes the mean. */
static tnd_result accumulate(rn_eval_series *s, uint32_t frame, const tnd_frame *f, ev_image *img)
{
    size_t n = (size_t)img->width * img->height * 3;
    if (n != s->acc_len) { /* (a capture of another size: eval refuses it after the load) */
        free(s->acc);
        if (!(s->acc = calloc(n, sizeof(double)))) {
            s->acc_len = 0;
            return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
        }
        s->acc_len = n;
        s->acc_n = 0;
    }
    if (s->acc_n == 0 || frame != s->acc_frame + 1 || capture_moves(f)) {
        memset(s->acc, 0, n * sizeof(double));
        s->acc_n = 0;
        s->acc_starts++;
    }
    s->acc_n++;
    s->acc_frame = frame;
    for (size_t i = 0; i < n; i++) {
        s->acc[i] += img->rgb[i];
        img->rgb[i] = (float)(s->acc[i] / s->acc_n);
    }
    return TND_OK;
}

/* Frame `frame` of a capture series: the capture composited (cap: that frame's capture, already
 * read, or NULL), and for the accumulated series added to its running mean, which img becomes. */
static tnd_result composite(rn_eval_series *s, uint32_t frame, const char *path, ev_image *img,
                            const tnd_frame *cap)
{
    tnd_frame own = {0};
    const tnd_frame *f = cap ? cap : &own;
    tnd_result res = f == &own ? tnd_capture_read(path, &own) : TND_OK;
    if (res == TND_OK)
        res = ev_image_alloc(f->width, f->height, img);
    if (res == TND_OK) {
        tnd_frame_composite(f, img->rgb);
        tnd_frame_interleave(f, img->rgb);
        if (s->kind == RN_SERIES_ACCUMULATED) {
            ev_image_sanitize(img); /* (a NaN would stay in the sum) */
            res = accumulate(s, frame, f, img);
        }
    }
    tnd_frame_destroy(&own);
    return res;
}

/* One frame of a series (a capture kind: composited) or of the reference (s NULL). A capture
 * series whose captures are e->regions_from composites `cap` (that frame's capture, already read
 * for the region masks; NULL: none) instead of reading it again. The accumulated series asked
 * for a frame out of order (the report's images) replays its running mean up to it: from where
 * it stands when the frame lies ahead, else from the first frame. */
static tnd_result load(const rn_eval *e, rn_eval_series *s, uint32_t frame, ev_image *img,
                       uint64_t *nonfinite, const tnd_frame *cap)
{
    char path[1300];
    snprintf(path, sizeof path, "%s/frame_%04u.exr", s ? s->dir : e->ref, frame);
    tnd_result res = TND_OK;
    if (s && s->kind == RN_SERIES_ACCUMULATED && s->acc_n > 0 && frame != s->acc_frame + 1) {
        bool ahead = frame > s->acc_frame;
        if (!ahead)
            s->acc_n = 0;
        for (uint32_t k = 0; res == TND_OK && k < e->count && e->frames[k] < frame; k++) {
            if (ahead && e->frames[k] <= s->acc_frame)
                continue;
            char p2[1300];
            snprintf(p2, sizeof p2, "%s/frame_%04u.exr", s->dir, e->frames[k]);
            ev_image tmp = {0};
            res = composite(s, e->frames[k], p2, &tmp, NULL);
            ev_image_free(&tmp);
        }
    }
    if (res != TND_OK)
        return res;
    if (s && s->kind != RN_SERIES_OUTPUT)
        res = composite(s, frame, path, img,
                        cap && strcmp(s->dir, e->regions_from) == 0 ? cap : NULL);
    else
        res = ev_image_read_exr(path, img);
    if (res == TND_OK) {
        uint64_t bad = ev_image_sanitize(img);
        if (nonfinite)
            *nonfinite = bad;
    }
    if (res == TND_OK && s && e->resample && e->width &&
        (img->width != e->width || img->height != e->height)) {
        ev_image big;
        res = ev_image_resize(img, e->width, e->height, &big);
        ev_image_free(img);
        *img = big;
    }
    return res;
}

void rn_eval_free(rn_eval *e)
{
    for (uint32_t i = 0; i < e->nseries; i++) {
        free(e->series[i].m);
        free(e->series[i].acc);
        e->series[i].acc = NULL;
        e->series[i].acc_len = 0;
    }
    free(e->frames);
    e->frames = NULL;
    e->nseries = 0;
}

/* The frames the reference and every series have. */
static tnd_result common_frames(rn_eval *e)
{
    uint32_t *ref = NULL, nref = 0;
    tnd_result res = rn_list_frames(e->ref, &ref, &nref);
    if (res != TND_OK)
        return res;
    e->count = 0;
    e->frames = malloc((nref + 1) * sizeof *e->frames);
    if (!e->frames) {
        free(ref);
        return tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    }
    uint32_t *have[RN_EVAL_MAX_SERIES] = {0}, nhave[RN_EVAL_MAX_SERIES] = {0};
    for (uint32_t i = 0; i < e->nseries && res == TND_OK; i++)
        res = rn_list_frames(e->series[i].dir, &have[i], &nhave[i]);
    for (uint32_t k = 0; res == TND_OK && k < nref; k++) {
        bool all = true;
        for (uint32_t i = 0; i < e->nseries && all; i++)
            all = bsearch(&ref[k], have[i], nhave[i], sizeof(uint32_t), cmp_u32) != NULL;
        if (all && ref[k] >= e->min_frame)
            e->frames[e->count++] = ref[k];
    }
    if (res == TND_OK && e->count == 0)
        res = tnd_fail(TND_ERR_BAD_INPUT,
                       "eval: no frame_NNNN.exr is in both the reference %s (%u frames) and %s "
                       "(%u frames)",
                       e->ref, nref, e->nseries ? e->series[0].dir : "?", e->nseries ? nhave[0] : 0);
    for (uint32_t i = 0; i < e->nseries; i++)
        free(have[i]);
    free(ref);
    return res;
}

/* What the region masks carry from frame to frame: the previous capture's instance and depth per
 * pixel, and how many frames each pixel's surface has been visible (for `disoccluded`). */
typedef struct region_state {
    uint32_t *inst;
    float *depth;
    uint8_t *age;
    uint32_t frame; /* the frame they are of */
    bool have;      /* false: no previous frame (the first, or after a gap) */
} region_state;

enum { REGION_DISOCCLUDED_FRAMES = 4 }; /* newly visible: the frame it appears and 3 more */

static bool is_hit(float depth)
{
    return depth < 0.5 * TND_DEPTH_MISS;
}

/* Was the surface at pixel q (instance, depth, motion) visible at its previous position? The
 * pixels within one of where the motion leads that show the same instance span the depth the
 * motion says, give or take 5% plus 1.5 times what it changes over a pixel on the surface
 * (`slope`): neighbours count because the sub-pixel jitter moves edges by a pixel, and their
 * span because a face seen edge-on crosses a range of depths within one pixel. */
static bool was_visible(const region_state *st, uint32_t w, uint32_t h, uint32_t inst, float depth,
                        double slope, const float *m, uint32_t x, uint32_t y)
{
    double px = x + m[0], py = y + m[1], want = (double)depth + m[2];
    double tol = 0.05 * fabs(want) + 1.5 * slope;
    long cx = lround(px), cy = lround(py);
    double lo = INFINITY, hi = -INFINITY;
    for (long dy = -1; dy <= 1; dy++)
        for (long dx = -1; dx <= 1; dx++) {
            long xx = cx + dx, yy = cy + dy;
            if (xx < 0 || yy < 0 || xx >= (long)w || yy >= (long)h)
                continue;
            size_t o = (size_t)yy * w + (size_t)xx;
            if (st->inst[o] == inst)
                lo = fmin(lo, st->depth[o]), hi = fmax(hi, st->depth[o]);
        }
    return want >= lo - tol && want <= hi + tol;
}

/* The region masks of frame `frame` from the run's capture, or false; the capture stays in *cap
 * for the noisy series (caller destroys it). Bits of mask[q]:
 *   mirror, glass: the path flags (docs/specular.md);
 *   emitter: a surface that emits towards the camera (the sky is no emitter);
 *   emitter_edge: any other pixel within 2 pixels of an emitter's (where a filter that reaches
 *     across the boundary spreads the light, and TAA's history ghosts it);
 *   glossy: a surface of roughness under 0.4 (GGX alpha under 0.16) not already mirror or glass;
 *   disoccluded: a surface that was not visible where its motion leads in the previous frame
 *     (was_visible), in the frame it appears and the 3 after while it stays visible: what
 *     motion uncovers, and faces seen edge-on that the sub-pixel jitter shows in one frame and
 *     not the one before (pixels without a history either way);
 *   moving: motion over a quarter pixel (camera or object);
 *   thin: a surface at most 3 pixels wide along x or y: on both sides within 2 pixels, one at
 *     least 10% farther away, and the two behind it alike (both sky, or within 20%). */
static bool region_masks(const rn_eval *e, uint32_t frame, uint32_t w, uint32_t h, uint8_t *mask,
                         tnd_frame *cap, region_state *st)
{
    if (!e->regions_from[0])
        return false;
    char path[1300];
    snprintf(path, sizeof path, "%s/frame_%04u.exr", e->regions_from, frame);
    bool ok = tnd_capture_read(path, cap) == TND_OK && cap->width == w && cap->height == h &&
              cap->present[TND_CT_PATH];
    tnd_error_clear();
    if (!ok) {
        tnd_frame_destroy(cap);
        st->have = false;
        return false;
    }
    const uint32_t *p = tnd_frame_u(cap, TND_CT_PATH), *vis = tnd_frame_u(cap, TND_CT_VIS_ID);
    const float *depth = tnd_frame_f(cap, TND_CT_DEPTH), *em = tnd_frame_f(cap, TND_CT_EMISSION);
    const float *rough = tnd_frame_f(cap, TND_CT_ROUGHNESS), *mo = tnd_frame_f(cap, TND_CT_MOTION);
    const float *gn = tnd_frame_f(cap, TND_CT_GEO_NORMAL);
    size_t n = (size_t)w * h;
    bool prev = st->have && frame == st->frame + 1;
    for (size_t q = 0; q < n; q++) {
        uint32_t b = 0;
        bool hit = is_hit(depth[q]);
        if (p[q] & TND_PATH_MIRROR)
            b |= 1u << RN_REGION_MIRROR;
        if (p[q] & (TND_PATH_GLASS | TND_PATH_SPLIT))
            b |= 1u << RN_REGION_GLASS;
        if (hit && em[3 * q] + em[3 * q + 1] + em[3 * q + 2] > 0.0f)
            b |= 1u << RN_REGION_EMITTER;
        if (hit && rough[q] < 0.4f && !(b & (1u << RN_REGION_MIRROR | 1u << RN_REGION_GLASS)))
            b |= 1u << RN_REGION_GLOSSY;
        const float *m = mo + 3 * q;
        if (m[0] * m[0] + m[1] * m[1] > 0.0625f)
            b |= 1u << RN_REGION_MOVING;
        mask[q] = (uint8_t)b;
    }
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t q = (size_t)y * w + x;
            bool near = false, thin = false;
            for (long dy = -2; dy <= 2 && !near; dy++)
                for (long dx = -2; dx <= 2 && !near; dx++) {
                    long xx = (long)x + dx, yy = (long)y + dy;
                    near = xx >= 0 && yy >= 0 && xx < (long)w && yy < (long)h &&
                           (mask[(size_t)yy * w + (size_t)xx] & 1u << RN_REGION_EMITTER);
                }
            if (near && !(mask[q] & 1u << RN_REGION_EMITTER))
                mask[q] |= 1u << RN_REGION_EMITTER_EDGE;
            if (is_hit(depth[q]))
                for (int axis = 0; axis < 2 && !thin; axis++) {
                    bool side[2] = {false, false};
                    float behind[2] = {0, 0};
                    for (int sgn = 0; sgn < 2; sgn++)
                        for (long d = 1; d <= 2 && !side[sgn]; d++) {
                            long xx = (long)x + (axis == 0 ? (sgn ? d : -d) : 0);
                            long yy = (long)y + (axis == 1 ? (sgn ? d : -d) : 0);
                            if (xx < 0 || yy < 0 || xx >= (long)w || yy >= (long)h)
                                continue;
                            float o = depth[(size_t)yy * w + (size_t)xx];
                            side[sgn] = !is_hit(o) || o > 1.1f * depth[q];
                            behind[sgn] = o;
                        }
                    /* (the same background on both sides, both sky or within 20% of each
                     * other: not the edge of a wall seen edge-on, sky on one side and the room
                     * on the other) */
                    float b0 = behind[0], b1 = behind[1];
                    bool same = is_hit(b0) == is_hit(b1) &&
                                (!is_hit(b0) || fabsf(b0 - b1) <= 0.2f * fminf(b0, b1));
                    thin = side[0] && side[1] && same;
                }
            if (thin)
                mask[q] |= 1u << RN_REGION_THIN;
        }
    /* newly visible surfaces: each pixel's age follows it along the motion */
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t q = (size_t)y * w + x;
            uint8_t age = UINT8_MAX;
            if (prev && is_hit(depth[q])) {
                const float *m = mo + 3 * q;
                /* the depth's change over a pixel on this surface: to the 4 neighbours
                 * that face the same way (geometric normals within 25 degrees) */
                double slope = 0;
                const long nb[4][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
                for (int k = 0; k < 4; k++) {
                    long xx = (long)x + nb[k][0], yy = (long)y + nb[k][1];
                    if (xx < 0 || yy < 0 || xx >= (long)w || yy >= (long)h)
                        continue;
                    size_t o = (size_t)yy * w + (size_t)xx;
                    const float *a = gn + 3 * q, *b = gn + 3 * o;
                    if (is_hit(depth[o]) && a[0] * b[0] + a[1] * b[1] + a[2] * b[2] > 0.9f)
                        slope = fmax(slope, fabs((double)depth[o] - depth[q]));
                }
                if (!was_visible(st, w, h, vis[2 * q], depth[q], slope, m, x, y)) {
                    age = 0;
                } else {
                    long px = lround(x + m[0]), py = lround(y + m[1]);
                    if (px >= 0 && py >= 0 && px < (long)w && py < (long)h) {
                        uint8_t a = st->age[(size_t)py * w + (size_t)px];
                        age = a < UINT8_MAX ? (uint8_t)(a + 1) : a;
                    }
                }
            }
            if (age < REGION_DISOCCLUDED_FRAMES)
                mask[q] |= 1u << RN_REGION_DISOCCLUDED;
            /* (written after every pixel has read the previous ages: a second array) */
            st->age[n + q] = age;
        }
    memcpy(st->age, st->age + n, n);
    for (size_t q = 0; q < n; q++) {
        st->inst[q] = is_hit(depth[q]) ? vis[2 * q] : TND_VIS_NONE;
        st->depth[q] = depth[q];
    }
    st->frame = frame;
    st->have = true;
    return true;
}

/* to, tr: the frame's tone-mapped output and reference (what the sequence just measured) */
static void region_add(rn_region *r, int bit, const uint8_t *mask, const ev_image *out,
                       const ev_image *ref, const float *flip, const float *to, const float *tr)
{
    uint32_t w = ref->width, h = ref->height;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t q = (size_t)y * w + x;
            if (!(mask[q] & (1u << bit)))
                continue;
            r->pixels++;
            r->flip += flip[q];
            const float *o3 = out->rgb + 3 * q, *r3 = ref->rgb + 3 * q;
            r->lum_out += 0.2126 * o3[0] + 0.7152 * o3[1] + 0.0722 * o3[2];
            r->lum_ref += 0.2126 * r3[0] + 0.7152 * r3[1] + 0.0722 * r3[2];
            for (int k = 0; k < 3; k++) {
                double d = (double)out->rgb[3 * q + k] - ref->rgb[3 * q + k];
                r->rel_sq += d * d / ((double)ref->rgb[3 * q + k] * ref->rgb[3 * q + k] + EV_RELMSE_EPS);
                r->values++;
            }
            const size_t nb[2] = {x + 1 < w ? q + 1 : q, y + 1 < h ? q + w : q};
            for (int a = 0; a < 2; a++) {
                size_t o = nb[a];
                if (o == q || !(mask[o] & (1u << bit)))
                    continue;
                for (int k = 0; k < 3; k++) {
                    r->grad_out += fabs((double)to[3 * o + k] - to[3 * q + k]);
                    r->grad_ref += fabs((double)tr[3 * o + k] - tr[3 * q + k]);
                }
                r->pairs++;
            }
        }
}

/* The reference's motion and depth of a frame (REF/frame_NNNN.motion.exr, written by `tandem
 * reference`), for the motion-compensated metrics; false when absent or unusable. */
static bool load_motion(const rn_eval *e, uint32_t frame, float *motion, float *depth)
{
    char path[1300];
    snprintf(path, sizeof path, "%s/frame_%04u.motion.exr", e->ref, frame);
    struct stat st;
    if (stat(path, &st) != 0)
        return false;
    tnd_exr_file x;
    if (tnd_exr_read(path, &x) != TND_OK) {
        tnd_warn("eval", "%s: unreadable (%s): no motion-compensated metrics", path,
                 tnd_error_detail());
        tnd_error_clear();
        return false;
    }
    const char *names[4] = {"motion.X", "motion.Y", "motion.Z", "depth.Z"};
    const tnd_exr_channel *c[4];
    bool ok = x.width == e->width && x.height == e->height;
    for (int k = 0; k < 4 && ok; k++)
        ok = (c[k] = tnd_exr_find(&x, names[k])) && c[k]->data && c[k]->type != TND_EXR_UINT;
    if (ok) {
        size_t n = (size_t)x.width * x.height;
        for (size_t q = 0; q < n; q++) {
            for (int k = 0; k < 3; k++)
                motion[3 * q + k] = ((const float *)c[k]->data)[q];
            depth[q] = ((const float *)c[3]->data)[q];
        }
    } else {
        tnd_warn("eval", "%s: not the frame's motion (motion.X/Y/Z, depth.Z at %ux%u): no "
                         "motion-compensated metrics", path, e->width, e->height);
    }
    tnd_exr_close(&x);
    return ok;
}

/* The per-image metrics' device (rn_eval.metrics_on): NULL for the CPU. */
static tnd_result open_metrics_device(const rn_eval *e, tnd_vk *vk, ev_gpu **g)
{
    *g = NULL;
    const char *on = e->metrics_on ? e->metrics_on : "auto";
    if (strcmp(on, "cpu") == 0)
        return TND_OK;
    bool must = strcmp(on, "device") == 0;
    tnd_result res = tnd_vk_create(&(tnd_vk_desc){.no_ray_tracing = true}, vk);
    if (res == TND_OK && (must || vk->info.type != VK_PHYSICAL_DEVICE_TYPE_CPU))
        res = ev_gpu_create(vk, e->width, e->height, e->ppd, g);
    if (res != TND_OK && !must) { /* (auto: the CPU, without a word) */
        tnd_error_clear();
        res = TND_OK;
    }
    if (!*g && vk->device)
        tnd_vk_destroy(vk), memset(vk, 0, sizeof *vk);
    return res;
}

tnd_result rn_eval_run(rn_eval *e)
{
    tnd_result res = common_frames(e);
    ev_image img = {0}, ref = {0};
    ev_sequence *seq[RN_EVAL_MAX_SERIES] = {0};
    tnd_vk vk = {0};
    ev_gpu *gpu = NULL;
    uint8_t *mask = NULL;
    float *flip = NULL, *motion = NULL, *depth = NULL;
    tnd_frame cap = {0};
    region_state rs = {0};
    if (res != TND_OK)
        return res;
    if (!(e->ppd > 0))
        e->ppd = EV_FLIP_PPD;
    /* the exposure: geometric-mean luminance of all reference frames -> 0.18 (or given) */
    if (!(e->exposure > 0)) {
        double logsum = 0;
        size_t n = 0;
        for (uint32_t k = 0; k < e->count; k++) {
            TND_TRY(load(e, NULL, e->frames[k], &ref, NULL, NULL));
            double x = ev_auto_exposure(&ref, 1);
            size_t px = (size_t)ref.width * ref.height;
            logsum += log(0.18 / x) * (double)px;
            n += px;
            ev_image_free(&ref);
        }
        e->exposure = 0.18 / exp(logsum / (double)n);
        e->auto_exposure = true;
    }
    for (uint32_t i = 0; i < e->nseries; i++) {
        e->series[i].acc_n = e->series[i].acc_starts = 0;
        e->series[i].m = calloc(e->count, sizeof(ev_frame_metrics));
        if (!e->series[i].m) {
            res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
            goto fail;
        }
    }
    for (uint32_t k = 0; k < e->count; k++) {
        TND_TRY(load(e, NULL, e->frames[k], &ref, NULL, NULL));
        if (k == 0) {
            e->width = ref.width;
            e->height = ref.height;
            size_t n = (size_t)ref.width * ref.height;
            mask = malloc(n);
            flip = malloc(n * sizeof(float));
            motion = malloc(n * 3 * sizeof(float));
            depth = malloc(n * sizeof(float));
            rs.inst = malloc(n * sizeof *rs.inst);
            rs.depth = malloc(n * sizeof *rs.depth);
            rs.age = malloc(2 * n);
            if (!mask || !flip || !motion || !depth || !rs.inst || !rs.depth || !rs.age) {
                res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
                goto fail;
            }
            TND_TRY(open_metrics_device(e, &vk, &gpu));
            for (uint32_t i = 0; i < e->nseries; i++) {
                TND_TRY(ev_sequence_create(ref.width, ref.height, e->exposure, e->ppd, &seq[i]));
                ev_sequence_gpu(seq[i], gpu);
            }
        } else if (ref.width != e->width || ref.height != e->height) {
            res = tnd_fail(TND_ERR_BAD_INPUT, "eval: %s/frame_%04u.exr is %ux%u, frame %u was %ux%u",
                           e->ref, e->frames[k], ref.width, ref.height, e->frames[0], e->width,
                           e->height);
            goto fail;
        }
        tnd_frame_destroy(&cap);
        bool regions = region_masks(e, e->frames[k], ref.width, ref.height, mask, &cap, &rs);
        /* the reference's motion, frame after frame (a gap: the next frame starts afresh) */
        bool consecutive = k == 0 || e->frames[k] == e->frames[k - 1] + 1;
        if (consecutive && load_motion(e, e->frames[k], motion, depth))
            for (uint32_t i = 0; i < e->nseries; i++)
                ev_sequence_motion(seq[i], motion, depth);
        for (uint32_t i = 0; i < e->nseries; i++) {
            uint64_t bad = 0;
            TND_TRY(load(e, &e->series[i], e->frames[k], &img, &bad, regions ? &cap : NULL));
            if (img.width != ref.width || img.height != ref.height) {
                res = tnd_fail(TND_ERR_BAD_INPUT,
                               "eval: %s/frame_%04u.exr is %ux%u, the reference is %ux%u",
                               e->series[i].dir, e->frames[k], img.width, img.height, ref.width,
                               ref.height);
                goto fail;
            }
            /* worth N by FLIP (a search of FLIP evaluations) on the last frame of each eighth
             * of the sequence; by relMSE on every frame */
            uint32_t eighth = (e->count + RN_WORTH_FLIP_FRAMES - 1) / RN_WORTH_FLIP_FRAMES;
            ev_sequence_worth_flip(seq[i], (k + 1) % eighth == 0 || k + 1 == e->count);
            TND_TRY(ev_sequence_add(seq[i], e->frames[k], &img, &ref, &e->series[i].m[k],
                                    regions ? flip : NULL));
            const float *to, *tr;
            ev_sequence_display(seq[i], &to, &tr);
            for (int b = 0; regions && b < RN_REGIONS; b++)
                region_add(&e->series[i].regions[b], b, mask, &img, &ref, flip, to, tr);
            e->series[i].m[k].nonfinite = bad;
            e->series[i].summary.nonfinite += bad;
            ev_image_free(&img);
        }
        ev_image_free(&ref);
        if (e->progress)
            rn_progress_step(e->progress, k + 1);
    }
    for (uint32_t i = 0; i < e->nseries; i++) {
        uint64_t bad = e->series[i].summary.nonfinite;
        ev_sequence_summary(seq[i], &e->series[i].summary);
        e->series[i].summary.nonfinite = bad;
        e->series[i].restarts = e->series[i].acc_starts ? e->series[i].acc_starts - 1 : 0;
    }
fail:
    for (uint32_t i = 0; i < e->nseries; i++)
        ev_sequence_destroy(seq[i]);
    ev_gpu_destroy(gpu);
    if (vk.device)
        tnd_vk_destroy(&vk);
    ev_image_free(&img);
    ev_image_free(&ref);
    free(mask);
    free(flip);
    free(motion);
    free(depth);
    free(rs.inst);
    free(rs.depth);
    free(rs.age);
    tnd_frame_destroy(&cap);
    return res;
}

rn_convergence rn_eval_convergence(const rn_eval *e)
{
    rn_convergence c = {0};
    bool out = false, acc = false;
    for (uint32_t i = 0; i < e->nseries; i++) {
        if (!out && e->series[i].kind == RN_SERIES_OUTPUT)
            c.output = i, out = true;
        if (!acc && e->series[i].kind == RN_SERIES_ACCUMULATED)
            c.accumulated = i, acc = true;
    }
    c.have = out && acc && e->count > 0;
    if (!c.have)
        return c;
    c.restarts = e->series[c.accumulated].restarts;
    c.still = c.restarts == 0;
    uint32_t n = e->count / 4 ? e->count / 4 : 1;
    for (uint32_t k = e->count - n; k < e->count; k++) {
        c.last_output += e->series[c.output].m[k].relmse / n;
        c.last_accumulated += e->series[c.accumulated].m[k].relmse / n;
    }
    c.converges = c.last_output <= c.last_accumulated;
    return c;
}

void rn_eval_convergence_text(const rn_eval *e, const char *indent, ev_text *t)
{
    rn_convergence c = rn_eval_convergence(e);
    if (!c.have)
        return;
    const ev_frame_metrics *o = e->series[c.output].m, *a = e->series[c.accumulated].m;
    ev_text_add(t, "%sconvergence (relMSE at frame N, the run / accumulation alone):", indent);
    for (uint32_t k = 0; k < e->count; k = 2 * k + 1) {
        ev_text_add(t, " %u: %.4g/%.4g", o[k].frame, o[k].relmse, a[k].relmse);
        if (2 * k + 1 >= e->count && k + 1 < e->count) { /* and the last */
            uint32_t l = e->count - 1;
            ev_text_add(t, " %u: %.4g/%.4g", o[l].frame, o[l].relmse, a[l].relmse);
        }
    }
    ev_text_add(t, "\n");
    if (c.still)
        ev_text_add(t,
                    "%snothing moves: over the last quarter of the frames relMSE %.4g against "
                    "accumulation alone's %.4g: %s\n",
                    indent, c.last_output, c.last_accumulated,
                    c.converges ? "converges (at or below accumulation alone)"
                                : "ends above accumulation alone (it does not converge)");
    else
        ev_text_add(t,
                    "%sthe image moves: accumulation alone restarts %u times (the running mean "
                    "of the noisy frames since the last motion)\n",
                    indent, c.restarts);
}

const char *rn_region_name(int region)
{
    static const char *const names[RN_REGIONS] = {
        [RN_REGION_MIRROR] = "mirror",           [RN_REGION_GLASS] = "glass",
        [RN_REGION_EMITTER] = "emitter",         [RN_REGION_EMITTER_EDGE] = "emitter_edge",
        [RN_REGION_GLOSSY] = "glossy",           [RN_REGION_DISOCCLUDED] = "disoccluded",
        [RN_REGION_MOVING] = "moving",           [RN_REGION_THIN] = "thin"};
    return region >= 0 && region < RN_REGIONS ? names[region] : "?";
}

rn_region_stats rn_region_summary(const rn_region *r)
{
    return (rn_region_stats){
        .relmse = r->values ? r->rel_sq / (double)r->values : 0.0,
        .flip = r->pixels ? r->flip / (double)r->pixels : 0.0,
        .sharpness = r->grad_ref > 0 ? r->grad_out / r->grad_ref : 0.0,
        .bias = r->lum_ref > 0 ? r->lum_out / r->lum_ref - 1.0 : 0.0,
    };
}

char *rn_eval_regions_json(const rn_eval *e, uint32_t i)
{
    ev_text t = {0};
    int any = 0;
    ev_text_add(&t, "{");
    for (int b = 0; b < RN_REGIONS; b++) {
        const rn_region *r = &e->series[i].regions[b];
        if (!r->pixels)
            continue;
        rn_region_stats st = rn_region_summary(r);
        ev_text_add(&t, "%s\"%s\": {\"pixels\": %llu, \"relmse\": %.9g, \"flip\": %.9g, "
                        "\"sharpness\": %.9g, \"bias\": %.9g}",
                    any++ ? ", " : "", rn_region_name(b), (unsigned long long)r->pixels,
                    st.relmse, st.flip, st.sharpness, st.bias);
    }
    ev_text_add(&t, "}");
    if (!any || t.failed) {
        ev_text_free(&t);
        return NULL;
    }
    return t.s;
}

void rn_eval_regions_html(const rn_eval *e, ev_text *t)
{
    bool any = false;
    for (uint32_t i = 0; i < e->nseries; i++)
        for (int b = 0; b < RN_REGIONS; b++)
            any |= e->series[i].regions[b].pixels > 0;
    if (!any)
        return;
    ev_text_add(t, "<h2>Regions (from the run's capture)</h2>\n<p>Over all frames: pixels seen "
                   "in a mirror, at glass, an emitter, within 2 pixels of one, glossy surfaces "
                   "(roughness under 0.4), surfaces in their first 4 frames after they appeared, "
                   "moving pixels (over a quarter pixel), thin parts (at most 3 pixels wide); a "
                   "pixel may be in several. Sharpness: the tone-mapped image's summed absolute "
                   "pixel differences inside the region over the reference's (below 1: blurrier "
                   "than the reference; noise raises it).</p>\n<table><tr><th>series</th><th>region"
                   "</th><th>pixels</th><th>relMSE</th><th>FLIP</th><th>sharpness</th><th>bias</th></tr>\n");
    for (uint32_t i = 0; i < e->nseries; i++)
        for (int b = 0; b < RN_REGIONS; b++) {
            const rn_region *r = &e->series[i].regions[b];
            if (!r->pixels)
                continue;
            rn_region_stats st = rn_region_summary(r);
            ev_text_add(t, "<tr><td>");
            ev_text_escaped(t, e->series[i].name);
            ev_text_add(t, "</td><td>%s</td><td>%llu</td><td>%.4g</td><td>%.4f</td><td>%.3f</td>"
                           "<td>%+.1f%%</td></tr>\n",
                        rn_region_name(b), (unsigned long long)r->pixels, st.relmse, st.flip,
                        st.sharpness, 100.0 * st.bias);
        }
    ev_text_add(t, "</table>\n");
}

/* ---- report -------------------------------------------------------------------------------- */
static tnd_result png(const char *dir, const char *name, const float *rgb, uint32_t w, uint32_t h)
{
    char path[1400];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return ev_write_png(path, rgb, w, h);
}

/* nearest-neighbour crop (x0, y0, size c) scaled by s */
static void crop(const float *rgb, uint32_t w, uint32_t x0, uint32_t y0, uint32_t c, uint32_t s,
                 float *out)
{
    for (uint32_t y = 0; y < c * s; y++)
        for (uint32_t x = 0; x < c * s; x++)
            for (int k = 0; k < 3; k++)
                out[3 * ((size_t)y * c * s + x) + k] =
                    rgb[3 * ((size_t)(y0 + y / s) * w + x0 + x / s) + k];
}

/* The report you can watch: REPORT/viewer.html and viewer.js, every frame of the reference and
 * of every series (frames/fNNNN.js, linear HDR at most EV_VIEWER_MAX_SIZE a side), each series'
 * FLIP map per frame (frames/fNNNN_sI_flip.png) and report.js (the frames, the per-frame
 * metrics the plots draw, the settings, the run's frame rate). */
static tnd_result write_viewer(rn_eval *e, const char *dir, const char *title,
                               const char *settings)
{
    tnd_result res = TND_OK;
    uint32_t w = e->width, h = e->height, ns = e->nseries, f = ev_viewer_scale(w, h);
    uint32_t vw = w / f, vh = h / f;
    size_t n = (size_t)w * h;
    char fdir[1300], path[1500];
    ev_image ref = {0}, img[RN_EVAL_MAX_SERIES] = {{0}};
    float *tr = malloc(n * 3 * sizeof(float)), *tm = malloc(n * 3 * sizeof(float));
    float *map = malloc(n * sizeof(float)), *col = malloc(n * 3 * sizeof(float));
    float *small = malloc((size_t)vw * vh * 3 * sizeof(float));
    cJSON *root = NULL;
    char *txt = NULL;
    if (!tr || !tm || !map || !col || !small) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
        goto fail;
    }
    snprintf(fdir, sizeof fdir, "%s/frames", dir);
    TND_TRY(tnd_mkdirs(fdir));
    TND_TRY(ev_viewer_assets(dir));
    for (uint32_t k = 0; k < e->count; k++) {
        uint32_t fr = e->frames[k];
        const float *hdr[RN_EVAL_MAX_SERIES + 1];
        TND_TRY(load(e, NULL, fr, &ref, NULL, NULL));
        hdr[0] = ref.rgb;
        ev_tonemap(&ref, e->exposure, tr);
        for (uint32_t i = 0; i < ns; i++) {
            TND_TRY(load(e, &e->series[i], fr, &img[i], NULL, NULL));
            hdr[i + 1] = img[i].rgb;
            ev_tonemap(&img[i], e->exposure, tm);
            double mean;
            TND_TRY(ev_flip(tr, tm, w, h, e->ppd, map, &mean));
            ev_colormap(map, n, col);
            for (uint32_t y = 0; y < vh; y++) /* (box filter to the viewer's size) */
                for (uint32_t x = 0; x < vw; x++)
                    for (int c = 0; c < 3; c++) {
                        double sum = 0;
                        for (uint32_t j = 0; j < f; j++)
                            for (uint32_t q = 0; q < f; q++)
                                sum += col[3 * ((size_t)(y * f + j) * w + x * f + q) + c];
                        small[3 * ((size_t)y * vw + x) + c] = (float)(sum / (f * f));
                    }
            snprintf(path, sizeof path, "%s/f%04u_s%u_flip.png", fdir, fr, i);
            TND_TRY(ev_write_png(path, small, vw, vh));
        }
        snprintf(path, sizeof path, "%s/f%04u.js", fdir, fr);
        TND_TRY(ev_viewer_frame(path, k, hdr, ns + 1, w, h));
        ev_image_free(&ref);
        for (uint32_t i = 0; i < ns; i++)
            ev_image_free(&img[i]);
    }
    root = cJSON_CreateObject();
    cJSON_AddStringToObject(root, "title", title);
    cJSON *set = settings ? cJSON_Parse(settings) : NULL;
    const cJSON *fps = cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(set, "run"),
                                                        "fps");
    cJSON_AddNumberToObject(root, "fps", cJSON_IsNumber(fps) ? fps->valuedouble : 30.0);
    cJSON_AddNumberToObject(root, "width", vw);
    cJSON_AddNumberToObject(root, "height", vh);
    cJSON_AddNumberToObject(root, "exposure", e->exposure);
    cJSON *frames = cJSON_AddArrayToObject(root, "frames");
    cJSON *sources = cJSON_AddArrayToObject(root, "sources");
    cJSON *series = cJSON_AddArrayToObject(root, "series");
    for (uint32_t k = 0; k < e->count; k++)
        cJSON_AddItemToArray(frames, cJSON_CreateNumber(e->frames[k]));
    cJSON_AddItemToArray(sources, cJSON_CreateString("reference"));
    for (uint32_t i = 0; i < ns; i++) {
        cJSON_AddItemToArray(sources, cJSON_CreateString(e->series[i].name));
        cJSON_AddItemToArray(series, cJSON_CreateString(e->series[i].name));
    }
    cJSON *metrics = cJSON_AddObjectToObject(root, "metrics");
    for (uint32_t m = 0; m < ev_metric_count(); m++) { /* the watched metrics' curves */
        const ev_metric *em = ev_metric_at(m);
        if (!em->watched)
            continue;
        cJSON *rows = cJSON_AddArrayToObject(metrics, em->name);
        bool any = false;
        for (uint32_t i = 0; i < ns; i++) {
            cJSON *row = cJSON_CreateArray();
            for (uint32_t k = 0; k < e->count; k++) {
                double v = ev_metric_frame(em, &e->series[i].m[k]);
                any |= v >= 0 && em->optional;
                cJSON_AddItemToArray(row, v < 0 ? cJSON_CreateNull() : cJSON_CreateNumber(v));
            }
            cJSON_AddItemToArray(rows, row);
        }
        if (em->optional && !any) /* (no motion: no plot of it) */
            cJSON_DeleteItemFromObject(metrics, em->name);
    }
    cJSON_AddItemToObject(root, "settings", set ? set : cJSON_CreateObject());
    txt = cJSON_PrintUnformatted(root);
    if (!txt) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
        goto fail;
    }
    ev_text js = {0};
    ev_text_add(&js, "var TND_REPORT = %s;\n", txt);
    snprintf(path, sizeof path, "%s/report.js", dir);
    res = js.failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory")
                    : tnd_file_write_atomic(path, js.s, js.len);
    ev_text_free(&js);
fail:
    cJSON_Delete(root);
    free(txt);
    ev_image_free(&ref);
    for (uint32_t i = 0; i < ns; i++)
        ev_image_free(&img[i]);
    free(tr), free(tm), free(map), free(col), free(small);
    return res;
}

void rn_metrics_json(cJSON *o, const ev_summary *s)
{
    for (uint32_t k = 0; k < ev_metric_count(); k++)
        if (ev_metric_at(k)->summarised)
            cJSON_AddNumberToObject(o, ev_metric_at(k)->name, ev_metric_summary(ev_metric_at(k), s));
}


/* The spread of FLIP between the series at frame index k (the largest minus the smallest). */
static double flip_spread(const rn_eval *e, uint32_t k)
{
    double lo = INFINITY, hi = -INFINITY;
    for (uint32_t i = 0; i < e->nseries; i++) {
        lo = fmin(lo, e->series[i].m[k].flip);
        hi = fmax(hi, e->series[i].m[k].flip);
    }
    return e->nseries ? hi - lo : 0;
}

/* The c x c box (on a grid of c/4) where the series' FLIP box sums differ most (the largest
 * minus the smallest), frame f; tr: the reference tone-mapped. */
static tnd_result spread_centre(rn_eval *e, uint32_t f, const float *tr, uint32_t c, uint32_t *cx,
                                uint32_t *cy)
{
    uint32_t w = e->width, h = e->height, ns = e->nseries, step = c / 4 ? c / 4 : 1;
    size_t n = (size_t)w * h;
    float *maps = malloc(n * ns * sizeof(float)), *tm = malloc(n * 3 * sizeof(float));
    ev_image img = {0};
    tnd_result res = maps && tm ? TND_OK : tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
    for (uint32_t i = 0; i < ns && res == TND_OK; i++) {
        double mean;
        if ((res = load(e, &e->series[i], f, &img, NULL, NULL)) != TND_OK)
            break;
        ev_tonemap(&img, e->exposure, tm);
        res = ev_flip(tr, tm, w, h, e->ppd, maps + i * n, &mean);
        ev_image_free(&img);
    }
    double best = -1;
    for (uint32_t y = 0; res == TND_OK && y + c <= h; y += step)
        for (uint32_t x = 0; x + c <= w; x += step) {
            double lo = INFINITY, hi = -INFINITY;
            for (uint32_t i = 0; i < ns; i++) {
                double sum = 0;
                for (uint32_t yy = y; yy < y + c; yy++)
                    for (uint32_t xx = x; xx < x + c; xx++)
                        sum += maps[i * n + (size_t)yy * w + xx];
                lo = fmin(lo, sum), hi = fmax(hi, sum);
            }
            if (hi - lo > best)
                best = hi - lo, *cx = x, *cy = y;
        }
    free(maps);
    free(tm);
    return res;
}

tnd_result rn_eval_report(rn_eval *e, const char *dir, const char *title, const char *settings,
                           const char *html)
{
    tnd_result res = TND_OK;
    uint32_t w = e->width, h = e->height, ns = e->nseries;
    size_t n = (size_t)w * h;
    ev_series series[RN_EVAL_MAX_SERIES];
    char *regions[RN_EVAL_MAX_SERIES] = {0};
    for (uint32_t i = 0; i < ns; i++) {
        regions[i] = rn_eval_regions_json(e, i);
        series[i] = (ev_series){e->series[i].name, e->series[i].m, e->series[i].summary, regions[i]};
    }
    float *tm = NULL, *tr = NULL, *tmp = NULL, *map = NULL, *cr = NULL;
    ev_image img = {0}, ref = {0};
    ev_row *rows = NULL;
    TND_TRY(tnd_mkdirs(dir));
    TND_TRY(ev_write_metrics(dir, series, ns, e->count, settings));
    enum { MAX_PLOTS = 16 };
    char plot_names[MAX_PLOTS][40];
    const char *plots[MAX_PLOTS];
    uint32_t nplots = 0;
    for (uint32_t k = 0; k < ev_metric_count() && nplots < MAX_PLOTS; k++) {
        const ev_metric *em = ev_metric_at(k);
        if (!em->plotted)
            continue;
        snprintf(plot_names[nplots], sizeof plot_names[nplots], "plot_%s.svg", em->name);
        plots[nplots] = plot_names[nplots];
        char path[1400];
        snprintf(path, sizeof path, "%s/%s", dir, plot_names[nplots]);
        TND_TRY(ev_plot_metric(path, em->name, series, ns, e->count));
        nplots++;
    }
    /* frames shown: the first, the one with the worst FLIP of the first series (crop_spread:
     * the largest spread of FLIP between the series), the last */
    uint32_t pick[3], npick = 0, worst = 0;
    for (uint32_t k = 0; k < e->count; k++)
        if (e->crop_spread ? flip_spread(e, k) > flip_spread(e, worst)
                           : ns && e->series[0].m[k].flip > e->series[0].m[worst].flip)
            worst = k;
    const uint32_t cand[3] = {0, worst, e->count - 1};
    for (int c = 0; c < 3; c++) {
        bool dup = false;
        for (uint32_t j = 0; j < npick; j++)
            dup |= pick[j] == cand[c];
        if (!dup)
            pick[npick++] = cand[c];
    }
    rows = calloc(2 * npick, sizeof *rows);
    tm = malloc(n * 3 * sizeof(float));
    tr = malloc(n * 3 * sizeof(float));
    tmp = malloc(n * 3 * sizeof(float));
    map = malloc(n * sizeof(float));
    uint32_t c = w < h ? w : h;
    c = c / 4 < 16 ? (c < 16 ? c : 16) : c / 4;
    uint32_t scale = (192 + c - 1) / c;
    scale = scale < 1 ? 1 : scale > 8 ? 8 : scale;
    cr = malloc((size_t)c * scale * c * scale * 3 * sizeof(float));
    if (!rows || !tm || !tr || !tmp || !map || !cr) {
        res = tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory");
        goto fail;
    }
    uint32_t nrows = 0, shown = w >= 240 ? w : w * ((240 + w - 1) / w);
    for (uint32_t p = 0; p < npick; p++) {
        uint32_t k = pick[p], f = e->frames[k];
        ev_row *row = &rows[nrows++], *crow = &rows[nrows++];
        snprintf(row->title, sizeof row->title, "Frame %u%s", f,
                 k != worst || !ns       ? ""
                 : e->crop_spread ? " (where the series differ most in FLIP)"
                                  : " (the worst FLIP of the first series)");
        TND_TRY(load(e, NULL, f, &ref, NULL, NULL));
        ev_tonemap(&ref, e->exposure, tr);
        snprintf(row->panels[row->count].file, sizeof row->panels[0].file, "f%04u_reference.png", f);
        row->panels[row->count].caption = "reference";
        row->panels[row->count].display_width = shown;
        TND_TRY(png(dir, row->panels[row->count++].file, tr, w, h));
        /* crop centre: the largest 16x16 box sum of the first series' FLIP (crop_spread: the
         * largest spread of the series' box sums) */
        uint32_t cx = 0, cy = 0;
        if (e->crop_spread && ns > 1)
            TND_TRY(spread_centre(e, f, tr, c, &cx, &cy));
        for (uint32_t i = 0; i < ns; i++) {
            TND_TRY(load(e, &e->series[i], f, &img, NULL, NULL));
            ev_tonemap(&img, e->exposure, tm);
            double mean;
            TND_TRY(ev_flip(tr, tm, w, h, e->ppd, map, &mean));
            ev_panel *pn = &row->panels[row->count++];
            snprintf(pn->file, sizeof pn->file, "f%04u_s%u.png", f, i);
            pn->caption = e->series[i].name;
            pn->display_width = shown;
            TND_TRY(png(dir, pn->file, tm, w, h));
            for (size_t q = 0; q < n * 3; q++)
                tmp[q] = fminf(1.0f, 4.0f * fabsf(tm[q] - tr[q]));
            pn = &row->panels[row->count++];
            snprintf(pn->file, sizeof pn->file, "f%04u_s%u_diff.png", f, i);
            pn->caption = "|difference| x4 (tone-mapped)";
            pn->display_width = shown;
            TND_TRY(png(dir, pn->file, tmp, w, h));
            ev_colormap(map, n, tmp);
            pn = &row->panels[row->count++];
            snprintf(pn->file, sizeof pn->file, "f%04u_s%u_flip.png", f, i);
            pn->caption = "FLIP error";
            pn->display_width = shown;
            TND_TRY(png(dir, pn->file, tmp, w, h));
            if (i == 0 && !(e->crop_spread && ns > 1)) {
                double best = -1;
                for (uint32_t y = 0; y + c <= h; y += c / 4 ? c / 4 : 1)
                    for (uint32_t x = 0; x + c <= w; x += c / 4 ? c / 4 : 1) {
                        double sum = 0;
                        for (uint32_t yy = y; yy < y + c; yy++)
                            for (uint32_t xx = x; xx < x + c; xx++)
                                sum += map[(size_t)yy * w + xx];
                        if (sum > best)
                            best = sum, cx = x, cy = y;
                    }
            }
            /* crops of this series (the reference's below, after the loop) */
            crop(tm, w, cx, cy, c, scale, cr);
            pn = &crow->panels[crow->count + 1 + i];
            snprintf(pn->file, sizeof pn->file, "f%04u_s%u_crop.png", f, i);
            pn->caption = e->series[i].name;
            TND_TRY(png(dir, pn->file, cr, c * scale, c * scale));
            ev_image_free(&img);
        }
        snprintf(crow->title, sizeof crow->title, "Frame %u, crop %ux%u at (%u, %u), x%u", f, c, c,
                 cx, cy, scale);
        crop(tr, w, cx, cy, c, scale, cr);
        snprintf(crow->panels[0].file, sizeof crow->panels[0].file, "f%04u_reference_crop.png", f);
        crow->panels[0].caption = "reference";
        TND_TRY(png(dir, crow->panels[0].file, cr, c * scale, c * scale));
        crow->count = 1 + ns;
        ev_image_free(&ref);
    }
    TND_TRY(write_viewer(e, dir, title, settings));
    ev_text page = {0}; /* the way to the viewer first, then the caller's sections */
    ev_text_add(&page, "<p><b><a href=\"viewer.html\">Watch every frame</a></b>: a scrubber, "
                       "play/pause, A/B swipe and side by side with linked zoom, exposure, error "
                       "and FLIP maps per frame, plots linked to the frames.</p>\n%s",
                html ? html : "");
    res = page.failed ? tnd_fail(TND_ERR_OUT_OF_MEMORY, "eval: out of memory")
                      : ev_report_write(&(ev_report){.dir = dir, .title = title,
                                                     .settings = settings, .series = series,
                                                     .nseries = ns, .plots = plots, .nplots = nplots,
                                                     .rows = rows, .nrows = nrows,
                                                     .html = page.s});
    ev_text_free(&page);
fail:
    for (uint32_t i = 0; i < ns; i++)
        free(regions[i]);
    ev_image_free(&img);
    ev_image_free(&ref);
    free(rows);
    free(tm);
    free(tr);
    free(tmp);
    free(map);
    free(cr);
    return res;
}
