/* examples/plugins/spheres.c: a Tandem front-end plugin (include/tandem/tandem_plugin.h) that
 * traces an analytic scene on the CPU: a few spheres on a large ground sphere under a sky and a
 * sun with a soft disk. It fills the contract's host buffers: the G-buffer, motion vectors from
 * the two cameras, and a noisy direct diffuse signal (one sample of the sun's disk and one of
 * the sky per pixel). It needs nothing of Tandem but the header.
 *
 * The scene is laid out in front of the first frame's camera, so that it suits the camera path
 * of whatever --scene is given (the scene's geometry itself is not used).
 *
 *     tandem render --scene data/scenes/dynamic.gltf --frontend plugin:build/plugins/spheres.so \
 *         --denoiser svgf --out out/spheres */
#include <tandem/tandem_plugin.h>

#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define N_SPHERES 5
#define PI 3.14159265358979f
#define MISS 1.0e30f

typedef struct sphere {
    float c[3], r;
    float albedo[3];
} sphere;

typedef struct state {
    bool placed;
    sphere s[N_SPHERES];
    float sun_dir[3]; /* towards the sun */
} state;

static float dot3(const float a[3], const float b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void normalize3(float v[3])
{
    float l = sqrtf(dot3(v, v));
    for (int k = 0; k < 3; k++)
        v[k] /= l;
}

static void cross3(const float a[3], const float b[3], float out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* Two unit vectors a, b completing unit w to an orthonormal basis. */
static void basis(const float w[3], float a[3], float b[3])
{
    const float helper[3] = {fabsf(w[0]) > 0.5f ? 0.0f : 1.0f, fabsf(w[0]) > 0.5f ? 1.0f : 0.0f,
                             0.0f};
    cross3(helper, w, a);
    normalize3(a);
    cross3(w, a, b);
}

/* A hash of (frame, pixel, sample, dimension) to [0, 1): the random numbers differ per frame and
 * per matched-reference sample, and repeat for the same key. */
static float rnd(uint32_t frame, uint32_t pixel, uint32_t sample, uint32_t dim)
{
    uint32_t h = frame * 0x9E3779B9u ^ pixel * 0x85EBCA6Bu ^ sample * 0xC2B2AE35u ^ dim * 0x27D4EB2Fu;
    h ^= h >> 16;
    h *= 0x7FEB352Du;
    h ^= h >> 15;
    h *= 0x846CA68Bu;
    h ^= h >> 16;
    return (float)(h >> 8) * (1.0f / 16777216.0f);
}

/* The nearest sphere hit along o + t d beyond t_min: its index and t, or -1. */
static int trace(const state *st, const float o[3], const float d[3], float t_min, float *t_hit)
{
    int best = -1;
    float tb = MISS;
    for (int i = 0; i < N_SPHERES; i++) {
        const sphere *s = &st->s[i];
        float oc[3] = {o[0] - s->c[0], o[1] - s->c[1], o[2] - s->c[2]};
        float b = dot3(oc, d), c = dot3(oc, oc) - s->r * s->r, disc = b * b - c;
        if (disc < 0)
            continue;
        float q = sqrtf(disc), t = -b - q;
        if (t <= t_min)
            t = -b + q;
        if (t > t_min && t < tb) {
            tb = t;
            best = i;
        }
    }
    *t_hit = tb;
    return best;
}

static void sky(const float d[3], float out[3])
{
    float up = d[1] > 0 ? d[1] : 0;
    out[0] = 0.25f + 0.35f * up;
    out[1] = 0.35f + 0.40f * up;
    out[2] = 0.55f + 0.55f * up;
}

/* Place the spheres in front of the first camera: the ground below it, the others on the
 * ground along its view direction. */
static void place(state *st, const tandem_frame_settings *fs)
{
    const float *V = fs->view;
    float fwd[3] = {-V[2], -V[6], -V[10]}; /* the camera's -Z row of the rotation */
    fwd[1] = 0;
    if (dot3(fwd, fwd) < 1e-6f)
        fwd[2] = -1;
    normalize3(fwd);
    float right[3] = {-fwd[2], 0, fwd[0]};
    const float *p = fs->camera_position;
    float ground_y = p[1] - 1.5f, R = 1000.0f;
    st->s[0] = (sphere){{p[0], ground_y - R, p[2]}, R, {0.6f, 0.6f, 0.55f}};
    const float at[N_SPHERES - 1][3] = {
        {5.0f, 0.0f, 1.0f}, {6.5f, -1.6f, 0.7f}, {7.5f, 1.8f, 0.9f}, {4.0f, 1.3f, 0.4f}};
    const float alb[N_SPHERES - 1][3] = {
        {0.8f, 0.2f, 0.15f}, {0.2f, 0.7f, 0.25f}, {0.2f, 0.3f, 0.8f}, {0.85f, 0.8f, 0.3f}};
    for (int i = 1; i < N_SPHERES; i++) {
        float dist = at[i - 1][0], side = at[i - 1][1], r = at[i - 1][2];
        sphere *s = &st->s[i];
        for (int k = 0; k < 3; k++)
            s->c[k] = p[k] + fwd[k] * dist + right[k] * side;
        s->c[1] = ground_y + r;
        s->r = r;
        memcpy(s->albedo, alb[i - 1], sizeof s->albedo);
    }
    float sun[3] = {0.4f * right[0] - 0.5f * fwd[0], 0.8f, 0.4f * right[2] - 0.5f * fwd[2]};
    normalize3(sun);
    memcpy(st->sun_dir, sun, sizeof sun);
    st->placed = true;
}

/* The pixel position of world point x through a camera (unjittered), false behind it. */
static int project(const float V[16], const float P[16], const float x[3], uint32_t w, uint32_t h,
                   float px[2])
{
    float v[4], clip[4];
    for (int r = 0; r < 4; r++)
        v[r] = V[r] * x[0] + V[4 + r] * x[1] + V[8 + r] * x[2] + V[12 + r];
    for (int r = 0; r < 4; r++)
        clip[r] = P[r] * v[0] + P[4 + r] * v[1] + P[8 + r] * v[2] + P[12 + r] * v[3];
    if (clip[3] <= 1e-6f)
        return 0;
    px[0] = (clip[0] / clip[3] * 0.5f + 0.5f) * (float)w;
    px[1] = (clip[1] / clip[3] * 0.5f + 0.5f) * (float)h;
    return 1;
}

static int sp_create(const tandem_frontend_create_info *info, void **out, char *err,
                     uint32_t cap)
{
    (void)info;
    state *st = calloc(1, sizeof *st);
    if (!st) {
        snprintf(err, cap, "out of memory");
        return 1;
    }
    *out = st;
    return 0;
}

static void sp_destroy(void *s)
{
    free(s);
}

static int sp_render(void *ctx, const tandem_frame_settings *fs, tandem_host_frame *f, char *err,
                     uint32_t cap)
{
    state *st = ctx;
    if (fs->width != f->width || fs->height != f->height) {
        snprintf(err, cap, "frame %ux%u, settings %ux%u", f->width, f->height, fs->width,
                 fs->height);
        return 1;
    }
    if (!st->placed)
        place(st, fs);
    const float *V = fs->view, *P = fs->proj;
    const float sun_radiance = 3.0f, sun_cos_max = 0.9990f; /* about 2.6 degrees across */
    float *albedo = f->entries[TANDEM_ENTRY_ALBEDO], *normal = f->entries[TANDEM_ENTRY_NORMAL];
    float *depth = f->entries[TANDEM_ENTRY_DEPTH], *motion = f->entries[TANDEM_ENTRY_MOTION];
    float *hf = f->entries[TANDEM_ENTRY_HF], *emission = f->entries[TANDEM_ENTRY_EMISSION];
    uint32_t *vis = f->entries[TANDEM_ENTRY_VIS_ID], *rng = f->entries[TANDEM_ENTRY_RNG];
    for (uint32_t y = 0; y < fs->height; y++)
        for (uint32_t x = 0; x < fs->width; x++) {
            uint32_t q = y * fs->width + x;
            /* the ray through the jittered pixel position: camera space, then world */
            float nx = ((float)x + 0.5f + fs->jitter[0]) / (float)fs->width * 2.0f - 1.0f;
            float ny = ((float)y + 0.5f + fs->jitter[1]) / (float)fs->height * 2.0f - 1.0f;
            float dc[3] = {nx / P[0], ny / P[5], -1.0f}, d[3];
            for (int k = 0; k < 3; k++) /* the inverse rotation: the transpose */
                d[k] = V[k * 4 + 0] * dc[0] + V[k * 4 + 1] * dc[1] + V[k * 4 + 2] * dc[2];
            normalize3(d);
            const float *o = fs->camera_position;
            float t;
            int i = trace(st, o, d, 1e-4f, &t);
            rng[2 * q] = fs->frame_index;
            rng[2 * q + 1] = q;
            memset(motion + 3 * q, 0, 3 * sizeof(float));
            memset(hf + 3 * q, 0, 3 * sizeof(float));
            if (i < 0) {
                sky(d, emission + 3 * q);
                depth[q] = MISS;
                vis[2 * q] = vis[2 * q + 1] = 0xFFFFFFFFu;
                memset(albedo + 3 * q, 0, 3 * sizeof(float));
                memcpy(normal + 3 * q, (float[3]){-d[0], -d[1], -d[2]}, 3 * sizeof(float));
                continue;
            }
            const sphere *s = &st->s[i];
            float hit[3], n[3];
            for (int k = 0; k < 3; k++) {
                hit[k] = o[k] + t * d[k];
                n[k] = (hit[k] - s->c[k]) / s->r;
            }
            if (dot3(n, d) > 0) /* facing the ray */
                for (int k = 0; k < 3; k++)
                    n[k] = -n[k];
            memcpy(albedo + 3 * q, s->albedo, sizeof s->albedo);
            memcpy(normal + 3 * q, n, sizeof n);
            memset(emission + 3 * q, 0, 3 * sizeof(float));
            depth[q] = t;
            vis[2 * q] = (uint32_t)i;
            vis[2 * q + 1] = 0;
            /* motion: the point through the previous camera (the spheres stand still) */
            float cur[2], prev[2];
            if (project(V, P, hit, fs->width, fs->height, cur) &&
                project(fs->prev_view, fs->prev_proj, hit, fs->width, fs->height, prev)) {
                motion[3 * q] = prev[0] - cur[0];
                motion[3 * q + 1] = prev[1] - cur[1];
            }
            float pv[4]; /* the previous camera's distance to the point */
            for (int r = 0; r < 3; r++)
                pv[r] = fs->prev_view[r] * hit[0] + fs->prev_view[4 + r] * hit[1] +
                        fs->prev_view[8 + r] * hit[2] + fs->prev_view[12 + r];
            motion[3 * q + 2] = sqrtf(pv[0] * pv[0] + pv[1] * pv[1] + pv[2] * pv[2]) - t;
            /* direct diffuse, demodulated (E / pi): one direction in the sun's cone, one
             * cosine-weighted sky direction, each with a shadow ray */
            uint32_t smp = fs->sample;
            float u1 = rnd(fs->frame_index, q, smp, 0), u2 = rnd(fs->frame_index, q, smp, 1);
            float ct = 1.0f - u1 * (1.0f - sun_cos_max), stt = sqrtf(1.0f - ct * ct);
            float a[3], b[3], L[3];
            const float *w = st->sun_dir;
            basis(w, a, b);
            for (int k = 0; k < 3; k++)
                L[k] = w[k] * ct + (a[k] * cosf(2 * PI * u2) + b[k] * sinf(2 * PI * u2)) * stt;
            float cosn = dot3(n, L), th;
            float solid = 2 * PI * (1.0f - sun_cos_max);
            float e = 0;
            if (cosn > 0 && trace(st, hit, L, 1e-3f * (1.0f + t), &th) < 0)
                e = sun_radiance * solid * cosn; /* the cone's irradiance, one sample */
            for (int k = 0; k < 3; k++)
                hf[3 * q + k] = e / PI;
            /* the sky: cosine-weighted, so that E / pi = the sky's radiance where it is seen */
            float v1 = rnd(fs->frame_index, q, smp, 2), v2 = rnd(fs->frame_index, q, smp, 3);
            float r = sqrtf(v1), phi = 2 * PI * v2, na[3], nb[3];
            basis(n, na, nb);
            float sd[3], zz = sqrtf(fmaxf(0.0f, 1.0f - v1));
            for (int k = 0; k < 3; k++)
                sd[k] = na[k] * r * cosf(phi) + nb[k] * r * sinf(phi) + n[k] * zz;
            if (trace(st, hit, sd, 1e-3f * (1.0f + t), &th) < 0) {
                float sk[3];
                sky(sd, sk);
                for (int k = 0; k < 3; k++)
                    hf[3 * q + k] += sk[k];
            }
        }
    return 0;
}

static const tandem_frontend_plugin frontend = {
    .struct_size = sizeof frontend,
    .writes = TANDEM_ENTRIES_REQUIRED | TANDEM_ENTRY_BIT(TANDEM_ENTRY_EMISSION) |
              TANDEM_ENTRY_BIT(TANDEM_ENTRY_VIS_ID) | TANDEM_ENTRY_BIT(TANDEM_ENTRY_RNG),
    .create = sp_create,
    .destroy = sp_destroy,
    .render = sp_render,
};

static const tandem_plugin plugin = {
    .struct_size = sizeof plugin,
    .abi_version = TANDEM_PLUGIN_ABI_VERSION,
    .kind = TANDEM_PLUGIN_FRONTEND,
    .name = "spheres",
    .description = "analytic spheres under a sun and sky, traced on the CPU",
    .frontend = &frontend,
};

__attribute__((visibility("default"))) const tandem_plugin *tandem_plugin_entry(uint32_t abi)
{
    return abi == TANDEM_PLUGIN_ABI_VERSION ? &plugin : NULL;
}
